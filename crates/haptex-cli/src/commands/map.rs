//! `haptex map`: friction maps over (x, y) (docs/maps.md): from a
//! grayscale image, a 1-D profile, regions, a grating or a height map, to
//! voltages per cell, and sampled along a finger path.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, Subcommand, ValueEnum};
use haptex_core::electrovibration::{ContactArea, Device, Method};
use haptex_core::map::{FrictionMap, GrayMapping, MapFormat, MapGrid, VoltageMap, min_max, png_header};
use haptex_core::num::Num;
use haptex_core::planar::PlanarTrajectory;
use haptex_core::ranges;

use crate::args::{LayerStackArgs, in_range, positive, read_profile};

/// Friction maps over (x, y): build one from an image, a profile, regions,
/// a grating or a height map (through the FE model), map it to voltages
/// cell by cell, sample it along a finger path.
///
/// Maps are CSV (`x_mm,y_mm,mu`, `x_mm,y_mm,voltage_v` or `x_mm,y_mm,h_mm`, rows running
/// through x for each y in turn) or NPY (a (ny, nx) float64 array, row j
/// at y0 + j dy) with a JSON sidecar `MAP.npy.json` holding the grid and
/// the NPY's SHA-256; the format follows the file's extension.
#[derive(Debug, Args)]
pub struct MapArgs {
    #[command(subcommand)]
    command: MapCommand,
}

#[derive(Debug, Subcommand)]
enum MapCommand {
    FromImage(FromImageArgs),
    FromProfile(FromProfileArgs),
    Voltage(MapVoltageArgs),
    SamplePath(SamplePathArgs),
    Grating(GratingArgs),
    Compose(ComposeArgs),
    Height(height::HeightArgs),
    ExportPng(ExportPngArgs),
}

mod height;
pub(crate) use height::read_height_map;

/// A map (friction, voltage or heights, .csv or .npy) as a 16- or 8-bit
/// grayscale PNG: its lowest value black, its highest white (or
/// --black/--white), linear; the mapping and the grid are written into the
/// PNG (a tEXt chunk) and printed with the command that reads it back
/// (`haptex map from-image` for friction, `haptex map height --height` for
/// heights).
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
struct ExportPngArgs {
    /// The map.
    #[arg(long, value_name = "MAP")]
    map: PathBuf,
    /// The map's quantity: mu (a friction map), voltage_v (a voltage map)
    /// or h_mm (a height map).
    #[arg(long, default_value = "mu", value_parser = ["mu", "voltage_v", "h_mm"])]
    quantity: String,
    /// Value of black (default: the map's lowest).
    #[arg(long)]
    black: Option<f64>,
    /// Value of white (default: the map's highest).
    #[arg(long)]
    white: Option<f64>,
    /// Bits per pixel, 8 or 16.
    #[arg(long, default_value_t = 16, value_parser = bits_per_pixel)]
    bits: u8,
    /// Output PNG.
    #[arg(short, long, value_name = "FILE.png")]
    output: PathBuf,
}

/// A friction map from a label image: each gray level of an 8-bit
/// grayscale PNG is a region, filled with a friction coefficient, a
/// library material (a stroke of it, tiled along x) or a friction profile
/// (tiled along x). One cell per pixel, the top row at the largest y.
#[derive(Debug, Args)]
#[command(after_help = "Example:\n  haptex map compose labels.png --region 0=0.5 --region 128=material:sponge \
                  --region 255=profile:data/examples/bump_friction.csv --pixel-mm 0.1 -o composed.csv")]
struct ComposeArgs {
    /// The label image (PNG, 8-bit grayscale); without it, --base and
    /// --size-mm give the map.
    labels: Option<PathBuf>,
    /// LEVEL=FILL for each gray level present: a number (mu),
    /// material:NAME (a library material) or profile:FILE.csv.
    #[arg(long = "region", value_name = "LEVEL=FILL", requires = "labels")]
    regions: Vec<String>,
    /// Without a label image: the FILL of the whole map (then polygons).
    #[arg(long, value_name = "FILL", conflicts_with = "labels", requires = "size_mm")]
    base: Option<String>,
    /// Without a label image: the map's size W,H in mm (cells at the pixel
    /// size from the origin).
    #[arg(long, value_name = "W,H", conflicts_with = "labels", requires = "base")]
    size_mm: Option<String>,
    /// "X,Y;X,Y;X,Y=FILL": a polygon (vertices in mm) filled over what is
    /// there, in the order given (even-odd rule at the cell positions).
    #[arg(long = "polygon", value_name = "X,Y;...=FILL")]
    polygons: Vec<String>,
    #[command(flatten)]
    pixels: PixelArgs,
    /// Texture library for material:NAME. Default: the shipped library, or $HAPTEX_LIBRARY.
    #[arg(long, value_name = "DB")]
    library: Option<PathBuf>,
    /// Seed of the stroke chosen for each material (the same seed picks the same stroke).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output map (.csv or .npy with its sidecar).
    #[arg(short, long, value_name = "MAP")]
    output: PathBuf,
}

