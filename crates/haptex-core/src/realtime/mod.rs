//! Real-time drive rendering: touch positions in (60-240 Hz), drive samples
//! out (kHz rates), O(1) and allocation-free per output sample.
//!
//! A [`RealtimeRenderer`] is built once from a voltage curve: the curve is
//! resampled onto a uniform lookup table, the
//! carrier is a 64-bit phase accumulator read through the offline render's
//! polynomial sine (so live and offline drives agree to rounding), and the safety limits
//! are checked for the whole table up front, so no output sample can exceed
//! the amplifier range. Then, from the audio callback:
//!
//! ```
//! use haptex_core::realtime::{RealtimeConfig, RealtimeRenderer};
//! use haptex_core::signal::VoltageCurve;
//!
//! let curve = VoltageCurve::new(vec![0.0, 5.0, 10.0], vec![0.0, 80.0, 0.0])?;
//! let config = RealtimeConfig { volts_per_full_scale: 200.0, ..RealtimeConfig::default() };
//! let mut renderer = RealtimeRenderer::new(&curve, &config)?;
//! let mut buffer = [0.0f32; 480]; // 10 ms at 48 kHz
//! for report in 0..6 {
//!     // A touch report (here every 10 ms; 60-240 Hz in practice), stamped
//!     // on the renderer's clock, then one buffer of samples.
//!     renderer.touch(renderer.now_s(), 2.0 + 0.5 * report as f64);
//!     renderer.fill(&mut buffer); // samples in [-1, 1]: volts / volts_per_full_scale
//! }
//! renderer.release(); // finger lifted: the envelope goes to 0 V
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Between touch reports the position is extrapolated with the velocity of
//! the last two reports, for at most `horizon_s` past the last report (then
//! held), so the envelope does not step at every report. When a new report
//! disagrees with the extrapolation, the difference is blended out linearly
//! over `blend_s` instead of jumping. Reports closer than
//! [`MIN_VELOCITY_DT_S`] give no velocity.
//!
//! A combined (or ultrasonic) display's design has a second channel, the
//! plate's vibration amplitude a(x) in um ([`RealtimeRenderer::two_channel`]):
//! read from its own lookup table at the same estimated position, with the
//! same [`Extend`] outside the span, clamped to 0 ..= a_max and without
//! carrier (a control signal for the resonant driver), as the offline
//! [`crate::signal::render_two_channel`] does. Its full scale is a_max:
//! [`RealtimeRenderer::fill_frames`] writes a / a_max, as the two-channel
//! WAV does, so no sample can stand for more than the clamp.

mod planar;
mod touch;

pub use planar::{PlanarRenderer, PlanarSample};
pub use touch::MIN_VELOCITY_DT_S;

use crate::num::Num;
use crate::signal::{
    AmplitudeCurve, Carrier, CarrierShape, EnvelopeLimiter, Extend, Limits, SignalError, VoltageCurve,
};
use touch::TouchEstimator;

/// Largest lookup table: 2^20 points.
pub const MAX_TABLE_POINTS: usize = 1 << 20;

// Compile-time modes of the per-sample loop.
const SINE: u8 = 0;
const SQUARE: u8 = 1;
const NONE: u8 = 2;
const HOLD: u8 = 0;
const ZERO: u8 = 1;
const REPEAT: u8 = 2;

/// Settings of a [`RealtimeRenderer`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RealtimeConfig {
    /// Output sample rate in Hz.
    pub sample_rate_hz: u32,
    pub carrier: Carrier,
    pub limits: Limits,
    /// The voltage outside the profile's span.
    pub extend: Extend,
    /// Volts at the amplifier output for a full-scale sample: [`RealtimeRenderer::fill`]
    /// writes volts / this. A curve whose peak could exceed it is refused.
    pub volts_per_full_scale: f64,
    /// Longest extrapolation past the last touch report, in s; then the
    /// position is held. A pair of reports further apart than this gives no
    /// velocity (the finger is taken as still).
    pub horizon_s: f64,
    /// Time over which a new report's disagreement with the extrapolated
    /// position is blended out, in s (0: jump to the report). Keep it at
    /// most the report interval (4 ms suits 60-240 Hz: see
    /// docs/playback.md for the measured trade-off).
    pub blend_s: f64,
    /// Points of the lookup table; `None`: enough for the curve's smallest
    /// spacing (exact for a uniformly sampled curve), at most
    /// [`MAX_TABLE_POINTS`].
    pub table_points: Option<usize>,
}

