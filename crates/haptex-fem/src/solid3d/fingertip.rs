//! The 3D fingertip's mesh: the lower cap of an ellipsoidal fingertip,
//! from the skin to the distal phalanx, in the 2D model's layers (stratum
//! corneum, viable epidermis and dermis of constant thickness along the
//! skin's normal, the hypodermis filling to the bone).
//!
//! Frame: x across the finger (the 2D model's cross-section is the x-z
//! plane), y along it, z up (towards the nail); the pad's lowest point at
//! the origin. The skin is the ellipsoid of
//! half-axes (a_x, a_y, a_z) centred at (0, 0, a_z); the bone the
//! ellipsoid of half-axes (b_x, b_y, b_z) centred at (0, 0, c_b).
//!
//! The cap is a structured block of hexahedra: its surface is the image of
//! the square (xi, eta) in [-1, 1]^2 under the gnomonic map of a cube's
//! bottom face (direction (tan(xi Phi), tan(eta Phi), -1) from the
//! ellipsoid's centre, as a cubed sphere's face), graded towards the pad's
//! centre; through the thickness each surface point is joined to the bone
//! along the same direction from the bone's centre. The cap's four side
//! faces and the bone face are the boundary the rigid bone drives (the
//! tissue beyond the cap is not modelled: Phi sets how far the cap
//! reaches, 60 degrees by default, well beyond the contact patches of
//! screen exploration).

use super::mesh::{Mesh3, MeshError, Side};
use crate::finger::{FingerModel, Resolution};

/// The fingertip's shape, layers and mesh resolution.
#[derive(Debug, Clone, PartialEq)]
pub struct FingertipSpec {
    /// Skin ellipsoid half-axes across, along and through the finger (mm).
    pub skin_half_axes_mm: [f64; 3],
    /// Bone ellipsoid half-axes (mm) and the height of its centre (mm).
    pub bone_half_axes_mm: [f64; 3],
    pub bone_center_height_mm: f64,
    /// Stratum corneum, viable epidermis and dermis thicknesses (mm).
    pub layers_mm: [f64; 3],
    /// Half-angle of the cap seen from the skin's centre (degrees).
    pub cap_half_angle_deg: f64,
    /// Elements along xi and along eta (each even: the pad's centre is a
    /// node).
    pub surface_divisions: usize,
    /// The surface spacing at the centre over the one at the cap's edge.
    pub surface_grading: f64,
    /// Element rows in each skin layer and in the hypodermis.
    pub rows: [usize; 4],
}

/// The fingertip's half-length along the finger (mm): the distal pad is
/// about 20 mm long (assumed; the 2D model has no length).
pub const SKIN_HALF_LENGTH_MM: f64 = 10.0;
/// The distal phalanx's half-length inside the cap (mm, assumed).
pub const BONE_HALF_LENGTH_MM: f64 = 4.0;

/// The material index of each layer (element_material of the body).
pub const STRATUM_CORNEUM: usize = 0;
pub const VIABLE_EPIDERMIS: usize = 1;
pub const DERMIS: usize = 2;
pub const HYPODERMIS: usize = 3;

/// A fingertip's mesh: the hexahedra, each element's layer, the nodes the
/// bone drives, and the skin's faces.
#[derive(Debug, Clone)]
pub struct FingertipMesh {
    pub mesh: Mesh3,
    /// Layer of each element ([`STRATUM_CORNEUM`] ..= [`HYPODERMIS`]).
    pub element_layer: Vec<usize>,
    /// Nodes on the bone and on the cap's sides (driven with the bone).
    pub driven_nodes: Vec<usize>,
    /// The skin's faces (4 nodes each, outward normal down at the pad).
    pub skin_faces: Vec<[usize; 4]>,
}

/// A fingertip that cannot be meshed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FingertipError {
    #[error("{field} = {value}: {why}")]
    Value { field: &'static str, value: f64, why: &'static str },
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

impl FingertipSpec {
    /// An index fingertip: [`FingertipSpec::from_model`] of the shipped
    /// 2D finger (data/finger/finger-2d.toml) at the default mesh.
    pub fn index_finger() -> Self {
        Self::from_model(&FingerModel::default_model(), Resolution::Default)
    }

