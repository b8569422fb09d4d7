//! Limits per client (issue 41, `haptex_server::clients`), over real TCP
//! connections from two loopback addresses (127.0.0.1 and 127.0.0.2 are
//! two clients, with `limit_loopback_clients`): a client past its bucket of expensive requests is 429
//! with `Retry-After` while the other's requests are answered; a client
//! past its connections gets a 429 and a closed connection, the other
//! connects; a client's second expensive request waits for its first
//! while the other's are answered. The latency the other client keeps is measured by a
//! benchmark (scripts/load_clients.py, BENCHMARKS.md), not timed here.

mod common;

use std::net::{IpAddr, SocketAddr};
use std::time::Duration;

use haptex_server::{AppState, Limits};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

use common::RawServer;

/// A connection to `server` from `from`.
async fn connect(server: SocketAddr, from: &str) -> tokio::net::TcpStream {
    let socket = tokio::net::TcpSocket::new_v4().unwrap();
    socket.bind(SocketAddr::new(from.parse::<IpAddr>().unwrap(), 0)).unwrap();
    socket.connect(server).await.unwrap()
}

/// Sends `request` from `from` and reads the answer to the connection's end.
async fn ask(server: SocketAddr, from: &str, request: &str) -> String {
    let mut stream = connect(server, from).await;
    stream.write_all(request.as_bytes()).await.unwrap();
    let mut answer = Vec::new();
    tokio::time::timeout(Duration::from_secs(10), stream.read_to_end(&mut answer)).await.unwrap().unwrap();
    String::from_utf8_lossy(&answer).into_owned()
}

fn play() -> String {
    let body = r#"{"voltage":{"x_mm":[0,10],"voltage_v":[50,80]},"stroke":{"velocity_mm_s":50},"format":"json"}"#;
    format!(
        "POST /api/play HTTP/1.1\r\nHost: localhost\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\
         Connection: close\r\n\r\n{body}",
        body.len()
    )
}

const CONFIG: &str = "GET /api/config HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_past_its_expensive_requests_waits_and_the_others_do_not() {
    let limits = Limits {
        client_expensive_burst: 3.0,
        client_expensive_per_s: 0.25,
        limit_loopback_clients: true,
        ..Limits::DEFAULT
    };
    let server = RawServer::start(AppState::new(None, limits).unwrap()).await;
    for i in 0..3 {
        let answer = ask(server.addr, "127.0.0.1", &play()).await;
        assert!(answer.starts_with("HTTP/1.1 200"), "play {i}: {}", &answer[..answer.len().min(300)]);
    }
    let refused = ask(server.addr, "127.0.0.1", &play()).await;
    common::assert_json_error(&refused, 429, None);
    let retry = refused.lines().find_map(|l| l.to_ascii_lowercase().strip_prefix("retry-after: ").map(str::to_string));
    let retry: u64 = retry.expect("a Retry-After").trim().parse().unwrap();
    assert!((1..=4).contains(&retry), "{retry}");
    assert!(refused.contains("expensive requests"), "{refused}");
    // Cheap requests of the same client, and the other client's expensive ones, are answered.
    assert!(ask(server.addr, "127.0.0.1", CONFIG).await.starts_with("HTTP/1.1 200"));
    for i in 0..3 {
        let answer = ask(server.addr, "127.0.0.2", &play()).await;
        assert!(
            answer.starts_with("HTTP/1.1 200"),
            "the other client's play {i}: {}",
            &answer[..answer.len().min(300)]
        );
    }
    server.stop().await;
}

/// One client's expensive requests are worked on one at a time
/// (`client_concurrent` 1): while its first is being handled (here its
/// body is still arriving), its second waits for it, up to `heavy_wait`,
/// then 429; the other client's are answered meanwhile, and the first
/// client's next one once its first is done.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_works_on_one_expensive_request_at_a_time_and_the_others_do_not_wait_for_it() {
    let limits = Limits {
        client_concurrent: 1,
        heavy_wait: Duration::from_millis(500),
        limit_loopback_clients: true,
        ..Limits::DEFAULT
    };
    let server = RawServer::start(AppState::new(None, limits).unwrap()).await;
    // The first request: its head and half its body.
    let first = play();
    let cut = first.len() - 20;
    let mut held = connect(server.addr, "127.0.0.1").await;
    held.write_all(&first.as_bytes()[..cut]).await.unwrap();
    tokio::time::sleep(Duration::from_millis(200)).await;
    let started = std::time::Instant::now();
    let refused = ask(server.addr, "127.0.0.1", &play()).await;
    common::assert_json_error(&refused, 429, None);
    assert!(refused.contains("still being worked on"), "{refused}");
    assert!(started.elapsed() >= Duration::from_millis(500), "answered before heavy_wait: {:?}", started.elapsed());
    for i in 0..2 {
        let answer = ask(server.addr, "127.0.0.2", &play()).await;
        assert!(
            answer.starts_with("HTTP/1.1 200"),
            "the other client's play {i}: {}",
            &answer[..answer.len().min(300)]
        );
    }
    // The first request completes, and frees the client's share.
    held.write_all(&first.as_bytes()[cut..]).await.unwrap();
    let mut answer = Vec::new();
    tokio::time::timeout(Duration::from_secs(10), held.read_to_end(&mut answer)).await.unwrap().unwrap();
    assert!(answer.starts_with(b"HTTP/1.1 200"), "{}", String::from_utf8_lossy(&answer[..answer.len().min(300)]));
    let answer = ask(server.addr, "127.0.0.1", &play()).await;
    assert!(answer.starts_with("HTTP/1.1 200"), "the next play: {}", &answer[..answer.len().min(300)]);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_past_its_connections_is_refused_and_the_others_are_not() {
    let limits = Limits { client_connections: 2, limit_loopback_clients: true, ..Limits::DEFAULT };
    let server = RawServer::start(AppState::new(None, limits).unwrap()).await;
    let held = [connect(server.addr, "127.0.0.1").await, connect(server.addr, "127.0.0.1").await];
    // Let the server count both before the third arrives.
    tokio::time::sleep(Duration::from_millis(200)).await;
    let refused = ask(server.addr, "127.0.0.1", CONFIG).await;
    common::assert_json_error(&refused, 429, None);
    assert!(refused.to_ascii_lowercase().contains("retry-after: 1"), "{refused}");
    assert!(ask(server.addr, "127.0.0.2", CONFIG).await.starts_with("HTTP/1.1 200"));
    drop(held);
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert!(ask(server.addr, "127.0.0.1", CONFIG).await.starts_with("HTTP/1.1 200"));
    server.stop().await;
}

/// By default clients on this machine are not limited per client.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn loopback_clients_are_not_limited_by_default() {
    let limits =
        Limits { client_expensive_burst: 1.0, client_expensive_per_s: 0.01, client_connections: 1, ..Limits::DEFAULT };
    let server = RawServer::start(AppState::new(None, limits).unwrap()).await;
    let _held = connect(server.addr, "127.0.0.1").await;
    for i in 0..3 {
        let answer = ask(server.addr, "127.0.0.1", &play()).await;
        assert!(answer.starts_with("HTTP/1.1 200"), "play {i}: {}", &answer[..answer.len().min(300)]);
    }
    server.stop().await;
}
