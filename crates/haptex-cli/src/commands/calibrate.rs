//! `haptex calibrate`: the display's constants from measurements made on
//! it, with their intervals, and the device file the design commands take.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use haptex_core::calibration::device_file::DeviceFile;
use haptex_core::calibration::force_fit::{self, carrier_name};
use haptex_core::calibration::measurements::Measurements;
use haptex_core::calibration::ultrasonic_fit::Choice;
use haptex_core::calibration::{Calibration, Estimate, Goodness, Settings, calibrate, curves};
use haptex_core::electrovibration::Device;
use haptex_core::frequency::round3;
use haptex_core::num::Num;
use haptex_core::plot::{Figure, PALETTE, Panel, Series, Shape};
use haptex_core::ranges;

use crate::args::{LayerStackArgs, in_range};

/// Fit the display's models to measurements made on it: mu_HD and the
/// force coefficient c of eq. (3)/(8) per carrier, the circuit model's
/// rho_sc and air gap g across carriers, and the ultrasonic plate's
/// rho(a), each with its 95% interval and a verdict on what the
/// measurements cannot identify (docs/calibration.md).
///
/// The measurements are steady sliding segments (or their samples) under
/// constant drives: `voltage_v,carrier,carrier_hz,amplitude_um,ft_n,fn_n`
/// (or `mu`), optional `velocity_mm_s,finger,repetition`. Only identified
/// constants go into the device file (-o), which `voltage`, `check`,
/// `play`, `live`, `map` and `serve` take with --device.
#[derive(Debug, Args)]
#[command(after_help = "Example:\n  haptex calibrate --measurements data/examples/calibration-measurements.csv \
                  -o my-display.toml --png fit.png\n  \
                  haptex voltage --profile data/examples/bump.csv --device my-display.toml -o U.csv")]
pub struct CalibrateArgs {
    /// Measurements CSV (docs/calibration.md, "The measurements file").
    #[arg(long, value_name = "M.csv", required_unless_present = "recordings", conflicts_with = "recordings")]
    measurements: Option<PathBuf>,
    /// Or recorded strokes: a manifest (TOML) listing each recording with
    /// the constant drive it was made under (docs/calibration.md,
    /// "From recorded strokes"); each sliding segment is one measurement.
    #[arg(long, value_name = "MANIFEST.toml")]
    recordings: Option<PathBuf>,
    /// The device file to write (TOML).
    #[arg(short, long, value_name = "DEVICE.toml")]
    output: Option<PathBuf>,
    /// The display's highest voltage, U_max in V RMS (stated, not measured;
    /// written into the device file).
    #[arg(long, default_value_t = Device::PAPER.u_max_v, value_parser = in_range(ranges::U_MAX_V))]
    u_max: f64,
    /// The layer stack assumed: friction data measure only k over the
    /// stack's product, so the stack is stated, not fitted.
    #[command(flatten)]
    stack: LayerStackArgs,
    /// The form of the ultrasonic plate's rho(a): the exponential when the
    /// data identify it (auto), or always the monotone table.
    #[arg(long, value_enum, default_value_t = UltrasonicModel::Auto)]
    ultrasonic_model: UltrasonicModel,
    /// PNG: the data with the fitted models and their 95% bands, and the
    /// residuals.
    #[arg(long, value_name = "F.png")]
    png: Option<PathBuf>,
    /// No report on stderr.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum UltrasonicModel {
    Auto,
    Exponential,
    Table,
}

pub fn run(args: CalibrateArgs) -> anyhow::Result<()> {
    let (m, source) = match (&args.measurements, &args.recordings) {
        (Some(path), _) => (Measurements::read_file(path)?, path),
        (None, Some(manifest)) => (haptex_core::calibration::from_recordings::read_manifest(manifest)?, manifest),
        (None, None) => anyhow::bail!("give --measurements or --recordings"),
    };
    let settings = Settings {
        stack: args.stack.stack(),
        ultrasonic: match args.ultrasonic_model {
            UltrasonicModel::Auto => Choice::Auto,
            UltrasonicModel::Exponential => Choice::Exponential,
            UltrasonicModel::Table => Choice::Table,
        },
    };
    settings.stack.validate()?;
    let cal = calibrate(&m, settings);
    if cal.force.is_none() && cal.ultrasonic.is_none() {
        anyhow::bail!(
            "{}: no row has a voltage or a vibration: the friction at rest alone calibrates nothing",
            source.display()
        );
    }
    let mut file = DeviceFile::from_calibration(&cal, &m, args.u_max);
    let report = report(&cal, &m, &file);
    if let Some(path) = &args.output {
        file.path = path.display().to_string();
        if file.electrovibration.is_none() && file.ultrasonic.is_none() {
            if !args.quiet {
                eprint!("{report}");
            }
            anyhow::bail!(
                "{}: the measurements identify no constant of the display (see the verdicts above): no device file \
                 written",
                path.display()
            );
        }
        let text = file.to_toml();
        haptex_core::io::write_atomic(path, |w| w.write_all(text.as_bytes()))?;
    }
    if let Some(path) = &args.png {
        figure(&cal, &m).write_png(path)?;
    }
    if !args.quiet {
        eprint!("{report}");
        for (label, path) in [("device file", &args.output), ("PNG", &args.png)] {
            if let Some(p) = path {
                eprintln!("{label}: {}", p.display());
            }
        }
    }
    Ok(())
}

