//! Friction maps over (x, y): mu on a regular grid, read and written as
//! CSV (long format), NPY (with a JSON sidecar for the grid) and 8/16-bit
//! grayscale PNG (with an explicit gray-to-friction mapping); eq. (8) and
//! eq. (9) per cell; bilinear sampling along a finger path.
//!
//! The grid: `nx` columns at x = x0 + i dx and `ny` rows at y = y0 + j dy,
//! values stored row by row (index j nx + i), y growing upwards. An
//! image's top row is the map's last row (largest y), so that the map
//! plotted with y up looks like the image.

use std::io::{BufRead, Write};

use serde::{Deserialize, Serialize};

use crate::electrovibration::{Device, Method, PhysicalMapping, normalized_voltages};
use crate::io::write_csv_row;
use crate::num::Num;
use crate::ranges;

/// Most cells of a map: 64 M (a 8000 x 8000 image), 512 MB as f64.
pub const MAX_CELLS: usize = 64 << 20;

/// A map that cannot be read or built, with where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{source_name}{}: {message}", place.as_deref().map(|p| format!(", {p}")).unwrap_or_default())]
pub struct MapError {
    pub source_name: String,
    /// Line, pixel or field, when the error has one.
    pub place: Option<String>,
    pub message: String,
}

impl MapError {
    pub(crate) fn new(source_name: &str, place: Option<String>, message: impl Into<String>) -> Self {
        Self { source_name: source_name.to_string(), place, message: message.into() }
    }
}

/// The regular grid of a map (mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MapGrid {
    pub nx: usize,
    pub ny: usize,
    pub x0_mm: f64,
    pub y0_mm: f64,
    pub dx_mm: f64,
    pub dy_mm: f64,
}

impl MapGrid {
    /// Checks the grid: at least 2 x 2 cells, at most [`MAX_CELLS`],
    /// positive spacings, positions within the position range.
    pub fn validate(&self, source_name: &str) -> Result<(), MapError> {
        let err = |field: &str, m: String| MapError::new(source_name, Some(field.to_string()), m);
        if self.nx < 2 || self.ny < 2 {
            return Err(err("shape", format!("{} x {} cells: a map needs at least 2 x 2", self.nx, self.ny)));
        }
        if self.nx.checked_mul(self.ny).is_none_or(|n| n > MAX_CELLS) {
            return Err(err("shape", format!("{} x {} cells: at most {MAX_CELLS} cells", self.nx, self.ny)));
        }
        for (name, d) in [("dx_mm", self.dx_mm), ("dy_mm", self.dy_mm)] {
            if !(d.is_finite() && d > 0.0) {
                return Err(err(name, format!("spacing must be a positive number of mm, got {}", Num(d))));
            }
        }
        let x1 = self.x0_mm + self.dx_mm * (self.nx - 1) as f64;
        let y1 = self.y0_mm + self.dy_mm * (self.ny - 1) as f64;
        for (name, v) in [("x0_mm", self.x0_mm), ("y0_mm", self.y0_mm), ("x_mm", x1), ("y_mm", y1)] {
            ranges::POSITION_MM.check(v).map_err(|e| err(name, e.to_string()))?;
        }
        Ok(())
    }

    /// The grid over a `w_mm` x `h_mm` rectangle from `origin_mm` at
    /// `spacing_mm`: floor(w / dx) + 1 columns and floor(h / dy) + 1 rows
    /// (`haptex map compose --size-mm`); None when that is more than
    /// [`MAX_CELLS`] cells. Not validated.
    pub fn covering(w_mm: f64, h_mm: f64, spacing_mm: (f64, f64), origin_mm: (f64, f64)) -> Option<Self> {
        let (nx, ny) = ((w_mm / spacing_mm.0).floor() + 1.0, (h_mm / spacing_mm.1).floor() + 1.0);
        if nx * ny > MAX_CELLS as f64 {
            return None;
        }
        Some(MapGrid {
            nx: nx as usize,
            ny: ny as usize,
            x0_mm: origin_mm.0,
            y0_mm: origin_mm.1,
            dx_mm: spacing_mm.0,
            dy_mm: spacing_mm.1,
        })
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// True for a grid without cells (never for a validated grid).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// x of column `i`.
    pub fn x(&self, i: usize) -> f64 {
        self.x0_mm + self.dx_mm * i as f64
    }

    /// y of row `j`.
    pub fn y(&self, j: usize) -> f64 {
        self.y0_mm + self.dy_mm * j as f64
    }

    /// Whether (x, y) lies on the grid (edges included).
    pub fn contains(&self, x_mm: f64, y_mm: f64) -> bool {
        (self.x0_mm..=self.x(self.nx - 1)).contains(&x_mm) && (self.y0_mm..=self.y(self.ny - 1)).contains(&y_mm)
    }

    /// Bilinear interpolation of `values` (one per cell) at (x, y), the
    /// edge values held beyond the grid. On a grid line the other axis'
    /// weight is exactly 0, so a row is sampled as the 1-D linear
    /// interpolation of its values.
    pub fn sample(&self, values: &[f64], x_mm: f64, y_mm: f64) -> f64 {
        let (i, tx) = axis(x_mm, self.x0_mm, self.dx_mm, self.nx);
        let (j, ty) = axis(y_mm, self.y0_mm, self.dy_mm, self.ny);
        let row = |j: usize| {
            let a = values[j * self.nx + i];
            if tx == 0.0 { a } else { a + tx * (values[j * self.nx + i + 1] - a) }
        };
        let r0 = row(j);
        if ty == 0.0 { r0 } else { r0 + ty * (row(j + 1) - r0) }
    }
}

/// The cell index and fraction along one axis: t in [0, 1), i + 1 < n
/// whenever t > 0; positions beyond the ends are held at the end.
fn axis(v: f64, v0: f64, d: f64, n: usize) -> (usize, f64) {
    let s = (v - v0) / d;
    if s.is_nan() || s <= 0.0 {
        return (0, 0.0);
    }
    if s >= (n - 1) as f64 {
        return (n - 1, 0.0);
    }
    let i = s.floor() as usize;
    (i, s - i as f64)
}

/// Friction coefficient over a regular (x, y) grid.
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionMap {
    pub grid: MapGrid,
    /// mu per cell, row by row (index j nx + i).
    pub mu: Vec<f64>,
}

impl FrictionMap {
    /// A map from its grid and values, checked (sizes, friction range).
    pub fn new(grid: MapGrid, mu: Vec<f64>, source_name: &str) -> Result<Self, MapError> {
        grid.validate(source_name)?;
        if mu.len() != grid.len() {
            return Err(MapError::new(
                source_name,
                None,
                format!("{} values for {} x {} cells", mu.len(), grid.nx, grid.ny),
            ));
        }
        if let Some(k) = ranges::MU.first_outside(&mu) {
            return Err(MapError::new(
                source_name,
                Some(format!("cell x = {} mm, y = {} mm", Num(grid.x(k % grid.nx)), Num(grid.y(k / grid.nx)))),
                ranges::MU.refusal(mu[k]).to_string(),
            ));
        }
        Ok(Self { grid, mu })
    }

    /// The map whose every row is the same 1-D profile sampled on the grid
    /// `x0 + i dx` (linear interpolation, ends held): a line texture
    /// extended along y.
    pub fn extrude(profile: &crate::profile::FrictionProfile, grid: MapGrid) -> Result<Self, MapError> {
        grid.validate("profile")?;
        let row: Vec<f64> = (0..grid.nx).map(|i| profile.mu_at(grid.x(i))).collect();
        let mu = (0..grid.ny).flat_map(|_| row.iter().copied()).collect();
        Self::new(grid, mu, "profile")
    }

