//! The total-Lagrangian Q4 for finite strain, with the mean-dilatation
//! treatment of the volume change (the finite-strain B-bar: the Q1/P0
//! element of Simo, Taylor & Pister 1985; de Souza Neto, Peric & Owen,
//! Computational Methods for Plasticity, 2008, sec. 15.2-15.3).
//!
//! The element's energy is
//!
//! ```text
//!   Pi_e(u) = sum_gp w_gp W_iso(F_gp) + V_e U(Jbar),   Jbar = v_e / V_e,
//! ```
//!
//! with the isochoric part at each of the 2x2 Gauss points and the
//! volumetric part at the element's mean dilatation: its current area v_e
//! over its reference area V_e (J is bilinear over a Q4, so the 2x2 rule
//! gives v_e exactly). With the decoupled neo-Hookean law this is the
//! Q1/P0 element whose Fbar = (Jbar/J)^(1/3) F has the isochoric part of F
//! and the determinant Jbar; it does not lock as nu -> 0.5, and at small
//! strain it is exactly the small-strain B-bar element of
//! [`crate::element`] (pointwise deviator, element-mean dilatation).
//!
//! Internal force and consistent tangent, nodes a, b, directions i, j:
//!
//! ```text
//!   f_ai   = sum_gp w (F S)_iK N_a,K + U'(Jbar) g_ai,           g_ai = dv/du_ai = sum_gp w cof(F)_iK N_a,K
//!   K_aibj = sum_gp w [ B^T D B + delta_ij N_a,K S_KL N_b,L ]
//!          + U''(Jbar)/V g_ai g_bj + U'(Jbar) eps_ij sum_gp w (N_a,1 N_b,2 - N_a,2 N_b,1)
//! ```
//!
//! (v is quadratic in the nodal positions, hence the constant last term.)
//! S is the isochoric second Piola-Kirchhoff stress, shear_ratio S0_iso(C)
//! plus the visco-elastic history part frozen over the step
//! ([`crate::hyperelastic`]), D = shear_ratio dS0_iso/dE.

use crate::element::Q4;
use crate::hyperelastic::{NeoHookean, push_forward};

/// The deformed element is inverted or degenerate.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("element inverted: det F = {det_f:e} at Gauss point {gauss_point} (4: the element's mean)")]
pub struct Inverted {
    pub gauss_point: usize,
    pub det_f: f64,
}

/// The in-plane deformation gradient F = I + grad_X u at Gauss point `gp`
/// (`f[i][k]` = dx_i / dX_k).
pub fn deformation_gradient(q: &Q4, gp: usize, u: &[f64; 8]) -> [[f64; 2]; 2] {
    let mut f = [[1.0, 0.0], [0.0, 1.0]];
    for a in 0..4 {
        for i in 0..2 {
            for k in 0..2 {
                f[i][k] += u[2 * a + i] * q.grad[gp][a][k];
            }
        }
    }
    f
}

fn det(f: &[[f64; 2]; 2]) -> f64 {
    f[0][0] * f[1][1] - f[0][1] * f[1][0]
}

/// The mean dilatation Jbar = v / V of the element (current over
/// reference area).
pub fn mean_dilatation(q: &Q4, u: &[f64; 8]) -> f64 {
    (0..4).map(|gp| q.weight[gp] * det(&deformation_gradient(q, gp, u))).sum::<f64>() / q.area
}

/// The instantaneous isochoric stress S0_iso (11, 22, 33, 12) at each Gauss
/// point (what the visco-elastic history records).
pub fn isochoric_stresses(q: &Q4, u: &[f64; 8], law: &NeoHookean) -> [[f64; 4]; 4] {
    std::array::from_fn(|gp| law.isochoric_stress(&deformation_gradient(q, gp, u)))
}