/// "0.601 (95%: 0.583 .. 0.619)", or the interval and "not identified".
fn estimate(e: &Estimate, unit: &str) -> String {
    let r = round3;
    let unit = if unit.is_empty() { String::new() } else { format!(" {unit}") };
    if e.identified {
        format!("{}{unit} (95%: {} .. {})", Num(r(e.value)), Num(r(e.interval[0])), Num(r(e.interval[1])))
    } else {
        format!("not identified (95% interval {} .. {}{unit})", Num(r(e.interval[0])), Num(r(e.interval[1])))
    }
}

fn goodness_line(g: &Goodness) -> String {
    let r = round3;
    let mut s = format!(
        "{} rows; RMS residual {}, robust noise {}, R^2 {}",
        g.rows,
        Num(r(g.rms)),
        Num(r(g.scale)),
        Num((g.r2 * 1e4).round() / 1e4)
    );
    if let Some(l) = g.lack_of_fit {
        s += &format!("; lack of fit F = {} on ({}, {}), p = {}", Num(r(l.f)), l.df1, l.df2, Num(r(l.p)));
    }
    if !g.converged {
        s += "; the fit did not converge";
    }
    s
}

fn report(cal: &Calibration, m: &Measurements, file: &DeviceFile) -> String {
    let mut out = format!(
        "haptex calibrate: {} ({} rows, sha256 {})\n",
        m.source_name(),
        m.rows().len(),
        &m.sha256()[..m.sha256().len().min(12)]
    );
    let stack = &cal.settings.stack;
    if let Some(f) = &cal.force {
        let g = &f.eq3.goodness;
        if let Some(level) = g.cluster_level {
            out += &format!("intervals rest on {}\n", level.describe(g.clusters));
        }
        out += &format!("eq. (3)/(8), c per carrier: mu_HD = {}\n", estimate(&f.eq3.mu_hd, ""));
        for c in &f.eq3.carriers {
            out += &format!(
                "  {}: c = {}; k = {} mm^2/N with the stack assumed; {} rows up to {} V\n",
                carrier_name(&c.carrier),
                estimate(&c.c_per_v2, "1/V^2"),
                Num(round3(force_fit::equivalent_k_mm2_per_n(c.c_per_v2.value, stack))),
                c.rows,
                Num(c.max_voltage_v)
            );
        }
        if f.eq3.goodness.rows > 0 {
            out += &format!("  fit: {}\n", goodness_line(&f.eq3.goodness));
        }
        if let Some(c) = &f.circuit {
            out += "circuit model across carriers:\n";
            out += &format!("  mu_HD = {}\n", estimate(&c.mu_hd, ""));
            out += &format!("  c (eq. 3's coefficient) = {}\n", estimate(&c.c_per_v2, "1/V^2"));
            out +=
                &format!("  rho_sc = {}; corner {} Hz\n", estimate(&c.rho_sc_ohm_m, "ohm m"), Num(round3(c.corner_hz)));
            out += &format!("  air gap g = {}\n", estimate(&c.gap_um, "um"));
            out += &format!("  fit: {}\n", goodness_line(&c.goodness));
        }
        let c = file.electrovibration.as_ref().and_then(|e| {
            e.circuit.as_ref().map(|c| c.c_per_v2.value).or(e.carriers.first().map(|c| c.c_per_v2.value))
        });
        if let Some(c) = c {
            out += &format!(
                "friction measures c = eps0 k / (2 (d_sc/eps_sc + d_i/eps_i)(d_sc + d_i)): the product k / stack = \
                 2 c / eps0 = {} 1/N; k, eps_sc, d_sc, eps_i and d_i are not separable from friction (the stack \
                 is assumed: eps_sc {}, d_sc {} mm, eps_i {}, d_i {} mm)\n",
                Num(round3(force_fit::k_over_stack_per_n(c))),
                Num(stack.eps_sc),
                Num(stack.d_sc_mm),
                Num(stack.eps_i),
                Num(stack.d_i_mm)
            );
        }
        let outliers = f.circuit.as_ref().map_or(&f.eq3.outliers, |c| &c.outliers);
        if !outliers.is_empty() {
            let lines: Vec<String> = outliers.iter().take(20).map(|o| o.line.to_string()).collect();
            out += &format!(
                "{} measurement(s) more than 3 robust SD from the model, down-weighted (kept): line{} {}{}\n",
                outliers.len(),
                if outliers.len() == 1 { "" } else { "s" },
                lines.join(", "),
                if outliers.len() > 20 { ", ..." } else { "" }
            );
        }
    }
    if let Some(u) = &cal.ultrasonic {
        out += "ultrasonic plate, rho(a) = mu(a) / mu(0):\n";
        if let Some(e) = &u.exponential {
            out += &format!(
                "  exponential: rho_inf = {}, a_c = {}\n  fit: {}\n",
                estimate(&e.rho_inf, ""),
                estimate(&e.a_c_um, "um"),
                goodness_line(&e.goodness)
            );
        }
        if u.table.len() >= 2 {
            let points: Vec<String> =
                u.table.iter().map(|p| format!("{} um: {}", Num(p.amplitude_um), Num(round3(p.rho)))).collect();
            out += &format!("  monotone table: {}\n", points.join("; "));
        }
        if u.table.len() >= 2 {
            out += &format!(
                "  rho_min = rho(a_max = {} um) = {}; the device file uses the {}\n",
                Num(u.a_max_um),
                estimate(&u.rho_min, ""),
                if u.chosen == Choice::Exponential { "exponential" } else { "table" }
            );
        }
    }
    if !cal.verdicts.is_empty() {
        out += "what the measurements cannot tell:\n";
        for v in &cal.verdicts {
            out += &format!("  - {v}\n");
        }
    }
    if let Some(e) = &file.electrovibration {
        out += &format!("device file model: {} (mu_HD {})\n", e.model, Num(round3(e.mu_hd.value)));
    }
    out
}