    /// Reads the long CSV format `x_mm,y_mm,mu` (other columns ignored),
    /// rows in row-major order as haptex writes them and as NumPy's
    /// `meshgrid(x, y)` raveled gives them: y constant while x runs through
    /// the grid, then the next y. The grid is the first row's x and y and
    /// the first steps in x and y; every row must lie on it (to 1e-9 of a
    /// step), in order.
    pub fn read_csv<R: std::io::Read>(reader: R, source_name: &str) -> Result<Self, MapError> {
        let (grid, mu) = read_grid_csv(reader, source_name, &ranges::MU)?;
        Self::new(grid, mu, source_name)
    }

    /// Writes the long CSV format, row-major, after a comment line.
    pub fn write_csv(&self, w: &mut dyn Write) -> std::io::Result<()> {
        let g = &self.grid;
        writeln!(
            w,
            "# haptex friction map: {} x {} cells, dx = {} mm, dy = {} mm",
            g.nx,
            g.ny,
            Num(g.dx_mm),
            Num(g.dy_mm)
        )?;
        write_grid_rows(w, g, "mu", &self.mu)
    }

    /// Writes the values as a 2-D float64 NPY array of shape (ny, nx),
    /// row j at y0 + j dy (the grid goes in [`MapGrid`]'s JSON sidecar).
    pub fn write_npy(&self, w: &mut dyn Write) -> std::io::Result<()> {
        write_npy_f64(w, self.grid.ny, self.grid.nx, &self.mu)
    }

    /// Reads a (ny, nx) float32/float64 NPY array with its grid.
    pub fn read_npy(bytes: &[u8], grid: MapGrid, source_name: &str) -> Result<Self, MapError> {
        grid.validate(source_name)?;
        let values = read_npy_2d(bytes, source_name, grid.ny, grid.nx)?;
        Self::new(grid, values, source_name)
    }

    /// Reads an 8- or 16-bit grayscale PNG (row 0 the top, at the largest
    /// y) with `mapping` from gray level to friction; the grid's nx and ny
    /// are the image's width and height.
    pub fn read_gray_png(
        bytes: &[u8],
        mapping: &GrayMapping,
        spacing_mm: (f64, f64),
        origin_mm: (f64, f64),
        source_name: &str,
    ) -> Result<Self, MapError> {
        mapping.validate(source_name)?;
        let (grid, mu) = read_gray_grid(bytes, spacing_mm, origin_mm, source_name, |g| mapping.mu(g))?;
        Self::new(grid, mu, source_name)
    }

    /// Writes the map as a grayscale PNG of `bits` (8 or 16) with the
    /// inverse of `mapping` (values outside its friction range are
    /// clamped to black or white).
    pub fn write_gray_png(&self, w: &mut dyn Write, mapping: &GrayMapping, bits: u8) -> std::io::Result<()> {
        let g = &self.grid;
        let mut encoder = png::Encoder::new(w, g.nx as u32, g.ny as u32);
        // What the gray levels mean, inside the image (a tEXt chunk).
        encoder
            .add_text_chunk(
                "haptex".to_string(),
                format!(
                    "haptex map: gray g in [0, 1] -> value = {} + ({} - {}) g^{}; pixel {} x {} mm; bottom-left pixel \
                     at x = {} mm, y = {} mm",
                    Num(mapping.mu_black),
                    Num(mapping.mu_white),
                    Num(mapping.mu_black),
                    Num(mapping.gamma),
                    Num(g.dx_mm),
                    Num(g.dy_mm),
                    Num(g.x0_mm),
                    Num(g.y0_mm)
                ),
            )
            .map_err(std::io::Error::other)?;
        encoder.set_color(png::ColorType::Grayscale);
        let sixteen = bits == 16;
        encoder.set_depth(if sixteen { png::BitDepth::Sixteen } else { png::BitDepth::Eight });
        let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
        let full = if sixteen { 65535.0 } else { 255.0 };
        let mut data = Vec::with_capacity(g.len() * if sixteen { 2 } else { 1 });
        for r in 0..g.ny {
            let j = g.ny - 1 - r;
            for &m in &self.mu[j * g.nx..(j + 1) * g.nx] {
                let level = (mapping.gray(m) * full).round();
                if sixteen {
                    data.extend_from_slice(&(level as u16).to_be_bytes());
                } else {
                    data.push(level as u8);
                }
            }
        }
        writer.write_image_data(&data).map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    }

    /// Eq. (8) or eq. (9) applied to every cell, with the device limits as
    /// fractions of the area.
    pub fn voltages(&self, device: &Device, method: Method) -> Result<VoltageMap, MapError> {
        let device_error = |m: String| MapError::new("device", None, m);
        device.validate().map_err(|e| device_error(e.to_string()))?;
        if method == Method::Physical && !device.contact.is_linear() {
            return Err(device_error(
                "a friction map is mapped with the linear contact-area law (area exponent 1), as eq. (8)".into(),
            ));
        }
        let mut voltage_v = vec![0.0; self.mu.len()];
        let (mut below, mut clipped) = (0usize, 0usize);
        match method {
            Method::Physical => {
                let m = PhysicalMapping::new(device.mu_hd, device.force_ratio_per_v2(1.0), device.u_max_v);
                m.fill(&self.mu, &mut voltage_v);
                for &mu in &self.mu {
                    below += usize::from(mu < device.mu_hd);
                    clipped += usize::from(mu > m.mu_clip);
                }
            }
            Method::Normalized => {
                normalized_voltages(&self.mu, device.u_max_v, &mut voltage_v);
            }
        }
        let n = self.mu.len() as f64;
        Ok(VoltageMap {
            grid: self.grid,
            voltage_v,
            u_max_v: device.u_max_v,
            not_renderable_fraction: below as f64 / n,
            clipped_fraction: clipped as f64 / n,
        })
    }
}

/// Voltages (V RMS) over a map's grid, and the device limits as areas.
#[derive(Debug, Clone, PartialEq)]
pub struct VoltageMap {
    pub grid: MapGrid,
    pub voltage_v: Vec<f64>,
    pub u_max_v: f64,
    /// Fraction of the cells below mu_HD (0 V, not renderable).
    pub not_renderable_fraction: f64,
    /// Fraction of the cells above what U_max reaches (clipped).
    pub clipped_fraction: f64,
}

impl VoltageMap {
    /// The voltage at (x, y), bilinear.
    pub fn sample(&self, x_mm: f64, y_mm: f64) -> f64 {
        self.grid.sample(&self.voltage_v, x_mm, y_mm)
    }

