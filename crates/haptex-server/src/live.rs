//! Live output from the web page: the page streams the finger's positions
//! over a WebSocket and the server plays the design on a lab's audio
//! output (`haptex serve --live`), showing the latency while it plays.
//!
//! The audio device is not this crate's: the `haptex` binary implements
//! [`LiveOutput`] with cpal (its `live` feature) and hands it to
//! [`crate::AppState::with_live_output`]; tests implement it with the
//! core's [`haptex_core::live::LiveEngine`] on a paced thread. This module
//! is what does not depend on the device: the design a page sends, checked
//! against the output's limits ([`LiveDesign::parse`]), and the
//! conversation over one WebSocket ([`converse`]).
//!
//! The conversation (text messages; docs/live.md):
//!
//! - page -> server: `{"design": {"x_mm": [..], "voltage_v": [..],
//!   "amplitude_um": [..]}}` opens the output with this design (replacing
//!   the one playing, which fades out first); `{"stop": true}` fades it
//!   out and closes the device; anything else is touch lines as `haptex
//!   live --stdin` reads them (`t_s,x_mm` on the page's clock, `x_mm`, or
//!   `lift`), one or more per message.
//! - server -> page: `{"opened": {..}}` (the output and the design's peak),
//!   `{"status": LiveFigures}` every 100 ms while open, `{"closed":
//!   LiveFigures}`, `{"error": message, "field": name}`. A bad message is
//!   answered with an error and lifts the finger (the drive fades); a
//!   closed socket closes the output.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use axum::extract::ws::{CloseFrame, Message, WebSocket, close_code};
use haptex_core::live::{DeviceClock, LiveFigures, TouchAxes, TouchEvent, TouchStamper, parse_touch_line};
use haptex_core::num::Num;
use haptex_core::profile::ProfileError;
use haptex_core::signal::{AmplitudeCurve, VoltageCurve};
use serde::{Deserialize, Serialize};
use serde_json::json;

/// What the page is told of the live output (`GET /api/live`): where it
/// plays and the limits a design must keep.
#[derive(Debug, Clone, Serialize)]
pub struct LiveInfo {
    /// The audio device's name.
    pub device: String,
    /// The rate the output runs at, Hz.
    pub sample_rate_hz: u32,
    /// Frames per device buffer, if fixed.
    pub buffer_frames: Option<u32>,
    /// The highest envelope played, V RMS: a design reaching above it is refused.
    pub u_max_v: f64,
    /// Volts at the amplifier output per full-scale sample.
    pub volts_per_full_scale: f64,
    /// Channel 2's full scale, the plate's a_max in um; `None`: the output
    /// has no ultrasonic channel and takes voltage designs only.
    pub a_max_um: Option<f64>,
    /// The carrier, e.g. `sine 1000 Hz`.
    pub carrier: String,
    /// Every fade (start, stop, touch-down, lift, gap), ms.
    pub ramp_ms: f64,
    /// No report for this long and the drive fades out, ms.
    pub gap_ms: f64,
}

/// A design to play: the voltage curve and, for a combined or ultrasonic
/// design, the amplitude curve over the same positions.
#[derive(Debug, Clone)]
pub struct LiveDesign {
    pub curve: VoltageCurve,
    pub amplitude: Option<AmplitudeCurve>,
}

/// A design as the page sends it (the profile of `POST /api/voltage`'s
/// answer).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DesignJson {
    x_mm: Vec<f64>,
    #[serde(default)]
    voltage_v: Option<Vec<f64>>,
    #[serde(default)]
    amplitude_um: Option<Vec<f64>>,
}

/// A control message from the page.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Control {
    #[serde(default)]
    design: Option<serde_json::Value>,
    #[serde(default)]
    stop: Option<bool>,
}

/// A refused message: what is wrong and the field it names.
#[derive(Debug, Clone, PartialEq)]
pub struct Refusal {
    pub message: String,
    pub field: Option<String>,
}

