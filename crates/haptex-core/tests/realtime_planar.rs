//! Issue 19: the real-time renderer over a voltage map, against the
//! offline render of the same planar path (`haptex play --voltage-map`),
//! and its limits.

use haptex_core::map::{MapGrid, VoltageMap};
use haptex_core::planar::PlanarTrajectory;
use haptex_core::realtime::{PlanarRenderer, PlanarSample, RealtimeConfig, RealtimeRenderer, Sample};
use haptex_core::signal::{Extend, Limits, RenderSettings, SignalError, VoltageCurve, render_map};
use proptest::prelude::*;

const FS: u32 = 48_000;

/// A 81 x 41 map over 8 x 4 mm: U = 50 + 30 sin(2 pi x / 2.5) cos(2 pi y /
/// 3) + 10 y, up to 110 V (above U_max = 100 V somewhere, so the clamp acts).
fn map() -> VoltageMap {
    let grid = MapGrid { nx: 81, ny: 41, x0_mm: 0.0, y0_mm: 0.0, dx_mm: 0.1, dy_mm: 0.1 };
    let mut voltage_v = Vec::with_capacity(grid.len());
    for j in 0..grid.ny {
        for i in 0..grid.nx {
            let (x, y) = (grid.x(i), grid.y(j));
            let tau = std::f64::consts::TAU;
            voltage_v.push(50.0 + 30.0 * (tau * x / 2.5).sin() * (tau * y / 3.0).cos() + 10.0 * y);
        }
    }
    VoltageMap { grid, voltage_v, u_max_v: 100.0, not_renderable_fraction: 0.0, clipped_fraction: 0.0 }
}

/// The finger: a straight diagonal at constant velocity (30, 12) mm/s from
/// (0.5, 0.3) mm, for 0.25 s.
fn finger(t_s: f64) -> (f64, f64) {
    (0.5 + 30.0 * t_s, 0.3 + 12.0 * t_s)
}

/// 120 Hz reports of a constant-velocity diagonal against the offline
/// render of the same path: from the second report on the extrapolation
/// is exact in both coordinates, so the positions, envelopes and drives
/// agree to rounding (1e-9: the offline path interpolates its samples, the
/// renderer extrapolates its reports; both carriers are the same
/// polynomial sine, the phases differ by rounding).
#[test]
fn follows_a_planar_path_as_the_offline_render() {
    let map = map();
    let duration_s = 0.25;
    let n = (duration_s * FS as f64) as usize + 1;
    let t: Vec<f64> = (0..n).map(|i| i as f64 / FS as f64).collect();
    let (x, y): (Vec<f64>, Vec<f64>) = t.iter().map(|&t| finger(t)).unzip();
    let path = PlanarTrajectory::new(t, x, y).unwrap();
    let offline = render_map(&map, &path, &RenderSettings::DEFAULT).unwrap();
    assert!(offline.report.clip.clamped_samples > 0, "the path reaches the U_max clamp");

    let mut live = PlanarRenderer::new(&map, &RealtimeConfig::default()).unwrap();
    let report_every = FS as usize / 120;
    let mut samples = vec![PlanarSample::ZERO; report_every];
    let (mut worst_x, mut worst_u, mut worst_s, mut compared) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    let mut i = 0;
    while i < n {
        let (x, y) = finger(live.now_s());
        live.touch_now(x, y);
        live.fill_samples(&mut samples);
        for s in samples.iter().take(n - i) {
            if i >= 2 * report_every {
                let (_, y_want) = finger(s.t_s);
                worst_x = worst_x.max((s.x_mm - offline.x_mm[i]).abs()).max((s.y_mm - y_want).abs());
                worst_u = worst_u.max((s.envelope_v - offline.envelope_v[i]).abs());
                worst_s = worst_s.max((s.signal_v - offline.signal_v[i]).abs());
                compared += 1;
            }
            i += 1;
        }
    }
    assert!(compared > 10_000, "{compared}");
    assert!(worst_x < 1e-9, "position {worst_x} mm");
    assert!(worst_u < 1e-9, "envelope {worst_u} V");
    assert!(worst_s < 1e-9, "drive {worst_s} V");
}

