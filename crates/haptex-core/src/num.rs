//! Numbers in messages.
//!
//! An error that quotes a value the user gave must quote it readably
//! whatever it is: `{}` on an `f64` prints 1e308 as 309 digits and 5e-324
//! as 324 zeros. [`Num`] prints the shortest text that reads back as the
//! same `f64` (ryu), in exponent form when the number is large or small
//! (`1e308`, `5e-324`), without a trailing `.0` (`5`, not `5.0`), and
//! `NaN`, `inf`, `-inf` for the non-finite values.

use std::fmt;

/// 1.5 * 2^52: added to a double below 2^51 in magnitude, the sum's last
/// place is 1, so the addition rounds the double to an integer (ties to
/// even) and the sum's low bits hold that integer (two's complement).
const ROUND_SHIFTER: f64 = 6755399441055744.0;

/// `v` rounded to the nearest integer (ties to even), and the bits of
/// `v + 1.5 * 2^52`, whose low bits hold that integer; |v| < 2^51. Plain
/// arithmetic, no libm `round` call, so a loop over it vectorizes. The
/// polynomial exp of the CAE, the carrier's sine and the WAV encoder's
/// rounding use it.
#[inline(always)]
pub(crate) fn round_shifted(v: f64) -> (f64, u64) {
    let shifted = v + ROUND_SHIFTER;
    (shifted - ROUND_SHIFTER, shifted.to_bits())
}

/// The integer in the low bits of `round_shifted(v).1`, as the bits of a
/// two's complement integer (wrapping).
#[inline(always)]
pub(crate) fn shifted_integer_bits(bits: u64) -> u64 {
    bits.wrapping_sub(ROUND_SHIFTER.to_bits())
}

/// Displays an `f64` as the shortest text that parses back to it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v.is_nan() {
            return f.write_str("NaN");
        }
        if v.is_infinite() {
            return f.write_str(if v > 0.0 { "inf" } else { "-inf" });
        }
        let mut buffer = ryu::Buffer::new();
        let text = buffer.format_finite(v);
        f.write_str(text.strip_suffix(".0").unwrap_or(text))
    }
}

/// Displays a list of numbers as `[a, b, c]` with [`Num`], at most
/// `limit` of them (then `, ... (N in all)`), so that a message quoting a
/// user's list stays short whatever its length.
#[derive(Debug, Clone, Copy)]
pub struct Nums<'a>(pub &'a [f64]);

impl fmt::Display for Nums<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const LIMIT: usize = 8;
        f.write_str("[")?;
        for (i, v) in self.0.iter().take(LIMIT).enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{}", Num(*v))?;
        }
        if self.0.len() > LIMIT {
            write!(f, ", ... ({} in all)", self.0.len())?;
        }
        f.write_str("]")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extreme_values_are_short_and_read_back() {
        for (v, text) in [
            (1e308, "1e308"),
            (5e-324, "5e-324"),
            (-1.7976931348623157e308, "-1.7976931348623157e308"),
            (0.1, "0.1"),
            (5.0, "5"),
            (-0.0, "-0"),
            (123456.5, "123456.5"),
            (f64::NAN, "NaN"),
            (f64::INFINITY, "inf"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            let shown = Num(v).to_string();
            assert_eq!(shown, text);
            assert!(shown.len() <= 24, "{shown}");
            if v.is_finite() {
                assert_eq!(shown.parse::<f64>().unwrap().to_bits(), v.to_bits(), "{shown}");
            }
        }
    }

    #[test]
    fn long_lists_are_cut() {
        assert_eq!(Nums(&[1.0, 2.5]).to_string(), "[1, 2.5]");
        let many: Vec<f64> = (0..100).map(f64::from).collect();
        assert_eq!(Nums(&many).to_string(), "[0, 1, 2, 3, 4, 5, 6, 7, ... (100 in all)]");
    }
}
