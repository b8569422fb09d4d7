//! `haptex compensate` end to end: measured compensation on a virtual
//! device (the FE finger on a display whose truth differs from the
//! design's constants), the history carried by the design, and bad input.
//!
//! The FE tests are heavy: run them with `--profile ci`.

mod common;
use std::path::Path;

use common::{haptex, stderr, write};
use haptex_core::FrictionProfile;
use haptex_core::io::Table;
use haptex_core::recording::rng::SplitMix64;
use haptex_core::ultrasonic::UltrasonicDevice;
use haptex_fem::render::{DEFAULT_LOAD_N_PER_MM, RenderSettings, feel_display};

/// The virtual device: what "really" happens on the display, unlike the
/// design's device file (docs/measured-compensation.md, "Worked example").
///
/// - the FE finger (shipped model, visco-elastic, default mesh, 0.0133
///   N/mm, 20 mm/s, 0.05 mm steps, 1 mm run-up) with the skin-display
///   friction TRUE_MU_HD;
/// - an air gap of 0.1 um between skin and display, which eq. (8) knows
///   nothing of (it lowers the attraction to 0.69 of eq. 3's);
/// - sensor noise: each stroke sampled every 0.01 mm (the FE's forces
///   interpolated between its 0.05 mm steps), Gaussian noise of SD
///   SIGMA_FN on Fn and SIGMA_FT on Ft per sample;
/// - stroke-to-stroke variation: each stroke's friction scaled by 1 + N(0,
///   STROKE_GAIN_SD) (moisture) and its positions shifted by N(0,
///   STROKE_SHIFT_SD_MM) (the position sensor's offset).
struct VirtualDevice {
    settings: RenderSettings,
    plate: Option<UltrasonicDevice>,
}

const TRUE_MU_HD: f64 = 0.5;
const AIR_GAP_UM: f64 = 0.1;
const SIGMA_FN: f64 = 1.5e-4;
const SIGMA_FT: f64 = 1.0e-4;
const STROKE_GAIN_SD: f64 = 0.01;
const STROKE_SHIFT_SD_MM: f64 = 0.005;
const STROKES: usize = 8;

impl VirtualDevice {
    fn new(plate: Option<UltrasonicDevice>) -> Self {
        let mut settings = RenderSettings::new(TRUE_MU_HD, DEFAULT_LOAD_N_PER_MM);
        settings.scenario.step_mm = 0.05;
        settings.air_gap_um = AIR_GAP_UM;
        Self { settings, plate }
    }

    /// The FE finger's contact-area coefficient on the display at 0 V,
    /// mm^2/N (contact length per unit normal force, per mm of width).
    fn k_fe_mm2_per_n(&self, target: &FrictionProfile) -> f64 {
        let felt = feel_display(target, &vec![0.0; target.len()], None, &self.settings, &mut |_| {}).unwrap();
        felt.k_mm2_per_n.iter().sum::<f64>() / felt.k_mm2_per_n.len() as f64
    }

    /// Plays the design in `design` and writes STROKES strokes
    /// (`x_mm,ft_n,fn_n`) into `dir`, seeded by `seed`; returns their paths.
    fn measure(&self, design: &Path, dir: &Path, seed: u64) -> Vec<String> {
        let table = Table::read_file(design).unwrap();
        let target = FrictionProfile::from_table(&table).unwrap();
        let voltage = table.require("voltage_v").unwrap();
        let amplitude = table.column("amplitude_um");
        let vibration = match (&self.plate, amplitude) {
            (Some(plate), Some(a)) => Some((a, plate)),
            _ => None,
        };
        let felt = feel_display(&target, voltage, vibration, &self.settings, &mut |_| {}).unwrap();
        // The slide s runs from 0 at x = x0 - run-up; keep it from 0.5 mm
        // on (past the pre-sliding) to the end.
        let start = target.x_mm()[0] - self.settings.run_up_mm;
        let rows: Vec<_> = felt.result.plane().unwrap().history.iter().filter(|r| r.slide_mm >= 0.5).collect();
        let slide: Vec<f64> = rows.iter().map(|r| r.slide_mm).collect();
        let ft: Vec<f64> = rows.iter().map(|r| r.ft_n).collect();
        let fnn: Vec<f64> = rows.iter().map(|r| r.fn_n).collect();
        let (s0, s1) = (slide[0], slide[slide.len() - 1]);
        let samples = ((s1 - s0) / 0.01).floor() as usize;
        (0..STROKES)
            .map(|k| {
                let mut rng = SplitMix64::fork(seed, k as u64);
                let gain = 1.0 + STROKE_GAIN_SD * rng.normal();
                let shift = STROKE_SHIFT_SD_MM * rng.normal();
                let mut text = String::from("x_mm,ft_n,fn_n\n");
                for i in 0..=samples {
                    let s = s0 + 0.01 * i as f64;
                    let at = |v: &[f64]| haptex_core::profile::interpolate(&slide, v, s);
                    let ft = gain * at(&ft) + SIGMA_FT * rng.normal();
                    let fnn = at(&fnn) + SIGMA_FN * rng.normal();
                    text += &format!("{},{ft},{fnn}\n", start + s + shift);
                }
                write(dir, &format!("stroke-{seed}-{k}.csv"), &text)
            })
            .collect()
    }
}

