//! `haptex compensate`: the next design of a display from strokes measured
//! on it, by iterative learning control (haptex_core::ilc;
//! docs/measured-compensation.md).

use std::path::PathBuf;

use clap::Args;
use haptex_core::electrovibration::{ContactArea, Device};
use haptex_core::ilc::{self, Design, DisplayModel, Kept, Limit, Settings, Step, Stroke};
use haptex_core::io::Table;
use haptex_core::num::Num;
use haptex_core::plot::{Figure, Panel};
use haptex_core::ranges;
use haptex_core::signal::{Carrier, CarrierShape};

use crate::args::{DesignDevice, DeviceFileArgs, DisplayArg, DisplayArgs, LayerStackArgs, in_range, positive};

/// Compute the next design of a friction display from strokes measured on
/// the last one (iterative learning control).
///
/// Play the design (a `haptex voltage` profile, `x_mm,mu,voltage_v`, the
/// mu column being the target; or a combined display's profile with
/// `amplitude_um`), stroke the display at least twice at a steady velocity
/// and force while recording the forces (recordings, NAME.recording.json,
/// or CSVs of `x_mm,ft_n,fn_n` in the design's coordinates), and give the
/// strokes here. The strokes' mean friction is compared with the target
/// over the renderable region; the friction command the design asks of
/// the display model is corrected by the error (low-pass filtered, shifted
/// by the display's lag, divided by the gain the strokes show) and mapped
/// to the next design, which never exceeds U_max or a_max.
///
/// When the error is within 1.5 times the noise floor (the RMS standard
/// error of the strokes' mean) the design is written unchanged: a further
/// iteration would chase noise. The written design carries the iteration
/// history in `# ilc iteration` lines, so give it as --design next time.
#[derive(Debug, Args)]
#[command(after_help = "Examples:\n  haptex voltage --profile target.csv --mu-hd 0.5 -o u0.csv\n  \
                  haptex compensate --design u0.csv --measured s1.csv s2.csv s3.csv s4.csv --mu-hd 0.5 -o u1.csv \
                  --report r.csv --png u1.png\n  \
                  haptex compensate --design u1.csv --measured t1.csv t2.csv t3.csv t4.csv --mu-hd 0.5 -o u2.csv\n\n\
                  With a device file (`haptex calibrate`): mu_HD, the stack, k (or the circuit, on the carrier the \
                  design states) and U_max are the file's; a design made with another device file is refused:\n  \
                  haptex compensate --design u0.csv --measured s1.csv s2.csv s3.csv --device my-display.toml -o u1.csv",
    mut_args = crate::args::set_by_device_file(&["mu_hd", "eps_sc", "eps_i", "d_sc_mm", "d_i_mm", "k_mm2_per_n",
               "ultrasonic_calibration"])
)]
pub struct CompensateArgs {
    /// The design played: `x_mm,mu,voltage_v` (mu the target), with
    /// `amplitude_um` for a combined display; its `# ilc iteration` lines
    /// are the history.
    #[arg(long, value_name = "U.csv")]
    design: PathBuf,
    /// The strokes measured on it (at least 2): NAME.recording.json
    /// recordings, or CSVs of `x_mm,ft_n,fn_n` (or `x_mm,mu`) that cover
    /// the design's span.
    #[arg(long, value_name = "STROKE", num_args = 1.., required = true)]
    measured: Vec<PathBuf>,
    /// The next design (written atomically), with the history.
    #[arg(short, long, value_name = "U-next.csv")]
    output: PathBuf,
    /// The learning gain L in (0, 1]: the share of the measured error
    /// corrected per iteration (lower it if the error rises from one
    /// iteration to the next).
    #[arg(long, default_value_t = 1.0, value_parser = learning_gain)]
    gain: f64,
    /// Standard deviation of the Q-filter (the Gaussian low-pass on the
    /// error), mm. Default: 0.05 mm or the design's median spacing,
    /// whichever is larger.
    #[arg(long, value_parser = positive)]
    q_sigma_mm: Option<f64>,
    /// Keep the design once the history has this many iterations.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=1000))]
    max_iterations: u32,
    /// CSV of the history: iteration,rms_error,noise_floor,max_error,lag_mm,strokes,limited_by.
    #[arg(long, value_name = "R.csv")]
    report: Option<PathBuf>,
    /// PNG: target, measured mean with a +-2 standard-error band, and the
    /// current and next drive.
    #[arg(long, value_name = "P.png")]
    png: Option<PathBuf>,
    /// Friction coefficient of the finger on the display with no drive, mu_HD.
    #[arg(long, default_value_t = Device::PAPER.mu_hd, value_parser = in_range(ranges::MU_HD))]
    mu_hd: f64,
    /// Highest voltage the display can apply, U_max in V RMS (default 100;
    /// with --device the file's, which this may lower, never raise).
    #[arg(long, value_parser = in_range(ranges::U_MAX_V))]
    u_max: Option<f64>,
    /// Contact-area coefficient k of eq. (8) in mm^2/N (A = k Fn).
    #[arg(long, default_value_t = ContactArea::PAPER.k_mm2_per_n, value_parser = in_range(ranges::K_MM2_PER_N))]
    k_mm2_per_n: f64,
    #[command(flatten)]
    stack: LayerStackArgs,
    #[command(flatten)]
    display: DisplayArgs,
    #[command(flatten)]
    device_file: DeviceFileArgs,
    /// No summary on stderr.
    #[arg(short, long)]
    quiet: bool,
}

