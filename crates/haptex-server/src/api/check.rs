//! `POST /api/check` and `POST /api/compensate`: a friction profile checked
//! on the finger model (issue 15, `haptex check`): eq. (8)'s voltage U(x)
//! applied to the FE finger sliding on the display, the friction it feels
//! against the target, and (`/api/compensate`) U(x) corrected run by run
//! until the finger feels the target ([`haptex_fem::render`]).
//!
//! Body (JSON): the body of `POST /api/voltage` (`profile`, `device`,
//! `relative`, `flat_mu`; `method` may only be `physical`: eq. (9) has no
//! force to check), and the finger's settings:
//!
//! - `load_n_per_mm` ([`LOAD_N_PER_MM`], default 0.0133): the normal load
//!   the finger presses with, per mm of finger width (load control: a user
//!   presses with a force);
//! - `velocity_mm_s` ([`CHECK_VELOCITY_MM_S`], default 20);
//! - `step_mm` ([`STEP_MM`]): the slide per FE step, where the voltage is
//!   sampled; default 0.05 mm, or the finest multiple of 0.005 mm that
//!   keeps the request within [`crate::Limits::max_check_steps`], and at
//!   most the profile's length (the answer says which);
//! - `model` (`2d`, the default, or `3d`): the 2D plane-strain finger or
//!   the 3D fingertip (`haptex check --model 3d`: eq. (3)'s attraction on
//!   its real contact area, forces in N, `k_fe_mm2_per_n` a real area over
//!   the normal force). The 3D finger takes `load_n` ([`LOAD_3D_N`], default
//!   0.5 N) instead of `load_n_per_mm`, `direction_deg` ([`DIRECTION_DEG`],
//!   default 0: across the finger, as the 2D finger slides) and `mesh`
//!   (`coarse` or `default`, the default); its runs are bounded by
//!   [`crate::Limits::max_check_steps_3d`]. Each finger's fields given to
//!   the other are refused (400 naming the field);
//! - `/api/compensate` only: `max_runs` (1 ..= [`MAX_RUNS`], default 8,
//!   eq. (8)'s run included) and `tolerance` ([`TOLERANCE`], default 1e-4
//!   in mu).
//!
//! `display` `combined` (with `strategy`, `weight`, `a_max_um` and
//! `ultrasonic_calibration`, as `POST /api/voltage` takes them; `POST
//! /api/check` only, `haptex check --display combined`) checks the
//! combined display's design instead of eq. (8)'s: the target allocated to
//! (U(x), a(x)), the finger sliding on the plate vibrating with a(x) under
//! U(x) ([`render::check_combined`]). The result's `design` then holds
//! the trial (`voltage_v`, `amplitude_um`, `felt_mu`, `metrics` over the
//! combined display's band) and `eq8` is null; `voltage` is the design as
//! `POST /api/voltage` answers it for that display and `voltage_csv` its
//! `x_mm,mu,voltage_v,amplitude_um` file. The compensation iterates eq.
//! (8)'s voltage: it is the electrovibration display's.
//!
//! The target is the profile as the voltage mapping sees it: relative to
//! its flat-surface friction when `relative` is true (the answer's
//! `target_mu`). The finger is the shipped model (visco-elastic tissue,
//! 1 mm run-up before the profile; the 2D finger on the default mesh),
//! mu_HD is its skin-display friction.
//!
//! # Bounds
//!
//! What the FE check needs of the profile is checked before the answer
//! starts, by the check's own rule ([`render::check_target`], which
//! `haptex check` applies too): positions at least
//! [`render::MIN_SPACING_MM`] apart (closer ones become one when the
//! profile is placed on the FE slide), a profile at least one slide step
//! long; 400 naming `profile.x_mm` (or `step_mm`, when given).
//!
//! Every size the request controls is bounded before any FE run: at most
//! [`crate::Limits::max_check_points`] points (the metrics cost up to n^2
//! per run), at most [`crate::Limits::max_check_steps`] FE slide steps over
//! all runs (runs x (span + 1 mm) / step_mm: the time the FE slot is
//! held, about 1.5 ms per step on one core), at most [`MAX_RUNS`] runs.
//! Forces and voltages outside physical limits are refused naming their
//! field: the load outside [`LOAD_N_PER_MM`] (a finger pressing with 0.015
//! to 0.75 N over a 15 mm wide pad), a U_max whose attraction at contact
//! exceeds the finger model's limit ([`MAX_PRESSURE_MPA`], 3.2 kV RMS with
//! the paper's layers), a contact-area law other than eq. (8)'s linear one
//! (`area_exponent` 1). Every voltage a trial applies is within 0 ..=
//! U_max (the compensation clips each), and the voltage offered for
//! download and playback is put into eq. (8)'s mapped profile with
//! [`VoltageProfile::with_voltages`], which refuses any sample outside
//! 0 ..= U_max, the same U_max its file and its summary state.
//!
//! # Answer: a stream of JSON lines
//!
//! The answer is `application/x-ndjson` ([`crate::lines`]): after the body
//! is checked (4xx otherwise) and an FE slot is free (shared with `POST
//! /api/simulate`, at most [`crate::Limits::concurrent_simulations`] at
//! once, a wait of up to [`crate::Limits::simulation_wait`], then 503),
//! progress lines `{"progress": {"run", "max_runs", "step", "steps",
//! "x_mm"}}` while the FE model runs, then `{"result": {...}}`, or
//! `{"error", "field", "status": 422}` when the FE model cannot run the
//! case (its own message, e.g. the skin touching the display outside the
//! finger model's contact region). A stream rather than a job to poll:
//! the server keeps no state between requests, the 4xx and 503 of every
//! other route apply unchanged, a client that goes away leaves nothing
//! behind, and the GUI reads the progress as it comes.
//!
//! The result: `settings` (the finger's, defaults filled in), `parameters`
//! (the device's, as `POST /api/voltage` gives them), `x_mm`, `target_mu`,
//! `eq8` (`voltage_v`, `felt_mu`, `metrics`: the first run), `compensated`
//! (`/api/compensate`: the best trial, `trial` its 1-based number; else
//! null), `trials` (each run's `metrics`), `fe_runs`, `stopped` (why the
//! compensation stopped: `reason` one of `tolerance`, `stalled`,
//! `max_runs`, and `message` as `haptex check --compensate` says it; null
//! for a check), `fe_seconds`, and
//! the voltage offered: `voltage` (as `POST /api/voltage` answers it, with
//! its summary and U_max) and `voltage_csv` (that profile as the
//! `x_mm,mu,voltage_v` file `haptex check --voltage-out` writes, the
//! achieved error in its first comment).

