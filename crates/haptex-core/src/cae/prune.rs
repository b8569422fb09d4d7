//! Which model vectors a prediction reads, and the weighted sum of eq. (11)
//! over them.
//!
//! A prediction's time is mostly reading the outputs of the model vectors
//! it uses (at N = 405, M = 500 that is 1.6 MB, more than a core's L2
//! cache). A model vector whose weight is so small that its outputs cannot
//! change the result is not read at all. The bound:
//!
//! Let a_n be the weights above the cutoff (the others are already left
//! out, `LOG_WEIGHT_CUTOFF`), S = sum_n a_n and c_k = sum_n a_n c_nk / S the
//! output of eq. (11) over those rows. When every output k is of one sign
//! over the database and never zero, F_k = min_n |c_nk| > 0 and c_k, a
//! weighted mean of values of one sign, has |c_k| >= F_k. With
//!
//!   rho_n = max_k |c_nk| / F_k  (>= 1, computed once per model matrix),
//!
//! a prediction divides by the same S but sums only the rows with
//! a_n rho_n > eps S / N, eps = [`PRUNE_RELATIVE`]. The rows left out (at
//! most N of them) change output k by at most
//!
//!   sum_out a_n |c_nk| / S <= F_k sum_out a_n rho_n / S <= F_k N (eps S / N) / S
//!                          = eps F_k <= eps |c_k|.
//!
//! When some output changes sign or is zero somewhere (there is no such
//! F_k > 0), nothing beyond the cutoff is left out.

use super::ModelMatrix;

/// Bound on the relative change of any output of a prediction by the
/// model vectors it leaves out beyond the cutoff (see the module doc):
/// 1e-16, below the unit roundoff of a double (1.1e-16).
pub const PRUNE_RELATIVE: f64 = 1e-16;

/// The pruning ratios rho_n of a model matrix, if its outputs allow
/// pruning.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Pruning {
    /// rho_n per row; empty when some output changes sign or is zero.
    ratio: Vec<f64>,
}

impl Pruning {
    pub(crate) fn new(matrix: &ModelMatrix) -> Self {
        let m = matrix.m();
        let c = matrix.outputs_flat();
        let (mut floor, mut positive, mut negative) = (vec![f64::INFINITY; m], vec![false; m], vec![false; m]);
        for values in c.chunks_exact(m) {
            for (k, &v) in values.iter().enumerate() {
                floor[k] = floor[k].min(v.abs());
                positive[k] |= v > 0.0;
                negative[k] |= v < 0.0;
            }
        }
        let one_sign = (0..m).all(|k| floor[k] > 0.0 && !(positive[k] && negative[k]));
        let ratio = if one_sign {
            // An overflow to infinity (|c| / F beyond 1.8e308) only keeps that row.
            c.chunks_exact(m)
                .map(|values| values.iter().zip(&floor).map(|(v, f)| v.abs() / f).fold(1.0, f64::max))
                .collect()
        } else {
            Vec::new()
        };
        Self { ratio }
    }

    /// True if predictions may leave out rows beyond the cutoff.
    pub(crate) fn is_active(&self) -> bool {
        !self.ratio.is_empty()
    }

    /// Whether a prediction sums row n of weight a_n, given the sum S of
    /// every weight and N: a_n rho_n > eps S / N when pruning, a_n > 0
    /// otherwise (rho_n >= 1 and the threshold is >= 0, so a zero weight
    /// is never kept).
    #[inline(always)]
    fn keeps(&self, sum: f64, n: usize) -> impl Fn(usize, f64) -> bool + '_ {
        let threshold = PRUNE_RELATIVE * sum / n as f64;
        move |row, a| if self.ratio.is_empty() { a > 0.0 } else { a * self.ratio[row] > threshold }
    }

    /// Lists the rows a prediction sums, from the weights of every row (0
    /// below the cutoff) and their sum S: into `rows` and `row_weights`,
    /// returning how many. Without branches: every row is written, and the
    /// list grows by one when the row is kept.
    #[inline(always)]
    pub(crate) fn select(&self, weights: &[f64], sum: f64, rows: &mut [usize], row_weights: &mut [f64]) -> usize {
        let n = weights.len();
        let (rows, row_weights) = (&mut rows[..n], &mut row_weights[..n]);
        let keep = self.keeps(sum, n);
        let mut used = 0;
        for (row, &a) in weights.iter().enumerate() {
            (rows[used], row_weights[used]) = (row, a);
            used += usize::from(keep(row, a));
        }
        used
    }

    /// The rows [`Pruning::select`] lists, sorted by quads (rows 4q to
    /// 4q + 3): the quads whose four rows are all kept go to `quads` and
    /// `quad_weights`, the other kept rows to `rows` and `row_weights`,
    /// both in row order; returns how many of each. Without branches on
    /// single rows: every slot of `rows` up to N may be written.
    pub(crate) fn classify(
        &self,
        weights: &[f64],
        sum: f64,
        quads: &mut [usize],
        quad_weights: &mut [[f64; 4]],
        rows: &mut [usize],
        row_weights: &mut [f64],
    ) -> (usize, usize) {
        let n = weights.len();
        let (rows, row_weights) = (&mut rows[..n], &mut row_weights[..n]);
        let (quads, quad_weights) = (&mut quads[..n / 4], &mut quad_weights[..n / 4]);
        let keep = self.keeps(sum, n);
        let (mut whole, mut rest) = (0, 0);
        for (q, a) in weights.chunks_exact(4).enumerate() {
            let a = [a[0], a[1], a[2], a[3]];
            let kept = [0, 1, 2, 3].map(|i| keep(4 * q + i, a[i]));
            if kept == [true; 4] {
                (quads[whole], quad_weights[whole]) = (q, a);
                whole += 1;
            } else {
                for i in 0..4 {
                    (rows[rest], row_weights[rest]) = (4 * q + i, a[i]);
                    rest += usize::from(kept[i]);
                }
            }
        }
        let first = n - n % 4;
        for (row, &a) in weights.iter().enumerate().skip(first) {
            (rows[rest], row_weights[rest]) = (row, a);
            rest += usize::from(keep(row, a));
        }
        (whole, rest)
    }
}