    /// The fingertip of a 2D finger model: its cross-section (the skin's
    /// half-width and half-height, the bone's, the bone's height, the
    /// three skin layers) with a half-length of
    /// [`SKIN_HALF_LENGTH_MM`] along the finger and the bone's of
    /// [`BONE_HALF_LENGTH_MM`]; the mesh of `resolution`:
    ///
    /// | resolution | surface divisions | grading | rows (SC, VE, dermis, hypodermis) |
    /// |---|---|---|---|
    /// | coarse | 12 | 3 | 1, 1, 1, 3 |
    /// | default | 24 | 4 | 1, 1, 2, 6 |
    /// | fine | 36 | 5 | 1, 1, 3, 8 |
    /// | extra-fine | 48 | 6 | 1, 1, 4, 10 |
    pub fn from_model(model: &FingerModel, resolution: Resolution) -> Self {
        let g = &model.geometry;
        let l = &model.layers;
        let (surface_divisions, surface_grading, rows) = match resolution {
            Resolution::Coarse => (12, 3.0, [1, 1, 1, 3]),
            Resolution::Default => (24, 4.0, [1, 1, 2, 6]),
            Resolution::Fine => (36, 5.0, [1, 1, 3, 8]),
            Resolution::ExtraFine => (48, 6.0, [1, 1, 4, 10]),
        };
        Self {
            skin_half_axes_mm: [g.half_width_mm, SKIN_HALF_LENGTH_MM, g.half_height_mm],
            bone_half_axes_mm: [g.bone_half_width_mm, BONE_HALF_LENGTH_MM, g.bone_half_height_mm],
            bone_center_height_mm: g.bone_center_height_mm,
            layers_mm: [l.stratum_corneum_mm, l.viable_epidermis_mm, l.dermis_mm],
            cap_half_angle_deg: 60.0,
            surface_divisions,
            surface_grading,
            rows,
        }
    }

    fn check(&self) -> Result<(), FingertipError> {
        let positive = |field: &'static str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(FingertipError::Value { field, value, why: "must be a positive finite number" })
            }
        };
        for (k, &v) in self.skin_half_axes_mm.iter().enumerate() {
            positive(["skin_half_axes_mm[0]", "skin_half_axes_mm[1]", "skin_half_axes_mm[2]"][k], v)?;
        }
        for (k, &v) in self.bone_half_axes_mm.iter().enumerate() {
            positive(["bone_half_axes_mm[0]", "bone_half_axes_mm[1]", "bone_half_axes_mm[2]"][k], v)?;
        }
        for (k, &v) in self.layers_mm.iter().enumerate() {
            positive(["layers_mm[0]", "layers_mm[1]", "layers_mm[2]"][k], v)?;
        }
        positive("surface_grading", self.surface_grading)?;
        let angle = self.cap_half_angle_deg;
        if !(angle.is_finite() && (10.0..=75.0).contains(&angle)) {
            return Err(FingertipError::Value {
                field: "cap_half_angle_deg",
                value: angle,
                why: "must be from 10 to 75 degrees",
            });
        }
        let n = self.surface_divisions;
        if !(2..=200).contains(&n) || !n.is_multiple_of(2) {
            return Err(FingertipError::Value {
                field: "surface_divisions",
                value: n as f64,
                why: "must be even and from 2 to 200",
            });
        }
        if self.rows.iter().any(|&r| !(1..=50).contains(&r)) {
            return Err(FingertipError::Value { field: "rows", value: 0.0, why: "each layer has 1 to 50 rows" });
        }
        // The bone lies inside the skin, under the skin layers.
        let [ax, ay, az] = self.skin_half_axes_mm;
        let [bx, by, bz] = self.bone_half_axes_mm;
        let skin: f64 = self.layers_mm.iter().sum();
        let c = self.bone_center_height_mm;
        if !(c.is_finite() && c - bz > skin && c + bz < 2.0 * az - skin && bx < ax - skin && by < ay - skin) {
            return Err(FingertipError::Value {
                field: "bone_center_height_mm",
                value: c,
                why: "the bone must lie inside the skin, beneath its three layers",
            });
        }
        Ok(())
    }
}

/// Surface parameters from -1 to 1 with `n` cells, graded so that the
/// cells at the ends are `grading` times those at the centre.
fn graded_parameters(n: usize, grading: f64) -> Vec<f64> {
    let half = n / 2;
    // Cell sizes growing geometrically from the centre to the end.
    let ratio = if half > 1 { grading.powf(1.0 / (half - 1) as f64) } else { 1.0 };
    let sizes: Vec<f64> = (0..half).map(|k| ratio.powi(k as i32)).collect();
    let total: f64 = sizes.iter().sum();
    let mut positive = vec![0.0];
    for s in &sizes {
        positive.push(positive.last().unwrap() + s / total);
    }
    *positive.last_mut().unwrap() = 1.0;
    let mut out: Vec<f64> = positive.iter().rev().map(|v| -v).collect();
    out.extend_from_slice(&positive[1..]);
    out
}

