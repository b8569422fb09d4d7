//! WAV output of a drive signal (mono, or two channels for a combined or
//! ultrasonic display, through `hound`) and its sidecar JSON, which
//! records how the signal was made.
//!
//! A two-channel WAV interleaves channel 1 (the electrovibration drive,
//! in volts, scaled by the chunk's top-level `volts_per_full_scale`) and
//! channel 2 (the ultrasonic amplitude envelope in um, scaled by the
//! chunk's `channel_2` [`AmplitudeScale`], full scale = a_max). A
//! one-channel WAV has no `channel_2`.
//!
//! Scale: a sample value v (an integer code, or a float) stands for
//! v / full_scale * volts_per_full_scale volts at the amplifier output,
//! with full_scale = 32767 (16-bit PCM), 8388607 (24-bit PCM) or 1.0
//! (32-bit float). Codes are rounded to the nearest integer, without dither.
//! A signal whose peak exceeds the full scale is refused, never clipped.
//!
//! The scale travels inside the WAV: a `hptx` chunk after the samples
//! holds a JSON [`ScaleChunk`] with the volts per full scale, every field
//! of the `fmt ` chunk ([`FmtFields`]: how any audio program reads the
//! samples) and the SHA-256 of the `fmt ` chunk and of the sample bytes.
//! Audio tools skip the chunk; haptex's reader ([`read_drive_wav`])
//! refuses a WAV without it, a WAV whose `fmt ` chunk or samples do not
//! match it, any sample of any channel that is not finite or beyond full
//! scale, and a sidecar that does not belong to the WAV (another hash or
//! another scale), so that samples are never paired with the wrong scale,
//! even after a run killed between writing the WAV and its sidecar.
//!
//! The hashes carry no secret: anyone can edit a file and recompute them.
//! What the reader guarantees of a file it accepts, forged or not, is that
//! its `fmt ` chunk describes the samples exactly as the scale chunk says
//! (so that no other program reads them as another format) and that every
//! sample of every channel stands for at most the stated full scale.
//!
//! Versions of the chunk: version 2 (`"version": 2`, this one) states the
//! `fmt ` fields and hashes them. Version 1 (no `version` field, haptex
//! before issue 35) hashed the samples only; it is still read, with the
//! same checks except the `fmt ` hash, which it does not have: its `fmt `
//! chunk must be, field by field, the one haptex writes for the chunk's
//! format, channels and rate (the only one haptex ever wrote), so an
//! edited format tag is refused in either version. A version above 2 is
//! refused (a newer haptex's file, whose checks this one cannot make), as
//! a version-1 reader refuses a version-2 chunk (an unknown field).

