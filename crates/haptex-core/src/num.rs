//! Numbers in messages: the one rule for every number shown to a person
//! (errors, summaries, progress, help), [`Num`].
//!
//! An error that quotes a value the user gave must quote it readably
//! whatever it is: `{}` on an `f64` prints 1e308 as 309 digits and 5e-324
//! as 324 zeros, and `{:.4}` of 1e300 prints 301 digits. [`Num`] prints the
//! shortest text that reads back as the value rounded to 15 significant
//! digits, in exponent form when the number is large or small (`1e308`,
//! `5e-324`), without a trailing `.0` (`5`, not `5.0`), and `NaN`, `inf`,
//! `-inf` for the non-finite values.
//!
//! Why 15 digits: every decimal of 15 significant digits survives the trip
//! through an `f64` and back (DBL_DIG), so a value the user typed with up
//! to 15 digits is shown as typed, exactly, and reads back as the same
//! `f64`. A value whose shortest exact text needs 16 or 17 digits is
//! nearly always a computed one carrying rounding error in its last bits
//! (0.1 x 7 = 0.7000000000000001, 8.725000000000001): [`Num`] shows it
//! as the 15-digit decimal it rounds to (`0.7`, `8.725`), which differs
//! from it by less than one part in 10^15. Where those last bits matter,
//! the full text is [`Exact`]: data files keep full precision (CSV values
//! through `io::write_csv_row`, JSON through serde, and the numbers haptex
//! writes in a comment to read back later, such as a display profile's
//! `at most a_max = A um`); and a message comparing two values that differ
//! only beyond the 15th digit shows both in full ([`distinct`], and a
//! [`crate::ranges::RangeError`] whose value rounds to its bound).
//!
//! Fixed precision (`{:.3}`) is deliberate in summaries of bounded
//! quantities (a percentage, a duration); [`Fixed`] does it, falling back
//! to [`Num`] when the value is too large or not finite, so that fixed
//! precision of an unbounded value never prints hundreds of digits.
//!
//! [`unreadable_number`] finds a number that breaks the rule in a text:
//! the tests apply it to every message they examine.

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

/// Displays an `f64` for a person: the shortest text of the value
/// rounded to 15 significant digits (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if !v.is_finite() {
            return Exact(v).fmt(f);
        }
        let mut buffer = ryu::Buffer::new();
        let text = buffer.format_finite(v);
        if significant_digits(text) <= 15 {
            return f.write_str(text.strip_suffix(".0").unwrap_or(text));
        }
        // 16 or 17 digits: the 15-digit decimal it rounds to, which reads
        // back as a double whose shortest text has at most 15 digits.
        let rounded = format!("{v:.14e}");
        match rounded.parse::<f64>() {
            Ok(r) if r.is_finite() => Exact(r).fmt(f),
            // Rounding the largest doubles up leaves the f64 range: the text.
            _ => {
                let (mantissa, exponent) = rounded.split_once('e').unwrap_or((&rounded, "0"));
                let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
                write!(f, "{mantissa}e{exponent}")
            }
        }
    }
}

/// Displays an `f64` as the shortest text that parses back to it exactly
/// (ryu): up to 17 significant digits, for data that is read back, and for
/// messages that must tell apart values closer than 15 digits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exact(pub f64);

impl fmt::Display for Exact {
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

/// Two values for a message that compares them ("b follows a", "got v,
/// the limit is m"): both by [`Num`], or both [`Exact`] when they differ
/// but [`Num`] would show them alike.
pub fn distinct(a: f64, b: f64) -> (String, String) {
    let (ta, tb) = (Num(a).to_string(), Num(b).to_string());
    if ta == tb && a.to_bits() != b.to_bits() { (Exact(a).to_string(), Exact(b).to_string()) } else { (ta, tb) }
}

/// A value for a message that compares it with limits ("got v, must be
/// from a to b"): by [`Num`], or [`Exact`] when [`Num`] would show it as
/// one of the limits it differs from (1.0000000000000002 is not "1").
pub fn against(value: f64, limits: &[f64]) -> String {
    let text = Num(value).to_string();
    let collides = limits.iter().any(|&l| l.to_bits() != value.to_bits() && Num(l).to_string() == text);
    if collides { Exact(value).to_string() } else { text }
}

/// Fixed precision for a summary: `{:.N}` with `N` = the second field,
/// for values below 1e9 in magnitude; beyond, or not finite, [`Num`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fixed(pub f64, pub usize);

impl fmt::Display for Fixed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Fixed(v, decimals) = *self;
        if v.abs() < 1e9 { write!(f, "{v:.decimals$}") } else { Num(v).fmt(f) }
    }
}

