//! Issue 7 acceptance: the real-time renderer's position estimate against
//! the true trajectory, for touch reports at 60 Hz (and 120, 240 Hz).
//!
//! The finger makes minimum-jerk strokes (Flash & Hogan 1985) between 0 and
//! 20 mm at a mean 100 mm/s: peak velocity v = 1.875 x 100 = 187.5 mm/s,
//! peak acceleration a = (10 / sqrt 3) L / D^2 = 2887 mm/s^2 (L = 20 mm,
//! D = 0.2 s). Reports carry the exact position at t_k = k T; the renderer
//! runs at 48 kHz. Bounds (Taylor with remainder, report interval T):
//! - hold (no extrapolation): |error| <= v T;
//! - two-point velocity extrapolation: |error(t_k + tau)| <=
//!   a (tau^2 / 2 + tau T / 2) <= a T^2;
//! - with the blended correction over b <= T (the default b = 4 ms), the
//!   correction left from the previous report adds at most a T^2:
//!   |error| <= 2 a T^2; and the estimate is continuous: its change per
//!   sample is at most (v + a T^2 / b) / fs, where holding jumps by up to
//!   v T at every report and plain extrapolation by up to a T^2.
//!
//! Run with `-- --nocapture` to print the figures quoted in BENCHMARKS.md
//! and docs/playback.md.

use haptex_core::realtime::{RealtimeConfig, RealtimeRenderer};
use haptex_core::signal::VoltageCurve;

const FS: u32 = 48_000;
const L_MM: f64 = 20.0;
const STROKE_S: f64 = 0.2;

/// The true finger position: minimum-jerk strokes 0 <-> 20 mm, 0.2 s each.
fn truth(t: f64) -> f64 {
    let k = (t / STROKE_S).floor();
    let s = t / STROKE_S - k;
    let shape = s * s * s * (10.0 + s * (-15.0 + 6.0 * s));
    if (k as i64) % 2 == 0 { L_MM * shape } else { L_MM * (1.0 - shape) }
}

struct Errors {
    rms_mm: f64,
    max_mm: f64,
    max_step_mm: f64,
}

/// Runs 2 s (10 strokes) with reports every `report_samples` samples and
/// returns the position error statistics after the first two reports.
fn run(report_samples: usize, horizon_s: f64, blend_s: f64) -> Errors {
    let curve = VoltageCurve::new(vec![-5.0, 25.0], vec![50.0, 50.0]).unwrap();
    let config = RealtimeConfig { horizon_s, blend_s, ..RealtimeConfig::default() };
    let mut renderer = RealtimeRenderer::new(&curve, &config).unwrap();
    let (mut sum_sq, mut max, mut max_step, mut count) = (0.0, 0.0f64, 0.0f64, 0usize);
    let mut previous: Option<f64> = None;
    for n in 0..2 * FS as usize {
        if n % report_samples == 0 {
            let t = renderer.now_s();
            renderer.touch(t, truth(t));
        }
        let sample = renderer.next_sample();
        if n >= 2 * report_samples {
            let error = sample.x_mm - truth(sample.t_s);
            sum_sq += error * error;
            max = max.max(error.abs());
            count += 1;
            if let Some(p) = previous {
                max_step = max_step.max((sample.x_mm - p).abs());
            }
        }
        previous = Some(sample.x_mm);
    }
    Errors { rms_mm: (sum_sq / count as f64).sqrt(), max_mm: max, max_step_mm: max_step }
}

#[test]
fn extrapolation_error_against_the_true_trajectory() {
    let v_peak = 1.875 * L_MM / STROKE_S;
    let a_peak = 10.0 / 3f64.sqrt() * L_MM / (STROKE_S * STROKE_S);
    println!("minimum-jerk strokes 0..20 mm, mean 100 mm/s (peak {v_peak} mm/s, {a_peak:.0} mm/s^2), fs = {FS} Hz");
    println!("report rate | method | RMS error (mm) | max error (mm) | largest step per sample (mm)");
    for report_hz in [60u32, 120, 240] {
        let report_samples = (FS / report_hz) as usize;
        let t = 1.0 / report_hz as f64;
        let hold = run(report_samples, 0.0, 0.0);
        let extrapolated = run(report_samples, 0.05, 0.0);
        let blend_s = RealtimeConfig::default().blend_s;
        assert!(blend_s <= t);
        let blended = run(report_samples, 0.05, blend_s);
        for (name, e) in [("hold", &hold), ("extrapolate", &extrapolated), ("extrapolate + blend", &blended)] {
            println!("{report_hz} Hz | {name} | {:.4} | {:.4} | {:.4}", e.rms_mm, e.max_mm, e.max_step_mm);
        }
        let slack = 1.0 + 1e-9;
        assert!(hold.max_mm <= v_peak * t * slack, "{report_hz} Hz hold: {}", hold.max_mm);
        assert!(extrapolated.max_mm <= a_peak * t * t * slack, "{report_hz} Hz: {}", extrapolated.max_mm);
        assert!(blended.max_mm <= 2.0 * a_peak * t * t * slack, "{report_hz} Hz blended: {}", blended.max_mm);
        assert!(
            blended.max_step_mm <= (v_peak + a_peak * t * t / blend_s) / FS as f64 * slack,
            "{report_hz} Hz blended step {}",
            blended.max_step_mm
        );
        // Extrapolation is the point: it beats holding the last report.
        assert!(extrapolated.rms_mm < hold.rms_mm && blended.rms_mm < hold.rms_mm);
    }
}
