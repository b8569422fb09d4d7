//! Issue 19: the live engine over a voltage map (`haptex live
//! --voltage-map`): a replayed planar log against the offline render of
//! the same path, a map extruded from a line against the line's engine,
//! the map's touch lines, and the fades and limits.

use std::sync::atomic::Ordering;

use haptex_core::live::{
    LiveConfig, LiveEngine, Touch, TouchAxes, TouchEvent, TouchLine, TouchStamper, parse_touch_line,
};
use haptex_core::map::{MapGrid, VoltageMap};
use haptex_core::planar::PlanarTrajectory;
use haptex_core::realtime::{PlanarRenderer, RealtimeConfig, RealtimeRenderer};
use haptex_core::signal::{RenderSettings, VoltageCurve, render_map};

const FS: u32 = 48_000;

fn at(t_s: f64, x_mm: f64, y_mm: f64) -> TouchEvent {
    TouchEvent { t_s, touch: Touch::AtXY(x_mm, y_mm), received: None }
}

/// 81 x 41 cells over 8 x 4 mm: U = 50 + 30 sin(2 pi x / 2.5) cos(2 pi y /
/// 3) + 10 y, up to 110 V (the U_max clamp of 100 V acts somewhere).
fn map() -> VoltageMap {
    let grid = MapGrid { nx: 81, ny: 41, x0_mm: 0.0, y0_mm: 0.0, dx_mm: 0.1, dy_mm: 0.1 };
    let tau = std::f64::consts::TAU;
    let mut voltage_v = Vec::with_capacity(grid.len());
    for j in 0..grid.ny {
        for i in 0..grid.nx {
            let (x, y) = (grid.x(i), grid.y(j));
            voltage_v.push(50.0 + 30.0 * (tau * x / 2.5).sin() * (tau * y / 3.0).cos() + 10.0 * y);
        }
    }
    VoltageMap { grid, voltage_v, u_max_v: 100.0, not_renderable_fraction: 0.0, clipped_fraction: 0.0 }
}

/// Renders `engine` for `frames` frames in buffers of 256.
fn run<R: haptex_core::live::LiveRenderer>(engine: &mut LiveEngine<R>, channels: usize, frames: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; channels * frames];
    for chunk in out.chunks_mut(channels * 256) {
        engine.process(chunk, || None);
    }
    out
}

/// A touch log of a constant-velocity diagonal at 120 Hz ((0.5, 0.3) mm +
/// (30, 12) mm/s, 0.25 s), replayed on the output clock, against the
/// offline render of the same log (`haptex play --voltage-map`) as a
/// float32 WAV holds it (volts / volts_per_full_scale). After the 20 ms
/// start ramp and up to the last report every sample agrees within one
/// f32 step at full scale (2^-23): the extrapolation of a constant
/// velocity is exact in both coordinates, and both carriers are the same
/// polynomial sine. The fades and the last clamp behave as on a line.
#[test]
fn replayed_planar_log_equals_the_offline_render_after_the_start_ramp() {
    let map = map();
    let log_t: Vec<f64> = (0..=30).map(|k| k as f64 / 120.0).collect();
    let log_x: Vec<f64> = log_t.iter().map(|t| 0.5 + 30.0 * t).collect();
    let log_y: Vec<f64> = log_t.iter().map(|t| 0.3 + 12.0 * t).collect();
    let path = PlanarTrajectory::new(log_t.clone(), log_x.clone(), log_y.clone()).unwrap();
    let offline = render_map(&map, &path, &RenderSettings::DEFAULT).unwrap();
    assert!(offline.report.clip.clamped_samples > 0, "the path reaches the U_max clamp");

    let renderer = PlanarRenderer::new(&map, &RealtimeConfig::default()).unwrap();
    let vpfs = renderer.volts_per_full_scale();
    let config = LiveConfig::new(2);
    let events = (0..log_t.len()).map(|k| at(log_t[k], log_x[k], log_y[k])).collect();
    let mut engine = LiveEngine::new(renderer, &config).unwrap().with_schedule(events).unwrap();
    let status = engine.status();
    let n = offline.len() + (config.ramp_s * FS as f64) as usize + 2000;
    let out = run(&mut engine, 2, n);
    let ramp = (config.ramp_s * FS as f64).ceil() as usize;
    let last = (log_t[30] * FS as f64).floor() as usize;
    let mut worst = 0.0f32;
    for i in ramp..last {
        worst = worst.max((out[2 * i] - (offline.signal_v[i] / vpfs) as f32).abs());
        assert_eq!(out[2 * i + 1], 0.0, "a map's design has one channel: channel 2 is silent");
    }
    assert!(worst <= f32::EPSILON, "worst {worst} (f32 step {})", f32::EPSILON);
    // Start ramp from 0; silent after the stop's fade; every event applied
    // at its own sample; the peak never above the bound; nothing clamped.
    assert_eq!(out[0], 0.0);
    assert!(out[2 * (last + ramp + 2)..].iter().all(|&v| v == 0.0));
    assert!(engine.is_finished());
    assert_eq!(status.events.load(Ordering::Relaxed), 31);
    assert!(status.max_latency_s() < 1.0 / FS as f64);
    assert_eq!(status.clamped_samples.load(Ordering::Relaxed), 0);
    assert!(f64::from(status.peak()) * vpfs <= 100.0 * std::f64::consts::SQRT_2 * (1.0 + 1e-6));
    // The figures carry the last position in both coordinates: the last
    // report extrapolated for the 50 ms horizon, then held.
    let figures = status.figures(FS, 0.0, 0);
    let y_last = figures.y_mm.expect("a map's figures have a y");
    let (x_end, y_end) = (log_x[30] + 30.0 * 0.05, log_y[30] + 12.0 * 0.05);
    assert!((figures.x_mm - x_end).abs() < 1e-9 && (y_last - y_end).abs() < 1e-9, "{figures:?}");
    let json = serde_json::to_value(figures).unwrap();
    assert!(json["y_mm"].is_number());
}

