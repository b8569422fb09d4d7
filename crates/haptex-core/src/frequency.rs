//! A frequency-dependent electrovibration force: finger and display as a
//! circuit (docs/physics.md, "Frequency-dependent force").
//!
//! Eq. (3) treats the stratum corneum and the display's insulator as two
//! perfect dielectrics in series with the whole applied voltage across
//! them, so the force does not depend on the carrier. The stratum corneum
//! is a leaky dielectric, and a sliding finger touches the display through
//! an air gap (Shultz, Peshkin and Colgate 2015 and 2018; Vezzoli et al.
//! 2014; Meyer, Peshkin and Colgate 2013). Per unit of contact area the
//! series stack is
//!
//! ```text
//!   electrode -- insulator C_i -- air gap C_g -- stratum corneum (R_sc || C_sc) -- body
//!   C_i = eps0 eps_i / d_i,  C_g = eps0 / g,  C_sc = eps0 eps_sc / d_sc,  R_sc = rho_sc d_sc
//! ```
//!
//! with the body a conductor. At carrier angular frequency w the charge per
//! area on the electrode is Q = eps0 U / s(w), with the stack's effective
//! thickness
//!
//! ```text
//!   s(w) = d_i/eps_i + g + (d_sc/eps_sc) j w tau / (1 + j w tau),   tau = eps0 eps_sc rho_sc,
//! ```
//!
//! tau being the stratum corneum's relaxation time R_sc C_sc. The model
//! keeps eq. (3)'s conversion from charge to force (which is proportional
//! to Q^2) and takes the charge from the circuit, so that it changes eq.
//! (3) by the gain
//!
//! ```text
//!   G(w) = |Q(w) / Q_eq3|^2 = ((d_sc/eps_sc + d_i/eps_i) / |s(w)|)^2.
//! ```
//!
//! Limits: with no gap and either a perfect dielectric (rho_sc infinite)
//! or w tau -> infinity, s = d_sc/eps_sc + d_i/eps_i and G = 1: eq. (3).
//! At w tau -> 0 the stratum corneum conducts and the voltage lies across
//! the insulator and the gap alone: G(0) = ((d_sc/eps_sc + d_i/eps_i) /
//! (d_i/eps_i + g))^2 (the Johnsen-Rahbek enhancement of Shultz et al.).
//! A gap lowers the force at every frequency.
//!
//! The carrier decides which frequencies the force sees: a sine at f gives
//! the mean force G(2 pi f) Fe_eq3(U_rms) (with a ripple at 2 f), a square
//! wave the mean over its period (closed form below, checked against the
//! sum over its harmonics), a direct (unipolar) drive G(0).

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::electrovibration::{EPS0_F_PER_M, LayerStack};
use crate::num::Num;
use crate::ranges::{self, RangeError};
use crate::signal::{Carrier, CarrierShape};

const MM: f64 = 1e-3;
const UM: f64 = 1e-6;

/// A circuit parameter out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FrequencyError {
    #[error(transparent)]
    Range(#[from] RangeError),
}

/// The parameters the circuit adds to eq. (3)'s layers: the stratum
/// corneum's resistivity and the air gap of the sliding interface.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FingerCircuit {
    /// DC resistivity of the stratum corneum, rho_sc in ohm m
    /// (`f64::INFINITY`: a perfect dielectric, as eq. 3 assumes).
    pub rho_sc_ohm_m: f64,
    /// Thickness of the air gap between skin and display, g in um (0: none).
    pub gap_um: f64,
}

impl FingerCircuit {
    /// Checks both parameters are in range (rho_sc may also be +infinity).
    pub fn validate(&self) -> Result<(), FrequencyError> {
        if self.rho_sc_ohm_m != f64::INFINITY {
            ranges::RHO_SC_OHM_M.check(self.rho_sc_ohm_m)?;
        }
        ranges::GAP_UM.check(self.gap_um)?;
        Ok(())
    }

    /// The stratum corneum's relaxation time tau = eps0 eps_sc rho_sc in s
    /// (infinite for a perfect dielectric).
    pub fn relaxation_time_s(&self, stack: &LayerStack) -> f64 {
        EPS0_F_PER_M * stack.eps_sc * self.rho_sc_ohm_m
    }