/// The target: a smooth bump from 0.52 to 0.58 over 4 mm (81 points),
/// inside the virtual device's band (0.5 .. above 0.9 at 200 V).
fn bump_target(dir: &Path, low: f64, high: f64) -> String {
    let mut text = String::from("x_mm,mu\n");
    for i in 0..=80 {
        let x = 0.05 * i as f64;
        text += &format!("{x},{}\n", low + (high - low) * (-((x - 2.0) / 0.6f64).powi(2)).exp());
    }
    write(dir, "target.csv", &text)
}

/// The report's rows: (iteration, rms_error, noise_floor, limited_by).
fn report(path: &Path) -> Vec<(usize, f64, f64, String)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("iteration,rms_error,noise_floor,max_error,lag_mm,strokes,limited_by"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[0].parse().unwrap(), f[1].parse().unwrap(), f[2].parse().unwrap(), f[6].to_string())
        })
        .collect()
}

/// Every voltage (and amplitude) of a design file within its limits.
fn assert_within_limits(design: &Path, u_max: f64, a_max: Option<f64>) {
    let table = Table::read_file(design).unwrap();
    for &u in table.require("voltage_v").unwrap() {
        assert!((0.0..=u_max).contains(&u), "{}: {u} V above U_max {u_max}", design.display());
    }
    if let Some(a_max) = a_max {
        for &a in table.require("amplitude_um").unwrap() {
            assert!((0.0..=a_max).contains(&a), "{}: {a} um above a_max {a_max}", design.display());
        }
    }
}

#[test]
fn measured_compensation_reaches_the_noise_floor_within_four_iterations_on_the_fe_virtual_device() {
    // Issue 36's acceptance. The design's device file is 30% off the
    // virtual device: mu_HD 0.35 against the true 0.5, k 1.3 times the FE
    // finger's own; the display also has a 0.1 um air gap eq. (8) ignores.
    // U_max is 200 V (the paper's 100 V would not reach the target's top
    // with a device file this far off). Asserted: eq. (8)'s design is at
    // least 5 noise floors off (the premise); the error is within
    // 1.5 noise floors (the stop rule, haptex_core::ilc::STOP_FACTOR) on
    // design 4 at the latest (eq. 8's is design 0); no design has a sample
    // above U_max.
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name);
    let target = bump_target(dir.path(), 0.52, 0.58);
    let device = VirtualDevice::new(None);
    let target_profile = FrictionProfile::read_csv_file(Path::new(&target)).unwrap();
    let k = 1.3 * device.k_fe_mm2_per_n(&target_profile);
    let k = format!("{k:.1}");
    let constants = ["--mu-hd", "0.35", "--k-mm2-per-n", &k, "--u-max", "200"];
    let design0 = p("u0.csv");
    let mut args = vec!["voltage", "--profile", &target, "-o", design0.to_str().unwrap()];
    args.extend(constants);
    let out = haptex(&args);
    assert!(out.status.success(), "{}", stderr(&out));
    let mut design = design0;
    let mut rows = Vec::new();
    for iteration in 0..=4 {
        assert_within_limits(&design, 200.0, None);
        let strokes = device.measure(&design, dir.path(), 1000 + iteration);
        let next = p(&format!("u{}.csv", iteration + 1));
        let mut args = vec![
            "compensate".to_string(),
            "--design".into(),
            design.to_str().unwrap().into(),
            "-o".into(),
            next.to_str().unwrap().into(),
            "--report".into(),
            p("report.csv").to_str().unwrap().into(),
            "--measured".into(),
        ];
        args.extend(strokes);
        args.extend(constants.iter().map(|s| s.to_string()));
        if iteration == 0 {
            args.extend(["--png".to_string(), p("iteration0.png").to_str().unwrap().into()]);
        }
        let out = haptex(&args.iter().map(String::as_str).collect::<Vec<_>>());
        let err = stderr(&out);
        assert!(out.status.success(), "{err}");
        eprintln!("{err}");
        rows = report(&p("report.csv"));
        assert_eq!(rows.len(), iteration as usize + 1, "the history travels with the design");
        design = next;
        let (_, rms, floor, limit) = rows.last().unwrap().clone();
        if rms <= 1.5 * floor {
            assert!(err.contains("at the noise floor: a further iteration would chase noise"), "{err}");
            assert!(limit == "noise_floor", "{limit}");
            break;
        }
    }
    assert_within_limits(&design, 200.0, None);
    let (_, rms0, floor0, _) = rows[0];
    assert!(rms0 >= 5.0 * floor0, "eq. (8)'s error {rms0:.3e} is not 5 noise floors ({floor0:.3e}): {rows:?}");
    let (last, rms, floor, _) = rows.last().unwrap();
    assert!(*rms <= 1.5 * floor && *last <= 4, "not at the noise floor after 4 iterations: {rows:?}");
    assert!(std::fs::metadata(p("iteration0.png")).unwrap().len() > 1000);
}