/// A map whose rows are all one voltage curve (the curve at the grid's x,
/// the way `haptex map from-profile` extrudes a profile), played along a
/// wandering y, gives the line engine's output for the same x log: the
/// map's bilinear sampling on equal rows is the line's interpolation. The
/// line renderer reads the curve from a lookup table on the same uniform
/// points, so the two agree to rounding (within one f32 step).
#[test]
fn a_map_extruded_from_a_line_plays_the_line() {
    let grid = MapGrid { nx: 201, ny: 9, x0_mm: 0.0, y0_mm: -2.0, dx_mm: 0.05, dy_mm: 0.5 };
    let xs: Vec<f64> = (0..grid.nx).map(|i| grid.x(i)).collect();
    let u: Vec<f64> = xs.iter().map(|&x| 40.0 + 35.0 * (-((x - 5.0) / 1.2).powi(2)).exp()).collect();
    let curve = VoltageCurve::new(xs.clone(), u.clone()).unwrap();
    let voltage_v: Vec<f64> = (0..grid.ny).flat_map(|_| u.iter().copied()).collect();
    let map = VoltageMap { grid, voltage_v, u_max_v: 100.0, not_renderable_fraction: 0.0, clipped_fraction: 0.0 };

    let log_t: Vec<f64> = (0..=48).map(|k| k as f64 / 120.0).collect();
    let x = |t: f64| 1.0 + 20.0 * t;
    let y = |t: f64| -1.5 + 2.5 * (7.0 * t).sin();
    let plane: Vec<TouchEvent> = log_t.iter().map(|&t| at(t, x(t), y(t))).collect();
    let line: Vec<TouchEvent> =
        log_t.iter().map(|&t| TouchEvent { t_s: t, touch: Touch::At(x(t)), received: None }).collect();
    let config = LiveConfig::new(1);
    let mut on_map = LiveEngine::new(PlanarRenderer::new(&map, &RealtimeConfig::default()).unwrap(), &config)
        .unwrap()
        .with_schedule(plane)
        .unwrap();
    let mut on_line = LiveEngine::new(RealtimeRenderer::new(&curve, &RealtimeConfig::default()).unwrap(), &config)
        .unwrap()
        .with_schedule(line)
        .unwrap();
    let frames = (0.45 * FS as f64) as usize;
    let (a, b) = (run(&mut on_map, 1, frames), run(&mut on_line, 1, frames));
    let worst = a.iter().zip(&b).fold(0.0f32, |m, (p, q)| m.max((p - q).abs()));
    assert!(a.iter().any(|&v| v.abs() > 0.3), "the output plays");
    assert!(worst <= f32::EPSILON, "worst {worst}");
}

