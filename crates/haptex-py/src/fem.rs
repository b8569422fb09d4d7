//! The FE finger from Python: `haptex.simulate` (`haptex simulate`),
//! `haptex.check` (`haptex check`) and `haptex.compensate` (`haptex
//! voltage --compensate`). The runs take the GIL off; a progress reporter
//! (python/haptex/_progress.py) is called between FE steps, where Ctrl-C,
//! a callback returning False or raising stops the run.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use haptex_core::combined::{Channels, map_display};
use haptex_core::electrovibration::{ContactArea, Device, LayerStack, Method, map_profile, map_profile_relative};
use haptex_core::frequency::ForceModel;
use haptex_core::num::Num;
use haptex_core::ranges;
use haptex_core::relative::FlatMu;
use haptex_core::signal::{Extend, VoltageCurve};
use haptex_fem::display::Display;
use haptex_fem::finger::{FingerModel, Resolution};
use haptex_fem::output::{self, VoltageSource};
use haptex_fem::render::{self, Check, CheckMetrics, RenderError, RenderSettings, Stopping};
use haptex_fem::scenario::{self, Kinematics, Loading, Scenario, SimulationError, SimulationResult};
use haptex_fem::surface::SurfaceShape;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

use crate::convert::{Floats, array, choice, input_path, ranged, ranged_opt, to_vec, type_name};
use crate::design::{Design, Designed, DeviceArgs, DisplayChoice, carrier_of, device_file, refuse_set_by_file};
use crate::errors::{Kind, OrRaise, describe, input, raise};
use crate::profile::{Profile, profile_arg};

// ---------------------------------------------------------------- progress

/// The progress of FE runs as Python sees it: the reporter of
/// `haptex._progress.reporter` (a tqdm bar, the caller's callable, or
/// none), called as `reporter(done, total)` with the GIL taken back; the
/// first error it raises (or a False it returns, or Ctrl-C) is kept and
/// stops the run through the scenario's stop flag.
struct Reporter {
    reporter: Option<Py<PyAny>>,
    stop: Arc<AtomicBool>,
    error: Mutex<Option<PyErr>>,
}

/// The FE runs done so far of a check or a compensation.
#[derive(Default)]
struct RunCounter {
    runs_done: usize,
    last_step: usize,
}

impl Reporter {
    fn new(py: Python<'_>, progress: &Bound<'_, PyAny>, what: &str) -> PyResult<Self> {
        let reporter = py.import("haptex._progress")?.call_method1("reporter", (progress, what))?;
        Ok(Self {
            reporter: (!reporter.is_none()).then(|| reporter.unbind()),
            stop: Arc::new(AtomicBool::new(false)),
            error: Mutex::new(None),
        })
    }

    /// Tells the reporter the step `p` of one of at most `runs` FE runs
    /// (from the FE thread): a run's steps count from 1, so a step below
    /// the last one starts the next run.
    fn report_run(&self, counter: &mut RunCounter, runs: usize, p: scenario::Progress) {
        if p.step < counter.last_step {
            counter.runs_done += 1;
        }
        counter.last_step = p.step;
        self.report(counter.runs_done * p.total_steps + p.step, runs.max(counter.runs_done + 1) * p.total_steps);
    }

    /// Tells the reporter `done` of `total` steps (from the FE thread).
    fn report(&self, done: usize, total: usize) {
        if self.stop.load(Ordering::Relaxed) {
            return;
        }
        let outcome = Python::attach(|py| -> PyResult<bool> {
            py.check_signals()?;
            match &self.reporter {
                Some(r) => r.bind(py).call1((done, total))?.is_truthy(),
                None => Ok(true),
            }
        });
        let error = match outcome {
            Ok(true) => return,
            Ok(false) => raise(Kind::Cancelled, "cancelled: the progress callback returned False"),
            Err(e) => e,
        };
        *self.error.lock().unwrap_or_else(|e| e.into_inner()) = Some(error);
        self.stop.store(true, Ordering::Relaxed);
    }

    /// Closes the reporter and turns the run's outcome into Python's: the
    /// reporter's error first (the run stopped for it).
    fn finish<T, E>(self, py: Python<'_>, result: Result<T, E>, error: impl FnOnce(E) -> PyErr) -> PyResult<T> {
        if let Some(r) = &self.reporter {
            r.bind(py).call_method0("close")?;
        }
        if let Some(e) = self.error.into_inner().unwrap_or_else(|e| e.into_inner()) {
            return Err(e);
        }
        result.map_err(error)
    }
}

/// The exception class of a simulation error: a run that did not
/// converge (or lost contact) is a ComputationError, anything refused
/// before a run bad input.
fn simulation_kind(error: &SimulationError) -> Kind {
    match error {
        SimulationError::Solve(_) | SimulationError::NoContact { .. } => Kind::Computation,
        SimulationError::Cancelled => Kind::Cancelled,
        _ => Kind::Input,
    }
}

/// A check's error as its exception, with `haptex check`'s message.
fn render_error(error: RenderError) -> PyErr {
    let kind = match &error {
        RenderError::Simulation(e) => simulation_kind(e),
        _ => Kind::Input,
    };
    raise(kind, describe(&error))
}

/// A simulation's error as its exception, with `haptex simulate`'s
/// message: "simulation failed: " before an error of the run itself.
fn simulation_error(error: SimulationError) -> PyErr {
    raise(simulation_kind(&error), format!("simulation failed: {}", describe(&error)))
}

// ---------------------------------------------------------------- arguments

/// `value`, a positive finite number (the command line's `positive`).
fn positive(arg: &str, value: f64) -> PyResult<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(input(format!("{arg} must be a positive finite number, got {}", Num(value))))
    }
}

/// `value`, a finite number >= 0 (the command line's `non_negative`).
fn non_negative(arg: &str, value: f64) -> PyResult<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(input(format!("{arg} must be a finite number >= 0, got {}", Num(value))))
    }
}

