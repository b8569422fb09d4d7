//! PNG line plots: one figure of stacked panels, each with line (or point)
//! series, axis labels, an optional title and a legend.
//!
//! Shared by every haptex command that draws (`haptex play --png`, FE
//! histories, CAE leave-one-out plots, the figures in `docs/`). The API is
//! plain data: a [`Figure`] holds [`Panel`]s, a panel holds [`Series`] of
//! (x, y) values. Axis labels carry their unit by convention,
//! `"quantity (unit)"`, e.g. `"t (s)"`, `"U (V RMS)"`.
//!
//! ```no_run
//! use haptex_core::plot::{Figure, Panel};
//! let t = [0.0, 0.5, 1.0];
//! Figure::new("A stroke")
//!     .panel(Panel::new("t (s)", "x (mm)").line("finger", &t, &[0.0, 5.0, 10.0]))
//!     .panel(Panel::new("t (s)", "U (V RMS)").line("envelope", &t, &[0.0, 80.0, 20.0]).y_range(0.0, 100.0))
//!     .write_png(std::path::Path::new("stroke.png"))?;
//! # Ok::<(), haptex_core::plot::PlotError>(())
//! ```
//!
//! Rendering is pure Rust (plotters' bitmap backend, text through ab_glyph
//! with DejaVu Sans embedded from `data/fonts/`, PNG encoding by the `png`
//! crate): no system fonts or C libraries. Files are written atomically.
//!
//! Long series are thinned for drawing: a sorted series with more than four
//! points per pixel column is reduced to the minimum and maximum of each
//! column's share of points, which draws the same picture (a carrier at
//! 1 kHz over 10 s shows as its filled envelope) in a fraction of the time.
//! Non-finite values (NaN, inf) break a line instead of corrupting the plot.

use std::path::Path;
use std::sync::OnceLock;

use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

use crate::io::{WriteError, write_atomic};

/// DejaVu Sans 2.37 (Bitstream Vera licence, `data/fonts/LICENSE-DejaVu.txt`).
static FONT_TTF: &[u8] = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/fonts/DejaVuSans.ttf"));
/// The family name the embedded font is registered under.
const FAMILY: &str = "sans-serif";

/// Line colours, in series order (the Tableau 10 palette).
pub const PALETTE: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

/// A plot could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The figure's data is inconsistent (e.g. x and y of different lengths).
    #[error("invalid plot: {0}")]
    Invalid(String),
    /// The drawing backend or the PNG encoder failed.
    #[error("cannot draw the plot: {0}")]
    Draw(String),
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeriesKind {
    /// Points joined by straight lines (a non-finite value breaks the line).
    Line,
    /// A small filled circle at each point.
    Points,
}

/// One data series: (x, y) values and the legend label (empty: no legend
/// entry).
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub label: String,
    pub kind: SeriesKind,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// RGB colour; `None` takes the next colour of the palette.
    pub color: Option<(u8, u8, u8)>,
}

impl Series {
    /// A line through the points (x[i], y[i]).
    pub fn line(label: impl Into<String>, x: &[f64], y: &[f64]) -> Self {
        Self { label: label.into(), kind: SeriesKind::Line, x: x.to_vec(), y: y.to_vec(), color: None }
    }

    /// A marker at each point (x[i], y[i]).
    pub fn points(label: impl Into<String>, x: &[f64], y: &[f64]) -> Self {
        Self { kind: SeriesKind::Points, ..Self::line(label, x, y) }
    }

    /// The same series in the RGB colour `color`.
    pub fn color(mut self, color: (u8, u8, u8)) -> Self {
        self.color = Some(color);
        self
    }
}

/// A closed polygon drawn under the series (e.g. a mesh element).
#[derive(Debug, Clone, PartialEq)]
pub struct Shape {
    pub points: Vec<(f64, f64)>,
    /// Fill colour, if filled.
    pub fill: Option<(u8, u8, u8)>,
    /// Outline colour, if outlined (1 px).
    pub stroke: Option<(u8, u8, u8)>,
}

