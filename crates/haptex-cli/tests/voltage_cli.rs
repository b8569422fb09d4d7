//! `haptex voltage` end to end: the binary, its files and its errors.

mod common;
use common::{haptex, stderr, write};

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

/// Issue 15: `--relative` maps the profile divided by its flat-surface
/// friction and scaled to mu_HD (paper Fig. 2). An FE-like bump around
/// mu_skin = 0.5 gives 0 V with the paper's mu_HD = 1 as it is; relative
/// to mu_flat = 0.5 it is 1.0, 1.1, 1.15, 1.3, 0.9, and eq. (8) by hand,
/// U = sqrt(50217.6 (mu_rel - 1)) V (docs/physics.md), gives 0, 70.864,
/// 86.791, 122.73 -> clipped at U_max = 100 V, 0 V (0.01 V). The file says
/// how the profile was made, and its samples stay within the U_max it states.
#[test]
fn relative_maps_the_profile_over_its_flat_value_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let profile = write(dir.path(), "p.csv", "x_mm,mu\n0,0.5\n1,0.55\n2,0.575\n3,0.65\n4,0.45\n");
    let raw = haptex(&["voltage", "--profile", &profile, "--format", "json"]);
    assert!(raw.status.success(), "{}", stderr(&raw));
    let json: serde_json::Value = serde_json::from_slice(&raw.stdout).unwrap();
    assert_eq!(json["summary"]["voltage_max_v"], 0.0);
    assert!(stderr(&raw).contains("(--relative)"), "{}", stderr(&raw));

    let out_path = dir.path().join("v.csv");
    let out =
        haptex(&["voltage", "--profile", &profile, "--relative", "--flat-mu", "0.5", "-o", out_path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(&out_path).unwrap();
    let comment = text.lines().nth(1).unwrap();
    assert!(
        comment.starts_with("# relative profile (paper Fig. 2a): mu = mu_profile / mu_flat * mu_HD with mu_flat = 0.5 (given) and mu_HD = 1;"),
        "{comment}"
    );
    let u_max: f64 = comment.split("U_max = ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert_eq!(u_max, 100.0);
    let table = haptex_core::io::Table::read(text.as_bytes(), "v.csv").unwrap();
    assert_eq!(table.column("mu").unwrap(), [1.0, 1.1, 1.15, 0.65 / 0.5, 0.9]);
    let u = table.column("voltage_v").unwrap();
    for (got, want) in u.iter().zip([0.0, 70.864, 86.791, 100.0, 0.0]) {
        assert!((got - want).abs() < 0.01, "{u:?}");
    }
    assert!(u.iter().all(|&v| v <= u_max));
    assert!(stderr(&out).contains("mu_flat = 0.5 (given)"), "{}", stderr(&out));

    // Without --flat-mu: the median (0.55), said to be an estimate.
    let out = haptex(&["voltage", "--profile", &profile, "--relative", "--format", "json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let relative = &json["summary"]["relative"];
    assert_eq!((relative["flat_mu"].as_f64(), relative["flat_mu_source"].as_str()), (Some(0.55), Some("median")));
    assert_eq!(relative["mu_hd"], 1.0);
    assert!(stderr(&out).contains("mu_flat = 0.55 (the median of the profile, an estimate)"), "{}", stderr(&out));
}

#[test]
fn relative_bad_flat_values_fail_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let profile = write(dir.path(), "p.csv", "x_mm,mu\n0,0.5\n1,0.6\n");
    for bad in ["0", "-0.5", "NaN", "inf", "11", "abc"] {
        let out = haptex(&["voltage", "--profile", &profile, "--relative", "--flat-mu", bad]);
        assert!(!out.status.success(), "--flat-mu {bad}");
        assert!(stderr(&out).contains("--flat-mu"), "{bad}: {}", stderr(&out));
        assert!(out.stdout.is_empty());
    }
    // --flat-mu alone would be ignored: refused, naming --relative.
    let out = haptex(&["voltage", "--profile", &profile, "--flat-mu", "0.5"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--relative"), "{}", stderr(&out));
    // A median that is no friction coefficient: say to give --flat-mu.
    let zero = write(dir.path(), "n.csv", "x_mm,mu\n0,0\n1,0\n2,0.3\n");
    let out = haptex(&["voltage", "--profile", &zero, "--relative"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("median mu is 0,") && stderr(&out).contains("give flat_mu"), "{}", stderr(&out));
}

/// The paper's Fig. 2 in one pipe: `haptex predict` says which mu_flat
/// its profile has, and `haptex voltage --relative` with it renders the
/// bump where it rises above flat.
#[test]
fn predicted_profile_names_its_flat_value_for_relative() {
    let dir = tempfile::tempdir().unwrap();
    let bump = dir.path().join("bump.csv");
    let out = haptex(&[
        "predict",
        "--surface",
        "bump",
        "--x0",
        "5",
        "--width",
        "1.5",
        "--height",
        "0.3",
        "-q",
        "-o",
        bump.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(&bump).unwrap();
    assert!(
        text.contains("# flat-surface friction mu_flat = 0.5 (Ft/Fn on a flat surface: the FE skin friction mu_skin)"),
        "{text}"
    );
    let out =
        haptex(&["voltage", "--profile", bump.to_str().unwrap(), "--relative", "--flat-mu", "0.5", "--format", "json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let u: Vec<f64> = json["voltage_v"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let mu: Vec<f64> = json["mu"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert!(u.iter().cloned().fold(0.0, f64::max) > 0.0);
    for (m, v) in mu.iter().zip(&u) {
        assert!(*v <= 100.0 && (*v > 0.0) == (*m > 1.0), "mu_rel {m}, U {v}");
    }
}
