//! The finger on an electrovibration display (issue 15, part 1): a flat
//! rigid display with friction mu_HD and an electrostatic attraction from
//! the voltage at the finger's position, U(x_f).

use haptex_core::electrovibration::{LayerStack, electrostatic_force_n};
use haptex_core::signal::{Extend, VoltageCurve};
use haptex_fem::contact::Electrostatic;
use haptex_fem::display::Display;
use haptex_fem::scenario::{self, HistoryRow, Loading, Scenario, SimulationResult};
use haptex_fem::surface::SurfaceShape;

fn display(x_mm: Vec<f64>, voltage_v: Vec<f64>) -> Display {
    Display {
        voltage: VoltageCurve::new(x_mm, voltage_v).unwrap(),
        extend: Extend::Hold,
        stack: LayerStack::PAPER,
        vibration: None,
        air_gap_um: 0.0,
    }
}

fn constant(u_v: f64) -> Display {
    display(vec![0.0, 1.0], vec![u_v, u_v])
}

fn run(display: Display, viscoelastic: bool, loading: Loading, mu_display: f64) -> SimulationResult {
    let mut s = Scenario::paper(SurfaceShape::Flat);
    s.viscoelastic = viscoelastic;
    s.loading = loading;
    s.slide_mm = 3.0;
    s.mu_skin = Some(mu_display);
    s.display = Some(display);
    scenario::run(&s, &mut |_| {}).unwrap()
}

/// Slide rows after the pre-sliding at the start (every contact point slips).
fn sliding(result: &SimulationResult) -> impl Iterator<Item = &HistoryRow> {
    result.history.iter().filter(|r| r.slide_mm >= 1.0)
}

#[test]
fn zero_voltage_feels_the_display_friction() {
    // With U = 0 the display is a flat surface of friction mu_HD: in steady
    // sliding Ft/Fn = mu_HD (Coulomb, every point slipping) to the solver's
    // tolerance (relative 1e-9).
    for (viscoelastic, loading) in [(false, Loading::Indent(0.25)), (true, Loading::Load(0.0133))] {
        let r = run(constant(0.0), viscoelastic, loading, 0.8);
        for row in sliding(&r) {
            assert_eq!(row.fe_n, 0.0);
            assert!((row.ft_n / row.fn_n - 0.8).abs() < 1e-8, "{row:?}");
        }
    }
}

#[test]
fn constant_voltage_adds_eq3_force_on_the_contact_length() {
    // A constant U: Coulomb on the total contact pressure gives
    // Ft = mu_HD (Fn + Fe) exactly (Fn the net normal force, Fe the
    // attraction), so Ft/Fn = mu_HD (1 + Fe/Fn) to the solver's tolerance;
    // the attraction on skin in contact is eq. (3) on the FE's own contact
    // length (per mm of width) to rounding; and at the paper's U_max
    // (100 V) Ft/Fn is within 1% of mu_HD (1 + Fe_eq3/Fn): the rest of Fe
    // pulls skin near the contact's edges through the air gap, 6% of Fe on
    // the default mesh (docs/fem.md, "The finger on a display").
    let stack = LayerStack::PAPER;
    for (viscoelastic, loading) in [(false, Loading::Indent(0.25)), (true, Loading::Load(0.0133))] {
        let r = run(constant(100.0), viscoelastic, loading, 0.5);
        for row in sliding(&r) {
            let mu = row.ft_n / row.fn_n;
            assert!((mu - 0.5 * (1.0 + row.fe_n / row.fn_n)).abs() < 1e-8, "{row:?}");
            let eq3 = electrostatic_force_n(&stack, row.contact_mm * 1.0, 100.0);
            assert!((row.fe_contact_n - eq3).abs() < 1e-12 * eq3, "{} vs eq. (3) {eq3}", row.fe_contact_n);
            let fringe = row.fe_n / row.fe_contact_n - 1.0;
            assert!(fringe > 0.0 && fringe < 0.1, "fringe {fringe}");
            let paper = 0.5 * (1.0 + eq3 / row.fn_n);
            assert!((mu / paper - 1.0).abs() < 0.01, "Ft/Fn {mu} vs eq. (3) on the contact length {paper}");
        }
    }
}

