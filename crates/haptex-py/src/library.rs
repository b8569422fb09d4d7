//! `haptex.Library`: the texture library (`haptex library`): materials,
//! their strokes' friction profiles, random samples, and imports of
//! recordings and profiles, through haptex_core::library as the command
//! line uses it.

use std::path::PathBuf;

use haptex_core::FrictionProfile;
use haptex_core::library::{
    Added, Library as CoreLibrary, ProfileProvenance, collect_recordings, default_library_path,
};
use haptex_core::name::check_name;
use haptex_core::recording::{DirectionFilter, ProcessingConfig};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{choice, json_object, path as path_of};
use crate::errors::{Kind, OrRaise, input, raise};
use crate::profile::{Profile, profile_arg};

/// A texture library: a SQLite file of materials and their strokes
/// (recordings processed to friction profiles, or profiles added as they
/// are), each with its provenance (docs/recordings.md).
///
/// Library(path=None): the library at path; by default $HAPTEX_LIBRARY,
/// else the shipped demo library data/library/library.sqlite (12
/// SYNTHETIC materials), as `haptex library` finds it. Reading needs the
/// file (else haptex.HaptexOSError); the import methods create it.
#[pyclass(module = "haptex", name = "Library", frozen)]
pub struct Library {
    path: PathBuf,
}

impl Library {
    /// `f` on the library opened read-only, without the GIL.
    fn read<T: Send>(
        &self,
        py: Python<'_>,
        f: impl FnOnce(&CoreLibrary) -> Result<T, haptex_core::library::LibraryError> + Send,
    ) -> PyResult<T> {
        if !self.path.exists() {
            return Err(raise(
                Kind::Os,
                format!(
                    "{}: no library there; give haptex.Library(PATH), or create one with \
                     haptex.Library(PATH).import_recordings(RECORDINGS)",
                    self.path.display()
                ),
            ));
        }
        py.detach(|| CoreLibrary::open_read_only(&self.path).and_then(|library| f(&library))).or_raise()
    }
}

/// The processing flags of `haptex library import` (docs/recordings.md).
#[allow(clippy::too_many_arguments)]
fn processing(
    dx_mm: Option<f64>,
    min_speed_mm_s: Option<f64>,
    min_fn_n: Option<f64>,
    fn_tolerance: Option<f64>,
    max_gap_mm: Option<f64>,
    direction: &str,
    trim_s: Option<f64>,
    min_duration_s: Option<f64>,
    min_length_mm: Option<f64>,
    speed_window_s: Option<f64>,
    passband_fraction: Option<f64>,
    stopband_fraction: Option<f64>,
    attenuation_db: Option<f64>,
) -> PyResult<ProcessingConfig> {
    let d = ProcessingConfig::default();
    // The flags the command line parses as positive numbers.
    let positive = |name: &str, value: Option<f64>, default: f64| -> PyResult<f64> {
        match value {
            None => Ok(default),
            Some(v) if v.is_finite() && v > 0.0 => Ok(v),
            Some(v) => Err(input(format!("{name} must be a positive finite number, got {v}"))),
        }
    };
    let config = ProcessingConfig {
        passband_fraction: positive("passband_fraction", passband_fraction, d.passband_fraction)?,
        stopband_fraction: positive("stopband_fraction", stopband_fraction, d.stopband_fraction)?,
        stopband_attenuation_db: positive("attenuation_db", attenuation_db, d.stopband_attenuation_db)?,
        speed_window_s: positive("speed_window_s", speed_window_s, d.speed_window_s)?,
        min_speed_mm_s: positive("min_speed_mm_s", min_speed_mm_s, d.min_speed_mm_s)?,
        min_fn_n: positive("min_fn_n", min_fn_n, d.min_fn_n)?,
        fn_tolerance: positive("fn_tolerance", fn_tolerance, d.fn_tolerance)?,
        trim_s: trim_s.unwrap_or(d.trim_s),
        min_duration_s: min_duration_s.unwrap_or(d.min_duration_s),
        min_length_mm: min_length_mm.unwrap_or(d.min_length_mm),
        dx_mm: positive("dx_mm", dx_mm, d.dx_mm)?,
        max_gap_mm: max_gap_mm.unwrap_or(d.max_gap_mm),
        direction: match choice("direction", direction, &["both", "forward", "backward"])? {
            "both" => DirectionFilter::Both,
            "forward" => DirectionFilter::Forward,
            _ => DirectionFilter::Backward,
        },
    };
    config.validate().or_raise()?;
    Ok(config)
}

