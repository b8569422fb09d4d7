//! Step cutting and the failure report (issue 3: "automatic step cutting on
//! non-convergence, and a clear error (time, step, residual) if it still
//! fails — never a silently wrong profile").
//!
//! The problem: a homogeneous elastic cylinder (R = 8 mm, E = 1 MPa,
//! nu = 0.3) pressed 0.08 mm onto the rigid flat by its rigid core,
//! frictionless, so that the final state does not depend on the loading
//! path. Oracle: the same press in 8 steps with the default settings; a
//! solution reached through halved steps must equal it to 1e-6 relative
//! (the Newton tolerance is 1e-9 of the force).

mod common;

use haptex_fem::contact::ContactLaw;
use haptex_fem::material::Material;
use haptex_fem::solver::{ContactProblem, Drive, SolveError, Solver, SolverSettings};

const DELTA_MM: f64 = 0.08;

fn problem() -> ContactProblem {
    let law = ContactLaw {
        penalty_normal: 2000.0,
        penalty_tangential: 2000.0,
        mu: 0.0,
        smoothing_mm: 0.0,
        geometric_tangent: false,
        electrostatic: None,
    };
    common::cylinder_on_flat(8.0, 2.0, 0.05, 2.0, Material::elastic(1.0, 0.3), law)
}

fn vertical_force(solver: &Solver) -> f64 {
    solver.forces.chunks(2).map(|f| f[1]).sum()
}

#[test]
fn a_step_newton_cannot_take_is_halved_until_it_converges() {
    let mut reference = Solver::new(problem(), SolverSettings::default(), 0.0).unwrap();
    for k in 1..=8 {
        reference.advance(1.0, 0.0, Drive::Displacement([0.0, -DELTA_MM * k as f64 / 8.0])).unwrap();
    }
    let expected = vertical_force(&reference);

    // Six Newton iterations are too few for the whole press in one step
    // (the contact zone grows from nothing), enough for small sub-steps.
    // (With six, one sub-step converges on its last allowed iteration: the
    // solver once failed that step with a residual below its tolerance.)
    let settings = SolverSettings { max_iterations: 6, ..SolverSettings::default() };
    let mut solver = Solver::new(problem(), settings, 0.0).unwrap();
    let report = solver.advance(1.0, 0.0, Drive::Displacement([0.0, -DELTA_MM])).unwrap();
    eprintln!("one 0.08 mm step: {} halvings, {} Newton iterations", report.cuts, report.iterations);
    assert!(report.cuts > 0, "the step converged without cutting: the test does not exercise step cutting");
    assert!((report.t_s - 1.0).abs() < 1e-12, "the sub-steps add up to the step: t = {}", report.t_s);
    let force = vertical_force(&solver);
    assert!(
        (force / expected - 1.0).abs() < 1e-6,
        "force after halved steps {force} N/mm vs {expected} N/mm in 8 plain steps"
    );
}

#[test]
fn a_step_that_fails_after_every_halving_is_a_clear_error() {
    let settings = SolverSettings { max_iterations: 1, max_cuts: 3, ..SolverSettings::default() };
    let mut solver = Solver::new(problem(), settings, 0.0).unwrap();
    let error = solver.advance(0.5, 0.0, Drive::Displacement([0.0, -DELTA_MM])).unwrap_err();
    let message = error.to_string();
    eprintln!("{message}");
    match error {
        SolveError::NotConverged { t_s, step, cuts, residual, tolerance, .. } => {
            assert_eq!(step, 1);
            assert_eq!(cuts, 3);
            assert!(t_s > 0.0 && t_s <= 0.5 / 8.0 + 1e-12, "failed sub-step ends at t = {t_s} s");
            assert!(residual.is_finite() && residual > tolerance, "residual {residual} vs tolerance {tolerance}");
        }
        other => panic!("expected NotConverged, got {other:?}"),
    }
    for part in ["t = ", "step 1", "3 step halvings", "force residual", "tolerance"] {
        assert!(message.contains(part), "the message does not say {part:?}: {message}");
    }
}
