//! Closing the loop (issue 15, parts 3-4): the FE finger on the display
//! under eq. (8)'s voltage, and the compensated voltage.

use haptex_core::profile::FrictionProfile;
use haptex_fem::render::{self, DEFAULT_LOAD_N_PER_MM, RenderError, RenderSettings, Stopping, TargetPart};
use haptex_fem::scenario::{self, Scenario};
use haptex_fem::surface::SurfaceShape;

/// The FE finger's profile on a template (the database's runs: paper
/// scenario, default mesh, visco-elastic, 20 mm/s).
fn fe_profile(surface: SurfaceShape) -> FrictionProfile {
    scenario::run(&Scenario::paper(surface), &mut |_| {}).unwrap().profile.unwrap()
}

fn settings() -> RenderSettings {
    let mut s = RenderSettings::new(0.5, DEFAULT_LOAD_N_PER_MM);
    s.scenario.step_mm = 0.05;
    s
}

#[test]
fn compensation_cuts_the_eq8_error_by_three_within_eight_runs() {
    // Issue 15's acceptance: on the bump, edge and sine at the database's
    // central case (r_w 1.5, r_h 0.3 mm) and two more (a bump narrower
    // than the contact, a long high sine period), the compensated
    // voltage's felt-friction RMS error over the renderable region is at
    // most a third of eq. (8)'s, within 8 FE runs. Measured (docs/fem.md,
    // "Closing the loop"): the factor is 20-200 in 3-4 runs.
    let cases = [
        SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 },
        SurfaceShape::Edge { x0: 5.0, width: 1.5, height: 0.3 },
        SurfaceShape::Sine { x0: 5.0, width: 1.5, height: 0.3 },
        SurfaceShape::Bump { x0: 5.0, width: 0.5, height: 0.2 },
        SurfaceShape::Sine { x0: 5.0, width: 2.5, height: 0.5 },
    ];
    let settings = settings();
    for surface in cases {
        let target = fe_profile(surface.clone());
        let c = render::compensate(&target, &settings, Stopping::default(), &mut |_, _| {}).unwrap();
        assert!(c.trials.len() <= 8);
        for t in &c.trials {
            assert!(t.voltage_v.iter().all(|&u| (0.0..=settings.device.u_max_v).contains(&u)));
        }
        let eq8 = c.trials[0].metrics.rms_error;
        let best = c.best().metrics.rms_error;
        assert!(best <= eq8 / 3.0, "{surface:?}: eq. (8) {eq8:.3e}, compensated {best:.3e}");
        assert_stopped_by_its_rule(&c, &Stopping::default());
    }
}

/// The reason a compensation gives for stopping is the rule its trials
/// show: the last within the tolerance; or the last above the reduction
/// times the best before it; or the runs spent.
fn assert_stopped_by_its_rule(c: &render::Compensation, stopping: &Stopping) {
    let errors: Vec<f64> = c.trials.iter().map(|t| t.metrics.rms_error).collect();
    let last = *errors.last().unwrap();
    let best_before = errors[..errors.len() - 1].iter().copied().fold(f64::INFINITY, f64::min);
    let expected = if last <= stopping.tolerance {
        render::CompensationStop::Tolerance
    } else if errors.len() > 1 && last > stopping.min_reduction * best_before {
        render::CompensationStop::Stalled
    } else {
        assert_eq!(errors.len(), stopping.max_runs, "{errors:?}");
        render::CompensationStop::MaxRuns
    };
    assert_eq!(c.stop, expected, "{errors:?}");
}

#[test]
fn a_target_the_display_cannot_render_is_reported_not_an_error() {
    // A target below mu_HD everywhere: U = 0, the finger feels mu_HD, the
    // whole length is reported not renderable and the renderable error is
    // 0 (nothing to compare).
    let x: Vec<f64> = (0..=50).map(|i| 0.1 * i as f64).collect();
    let target = FrictionProfile::new(x.clone(), vec![0.3; x.len()]).unwrap();
    let check = render::check(&target, &settings(), &mut |_| {}).unwrap();
    assert!(check.voltage_v.iter().all(|&u| u == 0.0));
    assert!((check.metrics.not_renderable_fraction - 1.0).abs() < 1e-12);
    assert_eq!(check.metrics.rms_error, 0.0);
    assert!(check.felt.mu.iter().all(|&m| (m - 0.5).abs() < 1e-8));
}

