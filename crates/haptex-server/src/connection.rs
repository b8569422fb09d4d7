//! One client connection's socket, as hyper sees it: a write timeout, and
//! the answers hyper writes by itself made like every other answer.
//!
//! - **Write timeout.** A client that stops reading leaves the answer in
//!   the server's memory. A connection that accepts none of the bytes
//!   written to it for [`Limits::write_timeout`] fails, hyper drops it,
//!   and the answer it held is freed (see [`crate::answers`] for the
//!   bound on what such clients can hold meanwhile).
//! - **hyper's own answers.** hyper answers a request it cannot parse (a
//!   garbage request line, an invalid header, a head beyond its buffer)
//!   itself, before the application sees anything: a bare `400`, `414` or
//!   `431` with an empty body and none of the security headers every
//!   answer must carry. hyper offers no hook for these, so this socket
//!   recognizes them on the way out and writes in their place the same
//!   status with the security headers and a JSON error body. Such an
//!   answer is recognized by three marks together: the connection has no
//!   request in the application (hyper writes it only between requests),
//!   the bytes start an HTTP/1.1 status line with a 4xx status, and the
//!   head lacks `x-content-type-options`, which every answer of the
//!   application carries (the middleware sets it).
//!
//! [`Limits::write_timeout`]: crate::Limits::write_timeout

use std::future::Future;
use std::io;
use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::task::{Context, Poll, ready};
use std::time::Duration;

use axum::body::Bytes;
use axum::http::StatusCode;
use hyper::body::{Body as HttpBody, Frame, SizeHint};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::time::{Instant, Sleep};

use crate::assets::SECURITY_HEADERS;

/// The requests of one connection that the application is answering.
#[derive(Debug, Default)]
pub(crate) struct Requests {
    open: AtomicUsize,
}

impl Requests {
    /// Marks a request as open until the returned guard is dropped (with
    /// its answer's body, once hyper has taken all of it).
    pub fn open(self: &Arc<Self>) -> OpenRequest {
        self.open.fetch_add(1, Ordering::AcqRel);
        OpenRequest(Arc::clone(self))
    }

    fn idle(&self) -> bool {
        self.open.load(Ordering::Acquire) == 0
    }
}

/// An open request (see [`Requests::open`]).
#[derive(Debug)]
pub(crate) struct OpenRequest(Arc<Requests>);

impl Drop for OpenRequest {
    fn drop(&mut self) {
        self.0.open.fetch_sub(1, Ordering::AcqRel);
    }
}

/// An answer's body that keeps its request open until dropped.
pub(crate) struct Held<B> {
    body: B,
    _request: OpenRequest,
}

impl<B> Held<B> {
    pub fn new(body: B, request: OpenRequest) -> Self {
        Self { body, _request: request }
    }
}

impl<B: HttpBody<Data = Bytes> + Unpin> HttpBody for Held<B> {
    type Data = Bytes;
    type Error = B::Error;

    fn poll_frame(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Result<Frame<Bytes>, B::Error>>> {
        Pin::new(&mut self.body).poll_frame(cx)
    }

    fn is_end_stream(&self) -> bool {
        self.body.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.body.size_hint()
    }
}

/// What the connection's answers written by hyper itself say: the limits
/// behind a 414 or 431.
#[derive(Debug, Clone, Copy)]
pub(crate) struct HeadLimits {
    /// Bytes of a request head hyper reads.
    pub head_bytes: usize,
    /// Header fields hyper reads.
    pub headers: usize,
}

/// A connection's socket with a write timeout and hyper's own answers
/// rewritten (see the module documentation).
pub(crate) struct Socket<T> {
    inner: T,
    requests: Arc<Requests>,
    limits: HeadLimits,
    write_timeout: Duration,
    /// Fires when a write has been pending for the write timeout.
    stall: Option<Pin<Box<Sleep>>>,
    /// Whether `stall` is armed (a write is pending).
    stalled: bool,
    /// An answer being written in place of hyper's own.
    rewrite: Option<Rewrite>,
}

struct Rewrite {
    answer: Vec<u8>,
    written: usize,
    /// Length of hyper's head that the answer replaces.
    replaces: usize,
}

impl<T> Socket<T> {
    pub fn new(inner: T, requests: Arc<Requests>, limits: HeadLimits, write_timeout: Duration) -> Self {
        Self { inner, requests, limits, write_timeout, stall: None, stalled: false, rewrite: None }
    }
}

impl<T: AsyncWrite + Unpin> Socket<T> {
    /// `poll` (a write or a flush) under the write timeout: pending for
    /// longer than the timeout without progress is an error.
    fn timed<R>(&mut self, cx: &mut Context<'_>, poll: Poll<io::Result<R>>) -> Poll<io::Result<R>> {
        if poll.is_ready() {
            self.stalled = false;
            return poll;
        }
        let deadline = Instant::now() + self.write_timeout;
        let stall = self.stall.get_or_insert_with(|| Box::pin(tokio::time::sleep_until(deadline)));
        if !self.stalled {
            stall.as_mut().reset(deadline);
            self.stalled = true;
        }
        match stall.as_mut().poll(cx) {
            Poll::Ready(()) => Poll::Ready(Err(io::Error::new(
                io::ErrorKind::TimedOut,
                format!("the client accepted no bytes of the answer for {:?}", self.write_timeout),
            ))),
            Poll::Pending => Poll::Pending,
        }
    }

