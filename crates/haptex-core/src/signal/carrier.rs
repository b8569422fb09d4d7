//! The carrier that carries the envelope U(t) to the display, and the
//! RMS/peak convention of each shape.
//!
//! The electrostatic force follows the square of the instantaneous voltage
//! (eq. 3), so the force the finger feels is set by the mean of s(t)^2 over a
//! carrier period: the RMS value. Every shape is therefore scaled to unit
//! RMS, and the drive is s(t) = U(t) c(t) with U the RMS envelope of eq. (8)
//! (docs/physics.md, "Voltage convention"):
//!
//! | shape  | c(phase)                        | peak / RMS | force ripple |
//! |--------|---------------------------------|------------|--------------|
//! | sine   | sqrt(2) sin(2 pi phase)         | sqrt(2)    | at 2 f       |
//! | square | +1 for phase < 1/2, else -1     | 1          | none (s^2 = U^2 between edges) |
//! | none   | 1 (s = U, a unipolar drive)     | 1          | none         |

use crate::num::Num;
use serde::{Deserialize, Serialize};

/// Waveform of the carrier.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CarrierShape {
    /// s = sqrt(2) U sin(2 pi f t): peak sqrt(2) U, RMS U.
    Sine,
    /// s = +U / -U, each half a period: peak U, RMS U.
    Square,
    /// s = U: the envelope itself, for a direct low-frequency drive (or a
    /// modulator downstream). Unipolar: see docs/playback.md on polarity.
    None,
}

impl CarrierShape {
    /// The shape's name as the `--carrier` flag and the JSON spell it.
    pub fn name(self) -> &'static str {
        match self {
            CarrierShape::Sine => "sine",
            CarrierShape::Square => "square",
            CarrierShape::None => "none",
        }
    }
}

/// A carrier: shape and frequency.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Carrier {
    pub shape: CarrierShape,
    /// Carrier frequency in Hz (ignored by [`CarrierShape::None`]).
    pub frequency_hz: f64,
}

impl Carrier {
    /// Default carrier: a 1 kHz sine, whose force ripple (2 kHz) lies above
    /// the vibrotactile range.
    pub const DEFAULT: Self = Self { shape: CarrierShape::Sine, frequency_hz: 1000.0 };

    /// Peak over RMS of the unit waveform: sqrt(2) for a sine, 1 otherwise.
    /// The drive's peak is this times the RMS envelope.
    pub fn peak_per_rms(&self) -> f64 {
        match self.shape {
            CarrierShape::Sine => std::f64::consts::SQRT_2,
            CarrierShape::Square | CarrierShape::None => 1.0,
        }
    }

    /// The unit-RMS waveform at `phase` in cycles (any real; its fractional
    /// part is used).
    #[inline]
    pub fn unit_rms(&self, phase: f64) -> f64 {
        match self.shape {
            CarrierShape::Sine => std::f64::consts::SQRT_2 * sin_turns(phase),
            CarrierShape::Square => {
                if phase - phase.floor() < 0.5 {
                    1.0
                } else {
                    -1.0
                }
            }
            CarrierShape::None => 1.0,
        }
    }

    /// Checks the carrier can be sampled at `sample_rate_hz`: a positive
    /// frequency below the Nyquist frequency (for sine and square).
    pub fn check(&self, sample_rate_hz: f64) -> Result<(), String> {
        if self.shape == CarrierShape::None {
            return Ok(());
        }
        let f = crate::ranges::CARRIER_HZ.check(self.frequency_hz).map_err(|e| e.to_string())?;
        if f >= sample_rate_hz / 2.0 {
            return Err(format!(
                "carrier frequency {} Hz is not below the Nyquist frequency {} Hz of the {} Hz sample rate",
                Num(f),
                Num(sample_rate_hz / 2.0),
                Num(sample_rate_hz)
            ));
        }
        Ok(())
    }
}

