//! The surface templates the server predicts (paper sections 3.1-3.2): the
//! FE database of bump, edge and sine loaded once at start (metadata and
//! one [`TemplateModel`] per template), and the ranges of their parameters
//! that the API accepts and the GUI offers.
//!
//! Three ranges per parameter:
//!
//! - `database`: the range the FE sweep covers; inside it the CAE
//!   interpolates between FE profiles;
//! - `accepted`: what a request may ask for, a factor [`REACH`] beyond the
//!   database range on either side. Between `database` and `accepted` the
//!   estimate extrapolates and the answer carries a warning; outside
//!   `accepted` the request is refused (400): so far out the kernel average
//!   is only the nearest corner of the database, not a prediction;
//! - `slider`: the GUI's slider, the database range widened by a quarter of
//!   its span on each side (within `accepted`), so that a user sees the
//!   extrapolation flag appear;
//! - `simulate`: what `POST /api/simulate` runs the FE model for, from the
//!   database's smallest value (features the mesh resolves, the range whose
//!   corners the FE robustness tests cover) to the slider's end.
//!
//! The set also holds the database's FE settings ([`DatabaseSpec`]), so
//! that a single case can be simulated on demand exactly as the database's
//! runs were (same finger model, mesh, material, press and slide).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use haptex_core::database::{DatabaseError, Metadata, Template, TemplateModel};
use haptex_fem::sweep::DatabaseSpec;
use serde::{Deserialize, Serialize};

use haptex_core::num::Num;

use crate::error::{ApiError, quote};
use crate::input::parse_json;

/// How far beyond the database range a request may go: a factor 4 below
/// the smallest and above the largest value of each parameter.
pub const REACH: f64 = 4.0;

/// Largest |x0| accepted (mm).
pub const MAX_ABS_X0_MM: f64 = 1000.0;

/// The default query the GUI starts with (the example: a bump of
/// width 1.3 mm and height 0.27 mm at x0 = 5 mm, at 20 mm/s).
pub const DEFAULT_X0_MM: f64 = 5.0;
pub const DEFAULT_WIDTH_MM: f64 = 1.3;
pub const DEFAULT_HEIGHT_MM: f64 = 0.27;
pub const DEFAULT_VELOCITY_MM_S: f64 = 20.0;

/// The loaded database.
#[derive(Debug)]
pub struct TemplateSet {
    dir: PathBuf,
    metadata: Metadata,
    models: Vec<TemplateModel>,
    /// The database's FE settings, or why this haptex cannot simulate with
    /// them (a database built with another finger model or FE settings).
    fe: Result<Arc<DatabaseSpec>, String>,
}

/// One parameter's ranges (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ParameterRange {
    pub name: &'static str,
    pub unit: &'static str,
    pub label: &'static str,
    pub default: f64,
    pub database: [f64; 2],
    pub accepted: [f64; 2],
    pub slider: [f64; 2],
    pub step: f64,
    pub simulate: [f64; 2],
}

impl ParameterRange {
    fn new(name: &'static str, unit: &'static str, label: &'static str, default: f64, database: (f64, f64)) -> Self {
        let (lo, hi) = database;
        let accepted = [lo / REACH, hi * REACH];
        let quarter = 0.25 * (hi - lo);
        let (s0, s1) = ((lo - quarter).max(accepted[0]), (hi + quarter).min(accepted[1]));
        // At most 200 slider positions, the step 1, 2 or 5 times a power of
        // ten and the ends on multiples of it (so that round values such as
        // the default are slider positions).
        let raw = (s1 - s0) / 200.0;
        let decade = 10f64.powf(raw.log10().floor());
        let step = [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * decade).find(|s| *s >= raw).unwrap_or(raw);
        let tidy = |v: f64| (v * 1e9).round() / 1e9;
        let slider = [tidy((s0 / step).ceil() * step), tidy((s1 / step).floor() * step)];
        let step = tidy(step);
        let simulate = [lo, slider[1]];
        Self { name, unit, label, default, database: [lo, hi], accepted, slider, step, simulate }
    }