/// One panel (a pair of axes) of a figure.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// Caption above the panel, if any.
    pub title: Option<String>,
    /// x axis label with its unit, e.g. `"t (s)"`.
    pub x_label: String,
    /// y axis label with its unit, e.g. `"U (V RMS)"`.
    pub y_label: String,
    pub series: Vec<Series>,
    /// Polygons drawn before the series.
    pub shapes: Vec<Shape>,
    /// Legend entries without data: (label, colour swatch).
    pub swatches: Vec<(String, (u8, u8, u8))>,
    /// Fixed x range; `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None` fits the data with 5% margins.
    pub y_range: Option<(f64, f64)>,
}

impl Panel {
    /// An empty panel with axis labels (units included, `"x (mm)"`).
    pub fn new(x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        Self {
            title: None,
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            shapes: Vec::new(),
            swatches: Vec::new(),
            x_range: None,
            y_range: None,
        }
    }

    /// Sets the panel's caption.
    pub fn title(mut self, title: impl Into<String>) -> Self {
        self.title = Some(title.into());
        self
    }

    /// Adds a line series (see [`Series::line`]).
    pub fn line(self, label: impl Into<String>, x: &[f64], y: &[f64]) -> Self {
        self.series(Series::line(label, x, y))
    }

    /// Adds a point series (see [`Series::points`]).
    pub fn points(self, label: impl Into<String>, x: &[f64], y: &[f64]) -> Self {
        self.series(Series::points(label, x, y))
    }

    /// Adds a series.
    pub fn series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// Adds a polygon, drawn under the series.
    pub fn shape(mut self, shape: Shape) -> Self {
        self.shapes.push(shape);
        self
    }

    /// Adds a legend entry with a colour swatch and no data.
    pub fn swatch(mut self, label: impl Into<String>, color: (u8, u8, u8)) -> Self {
        self.swatches.push((label.into(), color));
        self
    }

    /// Fixes the x range (lo < hi).
    pub fn x_range(mut self, lo: f64, hi: f64) -> Self {
        self.x_range = Some((lo, hi));
        self
    }

    /// Fixes the y range (lo < hi).
    pub fn y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y_range = Some((lo, hi));
        self
    }
}

/// A figure: a title and panels stacked top to bottom.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    pub title: Option<String>,
    /// Image width in pixels (default 1000).
    pub width_px: u32,
    /// Height of each panel in pixels (default 300); the image is
    /// `panels.len() * panel_height_px` high plus the title band.
    pub panel_height_px: u32,
    pub panels: Vec<Panel>,
}

/// Height of the figure title band in pixels.
const TITLE_PX: u32 = 40;

impl Figure {
    /// An empty figure, 1000 px wide with 300 px panels.
    pub fn new(title: impl Into<String>) -> Self {
        let title = title.into();
        Self { title: (!title.is_empty()).then_some(title), width_px: 1000, panel_height_px: 300, panels: Vec::new() }
    }

    /// Sets the image width and the height of each panel, in pixels.
    pub fn size(mut self, width_px: u32, panel_height_px: u32) -> Self {
        self.width_px = width_px;
        self.panel_height_px = panel_height_px;
        self
    }

    /// Adds a panel below the existing ones.
    pub fn panel(mut self, panel: Panel) -> Self {
        self.panels.push(panel);
        self
    }

    /// The image size in pixels, (width, height).
    pub fn dimensions(&self) -> (u32, u32) {
        let title = if self.title.is_some() { TITLE_PX } else { 0 };
        (self.width_px, title + self.panel_height_px * self.panels.len() as u32)
    }