impl Refusal {
    fn new(message: impl Into<String>, field: &str) -> Self {
        Self { message: message.into(), field: Some(field.to_owned()) }
    }

    fn json(&self) -> String {
        json!({ "error": self.message, "field": self.field }).to_string()
    }
}

impl LiveDesign {
    /// The design of a `design` message, checked against the output's
    /// limits: at most `max_points` points; positions strictly increasing;
    /// voltages finite, >= 0 and at most the output's U_max (a design made
    /// for a higher U_max would be clipped, so it is refused instead);
    /// amplitudes only on an output with an ultrasonic channel, at most its
    /// a_max. A design without `voltage_v` (the ultrasonic display) plays
    /// 0 V on channel 1.
    pub fn parse(value: serde_json::Value, info: &LiveInfo, max_points: usize) -> Result<Self, Refusal> {
        let design: DesignJson = serde_path_to_error::deserialize(value).map_err(|e| {
            let path = e.path().to_string();
            let field = if path == "." { "design".to_owned() } else { format!("design.{path}") };
            Refusal { message: format!("{field}: {}", e.inner()), field: Some(field) }
        })?;
        let n = design.x_mm.len();
        if n > max_points {
            return Err(Refusal::new(
                format!("the design has {n} points, more than the {max_points} this server takes"),
                "design.x_mm",
            ));
        }
        let voltage_v = match (design.voltage_v, &design.amplitude_um) {
            (Some(v), _) => v,
            (None, Some(_)) => vec![0.0; n],
            (None, None) => {
                return Err(Refusal::new("a design needs voltage_v, amplitude_um or both", "design.voltage_v"));
            }
        };
        for (name, column) in [("voltage_v", Some(&voltage_v)), ("amplitude_um", design.amplitude_um.as_ref())] {
            if let Some(column) = column.filter(|c| c.len() != n) {
                return Err(Refusal::new(
                    format!("design.{name} has {} values but x_mm has {n}", column.len()),
                    &format!("design.{name}"),
                ));
            }
        }
        let invalid = |e: ProfileError| match e {
            ProfileError::Invalid { index, field, message } => {
                Refusal::new(format!("design.{field}[{index}]: {message}"), &format!("design.{field}"))
            }
            other => Refusal::new(other.to_string(), "design"),
        };
        let curve = VoltageCurve::new(design.x_mm.clone(), voltage_v).map_err(invalid)?;
        if curve.max_v() > info.u_max_v {
            return Err(Refusal::new(
                format!(
                    "the design reaches {} V but this output plays at most U_max = {} V: design it with u_max_v = {}",
                    Num(curve.max_v()),
                    Num(info.u_max_v),
                    Num(info.u_max_v)
                ),
                "design.voltage_v",
            ));
        }
        let amplitude = match design.amplitude_um {
            None => None,
            Some(a) => {
                let Some(a_max) = info.a_max_um else {
                    return Err(Refusal::new(
                        "this output has no ultrasonic channel (haptex serve --live without --a-max-um): play a \
                         design for the electrovibration display",
                        "design.amplitude_um",
                    ));
                };
                let amplitude = AmplitudeCurve::new(design.x_mm, a).map_err(invalid)?;
                if amplitude.max_um() > a_max {
                    return Err(Refusal::new(
                        format!(
                            "the design asks for {} um but this output's plate gives at most a_max = {} um: design it \
                             with a_max_um = {}",
                            Num(amplitude.max_um()),
                            Num(a_max),
                            Num(a_max)
                        ),
                        "design.amplitude_um",
                    ));
                }
                Some(amplitude)
            }
        };
        Ok(Self { curve, amplitude })
    }
}

/// An audio output that plays designs live (the `haptex` binary's cpal
/// device).
pub trait LiveOutput: std::fmt::Debug + Send + Sync + 'static {
    /// The output and its limits.
    fn info(&self) -> &LiveInfo;
    /// Opens the device and starts playing `design` (silent until a touch,
    /// then faded in). Blocks while the device opens; the error says why it
    /// could not (a design the output's scale cannot play, a busy device).
    fn open(&self, design: LiveDesign) -> Result<Box<dyn LiveSession>, String>;
}

