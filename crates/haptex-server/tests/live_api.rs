//! The page's live output (`haptex serve --live`): `GET /api/live` and the
//! WebSocket conversation of `haptex_server::live`, on the real server
//! (hyper with upgrades) with a paced test output (the core's LiveEngine
//! called every 5 ms, as a device's callback would; `common::paced_output`).
//! The same conversation on a real ALSA device is `serve_live_on_the_alsa_file_device`
//! in crates/haptex-cli/tests/live_cli.rs.

mod common;

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use common::paced_output::PacedOutput;
use common::{RawServer, shipped_state};
use futures_util::{SinkExt, StreamExt};
use haptex_server::{AppState, Limits};
use serde_json::{Value, json};
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;

type Socket = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

async fn connect(server: &RawServer, origin: Option<&str>) -> Result<Socket, tokio_tungstenite::tungstenite::Error> {
    let mut request = format!("ws://{}/api/live/ws", server.addr).into_client_request().unwrap();
    if let Some(origin) = origin {
        request.headers_mut().insert("origin", origin.parse().unwrap());
    }
    tokio_tungstenite::connect_async(request).await.map(|(socket, _)| socket)
}

async fn send(socket: &mut Socket, text: &str) {
    socket.send(Message::Text(text.into())).await.unwrap();
}

/// The next JSON message that satisfies `want` (within 5 s), named `what` in the failure.
async fn until(socket: &mut Socket, what: &str, want: impl Fn(&Value) -> bool) -> Value {
    let wait = async {
        loop {
            match socket.next().await {
                Some(Ok(Message::Text(text))) => {
                    let value: Value = serde_json::from_str(&text).unwrap();
                    if want(&value) {
                        return value;
                    }
                }
                Some(Ok(_)) => {}
                other => panic!("the socket ended waiting for {what}: {other:?}"),
            }
        }
    };
    tokio::time::timeout(Duration::from_secs(5), wait).await.unwrap_or_else(|_| panic!("no {what} within 5 s"))
}

fn near(v: &Value, key: &str, want: f64) -> bool {
    v[key].as_f64().is_some_and(|x| (x - want).abs() < 1e-9)
}

fn status(v: &Value) -> Option<&Value> {
    v.get("status")
}

/// The limits of these tests: the default ones with at most 1000 points
/// (so that a design with more fits in a message).
const LIMITS: Limits = Limits { max_points: 1000, ..Limits::DEFAULT };

/// A ramp 0..100 V over 0..10 mm: U(x) = 10 x.
fn ramp() -> Value {
    json!({ "design": { "x_mm": [0.0, 10.0], "voltage_v": [0.0, 100.0] } })
}

fn live_state(output: &Arc<PacedOutput>) -> AppState {
    let state = AppState::new(None, LIMITS).unwrap();
    state.with_live_output(Arc::clone(output) as Arc<dyn haptex_server::live::LiveOutput>)
}

