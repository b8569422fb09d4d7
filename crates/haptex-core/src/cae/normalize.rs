//! Input normalization: every input mapped to [0, 1] over the database,
//! b' = (b - min) / (max - min), so that one kernel width means the same
//! fraction of every input's range (paper section 2.4: "the normalized
//! database [0 1]").
//!
//! An input with the same value in every row (max = min) carries no
//! information about the outputs: it is left out of the kernel (its term in
//! eq. 12 would be the same for every model vector and cancel in eq. 11). A
//! query that gives it another value is outside the database, and the
//! prediction diagnostic says so.

use super::CaeError;

/// Per-input minimum and range of the database.
#[derive(Debug, Clone, PartialEq)]
pub struct Normalization {
    min: Vec<f64>,
    range: Vec<f64>,
}

impl Normalization {
    /// Minimum and range of each of the `d` inputs of the row-major N x D
    /// values `b`.
    pub fn fit(b: &[f64], d: usize) -> Result<Self, CaeError> {
        let mut min = vec![f64::INFINITY; d];
        let mut max = vec![f64::NEG_INFINITY; d];
        for row in b.chunks_exact(d) {
            for l in 0..d {
                min[l] = min[l].min(row[l]);
                max[l] = max[l].max(row[l]);
            }
        }
        let range: Vec<f64> = min.iter().zip(&max).map(|(lo, hi)| hi - lo).collect();
        if let Some(l) = range.iter().position(|r| !r.is_finite()) {
            return Err(CaeError::Invalid(format!(
                "input {} spans {} .. {}: the range overflows a double",
                l + 1,
                crate::num::Num(min[l]),
                crate::num::Num(max[l])
            )));
        }
        Ok(Self { min, range })
    }

    /// Number of inputs D.
    pub fn d(&self) -> usize {
        self.min.len()
    }

    /// Smallest value of input `l` in the database.
    pub fn min(&self, l: usize) -> f64 {
        self.min[l]
    }

    /// max - min of input `l` (0 for a constant input).
    pub fn range(&self, l: usize) -> f64 {
        self.range[l]
    }

    /// True if input `l` has the same value in every row.
    pub fn is_constant(&self, l: usize) -> bool {
        self.range[l] == 0.0
    }

    /// Indices of the constant inputs.
    pub fn constant_inputs(&self) -> Vec<usize> {
        (0..self.d()).filter(|&l| self.is_constant(l)).collect()
    }

    /// Value `x` of input `l` in normalized units (0 for a constant input).
    pub fn normalize(&self, l: usize, x: f64) -> f64 {
        if self.is_constant(l) { 0.0 } else { (x - self.min[l]) / self.range[l] }
    }

    /// A row-major N x D block of values in normalized units.
    pub fn normalize_rows(&self, b: &[f64]) -> Vec<f64> {
        let d = self.d();
        b.chunks_exact(d).flat_map(|row| (0..d).map(move |l| self.normalize(l, row[l]))).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_to_unit_interval_and_flags_constant_inputs() {
        let n = Normalization::fit(&[1.0, 5.0, 3.0, 5.0, 2.0, 5.0], 2).unwrap();
        assert_eq!(n.normalize_rows(&[1.0, 5.0, 3.0, 5.0, 2.0, 5.0]), [0.0, 0.0, 1.0, 0.0, 0.5, 0.0]);
        assert_eq!(n.constant_inputs(), [1]);
        assert!(Normalization::fit(&[-1e308, 1e308], 1).is_err());
    }
}
