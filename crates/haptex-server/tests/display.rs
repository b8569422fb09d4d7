//! API tests of the display models (issue 16, part 4): `POST /api/voltage`
//! with `display` ultrasonic or combined, and `POST /api/play` of the
//! designed pair on two channels, the whole application in-process.
//!
//! Oracles: the core's model of the felt friction
//! (`Allocator::felt_mu`, mu_HD rho(a) (1 + Fe(U)/Fn), docs/physics.md "The
//! combined display"), the core's `map_display`, calibration reader and
//! two-channel renderer and WAV encoder (which `haptex voltage --display`
//! and `haptex play` use: the server must give the same numbers and bytes),
//! and the SHA-256 of the electrovibration answers as the server gave them
//! before the display fields existed (recorded from the build of commit
//! 69c1827 with the same requests).

use axum::Router;
use axum::body::Body;
use axum::http::{Request, StatusCode, header};
use haptex_core::combined::{Allocator, Channels, Strategy, map_display};
use haptex_core::electrovibration::Device;
use haptex_core::io::sha256_hex;
use haptex_core::profile::FrictionProfile;
use haptex_core::signal::{
    AmplitudeCurve, RenderSettings, VoltageCurve, WavFormat, WavOptions, WavSidecar, decode_drive_wav_channels,
    encode_wav, render_two_channel, write_wav,
};
use haptex_core::trajectory::Trajectory;
use haptex_core::ultrasonic::{Calibration, UltrasonicDevice};
use haptex_server::app;
use serde_json::{Value, json};

mod common;

use common::{Answer, send_to, shipped_state};

fn server() -> Router {
    app(shipped_state())
}

async fn post_raw(uri: &str, content_type: &str, body: impl Into<Body>) -> Answer {
    send_to(server(), Request::post(uri).header(header::CONTENT_TYPE, content_type).body(body.into()).unwrap()).await
}

async fn post_json(uri: &str, body: &Value) -> Answer {
    post_raw(uri, "application/json", body.to_string()).await
}

fn numbers(value: &Value) -> Vec<f64> {
    value.as_array().unwrap_or_else(|| panic!("not an array: {value}")).iter().map(|v| v.as_f64().unwrap()).collect()
}

/// A calibration of a plate (hand-written for the test, not a measurement).
const CALIBRATION: &str = "# test plate\namplitude_um,relative_friction\n0,1\n0.5,0.8\n1.0,0.5\n2.0,0.25\n";

/// A seeded xorshift generator: the round trip's random devices and profiles.
struct Rng(u64);