/// The finger, mesh and tissue arguments shared by simulate and check.
struct FingerArgs<'a, 'py> {
    material: &'a str,
    mesh: &'a str,
    finger: Option<&'a Bound<'py, PyAny>>,
}

impl FingerArgs<'_, '_> {
    fn model(&self) -> PyResult<FingerModel> {
        match self.finger {
            None => Ok(FingerModel::default_model()),
            Some(path) => FingerModel::read(&input_path("finger", path)?).or_raise(),
        }
    }

    fn resolution(&self) -> PyResult<Resolution> {
        Ok(match choice("mesh", self.mesh, &["coarse", "default", "fine", "extra-fine"])? {
            "coarse" => Resolution::Coarse,
            "default" => Resolution::Default,
            "fine" => Resolution::Fine,
            _ => Resolution::ExtraFine,
        })
    }

    fn viscoelastic(&self) -> PyResult<bool> {
        Ok(choice("material", self.material, &["elastic", "viscoelastic"])? == "viscoelastic")
    }
}

/// The layer stack of eq. (3) (default: the paper's Fig. 2).
fn stack_of(
    eps_sc: Option<f64>,
    eps_i: Option<f64>,
    d_sc_mm: Option<f64>,
    d_i_mm: Option<f64>,
) -> PyResult<LayerStack> {
    Ok(LayerStack {
        eps_sc: ranged("eps_sc", ranges::EPS_SC, eps_sc.unwrap_or(LayerStack::PAPER.eps_sc))?,
        eps_i: ranged("eps_i", ranges::EPS_I, eps_i.unwrap_or(LayerStack::PAPER.eps_i))?,
        d_sc_mm: ranged("d_sc_mm", ranges::D_SC_MM, d_sc_mm.unwrap_or(LayerStack::PAPER.d_sc_mm))?,
        d_i_mm: ranged("d_i_mm", ranges::D_I_MM, d_i_mm.unwrap_or(LayerStack::PAPER.d_i_mm))?,
    })
}

/// A path's text as the command line prints a path it was given.
fn path_text(path: &std::path::Path) -> String {
    path.display().to_string()
}

// ---------------------------------------------------------------- simulate

/// The surface of `surface=`, and how the description names a sampled one.
fn surface_arg(value: &Bound<'_, PyAny>, x0: f64, width: f64, height: f64) -> PyResult<(SurfaceShape, String, bool)> {
    // As `haptex simulate` checks its flags, whatever the surface.
    let width = positive("width", width)?;
    if !x0.is_finite() || !height.is_finite() {
        return Err(input("x0 and height must be finite numbers"));
    }
    if value.is_instance_of::<PyString>() {
        let name: String = value.extract()?;
        let name = name.as_str();
        if let Some(path) = name.strip_prefix("file:") {
            let shape = SurfaceShape::read_csv(&input_path("surface", &PyString::new(value.py(), path))?).or_raise()?;
            return Ok((shape, name.to_string(), false));
        }
        let shape = match name {
            "flat" | "display" => SurfaceShape::Flat,
            "bump" => SurfaceShape::Bump { x0, width, height },
            "edge" => SurfaceShape::Edge { x0, width, height },
            "sine" => SurfaceShape::Sine { x0, width, height },
            other if std::path::Path::new(other).is_file() => {
                let shape = SurfaceShape::read_csv(std::path::Path::new(other)).or_raise()?;
                return Ok((shape, format!("file:{other}"), false));
            }
            other => {
                return Err(input(format!(
                    "surface must be flat, bump, edge, sine, display, file:H.csv, a path to a height CSV or a pair \
                     (x_mm, h_mm) of arrays, got {other:?}"
                )));
            }
        };
        return Ok((shape, name.to_string(), name == "display"));
    }
    if let Ok((x, h)) = value.extract::<(Floats<'_>, Floats<'_>)>() {
        let shape = SurfaceShape::Sampled { x_mm: to_vec(&x), h_mm: to_vec(&h) };
        shape.validate().or_raise()?;
        let n = x.len().unwrap_or(0);
        return Ok((shape, format!("height profile ({n} points)"), false));
    }
    if value.extract::<PathBuf>().is_ok() {
        let path = input_path("surface", value)?;
        let shape = SurfaceShape::read_csv(&path).or_raise()?;
        return Ok((shape, format!("file:{}", path_text(&path)), false));
    }
    Err(input(format!(
        "surface must be a template name (flat, bump, edge, sine, display), a path to a height CSV (x_mm,h_mm) or a \
         pair (x_mm, h_mm) of arrays, got {}",
        type_name(value)
    )))
}

/// The voltage of `voltage=` on the display: a haptex.Design, a path to a
/// voltage profile CSV, or (x_mm, voltage_v); and how the description
/// names it.
fn voltage_arg(value: &Bound<'_, PyAny>) -> PyResult<(VoltageCurve, String)> {
    if let Ok(design) = value.cast::<Design>() {
        let design = design.get();
        let (x, u) = match design.designed() {
            Designed::Electrovibration(v) => (v.x_mm.clone(), v.voltage_v.clone()),
            Designed::Display(d) => match &d.voltage_v {
                Some(u) => (d.x_mm.clone(), u.clone()),
                None => return Err(input("voltage: the design has no voltage (an ultrasonic-only design)")),
            },
        };
        return Ok((VoltageCurve::new(x, u).or_raise()?, "a haptex.Design".to_string()));
    }
    if let Ok((x, u)) = value.extract::<(Floats<'_>, Floats<'_>)>() {
        return Ok((VoltageCurve::new(to_vec(&x), to_vec(&u)).or_raise()?, "arrays".to_string()));
    }
    if value.extract::<PathBuf>().is_ok() {
        let path = input_path("voltage", value)?;
        return Ok((VoltageCurve::read_csv_file(&path).or_raise()?, path_text(&path)));
    }
    Err(input(format!(
        "voltage must be a haptex.Design, a path to a voltage profile CSV or a pair (x_mm, voltage_v) of arrays, got {}",
        type_name(value)
    )))
}

