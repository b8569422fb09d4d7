//! `haptex live`: a voltage (or combined) design rendered in real time to an
//! audio output device, from touch positions replayed from a log or read
//! from stdin; the touch-to-output latency measured and printed.
//!
//! The audio output is cpal's, behind the `live` cargo feature (ALSA on
//! Linux needs libasound2-dev to build): without it this command only says
//! how to get it. The engine (renderer, fades, last clamp, latency
//! counters) is `haptex_core::live`; this module opens the device, feeds the
//! engine and reports. docs/live.md is the user's guide.

use std::path::PathBuf;

use clap::Args;

use super::play::DriveArgs;

/// Render a design in real time to an audio output (amplifier) from touch
/// positions.
///
/// The profile is a voltage profile (`haptex voltage`), played on one
/// channel, or a combined / ultrasonic display's profile (an
/// `amplitude_um` column), played on two: channel 1 the electrovibration
/// drive, channel 2 the ultrasonic amplitude, with the scales, limits and
/// carrier of `haptex play` (volts per full scale; never above U_max;
/// channel 2's full scale is a_max). The device runs at its own sample
/// rate (or --sample-rate).
///
/// Touch input: --touch-log T.csv (`t_s,x_mm`, replayed on the output's
/// clock from its first time, then the output fades out and the command
/// ends), --stdin (lines `x_mm`, stamped on arrival, or `t_s,x_mm` on
/// the sender's clock; `lift` when the finger leaves; the output fades out
/// at end of input), or --ws ADDR (a web page on a touchscreen or tablet
/// sends the same lines over a WebSocket).
///
/// Safety: the drive fades in over --ramp-ms at start and at every
/// touch-down and fades out on stop, lift, error and lost input: with no
/// report for --gap-ms it fades, reaching 0 V at most gap + ramp after
/// the last report. Ctrl-C fades out too.
///
/// At the end it prints the touch-to-output latency: from each event's
/// timestamp to the first sample rendered after it, plus the device
/// buffer latency cpal reports (callback to playback).
#[derive(Debug, Args)]
#[command(
    allow_negative_numbers = true,
    after_help = "Examples:\n  \
        haptex live --list-devices\n  \
        haptex voltage --profile data/examples/bump_friction.csv -o bump_u.csv\n  \
        haptex live --profile bump_u.csv --touch-log finger.csv --device hw:CARD=USB,DEV=0 --buffer-frames 256\n  \
        haptex live --profile bump_u.csv --ws 0.0.0.0:8090   (then open http://THIS-HOST:8090/ on the tablet)\n  \
        my_touch_reader | haptex live --profile bump_u.csv --stdin --volts-per-full-scale 200"
)]
pub struct LiveArgs {
    /// List the output devices (name to give --device, and description), then exit.
    #[arg(long, exclusive = true)]
    list_devices: bool,
    /// Design to play: voltage profile CSV (`x_mm,mu,voltage_v`), or a
    /// display profile with an `amplitude_um` column for two channels.
    #[arg(long, value_name = "U.csv", required_unless_present = "list_devices")]
    profile: Option<PathBuf>,
    /// Touch log to replay in real time: `t_s,x_mm` CSV (times strictly
    /// increasing; more columns, e.g. y, are ignored).
    #[arg(long, value_name = "T.csv", conflicts_with_all = ["stdin", "ws"], required_unless_present_any = ["stdin", "ws", "list_devices"])]
    touch_log: Option<PathBuf>,
    /// Read touches from stdin: `x_mm` or `t_s,x_mm` per line, `lift` when
    /// the finger leaves.
    #[arg(long, conflicts_with = "ws")]
    stdin: bool,
    /// Serve the live page and its WebSocket at this address (e.g.
    /// 0.0.0.0:8090 for a tablet on the same network; port 0 picks one):
    /// touches on the page's strip drive the output (the messages are
    /// --stdin's lines), and the page shows the position, the voltage and
    /// the latency. Runs until Ctrl-C.
    #[arg(long, value_name = "ADDR")]
    ws: Option<String>,
    /// Output device: its name from --list-devices (default: the host's
    /// default output).
    #[arg(long, value_name = "NAME")]
    device: Option<String>,
    /// Device channels to open (default: the design's, 1 or 2); channels
    /// beyond the design's get 0.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=64))]
    channels: Option<u16>,
    /// Frames per device buffer (default: the device's).
    #[arg(long, value_name = "FRAMES", value_parser = clap::value_parser!(u32).range(16..=65_536))]
    buffer_frames: Option<u32>,
    /// Sample rate in Hz (default: the device's default rate).
    #[arg(long, value_name = "HZ", value_parser = clap::value_parser!(u32).range(1000..=768_000))]
    sample_rate: Option<u32>,
    #[command(flatten)]
    drive: DriveArgs,
    /// Fade time in ms (start, stop, touch-down, lift, gap, error).
    #[arg(long, value_name = "MS", default_value_t = 20.0, value_parser = crate::args::positive)]
    ramp_ms: f64,
    /// No report for this long (ms) and the output fades out.
    #[arg(long, value_name = "MS", default_value_t = 100.0)]
    gap_ms: f64,
    /// Longest extrapolation past the last report in ms (then the position is held).
    #[arg(long, value_name = "MS", default_value_t = 50.0)]
    horizon_ms: f64,
    /// Time over which a report's disagreement with the extrapolation is blended out, ms.
    #[arg(long, value_name = "MS", default_value_t = 4.0)]
    blend_ms: f64,
    /// Also write the run's figures (device, latency, peak, CPU) as JSON.
    #[arg(long, value_name = "FILE.json")]
    json: Option<PathBuf>,
    /// Do not print the summary to stderr.
    #[arg(short, long)]
    quiet: bool,
}

