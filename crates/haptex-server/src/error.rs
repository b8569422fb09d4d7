//! Errors of the API, and the one place where they become responses.
//!
//! Every error a client gets is JSON: `{"error": message, "field": name}`
//! (`field` is `null` when no single field is at fault; `line` is added for
//! CSV bodies). Handlers return [`ApiError`]; responses that axum or a
//! middleware produce without a handler (unknown route, wrong method,
//! timeout) are rewritten into the same shape by [`json_client_errors`].

use std::any::Any;

use axum::Json;
use axum::extract::Request;
use axum::http::{HeaderValue, StatusCode, Uri, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use haptex_core::library::LibraryError;
use serde::Serialize;

/// An API error: status, message and the offending field.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ApiError {
    #[serde(skip)]
    pub status: StatusCode,
    /// What went wrong, for a person.
    #[serde(rename = "error")]
    pub message: String,
    /// The request field at fault (JSON path such as `profile.mu[3]`, a
    /// query parameter, a CSV column, `body`, `content-type`), if one is.
    pub field: Option<String>,
    /// 1-based line of a CSV body, when the error is tied to one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub line: Option<u64>,
    /// The CSV column at fault, when `field` is a field holding a whole
    /// CSV text (an ultrasonic calibration) rather than the column itself.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub column: Option<String>,
    /// The uploaded file at fault (an upload of recordings: `field` is
    /// then the metadata field, `line` the CSV line), when one is.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
}

impl ApiError {
    /// Longest message an answer carries (in bytes); longer ones are cut.
    pub const MAX_MESSAGE_BYTES: usize = 2048;
    /// Longest field name an answer carries (in bytes); longer ones are cut.
    pub const MAX_FIELD_BYTES: usize = 256;

    /// An error; a message or field name longer than the limits above (a
    /// hostile name echoed back) is cut, so that an error answer stays
    /// small whatever the request.
    pub fn new(status: StatusCode, message: impl Into<String>, field: Option<&str>) -> Self {
        let message = cut(printable(message.into()), Self::MAX_MESSAGE_BYTES);
        let field = field.map(|f| cut(printable(f.to_string()), Self::MAX_FIELD_BYTES));
        Self { status, message, field, line: None, column: None, file: None }
    }

    /// 400: the request is malformed or a value is out of range.
    pub fn bad_request(message: impl Into<String>, field: Option<&str>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, message, field)
    }

    /// 404: no such resource.
    pub fn not_found(message: impl Into<String>, field: Option<&str>) -> Self {
        Self::new(StatusCode::NOT_FOUND, message, field)
    }

    /// 413: the body, or what it asks for, is larger than the limits.
    pub fn too_large(message: impl Into<String>, field: Option<&str>) -> Self {
        Self::new(StatusCode::PAYLOAD_TOO_LARGE, message, field)
    }

    /// 415: a body in a format this route does not take.
    pub fn unsupported_media_type(message: impl Into<String>) -> Self {
        Self::new(StatusCode::UNSUPPORTED_MEDIA_TYPE, message, Some("content-type"))
    }

    /// 500: a fault of the server, not of the request.
    pub fn internal(message: impl Into<String>) -> Self {
        Self::new(StatusCode::INTERNAL_SERVER_ERROR, message, None)
    }

    /// 503: the server is busy; try again.
    pub fn unavailable(message: impl Into<String>) -> Self {
        Self::new(StatusCode::SERVICE_UNAVAILABLE, message, None)
    }

    pub fn with_line(mut self, line: Option<u64>) -> Self {
        self.line = line;
        self
    }

    pub fn with_file(mut self, file: Option<String>) -> Self {
        self.file = file.map(|f| cut(printable(f), Self::MAX_FIELD_BYTES));
        self
    }

    pub fn with_column(mut self, column: Option<String>) -> Self {
        self.column = column.map(|c| cut(printable(c), Self::MAX_FIELD_BYTES));
        self
    }

    /// A library error: an unknown material is the client's (404), the
    /// rest are the server's.
    pub fn library(error: LibraryError) -> Self {
        match error {
            LibraryError::UnknownMaterial { name, known } => Self::not_found(
                format!("no material named {} in the library (it has: {known})", quote(&name)),
                Some("name"),
            ),
            other => Self::internal(other.to_string()),
        }
    }
}

