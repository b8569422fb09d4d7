//! Issue 7 acceptance: the real-time renderer does not allocate per output
//! sample. A counting global allocator (in this test binary only) counts
//! allocations made by the test's own thread while the fill loop runs:
//! touch reports, buffer fills, lift-off, touch-down and every carrier and
//! extension mode, over 2 s of output. The expected count is exactly 0.

#[path = "support/counting_alloc.rs"]
mod counting_alloc;

use counting_alloc::allocations_in;
use haptex_core::realtime::{RealtimeConfig, RealtimeRenderer};
use haptex_core::signal::{AmplitudeCurve, Carrier, CarrierShape, Extend, Limits, VoltageCurve};

#[test]
fn fill_loop_does_not_allocate() {
    // The counter works: a Vec allocates.
    assert_eq!(allocations_in(|| drop(std::hint::black_box(vec![1u8; 16]))), 1);

    let x: Vec<f64> = (0..=2000).map(|i| i as f64 * 0.01).collect();
    let u = x.iter().map(|x| 60.0 + 50.0 * (x * 3.0).sin()).collect();
    let a = x.iter().map(|x| 1.0 + (x * 2.0).cos()).collect();
    let curve = VoltageCurve::new(x.clone(), u).unwrap();
    let amplitude = AmplitudeCurve::new(x, a).unwrap();
    let shapes = [CarrierShape::Sine, CarrierShape::Square, CarrierShape::None];
    for (shape, extend) in shapes.into_iter().zip([Extend::Hold, Extend::Zero, Extend::Repeat]) {
        let config = RealtimeConfig {
            carrier: Carrier { shape, frequency_hz: 1000.0 },
            limits: Limits { u_max_v: 100.0, slew_v_per_s: Some(20_000.0), amplifier_range_v: Some(150.0) },
            extend,
            ..RealtimeConfig::default()
        };
        // One- and two-channel renderers (the combined design's amplitude
        // channel written into interleaved frames).
        for two in [false, true] {
            let mut renderer = if two {
                RealtimeRenderer::two_channel(&curve, &amplitude, 1.5, &config).unwrap()
            } else {
                RealtimeRenderer::new(&curve, &config).unwrap()
            };
            let mut buffer = vec![0.0f32; 256];
            let mut frames = vec![0.0f32; 512];
            let mut volts = vec![0.0f64; 256];
            let mut peak = 0.0f32;
            let count = allocations_in(|| {
                // 2 s at 48 kHz in 256-sample buffers, a touch report every
                // 800 samples (60 Hz), the finger lifted for a while in the middle.
                let mut rendered = 0usize;
                let mut next_report = 0usize;
                while rendered < 96_000 {
                    if rendered >= next_report {
                        let t = renderer.now_s();
                        if (0.9..1.1).contains(&t) {
                            renderer.release();
                        } else {
                            renderer.touch(t, -3.0 + 30.0 * t);
                        }
                        next_report += 800;
                    }
                    if rendered.is_multiple_of(768) {
                        renderer.fill_frames(&mut frames, 2);
                    } else if rendered.is_multiple_of(512) {
                        renderer.fill(&mut buffer);
                    } else {
                        renderer.fill_volts(&mut volts);
                    }
                    peak = buffer.iter().fold(peak, |m, v| m.max(v.abs()));
                    rendered += 256;
                }
            });
            assert_eq!(count, 0, "{shape:?}/{extend:?}/two channels {two}: {count} allocations in the fill loop");
            assert!(peak > 0.1 && peak <= 1.0, "{shape:?}: peak {peak} of full scale");
        }
    }
}

/// A 200 x 100 voltage map, 0.1 mm cells, 10 .. 110 V.
fn planar_map() -> haptex_core::map::VoltageMap {
    use haptex_core::map::{MapGrid, VoltageMap};
    let grid = MapGrid { nx: 200, ny: 100, x0_mm: 0.0, y0_mm: 0.0, dx_mm: 0.1, dy_mm: 0.1 };
    let voltage_v = (0..grid.len()).map(|k| 60.0 + 50.0 * (k as f64 * 0.01).sin()).collect();
    VoltageMap { grid, voltage_v, u_max_v: 100.0, not_renderable_fraction: 0.0, clipped_fraction: 0.0 }
}

