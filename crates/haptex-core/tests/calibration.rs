//! Calibration from measurements (issue 36): the fits recover a virtual
//! device's constants, their 95% intervals hold the truth as often as they
//! say, and a design of experiment that cannot identify a constant is
//! reported as such.

use haptex_core::calibration::device_file::DeviceFile;
use haptex_core::calibration::measurements::Measurements;
use haptex_core::calibration::virtual_device::{Noise, Protocol, Truth, measure};
use haptex_core::calibration::{Settings, calibrate};
use haptex_core::electrovibration::{EPS0_F_PER_M, LayerStack};
use haptex_core::frequency::FingerCircuit;
use haptex_core::recording::rng::SplitMix64;
use haptex_core::signal::{Carrier, CarrierShape};
use haptex_core::ultrasonic::Exponential;

/// eq. (3)'s c for contact-area coefficient k (mm^2/N) on the paper's stack.
fn c_of_k(k: f64) -> f64 {
    EPS0_F_PER_M * k * 1e-6 / (2.0 * LayerStack::PAPER.gap_factor_m2())
}

/// A device drawn from the literature's ranges: mu_HD 0.3 to 1 (Vezzoli et
/// al. 2014 measure 0.3 to 1.2), k 100 to 400 mm^2/N (the paper's 200),
/// rho_sc 2e4 to 5e5 ohm m (corner 22 to 550 Hz; Shultz et al. 2018's
/// fits lie in 1e4 to 1e6), a gap of 0.02 to 0.3 um (Shultz et al. 2015:
/// tenths of a um), rho_inf 0.05 to 0.3 and a_c 0.4 to 1 um (Sednaoui et
/// al. 2017; Wiertlewski et al. 2016).
fn random_truth(rng: &mut SplitMix64) -> Truth {
    Truth {
        mu_hd: rng.range(0.3, 1.0),
        c_per_v2: c_of_k(rng.range(100.0, 400.0)),
        circuit: Some(FingerCircuit { rho_sc_ohm_m: 10f64.powf(rng.range(4.3, 5.7)), gap_um: rng.range(0.02, 0.3) }),
        stack: LayerStack::PAPER,
        ultrasonic: Some(Exponential { rho_inf: rng.range(0.05, 0.3), a_c_um: rng.range(0.4, 1.0), a_valid_um: 2.5 }),
    }
}

#[derive(Default)]
struct Tally {
    identified: usize,
    covered: usize,
}

impl Tally {
    fn add(&mut self, e: &haptex_core::calibration::Estimate, truth: f64) {
        if e.identified {
            self.identified += 1;
            self.covered += usize::from(e.covers(truth));
        }
    }

    fn rate(&self) -> f64 {
        self.covered as f64 / self.identified as f64
    }
}

