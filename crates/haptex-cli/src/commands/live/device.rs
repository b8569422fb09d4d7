//! The audio device of `haptex live` and `haptex serve --live` (cpal).

use std::io::BufRead;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use cpal::traits::{DeviceTrait, HostTrait, StreamTrait};
use cpal::{FromSample, SampleFormat, SizedSample};
use haptex_core::live::{
    DeviceClock, LiveConfig, LiveEngine, LiveFigures, LiveRenderer, LiveStatus, Touch, TouchAxes, TouchEvent,
    TouchStamper,
};
use haptex_core::map::VoltageMap;
use haptex_core::num::Num;
use haptex_core::planar::PlanarTrajectory;
use haptex_core::realtime::{PlanarRenderer, RealtimeConfig, RealtimeRenderer};
use haptex_core::signal::{AmplitudeCurve, SignalError, VoltageCurve};
use haptex_core::trajectory::Trajectory;
use serde_json::json;

use super::{LiveArgs, OutputArgs};
use crate::commands::play::read_design;

/// Touch events queued between the input thread and the callback.
const QUEUE: usize = 1024;
/// Frames per conversion chunk in the callback (the scratch buffer).
const CHUNK_FRAMES: usize = 4096;

/// Set by SIGINT / SIGTERM: fade out and end.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    INTERRUPTED.store(true, Ordering::Relaxed);
}

/// What the callback shares with the main thread beyond the engine's
/// status: the stop request and cpal's reported buffer latency.
#[derive(Default)]
pub(super) struct Shared {
    stop: AtomicBool,
    callbacks: AtomicU64,
    output_latency_min_ns: AtomicU64,
    output_latency_max_ns: AtomicU64,
    callback_busy_ns: AtomicU64,
    callback_busy_max_ns: AtomicU64,
    xruns: AtomicU64,
    realtime_denied: AtomicBool,
    errors: Mutex<Vec<String>>,
}

/// An output device chosen and checked: name, rate, channels, format.
pub(super) struct Resolved {
    device: cpal::Device,
    pub name: String,
    pub sample_rate: u32,
    pub channels: u16,
    pub format: SampleFormat,
    pub buffer_frames: Option<u32>,
}

/// The device of `output` (its name, or the host's default) at its rate
/// (`--sample-rate`, else the device's default), with `channels`
/// channels, in a sample format it takes.
pub(super) fn resolve(output: &OutputArgs, channels: u16) -> anyhow::Result<Resolved> {
    let host = cpal::default_host();
    let device = find_device(&host, output.device.as_deref())?;
    let name = device.id().map(|id| id.id().to_string()).unwrap_or_else(|_| "(unnamed)".into());
    let default_config = device
        .default_output_config()
        .with_context(|| format!("device {name} (haptex live --list-devices lists the output devices)"))?;
    let sample_rate = output.sample_rate.unwrap_or(default_config.sample_rate());
    let format = pick_format(&device, &name, channels, sample_rate)?;
    Ok(Resolved { device, name, sample_rate, channels, format, buffer_frames: output.buffer_frames })
}

/// The renderer of a design for `output`'s drive at `sample_rate`: one
/// channel, or two with the amplitude curve and channel 2's a_max. A
/// design whose peak exceeds the full scale is refused, saying which
/// option to change.
pub(super) fn renderer(
    output: &OutputArgs,
    sample_rate: u32,
    curve: &VoltageCurve,
    amplitude: Option<(&AmplitudeCurve, f64)>,
) -> anyhow::Result<RealtimeRenderer> {
    let config = realtime_config(output, sample_rate)?;
    match amplitude {
        Some((amplitude, a_max)) => RealtimeRenderer::two_channel(curve, amplitude, a_max, &config),
        None => RealtimeRenderer::new(curve, &config),
    }
    .map_err(full_scale_hint)
}

/// The renderer of a voltage map for `output`'s drive at `sample_rate`
/// (one channel; the map's edge held beyond it, as `haptex play
/// --voltage-map` does: another --outside is refused). A map whose peak
/// exceeds the full scale is refused, saying which option to change.
pub(super) fn planar_renderer(
    output: &OutputArgs,
    sample_rate: u32,
    map: &VoltageMap,
) -> anyhow::Result<PlanarRenderer> {
    PlanarRenderer::new(map, &realtime_config(output, sample_rate)?).map_err(full_scale_hint)
}

