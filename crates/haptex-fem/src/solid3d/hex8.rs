//! The 8-node trilinear hexahedron (Hex8, "C3D8" in CalculiX's words),
//! isoparametric, 2x2x2 Gauss points, small strain, in the 2D model's two
//! formulations ([`Formulation`]): the plain displacement element, which
//! locks volumetrically as nu -> 0.5, and the mean-dilatation B-bar
//! element (Hughes 1980; Simo & Hughes 1998, sec. 4.4), whose volumetric
//! strain is the element average and which does not lock.
//!
//! Strains are tensor components (xx, yy, zz, xy, yz, zx). For a linear
//! isotropic material with shear modulus G and bulk modulus K the stress
//! is sigma = 2 G dev(eps) + K theta I, theta the (mean) dilatation.

pub use crate::element::{Formulation, JacobianError};

/// Reference-cube corners of the 8 nodes: the bottom face (t = -1)
/// counter-clockwise seen from above, then the top face (t = +1).
pub const CORNERS: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// Gauss points of the 2x2x2 rule (weights 1), in the corners' order.
pub const GAUSS_POINTS: [[f64; 3]; 8] = {
    const A: f64 = 0.577_350_269_189_625_8; // 1/sqrt(3)
    let mut p = [[0.0; 3]; 8];
    let mut i = 0;
    while i < 8 {
        p[i] = [A * CORNERS[i][0], A * CORNERS[i][1], A * CORNERS[i][2]];
        i += 1;
    }
    p
};

/// Shape functions at reference point (r, s, t).
pub fn shape_functions(r: f64, s: f64, t: f64) -> [f64; 8] {
    CORNERS.map(|[ri, si, ti]| 0.125 * (1.0 + ri * r) * (1.0 + si * s) * (1.0 + ti * t))
}

/// d N_a / d (r, s, t) at a reference point.
fn reference_gradients(r: f64, s: f64, t: f64) -> [[f64; 3]; 8] {
    CORNERS.map(|[ri, si, ti]| {
        [
            0.125 * ri * (1.0 + si * s) * (1.0 + ti * t),
            0.125 * si * (1.0 + ri * r) * (1.0 + ti * t),
            0.125 * ti * (1.0 + ri * r) * (1.0 + si * s),
        ]
    })
}

/// The reference geometry of one element: shape-function gradients and
/// integration weights at the 8 Gauss points, and the mean-dilatation
/// operator. Computed once; the kinematics are linear.
#[derive(Debug, Clone, PartialEq)]
pub struct Hex8 {
    /// d N_a / d (x, y, z) at each Gauss point: `grad[gp][a]`.
    pub grad: [[[f64; 3]; 8]; 8],
    /// Gauss weight times det J at each Gauss point (mm^3).
    pub weight: [f64; 8],
    /// Element volume in mm^3.
    pub volume: f64,
    /// Mean dilatation operator: theta_bar = sum_a mean_grad[a] . u_a.
    pub mean_grad: [[f64; 3]; 8],
}

impl Hex8 {
    /// Geometry of the element with nodes at `x` (mm, in the order of
    /// [`CORNERS`]); refused where the Jacobian is not positive at a Gauss
    /// point (an inverted, degenerate or wrongly numbered element).
    pub fn new(x: &[[f64; 3]; 8]) -> Result<Self, JacobianError> {
        let mut grad = [[[0.0; 3]; 8]; 8];
        let mut weight = [0.0; 8];
        for (gp, &[r, s, t]) in GAUSS_POINTS.iter().enumerate() {
            let dn = reference_gradients(r, s, t);
            // j[i][k] = d x_k / d r_i
            let mut j = [[0.0; 3]; 3];
            for a in 0..8 {
                for i in 0..3 {
                    for k in 0..3 {
                        j[i][k] += dn[a][i] * x[a][k];
                    }
                }
            }
            let (det, inv) = invert3(&j);
            if det.is_nan() || det <= 0.0 {
                return Err(JacobianError { gauss_point: gp, det_j: det });
            }
            for a in 0..8 {
                // dN/dx_k = sum_i (J^-1)_{k i} dN/dr_i
                grad[gp][a] = std::array::from_fn(|k| (0..3).map(|i| inv[k][i] * dn[a][i]).sum());
            }
            weight[gp] = det;
        }
        let volume: f64 = weight.iter().sum();
        let mut mean_grad = [[0.0; 3]; 8];
        for gp in 0..8 {
            for a in 0..8 {
                for k in 0..3 {
                    mean_grad[a][k] += weight[gp] * grad[gp][a][k] / volume;
                }
            }
        }
        Ok(Self { grad, weight, volume, mean_grad })
    }