/// Significant digits of a decimal text (its mantissa: from the first
/// non-zero digit to the last non-zero digit).
fn significant_digits(text: &str) -> usize {
    let mantissa = text.split(['e', 'E']).next().unwrap_or(text);
    let digits: Vec<u8> = mantissa.bytes().filter(u8::is_ascii_digit).collect();
    match (digits.iter().position(|&d| d != b'0'), digits.iter().rposition(|&d| d != b'0')) {
        (Some(first), Some(last)) => last - first + 1,
        _ => 0,
    }
}

/// The first number in `text` that breaks the rule of [`Num`]: a decimal
/// number (with a point or an exponent) of more than 15 significant
/// digits, or any run of digits longer than 40 characters (`{}` of 1e300
/// or 5e-324). Words with digits (a SHA-256 in hex, a file name) are not
/// numbers (nor is a SHA-256, 64 hexadecimal digits that may all be
/// decimal), and quoted text ('...' or "...", opening after a space or
/// punctuation) is the user's own, echoed, not a number haptex formatted.
/// The tests apply it to every message they examine.
pub fn unreadable_number(text: &str) -> Option<&str> {
    let mut rest = text;
    loop {
        // The text up to the next quoted span, then past it.
        let opening = rest.char_indices().find(|&(i, c)| {
            matches!(c, '\'' | '"') && rest[..i].chars().next_back().is_none_or(|p| !p.is_alphanumeric())
        });
        let (plain, after) = match opening {
            None => (rest, None),
            Some((i, quote)) => {
                let inner = &rest[i + 1..];
                let closing = inner
                    .char_indices()
                    .find(|&(j, c)| c == quote && inner[j + 1..].chars().next().is_none_or(|n| !n.is_alphanumeric()));
                match closing {
                    Some((j, _)) => (&rest[..i], Some(&inner[j + 1..])),
                    None => (rest, None),
                }
            }
        };
        if let Some(found) = unreadable_in(plain) {
            return Some(found);
        }
        match after {
            Some(after) => rest = after,
            None => return None,
        }
    }
}

/// [`unreadable_number`] in text without quotes.
fn unreadable_in(text: &str) -> Option<&str> {
    let is_word = |c: char| c.is_ascii_alphanumeric() || c == '.' || c == '_';
    let mut rest = text;
    while let Some(start) = rest.find(is_word) {
        let tail = &rest[start..];
        let mut end = tail.find(|c: char| !is_word(c)).unwrap_or(tail.len());
        // An exponent's sign: 1e-300, 2.5E+10.
        if tail[..end].ends_with(['e', 'E'])
            && tail[end..].starts_with(['-', '+'])
            && tail[end + 1..].starts_with(|c: char| c.is_ascii_digit())
        {
            end += 1 + tail[end + 1..].find(|c: char| !is_word(c)).unwrap_or(tail.len() - end - 1);
        }
        let token = tail[..end].trim_end_matches('.');
        // A SHA-256 in hex is 64 characters, and may be all digits.
        let hash = token.len() == 64 && token.bytes().all(|b| b.is_ascii_hexdigit());
        if is_number(token) && !hash {
            let mantissa = token.split(['e', 'E']).next().unwrap_or(token);
            let decimal = token.contains(['.', 'e', 'E']);
            if mantissa.len() > 40 || (decimal && significant_digits(token) > 15) {
                return Some(token);
            }
        }
        rest = &tail[end..];
    }
    None
}

