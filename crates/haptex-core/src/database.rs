//! The FE database of template surfaces and the instant prediction of any
//! member of a family (paper sections 3.1-3.2, Fig. 2a).
//!
//! For each template (bump, edge, sine) a model matrix in the CAE CSV format
//! holds one FE simulation per row: the inputs `r_w_mm,r_h_mm,velocity_mm_s`
//! and the friction profile Ft/Fn sampled on a common grid of positions of
//! the finger relative to the feature, xi = x - x0 (outputs `mu@-5.00`,
//! ...). `metadata.json` beside them records the grid, the sweep, the FE
//! settings, the build and the leave-one-out-optimal CAE widths. A
//! prediction for (r_w, r_h, velocity) is the CAE estimate over the
//! template's matrix, shifted to the feature's position x0.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::cae::{Cae, CaeError, Diagnostics, LooErrors, ModelMatrix, Scratch, Widths};
use crate::num::Num;

/// The database's input columns, in order.
pub const INPUTS: [&str; 3] = ["r_w_mm", "r_h_mm", "velocity_mm_s"];

/// The template surfaces of design.md.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Template {
    Bump,
    Edge,
    Sine,
}

impl Template {
    pub const ALL: [Template; 3] = [Template::Bump, Template::Edge, Template::Sine];

    pub fn name(self) -> &'static str {
        match self {
            Template::Bump => "bump",
            Template::Edge => "edge",
            Template::Sine => "sine",
        }
    }

    /// Parses "bump", "edge" or "sine".
    pub fn parse(text: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.name() == text)
    }

    /// What the named mesh does not resolve of this template with width
    /// r_w and height r_h (mm): a sine's crests sharper than
    /// [`crate::crests::RESOLVED_SPACINGS`] pad spacings; nothing for the
    /// other templates.
    pub fn unresolved_crests(self, mesh: &str, width: f64, height: f64) -> Option<crate::crests::Unresolved> {
        match self {
            Template::Sine => crate::crests::unresolved_sine(mesh, width, height),
            Template::Bump | Template::Edge => None,
        }
    }

    /// Whether the named mesh resolves this template's crests at r_w and
    /// r_h: for a sine, true or false; `None` for the templates the rule
    /// does not apply to.
    pub fn crests_resolved(self, mesh: &str, width: f64, height: f64) -> Option<bool> {
        (self == Template::Sine).then(|| self.unresolved_crests(mesh, width, height).is_none())
    }

    /// The grid estimate of this template's rows (`matrix`, sampled on
    /// `grid`): multilinear interpolation over r_w, r_h and velocity, a
    /// sine's profiles blended in phase (its period r_w is input 0,
    /// [`crate::grid::GridInterpolation::in_phase`]; docs/database.md, "The
    /// sine in phase").
    pub fn grid_interpolation(
        self,
        matrix: &ModelMatrix,
        grid: &Grid,
    ) -> Result<crate::grid::GridInterpolation, crate::grid::GridError> {
        let interpolation = crate::grid::GridInterpolation::new(matrix)?;
        match self.phase(grid) {
            Some((input, start, step)) => interpolation.in_phase(input, start, step),
            None => Ok(interpolation),
        }
    }

    /// For a template whose profiles are blended in phase (the sine): the
    /// input that is its period (r_w, input 0) and the start and step of
    /// the positions `grid` samples its profiles at.
    pub fn phase(self, grid: &Grid) -> Option<(usize, f64, f64)> {
        (self == Template::Sine && grid.points >= 2)
            .then(|| (0, grid.xi_min_mm, (grid.xi_max_mm - grid.xi_min_mm) / (grid.points - 1) as f64))
    }

    /// The model-matrix file of this template in a database directory.
    pub fn file_name(self) -> String {
        format!("{}.csv", self.name())
    }

    /// The surface height h(x) in mm of this template with feature position
    /// `x0`, width r_w and height r_h (all mm), as design.md defines them:
    ///
    /// - bump: h = r_h exp(-((x - x0) / (r_w / 2))^2);
    /// - edge: h = r_h s((x - x0 + r_w) / r_w), s(t) = 3t^2 - 2t^3 on
    ///   [0, 1]: flat at 0, rising over r_w, flat at r_h from x0 on;
    /// - sine: h = r_h sin(2 pi (x - x0) / r_w): phase x0, period r_w,
    ///   amplitude r_h.
    pub fn height_mm(self, x: f64, x0: f64, width: f64, height: f64) -> f64 {
        match self {
            Template::Bump => height * (-((x - x0) / (0.5 * width)).powi(2)).exp(),
            Template::Edge => {
                let t = ((x - x0 + width) / width).clamp(0.0, 1.0);
                height * t * t * (3.0 - 2.0 * t)
            }
            Template::Sine => height * (std::f64::consts::TAU * (x - x0) / width).sin(),
        }
    }

    /// h(x), h'(x) and h''(x) of [`Template::height_mm`] (mm, 1, 1/mm):
    /// the surface's slope and curvature, which a contact computation on
    /// the exact curve needs. The edge's smoothstep is C1: its h'' jumps at
    /// both ends of the rise (0 outside, 6 r_h / r_w^2 at its foot).
    pub fn height_derivatives_mm(self, x: f64, x0: f64, width: f64, height: f64) -> [f64; 3] {
        match self {
            Template::Bump => {
                let s = 0.5 * width;
                let u = (x - x0) / s;
                let h = height * (-u * u).exp();
                [h, -2.0 * u / s * h, (4.0 * u * u - 2.0) / (s * s) * h]
            }
            Template::Edge => {
                let t = (x - x0 + width) / width;
                if t <= 0.0 {
                    [0.0, 0.0, 0.0]
                } else if t >= 1.0 {
                    [height, 0.0, 0.0]
                } else {
                    [
                        height * t * t * (3.0 - 2.0 * t),
                        height * 6.0 * t * (1.0 - t) / width,
                        height * (6.0 - 12.0 * t) / (width * width),
                    ]
                }
            }
            Template::Sine => {
                let k = std::f64::consts::TAU / width;
                let (sin, cos) = (k * (x - x0)).sin_cos();
                [height * sin, height * k * cos, -height * k * k * sin]
            }
        }
    }

    /// A query in words, as the headers of predicted and simulated
    /// profiles give it: `bump x0=5 mm r_w=1.3 mm r_h=0.27 mm velocity=20
    /// mm/s` (`query`: r_w, r_h, velocity).
    pub fn describe_query(self, x0_mm: f64, query: &[f64; 3]) -> String {
        {
            use crate::num::Num;
            format!(
                "{} x0={} mm r_w={} mm r_h={} mm velocity={} mm/s",
                self.name(),
                Num(x0_mm),
                Num(query[0]),
                Num(query[1]),
                Num(query[2])
            )
        }
    }

    /// What the width r_w and the height r_h mean for this template.
    pub fn parameter_meaning(self) -> (&'static str, &'static str) {
        match self {
            Template::Bump => ("bump width r_w", "bump height r_h"),
            Template::Edge => ("edge rise r_w", "edge height r_h"),
            Template::Sine => ("sine period r_w", "sine amplitude r_h"),
        }
    }
}

