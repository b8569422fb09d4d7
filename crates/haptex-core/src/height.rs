//! Height maps h(x, y) and the lines a sliding finger feels on them
//! (issue 19).
//!
//! The FE finger model is two-dimensional: plane strain in the plane of
//! the sliding direction and the surface normal. A height map is
//! therefore cut into straight lines along the sliding direction (angle
//! theta from +x), each a 1-D height profile the FE model slides over;
//! the friction of the lines is put back on the map's grid. The friction
//! map depends on the direction: a ridge met across is a bump, met at an
//! angle a wider bump, met along its length no bump at all.
//!
//! The lines are a grid in the rotated frame (s along the sliding
//! direction, r across it) covering the map: spacing dx |cos| + dy |sin|
//! along s and dy |cos| + dx |sin| across, so that at 0 degrees the lines
//! are the map's rows and at 90 its columns, exactly. Beyond the map a
//! line is flat (at the height where it enters, and where it leaves). A
//! cell's friction is the bilinear interpolation of the lines' friction at
//! its (s, r).
//!
//! ```
//! use haptex_core::height::{HeightMap, SlidingLines};
//! use haptex_core::map::MapGrid;
//!
//! let grid = MapGrid { nx: 5, ny: 3, x0_mm: 0.0, y0_mm: 0.0, dx_mm: 0.5, dy_mm: 1.0 };
//! let h = HeightMap::new(grid, vec![0.0; 15], "flat")?;
//! let lines = SlidingLines::new(&grid, 0.0)?;
//! assert_eq!((lines.grid.nx, lines.grid.ny), (5, 3)); // the rows
//! let (s, heights) = lines.line(&h, 1);
//! assert_eq!((s.len(), heights[0]), (5, 0.0));
//! # Ok::<(), haptex_core::map::MapError>(())
//! ```

use std::io::Write;

use crate::map::{FrictionMap, MapError, MapGrid};
use crate::num::Num;
use crate::ranges;

/// Most vertices of a path a template is laid along (each cell's
/// distance visits every segment).
pub const MAX_PATH_VERTICES: usize = 10_000;

/// Surface height over a regular (x, y) grid, mm.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightMap {
    pub grid: MapGrid,
    /// h per cell, row by row (index j nx + i), mm.
    pub h_mm: Vec<f64>,
}

impl HeightMap {
    /// Checks the grid, the count and every height (finite, within
    /// [`ranges::HEIGHT_MM`]); errors name the cell.
    pub fn new(grid: MapGrid, h_mm: Vec<f64>, source_name: &str) -> Result<Self, MapError> {
        grid.validate(source_name)?;
        if h_mm.len() != grid.len() {
            return Err(MapError::new(
                source_name,
                None,
                format!("{} heights for a {} x {} grid", h_mm.len(), grid.nx, grid.ny),
            ));
        }
        if let Some(k) = ranges::HEIGHT_MM.first_outside(&h_mm) {
            return Err(MapError::new(
                source_name,
                Some(format!("cell (column {}, row {})", k % grid.nx, k / grid.nx)),
                format!("h_mm = {} is outside {}", Num(h_mm[k]), ranges::HEIGHT_MM.describe()),
            ));
        }
        Ok(Self { grid, h_mm })
    }

    /// Reads `x_mm,y_mm,h_mm` CSV (the layout of every map CSV).
    pub fn read_csv<R: std::io::Read>(reader: R, source_name: &str) -> Result<Self, MapError> {
        let (grid, h) = crate::map::read_grid_csv(reader, source_name, &ranges::HEIGHT_MM)?;
        Self::new(grid, h, source_name)
    }

    /// Writes `x_mm,y_mm,h_mm` CSV.
    pub fn write_csv(&self, w: &mut dyn Write) -> std::io::Result<()> {
        crate::map::write_grid_rows(w, &self.grid, "h_mm", &self.h_mm)
    }