use std::io::{Cursor, Read};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{DriveSignal, SignalError, SignalReport};
use crate::io::{OutputTarget, fault_point, sha256_hex, write_atomic};
use crate::num::Num;

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
    /// The format's name in files and on the command line: pcm16, pcm24,
    /// float32.
    pub fn name(self) -> &'static str {
        match self {
            WavFormat::Pcm16 => "pcm16",
            WavFormat::Pcm24 => "pcm24",
            WavFormat::Float32 => "float32",
        }
    }

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

    fn spec(self, sample_rate_hz: u32, channels: u16) -> hound::WavSpec {
        hound::WavSpec {
            channels,
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

/// The id of the WAV chunk that carries the scale.
pub const SCALE_CHUNK_ID: [u8; 4] = *b"hptx";

/// The version of the scale chunk this haptex writes (see the module
/// documentation; version 1 had no `version` field).
pub const SCALE_CHUNK_VERSION: u32 = 2;

/// The `wFormatTag` values haptex writes: WAVE_FORMAT_PCM (pcm16) and
/// WAVE_FORMAT_EXTENSIBLE (pcm24, float32). WAVE_FORMAT_IEEE_FLOAT (3) is
/// never written: haptex's float32 is extensible.
const FORMAT_PCM: u16 = 1;
const FORMAT_EXTENSIBLE: u16 = 0xFFFE;
/// The SubFormat GUIDs of WAVE_FORMAT_EXTENSIBLE (KSDATAFORMAT_SUBTYPE_PCM
/// and _IEEE_FLOAT), in the usual text form.
const SUBTYPE_PCM: &str = "00000001-0000-0010-8000-00aa00389b71";
const SUBTYPE_IEEE_FLOAT: &str = "00000003-0000-0010-8000-00aa00389b71";

/// Every field of a WAV's `fmt ` chunk: what an audio program reads the
/// samples by. haptex writes PCMWAVEFORMAT (16 bytes, format tag 1) for
/// pcm16 and WAVE_FORMAT_EXTENSIBLE (40 bytes, format tag 0xFFFE, with
/// valid bits, channel mask and subformat) for pcm24 and float32; the
/// extensible fields are absent (`None`) for the former.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FmtFields {
    /// wFormatTag: 1 (integer PCM), 3 (IEEE float) or 65534 (extensible).
    pub format_tag: u16,
    pub channels: u16,
    pub sample_rate_hz: u32,
    /// nAvgBytesPerSec = sample rate x block align.
    pub byte_rate: u32,
    /// nBlockAlign = channels x bytes per sample: the bytes of one frame.
    pub block_align: u16,
    /// wBitsPerSample (the container size for the extensible format).
    pub bits_per_sample: u16,
    /// wValidBitsPerSample (extensible only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub valid_bits_per_sample: Option<u16>,
    /// dwChannelMask (extensible only): 1 for mono, 3 for two channels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channel_mask: Option<u32>,
    /// SubFormat GUID (extensible only): integer PCM or IEEE float.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub subformat: Option<String>,
}

impl FmtFields {
    /// The `fmt ` chunk haptex writes for `format` with `channels` at
    /// `sample_rate_hz` (what hound writes for that spec); `None` if the
    /// byte rate does not fit its 32 bits.
    pub fn of(format: WavFormat, channels: u16, sample_rate_hz: u32) -> Option<Self> {
        let width = format.bits() / 8;
        let block_align = channels.checked_mul(width)?;
        let byte_rate = sample_rate_hz.checked_mul(u32::from(block_align))?;
        let extensible = format != WavFormat::Pcm16;
        let subformat = match format {
            WavFormat::Float32 => SUBTYPE_IEEE_FLOAT,
            _ => SUBTYPE_PCM,
        };
        Some(Self {
            format_tag: if extensible { FORMAT_EXTENSIBLE } else { FORMAT_PCM },
            channels,
            sample_rate_hz,
            byte_rate,
            block_align,
            bits_per_sample: format.bits(),
            valid_bits_per_sample: extensible.then_some(format.bits()),
            channel_mask: extensible.then_some(if channels == 2 { 3 } else { 1 }),
            subformat: extensible.then(|| subformat.to_string()),
        })
    }

    /// Reads the fields of a `fmt ` chunk's content: the 16 bytes every
    /// WAV has, and for WAVE_FORMAT_EXTENSIBLE the 22 bytes of its
    /// extension (cbSize at least 22). Bytes beyond are not fields: the
    /// reader compares the chunk's length with the one haptex writes
    /// ([`FmtFields::byte_len`]).
    pub fn parse(fmt: &[u8]) -> Result<Self, String> {
        if fmt.len() < 16 {
            return Err(format!("fmt chunk of {} bytes, shorter than the 16 of every WAV", fmt.len()));
        }
        let u16_at = |i: usize| u16::from_le_bytes([fmt[i], fmt[i + 1]]);
        let u32_at = |i: usize| u32::from_le_bytes([fmt[i], fmt[i + 1], fmt[i + 2], fmt[i + 3]]);
        let format_tag = u16_at(0);
        let extensible = format_tag == FORMAT_EXTENSIBLE;
        if extensible && (fmt.len() < 40 || u16_at(16) < 22) {
            return Err(format!(
                "fmt chunk of {} bytes with format tag {format_tag} (WAVE_FORMAT_EXTENSIBLE) and no complete \
                 extension: it needs 40 bytes",
                fmt.len()
            ));
        }
        Ok(Self {
            format_tag,
            channels: u16_at(2),
            sample_rate_hz: u32_at(4),
            byte_rate: u32_at(8),
            block_align: u16_at(12),
            bits_per_sample: u16_at(14),
            valid_bits_per_sample: extensible.then(|| u16_at(18)),
            channel_mask: extensible.then(|| u32_at(20)),
            subformat: extensible.then(|| guid_text(&fmt[24..40])),
        })
    }

    /// The length of the `fmt ` chunk haptex writes with these fields: 16
    /// bytes, or 40 for WAVE_FORMAT_EXTENSIBLE (cbSize = 22).
    pub fn byte_len(&self) -> usize {
        if self.format_tag == FORMAT_EXTENSIBLE { 40 } else { 16 }
    }

    /// Every field by name, as text, in the order of the chunk.
    fn fields(&self) -> [(&'static str, String); 9] {
        let opt = |v: Option<String>| v.unwrap_or_else(|| "absent".to_string());
        [
            ("format tag", self.format_tag.to_string()),
            ("channels", self.channels.to_string()),
            ("sample rate (Hz)", self.sample_rate_hz.to_string()),
            ("byte rate", self.byte_rate.to_string()),
            ("block align", self.block_align.to_string()),
            ("bits per sample", self.bits_per_sample.to_string()),
            ("valid bits per sample", opt(self.valid_bits_per_sample.map(|v| v.to_string()))),
            ("channel mask", opt(self.channel_mask.map(|v| v.to_string()))),
            // Text from the file: quoted (escaped, cut short).
            ("subformat", opt(self.subformat.as_deref().map(|s| crate::text::Quoted(s).to_string()))),
        ]
    }

    /// The first field where `self` (what a `fmt ` chunk says) differs
    /// from `stated`, as `NAME A where STATED_BY says B`; every field is
    /// compared.
    fn first_difference(&self, stated: &FmtFields, stated_by: &str) -> Option<String> {
        self.fields()
            .into_iter()
            .zip(stated.fields())
            .find(|(a, b)| a.1 != b.1)
            .map(|((name, a), (_, b))| format!("{name} {a} where {stated_by} says {b}"))
    }

    /// `format tag T, C channel(s), R Hz, B bits`, for messages.
    fn summary(&self) -> String {
        format!(
            "format tag {}, {} channel(s), {} Hz, {} bits",
            self.format_tag, self.channels, self.sample_rate_hz, self.bits_per_sample
        )
    }
}

/// A GUID's 16 bytes (Data1, Data2, Data3 little-endian, then Data4) in
/// the usual text form.
fn guid_text(b: &[u8]) -> String {
    format!(
        "{:08x}-{:04x}-{:04x}-{:02x}{:02x}-{}",
        u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        u16::from_le_bytes([b[4], b[5]]),
        u16::from_le_bytes([b[6], b[7]]),
        b[8],
        b[9],
        b[10..16].iter().map(|x| format!("{x:02x}")).collect::<String>()
    )
}

/// The content of the `hptx` chunk (JSON): what a sample stands for, and
/// the hash that ties the scale to these samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScaleChunk {
    /// The chunk's version: [`SCALE_CHUNK_VERSION`]; absent (`None`) in a
    /// version-1 chunk.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub version: Option<u32>,
    /// Always "haptex drive signal".
    pub kind: String,
    pub sample_format: WavFormat,
    /// The sample value that stands for `volts_per_full_scale`.
    pub full_scale_value: f64,
    /// Volts at the amplifier output for a full-scale sample.
    pub volts_per_full_scale: f64,
    pub sample_rate_hz: u32,
    pub n_samples: usize,
    /// Lowercase hex SHA-256 of the `data` chunk's bytes.
    pub samples_sha256: String,
    /// Every field of the `fmt ` chunk, as written (version 2; absent
    /// from a version-1 chunk).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fmt: Option<FmtFields>,
    /// Lowercase hex SHA-256 of the `fmt ` chunk's bytes (version 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fmt_sha256: Option<String>,
    /// volts = sample / full_scale_value * volts_per_full_scale.
    pub conversion: String,
    /// A two-channel WAV's second channel (the ultrasonic amplitude, in
    /// um): its own scale. Absent from a one-channel WAV's chunk. The
    /// fields above are channel 1's (volts); `n_samples` counts frames.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channel_2: Option<AmplitudeScale>,
}

/// The scale of a drive WAV's channel 2, the ultrasonic vibration
/// amplitude envelope: named in um, never in volts, so that it cannot be
/// read as channel 1's scale.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AmplitudeScale {
    /// Always "ultrasonic vibration amplitude, peak".
    pub quantity: String,
    /// Always "um".
    pub unit: String,
    /// The sample value that stands for `um_per_full_scale` (as channel 1's).
    pub full_scale_value: f64,
    /// Micrometres of vibration amplitude for a full-scale sample. haptex
    /// writes channel 2 at full scale = a_max, and its reader refuses a
    /// chunk where the two differ.
    pub um_per_full_scale: f64,
    /// The clamp of the render: no sample stands for more than this, um.
    pub a_max_um: f64,
    /// um = sample / full_scale_value * um_per_full_scale.
    pub conversion: String,
    /// The plate's resonance in Hz when channel 2 is the displacement
    /// a(t) sin(2 pi f_r t) (signed samples, `quantity` says so); absent
    /// when channel 2 is the amplitude envelope a(t) (samples >= 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resonance_hz: Option<f64>,
}

