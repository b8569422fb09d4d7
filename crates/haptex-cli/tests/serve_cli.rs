//! `haptex serve` end to end: the binary starts the web application on the
//! shipped library, answers, and stops cleanly (exit 0) on Ctrl-C (SIGINT)
//! and on SIGTERM; requests are logged only with --access-log; a host
//! name is served only with --allow-host; a missing library is refused
//! before listening; the hidden --limit-loopback-clients limits clients on
//! this machine per address.

use std::io::{BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;

use common::KillOnDrop;

/// GET `path` over a plain socket; returns the whole answer.
fn http_get(port: u16, path: &str) -> String {
    http_get_for(port, "localhost", path)
}

/// GET `path` with `Host: host`.
fn http_get_for(port: u16, host: &str, path: &str) -> String {
    http_request(port, host, path, "")
}

/// GET `path` with extra header lines (each ending in CRLF).
fn http_get_with(port: u16, path: &str, headers: &str) -> String {
    http_request(port, "localhost", path, headers)
}

/// GET `path` with `Host: host` and extra header lines; the whole answer.
fn http_request(port: u16, host: &str, path: &str, headers: &str) -> String {
    let mut socket = TcpStream::connect(("127.0.0.1", port)).unwrap();
    socket.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(socket, "GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n{headers}\r\n").unwrap();
    let mut answer = String::new();
    socket.read_to_string(&mut answer).unwrap();
    answer
}

/// Issue 41: beyond loopback the server makes a token and prints the
/// address that carries it; requests without it are 401 (the health
/// check says only that it is up), with it as a bearer header they are
/// answered, and the access log never shows it. A token from a file or
/// $HAPTEX_TOKEN is not printed; bad ones are refused naming their
/// source; a loopback server says it runs without one.
#[cfg(unix)]
#[test]
fn serve_needs_a_token_beyond_loopback() {
    let dir = tempfile::tempdir().unwrap();
    let start = |args: &[&str], env: &[(&str, &str)]| {
        let mut child = Command::new(env!("CARGO_BIN_EXE_haptex"))
            .args(["serve"])
            .args(args)
            .env_remove("HAPTEX_TOKEN")
            .envs(env.iter().copied())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run haptex serve");
        let mut stderr = BufReader::new(child.stderr.take().unwrap());
        let mut seen = String::new();
        let port = loop {
            let mut line = String::new();
            assert!(std::io::BufRead::read_line(&mut stderr, &mut line).unwrap() > 0, "ended: {seen}");
            seen.push_str(&line);
            if let Some(rest) = line.split("open http://").nth(1) {
                let port = rest.split('/').next().unwrap().rsplit(':').next().unwrap();
                break port.parse::<u16>().unwrap();
            }
        };
        (KillOnDrop(child), stderr, port, seen)
    };
    let stop = |mut child: KillOnDrop, mut stderr: BufReader<std::process::ChildStderr>| {
        assert!(Command::new("kill").args(["-TERM", &child.0.id().to_string()]).status().unwrap().success());
        assert!(child.0.wait().unwrap().success());
        let mut rest = String::new();
        stderr.read_to_string(&mut rest).unwrap();
        rest
    };

    let (child, stderr, port, seen) = start(&["--addr", "0.0.0.0:0", "--access-log"], &[("RUST_LOG", "info")]);
    assert!(seen.contains("access token required (it listens beyond this machine)"), "{seen}");
    let token = common::printed_token(&seen).expect("the address with its token");
    assert!(token.len() == 64 && token.bytes().all(|b| b.is_ascii_hexdigit()), "{seen}");
    let health = http_get(port, "/api/health");
    assert!(health.starts_with("HTTP/1.1 200") && health.ends_with("{\"status\":\"ok\"}"), "{health}");
    let refused = http_get(port, "/api/config");
    assert!(refused.starts_with("HTTP/1.1 401") && refused.contains("\"field\":\"token\""), "{refused}");
    let page = http_get(port, &format!("/?token={token}"));
    assert!(page.starts_with("HTTP/1.1 200") && page.contains("set-cookie: haptex_session_"), "{page}");
    let config = http_get_with(port, "/api/config", &format!("Authorization: Bearer {token}\r\n"));
    assert!(config.starts_with("HTTP/1.1 200"), "{config}");
    let rest = stop(child, stderr);
    assert!(rest.contains("\"/api/config\" 401") && rest.contains("\"/api/config\" 200"), "{rest}");
    assert!(!rest.contains(&token), "the token in the log: {rest}");

    // From a file (first line) and from the environment: not printed.
    let file = dir.path().join("token");
    std::fs::write(&file, "file-token-0123456789\nsecond line\n").unwrap();
    let file_arg = file.to_str().unwrap();
    let (child, stderr, port, seen) = start(&["--addr", "127.0.0.1:0", "--token-file", file_arg], &[]);
    assert!(seen.contains(&format!("?token=<the token of --token-file {file_arg}>")), "{seen}");
    assert!(!seen.contains("file-token-0123456789"), "{seen}");
    let ok = http_get_with(port, "/api/config", "Authorization: Bearer file-token-0123456789\r\n");
    assert!(ok.starts_with("HTTP/1.1 200"), "{ok}");
    assert!(http_get(port, "/api/config").starts_with("HTTP/1.1 401"));
    stop(child, stderr);
    let (child, stderr, port, seen) = start(&["--addr", "127.0.0.1:0"], &[("HAPTEX_TOKEN", "env-token-0123456789")]);
    assert!(seen.contains("?token=<the token of $HAPTEX_TOKEN>"), "{seen}");
    let ok = http_get_with(port, "/api/config", "Authorization: Bearer env-token-0123456789\r\n");
    assert!(ok.starts_with("HTTP/1.1 200"), "{ok}");
    stop(child, stderr);

    // Loopback, no uploads, no live output: no token, and it says so.
    let (child, stderr, port, seen) = start(&["--addr", "127.0.0.1:0"], &[]);
    assert!(seen.contains("no access token: this server listens on this machine only"), "{seen}");
    assert!(common::printed_token(&seen).is_none(), "{seen}");
    assert!(http_get(port, "/api/config").starts_with("HTTP/1.1 200"));
    stop(child, stderr);

    // Bad tokens, named by where they came from.
    let empty = dir.path().join("empty");
    std::fs::write(&empty, "").unwrap();
    // (arguments, environment, what the error says)
    type Bad<'a> = (&'a [&'a str], &'a [(&'a str, &'a str)], &'a str);
    let bad: [Bad; 4] = [
        (&["--token", "short"], &[], "--token: the token has 5 characters"),
        (&["--token-file", "/nonexistent/token"], &[], "--token-file /nonexistent/token"),
        (&["--token-file", empty.to_str().unwrap()], &[], "line 1: the token has 0 characters"),
        (&[], &[("HAPTEX_TOKEN", "has space 0123456789")], "$HAPTEX_TOKEN: the token has a character"),
    ];
    for (args, env, expected) in bad {
        let out = Command::new(env!("CARGO_BIN_EXE_haptex"))
            .args(["serve", "--addr", "127.0.0.1:0"])
            .args(args)
            .env_remove("HAPTEX_TOKEN")
            .envs(env.iter().copied())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(expected), "{args:?}: {stderr}");
    }
}

#[cfg(unix)]
#[test]
fn serve_answers_and_stops_gracefully_on_ctrl_c_and_sigterm() {
    // With the access log (and an allowed host name) under SIGINT, without
    // under SIGTERM.
    for (signal, access_log) in [("-INT", true), ("-TERM", false)] {
        let mut args = vec!["serve", "--addr", "127.0.0.1:0"];
        if access_log {
            args.extend(["--access-log", "--allow-host", "haptex.test"]);
        }
        let mut child = Command::new(env!("CARGO_BIN_EXE_haptex"))
            .args(&args)
            .env("RUST_LOG", "info")
            .env_remove("HAPTEX_LIBRARY")
            .stderr(Stdio::piped())
            .spawn()
            .expect("run haptex serve");
        let mut stderr = BufReader::new(child.stderr.take().unwrap());
        let (port, seen) = common::listening_port(&mut stderr);
        assert!(seen.contains("data/library/library.sqlite"), "{seen}");

        let health = http_get(port, "/api/health");
        assert!(health.starts_with("HTTP/1.1 200"), "{health}");
        assert!(health.contains("\"library\":true"), "{health}");
        let page = http_get(port, "/");
        assert!(page.contains("content-security-policy") && page.contains("<title>"), "{page}");
        let named = http_get_for(port, "haptex.test:8080", "/api/health");
        let expected = if access_log { "HTTP/1.1 200" } else { "HTTP/1.1 421" };
        assert!(named.starts_with(expected), "--allow-host given: {access_log}: {named}");

        let kill = Command::new("kill").args([signal, &child.id().to_string()]).status().unwrap();
        assert!(kill.success());
        let start = Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            assert!(start.elapsed() < Duration::from_secs(15), "haptex serve did not stop on {signal}");
            std::thread::sleep(Duration::from_millis(20));
        };
        let mut rest = String::new();
        stderr.read_to_string(&mut rest).unwrap();
        assert!(status.success(), "exit status {status} after {signal}: {rest}");
        assert!(rest.contains("haptex serve: stopped"), "{rest}");
        // The requests were logged with --access-log only.
        let logged = rest.contains("/api/health") || seen.contains("/api/health");
        assert_eq!(logged, access_log, "{seen}{rest}");
    }
}

