//! Tissue materials: isotropic linear elasticity with an optional
//! generalized-Maxwell (Prony series) relaxation of the deviatoric stress.
//!
//! The bulk response is elastic; the shear modulus relaxes as
//!
//!   G(t) = G0 [ g_inf + sum_i g_i exp(-t / tau_i) ],   g_inf = 1 - sum_i g_i,
//!
//! (physics.md section 2). Stresses are integrated with the exponential
//! recursion of Simo & Hughes (Computational Inelasticity, 1998, sec. 10.3):
//! the deviatoric stress is s = g_inf s0 + sum_i h_i with the instantaneous
//! elastic deviator s0 = 2 G0 dev(eps) and, over a step dt,
//!
//!   h_i(n+1) = exp(-dt/tau_i) h_i(n) + g_i (1 - exp(-dt/tau_i)) / (dt/tau_i) (s0(n+1) - s0(n)),
//!
//! which is exact for a strain history linear within each step. Units: MPa, s.

use haptex_core::num::Num;
use serde::{Deserialize, Serialize};

/// One term of a Prony series: relative weight g_i and time constant tau_i.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PronyTerm {
    /// Relative weight g_i (0 < g_i, sum of all g_i < 1).
    pub g: f64,
    /// Relaxation time tau_i in s.
    pub tau_s: f64,
}

/// An isotropic material of the finger model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Instantaneous Young's modulus E0 in MPa.
    pub e_mpa: f64,
    /// Poisson's ratio (instantaneous).
    pub nu: f64,
    /// Prony series of the shear relaxation; empty for an elastic material.
    #[serde(default)]
    pub prony: Vec<PronyTerm>,
}

/// A material parameter is out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{what}")]
pub struct MaterialError {
    pub what: String,
}

impl Material {
    /// A linear elastic material.
    pub fn elastic(e_mpa: f64, nu: f64) -> Self {
        Self { e_mpa, nu, prony: Vec::new() }
    }

    /// Checks E > 0, -1 < nu < 0.5, g_i > 0, tau_i > 0, sum g_i < 1, and at
    /// most [`MAX_PRONY_TERMS`] terms.
    pub fn validate(&self) -> Result<(), MaterialError> {
        let err = |what: String| Err(MaterialError { what });
        if self.prony.len() > MAX_PRONY_TERMS {
            return err(format!("{} Prony terms: at most {MAX_PRONY_TERMS} are supported", self.prony.len()));
        }
        if !(self.e_mpa.is_finite() && self.e_mpa > 0.0) {
            return err(format!("Young's modulus must be positive, got {} MPa", Num(self.e_mpa)));
        }
        if !(self.nu > -1.0 && self.nu < 0.5) {
            return err(format!("Poisson's ratio must lie in (-1, 0.5), got {}", Num(self.nu)));
        }
        for term in &self.prony {
            if !(term.g > 0.0 && term.tau_s.is_finite() && term.tau_s > 0.0) {
                return err(format!(
                    "Prony terms need g > 0 and tau > 0 s, got g = {}, tau = {} s",
                    Num(term.g),
                    Num(term.tau_s)
                ));
            }
        }
        let total: f64 = self.prony.iter().map(|t| t.g).sum();
        if total >= 1.0 {
            return err(format!("the Prony weights must sum to less than 1, got {}", Num(total)));
        }
        Ok(())
    }

    /// Instantaneous shear modulus G0 = E / (2 (1 + nu)) in MPa.
    pub fn shear_mpa(&self) -> f64 {
        self.e_mpa / (2.0 * (1.0 + self.nu))
    }

    /// Bulk modulus K = E / (3 (1 - 2 nu)) in MPa (elastic, never relaxes).
    pub fn bulk_mpa(&self) -> f64 {
        self.e_mpa / (3.0 * (1.0 - 2.0 * self.nu))
    }

    /// Long-term shear fraction g_inf = 1 - sum g_i.
    pub fn g_inf(&self) -> f64 {
        1.0 - self.prony.iter().map(|t| t.g).sum::<f64>()
    }

    /// Relaxation modulus ratio G(t)/G0 (the analytic step response).
    pub fn relaxation_ratio(&self, t_s: f64) -> f64 {
        self.g_inf() + self.prony.iter().map(|p| p.g * (-t_s / p.tau_s).exp()).sum::<f64>()
    }

    pub fn is_viscoelastic(&self) -> bool {
        !self.prony.is_empty()
    }

    /// The coefficients of the exponential recursion for a step `dt_s`.
    /// With `dt_s` = 0 (or an elastic material) the response is instantaneous.
    pub fn step(&self, dt_s: f64) -> StepCoefficients {
        let n = self.prony.len();
        let mut decay = Vec::with_capacity(n);
        let mut gamma = Vec::with_capacity(n);
        let mut ratio = self.g_inf();
        for term in &self.prony {
            let x = dt_s / term.tau_s;
            decay.push((-x).exp());
            // (1 - e^-x)/x, with its limit 1 at x -> 0 (series for small x).
            let factor = if x < 1e-8 { 1.0 - 0.5 * x } else { -(-x).exp_m1() / x };
            gamma.push(term.g * factor);
            ratio += term.g * factor;
        }
        StepCoefficients { decay, gamma, shear_ratio: ratio }
    }
}

/// Most Prony terms a material may have. The recursion itself takes any
/// number; the bound keeps the history's memory (one stress per term and
/// Gauss point: 32 bytes x terms x ~10^4 points) in proportion.
pub const MAX_PRONY_TERMS: usize = 32;