#[test]
fn measured_compensation_of_the_combined_display_lowers_the_error() {
    // The combined display (split strategy, the literature plate in both
    // the design and the virtual device) on a target from 0.42 to 0.56
    // around the true mu_HD 0.5 (the plate renders below it, the voltage
    // above); the device file's k 1.3 times the FE finger's and the 0.1 um
    // air gap make eq. (8)'s voltage too weak. Asserted: the error falls
    // at each of two iterations, no sample above U_max or a_max.
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name);
    let target = bump_target(dir.path(), 0.42, 0.56);
    let plate = UltrasonicDevice::literature_default(None).unwrap();
    let a_max = plate.a_max_um();
    let device = VirtualDevice::new(Some(plate));
    let target_profile = FrictionProfile::read_csv_file(Path::new(&target)).unwrap();
    let k = format!("{:.1}", 1.3 * device.k_fe_mm2_per_n(&target_profile));
    let constants = ["--mu-hd", "0.5", "--k-mm2-per-n", &k, "--u-max", "200", "--display", "combined"];
    let design0 = p("u0.csv");
    let mut args = vec!["voltage", "--profile", &target, "-o", design0.to_str().unwrap()];
    args.extend(constants);
    let out = haptex(&args);
    assert!(out.status.success(), "{}", stderr(&out));
    let mut design = design0;
    let mut rows = Vec::new();
    for iteration in 0..=2 {
        assert_within_limits(&design, 200.0, Some(a_max));
        let strokes = device.measure(&design, dir.path(), 2000 + iteration);
        let next = p(&format!("u{}.csv", iteration + 1));
        let mut args = vec![
            "compensate".to_string(),
            "--design".into(),
            design.to_str().unwrap().into(),
            "-o".into(),
            next.to_str().unwrap().into(),
            "--report".into(),
            p("report.csv").to_str().unwrap().into(),
            "--measured".into(),
        ];
        args.extend(strokes);
        args.extend(constants.iter().map(|s| s.to_string()));
        let out = haptex(&args.iter().map(String::as_str).collect::<Vec<_>>());
        let err = stderr(&out);
        assert!(out.status.success(), "{err}");
        eprintln!("{err}");
        rows = report(&p("report.csv"));
        design = next;
    }
    assert_within_limits(&design, 200.0, Some(a_max));
    for pair in rows.windows(2) {
        assert!(
            pair[1].1 < pair[0].1 || pair[1].1 <= 1.5 * pair[1].2,
            "the error did not fall (nor reach the noise floor): {rows:?}"
        );
    }
}

/// A small design (eq. 8 at mu_HD 0.5 of a 0.52 .. 0.58 bump, 41 points
/// over 2 mm) and strokes around it, for the fast tests.
fn small_design(dir: &Path) -> String {
    let mut text = String::from("x_mm,mu\n");
    for i in 0..=40 {
        let x = 0.05 * i as f64;
        text += &format!("{x},{}\n", 0.52 + 0.06 * (-((x - 1.0) / 0.4f64).powi(2)).exp());
    }
    let target = write(dir, "target.csv", &text);
    let design = dir.join("u0.csv").to_str().unwrap().to_string();
    let out = haptex(&["voltage", "--profile", &target, "--mu-hd", "0.5", "-o", &design]);
    assert!(out.status.success(), "{}", stderr(&out));
    design
}

/// A stroke of the target itself plus noise of SD 0.002 in mu, over
/// [from, to] mm.
fn stroke_of_target(dir: &Path, name: &str, seed: u64, from: f64, to: f64) -> String {
    let mut rng = SplitMix64::new(seed);
    let mut text = String::from("x_mm,ft_n,fn_n\n");
    let n = ((to - from) / 0.01).round() as usize;
    for i in 0..=n {
        let x = from + 0.01 * i as f64;
        let mu = 0.52 + 0.06 * (-((x - 1.0) / 0.4f64).powi(2)).exp() + 0.002 * rng.normal();
        text += &format!("{x},{},0.5\n", mu * 0.5);
    }
    write(dir, name, &text)
}

