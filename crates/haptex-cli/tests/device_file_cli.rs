//! `--device FILE` (the device file of `haptex calibrate`) on the design
//! commands: the same numbers as the explicit flags it stands for, the
//! refusals (a carrier an eq3 file was not measured on, a corrupt file,
//! the flags it sets, a U_max above its own), and the file named in every
//! output.
//!
//! The device files are made here from a virtual device (known
//! constants, synthetic measurements) by the calibration code itself.

mod common;
use std::path::Path;

use common::{haptex, stderr, write};
use haptex_core::calibration::device_file::DeviceFile;
use haptex_core::calibration::virtual_device::{Noise, Protocol, Truth, measure};
use haptex_core::calibration::{Settings, calibrate};
use haptex_core::electrovibration::{ContactArea, Device, LayerStack};
use haptex_core::frequency::FingerCircuit;
use haptex_core::signal::{Carrier, CarrierShape};
use haptex_core::ultrasonic::Exponential;

fn sine(f: f64) -> Carrier {
    Carrier { shape: CarrierShape::Sine, frequency_hz: f }
}

/// c of eq. (3) for a k on the paper's stack, 1/V^2.
fn c_of_k(k: f64) -> f64 {
    let device = Device { contact: ContactArea { k_mm2_per_n: k, exponent: 1.0 }, ..Device::PAPER };
    device.force_ratio_per_v2(1.0)
}

/// A display with mu_HD 0.6, k 200 mm^2/N, a leaky stratum corneum and
/// an ultrasonic plate.
fn truth() -> Truth {
    Truth {
        mu_hd: 0.6,
        c_per_v2: c_of_k(200.0),
        circuit: Some(FingerCircuit { rho_sc_ohm_m: 1e5, gap_um: 0.1 }),
        stack: LayerStack::PAPER,
        ultrasonic: Some(Exponential::LITERATURE),
    }
}

/// Writes the device file of the virtual display measured on `carriers`
/// (one carrier: the eq3 model; the default seven: the circuit model),
/// U_max `u_max_v`; returns its path and the file as read.
fn device_file(dir: &Path, name: &str, carriers: Option<Vec<Carrier>>, u_max_v: f64) -> (String, DeviceFile) {
    let protocol = match carriers {
        Some(carriers) => Protocol { carriers, ..Protocol::default() },
        None => Protocol::default(),
    };
    let s = measure(&truth(), &protocol, &Noise::default(), 3);
    let cal = calibrate(&s.measurements, Settings::default());
    let text = DeviceFile::from_calibration(&cal, &s.measurements, u_max_v).to_toml();
    let path = write(dir, name, &text);
    let file = DeviceFile::read(Path::new(&path)).unwrap();
    (path, file)
}

fn eq3_file(dir: &Path, u_max_v: f64) -> (String, DeviceFile) {
    let (path, file) = device_file(dir, "eq3.toml", Some(vec![sine(1000.0)]), u_max_v);
    assert_eq!(file.electrovibration.as_ref().unwrap().model, "eq3");
    (path, file)
}

/// A profile from 0.55 to 1.6: below mu_HD, in the band, and above what
/// U_max reaches.
fn profile(dir: &Path) -> String {
    let rows: String = (0..=40).map(|i| format!("{},{}\n", i as f64 * 0.25, 0.55 + 1.05 * (i as f64 / 40.0))).collect();
    write(dir, "p.csv", &format!("x_mm,mu\n{rows}"))
}

