//! The total-Lagrangian Hex8 for finite strain (NLGEOM, issue 39): the 2D
//! model's finite-strain element ([`crate::finite_element`]) one dimension
//! up. The mean-dilatation treatment of the volume change (the Q1/P0
//! element of Simo, Taylor & Pister 1985; de Souza Neto, Peric & Owen,
//! Computational Methods for Plasticity, 2008, sec. 15.2-15.3) with the
//! decoupled neo-Hookean law of [`crate::hyperelastic`] in 3D:
//!
//! ```text
//!   Pi_e(u) = sum_gp w_gp W_iso(F_gp) + V_e U(Jbar),   Jbar = v_e / V_e,
//!   W_iso(F) = mu/2 (J^(-2/3) tr C - 3),
//! ```
//!
//! the isochoric part at each of the 2x2x2 Gauss points and the
//! volumetric part at the element's mean dilatation, its current volume
//! v_e = sum_gp w J over its reference volume V_e (exact: J of a trilinear
//! map is of degree 2 in each reference coordinate). At small strain it is
//! the small-strain B-bar element of [`super::hex8`] (pointwise deviator,
//! element-mean dilatation); it does not lock as nu -> 0.5.
//!
//! Internal force and consistent tangent, nodes a, b, directions i, j,
//! with n_a = F^-T grad_X N_a the spatial gradients:
//!
//! ```text
//!   f_ai   = sum_gp w (F S)_iK N_a,K + U'(Jbar) g_ai,        g_ai = dv/du_ai = sum_gp w J n_ai
//!   K_aibj = sum_gp w [ B^T D B + delta_ij N_a,K S_KL N_b,L ]
//!          + U''(Jbar)/V g_ai g_bj + U'(Jbar) sum_gp w J (n_ai n_bj - n_aj n_bi)
//! ```
//!
//! (the last term is the second derivative of v: d cof(F)_iK / dF_jL =
//! J (F^-1_Ki F^-1_Lj - F^-1_Kj F^-1_Li)). S is the isochoric second
//! Piola-Kirchhoff stress, shear_ratio S0_iso(C) plus a visco-elastic
//! history part frozen over the step, D = shear_ratio dS0_iso/dE (Holzapfel,
//! Nonlinear Solid Mechanics, 2000, eq. 6.168), as in 2D.
//!
//! Symmetric tensors are stored as (11, 22, 33, 12, 23, 31), the small-strain
//! element's order; tangents in Voigt order with engineering shears.

use super::hex8::{Hex8, invert3};
use crate::finite_element::Inverted;
use crate::hyperelastic::inverse_cbrt_squared;
use crate::material::Material;

/// Voigt index -> tensor index pair.
const VOIGT: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)];

/// The volumetric function U(J) of the law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Volumetric {
    /// U(J) = K/4 (J^2 - 1 - 2 ln J) (Simo & Taylor 1991; polyconvex,
    /// infinite as J -> 0): the 2D model's.
    #[default]
    SimoTaylor,
    /// U(J) = K/2 (J - 1)^2: CalculiX's (and Abaqus's) `*HYPERELASTIC, NEO
    /// HOOKE` with D1 = 2/K, for comparisons with it.
    Quadratic,
}

impl Volumetric {
    /// U(J) for the bulk modulus `kappa`.
    pub fn energy(self, kappa: f64, j: f64) -> f64 {
        match self {
            Self::SimoTaylor => 0.25 * kappa * (j * j - 1.0 - 2.0 * j.ln()),
            Self::Quadratic => 0.5 * kappa * (j - 1.0) * (j - 1.0),
        }
    }

    /// U'(J) (the Cauchy pressure, positive in tension) and U''(J).
    pub fn derivatives(self, kappa: f64, j: f64) -> (f64, f64) {
        match self {
            Self::SimoTaylor => (0.5 * kappa * (j - 1.0 / j), 0.5 * kappa * (1.0 + 1.0 / (j * j))),
            Self::Quadratic => (kappa * (j - 1.0), kappa),
        }
    }
}

/// The decoupled neo-Hookean law in 3D.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeoHookean3 {
    /// Shear modulus mu (instantaneous), MPa.
    pub mu: f64,
    /// Bulk modulus K, MPa.
    pub kappa: f64,
    pub volumetric: Volumetric,
}

