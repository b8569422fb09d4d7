//! `POST /api/play`: the drive signal of a voltage profile along a finger
//! trajectory (what `haptex play` does): the RMS envelope U(x(t)), clamped
//! at U_max and optionally slew limited, on a carrier; WAV bytes (default)
//! or JSON with the safety report.
//!
//! Body (JSON): `{"voltage": {"x_mm": [..], "voltage_v": [..]}, "stroke":
//! {"velocity_mm_s": 50}}` or with `"trajectory": {"t_s": [..], "x_mm":
//! [..]}` instead of `stroke`; optional `carrier`, `sample_rate_hz`,
//! `u_max_v`, `slew_v_per_s`, `amplifier_range_v`, `outside`, `format`
//! (`wav` | `json` | `sidecar`: the sidecar JSON of the WAV this request
//! answers, as `haptex play` writes it beside its WAV), `wav_format`,
//! `volts_per_full_scale`.
//!
//! A display profile of an ultrasonic or combined display (`POST
//! /api/voltage` with `display`) plays on two channels, as `haptex play`
//! plays one: `voltage.amplitude_um` beside `voltage.voltage_v` (0 V for
//! the ultrasonic display alone) and `a_max_um`, the plate's limit.
//! Channel 1 is the drive above; channel 2 the ultrasonic amplitude
//! envelope a(x(t)) in um, clamped at a_max, which is also its full scale
//! (the core's `render_two_channel` and `encode_wav`: the WAV's `hptx`
//! chunk holds both channels' scales, as the command line's file does).

use axum::Json;
use axum::http::{HeaderName, HeaderValue, header};
use axum::response::{IntoResponse, Response};
use haptex_core::num::Num;
use haptex_core::profile::ProfileError;
use haptex_core::signal::{
    AmplitudeCurve, Carrier, CarrierShape, DriveSignal, Extend, Limits, RenderSettings, SignalError, VoltageCurve,
    WavFormat, WavOptions, WavSidecar, encode_wav, render, render_two_channel,
};
use haptex_core::trajectory::Trajectory;
use serde::Deserialize;
use serde_json::json;

use crate::error::ApiError;
use crate::extract::{Preamble, Route};
use crate::fields;
use crate::input::{BodyKind, TrajectoryJson, check_points, parse_json};
use crate::params::{check_range, spec};
use crate::work;
use haptex_core::ranges;

/// The file name the WAV answer suggests (its Content-Disposition), which
/// its sidecar names.
const WAV_FILE_NAME: &str = "haptex-drive.wav";
/// Finger speed of a generated stroke when the GUI has no other, mm/s.
pub const DEFAULT_VELOCITY_MM_S: f64 = 50.0;
/// Rate at which generated strokes are sampled (linear in between), Hz.
const STROKE_RATE_HZ: f64 = 1000.0;
/// Sample rates accepted, Hz.
const SAMPLE_RATES_HZ: std::ops::RangeInclusive<u32> = 1000..=192_000;
/// Most back-and-forth strokes of a generated trajectory.
const MAX_STROKES: u32 = 1000;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlayBody {
    voltage: CurveJson,
    #[serde(default)]
    trajectory: Option<TrajectoryJson>,
    #[serde(default)]
    stroke: Option<StrokeJson>,
    #[serde(default)]
    carrier: Option<Carrier>,
    #[serde(default)]
    sample_rate_hz: Option<u32>,
    #[serde(default)]
    u_max_v: Option<f64>,
    #[serde(default)]
    slew_v_per_s: Option<f64>,
    #[serde(default)]
    amplifier_range_v: Option<f64>,
    #[serde(default)]
    outside: Option<Extend>,
    #[serde(default)]
    format: Option<PlayFormat>,
    #[serde(default)]
    wav_format: Option<WavFormat>,
    #[serde(default)]
    volts_per_full_scale: Option<f64>,
    /// The ultrasonic plate's highest amplitude, um (peak): channel 2's
    /// clamp and full scale (with `voltage.amplitude_um` only).
    #[serde(default)]
    a_max_um: Option<f64>,
    /// The design's provenance as the page states it (its recipe's
    /// `source`, a JSON object of at most 4096 bytes): the sidecar then
    /// records it with the data's SHA-256 in its `source`.
    #[serde(default)]
    source: Option<serde_json::Value>,
}

/// The longest `source` accepted, serialized.
const MAX_SOURCE_BYTES: usize = 4096;

