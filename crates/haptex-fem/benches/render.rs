//! Closing the loop: one check (the FE finger on the display under eq.
//! (8)'s voltage for the central bump's database profile, 10 mm + 1 mm
//! run-up at 0.05 mm steps, default mesh, visco-elastic) and a full
//! compensation of the same target (issue 15's budgets: 0.5 s and 5 s).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use haptex_core::profile::FrictionProfile;
use haptex_fem::render::{self, DEFAULT_LOAD_N_PER_MM, RenderSettings, Stopping};
use haptex_fem::scenario::{Scenario, run};
use haptex_fem::surface::SurfaceShape;

fn bench(c: &mut Criterion) {
    let bump = SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 };
    let target: FrictionProfile = run(&Scenario::paper(bump), &mut |_| {}).unwrap().profile.unwrap();
    let mut settings = RenderSettings::new(0.5, DEFAULT_LOAD_N_PER_MM);
    settings.scenario.step_mm = 0.05;
    let mut group = c.benchmark_group("render");
    group.sample_size(10);
    group.bench_function("check_bump_eq8", |b| {
        b.iter(|| render::check(black_box(&target), &settings, &mut |_| {}).unwrap())
    });
    group.bench_function("compensate_bump", |b| {
        b.iter(|| render::compensate(black_box(&target), &settings, Stopping::default(), &mut |_, _| {}).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