    /// Reads an 8- or 16-bit grayscale PNG as heights, linear in the gray
    /// level: black is `h_black_mm`, white `h_white_mm` (the mapping
    /// `haptex map export-png --quantity h_mm` writes and prints). One cell
    /// per pixel, the image's top row at the largest y.
    pub fn read_gray_png(
        bytes: &[u8],
        h_black_mm: f64,
        h_white_mm: f64,
        spacing_mm: (f64, f64),
        origin_mm: (f64, f64),
        source_name: &str,
    ) -> Result<Self, MapError> {
        for (name, v) in [("h_black_mm", h_black_mm), ("h_white_mm", h_white_mm)] {
            ranges::HEIGHT_MM.check(v).map_err(|e| MapError::new(source_name, Some(name.into()), e.to_string()))?;
        }
        if h_black_mm == h_white_mm {
            return Err(MapError::new(source_name, Some("h_white_mm".into()), "must differ from h_black_mm"));
        }
        let (grid, h) = crate::map::read_gray_grid(bytes, spacing_mm, origin_mm, source_name, |g| {
            h_black_mm + (h_white_mm - h_black_mm) * g
        })?;
        Self::new(grid, h, source_name)
    }

    /// A height map from a template's cross-section laid along a path
    /// (a polyline of at least two vertices, mm): each cell's height is
    /// the cross-section at the cell's distance from the path (signed for
    /// an edge: positive on the left of the path's direction of travel).
    pub fn along_path(grid: MapGrid, template: PathTemplate, path: &[(f64, f64)]) -> Result<Self, MapError> {
        let name = "the path";
        template.validate()?;
        if !(2..=MAX_PATH_VERTICES).contains(&path.len()) {
            return Err(MapError::new(
                name,
                None,
                format!("a path has 2 to {MAX_PATH_VERTICES} vertices, got {}", path.len()),
            ));
        }
        if let Some(k) =
            path.iter().position(|&(x, y)| !(ranges::POSITION_MM.contains(x) && ranges::POSITION_MM.contains(y)))
        {
            return Err(MapError::new(
                name,
                Some(format!("vertex {}", k + 1)),
                format!("({}, {}) mm is outside {}", Num(path[k].0), Num(path[k].1), ranges::POSITION_MM.describe()),
            ));
        }
        if path.windows(2).all(|w| w[0] == w[1]) {
            return Err(MapError::new(name, None, "the path's vertices are all the same point"));
        }
        grid.validate("the grid")?;
        let mut h = Vec::with_capacity(grid.len());
        for j in 0..grid.ny {
            for i in 0..grid.nx {
                h.push(template.height(signed_distance(path, grid.x(i), grid.y(j))));
            }
        }
        Self::new(grid, h, "the template along the path")
    }
}

/// A template's cross-section laid along a path (its x the distance from
/// the path), with the FE templates' formulas.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PathTemplate {
    /// A ridge: h = r_h exp(-(d / (r_w / 2))^2) at distance d.
    Bump { width_mm: f64, height_mm: f64 },
    /// A step: h = r_h s((d + r_w) / r_w), s(t) = 3t^2 - 2t^3 on [0, 1],
    /// d the signed distance (positive on the left): 0 on the right, r_h
    /// from the path on to its left.
    Edge { width_mm: f64, height_mm: f64 },
    /// Grooves parallel to the path: h = r_h sin(2 pi d / r_w).
    Sine { width_mm: f64, height_mm: f64 },
}

impl PathTemplate {
    fn parts(&self) -> (f64, f64) {
        match *self {
            PathTemplate::Bump { width_mm, height_mm }
            | PathTemplate::Edge { width_mm, height_mm }
            | PathTemplate::Sine { width_mm, height_mm } => (width_mm, height_mm),
        }
    }

    /// Width in (0, 1e4] mm, |height| within [`ranges::HEIGHT_MM`].
    pub fn validate(&self) -> Result<(), MapError> {
        let (w, h) = self.parts();
        let err = |field: &str, m: String| MapError::new("the template", Some(field.into()), m);
        if !(w.is_finite() && w > 0.0 && w <= 1e4) {
            return Err(err("width", format!("must be in (0, 10000] mm, got {}", Num(w))));
        }
        ranges::HEIGHT_MM.check(h).map_err(|e| err("height", e.to_string()))?;
        Ok(())
    }