    /// Writes `x_mm,y_mm,voltage_v`, row-major.
    pub fn write_csv(&self, w: &mut dyn Write) -> std::io::Result<()> {
        let g = &self.grid;
        writeln!(
            w,
            "# haptex voltage map: {} x {} cells; voltage_v is RMS, at most U_max = {} V; {:.2}% of the area below \
             mu_HD (0 V), {:.2}% clipped at U_max",
            g.nx,
            g.ny,
            Num(self.u_max_v),
            100.0 * self.not_renderable_fraction,
            100.0 * self.clipped_fraction
        )?;
        write_grid_rows(w, g, "voltage_v", &self.voltage_v)
    }
}

/// Reads a map in the long CSV format `x_mm,y_mm,QUANTITY` (other columns
/// ignored), rows in row-major order: see [`FrictionMap::read_csv`].
/// The values are checked against `quantity`'s range.
pub fn read_grid_csv<R: std::io::Read>(
    reader: R,
    source_name: &str,
    quantity: &ranges::Range,
) -> Result<(MapGrid, Vec<f64>), MapError> {
    // The table's error names the file first ("F: ..." or "F, line N,
    // ..."); the map's error names it once.
    let table = crate::io::Table::read(reader, source_name).map_err(|e| {
        let text = e.to_string();
        let rest = text.strip_prefix(source_name).map_or(text.as_str(), |r| r.trim_start_matches([':', ',', ' ']));
        MapError::new(source_name, None, rest)
    })?;
    let col = |name: &str| {
        table.column(name).ok_or_else(|| {
            MapError::new(
                source_name,
                None,
                format!("no '{name}' column: this map CSV needs x_mm,y_mm,{}", quantity.name),
            )
        })
    };
    let (x, y, mu) = (col("x_mm")?, col("y_mm")?, col(quantity.name)?);
    if quantity.name == ranges::VOLTAGE_V.name && table.column("amplitude_um").is_some() {
        // As `VoltageCurve::from_table` refuses such a profile.
        return Err(MapError::new(
            source_name,
            Some("amplitude_um".into()),
            "this map was designed for a combined or ultrasonic display: its voltages assume the plate amplitudes \
             beside them, which a voltage-only reader cannot apply (two-channel playback over a map is not built); \
             design it with haptex map voltage --display electrovibration",
        ));
    }
    let n = x.len();
    let line = |k: usize| Some(format!("line {}", table.line_of_row(k)));
    // nx: the first row whose y differs from the first y.
    let nx = y.iter().position(|&v| v != y[0]).unwrap_or(n);
    if nx < 2 {
        return Err(MapError::new(
            source_name,
            None,
            format!("{nx} x value(s) for the first y: a map needs at least 2 x values per y"),
        ));
    }
    if n % nx != 0 {
        return Err(MapError::new(
            source_name,
            None,
            format!("{n} rows are not a whole number of grid rows of {nx} x values"),
        ));
    }
    if n < 2 * nx {
        return Err(MapError::new(source_name, None, "one value of y: a map needs at least 2"));
    }
    let grid = MapGrid { nx, ny: n / nx, x0_mm: x[0], y0_mm: y[0], dx_mm: x[1] - x[0], dy_mm: y[nx] - y[0] };
    grid.validate(source_name)?;
    let tolerance = 1e-9;
    for k in 0..n {
        let (i, j) = (k % nx, k / nx);
        let (ex, ey) = ((x[k] - grid.x(i)) / grid.dx_mm, (y[k] - grid.y(j)) / grid.dy_mm);
        if ex.abs() > tolerance || ey.abs() > tolerance {
            return Err(MapError::new(
                source_name,
                line(k),
                format!(
                    "x_mm = {}, y_mm = {} is not the grid point ({}, {}) expected here: rows must run through \
                     x for each y in turn, on a regular grid (x0 {}, dx {}, y0 {}, dy {} mm)",
                    Num(x[k]),
                    Num(y[k]),
                    Num(grid.x(i)),
                    Num(grid.y(j)),
                    Num(grid.x0_mm),
                    Num(grid.dx_mm),
                    Num(grid.y0_mm),
                    Num(grid.dy_mm)
                ),
            ));
        }
    }
    if let Some(k) = quantity.first_outside(mu) {
        return Err(MapError::new(
            source_name,
            line(k),
            format!("field {}: {}", quantity.name, quantity.refusal(mu[k])),
        ));
    }
    Ok((grid, mu.to_vec()))
}

/// The header row `x_mm,y_mm,NAME` and one row per cell, row-major.
pub(crate) fn write_grid_rows(w: &mut dyn Write, g: &MapGrid, name: &str, values: &[f64]) -> std::io::Result<()> {
    writeln!(w, "x_mm,y_mm,{name}")?;
    for j in 0..g.ny {
        for i in 0..g.nx {
            write_csv_row(w, &[g.x(i), g.y(j), values[j * g.nx + i]])?;
        }
    }
    Ok(())
}

/// Gray level g in [0, 1] (black 0, white 1) to friction:
/// mu = mu_black + (mu_white - mu_black) g^gamma.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GrayMapping {
    pub mu_black: f64,
    pub mu_white: f64,
    pub gamma: f64,
}

impl GrayMapping {
    pub fn validate(&self, source_name: &str) -> Result<(), MapError> {
        for (name, v) in [("mu_black", self.mu_black), ("mu_white", self.mu_white)] {
            ranges::MU.check(v).map_err(|e| MapError::new(source_name, Some(name.into()), e.to_string()))?;
        }
        if self.mu_black == self.mu_white {
            return Err(MapError::new(source_name, Some("mu_white".into()), "must differ from mu_black"));
        }
        if !(self.gamma.is_finite() && (0.05..=20.0).contains(&self.gamma)) {
            return Err(MapError::new(
                source_name,
                Some("gamma".into()),
                format!("must be from 0.05 to 20, got {}", Num(self.gamma)),
            ));
        }
        Ok(())
    }

    /// Friction of gray level `g` in [0, 1].
    pub fn mu(&self, g: f64) -> f64 {
        let t = if self.gamma == 1.0 { g } else { g.powf(self.gamma) };
        self.mu_black + (self.mu_white - self.mu_black) * t
    }

    /// The gray level in [0, 1] of friction `mu` (clamped).
    pub fn gray(&self, mu: f64) -> f64 {
        let t = ((mu - self.mu_black) / (self.mu_white - self.mu_black)).clamp(0.0, 1.0);
        if self.gamma == 1.0 { t } else { t.powf(1.0 / self.gamma) }
    }
}

fn write_npy_f64(w: &mut dyn Write, rows: usize, cols: usize, values: &[f64]) -> std::io::Result<()> {
    use npyz::WriterBuilder;
    let mut writer =
        npyz::WriteOptions::<f64>::new().default_dtype().shape(&[rows as u64, cols as u64]).writer(w).begin_nd()?;
    for v in values {
        writer.push(v)?;
    }
    writer.finish()
}

/// Reads a (rows, cols) float32/float64 NPY array, C or Fortran order,
/// row-major out.
fn read_npy_2d(bytes: &[u8], source_name: &str, rows: usize, cols: usize) -> Result<Vec<f64>, MapError> {
    let (_, _, values) = crate::io::npy::read_2d(bytes, |shape| {
        (shape == [rows as u64, cols as u64])
            .then_some(())
            .ok_or_else(|| format!("array shape {shape:?}: the grid says ({rows}, {cols}) (ny, nx)"))
    })
    .map_err(|m| MapError::new(source_name, None, m))?;
    Ok(values)
}

/// Reads a map's grid sidecar (JSON with the [`MapGrid`] fields).
pub fn read_grid_json(reader: impl BufRead, source_name: &str) -> Result<MapGrid, MapError> {
    let grid: MapGrid = serde_json::from_reader(reader)
        .map_err(|e| MapError::new(source_name, Some(format!("line {}", e.line())), e.to_string()))?;
    grid.validate(source_name)?;
    Ok(grid)
}

/// The JSON sidecar of a map saved as NPY: the grid, what the values are
/// (and their unit), and the SHA-256 of the NPY file it belongs to, so
/// that an NPY and a sidecar from different runs are never paired.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NpySidecar {
    pub grid: MapGrid,
    /// `mu` (friction coefficient) or `voltage_v` (V RMS).
    pub quantity: String,
    /// U_max of a voltage map.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u_max_v: Option<f64>,
    pub npy_sha256: String,
    /// The device file a voltage map was designed with: what it is and
    /// its SHA-256 (`designed with device file ...; device file sha256 ...`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device_file: Option<String>,
}

/// The sidecar path of an NPY map: `MAP.npy` -> `MAP.npy.json`.
pub fn npy_sidecar_path(path: &std::path::Path) -> std::path::PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".json");
    std::path::PathBuf::from(name)
}

/// Writes `values` over `grid` as `path` (NPY, (ny, nx) float64) and its
/// sidecar. The old sidecar goes first and the new one last, both
/// atomically, so an interrupted write leaves no pair that agrees.
pub fn write_npy_pair(
    path: &std::path::Path,
    grid: &MapGrid,
    values: &[f64],
    quantity: &str,
    u_max_v: Option<f64>,
) -> Result<(), crate::io::WriteError> {
    write_npy_pair_designed(path, grid, values, quantity, u_max_v, None)
}

