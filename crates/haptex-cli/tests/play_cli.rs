//! `haptex play` end to end: the binary, its files and its errors.

use std::path::Path;
use std::process::{Command, Output};

use haptex_core::signal::WavFormat;

mod common;
use common::{haptex, stderr, write};
#[path = "../../haptex-core/tests/support/forge_wav.rs"]
mod forge_wav;

fn path(dir: &Path, name: &str) -> String {
    dir.join(name).to_str().unwrap().to_string()
}

/// voltage -> play with generated strokes: WAV at the asked rate and length
/// (3 strokes of 10 mm at a mean 50 mm/s = 0.6 s, 0.6 * 8000 + 1 samples),
/// the sidecar's default volts per full scale sqrt(2) x U_max, and a PNG.
#[test]
fn voltage_then_play_writes_wav_sidecar_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/examples/bump_friction.csv");
    let u = path(dir.path(), "u.csv");
    assert!(haptex(&["voltage", "--profile", example, "-o", &u, "-q"]).status.success());
    let wav = path(dir.path(), "s.wav");
    let png = path(dir.path(), "s.png");
    let out = haptex(&[
        "play",
        "--profile",
        &u,
        "--velocity",
        "50",
        "--strokes",
        "3",
        "--sample-rate",
        "8000",
        "--wav-format",
        "pcm24",
        "-o",
        &wav,
        "--png",
        &png,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("wrote"), "{}", stderr(&out));

    let sidecar: serde_json::Value = serde_json::from_slice(&std::fs::read(format!("{wav}.json")).unwrap()).unwrap();
    assert_eq!(sidecar["volts_per_full_scale"], 100.0 * std::f64::consts::SQRT_2);
    assert_eq!(sidecar["sample_format"], "pcm24");
    assert_eq!(sidecar["source"]["trajectory"]["generator"], "minimum_jerk_strokes");
    assert_eq!(sidecar["n_samples"], 4801);
    let read = haptex_core::signal::read_drive_wav(Path::new(&wav)).unwrap();
    assert_eq!(read.scale.volts_per_full_scale, sidecar["volts_per_full_scale"].as_f64().unwrap());
    assert_eq!((read.scale.sample_rate_hz, read.scale.sample_format, read.volts.len()), (8000, WavFormat::Pcm24, 4801));
    let volts = read.volts;
    // The bump profile reaches U_max = 100 V: the sine's peak is 141.4 V.
    let peak = volts.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(peak > 141.0 && peak <= 141.43, "{peak}");

    let png = std::fs::read(&png).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}

/// A trajectory file to CSV on stdout: one row per sample at 1 kHz over
/// 0.1 s, positions interpolated, the square carrier at +/- U.
#[test]
fn trajectory_file_to_csv() {
    let dir = tempfile::tempdir().unwrap();
    let u = write(dir.path(), "u.csv", "x_mm,voltage_v\n0,10\n10,30\n");
    let t = write(dir.path(), "t.csv", "# finger\nt_s,x_mm\n0,0\n0.1,10\n");
    let out = haptex(&[
        "play",
        "--profile",
        &u,
        "--trajectory",
        &t,
        "--sample-rate",
        "1000",
        "--carrier",
        "square",
        "--carrier-hz",
        "100",
        "-o",
        "-",
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).is_empty());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.lines().any(|l| l == "t_s,x_mm,envelope_v,signal_v"));
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 101);
    for row in &rows {
        let expected_u = 10.0 + 2.0 * row[1];
        assert!((row[1] - 100.0 * row[0]).abs() < 1e-9, "{row:?}");
        assert!((row[2] - expected_u).abs() < 1e-9, "{row:?}");
        assert!((row[3].abs() - expected_u).abs() < 1e-9, "{row:?}");
    }
}