impl Default for RealtimeConfig {
    /// 48 kHz, 1 kHz sine, U_max = 100 V, held ends, full scale = sqrt(2) x
    /// 100 V, 50 ms horizon, 4 ms blend.
    fn default() -> Self {
        Self {
            sample_rate_hz: 48_000,
            carrier: Carrier::DEFAULT,
            limits: Limits::DEFAULT,
            extend: Extend::Hold,
            volts_per_full_scale: std::f64::consts::SQRT_2 * Limits::DEFAULT.u_max_v,
            horizon_s: 0.05,
            blend_s: 0.004,
            table_points: None,
        }
    }
}

/// One output sample with the quantities behind it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time on the renderer's clock in s.
    pub t_s: f64,
    /// Estimated finger position in mm.
    pub x_mm: f64,
    /// Envelope after the limits, V RMS (0 when no finger touches).
    pub envelope_v: f64,
    /// Drive voltage in V (channel 1).
    pub signal_v: f64,
    /// Ultrasonic vibration amplitude in um (peak), after the a_max clamp:
    /// channel 2 of a two-channel renderer, 0 for a one-channel one and
    /// when no finger touches.
    pub amplitude_um: f64,
}

impl Sample {
    /// All zero: no time, no position, no output.
    pub const ZERO: Self = Self { t_s: 0.0, x_mm: 0.0, envelope_v: 0.0, signal_v: 0.0, amplitude_um: 0.0 };
}

/// A uniform lookup table of a curve (voltage or amplitude) over its span,
/// with linear interpolation between its points. The values are the
/// curve's own, not clamped: the renderer clamps after the interpolation,
/// as the offline render does (clamping the points first would lower the
/// values between a point above the limit and one below it).
#[derive(Debug, Clone)]
struct LookupTable {
    /// The points, plus one padding entry (a copy of the last) so that a
    /// lookup at exactly the last point can read one past it.
    values: Box<[f64]>,
    x0_mm: f64,
    inv_dx: f64,
    last_index: f64,
    inv_last_index: f64,
    /// Fraction of the points above the limit the renderer clamps at.
    clamped_fraction: f64,
}

impl LookupTable {
    /// Samples `curve` (held at its ends) on `points` (or enough for its
    /// smallest spacing) uniform points over its span, counting those above
    /// `ceiling`.
    fn new(curve: &VoltageCurve, points: Option<usize>, ceiling: f64) -> Result<Self, SignalError> {
        let (x0, x1) = curve.span_mm();
        let points = match points {
            Some(n) if (2..=MAX_TABLE_POINTS).contains(&n) => n,
            Some(n) => {
                return Err(SignalError::Settings(format!("table points must be 2..={MAX_TABLE_POINTS}, got {n}")));
            }
            None => {
                // Shave rounding so a uniform curve gets exactly its own points.
                let intervals = ((x1 - x0) / curve.min_spacing_mm() * (1.0 - 1e-9)).ceil();
                (intervals.min((MAX_TABLE_POINTS - 1) as f64) as usize + 1).max(2)
            }
        };
        let dx = (x1 - x0) / (points - 1) as f64;
        let mut clamped = 0usize;
        let mut values: Vec<f64> = (0..points)
            .map(|i| {
                let x = if i + 1 == points { x1 } else { x0 + dx * i as f64 };
                let v = curve.voltage_at(x, Extend::Hold);
                clamped += usize::from(v > ceiling);
                // max(0.0): the curve is >= 0; + 0.0 keeps -0.0 out.
                v.max(0.0) + 0.0
            })
            .collect();
        values.push(values[points - 1]);
        Ok(Self {
            values: values.into_boxed_slice(),
            x0_mm: x0,
            inv_dx: 1.0 / dx,
            last_index: (points - 1) as f64,
            inv_last_index: 1.0 / (points - 1) as f64,
            clamped_fraction: clamped as f64 / points as f64,
        })
    }

