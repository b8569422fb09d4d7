//! The raw recording format: reading CSV and NPY streams, and the errors
//! for malformed recordings (issue 6 acceptance: mismatched lengths,
//! non-monotone time, NaN, wrong units; each names the file and the line).

use std::path::{Path, PathBuf};

use haptex_core::recording::format::write_npy_f32;
use haptex_core::recording::synth::demo_recordings;
use haptex_core::recording::{ProcessingConfig, Recording, RecordingError, StreamFormat, process};

const META: &str = r#"{
  "format": "haptex-recording-1",
  "material": "test",
  "participant": "P1",
  "stroke": 1,
  "force": {"file": "s.force.csv", "rate_hz": 1000},
  "position": {"file": "s.position.csv", "rate_hz": 100},
  "units": {"time": "s", "force": "N", "position": "mm"},
  "source": "hand-written test data",
  "licence": "CC0-1.0"
}
"#;

/// A valid 1000 Hz / 100 Hz recording of 0.1 s, as CSV text.
fn force_csv() -> String {
    let mut s = String::from("# force\nt_s,fn_n,ft_n\n");
    for i in 0..=100 {
        s += &format!("{},{},{}\n", i as f64 / 1000.0, 0.5, 0.25);
    }
    s
}

fn position_csv() -> String {
    let mut s = String::from("t_s,x_mm\n");
    for k in 0..=10 {
        s += &format!("{},{}\n", k as f64 / 100.0, k as f64);
    }
    s
}

fn write_recording(dir: &Path, meta: &str, force: &str, position: &str) -> PathBuf {
    std::fs::write(dir.join("s.force.csv"), force).unwrap();
    std::fs::write(dir.join("s.position.csv"), position).unwrap();
    let path = dir.join("s.recording.json");
    std::fs::write(&path, meta).unwrap();
    path
}

fn load_error(meta: &str, force: &str, position: &str) -> (RecordingError, String) {
    let dir = tempfile::tempdir().unwrap();
    let path = write_recording(dir.path(), meta, force, position);
    let err = Recording::load(&path).unwrap_err();
    let message = err.to_string().replace(&format!("{}/", dir.path().display()), "");
    (err, message)
}

#[test]
fn a_valid_csv_recording_loads_with_its_hash() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_recording(dir.path(), META, &force_csv(), &position_csv());
    let rec = Recording::load(&path).unwrap();
    assert_eq!(rec.force.t_s.len(), 101);
    assert_eq!(rec.position.x_mm[10], 10.0);
    assert_eq!(rec.sha256.as_ref().unwrap().len(), 64);
    // The hash covers the stream contents.
    std::fs::write(dir.path().join("s.position.csv"), position_csv().replace(",10\n", ",10.5\n")).unwrap();
    assert_ne!(Recording::load(&path).unwrap().sha256, rec.sha256);
}

#[test]
fn mismatched_lengths_name_both_files() {
    // The position stream stops at 0.05 s, the force stream at 0.1 s.
    let short: String = position_csv().lines().take(7).map(|l| format!("{l}\n")).collect();
    let (err, message) = load_error(META, &force_csv(), &short);
    assert!(matches!(err, RecordingError::Mismatch { .. }), "{message}");
    assert!(message.contains("mismatched lengths"), "{message}");
    assert!(message.contains("s.force.csv (101 samples") && message.contains("s.position.csv (6 samples"), "{message}");
}

#[test]
fn a_row_with_a_missing_field_names_its_line() {
    let force = force_csv().replace("0.05,0.5,0.25\n", "0.05,0.5\n");
    let (_, message) = load_error(META, &force, &position_csv());
    assert_eq!(message, "s.force.csv, line 53: expected 3 fields as in the header, found 2");
}

#[test]
fn non_monotone_time_names_its_line() {
    let position = position_csv().replace("0.05,5\n", "0.035,5\n");
    let (_, message) = load_error(META, &force_csv(), &position);
    assert_eq!(message, "s.position.csv, line 7, column 't_s': time must increase strictly: 0.035 s follows 0.04 s");
}

#[test]
fn nan_names_its_line_and_column() {
    let force = force_csv().replace("0.02,0.5,0.25\n", "0.02,NaN,0.25\n");
    let (_, message) = load_error(META, &force, &position_csv());
    assert_eq!(message, "s.force.csv, line 23, column 'fn_n': not a finite number: \"NaN\"");
}