impl Rng {
    /// Uniform in [0, 1).
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Round trip (the acceptance, through the API): for random
/// devices (mu_HD, U_max, a_max, the literature default or a calibration)
/// and random profiles reaching below and above the band, every display
/// and strategy, the friction the core's model gives for the returned (U,
/// a) equals the target to 1e-9 wherever the target is inside the returned
/// band; outside it the channels saturate as documented (below: a = a_max,
/// U = 0; above: a = 0 and U = U_max with electrovibration). The answer is
/// the core's `map_display` (what `haptex voltage --display` writes) bit
/// for bit.
#[tokio::test]
async fn voltage_display_round_trip_renders_the_target_inside_the_band() {
    let cases: [(&str, Option<&str>, Option<f64>); 7] = [
        ("ultrasonic", None, None),
        ("combined", None, None),
        ("combined", Some("split"), None),
        ("combined", Some("bias"), None),
        ("combined", Some("weighted"), None),
        ("combined", Some("weighted"), Some(0.2)),
        ("combined", Some("weighted"), Some(50.0)),
    ];
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut inside, mut below, mut above) = (0, 0, 0);
    for trial in 0..10 {
        let mu_hd = 0.3 + 1.2 * rng.next();
        let u_max_v = 20.0 + 200.0 * rng.next();
        let calibrated = trial % 2 == 1;
        let a_max_um = 0.3 + 1.7 * rng.next();
        let x: Vec<f64> = (0..60).map(|i| f64::from(i) * 0.1).collect();
        let mu: Vec<f64> = x.iter().map(|_| mu_hd * (0.02 + 1.6 * rng.next())).collect();
        let device = Device { mu_hd, u_max_v, ..Device::PAPER };
        let plate = if calibrated {
            let calibration = Calibration::read_csv(CALIBRATION.as_bytes(), "ultrasonic_calibration").unwrap();
            UltrasonicDevice::calibrated(calibration, Some(a_max_um)).unwrap()
        } else {
            UltrasonicDevice::literature_default(Some(a_max_um)).unwrap()
        };
        let ratio = device.force_ratio_per_v2(1.0);
        for (display, strategy, weight) in cases {
            let mut body = json!({
                "profile": { "x_mm": x, "mu": mu },
                "device": { "mu_hd": mu_hd, "u_max_v": u_max_v },
                "display": display,
                "a_max_um": a_max_um,
            });
            if let Some(s) = strategy {
                body["strategy"] = json!(s);
            }
            if let Some(w) = weight {
                body["weight"] = json!(w);
            }
            if calibrated {
                body["ultrasonic_calibration"] = json!(CALIBRATION);
            }
            let what = format!("trial {trial}: {body}");
            let answer = post_json("/api/voltage", &body).await.ok().json();
            let s = &answer["summary"];
            assert_eq!(s["display"], display, "{what}");
            let combined = display == "combined";
            let model = Allocator::new(mu_hd, combined.then_some((ratio, u_max_v)), Some(&plate), Strategy::Split, 1.0);
            let band = numbers(&s["band_mu"]);
            let expected_band = model.band();
            for k in 0..2 {
                assert!((band[k] - expected_band[k]).abs() <= 1e-12 * expected_band[k], "{what}: {band:?}");
            }
            let a = numbers(&answer["amplitude_um"]);
            let u = if combined {
                let fe_fn = s["electrovibration"]["fe_over_fn_per_v2"].as_f64().unwrap();
                assert!((fe_fn - ratio).abs() <= 1e-12 * ratio, "{what}: Fe/Fn {fe_fn} vs {ratio}");
                numbers(&answer["voltage_v"])
            } else {
                assert!(answer.get("voltage_v").is_none(), "{what}: the ultrasonic display has no voltage");
                vec![0.0; x.len()]
            };
            assert_eq!(s["ultrasonic"]["a_max_um"].as_f64(), Some(a_max_um), "{what}");
            for i in 0..x.len() {
                let target = mu[i];
                assert!((0.0..=u_max_v).contains(&u[i]) && (0.0..=a_max_um).contains(&a[i]), "{what}: {i}");
                if target < band[0] {
                    below += 1;
                    assert_eq!((u[i], a[i]), (0.0, a_max_um), "{what}: sample {i} below the band");
                } else if target > band[1] {
                    above += 1;
                    assert_eq!((u[i], a[i]), (if combined { u_max_v } else { 0.0 }, 0.0), "{what}: sample {i}");
                } else {
                    inside += 1;
                    let felt = model.felt_mu(u[i], a[i]);
                    assert!((felt - target).abs() <= 1e-9, "{what}: sample {i}: felt {felt} vs target {target}");
                }
            }
            // The command line's numbers.
            let profile = FrictionProfile::new(x.clone(), mu.clone()).unwrap();
            let strategy = match (strategy, weight) {
                (Some("bias"), _) => Strategy::Bias,
                (Some("weighted"), w) => Strategy::Weighted { weight: w.unwrap_or(1.0) },
                _ => Strategy::Split,
            };
            let channels = if combined { Channels::Combined(&plate, strategy) } else { Channels::Ultrasonic(&plate) };
            let core = map_display(&profile, &device, channels, None, None).unwrap();
            assert_eq!(core.amplitude_um.as_deref(), Some(a.as_slice()), "{what}");
            if combined {
                assert_eq!(core.voltage_v.as_deref(), Some(u.as_slice()), "{what}");
            }
            assert_eq!(serde_json::to_value(&core.summary).unwrap(), *s, "{what}");
        }
    }
    eprintln!("round trip: {inside} samples inside the band, {below} below, {above} above");
    assert!(inside > 2000 && below > 100 && above > 100, "{inside} {below} {above}");
}

