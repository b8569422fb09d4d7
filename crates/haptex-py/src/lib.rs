//! haptex from Python: the extension module `haptex._haptex`, which the
//! package `haptex` (python/haptex) re-exports. Each function is a
//! command of the command line, its keyword arguments the command's flags,
//! and its numbers the command's, bit for bit: both call the same library
//! functions. Arrays come in as NumPy arrays (read in place when they are
//! C-contiguous float64) and go out as NumPy arrays Python owns; long
//! work runs with the GIL released.

use pyo3::prelude::*;

mod cae;
mod convert;
mod database;
mod design;
mod errors;
mod fem;
mod library;
mod maps;
mod playback;
mod profile;

#[pymodule]
fn _haptex(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<profile::Profile>()?;
    m.add_class::<design::Design>()?;
    m.add_function(wrap_pyfunction!(design::voltage, m)?)?;
    m.add_class::<cae::Cae>()?;
    m.add_function(wrap_pyfunction!(cae::cae_loo, m)?)?;
    m.add_function(wrap_pyfunction!(cae::_bench_rust_predict, m)?)?;
    m.add_function(wrap_pyfunction!(cae::_bench_rust_predict_batch, m)?)?;
    m.add_class::<database::Database>()?;
    m.add_class::<database::Prediction>()?;
    m.add_class::<database::LooCase>()?;
    m.add_function(wrap_pyfunction!(database::predict, m)?)?;
    m.add_class::<playback::Signal>()?;
    m.add_function(wrap_pyfunction!(playback::play, m)?)?;
    m.add_function(wrap_pyfunction!(playback::read_wav, m)?)?;
    m.add_class::<library::Library>()?;
    m.add_class::<fem::Simulation>()?;
    m.add_class::<fem::CheckResult>()?;
    m.add_function(wrap_pyfunction!(fem::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(fem::check, m)?)?;
    m.add_function(wrap_pyfunction!(fem::compensate, m)?)?;
    m.add_class::<maps::FrictionMap>()?;
    m.add_class::<maps::VoltageMap>()?;
    m.add_class::<maps::PathSamples>()?;
    m.add_function(wrap_pyfunction!(maps::map_from_image, m)?)?;
    m.add_function(wrap_pyfunction!(maps::map_from_profile, m)?)?;
    m.add_function(wrap_pyfunction!(maps::map_voltage, m)?)?;
    m.add_function(wrap_pyfunction!(maps::map_sample_path, m)?)?;
    m.add_function(wrap_pyfunction!(maps::map_grating, m)?)?;
    m.add_function(wrap_pyfunction!(maps::map_compose, m)?)?;
    Ok(())
}
