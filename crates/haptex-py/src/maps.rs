//! Friction maps over (x, y) from Python, as `haptex map` makes and uses
//! them (docs/maps.md): `haptex.FrictionMap` (from an image, a profile, a
//! 2-D array or a map file), `haptex.map_voltage` (eq. 8/9 per cell, the
//! ultrasonic and combined displays) and `haptex.map_sample_path` (the
//! voltage along a finger path). Arrays are (ny, nx): row j at
//! y0_mm + j dy_mm, column i at x0_mm + i dx_mm, y growing with the row.

use haptex_core::combined::Channels;
use haptex_core::electrovibration::Method;
use haptex_core::frequency::ForceModel;
use haptex_core::map::{self, DisplayMap, GrayLevels, GrayMapping, MapFormat, MapGrid};
use haptex_core::num::Num;
use haptex_core::planar::PlanarTrajectory;
use haptex_core::ranges;
use numpy::ndarray::Array2;
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{Floats, array, choice, input_path, ranged, ranged_opt, to_vec, type_name};
use crate::design::{DeviceArgs, DisplayChoice, carrier_of, device_file, refuse_set_by_file};
use crate::errors::{Kind, OrRaise, input, raise};
use crate::profile::profile_arg;
use haptex_core::io::BoundedReadError;

/// A friction map: the friction coefficient mu over a regular grid,
/// `mu[j, i]` at x = x0_mm + i dx_mm, y = y0_mm + j dy_mm (mm; row 0 at
/// the smallest y).
///
/// FrictionMap(mu, *, dx_mm, dy_mm, x0_mm=0.0, y0_mm=0.0): mu a 2-D array
/// (ny, nx) of real numbers, at least 2 x 2, checked as `haptex map` checks
/// a map file (finite, mu in range, positions in range).
#[pyclass(module = "haptex", name = "FrictionMap", frozen)]
pub struct FrictionMap {
    pub inner: map::FrictionMap,
}

#[pymethods]
impl FrictionMap {
    #[new]
    #[pyo3(signature = (mu, *, dx_mm, dy_mm, x0_mm = 0.0, y0_mm = 0.0))]
    fn new(mu: &Bound<'_, PyAny>, dx_mm: f64, dy_mm: f64, x0_mm: f64, y0_mm: f64) -> PyResult<Self> {
        let (values, ny, nx) = floats_2d("mu", mu)?;
        let grid = MapGrid { nx, ny, x0_mm, y0_mm, dx_mm, dy_mm };
        Ok(Self { inner: map::FrictionMap::new(grid, values, "mu").or_raise()? })
    }

    /// Reads a friction map file as `haptex map voltage --map` does: CSV
    /// (`x_mm,y_mm,mu`, rows through x for each y in turn) or NPY (a (ny,
    /// nx) array with its `.npy.json` sidecar), by the file's extension.
    #[staticmethod]
    fn read(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let path = input_path("path", path)?;
        Ok(Self { inner: py.detach(|| map::FrictionMap::read_file(&path)).or_raise()? })
    }

    /// Writes the map as `haptex map ... -o PATH` does: `.csv` (long
    /// format) or `.npy` with its `PATH.npy.json` sidecar (grid and
    /// SHA-256), by the extension; atomically.
    fn write(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        let format = MapFormat::of(&path).or_raise()?;
        py.detach(|| self.inner.write_file(&path, format)).or_raise()
    }

    /// The CSV `write` writes to a .csv path, as a str.
    fn to_csv(&self) -> PyResult<String> {
        let mut bytes = Vec::new();
        self.inner.write_csv(&mut bytes).or_raise()?;
        String::from_utf8(bytes).map_err(|e| input(format!("internal: {e}")))
    }

    /// Friction coefficient per cell, a new (ny, nx) float64 array.
    #[getter]
    fn mu<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        array_2d(py, &self.inner.grid, self.inner.mu.clone())
    }

    /// x of each column in mm (nx values).
    #[getter]
    fn x_mm(&self, py: Python<'_>) -> Py<PyArray1<f64>> {
        x_axis(py, &self.inner.grid)
    }

    /// y of each row in mm (ny values).
    #[getter]
    fn y_mm(&self, py: Python<'_>) -> Py<PyArray1<f64>> {
        y_axis(py, &self.inner.grid)
    }

    /// (ny, nx).
    #[getter]
    fn shape(&self) -> (usize, usize) {
        (self.inner.grid.ny, self.inner.grid.nx)
    }

    /// Grid spacing along x in mm.
    #[getter]
    fn dx_mm(&self) -> f64 {
        self.inner.grid.dx_mm
    }

    /// Grid spacing along y in mm.
    #[getter]
    fn dy_mm(&self) -> f64 {
        self.inner.grid.dy_mm
    }

    /// x of the first column in mm.
    #[getter]
    fn x0_mm(&self) -> f64 {
        self.inner.grid.x0_mm
    }

    /// y of the first row in mm.
    #[getter]
    fn y0_mm(&self) -> f64 {
        self.inner.grid.y0_mm
    }

    /// The line `haptex map` prints about the map (size, extent, mu range).
    #[getter]
    fn summary(&self) -> String {
        self.inner.summary_line()
    }

    fn __repr__(&self) -> String {
        let g = &self.inner.grid;
        format!(
            "FrictionMap({} x {} cells, x {} .. {} mm, y {} .. {} mm)",
            g.nx,
            g.ny,
            Num(g.x0_mm),
            Num(g.x(g.nx - 1)),
            Num(g.y0_mm),
            Num(g.y(g.ny - 1))
        )
    }
}

