//! The page in headless Chromium over HTTPS with an access token (issue
//! 41): opened once at the address with `?token=`, it loads, draws the
//! first template from the API (every request over TLS with the session
//! cookie), drops the token from the address bar, cannot read the cookie
//! (HttpOnly), and loads again from its address without the token.
//! Needs Debian's chromium and chromium-driver (HAPTEX_BROWSER_TEST=skip
//! skips it, saying so).

#[path = "common/browser.rs"]
mod browser;
mod common;

use haptex_server::access::{Access, Token};
use haptex_server::{AppState, Limits, tls};

use browser::{Check, console_errors, script, wait_for};

const TOKEN: &str = "browser-tls-token-0123456789";

#[test]
fn the_page_over_https_with_a_token() {
    let dir = tempfile::tempdir().unwrap();
    let made = rcgen::generate_simple_self_signed(vec!["localhost".to_string()]).unwrap();
    let (cert, key) = (dir.path().join("cert.pem"), dir.path().join("key.pem"));
    std::fs::write(&cert, made.cert.pem()).unwrap();
    std::fs::write(&key, made.signing_key.serialize_pem()).unwrap();
    let acceptor = tls::acceptor(&cert, &key).unwrap();
    let state = AppState::new(Some(&common::shipped_library()), Limits::DEFAULT)
        .unwrap()
        .with_database(&common::shipped_db())
        .unwrap()
        .with_access(Access::open().with_tls(true).with_token(Token::new(TOKEN).unwrap()).unwrap());
    browser::run_with(state, Some(acceptor), async |client, url, _| -> Check<()> {
        assert!(url.starts_with("https://localhost:"), "{url}");
        client.goto(&format!("{url}?token={TOKEN}")).await.map_err(|e| e.to_string())?;
        wait_for(client, "Number(document.body.dataset.updates) > 0", "the first profile drawn over HTTPS").await?;
        let address = script(client, "return location.href;").await?;
        if address.as_str() != Some(url) {
            return Err(format!("the token is still in the address bar: {address}"));
        }
        let cookie = script(client, "return document.cookie;").await?;
        if cookie.as_str() != Some("") {
            return Err(format!("a script reads the session cookie: {cookie}"));
        }
        let errors = console_errors(client).await?;
        if !errors.is_empty() {
            return Err(format!("console errors: {errors:?}"));
        }
        // Again, from the address without the token: the cookie opens it.
        client.goto(url).await.map_err(|e| e.to_string())?;
        wait_for(client, "Number(document.body.dataset.updates) > 0", "the page again, with the cookie only").await?;
        let errors = console_errors(client).await?;
        if !errors.is_empty() {
            return Err(format!("console errors on the second load: {errors:?}"));
        }
        Ok(())
    });
}