/// The CSV answer is the core's display file (`x_mm,mu,voltage_v,
/// amplitude_um` after its comments), and a CSV body with the display in
/// the query string gives the same answer as the JSON body.
#[tokio::test]
async fn voltage_display_csv_is_the_core_file_and_the_query_equals_the_json_body() {
    let x = [0.0, 1.0, 2.0, 3.0, 4.0];
    let mu = [0.3, 0.8, 1.0, 1.1, 1.5];
    let body = json!({ "profile": { "x_mm": x, "mu": mu }, "display": "combined", "strategy": "bias" });
    let answer = post_json("/api/voltage?format=csv", &body).await.ok().body.clone();
    let plate = UltrasonicDevice::literature_default(None).unwrap();
    let profile = FrictionProfile::new(x.to_vec(), mu.to_vec()).unwrap();
    let core = map_display(&profile, &Device::PAPER, Channels::Combined(&plate, Strategy::Bias), None, None).unwrap();
    let mut file = Vec::new();
    core.write_csv(&mut file).unwrap();
    assert_eq!(String::from_utf8_lossy(&answer), String::from_utf8_lossy(&file));
    assert!(String::from_utf8_lossy(&answer).contains("x_mm,mu,voltage_v,amplitude_um\n"));

    let csv = "x_mm,mu\n0,0.3\n1,0.8\n2,1.0\n3,1.1\n4,1.5\n";
    let from_query = post_raw("/api/voltage?display=combined&strategy=bias", "text/csv", csv).await.ok().json();
    let from_json = post_json("/api/voltage", &body).await.ok().json();
    assert_eq!(from_query, from_json);
    let ultrasonic =
        post_raw("/api/voltage?display=ultrasonic&a_max_um=1.5&format=csv", "text/csv", csv).await.ok().body.clone();
    let text = String::from_utf8_lossy(&ultrasonic);
    assert!(text.contains("\nx_mm,mu,amplitude_um\n") && !text.contains("voltage_v"), "{text}");
}

/// A drive WAV with its scale chunk as version 1 wrote it: without
/// `version`, `fmt` and `fmt_sha256` (the other fields in the same order),
/// the RIFF size adjusted.
fn as_version_1(wav: &[u8]) -> Vec<u8> {
    let at = wav.windows(4).position(|w| w == b"hptx").unwrap();
    let size = u32::from_le_bytes(wav[at + 4..at + 8].try_into().unwrap()) as usize;
    let mut scale: haptex_core::signal::ScaleChunk = serde_json::from_slice(&wav[at + 8..at + 8 + size]).unwrap();
    (scale.version, scale.fmt, scale.fmt_sha256) = (None, None, None);
    let content = serde_json::to_vec(&scale).unwrap();
    let mut out = wav[..at].to_vec();
    out.extend_from_slice(b"hptx");
    out.extend_from_slice(&(content.len() as u32).to_le_bytes());
    out.extend_from_slice(&content);
    if content.len() % 2 == 1 {
        out.push(0);
    }
    let riff = (out.len() - 8) as u32;
    out[4..8].copy_from_slice(&riff.to_le_bytes());
    out
}