/// Issue 19: the planar renderer's fill loop does not allocate either
/// (reports in x and y, a lift-off, every carrier).
#[test]
fn planar_fill_loop_does_not_allocate() {
    let map = planar_map();
    for shape in [CarrierShape::Sine, CarrierShape::Square, CarrierShape::None] {
        let config = RealtimeConfig { carrier: Carrier { shape, frequency_hz: 1000.0 }, ..RealtimeConfig::default() };
        let mut renderer = haptex_core::realtime::PlanarRenderer::new(&map, &config).unwrap();
        let (mut buffer, mut volts) = (vec![0.0f32; 256], vec![0.0f64; 256]);
        let count = allocations_in(|| {
            let mut rendered = 0usize;
            while rendered < 96_000 {
                if rendered.is_multiple_of(768) {
                    let t = renderer.now_s();
                    if (0.9..1.1).contains(&t) {
                        renderer.release();
                    } else {
                        renderer.touch(t, -3.0 + 12.0 * t, 2.0 + 4.0 * t);
                    }
                }
                if rendered.is_multiple_of(512) {
                    renderer.fill(&mut buffer);
                } else {
                    renderer.fill_volts(&mut volts);
                }
                rendered += 256;
            }
        });
        assert_eq!(count, 0, "{shape:?}: {count} allocations in the planar fill loop");
    }
}

/// Issue 18: the live engine's callback (`LiveEngine::process`, what
/// `haptex live` runs on the audio thread) does not allocate either: touch
/// events from a bounded std channel (`try_recv`, the CLI's queue), a
/// scheduled log, the fades, a gap and the stop, two channels in four-channel
/// frames. The channel and the engine are built before counting.
#[test]
fn live_callback_does_not_allocate() {
    use haptex_core::live::{LiveConfig, LiveEngine, Touch, TouchEvent};
    let x: Vec<f64> = (0..=2000).map(|i| i as f64 * 0.01).collect();
    let u = x.iter().map(|x| 60.0 + 50.0 * (x * 3.0).sin()).collect();
    let a = x.iter().map(|x| 1.0 + (x * 2.0).cos()).collect();
    let curve = VoltageCurve::new(x.clone(), u).unwrap();
    let amplitude = AmplitudeCurve::new(x, a).unwrap();
    let renderer = RealtimeRenderer::two_channel(&curve, &amplitude, 1.5, &RealtimeConfig::default()).unwrap();
    let schedule = (0..50).map(|k| TouchEvent { t_s: 1.0 + k as f64 / 120.0, touch: Touch::At(5.0), received: None });
    let mut engine = LiveEngine::new(renderer, &LiveConfig::new(4)).unwrap().with_schedule(schedule.collect()).unwrap();
    let (sender, receiver) = std::sync::mpsc::sync_channel::<TouchEvent>(64);
    let mut out = vec![0.0f32; 4 * 256];
    let started = std::time::Instant::now();
    let count = allocations_in(|| {
        for k in 0..600 {
            let t = k as f64 * 256.0 / 48_000.0;
            if k % 2 == 0 && !(0.5..0.8).contains(&t) {
                let touch = if k == 100 { Touch::Lift } else { Touch::At(2.0 + 10.0 * t) };
                sender.try_send(TouchEvent { t_s: t, touch, received: Some(started) }).unwrap();
            }
            if k == 550 {
                engine.stop();
            }
            engine.process(&mut out, || receiver.try_recv().ok());
        }
    });
    assert_eq!(count, 0, "{count} allocations in the live callback");
    assert!(engine.is_finished());
    assert!(engine.status().events.load(std::sync::atomic::Ordering::Relaxed) > 200);
}

/// Issue 19: the live engine over a voltage map (`haptex live
/// --voltage-map`) allocates nothing in its callback either: (x, y)
/// touches from the bounded channel, a lift, a gap and the stop.
#[test]
fn planar_live_callback_does_not_allocate() {
    use haptex_core::live::{LiveConfig, LiveEngine, Touch, TouchEvent};
    let renderer = haptex_core::realtime::PlanarRenderer::new(&planar_map(), &RealtimeConfig::default()).unwrap();
    let mut engine = LiveEngine::new(renderer, &LiveConfig::new(2)).unwrap();
    let (sender, receiver) = std::sync::mpsc::sync_channel::<TouchEvent>(64);
    let mut out = vec![0.0f32; 2 * 256];
    let started = std::time::Instant::now();
    let count = allocations_in(|| {
        for k in 0..600 {
            let t = k as f64 * 256.0 / 48_000.0;
            if k % 2 == 0 && !(0.5..0.8).contains(&t) {
                let touch = if k == 100 { Touch::Lift } else { Touch::AtXY(1.0 + 2.0 * t, 0.5 + t) };
                sender.try_send(TouchEvent { t_s: t, touch, received: Some(started) }).unwrap();
            }
            if k == 550 {
                engine.stop();
            }
            engine.process(&mut out, || receiver.try_recv().ok());
        }
    });
    assert_eq!(count, 0, "{count} allocations in the planar live callback");
    assert!(engine.is_finished());
    assert!(engine.status().events.load(std::sync::atomic::Ordering::Relaxed) > 200);
    assert!(engine.status().peak() > 0.1, "it played");
}
