//! Linear algebra on top of faer: the sparse Cholesky factorization of the
//! stiffness (symbolic analysis once, numeric factorization per time-step
//! size, solves without allocation) and small dense helpers.
//!
//! A factorization can also order a given set of unknowns (the pad's) last
//! ([`SparseCholesky::with_trailing`]). With K = [K_ii K_it; K_ti K_tt] in
//! that order, L = [L_ii 0; L_ti L_tt], and the Schur complement
//! S = K_tt - K_ti K_ii^-1 K_it, the condensed stiffness of the trailing
//! unknowns, is L_tt L_tt^T: it comes with the factorization, without one
//! solve per trailing unknown ([`SparseCholesky::trailing_factor`],
//! [`schur_compliance`]).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};
use std::sync::Arc;

use crate::assembly::Pattern;

/// The stiffness cannot be factorized.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FactorError {
    #[error("the stiffness matrix is not positive definite (is the body free to move? {0})")]
    NotPositiveDefinite(String),
    #[error("sparse factorization failed: {0}")]
    Faer(String),
    #[error("invalid set of unknowns to order last: {0}")]
    Trailing(String),
}

/// A sparse LL^T factorization with a fixed pattern.
pub struct SparseCholesky {
    pattern: Arc<SymbolicSparseColMat<usize>>,
    symbolic: Arc<SymbolicCholesky<usize>>,
    l_values: Vec<f64>,
    factor_scratch: MemBuffer,
    solve_scratch: MemBuffer,
    solve_columns: usize,
    factorized: bool,
    /// Number of unknowns ordered last (0: AMD throughout).
    trailing: usize,
}

