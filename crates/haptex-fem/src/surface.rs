//! The rigid reference surface y = h(x): the templates of design.md (flat,
//! bump, edge, sine) evaluated by their formulas, or a sampled height
//! profile through a C1 monotone cubic. Contact sees the exact curve, with
//! a normal that turns continuously; a fine polyline through it only
//! locates the closest point before it is refined on the curve.
//!
//! The rigid body occupies y < h(x). A point is inside (penetrating) iff
//! y < h(x); its closest boundary point lies within the vertical distance
//! h(x) - y of it, which bounds the segments searched.

use std::io::Read;
use std::path::Path;

use haptex_core::database::Template;
use haptex_core::io::{Table, TableError};
use haptex_core::num::Num;
use serde::{Deserialize, Serialize};

/// The shape of a reference surface (all lengths in mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum SurfaceShape {
    /// h = 0.
    Flat,
    /// h = r_h exp(-((x - x0) / (r_w / 2))^2).
    Bump { x0: f64, width: f64, height: f64 },
    /// h = r_h s((x - x0 + r_w) / r_w), s(t) = 3t^2 - 2t^3 on [0, 1]:
    /// flat at 0, rising over r_w, flat at r_h from x0 on.
    Edge { x0: f64, width: f64, height: f64 },
    /// h = r_h sin(2 pi (x - x0) / r_w): phase x0, period r_w, amplitude r_h.
    Sine { x0: f64, width: f64, height: f64 },
    /// A height profile given point by point (x strictly increasing): the
    /// monotone cubic through the points (PCHIP: C1, no overshoot, flat
    /// where the data turn) and held flat beyond the ends.
    Sampled { x_mm: Vec<f64>, h_mm: Vec<f64> },
}

/// The accepted magnitudes of surface parameters (mm): far beyond any
/// real surface, and far from where the solver's sums of positions and
/// heights would lose their digits or overflow.
pub mod limits {
    /// |x0| of a template.
    pub const X0_MM: f64 = 1e4;
    /// Width r_w of a template: from 1 um to 10 m.
    pub const WIDTH_MM: (f64, f64) = (1e-3, 1e4);
    /// |r_h| of a template and |h| of a height profile.
    pub const HEIGHT_MM: f64 = 1e3;
    /// |x| of a height profile.
    pub const X_MM: f64 = 1e6;
    /// Most vertices of the polyline a surface is represented by (a
    /// template is sampled at r_w/200, at most 5 um, over the slide): 4e6
    /// vertices take 96 MB.
    pub const MAX_VERTICES: usize = 4_000_000;
}

/// A surface definition is invalid.
#[derive(Debug, thiserror::Error)]
pub enum SurfaceError {
    #[error(transparent)]
    Table(#[from] TableError),
    #[error("{0}")]
    Invalid(String),
}

impl SurfaceShape {
    /// Height h(x) in mm (for a sampled profile this builds its
    /// interpolant, O(points): [`RigidSurface::height`] for many x).
    pub fn height(&self, x: f64) -> f64 {
        match self {
            SurfaceShape::Flat => 0.0,
            SurfaceShape::Bump { x0, width, height } => Template::Bump.height_mm(x, *x0, *width, *height),
            SurfaceShape::Edge { x0, width, height } => Template::Edge.height_mm(x, *x0, *width, *height),
            SurfaceShape::Sine { x0, width, height } => Template::Sine.height_mm(x, *x0, *width, *height),
            SurfaceShape::Sampled { .. } => Curve::new(self).eval(x)[0],
        }
    }

    /// Checks the parameters against [`limits`]: width, x0 and height of a
    /// template; point count, increasing x and magnitudes of a height profile.
    pub fn validate(&self) -> Result<(), SurfaceError> {
        let invalid = |m: String| Err(SurfaceError::Invalid(m));
        match self {
            SurfaceShape::Flat => Ok(()),
            SurfaceShape::Bump { x0, width, height }
            | SurfaceShape::Edge { x0, width, height }
            | SurfaceShape::Sine { x0, width, height } => {
                let (lo, hi) = limits::WIDTH_MM;
                if !(width.is_finite() && *width >= lo && *width <= hi) {
                    return invalid(format!(
                        "surface width r_w = {} mm is outside the supported range {} .. {} mm",
                        Num(*width),
                        Num(lo),
                        Num(hi)
                    ));
                }
                if !(x0.is_finite() && x0.abs() <= limits::X0_MM) {
                    return invalid(format!(
                        "surface x0 = {} mm is outside the supported range +-{} mm",
                        Num(*x0),
                        Num(limits::X0_MM)
                    ));
                }
                if !(height.is_finite() && height.abs() <= limits::HEIGHT_MM) {
                    return invalid(format!(
                        "surface height r_h = {} mm is outside the supported range +-{} mm",
                        Num(*height),
                        Num(limits::HEIGHT_MM)
                    ));
                }
                Ok(())
            }
            SurfaceShape::Sampled { x_mm, h_mm } => {
                if x_mm.len() < 2 || x_mm.len() != h_mm.len() {
                    return invalid("a sampled surface needs at least 2 points of x and h".into());
                }
                if let Some(message) = Self::out_of_range_point(x_mm, h_mm) {
                    return invalid(message.1);
                }
                if let Some(i) = x_mm.windows(2).position(|w| w[1] <= w[0]) {
                    return invalid(format!(
                        "a sampled surface needs strictly increasing x: point {} (x = {} mm) follows x = {} mm",
                        i + 2,
                        Num(x_mm[i + 1]),
                        Num(x_mm[i])
                    ));
                }
                Ok(())
            }
        }
    }

