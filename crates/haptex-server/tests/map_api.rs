//! `POST /api/map` and `POST /api/map/path` (issue 19): an uploaded
//! grayscale image gives the core's friction and voltage maps, value for
//! value (what `haptex map from-image` and `haptex map voltage` compute),
//! and a path over it the core's samples (`haptex map sample-path`); every
//! bad input is a 4xx JSON error naming its field.

use axum::Router;
use axum::body::Body;
use axum::http::{Request, StatusCode, header};
use haptex_core::electrovibration::{Device, Method};
use haptex_core::map::{FrictionMap, GrayMapping, MapGrid};
use haptex_core::planar::PlanarTrajectory;
use haptex_server::{AppState, Limits, app};
use serde_json::{Value, json};

mod common;

use common::{Answer, base64, header_only_png, send_to};

fn server() -> Router {
    app(AppState::new(None, Limits::DEFAULT).unwrap())
}

async fn post(uri: &str, body: &Value) -> Answer {
    send_to(
        server(),
        Request::post(uri).header(header::CONTENT_TYPE, "application/json").body(Body::from(body.to_string())).unwrap(),
    )
    .await
}

fn numbers(value: &Value) -> Vec<f64> {
    value.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect()
}

/// A grayscale PNG of `width` x `height` whose gray levels vary over the
/// image (a ramp along x plus a bump), 8 or 16 bit.
fn image(width: usize, height: usize, bits: u8) -> Vec<u8> {
    let grid = MapGrid { nx: width, ny: height, x0_mm: 0.0, y0_mm: 0.0, dx_mm: 1.0, dy_mm: 1.0 };
    let mu = (0..height)
        .flat_map(|j| {
            (0..width).map(move |i| {
                let (x, y) = (i as f64 / (width - 1) as f64, j as f64 / (height - 1) as f64);
                (0.6 * x + 0.4 * (-((x - 0.4).powi(2) + (y - 0.6).powi(2)) * 12.0).exp()).min(1.0)
            })
        })
        .collect();
    let map = FrictionMap { grid, mu };
    let mut bytes = Vec::new();
    map.write_gray_png(&mut bytes, &GrayMapping { mu_black: 0.0, mu_white: 1.0, gamma: 1.0 }, bits).unwrap();
    bytes
}

fn body(png: &[u8]) -> Value {
    json!({
        "image_png_base64": base64(png),
        "mu_black": 0.4, "mu_white": 1.6, "gamma": 1.5,
        "pixel_mm": 0.25, "pixel_mm_y": 0.5, "x0_mm": 1.0, "y0_mm": -2.0,
        "device": { "u_max_v": 80.0 },
    })
}

/// The core's maps of `png` with the mapping of [`body`] and the device.
fn core_maps(png: &[u8], method: Method) -> (FrictionMap, haptex_core::map::VoltageMap) {
    let mapping = GrayMapping { mu_black: 0.4, mu_white: 1.6, gamma: 1.5 };
    let map = FrictionMap::read_gray_png(png, &mapping, (0.25, 0.5), (1.0, -2.0), "test").unwrap();
    let device = Device { u_max_v: 80.0, ..Device::PAPER };
    let v = map.voltages(&device, method).unwrap();
    (map, v)
}

#[tokio::test]
async fn an_image_gives_the_cores_friction_and_voltage_maps() {
    for bits in [8, 16] {
        let png = image(23, 17, bits);
        let (map, v) = core_maps(&png, Method::Physical);
        let answer = post("/api/map", &body(&png)).await;
        let a = answer.ok().json();
        assert_eq!(a["bits"], bits);
        assert_eq!(a["grid"], serde_json::to_value(map.grid).unwrap());
        assert_eq!(numbers(&a["mu"]), map.mu, "{bits} bit: friction");
        assert_eq!(numbers(&a["voltage_v"]), v.voltage_v, "{bits} bit: voltage");
        assert_eq!(a["not_renderable_fraction"].as_f64(), Some(v.not_renderable_fraction));
        assert_eq!(a["clipped_fraction"].as_f64(), Some(v.clipped_fraction));
        assert_eq!(a["parameters"]["u_max_v"], 80.0);
        assert_eq!(a["method"], "physical");
        // Not a constant map: the test would pass on one too easily.
        assert!(v.voltage_v.iter().any(|&u| u > 1.0) && v.voltage_v.contains(&0.0), "{:?}", v.voltage_v);
    }
    // Eq. (9) on request.
    let png = image(9, 8, 8);
    let mut request = body(&png);
    request["method"] = json!("normalized");
    let a = post("/api/map", &request).await.ok().json();
    assert_eq!(numbers(&a["voltage_v"]), core_maps(&png, Method::Normalized).1.voltage_v);
    assert_eq!(a["method"], "normalized");
}

