//! Issue 16 part 4: the real-time renderer drives both channels of a
//! combined design, with the conventions of the offline two-channel
//! render (`haptex play`): channel 1 the electrovibration drive in V,
//! channel 2 the ultrasonic amplitude a(x(t)) in um, clamped to a_max,
//! without carrier.

use haptex_core::realtime::{RealtimeConfig, RealtimeRenderer, Sample};
use haptex_core::signal::{AmplitudeCurve, Extend, Limits, RenderSettings, VoltageCurve, render_two_channel};
use haptex_core::trajectory::Trajectory;
use proptest::prelude::*;

const FS: u32 = 48_000;

#[path = "support/two_channel_design.rs"]
mod two_channel_design;
use two_channel_design::design;

/// The finger: 0.5 mm to 9.5 mm at a constant 36 mm/s (0.25 s).
fn finger(t_s: f64) -> f64 {
    0.5 + 36.0 * t_s
}

/// The real-time renderer fed 120 Hz touch reports of a constant-velocity
/// sweep against the offline two-channel render of the same sweep. From
/// the second report on, the extrapolation is exact (constant velocity),
/// so both render the same positions. Tolerances: position 1e-9 mm and
/// envelope and amplitude 1e-9 (rounding; the lookup tables hold the
/// uniform curve's own points); the drive 1e-9 V (both carriers are the
/// same polynomial sine; the phases, n f / fs in f64 offline and a 64-bit
/// accumulator live, differ by rounding).
#[test]
fn both_channels_agree_with_the_offline_two_channel_render() {
    let (u, a) = design();
    let a_max = 2.0;
    let duration_s = 0.25;
    let report_every = FS as usize / 120; // 400 samples
    let n = (duration_s * FS as f64) as usize + 1;
    let times: Vec<f64> = (0..n).map(|i| i as f64 / FS as f64).collect();
    let trajectory = Trajectory::new(times.clone(), times.iter().map(|&t| finger(t)).collect()).unwrap();
    let offline = render_two_channel(&u, &a, a_max, &trajectory, &RenderSettings::DEFAULT).unwrap();
    let offline_a = offline.amplitude_um.as_ref().unwrap();
    assert_eq!(offline.len(), n);
    let us = offline.report.ultrasonic.as_ref().unwrap();
    assert!(us.clamped_samples > 0, "the sweep reaches the a_max clamp");
    assert!(offline.report.clip.clamped_samples > 0, "the sweep reaches the U_max clamp");

    let config = RealtimeConfig::default();
    let mut live = RealtimeRenderer::two_channel(&u, &a, a_max, &config).unwrap();
    assert_eq!((live.channels(), live.a_max_um()), (2, Some(2.0)));
    let mut samples = vec![Sample::ZERO; report_every];
    let (mut worst_x, mut worst_u, mut worst_s, mut worst_a, mut compared, mut clamped) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0usize, 0usize);
    let mut i = 0;
    while i < n {
        live.touch_now(finger(live.now_s()));
        live.fill_samples(&mut samples);
        for s in samples.iter().take(n - i) {
            if i >= 2 * report_every {
                worst_x = worst_x.max((s.x_mm - offline.x_mm[i]).abs());
                worst_u = worst_u.max((s.envelope_v - offline.envelope_v[i]).abs());
                worst_s = worst_s.max((s.signal_v - offline.signal_v[i]).abs());
                worst_a = worst_a.max((s.amplitude_um - offline_a[i]).abs());
                clamped += usize::from(s.amplitude_um == a_max);
                compared += 1;
            }
            i += 1;
        }
    }
    assert!(compared > 10_000 && clamped > 0, "{compared} samples compared, {clamped} at a_max");
    assert!(worst_x < 1e-9, "position {worst_x} mm");
    assert!(worst_u < 1e-9, "envelope {worst_u} V");
    assert!(worst_a < 1e-9, "amplitude {worst_a} um");
    assert!(worst_s < 1e-9, "drive {worst_s} V");
}