const AMPLITUDE_QUANTITY: &str = "ultrasonic vibration amplitude, peak";
const DISPLACEMENT_QUANTITY: &str = "ultrasonic plate displacement, amplitude-modulated at resonance_hz";
const AMPLITUDE_CONVERSION: &str = "um = sample / full_scale_value * um_per_full_scale";

const KIND: &str = "haptex drive signal";
const CONVERSION: &str = "volts = sample / full_scale_value * volts_per_full_scale";

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
    /// SHA-256 of the WAV's sample bytes, as in its `hptx` chunk: the
    /// sidecar belongs to the WAV whose samples have this hash.
    pub samples_sha256: String,
    /// SHA-256 of the WAV's `fmt ` chunk, as in its `hptx` chunk (version
    /// 2): the sidecar belongs to the WAV whose samples are read by this
    /// format. Absent from the sidecar of a version-1 WAV.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fmt_sha256: Option<String>,
    pub voltage_convention: String,
    /// Render settings, safety report and peak of the signal.
    pub report: SignalReport,
    /// Channel 2's scale (ultrasonic amplitude, um), as in the `hptx`
    /// chunk; absent for a one-channel WAV.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channel_2: Option<AmplitudeScale>,
    /// Where the signal came from (profile, trajectory, command), free form.
    pub source: serde_json::Value,
}

/// The sidecar path of a WAV file: the WAV path with `.json` appended.
pub fn sidecar_path(wav: &Path) -> PathBuf {
    let mut name = wav.as_os_str().to_owned();
    name.push(".json");
    PathBuf::from(name)
}

/// A WAV in memory with its scale chunk (what [`encode_wav`] returns).
#[derive(Debug, Clone, PartialEq)]
pub struct EncodedWav {
    /// The whole file.
    pub bytes: Vec<u8>,
    /// What its `hptx` chunk says.
    pub scale: ScaleChunk,
}

/// Checks a volts-per-full-scale value against its range
/// ([`crate::ranges::VOLTS_PER_FULL_SCALE`]).
pub fn check_volts_per_full_scale(vpfs: f64) -> Result<f64, SignalError> {
    crate::ranges::VOLTS_PER_FULL_SCALE.check(vpfs).map_err(|e| SignalError::Settings(e.to_string()))
}

/// Checks that a signal with `report` fits a WAV whose full scale stands
/// for `volts_per_full_scale` volts: the value within its range and the
/// drive's peak within it (refused, never clipped). Returns the value.
pub fn check_full_scale(report: &SignalReport, volts_per_full_scale: f64) -> Result<f64, SignalError> {
    let vpfs = check_volts_per_full_scale(volts_per_full_scale)?;
    if report.peak_v > vpfs {
        return Err(SignalError::ExceedsFullScale { amplitude_v: report.peak_v, volts_per_full_scale: vpfs });
    }
    Ok(vpfs)
}

