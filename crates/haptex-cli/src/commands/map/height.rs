//! `haptex map height`: the friction map of a height map h(x, y) (a file,
//! or a template laid along a path) from the FE finger model, line by line
//! along the sliding direction (`haptex_core::height`, docs/maps.md).

use std::collections::HashMap;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use haptex_core::height::{HeightMap, PathTemplate, SlidingLines};
use haptex_core::map::{read_npy_pair, write_npy_pair};
use haptex_core::num::Num;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use super::{MapFormat, min_max, parse_pair, report_map, sized_grid, write_friction_map};
use crate::args::{MeshArg, ModelArg, positive};

/// Lead-in before each line, mm: the finger is pressed this far before the
/// line's first point (on the first point's height) so that the press's
/// transient has settled when it reaches the map.
pub const LEAD_IN_MM: f64 = 3.0;

/// A friction map of a surface's heights h(x, y), from the FE finger model.
///
/// The finger slides in one direction (--direction-deg from +x). The map is
/// cut into lines along that direction, each a 1-D height profile the 2-D
/// FE model (plane strain in the sliding plane) slides over: pressed
/// 0.25 mm into the line's start, LEAD_IN 3 mm before the map, then slid
/// at --velocity at constant height. The lines' friction is put back on
/// the map's grid (bilinear in the rotated frame). The map therefore
/// depends on the direction: a ridge met across is a bump, met along its
/// length no bump at all. Lines with the same heights (relative to their
/// start) are run once; one FE run takes about 0.04 s per mm of slide.
///
/// The heights come from a file (--height: `x_mm,y_mm,h_mm` CSV, NPY with
/// its sidecar, quantity h_mm, or an 8/16-bit grayscale PNG with
/// --h-black-mm, --h-white-mm and --pixel-mm, linear in the gray level, as
/// `haptex map export-png --quantity h_mm` writes it) or from a template's cross-section laid
/// along a path (--template with --path and --size-mm): a ridge (bump), a
/// step (edge, up on the left of the path) or grooves (sine) following a
/// polyline.
///
/// With --model 3d the lines are run by the 3D fingertip over the whole
/// surface h(x, y) (its interpolating bicubic spline, docs/fem.md): each
/// run is pressed 0.5 mm deep, LEAD_IN before its line, and slid along it, its
/// contact patch seeing the heights beside the line too; runs are made
/// every --line-spacing-mm across the direction and the lines between
/// interpolated. A 3D run takes seconds (coarse mesh) to about a minute
/// (default) per 10 mm.
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    after_help = "Examples:\n  \
        haptex map height --template bump:1.5,0.2 --path \"2,2;10,6;18,3\" --size-mm 20,8 --pixel-mm 0.1 \\\n      \
            --direction-deg 0 -o ridge.csv --heights-out ridge_h.csv\n  \
        haptex map height --height surface.npy --direction-deg 45 -o surface_mu.npy"
)]
pub(super) struct HeightArgs {
    /// Height map: .csv `x_mm,y_mm,h_mm`, .npy with its sidecar (quantity
    /// h_mm) or a grayscale .png (with --h-black-mm, --h-white-mm, --pixel-mm).
    #[arg(long, value_name = "H", conflicts_with_all = ["template", "path", "size_mm"], required_unless_present = "template")]
    height: Option<PathBuf>,
    /// A template's cross-section laid along --path: bump:WIDTH,HEIGHT (a
    /// ridge), edge:WIDTH,HEIGHT (a step up on the path's left) or
    /// sine:PERIOD,AMPLITUDE (grooves parallel to the path), in mm; the
    /// FE templates' formulas, with the distance from the path as x.
    #[arg(long, value_name = "KIND:W,H", requires_all = ["path", "size_mm", "pixel_mm"])]
    template: Option<String>,
    /// The path: "X,Y;X,Y;..." (mm, at least 2 vertices).
    #[arg(long, value_name = "X,Y;X,Y;...", allow_hyphen_values = true)]
    path: Option<String>,
    /// With --template: the map's size W,H in mm.
    #[arg(long, value_name = "W,H")]
    size_mm: Option<String>,
    /// With --template or a PNG: cell size in mm (both axes, unless --pixel-mm-y).
    #[arg(long, value_parser = positive)]
    pixel_mm: Option<f64>,
    /// With a PNG: cell size along y in mm (default: --pixel-mm).
    #[arg(long, value_parser = positive, requires = "pixel_mm")]
    pixel_mm_y: Option<f64>,
    /// With --template or a PNG: x and y of the first cell (bottom left) in mm.
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    origin_mm: Option<String>,
    /// With a PNG: the height of black in mm.
    #[arg(long, value_name = "MM", requires = "h_white_mm")]
    h_black_mm: Option<f64>,
    /// With a PNG: the height of white in mm.
    #[arg(long, value_name = "MM", requires = "h_black_mm")]
    h_white_mm: Option<f64>,
    /// Sliding direction from +x in degrees (counter-clockwise): 0 slides
    /// along +x, 90 along +y.
    #[arg(long, default_value_t = 0.0)]
    direction_deg: f64,
    /// Sliding velocity in mm/s.
    #[arg(long, default_value_t = 20.0, value_parser = positive)]
    velocity: f64,
    /// FE runs at a time (default: the cores).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    jobs: Option<u32>,
    /// Also write the height map (the template's, or the file's) to this
    /// .csv or .npy.
    #[arg(long, value_name = "H_OUT")]
    heights_out: Option<PathBuf>,
    /// Output friction map (.csv or .npy with its sidecar).
    #[arg(short, long, value_name = "OUT")]
    output: PathBuf,
    /// The FE finger: 2d (each line a 2D run over its own height profile)
    /// or 3d (the 3D fingertip over the whole height map).
    #[arg(long, value_enum, default_value_t = ModelArg::TwoD)]
    model: ModelArg,
    /// With --model 3d: the distance between 3D runs across the sliding
    /// direction, mm (default 0.5; the lines between are interpolated).
    #[arg(long, value_parser = positive)]
    line_spacing_mm: Option<f64>,
    /// With --model 3d: the 3D mesh resolution.
    #[arg(long, value_enum)]
    mesh: Option<MeshArg>,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
}

