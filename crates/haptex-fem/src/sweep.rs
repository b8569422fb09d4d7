//! Building the FE database of template surfaces (`haptex db build` and
//! `haptex db merge`): the paper's sweep (section 3.1) of bump, edge and
//! sine over r_w and r_h, at several sliding velocities.
//!
//! Every run writes its own file `runs/<template>_w<r_w>_h<r_h>_v<v>.csv`
//! atomically once it is complete, so a build that is killed continues where
//! it stopped, and shards of the sweep (`--shard K/N`, one per job of a
//! cluster array) write disjoint sets of run files. Merging collects the
//! run files of one or more directories into the model matrices of
//! `haptex_core::database` and chooses the CAE widths by leave-one-out.
//! Runs are deterministic (each is single-threaded), so the database does
//! not depend on how the sweep was split.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use haptex_core::cae::{ModelMatrix, OptimizeOptions, optimize_widths};
use haptex_core::database::{self, Averaging, FeSettings, Grid, INPUTS, Metadata, Sweep, Template, TemplateEntry};
use haptex_core::io::{FileSet, OutputDir, Table, write_atomic};
use haptex_core::num::Num;
use rayon::prelude::*;
use sha2::{Digest, Sha256};

use crate::finger::{FingerModel, Resolution};
use crate::scenario::{Scenario, SimulationError, default_step_mm, run};
use crate::surface::SurfaceShape;

/// One simulation of the sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Run {
    pub template: Template,
    pub width_mm: f64,
    pub height_mm: f64,
    pub velocity_mm_s: f64,
}

impl Run {
    /// The run's file name in the `runs/` directory.
    pub fn file_name(&self) -> String {
        format!("{}_w{:.3}_h{:.3}_v{:.1}.csv", self.template.name(), self.width_mm, self.height_mm, self.velocity_mm_s)
    }

    /// The run in words, for messages: `bump r_w = 1.3 mm, r_h = 0.27 mm,
    /// v = 20 mm/s` (numbers quoted short whatever their size).
    pub fn describe(&self) -> String {
        format!(
            "{} r_w = {} mm, r_h = {} mm, v = {} mm/s",
            self.template.name(),
            Num(self.width_mm),
            Num(self.height_mm),
            Num(self.velocity_mm_s)
        )
    }

    /// The run's surface with its feature at `x0_mm`.
    pub fn surface(&self, x0_mm: f64) -> SurfaceShape {
        let (x0, width, height) = (x0_mm, self.width_mm, self.height_mm);
        match self.template {
            Template::Bump => SurfaceShape::Bump { x0, width, height },
            Template::Edge => SurfaceShape::Edge { x0, width, height },
            Template::Sine => SurfaceShape::Sine { x0, width, height },
        }
    }
}

/// Everything that defines a database.
#[derive(Debug, Clone)]
pub struct DatabaseSpec {
    pub sweep: Sweep,
    pub grid: Grid,
    pub model: FingerModel,
    /// Where the model came from and the text it was read from (for the
    /// metadata's provenance).
    pub model_source: String,
    pub model_text: String,
    pub resolution: Resolution,
    pub viscoelastic: bool,
    pub indent_mm: f64,
    pub press_time_s: f64,
    /// The feature's position in each run, and the slide: the grid xi must
    /// fall inside [step - x0, slide - x0] with a run-in before it.
    pub x0_mm: f64,
    pub slide_mm: f64,
    pub max_step_mm: f64,
    /// Average each run's Ft/Fn over two node spacings of the pad, from
    /// steps of a quarter node spacing ([`Averaging`]); false only for a
    /// database built before haptex averaged.
    pub averaged: bool,
}

