//! The rigid surface under the 3D finger: a height field z = h(x, y) in
//! the surface's own frame (x, y in the plane, z up, mm), and what a
//! contact point inside it needs: its depth along the surface's normal and
//! that normal.
//!
//! Depth: for a point q below the surface, d = (h(q_x, q_y) - q_z) c with
//! c = 1 / sqrt(1 + |grad h|^2), its distance to the tangent plane at the
//! surface point above it. Exact for a plane at any inclination; on a
//! curved surface it differs from the distance to the closest point by
//! O(d^2 kappa), which at the penalty's penetrations (below a micrometre)
//! and the templates' curvatures is far below a nanometre. The normal
//! n = c (-h_x, -h_y, 1) is the rigid body's outward unit normal, and
//! dd/dq = -n holds where the gradient is constant (the tangent the
//! contact law uses; the curvature's term is left out, as the 2D model
//! leaves it out after a stall).

use std::sync::Arc;

use haptex_core::height::HeightMap;

use crate::surface::{RigidSurface, SurfaceError, SurfaceShape};

/// A rigid surface in its own frame.
#[derive(Debug, Clone)]
pub enum HeightField {
    /// h = 0.
    Flat,
    /// A 2D surface (a template or a sampled profile) h(x), the same for
    /// every y: the 2D model's surfaces, their ridges along y.
    Extruded(Box<RigidSurface>),
    /// A height map h(x, y) (`haptex map height`'s), as a C2 surface
    /// ([`MapSurface`]), shared (one surface for many runs), with the
    /// surface frame's origin at the map's point `origin_mm`.
    Map { surface: Arc<MapSurface>, origin_mm: [f64; 2] },
}

impl HeightField {
    /// `shape` extruded along y, over x from `x_min` to `x_max` (held flat
    /// beyond); [`HeightField::Flat`] for the flat shape.
    pub fn extruded(shape: &SurfaceShape, x_min: f64, x_max: f64) -> Result<Self, SurfaceError> {
        Ok(match shape {
            SurfaceShape::Flat => Self::Flat,
            _ => Self::Extruded(Box::new(RigidSurface::new(shape, x_min, x_max)?)),
        })
    }

    /// h(x, y) and its gradient (h_x, h_y).
    pub fn height_gradient(&self, x: f64, y: f64) -> (f64, [f64; 2]) {
        let (h, g, _) = self.derivatives(x, y);
        (h, g)
    }

    /// h, its gradient and its Hessian at (x, y).
    fn derivatives(&self, x: f64, y: f64) -> (f64, [f64; 2], [[f64; 2]; 2]) {
        match self {
            Self::Flat => (0.0, [0.0; 2], [[0.0; 2]; 2]),
            Self::Extruded(profile) => {
                let [h, slope, curvature] = profile.height_derivatives(x);
                (h, [slope, 0.0], [[curvature, 0.0], [0.0, 0.0]])
            }
            Self::Map { surface, origin_mm } => surface.derivatives(x + origin_mm[0], y + origin_mm[1]),
        }
    }

    /// The lowest and highest heights over the rectangle [x0, x1] x [y0,
    /// y1] (for the extruded profiles, over [x0, x1]; for a map, bounds
    /// of the spline's there, [`MapSurface::bounds`]).
    pub fn height_range(&self, x: [f64; 2], y: [f64; 2]) -> (f64, f64) {
        match self {
            Self::Flat => (0.0, 0.0),
            Self::Extruded(profile) => (profile.min_height(x[0], x[1]), profile.max_height(x[0], x[1])),
            Self::Map { surface, origin_mm } => {
                surface.bounds([x[0] + origin_mm[0], x[1] + origin_mm[0]], [y[0] + origin_mm[1], y[1] + origin_mm[1]])
            }
        }
    }

