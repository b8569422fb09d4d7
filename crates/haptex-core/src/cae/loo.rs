//! Leave-one-out (LOO) error of the CAE and the widths that minimize it
//! (paper section 3.2: "a leave one out analysis was performed to assess
//! the prediction quality and to optimise the weight parameters").
//!
//! Row i is predicted by eqs. (11)-(12) from the other N - 1 model vectors:
//! its own kernel weight is zero, so neither its outputs nor its Gaussian
//! enter its prediction. The normalization and the width rule are those of
//! the whole database (they depend on the inputs only), exactly as the
//! estimator used for prediction has them; no model is refitted. All N
//! predictions at once are Ĉ = W C with the N x N row-normalized weight
//! matrix W (W_ii = 0), one matrix product: O(N^2 (D + M)) per width.
//!
//! The widths are searched in log space: a scan of constant widths over the
//! search range, Nelder-Mead on ln w from the best of them, then (unless
//! only a constant width is wanted) Nelder-Mead on (ln w_min, ln(w_max /
//! w_min)) from that constant optimum.

use serde::Serialize;

use super::nelder_mead::{self, Options};
use super::predict::{LOG_WEIGHT_CUTOFF, exp_near_zero};
use super::widths::transpose;
use super::{CaeError, Density, Kernel, ModelMatrix, Normalization, Widths};
use crate::buffer::{bytes_text, matrix_len, try_filled};
use crate::num::Num;

/// Leave-one-out evaluation over one model matrix, with its buffers.
#[derive(Debug)]
pub struct Loo<'a> {
    matrix: &'a ModelMatrix,
    norm: Normalization,
    /// N x D normalized inputs, row-major.
    bn: Vec<f64>,
    /// The same, D x N column-major.
    x_t: Vec<f64>,
    density: Option<Density>,
    /// N x D widths w_nl.
    w: Vec<f64>,
    kernel: Kernel,
    /// N x N row-normalized LOO weights, row-major.
    weights: Vec<f64>,
    /// N x M LOO predictions, row-major.
    predictions: Vec<f64>,
    evaluations: usize,
}

/// LOO errors at one set of widths.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LooErrors {
    /// RMS of the LOO residuals over all rows and outputs,
    /// sqrt(sum_ik (c_ik - ĉ_ik)^2 / (N M)), in output units.
    pub rmse: f64,
    /// RMS over the rows, per output (in output order).
    pub rmse_per_output: Vec<f64>,
}

/// The memory a leave-one-out evaluation may take by default: 2 GiB. Its
/// N x N weight matrix grows with the square of the model size (N = 16 000
/// is 2 GiB), so it is estimated and checked before anything is allocated.
pub const DEFAULT_LOO_MEMORY_BYTES: u64 = 2 << 30;

impl<'a> Loo<'a> {
    /// Bytes of the working buffers of a leave-one-out over N model vectors
    /// of D inputs and M outputs: the N x N weights, the N x M predictions
    /// and the N x D normalized inputs, widths and kernel coefficients.
    pub fn memory_bytes(n: usize, d: usize, m: usize) -> u128 {
        let (n, d, m) = (n as u128, d as u128, m as u128);
        8 * (n * n + n * m + 4 * n * d + 2 * n)
    }

    /// The leave-one-out evaluator of `matrix`, within the default memory
    /// budget ([`DEFAULT_LOO_MEMORY_BYTES`]).
    pub fn new(matrix: &'a ModelMatrix) -> Result<Self, CaeError> {
        Self::with_memory_budget(matrix, DEFAULT_LOO_MEMORY_BYTES)
    }

