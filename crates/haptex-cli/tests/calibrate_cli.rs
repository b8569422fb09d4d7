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