use std::panic::AssertUnwindSafe;
use std::time::Instant;

use axum::http::StatusCode;
use axum::response::Response;
use haptex_core::electrovibration::{Method, VoltageProfile};
use haptex_core::num::Num;
use haptex_core::profile::FrictionProfile;
use haptex_fem::contact::Electrostatic;
use haptex_fem::display::MAX_PRESSURE_MPA;
use haptex_fem::finger::Resolution;
use haptex_fem::render::{
    self, Check, DEFAULT_LOAD_N_PER_MM, FeFinger, RenderError, RenderSettings, Stopping, TargetError, TargetPart,
};
use haptex_fem::scenario::Progress;
use serde::Deserialize;
use serde_json::{Value, json};

use crate::display::{DisplayDesign, DisplayName, DisplayRequest, StrategyName};
use crate::error::ApiError;
use crate::extract::{Preamble, Route};
use crate::fields::{self, CHECK_VELOCITY_MM_S, DIRECTION_DEG, LOAD_3D_N, LOAD_N_PER_MM, MAX_RUNS, STEP_MM, TOLERANCE};
use crate::input::{BodyKind, Pairs, ProfileJson, check_points, parse_json};
use crate::lines::{self, Lines};
use crate::params::DeviceRequest;
use crate::work;

/// The default step, mm (`haptex check`'s).
pub const DEFAULT_STEP_MM: f64 = 0.05;
/// The default sliding velocity, mm/s (the paper's FE runs').
pub const DEFAULT_VELOCITY_MM_S: f64 = 20.0;
/// The compensation's default tolerance, in mu ([`Stopping::default`]'s).
pub const DEFAULT_TOLERANCE: f64 = 1e-4;
/// The grid of automatic steps, mm.
const STEP_GRID_MM: f64 = 0.005;
/// Slide before the profile's first position, mm.
const RUN_UP_MM: f64 = 1.0;

/// Which FE finger: `model` in a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
enum ModelName {
    /// The 2D plane-strain finger (forces per mm of width).
    #[default]
    #[serde(rename = "2d")]
    TwoD,
    /// The 3D fingertip (forces in N, a real contact area).
    #[serde(rename = "3d")]
    ThreeD,
}

/// The 3D fingertip's mesh: `mesh` in a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum MeshName {
    Coarse,
    Default,
}

