//! `haptex calibrate` (issue 36): the shipped example calibrates into a
//! device file that reads back, with a figure; measurements that identify
//! nothing write no file; bad measurements are refused by line and column.

mod common;

use common::{haptex, stderr, write};
use haptex_core::calibration::device_file::DeviceFile;

fn example() -> String {
    format!("{}/../../data/examples/calibration-measurements.csv", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn the_shipped_example_calibrates_into_a_circuit_device_file_with_a_figure() {
    let dir = tempfile::tempdir().unwrap();
    let device = dir.path().join("my-display.toml");
    let png = dir.path().join("fit.png");
    let out = haptex(&[
        "calibrate",
        "--measurements",
        &example(),
        "-o",
        device.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--u-max",
        "150",
    ]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    for expected in ["intervals rest on 4 fingers", "rho_sc = ", "corner", "air gap g = ", "rho_inf = ", "k / stack"] {
        assert!(err.contains(expected), "{expected:?} missing from:\n{err}");
    }
    let file = DeviceFile::read(&device).unwrap();
    let e = file.electrovibration.as_ref().unwrap();
    assert_eq!(e.model, "circuit");
    assert_eq!(file.u_max_v, 150.0);
    assert_eq!(file.measurements.sha256.len(), 64);
    assert_eq!(file.ultrasonic.as_ref().unwrap().model, "exponential");
    // The example's truth (virtual_device::example_truth): mu_HD 0.6, gap 0.1 um.
    assert!(e.mu_hd.low <= 0.6 && 0.6 <= e.mu_hd.high, "{:?}", e.mu_hd);
    let gap = e.circuit.as_ref().unwrap().gap_um;
    assert!(gap.low <= 0.1 && 0.1 <= gap.high, "{gap:?}");
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
}

#[test]
fn measurements_of_one_voltage_identify_nothing_and_write_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let m = write(
        dir.path(),
        "m.csv",
        "voltage_v,carrier,carrier_hz,mu\n50,sine,1000,0.6\n50,sine,1000,0.62\n50,sine,1000,0.61\n",
    );
    let device = dir.path().join("d.toml");
    let out = haptex(&["calibrate", "--measurements", &m, "-o", device.to_str().unwrap()]);
    let err = stderr(&out);
    assert!(!out.status.success());
    assert!(err.contains("cannot be separated from 1 voltage level"), "{err}");
    assert!(err.contains("no device file written"), "{err}");
    assert!(!device.exists());
}

#[test]
fn bad_measurements_are_refused_by_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let m =
        write(dir.path(), "m.csv", "voltage_v,carrier,carrier_hz,ft_n,fn_n\n0,none,0,0.3,0.5\n60,sine,-5,0.4,0.5\n");
    let out = haptex(&["calibrate", "--measurements", &m, "-o", dir.path().join("d.toml").to_str().unwrap()]);
    let err = stderr(&out);
    assert!(!out.status.success());
    assert!(err.contains("m.csv, line 3, column 'carrier_hz'"), "{err}");
    let out = haptex(&["calibrate", "--measurements", dir.path().to_str().unwrap()]);
    assert!(stderr(&out).contains("not a regular file"), "{}", stderr(&out));
}

/// Recorded strokes with a manifest of their drives: synthetic strokes
/// (20 kHz forces with 5 mN noise, 400 Hz position) on a display whose
/// friction is mu_HD (1 + c U^2) with mu_HD = 0.5 and c = 2e-5 / V^2,
/// at 0, 40, 70 and 100 V on a 1 kHz sine, three strokes each, with a 2%
/// stroke-to-stroke variation (without it the intervals shrink to the
/// sensor noise, 0.04% on c, and the pipeline's own bias of about 5e-5 in
/// mu at 100 V shows; real strokes vary by more). Each
/// stroke's one sliding segment is a measurement; the fit holds both
/// constants (95% intervals) and names the manifest.
#[test]
fn recorded_strokes_with_a_manifest_calibrate_like_segment_rows() {
    use haptex_core::recording::rng::SplitMix64;
    use haptex_core::recording::synth::{PressProfile, StrokeModel, Trajectory};
    use haptex_core::recording::{Recording, RecordingMeta, StreamFormat, StreamMeta, Units};
    let dir = tempfile::tempdir().unwrap();
    let strokes = dir.path().join("strokes");
    let (mu_hd, c) = (0.5, 2e-5);
    let trajectory = Trajectory::starting_at(0.0).hold(0.15).move_to(40.0, 0.8).hold(0.15);
    let press = PressProfile {
        fn0_n: 0.5,
        wobble: 0.05,
        wobble_hz: 1.5,
        wobble_phase: 0.3,
        ramp_s: 0.08,
        duration_s: trajectory.duration_s(),
    };
    let fn_n = |t: f64| press.at(t);
    let mut manifest = String::new();
    let mut seed = 1;
    let mut variation = SplitMix64::new(99);
    for u in [0.0f64, 40.0, 70.0, 100.0] {
        for repetition in 1..=3 {
            let mu_u = mu_hd * (1.0 + c * u * u) * (1.0 + 0.02 * variation.normal());
            let mu = move |_x: f64| mu_u;
            let model = StrokeModel {
                force_rate_hz: 20_000.0,
                position_rate_hz: 400.0,
                trajectory: &trajectory,
                mu: &mu,
                fn_n: &fn_n,
                stiction_speed_mm_s: 2.0,
                force_noise_n: 0.005,
                position_noise_mm: 0.01,
                tones: &[],
            };
            let (force, position) = model.generate(&mut SplitMix64::new(seed));
            seed += 1;
            let meta = RecordingMeta {
                format: "haptex-recording-1".into(),
                material: "display".into(),
                material_description: String::new(),
                participant: "P1".into(),
                stroke: repetition,
                force: StreamMeta { file: String::new(), rate_hz: 20_000.0 },
                position: StreamMeta { file: String::new(), rate_hz: 400.0 },
                units: Units::default(),
                source: "calibrate_cli test".into(),
                licence: "CC0-1.0".into(),
                synthetic: true,
                notes: String::new(),
                extra: serde_json::Value::Null,
            };
            let rec = Recording::from_parts("stroke", meta, force, position).unwrap();
            let stem = format!("u{u}-{repetition}");
            rec.write(&strokes, &stem, StreamFormat::Npy).unwrap();
            manifest += &format!(
                "[[stroke]]\nrecording = \"strokes/{stem}.recording.json\"\nvoltage_v = {u}\ncarrier = \"sine\"\n\
                 carrier_hz = 1000\nrepetition = {repetition}\n\n"
            );
        }
    }
    let manifest_path = write(dir.path(), "manifest.toml", &manifest);
    let device = dir.path().join("d.toml");
    let out = haptex(&["calibrate", "--recordings", &manifest_path, "-o", device.to_str().unwrap()]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("(12 rows"), "{err}");
    let file = DeviceFile::read(&device).unwrap();
    let e = file.electrovibration.as_ref().unwrap();
    assert!(e.mu_hd.low <= mu_hd && mu_hd <= e.mu_hd.high, "{:?}", e.mu_hd);
    let fitted = e.carriers[0].c_per_v2;
    assert!(fitted.low <= c && c <= fitted.high, "{fitted:?}");
    assert!(file.measurements.file.ends_with("manifest.toml"));
    // A stroke whose recording is missing is named.
    let bad = write(dir.path(), "bad.toml", "[[stroke]]\nrecording = \"nowhere.recording.json\"\nvoltage_v = 0\n");
    let out = haptex(&["calibrate", "--recordings", &bad]);
    let err = stderr(&out);
    assert!(!out.status.success() && err.contains("stroke 1 (nowhere.recording.json)"), "{err}");
}
