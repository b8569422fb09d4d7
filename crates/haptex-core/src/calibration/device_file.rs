//! The device file: a calibrated display's constants, with their intervals,
//! the model they belong to and where they came from (TOML; docs/
//! calibration.md, "The device file"). `haptex calibrate` writes it; every
//! design command reads it with `--device FILE`.
//!
//! Only constants the measurements identify are written; what could not be
//! identified is listed under `verdicts`, so a device file never carries a
//! number its data do not support.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::calibration::force_fit::{carrier_name, equivalent_k_mm2_per_n};
use crate::calibration::measurements::Measurements;
use crate::calibration::ultrasonic_fit::Choice;
use crate::calibration::{Calibration, Estimate};
use crate::electrovibration::{ContactArea, Device, LayerStack};
use crate::frequency::FingerCircuit;
use crate::num::Num;
use crate::ranges::{self, Range};
use crate::signal::{Carrier, CarrierShape};
use crate::ultrasonic::{self, Exponential, UltrasonicDevice};

/// The format line every device file starts with.
pub const FORMAT: &str = "haptex-device 1";

/// The largest device file read (a table of 10 000 amplitudes is ~0.5 MB).
pub const MAX_FILE_BYTES: u64 = 4 << 20;

/// A device file that cannot be read or used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DeviceFileError {
    #[error("{path}: {message}")]
    File { path: String, message: String },
    #[error("device file {path}: {message}")]
    Use { path: String, message: String },
}

/// A constant and its 95% interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Value {
    pub value: f64,
    pub low: f64,
    pub high: f64,
}

impl From<Estimate> for Value {
    fn from(e: Estimate) -> Self {
        Self { value: e.value, low: e.interval[0], high: e.interval[1] }
    }
}

/// Where the constants came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Source {
    pub file: String,
    pub sha256: String,
    pub rows: usize,
}

/// c at one measured carrier (eq. 3/8).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CarrierSection {
    /// `sine`, `square` or `none`.
    pub carrier: String,
    pub carrier_hz: f64,
    /// Fe / (Fn U^2) on this carrier, 1/V^2.
    pub c_per_v2: Value,
    /// The k of eq. (8) that gives c with the stack assumed, mm^2/N.
    pub k_mm2_per_n: f64,
}

/// The circuit model's constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CircuitSection {
    /// Eq. (3)'s coefficient (perfect dielectric, no gap), 1/V^2.
    pub c_per_v2: Value,
    pub k_mm2_per_n: f64,
    pub rho_sc_ohm_m: Value,
    pub gap_um: Value,
}

/// The electrovibration force.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElectroSection {
    /// `eq3` (c per measured carrier) or `circuit` (c at any carrier).
    pub model: String,
    pub mu_hd: Value,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub carriers: Vec<CarrierSection>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub circuit: Option<CircuitSection>,
}

/// The ultrasonic plate's rho(a).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UltrasonicSection {
    /// `exponential` or `table`.
    pub model: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rho_inf: Option<Value>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub a_c_um: Option<Value>,
    /// The monotone table (always written: the data as measured).
    pub amplitude_um: Vec<f64>,
    pub relative_friction: Vec<f64>,
    pub a_max_um: f64,
    pub rho_min: Value,
}

/// A device file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeviceFile {
    pub format: String,
    /// When it was made (UTC, RFC 3339).
    pub created: String,
    pub measurements: Source,
    /// The layer stack assumed (friction data cannot separate it from k).
    pub stack: LayerStack,
    /// The highest voltage the display's amplifier gives, V RMS (stated by
    /// the user, not measured).
    pub u_max_v: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub electrovibration: Option<ElectroSection>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ultrasonic: Option<UltrasonicSection>,
    /// What could not be identified, and what to measure next.
    #[serde(default)]
    pub verdicts: Vec<String>,
    /// The file it was read from (not part of the file).
    #[serde(skip)]
    pub path: String,
}

