//! `haptex db`: build the FE database of template surfaces (paper section
//! 3.1), merge the shards of a cluster build, and show the leave-one-out
//! comparison of the paper's Fig. 2a.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, Subcommand, ValueEnum};
use haptex_core::database::{Estimator, Metadata, Template, TemplateModel};
use haptex_core::num::Num;
use haptex_core::plot::{Figure, Panel};
use haptex_fem::finger::FingerModel;
use haptex_fem::held_out;
use haptex_fem::loo_case::LooCase;
use haptex_fem::refine;
use haptex_fem::sweep::{self, DatabaseSpec, Run};
use indicatif::{ProgressBar, ProgressStyle};

use crate::args::{MeshArg, Output, positive, shipped_data};

/// The shipped database, relative to the source tree.
pub const SHIPPED_DB: &str = "data/db";

/// Build, merge and inspect the FE database of template surfaces.
#[derive(Debug, Args)]
pub struct DbArgs {
    #[command(subcommand)]
    command: DbCommand,
}

#[derive(Debug, Subcommand)]
enum DbCommand {
    Build(BuildArgs),
    Merge(MergeArgs),
    Loo(LooArgs),
    Validate(ValidateArgs),
    Refine(RefineArgs),
}

/// Run the FE sweep of the template database and, when every run is done,
/// write the database (one CAE model matrix per template + metadata.json).
///
/// The default sweep is the paper's (section 3.1): bump, edge and sine with
/// r_w = 0.5 .. 2.5 mm in 0.25 mm steps and r_h = 0.1 .. 0.5 mm in 0.1 mm
/// steps, at 10, 20, 50 and 100 mm/s: 540 runs of the default finger model
/// (0.25 mm indentation, 11 mm slide over a feature at x0 = 6 mm), each
/// profile sampled at xi = x - x0 = -5 .. 5 mm every 0.02 mm.
///
/// Each run is written atomically to OUT/runs/ as soon as it finishes, so an
/// interrupted build continues where it stopped when run again. With
/// --shard K/N (or, without the flag, Slurm's SLURM_ARRAY_TASK_ID and
/// SLURM_ARRAY_TASK_COUNT) only every N-th run from the K-th is computed;
/// join the shards with `haptex db merge`.
#[derive(Debug, Args)]
#[command(after_help = "Examples:\n  haptex db build                       # the shipped database, data/db\n  \
                  haptex db build --out /tmp/db --jobs 2\n  \
                  haptex db build --out scratch/db --shard 3/16   # job 3 of a 16-job array\n  \
                  haptex db build --out /tmp/small --widths 1,2 --heights 0.2 --velocities 20 --templates bump")]
