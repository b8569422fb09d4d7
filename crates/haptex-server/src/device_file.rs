//! A calibrated display's device file in a design request (`device_file`:
//! the TOML text `haptex calibrate` and `POST /api/calibrate` write), as
//! `haptex voltage --device FILE` takes it: mu_HD, the layer stack, the
//! force coefficient (eq. 3 on a measured carrier, or the circuit model's
//! gain on any carrier) and U_max come from the file, for the `carrier`
//! the design will be played on (default a 1 kHz sine).
//!
//! The device parameters a file sets (mu_hd, the stack, k, the area
//! exponent) are refused beside it, each by its own field, rather than
//! silently overridden; `u_max_v` may lower the file's U_max (a lower limit
//! is safe), never raise it. Every answer designed with a file says which
//! (its description and the SHA-256 of its text), in the same words as the
//! command line's comment line.

use haptex_core::calibration::device_file::{DeviceFile, DeviceFileError, MAX_FILE_BYTES};
use haptex_core::electrovibration::Device;
use haptex_core::num::Num;
use haptex_core::ranges;
use haptex_core::signal::{Carrier, CarrierShape};
use haptex_core::ultrasonic::UltrasonicDevice;
use serde_json::{Value, json};

use crate::display::{DisplayDesign, DisplayRequest};
use crate::error::ApiError;
use crate::fields;
use crate::input::Pairs;
use crate::params::DeviceRequest;

/// The request field holding the device file's text.
pub const FIELD: &str = "device_file";

/// The name errors and comments give a device file sent in a request.
pub const SOURCE_NAME: &str = "uploaded device file";

/// The device parameters a device file sets: refused beside it.
pub const SET_BY_FILE: [&str; 7] = ["mu_hd", "eps_sc", "eps_i", "d_sc_mm", "d_i_mm", "k_mm2_per_n", "area_exponent"];

/// The words before the SHA-256 in a design's comment (as `haptex voltage
/// --device` writes it, so that `haptex play --device` reads it back).
pub const SHA256_MARK: &str = "device file sha256 ";

/// A device file read from a request, and the carrier it designs for.
#[derive(Debug, Clone)]
pub struct RequestDeviceFile {
    pub file: DeviceFile,
    /// SHA-256 of the text (hex).
    pub sha256: String,
    pub carrier: Carrier,
}

impl RequestDeviceFile {
    /// Reads and checks the file's text and the carrier (`carrier` field;
    /// default a 1 kHz sine). Errors name `device_file` (with the line of
    /// a TOML error) or `carrier.frequency_hz`.
    pub fn parse(text: &str, carrier: Option<Carrier>) -> Result<Self, ApiError> {
        if text.len() as u64 > MAX_FILE_BYTES {
            return Err(ApiError::too_large(
                format!("the device file is {} bytes, more than the limit of {MAX_FILE_BYTES}", text.len()),
                Some(FIELD),
            ));
        }
        let file = DeviceFile::from_toml(text, SOURCE_NAME).map_err(file_error)?;
        let carrier = carrier.unwrap_or(Carrier::DEFAULT);
        if carrier.shape != CarrierShape::None {
            fields::check(ranges::CARRIER_HZ, carrier.frequency_hz, "carrier.frequency_hz")?;
        }
        Ok(Self { file, sha256: haptex_core::io::sha256_hex(text.as_bytes()), carrier })
    }

    /// The electrovibration device of the file for its carrier, with U_max
    /// the file's or the lower `u_max_v` given. `given` are the device
    /// parameters the request named (refused when the file sets them);
    /// `prefix` starts their field names (`device.` in a JSON body).
    pub fn device<'a>(
        &self,
        given: impl IntoIterator<Item = (&'a str, f64)>,
        prefix: &str,
    ) -> Result<Device, ApiError> {
        let mut u_max_given = None;
        for (name, value) in given {
            if SET_BY_FILE.contains(&name) {
                return Err(ApiError::bad_request(
                    format!(
                        "{name} comes from the device file: leave it out, or design without the device file to give \
                         your own constants"
                    ),
                    Some(&format!("{prefix}{name}")),
                ));
            }
            if name == "u_max_v" {
                u_max_given = Some(value);
            }
        }
        let mut device = self.file.device(&self.carrier).map_err(|e| use_error(e, "carrier"))?;
        if let Some(u) = u_max_given {
            if u > self.file.u_max_v {
                return Err(ApiError::bad_request(
                    format!(
                        "U_max {} V is above the {} V RMS the device file states: the display gives at most that (a \
                         lower U_max is allowed)",
                        Num(u),
                        Num(self.file.u_max_v)
                    ),
                    Some(&format!("{prefix}u_max_v")),
                ));
            }
            device.u_max_v = u;
        }
        Ok(device)
    }

