//! The recording pipeline (issue 6 acceptance): round trip of a synthetic
//! stroke from a known mu(x), the anti-alias filter's attenuation, sliding
//! detection with pauses and reversals, and the error for no sliding.

use std::f64::consts::TAU;

use haptex_core::recording::filter::{LowPassFir, resample_filtered};
use haptex_core::recording::rng::SplitMix64;
use haptex_core::recording::synth::{PressProfile, StrokeModel, Tone, Trajectory};
use haptex_core::recording::{
    Direction, DirectionFilter, ProcessingConfig, Recording, RecordingError, RecordingMeta, StreamMeta, Units, process,
};

fn meta() -> RecordingMeta {
    RecordingMeta {
        format: "haptex-recording-1".into(),
        material: "test".into(),
        material_description: String::new(),
        participant: "P1".into(),
        stroke: 1,
        force: StreamMeta { file: String::new(), rate_hz: 20_000.0 },
        position: StreamMeta { file: String::new(), rate_hz: 400.0 },
        units: Units::default(),
        source: "test".into(),
        licence: "CC0-1.0".into(),
        synthetic: true,
        notes: String::new(),
        extra: serde_json::Value::Null,
    }
}

/// The known surface: two sines, wavelengths 8 and 3 mm.
fn true_mu(x: f64) -> f64 {
    0.6 + 0.1 * (TAU * x / 8.0).sin() + 0.05 * (TAU * x / 3.0 + 1.0).sin()
}

struct Noise {
    force_n: f64,
    position_mm: f64,
}

/// A 20 kHz / 400 Hz stroke over `true_mu` with Fn = 0.5 N (5% wobble at 1.5 Hz).
fn stroke(trajectory: &Trajectory, fn0_n: f64, noise: Noise, tones: &[Tone], seed: u64) -> Recording {
    let press = PressProfile {
        fn0_n,
        wobble: 0.05,
        wobble_hz: 1.5,
        wobble_phase: 0.3,
        ramp_s: 0.08,
        duration_s: trajectory.duration_s(),
    };
    let fn_n = |t: f64| press.at(t);
    let model = StrokeModel {
        force_rate_hz: 20_000.0,
        position_rate_hz: 400.0,
        trajectory,
        mu: &true_mu,
        fn_n: &fn_n,
        stiction_speed_mm_s: 2.0,
        force_noise_n: noise.force_n,
        position_noise_mm: noise.position_mm,
        tones,
    };
    let (force, position) = model.generate(&mut SplitMix64::new(seed));
    Recording::from_parts("synthetic", meta(), force, position).unwrap()
}

/// 0 -> 60 mm in 0.9 s (mean 67 mm/s, peak 125 mm/s), at rest before and after.
fn one_stroke() -> Trajectory {
    Trajectory::starting_at(0.0).hold(0.15).move_to(60.0, 0.9).hold(0.15)
}

