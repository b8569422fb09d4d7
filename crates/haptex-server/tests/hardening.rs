//! Issue 13 ("Hardening"), the server's part: one test per class of
//! fault the adversarial campaign found, each named after its class and
//! each failing on the server as it was before the fix (the comment of
//! each says what it saw then).
//!
//! In-process: the application through `tower::ServiceExt::oneshot`, or
//! the real `haptex_server::serve` on 127.0.0.1:0 where the connection
//! itself matters (raw TCP).

mod common;

use std::time::{Duration, Instant};

use axum::body::Body;
use axum::http::{Request, StatusCode, header};
use haptex_server::{AppState, HostPolicy, Limits, app};
use serde_json::json;

use common::{RawServer, maximal_csv, maximal_voltage_json, send_to, shipped_state};

// ------------------------------------------------ CPU work and parsing

/// Class: CPU-heavy work blocked the async workers, so two maximal uploads
/// stopped every endpoint, `/api/health` included. Three clients post
/// maximal bodies (a 1 MiB CSV with a 10^5-column header, a 1 MiB JSON
/// profile) back to back on a two-worker runtime while `/api/health` is
/// asked every 10 ms (as a task on the workers, where connections are
/// served): the slowest health answer comes sooner than the median
/// upload is answered. Before: the handlers parsed and mapped on the
/// workers (a maximal CSV took 135 ms there), and health waited behind
/// them, as long as an upload's work. The bound is relative, measured in
/// the same run, so that a loaded machine slows both sides alike: the
/// latency itself (p99 and maximum under load) is a benchmark
/// (scripts/load_health.py, BENCHMARKS.md), not a test.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cpu_work_runs_off_the_async_workers_so_health_answers_before_the_uploads() {
    let router = app(shipped_state());
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let mut uploaders = Vec::new();
    for i in 0..3 {
        let (router, stop) = (router.clone(), stop.clone());
        uploaders.push(tokio::spawn(async move {
            let (uri, content_type, body) = if i % 2 == 0 {
                ("/api/profile", "text/csv", maximal_csv())
            } else {
                ("/api/voltage", "application/json", maximal_voltage_json())
            };
            let mut took = Vec::new();
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                let request =
                    Request::post(uri).header(header::CONTENT_TYPE, content_type).body(Body::from(body.clone()));
                let t = Instant::now();
                send_to(router.clone(), request.unwrap()).await.ok();
                took.push(t.elapsed());
            }
            took
        }));
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    let mut latencies = Vec::new();
    let started = Instant::now();
    while started.elapsed() < Duration::from_secs(3) {
        // On the runtime's workers, as a connection's request is served.
        let router = router.clone();
        let latency = tokio::spawn(async move {
            let t = Instant::now();
            send_to(router, Request::get("/api/health").body(Body::empty()).unwrap()).await.ok();
            t.elapsed()
        });
        latencies.push(latency.await.unwrap());
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let mut uploads = Vec::new();
    for u in uploaders {
        uploads.extend(u.await.unwrap());
    }
    latencies.sort();
    uploads.sort();
    let (median, worst) = (latencies[latencies.len() / 2], latencies[latencies.len() - 1]);
    assert!(uploads.len() >= 6, "the uploads were not processed ({})", uploads.len());
    let upload = uploads[uploads.len() / 2];
    eprintln!(
        "{} health answers during {} maximal uploads (median {upload:?}): median {median:?}, worst {worst:?}",
        latencies.len(),
        uploads.len()
    );
    assert!(worst < upload, "health took up to {worst:?}, an upload {upload:?}: health waited behind the uploads");
}

/// Class: the request timeout did not stop a request while it was being
/// parsed (the handler parsed without yielding, so the timeout could not
/// fire). With a 1 ms timeout, a maximal body is answered 408 JSON, and
/// promptly. Before: 200, after the whole parse and mapping.
#[tokio::test]
async fn request_timeout_covers_parsing() {
    let limits = Limits { request_timeout: Duration::from_millis(1), ..Limits::DEFAULT };
    let router = app(AppState::new(None, limits).unwrap());
    for (uri, content_type, body) in
        [("/api/voltage", "application/json", maximal_voltage_json()), ("/api/profile", "text/csv", maximal_csv())]
    {
        let request = Request::post(uri).header(header::CONTENT_TYPE, content_type).body(Body::from(body)).unwrap();
        let answer = send_to(router.clone(), request).await;
        answer.error(StatusCode::REQUEST_TIMEOUT, None);
    }
}