/// A friction map from a grayscale image (`haptex map from-image`): gray
/// level g in [0, 1] (black 0, full level 1) to
/// mu = mu_black + (mu_white - mu_black) g^gamma, one cell per pixel, the
/// image's top row at the largest y.
///
/// image: a path to an 8- or 16-bit grayscale PNG, or a 2-D uint8 or
///   uint16 array of gray levels (row 0 the top row, as the PNG stores it;
///   uint8 full level 255, uint16 65535).
/// mu_black, mu_white: friction of black and of white. gamma: exponent on
///   the gray level (0.05 .. 20, 1 linear).
/// pixel_mm: pixel size along x in mm; pixel_mm_y along y (default
///   pixel_mm); x0_mm, y0_mm: the bottom-left pixel's position in mm.
///
/// Returns a haptex.FrictionMap, the same cells as the command line's for
/// the same PNG, bit for bit.
#[pyfunction]
#[pyo3(signature = (image, *, mu_black, mu_white, gamma = 1.0, pixel_mm, pixel_mm_y = None, x0_mm = 0.0, y0_mm = 0.0))]
#[allow(clippy::too_many_arguments)]
pub fn map_from_image(
    py: Python<'_>,
    image: &Bound<'_, PyAny>,
    mu_black: f64,
    mu_white: f64,
    gamma: f64,
    pixel_mm: f64,
    pixel_mm_y: Option<f64>,
    x0_mm: f64,
    y0_mm: f64,
) -> PyResult<FrictionMap> {
    let mapping = GrayMapping {
        mu_black: ranged("mu_black", ranges::MU, mu_black)?,
        mu_white: ranged("mu_white", ranges::MU, mu_white)?,
        gamma,
    };
    let pixel_mm = positive("pixel_mm", pixel_mm)?;
    let spacing = (pixel_mm, pixel_mm_y.map(|v| positive("pixel_mm_y", v)).transpose()?.unwrap_or(pixel_mm));
    let origin = (x0_mm, y0_mm);
    if let Ok(array) = image.cast::<numpy::PyUntypedArray>() {
        let dtype = array.dtype().to_string();
        if array.ndim() != 2 || !(dtype == "uint8" || dtype == "uint16") {
            return Err(input(format!(
                "image must be a 2-D uint8 or uint16 array of gray levels (row 0 the top row), got a {}-D {dtype} \
                 array",
                array.ndim()
            )));
        }
        let (height, width) = (array.shape()[0], array.shape()[1]);
        let map = if dtype == "uint8" {
            let levels = image.cast::<PyArray2<u8>>()?.readonly();
            let view = levels.as_array();
            // ndarray's slice is the C-ordered one (NumPy's would take a
            // Fortran-ordered array's memory as rows).
            match view.as_slice() {
                Some(l) => from_levels(GrayLevels::Eight(l), width, height, &mapping, spacing, origin),
                None => {
                    let l: Vec<u8> = view.iter().copied().collect();
                    from_levels(GrayLevels::Eight(&l), width, height, &mapping, spacing, origin)
                }
            }
        } else {
            let levels = image.cast::<PyArray2<u16>>()?.readonly();
            let view = levels.as_array();
            match view.as_slice() {
                Some(l) => from_levels(GrayLevels::Sixteen(l), width, height, &mapping, spacing, origin),
                None => {
                    let l: Vec<u16> = view.iter().copied().collect();
                    from_levels(GrayLevels::Sixteen(&l), width, height, &mapping, spacing, origin)
                }
            }
        };
        return Ok(FrictionMap { inner: map.or_raise()? });
    }
    if image.extract::<std::path::PathBuf>().is_err() {
        return Err(input(format!(
            "image must be a path to a grayscale PNG or a 2-D uint8 or uint16 array, got {}",
            type_name(image)
        )));
    }
    let path = input_path("image", image)?;
    let name = path.display().to_string();
    // As the command line reads it: at most 256 MiB of file, the size the
    // header claims checked before anything is decoded.
    let bytes = py.detach(|| haptex_core::io::read_file_bounded(&path, 256 << 20)).map_err(|e| {
        let kind = if matches!(e, BoundedReadError::Io(_)) { Kind::Os } else { Kind::Input };
        raise(kind, format!("{name}: {e}"))
    })?;
    map::png_header(&bytes, &name).or_raise()?;
    let map = py.detach(|| map::FrictionMap::read_gray_png(&bytes, &mapping, spacing, origin, &name));
    Ok(FrictionMap { inner: map.or_raise()? })
}

fn from_levels(
    levels: GrayLevels<'_>,
    width: usize,
    height: usize,
    mapping: &GrayMapping,
    spacing: (f64, f64),
    origin: (f64, f64),
) -> Result<map::FrictionMap, map::MapError> {
    map::FrictionMap::from_gray_levels(levels, width, height, mapping, spacing, origin, "image")
}

