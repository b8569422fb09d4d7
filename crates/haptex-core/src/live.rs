//! Live output: a renderer ([`RealtimeRenderer`] on a line,
//! [`PlanarRenderer`] over a voltage map; the [`LiveRenderer`] trait)
//! driven by timestamped touch events into an audio device's interleaved
//! buffers, with the safety envelope a real output needs. Independent of the audio API: `haptex live` calls
//! [`LiveEngine::process`] from its cpal callback, tests call it directly.
//!
//! Clock: the output's sample clock. Sample n is at t = n / fs; every touch
//! event carries its time on this clock.
//!
//! Safety, on top of the renderer's (U_max clamp, the peak bound checked
//! against the full scale and the amplifier range at construction):
//!
//! - **Gain ramp.** Every output sample is multiplied by a gain in
//!   [0, 1] that moves linearly by at most 1 / (ramp_s fs) per sample.
//!   It rises while a finger is down and reports are fresh, and falls
//!   otherwise: on start (and every touch-down) the drive fades in over
//!   `ramp_s`, on stop, lift-off, a gap or a fault it fades out over
//!   `ramp_s`.
//! - **Gap.** Past the last report the position is extrapolated for the
//!   renderer's horizon, then held; `gap_s` after the last report the gain
//!   starts to fall. The output is 0 V at most `gap_s + ramp_s` after the
//!   last report (the documented drop-out time, tested).
//! - **Last clamp.** Each written sample is clamped to the peak bound
//!   (channel 1) and to 0 ..= 1 of a_max (channel 2); a non-finite sample is
//!   written as 0 and stops the output. Neither can happen with a valid
//!   renderer; both are counted ([`LiveStatus`]) so that a test can say so.
//!
//! Latency: for each event, the time from its timestamp to the first
//! output sample rendered after it was applied (device clock), and, for
//! events that came through a queue, the wall-clock wait from its arrival
//! to the callback that applied it. The device's own buffer latency
//! (callback to DAC) is the audio API's to report (`haptex live` prints
//! cpal's).
//!
//! Allocation and locking: none in [`LiveEngine::process`]. It reads the
//! wall clock (`Instant::now`, a vDSO call) once per buffer when a queued
//! event carries an arrival time, and stores its counters in atomics.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

use crate::num::Num;
use crate::realtime::{PlanarRenderer, RealtimeRenderer};
use crate::signal::SignalError;

/// The coordinates a touch source reports: x on a line design, x and y
/// over a map.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TouchAxes {
    /// x only (a profile along a line).
    X,
    /// x and y (a voltage map).
    XY,
}

/// What a touch event says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Touch {
    /// The finger is at this x, in mm (a line's position).
    At(f64),
    /// The finger is at this (x, y), in mm (a map's position; a line
    /// renderer uses its x).
    AtXY(f64, f64),
    /// The finger was lifted.
    Lift,
}

impl Touch {
    /// Whether every number in it is finite.
    fn is_finite(&self) -> bool {
        match *self {
            Touch::At(x) => x.is_finite(),
            Touch::AtXY(x, y) => x.is_finite() && y.is_finite(),
            Touch::Lift => true,
        }
    }
}

/// One output sample of a live renderer with the quantities behind it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveSample {
    /// Time on the renderer's clock in s.
    pub t_s: f64,
    /// Estimated finger position in mm (y is 0 on a line).
    pub x_mm: f64,
    pub y_mm: f64,
    /// Envelope after the limits, V RMS.
    pub envelope_v: f64,
    /// Drive voltage in V (channel 1).
    pub signal_v: f64,
    /// Ultrasonic amplitude in um (channel 2; 0 on one channel).
    pub amplitude_um: f64,
}