/// The acceptance of issue 36: over 200 seeds of synthetic devices, each
/// identifiable constant's truth lies inside its 95% interval in 90 to 99%
/// of the cases (the band the issue sets; a correct 95% interval lands in
/// it with probability > 0.99 at n = 200: binomial SD 1.5%). The protocol
/// identifies every constant, so nearly all seeds count.
#[test]
fn intervals_hold_the_truth_in_90_to_99_percent_of_200_virtual_devices() {
    let mut rng = SplitMix64::new(36);
    let protocol = Protocol::default();
    let noise = Noise::default();
    let names =
        ["mu_HD (eq. 3)", "c (eq. 3, 1 kHz)", "mu_HD (circuit)", "c (circuit)", "rho_sc", "gap", "rho_inf", "a_c"];
    let mut tallies: Vec<Tally> = names.iter().map(|_| Tally::default()).collect();
    for seed in 0..200 {
        let truth = random_truth(&mut rng);
        let synthetic = measure(&truth, &protocol, &noise, 1000 + seed);
        let cal = calibrate(&synthetic.measurements, Settings::default());
        let force = cal.force.as_ref().expect("force fitted");
        let circuit = force.circuit.as_ref().expect("circuit fitted");
        let circuit_truth = truth.circuit.unwrap();
        let kilohertz = force.eq3.carriers.iter().find(|c| c.carrier.frequency_hz == 1000.0).unwrap();
        let g_1k = circuit_truth.carrier_gain(&truth.stack, &kilohertz.carrier);
        // Eq. (3) alone is the wrong model across carriers: its mu_HD is
        // pulled by the low-frequency carriers, so it is not scored here
        // (the circuit's is); its c on each carrier is c G there.
        tallies[1].add(&kilohertz.c_per_v2, truth.c_per_v2 * g_1k);
        tallies[2].add(&circuit.mu_hd, truth.mu_hd);
        tallies[3].add(&circuit.c_per_v2, truth.c_per_v2);
        tallies[4].add(&circuit.rho_sc_ohm_m, circuit_truth.rho_sc_ohm_m);
        tallies[5].add(&circuit.gap_um, circuit_truth.gap_um);
        let u = cal.ultrasonic.as_ref().expect("ultrasonic fitted");
        let e = u.exponential.as_ref().expect("exponential fitted");
        let ut = truth.ultrasonic.unwrap();
        tallies[6].add(&e.rho_inf, ut.rho_inf);
        tallies[7].add(&e.a_c_um, ut.a_c_um);
    }
    let mut report = String::new();
    for (name, t) in names.iter().zip(&tallies) {
        if t.identified > 0 {
            report += &format!("{name}: {} of {} identified, coverage {:.3}\n", t.identified, 200, t.rate());
        }
    }
    eprintln!("{report}");
    for (name, t) in names.iter().zip(&tallies).filter(|(_, t)| t.identified > 0) {
        // A gap of a few tenths of a um changes the ratio of the low- and
        // high-frequency force less than a small one (d ln(G(0)/G(inf)) /
        // dg = 2/(a+b+g) - 2/(b+g)), so four fingers leave it unidentified
        // in about one device in six (170 of 200 when this was written);
        // every other constant in at least nine in ten.
        let least = if *name == "gap" { 150 } else { 180 };
        assert!(t.identified >= least, "{name}: identified in only {} of 200 seeds\n{report}", t.identified);
        assert!((0.90..=0.99).contains(&t.rate()), "{name}: coverage {:.3}\n{report}", t.rate());
    }
}

/// One finger, named repetitions: the intervals rest on the repetitions
/// and hold for that finger (its mu_HD is the population's times its own
/// factor f; c and rho_sc do not depend on it). Coverage over 200 seeds
/// again in 90 to 99%.
#[test]
fn with_one_finger_the_intervals_hold_that_fingers_constants() {
    let mut rng = SplitMix64::new(3636);
    let protocol = Protocol { fingers: 1, repetitions: 6, ..Protocol::default() };
    let names = ["mu_HD of the finger", "c", "rho_sc"];
    let mut tallies: Vec<Tally> = names.iter().map(|_| Tally::default()).collect();
    for seed in 0..200 {
        let truth = random_truth(&mut rng);
        let s = measure(&truth, &protocol, &Noise::default(), 5000 + seed);
        let cal = calibrate(&s.measurements, Settings::default());
        let circuit = cal.force.as_ref().unwrap().circuit.as_ref().expect("circuit fitted");
        assert_eq!(
            circuit.goodness.cluster_level,
            Some(haptex_core::calibration::measurements::ClusterLevel::Repetition)
        );
        tallies[0].add(&circuit.mu_hd, truth.mu_hd * s.finger_factors[0]);
        tallies[1].add(&circuit.c_per_v2, truth.c_per_v2);
        tallies[2].add(&circuit.rho_sc_ohm_m, truth.circuit.unwrap().rho_sc_ohm_m);
    }
    let report: String = names
        .iter()
        .zip(&tallies)
        .map(|(n, t)| format!("{n}: {} identified, coverage {:.3}\n", t.identified, t.rate()))
        .collect();
    eprintln!("{report}");
    for (name, t) in names.iter().zip(&tallies) {
        assert!(t.identified >= 180, "{name}\n{report}");
        assert!((0.90..=0.99).contains(&t.rate()), "{name}: coverage {:.3}\n{report}", t.rate());
    }
}

fn paper_truth() -> Truth {
    Truth {
        mu_hd: 0.6,
        c_per_v2: c_of_k(200.0),
        circuit: Some(FingerCircuit { rho_sc_ohm_m: 1e5, gap_um: 0.1 }),
        stack: LayerStack::PAPER,
        ultrasonic: None,
    }
}

fn sine(f: f64) -> Carrier {
    Carrier { shape: CarrierShape::Sine, frequency_hz: f }
}

