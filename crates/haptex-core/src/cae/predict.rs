//! Prediction by the conditional average, eqs. (11)-(12):
//!
//! c_k = sum_n a_n c_nk / sum_n a_n,
//! a_n = (2 pi)^(-D/2) / prod_l w_nl * exp[ -sum_l (b_l - b_nl)^2 / (2 w_nl^2) ]
//!
//! evaluated in log space: ln a_n is computed for every model vector, the
//! largest is subtracted before exponentiating, so the largest weight is 1
//! and a query far from every model vector gives finite outputs (close to
//! those of the nearest vectors) instead of 0/0. Weights below
//! exp(LOG_WEIGHT_CUTOFF) of the largest are skipped: together they change
//! an output by less than N e^-46 = N 1.1e-20 of the largest |c_nk|, far
//! below double rounding for any database that fits in memory. Beyond
//! that cutoff, when every output is of one sign over the database and
//! never zero, the model vectors whose outputs cannot change any output by
//! more than PRUNE_RELATIVE = 1e-16 of its value are not read at all
//! (`prune`, which states the bound).
//!
//! Memory layout for speed: outputs are stored row-major, so eq. (11) is a
//! sum of contiguous rows a_n C_n over the listed rows, accumulated four
//! rows at a time into the caller's output buffer. A prediction allocates
//! nothing.

use super::prune::{Pruning, weighted_sum};
use super::widths::transpose;
use super::{CaeError, Density, Kernel, ModelMatrix, Normalization, Widths};
use crate::num::Num;

/// A query whose nearest model vector is farther than this many kernel
/// widths (sqrt(sum_l ((b_l - b_nl) / w_nl)^2) in normalized units) is
/// flagged as an extrapolation: there the largest Gaussian of eq. (12) is
/// below exp(-9/2) = 1.1% of its peak, and the prediction is carried by the
/// tails of the kernels (paper footnote 6: "extreme extrapolation of results
/// may lead to erroneous values").
pub const EXTRAPOLATION_KERNEL_DISTANCE: f64 = 3.0;

/// Model vectors whose ln a_n is more than 46 below the largest are
/// skipped (relative weight < 1.1e-20).
pub const LOG_WEIGHT_CUTOFF: f64 = -46.0;

/// The conditional average estimator over a model matrix with given widths.
#[derive(Debug, Clone)]
pub struct Cae {
    matrix: ModelMatrix,
    norm: Normalization,
    widths: Widths,
    /// N x D kernel widths w_nl, normalized units.
    w: Vec<f64>,
    kernel: Kernel,
    /// D x N normalized inputs, column-major (the kernel's layout).
    x_t: Vec<f64>,
    /// Which model vectors a prediction may leave out.
    pruning: Pruning,
}

/// Per-query working memory (one value per model vector). Make one with
/// [`Cae::scratch`] and reuse it for every query.
#[derive(Debug, Clone)]
pub struct Scratch {
    log_a: Vec<f64>,
    d2: Vec<f64>,
    query: Vec<f64>,
    /// The rows that enter eq. (11) and their weights (the first
    /// `Diagnostics::weights_used`).
    rows: Vec<usize>,
    weights: Vec<f64>,
}

/// What a prediction knows about where the query lies relative to the
/// database.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Diagnostics {
    /// Row (0-based) of the model vector nearest to the query in normalized
    /// Euclidean distance.
    pub nearest_row: usize,
    /// Its distance in normalized input units (constant inputs left out).
    pub nearest_distance: f64,
    /// The smallest distance to any model vector measured in that vector's
    /// kernel widths, sqrt(sum_l ((b_l - b_nl) / w_nl)^2).
    pub kernel_distance: f64,
    /// An input (index) whose normalized query value lies outside [0, 1],
    /// i.e. beyond the database's range, if any.
    pub outside_range: Option<usize>,
    /// A constant input (index) the query gives another value, if any.
    pub constant_mismatch: Option<usize>,
    /// Number of model vectors whose weight entered the sum.
    pub weights_used: usize,
}

impl Diagnostics {
    /// True if the query is an extrapolation: farther than
    /// [`EXTRAPOLATION_KERNEL_DISTANCE`] kernel widths from every model
    /// vector, or off the value of a constant input.
    pub fn is_extrapolation(&self) -> bool {
        self.kernel_distance > EXTRAPOLATION_KERNEL_DISTANCE || self.constant_mismatch.is_some()
    }
}