/// Encodes `signal` as a WAV file in memory (mono, or two channels when
/// the signal has an ultrasonic channel), with its scale chunk
/// (what [`write_wav`] writes; a server sends these bytes). Refuses a
/// signal whose peak exceeds `volts_per_full_scale`. `label` names the
/// output in errors.
pub fn encode_wav(signal: &DriveSignal, options: &WavOptions, label: &str) -> Result<EncodedWav, SignalError> {
    let vpfs = check_full_scale(&signal.report, options.volts_per_full_scale)?;
    let report = &signal.report;
    let wav_error = |e: hound::Error| SignalError::Wav { path: label.to_string(), message: e.to_string() };
    let format = options.format;
    let full_scale = format.full_scale();
    let scale = full_scale / vpfs;
    // Channel 2 (two-channel signals): the ultrasonic amplitude in um, full
    // scale = a_max, so that no sample can stand for more than the clamp.
    let channel_2 = match (&signal.amplitude_um, &report.ultrasonic) {
        (None, None) => None,
        (Some(a), Some(us)) if a.len() == signal.len() => {
            let upfs = crate::ranges::A_MAX_UM.check(us.a_max_um).map_err(|e| SignalError::Settings(e.to_string()))?;
            // Every amplitude within 0 ..= a_max, every displacement within
            // -a_max ..= a_max (a NaN fails both).
            let (low, quantity) = match us.resonance_hz {
                None => (0.0, AMPLITUDE_QUANTITY),
                Some(f) => {
                    super::plate_resonance(f, report.sample_rate_hz).map_err(SignalError::Settings)?;
                    (-upfs, DISPLACEMENT_QUANTITY)
                }
            };
            if let Some(&bad) = a.iter().find(|&&v| !(low..=upfs).contains(&v)) {
                return Err(SignalError::Settings(format!(
                    "refused: channel 2's sample {bad} um is outside {} .. a_max = {upfs} um, its full scale",
                    Num(low)
                )));
            }
            Some((
                a,
                AmplitudeScale {
                    quantity: quantity.into(),
                    unit: "um".into(),
                    full_scale_value: full_scale,
                    um_per_full_scale: upfs,
                    a_max_um: us.a_max_um,
                    conversion: AMPLITUDE_CONVERSION.into(),
                    resonance_hz: us.resonance_hz,
                },
            ))
        }
        _ => {
            return Err(SignalError::Settings(
                "the signal's ultrasonic channel and its report do not agree; render it again".into(),
            ));
        }
    };
    let channels: u16 = if channel_2.is_some() { 2 } else { 1 };
    let scale_2 = channel_2.as_ref().map_or(0.0, |(_, c)| full_scale / c.um_per_full_scale);
    let mut bytes =
        crate::buffer::bytes_with_capacity(64 + signal.len() * usize::from(channels) * usize::from(format.bits() / 8));
    {
        let mut writer = hound::WavWriter::new(Cursor::new(&mut bytes), format.spec(report.sample_rate_hz, channels))
            .map_err(wav_error)?;
        let value = |v: f64| (v * scale).clamp(-full_scale, full_scale);
        let value_2 = |a: f64| (a * scale_2).clamp(-full_scale, full_scale);
        match (format, &channel_2) {
            (WavFormat::Pcm16, None) => {
                // hound's 16-bit fast path: one capacity check, no error per
                // sample. The values are clamped to +-full scale just above,
                // so the rounding stays within i16.
                let samples = u32::try_from(signal.len()).map_err(|_| SignalError::Wav {
                    path: label.to_string(),
                    message: format!("{} samples do not fit a WAV file", signal.len()),
                })?;
                let mut samples_writer = writer.get_i16_writer(samples);
                for &v in &signal.signal_v {
                    samples_writer.write_sample(crate::num::round_shifted(value(v)).0 as i16);
                }
                samples_writer.flush().map_err(wav_error)?;
            }
            (WavFormat::Pcm16, Some((a, _))) => {
                let samples = signal.len().checked_mul(2).and_then(|n| u32::try_from(n).ok()).ok_or_else(|| {
                    SignalError::Wav {
                        path: label.to_string(),
                        message: format!("2 x {} samples do not fit a WAV file", signal.len()),
                    }
                })?;
                let mut samples_writer = writer.get_i16_writer(samples);
                for (&v, &a) in signal.signal_v.iter().zip(a.iter()) {
                    samples_writer.write_sample(crate::num::round_shifted(value(v)).0 as i16);
                    samples_writer.write_sample(crate::num::round_shifted(value_2(a)).0 as i16);
                }
                samples_writer.flush().map_err(wav_error)?;
            }
            (WavFormat::Pcm24, None) => {
                for &v in &signal.signal_v {
                    writer.write_sample(crate::num::round_shifted(value(v)).0 as i32).map_err(wav_error)?;
                }
            }
            (WavFormat::Pcm24, Some((a, _))) => {
                for (&v, &a) in signal.signal_v.iter().zip(a.iter()) {
                    writer.write_sample(crate::num::round_shifted(value(v)).0 as i32).map_err(wav_error)?;
                    writer.write_sample(crate::num::round_shifted(value_2(a)).0 as i32).map_err(wav_error)?;
                }
            }
            (WavFormat::Float32, None) => {
                for &v in &signal.signal_v {
                    writer.write_sample(value(v) as f32).map_err(wav_error)?;
                }
            }
            (WavFormat::Float32, Some((a, _))) => {
                for (&v, &a) in signal.signal_v.iter().zip(a.iter()) {
                    writer.write_sample(value(v) as f32).map_err(wav_error)?;
                    writer.write_sample(value_2(a) as f32).map_err(wav_error)?;
                }
            }
        }
        writer.finalize().map_err(wav_error)?;
    }
    let encoder_error = |message: &str| SignalError::Wav { path: label.to_string(), message: message.into() };
    let data = find_chunk(&bytes, b"data").ok_or_else(|| encoder_error("the encoder wrote no data chunk"))?;
    let fmt_range = find_chunk(&bytes, b"fmt ").ok_or_else(|| encoder_error("the encoder wrote no fmt chunk"))?;
    // The fmt chunk as written must be the one the reader expects for this
    // format (a guard against an encoder that writes another layout).
    let fmt = FmtFields::parse(&bytes[fmt_range.clone()]).map_err(|m| encoder_error(&m))?;
    if Some(&fmt) != FmtFields::of(format, channels, report.sample_rate_hz).as_ref() {
        return Err(encoder_error("the encoder wrote another fmt chunk than haptex's reader expects"));
    }
    let scale = ScaleChunk {
        version: Some(SCALE_CHUNK_VERSION),
        kind: KIND.into(),
        sample_format: format,
        full_scale_value: full_scale,
        volts_per_full_scale: vpfs,
        sample_rate_hz: report.sample_rate_hz,
        n_samples: signal.len(),
        samples_sha256: sha256_hex(&bytes[data]),
        fmt: Some(fmt),
        fmt_sha256: Some(sha256_hex(&bytes[fmt_range])),
        conversion: CONVERSION.into(),
        channel_2: channel_2.map(|(_, c)| c),
    };
    append_chunk(&mut bytes, SCALE_CHUNK_ID, &serde_json::to_vec(&scale).expect("the scale chunk serializes"))
        .map_err(|message| SignalError::Wav { path: label.to_string(), message })?;
    Ok(EncodedWav { bytes, scale })
}