/// The real-time settings of `output`'s drive at `sample_rate`.
fn realtime_config(output: &OutputArgs, sample_rate: u32) -> anyhow::Result<RealtimeConfig> {
    let settings = output.drive.settings(sample_rate);
    settings.check()?;
    Ok(RealtimeConfig {
        sample_rate_hz: sample_rate,
        carrier: settings.carrier,
        limits: settings.limits,
        extend: settings.extend,
        volts_per_full_scale: output.drive.volts_per_full_scale(),
        horizon_s: output.horizon_ms * 1e-3,
        blend_s: output.blend_ms * 1e-3,
        table_points: None,
    })
}

/// A renderer's refusal, naming the option to change for a peak above the full scale.
fn full_scale_hint(e: SignalError) -> anyhow::Error {
    match e {
        SignalError::ExceedsFullScale { amplitude_v, volts_per_full_scale } => anyhow::anyhow!(
            "refused: the drive's peak {amplitude_v:.3} V exceeds the output's full scale of {} V \
             (--volts-per-full-scale); raise it to at least {amplitude_v:.3} V or lower --u-max",
            Num(volts_per_full_scale)
        ),
        other => other.into(),
    }
}

/// The engine of `renderer` on `channels` device channels with
/// `output`'s fades.
pub(super) fn engine<R: LiveRenderer>(
    output: &OutputArgs,
    renderer: R,
    channels: u16,
) -> anyhow::Result<LiveEngine<R>> {
    let config =
        LiveConfig { channels: usize::from(channels), ramp_s: output.ramp_ms * 1e-3, gap_s: output.gap_ms * 1e-3 };
    Ok(LiveEngine::new(renderer, &config)?)
}

/// A stream playing an engine on a device, and what its callback shares.
pub(super) struct Playing {
    stream: cpal::Stream,
    pub status: Arc<LiveStatus>,
    pub clock: Arc<DeviceClock>,
    pub shared: Arc<Shared>,
    pub sender: SyncSender<TouchEvent>,
    sample_rate: u32,
    buffer_frames: Option<u32>,
}