/// A design playing on the output.
pub trait LiveSession: Send + Sync {
    /// The output's sample clock (touch events are stamped on it).
    fn clock(&self) -> &DeviceClock;
    /// Queues a touch event for the renderer; `false` if the queue is full
    /// (the output is not taking samples).
    fn queue(&self, event: TouchEvent) -> bool;
    /// The figures now.
    fn figures(&self) -> LiveFigures;
    /// Why the output stopped by itself (a device error), if it did.
    fn failure(&self) -> Option<String>;
    /// The largest drive the design can play, V peak at the amplifier.
    fn peak_bound_v(&self) -> f64;
    /// Fades out, lets the fade reach the converter, closes the device;
    /// the run's last figures. Blocks for the fade (the ramp and a buffer
    /// or two).
    fn close(self: Box<Self>) -> LiveFigures;
}

/// The server's live output and who is using it: one page at a time (two
/// would interleave their positions).
#[derive(Debug)]
pub struct LiveHub {
    output: Arc<dyn LiveOutput>,
    in_use: AtomicBool,
}

/// The hub's one page, held while its conversation lasts.
pub struct LiveClaim(Arc<LiveHub>);

impl Drop for LiveClaim {
    fn drop(&mut self) {
        self.0.in_use.store(false, Ordering::Release);
    }
}

impl LiveHub {
    pub fn new(output: Arc<dyn LiveOutput>) -> Self {
        Self { output, in_use: AtomicBool::new(false) }
    }

    pub fn info(&self) -> &LiveInfo {
        self.output.info()
    }

    /// The output for one page, or `None` while another page has it.
    pub fn claim(self: &Arc<Self>) -> Option<LiveClaim> {
        self.in_use
            .compare_exchange(false, true, Ordering::AcqRel, Ordering::Acquire)
            .is_ok()
            .then(|| LiveClaim(Arc::clone(self)))
    }
}

/// How often the page gets the figures.
const STATUS_PERIOD: Duration = Duration::from_millis(100);

/// One page's conversation with the live output (the module's protocol),
/// until the socket closes; the output is closed (faded) at the end.
/// `max_points` bounds a design.
pub async fn converse(mut socket: WebSocket, claim: LiveClaim, max_points: usize) {
    let output = Arc::clone(&claim.0.output);
    let mut session: Option<Box<dyn LiveSession>> = None;
    let mut stamper = TouchStamper::default();
    let mut tick = tokio::time::interval(STATUS_PERIOD);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            message = socket.recv() => {
                let text = match message {
                    Some(Ok(Message::Text(text))) => text,
                    Some(Ok(Message::Binary(_))) => {
                        let refusal = Refusal::new("send text messages (JSON or touch lines)", "message");
                        if send(&mut socket, refusal.json()).await.is_err() { break; }
                        continue;
                    }
                    Some(Ok(Message::Close(_))) | None => break,
                    Some(Err(e)) => {
                        // A message over the size limit, or a broken
                        // connection: say why if the socket still takes it.
                        let reason = format!("{e}").chars().take(100).collect::<String>();
                        let close = CloseFrame { code: close_code::SIZE, reason: reason.into() };
                        let _ = socket.send(Message::Close(Some(close))).await;
                        break;
                    }
                    Some(Ok(_)) => continue,
                };
                let reply = if text.trim_start().starts_with('{') {
                    control(text.as_str(), &output, &mut session, &mut stamper, max_points).await
                } else {
                    touches(text.as_str(), session.as_deref(), &mut stamper)
                };
                if let Some(reply) = reply && send(&mut socket, reply).await.is_err() {
                    break;
                }
            }
            _ = tick.tick(), if session.is_some() => {
                let Some(live) = session.as_deref() else { continue };
                if let Some(failure) = live.failure() {
                    let closed = close(session.take()).await;
                    let reply = json!({
                        "error": format!("the output stopped: {failure} (faded to 0 V)"),
                        "field": null,
                        "closed": closed,
                    });
                    if send(&mut socket, reply.to_string()).await.is_err() { break; }
                    continue;
                }
                let status = json!({ "status": live.figures() }).to_string();
                if send(&mut socket, status).await.is_err() { break; }
            }
        }
    }
    close(session.take()).await;
    drop(claim);
}

