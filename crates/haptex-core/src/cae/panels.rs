//! The outputs of a model matrix laid out for one prediction's sum
//! (eq. 11), so that the sum reads memory as one sequential stream.
//!
//! Row-major outputs summed four rows at a time are four streams 4 M bytes
//! apart; on AMD EPYC (KVM guest, 2026-11-25) that sum ran at 1.14x the
//! time of one sequential read of the same 1.62 MB (N 405, M 500), and the
//! same sum over this layout at 1.02x. Here the rows are taken in quads
//! (positions 4q .. 4q + 3 of a row order, `z_order`, that puts near
//! neighbours in input space together) and each quad is stored as M/4
//! blocks of 16 values: the quad's four rows' outputs 4j .. 4j + 3, row
//! after row, each block on a 64-byte boundary. Rows past N and outputs
//! past M are zeros. The layout costs a second copy of the outputs (N x M
//! doubles, rounded up to multiples of 4). A prediction lists the quads it
//! reads (`sum_quads`).
//!
//! Rows read one by one from the row-major outputs are short streams
//! (M doubles) and cost more per byte than a quad: on AMD EPYC (Zen 5, KVM
//! guest, 2026-11-28) 1.45-1.64x the floor's time per byte, against
//! 1.00-1.04x for the panels. So a prediction reads a quad from the panels
//! as soon as three of its rows enter (16 KB instead of 12 KB, the fourth
//! row with weight 0), and only quads with one or two rows row by row.

/// Rows per quad and outputs per block.
const LANES: usize = 4;

/// One block of a quad: its four rows' outputs 4j .. 4j + 3 (128 bytes),
/// on a 64-byte boundary so that no 32-byte load straddles two cache
/// lines. (A copy of the outputs 16 bytes off that alignment streamed
/// 9% slower: 19.1 against 17.5 µs, AMD EPYC, KVM guest, 2026-11-26. Where
/// the allocator put a plain `Vec<f64>` decided which of the two a run
/// got.)
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Block([f64; LANES * LANES]);

/// The outputs C (N x M) as quads of rows, interleaved four outputs at a
/// time.
#[derive(Debug, Clone)]
pub(crate) struct Panels {
    data: Vec<Block>,
    m: usize,
    /// Blocks of four outputs per quad: ceil(M / 4).
    blocks: usize,
}

impl Panels {
    /// The panels of the N x M row-major outputs `c`, their rows taken in
    /// `order` (the matrix row at each position; quad q holds positions
    /// 4q .. 4q + 3).
    pub(crate) fn new(c: &[f64], n: usize, m: usize, order: &[usize]) -> Self {
        assert_eq!(c.len(), n * m, "an N x M matrix");
        assert_eq!(order.len(), n, "a position per row");
        let (quads, blocks) = (n.div_ceil(LANES), m.div_ceil(LANES));
        let mut data = vec![Block([0.0; LANES * LANES]); quads * blocks];
        for (position, &row) in order.iter().enumerate() {
            let values = &c[row * m..(row + 1) * m];
            let (q, i) = (position / LANES, position % LANES);
            for (k, &v) in values.iter().enumerate() {
                let (j, l) = (k / LANES, k % LANES);
                data[q * blocks + j].0[i * LANES + l] = v;
            }
        }
        Self { data, m, blocks }
    }

