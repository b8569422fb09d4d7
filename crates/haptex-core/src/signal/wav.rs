//! WAV output of a drive signal (mono, through `hound`) and its sidecar
//! JSON, which records the scale in volts and how the signal was made.
//!
//! Scale: a sample value v (an integer code, or a float) stands for
//! v / full_scale * volts_per_full_scale volts at the amplifier output,
//! with full_scale = 32767 (16-bit PCM), 8388607 (24-bit PCM) or 1.0
//! (32-bit float). Codes are rounded to the nearest integer, without dither.
//! A signal whose peak exceeds the full scale is refused, never clipped.

use std::io::Cursor;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{DriveSignal, SignalError, SignalReport};
use crate::io::write_atomic;

/// Sample format of a WAV file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WavFormat {
    /// 16-bit signed integer PCM (WAVE_FORMAT_PCM).
    Pcm16,
    /// 24-bit signed integer PCM (WAVE_FORMAT_EXTENSIBLE, as the format
    /// requires above 16 bits).
    Pcm24,
    /// 32-bit IEEE float (WAVE_FORMAT_EXTENSIBLE).
    Float32,
}

impl WavFormat {
    /// The value that stands for `volts_per_full_scale`: 32767, 8388607 or 1.
    pub fn full_scale(self) -> f64 {
        match self {
            WavFormat::Pcm16 => i16::MAX as f64,
            WavFormat::Pcm24 => 8_388_607.0,
            WavFormat::Float32 => 1.0,
        }
    }

    fn bits(self) -> u16 {
        match self {
            WavFormat::Pcm16 => 16,
            WavFormat::Pcm24 => 24,
            WavFormat::Float32 => 32,
        }
    }

    fn spec(self, sample_rate_hz: u32) -> hound::WavSpec {
        hound::WavSpec {
            channels: 1,
            sample_rate: sample_rate_hz,
            bits_per_sample: self.bits(),
            sample_format: match self {
                WavFormat::Float32 => hound::SampleFormat::Float,
                _ => hound::SampleFormat::Int,
            },
        }
    }
}

/// How a drive signal is written as WAV.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WavOptions {
    pub format: WavFormat,
    /// Volts at the amplifier output for a full-scale sample (the gain of
    /// the DAC + amplifier chain), V.
    pub volts_per_full_scale: f64,
}

/// The sidecar JSON written next to a WAV (`out.wav` -> `out.wav.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WavSidecar {
    /// Always "haptex drive signal".
    pub kind: String,
    /// File name of the WAV (same directory).
    pub wav_file: String,
    pub sample_rate_hz: u32,
    pub channels: u16,
    pub n_samples: usize,
    pub sample_format: WavFormat,
    pub bits_per_sample: u16,
    /// The sample value that stands for `volts_per_full_scale`.
    pub full_scale_value: f64,
    /// Volts at the amplifier output for a full-scale sample.
    pub volts_per_full_scale: f64,
    /// volts = sample / full_scale_value * volts_per_full_scale.
    pub conversion: String,
    pub voltage_convention: String,
    /// Render settings, safety report and peak of the signal.
    pub report: SignalReport,
    /// Where the signal came from (profile, trajectory, command), free form.
    pub source: serde_json::Value,
}

/// The sidecar path of a WAV file: the WAV path with `.json` appended.
pub fn sidecar_path(wav: &Path) -> PathBuf {
    let mut name = wav.as_os_str().to_owned();
    name.push(".json");
    PathBuf::from(name)
}