    /// The first point (index, message) of a height profile whose x or h is
    /// not finite or beyond [`limits`].
    fn out_of_range_point(x_mm: &[f64], h_mm: &[f64]) -> Option<(usize, String)> {
        x_mm.iter().zip(h_mm).enumerate().find_map(|(i, (&x, &h))| {
            if !(x.is_finite() && x.abs() <= limits::X_MM) {
                Some((i, format!("x = {} mm is outside the supported range +-{} mm", Num(x), Num(limits::X_MM))))
            } else if !(h.is_finite() && h.abs() <= limits::HEIGHT_MM) {
                Some((i, format!("h = {} mm is outside the supported range +-{} mm", Num(h), Num(limits::HEIGHT_MM))))
            } else {
                None
            }
        })
    }

    /// Reads a sampled height profile (`x_mm,h_mm` CSV) from a file.
    pub fn read_csv(path: &Path) -> Result<Self, SurfaceError> {
        Self::from_table(Table::read_file(path)?)
    }

    /// Reads a sampled height profile (`x_mm,h_mm` CSV); `source_name`
    /// labels errors, which name the line and the column.
    pub fn read_csv_from<R: Read>(reader: R, source_name: &str) -> Result<Self, SurfaceError> {
        Self::from_table(Table::read(reader, source_name)?)
    }

    fn from_table(table: Table) -> Result<Self, SurfaceError> {
        let x = table.require("x_mm")?;
        let h = table.require("h_mm")?;
        if x.len() < 2 {
            return Err(table.error_at(None, Some("x_mm"), "a height profile needs at least 2 points").into());
        }
        if let Some(i) = x.windows(2).position(|w| w[1] <= w[0]) {
            return Err(table
                .error_at(Some(i + 1), Some("x_mm"), {
                    let (next, previous) = haptex_core::num::distinct(x[i + 1], x[i]);
                    format!("x must be strictly increasing: {next} follows {previous}")
                })
                .into());
        }
        if let Some((i, message)) = Self::out_of_range_point(x, h) {
            let column = if x[i].abs() <= limits::X_MM { "h_mm" } else { "x_mm" };
            return Err(table.error_at(Some(i), Some(column), message).into());
        }
        Ok(SurfaceShape::Sampled { x_mm: x.to_vec(), h_mm: h.to_vec() })
    }

    /// A length below which the shape has no detail (for sampling): a
    /// fraction of the feature width, or of the sampled spacing.
    fn detail_mm(&self) -> f64 {
        match self {
            SurfaceShape::Flat => f64::INFINITY,
            SurfaceShape::Bump { width, .. } | SurfaceShape::Edge { width, .. } | SurfaceShape::Sine { width, .. } => {
                *width / 200.0
            }
            SurfaceShape::Sampled { .. } => f64::INFINITY,
        }
    }
}

/// The closest point of the surface to a penetrating point, with what the
/// contact tangent needs of the curve there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Distance to the surface (> 0: penetration depth), mm.
    pub depth: f64,
    /// Outward unit normal of the rigid body at the closest point.
    pub normal: [f64; 2],
    /// Unit tangent, oriented towards +x.
    pub tangent: [f64; 2],
    /// Arc-length coordinate of the closest point along the surface, mm.
    pub arc_mm: f64,
    /// Signed curvature kappa at the closest point (1/mm): d tangent / ds =
    /// kappa normal; negative on a crest (convex rigid body), positive in a
    /// valley.
    pub curvature: f64,
    /// d arc / ds at the closest point: 1 up to the interpolation of the
    /// arc coordinate (within 1e-9).
    pub arc_rate: f64,
}

/// The exact curve y = h(x) behind the search polyline: the templates'
/// formulas, or a C1 monotone cubic through a sampled profile's points.
#[derive(Debug, Clone)]
enum Curve {
    Flat,
    Template {
        template: Template,
        x0: f64,
        width: f64,
        height: f64,
    },
    /// Piecewise cubic Hermite: knots, values, slopes; flat beyond the ends.
    Hermite {
        x: Vec<f64>,
        h: Vec<f64>,
        d: Vec<f64>,
    },
}

impl Curve {
    fn new(shape: &SurfaceShape) -> Self {
        match shape {
            SurfaceShape::Flat => Curve::Flat,
            SurfaceShape::Bump { x0, width, height } => {
                Curve::Template { template: Template::Bump, x0: *x0, width: *width, height: *height }
            }
            SurfaceShape::Edge { x0, width, height } => {
                Curve::Template { template: Template::Edge, x0: *x0, width: *width, height: *height }
            }
            SurfaceShape::Sine { x0, width, height } => {
                Curve::Template { template: Template::Sine, x0: *x0, width: *width, height: *height }
            }
            SurfaceShape::Sampled { x_mm, h_mm } => {
                Curve::Hermite { x: x_mm.clone(), h: h_mm.clone(), d: pchip_slopes(x_mm, h_mm) }
            }
        }
    }