/// The byte range of the content of chunk `id` in a RIFF/WAVE file.
fn find_chunk(bytes: &[u8], id: &[u8; 4]) -> Option<std::ops::Range<usize>> {
    let mut at = 12;
    while at + 8 <= bytes.len() {
        let size = u32::from_le_bytes(bytes[at + 4..at + 8].try_into().ok()?) as usize;
        let start = at + 8;
        let end = start.checked_add(size)?;
        if &bytes[at..at + 4] == id {
            return (end <= bytes.len()).then_some(start..end);
        }
        at = end + (size & 1);
    }
    None
}

/// Appends a chunk (padded to an even length) to a RIFF file in memory and
/// updates the RIFF size.
fn append_chunk(bytes: &mut Vec<u8>, id: [u8; 4], content: &[u8]) -> Result<(), String> {
    let size = u32::try_from(content.len()).map_err(|_| "chunk too large".to_string())?;
    if bytes.len() % 2 == 1 {
        bytes.push(0);
    }
    bytes.extend_from_slice(&id);
    bytes.extend_from_slice(&size.to_le_bytes());
    bytes.extend_from_slice(content);
    if content.len() % 2 == 1 {
        bytes.push(0);
    }
    let riff_size = u32::try_from(bytes.len() - 8).map_err(|_| "a WAV file is limited to 4 GiB".to_string())?;
    bytes[4..8].copy_from_slice(&riff_size.to_le_bytes());
    Ok(())
}

/// Writes `signal` as a WAV at `path` (mono, or two channels when the
/// signal has an ultrasonic channel; with its scale chunk) and,
/// when `path` is a file, its sidecar JSON at [`sidecar_path`], each
/// atomically: the WAV first, then the sidecar, which carries the WAV's
/// sample hash. A WAV written to a stream (`-`, a FIFO, a device) gets no
/// sidecar; its scale is in the WAV. Refuses a signal whose peak exceeds
/// `volts_per_full_scale`. Returns the sidecar (also when not written).
pub fn write_wav(
    path: &Path,
    signal: &DriveSignal,
    options: &WavOptions,
    source: serde_json::Value,
) -> Result<WavSidecar, SignalError> {
    let target = OutputTarget::of(path)?;
    let encoded = encode_wav(signal, options, &path.display().to_string())?;
    let wav_file = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let sidecar = WavSidecar::new(wav_file, &encoded, &signal.report, source);
    write_atomic(path, |w| w.write_all(&encoded.bytes))?;
    if target.is_file() {
        fault_point("between-wav-and-sidecar");
        write_atomic(&sidecar_path(path), |w| {
            serde_json::to_writer_pretty(&mut *w, &sidecar).map_err(std::io::Error::from)?;
            w.write_all(b"\n")
        })?;
    }
    Ok(sidecar)
}

impl WavSidecar {
    /// The sidecar of the WAV `encoded` (file name `wav_file`) of a signal
    /// with `report`: its scales and sample hash as in the WAV's chunk.
    /// What [`write_wav`] writes beside the WAV; a server answering the WAV
    /// bytes offers the same document.
    pub fn new(wav_file: String, encoded: &EncodedWav, report: &SignalReport, source: serde_json::Value) -> Self {
        let scale = &encoded.scale;
        WavSidecar {
            kind: KIND.into(),
            wav_file,
            sample_rate_hz: report.sample_rate_hz,
            channels: if scale.channel_2.is_some() { 2 } else { 1 },
            n_samples: scale.n_samples,
            sample_format: scale.sample_format,
            bits_per_sample: scale.sample_format.bits(),
            full_scale_value: scale.full_scale_value,
            volts_per_full_scale: scale.volts_per_full_scale,
            conversion: CONVERSION.into(),
            samples_sha256: scale.samples_sha256.clone(),
            fmt_sha256: scale.fmt_sha256.clone(),
            voltage_convention: format!(
                "the envelope U is the RMS voltage of eq. (8); the drive is U times a unit-RMS carrier, peak = {} x U{}",
                report.carrier.peak_per_rms(),
                if scale.channel_2.is_some() {
                    " (channel 1; channel 2 is the ultrasonic amplitude in um, scaled by channel_2.um_per_full_scale)"
                } else {
                    ""
                }
            ),
            report: report.clone(),
            channel_2: scale.channel_2.clone(),
            source,
        }
    }
}

/// A haptex drive-signal WAV read back and checked.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveWav {
    /// The scale chunk (checked against the samples).
    pub scale: ScaleChunk,
    /// Channel 1's samples in V at the amplifier output.
    pub volts: Vec<f64>,
    /// Channel 2's samples in um (ultrasonic amplitude), for a
    /// two-channel WAV (scale in `scale.channel_2`).
    pub amplitude_um: Option<Vec<f64>>,
    /// The sidecar, when one was found beside the WAV (checked to belong
    /// to it).
    pub sidecar: Option<WavSidecar>,
}

impl DriveWav {
    /// Largest |sample| in V.
    pub fn peak_v(&self) -> f64 {
        self.volts.iter().fold(0.0, |m, v| m.max(v.abs()))
    }
}