/// A sine grating at an angle to the sliding direction (+x), its friction
/// from the FE database: each line y = const cuts a sine of period
/// lambda / cos(angle), whose steady friction the CAE predicts (plane
/// strain along the sliding direction: the map depends on the direction).
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    after_help = "Example:\n  haptex map grating --period-mm 1.5 --amplitude-mm 0.2 --angle-deg 45 --nx 201 --ny 101 \
                  --dx-mm 0.05 --dy-mm 0.05 -o grating45.csv --png grating45.png"
)]
struct GratingArgs {
    /// Grating period lambda in mm (across the ridges).
    #[arg(long, value_parser = positive)]
    period_mm: f64,
    /// Sine amplitude in mm.
    #[arg(long, value_parser = positive)]
    amplitude_mm: f64,
    /// Angle between the grating's wave vector and the sliding direction x
    /// in degrees (0: ridges across the sliding direction, 90: along it).
    #[arg(long)]
    angle_deg: f64,
    /// Sliding velocity in mm/s.
    #[arg(long, default_value_t = 20.0, value_parser = positive)]
    velocity: f64,
    /// Grid columns and rows.
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=100_000))]
    nx: u32,
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=100_000))]
    ny: u32,
    /// Grid spacings in mm.
    #[arg(long, value_parser = positive)]
    dx_mm: f64,
    #[arg(long, value_parser = positive)]
    dy_mm: f64,
    #[arg(long, default_value_t = 0.0)]
    x0_mm: f64,
    #[arg(long, default_value_t = 0.0)]
    y0_mm: f64,
    /// Where a line's friction comes from: fe, one FE run of the sine the
    /// line cuts (about 0.5 s; exact for any period); cae, the database's
    /// estimate (milliseconds; between the database's periods it blends
    /// neighbouring periods, docs/maps.md).
    #[arg(long, value_enum, default_value_t = LineSource::Fe)]
    source: LineSource,
    /// Database directory for --source cae. Default: the shipped data/db, or $HAPTEX_DB.
    #[arg(long, value_name = "DIR")]
    db: Option<PathBuf>,
    /// Output map (.csv or .npy with its sidecar).
    #[arg(short, long, value_name = "MAP")]
    output: PathBuf,
    /// Also plot the friction along the first row (y = y0) to this PNG,
    /// with the grating across the sliding direction (0 degrees) beside it.
    #[arg(long, value_name = "FILE.png")]
    png: Option<PathBuf>,
}

/// A friction map from an 8- or 16-bit grayscale PNG: gray level g in
/// [0, 1] (black 0) to mu = mu_black + (mu_white - mu_black) g^gamma, one
/// cell per pixel, the top row at the largest y.
#[derive(Debug, Args)]
#[command(
    after_help = "Example:\n  haptex map from-image texture.png --mu-black 0.4 --mu-white 1.2 --pixel-mm 0.1 -o map.csv"
)]
struct FromImageArgs {
    /// The image (PNG, 8 or 16 bit grayscale).
    image: PathBuf,
    /// Friction of black (gray level 0).
    #[arg(long, value_parser = in_range(ranges::MU))]
    mu_black: f64,
    /// Friction of white (full gray level).
    #[arg(long, value_parser = in_range(ranges::MU))]
    mu_white: f64,
    /// Exponent on the gray level (1: linear).
    #[arg(long, default_value_t = 1.0)]
    gamma: f64,
    #[command(flatten)]
    pixels: PixelArgs,
    /// Output map (.csv or .npy with its sidecar).
    #[arg(short, long, value_name = "MAP")]
    output: PathBuf,
    /// Most memory the command may take, MiB: the file, the decoded image
    /// (1 or 2 bytes a pixel) and the map (8 bytes a cell; 8 more for an
    /// .npy output, written from memory), checked on the image's header
    /// before anything is decoded (512 MiB: about 50 million pixels).
    #[arg(long, value_name = "MIB", default_value_t = 512, value_parser = clap::value_parser!(u64).range(1..=1 << 24))]
    memory_budget_mib: u64,
}

