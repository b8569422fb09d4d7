//! `haptex voltage` end to end: the binary, its files and its errors.

use std::path::Path;
use std::process::{Command, Output};

fn haptex(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_haptex")).args(args).output().expect("run haptex")
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Issue 2 acceptance through the command line: the paper's constants with
/// U_max = 1000 V give 112.05, 158.46, 224.09 V (within 0.01 V).
#[test]
fn paper_voltages_through_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    let profile = write(dir.path(), "p.csv", "x_mm,mu\n0,1.25\n1,1.5\n2,2.0\n");
    let out_path = dir.path().join("v.csv");
    let out = haptex(&["voltage", "--profile", &profile, "--u-max", "1000", "-o", out_path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(&out_path).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert!(text.lines().any(|l| l == "x_mm,mu,voltage_v"));
    for (row, expected) in rows.iter().zip([112.05, 158.46, 224.09]) {
        assert!((row[2] - expected).abs() < 0.01, "{row:?}");
    }
    assert!(stderr(&out).contains("Fe/Fn = 1.99133e-5 U^2"), "{}", stderr(&out));
    // Only the output file remains: the temporary file was renamed.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
}

/// With the default U_max = 100 V the physical method clips and says so.
#[test]
fn default_u_max_clips_and_reports() {
    let dir = tempfile::tempdir().unwrap();
    let profile = write(dir.path(), "p.csv", "x_mm,mu\n0,1.25\n1,1.5\n");
    let out = haptex(&["voltage", "--profile", &profile, "--format", "json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["summary"]["clipped"]["fraction_of_length"], 1.0);
    assert_eq!(json["voltage_v"], serde_json::json!([100.0, 100.0]));
    assert!(stderr(&out).contains("clipped to U_max"), "{}", stderr(&out));
}

#[test]
fn bad_profile_names_file_and_line_and_fails() {
    let dir = tempfile::tempdir().unwrap();
    let profile = write(dir.path(), "bad.csv", "x_mm,mu\n0,1.1\n1,oops\n");
    let out = haptex(&["voltage", "--profile", &profile]);
    assert!(!out.status.success());
    let message = stderr(&out);
    assert!(message.contains("bad.csv, line 3, column 'mu'"), "{message}");
    assert!(out.stdout.is_empty());
}

#[test]
fn missing_file_and_bad_flags_fail_clearly() {
    let out = haptex(&["voltage", "--profile", "/nonexistent/p.csv"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("/nonexistent/p.csv"), "{}", stderr(&out));

    let out = haptex(&["voltage", "--profile", "x.csv", "--mu-hd", "-1"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--mu-hd"), "{}", stderr(&out));

    let out = haptex(&["voltage", "--profile", "x.csv", "--u-max", "NaN"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("u_max_v must be from 0.001 to 10000 V, got NaN"), "{}", stderr(&out));

    // Issue 13: each device constant has the API's range, checked at the
    // flag (1e308 used to be accepted and printed as 309 digits).
    let out = haptex(&["voltage", "--profile", "x.csv", "--d-sc-mm", "1e308"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("d_sc_mm must be from 1e-6 to 10 mm, got 1e308"), "{}", stderr(&out));
    assert!(stderr(&out).len() < 300, "{}", stderr(&out));
}

#[test]
fn power_law_without_normal_force_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let profile = write(dir.path(), "p.csv", "x_mm,mu\n0,1.25\n1,1.5\n");
    let out = haptex(&["voltage", "--profile", &profile, "--area-exponent", "0.5"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--fn-n"), "{}", stderr(&out));
    let out = haptex(&["voltage", "--profile", &profile, "--area-exponent", "0.5", "--fn-n", "0.4"]);
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn shipped_example_runs() {
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/examples/bump_friction.csv");
    let out = haptex(&["voltage", "--profile", example, "--method", "normalized", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).is_empty());
    let lines = String::from_utf8(out.stdout).unwrap();
    assert_eq!(lines.lines().filter(|l| !l.starts_with('#')).count(), 1 + 1001);
}
