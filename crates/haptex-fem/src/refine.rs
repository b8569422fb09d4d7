//! Growing a database where its estimate is wrong (`haptex db refine`):
//! the paper's "the database will be developed in time", with FE runs
//! placed by the estimate's own error.
//!
//! A template's rows form a full grid of r_w x r_h x velocity, and the
//! database serves multilinear interpolation over it (or the CAE). Each
//! round:
//!
//! 1. For every interior value a_i of an axis, the rows at a_i are predicted
//!    by interpolating linearly between the rows at a_{i-1} and a_{i+1}
//!    (the grid's leave-one-line-out error), each as its RMS relative to
//!    the row's range (max - min), as `db validate` measures; the value's
//!    error is the largest over its rows.
//! 2. Each interval (a_i, a_{i+1}) is scored by the larger error of its two
//!    ends, divided by 4: those errors are of interpolation across twice
//!    the spacing, and linear interpolation's error grows with the square
//!    of the spacing where the profiles are smooth in the input (the
//!    held-out error of step 3 measures whether they are). An axis of two
//!    values is scored infinite: nothing measures it.
//!    The worst interval above the target gets a new value at its middle:
//!    one FE run for every combination of the other axes' values, so the
//!    rows stay a full grid.
//! 3. Before those rows are added, the estimate of the database as it was
//!    is compared with them: the held-out error of the interval, reported
//!    per round and recorded in the metadata.
//!
//! It stops when no interval scores above the target, when the next round
//! would exceed the budget of runs, or when the worst interval cannot be
//! split at the run files' resolution (0.001 mm, 0.1 mm/s). Runs are
//! written to `DIR/runs` as `db build` writes them, so an interrupted
//! refinement continues where it stopped: the rounds are deterministic,
//! and a round whose runs are already there costs only reading them.
//!
//! On a cluster ([`Mode`]): the rounds are sequential (each is chosen by
//! the rows of the last), but a round's runs are independent. Each task of
//! a job array replays the rounds whose runs are there and computes its
//! shard of the first round that lacks some ([`Mode::Shard`]), writing
//! nothing else; [`Mode::Plan`] counts the runs that round still lacks
//! (0 once every round's runs are there). A driver submits one array per
//! round until the count is 0, then one refinement in [`Mode::Write`]
//! (which then only reads the runs) writes the database: the same bytes
//! as a refinement on one machine.

use std::collections::HashMap;
use std::path::Path;

use haptex_core::cae::{ModelMatrix, OptimizeOptions, optimize_widths};
use haptex_core::database::{self, INPUTS, Metadata, RefineRound, Template};
use haptex_core::io::FileSet;

use crate::sweep::{DatabaseSpec, Run, SweepError, build_runs, read_run_profile, write_matrix};

/// Which inputs a refinement may split, in the model matrix's order.
pub const AXES: [&str; 3] = ["width", "height", "velocity"];

/// What to refine and how far.
#[derive(Debug, Clone)]
pub struct RefineOptions {
    pub template: Template,
    /// Indices into [`AXES`] that may get new values.
    pub axes: Vec<usize>,
    /// Stop when every interval's leave-one-line-out error, relative to the
    /// profiles' range, is at most this.
    pub target: f64,
    /// Most FE runs to add.
    pub budget: usize,
    pub jobs: usize,
    pub mode: Mode,
    /// Measure the errors (scores and held-out) on the rows whose crests
    /// the database's mesh resolves only ([`haptex_core::crests`]: a sine's
    /// rows with crests of radius at least 5 pad spacings; every row of the
    /// other templates): elsewhere the FE rows are not mesh-converged, and
    /// their errors are the mesh's, which more rows cannot reduce.
    pub resolved_only: bool,
}

/// What a refinement does with the first round whose runs are not all in
/// `DIR/runs`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Computes them, and every later round's; writes the database.
    Write,
    /// Computes shard K of N of them (1-based: the round's runs K, K+N,
    /// ...), then stops; writes nothing but run files.
    Shard(usize, usize),
    /// Counts them and stops; computes and writes nothing.
    Plan,
}