    /// The surface as seen from the point `q` (surface frame): its depth
    /// (mm, negative above the surface), the outward unit normal, and
    /// their derivatives with respect to q.
    pub fn at(&self, q: [f64; 3]) -> SurfaceAt {
        let (h, g, hessian) = self.derivatives(q[0], q[1]);
        let c = 1.0 / (1.0 + g[0] * g[0] + g[1] * g[1]).sqrt();
        let a = [-g[0], -g[1], 1.0];
        let mut d_depth = [0.0, 0.0, -c];
        let mut d_normal = [[0.0; 3]; 3];
        for j in 0..2 {
            // dc/dq_j = -c^3 (g . H e_j); da/dq_j = -(H e_j, 0).
            let dc = -c * c * c * (g[0] * hessian[0][j] + g[1] * hessian[1][j]);
            d_depth[j] = g[j] * c + (h - q[2]) * dc;
            let da = [-hessian[0][j], -hessian[1][j], 0.0];
            for i in 0..3 {
                d_normal[i][j] = c * da[i] + a[i] * dc;
            }
        }
        SurfaceAt { depth: (h - q[2]) * c, normal: a.map(|v| v * c), d_depth, d_normal }
    }
}

/// A height map h(x, y) as a surface the contact can use: the
/// interpolating uniform bicubic B-spline of its samples (Unser, "Splines:
/// a perfect fit for signal and image processing", IEEE Signal Processing
/// Magazine 16(6), 1999): through every sample, twice continuously
/// differentiable (the contact's exact tangent needs the curvature), and
/// exact for heights linear in x and y. Beyond the map the edge's heights
/// continue: the samples are padded by [`MapSurface::PAD`] copies of the
/// edge's, and the spline is held at its value five cells beyond the map,
/// where what is left of its slope (the padding's own spline, a kink
/// there) is measured in the tests: 7.4e-4 of the slope at the edge.
///
/// The coefficients c solve the spline's interpolation conditions
/// (c_{i-1} + 4 c_i + c_{i+1}) / 6 = h_i along each row and then each
/// column (tridiagonal, linear time), with c = h at the padding's ends.
#[derive(Debug, Clone, PartialEq)]
pub struct MapSurface {
    x0_mm: f64,
    y0_mm: f64,
    dx_mm: f64,
    dy_mm: f64,
    /// The padded grid's size and its coefficients, row by row.
    nx: usize,
    ny: usize,
    coefficients: Vec<f64>,
}

impl MapSurface {
    /// Samples of the edge's heights added on each side.
    pub const PAD: usize = 6;

    /// The surface of `map` (a validated map: at least 2 x 2 cells).
    pub fn new(map: &HeightMap) -> Self {
        let g = &map.grid;
        let (nx, ny) = (g.nx + 2 * Self::PAD, g.ny + 2 * Self::PAD);
        let mut c = vec![0.0; nx * ny];
        for j in 0..ny {
            let sj = j.saturating_sub(Self::PAD).min(g.ny - 1);
            for i in 0..nx {
                let si = i.saturating_sub(Self::PAD).min(g.nx - 1);
                c[j * nx + i] = map.h_mm[sj * g.nx + si];
            }
        }
        let mut line = Vec::with_capacity(ny);
        let mut scratch = Vec::with_capacity(nx.max(ny));
        for row in c.chunks_exact_mut(nx) {
            interpolating_coefficients(row, &mut scratch);
        }
        for i in 0..nx {
            line.clear();
            line.extend((0..ny).map(|j| c[j * nx + i]));
            interpolating_coefficients(&mut line, &mut scratch);
            for (j, v) in line.iter().enumerate() {
                c[j * nx + i] = *v;
            }
        }
        Self { x0_mm: g.x0_mm, y0_mm: g.y0_mm, dx_mm: g.dx_mm, dy_mm: g.dy_mm, nx, ny, coefficients: c }
    }

    /// Where `v` (mm) lies in the padded grid of origin `v0`, spacing `d`
    /// and `n` points: its index, held within the cells whose four
    /// coefficients exist (1 ..= n - 2, five cells beyond the map; NaN at
    /// the low end), and whether it was held there.
    fn place(v: f64, v0: f64, d: f64, n: usize) -> (f64, bool) {
        let u = (v - v0) / d + Self::PAD as f64;
        let (lo, hi) = (1.0, (n - 2) as f64);
        (if u.is_nan() { lo } else { u.clamp(lo, hi) }, !(u > lo && u < hi))
    }