impl Playing {
    /// Builds the stream of `engine` on the resolved device and starts it.
    pub fn start<R: LiveRenderer + 'static>(resolved: &Resolved, engine: LiveEngine<R>) -> anyhow::Result<Self> {
        let status = engine.status();
        let clock = Arc::new(DeviceClock::new(resolved.sample_rate));
        let shared = Arc::new(Shared { output_latency_min_ns: AtomicU64::new(u64::MAX), ..Shared::default() });
        let (sender, receiver) = std::sync::mpsc::sync_channel::<TouchEvent>(QUEUE);
        let stream_config = cpal::StreamConfig {
            channels: resolved.channels,
            sample_rate: resolved.sample_rate,
            buffer_size: match resolved.buffer_frames {
                Some(n) => cpal::BufferSize::Fixed(n),
                None => cpal::BufferSize::Default,
            },
        };
        let device = &resolved.device;
        let stream = match resolved.format {
            SampleFormat::F32 => build::<f32, R>(device, &stream_config, engine, receiver, &clock, &shared),
            SampleFormat::I32 => build::<i32, R>(device, &stream_config, engine, receiver, &clock, &shared),
            SampleFormat::I16 => build::<i16, R>(device, &stream_config, engine, receiver, &clock, &shared),
            SampleFormat::F64 => build::<f64, R>(device, &stream_config, engine, receiver, &clock, &shared),
            other => bail!("sample format {other} is not supported"),
        }
        .with_context(|| {
            format!(
                "opening {} ({} channels, {} Hz, {}, {stream_config:?})",
                resolved.name, resolved.channels, resolved.sample_rate, resolved.format
            )
        })?;
        stream.play().with_context(|| format!("starting {}", resolved.name))?;
        Ok(Self {
            stream,
            status,
            clock,
            shared,
            sender,
            sample_rate: resolved.sample_rate,
            buffer_frames: resolved.buffer_frames,
        })
    }

    /// The first error the device reported (beyond underruns), if any.
    pub fn device_error(&self) -> Option<String> {
        self.shared.device_error()
    }

    /// Fades out (at most 2 s of waiting for the fade), lets the faded
    /// samples reach the converter (the device latency and two buffers,
    /// at most 1 s), and closes the stream.
    pub fn close(self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        let waited = Instant::now();
        while !self.status.finished.load(Ordering::Relaxed) && waited.elapsed() < Duration::from_secs(2) {
            if self.device_error().is_some() {
                break;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        let buffer_s = self.buffer_frames.map_or(0.05, |n| f64::from(n) / f64::from(self.sample_rate));
        let latency_max_s = ns_s(self.shared.output_latency_max_ns.load(Ordering::Relaxed));
        std::thread::sleep(Duration::from_secs_f64((latency_max_s + 2.0 * buffer_s).min(1.0)));
        let _ = self.stream.pause();
        drop(self.stream);
    }
}

impl Shared {
    /// The figures of `status` with what the device reported.
    pub fn figures(&self, status: &LiveStatus, sample_rate: u32) -> LiveFigures {
        status.figures(
            sample_rate,
            ns_s(self.output_latency_max_ns.load(Ordering::Relaxed)),
            self.xruns.load(Ordering::Relaxed),
        )
    }

    /// The first error the device reported (beyond underruns), if any.
    pub fn device_error(&self) -> Option<String> {
        self.errors.lock().ok().and_then(|e| e.first().cloned())
    }
}

pub fn run(args: LiveArgs) -> anyhow::Result<()> {
    if args.list_devices {
        return list_devices(&cpal::default_host());
    }
    let output = &args.output;
    let design =
        args.profile.as_deref().or(args.voltage_map.as_deref()).context("give --profile U.csv or --voltage-map MAP")?;
    if args.stdin && design.as_os_str() == "-" {
        bail!("--profile - and --stdin both read stdin: give the design as a file");
    }
    output.check()?;
    if args.touch_log.is_none() && !args.stdin && args.ws.is_none() {
        bail!("give --touch-log T.csv, --stdin or --ws ADDR");
    }
    // The page's token is checked before the device is opened.
    if args.ws.is_some() {
        args.token.given()?;
    } else if args.token != crate::args::TokenArgs::default() {
        bail!("--token and --token-file are for the page of --ws");
    }
    if args.voltage_map.is_some() {
        return run_map(&args, design);
    }
    let profile = design;
    let design = read_design(profile)?;
    let a_max_um = output.drive.a_max_um(profile, design.amplitude.as_ref(), design.stated_a_max())?;
    let design_channels: u16 = if a_max_um.is_some() { 2 } else { 1 };
    // The touch log is read (and refused) before the device is opened.
    let log = args.touch_log.as_deref().map(Trajectory::read_csv_file).transpose()?;
    let resolved = resolve(output, output.channels.unwrap_or(design_channels))?;
    // A frequency-dependent design renders its target only on its carrier.
    design.check_carrier(
        &output.drive.settings(resolved.sample_rate).carrier,
        &profile.display().to_string(),
        &haptex_core::arg_names::ArgNames::CLI,
    )?;
    let renderer = renderer(output, resolved.sample_rate, &design.curve, design.amplitude.as_ref().zip(a_max_um))?;
    let mut engine = engine(output, renderer, resolved.channels)?;
    if let Some(log) = &log {
        let t0 = log.start_s();
        let events = log
            .t_s()
            .iter()
            .zip(log.x_mm())
            .map(|(&t, &x)| TouchEvent { t_s: t - t0, touch: Touch::At(x), received: None })
            .collect();
        engine = engine.with_schedule(events)?;
    }
    let what = if design_channels == 2 { "drive + ultrasonic amplitude" } else { "drive" };
    let channel_2 = a_max_um.map_or(String::new(), |a| format!(", channel 2 at {} um (a_max) per full scale", Num(a)));
    let (x0, x1) = design.curve.span_mm();
    play(&args, &resolved, engine, &format!("{what}){channel_2}"), PageArea { x_mm: (x0, x1), y_mm: None })
}

/// `haptex live --voltage-map`: the map's drive at the (x, y) positions of
/// a planar touch log (`t_s,x_mm,y_mm`), of stdin's or of the page's.
fn run_map(args: &LiveArgs, path: &std::path::Path) -> anyhow::Result<()> {
    let output = &args.output;
    let map = crate::commands::map::read_voltage_map(path)?;
    let log = match &args.touch_log {
        Some(log) => {
            let name = log.display().to_string();
            let file = std::fs::File::open(log).with_context(|| format!("cannot open {name}"))?;
            Some(PlanarTrajectory::read_csv(std::io::BufReader::new(file), &name)?)
        }
        None => None,
    };
    let resolved = resolve(output, output.channels.unwrap_or(1))?;
    let renderer = planar_renderer(output, resolved.sample_rate, &map)
        .with_context(|| format!("the voltage map {}", path.display()))?;
    let mut engine = engine(output, renderer, resolved.channels)?;
    if let Some(log) = &log {
        let t0 = log.t_s()[0];
        let events = (0..log.len())
            .map(|k| TouchEvent {
                t_s: log.t_s()[k] - t0,
                touch: Touch::AtXY(log.x_mm()[k], log.y_mm()[k]),
                received: None,
            })
            .collect();
        engine = engine.with_schedule(events)?;
    }
    let g = &map.grid;
    let area = PageArea { x_mm: (g.x0_mm, g.x(g.nx - 1)), y_mm: Some((g.y0_mm, g.y(g.ny - 1))) };
    play(args, &resolved, engine, &format!("drive over a {} x {} map)", g.nx, g.ny), area)
}

/// What the live page spans: x, and y over a map.
#[derive(Debug, Clone, Copy)]
struct PageArea {
    x_mm: (f64, f64),
    y_mm: Option<(f64, f64)>,
}

/// Plays `engine` on the resolved device from the touch source of `args`
/// until the log ends, the input ends, an error or a signal; then the
/// fade, the close and the report. `what` ends the start line's
/// description of the channels.
fn play<R: LiveRenderer + 'static>(
    args: &LiveArgs,
    resolved: &Resolved,
    engine: LiveEngine<R>,
    what: &str,
    area: PageArea,
) -> anyhow::Result<()> {
    let output = &args.output;
    let (device_name, sample_rate, channels, format) =
        (resolved.name.clone(), resolved.sample_rate, resolved.channels, resolved.format);
    let peak_bound_v = engine.renderer().peak_bound_v();
    // SAFETY: the handler only stores to an atomic (async-signal-safe).
    unsafe {
        libc::signal(libc::SIGINT, on_signal as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, on_signal as *const () as libc::sighandler_t);
    }
    let cpu_before = cpu_time_s();
    let started = Instant::now();
    let playing = Playing::start(resolved, engine)?;
    let (status, shared, clock) =
        (Arc::clone(&playing.status), Arc::clone(&playing.shared), Arc::clone(&playing.clock));
    if !args.quiet {
        eprintln!(
            "live: {device_name}, {sample_rate} Hz, {channels} channel{} ({what}, {format}, buffer {}; channel 1 at {} V per \
             full scale (peak bound {:.3} V)",
            if channels == 1 { "" } else { "s" },
            output.buffer_frames.map_or("device default".to_string(), |n| format!("{n} frames")),
            Num(output.drive.volts_per_full_scale()),
            peak_bound_v,
        );
    }
    let input_error: Arc<Mutex<Option<String>>> = Arc::new(Mutex::new(None));
    if args.stdin {
        let (sender, clock, shared, input_error) =
            (playing.sender.clone(), Arc::clone(&clock), Arc::clone(&shared), Arc::clone(&input_error));
        std::thread::spawn(move || read_stdin(R::AXES, &sender, &clock, &shared, &input_error));
    } else if let Some(addr) = &args.ws {
        let state = WsState {
            sender: playing.sender.clone(),
            clock: Arc::clone(&clock),
            status: Arc::clone(&status),
            shared: Arc::clone(&shared),
            axes: R::AXES,
            area,
            sample_rate,
        };
        // The page drives the output: always behind a token.
        let given = args.token.given()?;
        let token = match &given {
            Some((token, _)) => token.clone(),
            None => haptex_server::access::Token::generate()?,
        };
        let query = crate::args::TokenArgs::query(&token, given.as_ref().map(|(_, source)| source.as_str()));
        let access = haptex_server::access::Access::open().with_token(token)?;
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let addr = addr.clone();
        std::thread::spawn(move || serve_ws(&addr, state, access, &ready_tx));
        let failure = match ready_rx.recv() {
            Ok(Ok(bound)) => {
                // Always printed: tests and scripts read the address from it.
                eprintln!(
                    "live: page http://{bound}/{query} , WebSocket ws://{bound}/live/ws with the page's cookie or \
                     'Authorization: Bearer TOKEN' (Ctrl-C ends)"
                );
                None
            }
            Ok(Err(e)) => Some(e),
            Err(_) => Some("the WebSocket server did not start".into()),
        };
        if let Some(message) = failure {
            playing.close();
            bail!("{message} (the output was faded to 0 V)");
        }
    }

    // Wait for the end: the log done (the engine stops itself), the
    // input ended, an error, or a signal; then the fade, then close.
    let mut last_frames = 0u64;
    let mut stalled_since = Instant::now();
    let mut failure: Option<String> = None;
    loop {
        std::thread::sleep(Duration::from_millis(5));
        if INTERRUPTED.load(Ordering::Relaxed) {
            shared.stop.store(true, Ordering::Relaxed);
        }
        if let Some(error) = playing.device_error() {
            failure.get_or_insert(format!("output device error: {error}"));
            shared.stop.store(true, Ordering::Relaxed);
        }
        if let Some(error) = input_error.lock().ok().and_then(|e| e.clone()) {
            failure.get_or_insert(error);
            shared.stop.store(true, Ordering::Relaxed);
        }
        if status.finished.load(Ordering::Relaxed) {
            break;
        }
        let frames = status.frames.load(Ordering::Relaxed);
        if frames != last_frames {
            (last_frames, stalled_since) = (frames, Instant::now());
        } else if stalled_since.elapsed() > Duration::from_secs(2) {
            failure.get_or_insert(format!("the output device stopped asking for samples (after {frames} frames)"));
            break;
        }
    }
    playing.close();
    let wall_s = started.elapsed().as_secs_f64();
    let cpu_s = cpu_time_s() - cpu_before;

    let report = report(args, &device_name, sample_rate, channels, format, &status, &shared, wall_s, cpu_s);
    if let Some(path) = &args.json {
        haptex_core::io::write_atomic(path, |w| {
            serde_json::to_writer_pretty(&mut *w, &report).map_err(std::io::Error::other)?;
            w.write_all(b"\n")
        })?;
    }
    if !args.quiet {
        print_report(&report);
    }
    if let Some(failure) = failure {
        bail!("{failure} (the output was faded to 0 V)");
    }
    if status.non_finite_samples.load(Ordering::Relaxed) > 0 {
        bail!("the renderer produced non-finite samples; the output was stopped at 0 V");
    }
    Ok(())
}