/// The positions xi = x - x0 (mm) at which every profile is sampled.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    pub xi_min_mm: f64,
    pub xi_max_mm: f64,
    pub points: usize,
}

impl Grid {
    pub fn positions(&self) -> Vec<f64> {
        self.positions_from(0.0)
    }

    /// The positions shifted by `x0_mm`, x = x0 + xi (mm). Each is one
    /// weighted mean of the two ends, a single rounding: a grid from 0 to
    /// 10 mm in 0.02 mm reads 0.02, 0.04, ... as written, not the
    /// 0.019999999999999574 of accumulated or offset sums.
    pub fn positions_from(&self, x0_mm: f64) -> Vec<f64> {
        let n = self.points;
        if n < 2 {
            return vec![x0_mm + self.xi_min_mm; n];
        }
        let (lo, hi) = (x0_mm + self.xi_min_mm, x0_mm + self.xi_max_mm);
        let last = (n - 1) as f64;
        (0..n).map(|i| (lo * (last - i as f64) + hi * i as f64) / last).collect()
    }

    /// The output column names, `mu@<xi>` with two decimals.
    pub fn column_names(&self) -> Vec<String> {
        self.positions().iter().map(|xi| format!("mu@{xi:.2}")).collect()
    }
}

/// The parameter sweep of a database.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sweep {
    pub templates: Vec<Template>,
    pub widths_mm: Vec<f64>,
    pub heights_mm: Vec<f64>,
    pub velocities_mm_s: Vec<f64>,
}

/// The FE settings every run of the database shares.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeSettings {
    /// Finger model file and the SHA-256 of its text.
    pub finger_model: String,
    pub finger_model_sha256: String,
    pub mesh: String,
    pub material: String,
    pub indent_mm: f64,
    pub press_time_s: f64,
    /// The feature's position in each run, and the slide (mm).
    pub x0_mm: f64,
    pub slide_mm: f64,
    /// Slide step: min(max_step_mm, width / 10), and at most
    /// `averaging.step_mm` when the profiles are averaged.
    pub max_step_mm: f64,
    pub mu_skin: f64,
    pub penalty_mpa_per_mm: f64,
    /// How each run's Ft/Fn is averaged over the finger's travel before it
    /// is sampled on the grid. Absent in databases built before haptex
    /// averaged (2026-12-07): their rows are Ft/Fn at the slide steps,
    /// interpolated onto the grid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub averaging: Option<Averaging>,
}

/// The moving average that takes the finger mesh's node passing out of a
/// database profile (docs/database.md, "What a database row is").
///
/// As the skin slides over a feature, each node of the pad's surface passes
/// it in turn, and Ft/Fn oscillates with the pad's node spacing h: a
/// discretization error, as large as a grating's own modulation on the fine
/// mesh. Sampled at slide steps of 2h (0.1 mm on the fine mesh), that
/// oscillation aliases into slow, random-looking wiggles no estimator can
/// interpolate. Steps of h/4 resolve it, and an average over 2h, the
/// shortest wavelength the pad's mesh represents, removes it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Averaging {
    /// The slide step of every run (mm): a quarter of the pad's node spacing.
    pub step_mm: f64,
    /// The width of the centred moving average of Ft/Fn over the finger's
    /// position (mm): two node spacings, cut to the slide at its ends.
    pub window_mm: f64,
}

impl FeSettings {
    /// The flat-surface friction of the database's profiles, the mu_flat of
    /// a relative profile ([`crate::relative`]): on a flat surface, once the
    /// whole contact slips, Ft/Fn equals the skin's Coulomb coefficient.
    pub fn flat_mu(&self) -> f64 {
        self.mu_skin
    }

    /// A comment line for predicted profiles: their flat-surface friction,
    /// and how to map them as the paper's Fig. 2 does.
    pub fn flat_mu_comment(&self) -> String {
        format!(
            "flat-surface friction mu_flat = {} (Ft/Fn on a flat surface: the FE skin friction mu_skin); for eq. (8) \
             as in the paper's Fig. 2: haptex voltage --relative --flat-mu {}",
            Num(self.flat_mu()),
            Num(self.flat_mu())
        )
    }
}

/// The CAE set-up of one template's matrix.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TemplateEntry {
    pub template: Template,
    pub file: String,
    pub rows: usize,
    /// Leave-one-out-optimal widths (normalized input units).
    pub widths: Widths,
    /// LOO RMS error of Ft/Fn over all outputs, and relative to the mean
    /// range of the profiles.
    pub loo_rmse: f64,
    pub loo_rmse_relative_to_range: f64,
    /// The constant width with the smallest LOO error, and that error.
    pub constant_width: f64,
    pub constant_width_rmse: f64,
}

