//! `haptex play`: voltage profile + finger trajectory -> drive signal
//! (WAV with a sidecar JSON, or CSV), with the safety limits applied and
//! reported, and optionally a PNG of trajectory, envelope and signal.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use haptex_core::arg_names::ArgNames;
use haptex_core::io::Table;
use haptex_core::num::Num;
use haptex_core::ranges;
use haptex_core::signal::play::{PlayProfile, generate_trajectory, resolve_a_max_um, sidecar_source};
use haptex_core::signal::{
    AmplitudeCurve, Carrier, Extend, Limits, RenderSettings, VoltageCurve, WavFormat, WavOptions,
    modulate_at_resonance, read_drive_wav, sidecar_path, write_wav,
};
use haptex_core::trajectory::Trajectory;
use serde_json::json;

use crate::args::{CarrierArg, Output, in_range, positive};

/// Turn a voltage profile U(x) and a finger trajectory x(t) into the drive
/// signal of an electrovibration display.
///
/// The envelope is U(x(t)) (RMS volts, from `haptex voltage`), clamped at
/// U_max and optionally slew limited, on a carrier: a sine of peak
/// sqrt(2) U (the default, 1 kHz), a square of peak U, or none (the
/// envelope itself). A drive whose peak exceeds the amplifier range (or the
/// WAV full scale) is refused, not clipped. The output format follows the
/// extension of -o: .wav (mono; a sidecar OUT.wav.json records the volts
/// per full scale and the safety report) or .csv (`t_s,x_mm,envelope_v,
/// signal_v`; `-` for stdout).
///
/// The trajectory is a `t_s,x_mm` CSV (--trajectory), or generated: one
/// sweep at constant --velocity, or --strokes back-and-forth minimum-jerk
/// strokes at mean --velocity, between --from-mm and --to-mm (default: the
/// profile's ends).
///
/// The WAV carries its own scale (volts per full scale) and the hash of its
/// samples in a `hptx` chunk; `haptex play --check OUT.wav` verifies a WAV
/// and its sidecar belong together before an amplifier is set by them.
///
/// A display profile with an `amplitude_um` column (`haptex voltage
/// --display combined|ultrasonic`) is played on two channels, a_max from
/// its header (or a lower --a-max-um): channel 1 the drive above, channel 2 the ultrasonic
/// amplitude envelope a(x(t)) in um (no carrier; clamped at a_max, which
/// is also its full scale). The WAV then has 2 channels and its scale
/// chunk and sidecar a `channel_2` scale in um; the CSV an `amplitude_um`
/// column.
#[derive(Debug, Args)]
#[command(
    group = clap::ArgGroup::new("finger").args(["trajectory", "velocity"]),
    allow_negative_numbers = true,
    after_help = "Examples:\n  \
        haptex voltage --profile data/examples/bump_friction.csv -o bump_u.csv\n  \
        haptex play --profile bump_u.csv --velocity 50 -o bump.wav --png bump.png\n  \
        haptex play --profile bump_u.csv --trajectory finger.csv --carrier square --carrier-hz 400 -o drive.csv\n  \
        haptex play --profile bump_u.csv --velocity 80 --strokes 6 --slew-v-per-s 20000 -o strokes.wav\n  \
        haptex play --check bump.wav\n  \
        haptex voltage --profile data/examples/bump_friction.csv --display combined -o bump_ua.csv\n  \
        haptex play --profile bump_ua.csv --velocity 40 -o bump2.wav\n  \
        haptex play --profile bump_ua.csv --velocity 40 --sample-rate 192000 --plate-resonance-hz 40000 -o plate.wav\n\n\
        With a device file (`haptex calibrate`): U_max is the file's (--u-max may lower it), the carrier must be \
        one the file gives the force for, a design made with another device file is refused, and the sidecar and \
        CSV name the file and its SHA-256:\n  \
        haptex voltage --profile data/examples/bump_friction.csv --device my-display.toml -o u.csv\n  \
        haptex play --profile u.csv --device my-display.toml --velocity 50 -o u.wav"
)]
pub struct PlayArgs {
    /// Check a drive-signal WAV written by haptex instead of rendering one:
    /// its fmt chunk (every field) and samples against the scale chunk
    /// inside it, every sample of every channel finite and within full
    /// scale, and its sidecar (WAV.json, if present) against both. Exits
    /// non-zero on a mismatch.
    #[arg(long, value_name = "WAV", exclusive = true)]
    check: Option<PathBuf>,
    /// Voltage profile CSV (`x_mm,mu,voltage_v` from `haptex voltage`, or
    /// `x_mm,voltage_v`), or `-` for stdin. voltage_v is RMS volts.
    #[arg(long, value_name = "U.csv", required_unless_present_any = ["check", "voltage_map"])]
    profile: Option<PathBuf>,
    /// A voltage map over (x, y) instead of a profile (`haptex map
    /// voltage`: .csv or .npy with its sidecar), played along the finger
    /// path of --trajectory, a CSV `t_s,x_mm,y_mm` (docs/maps.md).
    #[arg(long, value_name = "MAP", conflicts_with_all = ["profile", "velocity", "strokes", "a_max_um"], requires = "trajectory")]
    voltage_map: Option<PathBuf>,
    /// Finger trajectory CSV `t_s,x_mm` (times strictly increasing).
    #[arg(long, value_name = "T.csv", conflicts_with_all = ["velocity", "strokes"])]
    trajectory: Option<PathBuf>,
    /// Generate the trajectory instead: finger speed in mm/s (constant, or
    /// the mean speed of each stroke with --strokes).
    #[arg(long, value_name = "MM_PER_S", value_parser = positive)]
    velocity: Option<f64>,
    /// Generate N back-and-forth strokes (minimum-jerk velocity profile,
    /// at rest at each reversal) instead of one constant-velocity sweep.
    #[arg(long, value_name = "N", requires = "velocity", value_parser = clap::value_parser!(u32).range(1..=100_000))]
    strokes: Option<u32>,
    /// Start of the generated trajectory in mm (default: first x of the profile).
    #[arg(long, value_name = "MM", requires = "velocity")]
    from_mm: Option<f64>,
    /// End of the generated trajectory in mm (default: last x of the profile).
    #[arg(long, value_name = "MM", requires = "velocity")]
    to_mm: Option<f64>,
    #[command(flatten)]
    drive: DriveArgs,
    #[command(flatten)]
    device_file: crate::args::DeviceFileArgs,
    /// Play channel 2 as the plate's displacement a(t) sin(2 pi F t) at
    /// its resonance F in Hz, for an amplifier that drives the plate
    /// directly, instead of the amplitude envelope a(t) a resonant driver
    /// takes. Needs a two-channel design and F <= 0.45 x --sample-rate
    /// (e.g. 192000 for plates up to 86.4 kHz).
    #[arg(long, value_name = "F", value_parser = in_range(ranges::PLATE_RESONANCE_HZ))]
    plate_resonance_hz: Option<f64>,
    /// Output sample rate in Hz.
    #[arg(long, value_name = "HZ", default_value_t = 48_000, value_parser = clap::value_parser!(u32).range(1000..=768_000))]
    sample_rate: u32,
    /// WAV sample format.
    #[arg(long, value_enum, default_value_t = WavFormatArg::Pcm16)]
    wav_format: WavFormatArg,
    /// Output: OUT.wav (plus OUT.wav.json) or OUT.csv; `-` writes CSV to
    /// stdout. A FIFO or device (e.g. /dev/null) is written in place and
    /// takes the format of --format (a WAV there gets no sidecar: its scale
    /// is inside it).
    #[arg(short, long, value_name = "OUT", required_unless_present = "check")]
    output: Option<PathBuf>,
    /// Output format, when -o's extension does not say (`-`, a FIFO, a
    /// device): wav or csv.
    #[arg(long, value_enum)]
    format: Option<FormatArg>,
    /// Also write the signal as CSV (`t_s,x_mm,envelope_v,signal_v`).
    #[arg(long, value_name = "FILE.csv")]
    csv: Option<PathBuf>,
    /// Also write a PNG of trajectory, envelope and signal.
    #[arg(long, value_name = "FILE.png")]
    png: Option<PathBuf>,
    /// Do not print the summary to stderr.
    #[arg(short, long)]
    quiet: bool,
}