    /// Starts a rewrite if `first` (the start of what hyper writes) is one
    /// of hyper's own answers.
    fn recognize(&mut self, first: &[u8]) {
        if self.rewrite.is_none()
            && self.requests.idle()
            && let Some((status, replaces, date)) = hyper_answer(first)
        {
            let answer = answer_for(status, date, self.limits);
            self.rewrite = Some(Rewrite { answer, written: 0, replaces });
        }
    }

    /// Writes the rewritten answer; ready with the length of hyper's head
    /// once all of it is written.
    fn poll_rewrite(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<usize>> {
        while let Some(rewrite) = &mut self.rewrite {
            if rewrite.written == rewrite.answer.len() {
                let replaces = rewrite.replaces;
                self.rewrite = None;
                return Poll::Ready(Ok(replaces));
            }
            let poll = Pin::new(&mut self.inner).poll_write(cx, &rewrite.answer[rewrite.written..]);
            let n = ready!(self.timed(cx, poll))?;
            if n == 0 {
                return Poll::Ready(Err(io::ErrorKind::WriteZero.into()));
            }
            if let Some(rewrite) = &mut self.rewrite {
                rewrite.written += n;
            }
        }
        Poll::Ready(Ok(0))
    }
}

impl<T: AsyncRead + Unpin> AsyncRead for Socket<T> {
    fn poll_read(mut self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &mut ReadBuf<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_read(cx, buf)
    }
}

impl<T: AsyncWrite + Unpin> AsyncWrite for Socket<T> {
    fn poll_write(mut self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        let this = &mut *self;
        this.recognize(buf);
        if this.rewrite.is_some() {
            return this.poll_rewrite(cx);
        }
        let poll = Pin::new(&mut this.inner).poll_write(cx, buf);
        this.timed(cx, poll)
    }

    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[io::IoSlice<'_>],
    ) -> Poll<io::Result<usize>> {
        let this = &mut *self;
        if let Some(first) = bufs.iter().find(|b| !b.is_empty()) {
            this.recognize(first);
        }
        if this.rewrite.is_some() {
            return this.poll_rewrite(cx);
        }
        let poll = Pin::new(&mut this.inner).poll_write_vectored(cx, bufs);
        this.timed(cx, poll)
    }