/// The rows of a CSV after its comments and header.
fn rows(text: &str) -> Vec<Vec<f64>> {
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

fn comments(text: &str) -> Vec<&str> {
    text.lines().filter(|l| l.starts_with('#')).collect()
}

/// Runs haptex, expecting success; returns stderr.
#[track_caller]
fn ok(args: &[&str]) -> String {
    let out = haptex(args);
    assert!(out.status.success(), "haptex {}: {}", args.join(" "), stderr(&out));
    stderr(&out)
}

/// Runs haptex, expecting a refusal; returns stderr.
#[track_caller]
fn refused(args: &[&str]) -> String {
    let out = haptex(args);
    assert!(!out.status.success(), "haptex {} was not refused", args.join(" "));
    stderr(&out)
}

fn stack_flags(s: &LayerStack) -> Vec<String> {
    [("--eps-sc", s.eps_sc), ("--eps-i", s.eps_i), ("--d-sc-mm", s.d_sc_mm), ("--d-i-mm", s.d_i_mm)]
        .iter()
        .flat_map(|(flag, v)| [flag.to_string(), v.to_string()])
        .collect()
}

/// The eq3 model: `voltage --device F` gives, value for value, what
/// `voltage` gives with the file's mu_HD, stack, U_max and the k of its
/// carrier section.
#[test]
fn voltage_with_an_eq3_device_file_equals_the_explicit_mu_hd_and_k() {
    let dir = tempfile::tempdir().unwrap();
    let (file_path, file) = eq3_file(dir.path(), 80.0);
    let p = profile(dir.path());
    let e = file.electrovibration.as_ref().unwrap();
    let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
    ok(&["voltage", "--profile", &p, "--device", &file_path, "-o", a.to_str().unwrap()]);
    let mut explicit: Vec<String> = ["voltage", "--profile", &p, "-o", b.to_str().unwrap()].map(String::from).to_vec();
    explicit.extend(stack_flags(&file.stack));
    for (flag, v) in [("--mu-hd", e.mu_hd.value), ("--k-mm2-per-n", e.carriers[0].k_mm2_per_n), ("--u-max", 80.0)] {
        explicit.extend([flag.to_string(), v.to_string()]);
    }
    ok(&explicit.iter().map(String::as_str).collect::<Vec<_>>());
    let (a, b) = (std::fs::read_to_string(a).unwrap(), std::fs::read_to_string(b).unwrap());
    assert_eq!(rows(&a), rows(&b));
    assert!(rows(&a).iter().any(|r| r[2] > 0.0 && r[2] < 80.0), "the profile reaches the band");
}

/// The circuit model: `voltage --device F --carrier-hz 300` equals
/// `voltage --force-model circuit` with the file's rho_sc, gap and c (as
/// k) on that carrier: the same force gain.
#[test]
fn voltage_with_a_circuit_device_file_equals_the_explicit_circuit_force_gain() {
    let dir = tempfile::tempdir().unwrap();
    let (file_path, file) = device_file(dir.path(), "circuit.toml", None, 100.0);
    let e = file.electrovibration.as_ref().unwrap();
    assert_eq!(e.model, "circuit");
    let c = e.circuit.as_ref().unwrap();
    let p = profile(dir.path());
    let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
    let err =
        ok(&["voltage", "--profile", &p, "--device", &file_path, "--carrier-hz", "300", "-o", a.to_str().unwrap()]);
    assert!(err.contains("the device file's circuit"), "{err}");
    let mut explicit: Vec<String> = ["voltage", "--profile", &p, "-o", b.to_str().unwrap()].map(String::from).to_vec();
    explicit.extend(stack_flags(&file.stack));
    for (flag, v) in [
        ("--mu-hd", e.mu_hd.value),
        ("--k-mm2-per-n", c.k_mm2_per_n),
        ("--rho-sc-ohm-m", c.rho_sc_ohm_m.value),
        ("--gap-um", c.gap_um.value),
        ("--carrier-hz", 300.0),
        ("--u-max", 100.0),
    ] {
        explicit.extend([flag.to_string(), v.to_string()]);
    }
    explicit.extend(["--force-model".to_string(), "circuit".to_string()]);
    ok(&explicit.iter().map(String::as_str).collect::<Vec<_>>());
    let (a, b) = (std::fs::read_to_string(a).unwrap(), std::fs::read_to_string(b).unwrap());
    assert_eq!(rows(&a), rows(&b));
    // Both say the carrier, so that `haptex play` plays them on it only.
    for text in [&a, &b] {
        assert!(text.contains("designed for the carrier: sine 300 Hz"), "{text}");
    }
}

/// An eq3 file knows c only on the carriers it was measured on: another is
/// refused, naming both.
#[test]
fn an_eq3_device_file_refuses_an_unmeasured_carrier_naming_both() {
    let dir = tempfile::tempdir().unwrap();
    let (file_path, _) = eq3_file(dir.path(), 100.0);
    let p = profile(dir.path());
    let err = refused(&["voltage", "--profile", &p, "--device", &file_path, "--carrier-hz", "250"]);
    assert!(err.contains("calibrated on sine 1000 Hz and this design plays sine 250 Hz"), "{err}");
    assert!(err.contains(&file_path), "{err}");
    // `haptex play` with the file refuses to play on that carrier too.
    let u = dir.path().join("u.csv");
    ok(&["voltage", "--profile", &p, "--device", &file_path, "-o", u.to_str().unwrap()]);
    let w = dir.path().join("u.wav");
    let err = refused(&[
        "play",
        "--profile",
        u.to_str().unwrap(),
        "--device",
        &file_path,
        "--velocity",
        "50",
        "--carrier-hz",
        "250",
        "-o",
        w.to_str().unwrap(),
    ]);
    assert!(err.contains("this design plays sine 250 Hz"), "{err}");
}

/// A corrupt device file is refused naming the file and the line (a TOML
/// error) or the key (a value out of range).
#[test]
fn a_corrupt_device_file_is_refused_naming_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let (file_path, _) = eq3_file(dir.path(), 100.0);
    let p = profile(dir.path());
    let text = std::fs::read_to_string(&file_path).unwrap();
    let line = text.lines().position(|l| l.starts_with("u_max_v")).unwrap() + 1;
    let broken = write(dir.path(), "broken.toml", &text.replacen("u_max_v = ", "u_max_v = = ", 1));
    let err = refused(&["voltage", "--profile", &p, "--device", &broken]);
    assert!(err.contains(&format!("{broken}: line {line}")), "{err}");
    let out_of_range = write(dir.path(), "range.toml", &text.replacen("u_max_v = 100", "u_max_v = -5", 1));
    let err = refused(&["voltage", "--profile", &p, "--device", &out_of_range]);
    assert!(err.contains(&format!("{out_of_range}: u_max_v")), "{err}");
    let missing = dir.path().join("missing.toml");
    let err = refused(&["voltage", "--profile", &p, "--device", missing.to_str().unwrap()]);
    assert!(err.contains("missing.toml"), "{err}");
    let not_text = dir.path().join("binary.toml");
    std::fs::write(&not_text, [0xff, 0xfe, 0x00]).unwrap();
    let err =
        refused(&["play", "--profile", &p, "--device", not_text.to_str().unwrap(), "--velocity", "9", "-o", "x.wav"]);
    assert!(err.contains("binary.toml: not UTF-8 text"), "{err}");
}

