//! `POST /api/profile`: check a friction profile (JSON `{"x_mm": [..],
//! "mu": [..]}`, or a `text/csv` file) and return it normalized: JSON with
//! its summary, or `?format=csv` as `x_mm,mu` (`x_mm,mu,fn_n` when the
//! normal force is known). The GUI uses it to offer the profile it shows
//! as a CSV download.

use axum::Json;
use axum::response::{IntoResponse, Response};
use haptex_core::profile::FrictionProfile;
use serde_json::json;

use crate::error::ApiError;
use crate::extract::{JSON_OR_CSV, Preamble, Route};
use crate::input::{BodyKind, ProfileJson, parse_json, profile_from_csv};

/// The route: a JSON or CSV profile, answered as JSON or CSV.
pub(crate) struct Profile;

impl Route for Profile {
    const BODY: &'static [BodyKind] = &[BodyKind::Json, BodyKind::Csv];
    const FORMATS: &'static [&'static str] = JSON_OR_CSV;
}

pub async fn post(call: Preamble<Profile>) -> Result<Response, ApiError> {
    let Preamble { state, format, kind, bytes, slot, .. } = call;
    let max_points = state.limits().max_points;
    slot.run(move || {
        let profile = match kind {
            BodyKind::Json => parse_json::<ProfileJson>(&bytes)?.into_profile("", max_points)?,
            BodyKind::Csv => profile_from_csv(&bytes, max_points)?,
        };
        Ok(match format {
            "csv" => {
                let comments = vec![format!("haptex friction profile, {} points", profile.len())];
                super::csv_response(super::to_csv(|w| profile.write_csv_commented(w, &comments))?, "profile.csv")
            }
            _ => Json(profile_json(&profile)).into_response(),
        })
    })
    .await
}

/// A profile and its summary as JSON (`fn_n` and `mean_fn_n` are null
/// when the normal force is unknown).
pub(crate) fn profile_json(profile: &FrictionProfile) -> serde_json::Value {
    let (mu_min, mu_max) =
        profile.mu().iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &m| (lo.min(m), hi.max(m)));
    json!({
        "n_points": profile.len(),
        "x_min_mm": profile.x_mm()[0],
        "x_max_mm": profile.x_mm()[profile.len() - 1],
        "mu_min": mu_min,
        "mu_max": mu_max,
        "mean_fn_n": profile.mean_fn_n(),
        "x_mm": profile.x_mm(),
        "mu": profile.mu(),
        "fn_n": profile.fn_n(),
    })
}