/// A friction map whose every row is a 1-D friction profile (`haptex map
/// from-profile`): the profile sampled at x0 + i dx_mm (x0 its first x,
/// linear interpolation) over its whole span, repeated over ny rows from
/// y0_mm at dy_mm (a line texture extended along y).
///
/// profile: a haptex.Profile, a path to a profile CSV, or (x_mm, mu).
/// dx_mm, dy_mm: grid spacings in mm; ny: number of rows (2 .. 100000);
/// y0_mm: y of the first row in mm.
#[pyfunction]
#[pyo3(signature = (profile, *, dx_mm, dy_mm, ny, y0_mm = 0.0))]
pub fn map_from_profile(
    profile: &Bound<'_, PyAny>,
    dx_mm: f64,
    dy_mm: f64,
    ny: i64,
    y0_mm: f64,
) -> PyResult<FrictionMap> {
    let profile = profile_arg("profile", profile)?;
    let dx = positive("dx_mm", dx_mm)?;
    let dy = positive("dy_mm", dy_mm)?;
    if !(2..=100_000).contains(&ny) {
        return Err(input(format!("ny must be from 2 to 100000 rows, got {ny}")));
    }
    match map::FrictionMap::from_profile(&profile, dx, dy, ny as usize, y0_mm) {
        Ok(inner) => Ok(FrictionMap { inner }),
        Err(map::FromProfileError::TooManyColumns { columns, span_mm }) => Err(input(format!(
            "dx_mm {} gives {} columns over the profile's {} mm: too many",
            Num(dx),
            Num(columns),
            Num(span_mm)
        ))),
        Err(e) => Err(crate::errors::to_py(e)),
    }
}

/// What a voltage map holds: the electrovibration display's voltages
/// (with the method), or an ultrasonic or combined display's channels.
enum Drive {
    Electrovibration(map::VoltageMap, Option<Method>),
    Display(DisplayMap),
}

/// The drive of a display over a friction map's grid (`haptex map
/// voltage`): voltage_v (V RMS, at most U_max) and amplitude_um (the
/// ultrasonic plate's amplitude, um peak, at most a_max) as (ny, nx)
/// arrays, None for a channel the display does not have; `summary` (a
/// haptex.MapSummary) states the limits as fractions of the area.
///
/// VoltageMap.read(path) reads a voltage map file as `haptex map
/// sample-path --voltage-map` does (summary None).
#[pyclass(module = "haptex", name = "VoltageMap", frozen)]
pub struct VoltageMap {
    drive: Drive,
    /// What the file's comment of `map_sample_path` names the map by.
    source: String,
    /// What the map was designed for, when a device file designed it: the
    /// file (and its SHA-256) and the carrier. `write` puts them in the
    /// CSV's comments or the NPY's sidecar, as `haptex map voltage` does.
    #[pyo3(get)]
    notes: Vec<String>,
    #[pyo3(get)]
    voltage_v: Option<Py<PyArray2<f64>>>,
    #[pyo3(get)]
    amplitude_um: Option<Py<PyArray2<f64>>>,
    #[pyo3(get)]
    summary: Option<Py<PyAny>>,
}

#[pymethods]
impl VoltageMap {
    /// Reads a voltage map (.csv `x_mm,y_mm,voltage_v` or .npy with its
    /// sidecar); a map with plate amplitudes beside its voltages is refused
    /// as the command line refuses it.
    #[staticmethod]
    fn read(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let path = input_path("path", path)?;
        let v = py.detach(|| map::VoltageMap::read_file(&path)).or_raise()?;
        Self::new(py, Drive::Electrovibration(v, None), path.display().to_string(), Vec::new())
    }

    /// Writes the map as `haptex map voltage -o PATH` does: `.csv`, or
    /// `.npy` with its sidecar (the electrovibration display only; an
    /// ultrasonic or combined display's map is CSV); atomically.
    fn write(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        let format = MapFormat::of(&path).or_raise()?;
        match (&self.drive, format) {
            (Drive::Display(_), MapFormat::Npy) => Err(input(format!(
                "{}: an ultrasonic or combined display's map is written as CSV (one column per channel)",
                path.display()
            ))),
            (Drive::Electrovibration(v, _), MapFormat::Npy) => py
                .detach(|| {
                    let designed = (!self.notes.is_empty()).then(|| self.notes.join("; "));
                    map::write_npy_pair_designed(&path, &v.grid, &v.voltage_v, "voltage_v", Some(v.u_max_v), designed)
                })
                .or_raise(),
            (_, MapFormat::Csv) => py.detach(|| haptex_core::io::write_atomic(&path, |w| self.write_csv(w))).or_raise(),
        }
    }

    /// The CSV `write` writes to a .csv path, as a str.
    fn to_csv(&self) -> PyResult<String> {
        let mut bytes = Vec::new();
        self.write_csv(&mut bytes).or_raise()?;
        String::from_utf8(bytes).map_err(|e| input(format!("internal: {e}")))
    }

    /// x of each column in mm (nx values).
    #[getter]
    fn x_mm(&self, py: Python<'_>) -> Py<PyArray1<f64>> {
        x_axis(py, self.grid())
    }

    /// y of each row in mm (ny values).
    #[getter]
    fn y_mm(&self, py: Python<'_>) -> Py<PyArray1<f64>> {
        y_axis(py, self.grid())
    }

    /// (ny, nx).
    #[getter]
    fn shape(&self) -> (usize, usize) {
        (self.grid().ny, self.grid().nx)
    }

    /// The voltage in V RMS at each (x_mm[k], y_mm[k]), bilinear, the
    /// map's edge held beyond it (as `map_sample_path` samples it).
    fn sample<'py>(&self, py: Python<'py>, x_mm: Floats<'_>, y_mm: Floats<'_>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (grid, u) = self.voltages()?;
        let (x, y) = (to_vec(&x_mm), to_vec(&y_mm));
        if x.len() != y.len() {
            return Err(input(format!("x_mm has {} values, y_mm {}", x.len(), y.len())));
        }
        for (name, values) in [("x_mm", &x), ("y_mm", &y)] {
            if let Some(k) = ranges::POSITION_MM.first_outside(values) {
                return Err(input(format!("{name}[{k}]: {}", ranges::POSITION_MM.refusal(values[k]))));
            }
        }
        Ok(PyArray1::from_vec(py, x.iter().zip(&y).map(|(&x, &y)| grid.sample(u, x, y)).collect()))
    }

    fn __repr__(&self) -> String {
        let g = self.grid();
        let what = match &self.drive {
            Drive::Electrovibration(..) => "voltage_v",
            Drive::Display(d) if d.voltage_v.is_some() => "voltage_v, amplitude_um",
            Drive::Display(_) => "amplitude_um",
        };
        format!("VoltageMap({} x {} cells, {what})", g.nx, g.ny)
    }
}

