//! The "Your display" routes (issue 36): `POST /api/calibrate` (the
//! display's constants from the user's measurements, docs/calibration.md),
//! a device file in `POST /api/voltage`, and `POST /api/compensate/measured`
//! (the next design from measured strokes, docs/measured-compensation.md).
//! Oracles: the core functions `haptex calibrate`, `haptex voltage
//! --device` and `haptex compensate` call, run here directly.

mod common;

use std::path::PathBuf;

use axum::Router;
use axum::body::Body;
use axum::http::{Request, StatusCode, header};
use haptex_core::calibration::device_file::DeviceFile;
use haptex_core::calibration::measurements::Measurements;
use haptex_core::calibration::{Settings, calibrate};
use haptex_core::electrovibration::{Device, Method, map_profile};
use haptex_core::ilc::{Design, DisplayModel};
use haptex_core::io::Table;
use haptex_core::profile::FrictionProfile;
use haptex_core::signal::{Carrier, CarrierShape};
use haptex_server::{AppState, Limits, app};
use serde_json::{Value, json};

use common::{Answer, send_to};

fn example_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/examples/calibration-measurements.csv")
}

fn example() -> String {
    std::fs::read_to_string(example_path()).unwrap()
}

fn bump() -> String {
    std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/examples/bump_friction.csv"))
        .unwrap()
}

/// The application without library or database: these routes need neither.
fn server() -> Router {
    app(AppState::new(None, Limits::DEFAULT).unwrap())
}

async fn post(uri: &str, content_type: &str, body: impl Into<Body>) -> Answer {
    send_to(server(), Request::post(uri).header(header::CONTENT_TYPE, content_type).body(body.into()).unwrap()).await
}