/// The default distance between 3D runs across the sliding direction, mm:
/// a tenth of the 3D finger's contact width at its default press (about
/// 5 mm), over which its friction varies little.
pub const LINE_SPACING_3D_MM: f64 = 0.5;

pub(super) fn run(a: HeightArgs) -> anyhow::Result<()> {
    let format = MapFormat::of(&a.output)?;
    let heights_format = a.heights_out.as_deref().map(MapFormat::of).transpose()?;
    haptex_core::io::OutputTarget::of(&a.output)?;
    let origin = a.origin_mm.as_deref().map_or(Ok((0.0, 0.0)), |o| parse_pair(o, "--origin-mm"))?;
    let heights = match (&a.height, &a.template) {
        (Some(path), _) if is_png(path) => {
            let (Some(black), Some(white)) = (a.h_black_mm, a.h_white_mm) else {
                bail!("{}: a PNG's gray levels need --h-black-mm and --h-white-mm (mm)", path.display());
            };
            let pixel = a.pixel_mm.with_context(|| format!("{}: a PNG needs --pixel-mm", path.display()))?;
            let bytes =
                haptex_core::io::read_file_bounded(path, 256 << 20).with_context(|| format!("{}", path.display()))?;
            let spacing = (pixel, a.pixel_mm_y.unwrap_or(pixel));
            HeightMap::read_gray_png(&bytes, black, white, spacing, origin, &path.display().to_string())?
        }
        (Some(path), _) => {
            let png_only = [
                (a.pixel_mm.is_some(), "--pixel-mm"),
                (a.origin_mm.is_some(), "--origin-mm"),
                (a.h_black_mm.is_some(), "--h-black-mm"),
            ];
            if let Some((_, flag)) = png_only.iter().find(|(given, _)| *given) {
                bail!("{flag} is for a PNG or a template: {} holds its own grid and heights", path.display());
            }
            read_height_map(path)?
        }
        (None, Some(template)) => {
            if a.h_black_mm.is_some() || a.pixel_mm_y.is_some() {
                bail!("--h-black-mm, --h-white-mm and --pixel-mm-y are for a PNG height map, not a template");
            }
            let template = parse_template(template)?;
            let path = parse_path(a.path.as_deref().context("--template needs --path")?)?;
            let size = a.size_mm.as_deref().context("--template needs --size-mm W,H")?;
            let pixel = a.pixel_mm.context("--template needs --pixel-mm")?;
            let grid = sized_grid(size, (pixel, pixel), origin)?;
            HeightMap::along_path(grid, template, &path)?
        }
        (None, None) => bail!("give --height H.csv, or --template KIND:W,H with --path and --size-mm"),
    };
    let lines = SlidingLines::new(&heights.grid, a.direction_deg)?;
    let jobs = a.jobs.map_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()), |j| j as usize);
    if a.model == ModelArg::TwoD {
        for (given, flag) in [(a.line_spacing_mm.is_some(), "--line-spacing-mm"), (a.mesh.is_some(), "--mesh")] {
            if given {
                bail!("{flag} is for --model 3d (the 2D lines are run one per map row, on the default 2D mesh)");
            }
        }
    }
    let map = if a.model == ModelArg::ThreeD {
        friction_3d(&a, &heights, &lines, jobs)?
    } else {
        friction_2d(&a, &heights, &lines, jobs)?
    };

    if let (Some(path), Some(f)) = (&a.heights_out, heights_format) {
        write_heights(&heights, path, f)?;
    }
    write_friction_map(&map, &a.output, format)?;
    report_map(&map);
    let (lo, hi) = min_max(&heights.h_mm);
    eprintln!(
        "heights {lo:.4} .. {hi:.4} mm; sliding at {} degrees, {} mm/s; each line pressed {} mm before the map{}",
        Num(a.direction_deg),
        Num(a.velocity),
        Num(LEAD_IN_MM),
        if a.model == ModelArg::ThreeD { " by the 3D finger" } else { "" }
    );
    if let Some(path) = &a.heights_out {
        eprintln!("wrote {}", path.display());
    }
    eprintln!("wrote {}", a.output.display());
    Ok(())
}

