//! `haptex.Cae`: the conditional average estimator (paper eqs. 10-12) over
//! any model matrix, as `haptex cae predict` and `haptex cae loo` use it.

use haptex_core::cae::{
    Cae as CoreCae, CaeError, Diagnostics, LooReport, ModelMatrix, OptimizeOptions, Scratch, Widths, optimize_widths,
};
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyList;

use crate::convert::{Floats, input_path, json_object};
use crate::errors::{OrRaise, input};

/// A 2-D float64 array argument (rows x columns), read in place when
/// C-contiguous float64.
type Matrix<'py> = PyArrayLike2<'py, f64, AllowTypeChange>;

/// The rows of a 2-D argument, row-major, and its shape.
fn rows_of(name: &str, array: &Matrix<'_>) -> PyResult<(Vec<f64>, usize, usize)> {
    let shape = array.shape();
    let (rows, cols) = (shape[0], shape[1]);
    let values: Vec<f64> = match array.as_slice() {
        Ok(slice) => slice.to_vec(),
        Err(_) => array.as_array().iter().copied().collect(),
    };
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(input(format!(
            "{name}[{}, {}] is {}: every value must be a finite number",
            i / cols.max(1),
            i % cols.max(1),
            values[i]
        )));
    }
    Ok((values, rows, cols))
}

/// The widths of `width=` (one constant width) or `widths=(w_min, w_max)`.
fn widths_arg(width: Option<f64>, widths: Option<(f64, f64)>) -> PyResult<Option<Widths>> {
    match (width, widths) {
        (Some(_), Some(_)) => Err(input("give width= (a constant width) or widths=(w_min, w_max), not both")),
        (Some(w), None) => Widths::constant(w).or_raise().map(Some),
        (None, Some((lo, hi))) => Widths::range(lo, hi).or_raise().map(Some),
        (None, None) => Ok(None),
    }
}

/// The model's memory budget in bytes, the budget hint on refusal.
fn budget_error(error: CaeError) -> PyErr {
    match error {
        CaeError::TooLarge(message) => input(format!("{message}; the arguments are memory_budget_mib= and width=")),
        other => crate::errors::to_py(other),
    }
}

fn budget_bytes(mib: u64) -> PyResult<u64> {
    if mib == 0 || mib > u64::MAX >> 20 {
        return Err(input(format!("memory_budget_mib must be from 1 to {}, got {mib}", u64::MAX >> 20)));
    }
    Ok(mib << 20)
}

/// The conditional average estimator over a model matrix: inputs B (N x
/// D) and outputs C (N x M), with kernel widths w_min .. w_max in
/// normalized input units (paper eq. 12). Without width= or widths=, the
/// constant width with the smallest leave-one-out error is searched, as
/// `haptex cae predict` does.
///
/// Cae(inputs, outputs, *, width=None, widths=None, input_names=None,
///     output_names=None, memory_budget_mib=2048)
/// Cae.read_csv(path, inputs, ...): a model matrix CSV whose columns
///     `inputs` are the inputs and all others the outputs (`--model`,
///     `--inputs`).
#[pyclass(module = "haptex", name = "Cae")]
pub struct Cae {
    cae: CoreCae,
    scratch: Scratch,
}

impl Cae {
    fn build(matrix: ModelMatrix, widths: Option<Widths>, memory_budget_mib: u64) -> PyResult<Self> {
        let widths = match widths {
            Some(w) => w,
            None => {
                let options = OptimizeOptions {
                    constant_only: true,
                    memory_budget_bytes: budget_bytes(memory_budget_mib)?,
                    ..OptimizeOptions::default()
                };
                optimize_widths(&matrix, options).map_err(budget_error)?.widths
            }
        };
        let cae = CoreCae::new(matrix, widths).or_raise()?;
        let scratch = cae.scratch();
        Ok(Self { cae, scratch })
    }

    /// Warns (a haptex.ExtrapolationWarning) for each query that is an
    /// extrapolation, as the command line does on stderr.
    fn warn(&self, py: Python<'_>, queries: &[f64], diagnostics: &[Diagnostics]) -> PyResult<()> {
        let d = self.cae.matrix().d();
        let mut category = None;
        for (i, diag) in diagnostics.iter().enumerate() {
            if let Some(text) = self.cae.warning(&queries[i * d..(i + 1) * d], diag) {
                let class = match &category {
                    Some(c) => c,
                    None => category.insert(py.import("haptex._errors")?.getattr("ExtrapolationWarning")?),
                };
                let label = if diagnostics.len() > 1 { format!("query {}: ", i + 1) } else { String::new() };
                PyErr::warn(py, class, &std::ffi::CString::new(format!("{label}{text}"))?, 1)?;
            }
        }
        Ok(())
    }
}

