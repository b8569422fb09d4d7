//! Kernel widths w_nl and the Gaussian kernel of eq. (12) in log space.
//!
//! Widths are in normalized input units (each input spans [0, 1] over the
//! database). Two forms:
//!
//! - constant: w_nl = w for every model vector n and input l: the CAE is
//!   then Nadaraya-Watson regression with a Gaussian kernel;
//! - non-constant (Perus et al. 2006, "non-constant width"): w_nl between
//!   w_min and w_max, wider where the model vectors are sparse. The rule
//!   implemented here (haptex's own statement; see `docs/cae.md` for what
//!   could and could not be confirmed from the literature):
//!
//!   w_nl = w_min + (w_max - w_min) (1 - q_nl),
//!
//!   where q_nl in (0, 1] is the relative density of the database along
//!   input l at the model vector's value b_nl: p_l(b) = sum_m exp(-(b -
//!   b_ml)^2 / (2 h_l^2)) (a Gaussian kernel density estimate of input l's
//!   marginal distribution, in normalized units, with Silverman's
//!   rule-of-thumb pilot width h_l = 1.06 s_l N^(-1/5), s_l the sample
//!   standard deviation of the normalized input) and q_nl = p_l(b_nl) /
//!   max_m p_l(b_ml). The densest value gets exactly w_min, and widths grow
//!   linearly towards w_max as the density falls. With w_min = w_max every
//!   width is exactly w_min: the constant-width estimator.

use serde::Serialize;

use super::{CaeError, Normalization};
use crate::num::Num;

/// The width parameters: w_min and w_max in normalized input units
/// (equal for a constant width).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct Widths {
    pub w_min: f64,
    pub w_max: f64,
}

impl Widths {
    /// Smallest width accepted: far below any spacing of model vectors,
    /// and 1/(2 w^2) stays finite.
    pub const SMALLEST: f64 = 1e-9;
    /// Largest width accepted (the database spans 1 in every input).
    pub const LARGEST: f64 = 1e9;

    /// One constant width `w` for every model vector and input.
    pub fn constant(w: f64) -> Result<Self, CaeError> {
        Self::range(w, w)
    }

    /// Non-constant widths between `w_min` and `w_max`
    /// ([`Widths::SMALLEST`] <= w_min <= w_max <= [`Widths::LARGEST`]).
    pub fn range(w_min: f64, w_max: f64) -> Result<Self, CaeError> {
        for (name, w) in [("w_min", w_min), ("w_max", w_max)] {
            if !(w.is_finite() && w > 0.0) {
                return Err(CaeError::Width(format!("{name} must be a positive finite number, got {}", Num(w))));
            }
            if !(Self::SMALLEST..=Self::LARGEST).contains(&w) {
                return Err(CaeError::Width(format!(
                    "{name} = {} is outside {} .. {} (normalized input units)",
                    Num(w),
                    Num(Self::SMALLEST),
                    Num(Self::LARGEST)
                )));
            }
        }
        if w_min > w_max {
            return Err(CaeError::Width({
                let (w_min, w_max) = crate::num::distinct(w_min, w_max);
                format!("w_min = {w_min} is larger than w_max = {w_max}")
            }));
        }
        Ok(Self { w_min, w_max })
    }

    /// True when every width is the same (w_min = w_max).
    pub fn is_constant(&self) -> bool {
        self.w_min == self.w_max
    }

    /// Fills the N x D widths w_nl (row-major). `density` is needed only
    /// for non-constant widths.
    pub fn fill(&self, density: Option<&Density>, out: &mut [f64]) {
        match density {
            Some(density) if !self.is_constant() => {
                // w_min + span (1 - q): exactly w_min where q = 1.
                let span = self.w_max - self.w_min;
                for (w, q) in out.iter_mut().zip(&density.q) {
                    *w = self.w_min + span * (1.0 - q);
                }
            }
            _ => {
                assert!(self.is_constant(), "non-constant widths need the density of the model vectors");
                out.fill(self.w_min);
            }
        }
    }
}

/// The relative density q_nl of the model vectors along each input, at
/// each model vector (the input of the non-constant width rule).
#[derive(Debug, Clone, PartialEq)]
pub struct Density {
    /// N x D relative densities in (0, 1], row-major (1 for constant inputs).
    q: Vec<f64>,
    /// Pilot width h_l per input, normalized units (0 for constant inputs).
    pilot: Vec<f64>,
}