async fn post_json(uri: &str, body: &Value) -> Answer {
    post(uri, "application/json", body.to_string()).await
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

/// The device file `haptex calibrate -o` writes for the shipped example.
fn example_device_file() -> (DeviceFile, String) {
    let m = Measurements::from_bytes(example().as_bytes(), "calibration-measurements.csv").unwrap();
    let file = DeviceFile::from_calibration(&calibrate(&m, Settings::default()), &m, 100.0);
    let text = file.to_toml();
    (DeviceFile::from_toml(&text, "uploaded device file").unwrap(), text)
}

#[tokio::test]
async fn the_shipped_example_fits_with_the_circuit_model_identified() {
    let answer = post("/api/calibrate?name=calibration-measurements.csv", "text/csv", example()).await;
    answer.ok();
    let a = answer.json();
    let circuit = &a["electrovibration"]["circuit"];
    for name in ["mu_hd", "c_per_v2", "rho_sc_ohm_m", "gap_um"] {
        let e = &circuit[name];
        assert_eq!(e["identified"], true, "{name}: {e}");
        let (v, lo, hi) = (e["value"].as_f64().unwrap(), e["low"].as_f64().unwrap(), e["high"].as_f64().unwrap());
        assert!(lo <= v && v <= hi, "{name}: {e}");
    }
    // The truth of the virtual device that made it (its header): mu_HD 0.6, rho_sc 1e5 ohm m.
    assert!((circuit["mu_hd"]["value"].as_f64().unwrap() - 0.6).abs() < 0.05, "{circuit}");
    assert_eq!(a["device_model"], "circuit");
    assert_eq!(a["identified"], true);
    assert_eq!(a["measurements"]["rows"], 552);
    assert!(a["intervals_rest_on"].as_str().unwrap().contains("finger"), "{}", a["intervals_rest_on"]);
    // The device file is the one `haptex calibrate` writes (but for its date).
    let text = a["device_file"].as_str().unwrap();
    let served = DeviceFile::from_toml(text, "served").unwrap();
    let (mut expected, _) = example_device_file();
    expected.created.clone_from(&served.created);
    expected.path = "served".into();
    assert_eq!(served, expected);
    // The curves: per carrier the data, the model with its band, the residuals.
    let curves = &a["electrovibration"]["curves"];
    assert_eq!(curves["model"], "circuit");
    let carriers = curves["carriers"].as_array().unwrap();
    assert_eq!(carriers.len(), 7, "six sine carriers and a direct drive");
    for c in carriers {
        let model = &c["model"];
        let (y, lo, hi) = (numbers(&model["rise"]), numbers(&model["low"]), numbers(&model["high"]));
        assert_eq!(y.len(), numbers(&model["u_v"]).len());
        assert!(y.iter().zip(&lo).zip(&hi).all(|((y, l), h)| l <= y && y <= h), "{}", c["name"]);
        assert!(y.last().unwrap() > &0.0 && hi.last().unwrap() > lo.last().unwrap(), "{}", c["name"]);
        assert_eq!(c["data"]["u_v"].as_array().unwrap().len(), c["data"]["line"].as_array().unwrap().len());
        assert!(!c["residuals"]["residual"].as_array().unwrap().is_empty());
    }
    let plate = &a["ultrasonic"]["curves"];
    assert!(plate["exponential"]["rho"].as_array().unwrap().len() > 10, "{plate}");
    assert!(!plate["table"]["rho"].as_array().unwrap().is_empty());
    assert!(a["verdicts"].is_array());
}

#[tokio::test]
async fn the_json_body_takes_the_options_and_a_single_carrier_is_not_identified_as_a_circuit() {
    // One carrier only: the circuit is not identifiable, eq. (3) is, and the verdict says what to measure.
    let text = example();
    let mut lines = text.lines();
    let mut one: Vec<&str> = lines.by_ref().take_while(|l| l.starts_with('#')).collect();
    let header = "voltage_v,carrier,carrier_hz,amplitude_um,mu,velocity_mm_s,finger,repetition";
    one.push(header);
    one.extend(text.lines().filter(|l| l.contains(",sine,1000,") || l.starts_with("0,none,0,0,")));
    let body = json!({ "measurements": one.join("\n"), "name": "one.csv", "u_max_v": 150,
        "stack": { "eps_sc": 1000 }, "ultrasonic_model": "table" });
    let a = post_json("/api/calibrate", &body).await;
    a.ok();
    let a = a.json();
    assert_eq!(a["device_model"], "eq3", "{}", a["verdicts"]);
    assert!(a["electrovibration"]["circuit"].is_null());
    assert!(a["verdicts"].as_array().unwrap().iter().any(|v| v.as_str().unwrap().contains("rho_sc")));
    assert_eq!(a["stack"]["eps_sc"], 1000.0);
    let file = DeviceFile::from_toml(a["device_file"].as_str().unwrap(), "f").unwrap();
    assert_eq!(file.u_max_v, 150.0);
    assert_eq!(file.measurements.file, "one.csv");
    // Options out of range name their field.
    let bad = json!({ "measurements": example(), "u_max_v": -1 });
    post_json("/api/calibrate", &bad).await.error(StatusCode::BAD_REQUEST, Some("u_max_v"));
    let bad = json!({ "measurements": example(), "stack": { "k_mm2_per_n": 1 } });
    post_json("/api/calibrate", &bad).await.error(StatusCode::BAD_REQUEST, Some("stack.k_mm2_per_n"));
    let bad = json!({ "measurements": example(), "ultrasonic_model": "spline" });
    post_json("/api/calibrate", &bad).await.error(StatusCode::BAD_REQUEST, Some("ultrasonic_model"));
}

#[tokio::test]
async fn a_bad_measurements_csv_is_refused_naming_its_line_and_column() {
    // Line 9 of the file (the 4th data row) gets a friction that is not a number.
    let text: Vec<String> = example()
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 8 {
                let mut f: Vec<&str> = l.split(',').collect();
                f[4] = "abc";
                f.join(",")
            } else {
                l.to_string()
            }
        })
        .collect();
    let answer = post("/api/calibrate?name=mine.csv", "text/csv", text.join("\n")).await;
    let e = answer.error(StatusCode::BAD_REQUEST, Some("measurements"));
    assert_eq!(e["line"], 9, "{e}");
    assert_eq!(e["column"], "mu", "{e}");
    let message = e["error"].as_str().unwrap();
    assert!(message.starts_with("mine.csv, line 9, column 'mu'"), "{message}");
    // The same in a JSON body; a voltage and a vibration at once, at its line.
    let mixed = "voltage_v,carrier,carrier_hz,amplitude_um,mu\n0,none,0,0,0.5\n50,sine,1000,1,0.6\n";
    let e = post_json("/api/calibrate", &json!({ "measurements": mixed })).await;
    let e = e.error(StatusCode::BAD_REQUEST, Some("measurements"));
    assert_eq!((e["line"].as_u64(), e["column"].as_str()), (Some(3), Some("amplitude_um")), "{e}");
    // More distinct carriers than eq. (3) fits (each is a parameter): refused at the first one too many.
    let mut many = String::from("voltage_v,carrier,carrier_hz,mu\n0,none,0,0.5\n");
    for k in 0..100 {
        many += &format!("50,sine,{},0.6\n", 100 + k);
    }
    let e = post("/api/calibrate", "text/csv", many).await.error(StatusCode::BAD_REQUEST, Some("measurements"));
    assert_eq!((e["line"].as_u64(), e["column"].as_str()), (Some(35), Some("carrier_hz")), "{e}");
    // Rows at rest only: refused, saying why.
    let rest = "voltage_v,mu\n0,0.5\n0,0.51\n";
    let e = post("/api/calibrate", "text/csv", rest).await.error(StatusCode::BAD_REQUEST, Some("measurements"));
    assert!(e["error"].as_str().unwrap().contains("the friction at rest alone calibrates nothing"), "{e}");
    // Rows that identify nothing (one voltage): an answer with the
    // verdicts, and no device file.
    let none = "voltage_v,carrier,carrier_hz,mu\n50,sine,1000,0.6\n50,sine,1000,0.61\n50,sine,1000,0.6\n";
    let a = post("/api/calibrate", "text/csv", none).await;
    a.ok();
    let a = a.json();
    assert_eq!((a["identified"].as_bool(), a["device_file"].is_null()), (Some(false), true), "{a}");
    assert!(a["verdicts"][0].as_str().unwrap().contains("cannot be separated"), "{a}");
}