/// A finger simulation's result: the friction profile over the slide
/// (x_mm: finger position on the surface in mm; mu = Ft/Fn; ft_n, fn_n in
/// N per mm of finger width, as `haptex simulate` writes them), the force
/// history, and the run's description and statistics. A press-only run
/// (slide=0) has no profile (x_mm, mu, ft_n, fn_n and profile are None);
/// its press is in `history`.
#[pyclass(module = "haptex", name = "Simulation", frozen)]
pub struct Simulation {
    result: SimulationResult,
    /// The run as the file's first comment states it.
    #[pyo3(get)]
    description: String,
    #[pyo3(get)]
    x_mm: Option<Py<PyArray1<f64>>>,
    #[pyo3(get)]
    mu: Option<Py<PyArray1<f64>>>,
    #[pyo3(get)]
    ft_n: Option<Py<PyArray1<f64>>>,
    #[pyo3(get)]
    fn_n: Option<Py<PyArray1<f64>>>,
    /// The friction profile as a haptex.Profile (with fn_n), for haptex.voltage.
    #[pyo3(get)]
    profile: Option<Py<Profile>>,
    /// Per FE step: t_s, slide_mm, fn_n, ft_n, contact_mm, drive_y_mm,
    /// voltage_v, fe_n, fe_contact_n (arrays; forces per mm of width).
    #[pyo3(get)]
    history: Py<PyDict>,
    /// Mesh size and solver effort: nodes, elements, free_dofs,
    /// contact_dofs, steps, newton_iterations, step_cuts, wall_time_s.
    #[pyo3(get)]
    statistics: Py<PyAny>,
}

#[pymethods]
impl Simulation {
    /// Writes the profile as `haptex simulate -o FILE` does (`x_mm,mu,ft_n,fn_n`,
    /// full precision; the press curve of a press-only run), atomically.
    fn write_csv(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        py.detach(|| {
            haptex_core::io::write_atomic(&path, |w| output::write_profile(&self.result, &self.description, w))
        })
        .or_raise()
    }

    /// The CSV `write_csv` writes, as a str.
    fn to_csv(&self) -> PyResult<String> {
        let mut bytes = Vec::new();
        output::write_profile(&self.result, &self.description, &mut bytes).or_raise()?;
        String::from_utf8(bytes).map_err(|e| input(format!("internal: {e}")))
    }

    /// Writes the force history as `haptex simulate --history FILE` does.
    fn write_history(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        py.detach(|| haptex_core::io::write_atomic(&path, |w| output::write_history(&self.result, w))).or_raise()
    }

    /// Writes a PNG of the deformed finger as `haptex simulate --png FILE` does.
    fn write_png(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        let title = format!("haptex simulate: {}", self.description.split(';').next().unwrap_or(""));
        py.detach(|| output::write_png(&self.result, &title, &path)).or_raise()
    }

    fn __repr__(&self) -> String {
        match &self.result.profile {
            Some(p) => format!("Simulation({}; {} points)", self.description, p.len()),
            None => format!("Simulation({}; press only)", self.description),
        }
    }
}

impl Simulation {
    fn new(py: Python<'_>, result: SimulationResult, description: String) -> PyResult<Self> {
        let h = &result.history;
        let history = PyDict::new(py);
        let column = |f: &dyn Fn(&scenario::HistoryRow) -> f64| array(py, h.iter().map(f).collect());
        history.set_item("t_s", column(&|r| r.t_s))?;
        history.set_item("slide_mm", column(&|r| r.slide_mm))?;
        history.set_item("fn_n", column(&|r| r.fn_n))?;
        history.set_item("ft_n", column(&|r| r.ft_n))?;
        history.set_item("contact_mm", column(&|r| r.contact_mm))?;
        history.set_item("drive_y_mm", column(&|r| r.drive_y_mm))?;
        history.set_item("voltage_v", column(&|r| r.voltage_v))?;
        history.set_item("fe_n", column(&|r| r.fe_n))?;
        history.set_item("fe_contact_n", column(&|r| r.fe_contact_n))?;
        let statistics = crate::convert::json_object(py, &result.statistics)?.unbind();
        let (mut x, mut mu, mut ft, mut fnn, mut profile) = (None, None, None, None, None);
        if let Some(p) = &result.profile {
            let f = p.fn_n().unwrap_or(&[]);
            x = Some(array(py, p.x_mm().to_vec()));
            mu = Some(array(py, p.mu().to_vec()));
            // As the file writes them: ft_n = mu fn_n.
            ft = Some(array(py, p.mu().iter().zip(f).map(|(m, f)| m * f).collect()));
            fnn = Some(array(py, f.to_vec()));
            profile = Some(Py::new(py, Profile { inner: p.clone() })?);
        }
        Ok(Self {
            result,
            description,
            x_mm: x,
            mu,
            ft_n: ft,
            fn_n: fnn,
            profile,
            history: history.unbind(),
            statistics,
        })
    }
}

