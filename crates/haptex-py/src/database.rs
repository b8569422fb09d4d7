//! `haptex.Database`: the FE database of the bump, edge and sine templates,
//! predicted by the CAE (`haptex predict`) and checked case by case
//! (`haptex db loo`).

use std::collections::HashMap;
use std::path::PathBuf;

use haptex_core::database::{
    Estimator, Metadata, Prediction as CorePrediction, Template, TemplateModel, write_prediction_csv,
};
use haptex_fem::loo_case::LooCase as CoreLooCase;
use haptex_fem::sweep::Run;
use numpy::PyArray1;
use pyo3::prelude::*;

use crate::convert::{array, choice, json_object, path};
use crate::errors::{Kind, OrRaise, input, raise};

/// The shipped database directory: $HAPTEX_DB, else data/db of the
/// checkout this package was built from (as the command line finds it).
fn default_db() -> PathBuf {
    haptex_core::io::shipped_data("HAPTEX_DB", "data/db")
}

fn template_of(surface: &str) -> PyResult<Template> {
    Ok(match choice("surface", surface, &["bump", "edge", "sine"])? {
        "bump" => Template::Bump,
        "edge" => Template::Edge,
        _ => Template::Sine,
    })
}

/// The FE database of a directory (default: the shipped data/db, or
/// $HAPTEX_DB), its templates loaded on first use.
///
/// Database(db=None)
/// .predict(surface, x0, width, height, velocity=20.0): `haptex predict`
/// .loo_summary(): `haptex db loo --json` (per template: widths, LOO error)
/// .loo(surface, width, height, velocity=20.0): `haptex db loo --surface`
#[pyclass(module = "haptex", name = "Database")]
pub struct Database {
    dir: PathBuf,
    metadata: Metadata,
    models: HashMap<Template, TemplateModel>,
}

impl Database {
    /// Loads a template's model if it is not yet.
    fn load(&mut self, template: Template) -> PyResult<()> {
        if !self.models.contains_key(&template) {
            let model = TemplateModel::load_with(&self.dir, &self.metadata, template).or_raise()?;
            self.models.insert(template, model);
        }
        Ok(())
    }
}

#[pymethods]
impl Database {
    #[new]
    #[pyo3(signature = (db = None))]
    pub fn new(db: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let dir = match db {
            Some(db) => path("db", db)?,
            None => default_db(),
        };
        let metadata = Metadata::read(&dir).map_err(|e| {
            let kind = if dir.is_dir() { Kind::Input } else { Kind::Os };
            raise(
                kind,
                format!(
                    "no FE database in {} (build one with `haptex db build --out DIR`, or pass db=DIR): {}",
                    dir.display(),
                    crate::errors::describe(&e)
                ),
            )
        })?;
        Ok(Self { dir, metadata, models: HashMap::new() })
    }