impl Cae {
    /// The estimator over `matrix` with kernel widths from `widths`
    /// (normalized input units).
    pub fn new(matrix: ModelMatrix, widths: Widths) -> Result<Self, CaeError> {
        let widths = Widths::range(widths.w_min, widths.w_max)?;
        let (n, d) = (matrix.n(), matrix.d());
        let norm = Normalization::fit(matrix.inputs_flat(), d)?;
        let density = (!widths.is_constant()).then(|| Density::new(&norm, &norm.normalize_rows(matrix.inputs_flat())));
        let mut w = vec![0.0; n * d];
        widths.fill(density.as_ref(), &mut w);
        let mut kernel = Kernel::zeros(n, d);
        kernel.set(&norm, &w);
        let x_t = transpose(&norm.normalize_rows(matrix.inputs_flat()), d);
        let pruning = Pruning::new(&matrix);
        Ok(Self { matrix, norm, widths, w, kernel, x_t, pruning })
    }

    /// The model matrix.
    pub fn matrix(&self) -> &ModelMatrix {
        &self.matrix
    }

    /// The input normalization.
    pub fn normalization(&self) -> &Normalization {
        &self.norm
    }

    /// The width parameters.
    pub fn widths(&self) -> Widths {
        self.widths
    }

    /// The kernel widths w_nl, N x D row-major, normalized units.
    pub fn kernel_widths(&self) -> &[f64] {
        &self.w
    }

    /// True if predictions leave out the model vectors whose outputs cannot
    /// change any output by more than [`PRUNE_RELATIVE`](super::PRUNE_RELATIVE) of its value
    /// (possible when every output is of one sign over the database and
    /// never zero; `docs/cae.md`, "Speed").
    pub fn prunes(&self) -> bool {
        self.pruning.is_active()
    }

    /// Working memory for [`Cae::predict_into`].
    pub fn scratch(&self) -> Scratch {
        let (n, d) = (self.matrix.n(), self.matrix.d());
        Scratch { log_a: vec![0.0; n], d2: vec![0.0; n], query: vec![0.0; d], rows: vec![0; n], weights: vec![0.0; n] }
    }

    /// Predicts the M outputs at the input vector `b` (D values in the
    /// model's input order and units) into `out`, eqs. (11)-(12). Allocates
    /// nothing.
    pub fn predict_into(&self, b: &[f64], scratch: &mut Scratch, out: &mut [f64]) -> Result<Diagnostics, CaeError> {
        let (n, d, m) = (self.matrix.n(), self.matrix.d(), self.matrix.m());
        if b.len() != d {
            return Err(CaeError::Query(format!("a query needs {d} input values, got {}", b.len())));
        }
        if let Some(l) = b.iter().position(|v| !v.is_finite()) {
            return Err(CaeError::Query(format!("input '{}' is not finite: {}", self.matrix.inputs()[l], b[l])));
        }
        let scratch_ok = [scratch.log_a.len(), scratch.d2.len(), scratch.rows.len(), scratch.weights.len()] == [n; 4]
            && scratch.query.len() == d;
        if out.len() != m || !scratch_ok {
            return Err(CaeError::Query(format!(
                "buffers of {} outputs and {} scratch values for a model with {m} outputs and {n} rows",
                out.len(),
                scratch.log_a.len()
            )));
        }

        for (l, (q, &v)) in scratch.query.iter_mut().zip(b).enumerate() {
            *q = self.norm.normalize(l, v);
        }
        let mut pass = evaluate(self, scratch, out);
        let overflowed = !pass.sum.is_finite() || pass.sum <= 0.0;
        if overflowed {
            // So far out that the squared distances overflow: predict at the
            // query clamped into the database's box instead (flagged below).
            for q in scratch.query.iter_mut() {
                *q = q.clamp(0.0, 1.0);
            }
            pass = evaluate(self, scratch, out);
            pass.s_min = f64::INFINITY;
            pass.nearest_d2 = f64::INFINITY;
        }
        let mut outside_range = None;
        let mut constant_mismatch = None;
        for (l, &v) in b.iter().enumerate() {
            if self.norm.is_constant(l) {
                if v != self.norm.min(l) && constant_mismatch.is_none() {
                    constant_mismatch = Some(l);
                }
            } else if !(0.0..=1.0).contains(&self.norm.normalize(l, v)) && outside_range.is_none() {
                outside_range = Some(l);
            }
        }

        let inv = 1.0 / pass.sum;
        for o in out.iter_mut() {
            *o *= inv;
        }
        Ok(Diagnostics {
            nearest_row: pass.nearest_row,
            nearest_distance: pass.nearest_d2.sqrt(),
            kernel_distance: (2.0 * pass.s_min.max(0.0)).sqrt(),
            outside_range,
            constant_mismatch,
            weights_used: pass.used,
        })
    }

