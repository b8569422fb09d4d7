//! Helpers of the server's test files: the application on the shipped
//! data, answers checked as JSON errors, the real server over raw TCP,
//! maximal bodies, and the log captured.

#![allow(dead_code)]

pub mod paced_output;

use std::io::Write;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use axum::Router;
use axum::body::{Body, Bytes};
use axum::http::{HeaderMap, Request, StatusCode, header};
use haptex_server::assets::SECURITY_HEADERS;
use haptex_server::{AppState, Limits};
use serde_json::Value;
use tower::ServiceExt;

pub fn shipped_library() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/library/library.sqlite")
}

pub fn shipped_db() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/db")
}

/// The state on the shipped texture library and FE database (loaded once
/// per test binary; each use gets its own slots and counters only if it
/// builds a new state).
pub fn shipped_state() -> AppState {
    static STATE: std::sync::OnceLock<AppState> = std::sync::OnceLock::new();
    STATE
        .get_or_init(|| {
            AppState::new(Some(&shipped_library()), Limits::DEFAULT).unwrap().with_database(&shipped_db()).unwrap()
        })
        .clone()
}

/// An answer of the in-process application.
pub struct Answer {
    pub status: StatusCode,
    pub headers: HeaderMap,
    pub body: Bytes,
}

impl Answer {
    pub fn json(&self) -> Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(&self.body)))
    }

    pub fn text(&self) -> String {
        String::from_utf8(self.body.to_vec()).unwrap()
    }

    pub fn content_type(&self) -> &str {
        self.headers.get(header::CONTENT_TYPE).map(|v| v.to_str().unwrap()).unwrap_or("")
    }

    /// Asserts a JSON error with this status and field, and the security
    /// headers; returns the body.
    #[track_caller]
    pub fn error(&self, status: StatusCode, field: Option<&str>) -> Value {
        assert_eq!(self.status, status, "{}", String::from_utf8_lossy(&self.body));
        assert!(self.content_type().starts_with("application/json"), "content type {}", self.content_type());
        for (name, value) in SECURITY_HEADERS {
            assert_eq!(self.headers.get(name).map(|v| v.to_str().unwrap()), Some(value), "{name}");
        }
        let body = self.json();
        let message = body["error"].as_str().expect("an error message");
        assert!(!message.is_empty());
        assert_readable(message);
        assert!(body.as_object().unwrap().contains_key("field"), "{body}");
        assert_eq!(body["field"].as_str(), field, "{body}");
        body
    }

    #[track_caller]
    pub fn ok(&self) -> &Self {
        assert_eq!(self.status, StatusCode::OK, "{}", String::from_utf8_lossy(&self.body));
        self
    }
}

/// Sends `request` as a browser on this machine would: with `Host:
/// localhost` unless the request names its host.
pub async fn send_to(router: Router, mut request: Request<Body>) -> Answer {
    if !request.headers().contains_key(header::HOST) {
        request.headers_mut().insert(header::HOST, "localhost".parse().unwrap());
    }
    let response = router.oneshot(request).await.unwrap();
    let status = response.status();
    let headers = response.headers().clone();
    let body = axum::body::to_bytes(response.into_body(), usize::MAX).await.unwrap();
    Answer { status, headers, body }
}

/// A friction profile CSV of nearly 1 MiB whose header has 10^5 column
/// names (`x_mm`, `mu` and 99 998 others), with as many rows as fit: the
/// issue's maximal upload.
pub fn maximal_csv() -> String {
    const DIGITS: &[u8] = b"abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
    let mut csv = String::from("x_mm,mu");
    for i in 0..99_998usize {
        let name = [DIGITS[i % 62], DIGITS[(i / 62) % 62], DIGITS[i / (62 * 62)]];
        csv.push(',');
        csv.push_str(std::str::from_utf8(&name).unwrap());
    }
    csv.push('\n');
    let row = |x: usize| format!("{x},1.1{}\n", ",0".repeat(99_998));
    let mut x = 0;
    while csv.len() + row(x).len() <= Limits::DEFAULT.max_body_bytes {
        csv.push_str(&row(x));
        x += 1;
    }
    assert!(x >= 2, "{x} rows");
    csv
}

/// A `POST /api/voltage` JSON body of nearly 1 MiB: a profile of as many
/// points as fit.
pub fn maximal_voltage_json() -> String {
    let mut x = String::new();
    let mut mu = String::new();
    let mut n = 0;
    while 40 + x.len() + mu.len() + 16 < Limits::DEFAULT.max_body_bytes && n < Limits::DEFAULT.max_points {
        if n > 0 {
            x.push(',');
            mu.push(',');
        }
        x.push_str(&n.to_string());
        mu.push_str(if n % 3 == 0 { "1.25" } else { "1.05" });
        n += 1;
    }
    format!("{{\"profile\":{{\"x_mm\":[{x}],\"mu\":[{mu}]}}}}")
}

/// The real server (`haptex_server::serve`) on 127.0.0.1:0.
pub struct RawServer {
    pub addr: SocketAddr,
    stop: tokio::sync::oneshot::Sender<()>,
    task: tokio::task::JoinHandle<Result<(), haptex_server::ServeError>>,
}

impl RawServer {
    pub async fn start(state: AppState) -> Self {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let task = tokio::spawn(haptex_server::serve(listener, state, async {
            let _ = stopped.await;
        }));
        Self { addr, stop, task }
    }