/// Slides the 2D finite-element finger pad over a surface and returns its
/// friction profile (`haptex simulate`).
///
/// surface: "flat", "bump", "edge", "sine" (templates with x0, width,
///   height in mm: feature position, width r_w, height r_h), "file:H.csv"
///   or a path to a height profile CSV (x_mm,h_mm), a pair (x_mm, h_mm) of
///   arrays, or "display": a flat electrovibration display under the
///   voltage U(x) at the finger's position, given as voltage= (a
///   haptex.Design, a path to a voltage profile CSV, or (x_mm, voltage_v)
///   in mm and V RMS; the first/last voltage is held beyond it) or
///   constant_voltage= (V RMS); mu_display is then the skin-display
///   friction (default the finger model's, 0.5), eps_sc, eps_i, d_sc_mm,
///   d_i_mm the display's layers (default: the paper's Fig. 2).
/// velocity: sliding velocity in mm/s. indent: press bone and nail down by
///   this much in mm (default 0.25), or load: a constant normal load in N
///   per mm of finger width. slide: slide distance in mm (0: a press
///   only). step: slide per step in mm (default 0.1, or width/10 if
///   smaller). press_time: duration of the press in s. mu_skin: the
///   skin-surface friction (default the finger model's, 0.5).
/// material: "viscoelastic" or "elastic"; kinematics: "small" (the
///   paper's) or "finite" (neo-Hookean, about 3x slower); mesh: "coarse",
///   "default", "fine", "extra-fine"; finger: a finger model file (default the shipped
///   one); penalty: contact penalty in MPa per mm.
/// progress: True (the default, as None): a tqdm bar when tqdm is
///   installed; False: none; or a
///   callable progress(done, total) called after every FE step; returning
///   False cancels (haptex.CancelledError). Ctrl-C interrupts.
///
/// Returns a haptex.Simulation (x_mm, mu, ft_n, fn_n, history,
/// write_csv). Raises haptex.InvalidInputError for what `haptex simulate`
/// refuses, haptex.ComputationError when the FE run fails.
#[pyfunction]
#[pyo3(signature = (
    surface, *, voltage = None, constant_voltage = None, mu_display = None, eps_sc = None, eps_i = None,
    d_sc_mm = None, d_i_mm = None, x0 = 5.0, width = 1.5, height = 0.3, velocity = 20.0, indent = None,
    load = None, slide = 10.0, step = None, press_time = 0.1, mu_skin = None, material = "viscoelastic",
    kinematics = "small", mesh = "default", finger = None, penalty = 200.0, progress = None
),
    text_signature = "(surface, *, voltage=None, constant_voltage=None, mu_display=None, eps_sc=None, eps_i=None, d_sc_mm=None, d_i_mm=None, x0=5.0, width=1.5, height=0.3, velocity=20.0, indent=None, load=None, slide=10.0, step=None, press_time=0.1, mu_skin=None, material=\"viscoelastic\", kinematics=\"small\", mesh=\"default\", finger=None, penalty=200.0, progress=True)"
)]
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    py: Python<'_>,
    surface: &Bound<'_, PyAny>,
    voltage: Option<&Bound<'_, PyAny>>,
    constant_voltage: Option<f64>,
    mu_display: Option<f64>,
    eps_sc: Option<f64>,
    eps_i: Option<f64>,
    d_sc_mm: Option<f64>,
    d_i_mm: Option<f64>,
    x0: f64,
    width: f64,
    height: f64,
    velocity: f64,
    indent: Option<f64>,
    load: Option<f64>,
    slide: f64,
    step: Option<f64>,
    press_time: f64,
    mu_skin: Option<f64>,
    material: &str,
    kinematics: &str,
    mesh: &str,
    finger: Option<&Bound<'_, PyAny>>,
    penalty: f64,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<Simulation> {
    let (shape, sampled_name, is_display) = surface_arg(surface, x0, width, height)?;
    for (given, a, b) in [
        (voltage.is_some() && constant_voltage.is_some(), "voltage", "constant_voltage"),
        (mu_display.is_some() && mu_skin.is_some(), "mu_display", "mu_skin"),
        (indent.is_some() && load.is_some(), "indent", "load"),
    ] {
        if given {
            return Err(input(format!("{a} and {b} cannot be given together")));
        }
    }
    let constant_voltage = ranged_opt("constant_voltage", ranges::VOLTAGE_V, constant_voltage)?;
    let given_stack = [eps_sc, eps_i, d_sc_mm, d_i_mm].iter().any(Option::is_some);
    let (display, source) = if is_display {
        let (curve, source) = match (voltage, constant_voltage) {
            (Some(v), _) => voltage_arg(v)?,
            (None, Some(u)) => (VoltageCurve::new(vec![0.0, 1.0], vec![u, u]).or_raise()?, String::new()),
            (None, None) => {
                return Err(input(
                    "surface=\"display\" needs voltage= (a design, U.csv or arrays) or constant_voltage=",
                ));
            }
        };
        let stack = stack_of(eps_sc, eps_i, d_sc_mm, d_i_mm)?;
        (Some(Display { voltage: curve, extend: Extend::Hold, stack, vibration: None, air_gap_um: 0.0 }), source)
    } else {
        for (given, name) in [
            (voltage.is_some(), "voltage"),
            (constant_voltage.is_some(), "constant_voltage"),
            (mu_display.is_some(), "mu_display"),
            (given_stack, "eps_sc, eps_i, d_sc_mm and d_i_mm"),
        ] {
            if given {
                return Err(input(format!("{name} applies to surface=\"display\" only")));
            }
        }
        (None, String::new())
    };
    let finger_args = FingerArgs { material, mesh, finger };
    let mut scenario = Scenario::paper(shape.clone());
    scenario.model = finger_args.model()?;
    scenario.resolution = finger_args.resolution()?;
    scenario.viscoelastic = finger_args.viscoelastic()?;
    scenario.kinematics = match choice("kinematics", kinematics, &["small", "finite"])? {
        "small" => Kinematics::Small,
        _ => Kinematics::Finite,
    };
    scenario.loading = match (indent, load) {
        (_, Some(load)) => Loading::Load(positive("load", load)?),
        (Some(indent), None) => Loading::Indent(positive("indent", indent)?),
        (None, None) => Loading::Indent(0.25),
    };
    scenario.press_time_s = positive("press_time", press_time)?;
    scenario.slide_mm = non_negative("slide", slide)?;
    scenario.velocity_mm_s = positive("velocity", velocity)?;
    scenario.step_mm = match step {
        Some(step) => positive("step", step)?,
        None => scenario::default_step_mm(&shape),
    };
    scenario.mu_skin = mu_skin.or(mu_display);
    scenario.penalty_mpa_per_mm = positive("penalty", penalty)?;
    let voltage_source = match (&display, constant_voltage) {
        (Some(_), Some(u)) if voltage.is_none() => Some(VoltageSource::Constant(u)),
        (Some(_), _) => Some(VoltageSource::Profile(&source)),
        _ => None,
    };
    let description = output::describe(&scenario, &output::surface_text(&shape, voltage_source, &sampled_name));
    scenario.display = display;
    // Every setting is checked before anything runs.
    scenario.slide_steps().map_err(|e| raise(simulation_kind(&e), describe(&e)))?;
    let reporter = Reporter::new(py, &progress_or_default(py, progress), "simulate")?;
    scenario.stop = Some(reporter.stop.clone());
    let result = py.detach(|| scenario::run(&scenario, &mut |p| reporter.report(p.step, p.total_steps)));
    let result = reporter.finish(py, result, simulation_error)?;
    Simulation::new(py, result, description)
}