impl DatabaseSpec {
    /// The paper's sweep (section 3.1): bump, edge and sine; r_w from 0.5 to
    /// 2.5 mm in 0.25 mm steps; r_h from 0.1 to 0.5 mm in 0.1 mm steps; at
    /// 10, 20, 50 and 100 mm/s. Profiles on xi = x - x0 from -5 to 5 mm
    /// every 0.02 mm (501 points); each run slides 11 mm over a feature at
    /// x0 = 6 mm, so the first millimetre (the onset of sliding) is not in
    /// the profile.
    pub fn paper() -> Self {
        let model = FingerModel::default_model();
        Self {
            sweep: Sweep {
                templates: Template::ALL.to_vec(),
                widths_mm: (0..9).map(|i| 0.5 + 0.25 * i as f64).collect(),
                // i / 10, not 0.1 i: 0.1 * 3 is 0.30000000000000004.
                heights_mm: (1..=5).map(|i| i as f64 / 10.0).collect(),
                velocities_mm_s: vec![10.0, 20.0, 50.0, 100.0],
            },
            grid: Grid { xi_min_mm: -5.0, xi_max_mm: 5.0, points: 501 },
            model,
            model_source: "data/finger/finger-2d.toml".into(),
            model_text: crate::finger::DEFAULT_MODEL_TOML.into(),
            resolution: Resolution::Default,
            viscoelastic: true,
            indent_mm: 0.25,
            press_time_s: 0.1,
            x0_mm: 6.0,
            slide_mm: 11.0,
            max_step_mm: 0.1,
            averaged: true,
        }
    }

    /// The averaging of the runs' profiles on this spec's mesh, if any.
    pub fn averaging(&self) -> Option<Averaging> {
        self.averaged.then(|| averaging_for(self.resolution.parameters().pad_spacing_mm))
    }

    /// All runs, in a fixed order (template, width, height, velocity).
    pub fn runs(&self) -> Vec<Run> {
        self.record().runs()
    }

    /// The sweep, grid and FE settings, as recorded in a build directory.
    pub fn record(&self) -> SweepRecord {
        SweepRecord { sweep: self.sweep.clone(), grid: self.grid, fe: self.fe_settings() }
    }

    /// The runs of shard `k` of `n` (1-based): every n-th run from the k-th.
    pub fn shard(&self, k: usize, n: usize) -> Vec<Run> {
        self.runs().into_iter().enumerate().filter(|(i, _)| i % n == k - 1).map(|(_, r)| r).collect()
    }

    /// The FE scenario of one run.
    pub fn scenario(&self, run: &Run) -> Scenario {
        let surface = run.surface(self.x0_mm);
        let mut scenario = Scenario::paper(surface.clone());
        scenario.model = self.model.clone();
        scenario.resolution = self.resolution;
        scenario.viscoelastic = self.viscoelastic;
        scenario.loading = crate::scenario::Loading::Indent(self.indent_mm);
        scenario.press_time_s = self.press_time_s;
        scenario.slide_mm = self.slide_mm;
        scenario.velocity_mm_s = run.velocity_mm_s;
        scenario.step_mm = default_step_mm(&surface).min(self.max_step_mm);
        if let Some(a) = self.averaging() {
            scenario.step_mm = scenario.step_mm.min(a.step_mm);
        }
        scenario
    }

    /// Checks everything a build needs before its first FE run: the grid
    /// (and that `merge` can name its columns), the sweep (non-empty,
    /// distinct run files, at least [`MIN_ROWS`] runs per template for the
    /// CAE), the finger model (it meshes), and every run's scenario
    /// (surface, steps, memory). `db merge` checks the same of the record
    /// it merges.
    pub fn validate(&self) -> Result<(), SweepError> {
        let record = self.record();
        record.validate()?;
        let g = &self.grid;
        let min_step = self.max_step_mm.min(self.sweep.widths_mm.iter().cloned().fold(f64::INFINITY, f64::min) / 10.0);
        if g.xi_min_mm + self.x0_mm < min_step.max(self.max_step_mm) || g.xi_max_mm + self.x0_mm > self.slide_mm + 1e-9
        {
            return Err(SweepError::Invalid(format!(
                "the grid xi = {} .. {} mm does not fit the slide 0 .. {} mm around x0 = {} mm",
                Num(g.xi_min_mm),
                Num(g.xi_max_mm),
                Num(self.slide_mm),
                Num(self.x0_mm)
            )));
        }
        self.model.validate().map_err(|e| SweepError::Invalid(format!("finger model {}: {e}", self.model_source)))?;
        for run in record.runs() {
            self.scenario(&run).validate().map_err(|error| SweepError::Run { run: run.describe(), error })?;
        }
        Ok(())
    }

    /// The FE settings for the metadata.
    fn fe_settings(&self) -> FeSettings {
        FeSettings {
            finger_model: self.model_source.clone(),
            finger_model_sha256: hex(&Sha256::digest(self.model_text.as_bytes())),
            mesh: self.resolution.name().to_string(),
            material: if self.viscoelastic { "viscoelastic" } else { "elastic" }.into(),
            indent_mm: self.indent_mm,
            press_time_s: self.press_time_s,
            x0_mm: self.x0_mm,
            slide_mm: self.slide_mm,
            max_step_mm: self.max_step_mm,
            mu_skin: self.model.contact.mu_skin,
            penalty_mpa_per_mm: Scenario::paper(SurfaceShape::Flat).penalty_mpa_per_mm,
            averaging: self.averaging(),
        }
    }
}

