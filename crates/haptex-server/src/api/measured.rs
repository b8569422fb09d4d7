//! `POST /api/compensate/measured`: the next design of a display from
//! strokes measured on it, by iterative learning control (`haptex
//! compensate`, docs/measured-compensation.md; the core's
//! [`haptex_core::ilc`], the same functions). (`POST /api/compensate`
//! corrects a design on the FE finger instead.)
//!
//! JSON body:
//!
//! ```text
//! {"design": "<the design CSV's text: x_mm,mu,voltage_v[,amplitude_um], with its # ilc iteration lines>",
//!  "strokes": [{"name": "s1.csv", "csv": "x_mm,ft_n,fn_n\n..."}, ...],   (two or more)
//!  "device": {"mu_hd": 0.5, ...} | "device_file": "<TOML>", "carrier": {...},
//!  "display": "combined", "strategy": ..., "a_max_um": ..., "ultrasonic_calibration": ...,
//!  "gain": 1, "q_sigma_mm": 0.05, "max_iterations": 10}
//! ```
//!
//! The answer: the next design's CSV text (`design_csv`, with the history
//! lines; give it back as `design` next time), the history, the strokes'
//! mean with its standard error, the drives played and next, and what
//! limits the design. No sample of the next design is above U_max or
//! a_max ([`haptex_core::ilc::check_limits`], run before the answer).
//! Errors name the field: `design` or `strokes[i]` (with the line, the
//! column and the stroke's file name), the device's fields, `gain` ...

use axum::Json;
use axum::response::{IntoResponse, Response};
use haptex_core::ilc::{self, Design, DisplayModel, IlcError, Kept, Settings, Stroke};
use haptex_core::io::{Table, TableError};
use haptex_core::num::Num;
use haptex_core::profile::{FrictionProfile, ProfileError};
use haptex_core::signal::Carrier;
use serde::Deserialize;
use serde_json::{Value, json};

use crate::display::{DisplayName, DisplayRequest, StrategyName};
use crate::error::ApiError;
use crate::extract::{Preamble, Route};
use crate::input::{BodyKind, Pairs, check_points, parse_json};

