//! Drive signals: from a voltage profile U(x) and a finger trajectory x(t)
//! to the time signal an electrovibration display plays (offline).
//!
//! The chain, per output sample n at t = t0 + n / fs:
//!
//! 1. position x(t) from the trajectory (linear between its samples);
//! 2. requested envelope U(x(t)) from the voltage curve (RMS volts,
//!    linear between samples, [`Extend`] outside its span);
//! 3. safety: clamp at U_max, then the optional slew limit
//!    ([`EnvelopeLimiter`]);
//! 4. the drive s(t) = U(t) c(f t), c the unit-RMS carrier
//!    ([`Carrier`]): a sine of peak sqrt(2) U, a square of peak U, or
//!    the envelope itself;
//! 5. refusal if the peak (carrier amplitude) exceeds the amplifier range.
//!
//! The real-time counterpart is [`crate::realtime`]; WAV output is
//! [`write_wav`].

mod carrier;
mod curve;
pub mod play;
mod safety;
mod wav;

use std::fmt;
use std::io::Write;

use serde::{Deserialize, Serialize};

pub(crate) use carrier::sin_turns;
pub use carrier::{Carrier, CarrierShape};
pub use curve::{AmplitudeCurve, Extend, VoltageCurve};
pub use safety::{ClipReport, EnvelopeLimiter, Limits};
pub use wav::{
    AmplitudeScale, DriveWav, EncodedWav, FmtFields, SCALE_CHUNK_ID, SCALE_CHUNK_VERSION, ScaleChunk, WavFormat,
    WavOptions, WavSidecar, check_full_scale, check_volts_per_full_scale, decode_drive_wav, decode_drive_wav_channels,
    encode_wav, read_drive_wav, sidecar_path, write_wav,
};

use crate::io::{WriteError, write_csv_row};
use crate::num::{Fixed, Num};
use crate::plot::{Figure, Panel};
use crate::trajectory::Trajectory;

/// Most samples an offline render may have: 3e7 (10.4 min at 48 kHz; about
/// 1 GB of working memory). Longer drives belong to the real-time renderer.
pub const MAX_SAMPLES: usize = 30_000_000;

/// The lowest sample rate haptex renders, and reads a drive WAV at.
pub const MIN_SAMPLE_RATE_HZ: u32 = 100;

/// A drive signal cannot be rendered or written.
#[derive(Debug, thiserror::Error)]
pub enum SignalError {
    #[error("{0}")]
    Settings(String),
    #[error(
        "{} s at {sample_rate_hz} Hz is {} samples, more than the {MAX_SAMPLES} an offline render allows (is the \
         trajectory's t_s in seconds?)",
        Num(*duration_s),
        Num(*n_samples)
    )]
    TooLong { duration_s: f64, sample_rate_hz: u32, n_samples: f64 },
    #[error(
        "refused: the drive's peak {} V (first at t = {} s) exceeds the amplifier range {} V; lower U_max to {} V \
         RMS or less, or declare the amplifier's real range",
        Fixed(*amplitude_v, 3),
        Fixed(*t_s, 6),
        Num(*range_v),
        Fixed(*max_u_v, 3)
    )]
    ExceedsAmplifierRange { amplitude_v: f64, range_v: f64, t_s: f64, max_u_v: f64 },
    #[error(
        "refused: the drive's peak {} V exceeds the WAV full scale of {} V (volts per full scale); raise it to at \
         least {} V or lower U_max",
        Fixed(*amplitude_v, 3),
        Num(*volts_per_full_scale),
        Fixed(*amplitude_v, 3)
    )]
    ExceedsFullScale { amplitude_v: f64, volts_per_full_scale: f64 },
    #[error("cannot encode the WAV file {path}: {message}")]
    Wav { path: String, message: String },
    /// A drive WAV is refused by its reader ([`read_drive_wav`]).
    #[error("cannot read the WAV file {path}: {message}")]
    ReadWav { path: String, message: String },
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// How to render a drive signal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RenderSettings {
    /// Output sample rate in Hz.
    pub sample_rate_hz: u32,
    pub carrier: Carrier,
    pub limits: Limits,
    /// The voltage outside the profile's span.
    pub extend: Extend,
}

