//! The model matrix of the CAE (paper eq. 10): N model vectors
//! X_n = {B_n, C_n}, each with D input values B_n and M output values C_n.
//!
//! File form (`docs/file-formats.md`, "CAE model matrix"): any numeric CSV
//! table; the caller names the input columns, every other column is an
//! output. Inputs and outputs are stored row by row (row-major), so one
//! model vector's outputs are contiguous: prediction streams through them.

use std::collections::HashSet;
use std::path::Path;

use super::CaeError;
use crate::io::Table;
use crate::num::Num;

/// Largest magnitude of a model value: squared differences of two values
/// (the kernel distances, the leave-one-out residuals) stay finite.
pub const MAX_MODEL_VALUE: f64 = 1e150;

/// A model matrix: named inputs and outputs, N rows.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelMatrix {
    source_name: String,
    inputs: Vec<String>,
    outputs: Vec<String>,
    /// N x D input values, row-major.
    b: Vec<f64>,
    /// N x M output values, row-major.
    c: Vec<f64>,
    /// Source line of each row, when read from a file.
    lines: Option<Vec<u64>>,
}

impl ModelMatrix {
    /// A model matrix from in-memory data: `b` is N x D and `c` is N x M,
    /// both row-major. Needs N >= 2, D >= 1, M >= 1, unique non-empty names
    /// and finite values.
    pub fn new(inputs: Vec<String>, outputs: Vec<String>, b: Vec<f64>, c: Vec<f64>) -> Result<Self, CaeError> {
        let invalid = |m: String| Err(CaeError::Invalid(m));
        let (d, m) = (inputs.len(), outputs.len());
        if d == 0 {
            return invalid("a model matrix needs at least one input".into());
        }
        if m == 0 {
            return invalid("a model matrix needs at least one output".into());
        }
        let mut seen = HashSet::new();
        for name in inputs.iter().chain(&outputs) {
            if name.is_empty() {
                return invalid("empty column name".into());
            }
            if !seen.insert(name) {
                return invalid(format!("column name '{name}' appears twice"));
            }
        }
        if !b.len().is_multiple_of(d) || !c.len().is_multiple_of(m) || b.len() / d != c.len() / m {
            return invalid(format!(
                "{} input values for {d} inputs and {} output values for {m} outputs do not make whole rows",
                b.len(),
                c.len()
            ));
        }
        let n = b.len() / d;
        if n < 2 {
            return invalid(format!("a model matrix needs at least 2 rows, got {n}"));
        }
        if let Some(i) = b.iter().chain(&c).position(|v| !v.is_finite()) {
            return invalid(format!("value {i} is not finite"));
        }
        if let Some(v) = b.iter().chain(&c).find(|v| v.abs() > MAX_MODEL_VALUE) {
            return invalid(format!(
                "value {} is beyond +-{} (squared distances would overflow)",
                Num(*v),
                Num(MAX_MODEL_VALUE)
            ));
        }
        Ok(Self { source_name: "<memory>".into(), inputs, outputs, b, c, lines: None })
    }

    /// Reads a model matrix from a parsed table: the columns named in
    /// `inputs` (in that order) are the inputs, every other column, in file
    /// order, is an output. Errors name the file, line and column.
    pub fn from_table(table: &Table, inputs: &[&str]) -> Result<Self, CaeError> {
        if inputs.is_empty() {
            return Err(CaeError::Inputs("no input columns named (--inputs a,b,c)".into()));
        }
        let mut input_set = HashSet::new();
        for name in inputs {
            if name.is_empty() {
                return Err(CaeError::Inputs("empty input name in the list of inputs".into()));
            }
            if !input_set.insert(*name) {
                return Err(CaeError::Inputs(format!("input '{name}' is named twice in the list of inputs")));
            }
        }
        let input_columns = inputs.iter().map(|name| table.require(name)).collect::<Result<Vec<_>, _>>()?;
        let output_names: Vec<String> =
            table.columns().iter().filter(|c| !input_set.contains(c.as_str())).cloned().collect();
        if output_names.is_empty() {
            return Err(table.error_at(None, None, "no output columns: every column is an input").into());
        }
        let n = table.n_rows();
        if n < 2 {
            return Err(table.error_at(None, None, format!("a model matrix needs at least 2 rows, got {n}")).into());
        }
        let output_columns: Vec<&[f64]> = output_names.iter().map(|name| table.column(name).unwrap()).collect();
        let names = inputs.iter().copied().chain(output_names.iter().map(String::as_str));
        for (name, column) in names.zip(input_columns.iter().chain(&output_columns)) {
            if let Some(row) = column.iter().position(|v| v.abs() > MAX_MODEL_VALUE) {
                let message = format!(
                    "{} is beyond +-{} (squared distances would overflow)",
                    Num(column[row]),
                    Num(MAX_MODEL_VALUE)
                );
                return Err(table.error_at(Some(row), Some(name), message).into());
            }
        }
        let (d, m) = (inputs.len(), output_names.len());
        let too_large = |e: crate::buffer::AllocationError| CaeError::TooLarge(e.to_string());
        let mut b =
            crate::buffer::try_with_capacity(n * d, || format!("the {n} x {d} model inputs")).map_err(too_large)?;
        let mut c =
            crate::buffer::try_with_capacity(n * m, || format!("the {n} x {m} model outputs")).map_err(too_large)?;
        for row in 0..n {
            b.extend(input_columns.iter().map(|col| col[row]));
            c.extend(output_columns.iter().map(|col| col[row]));
        }
        Ok(Self {
            source_name: table.source_name().to_string(),
            inputs: inputs.iter().map(|s| s.to_string()).collect(),
            outputs: output_names,
            b,
            c,
            lines: Some((0..n).map(|r| table.line_of_row(r)).collect()),
        })
    }