/// sin(2 pi p) for a phase p in turns, to within 4.5e-16 absolute (2 units
/// in the last place of 1; the signal is quantized far coarser), in
/// straight-line arithmetic the compiler vectorizes (the libm call does
/// not). p is reduced to the nearest half turn, p = q / 2 + r with
/// |r| <= 1/4 (exactly: q / 2 and p are close), so sin(2 pi p) = (-1)^q sin(2 pi r) with |2 pi r| <= pi / 2,
/// where the odd Taylor series to x^23 truncates below 2e-18. For phases
/// up to 2^50 turns (a render's sample limit keeps them below 1e8).
#[inline(always)]
pub(crate) fn sin_turns(p: f64) -> f64 {
    // q = 2p rounded to an integer (ties to even; |2p| < 2^51), with q's
    // parity in the lowest bit of the shifted sum: no libm round/floor
    // call, so the loop vectorizes.
    let (q, shifted_bits) = crate::num::round_shifted(2.0 * p);
    let r = p - 0.5 * q;
    let x = std::f64::consts::TAU * r;
    let x2 = x * x;
    // Horner in x^2 over 1/23! .. 1/1! with alternating signs.
    let mut s = -1.0 / 25852016738884976640000.0;
    for c in [
        1.0 / 51090942171709440000.0,
        -1.0 / 121645100408832000.0,
        1.0 / 355687428096000.0,
        -1.0 / 1307674368000.0,
        1.0 / 6227020800.0,
        -1.0 / 39916800.0,
        1.0 / 362880.0,
        -1.0 / 5040.0,
        1.0 / 120.0,
        -1.0 / 6.0,
        1.0,
    ] {
        s = s * x2 + c;
    }
    // (-1)^q from the parity of q.
    let sign = 1.0 - 2.0 * (shifted_bits & 1) as f64;
    sign * (s * x)
}

impl Default for Carrier {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each shape has unit RMS over a period (docs/physics.md convention),
    /// sampled finely: within 1e-12.
    /// The polynomial sine against libm over 2e6 phases in [-3, 3] turns
    /// and the phases a long render reaches (1e6 turns, 1000 s at 1 kHz):
    /// within 4.5e-16 absolute; exact 0 and +-1 at the quarter turns. The
    /// reference is libm's sin of 2 pi (p - round(p)) (the whole turns
    /// taken off exactly first: libm's sin(2 pi p) itself carries the
    /// rounding of 2 pi p, 1.8e-15 at 3 turns, and would be the less
    /// accurate of the two).
    #[test]
    fn sin_turns_matches_libm() {
        let reference = |p: f64| (std::f64::consts::TAU * (p - p.round())).sin();
        let mut worst: f64 = 0.0;
        for i in 0..=2_000_000 {
            let p = -3.0 + 6.0 * i as f64 / 2_000_000.0;
            worst = worst.max((sin_turns(p) - reference(p)).abs());
        }
        for i in 0..100_000 {
            let p = 1e6 + i as f64 * (1.0 / 48.0);
            worst = worst.max((sin_turns(p) - reference(p)).abs());
        }
        assert!(worst <= 4.5e-16, "worst absolute error {worst:e}");
        assert_eq!((sin_turns(0.0), sin_turns(0.5), sin_turns(-1.0)), (0.0, 0.0, 0.0));
        assert_eq!((sin_turns(0.25), sin_turns(0.75), sin_turns(-0.25)), (1.0, -1.0, -1.0));
    }

    #[test]
    fn every_shape_has_unit_rms_and_its_peak() {
        for shape in [CarrierShape::Sine, CarrierShape::Square, CarrierShape::None] {
            let c = Carrier { shape, frequency_hz: 1.0 };
            let n = 10_000;
            let values: Vec<f64> = (0..n).map(|i| c.unit_rms(i as f64 / n as f64 + 3.0)).collect();
            let rms = (values.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
            let peak = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!((rms - 1.0).abs() < 1e-12, "{shape:?}: rms {rms}");
            assert!((peak - c.peak_per_rms()).abs() < 1e-12, "{shape:?}: peak {peak}");
        }
    }

    #[test]
    fn nyquist_is_checked() {
        assert!(Carrier::DEFAULT.check(48_000.0).is_ok());
        assert!(Carrier { shape: CarrierShape::Sine, frequency_hz: 24_000.0 }.check(48_000.0).is_err());
        assert!(Carrier { shape: CarrierShape::Square, frequency_hz: 0.0 }.check(48_000.0).is_err());
        assert!(Carrier { shape: CarrierShape::None, frequency_hz: f64::NAN }.check(48_000.0).is_ok());
    }
}