    /// h, its gradient and its Hessian at (x, y).
    pub fn derivatives(&self, x: f64, y: f64) -> (f64, [f64; 2], [[f64; 2]; 2]) {
        let cell = |v: f64, v0: f64, d: f64, n: usize| -> (usize, f64, bool) {
            let (u, held) = Self::place(v, v0, d, n);
            let i = (u.floor() as usize).min(n - 3);
            (i, u - i as f64, held)
        };
        let (i, tx, held_x) = cell(x, self.x0_mm, self.dx_mm, self.nx);
        let (j, ty, held_y) = cell(y, self.y0_mm, self.dy_mm, self.ny);
        let (wx, dwx, ddwx) = bspline_weights(tx);
        let (wy, dwy, ddwy) = bspline_weights(ty);
        let (mut h, mut hx, mut hy, mut hxx, mut hyy, mut hxy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for b in 0..4 {
            let row = &self.coefficients[(j + b - 1) * self.nx + i - 1..][..4];
            for a in 0..4 {
                let c = row[a];
                h += wx[a] * wy[b] * c;
                hx += dwx[a] * wy[b] * c;
                hy += wx[a] * dwy[b] * c;
                hxx += ddwx[a] * wy[b] * c;
                hyy += wx[a] * ddwy[b] * c;
                hxy += dwx[a] * dwy[b] * c;
            }
        }
        let (sx, sy) = (1.0 / self.dx_mm, 1.0 / self.dy_mm);
        let (mut g, mut hessian) =
            ([hx * sx, hy * sy], [[hxx * sx * sx, hxy * sx * sy], [hxy * sx * sy, hyy * sy * sy]]);
        // Held beyond the map: constant along the held direction.
        if held_x {
            g[0] = 0.0;
            hessian[0] = [0.0; 2];
            hessian[1][0] = 0.0;
        }
        if held_y {
            g[1] = 0.0;
            hessian[1] = [0.0; 2];
            hessian[0][1] = 0.0;
        }
        (h, g, hessian)
    }

    /// Bounds of the spline over [x0, x1] x [y0, y1]: the least and
    /// largest coefficient whose basis reaches the rectangle (the spline
    /// is a convex combination of its coefficients, its B-spline weights
    /// being non-negative and summing to 1). Beyond the map, where the
    /// spline is held, those of the held cells.
    pub fn bounds(&self, x: [f64; 2], y: [f64; 2]) -> (f64, f64) {
        let index = |v: f64, v0: f64, d: f64, n: usize| Self::place(v, v0, d, n).0 as usize;
        let (i0, i1) =
            (index(x[0], self.x0_mm, self.dx_mm, self.nx) - 1, index(x[1], self.x0_mm, self.dx_mm, self.nx) + 2);
        let (j0, j1) =
            (index(y[0], self.y0_mm, self.dy_mm, self.ny) - 1, index(y[1], self.y0_mm, self.dy_mm, self.ny) + 2);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for j in j0..=j1.min(self.ny - 1) {
            for &c in &self.coefficients[j * self.nx + i0..=j * self.nx + i1.min(self.nx - 1)] {
                lo = lo.min(c);
                hi = hi.max(c);
            }
        }
        (lo, hi)
    }
}

/// Replaces the samples `p` by the coefficients of their interpolating
/// cubic B-spline: (c_{i-1} + 4 c_i + c_{i+1}) / 6 = p_i inside, c = p at
/// both ends (Thomas' algorithm; the matrix is diagonally dominant).
fn interpolating_coefficients(p: &mut [f64], diagonal: &mut Vec<f64>) {
    let n = p.len();
    if n < 3 {
        return;
    }
    // Rows 1 .. n-2 of (1 4 1) c = 6 p with c_0 = p_0 and c_{n-1} =
    // p_{n-1} known, solved in place: forward elimination on the interior
    // (sub- and super-diagonals 1), then back substitution.
    let (first, last) = (p[0], p[n - 1]);
    for v in &mut p[1..n - 1] {
        *v *= 6.0;
    }
    p[1] -= first;
    p[n - 2] -= last;
    diagonal.clear();
    diagonal.resize(n, 0.0);
    diagonal[1] = 4.0;
    for i in 2..n - 1 {
        let factor = 1.0 / diagonal[i - 1];
        diagonal[i] = 4.0 - factor;
        p[i] -= factor * p[i - 1];
    }
    p[n - 2] /= diagonal[n - 2];
    for i in (1..n - 2).rev() {
        p[i] = (p[i] - p[i + 1]) / diagonal[i];
    }
}

/// The uniform cubic B-spline's four weights at fraction t of a cell,
/// and their first and second derivatives in t (taps i-1 .. i+2).
fn bspline_weights(t: f64) -> ([f64; 4], [f64; 4], [f64; 4]) {
    let s = 1.0 - t;
    let (t2, t3) = (t * t, t * t * t);
    (
        [s * s * s / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0, (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0],
        [-0.5 * s * s, 1.5 * t2 - 2.0 * t, -1.5 * t2 + t + 0.5, 0.5 * t2],
        [s, 3.0 * t - 2.0, 1.0 - 3.0 * t, t],
    )
}

/// A rigid surface seen from a point (see [`HeightField::at`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceAt {
    /// Depth of the point under the surface (mm; negative above it).
    pub depth: f64,
    /// The outward unit normal n.
    pub normal: [f64; 3],
    /// d depth / dq.
    pub d_depth: [f64; 3],
    /// d n_i / d q_j, row i, column j.
    pub d_normal: [[f64; 3]; 3],
}

impl SurfaceAt {
    /// The same without the curvature's terms in the derivatives (those
    /// of the tangent plane: d depth/dq = -n, dn/dq = 0).
    pub fn without_curvature(self) -> Self {
        Self { d_depth: self.normal.map(|v| -v), d_normal: [[0.0; 3]; 3], ..self }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On an inclined plane (a sampled profile of slope 0.5, extruded),
    /// the depth is the distance to the plane and the normal its own.
    #[test]
    fn depth_on_an_inclined_plane_is_the_distance_to_it() {
        let x_mm = vec![-10.0, -5.0, 0.0, 5.0, 10.0];
        let shape = SurfaceShape::Sampled { h_mm: x_mm.iter().map(|x| x / 2.0).collect(), x_mm };
        let field = HeightField::extruded(&shape, -8.0, 8.0).unwrap();
        let n_exact = [-0.5 / 1.25f64.sqrt(), 0.0, 1.0 / 1.25f64.sqrt()];
        for q in [[0.0, 3.0, -0.2], [1.0, -7.0, 0.1], [-2.0, 0.0, -1.05]] {
            let SurfaceAt { depth: d, normal: n, .. } = field.at(q);
            // Distance of q to the plane z = x / 2 along its normal.
            let exact = -(n_exact[0] * q[0] + n_exact[2] * q[2]);
            assert!((d - exact).abs() < 1e-12, "{q:?}: {d} against {exact}");
            for k in 0..3 {
                assert!((n[k] - n_exact[k]).abs() < 1e-12);
            }
        }
        let flat = HeightField::Flat.at([4.0, -2.0, -0.3]);
        assert_eq!((flat.depth, flat.normal), (0.3, [0.0, 0.0, 1.0]));
    }

    /// The derivatives of depth and normal are those of the functions
    /// (central differences) on a curved surface: an extruded bump.
    #[test]
    fn derivatives_on_a_bump_match_differences() {
        let shape = SurfaceShape::Bump { x0: 0.5, width: 1.5, height: 0.3 };
        let field = HeightField::extruded(&shape, -5.0, 5.0).unwrap();
        assert_derivatives_match(&field, &[[0.0, 1.0, 0.2], [0.9, -3.0, 0.1], [1.4, 0.0, -0.05]], 1e-7);
    }

    /// `field`'s depth and normal derivatives at each of `points` against
    /// central differences of 1e-6 mm, within `tolerance`.
    fn assert_derivatives_match(field: &HeightField, points: &[[f64; 3]], tolerance: f64) {
        for &q in points {
            let at = field.at(q);
            for j in 0..3 {
                let h = 1e-6;
                let (mut a, mut b) = (q, q);
                a[j] += h;
                b[j] -= h;
                let (fa, fb) = (field.at(a), field.at(b));
                let numeric = (fa.depth - fb.depth) / (2.0 * h);
                assert!((numeric - at.d_depth[j]).abs() < tolerance, "d depth/dq{j} at {q:?}: {numeric}");
                for i in 0..3 {
                    let numeric = (fa.normal[i] - fb.normal[i]) / (2.0 * h);
                    assert!((numeric - at.d_normal[i][j]).abs() < tolerance, "dn{i}/dq{j} at {q:?}");
                }
            }
        }
    }

    fn map_of(nx: usize, ny: usize, d: f64, origin: [f64; 2], h: impl Fn(f64, f64) -> f64) -> HeightMap {
        let grid = haptex_core::map::MapGrid { nx, ny, x0_mm: origin[0], y0_mm: origin[1], dx_mm: d, dy_mm: d };
        let mut heights = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                heights.push(h(origin[0] + d * i as f64, origin[1] + d * j as f64));
            }
        }
        HeightMap::new(grid, heights, "test").unwrap()
    }