impl DeviceFile {
    /// The device file of a calibration: identified constants only.
    pub fn from_calibration(c: &Calibration, m: &Measurements, u_max_v: f64) -> Self {
        let stack = c.settings.stack;
        let electrovibration = c.force.as_ref().and_then(|f| {
            if let Some(circuit) = f.circuit.as_ref().filter(|k| {
                k.mu_hd.identified && k.c_per_v2.identified && k.rho_sc_ohm_m.identified && k.gap_um.identified
            }) {
                return Some(ElectroSection {
                    model: "circuit".into(),
                    mu_hd: circuit.mu_hd.into(),
                    carriers: Vec::new(),
                    circuit: Some(CircuitSection {
                        c_per_v2: circuit.c_per_v2.into(),
                        k_mm2_per_n: equivalent_k_mm2_per_n(circuit.c_per_v2.value, &stack),
                        rho_sc_ohm_m: circuit.rho_sc_ohm_m.into(),
                        gap_um: circuit.gap_um.into(),
                    }),
                });
            }
            let carriers: Vec<CarrierSection> = f
                .eq3
                .carriers
                .iter()
                .filter(|k| k.c_per_v2.identified)
                .map(|k| CarrierSection {
                    carrier: k.carrier.shape.name().into(),
                    carrier_hz: if k.carrier.shape == CarrierShape::None { 0.0 } else { k.carrier.frequency_hz },
                    c_per_v2: k.c_per_v2.into(),
                    k_mm2_per_n: equivalent_k_mm2_per_n(k.c_per_v2.value, &stack),
                })
                .collect();
            (f.eq3.mu_hd.identified && !carriers.is_empty()).then(|| ElectroSection {
                model: "eq3".into(),
                mu_hd: f.eq3.mu_hd.into(),
                carriers,
                circuit: None,
            })
        });
        let ultrasonic = c.ultrasonic.as_ref().filter(|u| u.table.len() >= 2 && u.rho_min.value.is_finite()).map(|u| {
            let e = u.exponential.as_ref().filter(|_| u.chosen == Choice::Exponential);
            UltrasonicSection {
                model: if e.is_some() { "exponential" } else { "table" }.into(),
                rho_inf: e.map(|e| e.rho_inf.into()),
                a_c_um: e.map(|e| e.a_c_um.into()),
                amplitude_um: u.table.iter().map(|p| p.amplitude_um).collect(),
                relative_friction: u.table.iter().map(|p| p.rho).collect(),
                a_max_um: u.a_max_um,
                rho_min: u.rho_min.into(),
            }
        });
        Self {
            format: FORMAT.into(),
            created: crate::database::utc_now_rfc3339(),
            measurements: Source {
                file: m.source_name().to_string(),
                sha256: m.sha256().to_string(),
                rows: m.rows().len(),
            },
            stack,
            u_max_v,
            electrovibration,
            ultrasonic,
            verdicts: c.verdicts.clone(),
            path: String::new(),
        }
    }

    /// The file's TOML text, with a comment line on top.
    pub fn to_toml(&self) -> String {
        let body = toml::to_string(self).unwrap_or_else(|e| format!("# cannot serialize: {e}\n"));
        format!(
            "# haptex device file: the display's constants fitted by `haptex calibrate`, each with its 95% interval \
             (docs/calibration.md)\n{body}"
        )
    }

    /// Reads and checks a device file; errors name the file, and the line
    /// or the key.
    pub fn read(path: &Path) -> Result<Self, DeviceFileError> {
        let name = path.display().to_string();
        let file_error = |message: String| DeviceFileError::File { path: name.clone(), message };
        let bytes = crate::io::read_file_bounded(path, MAX_FILE_BYTES).map_err(|e| file_error(e.to_string()))?;
        let text = String::from_utf8(bytes).map_err(|_| file_error("not UTF-8 text".into()))?;
        Self::from_toml(&text, &name)
    }

