//! `POST /api/profile`: check a friction profile (JSON `{"x_mm": [..],
//! "mu": [..]}`, or a `text/csv` file) and return it normalized: JSON with
//! its summary, or `?format=csv` as `x_mm,mu` (`x_mm,mu,fn_n` when the
//! normal force is known). The GUI uses it to offer the profile it shows
//! as a CSV download.

use axum::Json;
use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{RawQuery, State};
use axum::http::HeaderMap;
use axum::response::{IntoResponse, Response};
use haptex_core::profile::FrictionProfile;
use serde_json::json;

use crate::error::ApiError;
use crate::input::{BodyKind, ProfileJson, Query, body_bytes, body_kind, parse_json, profile_from_csv};
use crate::state::AppState;
use crate::work;

pub async fn post(
    State(state): State<AppState>,
    headers: HeaderMap,
    RawQuery(raw_query): RawQuery,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, ApiError> {
    let limits = state.limits().clone();
    let mut query = Query::parse(raw_query.as_deref())?;
    let format = query.take_format(&["json", "csv"])?;
    query.finish()?;
    let kind = body_kind(&headers, &[BodyKind::Json, BodyKind::Csv])?;
    let bytes = body_bytes(body, limits.max_body_bytes)?;
    work::cpu(&state, bytes.len(), move || {
        let profile = match kind {
            BodyKind::Json => parse_json::<ProfileJson>(&bytes)?.into_profile("", limits.max_points)?,
            BodyKind::Csv => profile_from_csv(&bytes, limits.max_points)?,
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
