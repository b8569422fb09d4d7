//! The accepted range of every physical parameter a user sets: the one
//! table the command line, the web API and the library check against, so a
//! value accepted in one place is accepted in all (and a value that makes
//! a derived quantity overflow is refused where it is given).
//!
//! Each parameter must be finite, > 0 and <= its maximum. The maxima are
//! far beyond any real device (a display's insulator is microns thick, its
//! voltage hundreds of volts) but keep every derived value (Fe/Fn, the
//! clip level, a full-scale code) finite.

use crate::num::Num;

/// A parameter's name (as the flag and the API field spell it), largest
/// accepted value and unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    pub name: &'static str,
    pub max: f64,
    pub unit: &'static str,
}

/// A value outside its [`Range`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{name} must be > 0 and <= {}{}, got {}", Num(*max), unit_text(unit), Num(*value))]
pub struct RangeError {
    pub name: &'static str,
    pub value: f64,
    pub max: f64,
    pub unit: &'static str,
}

fn unit_text(unit: &str) -> String {
    if unit.is_empty() { String::new() } else { format!(" {unit}") }
}

impl Range {
    /// The value if it is finite, > 0 and <= the maximum.
    pub fn check(&self, value: f64) -> Result<f64, RangeError> {
        if value.is_finite() && value > 0.0 && value <= self.max {
            Ok(value)
        } else {
            Err(RangeError { name: self.name, value, max: self.max, unit: self.unit })
        }
    }
}

const fn range(name: &'static str, max: f64, unit: &'static str) -> Range {
    Range { name, max, unit }
}

/// Friction coefficient of the finger on the display, mu_HD.
pub const MU_HD: Range = range("mu_hd", 10.0, "");
/// Highest voltage of the display, U_max (RMS).
pub const U_MAX_V: Range = range("u_max_v", 10_000.0, "V");
/// Relative permittivity of the stratum corneum.
pub const EPS_SC: Range = range("eps_sc", 1e6, "");
/// Relative permittivity of the insulator.
pub const EPS_I: Range = range("eps_i", 1e6, "");
/// Stratum corneum thickness.
pub const D_SC_MM: Range = range("d_sc_mm", 10.0, "mm");
/// Insulator thickness.
pub const D_I_MM: Range = range("d_i_mm", 10.0, "mm");
/// Contact-area coefficient k of A = k Fn^n.
pub const K_MM2_PER_N: Range = range("k_mm2_per_n", 1e6, "mm^2/N");
/// Contact-area exponent n of A = k Fn^n.
pub const AREA_EXPONENT: Range = range("area_exponent", 2.0, "");
/// Exploration normal force Fn.
pub const FN_N: Range = range("fn_n", 100.0, "N");
/// Envelope slew limit.
pub const SLEW_V_PER_S: Range = range("slew_v_per_s", 1e9, "V/s");
/// Peak output of the amplifier.
pub const AMPLIFIER_RANGE_V: Range = range("amplifier_range_v", 100_000.0, "V");
/// Volts at the amplifier output for a full-scale WAV sample.
pub const VOLTS_PER_FULL_SCALE: Range = range("volts_per_full_scale", 100_000.0, "V");
/// Carrier frequency (also below the Nyquist frequency of the rate).
pub const CARRIER_HZ: Range = range("carrier_hz", 1e6, "Hz");

/// Every range, in the order the GUI and the docs list them.
pub const ALL: &[Range] = &[
    MU_HD,
    U_MAX_V,
    EPS_SC,
    EPS_I,
    D_SC_MM,
    D_I_MM,
    K_MM2_PER_N,
    AREA_EXPONENT,
    FN_N,
    SLEW_V_PER_S,
    AMPLIFIER_RANGE_V,
    VOLTS_PER_FULL_SCALE,
    CARRIER_HZ,
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_and_message() {
        assert_eq!(U_MAX_V.check(100.0), Ok(100.0));
        assert_eq!(U_MAX_V.check(10_000.0), Ok(10_000.0));
        for bad in [0.0, -1.0, 10_000.5, f64::NAN, f64::INFINITY, 1e308] {
            assert!(U_MAX_V.check(bad).is_err(), "{bad}");
        }
        assert_eq!(U_MAX_V.check(1e308).unwrap_err().to_string(), "u_max_v must be > 0 and <= 10000 V, got 1e308");
        let names: std::collections::HashSet<_> = ALL.iter().map(|r| r.name).collect();
        assert_eq!(names.len(), ALL.len());
    }
}
