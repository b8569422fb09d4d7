//! `haptex voltage --display ultrasonic|combined` end to end: the columns
//! of each display, the limits stated beside the samples, the summary, the
//! calibration file's errors, and the flags that do not go together.

use haptex_core::io::Table;

mod common;
use common::{haptex, stderr, write};

const EXAMPLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/examples/bump_friction.csv");
const CALIBRATION: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/examples/ultrasonic_calibration.csv");

/// The number after `key` in `text`.
fn stated(text: &str, key: &str) -> f64 {
    let rest = text.split(key).nth(1).unwrap_or_else(|| panic!("'{key}' not in:\n{text}"));
    rest.split([' ', ';', ',']).next().unwrap().parse().unwrap()
}

/// The example bump (0.98 .. 1.22) on the combined display with the
/// shipped illustrative calibration, every strategy: the file has
/// `x_mm,mu,voltage_v,amplitude_um`, states U_max and a_max, keeps every
/// sample within them, and the friction the pair gives (mu_HD rho(a)
/// (1 + 1.99133e-5 U^2), rho linear in the calibration) is the target
/// wherever it is in the band; the descent is rendered (nothing below the
/// band), the top above U_max's reach is clipped as by eq. (8).
#[test]
fn combined_display_writes_both_channels_within_their_limits() {
    let dir = tempfile::tempdir().unwrap();
    let cal = Table::read(std::fs::read(CALIBRATION).unwrap().as_slice(), "cal").unwrap();
    let (ca, cr) = (cal.column("amplitude_um").unwrap().to_vec(), cal.column("relative_friction").unwrap().to_vec());
    let rho = |a: f64| {
        let i = ca.iter().position(|&x| x >= a).unwrap().max(1);
        cr[i - 1] + (a - ca[i - 1]) / (ca[i] - ca[i - 1]) * (cr[i] - cr[i - 1])
    };
    for strategy in ["split", "bias", "weighted"] {
        let out_path = dir.path().join(format!("{strategy}.csv"));
        let out = haptex(&[
            "voltage",
            "--profile",
            EXAMPLE,
            "--display",
            "combined",
            "--strategy",
            strategy,
            "--ultrasonic-calibration",
            CALIBRATION,
            "-o",
            out_path.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        let text = std::fs::read_to_string(&out_path).unwrap();
        assert!(text.lines().any(|l| l == "x_mm,mu,voltage_v,amplitude_um"), "{text}");
        let (u_max, a_max) = (stated(&text, "at most U_max = "), stated(&text, "at most a_max = "));
        assert_eq!((u_max, a_max), (100.0, 2.5));
        let t = Table::read(text.as_bytes(), "d.csv").unwrap();
        let (mu, u, a) = (t.column("mu").unwrap(), t.column("voltage_v").unwrap(), t.column("amplitude_um").unwrap());
        let mut inside = 0;
        for i in 0..mu.len() {
            assert!((0.0..=u_max).contains(&u[i]) && (0.0..=a_max).contains(&a[i]), "{strategy} row {i}");
            let felt = rho(a[i]) * (1.0 + 1.991_33e-5 * u[i] * u[i]);
            if mu[i] <= 1.1991 {
                inside += 1;
                assert!((felt - mu[i]).abs() < 1e-5, "{strategy}: mu {} felt {felt}", mu[i]);
            } else {
                assert!(u[i] == 100.0 && a[i] == 0.0);
            }
        }
        assert!(inside > 900);
        let summary = stderr(&out);
        assert!(
            summary.contains(&format!("display: combined (electrovibration + ultrasonic), strategy {strategy}")),
            "{summary}"
        );
        assert!(summary.contains("renderable band: mu 0.1600 .. 1.1991"), "{summary}");
        assert!(summary.contains("below the band, a clipped at a_max (U = 0 V): 0.00% of the length"), "{summary}");
        assert!(summary.contains("above the band, U clipped at U_max (a = 0): 4.59% of the length"), "{summary}");
        assert!(!summary.contains("literature default"), "{summary}");
    }
}

/// The ultrasonic display alone: `x_mm,mu,amplitude_um`, no voltage; the
/// literature default is said to be one, in the file and the summary; a
/// friction above mu_HD is reported, a = 0 there.
#[test]
fn ultrasonic_display_writes_amplitudes_only_and_names_its_model() {
    let out = haptex(&["voltage", "--profile", EXAMPLE, "--display", "ultrasonic"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8(out.stdout.clone()).unwrap();
    assert!(text.lines().any(|l| l == "x_mm,mu,amplitude_um"), "{text}");
    assert!(!text.contains("voltage_v"));
    assert!(text.contains("literature default, not a calibration of this device"), "{text}");
    let a_max = stated(&text, "at most a_max = ");
    assert_eq!(a_max, 2.3);
    let t = Table::read(text.as_bytes(), "d.csv").unwrap();
    assert!(t.column("amplitude_um").unwrap().iter().all(|&a| (0.0..=a_max).contains(&a)));
    let summary = stderr(&out);
    assert!(summary.contains("warning: mu > mu_HD over"), "{summary}");
    assert!(summary.contains("warning: the ultrasonic model is the literature default"), "{summary}");
}

/// JSON: the summary carries the display, strategy, band, each channel's
/// limits and the bias level; a channel not in use has no array.
#[test]
fn json_summary_of_a_weighted_design() {
    let out = haptex(&[
        "voltage",
        "--profile",
        EXAMPLE,
        "--display",
        "combined",
        "--strategy",
        "weighted",
        "--weight",
        "4",
        "--format",
        "json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let s = &json["summary"];
    assert_eq!(
        (s["display"].as_str(), s["strategy"].as_str(), s["weight"].as_f64()),
        (Some("combined"), Some("weighted"), Some(4.0))
    );
    assert_eq!(s["electrovibration"]["u_max_v"], 100.0);
    assert_eq!(s["ultrasonic"]["a_max_um"], 2.3);
    assert_eq!(s["ultrasonic"]["source"], "literature_default");
    assert!(s["bias"]["amplitude_um"].as_f64().unwrap() > 0.0);
    assert_eq!(json["voltage_v"].as_array().unwrap().len(), 1001);
    assert_eq!(json["amplitude_um"].as_array().unwrap().len(), 1001);

    let out = haptex(&["voltage", "--profile", EXAMPLE, "--display", "ultrasonic", "--format", "json"]);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(json.get("voltage_v").is_none() && json["summary"].get("electrovibration").is_none());
    assert!(json["summary"].get("strategy").is_none());
}

/// A bad calibration stops the run with its file, line and column, and
/// writes nothing.
#[test]
fn bad_calibration_names_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("d.csv");
    for (text, expected) in [
        (
            "amplitude_um,relative_friction\n0,1\n0.5,0.8\n1.0,0.85\n",
            "line 4, column 'relative_friction': the relative friction must decrease strictly",
        ),
        (
            "amplitude_um,relative_friction\n0,1\n0.5,0.8\n0.5,0.7\n",
            "line 4, column 'amplitude_um': amplitudes must increase strictly",
        ),
        (
            "amplitude_um,relative_friction\n0,1\n# comment\n0.5,1.5\n",
            "line 4, column 'relative_friction': relative_friction must be from 1e-6 to 1",
        ),
        ("amplitude_um,relative_friction\n0,1\n0.5,x\n", "line 3, column 'relative_friction': not a number"),
    ] {
        let cal = write(dir.path(), "cal.csv", text);
        let out = haptex(&[
            "voltage",
            "--profile",
            EXAMPLE,
            "--display",
            "combined",
            "--ultrasonic-calibration",
            &cal,
            "-o",
            out_path.to_str().unwrap(),
        ]);
        assert!(!out.status.success());
        let message = stderr(&out);
        assert!(message.contains(&format!("cal.csv, {expected}")), "{message}");
        assert!(!out_path.exists());
    }
}

/// Flags that belong to another display are refused, naming the flag;
/// a_max beyond the calibration is refused, not extrapolated.
#[test]
fn flags_of_another_display_are_refused() {
    for (args, expected) in [
        (&["--strategy", "bias"][..], "--strategy is for an ultrasonic or combined display"),
        (
            &["--ultrasonic-calibration", CALIBRATION][..],
            "--ultrasonic-calibration is for an ultrasonic or combined display",
        ),
        (&["--display", "ultrasonic", "--strategy", "bias"][..], "give --display combined"),
        (&["--display", "combined", "--weight", "2"][..], "give --strategy weighted"),
        (
            &["--display", "combined", "--method", "normalized"][..],
            "--method normalized (eq. 9) is for the electrovibration display",
        ),
        (&["--display", "combined", "--compensate"][..], "--compensate is for the electrovibration display"),
        (
            &["--display", "combined", "--ultrasonic-calibration", CALIBRATION, "--a-max-um", "3"][..],
            "does not extrapolate",
        ),
        (&["--display", "combined", "--a-max-um", "-1"][..], "a_max_um must be from 0.001 to 100 um"),
        (
            &["--display", "combined", "--strategy", "weighted", "--weight", "-1"][..],
            "weight must be from 0 to 1000000",
        ),
    ] {
        let mut all = vec!["voltage", "--profile", EXAMPLE];
        all.extend_from_slice(args);
        let out = haptex(&all);
        assert!(!out.status.success(), "{args:?}");
        assert!(stderr(&out).contains(expected), "{args:?}: {}", stderr(&out));
    }
}

/// The electrovibration display stays the default: `--display
/// electrovibration` writes the same bytes as no flag.
#[test]
fn electrovibration_stays_the_default() {
    let plain = haptex(&["voltage", "--profile", EXAMPLE]);
    let explicit = haptex(&["voltage", "--profile", EXAMPLE, "--display", "electrovibration"]);
    assert!(plain.status.success() && explicit.status.success());
    assert_eq!(plain.stdout, explicit.stdout);
    assert_eq!(plain.stderr, explicit.stderr);
    assert!(String::from_utf8_lossy(&plain.stdout).lines().any(|l| l == "x_mm,mu,voltage_v"));
}

/// A combined design is not played as if its voltage were all of it: the
/// drive signal would carry the voltage without the plate's vibration.
#[test]
fn play_refuses_a_combined_design() {
    // Without a stated a_max (header comment removed) and without
    // --a-max-um, play does not know channel 2's limit: it refuses, and
    // never plays the voltage alone (the two-channel path is tested in
    // play_cli.rs).
    let dir = tempfile::tempdir().unwrap();
    let design = dir.path().join("d.csv");
    let out = haptex(&["voltage", "--profile", EXAMPLE, "--display", "combined", "-q", "-o", design.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(&design).unwrap();
    let bare: String = text.lines().filter(|l| !l.starts_with('#')).map(|l| format!("{l}\n")).collect();
    std::fs::write(&design, bare).unwrap();
    let wav = dir.path().join("d.wav");
    let out = haptex(&["play", "--profile", design.to_str().unwrap(), "--velocity", "50", "-o", wav.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("no header comment stating its a_max: give --a-max-um"), "{}", stderr(&out));
    assert!(!wav.exists());
}