/// A voltage curve: positions in mm and RMS voltages in V.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CurveJson {
    x_mm: Vec<f64>,
    voltage_v: Vec<f64>,
    /// The ultrasonic amplitude in um (peak) at each position: channel 2.
    #[serde(default)]
    amplitude_um: Option<Vec<f64>>,
}

/// A generated trajectory: one sweep at constant velocity, or `strokes`
/// back-and-forth minimum-jerk strokes at mean velocity, between `from_mm`
/// and `to_mm` (default: the ends of the voltage curve).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StrokeJson {
    velocity_mm_s: f64,
    #[serde(default)]
    strokes: Option<u32>,
    #[serde(default)]
    from_mm: Option<f64>,
    #[serde(default)]
    to_mm: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum PlayFormat {
    Wav,
    Json,
    /// The sidecar JSON of the WAV the same request answers (what `haptex
    /// play` writes beside its WAV: scales of both channels, sample hash,
    /// safety report).
    Sidecar,
}

/// The route: a JSON body (the answer's format is in it), no query.
pub(crate) struct Play;

impl Route for Play {
    const BODY: &'static [BodyKind] = &[BodyKind::Json];
}

pub async fn post(call: Preamble<Play>) -> Result<Response, ApiError> {
    let Preamble { state, bytes, slot, .. } = call;
    let limits = state.limits().clone();
    let mut job = slot.run(move || Job::parse(&bytes, &limits)).await?;
    if let Some(design) = job.design.take() {
        // The recipe's part the request cannot state: the data this server serves.
        job.design = Some(json!({
            "design": design,
            "library_sha256": state.library_sha256(),
            "database_sha256": state.database_sha256(),
        }));
    }
    let permit = work::slot(state.renders()).await?;
    let heavy = work::heavy_slot(&state).await?;
    work::blocking(vec![permit, heavy], move || job.run()).await
}

/// A checked request: everything the render needs.
struct Job {
    curve: VoltageCurve,
    /// Channel 2 and its a_max, for a two-channel drive.
    ultrasonic: Option<(AmplitudeCurve, f64)>,
    trajectory: Trajectory,
    settings: RenderSettings,
    format: PlayFormat,
    wav: WavOptions,
    /// The request's `source` (then with the data's SHA-256), for the sidecar.
    design: Option<serde_json::Value>,
}

