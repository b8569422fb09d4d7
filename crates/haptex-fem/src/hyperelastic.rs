//! The finite-strain tissue law: a decoupled compressible neo-Hookean solid
//! with the small-strain moduli, and its finite-strain visco-elastic
//! extension (Simo 1987; Simo & Hughes, Computational Inelasticity, 1998,
//! sec. 10.3; Holzapfel, Nonlinear Solid Mechanics, 2000, sec. 6.10).
//!
//! Strain energy per reference volume, with the isochoric invariant
//! I1bar = J^(-2/3) tr C:
//!
//! ```text
//!   W(C) = mu/2 (I1bar - 3) + U(J),   U(J) = K/4 (J^2 - 1 - 2 ln J)
//! ```
//!
//! (the volumetric function of Simo & Taylor 1991, polyconvex, U'(1) = 0,
//! U''(1) = K), mu = E / (2 (1 + nu)) and K = E / (3 (1 - 2 nu)): at small
//! strain it is the linear material of [`crate::material`]. Plane strain:
//! F33 = 1, so C33 = 1 enters I1 and J = det of the in-plane F.
//!
//! Visco-elasticity: the Prony series acts on the isochoric second
//! Piola-Kirchhoff stress S0_iso(C) of the instantaneous law, with the same
//! weights g_i, times tau_i and the same exponential recursion as the
//! small-strain deviator (the functions of [`crate::material`] are used
//! as they are, on S components instead of Cauchy ones):
//!
//! ```text
//!   S_iso(n+1) = g_inf S0_iso(n+1) + sum_i H_i(n+1),
//!   H_i(n+1)   = exp(-dt/tau_i) H_i(n) + gamma_i (S0_iso(n+1) - S0_iso(n)),
//! ```
//!
//! i.e. S_iso(n+1) = shear_ratio S0_iso(C(n+1)) + S_frozen with the step's
//! constant S_frozen = sum_i (exp(-dt/tau_i) H_i(n) - gamma_i S0_iso(n)).
//! The second Piola-Kirchhoff stress is referred to the reference
//! configuration, so the recursion is objective; at small strain S0_iso is
//! 2 G0 dev(eps) and both formulations agree.
//!
//! Components are stored as (11, 22, 33, 12); in-plane tangents in Voigt
//! order (11, 22, 12) with engineering shear 2 E12.

use crate::lanes::Real;
use crate::material::Material;

/// The neo-Hookean constants of a tissue.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeoHookean {
    /// Shear modulus mu (instantaneous), MPa.
    pub mu: f64,
    /// Bulk modulus K, MPa.
    pub kappa: f64,
}

/// The isochoric response at one point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IsochoricResponse {
    /// Second Piola-Kirchhoff stress S0_iso (11, 22, 33, 12), MPa.
    pub stress: [f64; 4],
    /// dS/dE on the in-plane components, Voigt (11, 22, 12), MPa.
    pub tangent: [[f64; 3]; 3],
}

/// Voigt index -> tensor index pair (in plane).
const VOIGT: [(usize, usize); 3] = [(0, 0), (1, 1), (0, 1)];

impl NeoHookean {
    /// The law with the small-strain moduli of `material` (mu = G0, K).
    pub fn from_material(material: &Material) -> Self {
        Self { mu: material.shear_mpa(), kappa: material.bulk_mpa() }
    }

    /// U(J) = K/4 (J^2 - 1 - 2 ln J).
    pub fn volumetric_energy(&self, j: f64) -> f64 {
        0.25 * self.kappa * (j * j - 1.0 - 2.0 * j.ln())
    }

    /// U'(J) (the pressure, Cauchy, positive in tension) and U''(J).
    pub fn volumetric(&self, j: f64) -> (f64, f64) {
        volumetric(self.kappa, j)
    }

    /// The isochoric energy mu/2 (I1bar - 3) for the in-plane deformation
    /// gradient `f` (`f[i][j]` = dx_i/dX_j, F33 = 1).
    pub fn isochoric_energy(&self, f: &[[f64; 2]; 2]) -> f64 {
        let j = f[0][0] * f[1][1] - f[0][1] * f[1][0];
        let i1 = f[0][0] * f[0][0] + f[0][1] * f[0][1] + f[1][0] * f[1][0] + f[1][1] * f[1][1] + 1.0;
        0.5 * self.mu * (j.powf(-2.0 / 3.0) * i1 - 3.0)
    }

