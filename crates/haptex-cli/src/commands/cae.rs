//! `haptex cae`: the conditional average estimator (paper eqs. 10-12) over a
//! model matrix CSV: `predict` outputs at given inputs, `loo` the
//! leave-one-out error and the widths that minimize it.

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use haptex_core::cae::{Cae, CaeError, ModelMatrix, OptimizeOptions, Widths, optimize_widths};
use haptex_core::io::{Table, write_csv_row};
use haptex_core::num::Num;

use crate::args::{Output, positive};

/// Conditional average estimator (Gaussian-kernel regression) over a model
/// matrix: a CSV whose `--inputs` columns are the inputs and every other
/// column an output (e.g. the FE database: surface parameters, then the
/// sampled friction profile). Widths are in normalized input units (each
/// input spans [0, 1] over the database). See docs/cae.md.
#[derive(Debug, Args)]
pub struct CaeArgs {
    #[command(subcommand)]
    command: CaeCommand,
}

#[derive(Debug, Subcommand)]
enum CaeCommand {
    Predict(PredictArgs),
    Loo(LooArgs),
}

#[derive(Debug, Args)]
struct ModelArgs {
    /// Model matrix CSV (header row, `#` comments), or `-` for stdin.
    #[arg(long, value_name = "M.csv")]
    model: PathBuf,
    /// The input columns, comma-separated (every other column is an output).
    #[arg(long, value_name = "a,b,c", value_delimiter = ',', required = true)]
    inputs: Vec<String>,
    /// Memory the leave-one-out may use, in MiB. Its N x N weight matrix
    /// grows with the square of the model's rows (2048 MiB: N up to about
    /// 16 000); larger models are refused before any work. Within a larger
    /// budget the system may still refuse the memory: that is an error
    /// naming the matrix, never an abort.
    #[arg(long, value_name = "MIB", default_value_t = 2048, value_parser = clap::value_parser!(u64).range(1..=u64::MAX >> 20))]
    memory_budget_mib: u64,
}

impl ModelArgs {
    fn memory_budget_bytes(&self) -> u64 {
        self.memory_budget_mib << 20
    }

    fn read(&self) -> anyhow::Result<ModelMatrix> {
        let inputs: Vec<&str> = self.inputs.iter().map(|s| s.trim()).collect();
        Ok(if self.model.as_os_str() == "-" {
            ModelMatrix::read_csv(std::io::stdin().lock(), "<stdin>", &inputs)?
        } else {
            ModelMatrix::read_csv_file(&self.model, &inputs)?
        })
    }
}

#[derive(Debug, Args)]
struct WidthArgs {
    /// One constant kernel width W for every model vector and input
    /// (normalized units; the paper found 0.13 on its FE database).
    #[arg(long, value_name = "W", value_parser = positive, conflicts_with = "widths")]
    width: Option<f64>,
    /// Non-constant widths between WMIN and WMAX: wider where model vectors
    /// are sparse (rule in docs/cae.md). WMIN = WMAX is the constant width.
    #[arg(long, value_name = "WMIN,WMAX", value_parser = width_pair)]
    widths: Option<(f64, f64)>,
}

impl WidthArgs {
    fn get(&self) -> anyhow::Result<Option<Widths>> {
        Ok(match (self.width, self.widths) {
            (Some(w), _) => Some(Widths::constant(w)?),
            (None, Some((lo, hi))) => Some(Widths::range(lo, hi)?),
            (None, None) => None,
        })
    }
}

/// Predict the outputs at given inputs.
///
/// Writes a CSV: a `#` line naming the model and widths, a header of the
/// output column names, one row of predictions per query (`--at` queries
/// first, then the rows of `--at-file`). Without `--width`/`--widths` the
/// constant width with the smallest leave-one-out error is used (as `haptex
/// cae loo --constant` finds it). A query farther than 3 kernel widths from
/// every model vector gets an extrapolation warning on stderr.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    after_help = "Example:\n  haptex cae predict --model db.csv --inputs r_w,r_h --at r_w=1.2,r_h=0.3 --width 0.13 -o mu.csv"
)]
struct PredictArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// A query: every input named once, `name=value` pairs separated by
    /// commas. Repeat for several queries.
    #[arg(long, value_name = "a=1,b=2")]
    at: Vec<String>,
    /// A CSV of queries, one per row, with a column for every input (other
    /// columns are ignored).
    #[arg(long, value_name = "Q.csv")]
    at_file: Option<PathBuf>,
    #[command(flatten)]
    widths: WidthArgs,
    /// Output file (default: stdout). Written atomically.
    #[arg(short, long, value_name = "OUT")]
    output: Option<PathBuf>,
    /// Do not print the widths and warnings to stderr.
    #[arg(short, long)]
    quiet: bool,
}