/// The drive settings `haptex play` and `haptex live` share: carrier,
/// limits, full scale, channel 2's a_max, the extension outside the profile.
#[derive(Debug, Clone, PartialEq, Args)]
pub struct DriveArgs {
    /// Carrier waveform: sine (peak sqrt(2) U), square (peak U), none (the
    /// envelope U itself, unipolar).
    #[arg(long, value_enum, default_value_t = CarrierArg::Sine)]
    carrier: CarrierArg,
    /// Carrier frequency in Hz (below half the sample rate).
    #[arg(long, value_name = "F", default_value_t = Carrier::DEFAULT.frequency_hz, value_parser = in_range(ranges::CARRIER_HZ))]
    carrier_hz: f64,
    /// Highest ultrasonic amplitude in um (peak) of channel 2: higher
    /// requests are clamped (and reported); also channel 2's full scale.
    /// For a profile with an `amplitude_um` column only. Default: the a_max
    /// its header comment states (`at most a_max = ... um`); a value above
    /// that is refused, and without such a comment it is required.
    #[arg(long, value_name = "UM", value_parser = in_range(ranges::A_MAX_UM))]
    a_max_um: Option<f64>,
    /// Highest envelope in V RMS: higher requests are clamped (and
    /// reported). Default 100, or the device file's U_max (which --u-max
    /// may lower, not raise).
    #[arg(long, value_name = "V", value_parser = in_range(ranges::U_MAX_V))]
    u_max: Option<f64>,
    /// Largest rate of change of the envelope in V/s (default: no limit).
    /// The envelope then also fades in from 0 V at the start.
    #[arg(long, value_name = "V_PER_S", value_parser = in_range(ranges::SLEW_V_PER_S))]
    slew_v_per_s: Option<f64>,
    /// Peak output of the amplifier in V: a drive whose peak exceeds it is
    /// refused (default: no check beyond the WAV full scale).
    #[arg(long, value_name = "V", value_parser = in_range(ranges::AMPLIFIER_RANGE_V))]
    amp_range_v: Option<f64>,
    /// Volts at the amplifier output for a full-scale WAV sample (default:
    /// sqrt(2) x --u-max, the peak of a sine at U_max). Written to the sidecar.
    #[arg(long, value_name = "V", value_parser = in_range(ranges::VOLTS_PER_FULL_SCALE))]
    volts_per_full_scale: Option<f64>,
    /// Voltage where the finger is outside the profile: hold the end
    /// values, zero, or repeat the profile as a tile.
    #[arg(long, value_enum, default_value_t = ExtendArg::Hold)]
    outside: ExtendArg,
}

