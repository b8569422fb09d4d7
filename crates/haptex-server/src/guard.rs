//! The first checks of every request, before any route sees it: the size
//! of its head (414 for a long request target, 431 for large or many
//! header fields) and the host it was sent to (DNS rebinding).
//!
//! Sizes: hyper reads heads up to [`Limits::head_buffer_bytes`], well
//! beyond the documented limits, so that a head over a limit reaches this
//! check and gets a JSON answer naming the field; what is larger still is
//! answered by hyper itself and rewritten by [`crate::connection`].
//!
//! Host: a web page of another site can make the browser send requests to
//! this server by DNS rebinding (its own name resolving to 127.0.0.1), and
//! read the answers, since for the browser they are same-origin. Such a
//! request carries the attacker's name in `Host`. The server answers only
//! for names that cannot be rebound: `localhost` and `*.localhost`
//! (resolved to loopback by the browser itself), IP addresses (a literal
//! address involves no DNS: this keeps `--addr 0.0.0.0` usable from a
//! phone by address), and the names given with `haptex serve
//! --allow-host`. Anything else is 421 naming the field `host`; an
//! HTTP/1.1 request without a Host is 400.
//!
//! [`Limits::head_buffer_bytes`]: crate::Limits::head_buffer_bytes

use std::net::{Ipv4Addr, Ipv6Addr};

use axum::extract::{Request, State};
use axum::http::{HeaderMap, StatusCode, Version, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use crate::error::{ApiError, quote};
use crate::state::AppState;

/// The host names a server answers for, besides `localhost`,
/// `*.localhost` and IP addresses.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct HostPolicy {
    /// Lowercase names, without port.
    names: Vec<String>,
}

/// A name given to [`HostPolicy::new`] is not a host name.
#[derive(Debug, thiserror::Error)]
#[error("--allow-host {name:?}: {why}")]
pub struct HostNameError {
    pub name: String,
    pub why: &'static str,
}

impl HostPolicy {
    /// A policy also allowing `names` (DNS names such as `haptex.lab` or
    /// `mypc.local`, without port; compared case-insensitively).
    pub fn new<S: AsRef<str>>(names: impl IntoIterator<Item = S>) -> Result<Self, HostNameError> {
        let mut allowed = Vec::new();
        for name in names {
            let name = name.as_ref();
            let error = |why| HostNameError { name: name.to_string(), why };
            if name.is_empty() || name.len() > 253 {
                return Err(error("a host name has 1 to 253 characters"));
            }
            if !name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'.') {
                return Err(error("a host name has letters, digits, '-' and '.' only (no port, no scheme)"));
            }
            allowed.push(name.to_ascii_lowercase());
        }
        Ok(Self { names: allowed })
    }

    /// The names given (lowercase).
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Whether a request with this `Host` value (name or address, with or
    /// without port) is answered.
    pub fn allows(&self, host: &str) -> bool {
        let Some(name) = host_name(host) else { return false };
        if let Some(v6) = name.strip_prefix('[').and_then(|n| n.strip_suffix(']')) {
            return v6.parse::<Ipv6Addr>().is_ok();
        }
        if name.parse::<Ipv4Addr>().is_ok() {
            return true;
        }
        let name = name.to_ascii_lowercase();
        name == "localhost" || name.ends_with(".localhost") || self.names.contains(&name)
    }
}

/// The name part of a Host value (`name`, `name:port`, `[v6]`,
/// `[v6]:port`); `None` if the port is not a number.
fn host_name(host: &str) -> Option<&str> {
    let (name, port) = match host.rfind([':', ']']) {
        Some(i) if host.as_bytes()[i] == b':' => (&host[..i], Some(&host[i + 1..])),
        _ => (host, None),
    };
    match port {
        Some(p) if p.is_empty() || !p.bytes().all(|b| b.is_ascii_digit()) => None,
        _ if name.is_empty() => None,
        _ => Some(name),
    }
}

/// Middleware: 414, 431, 400 or 421 for a request whose head is too large
/// or which was sent to a host this server does not answer for.
pub async fn check_request(State(state): State<AppState>, request: Request, next: Next) -> Response {
    match check(&state, &request) {
        Ok(()) => next.run(request).await,
        Err(e) => e.into_response(),
    }
}