    /// Sends `bytes` on a new connection and reads one answer (head and
    /// the body its Content-Length announces).
    pub async fn raw(&self, bytes: &[u8]) -> String {
        use tokio::io::{AsyncReadExt, AsyncWriteExt};
        let mut socket = tokio::net::TcpStream::connect(self.addr).await.unwrap();
        // The server may answer (and close) before reading all of it.
        let _ = socket.write_all(bytes).await;
        let read = async {
            let mut answer = Vec::new();
            let mut buffer = [0u8; 4096];
            loop {
                if let Some(end) = answer.windows(4).position(|w| w == b"\r\n\r\n") {
                    let head = String::from_utf8_lossy(&answer[..end]).to_ascii_lowercase();
                    let length = head
                        .lines()
                        .find_map(|l| l.strip_prefix("content-length:"))
                        .map_or(0, |v| v.trim().parse::<usize>().unwrap());
                    if answer.len() >= end + 4 + length {
                        answer.truncate(end + 4 + length);
                        break;
                    }
                }
                match socket.read(&mut buffer).await {
                    Ok(0) | Err(_) => break,
                    Ok(n) => answer.extend_from_slice(&buffer[..n]),
                }
            }
            answer
        };
        // A bound on a hang, not a benchmark: the one FE run among the
        // campaign's requests (POST /api/simulate with the database's
        // settings, slide steps of 0.0125 mm since the rows are averaged)
        // takes 4-6 s of CPU, 6-11 s wall on 2 loaded cores.
        let answer = tokio::time::timeout(Duration::from_secs(60), read).await.expect("an answer within 60 s");
        String::from_utf8_lossy(&answer).into_owned()
    }

    /// `GET path` with `Host: localhost`.
    pub async fn get(&self, path: &str) -> String {
        self.raw(format!("GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n").as_bytes()).await
    }

    /// Stops the server (graceful shutdown) and waits for it.
    pub async fn stop(self) {
        self.stop.send(()).unwrap();
        tokio::time::timeout(Duration::from_secs(15), self.task).await.unwrap().unwrap().unwrap();
    }
}

/// Asserts a raw answer is `status` with the security headers and a JSON
/// error body naming `field`.
#[track_caller]
pub fn assert_json_error(answer: &str, status: u16, field: Option<&str>) {
    if let Err(e) = check_json_error(answer, status, field) {
        panic!("{e}: {answer:?}");
    }
}

/// Whether a raw answer is `status` with the security headers and a JSON
/// error body naming `field`; what is wrong if not.
pub fn check_json_error(answer: &str, status: u16, field: Option<&str>) -> Result<(), String> {
    let (head, body) = answer.split_once("\r\n\r\n").ok_or("no complete answer")?;
    if !head.starts_with(&format!("HTTP/1.1 {status} ")) {
        return Err(format!("status is not {status}"));
    }
    let head = head.to_ascii_lowercase();
    for (name, value) in SECURITY_HEADERS {
        if !head.contains(&format!("{name}: {}", value.to_ascii_lowercase())) {
            return Err(format!("no {name}"));
        }
    }
    if !head.contains("content-type: application/json") {
        return Err("not application/json".into());
    }
    let json: Value = serde_json::from_str(body).map_err(|e| format!("not JSON ({e})"))?;
    if json["error"].as_str().is_none_or(str::is_empty) {
        return Err("no error message".into());
    }
    if let Some(number) = json["error"].as_str().and_then(haptex_core::num::unreadable_number) {
        return Err(format!("an unreadable number ({number}) in the message"));
    }
    if json["field"].as_str() != field {
        return Err(format!("field {} instead of {field:?}", json["field"]));
    }
    Ok(())
}

/// Asserts that a message follows the rule for numbers shown to a person
/// (`haptex_core::num`: no number of more than 15 significant digits, no
/// run of hundreds of digits); [`Answer::error`] and
/// [`check_json_error`] check every error message they see.
#[track_caller]
pub fn assert_readable(message: &str) {
    if let Some(number) = haptex_core::num::unreadable_number(message) {
        panic!("an unreadable number ({number}) in the message: {message}");
    }
}

/// What `f` logs (info level and above) on this thread.
pub fn capture_log(f: impl FnOnce()) -> String {
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);
    impl Write for Shared {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(bytes);
            Ok(bytes.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let shared = Shared::default();
    let writer = shared.clone();
    let subscriber = tracing_subscriber::fmt()
        .with_writer(move || writer.clone())
        .with_max_level(tracing::Level::INFO)
        .with_ansi(false)
        .finish();
    tracing::subscriber::with_default(subscriber, f);
    String::from_utf8(shared.0.lock().unwrap().clone()).unwrap()
}

/// Standard base64 with padding.
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let n = chunk.iter().enumerate().fold(0u32, |n, (k, &b)| n | (u32::from(b) << (16 - 8 * k)));
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A PNG whose header claims `width` x `height` (CRC correct), with no
/// image data: what a decompression bomb's header looks like.
pub fn header_only_png(width: u32, height: u32) -> Vec<u8> {
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend_from_slice(&width.to_be_bytes());
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend_from_slice(&13u32.to_be_bytes());
    png.extend_from_slice(&ihdr);
    png.extend_from_slice(&crc32(&ihdr).to_be_bytes());
    png
}

pub fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xedb8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// The next line of a streamed answer's body (None at its end).
pub async fn next_line(body: &mut Body, pending: &mut Vec<u8>) -> Option<Value> {
    use hyper::body::Body as _;
    loop {
        if let Some(end) = pending.iter().position(|&b| b == b'\n') {
            let line: Vec<u8> = pending.drain(..=end).collect();
            return Some(serde_json::from_slice(&line).unwrap());
        }
        let frame = std::future::poll_fn(|cx| std::pin::Pin::new(&mut *body).poll_frame(cx)).await?;
        if let Ok(data) = frame.unwrap().into_data() {
            pending.extend_from_slice(&data);
        }
    }
}
