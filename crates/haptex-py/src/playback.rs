//! `haptex.play`: a design and a finger trajectory to the drive signal of
//! a display, as `haptex play` renders it (haptex_core::signal::play, the
//! same functions the command line calls), and the WAV (with its scale
//! chunk and sidecar) or CSV it writes.

use std::path::PathBuf;

use haptex_core::arg_names::ArgNames;
use haptex_core::io::Table;
use haptex_core::ranges;
use haptex_core::signal::play::{PlayProfile, generate_trajectory, sidecar_source};
use haptex_core::signal::{
    AmplitudeCurve, DriveSignal, Extend, Limits, RenderSettings, VoltageCurve, WavFormat, WavOptions, check_full_scale,
    encode_wav, modulate_at_resonance, read_drive_wav, write_wav,
};
use haptex_core::trajectory::Trajectory;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use serde_json::json;

use crate::convert::{Floats, array, choice, input_path, json_object, ranged, ranged_opt, to_vec, type_name};
use crate::design::{Design, carrier_of, device_file};
use crate::errors::{OrRaise, input};

/// A rendered drive signal, one value per output sample, with the scale a
/// WAV of it carries.
///
/// t_s: time in s; x_mm: finger position in mm; envelope_v: the envelope
/// after the safety limits (V RMS, at most report["limits"]["u_max_v"]);
/// signal_v: the instantaneous drive in V (|signal_v| at most
/// report["peak_v"], itself at most volts_per_full_scale). For a display
/// profile with an amplitude_um column, channel 2: amplitude_um, the
/// ultrasonic amplitude envelope in um (0 .. a_max_um), or, with
/// plate_resonance_hz, displacement_um, the plate's displacement in um
/// (-a_max_um .. a_max_um); None otherwise.
#[pyclass(module = "haptex", name = "DriveSignal", frozen)]
pub struct Signal {
    signal: DriveSignal,
    source: serde_json::Value,
    csv_comment: Option<String>,
    /// Volts at the amplifier output for a full-scale WAV sample, V.
    #[pyo3(get)]
    volts_per_full_scale: f64,
    #[pyo3(get)]
    t_s: Py<PyArray1<f64>>,
    #[pyo3(get)]
    x_mm: Py<PyArray1<f64>>,
    #[pyo3(get)]
    envelope_v: Py<PyArray1<f64>>,
    #[pyo3(get)]
    signal_v: Py<PyArray1<f64>>,
    #[pyo3(get)]
    amplitude_um: Option<Py<PyArray1<f64>>>,
    #[pyo3(get)]
    displacement_um: Option<Py<PyArray1<f64>>>,
    /// What the render did, as the sidecar's `report` (a dict): sample
    /// rate, carrier, limits, envelope_max_v, peak_v (V), clip counts,
    /// warnings, and channel 2's `ultrasonic` record.
    #[pyo3(get)]
    report: Py<PyAny>,
}

fn wav_format(name: &str) -> PyResult<WavFormat> {
    Ok(match choice("wav_format", name, &["pcm16", "pcm24", "float32"])? {
        "pcm16" => WavFormat::Pcm16,
        "pcm24" => WavFormat::Pcm24,
        _ => WavFormat::Float32,
    })
}

impl Signal {
    fn write_csv_to(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        if let Some(c) = &self.csv_comment {
            writeln!(w, "# {c}")?;
        }
        self.signal.write_csv(w)
    }

    fn options(&self, wav_format_name: &str) -> PyResult<WavOptions> {
        Ok(WavOptions { format: wav_format(wav_format_name)?, volts_per_full_scale: self.volts_per_full_scale })
    }
}

