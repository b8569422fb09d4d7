//! A live output for tests: the core's `LiveEngine` (the one `haptex serve
//! --live` runs in its cpal callback) called by a thread every 5 ms for
//! 5 ms of frames, as a device would, the frames kept in memory instead of
//! played. The server's live module sees a `LiveOutput` like the binary's.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, SyncSender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use haptex_core::live::{DeviceClock, LiveConfig, LiveEngine, LiveFigures, LiveStatus, TouchEvent};
use haptex_core::realtime::{RealtimeConfig, RealtimeRenderer};
use haptex_server::live::{LiveDesign, LiveInfo, LiveOutput, LiveSession};

/// Frames per callback: 5 ms at 48 kHz.
const FRAMES: usize = 240;

#[derive(Debug)]
pub struct PacedOutput {
    info: LiveInfo,
    config: RealtimeConfig,
    channels: usize,
    /// Designs opened and sessions closed so far.
    pub opened: Arc<AtomicUsize>,
    pub closed: Arc<AtomicUsize>,
    /// Every frame written, interleaved, as fractions of full scale.
    pub captured: Arc<Mutex<Vec<f32>>>,
}

impl PacedOutput {
    /// 48 kHz, U_max 100 V, full scale sqrt(2) x 100 V, 1 kHz sine; two
    /// channels with `a_max_um`.
    pub fn new(a_max_um: Option<f64>) -> Self {
        let config = RealtimeConfig::default();
        let info = LiveInfo {
            device: "paced test output".into(),
            sample_rate_hz: config.sample_rate_hz,
            buffer_frames: Some(FRAMES as u32),
            u_max_v: config.limits.u_max_v,
            volts_per_full_scale: config.volts_per_full_scale,
            a_max_um,
            carrier: "sine 1000 Hz".into(),
            ramp_ms: 20.0,
            gap_ms: 60_000.0,
        };
        Self {
            info,
            config,
            channels: if a_max_um.is_some() { 2 } else { 1 },
            opened: Arc::default(),
            closed: Arc::default(),
            captured: Arc::default(),
        }
    }
}

impl LiveOutput for PacedOutput {
    fn info(&self) -> &LiveInfo {
        &self.info
    }

    fn open(&self, design: LiveDesign) -> Result<Box<dyn LiveSession>, String> {
        let renderer = match (&design.amplitude, self.info.a_max_um) {
            (Some(a), Some(a_max)) => RealtimeRenderer::two_channel(&design.curve, a, a_max, &self.config),
            _ => RealtimeRenderer::new(&design.curve, &self.config),
        }
        .map_err(|e| e.to_string())?;
        let peak_bound_v = renderer.peak_bound_v();
        let live =
            LiveConfig { channels: self.channels, ramp_s: self.info.ramp_ms * 1e-3, gap_s: self.info.gap_ms * 1e-3 };
        let engine = LiveEngine::new(renderer, &live).map_err(|e| e.to_string())?;
        let status = engine.status();
        let clock = Arc::new(DeviceClock::new(self.info.sample_rate_hz));
        let (sender, receiver) = std::sync::mpsc::sync_channel(1024);
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (clock, stop, captured) = (Arc::clone(&clock), Arc::clone(&stop), Arc::clone(&self.captured));
            std::thread::spawn(move || pace(engine, receiver, &clock, &stop, &captured))
        };
        self.opened.fetch_add(1, Ordering::SeqCst);
        Ok(Box::new(PacedSession {
            clock,
            sender,
            status,
            stop,
            thread: Some(thread),
            peak_bound_v,
            closed: Arc::clone(&self.closed),
        }))
    }
}

/// The device: a buffer every 5 ms until the stop has faded out.
fn pace(
    mut engine: LiveEngine,
    receiver: Receiver<TouchEvent>,
    clock: &DeviceClock,
    stop: &AtomicBool,
    captured: &Mutex<Vec<f32>>,
) {
    let mut buffer = vec![0.0f32; FRAMES * engine.channels()];
    let status = engine.status();
    loop {
        clock.publish(status.frames.load(Ordering::Relaxed), Instant::now());
        if stop.load(Ordering::Relaxed) {
            engine.stop();
        }
        engine.process(&mut buffer, || receiver.try_recv().ok());
        captured.lock().unwrap().extend_from_slice(&buffer);
        if engine.is_finished() {
            return;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

struct PacedSession {
    clock: Arc<DeviceClock>,
    sender: SyncSender<TouchEvent>,
    status: Arc<LiveStatus>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    peak_bound_v: f64,
    closed: Arc<AtomicUsize>,
}

impl LiveSession for PacedSession {
    fn clock(&self) -> &DeviceClock {
        &self.clock
    }

    fn queue(&self, event: TouchEvent) -> bool {
        self.sender.try_send(event).is_ok()
    }

    fn figures(&self) -> LiveFigures {
        self.status.figures(48_000, FRAMES as f64 / 48_000.0, 0)
    }

    fn failure(&self) -> Option<String> {
        None
    }

    fn peak_bound_v(&self) -> f64 {
        self.peak_bound_v
    }

    fn close(mut self: Box<Self>) -> LiveFigures {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(thread) = self.thread.take() {
            thread.join().unwrap();
        }
        self.closed.fetch_add(1, Ordering::SeqCst);
        self.figures()
    }
}

impl Drop for PacedSession {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