fn learning_gain(text: &str) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|_| format!("'{text}' is not a number"))?;
    if value > 0.0 && value <= 1.0 { Ok(value) } else { Err(format!("must be in (0, 1], got {text}")) }
}

/// The display's constants as the flags give them, or as the device file
/// gives them for the carrier the design states (default sine 1000 Hz):
/// the one place a device is built here.
fn device(args: &CompensateArgs, file: Option<&DesignDevice>, comments: &[String]) -> anyhow::Result<Device> {
    if let Some(file) = file {
        file.check_design(comments, &args.design.display().to_string())?;
        let carrier = match haptex_core::signal::play::stated_carrier(comments) {
            None => Carrier::DEFAULT,
            Some(Ok((shape, f))) => Carrier {
                shape: match shape.as_str() {
                    "square" => CarrierShape::Square,
                    "none" => CarrierShape::None,
                    _ => CarrierShape::Sine,
                },
                frequency_hz: f,
            },
            Some(Err(text)) => anyhow::bail!(
                "{}: cannot read the design carrier in its comment ('designed for the carrier: {text}')",
                args.design.display()
            ),
        };
        return Ok(file.device(&carrier, args.u_max)?);
    }
    let device = Device {
        stack: args.stack.stack(),
        contact: ContactArea { k_mm2_per_n: args.k_mm2_per_n, exponent: 1.0 },
        mu_hd: args.mu_hd,
        u_max_v: args.u_max.unwrap_or(Device::PAPER.u_max_v),
        force_gain: 1.0,
    };
    device.validate()?;
    Ok(device)
}

pub fn run(args: CompensateArgs) -> anyhow::Result<()> {
    let file = args.device_file.read()?;
    let table = Table::read_file(&args.design)?;
    let device = device(&args, file.as_ref(), table.comments())?;
    let ultrasonic = match args.display.display {
        DisplayArg::Electrovibration => {
            args.display.refuse_display_flags()?;
            None
        }
        DisplayArg::Combined => Some(args.display.ultrasonic(file.as_ref())?),
        DisplayArg::Ultrasonic => anyhow::bail!(
            "compensate iterates an electrovibration or a combined display's design; for the plate alone give \
             --display combined"
        ),
    };
    let strategy = args.display.strategy()?;
    let model = match (&ultrasonic, strategy) {
        (Some(ultrasonic), Some(strategy)) => DisplayModel::Combined { device, ultrasonic, strategy },
        _ => DisplayModel::Electrovibration(device),
    };
    let design = Design::from_table(&table, &model)?;
    let strokes = args.measured.iter().map(|p| Stroke::read_file(p)).collect::<Result<Vec<_>, _>>()?;
    let settings =
        Settings { gain: args.gain, q_sigma_mm: args.q_sigma_mm, max_iterations: args.max_iterations as usize };
    let step = ilc::iterate(&design, &model, &strokes, &settings)?;
    let mut history = design.history.clone();
    history.push(step.entry);

    // Every output is made in memory first: an error in any leaves none written.
    let mut design_bytes = ilc::next_design_csv(&design, &step, &history, &model)?;
    if let Some(file) = &file {
        // The next design names the device file it was made with, and the
        // carrier its force coefficient is for (read back by `play`).
        let carrier_line = table.comments().iter().find(|l| l.contains("designed for the carrier: ")).cloned();
        let mut head = format!("# {}\n", file.comment());
        if let Some(line) = carrier_line {
            head += &format!("{line}\n");
        }
        design_bytes.splice(0..0, head.into_bytes());
    }
    let report_bytes = args.report.as_ref().map(|_| ilc::report_csv(&history).into_bytes());
    let png_bytes = match &args.png {
        Some(_) => Some(figure(&args, &design, &step).to_png()?),
        None => None,
    };
    haptex_core::io::write_atomic(&args.output, |w| w.write_all(&design_bytes))?;
    if let (Some(path), Some(bytes)) = (&args.report, &report_bytes) {
        haptex_core::io::write_atomic(path, |w| w.write_all(bytes))?;
    }
    if let (Some(path), Some(bytes)) = (&args.png, &png_bytes) {
        haptex_core::io::write_atomic(path, |w| w.write_all(bytes))?;
    }
    if !args.quiet {
        for line in summary(&args, &design, &step, &model) {
            eprintln!("{line}");
        }
    }
    Ok(())
}

