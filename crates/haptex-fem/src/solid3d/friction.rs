//! The contact law at one point of the 3D skin against a rigid surface:
//! penalty pressure along the surface's normal and Coulomb friction in its
//! tangent plane, path-dependent through a committed state.
//!
//! With d the depth and n the outward normal ([`super::surface`]), q the
//! point's position relative to the surface (surface frame) and q_c, t_c
//! the position and traction at the last commit, P = I - n n^T:
//!
//!   p = eps_N d (with the 2D model's C1 onset, [`smoothed_penalty`]),
//!   t* = P t_c + eps_T P (q - q_c)                  (trial traction),
//!   stick if |t*| <= mu p: t = t*;  slip: t = mu p t* / |t*|,
//!
//! and the force per unit area on the body is p n - t. Its tangent,
//! K = -d(force)/dq, with k = dp/dd and dd/dq = -n:
//!
//!   stick: k n n^T + eps_T P,
//!   slip:  k n n^T - mu k m n^T + (mu p eps_T / |t*|) (P - m m^T),
//!          m = t* / |t*| (unsymmetric: the slip limit follows p).

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
    /// The response of a point at depth `depth` under a surface of normal
    /// `normal`, at relative position `q`; `None` out of contact.
    pub fn evaluate(&self, depth: f64, normal: [f64; 3], q: [f64; 3], committed: &Committed) -> Option<PointResponse> {
        let (pressure, k) = smoothed_penalty(self.penalty_n, self.smoothing_mm, depth);
        if pressure <= 0.0 {
            return None;
        }
        let n = normal;
        let project = |v: [f64; 3]| {
            let along = v[0] * n[0] + v[1] * n[1] + v[2] * n[2];
            [v[0] - along * n[0], v[1] - along * n[1], v[2] - along * n[2]]
        };
        let tc = project(committed.traction);
        let slip = project(std::array::from_fn(|i| q[i] - committed.position[i]));
        let trial: [f64; 3] = std::array::from_fn(|i| tc[i] + self.penalty_t * slip[i]);
        let size = (trial[0] * trial[0] + trial[1] * trial[1] + trial[2] * trial[2]).sqrt();
        let limit = self.mu * pressure;
        let sticking = size <= limit;
        let traction = if sticking { trial } else { trial.map(|v| limit * v / size) };
        let p_matrix = |i: usize, j: usize| f64::from(u8::from(i == j)) - n[i] * n[j];
        let tangent = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let normal_part = k * n[i] * n[j];
                if sticking {
                    normal_part + self.penalty_t * p_matrix(i, j)
                } else {
                    let m = trial.map(|v| v / size);
                    let c = self.mu * pressure * self.penalty_t / size;
                    normal_part - self.mu * k * m[i] * n[j] + c * (p_matrix(i, j) - m[i] * m[j])
                }
            })
        });
        let force = std::array::from_fn(|i| pressure * n[i] - traction[i]);
        Some(PointResponse { pressure, traction, sticking, force, tangent })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tangent is the force's derivative (central differences), in
    /// stick and in slip, on an inclined surface, with the smoothed onset.
    #[test]
    fn tangent_is_the_derivative_of_the_force() {
        let law = FrictionLaw { penalty_n: 200.0, smoothing_mm: 1e-3, penalty_t: 150.0, mu: 0.6 };
        let c = 1.0 / 1.09f64.sqrt();
        let normal = [-0.3 * c, 0.0, c];
        // The depth of a point q under the plane z = 0.3 x through the origin.
        let depth = |q: [f64; 3]| (0.3 * q[0] - q[2]) * c;
        let committed = Committed { position: [0.1, -0.2, 0.0], traction: [0.05, 0.01, 0.0] };
        // Stick deep in contact; slip; slip within the onset.
        for (q, sticks) in [([0.1001, -0.2001, -0.002], true), ([0.3, 0.1, 0.085], false), ([0.0, 0.0, -0.0005], false)]
        {
            let r = law.evaluate(depth(q), normal, q, &committed).unwrap();
            assert_eq!(r.sticking, sticks, "{q:?}");
            let h = 1e-7;
            for j in 0..3 {
                let mut a = q;
                let mut b = q;
                a[j] += h;
                b[j] -= h;
                let fa = law.evaluate(depth(a), normal, a, &committed).unwrap().force;
                let fb = law.evaluate(depth(b), normal, b, &committed).unwrap().force;
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

    /// Sliding: the traction is mu p along the slip, in the tangent plane.
    #[test]
    fn slipping_traction_is_mu_p_along_the_slip() {
        let law = FrictionLaw { penalty_n: 100.0, smoothing_mm: 0.0, penalty_t: 100.0, mu: 0.5 };
        let r = law.evaluate(0.01, [0.0, 0.0, 1.0], [3.0, 4.0, -0.01], &Committed::default()).unwrap();
        assert!(!r.sticking);
        assert!((r.pressure - 1.0).abs() < 1e-12);
        assert!((r.traction[0] - 0.3).abs() < 1e-12 && (r.traction[1] - 0.4).abs() < 1e-12);
        assert_eq!(r.traction[2], 0.0);
        assert!(law.evaluate(-0.01, [0.0, 0.0, 1.0], [0.0; 3], &Committed::default()).is_none());
    }
}