    /// The figure encoded as a PNG file (8-bit RGB).
    pub fn to_png(&self) -> Result<Vec<u8>, PlotError> {
        let (width, height) = self.dimensions();
        let rgb = self.render_rgb()?;
        let mut bytes = Vec::new();
        let mut encoder = png::Encoder::new(&mut bytes, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(|e| PlotError::Draw(e.to_string()))?;
        writer.write_image_data(&rgb).map_err(|e| PlotError::Draw(e.to_string()))?;
        writer.finish().map_err(|e| PlotError::Draw(e.to_string()))?;
        Ok(bytes)
    }

    /// Writes the figure as a PNG file, atomically.
    pub fn write_png(&self, path: &Path) -> Result<(), PlotError> {
        let bytes = self.to_png()?;
        write_atomic(path, |w| w.write_all(&bytes))?;
        Ok(())
    }

    /// Renders into an RGB8 buffer of `dimensions()`.
    fn render_rgb(&self) -> Result<Vec<u8>, PlotError> {
        self.validate()?;
        register_embedded_font()?;
        let (width, height) = self.dimensions();
        let mut rgb = vec![255u8; width as usize * height as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
            root.fill(&WHITE).map_err(draw_error)?;
            let body = match &self.title {
                Some(title) => root.titled(title, (FAMILY, 22)).map_err(draw_error)?,
                None => root.clone(),
            };
            let areas = body.split_evenly((self.panels.len().max(1), 1));
            for (panel, area) in self.panels.iter().zip(&areas) {
                draw_panel(panel, area, width)?;
            }
            root.present().map_err(draw_error)?;
        }
        Ok(rgb)
    }

    fn validate(&self) -> Result<(), PlotError> {
        if self.panels.is_empty() {
            return Err(PlotError::Invalid("a figure needs at least one panel".into()));
        }
        if !(200..=8000).contains(&self.width_px) || !(100..=4000).contains(&self.panel_height_px) {
            return Err(PlotError::Invalid(format!(
                "size {} x {} px per panel is outside 200..8000 x 100..4000",
                self.width_px, self.panel_height_px
            )));
        }
        for (p, panel) in self.panels.iter().enumerate() {
            for s in &panel.series {
                if s.x.len() != s.y.len() {
                    return Err(PlotError::Invalid(format!(
                        "panel {}, series '{}': {} x values and {} y values",
                        p + 1,
                        s.label,
                        s.x.len(),
                        s.y.len()
                    )));
                }
            }
            for (axis, range) in [("x", panel.x_range), ("y", panel.y_range)] {
                if let Some((lo, hi)) = range
                    && !(lo.is_finite() && hi.is_finite() && lo < hi)
                {
                    return Err(PlotError::Invalid(format!(
                        "panel {}: {axis} range {lo} .. {hi} is not an increasing finite range",
                        p + 1
                    )));
                }
            }
        }
        Ok(())
    }
}

fn draw_error<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// Registers the embedded DejaVu Sans with plotters (once per process).
fn register_embedded_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| register_font(FAMILY, FontStyle::Normal, FONT_TTF).is_ok());
    if ok { Ok(()) } else { Err(PlotError::Draw("the embedded font could not be loaded".into())) }
}