/// One round's outcome, for the report.
#[derive(Debug, Clone, PartialEq)]
pub struct Round {
    pub record: RefineRound,
}

/// Why a refinement stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// No interval's score is above the target.
    TargetMet,
    /// The next round would have spent more runs than the budget allows.
    Budget,
    /// The worst interval is too narrow to split at the run files' resolution.
    Resolution,
    /// Every interval above the target lies where halving the spacing did
    /// not halve the held-out error ([`converging`]).
    NotConverging,
    /// ([`Mode::Shard`], [`Mode::Plan`]) A round lacks runs: its shard was
    /// computed, or they were counted ([`RefineReport::pending`]).
    Pending,
}

/// What a refinement did.
#[derive(Debug, Clone)]
pub struct RefineReport {
    pub rounds: Vec<RefineRound>,
    pub stop: Stop,
    /// The worst interval's score when it stopped.
    pub worst_score: f64,
    pub runs_added: usize,
    /// The runs the first incomplete round lacked ([`Stop::Pending`]; 0
    /// otherwise), and how many of them this call computed.
    pub pending: usize,
    pub computed: usize,
    pub metadata: Metadata,
}

/// A template's rows: inputs (r_w, r_h, v) and the profile.
struct Rows {
    rows: Vec<([f64; 3], Vec<f64>)>,
}

impl Rows {
    fn read(path: &Path) -> Result<Self, SweepError> {
        let matrix = ModelMatrix::read_csv_file(path, &INPUTS)?;
        let rows = (0..matrix.n())
            .map(|n| {
                let i = matrix.input_row(n);
                ([i[0], i[1], i[2]], matrix.output_row(n).to_vec())
            })
            .collect();
        Ok(Self { rows })
    }

    fn axis_values(&self, axis: usize) -> Vec<f64> {
        let mut v: Vec<f64> = self.rows.iter().map(|r| r.0[axis]).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    }

    fn index(&self) -> HashMap<[u64; 3], usize> {
        self.rows.iter().enumerate().map(|(n, r)| (r.0.map(f64::to_bits), n)).collect()
    }

    fn matrix(&self, columns: &[String]) -> Result<ModelMatrix, SweepError> {
        let b = self.rows.iter().flat_map(|r| r.0).collect();
        let c = self.rows.iter().flat_map(|r| r.1.iter().copied()).collect();
        Ok(ModelMatrix::new(INPUTS.iter().map(|s| s.to_string()).collect(), columns.to_vec(), b, c)?)
    }

    fn sort(&mut self) {
        self.rows
            .sort_by(|a, b| a.0[0].total_cmp(&b.0[0]).then(a.0[1].total_cmp(&b.0[1])).then(a.0[2].total_cmp(&b.0[2])));
    }
}

/// RMS of `estimate - fe` relative to the range of `fe` (the RMS itself
/// for a flat profile).
pub fn relative_error(estimate: &[f64], fe: &[f64]) -> (f64, f64, f64) {
    let n = fe.len().max(1) as f64;
    let rms = (estimate.iter().zip(fe).map(|(e, f)| (e - f) * (e - f)).sum::<f64>() / n).sqrt();
    let (lo, hi) = fe.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let range = hi - lo;
    (rms, range, if range > 0.0 { rms / range } else { rms })
}