impl SparseCholesky {
    /// Symbolic analysis (AMD ordering, elimination tree) of `pattern`.
    /// Solves of up to `max_rhs` right-hand sides at once need no allocation.
    pub fn new(pattern: &Pattern, max_rhs: usize) -> Result<Self, FactorError> {
        let faer_error = |e: faer::sparse::FaerError| FactorError::Faer(format!("{e:?}"));
        let symbolic_matrix = SymbolicSparseColMat::new_checked(
            pattern.n,
            pattern.n,
            pattern.col_ptr.clone(),
            None,
            pattern.row_idx.clone(),
        );
        let symbolic = factorize_symbolic_cholesky(
            symbolic_matrix.as_ref(),
            Side::Lower,
            SymmetricOrdering::Amd,
            // Supernodal: the multi-right-hand-side solves that build the pad
            // compliance then run as dense block operations.
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: faer::sparse::linalg::SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            },
        )
        .map_err(faer_error)?;
        Ok(Self::with_symbolic(Arc::new(symbolic_matrix), Arc::new(symbolic), max_rhs, 0))
    }

    /// Symbolic analysis of `pattern` with the unknowns `trailing` ordered
    /// last, in that order, and the others by AMD on their own graph: the
    /// last `trailing.len()` columns of the factor are then the Cholesky
    /// factor of the Schur complement on `trailing` (see the module doc and
    /// [`SparseCholesky::trailing_factor`]).
    pub fn with_trailing(pattern: &Pattern, trailing: &[usize], max_rhs: usize) -> Result<Self, FactorError> {
        let faer_error = |e: faer::sparse::FaerError| FactorError::Faer(format!("{e:?}"));
        let n = pattern.n;
        // Interior numbering (order kept, so the lower triangle stays lower
        // and sorted); usize::MAX for the trailing unknowns.
        let mut interior = vec![0usize; n];
        for &t in trailing {
            if t >= n {
                return Err(FactorError::Trailing(format!("unknown {t} of {n}")));
            }
            if interior[t] == usize::MAX {
                return Err(FactorError::Trailing(format!("unknown {t} listed twice")));
            }
            interior[t] = usize::MAX;
        }
        let mut interior_to_full = Vec::with_capacity(n - trailing.len());
        for (j, slot) in interior.iter_mut().enumerate() {
            if *slot != usize::MAX {
                *slot = interior_to_full.len();
                interior_to_full.push(j);
            }
        }
        let ni = interior_to_full.len();
        let mut col_ptr = Vec::with_capacity(ni + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for &j in &interior_to_full {
            for &i in &pattern.row_idx[pattern.col_ptr[j]..pattern.col_ptr[j + 1]] {
                if interior[i] != usize::MAX {
                    row_idx.push(interior[i]);
                }
            }
            col_ptr.push(row_idx.len());
        }
        let mut perm = vec![0usize; ni];
        let mut perm_inv = vec![0usize; ni];
        if ni > 0 {
            let sub = SymbolicSparseColMat::new_checked(ni, ni, col_ptr, None, row_idx);
            let mut memory = MemBuffer::try_new(faer::sparse::linalg::amd::order_maybe_unsorted_scratch::<usize>(
                ni,
                sub.compute_nnz(),
            ))
            .map_err(|_| FactorError::Faer("out of memory for the ordering".into()))?;
            faer::sparse::linalg::amd::order_maybe_unsorted(
                &mut perm,
                &mut perm_inv,
                sub.as_ref(),
                Default::default(),
                MemStack::new(&mut memory),
            )
            .map_err(faer_error)?;
        }
        // Position -> unknown, and its inverse.
        let forward: Vec<usize> = perm.iter().map(|&p| interior_to_full[p]).chain(trailing.iter().copied()).collect();
        let mut inverse = vec![0usize; n];
        for (position, &unknown) in forward.iter().enumerate() {
            inverse[unknown] = position;
        }
        let symbolic_matrix =
            SymbolicSparseColMat::new_checked(n, n, pattern.col_ptr.clone(), None, pattern.row_idx.clone());
        let ordering = faer::perm::PermRef::new_checked(&forward, &inverse, n);
        let symbolic = factorize_symbolic_cholesky(
            symbolic_matrix.as_ref(),
            Side::Lower,
            SymmetricOrdering::Custom(ordering),
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: faer::sparse::linalg::SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            },
        )
        .map_err(faer_error)?;
        Ok(Self::with_symbolic(Arc::new(symbolic_matrix), Arc::new(symbolic), max_rhs, trailing.len()))
    }

    fn with_symbolic(
        pattern: Arc<SymbolicSparseColMat<usize>>,
        symbolic: Arc<SymbolicCholesky<usize>>,
        max_rhs: usize,
        trailing: usize,
    ) -> Self {
        let factor_scratch =
            MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        let solve_columns = max_rhs.max(1);
        let solve_scratch = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(solve_columns, Par::Seq));
        let l_values = vec![0.0; symbolic.len_val()];
        Self { pattern, symbolic, l_values, factor_scratch, solve_scratch, solve_columns, factorized: false, trailing }
    }

    /// A second factorization of the same pattern, sharing the symbolic
    /// analysis (for another time-step size).
    pub fn share(&self, max_rhs: usize) -> Self {
        Self::with_symbolic(self.pattern.clone(), self.symbolic.clone(), max_rhs, self.trailing)
    }

    /// Number of unknowns.
    pub fn n(&self) -> usize {
        self.symbolic.nrows()
    }

    /// Number of stored entries of the factor L.
    pub fn factor_nnz(&self) -> usize {
        self.l_values.len()
    }

    /// Numeric factorization of the matrix with the analysed pattern and
    /// lower-triangle `values`.
    pub fn factorize(&mut self, values: &[f64]) -> Result<(), FactorError> {
        self.factorized = false;
        let matrix = SparseColMatRef::new(self.pattern.as_ref().as_ref(), values);
        self.symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.l_values,
                matrix,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.factor_scratch),
                Default::default(),
            )
            .map_err(|e| FactorError::NotPositiveDefinite(format!("{e:?}")))?;
        self.factorized = true;
        Ok(())
    }

    /// Solves A X = B in place for the columns of `rhs` (n x k, k <= max_rhs).
    pub fn solve_in_place(&mut self, rhs: MatMut<'_, f64>) {
        assert!(self.factorized, "solve before a successful factorization");
        assert!(rhs.ncols() <= self.solve_columns, "more right-hand sides than the workspace holds");
        LltRef::new(&self.symbolic, &self.l_values).solve_in_place_with_conj(
            Conj::No,
            rhs,
            Par::Seq,
            MemStack::new(&mut self.solve_scratch),
        );
    }

    /// Solves A x = b in place for one vector.
    pub fn solve_vec(&mut self, b: &mut [f64]) {
        let n = b.len();
        self.solve_in_place(MatMut::from_column_major_slice_mut(b, n, 1));
    }

    /// The forward half of a solve: y = L^-1 Pi b, Pi the fill-reducing
    /// ordering; `y` is in the factor's order, so with
    /// [`SparseCholesky::with_trailing`] its last entries are those of the
    /// trailing unknowns, in their given order.
    pub fn forward(&mut self, b: &[f64], y: &mut [f64]) {
        assert!(self.factorized, "solve before a successful factorization");
        let n = self.n();
        assert!(b.len() == n && y.len() == n, "vectors of the wrong size");
        match self.symbolic.perm() {
            Some(perm) => {
                for (yi, &from) in y.iter_mut().zip(perm.arrays().0) {
                    *yi = b[from];
                }
            }
            None => y.copy_from_slice(b),
        }
        let rhs = MatMut::from_column_major_slice_mut(y, n, 1);
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(symbolic) => {
                faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef::new(symbolic, &self.l_values)
                    .l_solve_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut self.solve_scratch));
            }
            SymbolicCholeskyRaw::Simplicial(symbolic) => {
                let l = SparseColMatRef::new(symbolic.factor(), &self.l_values);
                faer::sparse::linalg::triangular_solve::solve_lower_triangular_in_place(l, Conj::No, rhs, Par::Seq);
            }
        }
    }

    /// The backward half of a solve: x = Pi^T L^-T y (`y`, in the factor's
    /// order, is overwritten). `backward(forward(b))` solves A x = b.
    pub fn backward(&mut self, y: &mut [f64], x: &mut [f64]) {
        assert!(self.factorized, "solve before a successful factorization");
        let n = self.n();
        assert!(x.len() == n && y.len() == n, "vectors of the wrong size");
        let rhs = MatMut::from_column_major_slice_mut(y, n, 1);
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(symbolic) => {
                faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef::new(symbolic, &self.l_values)
                    .l_transpose_solve_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut self.solve_scratch));
            }
            SymbolicCholeskyRaw::Simplicial(symbolic) => {
                let l = SparseColMatRef::new(symbolic.factor(), &self.l_values);
                faer::sparse::linalg::triangular_solve::solve_lower_triangular_transpose_in_place(
                    l,
                    Conj::No,
                    rhs,
                    Par::Seq,
                );
            }
        }
        match self.symbolic.perm() {
            Some(perm) => {
                for (&yi, &to) in y.iter().zip(perm.arrays().0) {
                    x[to] = yi;
                }
            }
            None => x.copy_from_slice(y),
        }
    }

    /// Number of unknowns ordered last ([`SparseCholesky::with_trailing`]).
    pub fn trailing(&self) -> usize {
        self.trailing
    }

    /// Writes the trailing block L_tt of the factor (m x m, m =
    /// [`SparseCholesky::trailing`], column-major, zero above the
    /// diagonal; rows and columns in the order the trailing unknowns were
    /// given) into `out`: L_tt L_tt^T is the Schur complement of the
    /// factorized matrix on them.
    pub fn trailing_factor(&self, out: &mut [f64]) {
        assert!(self.factorized, "trailing factor before a successful factorization");
        let m = self.trailing;
        assert_eq!(out.len(), m * m, "trailing factor buffer of the wrong size");
        out.fill(0.0);
        let first = self.n() - m;
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(symbolic) => {
                let factor =
                    faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef::new(symbolic, &self.l_values);
                for s in 0..symbolic.n_supernodes() {
                    let node = factor.supernode(s);
                    let values = node.val();
                    let (start, width) = (node.start(), values.ncols());
                    if start + width <= first {
                        continue;
                    }
                    for local_col in 0..width {
                        let col = start + local_col;
                        if col < first {
                            continue;
                        }
                        let target = &mut out[(col - first) * m..(col - first + 1) * m];
                        for local_row in local_col..width {
                            target[start + local_row - first] = values[(local_row, local_col)];
                        }
                        for (k, &row) in node.pattern().iter().enumerate() {
                            target[row - first] = values[(width + k, local_col)];
                        }
                    }
                }
            }
            SymbolicCholeskyRaw::Simplicial(symbolic) => {
                let (col_ptr, row_idx) = (symbolic.col_ptr(), symbolic.row_idx());
                for col in first..self.n() {
                    let target = &mut out[(col - first) * m..(col - first + 1) * m];
                    for slot in col_ptr[col]..col_ptr[col + 1] {
                        target[row_idx[slot] - first] = self.l_values[slot];
                    }
                }
            }
        }
    }
}

