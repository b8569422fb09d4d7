//! Who may use a served haptex (issue 41, `haptex_server::access`): the
//! token and the session cookie it is exchanged for, the Origin check of
//! the routes that change state or drive hardware, and the token kept out
//! of answers and logs. The campaign of every route without the token, and
//! the answers with it against an open server's, are in adversarial.rs.

mod common;

use std::sync::Arc;

use axum::body::Body;
use axum::http::{Method, Request, StatusCode, header};
use haptex_server::access::{Access, Token};
use haptex_server::{AppState, Limits, app, routes};

use common::{Answer, send_to, shipped_db, shipped_library};

const TOKEN: &str = "Test-token_0123456789.abcdef~XYZ";

fn protected(tls: bool) -> AppState {
    AppState::new(Some(&shipped_library()), Limits::DEFAULT)
        .unwrap()
        .with_database(&shipped_db())
        .unwrap()
        .with_live_output(Arc::new(common::paced_output::PacedOutput::new(None)))
        .with_access(Access::open().with_tls(tls).with_token(Token::new(TOKEN).unwrap()).unwrap())
}

async fn ask(state: &AppState, method: Method, target: &str, headers: &[(&str, &str)]) -> Answer {
    let mut request = Request::builder().method(method).uri(target);
    for (name, value) in headers {
        request = request.header(*name, *value);
    }
    send_to(app(state.clone()), request.body(Body::empty()).unwrap()).await
}

fn bearer() -> String {
    format!("Bearer {TOKEN}")
}

/// Every route's path with its segments filled in.
fn concrete(path: &str) -> String {
    path.replace("{*path}", "app.js").replace("{name}", "velvet")
}

/// The page opened with the token gets the page and the session cookie
/// (HttpOnly, SameSite=Strict, Path=/, not stored in caches); the cookie
/// then opens every route, another value or name none.
#[tokio::test]
async fn the_token_in_the_address_is_exchanged_for_a_session_cookie() {
    let state = protected(false);
    for page in ["/", "/map"] {
        let answer = ask(&state, Method::GET, &format!("{page}?token={TOKEN}"), &[]).await;
        answer.ok();
        assert!(answer.content_type().starts_with("text/html"), "{}", answer.content_type());
        assert_eq!(answer.headers[header::CACHE_CONTROL], "no-store");
        let cookie = answer.headers[header::SET_COOKIE].to_str().unwrap().to_string();
        let (pair, attributes) = cookie.split_once(';').unwrap();
        let (name, value) = pair.split_once('=').unwrap();
        assert!(name.starts_with("haptex_session_"), "{cookie}");
        assert_ne!(value, TOKEN, "the cookie is not the token");
        assert_eq!(value.len(), 64);
        for attribute in ["Path=/", "HttpOnly", "SameSite=Strict"] {
            assert!(attributes.split(';').any(|a| a.trim() == attribute), "{attribute} in {cookie}");
        }
        assert!(!cookie.contains("Secure"), "no TLS, no Secure: {cookie}");
        assert!(!answer.text().contains(TOKEN));

        let with = |v: &str| format!("other=1; {name}={v}; more=2");
        ask(&state, Method::GET, "/api/config", &[("cookie", &with(value))]).await.ok();
        ask(&state, Method::GET, "/static/app.js", &[("cookie", &with(value))]).await.ok();
        // Another value: the last digit changed (a fixed '0' was the
        // right value itself whenever the random cookie ended in '0').
        let last = if value.ends_with('0') { '1' } else { '0' };
        let wrong = format!("{}{last}", &value[..63]);
        assert_ne!(wrong, value);
        let refused = ask(&state, Method::GET, "/api/config", &[("cookie", &with(&wrong))]).await;
        refused.error(StatusCode::UNAUTHORIZED, Some("token"));
        let renamed = format!("haptex_session_00000000={value}");
        let refused = ask(&state, Method::GET, "/api/config", &[("cookie", &renamed)]).await;
        refused.error(StatusCode::UNAUTHORIZED, Some("token"));
    }
    // The page keeps its other parameters; the token is gone before the
    // handler sees it (the page takes no query: a parameter left is refused).
    let answer = ask(&state, Method::GET, &format!("/?a=1&token={TOKEN}"), &[]).await;
    answer.error(StatusCode::BAD_REQUEST, Some("a"));
    // A wrong token in the address; the token in an API address.
    let answer = ask(&state, Method::GET, &format!("/?token={TOKEN}x"), &[]).await;
    answer.error(StatusCode::UNAUTHORIZED, Some("token"));
    assert!(answer.headers.get(header::SET_COOKIE).is_none());
    let answer = ask(&state, Method::GET, &format!("/api/config?token={TOKEN}"), &[]).await;
    answer.error(StatusCode::BAD_REQUEST, Some("token"));
    // Under TLS the cookie is Secure.
    let answer = ask(&protected(true), Method::GET, &format!("/?token={TOKEN}"), &[]).await;
    answer.ok();
    assert!(answer.headers[header::SET_COOKIE].to_str().unwrap().ends_with("; Secure"));
}

