//! Recordings uploaded into a writable library (`POST /api/recordings`,
//! `haptex serve --writable`): stored as `haptex library import` stores
//! them (the profile sampled back equals the command line's, value for
//! value), refused by a read-only server, and every bad upload (bad
//! metadata, a missing stream, a zip bomb, too many entries, names that
//! leave the folder, no provenance, too large) answered by a 4xx JSON
//! error naming the file and field, with the library left as it was.

use std::io::Write;
use std::path::{Path, PathBuf};

use axum::Router;
use axum::body::Body;
use axum::http::{Request, StatusCode, header};
use haptex_core::library::Library;
use haptex_core::name::HOSTILE_NAMES;
use haptex_core::recording::{ProcessingConfig, Recording, process};
use haptex_server::{AppState, Limits, app};
use serde_json::Value;

mod common;

use common::{Answer, send_to, shipped_library, shipped_state};

const BOUNDARY: &str = "haptex-test-7d1f0c";

fn demo_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/library/demo")
}

/// The three files of a demo recording (`wood-s1`), as (name, bytes).
fn demo_files(material: &str, stem: &str) -> Vec<(String, Vec<u8>)> {
    [".recording.json", ".force.npy", ".position.npy"]
        .iter()
        .map(|suffix| {
            let name = format!("{stem}{suffix}");
            (name.clone(), std::fs::read(demo_dir().join(material).join(&name)).unwrap())
        })
        .collect()
}

/// Demo recordings of `material` renamed to `new_material` (so that their
/// content is new to the shipped library) and, unless `synthetic`, flagged
/// as measured data.
fn renamed(material: &str, new_material: &str, synthetic: bool, strokes: &[u32]) -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    for s in strokes {
        for (name, bytes) in demo_files(material, &format!("{material}-s{s}")) {
            let bytes = if name.ends_with(".recording.json") {
                let mut text = String::from_utf8(bytes).unwrap();
                text = text
                    .replace(&format!("\"material\": \"{material}\""), &format!("\"material\": \"{new_material}\""));
                if !synthetic {
                    text = text.replace("\"synthetic\": true", "\"synthetic\": false");
                }
                text.into_bytes()
            } else {
                bytes
            };
            files.push((name, bytes));
        }
    }
    files
}

/// A multipart/form-data body: `provenance` (if given) and the files.
fn form(provenance: Option<&str>, files: &[(String, Vec<u8>)]) -> Vec<u8> {
    let mut body = Vec::new();
    if let Some(p) = provenance {
        write!(body, "--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"provenance\"\r\n\r\n{p}\r\n").unwrap();
    }
    for (name, bytes) in files {
        write!(
            body,
            "--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"files\"; filename=\"{name}\"\r\nContent-Type: \
             application/octet-stream\r\n\r\n"
        )
        .unwrap();
        body.extend_from_slice(bytes);
        body.extend_from_slice(b"\r\n");
    }
    write!(body, "--{BOUNDARY}--\r\n").unwrap();
    body
}

/// A zip of the files (deflated), each under `folder/` if given.
fn zip_of(files: &[(String, Vec<u8>)], folder: Option<&str>) -> Vec<u8> {
    let mut writer = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (name, bytes) in files {
        let name = folder.map_or(name.clone(), |f| format!("{f}/{name}"));
        writer.start_file(name, options).unwrap();
        writer.write_all(bytes).unwrap();
    }
    writer.finish().unwrap().into_inner()
}

/// A writable copy of the shipped library in a temporary directory, and
/// the application serving it.
struct Lab {
    _dir: tempfile::TempDir,
    path: PathBuf,
    router: Router,
}