/// [`write_npy_pair`] for a voltage map designed with a device file: the
/// sidecar names it (`device_file`, the design's comment line).
pub fn write_npy_pair_designed(
    path: &std::path::Path,
    grid: &MapGrid,
    values: &[f64],
    quantity: &str,
    u_max_v: Option<f64>,
    device_file: Option<String>,
) -> Result<(), crate::io::WriteError> {
    let sidecar_path = npy_sidecar_path(path);
    match std::fs::remove_file(&sidecar_path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(crate::io::WriteError::new(&sidecar_path, e));
        }
        _ => {}
    }
    let mut bytes = Vec::new();
    write_npy_f64(&mut bytes, grid.ny, grid.nx, values).map_err(|e| crate::io::WriteError::new(path, e))?;
    crate::io::write_atomic(path, |w| w.write_all(&bytes))?;
    let sidecar = NpySidecar {
        grid: *grid,
        quantity: quantity.to_string(),
        u_max_v,
        npy_sha256: crate::io::sha256_hex(&bytes),
        device_file,
    };
    crate::io::write_atomic(&sidecar_path, |w| {
        serde_json::to_writer_pretty(&mut *w, &sidecar).map_err(std::io::Error::from)?;
        w.write_all(b"\n")
    })
}

/// Reads an NPY map and its sidecar, checking they belong together and
/// hold `quantity`; the NPY read is bounded by the size its grid needs.
pub fn read_npy_pair(path: &std::path::Path, quantity: &str) -> Result<(NpySidecar, Vec<f64>), MapError> {
    let name = path.display().to_string();
    let sidecar_path = npy_sidecar_path(path);
    let sidecar_name = sidecar_path.display().to_string();
    let read = |p: &std::path::Path, n: &str, limit: u64| -> Result<Vec<u8>, MapError> {
        crate::io::read_file_bounded(p, limit).map_err(|e| MapError::new(n, None, e.to_string()))
    };
    let sidecar_bytes = read(&sidecar_path, &sidecar_name, 1 << 16).map_err(|e| {
        MapError::new(&sidecar_name, None, format!("{} (an NPY map needs its JSON sidecar for the grid)", e.message))
    })?;
    let sidecar: NpySidecar = serde_json::from_slice(&sidecar_bytes)
        .map_err(|e| MapError::new(&sidecar_name, Some(format!("line {}", e.line())), e.to_string()))?;
    sidecar.grid.validate(&sidecar_name)?;
    if sidecar.quantity != quantity {
        return Err(MapError::new(
            &sidecar_name,
            Some("quantity".into()),
            format!("holds '{}', expected '{quantity}'", sidecar.quantity),
        ));
    }
    let bytes = read(path, &name, 128 + 8 * sidecar.grid.len() as u64)?;
    let hash = crate::io::sha256_hex(&bytes);
    if hash != sidecar.npy_sha256 {
        return Err(MapError::new(
            &sidecar_name,
            Some("npy_sha256".into()),
            format!("does not belong to {name} (its SHA-256 is {hash}): the two files are from different runs"),
        ));
    }
    let values = read_npy_2d(&bytes, &name, sidecar.grid.ny, sidecar.grid.nx)?;
    Ok((sidecar, values))
}

/// A sine grating at an angle to the sliding direction, as a friction map
/// for a finger sliding along +x (docs/maps.md).
///
/// The height is h(x, y) = A sin(2 pi (x cos theta + y sin theta) / lambda):
/// theta = 0 puts the ridges across the sliding direction (the 1-D sine
/// of the database), theta = 90 degrees along it. The FE finger is plane
/// strain in the sliding direction, so each line y = const is taken as the
/// 1-D surface it cuts: a sine of period P = lambda / cos theta with phase
/// shift y tan theta, whose friction is the steady periodic part of the
/// friction profile of that sine (from the FE model, or the CAE where the
/// database has the period). At theta = 90 degrees the height along each
/// line is constant and the friction is the flat-surface friction. This
/// is the plane-strain assumption: the map depends on the direction of
/// sliding, and a real finger (finite width, ridges at an angle under it)
/// is not resolved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grating {
    pub period_mm: f64,
    pub amplitude_mm: f64,
    /// Angle between the grating's wave vector and the sliding direction x.
    pub angle_deg: f64,
    pub velocity_mm_s: f64,
}

impl Grating {
    /// The period of the sine a line along x cuts: lambda / |cos theta|
    /// (infinite at 90 degrees).
    pub fn line_period_mm(&self) -> f64 {
        let c = self.angle_deg.to_radians().cos().abs();
        if c < 1e-12 { f64::INFINITY } else { self.period_mm / c }
    }

    /// Checks the grating's numbers.
    pub fn validate(&self) -> Result<(), MapError> {
        let err = |field: &str, m: String| MapError::new("grating", Some(field.to_string()), m);
        for (name, v) in
            [("period_mm", self.period_mm), ("amplitude_mm", self.amplitude_mm), ("velocity_mm_s", self.velocity_mm_s)]
        {
            if !(v.is_finite() && v > 0.0) {
                return Err(err(name, format!("must be a positive number, got {}", Num(v))));
            }
        }
        if !(self.angle_deg.is_finite() && (-90.0..=90.0).contains(&self.angle_deg)) {
            return Err(err("angle_deg", format!("must be from -90 to 90 degrees, got {}", Num(self.angle_deg))));
        }
        Ok(())
    }

    /// The friction map on `grid` from the friction of one line: `line`,
    /// the friction profile (FE or CAE) of the 1-D sine
    /// h = A sin(2 pi (x - `line_x0`) / P) with P = [`Self::line_period_mm`]
    /// (unused where the period is infinite: the map is `flat_mu`). The
    /// line's steady periodic part is used: its least-squares Fourier
    /// series of period P after the first mm of slide; the RMS of the rest
    /// is returned with the map.
    pub fn friction_map(
        &self,
        line: Option<(&[f64], &[f64], f64)>,
        flat_mu: f64,
        grid: MapGrid,
    ) -> Result<(FrictionMap, Option<f64>), MapError> {
        self.validate()?;
        grid.validate("grating")?;
        let p = self.line_period_mm();
        let Some((x, mu, x0)) = line.filter(|_| p.is_finite()) else {
            return Ok((FrictionMap::new(grid, vec![flat_mu; grid.len()], "grating")?, None));
        };
        let shifted: Vec<f64> = x.iter().map(|v| v - x0).collect();
        let series = PeriodicFit::fit(&shifted, mu, p, 1.0).ok_or_else(|| {
            MapError::new(
                "grating",
                Some("period_mm".into()),
                format!("the line's profile is shorter than 1 mm plus one period of {p:.4} mm"),
            )
        })?;
        let shift = self.angle_deg.to_radians().tan();
        let mut out = vec![0.0; grid.len()];
        for j in 0..grid.ny {
            let offset = grid.y(j) * shift;
            for i in 0..grid.nx {
                out[j * grid.nx + i] = series.eval(grid.x(i) + offset);
            }
        }
        Ok((FrictionMap::new(grid, out, "grating")?, Some(series.rms)))
    }
}

/// The least-squares Fourier series of period P (mean and the first K
/// harmonics) through a profile's steady part: the friction of a periodic
/// surface once the start of the slide is over. A CAE estimate between
/// the database's periods blends neighbouring periods and is not exactly
/// P-periodic; this is its P-periodic part.
struct PeriodicFit {
    period: f64,
    /// a0, then (a_k, b_k) for k = 1..K.
    coefficients: Vec<f64>,
    /// RMS of the profile minus the series over the fitted samples.
    rms: f64,
}

