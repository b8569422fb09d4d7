//! Device and finger parameters of the voltage mapping (paper eqs. 3-9),
//! with the paper's defaults (Fig. 2) and the ranges the API accepts.
//!
//! One table, [`DEVICE_PARAMS`], serves validation, the defaults the GUI
//! shows (`GET /api/config`) and the OpenAPI description (a test checks
//! they agree). Names and units are those of the `haptex voltage` flags.
//!
//! The ranges and units are haptex-core's ([`haptex_core::ranges`], which
//! the command line checks too). With them, eq. (3) stays inside the
//! floating-point range at every corner of the ranges (Fe/Fn per V^2, the
//! voltage of eq. (8) and mu at U_max are finite and positive; a test walks
//! the corners), so a value that would break the mapping is refused naming
//! its own field rather than by the library's check of the device as a
//! whole.

use std::collections::BTreeMap;

use haptex_core::electrovibration::{ContactArea, Device, LayerStack, Method};
use haptex_core::ranges;
use serde::Serialize;

use crate::error::ApiError;
use haptex_core::ranges::Range;

/// One parameter: accepted when `min` <= value <= `max`.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ParamSpec {
    pub name: &'static str,
    /// The paper's value (`None`: no default; the parameter is optional).
    pub default: Option<f64>,
    /// Smallest accepted value (inclusive, > 0).
    pub min: f64,
    /// Largest accepted value (inclusive).
    pub max: f64,
    pub unit: &'static str,
    pub description: &'static str,
}

/// Every device and finger parameter, in the order the GUI shows them.
pub const DEVICE_PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "mu_hd",
        default: Some(Device::PAPER.mu_hd),
        min: ranges::MU_HD.min,
        max: ranges::MU_HD.max,
        unit: ranges::MU_HD.unit,
        description: "friction coefficient of the finger on the display with no voltage, mu_HD",
    },
    ParamSpec {
        name: "u_max_v",
        default: Some(Device::PAPER.u_max_v),
        min: ranges::U_MAX_V.min,
        max: ranges::U_MAX_V.max,
        unit: ranges::U_MAX_V.unit,
        description: "highest voltage the display applies, U_max (RMS): clip level (physical) or full scale (normalized)",
    },
    ParamSpec {
        name: "eps_sc",
        default: Some(LayerStack::PAPER.eps_sc),
        min: ranges::EPS_SC.min,
        max: ranges::EPS_SC.max,
        unit: ranges::EPS_SC.unit,
        description: "relative permittivity of the stratum corneum, eps_sc",
    },
    ParamSpec {
        name: "eps_i",
        default: Some(LayerStack::PAPER.eps_i),
        min: ranges::EPS_I.min,
        max: ranges::EPS_I.max,
        unit: ranges::EPS_I.unit,
        description: "relative permittivity of the display insulator, eps_i",
    },
    ParamSpec {
        name: "d_sc_mm",
        default: Some(LayerStack::PAPER.d_sc_mm),
        min: ranges::D_SC_MM.min,
        max: ranges::D_SC_MM.max,
        unit: ranges::D_SC_MM.unit,
        description: "stratum corneum thickness d_sc",
    },
    ParamSpec {
        name: "d_i_mm",
        default: Some(LayerStack::PAPER.d_i_mm),
        min: ranges::D_I_MM.min,
        max: ranges::D_I_MM.max,
        unit: ranges::D_I_MM.unit,
        description: "insulator thickness d_i",
    },
    ParamSpec {
        name: "k_mm2_per_n",
        default: Some(ContactArea::PAPER.k_mm2_per_n),
        min: ranges::K_MM2_PER_N.min,
        max: ranges::K_MM2_PER_N.max,
        unit: ranges::K_MM2_PER_N.unit,
        description: "contact-area coefficient k in A = k Fn^n",
    },
    ParamSpec {
        name: "area_exponent",
        default: Some(ContactArea::PAPER.exponent),
        min: ranges::AREA_EXPONENT.min,
        max: ranges::AREA_EXPONENT.max,
        unit: ranges::AREA_EXPONENT.unit,
        description: "contact-area exponent n in A = k Fn^n (1: the paper's linear law; otherwise fn_n is needed)",
    },
    ParamSpec {
        name: "fn_n",
        default: None,
        min: ranges::FN_N.min,
        max: ranges::FN_N.max,
        unit: ranges::FN_N.unit,
        description: "exploration normal force Fn (used only when area_exponent != 1; default: the profile's mean fn_n)",
    },
];

impl ParamSpec {
    /// The accepted range.
    pub fn range(&self) -> Range {
        Range { name: self.name, min: self.min, max: self.max, unit: self.unit }
    }
}