    /// [`Cae::predict_into`] with freshly allocated buffers.
    pub fn predict(&self, b: &[f64]) -> Result<(Vec<f64>, Diagnostics), CaeError> {
        let mut out = vec![0.0; self.matrix.m()];
        let diagnostics = self.predict_into(b, &mut self.scratch(), &mut out)?;
        Ok((out, diagnostics))
    }

    /// The extrapolation warning for a query, if it is one, naming the
    /// inputs and the nearest model vector.
    pub fn warning(&self, b: &[f64], diagnostics: &Diagnostics) -> Option<String> {
        if !diagnostics.is_extrapolation() {
            return None;
        }
        let names = self.matrix.inputs();
        if let Some(l) = diagnostics.constant_mismatch {
            return Some(format!(
                "input '{}' = {} but every model vector has {} = {}: the query is outside the database, \
                 the prediction is unreliable",
                names[l],
                b[l],
                names[l],
                self.norm.min(l)
            ));
        }
        let row = diagnostics.nearest_row;
        let line = self.matrix.line_of_row(row).map(|l| format!(", line {l}")).unwrap_or_default();
        let beyond = diagnostics
            .outside_range
            .map(|l| {
                let (lo, hi) = (self.norm.min(l), self.norm.min(l) + self.norm.range(l));
                format!("; '{}' = {} is outside the database range {} .. {}", names[l], Num(b[l]), Num(lo), Num(hi))
            })
            .unwrap_or_default();
        Some(format!(
            "extrapolation: the nearest model vector (row {}{line}) is {:.3} kernel widths away \
             (normalized distance {:.4}; threshold {EXTRAPOLATION_KERNEL_DISTANCE} widths){beyond}: \
             the prediction is unreliable",
            row + 1,
            diagnostics.kernel_distance,
            diagnostics.nearest_distance,
        ))
    }
}

/// What the passes over the model vectors found.
struct Pass {
    /// Sum of every weight above the cutoff (kept or pruned).
    sum: f64,
    used: usize,
    nearest_row: usize,
    nearest_d2: f64,
    s_min: f64,
}

