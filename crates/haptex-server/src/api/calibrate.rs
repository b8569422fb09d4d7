//! `POST /api/calibrate`: measurements made on the user's own display ->
//! its constants with their 95% intervals, the identifiability verdicts,
//! the data and fitted curves with their bands, and the device file
//! (`haptex calibrate`, docs/calibration.md; the core's
//! [`haptex_core::calibration`]).
//!
//! Two bodies:
//!
//! - `text/csv`: the measurements file as is, the options in the query
//!   string (`?u_max_v=100&ultrasonic_model=auto&eps_sc=1650&name=my.csv`);
//! - `application/json`: `{"measurements": "<the CSV's text>", "name":
//!   "my.csv", "u_max_v": 100, "stack": {"eps_sc": 1650, ...},
//!   "ultrasonic_model": "auto"}`.
//!
//! Every error in the measurements names the field `measurements`, the
//! line and the column (`line`, `column`), and the message says them in
//! the file's name as given. The fit runs in a heavy slot (its cost is
//! linear in the rows; the core bounds the carriers it fits, each a
//! parameter). The answer's `device_file` is the TOML text `haptex
//! calibrate -o` writes, present when the measurements identify any
//! constant.

use axum::Json;
use axum::response::{IntoResponse, Response};
use haptex_core::calibration::device_file::DeviceFile;
use haptex_core::calibration::force_fit::{carrier_name, equivalent_k_mm2_per_n};
use haptex_core::calibration::measurements::{Measurements, MeasurementsError};
use haptex_core::calibration::ultrasonic_fit::Choice;
use haptex_core::calibration::{Estimate, Goodness, Outlier, Settings, calibrate, curves};
use haptex_core::electrovibration::{Device, LayerStack};
use serde::Deserialize;
use serde_json::{Value, json};

use crate::error::{ApiError, quote};
use crate::extract::{Preamble, Rest, Route, Work};
use crate::input::{BodyKind, parse_json, parse_number};
use crate::params::{check_range, spec};

/// The field of the measurements (JSON) and the name errors use when none
/// is given.
const FIELD: &str = "measurements";
/// Longest file name accepted.
const MAX_NAME_BYTES: usize = 256;

/// The JSON body.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CalibrateBody {
    /// The measurements CSV's text.
    measurements: String,
    /// The file's name, for messages and the device file.
    #[serde(default)]
    name: Option<String>,
    /// U_max in V RMS (stated, not measured; written into the device file).
    #[serde(default)]
    u_max_v: Option<f64>,
    /// The layer stack assumed (`eps_sc`, `eps_i`, `d_sc_mm`, `d_i_mm`).
    #[serde(default)]
    stack: crate::input::Pairs,
    /// `auto`, `exponential` or `table`.
    #[serde(default)]
    ultrasonic_model: Option<String>,
}

/// The options, from either body.
struct Options {
    name: String,
    u_max_v: f64,
    settings: Settings,
}

const STACK: [&str; 4] = ["eps_sc", "eps_i", "d_sc_mm", "d_i_mm"];

fn options(
    name: Option<String>,
    u_max_v: Option<f64>,
    stack: &[(String, f64)],
    model: Option<&str>,
    prefix: &str,
) -> Result<Options, ApiError> {
    let name = match name {
        Some(n) if n.trim().is_empty() || n.len() > MAX_NAME_BYTES || n.chars().any(char::is_control) => {
            return Err(ApiError::bad_request(
                format!("a file name of 1 to {MAX_NAME_BYTES} bytes without control characters"),
                Some("name"),
            ));
        }
        Some(n) => n,
        None => FIELD.to_string(),
    };
    let spec_of = |n: &str| spec(n).ok_or_else(|| ApiError::internal(format!("{n} is not a device parameter")));
    let u_max_v = match u_max_v {
        Some(u) => check_range(spec_of("u_max_v")?, u, "u_max_v")?,
        None => Device::PAPER.u_max_v,
    };
    let mut s = LayerStack::PAPER;
    let mut seen = [false; 4];
    for (key, value) in stack {
        let field = format!("{prefix}{key}");
        let Some(i) = STACK.iter().position(|k| k == key) else {
            return Err(ApiError::bad_request(
                format!("unknown layer parameter (known: {})", STACK.join(", ")),
                Some(&field),
            ));
        };
        if std::mem::replace(&mut seen[i], true) {
            return Err(ApiError::bad_request(format!("{key} is given twice"), Some(&field)));
        }
        let v = check_range(spec_of(key)?, *value, &field)?;
        match i {
            0 => s.eps_sc = v,
            1 => s.eps_i = v,
            2 => s.d_sc_mm = v,
            _ => s.d_i_mm = v,
        }
    }
    s.validate().map_err(|e| ApiError::bad_request(e.to_string(), Some(prefix.trim_end_matches('.'))))?;
    let ultrasonic = match model.unwrap_or("auto") {
        "auto" => Choice::Auto,
        "exponential" => Choice::Exponential,
        "table" => Choice::Table,
        other => {
            return Err(ApiError::bad_request(
                format!("unknown model {}: use auto, exponential or table", quote(other)),
                Some("ultrasonic_model"),
            ));
        }
    };
    Ok(Options { name, u_max_v, settings: Settings { stack: s, ultrasonic } })
}

