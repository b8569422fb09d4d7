//! `haptex.Profile`: a friction profile mu(x), as the library and the
//! command line's `x_mm,mu` (or `x_mm,ft_n,fn_n`) CSV files hold it.

use std::path::PathBuf;

use haptex_core::FrictionProfile;
use numpy::PyArray1;
use pyo3::prelude::*;

use crate::convert::{Floats, array, input_path, to_vec, type_name};
use crate::errors::{OrRaise, input};

/// A friction profile: positions x in mm (strictly increasing) and the
/// friction coefficient mu = Ft/Fn at each, optionally with the normal
/// force Fn in N (needed by a contact-area exponent other than 1).
///
/// Profile(x_mm, mu) checks the points as `haptex voltage --profile`
/// checks a file's: finite, x increasing, mu in range.
#[pyclass(module = "haptex", name = "Profile", frozen)]
#[derive(Clone)]
pub struct Profile {
    pub inner: FrictionProfile,
}

#[pymethods]
impl Profile {
    #[new]
    fn new(x_mm: Floats<'_>, mu: Floats<'_>) -> PyResult<Self> {
        Ok(Self { inner: FrictionProfile::new(to_vec(&x_mm), to_vec(&mu)).or_raise()? })
    }

    /// A profile from the tangential and normal forces in N at each
    /// position: mu = ft_n / fn_n (paper eq. 4); fn_n must be positive.
    #[staticmethod]
    fn from_forces(x_mm: Floats<'_>, ft_n: Floats<'_>, fn_n: Floats<'_>) -> PyResult<Self> {
        let ft = to_vec(&ft_n);
        Ok(Self { inner: FrictionProfile::from_forces(to_vec(&x_mm), &ft, to_vec(&fn_n)).or_raise()? })
    }

    /// Reads a profile CSV (`x_mm,mu` or `x_mm,ft_n,fn_n`, `#` comments),
    /// as `haptex voltage --profile` does.
    #[staticmethod]
    fn read_csv(path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let path = crate::convert::input_path("path", path)?;
        Ok(Self { inner: FrictionProfile::read_csv_file(&path).or_raise()? })
    }

    /// Writes `x_mm,mu` CSV to `path` atomically (a temporary file renamed
    /// over it when complete).
    fn write_csv(&self, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        self.inner.write_csv_file(&path).or_raise()
    }

    /// Positions in mm (a new array).
    #[getter]
    fn x_mm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.inner.x_mm())
    }

    /// Friction coefficient at each position (a new array).
    #[getter]
    fn mu<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.inner.mu())
    }

    /// Normal force in N at each position, or None.
    #[getter]
    fn fn_n(&self, py: Python<'_>) -> Option<Py<PyArray1<f64>>> {
        self.inner.fn_n().map(|f| array(py, f.to_vec()))
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    fn __repr__(&self) -> String {
        let x = self.inner.x_mm();
        format!(
            "Profile({} points, x {} .. {} mm{})",
            x.len(),
            haptex_core::num::Num(x[0]),
            haptex_core::num::Num(x[x.len() - 1]),
            if self.inner.fn_n().is_some() { ", with fn_n" } else { "" }
        )
    }
}

/// The profile argument of a design function: a `Profile`, a path to a
/// profile CSV, or a pair `(x_mm, mu)` of arrays.
pub fn profile_arg(arg: &str, value: &Bound<'_, PyAny>) -> PyResult<FrictionProfile> {
    if let Ok(profile) = value.cast::<Profile>() {
        return Ok(profile.get().inner.clone());
    }
    if let Ok((x, mu)) = value.extract::<(Floats<'_>, Floats<'_>)>() {
        return FrictionProfile::new(to_vec(&x), to_vec(&mu)).or_raise();
    }
    // Anything with x_mm and mu arrays: a haptex.Prediction, a Design, a
    // simulation's result.
    if let (Ok(x), Ok(mu)) = (value.getattr("x_mm"), value.getattr("mu"))
        && let (Ok(x), Ok(mu)) = (x.extract::<Floats<'_>>(), mu.extract::<Floats<'_>>())
    {
        return FrictionProfile::new(to_vec(&x), to_vec(&mu)).or_raise();
    }
    if value.extract::<PathBuf>().is_ok() {
        return FrictionProfile::read_csv_file(&input_path(arg, value)?).or_raise();
    }
    Err(input(format!(
        "{arg} must be a haptex.Profile, a path to a profile CSV, a pair (x_mm, mu) of arrays or an object with \
         x_mm and mu arrays (a haptex.Prediction), got {}",
        type_name(value)
    )))
}
