//! Robustness (issue 3): the full 10 mm slide converges for every template
//! at the corners of the database range, r_w in {0.5, 2.5} mm and r_h in
//! {0.1, 0.5} mm — features up to twice as high as the 0.25 mm press, so
//! they push deep into the pad. (A general-purpose solver, CalculiX 2.20
//! with node-to-surface penalty contact, stops converging a few mm into the
//! bump case, per issue 3.) Default finger, default mesh, visco-elastic.
//! Each run must produce a finite, positive-load profile over the whole
//! slide, with global equilibrium at every step (relative 1e-6).

use haptex_fem::scenario::{Scenario, run};
use haptex_fem::surface::SurfaceShape;

fn corners(make: fn(f64, f64) -> SurfaceShape) {
    for width in [0.5, 2.5] {
        for height in [0.1, 0.5] {
            let surface = make(width, height);
            let scenario = Scenario::paper(surface.clone());
            let result = run(&scenario, &mut |_| {}).unwrap_or_else(|e| panic!("{surface:?}: {e}"));
            let p = result.profile.as_ref().unwrap();
            assert!(
                (p.x_mm()[p.len() - 1] - 10.0).abs() < 1e-9,
                "{surface:?}: slide ended at {}",
                p.x_mm()[p.len() - 1]
            );
            assert!(p.mu().iter().all(|m| m.is_finite()), "{surface:?}");
            for row in &result.history {
                assert!(row.fn_n > 0.0, "{surface:?}: lost contact at {}", row.slide_mm);
                let error = (row.fn_n + row.reaction_n[1]).abs().max((row.ft_n - row.reaction_n[0]).abs());
                assert!(error <= 1e-6 * row.fn_n, "{surface:?}: equilibrium error {error} at t = {}", row.t_s);
            }
            let s = result.statistics;
            eprintln!(
                "{surface:?}: {} steps, {} Newton iterations, {} halvings",
                s.steps, s.newton_iterations, s.step_cuts
            );
        }
    }
}

#[test]
fn robust_bump_corners() {
    corners(|width, height| SurfaceShape::Bump { x0: 5.0, width, height });
}

#[test]
fn robust_edge_corners() {
    corners(|width, height| SurfaceShape::Edge { x0: 5.0, width, height });
}

#[test]
fn robust_sine_corners() {
    corners(|width, height| SurfaceShape::Sine { x0: 5.0, width, height });
}