impl PeriodicFit {
    /// Fits over the samples with x >= x_first + `skip_mm` (the start of
    /// the slide left out), K = min(10, samples per period / 2 - 1). None
    /// when fewer than one period or 5 samples per period remain.
    fn fit(x: &[f64], mu: &[f64], period: f64, skip_mm: f64) -> Option<Self> {
        let from = x.partition_point(|&v| v < x[0] + skip_mm);
        let (xs, ys) = (&x[from..], &mu[from..]);
        if xs.len() < 2 || xs[xs.len() - 1] - xs[0] < period {
            return None;
        }
        let per_period = period / ((xs[xs.len() - 1] - xs[0]) / (xs.len() - 1) as f64);
        if per_period < 5.0 {
            return None;
        }
        let k = 10usize.min((per_period / 2.0) as usize - 1).max(1);
        let m = 2 * k + 1;
        let basis = |xv: f64, out: &mut [f64]| {
            let w = 2.0 * std::f64::consts::PI * xv / period;
            out[0] = 1.0;
            for h in 1..=k {
                let (sn, cs) = (h as f64 * w).sin_cos();
                out[2 * h - 1] = cs;
                out[2 * h] = sn;
            }
        };
        // Normal equations, solved by Cholesky (the basis is nearly
        // orthogonal over whole periods: well conditioned).
        let mut a = vec![0.0; m * m];
        let mut rhs = vec![0.0; m];
        let mut phi = vec![0.0; m];
        for (&xv, &yv) in xs.iter().zip(ys) {
            basis(xv, &mut phi);
            for r in 0..m {
                rhs[r] += phi[r] * yv;
                for c in 0..=r {
                    a[r * m + c] += phi[r] * phi[c];
                }
            }
        }
        for r in 0..m {
            for c in 0..=r {
                let mut sum = a[r * m + c];
                for q in 0..c {
                    sum -= a[r * m + q] * a[c * m + q];
                }
                if r == c {
                    if sum <= 0.0 {
                        return None;
                    }
                    a[r * m + r] = sum.sqrt();
                } else {
                    a[r * m + c] = sum / a[c * m + c];
                }
            }
        }
        let mut z = rhs;
        for r in 0..m {
            let s: f64 = (0..r).map(|q| a[r * m + q] * z[q]).sum();
            z[r] = (z[r] - s) / a[r * m + r];
        }
        for r in (0..m).rev() {
            let s: f64 = (r + 1..m).map(|q| a[q * m + r] * z[q]).sum();
            z[r] = (z[r] - s) / a[r * m + r];
        }
        let mut fit = Self { period, coefficients: z, rms: 0.0 };
        let sq: f64 = xs.iter().zip(ys).map(|(&xv, &yv)| (fit.eval(xv) - yv).powi(2)).sum();
        fit.rms = (sq / xs.len() as f64).sqrt();
        Some(fit)
    }

    fn eval(&self, x: f64) -> f64 {
        let w = 2.0 * std::f64::consts::PI * x / self.period;
        let c = &self.coefficients;
        let mut v = c[0];
        for h in 1..=(c.len() - 1) / 2 {
            let (sn, cs) = (h as f64 * w).sin_cos();
            v += c[2 * h - 1] * cs + c[2 * h] * sn;
        }
        v
    }
}

/// What fills a region of a composed map.
#[derive(Debug, Clone, PartialEq)]
pub enum RegionFill {
    /// One friction coefficient.
    Constant(f64),
    /// A line texture (a library material's or any friction profile)
    /// along x, tiled with the profile's span as its period (x -> x0 +
    /// (x - x0) mod span) and the same on every row.
    Texture(crate::profile::FrictionProfile),
}

impl RegionFill {
    fn mu_at(&self, x_mm: f64) -> f64 {
        match self {
            RegionFill::Constant(mu) => *mu,
            RegionFill::Texture(p) => {
                let x = p.x_mm();
                let (x0, span) = (x[0], x[x.len() - 1] - x[0]);
                p.mu_at(x0 + (x_mm - x0).rem_euclid(span))
            }
        }
    }
}

/// The width and height (pixels) a PNG's header claims, read from its
/// first chunk (IHDR) without decoding anything else: what a caller with a
/// tighter bound than [`MAX_CELLS`] checks before
/// [`FrictionMap::read_gray_png`] sizes any buffer by them.
pub fn png_size(bytes: &[u8], source_name: &str) -> Result<(usize, usize), MapError> {
    png_header(bytes, source_name).map(|h| (h.width, h.height))
}

/// What a PNG's header (IHDR) claims: size and bits per sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PngHeader {
    pub width: usize,
    pub height: usize,
    /// Bits per sample (1, 2, 4, 8 or 16 in a valid PNG).
    pub bit_depth: u8,
}

impl PngHeader {
    /// The memory of a map read from this image, in bytes: the decoded
    /// image (its rows, up to 2 bytes per gray pixel) and the map's values
    /// (8 bytes a cell), what [`FrictionMap::read_gray_png`] holds at once
    /// (besides the file's own bytes). A caller checks it against its
    /// memory budget before decoding.
    pub fn map_memory_bytes(&self) -> u64 {
        let pixels = (self.width as u64).saturating_mul(self.height as u64);
        pixels.saturating_mul(u64::from(self.bit_depth.div_ceil(8).max(1)) + 8)
    }
}

/// The header of a PNG, read from its first chunk (IHDR) without decoding
/// anything else (see [`png_size`]).
pub fn png_header(bytes: &[u8], source_name: &str) -> Result<PngHeader, MapError> {
    const SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
    if bytes.len() < 25 || &bytes[..8] != SIGNATURE || &bytes[12..16] != b"IHDR" {
        return Err(MapError::new(
            source_name,
            None,
            "not a readable PNG: no PNG signature and header (IHDR) at its start",
        ));
    }
    let be = |k: usize| u32::from_be_bytes([bytes[k], bytes[k + 1], bytes[k + 2], bytes[k + 3]]) as usize;
    Ok(PngHeader { width: be(16), height: be(20), bit_depth: bytes[24] })
}

/// What the PNG decoder may allocate for itself (its line buffers and
/// the chunks it keeps, such as text): 4 lines of the image at 2 bytes a
/// pixel and 8 MiB. Its output, the image, is allocated by the caller,
/// which checks its size first. Set before decoding starts, so that a
/// small file claiming a huge image, or a huge text chunk, is refused
/// rather than allocated.
fn decoder_limits(bytes: &[u8]) -> png::Limits {
    let width = png_size(bytes, "").map_or(0, |(w, _)| w);
    png::Limits { bytes: width.saturating_mul(8).saturating_add(8 << 20) }
}

/// Decodes an 8- or 16-bit grayscale PNG into a grid of `value(g)` per
/// pixel, g the gray level in [0, 1] (black 0, white 1): one cell per
/// pixel, the image's top row at the largest y; nx and ny are the image's
/// width and height. An 8-bit image's 256 values are computed once.
pub(crate) fn read_gray_grid(
    bytes: &[u8],
    spacing_mm: (f64, f64),
    origin_mm: (f64, f64),
    source_name: &str,
    value: impl Fn(f64) -> f64,
) -> Result<(MapGrid, Vec<f64>), MapError> {
    let GrayImage { width, height, bits, buffer, stride } =
        GrayImage::decode(bytes, source_name, |color, depth| match (color, depth) {
            (png::ColorType::Grayscale, png::BitDepth::Eight) => Ok(8),
            (png::ColorType::Grayscale, png::BitDepth::Sixteen) => Ok(16),
            (png::ColorType::Grayscale, other) => Err(format!("bit depth {other:?}: expected 8 or 16 bit grayscale")),
            (color, _) => {
                let what = match color {
                    png::ColorType::Rgb => "an RGB colour image",
                    png::ColorType::Rgba => "an RGB colour image with transparency",
                    png::ColorType::Indexed => "a palette (indexed colour) image",
                    png::ColorType::GrayscaleAlpha => "a grayscale image with transparency",
                    png::ColorType::Grayscale => "a grayscale image",
                };
                Err(format!("{what}: the image must be plain grayscale (8 or 16 bit), convert it first"))
            }
        })?;
    let grid = MapGrid {
        nx: width,
        ny: height,
        x0_mm: origin_mm.0,
        y0_mm: origin_mm.1,
        dx_mm: spacing_mm.0,
        dy_mm: spacing_mm.1,
    };
    grid.validate(source_name)?;
    let values = gray_values(width, height, bits, value, |r, out, level| {
        let line = &buffer[r * stride..r * stride + stride];
        if bits == 8 {
            for (o, &g) in out.iter_mut().zip(line) {
                *o = level(g as u16);
            }
        } else {
            for (o, g) in out.iter_mut().zip(line.chunks_exact(2)) {
                *o = level(u16::from_be_bytes([g[0], g[1]]));
            }
        }
    });
    Ok((grid, values))
}