    /// h, h' and h'' at x.
    fn eval(&self, x: f64) -> [f64; 3] {
        match self {
            Curve::Flat => [0.0; 3],
            Curve::Template { template, x0, width, height } => template.height_derivatives_mm(x, *x0, *width, *height),
            Curve::Hermite { x: knots, h, d } => {
                let n = knots.len();
                if x <= knots[0] {
                    return [h[0], 0.0, 0.0];
                }
                if x >= knots[n - 1] {
                    return [h[n - 1], 0.0, 0.0];
                }
                let i = knots.partition_point(|&v| v <= x).saturating_sub(1).min(n - 2);
                hermite(knots[i], knots[i + 1], h[i], h[i + 1], d[i], d[i + 1], x)
            }
        }
    }
}

/// Value, first and second derivative at x of the cubic Hermite
/// interpolant on [a, b] with values (ya, yb) and slopes (da, db).
fn hermite(a: f64, b: f64, ya: f64, yb: f64, da: f64, db: f64, x: f64) -> [f64; 3] {
    let l = b - a;
    let t = (x - a) / l;
    let (t2, t3) = (t * t, t * t * t);
    let value = (2.0 * t3 - 3.0 * t2 + 1.0) * ya
        + (t3 - 2.0 * t2 + t) * l * da
        + (-2.0 * t3 + 3.0 * t2) * yb
        + (t3 - t2) * l * db;
    let first = ((6.0 * t2 - 6.0 * t) * ya + (-6.0 * t2 + 6.0 * t) * yb) / l
        + (3.0 * t2 - 4.0 * t + 1.0) * da
        + (3.0 * t2 - 2.0 * t) * db;
    let second = ((12.0 * t - 6.0) * (ya - yb) / l + (6.0 * t - 4.0) * da + (6.0 * t - 2.0) * db) / l;
    [value, first, second]
}

/// Slopes of the monotone piecewise cubic Hermite interpolant (PCHIP,
/// Fritsch & Carlson 1980, with the weighted harmonic mean of Fritsch &
/// Butland 1984 at interior knots, as SciPy's PchipInterpolator): no
/// overshoot between knots, a flat knot where the data turn. The end slopes
/// are 0, so the curve joins the flat continuation beyond the ends with a
/// continuous slope.
pub fn pchip_slopes(x: &[f64], h: &[f64]) -> Vec<f64> {
    let n = x.len();
    let mut d = vec![0.0; n];
    for k in 1..n.saturating_sub(1) {
        let (h0, h1) = (x[k] - x[k - 1], x[k + 1] - x[k]);
        let (s0, s1) = ((h[k] - h[k - 1]) / h0, (h[k + 1] - h[k]) / h1);
        if s0 == 0.0 || s1 == 0.0 || (s0 > 0.0) != (s1 > 0.0) {
            continue;
        }
        let (w1, w2) = (2.0 * h1 + h0, h1 + 2.0 * h0);
        d[k] = (w1 + w2) / (w1 / s0 + w2 / s1);
    }
    d
}

/// Sampling step of the search polyline: at most 5 um.
const MAX_SEGMENT_MM: f64 = 0.005;

/// Segments of the search polyline per bounding box ([`RigidSurface::boxes`]).
const BOX_SEGMENTS: usize = 16;

/// Boxes per super-box ([`RigidSurface::super_boxes`]).
const SUPER_BOXES: usize = 16;

/// How far a box's distance bound is lowered, mm: far above the rounding of
/// a computed point-to-chord distance (about 1e-14 mm at coordinates of tens
/// of mm), so that no chord in a skipped box can have a computed distance at
/// or below the best one, and far below any distance that decides anything.
const BOX_SLACK_MM: f64 = 1e-9;

/// The vertices of a sampled profile's interval [a, b] inside the search
/// polyline over [x_min, x_max]: the interval is cut into `pieces` equal
/// parts of at most 5 um, and of their inner points k = 1 .. pieces - 1
/// (at a + (b - a) k / pieces) only k = first ..= last, those over the
/// range with one beyond each end of it, are kept. So the polyline has 5 um
/// segments wherever the range reaches, and a wide interval (x = 0 and
/// 1e6 mm in a file) adds the range's vertices, not (b - a) / 5 um of them.
/// In f64 (pieces, first, last), so that an unvalidated shape gives a
/// count that [`RigidSurface::template_segments`] refuses, not a wrap.
fn subdivision(a: f64, b: f64, x_min: f64, x_max: f64) -> (f64, f64, f64) {
    if !(b > x_min && a < x_max) {
        return (1.0, 1.0, 0.0);
    }
    let pieces = ((b - a) / MAX_SEGMENT_MM).ceil();
    let step = (b - a) / pieces;
    let first = (((x_min - a) / step).floor() - 1.0).max(1.0);
    let last = (((x_max - a) / step).ceil() + 1.0).min(pieces - 1.0);
    (pieces, first, last)
}

/// The number of inner vertices [`subdivision`] keeps (NaN or infinite for
/// a non-finite interval).
fn inner_vertices(a: f64, b: f64, x_min: f64, x_max: f64) -> f64 {
    let (_, first, last) = subdivision(a, b, x_min, x_max);
    let n = last - first + 1.0;
    if n.is_nan() || n > 0.0 { n } else { 0.0 }
}

