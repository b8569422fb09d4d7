//! `haptex predict`: the friction profile of any bump, edge or sine from the
//! FE database by the conditional average estimator (paper section 3.2).

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};
use haptex_core::database::{Metadata, Template, TemplateModel};

use crate::args::{Output, positive};

/// Predict the friction profile Ft/Fn(x) of a template surface from the FE
/// database, in milliseconds.
///
/// The conditional average estimator (Gaussian kernels, the leave-one-out
/// optimal widths stored in the database's metadata) averages the database's
/// FE profiles of the same template, weighted by how close their (r_w, r_h,
/// velocity) are to the query. When the parameters are exactly a database
/// row, that row's FE profile is returned and the command says so. Queries
/// far from every database case, or with a parameter outside the database's
/// range of r_w, r_h or velocity, are answered with a warning: the estimate
/// then extrapolates and is unreliable.
///
/// Output: `x_mm,mu`, x the finger's position on the surface (the database
/// grid xi = -5 .. 5 mm shifted to the feature at x0), a friction profile
/// for `haptex voltage`.
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
    let model = TemplateModel::load_with(&dir, &metadata, template)?;
    let prediction = model.predict(args.x0, args.width, args.height, args.velocity)?;
    let query = [args.width, args.height, args.velocity];
    let source = match prediction.fe_row {
        Some(row) => format!(
            "FE result: r_w = {} mm, r_h = {} mm, v = {} mm/s is row {} of {} (no estimate involved)",
            args.width,
            args.height,
            args.velocity,
            row + 1,
            dir.join(template.file_name()).display()
        ),
        None => {
            let entry = metadata.entry(template).expect("the model was loaded from this entry");
            format!(
                "CAE estimate over {} FE profiles (widths {:.4} .. {:.4}); nearest case row {} at normalized \
                 distance {:.3}; typical error (leave-one-out RMS over the database) {:.4}, {:.0}% of a profile's \
                 range",
                model.cae.matrix().n(),
                model.cae.widths().w_min,
                model.cae.widths().w_max,
                prediction.diagnostics.nearest_row + 1,
                prediction.diagnostics.nearest_distance,
                entry.loo_rmse,
                100.0 * entry.loo_rmse_relative_to_range
            )
        }
    };
    let warning = if prediction.fe_row.is_some() {
        None
    } else {
        model.cae.warning(&query, &prediction.diagnostics).or_else(|| range_warning(&model, &query))
    };
    Output::new(args.output.clone()).write(|w| {
        writeln!(
            w,
            "# haptex predict: {} x0={} mm r_w={} mm r_h={} mm velocity={} mm/s",
            template.name(),
            args.x0,
            args.width,
            args.height,
            args.velocity
        )?;
        writeln!(w, "# {source}")?;
        if let Some(warning) = &warning {
            writeln!(w, "# warning: {warning}")?;
        }
        writeln!(w, "x_mm,mu")?;
        for (x, mu) in prediction.x_mm.iter().zip(&prediction.mu) {
            haptex_core::io::write_csv_row(w, &[*x, *mu])?;
        }
        Ok(())
    })?;
    if !args.quiet {
        eprintln!("{source}");
        if let Some(warning) = warning {
            eprintln!("warning: {warning}");
        }
    }
    Ok(())
}

/// A warning when a parameter lies outside the database's range although
/// the query is still within the kernel's reach of some case (the CAE's own
/// extrapolation warning covers queries farther away).
fn range_warning(model: &TemplateModel, query: &[f64; 3]) -> Option<String> {
    const NAMES: [(&str, &str); 3] = [("width r_w", "mm"), ("height r_h", "mm"), ("velocity", "mm/s")];
    let outside: Vec<String> = model
        .input_ranges()
        .iter()
        .zip(query)
        .zip(NAMES)
        .filter(|(((lo, hi), v), _)| *v < lo || *v > hi)
        .map(|(((lo, hi), v), (name, unit))| {
            format!("{name} = {v} {unit} is outside the database range {lo} .. {hi} {unit}")
        })
        .collect();
    (!outside.is_empty()).then(|| format!("{}: the estimate extrapolates the FE database", outside.join("; ")))
}