impl MeshName {
    fn resolution(self) -> Resolution {
        match self {
            Self::Coarse => Resolution::Coarse,
            Self::Default => Resolution::Default,
        }
    }
}

/// Which route.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// `POST /api/check`: eq. (8)'s voltage, one FE run.
    Check,
    /// `POST /api/compensate`: the compensation.
    Compensate,
}

/// The JSON body.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CheckBody {
    profile: ProfileJson,
    #[serde(default)]
    method: Option<Method>,
    #[serde(default)]
    device: Pairs,
    #[serde(default)]
    relative: bool,
    #[serde(default)]
    flat_mu: Option<f64>,
    #[serde(default)]
    load_n_per_mm: Option<f64>,
    #[serde(default)]
    model: ModelName,
    #[serde(default)]
    load_n: Option<f64>,
    #[serde(default)]
    direction_deg: Option<f64>,
    #[serde(default)]
    mesh: Option<MeshName>,
    #[serde(default)]
    velocity_mm_s: Option<f64>,
    #[serde(default)]
    step_mm: Option<f64>,
    #[serde(default)]
    max_runs: Option<u32>,
    #[serde(default)]
    tolerance: Option<f64>,
    #[serde(default)]
    display: Option<DisplayName>,
    #[serde(default)]
    strategy: Option<StrategyName>,
    #[serde(default)]
    weight: Option<f64>,
    #[serde(default)]
    a_max_um: Option<f64>,
    #[serde(default)]
    ultrasonic_calibration: Option<String>,
}

/// The routes: a JSON body, no query.
pub(crate) struct Checked;

impl Route for Checked {
    const BODY: &'static [BodyKind] = &[BodyKind::Json];
}

pub async fn check(call: Preamble<Checked>) -> Result<Response, ApiError> {
    start(Mode::Check, call).await
}

pub async fn compensate(call: Preamble<Checked>) -> Result<Response, ApiError> {
    start(Mode::Compensate, call).await
}

/// Checks the body, takes an FE slot and starts the work, whose lines
/// the answer streams.
async fn start(mode: Mode, call: Preamble<Checked>) -> Result<Response, ApiError> {
    let Preamble { state, bytes, slot, .. } = call;
    let limits = state.limits().clone();
    let base = state.default_device().device;
    let job = slot.run(move || Job::parse(mode, &bytes, &limits, &base)).await?;
    let permit = work::fe_slot(&state).await?;
    let heavy = work::heavy_slot(&state).await?;
    let (mut lines, response) = lines::stream();
    work::spawn_long(move || {
        let result = std::panic::catch_unwind(AssertUnwindSafe(|| job.run(&mut lines)))
            .unwrap_or_else(|panic| Err(crate::error::panicked(&*panic)));
        lines.finish(result);
        // The slot is free before the stream ends: a client that has read
        // the whole answer can send the next request at once.
        drop((permit, heavy));
        drop(lines);
        crate::memory::freed_large();
    });
    Ok(response)
}

/// A checked request: everything the FE runs need.
struct Job {
    mode: Mode,
    request: DeviceRequest,
    /// Eq. (8) on the profile as mapped (relative when asked): the
    /// profile the voltage offered is put into.
    mapped: VoltageProfile,
    target: FrictionProfile,
    settings: RenderSettings,
    stopping: Stopping,
    /// The combined display's plate and strategy (`display` combined).
    combined: Option<(DisplayDesign, haptex_core::combined::Strategy)>,
}