/// `metadata.json` of a database.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Metadata {
    pub format: String,
    pub haptex_version: String,
    /// UTC date and time the database was merged (RFC 3339).
    pub created: String,
    /// Wall time of the FE runs, summed over runs and shards (s), and the
    /// build's wall-clock time when it ran as one job.
    pub cpu_time_s: f64,
    pub build_wall_time_s: Option<f64>,
    pub grid: Grid,
    pub sweep: Sweep,
    pub fe: FeSettings,
    pub templates: Vec<TemplateEntry>,
    /// SHA-256 of each model-matrix file, by file name. `metadata.json` is
    /// written last by `haptex db merge` (and removed when a merge starts),
    /// so a database whose merge did not finish has none, and a matrix that
    /// does not match its hash is refused when loaded. Absent in databases
    /// merged before haptex recorded it (then not checked).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub files_sha256: Option<crate::io::MemberHashes>,
    /// The estimate measured on random members against fresh FE runs
    /// (`haptex db validate --record`), if it was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation: Option<Validation>,
    /// The estimator estimates between the rows are served with (`haptex
    /// predict`, the web page); the CAE when absent. `haptex db validate
    /// --record` sets it to the estimator it measured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimator: Option<Estimator>,
    /// The rounds of `haptex db refine` that added rows to the sweep's, in
    /// order; absent if none did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refined: Option<Vec<RefineRound>>,
}

/// One round of `haptex db refine`: a new value of one input between two
/// of the grid's, with an FE run at every combination of the other inputs'
/// values, and how far the estimate of the database before the round was
/// from those runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefineRound {
    pub template: Template,
    /// `width`, `height` or `velocity`.
    pub axis: String,
    /// The new value (mm or mm/s), between the two grid values `between`.
    pub value: f64,
    pub between: [f64; 2],
    /// The interval's score that chose it: the larger leave-one-line-out
    /// error of its ends, relative to the profiles' range, over 4 (the
    /// error across half that spacing, for profiles smooth in the input);
    /// none for an axis of two values, where nothing measures it.
    pub score: Option<f64>,
    /// FE runs added.
    pub runs: usize,
    /// The grid estimate before the round against the new runs: RMS over
    /// the grid relative to each run's range, median and largest.
    pub held_out_relative_median: f64,
    pub held_out_relative_max: f64,
    /// The round's errors (its score and held-out error) are over the rows
    /// whose crests the database's mesh resolves only (`db refine
    /// --resolved-only`, [`crate::crests`]).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub resolved_only: bool,
}

/// The estimate on random members of each template's family against FE
/// runs with the database's settings (`haptex db validate --record`): what
/// a user can expect of an estimate between the database's cases.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Validation {
    /// UTC date and time of the validation (RFC 3339).
    pub created: String,
    /// The seed of the members and their number per template.
    pub seed: u64,
    pub members: usize,
    /// The estimator measured (the CAE in validations recorded before
    /// haptex named it).
    #[serde(default)]
    pub estimator: Estimator,
    pub templates: Vec<ValidationEntry>,
}

/// One template's errors on random members: RMS of estimate - FE over the
/// grid, and that RMS relative to the FE profile's range (max - min).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValidationEntry {
    pub template: Template,
    pub rms_median: f64,
    pub rms_max: f64,
    pub relative_median: f64,
    pub relative_max: f64,
    /// The members whose crests the database's mesh resolves
    /// ([`crate::crests`]), apart, where some of the template's are and some
    /// are not (a sine's): against the others the FE reference itself is
    /// not mesh-converged. Absent in validations recorded before haptex
    /// told them apart (2026-12-07).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolved: Option<ResolvedEntry>,
}

/// [`ValidationEntry`]'s figures over the members whose crests the mesh
/// resolves (and the shape of the figures that apply to one estimate,
/// [`Validation::figures`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ResolvedEntry {
    /// How many of the template's members.
    pub members: usize,
    pub rms_median: f64,
    pub rms_max: f64,
    pub relative_median: f64,
    pub relative_max: f64,
}

impl ValidationEntry {
    /// This entry's own figures (not its resolved members'), over `members`
    /// members.
    pub fn figures_over(&self, members: usize) -> ResolvedEntry {
        ResolvedEntry {
            members,
            rms_median: self.rms_median,
            rms_max: self.rms_max,
            relative_median: self.relative_median,
            relative_max: self.relative_max,
        }
    }
}

/// What to expect of one estimate ([`TemplateModel::estimate_notes`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EstimateNotes {
    /// The template's errors on random members, in one sentence.
    pub expected: Option<String>,
    /// The advice to run the FE model, where the estimate is not good enough.
    pub advice: Option<String>,
    /// Where the database's own FE rows are not mesh-converged (a sine whose
    /// crests its mesh does not resolve, [`crate::crests`]): why, and what
    /// resolves them. For FE rows too.
    pub caveat: Option<String>,
}

/// The largest error relative to a profile's range, on random members, at
/// which an estimate is offered without advising the FE run instead: 10%,
/// issue 40's bound for the worst member.
pub const ESTIMATE_ADVISED_MAX_RELATIVE: f64 = 0.10;

impl Validation {
    pub fn entry(&self, template: Template) -> Option<&ValidationEntry> {
        self.templates.iter().find(|e| e.template == template)
    }

    /// The figures that apply to an estimate of `template` whose crests
    /// the database's mesh resolves (`crests_resolved`: `Some(true)`), or
    /// not, or to which the rule does not apply (`None`): the resolved
    /// members' where they were told apart and the estimate's crests are
    /// resolved, else all members'. The number of members, whether they
    /// are the resolved ones.
    pub fn figures(&self, template: Template, crests_resolved: Option<bool>) -> Option<(ResolvedEntry, bool)> {
        let e = self.entry(template)?;
        Some(match (crests_resolved, e.resolved) {
            (Some(true), Some(r)) => (r, true),
            _ => (e.figures_over(self.members), false),
        })
    }