#[pymethods]
impl Signal {
    /// Writes the signal as `haptex play -o PATH.wav` does: the WAV (mono,
    /// or 2 channels with channel 2) with its scale chunk, then its
    /// sidecar PATH.wav.json, each atomically, through the command line's
    /// writer (a peak beyond the full scale is refused, never clipped).
    /// wav_format: "pcm16", "pcm24" or "float32". Returns the sidecar as a
    /// dict. The sidecar's source.command says it came from Python.
    #[pyo3(signature = (path, *, wav_format = "pcm16"))]
    fn write_wav<'py>(
        &self,
        py: Python<'py>,
        path: &Bound<'_, PyAny>,
        wav_format: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let path = crate::convert::path("path", path)?;
        let options = self.options(wav_format)?;
        let sidecar = py.detach(|| write_wav(&path, &self.signal, &options, self.source.clone())).or_raise()?;
        json_object(py, &sidecar)
    }

    /// The bytes `write_wav` writes to the WAV file (scale chunk
    /// included), without writing anything.
    #[pyo3(signature = (*, wav_format = "pcm16"))]
    fn wav_bytes<'py>(&self, py: Python<'py>, wav_format: &str) -> PyResult<Bound<'py, PyBytes>> {
        let options = self.options(wav_format)?;
        let encoded = py.detach(|| encode_wav(&self.signal, &options, "the WAV")).or_raise()?;
        Ok(PyBytes::new(py, &encoded.bytes))
    }

    /// Writes the signal as `haptex play -o PATH.csv` does
    /// (`t_s,x_mm,envelope_v,signal_v[,amplitude_um|displacement_um]`, full
    /// precision), atomically.
    fn write_csv(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = crate::convert::path("path", path)?;
        py.detach(|| haptex_core::io::write_atomic(&path, |w| self.write_csv_to(w))).or_raise()
    }

    /// The CSV `write_csv` writes, as a str.
    fn to_csv(&self) -> PyResult<String> {
        let mut bytes = Vec::new();
        self.write_csv_to(&mut bytes).or_raise()?;
        String::from_utf8(bytes).map_err(|e| input(format!("internal: {e}")))
    }

    /// Output sample rate in Hz.
    #[getter]
    fn sample_rate_hz(&self) -> u32 {
        self.signal.report.sample_rate_hz
    }

    /// 1, or 2 with an ultrasonic channel.
    #[getter]
    fn channels(&self) -> u16 {
        if self.signal.amplitude_um.is_some() { 2 } else { 1 }
    }

    /// Channel 2's full scale and clamp a_max in um (None for one channel).
    #[getter]
    fn um_per_full_scale(&self) -> Option<f64> {
        self.signal.report.ultrasonic.as_ref().map(|u| u.a_max_um)
    }

    /// The envelope's limit U_max in V RMS.
    #[getter]
    fn u_max_v(&self) -> f64 {
        self.signal.report.limits.u_max_v
    }

    /// The drive's peak in V (the carrier's peak over RMS times the
    /// largest envelope), at most volts_per_full_scale.
    #[getter]
    fn peak_v(&self) -> f64 {
        self.signal.report.peak_v
    }

    /// The summary `haptex play` prints on stderr (before its `wrote` lines).
    #[getter]
    fn text(&self) -> String {
        self.signal.report.to_string()
    }

    fn __len__(&self) -> usize {
        self.signal.len()
    }

    fn __repr__(&self) -> String {
        let r = &self.signal.report;
        format!(
            "DriveSignal({} samples at {} Hz, {} channel{}, peak {:.3} V of {} V full scale)",
            r.n_samples,
            r.sample_rate_hz,
            self.channels(),
            if self.channels() == 2 { "s" } else { "" },
            r.peak_v,
            haptex_core::num::Num(self.volts_per_full_scale)
        )
    }
}