async fn send(socket: &mut WebSocket, text: String) -> Result<(), axum::Error> {
    socket.send(Message::Text(text.into())).await
}

/// Closes a session off the async workers (the fade blocks); its last figures.
async fn close(session: Option<Box<dyn LiveSession>>) -> Option<LiveFigures> {
    let session = session?;
    tokio::task::spawn_blocking(move || session.close()).await.ok()
}

/// A `{"design": ..}` or `{"stop": true}` message; the reply.
async fn control(
    text: &str,
    output: &Arc<dyn LiveOutput>,
    session: &mut Option<Box<dyn LiveSession>>,
    stamper: &mut TouchStamper,
    max_points: usize,
) -> Option<String> {
    let control: Control = match serde_json::from_str(text) {
        Ok(c) => c,
        Err(e) => return Some(Refusal::new(format!("message: {e}"), "message").json()),
    };
    match (control.design, control.stop) {
        (Some(design), None) => {
            let design = match LiveDesign::parse(design, output.info(), max_points) {
                Ok(d) => d,
                Err(refusal) => {
                    lift(session.as_deref());
                    return Some(refusal.json());
                }
            };
            close(session.take()).await;
            let opener = Arc::clone(output);
            // On a thread of its own at the default priority: the audio
            // callback thread the output starts inherits its priority,
            // which a work thread has lowered (`crate::work`).
            let opened = crate::work::on_new_thread(move || opener.open(design)).await;
            *stamper = TouchStamper::default();
            match opened {
                Some(Ok(live)) => {
                    let reply = json!({ "opened": { "output": output.info(), "peak_bound_v": live.peak_bound_v() } });
                    *session = Some(live);
                    Some(reply.to_string())
                }
                Some(Err(message)) => Some(Refusal::new(message, "design").json()),
                None => Some(Refusal::new("opening the output failed", "design").json()),
            }
        }
        (None, Some(true)) => {
            let closed = close(session.take()).await;
            Some(json!({ "closed": closed }).to_string())
        }
        _ => Some(Refusal::new("a control message is {\"design\": {..}} or {\"stop\": true}", "message").json()),
    }
}

/// Touch lines (`--stdin`'s) for the playing design; a reply only for a
/// refused line, which also lifts the finger.
fn touches(text: &str, session: Option<&dyn LiveSession>, stamper: &mut TouchStamper) -> Option<String> {
    let Some(live) = session else {
        return Some(
            Refusal::new("nothing is playing: send {\"design\": {..}} first, then touch lines", "message").json(),
        );
    };
    let received = Instant::now();
    let arrival_s = live.clock().time_of(received);
    for line in text.lines() {
        let parsed = match parse_touch_line(line, TouchAxes::X) {
            Ok(Some(parsed)) => parsed,
            Ok(None) => continue,
            Err(message) => {
                lift(Some(live));
                return Some(
                    Refusal::new(format!("message {}: {message}", crate::error::quote(line)), "message").json(),
                );
            }
        };
        if !live.queue(TouchEvent::received(parsed, received, arrival_s, stamper)) {
            return Some(Refusal::new("the touch queue is full: the output is not taking samples", "message").json());
        }
    }
    None
}

/// Lifts the finger (the drive fades out) on a refused message.
fn lift(session: Option<&dyn LiveSession>) {
    if let Some(live) = session {
        let _ = live.queue(TouchEvent::lift_now(live.clock()));
    }
}