impl Density {
    /// Relative marginal densities at the model vectors `bn` (N x D,
    /// normalized units, row-major).
    pub fn new(norm: &Normalization, bn: &[f64]) -> Self {
        let d = norm.d();
        let n = bn.len() / d;
        let mut q = vec![1.0; n * d];
        let mut pilot = vec![0.0; d];
        for l in (0..d).filter(|&l| !norm.is_constant(l)) {
            let values: Vec<f64> = bn.chunks_exact(d).map(|row| row[l]).collect();
            let mean = values.iter().sum::<f64>() / n as f64;
            let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
            // Silverman (1986), eq. (3.28): h = 1.06 sigma N^(-1/5).
            let h = 1.06 * var.sqrt() * (n as f64).powf(-0.2);
            pilot[l] = h;
            // The density at each distinct value, counting repeats once each:
            // a gridded database has few distinct values per input.
            let mut distinct = values.clone();
            distinct.sort_by(f64::total_cmp);
            let mut counts: Vec<(f64, f64)> = Vec::new();
            for v in distinct {
                match counts.last_mut() {
                    Some((u, c)) if *u == v => *c += 1.0,
                    _ => counts.push((v, 1.0)),
                }
            }
            let inv_2h2 = 1.0 / (2.0 * h * h);
            let p: Vec<f64> = counts
                .iter()
                .map(|(u, _)| counts.iter().map(|(v, c)| c * (-(u - v) * (u - v) * inv_2h2).exp()).sum())
                .collect();
            let p_max = p.iter().copied().fold(0.0, f64::max);
            for (row, v) in values.iter().enumerate() {
                let j = counts.partition_point(|(u, _)| u < v);
                q[row * d + l] = p[j] / p_max;
            }
        }
        Self { q, pilot }
    }

    /// Relative densities q_nl, N x D row-major.
    pub fn relative(&self) -> &[f64] {
        &self.q
    }

    /// Pilot widths h_l of the marginal density estimates, normalized units.
    pub fn pilot_widths(&self) -> &[f64] {
        &self.pilot
    }
}

/// The Gaussian of eq. (12) for every model vector, in log space and
/// normalized input units:
///
/// ln a_n = -sum_l ln w_nl - sum_l coef_nl (b'_l - b'_nl)^2 + const,
/// coef_nl = 1 / (2 w_nl^2),
///
/// the sums running over the non-constant inputs. The constant
/// -(D/2) ln(2 pi) is the same for every n and cancels in eq. (11). Stored
/// input by input (column-major, D x N), so the weights of all model
/// vectors are D vectorizable passes over N values.
#[derive(Debug, Clone, PartialEq)]
pub struct Kernel {
    n: usize,
    d: usize,
    /// D x N coefficients coef_nl, column-major (0 for constant inputs).
    coef_t: Vec<f64>,
    /// N log normalizers -sum_l ln w_nl.
    log_norm: Vec<f64>,
}

impl Kernel {
    /// A kernel for `n` model vectors with all coefficients zero.
    pub fn zeros(n: usize, d: usize) -> Self {
        Self { n, d, coef_t: vec![0.0; n * d], log_norm: vec![0.0; n] }
    }

    /// Sets the coefficients from the N x D widths `w` (normalized units,
    /// row-major).
    pub fn set(&mut self, norm: &Normalization, w: &[f64]) {
        let (n, d) = (self.n, self.d);
        self.log_norm.fill(0.0);
        for l in 0..d {
            let coef = &mut self.coef_t[l * n..(l + 1) * n];
            if norm.is_constant(l) {
                coef.fill(0.0);
                continue;
            }
            for ((c, log_norm), w) in coef.iter_mut().zip(&mut self.log_norm).zip(w.chunks_exact(d)) {
                *c = 0.5 / (w[l] * w[l]);
                *log_norm -= w[l].ln();
            }
        }
    }

    /// ln a_n (up to the common constant) of the normalized query `b` for
    /// every model vector, into `log_a`; `x_t` holds the normalized model
    /// inputs column-major (D x N, see [`transpose`]). log_norm_n - ln a_n = sum_l coef_nl (b_l -
    /// b_nl)^2, whose square root times sqrt(2) is the query's distance
    /// from vector n in kernel widths.
    #[inline(always)]
    pub fn log_weights(&self, x_t: &[f64], b: &[f64], log_a: &mut [f64]) {
        self.log_weights_and_distances(x_t, b, |_| false, log_a, &mut []);
    }

