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
    Extruded(RigidSurface),
}

impl HeightField {
    /// `shape` extruded along y, over x from `x_min` to `x_max` (held flat
    /// beyond); [`HeightField::Flat`] for the flat shape.
    pub fn extruded(shape: &SurfaceShape, x_min: f64, x_max: f64) -> Result<Self, SurfaceError> {
        Ok(match shape {
            SurfaceShape::Flat => Self::Flat,
            _ => Self::Extruded(RigidSurface::new(shape, x_min, x_max)?),
        })
    }

    /// h(x, y) and its gradient (h_x, h_y).
    pub fn height_gradient(&self, x: f64, _y: f64) -> (f64, [f64; 2]) {
        match self {
            Self::Flat => (0.0, [0.0; 2]),
            Self::Extruded(profile) => {
                let [h, slope, _] = profile.height_derivatives(x);
                (h, [slope, 0.0])
            }
        }
    }

    /// The depth (mm) of the point `q` (surface frame) under the surface,
    /// negative above it, and the surface's outward unit normal there.
    pub fn depth_normal(&self, q: [f64; 3]) -> (f64, [f64; 3]) {
        let (h, [hx, hy]) = self.height_gradient(q[0], q[1]);
        let c = 1.0 / (1.0 + hx * hx + hy * hy).sqrt();
        ((h - q[2]) * c, [-hx * c, -hy * c, c])
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
            let (d, n) = field.depth_normal(q);
            // Distance of q to the plane z = x / 2 along its normal.
            let exact = -(n_exact[0] * q[0] + n_exact[2] * q[2]);
            assert!((d - exact).abs() < 1e-12, "{q:?}: {d} against {exact}");
            for k in 0..3 {
                assert!((n[k] - n_exact[k]).abs() < 1e-12);
            }
        }
        let (d, n) = HeightField::Flat.depth_normal([4.0, -2.0, -0.3]);
        assert_eq!((d, n), (0.3, [0.0, 0.0, 1.0]));
    }
}
