//! `haptex simulate`: the finite-element finger pad (2D, or the 3D
//! fingertip with `--model 3d`) pressed onto a rigid surface and slid over
//! it; writes the friction profile Ft/Fn(x).

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};
use haptex_core::num::Num;
use haptex_fem::output;
use haptex_fem::scenario::{self, Kinematics, Loading, Scenario, default_step_mm};
use haptex_fem::solid3d::output as solid3d_output;
use haptex_fem::surface::SurfaceShape;
use indicatif::{ProgressBar, ProgressStyle};

use haptex_core::ranges;
use haptex_core::signal::{Extend, VoltageCurve};
use haptex_fem::display::Display;

use crate::args::{
    LayerStackArgs, MaterialArg, MeshArg, ModelArg, Output, finger_model, in_range, non_negative, positive,
};

/// Simulate a finger pad sliding over a surface (2D plane-strain FE, or the
/// 3D fingertip) and write its friction profile.
///
/// The finger (data/finger/finger-2d.toml: six tissue layers, rigid bone and
/// nail) is pressed onto the rigid surface, which then slides under it. The
/// output `x_mm,mu,ft_n,fn_n` gives the apparent friction Ft/Fn against the
/// finger's position on the surface (x from 0 to --slide, in the surface
/// template's coordinates); forces are per mm of finger width. It is a
/// friction profile for `haptex voltage`.
///
/// With --model 3d the finger is the 3D fingertip of the same layers and
/// cross-section (docs/fem.md, "The 3D finger pad"), pressed by --indent
/// (default 0.5 mm) or --load (N) and slid in the direction --direction-deg
/// over the surface extruded along y; x is the distance travelled and
/// forces are in N.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    after_help = "Examples:\n  haptex simulate --surface bump --x0 5 --width 1.5 --height 0.3 -o bump.csv --png bump.png\n  \
                  haptex simulate --surface file:heights.csv --history history.csv --vtk vtk/"
)]
pub struct SimulateArgs {
    /// Surface: flat, bump, edge, sine, file:H.csv (columns x_mm,h_mm),
    /// display: a flat electrovibration display under the voltage of
    /// --voltage or --constant-voltage at the finger's position, or with
    /// --model 3d map:H.csv|H.npy, a height map h(x, y) as `haptex map
    /// height` reads it (the finger starts over its (0, 0); beyond the map
    /// its edge's heights continue).
    #[arg(long, value_name = "SURFACE")]
    surface: String,
    /// With --surface display: the voltage profile U(x) (CSV with x_mm and
    /// voltage_v columns, as `haptex voltage` writes), x the finger's
    /// position on the display; the first/last voltage is held beyond it.
    #[arg(long, value_name = "U.csv", conflicts_with = "constant_voltage")]
    voltage: Option<PathBuf>,
    /// With --surface display: one voltage (V RMS) over the whole slide.
    #[arg(long, value_name = "V", value_parser = in_range(ranges::VOLTAGE_V))]
    constant_voltage: Option<f64>,
    /// With --surface display: skin-display friction coefficient mu_HD
    /// (default: the finger model's skin friction, 0.5).
    #[arg(long, conflicts_with = "mu_skin")]
    mu_display: Option<f64>,
    #[command(flatten)]
    stack: LayerStackArgs,
    /// Feature position x0 in mm (bump top, edge top, sine phase).
    #[arg(long, default_value_t = 5.0, allow_negative_numbers = true)]
    x0: f64,
    /// Feature width r_w in mm (bump width, edge rise, sine period).
    #[arg(long, default_value_t = 1.5, value_parser = positive)]
    width: f64,
    /// Feature height r_h in mm (bump and edge height, sine amplitude).
    #[arg(long, default_value_t = 0.3)]
    height: f64,
    /// Sliding velocity in mm/s.
    #[arg(long, default_value_t = 20.0, value_parser = positive)]
    velocity: f64,
    /// Press bone and nail down by this much after first touch (mm).
    #[arg(long, value_parser = positive, conflicts_with = "load")]
    indent: Option<f64>,
    /// Press with a constant normal load instead (N per mm of finger width;
    /// with --model 3d, N).
    #[arg(long, value_parser = positive)]
    load: Option<f64>,
    /// Slide distance in mm; 0 for a press only (the output is then the
    /// press curve `t_s,indent_mm,fn_n,ft_n,contact_mm`).
    #[arg(long, default_value_t = 10.0, value_parser = non_negative)]
    slide: f64,
    /// Slide per step in mm (default: 0.1, or width/10 if smaller).
    #[arg(long, value_parser = positive)]
    step: Option<f64>,
    /// Duration of the press in s.
    #[arg(long, default_value_t = 0.1, value_parser = positive)]
    press_time: f64,
    /// Skin-surface friction coefficient (default: the finger model's, 0.5).
    #[arg(long)]
    mu_skin: Option<f64>,
    /// Tissue model.
    #[arg(long, value_enum, default_value_t = MaterialArg::Viscoelastic)]
    material: MaterialArg,
    /// Kinematics: small strain (the paper's model) or finite strain
    /// (total Lagrangian, neo-Hookean tissue with the same moduli and Prony
    /// series; about 3x slower in 2D, 6-12x in 3D).
    #[arg(long, value_enum, default_value_t = KinematicsArg::Small)]
    kinematics: KinematicsArg,
    /// Mesh resolution: pad node spacing 0.2, 0.1, 0.05, 0.025 mm in 2D;
    /// 12, 24, 36, 48 surface divisions in 3D (extra-fine: about 8 times
    /// the fine mesh's time in 2D, 4 times in 3D, for convergence studies).
    #[arg(long, value_enum, default_value_t = MeshArg::Default)]
    mesh: MeshArg,
    /// The finger: the 2D plane-strain cross-section, or the 3D fingertip.
    #[arg(long, value_enum, default_value_t = ModelArg::TwoD)]
    model: ModelArg,
    /// With --model 3d: the direction of the finger's motion over the
    /// surface, degrees from the surface's x axis (0: across the surface's
    /// features, as in 2D; 90: along them).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    direction_deg: Option<f64>,
    /// With --model 3d: each skin face's 4 x 4 contact points on N x N
    /// equal parts of the face (1 to 8; N^2 times the points), for crests
    /// sharper than the faces, which pass between the points of whole
    /// faces (the warning "the surface reached ... between its contact
    /// points" says where). Costs time: docs/fem.md, "Contact points
    /// closer than the faces".
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=haptex_fem::solid3d::contact::MAX_CONTACT_PARTS as i64))]
    contact_parts: Option<u8>,
    /// Finger model file (default: the shipped data/finger/finger-2d.toml).
    #[arg(long, value_name = "FILE")]
    finger: Option<PathBuf>,
    /// Contact penalty in MPa per mm of penetration.
    #[arg(long, default_value_t = 200.0, value_parser = positive)]
    penalty: f64,
    /// Friction profile output (default: stdout).
    #[arg(short, long, value_name = "profile.csv")]
    output: Option<PathBuf>,
    /// Force history CSV (t_s,slide_mm,fn_n,ft_n,contact_mm,...).
    #[arg(long, value_name = "H.csv")]
    history: Option<PathBuf>,
    /// Directory for a VTK series (.vtu per frame + simulation.pvd) for ParaView.
    #[arg(long, value_name = "DIR")]
    vtk: Option<PathBuf>,
    /// With --vtk: a frame every this many slide steps (default: ~25 frames).
    #[arg(long, value_name = "N")]
    vtk_every: Option<usize>,
    /// PNG of the deformed finger after the press and over the feature.
    #[arg(long, value_name = "F.png")]
    png: Option<PathBuf>,
    /// No progress bar or summary.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum KinematicsArg {
    Small,
    Finite,
}

