//! Headless Chromium through chromedriver for the browser tests: the
//! tools, chromedriver on a free port, the session, a run against a server
//! in process (`run`), scripts, waits and the viewport. browser.rs keeps
//! its own copy of most of this (moving it here is a follow-up) and takes
//! `set_viewport` from here.

// Each browser test uses the part of this module it needs.
#![allow(dead_code)]

use std::net::TcpListener as StdListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use axum::http::Method;
use fantoccini::wd::WebDriverCompatibleCommand;
use fantoccini::{Client, ClientBuilder};
use serde_json::{Value, json};

pub const WAIT: Duration = Duration::from_secs(20);

pub type Check<T> = Result<T, String>;

/// The tool at `variable` or `default`; None (the test says it is skipped)
/// with HAPTEX_BROWSER_TEST=skip.
pub fn tools() -> Option<(PathBuf, PathBuf)> {
    if std::env::var("HAPTEX_BROWSER_TEST").as_deref() == Ok("skip") {
        eprintln!("SKIPPED: HAPTEX_BROWSER_TEST=skip: the GUI was not tested in a browser");
        return None;
    }
    let tool = |variable: &str, default: &str| {
        let path = std::env::var_os(variable).map(PathBuf::from).unwrap_or_else(|| PathBuf::from(default));
        assert!(
            path.is_file(),
            "{} not found: install Debian's chromium and chromium-driver (bash scripts/test.sh does), set \
             {variable}, or set HAPTEX_BROWSER_TEST=skip to skip the browser test",
            path.display()
        );
        path
    };
    Some((tool("HAPTEX_CHROMIUM", "/usr/bin/chromium"), tool("HAPTEX_CHROMEDRIVER", "/usr/bin/chromedriver")))
}

/// chromedriver on a free loopback port, killed when dropped.
pub struct Driver {
    child: Child,
    port: u16,
    pub log_path: PathBuf,
}

impl Driver {
    pub fn start(chromedriver: &Path, scratch: &Path) -> Self {
        let port = StdListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let log_path = scratch.join("chromedriver.log");
        let child = Command::new(chromedriver)
            .arg(format!("--port={port}"))
            .arg(format!("--log-path={}", log_path.display()))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {}: {e}", chromedriver.display()));
        let driver = Self { child, port, log_path };
        let start = Instant::now();
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(start.elapsed() < WAIT, "chromedriver did not listen on port {port} within {WAIT:?}");
            std::thread::sleep(Duration::from_millis(50));
        }
        driver
    }

    /// A session of headless Chromium, 1280 x 1000.
    pub async fn connect(&self, chromium: &Path, scratch: &Path) -> Client {
        self.connect_with(chromium, scratch, &[]).await
    }

    /// [`Self::connect`] with more command-line arguments for Chromium.
    pub async fn connect_with(&self, chromium: &Path, scratch: &Path, extra: &[&str]) -> Client {
        let profile = scratch.join("chromium-profile");
        let mut args: Vec<String> = [
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            "--disable-dev-shm-usage",
            "--window-size=1280,1000",
        ]
        .into_iter()
        .map(String::from)
        .collect();
        args.push(format!("--user-data-dir={}", profile.display()));
        args.extend(extra.iter().map(|a| a.to_string()));
        let capabilities = json!({
            "browserName": "chrome",
            "goog:chromeOptions": {
                "binary": chromium,
                "args": args,
            },
            "goog:loggingPrefs": { "browser": "ALL" },
        });
        let Value::Object(capabilities) = capabilities else { unreachable!() };
        let connector = hyper_util::client::legacy::connect::HttpConnector::new();
        ClientBuilder::new(connector)
            .capabilities(capabilities)
            .connect(&format!("http://127.0.0.1:{}", self.port))
            .await
            .expect("a WebDriver session with chromedriver")
    }
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// chromedriver's browser console log (entries since the last call).
#[derive(Debug)]
struct BrowserLog;

impl WebDriverCompatibleCommand for BrowserLog {
    fn endpoint(&self, base_url: &url::Url, session_id: Option<&str>) -> Result<url::Url, url::ParseError> {
        base_url.join(&format!("session/{}/se/log", session_id.unwrap_or_default()))
    }