/// Channel 1 of the two-channel renderer is the one-channel renderer's
/// output bit for bit, and the one-channel renderer writes 0 on channel 2
/// of a frame: adding the channel changed nothing for one-channel designs.
#[test]
fn channel_one_is_the_one_channel_renderer_unchanged() {
    let (u, a) = design();
    for extend in [Extend::Hold, Extend::Zero, Extend::Repeat] {
        let config = RealtimeConfig {
            extend,
            limits: Limits { slew_v_per_s: Some(30_000.0), ..Limits::DEFAULT },
            ..RealtimeConfig::default()
        };
        let mut one = RealtimeRenderer::new(&u, &config).unwrap();
        let mut two = RealtimeRenderer::two_channel(&u, &a, 1.5, &config).unwrap();
        assert_eq!((one.channels(), one.a_max_um()), (1, None));
        let (mut s1, mut s2) = (vec![Sample::ZERO; 256], vec![Sample::ZERO; 256]);
        let mut frames = vec![7.0f32; 2 * 256];
        let mut a_seen = 0.0f64;
        for k in 0..200 {
            let t = one.now_s();
            let x = -2.0 + 14.0 * (t * 3.0).sin().abs();
            if k == 80 {
                one.release();
                two.release();
            } else {
                one.touch(t, x);
                two.touch(t, x);
            }
            if k % 2 == 0 {
                one.fill_samples(&mut s1);
                two.fill_samples(&mut s2);
                for (p, q) in s1.iter().zip(&s2) {
                    assert_eq!(p.signal_v.to_bits(), q.signal_v.to_bits(), "{extend:?}");
                    assert_eq!(p.envelope_v.to_bits(), q.envelope_v.to_bits(), "{extend:?}");
                    assert_eq!(p.amplitude_um, 0.0);
                    a_seen = a_seen.max(q.amplitude_um);
                }
            } else {
                one.fill_frames(&mut frames, 2);
                assert!(frames.chunks(2).all(|f| f[1] == 0.0), "one-channel frames: channel 2 silent");
                two.fill_frames(&mut frames, 2);
            }
        }
        assert!(a_seen > 1.0, "{extend:?}: channel 2 played ({a_seen} um)");
    }
}

/// Random design: a voltage and an amplitude curve over random spans,
/// values up to twice the limits, and a random a_max.
fn arb_design() -> impl Strategy<Value = (VoltageCurve, AmplitudeCurve, f64, Extend)> {
    (
        2usize..60,
        -20.0f64..20.0,
        0.01f64..3.0,
        prop::collection::vec((0.0f64..200.0, 0.0f64..100.0), 60),
        0.01f64..50.0,
        0usize..3,
    )
        .prop_map(|(n, x0, dx, values, a_max, e)| {
            let x: Vec<f64> = (0..n).map(|i| x0 + dx * i as f64).collect();
            let u = values[..n].iter().map(|v| v.0).collect();
            let a = values[..n].iter().map(|v| v.1).collect();
            let extend = [Extend::Hold, Extend::Zero, Extend::Repeat][e];
            (VoltageCurve::new(x.clone(), u).unwrap(), AmplitudeCurve::new(x, a).unwrap(), a_max, extend)
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// Over random designs and touch streams (random times, including
    /// late, repeated and out-of-order reports, positions far outside the
    /// span, lifts): channel 2 stays within 0 ..= a_max, channel 1 within
    /// sqrt(2) U_max (the sine peak at U_max = 100 V), and the frames
    /// within full scale. Channel 2 and the frames exact (clamped, a safety
    /// limit); the drive within 1e-12 of sqrt(2) U_max (the envelope times
    /// the carrier, a few roundings).
    #[test]
    fn outputs_never_exceed_their_limits(
        (u, a, a_max, extend) in arb_design(),
        touches in prop::collection::vec((-0.02f64..0.05, -1e3f64..1e3, 0u8..10), 1..40),
    ) {
        let config = RealtimeConfig { extend, ..RealtimeConfig::default() };
        let mut r = RealtimeRenderer::two_channel(&u, &a, a_max, &config).unwrap();
        let mut samples = vec![Sample::ZERO; 97];
        let mut frames = vec![0.0f32; 3 * 97];
        let peak = std::f64::consts::SQRT_2 * config.limits.u_max_v;
        for (dt, x, kind) in touches {
            match kind {
                0 => r.release(),
                1 => r.touch(r.now_s() + dt, f64::NAN),
                _ => r.touch(r.now_s() + dt, x),
            }
            r.fill_samples(&mut samples);
            for s in &samples {
                prop_assert!((0.0..=a_max).contains(&s.amplitude_um), "a = {} um > a_max {a_max}", s.amplitude_um);
                prop_assert!(s.signal_v.abs() <= peak * (1.0 + 1e-12), "drive {} V", s.signal_v);
            }
            r.fill_frames(&mut frames, 3);
            for f in frames.chunks(3) {
                prop_assert!(f[0].abs() <= 1.0 && (0.0..=1.0).contains(&f[1]) && f[2] == 0.0, "{f:?}");
            }
        }
    }
}
