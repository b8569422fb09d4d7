//! `haptex.voltage`: a friction profile to the drive of a display, as
//! `haptex voltage` computes it (paper eqs. 3-9; the ultrasonic and
//! combined displays of docs/physics.md).

use haptex_core::arg_names::ArgNames;
use haptex_core::calibration::design_device::DesignDevice;
use haptex_core::combined::{Channels, DisplayProfile, Strategy, map_display};
use haptex_core::electrovibration::{
    ContactArea, Device, LayerStack, Method, VoltageProfile, map_profile, map_profile_relative,
};
use haptex_core::frequency::{FingerCircuit, ForceModel};
use haptex_core::ranges;
use haptex_core::relative::FlatMu;
use haptex_core::signal::{Carrier, CarrierShape};
use haptex_core::ultrasonic::{Calibration, UltrasonicDevice};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{array, choice, input_path, json_object, ranged, ranged_opt};
use crate::errors::{OrRaise, input};
use crate::profile::profile_arg;

/// What a design function returns: the target friction and each channel's
/// drive, with the summary; `write_csv` writes the file `haptex voltage`
/// writes.
pub enum Designed {
    Electrovibration(VoltageProfile),
    Display(DisplayProfile),
}

impl Designed {
    fn write_csv(&self, notes: &[String], w: &mut dyn std::io::Write) -> std::io::Result<()> {
        for note in notes {
            writeln!(w, "# {note}")?;
        }
        match self {
            Designed::Electrovibration(v) => v.write_csv(w),
            Designed::Display(d) => d.write_csv(w),
        }
    }
}

/// A design: per position x (mm) the target friction mu and the drive of
/// each channel in use (voltage_v in V RMS for electrovibration,
/// amplitude_um in um peak for an ultrasonic plate; None for a channel not
/// in use), and its `summary` (a haptex.Summary).
#[pyclass(module = "haptex", name = "Design", frozen)]
pub struct Design {
    designed: Designed,
    /// What the file's first comments say besides the design's own: the
    /// force model and the carrier a circuit design is for.
    #[pyo3(get)]
    notes: Vec<String>,
    /// The device file it was designed with (path, SHA-256, what it is),
    /// for the JSON record as `haptex voltage --device` writes it.
    device_file: Option<serde_json::Value>,
    #[pyo3(get)]
    x_mm: Py<PyArray1<f64>>,
    #[pyo3(get)]
    mu: Py<PyArray1<f64>>,
    #[pyo3(get)]
    voltage_v: Option<Py<PyArray1<f64>>>,
    #[pyo3(get)]
    amplitude_um: Option<Py<PyArray1<f64>>>,
    #[pyo3(get)]
    summary: Py<PyAny>,
}

#[pymethods]
impl Design {
    /// Writes the design as `haptex voltage -o FILE.csv` does (comments,
    /// then `x_mm,mu[,voltage_v][,amplitude_um]` in full precision),
    /// atomically.
    fn write_csv(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        py.detach(|| haptex_core::io::write_atomic(&path, |w| self.designed.write_csv(&self.notes, w))).or_raise()
    }

    /// The CSV `write_csv` writes, as a str.
    fn to_csv(&self) -> PyResult<String> {
        let mut bytes = Vec::new();
        self.designed.write_csv(&self.notes, &mut bytes).or_raise()?;
        String::from_utf8(bytes).map_err(|e| input(format!("internal: {e}")))
    }

    /// The design as `haptex voltage --format json` writes it, as a dict
    /// (with `device_file` and `notes` when a device file designed it).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut json = match &self.designed {
            Designed::Electrovibration(v) => serde_json::to_value(v),
            Designed::Display(d) => serde_json::to_value(d),
        }
        .map_err(|e| input(format!("internal: {e}")))?;
        if let (Some(file), Some(object)) = (&self.device_file, json.as_object_mut()) {
            object.insert("device_file".into(), file.clone());
            object.insert("notes".into(), serde_json::json!(self.notes));
        }
        json_object(py, &json)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let summary = self.summary.bind(py);
        Ok(format!(
            "Design(display={}, {} points)",
            summary.getattr("display")?.str()?,
            summary.getattr("n_points")?.str()?
        ))
    }
}

