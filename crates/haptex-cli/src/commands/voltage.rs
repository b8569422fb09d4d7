//! `haptex voltage`: friction profile -> electrovibration voltage profile
//! (paper eqs. 3-9), or the drive of an ultrasonic or combined display
//! (`--display`, docs/physics.md).

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use haptex_core::combined::{Channels, map_display};
use haptex_core::electrovibration::{ContactArea, Device, Method, map_profile, map_profile_relative};
use haptex_core::profile::FrictionProfile;
use haptex_core::ranges;
use haptex_core::relative::FlatMu;
use haptex_fem::render;

use crate::args::{
    DesignDevice, DeviceFileArgs, DisplayArg, DisplayArgs, ForceModelArgs, LayerStackArgs, Output, in_range,
    read_profile,
};

/// Compute the voltage an electrovibration display must apply to reproduce a
/// friction profile.
///
/// Reads a friction profile (CSV `x_mm,mu` or `x_mm,ft_n,fn_n`; `-` for
/// stdin) and writes `x_mm,mu,voltage_v`. Voltages are RMS values. Defaults
/// are the constants of the paper's Fig. 2. Where the display cannot follow
/// the profile (U above U_max, or mu_RS below mu_HD) the summary on stderr
/// says where.
///
/// With --relative the profile is first divided by its flat-surface friction
/// mu_flat and scaled to the display's mu_HD, as the paper's Fig. 2 does
/// (its "normalized output", with mu_HD = 1): the display's own friction then
/// stands for the surface's flat friction, and eq. (8) renders what the
/// features add to it. mu_flat is --flat-mu, else the profile's median.
///
/// --display ultrasonic designs the vibration amplitude of an ultrasonic
/// friction-reduction plate instead (it renders friction below mu_HD), and
/// --display combined both channels, the felt friction being
/// mu_HD rho(a) (1 + Fe(U)/Fn): the output then has a column per channel
/// in use (`voltage_v`, `amplitude_um`).
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    after_help = "Examples:\n  haptex voltage --profile data/examples/bump_friction.csv -o voltage.csv\n  \
                  haptex predict --surface bump --x0 5 --width 1.3 --height 0.27 | haptex voltage --profile - \
                  --relative --flat-mu 0.5\n  \
                  haptex voltage --profile data/examples/bump_friction.csv --display combined --strategy split \
                  --ultrasonic-calibration data/examples/ultrasonic_calibration.csv -o drive.csv\n\n\
                  With a device file (`haptex calibrate`): mu_HD, the stack, k (or the circuit) and U_max are the \
                  file's; give the carrier it will be played on (default sine 1000 Hz):\n  \
                  haptex voltage --profile data/examples/bump_friction.csv --device my-display.toml -o u.csv\n  \
                  haptex voltage --profile data/examples/bump_friction.csv --device my-display.toml --carrier sine \
                  --carrier-hz 300 --u-max 80 -o u300.csv   (--u-max may lower the file's U_max)\n  \
                  haptex play --profile u300.csv --device my-display.toml --carrier sine --carrier-hz 300 --velocity 50 \
                  -o u300.wav",
    mut_args = crate::args::set_by_device_file(&["mu_hd", "eps_sc", "eps_i", "d_sc_mm", "d_i_mm", "k_mm2_per_n", "area_exponent", "force_model",
               "rho_sc_ohm_m", "gap_um", "ultrasonic_calibration"])
)]
pub struct VoltageArgs {
    /// Friction profile CSV (`x_mm,mu` or `x_mm,ft_n,fn_n`), or `-` for stdin.
    #[arg(long, value_name = "P.csv")]
    profile: PathBuf,
    /// physical: eq. (8), reproduces the friction force; normalized: eq. (9),
    /// the pattern only (min mu -> 0 V, max mu -> U_max).
    #[arg(long, value_enum, default_value_t = MethodArg::Physical)]
    method: MethodArg,
    /// Friction coefficient of the finger on the display with no voltage, mu_HD.
    #[arg(long, default_value_t = Device::PAPER.mu_hd, value_parser = in_range(ranges::MU_HD))]
    mu_hd: f64,
    /// Map the profile relative to its flat-surface friction (paper Fig. 2):
    /// mu / mu_flat * mu_HD. The written mu column is the relative friction.
    #[arg(long)]
    relative: bool,
    /// The profile's flat-surface friction mu_flat for --relative: for FE
    /// profiles (haptex simulate, predict) the skin friction mu_skin, 0.5 for
    /// the shipped database; for a recording the friction on the flat
    /// surface. Default: the profile's median, an estimate.
    #[arg(long, requires = "relative", value_parser = in_range(ranges::FLAT_MU))]
    flat_mu: Option<f64>,
    #[command(flatten)]
    stack: LayerStackArgs,
    /// Contact-area coefficient k in mm^2/N (A = k Fn^n; mm^2/N^n when n != 1).
    #[arg(long, default_value_t = ContactArea::PAPER.k_mm2_per_n, value_parser = in_range(ranges::K_MM2_PER_N))]
    k_mm2_per_n: f64,
    /// Contact-area exponent n in A = k Fn^n (1 = the paper's linear law;
    /// other values need the normal force, from --fn-n or an fn_n column).
    #[arg(long, default_value_t = ContactArea::PAPER.exponent, value_parser = in_range(ranges::AREA_EXPONENT))]
    area_exponent: f64,
    /// Exploration normal force Fn in N (only used when --area-exponent != 1).
    #[arg(long, value_parser = in_range(ranges::FN_N))]
    fn_n: Option<f64>,
    /// Highest voltage the display can apply, U_max in V RMS: the clip level
    /// (physical) or the full scale (normalized). Default 100, or the
    /// device file's (which --u-max may lower, not raise).
    #[arg(long, value_parser = in_range(ranges::U_MAX_V))]
    u_max: Option<f64>,
    /// Output format (default: json if OUT ends in .json, else csv).
    #[arg(long, value_enum)]
    format: Option<Format>,
    /// Output file (default: stdout). Written atomically.
    #[arg(short, long, value_name = "OUT")]
    output: Option<PathBuf>,
    #[command(flatten)]
    display: DisplayArgs,
    #[command(flatten)]
    force: ForceModelArgs,
    #[command(flatten)]
    device_file: DeviceFileArgs,
    /// Compensate the voltage on the FE finger model (physical method):
    /// eq. (8)'s voltage corrected run by run until the friction the
    /// finger feels on the display matches the profile (see `haptex
    /// check`); the file's first comment states the achieved error.
    #[arg(long)]
    compensate: bool,
    /// With --compensate: the finger's normal load, N per mm of width.
    #[arg(long, value_parser = crate::args::positive, requires = "compensate")]
    load: Option<f64>,
    /// With --compensate: most FE runs, eq. (8)'s included.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=100), requires = "compensate")]
    max_runs: u32,
    /// Do not print the summary to stderr.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum MethodArg {
    Physical,
    Normalized,
}