impl DriveArgs {
    /// The render settings at `sample_rate_hz`.
    pub fn settings(&self, sample_rate_hz: u32) -> RenderSettings {
        RenderSettings {
            sample_rate_hz,
            carrier: Carrier { shape: self.carrier.shape(), frequency_hz: self.carrier_hz },
            limits: Limits {
                u_max_v: self.u_max(),
                slew_v_per_s: self.slew_v_per_s,
                amplifier_range_v: self.amp_range_v,
            },
            extend: match self.outside {
                ExtendArg::Hold => Extend::Hold,
                ExtendArg::Zero => Extend::Zero,
                ExtendArg::Repeat => Extend::Repeat,
            },
        }
    }

    /// Channel 2's a_max as given (`--a-max-um`), before any profile.
    #[cfg_attr(not(feature = "live"), allow(dead_code))]
    pub fn given_a_max_um(&self) -> Option<f64> {
        self.a_max_um
    }

    /// Volts at the amplifier output per full-scale sample: as given, or
    /// sqrt(2) x U_max (the peak of a sine at U_max).
    pub fn volts_per_full_scale(&self) -> f64 {
        self.volts_per_full_scale.unwrap_or(std::f64::consts::SQRT_2 * self.u_max())
    }

    /// The envelope's limit U_max in V RMS: --u-max, else 100 (or the
    /// device file's, once [`DriveArgs::use_device_file`] set it).
    pub fn u_max(&self) -> f64 {
        self.u_max.unwrap_or(Limits::DEFAULT.u_max_v)
    }

    /// Plays a design on the display of a device file: U_max the file's
    /// (or a lower --u-max; a higher one is refused), the carrier one the
    /// file gives the force for (an eq3 file: a carrier it was measured
    /// on), and the design one made with this file if it says which
    /// (`comments`, from `profile`).
    pub fn use_device_file(
        &mut self,
        file: &crate::args::DesignDevice,
        comments: &[String],
        profile: &Path,
    ) -> anyhow::Result<()> {
        let carrier = Carrier { shape: self.carrier.shape(), frequency_hz: self.carrier_hz };
        self.u_max = Some(file.play_u_max(&carrier, self.u_max, comments, &profile.display().to_string())?);
        Ok(())
    }