/// A renderer a [`LiveEngine`] drives: [`RealtimeRenderer`] (a line, one
/// or two channels) or [`PlanarRenderer`] (a voltage map, one channel).
/// Its settings were checked when it was built (peak bound against the
/// full scale and the amplifier range); the engine adds the fades and the
/// last clamp.
pub trait LiveRenderer: Send + std::fmt::Debug {
    /// The coordinates its touch reports carry.
    const AXES: TouchAxes;
    /// Output channels of the design: 1 (drive) or 2 (drive, amplitude).
    fn channels(&self) -> usize;
    /// Output sample rate in Hz.
    fn sample_rate_hz(&self) -> f64;
    /// Volts at the amplifier for a full-scale sample of channel 1.
    fn volts_per_full_scale(&self) -> f64;
    /// Channel 2's full scale in um (two channels only).
    fn a_max_um(&self) -> Option<f64>;
    /// Upper bound of |drive| in V.
    fn peak_bound_v(&self) -> f64;
    /// Samples rendered so far.
    fn samples_rendered(&self) -> u64;
    /// Time of the next sample on its clock, s.
    fn now_s(&self) -> f64;
    /// Whether a finger is down.
    fn is_touching(&self) -> bool;
    /// A position report at `t_s`. Returns false (and ignores it) if the
    /// report lacks a coordinate the renderer needs (an x alone over a map).
    fn report(&mut self, t_s: f64, touch: Touch) -> bool;
    /// The finger was lifted.
    fn release(&mut self);
    /// Renders the next `n` samples, handing each to `write`. No allocation.
    fn render_live(&mut self, n: usize, write: impl FnMut(usize, LiveSample));
}

impl LiveRenderer for RealtimeRenderer {
    const AXES: TouchAxes = TouchAxes::X;
    fn channels(&self) -> usize {
        RealtimeRenderer::channels(self)
    }
    fn sample_rate_hz(&self) -> f64 {
        RealtimeRenderer::sample_rate_hz(self)
    }
    fn volts_per_full_scale(&self) -> f64 {
        RealtimeRenderer::volts_per_full_scale(self)
    }
    fn a_max_um(&self) -> Option<f64> {
        RealtimeRenderer::a_max_um(self)
    }
    fn peak_bound_v(&self) -> f64 {
        RealtimeRenderer::peak_bound_v(self)
    }
    fn samples_rendered(&self) -> u64 {
        RealtimeRenderer::samples_rendered(self)
    }
    fn now_s(&self) -> f64 {
        RealtimeRenderer::now_s(self)
    }
    fn is_touching(&self) -> bool {
        RealtimeRenderer::is_touching(self)
    }
    fn report(&mut self, t_s: f64, touch: Touch) -> bool {
        match touch {
            Touch::At(x) | Touch::AtXY(x, _) => self.touch(t_s, x),
            Touch::Lift => self.release(),
        }
        true
    }
    fn release(&mut self) {
        RealtimeRenderer::release(self)
    }
    #[inline(always)]
    fn render_live(&mut self, n: usize, mut write: impl FnMut(usize, LiveSample)) {
        self.render_with(n, |i, s| {
            write(
                i,
                LiveSample {
                    t_s: s.t_s,
                    x_mm: s.x_mm,
                    y_mm: 0.0,
                    envelope_v: s.envelope_v,
                    signal_v: s.signal_v,
                    amplitude_um: s.amplitude_um,
                },
            )
        });
    }
}

impl LiveRenderer for PlanarRenderer {
    const AXES: TouchAxes = TouchAxes::XY;
    fn channels(&self) -> usize {
        1
    }
    fn sample_rate_hz(&self) -> f64 {
        PlanarRenderer::sample_rate_hz(self)
    }
    fn volts_per_full_scale(&self) -> f64 {
        PlanarRenderer::volts_per_full_scale(self)
    }
    fn a_max_um(&self) -> Option<f64> {
        None
    }
    fn peak_bound_v(&self) -> f64 {
        PlanarRenderer::peak_bound_v(self)
    }
    fn samples_rendered(&self) -> u64 {
        PlanarRenderer::samples_rendered(self)
    }
    fn now_s(&self) -> f64 {
        PlanarRenderer::now_s(self)
    }
    fn is_touching(&self) -> bool {
        PlanarRenderer::is_touching(self)
    }
    fn report(&mut self, t_s: f64, touch: Touch) -> bool {
        match touch {
            Touch::AtXY(x, y) => self.touch(t_s, x, y),
            Touch::At(_) => return false,
            Touch::Lift => self.release(),
        }
        true
    }
    fn release(&mut self) {
        PlanarRenderer::release(self)
    }
    #[inline(always)]
    fn render_live(&mut self, n: usize, mut write: impl FnMut(usize, LiveSample)) {
        self.render_with(n, |i, s| {
            write(
                i,
                LiveSample {
                    t_s: s.t_s,
                    x_mm: s.x_mm,
                    y_mm: s.y_mm,
                    envelope_v: s.envelope_v,
                    signal_v: s.signal_v,
                    amplitude_um: 0.0,
                },
            )
        });
    }
}