/// `progress=None` is the default: True.
fn progress_or_default<'py>(py: Python<'py>, progress: Option<&Bound<'py, PyAny>>) -> Bound<'py, PyAny> {
    match progress {
        Some(p) => p.clone(),
        None => pyo3::types::PyBool::new(py, true).to_owned().into_any(),
    }
}

// ---------------------------------------------------------------- compensate

/// Eq. (8)'s voltage for a friction profile, compensated on the FE finger
/// until the friction it feels on the display matches the profile
/// (`haptex voltage --compensate`).
///
/// profile: a haptex.Profile, a path to a profile CSV, or (x_mm, mu).
/// relative, flat_mu, mu_hd, eps_sc, eps_i, d_sc_mm, d_i_mm, k_mm2_per_n
///   (mm^2/N), area_exponent (must be 1), fn_n (N), u_max (V RMS): as
///   haptex.voltage (eq. 8 with the paper's Fig. 2 constants by default).
/// load: the finger's normal load, N per mm of width (default 0.0133).
/// max_runs: most FE runs, eq. (8)'s included (1 to 100; each about 0.6
///   s on a 10 mm profile). The finger is visco-elastic, default mesh,
///   0.05 mm steps.
/// progress: True (the default, as None): a tqdm bar when tqdm is
///   installed; False: none; or a
///   callable progress(done, total) in FE steps (total: max_runs runs'
///   worth; the compensation may stop earlier); returning False cancels
///   (haptex.CancelledError). Ctrl-C interrupts.
///
/// Returns a haptex.Design whose first note states the achieved
/// felt-friction RMS error; its write_csv writes the file of `haptex
/// voltage --compensate -o`.
#[pyfunction]
#[pyo3(signature = (
    profile, *, relative = false, flat_mu = None, mu_hd = None, eps_sc = None, eps_i = None, d_sc_mm = None,
    d_i_mm = None, k_mm2_per_n = None, area_exponent = None, fn_n = None, u_max = None, load = None,
    max_runs = 8, progress = None
),
    text_signature = "(profile, *, relative=False, flat_mu=None, mu_hd=None, eps_sc=None, eps_i=None, d_sc_mm=None, d_i_mm=None, k_mm2_per_n=None, area_exponent=None, fn_n=None, u_max=None, load=None, max_runs=8, progress=True)"
)]
#[allow(clippy::too_many_arguments)]
pub fn compensate(
    py: Python<'_>,
    profile: &Bound<'_, PyAny>,
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
    load: Option<f64>,
    max_runs: i64,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<Design> {
    let profile = profile_arg("profile", profile)?;
    let device = DeviceArgs { mu_hd, eps_sc, eps_i, d_sc_mm, d_i_mm, k_mm2_per_n, area_exponent, u_max }
        .device(&ForceModel::Eq3)?;
    if flat_mu.is_some() && !relative {
        return Err(input("flat_mu is the flat-surface friction of relative=True: give relative=True"));
    }
    let flat_mu = ranged_opt("flat_mu", ranges::FLAT_MU, flat_mu)?;
    let fn_n = ranged_opt("fn_n", ranges::FN_N, fn_n)?;
    let load = load.map(|l| positive("load", l)).transpose()?;
    let max_runs = runs("max_runs", max_runs)?;
    let voltage = py
        .detach(|| {
            if relative {
                map_profile_relative(
                    &profile,
                    &device,
                    Method::Physical,
                    fn_n,
                    flat_mu.map_or(FlatMu::Median, FlatMu::Given),
                )
            } else {
                map_profile(&profile, &device, Method::Physical, fn_n)
            }
        })
        .or_raise()?;
    let reporter = Reporter::new(py, &progress_or_default(py, progress), "compensate")?;
    let stop = Some(reporter.stop.clone());
    let result = py.detach(|| {
        let mut counter = RunCounter::default();
        render::compensate_design(voltage, &device, load, max_runs, stop, &mut |_, p| {
            reporter.report_run(&mut counter, max_runs, p)
        })
    });
    let (voltage, comment) = reporter.finish(py, result, render_error)?;
    Design::new(py, Designed::Electrovibration(voltage), vec![comment])
}

/// A number of FE runs, 1 to 100 (the command line's --max-runs).
fn runs(arg: &str, value: i64) -> PyResult<usize> {
    if (1..=100).contains(&value) {
        Ok(value as usize)
    } else {
        Err(input(format!("{arg} must be from 1 to 100 FE runs, got {value}")))
    }
}

// ---------------------------------------------------------------- check

/// The haptex.CheckMetrics (python/haptex/_types.py) of a check.
fn metrics_object<'py>(py: Python<'py>, m: &CheckMetrics) -> PyResult<Bound<'py, PyAny>> {
    let kwargs = PyDict::new(py);
    kwargs.set_item("rms_error", m.rms_error)?;
    kwargs.set_item("max_error", m.max_error)?;
    kwargs.set_item("not_renderable_fraction", m.not_renderable_fraction)?;
    kwargs.set_item("clipped_fraction", m.clipped_fraction)?;
    kwargs.set_item("lag_mm", m.lag_mm)?;
    kwargs.set_item("target_detail_rms", m.target_detail_rms)?;
    kwargs.set_item("detail_retained", m.detail_retained)?;
    kwargs.set_item("k_fe_mm2_per_n", m.k_fe_mm2_per_n)?;
    kwargs.set_item("contact_mm", m.contact_mm)?;
    py.import("haptex._types")?.getattr("CheckMetrics")?.call((), Some(&kwargs))
}