/// The electrovibration answers are the bytes the server gave before the
/// display fields existed (SHA-256 recorded from commit 69c1827's server
/// with these requests), and `display: electrovibration` given explicitly
/// changes nothing. The WAV's scale chunk is version 2 since issue 35 (it
/// states and hashes the `fmt ` chunk): turned back into version 1 (its
/// three new fields removed), the WAV is the old bytes, so its `fmt `
/// chunk and samples did not change; its new hash is recorded too.
#[tokio::test]
async fn electrovibration_answers_are_byte_identical_to_before() {
    let body = json!({
        "profile": { "x_mm": [0, 1, 2, 3, 4], "mu": [0.8, 1.0, 1.1, 1.3, 0.9] },
        "device": { "u_max_v": 120 },
    });
    let csv = "x_mm,mu\n0,0.8\n1,1.0\n2,1.1\n3,1.3\n4,0.9\n";
    let json_answer = "5a49cbfa0226987223c74a99f156c0ec0e4dd3006ec1b47aba99172909dec691";
    let csv_answer = "7ee5fba4be16884f7b61d6ad9d72696d0357c2c110cfced84607cec7bd0dcb7c";
    let mut explicit = body.clone();
    explicit["display"] = json!("electrovibration");
    for b in [&body, &explicit] {
        assert_eq!(sha256_hex(&post_json("/api/voltage", b).await.ok().body), json_answer, "{b}");
        assert_eq!(sha256_hex(&post_json("/api/voltage?format=csv", b).await.ok().body), csv_answer, "{b}");
    }
    for query in ["u_max_v=120", "u_max_v=120&display=electrovibration"] {
        let answer = post_raw(&format!("/api/voltage?{query}"), "text/csv", csv).await.ok().body.clone();
        assert_eq!(sha256_hex(&answer), json_answer, "{query}");
    }
    let play = json!({
        "voltage": { "x_mm": [0, 1, 2, 3, 4], "voltage_v": [0, 10, 60, 110, 30] },
        "stroke": { "velocity_mm_s": 40 },
        "u_max_v": 100,
    });
    let wav = post_json("/api/play", &play).await.ok().body.clone();
    assert_eq!(sha256_hex(&as_version_1(&wav)), "c9d9a65b5e6424a74cf0b9bc209778383f3811dadeba384538d953817177101a");
    assert_eq!(sha256_hex(&wav), "b79701ac3e5269a12d0db04c34f2d39bdf47ebe5ebf4dc4e8d1b22917d37f153");
    let play_json = json!({
        "voltage": { "x_mm": [0, 1, 2, 3, 4], "voltage_v": [0, 10, 60, 110, 30] },
        "stroke": { "velocity_mm_s": 400 },
        "u_max_v": 100, "format": "json", "sample_rate_hz": 8000,
    });
    let answer = post_json("/api/play", &play_json).await.ok().body.clone();
    assert_eq!(sha256_hex(&answer), "c3208844080ec67f57a24cd98b698a6cd2dc94358ecb5d771f8a17c637fc7b6d");
}