    /// Isochoric second Piola-Kirchhoff stress and its in-plane material
    /// tangent at the in-plane deformation gradient `f` (J > 0):
    ///
    /// S = mu J^(-2/3) (I - I1/3 C^-1),
    /// dS/dE = -2/3 mu J^(-2/3) (I x C^-1 + C^-1 x I) + 2/9 mu J^(-2/3) I1 C^-1 x C^-1
    ///         + 2/3 mu J^(-2/3) I1 (C^-1 (.) C^-1)    (Holzapfel 2000, eq. 6.168).
    pub fn isochoric(&self, f: &[[f64; 2]; 2]) -> IsochoricResponse {
        let (stress, ci, i1, a) = self.isochoric_parts(f);
        IsochoricResponse { stress, tangent: isochoric_tangent(&ci, i1, a) }
    }

    /// The isochoric second Piola-Kirchhoff stress alone (see
    /// [`NeoHookean::isochoric`]).
    pub fn isochoric_stress(&self, f: &[[f64; 2]; 2]) -> [f64; 4] {
        self.isochoric_parts(f).0
    }

    /// S0_iso, the in-plane C^-1, I1 and mu J^(-2/3).
    fn isochoric_parts(&self, f: &[[f64; 2]; 2]) -> ([f64; 4], [[f64; 2]; 2], f64, f64) {
        let j = f[0][0] * f[1][1] - f[0][1] * f[1][0];
        isochoric_parts(self.mu, f, inverse_cbrt_squared(j))
    }

    /// The Cauchy stress (xx, yy, zz, xy) of a homogeneous deformation `f`
    /// of the elastic law: sigma = mu/J dev(bbar) + U'(J) I, with
    /// bbar = J^(-2/3) F F^T (3D, F33 = 1). The analytic reference of the
    /// validation tests.
    pub fn cauchy_stress(&self, f: &[[f64; 2]; 2]) -> [f64; 4] {
        let j = f[0][0] * f[1][1] - f[0][1] * f[1][0];
        let b11 = f[0][0] * f[0][0] + f[0][1] * f[0][1];
        let b22 = f[1][0] * f[1][0] + f[1][1] * f[1][1];
        let b12 = f[0][0] * f[1][0] + f[0][1] * f[1][1];
        let s = j.powf(-2.0 / 3.0);
        let trace = s * (b11 + b22 + 1.0);
        let (p, _) = self.volumetric(j);
        let g = self.mu / j;
        [g * (s * b11 - trace / 3.0) + p, g * (s * b22 - trace / 3.0) + p, g * (s - trace / 3.0) + p, g * s * b12]
    }
}

/// U'(J) and U''(J) of the bulk modulus `kappa` (see
/// [`NeoHookean::volumetric`]), on f64 or on [`Lanes`](crate::lanes::Lanes).
#[inline(always)]
pub(crate) fn volumetric<T: Real>(kappa: T, j: T) -> (T, T) {
    let (half, one) = (kappa.constant(0.5), kappa.constant(1.0));
    (half * kappa * (j - one / j), half * kappa * (one + one / (j * j)))
}

/// S0_iso, the in-plane C^-1, I1 and mu J^(-2/3) of the shear modulus
/// `mu` at the in-plane deformation gradient `f`, given `j_23` = J^(-2/3)
/// (see [`NeoHookean::isochoric`]), on f64 or on
/// [`Lanes`](crate::lanes::Lanes).
#[inline(always)]
pub(crate) fn isochoric_parts<T: Real>(mu: T, f: &[[T; 2]; 2], j_23: T) -> ([T; 4], [[T; 2]; 2], T, T) {
    let (one, three) = (mu.constant(1.0), mu.constant(3.0));
    // C = F^T F (in plane), C33 = 1.
    let c11 = f[0][0] * f[0][0] + f[1][0] * f[1][0];
    let c22 = f[0][1] * f[0][1] + f[1][1] * f[1][1];
    let c12 = f[0][0] * f[0][1] + f[1][0] * f[1][1];
    let j = f[0][0] * f[1][1] - f[0][1] * f[1][0];
    let det_c = j * j;
    let ci = [[c22 / det_c, -c12 / det_c], [-c12 / det_c, c11 / det_c]];
    let i1 = c11 + c22 + one;
    let a = mu * j_23;
    let stress = [
        a * (one - i1 / three * ci[0][0]),
        a * (one - i1 / three * ci[1][1]),
        a * (one - i1 / three),
        -a * i1 / three * ci[0][1],
    ];
    (stress, ci, i1, a)
}