/// The point where the ray from `center` along `d` leaves the ellipsoid of
/// half-axes `axes` centred there.
fn on_ellipsoid(center: [f64; 3], axes: [f64; 3], d: [f64; 3]) -> [f64; 3] {
    let t = 1.0 / ((d[0] / axes[0]).powi(2) + (d[1] / axes[1]).powi(2) + (d[2] / axes[2]).powi(2)).sqrt();
    [center[0] + t * d[0], center[1] + t * d[1], center[2] + t * d[2]]
}

/// The outward unit normal of the ellipsoid (`center`, `axes`) at `p`.
fn ellipsoid_normal(center: [f64; 3], axes: [f64; 3], p: [f64; 3]) -> [f64; 3] {
    let g: [f64; 3] = std::array::from_fn(|k| (p[k] - center[k]) / (axes[k] * axes[k]));
    let norm = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
    g.map(|v| v / norm)
}

/// Meshes the fingertip of `spec`.
pub fn mesh(spec: &FingertipSpec) -> Result<FingertipMesh, FingertipError> {
    spec.check()?;
    let s = graded_parameters(spec.surface_divisions, spec.surface_grading);
    // Through the thickness: the grid's z index k runs from the skin (0)
    // to the bone; a placeholder coordinate for the block, replaced below.
    let rows_total: usize = spec.rows.iter().sum();
    let depth: Vec<f64> = (0..=rows_total).map(|k| k as f64).collect();
    let mut mesh = Mesh3::block(&s, &s, &depth)?;
    let skin_center = [0.0, 0.0, spec.skin_half_axes_mm[2]];
    let bone_center = [0.0, 0.0, spec.bone_center_height_mm];
    let phi = spec.cap_half_angle_deg.to_radians();
    // Depth (mm along the inward normal) of each row boundary in the skin
    // layers, and the fraction of the hypodermis for the rest.
    let mut skin_depths = vec![0.0];
    for (layer, &t) in spec.layers_mm.iter().enumerate() {
        let start = *skin_depths.last().unwrap();
        for r in 1..=spec.rows[layer] {
            skin_depths.push(start + t * r as f64 / spec.rows[layer] as f64);
        }
    }
    let skin_rows = skin_depths.len() - 1;
    mesh.map(|[xi, eta, k]| {
        let d = [(xi * phi).tan(), (eta * phi).tan(), -1.0];
        let outer = on_ellipsoid(skin_center, spec.skin_half_axes_mm, d);
        let normal = ellipsoid_normal(skin_center, spec.skin_half_axes_mm, outer);
        let k = k as usize;
        if k <= skin_rows {
            let depth = skin_depths[k];
            return std::array::from_fn(|i| outer[i] - depth * normal[i]);
        }
        // Hypodermis: from the dermis' inner face to the bone, rows
        // spaced geometrically (ratio 1.25) away from the dermis.
        let start: [f64; 3] = std::array::from_fn(|i| outer[i] - skin_depths[skin_rows] * normal[i]);
        let bone = on_ellipsoid(bone_center, spec.bone_half_axes_mm, d);
        let n = spec.rows[3];
        let weights: Vec<f64> = (0..n).map(|r| 1.25f64.powi(r as i32)).collect();
        let total: f64 = weights.iter().sum();
        let f = weights[..k - skin_rows].iter().sum::<f64>() / total;
        std::array::from_fn(|i| start[i] + f * (bone[i] - start[i]))
    });
    // Every element checked now: an inverted one is an error, not a run.
    mesh.geometry()?;
    let element_layer: Vec<usize> = {
        let [nx, ny, _] = mesh.shape;
        let per_row = (nx - 1) * (ny - 1);
        let mut bounds = Vec::new();
        let mut acc = 0;
        for &r in &spec.rows {
            acc += r;
            bounds.push(acc);
        }
        (0..mesh.elements.len())
            .map(|e| bounds.iter().position(|&b| e / per_row < b).expect("row in a layer"))
            .collect()
    };
    let mut driven: Vec<usize> = [Side::XMin, Side::XMax, Side::YMin, Side::YMax, Side::ZMax]
        .into_iter()
        .flat_map(|side| mesh.side_nodes(side))
        .collect();
    driven.sort_unstable();
    driven.dedup();
    let skin_faces = mesh.bottom_faces().into_iter().map(|(_, f)| f).collect();
    Ok(FingertipMesh { mesh, element_layer, driven_nodes: driven, skin_faces })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_skin_is_the_ellipsoid_and_the_layers_their_thickness() {
        let spec = FingertipSpec::index_finger();
        let f = mesh(&spec).unwrap();
        let [ax, ay, az] = spec.skin_half_axes_mm;
        let skin_nodes = f.mesh.side_nodes(Side::ZMin);
        for &n in &skin_nodes {
            let [x, y, z] = f.mesh.nodes[n];
            let level = (x / ax).powi(2) + (y / ay).powi(2) + ((z - az) / az).powi(2);
            assert!((level - 1.0).abs() < 1e-12, "node {n} off the skin: {level}");
        }
        // The pad's lowest point is a node at the origin; above it the
        // layer boundaries at 0.2, 0.325 and 1.325 mm.
        let [nx, ny, _] = f.mesh.shape;
        let centre = nx / 2 + nx * (ny / 2);
        assert!(f.mesh.nodes[centre].iter().all(|v| v.abs() < 1e-12));
        let layer_rows = [1, 2, 4];
        for (row, depth) in layer_rows.iter().zip([0.2, 0.325, 1.325]) {
            let p = f.mesh.nodes[centre + row * nx * ny];
            assert!(p[0].abs() < 1e-12 && p[1].abs() < 1e-12 && (p[2] - depth).abs() < 1e-12, "{p:?}");
        }
        // The last row is on the bone.
        let bottom_of_bone = spec.bone_center_height_mm - spec.bone_half_axes_mm[2];
        let top = *f.mesh.side_nodes(Side::ZMax).iter().find(|&&n| n % (nx * ny) == nx / 2 + nx * (ny / 2)).unwrap();
        assert!((f.mesh.nodes[top][2] - bottom_of_bone).abs() < 1e-12);
        // Layers: one row of stratum corneum, one of viable epidermis, two
        // of dermis, six of hypodermis.
        let per_row = (nx - 1) * (ny - 1);
        let count = |layer| f.element_layer.iter().filter(|&&l| l == layer).count();
        assert_eq!([count(0), count(1), count(2), count(3)], [per_row, per_row, 2 * per_row, 6 * per_row]);
        assert_eq!(f.skin_faces.len(), per_row);
    }

    /// The stratum corneum's volume is its thickness times the cap's area
    /// (to the curvature's first order: the layer is 0.2 mm on radii of
    /// 6 mm and more, 3.5% at most), the cap's area integrated by the
    /// faces' own quadrature.
    #[test]
    fn layer_volume_matches_area_times_thickness() {
        let spec = FingertipSpec::index_finger();
        let f = mesh(&spec).unwrap();
        let geometry = f.mesh.geometry().unwrap();
        let sc: f64 = (0..geometry.len()).filter(|&e| f.element_layer[e] == 0).map(|e| geometry[e].volume).sum();
        let area = super::super::contact::ContactSurface::new(&f.mesh, &f.skin_faces).area();
        let ratio = sc / (area * spec.layers_mm[0]);
        assert!(ratio < 1.0 && ratio > 0.965, "volume over area x thickness: {ratio}");
    }

    #[test]
    fn resolutions_mesh_without_inverted_elements() {
        for (divisions, rows, grading) in [(8, [1, 1, 1, 3], 2.0), (24, [1, 1, 2, 6], 4.0), (48, [2, 1, 4, 9], 6.0)] {
            let spec = FingertipSpec {
                surface_divisions: divisions,
                rows,
                surface_grading: grading,
                ..FingertipSpec::index_finger()
            };
            let f = mesh(&spec).unwrap();
            assert_eq!(f.mesh.elements.len(), divisions * divisions * rows.iter().sum::<usize>());
        }
    }

    #[test]
    fn impossible_fingertips_are_refused() {
        let base = FingertipSpec::index_finger();
        let bad = [
            FingertipSpec { bone_center_height_mm: 1.0, ..base.clone() },
            FingertipSpec { bone_half_axes_mm: [12.0, 3.0, 1.75], ..base.clone() },
            FingertipSpec { layers_mm: [0.2, f64::NAN, 1.0], ..base.clone() },
            FingertipSpec { cap_half_angle_deg: 89.0, ..base.clone() },
            FingertipSpec { surface_divisions: 7, ..base.clone() },
            FingertipSpec { rows: [1, 0, 2, 6], ..base.clone() },
        ];
        for spec in bad {
            assert!(matches!(mesh(&spec), Err(FingertipError::Value { .. })), "{spec:?}");
        }
    }
}