/// The compliance of the trailing unknowns from the trailing factor `l`
/// (m x m, column-major lower, see [`SparseCholesky::trailing_factor`]):
/// C = S^-1 = L^-T L^-1, with S = L L^T their condensed stiffness (kept as
/// L: S x = L (L^T x), [`lower_times`] and [`upper_times`]), column-major
/// and exactly symmetric. `inverse` (m x m) is scratch (it ends with L^-1
/// in its lower triangle).
pub fn schur_compliance(l: &[f64], m: usize, inverse: &mut [f64], compliance: &mut [f64]) {
    use faer::linalg::matmul::triangular::{BlockStructure, matmul};
    use faer::{Accum, MatRef};
    let factor = MatRef::from_column_major_slice(l, m, m);
    inverse.fill(0.0);
    faer::linalg::triangular_inverse::invert_lower_triangular(
        MatMut::from_column_major_slice_mut(inverse, m, m),
        factor,
        Par::Seq,
    );
    let inverse = MatRef::from_column_major_slice(inverse, m, m);
    // The lower half only (half the work of the full product), mirrored.
    matmul(
        MatMut::from_column_major_slice_mut(compliance, m, m),
        BlockStructure::TriangularLower,
        Accum::Replace,
        inverse.transpose(),
        BlockStructure::TriangularUpper,
        inverse,
        BlockStructure::TriangularLower,
        1.0,
        Par::Seq,
    );
    for c in 0..m {
        for r in c + 1..m {
            compliance[r * m + c] = compliance[c * m + r];
        }
    }
}

