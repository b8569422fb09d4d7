//! Issue 7 acceptance, offline path: envelope frequency (FFT), safety
//! limits, WAV read-back with hound and with Python's standard library.

use std::path::Path;
use std::process::Command;

use haptex_core::electrovibration::{Device, Method, map_profile};
use haptex_core::profile::FrictionProfile;
use haptex_core::signal::{
    AmplitudeCurve, Carrier, CarrierShape, Extend, Limits, RenderSettings, SignalError, VoltageCurve, WavFormat,
    WavOptions, decode_drive_wav_channels, encode_wav, modulate_at_resonance, read_drive_wav, render,
    render_two_channel, sidecar_path, write_wav,
};
use haptex_core::trajectory::Trajectory;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex;

/// Voltage profile of a sinusoidal friction profile, mu = 1.1 + 0.05 sin(2 pi x / P)
/// over 0..40 mm, mapped with the paper's device (eq. 8): U from 50.1 to
/// 86.8 V, below U_max, with period P.
fn sine_surface_curve(period_mm: f64) -> VoltageCurve {
    let x: Vec<f64> = (0..=4000).map(|i| i as f64 * 0.01).collect();
    let mu = x.iter().map(|x| 1.1 + 0.05 * (std::f64::consts::TAU * x / period_mm).sin()).collect();
    let profile = FrictionProfile::new(x, mu).unwrap();
    let voltage = map_profile(&profile, &Device::PAPER, Method::Physical, None).unwrap();
    assert!(voltage.summary.clipped.is_empty() && voltage.summary.not_renderable.is_empty());
    VoltageCurve::from(&voltage)
}

/// Magnitude spectrum of `values` minus their mean.
fn spectrum(values: &[f64]) -> Vec<f64> {
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let mut buffer: Vec<Complex<f64>> = values.iter().map(|&v| Complex::new(v - mean, 0.0)).collect();
    FftPlanner::new().plan_fft_forward(buffer.len()).process(&mut buffer);
    buffer[..values.len() / 2].iter().map(|c| c.norm()).collect()
}

fn argmax(values: &[f64]) -> usize {
    (0..values.len()).fold(0, |best, i| if values[i] > values[best] { i } else { best })
}

/// Issue 7 acceptance: a constant-velocity trajectory over a sine-surface
/// voltage profile gives an envelope at velocity / period. 20 whole periods
/// are analysed, so the expected frequency falls on an FFT bin (resolution
/// fs/N) and the peak must be exactly that bin. The drive's strongest
/// components are the carrier and the sidebands at carrier +/- v/P (AM).
#[test]
fn sine_surface_envelope_is_at_velocity_over_period() {
    let period_mm = 2.0;
    let curve = sine_surface_curve(period_mm);
    let settings = RenderSettings { sample_rate_hz: 8000, ..RenderSettings::DEFAULT };
    for velocity_mm_s in [50.0, 100.0] {
        let expected_hz = velocity_mm_s / period_mm;
        let duration_s = 20.0 / expected_hz;
        let trajectory = Trajectory::constant_velocity(0.0, velocity_mm_s * duration_s, velocity_mm_s, 1000.0).unwrap();
        let signal = render(&curve, &trajectory, &settings).unwrap();
        let n = (duration_s * 8000.0).round() as usize;
        assert_eq!(signal.len(), n + 1);
        let resolution_hz = 8000.0 / n as f64;

        let envelope = spectrum(&signal.envelope_v[..n]);
        let peak_hz = argmax(&envelope) as f64 * resolution_hz;
        assert_eq!(peak_hz, expected_hz, "envelope peak at v = {velocity_mm_s} mm/s");

        let drive = spectrum(&signal.signal_v[..n]);
        let carrier_bin = (1000.0 / resolution_hz) as usize;
        assert_eq!(argmax(&drive), carrier_bin);
        let mut sidebands = drive.clone();
        sidebands[carrier_bin] = 0.0;
        let side_hz = argmax(&sidebands) as f64 * resolution_hz;
        assert!((side_hz - 1000.0).abs() == expected_hz, "sideband at {side_hz} Hz, expected 1000 +/- {expected_hz}");
    }
}

/// A ramp U = 20 x V/mm over 0..10 mm (0..200 V) swept at constant speed
/// with U_max = 100 V: the second half is clamped to exactly 100 V, the
/// report counts it (fraction within one sample), and the peak is
/// sqrt(2) x 100 V.
#[test]
fn clipping_is_clamped_and_reported() {
    let curve = VoltageCurve::new(vec![0.0, 10.0], vec![0.0, 200.0]).unwrap();
    let trajectory = Trajectory::constant_velocity(0.0, 10.0, 10.0, 1000.0).unwrap();
    let signal = render(&curve, &trajectory, &RenderSettings::DEFAULT).unwrap();
    let r = &signal.report;
    assert_eq!(r.envelope_max_v, 100.0);
    assert!(signal.envelope_v.iter().all(|&u| u <= 100.0));
    assert!((r.clip.clamped_fraction - 0.5).abs() <= 1.0 / r.n_samples as f64, "{}", r.clip.clamped_fraction);
    assert!((r.clip.requested_max_v - 200.0).abs() < 1e-9);
    assert_eq!(r.peak_v, 100.0 * std::f64::consts::SQRT_2);
    assert!(r.sample_peak_v <= r.peak_v);
    assert!(r.warnings.iter().any(|w| w.contains("clamped at U_max")), "{:?}", r.warnings);
    assert!(r.to_string().contains("clamped at U_max = 100 V"), "{r}");
}