struct BuildArgs {
    /// Database directory (runs go to OUT/runs/). Default: the shipped
    /// data/db of this source tree, or $HAPTEX_DB.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// FE runs at a time (one thread each). Default: the number of cores.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    jobs: Option<u32>,
    /// Compute only shard K of N (1-based): runs K, K+N, K+2N, ... of the
    /// sweep's fixed order. Default: from SLURM_ARRAY_TASK_ID,
    /// SLURM_ARRAY_TASK_MIN and SLURM_ARRAY_TASK_COUNT when set, else all.
    #[arg(long, value_name = "K/N", value_parser = parse_shard)]
    shard: Option<(usize, usize)>,
    /// Surface templates, comma-separated.
    #[arg(long, value_delimiter = ',', value_enum)]
    templates: Option<Vec<TemplateArg>>,
    /// Feature widths r_w (mm), comma-separated.
    #[arg(long, value_delimiter = ',', value_parser = positive)]
    widths: Option<Vec<f64>>,
    /// Feature heights r_h (mm), comma-separated.
    #[arg(long, value_delimiter = ',', value_parser = positive)]
    heights: Option<Vec<f64>>,
    /// Sliding velocities (mm/s), comma-separated.
    #[arg(long, value_delimiter = ',', value_parser = positive)]
    velocities: Option<Vec<f64>>,
    /// Mesh resolution of the finger.
    #[arg(long, value_enum, default_value_t = MeshArg::Default)]
    mesh: MeshArg,
    /// Profile grid points over xi = -5 .. 5 mm.
    #[arg(long, default_value_t = 501, value_parser = clap::value_parser!(u32).range(2..=100_000))]
    grid_points: u32,
    /// Only compute the runs; do not write the database even if complete.
    #[arg(long)]
    no_merge: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

/// Join the runs of one or more build directories (the shards of a
/// cluster build) into a database: model matrices, LOO-optimal CAE widths
/// and metadata.json.
#[derive(Debug, Args)]
#[command(after_help = "Example:\n  haptex db merge --from shard-1 --from shard-2 --out data/db")]
struct MergeArgs {
    /// Build directories whose runs/ to collect (repeat the flag).
    #[arg(long, required = true, value_name = "DIR")]
    from: Vec<PathBuf>,
    /// Database directory to write.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

/// Leave-one-out view of the database: the paper's Fig. 2a for one case
/// (FE profile, CAE with the case left out, CAE over the whole database)
/// and the LOO error of every template.
///
/// Without --surface, prints the LOO summary (widths, RMS error, error
/// relative to the profiles' range) per template. With --surface, --width,
/// --height (and --velocity), writes `xi_mm,h_mm,mu_fe,mu_cae_loo,mu_cae_full`
/// and optionally a PNG. For a database case the FE profile is the
/// database's row; for any other parameters the case is simulated now with
/// the database's FE settings (about a second on the shipped database's
/// fine mesh), which shows how well
/// the CAE predicts it.
#[derive(Debug, Args)]
#[command(after_help = "Examples:\n  haptex db loo\n  \
                  haptex db loo --surface bump --width 1.5 --height 0.3 -o bump-loo.csv --png bump-loo.png\n  \
                  haptex db loo --surface edge --width 1.3 --height 0.27 --velocity 30 --png edge-check.png")]
struct LooArgs {
    /// Database directory. Default: the shipped data/db, or $HAPTEX_DB.
    #[arg(long, value_name = "DIR")]
    db: Option<PathBuf>,
    /// Template of the case.
    #[arg(long, value_enum, requires_all = ["width", "height"])]
    surface: Option<TemplateArg>,
    /// r_w of the case (mm).
    #[arg(long)]
    width: Option<f64>,
    /// r_h of the case (mm).
    #[arg(long)]
    height: Option<f64>,
    /// Velocity of the case (mm/s).
    #[arg(long, default_value_t = 20.0)]
    velocity: f64,
    /// CSV output of the case (default: stdout).
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// PNG plot of the case.
    #[arg(long, value_name = "FILE")]
    png: Option<PathBuf>,
    /// Summary as JSON (to stdout, or stderr when a case is written there).
    #[arg(long)]
    json: bool,
    /// No messages on stderr.
    #[arg(long, short)]
    quiet: bool,
}

/// The estimate on members nobody tuned it to: FE runs at N random
/// members of each template's family (r_w, r_h and velocity uniform over the
/// database's ranges), with the database's own FE settings, against the
/// estimate `haptex predict` gives for them.
///
/// Prints, per template, the median and largest RMS error of Ft/Fn over the
/// database's grid and the same relative to the FE profile's range
/// (max - min), as a Markdown table, and the worst member. The members
/// depend only on the seed (and the database's ranges): the same seed gives
/// the same members on every machine, and any member can be looked at with
/// `haptex db loo --surface S --width W --height H --velocity V --png F`.
#[derive(Debug, Args)]
#[command(after_help = "Examples:\n  haptex db validate --random 30 --seed 1\n  \
                  haptex db validate --random 10 --seed 7 --templates sine -o members.csv")]
struct ValidateArgs {
    /// Database directory. Default: the shipped data/db, or $HAPTEX_DB.
    #[arg(long, value_name = "DIR")]
    db: Option<PathBuf>,
    /// Random members per template.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=10_000))]
    random: u32,
    /// Seed of the members.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Surface templates, comma-separated. Default: all of the database's.
    #[arg(long, value_delimiter = ',', value_enum)]
    templates: Option<Vec<TemplateArg>>,
    /// FE runs at a time (one thread each). Default: the number of cores.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    jobs: Option<u32>,
    /// CSV of every member: template, parameters, RMS error, FE range, relative error.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// The summary as JSON on stdout instead of the table.
    #[arg(long)]
    json: bool,
    /// Record the result in the database's metadata.json, where `haptex
    /// predict` and the web page read what to expect of an estimate, and
    /// make the estimator measured the database's: the one its estimates
    /// are served with.
    #[arg(long)]
    record: bool,
    /// The estimate between the rows: multilinear interpolation over the
    /// sweep's grid (a sine's profiles in phase), or the paper's CAE. Default: the database's own.
    #[arg(long, value_enum)]
    estimator: Option<EstimatorArg>,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

/// Grow a template's grid where its estimate is wrong: FE runs at a new
/// value of r_w, r_h or velocity in the middle of the interval whose
/// score is largest, one run for every combination of the other inputs,
/// until every interval is within the target or the budget of runs is
/// spent. An interval's score is the larger leave-one-line-out error of
/// its ends (each grid value predicted between its neighbours, relative to
/// the profile's range) over 4: linear interpolation's error across the
/// interval, half that spacing, for profiles smooth in the input.
///
/// Each round prints the interval, its score, and the held-out error: the
/// database's estimate before the round against the round's new FE runs.
/// Runs go to DIR/runs as `db build` writes them, so an interrupted
/// refinement continues where it stopped (the rounds are deterministic).
/// The database is rewritten as a whole at the end, its rounds recorded in
/// metadata.json; its validation on random members is dropped, since it
/// measured the rows before: run `haptex db validate --record` again.
#[derive(Debug, Args)]
#[command(after_help = "Examples:\n  haptex db refine --template sine --budget 200\n  \
                  haptex db refine --db /tmp/db --template bump --axes width,height --target 0.03 --budget 60\n  \
                  haptex db refine --db /scratch/db --template sine --budget 300 --shard 3/16   # task 3 of a 16-task array")]
struct RefineArgs {
    /// Database directory, refined in place. Default: the shipped data/db, or $HAPTEX_DB.
    #[arg(long, value_name = "DIR")]
    db: Option<PathBuf>,
    /// The template to refine.
    #[arg(long, value_enum)]
    template: TemplateArg,
    /// Inputs that may get new values, comma-separated.
    #[arg(long, value_delimiter = ',', value_enum, default_values_t = [AxisArg::Width])]
    axes: Vec<AxisArg>,
    /// Stop when every interval's score is at most this fraction of the
    /// profiles' range.
    #[arg(long, default_value_t = 0.05, value_parser = positive)]
    target: f64,
    /// Most FE runs to add.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    budget: u32,
    /// FE runs at a time (one thread each). Default: the number of cores.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    jobs: Option<u32>,
    /// A task of a job array: replay the rounds whose runs are in DIR/runs,
    /// compute shard K of N (1-based) of the first round that lacks runs,
    /// and stop, writing nothing but run files. Default: from
    /// SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_MIN and SLURM_ARRAY_TASK_COUNT
    /// when set. Submit one array per round until --plan prints 0, then
    /// refine without --shard to write the database.
    #[arg(long, value_name = "K/N", value_parser = parse_shard, conflicts_with = "plan")]
    shard: Option<(usize, usize)>,
    /// Print (alone on standard output) how many runs the first round
    /// that lacks runs still needs, 0 when none does; compute and write
    /// nothing.
    #[arg(long)]
    plan: bool,
    /// Measure the errors that choose the splits on the rows whose crests
    /// the database's mesh resolves only: a sine's rows with crests of
    /// radius r_w^2 / (4 pi^2 r_h) at least 5 pad node spacings (0.25 mm on
    /// the fine mesh). Elsewhere the FE rows are not mesh-converged, and
    /// their errors are the mesh's, which more rows do not reduce
    /// (docs/database.md, "The sine's sharp crests").
    #[arg(long)]
    resolved_only: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum AxisArg {
    /// r_w (mm).
    Width,
    /// r_h (mm).
    Height,
    /// Sliding velocity (mm/s).
    Velocity,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub(crate) enum EstimatorArg {
    /// The paper's conditional average estimator.
    Cae,
    /// Multilinear interpolation over the sweep's grid (a sine's profiles
    /// blended in phase).
    Grid,
}

impl From<EstimatorArg> for Estimator {
    fn from(e: EstimatorArg) -> Self {
        match e {
            EstimatorArg::Cae => Estimator::Cae,
            EstimatorArg::Grid => Estimator::Grid,
        }
    }
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum TemplateArg {
    Bump,
    Edge,
    Sine,
}

impl From<TemplateArg> for Template {
    fn from(t: TemplateArg) -> Self {
        match t {
            TemplateArg::Bump => Template::Bump,
            TemplateArg::Edge => Template::Edge,
            TemplateArg::Sine => Template::Sine,
        }
    }
}

pub fn run(args: DbArgs) -> anyhow::Result<()> {
    match args.command {
        DbCommand::Build(a) => build(a),
        DbCommand::Merge(a) => merge(a),
        DbCommand::Loo(a) => loo(a),
        DbCommand::Validate(a) => validate(a),
        DbCommand::Refine(a) => refine(a),
    }
}

/// The database directory: the flag, else $HAPTEX_DB, else the shipped one.
pub fn default_db() -> PathBuf {
    shipped_data("HAPTEX_DB", SHIPPED_DB)
}

fn parse_shard(text: &str) -> Result<(usize, usize), String> {
    let (k, n) = text.split_once('/').ok_or_else(|| format!("'{text}' is not K/N (e.g. 3/16)"))?;
    let k: usize = k.trim().parse().map_err(|_| format!("'{k}' in '{text}' is not a whole number"))?;
    let n: usize = n.trim().parse().map_err(|_| format!("'{n}' in '{text}' is not a whole number"))?;
    if n == 0 || k == 0 || k > n {
        return Err(format!("shard {k}/{n}: need 1 <= K <= N"));
    }
    Ok((k, n))
}

/// The shard from Slurm's job-array variables, if set: task ids run from
/// SLURM_ARRAY_TASK_MIN (which Slurm always sets; 0 when it is absent).
fn slurm_shard() -> anyhow::Result<Option<(usize, usize)>> {
    let var = |name: &str| -> anyhow::Result<Option<usize>> {
        match std::env::var(name) {
            Ok(v) => v.trim().parse().map(Some).with_context(|| format!("${name} = '{v}' is not a whole number")),
            Err(_) => Ok(None),
        }
    };
    let (Some(id), Some(count)) = (var("SLURM_ARRAY_TASK_ID")?, var("SLURM_ARRAY_TASK_COUNT")?) else {
        return Ok(None);
    };
    let min = var("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
    let k = id.checked_sub(min).map(|i| i + 1);
    match k {
        Some(k) if count > 0 && k <= count => Ok(Some((k, count))),
        _ => bail!(
            "SLURM_ARRAY_TASK_ID = {id} with SLURM_ARRAY_TASK_MIN = {min} and SLURM_ARRAY_TASK_COUNT = {count} \
             is not a task of the array (use --shard K/N for arrays with gaps or steps)"
        ),
    }
}

fn build(args: BuildArgs) -> anyhow::Result<()> {
    let out = args.out.clone().unwrap_or_else(default_db);
    let mut spec = DatabaseSpec::paper();
    if let Some(templates) = &args.templates {
        spec.sweep.templates = chosen(templates);
    }
    if let Some(v) = args.widths.clone() {
        spec.sweep.widths_mm = sorted(v);
    }
    if let Some(v) = args.heights.clone() {
        spec.sweep.heights_mm = sorted(v);
    }
    if let Some(v) = args.velocities.clone() {
        spec.sweep.velocities_mm_s = sorted(v);
    }
    spec.resolution = args.mesh.resolution();
    spec.grid.points = args.grid_points as usize;
    // The model is the shipped one; its provenance goes into the metadata.
    spec.model = FingerModel::default_model();
    // Everything the runs and the merge need, before the first run.
    spec.validate().context("db build: these settings cannot make a database (nothing was computed)")?;

    let shard = match args.shard {
        Some(s) => Some(s),
        None => slurm_shard()?,
    };
    let runs: Vec<Run> = match shard {
        Some((k, n)) => spec.shard(k, n),
        None => spec.runs(),
    };
    let jobs =
        args.jobs.map(|j| j as usize).unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let total_all = spec.runs().len();
    if !args.quiet {
        let what = match shard {
            Some((k, n)) => format!("shard {k}/{n}: {} of {total_all} runs", runs.len()),
            None => format!("{total_all} runs"),
        };
        eprintln!("haptex db build: {what} into {}, {jobs} at a time", out.join("runs").display());
    }

    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        let bar = ProgressBar::new(runs.len() as u64);
        bar.set_style(
            ProgressStyle::with_template("{spinner} db build [{bar:30}] {pos}/{len} runs ({elapsed}, eta {eta})")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar
    };
    let report = sweep::build_runs(&spec, &runs, &out, jobs, &|done, _total| bar.set_position(done as u64));
    bar.finish_and_clear();
    let report = report.with_context(|| format!("building the database in {}", out.display()))?;
    if !args.quiet {
        eprintln!(
            "{} runs computed ({} were already done) in {:.1} s wall, {:.1} s of FE time",
            report.runs_computed, report.runs_done_before, report.wall_time_s, report.cpu_time_s
        );
    }
    if args.no_merge || shard.is_some() {
        if !args.quiet {
            eprintln!(
                "runs are in {}; join them with `haptex db merge --from DIR... --out DIR`",
                out.join("runs").display()
            );
        }
        return Ok(());
    }
    // The build's wall time is known only when this invocation ran the
    // whole sweep.
    let wall = (report.runs_done_before == 0).then_some(report.wall_time_s);
    let metadata = sweep::merge(std::slice::from_ref(&out), &out, wall)?;
    if !args.quiet {
        print_summary(&metadata, &out);
    }
    Ok(())
}

/// The templates of a `--templates` list, in order, each once.
fn chosen(list: &[TemplateArg]) -> Vec<Template> {
    let mut templates: Vec<Template> = list.iter().map(|&t| t.into()).collect();
    templates.sort();
    templates.dedup();
    templates
}

fn sorted(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

fn merge(args: MergeArgs) -> anyhow::Result<()> {
    let metadata = sweep::merge(&args.from, &args.out, None)?;
    print_summary(&metadata, &args.out);
    Ok(())
}

fn print_summary(metadata: &Metadata, dir: &Path) {
    eprintln!("database {} ({}):", dir.display(), metadata.created);
    for e in &metadata.templates {
        eprintln!(
            "  {:<5} {:>4} rows  widths {:.4} .. {:.4}  LOO RMS {:.4} ({:.1}% of the profile range)",
            e.template.name(),
            e.rows,
            e.widths.w_min,
            e.widths.w_max,
            e.loo_rmse,
            100.0 * e.loo_rmse_relative_to_range
        );
    }
}

fn loo(args: LooArgs) -> anyhow::Result<()> {
    let dir = args.db.clone().unwrap_or_else(default_db);
    let metadata = Metadata::read(&dir)?;
    let Some(surface) = args.surface else {
        let summary = metadata.loo_summary();
        if args.json {
            println!("{}", serde_json::to_string_pretty(&summary)?);
        } else {
            print_summary(&metadata, &dir);
        }
        return Ok(());
    };
    let template: Template = surface.into();
    let (width, height) = (args.width.expect("clap requires it"), args.height.expect("clap requires it"));
    let model = TemplateModel::load_with(&dir, &metadata, template)?;
    let query = [width, height, args.velocity];
    let run = Run { template, width_mm: width, height_mm: height, velocity_mm_s: args.velocity };
    let row = model.exact_row(&query);
    if row.is_none() && !args.quiet {
        // Not a database case: simulated with the database's FE settings;
        // the database never saw it, so both estimates agree.
        eprintln!("not a case of the database: simulating it with the database's FE settings");
    }
    let case = LooCase::compute(&dir, &metadata, &model, run);
    let case = if row.is_none() { case.context("simulating the case")? } else { case? };
    let (xi, h, fe, left_out, full) = (&case.xi_mm, &case.h_mm, &case.mu_fe, &case.mu_cae_loo, &case.mu_cae_full);
    let (rms_loo, rms_full) = (case.rms_loo, case.rms_full);
    Output::new(args.output.clone()).write(|w| case.write_csv(w))?;
    if let Some(path) = &args.png {
        let title = format!(
            "{} r_w = {} mm, r_h = {} mm, v = {} mm/s: FE and CAE (paper Fig. 2a)",
            template.name(),
            Num(width),
            Num(height),
            Num(args.velocity)
        );
        let friction = Panel::new("x - x0 (mm)", "Ft/Fn").line("FE", xi, fe);
        let friction = if row.is_some() {
            friction.line(format!("CAE, case left out (RMS {rms_loo:.4})"), xi, left_out).line(
                format!("CAE, full database (RMS {rms_full:.4})"),
                xi,
                full,
            )
        } else {
            friction.line(format!("CAE, case not in the database (RMS {rms_full:.4})"), xi, full)
        };
        Figure::new(title)
            .size(900, 260)
            .panel(Panel::new("x - x0 (mm)", "height (mm)").line("surface", xi, h))
            .panel(friction)
            .write_png(path)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if !args.quiet {
        eprintln!(
            "{} r_w = {width} mm, r_h = {height} mm, v = {} mm/s ({}): RMS difference to FE {rms_loo:.4} \
             leaving the case out, {rms_full:.4} over the whole database",
            template.name(),
            args.velocity,
            case.source
        );
    }
    if args.json {
        eprintln!("{}", serde_json::to_string_pretty(&metadata.loo_summary())?);
    }
    Ok(())
}

fn validate(args: ValidateArgs) -> anyhow::Result<()> {
    let dir = args.db.clone().unwrap_or_else(default_db);
    let metadata = Metadata::read(&dir)?;
    let templates: Vec<Template> = match &args.templates {
        Some(list) => chosen(list),
        None => metadata.templates.iter().map(|e| e.template).collect(),
    };
    let jobs =
        args.jobs.map(|j| j as usize).unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let n = args.random as usize;
    if !args.quiet {
        eprintln!(
            "haptex db validate: {n} random members of {} (seed {}), FE runs with the database's settings ({} mesh, \
             {}), {jobs} at a time",
            templates.iter().map(|t| t.name()).collect::<Vec<_>>().join(", "),
            args.seed,
            metadata.fe.mesh,
            metadata.fe.material
        );
    }
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        let bar = ProgressBar::new((n * templates.len()) as u64);
        bar.set_style(
            ProgressStyle::with_template("{spinner} db validate [{bar:30}] {pos}/{len} FE runs ({elapsed}, eta {eta})")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar
    };
    let estimator: Estimator = args.estimator.map_or(metadata.served_estimator(), Into::into);
    let members = held_out::validate(&dir, &metadata, &templates, estimator, n, args.seed, jobs, &|done, _| {
        bar.set_position(done as u64)
    });
    bar.finish_and_clear();
    let members = members.with_context(|| format!("validating the database in {}", dir.display()))?;
    // The members' CSV to a file, or to stdout (`-o -`), the table then to stderr.
    let members_out = args.output.clone().map(|p| Output::new(Some(p)));
    if let Some(out) = &members_out {
        out.write(|w| {
            writeln!(w, "# haptex db validate --random {n} --seed {} (database {})", args.seed, dir.display())?;
            writeln!(w, "template,r_w_mm,r_h_mm,velocity_mm_s,rms,fe_range,relative,crests_resolved")?;
            for m in &members {
                writeln!(
                    w,
                    "{},{},{},{},{:.6},{:.6},{:.6},{}",
                    m.run.template.name(),
                    Num(m.run.width_mm),
                    Num(m.run.height_mm),
                    Num(m.run.velocity_mm_s),
                    m.rms,
                    m.range,
                    m.relative,
                    m.crests_resolved(&metadata.fe.mesh).map_or(String::new(), |r| r.to_string())
                )?;
            }
            Ok(())
        })?;
    }
    // With a sine's members whose crests the database's mesh resolves
    // apart: against the others the FE reference itself is not
    // mesh-converged.
    let summary = held_out::summarize(&members, &metadata.fe.mesh);
    if args.record {
        held_out::record(&dir, &metadata, estimator, args.seed, n, &summary)
            .with_context(|| format!("recording the validation in {}", dir.join("metadata.json").display()))?;
        if !args.quiet {
            eprintln!("recorded in {}", dir.join("metadata.json").display());
        }
    }
    // With the members' CSV on stdout (`-o -`), the summary goes to stderr.
    let to_stderr = members_out.as_ref().is_some_and(|o| o.path().is_none());
    let text = if args.json {
        let rows: Vec<serde_json::Value> = summary
            .iter()
            .map(|s| {
                let e = &s.errors;
                serde_json::json!({
                    "template": e.template.name(),
                    "members": s.members,
                    "rms_median": e.rms_median,
                    "rms_max": e.rms_max,
                    "relative_median": e.relative_median,
                    "relative_max": e.relative_max,
                    "worst": { "r_w_mm": s.worst.width_mm, "r_h_mm": s.worst.height_mm,
                               "velocity_mm_s": s.worst.velocity_mm_s },
                    "crests_resolved": s.resolved.as_ref().map(|r| serde_json::json!({
                        "members": r.members,
                        "rms_median": r.errors.rms_median,
                        "rms_max": r.errors.rms_max,
                        "relative_median": r.errors.relative_median,
                        "relative_max": r.errors.relative_max,
                        "worst": { "r_w_mm": r.worst.width_mm, "r_h_mm": r.worst.height_mm,
                                   "velocity_mm_s": r.worst.velocity_mm_s },
                    })),
                })
            })
            .collect();
        serde_json::to_string_pretty(&serde_json::json!({ "seed": args.seed, "random": n, "templates": rows }))?
    } else {
        let mut lines = vec![
            "| template | members | RMS of Ft/Fn, median (max) | relative to the FE profile's range, median (max) | \
             worst member (r_w, r_h, v) |"
                .to_string(),
            "|---|---|---|---|---|".to_string(),
        ];
        let row = |name: String, members: String, s: &held_out::Summary| {
            let e = &s.errors;
            format!(
                "| {name} | {members} | {:.4} ({:.4}) | {:.1}% ({:.1}%) | {} mm, {} mm, {} mm/s |",
                e.rms_median,
                e.rms_max,
                100.0 * e.relative_median,
                100.0 * e.relative_max,
                Num(s.worst.width_mm),
                Num(s.worst.height_mm),
                Num(s.worst.velocity_mm_s)
            )
        };
        for s in &summary {
            lines.push(row(s.errors.template.name().to_string(), s.members.to_string(), s));
            if let Some(r) = &s.resolved {
                let bound = haptex_core::crests::resolved_radius_mm(&metadata.fe.mesh).unwrap_or(0.0);
                lines.push(row(
                    format!(
                        "{}, crests of radius >= {} mm (resolved by the {} mesh)",
                        s.errors.template.name(),
                        Num(bound),
                        metadata.fe.mesh
                    ),
                    format!("{} of {}", r.members, s.members),
                    r,
                ));
            }
        }
        lines.join("\n")
    };
    if to_stderr {
        eprintln!("{text}");
    } else {
        println!("{text}");
    }
    Ok(())
}

fn refine(args: RefineArgs) -> anyhow::Result<()> {
    let dir = args.db.clone().unwrap_or_else(default_db);
    let template: Template = args.template.into();
    let mut axes: Vec<usize> = args.axes.iter().map(|a| *a as usize).collect();
    axes.sort_unstable();
    axes.dedup();
    let jobs =
        args.jobs.map(|j| j as usize).unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let mode = match (args.plan, args.shard) {
        (true, _) => refine::Mode::Plan,
        (false, Some((k, n))) => refine::Mode::Shard(k, n),
        (false, None) => match slurm_shard()? {
            Some((k, n)) => refine::Mode::Shard(k, n),
            None => refine::Mode::Write,
        },
    };
    let options = refine::RefineOptions {
        template,
        axes,
        target: args.target,
        budget: args.budget as usize,
        jobs,
        mode,
        resolved_only: args.resolved_only,
    };
    let quiet = args.quiet || args.plan;
    if !quiet {
        eprintln!(
            "haptex db refine: {} of {}, along {}, to {}% of the range, at most {} runs, {jobs} at a time",
            template.name(),
            dir.display(),
            options.axes.iter().map(|&a| refine::AXES[a]).collect::<Vec<_>>().join(", "),
            Num(100.0 * args.target),
            args.budget
        );
    }
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        let bar = ProgressBar::new(0);
        bar.set_style(
            ProgressStyle::with_template("{spinner} db refine [{bar:30}] {pos}/{len} runs of this round ({elapsed})")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar
    };
    let report = refine::refine(
        &dir,
        &options,
        &|done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        },
        &mut |round| {
            if !quiet {
                bar.suspend(|| {
                    eprintln!(
                        "  {} {} between {} and {} (score {}): {} runs; the estimate before was off by {:.1}% \
                         (median), {:.1}% at most",
                        round.axis,
                        Num(round.value),
                        Num(round.between[0]),
                        Num(round.between[1]),
                        round.score.map_or_else(|| "not measured".to_string(), |s| format!("{:.1}%", 100.0 * s)),
                        round.runs,
                        100.0 * round.held_out_relative_median,
                        100.0 * round.held_out_relative_max
                    )
                });
            }
        },
    );
    bar.finish_and_clear();
    let report = report.with_context(|| format!("refining {} in {}", template.name(), dir.display()))?;
    let round = report.rounds.len() + 1;
    match mode {
        refine::Mode::Plan => {
            println!("{}", report.pending);
            return Ok(());
        }
        refine::Mode::Shard(k, n) => {
            if report.stop == refine::Stop::Pending {
                println!(
                    "round {round}: {} runs of shard {k}/{n} computed; {} of the round's runs were missing when this \
                     task started; when every task of the array is done, `--plan` counts what the round still lacks",
                    report.computed, report.pending
                );
            } else {
                println!(
                    "every round's runs are there ({} runs in {} rounds): refine without --shard to write the database",
                    report.runs_added,
                    report.rounds.len()
                );
            }
            return Ok(());
        }
        refine::Mode::Write => {}
    }
    let why = match report.stop {
        refine::Stop::Pending => unreachable!("a refinement that writes computes every round"),
        refine::Stop::TargetMet => {
            format!("every interval's score is within the target ({:.1}% at most)", 100.0 * report.worst_score)
        }
        refine::Stop::Budget => format!(
            "the next round would exceed the budget of {} runs (worst interval {:.1}%)",
            args.budget,
            100.0 * report.worst_score
        ),
        refine::Stop::NotConverging => format!(
            "the intervals above the target ({:.1}% at most) lie where halving the spacing did not halve the \
             estimate's error: the profiles are not smooth in the input there, and more runs would not help",
            100.0 * report.worst_score
        ),
        refine::Stop::Resolution => format!(
            "the worst interval ({:.1}%) is too narrow to split at the run files' resolution",
            100.0 * report.worst_score
        ),
    };
    let n = report.rounds.len();
    println!("{} runs added in {n} round{}; stopped: {why}", report.runs_added, if n == 1 { "" } else { "s" });
    if !report.rounds.is_empty() && !args.quiet {
        print_summary(&report.metadata, &dir);
        eprintln!(
            "the validation on random members was dropped (it measured the rows before): `haptex db validate --db {} \
             --random 30 --seed 1 --record` measures the refined database",
            dir.display()
        );
    }
    Ok(())
}
