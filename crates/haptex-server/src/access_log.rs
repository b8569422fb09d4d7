//! The request log: one line per request when switched on (`haptex serve
//! --access-log`), off by default (a line per request grows the log
//! without bound on a busy or attacked server); server errors (500 and
//! the like: a bug or a broken file, never a client's doing) are logged
//! either way, 503 (busy: a limit doing its job) only with the access log
//! or at debug level.
//!
//! A line: method, path (quoted, control characters escaped, at most 200
//! characters: a hostile path cannot forge log lines or fill the disk),
//! status, latency in microseconds.

use std::time::Instant;

use axum::extract::{Request, State};
use axum::http::StatusCode;
use axum::middleware::Next;
use axum::response::Response;

use crate::state::AppState;

/// Middleware: logs the request as the module documentation says.
pub async fn log(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let started = Instant::now();
    let method = request.method().clone();
    let path = short(request.uri().path()).to_string();
    let response = next.run(request).await;
    let status = response.status();
    let micros = started.elapsed().as_micros();
    if status.is_server_error() && status != StatusCode::SERVICE_UNAVAILABLE {
        tracing::error!("{method} {path:?} {} {micros} us", status.as_u16());
    } else if state.access_log() {
        tracing::info!("{method} {path:?} {} {micros} us", status.as_u16());
    } else if status == StatusCode::SERVICE_UNAVAILABLE {
        tracing::debug!("{method} {path:?} {} {micros} us", status.as_u16());
    }
    response
}

/// `path`, at most 200 characters.
fn short(path: &str) -> &str {
    match path.char_indices().nth(200) {
        Some((end, _)) => &path[..end],
        None => path,
    }
}
