//! `GET /api/health`: the server is up (and, to a client with the token,
//! its version and what it serves).

use axum::extract::State;
use axum::{Extension, Json};
use serde_json::{Value, json};

use crate::access::Authorized;
use crate::error::ApiError;
use crate::extract::NoQuery;
use crate::state::AppState;

/// Without the token of a server that needs one, only `{"status": "ok"}`.
pub async fn get(
    State(state): State<AppState>,
    authorized: Option<Extension<Authorized>>,
    _: NoQuery,
) -> Result<Json<Value>, ApiError> {
    if authorized.is_none() {
        return Ok(Json(json!({ "status": "ok" })));
    }
    Ok(Json(json!({
        "status": "ok",
        "version": env!("CARGO_PKG_VERSION"),
        "library": state.has_library(),
        "templates": state.has_templates(),
    })))
}
