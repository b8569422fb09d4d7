//! `GET /api/live`: whether the server plays designs live on an audio
//! output (`haptex serve --live`), and its limits; `GET /api/live/ws`: the
//! page's WebSocket to it ([`crate::live::converse`]).
//!
//! The WebSocket is refused (JSON errors, before the upgrade) when the
//! server has no live output (404), when another page holds it (409), and
//! when the request comes from a page of another site (403, before any
//! handler: [`crate::access`]): a browser lets any page open a WebSocket
//! to any address, so the `Origin` it sends must name this server (clients
//! that send no `Origin`, which are not browsers, are let in: the host
//! check and the token of every request apply).

use axum::Json;
use axum::extract::State;
use axum::extract::ws::WebSocketUpgrade;
use axum::extract::ws::rejection::WebSocketUpgradeRejection;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde_json::{Value, json};

use crate::error::ApiError;
use crate::extract::NoQuery;
use crate::state::AppState;

pub async fn get(State(state): State<AppState>, _: NoQuery) -> Result<Json<Value>, ApiError> {
    Ok(Json(match state.live() {
        Some(hub) => json!({ "available": true, "output": hub.info() }),
        None => json!({ "available": false, "output": null }),
    }))
}

pub async fn socket(
    State(state): State<AppState>,
    _: NoQuery,
    upgrade: Result<WebSocketUpgrade, WebSocketUpgradeRejection>,
) -> Result<Response, ApiError> {
    let hub = state.live().ok_or_else(|| {
        ApiError::not_found("this server has no live output: start it with haptex serve --live (docs/live.md)", None)
    })?;
    let upgrade = upgrade.map_err(|e| {
        ApiError::bad_request(format!("GET /api/live/ws is a WebSocket: {}", e.body_text()), Some("upgrade"))
    })?;
    let claim = hub.claim().ok_or_else(|| {
        ApiError::new(
            StatusCode::CONFLICT,
            "the live output is in use by another page (one page drives it at a time)",
            Some("live"),
        )
    })?;
    let limits = state.limits();
    let max_points = limits.max_points;
    Ok(upgrade
        .max_message_size(limits.max_body_bytes)
        .max_frame_size(limits.max_body_bytes)
        .on_upgrade(move |socket| crate::live::converse(socket, claim, max_points))
        .into_response())
}