impl Job {
    /// Parses and checks the body: every field in its range, the whole
    /// render within the sample limit of its format.
    fn parse(bytes: &[u8], limits: &crate::Limits) -> Result<Self, ApiError> {
        let body: PlayBody = parse_json(bytes)?;
        if let Some(source) = &body.source
            && (!source.is_object() || source.to_string().len() > MAX_SOURCE_BYTES)
        {
            return Err(ApiError::bad_request(
                format!("a JSON object of at most {MAX_SOURCE_BYTES} bytes (the design's provenance)"),
                Some("source"),
            ));
        }
        let design = body.source.clone();
        check_points(body.voltage.x_mm.len(), limits.max_points, "voltage.x_mm")?;
        // haptex-core checks positions, voltages and amplitudes against
        // their ranges.
        let curve_error = |e: ProfileError| match e {
            ProfileError::Invalid { index, field, message } => {
                ApiError::bad_request(message, Some(&format!("voltage.{field}[{index}]")))
            }
            other => ApiError::bad_request(other.to_string(), Some("voltage")),
        };
        let ultrasonic = match (body.voltage.amplitude_um, body.a_max_um) {
            (None, None) => None,
            (None, Some(_)) => {
                return Err(ApiError::bad_request(
                    "a_max_um is the limit of channel 2, the ultrasonic amplitude: give voltage.amplitude_um with it",
                    Some("a_max_um"),
                ));
            }
            (Some(_), None) => {
                return Err(ApiError::bad_request(
                    "voltage.amplitude_um (a combined or ultrasonic display's profile) needs a_max_um, the plate's \
                     highest amplitude in um: channel 2's clamp and full scale (summary.ultrasonic.a_max_um of \
                     POST /api/voltage)",
                    Some("a_max_um"),
                ));
            }
            (Some(amplitude_um), Some(a_max)) => {
                let a_max = fields::check(ranges::A_MAX_UM, a_max, "a_max_um")?;
                if amplitude_um.len() != body.voltage.x_mm.len() {
                    return Err(ApiError::bad_request(
                        format!(
                            "{} amplitudes for {} positions: one per x_mm",
                            amplitude_um.len(),
                            body.voltage.x_mm.len()
                        ),
                        Some("voltage.amplitude_um"),
                    ));
                }
                let amplitude = AmplitudeCurve::new(body.voltage.x_mm.clone(), amplitude_um).map_err(curve_error)?;
                Some((amplitude, a_max))
            }
        };
        let curve = VoltageCurve::new(body.voltage.x_mm, body.voltage.voltage_v).map_err(curve_error)?;
        let format = body.format.unwrap_or(PlayFormat::Wav);
        let sample_rate_hz = body.sample_rate_hz.unwrap_or(RenderSettings::DEFAULT.sample_rate_hz);
        if !SAMPLE_RATES_HZ.contains(&sample_rate_hz) {
            return Err(ApiError::bad_request(
                format!(
                    "sample_rate_hz must be from {} to {} Hz, got {sample_rate_hz}",
                    SAMPLE_RATES_HZ.start(),
                    SAMPLE_RATES_HZ.end()
                ),
                Some("sample_rate_hz"),
            ));
        }
        let carrier = body.carrier.unwrap_or(Carrier::DEFAULT);
        if carrier.shape != CarrierShape::None {
            let f = fields::check(ranges::CARRIER_HZ, carrier.frequency_hz, "carrier.frequency_hz")?;
            let nyquist = f64::from(sample_rate_hz) / 2.0;
            if f >= nyquist {
                return Err(ApiError::bad_request(
                    format!(
                        "frequency_hz must be below the Nyquist frequency of the sample rate ({} Hz), got {}",
                        Num(nyquist),
                        Num(f)
                    ),
                    Some("carrier.frequency_hz"),
                ));
            }
        }
        let u_max_v = match body.u_max_v {
            Some(u) => check_range(spec("u_max_v").expect("u_max_v is a device parameter"), u, "u_max_v")?,
            None => Limits::DEFAULT.u_max_v,
        };
        let slew_v_per_s =
            body.slew_v_per_s.map(|v| fields::check(ranges::SLEW_V_PER_S, v, "slew_v_per_s")).transpose()?;
        let amplifier_range_v = body
            .amplifier_range_v
            .map(|v| fields::check(ranges::AMPLIFIER_RANGE_V, v, "amplifier_range_v"))
            .transpose()?;
        // Checked whatever the format, so that a request is valid or not
        // independently of the answer it asks for.
        let volts_per_full_scale = match body.volts_per_full_scale {
            Some(v) => fields::check(ranges::VOLTS_PER_FULL_SCALE, v, "volts_per_full_scale")?,
            None => std::f64::consts::SQRT_2 * u_max_v,
        };
        let settings = RenderSettings {
            sample_rate_hz,
            carrier,
            limits: Limits { u_max_v, slew_v_per_s, amplifier_range_v },
            extend: body.outside.unwrap_or_default(),
        };
        settings.check().map_err(|e| ApiError::bad_request(e.to_string(), Some("carrier")))?;
        let wav = WavOptions { format: body.wav_format.unwrap_or(WavFormat::Pcm16), volts_per_full_scale };
        let budget = Budget {
            sample_rate_hz,
            channels: if ultrasonic.is_some() { 2 } else { 1 },
            format,
            wav_format: wav.format,
            limits,
        };
        let (field, trajectory) = trajectory(body.trajectory, body.stroke, &curve, &budget, limits)?;
        budget.check(trajectory.duration_s(), field)?;
        Ok(Self { curve, ultrasonic, trajectory, settings, format, wav, design })
    }

    /// The bytes of this request's answer, estimated before any of it is
    /// made (a recipe's budget of output bytes): a WAV's header and
    /// samples, a sidecar's JSON, or the JSON answer's numbers as text.
    fn answer_bytes(&self) -> f64 {
        let channels = if self.ultrasonic.is_some() { 2 } else { 1 };
        let samples = samples(self.trajectory.duration_s(), self.settings.sample_rate_hz);
        match self.format {
            PlayFormat::Wav => 4096.0 + samples * (channels * wav_sample_bytes(self.wav.format)) as f64,
            PlayFormat::Sidecar => 16384.0,
            PlayFormat::Json => 4096.0 + samples * ((3 + channels) * 25) as f64,
        }
    }