impl RenderSettings {
    /// 48 kHz, a 1 kHz sine carrier, U_max = 100 V, held ends.
    pub const DEFAULT: Self =
        Self { sample_rate_hz: 48_000, carrier: Carrier::DEFAULT, limits: Limits::DEFAULT, extend: Extend::Hold };

    /// Checks the sample rate, carrier and limits.
    pub fn check(&self) -> Result<(), SignalError> {
        if self.sample_rate_hz < MIN_SAMPLE_RATE_HZ {
            return Err(SignalError::Settings(format!(
                "sample rate {} Hz is below {MIN_SAMPLE_RATE_HZ} Hz",
                self.sample_rate_hz
            )));
        }
        self.carrier.check(self.sample_rate_hz as f64).map_err(SignalError::Settings)?;
        self.limits.check().map_err(SignalError::Settings)
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What a render produced and what the safety limits did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SignalReport {
    pub sample_rate_hz: u32,
    pub n_samples: usize,
    /// Time of the first sample (the trajectory's first time) in s.
    pub start_s: f64,
    pub duration_s: f64,
    pub carrier: Carrier,
    pub limits: Limits,
    pub extend: Extend,
    /// Largest envelope after the limits, V RMS.
    pub envelope_max_v: f64,
    /// Peak of the drive: peak/RMS of the carrier times the largest
    /// envelope, in V. This is the analogue peak a DAC reconstructs; the
    /// largest sample can be slightly lower.
    pub peak_v: f64,
    /// Largest |sample| in V.
    pub sample_peak_v: f64,
    /// RMS of the whole drive signal in V.
    pub signal_rms_v: f64,
    /// Fraction of samples where the finger is outside the profile's span.
    pub outside_fraction: f64,
    pub clip: ClipReport,
    pub warnings: Vec<String>,
    /// Channel 2, the ultrasonic amplitude envelope, when the signal has
    /// one (absent from a one-channel signal's JSON).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ultrasonic: Option<UltrasonicReport>,
}

/// What the ultrasonic channel (channel 2) holds and what its limit did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UltrasonicReport {
    /// The clamp: no sample of channel 2 exceeds it, um (peak vibration
    /// amplitude).
    pub a_max_um: f64,
    /// Largest amplitude after the clamp, um.
    pub amplitude_max_um: f64,
    /// Largest amplitude the profile asked for, um.
    pub requested_max_um: f64,
    /// Samples clamped at a_max, and their fraction.
    pub clamped_samples: usize,
    pub clamped_fraction: f64,
    /// What channel 2 is: the amplitude envelope itself (no carrier), a
    /// control signal for the resonant driver; or, with `resonance_hz`,
    /// the plate's displacement a(t) sin(2 pi f_r t).
    pub convention: String,
    /// The plate's resonance f_r when channel 2 carries the modulated
    /// carrier ([`modulate_at_resonance`]); absent for the envelope.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resonance_hz: Option<f64>,
}

impl fmt::Display for SignalReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "signal: {} samples at {} Hz, {:.4} s from t = {} s",
            self.n_samples,
            self.sample_rate_hz,
            self.duration_s,
            Num(self.start_s)
        )?;
        match self.carrier.shape {
            CarrierShape::None => writeln!(f, "carrier: none (the drive is the RMS envelope itself)")?,
            shape => writeln!(
                f,
                "carrier: {} at {} Hz (peak = {:.4} x RMS)",
                format!("{shape:?}").to_lowercase(),
                Num(self.carrier.frequency_hz),
                self.carrier.peak_per_rms()
            )?,
        }
        writeln!(
            f,
            "envelope (RMS): max {:.3} V; drive peak {:.3} V, RMS {:.3} V",
            self.envelope_max_v, self.peak_v, self.signal_rms_v
        )?;
        let c = &self.clip;
        writeln!(
            f,
            "clamped at U_max = {} V: {} samples ({:.2}%), largest request {:.3} V",
            Num(self.limits.u_max_v),
            c.clamped_samples,
            100.0 * c.clamped_fraction,
            c.requested_max_v
        )?;
        if let Some(slew) = self.limits.slew_v_per_s {
            writeln!(
                f,
                "slew limit {} V/s: {} samples changed ({:.2}%), largest change {:.3} V",
                Num(slew),
                c.slew_limited_samples,
                100.0 * c.slew_limited_fraction,
                c.slew_max_deviation_v
            )?;
        }
        if let Some(us) = &self.ultrasonic {
            let what = match us.resonance_hz {
                None => "ultrasonic amplitude envelope, um, no carrier".to_string(),
                Some(f) => format!("ultrasonic plate displacement, um, on its resonance {} Hz", Num(f)),
            };
            writeln!(
                f,
                "channel 2 ({what}): max envelope {:.4} um; clamped at a_max = {} um: {} samples ({:.2}%), largest \
                 request {:.4} um",
                us.amplitude_max_um,
                us.a_max_um,
                us.clamped_samples,
                100.0 * us.clamped_fraction,
                us.requested_max_um
            )?;
        }
        for warning in &self.warnings {
            writeln!(f, "warning: {warning}")?;
        }
        Ok(())
    }
}

