//! `haptex check`: the FE finger on the display under eq. (8)'s voltage,
//! the friction it feels against the target, and (`--compensate`) the
//! voltage corrected until it feels the target.

use std::path::PathBuf;

use clap::Args;
use haptex_core::electrovibration::{ContactArea, Device, Method, map_profile};
use haptex_core::num::Num;
use haptex_core::plot::{Figure, Panel};
use haptex_core::ranges;
use haptex_fem::render::{self, Check, FeFinger, RenderSettings, Stopping, TargetPart};
use haptex_fem::scenario::Loading;
use indicatif::{ProgressBar, ProgressStyle};

use crate::args::{
    CarrierArg, DesignDevice, DeviceFileArgs, DisplayArg, DisplayArgs, LayerStackArgs, MaterialArg, MeshArg, ModelArg,
    finger_model, in_range, non_negative, positive, read_profile,
};

/// Check a friction profile on the finger model: slide the FE finger on the
/// display under eq. (8)'s voltage and compare the friction it feels with
/// the target.
///
/// The finger (2D plane strain, per mm of width; or with --model 3d the 3D
/// fingertip, in N) is pressed onto the flat
/// display with a constant normal load and slid over the profile's span
/// (after a run-up, so that it slides steadily from the first position);
/// the voltage at each moment is U at the finger's position. The display's
/// friction mu_HD is the skin's on the FE display too. Reported over the
/// renderable region (mu_HD <= mu_RS <= mu at U_max): RMS and largest
/// error, the lag of the felt profile, how much detail finer than the
/// contact survives, and the contact-area coefficient k as the FE finger
/// sees it. With --compensate, U(x) is corrected run by run (in U^2, each
/// trial clipped to [0, U_max]) until the felt friction stops improving.
///
/// Before any FE run the profile is checked for what the check needs (the
/// web API's check applies the same rule): positions at least 1 nm apart,
/// at most 20 000 points, at least one --step long; a run-up of 0 to 100 mm.
#[derive(Debug, Args)]
#[command(after_help = "Examples:\n  haptex predict --surface bump --x0 5 --width 1.5 --height 0.3 -o bump.csv\n  \
                  haptex check --profile bump.csv --png check.png\n  \
                  haptex check --profile bump.csv --compensate --voltage-out u-compensated.csv\n  \
                  haptex check --profile bump.csv --model 3d --mesh coarse --fe-k -o check3d.csv\n\n\
                  With a device file (`haptex calibrate`, eq3 model): eq. (8) takes its mu_HD, k for the carrier \
                  (default sine 1000 Hz) and U_max, and the FE display its layer stack:\n  \
                  haptex check --profile bump.csv --device my-display.toml --carrier-hz 300 -o check.csv \
                  --voltage-out u300.csv",
    mut_args = crate::args::set_by_device_file(&["mu_hd", "eps_sc", "eps_i", "d_sc_mm", "d_i_mm", "k_mm2_per_n", "fe_k", "ultrasonic_calibration"])
)]
pub struct CheckArgs {
    /// Target friction profile CSV (`x_mm,mu` or `x_mm,ft_n,fn_n`), or `-` for stdin.
    #[arg(long, value_name = "P.csv")]
    profile: PathBuf,
    /// Friction of the finger on the display with no voltage, mu_HD (also
    /// the FE's skin-display friction; default: the finger model's skin
    /// friction, 0.5, the flat-surface value of the FE profiles).
    #[arg(long, value_parser = in_range(ranges::MU_HD))]
    mu_hd: Option<f64>,
    /// Highest voltage the display can apply, U_max in V RMS. Default 100,
    /// or the device file's (which --u-max may lower, not raise).
    #[arg(long, value_parser = in_range(ranges::U_MAX_V))]
    u_max: Option<f64>,
    /// Contact-area coefficient k of eq. (8) in mm^2/N (A = k Fn).
    #[arg(long, default_value_t = ContactArea::PAPER.k_mm2_per_n, value_parser = in_range(ranges::K_MM2_PER_N))]
    k_mm2_per_n: f64,
    /// Use eq. (8) with the FE finger's own k (its contact length per unit
    /// normal force, measured on a first run) instead of --k-mm2-per-n.
    #[arg(long)]
    fe_k: bool,
    #[command(flatten)]
    stack: LayerStackArgs,
    /// Normal load the finger presses with, N per mm of finger width
    /// (default 0.0133: the force of the paper's 0.25 mm press on a flat
    /// surface with the elastic tissue); with --model 3d in N (default
    /// 0.5, the top of the paper's "typical screen exploration").
    #[arg(long, value_parser = positive, conflicts_with = "indent")]
    load: Option<f64>,
    /// Press by a displacement of bone and nail instead (mm), the paper's
    /// FE loading.
    #[arg(long, value_parser = positive)]
    indent: Option<f64>,
    /// Sliding velocity in mm/s.
    #[arg(long, default_value_t = 20.0, value_parser = positive)]
    velocity: f64,
    /// Slide per FE step in mm (the voltage is sampled at each step: use
    /// a tenth of the finest detail); at most the profile's length.
    #[arg(long, default_value_t = 0.05, value_parser = positive)]
    step: f64,
    /// Slide before the profile's first position, mm (0 to 100).
    #[arg(long, default_value_t = 1.0)]
    run_up: f64,
    /// Tissue model.
    #[arg(long, value_enum, default_value_t = MaterialArg::Viscoelastic)]
    material: MaterialArg,
    /// Mesh resolution.
    #[arg(long, value_enum, default_value_t = MeshArg::Default)]
    mesh: MeshArg,
    /// The FE finger: the 2D plane-strain cross-section, or the 3D
    /// fingertip (eq. (3)'s attraction on its real contact area; --fe-k
    /// then measures eq. (8)'s k as a real area over the normal force).
    #[arg(long, value_enum, default_value_t = ModelArg::TwoD)]
    model: ModelArg,
    /// With --model 3d: the direction of the finger's motion on the
    /// display, degrees from the display's x axis (0: across the finger,
    /// as the 2D finger slides; 90: along it).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    direction_deg: Option<f64>,
    /// Finger model file (default: the shipped data/finger/finger-2d.toml).
    #[arg(long, value_name = "FILE")]
    finger: Option<PathBuf>,
    /// Correct the voltage with further FE runs until the felt friction
    /// stops improving.
    #[arg(long)]
    compensate: bool,
    /// With --compensate: most FE runs, eq. (8)'s included.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=100))]
    max_runs: u32,
    /// With --compensate: stop once the felt friction's RMS error is below
    /// this (in units of mu).
    #[arg(long, default_value_t = 1e-4, value_parser = non_negative)]
    tolerance: f64,
    /// CSV of the check: x_mm,target_mu,voltage_v,felt_mu,k_fe_mm2_per_n.
    #[arg(short, long, value_name = "C.csv")]
    output: Option<PathBuf>,
    /// The voltage applied (the compensated one with --compensate) as a
    /// `haptex voltage` profile (x_mm,mu,voltage_v), for `haptex play`.
    #[arg(long, value_name = "U.csv")]
    voltage_out: Option<PathBuf>,
    /// PNG: target and felt friction, and the voltage.
    #[arg(long, value_name = "F.png")]
    png: Option<PathBuf>,
    /// No progress bar or summary.
    #[arg(short, long)]
    quiet: bool,
    /// The display checked: electrovibration (eq. 8, the default) or
    /// combined (voltage and ultrasonic vibration, the target shared by
    /// --strategy; the finger slides on the vibrating plate with the
    /// reduced coefficient mu_HD rho(a(x_f)), docs/display.md).
    #[command(flatten)]
    display: DisplayArgs,
    #[command(flatten)]
    device_file: DeviceFileArgs,
    /// With --device: the carrier the design will be played on (the
    /// device file's c is measured per carrier). Default sine.
    #[arg(long, value_enum, requires = "device_file")]
    carrier: Option<CarrierArg>,
    /// With --device: the carrier frequency in Hz. Default 1000.
    #[arg(long, value_name = "F", value_parser = in_range(ranges::CARRIER_HZ), requires = "device_file")]
    carrier_hz: Option<f64>,
}