#[tokio::test]
async fn a_path_is_sampled_as_haptex_map_sample_path_samples_it() {
    let png = image(31, 21, 8);
    let (_, v) = core_maps(&png, Method::Physical);
    // Across the map, beyond its left and top edges, and along a row.
    let t: Vec<f64> = (0..40).map(|k| 0.01 * k as f64).collect();
    let x: Vec<f64> = (0..40).map(|k| 0.7 + 0.21 * k as f64).collect();
    let y: Vec<f64> = (0..40).map(|k| if k < 30 { -2.3 + 0.4 * k as f64 } else { 3.0 }).collect();
    let path = PlanarTrajectory::new(t.clone(), x.clone(), y.clone()).unwrap();
    let expected = path.sample(&v.grid, &v.voltage_v);
    let mut request = body(&png);
    request["path"] = json!({ "t_s": t, "x_mm": x, "y_mm": y });
    let a = post("/api/map/path", &request).await.ok().json();
    assert_eq!(numbers(&a["voltage_v"]), expected);
    assert_eq!(numbers(&a["t_s"]), t);
    assert!(a["outside"].as_u64().unwrap() > 0, "the path leaves the map: {}", a["outside"]);
    assert!(expected.iter().any(|&u| u > 1.0));
    // The CSV is the command's: its header and rows.
    let csv = post("/api/map/path?format=csv", &request).await;
    csv.ok();
    assert!(csv.content_type().starts_with("text/csv"));
    let mut rows = Vec::new();
    path.write_csv_with(&mut rows, "voltage_v", &expected).unwrap();
    let text = csv.text();
    assert!(text.starts_with("# haptex map sample-path"), "{text:.200}");
    assert!(text.ends_with(&String::from_utf8(rows).unwrap()), "{text:.300}");
}

#[tokio::test]
async fn bad_images_mappings_and_devices_are_refused_naming_the_field() {
    let png = image(6, 5, 8);
    let bad = StatusCode::BAD_REQUEST;
    let with = |path: &str, value: Value| {
        let mut b = body(&png);
        let (head, tail) = path.split_once('.').map_or((path, None), |(h, t)| (h, Some(t)));
        match tail {
            Some(t) => b[head][t] = value,
            None => b[head] = value,
        }
        b
    };
    let rgb = {
        let mut bytes = Vec::new();
        let mut encoder = png::Encoder::new(&mut bytes, 4, 4);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.write_header().unwrap().write_image_data(&[100; 48]).unwrap();
        bytes
    };
    let narrow = {
        let mut bytes = Vec::new();
        let mut encoder = png::Encoder::new(&mut bytes, 1, 5);
        encoder.set_color(png::ColorType::Grayscale);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.write_header().unwrap().write_image_data(&[100; 5]).unwrap();
        bytes
    };
    let cases: Vec<(&str, Value, StatusCode, &str)> = vec![
        ("not base64", with("image_png_base64", json!("iVBOR*w0K")), bad, "image_png_base64"),
        ("not a PNG", with("image_png_base64", json!(base64(b"GIF89a this is no PNG"))), bad, "image_png_base64"),
        ("a truncated PNG", with("image_png_base64", json!(base64(&png[..png.len() / 2]))), bad, "image_png_base64"),
        ("a colour PNG", with("image_png_base64", json!(base64(&rgb))), bad, "image_png_base64"),
        ("1 x 5 pixels", with("image_png_base64", json!(base64(&narrow))), bad, "image_png_base64"),
        ("mu_black == mu_white", with("mu_white", json!(0.4)), bad, "mu_white"),
        ("mu_black out of range", with("mu_black", json!(1e9)), bad, "mu_black"),
        ("mu_black a string", with("mu_black", json!("0.4")), bad, "mu_black"),
        ("gamma 0", with("gamma", json!(0.0)), bad, "gamma"),
        ("pixel_mm negative", with("pixel_mm", json!(-0.1)), bad, "pixel_mm"),
        ("pixel_mm_y zero", with("pixel_mm_y", json!(0.0)), bad, "pixel_mm_y"),
        ("x0 out of range", with("x0_mm", json!(-5e6)), bad, "x0_mm"),
        ("unknown method", with("method", json!("loud")), bad, "method"),
        ("u_max_v 0", with("device.u_max_v", json!(0.0)), bad, "device.u_max_v"),
        ("an unknown device parameter", with("device.volume", json!(1.0)), bad, "device.volume"),
        ("a non-linear contact law", with("device.area_exponent", json!(1.5)), bad, "device.area_exponent"),
        ("an unknown field", with("colour", json!(true)), bad, "colour"),
        ("a path here", with("path", json!({ "t_s": [0, 1], "x_mm": [0, 1], "y_mm": [0, 1] })), bad, "path"),
        (
            "600 x 600 pixels",
            with("image_png_base64", json!(base64(&image(600, 600, 8)))),
            StatusCode::PAYLOAD_TOO_LARGE,
            "image_png_base64",
        ),
        (
            "a header claiming 8000 x 8000",
            with("image_png_base64", json!(base64(&header_only_png(8000, 8000)))),
            StatusCode::PAYLOAD_TOO_LARGE,
            "image_png_base64",
        ),
    ];
    for (what, request, status, field) in cases {
        let answer = post("/api/map", &request).await;
        let error = answer.error(status, Some(field));
        eprintln!("{what}: {}", error["error"]);
    }
    // The missing image and a body past the limit.
    let mut missing = body(&png);
    missing.as_object_mut().unwrap().remove("image_png_base64");
    post("/api/map", &missing).await.error(bad, Some("body"));
    let huge = with("image_png_base64", json!("A".repeat(2 << 20)));
    post("/api/map", &huge).await.error(StatusCode::PAYLOAD_TOO_LARGE, Some("body"));
    // A header within the pixel limit but the data missing: the decoder's error.
    let answer = post("/api/map", &with("image_png_base64", json!(base64(&header_only_png(20, 20))))).await;
    answer.error(bad, Some("image_png_base64"));
}