impl DatabaseSpec {
    /// The specification a database was built with, from its metadata: the
    /// same FE settings, for simulating a case that is not a database row.
    /// The finger model must be the shipped one the database recorded (its
    /// SHA-256 is compared).
    pub fn from_metadata(metadata: &Metadata) -> Result<Self, SweepError> {
        let mut spec = Self::paper();
        let fe = &metadata.fe;
        if hex(&Sha256::digest(spec.model_text.as_bytes())) != fe.finger_model_sha256 {
            return Err(SweepError::Invalid(format!(
                "the database was built with another finger model ({}, SHA-256 {}) than this haptex's",
                fe.finger_model, fe.finger_model_sha256
            )));
        }
        spec.sweep = metadata.sweep.clone();
        spec.grid = metadata.grid;
        spec.resolution = match fe.mesh.as_str() {
            "coarse" => Resolution::Coarse,
            "default" => Resolution::Default,
            "fine" => Resolution::Fine,
            "extra-fine" => Resolution::ExtraFine,
            other => return Err(SweepError::Invalid(format!("unknown mesh '{other}' in the metadata"))),
        };
        spec.viscoelastic = match fe.material.as_str() {
            "viscoelastic" => true,
            "elastic" => false,
            other => return Err(SweepError::Invalid(format!("unknown material '{other}' in the metadata"))),
        };
        spec.indent_mm = fe.indent_mm;
        spec.press_time_s = fe.press_time_s;
        spec.x0_mm = fe.x0_mm;
        spec.slide_mm = fe.slide_mm;
        spec.max_step_mm = fe.max_step_mm;
        spec.averaged = fe.averaging.is_some();
        if spec.fe_settings() != *fe {
            return Err(SweepError::Invalid(
                "the database's FE settings (skin friction, contact penalty, averaging) differ from this haptex's"
                    .into(),
            ));
        }
        Ok(spec)
    }

    /// Simulates one case with the database's settings: its profile on the
    /// database grid, as a database row would hold it (rounded to 6
    /// decimals like the run files).
    pub fn simulate(&self, run: &Run) -> Result<Vec<f64>, SweepError> {
        let result =
            run_scenario(&self.scenario(run)).map_err(|error| SweepError::Run { run: run.describe(), error })?;
        let profile = slid(&result, run)?;
        Ok(sample(profile, self, &self.grid.positions()).into_iter().map(|m| (m * 1e6).round() / 1e6).collect())
    }
}

/// What `build_runs` records in a build directory (`sweep.json`) so that
/// `merge` assembles the database the runs were made for.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SweepRecord {
    pub sweep: Sweep,
    pub grid: Grid,
    pub fe: FeSettings,
}

/// Fewest runs per template: a CAE model matrix needs two rows.
pub const MIN_ROWS: usize = 2;

/// Most runs in a sweep (the paper's has 540): a bound on the list of runs
/// a build enumerates.
pub const MAX_RUNS: usize = 1_000_000;

/// Most grid points: a model matrix row (3 inputs and one Ft/Fn per point,
/// ~9 bytes each) must stay under the CSV reader's 1 MiB line limit.
pub const MAX_GRID_POINTS: usize = 50_000;