    /// [`Kernel::log_weights`] and, in the same pass, the squared
    /// normalized distances sum_l (b_l - b_nl)^2 over the inputs
    /// `in_distance(l)` is true for, into `d2` (it needs N values when
    /// some input is in the distance, and may be empty otherwise).
    ///
    /// Four model vectors at a time, the inputs inner: their ln a_n and
    /// distances stay in registers over the D inputs and are stored once,
    /// instead of D passes that each load and store them (the weights of
    /// one prediction at N 405, D 4, `weights_constant_w0.13_m4` in the
    /// CAE benchmark, took 1.55 against 1.73 µs, AMD EPYC, 2026-11-28).
    /// The same operations in the same order for every vector, so the same
    /// bits.
    #[inline(always)]
    pub fn log_weights_and_distances(
        &self,
        x_t: &[f64],
        b: &[f64],
        in_distance: impl Fn(usize) -> bool,
        log_a: &mut [f64],
        d2: &mut [f64],
    ) {
        let (n, d) = (self.n, self.d);
        let b = &b[..d];
        let (x_t, coef_t, log_a) = (&x_t[..d * n], &self.coef_t[..d * n], &mut log_a[..n]);
        let keep_d2 = d2.len() >= n;
        // One vector's ln a_n and distance from input 0 on.
        let vector = |j: usize| {
            let (mut a, mut s) = (self.log_norm[j], 0.0);
            for (l, &bl) in b.iter().enumerate() {
                let diff = bl - x_t[l * n + j];
                a -= coef_t[l * n + j] * diff * diff;
                if in_distance(l) {
                    s += diff * diff;
                }
            }
            (a, s)
        };
        let whole = n - n % 4;
        for j in (0..whole).step_by(4) {
            let mut a: [f64; 4] = self.log_norm[j..j + 4].try_into().expect("four values");
            let mut s = [0.0; 4];
            for (l, &bl) in b.iter().enumerate() {
                let x: &[f64; 4] = x_t[l * n + j..l * n + j + 4].try_into().expect("four values");
                let c: &[f64; 4] = coef_t[l * n + j..l * n + j + 4].try_into().expect("four values");
                let diff = x.map(|x| bl - x);
                for i in 0..4 {
                    a[i] -= c[i] * diff[i] * diff[i];
                }
                if in_distance(l) {
                    for i in 0..4 {
                        s[i] += diff[i] * diff[i];
                    }
                }
            }
            log_a[j..j + 4].copy_from_slice(&a);
            if keep_d2 {
                d2[j..j + 4].copy_from_slice(&s);
            }
        }
        for j in whole..n {
            let (a, s) = vector(j);
            log_a[j] = a;
            if keep_d2 {
                d2[j] = s;
            }
        }
    }

    /// The log normalizers -sum_l ln w_nl.
    pub fn log_norm(&self) -> &[f64] {
        &self.log_norm
    }
}

/// An N x D row-major block as D x N column-major.
pub fn transpose(b: &[f64], d: usize) -> Vec<f64> {
    let n = b.len() / d;
    (0..d).flat_map(|l| (0..n).map(move |r| b[r * d + l])).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_bounds_give_exactly_constant_widths() {
        let b = [0.0, 0.1, 0.2, 0.9, 1.0];
        let norm = Normalization::fit(&b, 1).unwrap();
        let density = Density::new(&norm, &norm.normalize_rows(&b));
        let mut w = [0.0; 5];
        Widths::constant(0.13).unwrap().fill(Some(&density), &mut w);
        assert!(w.iter().all(|&w| w == 0.13));
    }

    #[test]
    fn sparse_vectors_get_wider_kernels() {
        // Four values clustered near 0, one alone at 1.
        let b = [0.0, 0.05, 0.1, 0.15, 1.0];
        let norm = Normalization::fit(&b, 1).unwrap();
        let density = Density::new(&norm, &norm.normalize_rows(&b));
        let mut w = [0.0; 5];
        Widths::range(0.1, 0.3).unwrap().fill(Some(&density), &mut w);
        assert!(w.iter().all(|&w| (0.1..=0.3).contains(&w)), "{w:?}");
        assert!(w[4] > w[1] + 0.05, "{w:?}");
        assert_eq!(w.iter().copied().fold(f64::INFINITY, f64::min), 0.1);
    }

    #[test]
    fn width_validation() {
        assert!(Widths::constant(0.0).is_err());
        assert!(Widths::constant(f64::NAN).is_err());
        assert!(Widths::range(0.3, 0.2).is_err());
        assert!(Widths::range(0.2, 0.3).is_ok());
    }
}