/// The friction the FE finger feels on the display against a target, as
/// `haptex check` reports it: per target position x_mm (mm) the target
/// target_mu, the applied voltage_v (V RMS), the plate's amplitude_um (um
/// peak; None on the electrovibration display), the felt_mu and the
/// finger's k_fe_mm2_per_n (contact length over normal force, mm^2/N;
/// None on the combined display, whose file has no such column); the
/// metrics (a haptex.CheckMetrics), the compensation's trials, and the
/// voltage applied as a haptex.Design (what --voltage-out writes).
#[pyclass(module = "haptex", name = "CheckResult", frozen)]
pub struct CheckResult {
    check: Check,
    /// The report's first line (the file's first comment).
    #[pyo3(get)]
    header: String,
    /// The report's further lines (the file's further comments).
    #[pyo3(get)]
    lines: Vec<String>,
    #[pyo3(get)]
    x_mm: Py<PyArray1<f64>>,
    #[pyo3(get)]
    target_mu: Py<PyArray1<f64>>,
    #[pyo3(get)]
    voltage_v: Py<PyArray1<f64>>,
    #[pyo3(get)]
    amplitude_um: Option<Py<PyArray1<f64>>>,
    #[pyo3(get)]
    felt_mu: Py<PyArray1<f64>>,
    #[pyo3(get)]
    k_fe_mm2_per_n: Option<Py<PyArray1<f64>>>,
    /// How well the felt friction follows the target (a haptex.CheckMetrics).
    #[pyo3(get)]
    metrics: Py<PyAny>,
    /// With compensate=True: every trial's metrics, eq. (8) first; else [].
    #[pyo3(get)]
    trials: Py<PyAny>,
    /// Index in `trials` of the voltage reported (the best trial).
    #[pyo3(get)]
    best: usize,
    /// With fe_k=True: the FE finger's k (mm^2/N) eq. (8) then used.
    #[pyo3(get)]
    fe_k: Option<f64>,
    /// The voltage applied (the compensated one with compensate=True), as
    /// the design `haptex check --voltage-out` writes.
    #[pyo3(get)]
    design: Py<Design>,
}

#[pymethods]
impl CheckResult {
    /// Writes the check as `haptex check -o FILE` does (comments, then
    /// x_mm,target_mu,voltage_v,felt_mu,k_fe_mm2_per_n, or
    /// x_mm,target_mu,voltage_v,amplitude_um,felt_mu on the combined
    /// display), atomically.
    fn write_csv(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        py.detach(|| {
            haptex_core::io::write_atomic(&path, |w| render::write_check_csv(&self.check, &self.header, &self.lines, w))
        })
        .or_raise()
    }

    /// The CSV `write_csv` writes, as a str.
    fn to_csv(&self) -> PyResult<String> {
        let mut bytes = Vec::new();
        render::write_check_csv(&self.check, &self.header, &self.lines, &mut bytes).or_raise()?;
        String::from_utf8(bytes).map_err(|e| input(format!("internal: {e}")))
    }

    /// The report `haptex check` prints on stderr (header and lines).
    fn __str__(&self) -> String {
        std::iter::once(&self.header).chain(&self.lines).map(|l| format!("{l}\n")).collect()
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!(
            "CheckResult({} points, rms_error={})",
            self.check.target.len(),
            self.metrics.bind(py).getattr("rms_error")?.repr()?
        ))
    }
}