impl SweepRecord {
    /// What `merge` needs of a record: a grid of finite, distinct positions
    /// whose column names (`mu@xi`, two decimals) are distinct; a sweep of
    /// positive finite values, every run with its own file name, and at
    /// least [`MIN_ROWS`] runs per template.
    pub fn validate(&self) -> Result<(), SweepError> {
        let invalid = |m: String| Err(SweepError::Invalid(m));
        let g = &self.grid;
        if g.points < 2 || !g.xi_min_mm.is_finite() || !g.xi_max_mm.is_finite() || g.xi_max_mm <= g.xi_min_mm {
            return invalid(format!(
                "grid xi = {} .. {} mm with {} points: needs at least 2 points over a finite range",
                Num(g.xi_min_mm),
                Num(g.xi_max_mm),
                g.points
            ));
        }
        if g.points > MAX_GRID_POINTS {
            return invalid(format!("grid of {} points: at most {MAX_GRID_POINTS}", g.points));
        }
        let names = g.column_names();
        let mut seen = std::collections::HashSet::with_capacity(names.len());
        if let Some(name) = names.iter().find(|n| !seen.insert(n.as_str())) {
            // Columns are named to 0.01 mm: positions must be 0.01 mm apart.
            let most = ((g.xi_max_mm - g.xi_min_mm) / 0.01 + 1e-9).floor() as usize + 1;
            return invalid(format!(
                "grid of {} points over xi = {} .. {} mm: the database names its columns mu@<xi> to 0.01 mm, and \
                 positions closer than that share a name ({name} twice); at most {most} points",
                g.points,
                Num(g.xi_min_mm),
                Num(g.xi_max_mm)
            ));
        }
        let s = &self.sweep;
        if s.templates.is_empty() || s.widths_mm.is_empty() || s.heights_mm.is_empty() || s.velocities_mm_s.is_empty() {
            return invalid("the sweep is empty: it needs templates, widths, heights and velocities".into());
        }
        for (name, values) in [("width", &s.widths_mm), ("height", &s.heights_mm), ("velocity", &s.velocities_mm_s)] {
            if let Some(v) = values.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
                return invalid(format!("sweep {name} {} is not a positive number", Num(*v)));
            }
        }
        let per_template = s.widths_mm.len().saturating_mul(s.heights_mm.len()).saturating_mul(s.velocities_mm_s.len());
        let total = per_template.saturating_mul(s.templates.len());
        if total > MAX_RUNS {
            return invalid(format!(
                "the sweep has {} templates x {} widths x {} heights x {} velocities = {} runs; at most {MAX_RUNS}",
                s.templates.len(),
                s.widths_mm.len(),
                s.heights_mm.len(),
                s.velocities_mm_s.len(),
                if total == usize::MAX { "more than 10^19".to_string() } else { total.to_string() }
            ));
        }
        if per_template < MIN_ROWS {
            return invalid(format!(
                "the sweep has {per_template} run per template ({} width x {} height x {} velocity); the database's \
                 CAE needs at least {MIN_ROWS} (give more widths, heights or velocities)",
                s.widths_mm.len(),
                s.heights_mm.len(),
                s.velocities_mm_s.len()
            ));
        }
        let runs = self.runs();
        let mut names = std::collections::HashMap::with_capacity(runs.len());
        for run in &runs {
            let name = run.file_name();
            if name.len() > 200 {
                return invalid(format!("run file name too long ({} bytes): {}...", name.len(), &name[..60]));
            }
            if let Some(other) = names.insert(name.clone(), run) {
                return invalid(format!(
                    "two runs share the file name {name} (r_w {} and {} mm, r_h {} and {} mm, v {} and {} mm/s): run \
                     files name widths and heights to 0.001 mm and velocities to 0.1 mm/s",
                    Num(other.width_mm),
                    Num(run.width_mm),
                    Num(other.height_mm),
                    Num(run.height_mm),
                    Num(other.velocity_mm_s),
                    Num(run.velocity_mm_s)
                ));
            }
        }
        Ok(())
    }

    fn read(dir: &Path) -> Result<Self, SweepError> {
        let path = dir.join("sweep.json");
        let text = std::fs::read_to_string(&path)
            .map_err(|e| SweepError::File { path: path.clone(), message: e.to_string() })?;
        serde_json::from_str(&text).map_err(|e| SweepError::File { path, message: format!("line {}: {e}", e.line()) })
    }

    /// All runs of the record's sweep.
    fn runs(&self) -> Vec<Run> {
        let s = &self.sweep;
        let mut runs = Vec::new();
        for &template in &s.templates {
            for &width_mm in &s.widths_mm {
                for &height_mm in &s.heights_mm {
                    for &velocity_mm_s in &s.velocities_mm_s {
                        runs.push(Run { template, width_mm, height_mm, velocity_mm_s });
                    }
                }
            }
        }
        runs
    }
}