fn parse_surface(args: &SimulateArgs) -> anyhow::Result<SurfaceShape> {
    let (x0, width, height) = (args.x0, args.width, args.height);
    if !x0.is_finite() || !height.is_finite() {
        anyhow::bail!("--x0 and --height must be finite numbers");
    }
    Ok(match args.surface.as_str() {
        "flat" | "display" => SurfaceShape::Flat,
        "bump" => SurfaceShape::Bump { x0, width, height },
        "edge" => SurfaceShape::Edge { x0, width, height },
        "sine" => SurfaceShape::Sine { x0, width, height },
        other if other.starts_with("map:") => {
            if args.model != ModelArg::ThreeD {
                anyhow::bail!(
                    "--surface {other}: a height map needs --model 3d (the 2D finger's friction map of a height map \
                     is `haptex map height`)"
                );
            }
            SurfaceShape::Flat
        }
        other => match other.strip_prefix("file:") {
            Some(path) => SurfaceShape::read_csv(std::path::Path::new(path))?,
            None => anyhow::bail!(
                "--surface must be flat, bump, edge, sine, display, file:H.csv or (3D) map:H.csv, got '{other}'"
            ),
        },
    })
}

/// The display of `--surface display`, or `None`; voltage flags without it
/// are an error (they would be silently ignored).
fn parse_display(args: &SimulateArgs) -> anyhow::Result<Option<Display>> {
    let display = args.surface == "display";
    if !display {
        for (given, flag) in [
            (args.voltage.is_some(), "--voltage"),
            (args.constant_voltage.is_some(), "--constant-voltage"),
            (args.mu_display.is_some(), "--mu-display"),
        ] {
            if given {
                anyhow::bail!("{flag} applies to --surface display only (got --surface {})", args.surface);
            }
        }
        return Ok(None);
    }
    let voltage = match (&args.voltage, args.constant_voltage) {
        (Some(path), _) => VoltageCurve::read_csv_file(path)?,
        (None, Some(u)) => VoltageCurve::new(vec![0.0, 1.0], vec![u, u])?,
        (None, None) => anyhow::bail!("--surface display needs --voltage U.csv or --constant-voltage V"),
    };
    Ok(Some(Display { voltage, extend: Extend::Hold, stack: args.stack.stack(), vibration: None, air_gap_um: 0.0 }))
}