/// A calibration with bad input is refused as the command line's reader
/// refuses the file: the same message (line and column), 400 naming
/// `ultrasonic_calibration` with the line and the column; a calibration
/// past its size limit and a body past the body limit are refused with 413.
#[tokio::test]
async fn bad_calibrations_are_refused_with_line_and_column() {
    let profile = json!({ "x_mm": [0.0, 1.0, 2.0], "mu": [0.5, 1.0, 1.1] });
    let cases: [(&str, u64, &str); 6] = [
        ("amplitude_um,relative_friction\n0,1\n0.5,0.9\n0.4,0.8\n", 4, "amplitude_um"),
        ("amplitude_um,relative_friction\n0,1\n0.5,1.2\n", 3, "relative_friction"),
        ("amplitude_um,relative_friction\n0,1\n0.5,abc\n", 3, "relative_friction"),
        ("# comment\namplitude_um,relative_friction\n0,1\n0.5,0.6\n1,0.7\n", 5, "relative_friction"),
        ("amplitude_um,relative_friction\n0.1,1\n0.5,0.6\n", 2, "amplitude_um"),
        ("amplitude,relative_friction\n0,1\n0.5,0.6\n", 1, "amplitude_um"),
    ];
    for (text, line, column) in cases {
        let cli = Calibration::read_csv(text.as_bytes(), "ultrasonic_calibration").unwrap_err().to_string();
        for display in ["ultrasonic", "combined"] {
            let body = json!({ "profile": profile, "display": display, "ultrasonic_calibration": text });
            let error =
                post_json("/api/voltage", &body).await.error(StatusCode::BAD_REQUEST, Some("ultrasonic_calibration"));
            assert_eq!(error["error"].as_str(), Some(cli.as_str()), "{text:?}");
            assert_eq!(error["line"].as_u64(), Some(line), "{text:?}: {error}");
            assert_eq!(error["column"].as_str(), Some(column), "{text:?}: {error}");
            assert!(cli.contains(&format!("line {line}")) && cli.contains(column), "{cli}");
        }
    }
    // Past the calibration's limit (256 KiB) but within the body's (1 MiB).
    let long = format!("amplitude_um,relative_friction\n{}", "0.5,0.5\n".repeat(40_000));
    let body = json!({ "profile": profile, "display": "ultrasonic", "ultrasonic_calibration": long });
    post_json("/api/voltage", &body).await.error(StatusCode::PAYLOAD_TOO_LARGE, Some("ultrasonic_calibration"));
    let huge = format!("amplitude_um,relative_friction\n{}", "0.5,0.5\n".repeat(140_000));
    let body = json!({ "profile": profile, "display": "ultrasonic", "ultrasonic_calibration": huge });
    post_json("/api/voltage", &body).await.error(StatusCode::PAYLOAD_TOO_LARGE, Some("body"));
    // A good calibration is the device used: the summary names it.
    let body = json!({ "profile": profile, "display": "ultrasonic", "ultrasonic_calibration": CALIBRATION });
    let answer = post_json("/api/voltage", &body).await.ok().json();
    let model = &answer["summary"]["ultrasonic"];
    assert_eq!(model["source"], "calibration");
    assert_eq!(model["a_max_um"].as_f64(), Some(2.0));
    assert_eq!(model["relative_friction_min"].as_f64(), Some(0.25));
}