/// out = sum over the listed rows of a_n C_n, C the N x M outputs
/// row-major (eq. 11 before the division by the sum of the weights).
pub(crate) fn weighted_sum(c: &[f64], m: usize, rows: &[usize], weights: &[f64], out: &mut [f64]) {
    out[..m].fill(0.0);
    add_weighted_rows(c, m, rows, weights, out);
}

/// out += sum over the listed rows of a_n C_n: four rows at a time, in
/// list order, each output updated as
/// out_k += ((a_0 c_0k + a_1 c_1k) + a_2 c_2k) + a_3 c_3k. Runs the AVX2
/// build of the same code when the CPU has it: the same operations in the
/// same order (no fused multiply-add), so the same bits, with four outputs
/// per instruction instead of two. (Inlined into its callers it was the
/// two-lane build, 1.4x slower on AMD EPYC, 2026-11-25.)
pub(crate) fn add_weighted_rows(c: &[f64], m: usize, rows: &[usize], weights: &[f64], out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        return unsafe { add_weighted_rows_avx2(c, m, rows, weights, out) };
    }
    add_weighted_rows_lanes(c, m, rows, weights, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn add_weighted_rows_avx2(c: &[f64], m: usize, rows: &[usize], weights: &[f64], out: &mut [f64]) {
    add_weighted_rows_lanes(c, m, rows, weights, out)
}

#[inline(always)]
fn add_weighted_rows_lanes(c: &[f64], m: usize, rows: &[usize], weights: &[f64], out: &mut [f64]) {
    let out = &mut out[..m];
    let row = |n: usize| &c[n * m..(n + 1) * m];
    for (r, a) in rows.chunks_exact(4).zip(weights.chunks_exact(4)) {
        let (c0, c1, c2, c3) = (row(r[0]), row(r[1]), row(r[2]), row(r[3]));
        for ((((o, &x0), &x1), &x2), &x3) in out.iter_mut().zip(c0).zip(c1).zip(c2).zip(c3) {
            *o += a[0] * x0 + a[1] * x1 + a[2] * x2 + a[3] * x3;
        }
    }
    let whole = rows.len() - rows.len() % 4;
    for (&r, &a) in rows[whole..].iter().zip(&weights[whole..]) {
        for (o, &x) in out.iter_mut().zip(row(r)) {
            *o += a * x;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform numbers in [0, 1) from a xorshift generator with this seed.
    fn uniform_from(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The bound of the module doc, checked directly: for random weights
    /// spanning 1 .. e^-46 and outputs of one sign per column with
    /// magnitudes over two decades, the rows `select` leaves out change no
    /// output by more than PRUNE_RELATIVE of its exact value
    /// sum_n a_n c_nk / S (computed here over every row), and some rows are
    /// left out. The listed rows are in order, with their own weights.
    #[test]
    fn rows_left_out_change_no_output_by_more_than_the_bound() {
        let (n, m) = (300, 6);
        let mut uniform = uniform_from(0x2545_f491_4f6c_dd1d);
        let names = |p: &str, k: usize| (0..k).map(|i| format!("{p}{i}")).collect::<Vec<_>>();
        let b: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let c: Vec<f64> = (0..n * m)
            .map(|i| {
                let sign = if i % m % 2 == 0 { 1.0 } else { -1.0 };
                sign * 10f64.powf(2.0 * uniform() - 1.0)
            })
            .collect();
        let matrix = ModelMatrix::new(names("b", 1), names("c", m), b, c.clone()).unwrap();
        let pruning = Pruning::new(&matrix);
        assert!(pruning.is_active());
        let mut left_out_total = 0;
        for trial in 0..50 {
            let mut a: Vec<f64> = (0..n).map(|_| (-46.0 * uniform()).exp()).collect();
            a[trial] = 1.0;
            a[(trial * 7 + 3) % n] = 0.0;
            let sum: f64 = a.iter().sum();
            let (mut rows, mut weights) = (vec![0; n], vec![0.0; n]);
            let used = pruning.select(&a, sum, &mut rows, &mut weights);
            assert!(rows[..used].windows(2).all(|w| w[0] < w[1]));
            assert!(rows[..used].iter().zip(&weights[..used]).all(|(&r, &w)| w == a[r] && w > 0.0));
            let kept: Vec<bool> = (0..n).map(|r| rows[..used].contains(&r)).collect();
            left_out_total += kept.iter().zip(&a).filter(|(k, a)| !**k && **a > 0.0).count();
            for k in 0..m {
                let exact: f64 = (0..n).map(|r| a[r] * c[r * m + k]).sum::<f64>() / sum;
                let change: f64 = (0..n).filter(|&r| !kept[r]).map(|r| a[r] * c[r * m + k].abs()).sum::<f64>() / sum;
                assert!(change <= PRUNE_RELATIVE * exact.abs(), "trial {trial}, output {k}: {change:e} vs {exact:e}");
            }
        }
        assert!(left_out_total > 100, "only {left_out_total} rows left out");
    }

    /// `classify` keeps exactly the rows `select` lists, with their
    /// weights: the wholly kept quads in `quads`, the rest in row order,
    /// for N a multiple of four and not, pruning active and not.
    #[test]
    fn classify_keeps_the_rows_select_lists() {
        let names = |p: &str, k: usize| (0..k).map(|i| format!("{p}{i}")).collect::<Vec<_>>();
        let mut uniform = uniform_from(0x9e37_79b9_7f4a_7c15);
        let (mut wholes, mut rests) = (0, 0);
        for (n, sign) in [(40, 1.0), (43, 1.0), (43, -1.0)] {
            // One output of one sign (pruning) or of both (none).
            let c: Vec<f64> =
                (0..n).map(|i| if i % 2 == 0 { 1.0 + uniform() } else { sign * (1.0 + uniform()) }).collect();
            let b: Vec<f64> = (0..n).map(|i| i as f64).collect();
            let pruning = Pruning::new(&ModelMatrix::new(names("b", 1), names("c", 1), b, c).unwrap());
            assert_eq!(pruning.is_active(), sign > 0.0);
            for trial in 0..20 {
                // Runs of kept and dropped rows: whole quads, partial ones.
                let a: Vec<f64> = (0..n)
                    .map(|r| if (r / (trial % 5 + 1) + trial) % 3 == 0 { 0.0 } else { (-46.0 * uniform()).exp() })
                    .collect();
                let sum: f64 = a.iter().sum();
                let (mut rows, mut weights) = (vec![0; n], vec![0.0; n]);
                let used = pruning.select(&a, sum, &mut rows, &mut weights);
                let (mut quads, mut quad_weights) = (vec![0; n / 4], vec![[0.0; 4]; n / 4]);
                let (mut rest_rows, mut rest_weights) = (vec![0; n], vec![0.0; n]);
                let (whole, rest) =
                    pruning.classify(&a, sum, &mut quads, &mut quad_weights, &mut rest_rows, &mut rest_weights);
                let mut listed: Vec<(usize, f64)> = quads[..whole]
                    .iter()
                    .zip(&quad_weights[..whole])
                    .flat_map(|(&q, w)| (0..4).map(move |i| (4 * q + i, w[i])))
                    .chain(rest_rows[..rest].iter().copied().zip(rest_weights[..rest].iter().copied()))
                    .collect();
                assert!(rest_rows[..rest].windows(2).all(|w| w[0] < w[1]));
                assert!(rest_rows[..rest].iter().all(|&r| r >= 4 * (n / 4) || !quads[..whole].contains(&(r / 4))));
                listed.sort_by_key(|&(r, _)| r);
                let selected: Vec<(usize, f64)> =
                    rows[..used].iter().copied().zip(weights[..used].iter().copied()).collect();
                assert_eq!(listed, selected, "N {n}, trial {trial}");
                (wholes, rests) = (wholes + whole, rests + rest);
            }
        }
        assert!(wholes > 50 && rests > 50, "{wholes} whole quads, {rests} other rows");
    }

    /// An output that changes sign or is zero somewhere disables pruning:
    /// every non-zero weight is listed.
    #[test]
    fn outputs_of_both_signs_or_zero_disable_pruning() {
        let names = |p: &str, k: usize| (0..k).map(|i| format!("{p}{i}")).collect::<Vec<_>>();
        for column in [[1.0, -1.0, 2.0], [1.0, 0.0, 2.0]] {
            let c: Vec<f64> = column.iter().flat_map(|&v| [v, 5.0]).collect();
            let matrix = ModelMatrix::new(names("b", 1), names("c", 2), vec![0.0, 1.0, 2.0], c).unwrap();
            let pruning = Pruning::new(&matrix);
            assert!(!pruning.is_active());
            let (mut rows, mut weights) = (vec![0; 3], vec![0.0; 3]);
            assert_eq!(pruning.select(&[1.0, 0.0, 1e-300], 1.0, &mut rows, &mut weights), 2);
            assert_eq!(rows[..2], [0, 2]);
        }
    }
}