/// Internal nodal forces (u_a, v_a interleaved; N per mm of width) of the
/// element at displacement `u`, with the isochoric stress
/// `shear_ratio S0_iso(C) + frozen[gp]`; with `tangent`, its consistent
/// derivative (8x8, row-major, symmetric) is written there.
pub fn internal_force(
    q: &Q4,
    u: &[f64; 8],
    law: &NeoHookean,
    shear_ratio: f64,
    frozen: &[[f64; 4]; 4],
    mut tangent: Option<&mut [[f64; 8]; 8]>,
) -> Result<[f64; 8], Inverted> {
    let mut force = [0.0; 8];
    let mut g = [0.0; 8];
    let mut area = 0.0;
    if let Some(k) = tangent.as_deref_mut() {
        *k = [[0.0; 8]; 8];
    }
    for gp in 0..4 {
        let f = deformation_gradient(q, gp, u);
        let j = det(&f);
        if j.is_nan() || j <= 0.0 {
            return Err(Inverted { gauss_point: gp, det_f: j });
        }
        let w = q.weight[gp];
        let n = &q.grad[gp];
        area += w * j;
        let (s0, d) = match tangent {
            Some(_) => {
                let response = law.isochoric(&f);
                (response.stress, response.tangent)
            }
            None => (law.isochoric_stress(&f), [[0.0; 3]; 3]),
        };
        let s: [f64; 4] = std::array::from_fn(|k| shear_ratio * s0[k] + frozen[gp][k]);
        let sm = [[s[0], s[3]], [s[3], s[1]]];
        // P = F S (in plane).
        let mut p = [[0.0; 2]; 2];
        for i in 0..2 {
            for k in 0..2 {
                p[i][k] = f[i][0] * sm[0][k] + f[i][1] * sm[1][k];
            }
        }
        let cof = [[f[1][1], -f[1][0]], [-f[0][1], f[0][0]]];
        for a in 0..4 {
            for i in 0..2 {
                force[2 * a + i] += w * (p[i][0] * n[a][0] + p[i][1] * n[a][1]);
                g[2 * a + i] += w * (cof[i][0] * n[a][0] + cof[i][1] * n[a][1]);
            }
        }
        if let Some(k) = tangent.as_deref_mut() {
            // B: dE (Voigt 11, 22, 2 12) / du.
            let mut b = [[0.0; 8]; 3];
            for a in 0..4 {
                for i in 0..2 {
                    b[0][2 * a + i] = f[i][0] * n[a][0];
                    b[1][2 * a + i] = f[i][1] * n[a][1];
                    b[2][2 * a + i] = f[i][0] * n[a][1] + f[i][1] * n[a][0];
                }
            }
            let mut db = [[0.0; 8]; 3];
            for r in 0..3 {
                for c in 0..8 {
                    db[r][c] = shear_ratio * (d[r][0] * b[0][c] + d[r][1] * b[1][c] + d[r][2] * b[2][c]);
                }
            }
            for r in 0..8 {
                for c in 0..8 {
                    k[r][c] += w * (b[0][r] * db[0][c] + b[1][r] * db[1][c] + b[2][r] * db[2][c]);
                }
            }
            for a in 0..4 {
                for bb in 0..4 {
                    let geometric = w
                        * (n[a][0] * (sm[0][0] * n[bb][0] + sm[0][1] * n[bb][1])
                            + n[a][1] * (sm[1][0] * n[bb][0] + sm[1][1] * n[bb][1]));
                    k[2 * a][2 * bb] += geometric;
                    k[2 * a + 1][2 * bb + 1] += geometric;
                }
            }
        }
    }
    let j_bar = area / q.area;
    if j_bar.is_nan() || j_bar <= 0.0 {
        return Err(Inverted { gauss_point: 4, det_f: j_bar });
    }
    let (pressure, stiffness) = law.volumetric(j_bar);
    for r in 0..8 {
        force[r] += pressure * g[r];
    }
    if let Some(k) = tangent {
        for r in 0..8 {
            for c in 0..8 {
                k[r][c] += stiffness / q.area * g[r] * g[c];
            }
        }
        for gp in 0..4 {
            let (w, n) = (q.weight[gp], &q.grad[gp]);
            for a in 0..4 {
                for bb in 0..4 {
                    let h = pressure * w * (n[a][0] * n[bb][1] - n[a][1] * n[bb][0]);
                    k[2 * a][2 * bb + 1] += h;
                    k[2 * a + 1][2 * bb] -= h;
                }
            }
        }
    }
    Ok(force)
}

/// The Cauchy stress (xx, yy, zz, xy; MPa) at Gauss point `gp` for the
/// isochoric second Piola-Kirchhoff stress `s_iso` there: the push-forward
/// of s_iso plus the element's pressure U'(Jbar).
pub fn cauchy_stress(q: &Q4, gp: usize, u: &[f64; 8], law: &NeoHookean, s_iso: &[f64; 4]) -> [f64; 4] {
    let f = deformation_gradient(q, gp, u);
    let (p, _) = law.volumetric(mean_dilatation(q, u));
    let sigma = push_forward(&f, s_iso);
    [sigma[0] + p, sigma[1] + p, sigma[2] + p, sigma[3]]
}