/// Every display field out of place or out of range is refused naming
/// itself; messages name the page's controls or the API's fields, never a
/// command-line flag.
#[tokio::test]
async fn display_fields_out_of_place_or_range_are_refused_naming_the_field() {
    let profile = json!({ "x_mm": [0.0, 1.0, 2.0], "mu": [0.5, 1.0, 1.1] });
    let with = |fields: Value| {
        let mut body = json!({ "profile": profile });
        for (k, v) in fields.as_object().unwrap() {
            body[k] = v.clone();
        }
        body
    };
    let cases: Vec<(Value, StatusCode, &str)> = vec![
        (json!({ "display": "haptic" }), StatusCode::BAD_REQUEST, "display"),
        (json!({ "display": 3 }), StatusCode::BAD_REQUEST, "display"),
        (json!({ "strategy": "split" }), StatusCode::BAD_REQUEST, "strategy"),
        (json!({ "a_max_um": 1.0 }), StatusCode::BAD_REQUEST, "a_max_um"),
        (json!({ "weight": 1.0 }), StatusCode::BAD_REQUEST, "weight"),
        (json!({ "ultrasonic_calibration": CALIBRATION }), StatusCode::BAD_REQUEST, "ultrasonic_calibration"),
        (json!({ "display": "electrovibration", "a_max_um": 1.0 }), StatusCode::BAD_REQUEST, "a_max_um"),
        (json!({ "display": "ultrasonic", "strategy": "bias" }), StatusCode::BAD_REQUEST, "strategy"),
        (json!({ "display": "ultrasonic", "weight": 1.0 }), StatusCode::BAD_REQUEST, "weight"),
        (json!({ "display": "combined", "weight": 1.0 }), StatusCode::BAD_REQUEST, "weight"),
        (json!({ "display": "combined", "strategy": "bias", "weight": 1.0 }), StatusCode::BAD_REQUEST, "weight"),
        (json!({ "display": "combined", "strategy": "best" }), StatusCode::BAD_REQUEST, "strategy"),
        (json!({ "display": "combined", "strategy": "weighted", "weight": -1.0 }), StatusCode::BAD_REQUEST, "weight"),
        (json!({ "display": "combined", "strategy": "weighted", "weight": 1e7 }), StatusCode::BAD_REQUEST, "weight"),
        (json!({ "display": "combined", "strategy": "weighted", "weight": "1" }), StatusCode::BAD_REQUEST, "weight"),
        (json!({ "display": "combined", "a_max_um": 0.0 }), StatusCode::BAD_REQUEST, "a_max_um"),
        (json!({ "display": "combined", "a_max_um": 1e308 }), StatusCode::BAD_REQUEST, "a_max_um"),
        (json!({ "display": "combined", "a_max_um": -1.0 }), StatusCode::BAD_REQUEST, "a_max_um"),
        // Beyond the literature default's validity (2.3 um) or the calibration's last amplitude (2 um).
        (json!({ "display": "combined", "a_max_um": 3.0 }), StatusCode::BAD_REQUEST, "a_max_um"),
        (
            json!({ "display": "ultrasonic", "a_max_um": 2.5, "ultrasonic_calibration": CALIBRATION }),
            StatusCode::BAD_REQUEST,
            "a_max_um",
        ),
        (
            json!({ "display": "ultrasonic", "ultrasonic_calibration": 5 }),
            StatusCode::BAD_REQUEST,
            "ultrasonic_calibration",
        ),
        (json!({ "display": "combined", "method": "normalized" }), StatusCode::BAD_REQUEST, "method"),
        (json!({ "display": "combined", "relative": true, "flat_mu": 0.0 }), StatusCode::BAD_REQUEST, "flat_mu"),
        (json!({ "display": "combined", "device": { "u_max_v": 0.0 } }), StatusCode::BAD_REQUEST, "device.u_max_v"),
        (json!({ "display": "combined", "device": { "area_exponent": 0.5 } }), StatusCode::BAD_REQUEST, "device.fn_n"),
    ];
    for (fields, status, field) in cases {
        let error = post_json("/api/voltage", &with(fields.clone())).await.error(status, Some(field));
        let message = error["error"].as_str().unwrap();
        assert!(!message.contains("--"), "{fields}: {message}");
    }
    let csv = "x_mm,mu\n0,0.5\n1,1.0\n";
    for (query, field) in [
        ("display=hologram", "display"),
        ("display=combined&strategy=most", "strategy"),
        ("display=combined&weight=x", "weight"),
        ("display=combined&a_max_um=nan", "a_max_um"),
        ("display=combined&ultrasonic_calibration=0,1", "ultrasonic_calibration"),
        ("strategy=split", "strategy"),
    ] {
        post_raw(&format!("/api/voltage?{query}"), "text/csv", csv).await.error(StatusCode::BAD_REQUEST, Some(field));
    }
    // The page's words in the warnings: the literature default's warning
    // names the calibration upload, not --ultrasonic-calibration.
    let answer = post_json("/api/voltage", &with(json!({ "display": "combined" }))).await.ok().json();
    let cli = answer["summary"]["warnings"].to_string();
    let page = answer["page_warnings"].to_string();
    assert!(cli.contains("--ultrasonic-calibration"), "{cli}");
    assert!(!page.contains("--") && page.contains("the ultrasonic calibration file (Display)"), "{page}");
}