/// A touch event on the output's sample clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TouchEvent {
    /// Time in s on the output's sample clock (sample n is at n / fs).
    pub t_s: f64,
    pub touch: Touch,
    /// When a live source received it (for the queue-wait figure); `None`
    /// for scheduled events (a replayed log).
    pub received: Option<Instant>,
}

/// Settings of a [`LiveEngine`] beyond the renderer's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveConfig {
    /// Interleaved channels of the device (at least the design's).
    pub channels: usize,
    /// Duration of every fade (start, stop, touch-down, lift, gap, fault), s.
    pub ramp_s: f64,
    /// Time after the last report at which the drive starts to fade, s.
    pub gap_s: f64,
}

impl LiveConfig {
    /// 20 ms ramps, 100 ms gap; `channels` device channels.
    pub fn new(channels: usize) -> Self {
        Self { channels, ramp_s: 0.02, gap_s: 0.1 }
    }

    /// Longest time from the last report to 0 V output: gap + ramp, in s.
    pub fn dropout_s(&self) -> f64 {
        self.gap_s + self.ramp_s
    }
}

/// Counters of a running engine, shared with other threads (atomics only).
#[derive(Debug, Default)]
pub struct LiveStatus {
    /// Frames written so far.
    pub frames: AtomicU64,
    /// Touch events applied.
    pub events: AtomicU64,
    /// Sum and largest of the render latency (event time to the first
    /// sample rendered after it), in ns of the device clock.
    pub latency_sum_ns: AtomicU64,
    pub latency_max_ns: AtomicU64,
    /// Largest wall-clock wait of a queued event, arrival to the callback
    /// that applied it, in ns (0 if none came through a queue).
    pub queue_wait_max_ns: AtomicU64,
    pub queued_events: AtomicU64,
    /// Samples the last clamp changed (expected 0).
    pub clamped_samples: AtomicU64,
    /// Non-finite samples written as 0 (expected 0); the first stops the output.
    pub non_finite_samples: AtomicU64,
    /// The stop was requested or a fault happened, and the gain reached 0:
    /// everything written from now on is 0.
    pub finished: AtomicBool,
    /// Largest |channel 1| written, as a fraction of full scale, f32 bits.
    pub peak_bits: AtomicU64,
    /// The last rendered sample: estimated position (mm), the renderer's
    /// envelope (V RMS, before the gain), the gain, and the amplitude (um,
    /// before the gain), as f64 bits (for a live display).
    pub last_x_mm_bits: AtomicU64,
    /// The last sample's y (mm), f64 bits; meaningful when `planar`.
    pub last_y_mm_bits: AtomicU64,
    /// The renderer is a map's (positions are (x, y)).
    pub planar: AtomicBool,
    pub last_envelope_v_bits: AtomicU64,
    pub last_gain_bits: AtomicU64,
    pub last_amplitude_um_bits: AtomicU64,
}

impl LiveStatus {
    /// Mean render latency in s, if any event was applied.
    pub fn mean_latency_s(&self) -> Option<f64> {
        let n = self.events.load(Ordering::Relaxed);
        (n > 0).then(|| self.latency_sum_ns.load(Ordering::Relaxed) as f64 * 1e-9 / n as f64)
    }

    /// Largest render latency in s.
    pub fn max_latency_s(&self) -> f64 {
        self.latency_max_ns.load(Ordering::Relaxed) as f64 * 1e-9
    }

    /// Largest |channel 1| written, fraction of full scale.
    pub fn peak(&self) -> f32 {
        f32::from_bits(self.peak_bits.load(Ordering::Relaxed) as u32)
    }

    /// The last rendered sample: (position mm, envelope V RMS before the
    /// gain, gain, amplitude um before the gain).
    pub fn last_sample(&self) -> (f64, f64, f64, f64) {
        let f = |a: &AtomicU64| f64::from_bits(a.load(Ordering::Relaxed));
        (
            f(&self.last_x_mm_bits),
            f(&self.last_envelope_v_bits),
            f(&self.last_gain_bits),
            f(&self.last_amplitude_um_bits),
        )
    }
}