/// A map whose every row is a 1-D friction profile: the profile sampled
/// at x0 + i dx (linear interpolation, ends held) and repeated over ny
/// rows (a line texture extended along y).
#[derive(Debug, Args)]
struct FromProfileArgs {
    /// Friction profile CSV (`x_mm,mu`).
    #[arg(long, value_name = "P.csv")]
    profile: PathBuf,
    /// Grid spacing along x in mm.
    #[arg(long, value_parser = positive)]
    dx_mm: f64,
    /// Grid spacing along y in mm.
    #[arg(long, value_parser = positive)]
    dy_mm: f64,
    /// Number of rows.
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=100_000))]
    ny: u32,
    /// y of the first row in mm.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    y0_mm: f64,
    /// Output map (.csv or .npy with its sidecar).
    #[arg(short, long, value_name = "MAP")]
    output: PathBuf,
}

/// Eq. (8) (or eq. 9) applied to every cell of a friction map; the
/// device limits reported as fractions of the area.
///
/// With --device FILE (a device file of `haptex calibrate`), mu_HD, the
/// stack, k (or the circuit's gain) and U_max are the file's, for the
/// carrier of --carrier and --carrier-hz (default sine 1000 Hz); the map
/// (CSV comment, NPY sidecar) names the file and its SHA-256.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    after_help = "Example:\n  haptex map voltage --map friction.npy --device my-display.toml --carrier-hz 300 -o u.npy",
    mut_args = crate::args::set_by_device_file(&["mu_hd", "eps_sc", "eps_i", "d_sc_mm", "d_i_mm", "k_mm2_per_n", "ultrasonic_calibration"])
)]
struct MapVoltageArgs {
    /// The friction map (.csv or .npy).
    #[arg(long, value_name = "MAP")]
    map: PathBuf,
    #[arg(long, value_enum, default_value_t = MethodArg::Physical)]
    method: MethodArg,
    /// Friction coefficient of the finger on the display with no voltage, mu_HD.
    #[arg(long, default_value_t = Device::PAPER.mu_hd, value_parser = in_range(ranges::MU_HD))]
    mu_hd: f64,
    #[command(flatten)]
    stack: LayerStackArgs,
    /// Contact-area coefficient k in mm^2/N (A = k Fn).
    #[arg(long, default_value_t = ContactArea::PAPER.k_mm2_per_n, value_parser = in_range(ranges::K_MM2_PER_N))]
    k_mm2_per_n: f64,
    /// Highest voltage the display can apply, U_max in V RMS. Default 100,
    /// or the device file's (which --u-max may lower, not raise).
    #[arg(long, value_parser = in_range(ranges::U_MAX_V))]
    u_max: Option<f64>,
    #[command(flatten)]
    display: crate::args::DisplayArgs,
    #[command(flatten)]
    device_file: crate::args::DeviceFileArgs,
    /// With --device: the carrier the map will be played on (the device
    /// file's force coefficient is per carrier). Default sine.
    #[arg(long, value_enum, requires = "device_file")]
    carrier: Option<crate::args::CarrierArg>,
    /// With --device: the carrier frequency in Hz. Default 1000.
    #[arg(long, value_name = "F", value_parser = in_range(ranges::CARRIER_HZ), requires = "device_file")]
    carrier_hz: Option<f64>,
    /// Output voltage map (.csv or .npy with its sidecar; an ultrasonic or
    /// combined display's map is CSV, one column per channel).
    #[arg(short, long, value_name = "OUT")]
    output: PathBuf,
}

/// One cell per pixel: its size and the bottom-left pixel's position.
#[derive(Debug, Args)]
struct PixelArgs {
    /// Pixel size along x in mm.
    #[arg(long, value_parser = positive)]
    pixel_mm: f64,
    /// Pixel size along y in mm (default: --pixel-mm).
    #[arg(long, value_parser = positive)]
    pixel_mm_y: Option<f64>,
    /// x of the first column in mm.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    x0_mm: f64,
    /// y of the bottom row in mm.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    y0_mm: f64,
}

impl PixelArgs {
    fn spacing(&self) -> (f64, f64) {
        (self.pixel_mm, self.pixel_mm_y.unwrap_or(self.pixel_mm))
    }