/// Per-step constants of the exponential recursion, one per Prony term.
#[derive(Debug, Clone, PartialEq)]
pub struct StepCoefficients {
    /// exp(-dt/tau_i).
    pub decay: Vec<f64>,
    /// g_i (1 - exp(-dt/tau_i)) / (dt/tau_i).
    pub gamma: Vec<f64>,
    /// The algorithmic shear modulus over G0: g_inf + sum gamma_i.
    pub shear_ratio: f64,
}

impl StepCoefficients {
    /// Number of Prony terms.
    pub fn n_terms(&self) -> usize {
        self.decay.len()
    }
}

/// The part of the deviatoric stress at n+1 that does not depend on the
/// new strain (N tensor components: 4 in plane strain, 6 in 3D), for a point with instantaneous deviator `s0` and internal
/// stresses `h` (one per term): sum_i (exp(-dt/tau_i) h_i(n) - gamma_i s0(n)).
/// The full deviator is then 2 G0 shear_ratio dev(eps(n+1)) + this.
pub fn frozen_deviator<const N: usize>(s0: &[f64; N], h: &[[f64; N]], c: &StepCoefficients) -> [f64; N] {
    let mut s = [0.0; N];
    for i in 0..c.n_terms() {
        for k in 0..N {
            s[k] += c.decay[i] * h[i][k] - c.gamma[i] * s0[k];
        }
    }
    s
}

/// Advances a point's history (`s0`, `h`) to the new instantaneous
/// deviator `s0_new`.
pub fn advance_history<const N: usize>(s0: &mut [f64; N], h: &mut [[f64; N]], c: &StepCoefficients, s0_new: &[f64; N]) {
    for i in 0..c.n_terms() {
        for k in 0..N {
            h[i][k] = c.decay[i] * h[i][k] + c.gamma[i] * (s0_new[k] - s0[k]);
        }
    }
    *s0 = *s0_new;
}

/// Deviatoric stress g_inf s0 + sum h_i of a point with history (`s0`, `h`).
pub fn history_deviator<const N: usize>(s0: &[f64; N], h: &[[f64; N]], g_inf: f64) -> [f64; N] {
    let mut s = s0.map(|v| g_inf * v);
    for h in h {
        for k in 0..N {
            s[k] += h[k];
        }
    }
    s
}

/// Viscoelastic history of one integration point: the instantaneous
/// deviator s0 and the internal stresses h_i (one per Prony term), each as
/// (xx, yy, zz, xy). (A body keeps the histories of all its points in one
/// array; see [`crate::body::Body`].)
#[derive(Debug, Clone, PartialEq, Default)]
pub struct History {
    pub s0: [f64; 4],
    pub h: Vec<[f64; 4]>,
}

impl History {
    /// The history at rest of a point of a material with `n_terms` terms.
    pub fn new(n_terms: usize) -> Self {
        Self { s0: [0.0; 4], h: vec![[0.0; 4]; n_terms] }
    }

    /// See [`frozen_deviator`].
    pub fn frozen_deviator(&self, c: &StepCoefficients) -> [f64; 4] {
        frozen_deviator(&self.s0, &self.h, c)
    }

    /// See [`advance_history`].
    pub fn advance(&mut self, c: &StepCoefficients, s0_new: &[f64; 4]) {
        advance_history(&mut self.s0, &mut self.h, c, s0_new);
    }

    /// See [`history_deviator`].
    pub fn deviator(&self, g_inf: f64) -> [f64; 4] {
        history_deviator(&self.s0, &self.h, g_inf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prony_bar() -> Material {
        Material {
            e_mpa: 1.0,
            nu: 0.3,
            prony: vec![PronyTerm { g: 0.3, tau_s: 0.01 }, PronyTerm { g: 0.3, tau_s: 1.0 }],
        }
    }

    /// Step shear strain held from t = 0: the recursion reproduces G(t)/G0 of
    /// physics.md (1, 0.807, 0.672, 0.510, 0.400 at 0, 0.01, 0.1, 1, 10 s) up
    /// to the ramp time of the first step (1e-9 s), here to 1e-6.
    #[test]
    fn recursion_reproduces_step_relaxation() {
        let m = prony_bar();
        let g_inf = m.g_inf();
        let mut history = History::new(m.prony.len());
        let s0 = [0.0, 0.0, 0.0, 1.0];
        history.advance(&m.step(1e-9), &s0);
        let mut t = 1e-9;
        for (target, expected) in [(0.01, 0.807), (0.1, 0.672), (1.0, 0.510), (10.0, 0.400)] {
            history.advance(&m.step(target - t), &s0);
            t = target;
            let ratio = history.deviator(g_inf)[3];
            assert!((ratio - m.relaxation_ratio(t)).abs() < 1e-6, "t = {t}: {ratio}");
            assert!((ratio - expected).abs() < 0.0006, "t = {t}: {ratio} vs {expected}");
        }
    }

    #[test]
    fn validation_rejects_bad_parameters() {
        assert!(Material::elastic(1.0, 0.5).validate().is_err());
        assert!(Material::elastic(0.0, 0.3).validate().is_err());
        let mut m = prony_bar();
        m.prony[0].g = 0.8;
        assert!(m.validate().is_err());
        assert!(prony_bar().validate().is_ok());
    }
}