/// The leave-one-line-out error of every interior value of `axis`: the
/// largest relative error over the rows at that value, predicted between
/// their neighbours along the axis. Indexed like the axis's values; the
/// ends get `None`. With `phase` (the positions' start and step, for a
/// sine along r_w, its period) the neighbours are blended in phase, as the
/// grid estimate blends them ([`Template::grid_interpolation`]).
fn line_errors(
    rows: &Rows,
    axis: usize,
    counts: &dyn Fn(&[f64; 3]) -> bool,
    phase: Option<(f64, f64)>,
) -> Result<Vec<Option<f64>>, SweepError> {
    let values = rows.axis_values(axis);
    let index = rows.index();
    let mut out = vec![None; values.len()];
    for i in 1..values.len().saturating_sub(1) {
        let (a, b) = (values[i - 1], values[i + 1]);
        let t = (values[i] - a) / (b - a);
        let mut worst: f64 = 0.0;
        for (inputs, fe) in rows.rows.iter().filter(|r| r.0[axis] == values[i] && counts(&r.0)) {
            let at = |v: f64| {
                let mut k = *inputs;
                k[axis] = v;
                index.get(&k.map(f64::to_bits)).map(|&n| &rows.rows[n].1)
            };
            let (Some(lo), Some(hi)) = (at(a), at(b)) else {
                return Err(SweepError::Invalid(format!(
                    "the rows are not a full grid: r_w {}, r_h {}, v {} has no neighbour along the {}",
                    inputs[0], inputs[1], inputs[2], AXES[axis]
                )));
            };
            let estimate: Vec<f64> = match phase {
                Some((start, step)) => {
                    let mut e = vec![0.0; fe.len()];
                    haptex_core::grid::add_in_phase(lo, start, step, a, values[i], 1.0 - t, &mut e);
                    haptex_core::grid::add_in_phase(hi, start, step, b, values[i], t, &mut e);
                    e
                }
                None => lo.iter().zip(hi).map(|(l, h)| (1.0 - t) * l + t * h).collect(),
            };
            worst = worst.max(relative_error(&estimate, fe).2);
        }
        out[i] = Some(worst);
    }
    Ok(out)
}

/// Halving the spacing divides linear interpolation's error by this, where
/// the profiles are smooth in the input: the leave-one-line-out error,
/// across twice an interval's spacing, is this many times the interval's.
const SPACING_SQUARED: f64 = 4.0;

/// The resolution of run file names along each axis (`Run::file_name`).
const RESOLUTION: [f64; 3] = [1e-3, 1e-3, 0.1];

/// The value a new line gets between `a` and `b` on `axis`: their middle,
/// rounded to the run files' resolution; `None` if that is not strictly
/// between them.
fn middle(axis: usize, a: f64, b: f64) -> Option<f64> {
    let r = RESOLUTION[axis];
    let m = ((0.5 * (a + b)) / r).round() * r;
    // Rounded to the decimals a file name shows, so the value and its file agree.
    let m = format!("{:.*}", if axis == 2 { 1 } else { 3 }, m).parse::<f64>().ok()?;
    (m - a > 0.5 * r && b - m > 0.5 * r).then_some(m)
}