/// The design argument: a haptex.Design, a path to a voltage CSV, or
/// arrays (x_mm, voltage_v) or (x_mm, voltage_v, amplitude_um); with the
/// name the sidecar and messages give it.
fn design_arg(py: Python<'_>, value: &Bound<'_, PyAny>) -> PyResult<(PlayProfile, String)> {
    if let Ok(design) = value.cast::<Design>() {
        // The design as `haptex voltage -o` writes it, read back as
        // `haptex play --profile` reads it: the same curve, comments and
        // stated a_max, bit for bit (the CSV's numbers round-trip).
        let text = design.call_method0("to_csv")?.extract::<String>()?;
        let table = Table::read(text.as_bytes(), "haptex.Design").or_raise()?;
        return Ok((PlayProfile::from_table(&table).or_raise()?, "haptex.Design".into()));
    }
    if let Ok((x, u)) = value.extract::<(Floats<'_>, Floats<'_>)>() {
        let curve = VoltageCurve::new(to_vec(&x), to_vec(&u)).or_raise()?;
        return Ok((PlayProfile { curve, amplitude: None, comments: Vec::new() }, "arrays (x_mm, voltage_v)".into()));
    }
    if let Ok((x, u, a)) = value.extract::<(Floats<'_>, Floats<'_>, Floats<'_>)>() {
        let x = to_vec(&x);
        let curve = VoltageCurve::new(x.clone(), to_vec(&u)).or_raise()?;
        let amplitude = AmplitudeCurve::new(x, to_vec(&a)).or_raise()?;
        return Ok((
            PlayProfile { curve, amplitude: Some(amplitude), comments: Vec::new() },
            "arrays (x_mm, voltage_v, amplitude_um)".into(),
        ));
    }
    if value.extract::<PathBuf>().is_ok() {
        let path = input_path("design", value)?;
        let table = py.detach(|| Table::read_file(&path)).or_raise()?;
        return Ok((PlayProfile::from_table(&table).or_raise()?, path.display().to_string()));
    }
    Err(input(format!(
        "design must be a haptex.Design, a path to a voltage CSV, or arrays (x_mm, voltage_v[, amplitude_um]), got {}",
        type_name(value)
    )))
}