    fn is_write_vectored(&self) -> bool {
        self.inner.is_write_vectored()
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let this = &mut *self;
        let poll = Pin::new(&mut this.inner).poll_flush(cx);
        this.timed(cx, poll)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let this = &mut *self;
        let poll = Pin::new(&mut this.inner).poll_shutdown(cx);
        this.timed(cx, poll)
    }
}

/// If `bytes` start with a head hyper writes for a request it could not
/// parse (an HTTP/1.1 4xx status line, a complete head, none of the
/// application's security headers): its status, its length and its Date.
fn hyper_answer(bytes: &[u8]) -> Option<(StatusCode, usize, Option<&[u8]>)> {
    let code = bytes.strip_prefix(b"HTTP/1.1 ")?.get(..3)?;
    if code[0] != b'4' {
        return None;
    }
    let status = StatusCode::from_bytes(code).ok()?;
    let end = bytes.windows(4).position(|w| w == b"\r\n\r\n")? + 4;
    let mut date = None;
    for line in bytes[..end].split(|&b| b == b'\n').skip(1) {
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        let Some(colon) = line.iter().position(|&b| b == b':') else { continue };
        let name = &line[..colon];
        if name.eq_ignore_ascii_case(b"x-content-type-options") {
            return None;
        }
        if name.eq_ignore_ascii_case(b"date") {
            date = Some(line[colon + 1..].trim_ascii());
        }
    }
    Some((status, end, date))
}

/// The answer written in place of hyper's own: the same status, the
/// security headers, a JSON error naming what could not be read.
fn answer_for(status: StatusCode, date: Option<&[u8]>, limits: HeadLimits) -> Vec<u8> {
    let (message, field) = match status {
        StatusCode::URI_TOO_LONG => {
            (format!("the request target is longer than this server reads ({} bytes)", limits.head_bytes), Some("uri"))
        }
        StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE => (
            format!(
                "the request head is larger than this server reads ({} bytes, at most {} header fields)",
                limits.head_bytes, limits.headers
            ),
            Some("headers"),
        ),
        StatusCode::BAD_REQUEST => {
            ("malformed request: its request line or a header field is not valid HTTP/1.1".to_string(), Some("request"))
        }
        other => (other.canonical_reason().unwrap_or("client error").to_lowercase(), None),
    };
    let body = serde_json::json!({ "error": message, "field": field }).to_string();
    let mut answer = format!(
        "HTTP/1.1 {} {}\r\ncontent-type: application/json\r\ncontent-length: {}\r\nconnection: close\r\n",
        status.as_str(),
        status.canonical_reason().unwrap_or(""),
        body.len()
    )
    .into_bytes();
    for (name, value) in SECURITY_HEADERS {
        answer.extend_from_slice(format!("{name}: {value}\r\n").as_bytes());
    }
    if let Some(date) = date {
        answer.extend_from_slice(b"date: ");
        answer.extend_from_slice(date);
        answer.extend_from_slice(b"\r\n");
    }
    answer.extend_from_slice(b"\r\n");
    answer.extend_from_slice(body.as_bytes());
    answer
}

/// Writes `answer` (a small JSON error with its headers) as a whole
/// HTTP/1.1 answer on `io` with the security headers and `connection:
/// close`, within `timeout`, then shuts the connection: for a connection
/// refused before any request is read (a client over its connections,
/// [`crate::clients`]).
pub(crate) async fn write_and_close<T>(mut io: T, answer: axum::response::Response, timeout: Duration)
where
    T: AsyncWrite + Unpin,
{
    use tokio::io::AsyncWriteExt;
    let (parts, body) = answer.into_parts();
    let Ok(body) = axum::body::to_bytes(body, 64 << 10).await else { return };
    let status = parts.status;
    let mut bytes =
        format!("HTTP/1.1 {} {}\r\n", status.as_str(), status.canonical_reason().unwrap_or("")).into_bytes();
    for (name, value) in &parts.headers {
        if name != "content-length" && name != "connection" {
            bytes.extend_from_slice(name.as_str().as_bytes());
            bytes.extend_from_slice(b": ");
            bytes.extend_from_slice(value.as_bytes());
            bytes.extend_from_slice(b"\r\n");
        }
    }
    for (name, value) in SECURITY_HEADERS {
        if !parts.headers.contains_key(name) {
            bytes.extend_from_slice(format!("{name}: {value}\r\n").as_bytes());
        }
    }
    bytes.extend_from_slice(format!("content-length: {}\r\nconnection: close\r\n\r\n", body.len()).as_bytes());
    bytes.extend_from_slice(&body);
    let _ = tokio::time::timeout(timeout, async {
        io.write_all(&bytes).await?;
        io.shutdown().await
    })
    .await;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hypers_bare_answers_are_recognized_the_applications_are_not() {
        let bare = b"HTTP/1.1 431 Request Header Fields Too Large\r\ncontent-length: 0\r\ndate: Tue, 24 Nov 2026 10:00:00 GMT\r\n\r\n";
        let (status, end, date) = hyper_answer(bare).unwrap();
        assert_eq!((status, end), (StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE, bare.len()));
        assert_eq!(date, Some(&b"Tue, 24 Nov 2026 10:00:00 GMT"[..]));
        let ours = b"HTTP/1.1 400 Bad Request\r\ncontent-type: application/json\r\nx-content-type-options: nosniff\r\ncontent-length: 2\r\n\r\n{}";
        assert!(hyper_answer(ours).is_none());
        assert!(hyper_answer(b"HTTP/1.1 200 OK\r\ncontent-length: 0\r\n\r\n").is_none());
        assert!(hyper_answer(b"HTTP/1.1 100 Continue\r\n\r\n").is_none());
        assert!(hyper_answer(b"x_mm,mu\n0,1\n").is_none());
        let answer = String::from_utf8(answer_for(status, date, HeadLimits { head_bytes: 1000, headers: 10 })).unwrap();
        assert!(answer.starts_with("HTTP/1.1 431 Request Header Fields Too Large\r\n"), "{answer}");
        let (head, body) = answer.split_once("\r\n\r\n").unwrap();
        assert!(head.contains("x-content-type-options: nosniff") && head.contains("date: Tue, 24 Nov"), "{head}");
        assert!(head.contains(&format!("content-length: {}", body.len())), "{head}");
        let json: serde_json::Value = serde_json::from_str(body).unwrap();
        assert_eq!(json["field"], "headers");
    }
}