    /// Small strain (tensor components xx, yy, zz, xy, yz, zx) at Gauss
    /// point `gp` for element displacements `u` (u_a, v_a, w_a interleaved).
    pub fn strain(&self, gp: usize, u: &[f64; 24]) -> [f64; 6] {
        let g = &self.grad[gp];
        let mut e = [0.0; 6];
        for a in 0..8 {
            let (ua, va, wa) = (u[3 * a], u[3 * a + 1], u[3 * a + 2]);
            let [dx, dy, dz] = g[a];
            e[0] += dx * ua;
            e[1] += dy * va;
            e[2] += dz * wa;
            e[3] += 0.5 * (dy * ua + dx * va);
            e[4] += 0.5 * (dz * va + dy * wa);
            e[5] += 0.5 * (dx * wa + dz * ua);
        }
        e
    }

    /// The volumetric strain the formulation uses at Gauss point `gp`.
    pub fn dilatation(&self, formulation: Formulation, gp: usize, u: &[f64; 24]) -> f64 {
        let grad = match formulation {
            Formulation::Plain => &self.grad[gp],
            Formulation::BBar => &self.mean_grad,
        };
        (0..8).map(|a| (0..3).map(|k| grad[a][k] * u[3 * a + k]).sum::<f64>()).sum()
    }

    /// The stress (tensor components, MPa) at Gauss point `gp` for shear
    /// modulus `g_mpa` and bulk modulus `k_mpa`.
    pub fn stress(&self, formulation: Formulation, gp: usize, g_mpa: f64, k_mpa: f64, u: &[f64; 24]) -> [f64; 6] {
        let e = self.strain(gp, u);
        let mean = (e[0] + e[1] + e[2]) / 3.0;
        let p = k_mpa * self.dilatation(formulation, gp, u);
        [
            2.0 * g_mpa * (e[0] - mean) + p,
            2.0 * g_mpa * (e[1] - mean) + p,
            2.0 * g_mpa * (e[2] - mean) + p,
            2.0 * g_mpa * e[3],
            2.0 * g_mpa * e[4],
            2.0 * g_mpa * e[5],
        ]
    }

    /// Adds the nodal forces of a deviatoric stress `s` (tensor components
    /// xx, yy, zz, xy, yz, zx; MPa) at Gauss point `gp` to `f`: the
    /// transpose of the deviatoric strain operator, f_ai += w sum_j
    /// dev(s)_ij d_j N_a (for a deviator, dev(s) = s).
    pub fn add_deviator_force(&self, gp: usize, s: &[f64; 6], f: &mut [f64; 24]) {
        let w = self.weight[gp];
        let mean = (s[0] + s[1] + s[2]) / 3.0;
        let t = [[s[0] - mean, s[3], s[5]], [s[3], s[1] - mean, s[4]], [s[5], s[4], s[2] - mean]];
        for a in 0..8 {
            let g = self.grad[gp][a];
            for i in 0..3 {
                f[3 * a + i] += w * (t[i][0] * g[0] + t[i][1] * g[1] + t[i][2] * g[2]);
            }
        }
    }