impl Job {
    /// Parses and checks the body: every field in its range, the work
    /// within the limits.
    fn parse(
        mode: Mode,
        bytes: &[u8],
        limits: &crate::Limits,
        base: &haptex_core::electrovibration::Device,
    ) -> Result<Self, ApiError> {
        let body: CheckBody = parse_json(bytes)?;
        if body.method.is_some_and(|m| m != Method::Physical) {
            return Err(ApiError::bad_request(
                "the check applies eq. (8) (method physical): eq. (9)'s voltage renders the pattern only, with no \
                 friction force to compare",
                Some("method"),
            ));
        }
        let request = DeviceRequest::from_pairs_over(body.device.iter(), "device.", base)?;
        let device = &request.device;
        if !device.contact.is_linear() {
            return Err(ApiError::bad_request(
                format!(
                    "the check applies eq. (8) with the paper's linear contact-area law A = k Fn (area_exponent 1), \
                     got area_exponent {}",
                    Num(device.contact.exponent)
                ),
                Some("device.area_exponent"),
            ));
        }
        let pressure_mpa = Electrostatic::new(&device.stack, device.u_max_v).pressure_mpa;
        if pressure_mpa.is_nan() || pressure_mpa > MAX_PRESSURE_MPA {
            return Err(ApiError::bad_request(
                format!(
                    "U_max = {} V attracts the skin with {:.3} MPa at contact through these layers (eq. 3): more \
                     than the {} MPa the finger model is for (ten times its stiffest tissue's modulus)",
                    Num(device.u_max_v),
                    pressure_mpa,
                    Num(MAX_PRESSURE_MPA)
                ),
                Some("device.u_max_v"),
            ));
        }
        let (finger, load, resolution) = finger_of(&body)?;
        let display = DisplayRequest {
            display: body.display,
            strategy: body.strategy,
            weight: body.weight,
            a_max_um: body.a_max_um,
            ultrasonic_calibration: body.ultrasonic_calibration,
        };
        let combined = match display.design()? {
            None => None,
            Some(_) if mode == Mode::Compensate => {
                return Err(ApiError::bad_request(
                    "the compensation iterates eq. (8)'s voltage: it is the electrovibration display's (POST \
                     /api/check checks a combined display's design)",
                    Some("display"),
                ));
            }
            Some(design) => match design.strategy {
                Some(strategy) => Some((design, strategy)),
                None => {
                    return Err(ApiError::bad_request(
                        "the check on the finger model is for the electrovibration and combined displays: an \
                         ultrasonic plate alone is the combined display with U = 0 V where the target is below \
                         mu_HD (display combined)",
                        Some("display"),
                    ));
                }
            },
        };
        let relative = super::voltage::relative_request(body.relative, body.flat_mu)?;
        let velocity =
            fields::check(CHECK_VELOCITY_MM_S, body.velocity_mm_s.unwrap_or(DEFAULT_VELOCITY_MM_S), "velocity_mm_s")?;
        let step = body.step_mm.map(|s| fields::check(STEP_MM, s, "step_mm")).transpose()?;
        let stopping = match mode {
            Mode::Check => {
                for (given, name) in [(body.max_runs.is_some(), "max_runs"), (body.tolerance.is_some(), "tolerance")] {
                    if given {
                        return Err(ApiError::bad_request(
                            format!("{name} is a setting of the compensation: use POST /api/compensate"),
                            Some(name),
                        ));
                    }
                }
                Stopping { max_runs: 1, ..Stopping::default() }
            }
            Mode::Compensate => {
                let max_runs = body.max_runs.unwrap_or(MAX_RUNS);
                if !(1..=MAX_RUNS).contains(&max_runs) {
                    return Err(ApiError::bad_request(
                        format!("max_runs must be from 1 to {MAX_RUNS} FE runs, got {max_runs}"),
                        Some("max_runs"),
                    ));
                }
                let tolerance = fields::check(TOLERANCE, body.tolerance.unwrap_or(DEFAULT_TOLERANCE), "tolerance")?;
                Stopping { max_runs: max_runs as usize, tolerance, ..Stopping::default() }
            }
        };
        let profile = body.profile.into_profile("profile.", limits.max_points)?;
        check_points(profile.len(), limits.max_check_points, "profile.x_mm")?;
        let mapped = super::voltage::compute(&profile, Method::Physical, &request, relative, "device.")?;
        let target = FrictionProfile::new(mapped.x_mm.clone(), mapped.mu.clone())
            .map_err(|e| ApiError::internal(format!("the mapped profile is invalid: {e}")))?;
        let budget = match finger {
            FeFinger::Plane => limits.max_check_steps,
            FeFinger::Solid { .. } => limits.max_check_steps_3d,
        };
        let step_mm = slide_step(target.span_mm(), stopping.max_runs, step, budget)?;
        let mut settings = RenderSettings::new(device.mu_hd, load);
        settings.finger = finger;
        settings.scenario.resolution = resolution;
        settings.device = *device;
        settings.scenario.velocity_mm_s = velocity;
        settings.scenario.step_mm = step_mm;
        settings.run_up_mm = RUN_UP_MM;
        if target.span_mm() < STEP_MM.min {
            return Err(ApiError::bad_request(
                format!(
                    "the friction profile is {} mm long: the check on the finger model needs at least {} mm, its \
                     finest slide step",
                    Num(target.span_mm()),
                    Num(STEP_MM.min)
                ),
                Some("profile.x_mm"),
            ));
        }
        // What the FE check needs of the profile (its spacing, its span
        // against the step, the slide), as `haptex check` checks it.
        render::check_target(&target, &settings).map_err(|e| target_error(e, step.is_some()))?;
        Ok(Self { mode, request, mapped, target, settings, stopping, combined })
    }