    /// The friction profile of a bump, edge or sine at x0 (mm) with
    /// width r_w and height r_h (mm), slid over at `velocity` (mm/s): the
    /// database's FE row when the parameters are one, else the estimate of
    /// `estimator` ("grid": multilinear over the sweep's grid, "cae": the
    /// paper's section 3.2; default: the database's own). The numbers of
    /// `haptex predict`, bit for bit. Warns (haptex.ExtrapolationWarning)
    /// as the command line does.
    #[pyo3(signature = (surface, x0, width, height, velocity = 20.0, estimator = None))]
    #[allow(clippy::too_many_arguments)]
    pub fn predict(
        &mut self,
        py: Python<'_>,
        surface: &str,
        x0: f64,
        width: f64,
        height: f64,
        velocity: f64,
        estimator: Option<&str>,
    ) -> PyResult<Prediction> {
        let template = template_of(surface)?;
        let estimator = match estimator {
            None => None,
            Some(name) => Some(
                Estimator::from_name(name)
                    .ok_or_else(|| input(format!("estimator must be one of 'grid' or 'cae', got '{name}'")))?,
            ),
        };
        for (name, v) in [("width", width), ("height", height), ("velocity", velocity)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(input(format!("{name} must be a positive number, got {v}")));
            }
        }
        let query = [width, height, velocity];
        self.load(template)?;
        let model = &self.models[&template];
        let prediction =
            model.predict_with(estimator.unwrap_or(model.estimator()), x0, width, height, velocity).or_raise()?;
        let entry = self.metadata.entry(template).ok_or_else(|| input("the database has no such template"))?;
        let source = model.describe(&query, &prediction, entry);
        let warning = model.warning(&query, prediction.fe_row, &prediction.diagnostics);
        if let Some(text) = &warning {
            let class = py.import("haptex._errors")?.getattr("ExtrapolationWarning")?;
            PyErr::warn(py, &class, &std::ffi::CString::new(text.as_str())?, 1)?;
        }
        let notes = model.estimate_notes(&self.metadata, &query, &prediction);
        let comments = model.prediction_comments(&self.metadata, x0, &query, &source, warning.as_deref(), &notes);
        let CorePrediction { x_mm, mu, fe_row, .. } = prediction;
        Ok(Prediction {
            x_mm: array(py, x_mm.clone()),
            mu: array(py, mu.clone()),
            fe_row,
            source,
            warning,
            flat_mu: self.metadata.fe.flat_mu(),
            comments,
            points: (x_mm, mu),
        })
    }

    /// Per template: rows, widths and leave-one-out errors, with when and
    /// how the database was built: a dict equal to `haptex db loo --json`'s.
    fn loo_summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_object(py, &self.metadata.loo_summary())
    }

    /// One case against the CAE (`haptex db loo --surface ...`): the FE
    /// profile, the CAE estimate that never saw the case and the one over
    /// the whole database, on xi = x - x0 (mm). A case that is not a
    /// database row is simulated now with the database's FE settings
    /// (about half a second, the GIL released).
    #[pyo3(signature = (surface, width, height, velocity = 20.0))]
    fn loo(&mut self, py: Python<'_>, surface: &str, width: f64, height: f64, velocity: f64) -> PyResult<LooCase> {
        let template = template_of(surface)?;
        let run = Run { template, width_mm: width, height_mm: height, velocity_mm_s: velocity };
        self.load(template)?;
        let (dir, metadata, model) = (&self.dir, &self.metadata, &self.models[&template]);
        let case = py.detach(|| CoreLooCase::compute(dir, metadata, model, run)).or_raise()?;
        LooCase::new(py, case)
    }

    /// The database directory.
    #[getter]
    fn dir(&self) -> PathBuf {
        self.dir.clone()
    }

    /// The surface friction of the FE model (mu_skin): the mu_flat of a
    /// relative design of its profiles.
    #[getter]
    fn flat_mu(&self) -> f64 {
        self.metadata.fe.flat_mu()
    }

    fn __repr__(&self) -> String {
        format!("Database({})", self.dir.display())
    }
}

/// A predicted profile: x_mm (mm) and mu, the database row it is (or
/// None for a CAE estimate), where it comes from, the warning if any, the
/// database's flat-surface friction; write_csv writes `haptex predict`'s
/// file.
#[pyclass(module = "haptex", name = "Prediction", frozen)]
pub struct Prediction {
    #[pyo3(get)]
    x_mm: Py<PyArray1<f64>>,
    #[pyo3(get)]
    mu: Py<PyArray1<f64>>,
    #[pyo3(get)]
    fe_row: Option<usize>,
    #[pyo3(get)]
    source: String,
    #[pyo3(get)]
    warning: Option<String>,
    #[pyo3(get)]
    flat_mu: f64,
    /// The file's comment lines, and the points as predicted (the arrays
    /// handed out are the caller's to change): the CSV is written from
    /// these when asked for, not at every prediction.
    comments: Vec<String>,
    points: (Vec<f64>, Vec<f64>),
}

