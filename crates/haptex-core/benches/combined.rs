//! Throughput of the combined display's mapping (both channels) on a
//! 1e6-sample profile, for each allocation strategy, with the literature
//! default and with a calibration table. Run:
//! `cargo bench -p haptex-core --bench combined`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use haptex_core::combined::{Channels, Strategy, map_display};
use haptex_core::electrovibration::Device;
use haptex_core::profile::FrictionProfile;
use haptex_core::ultrasonic::{Calibration, UltrasonicDevice};
use std::hint::black_box;

const N: usize = 1_000_000;

fn profile() -> FrictionProfile {
    // A friction profile sweeping below the band, through it (below and
    // above mu_HD = 1) and above it for the paper's device.
    let x: Vec<f64> = (0..N).map(|i| i as f64 * 1e-4).collect();
    let mu: Vec<f64> = x.iter().map(|x| 0.7 + 0.6 * (x * 2.0).sin()).collect();
    FrictionProfile::new(x, mu).unwrap()
}

fn bench(c: &mut Criterion) {
    let p = profile();
    let device = Device::PAPER;
    let literature = UltrasonicDevice::literature_default(None).unwrap();
    let calibration = Calibration::new(
        vec![0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5],
        vec![1.0, 0.97, 0.88, 0.72, 0.55, 0.42, 0.32, 0.21, 0.16],
        "bench",
    )
    .unwrap();
    let calibrated = UltrasonicDevice::calibrated(calibration, None).unwrap();
    let mut group = c.benchmark_group("combined_1e6");
    group.throughput(Throughput::Elements(N as u64));
    group.sample_size(20);
    for (name, us) in [("literature", &literature), ("calibration", &calibrated)] {
        for (strategy_name, strategy) in
            [("split", Strategy::Split), ("bias", Strategy::Bias), ("weighted", Strategy::Weighted { weight: 1.0 })]
        {
            group.bench_function(format!("map_display_{strategy_name}_{name}"), |b| {
                b.iter(|| map_display(black_box(&p), &device, Channels::Combined(us, strategy), None, None).unwrap())
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