    /// The height at signed distance `d` mm from the path.
    pub fn height(&self, d: f64) -> f64 {
        match *self {
            PathTemplate::Bump { width_mm, height_mm } => {
                let t = d / (width_mm / 2.0);
                height_mm * (-t * t).exp()
            }
            PathTemplate::Edge { width_mm, height_mm } => {
                let t = ((d + width_mm) / width_mm).clamp(0.0, 1.0);
                height_mm * t * t * (3.0 - 2.0 * t)
            }
            PathTemplate::Sine { width_mm, height_mm } => height_mm * (std::f64::consts::TAU * d / width_mm).sin(),
        }
    }
}

/// The distance from (x, y) to the polyline, positive on the left of the
/// nearest segment's direction (its sign from that segment; at a vertex
/// shared by two segments, the first).
pub fn signed_distance(path: &[(f64, f64)], x: f64, y: f64) -> f64 {
    let mut best = (f64::INFINITY, 1.0);
    for w in path.windows(2) {
        let ((ax, ay), (bx, by)) = (w[0], w[1]);
        let (ux, uy) = (bx - ax, by - ay);
        let len2 = ux * ux + uy * uy;
        if len2 == 0.0 {
            continue;
        }
        let t = (((x - ax) * ux + (y - ay) * uy) / len2).clamp(0.0, 1.0);
        let (px, py) = (ax + t * ux, ay + t * uy);
        let d = ((x - px).powi(2) + (y - py).powi(2)).sqrt();
        if d < best.0 {
            let cross = ux * (y - ay) - uy * (x - ax);
            best = (d, if cross < 0.0 { -1.0 } else { 1.0 });
        }
    }
    best.0 * best.1
}

/// The lines along a sliding direction that cover a map: a grid in the
/// rotated frame, s (along the direction) as its x and r (across it) as
/// its y. See the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlidingLines {
    /// Sliding direction from +x, degrees (counter-clockwise).
    pub angle_deg: f64,
    cos: f64,
    sin: f64,
    /// At 0, 90, 180 and 270 degrees (quarter turns 0 to 3) the line
    /// points are the map's cells, read and written by index (exactly).
    quarter: Option<u8>,
    /// The lines: row k is line k, at r = y0 + k dy, its points at s = x0 + i dx.
    pub grid: MapGrid,
}

