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

/// A finger model file is unreadable or inconsistent.
#[derive(Debug, thiserror::Error)]
pub enum FingerError {
    #[error("{path}: {message}")]
    File { path: String, message: String },
    #[error("finger model: {0}")]
    Invalid(String),
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

/// The shipped default model, embedded so the library works anywhere.
pub const DEFAULT_MODEL_TOML: &str = include_str!("../../../data/finger/finger-2d.toml");

impl FingerModel {
    /// The shipped model (`data/finger/finger-2d.toml`).
    pub fn default_model() -> Self {
        Self::from_toml(DEFAULT_MODEL_TOML, "data/finger/finger-2d.toml").expect("the shipped finger model is valid")
    }

    /// Reads a model file; errors name the file, line and field.
    pub fn read(path: &Path) -> Result<Self, FingerError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| FingerError::File { path: path.display().to_string(), message: e.to_string() })?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// Parses and validates a model; `source` labels errors.
    pub fn from_toml(text: &str, source: &str) -> Result<Self, FingerError> {
        let model: Self = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| text[..s.start].lines().count().max(1));
            let message = e.message().to_string();
            FingerError::File {
                path: source.to_string(),
                message: match line {
                    Some(l) => format!("line {l}: {message}"),
                    None => message,
                },
            }
        })?;
        model.validate().map_err(|m| FingerError::File { path: source.to_string(), message: m })?;
        Ok(model)
    }

    fn validate(&self) -> Result<(), String> {
        let g = &self.geometry;
        let l = &self.layers;
        let positive = [
            ("geometry.half_width_mm", g.half_width_mm),
            ("geometry.half_height_mm", g.half_height_mm),
            ("geometry.bone_half_width_mm", g.bone_half_width_mm),
            ("geometry.bone_half_height_mm", g.bone_half_height_mm),
            ("geometry.bone_center_height_mm", g.bone_center_height_mm),
            ("geometry.nail_thickness_mm", g.nail_thickness_mm),
            ("geometry.nail_half_angle_deg", g.nail_half_angle_deg),
            ("layers.stratum_corneum_mm", l.stratum_corneum_mm),
            ("layers.viable_epidermis_mm", l.viable_epidermis_mm),
            ("layers.dermis_mm", l.dermis_mm),
            ("contact.contact_half_arc_mm", self.contact.contact_half_arc_mm),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} must be positive, got {v}"));
            }
        }
        if !(self.contact.mu_skin.is_finite() && self.contact.mu_skin >= 0.0) {
            return Err(format!("contact.mu_skin must be >= 0, got {}", self.contact.mu_skin));
        }
        let skin = self.skin_thickness_mm();
        // The bone must sit inside the skin layers with room for the hypodermis.
        let margin = 0.2;
        if g.bone_center_height_mm - g.bone_half_height_mm < skin + margin
            || g.bone_center_height_mm + g.bone_half_height_mm > 2.0 * g.half_height_mm - skin - margin
            || g.bone_half_width_mm > g.half_width_mm - skin - margin
        {
            return Err("the bone does not fit inside the skin layers with room for the hypodermis".into());
        }
        if g.nail_thickness_mm >= skin {
            return Err(format!("geometry.nail_thickness_mm must be thinner than the skin layers ({skin} mm)"));
        }
        if g.nail_half_angle_deg >= 90.0 {
            return Err("geometry.nail_half_angle_deg must be below 90".into());
        }
        let min_radius = g.half_height_mm.min(g.half_width_mm).powi(2) / g.half_width_mm.max(g.half_height_mm);
        if skin >= 0.8 * min_radius {
            return Err("the skin layers are too thick for the contour's curvature".into());
        }
        let materials = [
            ("stratum_corneum", &self.materials.stratum_corneum),
            ("viable_epidermis", &self.materials.viable_epidermis),
            ("dermis", &self.materials.dermis),
            ("hypodermis", &self.materials.hypodermis),
            ("bone", &self.materials.bone),
            ("nail", &self.materials.nail),
        ];
        for (name, m) in materials {
            m.validate().map_err(|e| format!("materials.{name}: {e}"))?;
        }
        let visco = Material { e_mpa: 1.0, nu: 0.3, prony: self.viscoelasticity.prony.clone() };
        visco.validate().map_err(|e| format!("viscoelasticity: {e}"))?;
        Ok(())
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

/// Mesh resolution presets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Resolution {
    Coarse,
    Default,
    Fine,
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
    pub fn mesh(&self, resolution: Resolution) -> Result<FingerMesh, FingerError> {
        let r = resolution.parameters();
        let contour = |phi: f64| self.contour(phi).0;
        let (phis, n_fine) =
            contour_parameters(&contour, self.contact.contact_half_arc_mm, r.pad_spacing_mm, r.coarse_spacing_mm);
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
        let nail = self.geometry.nail_thickness_mm;
        if rows.iter().all(|&t| (t - nail).abs() > 1e-6) {
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
        for resolution in [Resolution::Coarse, Resolution::Default, Resolution::Fine] {
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

    #[test]
    fn model_file_errors_name_line_and_field() {
        let text = DEFAULT_MODEL_TOML.replace("half_width_mm = 8.0", "half_width_mm = \"wide\"");
        let err = FingerModel::from_toml(&text, "f.toml").unwrap_err().to_string();
        assert!(err.starts_with("f.toml: line 15"), "{err}");
        let text = DEFAULT_MODEL_TOML.replace("dermis_mm = 1.0", "dermis_mm = -1.0");
        let err = FingerModel::from_toml(&text, "f.toml").unwrap_err().to_string();
        assert!(err.contains("layers.dermis_mm must be positive"), "{err}");
        let text = DEFAULT_MODEL_TOML.replace("[contact]", "[contact]\nspeed = 3");
        let err = FingerModel::from_toml(&text, "f.toml").unwrap_err().to_string();
        assert!(err.contains("unknown field"), "{err}");
    }
}
