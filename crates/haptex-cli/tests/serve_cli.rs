//! `haptex serve` end to end: the binary starts the web application on the
//! shipped library, answers, and stops cleanly (exit 0) on Ctrl-C (SIGINT)
//! and on SIGTERM; a missing library is refused before listening.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// GET `path` over a plain socket; returns the whole answer.
fn http_get(port: u16, path: &str) -> String {
    let mut socket = TcpStream::connect(("127.0.0.1", port)).unwrap();
    socket.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(socket, "GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n").unwrap();
    let mut answer = String::new();
    socket.read_to_string(&mut answer).unwrap();
    answer
}

#[cfg(unix)]
#[test]
fn serve_answers_and_stops_gracefully_on_ctrl_c_and_sigterm() {
    for signal in ["-INT", "-TERM"] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_haptex"))
            .args(["serve", "--addr", "127.0.0.1:0"])
            .env("RUST_LOG", "info")
            .env_remove("HAPTEX_LIBRARY")
            .stderr(Stdio::piped())
            .spawn()
            .expect("run haptex serve");
        let mut stderr = BufReader::new(child.stderr.take().unwrap());
        let mut seen = String::new();
        let port = loop {
            let mut line = String::new();
            assert!(stderr.read_line(&mut line).unwrap() > 0, "haptex serve ended before listening: {seen}");
            seen.push_str(&line);
            if let Some(rest) = line.strip_prefix("open http://127.0.0.1:") {
                break rest.split('/').next().unwrap().parse::<u16>().unwrap();
            }
        };
        assert!(seen.contains("data/library/library.sqlite"), "{seen}");

        let health = http_get(port, "/api/health");
        assert!(health.starts_with("HTTP/1.1 200"), "{health}");
        assert!(health.contains("\"library\":true"), "{health}");
        let page = http_get(port, "/");
        assert!(page.contains("content-security-policy") && page.contains("<title>"), "{page}");

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
        // The requests were logged.
        assert!(rest.contains("/api/health") || seen.contains("/api/health"), "{seen}{rest}");
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