    /// Runs the FE model (once, or as the compensation needs), reporting
    /// its progress to `lines`, and builds the result.
    fn run(self, lines: &mut Lines) -> Result<Value, ApiError> {
        let started = Instant::now();
        let max_runs = self.stopping.max_runs;
        let start_mm = self.target.x_mm()[0] - self.settings.run_up_mm;
        let mut report = |run: usize, p: Progress| {
            lines.progress(run, || {
                json!({
                    "run": run + 1, "max_runs": max_runs, "step": p.step, "steps": p.total_steps,
                    "x_mm": start_mm + p.slide_mm,
                })
            })
        };
        let (trials, best, stop) = match (self.mode, &self.combined) {
            (Mode::Check, Some((design, strategy))) => {
                let check =
                    render::check_combined(&self.target, &self.settings, &design.ultrasonic, *strategy, &mut |p| {
                        report(0, p)
                    })
                    .map_err(fe_error)?;
                (vec![check], 0, None)
            }
            (Mode::Check, None) => {
                (vec![render::check(&self.target, &self.settings, &mut |p| report(0, p)).map_err(fe_error)?], 0, None)
            }
            (Mode::Compensate, _) => {
                let c =
                    render::compensate(&self.target, &self.settings, self.stopping, &mut report).map_err(fe_error)?;
                (c.trials, c.best, Some(c.stop))
            }
        };
        let fe_seconds = started.elapsed().as_secs_f64();
        match &self.combined {
            Some((design, _)) => self.answer_combined(&trials[0], design, fe_seconds),
            None => self.answer(&trials, best, stop, fe_seconds),
        }
    }

    /// The result of the trials (eq. 8's first, `best` the one offered;
    /// `stop` why a compensation stopped).
    fn answer(
        &self,
        trials: &[Check],
        best: usize,
        stop: Option<render::CompensationStop>,
        fe_seconds: f64,
    ) -> Result<Value, ApiError> {
        let offered = &trials[best];
        // The voltage offered goes into eq. (8)'s mapped profile, which
        // refuses any sample outside 0 ..= U_max (its file states U_max).
        let voltage = self
            .mapped
            .clone()
            .with_voltages(offered.voltage_v.clone())
            .map_err(|e| ApiError::internal(format!("the voltage offered is outside the device's limits: {e}")))?;
        trials.iter().try_for_each(finite)?;
        let label = match self.mode {
            Mode::Check => "eq. (8)".to_string(),
            Mode::Compensate => format!("compensated (trial {} of {} FE runs)", best + 1, trials.len()),
        };
        let comment = format!(
            "# haptex check on the finger model: {}; voltage {label}; felt-friction RMS error {:.3e} over the \
             renderable region (eq. 8: {:.3e})",
            self.finger_comment(),
            offered.metrics.rms_error,
            trials[0].metrics.rms_error
        );
        let csv = commented_csv(&comment, |w| voltage.write_csv(w))?;
        let trial = |t: &Check| json!({ "voltage_v": t.voltage_v, "felt_mu": t.felt.mu, "metrics": t.metrics });
        let compensated = match self.mode {
            Mode::Check => Value::Null,
            Mode::Compensate => {
                let mut value = trial(offered);
                value["trial"] = json!(best + 1);
                value
            }
        };
        let stopped = match stop {
            Some(stop) => json!({
                "reason": match stop {
                    render::CompensationStop::Tolerance => "tolerance",
                    render::CompensationStop::Stalled => "stalled",
                    render::CompensationStop::MaxRuns => "max_runs",
                },
                "message": stop.describe(&self.stopping),
            }),
            None => Value::Null,
        };
        let mut settings = self.settings_json();
        if self.mode == Mode::Compensate {
            settings["max_runs"] = json!(self.stopping.max_runs);
            settings["tolerance"] = json!(self.stopping.tolerance);
        }
        let voltage_json = serde_json::to_value(super::voltage::VoltageAnswer::new(self.request.values(), &voltage))
            .map_err(|e| ApiError::internal(format!("cannot serialize the voltage: {e}")))?;
        Ok(json!({
            "settings": settings,
            "parameters": self.request.values(),
            "x_mm": self.target.x_mm(),
            "target_mu": self.target.mu(),
            "eq8": trial(&trials[0]),
            "compensated": compensated,
            "trials": trials.iter().enumerate().map(|(i, t)| json!({ "trial": i + 1, "metrics": t.metrics })).collect::<Vec<_>>(),
            "fe_runs": trials.len(),
            "stopped": stopped,
            "fe_seconds": fe_seconds,
            "voltage": voltage_json,
            "voltage_csv": csv,
        }))
    }
}