/// The values of a `width` x `height` gray image of `bits` (8 or 16) bits,
/// `value(g)` per pixel with g = level / full level in [0, 1] (an 8-bit
/// image's 256 values computed once), the image's top row (r = 0) at the
/// largest y. `row(r, out, level)` fills `out` with `level(l)` of row r's
/// pixels, left to right.
fn gray_values(
    width: usize,
    height: usize,
    bits: u8,
    value: impl Fn(f64) -> f64,
    row: impl Fn(usize, &mut [f64], &dyn Fn(u16) -> f64),
) -> Vec<f64> {
    let full = if bits == 8 { 255.0 } else { 65535.0 };
    let table: Vec<f64> = if bits == 8 { (0..256).map(|g| value(g as f64 / full)).collect() } else { Vec::new() };
    let level = |l: u16| if bits == 8 { table[l as usize] } else { value(l as f64 / full) };
    let mut values = vec![0.0; width * height];
    for r in 0..height {
        let j = height - 1 - r;
        row(r, &mut values[j * width..(j + 1) * width], &level);
    }
    values
}

/// Gray levels of an image held in memory, row by row from the top row,
/// as a decoded 8- or 16-bit grayscale PNG holds them.
#[derive(Debug, Clone, Copy)]
pub enum GrayLevels<'a> {
    Eight(&'a [u8]),
    Sixteen(&'a [u16]),
}

impl FrictionMap {
    /// [`FrictionMap::read_gray_png`] of an image already decoded: `width`
    /// x `height` gray levels, row 0 the top (at the largest y), with the
    /// same gray-to-friction arithmetic, so that the map is the one the PNG
    /// of these levels gives, bit for bit.
    pub fn from_gray_levels(
        levels: GrayLevels<'_>,
        width: usize,
        height: usize,
        mapping: &GrayMapping,
        spacing_mm: (f64, f64),
        origin_mm: (f64, f64),
        source_name: &str,
    ) -> Result<Self, MapError> {
        mapping.validate(source_name)?;
        let n = match levels {
            GrayLevels::Eight(l) => l.len(),
            GrayLevels::Sixteen(l) => l.len(),
        };
        if width.checked_mul(height) != Some(n) {
            return Err(MapError::new(source_name, None, format!("{n} gray levels for {width} x {height} pixels")));
        }
        let grid = MapGrid {
            nx: width,
            ny: height,
            x0_mm: origin_mm.0,
            y0_mm: origin_mm.1,
            dx_mm: spacing_mm.0,
            dy_mm: spacing_mm.1,
        };
        grid.validate(source_name)?;
        let bits = if matches!(levels, GrayLevels::Eight(_)) { 8 } else { 16 };
        let mu = gray_values(
            width,
            height,
            bits,
            |g| mapping.mu(g),
            |r, out, level| match levels {
                GrayLevels::Eight(l) => {
                    for (o, &g) in out.iter_mut().zip(&l[r * width..(r + 1) * width]) {
                        *o = level(g as u16);
                    }
                }
                GrayLevels::Sixteen(l) => {
                    for (o, &g) in out.iter_mut().zip(&l[r * width..(r + 1) * width]) {
                        *o = level(g);
                    }
                }
            },
        );
        Self::new(grid, mu, source_name)
    }
}

/// A decoded grayscale PNG: its rows from the top, `stride` bytes apart.
struct GrayImage {
    width: usize,
    height: usize,
    bits: u8,
    buffer: Vec<u8>,
    stride: usize,
}

impl GrayImage {
    /// Decodes a PNG whose colour type and depth `accept` takes (giving
    /// the bits per pixel, or the refusal); the size the header claims is
    /// checked (2 x 2 to [`MAX_CELLS`] pixels) before any buffer is sized.
    fn decode(
        bytes: &[u8],
        source_name: &str,
        accept: impl FnOnce(png::ColorType, png::BitDepth) -> Result<u8, String>,
    ) -> Result<Self, MapError> {
        let err = |m: String| MapError::new(source_name, None, m);
        let mut decoder = png::Decoder::new_with_limits(std::io::Cursor::new(bytes), decoder_limits(bytes));
        decoder.set_transformations(png::Transformations::IDENTITY);
        let mut reader = decoder.read_info().map_err(|e| err(format!("not a readable PNG: {e}")))?;
        let info = reader.info();
        let (width, height) = (info.width as usize, info.height as usize);
        let bits = accept(info.color_type, info.bit_depth).map_err(err)?;
        if width.checked_mul(height).is_none_or(|n| n > MAX_CELLS) || width < 2 || height < 2 {
            return Err(err(format!("{width} x {height} pixels: from 2 x 2 to at most {MAX_CELLS} pixels")));
        }
        let size = reader.output_buffer_size().ok_or_else(|| err("image too large".into()))?;
        let mut buffer = vec![0u8; size];
        let frame = reader.next_frame(&mut buffer).map_err(|e| err(format!("cannot decode the image: {e}")))?;
        Ok(Self { width, height, bits, buffer, stride: frame.line_size })
    }
}

/// An 8-bit grayscale label image: each gray level names a region.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelImage {
    pub width: usize,
    pub height: usize,
    /// Row by row from the top row, as the image stores them.
    pub labels: Vec<u8>,
}

impl LabelImage {
    /// Reads an 8-bit grayscale PNG (at most [`MAX_CELLS`] pixels).
    pub fn read_png(bytes: &[u8], source_name: &str) -> Result<Self, MapError> {
        let GrayImage { width, height, buffer, stride, .. } =
            GrayImage::decode(bytes, source_name, |color, depth| match (color, depth) {
                (png::ColorType::Grayscale, png::BitDepth::Eight) => Ok(8),
                (color, depth) => {
                    Err(format!("{color:?} at {depth:?}: a label image is 8-bit grayscale, one gray level per region"))
                }
            })?;
        let labels = (0..height).flat_map(|r| buffer[r * stride..r * stride + width].iter().copied()).collect();
        Ok(Self { width, height, labels })
    }

    /// The map of a label image: one cell per pixel (the top row at the
    /// largest y), each cell filled by its label's region; every label
    /// present must have one (the error names the label and its first
    /// pixel, column and row from the top left).
    pub fn compose(
        &self,
        fill: &dyn Fn(u8) -> Option<RegionFill>,
        spacing_mm: (f64, f64),
        origin_mm: (f64, f64),
        source_name: &str,
    ) -> Result<FrictionMap, MapError> {
        let grid = MapGrid {
            nx: self.width,
            ny: self.height,
            x0_mm: origin_mm.0,
            y0_mm: origin_mm.1,
            dx_mm: spacing_mm.0,
            dy_mm: spacing_mm.1,
        };
        grid.validate(source_name)?;
        let mut fills: Vec<Option<RegionFill>> = vec![None; 256];
        let mut seen = [false; 256];
        for (k, &label) in self.labels.iter().enumerate() {
            if !seen[label as usize] {
                seen[label as usize] = true;
                fills[label as usize] = Some(fill(label).ok_or_else(|| {
                    MapError::new(
                        source_name,
                        Some(format!("pixel column {}, row {}", k % self.width, k / self.width)),
                        format!("gray level {label} has no region: give one for it"),
                    )
                })?);
            }
        }
        let mut mu = vec![0.0; grid.len()];
        for r in 0..self.height {
            let j = self.height - 1 - r;
            for i in 0..self.width {
                let region =
                    fills[self.labels[r * self.width + i] as usize].as_ref().expect("every label seen has a fill");
                mu[j * grid.nx + i] = region.mu_at(grid.x(i));
            }
        }
        FrictionMap::new(grid, mu, source_name)
    }