/// What a running live output shows (a live page's status line, a
/// WebSocket status frame): the last rendered sample and the latency
/// figures so far, in ms.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LiveFigures {
    /// Estimated finger position of the last sample, mm.
    pub x_mm: f64,
    /// Its y over a map (absent on a line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub y_mm: Option<f64>,
    /// The renderer's envelope there (V RMS, before the gain).
    pub envelope_v: f64,
    /// The fade gain, 0 ..= 1.
    pub gain: f64,
    /// The envelope played: envelope x gain, V RMS.
    pub output_v: f64,
    /// The ultrasonic amplitude played (um, after the gain); 0 on one channel.
    pub amplitude_um: f64,
    /// Touch events applied.
    pub events: u64,
    /// Touch event to the first sample rendered after it (output clock).
    pub render_latency_mean_ms: Option<f64>,
    pub render_latency_max_ms: f64,
    /// Arrival to the callback that applied it (wall clock).
    pub queue_wait_max_ms: f64,
    /// The device's buffer latency (callback to playback), as the audio API reports it.
    pub output_latency_max_ms: f64,
    /// render_latency_max_ms + output_latency_max_ms.
    pub touch_to_output_max_ms: f64,
    /// Frames written so far.
    pub frames: u64,
    pub sample_rate_hz: u32,
    /// Underruns the device reported (it played silence for a moment).
    pub underruns: u64,
    /// The output has faded out for good (stopped, or a fault).
    pub finished: bool,
}

impl LiveStatus {
    /// The figures now, with what the audio API reports: its largest buffer
    /// latency (s) and its underruns.
    pub fn figures(&self, sample_rate_hz: u32, output_latency_max_s: f64, underruns: u64) -> LiveFigures {
        let (x_mm, envelope_v, gain, amplitude_um) = self.last_sample();
        let render_latency_max_ms = self.max_latency_s() * 1e3;
        let output_latency_max_ms = output_latency_max_s * 1e3;
        LiveFigures {
            x_mm,
            y_mm: self
                .planar
                .load(Ordering::Relaxed)
                .then(|| f64::from_bits(self.last_y_mm_bits.load(Ordering::Relaxed))),
            envelope_v,
            gain,
            output_v: envelope_v * gain,
            amplitude_um: amplitude_um * gain,
            events: self.events.load(Ordering::Relaxed),
            render_latency_mean_ms: self.mean_latency_s().map(|s| s * 1e3),
            render_latency_max_ms,
            queue_wait_max_ms: self.queue_wait_max_ns.load(Ordering::Relaxed) as f64 * 1e-6,
            output_latency_max_ms,
            touch_to_output_max_ms: render_latency_max_ms + output_latency_max_ms,
            frames: self.frames.load(Ordering::Relaxed),
            sample_rate_hz,
            underruns,
            finished: self.finished.load(Ordering::Relaxed),
        }
    }
}

/// The output's sample clock published for input threads: the frames
/// written before the latest callback and the wall-clock time of that
/// callback (a seqlock of three atomics, no locking).
#[derive(Debug)]
pub struct DeviceClock {
    epoch: Instant,
    sample_rate_hz: f64,
    seq: AtomicU64,
    frames: AtomicU64,
    callback_ns: AtomicU64,
}

impl DeviceClock {
    /// A clock at 0 now, for a device at `sample_rate_hz`.
    pub fn new(sample_rate_hz: u32) -> Self {
        Self {
            epoch: Instant::now(),
            sample_rate_hz: f64::from(sample_rate_hz),
            seq: AtomicU64::new(0),
            frames: AtomicU64::new(0),
            callback_ns: AtomicU64::new(0),
        }
    }

    /// Called by the audio callback at its start: `frames` written so far.
    pub fn publish(&self, frames: u64, now: Instant) {
        let ns = now.saturating_duration_since(self.epoch).as_nanos() as u64;
        self.seq.fetch_add(1, Ordering::AcqRel);
        self.frames.store(frames, Ordering::Release);
        self.callback_ns.store(ns, Ordering::Release);
        self.seq.fetch_add(1, Ordering::AcqRel);
    }

