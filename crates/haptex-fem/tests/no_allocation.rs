//! The step loop does not allocate (issue 3): once the operators of a step
//! size exist, `Solver::advance` and the reaction check run on memory
//! allocated up front. A counting global allocator (haptex-core's
//! `tests/support/counting_alloc.rs`, counting this test's thread only)
//! sees no allocation over 30 slide steps over a bump.

#[path = "../../haptex-core/tests/support/counting_alloc.rs"]
mod counting_alloc;

use counting_alloc::allocations_in;
use haptex_fem::scenario::{Scenario, build_problem};
use haptex_fem::solver::{Drive, Solver};
use haptex_fem::surface::SurfaceShape;

#[test]
fn step_loop_does_not_allocate() {
    // The counter works: a Vec allocates.
    assert_eq!(allocations_in(|| drop(std::hint::black_box(vec![1u8; 16]))), 1);
    let scenario = Scenario::paper(SurfaceShape::Bump { x0: 3.0, width: 1.5, height: 0.3 });
    let (problem, lift) = build_problem(&scenario).unwrap();
    let mut solver = Solver::new(problem, scenario.settings, lift).unwrap();
    let dt_press = scenario.press_time_s / scenario.press_steps as f64;
    for k in 1..=scenario.press_steps {
        solver.advance(dt_press, 0.0, Drive::Displacement([0.0, -0.025 * k as f64])).unwrap();
    }
    let dt = 0.1 / scenario.velocity_mm_s;
    // First slide step builds the operators for this step size.
    solver.advance(dt, 0.1, Drive::Displacement([0.0, -0.25])).unwrap();
    let count = allocations_in(|| {
        for k in 2..=31 {
            solver.advance(dt, 0.1 * k as f64, Drive::Displacement([0.0, -0.25])).unwrap();
            solver.driven_reaction();
        }
    });
    assert_eq!(count, 0, "{count} allocations in 30 steps");
}