/// Plays a design along a finger trajectory: the drive signal
/// (`haptex play`).
///
/// design: a haptex.Design (haptex.voltage), a path to a voltage CSV
///   (`x_mm,mu,voltage_v[,amplitude_um]` as `haptex voltage` writes it, or
///   `x_mm,voltage_v`), or arrays (x_mm, voltage_v) in mm and V RMS, or
///   (x_mm, voltage_v, amplitude_um) with the amplitude in um (then give
///   a_max_um). A design with an amplitude channel plays on two channels.
/// trajectory: the finger, a path to a `t_s,x_mm` CSV or arrays (t_s,
///   x_mm) in s and mm (times strictly increasing); or generate one:
///   velocity (mm/s; the mean speed of each stroke with strokes), strokes
///   (N back-and-forth minimum-jerk strokes), from_mm and to_mm (default:
///   the design's ends).
/// carrier: "sine" (peak sqrt(2) U), "square" (peak U) or "none" (the
///   envelope itself); carrier_hz (Hz, default 1000, below half the sample
///   rate).
/// u_max (V RMS, default 100): envelopes above it are clamped (reported).
/// device: the display's device file (TOML, `haptex calibrate`): U_max is
///   the file's (u_max may lower it, never raise it), the carrier must be one it
///   gives the force for, and a design that names another device file
///   (its SHA-256) is refused; the signal's CSV comment and WAV sidecar
///   name the file.
/// slew_v_per_s (V/s): largest rate of change of the envelope (it then
///   also fades in from 0 V).
/// amp_range_v (V): the amplifier's peak output; a drive whose peak
///   exceeds it is refused.
/// volts_per_full_scale (V, default sqrt(2) x u_max): the amplifier output
///   of a full-scale WAV sample; a drive whose peak exceeds it is refused
///   here already, so the signal and its scale always go together.
/// a_max_um (um): channel 2's clamp and full scale (default: the a_max
///   the design states; above it refused).
/// outside: "hold", "zero" or "repeat": the voltage where the finger is
///   outside the design.
/// plate_resonance_hz (Hz): channel 2 as the plate's displacement on its
///   resonance (at most 0.45 x sample_rate).
/// sample_rate (Hz, 1000 .. 768000, default 48000).
///
/// Returns a haptex.DriveSignal (arrays, report, write_wav, write_csv).
/// Raises haptex.InvalidInputError for what `haptex play` refuses, with
/// its message.
#[pyfunction]
#[pyo3(signature = (
    design, *, trajectory = None, velocity = None, strokes = None, from_mm = None, to_mm = None,
    carrier = "sine", carrier_hz = None, a_max_um = None, u_max = None, slew_v_per_s = None, amp_range_v = None,
    volts_per_full_scale = None, outside = "hold", plate_resonance_hz = None, sample_rate = 48000, device = None
))]
#[allow(clippy::too_many_arguments)]
pub fn play(
    py: Python<'_>,
    design: &Bound<'_, PyAny>,
    trajectory: Option<&Bound<'_, PyAny>>,
    velocity: Option<f64>,
    strokes: Option<u32>,
    from_mm: Option<f64>,
    to_mm: Option<f64>,
    carrier: &str,
    carrier_hz: Option<f64>,
    a_max_um: Option<f64>,
    u_max: Option<f64>,
    slew_v_per_s: Option<f64>,
    amp_range_v: Option<f64>,
    volts_per_full_scale: Option<f64>,
    outside: &str,
    plate_resonance_hz: Option<f64>,
    sample_rate: u32,
    device: Option<&Bound<'_, PyAny>>,
) -> PyResult<Signal> {
    // The flags' own checks, as the command line's parser makes them.
    if !(1000..=768_000).contains(&sample_rate) {
        return Err(input(format!("sample_rate must be 1000 .. 768000 Hz, got {sample_rate}")));
    }
    if let Some(n) = strokes
        && !(1..=100_000).contains(&n)
    {
        return Err(input(format!("strokes must be 1 .. 100000, got {n}")));
    }
    if let Some(v) = velocity
        && !(v.is_finite() && v > 0.0)
    {
        return Err(input(format!("velocity must be a positive finite number, got {v}")));
    }
    for (given, name) in [(strokes.is_some(), "strokes"), (from_mm.is_some(), "from_mm"), (to_mm.is_some(), "to_mm")] {
        if given && velocity.is_none() {
            return Err(input(format!("{name} is for a generated trajectory: give velocity= too")));
        }
    }
    match (trajectory.is_some(), velocity.is_some()) {
        (true, true) => return Err(input("give trajectory= or velocity=, not both")),
        (false, false) => {
            return Err(input("give trajectory= (t_s, x_mm), or velocity= (mm/s) to generate a trajectory"));
        }
        _ => {}
    }
    let carrier = carrier_of(Some(carrier), carrier_hz)?;
    let a_max_um = ranged_opt("a_max_um", ranges::A_MAX_UM, a_max_um)?;
    let u_max = ranged_opt("u_max", ranges::U_MAX_V, u_max)?;
    let slew_v_per_s = ranged_opt("slew_v_per_s", ranges::SLEW_V_PER_S, slew_v_per_s)?;
    let amp_range_v = ranged_opt("amp_range_v", ranges::AMPLIFIER_RANGE_V, amp_range_v)?;
    let plate_resonance_hz = ranged_opt("plate_resonance_hz", ranges::PLATE_RESONANCE_HZ, plate_resonance_hz)?;
    let extend = match choice("outside", outside, &["hold", "zero", "repeat"])? {
        "hold" => Extend::Hold,
        "zero" => Extend::Zero,
        _ => Extend::Repeat,
    };

    let file = device_file(device)?;
    let (design, name) = design_arg(py, design)?;
    // On a device file's display: U_max the file's (or lower), a carrier it
    // gives the force for, and a design made with this file if it says so.
    let u_max = match &file {
        Some(file) => file.play_u_max(&carrier, u_max, &design.comments, &name).or_raise()?,
        None => u_max.unwrap_or(Limits::DEFAULT.u_max_v),
    };
    let volts_per_full_scale = ranged(
        "volts_per_full_scale",
        ranges::VOLTS_PER_FULL_SCALE,
        volts_per_full_scale.unwrap_or(std::f64::consts::SQRT_2 * u_max),
    )?;
    let a_max_um = design.a_max_um(&name, a_max_um, &ArgNames::PYTHON).or_raise()?;
    let (trajectory, trajectory_source) = match (trajectory, velocity) {
        (Some(value), _) => {
            if let Ok((t, x)) = value.extract::<(Floats<'_>, Floats<'_>)>() {
                (Trajectory::new(to_vec(&t), to_vec(&x)).or_raise()?, json!({ "arrays": "(t_s, x_mm)" }))
            } else if value.extract::<PathBuf>().is_ok() {
                let path = input_path("trajectory", value)?;
                let t = py.detach(|| Trajectory::read_csv_file(&path)).or_raise()?;
                (t, json!({ "file": path.display().to_string() }))
            } else {
                return Err(input(format!(
                    "trajectory must be a path to a t_s,x_mm CSV or arrays (t_s, x_mm), got {}",
                    type_name(value)
                )));
            }
        }
        (None, Some(speed)) => generate_trajectory(&design.curve, speed, strokes, from_mm, to_mm).or_raise()?,
        (None, None) => unreachable!("refused above"),
    };
    let settings = RenderSettings {
        sample_rate_hz: sample_rate,
        carrier,
        limits: Limits { u_max_v: u_max, slew_v_per_s, amplifier_range_v: amp_range_v },
        extend,
    };
    design.check_carrier(&settings.carrier, &name, &ArgNames::PYTHON).or_raise()?;
    let signal = py
        .detach(|| {
            let mut signal = design.render(&trajectory, &settings, a_max_um)?;
            if let Some(f) = plate_resonance_hz {
                modulate_at_resonance(&mut signal, f)?;
            }
            // The scale goes with the samples: a peak beyond it is refused
            // now, not only when a WAV is written.
            check_full_scale(&signal.report, volts_per_full_scale)?;
            Ok::<_, haptex_core::signal::SignalError>(signal)
        })
        .or_raise()?;

    // The device file played on, or the one the design says it was made with.
    let stated = design.comments.iter().find(|c| c.contains(DEVICE_SHA256_MARK)).cloned();
    let mut source = sidecar_source(&name, &trajectory_source, "haptex.play (Python)");
    let csv_comment = match (&file, &stated) {
        (Some(file), _) => {
            source["device_file"] = file.provenance();
            Some(format!("played on the display of {}", file.comment()))
        }
        (None, Some(stated)) => {
            source["design_device_file"] = json!(stated);
            Some(format!("the design says: {stated}"))
        }
        (None, None) => None,
    };
    let report = json_object(py, &signal.report)?.unbind();
    let modulated = signal.report.ultrasonic.as_ref().is_some_and(|u| u.resonance_hz.is_some());
    let channel_2 = signal.amplitude_um.clone().map(|a| array(py, a));
    let (amplitude_um, displacement_um) = if modulated { (None, channel_2) } else { (channel_2, None) };
    Ok(Signal {
        t_s: array(py, signal.times_s()),
        x_mm: array(py, signal.x_mm.clone()),
        envelope_v: array(py, signal.envelope_v.clone()),
        signal_v: array(py, signal.signal_v.clone()),
        amplitude_um,
        displacement_um,
        report,
        volts_per_full_scale,
        csv_comment,
        source,
        signal,
    })
}