pub fn run(args: CheckArgs) -> anyhow::Result<()> {
    let target = read_profile(&args.profile)?;
    let model = finger_model(args.finger.as_deref())?;
    let device_file = args.device_file.read()?;
    let device = match &device_file {
        Some(file) => file_device(file, &args)?,
        None => Device {
            stack: args.stack.stack(),
            contact: ContactArea { k_mm2_per_n: args.k_mm2_per_n, exponent: 1.0 },
            mu_hd: args.mu_hd.unwrap_or(model.contact.mu_skin),
            u_max_v: args.u_max.unwrap_or(Device::PAPER.u_max_v),
            force_gain: 1.0,
        },
    };
    let finger = match args.model {
        ModelArg::TwoD => {
            if args.direction_deg.is_some() {
                anyhow::bail!("--direction-deg applies to --model 3d only (the 2D finger slides along x)");
            }
            FeFinger::Plane
        }
        ModelArg::ThreeD => FeFinger::Solid { direction_deg: crate::args::direction_deg(args.direction_deg)? },
    };
    let mut settings = RenderSettings::new(device.mu_hd, args.load.unwrap_or(finger.default_load()));
    settings.finger = finger;
    settings.device = device;
    settings.device.validate()?;
    let scenario = &mut settings.scenario;
    scenario.model = model;
    scenario.resolution = args.mesh.resolution();
    scenario.viscoelastic = args.material.viscoelastic();
    if let Some(indent) = args.indent {
        scenario.loading = Loading::Indent(indent);
    }
    scenario.velocity_mm_s = args.velocity;
    scenario.step_mm = args.step;
    settings.run_up_mm = args.run_up;
    // What the FE check needs of the profile and the slide, before any
    // run (the web API's check applies the same rule).
    render::check_target(&target, &settings).map_err(|e| match e.part {
        TargetPart::Positions => anyhow::anyhow!("{}: {e}", args.profile.display()),
        TargetPart::Step => anyhow::anyhow!("--step {}: {e}", Num(args.step)),
        TargetPart::RunUp => anyhow::anyhow!("--run-up {}: {e}", Num(args.run_up)),
    })?;

    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        let bar = ProgressBar::new(0);
        bar.set_style(
            ProgressStyle::with_template("{spinner} check [{bar:30}] {pos}/{len} steps, {msg} ({elapsed})")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar
    };
    let mut report = |run: usize, p: haptex_fem::scenario::Progress| {
        bar.set_length(p.total_steps as u64);
        bar.set_position(p.step as u64);
        bar.set_message(format!("FE run {}, x = {:.2} mm", run + 1, p.slide_mm));
    };
    if args.display.display != DisplayArg::Electrovibration {
        return run_display(&args, &target, &settings, device_file.as_ref(), &mut report, &bar);
    }
    args.display.refuse_display_flags()?;
    let stopping = args.compensate.then(|| Stopping {
        max_runs: args.max_runs as usize,
        tolerance: args.tolerance,
        ..Stopping::default()
    });
    let run = render::check_electrovibration(&target, settings, args.fe_k, stopping, &mut report)?;
    bar.finish_and_clear();
    let lines: Vec<String> = device_file.iter().map(DesignDevice::comment).chain(run.lines.iter().cloned()).collect();
    let profile_name = args.profile.display().to_string();
    let header = render::check_header(&profile_name, &run, device_file.as_ref().map(|f| f.file.path.as_str()));
    let (check, settings, m) = (&run.check, &run.settings, run.check.metrics);
    // What a voltage profile written from the check states for `haptex
    // play`: the device file and the carrier it was designed for.
    let design_notes = design_notes(device_file.as_ref(), &args);
    if let Some(path) = &args.output {
        haptex_core::io::write_atomic(path, |w| render::write_check_csv(check, &header, &lines, w))?;
    }
    if let Some(path) = &args.voltage_out {
        let profile = map_profile(&check.target, &settings.device, Method::Physical, None)?
            .with_voltages(check.voltage_v.clone())?;
        haptex_core::io::write_atomic(path, |w| {
            writeln!(w, "# {}", render::voltage_comment(&header, &m))?;
            for note in &design_notes {
                writeln!(w, "# {note}")?;
            }
            profile.write_csv(w)
        })?;
    }
    if let Some(path) = &args.png {
        figure(check, &header, settings).write_png(path)?;
    }
    if !args.quiet {
        eprintln!("{header}");
        for line in &lines {
            eprintln!("{line}");
        }
        for (label, path) in [("check", &args.output), ("voltage", &args.voltage_out), ("PNG", &args.png)] {
            if let Some(p) = path {
                eprintln!("wrote {label}: {}", p.display());
            }
        }
    }
    Ok(())
}

