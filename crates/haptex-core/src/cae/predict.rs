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
//! Memory layout for speed: besides the row-major outputs, the estimator
//! keeps them in quads of rows interleaved four outputs at a time
//! (`panels`), the rows taken along a Z-order curve through the inputs
//! (`panels::z_order`) so that a quad's rows are near neighbours and a
//! query's kernels rarely cut a quad in parts. The kernel, the inputs and
//! the pruning ratios are kept in that order too, so the weights come in
//! it; the diagnostics and every row index a caller sees are the matrix's.
//! A prediction sorts the rows that enter into the quads of which at least
//! three rows enter, summed from the panels (one sequential read; a row
//! left out there is summed with weight 0), and the other rows (with
//! narrow kernels, most of them), summed one by one from the row-major
//! outputs (`Pruning::classify`). A prediction allocates nothing.

use super::panels::{Panels, z_order};
use super::prune::{Pruning, add_weighted_rows, weighted_sum};
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
    /// The outputs in quads of rows, for one prediction's sum.
    panels: Panels,
}

/// Per-query working memory (one value per model vector). Make one with
/// [`Cae::scratch`] and reuse it for every query.
#[derive(Debug, Clone)]
pub struct Scratch {
    log_a: Vec<f64>,
    d2: Vec<f64>,
    query: Vec<f64>,
    /// The matrix rows that enter eq. (11) and their weights, as
    /// `weights` lists them: all of them (`Listing::Rows`), or those
    /// outside `quads` (`Listing::Quads`).
    rows: Vec<usize>,
    weights: Vec<f64>,
    /// The quads (of positions 4q .. 4q + 3 in the estimator's row order)
    /// of which three or four rows enter eq. (11), and their weights (0
    /// for a row left out).
    quads: Vec<usize>,
    quad_weights: Vec<[f64; 4]>,
    /// How many quads and rows `weights` listed in `Listing::Quads`.
    listed: (usize, usize),
}

/// How [`Cae::weights`] lists the rows that enter eq. (11).
#[derive(Debug, Clone, Copy)]
enum Listing {
    /// In `rows` and `weights`, in the estimator's row order.
    Rows,
    /// The quads of which three or four rows enter in `quads` and
    /// `quad_weights`, the other rows that enter in `rows` and `weights`.
    Quads,
}

/// Queries a batched prediction puts into one matrix product. The product
/// packs the N x M outputs once per block, so a larger block spreads that
/// over more queries: at N 405, M 500 (`scripts/compare_cae_numpy.py`'s
/// synthetic case, one thread) a batch took 8.7 µs a query with blocks of
/// 256 against 9.7 µs with 64, and 9.0 µs with 512 or 1024 (means of 4 to
/// 8 alternated runs, Intel Xeon with AVX-512, 2 MiB L2 a core,
/// 2026-12-08).
/// 256 keeps several blocks for rayon's threads from 512 queries on; a
/// block's weights are 256 x N doubles (830 KB at N = 405).
pub const BATCH_BLOCK: usize = 256;

/// A block whose queries use fewer than 1 / SPARSE_BLOCK_FRACTION of the
/// model vectors on average (after the cutoff and pruning) is summed query
/// by query over the rows each uses, not as one dense product.
const SPARSE_BLOCK_FRACTION: usize = 4;

