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
//!   extrapolation flag appear.

use std::path::{Path, PathBuf};

use haptex_core::database::{DatabaseError, Metadata, Template, TemplateModel};
use serde::Serialize;

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
        Self { name, unit, label, default, database: [lo, hi], accepted, slider, step }
    }

    /// Whether `value` is within the database range.
    pub fn in_database(&self, value: f64) -> bool {
        value >= self.database[0] && value <= self.database[1]
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
        Ok(Self { dir: dir.to_path_buf(), metadata, models })
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
        let v = ParameterRange::new("velocity_mm_s", "mm/s", "v", 20.0, (10.0, 100.0));
        assert_eq!((v.step, v.slider), (1.0, [3.0, 122.0]));
        let h = ParameterRange::new("height_mm", "mm", "h", 0.27, (0.1, 0.5));
        assert_eq!((h.step, h.slider, h.accepted), (0.005, [0.025, 0.6], [0.025, 2.0]));
    }
}