    /// The spline passes through every sample (to rounding) of an
    /// irregular map, and reproduces a plane's height and slope away from
    /// the map's edges (within 1e-9: the edge padding's influence falls
    /// by 2 - sqrt(3) = 0.27 per cell).
    #[test]
    fn map_surface_interpolates_and_is_exact_on_a_plane() {
        let rough = |x: f64, y: f64| (3.1 * x).sin() * (1.7 * y).cos() * 0.2 + 0.05 * x;
        let map = map_of(23, 17, 0.25, [-2.0, -1.0], rough);
        let surface = MapSurface::new(&map);
        for j in 0..17 {
            for i in 0..23 {
                let (x, y) = (-2.0 + 0.25 * i as f64, -1.0 + 0.25 * j as f64);
                let (h, _, _) = surface.derivatives(x, y);
                assert!((h - rough(x, y)).abs() < 1e-12, "({x}, {y}): {h} against {}", rough(x, y));
            }
        }
        let plane = |x: f64, y: f64| 0.3 * x - 0.2 * y + 0.1;
        let surface = MapSurface::new(&map_of(60, 60, 0.1, [0.0, 0.0], plane));
        for (x, y) in [(3.0, 3.0), (2.537, 3.981), (4.0, 2.0)] {
            let (h, g, hessian) = surface.derivatives(x, y);
            assert!((h - plane(x, y)).abs() < 1e-9, "{h}");
            assert!((g[0] - 0.3).abs() < 1e-9 && (g[1] + 0.2).abs() < 1e-9, "{g:?}");
            assert!(hessian.iter().flatten().all(|v| v.abs() < 1e-7), "{hessian:?}");
        }
    }