    /// The leave-one-out evaluator of `matrix`, refused with
    /// [`CaeError::TooLarge`] if its buffers would exceed `budget_bytes`.
    pub fn with_memory_budget(matrix: &'a ModelMatrix, budget_bytes: u64) -> Result<Self, CaeError> {
        let (n, d, m) = (matrix.n(), matrix.d(), matrix.m());
        let needed = Self::memory_bytes(n, d, m);
        if needed > u128::from(budget_bytes) {
            return Err(CaeError::TooLarge(format!(
                "leave-one-out over {n} model vectors needs a {n} x {n} weight matrix: about {} of memory, more \
                 than the budget of {} (raise the budget, or give the kernel width so that no leave-one-out is \
                 run)",
                bytes_text(needed),
                bytes_text(u128::from(budget_bytes))
            )));
        }
        // The N x N weights first, fallibly: within a budget far above the
        // machine's memory the system may still refuse them (12.8 GB for
        // 40 000 rows aborted the process, exit 134).
        let too_large = |e: crate::buffer::AllocationError| CaeError::TooLarge(e.to_string());
        let square = || format!("the {n} x {n} weight matrix of the leave-one-out");
        let weights =
            try_filled(matrix_len::<f64>(n, n, square).map_err(too_large)?, 0.0, square).map_err(too_large)?;
        let predictions =
            try_filled(n * m, 0.0, || format!("the {n} x {m} leave-one-out predictions")).map_err(too_large)?;
        let norm = Normalization::fit(matrix.inputs_flat(), d)?;
        let bn = norm.normalize_rows(matrix.inputs_flat());
        Ok(Self {
            matrix,
            norm,
            x_t: transpose(&bn, d),
            bn,
            density: None,
            w: vec![0.0; n * d],
            kernel: Kernel::zeros(n, d),
            weights,
            predictions,
            evaluations: 0,
        })
    }

    /// Number of width settings evaluated so far.
    pub fn evaluations(&self) -> usize {
        self.evaluations
    }

    /// The LOO predictions of every row, N x M row-major: row i from the
    /// other N - 1 model vectors.
    pub fn predictions(&mut self, widths: Widths) -> &[f64] {
        self.evaluations += 1;
        let (n, d, m) = (self.matrix.n(), self.matrix.d(), self.matrix.m());
        if !widths.is_constant() && self.density.is_none() {
            self.density = Some(Density::new(&self.norm, &self.bn));
        }
        widths.fill(self.density.as_ref(), &mut self.w);
        self.kernel.set(&self.norm, &self.w);

        for (i, row) in self.weights.chunks_exact_mut(n).enumerate() {
            weight_row(&self.kernel, &self.x_t, &self.bn[i * d..(i + 1) * d], i, row);
        }
        let c = self.matrix.outputs_flat();
        assert!(self.weights.len() == n * n && c.len() == n * m && self.predictions.len() == n * m);
        // SAFETY: the three buffers are contiguous row-major matrices of the
        // sizes given (N x N, N x M, N x M, checked above), the output does
        // not alias the inputs, and with beta = 0 it is only written.
        unsafe {
            matrixmultiply::dgemm(
                n,
                n,
                m,
                1.0,
                self.weights.as_ptr(),
                n as isize,
                1,
                c.as_ptr(),
                m as isize,
                1,
                0.0,
                self.predictions.as_mut_ptr(),
                m as isize,
                1,
            );
        }
        &self.predictions
    }

    /// RMS of the LOO residuals over all rows and outputs.
    pub fn rmse(&mut self, widths: Widths) -> f64 {
        self.predictions(widths);
        let sq: f64 = self.matrix.outputs_flat().iter().zip(&self.predictions).map(|(c, p)| (c - p) * (c - p)).sum();
        (sq / self.predictions.len() as f64).sqrt()
    }

    /// Overall and per-output LOO errors.
    pub fn errors(&mut self, widths: Widths) -> LooErrors {
        let (n, m) = (self.matrix.n(), self.matrix.m());
        self.predictions(widths);
        let mut per_output = vec![0.0; m];
        for (c, p) in self.matrix.outputs_flat().chunks_exact(m).zip(self.predictions.chunks_exact(m)) {
            for ((acc, c), p) in per_output.iter_mut().zip(c).zip(p) {
                *acc += (c - p) * (c - p);
            }
        }
        let rmse = (per_output.iter().sum::<f64>() / (n * m) as f64).sqrt();
        let rmse_per_output = per_output.iter().map(|s| (s / n as f64).sqrt()).collect();
        LooErrors { rmse, rmse_per_output }
    }
}

