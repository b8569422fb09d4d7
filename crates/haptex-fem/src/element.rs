//! The 4-node plane-strain quadrilateral (Q4), isoparametric, 2x2 Gauss
//! points, in two formulations:
//!
//! - `Plain`: the standard displacement element. It locks volumetrically
//!   as nu -> 0.5 (Hughes, The Finite Element Method, 1987, sec. 4.5).
//! - `BBar`: the mean-dilatation B-bar element (Hughes 1980; Simo & Hughes
//!   1998, sec. 4.4): the volumetric strain is replaced by its element
//!   average theta_bar, the deviatoric strain is taken pointwise. For a
//!   linear material this is the selectively reduced integrated element and
//!   does not lock.
//!
//! Strains and stresses are stored as tensor components (xx, yy, zz, xy);
//! plane strain means eps_zz = 0 while the stress sigma_zz is not zero.
//! The stress is split as sigma = s + p I with the deviator s and the mean
//! stress p = K theta (theta = eps_xx + eps_yy, or theta_bar).

/// Gauss points of the 2x2 rule in the reference square (weights are 1).
pub const GAUSS_POINTS: [[f64; 2]; 4] = {
    const A: f64 = 0.577_350_269_189_625_8; // 1/sqrt(3)
    [[-A, -A], [A, -A], [A, A], [-A, A]]
};

/// Reference-square corners of the 4 nodes, counter-clockwise.
const CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Which treatment of the volumetric strain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Formulation {
    Plain,
    BBar,
}

/// An element's Jacobian is not positive at a Gauss point (inverted or
/// degenerate element).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("element has a non-positive Jacobian ({det_j:e}) at Gauss point {gauss_point}")]
pub struct JacobianError {
    pub gauss_point: usize,
    pub det_j: f64,
}

/// Shape functions of the Q4 at reference point (r, s).
pub fn shape_functions(r: f64, s: f64) -> [f64; 4] {
    CORNERS.map(|[ri, si]| 0.25 * (1.0 + ri * r) * (1.0 + si * s))
}

/// The reference-configuration geometry of one element: shape function
/// gradients and integration weights at the 4 Gauss points, and the
/// mean-dilatation operator. Computed once; the kinematics are linear.
#[derive(Debug, Clone, PartialEq)]
pub struct Q4 {
    /// d N_a / d (x, y) at each Gauss point: `grad[gp][a] = [dN/dx, dN/dy]`.
    pub grad: [[[f64; 2]; 4]; 4],
    /// Gauss weight times det J at each Gauss point (area element, mm^2).
    pub weight: [f64; 4],
    /// Element area in mm^2.
    pub area: f64,
    /// Mean dilatation operator: theta_bar = sum_a (bx_a u_a + by_a v_a).
    pub mean_grad: [[f64; 2]; 4],
}

impl Q4 {
    /// Geometry of the element with nodes at `x` (mm, counter-clockwise).
    pub fn new(x: &[[f64; 2]; 4]) -> Result<Self, JacobianError> {
        let mut grad = [[[0.0; 2]; 4]; 4];
        let mut weight = [0.0; 4];
        for (gp, &[r, s]) in GAUSS_POINTS.iter().enumerate() {
            // dN/dr, dN/ds
            let dn: [[f64; 2]; 4] = CORNERS.map(|[ri, si]| [0.25 * ri * (1.0 + si * s), 0.25 * si * (1.0 + ri * r)]);
            let mut j = [[0.0; 2]; 2]; // j[i][k] = d x_k / d r_i
            for a in 0..4 {
                for i in 0..2 {
                    for k in 0..2 {
                        j[i][k] += dn[a][i] * x[a][k];
                    }
                }
            }
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if det.is_nan() || det <= 0.0 {
                return Err(JacobianError { gauss_point: gp, det_j: det });
            }
            let inv = [[j[1][1] / det, -j[0][1] / det], [-j[1][0] / det, j[0][0] / det]];
            for a in 0..4 {
                // dN/dx_k = sum_i (J^-1)_{k i} dN/dr_i
                grad[gp][a] =
                    [inv[0][0] * dn[a][0] + inv[0][1] * dn[a][1], inv[1][0] * dn[a][0] + inv[1][1] * dn[a][1]];
            }
            weight[gp] = det;
        }
        let area: f64 = weight.iter().sum();
        let mut mean_grad = [[0.0; 2]; 4];
        for gp in 0..4 {
            for a in 0..4 {
                for k in 0..2 {
                    mean_grad[a][k] += weight[gp] * grad[gp][a][k] / area;
                }
            }
        }
        Ok(Self { grad, weight, area, mean_grad })
    }