/// A sweep failed.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    #[error("{0}")]
    Invalid(String),
    /// A run failed (or would): `run` describes it, `error` says why (its
    /// text is part of this error's, not a separate source).
    #[error("run {run}: {error}")]
    Run { run: String, error: SimulationError },
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
    #[error("{0}")]
    Database(#[from] database::DatabaseError),
    #[error("{0}")]
    Cae(#[from] haptex_core::cae::CaeError),
    #[error(transparent)]
    Write(#[from] haptex_core::io::WriteError),
    #[error("missing runs ({count}), e.g. {example}: build them (or merge every shard's directory)")]
    MissingRuns { count: usize, example: String },
}

/// What a build did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BuildReport {
    pub runs_total: usize,
    pub runs_done_before: usize,
    pub runs_computed: usize,
    pub wall_time_s: f64,
    pub cpu_time_s: f64,
}

/// Runs the simulations of `runs` that have no file in `dir/runs` yet, on
/// `jobs` threads (one FE run per thread), calling `progress(done, total)`
/// after each. Each finished run is written atomically.
pub fn build_runs(
    spec: &DatabaseSpec,
    runs: &[Run],
    dir: &Path,
    jobs: usize,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<BuildReport, SweepError> {
    spec.validate()?;
    let started = Instant::now();
    let runs_dir = dir.join("runs");
    std::fs::create_dir_all(&runs_dir)
        .map_err(|e| SweepError::File { path: runs_dir.clone(), message: e.to_string() })?;
    // Every run will write here, and the merge beside it: find out now, not
    // after the first run.
    for d in [dir, runs_dir.as_path()] {
        probe_writable(d)?;
    }
    // The build directory records its sweep; resuming with another sweep
    // would mix runs of different settings.
    let record = spec.record();
    if dir.join("sweep.json").exists() {
        let existing = SweepRecord::read(dir)?;
        if existing != record {
            return Err(SweepError::File {
                path: dir.join("sweep.json"),
                message: "this directory holds runs of a different sweep or FE set-up; use another --out".into(),
            });
        }
    } else {
        let json = serde_json::to_string_pretty(&record).expect("record serializes");
        write_atomic(&dir.join("sweep.json"), |w| writeln!(w, "{json}"))?;
    }
    let runs_out = OutputDir::create(&runs_dir)?;
    let pending: Vec<&Run> = runs.iter().filter(|r| !runs_dir.join(r.file_name()).exists()).collect();
    let done_before = runs.len() - pending.len();
    let done = AtomicUsize::new(done_before);
    progress(done_before, runs.len());
    let cpu = Mutex::new(0.0f64);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.max(1))
        .build()
        .map_err(|e| SweepError::Invalid(format!("cannot start {jobs} threads: {e}")))?;
    pool.install(|| {
        pending.par_iter().try_for_each(|run| -> Result<(), SweepError> {
            let scenario = spec.scenario(run);
            let result = run_scenario(&scenario).map_err(|error| SweepError::Run { run: run.describe(), error })?;
            let mu = sample(slid(&result, run)?, spec, &spec.grid.positions());
            // Each run's file checked inside runs/ as every multi-file output's is.
            runs_out.write(&run.file_name(), |w| write_run(w, run, &spec.grid, &mu, result.statistics.wall_time_s))?;
            *cpu.lock().expect("no panics while holding the lock") += result.statistics.wall_time_s;
            progress(done.fetch_add(1, Ordering::SeqCst) + 1, runs.len());
            Ok(())
        })
    })?;
    Ok(BuildReport {
        runs_total: runs.len(),
        runs_done_before: done_before,
        runs_computed: pending.len(),
        wall_time_s: started.elapsed().as_secs_f64(),
        cpu_time_s: cpu.into_inner().unwrap_or(0.0),
    })
}

/// Creates and removes a file in `dir`, or says why it cannot.
fn probe_writable(dir: &Path) -> Result<(), SweepError> {
    let probe = dir.join(format!(".haptex-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"")
        .and_then(|()| std::fs::remove_file(&probe))
        .map_err(|e| SweepError::File { path: dir.into(), message: format!("cannot write here: {e}") })
}

fn run_scenario(scenario: &Scenario) -> Result<crate::scenario::SimulationResult, SimulationError> {
    run(scenario, &mut |_| {})
}

/// The profile sampled at xi + x0 by linear interpolation.
/// The profile of a run (a database's runs always slide: their grid must
/// fit the slide, checked when the spec is read).
fn slid<'a>(
    result: &'a crate::scenario::SimulationResult,
    run: &Run,
) -> Result<&'a haptex_core::FrictionProfile, SweepError> {
    result.profile.as_ref().ok_or_else(|| SweepError::Invalid(format!("{}: the run did not slide", run.describe())))
}

fn sample(profile: &haptex_core::FrictionProfile, spec: &DatabaseSpec, xi: &[f64]) -> Vec<f64> {
    match spec.averaging() {
        Some(a) => {
            let x: Vec<f64> = xi.iter().map(|xi| xi + spec.x0_mm).collect();
            moving_average(profile.x_mm(), profile.mu(), a.window_mm, &x)
        }
        None => xi.iter().map(|xi| profile.mu_at(xi + spec.x0_mm)).collect(),
    }
}

/// The averaging of a database on a pad mesh of node spacing `pad_mm`:
/// steps of a quarter spacing (the node passing's first three harmonics
/// then either lie below the sampling's Nyquist frequency or alias onto
/// zeros of the average), a window of two spacings.
pub fn averaging_for(pad_mm: f64) -> Averaging {
    Averaging { step_mm: pad_mm / 4.0, window_mm: 2.0 * pad_mm }
}

/// The mean of the piecewise-linear function through (`x`, `y`) (`x`
/// increasing) over [q - window/2, q + window/2] for each q, the window cut
/// to [x_first, x_last]; at a window of no width, the value at q. From the
/// cumulative trapezoid integral, with a binary search per window end.
pub fn moving_average(x: &[f64], y: &[f64], window_mm: f64, at: &[f64]) -> Vec<f64> {
    debug_assert_eq!(x.len(), y.len());
    let (Some(&first), Some(&last)) = (x.first(), x.last()) else { return vec![f64::NAN; at.len()] };
    let mut integral = Vec::with_capacity(x.len());
    let mut sum = 0.0;
    integral.push(0.0);
    for i in 1..x.len() {
        sum += 0.5 * (y[i] + y[i - 1]) * (x[i] - x[i - 1]);
        integral.push(sum);
    }
    // The integral and the value at t, by linear interpolation.
    let locate = |t: f64| -> (f64, f64) {
        let t = t.clamp(first, last);
        let i = x.partition_point(|&v| v <= t).clamp(1, x.len().max(2) - 1);
        if x.len() == 1 {
            return (0.0, y[0]);
        }
        let (x0, x1) = (x[i - 1], x[i]);
        let s = if x1 > x0 { (t - x0) / (x1 - x0) } else { 0.0 };
        let value = y[i - 1] + s * (y[i] - y[i - 1]);
        (integral[i - 1] + 0.5 * (y[i - 1] + value) * (t - x0), value)
    };
    at.iter()
        .map(|&q| {
            let lo = (q - 0.5 * window_mm).max(first);
            let hi = (q + 0.5 * window_mm).min(last);
            if hi - lo <= 1e-12 { locate(q).1 } else { (locate(hi).0 - locate(lo).0) / (hi - lo) }
        })
        .collect()
}

/// A run file: its parameters as comments, then `xi_mm,mu`. Values are
/// written with 6 decimals (the FE profile's accuracy is ~1e-3).
fn write_run(w: &mut dyn Write, run: &Run, grid: &Grid, mu: &[f64], wall_time_s: f64) -> std::io::Result<()> {
    writeln!(w, "# template={}", run.template.name())?;
    writeln!(w, "# r_w_mm={}", run.width_mm)?;
    writeln!(w, "# r_h_mm={}", run.height_mm)?;
    writeln!(w, "# velocity_mm_s={}", run.velocity_mm_s)?;
    writeln!(w, "# wall_time_s={wall_time_s}")?;
    writeln!(w, "xi_mm,mu")?;
    for (xi, m) in grid.positions().iter().zip(mu) {
        writeln!(w, "{xi:.4},{m:.6}")?;
    }
    Ok(())
}

/// The profile of a run file on `grid`, and the run's FE wall time (s).
pub(crate) fn read_run_profile(path: &Path, grid: &Grid) -> Result<(Vec<f64>, f64), SweepError> {
    read_run(path, grid)
}

/// Reads a run file: the profile and the wall time recorded in it.
fn read_run(path: &Path, grid: &Grid) -> Result<(Vec<f64>, f64), SweepError> {
    let table = Table::read_file(path).map_err(database::DatabaseError::from_table)?;
    let mu = table.require("mu").map_err(database::DatabaseError::from_table)?.to_vec();
    if mu.len() != grid.points {
        return Err(SweepError::File {
            path: path.into(),
            message: format!("{} points, the grid has {} (built with another grid?)", mu.len(), grid.points),
        });
    }
    let text =
        std::fs::read_to_string(path).map_err(|e| SweepError::File { path: path.into(), message: e.to_string() })?;
    let wall =
        text.lines().find_map(|l| l.strip_prefix("# wall_time_s=")).and_then(|v| v.trim().parse().ok()).unwrap_or(0.0);
    Ok((mu, wall))
}

/// Collects the runs of `sources` (directories with a `runs/` folder) into
/// the database in `out`: one model matrix per template, written with 6
/// decimals, and `metadata.json` with the LOO-optimal widths.
pub fn merge(sources: &[PathBuf], out: &Path, build_wall_time_s: Option<f64>) -> Result<Metadata, SweepError> {
    let Some(first) = sources.first() else {
        return Err(SweepError::Invalid("nothing to merge: give at least one build directory".into()));
    };
    let record = SweepRecord::read(first)?;
    for source in &sources[1..] {
        if SweepRecord::read(source)? != record {
            return Err(SweepError::File {
                path: source.join("sweep.json"),
                message: format!("a different sweep or FE set-up than {}", first.join("sweep.json").display()),
            });
        }
    }
    record.validate()?;
    let grid = record.grid;
    // Every run of every template, before anything is written.
    let mut cpu_time_s = 0.0;
    let mut missing = Vec::new();
    let mut tables = Vec::new();
    for &template in &record.sweep.templates {
        let runs: Vec<Run> = record.runs().into_iter().filter(|r| r.template == template).collect();
        let mut rows: Vec<(Run, Vec<f64>)> = Vec::with_capacity(runs.len());
        for run in runs {
            let found = sources.iter().map(|d| d.join("runs").join(run.file_name())).find(|p| p.exists());
            match found {
                Some(path) => {
                    let (mu, wall) = read_run(&path, &grid)?;
                    cpu_time_s += wall;
                    rows.push((run, mu));
                }
                None => missing.push(run.file_name()),
            }
        }
        tables.push((template, rows));
    }
    if !missing.is_empty() {
        return Err(SweepError::MissingRuns { count: missing.len(), example: missing[0].clone() });
    }
    // Each template's model matrix as it will be written (6 decimals), and
    // its LOO-optimal widths on that matrix; then the files.
    let columns = grid.column_names();
    let mut entries = Vec::new();
    let mut texts = Vec::new();
    for (template, rows) in &tables {
        let mut text = Vec::new();
        write_matrix(&mut text, *template, &columns, rows).map_err(|e| SweepError::Invalid(e.to_string()))?;
        let file = template.file_name();
        let matrix = ModelMatrix::read_csv(text.as_slice(), &out.join(&file).display().to_string(), &INPUTS)?;
        let optimum = optimize_widths(&matrix, OptimizeOptions::default())?;
        entries.push(TemplateEntry {
            template: *template,
            file: file.clone(),
            rows: matrix.n(),
            widths: optimum.widths,
            loo_rmse: optimum.errors.rmse,
            loo_rmse_relative_to_range: database::relative_loo_error(&matrix, &optimum.errors),
            constant_width: optimum.report.constant.w,
            constant_width_rmse: optimum.report.constant.rmse,
        });
        texts.push((file, text));
    }
    // The database is a file set: metadata.json is removed now and written
    // last with the SHA-256 of every matrix, so an interrupted merge leaves
    // a directory that reads as incomplete, never a mix of old and new.
    let mut set = FileSet::begin(out, "metadata.json")?;
    for (file, text) in &texts {
        set.write(file, |w| w.write_all(text))?;
    }
    let metadata = Metadata {
        format: database::FORMAT.into(),
        haptex_version: env!("CARGO_PKG_VERSION").into(),
        created: database::utc_now_rfc3339(),
        cpu_time_s,
        build_wall_time_s,
        grid,
        sweep: record.sweep.clone(),
        fe: record.fe.clone(),
        templates: entries,
        files_sha256: Some(set.members().clone()),
        // A new database has not been measured on random members yet, and
        // serves the paper's CAE until one is chosen by measuring it
        // (`haptex db validate --estimator E --record`).
        validation: None,
        estimator: None,
        refined: None,
    };
    let json = serde_json::to_string_pretty(&metadata).expect("metadata serializes");
    set.finish(|w, _| writeln!(w, "{json}"))?;
    Ok(metadata)
}

/// A template's model matrix: a comment, the header, one row per run.
pub(crate) fn write_matrix(
    w: &mut dyn Write,
    template: Template,
    columns: &[String],
    rows: &[(Run, Vec<f64>)],
) -> std::io::Result<()> {
    writeln!(
        w,
        "# haptex FE database, {} template: inputs {}, outputs Ft/Fn at xi = x - x0 (mm)",
        template.name(),
        INPUTS.join(",")
    )?;
    writeln!(w, "{},{}", INPUTS.join(","), columns.join(","))?;
    for (run, mu) in rows {
        write!(w, "{},{},{}", run.width_mm, run.height_mm, run.velocity_mm_s)?;
        for m in mu {
            write!(w, ",{m:.6}")?;
        }
        writeln!(w)?;
    }
    Ok(())
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples(step: f64, until: f64, f: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
        let n = (until / step).round() as usize;
        let x: Vec<f64> = (0..=n).map(|i| i as f64 * step).collect();
        let y = x.iter().map(|&x| f(x)).collect();
        (x, y)
    }

    #[test]
    fn moving_average_of_a_line_is_the_line_inside_and_its_half_window_mean_at_the_ends() {
        // The centred mean of a + b x over a window inside the data is a + b q
        // exactly (the trapezoid rule is exact on the piecewise-linear data).
        let (x, y) = samples(0.0125, 11.0, |x| 0.3 + 0.02 * x);
        let q = [1.0, 5.55, 10.95];
        let avg = moving_average(&x, &y, 0.1, &q);
        for (a, q) in avg.iter().zip(q) {
            assert!((a - (0.3 + 0.02 * q)).abs() < 1e-12, "{a} at {q}");
        }
        // At the slide's ends the window is cut: at x = 11 it covers 10.95 .. 11.
        let end = moving_average(&x, &y, 0.1, &[11.0])[0];
        assert!((end - (0.3 + 0.02 * 10.975)).abs() < 1e-12, "{end}");
        // No window: the linear interpolant's value.
        let at = moving_average(&x, &y, 0.0, &[3.00625])[0];
        assert!((at - (0.3 + 0.02 * 3.00625)).abs() < 1e-12, "{at}");
    }

    #[test]
    fn moving_average_over_its_wavelength_removes_an_oscillation_and_keeps_a_slow_one_by_the_sinc() {
        // A node-passing oscillation of wavelength h = 0.05 mm on a grating's
        // slow one (1.25 mm). The window 2h removes the first (its mean over
        // two wavelengths is 0; the trapezoid rule on steps of h/4 is exact
        // for the sampled sine's mean over whole periods up to rounding) and
        // scales the second by sinc(pi 2h / L) = 0.9747 (the analytic box
        // response, to 1e-3 for the piecewise-linear data's own error
        // (pi/50)^2/6 ~ 7e-4 of the amplitude).
        let h = 0.05;
        let (l, a_slow, a_node) = (1.25, 0.02, 0.04);
        let node = |x: f64| a_node * (2.0 * std::f64::consts::PI * x / h).sin();
        let slow = |x: f64| a_slow * (2.0 * std::f64::consts::PI * x / l).sin();
        let a = averaging_for(h);
        assert_eq!((a.step_mm, a.window_mm), (0.0125, 0.1));
        let (x, y) = samples(a.step_mm, 11.0, |x| 0.5 + slow(x) + node(x));
        let q: Vec<f64> = (0..=400).map(|i| 1.0 + i as f64 * 0.02).collect();
        let avg = moving_average(&x, &y, a.window_mm, &q);
        let arg = std::f64::consts::PI * a.window_mm / l;
        let sinc = arg.sin() / arg;
        let worst = q.iter().zip(&avg).map(|(&q, v)| (v - (0.5 + sinc * slow(q))).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-3 * a_slow + 1e-9, "largest deviation {worst}");
        // Sampled at steps of 2h instead, the oscillation aliases: every
        // sample sits at the same phase of it, here its zero crossing, but at
        // a spacing 4% off h (the deformed pad's, measured) it drifts
        // through its whole amplitude.
        let (x, y) =
            samples(2.0 * h, 11.0, |x| 0.5 + slow(x) + a_node * (2.0 * std::f64::consts::PI * x / 0.048).sin());
        let raw = moving_average(&x, &y, 0.0, &q);
        let worst_raw = q.iter().zip(&raw).map(|(&q, v)| (v - (0.5 + slow(q))).abs()).fold(0.0, f64::max);
        assert!(worst_raw > 0.5 * a_node, "aliased deviation {worst_raw}");
    }
}