/// Reads a haptex drive-signal WAV as volts, with the scale its `hptx`
/// chunk gives, after checking that the chunk matches the samples (hash,
/// count, format, rate) and that the sidecar beside it (`PATH.json`), if
/// there is one, belongs to it (same hash, same scale). Any mismatch is an
/// error: a WAV is never read with the wrong scale.
pub fn read_drive_wav(path: &Path) -> Result<DriveWav, SignalError> {
    let name = path.display().to_string();
    let bad = |message: String| SignalError::ReadWav { path: name.clone(), message };
    let metadata = std::fs::metadata(path).map_err(|e| bad(e.to_string()))?;
    if !metadata.is_file() {
        return Err(bad("not a regular file".into()));
    }
    if metadata.len() > u64::from(u32::MAX) + 8 {
        return Err(bad(format!("{} bytes: larger than a WAV file can be (4 GiB)", metadata.len())));
    }
    let mut bytes =
        crate::buffer::try_with_capacity(metadata.len() as usize, || format!("its {} bytes", metadata.len()))
            .map_err(|e| bad(e.to_string()))?;
    std::fs::File::open(path)
        .and_then(|f| f.take(metadata.len()).read_to_end(&mut bytes))
        .map_err(|e| bad(e.to_string()))?;
    let (scale, volts, amplitude_um) = decode_drive_wav_channels(&bytes).map_err(bad)?;
    let sidecar_file = sidecar_path(path);
    let sidecar = match std::fs::read(&sidecar_file) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(bad(format!("cannot read its sidecar {}: {e}", sidecar_file.display()))),
        Ok(text) => {
            let sidecar: WavSidecar = serde_json::from_slice(&text)
                .map_err(|e| bad(format!("its sidecar {} is not a haptex WAV sidecar: {e}", sidecar_file.display())))?;
            check_sidecar(&sidecar, &scale).map_err(|m| {
                bad(format!(
                    "its sidecar {} does not belong to it: {m} (a run was interrupted between the two files, or \
                     one was replaced; render the signal again)",
                    sidecar_file.display()
                ))
            })?;
            Some(sidecar)
        }
    };
    Ok(DriveWav { scale, volts, amplitude_um, sidecar })
}

/// Whether a sidecar describes the WAV whose scale chunk is `scale`.
fn check_sidecar(sidecar: &WavSidecar, scale: &ScaleChunk) -> Result<(), String> {
    if sidecar.samples_sha256 != scale.samples_sha256 {
        return Err(format!(
            "it is for samples with SHA-256 {}, the WAV's are {}",
            sidecar.samples_sha256, scale.samples_sha256
        ));
    }
    if sidecar.fmt_sha256 != scale.fmt_sha256 {
        let show = |h: &Option<String>| h.clone().unwrap_or_else(|| "none (a version-1 file)".into());
        return Err(format!(
            "it is for a fmt chunk with SHA-256 {}, the WAV's is {}",
            show(&sidecar.fmt_sha256),
            show(&scale.fmt_sha256)
        ));
    }
    if sidecar.volts_per_full_scale.to_bits() != scale.volts_per_full_scale.to_bits()
        || sidecar.full_scale_value.to_bits() != scale.full_scale_value.to_bits()
        || sidecar.sample_format != scale.sample_format
        || sidecar.bits_per_sample != scale.sample_format.bits()
    {
        return Err(format!(
            "it says {} V per full scale ({:?}), the WAV says {} V ({:?})",
            Num(sidecar.volts_per_full_scale),
            sidecar.sample_format,
            Num(scale.volts_per_full_scale),
            scale.sample_format
        ));
    }
    let bits = |c: &AmplitudeScale| {
        (
            c.full_scale_value.to_bits(),
            c.um_per_full_scale.to_bits(),
            c.a_max_um.to_bits(),
            c.unit.clone(),
            c.resonance_hz.map(f64::to_bits),
        )
    };
    if sidecar.channel_2.as_ref().map(bits) != scale.channel_2.as_ref().map(bits)
        || sidecar.channels != if scale.channel_2.is_some() { 2 } else { 1 }
    {
        let describe = |c: &Option<AmplitudeScale>| match c {
            Some(c) => {
                let on = c.resonance_hz.map_or(String::new(), |f| format!(", on the plate's resonance {} Hz", Num(f)));
                format!(
                    "channel 2 at {} um per full scale (a_max {} um{on})",
                    Num(c.um_per_full_scale),
                    Num(c.a_max_um)
                )
            }
            None => "no channel 2".to_string(),
        };
        return Err(format!(
            "it says {} channel(s), {}; the WAV says {}",
            sidecar.channels,
            describe(&sidecar.channel_2),
            describe(&scale.channel_2)
        ));
    }
    if sidecar.n_samples != scale.n_samples || sidecar.sample_rate_hz != scale.sample_rate_hz {
        return Err(format!(
            "it says {} samples at {} Hz, the WAV has {} at {} Hz",
            sidecar.n_samples, sidecar.sample_rate_hz, scale.n_samples, scale.sample_rate_hz
        ));
    }
    Ok(())
}

/// Decodes a haptex drive-signal WAV from its bytes: the scale chunk,
/// checked against the fmt and data chunks, and channel 1's samples in
/// volts (of a two-channel WAV too: channel 2 is
/// [`decode_drive_wav_channels`]'s). Linear in the input; chunk sizes are
/// checked against the bytes present before anything is allocated from
/// them.
pub fn decode_drive_wav(bytes: &[u8]) -> Result<(ScaleChunk, Vec<f64>), String> {
    decode_drive_wav_channels(bytes).map(|(scale, volts, _)| (scale, volts))
}