    /// The expected error of an estimate of `template` (its crests resolved
    /// or not, [`Self::figures`]), in one sentence, if the validation
    /// covers it.
    pub fn expected_error(&self, template: Template, crests_resolved: Option<bool>) -> Option<String> {
        self.figures(template, crests_resolved).map(|(f, resolved)| {
            let which = if resolved {
                format!("{} of {} random members whose crests the mesh resolves", f.members, self.members)
            } else {
                format!("{} random members", f.members)
            };
            format!(
                "on {which} against fresh FE runs (db validate --estimator {}, seed {}) the estimate was off by \
                 {:.1}% of the profile's range (median), {:.1}% at most",
                self.estimator.name(),
                self.seed,
                100.0 * f.relative_median,
                100.0 * f.relative_max
            )
        })
    }

    /// Whether the FE run is advised over the estimate for `template` (its
    /// crests resolved or not, [`Self::figures`]): its worst random member
    /// was off by more than [`ESTIMATE_ADVISED_MAX_RELATIVE`] of the
    /// profile's range.
    pub fn fe_advised(&self, template: Template, crests_resolved: Option<bool>) -> bool {
        // A value that is not a number (a hand-edited file) advises the FE run.
        self.figures(template, crests_resolved)
            .is_some_and(|(f, _)| f.relative_max.is_nan() || f.relative_max > ESTIMATE_ADVISED_MAX_RELATIVE)
    }
}

/// The identifier of the metadata format.
pub const FORMAT: &str = "haptex-template-database/1";

/// A database cannot be read or used.
#[derive(Debug, thiserror::Error)]
pub enum DatabaseError {
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
    #[error(transparent)]
    Cae(#[from] CaeError),
    #[error("the database has no {0} template")]
    MissingTemplate(&'static str),
    #[error("{0}")]
    Query(String),
}

impl Metadata {
    /// Reads `metadata.json` from a database directory.
    pub fn read(dir: &Path) -> Result<Self, DatabaseError> {
        let path = dir.join("metadata.json");
        let text = std::fs::read_to_string(&path).map_err(|e| DatabaseError::File {
            path: path.clone(),
            message: if e.kind() == std::io::ErrorKind::NotFound {
                "no metadata.json: not a database, or one whose build or merge did not finish (haptex db merge \
                 writes it last)"
                    .to_string()
            } else {
                e.to_string()
            },
        })?;
        let metadata: Self = serde_json::from_str(&text).map_err(|e| DatabaseError::File {
            path: path.clone(),
            message: format!("line {}, column {}: {e}", e.line(), e.column()),
        })?;
        if metadata.format != FORMAT {
            return Err(DatabaseError::File {
                path,
                message: format!("format '{}' is not '{FORMAT}'", metadata.format),
            });
        }
        let grid = metadata.grid;
        if grid.points >= 2 && grid.xi_max_mm <= grid.xi_min_mm {
            return Err(DatabaseError::File {
                path,
                message: format!(
                    "grid: xi_max_mm {} is not above xi_min_mm {} (the profiles' positions run from the one to the \
                     other)",
                    crate::num::Num(grid.xi_max_mm),
                    crate::num::Num(grid.xi_min_mm)
                ),
            });
        }
        // The files it names are read from the database's directory: each
        // a name by the one rule, so that the file cannot point elsewhere.
        let listed = metadata.files_sha256.iter().flat_map(|hashes| hashes.keys());
        for (i, file) in metadata.templates.iter().map(|e| &e.file).chain(listed).enumerate() {
            crate::name::check_name(file).map_err(|e| DatabaseError::File {
                path: path.clone(),
                message: if i < metadata.templates.len() {
                    format!("templates[{i}].file: {e}")
                } else {
                    format!("files_sha256: {e}")
                },
            })?;
        }
        Ok(metadata)
    }

    /// Per template: rows, widths and leave-one-out errors, with when and
    /// how the database was built (`haptex db loo --json`).
    pub fn loo_summary(&self) -> serde_json::Value {
        serde_json::json!({
            "created": self.created,
            "haptex_version": self.haptex_version,
            "build_wall_time_s": self.build_wall_time_s,
            "cpu_time_s": self.cpu_time_s,
            "inputs": INPUTS,
            "templates": self.templates,
        })
    }

    pub fn entry(&self, template: Template) -> Option<&TemplateEntry> {
        self.templates.iter().find(|e| e.template == template)
    }

    /// The estimator the database's estimates are served with: the one it
    /// names, else the paper's CAE.
    pub fn served_estimator(&self) -> Estimator {
        self.estimator.unwrap_or_default()
    }
}

/// One template's predictor: its model matrix and the CAE with the
/// database's LOO-optimal widths.
#[derive(Debug, Clone)]
pub struct TemplateModel {
    pub template: Template,
    pub cae: Cae,
    pub grid: Grid,
    positions: Vec<f64>,
    /// (min, max) of r_w, r_h and velocity over the rows, computed once.
    input_ranges: [(f64, f64); 3],
    /// The rows as a grid, if they are a full one (as every sweep's are).
    /// The grid estimate, or why the rows cannot have it.
    grid_interpolation: Result<crate::grid::GridInterpolation, crate::grid::GridError>,
    /// The estimator of [`Self::predict`] and [`Self::predict_into`].
    estimator: Estimator,
}

/// How an estimate between the database's rows is made. A database
/// names the one its estimates are served with (`estimator` in
/// `metadata.json`, [`Metadata::estimator`]); the CAE when it names none.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Estimator {
    /// The paper's conditional average estimator with the metadata's
    /// leave-one-out widths.
    #[default]
    Cae,
    /// Multilinear interpolation over the sweep's grid
    /// ([`crate::grid::GridInterpolation`]).
    Grid,
}

impl Estimator {
    /// Every estimator.
    pub const ALL: [Estimator; 2] = [Estimator::Cae, Estimator::Grid];