/// Most strokes in one request.
pub const MAX_STROKES: usize = 100;
/// Most iterations a history may be kept to (as `--max-iterations`).
const MAX_ITERATIONS: usize = 1000;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StrokeJson {
    /// The stroke's file name, for messages.
    #[serde(default)]
    name: Option<String>,
    /// The CSV's text: `x_mm,ft_n,fn_n` or `x_mm,mu`.
    csv: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MeasuredBody {
    design: String,
    strokes: Vec<StrokeJson>,
    #[serde(default)]
    device: Pairs,
    #[serde(default)]
    device_file: Option<String>,
    #[serde(default)]
    carrier: Option<Carrier>,
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
    #[serde(default)]
    gain: Option<f64>,
    #[serde(default)]
    q_sigma_mm: Option<f64>,
    #[serde(default)]
    max_iterations: Option<usize>,
}

/// The route: a JSON body, no query.
pub(crate) struct Measured;

impl Route for Measured {
    const BODY: &'static [BodyKind] = &[BodyKind::Json];
}

pub async fn post(call: Preamble<Measured>) -> Result<Response, ApiError> {
    let Preamble { state, bytes, slot, .. } = call;
    let max_points = state.limits().max_points;
    slot.run(move || {
        let body: MeasuredBody = parse_json(&bytes)?;
        Ok(Json(iterate(body, max_points)?).into_response())
    })
    .await
}

fn iterate(body: MeasuredBody, max_points: usize) -> Result<Value, ApiError> {
    let (request, device_file) =
        crate::device_file::resolve(&body.device, body.device_file.as_deref(), body.carrier, "device.")?;
    let display = DisplayRequest {
        display: body.display,
        strategy: body.strategy,
        weight: body.weight,
        a_max_um: body.a_max_um,
        ultrasonic_calibration: body.ultrasonic_calibration,
    };
    let mut designed = display.design()?;
    if let Some(d) = designed.as_mut() {
        crate::device_file::use_plate(device_file.as_ref(), &display, d)?;
    }
    let model = match &designed {
        None => DisplayModel::Electrovibration(request.device),
        Some(d) => match d.strategy {
            Some(strategy) => DisplayModel::Combined { device: request.device, ultrasonic: &d.ultrasonic, strategy },
            None => {
                return Err(ApiError::bad_request(
                    "the measured compensation iterates an electrovibration or a combined display's design; for the \
                     plate alone give display combined",
                    Some("display"),
                ));
            }
        },
    };
    let gain = match body.gain {
        Some(g) if !(g > 0.0 && g <= 1.0) => {
            return Err(ApiError::bad_request(
                format!("the learning gain must be in (0, 1], got {}", Num(g)),
                Some("gain"),
            ));
        }
        g => g.unwrap_or(1.0),
    };
    if let Some(q) = body.q_sigma_mm
        && !(q.is_finite() && q > 0.0 && q <= 1e3)
    {
        return Err(ApiError::bad_request(
            format!("the Q-filter's width must be from above 0 to 1000 mm, got {}", Num(q)),
            Some("q_sigma_mm"),
        ));
    }
    let max_iterations = body.max_iterations.unwrap_or(10);
    if !(1..=MAX_ITERATIONS).contains(&max_iterations) {
        return Err(ApiError::bad_request(
            format!("max_iterations must be from 1 to {MAX_ITERATIONS}"),
            Some("max_iterations"),
        ));
    }
    let table = Table::read(body.design.as_bytes(), "design").map_err(|e| table_error(e, "design", None))?;
    check_points(table.n_rows(), max_points, "design")?;
    let design = Design::from_table(&table, &model).map_err(|e| ilc_error(e, &[]))?;
    if body.strokes.len() > MAX_STROKES {
        return Err(ApiError::too_large(
            format!("{} strokes: more than the limit of {MAX_STROKES}", body.strokes.len()),
            Some("strokes"),
        ));
    }
    let names: Vec<String> = body
        .strokes
        .iter()
        .enumerate()
        .map(|(i, s)| s.name.clone().unwrap_or_else(|| format!("stroke {}", i + 1)))
        .collect();
    let mut strokes = Vec::with_capacity(body.strokes.len());
    for (i, s) in body.strokes.iter().enumerate() {
        let field = format!("strokes[{i}]");
        let table = Table::read(s.csv.as_bytes(), &names[i]).map_err(|e| table_error(e, &field, Some(&names[i])))?;
        check_points(table.n_rows(), max_points, &field)?;
        let profile = FrictionProfile::from_table(&table).map_err(|e| match e {
            ProfileError::Table(t) => table_error(t, &field, Some(&names[i])),
            other => {
                ApiError::bad_request(format!("{}: {other}", names[i]), Some(&field)).with_file(Some(names[i].clone()))
            }
        })?;
        strokes.push(Stroke { name: names[i].clone(), profile });
    }
    let settings = Settings { gain, q_sigma_mm: body.q_sigma_mm, max_iterations };
    let step = ilc::iterate(&design, &model, &strokes, &settings).map_err(|e| ilc_error(e, &names))?;
    let mut history = design.history.clone();
    history.push(step.entry);
    let csv = ilc::next_design_csv(&design, &step, &history, &model).map_err(|e| ilc_error(e, &names))?;
    let design_csv = String::from_utf8(csv).map_err(|_| ApiError::internal("the design CSV is not UTF-8"))?;
    let se2 = |sign: f64| -> Vec<f64> {
        step.mean.mu.iter().zip(&step.mean.standard_error).map(|(m, se)| m + sign * 2.0 * se).collect()
    };
    let e = &step.entry;
    Ok(json!({
        "design_csv": design_csv,
        "history": history.iter().map(|h| json!({
            "iteration": h.iteration, "rms_error": h.rms_error, "noise_floor": h.noise_floor,
            "max_error": h.max_error, "lag_mm": h.lag_mm, "plant_gain": h.plant_gain, "strokes": h.strokes,
            "limited_by": h.limited_by.name(),
        })).collect::<Vec<_>>(),
        "report_csv": ilc::report_csv(&history),
        "iteration": e.iteration,
        "kept": step.kept.map(|k| match k { Kept::AtNoiseFloor => "at_noise_floor", Kept::IterationLimit => "iteration_limit" }),
        "limited_by": e.limited_by.name(),
        "x_mm": design.target.x_mm(),
        "target": design.target.mu(),
        "mean": step.mean.mu,
        "standard_error": step.mean.standard_error,
        "mean_minus_2se": se2(-1.0),
        "mean_plus_2se": se2(1.0),
        "voltage_played_v": design.drive.voltage_v,
        "voltage_next_v": step.next.voltage_v,
        "amplitude_played_um": design.drive.amplitude_um,
        "amplitude_next_um": step.next.amplitude_um,
        "band": step.band,
        "not_renderable_fraction": step.not_renderable_fraction,
        "saturated_fraction": step.saturated_fraction,
        "q_sigma_mm": step.q_sigma_mm,
        "u_max_v": model.device().u_max_v,
        "a_max_um": model.a_max_um(),
        "mu_hd": model.device().mu_hd,
        "warnings": step.warnings,
        "device_file": device_file.as_ref().map(|f| f.provenance()),
    }))
}

/// A CSV error of `field` (the design, a stroke): the line and column,
/// and the stroke's file name.
fn table_error(e: TableError, field: &str, file: Option<&str>) -> ApiError {
    let (line, column) = (e.line, e.column.clone());
    ApiError::bad_request(e.to_string(), Some(field))
        .with_line(line)
        .with_column(column)
        .with_file(file.map(String::from))
}

/// An iteration's error, naming the design or the stroke at fault.
fn ilc_error(e: IlcError, names: &[String]) -> ApiError {
    match e {
        IlcError::Table(t) => table_error(t, "design", None),
        IlcError::Profile(ProfileError::Table(t)) => table_error(t, "design", None),
        IlcError::TooFewStrokes { .. } => ApiError::bad_request(e.to_string(), Some("strokes")),
        IlcError::NotCovered { ref name, .. } => {
            let i = names.iter().position(|n| n == name).unwrap_or(0);
            ApiError::bad_request(e.to_string(), Some(&format!("strokes[{i}]"))).with_file(Some(name.clone()))
        }
        IlcError::History { .. } => ApiError::bad_request(e.to_string(), Some("design")),
        IlcError::AboveLimit { .. } => ApiError::internal(e.to_string()),
        IlcError::Profile(_) => ApiError::bad_request(e.to_string(), Some("design")),
        other => ApiError::bad_request(other.to_string(), None),
    }
}