/// Bearer tokens: the token opens every route; another, a prefix of it, or
/// another scheme is 401 naming the header, with the Bearer challenge.
/// Without any, every route but the health check is 401; the health check
/// says only that the server is up.
#[tokio::test]
async fn bearer_tokens_and_the_health_check() {
    let state = protected(false);
    let full = ask(&state, Method::GET, "/api/health", &[("authorization", &bearer())]).await;
    full.ok();
    assert_eq!(full.json()["templates"], true, "{}", full.text());
    let lower = format!("bearer  {TOKEN} ");
    ask(&state, Method::GET, "/api/config", &[("authorization", &lower)]).await.ok();
    let minimal = ask(&state, Method::GET, "/api/health", &[]).await;
    minimal.ok();
    assert_eq!(minimal.json(), serde_json::json!({ "status": "ok" }));
    for wrong in [format!("Bearer {}", &TOKEN[..TOKEN.len() - 1]), format!("Bearer {TOKEN}0"), format!("Basic {TOKEN}")]
    {
        let answer = ask(&state, Method::GET, "/api/config", &[("authorization", &wrong)]).await;
        answer.error(StatusCode::UNAUTHORIZED, Some("authorization"));
        assert_eq!(answer.headers[header::WWW_AUTHENTICATE], "Bearer realm=\"haptex\"");
        assert!(!answer.text().contains(TOKEN));
    }
    for (method, path) in routes::list() {
        if path == "/api/health" {
            continue;
        }
        let answer = ask(&state, method.clone(), &concrete(&path), &[]).await;
        let body = answer.error(StatusCode::UNAUTHORIZED, Some("token"));
        assert!(body["error"].as_str().unwrap().contains("Authorization: Bearer TOKEN"), "{method} {path}: {body}");
        assert_eq!(answer.headers[header::WWW_AUTHENTICATE], "Bearer realm=\"haptex\"", "{method} {path}");
    }
    // A server without a token answers the health check in full.
    let open = AppState::new(Some(&shipped_library()), Limits::DEFAULT).unwrap();
    assert_eq!(ask(&open, Method::GET, "/api/health", &[]).await.json()["library"], true);
}

/// Every route that may change state or drive hardware (every method but
/// GET, and the live output's routes) refuses a request from a page of
/// another site, token or not, before anything else; the server's own
/// origin (its scheme and the request's Host) is let through.
#[tokio::test]
async fn foreign_origins_cannot_act_for_the_user() {
    for (state, scheme) in [(protected(false), "http"), (protected(true), "https")] {
        let open = AppState::new(None, Limits::DEFAULT).unwrap();
        let other = if scheme == "http" { "https" } else { "http" };
        for (method, path) in routes::list() {
            if method == Method::GET && !path.starts_with("/api/live") {
                continue;
            }
            let target = concrete(&path);
            let foreign = [
                "http://evil.example".to_string(),
                "null".to_string(),
                format!("{other}://localhost"),
                format!("{scheme}://localhost:1"),
                format!("{scheme}://localhost.evil.example"),
            ];
            for origin in &foreign {
                for (s, headers) in [
                    (&state, vec![("origin", origin.as_str()), ("authorization", bearer().leak() as &str)]),
                    (&state, vec![("origin", origin.as_str())]),
                ] {
                    let answer = ask(s, method.clone(), &target, &headers).await;
                    answer.error(StatusCode::FORBIDDEN, Some("origin"));
                }
                if scheme == "http" {
                    // Without a token too.
                    let answer = ask(&open, method.clone(), &target, &[("origin", origin)]).await;
                    answer.error(StatusCode::FORBIDDEN, Some("origin"));
                }
            }
            // The server's own origin, and none: past the check (whatever the
            // route then says of the empty request, it is not the origin).
            for headers in [vec![("origin", format!("{scheme}://localhost"))], vec![]] {
                let mut headers: Vec<(&str, &str)> = headers.iter().map(|(n, v)| (*n, v.as_str())).collect();
                let auth = bearer();
                headers.push(("authorization", &auth));
                let answer = ask(&state, method.clone(), &target, &headers).await;
                let field = serde_json::from_slice::<serde_json::Value>(&answer.body).ok().map(|v| v["field"].clone());
                let refused_for = field.as_ref().and_then(|f| f.as_str());
                assert!(
                    !matches!(refused_for, Some("origin" | "token" | "authorization")),
                    "{method} {path}: {}",
                    answer.text()
                );
            }
        }
    }
}

/// The token never reaches the log: the access log of requests carrying
/// it in every way (address, header, wrong variants) has no trace of it.
#[test]
fn the_token_is_not_logged() {
    let state = protected(false).with_access_log(true);
    let log = common::capture_log(|| {
        let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
        runtime.block_on(async {
            ask(&state, Method::GET, &format!("/?token={TOKEN}"), &[]).await.ok();
            ask(&state, Method::GET, &format!("/?token={TOKEN}x"), &[]).await;
            ask(&state, Method::GET, &format!("/api/config?token={TOKEN}"), &[]).await;
            ask(&state, Method::GET, "/api/config", &[("authorization", &bearer())]).await.ok();
            ask(&state, Method::GET, "/api/config", &[("authorization", &format!("{}0", bearer()))]).await;
            ask(&state, Method::POST, "/api/predict", &[("authorization", &bearer()), ("origin", "http://evil")]).await;
        });
    });
    assert!(log.lines().count() >= 6, "the access log has a line per request: {log}");
    assert!(!log.contains(TOKEN) && !log.contains(&TOKEN[..12]), "{log}");
}