impl Design {
    pub fn new(py: Python<'_>, designed: Designed, notes: Vec<String>) -> PyResult<Self> {
        let summary = summary_of(py, &designed)?;
        let (x, mu, u, a) = match &designed {
            Designed::Electrovibration(v) => (v.x_mm.clone(), v.mu.clone(), Some(v.voltage_v.clone()), None),
            Designed::Display(d) => (d.x_mm.clone(), d.mu.clone(), d.voltage_v.clone(), d.amplitude_um.clone()),
        };
        Ok(Self {
            x_mm: array(py, x),
            mu: array(py, mu),
            voltage_v: u.map(|u| array(py, u)),
            amplitude_um: a.map(|a| array(py, a)),
            summary: summary.unbind(),
            designed,
            notes,
            device_file: None,
        })
    }

    /// The design made with `file`: its JSON record names the file.
    pub fn with_device_file(mut self, file: Option<&DesignDevice>) -> Self {
        self.device_file = file.map(DesignDevice::provenance);
        self
    }

    pub fn designed(&self) -> &Designed {
        &self.designed
    }
}

/// The haptex.Summary of a design (python/haptex/_types.py).
fn summary_of<'py>(py: Python<'py>, designed: &Designed) -> PyResult<Bound<'py, PyAny>> {
    let types = py.import("haptex._types")?;
    let kwargs = PyDict::new(py);
    let (details, text) = match designed {
        Designed::Electrovibration(v) => {
            let s = &v.summary;
            kwargs.set_item("display", "electrovibration")?;
            kwargs.set_item("method", s.method.to_string())?;
            kwargs.set_item("n_points", s.n_points)?;
            kwargs.set_item("x_range_mm", (s.x_min_mm, s.x_max_mm))?;
            kwargs.set_item("mu_range", (s.mu_min, s.mu_max))?;
            let band = match (s.mu_hd, s.mu_at_u_max) {
                (Some(lo), Some(hi)) => Some((lo, hi)),
                _ => None,
            };
            kwargs.set_item("band_mu", band)?;
            kwargs.set_item("above_band", regions(&types, &s.clipped)?)?;
            kwargs.set_item("below_band", regions(&types, &s.not_renderable)?)?;
            kwargs.set_item("u_max_v", s.u_max_v)?;
            kwargs.set_item("a_max_um", py.None())?;
            kwargs.set_item("warnings", s.warnings.clone())?;
            (json_object(py, s)?, s.to_string())
        }
        Designed::Display(d) => {
            let s = &d.summary;
            let kind = match s.display {
                haptex_core::combined::DisplayKind::Electrovibration => "electrovibration",
                haptex_core::combined::DisplayKind::Ultrasonic => "ultrasonic",
                haptex_core::combined::DisplayKind::Combined => "combined",
            };
            kwargs.set_item("display", kind)?;
            kwargs.set_item("method", "physical (eq. 8)")?;
            kwargs.set_item("n_points", s.n_points)?;
            kwargs.set_item("x_range_mm", (s.x_min_mm, s.x_max_mm))?;
            kwargs.set_item("mu_range", (s.mu_min, s.mu_max))?;
            kwargs.set_item("band_mu", (s.band_mu[0], s.band_mu[1]))?;
            kwargs.set_item("above_band", regions(&types, &s.above_band)?)?;
            kwargs.set_item("below_band", regions(&types, &s.below_band)?)?;
            kwargs.set_item("u_max_v", s.electrovibration.as_ref().map(|e| e.u_max_v))?;
            let a_max = json_object(py, &s.ultrasonic)?;
            let a_max = if a_max.is_none() { py.None().into_bound(py) } else { a_max.get_item("a_max_um")? };
            kwargs.set_item("a_max_um", a_max)?;
            kwargs.set_item("warnings", s.warnings.clone())?;
            (json_object(py, s)?, s.to_string())
        }
    };
    kwargs.set_item("text", text)?;
    kwargs.set_item("details", details)?;
    types.getattr("Summary")?.call((), Some(&kwargs))
}