pub fn run(args: SimulateArgs) -> anyhow::Result<()> {
    let surface = parse_surface(&args)?;
    let display = parse_display(&args)?;
    let model = finger_model(args.finger.as_deref())?;
    let mut scenario = Scenario::paper(surface.clone());
    scenario.model = model;
    scenario.resolution = args.mesh.resolution();
    scenario.viscoelastic = args.material.viscoelastic();
    scenario.kinematics = match args.kinematics {
        KinematicsArg::Small => Kinematics::Small,
        KinematicsArg::Finite => Kinematics::Finite,
    };
    let three_d = args.model == ModelArg::ThreeD;
    scenario.loading = match (args.indent, args.load) {
        (_, Some(load)) => Loading::Load(load),
        (Some(indent), None) => Loading::Indent(indent),
        (None, None) => Loading::Indent(if three_d { DEFAULT_INDENT_3D_MM } else { 0.25 }),
    };
    scenario.press_time_s = args.press_time;
    scenario.slide_mm = args.slide;
    scenario.velocity_mm_s = args.velocity;
    scenario.step_mm = args.step.unwrap_or_else(|| default_step_mm(&surface));
    scenario.mu_skin = args.mu_skin.or(args.mu_display);
    scenario.display = display;
    scenario.penalty_mpa_per_mm = args.penalty;
    if three_d {
        scenario.contact_parts = args.contact_parts.map_or(1, usize::from);
        return run_3d(&args, scenario);
    }
    if args.direction_deg.is_some() {
        anyhow::bail!("--direction-deg applies to --model 3d only (the 2D finger slides along x)");
    }
    if args.contact_parts.is_some() {
        anyhow::bail!(
            "--contact-parts applies to --model 3d only (the 2D finger's contact points are on its segments)"
        );
    }
    // Every setting is checked before anything is sized by it.
    let slide_steps = scenario.slide_steps()?;
    if args.vtk.is_some() {
        scenario.frame_every = args.vtk_every.unwrap_or((slide_steps / 25).max(1)).max(1);
        scenario.validate()?;
    }

    // A grating sharper than the mesh resolves: said before the run, and in
    // the profile's header.
    let unresolved = match scenario.surface {
        SurfaceShape::Sine { width, height, .. } => {
            haptex_core::crests::unresolved_sine(scenario.resolution.name(), width, height)
        }
        _ => None,
    };
    if let (Some(u), false) = (unresolved, args.quiet) {
        eprintln!("warning: {}", u.describe());
    }

    let bar = progress_bar(args.quiet, scenario.press_steps + slide_steps);
    let result = scenario::run(&scenario, &mut |p| {
        bar.set_position(p.step as u64);
        bar.set_message(format!("t = {:.3} s, x = {:.2} mm", p.t_s, p.slide_mm));
    });
    bar.finish_and_clear();
    let result = result.context("simulation failed")?;

    let mut description = describe(&args, &scenario);
    if let Some(u) = unresolved {
        description.push_str(&format!("; not mesh-converged: {}", u.describe()));
    }
    Output::new(args.output.clone()).write(|w| output::write_profile(&result, &description, w))?;
    if let Some(path) = &args.history {
        haptex_core::io::write_atomic(path, |w| output::write_history(&result, w))?;
    }
    if let Some(dir) = &args.vtk {
        output::write_vtk_series(&result, dir)?;
    }
    if let Some(path) = &args.png {
        let title = format!("haptex simulate: {}", description.split(';').next().unwrap_or(""));
        output::write_png(&result, &title, path)?;
    }
    if !args.quiet {
        let s = result.statistics;
        let mu = result.profile.as_ref().map(|p| p.mu()).unwrap_or(&[]);
        let (lo, hi) = mu.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &m| (a.min(m), b.max(m)));
        eprintln!("{description}");
        eprintln!(
            "mesh: {} nodes, {} elements, {} free DOFs ({} in the contact region)",
            s.nodes, s.elements, s.free_dofs, s.contact_dofs
        );
        eprintln!(
            "solved {} steps, {} Newton iterations, {} step halvings in {:.2} s",
            s.steps, s.newton_iterations, s.step_cuts, s.wall_time_s
        );
        match result.history.last() {
            Some(last) if result.profile.is_none() => eprintln!(
                "press only: Fn = {:.6} N/mm at {} mm, contact {:.3} mm",
                last.fn_n,
                Num(-last.drive_y_mm),
                last.contact_mm
            ),
            _ => eprintln!("Ft/Fn over the slide: {lo:.4} .. {hi:.4}"),
        }
        for (label, path) in
            [("profile", &args.output), ("history", &args.history), ("VTK series", &args.vtk), ("PNG", &args.png)]
        {
            if let Some(p) = path {
                eprintln!("wrote {label}: {}", p.display());
            }
        }
    }
    Ok(())
}