/// `text` with control characters escaped (`\0`, `\n`, `\u{1b}`), so
/// that the cut below bounds the answer: JSON would write each as six
/// bytes; and format characters too (`\u{202e}`, `\u{200b}`: what the name
/// rule refuses as invisible, `haptex_core::name::is_invisible`), so that
/// a name from a file cannot reorder or hide the message's text.
fn printable(text: String) -> String {
    let invisible = haptex_core::name::is_invisible;
    if text.chars().any(invisible) {
        text.chars()
            .map(|c| match c {
                c if c.is_control() => c.escape_debug().to_string(),
                c if invisible(c) => c.escape_unicode().to_string(),
                c => c.to_string(),
            })
            .collect()
    } else {
        text
    }
}

/// `text` cut to at most `max` bytes (at a character boundary), marked
/// with "..." when cut.
fn cut(mut text: String, max: usize) -> String {
    if text.len() > max {
        let mut end = max.saturating_sub(3);
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        text.truncate(end);
        text.push_str("...");
    }
    text
}

/// A text from the request (a path, a name, a header value) as an error
/// message quotes it ([`haptex_core::text::Quoted`]: in quotes, control
/// characters escaped, cut with its length when long).
pub fn quote(text: &str) -> String {
    haptex_core::text::Quoted(text).to_string()
}

impl std::fmt::Display for ApiError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}", self.status.as_u16(), self.message)?;
        if let Some(field) = &self.field {
            write!(f, " (field {field})")?;
        }
        Ok(())
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        if self.status.is_server_error() {
            tracing::error!(status = self.status.as_u16(), "{}", self.message);
        } else {
            tracing::debug!(status = self.status.as_u16(), field = ?self.field, "{}", self.message);
        }
        let mut response = (self.status, Json(&self)).into_response();
        response.extensions_mut().insert(JsonError);
        response
    }
}

/// Marks a response whose body is already an [`ApiError`].
#[derive(Debug, Clone, Copy)]
struct JsonError;

/// Middleware: a 4xx response that is not already an [`ApiError`] (axum's
/// 405 for a wrong method, the timeout's 408, a rejection) gets the JSON
/// error body, keeping its status and headers (`Allow` for 405).
pub async fn json_client_errors(request: Request, next: Next) -> Response {
    let (method, path) = (request.method().clone(), quote(request.uri().path()));
    let response = next.run(request).await;
    let status = response.status();
    if !status.is_client_error() || response.extensions().get::<JsonError>().is_some() {
        return response;
    }
    let (parts, _) = response.into_parts();
    let (message, field) = match status {
        StatusCode::METHOD_NOT_ALLOWED => {
            (format!("{method} is not allowed on {path} (the Allow header lists what is)"), Some("method"))
        }
        StatusCode::REQUEST_TIMEOUT => {
            (format!("{method} {path} took longer than the server's time limit per request"), None)
        }
        other => (other.canonical_reason().unwrap_or("client error").to_lowercase(), None),
    };
    let mut rebuilt = ApiError::new(status, message, field).into_response();
    for (name, value) in &parts.headers {
        if name != header::CONTENT_TYPE && name != header::CONTENT_LENGTH {
            rebuilt.headers_mut().insert(name.clone(), value.clone());
        }
    }
    rebuilt
}

/// The error for work that panicked (a bug): 500, the panic's message
/// logged, not sent.
pub(crate) fn panicked(panic: &(dyn Any + Send)) -> ApiError {
    let what = panic
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| panic.downcast_ref::<&str>().copied())
        .unwrap_or("unknown panic");
    tracing::error!("handler panicked: {what}");
    ApiError::internal("internal error (a bug: the server's log has the details)")
}

/// Fallback for unknown routes: 404 JSON naming the path.
pub async fn not_found(uri: Uri) -> ApiError {
    ApiError::not_found(format!("no such route: {}", quote(uri.path())), Some("path"))
}

/// Response for a handler that panicked (a bug): 500 JSON; the panic is logged.
pub fn panic_response(panic: Box<dyn Any + Send + 'static>) -> Response {
    let mut response = panicked(&*panic).into_response();
    response.headers_mut().insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    response
}