/// Leave-one-out error and width optimization.
///
/// Predicts every model vector from the others and prints JSON: `n`, `d`,
/// `m`, `w_min`, `w_max` (the widths, normalized units), `rmse` (RMS of the
/// leave-one-out residuals over all rows and outputs, output units),
/// `rmse_per_output`, and `optimizer` (what the search did: the scan of
/// constant widths, evaluations, convergence, whether the optimum is at the
/// search range's edge). With `--width`/`--widths` the error is evaluated
/// at those widths instead of searched.
#[derive(Debug, Args)]
#[command(after_help = "Example:\n  haptex cae loo --model db.csv --inputs r_w,r_h,velocity --constant")]
struct LooArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Search a constant width only (w_min = w_max).
    #[arg(long, conflicts_with_all = ["width", "widths"])]
    constant: bool,
    #[command(flatten)]
    widths: WidthArgs,
    /// Smallest and largest width searched (normalized units).
    #[arg(long, value_name = "LO,HI", value_parser = width_pair, default_value = "0.005,2")]
    range: (f64, f64),
    /// Output file (default: stdout). Written atomically.
    #[arg(short, long, value_name = "OUT")]
    output: Option<PathBuf>,
}

pub fn run(args: CaeArgs) -> anyhow::Result<()> {
    match args.command {
        CaeCommand::Predict(args) => predict(args),
        CaeCommand::Loo(args) => loo(args),
    }
}