    /// Channel 2's a_max for the profile read from `profile`: --a-max-um
    /// (at most what the profile states), else the stated one; `None` for
    /// a profile without an amplitude channel.
    pub fn a_max_um(
        &self,
        profile: &Path,
        amplitude: Option<&AmplitudeCurve>,
        stated_a_max: Option<f64>,
    ) -> anyhow::Result<Option<f64>> {
        Ok(resolve_a_max_um(
            &profile.display().to_string(),
            amplitude.is_some(),
            self.a_max_um,
            stated_a_max,
            &ArgNames::CLI,
        )?)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, ValueEnum)]
enum WavFormatArg {
    Pcm16,
    Pcm24,
    Float32,
}

#[derive(Debug, Clone, Copy, PartialEq, ValueEnum)]
enum ExtendArg {
    Hold,
    Zero,
    Repeat,
}

#[derive(Debug, Clone, Copy, PartialEq, ValueEnum)]
enum FormatArg {
    Wav,
    Csv,
}

pub fn run(mut args: PlayArgs) -> anyhow::Result<()> {
    if let Some(wav) = &args.check {
        return check(wav, args.quiet);
    }
    let device_file = args.device_file.read()?;
    let (Some(profile), Some(output_path)) = (args.profile.as_ref().or(args.voltage_map.as_ref()), &args.output) else {
        bail!("give --profile U.csv (or --voltage-map MAP) and -o OUT (or --check WAV)");
    };
    if args.trajectory.is_none() && args.velocity.is_none() {
        bail!("give --trajectory T.csv, or --velocity MM_PER_S to generate a trajectory");
    }
    let output = Output::new(Some(output_path.clone()));
    let extension = output.path().and_then(|p| p.extension()).and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let format = match (args.format, extension.as_deref()) {
        (Some(FormatArg::Wav), None | Some("wav")) | (None, Some("wav")) => FormatArg::Wav,
        (Some(FormatArg::Csv), None | Some("csv")) | (None, Some("csv")) => FormatArg::Csv,
        (None, None) if output.path().is_none() => FormatArg::Csv,
        (Some(f), Some(e)) => bail!(
            "--format {} does not match the extension .{e} of {}",
            format!("{f:?}").to_lowercase(),
            output_path.display()
        ),
        (None, _) => bail!(
            "cannot tell the output format from {}: use a .wav or .csv file, or give --format wav|csv",
            output_path.display()
        ),
    };
    // Refuse a directory or special file before any work.
    haptex_core::io::OutputTarget::of(output_path)?;

    if args.voltage_map.is_some() {
        if let Some(file) = &device_file {
            args.drive.use_device_file(file, &[], profile)?;
        }
        let map = super::map::read_voltage_map(profile)?;
        let path_file = args.trajectory.as_ref().context("--voltage-map needs --trajectory T.csv (t_s,x_mm,y_mm)")?;
        let name = path_file.display().to_string();
        let file = std::fs::File::open(path_file).with_context(|| format!("cannot open {name}"))?;
        let path = haptex_core::planar::PlanarTrajectory::read_csv(std::io::BufReader::new(file), &name)?;
        let settings = args.drive.settings(args.sample_rate);
        let mut signal = haptex_core::signal::render_map(&map, &path, &settings)?;
        if let Some(f) = args.plate_resonance_hz {
            modulate_at_resonance(&mut signal, f)
                .with_context(|| format!("--plate-resonance-hz for {}", profile.display()))?;
        }
        let provenance =
            Provenance { trajectory: json!({ "file": name }), device_file: device_file.as_ref(), stated: None };
        return write_signal(&args, format, &output, output_path, profile, &signal, provenance);
    }
    let design = read_design(profile)?;
    if let Some(file) = &device_file {
        args.drive.use_device_file(file, &design.comments, profile)?;
    }
    let a_max_um = args.drive.a_max_um(profile, design.amplitude.as_ref(), design.stated_a_max())?;
    let (trajectory, trajectory_source) = trajectory(&args, &design.curve)?;
    let settings = args.drive.settings(args.sample_rate);
    design.check_carrier(&settings.carrier, &profile.display().to_string(), &ArgNames::CLI)?;
    let mut signal = design.render(&trajectory, &settings, a_max_um)?;
    if let Some(f) = args.plate_resonance_hz {
        modulate_at_resonance(&mut signal, f)
            .with_context(|| format!("--plate-resonance-hz for {}", profile.display()))?;
    }

    let stated = design.comments.iter().find(|c| c.contains(haptex_core::signal::play::DEVICE_SHA256_MARK)).cloned();
    let provenance = Provenance { trajectory: trajectory_source, device_file: device_file.as_ref(), stated };
    write_signal(&args, format, &output, output_path, profile, &signal, provenance)
}

