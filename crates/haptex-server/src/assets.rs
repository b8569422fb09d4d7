//! The web GUI: plain HTML, CSS and JavaScript plus the vendored uPlot,
//! embedded in the binary (rust-embed, `debug-embed` so that debug builds
//! embed too). Only these files are served: a path is looked up in the
//! embedded set, never on disk.
//!
//! Every response carries the security headers of [`SECURITY_HEADERS`]: a
//! Content-Security-Policy that allows scripts, styles and connections to
//! this origin only, `nosniff`, no referrer, no framing.

use axum::extract::rejection::PathRejection;
use axum::extract::{Path, RawQuery};
use axum::http::{HeaderMap, HeaderName, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use rust_embed::RustEmbed;

use crate::error::{ApiError, quote};
use crate::input::Query;

#[derive(RustEmbed)]
#[folder = "assets/"]
// The front-end's unit tests (node --test) and the package.json that tells
// Node the modules are ES modules are for the test suite, not the page.
#[exclude = "js/test/*"]
#[exclude = "js/package.json"]
struct Assets;

/// The Content-Security-Policy of every response. uPlot draws on canvas
/// and sets element styles from script (CSSOM, which `style-src` does not
/// restrict). Downloads are `blob:` URLs made by the page; `connect-src`
/// allows reading them back (the browser test checks a download's bytes
/// that way).
pub const CONTENT_SECURITY_POLICY: &str = "default-src 'none'; script-src 'self'; style-src 'self'; \
     img-src 'self' data: blob:; media-src 'self' blob:; connect-src 'self' blob:; font-src 'self'; \
     base-uri 'none'; form-action 'none'; frame-ancestors 'none'";

/// The security headers every answer carries, as (name, value): the
/// Content-Security-Policy above, no MIME sniffing, no referrer, no
/// framing. [`add_security_headers`] sets them on the application's
/// answers, [`crate::connection`] on the few answers hyper writes itself.
pub const SECURITY_HEADERS: [(&str, &str); 4] = [
    ("content-security-policy", CONTENT_SECURITY_POLICY),
    ("x-content-type-options", "nosniff"),
    ("referrer-policy", "no-referrer"),
    ("x-frame-options", "DENY"),
];

/// Middleware: the security headers on every response (each set unless
/// the handler set it).
pub async fn add_security_headers(mut response: Response) -> Response {
    let headers = response.headers_mut();
    for (name, value) in SECURITY_HEADERS {
        if !headers.contains_key(name) {
            headers.insert(HeaderName::from_static(name), HeaderValue::from_static(value));
        }
    }
    response
}

/// `GET /`: the GUI's page.
pub async fn index(headers: HeaderMap, RawQuery(raw_query): RawQuery) -> Result<Response, ApiError> {
    Query::parse(raw_query.as_deref())?.finish()?;
    Ok(serve("index.html", &headers))
}

/// `GET /map`: the map view's page (friction maps from an image).
pub async fn map_page(headers: HeaderMap, RawQuery(raw_query): RawQuery) -> Result<Response, ApiError> {
    Query::parse(raw_query.as_deref())?.finish()?;
    Ok(serve("map.html", &headers))
}

/// `GET /static/{*path}`: an embedded file, or 404.
pub async fn file(
    path: Result<Path<String>, PathRejection>,
    headers: HeaderMap,
    RawQuery(raw_query): RawQuery,
) -> Result<Response, ApiError> {
    let Path(path) = path.map_err(|e| ApiError::bad_request(e.body_text(), Some("path")))?;
    Query::parse(raw_query.as_deref())?.finish()?;
    Ok(serve(&path, &headers))
}

/// Names of the embedded files (for tests and docs).
pub fn names() -> Vec<String> {
    Assets::iter().map(|n| n.into_owned()).collect()
}

fn serve(path: &str, request: &HeaderMap) -> Response {
    let Some(file) = Assets::get(path) else {
        return ApiError::not_found(format!("no such file: /static/{}", quote(path)), Some("path")).into_response();
    };
    let etag = format!("\"{}\"", hex(&file.metadata.sha256_hash()[..16]));
    let etag_value = HeaderValue::from_str(&etag).expect("hex is a valid header value");
    let headers = [
        (header::CONTENT_TYPE, HeaderValue::from_static(content_type(path))),
        (header::ETAG, etag_value),
        (header::CACHE_CONTROL, HeaderValue::from_static("no-cache")),
    ];
    let unchanged = request
        .get(header::IF_NONE_MATCH)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.split(',').any(|tag| tag.trim() == etag));
    if unchanged {
        return (StatusCode::NOT_MODIFIED, headers).into_response();
    }
    (headers, file.data).into_response()
}

/// Content type by extension (the embedded set has only these kinds).
fn content_type(path: &str) -> &'static str {
    match path.rsplit('.').next().unwrap_or("") {
        "html" => "text/html; charset=utf-8",
        "js" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "svg" => "image/svg+xml",
        "png" => "image/png",
        "json" => "application/json",
        "md" | "txt" => "text/plain; charset=utf-8",
        _ => "application/octet-stream",
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