    /// Renders the drive and builds the answer.
    fn run(self) -> Result<Response, ApiError> {
        let signal = match &self.ultrasonic {
            Some((amplitude, a_max_um)) => {
                render_two_channel(&self.curve, amplitude, *a_max_um, &self.trajectory, &self.settings)
            }
            None => render(&self.curve, &self.trajectory, &self.settings),
        }
        .map_err(signal_error)?;
        match self.format {
            PlayFormat::Wav => wav_response(&signal, &self.wav),
            PlayFormat::Json => Ok(Json(json_answer(&signal)).into_response()),
            PlayFormat::Sidecar => {
                let encoded = encode_wav(&signal, &self.wav, "response").map_err(signal_error)?;
                let mut source =
                    json!({ "server": "haptex serve (POST /api/play)", "haptex_version": env!("CARGO_PKG_VERSION") });
                if let Some(recipe) = self.design {
                    source["recipe"] = recipe;
                }
                let sidecar = WavSidecar::new(WAV_FILE_NAME.to_string(), &encoded, &signal.report, source);
                Ok(Json(sidecar).into_response())
            }
        }
    }
}

/// The samples of a render `duration_s` long at `rate_hz` (both ends).
fn samples(duration_s: f64, rate_hz: u32) -> f64 {
    (duration_s * f64::from(rate_hz)).floor() + 1.0
}

/// What a render may cost: at most the samples of its answer's format
/// ([`crate::Limits::max_wav_samples`], `max_json_samples`), and at most
/// the request's memory budget
/// ([`crate::Limits::max_request_memory_bytes`]), both checked on the
/// duration before anything is generated or rendered.
struct Budget<'a> {
    sample_rate_hz: u32,
    channels: usize,
    format: PlayFormat,
    wav_format: WavFormat,
    limits: &'a crate::Limits,
}

impl Budget<'_> {
    /// Refuses (413 naming `field`) a render `duration_s` long beyond the
    /// samples or the memory a request may take.
    fn check(&self, duration_s: f64, field: &str) -> Result<(), ApiError> {
        let rate = self.sample_rate_hz;
        let samples = samples(duration_s, rate);
        let (max_samples, answer) = match self.format {
            PlayFormat::Wav | PlayFormat::Sidecar => (self.limits.max_wav_samples, "a WAV"),
            PlayFormat::Json => (self.limits.max_json_samples, "JSON"),
        };
        if samples > max_samples as f64 {
            return Err(ApiError::too_large(
                format!(
                    "{} s at {rate} Hz is {} samples, more than the {max_samples} {answer} answer may have",
                    Num(duration_s),
                    Num(samples)
                ),
                Some(field),
            ));
        }
        let memory = samples * self.memory_per_sample() as f64;
        let max = self.limits.max_request_memory_bytes;
        if memory > max as f64 {
            return Err(ApiError::too_large(
                format!(
                    "{} s at {rate} Hz on {} channel(s) as {answer}: about {} MiB to render and answer, more than the \
                     {} MiB a request may take; play a shorter trajectory or at a lower sample rate",
                    Num(duration_s),
                    self.channels,
                    Num((memory / f64::from(1 << 20)).ceil()),
                    max >> 20
                ),
                Some(field),
            ));
        }
        Ok(())
    }

    /// The working memory of the render and its answer per sample, bytes:
    /// the render's vectors (position, envelope, drive, and channel 2's
    /// amplitude: 8 bytes each) and the answer: the WAV's samples
    /// (channels x 2, 3 or 4 bytes; the sidecar hashes the same WAV), or
    /// the JSON's arrays (the times and the render's vectors, each number
    /// 8 bytes, then a JSON value of 32 bytes, then up to 25 bytes of
    /// text).
    fn memory_per_sample(&self) -> usize {
        let vectors = 2 + self.channels;
        match self.format {
            PlayFormat::Wav | PlayFormat::Sidecar => 8 * vectors + self.channels * wav_sample_bytes(self.wav_format),
            PlayFormat::Json => 8 * vectors + (1 + vectors) * (8 + 32 + 25),
        }
    }
}

/// The bytes of one sample of one channel of a WAV.
fn wav_sample_bytes(format: WavFormat) -> usize {
    match format {
        WavFormat::Pcm16 => 2,
        WavFormat::Pcm24 => 3,
        WavFormat::Float32 => 4,
    }
}

/// The bytes of the answer `POST /api/play` would give to `body`, checked
/// as the route checks it (its errors), estimated before anything is
/// rendered: what a recipe's budget adds up ([`crate::recipe`]).
pub(crate) fn answer_bytes(body: &[u8], limits: &crate::Limits) -> Result<f64, ApiError> {
    Ok(Job::parse(body, limits)?.answer_bytes())
}