/// Where a played signal came from: its trajectory (a JSON description),
/// the device file given (--device), and the design's own comment naming
/// the device file it was made with.
struct Provenance<'a> {
    trajectory: serde_json::Value,
    device_file: Option<&'a crate::args::DesignDevice>,
    stated: Option<String>,
}

impl Provenance<'_> {
    /// The line the signal's CSV starts with (without `# `).
    fn comment(&self) -> Option<String> {
        match (self.device_file, &self.stated) {
            (Some(file), _) => Some(format!("played on the display of {}", file.comment())),
            (None, Some(stated)) => Some(format!("the design says: {stated}")),
            (None, None) => None,
        }
    }
}

/// Writes the rendered signal (WAV with its scale and sidecar, or CSV;
/// and the optional CSV and PNG) and reports what was written.
fn write_signal(
    args: &PlayArgs,
    format: FormatArg,
    output: &Output,
    output_path: &Path,
    profile: &Path,
    signal: &haptex_core::signal::DriveSignal,
    provenance: Provenance,
) -> anyhow::Result<()> {
    let mut written = Vec::new();
    let comment = provenance.comment();
    let trajectory_source = &provenance.trajectory;
    let write_csv = |w: &mut dyn std::io::Write| {
        if let Some(c) = &comment {
            writeln!(w, "# {c}")?;
        }
        signal.write_csv(w)
    };
    match format {
        FormatArg::Wav => {
            let path = output_path;
            let options = WavOptions {
                format: match args.wav_format {
                    WavFormatArg::Pcm16 => WavFormat::Pcm16,
                    WavFormatArg::Pcm24 => WavFormat::Pcm24,
                    WavFormatArg::Float32 => WavFormat::Float32,
                },
                volts_per_full_scale: args.drive.volts_per_full_scale(),
            };
            let mut source = sidecar_source(
                &profile.display().to_string(),
                trajectory_source,
                &std::env::args().collect::<Vec<_>>().join(" "),
            );
            // The device file played on, or the one the design says it was made with.
            if let Some(file) = provenance.device_file {
                source["device_file"] = file.provenance();
            } else if let Some(stated) = &provenance.stated {
                source["design_device_file"] = json!(stated);
            }
            let sidecar = write_wav(path, signal, &options, source)?;
            let channel_2 = match &sidecar.channel_2 {
                Some(c) => format!("; channel 2: {} um per full scale", Num(c.um_per_full_scale)),
                None => String::new(),
            };
            written.push(format!(
                "{} ({}, {}{} V per full scale{channel_2}, in the WAV's hptx chunk; samples SHA-256 {})",
                path.display(),
                format!("{:?}", options.format).to_lowercase(),
                if channel_2.is_empty() { "" } else { "2 channels; channel 1: " },
                Num(options.volts_per_full_scale),
                sidecar.samples_sha256
            ));
            if haptex_core::io::OutputTarget::of(path).is_ok_and(|t| t.is_file()) {
                written.push(sidecar_path(path).display().to_string());
            } else {
                written.push("no sidecar for a stream output: the scale is inside the WAV".to_string());
            }
        }
        FormatArg::Csv => {
            output.write(write_csv)?;
            if let Some(path) = output.path() {
                written.push(path.display().to_string());
            }
        }
    }
    if let Some(path) = &args.csv {
        haptex_core::io::write_atomic(path, write_csv)?;
        written.push(path.display().to_string());
    }
    if let Some(path) = &args.png {
        let title = format!("haptex play: {}, {}", file_name(profile), describe(trajectory_source));
        signal.figure(&title).write_png(path)?;
        written.push(path.display().to_string());
    }
    if !args.quiet {
        eprint!("{}", signal.report);
        for w in written {
            eprintln!("wrote {w}");
        }
    }
    Ok(())
}