#[test]
fn bad_inputs_name_file_line_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let u = write(dir.path(), "u.csv", "x_mm,mu,voltage_v\n0,1.1,70\n1,1.2,80\n");
    let wav = path(dir.path(), "o.wav");
    let cases: &[(&str, &str, &str)] = &[
        ("t.csv", "t_s,x_mm\n0,0\n0.1,1\n0.1,2\n", "t.csv, line 4, column 't_s': times must be strictly increasing"),
        ("t.csv", "t_s,x_mm\n0,0\n0.1,oops\n", "t.csv, line 3, column 'x_mm': not a number"),
        ("t.csv", "time,x_mm\n0,0\n0.1,1\n", "t.csv, line 1, column 't_s': required column is missing"),
        ("t.csv", "t_s,x_mm\n0,0\n", "t.csv, line 1, column 't_s': a trajectory needs at least 2 samples"),
    ];
    for (name, text, message) in cases {
        let t = write(dir.path(), name, text);
        let out = haptex(&["play", "--profile", &u, "--trajectory", &t, "-o", &wav]);
        assert!(!out.status.success(), "{text:?}");
        assert!(stderr(&out).contains(message), "{text:?}: {}", stderr(&out));
    }
    let bad_u = write(dir.path(), "bad_u.csv", "x_mm,voltage_v\n0,1\n1,-5\n");
    let out = haptex(&["play", "--profile", &bad_u, "--velocity", "10", "-o", &wav]);
    assert!(
        stderr(&out).contains("bad_u.csv, line 3, column 'voltage_v': voltage_v must be from 0 to 1000000 V, got -5"),
        "{}",
        stderr(&out)
    );
    let out = haptex(&["play", "--profile", &u, "--velocity", "10", "-o", &path(dir.path(), "o.mp3")]);
    assert!(stderr(&out).contains("use a .wav or .csv file"), "{}", stderr(&out));
    let out = haptex(&["play", "--profile", &u, "-o", &wav]);
    assert!(!out.status.success() && stderr(&out).contains("--trajectory"), "{}", stderr(&out));
    let out = haptex(&["play", "--profile", &u, "--velocity", "10", "--carrier-hz", "30000", "-o", &wav]);
    assert!(stderr(&out).contains("Nyquist"), "{}", stderr(&out));
    // Nothing was written by any failed run.
    assert!(!Path::new(&wav).exists());
}