/// Row i of the LOO weight matrix: the normalized weights of eq. (12) of
/// every model vector for the query b_i, with w_ii = 0. Runs the AVX2 build
/// of the same code when the CPU has it (with FMA, which `exp_near_zero`
/// uses; without it that is a libm call).
fn weight_row(kernel: &Kernel, x_t: &[f64], bi: &[f64], i: usize, row: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU supports AVX2 and FMA, checked just above.
        return unsafe { weight_row_avx2(kernel, x_t, bi, i, row) };
    }
    weight_row_lanes(kernel, x_t, bi, i, row)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn weight_row_avx2(kernel: &Kernel, x_t: &[f64], bi: &[f64], i: usize, row: &mut [f64]) {
    weight_row_lanes(kernel, x_t, bi, i, row)
}

#[inline(always)]
fn weight_row_lanes(kernel: &Kernel, x_t: &[f64], bi: &[f64], i: usize, row: &mut [f64]) {
    kernel.log_weights(x_t, bi, row);
    row[i] = f64::NEG_INFINITY;
    // Largest ln a_j, j != i, with four independent lanes (vectorizable).
    let mut lanes = [f64::NEG_INFINITY; 4];
    let chunks = row.chunks_exact(4);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (lane, &e) in lanes.iter_mut().zip(chunk) {
            *lane = if e > *lane { e } else { *lane };
        }
    }
    let e_max = rest.iter().chain(&lanes).fold(f64::NEG_INFINITY, |a, &e| if e > a { e } else { a });
    let mut sum = 0.0;
    for w in row.iter_mut() {
        let t = *w - e_max;
        *w = if t >= LOG_WEIGHT_CUTOFF { exp_near_zero(t) } else { 0.0 };
        sum += *w;
    }
    let inv = 1.0 / sum;
    for w in row.iter_mut() {
        *w *= inv;
    }
}

/// A byte count for a message, in binary units: `11.9 GiB`, `512.0 MiB`.
/// How to search for the widths.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptimizeOptions {
    /// Only a constant width (w_min = w_max).
    pub constant_only: bool,
    /// Smallest and largest width searched, normalized units.
    pub search_range: (f64, f64),
    /// Constant widths scanned (log-spaced over the range) before the
    /// simplex search starts from the best.
    pub scan_points: usize,
    /// Largest memory the leave-one-out may take, bytes.
    pub memory_budget_bytes: u64,
}

impl Default for OptimizeOptions {
    fn default() -> Self {
        Self {
            constant_only: false,
            search_range: (0.005, 2.0),
            scan_points: 13,
            memory_budget_bytes: DEFAULT_LOO_MEMORY_BYTES,
        }
    }
}

/// One constant width and its LOO RMS error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScanPoint {
    pub w: f64,
    pub rmse: f64,
}

/// The leave-one-out figures of a model matrix at some widths, as `haptex
/// cae loo` writes them (JSON).
#[derive(Debug, Clone, Serialize)]
pub struct LooReport<'a> {
    pub model: &'a str,
    pub n: usize,
    pub d: usize,
    pub m: usize,
    pub inputs: &'a [String],
    /// The inputs with one value over all rows (left out of the distances).
    pub constant_inputs: Vec<&'a str>,
    pub outputs: &'a [String],
    pub constant: bool,
    pub w_min: f64,
    pub w_max: f64,
    pub rmse: f64,
    pub rmse_per_output: &'a [f64],
    /// What the width search did (None for widths given).
    pub optimizer: Option<&'a OptimizerReport>,
}

impl<'a> LooReport<'a> {
    /// The report of `errors` at `widths` over `matrix`.
    pub fn new(
        matrix: &'a ModelMatrix,
        widths: Widths,
        errors: &'a LooErrors,
        optimizer: Option<&'a OptimizerReport>,
    ) -> Result<Self, CaeError> {
        let norm = Normalization::fit(matrix.inputs_flat(), matrix.d())?;
        Ok(Self {
            model: matrix.source_name(),
            n: matrix.n(),
            d: matrix.d(),
            m: matrix.m(),
            inputs: matrix.inputs(),
            constant_inputs: norm.constant_inputs().into_iter().map(|l| matrix.inputs()[l].as_str()).collect(),
            outputs: matrix.outputs(),
            constant: widths.is_constant(),
            w_min: widths.w_min,
            w_max: widths.w_max,
            rmse: errors.rmse,
            rmse_per_output: &errors.rmse_per_output,
            optimizer,
        })
    }
}