fn check(state: &AppState, request: &Request) -> Result<(), ApiError> {
    let limits = state.limits();
    let uri = request.uri();
    let target =
        uri.path_and_query().map_or(0, |pq| pq.as_str().len()) + uri.authority().map_or(0, |a| a.as_str().len());
    if target > limits.max_uri_bytes {
        return Err(ApiError::new(
            StatusCode::URI_TOO_LONG,
            format!("the request target is {target} bytes, more than the {} this server reads", limits.max_uri_bytes),
            Some("uri"),
        ));
    }
    check_headers(request.headers(), limits.max_headers, limits.max_header_bytes)?;
    check_host(state, request)
}

fn check_headers(headers: &HeaderMap, max_headers: usize, max_bytes: usize) -> Result<(), ApiError> {
    let too_large =
        |message: String, field: &str| ApiError::new(StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE, message, Some(field));
    if headers.len() > max_headers {
        return Err(too_large(
            format!("{} header fields, more than the {max_headers} this server reads", headers.len()),
            "headers",
        ));
    }
    // Each field as on the wire: "name: value\r\n".
    let size = |(name, value): (&header::HeaderName, &header::HeaderValue)| name.as_str().len() + value.len() + 4;
    let total: usize = headers.iter().map(size).sum();
    if total > max_bytes {
        let (largest, bytes) = headers.iter().map(|f| (f.0, size(f))).max_by_key(|f| f.1).expect("some header");
        return Err(too_large(
            format!(
                "the header fields are {total} bytes, more than the {max_bytes} this server reads (the largest, \
                 {largest}, is {bytes} bytes)"
            ),
            largest.as_str(),
        ));
    }
    Ok(())
}

fn check_host(state: &AppState, request: &Request) -> Result<(), ApiError> {
    let mut hosts = request.headers().get_all(header::HOST).iter();
    let header = hosts.next();
    if hosts.next().is_some() {
        return Err(ApiError::bad_request("more than one Host header", Some("host")));
    }
    // An absolute request target (`GET http://name/ HTTP/1.1`) names the
    // host too; both must be allowed.
    let names = header
        .map(|h| h.to_str().map_err(|_| ApiError::bad_request("the Host header is not text", Some("host"))))
        .transpose()?
        .into_iter()
        .chain(request.uri().authority().map(|a| a.as_str()));
    let mut named = false;
    for name in names {
        named = true;
        if !state.hosts().allows(name) {
            return Err(ApiError::new(
                StatusCode::MISDIRECTED_REQUEST,
                format!(
                    "this server does not answer for the host {}: it answers for localhost, IP addresses{} (a page \
                     of another site that reached this server through DNS rebinding is refused here; to serve a \
                     name, start it with --allow-host NAME)",
                    quote(name),
                    match state.hosts().names() {
                        [] => String::new(),
                        names => format!(" and {}", names.join(", ")),
                    }
                ),
                Some("host"),
            ));
        }
    }
    if !named && request.version() >= Version::HTTP_11 {
        return Err(ApiError::bad_request("an HTTP/1.1 request needs a Host header", Some("host")));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn localhost_ip_literals_and_allowed_names_pass_others_do_not() {
        let policy = HostPolicy::new(["Haptex.Lab"]).unwrap();
        for host in [
            "localhost",
            "localhost:8080",
            "LOCALHOST:8080",
            "app.localhost:1",
            "127.0.0.1",
            "127.0.0.1:8080",
            "192.168.1.20:8080",
            "0.0.0.0:8080",
            "[::1]",
            "[::1]:8080",
            "[fe80::1]:80",
            "haptex.lab",
            "HAPTEX.LAB:8080",
        ] {
            assert!(policy.allows(host), "{host}");
        }
        for host in [
            "evil.example",
            "evil.example:8080",
            "localhost.evil.example",
            "127.0.0.1.evil.example",
            "localhost.",
            "haptex.lab.evil",
            "[::1",
            "::1",
            "[not-an-address]:80",
            "localhost:80x",
            "localhost:",
            ":8080",
            "",
            "127.1",
        ] {
            assert!(!policy.allows(host), "{host}");
        }
        assert!(HostPolicy::new(["bad name"]).is_err());
        assert!(HostPolicy::new(["name:80"]).is_err());
        assert!(HostPolicy::new([""]).is_err());
    }
}