    /// Largest value of the table.
    fn max(&self) -> f64 {
        self.values.iter().fold(0.0f64, |m, &v| m.max(v))
    }

    /// Number of points (without the padding entry).
    fn points(&self) -> usize {
        self.values.len() - 1
    }

    /// Table lookup with linear interpolation; `E` is the extension mode.
    /// `wrap` (Repeat only) is the whole number of periods, in table index
    /// units, last subtracted: kept between samples, it is recomputed only
    /// when the finger crosses into another period.
    #[inline(always)]
    fn lookup<const E: u8>(&self, x_mm: f64, wrap: &mut f64) -> f64 {
        let mut p = (x_mm - self.x0_mm) * self.inv_dx;
        if E == ZERO && !(0.0..=self.last_index).contains(&p) {
            return 0.0;
        }
        if E == REPEAT {
            let wrapped = p - *wrap;
            if (0.0..self.last_index).contains(&wrapped) {
                p = wrapped;
            } else {
                // floor(p / last_index) periods, with a truncating cast as floor.
                let q = p * self.inv_last_index;
                let mut k = q as i64;
                if (k as f64) > q {
                    k -= 1;
                }
                *wrap = k as f64 * self.last_index;
                p -= *wrap;
            }
        }
        let p = if p > 0.0 { p } else { 0.0 };
        let p = if p < self.last_index { p } else { self.last_index };
        // p <= last_index < 2^20; the table has one padding entry past
        // last_index, so i + 1 is in bounds even at the end.
        let i = p as u32;
        let f = p - f64::from(i);
        let (a, b) = (self.values[i as usize], self.values[i as usize + 1]);
        a + f * (b - a)
    }

    /// The value at `x_mm` for the extension mode `extend`.
    fn value_at(&self, x_mm: f64, extend: Extend) -> f64 {
        match extend {
            Extend::Hold => self.lookup::<HOLD>(x_mm, &mut 0.0),
            Extend::Zero => self.lookup::<ZERO>(x_mm, &mut 0.0),
            Extend::Repeat => self.lookup::<REPEAT>(x_mm, &mut 0.0),
        }
    }
}

/// Channel 2 of a two-channel renderer: the ultrasonic amplitude table
/// (clamped to 0 ..= a_max) and its Repeat-mode period cache.
#[derive(Debug, Clone)]
struct AmplitudeChannel {
    table: LookupTable,
    a_max_um: f64,
    wrap: f64,
}

/// Streams the drive of a voltage curve from touch reports; see the module
/// documentation.
#[derive(Debug, Clone)]
pub struct RealtimeRenderer {
    // Uniform lookup table of U(x) (the limiter clamps at U_max).
    table: LookupTable,
    extend: Extend,
    /// Periods subtracted by the last Repeat lookup (table index units).
    wrap: f64,
    /// Channel 2, the ultrasonic amplitude a(x), for a combined design.
    amplitude: Option<AmplitudeChannel>,
    /// Carrier, limits, scale and clock.
    out: Output,
    /// Touch state: last report, velocity, blended correction.
    touch: TouchEstimator<1>,
}

/// What every real-time renderer shares once it has the envelope: the
/// carrier (a 64-bit phase accumulator, a full cycle is 2^64), the
/// envelope limiter, the output scale, the clock and the peak bound.
#[derive(Debug, Clone)]
struct Output {
    shape: CarrierShape,
    phase: u64,
    phase_step: u64,
    limiter: EnvelopeLimiter,
    output_scale: f64,
    n: u64,
    dt_s: f64,
    sample_rate_hz: f64,
    peak_bound_v: f64,
}

