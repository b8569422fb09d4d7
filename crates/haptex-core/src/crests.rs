//! Which gratings a 2D finger mesh resolves: the sharpest crest its FE
//! profile converges on.
//!
//! A sine grating h = r_h sin(2 pi x / r_w) has crests of radius
//! R = r_w^2 / (4 pi^2 r_h). Where R is under a few of the pad's node
//! spacings, the skin's elements cannot wrap a crest, and the friction
//! profile depends on the mesh, not only on the grating. Measured on the 30
//! random sine members of `haptex db validate --seed 1` (2026-12-07,
//! docs/database.md, "The sine's sharp crests"), the fine mesh's profile
//! against one of half the spacing (extra-fine), relative to the profile's
//! range: 0-6% where R >= 5 spacings (15 members), 11-20% where R is 1.5
//! to 4 spacings (9), 38-79% below 1 spacing (6). Against a mesh of a quarter
//! of the spacing, the extra-fine mesh was within 1.7-1.9% at R = 7 and 12
//! of its spacings and 13.5% at R = 3: the bound scales with the spacing.

use crate::num::Num;

/// A crest radius of at least this many pad node spacings is resolved: the
/// profile is within about 6% of its range of a mesh twice as fine.
pub const RESOLVED_SPACINGS: f64 = 5.0;

/// The 2D finger's meshes and their pads' node spacings (mm), as the FE
/// model's presets define them (a test in haptex-fem keeps the two
/// equal), finest last.
const MESHES: [(&str, f64); 4] = [("coarse", 0.2), ("default", 0.1), ("fine", 0.05), ("extra-fine", 0.025)];

/// The pad's node spacing (mm) of the 2D finger's named mesh.
pub fn pad_spacing_mm(mesh: &str) -> Option<f64> {
    MESHES.iter().find(|(name, _)| *name == mesh).map(|&(_, h)| h)
}

/// The smallest crest radius (mm) the named mesh resolves:
/// [`RESOLVED_SPACINGS`] of its pad spacings.
pub fn resolved_radius_mm(mesh: &str) -> Option<f64> {
    pad_spacing_mm(mesh).map(|h| RESOLVED_SPACINGS * h)
}

/// The crest radius (mm) of a sine grating of period `period_mm` and
/// amplitude `amplitude_mm` (both positive): r_w^2 / (4 pi^2 r_h).
pub fn sine_crest_radius_mm(period_mm: f64, amplitude_mm: f64) -> f64 {
    period_mm * period_mm / (4.0 * std::f64::consts::PI * std::f64::consts::PI * amplitude_mm.abs())
}

/// A grating whose crests a mesh does not resolve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unresolved {
    /// The crests' radius (mm).
    pub radius_mm: f64,
    /// The mesh's name and the smallest radius it resolves (mm).
    pub mesh: &'static str,
    pub resolved_mm: f64,
}

/// Whether the sine of period `period_mm` and amplitude `amplitude_mm` is
/// resolved by `mesh`: `None` if it is (or the mesh is unknown, or the
/// grating flat), else what is missing.
pub fn unresolved_sine(mesh: &str, period_mm: f64, amplitude_mm: f64) -> Option<Unresolved> {
    let &(mesh, spacing) = MESHES.iter().find(|(name, _)| *name == mesh)?;
    let resolved_mm = RESOLVED_SPACINGS * spacing;
    let radius_mm = sine_crest_radius_mm(period_mm, amplitude_mm);
    (amplitude_mm != 0.0 && radius_mm.is_finite() && radius_mm < resolved_mm).then_some(Unresolved {
        radius_mm,
        mesh,
        resolved_mm,
    })
}

impl Unresolved {
    /// The coarsest mesh that resolves these crests, if any does.
    pub fn resolving_mesh(&self) -> Option<(&'static str, f64)> {
        MESHES.into_iter().find(|&(_, h)| self.radius_mm >= RESOLVED_SPACINGS * h)
    }

    /// In a sentence, with what resolves the crests (a `haptex simulate`
    /// mesh and step, or that no mesh of haptex's does).
    pub fn describe(&self) -> String {
        let then = match self.resolving_mesh() {
            Some((mesh, spacing)) => {
                format!("`haptex simulate --mesh {mesh} --step {}` resolves them", Num(spacing / 4.0))
            }
            None => {
                let (finest, spacing) = MESHES[MESHES.len() - 1];
                format!(
                    "no mesh of haptex's resolves them (the finest, {finest}, resolves crests of radius {} mm and more)",
                    Num(RESOLVED_SPACINGS * spacing)
                )
            }
        };
        format!(
            "the grating's crests (radius {} mm) are sharper than the {} mesh resolves ({} pad node spacings, {} mm): \
             its FE profile depends on the mesh there (on random sines such crests moved it by 11-79% of its range \
             against a mesh of half the spacing; docs/database.md, \"The sine's sharp crests\"); {then}",
            Num(round3(self.radius_mm)),
            self.mesh,
            Num(RESOLVED_SPACINGS),
            Num(self.resolved_mm)
        )
    }
}

fn round3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crest_radius_is_the_sines_curvature_radius() {
        // h'' = -r_h (2 pi / r_w)^2 at a crest, where h' = 0.
        let (r_w, r_h) = (0.6105, 0.4093);
        let k = r_h * (std::f64::consts::TAU / r_w).powi(2);
        assert!((sine_crest_radius_mm(r_w, r_h) - 1.0 / k).abs() < 1e-15);
        assert!((sine_crest_radius_mm(r_w, r_h) - 0.02307).abs() < 1e-5);
    }

    #[test]
    fn resolution_follows_the_mesh_spacing() {
        // The worst member of seed 1: R = 0.026 mm, beyond every mesh.
        let u = unresolved_sine("fine", 0.6996, 0.4824).unwrap();
        assert_eq!((u.mesh, u.resolved_mm), ("fine", 0.25));
        assert_eq!(u.resolving_mesh(), None);
        assert_eq!(resolved_radius_mm("fine"), Some(0.25));
        assert!(u.describe().contains("no mesh of haptex's resolves them"), "{}", u.describe());
        // R = 0.179 mm: unresolved on the fine mesh, resolved on the extra-fine one.
        let u = unresolved_sine("fine", 1.7153, 0.4168).unwrap();
        assert_eq!(u.resolving_mesh(), Some(("extra-fine", 0.025)));
        assert!(u.describe().contains("`haptex simulate --mesh extra-fine --step 0.00625`"), "{}", u.describe());
        assert_eq!(unresolved_sine("extra-fine", 1.7153, 0.4168), None);
        // R = 0.295 mm: resolved on the fine mesh, not on the default one.
        assert_eq!(unresolved_sine("fine", 1.5683, 0.2114), None);
        assert_eq!(unresolved_sine("default", 1.5683, 0.2114).unwrap().resolving_mesh(), Some(("fine", 0.05)));
        // A flat "grating" and an unknown mesh say nothing.
        assert_eq!(unresolved_sine("fine", 1.0, 0.0), None);
        assert_eq!(unresolved_sine("hexahedral", 0.5, 0.5), None);
    }
}