impl VoltageMap {
    fn new(py: Python<'_>, drive: Drive, source: String, notes: Vec<String>) -> PyResult<Self> {
        let (grid, u, a) = match &drive {
            Drive::Electrovibration(v, _) => (v.grid, Some(v.voltage_v.clone()), None),
            Drive::Display(d) => (d.grid, d.voltage_v.clone(), Some(d.amplitude_um.clone())),
        };
        let summary = map_summary(py, &drive)?;
        Ok(Self {
            voltage_v: u.map(|u| array_2d(py, &grid, u).map(Bound::unbind)).transpose()?,
            amplitude_um: a.map(|a| array_2d(py, &grid, a).map(Bound::unbind)).transpose()?,
            summary,
            drive,
            source,
            notes,
        })
    }

    fn grid(&self) -> &MapGrid {
        match &self.drive {
            Drive::Electrovibration(v, _) => &v.grid,
            Drive::Display(d) => &d.grid,
        }
    }

    fn write_csv(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        for note in &self.notes {
            writeln!(w, "# {note}")?;
        }
        match &self.drive {
            Drive::Electrovibration(v, _) => v.write_csv(w),
            Drive::Display(d) => d.write_csv(w),
        }
    }

    /// The voltages a finger path samples: refused for a map with plate
    /// amplitudes, as the command line refuses its file.
    fn voltages(&self) -> PyResult<(&MapGrid, &[f64])> {
        match &self.drive {
            Drive::Electrovibration(v, _) => Ok((&v.grid, &v.voltage_v)),
            Drive::Display(_) => Err(input(format!(
                "{}: this map was designed for a combined or ultrasonic display: its voltages assume the plate \
                 amplitudes beside them, which a voltage-only reader cannot apply (two-channel playback over a map \
                 is not built); design it with display=\"electrovibration\"",
                self.source
            ))),
        }
    }
}

/// The haptex.MapSummary of a computed map (None for a map read from a
/// file, whose limits the file does not state).
fn map_summary(py: Python<'_>, drive: &Drive) -> PyResult<Option<Py<PyAny>>> {
    let kwargs = PyDict::new(py);
    match drive {
        Drive::Electrovibration(_, None) => return Ok(None),
        Drive::Electrovibration(v, Some(method)) => {
            let physical = *method == Method::Physical;
            kwargs.set_item("display", "electrovibration")?;
            kwargs.set_item("method", method.to_string())?;
            kwargs.set_item("shape", (v.grid.ny, v.grid.nx))?;
            kwargs.set_item("voltage_range_v", map::min_max(&v.voltage_v))?;
            kwargs.set_item("amplitude_range_um", py.None())?;
            kwargs.set_item("u_max_v", v.u_max_v)?;
            kwargs.set_item("a_max_um", py.None())?;
            kwargs.set_item("band_mu", py.None())?;
            kwargs.set_item("below_band_fraction", physical.then_some(v.not_renderable_fraction))?;
            kwargs.set_item("above_band_fraction", physical.then_some(v.clipped_fraction))?;
            kwargs.set_item("text", v.summary_lines(*method).join("\n"))?;
        }
        Drive::Display(d) => {
            kwargs.set_item("display", if d.voltage_v.is_some() { "combined" } else { "ultrasonic" })?;
            kwargs.set_item("method", Method::Physical.to_string())?;
            kwargs.set_item("shape", (d.grid.ny, d.grid.nx))?;
            kwargs.set_item("voltage_range_v", d.voltage_v.as_ref().map(|u| map::min_max(u)))?;
            kwargs.set_item("amplitude_range_um", map::min_max(&d.amplitude_um))?;
            kwargs.set_item("u_max_v", d.voltage_v.as_ref().map(|_| d.u_max_v))?;
            kwargs.set_item("a_max_um", d.a_max_um)?;
            kwargs.set_item("band_mu", (d.band_mu[0], d.band_mu[1]))?;
            kwargs.set_item("below_band_fraction", d.below_fraction)?;
            kwargs.set_item("above_band_fraction", d.above_fraction)?;
            kwargs.set_item("text", d.summary_line())?;
        }
    }
    Ok(Some(py.import("haptex._types")?.getattr("MapSummary")?.call((), Some(&kwargs))?.unbind()))
}