/// A sampled stroke as haptex.LibrarySample (python/haptex/_types.py).
fn sample_record<'py>(
    py: Python<'py>,
    profile: FrictionProfile,
    stroke: &haptex_core::library::StrokeInfo,
    seed: Option<u64>,
) -> PyResult<Bound<'py, PyAny>> {
    let kwargs = PyDict::new(py);
    kwargs.set_item("profile", Py::new(py, Profile { inner: profile })?)?;
    kwargs.set_item("stroke", json_object(py, stroke)?)?;
    kwargs.set_item("seed", seed)?;
    kwargs.set_item("comments", stroke.provenance_lines())?;
    py.import("haptex._types")?.getattr("LibrarySample")?.call((), Some(&kwargs))
}

#[pymethods]
impl Library {
    #[new]
    #[pyo3(signature = (path = None))]
    fn new(path: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        Ok(Self { path: path.map(|p| path_of("path", p)).transpose()?.unwrap_or_else(default_library_path) })
    }

    /// The library file's path.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// The materials, as `haptex library list --format json` lists them:
    /// dicts with name, description, synthetic, strokes, mean_mu, mu_range
    /// and mean_fn_n (N, or None).
    fn materials<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let materials = self.read(py, |library| library.materials())?;
        json_object(py, &materials)
    }

    /// The strokes of a material (case-insensitive), as `haptex library
    /// list --material NAME --format json` lists them: dicts with id,
    /// provenance (source, licence, origin_path, synthetic, ...), n_points,
    /// span_mm, mean_mu, mean_fn_n (N).
    fn strokes<'py>(&self, py: Python<'py>, material: &str) -> PyResult<Bound<'py, PyAny>> {
        let strokes = self.read(py, |library| library.strokes(material))?;
        json_object(py, &strokes)
    }

    /// The friction profile of a random stroke of a material (`haptex
    /// library sample`): a haptex.LibrarySample with the profile (x_mm in
    /// mm, mu, fn_n in N when known), the stroke's record and the seed
    /// (the same seed picks the same stroke; None picks a fresh one,
    /// returned).
    #[pyo3(signature = (material, *, seed = None))]
    fn sample<'py>(&self, py: Python<'py>, material: &str, seed: Option<u64>) -> PyResult<Bound<'py, PyAny>> {
        let sampled = self.read(py, |library| library.sample(material, seed))?;
        sample_record(py, sampled.stored.profile, &sampled.stored.stroke, Some(sampled.seed))
    }

    /// The stored profile of stroke `stroke_id` (as `haptex library
    /// export` writes it): a haptex.LibrarySample whose seed is None.
    fn stroke<'py>(&self, py: Python<'py>, stroke_id: i64) -> PyResult<Bound<'py, PyAny>> {
        let stored = self.read(py, |library| library.profile(stroke_id))?;
        sample_record(py, stored.profile, &stored.stroke, None)
    }

    /// The library's consistency problems (`haptex library check`): an
    /// empty list when consistent.
    fn check(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        self.read(py, |library| library.check())
    }

    /// Imports recordings (`haptex library import PATHS`): NAME.recording.json
    /// files, or directories searched for them, each processed to a
    /// friction profile with the processing arguments (the command's
    /// flags: dx_mm, min_speed_mm_s (mm/s), min_fn_n (N), fn_tolerance,
    /// max_gap_mm, direction ("both", "forward", "backward"), trim_s,
    /// min_duration_s, min_length_mm, speed_window_s, passband_fraction,
    /// stopband_fraction, attenuation_db (dB)) and stored with its profile
    /// in one transaction; content already there is skipped. Creates the
    /// library if missing.
    ///
    /// Returns {"new": [stroke ids], "duplicate": [stroke ids]}. A
    /// recording that cannot be imported does not stop the others; then
    /// raises haptex.InvalidInputError naming each.
    #[pyo3(signature = (
        inputs, *, dx_mm = None, min_speed_mm_s = None, min_fn_n = None, fn_tolerance = None, max_gap_mm = None,
        direction = "both", trim_s = None, min_duration_s = None, min_length_mm = None, speed_window_s = None,
        passband_fraction = None, stopband_fraction = None, attenuation_db = None
    ))]
    #[allow(clippy::too_many_arguments)]
    fn import_recordings<'py>(
        &self,
        py: Python<'py>,
        inputs: &Bound<'_, PyAny>,
        dx_mm: Option<f64>,
        min_speed_mm_s: Option<f64>,
        min_fn_n: Option<f64>,
        fn_tolerance: Option<f64>,
        max_gap_mm: Option<f64>,
        direction: &str,
        trim_s: Option<f64>,
        min_duration_s: Option<f64>,
        min_length_mm: Option<f64>,
        speed_window_s: Option<f64>,
        passband_fraction: Option<f64>,
        stopband_fraction: Option<f64>,
        attenuation_db: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let config = processing(
            dx_mm,
            min_speed_mm_s,
            min_fn_n,
            fn_tolerance,
            max_gap_mm,
            direction,
            trim_s,
            min_duration_s,
            min_length_mm,
            speed_window_s,
            passband_fraction,
            stopband_fraction,
            attenuation_db,
        )?;
        // One path, or a sequence of them.
        let inputs: Vec<PathBuf> = match inputs.extract::<PathBuf>() {
            Ok(one) if !inputs.is_instance_of::<pyo3::types::PyList>() => vec![one],
            _ => inputs
                .try_iter()
                .map_err(|_| input("inputs must be a path or a list of paths"))?
                .map(|p| path_of("inputs", &p?))
                .collect::<PyResult<_>>()?,
        };
        if inputs.is_empty() {
            return Err(input("inputs: give at least one recording or directory"));
        }
        let db = self.path.clone();
        let (new, duplicate, errors, n) = py
            .detach(|| -> Result<_, PyErrText> {
                let files = collect_recordings(&inputs).map_err(PyErrText::io)?;
                let mut library = CoreLibrary::open(&db).map_err(PyErrText::other)?;
                let run = library
                    .begin_import("haptex.Library.import_recordings (Python)", &config)
                    .map_err(PyErrText::other)?;
                let (mut new, mut duplicate, mut errors) = (Vec::new(), Vec::new(), Vec::new());
                for file in &files {
                    match library.import_recording(run, file, &config) {
                        Ok(Added::New(id)) => new.push(id),
                        Ok(Added::Duplicate(id)) => duplicate.push(id),
                        Err(e) => errors.push(crate::errors::describe(&e)),
                    }
                }
                library.finish_import(run).map_err(PyErrText::other)?;
                library.settle().map_err(PyErrText::other)?;
                Ok((new, duplicate, errors, files.len()))
            })
            .map_err(PyErrText::raise)?;
        if !errors.is_empty() {
            return Err(input(format!(
                "{} of {n} recordings could not be imported (the others were): {}",
                errors.len(),
                errors.join("; ")
            )));
        }
        let out = PyDict::new(py);
        out.set_item("new", new)?;
        out.set_item("duplicate", duplicate)?;
        Ok(out)
    }

    /// Adds a friction profile as a stroke of `material` (`haptex library
    /// import --profile`): profile a haptex.Profile, a path to a profile
    /// CSV or (x_mm, mu); say where it comes from with synthetic=True
    /// (generated: an FE run, a model) or False (measured on a finger);
    /// source (default: the file, or "user profile from Python"), licence,
    /// description (of a new material). A material never mixes synthetic
    /// and measured strokes. Creates the library if missing.
    ///
    /// Returns {"new": id} or {"duplicate": id} (the same profile already
    /// stored).
    #[pyo3(signature = (profile, *, material, synthetic, description = "", source = None, licence = "unspecified"))]
    #[allow(clippy::too_many_arguments)]
    fn import_profile<'py>(
        &self,
        py: Python<'py>,
        profile: &Bound<'_, PyAny>,
        material: &str,
        synthetic: bool,
        description: &str,
        source: Option<String>,
        licence: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        // Checked before the library is opened: a refused name leaves no trace.
        check_name(material).map_err(|e| input(format!("material: {e}")))?;
        let origin = match profile.extract::<PathBuf>() {
            Ok(p) if profile.cast::<Profile>().is_err() => p.display().to_string(),
            _ => "<Python>".to_string(),
        };
        let profile = profile_arg("profile", profile)?;
        let provenance = ProfileProvenance {
            source: source.unwrap_or_else(|| {
                if origin == "<Python>" { "user profile from Python".into() } else { format!("user profile {origin}") }
            }),
            licence: licence.to_string(),
            synthetic,
            origin_path: origin,
        };
        let db = self.path.clone();
        let added = py
            .detach(|| -> Result<Added, haptex_core::library::LibraryError> {
                let mut library = CoreLibrary::open(&db)?;
                let run =
                    library.begin_import("haptex.Library.import_profile (Python)", &ProcessingConfig::default())?;
                let added = library.add_profile(run, material, description, &profile, &provenance)?;
                library.finish_import(run)?;
                library.settle()?;
                Ok(added)
            })
            .or_raise()?;
        let out = PyDict::new(py);
        match added {
            Added::New(id) => out.set_item("new", id)?,
            Added::Duplicate(id) => out.set_item("duplicate", id)?,
        }
        Ok(out)
    }

    fn __repr__(&self) -> String {
        format!("Library({:?})", self.path.display().to_string())
    }
}

/// An error met without the GIL, raised once it is back: an I/O error's
/// kind and text, or another error's text.
struct PyErrText {
    os: bool,
    text: String,
}

impl PyErrText {
    fn io(e: std::io::Error) -> Self {
        let os = !matches!(e.kind(), std::io::ErrorKind::InvalidData | std::io::ErrorKind::InvalidInput);
        Self { os, text: e.to_string() }
    }

    fn other(e: impl std::error::Error + 'static) -> Self {
        Self { os: false, text: crate::errors::describe(&e) }
    }

    fn raise(self) -> PyErr {
        raise(if self.os { Kind::Os } else { Kind::Input }, self.text)
    }
}