    /// The file's ultrasonic plate (`None` when it has none), a_max the
    /// file's or a lower `a_max_um` given.
    pub fn ultrasonic(&self, a_max_um: Option<f64>) -> Result<Option<UltrasonicDevice>, ApiError> {
        let Some(section) = &self.file.ultrasonic else { return Ok(None) };
        let mut file = self.file.clone();
        if let Some(a) = a_max_um {
            if a > section.a_max_um {
                return Err(ApiError::bad_request(
                    format!(
                        "a_max {} um is above the {} um the device file's plate was calibrated to: give at most that",
                        Num(a),
                        Num(section.a_max_um)
                    ),
                    Some("a_max_um"),
                ));
            }
            if let Some(u) = file.ultrasonic.as_mut() {
                u.a_max_um = a;
            }
        }
        file.ultrasonic_device().map_err(|e| ApiError::bad_request(format!("{SOURCE_NAME}: {e}"), Some(FIELD)))
    }

    /// The comment line of a CSV designed with the file (without `# `).
    pub fn comment(&self) -> String {
        format!(
            "designed with {} for the carrier {}; {SHA256_MARK}{}",
            self.file.describe(),
            carrier_words(&self.carrier),
            self.sha256
        )
    }

    /// Which device file designed an answer: `device_file` in the JSON.
    pub fn provenance(&self) -> Value {
        let electro = self.file.electrovibration.as_ref();
        json!({
            "describe": self.file.describe(),
            "sha256": self.sha256,
            "model": electro.map(|e| e.model.as_str()),
            "created": self.file.created,
            "measurements": { "file": self.file.measurements.file, "sha256": self.file.measurements.sha256,
                "rows": self.file.measurements.rows },
            "u_max_v": self.file.u_max_v,
            "ultrasonic": self.file.ultrasonic.as_ref().map(|u| u.model.as_str()),
            "carrier": self.carrier,
            "verdicts": self.file.verdicts,
        })
    }
}

/// The device of a design request: the constants given by name
/// (`device`), or, with `device_file`, the file's for `carrier` (the
/// constants it sets refused beside it). `carrier` without a file is
/// refused. `prefix` starts the device fields' names.
pub fn resolve(
    pairs: &Pairs,
    device_file: Option<&str>,
    carrier: Option<Carrier>,
    prefix: &str,
) -> Result<(DeviceRequest, Option<RequestDeviceFile>), ApiError> {
    let mut request = DeviceRequest::from_pairs(pairs.iter(), prefix)?;
    match (device_file, carrier) {
        (Some(text), carrier) => {
            let file = RequestDeviceFile::parse(text, carrier)?;
            request.device = file.device(pairs.iter(), prefix)?;
            Ok((request, Some(file)))
        }
        (None, Some(_)) => Err(ApiError::bad_request(
            "the carrier chooses a device file's force coefficient: give device_file with it",
            Some("carrier"),
        )),
        (None, None) => Ok((request, None)),
    }
}

/// The file's plate, when it has one, in place of the display's (the
/// literature default): a calibration given beside it is refused.
pub fn use_plate(
    file: Option<&RequestDeviceFile>,
    display: &DisplayRequest,
    design: &mut DisplayDesign,
) -> Result<(), ApiError> {
    if let Some(plate) = file.map(|f| f.ultrasonic(display.a_max_um)).transpose()?.flatten() {
        if display.ultrasonic_calibration.is_some() {
            return Err(ApiError::bad_request(
                "the device file has the plate's calibration: leave the ultrasonic calibration out, or design \
                 without the device file",
                Some("ultrasonic_calibration"),
            ));
        }
        design.ultrasonic = plate;
    }
    Ok(())
}

/// "sine 1000 Hz", or "none (a direct drive)".
fn carrier_words(c: &Carrier) -> String {
    match c.shape {
        CarrierShape::None => "none (a direct drive)".to_string(),
        shape => format!("{} {} Hz", shape.name(), Num(c.frequency_hz)),
    }
}

/// A file that cannot be read: 400 naming `device_file`, with the line of
/// a TOML error.
fn file_error(e: DeviceFileError) -> ApiError {
    let message = e.to_string();
    let line = message
        .split_once(": line ")
        .and_then(|(_, rest)| rest.split(':').next())
        .and_then(|n| n.trim().parse::<u64>().ok());
    ApiError::bad_request(message, Some(FIELD)).with_line(line)
}

/// A file that cannot design for this request (a carrier it was not
/// calibrated on, no electrovibration constants): 400 naming `field` when
/// it is the carrier's fault, else the file.
fn use_error(e: DeviceFileError, carrier_field: &str) -> ApiError {
    let message = e.to_string();
    let field = if message.contains("this design plays") { carrier_field } else { FIELD };
    ApiError::bad_request(message, Some(field))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_that_is_not_toml_is_refused_at_its_line() {
        let e = RequestDeviceFile::parse("format = \"haptex-device 1\"\nnot toml at all\n", None).unwrap_err();
        assert_eq!(e.field.as_deref(), Some(FIELD));
        assert_eq!(e.line, Some(2), "{e}");
        assert!(e.message.starts_with(SOURCE_NAME), "{e}");
    }
}