/// Refines `options.template` of the database in `dir`, in place: FE runs
/// go to `dir/runs`, and the database is rewritten as a whole (a file set,
/// as `db merge` writes it) once the rounds are done. `progress` is told
/// each round's runs as they finish, and `round` each round as it ends.
pub fn refine(
    dir: &Path,
    options: &RefineOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
    round_done: &mut dyn FnMut(&RefineRound),
) -> Result<RefineReport, SweepError> {
    let metadata = Metadata::read(dir)?;
    let spec = DatabaseSpec::from_metadata(&metadata)?;
    let entry = metadata
        .entry(options.template)
        .ok_or_else(|| SweepError::Invalid(format!("the database has no {} template", options.template.name())))?
        .clone();
    // The matrices as they are (their hashes checked when loaded).
    for e in &metadata.templates {
        haptex_core::database::TemplateModel::load_with(dir, &metadata, e.template)?;
    }
    if !(options.target.is_finite() && options.target > 0.0) {
        return Err(SweepError::Invalid(format!("target {} is not a positive number", options.target)));
    }
    let mut rows = Rows::read(&dir.join(&entry.file))?;
    let columns = metadata.grid.column_names();
    options
        .template
        .grid_interpolation(&rows.matrix(&columns)?, &metadata.grid)
        .map_err(|e| SweepError::Invalid(format!("{}: refine needs a full grid: {e}", entry.file)))?;
    let mut rounds: Vec<RefineRound> = Vec::new();
    // Every round so far, the database's earlier refinements first: which
    // splits made an interval, and whether they converged.
    let mut history: Vec<RefineRound> = metadata.refined.clone().unwrap_or_default();
    let mut added = 0usize;
    let mut cpu_time_s = 0.0;
    // The rows whose errors count.
    let mesh = metadata.fe.mesh.clone();
    let counts = |inputs: &[f64; 3]| {
        !options.resolved_only || options.template.crests_resolved(&mesh, inputs[0], inputs[1]) != Some(false)
    };
    // Along a sine's period the rows are blended in phase, as the grid
    // estimate blends them.
    let phase = |axis: usize| {
        options
            .template
            .phase(&metadata.grid)
            .filter(|&(input, ..)| input == axis)
            .map(|(_, start, step)| (start, step))
    };
    let (stop, worst_score) = loop {
        // Score every interval of every axis that may be split.
        let mut best: Option<(f64, usize, f64, f64)> = None;
        // The worst score of the intervals where splitting stopped helping.
        let mut frozen = 0.0f64;
        for &axis in &options.axes {
            let values = rows.axis_values(axis);
            if values.len() < 2 {
                continue;
            }
            let lines = line_errors(&rows, axis, &counts, phase(axis))?;
            for j in 0..values.len() - 1 {
                let score = match (lines[j], lines[j + 1]) {
                    (None, None) => f64::INFINITY,
                    (a, b) => a.unwrap_or(0.0).max(b.unwrap_or(0.0)) / SPACING_SQUARED,
                };
                if !converging(&history, options.template, AXES[axis], values[j], values[j + 1]) {
                    frozen = frozen.max(score);
                    continue;
                }
                if best.is_none_or(|(s, ..)| score > s) {
                    best = Some((score, axis, values[j], values[j + 1]));
                }
            }
        }
        let best_score = best.map_or(0.0, |b| b.0);
        if best_score <= options.target {
            break if frozen > options.target { (Stop::NotConverging, frozen) } else { (Stop::TargetMet, best_score) };
        }
        let Some((score, axis, a, b)) = best else { unreachable!("a score above the target has an interval") };
        let Some(value) = middle(axis, a, b) else { break (Stop::Resolution, score) };
        let others: Vec<Vec<f64>> = (0..3).map(|k| rows.axis_values(k)).collect();
        let mut runs = Vec::new();
        let choices = |k: usize| if k == axis { vec![value] } else { others[k].clone() };
        for &w in &choices(0) {
            for &h in &choices(1) {
                for &v in &choices(2) {
                    runs.push(Run { template: options.template, width_mm: w, height_mm: h, velocity_mm_s: v });
                }
            }
        }
        if added + runs.len() > options.budget {
            break (Stop::Budget, score);
        }
        // A task of an array (or --plan) stops at the first round that
        // lacks runs; the refinement that writes computes them.
        let pending = match options.mode {
            Mode::Write => 0,
            _ => runs.iter().filter(|r| !dir.join("runs").join(r.file_name()).exists()).count(),
        };
        let computed = match options.mode {
            Mode::Write => {
                build_runs(&spec, &runs, dir, options.jobs, progress)?;
                None
            }
            _ if pending == 0 => None,
            Mode::Plan => Some(0),
            Mode::Shard(k, n) => {
                // The round's runs K, K+N, ...: every task of the array
                // derives the same round, so the shards partition it.
                let shard: Vec<Run> =
                    runs.iter().enumerate().filter(|(i, _)| i % n == k - 1).map(|(_, r)| *r).collect();
                Some(build_runs(&spec, &shard, dir, options.jobs, progress)?.runs_computed)
            }
        };
        if let Some(computed) = computed {
            return Ok(RefineReport {
                rounds,
                stop: Stop::Pending,
                worst_score: score,
                runs_added: added,
                pending,
                computed,
                metadata,
            });
        }
        // The held-out error: the database as it was, against the new runs.
        let matrix = rows.matrix(&columns)?;
        let grid = options
            .template
            .grid_interpolation(&matrix, &metadata.grid)
            .map_err(|e| SweepError::Invalid(format!("{}: the rows stopped being a grid: {e}", entry.file)))?;
        let mut relative = Vec::with_capacity(runs.len());
        let mut estimate = vec![0.0; metadata.grid.points];
        let mut new_rows = Vec::with_capacity(runs.len());
        for run in &runs {
            // The FE time of every run added, computed now or by an earlier,
            // interrupted refinement, as `db merge` counts a build's.
            let (mu, wall_s) = read_run_profile(&dir.join("runs").join(run.file_name()), &metadata.grid)?;
            cpu_time_s += wall_s;
            let inputs = [run.width_mm, run.height_mm, run.velocity_mm_s];
            if counts(&inputs) {
                grid.predict_into(&matrix, &inputs, &mut estimate);
                relative.push(relative_error(&estimate, &mu).2);
            }
            new_rows.push((inputs, mu));
        }
        relative.sort_by(f64::total_cmp);
        let record = RefineRound {
            template: options.template,
            axis: AXES[axis].to_string(),
            value,
            between: [a, b],
            score: score.is_finite().then_some(score),
            runs: runs.len(),
            held_out_relative_median: median_sorted(&relative),
            held_out_relative_max: relative.last().copied().unwrap_or(0.0),
            resolved_only: options.resolved_only,
        };
        round_done(&record);
        history.push(record.clone());
        rounds.push(record);
        added += runs.len();
        rows.rows.extend(new_rows);
        rows.sort();
    };
    let metadata = if rounds.is_empty() || options.mode != Mode::Write {
        metadata
    } else {
        write_refined(dir, metadata, options.template, &rows, &columns, &rounds, cpu_time_s)?
    };
    Ok(RefineReport { rounds, stop, worst_score, runs_added: added, pending: 0, computed: 0, metadata })
}