/// A rendered drive signal, one value per output sample.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveSignal {
    /// Finger position in mm.
    pub x_mm: Vec<f64>,
    /// Envelope after the safety limits, V RMS.
    pub envelope_v: Vec<f64>,
    /// Instantaneous drive voltage in V.
    pub signal_v: Vec<f64>,
    /// Channel 2: the ultrasonic vibration amplitude in um (peak) at each
    /// sample, after the a_max clamp; `None` for an electrovibration-only
    /// signal.
    pub amplitude_um: Option<Vec<f64>>,
    pub report: SignalReport,
}

impl DriveSignal {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.signal_v.len()
    }

    /// True if there are no samples (never, for a rendered signal).
    pub fn is_empty(&self) -> bool {
        self.signal_v.is_empty()
    }

    /// Time of sample `i` in s.
    pub fn t_s(&self, i: usize) -> f64 {
        self.report.start_s + i as f64 / self.report.sample_rate_hz as f64
    }

    /// Times of all samples in s.
    pub fn times_s(&self) -> Vec<f64> {
        (0..self.len()).map(|i| self.t_s(i)).collect()
    }

    /// Writes `t_s,x_mm,envelope_v,signal_v` CSV after a comment line with
    /// the conventions.
    pub fn write_csv(&self, w: &mut dyn Write) -> std::io::Result<()> {
        let r = &self.report;
        writeln!(
            w,
            "# haptex drive signal, {} Hz, carrier {} {} Hz: envelope_v is RMS (V), signal_v the instantaneous drive (V), peak = {} x envelope",
            r.sample_rate_hz,
            format!("{:?}", r.carrier.shape).to_lowercase(),
            r.carrier.frequency_hz,
            r.carrier.peak_per_rms()
        )?;
        let Some(amplitude_um) = &self.amplitude_um else {
            w.write_all(b"t_s,x_mm,envelope_v,signal_v\n")?;
            for i in 0..self.len() {
                write_csv_row(w, &[self.t_s(i), self.x_mm[i], self.envelope_v[i], self.signal_v[i]])?;
            }
            return Ok(());
        };
        let a_max = self.report.ultrasonic.as_ref().map_or(f64::NAN, |u| u.a_max_um);
        // A modulated channel 2 is a displacement, not an amplitude: its
        // column is named for it, so that no reader takes it for a(t).
        match self.report.ultrasonic.as_ref().and_then(|u| u.resonance_hz) {
            None => {
                writeln!(
                    w,
                    "# amplitude_um is channel 2, the ultrasonic vibration amplitude envelope (um, peak; no carrier: the envelope is the channel's signal), at most a_max = {a_max} um"
                )?;
                w.write_all(b"t_s,x_mm,envelope_v,signal_v,amplitude_um\n")?;
            }
            Some(f) => {
                writeln!(
                    w,
                    "# displacement_um is channel 2, the ultrasonic plate's displacement a(t) sin(2 pi f_r t) (um) on its resonance f_r = {} Hz, |displacement| at most a_max = {a_max} um",
                    Num(f)
                )?;
                w.write_all(b"t_s,x_mm,envelope_v,signal_v,displacement_um\n")?;
            }
        }
        for (i, &a) in amplitude_um.iter().enumerate() {
            write_csv_row(w, &[self.t_s(i), self.x_mm[i], self.envelope_v[i], self.signal_v[i], a])?;
        }
        Ok(())
    }

    /// A three-panel figure: finger position, envelope (with U_max) and
    /// drive; a fourth with channel 2's amplitude (and a_max) when there is one.
    pub fn figure(&self, title: &str) -> Figure {
        let t = self.times_s();
        let u_max = self.report.limits.u_max_v;
        let ends = [t[0], t[t.len() - 1]];
        let figure = Figure::new(title)
            .panel(Panel::new("t (s)", "x (mm)").title("finger trajectory").line("x(t)", &t, &self.x_mm))
            .panel(
                Panel::new("t (s)", "U (V RMS)")
                    .title("envelope U(x(t)) after the safety limits")
                    .line("U(t)", &t, &self.envelope_v)
                    .series(crate::plot::Series::line("U_max", &ends, &[u_max, u_max]).color((150, 150, 150))),
            )
            .panel(Panel::new("t (s)", "s (V)").title("drive signal").line("s(t)", &t, &self.signal_v));
        match (&self.amplitude_um, &self.report.ultrasonic) {
            (Some(a), Some(us)) => figure.panel(
                Panel::new("t (s)", "a (um)")
                    .title(if us.resonance_hz.is_some() {
                        "channel 2: plate displacement a(x(t)) sin(2 pi f_r t), a after the a_max clamp"
                    } else {
                        "channel 2: ultrasonic amplitude a(x(t)) after the a_max clamp"
                    })
                    .line(if us.resonance_hz.is_some() { "displacement" } else { "a(t)" }, &t, a)
                    .series(
                        crate::plot::Series::line("a_max", &ends, &[us.a_max_um, us.a_max_um]).color((150, 150, 150)),
                    ),
            ),
            _ => figure,
        }
    }
}

