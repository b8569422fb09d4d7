//! Real-time renderer: time per output sample (issue 7 target: at most
//! 20 ns). Each iteration fills one 480-sample buffer (10 ms at 48 kHz)
//! after a touch report, as an audio callback fed at 100 Hz would.
//! Run: `cargo bench -p haptex-core --bench realtime`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use haptex_core::realtime::{RealtimeConfig, RealtimeRenderer};
use haptex_core::signal::{AmplitudeCurve, Carrier, CarrierShape, Extend, Limits, VoltageCurve};
use std::hint::black_box;

const BUFFER: usize = 480;

fn curve() -> VoltageCurve {
    // A 40 mm texture sampled every 0.01 mm (4001 points).
    let x: Vec<f64> = (0..=4000).map(|i| i as f64 * 0.01).collect();
    let u = x.iter().map(|x| 60.0 + 30.0 * (x * 3.1).sin() + 10.0 * (x * 17.0).sin()).collect();
    VoltageCurve::new(x, u).unwrap()
}

fn bench(c: &mut Criterion) {
    let curve = curve();
    let mut group = c.benchmark_group("realtime_fill");
    group.throughput(Throughput::Elements(BUFFER as u64));
    let cases = [
        ("sine_hold", CarrierShape::Sine, Extend::Hold, None),
        ("sine_hold_slew", CarrierShape::Sine, Extend::Hold, Some(50_000.0)),
        ("square_zero", CarrierShape::Square, Extend::Zero, None),
        ("none_repeat", CarrierShape::None, Extend::Repeat, None),
        ("sine_repeat", CarrierShape::Sine, Extend::Repeat, None),
    ];
    for (name, shape, extend, slew) in cases {
        let config = RealtimeConfig {
            carrier: Carrier { shape, frequency_hz: 1000.0 },
            limits: Limits { slew_v_per_s: slew, ..Limits::DEFAULT },
            extend,
            ..RealtimeConfig::default()
        };
        let mut renderer = RealtimeRenderer::new(&curve, &config).unwrap();
        let mut buffer = vec![0.0f32; BUFFER];
        let mut k = 0u64;
        group.bench_function(name, |b| {
            b.iter(|| {
                // The finger sweeps back and forth at 100 mm/s over the texture.
                let t = renderer.now_s();
                let x = 20.0 + 15.0 * (t * 100.0 / 15.0).sin();
                renderer.touch(t, black_box(x));
                renderer.fill(black_box(&mut buffer));
                k += 1;
            })
        });
    }
    // A combined design on two channels: drive and ultrasonic amplitude
    // into interleaved frames (as `haptex live` writes them).
    let x = curve.x_mm().to_vec();
    let amplitude = AmplitudeCurve::new(x.clone(), x.iter().map(|x| 1.0 + (x * 1.7).cos()).collect()).unwrap();
    let mut renderer = RealtimeRenderer::two_channel(&curve, &amplitude, 1.5, &RealtimeConfig::default()).unwrap();
    let mut frames = vec![0.0f32; 2 * BUFFER];
    group.bench_function("sine_hold_two_channel_frames", |b| {
        b.iter(|| {
            let t = renderer.now_s();
            let x = 20.0 + 15.0 * (t * 100.0 / 15.0).sin();
            renderer.touch(t, black_box(x));
            renderer.fill_frames(black_box(&mut frames), 2);
        })
    });
    // Issue 19: the planar renderer over a 40 x 40 mm map (401 x 401
    // cells, 0.1 mm), the finger on a circle at 100 mm/s: the same buffer
    // and report rate, compared with sine_hold above (target: within 2x
    // its cost per sample).
    let grid = haptex_core::map::MapGrid { nx: 401, ny: 401, x0_mm: 0.0, y0_mm: 0.0, dx_mm: 0.1, dy_mm: 0.1 };
    let voltage_v = (0..grid.len())
        .map(|k| {
            let (x, y) = (grid.x(k % grid.nx), grid.y(k / grid.nx));
            60.0 + 30.0 * (x * 3.1).sin() * (y * 1.3).cos() + 10.0 * (x * 17.0).sin()
        })
        .collect();
    let map = haptex_core::map::VoltageMap {
        grid,
        voltage_v,
        u_max_v: 100.0,
        not_renderable_fraction: 0.0,
        clipped_fraction: 0.0,
    };
    let mut planar = haptex_core::realtime::PlanarRenderer::new(&map, &RealtimeConfig::default()).unwrap();
    let mut buffer = vec![0.0f32; BUFFER];
    group.bench_function("planar_sine_hold", |b| {
        b.iter(|| {
            let t = planar.now_s();
            let (x, y) = (20.0 + 15.0 * (t * 100.0 / 15.0).sin(), 20.0 + 15.0 * (t * 100.0 / 15.0).cos());
            planar.touch(t, black_box(x), black_box(y));
            planar.fill(black_box(&mut buffer));
        })
    });
    // The live engine's callback (`LiveEngine::process`: renderer, fades,
    // last clamp, counters) on a line and over the map: what `haptex live`
    // runs per buffer, one report per buffer through the queue closure.
    use haptex_core::live::{LiveConfig, LiveEngine, Touch, TouchEvent};
    let renderer = RealtimeRenderer::new(&curve, &RealtimeConfig::default()).unwrap();
    let mut engine = LiveEngine::new(renderer, &LiveConfig::new(1)).unwrap();
    group.bench_function("live_process_line", |b| {
        b.iter(|| {
            let t = engine.renderer().now_s();
            let mut event =
                Some(TouchEvent { t_s: t, touch: Touch::At(20.0 + 15.0 * (t * 100.0 / 15.0).sin()), received: None });
            engine.process(black_box(&mut buffer), || event.take());
        })
    });
    let planar = haptex_core::realtime::PlanarRenderer::new(&map, &RealtimeConfig::default()).unwrap();
    let mut engine = LiveEngine::new(planar, &LiveConfig::new(1)).unwrap();
    group.bench_function("live_process_planar", |b| {
        b.iter(|| {
            let t = engine.renderer().now_s();
            let w = t * 100.0 / 15.0;
            let touch = Touch::AtXY(20.0 + 15.0 * w.sin(), 20.0 + 15.0 * w.cos());
            let mut event = Some(TouchEvent { t_s: t, touch, received: None });
            engine.process(black_box(&mut buffer), || event.take());
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