/// The FE runs of lines `line_of_run` (run i is `run(i)`, on line
/// `line_of_run[i]`), `jobs` at a time with a progress bar labelled
/// `label`; an error names the run's line.
fn run_lines(
    quiet: bool,
    label: &str,
    jobs: usize,
    lines: &SlidingLines,
    line_of_run: &[usize],
    run: impl Fn(usize) -> anyhow::Result<Vec<f64>> + Sync,
) -> anyhow::Result<Vec<Vec<f64>>> {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        let bar = ProgressBar::new(line_of_run.len() as u64);
        bar.set_style(
            ProgressStyle::with_template(&format!(
                "{{spinner}} {label} [{{bar:30}}] {{pos}}/{{len}} ({{elapsed}}, eta {{eta}})"
            ))
            .expect("valid template")
            .progress_chars("=> "),
        );
        bar
    };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(jobs).build().context("starting the FE workers")?;
    let results = pool.install(|| {
        line_of_run
            .par_iter()
            .enumerate()
            .map(|(i, &k)| {
                let mu = run(i).with_context(|| {
                    format!(
                        "line {} of {} (r = {} mm across the sliding direction)",
                        k + 1,
                        lines.count(),
                        Num(lines.grid.y(k))
                    )
                })?;
                bar.inc(1);
                Ok(mu)
            })
            .collect::<anyhow::Result<Vec<Vec<f64>>>>()
    });
    bar.finish_and_clear();
    results
}

