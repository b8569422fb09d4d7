//! The texture library (paper section 2.4): `GET /api/materials` lists the
//! materials (each with its `synthetic` flag: generated, not measured), and
//! `GET /api/materials/{name}/sample?seed=S` returns a random stroke's
//! friction profile (the paper's "random selection from the experimental
//! set"; the same seed selects the same stroke). `?format=csv` answers the
//! profile as CSV with its provenance in `#` comments.

use axum::Json;
use axum::extract::rejection::PathRejection;
use axum::extract::{Path, State};
use axum::response::{IntoResponse, Response};
use haptex_core::library::SampledProfile;
use serde_json::{Value, json};

use crate::error::ApiError;
use crate::extract::NoQuery;
use crate::input::Query;
use crate::state::AppState;

pub async fn list(State(state): State<AppState>, _: NoQuery) -> Result<Json<Value>, ApiError> {
    let pool = state.library()?;
    let file = pool.path().file_name().map(|n| n.to_string_lossy().into_owned());
    let materials = pool.with(|library| library.materials().map_err(ApiError::library)).await?;
    Ok(Json(json!({ "library": file, "materials": materials })))
}

pub async fn sample(
    State(state): State<AppState>,
    name: Result<Path<String>, PathRejection>,
    query: Result<Query, ApiError>,
) -> Result<Response, ApiError> {
    let Path(name) = name.map_err(|e| ApiError::bad_request(e.body_text(), Some("name")))?;
    let mut query = query?;
    let seed = query.take_u64("seed")?;
    let format = query.take_format(&["json", "csv"])?;
    query.finish()?;
    let pool = state.library()?;
    let library_sha256 = state.library_sha256();
    // The library read, the answer and its serialization on a blocking
    // thread (a stroke can have many thousand points).
    pool.with(move |library| {
        let sampled = library.sample(&name, seed).map_err(ApiError::library)?;
        let total = library.strokes(&name).map_err(ApiError::library)?.len();
        answer(&sampled, total, format, library_sha256.as_deref())
    })
    .await
}

/// The sample's answer: JSON, or CSV with the provenance in comments and
/// the recipe's rest (the haptex version and the library's SHA-256: with
/// the material and seed, what reproduces the file).
fn answer(
    sampled: &SampledProfile,
    total: usize,
    format: &str,
    library_sha256: Option<&str>,
) -> Result<Response, ApiError> {
    let stroke = &sampled.stored.stroke;
    let profile = &sampled.stored.profile;
    if format == "csv" {
        let mut comments = vec![format!(
            "haptex library sample: material {:?} ({} data), stroke id {} (one of {total}), seed {}",
            stroke.material,
            if stroke.synthetic { "SYNTHETIC" } else { "measured" },
            stroke.id,
            sampled.seed
        )];
        comments.extend(stroke.provenance_lines());
        comments.push(format!(
            "haptex {} (GET /api/materials/NAME/sample); library_sha256: {}",
            env!("CARGO_PKG_VERSION"),
            library_sha256.unwrap_or("(none)")
        ));
        let bytes = super::to_csv(|w| profile.write_csv_commented(w, &comments))?;
        return Ok(super::csv_response(bytes, &format!("{}-stroke-{}.csv", safe_name(&stroke.material), stroke.id)));
    }
    let mut answer = super::profile::profile_json(profile);
    answer["material"] = json!(stroke.material);
    answer["synthetic"] = json!(stroke.synthetic);
    answer["seed"] = json!(sampled.seed.to_string());
    answer["strokes_total"] = json!(total);
    answer["stroke"] = json!(stroke);
    Ok(Json(answer).into_response())
}

/// A material name reduced to characters safe in a file name.
fn safe_name(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect()
}