/// Decodes a haptex drive-signal WAV as [`decode_drive_wav`], with
/// channel 2 (the ultrasonic amplitude in um, by the chunk's `channel_2`
/// scale) when the WAV has two channels. Checks, in order, and refuses
/// the file at the first that fails:
///
/// 1. the RIFF header (its size is the file's), every chunk within the
///    file, none twice;
/// 2. the scale chunk: its version, kind, full scale and volts per full
///    scale, a sample rate of at least [`super::MIN_SAMPLE_RATE_HZ`],
///    channel 2's scale;
/// 3. the `fmt ` chunk, field by field, against the one haptex writes for
///    the chunk's format, channels and rate ([`FmtFields::of`]), and, in
///    a version-2 chunk, against its `fmt` fields and `fmt_sha256`;
/// 4. the samples' hash and count;
/// 5. every sample of every channel: finite and within full scale
///    (|code| <= `full_scale_value`; channel 2 also within 0, or -a_max
///    on the plate's resonance, .. a_max).
#[allow(clippy::type_complexity)]
pub fn decode_drive_wav_channels(bytes: &[u8]) -> Result<(ScaleChunk, Vec<f64>, Option<Vec<f64>>), String> {
    if bytes.len() < 12 || &bytes[0..4] != b"RIFF" || &bytes[8..12] != b"WAVE" {
        return Err("not a WAV file (no RIFF/WAVE header)".into());
    }
    let riff_size = u32::from_le_bytes(bytes[4..8].try_into().expect("4 bytes")) as usize;
    if riff_size.checked_add(8) != Some(bytes.len()) {
        return Err(format!(
            "the RIFF header says the file has {} bytes, it has {}: it was cut or extended after haptex wrote it",
            riff_size as u64 + 8,
            bytes.len()
        ));
    }
    let mut fmt: Option<&[u8]> = None;
    let mut data: Option<&[u8]> = None;
    let mut scale: Option<&[u8]> = None;
    let mut at = 12usize;
    while at < bytes.len() {
        let header = bytes.get(at..at + 8).ok_or_else(|| format!("truncated chunk header at byte {at}"))?;
        let id: [u8; 4] = header[0..4].try_into().expect("4 bytes");
        let size = u32::from_le_bytes(header[4..8].try_into().expect("4 bytes")) as usize;
        let start = at + 8;
        let content = bytes.get(start..start.saturating_add(size)).ok_or_else(|| {
            format!(
                "chunk {:?} at byte {at} claims {size} bytes, the file ends {} bytes later",
                String::from_utf8_lossy(&id),
                bytes.len() - start
            )
        })?;
        let slot = match &id {
            b"fmt " => &mut fmt,
            b"data" => &mut data,
            id if *id == SCALE_CHUNK_ID => &mut scale,
            _ => &mut None,
        };
        if slot.replace(content).is_some() {
            return Err(format!("chunk {:?} appears twice", String::from_utf8_lossy(&id)));
        }
        at = start + size + (size & 1);
    }
    let fmt = fmt.ok_or("no fmt chunk")?;
    let data = data.ok_or("no data chunk")?;
    let scale_bytes = scale.ok_or(
        "no haptex scale chunk (hptx): not a haptex drive signal, or written before the scale travelled with the \
         samples; its volts per full scale cannot be checked, render it again",
    )?;

    // 2. The scale chunk, on its own.
    let scale: ScaleChunk =
        serde_json::from_slice(scale_bytes).map_err(|e| format!("the haptex scale chunk is not valid: {e}"))?;
    match (scale.version, &scale.fmt, &scale.fmt_sha256) {
        (None, None, None) | (Some(SCALE_CHUNK_VERSION), Some(_), Some(_)) => {}
        (Some(v), _, _) if v > SCALE_CHUNK_VERSION => {
            return Err(format!(
                "the haptex scale chunk is version {v}, written by a newer haptex: this one cannot make its \
                 checks; read it with that version"
            ));
        }
        (v, f, h) => {
            return Err(format!(
                "the haptex scale chunk is not consistent: version {}, {} fmt fields, {} fmt hash (version 1 has \
                 neither, version {SCALE_CHUNK_VERSION} both)",
                v.map_or("1".to_string(), |v| v.to_string()),
                if f.is_some() { "with" } else { "without" },
                if h.is_some() { "with" } else { "without" },
            ));
        }
    }
    let format = scale.sample_format;
    let full_scale = format.full_scale();
    if scale.kind != KIND
        || scale.full_scale_value.to_bits() != full_scale.to_bits()
        || scale.conversion != CONVERSION
        || check_volts_per_full_scale(scale.volts_per_full_scale).is_err()
    {
        return Err(format!(
            "the haptex scale chunk is not consistent (kind {}, full scale {} for {:?}, {} V per full scale)",
            crate::text::Quoted(&scale.kind),
            Num(scale.full_scale_value),
            scale.sample_format,
            Num(scale.volts_per_full_scale)
        ));
    }
    if scale.sample_rate_hz < super::MIN_SAMPLE_RATE_HZ {
        return Err(format!(
            "the haptex scale chunk says {} Hz, below the {} Hz of any haptex drive signal",
            scale.sample_rate_hz,
            super::MIN_SAMPLE_RATE_HZ
        ));
    }
    if let Some(c2) = &scale.channel_2
        && (c2.quantity != if c2.resonance_hz.is_some() { DISPLACEMENT_QUANTITY } else { AMPLITUDE_QUANTITY }
            || c2.resonance_hz.is_some_and(|f| super::plate_resonance(f, scale.sample_rate_hz).is_err())
            || c2.unit != "um"
            || c2.conversion != AMPLITUDE_CONVERSION
            || c2.full_scale_value.to_bits() != full_scale.to_bits()
            || crate::ranges::A_MAX_UM.check(c2.um_per_full_scale).is_err()
            || crate::ranges::A_MAX_UM.check(c2.a_max_um).is_err()
            || c2.a_max_um.to_bits() != c2.um_per_full_scale.to_bits())
    {
        return Err(format!(
            "the haptex scale chunk's channel 2 is not consistent (quantity {}, unit {}, full scale {}, {} um per \
             full scale, a_max {} um)",
            crate::text::Quoted(&c2.quantity),
            crate::text::Quoted(&c2.unit),
            Num(c2.full_scale_value),
            Num(c2.um_per_full_scale),
            Num(c2.a_max_um)
        ));
    }

    // 3. The fmt chunk: every field as haptex writes it for this format,
    // channel count and rate, and as the chunk states it.
    let channels: u16 = if scale.channel_2.is_some() { 2 } else { 1 };
    let described = format!("{}, {channels} channel(s), {} Hz", format.name(), scale.sample_rate_hz);
    let expected = FmtFields::of(format, channels, scale.sample_rate_hz)
        .ok_or_else(|| format!("the haptex scale chunk's {described} do not fit a WAV's byte rate"))?;
    if let Some(stated) = &scale.fmt
        && let Some(difference) = stated.first_difference(&expected, "haptex's")
    {
        return Err(format!(
            "the haptex scale chunk is not consistent: its fmt fields ({}) are not those of {described}: {difference}",
            stated.summary()
        ));
    }
    let actual = FmtFields::parse(fmt)?;
    if let Some(difference) = actual.first_difference(&expected, "the scale chunk") {
        return Err(format!(
            "the fmt chunk ({}) does not match the scale chunk ({described}): {difference}; another program would \
             read the samples as another format",
            actual.summary()
        ));
    }
    if fmt.len() != expected.byte_len() || (expected.byte_len() == 40 && fmt[16..18] != [22, 0]) {
        return Err(format!(
            "the fmt chunk has {} bytes (extension size {}), haptex writes {} for {described}",
            fmt.len(),
            fmt.get(16..18).map_or(0, |b| u16::from_le_bytes([b[0], b[1]])),
            expected.byte_len()
        ));
    }
    if let Some(stated) = &scale.fmt_sha256 {
        let hash = sha256_hex(fmt);
        if hash != *stated {
            return Err(format!(
                "the fmt chunk does not match the scale chunk (SHA-256 {hash}, the chunk says {stated}): the file \
                 was changed after haptex wrote it"
            ));
        }
    }

    // 4. The samples: hash and count.
    let hash = sha256_hex(data);
    if hash != scale.samples_sha256 {
        return Err(format!(
            "the samples do not match the scale chunk (SHA-256 {hash}, the chunk says {}): the file was changed \
             after haptex wrote it",
            scale.samples_sha256
        ));
    }
    let width = usize::from(format.bits() / 8);
    let frame = width * usize::from(channels);
    if scale.n_samples.checked_mul(frame) != Some(data.len()) {
        return Err(format!(
            "{} data bytes for {} frames of {channels} sample(s) of {width} bytes",
            data.len(),
            scale.n_samples
        ));
    }

    // 5. Every sample of every channel: finite and within full scale.
    // volts = sample / full_scale_value * volts_per_full_scale, as written;
    // um = sample / full_scale_value * um_per_full_scale on channel 2.
    let sample = |s: &[u8]| match format {
        WavFormat::Pcm16 => f64::from(i16::from_le_bytes([s[0], s[1]])),
        WavFormat::Pcm24 => f64::from(i32::from_le_bytes([0, s[0], s[1], s[2]]) >> 8),
        WavFormat::Float32 => f64::from(f32::from_le_bytes([s[0], s[1], s[2], s[3]])),
    };
    let within = |code: f64, i: usize, channel: usize| {
        // NaN fails the comparison too.
        if code.abs() <= full_scale {
            Ok(code)
        } else {
            Err(format!(
                "channel {channel}'s sample {i} is {}: {} the full scale +-{} of its scale chunk (haptex never \
                 writes such a sample: the file was changed)",
                Num(code),
                if code.is_finite() { "beyond" } else { "not a finite value within" },
                Num(full_scale)
            ))
        }
    };
    let vpfs = scale.volts_per_full_scale;
    let Some(c2) = &scale.channel_2 else {
        let volts = data
            .chunks_exact(width)
            .enumerate()
            .map(|(i, s)| within(sample(s), i, 1).map(|code| code / full_scale * vpfs))
            .collect::<Result<Vec<f64>, String>>()?;
        return Ok((scale, volts, None));
    };
    let upfs = c2.um_per_full_scale;
    let mut volts = Vec::with_capacity(scale.n_samples);
    let mut amplitude = Vec::with_capacity(scale.n_samples);
    for (i, f) in data.chunks_exact(frame).enumerate() {
        volts.push(within(sample(&f[..width]), i, 1)? / full_scale * vpfs);
        amplitude.push(within(sample(&f[width..]), i, 2)? / full_scale * upfs);
    }
    // No sample may stand for more than a_max (half a code of rounding
    // allowed), nor for a negative amplitude; a displacement on the
    // plate's resonance swings between -a_max and a_max.
    let tolerance = match format {
        WavFormat::Float32 => upfs * 1e-6,
        _ => 0.5 * upfs / full_scale,
    };
    let low = if c2.resonance_hz.is_some() { -c2.a_max_um } else { 0.0 };
    if let Some(i) = amplitude.iter().position(|&a| !(a <= c2.a_max_um + tolerance && a >= low - tolerance)) {
        return Err(format!(
            "channel 2's sample {i} stands for {} um, outside {} .. a_max = {} um: the scale chunk does not belong \
             to these samples",
            Num(amplitude[i]),
            Num(low),
            Num(c2.a_max_um)
        ));
    }
    Ok((scale, volts, Some(amplitude)))
}