    /// Reads a model matrix CSV from any reader; `source_name` labels errors.
    pub fn read_csv<R: std::io::Read>(reader: R, source_name: &str, inputs: &[&str]) -> Result<Self, CaeError> {
        Self::from_table(&Table::read(reader, source_name)?, inputs)
    }

    /// Reads a model matrix CSV file.
    pub fn read_csv_file(path: &Path, inputs: &[&str]) -> Result<Self, CaeError> {
        Self::from_table(&Table::read_file(path)?, inputs)
    }

    /// Where the matrix came from (a path, `<stdin>` or `<memory>`).
    pub fn source_name(&self) -> &str {
        &self.source_name
    }

    /// Number of model vectors N.
    pub fn n(&self) -> usize {
        self.b.len() / self.inputs.len()
    }

    /// Number of inputs D.
    pub fn d(&self) -> usize {
        self.inputs.len()
    }

    /// Number of outputs M.
    pub fn m(&self) -> usize {
        self.outputs.len()
    }

    /// Input names, in the order of every input vector.
    pub fn inputs(&self) -> &[String] {
        &self.inputs
    }

    /// Output names, in the order of every output vector.
    pub fn outputs(&self) -> &[String] {
        &self.outputs
    }

    /// Input values B_n of row `n`.
    pub fn input_row(&self, n: usize) -> &[f64] {
        let d = self.d();
        &self.b[n * d..(n + 1) * d]
    }

    /// Output values C_n of row `n`.
    pub fn output_row(&self, n: usize) -> &[f64] {
        let m = self.m();
        &self.c[n * m..(n + 1) * m]
    }

    /// All input values, N x D row-major.
    pub fn inputs_flat(&self) -> &[f64] {
        &self.b
    }

    /// All output values, N x M row-major.
    pub fn outputs_flat(&self) -> &[f64] {
        &self.c
    }

    /// Source line of row `n`, when the matrix was read from a file.
    pub fn line_of_row(&self, n: usize) -> Option<u64> {
        self.lines.as_ref().map(|l| l[n])
    }

    /// The matrix without row `row`: the database a left-out case's
    /// estimate is made from (`haptex db loo`).
    pub fn without_row(&self, row: usize) -> Result<Self, CaeError> {
        let (n_rows, d, m) = (self.n(), self.d(), self.m());
        let mut b = Vec::with_capacity((n_rows - 1) * d);
        let mut c = Vec::with_capacity((n_rows - 1) * m);
        for n in (0..n_rows).filter(|&n| n != row) {
            b.extend_from_slice(self.input_row(n));
            c.extend_from_slice(self.output_row(n));
        }
        Self::new(self.inputs.clone(), self.outputs.clone(), b, c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_stored_row_major_in_the_named_input_order() {
        let t = Table::read("y1,b,y2,a\n1,2,3,4\n5,6,7,8\n".as_bytes(), "m.csv").unwrap();
        let x = ModelMatrix::from_table(&t, &["a", "b"]).unwrap();
        assert_eq!((x.n(), x.d(), x.m()), (2, 2, 2));
        assert_eq!(x.outputs(), ["y1", "y2"]);
        assert_eq!(x.input_row(1), [8.0, 6.0]);
        assert_eq!(x.output_row(0), [1.0, 3.0]);
        assert_eq!(x.line_of_row(1), Some(3));
    }

    #[test]
    fn in_memory_validation() {
        let s = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert!(ModelMatrix::new(s(&["a"]), s(&["y"]), vec![0.0, 1.0], vec![1.0, 2.0]).is_ok());
        assert!(ModelMatrix::new(s(&["a"]), s(&["y"]), vec![0.0], vec![1.0]).is_err());
        assert!(ModelMatrix::new(s(&["a"]), s(&["a"]), vec![0.0, 1.0], vec![1.0, 2.0]).is_err());
        assert!(ModelMatrix::new(s(&["a"]), s(&["y"]), vec![0.0, f64::NAN], vec![1.0, 2.0]).is_err());
        assert!(ModelMatrix::new(s(&["a"]), s(&["y"]), vec![0.0, 1.0], vec![1.0, 2.0, 3.0]).is_err());
    }
}
