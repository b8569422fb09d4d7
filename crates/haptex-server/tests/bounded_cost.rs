//! Issue 35, "Bounded cost per request", the server's part: heavy work (FE
//! runs, renders, maps) takes bounded slots with admission control, and
//! every request has a memory budget checked on its parameters before the
//! work starts. (How `/api/health` fares under load, and the server's
//! memory after it, are measured by `scripts/load_health.py`, not timed
//! here: RELIABILITY.md.)

mod common;

use std::time::Duration;

use axum::body::Body;
use axum::http::{Request, StatusCode, header};
use haptex_server::{AppState, Limits, app};
use serde_json::{Value, json};
use tower::ServiceExt;

use common::{base64, header_only_png, next_line, send_to};

fn post(route: &str, body: &Value) -> Request<Body> {
    let mut request = Request::post(route)
        .header(header::CONTENT_TYPE, "application/json")
        .body(Body::from(body.to_string()))
        .unwrap();
    request.headers_mut().insert(header::HOST, "localhost".parse().unwrap());
    request
}

/// A small map request: a 16 x 16 grayscale image.
fn map_body() -> Value {
    let mut png = Vec::new();
    let mut encoder = png::Encoder::new(&mut png, 16, 16);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.write_header().unwrap().write_image_data(&[128; 256]).unwrap();
    json!({ "image_png_base64": base64(&png), "mu_black": 0.4, "mu_white": 1.2, "pixel_mm": 0.1 })
}

/// Class: heavy requests without bound (before: an FE check, two renders,
/// two large bodies and any number of maps and smaller bodies at once,
/// each holding a core and its memory; under 12 heavy clients the server's
/// health checks waited up to 262 ms). Now every kind of heavy work takes
/// one of `concurrent_heavy` slots; with the slots busy, at most
/// `max_queued_heavy` requests wait and the next is answered 503 at once,
/// before any work; `/api/health` answers meanwhile; the waiting request
/// runs once the slot is free.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn heavy_work_takes_bounded_slots_and_beyond_its_queue_is_refused_at_once() {
    let limits = Limits {
        concurrent_heavy: 1,
        max_queued_heavy: 1,
        heavy_wait: Duration::from_secs(60),
        simulation_wait: Duration::from_secs(60),
        ..Limits::DEFAULT
    };
    let state = AppState::new(None, limits).unwrap();
    let router = app(state.clone());
    // A check holds the one heavy slot while its FE run goes on.
    let x: Vec<f64> = (0..=50).map(|i| 0.1 * f64::from(i)).collect();
    let check = json!({ "profile": { "x_mm": x, "mu": vec![0.6; x.len()] }, "device": { "mu_hd": 0.5 } });
    let response = router.clone().oneshot(post("/api/check", &check)).await.unwrap();
    assert_eq!(response.status(), StatusCode::OK);
    let mut stream = response.into_body();
    let mut pending = Vec::new();
    let first = next_line(&mut stream, &mut pending).await.unwrap();
    assert!(first.get("progress").is_some(), "{first}");
    // One map waits for the slot (the queue holds one) ...
    let waiting = tokio::spawn(send_to(router.clone(), post("/api/map", &map_body())));
    while state.heavy_waiting() == 0 {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    // ... the next is refused at once, naming why; health answers.
    let refused = send_to(router.clone(), post("/api/map", &map_body())).await;
    let error = refused.error(StatusCode::SERVICE_UNAVAILABLE, None);
    assert!(error["error"].as_str().unwrap().contains("busy"), "{error}");
    let play = json!({ "voltage": { "x_mm": [0, 10], "voltage_v": [0, 100] }, "stroke": { "velocity_mm_s": 50 } });
    send_to(router.clone(), post("/api/play", &play)).await.error(StatusCode::SERVICE_UNAVAILABLE, None);
    send_to(router.clone(), Request::get("/api/health").body(Body::empty()).unwrap()).await.ok();
    assert!(!waiting.is_finished(), "the queued map ran while the check held the only heavy slot");
    // The check ends; the queued map gets the slot.
    let mut last = first;
    while let Some(line) = next_line(&mut stream, &mut pending).await {
        last = line;
    }
    assert!(last.get("result").is_some(), "{last:.300}");
    waiting.await.unwrap().ok();
    send_to(router, post("/api/play", &play)).await.ok();
}

/// Class: the memory of a request far beyond what its size suggests (a
/// 130 KB PNG of 8192 x 8192 pixels took 1.06 GB; a play's vectors grow
/// with its duration, rate and channels). Each request's working memory
/// is estimated from its parameters and refused beyond
/// `max_request_memory_bytes` (413 naming the field) before anything is
/// allocated. The server's sample and pixel limits are lifted here, so
/// that only the budget stands between a body of under 200 bytes and its
/// cost: a JSON play of 10^7 samples (before: rendered and serialized,
/// gigabytes), a stroke of 10^9 s and an image header claiming 8000 x
/// 8000 pixels (before: left to the core's own caps, which refused them
/// later, as 400s).
#[tokio::test]
async fn requests_over_their_memory_budget_are_refused_before_allocating() {
    let limits = Limits {
        max_wav_samples: usize::MAX,
        max_json_samples: usize::MAX,
        max_map_pixels: usize::MAX,
        ..Limits::DEFAULT
    };
    let router = app(AppState::new(None, limits).unwrap());
    let voltage = json!({ "x_mm": [0, 1000], "voltage_v": [0, 100] });
    for (body, field) in [
        (
            json!({ "voltage": voltage, "trajectory": { "t_s": [0, 208.4], "x_mm": [0, 1000] }, "format": "json" }),
            "trajectory",
        ),
        (json!({ "voltage": voltage, "stroke": { "velocity_mm_s": 1e-6 } }), "stroke"),
        (json!({ "voltage": voltage, "stroke": { "velocity_mm_s": 1e-6 }, "format": "json" }), "stroke"),
        (json!({ "voltage": voltage, "trajectory": { "t_s": [0, 1e6], "x_mm": [0, 1000] } }), "trajectory"),
    ] {
        assert!(body.to_string().len() < 200);
        let answer = send_to(router.clone(), post("/api/play", &body)).await;
        let error = answer.error(StatusCode::PAYLOAD_TOO_LARGE, Some(field));
        assert!(error["error"].as_str().unwrap().contains("MiB a request may take"), "{error}");
    }
    let mut map = map_body();
    map["image_png_base64"] = json!(base64(&header_only_png(8000, 8000)));
    for route in ["/api/map", "/api/map/path"] {
        let mut body = map.clone();
        if route == "/api/map/path" {
            body["path"] = json!({ "t_s": [0, 1], "x_mm": [0, 1], "y_mm": [0, 1] });
        }
        let answer = send_to(router.clone(), post(route, &body)).await;
        let error = answer.error(StatusCode::PAYLOAD_TOO_LARGE, Some("image_png_base64"));
        assert!(error["error"].as_str().unwrap().contains("MiB a request may take"), "{error}");
    }
    // Within the budget, the same routes answer.
    let small = json!({ "voltage": { "x_mm": [0, 10], "voltage_v": [0, 100] }, "stroke": { "velocity_mm_s": 50 } });
    send_to(router.clone(), post("/api/play", &small)).await.ok();
    send_to(router, post("/api/map", &map_body())).await.ok();
}