/// A surface over a range of x, in its own frame: the exact curve, and a
/// polyline through it (vertices at most 5 um apart) that locates the
/// closest point before it is refined on the curve.
#[derive(Debug, Clone)]
pub struct RigidSurface {
    curve: Curve,
    x: Vec<f64>,
    h: Vec<f64>,
    /// Arc length at each vertex, and d arc / dx there: the arc coordinate
    /// between vertices is their cubic Hermite interpolant.
    arc: Vec<f64>,
    arc_slope: Vec<f64>,
    /// (first x, 1/spacing) when the vertices are uniformly spaced: O(1)
    /// segment lookup (templates), else binary search (sampled files).
    uniform: Option<(f64, f64)>,
    /// The lowest and highest vertex of each run of [`BOX_SEGMENTS`]
    /// segments (vertices k B ..= (k + 1) B): with the run's x range, a box
    /// holding its chords, whose distance to a point bounds theirs from
    /// below, so that the closest-point search skips runs that cannot hold
    /// the closest chord.
    boxes: Vec<[f64; 2]>,
    /// The same over each run of [`SUPER_BOXES`] boxes (boxes k S ..
    /// (k + 1) S): the search skips a whole run of boxes that cannot hold
    /// the closest chord in one step. Under a long window (a point far
    /// inside the surface, as a Newton iterate may put one for an
    /// iteration) the walk over single boxes was most of the search.
    super_boxes: Vec<[f64; 2]>,
}

