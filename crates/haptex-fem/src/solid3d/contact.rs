//! Contact points of a 3D body's skin: the 2x2 Gauss points of each
//! bilinear face, with their reference positions and areas (the 2D
//! model's Gauss-point-to-surface scheme, one dimension up), and their
//! gaps to a rigid plane z = z_plane below the body.
//!
//! Small strain: positions and areas are the reference ones, the gap is
//! the vertical distance of the displaced point to the plane.

use super::mesh::Mesh3;

/// The most parts a face's contact points may be spread over along each
/// of its directions ([`ContactSurface::with_composite_rule`],
/// [`crate::scenario::Scenario::contact_parts`]): 8 x 8 parts of 4 x 4
/// points, 1 024 points a face.
pub const MAX_CONTACT_PARTS: usize = 8;

/// A face's corners in its parameter square, in order around it.
const CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// The bilinear shape functions of a face's four nodes at (r, s).
fn bilinear(r: f64, s: f64) -> [f64; 4] {
    CORNERS.map(|[a, b]| 0.25 * (1.0 + a * r) * (1.0 + b * s))
}

/// One contact point: on a face of four nodes, the shape-function values
/// at the point, its reference position (mm) and its area weight (mm^2).
#[derive(Debug, Clone, PartialEq)]
pub struct ContactPoint {
    pub nodes: [usize; 4],
    pub shape: [f64; 4],
    pub position: [f64; 3],
    pub weight: f64,
}

impl ContactPoint {
    /// The point's displacement (mm) for global displacements `u` (3 per
    /// node), interpolated from its face's nodes.
    pub fn displacement(&self, u: &[f64]) -> [f64; 3] {
        std::array::from_fn(|d| (0..4).map(|a| self.shape[a] * u[3 * self.nodes[a] + d]).sum())
    }
}

/// The contact points of a set of faces.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactSurface {
    pub points: Vec<ContactPoint>,
    /// Points per face (face f has points f * per_face ..).
    pub per_face: usize,
}

impl ContactSurface {
    /// The 2x2 Gauss points of each face (4 nodes, in order around it).
    pub fn new(mesh: &Mesh3, faces: &[[usize; 4]]) -> Self {
        Self::with_rule(mesh, faces, 2)
    }

    /// The n x n Gauss-Legendre points of each face (n from 1 to 4), in
    /// rows of the face's first direction.
    pub fn with_rule(mesh: &Mesh3, faces: &[[usize; 4]], n: usize) -> Self {
        Self::with_composite_rule(mesh, faces, n, 1)
    }