/// Solves U x = b in place for a dense upper-triangular `u` (m x m,
/// column-major; with U = L^T, L^T x = b), by columns from the last (each
/// solved unknown's column subtracted at once, in SIMD lanes).
pub fn upper_solve(u: &[f64], m: usize, x: &mut [f64]) {
    struct Solve<'a>(&'a [f64], usize, &'a mut [f64]);
    impl pulp::WithSimd for Solve<'_> {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, _simd: S) {
            let Solve(u, m, x) = self;
            for k in (0..m).rev() {
                let column = &u[k * m..k * m + k + 1];
                let xk = x[k] / column[k];
                x[k] = xk;
                for (xi, uik) in x[..k].iter_mut().zip(column) {
                    *xi -= uik * xk;
                }
            }
        }
    }
    pulp::Arch::new().dispatch(Solve(u, m, x))
}

/// out = A x for a dense symmetric `a` (m x m, column-major), column by
/// column in SIMD lanes: each out_r sums A_rc x_c over c in order, as the
/// row-by-row dot product would, to the bit.
pub fn symmetric_times(a: &[f64], m: usize, x: &[f64], out: &mut [f64]) {
    pulp::Arch::new().dispatch(ColumnsTimes { a, m, x, out, shape: Shape::Full })
}

/// out = L x for a dense lower-triangular `l` (m x m, column-major), column
/// by column in SIMD lanes.
pub fn lower_times(l: &[f64], m: usize, x: &[f64], out: &mut [f64]) {
    pulp::Arch::new().dispatch(ColumnsTimes { a: l, m, x, out, shape: Shape::Lower })
}

/// out = U x for a dense upper-triangular `u` (m x m, column-major; with U
/// = L^T, out = L^T x), column by column in SIMD lanes, each out_i summed
/// over k = i, i + 1, ... in order as a dot product with L's column i
/// would.
pub fn upper_times(u: &[f64], m: usize, x: &[f64], out: &mut [f64]) {
    pulp::Arch::new().dispatch(ColumnsTimes { a: u, m, x, out, shape: Shape::Upper })
}

/// Which entries of a dense matrix's columns are stored.
#[derive(Clone, Copy, PartialEq)]
enum Shape {
    Full,
    /// Column c in rows 0..=c.
    Upper,
    /// Column c in rows c..m.
    Lower,
}

/// The loop of [`symmetric_times`] and [`upper_times`].
struct ColumnsTimes<'a> {
    a: &'a [f64],
    m: usize,
    x: &'a [f64],
    out: &'a mut [f64],
    shape: Shape,
}

impl pulp::WithSimd for ColumnsTimes<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let m = self.m;
        let out = &mut self.out[..m];
        out.fill(0.0);
        for (c, &xc) in self.x[..m].iter().enumerate() {
            let rows = match self.shape {
                Shape::Full => 0..m,
                Shape::Upper => 0..c + 1,
                Shape::Lower => c..m,
            };
            let column = &self.a[c * m + rows.start..c * m + rows.end];
            for (o, a) in out[rows].iter_mut().zip(column) {
                *o += a * xc;
            }
        }
    }
}