    /// The device-clock time of wall-clock instant `at`, in s: the frames
    /// of the latest callback plus the wall time since it (the device
    /// clock runs at the wall clock's rate on a real device).
    pub fn time_of(&self, at: Instant) -> f64 {
        let (frames, ns) = loop {
            let s1 = self.seq.load(Ordering::Acquire);
            if s1 % 2 == 1 {
                std::hint::spin_loop();
                continue;
            }
            let f = self.frames.load(Ordering::Acquire);
            let n = self.callback_ns.load(Ordering::Acquire);
            if self.seq.load(Ordering::Acquire) == s1 {
                break (f, n);
            }
        };
        let at_ns = at.saturating_duration_since(self.epoch).as_nanos() as u64;
        frames as f64 / self.sample_rate_hz + at_ns.saturating_sub(ns) as f64 * 1e-9
    }
}

/// The live output: renderer, event schedule, gain ramp, last clamp.
#[derive(Debug)]
pub struct LiveEngine<R = RealtimeRenderer> {
    renderer: R,
    channels: usize,
    fs: f64,
    scale_1: f64,
    scale_2: f64,
    limit_1: f64,
    gain: f64,
    gain_step: f64,
    gap_s: f64,
    last_report_s: f64,
    stopping: bool,
    /// Scheduled events (a replayed log), in time order, and the next one.
    schedule: Box<[TouchEvent]>,
    next: usize,
    /// Stop when the schedule is done: at the last event's time.
    stop_at_s: f64,
    status: Arc<LiveStatus>,
}

impl<R: LiveRenderer> LiveEngine<R> {
    /// An engine around `renderer` (its clock at 0). Refuses fewer device
    /// channels than the design has, and ramp or gap times that are not
    /// finite and positive (ramp) or >= 0 (gap).
    pub fn new(renderer: R, config: &LiveConfig) -> Result<Self, SignalError> {
        if config.channels < renderer.channels() {
            return Err(SignalError::Settings(format!(
                "the design has {} channels (electrovibration drive and ultrasonic amplitude) but the output has {}: \
                 give at least {} channels",
                renderer.channels(),
                config.channels,
                renderer.channels()
            )));
        }
        if !(config.ramp_s.is_finite() && config.ramp_s > 0.0 && config.ramp_s <= 10.0) {
            return Err(SignalError::Settings(format!("ramp time must be in (0, 10] s, got {}", Num(config.ramp_s))));
        }
        if !(config.gap_s.is_finite() && (0.0..=60.0).contains(&config.gap_s)) {
            return Err(SignalError::Settings(format!("gap time must be in [0, 60] s, got {}", Num(config.gap_s))));
        }
        if renderer.samples_rendered() != 0 {
            return Err(SignalError::Settings("the renderer has already rendered samples".into()));
        }
        let fs = renderer.sample_rate_hz();
        let vpfs = renderer.volts_per_full_scale();
        Ok(Self {
            channels: config.channels,
            fs,
            scale_1: 1.0 / vpfs,
            scale_2: renderer.a_max_um().map_or(0.0, |a| 1.0 / a),
            limit_1: (renderer.peak_bound_v() / vpfs).min(1.0),
            gain: 0.0,
            gain_step: 1.0 / (config.ramp_s * fs),
            gap_s: config.gap_s,
            last_report_s: f64::NEG_INFINITY,
            stopping: false,
            schedule: Box::new([]),
            next: 0,
            stop_at_s: f64::INFINITY,
            status: Arc::new(LiveStatus { planar: AtomicBool::new(R::AXES == TouchAxes::XY), ..LiveStatus::default() }),
            renderer,
        })
    }

    /// Plays `events` (times on the output clock, non-decreasing) at their
    /// times, each applied at the first sample at or after it, then stops
    /// (fades out from the last event's time). Refuses events out of order,
    /// with non-finite values, or without a y over a map.
    pub fn with_schedule(mut self, events: Vec<TouchEvent>) -> Result<Self, SignalError> {
        if let Some((i, _)) = events.iter().enumerate().find(|(_, e)| !(e.t_s.is_finite() && e.touch.is_finite())) {
            return Err(SignalError::Settings(format!("touch event {}: time or position is not finite", i + 1)));
        }
        if R::AXES == TouchAxes::XY
            && let Some(i) = events.iter().position(|e| matches!(e.touch, Touch::At(_)))
        {
            return Err(SignalError::Settings(format!(
                "touch event {}: a position over a map needs x and y, it has x only",
                i + 1
            )));
        }
        // All finite from here.
        for (i, pair) in events.windows(2).enumerate() {
            if pair[1].t_s < pair[0].t_s {
                return Err(SignalError::Settings(format!(
                    "touch event {}: time {} s is before the previous event's {} s",
                    i + 2,
                    crate::num::distinct(pair[1].t_s, pair[0].t_s).0,
                    crate::num::distinct(pair[1].t_s, pair[0].t_s).1
                )));
            }
        }
        self.stop_at_s = events.last().map_or(0.0, |e| e.t_s);
        self.schedule = events.into_boxed_slice();
        Ok(self)
    }