/// The route: a measurements CSV with its options in the query (which the
/// handler reads), or a JSON body and no query; heavy work.
pub(crate) struct Calibrate;

impl Route for Calibrate {
    const BODY: &'static [BodyKind] = &[BodyKind::Csv, BodyKind::Json];
    const REST: Rest = Rest::Handler;
    const WORK: Work = Work::Heavy;
}

pub async fn post(call: Preamble<Calibrate>) -> Result<Response, ApiError> {
    let Preamble { mut query, kind, bytes, slot, .. } = call;
    slot.run(move || {
        let (text, options) = match kind {
            BodyKind::Json => {
                query.finish()?;
                let body: CalibrateBody = parse_json(&bytes)?;
                let options =
                    options(body.name, body.u_max_v, &body.stack.0, body.ultrasonic_model.as_deref(), "stack.")?;
                (body.measurements.into_bytes(), options)
            }
            BodyKind::Csv => {
                let name = query.take("name");
                let u_max_v = query.take("u_max_v").map(|t| parse_number(&t, "u_max_v")).transpose()?;
                let model = query.take("ultrasonic_model");
                let mut stack = Vec::new();
                for key in STACK {
                    if let Some(t) = query.take(key) {
                        stack.push((key.to_string(), parse_number(&t, key)?));
                    }
                }
                query.finish()?;
                (bytes.to_vec(), options(name, u_max_v, &stack, model.as_deref(), "")?)
            }
        };
        let answer = fit(&text, &options)?;
        Ok(Json(answer).into_response())
    })
    .await
}