    fn method_and_body(&self, _: &url::Url) -> (Method, Option<String>) {
        (Method::POST, Some(r#"{"type": "browser"}"#.to_string()))
    }
}

/// Console messages at level SEVERE since the last call.
pub async fn console_errors(client: &Client) -> Check<Vec<String>> {
    let entries = client.issue_cmd(BrowserLog).await.map_err(|e| e.to_string())?;
    Ok(entries
        .as_array()
        .map(|a| a.as_slice())
        .unwrap_or_default()
        .iter()
        .filter(|e| e["level"] == "SEVERE")
        .map(|e| e["message"].as_str().unwrap_or_default().to_string())
        .collect())
}

pub async fn script(client: &Client, code: &str) -> Check<Value> {
    client.execute(code, vec![]).await.map_err(|e| format!("{code}: {e}"))
}

/// Waits until `code` (a JS expression) is truthy.
pub async fn wait_for(client: &Client, code: &str, what: &str) -> Check<()> {
    let start = Instant::now();
    loop {
        if script(client, &format!("return Boolean({code});")).await? == Value::Bool(true) {
            return Ok(());
        }
        if start.elapsed() > WAIT {
            let message = script(client, "return document.getElementById('message').textContent;").await?;
            return Err(format!("timed out waiting for {what} ({code}); the page says: {message}"));
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Sizes the window so that its viewport (innerWidth x innerHeight) is
/// `width` x `height`: headless Chromium's window includes a frame.
pub async fn set_viewport(client: &Client, width: u32, height: u32) -> Check<()> {
    client.set_window_size(width, height).await.map_err(|e| e.to_string())?;
    let frame =
        script(client, "return [window.outerWidth - window.innerWidth, window.outerHeight - window.innerHeight];")
            .await?;
    let dx = frame[0].as_u64().unwrap_or(0) as u32;
    let dy = frame[1].as_u64().unwrap_or(0) as u32;
    client.set_window_size(width + dx, height + dy).await.map_err(|e| e.to_string())?;
    let start = Instant::now();
    loop {
        let inner =
            script(client, "return [window.innerWidth, window.innerHeight, window.outerWidth, window.outerHeight];")
                .await?;
        if inner[0] == width && inner[1] == height {
            return Ok(());
        }
        if start.elapsed() > WAIT {
            return Err(format!("the window did not reach a {width} x {height} viewport: [inner, outer] = {inner}"));
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Runs `exercise` in one headless Chromium session against a server on
/// `state`, in process on a loopback port: its arguments are the client,
/// the server's URL (ending in `/`) and a scratch folder. Panics with the
/// exercise's error and chromedriver's log; skipped, saying so, with
/// HAPTEX_BROWSER_TEST=skip.
pub fn run(state: haptex_server::AppState, exercise: impl AsyncFnOnce(&Client, &str, &Path) -> Check<()>) {
    run_with(state, None, exercise)
}

/// [`run`] over HTTPS with `tls` when given (the URL is then
/// `https://localhost:PORT/`, and Chromium accepts the test's self-signed
/// certificate).
#[allow(dead_code)]
pub fn run_with(
    state: haptex_server::AppState,
    tls: Option<haptex_server::tls::Acceptor>,
    exercise: impl AsyncFnOnce(&Client, &str, &Path) -> Check<()>,
) {
    let Some((chromium, chromedriver)) = tools() else { return };
    let scratch = tempfile::tempdir().unwrap();
    let runtime = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().unwrap();
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let url = match &tls {
            Some(_) => format!("https://localhost:{}/", addr.port()),
            None => format!("http://{addr}/"),
        };
        let extra: &[&str] = if tls.is_some() { &["--ignore-certificate-errors"] } else { &[] };
        tokio::spawn(haptex_server::serve_with(listener, state, tls, async {
            let _ = stopped.await;
        }));
        let driver = Driver::start(&chromedriver, scratch.path());
        let client = driver.connect_with(&chromium, scratch.path(), extra).await;
        let result = exercise(&client, &url, scratch.path()).await;
        let _ = client.close().await;
        let _ = stop.send(());
        if let Err(message) = result {
            panic!("{message}\nchromedriver log: {}", driver.log_path.display());
        }
    });
}

/// The paper's symbols written with an underscore for a subscript (f_c,
/// the carrier frequency, as docs/physics.md writes it): the only
/// snake_case-looking words a page may show outside code samples.
pub const PAPER_SYMBOLS: &[&str] = &[
    "mu_flat", "rho_min", "rho_inf", "rho_sc", "r_w", "r_h", "a_max", "a_c", "eps_sc", "eps_i", "d_sc", "d_i", "eps_0",
    "f_c",
];

/// The first code-like word of the page's visible text (outside code
/// samples, screen-reader-only text and scripts; placeholders included),
/// with the text it is in: a snake_case identifier other than the paper's
/// symbols, an API field path or wording, or a path in the repository
/// (sources are cited by name). None when there is none.
pub async fn code_like_text(client: &Client) -> Check<Option<String>> {
    let texts = script(
        client,
        "const out = []; const walk = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT); \
         for (let n = walk.nextNode(); n; n = walk.nextNode()) { \
           const p = n.parentElement; if (!p || p.closest('code, pre, script, style, .sr-only')) continue; \
           if (!p.checkVisibility()) continue; \
           const t = n.textContent.trim(); if (t) out.push(t); } \
         document.querySelectorAll('input[placeholder]').forEach(i => { if (i.checkVisibility()) out.push(i.placeholder); }); \
         return out;",
    )
    .await?;
    let snake = |w: &str| {
        w.contains('_')
            && w.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
            && !PAPER_SYMBOLS.contains(&w)
    };
    for t in texts.as_array().ok_or("no texts")?.iter().filter_map(Value::as_str) {
        let words = t.split(|c: char| {
            c.is_whitespace() || matches!(c, ',' | ';' | '(' | ')' | ':' | '=' | '/' | '\'' | '"' | '“' | '”')
        });
        for w in words.map(|w| w.trim_matches(|c: char| !c.is_alphanumeric() && c != '_')) {
            if snake(w) {
                return Ok(Some(format!("the identifier {w:?} in {t:?}")));
            }
        }
        for phrase in ["device.", "image_png_base64", "request body", "(field", "body:"] {
            if t.contains(phrase) {
                return Ok(Some(format!("{phrase:?} in {t:?}")));
            }
        }
        for w in t.split_whitespace().map(|w| w.trim_matches(|c: char| !c.is_alphanumeric())) {
            if [".md", ".rs", ".toml"].iter().any(|e| w.ends_with(e))
                || ["crates/", "docs/", "data/", "src/"].iter().any(|d| w.starts_with(d))
            {
                return Ok(Some(format!("the repository path {w:?} in {t:?}")));
            }
        }
    }
    Ok(None)
}