impl Lab {
    fn new(limits: Limits) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("lab.sqlite");
        std::fs::copy(shipped_library(), &path).unwrap();
        let state = AppState::new(Some(&path), limits).unwrap().with_writable_library().unwrap();
        Self { _dir: dir, path, router: app(state) }
    }

    async fn upload(&self, provenance: Option<&str>, files: &[(String, Vec<u8>)]) -> Answer {
        self.post(form(provenance, files)).await
    }

    async fn post(&self, body: Vec<u8>) -> Answer {
        let request = Request::post("/api/recordings")
            .header(header::CONTENT_TYPE, format!("multipart/form-data; boundary={BOUNDARY}"))
            .body(Body::from(body))
            .unwrap();
        send_to(self.router.clone(), request).await
    }

    async fn get(&self, uri: &str) -> Answer {
        send_to(self.router.clone(), Request::get(uri).body(Body::empty()).unwrap()).await
    }

    /// What the library holds: materials, import runs, strokes.
    fn contents(&self) -> String {
        contents(&self.path)
    }
}

fn contents(path: &Path) -> String {
    let library = Library::open_read_only(path).unwrap();
    let materials = library.materials().unwrap();
    let strokes: Vec<_> = materials.iter().map(|m| library.strokes(&m.name).unwrap()).collect();
    format!("{materials:?}\n{:?}\n{strokes:?}", library.imports().unwrap())
}

fn numbers(value: &Value) -> Vec<f64> {
    value.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect()
}

/// The acceptance case: recordings uploaded into a writable library come
/// back, sampled with a seed, exactly as the command line's import and
/// sample give them for the same files (`haptex library import` is
/// `Recording::load`, `process`, `add_recording` with the default
/// configuration, over the sorted files of a directory).
#[tokio::test]
async fn an_upload_is_stored_as_the_command_line_import_stores_it() {
    let lab = Lab::new(Limits::DEFAULT);
    let config = lab.get("/api/config").await;
    assert_eq!(config.ok().json()["library_writable"], true);
    assert_eq!(config.json()["limits"]["max_upload_bytes"], 64 << 20);
    let files = renamed("wood", "wood-lab", false, &[1, 2, 3]);
    let answer = lab.upload(Some("measured"), &files).await;
    let report = answer.ok().json();
    assert_eq!(report["added"], 3, "{report}");
    assert_eq!(report["duplicates"], 0);
    assert_eq!(report["provenance"], "measured");
    let recordings = report["recordings"].as_array().unwrap();
    assert_eq!(recordings.len(), 3);
    for r in recordings {
        assert_eq!(r["material"], "wood-lab");
        assert_eq!(r["synthetic"], false);
        assert_eq!(r["duplicate"], false);
        assert!(!r["segments"].as_array().unwrap().is_empty(), "{r}");
        assert!(r["dropped"].is_array());
        // The raw forces, reduced for the plot: 20 kHz for about a second.
        let forces = &r["forces"];
        let n = numbers(&forces["t_s"]).len();
        assert!(forces["samples"].as_u64().unwrap() > 2000 && (1000..=2000).contains(&n), "{n}");
        assert_eq!(numbers(&forces["fn_n"]).len(), n);
        assert_eq!(forces["decimated"], true);
        // Every kept segment lies inside the recording's time.
        let t = numbers(&forces["t_s"]);
        for s in r["segments"].as_array().unwrap() {
            let (a, b) = (s["t_start_s"].as_f64().unwrap(), s["t_end_s"].as_f64().unwrap());
            assert!(t[0] <= a && a < b && b <= t[n - 1], "{s}");
        }
    }
    let material = report["materials"].as_array().unwrap().iter().find(|m| m["name"] == "wood-lab").unwrap().clone();
    assert_eq!(material["strokes"], 3);
    assert_eq!(material["synthetic"], false);
    // GET /api/materials lists it.
    let listed = lab.get("/api/materials").await;
    assert!(listed.ok().json()["materials"].as_array().unwrap().iter().any(|m| m["name"] == "wood-lab"));

    // The command line's import of the same files into a new library.
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in &files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    let cli_path = dir.path().join("cli.sqlite");
    let mut cli = Library::open(&cli_path).unwrap();
    let processing = ProcessingConfig::default();
    let run = cli.begin_import("haptex library import", &processing).unwrap();
    let mut metadata: Vec<PathBuf> =
        files.iter().filter(|(n, _)| n.ends_with(".recording.json")).map(|(n, _)| dir.path().join(n)).collect();
    metadata.sort();
    for path in &metadata {
        let recording = Recording::load(path).unwrap();
        cli.add_recording(run, &recording, &process(&recording, &processing).unwrap(), &processing).unwrap();
    }
    cli.finish_import(run).unwrap();
    for seed in 0..6u64 {
        let ours = lab.get(&format!("/api/materials/wood-lab/sample?seed={seed}")).await;
        let ours = ours.ok().json();
        let theirs = cli.sample("wood-lab", Some(seed)).unwrap();
        let profile = &theirs.stored.profile;
        assert_eq!(numbers(&ours["x_mm"]), profile.x_mm(), "seed {seed}");
        assert_eq!(numbers(&ours["mu"]), profile.mu(), "seed {seed}");
        assert_eq!(numbers(&ours["fn_n"]), profile.fn_n().unwrap(), "seed {seed}");
        assert_eq!(ours["stroke"]["content_sha256"], theirs.stored.stroke.content_sha256.as_str());
        assert_eq!(ours["synthetic"], false);
    }
    assert!(Library::open_read_only(&lab.path).unwrap().check().unwrap().is_empty());

    // The same files again: duplicates, nothing added. A recipe records
    // the library's new hash.
    let again = lab.upload(Some("measured"), &files).await;
    let again = again.ok().json();
    assert_eq!((again["added"].as_u64(), again["duplicates"].as_u64()), (Some(0), Some(3)));
    let hash = haptex_core::io::sha256_file(&lab.path).unwrap();
    assert_eq!(lab.get("/api/config").await.json()["data"]["library_sha256"], hash.as_str());
}

