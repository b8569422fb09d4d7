//! `GET /api/health`: the server is up.

use axum::Json;
use axum::extract::State;
use serde_json::{Value, json};

use crate::error::ApiError;
use crate::extract::NoQuery;
use crate::state::AppState;

pub async fn get(State(state): State<AppState>, _: NoQuery) -> Result<Json<Value>, ApiError> {
    Ok(Json(json!({
        "status": "ok",
        "version": env!("CARGO_PKG_VERSION"),
        "library": state.has_library(),
        "templates": state.has_templates(),
    })))
}