    /// The name in `metadata.json` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Cae => "cae",
            Estimator::Grid => "grid",
        }
    }

    /// The estimator named `name` ([`Self::name`]), if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|e| e.name() == name)
    }
}

/// A predicted profile.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Prediction {
    /// Finger positions on the surface, x = x0 + xi (mm).
    pub x_mm: Vec<f64>,
    pub mu: Vec<f64>,
    /// The database row whose FE profile this is, when the parameters are
    /// exactly a row's (then no estimate is involved).
    pub fe_row: Option<usize>,
    /// The estimator between the rows (not involved at an FE row).
    pub estimator: Estimator,
    pub diagnostics: Diagnostics,
}

impl TemplateModel {
    /// Loads one template of the database in `dir`.
    pub fn load(dir: &Path, template: Template) -> Result<Self, DatabaseError> {
        let metadata = Metadata::read(dir)?;
        Self::load_with(dir, &metadata, template)
    }

    /// Loads one template, given the database's metadata.
    pub fn load_with(dir: &Path, metadata: &Metadata, template: Template) -> Result<Self, DatabaseError> {
        let entry = metadata.entry(template).ok_or(DatabaseError::MissingTemplate(template.name()))?;
        let path = dir.join(&entry.file);
        if let Some(hashes) = &metadata.files_sha256 {
            let expected = hashes.get(&entry.file).ok_or_else(|| DatabaseError::File {
                path: dir.join("metadata.json"),
                message: format!("files_sha256 lists no hash for {}", entry.file),
            })?;
            let member = crate::io::MemberHashes::from([(entry.file.clone(), expected.clone())]);
            crate::io::verify_members(dir, &member)
                .map_err(|e| DatabaseError::File { path: path.clone(), message: e.problem })?;
        }
        let matrix = ModelMatrix::read_csv_file(&path, &INPUTS)?;
        if matrix.m() != metadata.grid.points {
            return Err(DatabaseError::File {
                path,
                message: format!("{} outputs, the metadata's grid has {} points", matrix.m(), metadata.grid.points),
            });
        }
        let input_ranges = std::array::from_fn(|l| {
            (0..matrix.n())
                .map(|n| matrix.input_row(n)[l])
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)))
        });
        let grid = template.grid_interpolation(&matrix, &metadata.grid);
        let estimator = metadata.served_estimator();
        if let (Estimator::Grid, Err(e)) = (estimator, &grid) {
            return Err(DatabaseError::File {
                path: dir.join("metadata.json"),
                message: format!("estimator: 'grid' cannot serve {}: {e}", entry.file),
            });
        }
        let cae = Cae::new(matrix, entry.widths)?;
        Ok(Self {
            template,
            cae,
            grid: metadata.grid,
            positions: metadata.grid.positions(),
            input_ranges,
            grid_interpolation: grid,
            estimator,
        })
    }

    /// The estimator of [`Self::predict`] and [`Self::predict_into`]: the
    /// database's ([`Metadata::served_estimator`]) unless set otherwise.
    pub fn estimator(&self) -> Estimator {
        self.estimator
    }

    /// The model with `estimator` between the rows, or why it cannot have
    /// it (the grid needs rows that form a full grid).
    pub fn with_estimator(mut self, estimator: Estimator) -> Result<Self, DatabaseError> {
        self.grid_for(estimator)?;
        self.estimator = estimator;
        Ok(self)
    }

    /// The grid interpolation `estimator` needs, if it needs one.
    fn grid_for(&self, estimator: Estimator) -> Result<Option<&crate::grid::GridInterpolation>, DatabaseError> {
        match estimator {
            Estimator::Cae => Ok(None),
            Estimator::Grid => self.grid_interpolation.as_ref().map(Some).map_err(|e| {
                DatabaseError::Query(format!(
                    "the {} rows cannot have the grid estimate ({e}): use the CAE",
                    self.template.name()
                ))
            }),
        }
    }

    /// Positions xi = x - x0 of the outputs (mm).
    pub fn positions(&self) -> &[f64] {
        &self.positions
    }

    /// The row whose inputs equal (r_w, r_h, v) to 1e-9, if any.
    pub fn exact_row(&self, inputs: &[f64; 3]) -> Option<usize> {
        let m = self.cae.matrix();
        (0..m.n()).find(|&n| m.input_row(n).iter().zip(inputs).all(|(a, b)| (a - b).abs() <= 1e-9 * a.abs().max(1.0)))
    }

    /// Ft/Fn on the grid for (r_w, r_h, velocity) into `out`, without
    /// allocation: the FE row itself at a database point, else the
    /// estimate of the model's estimator ([`Self::estimator`]). Returns the
    /// row used, if exact, and the CAE's diagnostics (its nearest case and
    /// weights, whichever the estimator).
    pub fn predict_into(
        &self,
        inputs: &[f64; 3],
        scratch: &mut Scratch,
        out: &mut [f64],
    ) -> Result<(Option<usize>, Diagnostics), DatabaseError> {
        self.predict_into_with(self.estimator, inputs, scratch, out)
    }

    /// [`Self::predict_into`] with `estimator` between the rows.
    pub fn predict_into_with(
        &self,
        estimator: Estimator,
        inputs: &[f64; 3],
        scratch: &mut Scratch,
        out: &mut [f64],
    ) -> Result<(Option<usize>, Diagnostics), DatabaseError> {
        let grid = self.grid_for(estimator)?;
        if inputs.iter().any(|v| !v.is_finite()) {
            return Err(DatabaseError::Query(format!(
                "parameters must be finite numbers, got {}",
                crate::num::Nums(inputs)
            )));
        }
        if out.len() != self.cae.matrix().m() {
            return Err(DatabaseError::Query(format!(
                "a buffer of {} outputs for a profile of {} points",
                out.len(),
                self.cae.matrix().m()
            )));
        }
        // The CAE's sum only where it is the estimate; its diagnostics always.
        let row = self.exact_row(inputs);
        let diagnostics = match (row, grid) {
            (Some(n), _) => {
                out.copy_from_slice(self.cae.matrix().output_row(n));
                self.cae.diagnose(inputs, scratch)?
            }
            (None, Some(grid)) => {
                grid.predict_into(self.cae.matrix(), inputs, out);
                self.cae.diagnose(inputs, scratch)?
            }
            (None, None) => self.cae.predict_into(inputs, scratch, out)?,
        };
        Ok((row, diagnostics))
    }

    /// The predicted profile of a feature at `x0_mm`.
    pub fn predict(
        &self,
        x0_mm: f64,
        width_mm: f64,
        height_mm: f64,
        velocity_mm_s: f64,
    ) -> Result<Prediction, DatabaseError> {
        self.predict_with(self.estimator, x0_mm, width_mm, height_mm, velocity_mm_s)
    }

    /// [`Self::predict`] with the estimator `estimator` between the rows
    /// (an FE row is returned as it is either way; the diagnostics are the
    /// CAE's, for its warnings). `Grid` needs rows that form a full grid.
    pub fn predict_with(
        &self,
        estimator: Estimator,
        x0_mm: f64,
        width_mm: f64,
        height_mm: f64,
        velocity_mm_s: f64,
    ) -> Result<Prediction, DatabaseError> {
        if !x0_mm.is_finite() {
            return Err(DatabaseError::Query(format!("x0 must be a finite number, got {}", crate::num::Num(x0_mm))));
        }
        let mut scratch = self.cae.scratch();
        let mut mu = vec![0.0; self.grid.points];
        let query = [width_mm, height_mm, velocity_mm_s];
        let (fe_row, diagnostics) = self.predict_into_with(estimator, &query, &mut scratch, &mut mu)?;
        let x_mm = self.grid.positions_from(x0_mm);
        Ok(Prediction { x_mm, mu, fe_row, estimator, diagnostics })
    }

    /// Where a prediction for `query` (r_w, r_h, velocity) comes from, in
    /// one sentence: the FE row it is, or the CAE estimate with its nearest
    /// case and the template's typical (leave-one-out) error from `entry`.
    pub fn describe(&self, query: &[f64; 3], prediction: &Prediction, entry: &TemplateEntry) -> String {
        match prediction.fe_row {
            Some(row) => format!(
                "FE result: r_w = {} mm, r_h = {} mm, v = {} mm/s is row {} of {} (no estimate involved)",
                query[0],
                query[1],
                query[2],
                row + 1,
                self.template.file_name()
            ),
            None if prediction.estimator == Estimator::Grid => {
                let axes = self.grid_interpolation.as_ref().map_or_else(
                    |_| String::new(),
                    |g| {
                        let counts: Vec<String> = g.axes().iter().map(|a| a.len().to_string()).collect();
                        format!(" ({} values of r_w x r_h x velocity)", counts.join(" x "))
                    },
                );
                let phase = if self.grid_interpolation.as_ref().is_ok_and(|g| g.is_in_phase()) {
                    ", the profiles blended in phase (at the same (x - x0) / r_w)"
                } else {
                    ""
                };
                format!(
                    "grid estimate: multilinear interpolation over the grid of {} FE profiles{axes}{phase}; nearest \
                     case row {} at normalized distance {:.3}",
                    self.cae.matrix().n(),
                    prediction.diagnostics.nearest_row + 1,
                    prediction.diagnostics.nearest_distance,
                )
            }
            None => format!(
                "CAE estimate over {} FE profiles (widths {:.4} .. {:.4}); nearest case row {} at normalized \
                 distance {:.3}; typical error (leave-one-out RMS over the database) {:.4}, {:.0}% of a profile's \
                 range",
                self.cae.matrix().n(),
                self.cae.widths().w_min,
                self.cae.widths().w_max,
                prediction.diagnostics.nearest_row + 1,
                prediction.diagnostics.nearest_distance,
                entry.loo_rmse,
                100.0 * entry.loo_rmse_relative_to_range
            ),
        }
    }

    /// The comment lines (without `# `) of a prediction's file, as `haptex
    /// predict` writes them ([`write_prediction_csv`]): what was predicted,
    /// where it comes from (`source`, [`Self::describe`]'s), the database's
    /// flat-surface friction, the `warning` if any ([`Self::warning`]'s) and
    /// what to expect of the estimate (`notes`, [`Self::estimate_notes`]').
    pub fn prediction_comments(
        &self,
        metadata: &Metadata,
        x0_mm: f64,
        query: &[f64; 3],
        source: &str,
        warning: Option<&str>,
        notes: &EstimateNotes,
    ) -> Vec<String> {
        let mut comments = vec![
            format!("haptex predict: {}", self.template.describe_query(x0_mm, query)),
            source.to_string(),
            metadata.fe.flat_mu_comment(),
        ];
        comments.extend(warning.map(|w| format!("warning: {w}")));
        comments.extend(notes.expected.iter().map(|e| format!("expected error: {e}")));
        comments.extend(notes.advice.iter().map(|a| format!("advice: {a}")));
        comments.extend(notes.caveat.iter().map(|c| format!("caveat: {c}")));
        comments
    }

    /// What the database's validation on random members ([`Validation`])
    /// says of an estimate for `query` (r_w, r_h, velocity): its expected
    /// error, and the advice to run the FE model where that is not good
    /// enough. Nothing for an FE row or a database without a validation;
    /// for an estimator other than the validated one, that it was not
    /// measured.
    pub fn estimate_notes(&self, metadata: &Metadata, query: &[f64; 3], prediction: &Prediction) -> EstimateNotes {
        let t = self.template;
        let unresolved = self.unresolved_crests(metadata, query);
        let caveat = unresolved.map(|u| u.describe());
        let crests_resolved = self.crests_resolved(metadata, query);
        let Some(validation) = metadata.validation.as_ref().filter(|_| prediction.fe_row.is_none()) else {
            return EstimateNotes { caveat, ..EstimateNotes::default() };
        };
        if validation.estimator != prediction.estimator {
            return EstimateNotes {
                expected: validation.entry(t).map(|_| {
                    format!(
                        "not measured for the {} estimator (the database's validation, seed {}, is of the {})",
                        prediction.estimator.name(),
                        validation.seed,
                        validation.estimator.name()
                    )
                }),
                advice: None,
                caveat,
            };
        }
        EstimateNotes {
            expected: validation.expected_error(t, crests_resolved),
            advice: validation.fe_advised(t, crests_resolved).then(|| match unresolved {
                // The database's settings would not resolve it either.
                Some(u) if u.resolving_mesh().is_some() => format!(
                    "for {} surfaces the estimate is not good enough, and the database's FE rows do not resolve \
                     this grating (caveat below): run the FE model on a mesh that does",
                    t.name()
                ),
                Some(_) => format!(
                    "for {} surfaces the estimate is not good enough, and neither the database's FE rows nor any \
                     mesh of haptex's resolve this grating (caveat below): read the estimate as indicative only",
                    t.name()
                ),
                None => format!(
                    "for {} surfaces the estimate is not good enough: run the FE model instead, `haptex db loo \
                     --surface {} --width {} --height {} --velocity {}` (its FE profile, with the database's \
                     settings) or `haptex simulate`",
                    t.name(),
                    t.name(),
                    Num(query[0]),
                    Num(query[1]),
                    Num(query[2])
                ),
            }),
            caveat,
        }
    }

    /// What the database's mesh does not resolve of a query (r_w, r_h,
    /// velocity): a sine's crests sharper than 5 pad spacings
    /// ([`crate::crests`]); nothing for the other templates.
    pub fn unresolved_crests(&self, metadata: &Metadata, query: &[f64; 3]) -> Option<crate::crests::Unresolved> {
        self.template.unresolved_crests(&metadata.fe.mesh, query[0], query[1])
    }

    /// Whether the database's mesh resolves a query's crests: for a sine,
    /// true or false; `None` for the templates the rule does not apply to.
    pub fn crests_resolved(&self, metadata: &Metadata, query: &[f64; 3]) -> Option<bool> {
        self.template.crests_resolved(&metadata.fe.mesh, query[0], query[1])
    }

    /// The warning for a query (r_w, r_h, velocity) and its prediction, if
    /// any: none for an exact database row; the CAE's extrapolation warning
    /// when the query is far from every case (paper footnote 6); else a
    /// warning naming each parameter outside the database's range, where
    /// the estimate extrapolates although some case is still within the
    /// kernel's reach.
    pub fn warning(&self, query: &[f64; 3], fe_row: Option<usize>, diagnostics: &Diagnostics) -> Option<String> {
        if fe_row.is_some() {
            return None;
        }
        self.cae.warning(query, diagnostics).or_else(|| self.range_warning(query))
    }

    /// A warning naming each parameter of `query` outside the database's
    /// range, if any.
    pub fn range_warning(&self, query: &[f64; 3]) -> Option<String> {
        const NAMES: [(&str, &str); 3] = [("width r_w", "mm"), ("height r_h", "mm"), ("velocity", "mm/s")];
        let outside: Vec<String> = self
            .input_ranges()
            .iter()
            .zip(query)
            .zip(NAMES)
            .filter(|(((lo, hi), v), _)| *v < lo || *v > hi)
            .map(|(((lo, hi), v), (name, unit))| {
                format!("{name} = {} {unit} is outside the database range {} .. {} {unit}", Num(*v), Num(*lo), Num(*hi))
            })
            .collect();
        (!outside.is_empty()).then(|| format!("{}: the estimate extrapolates the FE database", outside.join("; ")))
    }

    /// The range of each input over the database: (min, max) for r_w, r_h, v.
    pub fn input_ranges(&self) -> [(f64, f64); 3] {
        self.input_ranges
    }
}