/// Without a live output: `available: false`, and the socket is a 404.
#[tokio::test]
async fn without_a_live_output_the_page_is_told_so() {
    let server = RawServer::start(shipped_state().clone()).await;
    let answer = server.get("/api/live").await;
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    assert!(answer.ends_with(r#"{"available":false,"output":null}"#), "{answer}");
    let refused = connect(&server, None).await.unwrap_err();
    assert!(refused.to_string().contains("404"), "{refused}");
    server.stop().await;
}

/// The page's conversation: the output's limits; a design opened; touches
/// followed (x = 2 mm -> 20 V, 7.5 mm -> 75 V to 1e-9 V, the gain at 1
/// after the ramp); a bad line refused (naming the field) and the finger
/// lifted (0 V); a stop closes the output; the captured frames never
/// above the U_max peak; a closed socket closes what plays.
#[tokio::test]
async fn touches_over_the_websocket_drive_the_output() {
    let output = Arc::new(PacedOutput::new(None));
    let server = RawServer::start(live_state(&output)).await;
    let answer = server.get("/api/live").await;
    let body: Value = serde_json::from_str(answer.split("\r\n\r\n").nth(1).unwrap()).unwrap();
    assert_eq!(body["available"], true);
    assert_eq!(body["output"]["sample_rate_hz"], 48_000);
    assert_eq!(body["output"]["u_max_v"], 100.0);
    assert_eq!(body["output"]["a_max_um"], Value::Null);

    let mut socket = connect(&server, Some(&format!("http://{}", server.addr))).await.unwrap();
    // Touches before a design are refused.
    send(&mut socket, "2.0").await;
    let refused = until(&mut socket, "a refusal", |v| v.get("error").is_some()).await;
    assert!(refused["error"].as_str().unwrap().contains("nothing is playing"), "{refused}");

    send(&mut socket, &ramp().to_string()).await;
    let opened = until(&mut socket, "opened", |v| v.get("opened").is_some()).await;
    assert_eq!(opened["opened"]["output"]["device"], "paced test output");
    assert!((opened["opened"]["peak_bound_v"].as_f64().unwrap() - 100.0 * 2f64.sqrt()).abs() < 1e-9, "{opened}");

    let first_touch = std::time::Instant::now();
    send(&mut socket, "2.0").await;
    until(&mut socket, "x = 2 mm, U = 20 V played", |v| {
        status(v).is_some_and(|s| near(s, "x_mm", 2.0) && near(s, "output_v", 20.0) && near(s, "gain", 1.0))
    })
    .await;
    // Several lines in one message, on the page's clock.
    send(&mut socket, "10.000,5.0\n10.004,7.5").await;
    let f = until(&mut socket, "x = 7.5 mm, U = 75 V", |v| {
        status(v).is_some_and(|s| near(s, "x_mm", 7.5) && near(s, "envelope_v", 75.0))
    })
    .await;
    let s = &f["status"];
    assert!(s["events"].as_u64().unwrap() >= 3, "{f}");
    // The queue wait is measured: positive, and no longer than the time
    // since the first touch was sent (a bound that holds on a loaded
    // machine; how short it is, is a benchmark's business). The paced
    // output's buffer latency is one callback.
    let waited_ms = first_touch.elapsed().as_secs_f64() * 1e3;
    let queue_wait_ms = s["queue_wait_max_ms"].as_f64().unwrap();
    assert!(queue_wait_ms > 0.0 && queue_wait_ms <= waited_ms, "{queue_wait_ms} ms of {waited_ms} ms: {f}");
    assert!(near(s, "output_latency_max_ms", 5.0), "{f}");

    send(&mut socket, "11.0,abc").await;
    let refused = until(&mut socket, "a refusal", |v| v.get("error").is_some()).await;
    assert_eq!(refused["field"], "message");
    assert!(
        refused["error"].as_str().unwrap().contains("field 'x_mm': expected a finite number, got 'abc'"),
        "{refused}"
    );
    until(&mut socket, "the finger lifted: 0 V played", |v| status(v).is_some_and(|s| near(s, "output_v", 0.0))).await;

    send(&mut socket, r#"{"stop": true}"#).await;
    let closed = until(&mut socket, "closed", |v| v.get("closed").is_some()).await;
    assert_eq!(closed["closed"]["finished"], true, "{closed}");
    assert_eq!(output.closed.load(Ordering::SeqCst), 1);
    let peak = output.captured.lock().unwrap().iter().fold(0.0f32, |m, v| m.max(v.abs()));
    assert!(
        peak > 0.5 && f64::from(peak) <= 75.0 / 100.0 + 1e-6,
        "peak {peak} of full scale (75 V of sqrt(2) 100 V peak)"
    );
    assert_eq!(*output.captured.lock().unwrap().last().unwrap(), 0.0);

    // Open again, then go away: the output closes with the socket.
    send(&mut socket, &ramp().to_string()).await;
    until(&mut socket, "opened", |v| v.get("opened").is_some()).await;
    drop(socket);
    let closed = async {
        while output.closed.load(Ordering::SeqCst) < 2 {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    };
    tokio::time::timeout(Duration::from_secs(5), closed).await.expect("the output closed with the socket");
    assert_eq!(output.opened.load(Ordering::SeqCst), 2);
    server.stop().await;
}

/// One page at a time (409 for the second until the first leaves); a page
/// of another site is refused (403) before the upgrade; an upgrade-less
/// GET is a JSON 400.
#[tokio::test]
async fn one_page_at_a_time_and_only_this_sites() {
    let output = Arc::new(PacedOutput::new(None));
    let server = RawServer::start(live_state(&output)).await;
    let first = connect(&server, None).await.unwrap();
    let second = connect(&server, None).await.unwrap_err();
    assert!(second.to_string().contains("409"), "{second}");
    drop(first);
    let mut again = None;
    for _ in 0..100 {
        if let Ok(socket) = connect(&server, None).await {
            again = Some(socket);
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert!(again.is_some(), "the output was not released when the first page left");
    drop(again);
    tokio::time::sleep(Duration::from_millis(100)).await;

    let foreign = connect(&server, Some("http://evil.example")).await.unwrap_err();
    assert!(foreign.to_string().contains("403"), "{foreign}");
    let answer = server
        .raw(
            b"GET /api/live/ws HTTP/1.1\r\nHost: localhost\r\nOrigin: http://evil.example\r\nConnection: Upgrade\r\n\
              Upgrade: websocket\r\nSec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n",
        )
        .await;
    common::assert_json_error(&answer, 403, Some("origin"));
    let answer = server.get("/api/live/ws").await;
    common::assert_json_error(&answer, 400, Some("upgrade"));
    server.stop().await;
}

/// Designs the output cannot play are refused naming the field, and
/// nothing opens: above U_max, an amplitude without an ultrasonic channel,
/// positions not increasing, unknown fields, lengths that differ, too many
/// points, no channel at all, a bad control message. A combined design
/// plays on an output with a_max, its amplitude bounded by it.
#[tokio::test]
async fn designs_are_checked_against_the_outputs_limits() {
    let output = Arc::new(PacedOutput::new(None));
    let server = RawServer::start(live_state(&output)).await;
    let mut socket = connect(&server, None).await.unwrap();
    let too_many: Vec<f64> = (0..=LIMITS.max_points).map(|i| i as f64).collect();
    let cases = [
        (json!({"design": {"x_mm": [0, 1], "voltage_v": [0, 120]}}), "design.voltage_v", "U_max = 100 V"),
        (
            json!({"design": {"x_mm": [0, 1], "voltage_v": [0, 50], "amplitude_um": [0, 1]}}),
            "design.amplitude_um",
            "no ultrasonic channel",
        ),
        (json!({"design": {"x_mm": [0, 0], "voltage_v": [0, 50]}}), "design.x_mm", "design.x_mm[1]"),
        (json!({"design": {"x_mm": [0, 1], "voltage_v": [0, -5]}}), "design.voltage_v", "design.voltage_v[1]"),
        (json!({"design": {"x_mm": [0, 1], "voltage": [0, 5]}}), "design.voltage", "unknown field"),
        (json!({"design": {"x_mm": [0, 1, 2], "voltage_v": [0, 5]}}), "design.voltage_v", "2 values but x_mm has 3"),
        (json!({"design": {"x_mm": too_many.clone(), "voltage_v": too_many}}), "design.x_mm", "more than the"),
        (json!({"design": {"x_mm": [0, 1]}}), "design.voltage_v", "needs voltage_v, amplitude_um or both"),
        (json!({"design": {"x_mm": [0, 1], "voltage_v": [0, 1]}, "stop": true}), "message", "a control message is"),
        (json!({"start": true}), "message", "unknown field"),
    ];
    for (message, field, says) in cases {
        send(&mut socket, &message.to_string()).await;
        let refused = until(&mut socket, field, |v| v.get("error").is_some()).await;
        assert_eq!(refused["field"], field, "{refused}");
        assert!(refused["error"].as_str().unwrap().contains(says), "{says}: {refused}");
    }
    send(&mut socket, "{not json").await;
    let refused = until(&mut socket, "bad JSON", |v| v.get("error").is_some()).await;
    assert_eq!(refused["field"], "message");
    assert_eq!(output.opened.load(Ordering::SeqCst), 0);
    // A message over the size limit (the body limit, 1 MiB) closes the
    // socket with code 1009 (too big).
    send(&mut socket, &format!("{{\"design\": {{\"x_mm\": [{}]}}}}", "1,".repeat(600_000))).await;
    let ended = tokio::time::timeout(Duration::from_secs(5), async {
        loop {
            match socket.next().await {
                Some(Ok(Message::Close(frame))) => return frame,
                Some(Ok(_)) => {}
                other => panic!("no close frame: {other:?}"),
            }
        }
    })
    .await
    .unwrap();
    assert_eq!(ended.map(|f| u16::from(f.code)), Some(1009));
    server.stop().await;

    let output = Arc::new(PacedOutput::new(Some(2.0)));
    let server = RawServer::start(live_state(&output)).await;
    let mut socket = connect(&server, None).await.unwrap();
    let design = json!({"design": {"x_mm": [0, 10], "voltage_v": [50, 50], "amplitude_um": [0, 3]}});
    send(&mut socket, &design.to_string()).await;
    let refused = until(&mut socket, "a_max refusal", |v| v.get("error").is_some()).await;
    assert!(refused["error"].as_str().unwrap().contains("a_max = 2 um"), "{refused}");
    // An ultrasonic-only design: channel 1 at 0 V, channel 2 = a / a_max.
    let design = json!({"design": {"x_mm": [0, 10], "amplitude_um": [0, 2]}});
    send(&mut socket, &design.to_string()).await;
    until(&mut socket, "opened", |v| v.get("opened").is_some()).await;
    send(&mut socket, "5.0").await;
    let f = until(&mut socket, "a = 1 um", |v| {
        status(v).is_some_and(|s| near(s, "amplitude_um", 1.0) && near(s, "output_v", 0.0))
    })
    .await;
    assert!(near(&f["status"], "x_mm", 5.0), "{f}");
    send(&mut socket, r#"{"stop": true}"#).await;
    until(&mut socket, "closed", |v| v.get("closed").is_some()).await;
    let captured = output.captured.lock().unwrap().clone();
    assert!(captured.chunks(2).all(|f| f[0] == 0.0 && (0.0..=1.0).contains(&f[1])));
    assert!(captured.chunks(2).any(|f| (f[1] - 0.5).abs() < 1e-6), "channel 2 reached a / a_max = 0.5");
    server.stop().await;
}