/// Designs the drive of a display cell by cell over a friction map
/// (`haptex map voltage`): eq. (8) ("physical": the friction force) or
/// eq. (9) ("normalized": min mu -> 0 V, max mu -> U_max) for the
/// electrovibration display; the ultrasonic and combined displays as
/// `haptex voltage` designs them along a profile.
///
/// friction_map: a haptex.FrictionMap or a path to a map file (.csv or
///   .npy). mu_hd, eps_sc, eps_i, d_sc_mm, d_i_mm, k_mm2_per_n (mm^2/N),
///   u_max (V RMS): the display (default: the paper's Fig. 2 constants,
///   U_max 100 V; the linear contact-area law). display:
///   "electrovibration", "ultrasonic" or "combined"; strategy ("split",
///   "bias", "weighted") and weight for the combined display;
///   ultrasonic_calibration: a CSV path or (amplitude_um,
///   relative_friction) arrays; a_max_um (um peak).
/// device: the display's device file (TOML, `haptex calibrate`): mu_HD,
///   the stack, k for the carrier (carrier, carrier_hz; default sine
///   1000 Hz), U_max (u_max may lower it) and the plate come from it; the
///   map's notes name the file and the carrier.
///
/// Returns a haptex.VoltageMap: no voltage above U_max, no amplitude above
/// a_max, in any cell. Raises haptex.InvalidInputError with the command
/// line's message for anything `haptex map voltage` refuses.
#[pyfunction]
#[pyo3(signature = (
    friction_map, *, method = "physical", mu_hd = None, eps_sc = None, eps_i = None, d_sc_mm = None,
    d_i_mm = None, k_mm2_per_n = None, u_max = None, display = "electrovibration", strategy = None,
    weight = None, ultrasonic_calibration = None, a_max_um = None, device = None, carrier = None, carrier_hz = None
))]
#[allow(clippy::too_many_arguments)]
pub fn map_voltage(
    py: Python<'_>,
    friction_map: &Bound<'_, PyAny>,
    method: &str,
    mu_hd: Option<f64>,
    eps_sc: Option<f64>,
    eps_i: Option<f64>,
    d_sc_mm: Option<f64>,
    d_i_mm: Option<f64>,
    k_mm2_per_n: Option<f64>,
    u_max: Option<f64>,
    display: &str,
    strategy: Option<&str>,
    weight: Option<f64>,
    ultrasonic_calibration: Option<&Bound<'_, PyAny>>,
    a_max_um: Option<f64>,
    device: Option<&Bound<'_, PyAny>>,
    carrier: Option<&str>,
    carrier_hz: Option<f64>,
) -> PyResult<VoltageMap> {
    let file = device_file(device)?;
    refuse_set_by_file(
        file.as_ref(),
        [mu_hd, eps_sc, eps_i, d_sc_mm, d_i_mm, k_mm2_per_n],
        &[(ultrasonic_calibration.is_some(), "ultrasonic_calibration")],
    )?;
    let (device, notes) = match &file {
        Some(file) => {
            let carrier = carrier_of(carrier, carrier_hz)?;
            let u_max = ranged_opt("u_max", ranges::U_MAX_V, u_max)?;
            (file.device(&carrier, u_max).or_raise()?, file.design_notes(&carrier))
        }
        None if carrier.is_some() || carrier_hz.is_some() => {
            return Err(input(
                "carrier and carrier_hz are the carrier a device file's design is played on: give device= with them",
            ));
        }
        None => {
            let args = DeviceArgs { mu_hd, eps_sc, eps_i, d_sc_mm, d_i_mm, k_mm2_per_n, area_exponent: None, u_max };
            (args.device(&ForceModel::Eq3)?, Vec::new())
        }
    };
    let method = match choice("method", method, &["physical", "normalized"])? {
        "physical" => Method::Physical,
        _ => Method::Normalized,
    };
    let choice = DisplayChoice { display, strategy, weight, ultrasonic_calibration, a_max_um, file: file.as_ref() };
    let kind = choice.kind()?;
    let owned;
    let friction = match friction_map.cast::<FrictionMap>() {
        Ok(m) => &m.get().inner,
        Err(_) => {
            if friction_map.extract::<std::path::PathBuf>().is_err() {
                return Err(input(format!(
                    "friction_map must be a haptex.FrictionMap or a path to a map file (.csv or .npy), got {}",
                    type_name(friction_map)
                )));
            }
            let path = input_path("friction_map", friction_map)?;
            owned = py.detach(|| map::FrictionMap::read_file(&path)).or_raise()?;
            &owned
        }
    };
    let drive = if kind == "electrovibration" {
        choice.refuse_plate_args()?;
        Drive::Electrovibration(py.detach(|| friction.voltages(&device, method)).or_raise()?, Some(method))
    } else {
        let (ultrasonic, strategy) = choice.plate(method)?;
        let channels = match strategy {
            Some(strategy) => Channels::Combined(&ultrasonic, strategy),
            None => Channels::Ultrasonic(&ultrasonic),
        };
        Drive::Display(py.detach(|| friction.display_channels(&device, channels)).or_raise()?)
    };
    VoltageMap::new(py, drive, "a haptex.map_voltage map".into(), notes)
}

/// The voltage along a finger path over a voltage map, at the path's own
/// samples (`haptex map sample-path`): t_s, x_mm, y_mm (the path) and
/// voltage_v (V RMS, bilinear on the map, its edge held beyond it), each a
/// 1-D array; `summary` is the line the command line prints.
#[pyclass(module = "haptex", name = "PathSamples", frozen)]
pub struct PathSamples {
    path: PlanarTrajectory,
    values: Vec<f64>,
    map_name: String,
    path_name: String,
    #[pyo3(get)]
    t_s: Py<PyArray1<f64>>,
    #[pyo3(get)]
    x_mm: Py<PyArray1<f64>>,
    #[pyo3(get)]
    y_mm: Py<PyArray1<f64>>,
    #[pyo3(get)]
    voltage_v: Py<PyArray1<f64>>,
    #[pyo3(get)]
    summary: String,
}

