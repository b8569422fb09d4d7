//! Who may use the server: the access token, the session cookie it is
//! exchanged for, and the Origin check of requests that change state or
//! drive hardware (docs/web.md, "Safety").
//!
//! - **Token.** A server with a token ([`Access::with_token`]; `haptex
//!   serve` makes one whenever it listens beyond loopback, takes uploads or
//!   drives a live output) answers every route but `GET /api/health` with
//!   401 unless the request carries it: as `Authorization: Bearer TOKEN`
//!   (API clients), or as the session cookie. `GET /api/health` without it
//!   says only that the server is up.
//! - **Session cookie.** Opening a page (`GET /` or `GET /map`) with
//!   `?token=TOKEN` answers the page with a cookie (`HttpOnly`, `SameSite=Strict`, `Path=/`, `Secure`
//!   under TLS) whose value is a second random secret of the server, not
//!   the token. Its name carries a random suffix per server start, so
//!   that two servers on one host do not overwrite each other's cookie.
//!   The page's first script removes the token from the address bar.
//!   The token is accepted in the query of those two pages only, so that
//!   it does not end up in the addresses of API calls.
//! - **Origin.** A request that may change state or drive hardware (every
//!   method but GET, HEAD and OPTIONS, and everything under `/api/live`,
//!   the WebSocket included) that carries an `Origin` must name this
//!   server (scheme and the request's `Host`): a page of another site
//!   cannot act for the user, with or without a token. Requests without
//!   `Origin` (not from a browser) are let through.
//!
//! Comparisons are in constant time (`subtle`), and the token never
//! appears in an answer or a log line: the request log has the path
//! without the query, and the query's token is removed before any handler
//! sees it.

use std::fmt;

use axum::extract::{Request, State};
use axum::http::{HeaderMap, HeaderValue, Method, StatusCode, Uri, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use subtle::ConstantTimeEq;

use crate::error::{ApiError, quote};
use crate::state::AppState;

/// Fewest characters of a token given by the user.
pub const MIN_TOKEN_CHARS: usize = 16;
/// Most characters of a token.
pub const MAX_TOKEN_CHARS: usize = 256;

/// An access token: URL-safe characters (letters, digits, `-`, `.`, `_`,
/// `~`), 16 to 256 of them. Its `Debug` does not show it.
#[derive(Clone, PartialEq, Eq)]
pub struct Token(String);

impl fmt::Debug for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Token(..)")
    }
}

/// A token given by the user that cannot be one.
#[derive(Debug, thiserror::Error)]
pub enum TokenError {
    #[error("the token has {0} characters: it needs {MIN_TOKEN_CHARS} to {MAX_TOKEN_CHARS}")]
    Length(usize),
    #[error(
        "the token has a character other than letters, digits, '-', '.', '_' and '~' (at character {0}): it travels \
         in a URL and a header"
    )]
    Character(usize),
    #[error("no random numbers from the operating system: {0}")]
    Random(String),
}

impl Token {
    /// A token from the user (`--token`, a file, an environment variable),
    /// surrounding white space removed.
    pub fn new(text: &str) -> Result<Self, TokenError> {
        let text = text.trim();
        let n = text.chars().count();
        if !(MIN_TOKEN_CHARS..=MAX_TOKEN_CHARS).contains(&n) {
            return Err(TokenError::Length(n));
        }
        if let Some(i) = text.chars().position(|c| !(c.is_ascii_alphanumeric() || "-._~".contains(c))) {
            return Err(TokenError::Character(i + 1));
        }
        Ok(Self(text.to_string()))
    }

    /// A random token: 32 bytes from the operating system, 64 hexadecimal
    /// digits.
    pub fn generate() -> Result<Self, TokenError> {
        random_hex().map(Self)
    }

    /// The token itself (to print the address that carries it, once).
    pub fn expose(&self) -> &str {
        &self.0
    }

    /// Whether `candidate` is this token, in time independent of where
    /// they differ.
    pub fn matches(&self, candidate: &[u8]) -> bool {
        bool::from(self.0.as_bytes().ct_eq(candidate))
    }
}