/// The friction map from the 3D finger: runs along every few lines (every
/// --line-spacing-mm across the direction, and the last), each over the
/// whole surface, the lines between interpolated linearly across.
fn friction_3d(
    a: &HeightArgs,
    heights: &HeightMap,
    lines: &SlidingLines,
    jobs: usize,
) -> anyhow::Result<haptex_core::map::FrictionMap> {
    use haptex_fem::solid3d::surface::MapSurface;
    let spacing = a.line_spacing_mm.unwrap_or(LINE_SPACING_3D_MM);
    let count = lines.count();
    let every = ((spacing / lines.grid.dy_mm).round() as usize).clamp(1, count);
    let mut runs: Vec<usize> = (0..count).step_by(every).collect();
    if runs.last() != Some(&(count - 1)) {
        runs.push(count - 1);
    }
    let resolution = a.mesh.unwrap_or(MeshArg::Default).resolution();
    let surface = std::sync::Arc::new(MapSurface::new(heights));
    if !a.quiet {
        let g = &lines.grid;
        eprintln!(
            "haptex map height --model 3d: {} lines of {} mm at {} degrees; 3D runs on {} of them (every {} mm), {jobs} \
             at a time",
            count,
            Num(g.dx_mm * (g.nx - 1) as f64),
            Num(a.direction_deg),
            runs.len(),
            Num(every as f64 * g.dy_mm)
        );
    }
    let results = run_lines(a.quiet, "3D lines", jobs, lines, &runs, |i| {
        line_friction_3d(lines, &surface, runs[i], a.velocity, resolution)
    })?;
    // Every line: a run's, or interpolated between the runs on each side.
    let nx = lines.grid.nx;
    let mut mu_lines = Vec::with_capacity(lines.grid.len());
    let mut next = 0;
    for k in 0..count {
        while runs[next] < k {
            next += 1;
        }
        if runs[next] == k {
            mu_lines.extend_from_slice(&results[next]);
        } else {
            let (k0, k1) = (runs[next - 1], runs[next]);
            let w = (k - k0) as f64 / (k1 - k0) as f64;
            mu_lines.extend((0..nx).map(|i| (1.0 - w) * results[next - 1][i] + w * results[next][i]));
        }
    }
    Ok(lines.assemble(&heights.grid, &mu_lines, "the height map's friction")?)
}

/// The 3D finger's friction (Ft/Fn) along line `k` of `lines` at its
/// points: the fingertip pressed 0.5 mm deep, [`LEAD_IN_MM`] before the line's
/// start, then slid along it over the whole surface at `velocity` mm/s in
/// steps of at most 0.1 mm and at most the line's spacing.
pub fn line_friction_3d(
    lines: &SlidingLines,
    surface: &std::sync::Arc<haptex_fem::solid3d::surface::MapSurface>,
    k: usize,
    velocity: f64,
    resolution: haptex_fem::finger::Resolution,
) -> anyhow::Result<Vec<f64>> {
    use haptex_fem::scenario::{Loading, Scenario};
    use haptex_fem::surface::SurfaceShape;
    let g = &lines.grid;
    let r = g.y(k);
    let (s0, s1) = (g.x(0), g.x(g.nx - 1));
    let start = lines.to_map_frame(s0 - LEAD_IN_MM, r);
    let mut scenario = Scenario::paper(SurfaceShape::Flat);
    scenario.resolution = resolution;
    scenario.loading = Loading::Indent(crate::commands::simulate::DEFAULT_INDENT_3D_MM);
    scenario.slide_mm = s1 - s0 + LEAD_IN_MM;
    scenario.velocity_mm_s = velocity;
    scenario.step_mm = scenario.step_mm.min(g.dx_mm);
    let result = haptex_fem::solid3d::slide::run_on_surface(
        &scenario,
        surface.clone(),
        [start.0, start.1],
        lines.angle_deg,
        &mut |_| {},
    )?;
    if let Some(u) = result.unresolved() {
        // The line's friction is the mesh's where this holds.
        eprintln!("warning: the 3D finger's line {k} (r = {} mm across the sliding direction): {u}", Num(r));
    }
    let profile = result.profile.context("the FE run gave no profile")?;
    let (px, pmu) = (profile.x_mm(), profile.mu());
    Ok((0..g.nx).map(|i| haptex_core::profile::interpolate(px, pmu, g.x(i) - s0 + LEAD_IN_MM)).collect())
}

