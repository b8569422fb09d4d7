//! The contact law at one point of the 3D skin against a rigid surface:
//! penalty pressure along the surface's normal and Coulomb friction in its
//! tangent plane, path-dependent through a committed state.
//!
//! With d the depth and n the outward normal ([`super::surface`]), q the
//! point's position relative to the surface (surface frame) and q_c, t_c
//! the position and traction at the last commit, P = I - n n^T:
//!
//!   p = eps_N d (with the 2D model's C1 onset, [`smoothed_penalty`]),
//!   t* = P v, v = t_c + eps_T (q - q_c)             (trial traction),
//!   stick if |t*| <= mu p: t = t*;  slip: t = mu p t* / |t*|,
//!
//! and the force per unit area on the body is F = p n - t. Its tangent
//! K = -dF/dq is exact, the surface's curvature included (d and n vary
//! with q; [`super::surface::SurfaceAt`]): with k = dp/dd,
//!
//!   dt*/dq_j = dP_j v + eps_T P e_j,  dP_j = -(n_,j n^T + n n_,j^T),
//!   stick: dt/dq = dt*/dq;  slip: dt/dq_j = mu k d_,j m + (mu p / |t*|)
//!   (I - m m^T) dt*/dq_j, m = t* / |t*| (unsymmetric: the slip limit
//!   follows p),
//!   dF/dq_j = k d_,j n + p n_,j - dt/dq_j.
//!
//! Sliding, |t*| is large next to mu p and the slipping points' own
//! tangential stiffness mu p eps_T / |t*| small: the curvature's terms
//! are then of its size, and leaving them out made Newton's method
//! converge linearly over a bump (a factor 7 per iteration).

use super::surface::SurfaceAt;
use crate::contact::smoothed_penalty;

/// The parameters of the point law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionLaw {
    /// Normal penalty eps_N (MPa/mm) and its C1 onset width (mm; 0: none).
    pub penalty_n: f64,
    pub smoothing_mm: f64,
    /// Tangential penalty eps_T on the elastic slip (MPa/mm).
    pub penalty_t: f64,
    /// Coulomb friction coefficient.
    pub mu: f64,
}

/// A point's state at the last commit: its position relative to the
/// surface (mm) and its tangential traction (MPa, a vector in 3D).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Committed {
    pub position: [f64; 3],
    pub traction: [f64; 3],
}

/// The law's answer at one point in contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointResponse {
    /// Pressure (MPa) and tangential traction (MPa; the shear the body
    /// exerts on the surface, along its slip).
    pub pressure: f64,
    pub traction: [f64; 3],
    pub sticking: bool,
    /// Force per unit area on the body, p n - t (MPa).
    pub force: [f64; 3],
    /// -d(force)/dq (MPa/mm), row i, column j.
    pub tangent: [[f64; 3]; 3],
}

impl FrictionLaw {
    /// The response of a point at relative position `q` under the surface
    /// `at`; `None` out of contact.
    pub fn evaluate(&self, at: &SurfaceAt, q: [f64; 3], committed: &Committed) -> Option<PointResponse> {
        let (pressure, k) = smoothed_penalty(self.penalty_n, self.smoothing_mm, at.depth);
        if pressure <= 0.0 {
            return None;
        }
        let n = at.normal;
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let v: [f64; 3] =
            std::array::from_fn(|i| committed.traction[i] + self.penalty_t * (q[i] - committed.position[i]));
        let nv = dot(n, v);
        let trial: [f64; 3] = std::array::from_fn(|i| v[i] - nv * n[i]);
        let size = dot(trial, trial).sqrt();
        let limit = self.mu * pressure;
        let sticking = size <= limit;
        let traction = if sticking { trial } else { trial.map(|x| limit * x / size) };
        let m = trial.map(|x| if size > 0.0 { x / size } else { 0.0 });
        let mut tangent = [[0.0; 3]; 3];
        for j in 0..3 {
            let dn: [f64; 3] = std::array::from_fn(|i| at.d_normal[i][j]);
            let dnv = dot(dn, v);
            // dt*/dq_j.
            let d_trial: [f64; 3] = std::array::from_fn(|i| {
                let projector = f64::from(u8::from(i == j)) - n[i] * n[j];
                -(dn[i] * nv + n[i] * dnv) + self.penalty_t * projector
            });
            let dp = k * at.d_depth[j];
            let d_traction: [f64; 3] = if sticking {
                d_trial
            } else {
                let along = dot(m, d_trial);
                std::array::from_fn(|i| self.mu * dp * m[i] + limit / size * (d_trial[i] - m[i] * along))
            };
            for i in 0..3 {
                tangent[i][j] = -(dp * n[i] + pressure * dn[i] - d_traction[i]);
            }
        }
        let force = std::array::from_fn(|i| pressure * n[i] - traction[i]);
        Some(PointResponse { pressure, traction, sticking, force, tangent })
    }
}