impl Job {
    /// The settings of the answer (the finger's, defaults filled in).
    fn settings_json(&self) -> Value {
        let s = &self.settings;
        let mut settings = json!({
            "velocity_mm_s": s.scenario.velocity_mm_s,
            "step_mm": s.scenario.step_mm,
            "run_up_mm": s.run_up_mm,
            "loading": "load",
            "mesh": s.scenario.resolution.name(),
            "tissue": "viscoelastic",
            "mu_hd": s.device.mu_hd,
        });
        // The finger's own fields: its model, its load in its unit, the 3D
        // fingertip's direction.
        match s.finger {
            FeFinger::Plane => {
                settings["model"] = json!("2d");
                settings["load_n_per_mm"] = json!(load_of(s));
            }
            FeFinger::Solid { direction_deg } => {
                settings["model"] = json!("3d");
                settings["load_n"] = json!(load_of(s));
                settings["direction_deg"] = json!(direction_deg);
            }
        }
        settings
    }

    /// The finger of the drive file's first comment: "visco-elastic FE
    /// finger, default mesh, load 0.0133 N/mm, 20 mm/s, step 0.05 mm".
    fn finger_comment(&self) -> String {
        let s = &self.settings;
        format!(
            "visco-elastic {}, {} mesh, load {}, {} mm/s, step {} mm",
            render::finger_text(s.finger),
            s.scenario.resolution.name(),
            render::loading_text(s.scenario.loading, s.finger),
            Num(s.scenario.velocity_mm_s),
            Num(s.scenario.step_mm)
        )
    }

    /// The result of a combined display's check: the design applied (as
    /// `POST /api/voltage` designs it for the target with this display:
    /// the same allocation, checked equal), what the finger felt, the
    /// metrics over the band.
    fn answer_combined(&self, check: &Check, design: &DisplayDesign, fe_seconds: f64) -> Result<Value, ApiError> {
        // The target as it is (already relative when asked), with no Fn:
        // the design render::check_combined applied.
        let request = crate::params::DeviceRequest { device: self.request.device, fn_n: None };
        let designed = super::voltage::compute_display(&self.target, &request, None, design, "device.")?;
        if designed.voltage_v.as_ref() != Some(&check.voltage_v) || designed.amplitude_um != check.amplitude_um {
            return Err(ApiError::internal("the combined design offered differs from the one the finger felt (a bug)"));
        }
        finite(check)?;
        let m = &check.metrics;
        let answer = super::voltage::DisplayAnswer::new(&request, design, &designed);
        let strategy = match design.strategy {
            Some(haptex_core::combined::Strategy::Split) => "split",
            Some(haptex_core::combined::Strategy::Bias) => "bias",
            Some(haptex_core::combined::Strategy::Weighted { .. }) => "weighted",
            None => "none",
        };
        let comment = format!(
            "# haptex check on the finger model: {}; combined display ({strategy}); felt-friction RMS error {:.3e} \
             over the combined display's band",
            self.finger_comment(),
            m.rms_error
        );
        let csv = commented_csv(&comment, |w| designed.write_csv(w))?;
        let mut settings = self.settings_json();
        settings["display"] = json!("combined");
        settings["strategy"] = json!(strategy);
        let voltage_json = serde_json::to_value(&answer)
            .map_err(|e| ApiError::internal(format!("cannot serialize the design: {e}")))?;
        Ok(json!({
            "settings": settings,
            "parameters": answer.parameters,
            "x_mm": self.target.x_mm(),
            "target_mu": self.target.mu(),
            "eq8": Value::Null,
            "design": {
                "voltage_v": check.voltage_v,
                "amplitude_um": check.amplitude_um,
                "felt_mu": check.felt.mu,
                "metrics": check.metrics,
            },
            "compensated": Value::Null,
            "trials": [json!({ "trial": 1, "metrics": check.metrics })],
            "fe_runs": 1,
            "stopped": Value::Null,
            "fe_seconds": fe_seconds,
            "voltage": voltage_json,
            "voltage_csv": csv,
        }))
    }
}