/// Renders the drive signal of `curve` along `trajectory`, from the
/// trajectory's first to its last time, with the safety limits of
/// `settings`. Refuses (error) a signal whose peak exceeds the amplifier
/// range; clamps and slew limits are applied and reported.
pub fn render(
    curve: &VoltageCurve,
    trajectory: &Trajectory,
    settings: &RenderSettings,
) -> Result<DriveSignal, SignalError> {
    settings.check()?;
    let fs = settings.sample_rate_hz as f64;
    let n = sample_count(trajectory.duration_s(), settings)?;
    let mut x_mm = crate::buffer::zeroed_f64(n);
    trajectory.positions_into(trajectory.start_s(), 1.0 / fs, &mut x_mm);
    // In passes over the samples, each a simple loop: the requested
    // envelope U(x(t)) (walking the profile with the finger), the safety
    // limits in place (a serial chain only with a slew limit), the drive
    // (vectorized: a polynomial sine), the sums.
    let mut envelope_v = crate::buffer::zeroed_f64(n);
    curve.voltages_along(&x_mm, settings.extend, &mut envelope_v);
    let outside = x_mm.iter().map(|&x| usize::from(!curve.contains(x))).sum::<usize>();
    let outside_warning = (outside > 0).then(|| {
        let (x0, x1) = curve.span_mm();
        let what = match settings.extend {
            Extend::Hold => "the end voltages are held",
            Extend::Zero => "U = 0 V there",
            Extend::Repeat => "the profile repeats",
        };
        format!(
            "the finger is outside the profile ({} .. {} mm) for {:.2}% of the time: {what}",
            Num(x0),
            Num(x1),
            100.0 * outside as f64 / n as f64
        )
    });
    finish(x_mm, envelope_v, trajectory.start_s(), settings, outside, outside_warning)
}