#[test]
fn wrong_units_in_a_header_or_the_metadata_are_named() {
    let force = force_csv().replace("t_s,fn_n,ft_n", "t_ms,fn_n,ft_n");
    let (_, message) = load_error(META, &force, &position_csv());
    assert_eq!(
        message,
        "s.force.csv, line 2, column 't_ms': wrong unit in the header: haptex recordings need column 't_s' \
         (seconds); convert the data"
    );
    let position = position_csv().replace("x_mm", "x_m");
    let (_, message) = load_error(META, &force_csv(), &position);
    assert!(message.starts_with("s.position.csv, line 1, column 'x_m': wrong unit"), "{message}");

    let meta = META.replace(r#""force": "N""#, r#""force": "mN""#);
    let (_, message) = load_error(&meta, &force_csv(), &position_csv());
    assert!(message.starts_with("s.recording.json, field 'units.force': is \"mN\""), "{message}");
}

#[test]
fn a_missing_column_is_named() {
    let force = force_csv().replace("t_s,fn_n,ft_n", "t_s,fn_n,fx_n");
    let (_, message) = load_error(META, &force, &position_csv());
    assert!(message.starts_with("s.force.csv, line 2, column 'ft_n': required column is missing"), "{message}");
}

#[test]
fn a_declared_rate_that_does_not_match_the_timestamps_is_named() {
    let meta = META.replace(r#""rate_hz": 1000"#, r#""rate_hz": 2000"#);
    let (_, message) = load_error(&meta, &force_csv(), &position_csv());
    assert!(message.starts_with("s.recording.json, field 'force.rate_hz': declares 2000 Hz"), "{message}");
}

#[test]
fn a_gap_in_the_force_stream_is_named() {
    let force: String = force_csv().lines().filter(|l| !l.starts_with("0.03,")).map(|l| format!("{l}\n")).collect();
    let (_, message) = load_error(META, &force, &position_csv());
    assert!(message.starts_with("s.force.csv, line 33, column 't_s': sample interval 2.0000e-3 s"), "{message}");
}

#[test]
fn malformed_metadata_is_named_with_its_line() {
    let meta = META.replace("  \"participant\": \"P1\",\n", "");
    let (_, message) = load_error(&meta, &force_csv(), &position_csv());
    assert!(
        message.starts_with("s.recording.json: invalid metadata: missing field `participant` at line"),
        "{message}"
    );
    let meta = META.replace("\"licence\"", "\"licnce\"");
    let (_, message) = load_error(&meta, &force_csv(), &position_csv());
    assert!(message.contains("unknown field `licnce`") && message.contains("line 10"), "{message}");
    let (_, message) = load_error("{", &force_csv(), &position_csv());
    assert!(message.contains("line 1"), "{message}");
}

#[test]
fn a_missing_stream_file_is_named() {
    let meta = META.replace("s.force.csv", "nowhere.csv");
    let (err, message) = load_error(&meta, &force_csv(), &position_csv());
    assert!(matches!(err, RecordingError::Io { .. }));
    assert!(message.starts_with("nowhere.csv: cannot read"), "{message}");
}

#[test]
fn npy_streams_report_rows_and_shapes() {
    let dir = tempfile::tempdir().unwrap();
    let meta = META.replace(".csv", ".npy");
    std::fs::write(dir.path().join("s.recording.json"), &meta).unwrap();
    let t: Vec<f64> = (0..=100).map(|i| i as f64 / 1000.0).collect();
    let mut fn_n = vec![0.5; 101];
    let ft_n = vec![0.25; 101];
    let tp: Vec<f64> = (0..=10).map(|k| k as f64 / 100.0).collect();
    let x: Vec<f64> = (0..=10).map(f64::from).collect();
    write_npy_f32(&dir.path().join("s.position.npy"), &[&tp, &x]).unwrap();
    write_npy_f32(&dir.path().join("s.force.npy"), &[&t, &fn_n, &ft_n]).unwrap();
    let path = dir.path().join("s.recording.json");
    let rec = Recording::load(&path).unwrap();
    assert_eq!(rec.force.fn_n[7], 0.5);

    fn_n[42] = f64::NAN;
    write_npy_f32(&dir.path().join("s.force.npy"), &[&t, &fn_n, &ft_n]).unwrap();
    let message = Recording::load(&path).unwrap_err().to_string();
    assert!(message.ends_with("s.force.npy, row 42, column 'fn_n': not a finite number: NaN"), "{message}");

    write_npy_f32(&dir.path().join("s.force.npy"), &[&t, &ft_n]).unwrap();
    let message = Recording::load(&path).unwrap_err().to_string();
    assert!(
        message.ends_with("s.force.npy: array shape [101, 2]: expected (samples, 3) with columns t_s, fn_n, ft_n"),
        "{message}"
    );

    std::fs::write(dir.path().join("s.force.npy"), b"not an npy file").unwrap();
    let message = Recording::load(&path).unwrap_err().to_string();
    assert!(message.contains("s.force.npy: not a valid NPY file"), "{message}");
}

/// A recording written as CSV reads back exactly (shortest round-trip
/// number formatting) and processes to the same profile as in memory.
#[test]
fn csv_written_recordings_process_identically() {
    let (stem, rec) = demo_recordings(5, 1).swap_remove(0);
    let dir = tempfile::tempdir().unwrap();
    let path = rec.write(dir.path(), &stem, StreamFormat::Csv).unwrap();
    let back = Recording::load(&path).unwrap();
    assert_eq!(back.force, rec.force);
    assert_eq!(back.position, rec.position);
    assert_eq!(back.meta.extra, rec.meta.extra);
    let config = ProcessingConfig::default();
    assert_eq!(process(&back, &config).unwrap().profile, process(&rec, &config).unwrap().profile);
}

/// Issue 13: metadata that names a device, a FIFO, a directory, a path
/// outside the recording's directory (absolute, `..`, or a symbolic link
/// leading out) is refused before anything is read from it, with the field
/// and the reason. (`/dev/zero` used to be read until memory ran out; a
/// FIFO would block forever.)
#[test]
fn recording_streams_must_be_regular_files_inside_its_directory() {
    let outside = tempfile::tempdir().unwrap();
    std::fs::write(outside.path().join("far.csv"), force_csv()).unwrap();
    let far = outside.path().join("far.csv");
    let cases: Vec<(String, &str)> = vec![
        ("/dev/zero".into(), "not a file name inside the recording's directory"),
        (far.display().to_string(), "not a file name inside the recording's directory"),
        ("../s.force.csv".into(), "not a file name inside the recording's directory"),
        ("".into(), "not a file name inside the recording's directory"),
        ("link.csv".into(), "leads outside the recording's directory"),
        ("sub".into(), "not a regular file"),
        #[cfg(unix)]
        ("fifo.csv".into(), "not a regular file"),
        ("missing.csv".into(), "missing.csv"),
    ];
    for (file, expected) in cases {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(&far, dir.path().join("link.csv")).unwrap();
            let status = std::process::Command::new("mkfifo").arg(dir.path().join("fifo.csv")).status().unwrap();
            assert!(status.success());
        }
        let meta = META.replace(r#""file": "s.force.csv""#, &format!(r#""file": {}"#, serde_json::json!(file)));
        let path = write_recording(dir.path(), &meta, &force_csv(), &position_csv());
        let message = Recording::load(&path).unwrap_err().to_string();
        // Path errors name the metadata field; file errors name the file.
        let names_field = expected.starts_with("not a file name") || expected.starts_with("leads outside");
        assert!(!names_field || message.contains("force.file"), "{file:?}: {message}");
        assert!(message.contains(expected), "{file:?}: {message}");
    }
    // A symbolic link that stays inside the directory is fine.
    #[cfg(unix)]
    {
        let dir = tempfile::tempdir().unwrap();
        let path = write_recording(dir.path(), META, &force_csv(), &position_csv());
        std::fs::rename(dir.path().join("s.force.csv"), dir.path().join("real.csv")).unwrap();
        std::os::unix::fs::symlink("real.csv", dir.path().join("s.force.csv")).unwrap();
        Recording::load(&path).unwrap();
    }
}

/// An NPY stream whose header claims more values than the file holds is
/// refused before any allocation sized by the claim.
#[test]
fn npy_shape_larger_than_the_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.npy");
    write_npy_f32(&path, &[&[0.0, 0.01], &[0.0, 1.0]]).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    // Claim 4e12 rows in the header, keeping its length (NPY pads the
    // header with spaces to a multiple of 64 bytes).
    let header_end = bytes.iter().position(|&b| b == b'\n').unwrap();
    let header = String::from_utf8_lossy(&bytes[10..header_end]).into_owned();
    let claimed = header.replace("(2, 2", "(4000000000000, 2");
    assert_ne!(header, claimed, "{header}");
    let claimed = claimed.trim_end().to_string();
    let padded = format!("{claimed:<width$}", width = header.len());
    assert_eq!(padded.len(), header.len());
    bytes.splice(10..header_end, padded.into_bytes());
    std::fs::write(&path, &bytes).unwrap();
    let meta = META.replace("s.position.csv", "p.npy");
    std::fs::write(dir.path().join("s.force.csv"), force_csv()).unwrap();
    let meta_path = dir.path().join("s.recording.json");
    std::fs::write(&meta_path, meta).unwrap();
    let message = Recording::load(&meta_path).unwrap_err().to_string();
    assert!(message.contains("claims more values than the file"), "{message}");
}

/// Found by the fuzz campaign: an NPY header whose shape is 90 nested
/// brackets (`'shape': [[[[...`) took the NPY library's header parser
/// exponential time (over 10 s). A header that is not the plain dictionary
/// numpy writes is refused before it is parsed.
#[test]
fn npy_header_with_nested_brackets_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {}", "[".repeat(90));
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend((header.len() as u16).to_le_bytes());
    bytes.extend(header.bytes());
    bytes.extend([0u8; 64]);
    std::fs::write(dir.path().join("p.npy"), &bytes).unwrap();
    std::fs::write(dir.path().join("s.force.csv"), force_csv()).unwrap();
    let meta_path = dir.path().join("s.recording.json");
    std::fs::write(&meta_path, META.replace("s.position.csv", "p.npy")).unwrap();
    let start = std::time::Instant::now();
    let message = Recording::load(&meta_path).unwrap_err().to_string();
    assert!(message.contains("not the plain dictionary numpy writes"), "{message}");
    // Exponential before the fix (over 10 s); a guard against its return,
    // not a timing of the reader.
    assert!(start.elapsed() < std::time::Duration::from_secs(2), "{:?}", start.elapsed());
}

/// Recordings from files held in memory (an upload) read exactly as from
/// a directory: the same recording, the same content hash; a stream that
/// is not among the files, or a name that could leave the folder, is an
/// error naming the metadata field.
#[test]
fn bundles_in_memory_read_as_directories_do() {
    use haptex_core::recording::bundle::FileBundle;
    let demo = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/library/demo/wood");
    let mut bundle = FileBundle::new();
    for stem in ["wood-s1", "wood-s2"] {
        for suffix in [".recording.json", ".force.npy", ".position.npy"] {
            let name = format!("{stem}{suffix}");
            bundle.add(&format!("wood/{name}"), std::fs::read(demo.join(&name)).unwrap()).unwrap();
        }
    }
    bundle.add("notes.txt", b"x".to_vec()).unwrap();
    let found = bundle.recordings().unwrap();
    assert_eq!(found.unused, ["notes.txt"]);
    assert_eq!(found.recordings.len(), 2);
    let loaded = Recording::load(&demo.join("wood-s1.recording.json")).unwrap();
    let mine = &found.recordings[0];
    assert_eq!(mine.name, "wood/wood-s1.recording.json");
    assert_eq!(
        (&mine.meta, &mine.force, &mine.position, &mine.sha256),
        (&loaded.meta, &loaded.force, &loaded.position, &loaded.sha256)
    );

    let meta = std::fs::read_to_string(demo.join("wood-s1.recording.json")).unwrap();
    for (file, expected) in [
        ("wood-s9.force.npy", "names \"wood-s9.force.npy\", which is not among the files given"),
        ("../wood-s1.force.npy", "is not a file name inside the recording's folder"),
    ] {
        let mut bundle = FileBundle::new();
        bundle.add("m.recording.json", meta.replace("wood-s1.force.npy", file).into_bytes()).unwrap();
        let e = bundle.recordings().unwrap_err().to_string();
        assert!(e.starts_with("m.recording.json, field 'force.file': ") && e.contains(expected), "{e}");
    }
    // A value of the wrong type is reported at its field.
    let mut bundle = FileBundle::new();
    bundle.add("m.recording.json", meta.replace("\"rate_hz\": 400.0", "\"rate_hz\": \"fast\"").into_bytes()).unwrap();
    let e = bundle.recordings().unwrap_err().to_string();
    assert!(e.starts_with("m.recording.json, field 'position.rate_hz': invalid metadata: invalid type"), "{e}");
}