#[pymethods]
impl Cae {
    #[new]
    #[pyo3(signature = (inputs, outputs, *, width = None, widths = None, input_names = None, output_names = None, memory_budget_mib = 2048))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        inputs: Matrix<'_>,
        outputs: Matrix<'_>,
        width: Option<f64>,
        widths: Option<(f64, f64)>,
        input_names: Option<Vec<String>>,
        output_names: Option<Vec<String>>,
        memory_budget_mib: u64,
    ) -> PyResult<Self> {
        let (b, n, d) = rows_of("inputs", &inputs)?;
        let (c, n_out, m) = rows_of("outputs", &outputs)?;
        if n != n_out {
            return Err(input(format!("inputs has {n} rows and outputs {n_out}: one row per model vector")));
        }
        let names = |given: Option<Vec<String>>, count: usize, prefix: &str, what: &str| match given {
            Some(names) if names.len() != count => {
                Err(input(format!("{what} has {} names for {count} columns", names.len())))
            }
            Some(names) => Ok(names),
            None => Ok((0..count).map(|i| format!("{prefix}{i}")).collect()),
        };
        let matrix = ModelMatrix::new(
            names(input_names, d, "b", "input_names")?,
            names(output_names, m, "c", "output_names")?,
            b,
            c,
        )
        .or_raise()?;
        let widths = widths_arg(width, widths)?;
        py.detach(|| Self::build(matrix, widths, memory_budget_mib))
    }

    /// Reads a model matrix CSV (`haptex cae --model M.csv --inputs a,b`):
    /// the columns named in `inputs` are the inputs, every other column an
    /// output.
    #[staticmethod]
    #[pyo3(signature = (path, inputs, *, width = None, widths = None, memory_budget_mib = 2048))]
    fn read_csv(
        py: Python<'_>,
        path: &Bound<'_, PyAny>,
        inputs: Vec<String>,
        width: Option<f64>,
        widths: Option<(f64, f64)>,
        memory_budget_mib: u64,
    ) -> PyResult<Self> {
        let path = input_path("path", path)?;
        let names: Vec<&str> = inputs.iter().map(|s| s.trim()).collect();
        let matrix = ModelMatrix::read_csv_file(&path, &names).or_raise()?;
        let widths = widths_arg(width, widths)?;
        py.detach(|| Self::build(matrix, widths, memory_budget_mib))
    }

    /// The outputs (M values) at one query (D inputs, in the model's input
    /// order and units): eq. (11) with the weights of eq. (10). The same
    /// numbers as `haptex cae predict --at`, bit for bit. Warns
    /// (haptex.ExtrapolationWarning) when the query is far from every model
    /// vector. (A batch of one query is computed the same way, to the bit.)
    fn predict<'py>(&mut self, py: Python<'py>, query: Floats<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let m = self.cae.matrix().m();
        let out = PyArray1::<f64>::zeros(py, m, false);
        let owned;
        let q = match query.as_slice() {
            Ok(slice) => slice,
            Err(_) => {
                owned = query.as_array().to_vec();
                &owned
            }
        };
        {
            // SAFETY: `out` was created above and is not shared yet.
            let slice = unsafe { out.as_slice_mut() }.map_err(|e| input(format!("internal: {e}")))?;
            let diagnostics = self.cae.predict_into(q, &mut self.scratch, slice).or_raise()?;
            if diagnostics.is_extrapolation() {
                self.warn(py, q, &[diagnostics])?;
            }
        }
        Ok(out)
    }

    /// The outputs at many queries (K x D) as a K x M array, computed in
    /// blocks on all cores with the GIL released; bit for bit the numbers
    /// of `haptex cae predict` with the same queries.
    fn predict_batch<'py>(&self, py: Python<'py>, queries: Matrix<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let d = self.cae.matrix().d();
        let shape = queries.shape();
        if shape[1] != d {
            return Err(input(format!("queries has {} columns; the model has {d} inputs", shape[1])));
        }
        let owned;
        let q = match queries.as_slice() {
            Ok(slice) => slice,
            Err(_) => {
                owned = queries.as_array().iter().copied().collect::<Vec<_>>();
                &owned
            }
        };
        let (out, diagnostics) = py.detach(|| self.cae.predict_batch(q)).map_err(|e| match e {
            CaeError::BatchQuery { index, message } => input(format!("query {} (row {index}): {message}", index + 1)),
            other => crate::errors::to_py(other),
        })?;
        self.warn(py, q, &diagnostics)?;
        let k = shape[0];
        let m = self.cae.matrix().m();
        PyArray1::from_vec(py, out).reshape([k, m])
    }

    /// Where a query lies relative to the model vectors (a dict): the
    /// nearest row (0-based) and its normalized distance, the distance in
    /// kernel widths, an input outside the range, the weights used.
    fn diagnose<'py>(&self, py: Python<'py>, query: Floats<'py>) -> PyResult<Bound<'py, PyAny>> {
        let q = crate::convert::to_vec(&query);
        let (_, diagnostics) = self.cae.predict(&q).or_raise()?;
        json_object(py, &diagnostics)
    }

    /// The kernel widths (w_min, w_max), normalized input units.
    #[getter]
    fn widths(&self) -> (f64, f64) {
        let w = self.cae.widths();
        (w.w_min, w.w_max)
    }

    /// The input names, in query order.
    #[getter]
    fn inputs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        PyList::new(py, self.cae.matrix().inputs())
    }

    /// The output names, in output order.
    #[getter]
    fn outputs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        PyList::new(py, self.cae.matrix().outputs())
    }

    /// (N, D, M): model vectors, inputs, outputs.
    #[getter]
    fn shape(&self) -> (usize, usize, usize) {
        let m = self.cae.matrix();
        (m.n(), m.d(), m.m())
    }

    fn __repr__(&self) -> String {
        let m = self.cae.matrix();
        let w = self.cae.widths();
        format!(
            "Cae({} model vectors, inputs {}, {} outputs, widths {} .. {})",
            m.n(),
            m.inputs().join(","),
            m.m(),
            haptex_core::num::Num(w.w_min),
            haptex_core::num::Num(w.w_max)
        )
    }
}