/// A check's numbers are finite (its voltage and felt friction, every
/// error figure); a non-finite one for accepted input is a bug (500).
fn finite(check: &Check) -> Result<(), ApiError> {
    let m = &check.metrics;
    let finite =
        check.felt.mu.iter().chain(&check.voltage_v).chain(check.amplitude_um.iter().flatten()).all(|v| v.is_finite())
            && [m.rms_error, m.max_error, m.lag_mm, m.k_fe_mm2_per_n, m.contact_mm, m.target_detail_rms]
                .iter()
                .chain(&m.detail_retained)
                .all(|v| v.is_finite());
    if finite {
        Ok(())
    } else {
        Err(ApiError::internal("the check gave a non-finite number for accepted input (a bug)"))
    }
}

/// The text of a drive file offered: `comment` (one `#` line), then what
/// `write` writes.
fn commented_csv(
    comment: &str,
    write: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
) -> Result<String, ApiError> {
    let csv = super::to_csv(|w| {
        writeln!(w, "{comment}")?;
        write(w)
    })?;
    String::from_utf8(csv).map_err(|e| ApiError::internal(format!("the drive CSV is not UTF-8: {e}")))
}

/// The finger of the request (`model`, with `direction_deg` and `mesh`
/// for the 3D fingertip), its normal load (`load_n_per_mm` in 2D, `load_n`
/// in 3D, each in its range) and its mesh; 400 naming a field the other
/// finger's.
fn finger_of(body: &CheckBody) -> Result<(FeFinger, f64, Resolution), ApiError> {
    let refuse = |field: &str, why: &str| Err(ApiError::bad_request(format!("{field} {why}"), Some(field)));
    match body.model {
        ModelName::TwoD => {
            for (given, field) in [
                (body.load_n.is_some(), "load_n"),
                (body.direction_deg.is_some(), "direction_deg"),
                (body.mesh.is_some(), "mesh"),
            ] {
                if given {
                    return refuse(
                        field,
                        "is a setting of the 3D fingertip (model 3d); the 2D finger (model 2d, the default) runs on \
                         the default mesh, slides along x and takes its load as load_n_per_mm",
                    );
                }
            }
            let load =
                fields::check(LOAD_N_PER_MM, body.load_n_per_mm.unwrap_or(DEFAULT_LOAD_N_PER_MM), "load_n_per_mm")?;
            Ok((FeFinger::Plane, load, Resolution::Default))
        }
        ModelName::ThreeD => {
            if body.load_n_per_mm.is_some() {
                return refuse(
                    "load_n_per_mm",
                    "is the 2D finger's load, per mm of width; the 3D fingertip (model 3d) presses with load_n, in N",
                );
            }
            let finger = FeFinger::Solid {
                direction_deg: fields::check(DIRECTION_DEG, body.direction_deg.unwrap_or(0.0), "direction_deg")?,
            };
            let load = fields::check(LOAD_3D_N, body.load_n.unwrap_or(finger.default_load()), "load_n")?;
            Ok((finger, load, body.mesh.unwrap_or(MeshName::Default).resolution()))
        }
    }
}

/// The load of the settings (N/mm; they are built with load control).
fn load_of(settings: &RenderSettings) -> f64 {
    match settings.scenario.loading {
        haptex_fem::scenario::Loading::Load(f) => f,
        haptex_fem::scenario::Loading::Indent(_) => f64::NAN,
    }
}

/// A target the FE check cannot run, naming the request's field: the
/// profile's positions, or the step when one was given (an automatic
/// step is chosen from the profile, so the profile is at fault then).
fn target_error(error: TargetError, step_given: bool) -> ApiError {
    let field = match error.part {
        TargetPart::Step if step_given => "step_mm",
        TargetPart::Positions | TargetPart::Step => "profile.x_mm",
        TargetPart::RunUp => return ApiError::internal(format!("the check's run-up is invalid (a bug): {error}")),
    };
    ApiError::bad_request(error.message, Some(field))
}

/// An error of the FE runs: the FE model could not run the case (422,
/// its message), or a bug (the request was checked before).
fn fe_error(error: RenderError) -> ApiError {
    match error {
        RenderError::Simulation(e) => {
            ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, format!("the finger model cannot run this case: {e}"), None)
        }
        other => ApiError::internal(format!("the check failed on checked input (a bug): {other}")),
    }
}