/// a . b of two long vectors, in four interleaved sums (so that it runs in
/// SIMD lanes).
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let mut sums = [0.0; 4];
    let (a4, b4) = (a[..n].chunks_exact(4), b[..n].chunks_exact(4));
    let (a_rest, b_rest) = (a4.remainder(), b4.remainder());
    for (a, b) in a4.zip(b4) {
        for k in 0..4 {
            sums[k] += a[k] * b[k];
        }
    }
    let mut sum = (sums[0] + sums[1]) + (sums[2] + sums[3]);
    for (a, b) in a_rest.iter().zip(b_rest) {
        sum += a * b;
    }
    sum
}

/// The transpose of the dense m x m `l` (column-major) into `t`.
pub fn transpose(l: &[f64], m: usize, t: &mut [f64]) {
    for c in 0..m {
        for r in 0..m {
            t[r * m + c] = l[c * m + r];
        }
    }
}

/// y += A x for a symmetric matrix stored as its lower triangle in `pattern`.
pub fn symmetric_matvec_add(pattern: &Pattern, values: &[f64], x: &[f64], y: &mut [f64]) {
    for j in 0..pattern.n {
        for slot in pattern.col_ptr[j]..pattern.col_ptr[j + 1] {
            let i = pattern.row_idx[slot];
            let a = values[slot];
            y[i] += a * x[j];
            if i != j {
                y[j] += a * x[i];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assembly::{DofMap, Pattern};

    /// A 1D chain of springs assembled through the pattern machinery (using
    /// 4-node "elements" whose y DOFs are fixed) solved against its exact
    /// solution: unit springs in series, fixed at 0, unit load at the end.
    #[test]
    fn cholesky_solves_a_spring_chain() {
        let n_links = 5;
        // Nodes 0..=n_links on a line; element e uses nodes (e, e+1, e+1, e)
        // is degenerate for Q4 but fine for the pattern test.
        let elements: Vec<[usize; 4]> = (0..n_links).map(|e| [e, e + 1, e + 1, e]).collect();
        let mut prescribed: Vec<usize> = (0..=n_links).map(|n| 2 * n + 1).collect();
        prescribed.push(0);
        let dofs = DofMap::new(n_links + 1, &prescribed);
        let all: Vec<usize> = (0..n_links).collect();
        let pattern = Pattern::new(&dofs, &elements, &all);
        let mut values = vec![0.0; pattern.nnz()];
        for e in 0..n_links {
            // Spring between x DOFs of local nodes 0 and 1, split over the
            // duplicated node pairs (0,3) and (1,2) with half stiffness each.
            let mut k = [[0.0; 8]; 8];
            for (a, b) in [(0, 2), (6, 4)] {
                k[a][a] += 0.5;
                k[b][b] += 0.5;
                k[a][b] -= 0.5;
                k[b][a] -= 0.5;
            }
            pattern.add_element(e, &k, &mut values);
        }
        let mut chol = SparseCholesky::new(&pattern, 1).unwrap();
        chol.factorize(&values).unwrap();
        let mut b = vec![0.0; n_links];
        b[n_links - 1] = 1.0;
        let rhs = b.clone();
        chol.solve_vec(&mut b);
        for (i, x) in b.iter().enumerate() {
            assert!((x - (i + 1) as f64).abs() < 1e-12, "x[{i}] = {x}");
        }
        let mut check = vec![0.0; n_links];
        symmetric_matvec_add(&pattern, &values, &b, &mut check);
        assert!(check.iter().zip(&rhs).all(|(a, b)| (a - b).abs() < 1e-12));
    }
}

#[cfg(test)]
mod trailing_tests {
    use super::*;
    use crate::assembly::{DofMap, Pattern};

    /// On a 4 x 3 grid of bilinear elements with one edge fixed, the
    /// trailing block of the pad-last factorization gives the same
    /// condensed stiffness and compliance as one solve per trailing
    /// unknown with the AMD factorization.
    #[test]
    fn trailing_factor_is_the_schur_complement() {
        let (nx, ny) = (5, 4);
        let node = |i: usize, j: usize| j * nx + i;
        let mut elements = Vec::new();
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                elements.push([node(i, j), node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)]);
            }
        }
        // Fixed bottom edge; the top edge's DOFs are the trailing ones.
        let prescribed: Vec<usize> = (0..nx).flat_map(|i| [2 * node(i, 0), 2 * node(i, 0) + 1]).collect();
        let dofs = DofMap::new(nx * ny, &prescribed);
        let all: Vec<usize> = (0..elements.len()).collect();
        let pattern = Pattern::new(&dofs, &elements, &all);
        // An SPD element matrix: a spring between every pair of DOFs of
        // the same direction, of varying stiffness, plus a small diagonal.
        let mut values = vec![0.0; pattern.nnz()];
        for e in 0..elements.len() {
            let mut k = [[0.0; 8]; 8];
            for a in 0..8 {
                k[a][a] += 0.01 * (1 + e % 3) as f64;
                for b in 0..8 {
                    if a != b && a % 2 == b % 2 {
                        let w = 1.0 + 0.1 * ((a + b + e) % 5) as f64;
                        k[a][a] += w;
                        k[a][b] -= w;
                    }
                }
            }
            pattern.add_element(e, &k, &mut values);
        }
        // Trailing: the top edge, in reverse order (any order is kept).
        let trailing: Vec<usize> =
            (0..nx).rev().flat_map(|i| [dofs.free[2 * node(i, ny - 1) + 1], dofs.free[2 * node(i, ny - 1)]]).collect();
        let m = trailing.len();
        let n = pattern.n;
        let mut amd = SparseCholesky::new(&pattern, m).unwrap();
        amd.factorize(&values).unwrap();
        let mut phi = vec![0.0; n * m];
        for (c, &row) in trailing.iter().enumerate() {
            phi[c * n + row] = 1.0;
        }
        amd.solve_in_place(MatMut::from_column_major_slice_mut(&mut phi, n, m));
        let mut last = SparseCholesky::with_trailing(&pattern, &trailing, 1).unwrap();
        last.factorize(&values).unwrap();
        assert_eq!(last.trailing(), m);
        let mut l = vec![0.0; m * m];
        last.trailing_factor(&mut l);
        let (mut inverse, mut compliance) = (vec![0.0; m * m], vec![0.0; m * m]);
        schur_compliance(&l, m, &mut inverse, &mut compliance);
        // S = L L^T column by column (unit vectors through lower_times and
        // upper_times).
        let mut u = vec![0.0; m * m];
        transpose(&l, m, &mut u);
        let mut stiffness = vec![0.0; m * m];
        for c in 0..m {
            let mut e = vec![0.0; m];
            e[c] = 1.0;
            let mut half = vec![0.0; m];
            upper_times(&u, m, &e, &mut half);
            lower_times(&l, m, &half, &mut stiffness[c * m..(c + 1) * m]);
        }
        let scale = compliance.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        for c in 0..m {
            for (r, &row) in trailing.iter().enumerate() {
                let expected = phi[c * n + row];
                assert!((compliance[c * m + r] - expected).abs() < 1e-12 * scale, "C[{r},{c}]");
            }
        }
        // S C = I.
        for c in 0..m {
            for r in 0..m {
                let v: f64 = (0..m).map(|k| stiffness[k * m + r] * compliance[c * m + k]).sum();
                let expected = if r == c { 1.0 } else { 0.0 };
                assert!((v - expected).abs() < 1e-10, "(S C)[{r},{c}] = {v}");
            }
        }
        // Solves with the pad-last factorization agree with the AMD ones,
        // whole or in halves.
        let rhs: Vec<f64> = (0..n).map(|i| ((i * 7) % 11) as f64 - 5.0).collect();
        let (mut b, mut b2) = (rhs.clone(), rhs.clone());
        amd.solve_vec(&mut b);
        last.solve_vec(&mut b2);
        let scale = b.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(b.iter().zip(&b2).all(|(x, y)| (x - y).abs() < 1e-12 * scale));
        let (mut y, mut x) = (vec![0.0; n], vec![0.0; n]);
        last.forward(&rhs, &mut y);
        // The trailing part of the solution from the forward half alone:
        // x_t = L_tt^-T y_t.
        let mut x_t = y[n - m..].to_vec();
        upper_solve(&u, m, &mut x_t);
        for (c, &row) in trailing.iter().enumerate() {
            assert!((x_t[c] - b[row]).abs() < 1e-12 * scale, "x_t[{c}]");
        }
        last.backward(&mut y, &mut x);
        assert!(b.iter().zip(&x).all(|(p, q)| (p - q).abs() < 1e-12 * scale));
        // A load on the trailing unknowns only: L^-1 Pi P g = [0; L_tt^-1 g],
        // and L_tt^-1 S w = L_tt^T w.
        let w: Vec<f64> = (0..m).map(|i| (i % 3) as f64 - 1.0).collect();
        let mut y = vec![0.0; n];
        upper_times(&u, m, &w, &mut y[n - m..]);
        last.backward(&mut y, &mut x);
        for (c, &row) in trailing.iter().enumerate() {
            assert!((x[row] - w[c]).abs() < 1e-10, "pad displacement {c}");
        }
        // Invalid sets are errors, not panics.
        assert!(SparseCholesky::with_trailing(&pattern, &[n], 1).is_err());
        assert!(SparseCholesky::with_trailing(&pattern, &[0, 0], 1).is_err());
    }
}