fn list_devices(host: &cpal::Host) -> anyhow::Result<()> {
    let default = host.default_output_device().and_then(|d| d.id().ok());
    let devices = host.output_devices().context("listing the output devices")?;
    println!("output devices of the {} host (give the name to --device):", host.id());
    for device in devices {
        let Ok(id) = device.id() else { continue };
        let description = device.description().map(|d| d.name().replace('\n', " ")).unwrap_or_default();
        let mark = if Some(&id) == default.as_ref() { " (default)" } else { "" };
        println!("  {}{mark}  {description}", id.id());
    }
    Ok(())
}

/// The device called `name` (its id, with or without the host prefix,
/// or its description's name), or the default output.
fn find_device(host: &cpal::Host, name: Option<&str>) -> anyhow::Result<cpal::Device> {
    let Some(name) = name else {
        return host
            .default_output_device()
            .context("no default output device: give --device NAME (see --list-devices)");
    };
    let devices: Vec<cpal::Device> = host.output_devices().context("listing the output devices")?.collect();
    let matches = |d: &cpal::Device| {
        d.id().is_ok_and(|id| id.id() == name || id.to_string() == name)
            || d.description().is_ok_and(|desc| desc.name() == name)
    };
    if let Some(device) = devices.iter().find(|d| matches(d)) {
        return Ok(device.clone());
    }
    let names: Vec<String> = devices.iter().filter_map(|d| d.id().ok().map(|id| id.id().to_string())).collect();
    bail!("no output device named '{name}'; the output devices are: {}", names.join(", "))
}