#[pymethods]
impl PathSamples {
    /// Writes `t_s,x_mm,y_mm,voltage_v` after a comment naming the map and
    /// the path, as `haptex map sample-path -o PATH` does; atomically.
    fn write_csv(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        py.detach(|| haptex_core::io::write_atomic(&path, |w| self.write(w))).or_raise()
    }

    /// The CSV `write_csv` writes, as a str.
    fn to_csv(&self) -> PyResult<String> {
        let mut bytes = Vec::new();
        self.write(&mut bytes).or_raise()?;
        String::from_utf8(bytes).map_err(|e| input(format!("internal: {e}")))
    }

    fn __len__(&self) -> usize {
        self.path.len()
    }

    fn __repr__(&self) -> String {
        format!("PathSamples({} samples)", self.path.len())
    }
}

impl PathSamples {
    fn write(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        self.path.write_sampled_voltage_csv(w, &self.map_name, &self.path_name, &self.values)
    }
}

/// Samples a voltage map along a finger path (`haptex map sample-path`).
///
/// voltage_map: a haptex.VoltageMap (of the electrovibration display) or
///   a path to a voltage map file (.csv or .npy).
/// trajectory: a path to a `t_s,x_mm,y_mm` CSV, or a tuple (t_s, x_mm,
///   y_mm) of 1-D arrays: times in s (strictly increasing), positions in
///   mm.
///
/// Returns a haptex.PathSamples; its write_csv writes the command line's
/// file (its comment names the map and the path as given).
#[pyfunction]
pub fn map_sample_path(
    py: Python<'_>,
    voltage_map: &Bound<'_, PyAny>,
    trajectory: &Bound<'_, PyAny>,
) -> PyResult<PathSamples> {
    let read;
    let map = match voltage_map.cast::<VoltageMap>() {
        Ok(m) => m.get(),
        Err(_) => {
            if voltage_map.extract::<std::path::PathBuf>().is_err() {
                return Err(input(format!(
                    "voltage_map must be a haptex.VoltageMap or a path to a voltage map file, got {}",
                    type_name(voltage_map)
                )));
            }
            read = VoltageMap::read(py, voltage_map)?;
            &read
        }
    };
    let (path, path_name) = if let Ok((t, x, y)) = trajectory.extract::<(Floats<'_>, Floats<'_>, Floats<'_>)>() {
        (PlanarTrajectory::new(to_vec(&t), to_vec(&x), to_vec(&y)).or_raise()?, "arrays (t_s, x_mm, y_mm)".into())
    } else if trajectory.extract::<std::path::PathBuf>().is_ok() {
        let file = input_path("trajectory", trajectory)?;
        let name = file.display().to_string();
        let reader = std::fs::File::open(&file).map_err(crate::errors::to_py)?;
        (PlanarTrajectory::read_csv(std::io::BufReader::new(reader), &name).or_raise()?, name)
    } else {
        return Err(input(format!(
            "trajectory must be a path to a t_s,x_mm,y_mm CSV or a tuple (t_s, x_mm, y_mm) of arrays, got {}",
            type_name(trajectory)
        )));
    };
    let (grid, u) = map.voltages()?;
    let values = py.detach(|| path.sample(grid, u));
    Ok(PathSamples {
        t_s: array(py, path.t_s().to_vec()),
        x_mm: array(py, path.x_mm().to_vec()),
        y_mm: array(py, path.y_mm().to_vec()),
        voltage_v: array(py, values.clone()),
        summary: path.sampled_voltage_summary(&values),
        map_name: map.source.clone(),
        path_name,
        path,
        values,
    })
}

/// A value that must be positive and finite (the command line's
/// `positive` flags).
fn positive(arg: &str, value: f64) -> PyResult<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(input(format!("{arg} must be a positive finite number, got {}", Num(value))))
    }
}

/// A 2-D array argument of real numbers as row-major float64 values and
/// its shape (ny, nx); other shapes and dtypes refused by name.
fn floats_2d(arg: &str, value: &Bound<'_, PyAny>) -> PyResult<(Vec<f64>, usize, usize)> {
    let py = value.py();
    let converted = py
        .import("numpy")?
        .call_method1("asarray", (value,))
        .map_err(|e| input(format!("{arg} must be a 2-D array of real numbers (ny, nx): {}", e.value(py))))?;
    let array = converted.cast::<numpy::PyUntypedArray>()?;
    let kind: String = array.dtype().getattr("kind")?.extract()?;
    if array.ndim() != 2 {
        return Err(input(format!(
            "{arg} must be a 2-D array (ny, nx): row j at y0_mm + j dy_mm, column i at x0_mm + i dx_mm; got a {}-D \
             array",
            array.ndim()
        )));
    }
    if !matches!(kind.as_str(), "f" | "i" | "u") {
        return Err(input(format!("{arg} must hold real numbers (a float or int array), got dtype {}", array.dtype())));
    }
    let (ny, nx) = (array.shape()[0], array.shape()[1]);
    let floats = converted.extract::<PyArrayLike2<'_, f64, AllowTypeChange>>()?;
    // C order (row-major) whatever the array's memory order.
    let view = floats.as_array();
    let values = match view.as_slice() {
        Some(slice) => slice.to_vec(),
        None => view.iter().copied().collect(),
    };
    Ok((values, ny, nx))
}

/// Row-major values over `grid` as a (ny, nx) NumPy array (no copy).
fn array_2d<'py>(py: Python<'py>, grid: &MapGrid, values: Vec<f64>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let array = Array2::from_shape_vec((grid.ny, grid.nx), values).map_err(|e| input(format!("internal: {e}")))?;
    Ok(PyArray2::from_owned_array(py, array))
}