fn predict(args: PredictArgs) -> anyhow::Result<()> {
    let matrix = args.model.read()?;
    let mut queries: Vec<(String, Vec<f64>)> = Vec::new();
    for (i, text) in args.at.iter().enumerate() {
        let quoted = haptex_core::text::Quoted(text);
        let query = parse_at(text, matrix.inputs()).with_context(|| format!("--at {quoted} (query {})", i + 1))?;
        queries.push((format!("--at {quoted}"), query));
    }
    if let Some(path) = &args.at_file {
        let table = Table::read_file(path)?;
        let columns = matrix.inputs().iter().map(|name| table.require(name)).collect::<Result<Vec<_>, _>>()?;
        for row in 0..table.n_rows() {
            let label = format!("{}, line {}", table.source_name(), table.line_of_row(row));
            queries.push((label, columns.iter().map(|c| c[row]).collect()));
        }
    }
    if queries.is_empty() {
        bail!("no queries: give --at name=value,... (repeatable) or --at-file Q.csv");
    }
    let widths = match args.widths.get()? {
        Some(w) => w,
        None => {
            let options = OptimizeOptions {
                constant_only: true,
                memory_budget_bytes: args.model.memory_budget_bytes(),
                ..OptimizeOptions::default()
            };
            let optimum = optimize_widths(&matrix, options).map_err(budget_hint)?;
            if !args.quiet {
                eprintln!(
                    "width: {} (the constant width with the smallest leave-one-out error, RMSE {})",
                    Num(optimum.widths.w_min),
                    Num(optimum.errors.rmse)
                );
            }
            optimum.widths
        }
    };
    let cae = Cae::new(matrix, widths)?;
    let matrix = cae.matrix();
    // All the queries in one batch: eq. (11) as blocked matrix products.
    let flat: Vec<f64> = queries.iter().flat_map(|(_, q)| q.iter().copied()).collect();
    let (predictions, diagnostics) = cae.predict_batch(&flat).map_err(|e| match e {
        CaeError::BatchQuery { index, message } => anyhow::anyhow!("query {}: {message}", queries[index].0),
        other => other.into(),
    })?;
    let mut extrapolations = 0;
    for ((label, query), diagnostics) in queries.iter().zip(&diagnostics) {
        if let Some(warning) = cae.warning(query, diagnostics) {
            extrapolations += 1;
            if !args.quiet {
                eprintln!("warning: query {label}: {warning}");
            }
        }
    }
    let output = Output::new(args.output);
    output.write(|w| {
        writeln!(
            w,
            "# haptex cae predict: model {}, inputs {}, widths w_min = {}, w_max = {} (normalized units)",
            matrix.source_name(),
            matrix.inputs().join(","),
            Num(widths.w_min),
            Num(widths.w_max)
        )?;
        writeln!(w, "{}", matrix.outputs().join(","))?;
        for row in predictions.chunks_exact(matrix.m()) {
            write_csv_row(w, row)?;
        }
        Ok(())
    })?;
    if !args.quiet {
        eprintln!(
            "{} queries over {} model vectors ({} inputs, {} outputs); {extrapolations} extrapolated",
            queries.len(),
            matrix.n(),
            matrix.d(),
            matrix.m()
        );
        if let Some(path) = output.path() {
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(())
}

/// The JSON `haptex cae loo` prints.
fn loo(args: LooArgs) -> anyhow::Result<()> {
    let matrix = args.model.read()?;
    let (widths, errors, report) = match args.widths.get()? {
        Some(widths) => {
            let mut loo = haptex_core::cae::Loo::with_memory_budget(&matrix, args.model.memory_budget_bytes())
                .map_err(budget_hint)?;
            (widths, loo.errors(widths), None)
        }
        None => {
            let options = OptimizeOptions {
                constant_only: args.constant,
                search_range: args.range,
                memory_budget_bytes: args.model.memory_budget_bytes(),
                ..Default::default()
            };
            let optimum = optimize_widths(&matrix, options).map_err(budget_hint)?;
            (optimum.widths, optimum.errors, Some(optimum.report))
        }
    };
    let json = haptex_core::cae::LooReport::new(&matrix, widths, &errors, report.as_ref())?;
    if let Some(report) = &report
        && report.at_bound
    {
        eprintln!(
            "warning: the optimum touches the search range {} .. {}: widen it with --range",
            report.search_range[0], report.search_range[1]
        );
    }
    Output::new(args.output).write(|w| {
        serde_json::to_writer_pretty(&mut *w, &json).map_err(std::io::Error::from)?;
        w.write_all(b"\n")
    })
}

/// A memory-budget refusal says which flags change it.
fn budget_hint(error: CaeError) -> anyhow::Error {
    match error {
        CaeError::TooLarge(message) => {
            anyhow::anyhow!("{message}; the flags are --memory-budget-mib MIB and --width W")
        }
        other => other.into(),
    }
}

/// Parses `name=value,name=value` into the input vector, in `inputs` order.
fn parse_at(text: &str, inputs: &[String]) -> anyhow::Result<Vec<f64>> {
    let mut values: Vec<Option<f64>> = vec![None; inputs.len()];
    let index: std::collections::HashMap<&str, usize> =
        inputs.iter().enumerate().map(|(l, name)| (name.as_str(), l)).collect();
    for pair in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let Some((name, value)) = pair.split_once('=') else {
            bail!("'{pair}' is not name=value");
        };
        let name = name.trim();
        let Some(l) = index.get(name).copied() else {
            bail!("'{name}' is not an input of the model (inputs: {})", inputs.join(","));
        };
        let value: f64 = value.trim().parse().map_err(|_| anyhow::anyhow!("'{}' is not a number", value.trim()))?;
        if !value.is_finite() {
            bail!("{name} = {value} is not finite");
        }
        if values[l].replace(value).is_some() {
            bail!("input '{name}' is given twice");
        }
    }
    let missing: Vec<&str> = inputs.iter().zip(&values).filter(|(_, v)| v.is_none()).map(|(n, _)| n.as_str()).collect();
    if !missing.is_empty() {
        bail!("missing input(s): {}", missing.join(","));
    }
    Ok(values.into_iter().flatten().collect())
}

/// Parses `A,B` into two positive finite numbers.
fn width_pair(text: &str) -> Result<(f64, f64), String> {
    let (a, b) = text.split_once(',').ok_or_else(|| format!("expected two numbers A,B, got '{text}'"))?;
    Ok((positive(a)?, positive(b)?))
}
