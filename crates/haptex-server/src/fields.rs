//! Numeric request fields: the range each is accepted in, and the one
//! check every route and body format uses.
//!
//! Every number a request gives, and every number the server derives from
//! them before answering (mu = ft/fn), is checked here against its range,
//! and a value outside is refused with 400 naming the field (a JSON path
//! such as `profile.fn_n[3]`, a query parameter, or a CSV column with its
//! line) and quoting the value readably (`1e308`, not 309 digits). The ranges are wide (far beyond any finger, display or
//! recording) but finite, so that no sum, span, ratio or square the server
//! computes from accepted values can overflow to infinity or NaN. They are
//! haptex-core's ([`haptex_core::ranges`]), which the command line and the
//! file readers check too: a value is accepted by all or by none.

use haptex_core::ranges::Range;

use crate::error::ApiError;

/// Checks a request value against its range; the error names `field`
/// (a JSON path such as `stroke.velocity_mm_s`) and quotes the value.
pub fn check(range: Range, value: f64, field: &str) -> Result<f64, ApiError> {
    range.check(value).map_err(|e| ApiError::bad_request(e.to_string(), Some(field)))
}

#[cfg(test)]
mod tests {
    use haptex_core::ranges;

    use super::*;

    #[test]
    fn refusals_name_the_field_and_quote_the_value_short() {
        let e = check(ranges::FN_N, 5e-324, "profile.fn_n").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("profile.fn_n"));
        assert_eq!(e.message, "fn_n must be from 1e-6 to 100 N, got 5e-324");
        assert!(check(ranges::MU, f64::NAN, "mu").is_err() && check(ranges::MU, f64::INFINITY, "mu").is_err());
        assert_eq!(check(ranges::MU, -1e3, "mu").unwrap(), -1e3);
    }
}
