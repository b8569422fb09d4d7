//! A device file in use: what `--device FILE` (and Python's `device=`)
//! does to a design, a check or a playback. The file's constants replace
//! the flags that set them; U_max and a_max may be lowered, never raised;
//! every output says which file (and the SHA-256 of its bytes) made it, and
//! a design made with one file is not played with another.
//!
//! The command line and the Python package share this, so their files say
//! the same; only the names of the arguments in the messages differ
//! ([`ArgNames`]).

use std::path::Path;

pub use crate::arg_names::ArgNames;
use crate::calibration::device_file::{DeviceFile, DeviceFileError, MAX_FILE_BYTES};
use crate::calibration::force_fit::carrier_name;
use crate::electrovibration::Device;
use crate::frequency::carrier_note;
use crate::num::Num;
use crate::signal::Carrier;
use crate::signal::play::DEVICE_SHA256_MARK;
use crate::ultrasonic::UltrasonicDevice;

/// A device file that cannot be read, or cannot do what is asked of it.
#[derive(Debug, thiserror::Error)]
pub enum DesignDeviceError {
    /// The file could not be read (missing, not a file, too large).
    #[error("device file {path}: {source}")]
    Read { path: String, source: crate::io::BoundedReadError },
    /// Unreadable, not a device file, or without what the use needs.
    #[error(transparent)]
    File(#[from] DeviceFileError),
    /// A limit asked for above the file's.
    #[error(
        "{arg} {given} is above the {quantity} = {stated} {unit} of device file {path}: {why}give at most {stated} \
         (a lower {quantity} is allowed), or drop {arg}"
    )]
    AboveFile {
        arg: &'static str,
        given: Num,
        quantity: &'static str,
        stated: Num,
        unit: &'static str,
        path: String,
        why: &'static str,
    },
    /// A plate asked of a file without one.
    #[error(
        "device file {path} has no ultrasonic plate (its measurements did not calibrate rho(a)): design for \
         {electrovibration}, or calibrate the plate"
    )]
    NoPlate { path: String, electrovibration: &'static str },
    /// The FE check asked of a circuit-model file.
    #[error(
        "device file {path} is of the circuit model (its force on {carrier} is eq. (3)'s times a gain of {gain:.4}): \
         the FE display applies eq. (3)'s attraction without that gain, so the check would not be of this display; \
         design with {design_with_file} and play it, or check with an eq3 device file"
    )]
    CircuitCheck { path: String, carrier: String, gain: f64, design_with_file: &'static str },
    /// A design made with another device file.
    #[error(
        "{design} was designed with a device file of SHA-256 {stated}, and device file {path} has SHA-256 {sha256}: \
         design it again with this device file, or play it with the one it was designed with"
    )]
    OtherFile { design: String, stated: String, path: String, sha256: String },
}

/// A device file read for use: its constants and the SHA-256 of its
/// bytes, which every output made with it records.
#[derive(Debug, Clone)]
pub struct DesignDevice {
    pub file: DeviceFile,
    /// SHA-256 of the file's bytes (hex).
    pub sha256: String,
    /// The arguments' names in messages.
    pub names: ArgNames,
}

/// The device of a design made with a device file, and the comments that
/// say so.
#[derive(Debug, Clone)]
pub struct FileDesign {
    pub device: Device,
    /// The file and its SHA-256, the force coefficient's origin, U_max and
    /// the carrier (in the words `haptex play` reads back).
    pub notes: Vec<String>,
    /// Whether the force is the file's circuit model (G times eq. 3).
    pub circuit: bool,
}

impl DesignDevice {
    /// Reads and checks the device file at `path` (at most
    /// [`MAX_FILE_BYTES`]); the hash is of the bytes parsed.
    pub fn read(path: &Path, names: ArgNames) -> Result<Self, DesignDeviceError> {
        let name = path.display().to_string();
        let bytes = crate::io::read_file_bounded(path, MAX_FILE_BYTES)
            .map_err(|source| DesignDeviceError::Read { path: name.clone(), source })?;
        let text = std::str::from_utf8(&bytes).map_err(|_| DeviceFileError::File {
            path: name.clone(),
            message: "not UTF-8 text, not a device file".into(),
        })?;
        let file = DeviceFile::from_toml(text, &name)?;
        Ok(Self { file, sha256: crate::io::sha256_hex(&bytes), names })
    }

    /// The electrovibration device for a design played on `carrier`, with
    /// U_max the file's or the lower one given.
    pub fn device(&self, carrier: &Carrier, u_max_given: Option<f64>) -> Result<Device, DesignDeviceError> {
        let mut device = self.file.device(carrier)?;
        device.u_max_v = self.u_max_v(u_max_given)?;
        Ok(device)
    }

    /// U_max: the file's, or a lower one given; a higher one is refused
    /// (the amplifier gives no more than the file states).
    pub fn u_max_v(&self, given: Option<f64>) -> Result<f64, DesignDeviceError> {
        let stated = self.file.u_max_v;
        match given {
            Some(u) if u > stated => Err(DesignDeviceError::AboveFile {
                arg: self.names.u_max,
                given: Num(u),
                quantity: "U_max",
                stated: Num(stated),
                unit: "V RMS",
                path: self.file.path.clone(),
                why: "the display gives at most that; ",
            }),
            Some(u) => Ok(u),
            None => Ok(stated),
        }
    }

    /// Whether the file's electrovibration force is the circuit model's.
    pub fn is_circuit(&self) -> bool {
        self.file.electrovibration.as_ref().is_some_and(|e| e.circuit.is_some())
    }