#[cfg(not(feature = "live"))]
pub fn run(_args: LiveArgs) -> anyhow::Result<()> {
    anyhow::bail!(
        "this haptex was built without audio output (the `live` cargo feature): build it with \
         `cargo build --release -p haptex-cli --features live` (cpal; on Linux its ALSA backend needs \
         libasound2-dev: apt-get install libasound2-dev)"
    )
}

#[cfg(feature = "live")]
pub fn run(args: LiveArgs) -> anyhow::Result<()> {
    device::run(args)
}

#[cfg(feature = "live")]
mod device {
    use std::io::BufRead;
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
    use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
    use std::sync::{Arc, Mutex};
    use std::time::{Duration, Instant};

    use anyhow::{Context, bail};
    use cpal::traits::{DeviceTrait, HostTrait, StreamTrait};
    use cpal::{FromSample, SampleFormat, SizedSample};
    use haptex_core::live::{
        DeviceClock, LiveConfig, LiveEngine, LiveStatus, Touch, TouchEvent, TouchLine, TouchStamper,
    };
    use haptex_core::num::Num;
    use haptex_core::realtime::{RealtimeConfig, RealtimeRenderer};
    use haptex_core::signal::SignalError;
    use haptex_core::trajectory::Trajectory;
    use serde_json::json;

    use super::LiveArgs;
    use crate::commands::play::{check_design_carrier, read_curve, stated_a_max};

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
    struct Shared {
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

