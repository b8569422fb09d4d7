//! `haptex predict`: the friction profile of any bump, edge or sine from the
//! FE database by the conditional average estimator (paper section 3.2).

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};
use haptex_core::database::{Metadata, Template, TemplateModel, write_prediction_csv};

use crate::args::{Output, positive};

/// Predict the friction profile Ft/Fn(x) of a template surface from the FE
/// database, in milliseconds.
///
/// Between the database's rows, the estimate is the database's estimator
/// (`estimator` in its metadata.json, or `--estimator`): multilinear
/// interpolation over the sweep's grid of (r_w, r_h, velocity), a sine's
/// profiles blended in phase (at the same (x - x0) / r_w), for the shipped
/// database, or the paper's conditional average estimator (Gaussian
/// kernels, the leave-one-out optimal widths stored in the metadata), which
/// averages the FE profiles of the same template weighted by how close
/// their (r_w, r_h, velocity) are to the query. When the parameters are
/// exactly a database row, that row's FE profile is returned and the
/// command says so. The expected error measured on random members (`haptex
/// db validate --record`) is printed with each estimate. Queries
/// far from every database case, or with a parameter outside the database's
/// range of r_w, r_h or velocity, are answered with a warning: the estimate
/// then extrapolates and is unreliable.
///
/// Output: `x_mm,mu`, x the finger's position on the surface (the database
/// grid xi = -5 .. 5 mm shifted to the feature at x0), a friction profile
/// for `haptex voltage`. Its flat-surface friction is the FE skin friction
/// (0.5 for the shipped database; a comment line says so): `haptex voltage
/// --relative --flat-mu 0.5` maps it as the paper's Fig. 2 does.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    after_help = "Examples:\n  haptex predict --surface bump --x0 5 --width 1.3 --height 0.27\n  \
                  haptex predict --surface sine --x0 0 --width 2 --height 0.2 --velocity 50 -o sine.csv\n  \
                  haptex predict --surface edge --x0 5 --width 1 --height 0.3 | haptex voltage --profile -"
)]
pub struct PredictArgs {
    /// Surface template.
    #[arg(long, value_enum)]
    surface: SurfaceArg,
    /// Feature position x0 in mm (bump top, edge top, sine phase).
    #[arg(long, allow_negative_numbers = true)]
    x0: f64,
    /// Feature width r_w in mm (bump width, edge rise, sine period).
    #[arg(long, value_parser = positive)]
    width: f64,
    /// Feature height r_h in mm (bump and edge height, sine amplitude).
    #[arg(long, value_parser = positive)]
    height: f64,
    /// Sliding velocity in mm/s.
    #[arg(long, default_value_t = 20.0, value_parser = positive)]
    velocity: f64,
    /// Database directory. Default: the shipped data/db, or $HAPTEX_DB.
    #[arg(long, value_name = "DIR")]
    db: Option<PathBuf>,
    /// The estimate between the database's rows: multilinear over the
    /// sweep's grid (a sine's profiles in phase), or the paper's CAE. Default: the database's own.
    #[arg(long, value_enum)]
    estimator: Option<super::db::EstimatorArg>,
    /// Output file (default: stdout).
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Print nothing to stderr (warnings included).
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum SurfaceArg {
    Bump,
    Edge,
    Sine,
}

pub fn run(args: PredictArgs) -> anyhow::Result<()> {
    let dir = args.db.clone().unwrap_or_else(super::db::default_db);
    let template = match args.surface {
        SurfaceArg::Bump => Template::Bump,
        SurfaceArg::Edge => Template::Edge,
        SurfaceArg::Sine => Template::Sine,
    };
    let metadata = Metadata::read(&dir).with_context(|| {
        format!("no FE database in {} (build one with `haptex db build --out DIR`, or pass --db DIR)", dir.display())
    })?;
    let mut model = TemplateModel::load_with(&dir, &metadata, template)?;
    if let Some(estimator) = args.estimator {
        model = model.with_estimator(estimator.into())?;
    }
    let prediction = model.predict(args.x0, args.width, args.height, args.velocity)?;
    let query = [args.width, args.height, args.velocity];
    let entry = metadata.entry(template).expect("the model was loaded from this entry");
    let source = model.describe(&query, &prediction, entry);
    let warning = model.warning(&query, prediction.fe_row, &prediction.diagnostics);
    let notes = model.estimate_notes(&metadata, &query, &prediction);
    Output::new(args.output.clone()).write(|w| {
        let comments = model.prediction_comments(&metadata, args.x0, &query, &source, warning.as_deref(), &notes);
        write_prediction_csv(w, &comments, &prediction.x_mm, &prediction.mu)
    })?;
    if !args.quiet {
        eprintln!("{source}");
        if let Some(e) = &notes.expected {
            eprintln!("expected error: {e}");
        }
        if let Some(warning) = warning {
            eprintln!("warning: {warning}");
        }
        if let Some(a) = &notes.advice {
            eprintln!("advice: {a}");
        }
        if let Some(c) = &notes.caveat {
            eprintln!("caveat: {c}");
        }
    }
    Ok(())
}
