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
use crate::args::positive;

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
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
}

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

    // The lines, relative to their start; identical ones run once.
    let mut unique: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    let mut first_line: Vec<usize> = Vec::new();
    let mut of_line = Vec::with_capacity(lines.count());
    let mut seen: HashMap<Vec<u64>, usize> = HashMap::new();
    for k in 0..lines.count() {
        let (s, h) = lines.line(&heights, k);
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
    let bar = if a.quiet {
        ProgressBar::hidden()
    } else {
        let bar = ProgressBar::new(unique.len() as u64);
        bar.set_style(
            ProgressStyle::with_template("{spinner} FE lines [{bar:30}] {pos}/{len} ({elapsed}, eta {eta})")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar
    };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(jobs).build().context("starting the FE workers")?;
    let results = pool.install(|| {
        unique
            .par_iter()
            .zip(&first_line)
            .map(|((s, h), &k)| {
                let mu = line_friction(s, h, a.velocity).with_context(|| {
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
    let results = results?;
    let mut mu_lines = Vec::with_capacity(lines.grid.len());
    for &i in &of_line {
        mu_lines.extend_from_slice(&results[i]);
    }
    let map = lines.assemble(&heights.grid, &mu_lines, "the height map's friction")?;

    if let (Some(path), Some(f)) = (&a.heights_out, heights_format) {
        write_heights(&heights, path, f)?;
    }
    write_friction_map(&map, &a.output, format)?;
    report_map(&map);
    let (lo, hi) = min_max(&heights.h_mm);
    eprintln!(
        "heights {lo:.4} .. {hi:.4} mm; sliding at {} degrees, {} mm/s; each line pressed {} mm before the map",
        Num(a.direction_deg),
        Num(a.velocity),
        Num(LEAD_IN_MM)
    );
    if let Some(path) = &a.heights_out {
        eprintln!("wrote {}", path.display());
    }
    eprintln!("wrote {}", a.output.display());
    Ok(())
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