    /// Element stiffness (24 x 24, DOFs u_a, v_a, w_a interleaved) for
    /// shear modulus `g_mpa` and bulk modulus `k_mpa`: the second variation
    /// of the energy G dev(eps):dev(eps) + K/2 theta^2, i.e. for node a in
    /// direction i and node b in direction k
    ///
    ///   2G sum_gp w [ (delta_ik grad N_a . grad N_b + d_k N_a d_i N_b) / 2
    ///                 - d_i N_a d_k N_b / 3 ]  +  volumetric part,
    ///
    /// the volumetric part K sum_gp w d_i N_a d_k N_b (plain) or
    /// K V bbar_ai bbar_bk (B-bar).
    pub fn stiffness(&self, formulation: Formulation, g_mpa: f64, k_mpa: f64) -> [[f64; 24]; 24] {
        let mut k = [[0.0; 24]; 24];
        for gp in 0..8 {
            let g = &self.grad[gp];
            let w = self.weight[gp] * 2.0 * g_mpa;
            for a in 0..8 {
                for b in 0..8 {
                    let dot = g[a][0] * g[b][0] + g[a][1] * g[b][1] + g[a][2] * g[b][2];
                    for i in 0..3 {
                        for m in 0..3 {
                            let mut v = 0.5 * g[a][m] * g[b][i] - g[a][i] * g[b][m] / 3.0;
                            if i == m {
                                v += 0.5 * dot;
                            }
                            k[3 * a + i][3 * b + m] += w * v;
                        }
                    }
                }
            }
            if formulation == Formulation::Plain {
                add_volumetric(&mut k, g, self.weight[gp] * k_mpa);
            }
        }
        if formulation == Formulation::BBar {
            add_volumetric(&mut k, &self.mean_grad, self.volume * k_mpa);
        }
        k
    }
}

/// k += scale b b^T with b_{3a+i} = grad[a][i].
fn add_volumetric(k: &mut [[f64; 24]; 24], grad: &[[f64; 3]; 8], scale: f64) {
    for a in 0..8 {
        for i in 0..3 {
            for b in 0..8 {
                for m in 0..3 {
                    k[3 * a + i][3 * b + m] += scale * grad[a][i] * grad[b][m];
                }
            }
        }
    }
}

/// Determinant and inverse of a 3x3 matrix (the inverse is meaningless
/// when the determinant is zero; callers check it first).
pub(crate) fn invert3(j: &[[f64; 3]; 3]) -> (f64, [[f64; 3]; 3]) {
    let c = |r0: usize, c0: usize, r1: usize, c1: usize| j[r0][c0] * j[r1][c1] - j[r0][c1] * j[r1][c0];
    let cof = [
        [c(1, 1, 2, 2), -c(1, 0, 2, 2), c(1, 0, 2, 1)],
        [-c(0, 1, 2, 2), c(0, 0, 2, 2), -c(0, 0, 2, 1)],
        [c(0, 1, 1, 2), -c(0, 0, 1, 2), c(0, 0, 1, 1)],
    ];
    let det = j[0][0] * cof[0][0] + j[0][1] * cof[0][1] + j[0][2] * cof[0][2];
    // inverse = adjugate / det = cof^T / det
    let inv = std::array::from_fn(|r| std::array::from_fn(|col| cof[col][r] / det));
    (det, inv)
}