    /// The corner frequency 1 / (2 pi tau) in Hz above which the stratum
    /// corneum acts as a dielectric (0 for a perfect dielectric).
    pub fn corner_hz(&self, stack: &LayerStack) -> f64 {
        1.0 / (2.0 * PI * self.relaxation_time_s(stack))
    }

    /// The gain G on eq. (3)'s force for a sinusoidal voltage at `f_hz`
    /// (0: DC; +infinity allowed).
    pub fn gain(&self, stack: &LayerStack, f_hz: f64) -> f64 {
        let t = Thicknesses::of(stack, self);
        // u = 1 / (w tau); j w tau / (1 + j w tau) = (1 + j u) / (1 + u^2).
        let tau = self.relaxation_time_s(stack);
        let u = if tau == f64::INFINITY { 0.0 } else { 1.0 / (2.0 * PI * f_hz * tau) };
        if u == f64::INFINITY {
            return t.dc_gain();
        }
        let d = 1.0 + u * u;
        let re = t.b + t.g + t.a / d;
        let im = t.a * u / d;
        (t.a + t.b).powi(2) / (re * re + im * im)
    }

    /// The gain on eq. (3)'s mean force when the envelope is played on
    /// `carrier` (RMS convention of [`Carrier`]): G(2 pi f) for a sine, the
    /// period mean for a square wave, G(0) for a direct drive.
    pub fn carrier_gain(&self, stack: &LayerStack, carrier: &Carrier) -> f64 {
        match carrier.shape {
            CarrierShape::Sine => self.gain(stack, carrier.frequency_hz),
            CarrierShape::Square => self.square_gain(stack, carrier.frequency_hz),
            CarrierShape::None => self.gain(stack, 0.0),
        }
    }

    /// The mean force gain of a square wave +-U at `f_hz`, in closed form.
    ///
    /// Q / U = eps0 / s(w) is a lead-lag: with c0 = a + b + g (a = d_sc/eps_sc,
    /// b = d_i/eps_i) and tau2 = tau c0 / (b + g),
    /// Q = eps0 U / c0 + eps0 a / (c0 (b + g)) y, where y is U through a
    /// first-order low-pass of time constant tau2. For the square wave, y's
    /// periodic steady state over a half period is U (1 - (1 + tanh(h/2))
    /// e^(-t/tau2)), h = T / (2 tau2); its mean and the mean of y^2 over the
    /// half period are both U q(h), q = 1 - (2/h) tanh(h/2). So
    /// mean Q^2 = U^2 (alpha^2 + (2 alpha beta + beta^2) q) with
    /// alpha = eps0 / c0 and beta = eps0 a / (c0 (b + g)).
    pub fn square_gain(&self, stack: &LayerStack, f_hz: f64) -> f64 {
        let t = Thicknesses::of(stack, self);
        let tau = self.relaxation_time_s(stack);
        let c0 = t.a + t.b + t.g;
        // In units of eps0: alpha = 1/c0, beta = a / (c0 (b + g)).
        let alpha = 1.0 / c0;
        let beta = t.a / (c0 * (t.b + t.g));
        let q = if tau == f64::INFINITY {
            0.0
        } else {
            let tau2 = tau * c0 / (t.b + t.g);
            square_mean(1.0 / (2.0 * f_hz * tau2))
        };
        (t.a + t.b).powi(2) * (alpha * alpha + (2.0 * alpha * beta + beta * beta) * q)
    }

    /// One line for summaries and file comments.
    pub fn describe(&self, stack: &LayerStack) -> String {
        let rho = if self.rho_sc_ohm_m == f64::INFINITY {
            "a perfect dielectric".to_string()
        } else {
            format!("rho_sc = {} ohm m (corner {} Hz)", Num(self.rho_sc_ohm_m), Num(round3(self.corner_hz(stack))))
        };
        format!("finger circuit: stratum corneum {rho}, air gap g = {} um", Num(self.gap_um))
    }
}