/// Whether a word is a number: digits with at most one point, and an
/// optional exponent.
fn is_number(token: &str) -> bool {
    let (mantissa, exponent) = match token.split_once(['e', 'E']) {
        Some((m, e)) => (m, Some(e)),
        None => (token, None),
    };
    let digits_and_point = |s: &str| {
        s.bytes().any(|b| b.is_ascii_digit())
            && s.bytes().all(|b| b.is_ascii_digit() || b == b'.')
            && s.bytes().filter(|&b| b == b'.').count() <= 1
    };
    digits_and_point(mantissa)
        && exponent.is_none_or(|e| {
            let e = e.strip_prefix(['-', '+']).unwrap_or(e);
            !e.is_empty() && e.bytes().all(|b| b.is_ascii_digit())
        })
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
            (-1.79769313486231e308, "-1.79769313486231e308"),
            (0.1, "0.1"),
            (123456789012345.0, "123456789012345"),
            (0.123456789012345, "0.123456789012345"),
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

    /// Values whose exact text needs 16 or 17 digits read as the 15-digit
    /// decimal they round to; [`Exact`] keeps every digit; [`distinct`]
    /// falls back to it when the two would look alike.
    #[test]
    fn computed_values_read_as_the_decimal_they_round_to() {
        for (v, text) in [
            (0.1 * 7.0, "0.7"),
            (0.1 + 0.2, "0.3"),
            (8.725000000000001, "8.725"),
            (127.27922061357856, "127.279220613579"),
            (1.0000000000000002, "1"),
            (-1.7976931348623157e308, "-1.79769313486232e308"),
            (2.2250738585072014e-308, "2.2250738585072e-308"),
        ] {
            assert_eq!(Num(v).to_string(), text, "{v:?}");
            assert_eq!(unreadable_number(&Num(v).to_string()), None);
            assert_eq!(Exact(v).to_string().parse::<f64>().unwrap().to_bits(), v.to_bits());
        }
        assert_eq!(Exact(0.1 * 7.0).to_string(), "0.7000000000000001");
        assert_eq!(distinct(1.0, 1.0000000000000002), ("1".to_string(), "1.0000000000000002".to_string()));
        assert_eq!(distinct(1.0, 2.5), ("1".to_string(), "2.5".to_string()));
        assert_eq!(against(0.9900000000000001, &[0.01, 0.99]), "0.9900000000000001");
        assert_eq!(against(0.1 * 7.0, &[0.01, 0.99]), "0.7");
        assert_eq!(Fixed(0.12345, 3).to_string(), "0.123");
        assert_eq!(Fixed(1e300, 4).to_string(), "1e300");
        assert_eq!(Fixed(f64::NAN, 2).to_string(), "NaN");
    }

    /// The checker the tests use on messages.
    #[test]
    fn unreadable_numbers_are_found() {
        let long = format!("{}", 1e-300);
        for (text, found) in [
            ("x 0 .. 0.7000000000000001 mm", Some("0.7000000000000001")),
            ("got 8.725000000000001, expected", Some("8.725000000000001")),
            ("a 1.2345678901234567e-5 b", Some("1.2345678901234567e-5")),
            (long.as_str(), Some(long.as_str())),
            ("peak 127.279220613579 V, 30000000 samples, 1e308, 5e-324.", None),
            ("SHA-256 1b75678434819610fb01b0b74975ab9e567ddc239337c0e75b200be88f34d73f", None),
            ("18446744073709551615 bytes", None),
            ("SHA-256 0000000000000000000000000000000000000000000000000000000000000000)", None),
            ("version 1.2.3 file_12345678901234567890.csv", None),
            // The user's own text, echoed in quotes, is theirs.
            ("invalid value '1.7976931348623157e308' for '--u-max'", None),
            ("the finger's speed 0.30000000000000004 mm/s", Some("0.30000000000000004")),
            ("name \"0.30000000000000004\", then 0.7000000000000001", Some("0.7000000000000001")),
        ] {
            assert_eq!(unreadable_number(text), found, "{text}");
        }
    }

    #[test]
    fn long_lists_are_cut() {
        assert_eq!(Nums(&[1.0, 2.5]).to_string(), "[1, 2.5]");
        let many: Vec<f64> = (0..100).map(f64::from).collect();
        assert_eq!(Nums(&many).to_string(), "[0, 1, 2, 3, 4, 5, 6, 7, ... (100 in all)]");
    }
}