/// `--display combined`: the check of the combined display.
fn run_display(
    args: &CheckArgs,
    target: &haptex_core::profile::FrictionProfile,
    settings: &RenderSettings,
    device_file: Option<&DesignDevice>,
    report: &mut dyn FnMut(usize, haptex_fem::scenario::Progress),
    bar: &ProgressBar,
) -> anyhow::Result<()> {
    use haptex_core::combined::{Channels, map_display};
    if args.display.display == DisplayArg::Ultrasonic {
        anyhow::bail!(
            "the check runs an electrovibration or a combined display; for the plate alone give --display combined \
             (a target below mu_HD is then rendered by the plate only)"
        );
    }
    for (given, flag) in [(args.compensate, "--compensate"), (args.fe_k, "--fe-k")] {
        if given {
            anyhow::bail!("{flag} is for the electrovibration display; it is not done for --display combined yet");
        }
    }
    let ultrasonic = args.display.ultrasonic(device_file)?;
    let strategy = args.display.strategy()?.expect("a combined display has a strategy");
    let check = render::check_combined(target, settings, &ultrasonic, strategy, &mut |p| report(0, p))?;
    bar.finish_and_clear();
    let m = check.metrics;
    let amplitude = check.amplitude_um.as_deref().expect("a combined check has amplitudes");
    let header = render::combined_header(
        &args.profile.display().to_string(),
        settings,
        &ultrasonic,
        strategy,
        device_file.map(|f| f.file.path.as_str()),
    );
    let design_notes = design_notes(device_file, args);
    let lines: Vec<String> =
        device_file.iter().map(|f| f.comment()).chain(render::describe_combined_metrics(&m)).collect();
    if let Some(path) = &args.output {
        haptex_core::io::write_atomic(path, |w| render::write_check_csv(&check, &header, &lines, w))?;
    }
    if let Some(path) = &args.voltage_out {
        // The same design the check applied (map_display is deterministic),
        // written as `haptex voltage --display combined` writes it.
        let design = map_display(target, &settings.device, Channels::Combined(&ultrasonic, strategy), None, None)?;
        if design.voltage_v.as_deref() != Some(&check.voltage_v[..])
            || design.amplitude_um.as_deref() != Some(amplitude)
        {
            anyhow::bail!("internal: the design written differs from the one checked");
        }
        haptex_core::io::write_atomic(path, |w| {
            for note in &design_notes {
                writeln!(w, "# {note}")?;
            }
            design.write_csv(w)
        })?;
    }
    if let Some(path) = &args.png {
        let x = check.target.x_mm();
        Figure::new(&header)
            .panel(Panel::new("x (mm)", "Ft/Fn").line("target mu_RS", x, check.target.mu()).line(
                "felt on the FE finger",
                x,
                &check.felt.mu,
            ))
            .panel(Panel::new("x (mm)", "U (V RMS)").line("applied voltage", x, &check.voltage_v))
            .panel(Panel::new("x (mm)", "a (um peak)").line("plate amplitude", x, amplitude))
            .write_png(path)?;
    }
    if !args.quiet {
        eprintln!("{header}");
        for line in &lines {
            eprintln!("{line}");
        }
        for (label, path) in [("check", &args.output), ("drive", &args.voltage_out), ("PNG", &args.png)] {
            if let Some(p) = path {
                eprintln!("wrote {label}: {}", p.display());
            }
        }
    }
    Ok(())
}