#[tokio::test]
async fn bad_paths_are_refused_naming_the_sample() {
    let png = image(6, 5, 8);
    let request = |path: Value| {
        let mut b = body(&png);
        b["path"] = path;
        b
    };
    let bad = StatusCode::BAD_REQUEST;
    let n = Limits::DEFAULT.max_points + 1;
    let cases: Vec<(&str, Value, StatusCode, &str)> = vec![
        ("t not increasing", json!({ "t_s": [0, 0.1, 0.1], "x_mm": [1, 2, 3], "y_mm": [0, 0, 0] }), bad, "path.t_s[2]"),
        ("t decreasing", json!({ "t_s": [0, 0.2, 0.1], "x_mm": [1, 2, 3], "y_mm": [0, 0, 0] }), bad, "path.t_s[2]"),
        ("x not a number", json!({ "t_s": [0, 0.1], "x_mm": [1, null], "y_mm": [0, 0] }), bad, "path.x_mm[1]"),
        ("y infinite (1e999)", json!({ "t_s": [0, 0.1], "x_mm": [1, 2], "y_mm": [0, 0] }), bad, "path.y_mm[1]"),
        ("y out of range", json!({ "t_s": [0, 0.1], "x_mm": [1, 2], "y_mm": [0, 5e6] }), bad, "path.y_mm[1]"),
        ("y too short", json!({ "t_s": [0, 0.1, 0.2], "x_mm": [1, 2, 3], "y_mm": [0, 0] }), bad, "path.y_mm[0]"),
        ("one sample", json!({ "t_s": [0], "x_mm": [1], "y_mm": [0] }), bad, "path.t_s[0]"),
        ("y missing", json!({ "t_s": [0, 0.1], "x_mm": [1, 2] }), bad, "path"),
        (
            "too many samples",
            // The count is checked first: one x and y are enough (and keep the body within its limit).
            json!({ "t_s": vec![0; n], "x_mm": [1], "y_mm": [0] }),
            StatusCode::PAYLOAD_TOO_LARGE,
            "path.t_s",
        ),
    ];
    for (what, path, status, field) in cases {
        let body = request(path);
        if what.starts_with("y infinite") {
            // Not expressible in serde_json's Value: patched into the text.
            let text = body.to_string().replacen("\"y_mm\":[0,0]", "\"y_mm\":[0,1e999]", 1);
            let answer = send_to(
                server(),
                Request::post("/api/map/path")
                    .header(header::CONTENT_TYPE, "application/json")
                    .body(Body::from(text))
                    .unwrap(),
            )
            .await;
            answer.error(status, Some(field));
            continue;
        }
        let answer = post("/api/map/path", &body).await;
        let error = answer.error(status, Some(field));
        eprintln!("{what}: {}", error["error"]);
    }
    post("/api/map/path", &body(&png)).await.error(bad, Some("path"));
    post("/api/map/path?format=wav", &request(json!({}))).await.error(bad, Some("format"));
}