/// Reads the measurements, fits them and builds the answer.
fn fit(text: &[u8], options: &Options) -> Result<Value, ApiError> {
    let m = Measurements::from_bytes(text, &options.name).map_err(measurements_error)?;
    let cal = calibrate(&m, options.settings);
    if cal.force.is_none() && cal.ultrasonic.is_none() {
        return Err(ApiError::bad_request(
            format!(
                "{}: no row has a voltage or a vibration: the friction at rest alone calibrates nothing",
                options.name
            ),
            Some(FIELD),
        ));
    }
    let file = DeviceFile::from_calibration(&cal, &m, options.u_max_v);
    let identified = file.electrovibration.is_some() || file.ultrasonic.is_some();
    let stack = &cal.settings.stack;
    let force = cal.force.as_ref().map(|f| {
        let g = &f.eq3.goodness;
        json!({
            "eq3": {
                "mu_hd": estimate(&f.eq3.mu_hd),
                "carriers": f.eq3.carriers.iter().map(|c| json!({
                    "carrier": c.carrier,
                    "name": carrier_name(&c.carrier),
                    "c_per_v2": estimate(&c.c_per_v2),
                    "k_mm2_per_n": finite(equivalent_k_mm2_per_n(c.c_per_v2.value, stack)),
                    "rows": c.rows,
                    "max_voltage_v": c.max_voltage_v,
                })).collect::<Vec<_>>(),
                "goodness": goodness(g),
                "outliers": outliers(&f.eq3.outliers),
            },
            "circuit": f.circuit.as_ref().map(|c| json!({
                "mu_hd": estimate(&c.mu_hd),
                "c_per_v2": estimate(&c.c_per_v2),
                "k_mm2_per_n": finite(equivalent_k_mm2_per_n(c.c_per_v2.value, stack)),
                "rho_sc_ohm_m": estimate(&c.rho_sc_ohm_m),
                "gap_um": estimate(&c.gap_um),
                "corner_hz": finite(c.corner_hz),
                "goodness": goodness(&c.goodness),
                "outliers": outliers(&c.outliers),
            })),
            "curves": curves::force(&cal, &m).map(|c| json!({
                "model": c.model,
                "carriers": c.carriers.iter().map(|k| json!({
                    "carrier": k.carrier,
                    "name": k.name,
                    "data": { "u_v": k.data_u_v, "rise": finite_all(&k.data_rise), "line": k.data_lines },
                    "model": band(&k.grid_u_v, &k.rise, "u_v", "rise"),
                    "residuals": { "fitted": finite_all(&k.fitted), "residual": finite_all(&k.residual),
                        "line": k.residual_lines },
                })).collect::<Vec<_>>(),
            })),
        })
    });
    let ultrasonic = cal.ultrasonic.as_ref().map(|u| {
        let c = curves::ultrasonic(&cal, &m);
        json!({
            "exponential": u.exponential.as_ref().map(|e| json!({
                "rho_inf": estimate(&e.rho_inf),
                "a_c_um": estimate(&e.a_c_um),
                "goodness": goodness(&e.goodness),
                "outliers": outliers(&e.outliers),
            })),
            "table": u.table.iter().map(|p| json!({
                "amplitude_um": p.amplitude_um, "rho": finite(p.rho),
                "low": finite(p.interval[0]), "high": finite(p.interval[1]),
            })).collect::<Vec<_>>(),
            "chosen": if u.chosen == Choice::Exponential { "exponential" } else { "table" },
            "a_max_um": u.a_max_um,
            "rho_min": estimate(&u.rho_min),
            "curves": c.map(|c| json!({
                "data": { "amplitude_um": c.data_amplitude_um, "rho": finite_all(&c.data_rho), "line": c.data_lines },
                "table": { "amplitude_um": c.table_amplitude_um, "rho": finite_all(&c.table_rho) },
                "exponential": c.exponential.as_ref().map(|e| band(&c.grid_amplitude_um, e, "amplitude_um", "rho")),
            })),
        })
    });
    let cluster = cal
        .force
        .as_ref()
        .map(|f| &f.eq3.goodness)
        .or(cal.ultrasonic.as_ref().and_then(|u| u.exponential.as_ref().map(|e| &e.goodness)))
        .and_then(|g| g.cluster_level.map(|l| l.describe(g.clusters)));
    Ok(json!({
        "measurements": { "file": m.source_name(), "sha256": m.sha256(), "rows": m.rows().len() },
        "stack": stack,
        "u_max_v": options.u_max_v,
        "intervals_rest_on": cluster,
        "electrovibration": force,
        "ultrasonic": ultrasonic,
        "verdicts": cal.verdicts,
        "device_model": file.electrovibration.as_ref().map(|e| e.model.as_str()),
        "device_file": identified.then(|| file.to_toml()),
        "identified": identified,
    }))
}

/// A measurements error: 400 naming `measurements`, the line and the column.
fn measurements_error(e: MeasurementsError) -> ApiError {
    match e {
        MeasurementsError::Table(t) => {
            let (line, column) = (t.line, t.column.clone());
            ApiError::bad_request(t.to_string(), Some(FIELD)).with_line(line).with_column(column)
        }
        other => ApiError::bad_request(other.to_string(), Some(FIELD)),
    }
}

/// A number, or null when not finite (an unidentified constant's interval).
fn finite(v: f64) -> Value {
    if v.is_finite() { json!(v) } else { Value::Null }
}

fn finite_all(v: &[f64]) -> Vec<Value> {
    v.iter().map(|&x| finite(x)).collect()
}

fn estimate(e: &Estimate) -> Value {
    json!({ "value": finite(e.value), "low": finite(e.interval[0]), "high": finite(e.interval[1]),
        "identified": e.identified })
}

fn goodness(g: &Goodness) -> Value {
    json!({
        "rows": g.rows, "rms": finite(g.rms), "scale": finite(g.scale), "r2": finite(g.r2),
        "clusters": g.clusters, "converged": g.converged,
        "lack_of_fit": g.lack_of_fit.map(|l| json!({ "f": finite(l.f), "df1": l.df1, "df2": l.df2, "p": finite(l.p) })),
    })
}

fn outliers(o: &[Outlier]) -> Vec<Value> {
    o.iter()
        .map(|o| {
            json!({ "line": o.line, "measured": finite(o.measured), "fitted": finite(o.fitted),
                "weight": finite(o.weight) })
        })
        .collect()
}

/// A model curve with its 95% band: `{x: [..], y: [..], low: [..], high: [..]}`.
fn band(x: &[f64], values: &[[f64; 3]], x_name: &str, y_name: &str) -> Value {
    let column = |k: usize| values.iter().map(|b| finite(b[k])).collect::<Vec<_>>();
    let mut out = serde_json::Map::new();
    out.insert(x_name.into(), json!(x));
    out.insert(y_name.into(), json!(column(0)));
    out.insert("low".into(), json!(column(1)));
    out.insert("high".into(), json!(column(2)));
    Value::Object(out)
}