    /// Small strain (tensor components xx, yy, zz = 0, xy) at Gauss point
    /// `gp` for element displacements `u` (u_a, v_a interleaved, mm).
    pub fn strain(&self, gp: usize, u: &[f64; 8]) -> [f64; 4] {
        let g = &self.grad[gp];
        let mut e = [0.0; 4];
        for a in 0..4 {
            let (ua, va) = (u[2 * a], u[2 * a + 1]);
            e[0] += g[a][0] * ua;
            e[1] += g[a][1] * va;
            e[3] += 0.5 * (g[a][1] * ua + g[a][0] * va);
        }
        e
    }

    /// Volumetric strain used by the formulation at Gauss point `gp`.
    pub fn dilatation(&self, formulation: Formulation, gp: usize, u: &[f64; 8]) -> f64 {
        match formulation {
            Formulation::Plain => {
                let e = self.strain(gp, u);
                e[0] + e[1]
            }
            Formulation::BBar => {
                (0..4).map(|a| self.mean_grad[a][0] * u[2 * a] + self.mean_grad[a][1] * u[2 * a + 1]).sum()
            }
        }
    }

    /// Element stiffness for shear modulus `g_mpa` and bulk modulus `k_mpa`:
    /// K = sum_gp w 2G Bd^T diag(1,1,1,2) Bd + volumetric part (K b b^T per
    /// Gauss point, or K A b_bar b_bar^T for B-bar). Row-major 8x8.
    pub fn stiffness(&self, formulation: Formulation, g_mpa: f64, k_mpa: f64) -> [[f64; 8]; 8] {
        let mut k = [[0.0; 8]; 8];
        for gp in 0..4 {
            let bd = self.deviatoric_operator(gp);
            let w = self.weight[gp] * 2.0 * g_mpa;
            for i in 0..8 {
                for j in 0..8 {
                    k[i][j] += w
                        * (bd[0][i] * bd[0][j] + bd[1][i] * bd[1][j] + bd[2][i] * bd[2][j] + 2.0 * bd[3][i] * bd[3][j]);
                }
            }
            if formulation == Formulation::Plain {
                let b = volumetric_row(&self.grad[gp]);
                add_outer(&mut k, &b, self.weight[gp] * k_mpa);
            }
        }
        if formulation == Formulation::BBar {
            let b = volumetric_row(&self.mean_grad);
            add_outer(&mut k, &b, self.area * k_mpa);
        }
        k
    }

    /// d (dev eps) / d u at Gauss point `gp`: rows xx, yy, zz, xy (tensor).
    fn deviatoric_operator(&self, gp: usize) -> [[f64; 8]; 4] {
        let g = &self.grad[gp];
        let mut bd = [[0.0; 8]; 4];
        for a in 0..4 {
            let (dx, dy) = (g[a][0], g[a][1]);
            let (iu, iv) = (2 * a, 2 * a + 1);
            bd[0][iu] = 2.0 / 3.0 * dx;
            bd[1][iu] = -dx / 3.0;
            bd[2][iu] = -dx / 3.0;
            bd[3][iu] = 0.5 * dy;
            bd[0][iv] = -dy / 3.0;
            bd[1][iv] = 2.0 / 3.0 * dy;
            bd[2][iv] = -dy / 3.0;
            bd[3][iv] = 0.5 * dx;
        }
        bd
    }

    /// Adds the nodal forces of a deviatoric stress `s` (tensor components,
    /// MPa) at Gauss point `gp` to `f`: f += w Bd^T diag(1,1,1,2) s.
    pub fn add_deviator_force(&self, gp: usize, s: &[f64; 4], f: &mut [f64; 8]) {
        let w = self.weight[gp];
        let g = &self.grad[gp];
        // For a deviator (s_xx + s_yy + s_zz = 0) this is B^T sigma; written
        // out for any s so that it is exactly the transpose of the operator.
        let sx = (2.0 * s[0] - s[1] - s[2]) / 3.0;
        let sy = (2.0 * s[1] - s[0] - s[2]) / 3.0;
        for a in 0..4 {
            f[2 * a] += w * (g[a][0] * sx + g[a][1] * s[3]);
            f[2 * a + 1] += w * (g[a][1] * sy + g[a][0] * s[3]);
        }
    }

    /// Adds the nodal forces of a mean stress `p` (MPa) to `f`: at Gauss
    /// point `gp` (plain), or over the element (B-bar, `gp` ignored when
    /// called once with the element's mean stress).
    pub fn add_pressure_force(&self, formulation: Formulation, gp: usize, p: f64, f: &mut [f64; 8]) {
        let (grad, w) = match formulation {
            Formulation::Plain => (&self.grad[gp], self.weight[gp]),
            Formulation::BBar => (&self.mean_grad, self.area),
        };
        for a in 0..4 {
            f[2 * a] += w * grad[a][0] * p;
            f[2 * a + 1] += w * grad[a][1] * p;
        }
    }
}

