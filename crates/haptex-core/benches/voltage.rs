//! Throughput of the friction -> voltage mapping (paper eqs. 8 and 9) on a
//! 1e6-sample profile. Run: `cargo bench -p haptex-core --bench voltage`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use haptex_core::electrovibration::{Device, Method, PhysicalMapping, map_profile, normalized_voltages};
use haptex_core::profile::FrictionProfile;
use std::hint::black_box;

const N: usize = 1_000_000;

fn profile() -> FrictionProfile {
    // A friction profile sweeping through the non-renderable, normal and
    // clipped ranges of the paper's device (mu_HD = 1, U_max = 100 V).
    let x: Vec<f64> = (0..N).map(|i| i as f64 * 1e-4).collect();
    let mu: Vec<f64> = x.iter().map(|x| 1.1 + 0.3 * (x * 2.0).sin()).collect();
    FrictionProfile::new(x, mu).unwrap()
}

fn bench(c: &mut Criterion) {
    let p = profile();
    let device = Device::PAPER;
    let mut out = vec![0.0; N];
    let mut group = c.benchmark_group("voltage_1e6");
    group.throughput(Throughput::Elements(N as u64));
    group.sample_size(30);
    let mapping = PhysicalMapping::new(device.mu_hd, device.force_ratio_per_v2(1.0), device.u_max_v);
    group.bench_function("eq8_fill", |b| b.iter(|| mapping.fill(black_box(p.mu()), &mut out)));
    group.bench_function("eq9_fill", |b| b.iter(|| normalized_voltages(black_box(p.mu()), 100.0, &mut out)));
    group.bench_function("map_profile_physical_with_summary", |b| {
        b.iter(|| map_profile(black_box(&p), &device, Method::Physical, None).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