fn lighter(c: (u8, u8, u8)) -> (u8, u8, u8) {
    let l = |v: u8| (v as u16 + (255 - v as u16) * 3 / 4) as u8;
    (l(c.0), l(c.1), l(c.2))
}

/// A band as a filled polygon.
fn band(x: &[f64], lo: &[f64], hi: &[f64], color: (u8, u8, u8)) -> Shape {
    let mut points: Vec<(f64, f64)> = x.iter().zip(hi).map(|(a, b)| (*a, *b)).collect();
    points.extend(x.iter().zip(lo).rev().map(|(a, b)| (*a, *b)));
    Shape { points, fill: Some(lighter(color)), stroke: None }
}

fn figure(cal: &Calibration, m: &Measurements) -> Figure {
    let mut figure = Figure::new(format!("haptex calibrate: {}", m.source_name()));
    if let Some(f) = curves::force(cal, m) {
        let title = if f.model == "circuit" { "circuit model, 95% band" } else { "eq. (3) per carrier, 95% band" };
        let mut panel = Panel::new("U (V RMS)", "mu / mu(0 V) - 1").title(title);
        let mut residuals = Panel::new("fitted mu", "measured - fitted").title("residuals");
        for (k, c) in f.carriers.iter().enumerate() {
            let color = PALETTE[k % PALETTE.len()];
            let column = |j: usize| -> Vec<f64> { c.rise.iter().map(|b| b[j]).collect() };
            panel = panel
                .shape(band(&c.grid_u_v, &column(1), &column(2), color))
                .series(Series::points("", &c.data_u_v, &c.data_rise).color(color))
                .series(Series::line(c.name.clone(), &c.grid_u_v, &column(0)).color(color));
            residuals = residuals.series(Series::points(c.name.clone(), &c.fitted, &c.residual).color(color));
        }
        figure = figure.panel(panel).panel(residuals);
    }
    if let Some(u) = curves::ultrasonic(cal, m) {
        let mut panel = Panel::new("a (um, peak)", "rho = mu(a) / mu(0)")
            .title("ultrasonic plate")
            .series(Series::points("measured / mean at rest", &u.data_amplitude_um, &u.data_rho).color(PALETTE[7]))
            .series(Series::line("monotone table", &u.table_amplitude_um, &u.table_rho).color(PALETTE[1]));
        if let Some(e) = &u.exponential {
            let column = |j: usize| -> Vec<f64> { e.iter().map(|b| b[j]).collect() };
            panel = panel
                .shape(band(&u.grid_amplitude_um, &column(1), &column(2), PALETTE[0]))
                .series(Series::line("exponential, 95% band", &u.grid_amplitude_um, &column(0)).color(PALETTE[0]));
        }
        figure = figure.panel(panel);
    }
    figure
}