impl RigidSurface {
    /// The surface `shape` over [x_min, x_max] (mm). Contact is computed on
    /// the exact curve: the templates' formulas with their derivatives, or
    /// for a sampled profile the C1 monotone cubic through its points (flat
    /// beyond its ends). A continuous normal is what lets Newton's method
    /// converge while the skin slides over a crest (docs/fem.md, "Solver").
    /// The search polyline samples templates at r_w/200 (at most 5 um) and
    /// sampled profiles at their points, subdivided to at most 5 um over the
    /// range. The shape must be valid ([`SurfaceShape::validate`]) and the
    /// polyline at most [`limits::MAX_VERTICES`] long.
    pub fn new(shape: &SurfaceShape, x_min: f64, x_max: f64) -> Result<Self, SurfaceError> {
        shape.validate()?;
        if !(x_min.is_finite() && x_max.is_finite() && x_max > x_min) {
            return Err(SurfaceError::Invalid(format!(
                "the surface range {} .. {} mm is empty or not finite",
                Num(x_min),
                Num(x_max)
            )));
        }
        let segments = Self::template_segments(shape, x_min, x_max)?;
        let curve = Curve::new(shape);
        let mut x: Vec<f64> = match shape {
            SurfaceShape::Sampled { x_mm, .. } => {
                let mut x = Vec::with_capacity(segments + 3);
                for w in x_mm.windows(2) {
                    x.push(w[0]);
                    // Validated, finite, and counted by `template_segments`.
                    let (pieces, first, last) = subdivision(w[0], w[1], x_min, x_max);
                    if first <= last {
                        x.extend((first as usize..=last as usize).map(|k| w[0] + (w[1] - w[0]) * k as f64 / pieces));
                    }
                }
                x.push(x_mm[x_mm.len() - 1]);
                x
            }
            _ => (0..=segments).map(|i| x_min + (x_max - x_min) * i as f64 / segments as f64).collect(),
        };
        if x[0] > x_min {
            x.insert(0, x_min);
        }
        if x[x.len() - 1] < x_max {
            x.push(x_max);
        }
        let (h, arc_slope): (Vec<f64>, Vec<f64>) = x
            .iter()
            .map(|&x| {
                let [h, slope, _] = curve.eval(x);
                (h, slope.hypot(1.0))
            })
            .unzip();
        let mut arc = vec![0.0; x.len()];
        // Arc length of each segment: 3-point Gauss-Legendre of |c'(x)|
        // (error ~ l^6 |L^(6)|, far below 1e-12 mm on 5 um segments).
        let (nodes, weights) = ([-(0.6f64.sqrt()), 0.0, 0.6f64.sqrt()], [5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0]);
        for i in 1..x.len() {
            let (a, b) = (x[i - 1], x[i]);
            let length: f64 = nodes
                .iter()
                .zip(&weights)
                .map(|(&xi, &w)| 0.5 * w * curve.eval(0.5 * (a + b) + 0.5 * (b - a) * xi)[1].hypot(1.0))
                .sum::<f64>()
                * (b - a);
            arc[i] = arc[i - 1] + length;
        }
        let n = x.len();
        let spacing = (x[n - 1] - x[0]) / (n - 1) as f64;
        let uniform =
            x.windows(2).all(|w| ((w[1] - w[0]) / spacing - 1.0).abs() < 1e-9).then_some((x[0], 1.0 / spacing));
        let boxes = (0..(n - 1).div_ceil(BOX_SEGMENTS))
            .map(|k| {
                let run = &h[k * BOX_SEGMENTS..=((k + 1) * BOX_SEGMENTS).min(n - 1)];
                run.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], &v| [lo.min(v), hi.max(v)])
            })
            .collect::<Vec<[f64; 2]>>();
        let super_boxes = boxes
            .chunks(SUPER_BOXES)
            .map(|run| run.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], b| [lo.min(b[0]), hi.max(b[1])]))
            .collect();
        Ok(Self { curve, x, h, arc, arc_slope, uniform, boxes, super_boxes })
    }

    /// The number of segments of the search polyline over [x_min, x_max]:
    /// a template's at r_w/200 (at most 5 um), a sampled profile's points
    /// with the part of every interval over the range cut to at most 5 um
    /// (O(points + range / 5 um), whatever the intervals' widths); an error
    /// beyond [`limits::MAX_VERTICES`].
    pub fn template_segments(shape: &SurfaceShape, x_min: f64, x_max: f64) -> Result<usize, SurfaceError> {
        let (count, dx) = match shape {
            SurfaceShape::Sampled { x_mm, .. } => {
                let count: f64 = x_mm.windows(2).map(|w| 1.0 + inner_vertices(w[0], w[1], x_min, x_max)).sum();
                (count, MAX_SEGMENT_MM)
            }
            _ => {
                let dx = shape.detail_mm().min(MAX_SEGMENT_MM);
                (((x_max - x_min) / dx).ceil(), dx)
            }
        };
        if count.is_nan() || count >= limits::MAX_VERTICES as f64 {
            return Err(SurfaceError::Invalid(format!(
                "sampling the surface over x = {} .. {} mm every {} mm (r_w/200, at most 5 um) takes {} points, more \
                 than {}: widen the feature or shorten the slide",
                Num(x_min),
                Num(x_max),
                Num(dx),
                Num(count),
                limits::MAX_VERTICES
            )));
        }
        Ok(count as usize)
    }

    /// Index i of the segment [x_i, x_i+1] containing x (clamped to the range).
    fn segment(&self, x: f64) -> usize {
        let last = self.x.len() - 2;
        match self.uniform {
            Some((x0, inv)) => {
                let i = ((x - x0) * inv).floor();
                if i.is_nan() || i < 0.0 { 0 } else { (i as usize).min(last) }
            }
            None => self.x.partition_point(|&v| v <= x).saturating_sub(1).min(last),
        }
    }

    /// The x range covered.
    pub fn range(&self) -> (f64, f64) {
        (self.x[0], self.x[self.x.len() - 1])
    }

    /// Height h(x) of the exact curve (held flat outside the range).
    pub fn height(&self, x: f64) -> f64 {
        let (lo, hi) = self.range();
        self.curve.eval(x.clamp(lo, hi))[0]
    }

    /// Highest vertex of the search polyline over [a, b] (within its
    /// chord error of the curve's maximum).
    pub fn max_height(&self, a: f64, b: f64) -> f64 {
        let i0 = self.x.partition_point(|&v| v < a);
        let i1 = self.x.partition_point(|&v| v <= b);
        self.h[i0..i1].iter().cloned().fold(self.height(a).max(self.height(b)), f64::max)
    }

    /// Lowest vertex of the search polyline over [a, b].
    pub fn min_height(&self, a: f64, b: f64) -> f64 {
        let i0 = self.x.partition_point(|&v| v < a);
        let i1 = self.x.partition_point(|&v| v <= b);
        self.h[i0..i1].iter().cloned().fold(self.height(a).min(self.height(b)), f64::min)
    }

    /// Arc coordinate at x and its derivative d arc / dx: the cubic Hermite
    /// interpolant of the vertices' arc lengths and slopes (C1, within 1e-9
    /// of the true arc length's slope).
    fn arc_and_rate(&self, x: f64) -> (f64, f64) {
        let (lo, hi) = self.range();
        if x <= lo {
            return (self.arc[0] - (lo - x), 1.0);
        }
        if x >= hi {
            let n = self.x.len() - 1;
            return (self.arc[n] + (x - hi), 1.0);
        }
        let i = self.segment(x);
        let [a, rate, _] = hermite(
            self.x[i],
            self.x[i + 1],
            self.arc[i],
            self.arc[i + 1],
            self.arc_slope[i],
            self.arc_slope[i + 1],
            x,
        );
        (a, rate)
    }

    /// Arc-length coordinate of the surface point below x.
    pub fn arc_at(&self, x: f64) -> f64 {
        self.arc_and_rate(x).0
    }

    /// The closest point of the exact curve to `p` (surface frame) if p is
    /// inside the rigid body (y < h(x)), else `None`.
    ///
    /// The closest vertex-or-chord point of the polyline gives a start and
    /// a bracket; the distance is then minimized on the curve itself by a
    /// Newton iteration on g'(s) = (s - p_x) + (h(s) - p_y) h'(s),
    /// safeguarded by bisection. The result's normal and tangent are the
    /// curve's own at the closest point, so they vary continuously with p
    /// (a polyline's jump at each vertex kept Newton's method from
    /// converging over crests).
    pub fn project(&self, p: [f64; 2]) -> Option<Projection> {
        let [hp, slope, second] = self.height_derivatives(p[0]);
        let vertical = hp - p[1];
        if vertical.is_nan() || vertical <= 0.0 {
            return None;
        }
        let s = if slope == 0.0 && second == 0.0 && matches!(self.curve, Curve::Flat) {
            p[0]
        } else {
            self.closest_parameter(p, vertical)
        };
        let [h, h1, h2] = self.height_derivatives(s);
        let length = h1.hypot(1.0);
        let normal = [-h1 / length, 1.0 / length];
        let tangent = [1.0 / length, h1 / length];
        // Signed depth along the normal (the distance at the closest point).
        let depth = (s - p[0]) * normal[0] + (h - p[1]) * normal[1];
        if depth.is_nan() || depth <= 0.0 {
            return None;
        }
        let curvature = h2 / (length * length * length);
        let (arc_mm, rate) = self.arc_and_rate(s);
        Some(Projection { depth, normal, tangent, arc_mm, curvature, arc_rate: rate / length })
    }

    /// h, h', h'' of the curve, held flat outside the range.
    pub fn height_derivatives(&self, x: f64) -> [f64; 3] {
        let (lo, hi) = self.range();
        if x < lo || x > hi { [self.curve.eval(x.clamp(lo, hi))[0], 0.0, 0.0] } else { self.curve.eval(x) }
    }

    /// The chord of segments `first..last` closest to `p`: its index and
    /// the parameter t in [0, 1] of its closest point; the first of equally
    /// close chords, as a plain scan in index order finds it.
    ///
    /// With `prune`, the search starts at the chord below p and walks the
    /// runs of [`BOX_SEGMENTS`] chords outwards on both sides, skipping a
    /// run whose box lies farther from p than the closest chord so far and
    /// stopping on a side once a box is farther in x alone (the box's
    /// distance, lowered by [`BOX_SLACK_MM`], bounds its chords' computed
    /// distances from below; ties go to the lower index). The result is the
    /// plain scan's, to the bit, at a cost set by the distance to the
    /// surface rather than by the window, which for a point deep under a
    /// steep flank spans hundreds of 2.5 um chords. Without `prune`, the
    /// plain scan (the reference the tests compare with).
    fn closest_chord(&self, p: [f64; 2], first: usize, last: usize, prune: bool) -> (usize, f64) {
        let distance2 = |i: usize| {
            let (ax, ay) = (self.x[i], self.h[i]);
            let (dx, dy) = (self.x[i + 1] - ax, self.h[i + 1] - ay);
            let t = (((p[0] - ax) * dx + (p[1] - ay) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
            ((ax + t * dx - p[0]).powi(2) + (ay + t * dy - p[1]).powi(2), t)
        };
        // (squared distance, index, t), the smallest distance and then the
        // lowest index winning.
        let scan = |from: usize, to: usize, best: &mut (f64, usize, f64)| {
            for i in from..to {
                let (d2, t) = distance2(i);
                if d2 < best.0 || (d2 == best.0 && i < best.1) {
                    *best = (d2, i, t);
                }
            }
        };
        let mut best = (f64::INFINITY, first, 0.0);
        if !prune {
            scan(first, last, &mut best);
            return (best.1, best.2);
        }
        let gap = |v: f64, lo: f64, hi: f64| ((lo - v).max(v - hi) - BOX_SLACK_MM).max(0.0);
        // The x gap and distance (both squared) to p of the box over
        // vertices a ..= b (b at most the last) and heights h_lo ..= h_hi.
        let box_gaps = |a: usize, b: usize, [h_lo, h_hi]: [f64; 2]| {
            let (gx, gy) = (gap(p[0], self.x[a], self.x[b.min(self.x.len() - 1)]), gap(p[1], h_lo, h_hi));
            (gx * gx, gx * gx + gy * gy)
        };
        // Run k's chords within the window, and its box's gaps.
        let run = |k: usize| {
            let (from, to) = ((k * BOX_SEGMENTS).max(first), ((k + 1) * BOX_SEGMENTS).min(last));
            let (x_gap2, gap2) = box_gaps(k * BOX_SEGMENTS, (k + 1) * BOX_SEGMENTS, self.boxes[k]);
            (from, to, x_gap2, gap2)
        };
        let below = self.segment(p[0]).clamp(first, last - 1) / BOX_SEGMENTS;
        let (from, to, _, _) = run(below);
        scan(from, to, &mut best);
        // The x gap and distance (both squared) of super-box j: no larger
        // than those of any of its runs (its box holds theirs).
        let super_run = |j: usize| {
            let k_hi = ((j + 1) * SUPER_BOXES).min(self.boxes.len());
            box_gaps(j * SUPER_BOXES * BOX_SEGMENTS, k_hi * BOX_SEGMENTS, self.super_boxes[j])
        };
        // Outwards on one side, until a run is farther in x alone than the
        // closest chord so far (every run beyond it is farther still). On
        // entering a super-box from its near end, the whole of it is
        // skipped when its box is farther than the closest chord (each of
        // its runs would be skipped, or end the walk, one by one), and the
        // walk ends when it is farther in x alone: the same chords are
        // scanned as run by run, so the result is the same to the bit.
        let walk = |from: usize, to: usize, step_left: bool, best: &mut (f64, usize, f64)| {
            // Runs from..to (exclusive), walked down from to - 1 when
            // step_left, else up from `from`.
            let mut k = if step_left { to } else { from };
            loop {
                if step_left {
                    if k == from {
                        break;
                    }
                    k -= 1;
                } else if k == to {
                    break;
                }
                let entering = if step_left { k % SUPER_BOXES == SUPER_BOXES - 1 } else { k % SUPER_BOXES == 0 };
                if entering {
                    let (x_gap2, gap2) = super_run(k / SUPER_BOXES);
                    if x_gap2 > best.0 {
                        break;
                    }
                    if gap2 > best.0 {
                        // Past this super-box: to the run beyond its far end.
                        if step_left {
                            k = (k + 1 - SUPER_BOXES).max(from);
                        } else {
                            k = (k + SUPER_BOXES).min(to);
                        }
                        continue;
                    }
                }
                let (from_chord, to_chord, x_gap2, gap2) = run(k);
                if x_gap2 > best.0 {
                    break;
                }
                if gap2 <= best.0 {
                    scan(from_chord, to_chord, best);
                }
                if !step_left {
                    k += 1;
                }
            }
        };
        walk(first / BOX_SEGMENTS, below, true, &mut best);
        walk(below + 1, (last - 1) / BOX_SEGMENTS + 1, false, &mut best);
        (best.1, best.2)
    }

    /// The parameter s of the curve point closest to p (which lies `vertical`
    /// below the curve, so |s - p_x| <= vertical).
    fn closest_parameter(&self, p: [f64; 2], vertical: f64) -> f64 {
        // The polyline's closest point over the window [x - v, x + v].
        let first = self.segment(p[0] - vertical);
        let last = (self.segment(p[0] + vertical) + 1).max(first + 1);
        let (i, t) = self.closest_chord(p, first, last, true);
        let start = self.x[i] + t * (self.x[i + 1] - self.x[i]);
        // g'(s) and g''(s) of g(s) = |c(s) - p|^2 / 2.
        let derivatives = |s: f64| {
            let [h, h1, h2] = self.height_derivatives(s);
            ((s - p[0]) + (h - p[1]) * h1, 1.0 + h1 * h1 + (h - p[1]) * h2)
        };
        // Bracket: the neighbouring vertices, widened until g' changes sign
        // (a few segments at most on a smooth curve).
        let n = self.x.len();
        let (mut a, mut b) = (i.saturating_sub(1), (i + 2).min(n - 1));
        let (mut ga, mut gb) = (derivatives(self.x[a]).0, derivatives(self.x[b]).0);
        for _ in 0..8 {
            if ga <= 0.0 && gb >= 0.0 {
                break;
            }
            if ga > 0.0 && a > 0 {
                a = a.saturating_sub(2);
                ga = derivatives(self.x[a]).0;
            }
            if gb < 0.0 && b < n - 1 {
                b = (b + 2).min(n - 1);
                gb = derivatives(self.x[b]).0;
            }
        }
        if !(ga <= 0.0 && gb >= 0.0) {
            return start;
        }
        let (mut lo, mut hi) = (self.x[a], self.x[b]);
        let mut s = start.clamp(lo, hi);
        for _ in 0..60 {
            let (g, g2) = derivatives(s);
            if g == 0.0 {
                break;
            }
            if g < 0.0 {
                lo = s;
            } else {
                hi = s;
            }
            let newton = s - g / g2;
            let next = if g2 > 0.0 && newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
            if (next - s).abs() <= 1e-15 * (1.0 + s.abs()) || hi - lo <= 1e-15 * (1.0 + s.abs()) {
                s = next;
                break;
            }
            s = next;
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn templates_match_design_formulas() {
        let bump = SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 };
        assert_eq!(bump.height(5.0), 0.3);
        assert!((bump.height(5.75) - 0.3 * (-1.0f64).exp()).abs() < 1e-15);
        let edge = SurfaceShape::Edge { x0: 5.0, width: 1.0, height: 0.2 };
        assert_eq!((edge.height(3.9), edge.height(4.5), edge.height(5.0), edge.height(9.0)), (0.0, 0.1, 0.2, 0.2));
        let sine = SurfaceShape::Sine { x0: 1.0, width: 2.0, height: 0.5 };
        assert!((sine.height(1.5) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn projection_onto_flat_and_slope() {
        let flat = RigidSurface::new(&SurfaceShape::Flat, -5.0, 5.0).unwrap();
        assert!(flat.project([0.0, 0.1]).is_none());
        let p = flat.project([1.0, -0.01]).unwrap();
        assert!((p.depth - 0.01).abs() < 1e-15 && p.normal == [0.0, 1.0] && p.tangent == [1.0, 0.0]);
        assert!((p.arc_mm - 6.0).abs() < 1e-12);
        // A 45-degree ramp: a point below it projects perpendicular to it.
        // (Eleven points: the interpolant is straight between the inner
        // ones, and joins the flat continuation smoothly at the ends.)
        let line: Vec<f64> = (0..=10).map(f64::from).collect();
        let ramp = RigidSurface::new(&SurfaceShape::Sampled { x_mm: line.clone(), h_mm: line }, -1.0, 11.0).unwrap();
        let p = ramp.project([5.0, 4.0]).unwrap();
        assert!((p.depth - 0.5f64.sqrt()).abs() < 1e-12);
        assert!((p.normal[0] + 0.5f64.sqrt()).abs() < 1e-12 && (p.normal[1] - 0.5f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn wide_sampled_interval_is_subdivided_over_the_range_only() {
        // Two points 1e6 mm apart (both within limits::X_MM) across the
        // finger's range: the interval used to be cut into 5 um pieces over
        // its whole width (2e8 vertices, refused by the scenario).
        let shape = SurfaceShape::Sampled { x_mm: vec![0.0, 1e6], h_mm: vec![0.0, 0.0] };
        let segments = RigidSurface::template_segments(&shape, -10.0, 20.0).unwrap();
        assert!(segments <= 4010, "{segments}");
        let s = RigidSurface::new(&shape, -10.0, 20.0).unwrap();
        assert_eq!(s.range(), (-10.0, 1e6));
        assert!(s.x.len() <= segments + 3);
        assert!(s.x.windows(2).all(|w| w[1] > w[0]));
        // 5 um segments from the first point (before it, the flat
        // continuation is one segment) to beyond the range's end.
        let i = s.x.partition_point(|&v| v <= 20.0);
        assert_eq!(s.x[1], 0.0);
        assert!(s.x[1..=i].windows(2).all(|w| w[1] - w[0] <= MAX_SEGMENT_MM * (1.0 + 1e-9)));
        // A slope over the range on a wide interval: finite heights, arcs
        // and projections, and the same polyline vertices over the range
        // as the full subdivision would give.
        let shape = SurfaceShape::Sampled { x_mm: vec![-1e6, 5.0, 1e6], h_mm: vec![-1e3, 0.0, 1e3] };
        let s = RigidSurface::new(&shape, -10.0, 20.0).unwrap();
        assert!(s.x.len() < 6100, "{}", s.x.len());
        for k in 0..=30 {
            let x = -10.0 + k as f64;
            let h = s.height(x);
            assert!(h.is_finite() && s.arc_at(x).is_finite());
            let p = s.project([x, h - 0.01]).unwrap();
            assert!(p.depth > 0.0 && p.depth <= 0.01 + 1e-12 && p.arc_mm.is_finite());
        }
        let step = (5.0 + 1e6) / ((5.0 + 1e6) / MAX_SEGMENT_MM).ceil();
        let k = ((-10.0 + 1e6) / step).floor() as usize;
        assert!(s.x.contains(&(-1e6 + (5.0 + 1e6) * k as f64 / ((5.0 + 1e6) / MAX_SEGMENT_MM).ceil())));
    }

    /// The pruned closest-chord search finds the plain scan's chord and
    /// parameter, to the bit, for points all around and deep under steep,
    /// sharp and sampled surfaces (the pruning is exact by construction:
    /// see `closest_chord`).
    #[test]
    fn pruned_closest_chord_is_the_plain_scan() {
        let shapes = [
            SurfaceShape::Sine { x0: 5.0, width: 0.5, height: 0.5 },
            SurfaceShape::Bump { x0: 5.0, width: 0.5, height: 0.5 },
            SurfaceShape::Edge { x0: 5.0, width: 0.5, height: 0.5 },
            SurfaceShape::Bump { x0: 5.0, width: 2.5, height: 0.1 },
            SurfaceShape::Sampled { x_mm: vec![0.0, 1.0, 1.001, 4.0, 4.2], h_mm: vec![1.0, 1.0, 0.0, 0.3, -0.2] },
        ];
        // A fixed sequence (xorshift), so that the test is deterministic.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for shape in &shapes {
            let s = RigidSurface::new(shape, -2.0, 12.0).unwrap();
            let (mut wide, mut super_wide) = (0usize, 0usize);
            for k in 0..20_000 {
                let x = -2.5 + 15.0 * uniform();
                // Every fourth point up to 8 mm deep, where the window spans
                // many super-boxes (a Newton iterate far inside the surface).
                let depth = if k % 4 == 0 { 8.0 } else { 1.2 };
                let p = [x, s.height(x) - depth * uniform().powi(3)];
                let v = (s.height(p[0]) - p[1]).max(1e-9);
                let first = s.segment(p[0] - v);
                let last = (s.segment(p[0] + v) + 1).max(first + 1);
                let (i, t) = s.closest_chord(p, first, last, false);
                let (j, u) = s.closest_chord(p, first, last, true);
                assert!(i == j && t.to_bits() == u.to_bits(), "{shape:?} at {p:?}: scan ({i}, {t}), pruned ({j}, {u})");
                wide += usize::from(last - first > 4 * BOX_SEGMENTS);
                super_wide += usize::from(last - first > 2 * SUPER_BOXES * BOX_SEGMENTS);
            }
            assert!(wide > 1000 && super_wide > 300, "{shape:?}: only {wide} wide windows tried, {super_wide} wider");
        }
    }

    #[test]
    fn sampled_surface_is_padded_and_projected_at_corners() {
        // A step down: the point under the corner's concave side.
        let s = RigidSurface::new(
            &SurfaceShape::Sampled { x_mm: vec![0.0, 1.0, 1.001], h_mm: vec![1.0, 1.0, 0.0] },
            -2.0,
            3.0,
        )
        .unwrap();
        assert_eq!(s.range(), (-2.0, 3.0));
        assert_eq!(s.height(-1.0), 1.0);
        let p = s.project([0.95, 0.9]).unwrap();
        assert!(p.depth <= 0.1 + 1e-12 && p.depth > 0.0);
    }
}
