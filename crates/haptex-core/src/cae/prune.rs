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
//! a prediction divides by the same S but leaves out a set O of rows
//! with sum_{n in O} a_n rho_n <= eps S, eps = [`PRUNE_RELATIVE`]. They
//! change output k by at most
//!
//!   sum_O a_n |c_nk| / S <= F_k sum_O a_n rho_n / S <= eps F_k <= eps |c_k|.
//!
//! O is the rows with a_n rho_n <= 2^J eps S / N for the largest J >= 0
//! for which their sum is within the budget eps S. J = 0 always is (at
//! most N rows, each at most eps S / N): that was the whole rule until
//! 2026-11-28. Taking the largest J spends the budget on the smallest
//! weights first, as sorting them would, but in one pass over the rows
//! with no sort: the rows are counted into octaves of a_n rho_n below
//! eps S (`Pruning::threshold`), and J is where the octaves' running sum
//! passes the budget. At the benchmark's N 405 this leaves out 15 more
//! of the 362 rows a query read under J = 0 (4%).
//!
//! When some output changes sign or is zero somewhere (there is no such
//! F_k > 0), nothing beyond the cutoff is left out.

use super::ModelMatrix;

/// Bound on the relative change of any output of a prediction by the
/// model vectors it leaves out beyond the cutoff (see the module doc):
/// 1e-16, below the unit roundoff of a double (1.1e-16).
pub const PRUNE_RELATIVE: f64 = 1e-16;

/// The mantissa bits of a double.
const MANTISSA: u64 = (1 << 52) - 1;

/// The pruning ratios rho_n of a model matrix, if its outputs allow
/// pruning.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Pruning {
    /// The model matrix row at each position of the estimator's own row
    /// order (`panels::z_order`), in which the weights come.
    order: Vec<usize>,
    /// rho_n per position when pruning; 1 for every one otherwise (so
    /// that a_n rho_n > 0 is a_n > 0).
    ratio: Vec<f64>,
    /// Every output is of one sign over the database and never zero.
    active: bool,
}

impl Pruning {
    /// The pruning ratios of `matrix`, for weights that come in `order`
    /// (the matrix row at each position).
    pub(crate) fn new(matrix: &ModelMatrix, order: &[usize]) -> Self {
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
        let active = (0..m).all(|k| floor[k] > 0.0 && !(positive[k] && negative[k]));
        let ratio = if active {
            // An overflow to infinity (|c| / F beyond 1.8e308) only keeps that row.
            let row = |r: usize| &c[r * m..(r + 1) * m];
            order.iter().map(|&r| row(r).iter().zip(&floor).map(|(v, f)| v.abs() / f).fold(1.0, f64::max)).collect()
        } else {
            vec![1.0; order.len()]
        };
        Self { order: order.to_vec(), ratio, active }
    }

    /// The matrix row at each position of the weights.
    pub(crate) fn order(&self) -> &[usize] {
        &self.order
    }

    /// True if predictions may leave out rows beyond the cutoff.
    pub(crate) fn is_active(&self) -> bool {
        self.active
    }

    /// The rows a prediction keeps are those with a_n rho_n above this,
    /// given the weights of every row (0 below the cutoff) and their sum
    /// S: 2^J eps S / N with the largest J >= 0 for which the rows at or
    /// below it sum to at most eps S (the module doc) when pruning, 0
    /// otherwise (rho_n = 1 then, so a zero weight is never kept).
    pub(crate) fn threshold(&self, weights: &[f64], sum: f64) -> f64 {
        let n = weights.len();
        if !self.active || n == 0 {
            return 0.0;
        }
        let budget = PRUNE_RELATIVE * sum;
        let base = budget / n as f64;
        // Octave j >= 1 holds the rows with 2^(j-1) base < a_n rho_n <=
        // 2^j base, octave 0 those at or below base; past octave
        // ceil(log2 N) a row alone is over the budget. The octave of a
        // value from the bits of it and of base (both positive and
        // normal: S >= 1, the largest weight being 1, and a_n >= e^-46
        // when it is not 0): 2^j base is base with j added to its
        // exponent, so v <= 2^j base holds from the first j at which v's
        // exponent is at most base's plus j, or equal with a mantissa at
        // most base's.
        let top = n.next_power_of_two().trailing_zeros() as usize;
        let ceiling = base * (1u64 << top) as f64;
        let (base_exponent, base_mantissa) = (base.to_bits() >> 52, base.to_bits() & MANTISSA);
        let mut octaves = [0.0f64; 65];
        let mut count = |v: f64| {
            if v <= ceiling {
                let j = if v <= base {
                    0
                } else {
                    let (exponent, mantissa) = (v.to_bits() >> 52, v.to_bits() & MANTISSA);
                    (exponent - base_exponent) as usize + usize::from(mantissa > base_mantissa)
                };
                octaves[j] += v;
            }
        };
        // Four rows at a time: most are far above the ceiling, and one
        // test of four products is one branch instead of four.
        let ratio = &self.ratio[..n];
        for (a, rho) in weights.chunks_exact(4).zip(ratio.chunks_exact(4)) {
            let v = [a[0] * rho[0], a[1] * rho[1], a[2] * rho[2], a[3] * rho[3]];
            if v.iter().any(|&v| v <= ceiling) {
                v.into_iter().for_each(&mut count);
            }
        }
        let first = n - n % 4;
        weights[first..].iter().zip(&ratio[first..]).for_each(|(&a, &rho)| count(a * rho));
        let mut below = 0.0;
        let mut octave = 0;
        for (j, &total) in octaves.iter().enumerate().take(top + 1) {
            below += total;
            if below > budget {
                break;
            }
            octave = j;
        }
        base * (1u64 << octave) as f64
    }