/// Reads a drive-signal WAV written by haptex and checks it, as `haptex
/// play --check WAV` does: the fmt chunk and samples against the scale
/// chunk inside it, every sample of every channel finite and within full
/// scale, and the sidecar PATH.json (if present) against both. Raises
/// haptex.InvalidInputError on any mismatch (with the command line's
/// message), haptex.HaptexOSError when the file cannot be read.
///
/// Returns a dict: volts (channel 1 in V at the amplifier output),
/// amplitude_um (channel 2 in um, or None), scale (the scale chunk: sample
/// format, volts_per_full_scale, sample rate, hashes, channel_2), sidecar
/// (the sidecar, or None).
#[pyfunction]
pub fn read_wav<'py>(py: Python<'py>, path: &Bound<'_, PyAny>) -> PyResult<Bound<'py, PyDict>> {
    let path = input_path("path", path)?;
    let wav = py.detach(|| read_drive_wav(&path)).or_raise()?;
    let out = PyDict::new(py);
    out.set_item("volts", array(py, wav.volts))?;
    out.set_item("amplitude_um", wav.amplitude_um.map(|a| array(py, a)))?;
    out.set_item("scale", json_object(py, &wav.scale)?)?;
    out.set_item("sidecar", wav.sidecar.as_ref().map(|s| json_object(py, s)).transpose()?)?;
    Ok(out)
}

/// What a design made with a device file says of it (`haptex voltage
/// --device`'s comment).
const DEVICE_SHA256_MARK: &str = haptex_core::signal::play::DEVICE_SHA256_MARK;