impl SlidingLines {
    /// The lines over `map` in direction `angle_deg` (finite, from -360 to
    /// 360). At most [`crate::map::MAX_CELLS`] points in all.
    pub fn new(map: &MapGrid, angle_deg: f64) -> Result<Self, MapError> {
        map.validate("the map")?;
        if !(angle_deg.is_finite() && angle_deg.abs() <= 360.0) {
            return Err(MapError::new(
                "the sliding direction",
                Some("angle_deg".into()),
                format!("must be from -360 to 360 degrees, got {}", Num(angle_deg)),
            ));
        }
        // Exact at the axes (sin 90 deg is not exactly 1 in f64 radians).
        let (sin, cos, quarter) = match angle_deg.rem_euclid(360.0) {
            0.0 => (0.0, 1.0, Some(0)),
            90.0 => (1.0, 0.0, Some(1)),
            180.0 => (0.0, -1.0, Some(2)),
            270.0 => (-1.0, 0.0, Some(3)),
            _ => {
                let (sin, cos) = angle_deg.to_radians().sin_cos();
                (sin, cos, None)
            }
        };
        let (x1, y1) = (map.x(map.nx - 1), map.y(map.ny - 1));
        let corners = [(map.x0_mm, map.y0_mm), (x1, map.y0_mm), (map.x0_mm, y1), (x1, y1)];
        let (mut s_lo, mut s_hi, mut r_lo, mut r_hi) =
            (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for (x, y) in corners {
            let (s, r) = (x * cos + y * sin, -x * sin + y * cos);
            (s_lo, s_hi, r_lo, r_hi) = (s_lo.min(s), s_hi.max(s), r_lo.min(r), r_hi.max(r));
        }
        let ds = map.dx_mm * cos.abs() + map.dy_mm * sin.abs();
        let dr = map.dy_mm * cos.abs() + map.dx_mm * sin.abs();
        let count = |span: f64, d: f64| ((span / d) - 1e-9).ceil().max(1.0) as usize + 1;
        let (nx, ny) = match quarter {
            Some(0 | 2) => (map.nx, map.ny),
            Some(_) => (map.ny, map.nx),
            None => (count(s_hi - s_lo, ds), count(r_hi - r_lo, dr)),
        };
        let grid = MapGrid { nx, ny, x0_mm: s_lo, y0_mm: r_lo, dx_mm: ds, dy_mm: dr };
        grid.validate("the sliding lines")?;
        Ok(Self { angle_deg, cos, sin, quarter, grid })
    }

    /// Number of lines.
    pub fn count(&self) -> usize {
        self.grid.ny
    }

    /// The rotated coordinates (s, r) of a map point (x, y).
    pub fn to_line_frame(&self, x: f64, y: f64) -> (f64, f64) {
        (x * self.cos + y * self.sin, -x * self.sin + y * self.cos)
    }

    /// The map point (x, y) of rotated coordinates (s, r).
    pub fn to_map_frame(&self, s: f64, r: f64) -> (f64, f64) {
        (s * self.cos - r * self.sin, s * self.sin + r * self.cos)
    }

    /// At a quarter turn, the map cell of point `i` of line `k`.
    fn cell(&self, map: &MapGrid, k: usize, i: usize) -> Option<usize> {
        let (nx, ny) = (map.nx, map.ny);
        Some(match self.quarter? {
            0 => k * nx + i,
            1 => i * nx + (nx - 1 - k),
            2 => (ny - 1 - k) * nx + (nx - 1 - i),
            _ => (ny - 1 - i) * nx + k,
        })
    }

    /// Line `k`'s positions s (mm along the sliding direction) and the
    /// heights there: bilinear in the map where the line is on it (the
    /// cells themselves at a quarter turn), and flat beyond, at the height
    /// where the line enters the map before it and where it leaves after
    /// it (0 for a line that misses the map). Holding the map's edge
    /// instead would show the finger, on a line leaving the map at an
    /// angle, the edge's profile as if it ran along the line.
    pub fn line(&self, map: &HeightMap, k: usize) -> (Vec<f64>, Vec<f64>) {
        let r = self.grid.y(k);
        let g = &map.grid;
        let slack = 1e-9 * (g.dx_mm + g.dy_mm);
        let (x1, y1) = (g.x(g.nx - 1), g.y(g.ny - 1));
        let on_map =
            |x: f64, y: f64| x >= g.x0_mm - slack && x <= x1 + slack && y >= g.y0_mm - slack && y <= y1 + slack;
        let s: Vec<f64> = (0..self.grid.nx).map(|i| self.grid.x(i)).collect();
        let mut h: Vec<Option<f64>> = s
            .iter()
            .enumerate()
            .map(|(i, &s)| match self.cell(g, k, i) {
                Some(c) => Some(map.h_mm[c]),
                None => {
                    let (x, y) = self.to_map_frame(s, r);
                    on_map(x, y).then(|| g.sample(&map.h_mm, x, y))
                }
            })
            .collect();
        if let (Some(first), Some(last)) = (h.iter().position(Option::is_some), h.iter().rposition(Option::is_some)) {
            let (enter, leave) = (h[first], h[last]);
            h[..first].fill(enter);
            h[last + 1..].fill(leave);
        }
        (s, h.into_iter().map(|v| v.unwrap_or(0.0)).collect())
    }

    /// The friction map on `map`'s grid from the lines' friction
    /// (`mu_lines`, one per line point, row k line k): each cell's the
    /// bilinear interpolation at its (s, r).
    pub fn assemble(&self, map: &MapGrid, mu_lines: &[f64], source_name: &str) -> Result<FrictionMap, MapError> {
        if mu_lines.len() != self.grid.len() {
            return Err(MapError::new(
                source_name,
                None,
                format!("{} line values for {} x {} line points", mu_lines.len(), self.grid.nx, self.grid.ny),
            ));
        }
        let mut mu = vec![0.0; map.len()];
        if self.quarter.is_some() {
            for k in 0..self.grid.ny {
                for i in 0..self.grid.nx {
                    if let Some(c) = self.cell(map, k, i) {
                        mu[c] = mu_lines[k * self.grid.nx + i];
                    }
                }
            }
        } else {
            for j in 0..map.ny {
                for i in 0..map.nx {
                    let (s, r) = self.to_line_frame(map.x(i), map.y(j));
                    mu[j * map.nx + i] = self.grid.sample(mu_lines, s, r);
                }
            }
        }
        FrictionMap::new(*map, mu, source_name)
    }
}