/// Along a row of a map extruded from a profile (every row the same), the
/// planar renderer is the line renderer of that profile, sample for
/// sample: on a grid line the map is the 1-D interpolation of its row.
/// Positions equal bit for bit (the same extrapolation); voltages within
/// 1e-12 V (the line renderer's table multiplies by 1/dx, the map divides
/// by dx: rounding).
#[test]
fn along_a_row_it_is_the_line_renderer() {
    let grid = MapGrid { nx: 101, ny: 3, x0_mm: 0.0, y0_mm: 0.0, dx_mm: 0.1, dy_mm: 0.5 };
    let row: Vec<f64> = (0..grid.nx).map(|i| 40.0 + 35.0 * (grid.x(i) * 1.7).sin()).collect();
    let voltage_v = [row.clone(), row.clone(), row.clone()].concat();
    let map = VoltageMap { grid, voltage_v, u_max_v: 100.0, not_renderable_fraction: 0.0, clipped_fraction: 0.0 };
    let x: Vec<f64> = (0..grid.nx).map(|i| grid.x(i)).collect();
    let curve = VoltageCurve::new(x, row).unwrap();
    let config = RealtimeConfig::default();
    let (mut planar, mut line) =
        (PlanarRenderer::new(&map, &config).unwrap(), RealtimeRenderer::new(&curve, &config).unwrap());
    let (mut a, mut b) = (vec![PlanarSample::ZERO; 400], vec![Sample::ZERO; 400]);
    for k in 0..60 {
        let x = 1.0 + 0.13 * k as f64;
        planar.touch_now(x, 0.5);
        line.touch_now(x);
        planar.fill_samples(&mut a);
        line.fill_samples(&mut b);
        for (p, l) in a.iter().zip(&b) {
            assert_eq!((p.t_s, p.x_mm, p.y_mm), (l.t_s, l.x_mm, 0.5), "report {k}");
            assert!((p.envelope_v - l.envelope_v).abs() < 1e-12, "report {k}: {} vs {}", p.envelope_v, l.envelope_v);
            assert!((p.signal_v - l.signal_v).abs() < 1e-12, "report {k}: {} vs {}", p.signal_v, l.signal_v);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Safety over random maps and touch streams: no sample above the
    /// peak bound, which is at most sqrt(2) U_max; silence after a release.
    /// The bound within 1e-15 relative (sqrt(2) times U_max, one rounding);
    /// the samples within 1e-12 of it (a product of the bounded envelope and
    /// a carrier within 1, a few roundings).
    #[test]
    fn never_above_u_max(
        values in proptest::collection::vec(0.0f64..300.0, 16),
        touches in proptest::collection::vec((-20.0f64..20.0, -20.0f64..20.0, 1usize..800), 1..30),
        u_max in 10.0f64..150.0,
    ) {
        let grid = MapGrid { nx: 4, ny: 4, x0_mm: -3.0, y0_mm: 1.0, dx_mm: 2.0, dy_mm: 1.5 };
        let map = VoltageMap { grid, voltage_v: values, u_max_v: u_max, not_renderable_fraction: 0.0,
            clipped_fraction: 0.0 };
        let config = RealtimeConfig {
            limits: Limits { u_max_v: u_max, ..Limits::DEFAULT },
            volts_per_full_scale: std::f64::consts::SQRT_2 * u_max,
            ..RealtimeConfig::default()
        };
        let mut r = PlanarRenderer::new(&map, &config).unwrap();
        prop_assert!(r.peak_bound_v() <= std::f64::consts::SQRT_2 * u_max * (1.0 + 1e-15));
        let mut out = vec![0.0f64; 800];
        for &(x, y, n) in &touches {
            r.touch_now(x, y);
            r.fill_volts(&mut out[..n]);
            for &v in &out[..n] {
                prop_assert!(v.abs() <= r.peak_bound_v() * (1.0 + 1e-12), "{v} V");
            }
        }
        r.release();
        let mut samples = vec![PlanarSample::ZERO; 10];
        r.fill_samples(&mut samples);
        prop_assert!(samples.iter().all(|s| s.envelope_v == 0.0 && s.signal_v == 0.0));
    }
}

/// Bad settings and maps are refused with what is wrong.
#[test]
fn bad_maps_and_settings_are_refused() {
    let m = map();
    let e = PlanarRenderer::new(&m, &RealtimeConfig { extend: Extend::Repeat, ..RealtimeConfig::default() });
    assert!(matches!(&e, Err(SignalError::Settings(s)) if s.contains("holds its edge")), "{e:?}");
    let mut nan = m.clone();
    nan.voltage_v[85] = f64::NAN;
    let e = PlanarRenderer::new(&nan, &RealtimeConfig::default()).unwrap_err().to_string();
    assert!(e.contains("cell 85 (column 4, row 1)"), "{e}");
    let mut short = m.clone();
    short.voltage_v.pop();
    assert!(PlanarRenderer::new(&short, &RealtimeConfig::default()).is_err());
    // Peak sqrt(2) x 100 V (U_max clamps the 110 V cells) above a 120 V full scale.
    let small = RealtimeConfig { volts_per_full_scale: 120.0, ..RealtimeConfig::default() };
    assert!(matches!(PlanarRenderer::new(&m, &small), Err(SignalError::ExceedsFullScale { .. })));
}