/// A zip of a folder of recordings (deflated), and the shipped demo files
/// as they are: already in the library, so reported as duplicates of the
/// shipped strokes.
#[tokio::test]
async fn a_zip_of_a_folder_is_read_and_known_content_is_a_duplicate() {
    let lab = Lab::new(Limits::DEFAULT);
    let mut files = renamed("velvet", "velvet-lab", false, &[1, 2]);
    files.push(("README.txt".into(), b"two velvet strokes".to_vec()));
    let zip = zip_of(&files, Some("lab/velvet"));
    let answer = lab.upload(Some("measured"), &[("velvet.zip".into(), zip)]).await;
    let report = answer.ok().json();
    assert_eq!(report["added"], 2, "{report}");
    assert_eq!(report["recordings"][0]["file"], "lab/velvet/velvet-s1.recording.json");
    assert_eq!(report["unused_files"], serde_json::json!(["lab/velvet/README.txt"]));

    let shipped = Library::open_read_only(&shipped_library()).unwrap();
    let shipped_ids: Vec<i64> = shipped.strokes("tile").unwrap().iter().map(|s| s.id).collect();
    let answer = lab.upload(Some("synthetic"), &demo_files("tile", "tile-s2")).await;
    let report = answer.ok().json();
    assert_eq!((report["added"].as_u64(), report["duplicates"].as_u64()), (Some(0), Some(1)));
    assert!(shipped_ids.contains(&report["recordings"][0]["stroke_id"].as_i64().unwrap()), "{report}");
}

/// A read-only server (the default) refuses uploads, saying how to start
/// one that takes them.
#[tokio::test]
async fn a_read_only_library_refuses_uploads() {
    let state = shipped_state();
    let before = contents(&shipped_library());
    let config = send_to(app(state.clone()), Request::get("/api/config").body(Body::empty()).unwrap()).await;
    assert_eq!(config.ok().json()["library_writable"], false);
    let request = Request::post("/api/recordings")
        .header(header::CONTENT_TYPE, format!("multipart/form-data; boundary={BOUNDARY}"))
        .body(Body::from(form(Some("synthetic"), &renamed("wood", "wood-x", false, &[1]))))
        .unwrap();
    let answer = send_to(app(state), request).await;
    let error = answer.error(StatusCode::FORBIDDEN, Some("library"));
    assert!(error["error"].as_str().unwrap().contains("--writable"), "{error}");
    assert_eq!(contents(&shipped_library()), before);
}