    /// out = sum over the quads listed in `quads` (increasing) of their
    /// four rows' a_n C_n, `weights[i]` the weights of rows 4q .. 4q + 3
    /// of quad q = quads[i] (eq. 11 before the division by the sum of the
    /// weights). Each output is updated per quad as
    /// out_k += ((a_0 c_0k + a_1 c_1k) + a_2 c_2k) + a_3 c_3k (no fused
    /// multiply-add), so the AVX2 build used where the CPU has it gives the
    /// same bits as the portable one, and a quad adds exactly what
    /// `prune::add_weighted_rows` adds for its four rows.
    pub(crate) fn sum_quads(&self, out: &mut [f64], quads: &[usize], weights: &[[f64; 4]]) {
        assert_eq!(out.len(), self.m, "M outputs");
        assert_eq!(quads.len(), weights.len(), "one weight quad per quad");
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above; the
            // length was checked above.
            return unsafe { self.sum_quads_avx2(out, quads, weights) };
        }
        self.sum_quads_portable(out, quads, weights)
    }

    fn sum_quads_portable(&self, out: &mut [f64], quads: &[usize], weights: &[[f64; 4]]) {
        let mut acc = vec![0.0; self.blocks * LANES];
        for (&q, w) in quads.iter().zip(weights) {
            let quad = &self.data[q * self.blocks..(q + 1) * self.blocks];
            for (o, Block(v)) in acc.chunks_exact_mut(LANES).zip(quad) {
                for l in 0..LANES {
                    o[l] += ((w[0] * v[l] + w[1] * v[4 + l]) + w[2] * v[8 + l]) + w[3] * v[12 + l];
                }
            }
        }
        out.copy_from_slice(&acc[..self.m]);
    }

    /// The AVX2 build: one register per block of four outputs.
    ///
    /// # Safety
    /// The CPU must support AVX2; `out` holds M values (checked by the
    /// caller).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn sum_quads_avx2(&self, out: &mut [f64], quads: &[usize], weights: &[[f64; 4]]) {
        use std::arch::x86_64::{
            _mm256_add_pd, _mm256_load_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_storeu_pd,
        };
        let whole = self.m / LANES;
        let (body, tail) = out.split_at_mut(whole * LANES);
        body.fill(0.0);
        let mut last = [0.0f64; LANES];
        for (&q, w) in quads.iter().zip(weights) {
            let quad = &self.data[q * self.blocks..(q + 1) * self.blocks];
            let p = quad.as_ptr().cast::<f64>();
            // SAFETY: `quad` is a bounds-checked slice of `blocks` Blocks;
            // block j is quad[j], 16 doubles from p + 16 j (a Block is 16
            // doubles, no padding, 64-byte aligned), j < blocks; body holds
            // `whole` blocks of four and `last` one.
            unsafe {
                let (w0, w1, w2, w3) =
                    (_mm256_set1_pd(w[0]), _mm256_set1_pd(w[1]), _mm256_set1_pd(w[2]), _mm256_set1_pd(w[3]));
                let block = |j: usize| {
                    let v = p.add(j * LANES * LANES);
                    let s01 = _mm256_add_pd(
                        _mm256_mul_pd(w0, _mm256_load_pd(v)),
                        _mm256_mul_pd(w1, _mm256_load_pd(v.add(4))),
                    );
                    let s012 = _mm256_add_pd(s01, _mm256_mul_pd(w2, _mm256_load_pd(v.add(8))));
                    _mm256_add_pd(s012, _mm256_mul_pd(w3, _mm256_load_pd(v.add(12))))
                };
                let o = body.as_mut_ptr();
                for j in 0..whole {
                    let sum = _mm256_add_pd(_mm256_loadu_pd(o.add(j * LANES)), block(j));
                    _mm256_storeu_pd(o.add(j * LANES), sum);
                }
                if whole < self.blocks {
                    let sum = _mm256_add_pd(_mm256_loadu_pd(last.as_ptr()), block(whole));
                    _mm256_storeu_pd(last.as_mut_ptr(), sum);
                }
            }
        }
        tail.copy_from_slice(&last[..tail.len()]);
    }
}

