//! The memory held by finished answers that their clients have not read.
//!
//! An answer is built whole (a WAV, a profile as JSON: up to tens of MB)
//! and then written to the connection as fast as the client reads it. A
//! client that never reads keeps its answer in the server's memory (150
//! such clients took the server from 0.3 to 2.4 GB). Three things bound
//! that memory:
//!
//! - a budget: every answer's bytes are counted from the moment it is
//!   built until hyper has taken its last byte (the gauge
//!   [`AppState::unsent_answer_bytes`]); an answer larger than
//!   [`Limits::small_answer_bytes`] that would take the gauge past
//!   [`Limits::max_unsent_answer_bytes`] is refused with 503 (its memory
//!   freed at once). Small answers (errors, health, small profiles) are
//!   always sent, so the server stays reachable;
//! - hyper takes an answer in chunks of [`CHUNK_BYTES`], each a copy, and
//!   holds at most its write buffer ([`Limits::head_buffer_bytes`]) of
//!   them per connection, so once hyper has taken the last chunk the
//!   answer's own buffer is freed and no longer counted;
//! - the write timeout of [`crate::connection`]: a connection that takes
//!   no bytes for [`Limits::write_timeout`] is closed and its answer freed.
//!
//! So unread answers hold at most `max_unsent_answer_bytes` plus, per
//! connection, one write buffer, for at most the write timeout.
//!
//! [`AppState::unsent_answer_bytes`]: crate::AppState::unsent_answer_bytes
//! [`Limits::small_answer_bytes`]: crate::Limits::small_answer_bytes
//! [`Limits::max_unsent_answer_bytes`]: crate::Limits::max_unsent_answer_bytes
//! [`Limits::head_buffer_bytes`]: crate::Limits::head_buffer_bytes
//! [`Limits::write_timeout`]: crate::Limits::write_timeout

use std::pin::Pin;
use std::task::{Context, Poll};

use axum::body::{Body, Bytes};
use axum::extract::{Request, State};
use axum::http::{HeaderValue, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use hyper::body::{Body as HttpBody, Frame, SizeHint};

use crate::error::ApiError;
use crate::state::AppState;

/// Size of the pieces an answer is handed to the connection in.
pub const CHUNK_BYTES: usize = 64 << 10;

/// Middleware: counts every answer's bytes until sent, and refuses a large
/// answer that would pass the budget (503, `Retry-After`).
pub async fn budget(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let response = next.run(request).await;
    let hint = response.body().size_hint();
    let bytes = usize::try_from(hint.exact().unwrap_or(hint.lower())).unwrap_or(usize::MAX);
    let limits = state.limits();
    if !state.reserve_answer(bytes, bytes <= limits.small_answer_bytes) {
        drop(response);
        let mut refused = ApiError::unavailable(format!(
            "the server holds {} MiB of answers its clients have not read yet (at most {} MiB); this answer of {} \
             KiB would pass that: try again in a few seconds",
            state.unsent_answer_bytes() >> 20,
            limits.max_unsent_answer_bytes >> 20,
            bytes >> 10
        ))
        .into_response();
        refused.headers_mut().insert(header::RETRY_AFTER, HeaderValue::from_static("2"));
        return refused;
    }
    let (parts, body) = response.into_parts();
    Response::from_parts(parts, Body::new(Unsent { body, pending: Bytes::new(), bytes, state }))
}

/// An answer's body, counted in the budget until dropped, handed out in
/// copied chunks of [`CHUNK_BYTES`].
struct Unsent {
    body: Body,
    /// The rest of the frame being handed out.
    pending: Bytes,
    /// Bytes counted for this answer.
    bytes: usize,
    state: AppState,
}

impl HttpBody for Unsent {
    type Data = Bytes;
    type Error = axum::Error;

    fn poll_frame(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Result<Frame<Bytes>, Self::Error>>> {
        if self.pending.is_empty() {
            match Pin::new(&mut self.body).poll_frame(cx) {
                Poll::Ready(Some(Ok(frame))) => match frame.into_data() {
                    Ok(data) if data.len() > CHUNK_BYTES => self.pending = data,
                    Ok(data) => return Poll::Ready(Some(Ok(Frame::data(data)))),
                    Err(frame) => return Poll::Ready(Some(Ok(frame))),
                },
                other => return other,
            }
        }
        // A copy, not a slice: a slice would keep the whole buffer alive
        // in hyper's write queue after this body is dropped.
        let n = self.pending.len().min(CHUNK_BYTES);
        let chunk = Bytes::copy_from_slice(&self.pending[..n]);
        if n == self.pending.len() {
            self.pending = Bytes::new();
        } else {
            let rest = self.pending.slice(n..);
            self.pending = rest;
        }
        Poll::Ready(Some(Ok(Frame::data(chunk))))
    }

    fn is_end_stream(&self) -> bool {
        self.pending.is_empty() && self.body.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        let inner = self.body.size_hint();
        let pending = self.pending.len() as u64;
        match inner.exact() {
            Some(n) => SizeHint::with_exact(n + pending),
            None => {
                let mut hint = SizeHint::new();
                hint.set_lower(inner.lower() + pending);
                if let Some(upper) = inner.upper() {
                    hint.set_upper(upper + pending);
                }
                hint
            }
        }
    }
}

impl Drop for Unsent {
    fn drop(&mut self) {
        self.state.release_answer(self.bytes);
        if self.bytes > self.state.limits().small_answer_bytes {
            crate::memory::freed_large();
        }
    }
}
