//! `haptex library` end to end: the binary, its files and its errors, and
//! the issue 6 acceptance tests that need a real process (killing an
//! import, readers during an import).

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use haptex_core::library::Library;
use haptex_core::recording::rng::SplitMix64;
use haptex_core::recording::synth::{PressProfile, StrokeModel, Trajectory};
use haptex_core::recording::{Recording, RecordingMeta, StreamFormat, StreamMeta, Units};

mod common;
use common::{haptex, stderr};

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}

#[test]
fn demo_import_list_sample_export_and_voltage() {
    let dir = tempfile::tempdir().unwrap();
    let demo = dir.path().join("demo");
    let db = dir.path().join("lib.sqlite");
    let out = haptex(&["library", "demo", "--out", s(&demo), "--strokes", "1"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("wrote 12 SYNTHETIC recordings"), "{}", stderr(&out));

    let out = haptex(&["library", "import", "--db", s(&db), s(&demo)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("imported 12 strokes"), "{}", stderr(&out));
    // Importing again adds nothing.
    let out = haptex(&["library", "import", "--db", s(&db), s(&demo)]);
    assert!(stderr(&out).contains("imported 0 strokes") && stderr(&out).contains("12 already there"));

    let out = haptex(&["library", "list", "--db", s(&db)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(text.contains("12 materials, 12 strokes"), "{text}");
    assert_eq!(text.lines().filter(|l| l.contains(" SYNTHETIC ")).count(), 12, "{text}");
    assert!(text.contains("SYNTHETIC materials are generated"), "{text}");
    let out = haptex(&["library", "list", "--db", s(&db), "--format", "json"]);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["materials"].as_array().unwrap().len(), 12);
    assert!(json["materials"].as_array().unwrap().iter().all(|m| m["synthetic"] == true));

    // sample: seeded, repeatable, a profile `haptex voltage` reads.
    let a = dir.path().join("a.csv");
    let b = dir.path().join("b.csv");
    for path in [&a, &b] {
        let out = haptex(&["library", "sample", "--db", s(&db), "--material", "Velvet", "--seed", "5", "-o", s(path)]);
        assert!(out.status.success(), "{}", stderr(&out));
        assert!(stderr(&out).contains("(SYNTHETIC data)"), "{}", stderr(&out));
    }
    let text = std::fs::read_to_string(&a).unwrap();
    assert_eq!(text, std::fs::read_to_string(&b).unwrap());
    assert!(text.lines().any(|l| l == "x_mm,mu,fn_n"), "{text}");
    assert!(text.contains("SYNTHETIC (generated, not measured)"));
    let out = haptex(&["voltage", "--profile", s(&a), "--area-exponent", "0.7", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).lines().any(|l| l.starts_with("x_mm,mu,voltage_v")));

    let out = haptex(&["library", "sample", "--db", s(&db), "--material", "granite"]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("no material named \"granite\" in the library (it has: \"aluminium\", \"latex\""),
        "{}",
        stderr(&out)
    );

    let export = dir.path().join("export");
    let out = haptex(&["library", "export", "--db", s(&db), "--out", s(&export)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(export.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["strokes"].as_array().unwrap().len(), 12);
    let file = manifest["strokes"][0]["file"].as_str().unwrap();
    assert!(haptex(&["voltage", "--profile", s(&export.join(file)), "-q"]).status.success());

    let out = haptex(&["library", "check", "--db", s(&db)]);
    assert!(out.status.success() && stdout(&out).contains("consistent (12 materials, 12 strokes)"), "{}", stdout(&out));
}

#[test]
fn user_profiles_import_as_measured_materials() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("lib.sqlite");
    let profile = dir.path().join("bump.csv");
    std::fs::write(&profile, "x_mm,mu\n0,1.1\n1,1.2\n2,1.1\n").unwrap();
    let out = haptex(&[
        "library",
        "import",
        "--db",
        s(&db),
        "--profile",
        s(&profile),
        "--material",
        "my bump",
        "--licence",
        "CC0-1.0",
        "--measured",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&haptex(&["library", "list", "--db", s(&db)]));
    assert!(text.contains("my bump") && text.contains("measured") && !text.contains("SYNTHETIC"), "{text}");
    let out = haptex(&["library", "sample", "--db", s(&db), "--material", "my bump", "--seed", "1"]);
    assert!(stdout(&out).contains("x_mm,mu\n0.0,1.1\n1.0,1.2\n2.0,1.1\n"), "{}", stdout(&out));

    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "x_mm,mu\n0,1.1\n0,1.2\n").unwrap();
    let out = haptex(&["library", "import", "--db", s(&db), "--profile", s(&bad), "--material", "x", "--measured"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("bad.csv, line 3, column 'x_mm'"), "{}", stderr(&out));
}

/// Issue 13: a profile's provenance must be stated (an FE-predicted profile
/// used to enter the library as "measured" by default), and it is carried
/// through list, sample and export.
#[test]
fn profile_import_requires_its_provenance() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("lib.sqlite");
    let profile = dir.path().join("fe.csv");
    std::fs::write(&profile, "x_mm,mu\n0,0.5\n1,0.6\n2,0.5\n").unwrap();
    let import = |extra: &[&str]| {
        let mut args = vec!["library", "import", "--db", s(&db), "--profile", s(&profile), "--material", "fe bump"];
        args.extend_from_slice(extra);
        haptex(&args)
    };
    let out = import(&[]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--measured") && stderr(&out).contains("--synthetic"), "{}", stderr(&out));
    assert!(!db.exists(), "a refused import created the library");
    let out = import(&["--measured", "--synthetic"]);
    assert!(!out.status.success(), "both kinds accepted");

    let out = import(&["--synthetic", "--source", "haptex predict"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&haptex(&["library", "list", "--db", s(&db)]));
    assert!(text.contains("fe bump") && text.contains("SYNTHETIC"), "{text}");
    let out = haptex(&["library", "sample", "--db", s(&db), "--material", "fe bump", "--seed", "1"]);
    assert!(stdout(&out).contains("SYNTHETIC"), "{}", stdout(&out));
    let export = dir.path().join("export");
    assert!(haptex(&["library", "export", "--db", s(&db), "--out", s(&export)]).status.success());
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(export.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["strokes"][0]["stroke"]["synthetic"], true);
}

#[test]
fn malformed_recordings_fail_with_file_and_line_and_the_rest_is_imported() {
    let dir = tempfile::tempdir().unwrap();
    let recordings = dir.path().join("rec");
    std::fs::create_dir(&recordings).unwrap();
    let good = short_recording(1, 0.6);
    good.write(&recordings, "good", StreamFormat::Csv).unwrap();
    good.write(&recordings, "bad", StreamFormat::Csv).unwrap();
    let force = recordings.join("bad.force.csv");
    let text = std::fs::read_to_string(&force).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[100] = "0.1,NaN,0.2";
    std::fs::write(&force, lines.join("\n")).unwrap();
    let db = dir.path().join("lib.sqlite");
    let out = haptex(&["library", "import", "--db", s(&db), s(&recordings)]);
    assert!(!out.status.success());
    let message = stderr(&out);
    assert!(message.contains("bad.force.csv, line 101, column 'fn_n': not a finite number: \"NaN\""), "{message}");
    assert!(message.contains("imported 1 strokes") && message.contains("1 failed"), "{message}");
    assert!(message.contains("1 of 2 recordings could not be imported"), "{message}");

    let out = haptex(&["library", "list", "--db", s(&dir.path().join("missing.sqlite"))]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("missing.sqlite: no library there"), "{}", stderr(&out));
}

#[test]
fn process_writes_a_profile_and_the_position_rate_series() {
    let dir = tempfile::tempdir().unwrap();
    let meta = short_recording(2, 0.8).write(dir.path(), "r", StreamFormat::Npy).unwrap();
    let profile = dir.path().join("p.csv");
    let series = dir.path().join("s.csv");
    let out = haptex(&["library", "process", s(&meta), "-o", s(&profile), "--series", s(&series)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("segment 1: Forward"), "{}", stderr(&out));
    assert!(std::fs::read_to_string(&series).unwrap().starts_with("t_s,x_mm,v_mm_s,fn_n,ft_n,segment\n"));
    assert!(haptex(&["voltage", "--profile", s(&profile), "-q"]).status.success());
    let out = haptex(&["library", "process", s(&meta), "--min-speed-mm-s", "1000"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("no sliding found"), "{}", stderr(&out));
}

/// One short stroke (0 -> 20 mm) on a constant-friction surface, with
/// `stroke` in its metadata so that copies differ in content.
fn short_recording(stroke: u32, duration_s: f64) -> Recording {
    let trajectory = Trajectory::starting_at(0.0).hold(0.1).move_to(20.0, duration_s - 0.2).hold(0.1);
    let press = PressProfile { fn0_n: 0.5, wobble: 0.0, wobble_hz: 1.0, wobble_phase: 0.0, ramp_s: 0.05, duration_s };
    let fn_n = |t: f64| press.at(t);
    let mu = |x: f64| 0.5 + 0.05 * (x / 2.0).sin();
    let model = StrokeModel {
        force_rate_hz: 20_000.0,
        position_rate_hz: 400.0,
        trajectory: &trajectory,
        mu: &mu,
        fn_n: &fn_n,
        stiction_speed_mm_s: 2.0,
        force_noise_n: 0.003,
        position_noise_mm: 0.01,
        tones: &[],
    };
    let (force, position) = model.generate(&mut SplitMix64::new(u64::from(stroke)));
    Recording::from_parts("test", meta(stroke), force, position).unwrap()
}

fn meta(stroke: u32) -> RecordingMeta {
    RecordingMeta {
        format: "haptex-recording-1".into(),
        material: "test material".into(),
        material_description: String::new(),
        participant: "P1".into(),
        stroke,
        force: StreamMeta { file: String::new(), rate_hz: 20_000.0 },
        position: StreamMeta { file: String::new(), rate_hz: 400.0 },
        units: Units::default(),
        source: "haptex test".into(),
        licence: "CC0-1.0".into(),
        synthetic: false,
        notes: String::new(),
        extra: serde_json::Value::Null,
    }
}

/// `n` recordings in `dir`: one stroke's streams with `n` different
/// metadata files (stroke numbers), so each has its own content hash.
fn many_recordings(dir: &Path, n: u32) -> PathBuf {
    let recordings = dir.join("many");
    std::fs::create_dir(&recordings).unwrap();
    let base = short_recording(1, 0.5);
    for k in 0..n {
        let mut r = base.clone();
        r.meta.stroke = k + 1;
        r.write(&recordings, &format!("r{k:04}"), StreamFormat::Npy).unwrap();
    }
    recordings
}

/// Issue 6 acceptance: a real `haptex library import` process is killed
/// (SIGKILL) in the middle of a big import while readers work beside it.
/// The readers (in this process, and `haptex library list` processes) never
/// fail; after the kill the database passes SQLite's integrity and
/// foreign-key checks and holds only complete strokes (each with its
/// profile); `list` reports the interrupted import, and running the import
/// again completes it without duplicates.
#[test]
fn killing_an_import_leaves_a_consistent_library_and_readers_work_meanwhile() {
    const N: u32 = 400;
    let dir = tempfile::tempdir().unwrap();
    let recordings = many_recordings(dir.path(), N);
    let db = dir.path().join("lib.sqlite");
    let mut child = Command::new(env!("CARGO_BIN_EXE_haptex"))
        .args(["library", "import", "--quiet", "--db", s(&db), s(&recordings)])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();

    // A reader: wait until the library exists, then read continuously.
    let start = Instant::now();
    let reader = loop {
        if let Ok(library) = Library::open_read_only(&db) {
            break library;
        }
        assert!(start.elapsed() < Duration::from_secs(20), "the import never created the library");
        std::thread::sleep(Duration::from_millis(1));
    };
    let mut seen = 0;
    let mut reader_processes = 0;
    while seen < 60 {
        let strokes: u64 =
            reader.materials().expect("a reader works during the import").iter().map(|m| m.strokes).sum();
        assert!(strokes as usize >= seen, "the library shrank: {strokes} < {seen}");
        seen = strokes as usize;
        if seen > 0 {
            reader.sample("test material", Some(seen as u64)).expect("sampling works during the import");
        }
        if seen >= 20 && reader_processes < 2 {
            let out = haptex(&["library", "list", "--db", s(&db)]);
            assert!(out.status.success(), "list during the import: {}", stderr(&out));
            reader_processes += 1;
        }
        assert!(child.try_wait().unwrap().is_none(), "the import finished before it could be killed");
        assert!(start.elapsed() < Duration::from_secs(60), "the import makes no progress");
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    drop(reader);

    let library = Library::open_read_only(&db).unwrap();
    assert_eq!(library.check().unwrap(), Vec::<String>::new());
    let kept: u64 = library.materials().unwrap().iter().map(|m| m.strokes).sum();
    assert!(kept >= 60 && kept < u64::from(N), "{kept} strokes after the kill");
    let imports = library.imports().unwrap();
    assert_eq!(imports.len(), 1);
    assert!(imports[0].finished_at.is_none());
    drop(library);
    let out = haptex(&["library", "list", "--db", s(&db)]);
    assert!(stderr(&out).contains("did not finish"), "{}", stderr(&out));

    let out = haptex(&["library", "import", "--db", s(&db), s(&recordings)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains(&format!("imported {} strokes", u64::from(N) - kept)), "{}", stderr(&out));
    let library = Library::open_read_only(&db).unwrap();
    assert_eq!(library.check().unwrap(), Vec::<String>::new());
    assert_eq!(library.strokes("test material").unwrap().len(), N as usize);
}

/// The converter of docs/recordings.md (scripts/convert_recording.py,
/// Python standard library only) turns a generic export in ms, mN and m
/// with the friction force reported on the finger into a recording that
/// processes to the same profile as the original.
#[test]
fn python_converter_produces_an_importable_recording() {
    let dir = tempfile::tempdir().unwrap();
    let rec = short_recording(3, 0.8);
    let mut force = String::from("# lab export\ntime,Fz,Fx\n");
    for i in 0..rec.force.t_s.len() {
        force += &format!("{},{},{}\n", rec.force.t_s[i] * 1e3, rec.force.fn_n[i] * 1e3, -rec.force.ft_n[i] * 1e3);
    }
    let mut track = String::from("time,X\n");
    for k in 0..rec.position.t_s.len() {
        track += &format!("{},{}\n", rec.position.t_s[k] * 1e3, rec.position.x_mm[k] * 1e-3);
    }
    std::fs::write(dir.path().join("forces.csv"), force).unwrap();
    std::fs::write(dir.path().join("track.csv"), track).unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/convert_recording.py");
    let out = Command::new("python3")
        .arg(&script)
        .args(["--force", "forces.csv", "--force-columns", "time,Fz,Fx", "--position", "track.csv"])
        .args(["--position-columns", "time,X", "--time-unit", "ms", "--force-unit", "mN", "--position-unit", "m"])
        .args(["--flip-ft", "--force-rate", "20000", "--position-rate", "400", "--material", "test material"])
        .args(["--participant", "P1", "--stroke", "3", "--source", "converter test", "--licence", "CC0-1.0"])
        .args(["--out", "converted", "--name", "trial"])
        .current_dir(dir.path())
        .output()
        .expect("python3 runs");
    assert!(out.status.success(), "{}", stderr(&out));
    let converted = Recording::load(&dir.path().join("converted/trial.recording.json")).unwrap();
    let config = haptex_core::recording::ProcessingConfig::default();
    let a = haptex_core::recording::process(&converted, &config).unwrap().profile;
    let b = haptex_core::recording::process(&rec, &config).unwrap().profile;
    assert_eq!(a.x_mm(), b.x_mm());
    // Unit conversion rounds in the last digits only.
    let diff = a.mu().iter().zip(b.mu()).fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
    assert!(diff < 1e-9, "{diff}");
}

/// Issue 13: a multi-file output appears whole or is detectably
/// incomplete. An export killed before its manifest leaves no manifest
/// (the old one is removed first); a complete export lists the hash of
/// every file it wrote, and the files match it.
#[test]
fn export_is_whole_or_detectably_incomplete() {
    let dir = tempfile::tempdir().unwrap();
    let db = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/library/library.sqlite");
    let export = dir.path().join("export");
    assert!(haptex(&["library", "export", "--db", s(&db), "--out", s(&export)]).status.success());
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(export.join("manifest.json")).unwrap()).unwrap();
    let files = manifest["files_sha256"].as_object().unwrap();
    assert_eq!(files.len(), manifest["strokes"].as_array().unwrap().len());
    assert!(files.len() >= 12);
    let members: haptex_core::io::MemberHashes =
        files.iter().map(|(k, v)| (k.clone(), v.as_str().unwrap().to_string())).collect();
    haptex_core::io::verify_members(&export, &members).unwrap();

    let killed = Command::new(env!("CARGO_BIN_EXE_haptex"))
        .args(["library", "export", "--db", s(&db), "--out", s(&export)])
        .env("HAPTEX_FAULT_INJECT", "before-marker")
        .output()
        .unwrap();
    assert!(!killed.status.success(), "the fault hook did not fire");
    assert!(!export.join("manifest.json").exists(), "an interrupted export kept a manifest");
    // A rerun completes it.
    assert!(haptex(&["library", "export", "--db", s(&db), "--out", s(&export)]).status.success());
    assert!(export.join("manifest.json").exists());
}

/// Issue 13, "linear in the input": a recordings directory holding two
/// symbolic links to itself made the import walk exponential (endless in
/// practice); each real directory is now entered once.
#[cfg(unix)]
#[test]
fn directory_walk_enters_each_directory_once() {
    let dir = tempfile::tempdir().unwrap();
    let recordings = dir.path().join("rec");
    std::fs::create_dir(&recordings).unwrap();
    short_recording(1, 0.6).write(&recordings, "one", StreamFormat::Csv).unwrap();
    std::os::unix::fs::symlink(&recordings, recordings.join("loop-a")).unwrap();
    std::os::unix::fs::symlink("..", recordings.join("loop-b")).unwrap();
    let db = dir.path().join("lib.sqlite");
    let out = Command::new(env!("CARGO_BIN_EXE_haptex"))
        .args(["library", "import", "--db", s(&db), s(&recordings), "-q"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&haptex(&["library", "list", "--db", s(&db)]));
    assert!(text.contains("1 materials, 1 strokes") || text.contains("1 material, 1 stroke"), "{text}");
}

/// Issue 35: a profile's mu below zero is the surface pushing the finger
/// along (`haptex_core::ranges::MU`, which the FE finger's own profiles
/// reach on steep downslopes): `library import --profile` keeps it, in both
/// the mu and the force form; beyond +-1000 it refuses, naming file, line
/// and column, and creates no library.
#[test]
fn friction_below_zero_is_kept_and_beyond_the_range_refused() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("lib.sqlite");
    for (k, text) in ["x_mm,mu\n0,0.5\n1,-0.2\n", "x_mm,ft_n,fn_n\n0,0.2,0.5\n1,-0.1,0.5\n"].iter().enumerate() {
        let profile = dir.path().join(format!("neg{k}.csv"));
        std::fs::write(&profile, text).unwrap();
        let material = format!("m{k}");
        let args =
            ["library", "import", "--db", s(&db), "--profile", s(&profile), "--material", &material, "--measured"];
        let out = haptex(&args);
        assert!(out.status.success(), "{text:?}: {}", stderr(&out));
    }
    let other = dir.path().join("other.sqlite");
    for (text, fragment) in [
        ("x_mm,mu\n0,0.5\n1,-1000.5\n", "line 3, column 'mu': mu must be from -1000 to 1000, got -1000.5"),
        ("x_mm,ft_n,fn_n\n0,0.2,0.5\n1,-90,0.01\n", "line 3, column 'fn_n'"),
    ] {
        let profile = dir.path().join("far.csv");
        std::fs::write(&profile, text).unwrap();
        let args = ["library", "import", "--db", s(&other), "--profile", s(&profile), "--material", "m", "--measured"];
        let out = haptex(&args);
        assert!(!out.status.success(), "{text:?}");
        assert!(stderr(&out).contains(fragment), "{text:?}: {}", stderr(&out));
        assert!(!other.exists(), "a refused import created the library");
    }
}
