//! `haptex serve --live`: the web page's live output on an audio device.
//!
//! [`ServedOutput`] is the server's [`LiveOutput`]: each design the page
//! sends opens the device on a thread of its own (which owns the cpal
//! stream) with the options of `haptex live`, and the [`ServedSession`]
//! the server holds queues the page's touches, reads the figures and
//! closes the stream (faded) when the page stops, sends another design or
//! goes away.

use std::sync::mpsc::SyncSender;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::bail;
use haptex_core::live::{DeviceClock, LiveFigures, LiveStatus, TouchEvent};
use haptex_core::num::Num;
use haptex_server::live::{LiveDesign, LiveInfo, LiveOutput, LiveSession};

use super::OutputArgs;
use super::device::{Playing, Shared, engine, renderer, resolve};

/// A device stalled this long (no frames asked for) counts as failed.
const STALL: Duration = Duration::from_secs(2);

/// The live output of `haptex serve --live`.
#[derive(Debug)]
pub struct ServedOutput {
    output: OutputArgs,
    channels: u16,
    info: LiveInfo,
}

impl ServedOutput {
    /// The output of these options, its device checked now (it exists and
    /// takes a stream of this many channels at this rate) so that a wrong
    /// `--device` fails at start rather than when a page goes live.
    pub fn new(output: OutputArgs) -> anyhow::Result<Self> {
        output.check()?;
        let a_max_um = output.drive.given_a_max_um();
        let design_channels: u16 = if a_max_um.is_some() { 2 } else { 1 };
        let channels = output.channels.unwrap_or(design_channels);
        if channels < design_channels {
            bail!(
                "--a-max-um gives the output an ultrasonic channel (channel 2): give --channels {design_channels} or more"
            );
        }
        let resolved = resolve(&output, channels)?;
        let settings = output.drive.settings(resolved.sample_rate);
        settings.check()?;
        let info = LiveInfo {
            device: resolved.name.clone(),
            sample_rate_hz: resolved.sample_rate,
            buffer_frames: resolved.buffer_frames,
            u_max_v: settings.limits.u_max_v,
            volts_per_full_scale: output.drive.volts_per_full_scale(),
            a_max_um,
            carrier: format!("{} {} Hz", settings.carrier.shape.name(), Num(settings.carrier.frequency_hz)),
            ramp_ms: output.ramp_ms,
            gap_ms: output.gap_ms,
        };
        Ok(Self { output, channels, info })
    }
}

impl LiveOutput for ServedOutput {
    fn info(&self) -> &LiveInfo {
        &self.info
    }

    fn open(&self, design: LiveDesign) -> Result<Box<dyn LiveSession>, String> {
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let (close_tx, close_rx) = std::sync::mpsc::channel::<()>();
        let (output, channels, a_max_um) = (self.output.clone(), self.channels, self.info.a_max_um);
        let thread = std::thread::Builder::new()
            .name("haptex-live-output".into())
            .spawn(move || {
                let started = (|| {
                    let resolved = resolve(&output, channels)?;
                    let amplitude = design.amplitude.as_ref().zip(a_max_um);
                    let renderer = renderer(&output, resolved.sample_rate, &design.curve, amplitude)?;
                    let peak_bound_v = renderer.peak_bound_v();
                    let engine = engine(&output, renderer, channels)?;
                    anyhow::Ok((Playing::start(&resolved, engine)?, peak_bound_v, resolved.sample_rate))
                })();
                match started {
                    Err(e) => {
                        let _ = ready_tx.send(Err(format!("{e:#}")));
                    }
                    Ok((playing, peak_bound_v, sample_rate)) => {
                        let handles = Handles {
                            status: Arc::clone(&playing.status),
                            shared: Arc::clone(&playing.shared),
                            clock: Arc::clone(&playing.clock),
                            sender: playing.sender.clone(),
                            peak_bound_v,
                            sample_rate,
                        };
                        let _ = ready_tx.send(Ok(handles));
                        // Until the session closes (or is dropped).
                        let _ = close_rx.recv();
                        playing.close();
                    }
                }
            })
            .map_err(|e| format!("cannot start the output thread: {e}"))?;
        match ready_rx.recv() {
            Ok(Ok(handles)) => Ok(Box::new(ServedSession {
                handles,
                close: Some(close_tx),
                thread: Some(thread),
                progress: Mutex::new((0, Instant::now())),
            })),
            Ok(Err(message)) => {
                let _ = thread.join();
                Err(message)
            }
            Err(_) => {
                let _ = thread.join();
                Err("the output thread ended before the device opened".into())
            }
        }
    }
}

/// What the session shares with the stream's thread.
struct Handles {
    status: Arc<LiveStatus>,
    shared: Arc<Shared>,
    clock: Arc<DeviceClock>,
    sender: SyncSender<TouchEvent>,
    peak_bound_v: f64,
    sample_rate: u32,
}

/// A design playing for the page.
pub struct ServedSession {
    handles: Handles,
    /// Dropping (or sending on) it makes the stream's thread fade and close.
    close: Option<std::sync::mpsc::Sender<()>>,
    thread: Option<JoinHandle<()>>,
    /// Frames written at the last look, and when they last moved (a
    /// stalled device is a failure).
    progress: Mutex<(u64, Instant)>,
}

impl ServedSession {
    /// Closes the stream (faded) and waits for its thread.
    fn finish(&mut self) {
        self.close.take();
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl LiveSession for ServedSession {
    fn clock(&self) -> &DeviceClock {
        &self.handles.clock
    }

    fn queue(&self, event: TouchEvent) -> bool {
        self.handles.sender.try_send(event).is_ok()
    }

    fn figures(&self) -> LiveFigures {
        self.handles.shared.figures(&self.handles.status, self.handles.sample_rate)
    }

    fn failure(&self) -> Option<String> {
        if let Some(error) = self.handles.shared.device_error() {
            return Some(format!("output device error: {error}"));
        }
        if self.handles.status.non_finite_samples.load(std::sync::atomic::Ordering::Relaxed) > 0 {
            return Some("the renderer produced non-finite samples".into());
        }
        let frames = self.handles.status.frames.load(std::sync::atomic::Ordering::Relaxed);
        let mut progress = self.progress.lock().ok()?;
        if frames != progress.0 {
            *progress = (frames, Instant::now());
            None
        } else {
            (progress.1.elapsed() > STALL)
                .then(|| format!("the output device stopped asking for samples (after {frames} frames)"))
        }
    }

    fn peak_bound_v(&self) -> f64 {
        self.handles.peak_bound_v
    }

    fn close(mut self: Box<Self>) -> LiveFigures {
        self.finish();
        self.figures()
    }
}

impl Drop for ServedSession {
    fn drop(&mut self) {
        self.finish();
    }
}