/// LOO errors for the metadata, from the CAE's per-output errors.
pub fn relative_loo_error(matrix: &ModelMatrix, errors: &LooErrors) -> f64 {
    // Mean range of the profiles (max - min of each row), averaged.
    let mean_range = (0..matrix.n())
        .map(|n| {
            let row = matrix.output_row(n);
            let (lo, hi) = row.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
            hi - lo
        })
        .sum::<f64>()
        / matrix.n() as f64;
    errors.rmse / mean_range
}

impl DatabaseError {
    /// A CSV problem (file, line, column) as a database error.
    pub fn from_table(e: crate::io::TableError) -> Self {
        DatabaseError::Cae(CaeError::Table(e))
    }
}

/// The current UTC time as RFC 3339 (`2026-11-22T07:30:00Z`).
pub fn utc_now_rfc3339() -> String {
    let seconds = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (days, rest) = (seconds.div_euclid(86_400), seconds.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (H. Hinnant, "chrono-Compatible
    // Low-Level Date Algorithms").
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z", rest / 3600, rest % 3600 / 60, rest % 60)
}

/// Writes a predicted profile as `haptex predict` does: `comments` (from
/// [`TemplateModel::prediction_comments`]) as `# ` lines, then `x_mm,mu`
/// in full precision.
pub fn write_prediction_csv(
    w: &mut dyn std::io::Write,
    comments: &[String],
    x_mm: &[f64],
    mu: &[f64],
) -> std::io::Result<()> {
    for comment in comments {
        writeln!(w, "# {comment}")?;
    }
    writeln!(w, "x_mm,mu")?;
    for (x, mu) in x_mm.iter().zip(mu) {
        crate::io::write_csv_row(w, &[*x, *mu])?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A metadata.json whose grid runs backwards (or nowhere) is refused
    /// by name: the positions, and the sine's phase, are read from it.
    #[test]
    fn a_grid_that_does_not_run_forwards_is_named() {
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/db/metadata.json");
        let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(shipped).unwrap()).unwrap();
        let dir = std::env::temp_dir().join(format!("haptex-grid-backwards-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (lo, hi) in [(5.0, -5.0), (1.0, 1.0)] {
            json["grid"]["xi_min_mm"] = lo.into();
            json["grid"]["xi_max_mm"] = hi.into();
            std::fs::write(dir.join("metadata.json"), json.to_string()).unwrap();
            let error = Metadata::read(&dir).unwrap_err().to_string();
            assert!(error.contains("metadata.json") && error.contains("grid: xi_max_mm"), "{error}");
        }
        json["grid"]["xi_min_mm"] = (-5.0).into();
        json["grid"]["xi_max_mm"] = 5.0.into();
        std::fs::write(dir.join("metadata.json"), json.to_string()).unwrap();
        assert!(Metadata::read(&dir).is_ok());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// An estimate of a sine whose crests the mesh resolves is told the
    /// resolved members' figures (and advised by them), where the
    /// validation told them apart; any other estimate all members'.
    #[test]
    fn a_resolved_sine_is_told_the_resolved_members_figures() {
        let entry = |template, relative_max, resolved| ValidationEntry {
            template,
            rms_median: 0.004,
            rms_max: 0.06,
            relative_median: 0.089,
            relative_max,
            resolved,
        };
        let resolved = ResolvedEntry {
            members: 15,
            rms_median: 0.002,
            rms_max: 0.006,
            relative_median: 0.054,
            relative_max: 0.093,
        };
        let v = Validation {
            created: String::new(),
            seed: 1,
            members: 30,
            estimator: Estimator::Grid,
            templates: vec![entry(Template::Sine, 0.585, Some(resolved)), entry(Template::Bump, 0.027, None)],
        };
        let figures = |t, crests| v.figures(t, crests).map(|(f, r)| (f.members, r, f.relative_median, f.relative_max));
        assert_eq!(figures(Template::Sine, Some(true)), Some((15, true, 0.054, 0.093)));
        assert_eq!(figures(Template::Sine, Some(false)), Some((30, false, 0.089, 0.585)));
        assert_eq!(figures(Template::Bump, None), Some((30, false, 0.089, 0.027)));
        assert_eq!(v.figures(Template::Sine, Some(true)).unwrap().0, resolved);
        assert_eq!(v.figures(Template::Edge, None), None);
        assert!(!v.fe_advised(Template::Sine, Some(true)) && v.fe_advised(Template::Sine, Some(false)));
        let said = v.expected_error(Template::Sine, Some(true)).unwrap();
        assert!(
            said.starts_with("on 15 of 30 random members whose crests the mesh resolves against fresh FE runs")
                && said.ends_with("off by 5.4% of the profile's range (median), 9.3% at most"),
            "{said}"
        );
        assert!(v.expected_error(Template::Sine, Some(false)).unwrap().starts_with("on 30 random members against"));
        // A validation recorded before the members were told apart reads as before.
        let old: ValidationEntry = serde_json::from_str(
            r#"{"template": "sine", "rms_median": 0.004, "rms_max": 0.06, "relative_median": 0.11, "relative_max": 0.585}"#,
        )
        .unwrap();
        assert_eq!(old.resolved, None);
    }

    #[test]
    fn grid_positions_and_names() {
        let g = Grid { xi_min_mm: -5.0, xi_max_mm: 5.0, points: 501 };
        let p = g.positions();
        assert_eq!((p[0], p[250], p[500]), (-5.0, 0.0, 5.0));
        assert!((p[1] + 4.98).abs() < 1e-12);
        assert_eq!(g.column_names()[1], "mu@-4.98");
        // Every position the double nearest its decimal value, shifted or
        // not (the positions are printed in CSV files and JSON answers).
        for x0 in [0.0, 5.0, 2.5] {
            for (i, x) in g.positions_from(x0).iter().enumerate() {
                let decimal: f64 = format!("{:.2}", x0 - 5.0 + 0.02 * i as f64).parse().unwrap();
                assert_eq!(*x, decimal, "position {i} from {x0}");
            }
        }
    }

    /// The derivatives agree with central differences of height_mm (step
    /// 1e-5 mm: truncation ~1e-10 relative, round-off ~1e-11) and the value
    /// with height_mm itself, for every template over its feature.
    #[test]
    fn height_derivatives_match_differences() {
        for template in [Template::Bump, Template::Edge, Template::Sine] {
            for i in 0..=400 {
                let (x0, w, a) = (5.0, 1.5, 0.3);
                let x = 3.0 + 4.0 * i as f64 / 400.0 + 1e-3;
                let [h, h1, h2] = template.height_derivatives_mm(x, x0, w, a);
                let f = |x: f64| template.height_mm(x, x0, w, a);
                let d = 1e-5;
                assert!((h - f(x)).abs() < 1e-15, "{template:?} h at {x}");
                let fd1 = (f(x + d) - f(x - d)) / (2.0 * d);
                assert!((h1 - fd1).abs() < 1e-8, "{template:?} h' at {x}: {h1} vs {fd1}");
                let fd2 = (f(x + d) - 2.0 * f(x) + f(x - d)) / (d * d);
                // The edge's h'' jumps at the ends of its rise: skip those.
                let near_kink = template == Template::Edge && ((x - x0).abs() < d || (x - x0 + w).abs() < d);
                assert!(
                    near_kink || (h2 - fd2).abs() < 1e-4 * (1.0 + h2.abs()),
                    "{template:?} h'' at {x}: {h2} vs {fd2}"
                );
            }
        }
    }

    #[test]
    fn rfc3339_shape() {
        let t = utc_now_rfc3339();
        assert_eq!(t.len(), 20, "{t}");
        assert!(t.starts_with("20") && t.ends_with('Z'));
    }
}