/// Every bad upload: a 4xx JSON error naming the file and the field, and
/// the library as it was.
#[tokio::test]
async fn bad_uploads_are_refused_with_the_file_and_field_and_change_nothing() {
    let lab = Lab::new(Limits::DEFAULT);
    let before = lab.contents();
    let good = renamed("wood", "wood-lab", false, &[1]);
    let with_meta = |edit: &dyn Fn(&str) -> String| -> Vec<(String, Vec<u8>)> {
        good.iter()
            .map(|(n, b)| {
                if n.ends_with(".recording.json") {
                    (n.clone(), edit(std::str::from_utf8(b).unwrap()).into_bytes())
                } else {
                    (n.clone(), b.clone())
                }
            })
            .collect()
    };
    let expect = |answer: Answer, status: StatusCode, field: &str, file: Option<&str>, words: &str| {
        let error = answer.error(status, Some(field));
        assert_eq!(error["file"].as_str(), file, "{error}");
        assert!(error["error"].as_str().unwrap().contains(words), "{error}");
    };
    let meta = Some("wood-s1.recording.json");

    // Metadata: a unit other than the format's, a value of the wrong type,
    // a missing field, malformed JSON.
    let files = with_meta(&|m| m.replace("\"force\": \"N\"", "\"force\": \"mN\""));
    expect(lab.upload(Some("measured"), &files).await, StatusCode::BAD_REQUEST, "units.force", meta, "newtons");
    let files = with_meta(&|m| m.replace("\"stroke\": 1", "\"stroke\": \"one\""));
    expect(lab.upload(Some("measured"), &files).await, StatusCode::BAD_REQUEST, "stroke", meta, "invalid type");
    let files = with_meta(&|m| m.replace("\"participant\": \"P7\",", ""));
    expect(lab.upload(Some("measured"), &files).await, StatusCode::BAD_REQUEST, "participant", meta, "missing field");
    let files = with_meta(&|m| m.replace("\"format\"", "format"));
    expect(lab.upload(Some("measured"), &files).await, StatusCode::BAD_REQUEST, "metadata", meta, "line 2");

    // A missing stream file; a stream named outside the folder.
    let answer = lab.upload(Some("measured"), &good[..2]).await;
    expect(answer, StatusCode::BAD_REQUEST, "position.file", meta, "not among the files given");
    let files = with_meta(&|m| m.replace("\"wood-s1.force.npy\"", "\"../wood-s1.force.npy\""));
    expect(lab.upload(Some("measured"), &files).await, StatusCode::BAD_REQUEST, "force.file", meta, "no '..'");

    // Names that could leave the folder, as a part's file name and as a
    // zip entry.
    let mut files = good.clone();
    files[1].0 = "../wood-s1.force.npy".into();
    expect(
        lab.upload(Some("measured"), &files).await,
        StatusCode::BAD_REQUEST,
        "files",
        Some("\"../wood-s1.force.npy\""),
        "..",
    );
    for (evil, why) in
        [("/etc/evil.recording.json", "absolute path"), ("../evil.recording.json", "'.' and '..' name a directory")]
    {
        let mut entries = good.clone();
        entries.push((evil.into(), b"{}".to_vec()));
        let zip = zip_of(&entries, None);
        let answer = lab.upload(Some("measured"), &[("x.zip".into(), zip)]).await;
        expect(answer, StatusCode::BAD_REQUEST, "files", Some(&format!("x.zip: {evil}")), why);
    }

    // Provenance: missing, unknown, or not what the metadata says.
    expect(lab.upload(None, &good).await, StatusCode::BAD_REQUEST, "provenance", None, "measured");
    expect(lab.upload(Some("real"), &good).await, StatusCode::BAD_REQUEST, "provenance", None, "\"real\"");
    let answer = lab.upload(Some("synthetic"), &good).await;
    expect(answer, StatusCode::BAD_REQUEST, "provenance", meta, "\"synthetic\": false");

    // A measured stroke for the shipped synthetic material: 409, nothing
    // stored, not even the valid recording beside it.
    let mut files = renamed("latex", "latex-lab", false, &[1]);
    files.extend(renamed("wood", "wood", false, &[2]));
    let answer = lab.upload(Some("measured"), &files).await;
    expect(answer, StatusCode::CONFLICT, "material", None, "never mixes");

    // One invalid recording among valid ones refuses them all.
    let mut files = renamed("latex", "latex-lab", false, &[1]);
    files.extend(with_meta(&|m| m.replace("\"rate_hz\": 400.0", "\"rate_hz\": 500.0")));
    let answer = lab.upload(Some("measured"), &files).await;
    expect(answer, StatusCode::BAD_REQUEST, "position.rate_hz", meta, "median sample interval");

    // Not a form; no files; a file that is not a recording; an unknown field.
    let request =
        Request::post("/api/recordings").header(header::CONTENT_TYPE, "application/zip").body(Body::from("x"));
    send_to(lab.router.clone(), request.unwrap()).await.error(StatusCode::UNSUPPORTED_MEDIA_TYPE, Some("content-type"));
    expect(lab.upload(Some("measured"), &[]).await, StatusCode::BAD_REQUEST, "files", None, "no files");
    let answer = lab.upload(Some("measured"), &[("notes.txt".into(), b"hello".to_vec())]).await;
    expect(answer, StatusCode::BAD_REQUEST, "files", Some("the files given"), "no recording among them");
    let mut body = form(Some("measured"), &good);
    let extra = format!("--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"colour\"\r\n\r\nred\r\n");
    body.splice(0..0, extra.into_bytes());
    lab.post(body).await.error(StatusCode::BAD_REQUEST, Some("colour"));
    let answer = lab.upload(Some("measured"), &[("broken.zip".into(), b"PK\x03\x04 not really".to_vec())]).await;
    expect(answer, StatusCode::BAD_REQUEST, "files", Some("broken.zip"), "not a zip archive");

    assert_eq!(lab.contents(), before);
}