// ------------------------------------------------------ unread answers

/// Class: the server kept finished answers for clients that never read
/// them, without bound (150 such clients took it from 0.3 to 2.4 GB).
/// 24 clients each ask for a 192 000-sample JSON drive (about 16 MB) and
/// read nothing, with a budget of 24 MiB: the bytes of unsent answers
/// (the server's gauge) never exceed the budget, the clients past it get
/// 503 JSON, the server keeps serving others meanwhile, and once the
/// write timeout closes the stalled connections the gauge returns to 0.
/// Before: nothing bounded it; the same clients held 24 x 16 MB.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn unread_answers_hold_bounded_memory() {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let budget = 24 << 20;
    let limits = Limits {
        max_unsent_answer_bytes: budget,
        write_timeout: Duration::from_secs(2),
        concurrent_renders: 2,
        ..Limits::DEFAULT
    };
    let state = AppState::new(None, limits).unwrap();
    let server = RawServer::start(state.clone()).await;
    let body = json!({
        "voltage": { "x_mm": [0.0, 10.0], "voltage_v": [50.0, 80.0] },
        "stroke": { "velocity_mm_s": 2.6 },
        "sample_rate_hz": 50000,
        "format": "json",
    })
    .to_string();
    let request = format!(
        "POST /api/play HTTP/1.1\r\nHost: localhost\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    );
    let mut sockets = Vec::new();
    let mut peak = 0;
    for _ in 0..24 {
        let mut socket = tokio::net::TcpStream::connect(server.addr).await.unwrap();
        socket.write_all(request.as_bytes()).await.unwrap();
        sockets.push(socket);
        for _ in 0..10 {
            peak = peak.max(state.unsent_answer_bytes());
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    }
    // Wait for every render to end (2 at a time), watching the gauge.
    let started = Instant::now();
    while started.elapsed() < Duration::from_secs(4) {
        peak = peak.max(state.unsent_answer_bytes());
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    eprintln!("unsent answers: peak {} MiB, budget {} MiB", peak >> 20, budget >> 20);
    assert!(peak > 0 && peak <= budget, "peak of unsent answer bytes {peak}, budget {budget}");
    // Others are still served meanwhile.
    let health = server.get("/api/health").await;
    assert!(health.starts_with("HTTP/1.1 200"), "{health}");
    // The clients past the budget were told so: 503 JSON.
    let mut refused = 0;
    for socket in &mut sockets {
        let mut head = vec![0u8; 12];
        if tokio::time::timeout(Duration::from_millis(200), socket.read_exact(&mut head)).await.is_ok()
            && head.starts_with(b"HTTP/1.1 503")
        {
            refused += 1;
        }
    }
    assert!(refused > 0, "no client was refused: the budget did not bind");
    // The write timeout closes the stalled connections; their answers are
    // freed.
    let started = Instant::now();
    while state.unsent_answer_bytes() > 0 && started.elapsed() < Duration::from_secs(10) {
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    assert_eq!(state.unsent_answer_bytes(), 0, "answers still held after the write timeout");
    server.stop().await;
}

// ------------------------------------------------------ derived values

/// Class: derived values were not checked like given ones: rows with
/// ft_n = 1e308 or fn_n = 5e-324 gave mu = inf, answered 200 with
/// `"mu": [null, ...]` and "NaN% of the length". Each such profile, as a
/// CSV upload or as JSON, to /api/profile and /api/voltage, is now 400
/// naming the field (and the line for CSV), with the value quoted short.
/// A finite but extreme ratio (mu = 10 / 1e-5) is refused like a given
/// mu out of range would be.
#[tokio::test]
async fn derived_values_are_checked_like_given_ones() {
    let router = app(shipped_state());
    let cases: &[(&str, &str, &str, &str)] = &[
        ("x_mm,ft_n,fn_n\n0,0.1,0.2\n1,1e308,0.2\n", "ft_n", "profile.ft_n[1]", "1e308"),
        ("x_mm,ft_n,fn_n\n0,0.1,0.2\n1,0.1,5e-324\n", "fn_n", "profile.fn_n[1]", "5e-324"),
        (
            "x_mm,ft_n,fn_n\n0,0.1,0.2\n1,10,1e-5\n",
            "fn_n",
            "profile.fn_n[1]",
            // 999999.9999999999 to the last bit, shown as the number it rounds to.
            "mu = ft_n / fn_n = 10 / 0.00001 = 1000000 is not",
        ),
        ("x_mm,mu,fn_n\n0,1,0.2\n1,1,5e-324\n", "fn_n", "profile.fn_n[1]", "5e-324"),
        ("x_mm,mu\n-1e308,1\n1e308,1\n", "x_mm", "profile.x_mm[0]", "-1e308"),
        ("x_mm,mu\n0,-1e308\n1,1e308\n", "mu", "profile.mu[0]", "-1e308"),
    ];
    for (csv, column, json_field, quoted) in cases {
        for uri in ["/api/profile", "/api/voltage?method=normalized"] {
            let request = Request::post(uri).header(header::CONTENT_TYPE, "text/csv").body(Body::from(*csv));
            let body = send_to(router.clone(), request.unwrap()).await.error(StatusCode::BAD_REQUEST, Some(column));
            assert_eq!(body["line"], 3 - u64::from(json_field.ends_with("[0]")), "{csv:?}: {body}");
            let message = body["error"].as_str().unwrap();
            assert!(message.contains(quoted) && message.len() < 300, "{csv:?}: {message}");
        }
        let table = haptex_core::io::Table::read(csv.as_bytes(), "case").unwrap();
        let mut profile = serde_json::Map::new();
        for name in table.columns() {
            profile.insert(name.clone(), json!(table.column(name).unwrap()));
        }
        let body = json!({ "profile": profile, "method": "normalized" }).to_string();
        let request = Request::post("/api/voltage").header(header::CONTENT_TYPE, "application/json").body(body.into());
        let answer = send_to(router.clone(), request.unwrap()).await;
        let error = answer.error(StatusCode::BAD_REQUEST, Some(json_field));
        assert!(error["error"].as_str().unwrap().contains(quoted), "{error}");
    }
}

// ---------------------------------------------- one validation per field

/// Class: a field was validated on one path and not another:
/// `/api/play` with `"format": "json"` accepted `volts_per_full_scale`
/// <= 0, the WAV path refused it with `"field": null`, and messages
/// printed 1e308 as 309 digits. Every numeric field of `/api/play`, bad
/// in each of the ways a number can be (zero, negative, 1e308, 5e-324,
/// -1e308), is refused identically in both formats, naming the field and
/// quoting the value short.
#[tokio::test]
async fn one_validation_path_per_field() {
    let router = app(shipped_state());
    let fields: &[(&str, &[f64])] = &[
        ("volts_per_full_scale", &[0.0, -1.0, 1e308, 5e-324]),
        ("u_max_v", &[0.0, -1.0, 1e308, 5e-324]),
        ("slew_v_per_s", &[0.0, -1.0, 1e308, 5e-324]),
        ("amplifier_range_v", &[0.0, -1.0, 1e308, 5e-324]),
        ("stroke.velocity_mm_s", &[0.0, -1.0, 1e308, 5e-324]),
        ("stroke.from_mm", &[1e308, -1e308]),
        ("stroke.to_mm", &[1e308, -1e308]),
        ("carrier.frequency_hz", &[0.0, -1.0, 1e308, 5e-324]),
    ];
    for (field, values) in fields {
        for value in *values {
            let mut answers = Vec::new();
            for format in ["wav", "json"] {
                let mut body = json!({
                    "voltage": { "x_mm": [0.0, 10.0], "voltage_v": [50.0, 50.0] },
                    "stroke": { "velocity_mm_s": 50.0 },
                    "carrier": { "shape": "sine", "frequency_hz": 1000.0 },
                    "format": format,
                });
                match field.split_once('.') {
                    Some((outer, inner)) => body[outer][inner] = json!(value),
                    None => body[field] = json!(value),
                }
                let request =
                    Request::post("/api/play").header(header::CONTENT_TYPE, "application/json").body(body.to_string());
                let answer = send_to(router.clone(), request.unwrap().map(Body::from)).await;
                let error = answer.error(StatusCode::BAD_REQUEST, Some(field));
                let message = error["error"].as_str().unwrap().to_string();
                let longest_number = message.split(|c: char| !c.is_ascii_digit()).map(str::len).max().unwrap_or(0);
                assert!(message.len() < 200 && longest_number <= 17, "{field} = {value}: {message}");
                answers.push(message);
            }
            assert_eq!(answers[0], answers[1], "{field} = {value}: the two formats disagree");
        }
    }
}

// ------------------------------------------------------------ hosts

/// Class: the Host header was not checked, so a page of another origin
/// could reach the API by DNS rebinding. A request for another name is
/// 421 JSON naming `host`; localhost, IP addresses and the names allowed
/// at start are served; an HTTP/1.1 request without Host is 400. Before:
/// every host was served.
#[tokio::test]
async fn dns_rebinding_hosts_are_refused() {
    let state = shipped_state().with_hosts(HostPolicy::new(["haptex.lab"]).unwrap());
    let router = app(state.clone());
    let ask = |host: &'static str| {
        let router = router.clone();
        async move {
            let request = Request::get("/api/health").header(header::HOST, host).body(Body::empty()).unwrap();
            send_to(router, request).await
        }
    };
    for host in ["evil.example", "evil.example:8080", "localhost.evil.example", "127.0.0.1.nip.io:8080"] {
        let answer = ask(host).await;
        let body = answer.error(StatusCode::MISDIRECTED_REQUEST, Some("host"));
        assert!(body["error"].as_str().unwrap().contains("DNS rebinding"), "{body}");
        assert!(answer.headers.contains_key(header::CONTENT_SECURITY_POLICY));
    }
    for host in ["localhost:8080", "127.0.0.1:8080", "192.168.1.7:8080", "[::1]:8080", "haptex.lab:8080", "a.localhost"]
    {
        ask(host).await.ok();
    }
    // An absolute request target names the host too.
    let request = Request::get("http://evil.example/api/health").header(header::HOST, "localhost").body(Body::empty());
    send_to(router.clone(), request.unwrap()).await.error(StatusCode::MISDIRECTED_REQUEST, Some("host"));
    // Over a real socket: no Host at all, and a rebinding page's request.
    let server = RawServer::start(state).await;
    let answer = server.raw(b"GET /api/health HTTP/1.1\r\nConnection: close\r\n\r\n").await;
    common::assert_json_error(&answer, 400, Some("host"));
    let answer = server.raw(b"GET /api/health HTTP/1.1\r\nHost: attacker.example\r\nConnection: close\r\n\r\n").await;
    common::assert_json_error(&answer, 421, Some("host"));
    let answer = server.raw(b"GET /api/health HTTP/1.0\r\n\r\n").await;
    assert!(answer.starts_with("HTTP/1.1 200") || answer.starts_with("HTTP/1.0 200"), "{answer}");
    server.stop().await;
}

// ------------------------------------------------- answers hyper writes

/// Class: 414, 431 and malformed-request answers carried none of the
/// security headers and had empty bodies (hyper wrote them itself). Over
/// raw TCP: a request target over the documented 8 KiB and one beyond
/// hyper's buffer, header fields over 32 KiB, too many header fields
/// (for the server's limit and for hyper's), a garbage request line, a
/// header line without a colon and a header name with a space: every
/// answer has the security headers and a JSON body naming the field.
/// Before: `HTTP/1.1 431 ...\r\ncontent-length: 0` and nothing else.
#[tokio::test]
async fn every_answer_carries_the_security_headers_and_a_json_body() {
    let server = RawServer::start(shipped_state()).await;
    let long = |n: usize| "a".repeat(n);
    let many = |n: usize| (0..n).map(|i| format!("x-h{i}: v\r\n")).collect::<String>();
    let cases: Vec<(String, u16, Option<&str>)> = vec![
        (format!("GET /api/health?{} HTTP/1.1\r\nHost: localhost\r\n\r\n", long(9000)), 414, Some("uri")),
        (format!("GET /{} HTTP/1.1\r\nHost: localhost\r\n\r\n", long(400_000)), 431, Some("headers")),
        (
            format!("GET /api/health HTTP/1.1\r\nHost: localhost\r\nCookie: {}\r\n\r\n", long(40_000)),
            431,
            Some("cookie"),
        ),
        (format!("GET /api/health HTTP/1.1\r\nHost: localhost\r\n{}\r\n", many(150)), 431, Some("headers")),
        (format!("GET /api/health HTTP/1.1\r\nHost: localhost\r\n{}\r\n", many(300)), 431, Some("headers")),
        ("GARBAGE\r\n\r\n".to_string(), 400, Some("request")),
        ("GET /api/health HTTP/1.1\r\nHost: localhost\r\nNo colon here\r\n\r\n".to_string(), 400, Some("request")),
        ("GET /api/health HTTP/1.1\r\nHost: localhost\r\nBad Name: v\r\n\r\n".to_string(), 400, Some("request")),
        ("GET /api/health HTTP/9.9\r\nHost: localhost\r\n\r\n".to_string(), 400, Some("request")),
        ("\x00\x01\x02\x03 / HTTP/1.1\r\n\r\n".to_string(), 400, Some("request")),
    ];
    for (request, status, field) in cases {
        let answer = server.raw(request.as_bytes()).await;
        common::assert_json_error(&answer, status, field);
    }
    // The connection stays usable for the next client.
    assert!(server.get("/api/health").await.starts_with("HTTP/1.1 200"));
    server.stop().await;
}

// ------------------------------------------------------------ the log

/// Class: the request log grew ~177 bytes per request with no switch.
/// With the default state nothing is logged for 50 served and refused
/// requests; with the access log on, one line each; a server error (a
/// panic here is not reachable from input, so a 500 from the library's
/// broken file) is logged either way. Before: a line per request always.
#[test]
fn access_log_is_off_by_default_and_errors_are_always_logged() {
    let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
    let run = |state: AppState| {
        common::capture_log(|| {
            runtime.block_on(async {
                let router = app(state);
                for i in 0..50 {
                    let uri = if i % 2 == 0 { "/api/health" } else { "/api/health?unknown=1" };
                    send_to(router.clone(), Request::get(uri).body(Body::empty()).unwrap()).await;
                }
            })
        })
    };
    let quiet = run(shipped_state());
    assert_eq!(quiet, "", "logged without the access log:\n{quiet}");
    let logged = run(shipped_state().with_access_log(true));
    assert_eq!(logged.lines().count(), 50, "{logged}");
    assert!(logged.contains("GET \"/api/health\" 200") && logged.contains("GET \"/api/health\" 400"), "{logged}");

    // A library file that is not a library: listing it is the server's
    // fault (500), logged without the access log.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("library.sqlite");
    std::fs::copy(common::shipped_library(), &path).unwrap();
    let state = AppState::new(Some(&path), Limits::DEFAULT).unwrap();
    std::fs::write(&path, b"not a database").unwrap();
    let errors = common::capture_log(|| {
        runtime.block_on(async {
            let answer = send_to(app(state), Request::get("/api/materials").body(Body::empty()).unwrap()).await;
            assert!(answer.status.is_server_error(), "{}", answer.status);
        })
    });
    assert!(errors.contains("ERROR") && errors.contains("/api/materials"), "{errors}");
}

/// Found by the fuzz campaign (fuzz/, target http_body): a CSV header of
/// 1000 NUL bytes made the error name that column, and JSON wrote each NUL
/// as six bytes: a 4 KB answer echoing binary. Whatever the request, an
/// error answer is short and printable.
#[tokio::test]
async fn error_answers_are_short_and_printable_whatever_the_request() {
    let router = app(shipped_state());
    let headers = [
        format!("{}#\nx_mm,mu\n0,1\n1,1\n", "\0".repeat(1000)),
        format!("x_mm,{}\n0,1\n1,1\n", "\u{1b}[31m".repeat(3000)),
        format!("x_mm,{}\n0,1\n1,1\n", "m".repeat(500_000)),
    ];
    for csv in headers {
        let request = Request::post("/api/voltage").header(header::CONTENT_TYPE, "text/csv").body(Body::from(csv));
        let answer = send_to(router.clone(), request.unwrap()).await;
        assert_eq!(answer.status, StatusCode::BAD_REQUEST);
        assert!(answer.body.len() < 1024, "an error answer of {} bytes: {}", answer.body.len(), answer.text());
        let json = answer.json();
        let message = json["error"].as_str().unwrap();
        assert!(!message.chars().any(char::is_control), "{message:?}");
    }
}