/// A designed pair plays on two channels: the WAV is the bytes the core
/// writes for `haptex play` (its `hptx` chunk with channel 2's scale, the
/// CLI's sidecar `channel_2` equal to it), channel 2 is a(x(t)) within a
/// sample step, its full scale a_max; the JSON answer has the amplitude
/// and the ultrasonic report; and the two-channel fields are refused out
/// of place.
#[tokio::test]
async fn play_two_channels_is_the_cores_wav_with_channel_2s_scale() {
    let x = [0.0, 1.0, 2.0, 3.0, 4.0];
    let mu = [0.3, 0.8, 1.0, 1.1, 1.5];
    let body = json!({ "profile": { "x_mm": x, "mu": mu }, "display": "combined", "a_max_um": 2.0 });
    let design = post_json("/api/voltage", &body).await.ok().json();
    let (u, a) = (numbers(&design["voltage_v"]), numbers(&design["amplitude_um"]));
    let a_max_um = design["summary"]["ultrasonic"]["a_max_um"].as_f64().unwrap();
    assert_eq!(a_max_um, 2.0);
    let play = json!({
        "voltage": { "x_mm": x, "voltage_v": u, "amplitude_um": a },
        "a_max_um": a_max_um,
        "stroke": { "velocity_mm_s": 40.0 },
    });
    let answer = post_json("/api/play", &play).await;
    answer.ok();
    assert_eq!(answer.headers["x-haptex-um-per-full-scale"], "2");
    // The core's render and encoding of the same drive.
    let curve = VoltageCurve::new(x.to_vec(), u.clone()).unwrap();
    let amplitude = AmplitudeCurve::new(x.to_vec(), a.clone()).unwrap();
    let trajectory = Trajectory::constant_velocity(0.0, 4.0, 40.0, 1000.0).unwrap();
    let signal = render_two_channel(&curve, &amplitude, a_max_um, &trajectory, &RenderSettings::DEFAULT).unwrap();
    let options = WavOptions { format: WavFormat::Pcm16, volts_per_full_scale: std::f64::consts::SQRT_2 * 100.0 };
    let encoded = encode_wav(&signal, &options, "test").unwrap();
    assert!(answer.body.as_ref() == encoded.bytes.as_slice(), "the server's WAV differs from the core's");
    // What haptex play writes: the same file, its sidecar's channel 2 scale the chunk's.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("drive.wav");
    let sidecar = write_wav(&path, &signal, &options, json!({})).unwrap();
    assert!(std::fs::read(&path).unwrap() == answer.body.as_ref());
    let (scale, volts, channel_2) = decode_drive_wav_channels(&answer.body).unwrap();
    assert_eq!(sidecar.channel_2, scale.channel_2);
    assert_eq!(sidecar.samples_sha256, scale.samples_sha256);
    let c2 = scale.channel_2.unwrap();
    assert_eq!((c2.um_per_full_scale, c2.a_max_um, c2.unit.as_str()), (2.0, 2.0, "um"));
    let channel_2 = channel_2.unwrap();
    assert_eq!((volts.len(), channel_2.len()), (signal.len(), signal.len()));
    // Channel 2 is a(x(t)) to the 16-bit step (a_max / 32767).
    let expected = signal.amplitude_um.as_ref().unwrap();
    let step = 2.0 / 32767.0;
    for (got, want) in channel_2.iter().zip(expected) {
        assert!((got - want).abs() <= 0.5 * step + 1e-12, "{got} vs {want}");
    }
    assert!(expected.iter().any(|&v| v > 1.0), "the stroke crosses the region rendered by the plate");

    // The sidecar format: what haptex play writes beside that WAV (its own file name and source aside).
    let mut as_sidecar = play.clone();
    as_sidecar["format"] = json!("sidecar");
    let served: WavSidecar = serde_json::from_slice(&post_json("/api/play", &as_sidecar).await.ok().body).unwrap();
    let mut cli = sidecar.clone();
    (cli.wav_file, cli.source) = (served.wav_file.clone(), served.source.clone());
    assert_eq!(served, cli);
    assert_eq!((served.channels, served.wav_file.as_str()), (2, "haptex-drive.wav"));

    let mut as_json = play.clone();
    as_json["format"] = json!("json");
    as_json["sample_rate_hz"] = json!(8000);
    let answer = post_json("/api/play", &as_json).await.ok().json();
    assert_eq!(answer["amplitude_um"].as_array().unwrap().len(), answer["signal_v"].as_array().unwrap().len());
    assert_eq!(answer["report"]["ultrasonic"]["a_max_um"].as_f64(), Some(2.0));

    // Out of place, out of range.
    let voltage = json!({ "x_mm": [0.0, 1.0], "voltage_v": [10.0, 20.0] });
    let stroke = json!({ "velocity_mm_s": 50.0 });
    let with_amplitude = |a: Value| json!({ "x_mm": [0.0, 1.0], "voltage_v": [10.0, 20.0], "amplitude_um": a });
    let cases: Vec<(Value, &str)> = vec![
        (json!({ "voltage": voltage, "stroke": stroke, "a_max_um": 1.0 }), "a_max_um"),
        (json!({ "voltage": with_amplitude(json!([0.5, 0.5])), "stroke": stroke }), "a_max_um"),
        (json!({ "voltage": with_amplitude(json!([0.5, 0.5])), "stroke": stroke, "a_max_um": 0.0 }), "a_max_um"),
        (json!({ "voltage": with_amplitude(json!([0.5, 0.5])), "stroke": stroke, "a_max_um": 1e9 }), "a_max_um"),
        (
            json!({ "voltage": with_amplitude(json!([0.5, -0.5])), "stroke": stroke, "a_max_um": 1.0 }),
            "voltage.amplitude_um[1]",
        ),
        (
            json!({ "voltage": with_amplitude(json!([0.5, 1e308])), "stroke": stroke, "a_max_um": 1.0 }),
            "voltage.amplitude_um[1]",
        ),
        (json!({ "voltage": with_amplitude(json!([0.5])), "stroke": stroke, "a_max_um": 1.0 }), "voltage.amplitude_um"),
        (json!({ "voltage": with_amplitude(json!("0.5")), "stroke": stroke, "a_max_um": 1.0 }), "voltage.amplitude_um"),
    ];
    for (body, field) in cases {
        post_json("/api/play", &body).await.error(StatusCode::BAD_REQUEST, Some(field));
    }
}