/// Zip bombs and floods are refused before anything is unzipped: a zip
/// declaring more bytes than the upload may hold unzipped, a zip of more
/// entries than an upload may hold, and a body over the limit.
#[tokio::test]
async fn zip_bombs_floods_and_oversized_bodies_are_refused() {
    let lab = Lab::new(Limits::DEFAULT);
    let before = lab.contents();
    // 65 MiB of zeros deflate to about 64 KiB.
    let bomb = zip_of(&[("zeros.force.csv".to_string(), vec![0u8; 65 << 20])], None);
    assert!(bomb.len() < 1 << 20, "{}", bomb.len());
    let answer = lab.upload(Some("measured"), &[("bomb.zip".into(), bomb)]).await;
    let error = answer.error(StatusCode::PAYLOAD_TOO_LARGE, Some("files"));
    assert_eq!(error["file"], "bomb.zip");
    assert!(error["error"].as_str().unwrap().contains("unzipped"), "{error}");

    let many: Vec<(String, Vec<u8>)> = (0..1001).map(|i| (format!("f{i}.csv"), Vec::new())).collect();
    let answer = lab.upload(Some("measured"), &[("many.zip".into(), zip_of(&many, None))]).await;
    let error = answer.error(StatusCode::PAYLOAD_TOO_LARGE, Some("files"));
    assert!(error["error"].as_str().unwrap().contains("1001 entries"), "{error}");

    // Small limits for the body: 1 MiB.
    let small = Lab::new(Limits { max_upload_bytes: 1 << 20, ..Limits::DEFAULT });
    let big = vec![("big.force.csv".to_string(), vec![b'0'; (1 << 20) + 1])];
    let error = small.upload(Some("measured"), &big).await.error(StatusCode::PAYLOAD_TOO_LARGE, Some("body"));
    assert!(error["error"].as_str().unwrap().contains("1048576 bytes"), "{error}");
    // Within the body limit, but more unzipped than the limit allows.
    let half = vec![0u8; 600 << 10];
    let zipped = zip_of(&[("a.csv".to_string(), half.clone()), ("b.csv".to_string(), half)], None);
    let answer = small.upload(Some("measured"), &[("two.zip".into(), zipped)]).await;
    answer.error(StatusCode::PAYLOAD_TOO_LARGE, Some("files"));
    assert_eq!(lab.contents(), before);
}