impl Prediction {
    fn write(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        write_prediction_csv(w, &self.comments, &self.points.0, &self.points.1)
    }
}

#[pymethods]
impl Prediction {
    /// Writes the profile as `haptex predict -o` does, atomically.
    fn write_csv(&self, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        haptex_core::io::write_atomic(&path, |w| self.write(w)).or_raise()
    }

    /// The CSV `write_csv` writes, as a str.
    fn to_csv(&self) -> PyResult<String> {
        let mut bytes = Vec::new();
        self.write(&mut bytes).or_raise()?;
        String::from_utf8(bytes).map_err(|e| input(format!("internal: {e}")))
    }

    /// The profile as a haptex.Profile (for haptex.voltage).
    fn profile(&self) -> PyResult<crate::profile::Profile> {
        let (x, mu) = self.points.clone();
        Ok(crate::profile::Profile { inner: haptex_core::FrictionProfile::new(x, mu).or_raise()? })
    }

    fn __repr__(&self) -> String {
        format!("Prediction({})", self.source)
    }
}

/// One database case against the CAE (haptex.Database.loo): arrays xi_mm,
/// h_mm, mu_fe, mu_cae_loo, mu_cae_full; the row (or None), the source,
/// the RMS differences rms_loo and rms_full; write_csv writes `haptex db
/// loo -o`'s file.
#[pyclass(module = "haptex", name = "LooCase", frozen)]
pub struct LooCase {
    case: CoreLooCase,
    #[pyo3(get)]
    xi_mm: Py<PyArray1<f64>>,
    #[pyo3(get)]
    h_mm: Py<PyArray1<f64>>,
    #[pyo3(get)]
    mu_fe: Py<PyArray1<f64>>,
    #[pyo3(get)]
    mu_cae_loo: Py<PyArray1<f64>>,
    #[pyo3(get)]
    mu_cae_full: Py<PyArray1<f64>>,
}

impl LooCase {
    fn new(py: Python<'_>, case: CoreLooCase) -> PyResult<Self> {
        Ok(Self {
            xi_mm: array(py, case.xi_mm.clone()),
            h_mm: array(py, case.h_mm.clone()),
            mu_fe: array(py, case.mu_fe.clone()),
            mu_cae_loo: array(py, case.mu_cae_loo.clone()),
            mu_cae_full: array(py, case.mu_cae_full.clone()),
            case,
        })
    }
}

#[pymethods]
impl LooCase {
    /// The database row (0-based) the case is, or None.
    #[getter]
    fn row(&self) -> Option<usize> {
        self.case.row
    }

    /// Where the FE profile comes from.
    #[getter]
    fn source(&self) -> String {
        self.case.source.clone()
    }

    /// RMS difference of the CAE that never saw the case to the FE profile.
    #[getter]
    fn rms_loo(&self) -> f64 {
        self.case.rms_loo
    }

    /// RMS difference of the CAE over the whole database to the FE profile.
    #[getter]
    fn rms_full(&self) -> f64 {
        self.case.rms_full
    }

    /// Writes the case as `haptex db loo -o` does, atomically.
    fn write_csv(&self, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        haptex_core::io::write_atomic(&path, |w| self.case.write_csv(w)).or_raise()
    }
}

/// The friction profile of a bump, edge or sine from the shipped FE
/// database (`haptex predict`): haptex.Database(db).predict(...), the
/// database opened for this call. Keep a haptex.Database to predict many.
#[pyfunction]
#[pyo3(signature = (surface, x0, width, height, velocity = 20.0, db = None, estimator = None))]
#[allow(clippy::too_many_arguments)]
pub fn predict(
    py: Python<'_>,
    surface: &str,
    x0: f64,
    width: f64,
    height: f64,
    velocity: f64,
    db: Option<&Bound<'_, PyAny>>,
    estimator: Option<&str>,
) -> PyResult<Prediction> {
    Database::new(db)?.predict(py, surface, x0, width, height, velocity, estimator)
}