/// Clamping is reported; a peak above the amplifier range is refused and
/// writes nothing; the same drive fits with a square carrier.
#[test]
fn clamp_is_reported_and_amplifier_range_refused() {
    let dir = tempfile::tempdir().unwrap();
    let u = write(dir.path(), "u.csv", "x_mm,voltage_v\n0,50\n10,150\n");
    let wav = path(dir.path(), "o.wav");
    let out = haptex(&["play", "--profile", &u, "--velocity", "100", "-o", &wav]);
    assert!(out.status.success(), "{}", stderr(&out));
    // 2400 of 4801 samples request more than 100 V (x > 5 mm; at x = 5 mm exactly 100 V).
    assert!(stderr(&out).contains("clamped at U_max = 100 V for 49.99% of the time"), "{}", stderr(&out));

    let refused = path(dir.path(), "refused.wav");
    let out = haptex(&["play", "--profile", &u, "--velocity", "100", "--amp-range-v", "120", "-o", &refused]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("refused: the drive's peak 141.421 V"), "{}", stderr(&out));
    assert!(!Path::new(&refused).exists() && !Path::new(&format!("{refused}.json")).exists());

    let out = haptex(&[
        "play",
        "--profile",
        &u,
        "--velocity",
        "100",
        "--amp-range-v",
        "120",
        "--carrier",
        "square",
        "-o",
        &refused,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = haptex(&["play", "--profile", &u, "--velocity", "100", "--volts-per-full-scale", "120", "-o", &refused]);
    assert!(stderr(&out).contains("exceeds the WAV full scale"), "{}", stderr(&out));
}

/// Issue 13: a run killed between the WAV and its sidecar leaves a new WAV
/// beside the old sidecar. The old sidecar here says twice the volts per
/// full scale of the new WAV (the dangerous direction: an amplifier set by
/// it would drive the display at twice the voltage). `play --check` and the
/// reader refuse the pair; the WAV alone still carries its true scale.
#[test]
fn wav_and_sidecar_of_different_runs_are_never_paired() {
    let dir = tempfile::tempdir().unwrap();
    let u = write(dir.path(), "u.csv", "x_mm,voltage_v\n0,10\n10,40\n");
    let wav = path(dir.path(), "drive.wav");
    let play = |vpfs: &str, fault: Option<&str>| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_haptex"));
        command.args(["play", "--profile", &u, "--velocity", "100", "--volts-per-full-scale", vpfs, "-o", &wav]);
        if let Some(point) = fault {
            command.env("HAPTEX_FAULT_INJECT", point);
        }
        command.output().unwrap()
    };
    let first = play("200", None);
    assert!(first.status.success(), "{}", stderr(&first));
    let checked = haptex(&["play", "--check", &wav]);
    assert!(checked.status.success() && stderr(&checked).contains("belongs to this WAV"), "{}", stderr(&checked));

    // Killed after the WAV is renamed into place, before the sidecar.
    let killed = play("100", Some("between-wav-and-sidecar"));
    assert!(!killed.status.success(), "the fault hook did not fire: {}", stderr(&killed));
    let sidecar: serde_json::Value = serde_json::from_slice(&std::fs::read(format!("{wav}.json")).unwrap()).unwrap();
    assert_eq!(sidecar["volts_per_full_scale"], 200.0, "the old sidecar is expected beside the new WAV");

    let checked = haptex(&["play", "--check", &wav]);
    assert!(!checked.status.success(), "a mismatched pair passed --check: {}", stderr(&checked));
    assert!(stderr(&checked).contains("does not belong to it"), "{}", stderr(&checked));
    let e = haptex_core::signal::read_drive_wav(Path::new(&wav)).unwrap_err().to_string();
    assert!(e.contains("SHA-256"), "{e}");
    // Without the stale sidecar the WAV reads with its own (new) scale.
    std::fs::remove_file(format!("{wav}.json")).unwrap();
    let read = haptex_core::signal::read_drive_wav(Path::new(&wav)).unwrap();
    assert_eq!(read.scale.volts_per_full_scale, 100.0);
    // A rerun completes the pair and leaves no temporary behind.
    assert!(play("100", None).status.success());
    assert!(haptex(&["play", "--check", &wav]).status.success());
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// A WAV whose samples were changed after haptex wrote it, or that haptex
/// did not write (no scale chunk), is refused by `--check`.
#[test]
fn wav_without_a_matching_scale_chunk_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let u = write(dir.path(), "u.csv", "x_mm,voltage_v\n0,10\n10,40\n");
    let wav = path(dir.path(), "drive.wav");
    let out = haptex(&["play", "--profile", &u, "--velocity", "100", "-o", &wav]);
    assert!(out.status.success(), "{}", stderr(&out));
    let mut bytes = std::fs::read(&wav).unwrap();
    bytes[100] ^= 0x40; // a sample byte (the data chunk starts at byte 44)
    std::fs::write(&wav, &bytes).unwrap();
    let checked = haptex(&["play", "--check", &wav]);
    assert!(!checked.status.success());
    assert!(stderr(&checked).contains("do not match the scale chunk"), "{}", stderr(&checked));

    let plain = path(dir.path(), "plain.wav");
    let spec =
        hound::WavSpec { channels: 1, sample_rate: 8000, bits_per_sample: 16, sample_format: hound::SampleFormat::Int };
    let mut writer = hound::WavWriter::create(&plain, spec).unwrap();
    writer.write_sample(100i16).unwrap();
    writer.finalize().unwrap();
    let checked = haptex(&["play", "--check", &plain]);
    assert!(!checked.status.success());
    assert!(stderr(&checked).contains("no haptex scale chunk"), "{}", stderr(&checked));
}

/// Issue 13: `-o` naming a FIFO writes through it (it used to be replaced
/// by a regular file); `-o -` writes to standard output; a directory is
/// refused before any work.
#[cfg(unix)]
#[test]
fn outputs_to_a_fifo_or_stdout_are_written_in_place() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let u = write(dir.path(), "u.csv", "x_mm,voltage_v\n0,10\n10,40\n");
    let fifo = dir.path().join("f");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let reader = read_in_background(&fifo);
    let fifo_arg = fifo.to_str().unwrap();
    let out = haptex(&["play", "--profile", &u, "--velocity", "100", "--format", "wav", "-o", fifo_arg]);
    release(&fifo, &out);
    assert!(out.status.success(), "{}", stderr(&out));
    let bytes = reader.join().unwrap();
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo(), "the FIFO was replaced");
    let (scale, volts) = haptex_core::signal::decode_drive_wav(&bytes).unwrap();
    assert_eq!(volts.len(), scale.n_samples);
    assert!(!Path::new(&format!("{fifo_arg}.json")).exists(), "a stream output got a sidecar");

    let out = haptex(&[
        "play",
        "--profile",
        &u,
        "--velocity",
        "100",
        "--sample-rate",
        "1000",
        "--carrier-hz",
        "100",
        "-o",
        "-",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("\nt_s,x_mm,envelope_v,signal_v\n") && text.lines().count() > 50, "{text}");

    let out =
        haptex(&["play", "--profile", &u, "--velocity", "100", "--format", "csv", "-o", dir.path().to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("is a directory"), "{}", stderr(&out));
    // Same class, another command: voltage into the FIFO.
    let reader = read_in_background(&fifo);
    let profile = write(dir.path(), "p.csv", "x_mm,mu\n0,1.1\n1,1.2\n");
    let out = haptex(&["voltage", "--profile", &profile, "-o", fifo_arg]);
    release(&fifo, &out);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(String::from_utf8(reader.join().unwrap()).unwrap().contains("x_mm,mu,voltage_v"));
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
}

/// Reads a FIFO to its end on another thread.
#[cfg(unix)]
fn read_in_background(fifo: &Path) -> std::thread::JoinHandle<Vec<u8>> {
    use std::io::Read;
    let fifo = fifo.to_path_buf();
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        std::fs::File::open(&fifo).unwrap().read_to_end(&mut bytes).unwrap();
        bytes
    })
}