    /// Whether `value` is within the database range.
    pub fn in_database(&self, value: f64) -> bool {
        value >= self.database[0] && value <= self.database[1]
    }

    /// Whether `POST /api/simulate` runs the FE model for `value`.
    pub fn simulates(&self, value: f64) -> bool {
        value.is_finite() && value >= self.simulate[0] && value <= self.simulate[1]
    }

    /// Whether a request may ask for `value`.
    pub fn accepts(&self, value: f64) -> bool {
        value.is_finite() && value >= self.accepted[0] && value <= self.accepted[1]
    }
}

impl TemplateSet {
    /// Loads the database in `dir` (its `metadata.json` and every
    /// template it lists).
    pub fn load(dir: &Path) -> Result<Self, DatabaseError> {
        let metadata = Metadata::read(dir)?;
        let models = metadata
            .templates
            .iter()
            .map(|entry| TemplateModel::load_with(dir, &metadata, entry.template))
            .collect::<Result<Vec<_>, _>>()?;
        if models.is_empty() {
            return Err(DatabaseError::File {
                path: dir.join("metadata.json"),
                message: "the database lists no template".into(),
            });
        }
        let fe = DatabaseSpec::from_metadata(&metadata).map(Arc::new).map_err(|e| e.to_string());
        Ok(Self { dir: dir.to_path_buf(), metadata, models, fe })
    }

    /// The database's FE settings, or why FE simulation is not available.
    pub fn fe(&self) -> Result<&Arc<DatabaseSpec>, &str> {
        self.fe.as_ref().map_err(String::as_str)
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    pub fn metadata(&self) -> &Metadata {
        &self.metadata
    }

    /// The templates served, in the database's order.
    pub fn templates(&self) -> impl Iterator<Item = Template> + '_ {
        self.models.iter().map(|m| m.template)
    }

    pub fn model(&self, template: Template) -> Option<&TemplateModel> {
        self.models.iter().find(|m| m.template == template)
    }

    /// The ranges of width, height and velocity for `model` (in the
    /// database's input order: r_w, r_h, velocity).
    pub fn ranges(model: &TemplateModel) -> [ParameterRange; 3] {
        let [w, h, v] = model.input_ranges();
        let (width, height) = model.template.parameter_meaning();
        [
            ParameterRange::new("width_mm", "mm", width, DEFAULT_WIDTH_MM, w),
            ParameterRange::new("height_mm", "mm", height, DEFAULT_HEIGHT_MM, h),
            ParameterRange::new("velocity_mm_s", "mm/s", "sliding velocity", DEFAULT_VELOCITY_MM_S, v),
        ]
    }
}

/// The JSON body of `POST /api/predict` and `POST /api/simulate`; every
/// field optional here so that a missing one is refused naming it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TemplateBody {
    #[serde(default)]
    surface: Option<String>,
    #[serde(default)]
    x0_mm: Option<f64>,
    #[serde(default)]
    width_mm: Option<f64>,
    #[serde(default)]
    height_mm: Option<f64>,
    #[serde(default)]
    velocity_mm_s: Option<f64>,
}

/// A checked request for a template surface's profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TemplateQuery {
    pub template: Template,
    pub x0_mm: f64,
    /// r_w, r_h (mm) and velocity (mm/s), the database's input order.
    pub query: [f64; 3],
}