    pub fn run(args: LiveArgs) -> anyhow::Result<()> {
        let host = cpal::default_host();
        if args.list_devices {
            return list_devices(&host);
        }
        let profile = args.profile.as_deref().context("give --profile U.csv")?;
        if args.stdin && profile.as_os_str() == "-" {
            bail!("--profile - and --stdin both read stdin: give the profile as a file");
        }
        if args.ramp_ms > 10_000.0 {
            bail!("--ramp-ms must be at most 10000 ms, got {}", Num(args.ramp_ms));
        }
        let (curve, amplitude, comments) = read_curve(profile)?;
        let stated = if amplitude.is_some() { stated_a_max(&comments) } else { None };
        let a_max_um = args.drive.a_max_um(profile, amplitude.as_ref(), stated)?;
        let design_channels: u16 = if a_max_um.is_some() { 2 } else { 1 };
        // The touch log is read (and refused) before the device is opened.
        let log = match &args.touch_log {
            Some(path) => Some(Trajectory::read_csv_file(path)?),
            None if args.stdin || args.ws.is_some() => None,
            None => bail!("give --touch-log T.csv, --stdin or --ws ADDR"),
        };
        for (name, ms) in [("--gap-ms", args.gap_ms), ("--horizon-ms", args.horizon_ms), ("--blend-ms", args.blend_ms)]
        {
            if !(ms.is_finite() && (0.0..=60_000.0).contains(&ms)) {
                bail!("{name} must be from 0 to 60000 ms, got {}", Num(ms));
            }
        }

        let device = find_device(&host, args.device.as_deref())?;
        let device_name = device.id().map(|id| id.id().to_string()).unwrap_or_else(|_| "(unnamed)".into());
        let channels = args.channels.unwrap_or(design_channels);
        let default_config = device
            .default_output_config()
            .with_context(|| format!("device {device_name} (haptex live --list-devices lists the output devices)"))?;
        let sample_rate = args.sample_rate.unwrap_or(default_config.sample_rate());
        let format = pick_format(&device, &device_name, channels, sample_rate)?;
        let settings = args.drive.settings(sample_rate);
        settings.check()?;
        // A frequency-dependent design renders its target only on its carrier.
        check_design_carrier(&comments, &settings.carrier, profile)?;
        let config = RealtimeConfig {
            sample_rate_hz: sample_rate,
            carrier: settings.carrier,
            limits: settings.limits,
            extend: settings.extend,
            volts_per_full_scale: args.drive.volts_per_full_scale(),
            horizon_s: args.horizon_ms * 1e-3,
            blend_s: args.blend_ms * 1e-3,
            table_points: None,
        };
        let renderer = match (&amplitude, a_max_um) {
            (Some(amplitude), Some(a_max)) => RealtimeRenderer::two_channel(&curve, amplitude, a_max, &config),
            _ => RealtimeRenderer::new(&curve, &config),
        }
        .map_err(|e| match e {
            SignalError::ExceedsFullScale { amplitude_v, volts_per_full_scale } => anyhow::anyhow!(
                "refused: the drive's peak {amplitude_v:.3} V exceeds the output's full scale of {} V \
                 (--volts-per-full-scale); raise it to at least {amplitude_v:.3} V or lower --u-max",
                Num(volts_per_full_scale)
            ),
            other => other.into(),
        })?;
        let peak_bound_v = renderer.peak_bound_v();
        let live_config =
            LiveConfig { channels: usize::from(channels), ramp_s: args.ramp_ms * 1e-3, gap_s: args.gap_ms * 1e-3 };
        let mut engine = LiveEngine::new(renderer, &live_config)?;
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
        let status = engine.status();
        let clock = Arc::new(DeviceClock::new(sample_rate));
        let shared = Arc::new(Shared { output_latency_min_ns: AtomicU64::new(u64::MAX), ..Shared::default() });
        let (sender, receiver) = std::sync::mpsc::sync_channel::<TouchEvent>(QUEUE);

        let stream_config = cpal::StreamConfig {
            channels,
            sample_rate,
            buffer_size: match args.buffer_frames {
                Some(n) => cpal::BufferSize::Fixed(n),
                None => cpal::BufferSize::Default,
            },
        };
        let stream = match format {
            SampleFormat::F32 => build::<f32>(&device, &stream_config, engine, receiver, &clock, &shared),
            SampleFormat::I32 => build::<i32>(&device, &stream_config, engine, receiver, &clock, &shared),
            SampleFormat::I16 => build::<i16>(&device, &stream_config, engine, receiver, &clock, &shared),
            SampleFormat::F64 => build::<f64>(&device, &stream_config, engine, receiver, &clock, &shared),
            other => bail!("sample format {other} is not supported"),
        }
        .with_context(|| {
            format!("opening {device_name} ({channels} channels, {sample_rate} Hz, {format}, {stream_config:?})")
        })?;
        // SAFETY: the handler only stores to an atomic (async-signal-safe).
        unsafe {
            libc::signal(libc::SIGINT, on_signal as *const () as libc::sighandler_t);
            libc::signal(libc::SIGTERM, on_signal as *const () as libc::sighandler_t);
        }
        let cpu_before = cpu_time_s();
        let started = Instant::now();
        stream.play().with_context(|| format!("starting {device_name}"))?;
        if !args.quiet {
            eprintln!(
                "live: {device_name}, {sample_rate} Hz, {channels} channel{} ({}), {format}, buffer {}; channel 1 at {} V per \
                 full scale (peak bound {:.3} V){}",
                if channels == 1 { "" } else { "s" },
                if design_channels == 2 { "drive + ultrasonic amplitude" } else { "drive" },
                args.buffer_frames.map_or("device default".to_string(), |n| format!("{n} frames")),
                Num(args.drive.volts_per_full_scale()),
                peak_bound_v,
                a_max_um.map_or(String::new(), |a| format!(", channel 2 at {} um (a_max) per full scale", Num(a)))
            );
        }
        let input_error: Arc<Mutex<Option<String>>> = Arc::new(Mutex::new(None));
        if args.stdin {
            let (clock, shared, input_error) = (Arc::clone(&clock), Arc::clone(&shared), Arc::clone(&input_error));
            std::thread::spawn(move || read_stdin(&sender, &clock, &shared, &input_error));
        } else if let Some(addr) = &args.ws {
            let state = WsState {
                sender,
                clock: Arc::clone(&clock),
                status: Arc::clone(&status),
                shared: Arc::clone(&shared),
                span_mm: curve.span_mm(),
                sample_rate,
            };
            let (ready_tx, ready_rx) = std::sync::mpsc::channel();
            let addr = addr.clone();
            std::thread::spawn(move || serve_ws(&addr, state, &ready_tx));
            match ready_rx.recv() {
                Ok(Ok(bound)) => {
                    // Always printed: tests and scripts read the address from it.
                    eprintln!("live: page http://{bound}/ , WebSocket ws://{bound}/live/ws (Ctrl-C ends)");
                }
                Ok(Err(e)) => failure_at_start(&shared, &status, e)?,
                Err(_) => failure_at_start(&shared, &status, "the WebSocket server did not start".into())?,
            }
        } else {
            drop(sender);
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
            if let Some(error) = shared.errors.lock().ok().and_then(|e| e.first().cloned()) {
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
        // Let the faded-out samples reach the DAC before closing.
        let buffer_s = args.buffer_frames.map_or(0.05, |n| f64::from(n) / f64::from(sample_rate));
        let latency_max_s = ns_s(shared.output_latency_max_ns.load(Ordering::Relaxed));
        std::thread::sleep(Duration::from_secs_f64((latency_max_s + 2.0 * buffer_s).min(1.0)));
        let _ = stream.pause();
        drop(stream);
        let wall_s = started.elapsed().as_secs_f64();
        let cpu_s = cpu_time_s() - cpu_before;

        let report = report(&args, &device_name, sample_rate, channels, format, &status, &shared, wall_s, cpu_s);
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
    fn build<T>(
        device: &cpal::Device,
        config: &cpal::StreamConfig,
        mut engine: LiveEngine,
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

    /// Stops the output (faded) when the input could not start, and
    /// returns the error after the fade.
    fn failure_at_start(shared: &Shared, status: &LiveStatus, message: String) -> anyhow::Result<()> {
        shared.stop.store(true, Ordering::Relaxed);
        let waited = Instant::now();
        while !status.finished.load(Ordering::Relaxed) && waited.elapsed() < Duration::from_secs(2) {
            std::thread::sleep(Duration::from_millis(5));
        }
        bail!("{message} (the output was faded to 0 V)")
    }

    /// Turns parsed touch lines into events on the output clock
    /// ([`TouchStamper`]: at arrival, or from the line's own `t_s`).
    #[derive(Default)]
    struct Stamper(TouchStamper);

    impl Stamper {
        fn event(&mut self, line: TouchLine, received: Instant, clock: &DeviceClock) -> TouchEvent {
            let (t_s, touch) = self.0.stamp(line, clock.time_of(received));
            TouchEvent { t_s, touch, received: Some(received) }
        }
    }

    /// The stdin touch source: one event per line ([`Stamper`]). End of
    /// input, a bad line or a full queue stop the output (faded).
    fn read_stdin(
        sender: &SyncSender<TouchEvent>,
        clock: &DeviceClock,
        shared: &Shared,
        error: &Mutex<Option<String>>,
    ) {
        let mut stamper = Stamper::default();
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
            let parsed = match haptex_core::live::parse_touch_line(&line) {
                Ok(Some(p)) => p,
                Ok(None) => continue,
                Err(message) => return fail(format!("stdin, line {}, {message}", i + 1)),
            };
            match sender.try_send(stamper.event(parsed, received, clock)) {
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
        span_mm: (f64, f64),
        sample_rate: u32,
    }

    /// The live page and its WebSocket, on a thread of their own (a
    /// one-thread tokio runtime); `ready` gets the bound address or why not.
    fn serve_ws(addr: &str, state: WsState, ready: &std::sync::mpsc::Sender<Result<std::net::SocketAddr, String>>) {
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
            let app = axum::Router::new().route("/", get(page)).route("/live/ws", get(ws_upgrade)).with_state(state);
            if let Err(e) = axum::serve(listener, app).await {
                eprintln!("live: the WebSocket server stopped: {e}");
            }
        });
    }

    async fn page(axum::extract::State(state): axum::extract::State<WsState>) -> axum::response::Html<String> {
        let (x0, x1) = state.span_mm;
        axum::response::Html(LIVE_PAGE.replace("{X0}", &format!("{x0:?}")).replace("{X1}", &format!("{x1:?}")))
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
        let mut stamper = Stamper::default();
        let mut tick = tokio::time::interval(Duration::from_millis(100));
        let lift = |state: &WsState| {
            let _ = state.sender.try_send(TouchEvent {
                t_s: state.clock.time_of(Instant::now()),
                touch: Touch::Lift,
                received: Some(Instant::now()),
            });
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
                    for line in text.as_str().lines() {
                        let event = match haptex_core::live::parse_touch_line(line) {
                            Ok(Some(parsed)) => stamper.event(parsed, received, &state.clock),
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
                    let (x_mm, envelope_v, gain, amplitude_um) = state.status.last_sample();
                    let ms = |ns: &AtomicU64| ns_s(ns.load(Ordering::Relaxed)) * 1e3;
                    let render_max_ms = state.status.max_latency_s() * 1e3;
                    let output_max_ms = ms(&state.shared.output_latency_max_ns);
                    let frame = json!({
                        "x_mm": x_mm,
                        "envelope_v": envelope_v,
                        "gain": gain,
                        "output_v": envelope_v * gain,
                        "amplitude_um": amplitude_um * gain,
                        "events": state.status.events.load(Ordering::Relaxed),
                        "render_latency_mean_ms": state.status.mean_latency_s().map(|s| s * 1e3),
                        "render_latency_max_ms": render_max_ms,
                        "queue_wait_max_ms": ms(&state.status.queue_wait_max_ns),
                        "output_latency_max_ms": output_max_ms,
                        "touch_to_output_max_ms": render_max_ms + output_max_ms,
                        "sample_rate_hz": state.sample_rate,
                    });
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
            "buffer_frames": args.buffer_frames,
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
            "peak_v": f64::from(status.peak()) * args.drive.volts_per_full_scale(),
            "clamped_samples": status.clamped_samples.load(Ordering::Relaxed),
            "xruns": shared.xruns.load(Ordering::Relaxed),
            "realtime_priority_denied": shared.realtime_denied.load(Ordering::Relaxed),
            "non_finite_samples": status.non_finite_samples.load(Ordering::Relaxed),
            "wall_s": wall_s,
            "audio_s": frames as f64 / f64::from(sample_rate),
            "cpu_s": cpu_s,
            "cpu_fraction": cpu_s / wall_s,
            "ramp_s": args.ramp_ms * 1e-3,
            "gap_s": args.gap_ms * 1e-3,
            "dropout_s": (args.gap_ms + args.ramp_ms) * 1e-3,
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
}
