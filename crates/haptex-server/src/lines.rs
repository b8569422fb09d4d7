//! Answers streamed as JSON lines (NDJSON, `application/x-ndjson`): the
//! progress of long work while it runs, then its result.
//!
//! The check on the finger model runs the FE model once (about 0.3 s on a
//! 10 mm profile) and the compensation up to 8 times (seconds): long
//! enough that a person wants to see it move. One request carries the
//! input, the progress and the result, so the server keeps nothing
//! between requests (no job store, no ids, no result waiting for a client
//! that never comes back) and the rules of every other route hold: the
//! body is checked and refused with a 4xx, and the FE slot taken or
//! refused with 503, before the answer starts; only then is `200` sent and
//! the lines follow, one JSON object each:
//!
//! - `{"progress": {...}}` while the work runs, at most every
//!   [`PROGRESS_EVERY`] and at each new FE run;
//! - then exactly one of `{"result": {...}}` or `{"error": message,
//!   "field": null, "status": code}` (a failure found while running: the
//!   FE model's own message, as a status code it would have had).
//!
//! The work runs on a blocking thread and sends its lines through an
//! unbounded channel: it never waits for the client. The lines are few
//! (a progress line per [`PROGRESS_EVERY`] of work, which the request's
//! step budget bounds, and one result), so a client that reads nothing
//! holds at most those, until the write timeout closes its connection
//! (`crate::connection`). A client that goes away does not stop the work
//! (the FE model has no way to be interrupted); it finishes, bounded by
//! the same budget, and frees its slot, as abandoned work does everywhere
//! in this server (`crate::work`).

use std::pin::Pin;
use std::task::{Context, Poll};
use std::time::{Duration, Instant};

use axum::body::{Body, Bytes};
use axum::http::{HeaderValue, header};
use axum::response::{IntoResponse, Response};
use hyper::body::{Body as HttpBody, Frame};
use serde::Serialize;
use tokio::sync::mpsc::{UnboundedReceiver, UnboundedSender, unbounded_channel};

use crate::error::ApiError;

/// The media type of the answer.
pub const CONTENT_TYPE: &str = "application/x-ndjson";

/// Shortest interval between two progress lines.
pub const PROGRESS_EVERY: Duration = Duration::from_millis(100);

/// The sending end: the work writes its lines here.
pub(crate) struct Lines {
    tx: UnboundedSender<Bytes>,
    last_progress: Option<(Instant, usize)>,
}

/// A new stream: its sending end and the `200` answer that carries it.
pub(crate) fn stream() -> (Lines, Response) {
    let (tx, rx) = unbounded_channel();
    let response = (
        [
            (header::CONTENT_TYPE, HeaderValue::from_static(CONTENT_TYPE)),
            (header::CACHE_CONTROL, HeaderValue::from_static("no-store")),
        ],
        Body::new(LineBody { rx }),
    )
        .into_response();
    (Lines { tx, last_progress: None }, response)
}

impl Lines {
    /// Sends one line (`value` as JSON and a newline); false when the
    /// client has gone.
    fn send(&self, value: &impl Serialize) -> bool {
        match serde_json::to_vec(value) {
            Ok(mut line) => {
                line.push(b'\n');
                self.tx.send(Bytes::from(line)).is_ok()
            }
            Err(e) => {
                tracing::error!("cannot serialize a line of a streamed answer: {e}");
                false
            }
        }
    }

    /// Sends `{"progress": progress}` if `stage` (an FE run's number) is
    /// new or [`PROGRESS_EVERY`] has passed since the last progress line.
    pub fn progress(&mut self, stage: usize, progress: impl FnOnce() -> serde_json::Value) {
        let now = Instant::now();
        let due = match self.last_progress {
            None => true,
            Some((at, last_stage)) => stage != last_stage || now.duration_since(at) >= PROGRESS_EVERY,
        };
        if due {
            self.last_progress = Some((now, stage));
            self.send(&serde_json::json!({ "progress": progress() }));
        }
    }

    /// Sends the last line: the result, or the error. (The stream ends
    /// when `self` is dropped.)
    pub fn finish(&self, result: Result<serde_json::Value, ApiError>) {
        match result {
            Ok(value) => {
                self.send(&serde_json::json!({ "result": value }));
            }
            Err(e) => {
                if e.status.is_server_error() {
                    tracing::error!(status = e.status.as_u16(), "{}", e.message);
                } else {
                    tracing::debug!(status = e.status.as_u16(), "{}", e.message);
                }
                self.send(&ErrorLine { error: &e, status: e.status.as_u16() });
            }
        }
    }
}

/// An error line: the API's error object with its status.
#[derive(Serialize)]
struct ErrorLine<'a> {
    #[serde(flatten)]
    error: &'a ApiError,
    status: u16,
}

/// The answer's body: the lines as they are sent; it ends when the work
/// has finished (the sending end is dropped).
struct LineBody {
    rx: UnboundedReceiver<Bytes>,
}

impl HttpBody for LineBody {
    type Data = Bytes;
    type Error = axum::Error;

    fn poll_frame(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Result<Frame<Bytes>, Self::Error>>> {
        self.rx.poll_recv(cx).map(|line| line.map(|bytes| Ok(Frame::data(bytes))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn lines_arrive_in_order_and_the_stream_ends_with_the_work() {
        let (mut lines, response) = stream();
        assert_eq!(response.headers()[header::CONTENT_TYPE], CONTENT_TYPE);
        // The first progress line of a stage goes out, a second one within
        // the interval does not, a new stage does.
        lines.progress(0, || serde_json::json!({ "run": 1 }));
        lines.progress(0, || serde_json::json!({ "run": 1, "again": true }));
        lines.progress(1, || serde_json::json!({ "run": 2 }));
        lines.finish(Err(ApiError::new(axum::http::StatusCode::UNPROCESSABLE_ENTITY, "no", None)));
        drop(lines);
        let body = axum::body::to_bytes(response.into_body(), usize::MAX).await.unwrap();
        let text = String::from_utf8(body.to_vec()).unwrap();
        assert_eq!(
            text,
            "{\"progress\":{\"run\":1}}\n{\"progress\":{\"run\":2}}\n{\"error\":\"no\",\"field\":null,\"status\":422}\n"
        );
    }
}