impl TemplateQuery {
    /// Parses and checks a JSON body against the templates of `set`: the
    /// surface must be one of them, x0 within +-[`MAX_ABS_X0_MM`], each
    /// parameter within its accepted range; errors name the field.
    pub fn parse(bytes: &[u8], set: &TemplateSet) -> Result<Self, ApiError> {
        let body: TemplateBody = parse_json(bytes)?;
        let required = |value: Option<f64>, field: &str| {
            value.ok_or_else(|| ApiError::bad_request(format!("{field} is required"), Some(field)))
        };
        let surface = body.surface.ok_or_else(|| ApiError::bad_request("surface is required", Some("surface")))?;
        let (width, height) = (required(body.width_mm, "width_mm")?, required(body.height_mm, "height_mm")?);
        let model = Template::parse(&surface).and_then(|t| set.model(t)).ok_or_else(|| {
            let names: Vec<&str> = set.templates().map(Template::name).collect();
            ApiError::bad_request(
                format!("unknown surface {}: this server has {}", quote(&surface), names.join(", ")),
                Some("surface"),
            )
        })?;
        let x0_mm = body.x0_mm.unwrap_or(DEFAULT_X0_MM);
        if !(x0_mm.is_finite() && x0_mm.abs() <= MAX_ABS_X0_MM) {
            return Err(ApiError::bad_request(
                format!("x0_mm = {} mm: give a position from {} to {MAX_ABS_X0_MM} mm", Num(x0_mm), -MAX_ABS_X0_MM),
                Some("x0_mm"),
            ));
        }
        let query = [width, height, body.velocity_mm_s.unwrap_or(DEFAULT_VELOCITY_MM_S)];
        for (range, value) in TemplateSet::ranges(model).iter().zip(query) {
            if !range.accepts(value) {
                return Err(ApiError::bad_request(
                    format!(
                        "{} = {} {} is out of range: this server accepts {} .. {} {} (the FE database covers \
                         {} .. {} {}; beyond a factor {REACH} of it an estimate would be meaningless)",
                        range.name,
                        Num(value),
                        range.unit,
                        Num(range.accepted[0]),
                        Num(range.accepted[1]),
                        range.unit,
                        Num(range.database[0]),
                        Num(range.database[1]),
                        range.unit,
                    ),
                    Some(range.name),
                ));
            }
        }
        Ok(Self { template: model.template, x0_mm, query })
    }

    /// The surface height h(x) (mm) at each of `x_mm`.
    pub fn heights(&self, x_mm: &[f64]) -> Vec<f64> {
        x_mm.iter().map(|&x| self.template.height_mm(x, self.x0_mm, self.query[0], self.query[1])).collect()
    }

    /// The parameters as JSON (`x0_mm`, `width_mm`, `height_mm`,
    /// `velocity_mm_s`).
    pub fn parameters_json(&self) -> serde_json::Value {
        serde_json::json!({
            "x0_mm": self.x0_mm,
            "width_mm": self.query[0],
            "height_mm": self.query[1],
            "velocity_mm_s": self.query[2],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_widen_the_database_range() {
        let r = ParameterRange::new("width_mm", "mm", "w", 1.3, (0.5, 2.5));
        assert_eq!(r.accepted, [0.125, 10.0]);
        assert_eq!((r.step, r.slider), (0.02, [0.14, 3.0]));
        assert!(r.step > 0.0 && (r.slider[1] - r.slider[0]) / r.step <= 200.0 + 1e-9);
        assert!(r.in_database(0.5) && r.in_database(2.5) && !r.in_database(2.6));
        assert!(r.accepts(10.0) && !r.accepts(10.1) && !r.accepts(f64::NAN) && !r.accepts(0.1));
        assert_eq!(r.simulate, [0.5, 3.0]);
        assert!(r.simulates(0.5) && r.simulates(3.0) && !r.simulates(0.48) && !r.simulates(3.02));
        let v = ParameterRange::new("velocity_mm_s", "mm/s", "v", 20.0, (10.0, 100.0));
        assert_eq!((v.step, v.slider), (1.0, [3.0, 122.0]));
        let h = ParameterRange::new("height_mm", "mm", "h", 0.27, (0.1, 0.5));
        assert_eq!((h.step, h.slider, h.accepted), (0.005, [0.025, 0.6], [0.025, 2.0]));
    }
}