/// dS/dE of [`NeoHookean::isochoric`] (Voigt 11, 22, 12) from the parts
/// C^-1, I1 and a = mu J^(-2/3) of [`isochoric_parts`], on f64 or on
/// [`Lanes`](crate::lanes::Lanes).
#[inline(always)]
pub(crate) fn isochoric_tangent<T: Real>(ci: &[[T; 2]; 2], i1: T, a: T) -> [[T; 3]; 3] {
    let (zero, one) = (a.constant(0.0), a.constant(1.0));
    let (c1, c2, c3, half) = (a.constant(-2.0 / 3.0), a.constant(2.0 / 9.0), a.constant(2.0 / 3.0), a.constant(0.5));
    let mut tangent = [[zero; 3]; 3];
    for (r, &(i, jj)) in VOIGT.iter().enumerate() {
        for (s, &(k, l)) in VOIGT.iter().enumerate() {
            let (delta_ij, delta_kl) = (if i == jj { one } else { zero }, if k == l { one } else { zero });
            tangent[r][s] = c1 * a * (delta_ij * ci[k][l] + ci[i][jj] * delta_kl)
                + c2 * a * i1 * ci[i][jj] * ci[k][l]
                + c3 * a * i1 * half * (ci[i][k] * ci[jj][l] + ci[i][l] * ci[jj][k]);
        }
    }
    tangent
}

/// The Cauchy stress (xx, yy, zz, xy) of a second Piola-Kirchhoff stress
/// `s` (11, 22, 33, 12) under the in-plane deformation gradient `f`
/// (F33 = 1): sigma = F S F^T / J.
pub fn push_forward(f: &[[f64; 2]; 2], s: &[f64; 4]) -> [f64; 4] {
    let j = f[0][0] * f[1][1] - f[0][1] * f[1][0];
    let sm = [[s[0], s[3]], [s[3], s[1]]];
    let mut fs = [[0.0; 2]; 2];
    for i in 0..2 {
        for k in 0..2 {
            fs[i][k] = f[i][0] * sm[0][k] + f[i][1] * sm[1][k];
        }
    }
    let mut sigma = [[0.0; 2]; 2];
    for i in 0..2 {
        for k in 0..2 {
            sigma[i][k] = (fs[i][0] * f[k][0] + fs[i][1] * f[k][1]) / j;
        }
    }
    [sigma[0][0], sigma[1][1], s[2] / j, sigma[0][1]]
}

/// x^(-2/3) for x > 0, to round-off (a few ulp): Newton's iteration
/// y <- y (4 - x y^3) / 3 for x^(-1/3), squared. Near 1 (J of a tissue
/// point) from a rational estimate (`inverse_cbrt_squared_near_one`);
/// elsewhere from the exponent-halving bit estimate (3.4% off at worst;
/// four iterations: 2.4e-3, 1.1e-5, 2.6e-10, round-off). Multiplications
/// and one division: several times faster than `powf` or Rust's correctly
/// rounded `cbrt`, and this is the hottest line of the finite-strain
/// residual. Falls back to `powf` far from 1.
pub fn inverse_cbrt_squared(x: f64) -> f64 {
    if near_one(x) {
        return inverse_cbrt_squared_near_one(x);
    }
    if !(x > 1e-100 && x < 1e100) {
        return x.powf(-2.0 / 3.0);
    }
    let y = inverse_cbrt_newton(x, f64::from_bits(0x553e_f0ff_289d_d796 - x.to_bits() / 3), 4);
    y * y
}

/// Whether x is in the range of [`inverse_cbrt_squared_near_one`],
/// 0.7 < x < 1.4 (false for NaN).
#[inline(always)]
pub(crate) fn near_one(x: f64) -> bool {
    x > 0.7 && x < 1.4
}