/// A row order in which the rows of each quad lie close together in input
/// space: the Z-order (Morton) curve through the normalized inputs `b` (N x
/// D, row-major, in [0, 1] for the inputs `varies(l)` says vary; the others
/// are left out), rows of equal key in matrix order. A query's kernels
/// then leave out whole quads more often and cut fewer in parts (on the
/// benchmark's 16 queries, N 405: 6.8 quads left out, 4.6 with three rows
/// entering and 10.8 with one or two, against 3.9, 16.9 and 10.4 in matrix
/// order). Returns the matrix row at each position.
pub(crate) fn z_order(b: &[f64], d: usize, varies: impl Fn(usize) -> bool) -> Vec<usize> {
    let n = b.len().checked_div(d).unwrap_or(0);
    let inputs: Vec<usize> = (0..d).filter(|&l| varies(l)).collect();
    if inputs.is_empty() {
        return (0..n).collect();
    }
    // As many bits of each input as fit in a 64-bit key, at most 16.
    let bits = (64 / inputs.len()).clamp(1, 16);
    let scale = ((1u64 << bits) - 1) as f64;
    let key = |row: &[f64]| {
        let mut key = 0u64;
        for bit in (0..bits).rev() {
            for &l in &inputs {
                let q = (row[l].clamp(0.0, 1.0) * scale).round() as u64;
                key = (key << 1) | ((q >> bit) & 1);
            }
        }
        key
    };
    let mut order: Vec<(u64, usize)> = b.chunks_exact(d).enumerate().map(|(r, row)| (key(row), r)).collect();
    order.sort_unstable();
    order.into_iter().map(|(_, r)| r).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the plain double sum, for sizes that are and are not
    /// multiples of four, with zero quads skipped; the AVX2 build and the
    /// portable one give the same bits.
    #[test]
    fn sums_every_row_and_both_builds_agree_to_the_bit() {
        for (n, m) in [(1, 1), (4, 4), (5, 7), (13, 501), (16, 3)] {
            let c: Vec<f64> = (0..n * m).map(|k| ((k * 7919) % 1000) as f64 / 997.0 - 0.3).collect();
            let panels = Panels::new(&c, n, m, &(0..n).collect::<Vec<_>>());
            let mut a = vec![0.0; n.div_ceil(LANES) * LANES];
            for (r, w) in a.iter_mut().enumerate().take(n) {
                // The second quad all zero: skipped.
                *w = if r / 4 == 1 { 0.0 } else { 1.0 / (1.0 + r as f64) };
            }
            // Every quad but the all-zero one, the last partial quad's
            // missing rows with zero weights.
            let quads: Vec<usize> = (0..n.div_ceil(LANES)).filter(|&q| q != 1).collect();
            let weights: Vec<[f64; 4]> =
                quads.iter().map(|&q| [a[4 * q], a[4 * q + 1], a[4 * q + 2], a[4 * q + 3]]).collect();
            let mut out = vec![f64::NAN; m];
            panels.sum_quads(&mut out, &quads, &weights);
            let mut portable = vec![f64::NAN; m];
            panels.sum_quads_portable(&mut portable, &quads, &weights);
            assert_eq!(
                out.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                portable.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "({n}, {m})"
            );
            for k in 0..m {
                let exact: f64 = (0..n).map(|r| a[r] * c[r * m + k]).sum();
                assert!(
                    (out[k] - exact).abs() <= 1e-14 * (1.0 + exact.abs()),
                    "({n}, {m}) output {k}: {} against {exact}",
                    out[k]
                );
            }
        }
    }

    /// The Z-order is a permutation of the rows that walks a grid in 2 x 2
    /// squares: on a 4 x 4 grid of two inputs (a third one constant, left
    /// out), each quad of the order is one square of four neighbours, and
    /// the squares come in Z order. Repeated rows keep their matrix order.
    #[test]
    fn z_order_puts_neighbours_in_the_same_quad() {
        let mut b = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                b.extend([i as f64 / 3.0, 0.5, j as f64 / 3.0]);
            }
        }
        let order = z_order(&b, 3, |l| l != 1);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..16).collect::<Vec<_>>());
        let cell = |r: usize| (r / 4, r % 4);
        for (q, quad) in order.chunks_exact(4).enumerate() {
            let corner = (2 * (q / 2), 2 * (q % 2));
            let mut cells: Vec<_> = quad.iter().map(|&r| cell(r)).collect();
            cells.sort_unstable();
            let square = vec![corner, (corner.0, corner.1 + 1), (corner.0 + 1, corner.1), (corner.0 + 1, corner.1 + 1)];
            assert_eq!(cells, square, "quad {q}: {quad:?}");
        }
        // Every input constant: the matrix order; equal keys in matrix order.
        assert_eq!(z_order(&[0.5, 0.5, 0.5], 1, |_| false), [0, 1, 2]);
        assert_eq!(z_order(&[0.2, 0.7, 0.2, 0.7], 1, |_| true), [0, 2, 1, 3]);
    }
}
