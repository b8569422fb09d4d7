//! `GET /api/live`: whether the server plays designs live on an audio
//! output (`haptex serve --live`), and its limits; `GET /api/live/ws`: the
//! page's WebSocket to it ([`crate::live::converse`]).
//!
//! The WebSocket is refused (JSON errors, before the upgrade) when the
//! server has no live output (404), when another page holds it (409), and
//! when the request comes from a page of another site (403): a browser
//! lets any page open a WebSocket to any address, so the `Origin` it sends
//! must name this server's own host (clients that send no `Origin`, which
//! are not browsers, are let in: the host check of every request applies).

use axum::Json;
use axum::extract::State;
use axum::extract::ws::WebSocketUpgrade;
use axum::extract::ws::rejection::WebSocketUpgradeRejection;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde_json::{Value, json};

use crate::error::{ApiError, quote};
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
    headers: HeaderMap,
    _: NoQuery,
    upgrade: Result<WebSocketUpgrade, WebSocketUpgradeRejection>,
) -> Result<Response, ApiError> {
    let hub = state.live().ok_or_else(|| {
        ApiError::not_found("this server has no live output: start it with haptex serve --live (docs/live.md)", None)
    })?;
    same_origin(&headers)?;
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

/// 403 unless the `Origin` (if any) is this server's own host, as the
/// `Host` header names it.
fn same_origin(headers: &HeaderMap) -> Result<(), ApiError> {
    let Some(origin) = headers.get(header::ORIGIN) else { return Ok(()) };
    let host = headers.get(header::HOST).and_then(|h| h.to_str().ok()).unwrap_or("");
    let origin_host = origin
        .to_str()
        .ok()
        .and_then(|o| o.strip_prefix("http://").or_else(|| o.strip_prefix("https://")))
        .unwrap_or("");
    if !host.is_empty() && origin_host.eq_ignore_ascii_case(host) {
        return Ok(());
    }
    Err(ApiError::new(
        StatusCode::FORBIDDEN,
        format!(
            "a page of another site ({}) may not drive the live output; open the page this server serves",
            quote(&String::from_utf8_lossy(origin.as_bytes()))
        ),
        Some("origin"),
    ))
}