/// The sample format to open: f32 if the device takes it at this
/// channel count and rate, else i32, i16, f64.
fn pick_format(device: &cpal::Device, name: &str, channels: u16, rate: u32) -> anyhow::Result<SampleFormat> {
    let configs: Vec<_> =
        device.supported_output_configs().with_context(|| format!("the configurations of {name}"))?.collect();
    let fits = |f: SampleFormat| {
        configs.iter().any(|c| {
            c.sample_format() == f
                && c.channels() == channels
                && (c.min_sample_rate()..=c.max_sample_rate()).contains(&rate)
        })
    };
    if let Some(f) =
        [SampleFormat::F32, SampleFormat::I32, SampleFormat::I16, SampleFormat::F64].into_iter().find(|&f| fits(f))
    {
        return Ok(f);
    }
    let offered: Vec<String> = configs
        .iter()
        .map(|c| {
            format!("{} ch {}-{} Hz {}", c.channels(), c.min_sample_rate(), c.max_sample_rate(), c.sample_format())
        })
        .collect();
    bail!(
        "{name} takes no f32, i32, i16 or f64 stream of {channels} channels at {rate} Hz; it offers: {}",
        offered.join("; ")
    )
}

/// Builds the output stream whose callback runs the engine. The
/// callback allocates nothing and takes no lock: the engine renders
/// into a scratch buffer made here (converted to the device's sample
/// type), events come from the bounded channel's `try_recv` (its
/// receiver locks only to wake a blocked sender, and the senders never
/// block: `try_send`), the figures go to atomics. The error callback
/// (errors only) locks a mutex to record the message.
fn build<T, R: LiveRenderer + 'static>(
    device: &cpal::Device,
    config: &cpal::StreamConfig,
    mut engine: LiveEngine<R>,
    receiver: Receiver<TouchEvent>,
    clock: &Arc<DeviceClock>,
    shared: &Arc<Shared>,
) -> Result<cpal::Stream, cpal::Error>
where
    T: SizedSample + FromSample<f32>,
{
    let channels = engine.channels();
    let mut scratch = vec![0.0f32; CHUNK_FRAMES * channels];
    let (clock, callback_shared, error_shared) = (Arc::clone(clock), Arc::clone(shared), Arc::clone(shared));
    let status = engine.status();
    device.build_output_stream::<T, _, _>(
        *config,
        move |data: &mut [T], info: &cpal::OutputCallbackInfo| {
            let begun = Instant::now();
            let shared = &callback_shared;
            clock.publish(status.frames.load(Ordering::Relaxed), begun);
            let ts = info.timestamp();
            let latency_ns = ts.playback.duration_since(ts.callback).as_nanos() as u64;
            shared.output_latency_min_ns.fetch_min(latency_ns, Ordering::Relaxed);
            shared.output_latency_max_ns.fetch_max(latency_ns, Ordering::Relaxed);
            if shared.stop.load(Ordering::Relaxed) {
                engine.stop();
            }
            for chunk in data.chunks_mut(scratch.len()) {
                let out = &mut scratch[..chunk.len()];
                engine.process(out, || receiver.try_recv().ok());
                for (d, &v) in chunk.iter_mut().zip(out.iter()) {
                    *d = T::from_sample(v);
                }
            }
            let busy = begun.elapsed().as_nanos() as u64;
            shared.callbacks.fetch_add(1, Ordering::Relaxed);
            shared.callback_busy_ns.fetch_add(busy, Ordering::Relaxed);
            shared.callback_busy_max_ns.fetch_max(busy, Ordering::Relaxed);
        },
        move |error: cpal::Error| {
            // An underrun (the device played silence for a moment) or a
            // denied real-time priority is counted and the stream goes
            // on; anything else ends the run (the main thread fades out
            // and closes).
            match error.kind() {
                cpal::ErrorKind::Xrun => {
                    error_shared.xruns.fetch_add(1, Ordering::Relaxed);
                }
                cpal::ErrorKind::RealtimeDenied => {
                    error_shared.realtime_denied.store(true, Ordering::Relaxed);
                }
                _ => {
                    if let Ok(mut errors) = error_shared.errors.lock() {
                        errors.push(error.to_string());
                    }
                }
            }
        },
        None,
    )
}