fn x_axis(py: Python<'_>, grid: &MapGrid) -> Py<PyArray1<f64>> {
    array(py, (0..grid.nx).map(|i| grid.x(i)).collect())
}

fn y_axis(py: Python<'_>, grid: &MapGrid) -> Py<PyArray1<f64>> {
    array(py, (0..grid.ny).map(|j| grid.y(j)).collect())
}

/// A sine grating at an angle to the sliding direction (+x) as a friction
/// map (`haptex map grating`): each line y = const cuts a sine of period
/// period_mm / cos(angle), whose steady friction comes from one FE run of
/// that sine (source="fe", about a second, with the GIL released) or the
/// FE database's CAE estimate (source="cae", milliseconds; db a database
/// directory, default $HAPTEX_DB). Plane strain along the sliding
/// direction: the map depends on the direction (docs/maps.md).
///
/// period_mm: grating period (mm, across the ridges); amplitude_mm: sine
/// amplitude (mm); angle_deg: angle between the wave vector and x (-90 ..
/// 90 degrees; 0: ridges across the sliding direction); velocity: sliding
/// velocity in mm/s; nx, ny: columns and rows (2 .. 100000); dx_mm, dy_mm,
/// x0_mm, y0_mm: the grid (mm).
///
/// Raises haptex.ComputationError when the FE run fails.
#[pyfunction]
#[pyo3(signature = (
    *, period_mm, amplitude_mm, angle_deg, velocity = 20.0, nx, ny, dx_mm, dy_mm, x0_mm = 0.0, y0_mm = 0.0,
    source = "fe", db = None
))]
#[allow(clippy::too_many_arguments)]
pub fn map_grating(
    py: Python<'_>,
    period_mm: f64,
    amplitude_mm: f64,
    angle_deg: f64,
    velocity: f64,
    nx: i64,
    ny: i64,
    dx_mm: f64,
    dy_mm: f64,
    x0_mm: f64,
    y0_mm: f64,
    source: &str,
    db: Option<&Bound<'_, PyAny>>,
) -> PyResult<FrictionMap> {
    use haptex_fem::grating::{self, LineError, LineSource};
    let grating = map::Grating {
        period_mm: positive("period_mm", period_mm)?,
        amplitude_mm: positive("amplitude_mm", amplitude_mm)?,
        angle_deg,
        velocity_mm_s: positive("velocity", velocity)?,
    };
    for (name, n) in [("nx", nx), ("ny", ny)] {
        if !(2..=100_000).contains(&n) {
            return Err(input(format!("{name} must be from 2 to 100000, got {n}")));
        }
    }
    let grid = MapGrid {
        nx: nx as usize,
        ny: ny as usize,
        x0_mm,
        y0_mm,
        dx_mm: positive("dx_mm", dx_mm)?,
        dy_mm: positive("dy_mm", dy_mm)?,
    };
    grating.validate().or_raise()?;
    grid.validate("grating").or_raise()?;
    let source = match choice("source", source, &["fe", "cae"])? {
        "fe" => LineSource::Fe,
        _ => LineSource::Cae,
    };
    let dir = match db {
        Some(db) => crate::convert::path("db", db)?,
        None => match std::env::var_os("HAPTEX_DB") {
            Some(dir) => dir.into(),
            None if source == LineSource::Cae => {
                return Err(input("source=\"cae\" needs db= (an FE database directory) or $HAPTEX_DB"));
            }
            None => std::path::PathBuf::new(),
        },
    };
    let line = py.detach(|| -> Result<_, LineError> {
        Ok((grating::flat_mu(source, &dir)?, grating::line_friction(&grating, source, &dir)?))
    });
    let (flat, line) = match line {
        Ok(found) => found,
        Err(e @ LineError::OutsideDatabase { .. }) => return Err(input(format!("{e}: use source=\"fe\""))),
        Err(e @ (LineError::Fe { .. } | LineError::NoProfile)) => {
            return Err(raise(Kind::Computation, crate::errors::describe(&e)));
        }
        Err(e) => return Err(crate::errors::to_py(e)),
    };
    let line = line.as_ref().map(|(x, mu, x0)| (x.as_slice(), mu.as_slice(), *x0));
    let (inner, _) = py.detach(|| grating.friction_map(line, flat, grid)).or_raise()?;
    Ok(FrictionMap { inner })
}

/// What fills a region of `map_compose`: a number (mu), or a friction
/// profile (a haptex.Profile, a profile CSV path or (x_mm, mu)) tiled
/// along x.
fn region_fill(what: &str, value: &Bound<'_, PyAny>) -> PyResult<map::RegionFill> {
    if let Ok(text) = value.extract::<String>()
        && text.trim_start().starts_with("material:")
    {
        return Err(input(format!(
            "{what}: material fills (the texture library) are not bound in Python yet: give a number or a friction \
             profile, or use haptex map compose"
        )));
    }
    if !value.is_instance_of::<pyo3::types::PyBool>()
        && let Ok(mu) = value.extract::<f64>()
    {
        return ranges::MU.check(mu).map(map::RegionFill::Constant).map_err(|e| input(format!("{what}: {e}")));
    }
    profile_arg(what, value).map(map::RegionFill::Texture)
}

