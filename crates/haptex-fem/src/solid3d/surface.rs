//! The rigid surface under the 3D finger: a height field z = h(x, y) in
//! the surface's own frame (x, y in the plane, z up, mm), and what a
//! contact point inside it needs: its depth along the surface's normal and
//! that normal.
//!
//! Depth: for a point q below the surface, d = (h(q_x, q_y) - q_z) c with
//! c = 1 / sqrt(1 + |grad h|^2), its distance to the tangent plane at the
//! surface point above it. Exact for a plane at any inclination; on a
//! curved surface it differs from the distance to the closest point by
//! O(d^2 kappa), which at the penalty's penetrations (below a micrometre)
//! and the templates' curvatures is far below a nanometre. The normal
//! n = c (-h_x, -h_y, 1) is the rigid body's outward unit normal, and
//! dd/dq = -n holds where the gradient is constant (the tangent the
//! contact law uses; the curvature's term is left out, as the 2D model
//! leaves it out after a stall).

use crate::surface::{RigidSurface, SurfaceError, SurfaceShape};

/// A rigid surface in its own frame.
#[derive(Debug, Clone)]
pub enum HeightField {
    /// h = 0.
    Flat,
    /// A 2D surface (a template or a sampled profile) h(x), the same for
    /// every y: the 2D model's surfaces, their ridges along y.
    Extruded(Box<RigidSurface>),
}

impl HeightField {
    /// `shape` extruded along y, over x from `x_min` to `x_max` (held flat
    /// beyond); [`HeightField::Flat`] for the flat shape.
    pub fn extruded(shape: &SurfaceShape, x_min: f64, x_max: f64) -> Result<Self, SurfaceError> {
        Ok(match shape {
            SurfaceShape::Flat => Self::Flat,
            _ => Self::Extruded(Box::new(RigidSurface::new(shape, x_min, x_max)?)),
        })
    }

    /// h(x, y) and its gradient (h_x, h_y).
    pub fn height_gradient(&self, x: f64, y: f64) -> (f64, [f64; 2]) {
        let (h, g, _) = self.derivatives(x, y);
        (h, g)
    }

    /// h, its gradient and its Hessian at (x, y).
    fn derivatives(&self, x: f64, _y: f64) -> (f64, [f64; 2], [[f64; 2]; 2]) {
        match self {
            Self::Flat => (0.0, [0.0; 2], [[0.0; 2]; 2]),
            Self::Extruded(profile) => {
                let [h, slope, curvature] = profile.height_derivatives(x);
                (h, [slope, 0.0], [[curvature, 0.0], [0.0, 0.0]])
            }
        }
    }

    /// The surface as seen from the point `q` (surface frame): its depth
    /// (mm, negative above the surface), the outward unit normal, and
    /// their derivatives with respect to q.
    pub fn at(&self, q: [f64; 3]) -> SurfaceAt {
        let (h, g, hessian) = self.derivatives(q[0], q[1]);
        let c = 1.0 / (1.0 + g[0] * g[0] + g[1] * g[1]).sqrt();
        let a = [-g[0], -g[1], 1.0];
        let mut d_depth = [0.0, 0.0, -c];
        let mut d_normal = [[0.0; 3]; 3];
        for j in 0..2 {
            // dc/dq_j = -c^3 (g . H e_j); da/dq_j = -(H e_j, 0).
            let dc = -c * c * c * (g[0] * hessian[0][j] + g[1] * hessian[1][j]);
            d_depth[j] = g[j] * c + (h - q[2]) * dc;
            let da = [-hessian[0][j], -hessian[1][j], 0.0];
            for i in 0..3 {
                d_normal[i][j] = c * da[i] + a[i] * dc;
            }
        }
        SurfaceAt { depth: (h - q[2]) * c, normal: a.map(|v| v * c), d_depth, d_normal }
    }
}

/// A rigid surface seen from a point (see [`HeightField::at`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceAt {
    /// Depth of the point under the surface (mm; negative above it).
    pub depth: f64,
    /// The outward unit normal n.
    pub normal: [f64; 3],
    /// d depth / dq.
    pub d_depth: [f64; 3],
    /// d n_i / d q_j, row i, column j.
    pub d_normal: [[f64; 3]; 3],
}

impl SurfaceAt {
    /// The same without the curvature's terms in the derivatives (those
    /// of the tangent plane: d depth/dq = -n, dn/dq = 0).
    pub fn without_curvature(self) -> Self {
        Self { d_depth: self.normal.map(|v| -v), d_normal: [[0.0; 3]; 3], ..self }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On an inclined plane (a sampled profile of slope 0.5, extruded),
    /// the depth is the distance to the plane and the normal its own.
    #[test]
    fn depth_on_an_inclined_plane_is_the_distance_to_it() {
        let x_mm = vec![-10.0, -5.0, 0.0, 5.0, 10.0];
        let shape = SurfaceShape::Sampled { h_mm: x_mm.iter().map(|x| x / 2.0).collect(), x_mm };
        let field = HeightField::extruded(&shape, -8.0, 8.0).unwrap();
        let n_exact = [-0.5 / 1.25f64.sqrt(), 0.0, 1.0 / 1.25f64.sqrt()];
        for q in [[0.0, 3.0, -0.2], [1.0, -7.0, 0.1], [-2.0, 0.0, -1.05]] {
            let SurfaceAt { depth: d, normal: n, .. } = field.at(q);
            // Distance of q to the plane z = x / 2 along its normal.
            let exact = -(n_exact[0] * q[0] + n_exact[2] * q[2]);
            assert!((d - exact).abs() < 1e-12, "{q:?}: {d} against {exact}");
            for k in 0..3 {
                assert!((n[k] - n_exact[k]).abs() < 1e-12);
            }
        }
        let flat = HeightField::Flat.at([4.0, -2.0, -0.3]);
        assert_eq!((flat.depth, flat.normal), (0.3, [0.0, 0.0, 1.0]));
    }

    /// The derivatives of depth and normal are those of the functions
    /// (central differences) on a curved surface: an extruded bump.
    #[test]
    fn derivatives_on_a_bump_match_differences() {
        let shape = SurfaceShape::Bump { x0: 0.5, width: 1.5, height: 0.3 };
        let field = HeightField::extruded(&shape, -5.0, 5.0).unwrap();
        for q in [[0.0, 1.0, 0.2], [0.9, -3.0, 0.1], [1.4, 0.0, -0.05]] {
            let at = field.at(q);
            for j in 0..3 {
                let h = 1e-6;
                let (mut a, mut b) = (q, q);
                a[j] += h;
                b[j] -= h;
                let (fa, fb) = (field.at(a), field.at(b));
                let numeric = (fa.depth - fb.depth) / (2.0 * h);
                assert!((numeric - at.d_depth[j]).abs() < 1e-7, "d depth/dq{j} at {q:?}");
                for i in 0..3 {
                    let numeric = (fa.normal[i] - fb.normal[i]) / (2.0 * h);
                    assert!((numeric - at.d_normal[i][j]).abs() < 1e-7, "dn{i}/dq{j} at {q:?}");
                }
            }
        }
    }
}