/// Issue 35, "a name from a user never escapes its directory", through
/// the HTTP route: a recording whose metadata names a hostile material
/// (it would become a directory of a library export), and a hostile file
/// name in the form or in a zip, are refused with a 400 naming the field,
/// the name quoted (no control or format character raw in the answer),
/// and the library left as it was. Names read back from a library file
/// another program wrote are quoted in the answers' messages.
#[tokio::test]
async fn user_names_never_escape_their_directory() {
    let lab = Lab::new(Limits::DEFAULT);
    let before = lab.contents();
    let good = renamed("wood", "wood-lab", true, &[1]);
    let mut names: Vec<String> = HOSTILE_NAMES.iter().map(|s| s.to_string()).collect();
    names.push("x".repeat(5000));
    names.push("\0".repeat(300));
    for name in &names {
        let shown = haptex_core::text::Quoted(name).to_string();
        // The metadata's material.
        let files: Vec<(String, Vec<u8>)> = good
            .iter()
            .map(|(n, b)| {
                if n.ends_with(".recording.json") {
                    let mut meta: Value = serde_json::from_slice(b).unwrap();
                    meta["material"] = serde_json::json!(name);
                    (n.clone(), serde_json::to_vec(&meta).unwrap())
                } else {
                    (n.clone(), b.clone())
                }
            })
            .collect();
        let error = lab.upload(Some("synthetic"), &files).await.error(StatusCode::BAD_REQUEST, Some("material"));
        let message = error["error"].as_str().unwrap();
        assert!(message.contains("is not accepted as a name") && shows_nothing_raw(&error, name), "{shown}: {error}");

        // The name of a file in the form, and of a zip's entry (a hidden
        // entry, `.hidden`, is skipped as an archiver's, not refused).
        let mut files = good.clone();
        files.push((name.clone(), b"x".to_vec()));
        let answer = lab.upload(Some("synthetic"), &files).await;
        assert!(answer.status.is_client_error(), "{shown}: {}", answer.text());
        assert!(shows_nothing_raw(&answer.json(), name), "{shown}: {}", answer.text());
        let zip = zip_of(&[(name.clone(), b"x".to_vec())], None);
        let error =
            lab.upload(Some("synthetic"), &[("x.zip".into(), zip)]).await.error(StatusCode::BAD_REQUEST, Some("files"));
        let message = error["error"].as_str().unwrap();
        let refused = message.contains("not accepted as a file name") || message.contains("no recording among them");
        assert!(refused && shows_nothing_raw(&error, name), "{shown}: {error}");
        assert_eq!(lab.contents(), before, "{shown}: the library changed");
    }

    // A library in which another program renamed a material: the answers'
    // messages quote the name.
    for name in &names {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tampered.sqlite");
        std::fs::copy(shipped_library(), &path).unwrap();
        let conn = rusqlite::Connection::open(&path).unwrap();
        conn.execute("UPDATE materials SET name = ?1 WHERE name = 'wood'", [name]).unwrap();
        drop(conn);
        let router = app(AppState::new(Some(&path), Limits::DEFAULT).unwrap());
        let answer = send_to(router, Request::get("/api/materials/granite/sample").body(Body::empty()).unwrap()).await;
        let error = answer.error(StatusCode::NOT_FOUND, Some("name"));
        let message = error["error"].as_str().unwrap();
        let quoted = haptex_core::text::Quoted(name).to_string();
        assert!(message.contains(&quoted) && shows_nothing_raw(&error, name), "{quoted}: {error}");
    }
}

/// No character of `name` that a name may not hold (control, format ...)
/// appears raw in the JSON answer's texts.
fn shows_nothing_raw(answer: &Value, name: &str) -> bool {
    let texts: Vec<&str> = ["error", "field", "file"].iter().filter_map(|k| answer[*k].as_str()).collect();
    name.chars()
        .filter(|c| !"/\\: ".contains(*c) && haptex_core::name::check_name(&format!("a{c}b")).is_err())
        .all(|c| texts.iter().all(|t| !t.contains(c)))
}