#[cfg(test)]
mod tests {
    use super::super::surface::HeightField;
    use super::*;
    use crate::surface::SurfaceShape;

    /// The tangent is the force's derivative (central differences), in
    /// stick and in slip, within the penalty's onset, on a curved surface
    /// (an extruded bump: depth and normal vary with q).
    #[test]
    fn tangent_is_the_derivative_of_the_force() {
        let law = FrictionLaw { penalty_n: 200.0, smoothing_mm: 1e-3, penalty_t: 150.0, mu: 0.6 };
        let shape = SurfaceShape::Bump { x0: 0.3, width: 1.5, height: 0.3 };
        let field = HeightField::extruded(&shape, -5.0, 5.0).unwrap();
        let height = |x: f64| field.height_gradient(x, 0.0).0;
        let committed = Committed { position: [0.1, -0.2, height(0.1) - 0.0201], traction: [0.05, 0.01, 0.02] };
        // Stick deep in contact; slip; slip within the onset.
        let cases = [
            ([0.1001, -0.2001, height(0.1001) - 0.02], true),
            ([0.5, 0.1, height(0.5) - 0.005], false),
            ([0.0, 0.0, height(0.0) - 0.0005], false),
        ];
        for (q, sticks) in cases {
            let r = law.evaluate(&field.at(q), q, &committed).unwrap();
            assert_eq!(r.sticking, sticks, "{q:?}");
            let h = 1e-7;
            for j in 0..3 {
                let (mut a, mut b) = (q, q);
                a[j] += h;
                b[j] -= h;
                let fa = law.evaluate(&field.at(a), a, &committed).unwrap().force;
                let fb = law.evaluate(&field.at(b), b, &committed).unwrap().force;
                for i in 0..3 {
                    let numeric = -(fa[i] - fb[i]) / (2.0 * h);
                    let scale = r.tangent[i][j].abs().max(1.0);
                    assert!(
                        (numeric - r.tangent[i][j]).abs() < 1e-5 * scale,
                        "q {q:?} sticking {}: K[{i}][{j}] = {} against {numeric}",
                        r.sticking,
                        r.tangent[i][j]
                    );
                }
            }
        }
    }

    /// Sliding on a flat: the traction is mu p along the slip, in the
    /// plane.
    #[test]
    fn slipping_traction_is_mu_p_along_the_slip() {
        let law = FrictionLaw { penalty_n: 100.0, smoothing_mm: 0.0, penalty_t: 100.0, mu: 0.5 };
        let q = [3.0, 4.0, -0.01];
        let r = law.evaluate(&HeightField::Flat.at(q), q, &Committed::default()).unwrap();
        assert!(!r.sticking);
        assert!((r.pressure - 1.0).abs() < 1e-12);
        assert!((r.traction[0] - 0.3).abs() < 1e-12 && (r.traction[1] - 0.4).abs() < 1e-12);
        assert_eq!(r.traction[2], 0.0);
        let above = [0.0, 0.0, 0.01];
        assert!(law.evaluate(&HeightField::Flat.at(above), above, &Committed::default()).is_none());
    }
}