/// The passes of a prediction: ln a_n and the distances of every model
/// vector, the weights, the list of rows that enter eq. (11), then out =
/// sum_n exp(ln a_n - max ln a) C_n over those rows (not yet divided by the
/// sum of the weights). Runs the AVX2 build of the same code when the CPU
/// has it (identical results: the same operations in the same order, only
/// more lanes at once).
fn evaluate(cae: &Cae, scratch: &mut Scratch, out: &mut [f64]) -> Pass {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        return unsafe { evaluate_avx2(cae, scratch, out) };
    }
    evaluate_lanes(cae, scratch, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn evaluate_avx2(cae: &Cae, scratch: &mut Scratch, out: &mut [f64]) -> Pass {
    evaluate_lanes(cae, scratch, out)
}

#[inline(always)]
fn evaluate_lanes(cae: &Cae, scratch: &mut Scratch, out: &mut [f64]) -> Pass {
    let (n, m) = (cae.matrix.n(), cae.matrix.m());
    // Pass 1, input by input over all model vectors: ln a_n (eq. 12) and
    // the squared normalized distance to the (normalized) query.
    let b = &scratch.query;
    cae.kernel.log_weights(&cae.x_t, b, &mut scratch.log_a);
    let d2 = &mut scratch.d2[..n];
    d2.fill(0.0);
    for (l, &bl) in b.iter().enumerate() {
        if cae.norm.is_constant(l) {
            continue;
        }
        for (acc, x) in d2.iter_mut().zip(&cae.x_t[l * n..(l + 1) * n]) {
            let diff = bl - x;
            *acc += diff * diff;
        }
    }
    // The largest ln a_n, the smallest log_norm_n - ln a_n and the smallest
    // distance, four lanes at a time (plain comparisons: cheaper than
    // f64::max, and every value is finite or infinite, never NaN, unless the
    // distances overflowed, which the caller detects from the sum).
    let log_a = &mut scratch.log_a[..n];
    let log_norm = &cae.kernel.log_norm()[..n];
    let (mut e_max, mut s_min, mut d2_min) = ([f64::NEG_INFINITY; 4], [f64::INFINITY; 4], [f64::INFINITY; 4]);
    let mut reduce = |i: usize, e: f64, ln: f64, d: f64| {
        if e > e_max[i] {
            e_max[i] = e;
        }
        if ln - e < s_min[i] {
            s_min[i] = ln - e;
        }
        if d < d2_min[i] {
            d2_min[i] = d;
        }
    };
    let whole = n - n % 4;
    for ((e, ln), d) in log_a[..whole].chunks_exact(4).zip(log_norm.chunks_exact(4)).zip(d2.chunks_exact(4)) {
        for i in 0..4 {
            reduce(i, e[i], ln[i], d[i]);
        }
    }
    for j in whole..n {
        reduce(0, log_a[j], log_norm[j], d2[j]);
    }
    let fold_max = |v: [f64; 4]| v.into_iter().fold(f64::NEG_INFINITY, |a, e| if e > a { e } else { a });
    let fold_min = |v: [f64; 4]| v.into_iter().fold(f64::INFINITY, |a, e| if e < a { e } else { a });
    let (e_max, s_min, nearest_d2) = (fold_max(e_max), fold_min(s_min), fold_min(d2_min));
    let nearest_row = d2.iter().position(|&v| v == nearest_d2).unwrap_or(0);

    // Pass 2: the weights shifted by their maximum (0 below the cutoff)
    // and their sum, in vectorizable passes.
    for v in log_a.iter_mut() {
        let t = *v - e_max;
        *v = if t >= LOG_WEIGHT_CUTOFF { exp_near_zero(t) } else { 0.0 };
    }
    let mut sums = [0.0f64; 4];
    for chunk in log_a[..whole].chunks_exact(4) {
        for (s, a) in sums.iter_mut().zip(chunk) {
            *s += a;
        }
    }
    let sum = (sums[0] + sums[1]) + (sums[2] + sums[3]) + log_a[whole..].iter().sum::<f64>();

    // Pass 3: the rows that enter eq. (11), the ones whose outputs cannot
    // matter left out (`prune`: together they change no output by more
    // than PRUNE_RELATIVE of its value).
    let used = cae.pruning.select(log_a, sum, &mut scratch.rows, &mut scratch.weights);

    // Pass 4, eq. (11) before the division by the sum of the weights.
    weighted_sum(cae.matrix.outputs_flat(), m, &scratch.rows[..used], &scratch.weights[..used], out);
    Pass { sum, used, nearest_row, nearest_d2, s_min }
}

/// exp(t) for t in [LOG_WEIGHT_CUTOFF, 0], to within 2 units in the last
/// place, in straight-line arithmetic the compiler vectorizes (the libm
/// call does not). t = k ln 2 + r with k = round(t / ln 2) (by the
/// 1.5 * 2^52 shifter, which also leaves k in the low bits) and |r| <=
/// ln(2)/2; exp(r) by its Taylor series to r^13 (truncation below 4e-18);
/// 2^k (k in -67..=0, always a normal number) put into the exponent bits.
#[inline(always)]
pub(crate) fn exp_near_zero(t: f64) -> f64 {
    const SHIFTER: f64 = 6755399441055744.0; // 1.5 * 2^52
    const LN2_HI: f64 = 0.6931471803691238;
    const LN2_LO: f64 = 1.9082149292705877e-10;
    let shifted = t * std::f64::consts::LOG2_E + SHIFTER;
    let k = shifted - SHIFTER;
    let r = (t - k * LN2_HI) - k * LN2_LO;
    // Horner, 1/13! .. 1/0!.
    let mut p = 1.0 / 6227020800.0;
    for coefficient in [
        1.0 / 479001600.0,
        1.0 / 39916800.0,
        1.0 / 3628800.0,
        1.0 / 362880.0,
        1.0 / 40320.0,
        1.0 / 5040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        0.5,
        1.0,
        1.0,
    ] {
        p = p * r + coefficient;
    }
    let k_bits = shifted.to_bits().wrapping_sub(SHIFTER.to_bits());
    p * f64::from_bits(k_bits.wrapping_add(1023) << 52)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fast exp against the libm one over its whole domain, 2e6 points
    /// plus the ends: at most 2 ulp (4.5e-16 relative).
    #[test]
    fn exp_near_zero_matches_libm() {
        let mut worst: f64 = 0.0;
        let points = 2_000_000;
        for i in 0..=points {
            let t = LOG_WEIGHT_CUTOFF * i as f64 / points as f64;
            let (got, want) = (exp_near_zero(t), t.exp());
            worst = worst.max((got - want).abs() / want);
        }
        assert!(worst <= 4.5e-16, "worst relative error {worst:e}");
        assert_eq!(exp_near_zero(0.0), 1.0);
    }
}