/// The slide step: `given` (checked against its range), or the default
/// step, or the finest multiple of [`STEP_GRID_MM`] above it, that keeps
/// `runs` FE runs over `span_mm` (after the run-up) within `budget` slide
/// steps; 413 when none does.
fn slide_step(span_mm: f64, runs: usize, given: Option<f64>, budget: usize) -> Result<f64, ApiError> {
    let slide = span_mm + RUN_UP_MM;
    let steps = |step: f64| runs as f64 * (slide / step).ceil();
    let too_long = || {
        ApiError::too_large(
            format!(
                "a profile {} mm long: {runs} FE run(s) over it take more than the {budget} slide steps a request may \
                 take even in steps of {} mm; check a part of it at most {} mm long",
                Num(span_mm),
                Num(STEP_MM.max),
                Num((budget / runs) as f64 * STEP_MM.max - RUN_UP_MM)
            ),
            Some("profile.x_mm"),
        )
    };
    if steps(STEP_MM.max) > budget as f64 {
        return Err(too_long());
    }
    if let Some(step) = given {
        if steps(step) > budget as f64 {
            return Err(ApiError::too_large(
                format!(
                    "{runs} FE run(s) over {} mm (the profile and a {} mm run-up) in steps of {} mm take {} slide \
                     steps, more than the {budget} a request may take: give a step_mm of at least {} mm, or fewer \
                     runs",
                    Num(slide),
                    Num(RUN_UP_MM),
                    Num(step),
                    Num(steps(step)),
                    Num((runs as f64 * slide / budget as f64 / STEP_GRID_MM).ceil() * STEP_GRID_MM)
                ),
                Some("step_mm"),
            ));
        }
        return Ok(step);
    }
    let first = (DEFAULT_STEP_MM / STEP_GRID_MM).round() as u32;
    let last = (STEP_MM.max / STEP_GRID_MM).round() as u32;
    let step = (first..=last)
        .map(|k| f64::from(k) * STEP_GRID_MM)
        .find(|&step| steps(step) <= budget as f64)
        .ok_or_else(too_long)?;
    // A profile shorter than that step: the longest grid step within it
    // (the finger feels the voltage at its steps), at least the finest.
    let mut within = (span_mm / STEP_GRID_MM).floor().max(1.0);
    while within > 1.0 && within * STEP_GRID_MM > span_mm {
        within -= 1.0;
    }
    let step = step.min(within * STEP_GRID_MM);
    if steps(step) > budget as f64 {
        return Err(too_long());
    }
    Ok(step)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_libraries() {
        assert_eq!(DEFAULT_TOLERANCE, Stopping::default().tolerance);
        assert_eq!(MAX_RUNS as usize, Stopping::default().max_runs);
    }

    /// The step: the default where it fits, else the finest grid step that
    /// fits, the given one when it fits; 413 naming the step or the profile.
    #[test]
    fn slide_step_keeps_the_request_within_its_step_budget() {
        // A 10 mm template profile: 0.05 mm, 220 steps a run.
        assert_eq!(slide_step(10.0, 8, None, 4000).unwrap(), 0.05);
        // A 49 mm library stroke, 8 runs: 8 * 50 / 4000 = 0.1 mm.
        assert_eq!(slide_step(49.0, 8, None, 4000).unwrap(), 0.1);
        let step = slide_step(50.0, 8, None, 4000).unwrap();
        assert!((step - 0.105).abs() < 1e-12 && 8.0 * (51.0 / step).ceil() <= 4000.0, "{step}");
        assert_eq!(slide_step(10.0, 1, Some(0.01), 4000).unwrap(), 0.01);
        let e = slide_step(50.0, 8, Some(0.05), 4000).unwrap_err();
        assert_eq!((e.status, e.field.as_deref()), (StatusCode::PAYLOAD_TOO_LARGE, Some("step_mm")), "{e}");
        assert!(e.message.contains("at least 0.105 mm"), "{e}");
        let e = slide_step(300.0, 8, Some(0.1), 4000).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("profile.x_mm"), "{e}");
        let e = slide_step(300.0, 8, None, 4000).unwrap_err();
        assert_eq!((e.status, e.field.as_deref()), (StatusCode::PAYLOAD_TOO_LARGE, Some("profile.x_mm")), "{e}");
        assert!(e.message.contains("at most 249 mm"), "{e}");
        assert_eq!(slide_step(249.0, 8, None, 4000).unwrap(), 0.5);
        // A profile shorter than the default step: the longest grid step
        // within it, at least the finest.
        assert_eq!(slide_step(0.03, 1, None, 4000).unwrap(), 0.03);
        assert_eq!(slide_step(0.0349, 8, None, 4000).unwrap(), 0.03);
        assert_eq!(slide_step(0.007, 8, None, 4000).unwrap(), 0.005);
        assert_eq!(slide_step(0.001, 1, None, 4000).unwrap(), 0.005);
    }
}