/// A signal whose peak exceeds the declared amplifier range is refused,
/// not clipped: U = 90 V RMS on a sine is 127.3 V peak, above 120 V; the
/// same envelope on a square carrier (peak 90 V) fits.
#[test]
fn amplifier_range_is_refused_not_clipped() {
    let curve = VoltageCurve::new(vec![0.0, 10.0], vec![90.0, 90.0]).unwrap();
    let trajectory = Trajectory::constant_velocity(0.0, 10.0, 100.0, 1000.0).unwrap();
    let limits = Limits { amplifier_range_v: Some(120.0), ..Limits::DEFAULT };
    let sine = RenderSettings { limits, ..RenderSettings::DEFAULT };
    match render(&curve, &trajectory, &sine) {
        Err(SignalError::ExceedsAmplifierRange { amplitude_v, range_v, t_s, max_u_v }) => {
            assert!((amplitude_v - 90.0 * std::f64::consts::SQRT_2).abs() < 1e-9);
            assert_eq!((range_v, t_s), (120.0, 0.0));
            assert!((max_u_v - 120.0 / std::f64::consts::SQRT_2).abs() < 1e-9);
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
    let square = RenderSettings { carrier: Carrier { shape: CarrierShape::Square, frequency_hz: 500.0 }, ..sine };
    let signal = render(&curve, &trajectory, &square).unwrap();
    assert_eq!(signal.report.peak_v, 90.0);
    assert_eq!(signal.report.sample_peak_v, 90.0);
    // Clamping below the range makes the sine fit.
    let clamped = RenderSettings { limits: Limits { u_max_v: 84.0, ..limits }, ..sine };
    assert!(render(&curve, &trajectory, &clamped).is_ok());
}

/// A signal with clamping, a slew limit and both carriers' worth of
/// structure, used by the WAV tests: 0.25 s at 44.1 kHz.
fn test_signal() -> haptex_core::signal::DriveSignal {
    let (curve, trajectory, settings) = test_inputs();
    render(&curve, &trajectory, &settings).unwrap()
}

/// The voltage curve, trajectory and settings of [`test_signal`].
fn test_inputs() -> (VoltageCurve, Trajectory, RenderSettings) {
    let curve = VoltageCurve::new(vec![0.0, 2.0, 4.0], vec![10.0, 120.0, 30.0]).unwrap();
    let trajectory = Trajectory::strokes(0.0, 4.0, 32.0, 2, 1000.0).unwrap();
    let settings = RenderSettings {
        sample_rate_hz: 44_100,
        carrier: Carrier { shape: CarrierShape::Sine, frequency_hz: 700.0 },
        limits: Limits { u_max_v: 100.0, slew_v_per_s: Some(5000.0), amplifier_range_v: Some(150.0) },
        extend: Extend::Hold,
    };
    (curve, trajectory, settings)
}

/// WAV read-back with hound: rate, channels, bits, length, and every sample
/// within half a quantisation step (vpfs / full scale / 2) of the rendered
/// volts; 32-bit float within f32 rounding (2^-24 relative to full scale).
#[test]
fn wav_reads_back_with_hound_at_rate_length_and_scale() {
    let signal = test_signal();
    assert_eq!(signal.len(), 11_026);
    let dir = tempfile::tempdir().unwrap();
    let vpfs = 150.0;
    for format in [WavFormat::Pcm16, WavFormat::Pcm24, WavFormat::Float32] {
        let path = dir.path().join(format!("{format:?}.wav"));
        let options = WavOptions { format, volts_per_full_scale: vpfs };
        let sidecar = write_wav(&path, &signal, &options, serde_json::json!({"test": true})).unwrap();
        let (spec, volts) = hound_volts(&path, vpfs);
        assert_eq!((spec.sample_rate, spec.channels), (44_100, 1));
        // haptex's own reader takes the scale from the WAV and checks the
        // sidecar: the same volts as hound's with the sidecar's scale.
        let checked = read_drive_wav(&path).unwrap();
        assert_eq!(checked.volts, volts);
        let read_sidecar = checked.sidecar.as_ref().expect("the sidecar is found");
        assert_eq!(read_sidecar.samples_sha256, sidecar.samples_sha256);
        assert_eq!(checked.scale.volts_per_full_scale, vpfs);
        assert_eq!(volts.len(), signal.len());
        let tolerance = match format {
            WavFormat::Float32 => vpfs * 2f64.powi(-24),
            _ => 0.5 * vpfs / format.full_scale() * (1.0 + 1e-9),
        };
        let worst = volts.iter().zip(&signal.signal_v).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst <= tolerance, "{format:?}: error {worst} V > {tolerance} V");

        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(sidecar_path(&path)).unwrap()).unwrap();
        assert_eq!(json["volts_per_full_scale"], vpfs);
        assert_eq!(json["n_samples"], signal.len());
        assert_eq!(json["sample_rate_hz"], 44_100);
        assert_eq!(json["wav_file"], format!("{format:?}.wav"));
        assert_eq!(json["report"]["clip"]["clamped_samples"], signal.report.clip.clamped_samples);
        assert_eq!(sidecar.full_scale_value, format.full_scale());
    }
}