/// The flags that set what the file sets are refused with it, naming both.
#[test]
fn flags_the_device_file_sets_are_refused_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let (f, _) = eq3_file(dir.path(), 100.0);
    let p = profile(dir.path());
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["voltage", "--profile", &p, "--mu-hd", "0.5"], "--mu-hd"),
        (vec!["voltage", "--profile", &p, "--k-mm2-per-n", "150"], "--k-mm2-per-n"),
        (vec!["voltage", "--profile", &p, "--area-exponent", "0.8"], "--area-exponent"),
        (vec!["voltage", "--profile", &p, "--eps-sc", "1000"], "--eps-sc"),
        (vec!["voltage", "--profile", &p, "--d-i-mm", "0.002"], "--d-i-mm"),
        (vec!["voltage", "--profile", &p, "--force-model", "circuit"], "--force-model"),
        (vec!["voltage", "--profile", &p, "--rho-sc-ohm-m", "1e5"], "--rho-sc-ohm-m"),
        (vec!["voltage", "--profile", &p, "--gap-um", "0.1"], "--gap-um"),
        (
            vec!["voltage", "--profile", &p, "--display", "combined", "--ultrasonic-calibration", "u.csv"],
            "--ultrasonic-calibration",
        ),
        (vec!["check", "--profile", &p, "--mu-hd", "0.5"], "--mu-hd"),
        (vec!["check", "--profile", &p, "--fe-k"], "--fe-k"),
        (vec!["check", "--profile", &p, "--eps-i", "5"], "--eps-i"),
        (vec!["map", "voltage", "--map", "m.csv", "-o", "v.csv", "--k-mm2-per-n", "150"], "--k-mm2-per-n"),
    ];
    for (mut args, flag) in cases {
        args.extend(["--device", &f]);
        let err = refused(&args);
        assert!(
            err.contains("cannot be used with") && err.contains(flag) && err.contains("--device"),
            "{args:?}: {err}"
        );
    }
    // The carrier flags of check and map are the device file's only.
    let err = refused(&["check", "--profile", &p, "--carrier-hz", "300"]);
    assert!(err.contains("--device"), "{err}");
}

