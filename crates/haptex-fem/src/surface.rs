//! The rigid reference surface y = h(x): the templates of design.md (flat,
//! bump, edge, sine) or a sampled height profile, represented as a fine
//! polyline so that every shape — smooth or with corners — is handled by
//! the same exact closest-point projection.
//!
//! The rigid body occupies y < h(x). A point is inside (penetrating) iff
//! y < h(x) on the polyline; its closest boundary point lies within the
//! vertical distance h(x) - y of it, which bounds the segments searched.

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
    /// A height profile given point by point (x strictly increasing),
    /// linear between points and held flat beyond the ends.
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
    /// Height h(x) in mm.
    pub fn height(&self, x: f64) -> f64 {
        match self {
            SurfaceShape::Flat => 0.0,
            SurfaceShape::Bump { x0, width, height } => Template::Bump.height_mm(x, *x0, *width, *height),
            SurfaceShape::Edge { x0, width, height } => Template::Edge.height_mm(x, *x0, *width, *height),
            SurfaceShape::Sine { x0, width, height } => Template::Sine.height_mm(x, *x0, *width, *height),
            SurfaceShape::Sampled { x_mm, h_mm } => haptex_core::profile::interpolate(x_mm, h_mm, x),
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
                .error_at(
                    Some(i + 1),
                    Some("x_mm"),
                    format!("x must be strictly increasing: {} follows {}", Num(x[i + 1]), Num(x[i])),
                )
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

/// The closest point of the surface to a penetrating point.
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
}

/// A surface as a polyline over a range of x, in its own frame.
#[derive(Debug, Clone)]
pub struct RigidSurface {
    x: Vec<f64>,
    h: Vec<f64>,
    arc: Vec<f64>,
    /// (first x, 1/spacing) when the vertices are uniformly spaced: O(1)
    /// segment lookup (templates), else binary search (sampled files).
    uniform: Option<(f64, f64)>,
}

impl RigidSurface {
    /// Samples `shape` over [x_min, x_max] (mm). Templates are sampled at
    /// 1/200 of their width (at most 5 um) — chord error below 1e-4 mm at
    /// the sharpest corner of the database range; sampled surfaces keep
    /// their own points, padded flat to the range. The shape must be valid
    /// ([`SurfaceShape::validate`]) and the polyline at most
    /// [`limits::MAX_VERTICES`] long.
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
        let (mut x, mut h) = match shape {
            SurfaceShape::Sampled { x_mm, h_mm } => (x_mm.clone(), h_mm.clone()),
            _ => {
                let n = segments;
                let x: Vec<f64> = (0..=n).map(|i| x_min + (x_max - x_min) * i as f64 / n as f64).collect();
                let h = x.iter().map(|&x| shape.height(x)).collect();
                (x, h)
            }
        };
        if x[0] > x_min {
            x.insert(0, x_min);
            h.insert(0, h[0]);
        }
        if x[x.len() - 1] < x_max {
            x.push(x_max);
            h.push(h[h.len() - 1]);
        }
        let mut arc = vec![0.0; x.len()];
        for i in 1..x.len() {
            arc[i] = arc[i - 1] + (x[i] - x[i - 1]).hypot(h[i] - h[i - 1]);
        }
        let n = x.len();
        let spacing = (x[n - 1] - x[0]) / (n - 1) as f64;
        let uniform =
            x.windows(2).all(|w| ((w[1] - w[0]) / spacing - 1.0).abs() < 1e-9).then_some((x[0], 1.0 / spacing));
        Ok(Self { x, h, arc, uniform })
    }

    /// The number of segments a template is sampled with over [x_min,
    /// x_max] (at r_w/200, at most 5 um; 0 for a sampled surface, which
    /// keeps its points); an error beyond [`limits::MAX_VERTICES`].
    pub fn template_segments(shape: &SurfaceShape, x_min: f64, x_max: f64) -> Result<usize, SurfaceError> {
        if let SurfaceShape::Sampled { .. } = shape {
            return Ok(0);
        }
        let dx = shape.detail_mm().min(0.005);
        let count = ((x_max - x_min) / dx).ceil();
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

    /// Polyline height at x (held flat outside the range).
    pub fn height(&self, x: f64) -> f64 {
        let i = self.segment(x);
        let t = ((x - self.x[i]) / (self.x[i + 1] - self.x[i])).clamp(0.0, 1.0);
        self.h[i] + t * (self.h[i + 1] - self.h[i])
    }

    /// Highest point over [a, b].
    pub fn max_height(&self, a: f64, b: f64) -> f64 {
        let i0 = self.x.partition_point(|&v| v < a);
        let i1 = self.x.partition_point(|&v| v <= b);
        self.h[i0..i1].iter().cloned().fold(self.height(a).max(self.height(b)), f64::max)
    }

    /// Lowest point over [a, b].
    pub fn min_height(&self, a: f64, b: f64) -> f64 {
        let i0 = self.x.partition_point(|&v| v < a);
        let i1 = self.x.partition_point(|&v| v <= b);
        self.h[i0..i1].iter().cloned().fold(self.height(a).min(self.height(b)), f64::min)
    }

    /// Arc-length coordinate of the surface point below x.
    pub fn arc_at(&self, x: f64) -> f64 {
        let i = self.segment(x);
        let t = ((x - self.x[i]) / (self.x[i + 1] - self.x[i])).clamp(0.0, 1.0);
        self.arc[i] + t * (self.arc[i + 1] - self.arc[i])
    }

    /// The closest surface point of `p` (surface frame) if p is inside the
    /// rigid body (y < h(x)), else `None`.
    pub fn project(&self, p: [f64; 2]) -> Option<Projection> {
        let vertical = self.height(p[0]) - p[1];
        if vertical.is_nan() || vertical <= 0.0 {
            return None;
        }
        // Segments meeting the window [x - vertical, x + vertical].
        let first = self.segment(p[0] - vertical);
        let last = (self.segment(p[0] + vertical) + 1).max(first + 1);
        let mut best = (f64::INFINITY, 0usize, 0.0);
        for i in first..last {
            let (ax, ay) = (self.x[i], self.h[i]);
            let (dx, dy) = (self.x[i + 1] - ax, self.h[i + 1] - ay);
            let t = (((p[0] - ax) * dx + (p[1] - ay) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
            let d2 = (ax + t * dx - p[0]).powi(2) + (ay + t * dy - p[1]).powi(2);
            if d2 < best.0 {
                best = (d2, i, t);
            }
        }
        let (d2, i, t) = best;
        let (dx, dy) = (self.x[i + 1] - self.x[i], self.h[i + 1] - self.h[i]);
        let length = dx.hypot(dy);
        let c = [self.x[i] + t * dx, self.h[i] + t * dy];
        let depth = d2.sqrt();
        // Outward normal: from the point to its closest point; on a segment
        // interior (or for a point on the surface) this is the segment normal.
        let normal = if t > 0.0 && t < 1.0 || depth < 1e-12 {
            [-dy / length, dx / length]
        } else {
            [(c[0] - p[0]) / depth, (c[1] - p[1]) / depth]
        };
        Some(Projection { depth, normal, tangent: [normal[1], -normal[0]], arc_mm: self.arc[i] + t * length })
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
        let ramp =
            RigidSurface::new(&SurfaceShape::Sampled { x_mm: vec![0.0, 10.0], h_mm: vec![0.0, 10.0] }, -1.0, 11.0)
                .unwrap();
        let p = ramp.project([5.0, 4.0]).unwrap();
        assert!((p.depth - 0.5f64.sqrt()).abs() < 1e-12);
        assert!((p.normal[0] + 0.5f64.sqrt()).abs() < 1e-12 && (p.normal[1] - 0.5f64.sqrt()).abs() < 1e-12);
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
