//! `GET /api/health`: the server is up.

use axum::Json;
use axum::extract::{RawQuery, State};
use serde_json::{Value, json};

use crate::error::ApiError;
use crate::input::Query;
use crate::state::AppState;

pub async fn get(State(state): State<AppState>, RawQuery(raw_query): RawQuery) -> Result<Json<Value>, ApiError> {
    Query::parse(raw_query.as_deref())?.finish()?;
    Ok(Json(json!({
        "status": "ok",
        "version": env!("CARGO_PKG_VERSION"),
        "library": state.has_library(),
        "templates": state.has_templates(),
    })))
}