/// U_max: the file's by default; a lower --u-max is used, a higher one
/// refused naming both values; no voltage is ever above the file's.
#[test]
fn no_voltage_above_the_device_files_u_max_and_a_higher_u_max_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (f, _) = eq3_file(dir.path(), 60.0);
    let p = profile(dir.path());
    let err = refused(&["voltage", "--profile", &p, "--device", &f, "--u-max", "61"]);
    assert!(err.contains("--u-max 61 is above the U_max = 60 V RMS of device file"), "{err}");
    let highest = |extra: &[&str]| {
        let out = dir.path().join("u.csv");
        let mut args = vec!["voltage", "--profile", &p, "--device", &f, "-o", out.to_str().unwrap()];
        args.extend(extra);
        ok(&args);
        rows(&std::fs::read_to_string(out).unwrap()).iter().map(|r| r[2]).fold(0.0, f64::max)
    };
    assert_eq!(highest(&[]), 60.0, "the profile asks for more than U_max: clipped at the file's");
    assert_eq!(highest(&["--u-max", "45"]), 45.0);
    // The combined display with the file's plate keeps the voltage within it too.
    let out = dir.path().join("ua.csv");
    ok(&["voltage", "--profile", &p, "--device", &f, "--display", "combined", "-o", out.to_str().unwrap()]);
    let text = std::fs::read_to_string(&out).unwrap();
    let header: Vec<&str> = text.lines().find(|l| !l.starts_with('#')).unwrap().split(',').collect();
    let column = header.iter().position(|c| *c == "voltage_v").unwrap();
    assert!(rows(&text).iter().all(|r| r[column] <= 60.0));
    // play and live refuse a --u-max above the file's before any output.
    let u = dir.path().join("u.csv");
    ok(&["voltage", "--profile", &p, "--device", &f, "-o", u.to_str().unwrap()]);
    let err = refused(&[
        "play",
        "--profile",
        u.to_str().unwrap(),
        "--device",
        &f,
        "--u-max",
        "70",
        "--velocity",
        "50",
        "-o",
        "x.wav",
    ]);
    assert!(err.contains("above the U_max = 60 V RMS"), "{err}");
    let err = refused(&["live", "--profile", u.to_str().unwrap(), "--device-file", &f, "--u-max", "70", "--stdin"]);
    assert!(err.contains("above the U_max = 60 V RMS"), "{err}");
}

/// Every output of a design made with a device file names the file and
/// its SHA-256: voltage's CSV and JSON, play's WAV sidecar and CSV, map
/// voltage's CSV and NPY sidecar.
#[test]
fn every_output_names_the_device_file_and_its_sha256() {
    let dir = tempfile::tempdir().unwrap();
    let (f, _) = eq3_file(dir.path(), 100.0);
    let sha = haptex_core::io::sha256_file(Path::new(&f)).unwrap();
    let p = profile(dir.path());
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let names = |text: &str, what: &str| {
        assert!(text.contains(&format!("device file {f}")) && text.contains(&sha), "{what} does not name it: {text}");
    };
    ok(&["voltage", "--profile", &p, "--device", &f, "-o", &path("u.csv")]);
    let u = std::fs::read_to_string(path("u.csv")).unwrap();
    names(&comments(&u).join("\n"), "voltage CSV");
    ok(&["voltage", "--profile", &p, "--device", &f, "-o", &path("u.json")]);
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path("u.json")).unwrap()).unwrap();
    assert_eq!(json["device_file"]["sha256"], sha.as_str());
    assert_eq!(json["device_file"]["path"], f.as_str());
    ok(&[
        "play",
        "--profile",
        &path("u.csv"),
        "--device",
        &f,
        "--velocity",
        "50",
        "-o",
        &path("u.wav"),
        "--csv",
        &path("s.csv"),
    ]);
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path("u.wav.json")).unwrap()).unwrap();
    assert_eq!(sidecar["source"]["device_file"]["sha256"], sha.as_str(), "{sidecar}");
    names(&comments(&std::fs::read_to_string(path("s.csv")).unwrap()).join("\n"), "play CSV");
    ok(&["play", "--check", &path("u.wav")]);
    // Played without --device, the sidecar still says what the design was made with.
    ok(&["play", "--profile", &path("u.csv"), "--velocity", "50", "-o", &path("v.wav")]);
    let sidecar = std::fs::read_to_string(path("v.wav.json")).unwrap();
    assert!(sidecar.contains("design_device_file") && sidecar.contains(&sha), "{sidecar}");
    // map voltage: the CSV's comments and the NPY's sidecar.
    let map: String = (0..3).flat_map(|j| (0..3).map(move |i| format!("{i},{j},{}\n", 0.7 + 0.1 * i as f64))).collect();
    let m = write(dir.path(), "m.csv", &format!("x_mm,y_mm,mu\n{map}"));
    ok(&["map", "voltage", "--map", &m, "--device", &f, "-o", &path("mv.csv")]);
    names(&comments(&std::fs::read_to_string(path("mv.csv")).unwrap()).join("\n"), "map CSV");
    ok(&["map", "voltage", "--map", &m, "--device", &f, "-o", &path("mv.npy")]);
    names(&std::fs::read_to_string(path("mv.npy.json")).unwrap(), "map NPY sidecar");
    // The NPY map still reads back (its sidecar's new field included).
    ok(&[
        "map",
        "sample-path",
        "--voltage-map",
        &path("mv.npy"),
        "--trajectory",
        &write(dir.path(), "path.csv", "t_s,x_mm,y_mm\n0,0.5,0.5\n1,1.5,1\n"),
        "-o",
        &path("sp.csv"),
    ]);
}