/// Whether splitting (a, b) on `axis` can still be expected to help. The
/// round that made (a, b) by splitting a wider interval measured that
/// interval's held-out error; if the wider one was itself made by a round,
/// halving the spacing there took the error from that round's to this
/// one's. Where it did not at least halve it (smooth profiles would quarter
/// it), the profiles are not a smooth function of the input at this
/// spacing, and another split would buy rows, not accuracy: the narrow
/// gratings on the fine mesh, whose crests are sharper than the pad's
/// node spacing, measured 32.5%, 23.4%, 25.9% and 23.6% (median) at
/// spacings 0.25 .. 0.03 mm of r_w.
fn converging(history: &[RefineRound], template: Template, axis: &str, a: f64, b: f64) -> bool {
    // The round that made (a, b): its value is a or b, inside its interval.
    let made_by = |lo: f64, hi: f64| {
        history.iter().rev().find(|r| {
            r.template == template
                && r.axis == axis
                && (r.value == lo || r.value == hi)
                && r.between[0] <= lo
                && hi <= r.between[1]
        })
    };
    let Some(round) = made_by(a, b) else { return true };
    let Some(parent) = made_by(round.between[0], round.between[1]) else { return true };
    round.held_out_relative_median <= 0.5 * parent.held_out_relative_median
}