    /// Parses and checks device-file text; `source` labels errors.
    pub fn from_toml(text: &str, source: &str) -> Result<Self, DeviceFileError> {
        let file_error = |message: String| DeviceFileError::File { path: source.to_string(), message };
        let mut file: Self = toml::from_str(text).map_err(|e| {
            let message = e.message().trim_end().to_string();
            file_error(match e.span() {
                Some(span) => {
                    format!("line {}: {message}", text[..span.start.min(text.len())].matches('\n').count() + 1)
                }
                None => message,
            })
        })?;
        file.path = source.to_string();
        file.validate().map_err(file_error)?;
        Ok(file)
    }

    /// Every value in range, every model complete.
    fn validate(&self) -> Result<(), String> {
        if self.format != FORMAT {
            return Err(format!("format is {:?}; this haptex reads {FORMAT:?}", self.format));
        }
        let check = |key: &str, range: Range, v: f64| -> Result<(), String> {
            range.check(v).map(|_| ()).map_err(|e| format!("{key}: {e}"))
        };
        let interval = |key: &str, range: Range, v: &Value| -> Result<(), String> {
            check(&format!("{key}.value"), range, v.value)?;
            if !(v.low <= v.value && v.value <= v.high) {
                return Err(format!(
                    "{key}: the interval {} .. {} does not hold the value {}",
                    Num(v.low),
                    Num(v.high),
                    Num(v.value)
                ));
            }
            Ok(())
        };
        self.stack.validate().map_err(|e| format!("stack: {e}"))?;
        check("u_max_v", ranges::U_MAX_V, self.u_max_v)?;
        if let Some(e) = &self.electrovibration {
            interval("electrovibration.mu_hd", ranges::MU_HD, &e.mu_hd)?;
            match (e.model.as_str(), &e.circuit) {
                ("circuit", Some(c)) => {
                    interval("electrovibration.circuit.c_per_v2", C_PER_V2, &c.c_per_v2)?;
                    interval("electrovibration.circuit.rho_sc_ohm_m", ranges::RHO_SC_OHM_M, &c.rho_sc_ohm_m)?;
                    interval("electrovibration.circuit.gap_um", ranges::GAP_UM, &c.gap_um)?;
                }
                ("circuit", None) => {
                    return Err("electrovibration: model \"circuit\" needs [electrovibration.circuit]".into());
                }
                ("eq3", _) => {
                    if e.carriers.is_empty() {
                        return Err(
                            "electrovibration: model \"eq3\" needs at least one [[electrovibration.carriers]]".into()
                        );
                    }
                    for (i, c) in e.carriers.iter().enumerate() {
                        let key = format!("electrovibration.carriers[{i}]");
                        parse_carrier(&c.carrier, c.carrier_hz).map_err(|m| format!("{key}: {m}"))?;
                        interval(&format!("{key}.c_per_v2"), C_PER_V2, &c.c_per_v2)?;
                    }
                }
                (other, _) => return Err(format!("electrovibration.model: {other:?} is not \"eq3\" or \"circuit\"")),
            }
        }
        if let Some(u) = &self.ultrasonic {
            if !matches!(u.model.as_str(), "exponential" | "table") {
                return Err(format!("ultrasonic.model: {:?} is not \"exponential\" or \"table\"", u.model));
            }
            if u.model == "exponential" {
                match (u.rho_inf, u.a_c_um) {
                    (Some(r), Some(a)) => {
                        interval("ultrasonic.rho_inf", RHO_INF, &r)?;
                        interval("ultrasonic.a_c_um", ranges::A_MAX_UM, &a)?;
                    }
                    _ => return Err("ultrasonic: model \"exponential\" needs rho_inf and a_c_um".into()),
                }
            }
            check("ultrasonic.a_max_um", ranges::A_MAX_UM, u.a_max_um)?;
            self.ultrasonic_device().map_err(|e| format!("ultrasonic: {e}"))?;
        }
        Ok(())
    }

    fn use_error(&self, message: String) -> DeviceFileError {
        DeviceFileError::Use { path: self.path.clone(), message }
    }