/// A map holds its edge voltages beyond it: any other extension (zero,
/// repeat: a profile's) is refused rather than silently ignored.
pub fn check_map_extend(extend: Extend) -> Result<(), SignalError> {
    if extend == Extend::Hold {
        return Ok(());
    }
    let name = format!("{extend:?}").to_lowercase();
    Err(SignalError::Settings(format!(
        "a map holds its edge voltages beyond it: extending with {name} (--outside {name}) is for a profile"
    )))
}

/// Renders the drive signal of a voltage map along a finger path in the
/// plane: the envelope is the map's voltage at the path's position (both
/// coordinates linear between the path's samples, the map bilinear, its
/// edge held beyond it) at each output sample; the safety limits, the
/// carrier and the report are [`render`]'s. The signal's `x_mm` holds the
/// x positions.
pub fn render_map(
    map: &crate::map::VoltageMap,
    path: &crate::planar::PlanarTrajectory,
    settings: &RenderSettings,
) -> Result<DriveSignal, SignalError> {
    settings.check()?;
    check_map_extend(settings.extend)?;
    let fs = settings.sample_rate_hz as f64;
    let t = path.t_s();
    let start = t[0];
    let n = sample_count(t[t.len() - 1] - start, settings)?;
    let mut x_mm = crate::buffer::zeroed_f64(n);
    let mut y_mm = crate::buffer::zeroed_f64(n);
    path.positions_into(start, 1.0 / fs, &mut x_mm, &mut y_mm);
    let mut envelope_v = crate::buffer::zeroed_f64(n);
    for ((u, &x), &y) in envelope_v.iter_mut().zip(&x_mm).zip(&y_mm) {
        *u = map.sample(x, y);
    }
    let g = &map.grid;
    let outside = x_mm.iter().zip(&y_mm).filter(|&(&x, &y)| !g.contains(x, y)).count();
    let (x_hi, y_hi) = (g.x(g.nx - 1), g.y(g.ny - 1));
    let outside_warning = (outside > 0).then(|| {
        format!(
            "the finger is outside the map (x {} .. {} mm, y {} .. {} mm) for {:.2}% of the time: the edge \
             voltages are held",
            crate::num::Num(g.x0_mm),
            crate::num::Num(x_hi),
            crate::num::Num(g.y0_mm),
            crate::num::Num(y_hi),
            100.0 * outside as f64 / n as f64
        )
    });
    finish(x_mm, envelope_v, start, settings, outside, outside_warning)
}

/// The number of output samples over `duration_s` (the first and last
/// instants included), refused beyond [`MAX_SAMPLES`].
fn sample_count(duration_s: f64, settings: &RenderSettings) -> Result<usize, SignalError> {
    let n_float = (duration_s * settings.sample_rate_hz as f64).floor() + 1.0;
    if n_float > MAX_SAMPLES as f64 {
        return Err(SignalError::TooLong { duration_s, sample_rate_hz: settings.sample_rate_hz, n_samples: n_float });
    }
    Ok(n_float as usize)
}