    /// The file's ultrasonic plate, a_max the file's or a lower one given
    /// (a higher one is refused).
    pub fn ultrasonic(&self, a_max_given: Option<f64>) -> Result<UltrasonicDevice, DesignDeviceError> {
        let path = &self.file.path;
        let Some(section) = &self.file.ultrasonic else {
            return Err(DesignDeviceError::NoPlate {
                path: path.clone(),
                electrovibration: self.names.electrovibration,
            });
        };
        let mut file = self.file.clone();
        if let Some(a) = a_max_given {
            if a > section.a_max_um {
                return Err(DesignDeviceError::AboveFile {
                    arg: self.names.a_max,
                    given: Num(a),
                    quantity: "a_max",
                    stated: Num(section.a_max_um),
                    unit: "um",
                    path: path.clone(),
                    why: "the plate gives at most that; ",
                });
            }
            if let Some(u) = file.ultrasonic.as_mut() {
                u.a_max_um = a;
            }
        }
        let device = file
            .ultrasonic_device()
            .map_err(|e| DeviceFileError::Use { path: path.clone(), message: e.to_string() })?;
        device.ok_or_else(|| DesignDeviceError::NoPlate {
            path: path.clone(),
            electrovibration: self.names.electrovibration,
        })
    }

    /// The comment every output made with the file carries (without `# `):
    /// what the file is, and the SHA-256 of its bytes.
    pub fn comment(&self) -> String {
        format!("designed with {}; {DEVICE_SHA256_MARK}{}", self.file.describe(), self.sha256)
    }

    /// The file as a JSON provenance record (JSON designs, WAV and NPY
    /// sidecars).
    pub fn provenance(&self) -> serde_json::Value {
        serde_json::json!({
            "path": self.file.path,
            "sha256": self.sha256,
            "describe": self.file.describe(),
        })
    }

    /// The device of a design played on `carrier` (U_max the file's or the
    /// lower one given), with the comments a design file carries: the
    /// file, the force coefficient's origin, U_max and the carrier.
    pub fn design(&self, carrier: &Carrier, u_max_given: Option<f64>) -> Result<FileDesign, DesignDeviceError> {
        let device = self.device(carrier, u_max_given)?;
        let circuit = self.is_circuit();
        let force = if circuit {
            format!(
                "force model: the device file's circuit; Fe = G Fe_eq3 with G = {:.6} for this carrier",
                device.force_gain
            )
        } else {
            format!(
                "force model: eq. (3) with the device file's c measured on {} (k = {} mm^2/N with its stack)",
                carrier_name(carrier),
                Num(device.contact.k_mm2_per_n)
            )
        };
        let notes =
            vec![self.comment(), format!("{force}; U_max = {} V RMS; {}", Num(device.u_max_v), carrier_note(carrier))];
        Ok(FileDesign { device, notes, circuit })
    }

    /// The device of an FE check: eq. (8) with the file's mu_HD, U_max and
    /// k for the carrier. The FE display applies eq. (3)'s attraction over
    /// its own contact, so a circuit-model file (whose force on a carrier
    /// is eq. (3)'s times the circuit's gain) is refused rather than
    /// checked on a display it does not describe.
    pub fn check_device(&self, carrier: &Carrier, u_max_given: Option<f64>) -> Result<Device, DesignDeviceError> {
        let device = self.device(carrier, u_max_given)?;
        if self.is_circuit() {
            return Err(DesignDeviceError::CircuitCheck {
                path: self.file.path.clone(),
                carrier: carrier_name(carrier),
                gain: device.force_gain,
                design_with_file: self.names.design_with_file,
            });
        }
        Ok(device)
    }

    /// The comments of a design made with the file on `carrier` without
    /// the force model's line (a check's, a map's): the file, and the
    /// carrier it is designed for (`haptex play` refuses another).
    pub fn design_notes(&self, carrier: &Carrier) -> Vec<String> {
        vec![self.comment(), carrier_note(carrier)]
    }

    /// For playing a design on the file's display: U_max the file's (or
    /// the lower one given), the carrier one the file gives the force for
    /// (an eq3 file: a carrier it was measured on), and the design one
    /// made with this file if its comments say which. `design` names the
    /// design in messages.
    pub fn play_u_max(
        &self,
        carrier: &Carrier,
        u_max_given: Option<f64>,
        comments: &[String],
        design: &str,
    ) -> Result<f64, DesignDeviceError> {
        let u_max = self.u_max_v(u_max_given)?;
        if self.file.electrovibration.is_some() {
            self.file.device(carrier)?;
        }
        self.check_design(comments, design)?;
        Ok(u_max)
    }

    /// Refuses a design whose comments say it was made with another device
    /// file (another SHA-256) than this one.
    pub fn check_design(&self, comments: &[String], design: &str) -> Result<(), DesignDeviceError> {
        match stated_device_sha256(comments) {
            Some(stated) if stated != self.sha256 => Err(DesignDeviceError::OtherFile {
                design: design.to_string(),
                stated,
                path: self.file.path.clone(),
                sha256: self.sha256.clone(),
            }),
            _ => Ok(()),
        }
    }
}

/// The SHA-256 of the device file a design's comment says it was made
/// with (`...; device file sha256 HEX`).
pub fn stated_device_sha256(comments: &[String]) -> Option<String> {
    comments.iter().find_map(|line| {
        let (_, rest) = line.split_once(DEVICE_SHA256_MARK)?;
        Some(rest.split_whitespace().next().unwrap_or("").to_string())
    })
}