/// 32 random bytes as 64 hexadecimal digits.
fn random_hex() -> Result<String, TokenError> {
    let mut bytes = [0u8; 32];
    getrandom::fill(&mut bytes).map_err(|e| TokenError::Random(e.to_string()))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// The access rules of a server.
#[derive(Debug, Clone, Default)]
pub struct Access {
    /// The token and the session it gives; `None`: every request is let
    /// in (the Origin check stays).
    token: Option<(Token, Session)>,
    /// The server speaks TLS: the cookie is `Secure`, origins are https.
    tls: bool,
}

/// The session cookie's name and value (random per server start).
#[derive(Debug, Clone)]
struct Session {
    cookie_name: String,
    value: Token,
}

/// Marks a request that carried the token (or came to a server without
/// one): `GET /api/health` answers more to it.
#[derive(Debug, Clone, Copy)]
pub struct Authorized;

impl Access {
    /// No token: every request is let in.
    pub fn open() -> Self {
        Self::default()
    }

    /// Requests must carry `token` (or the session cookie it gives, made
    /// now from the operating system's random numbers).
    pub fn with_token(self, token: Token) -> Result<Self, TokenError> {
        let session =
            Session { cookie_name: format!("haptex_session_{}", &random_hex()?[..8]), value: Token::generate()? };
        Ok(Self { token: Some((token, session)), ..self })
    }

    /// The server speaks TLS.
    pub fn with_tls(self, tls: bool) -> Self {
        Self { tls, ..self }
    }

    /// Whether requests need the token.
    pub fn requires_token(&self) -> bool {
        self.token.is_some()
    }

    /// The session cookie's name, with a token.
    pub fn cookie_name(&self) -> Option<&str> {
        self.token.as_ref().map(|(_, s)| s.cookie_name.as_str())
    }

    /// Whether the server speaks TLS.
    pub fn tls(&self) -> bool {
        self.tls
    }

    /// The session cookie: `Set-Cookie`'s value.
    fn set_cookie(&self, session: &Session) -> String {
        format!(
            "{}={}; Path=/; HttpOnly; SameSite=Strict{}",
            session.cookie_name,
            session.value.expose(),
            if self.tls { "; Secure" } else { "" }
        )
    }

    /// Whether the request carries a valid bearer token or session cookie;
    /// an `Authorization` header that is not the token is an error (not a
    /// fallback to the cookie).
    fn carries_credentials(token: &Token, session: &Session, headers: &HeaderMap) -> Result<bool, ApiError> {
        if let Some(value) = headers.get(header::AUTHORIZATION) {
            let bytes = value.as_bytes();
            let given = bytes
                .get(..7)
                .filter(|scheme| scheme.eq_ignore_ascii_case(b"bearer "))
                .map(|_| bytes[7..].trim_ascii())
                .ok_or_else(|| unauthorized("the Authorization header is not 'Bearer TOKEN'", "authorization"))?;
            return if token.matches(given) {
                Ok(true)
            } else {
                Err(unauthorized("the Authorization header's token is not this server's", "authorization"))
            };
        }
        let mut found = false;
        for value in headers.get_all(header::COOKIE) {
            for pair in value.as_bytes().split(|&b| b == b';') {
                let pair = pair.trim_ascii();
                let Some(eq) = pair.iter().position(|&b| b == b'=') else { continue };
                if &pair[..eq] == session.cookie_name.as_bytes() {
                    // Every cookie of the name is compared: no early exit on the first.
                    found |= session.value.matches(&pair[eq + 1..]);
                }
            }
        }
        Ok(found)
    }
}

/// 401 naming `field`, with the `WWW-Authenticate` challenge of a bearer token.
fn unauthorized(message: &str, field: &str) -> ApiError {
    ApiError::new(StatusCode::UNAUTHORIZED, message, Some(field))
}

/// The answer to a request without the token.
fn token_needed() -> Response {
    let mut response = unauthorized(
        "this server needs its access token: open the address `haptex serve` printed at start (it ends in \
         ?token=...), or send the header 'Authorization: Bearer TOKEN'",
        "token",
    )
    .into_response();
    response.headers_mut().insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer realm=\"haptex\""));
    response
}

/// Whether a request may change state or drive hardware: every method but
/// GET, HEAD and OPTIONS, and the live output's routes (`/api/live...` of
/// `haptex serve`, `/live/...` of `haptex live --ws`).
fn acts(method: &Method, path: &str) -> bool {
    let live = |prefix: &str| path.strip_prefix(prefix).is_some_and(|rest| rest.is_empty() || rest.starts_with('/'));
    !matches!(*method, Method::GET | Method::HEAD | Method::OPTIONS) || live("/api/live") || live("/live")
}

/// 403 unless the request's `Origin` (if any) is this server: the scheme
/// it speaks and the request's own `Host`.
fn same_origin(access: &Access, headers: &HeaderMap) -> Result<(), ApiError> {
    let Some(origin) = headers.get(header::ORIGIN) else { return Ok(()) };
    let host = headers.get(header::HOST).and_then(|h| h.to_str().ok()).unwrap_or("");
    let scheme = if access.tls { "https://" } else { "http://" };
    let matches = origin
        .to_str()
        .ok()
        .and_then(|o| o.get(..scheme.len()).filter(|s| s.eq_ignore_ascii_case(scheme)).map(|_| &o[scheme.len()..]))
        .is_some_and(|o| !host.is_empty() && o.eq_ignore_ascii_case(host));
    if matches {
        return Ok(());
    }
    Err(ApiError::new(
        StatusCode::FORBIDDEN,
        format!(
            "a page of another site ({}) may not change this server's state or drive its live output; use the page \
             this server serves",
            quote(&String::from_utf8_lossy(origin.as_bytes()))
        ),
        Some("origin"),
    ))
}

/// The query without its `token` parameters, and the token's value if one
/// was there (the last, if several).
fn split_token(query: &str) -> (String, Option<String>) {
    let mut token = None;
    let rest: Vec<&str> = query
        .split('&')
        .filter(|pair| {
            let (name, value) = pair.split_once('=').unwrap_or((pair, ""));
            if name == "token" {
                token = Some(value.to_string());
                false
            } else {
                true
            }
        })
        .collect();
    (rest.join("&"), token)
}