#[tokio::test]
async fn a_body_over_the_limit_is_refused() {
    let mut big = String::from("voltage_v,carrier,carrier_hz,mu\n");
    while big.len() <= Limits::DEFAULT.max_body_bytes {
        big += "50,sine,1000,0.6\n";
    }
    post("/api/calibrate", "text/csv", big.clone()).await.error(StatusCode::PAYLOAD_TOO_LARGE, Some("body"));
    let strokes = json!({ "design": big, "strokes": [] });
    post_json("/api/compensate/measured", &strokes).await.error(StatusCode::PAYLOAD_TOO_LARGE, Some("body"));
}

#[tokio::test]
async fn a_device_file_in_a_voltage_request_designs_as_haptex_voltage_device_does() {
    let (file, text) = example_device_file();
    let profile = FrictionProfile::read_csv(bump().as_bytes(), "bump").unwrap();
    let body = |extra: Value| {
        let mut b = json!({ "profile": { "x_mm": profile.x_mm(), "mu": profile.mu() }, "device_file": text });
        for (k, v) in extra.as_object().unwrap() {
            b[k] = v.clone();
        }
        b
    };
    for (carrier, extra) in [
        (Carrier::DEFAULT, json!({})),
        (
            Carrier { shape: CarrierShape::Sine, frequency_hz: 30.0 },
            json!({ "carrier": { "shape": "sine", "frequency_hz": 30 } }),
        ),
    ] {
        let answer = post_json("/api/voltage", &body(extra)).await;
        answer.ok();
        let a = answer.json();
        let device = file.device(&carrier).unwrap();
        let expected = map_profile(&profile, &device, Method::Physical, None).unwrap();
        assert_eq!(numbers(&a["voltage_v"]), expected.voltage_v, "carrier {carrier:?}");
        assert_eq!(a["parameters"]["mu_hd"].as_f64(), Some(device.mu_hd));
        assert_eq!(a["device_file"]["model"], "circuit");
        assert_eq!(a["device_file"]["sha256"].as_str().unwrap(), haptex_core::io::sha256_hex(text.as_bytes()));
    }
    // It changes the design: the paper's constants give another voltage.
    let paper = map_profile(&profile, &Device::PAPER, Method::Physical, None).unwrap();
    let with_file = post_json("/api/voltage", &body(json!({}))).await.json();
    assert_ne!(numbers(&with_file["voltage_v"]), paper.voltage_v);
    // The CSV says which device file designed it.
    let csv = post_json("/api/voltage?format=csv", &body(json!({}))).await;
    csv.ok();
    assert!(csv.text().contains("# designed with device file uploaded device file (circuit model"), "{}", csv.text());
    assert!(csv.text().contains(&format!("device file sha256 {}", haptex_core::io::sha256_hex(text.as_bytes()))));
    // A constant the file sets is refused beside it; a lower U_max is allowed, a higher one is not.
    post_json("/api/voltage", &body(json!({ "device": { "mu_hd": 0.5 } })))
        .await
        .error(StatusCode::BAD_REQUEST, Some("device.mu_hd"));
    let lower = post_json("/api/voltage", &body(json!({ "device": { "u_max_v": 80 } }))).await.json();
    assert_eq!(lower["parameters"]["u_max_v"], 80.0);
    post_json("/api/voltage", &body(json!({ "device": { "u_max_v": 150 } })))
        .await
        .error(StatusCode::BAD_REQUEST, Some("device.u_max_v"));
    // A broken file names the field and its line; a carrier without a file is refused.
    let e = post_json("/api/voltage", &body(json!({ "device_file": "format = \"haptex-device 1\"\n[oops\n" }))).await;
    let e = e.error(StatusCode::BAD_REQUEST, Some("device_file"));
    assert_eq!(e["line"], 2, "{e}");
    let no_file = json!({ "profile": { "x_mm": [0, 1], "mu": [1, 1.2] },
        "carrier": { "shape": "sine", "frequency_hz": 100 } });
    post_json("/api/voltage", &no_file).await.error(StatusCode::BAD_REQUEST, Some("carrier"));
    // The combined display takes the file's plate and constants.
    let combined = post_json("/api/voltage", &body(json!({ "display": "combined" }))).await;
    combined.ok();
    let c = combined.json();
    assert_eq!(c["summary"]["ultrasonic"]["source"], "calibration", "{}", c["summary"]["ultrasonic"]);
    assert_eq!(c["device_file"]["ultrasonic"], "exponential");
}