/// The 3D finger's default indentation (mm): about 0.4 N on the shipped
/// finger, within screen exploration's 0.1-1 N (docs/fem.md).
pub const DEFAULT_INDENT_3D_MM: f64 = 0.5;

fn progress_bar(quiet: bool, steps: usize) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(steps as u64);
    bar.set_style(
        ProgressStyle::with_template("{spinner} simulate [{bar:30}] {pos}/{len} steps, {msg} ({elapsed}, eta {eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar
}

/// `--model 3d`: the 3D fingertip.
fn run_3d(args: &SimulateArgs, mut scenario: Scenario) -> anyhow::Result<()> {
    let direction = crate::args::direction_deg(args.direction_deg)?;
    // The 3D checks first: a load is in N here.
    haptex_fem::solid3d::slide::validate(&scenario)?;
    let slide_steps = scenario.slide_steps()?;
    if args.vtk.is_some() {
        scenario.frame_every = args.vtk_every.unwrap_or((slide_steps / 25).max(1)).max(1);
        haptex_fem::solid3d::slide::validate(&scenario)?;
    }
    let map = match args.surface.strip_prefix("map:") {
        Some(path) => Some(crate::commands::map::read_height_map(std::path::Path::new(path))?),
        None => None,
    };
    let steps = scenario.press_steps + slide_steps;
    let bar = progress_bar(args.quiet, steps);
    let mut report = |p: scenario::Progress| {
        bar.set_position(p.step as u64);
        bar.set_message(format!("t = {:.3} s, travelled {:.2} mm", p.t_s, p.slide_mm));
    };
    let result = match &map {
        Some(map) => haptex_fem::solid3d::slide::run_on_map(&scenario, map, direction, &mut report),
        None => haptex_fem::solid3d::slide::run(&scenario, direction, &mut report),
    };
    bar.finish_and_clear();
    let result = result.context("simulation failed")?;
    if let Some(u) = result.unresolved() {
        // Even with --quiet: the profile is the mesh's where this holds.
        eprintln!("warning: {u}; the forces there are the mesh's, not the surface's");
    }
    let mut description = format!("{}; direction {} degrees", describe(args, &scenario), Num(direction));
    if scenario.contact_parts > 1 {
        let n = scenario.contact_parts;
        description.push_str(&format!("; contact points on {n} x {n} parts of each face"));
    }
    Output::new(args.output.clone()).write(|w| solid3d_output::write_profile(&result, &description, w))?;
    if let Some(path) = &args.history {
        haptex_core::io::write_atomic(path, |w| solid3d_output::write_history(&result, w))?;
    }
    if let Some(dir) = &args.vtk {
        solid3d_output::write_vtk_series(&result, dir)?;
    }
    if let Some(path) = &args.png {
        let title = format!("3D finger: {}", description.split(';').next().unwrap_or(""));
        solid3d_output::write_png(&result, &title, path)?;
    }
    if !args.quiet {
        let s = result.statistics;
        eprintln!("{description}");
        eprintln!(
            "3D mesh: {} nodes, {} elements, {} free DOFs ({} in the contact region)",
            s.nodes, s.elements, s.free_dofs, s.contact_dofs
        );
        eprintln!("solved {} steps, {} Newton iterations in {:.2} s", s.steps, s.newton_iterations, s.wall_time_s);
        match (&result.profile, result.history.last()) {
            (None, Some(last)) => eprintln!(
                "press only: Fn = {:.4} N at {} mm, contact area {:.2} mm^2",
                last.fn_n,
                Num(-last.drive_z_mm),
                last.contact_area_mm2
            ),
            (Some(p), _) => {
                let (lo, hi) =
                    p.mu().iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &m| (a.min(m), b.max(m)));
                eprintln!("Ft/Fn over the slide: {lo:.4} .. {hi:.4}");
            }
            (None, None) => {}
        }
        for (label, path) in
            [("profile", &args.output), ("history", &args.history), ("VTK series", &args.vtk), ("PNG", &args.png)]
        {
            if let Some(p) = path {
                eprintln!("wrote {label}: {}", p.display());
            }
        }
    }
    Ok(())
}

fn describe(args: &SimulateArgs, scenario: &Scenario) -> String {
    let voltage = args.voltage.as_ref().map(|p| p.display().to_string());
    let source = match (&scenario.display, &voltage, args.constant_voltage) {
        (Some(_), Some(path), _) => Some(output::VoltageSource::Profile(path)),
        (Some(_), None, Some(u)) => Some(output::VoltageSource::Constant(u)),
        _ => None,
    };
    let unit = if args.model == ModelArg::ThreeD { "N" } else { "N/mm" };
    let surface = match args.surface.strip_prefix("map:") {
        Some(path) => format!("height map {path}"),
        None => output::surface_text(&scenario.surface, source, &args.surface),
    };
    output::describe_with_load_unit(scenario, &surface, unit)
}
