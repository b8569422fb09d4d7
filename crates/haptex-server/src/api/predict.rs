//! `POST /api/predict`: the friction profile of a template surface (bump,
//! edge or sine) predicted from the FE database by the conditional average
//! estimator (paper section 3.2), in microseconds: the same computation as
//! `haptex predict`.
//!
//! Body (JSON): `{"surface": "bump", "x0_mm": 5, "width_mm": 1.3,
//! "height_mm": 0.27, "velocity_mm_s": 20}` (`x0_mm` defaults to 5 mm,
//! `velocity_mm_s` to 20 mm/s). Parameters outside the database's range
//! but within the accepted range ([`crate::templates`]) are predicted with
//! `extrapolation: true` and a warning; beyond it they are refused (400).
//! At a database case, the FE profile itself is returned (`fe_exact`).
//!
//! The answer is the profile (as `POST /api/profile` gives it) plus the
//! surface height `h_mm` at each x, where the profile comes from, the
//! warnings and the template's typical error; `?format=csv` answers the
//! `x_mm,mu` file `haptex predict` writes.

use axum::Json;
use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{RawQuery, State};
use axum::http::HeaderMap;
use axum::response::{IntoResponse, Response};
use haptex_core::database::Template;
use haptex_core::profile::FrictionProfile;
use serde::Deserialize;
use serde_json::json;

use crate::error::ApiError;
use crate::input::{BodyKind, Query, body_bytes, body_kind, parse_json};
use crate::state::AppState;
use crate::templates::{DEFAULT_VELOCITY_MM_S, DEFAULT_X0_MM, MAX_ABS_X0_MM, TemplateSet};

/// The JSON body; every field optional here so that a missing one is
/// refused naming it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PredictBody {
    #[serde(default)]
    surface: Option<String>,
    #[serde(default)]
    x0_mm: Option<f64>,
    #[serde(default)]
    width_mm: Option<f64>,
    #[serde(default)]
    height_mm: Option<f64>,
    #[serde(default)]
    velocity_mm_s: Option<f64>,
}

fn required<T>(value: Option<T>, field: &str) -> Result<T, ApiError> {
    value.ok_or_else(|| ApiError::bad_request(format!("{field} is required"), Some(field)))
}

pub async fn post(
    State(state): State<AppState>,
    headers: HeaderMap,
    RawQuery(raw_query): RawQuery,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, ApiError> {
    let mut query = Query::parse(raw_query.as_deref())?;
    let format = query.take_format(&["json", "csv"])?;
    query.finish()?;
    body_kind(&headers, &[BodyKind::Json])?;
    let body: PredictBody = parse_json(&body_bytes(body, state.limits().max_body_bytes)?)?;
    let set = state.templates()?;
    let surface = required(body.surface, "surface")?;
    let (width, height) = (required(body.width_mm, "width_mm")?, required(body.height_mm, "height_mm")?);

    let unknown = || {
        let names: Vec<&str> = set.templates().map(Template::name).collect();
        ApiError::bad_request(
            format!("unknown surface {surface:?}: this server predicts {}", names.join(", ")),
            Some("surface"),
        )
    };
    let template = Template::parse(&surface).ok_or_else(unknown)?;
    let model = set.model(template).ok_or_else(unknown)?;
    let entry = set.metadata().entry(template).ok_or_else(unknown)?;

    let x0 = body.x0_mm.unwrap_or(DEFAULT_X0_MM);
    if !(x0.is_finite() && x0.abs() <= MAX_ABS_X0_MM) {
        return Err(ApiError::bad_request(
            format!("x0_mm = {x0} mm: give a position from {} to {MAX_ABS_X0_MM} mm", -MAX_ABS_X0_MM),
            Some("x0_mm"),
        ));
    }
    let query = [width, height, body.velocity_mm_s.unwrap_or(DEFAULT_VELOCITY_MM_S)];
    let ranges = TemplateSet::ranges(model);
    for (range, value) in ranges.iter().zip(query) {
        if !range.accepts(value) {
            return Err(ApiError::bad_request(
                format!(
                    "{} = {value} {} is out of range: this server accepts {} .. {} {} (the FE database covers {} .. \
                     {} {}; beyond a factor {} of it an estimate would be meaningless)",
                    range.name,
                    range.unit,
                    range.accepted[0],
                    range.accepted[1],
                    range.unit,
                    range.database[0],
                    range.database[1],
                    range.unit,
                    crate::templates::REACH
                ),
                Some(range.name),
            ));
        }
    }

    let prediction =
        model.predict(x0, query[0], query[1], query[2]).map_err(|e| ApiError::bad_request(e.to_string(), None))?;
    let source = model.describe(&query, &prediction, entry);
    let warning = model.warning(&query, prediction.fe_row, &prediction.diagnostics);
    let profile = FrictionProfile::new(prediction.x_mm.clone(), prediction.mu.clone())
        .map_err(|e| ApiError::internal(format!("the predicted profile is invalid: {e}")))?;
    let parameters = json!({ "x0_mm": x0, "width_mm": query[0], "height_mm": query[1], "velocity_mm_s": query[2] });

    if format == "csv" {
        let mut comments = vec![format!(
            "haptex predict: {} x0={x0} mm r_w={} mm r_h={} mm velocity={} mm/s",
            template.name(),
            query[0],
            query[1],
            query[2]
        )];
        comments.push(source);
        comments.extend(warning.map(|w| format!("warning: {w}")));
        let bytes = super::to_csv(|w| profile.write_csv_commented(w, &comments))?;
        return Ok(super::csv_response(
            bytes,
            &format!("{}-w{}-h{}-v{}.csv", template.name(), query[0], query[1], query[2]),
        ));
    }

    let outside: Vec<&str> =
        ranges.iter().zip(query).filter(|(r, v)| !r.in_database(*v)).map(|(r, _)| r.name).collect();
    let h_mm: Vec<f64> = prediction.x_mm.iter().map(|&x| template.height_mm(x, x0, query[0], query[1])).collect();
    let mut answer = super::profile::profile_json(&profile);
    answer["surface"] = json!(template.name());
    answer["formula"] = json!(super::templates::formula(template));
    answer["parameters"] = parameters;
    answer["fe_exact"] = json!(prediction.fe_row.is_some());
    answer["fe_row"] = json!(prediction.fe_row.map(|r| r + 1));
    answer["source"] = json!(source);
    answer["extrapolation"] = json!(warning.is_some());
    answer["outside_database"] = json!(outside);
    answer["warnings"] = json!(warning.into_iter().collect::<Vec<_>>());
    answer["diagnostics"] = json!(prediction.diagnostics);
    answer["loo_rmse"] = json!(entry.loo_rmse);
    answer["loo_rmse_relative_to_range"] = json!(entry.loo_rmse_relative_to_range);
    answer["h_mm"] = json!(h_mm);
    Ok(Json(answer).into_response())
}