impl Output {
    /// Checks `config` (sample rate, carrier, limits, horizon, blend, full
    /// scale) for envelopes up to `max_envelope_v`: refuses a peak (carrier
    /// peak/RMS times the largest envelope or U_max, whichever is lower)
    /// above the amplifier range or the full scale.
    fn new(config: &RealtimeConfig, max_envelope_v: f64) -> Result<Self, SignalError> {
        let fs = config.sample_rate_hz as f64;
        if config.sample_rate_hz < crate::signal::MIN_SAMPLE_RATE_HZ {
            return Err(SignalError::Settings(format!(
                "sample rate {} Hz is below {} Hz",
                config.sample_rate_hz,
                crate::signal::MIN_SAMPLE_RATE_HZ
            )));
        }
        config.carrier.check(fs).map_err(SignalError::Settings)?;
        config.limits.check().map_err(SignalError::Settings)?;
        let non_negative = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(SignalError::Settings(format!("{name} must be a finite number >= 0, got {}", Num(v))))
            }
        };
        non_negative("horizon (s)", config.horizon_s)?;
        non_negative("blend time (s)", config.blend_s)?;
        let vpfs = config.volts_per_full_scale;
        if !(vpfs.is_finite() && vpfs > 0.0) {
            return Err(SignalError::Settings(format!(
                "volts per full scale must be a positive finite number, got {vpfs}"
            )));
        }
        // The envelope limiter clamps every sample at U_max.
        let peak_bound_v = config.carrier.peak_per_rms() * max_envelope_v.min(config.limits.u_max_v);
        if let Some(range_v) = config.limits.amplifier_range_v
            && peak_bound_v > range_v
        {
            return Err(SignalError::ExceedsAmplifierRange {
                amplitude_v: peak_bound_v,
                range_v,
                t_s: 0.0,
                max_u_v: range_v / config.carrier.peak_per_rms(),
            });
        }
        if peak_bound_v > vpfs {
            return Err(SignalError::ExceedsFullScale { amplitude_v: peak_bound_v, volts_per_full_scale: vpfs });
        }
        let cycles_per_sample =
            if config.carrier.shape == CarrierShape::None { 0.0 } else { config.carrier.frequency_hz / fs };
        Ok(Self {
            shape: config.carrier.shape,
            phase: 0,
            phase_step: (cycles_per_sample * 18_446_744_073_709_551_616.0).round() as u64,
            limiter: EnvelopeLimiter::new(&config.limits, fs),
            output_scale: 1.0 / vpfs,
            n: 0,
            dt_s: 1.0 / fs,
            sample_rate_hz: fs,
            peak_bound_v,
        })
    }

    /// Time of the next output sample, s.
    fn now_s(&self) -> f64 {
        self.n as f64 * self.dt_s
    }
}

impl RealtimeRenderer {
    /// Builds the renderer: the lookup table, the carrier, the limits.
    /// Refuses a configuration whose peak (carrier peak/RMS times the largest
    /// table voltage) exceeds the amplifier range or the full scale.
    pub fn new(curve: &VoltageCurve, config: &RealtimeConfig) -> Result<Self, SignalError> {
        // The configuration first (its errors before the table's).
        Output::new(config, 0.0)?;
        let table = LookupTable::new(curve, config.table_points, config.limits.u_max_v)?;
        let out = Output::new(config, table.max())?;
        let touch = TouchEstimator::new(config.horizon_s, config.blend_s, [table.x0_mm]);
        Ok(Self { table, wrap: 0.0, extend: config.extend, amplitude: None, out, touch })
    }

    /// A two-channel renderer for a combined (or ultrasonic) display's
    /// design: channel 1 is [`new`](Self::new)'s drive of `curve`, channel
    /// 2 the ultrasonic amplitude a(x) of `amplitude` at the same estimated
    /// position (its own lookup table, `config.table_points` or enough for
    /// its smallest spacing), clamped to 0 ..= `a_max_um`, no carrier, no
    /// slew limit: the offline [`crate::signal::render_two_channel`]'s
    /// conventions. `a_max_um` must be within [`crate::ranges::A_MAX_UM`].
    pub fn two_channel(
        curve: &VoltageCurve,
        amplitude: &AmplitudeCurve,
        a_max_um: f64,
        config: &RealtimeConfig,
    ) -> Result<Self, SignalError> {
        crate::ranges::A_MAX_UM.check(a_max_um).map_err(|e| SignalError::Settings(e.to_string()))?;
        let mut renderer = Self::new(curve, config)?;
        let table = LookupTable::new(amplitude.curve(), config.table_points, a_max_um)?;
        renderer.amplitude = Some(AmplitudeChannel { table, a_max_um, wrap: 0.0 });
        Ok(renderer)
    }

