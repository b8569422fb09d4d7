//! Linear algebra on top of faer: the sparse Cholesky factorization of the
//! stiffness (symbolic analysis once, numeric factorization per time-step
//! size, solves without allocation) and small dense helpers.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
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
        Ok(Self::with_symbolic(Arc::new(symbolic_matrix), Arc::new(symbolic), max_rhs))
    }

    fn with_symbolic(
        pattern: Arc<SymbolicSparseColMat<usize>>,
        symbolic: Arc<SymbolicCholesky<usize>>,
        max_rhs: usize,
    ) -> Self {
        let factor_scratch =
            MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
        let solve_columns = max_rhs.max(1);
        let solve_scratch = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(solve_columns, Par::Seq));
        let l_values = vec![0.0; symbolic.len_val()];
        Self { pattern, symbolic, l_values, factor_scratch, solve_scratch, solve_columns, factorized: false }
    }

    /// A second factorization of the same pattern, sharing the symbolic
    /// analysis (for another time-step size).
    pub fn share(&self, max_rhs: usize) -> Self {
        Self::with_symbolic(self.pattern.clone(), self.symbolic.clone(), max_rhs)
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