/// The safety limits on a requested envelope, the carrier, and the report:
/// what every renderer shares once it has the envelope U(t).
fn finish(
    x_mm: Vec<f64>,
    mut envelope_v: Vec<f64>,
    start_s: f64,
    settings: &RenderSettings,
    outside: usize,
    outside_warning: Option<String>,
) -> Result<DriveSignal, SignalError> {
    let n = envelope_v.len();
    let fs = settings.sample_rate_hz as f64;
    let carrier = settings.carrier;
    let cycles_per_sample = carrier.frequency_hz / fs;
    let mut limiter = EnvelopeLimiter::new(&settings.limits, fs);
    let mut clip = ClipReport::default();
    let u_max = settings.limits.u_max_v;
    for u in envelope_v.iter_mut() {
        let requested = *u;
        clip.requested_max_v = clip.requested_max_v.max(requested);
        let clamped = requested.min(u_max);
        clip.clamped_samples += usize::from(requested > u_max);
        let limited = limiter.apply(requested);
        if limited != clamped {
            clip.slew_limited_samples += 1;
            clip.slew_max_deviation_v = clip.slew_max_deviation_v.max((limited - clamped).abs());
        }
        *u = limited;
    }
    let mut signal_v = crate::buffer::zeroed_f64(n);
    // + 0.0 turns -0.0 (0 V times a negative carrier value) into 0.0. The
    // same values as `carrier.unit_rms`, one loop per shape.
    match carrier.shape {
        CarrierShape::Sine => sine_drive(&envelope_v, cycles_per_sample, &mut signal_v),
        _ => {
            for (i, (s, &u)) in signal_v.iter_mut().zip(&envelope_v).enumerate() {
                *s = u * carrier.unit_rms(i as f64 * cycles_per_sample) + 0.0;
            }
        }
    }
    let sum_sq = signal_v.iter().map(|s| s * s).sum::<f64>();
    clip.clamped_fraction = clip.clamped_samples as f64 / n as f64;
    clip.slew_limited_fraction = clip.slew_limited_samples as f64 / n as f64;

    let envelope_max_v = envelope_v.iter().fold(0.0f64, |m, &u| m.max(u));
    let peak_v = carrier.peak_per_rms() * envelope_max_v;
    if let Some(range_v) = settings.limits.amplifier_range_v
        && peak_v > range_v
    {
        let first = envelope_v.iter().position(|&u| carrier.peak_per_rms() * u > range_v).unwrap_or(0);
        return Err(SignalError::ExceedsAmplifierRange {
            amplitude_v: peak_v,
            range_v,
            t_s: start_s + first as f64 / fs,
            max_u_v: range_v / carrier.peak_per_rms(),
        });
    }

    let outside_fraction = outside as f64 / n as f64;
    let mut warnings = Vec::new();
    if clip.clamped_samples > 0 {
        warnings.push(format!(
            "the profile asks for up to {:.3} V RMS: clamped at U_max = {} V for {:.2}% of the time",
            clip.requested_max_v,
            Num(settings.limits.u_max_v),
            100.0 * clip.clamped_fraction
        ));
    }
    warnings.extend(outside_warning);
    let report = SignalReport {
        sample_rate_hz: settings.sample_rate_hz,
        n_samples: n,
        start_s,
        duration_s: (n - 1) as f64 / fs,
        carrier,
        limits: settings.limits,
        extend: settings.extend,
        envelope_max_v,
        peak_v,
        sample_peak_v: signal_v.iter().fold(0.0f64, |m, &s| m.max(s.abs())),
        signal_rms_v: (sum_sq / n as f64).sqrt(),
        outside_fraction,
        clip,
        warnings,
        ultrasonic: None,
    };
    Ok(DriveSignal { x_mm, envelope_v, signal_v, amplitude_um: None, report })
}

/// Renders a two-channel drive: channel 1 is [`render`] of `curve`
/// (identical samples and report), channel 2 the ultrasonic amplitude
/// a(x(t)) of `amplitude` along the same finger positions, in um, with
/// the same [`Extend`] outside the span, clamped at `a_max_um` (reported,
/// with a warning) and without carrier: a control signal for the plate's
/// resonant driver. `a_max_um` must be within [`crate::ranges::A_MAX_UM`].
pub fn render_two_channel(
    curve: &VoltageCurve,
    amplitude: &AmplitudeCurve,
    a_max_um: f64,
    trajectory: &Trajectory,
    settings: &RenderSettings,
) -> Result<DriveSignal, SignalError> {
    crate::ranges::A_MAX_UM.check(a_max_um).map_err(|e| SignalError::Settings(e.to_string()))?;
    let mut signal = render(curve, trajectory, settings)?;
    let n = signal.len();
    let mut a_um = crate::buffer::zeroed_f64(n);
    amplitude.amplitudes_along(&signal.x_mm, settings.extend, &mut a_um);
    let mut requested_max_um = 0.0f64;
    let mut clamped_samples = 0usize;
    for a in a_um.iter_mut() {
        requested_max_um = requested_max_um.max(*a);
        clamped_samples += usize::from(*a > a_max_um);
        // max(0.0): the curve is >= 0, and + 0.0 keeps -0.0 out.
        *a = a.min(a_max_um).max(0.0) + 0.0;
    }
    let amplitude_max_um = a_um.iter().fold(0.0f64, |m, &a| m.max(a));
    let clamped_fraction = clamped_samples as f64 / n as f64;
    if clamped_samples > 0 {
        signal.report.warnings.push(format!(
            "the profile asks for up to {requested_max_um:.4} um: channel 2 clamped at a_max = {a_max_um} um for \
             {:.2}% of the time",
            100.0 * clamped_fraction
        ));
    }
    signal.report.ultrasonic = Some(UltrasonicReport {
        a_max_um,
        amplitude_max_um,
        requested_max_um,
        clamped_samples,
        clamped_fraction,
        convention: "channel 2 is the ultrasonic vibration amplitude envelope a(x(t)) in um (peak), without \
                     carrier: a control signal for the plate's resonant driver"
            .into(),
        resonance_hz: None,
    });
    signal.amplitude_um = Some(a_um);
    Ok(signal)
}