#[test]
fn equilibrium_contact_and_attraction_balance_the_bone_reaction() {
    // At every step (press and slide): the contact force on the finger
    // less the electrostatic attraction equals the reaction on bone and
    // nail, computed element by element from the tissue's stresses
    // independently of the solver's condensation; to 1e-6 of Fn.
    let ramp = display(vec![0.0, 1.0, 2.0, 3.0], vec![20.0, 100.0, 0.0, 60.0]);
    for (viscoelastic, loading) in [(true, Loading::Indent(0.25)), (true, Loading::Load(0.0133))] {
        let r = run(ramp.clone(), viscoelastic, loading, 0.5);
        for row in &r.history {
            let scale = row.fn_n.abs();
            assert!((row.fn_n + row.reaction_n[1]).abs() < 1e-6 * scale, "{row:?}");
            assert!((row.ft_n - row.reaction_n[0]).abs() < 1e-6 * scale, "{row:?}");
            assert_eq!(row.voltage_v, ramp.voltage_at(row.slide_mm));
        }
        if let Loading::Load(load) = loading {
            for row in &r.history[r.history.len() - 10..] {
                assert!((row.fn_n - load).abs() < 1e-9 * load, "{row:?}");
            }
        }
    }
}

#[test]
fn gap_law_limits() {
    // p_e(0) is eq. (3) divided by the area (the core's eq. 3 over 1 mm^2,
    // to rounding); for a gap far beyond the layers (1e4 b) the force
    // between two plates in air, eps0 U^2 / (2 g^2), within 2e-4 (the
    // relative size of a + b next to g); halving between.
    let stack = LayerStack::PAPER;
    let e = Electrostatic::new(&stack, 100.0);
    let eq3_mpa = electrostatic_force_n(&stack, 1.0, 100.0);
    assert!((e.traction(0.0).0 / eq3_mpa - 1.0).abs() < 1e-12);
    assert_eq!(e.traction(-0.01), e.traction(0.0));
    let g = 1e4 * e.thickness_mm;
    let plates_mpa = haptex_core::electrovibration::EPS0_F_PER_M * 1e4 / (2.0 * (g * 1e-3) * (g * 1e-3)) * 1e-6;
    assert!((e.traction(g).0 / plates_mpa - 1.0).abs() < 2e-4, "{} vs {plates_mpa}", e.traction(g).0);
    // The derivative is the law's own (central difference, 1e-6).
    for gap in [1e-5, 2e-4, 3e-3] {
        let h = 1e-4 * gap;
        let fd = (e.traction(gap + h).0 - e.traction(gap - h).0) / (2.0 * h);
        assert!((e.traction(gap).1 / fd - 1.0).abs() < 1e-6, "gap {gap}");
    }
}

#[test]
fn an_air_gap_lowers_the_contact_traction_as_the_series_law_says() {
    // A 0.1 um air gap in series with the layers (the law's closed form,
    // Electrostatic's docs): in contact the traction is eq. (3)'s times
    // a b / ((a + g0)(b + g0)) = 0.6883 with the paper's layers (a = 0.2212
    // um, b = 201 um), to rounding (1e-12); above the skin it is the law's
    // at g + g0; the derivative stays the law's (central difference, 1e-6).
    let stack = LayerStack::PAPER;
    let bare = Electrostatic::new(&stack, 100.0);
    let gapped = bare.with_air_gap(1e-4);
    let (a, b, g0) = (bare.electric_mm, bare.thickness_mm, 1e-4);
    let factor = a * b / ((a + g0) * (b + g0));
    assert!((factor - 0.6883).abs() < 1e-4, "{factor}");
    for gap in [-0.01, 0.0] {
        assert!((gapped.traction(gap).0 / bare.traction(0.0).0 - factor).abs() < 1e-12);
    }
    for gap in [1e-5, 2e-4, 3e-3] {
        assert!((gapped.traction(gap).0 / bare.traction(gap + g0).0 - 1.0).abs() < 1e-12);
        let h = 1e-4 * gap;
        let fd = (gapped.traction(gap + h).0 - gapped.traction(gap - h).0) / (2.0 * h);
        assert!((gapped.traction(gap).1 / fd - 1.0).abs() < 1e-6, "gap {gap}");
    }
    // The display passes its gap (in um) to the law it applies.
    let display = Display { air_gap_um: 0.1, ..constant(100.0) };
    assert_eq!(display.electrostatic_at(0.5), gapped);
    assert!(Display { air_gap_um: -1.0, ..constant(100.0) }.validate().is_err());
}

