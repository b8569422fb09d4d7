//! `GET /api/openapi.json`: the OpenAPI 3.1 description of the API
//! (hand-written, `src/openapi.json`; a test checks it lists exactly the
//! routes of [`crate::routes::table`]).

use axum::http::{HeaderValue, header};
use axum::response::IntoResponse;

use crate::error::ApiError;
use crate::extract::NoQuery;

/// The OpenAPI document.
pub const OPENAPI_JSON: &str = include_str!("../openapi.json");

pub async fn get(_: NoQuery) -> Result<impl IntoResponse, ApiError> {
    Ok(([(header::CONTENT_TYPE, HeaderValue::from_static("application/json"))], OPENAPI_JSON))
}
