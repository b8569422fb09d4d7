//! The step loop does not allocate (issue 3): once the operators of a step
//! size exist, `Solver::advance` and the reaction check run on memory
//! allocated up front. A counting global allocator (active on this test's
//! thread only) sees no allocation over 30 slide steps over a bump.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use haptex_fem::scenario::{Scenario, build_problem};
use haptex_fem::solver::{Drive, Solver};
use haptex_fem::surface::SurfaceShape;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.with(|c| c.get()) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if COUNTING.with(|c| c.get()) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn step_loop_does_not_allocate() {
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
    COUNTING.with(|c| c.set(true));
    for k in 2..=31 {
        solver.advance(dt, 0.1 * k as f64, Drive::Displacement([0.0, -0.25])).unwrap();
        solver.driven_reaction();
    }
    COUNTING.with(|c| c.set(false));
    let count = ALLOCATIONS.load(Ordering::Relaxed);
    assert_eq!(count, 0, "{count} allocations in 30 steps");
}