/// Reads a mono WAV with hound (an independent reader) as volts, given the
/// volts per full scale.
fn hound_volts(path: &std::path::Path, volts_per_full_scale: f64) -> (hound::WavSpec, Vec<f64>) {
    let mut reader = hound::WavReader::open(path).unwrap();
    let spec = reader.spec();
    let volts = match spec.sample_format {
        hound::SampleFormat::Float => {
            reader.samples::<f32>().map(|s| f64::from(s.unwrap()) * volts_per_full_scale).collect()
        }
        hound::SampleFormat::Int => {
            let full_scale = ((1i64 << (spec.bits_per_sample - 1)) - 1) as f64;
            reader.samples::<i32>().map(|s| f64::from(s.unwrap()) / full_scale * volts_per_full_scale).collect()
        }
    };
    (spec, volts)
}

/// A WAV whose full scale is below the drive's peak is refused and nothing
/// is written.
#[test]
fn wav_full_scale_below_peak_is_refused() {
    let signal = test_signal();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.wav");
    let options = WavOptions { format: WavFormat::Pcm16, volts_per_full_scale: 140.0 };
    let e = write_wav(&path, &signal, &options, serde_json::Value::Null).unwrap_err();
    assert!(matches!(e, SignalError::ExceedsFullScale { .. }), "{e}");
    assert!(e.to_string().contains("141.421"), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Reads a WAV with Python's standard library, independently of hound:
/// `wave` for 16-bit PCM, and for WAVE_FORMAT_EXTENSIBLE files (24-bit,
/// float; Python 3.11's `wave` reads only plain PCM) a RIFF parse with
/// `struct`. Volts per full scale come from the sidecar JSON. Prints
/// "rate n bits peak_volts".
const PYTHON_READER: &str = r#"
import json, struct, sys, wave
path = sys.argv[1]
side = json.load(open(path + ".json"))
vpfs, fs_value = side["volts_per_full_scale"], side["full_scale_value"]
data = open(path, "rb").read()
assert data[:4] == b"RIFF" and data[8:12] == b"WAVE"
pos, fmt, payload = 12, None, None
while pos < len(data):
    cid, size = data[pos:pos + 4], struct.unpack("<I", data[pos + 4:pos + 8])[0]
    body = data[pos + 8:pos + 8 + size]
    if cid == b"fmt ":
        fmt = struct.unpack("<HHIIHH", body[:16])
    elif cid == b"data":
        payload = body
    pos += 8 + size + (size & 1)
tag, channels, rate, _, _, bits = fmt
if tag == 1:
    with wave.open(path, "rb") as w:
        assert (w.getframerate(), w.getnchannels(), w.getsampwidth()) == (rate, 1, 2)
        n = w.getnframes()
        values = struct.unpack("<%dh" % n, w.readframes(n))
elif bits == 24:
    n = len(payload) // 3
    values = [int.from_bytes(payload[3 * i:3 * i + 3], "little", signed=True) for i in range(n)]
else:
    n = len(payload) // 4
    values = struct.unpack("<%df" % n, payload)
peak = max(abs(v) for v in values) / fs_value * vpfs
print(rate, n, bits, repr(peak))
"#;

/// Issue 7 acceptance: the WAVs read back with Python's standard library at
/// the right rate, length and scale (peak in volts within one quantisation
/// step of the rendered sample peak).
#[test]
fn wav_reads_back_with_python_at_rate_length_and_scale() {
    let signal = test_signal();
    let dir = tempfile::tempdir().unwrap();
    let vpfs = 200.0;
    for (format, bits) in [(WavFormat::Pcm16, 16), (WavFormat::Pcm24, 24), (WavFormat::Float32, 32)] {
        let path = dir.path().join(format!("{format:?}.wav"));
        write_wav(&path, &signal, &WavOptions { format, volts_per_full_scale: vpfs }, serde_json::Value::Null).unwrap();
        let (rate, n, read_bits, peak) = python_read(&path);
        assert_eq!((rate, n, read_bits), (44_100, signal.len(), bits), "{format:?}");
        let step = vpfs / format.full_scale();
        assert!(
            (peak - signal.report.sample_peak_v).abs() <= step.max(vpfs * 2f64.powi(-24)),
            "{format:?}: Python peak {peak} V, rendered {} V",
            signal.report.sample_peak_v
        );
    }
}

fn python_read(path: &Path) -> (u32, usize, u32, f64) {
    let out = Command::new("python3")
        .args(["-c", PYTHON_READER, path.to_str().unwrap()])
        .output()
        .expect("python3 must be installed to run this test");
    assert!(out.status.success(), "python: {}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let fields: Vec<&str> = text.split_whitespace().collect();
    (fields[0].parse().unwrap(), fields[1].parse().unwrap(), fields[2].parse().unwrap(), fields[3].parse().unwrap())
}

/// A two-channel test signal: the voltage of [`test_signal`] and an
/// amplitude curve that asks for more than a_max = 2 um in its middle.
fn two_channel_signal() -> (haptex_core::signal::DriveSignal, VoltageCurve, f64) {
    let (curve, trajectory, settings) = test_inputs();
    let (x, a) = (vec![0.0, 1.0, 2.5, 4.0], vec![0.0, 1.2, 2.6, 0.4]);
    let amplitude = AmplitudeCurve::new(x.clone(), a.clone()).unwrap();
    let a_max = 2.0;
    let signal = render_two_channel(&curve, &amplitude, a_max, &trajectory, &settings).unwrap();
    (signal, VoltageCurve::new(x, a).unwrap(), a_max)
}

/// Round trip of a two-channel drive: render -> WAV -> decode. Channel 1
/// is the same samples as the one-channel WAV of the same voltage
/// (identical volts), channel 2 maps back to min(a(x(t)), a_max) within
/// half a quantization step, a_max is never exceeded, and the clamp is
/// reported.
#[test]
fn two_channel_round_trip_keeps_each_channel_with_its_own_scale() {
    let one = test_signal();
    let (two, a_of_x, a_max) = two_channel_signal();
    assert_eq!((&two.signal_v, &two.envelope_v, &two.x_mm), (&one.signal_v, &one.envelope_v, &one.x_mm));
    let us = two.report.ultrasonic.as_ref().unwrap();
    assert!(us.clamped_samples > 0 && us.requested_max_um > a_max && us.amplitude_max_um == a_max);
    let a = two.amplitude_um.as_ref().unwrap();
    for (i, &x) in two.x_mm.iter().enumerate() {
        let expected = a_of_x.voltage_at(x, Extend::Hold).min(a_max);
        assert!((a[i] - expected).abs() <= 1e-12, "sample {i}: {} vs {expected}", a[i]);
    }
    for format in [WavFormat::Pcm16, WavFormat::Pcm24, WavFormat::Float32] {
        let options = WavOptions { format, volts_per_full_scale: 150.0 };
        let mono = encode_wav(&one, &options, "one").unwrap();
        let stereo = encode_wav(&two, &options, "two").unwrap();
        let (scale_1, volts_1, none) = decode_drive_wav_channels(&mono.bytes).unwrap();
        assert!(none.is_none() && scale_1.channel_2.is_none());
        let (scale_2, volts_2, amplitude) = decode_drive_wav_channels(&stereo.bytes).unwrap();
        assert_eq!(volts_2, volts_1, "{format:?}: channel 1 as the one-channel render");
        assert_eq!(scale_2.volts_per_full_scale, 150.0);
        let c2 = scale_2.channel_2.as_ref().unwrap();
        assert_eq!((c2.unit.as_str(), c2.um_per_full_scale, c2.a_max_um), ("um", a_max, a_max));
        let amplitude = amplitude.unwrap();
        assert_eq!(amplitude.len(), two.len());
        let tolerance = match format {
            WavFormat::Float32 => a_max * 2f64.powi(-24),
            _ => 0.5 * a_max / format.full_scale() * (1.0 + 1e-9),
        };
        for (i, (&got, &want)) in amplitude.iter().zip(a).enumerate() {
            assert!((got - want).abs() <= tolerance, "{format:?} sample {i}: {got} vs {want}");
            assert!(got <= a_max && got >= 0.0, "{format:?} sample {i}: {got} outside 0..a_max");
        }
        // The one-channel decoder gives channel 1 only, never interleaved.
        assert_eq!(haptex_core::signal::decode_drive_wav(&stereo.bytes).unwrap().1, volts_1);
        // hound sees two channels, channel 1 first.
        let reader = hound::WavReader::new(std::io::Cursor::new(&stereo.bytes)).unwrap();
        assert_eq!(reader.spec().channels, 2);
        assert_eq!(reader.len() as usize, 2 * two.len());
    }
}

/// A tampered channel-2 scale is caught: in the sidecar (it no longer
/// belongs to the WAV), in the chunk without a sidecar (um per full scale
/// and a_max must agree; and raising both makes the samples stand for
/// more than a_max), and a chunk whose channel count disagrees with fmt.
#[test]
fn tampered_channel_2_scale_is_refused() {
    let (signal, _, _) = two_channel_signal();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.wav");
    let options = WavOptions { format: WavFormat::Pcm16, volts_per_full_scale: 150.0 };
    write_wav(&path, &signal, &options, serde_json::Value::Null).unwrap();
    let read = read_drive_wav(&path).unwrap();
    assert_eq!(read.sidecar.as_ref().unwrap().channels, 2);
    assert!(read.amplitude_um.is_some());

    // Sidecar: channel 2's scale doubled.
    let sidecar = sidecar_path(&path);
    let text = std::fs::read_to_string(&sidecar).unwrap();
    let tampered = text.replace("\"um_per_full_scale\": 2.0", "\"um_per_full_scale\": 4.0");
    assert_ne!(tampered, text);
    std::fs::write(&sidecar, &tampered).unwrap();
    let e = read_drive_wav(&path).unwrap_err().to_string();
    assert!(e.contains("does not belong to it") && e.contains("channel 2 at 4 um per full scale"), "{e}");
    std::fs::remove_file(&sidecar).unwrap();
    assert!(read_drive_wav(&path).is_ok());

    // Chunk: the scale alone changed (same length), then scale and a_max.
    let bytes = std::fs::read(&path).unwrap();
    let edit = |from: &str, to: &str| {
        let text = replace_once(&bytes, from, to);
        std::fs::write(&path, text).unwrap();
        read_drive_wav(&path).unwrap_err().to_string()
    };
    let e = edit("\"um_per_full_scale\":2.0", "\"um_per_full_scale\":8.0");
    assert!(e.contains("channel 2 is not consistent"), "{e}");
    let twice = replace_once(
        &replace_once(&bytes, "\"um_per_full_scale\":2.0", "\"um_per_full_scale\":8.0"),
        "\"a_max_um\":2.0",
        "\"a_max_um\":8.0",
    );
    let (scale, _, a) = decode_drive_wav_channels(&twice).unwrap();
    // Raised consistently, the samples read 4x larger but within the new
    // a_max: the chunk alone cannot tell; the sidecar (above) does.
    assert_eq!(scale.channel_2.unwrap().a_max_um, 8.0);
    assert!(a.unwrap().iter().any(|&v| v > 2.0));
    // Channel count: a one-channel chunk over two-channel samples.
    let start = find(&bytes, b",\"channel_2\":{").unwrap();
    let end = start + find(&bytes[start..], b"}").unwrap() + 1;
    let mut mono_chunk = bytes[..start].to_vec();
    mono_chunk.extend_from_slice(&bytes[end..]);
    // Fix the chunk and RIFF sizes for the removed bytes.
    let removed = (end - start) as u32;
    let chunk_at = find(&bytes, b"hptx").unwrap();
    let size = u32::from_le_bytes(bytes[chunk_at + 4..chunk_at + 8].try_into().unwrap()) - removed;
    mono_chunk[chunk_at + 4..chunk_at + 8].copy_from_slice(&size.to_le_bytes());
    let riff = (mono_chunk.len() - 8) as u32;
    mono_chunk[4..8].copy_from_slice(&riff.to_le_bytes());
    let e = decode_drive_wav_channels(&mono_chunk).unwrap_err();
    assert!(e.contains("2 channel(s)") && e.contains("1 channel(s)"), "{e}");
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

/// `bytes` with the one occurrence of `from` replaced by `to` (same length).
fn replace_once(bytes: &[u8], from: &str, to: &str) -> Vec<u8> {
    assert_eq!(from.len(), to.len());
    let at = find(bytes, from.as_bytes()).unwrap_or_else(|| panic!("{from} not in the file"));
    let mut out = bytes.to_vec();
    out[at..at + to.len()].copy_from_slice(to.as_bytes());
    out
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]
    /// Over random profiles, trajectories and limits: no sample of either
    /// channel exceeds its limit, rendered or read back from the WAV.
    /// Rendered: exact, no tolerance (a safety limit: the envelope is
    /// clamped to U_max and a_max, and sqrt(2) U sin(...) with U <= U_max
    /// and |sin| <= 1 cannot round above sqrt(2) U_max); read back: the
    /// scale's 1 ulp below.
    #[test]
    fn limits_are_never_exceeded_on_either_channel(
        points in proptest::collection::vec((0.01f64..3.0, 0.0f64..250.0, 0.0f64..6.0), 2..12),
        u_max in 1.0f64..200.0,
        a_max in 0.01f64..5.0,
        speed in 5.0f64..200.0,
        strokes in 1usize..4,
        format in proptest::sample::select(vec![WavFormat::Pcm16, WavFormat::Pcm24, WavFormat::Float32]),
    ) {
        let mut x = Vec::new();
        let mut at = 0.0;
        for (dx, _, _) in &points { x.push(at); at += dx; }
        let curve = VoltageCurve::new(x.clone(), points.iter().map(|p| p.1).collect()).unwrap();
        let amplitude = AmplitudeCurve::new(x.clone(), points.iter().map(|p| p.2).collect()).unwrap();
        let trajectory = Trajectory::strokes(x[0] - 0.5, at + 0.5, speed, strokes, 1000.0).unwrap();
        let settings = RenderSettings {
            sample_rate_hz: 8000,
            carrier: Carrier { shape: CarrierShape::Sine, frequency_hz: 300.0 },
            limits: Limits { u_max_v: u_max, slew_v_per_s: None, amplifier_range_v: None },
            extend: Extend::Hold,
        };
        let signal = render_two_channel(&curve, &amplitude, a_max, &trajectory, &settings).unwrap();
        let peak = std::f64::consts::SQRT_2 * u_max;
        proptest::prop_assert!(signal.envelope_v.iter().all(|&u| (0.0..=u_max).contains(&u)));
        proptest::prop_assert!(signal.signal_v.iter().all(|&s| s.abs() <= peak));
        proptest::prop_assert!(signal.amplitude_um.as_ref().unwrap().iter().all(|&a| (0.0..=a_max).contains(&a)));
        let encoded = encode_wav(&signal, &WavOptions { format, volts_per_full_scale: peak }, "p").unwrap();
        let (_, volts, a) = decode_drive_wav_channels(&encoded.bytes).unwrap();
        // Read back, a scale can be 1 ulp off: the chunk's JSON number is
        // parsed by serde_json, which does not round-trip every f64 exactly.
        let ulps = 1.0 + 1e-15;
        let worst = volts.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
        proptest::prop_assert!(worst <= peak * ulps, "{} > {}", worst, peak);
        let a = a.unwrap();
        let worst = a.iter().fold(0.0f64, |m, &v| m.max(v));
        proptest::prop_assert!(worst <= a_max * ulps, "{} > {}", worst, a_max);
        proptest::prop_assert!(a.iter().all(|&v| v >= 0.0));
    }
}

/// The encoder refuses a channel-2 sample outside 0 .. a_max (a signal
/// changed after its render), never writing it clipped.
#[test]
fn encoder_refuses_channel_2_outside_its_limit() {
    let options = WavOptions { format: WavFormat::Pcm16, volts_per_full_scale: 150.0 };
    for bad in [2.0 * (1.0 + 1e-12), -1e-9, f64::NAN] {
        let (mut signal, _, _) = two_channel_signal();
        signal.amplitude_um.as_mut().unwrap()[100] = bad;
        let e = encode_wav(&signal, &options, "x").unwrap_err().to_string();
        assert!(e.contains("outside 0 .. a_max = 2 um"), "{bad}: {e}");
    }
    // A signal whose channel and report disagree.
    let (mut signal, _, _) = two_channel_signal();
    signal.report.ultrasonic = None;
    assert!(encode_wav(&signal, &options, "x").unwrap_err().to_string().contains("do not agree"));
}

/// Channel 2 on the plate's resonance (issue 16's optional modulated
/// carrier, `haptex play --plate-resonance-hz`): sample by sample the
/// envelope a(t) times sin(2 pi f_r t) (against libm's sin, 1e-9 of
/// a_max: the phase reaches 1e4 turns, where 2 pi p itself rounds at
/// 1e-12), its spectrum's peak at f_r, channel 1 untouched; through a
/// 24-bit WAV within half a step, signed, never beyond a_max, the scale
/// chunk and sidecar naming f_r; a chunk claiming a resonance the sample
/// rate cannot carry is refused; so are a 48 kHz drive, a one-channel
/// drive and a second modulation.
#[test]
fn channel_2_on_the_plate_resonance() {
    let (curve, trajectory, mut settings) = test_inputs();
    settings.sample_rate_hz = 192_000;
    let amplitude = AmplitudeCurve::new(vec![0.0, 1.0, 2.5, 4.0], vec![0.0, 1.2, 2.6, 0.4]).unwrap();
    let a_max = 2.0;
    let envelope = render_two_channel(&curve, &amplitude, a_max, &trajectory, &settings).unwrap();
    let mut plate = envelope.clone();
    let f_r = 40_000.0;
    modulate_at_resonance(&mut plate, f_r).unwrap();
    assert_eq!((&plate.signal_v, &plate.envelope_v), (&envelope.signal_v, &envelope.envelope_v));
    let (a, d) = (envelope.amplitude_um.as_ref().unwrap(), plate.amplitude_um.as_ref().unwrap());
    for (i, (&a, &d)) in a.iter().zip(d).enumerate() {
        let want = a * (std::f64::consts::TAU * f_r * i as f64 / 192_000.0).sin();
        assert!((d - want).abs() <= 1e-9 * a_max, "sample {i}: {d} vs {want}");
    }
    let spectrum = spectrum(d);
    let peak_hz = argmax(&spectrum) as f64 * 192_000.0 / d.len() as f64;
    assert!((peak_hz - f_r).abs() <= 2.0 * 192_000.0 / d.len() as f64, "spectrum peak at {peak_hz} Hz");
    let us = plate.report.ultrasonic.as_ref().unwrap();
    assert_eq!(us.resonance_hz, Some(f_r));
    assert!(us.convention.contains("40000 Hz"), "{}", us.convention);

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plate.wav");
    let options = WavOptions { format: WavFormat::Pcm24, volts_per_full_scale: 150.0 };
    write_wav(&path, &plate, &options, serde_json::json!({"test": true})).unwrap();
    let read = read_drive_wav(&path).unwrap();
    let c2 = read.scale.channel_2.as_ref().unwrap();
    assert_eq!((c2.resonance_hz, c2.um_per_full_scale), (Some(f_r), a_max));
    assert!(c2.quantity.contains("displacement"), "{}", c2.quantity);
    assert_eq!(read.sidecar.as_ref().unwrap().channel_2.as_ref().unwrap().resonance_hz, Some(f_r));
    let got = read.amplitude_um.as_ref().unwrap();
    let step = 0.5 * a_max / WavFormat::Pcm24.full_scale() * (1.0 + 1e-9);
    for (i, (&got, &want)) in got.iter().zip(d).enumerate() {
        assert!((got - want).abs() <= step && got.abs() <= a_max, "sample {i}: {got} vs {want}");
    }
    assert!(got.iter().any(|&v| v < -1.0), "the displacement swings below zero");
    // A scale chunk claiming 99999 Hz at 192 kHz (above 0.45 fs) is refused.
    let bytes = std::fs::read(&path).unwrap();
    let claim = b"\"resonance_hz\":40000.0";
    let at = bytes.windows(claim.len()).position(|w| w == claim).expect("the chunk names the resonance");
    let mut forged = bytes.clone();
    forged[at..at + claim.len()].copy_from_slice(b"\"resonance_hz\":99999.0");
    let e = decode_drive_wav_channels(&forged).unwrap_err().to_string();
    assert!(e.contains("channel 2 is not consistent"), "{e}");

    let mut low = render_two_channel(&curve, &amplitude, a_max, &trajectory, &test_inputs().2).unwrap();
    let e = modulate_at_resonance(&mut low, f_r).unwrap_err().to_string();
    assert!(e.contains("at least 88889 Hz") && e.contains("44100 Hz"), "{e}");
    let mut one = test_signal();
    assert!(modulate_at_resonance(&mut one, f_r).unwrap_err().to_string().contains("two-channel"));
    assert!(modulate_at_resonance(&mut plate, f_r).unwrap_err().to_string().contains("already"));
    let e = modulate_at_resonance(&mut envelope.clone(), 500.0).unwrap_err().to_string();
    assert!(e.contains("plate_resonance_hz"), "{e}");
}

#[path = "support/forge_wav.rs"]
mod forge_wav;

/// An edit of a `fmt ` chunk's bytes.
type Edit = Box<dyn Fn(&mut Vec<u8>)>;

/// Bits per sample of a format.
fn bits(format: WavFormat) -> u16 {
    match format {
        WavFormat::Pcm16 => 16,
        WavFormat::Pcm24 => 24,
        WavFormat::Float32 => 32,
    }
}

/// The WAVs the forgery tests edit: the test signal in every format, on
/// one channel and on two (volts per full scale 150 V).
fn every_layout() -> Vec<(String, Vec<u8>)> {
    let (two, _, _) = two_channel_signal();
    let mut out = Vec::new();
    for format in [WavFormat::Pcm16, WavFormat::Pcm24, WavFormat::Float32] {
        for (channels, signal) in [(1, test_signal()), (2, two.clone())] {
            let options = WavOptions { format, volts_per_full_scale: 150.0 };
            out.push((format!("{format:?}, {channels} channel(s)"), encode_wav(&signal, &options, "t").unwrap().bytes));
        }
    }
    out
}

/// Issue 35: the scale chunk's hash covered the samples, not the `fmt `
/// chunk, so a 2-byte edit of the format tag (float32 relabelled as
/// integer PCM, PCM16 as float) passed the reader, and any other program
/// then played the bit patterns as noise up to 52 % of full scale. Every
/// field of `fmt ` (format tag, channels, rate, byte rate, block align,
/// bits; valid bits, channel mask and subformat GUID of the extensible
/// format) is compared with what the scale chunk states, and the chunk
/// hashes it: each forgery below, its hashes recomputed, is refused, also
/// when the scale chunk's own `fmt` fields are forged to match; a file as
/// written reads with hound as the scale chunk says.
#[test]
fn wav_format_fields_are_covered_by_the_scale_chunk() {
    use forge_wav::{forge, put_u16, put_u32};
    for (layout, bytes) in every_layout() {
        let (scale, volts, _) = decode_drive_wav_channels(&bytes).unwrap();
        let spec = hound::WavReader::new(std::io::Cursor::new(&bytes)).unwrap().spec();
        let float = scale.sample_format == WavFormat::Float32;
        assert_eq!(
            (spec.sample_format == hound::SampleFormat::Float, spec.bits_per_sample, spec.sample_rate, spec.channels),
            (float, bits(scale.sample_format), scale.sample_rate_hz, if scale.channel_2.is_some() { 2 } else { 1 }),
            "{layout}"
        );
        assert_eq!(volts.len(), scale.n_samples);
        let extensible = scale.sample_format != WavFormat::Pcm16;
        let mut edits: Vec<(&str, Edit)> = vec![
            ("format tag: integer PCM", Box::new(|f| put_u16(f, 0, 1))),
            ("format tag: IEEE float", Box::new(|f| put_u16(f, 0, 3))),
            (
                "channels",
                Box::new(|f| {
                    let channels = u16::from_le_bytes([f[2], f[3]]);
                    put_u16(f, 2, 3 - channels)
                }),
            ),
            ("sample rate", Box::new(|f| put_u32(f, 4, 48_000))),
            ("byte rate", Box::new(|f| put_u32(f, 8, 1))),
            ("block align", Box::new(|f| put_u16(f, 12, 1))),
            ("bits per sample", Box::new(|f| put_u16(f, 14, 8))),
        ];
        if extensible {
            edits.push(("format tag: extensible as PCM", Box::new(|f| put_u16(f, 0, 1))));
            edits.push(("valid bits", Box::new(|f| put_u16(f, 18, 20))));
            edits.push(("channel mask", Box::new(|f| put_u32(f, 20, 4))));
            edits.push(("subformat: float as integer", Box::new(|f| f[24] ^= 2)));
        }
        let fmt = forge_wav::parts(&bytes).fmt;
        for (what, edit) in &edits {
            let mut edited = fmt.clone();
            edit(&mut edited);
            if edited == fmt {
                continue; // the value already there (tag 1 of a PCM16 file)
            }
            let forged = forge(&bytes, |p| p.fmt = edited.clone());
            let e = decode_drive_wav_channels(&forged).map(|_| ()).unwrap_err();
            assert!(e.contains("fmt chunk"), "{layout}, {what}: {e}");
            // The scale chunk's own statement of the fields, forged to
            // match, does not help: they are not the format's.
            let forged = forge(&bytes, |p| {
                p.fmt = edited.clone();
                if let Ok(fields) = haptex_core::signal::FmtFields::parse(&p.fmt) {
                    p.scale["fmt"] = serde_json::to_value(fields).unwrap();
                }
            });
            let e = decode_drive_wav_channels(&forged).map(|_| ()).unwrap_err();
            assert!(e.contains("fmt"), "{layout}, {what}: {e}");
        }
        // The format tag's low byte edited in place, hashes not recomputed.
        let mut tampered = bytes.clone();
        let fmt_at = 20; // after the RIFF header (12 bytes) and the fmt chunk's (8)
        tampered[fmt_at] ^= 1;
        let e = decode_drive_wav_channels(&tampered).unwrap_err();
        assert!(e.contains("fmt chunk"), "{layout}: {e}");
    }
}

/// The scale chunk's version: a version-1 chunk (haptex before the `fmt `
/// fields were hashed) still reads, with its `fmt ` chunk checked field by
/// field, so its format tag cannot be edited either; a version from the
/// future, or a version-2 chunk without its `fmt` fields, is refused.
#[test]
fn scale_chunk_versions_are_read_in_the_safe_direction() {
    use forge_wav::{forge, put_u16};
    for (layout, bytes) in every_layout() {
        let (_, volts, _) = decode_drive_wav_channels(&bytes).unwrap();
        let version_1 = |p: &mut forge_wav::Parts| {
            let object = p.scale.as_object_mut().unwrap();
            for key in ["version", "fmt", "fmt_sha256"] {
                assert!(object.remove(key).is_some(), "{layout}: the chunk has no {key}");
            }
        };
        let old = forge(&bytes, version_1);
        let (scale, old_volts, _) = decode_drive_wav_channels(&old).unwrap();
        assert_eq!((scale.version, old_volts), (None, volts.clone()), "{layout}");
        let relabelled = forge(&bytes, |p| {
            version_1(p);
            let tag = if p.fmt[0] == 1 { 3 } else { 1 };
            put_u16(&mut p.fmt, 0, tag);
        });
        let e = decode_drive_wav_channels(&relabelled).unwrap_err();
        assert!(e.contains("fmt chunk") && e.contains("format tag"), "{layout}: {e}");
        let future = forge(&bytes, |p| p.scale["version"] = 3.into());
        let e = decode_drive_wav_channels(&future).unwrap_err();
        assert!(e.contains("version 3") && e.contains("newer haptex"), "{layout}: {e}");
        let half = forge(&bytes, |p| {
            p.scale.as_object_mut().unwrap().remove("fmt");
        });
        assert!(decode_drive_wav_channels(&half).unwrap_err().contains("not consistent"), "{layout}");
    }
}

/// Issue 35: a forged float WAV with NaN, an infinity or 50.0 in channel
/// 1 (hashes recomputed) passed the reader ("peak inf V", "peak 7071 V"):
/// only channel 2 was range-checked. Every sample of every channel must
/// be finite and within full scale (a PCM16 -32768 too, which haptex never
/// writes); the sample rate at least 100 Hz (0 Hz passed as "0 Hz (inf
/// s)"); the RIFF size the file's. Each forgery's hashes are recomputed.
#[test]
fn every_channel_of_every_sample_is_checked() {
    use forge_wav::{forge, put_u32};
    for (layout, bytes) in every_layout() {
        let (scale, _, _) = decode_drive_wav_channels(&bytes).unwrap();
        let width = usize::from(bits(scale.sample_format) / 8);
        let channels = if scale.channel_2.is_some() { 2 } else { 1 };
        let codes: Vec<Vec<u8>> = match scale.sample_format {
            WavFormat::Float32 => [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 50.0, -1.0001]
                .iter()
                .map(|v| v.to_le_bytes().to_vec())
                .collect(),
            WavFormat::Pcm16 => vec![i16::MIN.to_le_bytes().to_vec()],
            WavFormat::Pcm24 => vec![vec![0x00, 0x00, 0x80]],
        };
        for code in &codes {
            for channel in 0..channels {
                for sample in [0, scale.n_samples / 2, scale.n_samples - 1] {
                    let forged = forge(&bytes, |p| {
                        let at = (sample * channels + channel) * width;
                        p.data[at..at + width].copy_from_slice(code);
                    });
                    let e = decode_drive_wav_channels(&forged).map(|_| ()).unwrap_err();
                    assert!(
                        e.contains(&format!("channel {}'s sample {sample}", channel + 1)),
                        "{layout}, code {code:?} at channel {}, sample {sample}: {e}",
                        channel + 1
                    );
                }
            }
        }
        // A rate of 0 Hz (or 99), stated consistently by both chunks.
        for rate in [0u32, 99] {
            let forged = forge(&bytes, |p| {
                let block = u32::from(u16::from_le_bytes([p.fmt[12], p.fmt[13]]));
                put_u32(&mut p.fmt, 4, rate);
                put_u32(&mut p.fmt, 8, rate * block);
                p.scale["sample_rate_hz"] = rate.into();
                if let Some(fields) = p.scale.get_mut("fmt") {
                    fields["sample_rate_hz"] = rate.into();
                    fields["byte_rate"] = (rate * block).into();
                }
            });
            let e = decode_drive_wav_channels(&forged).map(|_| ()).unwrap_err();
            assert!(e.contains(&format!("{rate} Hz")) && e.contains("below"), "{layout}, {rate} Hz: {e}");
        }
        // The RIFF size: longer or shorter than the file.
        for delta in [2i64, -2] {
            let mut lying = bytes.clone();
            let riff = (lying.len() as i64 - 8 + delta) as u32;
            lying[4..8].copy_from_slice(&riff.to_le_bytes());
            let e = decode_drive_wav_channels(&lying).map(|_| ()).unwrap_err();
            assert!(e.contains("RIFF header"), "{layout}, {delta}: {e}");
        }
        // The data chunk's size beyond the file.
        let data_at = find(&bytes, b"data").unwrap();
        let mut lying = bytes.clone();
        lying[data_at + 4..data_at + 8].copy_from_slice(&(bytes.len() as u32).to_le_bytes());
        assert!(decode_drive_wav_channels(&lying).is_err(), "{layout}");
    }
}

/// Errors of the reader say "cannot read", not "cannot encode".
#[test]
fn reading_errors_say_cannot_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.wav");
    std::fs::write(&path, b"RIFF").unwrap();
    let e = read_drive_wav(&path).unwrap_err().to_string();
    assert!(e.starts_with("cannot read the WAV file") && e.contains("x.wav"), "{e}");
}