/// The friction map from the 2D finger, line by line.
fn friction_2d(
    a: &HeightArgs,
    heights: &HeightMap,
    lines: &SlidingLines,
    jobs: usize,
) -> anyhow::Result<haptex_core::map::FrictionMap> {
    // The lines, relative to their start; identical ones run once.
    let mut unique: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    let mut first_line: Vec<usize> = Vec::new();
    let mut of_line = Vec::with_capacity(lines.count());
    let mut seen: HashMap<Vec<u64>, usize> = HashMap::new();
    for k in 0..lines.count() {
        let (s, h) = lines.line(heights, k);
        let relative: Vec<f64> = h.iter().map(|v| v - h[0]).collect();
        let key: Vec<u64> = relative.iter().map(|v| (v + 0.0).to_bits()).collect();
        let index = *seen.entry(key).or_insert_with(|| {
            unique.push((s.iter().map(|v| v - s[0]).collect(), relative));
            first_line.push(k);
            unique.len() - 1
        });
        of_line.push(index);
    }
    if !a.quiet {
        let g = &lines.grid;
        eprintln!(
            "haptex map height: {} lines of {} points ({} mm) at {} degrees, {} distinct: {} FE runs, {jobs} at a time",
            g.ny,
            g.nx,
            Num(g.dx_mm * (g.nx - 1) as f64),
            Num(a.direction_deg),
            unique.len(),
            unique.len()
        );
    }
    let results = run_lines(a.quiet, "FE lines", jobs, lines, &first_line, |i| {
        let (s, h) = &unique[i];
        line_friction(s, h, a.velocity)
    })?;
    let mut mu_lines = Vec::with_capacity(lines.grid.len());
    for &i in &of_line {
        mu_lines.extend_from_slice(&results[i]);
    }
    Ok(lines.assemble(&heights.grid, &mu_lines, "the height map's friction")?)
}

/// The FE friction (Ft/Fn) along one line at its points `s` (mm from its
/// start) over heights `h` (mm, 0 at the start): the finger pressed
/// [`LEAD_IN_MM`] before the start, on the start's height, then slid over
/// the line at `velocity` mm/s in steps of at most 0.1 mm and at most the
/// line's spacing.
pub fn line_friction(s: &[f64], h: &[f64], velocity: f64) -> anyhow::Result<Vec<f64>> {
    use haptex_fem::scenario::{self, Scenario};
    use haptex_fem::surface::SurfaceShape;
    let x: Vec<f64> = s.iter().map(|v| v + LEAD_IN_MM).collect();
    let length = s[s.len() - 1];
    let mut scenario = Scenario::paper(SurfaceShape::Sampled { x_mm: x.clone(), h_mm: h.to_vec() });
    scenario.slide_mm = length + LEAD_IN_MM;
    scenario.velocity_mm_s = velocity;
    scenario.step_mm = scenario.step_mm.min(s[1] - s[0]);
    let result = scenario::run(&scenario, &mut |_| {})?;
    let profile = result.profile.context("the FE run gave no profile")?;
    let (px, pmu) = (profile.x_mm(), profile.mu());
    Ok(x.iter().map(|&v| haptex_core::profile::interpolate(px, pmu, v)).collect())
}

fn parse_template(text: &str) -> anyhow::Result<PathTemplate> {
    let (kind, rest) =
        text.split_once(':').with_context(|| format!("--template '{text}': expected KIND:W,H (bump, edge or sine)"))?;
    let (w, h) = parse_pair(rest, "--template")?;
    let t = match kind.trim() {
        "bump" => PathTemplate::Bump { width_mm: w, height_mm: h },
        "edge" => PathTemplate::Edge { width_mm: w, height_mm: h },
        "sine" => PathTemplate::Sine { width_mm: w, height_mm: h },
        other => bail!("--template '{text}': unknown kind '{other}' (bump, edge or sine)"),
    };
    t.validate()?;
    Ok(t)
}

fn parse_path(text: &str) -> anyhow::Result<Vec<(f64, f64)>> {
    text.split(';').enumerate().map(|(k, point)| parse_pair(point, &format!("--path, vertex {}", k + 1))).collect()
}

fn is_png(path: &std::path::Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("png"))
}

/// A height map from .csv or .npy (with its sidecar).
pub(crate) fn read_height_map(path: &std::path::Path) -> anyhow::Result<HeightMap> {
    let name = path.display().to_string();
    Ok(match MapFormat::of(path)? {
        MapFormat::Csv => {
            let file = std::fs::File::open(path).with_context(|| format!("cannot open {name}"))?;
            HeightMap::read_csv(std::io::BufReader::new(file), &name)?
        }
        MapFormat::Npy => {
            let (sidecar, h) = read_npy_pair(path, "h_mm")?;
            HeightMap::new(sidecar.grid, h, &name)?
        }
    })
}

fn write_heights(map: &HeightMap, path: &std::path::Path, format: MapFormat) -> anyhow::Result<()> {
    match format {
        MapFormat::Csv => haptex_core::io::write_atomic(path, |w| map.write_csv(w))?,
        MapFormat::Npy => write_npy_pair(path, &map.grid, &map.h_mm, "h_mm", None)?,
    }
    Ok(())
}