    /// The counters, to share with other threads.
    pub fn status(&self) -> Arc<LiveStatus> {
        Arc::clone(&self.status)
    }

    /// The renderer (for its settings).
    pub fn renderer(&self) -> &R {
        &self.renderer
    }

    /// Device channels written per frame.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Starts the fade out; everything after it reaches 0 is 0.
    pub fn stop(&mut self) {
        self.stopping = true;
    }

    /// Whether the stop (or a fault) has faded the output to 0 for good.
    pub fn is_finished(&self) -> bool {
        self.status.finished.load(Ordering::Relaxed)
    }

    /// Applies one event at sample time `t_now_s` (the first sample that
    /// reflects it), recording its latency.
    fn apply(&mut self, event: TouchEvent, t_now_s: f64, now: Option<Instant>) {
        match event.touch {
            Touch::Lift => self.renderer.release(),
            touch if touch.is_finite() && event.t_s.is_finite() => {
                if !self.renderer.report(event.t_s, touch) {
                    return;
                }
                self.last_report_s = self.last_report_s.max(event.t_s);
            }
            _ => return,
        }
        let latency_ns = ((t_now_s - event.t_s).max(0.0) * 1e9) as u64;
        let s = &self.status;
        s.events.fetch_add(1, Ordering::Relaxed);
        s.latency_sum_ns.fetch_add(latency_ns, Ordering::Relaxed);
        s.latency_max_ns.fetch_max(latency_ns, Ordering::Relaxed);
        if let (Some(received), Some(now)) = (event.received, now) {
            s.queued_events.fetch_add(1, Ordering::Relaxed);
            s.queue_wait_max_ns.fetch_max(now.saturating_duration_since(received).as_nanos() as u64, Ordering::Relaxed);
        }
    }

    /// Fills the interleaved frames of `out` (a trailing partial frame is
    /// zeroed): first the events `queued` yields (live sources, applied
    /// before the buffer's first sample), then the scheduled events at
    /// their samples. Channel 1 is the drive / volts_per_full_scale,
    /// channel 2 (a two-channel design) the amplitude / a_max, further
    /// channels 0; all times the gain. No allocation, no locking.
    pub fn process(&mut self, out: &mut [f32], mut queued: impl FnMut() -> Option<TouchEvent>) {
        let ch = self.channels;
        let frames = out.len() / ch;
        out[frames * ch..].fill(0.0);
        let mut now: Option<Instant> = None;
        let t_start = self.renderer.now_s();
        while let Some(event) = queued() {
            if event.received.is_some() && now.is_none() {
                now = Some(Instant::now());
            }
            self.apply(event, t_start, now);
        }
        let mut done = 0usize;
        while done < frames {
            // Scheduled events due at or before the next sample.
            let n_now = self.renderer.samples_rendered();
            let mut end = frames;
            while let Some(&event) = self.schedule.get(self.next) {
                // The first sample at or after the event (a micro-sample of
                // slack for times like k / 120 s rounded in f64).
                let due = (event.t_s * self.fs - 1e-6).ceil().max(0.0) as u64;
                if due <= n_now {
                    self.apply(event, n_now as f64 / self.fs, None);
                    self.next += 1;
                } else {
                    end = end.min(done + (due - n_now).min(frames as u64) as usize);
                    break;
                }
            }
            self.render(&mut out[done * ch..end * ch]);
            done = end;
        }
        let status = &self.status;
        status.frames.fetch_add(frames as u64, Ordering::Relaxed);
        if self.stopping && self.gain == 0.0 {
            status.finished.store(true, Ordering::Relaxed);
        }
    }