#[test]
fn a_constant_target_is_felt_with_the_fe_finger_own_k() {
    // mu_RS = 0.55 everywhere: eq. (8) with the FE finger's own k (its
    // contact length per normal force) renders it within the attraction
    // of the skin near the contact's edges through the air gap, which
    // eq. (8) leaves out (6% of Fe: 0.003 in mu at Fe/Fn = 0.1); the
    // compensated voltage within the 1e-4 tolerance.
    let x: Vec<f64> = (0..=40).map(|i| 0.1 * i as f64).collect();
    let target = FrictionProfile::new(x.clone(), vec![0.55; x.len()]).unwrap();
    let mut s = settings();
    let first = render::check(&target, &s, &mut |_| {}).unwrap();
    s.device.contact.k_mm2_per_n = first.metrics.k_fe_mm2_per_n;
    let with_fe_k = render::check(&target, &s, &mut |_| {}).unwrap();
    assert!(with_fe_k.metrics.rms_error < 0.004, "{:?}", with_fe_k.metrics);
    assert!(with_fe_k.metrics.rms_error < first.metrics.rms_error);
    let c = render::compensate(&target, &s, Stopping::default(), &mut |_, _| {}).unwrap();
    assert!(c.best().metrics.rms_error <= 1e-4, "{:?}", c.best().metrics);
    assert_eq!(c.stop, render::CompensationStop::Tolerance);
    // Two runs allowed: spent before the tolerance.
    let two = Stopping { max_runs: 2, tolerance: 0.0, ..Stopping::default() };
    let c = render::compensate(&target, &s, two, &mut |_, _| {}).unwrap();
    assert_eq!((c.trials.len(), c.stop), (2, render::CompensationStop::MaxRuns));
}

#[test]
fn bad_settings_are_refused_before_any_run() {
    let x: Vec<f64> = (0..=10).map(|i| i as f64).collect();
    let target = FrictionProfile::new(x.clone(), vec![0.6; x.len()]).unwrap();
    let mut s = settings();
    s.run_up_mm = -1.0;
    assert!(render::check(&target, &s, &mut |_| {}).unwrap_err().to_string().contains("run-up"));
    let s = settings();
    let stopping = Stopping { max_runs: 0, ..Stopping::default() };
    assert!(render::compensate(&target, &s, stopping, &mut |_, _| {}).is_err());
    let e = render::check_voltage(&target, vec![150.0; x.len()], &s, &mut |_| {}).unwrap_err();
    assert!(e.to_string().contains("U_max"), "{e}");
}