/// The relative mapping (paper Fig. 2) with the combined display: the
/// profile over its flat-surface friction times mu_HD, then the core's
/// `map_display` (what `haptex voltage --relative --flat-mu 0.5 --display
/// combined` writes), the summary saying how it was made.
#[tokio::test]
async fn voltage_display_relative_is_the_cores() {
    use haptex_core::relative::FlatMu;
    let x: Vec<f64> = (0..41).map(|i| f64::from(i) * 0.25).collect();
    let mu: Vec<f64> = x.iter().map(|x| 0.5 + 0.15 * (x - 5.0).sin()).collect();
    let body = json!({
        "profile": { "x_mm": x, "mu": mu },
        "relative": true, "flat_mu": 0.5,
        "display": "combined", "strategy": "bias",
    });
    let answer = post_json("/api/voltage", &body).await.ok().json();
    let plate = UltrasonicDevice::literature_default(None).unwrap();
    let profile = FrictionProfile::new(x.clone(), mu.clone()).unwrap();
    let channels = Channels::Combined(&plate, Strategy::Bias);
    let core = map_display(&profile, &Device::PAPER, channels, None, Some(FlatMu::Given(0.5))).unwrap();
    assert_eq!(numbers(&answer["mu"]), core.mu);
    assert_eq!(numbers(&answer["amplitude_um"]), core.amplitude_um.unwrap());
    assert_eq!(numbers(&answer["voltage_v"]), core.voltage_v.unwrap());
    assert_eq!(answer["summary"]["relative"]["flat_mu"].as_f64(), Some(0.5));
    // The relative profile spans 0.7 .. 1.3: below mu_HD = 1 the plate, above it the voltage.
    assert!(core.mu.iter().any(|m| *m < 0.75) && core.mu.iter().any(|m| *m > 1.25));
}