    /// Renders whole frames into `out` with the gain and the last clamp.
    fn render(&mut self, out: &mut [f32]) {
        let ch = self.channels;
        let n = out.len() / ch;
        let Self {
            renderer,
            scale_1,
            scale_2,
            limit_1,
            gain,
            gain_step,
            gap_s,
            last_report_s,
            stopping,
            stop_at_s,
            status,
            ..
        } = self;
        let touching = renderer.is_touching();
        let (scale_1, scale_2, limit_1, gain_step, gap_s, last_report_s, stop_at_s) =
            (*scale_1, *scale_2, *limit_1 as f32, *gain_step, *gap_s, *last_report_s, *stop_at_s);
        let mut g = *gain;
        let mut stop = *stopping;
        let (mut clamped, mut non_finite) = (0u64, 0u64);
        let mut peak = status.peak();
        let mut last = None;
        renderer.render_live(n, |i, s| {
            last = Some(s);
            stop |= s.t_s >= stop_at_s;
            let on = touching && !stop && s.t_s - last_report_s <= gap_s;
            g = if on { (g + gain_step).min(1.0) } else { (g - gain_step).max(0.0) };
            let mut v1 = (s.signal_v * g * scale_1) as f32;
            let mut v2 = (s.amplitude_um * g * scale_2) as f32;
            if !(v1.is_finite() && v2.is_finite()) {
                // Cannot happen with a valid renderer: write 0, stop at once.
                non_finite += 1;
                (v1, v2, g, stop) = (0.0, 0.0, 0.0, true);
            }
            if v1.abs() > limit_1 {
                clamped += 1;
                v1 = v1.clamp(-limit_1, limit_1);
            }
            if !(0.0..=1.0).contains(&v2) {
                clamped += 1;
                v2 = v2.clamp(0.0, 1.0);
            }
            peak = peak.max(v1.abs());
            let frame = &mut out[i * ch..(i + 1) * ch];
            frame[0] = v1;
            if ch > 1 {
                frame[1] = v2;
                frame[2..].fill(0.0);
            }
        });
        self.gain = g;
        self.stopping = stop;
        let status = &self.status;
        if let Some(s) = last {
            status.last_x_mm_bits.store(s.x_mm.to_bits(), Ordering::Relaxed);
            status.last_y_mm_bits.store(s.y_mm.to_bits(), Ordering::Relaxed);
            status.last_envelope_v_bits.store(s.envelope_v.to_bits(), Ordering::Relaxed);
            status.last_gain_bits.store(g.to_bits(), Ordering::Relaxed);
            status.last_amplitude_um_bits.store(s.amplitude_um.to_bits(), Ordering::Relaxed);
        }
        status.peak_bits.store(u64::from(peak.to_bits()), Ordering::Relaxed);
        if clamped > 0 {
            status.clamped_samples.fetch_add(clamped, Ordering::Relaxed);
        }
        if non_finite > 0 {
            status.non_finite_samples.fetch_add(non_finite, Ordering::Relaxed);
        }
    }
}

/// One line of a live touch stream (`haptex live --stdin`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TouchLine {
    /// On a line: `x_mm` (stamped on arrival) or `t_s,x_mm` (the sender's clock).
    At { t_s: Option<f64>, x_mm: f64 },
    /// Over a map: `x_mm,y_mm` (stamped on arrival) or `t_s,x_mm,y_mm`.
    AtXY { t_s: Option<f64>, x_mm: f64, y_mm: f64 },
    /// `lift` (or `up`): the finger left the surface.
    Lift,
}

/// Largest clock-rate difference between a touch sender and the output
/// that [`TouchStamper`] follows: 1000 ppm (crystal clocks differ by under
/// 100 ppm).
pub const CLOCK_DRIFT: f64 = 1e-3;

/// Maps touch lines onto the output clock: a line without a time at its
/// arrival; a line with the sender's `t_s` at t_s + offset, the offset
/// being the smallest arrival - t_s seen (the fastest delivery), allowed to
/// rise by [`CLOCK_DRIFT`] per second of sender time, so that a sender
/// clock running slower than the output's does not leave the stamps ever
/// further behind (which would look like a gap and fade the output out).
/// No stamp is later than its arrival.
#[derive(Debug, Clone, Copy, Default)]
pub struct TouchStamper {
    offset: Option<(f64, f64)>,
}