    /// Output channels the design has: 1 (electrovibration), or 2 (drive
    /// and ultrasonic amplitude).
    pub fn channels(&self) -> usize {
        if self.amplitude.is_some() { 2 } else { 1 }
    }

    /// Channel 2's clamp and full scale in um, for a two-channel renderer.
    pub fn a_max_um(&self) -> Option<f64> {
        self.amplitude.as_ref().map(|a| a.a_max_um)
    }

    /// Volts at the amplifier output for a full-scale sample of channel 1.
    pub fn volts_per_full_scale(&self) -> f64 {
        1.0 / self.out.output_scale
    }

    /// Time of the next output sample on the renderer's clock, in s (0 at
    /// the first sample).
    pub fn now_s(&self) -> f64 {
        self.out.now_s()
    }

    /// Output sample rate in Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        self.out.sample_rate_hz
    }

    /// Samples rendered so far (the index of the next one).
    pub fn samples_rendered(&self) -> u64 {
        self.out.n
    }

    /// Whether a finger is down (a report came, and no release since).
    pub fn is_touching(&self) -> bool {
        self.touch.is_touching()
    }

    /// A touch report: the finger is at `x_mm` at time `t_s` (renderer
    /// clock). Non-finite reports are ignored. O(1), no allocation.
    pub fn touch(&mut self, t_s: f64, x_mm: f64) {
        self.touch.touch(t_s, [x_mm]);
    }

    /// A touch report stamped at [`now_s`](Self::now_s).
    pub fn touch_now(&mut self, x_mm: f64) {
        self.touch(self.now_s(), x_mm);
    }

    /// The finger was lifted: the envelope goes to 0 V (through the slew
    /// limit, if any) until the next report.
    pub fn release(&mut self) {
        self.touch.release();
    }

    /// The estimated finger position in mm at time `t_s` (renderer clock):
    /// the last report extrapolated with the report velocity for at most the
    /// horizon, plus what is left of the blended correction.
    #[inline]
    pub fn position_at(&self, t_s: f64) -> f64 {
        self.touch.position_at(t_s)[0]
    }

    /// U in V RMS at `x_mm` from the lookup table, before the U_max
    /// clamp the limiter applies.
    pub fn voltage_at(&self, x_mm: f64) -> f64 {
        self.table.value_at(x_mm, self.extend)
    }

    /// a in um (clamped to 0 ..= a_max) at `x_mm`, from channel 2's lookup
    /// table; `None` for a one-channel renderer.
    pub fn amplitude_at(&self, x_mm: f64) -> Option<f64> {
        self.amplitude.as_ref().map(|a| a.table.value_at(x_mm, self.extend).min(a.a_max_um))
    }

    /// The unit-RMS carrier at `phase` (a full cycle is 2^64); `S` is the
    /// shape. The sine is the offline render's polynomial
    /// (`signal::carrier::sin_turns`, within 4.5e-16 of sin), at the phase
    /// in turns (the accumulator's top 53 bits).
    #[inline(always)]
    pub(crate) fn carrier_at<const S: u8>(phase: u64) -> f64 {
        match S {
            SINE => {
                std::f64::consts::SQRT_2 * crate::signal::sin_turns(phase as f64 * (1.0 / 18_446_744_073_709_551_616.0))
            }
            SQUARE => {
                if phase < 1 << 63 {
                    1.0
                } else {
                    -1.0
                }
            }
            _ => 1.0,
        }
    }

    /// Renders the next `n` samples, handing each with its index to
    /// `write`. The carrier shape `S`, extension `E` and channel count
    /// (`TWO`: with the amplitude channel) are compile-time constants, so
    /// the per-sample loop has no mode branches.
    #[inline(always)]
    fn render<const S: u8, const E: u8, const TWO: bool>(&mut self, n: usize, mut write: impl FnMut(usize, Sample)) {
        let dt = self.out.dt_s;
        let t0 = self.out.n as f64 * dt;
        let mut phase = self.out.phase;
        let mut limiter = self.out.limiter;
        let phase_step = self.out.phase_step;
        let mut wrap = self.wrap;
        let (amplitude_table, mut amplitude_wrap, a_max_um) = match &self.amplitude {
            Some(a) if TWO => (Some(&a.table), a.wrap, a.a_max_um),
            _ => (None, 0.0, 0.0),
        };
        let mut k = 0.0;
        for i in 0..n {
            let t_s = t0 + k * dt;
            k += 1.0;
            let (x_mm, requested, amplitude_um) = if self.touch.is_touching() {
                let [x] = self.touch.position_at(t_s);
                let a = match amplitude_table {
                    Some(table) if TWO => {
                        // The a_max clamp (the table's values are >= 0).
                        let a = table.lookup::<E>(x, &mut amplitude_wrap);
                        if a < a_max_um { a } else { a_max_um }
                    }
                    _ => 0.0,
                };
                (x, self.table.lookup::<E>(x, &mut wrap), a)
            } else {
                (self.touch.last()[0], 0.0, 0.0)
            };
            let envelope_v = limiter.apply(requested);
            let signal_v = envelope_v * Self::carrier_at::<S>(phase);
            phase = phase.wrapping_add(phase_step);
            write(i, Sample { t_s, x_mm, envelope_v, signal_v, amplitude_um });
        }
        self.out.phase = phase;
        self.out.limiter = limiter;
        self.wrap = wrap;
        if let Some(a) = &mut self.amplitude {
            a.wrap = amplitude_wrap;
        }
        self.out.n += n as u64;
    }

    /// Renders the next `n` samples for the configured shape, extension
    /// and channels, handing each with its index to `write`: the primitive
    /// the `fill*` methods and a live output's callback are built on. O(1)
    /// per sample, no allocation.
    pub fn render_with(&mut self, n: usize, write: impl FnMut(usize, Sample)) {
        use CarrierShape as C;
        macro_rules! by_channels {
            ($s:expr, $e:expr) => {
                if self.amplitude.is_some() {
                    self.render::<{ $s }, { $e }, true>(n, write)
                } else {
                    self.render::<{ $s }, { $e }, false>(n, write)
                }
            };
        }
        match (self.out.shape, self.extend) {
            (C::Sine, Extend::Hold) => by_channels!(SINE, HOLD),
            (C::Sine, Extend::Zero) => by_channels!(SINE, ZERO),
            (C::Sine, Extend::Repeat) => by_channels!(SINE, REPEAT),
            (C::Square, Extend::Hold) => by_channels!(SQUARE, HOLD),
            (C::Square, Extend::Zero) => by_channels!(SQUARE, ZERO),
            (C::Square, Extend::Repeat) => by_channels!(SQUARE, REPEAT),
            (C::None, Extend::Hold) => by_channels!(NONE, HOLD),
            (C::None, Extend::Zero) => by_channels!(NONE, ZERO),
            (C::None, Extend::Repeat) => by_channels!(NONE, REPEAT),
        }
    }

    /// Renders the next output sample. O(1), no allocation.
    pub fn next_sample(&mut self) -> Sample {
        let mut sample = Sample::ZERO;
        self.render_with(1, |_, s| sample = s);
        sample
    }

    /// Fills `out` with the next samples of channel 1, as fractions of full
    /// scale (volts / volts_per_full_scale, within [-1, 1]). O(1) per
    /// sample, no allocation.
    pub fn fill(&mut self, out: &mut [f32]) {
        let scale = self.out.output_scale;
        self.render_with(out.len(), |i, s| out[i] = (s.signal_v * scale) as f32);
    }

    /// Fills the interleaved frames of `out` (`channels` samples each, a
    /// trailing partial frame left as it is) with the next samples as
    /// fractions of full scale: channel 1 volts / volts_per_full_scale,
    /// channel 2 (two-channel renderers) a / a_max, further channels 0.
    /// A one-channel renderer leaves channel 2 at 0 too. O(1) per sample,
    /// no allocation.
    pub fn fill_frames(&mut self, out: &mut [f32], channels: usize) {
        let channels = channels.max(1);
        let frames = out.len() / channels;
        let (scale, scale_2) = (self.out.output_scale, self.a_max_um().map_or(0.0, |a| 1.0 / a));
        self.render_with(frames, |i, s| {
            let frame = &mut out[i * channels..(i + 1) * channels];
            frame.fill(0.0);
            frame[0] = (s.signal_v * scale) as f32;
            if channels > 1 {
                frame[1] = (s.amplitude_um * scale_2) as f32;
            }
        });
    }

    /// Fills `out` with the next samples in volts.
    pub fn fill_volts(&mut self, out: &mut [f64]) {
        self.render_with(out.len(), |i, s| out[i] = s.signal_v);
    }

    /// Fills `out` with the next samples, each with its time, position,
    /// envelope and amplitude (for inspection and tests).
    pub fn fill_samples(&mut self, out: &mut [Sample]) {
        self.render_with(out.len(), |i, s| out[i] = s);
    }

    /// Upper bound of |drive| in V: carrier peak/RMS times the largest
    /// table voltage or U_max, whichever is lower.
    pub fn peak_bound_v(&self) -> f64 {
        self.out.peak_bound_v
    }

    /// Number of lookup-table points.
    pub fn table_points(&self) -> usize {
        self.table.points()
    }

    /// Fraction of the lookup table's points above U_max (clamped when played).
    pub fn table_clamped_fraction(&self) -> f64 {
        self.table.clamped_fraction
    }

    /// Fraction of channel 2's lookup table points above a_max (clamped
    /// when played; two-channel renderers).
    pub fn amplitude_clamped_fraction(&self) -> Option<f64> {
        self.amplitude.as_ref().map(|a| a.table.clamped_fraction)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve() -> VoltageCurve {
        let x: Vec<f64> = (0..=1000).map(|i| i as f64 * 0.01).collect();
        let u = x.iter().map(|x| 50.0 + 40.0 * (std::f64::consts::TAU * x / 2.0).sin()).collect();
        VoltageCurve::new(x, u).unwrap()
    }

    /// The lookup table of a uniformly sampled curve holds its own points, so
    /// table and direct interpolation agree to rounding (1e-9 V).
    #[test]
    fn table_matches_the_curve() {
        let c = curve();
        for extend in [Extend::Hold, Extend::Zero, Extend::Repeat] {
            let r = RealtimeRenderer::new(&c, &RealtimeConfig { extend, ..RealtimeConfig::default() }).unwrap();
            assert_eq!(r.table_points(), 1001);
            for i in 0..4000 {
                let x = -5.0 + i as f64 * 0.00537;
                let (a, b) = (r.voltage_at(x), c.voltage_at(x, extend));
                assert!((a - b).abs() < 1e-9, "{extend:?} x = {x}: {a} vs {b}");
            }
        }
    }

    /// Streaming in Repeat mode (the period offset is cached between
    /// samples) gives the curve's tiled value at every estimated position,
    /// while the finger crosses several periods both ways: within 1e-9 V.
    #[test]
    fn repeat_tiles_across_periods_while_streaming() {
        let c = curve();
        let config = RealtimeConfig { extend: Extend::Repeat, ..RealtimeConfig::default() };
        let mut r = RealtimeRenderer::new(&c, &config).unwrap();
        let mut samples = [Sample::ZERO; 400];
        for k in 0..240 {
            // 2 s of 120 Hz reports, x swinging between -25 and 45 mm.
            let t = r.now_s();
            r.touch(t, 10.0 + 35.0 * (std::f64::consts::TAU * 0.5 * t).sin());
            r.fill_samples(&mut samples);
            for s in &samples {
                let expected = c.voltage_at(s.x_mm, Extend::Repeat);
                assert!(
                    (s.envelope_v - expected).abs() < 1e-9,
                    "report {k}, x = {}: {} vs {expected}",
                    s.x_mm,
                    s.envelope_v
                );
            }
        }
    }

    /// The sine carrier against sin() at the frequency asked for: within
    /// 1e-12 of the peak over 1 s (the polynomial's 4.5e-16; the
    /// accumulator's step, f / fs rounded in f64 then to 2^-64 turns, off by
    /// ~1e-16 relative: a phase drift of 1e-14 turns per 10^4 cycles).
    #[test]
    fn sine_carrier_matches_sin() {
        let c = VoltageCurve::new(vec![0.0, 1.0], vec![100.0, 100.0]).unwrap();
        let mut r = RealtimeRenderer::new(&c, &RealtimeConfig::default()).unwrap();
        r.touch(0.0, 0.5);
        for n in 0..48_000 {
            let s = r.next_sample();
            // The phase reduced to one turn exactly first (1000 n mod 48000):
            // sin of the unreduced 2 pi f t carries its rounding, 1e-13 rad.
            let turns = (1000 * n % 48_000) as f64 / 48_000.0;
            let exact = 100.0 * std::f64::consts::SQRT_2 * (std::f64::consts::TAU * turns).sin();
            assert!((s.signal_v - exact).abs() < 1e-12 * 141.43, "n = {n}: {} vs {exact}", s.signal_v);
        }
    }

    /// Constant velocity is extrapolated exactly between reports.
    #[test]
    fn constant_velocity_is_extrapolated_exactly() {
        let mut r = RealtimeRenderer::new(&curve(), &RealtimeConfig::default()).unwrap();
        let report_every = 800; // 60 Hz at 48 kHz
        let truth = |t: f64| 1.0 + 40.0 * t;
        let mut max_error = 0.0f64;
        for n in 0..48_000usize {
            if n % report_every == 0 {
                r.touch_now(truth(r.now_s()));
            }
            let s = r.next_sample();
            if n >= 2 * report_every {
                max_error = max_error.max((s.x_mm - truth(s.t_s)).abs());
            }
        }
        assert!(max_error < 1e-9, "{max_error}");
    }

    /// Two reports microseconds apart (one message's lines stamped across
    /// a clock update, a report seen twice) give no velocity: the position
    /// settles on the last report, instead of running off at 2.5 mm / 10 us
    /// (the cause of a flaky live WebSocket test). Reports 2 ms apart give
    /// their own velocity (40 mm/s to 1e-9).
    #[test]
    fn reports_closer_than_a_millisecond_give_no_velocity() {
        let config = RealtimeConfig { blend_s: 0.0, ..RealtimeConfig::default() };
        let mut r = RealtimeRenderer::new(&curve(), &config).unwrap();
        r.touch(0.0, 2.0);
        r.touch(0.5, 5.0);
        r.touch(0.5 + 1e-5, 7.5);
        for t in [0.5 + 1e-5, 0.52, 0.6] {
            assert!((r.position_at(t) - 7.5).abs() < 1e-12, "t = {t}: {}", r.position_at(t));
        }
        let mut r = RealtimeRenderer::new(&curve(), &config).unwrap();
        r.touch(0.0, 2.0);
        r.touch(0.01, 2.4);
        r.touch(0.012, 2.48);
        let v = (r.position_at(0.02) - 2.48) / (0.02 - 0.012);
        assert!((v - 40.0).abs() < 1e-9, "{v} mm/s");
    }

    #[test]
    fn release_silences_and_bad_configs_are_refused() {
        let c = curve();
        let mut r = RealtimeRenderer::new(&c, &RealtimeConfig::default()).unwrap();
        assert_eq!(r.next_sample().envelope_v, 0.0, "silent before the first touch");
        r.touch_now(0.5);
        assert!(r.next_sample().envelope_v > 0.0);
        r.release();
        assert_eq!(r.next_sample().envelope_v, 0.0);
        // Peak bound sqrt(2) * 90 V = 127.3 V.
        let small = RealtimeConfig { volts_per_full_scale: 120.0, ..RealtimeConfig::default() };
        assert!(matches!(RealtimeRenderer::new(&c, &small), Err(SignalError::ExceedsFullScale { .. })));
        let limits = Limits { amplifier_range_v: Some(100.0), ..Limits::DEFAULT };
        let amp = RealtimeConfig { limits, ..RealtimeConfig::default() };
        assert!(matches!(RealtimeRenderer::new(&c, &amp), Err(SignalError::ExceedsAmplifierRange { .. })));
        let clamped = RealtimeConfig { limits: Limits { u_max_v: 70.0, ..limits }, ..RealtimeConfig::default() };
        let r = RealtimeRenderer::new(&c, &clamped).unwrap();
        assert!((r.peak_bound_v() - 70.0 * std::f64::consts::SQRT_2).abs() < 1e-12);
        assert!(r.table_clamped_fraction() > 0.0);
    }
}