fn regions<'py>(
    types: &Bound<'py, PyModule>,
    r: &haptex_core::electrovibration::Regions,
) -> PyResult<Bound<'py, PyAny>> {
    let ranges: Vec<(f64, f64)> = r.ranges_mm.iter().map(|[a, b]| (*a, *b)).collect();
    types.getattr("Regions")?.call1((r.length_mm, r.fraction_of_length, ranges))
}

/// The device flags of `haptex voltage`, as keyword arguments (None: the
/// paper's Fig. 2 constant).
#[derive(Clone, Copy)]
pub struct DeviceArgs {
    pub mu_hd: Option<f64>,
    pub eps_sc: Option<f64>,
    pub eps_i: Option<f64>,
    pub d_sc_mm: Option<f64>,
    pub d_i_mm: Option<f64>,
    pub k_mm2_per_n: Option<f64>,
    pub area_exponent: Option<f64>,
    pub u_max: Option<f64>,
}

impl DeviceArgs {
    /// The device of eq. (3) and (8) these give, each value checked as the
    /// command line checks its flag.
    pub fn device(&self, force_model: &ForceModel) -> PyResult<Device> {
        let stack = LayerStack {
            eps_sc: ranged("eps_sc", ranges::EPS_SC, self.eps_sc.unwrap_or(LayerStack::PAPER.eps_sc))?,
            eps_i: ranged("eps_i", ranges::EPS_I, self.eps_i.unwrap_or(LayerStack::PAPER.eps_i))?,
            d_sc_mm: ranged("d_sc_mm", ranges::D_SC_MM, self.d_sc_mm.unwrap_or(LayerStack::PAPER.d_sc_mm))?,
            d_i_mm: ranged("d_i_mm", ranges::D_I_MM, self.d_i_mm.unwrap_or(LayerStack::PAPER.d_i_mm))?,
        };
        Ok(Device {
            stack,
            contact: ContactArea {
                k_mm2_per_n: ranged(
                    "k_mm2_per_n",
                    ranges::K_MM2_PER_N,
                    self.k_mm2_per_n.unwrap_or(ContactArea::PAPER.k_mm2_per_n),
                )?,
                exponent: ranged(
                    "area_exponent",
                    ranges::AREA_EXPONENT,
                    self.area_exponent.unwrap_or(ContactArea::PAPER.exponent),
                )?,
            },
            mu_hd: ranged("mu_hd", ranges::MU_HD, self.mu_hd.unwrap_or(Device::PAPER.mu_hd))?,
            u_max_v: ranged("u_max", ranges::U_MAX_V, self.u_max.unwrap_or(Device::PAPER.u_max_v))?,
            force_gain: force_model.gain(&stack),
        })
    }
}

/// The carrier of `carrier=` and `carrier_hz=` (default a 1 kHz sine).
pub fn carrier_of(shape: Option<&str>, frequency_hz: Option<f64>) -> PyResult<Carrier> {
    let shape = match shape.map(|s| choice("carrier", s, &["sine", "square", "none"])).transpose()? {
        None | Some("sine") => CarrierShape::Sine,
        Some("square") => CarrierShape::Square,
        _ => CarrierShape::None,
    };
    let frequency_hz = ranged_opt("carrier_hz", ranges::CARRIER_HZ, frequency_hz)?;
    Ok(Carrier { shape, frequency_hz: frequency_hz.unwrap_or(Carrier::DEFAULT.frequency_hz) })
}

/// The device file of `device=` (a path to a `haptex calibrate` TOML),
/// read and checked; None when not given.
pub fn device_file(device: Option<&Bound<'_, PyAny>>) -> PyResult<Option<DesignDevice>> {
    device.map(|d| DesignDevice::read(&input_path("device", d)?, ArgNames::PYTHON).or_raise()).transpose()
}