/// Over a map a touch needs x and y: a schedule with an x alone is refused
/// naming the event; a queued x alone is not applied. The map's touch
/// lines are `x_mm,y_mm` (stamped on arrival) and `t_s,x_mm,y_mm`.
#[test]
fn a_map_takes_positions_in_x_and_y() {
    let renderer = PlanarRenderer::new(&map(), &RealtimeConfig::default()).unwrap();
    let events = vec![at(0.0, 1.0, 1.0), TouchEvent { t_s: 0.01, touch: Touch::At(2.0), received: None }];
    let error = LiveEngine::new(renderer.clone(), &LiveConfig::new(1)).unwrap().with_schedule(events).unwrap_err();
    assert!(error.to_string().contains("touch event 2") && error.to_string().contains("x only"), "{error}");
    let mut engine = LiveEngine::new(renderer, &LiveConfig::new(1)).unwrap();
    let mut out = vec![0.0f32; 480];
    let mut x_only = Some(TouchEvent { t_s: 0.0, touch: Touch::At(2.0), received: None });
    engine.process(&mut out, || x_only.take());
    assert_eq!(engine.status().events.load(Ordering::Relaxed), 0);
    assert!(out.iter().all(|&v| v == 0.0));

    let xy = TouchAxes::XY;
    assert_eq!(parse_touch_line("3.5, 1", xy), Ok(Some(TouchLine::AtXY { t_s: None, x_mm: 3.5, y_mm: 1.0 })));
    assert_eq!(parse_touch_line("0.25,4,7,9", xy), Ok(Some(TouchLine::AtXY { t_s: Some(0.25), x_mm: 4.0, y_mm: 7.0 })));
    assert_eq!(parse_touch_line("t_s,x_mm,y_mm", xy), Ok(None));
    assert_eq!(parse_touch_line("lift", xy), Ok(Some(TouchLine::Lift)));
    assert!(parse_touch_line("3.5", xy).unwrap_err().contains("'y_mm'"));
    assert_eq!(parse_touch_line("1,2,inf", xy), Err("field 'y_mm': expected a finite number, got 'inf'".into()));
    assert_eq!(parse_touch_line("1,x", xy), Err("field 'y_mm': expected a finite number, got 'x'".into()));
    // A line design keeps its format: two fields are t_s,x_mm.
    assert_eq!(parse_touch_line("1,2", TouchAxes::X), Ok(Some(TouchLine::At { t_s: Some(1.0), x_mm: 2.0 })));
    let mut stamper = TouchStamper::default();
    let line = TouchLine::AtXY { t_s: Some(1.0), x_mm: 2.0, y_mm: 3.0 };
    assert_eq!(stamper.stamp(line, 5.0), (5.0, Touch::AtXY(2.0, 3.0)));
    assert_eq!(stamper.stamp(TouchLine::AtXY { t_s: None, x_mm: 1.0, y_mm: 2.0 }, 6.0), (6.0, Touch::AtXY(1.0, 2.0)));
}

/// Reports over a map that stop without a lift fade the output to exactly
/// 0 within gap + ramp of the last one (through the queue, as a live
/// source), and a lift fades it within the ramp.
#[test]
fn planar_input_lost_or_lifted_fades_out() {
    let map = map();
    let config = LiveConfig::new(1);
    for lift in [false, true] {
        let mut engine =
            LiveEngine::new(PlanarRenderer::new(&map, &RealtimeConfig::default()).unwrap(), &config).unwrap();
        let (mut out, mut samples, mut t, mut last_report) = (vec![0.0f32; 400], Vec::new(), 0.0, 0.0);
        while t < 0.6 {
            let mut event = if t < 0.3 {
                last_report = t;
                Some(at(t, 1.0 + 10.0 * t, 2.0 - 3.0 * t))
            } else if lift {
                Some(TouchEvent { t_s: t, touch: Touch::Lift, received: None })
            } else {
                None
            };
            engine.process(&mut out, || event.take());
            samples.extend_from_slice(&out);
            t += 400.0 / FS as f64;
        }
        let last_nonzero = samples.iter().rposition(|&v| v != 0.0).unwrap() as f64 / FS as f64;
        let bound =
            if lift { last_report + 400.0 / FS as f64 + config.ramp_s } else { last_report + config.dropout_s() };
        assert!(last_nonzero <= bound, "lift {lift}: last non-zero sample at {last_nonzero} s > {bound} s");
        assert!(last_nonzero > last_report, "lift {lift}: it played up to the last report");
    }
}
