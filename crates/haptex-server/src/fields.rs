//! Numeric request fields: the range each is accepted in, and the one
//! check every route and body format uses.
//!
//! Every number a request gives, and every number the server derives from
//! them before answering (mu = ft/fn), is checked here against its range,
//! and a value outside is refused with 400 naming the field (a JSON path
//! such as `profile.fn_n[3]`, a query parameter, or a CSV column with its
//! line) and quoting the value readably ([`Num`]: `1e308`, not 309
//! digits). The ranges are wide (far beyond any finger, display or
//! recording) but finite, so that no sum, span, ratio or square the server
//! computes from accepted values can overflow to infinity or NaN. The
//! maxima of the parameters haptex-core also knows (carrier, slew,
//! amplifier range, WAV scale) are haptex-core's ([`haptex_core::ranges`]).

use haptex_core::num::Num;
use haptex_core::ranges;

use crate::error::ApiError;

/// An accepted range: `min <= value <= max`, finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    pub min: f64,
    pub max: f64,
    /// Unit for messages (empty: unitless).
    pub unit: &'static str,
}

impl Range {
    pub const fn new(min: f64, max: f64, unit: &'static str) -> Self {
        Self { min, max, unit }
    }

    /// Whether `value` is accepted.
    pub fn contains(&self, value: f64) -> bool {
        value.is_finite() && value >= self.min && value <= self.max
    }

    /// `from MIN to MAX UNIT`.
    pub fn describe(&self) -> String {
        let unit = if self.unit.is_empty() { String::new() } else { format!(" {}", self.unit) };
        format!("from {} to {}{unit}", Num(self.min), Num(self.max))
    }

    /// The error for `value` of field `field` (named `name` in the
    /// message).
    pub fn refusal(&self, name: &str, value: f64, field: &str) -> ApiError {
        ApiError::bad_request(format!("{name} must be {}, got {}", self.describe(), Num(value)), Some(field))
    }

    /// Checks one value; the error names `field`.
    pub fn check(&self, value: f64, field: &str) -> Result<f64, ApiError> {
        if self.contains(value) { Ok(value) } else { Err(self.refusal(last_name(field), value, field)) }
    }

    /// The index of the first value outside the range.
    pub fn first_outside(&self, values: &[f64]) -> Option<usize> {
        values.iter().position(|v| !self.contains(*v))
    }

    /// Checks every value of a JSON array `field`; the error names
    /// `field[i]`.
    pub fn check_all(&self, values: &[f64], field: &str) -> Result<(), ApiError> {
        match self.first_outside(values) {
            None => Ok(()),
            Some(i) => Err(self.refusal(last_name(field), values[i], &format!("{field}[{i}]"))),
        }
    }
}

/// `device.u_max_v` -> `u_max_v`, `profile.mu[3]` -> `mu`.
fn last_name(field: &str) -> &str {
    let name = field.rsplit('.').next().unwrap_or(field);
    name.split('[').next().unwrap_or(name)
}

/// Positions along the surface (profiles, voltage curves, trajectories,
/// stroke ends): +-1 km.
pub const POSITION_MM: Range = Range::new(-1e6, 1e6, "mm");
/// Friction coefficients, given or derived (mu = ft/fn).
pub const MU: Range = Range::new(-1e3, 1e3, "");
/// Tangential (friction) force.
pub const FT_N: Range = Range::new(-100.0, 100.0, "N");
/// Normal force: positive, from 1 uN.
pub const FN_N: Range = Range::new(1e-6, 100.0, "N");
/// Times of a trajectory: +-11.6 days.
pub const TIME_S: Range = Range::new(-1e6, 1e6, "s");
/// RMS voltages of a voltage curve.
pub const VOLTAGE_V: Range = Range::new(0.0, 1e6, "V");
/// Finger velocity of a generated stroke.
pub const VELOCITY_MM_S: Range = Range::new(1e-6, 1e4, "mm/s");
/// Carrier frequency (and below the Nyquist frequency of the sample rate).
pub const CARRIER_HZ: Range = from_core(1e-3, ranges::CARRIER_HZ);
/// Slew limit of the drive's envelope.
pub const SLEW_V_PER_S: Range = from_core(1e-3, ranges::SLEW_V_PER_S);
/// Peak output of the amplifier.
pub const AMPLIFIER_RANGE_V: Range = from_core(1e-3, ranges::AMPLIFIER_RANGE_V);
/// Volts of drive per WAV full scale.
pub const VOLTS_PER_FULL_SCALE: Range = from_core(1e-3, ranges::VOLTS_PER_FULL_SCALE);

/// haptex-core's range of a parameter (its maximum and unit, which the
/// command line checks too), from `min` on.
const fn from_core(min: f64, core: ranges::Range) -> Range {
    Range::new(min, core.max, core.unit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals_name_the_field_and_quote_the_value_short() {
        let e = FN_N.check(5e-324, "profile.fn_n").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("profile.fn_n"));
        assert_eq!(e.message, "fn_n must be from 1e-6 to 100 N, got 5e-324");
        let e = FT_N.check_all(&[0.1, 1e308], "ft_n").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("ft_n[1]"));
        assert!(e.message.ends_with("got 1e308"), "{}", e.message);
        assert!(MU.check(f64::NAN, "mu").is_err() && MU.check(f64::INFINITY, "mu").is_err());
        assert_eq!(MU.check(-1e3, "mu").unwrap(), -1e3);
    }
}