impl NeoHookean3 {
    /// The law with the small-strain moduli of `material` (mu = G0, K), the
    /// 2D model's volumetric function.
    pub fn from_material(material: &Material) -> Self {
        Self { mu: material.shear_mpa(), kappa: material.bulk_mpa(), volumetric: Volumetric::SimoTaylor }
    }

    /// The same moduli with another volumetric function.
    pub fn with_volumetric(self, volumetric: Volumetric) -> Self {
        Self { volumetric, ..self }
    }

    /// The elastic energy per reference volume at `f`: mu/2 (I1bar - 3) + U(J).
    pub fn energy(&self, f: &[[f64; 3]; 3]) -> f64 {
        let j = det3(f);
        let i1: f64 = f.iter().flatten().map(|v| v * v).sum();
        0.5 * self.mu * (inverse_cbrt_squared(j) * i1 - 3.0) + self.volumetric.energy(self.kappa, j)
    }

    /// The instantaneous isochoric second Piola-Kirchhoff stress S0_iso =
    /// mu J^(-2/3) (I - I1/3 C^-1) at `f`.
    pub fn isochoric_stress(&self, f: &[[f64; 3]; 3]) -> [f64; 6] {
        isochoric_parts(self.mu, f).0
    }

    /// The Cauchy stress (xx, yy, zz, xy, yz, zx) of a homogeneous
    /// deformation `f` of the elastic law: sigma = mu/J dev(bbar) + U'(J) I
    /// with bbar = J^(-2/3) F F^T. The analytic reference of the
    /// validation tests.
    pub fn cauchy_stress(&self, f: &[[f64; 3]; 3]) -> [f64; 6] {
        let j = det3(f);
        let b = |r: usize, c: usize| (0..3).map(|k| f[r][k] * f[c][k]).sum::<f64>();
        let s = inverse_cbrt_squared(j);
        let trace = s * (b(0, 0) + b(1, 1) + b(2, 2));
        let (p, _) = self.volumetric.derivatives(self.kappa, j);
        let g = self.mu / j;
        std::array::from_fn(|c| {
            let (r, k) = VOIGT[c];
            let dev = s * b(r, k) - if r == k { trace / 3.0 } else { 0.0 };
            g * dev + if r == k { p } else { 0.0 }
        })
    }
}

/// det of a 3x3 matrix.
pub fn det3(f: &[[f64; 3]; 3]) -> f64 {
    f[0][0] * (f[1][1] * f[2][2] - f[1][2] * f[2][1]) - f[0][1] * (f[1][0] * f[2][2] - f[1][2] * f[2][0])
        + f[0][2] * (f[1][0] * f[2][1] - f[1][1] * f[2][0])
}

/// S0_iso (6 components), C^-1, I1 and a = mu J^(-2/3) at `f`.
fn isochoric_parts(mu: f64, f: &[[f64; 3]; 3]) -> ([f64; 6], [[f64; 3]; 3], f64, f64) {
    let mut c = [[0.0; 3]; 3];
    for r in 0..3 {
        for k in 0..3 {
            c[r][k] = (0..3).map(|i| f[i][r] * f[i][k]).sum();
        }
    }
    let (det_c, ci) = invert3(&c);
    let i1 = c[0][0] + c[1][1] + c[2][2];
    // J^(-2/3) = (det C)^(-1/3), which is defined for det F < 0 too; the
    // caller refuses such a point.
    let a = mu * inverse_cbrt_squared(det_c.sqrt());
    let stress = std::array::from_fn(|v| {
        let (r, k) = VOIGT[v];
        a * (if r == k { 1.0 } else { 0.0 } - i1 / 3.0 * ci[r][k])
    });
    (stress, ci, i1, a)
}