fn errors(profile: &haptex_core::FrictionProfile) -> (f64, f64) {
    let e: Vec<f64> = profile.x_mm().iter().zip(profile.mu()).map(|(x, m)| m - true_mu(*x)).collect();
    let max = e.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let rms = (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt();
    (max, rms)
}

const FIVE_KHZ: Tone = Tone { frequency_hz: 5000.0, amplitude_n: 0.1 };

/// Without noise the only error is resolution: mu is known at the 400 Hz
/// position samples, up to 125/400 = 0.3125 mm apart, and interpolated
/// linearly between them; the bound h^2/8 max|mu''| = 0.3125^2/8 * 0.281 =
/// 0.0034 (mu'' <= 0.1 (2 pi/8)^2 + 0.05 (2 pi/3)^2 = 0.281 /mm^2).
#[test]
fn round_trip_without_noise_is_within_the_interpolation_bound() {
    let rec = stroke(&one_stroke(), 0.5, Noise { force_n: 0.0, position_mm: 0.0 }, &[], 1);
    let p = process(&rec, &ProcessingConfig::default()).unwrap();
    let (max, _) = errors(&p.profile);
    assert!(max <= 0.0035, "max |mu error| {max}");
}

/// Issue 6 acceptance: a stroke made from a known mu(x), with 5 mN white
/// force noise, 0.01 mm position noise and a 0.1 N 5 kHz disturbance on both
/// force channels, comes back to mu(x) within max 0.012 and RMS 0.004.
/// Budget: interpolation <= 0.0034 (above); force noise after the ~200 Hz
/// filter 5 mN sqrt(200/10000) = 0.7 mN, i.e. 0.0017 RMS in mu at 0.5 N;
/// position noise 0.01 mm times |mu'| <= 0.18 /mm, at most 0.0018.
#[test]
fn round_trip_known_mu_with_noise_and_5khz_disturbance() {
    let rec = stroke(&one_stroke(), 0.5, Noise { force_n: 0.005, position_mm: 0.01 }, &[FIVE_KHZ], 1);
    let p = process(&rec, &ProcessingConfig::default()).unwrap();
    let (max, rms) = errors(&p.profile);
    assert!(max <= 0.012 && rms <= 0.004, "max {max}, rms {rms}");
    // The profile covers the stroke except where the finger is slower than
    // 10 mm/s (the first and last ~0.5 mm) and the trimmed ends.
    let x = p.profile.x_mm();
    assert!(x[0] < 1.0 && x[x.len() - 1] > 59.0, "{} .. {}", x[0], x[x.len() - 1]);
    assert_eq!(p.segments.len(), 1);
    // Fn_RS: the mean of 0.5 (1 + 0.05 sin) N while sliding, within 1%.
    assert!((p.mean_fn_n - 0.5).abs() < 0.005, "{}", p.mean_fn_n);
    assert_eq!(p.profile.fn_n().unwrap().len(), p.profile.len());
}

/// The 5 kHz disturbance's effect on the profile, isolated: the same stroke
/// (same noise) with a 0.1 N and a 0 N tone. At least 60 dB of attenuation
/// means at most 0.1 mN of it left, 2e-4 in mu at 0.5 N.
#[test]
fn five_khz_disturbance_leaves_less_than_60_db() {
    let noise = || Noise { force_n: 0.005, position_mm: 0.01 };
    let with = stroke(&one_stroke(), 0.5, noise(), &[FIVE_KHZ], 2);
    let without = stroke(&one_stroke(), 0.5, noise(), &[Tone { amplitude_n: 0.0, ..FIVE_KHZ }], 2);
    let a = process(&with, &ProcessingConfig::default()).unwrap();
    let b = process(&without, &ProcessingConfig::default()).unwrap();
    assert_eq!(a.profile.x_mm(), b.profile.x_mm());
    let diff = a.profile.mu().iter().zip(b.profile.mu()).fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
    assert!(diff <= 2e-4, "{diff}");
}

/// The default anti-alias filter for 20 kHz -> 400 Hz, measured from its
/// taps: >= 60 dB at 5 kHz (acceptance), and the Kaiser design's 80 dB
/// over the whole stopband 250 Hz .. 10 kHz (Kaiser's formula is an
/// approximation: 0.5 dB allowed), passband 0-150 Hz flat within 0.01 dB.
#[test]
fn anti_alias_filter_attenuates_5khz_by_at_least_60_db() {
    let f = ProcessingConfig::default().anti_alias_filter(20_000.0, 400.0).unwrap();
    assert_eq!((f.passband_hz(), f.stopband_hz()), (150.0, 250.0));
    assert!(f.gain_db(5000.0) <= -60.0, "{}", f.gain_db(5000.0));
    let stop = (250..=10_000).map(|hz| f.gain_db(hz as f64)).fold(f64::NEG_INFINITY, f64::max);
    assert!(stop <= -79.5, "worst stopband gain {stop} dB");
    let ripple = (0..=150).map(|hz| f.gain_db(hz as f64).abs()).fold(0.0, f64::max);
    assert!(ripple <= 0.01, "passband ripple {ripple} dB");
}

/// The same, measured in the time domain: a 1 N 5 kHz sine through the
/// resampler to 400 Hz comes out below 1 mN (60 dB); a 50 Hz sine passes
/// with its amplitude within 0.01%.
#[test]
fn resampler_measured_on_sines() {
    let f = LowPassFir::kaiser(20_000.0, 150.0, 250.0, 80.0).unwrap();
    let t: Vec<f64> = (0..40_000).map(|i| i as f64 / 20_000.0).collect();
    // Output times between input samples; the sines have a phase offset so
    // that no output falls on a zero crossing.
    let times: Vec<f64> = (0..800).map(|k| k as f64 / 400.0 + 0.000_123_4).collect();
    let sine = |hz: f64| -> Vec<f64> { t.iter().map(|t| (TAU * hz * t + 0.7).sin()).collect() };
    let (hf, lf) = (sine(5000.0), sine(50.0));
    let r = resample_filtered(&t, &[&hf, &lf], &times, &f);
    assert!(r.valid.len() > 700);
    let peak_hf = r.columns[0].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let attenuation_db = -20.0 * peak_hf.log10();
    assert!(attenuation_db >= 60.0, "{attenuation_db} dB");
    for (k, y) in r.valid.clone().zip(&r.columns[1]) {
        assert!((y - (TAU * 50.0 * times[k] + 0.7).sin()).abs() <= 1e-4, "{k}: {y}");
    }
}

/// Sliding detection on a stroke with a pause and a reversal: +20 mm, a
/// 0.2 s pause, +15 mm, a 0.05 s stop, back -25 mm. Three segments, in that
/// order and direction, each inside its move; and the profile covers the
/// ground (the backward pass overlaps the forward ones and is averaged in).
#[test]
fn sliding_detection_finds_pauses_and_reversals() {
    let path = Trajectory::starting_at(5.0)
        .hold(0.15)
        .move_to(25.0, 0.3)
        .hold(0.2)
        .move_to(40.0, 0.25)
        .hold(0.05)
        .move_to(15.0, 0.4)
        .hold(0.15);
    let moves = [(0.15, 0.45), (0.65, 0.9), (0.95, 1.35)];
    let rec = stroke(&path, 0.4, Noise { force_n: 0.003, position_mm: 0.01 }, &[FIVE_KHZ], 3);
    let p = process(&rec, &ProcessingConfig::default()).unwrap();
    let directions: Vec<Direction> = p.segments.iter().map(|s| s.direction).collect();
    assert_eq!(directions, [Direction::Forward, Direction::Forward, Direction::Backward], "{:#?}", p.segments);
    for (segment, (t0, t1)) in p.segments.iter().zip(moves) {
        assert!(segment.t_start_s > t0 && segment.t_end_s < t1, "{segment:?} not inside {t0}..{t1}");
        // Most of each move is sliding: all but the slow (< 10 mm/s) ends.
        assert!(segment.duration_s() > 0.7 * (t1 - t0), "{segment:?}");
    }
    let x = p.profile.x_mm();
    assert!(x[0] < 6.0 && x[x.len() - 1] > 39.0, "{} .. {}", x[0], x[x.len() - 1]);
    let (max, _) = errors(&p.profile);
    assert!(max <= 0.012, "{max}");
    // Only the backward pass: its ground only.
    let backward =
        process(&rec, &ProcessingConfig { direction: DirectionFilter::Backward, ..ProcessingConfig::default() })
            .unwrap();
    let xb = backward.profile.x_mm();
    assert!(xb[0] > 15.0 && xb[xb.len() - 1] < 40.0, "{} .. {}", xb[0], xb[xb.len() - 1]);
    assert_eq!(backward.used, [false, false, true]);
}

/// A pause within a stroke: the two segments are joined across the short
/// stretch where the finger slows down and restarts (bridged, under 1 mm),
/// and the whole stroke comes back within the round-trip tolerance.
#[test]
fn a_pause_is_bridged_into_one_profile() {
    let path = Trajectory::starting_at(0.0).hold(0.15).move_to(20.0, 0.25).hold(0.2).move_to(40.0, 0.25).hold(0.15);
    let rec = stroke(&path, 0.5, Noise { force_n: 0.005, position_mm: 0.01 }, &[FIVE_KHZ], 6);
    let p = process(&rec, &ProcessingConfig::default()).unwrap();
    assert_eq!(p.segments.len(), 2);
    assert!(p.bridged_mm > 0.0 && p.bridged_mm <= 1.0, "{}", p.bridged_mm);
    let x = p.profile.x_mm();
    assert!(x[0] < 1.0 && x[x.len() - 1] > 39.0, "{} .. {}", x[0], x[x.len() - 1]);
    let (max, rms) = errors(&p.profile);
    assert!(max <= 0.012 && rms <= 0.004, "max {max}, rms {rms}");
    // Without bridging, the profile is the longer of the two segments.
    let unbridged = process(&rec, &ProcessingConfig { max_gap_mm: 0.0, ..ProcessingConfig::default() }).unwrap();
    assert!(unbridged.profile.span_mm() < 20.0 && unbridged.bridged_mm == 0.0);
}

/// A finger pressing without moving, and a finger moving without pressing,
/// give a NoSliding error that says why.
#[test]
fn no_sliding_gives_a_clear_error() {
    let still = Trajectory::starting_at(3.0).hold(1.0);
    let rec = stroke(&still, 0.5, Noise { force_n: 0.003, position_mm: 0.01 }, &[], 4);
    let err = process(&rec, &ProcessingConfig::default()).unwrap_err();
    assert!(matches!(err, RecordingError::NoSliding { .. }), "{err}");
    let message = err.to_string();
    assert!(message.contains("synthetic: no sliding found: the finger never moved at >= 10 mm/s"), "{message}");

    let hovering = one_stroke();
    let rec = stroke(&hovering, 0.0, Noise { force_n: 0.003, position_mm: 0.01 }, &[], 5);
    let message = process(&rec, &ProcessingConfig::default()).unwrap_err().to_string();
    assert!(message.contains("no sliding found") && message.contains("largest Fn"), "{message}");
}

#[test]
fn invalid_config_is_rejected() {
    let config = ProcessingConfig { passband_fraction: 0.7, ..ProcessingConfig::default() };
    let rec = stroke(&one_stroke(), 0.5, Noise { force_n: 0.0, position_mm: 0.0 }, &[], 1);
    let err = process(&rec, &config).unwrap_err();
    assert!(err.to_string().contains("stopband_fraction"), "{err}");
    let config = ProcessingConfig { dx_mm: 0.0, ..ProcessingConfig::default() };
    assert!(process(&rec, &config).unwrap_err().to_string().contains("dx_mm"));
}

/// Issue 35: a signed Ft is handled where it belongs. ft_n is the force
/// along +x; the pipeline turns it into friction by each segment's
/// direction (mu = sign(direction) ft_n / fn_n), so a stroke out and back
/// over a surface gives the same positive mu both ways. Where the true
/// friction is zero (10 mm of a frictionless strip), noise and the
/// filter's ringing at its edges average below zero at some nodes: those
/// are kept as measured and counted (`negative_nodes`); they stay within
/// the low-pass filter's ringing at the 0.6 step (at most the Gibbs
/// overshoot, 9% of the step: 0.054) plus the noise (0.005 N over 0.5 N,
/// 0.01 per sample before averaging): -0.065 (measured -0.040), while a
/// direction taken the wrong way round would give -0.6. A force that opposes the motion throughout (a
/// converter that flipped the sign) is refused, naming the segment.
#[test]
fn signed_ft_becomes_friction_by_the_sliding_direction() {
    let strip = |x: f64| if (20.0..30.0).contains(&x) { 0.0 } else { 0.6 };
    let path = Trajectory::starting_at(0.0).hold(0.15).move_to(50.0, 0.7).hold(0.1).move_to(0.0, 0.7).hold(0.15);
    let press = PressProfile {
        fn0_n: 0.5,
        wobble: 0.05,
        wobble_hz: 1.5,
        wobble_phase: 0.3,
        ramp_s: 0.08,
        duration_s: path.duration_s(),
    };
    let fn_n = |t: f64| press.at(t);
    let model = StrokeModel {
        force_rate_hz: 20_000.0,
        position_rate_hz: 400.0,
        trajectory: &path,
        mu: &strip,
        fn_n: &fn_n,
        stiction_speed_mm_s: 2.0,
        force_noise_n: 0.005,
        position_noise_mm: 0.01,
        tones: &[],
    };
    let (force, position) = model.generate(&mut SplitMix64::new(35));
    assert!(force.ft_n.iter().any(|&f| f < -0.2), "the backward stroke's ft_n is negative");
    let rec = Recording::from_parts("signed", meta(), force.clone(), position.clone()).unwrap();
    for direction in [DirectionFilter::Forward, DirectionFilter::Backward, DirectionFilter::Both] {
        let p = process(&rec, &ProcessingConfig { direction, ..ProcessingConfig::default() }).unwrap();
        let (x, mu) = (p.profile.x_mm(), p.profile.mu());
        let lowest = mu.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(lowest >= -0.065, "{direction:?}: lowest mu {lowest}: beyond ringing and noise, a wrong sign");
        assert!(p.negative_nodes() > 0, "{direction:?}: the frictionless strip should average below zero somewhere");
        assert_eq!(p.negative_nodes(), mu.iter().filter(|&&m| m < 0.0).count(), "{direction:?}");
        for (x, m) in x.iter().zip(mu) {
            if (22.0..28.0).contains(x) {
                assert!(*m <= 0.01, "{direction:?}: mu({x}) = {m} on the frictionless strip");
            } else if (3.0..18.0).contains(x) || (32.0..47.0).contains(x) {
                assert!((m - 0.6).abs() <= 0.02, "{direction:?}: mu({x}) = {m}, expected 0.6");
            }
        }
    }
    // The converter's sign flipped: the force opposes the motion.
    let flipped = haptex_core::recording::ForceStream { ft_n: force.ft_n.iter().map(|f| -f).collect(), ..force };
    let rec = Recording::from_parts("flipped", meta(), flipped, position).unwrap();
    let e = process(&rec, &ProcessingConfig::default()).unwrap_err().to_string();
    assert!(e.contains("opposes the motion") && e.contains("flip its sign"), "{e}");
}