/// The leave-one-out error of the CAE over a model matrix CSV, and the
/// widths that minimize it (`haptex cae loo`): a dict equal to the JSON
/// the command line writes. width= or widths= evaluates given widths;
/// constant=True searches one constant width only; range=(lo, hi) bounds
/// the search (normalized units).
#[pyfunction]
#[pyo3(signature = (model, inputs, *, constant = false, width = None, widths = None, range = (0.005, 2.0), memory_budget_mib = 2048))]
#[allow(clippy::too_many_arguments)]
pub fn cae_loo<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    inputs: Vec<String>,
    constant: bool,
    width: Option<f64>,
    widths: Option<(f64, f64)>,
    range: (f64, f64),
    memory_budget_mib: u64,
) -> PyResult<Bound<'py, PyAny>> {
    let path = input_path("model", model)?;
    let names: Vec<&str> = inputs.iter().map(|s| s.trim()).collect();
    let matrix = ModelMatrix::read_csv_file(&path, &names).or_raise()?;
    let given = widths_arg(width, widths)?;
    if constant && given.is_some() {
        return Err(input("constant=True searches a constant width: drop width= and widths="));
    }
    for (name, v) in [("range[0]", range.0), ("range[1]", range.1)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(input(format!("{name} must be a positive number, got {v}")));
        }
    }
    let budget = budget_bytes(memory_budget_mib)?;
    let (widths, errors, report) = py.detach(|| -> PyResult<_> {
        Ok(match given {
            Some(widths) => {
                let mut loo = haptex_core::cae::Loo::with_memory_budget(&matrix, budget).map_err(budget_error)?;
                (widths, loo.errors(widths), None)
            }
            None => {
                let options = OptimizeOptions {
                    constant_only: constant,
                    search_range: range,
                    memory_budget_bytes: budget,
                    ..Default::default()
                };
                let optimum = optimize_widths(&matrix, options).map_err(budget_error)?;
                (optimum.widths, optimum.errors, Some(optimum.report))
            }
        })
    })?;
    let report = LooReport::new(&matrix, widths, &errors, report.as_ref()).or_raise()?;
    json_object(py, &report)
}

/// Seconds per call of `repeats` one-query predictions timed in Rust, no
/// Python between them: the same function `Cae.predict` calls, with the
/// same scratch (the Rust side of the call-overhead benchmark,
/// crates/haptex-py/bench/bench_cae.py).
#[pyfunction]
pub fn _bench_rust_predict(py: Python<'_>, cae: &mut Cae, query: Floats<'_>, repeats: usize) -> PyResult<f64> {
    let q = crate::convert::to_vec(&query);
    let m = cae.cae.matrix().m();
    let Cae { cae, scratch } = cae;
    py.detach(|| {
        let mut out = vec![0.0; m];
        let start = std::time::Instant::now();
        for _ in 0..repeats.max(1) {
            cae.predict_into(std::hint::black_box(&q), scratch, &mut out).or_raise()?;
            std::hint::black_box(&out);
        }
        Ok(start.elapsed().as_secs_f64() / repeats.max(1) as f64)
    })
}

/// Seconds per call of `repeats` batched predictions timed in Rust (the
/// function `Cae.predict_batch` calls).
#[pyfunction]
pub fn _bench_rust_predict_batch(py: Python<'_>, cae: &Cae, queries: Matrix<'_>, repeats: usize) -> PyResult<f64> {
    let (q, _, _) = rows_of("queries", &queries)?;
    py.detach(|| {
        let start = std::time::Instant::now();
        for _ in 0..repeats.max(1) {
            std::hint::black_box(cae.cae.predict_batch(std::hint::black_box(&q)).or_raise()?);
        }
        Ok(start.elapsed().as_secs_f64() / repeats.max(1) as f64)
    })
}