/// If haptex failed without opening the FIFO, opens it for writing so the
/// test's reader thread is not left waiting forever.
#[cfg(unix)]
fn release(fifo: &Path, out: &Output) {
    if !out.status.success() {
        let _ = std::fs::OpenOptions::new().write(true).open(fifo);
    }
}

/// One-channel output keeps its format: the `fmt ` chunk and the samples
/// are byte-identical to those haptex wrote before the two-channel drive
/// (the SHA-256 of each WAV's bytes from "WAVE" to the end of the data
/// chunk, as the previous release wrote them, measured with its binary on
/// the same commands). What changed, in issue 35, is the scale chunk after
/// the samples (version 2 states every field of the `fmt ` chunk and
/// hashes it; so the RIFF size changed too) and the sidecar (its
/// `fmt_sha256`): their hashes as this version writes them follow, so
/// that any further change is seen (the sidecar with its `command` line,
/// which names the test's paths, blanked).
#[test]
fn one_channel_output_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let u = path(d, "u.csv");
    let out = haptex(&["voltage", "--profile", "../../data/examples/bump_friction.csv", "-o", &u, "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let sha = |p: &str| haptex_core::io::sha256_hex(&std::fs::read(p).unwrap());
    // "WAVE", the fmt chunk and the data chunk: what every audio program reads.
    let format_and_samples = |p: &str| {
        let bytes = std::fs::read(p).unwrap();
        let data = bytes.windows(4).position(|w| w == b"data").unwrap();
        let size = u32::from_le_bytes(bytes[data + 4..data + 8].try_into().unwrap()) as usize;
        haptex_core::io::sha256_hex(&bytes[8..data + 8 + size])
    };
    // Without its fmt_sha256 line, the sidecar is the previous release's.
    let blanked_sidecar = |p: &str, without_fmt_hash: bool| {
        let text = std::fs::read_to_string(p).unwrap();
        let text: String = text
            .lines()
            .filter(|l| !(without_fmt_hash && l.contains("\"fmt_sha256\":")))
            .map(|l| if l.contains("\"command\":") { "    \"command\": \"X\"," } else { l })
            .fold(String::new(), |mut s, l| {
                s.push_str(l);
                s.push('\n');
                s
            });
        haptex_core::io::sha256_hex(text.as_bytes())
    };
    for (format, previous, wav_hash, sidecar_hash, previous_sidecar) in [
        (
            "pcm16",
            "ffcdbff919217e4abbd0b950827612d6d82380c2e063d729e5e5aa9c2be148e8",
            "7c9ffd0b41b641afd589c470242ced0c707cdd801273e11317f17faf28a0a501",
            "c2cc0a7c01a7fbd3ba1b0f5864ebf68efe6fd1d8456bc08d3abdf37dcd04df9f",
            "33130a2308b66311c2c1ed58f51e09913a0fccc67b7a557ad89c30296bf761ee",
        ),
        (
            "pcm24",
            "264487919ff763e0e3464295a0785f6a9e6e63044f397003ecfba90674163ade",
            "7edbe20eb1318d29121ee8d6a9571685cb6b733bb7d3a787d0281bf309eb9a63",
            "20cde01749dbc24e539ec6f43d6a58c0e5a45c444df18f44599fd296dab9994a",
            "089bdc7f36e0dd136f097754a575190f52390579bb757e42e67249ef0515e871",
        ),
        (
            "float32",
            "7674fd189aa4321579ac42d6bac8fe2f36f3ce812c2a6606e0c9e918f1e7d50d",
            "8db967f6ad5bffe5cceab461ed095e4e5ec15cb5e0dc8f48b8556abf5878fef9",
            "ae38e67d1847c4216f0c4f84edd26c4d47da25f33004d402ba04e361694bfa2a",
            "99cfefb9157beb91793695d6cbeae0b384ab8422e19a16999c6cb344a3d118d1",
        ),
    ] {
        let name = format!("b_{format}.wav");
        let out = Command::new(env!("CARGO_BIN_EXE_haptex"))
            .current_dir(d)
            .args(["play", "--profile", "u.csv", "--velocity", "40", "--strokes", "2", "--u-max", "90"])
            .args(["--slew-v-per-s", "20000", "--wav-format", format, "-o", &name, "-q"])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        assert_eq!(format_and_samples(&path(d, &name)), previous, "{format}: fmt chunk or samples");
        assert_eq!(sha(&path(d, &name)), wav_hash, "{format} WAV");
        let sidecar = path(d, &format!("{name}.json"));
        assert_eq!(blanked_sidecar(&sidecar, false), sidecar_hash, "{format} sidecar");
        assert_eq!(blanked_sidecar(&sidecar, true), previous_sidecar, "{format} sidecar but its fmt_sha256");
    }
    let csv = path(d, "b.csv");
    let out = haptex(&["play", "--profile", &u, "--velocity", "40", "--carrier", "square", "-o", &csv, "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(sha(&csv), "8af350284c5055a59623b428b3aee6f80f2975d8aec297fb3ed26f0024233531");
}

/// A combined display's profile plays on two channels: a 2-channel WAV
/// whose channel 2 is the amplitude in um (checked by --check, scale in
/// chunk and sidecar), a CSV with amplitude_um, --a-max-um required, and
/// a sidecar with a tampered channel-2 scale caught by --check.
#[test]
fn combined_profile_plays_on_two_channels() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let design = path(d, "d.csv");
    let out = haptex(&[
        "voltage",
        "--profile",
        "../../data/examples/bump_friction.csv",
        "--display",
        "combined",
        "-q",
        "-o",
        &design,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(&design).unwrap();
    let a_max = text.split("at most a_max = ").nth(1).unwrap().split(' ').next().unwrap().to_string();

    let wav = path(d, "d.wav");
    // Above the a_max the profile states: refused.
    let above = format!("{}", a_max.parse::<f64>().unwrap() + 0.5);
    let out = haptex(&["play", "--profile", &design, "--velocity", "20", "--a-max-um", &above, "-o", &wav]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("is above the a_max"), "{}", stderr(&out));
    assert!(!Path::new(&wav).exists());

    // Without --a-max-um: the stated a_max (the same file as giving it).
    let out = haptex(&["play", "--profile", &design, "--velocity", "20", "-o", &wav, "--png", &path(d, "d.png")]);
    assert!(out.status.success(), "{}", stderr(&out));
    let stated = std::fs::read(&wav).unwrap();
    let out = haptex(&["play", "--profile", &design, "--velocity", "20", "--a-max-um", &a_max, "-o", &wav]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(std::fs::read(&wav).unwrap(), stated);
    assert!(stderr(&out).contains("channel 2 (ultrasonic amplitude envelope, um"), "{}", stderr(&out));
    let read = haptex_core::signal::read_drive_wav(Path::new(&wav)).unwrap();
    let c2 = read.scale.channel_2.as_ref().unwrap();
    assert_eq!(c2.um_per_full_scale, a_max.parse::<f64>().unwrap());
    let amplitude = read.amplitude_um.as_ref().unwrap();
    assert!(amplitude.iter().all(|&a| a >= 0.0 && a <= c2.a_max_um));
    assert!(amplitude.iter().any(|&a| a > 0.0), "the descent needs the plate");
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(format!("{wav}.json")).unwrap()).unwrap();
    assert_eq!(sidecar["channels"], 2);
    assert_eq!(sidecar["channel_2"]["unit"], "um");
    let out = haptex(&["play", "--check", &wav]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("channel 2: ")
            && stderr(&out).contains("um of ultrasonic amplitude per full-scale sample"),
        "{}",
        stderr(&out)
    );

    // CSV: the amplitude as a fifth column, within a_max.
    let csv = path(d, "d_signal.csv");
    let out = haptex(&["play", "--profile", &design, "--velocity", "20", "--a-max-um", &a_max, "-o", &csv, "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    assert_eq!(lines.next(), Some("t_s,x_mm,envelope_v,signal_v,amplitude_um"));
    let a_max_f: f64 = a_max.parse().unwrap();
    for line in lines {
        let a: f64 = line.rsplit(',').next().unwrap().parse().unwrap();
        assert!((0.0..=a_max_f).contains(&a), "{line}");
    }

    // A tampered channel-2 scale in the sidecar.
    let sidecar_file = format!("{wav}.json");
    let text = std::fs::read_to_string(&sidecar_file).unwrap();
    let tampered = text.replacen(&format!("\"um_per_full_scale\": {a_max}"), "\"um_per_full_scale\": 9.0", 1);
    assert_ne!(tampered, text);
    std::fs::write(&sidecar_file, tampered).unwrap();
    let out = haptex(&["play", "--check", &wav]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("does not belong to it"), "{}", stderr(&out));

    // Channel 2 on the plate's resonance (--plate-resonance-hz): at
    // 192 kHz a 40 kHz plate plays, its displacement signed and within
    // a_max, the chunk, the sidecar, --check and the CSV's column naming
    // it; channel 1 is the sample-for-sample the envelope render's. At
    // 48 kHz, or for a one-channel design, it is refused and nothing is
    // written.
    let plate = path(d, "plate.wav");
    let base = ["play", "--profile", &design, "--velocity", "20", "--sample-rate", "192000", "-q"];
    let run = |extra: &[&str]| haptex(&[&base[..], extra].concat());
    let envelope = path(d, "envelope.wav");
    assert!(run(&["-o", &envelope]).status.success());
    let out = run(&["--plate-resonance-hz", "40000", "-o", &plate]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (on, off) = (
        haptex_core::signal::read_drive_wav(Path::new(&plate)).unwrap(),
        haptex_core::signal::read_drive_wav(Path::new(&envelope)).unwrap(),
    );
    assert_eq!(on.volts, off.volts);
    let c2 = on.scale.channel_2.as_ref().unwrap();
    assert_eq!(c2.resonance_hz, Some(40_000.0));
    let (d_um, a_um) = (on.amplitude_um.as_ref().unwrap(), off.amplitude_um.as_ref().unwrap());
    assert!(d_um.iter().zip(a_um).all(|(d, a)| d.abs() <= a + 1e-4 && d.abs() <= c2.a_max_um));
    let peak = a_um.iter().fold(0.0f64, |m, &a| m.max(a));
    assert!(d_um.iter().any(|&v| v < -0.5 * peak), "the displacement swings below zero (envelope peak {peak} um)");
    let out = haptex(&["play", "--check", &plate]);
    assert!(stderr(&out).contains("plate displacement on its resonance 40000 Hz"), "{}", stderr(&out));
    let plate_csv = path(d, "plate.csv");
    assert!(run(&["--plate-resonance-hz", "40000", "-o", &plate_csv]).status.success());
    let text = std::fs::read_to_string(&plate_csv).unwrap();
    assert!(text.lines().any(|l| l == "t_s,x_mm,envelope_v,signal_v,displacement_um"), "{:.600}", text);
    let refused = path(d, "refused.wav");
    let out =
        haptex(&["play", "--profile", &design, "--velocity", "20", "--plate-resonance-hz", "40000", "-o", &refused]);
    assert!(
        !out.status.success() && stderr(&out).contains("needs a sample rate of at least 88889 Hz"),
        "{}",
        stderr(&out)
    );
    let electro = path(d, "electro.csv");
    let out = haptex(&["voltage", "--profile", "../../data/examples/bump_friction.csv", "-q", "-o", &electro]);
    assert!(out.status.success());
    let out = haptex(&[
        "play",
        "--profile",
        &electro,
        "--velocity",
        "20",
        "--sample-rate",
        "192000",
        "--plate-resonance-hz",
        "40000",
        "-o",
        &refused,
    ]);
    assert!(!out.status.success() && stderr(&out).contains("two-channel drive"), "{}", stderr(&out));
    assert!(!Path::new(&refused).exists());

    // simulate still refuses such a profile (its voltage alone is not the design).
    let out = haptex(&["simulate", "--surface", "display", "--voltage", &design, "-o", &path(d, "s.csv")]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("designed for a combined display"), "{}", stderr(&out));
}

/// A float32 WAV `haptex play` wrote (volts per full scale 150 V), and
/// its path in `dir`.
fn float_wav(dir: &Path) -> (String, Vec<u8>) {
    let u = write(dir, "u.csv", "x_mm,voltage_v\n0,10\n10,40\n");
    let wav = path(dir, "drive.wav");
    let out = haptex(&[
        "play",
        "--profile",
        &u,
        "--velocity",
        "100",
        "--wav-format",
        "float32",
        "--volts-per-full-scale",
        "150",
        "-o",
        &wav,
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    std::fs::remove_file(format!("{wav}.json")).unwrap();
    let bytes = std::fs::read(&wav).unwrap();
    (wav, bytes)
}

/// `haptex play --check` on forged bytes: refused with a "cannot read"
/// message containing `fragment`.
fn check_refuses(wav: &str, bytes: &[u8], fragment: &str) {
    std::fs::write(wav, bytes).unwrap();
    let out = haptex(&["play", "--check", wav]);
    let text = stderr(&out);
    assert!(!out.status.success(), "a forged WAV passed --check: {text}");
    assert!(text.contains("cannot read the WAV file") && text.contains(fragment), "{fragment}: {text}");
    assert!(!text.contains("cannot encode") && !text.contains("peak"), "{text}");
}

/// Issue 35, through `haptex play --check`: a float32 WAV whose format tag
/// was edited to integer PCM (2 bytes, hashes recomputed) passed, and
/// every other program then read the float bit patterns as integer noise.
#[test]
fn wav_format_fields_are_covered_by_the_scale_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let (wav, bytes) = float_wav(dir.path());
    assert!(haptex(&["play", "--check", &wav]).status.success());
    // WAVE_FORMAT_EXTENSIBLE relabelled as WAVE_FORMAT_PCM.
    let forged = forge_wav::forge(&bytes, |p| forge_wav::put_u16(&mut p.fmt, 0, 1));
    check_refuses(&wav, &forged, "format tag 1 where the scale chunk says 65534");
    // The subformat GUID: IEEE float relabelled as integer PCM.
    let forged = forge_wav::forge(&bytes, |p| p.fmt[24] = 1);
    check_refuses(&wav, &forged, "subformat");
}

/// Issue 35, through `haptex play --check`: NaN, an infinity or 50.0 in
/// channel 1 of a float WAV (hashes recomputed) passed as "peak inf V" or
/// "peak 7071 V", and a rate of 0 Hz as "0 Hz (inf s) ... ok".
#[test]
fn every_channel_of_every_sample_is_checked() {
    let dir = tempfile::tempdir().unwrap();
    let (wav, bytes) = float_wav(dir.path());
    for value in [f32::NAN, f32::INFINITY, 50.0] {
        let forged = forge_wav::forge(&bytes, |p| p.data[400..404].copy_from_slice(&value.to_le_bytes()));
        check_refuses(&wav, &forged, "channel 1's sample 100");
    }
    let forged = forge_wav::forge(&bytes, |p| {
        forge_wav::put_u32(&mut p.fmt, 4, 0);
        forge_wav::put_u32(&mut p.fmt, 8, 0);
        p.scale["sample_rate_hz"] = 0.into();
        if let Some(fields) = p.scale.get_mut("fmt") {
            fields["sample_rate_hz"] = 0.into();
            fields["byte_rate"] = 0.into();
        }
    });
    check_refuses(&wav, &forged, "0 Hz");
}