/// The stdin touch source: one event per line (stamped by a [`TouchStamper`]). End of
/// input, a bad line or a full queue stop the output (faded).
fn read_stdin(
    axes: TouchAxes,
    sender: &SyncSender<TouchEvent>,
    clock: &DeviceClock,
    shared: &Shared,
    error: &Mutex<Option<String>>,
) {
    let mut stamper = TouchStamper::default();
    let fail = |message: String| {
        if let Ok(mut e) = error.lock() {
            e.get_or_insert(message);
        }
    };
    for (i, line) in std::io::stdin().lock().lines().enumerate() {
        let received = Instant::now();
        let line = match line {
            Ok(line) => line,
            Err(e) => return fail(format!("reading stdin, line {}: {e}", i + 1)),
        };
        let parsed = match haptex_core::live::parse_touch_line(&line, axes) {
            Ok(Some(p)) => p,
            Ok(None) => continue,
            Err(message) => return fail(format!("stdin, line {}, {message}", i + 1)),
        };
        match sender.try_send(TouchEvent::received(parsed, received, clock.time_of(received), &mut stamper)) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => {
                return fail(format!(
                    "stdin, line {}: more than {QUEUE} touches waiting for the output (is the device running?)",
                    i + 1
                ));
            }
            Err(TrySendError::Disconnected(_)) => return,
        }
    }
    // End of input: lost input, fade out.
    shared.stop.store(true, Ordering::Relaxed);
}

/// What the WebSocket handlers share.
#[derive(Clone)]
struct WsState {
    sender: SyncSender<TouchEvent>,
    clock: Arc<DeviceClock>,
    status: Arc<LiveStatus>,
    shared: Arc<Shared>,
    axes: TouchAxes,
    area: PageArea,
    sample_rate: u32,
}