/// The forces K_e u_p on an element's 24 DOFs `dofs` from the prescribed
/// displacements among them (`prescribed(d)`: global DOF d's prescribed
/// value, or `None` if it is free): what moves a body's free unknowns
/// when its driven nodes move (the load of a prescribed displacement is
/// its negative).
pub fn prescribed_forces(
    k: &[[f64; 24]; 24],
    dofs: &[usize; 24],
    prescribed: impl Fn(usize) -> Option<f64>,
) -> [f64; 24] {
    let values: [Option<f64>; 24] = std::array::from_fn(|j| prescribed(dofs[j]).filter(|&v| v != 0.0));
    std::array::from_fn(|i| values.iter().enumerate().filter_map(|(j, v)| v.map(|v| k[i][j] * v)).sum())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hexahedron with its corners moved off the unit cube.
    fn distorted_nodes() -> [[f64; 3]; 8] {
        let moves = [
            [0.1, -0.05, 0.0],
            [0.2, 0.1, -0.1],
            [-0.1, 0.15, 0.05],
            [0.0, -0.1, 0.1],
            [0.05, 0.0, -0.15],
            [-0.1, 0.05, 0.1],
            [0.15, -0.1, 0.0],
            [0.0, 0.1, -0.05],
        ];
        std::array::from_fn(|a| std::array::from_fn(|k| CORNERS[a][k] + moves[a][k]))
    }

    #[test]
    fn volume_of_a_parallelepiped_and_partition_of_unity() {
        // The cube [-1,1]^3 sheared by a constant matrix: volume 8 det(A).
        let a = [[1.2, 0.3, 0.0], [0.1, 0.9, 0.2], [0.0, -0.2, 1.1]];
        let x: [[f64; 3]; 8] =
            std::array::from_fn(|n| std::array::from_fn(|k| (0..3).map(|i| a[k][i] * CORNERS[n][i]).sum()));
        let h = Hex8::new(&x).unwrap();
        let det = invert3(&a).0;
        assert!((h.volume - 8.0 * det).abs() < 1e-12, "{} vs {}", h.volume, 8.0 * det);
        for gp in 0..8 {
            for k in 0..3 {
                assert!((0..8).map(|n| h.grad[gp][n][k]).sum::<f64>().abs() < 1e-13);
            }
        }
        assert!((shape_functions(0.3, -0.7, 0.1).iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }

    /// The six rigid-body modes are in the null space of both stiffness
    /// matrices, which are symmetric.
    #[test]
    fn stiffness_rigid_modes_and_symmetry() {
        let x = distorted_nodes();
        let h = Hex8::new(&x).unwrap();
        let mut modes: Vec<[f64; 24]> = Vec::new();
        for d in 0..3 {
            modes.push(std::array::from_fn(|i| if i % 3 == d { 1.0 } else { 0.0 }));
        }
        // Infinitesimal rotations about x, y and z: u = omega x X.
        for axis in 0..3 {
            modes.push(std::array::from_fn(|i| {
                let (a, k) = (i / 3, i % 3);
                let p = x[a];
                let mut omega = [0.0; 3];
                omega[axis] = 1.0;
                let cross = [
                    omega[1] * p[2] - omega[2] * p[1],
                    omega[2] * p[0] - omega[0] * p[2],
                    omega[0] * p[1] - omega[1] * p[0],
                ];
                cross[k]
            }));
        }
        for formulation in [Formulation::Plain, Formulation::BBar] {
            let k = h.stiffness(formulation, 0.7, 20.0);
            for i in 0..24 {
                for j in 0..24 {
                    assert!((k[i][j] - k[j][i]).abs() < 1e-11, "{formulation:?} asymmetric at {i},{j}");
                }
            }
            for mode in &modes {
                for row in &k {
                    let f: f64 = row.iter().zip(mode).map(|(a, b)| a * b).sum();
                    assert!(f.abs() < 1e-11, "{formulation:?}: {f}");
                }
            }
            // Positive on a deformation mode.
            let stretch: [f64; 24] = std::array::from_fn(|i| if i % 3 == 0 { x[i / 3][0] } else { 0.0 });
            let energy: f64 = (0..24).map(|i| (0..24).map(|j| stretch[i] * k[i][j] * stretch[j]).sum::<f64>()).sum();
            assert!(energy > 0.0);
        }
    }

    /// The energy of a uniform strain is its exact value: K u . u / 2 =
    /// V (G dev eps : dev eps + K theta^2 / 2), for both formulations.
    #[test]
    fn uniform_strain_energy_is_exact() {
        let x = distorted_nodes();
        let h = Hex8::new(&x).unwrap();
        let grad_u = [[0.01, 0.002, -0.003], [0.004, -0.02, 0.001], [0.0, 0.005, 0.015]];
        let u: [f64; 24] = std::array::from_fn(|i| (0..3).map(|m| grad_u[i % 3][m] * x[i / 3][m]).sum());
        let eps: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| 0.5 * (grad_u[i][j] + grad_u[j][i])));
        let theta = eps[0][0] + eps[1][1] + eps[2][2];
        let dev2: f64 = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| {
                let d = eps[i][j] - if i == j { theta / 3.0 } else { 0.0 };
                d * d
            })
            .sum();
        let (g, bulk) = (0.3, 5.0);
        let exact = h.volume * (g * dev2 + 0.5 * bulk * theta * theta);
        for formulation in [Formulation::Plain, Formulation::BBar] {
            let k = h.stiffness(formulation, g, bulk);
            let energy: f64 = 0.5 * (0..24).map(|i| (0..24).map(|j| u[i] * k[i][j] * u[j]).sum::<f64>()).sum::<f64>();
            assert!((energy - exact).abs() < 1e-12 * exact.abs().max(1e-12), "{formulation:?}: {energy} vs {exact}");
            for gp in 0..8 {
                let s = h.stress(formulation, gp, g, bulk, &u);
                assert!((s[0] - (2.0 * g * (eps[0][0] - theta / 3.0) + bulk * theta)).abs() < 1e-12);
                assert!((s[4] - 2.0 * g * eps[1][2]).abs() < 1e-12);
            }
        }
    }

    /// The deviator forces are the transpose of the stiffness's deviatoric
    /// part: sum_gp w Bd^T (2G dev eps(u)) = K(G, K = 0) u.
    #[test]
    fn deviator_forces_are_the_stiffness_transpose() {
        let x = distorted_nodes();
        let h = Hex8::new(&x).unwrap();
        let u: [f64; 24] = std::array::from_fn(|i| 0.01 * ((i * 7 % 11) as f64 - 5.0));
        let g = 0.4;
        let k = h.stiffness(Formulation::BBar, g, 0.0);
        let mut f = [0.0; 24];
        for gp in 0..8 {
            let e = h.strain(gp, &u);
            let mean = (e[0] + e[1] + e[2]) / 3.0;
            let s = [e[0] - mean, e[1] - mean, e[2] - mean, e[3], e[4], e[5]].map(|v| 2.0 * g * v);
            h.add_deviator_force(gp, &s, &mut f);
        }
        for i in 0..24 {
            let ku: f64 = (0..24).map(|j| k[i][j] * u[j]).sum();
            assert!((ku - f[i]).abs() < 1e-14, "row {i}: {ku} vs {}", f[i]);
        }
    }

    proptest::proptest! {
        /// Patch property: on any hexahedron with corners moved by up to
        /// 0.3 off the cube, an affine displacement field gives its exact
        /// constant strain at every Gauss point (1e-12).
        #[test]
        fn affine_field_gives_exact_strain_on_random_hexahedra(
            moves in proptest::collection::vec(-0.3f64..0.3, 24),
            a in proptest::collection::vec(-1.0f64..1.0, 12),
        ) {
            let x: [[f64; 3]; 8] = std::array::from_fn(|n| std::array::from_fn(|k| CORNERS[n][k] + moves[3 * n + k]));
            let h = Hex8::new(&x).unwrap();
            // u_k = a[4k] + sum_m a[4k+1+m] x_m
            let u: [f64; 24] = std::array::from_fn(|i| {
                let (n, k) = (i / 3, i % 3);
                a[4 * k] + (0..3).map(|m| a[4 * k + 1 + m] * x[n][m]).sum::<f64>()
            });
            let du = |k: usize, m: usize| a[4 * k + 1 + m];
            let exact = [du(0, 0), du(1, 1), du(2, 2), 0.5 * (du(0, 1) + du(1, 0)), 0.5 * (du(1, 2) + du(2, 1)), 0.5 * (du(2, 0) + du(0, 2))];
            for gp in 0..8 {
                let e = h.strain(gp, &u);
                for k in 0..6 {
                    proptest::prop_assert!((e[k] - exact[k]).abs() < 1e-12);
                }
                proptest::prop_assert!((h.dilatation(Formulation::BBar, gp, &u) - (exact[0] + exact[1] + exact[2])).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn inverted_element_is_rejected() {
        let mut x = CORNERS;
        x.swap(0, 1);
        x.swap(2, 3);
        x.swap(4, 5);
        x.swap(6, 7);
        let err = Hex8::new(&x).unwrap_err();
        assert!(err.det_j < 0.0);
    }
}
