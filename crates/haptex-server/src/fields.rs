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

// The finger's settings of the check on the finger model (`POST
// /api/check`, `POST /api/compensate`), the server's own: `haptex check`
// leaves them to the FE model's wider limits.

/// Normal load of the finger, N per mm of finger width: 0.015 to 0.75 N
/// over a 15 mm wide pad. The FE finger's contact is then 0.4 to 6.3 mm
/// long (measured), inside its 12 mm contact region; at 0.2 N/mm the skin
/// reaches the region's end.
pub const LOAD_N_PER_MM: Range = Range { name: "load_n_per_mm", min: 0.001, max: 0.05, unit: "N/mm" };
/// Normal load of the 3D fingertip (`model` 3d), N: from a light touch to
/// twice the top of the paper's "typical screen exploration (< 0.5 N)",
/// the range of the contact-area measurements docs/fem.md compares with.
/// The 3D finger's contact stays inside its contact region over it
/// (measured: 0.015 to 5 N on the coarse mesh).
pub const LOAD_3D_N: Range = Range { name: "load_n", min: 0.015, max: 2.0, unit: "N" };
/// The 3D fingertip's direction of motion on the display, degrees from
/// its x axis (`haptex check --direction-deg`'s range).
pub const DIRECTION_DEG: Range = Range { name: "direction_deg", min: -360.0, max: 360.0, unit: "degrees" };
/// Sliding velocity of the finger on the display.
pub const CHECK_VELOCITY_MM_S: Range = Range { name: "velocity_mm_s", min: 1.0, max: 500.0, unit: "mm/s" };
/// Slide per FE step (the voltage is sampled once per step).
pub const STEP_MM: Range = Range { name: "step_mm", min: 0.005, max: 0.5, unit: "mm" };
/// The compensation's stopping tolerance on the RMS error, in units of mu.
pub const TOLERANCE: Range = Range { name: "tolerance", min: 0.0, max: 1.0, unit: "" };
/// Most FE runs of a compensation, eq. (8)'s included (issue 15's budget;
/// on the templates the compensation converges in 2 to 4).
pub const MAX_RUNS: u32 = 8;

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
        assert_eq!(check(ranges::MU, 1e3, "mu").unwrap(), 1e3);
        assert_eq!(check(ranges::MU, -1e3, "mu").unwrap(), -1e3);
        assert!(check(ranges::MU, -1000.5, "mu").is_err());
    }
}
