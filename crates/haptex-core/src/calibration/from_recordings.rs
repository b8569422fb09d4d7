//! Calibration measurements from recorded strokes: the recording format
//! (forces and finger position, docs/file-formats.md "Recording") with the
//! constant drive each was made under, stated in a manifest (TOML):
//!
//! ```toml
//! [[stroke]]
//! recording = "strokes/u80-1khz-1.recording.json"   # relative to the manifest
//! voltage_v = 80
//! carrier = "sine"          # sine, square or none (required when voltage_v > 0)
//! carrier_hz = 1000
//! amplitude_um = 0          # optional
//! finger = 1                # optional
//! repetition = 1            # optional
//! ```
//!
//! Each recording goes through the recordings pipeline (its default
//! settings: anti-alias filter, sliding detection, trimmed ends) and each
//! sliding segment it finds becomes one measurement: the mean of Ft/Fn
//! along the motion over the segment, its mean speed, and the stroke's
//! drive and ids. The rows are checked as a measurements file's are.

use std::path::Path;

use serde::Deserialize;

use crate::calibration::measurements::{Measurement, Measurements, MeasurementsError};
use crate::ranges;
use crate::recording::{ProcessingConfig, Recording, friction_coefficient, process};
use crate::signal::{Carrier, CarrierShape};

/// The most strokes a manifest may list.
pub const MAX_STROKES: usize = 10_000;

/// The largest manifest read.
const MAX_MANIFEST_BYTES: u64 = 4 << 20;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    stroke: Vec<Entry>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    recording: String,
    voltage_v: f64,
    #[serde(default)]
    carrier: Option<String>,
    #[serde(default)]
    carrier_hz: Option<f64>,
    #[serde(default)]
    amplitude_um: f64,
    #[serde(default)]
    finger: Option<u64>,
    #[serde(default)]
    repetition: Option<u64>,
}

/// Reads a manifest and the recordings it lists; every error names the
/// manifest and the stroke (and the recording's own file where the
/// pipeline refuses it).
pub fn read_manifest(path: &Path) -> Result<Measurements, MeasurementsError> {
    let name = path.display().to_string();
    let error = |message: String| MeasurementsError::File { path: name.clone(), message };
    let bytes = crate::io::read_file_bounded(path, MAX_MANIFEST_BYTES).map_err(|e| error(e.to_string()))?;
    let sha256 = crate::io::sha256_hex(&bytes);
    let text = String::from_utf8(bytes).map_err(|_| error("not UTF-8 text".into()))?;
    let manifest: Manifest = toml::from_str(&text).map_err(|e| {
        let at = e.span().map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
        error(match at {
            Some(line) => format!("line {line}: {}", e.message().trim_end()),
            None => e.message().trim_end().to_string(),
        })
    })?;
    if manifest.stroke.is_empty() || manifest.stroke.len() > MAX_STROKES {
        return Err(error(format!(
            "a manifest lists 1 to {MAX_STROKES} [[stroke]] entries, got {}",
            manifest.stroke.len()
        )));
    }
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut rows = Vec::new();
    let mut lines = Vec::new();
    for (k, entry) in manifest.stroke.iter().enumerate() {
        let at = |message: String| error(format!("stroke {} ({}): {message}", k + 1, entry.recording));
        ranges::VOLTAGE_V.check(entry.voltage_v).map_err(|e| at(e.to_string()))?;
        ranges::AMPLITUDE_UM.check(entry.amplitude_um).map_err(|e| at(e.to_string()))?;
        let carrier = match (entry.carrier.as_deref(), entry.carrier_hz) {
            (None, _) if entry.voltage_v > 0.0 => {
                return Err(at("the voltage is not 0: give its carrier (sine, square or none)".into()));
            }
            (None, _) => None,
            (Some("none"), _) => Some(Carrier { shape: CarrierShape::None, frequency_hz: 0.0 }),
            (Some(word @ ("sine" | "square")), hz) => {
                let hz = hz.ok_or_else(|| at(format!("a {word} carrier needs carrier_hz")))?;
                let frequency_hz = ranges::CARRIER_HZ.check(hz).map_err(|e| at(e.to_string()))?;
                let shape = if word == "sine" { CarrierShape::Sine } else { CarrierShape::Square };
                Some(Carrier { shape, frequency_hz })
            }
            (Some(other), _) => return Err(at(format!("carrier {other:?} is not sine, square or none"))),
        };
        if entry.voltage_v > 0.0 && entry.amplitude_um > 0.0 {
            return Err(at("both the voltage and the vibration are on: calibrate each channel alone".into()));
        }
        let recording = Recording::load(&dir.join(&entry.recording)).map_err(|e| at(e.to_string()))?;
        let stroke = process(&recording, &ProcessingConfig::default()).map_err(|e| at(e.to_string()))?;
        let s = &stroke.series;
        for (segment, _) in stroke.segments.iter().zip(&stroke.used).filter(|(_, u)| **u) {
            let range = segment.start..segment.end;
            let mu = friction_coefficient(&s.ft_n[range.clone()], &s.fn_n[range], segment.direction);
            rows.push(Measurement {
                voltage_v: entry.voltage_v,
                carrier,
                amplitude_um: entry.amplitude_um,
                mu: mu.iter().sum::<f64>() / mu.len() as f64,
                velocity_mm_s: Some(segment.mean_speed_mm_s),
                finger: entry.finger.unwrap_or(0),
                repetition: entry.repetition.unwrap_or(k as u64 + 1),
            });
            lines.push(k as u64 + 1);
        }
    }
    let named_fingers = manifest.stroke.iter().any(|e| e.finger.is_some());
    Measurements::from_segments(rows, lines, &name, sha256, named_fingers)
}