/// The device of a check made with a device file (a circuit-model file
/// is refused: haptex-core's `DesignDevice::check_device` says why).
fn file_device(file: &DesignDevice, args: &CheckArgs) -> anyhow::Result<Device> {
    Ok(file.check_device(&carrier(args), args.u_max)?)
}

/// The carrier of --carrier and --carrier-hz (default sine 1000 Hz).
fn carrier(args: &CheckArgs) -> haptex_core::signal::Carrier {
    crate::args::carrier_of(args.carrier, args.carrier_hz)
}

/// The comments of a voltage written from a check with a device file: the
/// file, and the carrier it is designed for (`haptex play` refuses
/// another).
fn design_notes(device_file: Option<&DesignDevice>, args: &CheckArgs) -> Vec<String> {
    device_file.map_or_else(Vec::new, |file| file.design_notes(&carrier(args)))
}

fn figure(check: &Check, title: &str, settings: &RenderSettings) -> Figure {
    let x = check.target.x_mm();
    let hd = vec![settings.device.mu_hd; x.len()];
    Figure::new(title)
        .panel(
            Panel::new("x (mm)", "Ft/Fn")
                .line("target mu_RS", x, check.target.mu())
                .line("felt on the FE finger", x, &check.felt.mu)
                .line("mu_HD", x, &hd),
        )
        .panel(Panel::new("x (mm)", "U (V RMS)").line("applied voltage", x, &check.voltage_v))
}
