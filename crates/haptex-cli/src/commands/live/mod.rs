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
/// Or a voltage map over (x, y) (`haptex map voltage`, --voltage-map),
/// played on one channel at the finger's (x, y), bilinear, the map's edge
/// held beyond it, as `haptex play --voltage-map` renders it offline.
///
/// Touch input: --touch-log T.csv (`t_s,x_mm`, or `t_s,x_mm,y_mm` over a
/// map, replayed on the output's clock from its first time, then the
/// output fades out and the command ends), --stdin (lines `x_mm`, stamped
/// on arrival, or `t_s,x_mm` on the sender's clock; over a map `x_mm,y_mm`
/// or `t_s,x_mm,y_mm`; `lift` when the finger leaves; the output fades out
/// at end of input), or --ws ADDR (a web page on a touchscreen or tablet
/// sends the same lines over a WebSocket: a strip, or over a map a pad).
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
        haptex live --voltage-map texture-u.npy --touch-log path.csv   (path.csv: t_s,x_mm,y_mm)\n  \
        my_touch_reader | haptex live --profile bump_u.csv --stdin --volts-per-full-scale 200\n\n\
        With a device file (`haptex calibrate`; --device-file, since --device is the audio output): U_max is \
        the file's (--u-max may lower it), the carrier one it gives the force for, and a design made with another \
        device file is refused, all before the audio output is opened:\n  \
        haptex live --profile u.csv --device-file my-display.toml --touch-log finger.csv"
)]
pub struct LiveArgs {
    /// List the output devices (name to give --device, and description), then exit.
    #[arg(long, exclusive = true)]
    list_devices: bool,
    /// Design to play: voltage profile CSV (`x_mm,mu,voltage_v`), or a
    /// display profile with an `amplitude_um` column for two channels.
    #[arg(long, value_name = "U.csv", required_unless_present_any = ["list_devices", "voltage_map"])]
    profile: Option<PathBuf>,
    /// A voltage map over (x, y) instead of a profile (`haptex map
    /// voltage`: .csv or .npy with its sidecar); touches are then (x, y).
    #[arg(long, value_name = "MAP", conflicts_with = "profile")]
    voltage_map: Option<PathBuf>,
    /// Touch log to replay in real time: `t_s,x_mm` CSV (times strictly
    /// increasing; more columns, e.g. y, are ignored), or `t_s,x_mm,y_mm`
    /// over a map.
    #[arg(long, value_name = "T.csv", conflicts_with_all = ["stdin", "ws"], required_unless_present_any = ["stdin", "ws", "list_devices"])]
    touch_log: Option<PathBuf>,
    /// Read touches from stdin: `x_mm` or `t_s,x_mm` per line (over a map
    /// `x_mm,y_mm` or `t_s,x_mm,y_mm`), `lift` when the finger leaves.
    #[arg(long, conflicts_with = "ws")]
    stdin: bool,
    /// Serve the live page and its WebSocket at this address (e.g.
    /// 0.0.0.0:8090 for a tablet on the same network; port 0 picks one):
    /// touches on the page's strip drive the output (the messages are
    /// --stdin's lines), and the page shows the position, the voltage and
    /// the latency. Runs until Ctrl-C.
    #[arg(long, value_name = "ADDR")]
    ws: Option<String>,
    /// The page and its WebSocket drive the output: they need an access
    /// token, made at start and printed in the page's address unless given
    /// (as `haptex serve`'s; docs/web.md, "Safety").
    #[command(flatten, next_help_heading = "Access token (with --ws)")]
    token: crate::args::TokenArgs,
    #[command(flatten)]
    output: OutputArgs,
    #[command(flatten)]
    device_file: crate::args::DeviceFileLongArgs,
    /// Also write the run's figures (device, latency, peak, CPU) as JSON.
    #[arg(long, value_name = "FILE.json")]
    json: Option<PathBuf>,
    /// Do not print the summary to stderr.
    #[arg(short, long)]
    quiet: bool,
}

/// The output device and the drive: what `haptex live` and `haptex serve
/// --live` share.
#[derive(Debug, Clone, PartialEq, Args)]
pub struct OutputArgs {
    /// Output device: its name from `haptex live --list-devices` (default:
    /// the host's default output).
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
}

impl OutputArgs {
    /// The options as clap's defaults leave them.
    pub fn defaults() -> Self {
        #[derive(clap::Parser)]
        struct Defaults {
            #[command(flatten)]
            output: OutputArgs,
        }
        <Defaults as clap::Parser>::parse_from(["haptex"]).output
    }

    /// Refuses fade and timing options out of range.
    #[cfg_attr(not(feature = "live"), allow(dead_code))]
    pub fn check(&self) -> anyhow::Result<()> {
        if self.ramp_ms > 10_000.0 {
            anyhow::bail!("--ramp-ms must be at most 10000 ms, got {}", haptex_core::num::Num(self.ramp_ms));
        }
        for (name, ms) in [("--gap-ms", self.gap_ms), ("--horizon-ms", self.horizon_ms), ("--blend-ms", self.blend_ms)]
        {
            if !(ms.is_finite() && (0.0..=60_000.0).contains(&ms)) {
                anyhow::bail!("{name} must be from 0 to 60000 ms, got {}", haptex_core::num::Num(ms));
            }
        }
        Ok(())
    }
}

/// Applies --device-file to the drive (U_max, carrier, the design's own
/// device file) before anything is opened; says so on stderr.
fn use_device_file(args: &mut LiveArgs) -> anyhow::Result<()> {
    let Some(file) = args.device_file.read()? else { return Ok(()) };
    let comments = match &args.profile {
        Some(profile) if profile.as_os_str() != "-" => super::play::read_design(profile)?.comments,
        _ => Vec::new(),
    };
    let design = args.profile.as_ref().or(args.voltage_map.as_ref()).cloned().unwrap_or_default();
    args.output.drive.use_device_file(&file, &comments, &design)?;
    if !args.quiet {
        eprintln!("playing on the display of {}", file.comment());
    }
    Ok(())
}

#[cfg(not(feature = "live"))]
pub fn run(mut args: LiveArgs) -> anyhow::Result<()> {
    use_device_file(&mut args)?;
    anyhow::bail!(
        "this haptex was built without audio output (the `live` cargo feature): build it with \
         `cargo build --release -p haptex-cli --features live` (cpal; on Linux its ALSA backend needs \
         libasound2-dev: apt-get install libasound2-dev)"
    )
}

#[cfg(feature = "live")]
pub fn run(mut args: LiveArgs) -> anyhow::Result<()> {
    use_device_file(&mut args)?;
    device::run(args)
}

#[cfg(feature = "live")]
mod device;
#[cfg(feature = "live")]
pub mod served;