/// [`inverse_cbrt_squared`] for 0.7 < x < 1.4 ([`near_one`], not checked),
/// on f64 or on [`Lanes`](crate::lanes::Lanes): from (2 + x) / (1 + 2 x),
/// the [1/1] Pade approximant of x^(-1/3) at 1 (0.1% off at worst there),
/// three Newton iterations (1.6e-6, 5e-12, round-off). Arithmetic only, no
/// bit tricks: it runs in SIMD lanes.
#[inline(always)]
pub(crate) fn inverse_cbrt_squared_near_one<T: Real>(x: T) -> T {
    let (one, two) = (x.constant(1.0), x.constant(2.0));
    let y = inverse_cbrt_newton(x, (two + x) / (one + two * x), 3);
    y * y
}

/// `iterations` of Newton's iteration y <- y (4 - x y^3) / 3 for x^(-1/3)
/// from `y`.
#[inline(always)]
fn inverse_cbrt_newton<T: Real>(x: T, mut y: T, iterations: usize) -> T {
    let (four, third) = (x.constant(4.0), x.constant(1.0 / 3.0));
    for _ in 0..iterations {
        y = y * ((four - x * y * y * y) * third);
    }
    y
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_cbrt_squared_is_pow_to_round_off() {
        let mut worst: f64 = 0.0;
        for k in 0..=20000 {
            // 1e-6 .. 1e6, densest around 1.
            let x = 10f64.powf(12.0 * (k as f64 / 20000.0 - 0.5).powi(3) * 4.0);
            let exact = x.powf(-2.0 / 3.0);
            worst = worst.max((inverse_cbrt_squared(x) / exact - 1.0).abs());
        }
        assert!(worst < 4e-15, "worst relative error {worst:e}");
        for x in [0.0, 1e-200, 1e200, f64::INFINITY] {
            let (a, b) = (inverse_cbrt_squared(x), x.powf(-2.0 / 3.0));
            assert!(a == b || (a / b - 1.0).abs() < 1e-15, "{x}: {a} vs {b}");
        }
        assert!(inverse_cbrt_squared(f64::NAN).is_nan());
    }

    fn law() -> NeoHookean {
        NeoHookean::from_material(&Material::elastic(0.1, 0.45))
    }

    /// S is the derivative of W: 2 dW/dC by central differences (1e-7).
    #[test]
    fn stress_is_the_derivative_of_the_energy() {
        let law = law();
        let f = [[1.1, 0.2], [0.05, 0.93]];
        let response = law.isochoric(&f);
        // dW/dF = F S: perturb F and compare with P = F S.
        let p = [
            [
                f[0][0] * response.stress[0] + f[0][1] * response.stress[3],
                f[0][0] * response.stress[3] + f[0][1] * response.stress[1],
            ],
            [
                f[1][0] * response.stress[0] + f[1][1] * response.stress[3],
                f[1][0] * response.stress[3] + f[1][1] * response.stress[1],
            ],
        ];
        let h = 1e-6;
        for i in 0..2 {
            for k in 0..2 {
                let mut fp = f;
                let mut fm = f;
                fp[i][k] += h;
                fm[i][k] -= h;
                let fd = (law.isochoric_energy(&fp) - law.isochoric_energy(&fm)) / (2.0 * h);
                assert!((fd - p[i][k]).abs() < 1e-7 * law.mu, "P[{i}][{k}] = {} vs {fd}", p[i][k]);
            }
        }
        let j = 1.07;
        let fd = (law.volumetric_energy(j + h) - law.volumetric_energy(j - h)) / (2.0 * h);
        assert!((fd - law.volumetric(j).0).abs() < 1e-7 * law.kappa);
    }

    /// At small strain S0_iso = 2 mu dev(eps) (1e-5 relative at 1e-6 strain).
    #[test]
    fn small_strain_limit_is_the_linear_deviator() {
        let law = law();
        let g = [[0.7e-6, -0.3e-6], [0.5e-6, -0.9e-6]];
        let f = [[1.0 + g[0][0], g[0][1]], [g[1][0], 1.0 + g[1][1]]];
        let eps = [g[0][0], g[1][1], 0.0, 0.5 * (g[0][1] + g[1][0])];
        let dev = crate::element::deviator(&eps);
        let s = law.isochoric(&f).stress;
        for k in 0..4 {
            assert!((s[k] - 2.0 * law.mu * dev[k]).abs() < 1e-5 * 2.0 * law.mu * 1e-6, "{k}: {s:?} vs {dev:?}");
        }
    }
}