/// The trajectory to render, and the request field it came from.
fn trajectory(
    given: Option<TrajectoryJson>,
    stroke: Option<StrokeJson>,
    curve: &VoltageCurve,
    budget: &Budget,
    limits: &crate::Limits,
) -> Result<(&'static str, Trajectory), ApiError> {
    match (given, stroke) {
        (Some(t), None) => Ok(("trajectory", t.into_trajectory("trajectory.", limits.max_points)?)),
        (None, Some(s)) => {
            let velocity = fields::check(ranges::VELOCITY_MM_S, s.velocity_mm_s, "stroke.velocity_mm_s")?;
            let strokes = s.strokes.unwrap_or(1);
            if !(1..=MAX_STROKES).contains(&strokes) {
                return Err(ApiError::bad_request(
                    format!("strokes must be from 1 to {MAX_STROKES}, got {strokes}"),
                    Some("stroke.strokes"),
                ));
            }
            let (x0, x1) = curve.span_mm();
            let from = fields::check(ranges::POSITION_MM, s.from_mm.unwrap_or(x0), "stroke.from_mm")?;
            let to = fields::check(ranges::POSITION_MM, s.to_mm.unwrap_or(x1), "stroke.to_mm")?;
            // Refuse before generating: the render is at least this long.
            let duration_s = (to - from).abs() / velocity * f64::from(strokes);
            budget.check(duration_s, "stroke")?;
            let generated = if strokes == 1 {
                Trajectory::constant_velocity(from, to, velocity, STROKE_RATE_HZ)
            } else {
                Trajectory::strokes(from, to, velocity, strokes as usize, STROKE_RATE_HZ)
            };
            Ok(("stroke", generated.map_err(|e| ApiError::bad_request(e.to_string(), Some("stroke")))?))
        }
        (Some(_), Some(_)) => Err(ApiError::bad_request("give trajectory or stroke, not both", Some("stroke"))),
        (None, None) => Err(ApiError::bad_request(
            "give a trajectory ({\"t_s\": [..], \"x_mm\": [..]}) or a stroke ({\"velocity_mm_s\": 50})",
            Some("trajectory"),
        )),
    }
}

fn signal_error(error: SignalError) -> ApiError {
    match &error {
        SignalError::TooLong { .. } => ApiError::too_large(error.to_string(), Some("trajectory")),
        SignalError::ExceedsAmplifierRange { .. } => {
            ApiError::bad_request(error.to_string(), Some("amplifier_range_v"))
        }
        SignalError::ExceedsFullScale { .. } => ApiError::bad_request(error.to_string(), Some("volts_per_full_scale")),
        SignalError::Settings(_) => ApiError::bad_request(error.to_string(), None),
        SignalError::Wav { .. } | SignalError::ReadWav { .. } | SignalError::Write(_) => {
            ApiError::internal(error.to_string())
        }
    }
}

fn wav_response(signal: &DriveSignal, options: &WavOptions) -> Result<Response, ApiError> {
    let encoded = encode_wav(signal, options, "response").map_err(signal_error)?;
    let number = |v: f64| HeaderValue::from_str(&v.to_string()).unwrap_or_else(|_| HeaderValue::from_static("0"));
    let mut response = (
        [
            (header::CONTENT_TYPE, HeaderValue::from_static("audio/wav")),
            (header::CONTENT_DISPOSITION, HeaderValue::from_static("attachment; filename=\"haptex-drive.wav\"")),
            (HeaderName::from_static("x-haptex-volts-per-full-scale"), number(options.volts_per_full_scale)),
            (HeaderName::from_static("x-haptex-peak-v"), number(signal.report.peak_v)),
        ],
        encoded.bytes,
    )
        .into_response();
    // Channel 2's scale (also in the WAV's hptx chunk).
    if let Some(c2) = &encoded.scale.channel_2 {
        response
            .headers_mut()
            .insert(HeaderName::from_static("x-haptex-um-per-full-scale"), number(c2.um_per_full_scale));
    }
    Ok(response)
}

fn json_answer(signal: &DriveSignal) -> serde_json::Value {
    let mut answer = json!({
        "report": signal.report,
        "t_s": signal.times_s(),
        "x_mm": signal.x_mm,
        "envelope_v": signal.envelope_v,
        "signal_v": signal.signal_v,
    });
    if let Some(a) = &signal.amplitude_um {
        answer["amplitude_um"] = json!(a);
    }
    answer
}