/// A design made with one device file is not played with another.
#[test]
fn play_refuses_a_design_made_with_another_device_file() {
    let dir = tempfile::tempdir().unwrap();
    let (f, _) = eq3_file(dir.path(), 100.0);
    let (g, _) = device_file(dir.path(), "other.toml", Some(vec![sine(1000.0)]), 90.0);
    let p = profile(dir.path());
    let u = dir.path().join("u.csv");
    ok(&["voltage", "--profile", &p, "--device", &f, "-o", u.to_str().unwrap()]);
    let err = refused(&["play", "--profile", u.to_str().unwrap(), "--device", &g, "--velocity", "50", "-o", "x.wav"]);
    assert!(err.contains("was designed with a device file of SHA-256") && err.contains(&g), "{err}");
}

/// POST `body` (JSON) to `path`; returns the whole answer.
fn http_post(port: u16, path: &str, body: &str) -> String {
    use std::io::{Read, Write};
    let mut socket = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    socket.set_read_timeout(Some(std::time::Duration::from_secs(20))).unwrap();
    write!(
        socket,
        "POST {path} HTTP/1.1\r\nHost: localhost\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\
         Connection: close\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    let mut answer = String::new();
    socket.read_to_string(&mut answer).unwrap();
    answer
}

fn http_get(port: u16, path: &str) -> String {
    use std::io::{Read, Write};
    let mut socket = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    socket.set_read_timeout(Some(std::time::Duration::from_secs(20))).unwrap();
    write!(socket, "GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n").unwrap();
    let mut answer = String::new();
    socket.read_to_string(&mut answer).unwrap();
    answer
}

/// `haptex serve --device-file F`: the page's device fields (the config's
/// defaults) and the API's default device are the file's; a request that
/// gives a constant still uses it, and only a design of the file's own
/// device is labelled with the file.
#[cfg(unix)]
#[test]
fn serve_with_a_device_file_makes_it_the_default_device() {
    use std::io::BufReader;
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    let (f, file) = eq3_file(dir.path(), 70.0);
    let sha = haptex_core::io::sha256_file(Path::new(&f)).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_haptex"))
        .args(["serve", "--addr", "127.0.0.1:0", "--device-file", &f])
        .env_remove("HAPTEX_LIBRARY")
        .env_remove("HAPTEX_DB")
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let (port, seen) = common::listening_port(&mut stderr);
    let answers = {
        let config = http_get(port, "/api/config");
        let body = http_post(
            port,
            "/api/voltage?format=csv",
            r#"{"profile":{"x_mm":[0,1,2],"mu":[0.6,0.9,1.2]},"source":{"kind":"test"}}"#,
        );
        let explicit = http_post(
            port,
            "/api/voltage?format=csv",
            r#"{"profile":{"x_mm":[0,1,2],"mu":[0.6,0.9,1.2]},"device":{"mu_hd":0.5}}"#,
        );
        (config, body, explicit)
    };
    let _ = Command::new("kill").args(["-TERM", &child.id().to_string()]).status();
    let _ = child.wait();
    let (config, designed, explicit) = answers;
    assert!(seen.contains("default device: designed with device file"), "{seen}");
    let json: serde_json::Value = serde_json::from_str(config.split("\r\n\r\n").nth(1).unwrap()).unwrap();
    let default = |name: &str| {
        json["device_params"].as_array().unwrap().iter().find(|p| p["name"] == name).unwrap()["default"].as_f64()
    };
    let e = file.electrovibration.as_ref().unwrap();
    assert_eq!(default("mu_hd"), Some(e.mu_hd.value));
    assert_eq!(default("k_mm2_per_n"), Some(e.carriers[0].k_mm2_per_n));
    assert_eq!(default("u_max_v"), Some(70.0));
    assert_eq!(default("eps_sc"), Some(file.stack.eps_sc));
    assert_eq!(json["data"]["device_file_sha256"], sha.as_str());
    assert!(designed.starts_with("HTTP/1.1 200"), "{designed}");
    assert!(designed.contains(&format!("# designed with device file {f}")) && designed.contains(&sha), "{designed}");
    assert!(designed.contains(&format!("# device_file: {f} sha256 {sha}")), "{designed}");
    assert!(explicit.starts_with("HTTP/1.1 200"), "{explicit}");
    assert!(!explicit.contains("designed with device file"), "not the file's device: {explicit}");
}

/// A recipe made with a device file replays with it (its recorded path),
/// and is refused with another file, naming the recipe's field.
#[test]
fn a_recipe_made_with_a_device_file_replays_only_with_a_file_of_its_sha256() {
    let dir = tempfile::tempdir().unwrap();
    let (f, _) = eq3_file(dir.path(), 100.0);
    let (g, _) = device_file(dir.path(), "other.toml", Some(vec![sine(1000.0)]), 90.0);
    let sha = haptex_core::io::sha256_file(Path::new(&f)).unwrap();
    let recipe = serde_json::json!({
        "format": "haptex-recipe/1",
        "haptex_version": env!("CARGO_PKG_VERSION"),
        "device_file": f,
        "device_file_sha256": sha,
        "downloads": [{
            "file": "voltage.csv", "method": "POST", "path": "/api/voltage?format=csv",
            "body": { "profile": { "x_mm": [0, 1, 2], "mu": [0.6, 0.9, 1.2] } },
        }],
    });
    let recipe_path = write(dir.path(), "recipe.json", &recipe.to_string());
    let out = dir.path().join("out");
    let err = ok(&["recipe", "run", &recipe_path, "-o", out.to_str().unwrap(), "--allow-unpinned"]);
    let voltage = std::fs::read_to_string(out.join("voltage.csv")).unwrap();
    assert!(voltage.contains(&format!("designed with device file {f}")), "{voltage}\n{err}");
    let err =
        refused(&["recipe", "run", &recipe_path, "-o", out.to_str().unwrap(), "--allow-unpinned", "--device-file", &g]);
    assert!(err.contains("device_file_sha256") && err.contains(&sha) && err.contains(&g), "{err}");
    // Made without a device file: refused with one.
    let mut without = recipe.clone();
    without.as_object_mut().unwrap().retain(|k, _| !k.starts_with("device_file"));
    let without_path = write(dir.path(), "without.json", &without.to_string());
    let err = refused(&[
        "recipe",
        "run",
        &without_path,
        "-o",
        out.to_str().unwrap(),
        "--allow-unpinned",
        "--device-file",
        &f,
    ]);
    assert!(err.contains("device_file_sha256: missing"), "{err}");
}

/// `haptex check --device F` (one FE run, coarse mesh): eq. (8) with the
/// file's constants, the voltage within its U_max; the check's CSV, the
/// voltage written from it (which `haptex play` then takes with the file)
/// and the header name the file; a circuit-model file is refused.
#[test]
fn check_with_a_device_file_names_it_and_keeps_within_its_u_max() {
    let dir = tempfile::tempdir().unwrap();
    let (f, file) = eq3_file(dir.path(), 50.0);
    let sha = haptex_core::io::sha256_file(Path::new(&f)).unwrap();
    let mu_hd = file.electrovibration.as_ref().unwrap().mu_hd.value;
    let points: String = (0..=20)
        .map(|i| format!("{},{}\n", 0.1 * i as f64, mu_hd * if (5..15).contains(&i) { 1.15 } else { 1.0 }))
        .collect();
    let target = write(dir.path(), "target.csv", &format!("x_mm,mu\n{points}"));
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let args = ["check", "--profile", &target, "--device", &f, "--mesh", "coarse", "--step", "0.1", "--run-up", "0.5"];
    let err = ok(&[&args[..], &["-o", &path("c.csv"), "--voltage-out", &path("u.csv"), "-q"]].concat());
    let check = std::fs::read_to_string(path("c.csv")).unwrap();
    assert!(check.contains(&format!("device file {f}")) && check.contains(&sha), "{check}\n{err}");
    let u = std::fs::read_to_string(path("u.csv")).unwrap();
    assert!(u.contains(&sha) && u.contains("designed for the carrier: sine 1000 Hz"), "{u}");
    assert!(rows(&check).iter().all(|r| r[2] <= 50.0));
    ok(&["play", "--profile", &path("u.csv"), "--device", &f, "--velocity", "20", "-o", &path("u.wav")]);
    let (c, _) = device_file(dir.path(), "circuit.toml", None, 100.0);
    let err = refused(&[&args[..3], &["--device", &c]].concat());
    assert!(err.contains("is of the circuit model"), "{err}");
}

/// `compensate --device F`: the design's constants come from the file (the
/// flags it sets are refused), the next design names the file and keeps
/// within its U_max, and a design made with another file is refused.
#[test]
fn compensate_with_a_device_file_names_it_and_refuses_another_files_design() {
    let dir = tempfile::tempdir().unwrap();
    let (f, file) = eq3_file(dir.path(), 100.0);
    let (g, _) = device_file(dir.path(), "other.toml", Some(vec![sine(1000.0)]), 90.0);
    let p = profile(dir.path());
    let u0 = dir.path().join("u0.csv");
    ok(&["voltage", "--profile", &p, "--device", &f, "-o", u0.to_str().unwrap()]);
    // Strokes: the target felt 10% high inside the band, with 1% noise
    // that differs between the three strokes.
    let mu_hd = file.electrovibration.as_ref().unwrap().mu_hd.value;
    let mut strokes = Vec::new();
    for s in 0..3 {
        let rows: String = (0..=400)
            .map(|i| {
                let x = i as f64 * 0.025;
                let target = 0.55 + 1.05 * (x / 10.0);
                let felt = if target > mu_hd { mu_hd + 1.1 * (target - mu_hd) } else { mu_hd };
                let noise = 1.0 + 0.01 * (((i * 31 + s * 17) % 13) as f64 / 6.0 - 1.0);
                format!("{x},{},0.5\n", felt * 0.5 * noise)
            })
            .collect();
        strokes.push(write(dir.path(), &format!("s{s}.csv"), &format!("x_mm,ft_n,fn_n\n{rows}")));
    }
    let u1 = dir.path().join("u1.csv");
    let mut args = vec!["compensate", "--design", u0.to_str().unwrap(), "--device", &f, "-o", u1.to_str().unwrap()];
    args.push("--measured");
    args.extend(strokes.iter().map(String::as_str));
    ok(&args);
    let text = std::fs::read_to_string(&u1).unwrap();
    assert!(comments(&text).iter().any(|c| c.contains("device file sha256")), "{text}");
    let u_col = rows(&text).iter().map(|r| r[2]).fold(0.0, f64::max);
    assert!(u_col <= 100.0, "{u_col}");
    let mut refused_args = args.clone();
    refused_args[4] = &g;
    let err = refused(&refused_args);
    assert!(err.contains("was designed with a device file of SHA-256"), "{err}");
    let mut with_mu = args.clone();
    with_mu.extend(["--mu-hd", "0.5"]);
    let err = refused(&with_mu);
    assert!(err.contains("--mu-hd") && err.contains("--device"), "{err}");
}