/// Encodes `signal` as a mono WAV file in memory (what [`write_wav`] writes;
/// a server sends these bytes). Refuses a signal whose peak exceeds
/// `volts_per_full_scale`. `label` names the output in errors.
pub fn encode_wav(signal: &DriveSignal, options: &WavOptions, label: &str) -> Result<Vec<u8>, SignalError> {
    let vpfs = options.volts_per_full_scale;
    if !(vpfs.is_finite() && vpfs > 0.0) {
        return Err(SignalError::Settings(format!(
            "volts per full scale must be a positive finite number, got {vpfs}"
        )));
    }
    let report = &signal.report;
    if report.peak_v > vpfs {
        return Err(SignalError::ExceedsFullScale { amplitude_v: report.peak_v, volts_per_full_scale: vpfs });
    }
    let wav_error = |e: hound::Error| SignalError::Wav { path: label.to_string(), message: e.to_string() };
    let format = options.format;
    let full_scale = format.full_scale();
    let scale = full_scale / vpfs;
    let mut bytes = Vec::with_capacity(64 + signal.len() * usize::from(format.bits() / 8));
    {
        let mut writer =
            hound::WavWriter::new(Cursor::new(&mut bytes), format.spec(report.sample_rate_hz)).map_err(wav_error)?;
        for &v in &signal.signal_v {
            let value = (v * scale).clamp(-full_scale, full_scale);
            match format {
                WavFormat::Pcm16 => writer.write_sample(value.round() as i16),
                WavFormat::Pcm24 => writer.write_sample(value.round() as i32),
                WavFormat::Float32 => writer.write_sample(value as f32),
            }
            .map_err(wav_error)?;
        }
        writer.finalize().map_err(wav_error)?;
    }
    Ok(bytes)
}

/// Writes `signal` as a mono WAV at `path` and its sidecar JSON at
/// [`sidecar_path`], each atomically. Refuses a signal whose peak exceeds
/// `volts_per_full_scale`. Returns the sidecar.
pub fn write_wav(
    path: &Path,
    signal: &DriveSignal,
    options: &WavOptions,
    source: serde_json::Value,
) -> Result<WavSidecar, SignalError> {
    let bytes = encode_wav(signal, options, &path.display().to_string())?;
    write_atomic(path, |w| w.write_all(&bytes))?;
    let report = &signal.report;
    let (format, vpfs, full_scale) = (options.format, options.volts_per_full_scale, options.format.full_scale());
    let sidecar = WavSidecar {
        kind: "haptex drive signal".into(),
        wav_file: path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        sample_rate_hz: report.sample_rate_hz,
        channels: 1,
        n_samples: signal.len(),
        sample_format: format,
        bits_per_sample: format.bits(),
        full_scale_value: full_scale,
        volts_per_full_scale: vpfs,
        conversion: "volts = sample / full_scale_value * volts_per_full_scale".into(),
        voltage_convention: format!(
            "the envelope U is the RMS voltage of eq. (8); the drive is U times a unit-RMS carrier, peak = {} x U",
            report.carrier.peak_per_rms()
        ),
        report: report.clone(),
        source,
    };
    let json = sidecar_path(path);
    write_atomic(&json, |w| {
        serde_json::to_writer_pretty(&mut *w, &sidecar).map_err(std::io::Error::from)?;
        w.write_all(b"\n")
    })?;
    Ok(sidecar)
}

/// Reads a mono WAV back as volts, given its volts per full scale (from the
/// sidecar). Returns the WAV's spec and the samples in V.
pub fn read_wav_volts(path: &Path, volts_per_full_scale: f64) -> Result<(hound::WavSpec, Vec<f64>), SignalError> {
    let wav_error = |e: hound::Error| SignalError::Wav { path: path.display().to_string(), message: e.to_string() };
    let mut reader = hound::WavReader::open(path).map_err(wav_error)?;
    let spec = reader.spec();
    let volts: Result<Vec<f64>, hound::Error> = match (spec.sample_format, spec.bits_per_sample) {
        (hound::SampleFormat::Float, 32) => {
            reader.samples::<f32>().map(|s| s.map(|v| f64::from(v) * volts_per_full_scale)).collect()
        }
        (hound::SampleFormat::Int, bits @ (16 | 24)) => {
            let full_scale = ((1i64 << (bits - 1)) - 1) as f64;
            reader.samples::<i32>().map(|s| s.map(|v| f64::from(v) / full_scale * volts_per_full_scale)).collect()
        }
        (format, bits) => {
            return Err(SignalError::Wav {
                path: path.display().to_string(),
                message: format!("unsupported sample format {format:?} with {bits} bits"),
            });
        }
    };
    Ok((spec, volts.map_err(wav_error)?))
}