/// `uri` with `query` as its query (none if empty).
fn with_query(uri: &Uri, query: &str) -> String {
    if query.is_empty() { uri.path().to_string() } else { format!("{}?{query}", uri.path()) }
}

/// Middleware: the rules of the module documentation, for the server's
/// state.
pub async fn check(State(state): State<AppState>, request: Request, next: Next) -> Response {
    enforce(state.access(), request, next).await
}

/// The rules of the module documentation under `access`, for any router
/// (`haptex live --ws` serves its page and WebSocket under the same rules).
pub async fn enforce(access: &Access, mut request: Request, next: Next) -> Response {
    let path = request.uri().path().to_string();
    if acts(request.method(), &path)
        && let Err(e) = same_origin(access, request.headers())
    {
        return e.into_response();
    }
    let Some((token, session)) = &access.token else {
        request.extensions_mut().insert(Authorized);
        return next.run(request).await;
    };
    // The page opened with ?token=: exchanged for the cookie, and the
    // address without it (the token never reaches a handler).
    let is_page = matches!(*request.method(), Method::GET | Method::HEAD) && (path == "/" || path == "/map");
    let query = request.uri().query().unwrap_or("").to_string();
    let (rest, given) = split_token(&query);
    if let Some(given) = given {
        if !is_page {
            return ApiError::bad_request(
                "the token goes in the header 'Authorization: Bearer TOKEN' (only the pages / and /map take \
                 ?token=)",
                Some("token"),
            )
            .into_response();
        }
        if !token.matches(given.as_bytes()) {
            return unauthorized("the token in the address is not this server's", "token").into_response();
        }
        // The page itself, with the cookie: a redirect would lose it when
        // the address was opened from another site's page (a SameSite=Strict
        // cookie is not sent along a navigation another site started); the
        // page's first script drops the token from the address bar
        // (js/token.js).
        let Ok(uri) = with_query(request.uri(), &rest).parse::<Uri>() else {
            return ApiError::bad_request("the address without its token is not an address", Some("token"))
                .into_response();
        };
        *request.uri_mut() = uri;
        request.extensions_mut().insert(Authorized);
        let cookie = HeaderValue::from_str(&access.set_cookie(session));
        let mut response = next.run(request).await;
        let headers = response.headers_mut();
        if let Ok(cookie) = cookie {
            headers.insert(header::SET_COOKIE, cookie);
        }
        headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
        return response;
    }
    match Access::carries_credentials(token, session, request.headers()) {
        Ok(true) => {
            request.extensions_mut().insert(Authorized);
            next.run(request).await
        }
        Ok(false) if request.method() == Method::GET && path == "/api/health" => next.run(request).await,
        Ok(false) => token_needed(),
        Err(e) => {
            let mut response = e.into_response();
            response
                .headers_mut()
                .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer realm=\"haptex\""));
            response
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_from_users_are_checked() {
        assert!(Token::new("short").is_err());
        assert!(Token::new(&"a".repeat(257)).is_err());
        assert!(matches!(Token::new("abcdefghijklmnop qrs"), Err(TokenError::Character(17))));
        assert!(matches!(Token::new("abcdefghijklmnop&x=1"), Err(TokenError::Character(17))));
        let t = Token::new("  abcdefghijklmnop-._~  \n").unwrap();
        assert_eq!(t.expose(), "abcdefghijklmnop-._~");
        assert!(t.matches(b"abcdefghijklmnop-._~"));
        assert!(!t.matches(b"abcdefghijklmnop-._"));
        assert!(!t.matches(b"abcdefghijklmnop-._!"));
        assert_eq!(format!("{t:?}"), "Token(..)");
    }

    #[test]
    fn generated_tokens_are_random_hex() {
        let (a, b) = (Token::generate().unwrap(), Token::generate().unwrap());
        assert_eq!(a.expose().len(), 64);
        assert!(a.expose().bytes().all(|c| c.is_ascii_hexdigit()));
        assert_ne!(a, b);
        assert!(Token::new(a.expose()).is_ok());
    }

    #[test]
    fn the_query_loses_its_token() {
        assert_eq!(split_token("token=abc"), (String::new(), Some("abc".into())));
        assert_eq!(split_token("a=1&token=abc&b=2"), ("a=1&b=2".into(), Some("abc".into())));
        assert_eq!(split_token("a=1"), ("a=1".into(), None));
        assert_eq!(split_token("tokens=1"), ("tokens=1".into(), None));
    }

    #[test]
    fn what_acts() {
        assert!(acts(&Method::POST, "/api/predict"));
        assert!(acts(&Method::GET, "/api/live/ws"));
        assert!(acts(&Method::GET, "/api/live"));
        assert!(!acts(&Method::GET, "/api/lively"));
        assert!(acts(&Method::GET, "/live/ws"));
        assert!(!acts(&Method::GET, "/"));
    }
}