/// Looks a parameter up by name.
pub fn spec(name: &str) -> Option<&'static ParamSpec> {
    DEVICE_PARAMS.iter().find(|p| p.name == name)
}

/// The device a request's parameters start from: the paper's (Fig. 2),
/// or a calibrated display's device file (`haptex serve --device-file`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DefaultDevice {
    pub device: Device,
    /// The device file it is, if any.
    pub file: Option<DeviceFileSource>,
}

impl DefaultDevice {
    /// The paper's device, no device file.
    pub const PAPER: Self = Self { device: Device::PAPER, file: None };
}

/// The device file a server's default device comes from: what `GET
/// /api/config` shows, recipes pin and outputs designed with it name.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeviceFileSource {
    pub path: String,
    /// SHA-256 of the file's bytes (hex).
    pub sha256: String,
    /// One line: the file, its model, its measurements and their date.
    pub describe: String,
    /// The carrier its force coefficient is for (`sine 1000 Hz`); the
    /// circuit model's gain on it is folded into k.
    pub carrier: String,
}

impl DeviceFileSource {
    /// The comment line (without `# `) of an output designed with it.
    pub fn comment(&self) -> String {
        format!("designed with {}; device file sha256 {}", self.describe, self.sha256)
    }
}

/// The device and normal force a request asks for.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DeviceRequest {
    pub device: Device,
    /// Fn in N, when given.
    pub fn_n: Option<f64>,
}

impl DeviceRequest {
    /// The device from `(name, value)` pairs; missing parameters take the
    /// paper's defaults. Unknown names, names given twice and values out
    /// of [min, max] are errors naming `prefix` + the parameter.
    pub fn from_pairs<'a>(pairs: impl IntoIterator<Item = (&'a str, f64)>, prefix: &str) -> Result<Self, ApiError> {
        Self::from_pairs_over(pairs, prefix, &Device::PAPER)
    }

    /// [`DeviceRequest::from_pairs`] with the missing parameters taken
    /// from `base` (the server's default device).
    pub fn from_pairs_over<'a>(
        pairs: impl IntoIterator<Item = (&'a str, f64)>,
        prefix: &str,
        base: &Device,
    ) -> Result<Self, ApiError> {
        let mut values: Vec<Option<f64>> = DEVICE_PARAMS.iter().map(|p| p.default).collect();
        for (name, value) in Self::device_values(base) {
            if let Some(i) = DEVICE_PARAMS.iter().position(|p| p.name == name) {
                values[i] = Some(value);
            }
        }
        let mut given = vec![false; DEVICE_PARAMS.len()];
        for (name, value) in pairs {
            let field = format!("{prefix}{name}");
            let index = DEVICE_PARAMS.iter().position(|p| p.name == name).ok_or_else(|| {
                let known: Vec<&str> = DEVICE_PARAMS.iter().map(|p| p.name).collect();
                ApiError::bad_request(format!("unknown parameter (known: {})", known.join(", ")), Some(&field))
            })?;
            if std::mem::replace(&mut given[index], true) {
                return Err(ApiError::bad_request(format!("{name} is given twice"), Some(&field)));
            }
            check_range(&DEVICE_PARAMS[index], value, &field)?;
            values[index] = Some(value);
        }
        let get = |name: &str| -> f64 {
            let i = DEVICE_PARAMS.iter().position(|p| p.name == name).expect("known parameter");
            values[i].expect("parameter with a default")
        };
        let device = Device {
            stack: LayerStack {
                d_sc_mm: get("d_sc_mm"),
                eps_sc: get("eps_sc"),
                d_i_mm: get("d_i_mm"),
                eps_i: get("eps_i"),
            },
            contact: ContactArea { k_mm2_per_n: get("k_mm2_per_n"), exponent: get("area_exponent") },
            mu_hd: get("mu_hd"),
            u_max_v: get("u_max_v"),
            force_gain: base.force_gain,
        };
        let fn_n = values[DEVICE_PARAMS.iter().position(|p| p.name == "fn_n").expect("fn_n")];
        Ok(Self { device, fn_n })
    }
}

impl DeviceRequest {
    /// Every parameter by name, defaults included (`fn_n` when given).
    pub fn values(&self) -> BTreeMap<&'static str, f64> {
        let mut map = Self::device_values(&self.device);
        if let Some(f) = self.fn_n {
            map.insert("fn_n", f);
        }
        map
    }

    /// A device's parameters by name.
    fn device_values(d: &Device) -> BTreeMap<&'static str, f64> {
        BTreeMap::from([
            ("mu_hd", d.mu_hd),
            ("u_max_v", d.u_max_v),
            ("eps_sc", d.stack.eps_sc),
            ("eps_i", d.stack.eps_i),
            ("d_sc_mm", d.stack.d_sc_mm),
            ("d_i_mm", d.stack.d_i_mm),
            ("k_mm2_per_n", d.contact.k_mm2_per_n),
            ("area_exponent", d.contact.exponent),
        ])
    }
}