/// `--check WAV`: reads a drive-signal WAV with its checks (scale chunk,
/// sample hash, sidecar) and says what it holds.
fn check(path: &Path, quiet: bool) -> anyhow::Result<()> {
    let wav = read_drive_wav(path)?;
    let s = &wav.scale;
    if !quiet {
        eprintln!(
            "{}: haptex drive signal, {} samples at {} Hz ({:.4} s), {}",
            path.display(),
            s.n_samples,
            s.sample_rate_hz,
            s.n_samples as f64 / f64::from(s.sample_rate_hz),
            format!("{:?}", s.sample_format).to_lowercase()
        );
        eprintln!(
            "{}scale: {} V at the amplifier output per full-scale sample ({}); peak {:.4} V",
            if s.channel_2.is_some() { "channel 1 " } else { "" },
            Num(s.volts_per_full_scale),
            s.conversion,
            wav.peak_v()
        );
        if let (Some(c2), Some(a)) = (&s.channel_2, &wav.amplitude_um) {
            let peak = a.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
            let what = match c2.resonance_hz {
                None => "ultrasonic amplitude".to_string(),
                Some(f) => format!("plate displacement on its resonance {} Hz", Num(f)),
            };
            eprintln!(
                "channel 2: {} um of {what} per full-scale sample ({}); peak {:.4} um, within a_max = {} um",
                Num(c2.um_per_full_scale),
                c2.conversion,
                peak,
                Num(c2.a_max_um)
            );
        }
        match &s.fmt_sha256 {
            Some(hash) => eprintln!("fmt chunk: every field as the scale chunk states (SHA-256 {hash})"),
            None => eprintln!(
                "fmt chunk: every field as haptex writes it for this format (a version-1 scale chunk, written before \
                 haptex hashed the fmt chunk; render the signal again for a version-{} chunk)",
                haptex_core::signal::SCALE_CHUNK_VERSION
            ),
        }
        eprintln!(
            "samples: SHA-256 {} matches the scale chunk; every sample of every channel finite and within full scale",
            s.samples_sha256
        );
        match &wav.sidecar {
            Some(_) => eprintln!("sidecar {}: belongs to this WAV (same hash and scale)", sidecar_path(path).display()),
            None => eprintln!("sidecar {}: none (the WAV's own scale chunk is checked)", sidecar_path(path).display()),
        }
        eprintln!("ok");
    }
    Ok(())
}

/// Reads the design to play from a file, or stdin for `-`: its voltage
/// curve, the amplitude curve of a profile with an `amplitude_um` column,
/// and the `#` comment lines before its header row (where `haptex voltage`
/// states an a_max and a design carrier).
pub fn read_design(path: &Path) -> anyhow::Result<PlayProfile> {
    let table = if path.as_os_str() == "-" {
        Table::read(std::io::stdin().lock(), "<stdin>")?
    } else {
        Table::read_file(path)?
    };
    Ok(PlayProfile::from_table(&table)?)
}

/// The trajectory (read or generated) and a JSON description of where it
/// came from.
fn trajectory(args: &PlayArgs, curve: &VoltageCurve) -> anyhow::Result<(Trajectory, serde_json::Value)> {
    if let Some(path) = &args.trajectory {
        let t = Trajectory::read_csv_file(path)?;
        return Ok((t, json!({ "file": path.display().to_string() })));
    }
    let speed = args.velocity.context("give --trajectory T.csv, or --velocity to generate one")?;
    Ok(generate_trajectory(curve, speed, args.strokes, args.from_mm, args.to_mm)?)
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// A short description of the trajectory for the plot title.
fn describe(source: &serde_json::Value) -> String {
    if let Some(file) = source["file"].as_str() {
        return format!("trajectory {}", file_name(Path::new(file)));
    }
    let (from, to) = (source["from_mm"].as_f64().unwrap_or(0.0), source["to_mm"].as_f64().unwrap_or(0.0));
    match source["strokes"].as_u64() {
        Some(n) => format!("{n} strokes {from}..{to} mm at mean {} mm/s", source["mean_velocity_mm_s"]),
        None => format!("{from}..{to} mm at {} mm/s", source["velocity_mm_s"]),
    }
}