/// A friction map composed of regions (`haptex map compose`): a label
/// image whose gray levels name regions, or one base fill over a
/// rectangle, then polygons filled over it in order.
///
/// labels: a path to an 8-bit grayscale PNG or a 2-D uint8 array (row 0
///   the top row, at the largest y), one cell per pixel; regions: {gray
///   level: fill} for each level present. Without labels: base (a fill)
///   and size_mm (width, height in mm).
/// A fill: a number (mu) or a friction profile (a haptex.Profile, a
///   profile CSV path or (x_mm, mu)) tiled along x with its span as the
///   period.
/// polygons: [(vertices, fill), ...], vertices [(x_mm, y_mm), ...] (3 ..
///   10000, even-odd rule at the cell positions).
/// pixel_mm, pixel_mm_y (default pixel_mm): cell size in mm; x0_mm, y0_mm:
///   the bottom-left cell's position in mm.
#[pyfunction]
#[pyo3(signature = (
    labels = None, *, regions = None, base = None, size_mm = None, polygons = None, pixel_mm, pixel_mm_y = None,
    x0_mm = 0.0, y0_mm = 0.0
))]
#[allow(clippy::too_many_arguments)]
pub fn map_compose(
    py: Python<'_>,
    labels: Option<&Bound<'_, PyAny>>,
    regions: Option<&Bound<'_, PyDict>>,
    base: Option<&Bound<'_, PyAny>>,
    size_mm: Option<(f64, f64)>,
    polygons: Option<Polygons<'_>>,
    pixel_mm: f64,
    pixel_mm_y: Option<f64>,
    x0_mm: f64,
    y0_mm: f64,
) -> PyResult<FrictionMap> {
    let pixel_mm = positive("pixel_mm", pixel_mm)?;
    let spacing = (pixel_mm, pixel_mm_y.map(|v| positive("pixel_mm_y", v)).transpose()?.unwrap_or(pixel_mm));
    let origin = (x0_mm, y0_mm);
    let mut map = match (labels, base, size_mm) {
        (Some(labels), None, None) => {
            let regions = regions
                .filter(|r| !r.is_empty())
                .ok_or_else(|| input("a label image needs regions={level: fill} for each of its gray levels"))?;
            let mut fills: Vec<Option<map::RegionFill>> = vec![None; 256];
            for (level, fill) in regions.iter() {
                let what = format!("regions[{}]", level.repr()?);
                let level = level
                    .extract::<u8>()
                    .map_err(|_| input(format!("{what}: the level must be a gray level 0 .. 255")))?;
                fills[level as usize] = Some(region_fill(&what, &fill)?);
            }
            let image = label_image(py, labels)?;
            let fill = |level: u8| fills[level as usize].clone();
            image.0.compose(&fill, spacing, origin, &image.1).or_raise()?
        }
        (None, Some(base), Some((w, h))) => {
            if regions.is_some() {
                return Err(input("regions are the label image's: give labels, or drop regions"));
            }
            if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0) {
                return Err(input(format!(
                    "size_mm ({}, {}): expected (width, height) in mm, both positive",
                    Num(w),
                    Num(h)
                )));
            }
            let grid = MapGrid::covering(w, h, spacing, origin).ok_or_else(|| {
                input(format!(
                    "size_mm ({}, {}) at {} x {} mm cells: more than {} cells",
                    Num(w),
                    Num(h),
                    Num(spacing.0),
                    Num(spacing.1),
                    map::MAX_CELLS
                ))
            })?;
            grid.validate("size_mm").or_raise()?;
            let base = region_fill("base", base)?;
            let one = map::LabelImage { width: grid.nx, height: grid.ny, labels: vec![0; grid.len()] };
            one.compose(&|_| Some(base.clone()), spacing, origin, "base").or_raise()?
        }
        _ => {
            return Err(input(
                "give a label image with regions={level: fill}, or base=FILL with size_mm=(width, height)",
            ));
        }
    };
    for (k, (vertices, fill)) in polygons.unwrap_or_default().iter().enumerate() {
        let what = format!("polygons[{k}]");
        let fill = region_fill(&what, fill)?;
        map.fill_polygon(vertices, &fill, &what).or_raise()?;
    }
    Ok(FrictionMap { inner: map })
}

/// The polygons of `map_compose`: vertices (mm) and a fill each.
type Polygons<'py> = Vec<(Vec<(f64, f64)>, Bound<'py, PyAny>)>;

/// The label image of `map_compose` and its name for messages.
fn label_image(py: Python<'_>, labels: &Bound<'_, PyAny>) -> PyResult<(map::LabelImage, String)> {
    if let Ok(array) = labels.cast::<numpy::PyUntypedArray>() {
        let dtype = array.dtype().to_string();
        if array.ndim() != 2 || dtype != "uint8" {
            return Err(input(format!(
                "labels must be a 2-D uint8 array of gray levels (row 0 the top row), got a {}-D {dtype} array",
                array.ndim()
            )));
        }
        let levels = labels.cast::<PyArray2<u8>>()?.readonly();
        let view = levels.as_array();
        let (height, width) = view.dim();
        let image = map::LabelImage { width, height, labels: view.iter().copied().collect() };
        return Ok((image, "labels".into()));
    }
    if labels.extract::<std::path::PathBuf>().is_err() {
        return Err(input(format!(
            "labels must be a path to an 8-bit grayscale PNG or a 2-D uint8 array, got {}",
            type_name(labels)
        )));
    }
    let path = input_path("labels", labels)?;
    let name = path.display().to_string();
    let bytes = py.detach(|| haptex_core::io::read_file_bounded(&path, 256 << 20)).map_err(|e| {
        let kind = if matches!(e, BoundedReadError::Io(_)) { Kind::Os } else { Kind::Input };
        raise(kind, format!("{name}: {e}"))
    })?;
    let image = map::LabelImage::read_png(&bytes, &name).or_raise()?;
    Ok((image, name))
}