/// Highest plate resonance channel 2 may carry, as a fraction of the
/// sample rate: 0.45 fs, where audio converters' reconstruction filters
/// still pass the signal flat (their pass band ends at about 0.45 fs;
/// the Nyquist frequency is 0.5 fs). A 192 kHz interface plays plates up
/// to 86.4 kHz; 48 kHz, none (21.6 kHz is below any plate's resonance).
pub const MAX_RESONANCE_PER_SAMPLE_RATE: f64 = 0.45;

/// A plate resonance channel 2 can carry at `sample_rate_hz`: within
/// [`crate::ranges::PLATE_RESONANCE_HZ`] and at most
/// [`MAX_RESONANCE_PER_SAMPLE_RATE`] times the sample rate (the rule of
/// [`modulate_at_resonance`] and of the WAV reader).
pub(crate) fn plate_resonance(resonance_hz: f64, sample_rate_hz: u32) -> Result<f64, String> {
    let f = crate::ranges::PLATE_RESONANCE_HZ.check(resonance_hz).map_err(|e| e.to_string())?;
    if f > MAX_RESONANCE_PER_SAMPLE_RATE * f64::from(sample_rate_hz) {
        return Err(format!(
            "a plate resonance of {} Hz needs a sample rate of at least {} Hz (f_r <= 0.45 fs, where converters pass \
             the signal flat); the drive is at {sample_rate_hz} Hz",
            Num(f),
            (f / MAX_RESONANCE_PER_SAMPLE_RATE).ceil(),
        ));
    }
    Ok(f)
}

/// Turns a two-channel drive's channel 2 from the amplitude envelope a(t)
/// into the plate's displacement at its resonance f_r, a(t) sin(2 pi f_r
/// (t - t0)) in um (t0 the first sample's time; the same polynomial sine
/// as channel 1's carrier), for an amplifier that drives the plate
/// directly instead of a resonant driver that takes the envelope. Its
/// peak stays within a_max, channel 2's full scale. Refused, naming the
/// limit, for a one-channel drive, for f_r outside
/// [`crate::ranges::PLATE_RESONANCE_HZ`] or above
/// [`MAX_RESONANCE_PER_SAMPLE_RATE`] times the sample rate, and for a
/// drive already modulated.
pub fn modulate_at_resonance(signal: &mut DriveSignal, resonance_hz: f64) -> Result<(), SignalError> {
    let sample_rate_hz = signal.report.sample_rate_hz;
    let (Some(a_um), Some(us)) = (signal.amplitude_um.as_mut(), signal.report.ultrasonic.as_mut()) else {
        return Err(SignalError::Settings(
            "the plate's resonance is for a two-channel drive (a display profile with an amplitude_um column)".into(),
        ));
    };
    if us.resonance_hz.is_some() {
        return Err(SignalError::Settings("channel 2 already carries the plate's resonance".into()));
    }
    let f = plate_resonance(resonance_hz, sample_rate_hz).map_err(SignalError::Settings)?;
    let cycles_per_sample = f / f64::from(sample_rate_hz);
    for (i, a) in a_um.iter_mut().enumerate() {
        *a = *a * carrier::sin_turns(i as f64 * cycles_per_sample) + 0.0;
    }
    us.resonance_hz = Some(f);
    us.convention = format!(
        "channel 2 is the ultrasonic plate's displacement a(x(t)) sin(2 pi f_r t) in um, f_r = {} Hz: the \
         amplitude envelope a (peak, at most a_max) on the plate's resonance",
        Num(f)
    );
    Ok(())
}

