//! `haptex serve` end to end: the binary starts the web application on the
//! shipped library, answers, and stops cleanly (exit 0) on Ctrl-C (SIGINT)
//! and on SIGTERM; requests are logged only with --access-log; a host
//! name is served only with --allow-host; a missing library is refused
//! before listening.

use std::io::{BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;

/// GET `path` over a plain socket; returns the whole answer.
fn http_get(port: u16, path: &str) -> String {
    http_get_for(port, "localhost", path)
}

/// GET `path` with `Host: host`.
fn http_get_for(port: u16, host: &str, path: &str) -> String {
    let mut socket = TcpStream::connect(("127.0.0.1", port)).unwrap();
    socket.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(socket, "GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n").unwrap();
    let mut answer = String::new();
    socket.read_to_string(&mut answer).unwrap();
    answer
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