#[test]
fn at_the_noise_floor_the_design_is_kept_and_the_history_grows() {
    // Strokes that feel the target up to noise: the error is the noise of
    // the mean, within 1.5 noise floors; the design is written unchanged
    // (the same voltages) with the history line, and the next call reads
    // it back as iteration 1.
    let dir = tempfile::tempdir().unwrap();
    let design = small_design(dir.path());
    let strokes: Vec<String> =
        (0..4).map(|k| stroke_of_target(dir.path(), &format!("s{k}.csv"), k, -0.2, 2.2)).collect();
    let next = dir.path().join("u1.csv").to_str().unwrap().to_string();
    let mut args = vec!["compensate", "--design", &design, "--mu-hd", "0.5", "-o", &next, "--measured"];
    args.extend(strokes.iter().map(String::as_str));
    let out = haptex(&args);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("at the noise floor: a further iteration would chase noise"), "{err}");
    assert!(err.contains("limited by: the noise floor"), "{err}");
    let before = Table::read_file(Path::new(&design)).unwrap();
    let after = Table::read_file(Path::new(&next)).unwrap();
    assert_eq!(before.require("voltage_v").unwrap(), after.require("voltage_v").unwrap());
    assert!(after.comments()[0].contains("ilc iteration 0: RMS error"), "{:?}", after.comments());
    let again = dir.path().join("u2.csv").to_str().unwrap().to_string();
    let mut args = vec!["compensate", "--design", &next, "--mu-hd", "0.5", "-o", &again, "--measured"];
    args.extend(strokes.iter().map(String::as_str));
    let out = haptex(&args);
    let err = stderr(&out);
    assert!(out.status.success() && err.contains("iteration 1 of"), "{err}");
}

#[test]
fn one_stroke_gives_no_noise_floor_and_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let design = small_design(dir.path());
    let stroke = stroke_of_target(dir.path(), "s.csv", 1, -0.2, 2.2);
    let out = haptex(&["compensate", "--design", &design, "--mu-hd", "0.5", "-o", "/dev/null", "--measured", &stroke]);
    let err = stderr(&out);
    assert!(!out.status.success());
    assert!(err.contains("1 stroke: the noise floor") && err.contains("at least 2"), "{err}");
}

#[test]
fn a_stroke_short_of_the_design_span_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let design = small_design(dir.path());
    let full = stroke_of_target(dir.path(), "full.csv", 1, -0.2, 2.2);
    let short = stroke_of_target(dir.path(), "short.csv", 2, 0.5, 2.2);
    let next = dir.path().join("u1.csv");
    let out = haptex(&[
        "compensate",
        "--design",
        &design,
        "--mu-hd",
        "0.5",
        "-o",
        next.to_str().unwrap(),
        "--measured",
        &full,
        &short,
    ]);
    let err = stderr(&out);
    assert!(!out.status.success());
    assert!(err.contains(&format!("{short}: the stroke covers x = 0.5 .. 2.2 mm, the design 0 .. 2 mm")), "{err}");
    assert!(!next.exists(), "nothing written");
}

#[test]
fn a_bad_stroke_csv_is_named_by_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let design = small_design(dir.path());
    let good = stroke_of_target(dir.path(), "good.csv", 1, -0.2, 2.2);
    let bad = write(dir.path(), "bad.csv", "x_mm,ft_n,fn_n\n0,0.25,0.5\n0.01,0.25,abc\n");
    let out =
        haptex(&["compensate", "--design", &design, "--mu-hd", "0.5", "-o", "/dev/null", "--measured", &good, &bad]);
    let err = stderr(&out);
    assert!(!out.status.success());
    assert!(err.contains(&format!("{bad}, line 3, column 'fn_n': not a number")), "{err}");
}

#[test]
fn a_design_above_u_max_is_refused() {
    // The design was made for 100 V; this display stops at 50 V.
    let dir = tempfile::tempdir().unwrap();
    let design = small_design(dir.path());
    let strokes: Vec<String> =
        (0..2).map(|k| stroke_of_target(dir.path(), &format!("s{k}.csv"), k, -0.2, 2.2)).collect();
    let out = haptex(&[
        "compensate",
        "--design",
        &design,
        "--mu-hd",
        "0.5",
        "--u-max",
        "50",
        "-o",
        "/dev/null",
        "--measured",
        &strokes[0],
        &strokes[1],
    ]);
    let err = stderr(&out);
    assert!(!out.status.success());
    assert!(err.contains(&format!("{design}, line")) && err.contains("column 'voltage_v'"), "{err}");
    assert!(err.contains("outside 0 .. U_max = 50 V"), "{err}");
}