/// One carrier frequency cannot tell rho_sc, the gap and c apart: the
/// circuit is not fitted, the verdict says what to measure, and the
/// device file keeps eq. (3) on that carrier only.
#[test]
fn one_carrier_frequency_leaves_rho_sc_and_the_gap_unidentified() {
    let protocol = Protocol { carriers: vec![sine(1000.0)], ..Protocol::default() };
    let s = measure(&paper_truth(), &protocol, &Noise::default(), 5);
    let cal = calibrate(&s.measurements, Settings::default());
    let force = cal.force.as_ref().unwrap();
    assert!(force.circuit.is_none());
    assert!(
        cal.verdicts
            .iter()
            .any(|v| v.contains("rho_sc and the air gap g are not identifiable from 1 carrier frequency")
                && v.contains("three or more")),
        "{:?}",
        cal.verdicts
    );
    let file = DeviceFile::from_calibration(&cal, &s.measurements, 100.0);
    let e = file.electrovibration.as_ref().unwrap();
    assert_eq!(e.model, "eq3");
    assert!(e.circuit.is_none());
    assert!(file.device(&sine(1000.0)).is_ok());
    let refused = file.device(&sine(250.0)).unwrap_err().to_string();
    assert!(refused.contains("calibrated on sine 1000 Hz and this design plays sine 250 Hz"), "{refused}");
}

/// Carriers all above the corner (1 and 3 kHz and 2 kHz) give three
/// frequencies but no view of the corner: rho_sc is reported as not
/// identifiable, never with a confident number, and the device file does
/// not use the circuit.
#[test]
fn carriers_all_above_the_corner_leave_rho_sc_unidentified() {
    let protocol = Protocol { carriers: vec![sine(1000.0), sine(2000.0), sine(3000.0)], ..Protocol::default() };
    let s = measure(&paper_truth(), &protocol, &Noise::default(), 6);
    let cal = calibrate(&s.measurements, Settings::default());
    let circuit = cal.force.as_ref().unwrap().circuit.as_ref().expect("three frequencies: fitted");
    assert!(!circuit.rho_sc_ohm_m.identified, "{:?}", circuit.rho_sc_ohm_m);
    assert!(cal.verdicts.iter().any(|v| v.starts_with("rho_sc is not identifiable")), "{:?}", cal.verdicts);
    let file = DeviceFile::from_calibration(&cal, &s.measurements, 100.0);
    assert_eq!(file.electrovibration.as_ref().unwrap().model, "eq3");
}

/// A single voltage cannot separate mu_HD from c.
#[test]
fn one_voltage_level_cannot_separate_mu_hd_from_c() {
    let rows: Vec<_> = measure(&paper_truth(), &Protocol::default(), &Noise::default(), 7)
        .measurements
        .rows()
        .iter()
        .filter(|r| r.voltage_v == 60.0)
        .copied()
        .collect();
    let m = Measurements::from_rows(rows, "sixty volts");
    let cal = calibrate(&m, Settings::default());
    assert!(cal.verdicts.iter().any(|v| v.contains("cannot be separated from 1 voltage level")), "{:?}", cal.verdicts);
    let file = DeviceFile::from_calibration(&cal, &m, 100.0);
    assert!(file.electrovibration.is_none(), "{:?}", file.electrovibration);
}

/// Spoiled segments (5%, friction off by 50%) are reported by line, not
/// deleted, and the robust fit still holds the truth.
#[test]
fn spoiled_segments_are_reported_and_do_not_pull_the_fit() {
    let truth = paper_truth();
    let noise = Noise { spoiled: 0.05, ..Noise::default() };
    let s = measure(&truth, &Protocol::default(), &noise, 8);
    let cal = calibrate(&s.measurements, Settings::default());
    let circuit = cal.force.as_ref().unwrap().circuit.as_ref().unwrap();
    assert!(circuit.outliers.len() >= 5, "{} outliers", circuit.outliers.len());
    assert!(circuit.outliers.iter().all(|o| o.weight < 1.0 && o.line >= 2));
    assert!(circuit.c_per_v2.covers(truth.c_per_v2), "{:?}", circuit.c_per_v2);
    assert!(circuit.rho_sc_ohm_m.covers(1e5), "{:?}", circuit.rho_sc_ohm_m);
}