/// dS0_iso/dE (Voigt, engineering shears) from C^-1, I1 and a:
///
/// a [ -2/3 (I x C^-1 + C^-1 x I) + 2/9 I1 C^-1 x C^-1 + 2/3 I1 C^-1 (.) C^-1 ].
fn isochoric_tangent(ci: &[[f64; 3]; 3], i1: f64, a: f64) -> [[f64; 6]; 6] {
    let mut d = [[0.0; 6]; 6];
    for (r, &(i, j)) in VOIGT.iter().enumerate() {
        for (s, &(k, l)) in VOIGT.iter().enumerate() {
            let delta_ij = if i == j { 1.0 } else { 0.0 };
            let delta_kl = if k == l { 1.0 } else { 0.0 };
            d[r][s] = a
                * (-2.0 / 3.0 * (delta_ij * ci[k][l] + ci[i][j] * delta_kl)
                    + 2.0 / 9.0 * i1 * ci[i][j] * ci[k][l]
                    + 2.0 / 3.0 * i1 * 0.5 * (ci[i][k] * ci[j][l] + ci[i][l] * ci[j][k]));
        }
    }
    d
}

/// F = I + grad_X u at Gauss point `gp` of `h` for the element
/// displacements `u` (u_a, v_a, w_a interleaved): `f[i][k]` = dx_i/dX_k.
pub fn deformation_gradient(h: &Hex8, gp: usize, u: &[f64; 24]) -> [[f64; 3]; 3] {
    let n = &h.grad[gp];
    let mut f = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for a in 0..8 {
        for i in 0..3 {
            for k in 0..3 {
                f[i][k] += u[3 * a + i] * n[a][k];
            }
        }
    }
    f
}

/// Jbar, the element's current volume over its reference volume.
pub fn mean_dilatation(h: &Hex8, u: &[f64; 24]) -> f64 {
    (0..8).map(|gp| h.weight[gp] * det3(&deformation_gradient(h, gp, u))).sum::<f64>() / h.volume
}

/// S0_iso at each Gauss point (what the visco-elastic history records).
pub fn isochoric_stresses(h: &Hex8, u: &[f64; 24], law: &NeoHookean3) -> [[f64; 6]; 8] {
    std::array::from_fn(|gp| law.isochoric_stress(&deformation_gradient(h, gp, u)))
}

/// The element's elastic energy (shear ratio 1, no history), mJ: what the
/// internal force derives from.
pub fn energy(h: &Hex8, u: &[f64; 24], law: &NeoHookean3) -> f64 {
    let mut iso = 0.0;
    for gp in 0..8 {
        let f = deformation_gradient(h, gp, u);
        let i1: f64 = f.iter().flatten().map(|v| v * v).sum();
        iso += h.weight[gp] * 0.5 * law.mu * (inverse_cbrt_squared(det3(&f)) * i1 - 3.0);
    }
    iso + h.volume * law.volumetric.energy(law.kappa, mean_dilatation(h, u))
}