/// The deviator of a plane-strain strain (tensor components).
pub fn deviator(e: &[f64; 4]) -> [f64; 4] {
    let mean = (e[0] + e[1] + e[2]) / 3.0;
    [e[0] - mean, e[1] - mean, e[2] - mean, e[3]]
}

fn volumetric_row(grad: &[[f64; 2]; 4]) -> [f64; 8] {
    let mut b = [0.0; 8];
    for a in 0..4 {
        b[2 * a] = grad[a][0];
        b[2 * a + 1] = grad[a][1];
    }
    b
}

fn add_outer(k: &mut [[f64; 8]; 8], b: &[f64; 8], scale: f64) {
    for i in 0..8 {
        for j in 0..8 {
            k[i][j] += scale * b[i] * b[j];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn distorted() -> Q4 {
        Q4::new(&[[0.0, 0.0], [2.0, 0.3], [2.4, 1.7], [-0.2, 1.2]]).unwrap()
    }

    #[test]
    fn area_and_partition_of_unity() {
        let q = distorted();
        // Shoelace area of the quadrilateral.
        let x = [[0.0, 0.0], [2.0, 0.3], [2.4, 1.7], [-0.2, 1.2]];
        let shoelace: f64 =
            (0..4).map(|i| x[i][0] * x[(i + 1) % 4][1] - x[(i + 1) % 4][0] * x[i][1]).sum::<f64>() / 2.0;
        assert!((q.area - shoelace).abs() < 1e-14);
        for gp in 0..4 {
            let sum: [f64; 2] = (0..4).fold([0.0, 0.0], |s, a| [s[0] + q.grad[gp][a][0], s[1] + q.grad[gp][a][1]]);
            assert!(sum[0].abs() < 1e-14 && sum[1].abs() < 1e-14);
        }
        assert!((shape_functions(0.3, -0.7).iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }

    /// Rigid-body translations and the infinitesimal rotation are in the
    /// null space of both stiffness matrices, which are symmetric.
    #[test]
    fn stiffness_rigid_modes_and_symmetry() {
        let q = distorted();
        let x = [[0.0, 0.0], [2.0, 0.3], [2.4, 1.7], [-0.2, 1.2]];
        let modes: [[f64; 8]; 3] = [
            [1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0],
            std::array::from_fn(|i| if i % 2 == 0 { -x[i / 2][1] } else { x[i / 2][0] }),
        ];
        for formulation in [Formulation::Plain, Formulation::BBar] {
            let k = q.stiffness(formulation, 0.7, 20.0);
            for i in 0..8 {
                for j in 0..8 {
                    assert!((k[i][j] - k[j][i]).abs() < 1e-12);
                }
            }
            for mode in &modes {
                for row in &k {
                    let f: f64 = row.iter().zip(mode).map(|(a, b)| a * b).sum();
                    assert!(f.abs() < 1e-12, "{formulation:?}: {f}");
                }
            }
        }
    }

    proptest::proptest! {
        /// fenris-style patch property: on any convex quad (a unit square
        /// with corners moved by up to 0.3), an affine displacement field
        /// gives its exact constant strain at every Gauss point (1e-12).
        #[test]
        fn affine_field_gives_exact_strain_on_random_quads(
            moves in proptest::collection::vec(-0.3f64..0.3, 8),
            a in proptest::collection::vec(-1.0f64..1.0, 6),
        ) {
            let x: [[f64; 2]; 4] = std::array::from_fn(|i| [CORNERS[i][0] + moves[2 * i], CORNERS[i][1] + moves[2 * i + 1]]);
            let q = Q4::new(&x).unwrap();
            let u: [f64; 8] = std::array::from_fn(|i| {
                let p = x[i / 2];
                if i % 2 == 0 { a[0] + a[1] * p[0] + a[2] * p[1] } else { a[3] + a[4] * p[0] + a[5] * p[1] }
            });
            let exact = [a[1], a[5], 0.0, 0.5 * (a[2] + a[4])];
            for gp in 0..4 {
                let e = q.strain(gp, &u);
                for k in 0..4 {
                    proptest::prop_assert!((e[k] - exact[k]).abs() < 1e-12);
                }
                proptest::prop_assert!((q.dilatation(Formulation::BBar, gp, &u) - (a[1] + a[5])).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn inverted_element_is_rejected() {
        let err = Q4::new(&[[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]]).unwrap_err();
        assert!(err.det_j < 0.0);
    }
}