fn median_sorted(v: &[f64]) -> f64 {
    match v.len() {
        0 => 0.0,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Rewrites the database with the refined template's rows: every matrix
/// (the others as they were), its leave-one-out widths, and the metadata
/// with the rounds appended. The validation on random members is dropped:
/// it measured the rows before.
fn write_refined(
    dir: &Path,
    mut metadata: Metadata,
    template: Template,
    rows: &Rows,
    columns: &[String],
    rounds: &[RefineRound],
    cpu_time_s: f64,
) -> Result<Metadata, SweepError> {
    let mut texts = Vec::new();
    for e in &mut metadata.templates {
        let path = dir.join(&e.file);
        let text = if e.template == template {
            let mut text = Vec::new();
            let as_runs: Vec<(Run, Vec<f64>)> = rows
                .rows
                .iter()
                .map(|(i, mu)| (Run { template, width_mm: i[0], height_mm: i[1], velocity_mm_s: i[2] }, mu.clone()))
                .collect();
            write_matrix(&mut text, template, columns, &as_runs).map_err(|e| SweepError::Invalid(e.to_string()))?;
            let matrix = ModelMatrix::read_csv(text.as_slice(), &path.display().to_string(), &INPUTS)?;
            let optimum = optimize_widths(&matrix, OptimizeOptions::default())?;
            e.rows = matrix.n();
            e.widths = optimum.widths;
            e.loo_rmse = optimum.errors.rmse;
            e.loo_rmse_relative_to_range = database::relative_loo_error(&matrix, &optimum.errors);
            e.constant_width = optimum.report.constant.w;
            e.constant_width_rmse = optimum.report.constant.rmse;
            text
        } else {
            std::fs::read(&path).map_err(|err| SweepError::File { path: path.clone(), message: err.to_string() })?
        };
        texts.push((e.file.clone(), text));
    }
    let mut set = FileSet::begin(dir, "metadata.json")?;
    for (file, text) in &texts {
        set.write(file, |w| w.write_all(text))?;
    }
    metadata.created = database::utc_now_rfc3339();
    metadata.cpu_time_s += cpu_time_s;
    metadata.files_sha256 = Some(set.members().clone());
    metadata.validation = None;
    metadata.refined.get_or_insert_with(Vec::new).extend(rounds.iter().cloned());
    let json = serde_json::to_string_pretty(&metadata).expect("metadata serializes");
    set.finish(|w, _| writeln!(w, "{json}"))?;
    Ok(metadata)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_new_value_is_the_middle_at_the_file_names_resolution() {
        assert_eq!(middle(0, 1.25, 1.5), Some(1.375));
        assert_eq!(middle(0, 1.25, 1.375), Some(1.313)); // 1.3125 rounded
        assert_eq!(middle(0, 1.25, 1.251), None);
        assert_eq!(middle(2, 20.0, 50.0), Some(35.0));
        assert_eq!(middle(2, 20.0, 20.1), None);
    }

    /// A line's error is the worst of the rows that count: with
    /// `--resolved-only`, a sine row whose crests the mesh does not resolve
    /// is left out, however far off it is.
    #[test]
    fn line_errors_count_only_the_rows_asked_for() {
        // Widths 1, 2, 3 at heights 0.1 and 0.5: profiles linear in the
        // width, but the middle row at height 0.5 (crest radius 4 / (4 pi^2
        // 0.5) = 0.20 mm, under the fine mesh's 0.25 mm) is off by 1.
        let mut rows = Vec::new();
        for w in [1.0, 2.0, 3.0] {
            for h in [0.1, 0.5] {
                let off = if w == 2.0 && h == 0.5 { 1.0 } else { 0.0 };
                rows.push(([w, h, 20.0], vec![w + off, 2.0 * w + off, 0.0]));
            }
        }
        let rows = Rows { rows };
        let all = line_errors(&rows, 0, &|_| true, None).unwrap();
        assert_eq!(all[0], None);
        assert!(all[1].unwrap() > 0.1, "{all:?}");
        let resolved = |i: &[f64; 3]| haptex_core::crests::unresolved_sine("fine", i[0], i[1]).is_none();
        let counted = line_errors(&rows, 0, &resolved, None).unwrap();
        assert_eq!(counted[1], Some(0.0), "the rows that count are linear in the width");
    }

    #[test]
    fn an_interval_is_not_split_again_where_halving_did_not_halve_the_error() {
        let round = |value: f64, between: [f64; 2], median: f64| RefineRound {
            template: Template::Sine,
            axis: "width".into(),
            value,
            between,
            score: None,
            runs: 20,
            held_out_relative_median: median,
            held_out_relative_max: median,
            resolved_only: false,
        };
        // The narrow gratings' rounds as measured: 32.5% at 0.25 mm, then 23.4%.
        let history = [round(0.625, [0.5, 0.75], 0.325), round(0.563, [0.5, 0.625], 0.234)];
        let go = |a, b| converging(&history, Template::Sine, "width", a, b);
        assert!(go(0.5, 0.625) && go(0.625, 0.75), "made by a first split: nothing measured its convergence");
        assert!(!go(0.5, 0.563) && !go(0.563, 0.625), "23.4% is more than half of 32.5%");
        assert!(go(0.75, 1.0) && go(0.5, 0.75));
        assert!(converging(&history, Template::Bump, "width", 0.5, 0.563), "another template's rounds");
        // Where it did halve, the next level may be split.
        let history = [round(0.625, [0.5, 0.75], 0.325), round(0.563, [0.5, 0.625], 0.16)];
        assert!(converging(&history, Template::Sine, "width", 0.5, 0.563));
    }

    #[test]
    fn relative_error_is_rms_over_the_fe_range() {
        let fe = [0.0, 1.0, 2.0, 3.0];
        let est = [0.5, 1.5, 2.5, 3.5];
        let (rms, range, rel) = relative_error(&est, &fe);
        assert!((rms - 0.5).abs() < 1e-15 && range == 3.0 && (rel - 0.5 / 3.0).abs() < 1e-15);
    }

    #[test]
    fn line_errors_are_zero_on_a_linear_family_and_find_the_kink_of_another() {
        // Profiles linear in r_w: interpolation between neighbours is exact.
        let make = |f: &dyn Fn(f64, f64) -> f64| Rows {
            rows: [0.5, 1.0, 1.5, 2.0]
                .iter()
                .flat_map(|&w| {
                    [0.1, 0.2].iter().map(move |&h| ([w, h, 20.0], (0..5).map(|x| f(w, h) * x as f64).collect()))
                })
                .collect(),
        };
        let linear = make(&|w, h| 1.0 + w + h);
        let e = line_errors(&linear, 0, &|_| true, None).unwrap();
        assert_eq!(e[0], None);
        assert_eq!(e[3], None);
        assert!(e[1].unwrap() < 1e-12 && e[2].unwrap() < 1e-12, "{e:?}");
        // A kink at r_w = 1.5: the line there is mispredicted, 1.0 is not.
        let kinked = make(&|w, h| 1.0 + h + (w - 1.5).abs());
        let e = line_errors(&kinked, 0, &|_| true, None).unwrap();
        assert!(e[1].unwrap() < 1e-12 && e[2].unwrap() > 0.05, "{e:?}");
    }

    /// Along a sine's period the neighbours are blended in phase, as the
    /// grid estimate blends them: exact sines of periods 1.0, 1.25 and 1.5
    /// mm (0.02 mm samples from -5 mm) predict the middle one to the error
    /// of reading between samples (under 0.1% of the range), where the
    /// absolute axis misses it by more than a quarter of its range.
    #[test]
    fn line_errors_along_a_sines_period_blend_in_phase() {
        let (start, step, m) = (-5.0, 0.02, 501);
        let rows = Rows {
            rows: [1.0, 1.25, 1.5]
                .iter()
                .map(|&w| {
                    let mu = (0..m)
                        .map(|k| 0.5 + 0.05 * (std::f64::consts::TAU * (start + k as f64 * step) / w).sin())
                        .collect();
                    ([w, 0.2, 20.0], mu)
                })
                .collect(),
        };
        let in_phase = line_errors(&rows, 0, &|_| true, Some((start, step))).unwrap();
        let absolute = line_errors(&rows, 0, &|_| true, None).unwrap();
        assert!(in_phase[1].unwrap() < 1e-3, "{in_phase:?}");
        assert!(absolute[1].unwrap() > 0.25, "{absolute:?}");
    }
}
