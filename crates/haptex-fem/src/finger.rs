//! The finger model: geometry, layers and materials read from a TOML file
//! (`data/finger/finger-2d.toml`), and the mesh of its cross-section.
//!
//! Six subdomains as in the paper's Fig. 1b. The soft tissues (stratum
//! corneum, viable epidermis, dermis, hypodermis) are meshed with B-bar
//! quadrilaterals; bone and nail are rigid bodies (their stiffness is 10^3
//! to 10^5 times the tissue's) driven together: the bone is the ring's inner
//! boundary, the nail a band of rigid elements on top.
//!
//! The mesh is a ring (see [`crate::ring`]): rows of nodes follow the outer
//! contour inwards through the skin layers (offset curves), then blend to
//! the bone. Angularly, the pad (the contact region) has the fine spacing,
//! the rest grows smoothly to a coarse spacing; two 3-to-1 transitions in
//! the hypodermis coarsen towards the bone.

use std::path::Path;

use haptex_core::num::Num;
use serde::{Deserialize, Serialize};

use crate::body::SubdomainModel;
use crate::material::{Material, PronyTerm};
use crate::mesh::{Mesh, MeshError};
use crate::ring::{RingSpec, Transition, contour_parameters, mesh_ring};

/// Subdomain indices of the finger mesh.
pub mod subdomain {
    pub const STRATUM_CORNEUM: u8 = 0;
    pub const VIABLE_EPIDERMIS: u8 = 1;
    pub const DERMIS: u8 = 2;
    pub const HYPODERMIS: u8 = 3;
    pub const BONE: u8 = 4;
    pub const NAIL: u8 = 5;
    pub const NAMES: [&str; 6] = ["stratum corneum", "viable epidermis", "dermis", "hypodermis", "bone", "nail"];
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Geometry {
    pub half_width_mm: f64,
    pub half_height_mm: f64,
    pub bone_half_width_mm: f64,
    pub bone_half_height_mm: f64,
    pub bone_center_height_mm: f64,
    pub nail_thickness_mm: f64,
    pub nail_half_angle_deg: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Layers {
    pub stratum_corneum_mm: f64,
    pub viable_epidermis_mm: f64,
    pub dermis_mm: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Materials {
    pub stratum_corneum: Material,
    pub viable_epidermis: Material,
    pub dermis: Material,
    pub hypodermis: Material,
    pub bone: Material,
    pub nail: Material,
}

impl Materials {
    /// Each material with its key in the file.
    pub fn named(&self) -> [(&'static str, &Material); 6] {
        [
            ("stratum_corneum", &self.stratum_corneum),
            ("viable_epidermis", &self.viable_epidermis),
            ("dermis", &self.dermis),
            ("hypodermis", &self.hypodermis),
            ("bone", &self.bone),
            ("nail", &self.nail),
        ]
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Viscoelasticity {
    pub prony: Vec<PronyTerm>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactParameters {
    pub mu_skin: f64,
    pub contact_half_arc_mm: f64,
}

/// A finger model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FingerModel {
    pub geometry: Geometry,
    pub layers: Layers,
    pub materials: Materials,
    pub viscoelasticity: Viscoelasticity,
    pub contact: ContactParameters,
}

/// A field of a finger model that the mesher or the solver cannot take:
/// its name (`contact.contact_half_arc_mm`) and what is wrong, starting with
/// its value (`= 18 is longer than ...`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field} {message}")]
pub struct FieldError {
    /// The field's path in the file: `table.key`, `table.list[i].key`.
    pub field: String,
    pub message: String,
}

/// A finger model file is unreadable or inconsistent.
#[derive(Debug, thiserror::Error)]
pub enum FingerError {
    #[error("{path}: {message}")]
    File { path: String, message: String },
    /// A field out of range, at the line of its key in the file.
    #[error("{path}: line {line}: {error}")]
    Field { path: String, line: usize, error: FieldError },
    /// A field out of range in a model built in code (no file, no line).
    #[error("finger model: {0}")]
    Invalid(FieldError),
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

/// The shipped default model, embedded so the library works anywhere.
pub const DEFAULT_MODEL_TOML: &str = include_str!("../../../data/finger/finger-2d.toml");

/// Largest finger model file read (1 MiB; the shipped one is 3 kB): a bound
/// on the memory a wrong path (`/dev/zero`) can take.
pub const MAX_MODEL_BYTES: u64 = 1 << 20;

/// The accepted range of every number field (inclusive), with its unit.
/// Lengths are bounded so that the mesh and the solver's dense contact
/// system stay within a few hundred MB at the finest mesh; moduli and
/// times so that every product the solver forms stays far from overflow;
/// the rest by what the mesher and solver assume (docs/fem.md, "Finger
/// model file").
pub mod limits {
    /// Half-axes of the outer contour, mm.
    pub const HALF_AXIS_MM: (f64, f64) = (2.0, 20.0);
    /// Half-axes of the bone, mm.
    pub const BONE_HALF_AXIS_MM: (f64, f64) = (0.2, 20.0);
    /// Height of the bone's centre above the pad, mm.
    pub const BONE_CENTER_MM: (f64, f64) = (0.2, 40.0);
    /// Nail thickness, mm (and thinner than the skin).
    pub const NAIL_THICKNESS_MM: (f64, f64) = (0.01, 5.0);
    /// Nail half-angle from the top, degrees (0: no nail).
    pub const NAIL_HALF_ANGLE_DEG: (f64, f64) = (0.0, 90.0);
    /// Each skin layer's thickness, mm.
    pub const LAYER_MM: (f64, f64) = (0.01, 5.0);
    /// Young's modulus, MPa.
    pub const E_MPA: (f64, f64) = (1e-4, 1e6);
    /// Poisson's ratio: up to 0.4999 (the B-bar element is exact there in
    /// the patch test); negative values are accepted down to -0.9.
    pub const NU: (f64, f64) = (-0.9, 0.4999);
    /// Prony weight g_i, and the largest sum of all weights (the long-term
    /// shear modulus keeps at least 1% of the instantaneous one).
    pub const PRONY_G: (f64, f64) = (1e-9, 0.99);
    pub const PRONY_G_SUM: f64 = 0.99;
    /// Prony time constant tau_i, s.
    pub const PRONY_TAU_S: (f64, f64) = (1e-9, 1e9);
    /// Skin-surface friction coefficient.
    pub const MU_SKIN: (f64, f64) = (0.0, 10.0);
    /// Half-arc of the contact region, mm (and ending before the nail).
    pub const CONTACT_HALF_ARC_MM: (f64, f64) = (1.0, 20.0);
    /// Arc of coarse contour the contact region must leave before the nail, mm.
    pub const PAD_TO_NAIL_MM: f64 = 1.0;
    /// Hypodermis the bone must leave above and below it and at its sides, mm.
    pub const HYPODERMIS_MARGIN_MM: f64 = 0.2;
    /// The skin must be thinner than this fraction of the contour's
    /// smallest radius of curvature (offset curves stay regular).
    pub const SKIN_PER_RADIUS: f64 = 0.8;
    /// Smallest sine of the angle between the contour (or the bone) and the
    /// lines that blend the skin's inner face into the bone: below it the
    /// hypodermis elements degenerate.
    pub const BLEND_SINE: f64 = 0.2;
}

/// Checks that `value` is a finite number within `range` (inclusive).
fn in_range(field: &str, value: f64, range: (f64, f64), unit: &str) -> Result<(), FieldError> {
    if value.is_finite() && value >= range.0 && value <= range.1 {
        return Ok(());
    }
    let unit = if unit.is_empty() { String::new() } else { format!(" {unit}") };
    Err(FieldError {
        field: field.to_string(),
        message: format!(
            "= {}{unit} is outside the supported range {} .. {}{unit}",
            haptex_core::num::against(value, &[range.0, range.1]),
            Num(range.0),
            Num(range.1)
        ),
    })
}

fn field_error(field: &str, message: String) -> FieldError {
    FieldError { field: field.to_string(), message }
}

/// The 1-based line of byte `offset` in `text`.
fn line_at(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())].iter().filter(|&&b| b == b'\n').count() + 1
}

/// The line of the key (or list element) `field` (`a.b`, `a.list[2].c`)
/// in the TOML `text`, if the text parses and holds it.
fn line_of_field(text: &str, field: &str) -> Option<usize> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(text).ok()?;
    let mut table: &DeTable<'_> = root.get_ref();
    let mut span = None;
    let mut value: Option<&DeValue<'_>> = None;
    for part in field.split('.') {
        let (name, index) = match part.split_once('[') {
            Some((name, rest)) => (name, Some(rest.strip_suffix(']')?.parse::<usize>().ok()?)),
            None => (part, None),
        };
        if let Some(DeValue::Table(t)) = value {
            table = t;
        } else if value.is_some() {
            return None;
        }
        let (key, v) = table.get_key_value(name)?;
        span = Some(key.span());
        value = Some(v.get_ref());
        if let Some(i) = index {
            let element = match value {
                Some(DeValue::Array(a)) => a.get(i)?,
                _ => return None,
            };
            span = Some(element.span());
            value = Some(element.get_ref());
        }
    }
    span.map(|s| line_at(text, s.start))
}

impl FingerModel {
    /// The shipped model (`data/finger/finger-2d.toml`).
    pub fn default_model() -> Self {
        static MODEL: std::sync::OnceLock<FingerModel> = std::sync::OnceLock::new();
        MODEL
            .get_or_init(|| {
                Self::from_toml(DEFAULT_MODEL_TOML, "data/finger/finger-2d.toml")
                    .expect("the shipped finger model is valid")
            })
            .clone()
    }

    /// Reads a model file (at most [`MAX_MODEL_BYTES`]); errors name the
    /// file, line and field.
    pub fn read(path: &Path) -> Result<Self, FingerError> {
        use std::io::Read;
        let file_error = |message: String| FingerError::File { path: path.display().to_string(), message };
        let file = std::fs::File::open(path).map_err(|e| file_error(e.to_string()))?;
        let mut bytes = Vec::new();
        file.take(MAX_MODEL_BYTES + 1).read_to_end(&mut bytes).map_err(|e| file_error(e.to_string()))?;
        if bytes.len() as u64 > MAX_MODEL_BYTES {
            return Err(file_error(format!(
                "longer than {MAX_MODEL_BYTES} bytes (a finger model is a short TOML file; is this the right file?)"
            )));
        }
        let text = String::from_utf8(bytes).map_err(|e| {
            let bytes = e.as_bytes();
            let at = e.utf8_error().valid_up_to();
            file_error(format!("line {}: not UTF-8 text", bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1))
        })?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// Parses and validates a model; `source` labels errors, which name the
    /// line and the field.
    pub fn from_toml(text: &str, source: &str) -> Result<Self, FingerError> {
        let model: Self = toml::from_str(text).map_err(|e| {
            let message = e.message().trim_end().to_string();
            FingerError::File {
                path: source.to_string(),
                message: match e.span() {
                    Some(span) => format!("line {}: {message}", line_at(text, span.start)),
                    None => message,
                },
            }
        })?;
        model.validate().map_err(|error| match line_of_field(text, &error.field) {
            Some(line) => FingerError::Field { path: source.to_string(), line, error },
            None => FingerError::File { path: source.to_string(), message: error.to_string() },
        })?;
        Ok(model)
    }

    /// Checks every field against what the mesher and the solver support
    /// ([`limits`]), then that the model meshes at every resolution; the
    /// error names the first field out of range.
    pub fn validate(&self) -> Result<(), FieldError> {
        self.validate_fields()?;
        self.validate_meshes()
    }

    /// Each field within its range of [`limits`].
    fn validate_ranges(&self) -> Result<(), FieldError> {
        use limits::*;

        let g = &self.geometry;
        let l = &self.layers;
        let lengths = [
            ("geometry.half_width_mm", g.half_width_mm, HALF_AXIS_MM),
            ("geometry.half_height_mm", g.half_height_mm, HALF_AXIS_MM),
            ("geometry.bone_half_width_mm", g.bone_half_width_mm, BONE_HALF_AXIS_MM),
            ("geometry.bone_half_height_mm", g.bone_half_height_mm, BONE_HALF_AXIS_MM),
            ("geometry.bone_center_height_mm", g.bone_center_height_mm, BONE_CENTER_MM),
            ("geometry.nail_thickness_mm", g.nail_thickness_mm, NAIL_THICKNESS_MM),
            ("layers.stratum_corneum_mm", l.stratum_corneum_mm, LAYER_MM),
            ("layers.viable_epidermis_mm", l.viable_epidermis_mm, LAYER_MM),
            ("layers.dermis_mm", l.dermis_mm, LAYER_MM),
            ("contact.contact_half_arc_mm", self.contact.contact_half_arc_mm, CONTACT_HALF_ARC_MM),
        ];
        for (field, value, range) in lengths {
            in_range(field, value, range, "mm")?;
        }
        in_range("geometry.nail_half_angle_deg", g.nail_half_angle_deg, NAIL_HALF_ANGLE_DEG, "degrees")?;
        in_range("contact.mu_skin", self.contact.mu_skin, MU_SKIN, "")?;
        for (name, m) in self.materials.named() {
            in_range(&format!("materials.{name}.e_mpa"), m.e_mpa, E_MPA, "MPa")?;
            in_range(&format!("materials.{name}.nu"), m.nu, NU, "")?;
            if !m.prony.is_empty() {
                return Err(field_error(
                    &format!("materials.{name}.prony"),
                    "is not read here: the Prony series of all soft tissues is [viscoelasticity] prony".into(),
                ));
            }
        }
        let prony = &self.viscoelasticity.prony;
        if prony.len() > crate::material::MAX_PRONY_TERMS {
            return Err(field_error(
                "viscoelasticity.prony",
                format!("has {} terms; at most {} are supported", prony.len(), crate::material::MAX_PRONY_TERMS),
            ));
        }
        for (i, term) in prony.iter().enumerate() {
            in_range(&format!("viscoelasticity.prony[{i}].g"), term.g, PRONY_G, "")?;
            in_range(&format!("viscoelasticity.prony[{i}].tau_s"), term.tau_s, PRONY_TAU_S, "s")?;
        }
        let total: f64 = prony.iter().map(|t| t.g).sum();
        if total > PRONY_G_SUM {
            let last = prony.len() - 1;
            return Err(field_error(
                &format!("viscoelasticity.prony[{last}].g"),
                format!(
                    "= {} brings the sum of the Prony weights to {}; it must be at most {} (the long-term shear \
                     modulus is 1 - sum g of the instantaneous one)",
                    Num(prony[last].g),
                    Num(total),
                    Num(PRONY_G_SUM)
                ),
            ));
        }
        Ok(())
    }

    /// The fields and the checks between them, without meshing (for
    /// [`FingerModel::mesh`], which meshes anyway, and for a quick check).
    pub fn validate_fields(&self) -> Result<(), FieldError> {
        self.validate_ranges()?;
        self.validate_shape()
    }

    /// Every resolution meshes with positive Jacobians: the final word on
    /// the bone's position and shape (the blend check of `validate_shape`
    /// tests the continuous map; a coarse mesh can still fold near a
    /// sharply curved bone).
    fn validate_meshes(&self) -> Result<(), FieldError> {
        for resolution in Resolution::ALL {
            if let Err(e) = self.mesh_validated(resolution) {
                let hint = if matches!(e, MeshError::Inverted { .. }) {
                    ": the hypodermis between the bone and the skin folds; move the bone towards the finger's \
                     centre, or make it smaller or rounder"
                } else {
                    ""
                };
                let resolution = resolution.name();
                return Err(field_error(
                    "geometry",
                    format!("cannot be meshed at the {resolution} resolution ({e}){hint}"),
                ));
            }
        }
        Ok(())
    }

    /// The checks that involve several fields: skin against curvature, nail
    /// against skin, bone inside the pulp, contact region against the nail.
    fn validate_shape(&self) -> Result<(), FieldError> {
        use limits::*;
        let g = &self.geometry;
        let l = &self.layers;
        let skin = self.skin_thickness_mm();
        let (a, b) = (g.half_width_mm, g.half_height_mm);
        let min_radius = a.min(b).powi(2) / a.max(b);
        if skin >= SKIN_PER_RADIUS * min_radius {
            return Err(field_error(
                "layers.dermis_mm",
                format!(
                    "= {} makes the skin (stratum corneum + viable epidermis + dermis = {} mm) too thick for the \
                     contour: it must be thinner than {} mm ({} of the contour's smallest radius of curvature, {} mm)",
                    Num(l.dermis_mm),
                    Num(skin),
                    Num(SKIN_PER_RADIUS * min_radius),
                    Num(SKIN_PER_RADIUS),
                    Num(min_radius)
                ),
            ));
        }
        if g.nail_thickness_mm >= skin {
            return Err(field_error(
                "geometry.nail_thickness_mm",
                format!(
                    "= {} mm must be thinner than the skin (stratum corneum + viable epidermis + dermis = {} mm)",
                    Num(g.nail_thickness_mm),
                    Num(skin)
                ),
            ));
        }
        // The bone inside the skin's inner face, with hypodermis around it.
        let margin = HYPODERMIS_MARGIN_MM;
        let room = 2.0 * b - 2.0 * skin - 2.0 * margin;
        if 2.0 * g.bone_half_height_mm > room {
            return Err(field_error(
                "geometry.bone_half_height_mm",
                format!(
                    "= {} mm is too tall for the finger: the bone must leave the skin and {margin} mm of hypodermis \
                     above and below it (at most {} mm here)",
                    Num(g.bone_half_height_mm),
                    Num(0.5 * room.max(0.0))
                ),
            ));
        }
        let (lowest, highest) =
            (skin + margin + g.bone_half_height_mm, 2.0 * b - skin - margin - g.bone_half_height_mm);
        if g.bone_center_height_mm < lowest || g.bone_center_height_mm > highest {
            return Err(field_error(
                "geometry.bone_center_height_mm",
                format!(
                    "= {} mm puts the bone into the skin: with the skin and {margin} mm of hypodermis above and below \
                     it, its centre must lie between {} and {} mm",
                    Num(g.bone_center_height_mm),
                    Num(lowest),
                    Num(highest)
                ),
            ));
        }
        let widest = a - skin - margin;
        if g.bone_half_width_mm > widest {
            return Err(field_error(
                "geometry.bone_half_width_mm",
                format!(
                    "= {} mm is too wide for the finger: the bone must leave the skin and {margin} mm of hypodermis \
                     at its sides (at most {} mm here)",
                    Num(g.bone_half_width_mm),
                    Num(widest)
                ),
            ));
        }
        if let Some(phi) = self.degenerate_blend_angle() {
            return Err(field_error(
                "geometry.bone_center_height_mm",
                format!(
                    "= {} mm: the bone's size and position leave no room to mesh the hypodermis between it and the \
                     skin near {} degrees from the pad's lowest point (the blend lines there run almost along the \
                     contour or the bone); move the bone towards the centre of the finger or make it smaller",
                    Num(g.bone_center_height_mm),
                    Num(phi.to_degrees().round())
                ),
            ));
        }
        // The contact region ends on the free skin before the nail.
        let nail_start = std::f64::consts::PI - g.nail_half_angle_deg.to_radians();
        let available = self.contour_arc_mm(nail_start) - PAD_TO_NAIL_MM;
        let longest = available.min(CONTACT_HALF_ARC_MM.1);
        if longest < CONTACT_HALF_ARC_MM.0 {
            return Err(field_error(
                "geometry.nail_half_angle_deg",
                format!(
                    "= {} degrees leaves {} mm of contour between the pad's lowest point and the nail; the contact \
                     region needs at least {} mm plus {} mm before the nail",
                    Num(g.nail_half_angle_deg),
                    Num(available + PAD_TO_NAIL_MM),
                    Num(CONTACT_HALF_ARC_MM.0),
                    Num(PAD_TO_NAIL_MM)
                ),
            ));
        }
        if self.contact.contact_half_arc_mm > longest {
            return Err(field_error(
                "contact.contact_half_arc_mm",
                format!(
                    "= {} mm is longer than the contour allows (at most {} mm for this contour: the contact region \
                     must end {} mm of arc before the nail, which covers the top {} degrees)",
                    Num(self.contact.contact_half_arc_mm),
                    Num((longest * 1000.0).floor() / 1000.0),
                    Num(PAD_TO_NAIL_MM),
                    Num(2.0 * g.nail_half_angle_deg)
                ),
            ));
        }
        Ok(())
    }

    /// Arc length of the outer contour from the pad's lowest point to
    /// ellipse parameter `phi` (Simpson's rule, 1e-9 relative).
    fn contour_arc_mm(&self, phi: f64) -> f64 {
        let (a, b) = (self.geometry.half_width_mm, self.geometry.half_height_mm);
        let speed = |p: f64| (a * p.cos()).hypot(b * p.sin());
        let n = 2000;
        let h = phi / n as f64;
        let inner: f64 = (1..n).map(|i| if i % 2 == 1 { 4.0 } else { 2.0 } * speed(i as f64 * h)).sum();
        h / 3.0 * (speed(0.0) + inner + speed(phi))
    }

    /// Where the hypodermis cannot be meshed, if anywhere: the parameter phi
    /// at which a line blending the skin's inner face I(phi) into the bone
    /// B(phi) (the mesh's radial lines, see [`FingerModel::map`]) runs
    /// within asin(BLEND_SINE) of the tangent of either curve. The map
    /// (1 - rho) I + rho B has the Jacobian det[(1 - rho) I' + rho B', B - I],
    /// linear in rho, so it is positive on the whole line if it is at both
    /// ends.
    fn degenerate_blend_angle(&self) -> Option<f64> {
        let skin = self.skin_thickness_mm();
        let inner = |phi: f64| self.map(phi, skin);
        let g = &self.geometry;
        let n = 3600;
        (0..n).map(|i| std::f64::consts::TAU * i as f64 / n as f64).find(|&phi| {
            let p = inner(phi);
            let q = self.bone(phi);
            let d = [q[0] - p[0], q[1] - p[1]];
            let h = 1e-6;
            let (p1, p0) = (inner(phi + h), inner(phi - h));
            let tangent_inner = [(p1[0] - p0[0]) / (2.0 * h), (p1[1] - p0[1]) / (2.0 * h)];
            let tangent_bone = [g.bone_half_width_mm * phi.cos(), g.bone_half_height_mm * phi.sin()];
            let sine = |t: [f64; 2]| (t[0] * d[1] - t[1] * d[0]) / (t[0].hypot(t[1]) * d[0].hypot(d[1]));
            let (s_inner, s_bone) = (sine(tangent_inner), sine(tangent_bone));
            !(s_inner >= limits::BLEND_SINE && s_bone >= limits::BLEND_SINE)
        })
    }

    /// Total thickness of stratum corneum, viable epidermis and dermis.
    pub fn skin_thickness_mm(&self) -> f64 {
        self.layers.stratum_corneum_mm + self.layers.viable_epidermis_mm + self.layers.dermis_mm
    }

    /// The constitutive model of each subdomain (indices of [`subdomain`]),
    /// elastic or with the model's Prony series on the soft tissues.
    pub fn subdomain_models(&self, viscoelastic: bool) -> Vec<SubdomainModel> {
        let soft = |m: &Material| {
            let mut m = m.clone();
            m.prony = if viscoelastic { self.viscoelasticity.prony.clone() } else { Vec::new() };
            SubdomainModel::Deformable(m)
        };
        vec![
            soft(&self.materials.stratum_corneum),
            soft(&self.materials.viable_epidermis),
            soft(&self.materials.dermis),
            soft(&self.materials.hypodermis),
            SubdomainModel::Rigid,
            SubdomainModel::Rigid,
        ]
    }
}

/// A nail face within this distance of a skin row ends on that row, mm.
const NAIL_ROW_SNAP_MM: f64 = 1e-3;

/// Mesh resolution presets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Resolution {
    Coarse,
    Default,
    Fine,
    /// Half the fine mesh's pad spacing: for convergence studies and the
    /// sharpest features (a 2D run costs about 5 times the fine mesh's).
    #[serde(rename = "extra-fine")]
    ExtraFine,
}

/// The numbers behind a resolution preset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResolutionParameters {
    /// Node spacing along the pad surface (the contact region), mm.
    pub pad_spacing_mm: f64,
    /// Largest node spacing elsewhere on the contour, mm.
    pub coarse_spacing_mm: f64,
    /// Element rows in stratum corneum, viable epidermis, dermis.
    pub skin_rows: [usize; 3],
    /// Element rows in the hypodermis.
    pub hypodermis_rows: usize,
}

impl Resolution {
    pub const ALL: [Resolution; 4] = [Resolution::Coarse, Resolution::Default, Resolution::Fine, Resolution::ExtraFine];

    /// The name the CLI's `--mesh` and a database's metadata use.
    pub fn name(self) -> &'static str {
        match self {
            Resolution::Coarse => "coarse",
            Resolution::Default => "default",
            Resolution::Fine => "fine",
            Resolution::ExtraFine => "extra-fine",
        }
    }

    pub fn parameters(self) -> ResolutionParameters {
        match self {
            Resolution::Coarse => ResolutionParameters {
                pad_spacing_mm: 0.2,
                coarse_spacing_mm: 0.8,
                skin_rows: [1, 1, 2],
                hypodermis_rows: 6,
            },
            Resolution::Default => ResolutionParameters {
                pad_spacing_mm: 0.1,
                coarse_spacing_mm: 0.4,
                skin_rows: [2, 1, 4],
                hypodermis_rows: 9,
            },
            Resolution::Fine => ResolutionParameters {
                pad_spacing_mm: 0.05,
                coarse_spacing_mm: 0.3,
                skin_rows: [3, 2, 5],
                hypodermis_rows: 12,
            },
            Resolution::ExtraFine => ResolutionParameters {
                pad_spacing_mm: 0.025,
                coarse_spacing_mm: 0.2,
                skin_rows: [5, 3, 8],
                hypodermis_rows: 16,
            },
        }
    }
}

/// The meshed finger.
#[derive(Debug, Clone)]
pub struct FingerMesh {
    pub mesh: Mesh,
    /// Nodes of the rigid bone and nail, driven together.
    pub driven_nodes: Vec<usize>,
    /// Outer-contour segments (node pairs in contour order) that may touch
    /// the surface: the pad region.
    pub contact_segments: Vec<[usize; 2]>,
    /// Outer-contour nodes outside the pad region (checked for stray contact).
    pub other_surface_nodes: Vec<usize>,
}

impl FingerModel {
    /// Point of the outer contour at ellipse parameter phi (0 = lowest
    /// point, counter-clockwise), and its outward unit normal.
    fn contour(&self, phi: f64) -> ([f64; 2], [f64; 2]) {
        let (a, b) = (self.geometry.half_width_mm, self.geometry.half_height_mm);
        let p = [a * phi.sin(), b - b * phi.cos()];
        let n = [b * phi.sin(), -a * phi.cos()];
        let len = n[0].hypot(n[1]);
        (p, [n[0] / len, n[1] / len])
    }

    fn bone(&self, phi: f64) -> [f64; 2] {
        let g = &self.geometry;
        [g.bone_half_width_mm * phi.sin(), g.bone_center_height_mm - g.bone_half_height_mm * phi.cos()]
    }

    /// Position at (phi, t): t in [0, skin] is the depth below the contour;
    /// t in [skin, skin + 1] blends from the skin's inner face to the bone.
    fn map(&self, phi: f64, t: f64) -> [f64; 2] {
        let skin = self.skin_thickness_mm();
        let (p, n) = self.contour(phi);
        let depth = t.min(skin);
        let inner = [p[0] - depth * n[0], p[1] - depth * n[1]];
        if t <= skin {
            return inner;
        }
        let rho = t - skin;
        let b = self.bone(phi);
        [(1.0 - rho) * inner[0] + rho * b[0], (1.0 - rho) * inner[1] + rho * b[1]]
    }

    /// Meshes the finger at `resolution`.
    /// The model is validated first (a model built in code has not been
    /// through [`FingerModel::from_toml`]).
    pub fn mesh(&self, resolution: Resolution) -> Result<FingerMesh, FingerError> {
        self.validate_fields().map_err(FingerError::Invalid)?;
        Ok(self.mesh_validated(resolution)?)
    }

    /// Meshes a model whose fields have been checked.
    fn mesh_validated(&self, resolution: Resolution) -> Result<FingerMesh, MeshError> {
        let r = resolution.parameters();
        let contour = |phi: f64| self.contour(phi).0;
        let (phis, n_fine) =
            contour_parameters(&contour, self.contact.contact_half_arc_mm, r.pad_spacing_mm, r.coarse_spacing_mm)?;
        let l = &self.layers;
        let skin = self.skin_thickness_mm();
        // Skin rows: each layer split evenly, plus the nail's inner face.
        let mut rows = vec![0.0];
        let mut top = 0.0;
        for (thickness, n) in [l.stratum_corneum_mm, l.viable_epidermis_mm, l.dermis_mm].into_iter().zip(r.skin_rows) {
            for k in 1..=n {
                rows.push(top + thickness * k as f64 / n as f64);
            }
            top += thickness;
        }
        // The nail's inner face is a row of its own, unless a row lies within
        // 1 um of it (then the nail ends there: no sliver of elements thinner
        // than 1 um).
        let nail = self.geometry.nail_thickness_mm;
        if rows.iter().all(|&t| (t - nail).abs() > NAIL_ROW_SNAP_MM) {
            rows.push(nail);
            rows.sort_by(f64::total_cmp);
        }
        let skin_rows = rows.len();
        // Hypodermis rows: geometric growth (ratio 1.25) towards the bone.
        let ratio: f64 = 1.25;
        let n_h = r.hypodermis_rows;
        let denominator = ratio.powi(n_h as i32) - 1.0;
        for k in 1..=n_h {
            rows.push(skin + (ratio.powi(k as i32) - 1.0) / denominator);
        }
        let transitions = vec![
            Transition { after_row: skin_rows, range: None },
            Transition { after_row: skin_rows + 2, range: Some((0, n_fine / 3)) },
        ];
        let nail_half = self.geometry.nail_half_angle_deg.to_radians();
        let (sc, ve) = (l.stratum_corneum_mm, l.stratum_corneum_mm + l.viable_epidermis_mm);
        let classify = |phi: f64, t: f64| {
            let from_top = (phi.rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI).abs();
            if t < nail && from_top < nail_half {
                subdomain::NAIL
            } else if t < sc {
                subdomain::STRATUM_CORNEUM
            } else if t < ve {
                subdomain::VIABLE_EPIDERMIS
            } else if t < skin {
                subdomain::DERMIS
            } else {
                subdomain::HYPODERMIS
            }
        };
        let map = |phi: f64, t: f64| self.map(phi, t);
        let ring = mesh_ring(&RingSpec { map: &map, phis, rows, transitions, subdomain: &classify })?;
        let mesh = ring.mesh;
        let mut driven = mesh.nodes_of_subdomains(|s| s == subdomain::NAIL);
        driven.extend_from_slice(&mesh.inner);
        driven.sort_unstable();
        driven.dedup();
        // The contact region is free skin (validate() keeps it off the nail).
        if let Some(k) = (0..=n_fine).find(|&k| driven.binary_search(&mesh.outer[k]).is_ok()) {
            return Err(MeshError::Generation(format!(
                "contact node {k} (mesh node {}) belongs to the rigid nail: the contact region overlaps the nail",
                mesh.outer[k]
            )));
        }
        let contact_segments = (0..n_fine).map(|k| [mesh.outer[k], mesh.outer[k + 1]]).collect();
        let other_surface_nodes = mesh.outer[n_fine + 1..].to_vec();
        Ok(FingerMesh { mesh, driven_nodes: driven, contact_segments, other_surface_nodes })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_model_meshes_at_every_resolution() {
        let model = FingerModel::default_model();
        for resolution in Resolution::ALL {
            let finger = model.mesh(resolution).unwrap();
            let m = &finger.mesh;
            let geometry = m.geometry().unwrap();
            let quality = m.quality(&geometry);
            eprintln!(
                "{resolution:?}: {} nodes, {} elements, {} contact segments, aspect {:.1}, jacobian ratio {:.2}",
                m.n_nodes(),
                m.n_elements(),
                finger.contact_segments.len(),
                quality.max_aspect_ratio,
                quality.min_jacobian_ratio
            );
            // Pad spacing at most the preset's (issue 3: ~0.1 mm at default).
            let spacing = resolution.parameters().pad_spacing_mm;
            for [a, b] in &finger.contact_segments {
                let d = crate::mesh::distance(m.nodes[*a], m.nodes[*b]);
                assert!(d <= 1.05 * spacing, "{resolution:?}: segment {d} mm");
            }
            // Every subdomain but the (unmeshed) bone has elements.
            for s in [0, 1, 2, 3, 5] {
                assert!(m.subdomain.contains(&s), "{resolution:?}: subdomain {s} empty");
            }
            // The lowest contour point is at y = 0 and inside the pad region.
            let lowest = m.outer.iter().map(|&n| m.nodes[n][1]).fold(f64::INFINITY, f64::min);
            assert!(lowest.abs() < 1e-9);
        }
        let default = model.mesh(Resolution::Default).unwrap();
        assert!((2500..=3600).contains(&default.mesh.n_nodes()), "{} nodes", default.mesh.n_nodes());
    }

    /// The name a database's metadata records is the one it is read back
    /// by and the CLI's `--mesh` takes (clap's kebab-case of the variant).
    #[test]
    fn resolution_names_are_the_serialized_ones() {
        for resolution in Resolution::ALL {
            assert_eq!(serde_json::to_value(resolution).unwrap(), resolution.name());
            // haptex-core's table of spacings (which gratings a database's mesh resolves).
            assert_eq!(
                haptex_core::crests::pad_spacing_mm(resolution.name()),
                Some(resolution.parameters().pad_spacing_mm)
            );
        }
        assert_eq!(Resolution::ExtraFine.name(), "extra-fine");
    }

    #[test]
    fn model_file_errors_name_line_and_field() {
        let text = DEFAULT_MODEL_TOML.replace("half_width_mm = 8.0", "half_width_mm = \"wide\"");
        let err = FingerModel::from_toml(&text, "f.toml").unwrap_err().to_string();
        assert!(err.starts_with("f.toml: line 15"), "{err}");
        let text = DEFAULT_MODEL_TOML.replace("dermis_mm = 1.0", "dermis_mm = -1.0");
        let err = FingerModel::from_toml(&text, "f.toml").unwrap_err().to_string();
        assert!(err.contains("line 35: layers.dermis_mm = -1 mm is outside the supported range"), "{err}");
        let text = DEFAULT_MODEL_TOML.replace("[contact]", "[contact]\nspeed = 3");
        let err = FingerModel::from_toml(&text, "f.toml").unwrap_err().to_string();
        assert!(err.contains("unknown field"), "{err}");
    }
}
