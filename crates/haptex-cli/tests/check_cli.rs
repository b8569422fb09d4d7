//! `haptex simulate --surface display` and `haptex check` end to end:
//! outputs, the voltage limit, and bad input.

mod common;
use common::{haptex, stderr};

/// Rows of a CSV after its `#` lines, as numbers, with the header.
fn table(text: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header = lines.next().unwrap().split(',').map(str::to_string).collect();
    (header, lines.map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect())
}

#[test]
fn check_writes_the_felt_profile_and_a_voltage_within_u_max() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    // A raised plateau: 0.5 (mu_HD) then 0.56 then 0.5.
    let mut target = String::from("x_mm,mu\n");
    for i in 0..=40 {
        let x = 0.1 * i as f64;
        target += &format!("{x},{}\n", if (1.0..3.0).contains(&x) { 0.56 } else { 0.5 });
    }
    std::fs::write(p("target.csv"), target).unwrap();
    let out = haptex(&[
        "check",
        "--profile",
        &p("target.csv"),
        "--compensate",
        "--max-runs",
        "3",
        "--mesh",
        "coarse",
        "--step",
        "0.1",
        "-o",
        &p("check.csv"),
        "--voltage-out",
        &p("u.csv"),
        "--png",
        &p("check.png"),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("trial 1 (eq. 8)") && err.contains("FE finger's contact length"), "{err}");
    assert!(err.contains("\nstopped: "), "the compensation says why it stopped: {err}");
    let (header, rows) = table(&std::fs::read_to_string(p("check.csv")).unwrap());
    assert_eq!(header, ["x_mm", "target_mu", "voltage_v", "felt_mu", "k_fe_mm2_per_n"]);
    assert_eq!(rows.len(), 41);
    // The voltage file pairs its samples with the stated limit and stays
    // within it; the check's voltage column is the same voltage.
    let text = std::fs::read_to_string(p("u.csv")).unwrap();
    assert!(text.starts_with("# haptex check:"), "{text}");
    let (header, u) = table(&text);
    assert_eq!(header, ["x_mm", "mu", "voltage_v"]);
    for (a, b) in u.iter().zip(&rows) {
        assert!(a[2] >= 0.0 && a[2] <= 100.0);
        assert_eq!(a[2], b[2]);
    }
    assert!(std::fs::metadata(p("check.png")).unwrap().len() > 1000);

    // The voltage drives the FE display as `simulate --surface display`.
    let out = haptex(&[
        "simulate",
        "--surface",
        "display",
        "--voltage",
        &p("u.csv"),
        "--load",
        "0.0133",
        "--slide",
        "2",
        "--mesh",
        "coarse",
        "-q",
        "-o",
        &p("felt.csv"),
        "--history",
        &p("history.csv"),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (header, rows) = table(&std::fs::read_to_string(p("history.csv")).unwrap());
    assert_eq!(&header[header.len() - 3..], ["voltage_v", "fe_n", "fe_contact_n"]);
    assert!(rows.iter().any(|r| r[r.len() - 2] > 0.0));
}

#[test]
fn bad_display_and_check_input_is_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    std::fs::write(p("u.csv"), "x_mm,voltage_v\n0,10\n1,-5\n").unwrap();
    for (args, expected) in [
        (vec!["simulate", "--surface", "display", "-q"], "--voltage"),
        (vec!["simulate", "--surface", "bump", "--constant-voltage", "50", "-q"], "display only"),
        (vec!["simulate", "--surface", "display", "--voltage", &p("u.csv"), "-q"], "line 3"),
        (vec!["simulate", "--surface", "display", "--constant-voltage", "5000", "-q"], "MPa"),
        (vec!["simulate", "--surface", "display", "--constant-voltage", "nan", "-q"], "voltage"),
        (vec!["check", "--profile", &p("missing.csv"), "-q"], "missing.csv"),
    ] {
        let out = haptex(&args);
        assert!(!out.status.success(), "{args:?} succeeded");
        let err = stderr(&out);
        assert!(err.contains(expected), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// Issue 35 ("No internal error reaches a client as a success"), the
/// command line's part: what the FE check cannot run is refused before
/// any FE run by the check's own rule (`render::check_target`, which the
/// web API applies too), naming the file or the flag, not reported as a
/// bug. Before: positions 0 and 1e-300 mm failed after the finger model
/// was set up, with "positions must be strictly increasing: 1 follows 1"
/// (both became 1 mm on the FE slide after its 1 mm run-up).
#[test]
fn check_refuses_what_the_finger_model_cannot_run_naming_the_file_or_flag() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    std::fs::write(p("tiny-gap.csv"), "x_mm,mu\n0,0.6\n1e-300,0.7\n").unwrap();
    std::fs::write(p("subnormal.csv"), "x_mm,mu\n0,0.6\n5e-324,0.7\n2,0.6\n").unwrap();
    std::fs::write(p("short.csv"), "x_mm,mu\n0,0.6\n0.02,0.7\n").unwrap();
    for (args, expected) in [
        (vec!["check", "--profile", &p("tiny-gap.csv"), "-q"], vec![p("tiny-gap.csv"), "1e-6 mm".into()]),
        (vec!["check", "--profile", &p("subnormal.csv"), "-q"], vec![p("subnormal.csv"), "1e-6 mm".into()]),
        (
            vec!["check", "--profile", &p("tiny-gap.csv"), "--display", "combined", "-q"],
            vec![p("tiny-gap.csv"), "1e-6 mm".into()],
        ),
        (vec!["check", "--profile", &p("short.csv"), "-q"], vec!["--step 0.05".into(), "0.02 mm long".into()]),
        (
            vec!["check", "--profile", &p("short.csv"), "--step", "0.01", "--run-up", "500", "-q"],
            vec!["--run-up 500".into()],
        ),
    ] {
        let out = haptex(&args);
        assert!(!out.status.success(), "{args:?} succeeded");
        let err = stderr(&out);
        for e in expected {
            assert!(err.contains(&e), "{args:?}: {e:?} not in {err}");
        }
        for wrong in ["a bug", "strictly increasing", "panicked", "finger model on the display"] {
            assert!(!err.contains(wrong), "{args:?}: {err}");
        }
    }
}

#[test]
fn voltage_compensate_writes_the_compensated_voltage_with_its_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let mut target = String::from("x_mm,mu\n");
    for i in 0..=30 {
        let x = 0.1 * i as f64;
        target += &format!("{x},{}\n", 0.5 + 0.05 * (x * 2.0).sin().abs());
    }
    std::fs::write(p("target.csv"), target).unwrap();
    let out = haptex(&["voltage", "--profile", &p("target.csv"), "--mu-hd", "0.5", "--compensate", "-o", &p("u.csv")]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(p("u.csv")).unwrap();
    let first = text.lines().next().unwrap();
    assert!(first.starts_with("# compensated on the FE finger") && first.contains("RMS error"), "{first}");
    let (_, rows) = table(&text);
    assert!(rows.iter().all(|r| (0.0..=100.0).contains(&r[2])));
    let out = haptex(&["voltage", "--profile", &p("target.csv"), "--compensate", "--method", "normalized"]);
    assert!(!out.status.success() && stderr(&out).contains("--method physical"));
}

/// `haptex check --display combined`: a dip below mu_HD and a rise above it
/// are both inside the combined display's band, so nothing is outside it;
/// the plate carries the dip and the voltage the rise (split strategy),
/// each within its limit (U_max, the literature default's a_max = 2.3
/// um); the drive file is the design the check applied, with both limits
/// in its comments; flags that do not apply are refused by name.
#[test]
fn combined_display_check_renders_below_and_above_mu_hd() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let mut target = String::from("x_mm,mu\n");
    for i in 0..=40 {
        let x = 0.1 * i as f64;
        let mu = if (0.8..1.6).contains(&x) {
            0.4
        } else if (2.4..3.2).contains(&x) {
            0.56
        } else {
            0.5
        };
        target += &format!("{x},{mu}\n");
    }
    std::fs::write(p("target.csv"), target).unwrap();
    let args = ["check", "--profile", &p("target.csv"), "--mesh", "coarse", "--step", "0.1", "--display", "combined"];
    let mut run = args.to_vec();
    let (c, u, png) = (p("c.csv"), p("u.csv"), p("c.png"));
    run.extend(["-o", &c, "--voltage-out", &u, "--png", &png]);
    let out = haptex(&run);
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("outside the band: 0.0% of the length below it, 0.0% above it"), "{err}");
    assert!(err.contains("literature default, not a calibration"), "{err}");
    let (header, rows) = table(&std::fs::read_to_string(&c).unwrap());
    assert_eq!(header, ["x_mm", "target_mu", "voltage_v", "amplitude_um", "felt_mu"]);
    assert_eq!(rows.len(), 41);
    for r in &rows {
        let (mu, voltage, amplitude) = (r[1], r[2], r[3]);
        assert!((0.0..=100.0).contains(&voltage) && (0.0..=2.3).contains(&amplitude), "{r:?}");
        // Split: the plate only below mu_HD, the voltage only above.
        if mu < 0.5 {
            assert!(amplitude > 0.0 && voltage == 0.0, "{r:?}");
        } else if mu > 0.5 {
            assert!(voltage > 0.0 && amplitude == 0.0, "{r:?}");
        }
    }
    let text = std::fs::read_to_string(&u).unwrap();
    assert!(text.contains("at most U_max = 100 V") && text.contains("at most a_max = 2.3 um"), "{text}");
    let (header, drive) = table(&text);
    assert_eq!(header, ["x_mm", "mu", "voltage_v", "amplitude_um"]);
    for (d, r) in drive.iter().zip(&rows) {
        assert_eq!((d[2], d[3]), (r[2], r[3]), "the drive file is the design the check applied");
    }
    assert!(std::fs::metadata(&png).unwrap().len() > 1000);
    for (extra, expect) in [
        (vec!["--compensate"], "--compensate is for the electrovibration display"),
        (vec!["--fe-k"], "--fe-k is for the electrovibration display"),
        (vec!["--weight", "2"], "--weight is the weighted strategy's"),
    ] {
        let mut run = args.to_vec();
        run.extend(extra);
        let out = haptex(&run);
        assert!(!out.status.success() && stderr(&out).contains(expect), "{}", stderr(&out));
    }
    let out = haptex(&["check", "--profile", &p("target.csv"), "--strategy", "bias"]);
    assert!(!out.status.success() && stderr(&out).contains("--strategy is for an ultrasonic or combined display"));
}

/// `haptex check --model 3d` (issue 39): the 3D fingertip on the display,
/// its load in N, eq. (3)'s attraction on its real contact area; the
/// report states k as an area over the normal force, and `--fe-k` designs
/// eq. (8) with it, which the 3D finger then feels far more closely than
/// eq. (8) with the paper's k = 200 mm^2/N. Measured on this target
/// (0.5, a plateau of 0.52, renderable at 100 V by either k), coarse mesh:
/// RMS error 7.5e-3 with k = 200, 3.7e-4 with the finger's own k of
/// 68 mm^2/N. 3D-only flags are refused in 2D by name.
#[test]
fn check_3d_measures_k_as_an_area_and_fe_k_designs_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let mut target = String::from("x_mm,mu\n");
    for i in 0..=30 {
        let x = 0.1 * i as f64;
        target += &format!("{x},{}\n", if (1.0..2.0).contains(&x) { 0.52 } else { 0.5 });
    }
    std::fs::write(p("target.csv"), target).unwrap();
    let (target, voltage) = (p("target.csv"), p("u.csv"));
    let run = |extra: &[&str]| {
        let mut args = vec![
            "check",
            "--profile",
            &target,
            "--model",
            "3d",
            "--mesh",
            "coarse",
            "--step",
            "0.1",
            "--direction-deg",
            "20",
            "--voltage-out",
            &voltage,
        ];
        args.extend(extra);
        let out = haptex(&args);
        let err = stderr(&out);
        assert!(out.status.success(), "{err}");
        err
    };
    let rms = |err: &str, line: &str| -> f64 {
        let l = err.lines().find(|l| l.starts_with(line)).unwrap_or_else(|| panic!("{line} not in {err}"));
        let value = l.split("RMS error ").nth(1).unwrap().split([',', ';']).next().unwrap();
        value.parse().unwrap()
    };
    let paper = run(&[]);
    assert!(paper.contains("3D FE finger sliding at 20 degrees") && paper.contains("load 0.5 N)"), "{paper}");
    assert!(paper.contains("the 3D finger's contact area per normal force is"), "{paper}");
    let check = p("check.csv");
    let own = run(&["--fe-k", "-o", &check]);
    let (header, rows) = table(&std::fs::read_to_string(p("check.csv")).unwrap());
    assert_eq!(header, ["x_mm", "target_mu", "voltage_v", "felt_mu", "k_fe_mm2_per_n"]);
    // The 3D finger's k at 0.5 N: a real area over a force, tens of mm^2/N.
    for r in &rows {
        assert!((20.0..150.0).contains(&r[4]), "k {}", r[4]);
    }
    // The whole target is renderable with either k (the RMS is taken over
    // the plateau too).
    for err in [&paper, &own] {
        assert!(err.contains("not renderable (mu_RS < mu_HD = 0.5): 0.0% of the length; above mu at U_max: 0.0%"));
    }
    let (with_paper_k, with_own_k) = (rms(&paper, "felt friction"), rms(&own, "felt friction"));
    eprintln!("RMS error: eq. (8) with k = 200: {with_paper_k:.3e}; with the 3D finger's k: {with_own_k:.3e}");
    assert!(with_own_k < 0.1 * with_paper_k, "{with_own_k} vs {with_paper_k}\n{own}");
    assert!(rms(&own, "eq. (8) with k = 200") == with_paper_k, "{own}");
    let (_, u) = table(&std::fs::read_to_string(p("u.csv")).unwrap());
    assert!(u.iter().all(|r| (0.0..=100.0).contains(&r[2])));

    for (args, expected) in [
        (vec!["--direction-deg", "30"], "--direction-deg applies to --model 3d only"),
        (vec!["--model", "3d", "--direction-deg", "inf"], "--direction-deg inf must be a finite angle"),
    ] {
        let mut full = vec!["check", "--profile", &target, "-q", "--mesh", "coarse"];
        full.extend(args.iter());
        let out = haptex(&full);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr(&out).contains(expected), "{args:?}: {}", stderr(&out));
    }
}