    /// The map's depth and normal have the derivatives of the functions
    /// (central differences), inside the map and near its edge; beyond
    /// the map the surface is held, and the slope left where it is held is
    /// 7.4e-4 of the edge's (measured, PAD = 6 cells; bound 2e-3).
    #[test]
    fn map_surface_derivatives_match_differences_and_it_is_held_beyond() {
        let bump = SurfaceShape::Bump { x0: 0.5, width: 1.5, height: 0.3 };
        let profile = RigidSurface::new(&bump, -6.0, 6.0).unwrap();
        let map = map_of(81, 41, 0.1, [-4.0, -2.0], |x, y| profile.height(x) * (1.0 - 0.05 * y));
        let field = HeightField::Map { surface: Arc::new(MapSurface::new(&map)), origin_mm: [0.0; 2] };
        let points = [[0.0, 1.0, 0.2], [0.93, -1.37, 0.1], [1.4, 0.0, -0.05], [-3.87, 1.91, 0.0]];
        assert_derivatives_match(&field, &points, 1e-6);
        // A ramp in x: the slope just inside the hold, five cells beyond
        // the map's last column, against the ramp's.
        let ramp = MapSurface::new(&map_of(30, 30, 0.1, [0.0, 0.0], |x, _| 0.2 * x));
        let (_, g, _) = ramp.derivatives(2.9 + 0.1 * 4.999, 1.5);
        let left = g[0] / 0.2;
        assert!(left.abs() < 2e-3, "slope left where held: {left}");
        let (h_far, g_far, _) = ramp.derivatives(100.0, 1.5);
        let (h_hold, _, _) = ramp.derivatives(2.9 + 0.5, 1.5);
        assert_eq!(g_far[0], 0.0);
        assert!((h_far - h_hold).abs() < 1e-12 && (h_far - 0.58).abs() < 1e-3, "{h_far}");
        // Non-finite positions are held too, never a panic.
        assert!(ramp.derivatives(f64::NAN, f64::INFINITY).0.is_finite());
    }
}