fn figure(args: &CompensateArgs, design: &Design, step: &Step) -> Figure {
    let x = design.target.x_mm();
    let band = |sign: f64| -> Vec<f64> {
        step.mean.mu.iter().zip(&step.mean.standard_error).map(|(m, se)| m + sign * 2.0 * se).collect()
    };
    let title = format!(
        "haptex compensate: {}, iteration {} ({} strokes)",
        args.design.display(),
        step.entry.iteration,
        step.entry.strokes
    );
    let mut figure = Figure::new(title)
        .panel(
            Panel::new("x (mm)", "Ft/Fn")
                .line("target", x, design.target.mu())
                .line("measured mean", x, &step.mean.mu)
                .line("mean + 2 SE", x, &band(1.0))
                .line("mean - 2 SE", x, &band(-1.0)),
        )
        .panel(Panel::new("x (mm)", "U (V RMS)").line("design played", x, &design.drive.voltage_v).line(
            "next design",
            x,
            &step.next.voltage_v,
        ));
    if let (Some(a), Some(next)) = (&design.drive.amplitude_um, &step.next.amplitude_um) {
        figure =
            figure.panel(Panel::new("x (mm)", "a (um peak)").line("design played", x, a).line("next design", x, next));
    }
    figure
}

/// The summary on stderr: the measurement, the update, what limits it.
fn summary(args: &CompensateArgs, design: &Design, step: &Step, model: &DisplayModel) -> Vec<String> {
    let e = &step.entry;
    let device = model.device();
    let display = match model {
        DisplayModel::Electrovibration(_) => "electrovibration display".to_string(),
        DisplayModel::Combined { strategy, .. } => format!("combined display, {} strategy", strategy.kind()),
    };
    let mut lines = vec![
        format!(
            "haptex compensate: iteration {} of {} ({display}, mu_HD = {}, U_max = {} V), {} strokes",
            e.iteration,
            args.design.display(),
            Num(device.mu_hd),
            Num(device.u_max_v),
            e.strokes
        ),
        format!(
            "measured mean against the target over the renderable region ({:.1}% of the length): RMS error {:.3e}, \
             max {:.3e}; noise floor {:.3e} (RMS standard error of the mean); error / floor = {:.2}",
            100.0 * (1.0 - step.not_renderable_fraction),
            e.rms_error,
            e.max_error,
            e.noise_floor,
            e.rms_error / e.noise_floor.max(f64::MIN_POSITIVE)
        ),
        format!(
            "display lag {:.4} mm, plant gain {:.3} (1: as the model predicts), Q-filter sigma {} mm, learning gain {}",
            e.lag_mm,
            e.plant_gain,
            Num(step.q_sigma_mm),
            Num(args.gain)
        ),
    ];
    if let Some(previous) = design.history.last() {
        lines.push(format!(
            "history: {} earlier iteration{}, last RMS error {:.3e}",
            design.history.len(),
            if design.history.len() == 1 { "" } else { "s" },
            previous.rms_error
        ));
    }
    match step.kept {
        Some(Kept::AtNoiseFloor) => lines.push(format!(
            "at the noise floor: a further iteration would chase noise; the design is unchanged (error within {} \
             noise floors)",
            Num(ilc::STOP_FACTOR)
        )),
        Some(Kept::IterationLimit) => lines.push(format!(
            "iteration limit: the history has {} iterations (--max-iterations {}); the design is unchanged",
            e.iteration + 1,
            args.max_iterations
        )),
        None => {
            let change = rms_difference(&step.command, &step.next_command);
            let (lo, hi) = step.next.voltage_v.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &u| (a.min(u), b.max(u)));
            lines.push(format!(
                "next design: the friction command changed by {change:.3e} RMS; voltage {lo:.2} .. {hi:.2} V (U_max {} V)",
                Num(device.u_max_v)
            ));
        }
    }
    lines.push(format!(
        "limited by: {}",
        match e.limited_by {
            Limit::NoiseFloor => "the noise floor (more strokes per iteration lower it)".to_string(),
            Limit::NotRenderable => format!(
                "the region the display cannot render ({:.1}% of the length outside its band {:.4} .. {:.4}); the rest \
                 is at the noise floor",
                100.0 * step.not_renderable_fraction,
                step.band[0],
                step.band[1]
            ),
            Limit::UMax => format!(
                "the display's limit: over {:.1}% of the renderable length the update asks for more than U_max{} or \
                 less than nothing",
                100.0 * step.saturated_fraction,
                if model.a_max_um().is_some() { " and a_max" } else { "" }
            ),
            Limit::Iterations => "the iteration count: measure the next design and run compensate again".to_string(),
        }
    ));
    if step.not_renderable_fraction > 1e-9 && e.limited_by != Limit::NotRenderable {
        lines.push(format!(
            "not renderable: {:.1}% of the target is outside the display's band {:.4} .. {:.4}; no iteration changes \
             the friction felt there",
            100.0 * step.not_renderable_fraction,
            step.band[0],
            step.band[1]
        ));
    }
    lines.extend(step.warnings.iter().map(|w| format!("warning: {w}")));
    for (label, path) in [("design", Some(&args.output)), ("report", args.report.as_ref()), ("PNG", args.png.as_ref())]
    {
        if let Some(p) = path {
            lines.push(format!("wrote {label}: {}", p.display()));
        }
    }
    lines
}

fn rms_difference(a: &[f64], b: &[f64]) -> f64 {
    (a.iter().zip(b).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / a.len().max(1) as f64).sqrt()
}
