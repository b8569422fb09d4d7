//! Issue 35, "readable numbers", through the web API: a corpus of
//! extreme numbers (1e-300, 5e-324, 1e300, values whose exact text needs
//! 16-17 digits) in the bodies of the routes that take numbers, and every
//! text of every answer scanned: the error message of a 4xx, and every
//! string of a 2xx JSON answer (warnings, summaries, sources). A number
//! in a string is for a person and follows `haptex_core::num::Num`; the
//! answer's data are JSON numbers, in full precision, and not scanned.
//! (`common::Answer::error` and `common::check_json_error` scan every
//! error message the other server tests examine.)

mod common;

use axum::body::Body;
use axum::http::{Request, header};
use haptex_server::app;
use serde_json::{Value, json};

use common::{send_to, shipped_state};

const EXTREMES: &[f64] = &[1e-300, 5e-324, 1e300, -1e300, 0.7000000000000001, 8.725000000000001, 1.0000000000000002];

/// Every string in a JSON value, with its path.
fn strings<'a>(value: &'a Value, path: String, out: &mut Vec<(String, &'a str)>) {
    match value {
        Value::String(s) => out.push((path, s)),
        Value::Array(items) => items.iter().enumerate().for_each(|(i, v)| strings(v, format!("{path}[{i}]"), out)),
        Value::Object(map) => map.iter().for_each(|(k, v)| strings(v, format!("{path}.{k}"), out)),
        _ => {}
    }
}

#[tokio::test]
async fn numbers_in_answers_are_readable_whatever_the_request() {
    let router = app(shipped_state());
    let mut bodies: Vec<(&str, Value)> = Vec::new();
    for &v in EXTREMES {
        let profile = |x: f64, mu: f64| json!({ "x_mm": [0.0, x.abs().max(5e-324), 2.0e6_f64.min(x.abs() + 1.0)], "mu": [1.1, mu, 1.2] });
        bodies.push(("/api/voltage", json!({ "profile": profile(v, 1.3) })));
        bodies.push(("/api/voltage", json!({ "profile": profile(1.0, v) })));
        bodies.push(("/api/profile", profile(v, 1.3)));
        for field in ["u_max_v", "mu_hd", "eps_sc", "d_sc_mm", "k_mm2_per_n", "fn_n"] {
            bodies.push(("/api/voltage", json!({ "profile": profile(1.0, 1.3), "device": { field: v } })));
        }
        bodies.push(("/api/voltage", json!({ "profile": profile(1.0, 1.3), "relative": true, "flat_mu": v })));
        for field in ["x0_mm", "width_mm", "height_mm", "velocity_mm_s"] {
            let mut body =
                json!({ "surface": "bump", "x0_mm": 5, "width_mm": 1.3, "height_mm": 0.27, "velocity_mm_s": 20 });
            body[field] = json!(v);
            bodies.push(("/api/predict", body));
        }
        let voltage = json!({ "x_mm": [0.0, 1.0], "voltage_v": [50.0, 8.725000000000001] });
        bodies.push(("/api/play", json!({ "voltage": voltage, "stroke": { "velocity_mm_s": v } })));
        bodies.push((
            "/api/play",
            json!({ "voltage": voltage, "trajectory": { "t_s": [0.0, v.abs().max(5e-324)], "x_mm": [0.0, 1.0] } }),
        ));
        for field in ["carrier_hz", "u_max_v", "volts_per_full_scale", "slew_v_per_s"] {
            let mut body = json!({ "voltage": voltage, "stroke": { "velocity_mm_s": 50 } });
            body[field] = json!(v);
            bodies.push(("/api/play", body));
        }
    }
    let mut answered = 0;
    for (route, body) in bodies {
        let request =
            Request::post(route).header(header::CONTENT_TYPE, "application/json").body(Body::from(body.to_string()));
        let answer = send_to(router.clone(), request.unwrap()).await;
        if !answer.content_type().starts_with("application/json") {
            continue; // a WAV or CSV answer: data
        }
        let json = answer.json();
        let mut texts = Vec::new();
        strings(&json, String::new(), &mut texts);
        for (path, text) in texts {
            if let Some(number) = haptex_core::num::unreadable_number(text) {
                panic!("{route} {body}: {} answered an unreadable number ({number}) at {path}: {text}", answer.status);
            }
        }
        answered += 1;
    }
    assert!(answered > 100, "{answered} JSON answers");
}