    /// The composite rule: each face's parameter square cut into `parts` x
    /// `parts` equal squares (1 to [`MAX_CONTACT_PARTS`]), n x n Gauss-Legendre points in each
    /// (n from 1 to 4): the points `parts` times closer together, for a
    /// surface whose crests are sharper than the faces. In rows of the
    /// face's first direction, over the whole face.
    pub fn with_composite_rule(mesh: &Mesh3, faces: &[[usize; 4]], n: usize, parts: usize) -> Self {
        let (gauss, gauss_weights) = crate::contact::gauss_legendre(n.clamp(1, 4));
        let parts = parts.clamp(1, MAX_CONTACT_PARTS);
        let h = 1.0 / parts as f64;
        let (abscissae, weights): (Vec<f64>, Vec<f64>) = (0..parts)
            .flat_map(|p| {
                let centre = -1.0 + h * (2 * p + 1) as f64;
                gauss.iter().zip(&gauss_weights).map(move |(&g, &w)| (centre + h * g, h * w))
            })
            .unzip();
        let mut points = Vec::with_capacity(abscissae.len() * abscissae.len() * faces.len());
        for face in faces {
            let x = face.map(|n| mesh.nodes[n]);
            for (j, &gs) in abscissae.iter().enumerate() {
                for (i, &gr) in abscissae.iter().enumerate() {
                    let shape = bilinear(gr, gs);
                    let dr = CORNERS.map(|[r, s]| 0.25 * r * (1.0 + s * gs));
                    let ds = CORNERS.map(|[r, s]| 0.25 * s * (1.0 + r * gr));
                    let mut position = [0.0; 3];
                    let (mut tr, mut ts) = ([0.0; 3], [0.0; 3]);
                    for a in 0..4 {
                        for k in 0..3 {
                            position[k] += shape[a] * x[a][k];
                            tr[k] += dr[a] * x[a][k];
                            ts[k] += ds[a] * x[a][k];
                        }
                    }
                    let normal =
                        [tr[1] * ts[2] - tr[2] * ts[1], tr[2] * ts[0] - tr[0] * ts[2], tr[0] * ts[1] - tr[1] * ts[0]];
                    let jacobian = (normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]).sqrt();
                    points.push(ContactPoint {
                        nodes: *face,
                        shape,
                        position,
                        weight: jacobian * weights[i] * weights[j],
                    });
                }
            }
        }
        Self { points, per_face: abscissae.len() * abscissae.len() }
    }

    /// The vertical gap (mm) of point `q` above the plane z = `plane_z` for
    /// global displacements `u` (3 per node): negative is penetration.
    pub fn gap(&self, q: usize, u: &[f64], plane_z: f64) -> f64 {
        let p = &self.points[q];
        let w = p.displacement(u)[2];
        p.position[2] + w - plane_z
    }

    /// The faces' current positions at m x m points each, evenly spread
    /// over the face (the centres of an m x m grid of its parameter
    /// square), m the face's longest reference side over `spacing_mm`
    /// rounded up (at least 2, at most 64), on the faces whose current node
    /// positions `keep` accepts: `reference` the mesh's node positions, `u`
    /// the global displacements (3 per node). Between the contact points,
    /// for what the points cannot see.
    pub fn face_samples<'a>(
        &'a self,
        reference: &'a [[f64; 3]],
        u: &'a [f64],
        spacing_mm: f64,
        keep: impl Fn(&[[f64; 3]; 4]) -> bool + 'a,
    ) -> impl Iterator<Item = [f64; 3]> + 'a {
        let current = move |n: usize| -> [f64; 3] { std::array::from_fn(|d| reference[n][d] + u[3 * n + d]) };
        self.points.chunks(self.per_face.max(1)).filter(move |face| keep(&face[0].nodes.map(current))).flat_map(
            move |face| {
                let nodes = face[0].nodes;
                let side = (0..4)
                    .map(|a| {
                        let (p, q) = (reference[nodes[a]], reference[nodes[(a + 1) % 4]]);
                        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
                    })
                    .fold(0.0, f64::max);
                let m = (side / spacing_mm).ceil().clamp(2.0, 64.0) as usize;
                let at = move |i: usize| 2.0 * (i as f64 + 0.5) / m as f64 - 1.0;
                let x = nodes.map(current);
                (0..m * m).map(move |k| {
                    let (r, s) = (at(k % m), at(k / m));
                    let shape = bilinear(r, s);
                    std::array::from_fn(|d| (0..4).map(|a| shape[a] * x[a][d]).sum())
                })
            },
        )
    }

    /// The total reference area of the faces (mm^2).
    pub fn area(&self) -> f64 {
        self.points.iter().map(|p| p.weight).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_integrate_the_area_and_interpolate_positions() {
        let mut m = Mesh3::block(&[0.0, 1.0, 3.0], &[0.0, 2.0], &[0.0, 1.0]).unwrap();
        // A tilted bottom: z = 0.1 x, its area grows by sqrt(1 + 0.01).
        m.map(|[x, y, z]| [x, y, z + 0.1 * x * (1.0 - z)]);
        let faces: Vec<[usize; 4]> = m.bottom_faces().into_iter().map(|(_, f)| f).collect();
        let s = ContactSurface::new(&m, &faces);
        assert_eq!(s.points.len(), 8);
        assert!((s.area() - 6.0 * (1.01f64).sqrt()).abs() < 1e-12);
        for p in &s.points {
            assert!((p.position[2] - 0.1 * p.position[0]).abs() < 1e-12);
            assert!((p.shape.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        }
        // A rigid lift of 0.5 mm raises every gap by 0.5.
        let u: Vec<f64> = (0..3 * m.n_nodes()).map(|i| if i % 3 == 2 { 0.5 } else { 0.0 }).collect();
        for q in 0..8 {
            assert!((s.gap(q, &u, 0.0) - (s.points[q].position[2] + 0.5)).abs() < 1e-15);
        }
    }

    /// The composite rule: one part is the plain rule to the bit; 3 x 3
    /// parts of 2 x 2 points are 36 points a face that integrate its area
    /// and any bilinear field exactly, spread evenly over the face (each
    /// part holds 4 of them), on the displaced face where the nodes move.
    #[test]
    fn composite_points_are_the_rule_on_each_part_of_the_face() {
        let mut m = Mesh3::block(&[0.0, 1.0, 3.0], &[0.0, 2.0], &[0.0, 1.0]).unwrap();
        m.map(|[x, y, z]| [x, y, z + 0.1 * x * (1.0 - z)]);
        let faces: Vec<[usize; 4]> = m.bottom_faces().into_iter().map(|(_, f)| f).collect();
        assert_eq!(ContactSurface::with_composite_rule(&m, &faces, 4, 1), ContactSurface::with_rule(&m, &faces, 4));
        let s = ContactSurface::with_composite_rule(&m, &faces, 2, 3);
        assert_eq!((s.per_face, s.points.len()), (36, 72));
        assert!((s.area() - 6.0 * (1.01f64).sqrt()).abs() < 1e-12);
        // x y integrates to int x dx int y dy = (9/2 - 0) * 2 = 9 over the
        // tilted faces (times the constant area factor).
        let xy: f64 = s.points.iter().map(|p| p.weight * p.position[0] * p.position[1]).sum();
        assert!((xy - 9.0 * (1.01f64).sqrt()).abs() < 1e-12, "{xy}");
        // The first face (x in [0, 1], y in [0, 2]): four points in each
        // third of it along x and along y.
        for (axis, side) in [(0, 1.0), (1, 2.0)] {
            for part in 0..3 {
                let (lo, hi) = (side * part as f64 / 3.0, side * (part + 1) as f64 / 3.0);
                let inside = s.points[..36].iter().filter(|p| p.position[axis] > lo && p.position[axis] < hi).count();
                assert_eq!(inside, 12, "axis {axis}, part {part}");
            }
        }
        let u: Vec<f64> = (0..3 * m.n_nodes()).map(|i| if i % 3 == 2 { 0.25 } else { 0.0 }).collect();
        for q in 0..72 {
            assert!((s.gap(q, &u, 0.0) - (s.points[q].position[2] + 0.25)).abs() < 1e-15);
        }
    }

    #[test]
    fn face_samples_cover_each_displaced_face_evenly() {
        let mut m = Mesh3::block(&[0.0, 1.0, 3.0], &[0.0, 2.0], &[0.0, 1.0]).unwrap();
        m.map(|[x, y, z]| [x, y, z + 0.1 * x * (1.0 - z)]);
        let faces: Vec<[usize; 4]> = m.bottom_faces().into_iter().map(|(_, f)| f).collect();
        let s = ContactSurface::with_rule(&m, &faces, 4);
        // Lifted by 0.5 mm and moved 0.2 mm along y.
        let u: Vec<f64> = (0..3 * m.n_nodes()).map(|i| [0.0, 0.2, 0.5][i % 3]).collect();
        // Faces of sides 1 and 2 (x) by 2 (y), tilted by 0.1: their longest
        // sides 2 and 2.01 mm, so 5 samples along each direction at 0.41 mm.
        let samples: Vec<[f64; 3]> = s.face_samples(&m.nodes, &u, 0.41, |_| true).collect();
        assert_eq!(samples.len(), 2 * 25);
        // The faces kept: the second (x from 1 to 3) alone.
        let second: Vec<[f64; 3]> = s.face_samples(&m.nodes, &u, 0.41, |x| x.iter().all(|p| p[0] >= 1.0)).collect();
        assert_eq!(second.len(), 25);
        assert!(second.iter().all(|p| p[0] > 1.0));
        for x in &samples {
            assert!((x[2] - (0.1 * x[0] + 0.5)).abs() < 1e-12, "{x:?} off the displaced face");
        }
        // The first face spans x in [0, 1], y in [0.2, 2.2]: a 5 x 5 grid of
        // cell centres, 0.1 of the face from its edges.
        let first = &samples[..25];
        let (lo, hi) = first.iter().fold(([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]), |(lo, hi), x| {
            ([lo[0].min(x[0]), lo[1].min(x[1])], [hi[0].max(x[0]), hi[1].max(x[1])])
        });
        for (got, want) in [(lo[0], 0.1), (hi[0], 0.9), (lo[1], 0.4), (hi[1], 2.0)] {
            assert!((got - want).abs() < 1e-12, "extent {got} instead of {want}");
        }
        let mean: f64 = first.iter().map(|x| x[0]).sum::<f64>() / 25.0;
        assert!((mean - 0.5).abs() < 1e-12);
    }
}