impl TouchStamper {
    /// The output-clock time and the touch of `line`, which arrived at
    /// `arrival_s` on the output clock.
    pub fn stamp(&mut self, line: TouchLine, arrival_s: f64) -> (f64, Touch) {
        let (sent, touch) = match line {
            TouchLine::Lift => return (arrival_s, Touch::Lift),
            TouchLine::At { t_s, x_mm } => (t_s, Touch::At(x_mm)),
            TouchLine::AtXY { t_s, x_mm, y_mm } => (t_s, Touch::AtXY(x_mm, y_mm)),
        };
        let Some(t) = sent else {
            return (arrival_s, touch);
        };
        let delay = arrival_s - t;
        let offset = match self.offset {
            Some((offset, t_last)) => (offset + CLOCK_DRIFT * (t - t_last).abs()).min(delay),
            None => delay,
        };
        self.offset = Some((offset, t));
        ((t + offset).min(arrival_s), touch)
    }
}

impl TouchEvent {
    /// The event of `line`, received at wall-clock instant `received`,
    /// which is `arrival_s` on the output clock (`DeviceClock::time_of`),
    /// stamped by `stamper` (a live source: stdin, a WebSocket). The lines
    /// of one message share one `arrival_s`, read once: read per line, a
    /// callback publishing between two lines moves the clock under them,
    /// and lines sent together would arrive microseconds apart.
    pub fn received(line: TouchLine, received: Instant, arrival_s: f64, stamper: &mut TouchStamper) -> Self {
        let (t_s, touch) = stamper.stamp(line, arrival_s);
        Self { t_s, touch, received: Some(received) }
    }

    /// A lift-off now, on `clock` (a source that went away or sent a bad line).
    pub fn lift_now(clock: &DeviceClock) -> Self {
        let now = Instant::now();
        Self { t_s: clock.time_of(now), touch: Touch::Lift, received: Some(now) }
    }
}

/// Parses one line of a touch stream, `lift` or `up`, or a position: on a
/// line ([`TouchAxes::X`]) `x_mm` or `t_s,x_mm` (more columns, e.g. y, are
/// ignored); over a map ([`TouchAxes::XY`]) `x_mm,y_mm` or
/// `t_s,x_mm,y_mm` (more columns ignored). Blank lines, `#` comments and a
/// header (a first field that is `x_mm` or `t_s`) give `None`. The error
/// names the field; the caller adds where the line came from.
pub fn parse_touch_line(line: &str, axes: TouchAxes) -> Result<Option<TouchLine>, String> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') {
        return Ok(None);
    }
    if line.eq_ignore_ascii_case("lift") || line.eq_ignore_ascii_case("up") {
        return Ok(Some(TouchLine::Lift));
    }
    let fields: Vec<&str> = line.split(',').map(str::trim).collect();
    if matches!(fields[0], "x_mm" | "t_s") {
        return Ok(None);
    }
    let number = |name: &str, text: &str| -> Result<f64, String> {
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!("field '{name}': expected a finite number, got '{text}'")),
        }
    };
    match (axes, fields.len()) {
        (TouchAxes::X, 1) => Ok(Some(TouchLine::At { t_s: None, x_mm: number("x_mm", fields[0])? })),
        (TouchAxes::X, _) => {
            let t_s = number("t_s", fields[0])?;
            Ok(Some(TouchLine::At { t_s: Some(t_s), x_mm: number("x_mm", fields[1])? }))
        }
        (TouchAxes::XY, 1) => {
            Err(format!("field 'y_mm': missing (over a map a position is x_mm,y_mm or t_s,x_mm,y_mm), got '{line}'"))
        }
        (TouchAxes::XY, 2) => {
            let x_mm = number("x_mm", fields[0])?;
            Ok(Some(TouchLine::AtXY { t_s: None, x_mm, y_mm: number("y_mm", fields[1])? }))
        }
        (TouchAxes::XY, _) => {
            let t_s = number("t_s", fields[0])?;
            let x_mm = number("x_mm", fields[1])?;
            Ok(Some(TouchLine::AtXY { t_s: Some(t_s), x_mm, y_mm: number("y_mm", fields[2])? }))
        }
    }
}