/// The live page and its WebSocket, on a thread of their own (a
/// one-thread tokio runtime), under `access` (the token, the Origin
/// check: `haptex_server::access`); `ready` gets the bound address or why
/// not.
fn serve_ws(
    addr: &str,
    state: WsState,
    access: haptex_server::access::Access,
    ready: &std::sync::mpsc::Sender<Result<std::net::SocketAddr, String>>,
) {
    use axum::routing::get;
    let runtime = match tokio::runtime::Builder::new_current_thread().enable_all().build() {
        Ok(r) => r,
        Err(e) => {
            let _ = ready.send(Err(format!("starting the WebSocket server: {e}")));
            return;
        }
    };
    runtime.block_on(async move {
        let listener = match tokio::net::TcpListener::bind(addr).await {
            Ok(l) => l,
            Err(e) => {
                let _ = ready.send(Err(format!("--ws {addr}: cannot listen there: {e}")));
                return;
            }
        };
        let _ = ready.send(listener.local_addr().map_err(|e| e.to_string()));
        let access = Arc::new(access);
        let app = axum::Router::new().route("/", get(page)).route("/live/ws", get(ws_upgrade)).with_state(state).layer(
            axum::middleware::from_fn(move |request, next| {
                let access = Arc::clone(&access);
                async move { haptex_server::access::enforce(&access, request, next).await }
            }),
        );
        if let Err(e) = axum::serve(listener, app).await {
            eprintln!("live: the WebSocket server stopped: {e}");
        }
    });
}

async fn page(axum::extract::State(state): axum::extract::State<WsState>) -> axum::response::Html<String> {
    let ((x0, x1), y) = (state.area.x_mm, state.area.y_mm);
    let (y0, y1) = y.map_or(("null".to_string(), "null".to_string()), |(a, b)| (format!("{a:?}"), format!("{b:?}")));
    axum::response::Html(
        LIVE_PAGE
            .replace("{X0}", &format!("{x0:?}"))
            .replace("{X1}", &format!("{x1:?}"))
            .replace("{Y0}", &y0)
            .replace("{Y1}", &y1),
    )
}

async fn ws_upgrade(
    axum::extract::State(state): axum::extract::State<WsState>,
    upgrade: axum::extract::ws::WebSocketUpgrade,
) -> axum::response::Response {
    upgrade.on_upgrade(move |socket| ws_session(socket, state))
}

/// One page's session: its text messages are touch lines (as
/// --stdin's, one or more per message); a bad one is answered with an
/// error and lifts the finger; a closed socket lifts it. Every 100 ms
/// the page gets the last rendered sample and the latency figures.
async fn ws_session(mut socket: axum::extract::ws::WebSocket, state: WsState) {
    use axum::extract::ws::Message;
    let mut stamper = TouchStamper::default();
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    let lift = |state: &WsState| {
        let _ = state.sender.try_send(TouchEvent::lift_now(&state.clock));
    };
    loop {
        tokio::select! {
            message = socket.recv() => {
                let text = match message {
                    Some(Ok(Message::Text(text))) => text,
                    Some(Ok(Message::Close(_))) | None | Some(Err(_)) => {
                        lift(&state);
                        return;
                    }
                    Some(Ok(_)) => continue,
                };
                let received = Instant::now();
                let arrival_s = state.clock.time_of(received);
                for line in text.as_str().lines() {
                    let event = match haptex_core::live::parse_touch_line(line, state.axes) {
                        Ok(Some(parsed)) => TouchEvent::received(parsed, received, arrival_s, &mut stamper),
                        Ok(None) => continue,
                        Err(message) => {
                            lift(&state);
                            let reply = json!({ "error": format!("message '{line}': {message}") }).to_string();
                            let _ = socket.send(Message::Text(reply.into())).await;
                            break;
                        }
                    };
                    if state.sender.try_send(event).is_err() {
                        let reply = json!({ "error": "touch queue full: the output is not running" }).to_string();
                        let _ = socket.send(Message::Text(reply.into())).await;
                    }
                }
            }
            _ = tick.tick() => {
                let frame = json!(state.shared.figures(&state.status, state.sample_rate));
                if socket.send(Message::Text(frame.to_string().into())).await.is_err() {
                    lift(&state);
                    return;
                }
            }
        }
    }
}

/// The live page: a strip spanning the profile; touches (or a held
/// mouse button) on it send `t_s,x_mm` lines, lifting sends `lift`.
const LIVE_PAGE: &str = include_str!("live_page.html");

fn ns_s(ns: u64) -> f64 {
    if ns == u64::MAX { 0.0 } else { ns as f64 * 1e-9 }
}

/// CPU time of this process (user + system), s.
fn cpu_time_s() -> f64 {
    // SAFETY: getrusage fills the struct it is given.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
        return f64::NAN;
    }
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    tv(usage.ru_utime) + tv(usage.ru_stime)
}