/// Checks a friction profile on the FE finger: slides it on the display
/// under eq. (8)'s voltage (or the compensated one) and compares the
/// friction it feels with the target (`haptex check`).
///
/// profile: the target, a haptex.Profile, a path to a profile CSV, or
///   (x_mm, mu).
/// mu_hd: the finger's friction on the display with no voltage (also the
///   FE's skin-display friction; default the finger model's, 0.5). u_max:
///   U_max in V RMS (default 100). k_mm2_per_n: eq. (8)'s contact-area
///   coefficient in mm^2/N (default 200); fe_k=True uses the FE finger's
///   own, measured on a first run. eps_sc, eps_i, d_sc_mm, d_i_mm: the
///   layers (default the paper's Fig. 2).
/// load: normal load, N per mm of width (default 0.0133; with model="3d"
///   in N, default 0.5), or indent: a press of bone and nail in mm.
///   velocity (mm/s), step (mm per FE step, default 0.05), run_up (mm
///   before the profile, 0 to 100), material, mesh, finger: as
///   haptex.simulate.
/// model: "2d" (the plane-strain finger) or "3d" (the 3D fingertip: eq.
///   (3)'s attraction on its real contact area, k reported and, with
///   fe_k, used as a real area over the normal force); direction_deg:
///   with "3d", the slide's direction from the display's x axis (default
///   0, across the finger).
/// compensate=True: correct the voltage run by run, at most max_runs FE
///   runs (1 to 100), until the RMS error is below tolerance (in mu).
/// display: "electrovibration" (eq. 8) or "combined" (voltage and
///   ultrasonic vibration shared by strategy "split", "bias" or
///   "weighted" with weight; ultrasonic_calibration: a CSV path or
///   (amplitude_um, relative_friction); a_max_um in um peak).
/// device: a display's device file (TOML, `haptex calibrate`): mu_HD, the
///   stack, k for the carrier (carrier, carrier_hz: what the design will be
///   played on; default sine 1000 Hz) and U_max come from it (u_max may
///   lower it); a circuit-model file is refused (the FE display applies
///   eq. 3 without its gain).
/// progress: True (the default, as None): a tqdm bar when tqdm is
///   installed; False: none; or a
///   callable progress(done, total) in FE steps (total: the most runs'
///   worth); returning False cancels (haptex.CancelledError). Ctrl-C
///   interrupts.
///
/// Returns a haptex.CheckResult. Each FE run takes about 0.6 s on a 10 mm
/// profile.
#[pyfunction]
#[pyo3(signature = (
    profile, *, mu_hd = None, u_max = None, k_mm2_per_n = None, fe_k = false, eps_sc = None, eps_i = None,
    d_sc_mm = None, d_i_mm = None, load = None, indent = None, velocity = 20.0, step = 0.05, run_up = 1.0,
    material = "viscoelastic", mesh = "default", finger = None, compensate = false, max_runs = 8,
    tolerance = 1e-4, display = "electrovibration", strategy = None, weight = None,
    ultrasonic_calibration = None, a_max_um = None, device = None, carrier = None, carrier_hz = None, progress = None,
    model = "2d", direction_deg = None
),
    text_signature = "(profile, *, mu_hd=None, u_max=None, k_mm2_per_n=None, fe_k=False, eps_sc=None, eps_i=None, d_sc_mm=None, d_i_mm=None, load=None, indent=None, velocity=20.0, step=0.05, run_up=1.0, material=\"viscoelastic\", mesh=\"default\", finger=None, compensate=False, max_runs=8, tolerance=0.0001, display=\"electrovibration\", strategy=None, weight=None, ultrasonic_calibration=None, a_max_um=None, device=None, carrier=None, carrier_hz=None, progress=True, model=\"2d\", direction_deg=None)"
)]
#[allow(clippy::too_many_arguments)]
pub fn check(
    py: Python<'_>,
    profile: &Bound<'_, PyAny>,
    mu_hd: Option<f64>,
    u_max: Option<f64>,
    k_mm2_per_n: Option<f64>,
    fe_k: bool,
    eps_sc: Option<f64>,
    eps_i: Option<f64>,
    d_sc_mm: Option<f64>,
    d_i_mm: Option<f64>,
    load: Option<f64>,
    indent: Option<f64>,
    velocity: f64,
    step: f64,
    run_up: f64,
    material: &str,
    mesh: &str,
    finger: Option<&Bound<'_, PyAny>>,
    compensate: bool,
    max_runs: i64,
    tolerance: f64,
    display: &str,
    strategy: Option<&str>,
    weight: Option<f64>,
    ultrasonic_calibration: Option<&Bound<'_, PyAny>>,
    a_max_um: Option<f64>,
    device: Option<&Bound<'_, PyAny>>,
    carrier: Option<&str>,
    carrier_hz: Option<f64>,
    progress: Option<&Bound<'_, PyAny>>,
    model: &str,
    direction_deg: Option<f64>,
) -> PyResult<CheckResult> {
    let fe_finger = match (model, direction_deg) {
        ("2d", None) => render::FeFinger::Plane,
        ("2d", Some(_)) => return Err(input("direction_deg is for model=\"3d\" (the 2D finger slides along x)")),
        ("3d", direction) => {
            let direction_deg = direction.unwrap_or(0.0);
            if !haptex_fem::solid3d::slide::is_direction(direction_deg) {
                return Err(input(format!(
                    "direction_deg {} must be a finite angle from -360 to 360 degrees",
                    Num(direction_deg)
                )));
            }
            render::FeFinger::Solid { direction_deg }
        }
        (other, _) => return Err(input(format!("model must be \"2d\" or \"3d\", got {other:?}"))),
    };
    let name = match profile.extract::<PathBuf>() {
        Ok(path) => path_text(&path),
        _ if profile.cast::<Profile>().is_ok() => "a haptex.Profile".to_string(),
        _ => "arrays".to_string(),
    };
    let target = profile_arg("profile", profile)?;
    let fingers = FingerArgs { material, mesh, finger };
    let model = fingers.model()?;
    let mu_hd = ranged_opt("mu_hd", ranges::MU_HD, mu_hd)?;
    let u_max = ranged_opt("u_max", ranges::U_MAX_V, u_max)?;
    let k = ranged("k_mm2_per_n", ranges::K_MM2_PER_N, k_mm2_per_n.unwrap_or(ContactArea::PAPER.k_mm2_per_n))?;
    if indent.is_some() && load.is_some() {
        return Err(input("load and indent cannot be given together"));
    }
    let file = device_file(device)?;
    refuse_set_by_file(
        file.as_ref(),
        [mu_hd, eps_sc, eps_i, d_sc_mm, d_i_mm, k_mm2_per_n],
        &[(fe_k, "fe_k"), (ultrasonic_calibration.is_some(), "ultrasonic_calibration")],
    )?;
    // The carrier the design will be played on: the device file's c is
    // measured per carrier (without a file, eq. 3 does not depend on it).
    let carrier = match &file {
        Some(_) => Some(carrier_of(carrier, carrier_hz)?),
        None if carrier.is_some() || carrier_hz.is_some() => {
            return Err(input(
                "carrier and carrier_hz are the carrier a device file's design is played on: give device= with them",
            ));
        }
        None => None,
    };
    let device = match (&file, &carrier) {
        (Some(file), Some(carrier)) => file.check_device(carrier, u_max).or_raise()?,
        _ => Device {
            stack: stack_of(eps_sc, eps_i, d_sc_mm, d_i_mm)?,
            contact: ContactArea { k_mm2_per_n: k, exponent: 1.0 },
            mu_hd: mu_hd.unwrap_or(model.contact.mu_skin),
            u_max_v: u_max.unwrap_or(Device::PAPER.u_max_v),
            force_gain: 1.0,
        },
    };
    let file_path = file.as_ref().map(|f| f.file.path.as_str());
    // The device file (and its SHA-256) first among the check's lines;
    // the design's notes name it and the carrier, as `haptex check
    // --voltage-out` writes them.
    let file_lines: Vec<String> = file.iter().map(|f| f.comment()).collect();
    let design_notes = match (&file, &carrier) {
        (Some(file), Some(carrier)) => file.design_notes(carrier),
        _ => Vec::new(),
    };
    let load = load.map(|l| positive("load", l)).transpose()?;
    let mut settings = RenderSettings::new(device.mu_hd, load.unwrap_or(fe_finger.default_load()));
    settings.finger = fe_finger;
    settings.device = device;
    settings.device.validate().or_raise()?;
    let scenario = &mut settings.scenario;
    scenario.model = model;
    scenario.resolution = fingers.resolution()?;
    scenario.viscoelastic = fingers.viscoelastic()?;
    if let Some(indent) = indent {
        scenario.loading = Loading::Indent(positive("indent", indent)?);
    }
    scenario.velocity_mm_s = positive("velocity", velocity)?;
    scenario.step_mm = positive("step", step)?;
    settings.run_up_mm = run_up;
    let max_runs = runs("max_runs", max_runs)?;
    let tolerance = non_negative("tolerance", tolerance)?;
    render::check_target(&target, &settings).map_err(|e| match e.part {
        render::TargetPart::Positions => input(format!("{name}: {e}")),
        render::TargetPart::Step => input(format!("step {}: {e}", Num(step))),
        render::TargetPart::RunUp => input(format!("run_up {}: {e}", Num(run_up))),
    })?;
    let choice = DisplayChoice { display, strategy, weight, ultrasonic_calibration, a_max_um, file: file.as_ref() };
    let kind = choice.kind()?;
    if kind == "ultrasonic" {
        return Err(input(
            "the check runs an electrovibration or a combined display; for the plate alone give display=\"combined\" \
             (a target below mu_HD is then rendered by the plate only)",
        ));
    }
    if kind == "combined" {
        for (given, name) in [(compensate, "compensate"), (fe_k, "fe_k")] {
            if given {
                return Err(input(format!(
                    "{name} is for the electrovibration display; it is not done for display=\"combined\" yet"
                )));
            }
        }
        let ultrasonic = choice.ultrasonic()?;
        let strategy = choice.strategy()?.expect("a combined display has a strategy");
        let reporter = Reporter::new(py, &progress_or_default(py, progress), "check")?;
        settings.scenario.stop = Some(reporter.stop.clone());
        let result = py.detach(|| {
            render::check_combined(&target, &settings, &ultrasonic, strategy, &mut |p| {
                reporter.report(p.step, p.total_steps)
            })
        });
        let check = reporter.finish(py, result, render_error)?;
        let header = render::combined_header(&name, &settings, &ultrasonic, strategy, file_path);
        let lines = file_lines.into_iter().chain(render::describe_combined_metrics(&check.metrics)).collect();
        let design =
            map_display(&target, &settings.device, Channels::Combined(&ultrasonic, strategy), None, None).or_raise()?;
        if design.voltage_v.as_deref() != Some(&check.voltage_v[..])
            || design.amplitude_um.as_deref() != check.amplitude_um.as_deref()
        {
            return Err(input("internal: the design differs from the one checked"));
        }
        let design = Design::new(py, Designed::Display(design), design_notes)?.with_device_file(file.as_ref());
        return result_object(py, check, header, lines, Vec::new(), 0, None, design);
    }
    choice.refuse_plate_args()?;
    let stopping = compensate.then_some(Stopping { max_runs, tolerance, ..Stopping::default() });
    let reporter = Reporter::new(py, &progress_or_default(py, progress), "check")?;
    settings.scenario.stop = Some(reporter.stop.clone());
    let runs_most = usize::from(fe_k) + if compensate { max_runs } else { 1 };
    let result = py.detach(|| {
        let mut counter = RunCounter::default();
        render::check_electrovibration(&target, settings, fe_k, stopping, &mut |_, p| {
            reporter.report_run(&mut counter, runs_most, p)
        })
    });
    let run = reporter.finish(py, result, render_error)?;
    let header = render::check_header(&name, &run, file_path);
    let m = run.check.metrics;
    let voltage = map_profile(&run.check.target, &run.settings.device, Method::Physical, None)
        .and_then(|v| v.with_voltages(run.check.voltage_v.clone()))
        .or_raise()?;
    let notes = std::iter::once(render::voltage_comment(&header, &m)).chain(design_notes).collect();
    let design = Design::new(py, Designed::Electrovibration(voltage), notes)?.with_device_file(file.as_ref());
    let lines = file_lines.into_iter().chain(run.lines).collect();
    result_object(py, run.check, header, lines, run.trials, run.best, run.fe_k_mm2_per_n, design)
}

#[allow(clippy::too_many_arguments)]
fn result_object(
    py: Python<'_>,
    check: Check,
    header: String,
    lines: Vec<String>,
    trials: Vec<CheckMetrics>,
    best: usize,
    fe_k: Option<f64>,
    design: Design,
) -> PyResult<CheckResult> {
    let trials: Vec<Bound<'_, PyAny>> = trials.iter().map(|t| metrics_object(py, t)).collect::<PyResult<_>>()?;
    let combined = check.amplitude_um.is_some();
    Ok(CheckResult {
        header,
        lines,
        x_mm: array(py, check.target.x_mm().to_vec()),
        target_mu: array(py, check.target.mu().to_vec()),
        voltage_v: array(py, check.voltage_v.clone()),
        amplitude_um: check.amplitude_um.clone().map(|a| array(py, a)),
        felt_mu: array(py, check.felt.mu.clone()),
        k_fe_mm2_per_n: (!combined).then(|| array(py, check.felt.k_mm2_per_n.clone())),
        metrics: metrics_object(py, &check.metrics)?.unbind(),
        trials: pyo3::types::PyList::new(py, trials)?.into_any().unbind(),
        best,
        fe_k,
        design: Py::new(py, design)?,
        check,
    })
}
