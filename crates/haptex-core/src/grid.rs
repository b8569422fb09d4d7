//! Multilinear interpolation over a model matrix whose inputs form a full
//! tensor grid (every combination of each input's values is one row, as in
//! the FE database's sweep): the estimate between the rows that is exact at
//! every row and linear along each input between neighbouring values.
//!
//! An alternative to the CAE ([`crate::cae`]) for grid databases, measured
//! against fresh FE runs on random members (`haptex db validate
//! --estimator grid`, docs/database.md): the CAE's leave-one-out width is
//! chosen by predicting each row from neighbours a whole grid step away,
//! which favours narrow kernels that, between rows, are nearly the nearest
//! row. Outside an input's range the value at its end is held.

use crate::cae::ModelMatrix;

/// Most inputs of a grid (2^16 corners per query).
pub const MAX_INPUTS: usize = 16;

/// The grid of a model matrix: each input's sorted distinct values and the
/// row of every node.
#[derive(Debug, Clone, PartialEq)]
pub struct GridInterpolation {
    axes: Vec<Vec<f64>>,
    /// The row at each node, the last input varying fastest.
    rows: Vec<usize>,
}

/// A model matrix that is not a full tensor grid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("the model vectors are not a full grid: {0}")]
pub struct GridError(String);

impl GridInterpolation {
    /// The grid of `matrix`, or why it is not one: a node without a row or
    /// a node with two. An input with a single value is set aside.
    pub fn new(matrix: &ModelMatrix) -> Result<Self, GridError> {
        let d = matrix.d();
        if d > MAX_INPUTS {
            return Err(GridError(format!("{d} inputs, at most {MAX_INPUTS}")));
        }
        let axes: Vec<Vec<f64>> = (0..d)
            .map(|l| {
                let mut v: Vec<f64> = (0..matrix.n()).map(|n| matrix.input_row(n)[l]).collect();
                v.sort_by(f64::total_cmp);
                v.dedup();
                v
            })
            .collect();
        let nodes = axes.iter().try_fold(1usize, |p, a| p.checked_mul(a.len()));
        if nodes != Some(matrix.n()) {
            return Err(GridError(format!(
                "{} rows for {} combinations of the inputs' values",
                matrix.n(),
                nodes.map_or_else(|| "too many".to_string(), |n| n.to_string())
            )));
        }
        let mut rows = vec![usize::MAX; matrix.n()];
        for n in 0..matrix.n() {
            let node = matrix.input_row(n).iter().zip(&axes).fold(0usize, |index, (v, axis)| {
                index * axis.len() + axis.binary_search_by(|a| a.total_cmp(v)).expect("the axis holds every value")
            });
            if rows[node] != usize::MAX {
                return Err(GridError(format!("rows {} and {} have the same inputs", rows[node] + 1, n + 1)));
            }
            rows[node] = n;
        }
        Ok(Self { axes, rows })
    }

    /// Each input's grid values.
    pub fn axes(&self) -> &[Vec<f64>] {
        &self.axes
    }

    /// The multilinear interpolant of `matrix`'s outputs at `query` (D
    /// finite values, checked by the caller) into `out` (M values), without
    /// allocation: the 2^D nodes around the query, weighted by the products
    /// of the linear weights along each input; at a node, its row exactly.
    pub fn predict_into(&self, matrix: &ModelMatrix, query: &[f64], out: &mut [f64]) {
        let d = self.axes.len();
        debug_assert!(query.len() == d && out.len() == matrix.m());
        // Per input: the lower node of the bracket and the weight of the upper.
        let mut lower = [0usize; MAX_INPUTS];
        let mut t = [0.0f64; MAX_INPUTS];
        for (l, (axis, &q)) in self.axes.iter().zip(query).enumerate() {
            if axis.len() == 1 {
                // A constant input (one value in the sweep): set aside, as the CAE does.
                (lower[l], t[l]) = (0, 0.0);
                continue;
            }
            let j = axis.partition_point(|&a| a <= q).clamp(1, axis.len() - 1) - 1;
            lower[l] = j;
            t[l] = ((q - axis[j]) / (axis[j + 1] - axis[j])).clamp(0.0, 1.0);
        }
        out.fill(0.0);
        for corner in 0..(1usize << d) {
            let (mut node, mut weight) = (0usize, 1.0f64);
            for (l, axis) in self.axes.iter().enumerate() {
                let upper = corner >> (d - 1 - l) & 1 == 1;
                // (An upper node beyond a constant input's one value has weight 0.)
                node = node * axis.len() + (lower[l] + usize::from(upper)).min(axis.len() - 1);
                weight *= if upper { t[l] } else { 1.0 - t[l] };
            }
            if weight == 0.0 {
                continue;
            }
            for (o, &c) in out.iter_mut().zip(matrix.output_row(self.rows[node])) {
                *o += weight * c;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn matrix(rows: &[[f64; 2]], f: impl Fn(f64, f64) -> [f64; 2]) -> ModelMatrix {
        let b: Vec<f64> = rows.iter().flatten().copied().collect();
        let c: Vec<f64> = rows.iter().flat_map(|r| f(r[0], r[1])).collect();
        ModelMatrix::new(vec!["a".into(), "b".into()], vec!["y".into(), "z".into()], b, c).unwrap()
    }

    /// Rows in any order; a function linear in each input separately
    /// (bilinear) is reproduced exactly inside the grid; nodes give their
    /// rows; outside, the end value is held.
    #[test]
    fn bilinear_functions_are_reproduced_and_ends_held() {
        let f = |a: f64, b: f64| [1.0 + 2.0 * a - 3.0 * b + 0.5 * a * b, -a];
        let rows = [[1.0, 10.0], [0.0, 20.0], [2.5, 10.0], [0.0, 10.0], [1.0, 20.0], [2.5, 20.0]];
        let m = matrix(&rows, f);
        let g = GridInterpolation::new(&m).unwrap();
        assert_eq!(g.axes(), &[vec![0.0, 1.0, 2.5], vec![10.0, 20.0]]);
        let mut out = [0.0; 2];
        for (a, b) in [(0.3, 12.0), (1.0, 10.0), (2.2, 19.9), (0.0, 20.0), (1.7, 15.0)] {
            g.predict_into(&m, &[a, b], &mut out);
            let want = f(a, b);
            assert!((out[0] - want[0]).abs() < 1e-12 && (out[1] - want[1]).abs() < 1e-12, "{a} {b}: {out:?}");
        }
        g.predict_into(&m, &[-4.0, 25.0], &mut out);
        assert_eq!(out, f(0.0, 20.0));
    }

    #[test]
    fn incomplete_and_repeated_grids_are_refused() {
        let f = |a: f64, b: f64| [a, b];
        let missing = matrix(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], f);
        assert!(GridInterpolation::new(&missing).unwrap_err().to_string().contains("3 rows for 4 combinations"));
        let twice = matrix(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 1.0]], f);
        assert!(GridInterpolation::new(&twice).is_err());
        // A constant input is set aside: linear along the other.
        let flat = matrix(&[[0.0, 0.0], [1.0, 0.0]], f);
        let g = GridInterpolation::new(&flat).unwrap();
        let mut out = [0.0; 2];
        g.predict_into(&flat, &[0.25, 3.0], &mut out);
        assert_eq!(out, [0.25, 0.0]);
    }
}
