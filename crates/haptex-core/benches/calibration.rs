//! A calibration of 10,120 measurements with its intervals (issue 36's
//! target: under 2 s): the example device's protocol with 10 fingers and
//! 22 repetitions, every model (eq. 3 per carrier, the circuit across
//! seven carriers, the exponential rho(a) and its table). Run:
//! `cargo bench -p haptex-core --bench calibration`.

use criterion::{Criterion, criterion_group, criterion_main};
use haptex_core::calibration::virtual_device::{Noise, Protocol, example_truth, measure};
use haptex_core::calibration::{Settings, calibrate};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let protocol = Protocol { fingers: 10, repetitions: 22, ..Protocol::default() };
    let m = measure(&example_truth(), &protocol, &Noise::default(), 1).measurements;
    assert!(m.rows().len() >= 10_000, "{} rows", m.rows().len());
    let mut group = c.benchmark_group("calibration");
    group.sample_size(10);
    group.bench_function(format!("calibrate_{}_rows", m.rows().len()), |b| {
        b.iter(|| black_box(calibrate(black_box(&m), Settings::default())))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
