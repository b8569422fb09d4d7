//! Handlers, one module per resource.

pub mod config;
pub mod health;
pub mod materials;
pub mod openapi;
pub mod play;
pub mod predict;
pub mod profile;
pub mod simulate;
pub mod templates;
pub mod voltage;

use axum::http::{HeaderValue, header};
use axum::response::{IntoResponse, Response};

/// A CSV body offered as a download named `filename`.
pub(crate) fn csv_response(bytes: Vec<u8>, filename: &str) -> Response {
    let disposition = HeaderValue::from_str(&format!("attachment; filename=\"{filename}\""))
        .unwrap_or_else(|_| HeaderValue::from_static("attachment"));
    (
        [
            (header::CONTENT_TYPE, HeaderValue::from_static("text/csv; charset=utf-8")),
            (header::CONTENT_DISPOSITION, disposition),
        ],
        bytes,
    )
        .into_response()
}

/// Runs CSV writing into a buffer (writing to memory cannot fail short of
/// running out of it).
pub(crate) fn to_csv(
    fill: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
) -> Result<Vec<u8>, crate::ApiError> {
    let mut bytes = Vec::new();
    fill(&mut bytes).map_err(|e| crate::ApiError::internal(format!("cannot write CSV: {e}")))?;
    Ok(bytes)
}