/// The device file carries the fit through TOML unchanged, and the device
/// it gives has the force the circuit predicts on any carrier:
/// Fe/Fn per V^2 = c G(carrier), to rounding.
#[test]
fn a_device_file_gives_the_fitted_force_on_any_carrier() {
    let s = measure(&paper_truth(), &Protocol::default(), &Noise::default(), 9);
    let cal = calibrate(&s.measurements, Settings::default());
    let file = DeviceFile::from_calibration(&cal, &s.measurements, 120.0);
    let text = file.to_toml();
    let read = DeviceFile::from_toml(&text, "my-display.toml").unwrap();
    assert_eq!(read.electrovibration, file.electrovibration);
    let circuit = read.electrovibration.as_ref().unwrap().circuit.as_ref().expect("circuit identified");
    let fitted = FingerCircuit { rho_sc_ohm_m: circuit.rho_sc_ohm_m.value, gap_um: circuit.gap_um.value };
    for carrier in [sine(50.0), sine(700.0), Carrier { shape: CarrierShape::Square, frequency_hz: 300.0 }] {
        let device = read.device(&carrier).unwrap();
        let expected = circuit.c_per_v2.value * fitted.carrier_gain(&LayerStack::PAPER, &carrier);
        let got = device.force_ratio_per_v2(1.0);
        assert!(((got - expected) / expected).abs() < 1e-12, "{got} {expected}");
        assert_eq!(device.u_max_v, 120.0);
    }
}

/// A broken device file is refused with the file and the line or key.
#[test]
fn a_broken_device_file_names_the_file_and_the_key() {
    let s = measure(&paper_truth(), &Protocol::default(), &Noise::default(), 10);
    let cal = calibrate(&s.measurements, Settings::default());
    let text = DeviceFile::from_calibration(&cal, &s.measurements, 100.0).to_toml();
    let bad = text.replacen("u_max_v = 100", "u_max_v = -3", 1);
    let e = DeviceFile::from_toml(&bad, "d.toml").unwrap_err().to_string();
    assert!(e.starts_with("d.toml: u_max_v:"), "{e}");
    let e = DeviceFile::from_toml(&text.replacen("format", "formt", 1), "d.toml").unwrap_err().to_string();
    assert!(e.starts_with("d.toml: line "), "{e}");
    let e = DeviceFile::from_toml("format = \"haptex-device 9\"", "d.toml").unwrap_err().to_string();
    assert!(e.starts_with("d.toml: "), "{e}");
}

/// Measurement files: every refusal names the line and the column.
#[test]
fn measurement_errors_name_the_line_and_the_column() {
    let read = |text: &str| Measurements::from_bytes(text.as_bytes(), "m.csv").map(|_| ()).unwrap_err().to_string();
    assert_eq!(
        read("voltage_v,carrier,carrier_hz,mu\n0,none,0,0.5\n50,triangle,100,0.6\n"),
        "m.csv, line 3, column 'carrier': expected one of sine, square, none, found \"triangle\""
    );
    assert!(read("voltage_v,mu\n0,0.5\n50,0.6\n").starts_with("m.csv, line 3, column 'carrier': the voltage is 50 V"));
    assert!(read("voltage_v,carrier,mu\n50,sine,0.6\n").starts_with("m.csv, line 1, column 'carrier_hz"));
    assert!(
        read("voltage_v,carrier,carrier_hz,ft_n,fn_n\n50,sine,100,0.3,0\n").starts_with("m.csv, line 2, column 'fn_n'")
    );
    assert!(read("voltage_v,carrier,carrier_hz,mu,ft_n,fn_n\n50,sine,100,1,1,1\n").contains("not both"));
    assert!(
        read("voltage_v,carrier,carrier_hz,amplitude_um,mu\n50,sine,100,1,0.5\n")
            .starts_with("m.csv, line 2, column 'amplitude_um': both the voltage and the vibration are on")
    );
    assert!(read("voltage_v,mu,finger\n0,0.5,1.5\n").starts_with("m.csv, line 2, column 'finger'"));
    assert!(read("voltage_v,mu\n").contains("no measurements"));
    assert!(
        read("voltage_v,carrier,carrier_hz,mu\n-1,sine,100,0.5\n").starts_with("m.csv, line 2, column 'voltage_v'")
    );
    // Each carrier is a parameter of the per-carrier fit: at most 32.
    let many: String = (0..40).map(|i| format!("50,sine,{},0.6\n", 100 + i)).collect();
    let e = read(&format!("voltage_v,carrier,carrier_hz,mu\n{many}"));
    assert!(e.starts_with("m.csv, line 34, column 'carrier_hz': more than 32 distinct carriers"), "{e}");
}