/// Strokes "measured" on a display whose friction rises 0.8 times as much
/// as the design's model says, with noise of SD about 2e-3: every stroke
/// covers the design's span, on a 0.01 mm grid.
fn strokes(design: &FrictionProfile, mu_hd: f64, n: usize) -> Vec<Value> {
    let mut seed: u64 = 36;
    let mut noise = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 7e-3
    };
    let (x0, x1) = (design.x_mm()[0] - 0.5, design.x_mm()[design.len() - 1] + 0.5);
    (0..n)
        .map(|k| {
            let mut csv = String::from("x_mm,mu\n");
            let mut x = x0;
            while x <= x1 {
                let target = design.mu_at(x.clamp(design.x_mm()[0], design.x_mm()[design.len() - 1]));
                let felt = mu_hd + 0.8 * (target - mu_hd).max(0.0) + noise();
                csv += &format!("{x:.3},{felt:.6}\n");
                x += 0.01;
            }
            json!({ "name": format!("s{}.csv", k + 1), "csv": csv })
        })
        .collect()
}

#[tokio::test]
async fn measured_compensation_returns_a_design_within_u_max_and_a_history() {
    // The target: a bump from 0.52 to 0.58 on a display of mu_HD 0.5 (docs/measured-compensation.md).
    let x: Vec<f64> = (0..=80).map(|i| 0.05 * f64::from(i)).collect();
    let mu: Vec<f64> = x.iter().map(|x| 0.52 + 0.06 * (-((x - 2.0) / 0.6f64).powi(2)).exp()).collect();
    let target = FrictionProfile::new(x, mu).unwrap();
    let device = Device { mu_hd: 0.5, u_max_v: 200.0, ..Device::PAPER };
    let mut design = Vec::new();
    map_profile(&target, &device, Method::Physical, None).unwrap().write_csv(&mut design).unwrap();
    let design = String::from_utf8(design).unwrap();
    let body = json!({ "design": design, "strokes": strokes(&target, 0.5, 6),
        "device": { "mu_hd": 0.5, "u_max_v": 200 } });
    let answer = post_json("/api/compensate/measured", &body).await;
    answer.ok();
    let a = answer.json();
    let history = a["history"].as_array().unwrap();
    assert_eq!(history.len(), 1);
    assert_eq!(history[0]["iteration"], 0);
    assert!(history[0]["rms_error"].as_f64().unwrap() > history[0]["noise_floor"].as_f64().unwrap());
    assert_eq!(history[0]["strokes"], 6);
    assert!(a["kept"].is_null(), "the first design is far from the floor: {}", a["limited_by"]);
    // No sample above U_max, and the next design asks for more voltage (the display gives 0.8 of the rise).
    let next = a["design_csv"].as_str().unwrap();
    let table = Table::read(next.as_bytes(), "next").unwrap();
    let u = table.require("voltage_v").unwrap();
    assert!(u.iter().all(|&u| (0.0..=200.0).contains(&u)), "{u:?}");
    let played = numbers(&a["voltage_played_v"]);
    assert!(u.iter().sum::<f64>() > played.iter().sum::<f64>());
    assert_eq!(u, numbers(&a["voltage_next_v"]).as_slice());
    // The next design carries the history: the core reads it back, ready for iteration 1.
    let back = Design::from_table(&table, &DisplayModel::Electrovibration(device)).unwrap();
    assert_eq!(back.history.len(), 1);
    assert!(a["report_csv"].as_str().unwrap().starts_with("iteration,rms_error,noise_floor"));
    assert_eq!(a["mean"].as_array().unwrap().len(), 81);
    // A second iteration from the design returned.
    let body =
        json!({ "design": next, "strokes": strokes(&target, 0.5, 6), "device": { "mu_hd": 0.5, "u_max_v": 200 } });
    let second = post_json("/api/compensate/measured", &body).await;
    second.ok();
    assert_eq!(second.json()["history"].as_array().unwrap().len(), 2);
}

