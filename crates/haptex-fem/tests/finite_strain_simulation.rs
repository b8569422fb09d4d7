//! The full simulation with finite-strain kinematics (`--kinematics
//! finite`) on the homogeneous soft half-disc (data/finger/half-disc.toml)
//! and on the shipped finger, over a flat and over the bump x0 5, r_w 1.5,
//! r_h 0.3 mm, elastic and visco-elastic, default mesh, 10 mm slide:
//!
//! - the slide completes;
//! - on the flat, once the whole contact slips (x >= 1 mm), Ft/Fn equals
//!   the Coulomb mu (1%, as the small-strain test of issue 3);
//! - global equilibrium at every step: the contact force on the skin
//!   balances the reaction of the driven set computed element by element
//!   from the committed finite-strain stresses (1e-6 of Fn, issue 3);
//! - the committed state is in equilibrium on every free DOF, not only on
//!   the pad: the residual f_int - P F recomputed from the committed
//!   stresses after every step of a press and slide over the bump (coarse
//!   mesh), within the outer tolerance (1e-8 of the largest nodal contact
//!   force, 10x margin for the recomputation).

// Numeric checks index several arrays with one loop variable (as the library).
#![allow(clippy::needless_range_loop)]

use haptex_fem::finger::{FingerModel, Resolution};
use haptex_fem::finite_solver::{FiniteSettings, FiniteSolver};
use haptex_fem::scenario::{Kinematics, Scenario, build_problem, run};
use haptex_fem::solver::{Drive, Solver};
use haptex_fem::surface::SurfaceShape;

fn half_disc() -> FingerModel {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/finger/half-disc.toml");
    FingerModel::read(std::path::Path::new(path)).unwrap()
}

fn check(name: &str, model: FingerModel, surface: SurfaceShape, viscoelastic: bool) {
    let flat = surface == SurfaceShape::Flat;
    let mut scenario = Scenario::paper(surface);
    scenario.model = model;
    scenario.viscoelastic = viscoelastic;
    scenario.kinematics = Kinematics::Finite;
    let mu = scenario.model.contact.mu_skin;
    let result = run(&scenario, &mut |_| {}).unwrap_or_else(|e| panic!("{name}: {e}"));
    let x = result.profile.as_ref().unwrap().x_mm();
    assert!((x.last().unwrap() - 10.0).abs() < 1e-9, "{name}: the slide completes");
    if flat {
        for (x, m) in x.iter().zip(result.profile.as_ref().unwrap().mu()).filter(|(x, _)| **x >= 1.0) {
            assert!((m / mu - 1.0).abs() < 0.01, "{name}: Ft/Fn = {m} at x = {x}");
        }
    }
    let mut worst: f64 = 0.0;
    for row in &result.history {
        let contact = [-row.ft_n, row.fn_n];
        for k in 0..2 {
            worst = worst.max((contact[k] + row.reaction_n[k]).abs() / row.fn_n.abs());
        }
    }
    let mu_range = result
        .profile
        .as_ref()
        .unwrap()
        .mu()
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &m| (a.min(m), b.max(m)));
    eprintln!(
        "{name}: {} steps, {} cuts, {:.2} s, Ft/Fn {:.4} .. {:.4}, worst equilibrium {worst:.2e} of Fn",
        result.statistics.steps, result.statistics.step_cuts, result.statistics.wall_time_s, mu_range.0, mu_range.1
    );
    assert!(worst < 1e-6, "{name}: contact force vs driven-set reaction, {worst:e} of Fn");
}

const BUMP: SurfaceShape = SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 };

#[test]
fn half_disc_flat_and_bump_finite_strain() {
    for viscoelastic in [false, true] {
        check(&format!("half-disc flat ve={viscoelastic}"), half_disc(), SurfaceShape::Flat, viscoelastic);
        check(&format!("half-disc bump ve={viscoelastic}"), half_disc(), BUMP, viscoelastic);
    }
}

#[test]
fn shipped_finger_flat_and_bump_finite_strain() {
    for viscoelastic in [false, true] {
        check(
            &format!("finger flat ve={viscoelastic}"),
            FingerModel::default_model(),
            SurfaceShape::Flat,
            viscoelastic,
        );
        check(&format!("finger bump ve={viscoelastic}"), FingerModel::default_model(), BUMP, viscoelastic);
    }
}

#[test]
fn committed_state_is_in_equilibrium_on_every_free_dof() {
    let mut scenario = Scenario::paper(SurfaceShape::Bump { x0: 2.0, width: 1.5, height: 0.3 });
    scenario.resolution = Resolution::Coarse;
    let (problem, lift) = build_problem(&scenario).unwrap();
    let inner = Solver::new(problem, scenario.settings, lift).unwrap();
    let settings = FiniteSettings::default();
    let mut solver = FiniteSolver::new(inner, settings);
    let check = |solver: &FiniteSolver| {
        let scale = solver.inner.forces.iter().fold(0.0f64, |m, f| m.max(f.abs()));
        let residual = solver.committed_residual();
        assert!(residual <= 10.0 * settings.relative_tolerance * scale, "residual {residual:e}, force scale {scale:e}");
    };
    for k in 1..=10 {
        solver.advance(0.01, 0.0, Drive::Displacement([0.0, -0.025 * k as f64])).unwrap();
        check(&solver);
    }
    for k in 1..=30 {
        solver.advance(0.005, 0.1 * k as f64, Drive::Displacement([0.0, -0.25])).unwrap();
        check(&solver);
    }
}

/// Load control with finite strain (as `load_control_holds_the_normal_force`
/// for small strain): Fn stays at the load to 1e-6 over a 0.2 mm bump while
/// the bone rides up and down (the driven y is an unknown of the outer
/// iteration too).
#[test]
fn load_control_holds_the_normal_force_finite_strain() {
    let load = 0.012;
    let mut scenario = Scenario::paper(SurfaceShape::Bump { x0: 3.0, width: 1.5, height: 0.2 });
    scenario.loading = haptex_fem::scenario::Loading::Load(load);
    scenario.resolution = Resolution::Coarse;
    scenario.slide_mm = 6.0;
    scenario.kinematics = Kinematics::Finite;
    let result = run(&scenario, &mut |_| {}).unwrap();
    let slide = &result.history[scenario.press_steps..];
    for row in slide {
        assert!((row.fn_n / load - 1.0).abs() < 1e-6, "Fn = {} at x = {}", row.fn_n, row.slide_mm);
    }
    let (lo, hi) =
        slide.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| (a.min(r.drive_y_mm), b.max(r.drive_y_mm)));
    assert!(hi - lo > 0.05, "the bone rides over the 0.2 mm bump: {lo} .. {hi}");
}