/// With a device file, refuses the arguments whose values come from it,
/// as the command line refuses those flags beside --device: the display's
/// constants every design function takes (`constants`: mu_hd, eps_sc,
/// eps_i, d_sc_mm, d_i_mm, k_mm2_per_n, as given), then the function's
/// own (`others`: whether each was given, and its name).
pub fn refuse_set_by_file(
    file: Option<&DesignDevice>,
    constants: [Option<f64>; 6],
    others: &[(bool, &str)],
) -> PyResult<()> {
    let Some(file) = file else { return Ok(()) };
    const NAMES: [&str; 6] = ["mu_hd", "eps_sc", "eps_i", "d_sc_mm", "d_i_mm", "k_mm2_per_n"];
    let mut given = constants.iter().zip(NAMES).map(|(c, name)| (c.is_some(), name)).chain(others.iter().copied());
    match given.find(|(g, _)| *g) {
        Some((_, name)) => Err(input(format!(
            "{name} cannot be given with device=: the device file {} sets it (drop {name}; u_max may lower the \
             file's U_max, never raise it)",
            file.file.path
        ))),
        None => Ok(()),
    }
}

/// The force model of `force_model=` and the circuit's arguments, refusing
/// the circuit's arguments with eq. (3) as `haptex voltage` does.
pub fn force_model_of(
    model: &str,
    rho_sc_ohm_m: Option<f64>,
    gap_um: Option<f64>,
    carrier: Option<&str>,
    carrier_hz: Option<f64>,
) -> PyResult<ForceModel> {
    if choice("force_model", model, &["eq3", "circuit"])? == "eq3" {
        for (given, name) in [
            (rho_sc_ohm_m.is_some(), "rho_sc_ohm_m"),
            (gap_um.is_some(), "gap_um"),
            (carrier.is_some(), "carrier"),
            (carrier_hz.is_some(), "carrier_hz"),
        ] {
            if given {
                return Err(input(format!(
                    "{name} is for the frequency-dependent force model: give force_model=\"circuit\" (eq. 3, the \
                     default, does not depend on the carrier)"
                )));
            }
        }
        return Ok(ForceModel::Eq3);
    }
    let (Some(rho_sc_ohm_m), Some(gap_um)) = (rho_sc_ohm_m, gap_um) else {
        return Err(input(
            "force_model=\"circuit\" needs rho_sc_ohm_m (the stratum corneum's DC resistivity) and gap_um (the air \
             gap, 0 for none): haptex has no default for either, measure or choose them (docs/physics.md)",
        ));
    };
    let circuit = FingerCircuit { rho_sc_ohm_m, gap_um };
    circuit.validate().or_raise()?;
    Ok(ForceModel::Circuit { circuit, carrier: carrier_of(carrier, carrier_hz)? })
}

/// The ultrasonic and combined displays' arguments.
pub struct DisplayChoice<'a> {
    pub display: &'a str,
    pub strategy: Option<&'a str>,
    pub weight: Option<f64>,
    pub ultrasonic_calibration: Option<&'a Bound<'a, PyAny>>,
    pub a_max_um: Option<f64>,
    /// The device file given: its plate (a_max at most its own).
    pub file: Option<&'a DesignDevice>,
}