/// The file format round-trips through the virtual device's writer.
#[test]
fn written_measurements_read_back_the_same() {
    let s = measure(&paper_truth(), &Protocol::default(), &Noise::default(), 11);
    let mut bytes = Vec::new();
    haptex_core::calibration::virtual_device::write_csv(&s.measurements, &[], &mut bytes).unwrap();
    let back = Measurements::from_bytes(&bytes, "back.csv").unwrap();
    assert_eq!(back.rows(), s.measurements.rows());
    assert_eq!(back.sha256().len(), 64);
}

/// data/examples/calibration-measurements.csv is the virtual device's
/// output, byte for byte (HAPTEX_REGENERATE=1 rewrites it), and its fit
/// holds the example's truth.
#[test]
fn shipped_example_measurements_are_the_virtual_devices_and_their_fit_holds_the_truth() {
    use haptex_core::calibration::virtual_device::{example_csv, example_truth};
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/examples/calibration-measurements.csv");
    let bytes = example_csv();
    if std::env::var_os("HAPTEX_REGENERATE").is_some() {
        std::fs::write(&path, &bytes).unwrap();
    }
    let shipped = std::fs::read(&path).unwrap();
    assert!(shipped == bytes, "{} differs from the virtual device's output: regenerate it", path.display());
    let m = Measurements::from_bytes(&shipped, "example").unwrap();
    let cal = calibrate(&m, Settings::default());
    let truth = example_truth();
    let circuit = cal.force.as_ref().unwrap().circuit.as_ref().unwrap();
    assert!(circuit.c_per_v2.identified && circuit.c_per_v2.covers(truth.c_per_v2), "{:?}", circuit.c_per_v2);
    // This seed's rho_sc interval (1.05e5 .. 1.38e5 ohm m) misses the
    // truth, as one 95% interval in twenty does (the coverage test above
    // measures how often); docs/calibration.md shows it. Its estimate is
    // within 25%.
    let rho = circuit.rho_sc_ohm_m;
    assert!(rho.identified && (rho.value / 1e5 - 1.0).abs() < 0.25, "{rho:?}");
    assert!(circuit.gap_um.identified && circuit.gap_um.covers(0.1), "{:?}", circuit.gap_um);
    assert!(circuit.mu_hd.covers(0.6), "{:?}", circuit.mu_hd);
}

mod arbitrary_input {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

        /// Any bytes: read or refused with a located error, never a panic.
        #[test]
        fn any_bytes_are_read_or_refused(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let _ = Measurements::from_bytes(&bytes, "fuzz.csv");
        }

        /// Any valid rows, however degenerate (equal values, zeros, huge
        /// voltages, one carrier or many): a calibration and its device
        /// file, never a panic, and every written constant finite.
        #[test]
        fn any_valid_rows_calibrate_without_panic(
            rows in proptest::collection::vec(
                (0usize..4, prop_oneof![Just(0.0), 0.0..1e4f64], 0usize..3, prop_oneof![Just(0.0), 0.0..5.0f64],
                 prop_oneof![Just(0.5), 0.0..3.0f64], 0u64..3),
                1..60,
            )
        ) {
            use haptex_core::calibration::measurements::Measurement;
            let shapes = [CarrierShape::Sine, CarrierShape::Square, CarrierShape::None];
            let m: Vec<Measurement> = rows
                .iter()
                .map(|&(f, u, shape, a, mu, finger)| {
                    let (u, a) = if u > 0.0 && a > 0.0 { (u, 0.0) } else { (u, a) };
                    Measurement {
                        voltage_v: u,
                        carrier: Some(Carrier { shape: shapes[shape], frequency_hz: [10.0, 100.0, 1000.0, 3000.0][f] }),
                        amplitude_um: a,
                        mu,
                        velocity_mm_s: None,
                        finger,
                        repetition: 0,
                    }
                })
                .collect();
            let m = Measurements::from_rows(m, "arbitrary");
            let cal = calibrate(&m, Settings::default());
            let file = DeviceFile::from_calibration(&cal, &m, 100.0);
            let text = file.to_toml();
            if file.electrovibration.is_some() || file.ultrasonic.is_some() {
                let read = DeviceFile::from_toml(&text, "arbitrary.toml");
                prop_assert!(read.is_ok(), "{:?}\n{text}", read.err());
            }
        }
    }
}