#[test]
fn a_voltage_step_is_felt_after_a_short_pre_sliding_length() {
    // U jumps from 0 to 100 V at x = 5 mm. The electrode is one: the whole
    // contact feels the new voltage at once, and the friction force can
    // rise only as fast as the pad shears to carry it: the skin sticks
    // while the surface drags it by the extra tangential deflection (a
    // Cattaneo-Mindlin pre-sliding, as at the start of the slide). The
    // 10-90% transition is therefore finite, shorter than the pre-sliding
    // at the slide's start (a friction rise of mu Fn instead of mu Fe), the
    // same at steps of 0.01 and 0.005 mm (converged, within one step), and
    // ends at the constant-voltage run's friction (1e-6).
    let step = display(vec![0.0, 4.999, 5.001, 10.0], vec![0.0, 0.0, 100.0, 100.0]);
    let mut lengths = Vec::new();
    for step_mm in [0.01, 0.005] {
        let mut s = Scenario::paper(SurfaceShape::Flat);
        s.viscoelastic = false;
        s.slide_mm = 6.0;
        s.step_mm = step_mm;
        s.display = Some(step.clone());
        let r = scenario::run(&s, &mut |_| {}).unwrap();
        let p = r.profile.unwrap();
        let (x, mu) = (p.x_mm(), p.mu());
        let before = mu[x.iter().position(|&x| x >= 4.9).unwrap()];
        let after = *mu.last().unwrap();
        let crossing = |level: f64, from: f64| {
            x.iter().zip(mu).find(|&(&x, &m)| x >= from && m >= level).map(|(&x, _)| x).unwrap()
        };
        let rise = |f: f64| crossing(before + f * (after - before), 5.0);
        let transition = rise(0.9) - rise(0.1);
        let start = crossing(0.9 * before, 0.0) - crossing(0.1 * before, 0.0);
        assert!(transition > 0.0 && transition < start, "transition {transition} mm, start {start} mm");
        s.display = Some(constant(100.0));
        let steady = scenario::run(&s, &mut |_| {}).unwrap().profile.unwrap();
        assert!((after - steady.mu().last().unwrap()).abs() < 1e-6);
        lengths.push(transition);
    }
    assert!((lengths[0] - lengths[1]).abs() <= 0.01, "{lengths:?}");
}

#[test]
fn a_display_must_be_flat_and_its_voltage_bounded() {
    let mut s = Scenario::paper(SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 });
    s.display = Some(constant(50.0));
    let e = s.validate().unwrap_err().to_string();
    assert!(e.contains("flat"), "{e}");
    s.surface = SurfaceShape::Flat;
    s.display = Some(constant(5000.0));
    let e = s.validate().unwrap_err().to_string();
    assert!(e.contains("5000 V") && e.contains("MPa"), "{e}");
}

/// A combined display (issue 16): a constant vibration amplitude lowers
/// the skin-display coefficient to mu_HD rho(a), and with a voltage the
/// finger feels mu_HD rho(a) (1 + Fe/Fn) (Vezzoli et al. 2015), both to
/// the solver's tolerance in steady sliding; a scenario whose friction is
/// not the plate's mu_HD is refused.
#[test]
fn vibrating_display_feels_the_reduced_coefficient() {
    use haptex_core::ultrasonic::UltrasonicDevice;
    use haptex_fem::display::Vibration;
    let plate = UltrasonicDevice::literature_default(None).unwrap();
    let rho = plate.relative_friction(1.0);
    let vibrating = |u_v: f64, mu_hd: f64| Display {
        vibration: Some(Vibration::new(vec![0.0, 1.0], vec![1.0, 1.0], plate.clone(), mu_hd).unwrap()),
        ..constant(u_v)
    };
    for u_v in [0.0, 100.0] {
        let r = run(vibrating(u_v, 0.8), true, Loading::Load(0.0133), 0.8);
        for row in sliding(&r) {
            let expected = 0.8 * rho * (1.0 + row.fe_n / row.fn_n);
            assert!((row.ft_n / row.fn_n - expected).abs() < 1e-8, "U = {u_v}: {row:?}, expected {expected}");
        }
    }
    let mut s = Scenario::paper(SurfaceShape::Flat);
    s.mu_skin = Some(0.5);
    s.display = Some(vibrating(0.0, 0.8));
    let e = scenario::run(&s, &mut |_| {}).unwrap_err();
    assert!(e.to_string().contains("must be the skin-display friction"), "{e}");
    let e = Vibration::new(vec![0.0, 1.0], vec![0.0, 3.0], plate, 0.5).unwrap_err();
    assert!(e.to_string().contains("outside 0 .. a_max = 2.3 um"), "{e}");
}
