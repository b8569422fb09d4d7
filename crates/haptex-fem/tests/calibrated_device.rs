//! The FE finger as a virtual device (issue 36): calibrated from its own
//! constant-voltage "measurements", eq. (8) with the calibration renders
//! the five cases of docs/display.md at least as well as eq. (8) with the
//! FE finger's measured k (`check --fe-k`).

use haptex_core::calibration::device_file::DeviceFile;
use haptex_core::calibration::measurements::{Measurement, Measurements};
use haptex_core::calibration::{Settings, calibrate};
use haptex_core::profile::FrictionProfile;
use haptex_core::recording::rng::SplitMix64;
use haptex_core::signal::{Carrier, CarrierShape};
use haptex_fem::render::{self, DEFAULT_LOAD_N_PER_MM, RenderSettings};
use haptex_fem::scenario::{self, Scenario};
use haptex_fem::surface::SurfaceShape;

fn settings() -> RenderSettings {
    let mut s = RenderSettings::new(0.5, DEFAULT_LOAD_N_PER_MM);
    s.scenario.step_mm = 0.05;
    s
}

/// The FE finger's friction on the flat display under a constant RMS
/// voltage: the mean felt Ft/Fn over a 4 mm slide after the run-up.
fn fe_friction(u_v: f64, settings: &RenderSettings) -> f64 {
    let x: Vec<f64> = (0..=40).map(|i| 0.1 * i as f64).collect();
    let target = FrictionProfile::new(x.clone(), vec![settings.device.mu_hd; x.len()]).unwrap();
    let felt = render::feel(&target, &vec![u_v; x.len()], settings, &mut |_| {}).unwrap();
    felt.mu.iter().sum::<f64>() / felt.mu.len() as f64
}

#[test]
fn eq8_with_a_calibration_of_the_fe_finger_renders_as_well_as_its_fe_k() {
    // The device's truth differs from the paper's: mu_HD 0.5 (the FE
    // skin's), the FE finger's own contact per unit force and the edge
    // attraction. "Measured" at 0 to 100 V on a 1 kHz sine (eq. 3 has no
    // frequency dependence) with three strokes each, a 0.2% stroke-to-
    // stroke variation and force-sensor noise (seeded).
    let s = settings();
    let sine = Carrier { shape: CarrierShape::Sine, frequency_hz: 1000.0 };
    let mut rng = SplitMix64::new(36);
    let mut rows = Vec::new();
    for u in [0.0, 25.0, 50.0, 75.0, 100.0] {
        let mu = fe_friction(u, &s);
        for repetition in 1..=3 {
            rows.push(Measurement {
                voltage_v: u,
                carrier: Some(sine),
                amplitude_um: 0.0,
                mu: mu * (1.0 + 0.002 * rng.normal()),
                velocity_mm_s: Some(s.scenario.velocity_mm_s),
                finger: 1,
                repetition,
            });
        }
    }
    let m = Measurements::from_rows(rows, "FE virtual device");
    let cal = calibrate(&m, Settings::default());
    let file = DeviceFile::from_calibration(&cal, &m, s.device.u_max_v);
    let device = file.device(&sine).expect("mu_HD and c identified");
    let mut calibrated = s.clone();
    calibrated.device = device;
    let cases = [
        SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 },
        SurfaceShape::Edge { x0: 5.0, width: 1.5, height: 0.3 },
        SurfaceShape::Sine { x0: 5.0, width: 1.5, height: 0.3 },
        SurfaceShape::Bump { x0: 5.0, width: 0.5, height: 0.2 },
        SurfaceShape::Sine { x0: 5.0, width: 2.5, height: 0.5 },
    ];
    let mut report = format!("calibrated mu_HD {:.4}, k {:.1} mm^2/N\n", device.mu_hd, device.contact.k_mm2_per_n);
    let mut failures = Vec::new();
    for surface in cases {
        let target = scenario::run(&Scenario::paper(surface.clone()), &mut |_| {}).unwrap().profile.unwrap();
        let first = render::check(&target, &s, &mut |_| {}).unwrap();
        let mut fe_k = s.clone();
        fe_k.device.contact.k_mm2_per_n = first.metrics.k_fe_mm2_per_n;
        let with_fe_k = render::check(&target, &fe_k, &mut |_| {}).unwrap().metrics.rms_error;
        let with_calibration = render::check(&target, &calibrated, &mut |_| {}).unwrap();
        assert!(with_calibration.voltage_v.iter().all(|&u| (0.0..=calibrated.device.u_max_v).contains(&u)));
        let e = with_calibration.metrics.rms_error;
        report += &format!("{surface:?}: --fe-k {with_fe_k:.3e}, calibrated {e:.3e}\n");
        if e > with_fe_k {
            failures.push(format!("{surface:?}"));
        }
    }
    eprintln!("{report}");
    assert!(failures.is_empty(), "the calibration renders worse than --fe-k on {failures:?}\n{report}");
}