/// Working memory for [`Cae::predict_batch_into`]: one query's scratch and
/// the weights of a block of queries. Make one with [`Cae::batch_scratch`].
#[derive(Debug, Clone)]
pub struct BatchScratch {
    one: Scratch,
    /// BATCH_BLOCK x N normalized weights a_n / sum_n a_n, row-major.
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
        let bn = norm.normalize_rows(matrix.inputs_flat());
        let density = (!widths.is_constant()).then(|| Density::new(&norm, &bn));
        let mut w = vec![0.0; n * d];
        widths.fill(density.as_ref(), &mut w);
        // The kernel, the inputs, the pruning ratios and the panels in the
        // estimator's own row order (`panels::z_order`); `w`, the
        // diagnostics and the rows read one by one in the matrix's.
        let order = z_order(&bn, d, |l| !norm.is_constant(l));
        let in_order =
            |v: &[f64]| order.iter().flat_map(|&r| v[r * d..(r + 1) * d].iter().copied()).collect::<Vec<_>>();
        let mut kernel = Kernel::zeros(n, d);
        kernel.set(&norm, &in_order(&w));
        let x_t = transpose(&in_order(&bn), d);
        let pruning = Pruning::new(&matrix, &order);
        let panels = Panels::new(matrix.outputs_flat(), n, matrix.m(), &order);
        Ok(Self { matrix, norm, widths, w, kernel, x_t, pruning, panels })
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
        Scratch {
            log_a: vec![0.0; n],
            d2: vec![0.0; n],
            query: vec![0.0; d],
            rows: vec![0; n],
            weights: vec![0.0; n],
            quads: vec![0; n / 4],
            quad_weights: vec![[0.0; 4]; n / 4],
            listed: (0, 0),
        }
    }

    /// Predicts the M outputs at the input vector `b` (D values in the
    /// model's input order and units) into `out`, eqs. (11)-(12). Allocates
    /// nothing.
    pub fn predict_into(&self, b: &[f64], scratch: &mut Scratch, out: &mut [f64]) -> Result<Diagnostics, CaeError> {
        let m = self.matrix.m();
        if out.len() != m {
            return Err(CaeError::Query(format!("a buffer of {} outputs for a model with {m} outputs", out.len())));
        }
        let (diagnostics, sum) = self.weights(b, scratch, Listing::Quads)?;
        // Eq. (11) over the rows that enter, then the division by the sum
        // of every weight: the quads whose four rows all enter from the
        // panels (one sequential read), the other rows one by one.
        let (whole, rest) = scratch.listed;
        let Scratch { rows, weights, quads, quad_weights, .. } = scratch;
        self.panels.sum_quads(out, &quads[..whole], &quad_weights[..whole]);
        add_weighted_rows(self.matrix.outputs_flat(), m, &rows[..rest], &weights[..rest], out);
        let inv = 1.0 / sum;
        for o in out.iter_mut() {
            *o *= inv;
        }
        Ok(diagnostics)
    }

    /// The diagnostics [`Cae::predict_into`] returns for the input vector
    /// `b` (where it lies relative to the database, how many rows enter),
    /// from eq. (12)'s weights alone, without eq. (11)'s sum: for a caller
    /// that estimates the outputs otherwise. Allocates nothing.
    pub fn diagnose(&self, b: &[f64], scratch: &mut Scratch) -> Result<Diagnostics, CaeError> {
        self.weights(b, scratch, Listing::Quads).map(|(diagnostics, _)| diagnostics)
    }

    /// The weights of eq. (12) at the input vector `b`: the rows that enter
    /// eq. (11) with their weights (shifted so that the largest is 1),
    /// listed in `scratch` as `listing` says (`Listing::Rows`: in
    /// `scratch.rows[..used]` and `scratch.weights[..used]`), the query's
    /// diagnostics and the sum of the weights.
    fn weights(&self, b: &[f64], scratch: &mut Scratch, listing: Listing) -> Result<(Diagnostics, f64), CaeError> {
        let (n, d) = (self.matrix.n(), self.matrix.d());
        if b.len() != d {
            return Err(CaeError::Query(format!("a query needs {d} input values, got {}", b.len())));
        }
        if let Some(l) = b.iter().position(|v| !v.is_finite()) {
            return Err(CaeError::Query(format!("input '{}' is not finite: {}", self.matrix.inputs()[l], b[l])));
        }
        let scratch_ok = [scratch.log_a.len(), scratch.d2.len(), scratch.rows.len(), scratch.weights.len()] == [n; 4]
            && [scratch.quads.len(), scratch.quad_weights.len()] == [n / 4; 2]
            && scratch.query.len() == d;
        if !scratch_ok {
            return Err(CaeError::Query(format!(
                "{} scratch values for a model with {n} rows: make the scratch with Cae::scratch",
                scratch.log_a.len()
            )));
        }

        for (l, (q, &v)) in scratch.query.iter_mut().zip(b).enumerate() {
            *q = self.norm.normalize(l, v);
        }
        let mut pass = evaluate(self, scratch);
        let overflowed = !pass.sum.is_finite() || pass.sum <= 0.0;
        if overflowed {
            // So far out that the squared distances overflow: predict at the
            // query clamped into the database's box instead (flagged below).
            for q in scratch.query.iter_mut() {
                *q = q.clamp(0.0, 1.0);
            }
            pass = evaluate(self, scratch);
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

        // The rows that enter eq. (11), the ones whose outputs cannot
        // matter left out (`prune`: together they change no output by more
        // than PRUNE_RELATIVE of its value).
        let used = match listing {
            Listing::Rows => self.pruning.select(&scratch.log_a, pass.sum, &mut scratch.rows, &mut scratch.weights),
            Listing::Quads => {
                let Scratch { log_a, quads, quad_weights, rows, weights, .. } = &mut *scratch;
                let (whole, rest, used) = self.pruning.classify(log_a, pass.sum, quads, quad_weights, rows, weights);
                scratch.listed = (whole, rest);
                used
            }
        };
        let diagnostics = Diagnostics {
            nearest_row: pass.nearest_row,
            nearest_distance: pass.nearest_d2.sqrt(),
            kernel_distance: (2.0 * pass.s_min.max(0.0)).sqrt(),
            outside_range,
            constant_mismatch,
            weights_used: used,
        };
        Ok((diagnostics, pass.sum))
    }

    /// Working memory for [`Cae::predict_batch_into`].
    pub fn batch_scratch(&self) -> BatchScratch {
        BatchScratch { one: self.scratch(), weights: vec![0.0; BATCH_BLOCK * self.matrix.n()] }
    }

    /// Predicts many queries at once: `queries` holds Q input vectors
    /// (Q x D, row-major, in the model's input order and units), `out`
    /// receives Q x M outputs (row-major, query by query) and `diagnostics`
    /// is cleared and receives one entry per query. The same eqs. (11)-(12)
    /// and the same weights as [`Cae::predict_into`] (the same rows left
    /// out), but eq. (11) for a block of [`BATCH_BLOCK`] queries is one
    /// matrix product W C, W the block's normalized weights (zero for the
    /// rows a query leaves out): the outputs are read once per block
    /// instead of once per query. (A block whose queries each use under a
    /// quarter of the rows is summed query by query over those rows.) The results agree with
    /// [`Cae::predict_into`] to rounding (the sums are taken in another
    /// order). Allocates at most the product's packing buffer, once per block
    /// (faer keeps it between calls), once `diagnostics` has room for
    /// Q entries. An error names the query (1-based) it is about.
    pub fn predict_batch_into(
        &self,
        queries: &[f64],
        scratch: &mut BatchScratch,
        out: &mut [f64],
        diagnostics: &mut Vec<Diagnostics>,
    ) -> Result<(), CaeError> {
        let (n, d, m) = (self.matrix.n(), self.matrix.d(), self.matrix.m());
        let q_total = self.query_count(queries)?;
        if out.len() != q_total * m {
            return Err(CaeError::Query(format!(
                "a buffer of {} outputs for {q_total} queries of a model with {m} outputs",
                out.len()
            )));
        }
        if scratch.weights.len() != BATCH_BLOCK * n {
            return Err(CaeError::Query(format!(
                "a batch scratch for {} rows and a model with {n} rows: make it with Cae::batch_scratch",
                scratch.weights.len() / BATCH_BLOCK
            )));
        }
        diagnostics.clear();
        let c = self.matrix.outputs_flat();
        for (block, out_block) in queries.chunks(BATCH_BLOCK * d).zip(out.chunks_mut(BATCH_BLOCK * m)) {
            let q_block = block.len() / d;
            if q_block == 1 {
                // A block of one query: eq. (11) summed over the rows it uses
                // ([`Cae::predict_into`], the same bits): a product would pack
                // all N x M outputs for one row of weights.
                let index = diagnostics.len();
                let diag = self.predict_into(block, &mut scratch.one, out_block).map_err(|e| match e {
                    CaeError::Query(message) => CaeError::BatchQuery { index, message },
                    other => other,
                })?;
                diagnostics.push(diag);
                continue;
            }
            let mut rows_used = 0;
            for (b, w_row) in block.chunks_exact(d).zip(scratch.weights.chunks_exact_mut(n)) {
                let (diag, sum) = self.weights(b, &mut scratch.one, Listing::Rows).map_err(|e| match e {
                    CaeError::Query(message) => CaeError::BatchQuery { index: diagnostics.len(), message },
                    other => other,
                })?;
                w_row.fill(0.0);
                let inv = 1.0 / sum;
                let used = diag.weights_used;
                for (&row, &a) in scratch.one.rows[..used].iter().zip(&scratch.one.weights[..used]) {
                    w_row[row] = a * inv;
                }
                rows_used += used;
                diagnostics.push(diag);
            }
            if rows_used * SPARSE_BLOCK_FRACTION < q_block * n {
                // Narrow kernels (the database shipped until 2026-11-25): each query reads
                // only its own few rows, as one query does; a product over
                // every row would do N / used times the work.
                for (w_row, o) in scratch.weights.chunks_exact(n).zip(out_block.chunks_exact_mut(m)) {
                    let mut used = 0;
                    for (row, &a) in w_row.iter().enumerate() {
                        (scratch.one.rows[used], scratch.one.weights[used]) = (row, a);
                        used += usize::from(a != 0.0);
                    }
                    weighted_sum(c, m, &scratch.one.rows[..used], &scratch.one.weights[..used], o);
                }
                continue;
            }
            // The block's product, row-major: out (q x M) = W (q x N) C (N x M),
            // as its transpose in faer's column-major views, out^T = C^T W^T
            // (the same memory): faer's kernels use the widest vector unit
            // the CPU has (AVX-512 where it has it).
            let out_t = faer::MatMut::from_column_major_slice_mut(&mut out_block[..q_block * m], m, q_block);
            let c_t = faer::MatRef::from_column_major_slice(c, m, n);
            let w_t = faer::MatRef::from_column_major_slice(&scratch.weights[..q_block * n], n, q_block);
            faer::linalg::matmul::matmul(out_t, faer::Accum::Replace, c_t, w_t, 1.0, faer::Par::Seq);
        }
        Ok(())
    }

    /// The number of queries in a batch of `queries` values (D per query).
    fn query_count(&self, queries: &[f64]) -> Result<usize, CaeError> {
        let d = self.matrix.d();
        if !queries.len().is_multiple_of(d) {
            return Err(CaeError::Query(format!(
                "{} query values are not a whole number of queries of {d} inputs",
                queries.len()
            )));
        }
        Ok(queries.len() / d)
    }

    /// [`Cae::predict_batch_into`] with freshly allocated buffers: Q x M
    /// outputs and one diagnostic per query. The blocks of
    /// [`BATCH_BLOCK`] queries run on rayon's threads (one scratch per
    /// thread); the results are the same to the bit as one thread's, since
    /// each block is computed the same way wherever it runs.
    pub fn predict_batch(&self, queries: &[f64]) -> Result<(Vec<f64>, Vec<Diagnostics>), CaeError> {
        use rayon::prelude::*;
        let (d, m) = (self.matrix.d(), self.matrix.m());
        let q_total = self.query_count(queries)?;
        // Q x M outputs: two sizes from the input, allocated fallibly.
        let what = || format!("the {q_total} x {m} predictions of the batch");
        let too_large = |e: crate::buffer::AllocationError| CaeError::TooLarge(e.to_string());
        let len = crate::buffer::matrix_len::<f64>(q_total, m, what).map_err(too_large)?;
        let mut out = crate::buffer::try_filled(len, 0.0, what).map_err(too_large)?;
        let blocks: Vec<Vec<Diagnostics>> = queries
            .par_chunks(BATCH_BLOCK * d)
            .zip(out.par_chunks_mut(BATCH_BLOCK * m))
            .enumerate()
            .map_init(
                || self.batch_scratch(),
                |scratch, (block, (q, o))| {
                    let mut diagnostics = Vec::with_capacity(BATCH_BLOCK);
                    match self.predict_batch_into(q, scratch, o, &mut diagnostics) {
                        Ok(()) => Ok(diagnostics),
                        Err(CaeError::BatchQuery { index, message }) => {
                            Err(CaeError::BatchQuery { index: index + block * BATCH_BLOCK, message })
                        }
                        Err(e) => Err(e),
                    }
                },
            )
            .collect::<Result<_, _>>()?;
        Ok((out, blocks.into_iter().flatten().collect()))
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
    nearest_row: usize,
    nearest_d2: f64,
    s_min: f64,
}

/// The passes of a prediction's weights: ln a_n and the distances of every
/// model vector, then the weights exp(ln a_n - max ln a) (into
/// `scratch.log_a`) and their sum. Runs the AVX2 and FMA build of the same
/// code when the CPU has them (identical results: the same operations in
/// the same order, only more lanes at once; the fused multiply-adds of
/// `exp_near_zero` are one instruction there and a libm call elsewhere,
/// with the same correctly rounded result).
fn evaluate(cae: &Cae, scratch: &mut Scratch) -> Pass {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU supports AVX2 and FMA, checked just above.
        return unsafe { evaluate_avx2(cae, scratch) };
    }
    evaluate_lanes(cae, scratch)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn evaluate_avx2(cae: &Cae, scratch: &mut Scratch) -> Pass {
    evaluate_lanes(cae, scratch)
}

#[inline(always)]
fn evaluate_lanes(cae: &Cae, scratch: &mut Scratch) -> Pass {
    let n = cae.matrix.n();
    // Pass 1, input by input over all model vectors: ln a_n (eq. 12) and
    // the squared normalized distance to the (normalized) query.
    let b = &scratch.query;
    let d2 = &mut scratch.d2[..n];
    cae.kernel.log_weights_and_distances(&cae.x_t, b, |l| !cae.norm.is_constant(l), &mut scratch.log_a, d2);
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
    // The first matrix row at the smallest distance.
    let order = cae.pruning.order();
    let nearest_row = d2.iter().zip(order).filter(|&(&v, _)| v == nearest_d2).map(|(_, &r)| r).min().unwrap_or(0);

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

    Pass { sum, nearest_row, nearest_d2, s_min }
}

/// exp(t) for t in [LOG_WEIGHT_CUTOFF, 0], to within 2 units in the last
/// place, in straight-line arithmetic the compiler vectorizes (the libm
/// call does not). t = k ln 2 + r with k = round(t / ln 2) (by the
/// 1.5 * 2^52 shifter, which also leaves k in the low bits) and |r| <=
/// ln(2)/2; exp(r) by its Taylor series to r^13 (truncation below 4e-18),
/// in Horner's form with fused multiply-adds (half the operations and half
/// the dependency chain of separate ones: the weights of one prediction
/// 16% faster, AMD EPYC, 2026-11-26); 2^k (k in -67..=0, always a normal
/// number) put into the exponent bits. Call it from code built with FMA
/// (`f64::mul_add` is a libm call otherwise).
#[inline(always)]
pub(crate) fn exp_near_zero(t: f64) -> f64 {
    const LN2_HI: f64 = 0.6931471803691238;
    const LN2_LO: f64 = 1.9082149292705877e-10;
    let (k, shifted_bits) = crate::num::round_shifted(t * std::f64::consts::LOG2_E);
    let r = (t - k * LN2_HI) - k * LN2_LO;
    // Horner, 1/13! .. 1/0!.
    let mut p: f64 = 1.0 / 6227020800.0;
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
        p = p.mul_add(r, coefficient);
    }
    let k_bits = crate::num::shifted_integer_bits(shifted_bits);
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