/// POST /api/play (an expensive route: it draws from the client's
/// bucket) from the source address `from`; the whole answer.
fn play_from(port: u16, from: &str) -> String {
    let body = r#"{"voltage":{"x_mm":[0,10],"voltage_v":[50,80]},"stroke":{"velocity_mm_s":50},"format":"json"}"#;
    // std cannot bind a socket before connecting it: tokio's TcpSocket can.
    let runtime = tokio::runtime::Builder::new_current_thread().enable_io().build().unwrap();
    let mut socket = runtime.block_on(async {
        let socket = tokio::net::TcpSocket::new_v4().unwrap();
        socket.bind(std::net::SocketAddr::new(from.parse().unwrap(), 0)).unwrap();
        let stream = socket.connect(std::net::SocketAddr::from(([127, 0, 0, 1], port))).await.unwrap();
        stream.into_std().unwrap()
    });
    socket.set_nonblocking(false).unwrap();
    socket.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(
        socket,
        "POST /api/play HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\nContent-Type: application/json\r\n\
         Content-Length: {}\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    let mut answer = String::new();
    socket.read_to_string(&mut answer).unwrap();
    answer
}

/// Issue 41: clients on this machine are not limited per client, unless
/// the hidden --limit-loopback-clients (for benchmarks that use
/// 127.0.0.x addresses as different clients, scripts/load_clients.py)
/// says so: then 127.0.0.2 past its bucket of expensive requests (2 here)
/// gets 429 with Retry-After while 127.0.0.1, another client, is answered;
/// without it the same requests are all answered. The flag is not in
/// --help.
#[cfg(unix)]
#[test]
fn serve_limits_loopback_clients_with_the_hidden_flag() {
    let help = common::haptex(&["serve", "--help"]);
    assert!(help.status.success() && !String::from_utf8_lossy(&help.stdout).contains("loopback-clients"));
    for limited in [true, false] {
        let mut args = vec!["serve", "--addr", "127.0.0.1:0", "--client-burst", "2", "--client-rate", "0.01"];
        if limited {
            args.push("--limit-loopback-clients");
        }
        let mut child = KillOnDrop(
            Command::new(env!("CARGO_BIN_EXE_haptex"))
                .args(&args)
                .env_remove("HAPTEX_TOKEN")
                .stderr(Stdio::piped())
                .spawn()
                .expect("run haptex serve"),
        );
        let mut stderr = BufReader::new(child.0.stderr.take().unwrap());
        let (port, _) = common::listening_port(&mut stderr);
        let answers: Vec<String> = (0..3).map(|_| play_from(port, "127.0.0.2")).collect();
        for (i, answer) in answers.iter().enumerate() {
            let expected = if limited && i == 2 { "HTTP/1.1 429" } else { "HTTP/1.1 200" };
            assert!(answer.starts_with(expected), "limited {limited}, play {i}: {}", &answer[..answer.len().min(400)]);
        }
        if limited {
            let refused = answers[2].to_ascii_lowercase();
            assert!(refused.contains("retry-after: ") && refused.contains("expensive requests"), "{refused}");
            let other = play_from(port, "127.0.0.1");
            assert!(other.starts_with("HTTP/1.1 200"), "the other client: {}", &other[..other.len().min(400)]);
        }
        assert!(Command::new("kill").args(["-TERM", &child.0.id().to_string()]).status().unwrap().success());
        assert!(child.0.wait().unwrap().success());
    }
}

#[test]
fn serve_refuses_a_missing_library() {
    let out = Command::new(env!("CARGO_BIN_EXE_haptex"))
        .args(["serve", "--addr", "127.0.0.1:0", "--library", "/nonexistent/lib.sqlite"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("/nonexistent/lib.sqlite") && stderr.contains("no library"), "{stderr}");
}

/// `haptex serve --writable`: recordings uploaded to the server
/// (`POST /api/recordings`) are stored as `haptex library import` stores
/// the same files: `haptex library sample` of both libraries gives the
/// same profile, value for value. The flag is said at start.
#[cfg(unix)]
#[test]
fn serve_writable_stores_uploads_as_library_import_does() {
    let dir = tempfile::tempdir().unwrap();
    let demo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/library/demo/tile");
    let files = dir.path().join("tile-lab");
    std::fs::create_dir(&files).unwrap();
    let mut parts: Vec<(String, Vec<u8>)> = Vec::new();
    for stroke in 1..=3 {
        for suffix in [".recording.json", ".force.npy", ".position.npy"] {
            let name = format!("tile-s{stroke}{suffix}");
            let mut bytes = std::fs::read(demo.join(&name)).unwrap();
            if suffix == ".recording.json" {
                bytes = String::from_utf8(bytes)
                    .unwrap()
                    .replace("\"material\": \"tile\"", "\"material\": \"tile-lab\"")
                    .into_bytes();
            }
            std::fs::write(files.join(&name), &bytes).unwrap();
            parts.push((name, bytes));
        }
    }
    let served = dir.path().join("served.sqlite");
    let shipped = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/library/library.sqlite");
    std::fs::copy(&shipped, &served).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_haptex"))
        .args(["serve", "--addr", "127.0.0.1:0", "--writable", "--library"])
        .arg(&served)
        .stderr(Stdio::piped())
        .spawn()
        .expect("run haptex serve");
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let (port, seen) = common::listening_port(&mut stderr);
    assert!(seen.contains("writable"), "{seen}");
    // Uploads need the access token, made at start and printed once.
    assert!(seen.contains("access token required (--writable lets requests add recordings"), "{seen}");
    let token = common::printed_token(&seen).expect("the address with its token");
    assert_eq!(token.len(), 64, "{seen}");

    let boundary = "haptex-cli-test-5b2e";
    let mut body = Vec::new();
    write!(body, "--{boundary}\r\nContent-Disposition: form-data; name=\"provenance\"\r\n\r\nsynthetic\r\n").unwrap();
    for (name, bytes) in &parts {
        write!(body, "--{boundary}\r\nContent-Disposition: form-data; name=\"files\"; filename=\"{name}\"\r\n\r\n")
            .unwrap();
        body.extend_from_slice(bytes);
        body.extend_from_slice(b"\r\n");
    }
    write!(body, "--{boundary}--\r\n").unwrap();
    let mut socket = TcpStream::connect(("127.0.0.1", port)).unwrap();
    socket.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    write!(
        socket,
        "POST /api/recordings HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\nContent-Type: multipart/form-data; \
         boundary={boundary}\r\nAuthorization: Bearer {token}\r\nContent-Length: {}\r\n\r\n",
        body.len()
    )
    .unwrap();
    socket.write_all(&body).unwrap();
    let mut answer = String::new();
    socket.read_to_string(&mut answer).unwrap();
    assert!(
        answer.starts_with("HTTP/1.1 200") && answer.contains("\"added\":3"),
        "{}",
        &answer[..answer.len().min(600)]
    );
    let kill = Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    assert!(child.wait().unwrap().success());

    let imported = dir.path().join("imported.sqlite");
    let import = Command::new(env!("CARGO_BIN_EXE_haptex"))
        .args(["library", "import", "--quiet", "--db"])
        .arg(&imported)
        .arg(&files)
        .output()
        .unwrap();
    assert!(import.status.success(), "{}", String::from_utf8_lossy(&import.stderr));
    let sample = |db: &std::path::Path, seed: u64| -> serde_json::Value {
        let out = Command::new(env!("CARGO_BIN_EXE_haptex"))
            .args([
                "library",
                "sample",
                "--material",
                "tile-lab",
                "--format",
                "json",
                "--seed",
                &seed.to_string(),
                "--db",
            ])
            .arg(db)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice(&out.stdout).unwrap()
    };
    for seed in 0..4 {
        let (a, b) = (sample(&served, seed), sample(&imported, seed));
        for column in ["x_mm", "mu", "fn_n"] {
            assert!(a[column].as_array().is_some_and(|v| v.len() > 100), "{column}");
            assert_eq!(a[column], b[column], "seed {seed}, {column}");
        }
        assert_eq!(a["stroke"]["content_sha256"], b["stroke"]["content_sha256"]);
        assert_eq!(a["stroke"]["synthetic"], true);
    }
    let check =
        Command::new(env!("CARGO_BIN_EXE_haptex")).args(["library", "check", "--db"]).arg(&served).output().unwrap();
    assert!(check.status.success(), "{}", String::from_utf8_lossy(&check.stderr));
}