/// Issue 35 ("No internal error reaches a client as a success"): what the
/// check needs of its target is one rule, `check_target`, applied before
/// any FE run, its error naming the part at fault. Positions closer than
/// 1 nm became one when placed on the slide (0 and 1e-300 mm: both 1 mm
/// after the run-up), which the voltage curve then refused as "positions
/// must be strictly increasing: 1 follows 1", an internal error for the
/// callers; a target shorter than a step, a run-up out of range, too many
/// points are refused the same way; 1 nm apart is accepted.
#[test]
fn a_target_the_fe_slide_cannot_run_is_refused_before_any_run_naming_its_part() {
    let s = settings();
    let profile = |x: &[f64]| FrictionProfile::new(x.to_vec(), vec![0.6; x.len()]).unwrap();
    let mut long_run_up = settings();
    long_run_up.run_up_mm = 101.0;
    let many: Vec<f64> = (0..=render::MAX_CHECK_POINTS).map(|i| 1e-3 * i as f64).collect();
    for (x, settings, part) in [
        (vec![0.0, 1e-300, 1.0], &s, TargetPart::Positions),
        (vec![0.0, 5e-324], &s, TargetPart::Positions),
        (vec![-1.0, 0.5, 0.5 + 1e-7], &s, TargetPart::Positions),
        (vec![1e6 - 1.0, 1e6 - 1e-9, 1e6], &s, TargetPart::Positions),
        (many, &s, TargetPart::Positions),
        (vec![0.0, 0.01], &s, TargetPart::Step),
        (vec![0.0, 1.0], &long_run_up, TargetPart::RunUp),
    ] {
        let target = profile(&x);
        let e = render::check_target(&target, settings).unwrap_err();
        assert_eq!(e.part, part, "{e}");
        assert!(e.message.contains("the friction profile") || part == TargetPart::RunUp, "{e}");
        // The check itself refuses it the same way, before any FE step.
        match render::check(&target, settings, &mut |_| panic!("an FE run started")) {
            Err(RenderError::Target(t)) => assert_eq!(t, e),
            other => panic!("{:?}", other.map(|c| c.metrics)),
        }
    }
    render::check_target(&profile(&[0.0, 0.5, 0.5 + 1e-6, 1.0]), &s).unwrap();
}

#[test]
fn combined_display_renders_the_whole_bump_within_the_electrovibration_tolerance() {
    // Issue 16: the FE bump (the database's central case, around its flat
    // value mu_skin = 0.5 = mu_HD, the paper's normalized bump) climbs to
    // 0.65 and descends to 0.38. Electrovibration alone renders the climb
    // (U_max raised to 200 V so that its top is inside the band) and
    // leaves the descent at U = 0. The combined display (split, the
    // literature ultrasonic default as the plate) renders both: nothing
    // is outside its band, and the felt friction's RMS error over the
    // whole bump is within the error electrovibration reaches over the
    // climb alone (eq. 8, the same device and finger). Over the descent
    // the felt friction is the target to rounding: the plate's part is a
    // Coulomb coefficient on the whole contact, mu_HD rho(a(x_f)), and the
    // pad slips throughout, so Ft/Fn is that coefficient at every step (a
    // check of the FE's use of the model, not of the model).
    use haptex_core::combined::Strategy;
    use haptex_core::ultrasonic::UltrasonicDevice;
    let target = fe_profile(SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 });
    let mut settings = settings();
    settings.device.u_max_v = 200.0;
    let electro = render::check(&target, &settings, &mut |_| {}).unwrap();
    assert!(electro.metrics.not_renderable_fraction > 0.2, "{:?}", electro.metrics);
    let plate = UltrasonicDevice::literature_default(None).unwrap();
    let combined = render::check_combined(&target, &settings, &plate, Strategy::Split, &mut |_| {}).unwrap();
    let m = combined.metrics;
    assert_eq!((m.not_renderable_fraction, m.clipped_fraction), (0.0, 0.0), "{m:?}");
    let amplitude = combined.amplitude_um.as_ref().unwrap();
    assert!(amplitude.iter().any(|&a| a > 0.0) && amplitude.iter().all(|&a| a <= plate.a_max_um()));
    assert!(combined.voltage_v.iter().all(|&u| (0.0..=200.0).contains(&u)));
    // Over the descent alone (target below mu_HD: the plate's part).
    let (mut sum, mut count) = (0.0, 0);
    for (i, &mu) in target.mu().iter().enumerate() {
        if mu < settings.device.mu_hd {
            sum += (combined.felt.mu[i] - mu).powi(2);
            count += 1;
        }
    }
    let descent_rms = (sum / count as f64).sqrt();
    eprintln!("electrovibration alone: {:?}\ncombined: {m:?}\ndescent RMS {descent_rms:.3e}", electro.metrics);
    assert!(descent_rms < 1e-9, "descent RMS {descent_rms:e}");
    assert!(m.rms_error <= electro.metrics.rms_error, "combined {m:?} vs electrovibration {:?}", electro.metrics);
}