/// LU factorization with partial pivoting of small dense matrices, with
/// all memory allocated once for a largest size (no allocation per solve).
pub struct DenseLu {
    n_max: usize,
    n: usize,
    a: Vec<f64>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    scratch: MemBuffer,
}

impl DenseLu {
    pub fn new(n_max: usize) -> Self {
        use faer::linalg::lu::partial_pivoting::{factor, solve};
        let req = factor::lu_in_place_scratch::<usize, f64>(n_max, n_max, Par::Seq, Default::default())
            .or(solve::solve_in_place_scratch::<usize, f64>(n_max, 1, Par::Seq));
        Self {
            n_max,
            n: 0,
            a: vec![0.0; n_max * n_max],
            perm: vec![0; n_max],
            perm_inv: vec![0; n_max],
            scratch: MemBuffer::new(req),
        }
    }

    /// The n x n matrix to fill (column-major), before [`DenseLu::factor`].
    pub fn matrix_mut(&mut self, n: usize) -> MatMut<'_, f64> {
        assert!(n <= self.n_max, "dense system of {n} exceeds the workspace ({})", self.n_max);
        self.n = n;
        MatMut::from_column_major_slice_mut(&mut self.a[..n * n], n, n)
    }

    /// Factorizes the matrix filled through [`DenseLu::matrix_mut`]; false if singular.
    pub fn factor(&mut self) -> bool {
        use faer::linalg::lu::partial_pivoting::factor;
        let n = self.n;
        let a = MatMut::from_column_major_slice_mut(&mut self.a[..n * n], n, n);
        factor::lu_in_place(
            a,
            &mut self.perm[..n],
            &mut self.perm_inv[..n],
            Par::Seq,
            MemStack::new(&mut self.scratch),
            Default::default(),
        );
        (0..n).all(|i| {
            let d = self.a[i * n + i];
            d.is_finite() && d != 0.0
        })
    }

    /// Solves in place for one right-hand side of length n.
    pub fn solve(&mut self, rhs: &mut [f64]) {
        use faer::linalg::lu::partial_pivoting::solve;
        let n = self.n;
        let lu = faer::MatRef::from_column_major_slice(&self.a[..n * n], n, n);
        // SAFETY: perm and perm_inv were filled by lu_in_place for size n and
        // are inverse permutations of 0..n.
        let perm = unsafe { faer::perm::PermRef::new_unchecked(&self.perm[..n], &self.perm_inv[..n], n) };
        solve::solve_in_place(
            lu,
            lu,
            perm,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            Par::Seq,
            MemStack::new(&mut self.scratch),
        );
    }
}

#[cfg(test)]
mod dense_tests {
    use super::*;

    #[test]
    fn dense_lu_solves_a_nonsymmetric_system() {
        let mut lu = DenseLu::new(5);
        let a = [[0.0, 2.0, 1.0], [1.0, 1.0, 0.0], [3.0, 0.0, 1.0]];
        {
            let mut m = lu.matrix_mut(3);
            for i in 0..3 {
                for j in 0..3 {
                    m[(i, j)] = a[i][j];
                }
            }
        }
        assert!(lu.factor());
        let x = [1.0, -2.0, 0.5];
        let mut b: Vec<f64> = (0..3).map(|i| (0..3).map(|j| a[i][j] * x[j]).sum()).collect();
        lu.solve(&mut b);
        for i in 0..3 {
            assert!((b[i] - x[i]).abs() < 1e-14);
        }
    }
}