fn draw_panel<DB: DrawingBackend>(
    panel: &Panel,
    area: &DrawingArea<DB, plotters::coord::Shift>,
    width: u32,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let (x_range, y_range) = ranges(panel);
    let mut builder = ChartBuilder::on(area);
    builder.margin(10).margin_right(25).x_label_area_size(45).y_label_area_size(80);
    if let Some(title) = &panel.title {
        builder.caption(title, (FAMILY, 17));
    }
    let mut chart = builder.build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1).map_err(draw_error)?;
    chart
        .configure_mesh()
        .x_desc(panel.x_label.as_str())
        .y_desc(panel.y_label.as_str())
        .axis_desc_style((FAMILY, 16))
        .label_style((FAMILY, 13))
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(215, 215, 215))
        .x_labels(10)
        .y_labels(6)
        .draw()
        .map_err(draw_error)?;

    for shape in &panel.shapes {
        let points: Vec<(f64, f64)> =
            shape.points.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
        if let Some((r, g, b)) = shape.fill {
            chart
                .draw_series(std::iter::once(Polygon::new(points.clone(), RGBColor(r, g, b).filled())))
                .map_err(draw_error)?;
        }
        if let Some((r, g, b)) = shape.stroke {
            let mut closed = points;
            if let Some(&first) = closed.first() {
                closed.push(first);
            }
            chart.draw_series(std::iter::once(PathElement::new(closed, RGBColor(r, g, b)))).map_err(draw_error)?;
        }
    }
    let mut labelled = false;
    for (label, (r, g, b)) in &panel.swatches {
        let color = RGBColor(*r, *g, *b);
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
            .map_err(draw_error)?
            .label(label.as_str())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 16, y + 5)], color.filled()));
        labelled = true;
    }
    // Plot columns available to the data, for thinning long series.
    let columns = (width as usize).saturating_sub(115).max(50);
    for (i, series) in panel.series.iter().enumerate() {
        let (r, g, b) = series.color.unwrap_or(PALETTE[i % PALETTE.len()]);
        let color = RGBColor(r, g, b);
        let mut first = true;
        match series.kind {
            SeriesKind::Line => {
                for segment in finite_segments(&series.x, &series.y) {
                    let points = thin(segment, columns);
                    // One 2-px path per segment: plotters' mitred joins of a
                    // thick polyline spike out at sharp reversals (a dense
                    // carrier), separate segments do not.
                    let style = color.stroke_width(2);
                    let drawn = chart
                        .draw_series(points.windows(2).map(|w| PathElement::new(vec![w[0], w[1]], style)))
                        .map_err(draw_error)?;
                    if first && !series.label.is_empty() {
                        drawn
                            .label(series.label.as_str())
                            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
                        labelled = true;
                    }
                    first = false;
                }
            }
            SeriesKind::Points => {
                let points = series.x.iter().zip(&series.y).filter(|(x, y)| x.is_finite() && y.is_finite());
                let drawn = chart
                    .draw_series(points.map(|(&x, &y)| Circle::new((x, y), 3, color.filled())))
                    .map_err(draw_error)?;
                if !series.label.is_empty() {
                    drawn
                        .label(series.label.as_str())
                        .legend(move |(x, y)| Circle::new((x + 10, y), 3, color.filled()));
                    labelled = true;
                }
            }
        }
    }
    if labelled {
        chart
            .configure_series_labels()
            .label_font((FAMILY, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(draw_error)?;
    }
    Ok(())
}

/// The panel's axis ranges: fixed ones as given, others fitted to the
/// finite data (y with 5% margins); a degenerate range is widened.
fn ranges(panel: &Panel) -> ((f64, f64), (f64, f64)) {
    let fit = |values: &mut dyn Iterator<Item = f64>| {
        values.filter(|v| v.is_finite()).fold(None, |acc: Option<(f64, f64)>, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
    };
    let widen = |(lo, hi): (f64, f64), margin: f64| {
        if hi > lo {
            let pad = (hi - lo) * margin;
            (lo - pad, hi + pad)
        } else {
            let pad = if lo == 0.0 { 1.0 } else { 0.05 * lo.abs() };
            (lo - pad, hi + pad)
        }
    };
    let finite_pairs = || {
        let series = panel.series.iter().flat_map(|s| s.x.iter().copied().zip(s.y.iter().copied()));
        let shapes = panel.shapes.iter().flat_map(|s| s.points.iter().copied());
        series.chain(shapes).filter(|(x, y)| x.is_finite() && y.is_finite())
    };
    let x = panel.x_range.unwrap_or_else(|| widen(fit(&mut finite_pairs().map(|(x, _)| x)).unwrap_or((0.0, 1.0)), 0.0));
    let y =
        panel.y_range.unwrap_or_else(|| widen(fit(&mut finite_pairs().map(|(_, y)| y)).unwrap_or((0.0, 1.0)), 0.05));
    (x, y)
}

/// Maximal runs of points whose x and y are both finite.
fn finite_segments<'a>(x: &'a [f64], y: &'a [f64]) -> impl Iterator<Item = Vec<(f64, f64)>> + 'a {
    let mut i = 0;
    std::iter::from_fn(move || {
        while i < x.len() && !(x[i].is_finite() && y[i].is_finite()) {
            i += 1;
        }
        if i >= x.len() {
            return None;
        }
        let start = i;
        while i < x.len() && x[i].is_finite() && y[i].is_finite() {
            i += 1;
        }
        Some(x[start..i].iter().copied().zip(y[start..i].iter().copied()).collect())
    })
}

/// Thins a line for drawing on `columns` pixel columns: when x is sorted and
/// there are more than 4 points per column, each column's share of points
/// is replaced by its minimum and maximum (in their original order), which
/// draws the same picture. Other lines are returned unchanged.
pub fn thin(points: Vec<(f64, f64)>, columns: usize) -> Vec<(f64, f64)> {
    let columns = columns.max(1);
    if points.len() <= 4 * columns || !points.windows(2).all(|w| w[0].0 <= w[1].0) {
        return points;
    }
    let chunk = points.len().div_ceil(columns);
    let mut out = Vec::with_capacity(2 * columns + 2);
    for part in points.chunks(chunk) {
        let (mut lo, mut hi) = (0, 0);
        for (j, p) in part.iter().enumerate() {
            if p.1 < part[lo].1 {
                lo = j;
            }
            if p.1 > part[hi].1 {
                hi = j;
            }
        }
        let (a, b) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        out.push(part[a]);
        if b != a {
            out.push(part[b]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thin_keeps_short_or_unsorted_lines_and_extremes_of_long_ones() {
        let short: Vec<(f64, f64)> = (0..10).map(|i| (i as f64, 0.0)).collect();
        assert_eq!(thin(short.clone(), 5), short);
        // A square wave of 10 000 points on 10 columns keeps both levels.
        let long: Vec<(f64, f64)> = (0..10_000).map(|i| (i as f64, if i % 2 == 0 { 1.0 } else { -1.0 })).collect();
        let thinned = thin(long, 10);
        assert_eq!(thinned.len(), 20);
        assert!(thinned.iter().any(|p| p.1 == 1.0) && thinned.iter().any(|p| p.1 == -1.0));
        let unsorted: Vec<(f64, f64)> = (0..100).map(|i| ((i % 7) as f64, i as f64)).collect();
        assert_eq!(thin(unsorted.clone(), 2), unsorted);
    }

    #[test]
    fn non_finite_values_split_lines() {
        let x = [0.0, 1.0, 2.0, 3.0, 4.0];
        let y = [1.0, f64::NAN, 2.0, 3.0, f64::INFINITY];
        let segments: Vec<_> = finite_segments(&x, &y).collect();
        assert_eq!(segments, vec![vec![(0.0, 1.0)], vec![(2.0, 2.0), (3.0, 3.0)]]);
    }

    #[test]
    fn ranges_fit_data_and_widen_constant_series() {
        let p = Panel::new("x", "y").line("a", &[0.0, 2.0], &[5.0, 5.0]);
        let (x, y) = ranges(&p);
        assert_eq!(x, (0.0, 2.0));
        assert_eq!(y, (4.75, 5.25));
        let p = Panel::new("x", "y").line("a", &[0.0, 1.0], &[0.0, 10.0]).y_range(-1.0, 1.0);
        assert_eq!(ranges(&p).1, (-1.0, 1.0));
    }

    #[test]
    fn inconsistent_series_is_an_error_not_a_panic() {
        let f = Figure::new("t").panel(Panel::new("x", "y").line("bad", &[0.0, 1.0], &[0.0]));
        let e = f.to_png().unwrap_err();
        assert!(e.to_string().contains("series 'bad': 2 x values and 1 y values"), "{e}");
        assert!(Figure::new("t").to_png().is_err());
        let f = Figure::new("t").panel(Panel::new("x", "y").y_range(1.0, 1.0));
        assert!(f.to_png().unwrap_err().to_string().contains("y range"));
    }
}
