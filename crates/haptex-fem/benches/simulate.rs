//! The default simulation (issue 3 benchmark): default finger and mesh,
//! visco-elastic, bump x0 = 5, r_w = 1.5, r_h = 0.3 mm, 0.25 mm press in 10
//! steps, 10 mm slide at 20 mm/s in 0.1 mm steps, on one core (the solver
//! is sequential). Run: `cargo bench -p haptex-fem --bench simulate`.
//! Prints the run's steps and Newton iterations once. The same case with
//! finite strain (`default_bump_10mm_finite`) is measured in the same run,
//! so the two figures share the machine's state:
//! `cargo bench -p haptex-fem --bench simulate -- default_bump_10mm`.

use criterion::{Criterion, criterion_group, criterion_main};
use haptex_fem::scenario::{Kinematics, Scenario, run};
use haptex_fem::surface::SurfaceShape;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let scenario = Scenario::paper(SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 });
    let result = run(&scenario, &mut |_| {}).unwrap();
    eprintln!("default case: {:?}", result.statistics);
    let mut group = c.benchmark_group("simulate");
    group.sample_size(10);
    group.bench_function("default_bump_10mm", |b| b.iter(|| run(black_box(&scenario), &mut |_| {}).unwrap()));
    let mut elastic = scenario.clone();
    elastic.viscoelastic = false;
    group.bench_function("default_bump_10mm_elastic", |b| b.iter(|| run(black_box(&elastic), &mut |_| {}).unwrap()));
    let mut finite = scenario.clone();
    finite.kinematics = Kinematics::Finite;
    let result = run(&finite, &mut |_| {}).unwrap();
    eprintln!("default case, finite strain: {:?}", result.statistics);
    group.bench_function("default_bump_10mm_finite", |b| b.iter(|| run(black_box(&finite), &mut |_| {}).unwrap()));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