/// Internal nodal forces (N; u_a, v_a, w_a interleaved) of the element at
/// displacement `u`, with the isochoric stress `shear_ratio S0_iso(C) +
/// frozen[gp]`; with `tangent`, its consistent derivative (24 x 24,
/// symmetric) is written there. Refused where det F or Jbar is not
/// positive.
pub fn internal_force(
    h: &Hex8,
    u: &[f64; 24],
    law: &NeoHookean3,
    shear_ratio: f64,
    frozen: &[[f64; 6]; 8],
    mut tangent: Option<&mut [[f64; 24]; 24]>,
) -> Result<[f64; 24], Inverted> {
    let mut force = [0.0; 24];
    let mut g = [0.0; 24];
    let mut volume = 0.0;
    // sum_gp w J (n_ai n_bj - n_aj n_bi), with the tangent only.
    let mut second = [[0.0; 24]; 24];
    if let Some(k) = tangent.as_deref_mut() {
        *k = [[0.0; 24]; 24];
    }
    for gp in 0..8 {
        let n = &h.grad[gp];
        let f = deformation_gradient(h, gp, u);
        let (j, f_inv) = invert3(&f);
        if j.is_nan() || j <= 0.0 {
            return Err(Inverted { gauss_point: Some(gp), det_f: j });
        }
        let w = h.weight[gp];
        volume += w * j;
        let (s0, ci, i1, a) = isochoric_parts(law.mu, &f);
        let s: [f64; 6] = std::array::from_fn(|v| shear_ratio * s0[v] + frozen[gp][v]);
        let sm = [[s[0], s[3], s[5]], [s[3], s[1], s[4]], [s[5], s[4], s[2]]];
        // P = F S, the first Piola-Kirchhoff stress of the isochoric part.
        let mut p = [[0.0; 3]; 3];
        for i in 0..3 {
            for k in 0..3 {
                p[i][k] = (0..3).map(|l| f[i][l] * sm[l][k]).sum();
            }
        }
        // Spatial gradients n_a = F^-T grad_X N_a.
        let spatial: [[f64; 3]; 8] =
            std::array::from_fn(|b| std::array::from_fn(|i| (0..3).map(|k| f_inv[k][i] * n[b][k]).sum()));
        for b in 0..8 {
            for i in 0..3 {
                force[3 * b + i] += w * (p[i][0] * n[b][0] + p[i][1] * n[b][1] + p[i][2] * n[b][2]);
                g[3 * b + i] += w * j * spatial[b][i];
            }
        }
        let Some(k) = tangent.as_deref_mut() else { continue };
        let d = isochoric_tangent(&ci, i1, a);
        // B: dE (Voigt, engineering shears) / du.
        let mut bm = [[0.0; 24]; 6];
        for b in 0..8 {
            let nb = n[b];
            for i in 0..3 {
                let c = 3 * b + i;
                bm[0][c] = f[i][0] * nb[0];
                bm[1][c] = f[i][1] * nb[1];
                bm[2][c] = f[i][2] * nb[2];
                bm[3][c] = f[i][0] * nb[1] + f[i][1] * nb[0];
                bm[4][c] = f[i][1] * nb[2] + f[i][2] * nb[1];
                bm[5][c] = f[i][2] * nb[0] + f[i][0] * nb[2];
            }
        }
        let mut db = [[0.0; 24]; 6];
        for r in 0..6 {
            for c in 0..24 {
                db[r][c] = shear_ratio * (0..6).map(|q| d[r][q] * bm[q][c]).sum::<f64>();
            }
        }
        for r in 0..24 {
            for c in 0..24 {
                k[r][c] += w * (0..6).map(|q| bm[q][r] * db[q][c]).sum::<f64>();
            }
        }
        for a in 0..8 {
            for b in 0..8 {
                let geometric = w
                    * (0..3)
                        .map(|kk| n[a][kk] * (sm[kk][0] * n[b][0] + sm[kk][1] * n[b][1] + sm[kk][2] * n[b][2]))
                        .sum::<f64>();
                for i in 0..3 {
                    k[3 * a + i][3 * b + i] += geometric;
                }
                for i in 0..3 {
                    for jj in 0..3 {
                        second[3 * a + i][3 * b + jj] +=
                            w * j * (spatial[a][i] * spatial[b][jj] - spatial[a][jj] * spatial[b][i]);
                    }
                }
            }
        }
    }
    let j_bar = volume / h.volume;
    if j_bar.is_nan() || j_bar <= 0.0 {
        return Err(Inverted { gauss_point: None, det_f: j_bar });
    }
    let (pressure, stiffness) = law.volumetric.derivatives(law.kappa, j_bar);
    for r in 0..24 {
        force[r] += pressure * g[r];
    }
    if let Some(k) = tangent {
        for r in 0..24 {
            for c in 0..24 {
                k[r][c] += stiffness / h.volume * g[r] * g[c] + pressure * second[r][c];
            }
        }
    }
    Ok(force)
}

/// The Cauchy stress (xx, yy, zz, xy, yz, zx; MPa) at Gauss point `gp` for
/// the isochoric second Piola-Kirchhoff stress `s_iso` there: F S F^T / J
/// plus the element's pressure U'(Jbar).
pub fn cauchy_stress(h: &Hex8, gp: usize, u: &[f64; 24], law: &NeoHookean3, s_iso: &[f64; 6]) -> [f64; 6] {
    let f = deformation_gradient(h, gp, u);
    let j = det3(&f);
    let (p, _) = law.volumetric.derivatives(law.kappa, mean_dilatation(h, u));
    let sm = [[s_iso[0], s_iso[3], s_iso[5]], [s_iso[3], s_iso[1], s_iso[4]], [s_iso[5], s_iso[4], s_iso[2]]];
    std::array::from_fn(|v| {
        let (r, k) = VOIGT[v];
        let mut sigma = 0.0;
        for l in 0..3 {
            for m in 0..3 {
                sigma += f[r][l] * sm[l][m] * f[k][m];
            }
        }
        sigma / j + if r == k { p } else { 0.0 }
    })
}