    /// The distinct labels present, ascending.
    pub fn levels(&self) -> Vec<u8> {
        let mut seen = [false; 256];
        for &l in &self.labels {
            seen[l as usize] = true;
        }
        (0..=255u8).filter(|&l| seen[l as usize]).collect()
    }
}

/// The drive of an ultrasonic or combined display over a map's grid: the
/// voltage (None for the ultrasonic display alone) and the plate's
/// amplitude per cell, as [`crate::combined::map_display`] designs them
/// along a profile (the same allocator, the bias level from the map's
/// lowest friction).
#[derive(Debug, Clone, PartialEq)]
pub struct DisplayMap {
    pub grid: MapGrid,
    pub voltage_v: Option<Vec<f64>>,
    pub amplitude_um: Vec<f64>,
    /// The renderable band [mu_HD rho_min, mu_HD (1 + Fe/Fn at U_max)].
    pub band_mu: [f64; 2],
    /// Fractions of the cells below and above the band (saturated).
    pub below_fraction: f64,
    pub above_fraction: f64,
    pub u_max_v: f64,
    pub a_max_um: f64,
}

impl FrictionMap {
    /// Designs an ultrasonic (`channels` = Ultrasonic) or combined display
    /// cell by cell; every value is checked against its channel's limit.
    pub fn display_channels(
        &self,
        device: &Device,
        channels: crate::combined::Channels<'_>,
    ) -> Result<DisplayMap, MapError> {
        use crate::combined::{Allocator, Channels, Strategy, bias_level};
        let device_error = |m: String| MapError::new("device", None, m);
        device.validate().map_err(|e| device_error(e.to_string()))?;
        if !device.contact.is_linear() {
            return Err(device_error(
                "a friction map is mapped with the linear contact-area law (area exponent 1)".into(),
            ));
        }
        let (ultrasonic, strategy, electro) = match channels {
            Channels::Electrovibration => {
                return Err(device_error("the electrovibration display alone is FrictionMap::voltages".into()));
            }
            Channels::Ultrasonic(d) => (d, Strategy::Split, false),
            Channels::Combined(d, s) => (d, s, true),
        };
        if let Strategy::Weighted { weight } = strategy {
            ranges::STRATEGY_WEIGHT.check(weight).map_err(|e| device_error(e.to_string()))?;
        }
        let (mu_min, _) = self.mu.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &m| (a.min(m), b.max(m)));
        let rho_bias = bias_level(mu_min, device.mu_hd, ultrasonic.rho_min());
        let ratio = device.force_ratio_per_v2(1.0);
        let allocator = Allocator::new(
            device.mu_hd,
            electro.then_some((ratio, device.u_max_v)),
            Some(ultrasonic),
            strategy,
            rho_bias,
        );
        let band_mu = allocator.band();
        let n = self.mu.len();
        let below = self.mu.iter().filter(|&&m| m < band_mu[0]).count();
        let above = self.mu.iter().filter(|&&m| m > band_mu[1]).count();
        let (u_max, a_max) = (if electro { device.u_max_v } else { 0.0 }, ultrasonic.a_max_um());
        let (voltage_v, amplitude_um) = allocator.allocate_all(&self.mu, u_max, a_max).map_err(|v| {
            MapError::new(
                "display design",
                Some(format!(
                    "cell x = {} mm, y = {} mm",
                    Num(self.grid.x(v.index % self.grid.nx)),
                    Num(self.grid.y(v.index / self.grid.nx))
                )),
                format!(
                    "{} = {} outside 0 .. {}",
                    match v.channel {
                        crate::combined::Channel::Voltage => "voltage_v",
                        crate::combined::Channel::Amplitude => "amplitude_um",
                    },
                    Num(v.value),
                    Num(v.limit)
                ),
            )
        })?;
        Ok(DisplayMap {
            grid: self.grid,
            voltage_v: electro.then_some(voltage_v),
            amplitude_um,
            band_mu,
            below_fraction: below as f64 / n as f64,
            above_fraction: above as f64 / n as f64,
            u_max_v: u_max,
            a_max_um: a_max,
        })
    }
}

impl DisplayMap {
    /// Writes `x_mm,y_mm[,voltage_v],amplitude_um`, row-major, after a
    /// comment stating each channel's limit.
    pub fn write_csv(&self, w: &mut dyn Write) -> std::io::Result<()> {
        let g = &self.grid;
        writeln!(
            w,
            "# haptex display map: {} x {} cells; band mu {:.6} .. {:.6}; {:.2}% of the area below it (plate at \
             a_max), {:.2}% above it (clipped)",
            g.nx,
            g.ny,
            self.band_mu[0],
            self.band_mu[1],
            100.0 * self.below_fraction,
            100.0 * self.above_fraction
        )?;
        match &self.voltage_v {
            Some(_) => writeln!(
                w,
                "# voltage_v is RMS, at most U_max = {} V; amplitude_um is the plate's amplitude, peak, at most a_max = {} um",
                crate::num::Exact(self.u_max_v),
                crate::num::Exact(self.a_max_um)
            )?,
            // The stated a_max is read back by `haptex play`: in full.
            None => writeln!(
                w,
                "# amplitude_um is the plate's amplitude, peak, at most a_max = {} um",
                crate::num::Exact(self.a_max_um)
            )?,
        }
        writeln!(
            w,
            "{}",
            if self.voltage_v.is_some() { "x_mm,y_mm,voltage_v,amplitude_um" } else { "x_mm,y_mm,amplitude_um" }
        )?;
        for j in 0..g.ny {
            for i in 0..g.nx {
                let k = j * g.nx + i;
                match &self.voltage_v {
                    Some(u) => write_csv_row(w, &[g.x(i), g.y(j), u[k], self.amplitude_um[k]])?,
                    None => write_csv_row(w, &[g.x(i), g.y(j), self.amplitude_um[k]])?,
                }
            }
        }
        Ok(())
    }
}

/// Most vertices of a polygon region.
pub const MAX_POLYGON_VERTICES: usize = 10_000;