    /// The electrovibration device for a design played on `carrier`:
    /// mu_HD, the stack and U_max from the file, and the force coefficient
    /// for that carrier (the circuit's gain, or c measured on it).
    pub fn device(&self, carrier: &Carrier) -> Result<Device, DeviceFileError> {
        let Some(e) = &self.electrovibration else {
            return Err(self.use_error(
                "it has no electrovibration constants (the measurements did not identify mu_HD and c; see its \
                 verdicts)"
                    .into(),
            ));
        };
        let (k, force_gain) = if let Some(c) = &e.circuit {
            let circuit = FingerCircuit { rho_sc_ohm_m: c.rho_sc_ohm_m.value, gap_um: c.gap_um.value };
            (equivalent_k_mm2_per_n(c.c_per_v2.value, &self.stack), circuit.carrier_gain(&self.stack, carrier))
        } else {
            let found = e.carriers.iter().find(|c| {
                parse_carrier(&c.carrier, c.carrier_hz).is_ok_and(|m| {
                    m.shape == carrier.shape
                        && (m.shape == CarrierShape::None || m.frequency_hz == carrier.frequency_hz)
                })
            });
            let Some(found) = found else {
                let measured: Vec<String> = e
                    .carriers
                    .iter()
                    .filter_map(|c| parse_carrier(&c.carrier, c.carrier_hz).ok())
                    .map(|c| carrier_name(&c))
                    .collect();
                return Err(self.use_error(format!(
                    "it was calibrated on {} and this design plays {}: calibrate on that carrier too, or measure \
                     three or more carrier frequencies so that the circuit model gives c on any carrier",
                    measured.join(", "),
                    carrier_name(carrier)
                )));
            };
            (equivalent_k_mm2_per_n(found.c_per_v2.value, &self.stack), 1.0)
        };
        let device = Device {
            stack: self.stack,
            contact: ContactArea { k_mm2_per_n: k, exponent: 1.0 },
            mu_hd: e.mu_hd.value,
            u_max_v: self.u_max_v,
            force_gain,
        };
        device.validate().map_err(|err| self.use_error(err.to_string()))?;
        Ok(device)
    }

    /// The ultrasonic plate, if the file has one: its table, or the
    /// exponential valid up to a_max.
    pub fn ultrasonic_device(&self) -> Result<Option<UltrasonicDevice>, ultrasonic::UltrasonicError> {
        let Some(u) = &self.ultrasonic else { return Ok(None) };
        let device = match (u.model.as_str(), u.rho_inf, u.a_c_um) {
            ("exponential", Some(r), Some(a)) => UltrasonicDevice::parametric(
                Exponential { rho_inf: r.value, a_c_um: a.value, a_valid_um: u.a_max_um },
                Some(u.a_max_um),
            )?,
            _ => UltrasonicDevice::calibrated(
                ultrasonic::Calibration::new(u.amplitude_um.clone(), u.relative_friction.clone(), &self.path)?,
                Some(u.a_max_um),
            )?,
        };
        Ok(Some(device))
    }

    /// One line for the comments of every output designed with it.
    pub fn describe(&self) -> String {
        let model = self.electrovibration.as_ref().map_or("no electrovibration", |e| e.model.as_str());
        format!(
            "device file {} ({} model, measurements {} sha256 {}, made {})",
            self.path,
            model,
            self.measurements.file,
            &self.measurements.sha256[..self.measurements.sha256.len().min(12)],
            self.created
        )
    }
}

/// The range of a force coefficient c in 1/V^2 (eq. 3 at k from 1e-6 to
/// 1e6 mm^2/N on any stack in range stays far inside).
const C_PER_V2: Range = ranges::range("c_per_v2", 1e-15, 1.0, "1/V^2");
const RHO_INF: Range = ranges::range("rho_inf", 0.0, 1.0, "");

fn parse_carrier(shape: &str, hz: f64) -> Result<Carrier, String> {
    let shape = match shape {
        "sine" => CarrierShape::Sine,
        "square" => CarrierShape::Square,
        "none" => CarrierShape::None,
        other => return Err(format!("carrier {other:?} is not sine, square or none")),
    };
    let frequency_hz =
        if shape == CarrierShape::None { 0.0 } else { ranges::CARRIER_HZ.check(hz).map_err(|e| e.to_string())? };
    Ok(Carrier { shape, frequency_hz })
}