/// The parameter table with the defaults of `base` (the server's default
/// device), as `GET /api/config` shows it.
pub fn params_over(base: &Device) -> Vec<ParamSpec> {
    let values = DeviceRequest::device_values(base);
    DEVICE_PARAMS.iter().map(|p| ParamSpec { default: values.get(p.name).copied().or(p.default), ..*p }).collect()
}

/// Checks min <= value <= max (and finite); the error names `field`.
pub fn check_range(spec: &ParamSpec, value: f64, field: &str) -> Result<f64, ApiError> {
    crate::fields::check(spec.range(), value, field)
}

/// Parses a mapping method: `physical` (eq. 8) or `normalized` (eq. 9).
pub fn parse_method(text: &str, field: &str) -> Result<Method, ApiError> {
    match text {
        "physical" => Ok(Method::Physical),
        "normalized" => Ok(Method::Normalized),
        other => Err(ApiError::bad_request(
            format!("unknown method {other:?}: use physical (eq. 8) or normalized (eq. 9)"),
            Some(field),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With no parameters the device is the paper's Fig. 2 device.
    #[test]
    fn defaults_are_the_papers_device() {
        let request = DeviceRequest::from_pairs([], "").unwrap();
        assert_eq!(request.device, Device::PAPER);
        assert_eq!(request.fn_n, None);
    }

    #[test]
    fn out_of_range_and_unknown_names_are_refused_with_their_field() {
        for (name, value) in [("u_max_v", 0.0), ("u_max_v", 1e5), ("mu_hd", -1.0), ("d_i_mm", f64::NAN)] {
            let e = DeviceRequest::from_pairs([(name, value)], "device.").unwrap_err();
            assert_eq!(e.field.as_deref(), Some(format!("device.{name}").as_str()), "{e}");
        }
        let e = DeviceRequest::from_pairs([("u_max", 50.0)], "").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("u_max"));
        let e = DeviceRequest::from_pairs([("u_max_v", 50.0), ("u_max_v", 60.0)], "device.").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("device.u_max_v"));
    }

    /// At every corner of the accepted ranges (2^9 devices, each with mu
    /// at the ends of its own range), eq. (3)'s factor, the voltage of
    /// eq. (8) and mu at U_max are finite: no accepted combination makes
    /// the mapping overflow or underflow.
    #[test]
    fn device_ranges_keep_eq3_finite_at_every_corner() {
        use haptex_core::electrovibration::PhysicalMapping;
        let n = DEVICE_PARAMS.len();
        for corner in 0..(1u32 << n) {
            let pairs: Vec<(&str, f64)> = DEVICE_PARAMS
                .iter()
                .enumerate()
                .map(|(i, p)| (p.name, if corner & (1 << i) == 0 { p.min } else { p.max }))
                .collect();
            let request = DeviceRequest::from_pairs(pairs, "").unwrap();
            let d = request.device;
            let ratio = d.force_ratio_per_v2(request.fn_n.unwrap());
            assert!(ratio.is_finite() && ratio > 0.0, "corner {corner:b}: Fe/Fn per V^2 = {ratio}");
            let mapping = PhysicalMapping::new(d.mu_hd, ratio, d.u_max_v);
            assert!(mapping.mu_clip.is_finite() && mapping.mu_clip > 0.0, "corner {corner:b}: {}", mapping.mu_clip);
            for mu in [ranges::MU.min, ranges::MU.max, d.mu_hd, mapping.mu_clip] {
                let u = mapping.voltage_v(mu);
                assert!(u.is_finite() && u >= 0.0, "corner {corner:b}, mu {mu}: U = {u}");
            }
        }
    }

    /// Each parameter set by name comes back under that name: the table and
    /// the device fields are wired one to one.
    #[test]
    fn every_parameter_reaches_its_device_field() {
        for (i, spec) in DEVICE_PARAMS.iter().enumerate() {
            let value = spec.min + (spec.max - spec.min) / (i as f64 + 3.0);
            let request = DeviceRequest::from_pairs([(spec.name, value)], "").unwrap();
            let values = request.values();
            assert_eq!(values.get(spec.name), Some(&value), "{}", spec.name);
            for other in DEVICE_PARAMS.iter().filter(|o| o.name != spec.name) {
                assert_eq!(values.get(other.name).copied(), other.default, "{} when setting {}", other.name, spec.name);
            }
        }
    }
}