#[allow(clippy::too_many_arguments)]
fn report(
    args: &LiveArgs,
    device: &str,
    sample_rate: u32,
    channels: u16,
    format: SampleFormat,
    status: &LiveStatus,
    shared: &Shared,
    wall_s: f64,
    cpu_s: f64,
) -> serde_json::Value {
    let frames = status.frames.load(Ordering::Relaxed);
    let callbacks = shared.callbacks.load(Ordering::Relaxed);
    let busy_ns = shared.callback_busy_ns.load(Ordering::Relaxed);
    let out_min = ns_s(shared.output_latency_min_ns.load(Ordering::Relaxed));
    let out_max = ns_s(shared.output_latency_max_ns.load(Ordering::Relaxed));
    let render_max = status.max_latency_s();
    json!({
        "device": device,
        "sample_rate_hz": sample_rate,
        "channels": channels,
        "sample_format": format.to_string(),
        "buffer_frames": args.output.buffer_frames,
        "frames": frames,
        "callbacks": callbacks,
        "events": status.events.load(Ordering::Relaxed),
        "render_latency_mean_s": status.mean_latency_s(),
        "render_latency_max_s": render_max,
        "queue_wait_max_s": ns_s(status.queue_wait_max_ns.load(Ordering::Relaxed)),
        "output_latency_min_s": out_min,
        "output_latency_max_s": out_max,
        "touch_to_output_max_s": render_max + out_max,
        "callback_ns_per_frame": if frames > 0 { busy_ns as f64 / frames as f64 } else { 0.0 },
        "callback_max_s": ns_s(shared.callback_busy_max_ns.load(Ordering::Relaxed)),
        "peak_fraction_of_full_scale": status.peak(),
        "peak_v": f64::from(status.peak()) * args.output.drive.volts_per_full_scale(),
        "clamped_samples": status.clamped_samples.load(Ordering::Relaxed),
        "xruns": shared.xruns.load(Ordering::Relaxed),
        "realtime_priority_denied": shared.realtime_denied.load(Ordering::Relaxed),
        "non_finite_samples": status.non_finite_samples.load(Ordering::Relaxed),
        "wall_s": wall_s,
        "audio_s": frames as f64 / f64::from(sample_rate),
        "cpu_s": cpu_s,
        "cpu_fraction": cpu_s / wall_s,
        "ramp_s": args.output.ramp_ms * 1e-3,
        "gap_s": args.output.gap_ms * 1e-3,
        "dropout_s": (args.output.gap_ms + args.output.ramp_ms) * 1e-3,
    })
}

fn print_report(r: &serde_json::Value) {
    let ms = |k: &str| r[k].as_f64().unwrap_or(f64::NAN) * 1e3;
    eprintln!(
        "played {:.3} s of audio ({} frames, {} callbacks) in {:.3} s; peak {:.3} V on channel 1",
        r["audio_s"].as_f64().unwrap_or(0.0),
        r["frames"],
        r["callbacks"],
        r["wall_s"].as_f64().unwrap_or(0.0),
        r["peak_v"].as_f64().unwrap_or(0.0)
    );
    if r["events"].as_u64().unwrap_or(0) == 0 {
        eprintln!("latency: no touch events");
    } else {
        eprintln!(
            "latency: touch to first sample rendered mean {:.3} ms, max {:.3} ms over {} events (queue wait max {:.3} ms); \
         device buffer (cpal, callback to playback) {:.3}..{:.3} ms; touch to output at most {:.3} ms",
            ms("render_latency_mean_s"),
            ms("render_latency_max_s"),
            r["events"],
            ms("queue_wait_max_s"),
            ms("output_latency_min_s"),
            ms("output_latency_max_s"),
            ms("touch_to_output_max_s")
        );
    }
    eprintln!(
        "callback: {:.1} ns per frame, longest {:.3} ms; CPU {:.1}% of one core",
        r["callback_ns_per_frame"].as_f64().unwrap_or(0.0),
        ms("callback_max_s"),
        100.0 * r["cpu_fraction"].as_f64().unwrap_or(0.0)
    );
    let xruns = r["xruns"].as_u64().unwrap_or(0);
    if xruns > 0 {
        eprintln!(
            "warning: {xruns} underruns (the device played silence while waiting for samples): try a larger --buffer-frames"
        );
    }
    let clamped = r["clamped_samples"].as_u64().unwrap_or(0);
    if clamped > 0 {
        eprintln!("warning: the last clamp acted on {clamped} samples (a renderer bug: report it)");
    }
}
