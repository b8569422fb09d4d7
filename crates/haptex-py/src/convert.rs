//! Arguments in and results out: NumPy arrays read in place where their
//! layout allows, checked values, paths, JSON records as Python objects.

use std::path::PathBuf;

use haptex_core::ranges::Range;
use numpy::{AllowTypeChange, PyArray1, PyArrayLike1};
use pyo3::prelude::*;
use pyo3::types::PyString;

use crate::errors::{Kind, input, raise};

/// A 1-D float64 array argument: the caller's array itself when it is a
/// C-contiguous float64 array, else NumPy's conversion of it (a list, an
/// int array, a strided view).
pub type Floats<'py> = PyArrayLike1<'py, f64, AllowTypeChange>;

/// The values of a 1-D array argument as a Vec (the library's profiles own
/// their points).
pub fn to_vec(array: &Floats<'_>) -> Vec<f64> {
    match array.as_slice() {
        Ok(slice) => slice.to_vec(),
        Err(_) => array.as_array().iter().copied().collect(),
    }
}

/// `value` checked against `range`, the message naming the argument `arg`
/// when the range's own name differs.
pub fn ranged(arg: &str, range: Range, value: f64) -> PyResult<f64> {
    range.check(value).map_err(|e| if e.name == arg { input(e.to_string()) } else { input(format!("{arg}: {e}")) })
}

/// An optional value checked against `range`.
pub fn ranged_opt(arg: &str, range: Range, value: Option<f64>) -> PyResult<Option<f64>> {
    value.map(|v| ranged(arg, range, v)).transpose()
}

/// A path argument: a str or an os.PathLike.
pub fn path(arg: &str, value: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    value
        .extract::<PathBuf>()
        .map_err(|_| input(format!("{arg} must be a path (str or os.PathLike), got {}", type_name(value))))
}

/// A path argument naming a file to read: refused as an OSError (a
/// `HaptexOSError`) when it cannot be opened, as the file readers' own
/// errors say it ("PATH: cannot read: ...").
pub fn input_path(arg: &str, value: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    let path = path(arg, value)?;
    if let Err(e) = std::fs::File::open(&path) {
        return Err(raise(Kind::Os, format!("{}: cannot read: {e}", path.display())));
    }
    Ok(path)
}

/// The Python type name of `value`, for messages.
pub fn type_name(value: &Bound<'_, PyAny>) -> String {
    value.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "an object".into())
}

/// One of `choices` for the string argument `arg`.
pub fn choice<'a>(arg: &str, value: &str, choices: &[&'a str]) -> PyResult<&'a str> {
    choices
        .iter()
        .find(|c| **c == value)
        .copied()
        .ok_or_else(|| input(format!("{arg} must be one of {}, got {:?}", choices.join(", "), value)))
}

/// A Vec as a NumPy array owned by Python (no copy).
pub fn array<'py>(py: Python<'py>, values: Vec<f64>) -> Py<PyArray1<f64>> {
    PyArray1::from_vec(py, values).unbind()
}

/// A serializable record as the Python object its JSON reads as (dicts,
/// lists, floats, str, None).
pub fn json_object<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| input(format!("internal: {e}")))?;
    py.import("json")?.call_method1("loads", (PyString::new(py, &text),))
}