impl DisplayChoice<'_> {
    /// The display ("electrovibration", "ultrasonic" or "combined").
    pub fn kind(&self) -> PyResult<&'static str> {
        choice("display", self.display, &["electrovibration", "ultrasonic", "combined"])
    }

    /// Refuses the plate's arguments on the electrovibration display.
    pub fn refuse_plate_args(&self) -> PyResult<()> {
        for (given, name) in [
            (self.strategy.is_some(), "strategy"),
            (self.weight.is_some(), "weight"),
            (self.ultrasonic_calibration.is_some(), "ultrasonic_calibration"),
            (self.a_max_um.is_some(), "a_max_um"),
        ] {
            if given {
                return Err(input(format!(
                    "{name} is for an ultrasonic or combined display: give display=\"ultrasonic\" or \"combined\""
                )));
            }
        }
        Ok(())
    }

    /// The ultrasonic plate: the device file's, the calibration given (a
    /// CSV path, or a pair of arrays amplitude_um, relative_friction) or
    /// the literature default.
    pub fn ultrasonic(&self) -> PyResult<UltrasonicDevice> {
        let a_max = ranged_opt("a_max_um", ranges::A_MAX_UM, self.a_max_um)?;
        if let Some(file) = self.file {
            return file.ultrasonic(a_max).or_raise();
        }
        match self.ultrasonic_calibration {
            None => UltrasonicDevice::literature_default(a_max).or_raise(),
            Some(value) => {
                let calibration = match value.extract::<(crate::convert::Floats<'_>, crate::convert::Floats<'_>)>() {
                    Ok((a, rho)) => Calibration::new(
                        crate::convert::to_vec(&a),
                        crate::convert::to_vec(&rho),
                        "ultrasonic_calibration arrays",
                    )
                    .or_raise()?,
                    Err(_) => Calibration::read_csv_file(&input_path("ultrasonic_calibration", value)?).or_raise()?,
                };
                UltrasonicDevice::calibrated(calibration, a_max).or_raise()
            }
        }
    }

    /// The plate and the combined display's strategy of a design with
    /// `method` on the ultrasonic or combined display (eq. 9 is refused:
    /// it is the electrovibration display's).
    pub fn plate(&self, method: Method) -> PyResult<(UltrasonicDevice, Option<Strategy>)> {
        if method != Method::Physical {
            return Err(input(
                "method=\"normalized\" (eq. 9) is for the electrovibration display: drop it with display=",
            ));
        }
        Ok((self.ultrasonic()?, self.strategy()?))
    }

    /// The combined display's strategy (None for the other displays).
    pub fn strategy(&self) -> PyResult<Option<Strategy>> {
        let kind = self.kind()?;
        if kind != "combined" && (self.strategy.is_some() || self.weight.is_some()) {
            return Err(input("strategy and weight share a target between two channels: give display=\"combined\""));
        }
        let strategy = self.strategy.map(|s| choice("strategy", s, &["split", "bias", "weighted"])).transpose()?;
        if self.weight.is_some() && strategy != Some("weighted") {
            return Err(input("weight is the weighted strategy's: give strategy=\"weighted\""));
        }
        if kind != "combined" {
            return Ok(None);
        }
        Ok(Some(match strategy.unwrap_or("split") {
            "split" => Strategy::Split,
            "bias" => Strategy::Bias,
            _ => Strategy::Weighted { weight: ranged("weight", ranges::STRATEGY_WEIGHT, self.weight.unwrap_or(1.0))? },
        }))
    }
}