#[derive(Debug, Clone, Copy, PartialEq, ValueEnum)]
enum Format {
    Csv,
    Json,
}

pub fn run(args: VoltageArgs) -> anyhow::Result<()> {
    let profile = read_profile(&args.profile)?;
    let device_file = args.device_file.read()?;
    let (device, notes, circuit) = match &device_file {
        Some(file) => device_file_design(file, &args)?,
        None => {
            let force_model = args.force.model()?;
            let stack = args.stack.stack();
            let device = Device {
                stack,
                contact: ContactArea { k_mm2_per_n: args.k_mm2_per_n, exponent: args.area_exponent },
                mu_hd: args.mu_hd,
                u_max_v: args.u_max.unwrap_or(Device::PAPER.u_max_v),
                force_gain: force_model.gain(&stack),
            };
            let notes: Vec<String> = force_model.design_comment(&device).into_iter().collect();
            let circuit = !notes.is_empty();
            (device, notes, circuit)
        }
    };
    if circuit && args.compensate {
        anyhow::bail!(
            "--compensate runs the FE finger with eq. (3)'s attraction: it cannot compensate a --force-model circuit \
             design (nor one of a device file of the circuit model); drop one of them"
        );
    }
    let method = match args.method {
        MethodArg::Physical => Method::Physical,
        MethodArg::Normalized => Method::Normalized,
    };
    if args.display.display != DisplayArg::Electrovibration {
        return run_display(args, &profile, &device, method, notes, device_file.as_ref());
    }
    args.display.refuse_display_flags()?;
    let mut voltage = if args.relative {
        let flat = args.flat_mu.map_or(FlatMu::Median, FlatMu::Given);
        map_profile_relative(&profile, &device, method, args.fn_n, flat)?
    } else {
        map_profile(&profile, &device, method, args.fn_n)?
    };

    let mut comment = None;
    if args.compensate {
        let (compensated, c) =
            render::compensate_design(voltage, &device, args.load, args.max_runs as usize, None, &mut |_, _| {})?;
        voltage = compensated;
        comment = Some(c);
    }
    let output = Output::new(args.output);
    write_output(&output, args.format, &voltage, device_file.as_ref().map(|f| (f, &notes[..])), |w| {
        for c in comment.iter().chain(&notes) {
            writeln!(w, "# {c}")?;
        }
        voltage.write_csv(w)
    })?;
    if !args.quiet {
        eprint!("{}", voltage.summary);
        for c in notes.iter().chain(&comment) {
            eprintln!("{c}");
        }
        if let Some(path) = output.path() {
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(())
}

/// `--display ultrasonic` or `combined`: the drive of each channel in use.
fn run_display(
    args: VoltageArgs,
    profile: &FrictionProfile,
    device: &Device,
    method: Method,
    notes: Vec<String>,
    device_file: Option<&DesignDevice>,
) -> anyhow::Result<()> {
    if method != Method::Physical {
        anyhow::bail!("--method normalized (eq. 9) is for the electrovibration display: drop it with --display");
    }
    if args.compensate {
        anyhow::bail!("--compensate is for the electrovibration display: drop it with --display");
    }
    let ultrasonic = args.display.ultrasonic(device_file)?;
    let channels = match args.display.strategy()? {
        Some(strategy) => Channels::Combined(&ultrasonic, strategy),
        None => Channels::Ultrasonic(&ultrasonic),
    };
    let flat = args.relative.then(|| args.flat_mu.map_or(FlatMu::Median, FlatMu::Given));
    let design = map_display(profile, device, channels, args.fn_n, flat)?;
    let output = Output::new(args.output);
    write_output(&output, args.format, &design, device_file.map(|f| (f, &notes[..])), |w| {
        for c in &notes {
            writeln!(w, "# {c}")?;
        }
        design.write_csv(w)
    })?;
    if !args.quiet {
        eprint!("{}", design.summary);
        for c in &notes {
            eprintln!("{c}");
        }
        if let Some(path) = output.path() {
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(())
}

/// Writes `value` as CSV (by `csv`) or JSON, as --format or the output's
/// extension says (default CSV).
/// A design made with a device file records it in the JSON too
/// (`device_file`: path, SHA-256, what it is; `notes`: the CSV's comments).
fn write_output<T: serde::Serialize>(
    output: &Output,
    format: Option<Format>,
    value: &T,
    device_file: Option<(&DesignDevice, &[String])>,
    csv: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
) -> anyhow::Result<()> {
    let format = format.unwrap_or(match output.path().and_then(|p| p.extension()) {
        Some(ext) if ext.eq_ignore_ascii_case("json") => Format::Json,
        _ => Format::Csv,
    });
    let json = match (format, device_file) {
        (Format::Json, Some((file, notes))) => {
            let mut json = serde_json::to_value(value)?;
            if let Some(object) = json.as_object_mut() {
                object.insert("device_file".into(), file.provenance());
                object.insert("notes".into(), serde_json::json!(notes));
            }
            Some(json)
        }
        _ => None,
    };
    output.write(|w| match format {
        Format::Csv => csv(w),
        Format::Json => match &json {
            Some(json) => serde_json::to_writer(&mut *w, json),
            None => serde_json::to_writer(&mut *w, value),
        }
        .map_err(std::io::Error::from)
        .and_then(|()| w.write_all(b"\n")),
    })
}

/// The device of a design made with a device file, for the carrier it
/// will be played on (--carrier, --carrier-hz; default sine 1000 Hz): the
/// comments that say so (the file, its SHA-256, the force coefficient's
/// origin and the carrier, in the words `haptex play` reads), and whether
/// the force is the circuit model's.
fn device_file_design(file: &DesignDevice, args: &VoltageArgs) -> anyhow::Result<(Device, Vec<String>, bool)> {
    let design = file.design(&args.force.carrier(), args.u_max)?;
    Ok((design.device, design.notes, design.circuit))
}