#[tokio::test]
async fn measured_compensation_errors_name_the_design_or_the_stroke() {
    let design = "x_mm,mu,voltage_v\n0,0.52,50\n1,0.55,80\n2,0.52,250\n";
    let ok_stroke = |name: &str| json!({ "name": name, "csv": "x_mm,mu\n-1,0.5\n3,0.5\n" });
    // A voltage above U_max: the design's line and column.
    let body =
        json!({ "design": design, "strokes": [ok_stroke("a.csv"), ok_stroke("b.csv")], "device": { "mu_hd": 0.5 } });
    let e = post_json("/api/compensate/measured", &body).await.error(StatusCode::BAD_REQUEST, Some("design"));
    assert_eq!((e["line"].as_u64(), e["column"].as_str()), (Some(4), Some("voltage_v")), "{e}");
    let design = "x_mm,mu,voltage_v\n0,0.52,50\n1,0.55,80\n2,0.52,50\n";
    // A bad stroke: its index, file name, line and column.
    let bad = json!({ "name": "b.csv", "csv": "x_mm,mu\n-1,0.5\n3,zero\n" });
    let body = json!({ "design": design, "strokes": [ok_stroke("a.csv"), bad], "device": { "mu_hd": 0.5 } });
    let e = post_json("/api/compensate/measured", &body).await.error(StatusCode::BAD_REQUEST, Some("strokes[1]"));
    assert_eq!((e["line"].as_u64(), e["column"].as_str(), e["file"].as_str()), (Some(3), Some("mu"), Some("b.csv")));
    // A stroke that does not cover the span.
    let short = json!({ "name": "short.csv", "csv": "x_mm,mu\n0.5,0.5\n3,0.5\n" });
    let body = json!({ "design": design, "strokes": [ok_stroke("a.csv"), short], "device": { "mu_hd": 0.5 } });
    let e = post_json("/api/compensate/measured", &body).await.error(StatusCode::BAD_REQUEST, Some("strokes[1]"));
    assert_eq!(e["file"], "short.csv");
    // One stroke is not enough for a noise floor.
    let body = json!({ "design": design, "strokes": [ok_stroke("a.csv")], "device": { "mu_hd": 0.5 } });
    post_json("/api/compensate/measured", &body).await.error(StatusCode::BAD_REQUEST, Some("strokes"));
    let body = json!({ "design": design, "strokes": [ok_stroke("a.csv"), ok_stroke("b.csv")], "gain": 2 });
    post_json("/api/compensate/measured", &body).await.error(StatusCode::BAD_REQUEST, Some("gain"));
}