impl FrictionMap {
    /// Fills the cells inside a polygon (vertices in mm, closed implicitly;
    /// even-odd rule at the cell positions) with `fill`, row by row: the
    /// edges crossing each row are found and the spans between pairs of
    /// crossings filled, O(rows x vertices + cells).
    pub fn fill_polygon(
        &mut self,
        vertices: &[(f64, f64)],
        fill: &RegionFill,
        source_name: &str,
    ) -> Result<usize, MapError> {
        let err = |m: String| MapError::new(source_name, None, m);
        if vertices.len() < 3 || vertices.len() > MAX_POLYGON_VERTICES {
            return Err(err(format!("{} vertices: a polygon has 3 to {MAX_POLYGON_VERTICES}", vertices.len())));
        }
        if let Some(k) =
            vertices.iter().position(|(x, y)| !(ranges::POSITION_MM.contains(*x) && ranges::POSITION_MM.contains(*y)))
        {
            return Err(err(format!(
                "vertex {} ({}, {}): positions must be {}",
                k + 1,
                Num(vertices[k].0),
                Num(vertices[k].1),
                ranges::POSITION_MM.describe()
            )));
        }
        let g = self.grid;
        let mut crossings = Vec::with_capacity(vertices.len());
        let mut filled = 0usize;
        for j in 0..g.ny {
            let y = g.y(j);
            crossings.clear();
            for e in 0..vertices.len() {
                let (xa, ya) = vertices[e];
                let (xb, yb) = vertices[(e + 1) % vertices.len()];
                if (ya <= y && y < yb) || (yb <= y && y < ya) {
                    crossings.push(xa + (y - ya) / (yb - ya) * (xb - xa));
                }
            }
            crossings.sort_by(f64::total_cmp);
            for pair in crossings.chunks_exact(2) {
                // Columns with x in [pair[0], pair[1]).
                let first = ((pair[0] - g.x0_mm) / g.dx_mm).ceil().max(0.0);
                let last = ((pair[1] - g.x0_mm) / g.dx_mm).ceil().min(g.nx as f64);
                if first >= last {
                    continue;
                }
                for i in first as usize..last as usize {
                    self.mu[j * g.nx + i] = fill.mu_at(g.x(i));
                    filled += 1;
                }
            }
        }
        if let Some(k) = ranges::MU.first_outside(&self.mu) {
            return Err(err(ranges::MU.refusal(self.mu[k]).to_string()));
        }
        Ok(filled)
    }
}

/// The format of a map file, from its extension: `.csv` (long format) or
/// `.npy` (with its `.npy.json` sidecar).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MapFormat {
    Csv,
    Npy,
}

impl MapFormat {
    /// The format of `path` (refused unless .csv or .npy).
    pub fn of(path: &std::path::Path) -> Result<Self, MapError> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("csv") => Ok(MapFormat::Csv),
            Some("npy") => Ok(MapFormat::Npy),
            _ => Err(MapError::new(
                &path.display().to_string(),
                None,
                "a map file is .csv or .npy (with its .npy.json sidecar)",
            )),
        }
    }
}

/// A map file that cannot be opened, or whose content is refused.
#[derive(Debug, thiserror::Error)]
pub enum MapFileError {
    #[error("cannot open {name}")]
    Open {
        name: String,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Map(#[from] MapError),
}

/// Reads a map CSV `x_mm,y_mm,QUANTITY` from a file (see [`read_grid_csv`]).
pub fn read_map_csv_file(
    path: &std::path::Path,
    quantity: &ranges::Range,
) -> Result<(MapGrid, Vec<f64>), MapFileError> {
    let name = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|source| MapFileError::Open { name: name.clone(), source })?;
    Ok(read_grid_csv(std::io::BufReader::new(file), &name, quantity)?)
}

impl FrictionMap {
    /// Reads a friction map file, CSV or NPY by its extension.
    pub fn read_file(path: &std::path::Path) -> Result<Self, MapFileError> {
        let name = path.display().to_string();
        Ok(match MapFormat::of(path)? {
            MapFormat::Csv => {
                let (grid, mu) = read_map_csv_file(path, &ranges::MU)?;
                FrictionMap::new(grid, mu, &name)?
            }
            MapFormat::Npy => {
                let (sidecar, mu) = read_npy_pair(path, "mu")?;
                FrictionMap::new(sidecar.grid, mu, &name)?
            }
        })
    }

    /// Writes the map as `format` (CSV atomically; NPY with its sidecar).
    pub fn write_file(&self, path: &std::path::Path, format: MapFormat) -> Result<(), crate::io::WriteError> {
        match format {
            MapFormat::Csv => crate::io::write_atomic(path, |w| self.write_csv(w)),
            MapFormat::Npy => write_npy_pair(path, &self.grid, &self.mu, "mu", None),
        }
    }

    /// `haptex map from-profile`: every row the profile sampled at
    /// x0 + i dx over the profile's span (x0 its first x; floor(span / dx)
    /// + 1 columns), `ny` rows from `y0_mm` at `dy_mm`.
    pub fn from_profile(
        profile: &crate::profile::FrictionProfile,
        dx_mm: f64,
        dy_mm: f64,
        ny: usize,
        y0_mm: f64,
    ) -> Result<Self, FromProfileError> {
        let (x0, x1) = (profile.x_mm()[0], profile.x_mm()[profile.len() - 1]);
        let columns = ((x1 - x0) / dx_mm).floor() + 1.0;
        if columns > MAX_CELLS as f64 {
            return Err(FromProfileError::TooManyColumns { columns, span_mm: x1 - x0 });
        }
        let grid = MapGrid { nx: columns as usize, ny, x0_mm: x0, y0_mm, dx_mm, dy_mm };
        Ok(Self::extrude(profile, grid)?)
    }

    /// The line `haptex map` prints about a friction map it made.
    pub fn summary_line(&self) -> String {
        let g = &self.grid;
        let (lo, hi) = min_max(&self.mu);
        format!(
            "friction map: {} x {} cells, x {} .. {} mm, y {} .. {} mm, mu {:.4} .. {:.4}",
            g.nx,
            g.ny,
            Num(g.x0_mm),
            Num(g.x(g.nx - 1)),
            Num(g.y0_mm),
            Num(g.y(g.ny - 1)),
            lo,
            hi
        )
    }
}

/// Why [`FrictionMap::from_profile`] refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FromProfileError {
    /// The spacing gives more than [`MAX_CELLS`] columns over the span.
    #[error("{columns} columns over the profile's {span_mm} mm: too many")]
    TooManyColumns { columns: f64, span_mm: f64 },
    #[error(transparent)]
    Map(#[from] MapError),
}

impl VoltageMap {
    /// Reads a voltage map file, CSV or NPY by its extension. U_max is the
    /// NPY sidecar's (NaN for a CSV); the area fractions are NaN.
    pub fn read_file(path: &std::path::Path) -> Result<Self, MapFileError> {
        let (grid, voltage_v, u_max_v) = match MapFormat::of(path)? {
            MapFormat::Csv => {
                let (grid, v) = read_map_csv_file(path, &ranges::VOLTAGE_V)?;
                (grid, v, f64::NAN)
            }
            MapFormat::Npy => {
                let (sidecar, v) = read_npy_pair(path, "voltage_v")?;
                (sidecar.grid, v, sidecar.u_max_v.unwrap_or(f64::NAN))
            }
        };
        Ok(VoltageMap { grid, voltage_v, u_max_v, not_renderable_fraction: f64::NAN, clipped_fraction: f64::NAN })
    }

    /// The lines `haptex map voltage` prints about a map made with
    /// `method`.
    pub fn summary_lines(&self, method: Method) -> Vec<String> {
        let (lo, hi) = min_max(&self.voltage_v);
        let mut lines = vec![
            format!("method: {method}"),
            format!(
                "voltage map: {} x {} cells, {:.3} .. {:.3} V RMS, U_max = {} V",
                self.grid.nx,
                self.grid.ny,
                lo,
                hi,
                Num(self.u_max_v)
            ),
        ];
        if method == Method::Physical {
            lines.push(format!(
                "area below mu_HD (not renderable, 0 V): {:.2}%; clipped at U_max: {:.2}%",
                100.0 * self.not_renderable_fraction,
                100.0 * self.clipped_fraction
            ));
        }
        lines
    }
}

impl DisplayMap {
    /// The line `haptex map voltage --display ultrasonic|combined` prints.
    pub fn summary_line(&self) -> String {
        format!(
            "display map: {} x {} cells; band mu {:.4} .. {:.4}; below it (plate at a_max = {} um): {:.2}% of the \
             area, above it (clipped): {:.2}%",
            self.grid.nx,
            self.grid.ny,
            self.band_mu[0],
            self.band_mu[1],
            Num(self.a_max_um),
            100.0 * self.below_fraction,
            100.0 * self.above_fraction
        )
    }
}

/// The lowest and highest of `v` (inf, -inf when empty).
pub fn min_max(v: &[f64]) -> (f64, f64) {
    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)))
}