    fn origin(&self) -> (f64, f64) {
        (self.x0_mm, self.y0_mm)
    }
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum MethodArg {
    Physical,
    Normalized,
}

/// The voltage along a finger path over a voltage map (bilinear, the
/// map's edge held beyond it), at the path's own samples:
/// `t_s,x_mm,y_mm,voltage_v`.
#[derive(Debug, Args)]
struct SamplePathArgs {
    /// The voltage map (.csv `x_mm,y_mm,voltage_v` or .npy).
    #[arg(long, value_name = "MAP")]
    voltage_map: PathBuf,
    /// The finger path, CSV `t_s,x_mm,y_mm`.
    #[arg(long, value_name = "T.csv")]
    trajectory: PathBuf,
    /// Output CSV (default: stdout). Written atomically.
    #[arg(short, long, value_name = "OUT")]
    output: Option<PathBuf>,
}

pub fn run(args: MapArgs) -> anyhow::Result<()> {
    match args.command {
        MapCommand::FromImage(a) => from_image(a),
        MapCommand::FromProfile(a) => from_profile(a),
        MapCommand::Voltage(a) => voltage(a),
        MapCommand::SamplePath(a) => sample_path(a),
        MapCommand::Grating(a) => grating(a),
        MapCommand::Compose(a) => compose(a),
        MapCommand::Height(a) => height::run(a),
        MapCommand::ExportPng(a) => export_png(a),
    }
}

fn from_image(a: FromImageArgs) -> anyhow::Result<()> {
    let mapping = GrayMapping { mu_black: a.mu_black, mu_white: a.mu_white, gamma: a.gamma };
    let format = MapFormat::of(&a.output)?;
    let bytes = read_bounded(&a.image, 256 << 20)?;
    let name = a.image.display().to_string();
    let header = png_header(&bytes, &name)?;
    let pixels = (header.width as u64).saturating_mul(header.height as u64);
    let output = if format == MapFormat::Npy { pixels.saturating_mul(8) } else { 0 };
    let memory = (bytes.len() as u64).saturating_add(header.map_memory_bytes()).saturating_add(output);
    if memory > a.memory_budget_mib << 20 {
        bail!(
            "{name}: {} x {} pixels at {} bits take about {} MiB to read into a map{}, more than --memory-budget-mib \
             {} (raise it, or give a smaller image)",
            header.width,
            header.height,
            header.bit_depth,
            memory.div_ceil(1 << 20),
            if output > 0 { " and write as NPY" } else { "" },
            a.memory_budget_mib
        );
    }
    let map = FrictionMap::read_gray_png(&bytes, &mapping, a.pixels.spacing(), a.pixels.origin(), &name)?;
    write_friction_map(&map, &a.output, format)?;
    report_map(&map);
    eprintln!("wrote {}", a.output.display());
    Ok(())
}

fn from_profile(a: FromProfileArgs) -> anyhow::Result<()> {
    let format = MapFormat::of(&a.output)?;
    let profile = read_profile(&a.profile)?;
    let map = match FrictionMap::from_profile(&profile, a.dx_mm, a.dy_mm, a.ny as usize, a.y0_mm) {
        Ok(map) => map,
        Err(haptex_core::map::FromProfileError::TooManyColumns { columns, span_mm }) => bail!(
            "--dx-mm {} gives {} columns over the profile's {} mm: too many",
            Num(a.dx_mm),
            Num(columns),
            Num(span_mm)
        ),
        Err(e) => return Err(e.into()),
    };
    write_friction_map(&map, &a.output, format)?;
    report_map(&map);
    eprintln!("wrote {}", a.output.display());
    Ok(())
}

fn voltage(a: MapVoltageArgs) -> anyhow::Result<()> {
    let format = MapFormat::of(&a.output)?;
    let map = read_friction_map(&a.map)?;
    let device_file = a.device_file.read()?;
    let carrier = crate::args::carrier_of(a.carrier, a.carrier_hz);
    let device = match &device_file {
        Some(file) => file.device(&carrier, a.u_max)?,
        None => Device {
            stack: a.stack.stack(),
            contact: ContactArea { k_mm2_per_n: a.k_mm2_per_n, exponent: 1.0 },
            mu_hd: a.mu_hd,
            u_max_v: a.u_max.unwrap_or(Device::PAPER.u_max_v),
            force_gain: 1.0,
        },
    };
    // The device file and the carrier the map is designed for, in its
    // comments (CSV) or sidecar (NPY).
    let notes: Vec<String> = device_file.as_ref().map_or_else(Vec::new, |f| f.design_notes(&carrier));
    let method = match a.method {
        MethodArg::Physical => Method::Physical,
        MethodArg::Normalized => Method::Normalized,
    };
    if a.display.display != crate::args::DisplayArg::Electrovibration {
        return display_map(&a, &map, &device, method, format, device_file.as_ref(), &notes);
    }
    a.display.refuse_display_flags()?;
    let v = map.voltages(&device, method)?;
    match format {
        MapFormat::Csv => haptex_core::io::write_atomic(&a.output, |w| {
            for note in &notes {
                writeln!(w, "# {note}")?;
            }
            v.write_csv(w)
        })?,
        MapFormat::Npy => haptex_core::map::write_npy_pair_designed(
            &a.output,
            &v.grid,
            &v.voltage_v,
            "voltage_v",
            Some(v.u_max_v),
            (!notes.is_empty()).then(|| notes.join("; ")),
        )?,
    }
    for note in &notes {
        eprintln!("{note}");
    }
    for line in v.summary_lines(method) {
        eprintln!("{line}");
    }
    eprintln!("wrote {}", a.output.display());
    Ok(())
}

/// `haptex map voltage --display ultrasonic|combined`: both channels per
/// cell, as one CSV.
fn display_map(
    a: &MapVoltageArgs,
    map: &FrictionMap,
    device: &Device,
    method: Method,
    format: MapFormat,
    device_file: Option<&crate::args::DesignDevice>,
    notes: &[String],
) -> anyhow::Result<()> {
    use haptex_core::combined::Channels;
    if method != Method::Physical {
        bail!("--method normalized (eq. 9) is for the electrovibration display: drop it with --display");
    }
    if format != MapFormat::Csv {
        bail!(
            "{}: an ultrasonic or combined display's map is written as CSV (one column per channel)",
            a.output.display()
        );
    }
    let ultrasonic = a.display.ultrasonic(device_file)?;
    let channels = match a.display.strategy()? {
        Some(strategy) => Channels::Combined(&ultrasonic, strategy),
        None => Channels::Ultrasonic(&ultrasonic),
    };
    let d = map.display_channels(device, channels)?;
    haptex_core::io::write_atomic(&a.output, |w| {
        for note in notes {
            writeln!(w, "# {note}")?;
        }
        d.write_csv(w)
    })?;
    for note in notes {
        eprintln!("{note}");
    }
    eprintln!("{}", d.summary_line());
    eprintln!("wrote {}", a.output.display());
    Ok(())
}

fn bits_per_pixel(text: &str) -> Result<u8, String> {
    match text.trim() {
        "8" => Ok(8),
        "16" => Ok(16),
        _ => Err(format!("'{text}': a grayscale PNG here has 8 or 16 bits per pixel")),
    }
}

fn export_png(a: ExportPngArgs) -> anyhow::Result<()> {
    let (grid, values) = match a.quantity.as_str() {
        "mu" => {
            let m = read_friction_map(&a.map)?;
            (m.grid, m.mu)
        }
        "h_mm" => {
            let h = height::read_height_map(&a.map)?;
            (h.grid, h.h_mm)
        }
        _ => {
            let v = read_voltage_map(&a.map)?;
            (v.grid, v.voltage_v)
        }
    };
    let (lo, hi) = min_max(&values);
    let (black, white) = (a.black.unwrap_or(lo), a.white.unwrap_or(hi));
    if !(black.is_finite() && white.is_finite()) || black == white {
        bail!(
            "black {} and white {} must be two different numbers (the map is constant at {}: give --black and --white)",
            Num(black),
            Num(white),
            Num(lo)
        );
    }
    let mapping = GrayMapping { mu_black: black, mu_white: white, gamma: 1.0 };
    // The encoder clamps; the map's own values stay as they are.
    let map = FrictionMap { grid, mu: values };
    haptex_core::io::write_atomic(&a.output, |w| map.write_gray_png(w, &mapping, a.bits))?;
    let clamped = map.mu.iter().filter(|&&v| v < black.min(white) || v > black.max(white)).count();
    eprintln!(
        "{} x {} pixels, {} bit: black = {}, white = {} ({}), linear",
        grid.nx,
        grid.ny,
        a.bits,
        Num(black),
        Num(white),
        a.quantity
    );
    if clamped > 0 {
        eprintln!("warning: {clamped} cells outside black .. white are drawn as black or white");
    }
    // A command to run: Num's 15 digits are far finer than the PNG's
    // levels (1/65535 of the range at best), so it reads back the same map.
    let pixels = format!("--pixel-mm {} --pixel-mm-y {}", Num(grid.dx_mm), Num(grid.dy_mm));
    let (x0, y0) = (Num(grid.x0_mm), Num(grid.y0_mm));
    let read_back = if a.quantity == "h_mm" {
        format!(
            "map height --height {} --h-black-mm {} --h-white-mm {} {pixels} --origin-mm {x0},{y0}",
            a.output.display(),
            Num(black),
            Num(white)
        )
    } else {
        format!(
            "map from-image {} --mu-black {} --mu-white {} {pixels} --x0-mm {x0} --y0-mm {y0}",
            a.output.display(),
            Num(black),
            Num(white)
        )
    };
    eprintln!("read back: haptex {read_back} -o MAP.csv");
    eprintln!("wrote {}", a.output.display());
    Ok(())
}

fn sample_path(a: SamplePathArgs) -> anyhow::Result<()> {
    let v = read_voltage_map(&a.voltage_map)?;
    let name = a.trajectory.display().to_string();
    let file = std::fs::File::open(&a.trajectory).with_context(|| format!("cannot open {name}"))?;
    let path = PlanarTrajectory::read_csv(std::io::BufReader::new(file), &name)?;
    let u = path.sample(&v.grid, &v.voltage_v);
    let output = crate::args::Output::new(a.output);
    output.write(|w| path.write_sampled_voltage_csv(w, &a.voltage_map.display().to_string(), &name, &u))?;
    eprintln!("{}", path.sampled_voltage_summary(&u));
    if let Some(p) = output.path() {
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

fn grating(a: GratingArgs) -> anyhow::Result<()> {
    use haptex_core::map::Grating;
    let format = MapFormat::of(&a.output)?;
    let grid = MapGrid {
        nx: a.nx as usize,
        ny: a.ny as usize,
        x0_mm: a.x0_mm,
        y0_mm: a.y0_mm,
        dx_mm: a.dx_mm,
        dy_mm: a.dy_mm,
    };
    let g = Grating {
        period_mm: a.period_mm,
        amplitude_mm: a.amplitude_mm,
        angle_deg: a.angle_deg,
        velocity_mm_s: a.velocity,
    };
    g.validate()?;
    grid.validate("grating")?;
    let dir = a.db.clone().unwrap_or_else(super::db::default_db);
    // The FE model's own flat-surface friction (its skin friction), or the
    // database's.
    let flat = haptex_fem::grating::flat_mu(a.source.into(), &dir)?;
    let across = Grating { angle_deg: 0.0, ..g };
    let mut maps = Vec::new();
    for grating in [g, across] {
        let line = line_friction(&grating, a.source, &dir)?;
        let (map, rms) =
            grating.friction_map(line.as_ref().map(|(x, mu, x0)| (x.as_slice(), mu.as_slice(), *x0)), flat, grid)?;
        maps.push((map, rms));
        if a.png.is_none() {
            break;
        }
    }
    let (map, rms) = &maps[0];
    write_friction_map(map, &a.output, format)?;
    report_map(map);
    let row = &map.mu[..grid.nx];
    let (lo, hi) = min_max(row);
    let mean = row.iter().sum::<f64>() / row.len() as f64;
    eprintln!(
        "grating: lambda {} mm, amplitude {} mm, {} degrees to the sliding direction: each line cuts a sine of \
         period {:.4} mm; along y = {} mm Ft/Fn {:.4} .. {:.4} (mean {:.4}, flat {})",
        Num(a.period_mm),
        Num(a.amplitude_mm),
        Num(a.angle_deg),
        g.line_period_mm(),
        Num(grid.y0_mm),
        lo,
        hi,
        mean,
        Num(flat)
    );
    if let Some(rms) = rms {
        eprintln!(
            "the line's friction is the periodic part (mean and up to 10 harmonics) of its {} profile after the \
             first mm: RMS {rms:.2e} from it",
            match a.source {
                LineSource::Fe => "FE",
                LineSource::Cae => "CAE",
            }
        );
    }
    if let Some(png) = &a.png {
        let x: Vec<f64> = (0..grid.nx).map(|i| grid.x(i)).collect();
        haptex_core::plot::Figure::new(format!(
            "sine grating lambda {} mm, amplitude {} mm: friction along y = {} mm",
            Num(a.period_mm),
            Num(a.amplitude_mm),
            Num(grid.y0_mm)
        ))
        .panel(
            haptex_core::plot::Panel::new("x (mm), the sliding direction", "Ft/Fn")
                .line(format!("{} degrees", Num(a.angle_deg)), &x, row)
                .line("0 degrees (ridges across the sliding)", &x, &maps[1].0.mu[..grid.nx])
                .line("flat surface", &x, &vec![flat; grid.nx]),
        )
        .write_png(png)?;
        eprintln!("wrote {}", png.display());
    }
    eprintln!("wrote {}", a.output.display());
    Ok(())
}

fn compose(a: ComposeArgs) -> anyhow::Result<()> {
    use haptex_core::map::{LabelImage, RegionFill};
    let format = MapFormat::of(&a.output)?;
    let mut fills: Vec<Option<(RegionFill, String)>> = vec![None; 256];
    let mut library = None;
    let mut fill_of = |text: &str, what: &str| -> anyhow::Result<(RegionFill, String)> {
        let text = text.trim();
        Ok(if let Some(name) = text.strip_prefix("material:") {
            if library.is_none() {
                let db = a.library.clone().unwrap_or_else(super::library::default_db);
                library = Some(super::library::open_read_only(&db)?);
            }
            let sampled = library.as_ref().expect("opened above").sample(name, Some(a.seed))?;
            let described = format!("material {name} (stroke {}, seed {})", sampled.stored.stroke.id, sampled.seed);
            (RegionFill::Texture(sampled.stored.profile), described)
        } else if let Some(file) = text.strip_prefix("profile:") {
            (RegionFill::Texture(read_profile(Path::new(file))?), format!("profile {file}"))
        } else {
            let mu: f64 = text.parse().map_err(|_| {
                anyhow::anyhow!("{what}: FILL must be a number, material:NAME or profile:FILE.csv, got '{text}'")
            })?;
            ranges::MU.check(mu).map_err(|e| anyhow::anyhow!("{what}: {e}"))?;
            (RegionFill::Constant(mu), format!("mu = {}", Num(mu)))
        })
    };
    for spec in &a.regions {
        let what = format!("--region '{spec}'");
        let (level, fill) = spec
            .split_once('=')
            .with_context(|| format!("{what}: expected LEVEL=FILL, e.g. 0=0.5 or 255=material:sponge"))?;
        let level: u8 =
            level.trim().parse().map_err(|_| anyhow::anyhow!("{what}: the level must be a gray level 0 .. 255"))?;
        if fills[level as usize].is_some() {
            bail!("{what}: gray level {level} is given twice");
        }
        fills[level as usize] = Some(fill_of(fill, &what)?);
    }
    let mut polygons = Vec::new();
    for spec in &a.polygons {
        let what = format!("--polygon '{spec}'");
        let (points, fill) =
            spec.rsplit_once('=').with_context(|| format!("{what}: expected X,Y;X,Y;X,Y=FILL (mm)"))?;
        let mut vertices = Vec::new();
        for (k, point) in points.split(';').enumerate() {
            let parsed = point
                .split_once(',')
                .and_then(|(x, y)| Some((x.trim().parse::<f64>().ok()?, y.trim().parse::<f64>().ok()?)));
            vertices.push(parsed.with_context(|| format!("{what}: vertex {} '{point}' is not X,Y in mm", k + 1))?);
        }
        polygons.push((vertices, fill_of(fill, &what)?, what));
    }
    let (spacing, origin) = (a.pixels.spacing(), a.pixels.origin());
    let (mut map, name, present) = match (&a.labels, &a.base, &a.size_mm) {
        (Some(labels), _, _) => {
            if a.regions.is_empty() {
                bail!("a label image needs --region LEVEL=FILL for each of its gray levels");
            }
            let name = labels.display().to_string();
            let image = LabelImage::read_png(&read_bounded(labels, 256 << 20)?, &name)?;
            let map = image.compose(
                &|level| fills[level as usize].as_ref().map(|(f, _)| f.clone()),
                spacing,
                origin,
                &name,
            )?;
            (map, name, image.levels())
        }
        (None, Some(base), Some(size)) => {
            let grid = sized_grid(size, spacing, origin)?;
            let (base_fill, described) = fill_of(base, "--base")?;
            fills[0] = Some((base_fill.clone(), described));
            let one = LabelImage { width: grid.nx, height: grid.ny, labels: vec![0; grid.len()] };
            (one.compose(&|_| Some(base_fill.clone()), spacing, origin, "--base")?, "--base".to_string(), vec![0])
        }
        _ => bail!("give a label image with --region LEVEL=FILL, or --base FILL with --size-mm W,H"),
    };
    let mut polygon_lines = Vec::new();
    for (vertices, (fill, described), what) in &polygons {
        let cells = map.fill_polygon(vertices, fill, what)?;
        polygon_lines.push(format!("{what}: {described}, {cells} cells"));
    }
    let unused: Vec<String> =
        (0..=255u8).filter(|l| fills[*l as usize].is_some() && !present.contains(l)).map(|l| l.to_string()).collect();
    write_friction_map(&map, &a.output, format)?;
    report_map(&map);
    for level in present {
        if let Some((_, described)) = &fills[level as usize] {
            if name == "--base" {
                eprintln!("base: {described}");
            } else {
                eprintln!("gray level {level}: {described}");
            }
        }
    }
    for line in polygon_lines {
        eprintln!("{line}");
    }
    if !unused.is_empty() {
        eprintln!("warning: no pixel has gray level {}: those regions are unused", unused.join(", "));
    }
    eprintln!("wrote {}", a.output.display());
    Ok(())
}

/// The friction profile of the 1-D sine a line of the grating cuts, and
/// its phase x0 (None where the line is flat): from an FE run (10 mm of
/// slide, the paper's scenario) or the database's CAE.
fn line_friction(g: &haptex_core::map::Grating, source: LineSource, db: &Path) -> anyhow::Result<Option<LineProfile>> {
    use haptex_fem::grating::LineError;
    match haptex_fem::grating::line_friction(g, source.into(), db) {
        Err(e @ LineError::OutsideDatabase { .. }) => bail!("{e}: use --source fe"),
        other => Ok(other?),
    }
}

use haptex_fem::grating::LineProfile;

impl From<LineSource> for haptex_fem::grating::LineSource {
    fn from(source: LineSource) -> Self {
        match source {
            LineSource::Fe => Self::Fe,
            LineSource::Cae => Self::Cae,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, ValueEnum)]
enum LineSource {
    Fe,
    Cae,
}

fn write_friction_map(map: &FrictionMap, path: &Path, format: MapFormat) -> anyhow::Result<()> {
    Ok(map.write_file(path, format)?)
}

fn read_friction_map(path: &Path) -> anyhow::Result<FrictionMap> {
    Ok(FrictionMap::read_file(path)?)
}

pub(crate) fn read_voltage_map(path: &Path) -> anyhow::Result<VoltageMap> {
    Ok(VoltageMap::read_file(path)?)
}

/// Reads a file of at most `limit` bytes.
fn read_bounded(path: &Path, limit: u64) -> anyhow::Result<Vec<u8>> {
    haptex_core::io::read_file_bounded(path, limit).with_context(|| format!("{}", path.display()))
}

/// "A,B" as two finite numbers; the error names `what`.
fn parse_pair(text: &str, what: &str) -> anyhow::Result<(f64, f64)> {
    text.split_once(',')
        .and_then(|(a, b)| Some((a.trim().parse::<f64>().ok()?, b.trim().parse::<f64>().ok()?)))
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .with_context(|| format!("{what} '{text}': expected two numbers A,B"))
}

/// The grid of a W,H mm map (`--size-mm`) at `spacing`, from `origin`.
fn sized_grid(size: &str, spacing: (f64, f64), origin: (f64, f64)) -> anyhow::Result<MapGrid> {
    let (w, h) = parse_pair(size, "--size-mm")
        .ok()
        .filter(|(w, h)| *w > 0.0 && *h > 0.0)
        .with_context(|| format!("--size-mm '{size}': expected W,H in mm, both positive"))?;
    let grid = MapGrid::covering(w, h, spacing, origin).with_context(|| {
        format!(
            "--size-mm {size} at {} x {} mm cells: more than {} cells",
            Num(spacing.0),
            Num(spacing.1),
            haptex_core::map::MAX_CELLS
        )
    })?;
    grid.validate("--size-mm")?;
    Ok(grid)
}

fn report_map(map: &FrictionMap) {
    eprintln!("{}", map.summary_line());
}