/// Designs the drive of a display for a friction profile (`haptex voltage`).
///
/// profile: a haptex.Profile, a path to a profile CSV, (x_mm, mu), or an
///   object with x_mm and mu arrays (a haptex.Prediction).
/// method: "physical" (eq. 8: reproduces the friction force) or
///   "normalized" (eq. 9: the pattern only, min mu -> 0 V, max mu -> U_max).
/// relative: map mu / mu_flat * mu_HD (the paper's Fig. 2), mu_flat being
///   flat_mu or the profile's median.
/// mu_hd, eps_sc, eps_i, d_sc_mm, d_i_mm, k_mm2_per_n (mm^2/N),
///   area_exponent, u_max (V RMS): the display (default: the paper's Fig. 2
///   constants; U_max 100 V). fn_n (N): the exploration force, needed when
///   area_exponent != 1.
/// display: "electrovibration", "ultrasonic" or "combined"; strategy
///   ("split", "bias", "weighted") and weight for the combined display;
///   ultrasonic_calibration: a CSV path or (amplitude_um, relative_friction)
///   arrays (default: the literature placeholder); a_max_um (um peak).
/// force_model: "eq3" or "circuit" (with rho_sc_ohm_m, gap_um, carrier,
///   carrier_hz).
/// device: a display's device file (TOML, `haptex calibrate`): mu_HD, the
///   layer stack, the force coefficient on the carrier (carrier, carrier_hz;
///   default sine 1000 Hz) and U_max come from it, so the arguments that
///   set them are refused with it; u_max may lower U_max, never raise it.
///   The design's notes name the file and its SHA-256.
///
/// Returns a haptex.Design. Raises haptex.InvalidInputError (a ValueError)
/// with the command line's message for anything `haptex voltage` refuses.
#[pyfunction]
#[pyo3(signature = (
    profile, *, method = "physical", relative = false, flat_mu = None, mu_hd = None, eps_sc = None,
    eps_i = None, d_sc_mm = None, d_i_mm = None, k_mm2_per_n = None, area_exponent = None, fn_n = None,
    u_max = None, display = "electrovibration", strategy = None, weight = None, ultrasonic_calibration = None,
    a_max_um = None, force_model = "eq3", rho_sc_ohm_m = None, gap_um = None, carrier = None, carrier_hz = None,
    device = None
))]
#[allow(clippy::too_many_arguments)]
pub fn voltage(
    py: Python<'_>,
    profile: &Bound<'_, PyAny>,
    method: &str,
    relative: bool,
    flat_mu: Option<f64>,
    mu_hd: Option<f64>,
    eps_sc: Option<f64>,
    eps_i: Option<f64>,
    d_sc_mm: Option<f64>,
    d_i_mm: Option<f64>,
    k_mm2_per_n: Option<f64>,
    area_exponent: Option<f64>,
    fn_n: Option<f64>,
    u_max: Option<f64>,
    display: &str,
    strategy: Option<&str>,
    weight: Option<f64>,
    ultrasonic_calibration: Option<&Bound<'_, PyAny>>,
    a_max_um: Option<f64>,
    force_model: &str,
    rho_sc_ohm_m: Option<f64>,
    gap_um: Option<f64>,
    carrier: Option<&str>,
    carrier_hz: Option<f64>,
    device: Option<&Bound<'_, PyAny>>,
) -> PyResult<Design> {
    let profile = profile_arg("profile", profile)?;
    let file = device_file(device)?;
    refuse_set_by_file(
        file.as_ref(),
        [mu_hd, eps_sc, eps_i, d_sc_mm, d_i_mm, k_mm2_per_n],
        &[
            (area_exponent.is_some(), "area_exponent"),
            (force_model != "eq3", "force_model"),
            (rho_sc_ohm_m.is_some(), "rho_sc_ohm_m"),
            (gap_um.is_some(), "gap_um"),
            (ultrasonic_calibration.is_some(), "ultrasonic_calibration"),
        ],
    )?;
    let (device, notes) = match &file {
        Some(file) => {
            let u_max = ranged_opt("u_max", ranges::U_MAX_V, u_max)?;
            let design = file.design(&carrier_of(carrier, carrier_hz)?, u_max).or_raise()?;
            (design.device, design.notes)
        }
        None => {
            let force_model = force_model_of(force_model, rho_sc_ohm_m, gap_um, carrier, carrier_hz)?;
            let device = DeviceArgs { mu_hd, eps_sc, eps_i, d_sc_mm, d_i_mm, k_mm2_per_n, area_exponent, u_max }
                .device(&force_model)?;
            let notes = force_model.design_comment(&device).into_iter().collect();
            (device, notes)
        }
    };
    let method = match choice("method", method, &["physical", "normalized"])? {
        "physical" => Method::Physical,
        _ => Method::Normalized,
    };
    if flat_mu.is_some() && !relative {
        return Err(input("flat_mu is the flat-surface friction of relative=True: give relative=True"));
    }
    let flat_mu = ranged_opt("flat_mu", ranges::FLAT_MU, flat_mu)?;
    let fn_n = ranged_opt("fn_n", ranges::FN_N, fn_n)?;
    let choice = DisplayChoice { display, strategy, weight, ultrasonic_calibration, a_max_um, file: file.as_ref() };
    let flat = flat_mu.map_or(FlatMu::Median, FlatMu::Given);
    let designed = if choice.kind()? == "electrovibration" {
        choice.refuse_plate_args()?;
        let voltage = py.detach(|| {
            if relative {
                map_profile_relative(&profile, &device, method, fn_n, flat)
            } else {
                map_profile(&profile, &device, method, fn_n)
            }
        });
        Designed::Electrovibration(voltage.or_raise()?)
    } else {
        let (ultrasonic, strategy) = choice.plate(method)?;
        let channels = match strategy {
            Some(strategy) => Channels::Combined(&ultrasonic, strategy),
            None => Channels::Ultrasonic(&ultrasonic),
        };
        let design = py.detach(|| map_display(&profile, &device, channels, fn_n, relative.then_some(flat)));
        Designed::Display(design.or_raise()?)
    };
    Ok(Design::new(py, designed, notes)?.with_device_file(file.as_ref()))
}