    /// Lists the rows a prediction sums, from the weights at every
    /// position (0 below the cutoff) and their sum S: their matrix rows
    /// into `rows` and their weights into `row_weights`, in the order of
    /// the positions, returning how many. Without branches: every position
    /// is written, and the list grows by one when the row is kept.
    #[inline(always)]
    pub(crate) fn select(&self, weights: &[f64], sum: f64, rows: &mut [usize], row_weights: &mut [f64]) -> usize {
        let n = weights.len();
        let (rows, row_weights, ratio, order) =
            (&mut rows[..n], &mut row_weights[..n], &self.ratio[..n], &self.order[..n]);
        let threshold = self.threshold(weights, sum);
        let mut used = 0;
        for ((&a, &rho), &row) in weights.iter().zip(ratio).zip(order) {
            (rows[used], row_weights[used]) = (row, a);
            used += usize::from(keeps(a, rho, threshold));
        }
        used
    }

    /// The rows [`Pruning::select`] lists, sorted by quads (positions 4q
    /// to 4q + 3): the quads with at least three rows kept go to `quads`
    /// and `quad_weights` (a row left out with weight 0: reading a quad's
    /// panel is one sequential stream, faster than three rows read one by
    /// one, see `panels`), the matrix rows of the other kept rows to
    /// `rows` and their weights to `row_weights`, both in the order of the
    /// positions. Returns how many quads, how many rows and how many rows
    /// are kept in all. Without branches on single rows: every slot of
    /// `rows` up to N may be written.
    pub(crate) fn classify(
        &self,
        weights: &[f64],
        sum: f64,
        quads: &mut [usize],
        quad_weights: &mut [[f64; 4]],
        rows: &mut [usize],
        row_weights: &mut [f64],
    ) -> (usize, usize, usize) {
        let n = weights.len();
        let (rows, row_weights, ratio, order) =
            (&mut rows[..n], &mut row_weights[..n], &self.ratio[..n], &self.order[..n]);
        let (quads, quad_weights) = (&mut quads[..n / 4], &mut quad_weights[..n / 4]);
        let threshold = self.threshold(weights, sum);
        let (mut whole, mut rest, mut kept_rows) = (0, 0, 0);
        for (q, (a, rho)) in weights.chunks_exact(4).zip(ratio.chunks_exact(4)).enumerate() {
            let a: [f64; 4] = a.try_into().expect("four weights");
            let kept = [
                keeps(a[0], rho[0], threshold),
                keeps(a[1], rho[1], threshold),
                keeps(a[2], rho[2], threshold),
                keeps(a[3], rho[3], threshold),
            ];
            let count = kept.iter().map(|&k| usize::from(k)).sum::<usize>();
            kept_rows += count;
            if count >= 3 {
                let zero_left_out = |i: usize| if kept[i] { a[i] } else { 0.0 };
                (quads[whole], quad_weights[whole]) =
                    (q, [zero_left_out(0), zero_left_out(1), zero_left_out(2), zero_left_out(3)]);
                whole += 1;
            } else {
                for i in 0..4 {
                    (rows[rest], row_weights[rest]) = (order[4 * q + i], a[i]);
                    rest += usize::from(kept[i]);
                }
            }
        }
        let in_quads = rest;
        let first = n - n % 4;
        for ((&a, &rho), &row) in weights.iter().zip(ratio).zip(order).skip(first) {
            (rows[rest], row_weights[rest]) = (row, a);
            rest += usize::from(keeps(a, rho, threshold));
        }
        (whole, rest, kept_rows + rest - in_quads)
    }
}