/// signal = envelope x sqrt(2) sin(2 pi i f / fs) (+ 0.0: no -0.0), in
/// AVX2 lanes where the CPU has them (without FMA: the same operations, so
/// the same bits, as the portable build).
fn sine_drive(envelope_v: &[f64], cycles_per_sample: f64, signal_v: &mut [f64]) {
    #[inline(always)]
    fn lanes(envelope_v: &[f64], cycles_per_sample: f64, signal_v: &mut [f64]) {
        for (i, (s, &u)) in signal_v.iter_mut().zip(envelope_v).enumerate() {
            *s = u * (std::f64::consts::SQRT_2 * carrier::sin_turns(i as f64 * cycles_per_sample)) + 0.0;
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn avx2(envelope_v: &[f64], cycles_per_sample: f64, signal_v: &mut [f64]) {
        lanes(envelope_v, cycles_per_sample, signal_v)
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        return unsafe { avx2(envelope_v, cycles_per_sample, signal_v) };
    }
    lanes(envelope_v, cycles_per_sample, signal_v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(u: f64) -> VoltageCurve {
        VoltageCurve::new(vec![0.0, 10.0], vec![u, u]).unwrap()
    }

    /// A constant envelope U on a sine carrier has RMS U and peak sqrt(2) U
    /// (docs/physics.md voltage convention); 1 kHz at 48 kHz over whole
    /// periods: within 1e-9 relative.
    #[test]
    fn sine_drive_has_rms_u_and_peak_sqrt2_u() {
        let trajectory = Trajectory::new(vec![0.0, 0.1], vec![1.0, 1.0]).unwrap();
        let s = render(&flat(80.0), &trajectory, &RenderSettings::DEFAULT).unwrap();
        assert_eq!(s.len(), 4801);
        let whole = &s.signal_v[..4800];
        let rms = (whole.iter().map(|v| v * v).sum::<f64>() / 4800.0).sqrt();
        assert!((rms / 80.0 - 1.0).abs() < 1e-9, "{rms}");
        assert!((s.report.peak_v - 80.0 * std::f64::consts::SQRT_2).abs() < 1e-9);
        assert!(s.report.clip.clamped_samples == 0 && s.report.warnings.is_empty());
    }

    #[test]
    fn slew_limit_fades_in_from_zero() {
        let trajectory = Trajectory::new(vec![0.0, 0.01], vec![1.0, 1.0]).unwrap();
        let settings = RenderSettings {
            sample_rate_hz: 1000,
            carrier: Carrier { shape: CarrierShape::None, frequency_hz: 0.0 },
            limits: Limits { slew_v_per_s: Some(10_000.0), ..Limits::DEFAULT },
            extend: Extend::Hold,
        };
        let s = render(&flat(50.0), &trajectory, &settings).unwrap();
        assert_eq!(s.envelope_v, [10.0, 20.0, 30.0, 40.0, 50.0, 50.0, 50.0, 50.0, 50.0, 50.0, 50.0]);
        assert_eq!(s.signal_v, s.envelope_v);
        assert_eq!(s.report.clip.slew_limited_samples, 4);
        assert_eq!(s.report.clip.slew_max_deviation_v, 40.0);
    }

    #[test]
    fn absurd_lengths_are_refused() {
        let trajectory = Trajectory::new(vec![0.0, 1e6], vec![0.0, 1.0]).unwrap();
        let e = render(&flat(1.0), &trajectory, &RenderSettings::DEFAULT).unwrap_err();
        assert!(matches!(e, SignalError::TooLong { .. }), "{e}");
    }
}