/// Three significant digits, for a fitted or derived constant in a
/// message (a corner frequency, an interval's ends).
pub fn round3(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(2 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

/// q(h) = 1 - (2/h) tanh(h/2): the half-period mean of the low-passed
/// square wave (and of its square), from 0 (h -> 0, a fast carrier) to 1
/// (h -> infinity, a slow one). Near 0 from its series, where the closed
/// form cancels.
fn square_mean(h: f64) -> f64 {
    if h == f64::INFINITY {
        1.0
    } else if h < 1e-2 {
        let h2 = h * h;
        h2 / 12.0 - h2 * h2 / 120.0 + 17.0 * h2 * h2 * h2 / 20160.0
    } else {
        1.0 - 2.0 / h * (h / 2.0).tanh()
    }
}

/// The stack's effective thicknesses in m: a = d_sc/eps_sc, b = d_i/eps_i,
/// g the gap.
struct Thicknesses {
    a: f64,
    b: f64,
    g: f64,
}

impl Thicknesses {
    fn of(stack: &LayerStack, circuit: &FingerCircuit) -> Self {
        Self { a: stack.d_sc_mm * MM / stack.eps_sc, b: stack.d_i_mm * MM / stack.eps_i, g: circuit.gap_um * UM }
    }

    /// G(0) = ((a + b) / (b + g))^2.
    fn dc_gain(&self) -> f64 {
        ((self.a + self.b) / (self.b + self.g)).powi(2)
    }
}

/// Which force law turns the voltage into the electrostatic force.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "lowercase")]
pub enum ForceModel {
    /// Eq. (3), Kaczmarek et al. 2006: no frequency dependence (the paper's).
    Eq3,
    /// Eq. (3) times the circuit's gain for the carrier that will be played.
    Circuit { circuit: FingerCircuit, carrier: Carrier },
}

impl ForceModel {
    /// The factor on eq. (3)'s force (1 for eq. 3 itself).
    pub fn gain(&self, stack: &LayerStack) -> f64 {
        match self {
            ForceModel::Eq3 => 1.0,
            ForceModel::Circuit { circuit, carrier } => circuit.carrier_gain(stack, carrier),
        }
    }

    /// The file comment of a design made with this model on `device` (its
    /// gain already in `device.force_gain`): the circuit, its gain and the
    /// carrier it was designed for, in the words `haptex play` reads
    /// ([`carrier_note`]). None for eq. (3), which needs none.
    pub fn design_comment(&self, device: &crate::electrovibration::Device) -> Option<String> {
        let ForceModel::Circuit { circuit, carrier } = self else {
            return None;
        };
        Some(format!(
            "force model: circuit ({}); Fe = G Fe_eq3 with G = {:.6} for this carrier; {}",
            circuit.describe(&device.stack),
            device.force_gain,
            carrier_note(carrier)
        ))
    }
}

/// `designed for the carrier: SHAPE F Hz (play it with ...)`: the comment
/// of a design whose force depends on the carrier, as `haptex play` reads
/// it back (the frequency in full: it compares exactly).
pub fn carrier_note(carrier: &Carrier) -> String {
    let shape = carrier.shape.name();
    let f = crate::num::Exact(carrier.frequency_hz);
    format!("designed for the carrier: {shape} {f} Hz (play it with haptex play --carrier {shape} --carrier-hz {f})")
}

/// The sum over a square wave's odd harmonics k of (8 / (pi k)^2) G(k f):
/// an independent evaluation of [`FingerCircuit::square_gain`] for tests.
/// `terms` odd harmonics, and the remainder G(infinity) times the weight
/// left over.
pub fn square_gain_by_harmonics(circuit: &FingerCircuit, stack: &LayerStack, f_hz: f64, terms: usize) -> f64 {
    let g_inf = circuit.gain(stack, f64::INFINITY);
    let mut sum = g_inf;
    for n in 0..terms {
        let k = (2 * n + 1) as f64;
        sum += 8.0 / (PI * PI * k * k) * (circuit.gain(stack, k * f_hz) - g_inf);
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_mean_series_meets_the_closed_form() {
        // At h = 1e-2 the two forms agree to the series' truncation
        // (next term ~ h^8 / 1e4) and the closed form's cancellation
        // (~1e-16 / q ~ 1e-11 relative).
        let h: f64 = 1e-2;
        let closed = 1.0 - 2.0 / h * (h / 2.0).tanh();
        let series = square_mean(h * (1.0 - 1e-15));
        assert!(((closed - series) / series).abs() < 1e-9, "{closed} {series}");
        assert_eq!(square_mean(0.0), 0.0);
        assert_eq!(square_mean(f64::INFINITY), 1.0);
        assert!((square_mean(1e6) - (1.0 - 2e-6)).abs() < 1e-15);
    }

    #[test]
    fn round3_keeps_three_digits() {
        assert_eq!(round3(1234.5), 1230.0);
        assert_eq!(round3(0.012345), 0.0123);
    }
}