/// Whether a prediction sums a row of weight a_n and pruning ratio rho_n,
/// given [`Pruning::threshold`].
#[inline(always)]
fn keeps(a: f64, rho: f64, threshold: f64) -> bool {
    a * rho > threshold
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
        let pruning = Pruning::new(&matrix, &(0..matrix.n()).collect::<Vec<_>>());
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
    /// weights and matrix rows: the quads with three or four rows kept in
    /// `quads` (a row left out with weight 0), the rest in the order of the
    /// positions, for N a multiple of four and not, pruning active and
    /// not, with the weights in an order other than the matrix's.
    #[test]
    fn classify_keeps_the_rows_select_lists() {
        let names = |p: &str, k: usize| (0..k).map(|i| format!("{p}{i}")).collect::<Vec<_>>();
        let mut uniform = uniform_from(0x9e37_79b9_7f4a_7c15);
        let (mut wholes, mut three_row_quads, mut rests) = (0, 0, 0);
        for (n, sign) in [(40, 1.0), (43, 1.0), (43, -1.0)] {
            // One output of one sign (pruning) or of both (none).
            let c: Vec<f64> =
                (0..n).map(|i| if i % 2 == 0 { 1.0 + uniform() } else { sign * (1.0 + uniform()) }).collect();
            let b: Vec<f64> = (0..n).map(|i| i as f64).collect();
            let matrix = ModelMatrix::new(names("b", 1), names("c", 1), b, c).unwrap();
            // Position j holds matrix row 7j mod N (7 and N coprime).
            let order: Vec<usize> = (0..n).map(|j| 7 * j % n).collect();
            let pruning = Pruning::new(&matrix, &order);
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
                let (whole, rest, kept) =
                    pruning.classify(&a, sum, &mut quads, &mut quad_weights, &mut rest_rows, &mut rest_weights);
                assert_eq!(kept, used, "N {n}, trial {trial}");
                for (&q, w) in quads[..whole].iter().zip(&quad_weights[..whole]) {
                    let zeros = w.iter().filter(|&&w| w == 0.0).count();
                    assert!(zeros <= 1, "N {n}, trial {trial}: quad {q} with {zeros} rows left out");
                    three_row_quads += zeros;
                    assert!((0..4).all(|i| w[i] == 0.0 || w[i] == a[4 * q + i]));
                }
                let mut listed: Vec<(usize, f64)> = quads[..whole]
                    .iter()
                    .zip(&quad_weights[..whole])
                    .flat_map(|(&q, w)| (0..4).map(move |i| (q, i, w[i])))
                    .filter(|&(_, _, w)| w != 0.0)
                    .map(|(q, i, w)| (order[4 * q + i], w))
                    .chain(rest_rows[..rest].iter().copied().zip(rest_weights[..rest].iter().copied()))
                    .collect();
                // The other rows in the order of their positions, none of them in a listed quad.
                let position = |r: usize| order.iter().position(|&o| o == r).unwrap();
                assert!(rest_rows[..rest].windows(2).all(|w| position(w[0]) < position(w[1])));
                assert!(rest_rows[..rest].iter().all(|&r| {
                    let p = position(r);
                    p >= 4 * (n / 4) || !quads[..whole].contains(&(p / 4))
                }));
                listed.sort_by_key(|&(r, _)| r);
                let mut selected: Vec<(usize, f64)> =
                    rows[..used].iter().copied().zip(weights[..used].iter().copied()).collect();
                selected.sort_by_key(|&(r, _)| r);
                assert_eq!(listed, selected, "N {n}, trial {trial}");
                (wholes, rests) = (wholes + whole, rests + rest);
            }
        }
        assert!(
            wholes > 50 && three_row_quads > 10 && rests > 50,
            "{wholes} quads ({three_row_quads} of three rows), {rests} other rows"
        );
    }

    /// An output that changes sign or is zero somewhere disables pruning:
    /// every non-zero weight is listed.
    #[test]
    fn outputs_of_both_signs_or_zero_disable_pruning() {
        let names = |p: &str, k: usize| (0..k).map(|i| format!("{p}{i}")).collect::<Vec<_>>();
        for column in [[1.0, -1.0, 2.0], [1.0, 0.0, 2.0]] {
            let c: Vec<f64> = column.iter().flat_map(|&v| [v, 5.0]).collect();
            let matrix = ModelMatrix::new(names("b", 1), names("c", 2), vec![0.0, 1.0, 2.0], c).unwrap();
            let pruning = Pruning::new(&matrix, &(0..matrix.n()).collect::<Vec<_>>());
            assert!(!pruning.is_active());
            let (mut rows, mut weights) = (vec![0; 3], vec![0.0; 3]);
            assert_eq!(pruning.select(&[1.0, 0.0, 1e-300], 1.0, &mut rows, &mut weights), 2);
            assert_eq!(rows[..2], [0, 2]);
        }
    }
}