/// What the width search did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OptimizerReport {
    pub method: &'static str,
    /// Smallest and largest width searched.
    pub search_range: [f64; 2],
    /// The scan of constant widths (the LOO error curve).
    pub scan: Vec<ScanPoint>,
    /// The best constant width found by Nelder-Mead from the scan.
    pub constant: ScanPoint,
    /// Width settings evaluated in total (scan, searches and the final one).
    pub evaluations: usize,
    /// Nelder-Mead iterations in total.
    pub iterations: usize,
    /// True if every simplex search met its tolerances.
    pub converged: bool,
    /// True if the optimum touches the search range (widen it).
    pub at_bound: bool,
}

/// The widths with the smallest LOO error found, and that error.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WidthOptimum {
    pub widths: Widths,
    pub errors: LooErrors,
    pub report: OptimizerReport,
}

/// Searches the widths that minimize the LOO RMS error (see the module doc).
pub fn optimize_widths(matrix: &ModelMatrix, options: OptimizeOptions) -> Result<WidthOptimum, CaeError> {
    let (lo, hi) = options.search_range;
    Widths::range(lo, hi)?;
    if lo >= hi {
        return Err(CaeError::Width(format!("the search range {} .. {} is empty", Num(lo), Num(hi))));
    }
    let mut loo = Loo::with_memory_budget(matrix, options.memory_budget_bytes)?;
    let (ln_lo, ln_hi) = (lo.ln(), hi.ln());
    let points = options.scan_points.max(2);
    let step = (ln_hi - ln_lo) / (points - 1) as f64;
    let scan: Vec<ScanPoint> = (0..points)
        .map(|j| {
            let w = if j + 1 == points { hi } else { (ln_lo + step * j as f64).exp() };
            ScanPoint { w, rmse: loo.rmse(Widths { w_min: w, w_max: w }) }
        })
        .collect();
    let start = scan.iter().min_by(|a, b| a.rmse.total_cmp(&b.rmse)).unwrap();

    let nm = Options { x_tol: 1e-3, f_tol: 1e-6, f_abs: 0.0, max_evals: 100 };
    let constant = nelder_mead::minimize(
        |x| {
            let w = x[0].exp();
            loo.rmse(Widths { w_min: w, w_max: w })
        },
        &[start.w.ln()],
        &[step],
        &[ln_lo],
        &[ln_hi],
        nm,
    );
    let w_c = constant.x[0].exp();
    let mut best = (Widths { w_min: w_c, w_max: w_c }, constant.f);
    let (mut iterations, mut converged) = (constant.iterations, constant.converged);

    if !options.constant_only {
        let span = ln_hi - ln_lo;
        let to_widths = |x: &[f64]| {
            let w_min = x[0].exp();
            Widths { w_min, w_max: (x[0] + x[1].abs()).exp().clamp(w_min, hi) }
        };
        let varying = nelder_mead::minimize(
            |x| loo.rmse(to_widths(x)),
            &[constant.x[0], 0.0],
            &[0.5 * step, 0.5],
            &[ln_lo, -span],
            &[ln_hi, span],
            Options { max_evals: 200, ..nm },
        );
        iterations += varying.iterations;
        converged &= varying.converged;
        // Kept only if they lower the error by more than the search's own
        // resolution (f_tol): the shipped bump database's search once
        // "improved" on the constant width by moving w_max 4e-10 away from
        // w_min, which bought nothing but non-constant widths.
        if varying.f < best.1 * (1.0 - nm.f_tol) {
            best = (to_widths(&varying.x), varying.f);
        }
    }

    let widths = best.0;
    let errors = loo.errors(widths);
    let near = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-9;
    let at_bound = near(widths.w_min, lo) || near(widths.w_max, hi);
    Ok(WidthOptimum {
        widths,
        errors,
        report: OptimizerReport {
            method: "scan of constant widths, then Nelder-Mead in log width",
            search_range: [lo, hi],
            scan,
            constant: ScanPoint { w: w_c, rmse: constant.f },
            evaluations: loo.evaluations(),
            iterations,
            converged,
            at_bound,
        },
    })
}
