//! Issue 35, "a name from a user never escapes its directory", through the
//! real binary: every entry point that takes a name that becomes a path
//! component (`library import --material`, a recording's `material`, a
//! recipe's download files) refuses each hostile name with a clear error
//! and writes nothing, inside its output or out of it; names read back
//! from a library file that another program wrote (renamed here with SQL)
//! are refused by `library export`, reported by `library check`, and
//! quoted wherever they are printed (`library list`, the "no material
//! named" error); and a symbolic link planted in an export's directory
//! does not lead the export out of it. (`haptex_core`'s `names.rs` walks
//! the library's writers, `upload.rs` the HTTP route.)

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Output;

use haptex_core::library::Library;
use haptex_core::name::{HOSTILE_NAMES, check_name};
use haptex_core::recording::StreamFormat;
use haptex_core::recording::synth::demo_recordings;
use haptex_core::text::{Quoted, QuotedUpTo};

mod common;
use common::{haptex, stderr};

fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Every path under `dir` (not following links), relative to it.
fn tree(dir: &Path) -> BTreeSet<PathBuf> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeSet<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else { return };
        for entry in entries.flatten() {
            let path = entry.path();
            out.insert(path.strip_prefix(root).unwrap().to_path_buf());
            if entry.file_type().unwrap().is_dir() {
                walk(root, &path, out);
            }
        }
    }
    let mut out = BTreeSet::new();
    walk(dir, dir, &mut out);
    out
}

/// The shared hostile names and a very long one.
fn hostile() -> Vec<String> {
    let mut names: Vec<String> = HOSTILE_NAMES.iter().map(|s| s.to_string()).collect();
    names.push("x".repeat(5000));
    names
}

/// `text` shows none of the characters of `name` that a name may not hold
/// (control and format characters ...) raw.
fn shows_nothing_raw(text: &str, name: &str) -> bool {
    name.chars().filter(|c| !"/\\: ".contains(*c) && check_name(&format!("a{c}b")).is_err()).all(|c| !text.contains(c))
}

/// Every entry point refuses every hostile name, says which and why, and
/// writes nothing; names read from a library file are refused by the
/// export, reported by the check and quoted by the listing and the errors.
#[test]
fn user_names_never_escape_their_directory() {
    let dir = tempfile::tempdir().unwrap();
    let sandbox = dir.path();
    let profile = sandbox.join("p.csv");
    std::fs::write(&profile, "x_mm,mu\n0,0.5\n1,0.6\n2,0.5\n").unwrap();
    let recordings = sandbox.join("rec");
    let recording = demo_recordings(5, 1).into_iter().next().unwrap().1;
    let meta_path = recording.write(&recordings, "s", StreamFormat::Npy).unwrap();
    let meta: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&meta_path).unwrap()).unwrap();
    let db = sandbox.join("lib.sqlite");
    let recipe = sandbox.join("recipe.json");
    let replay = sandbox.join("replay");

    let mut names = hostile();
    names.push("\0".repeat(300));
    for name in &names {
        let shown = Quoted(name).to_string();
        let before = tree(sandbox);
        // `library import --profile --material NAME`: refused before the
        // library is opened (a command line cannot hold a NUL byte).
        if !name.contains('\0') {
            // `--material=NAME`: a name beginning with '-' would be taken for a flag.
            let flag = format!("--material={name}");
            let out = haptex(&["library", "import", "--db", s(&db), "--profile", s(&profile), "--measured", &flag]);
            let e = stderr(&out);
            assert!(!out.status.success() && e.contains("--material: "), "{shown}: {e}");
            assert!(e.contains("is not accepted as a name") && shows_nothing_raw(&e, name), "{shown}: {e}");
            assert!(!db.exists(), "{shown}: the refused import created the library");
        }

        // A recording whose metadata names the material: refused with the
        // file and the field, nothing stored.
        let mut edited = meta.clone();
        edited["material"] = serde_json::json!(name);
        std::fs::write(&meta_path, serde_json::to_vec_pretty(&edited).unwrap()).unwrap();
        let out = haptex(&["library", "import", "--db", s(&db), s(&recordings), "-q"]);
        let e = stderr(&out);
        assert!(!out.status.success() && e.contains("s.recording.json, field 'material'"), "{shown}: {e}");
        assert!(e.contains("is not accepted as a name") && shows_nothing_raw(&e, name), "{shown}: {e}");
        assert!(Library::open_read_only(&db).unwrap().materials().unwrap().is_empty(), "{shown}");
        std::fs::remove_file(&db).unwrap();

        // A recipe's download file: refused naming the field, no directory made.
        let r = serde_json::json!({ "format": "haptex-recipe/1", "haptex_version": env!("CARGO_PKG_VERSION"),
            "downloads": [{ "file": name, "method": "GET", "path": "/api/health" }] });
        std::fs::write(&recipe, serde_json::to_vec(&r).unwrap()).unwrap();
        let out = haptex(&["recipe", "run", s(&recipe), "-o", s(&replay)]);
        let e = stderr(&out);
        assert!(!out.status.success() && e.contains("downloads[0].file"), "{shown}: {e}");
        assert!(e.contains("is not accepted as a name") && shows_nothing_raw(&e, name), "{shown}: {e}");
        std::fs::remove_file(&recipe).unwrap();

        assert_eq!(tree(sandbox), before, "{shown}: a file was written");
    }

    // Names read back from a library another program wrote.
    let good = sandbox.join("good.sqlite");
    let out =
        haptex(&["library", "import", "--db", s(&good), "--profile", s(&profile), "--measured", "--material", "felt"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let export = sandbox.join("export");
    for name in &names {
        let shown = Quoted(name).to_string();
        let tampered = sandbox.join("tampered.sqlite");
        std::fs::copy(&good, &tampered).unwrap();
        let conn = rusqlite::Connection::open(&tampered).unwrap();
        conn.execute("UPDATE materials SET name = ?1", [name]).unwrap();
        drop(conn);
        let before = tree(sandbox);

        let out = haptex(&["library", "export", "--db", s(&tampered), "--out", s(&export)]);
        let e = stderr(&out);
        assert!(
            !out.status.success() && e.contains("cannot export material") && e.contains("library check"),
            "{shown}: {e}"
        );
        assert!(shows_nothing_raw(&e, name), "{shown}: {e}");
        assert_eq!(tree(sandbox), before, "{shown}: the refused export wrote a file");

        let out = haptex(&["library", "check", "--db", s(&tampered)]);
        let e = stderr(&out);
        assert!(!out.status.success() && e.contains("is not accepted as a name"), "{shown}: {e}");
        assert!(shows_nothing_raw(&e, name), "{shown}: {e}");

        let out = haptex(&["library", "list", "--db", s(&tampered)]);
        let text = stdout(&out);
        assert!(out.status.success(), "{shown}: {}", stderr(&out));
        assert!(text.contains(&QuotedUpTo(name, 100).to_string()) && shows_nothing_raw(&text, name), "{shown}: {text}");
        if !name.contains('\0') {
            let out = haptex(&["library", "list", "--db", s(&tampered), &format!("--material={name}")]);
            assert!(shows_nothing_raw(&stdout(&out), name) && shows_nothing_raw(&stderr(&out), name), "{shown}");
        }

        let out = haptex(&["library", "sample", "--db", s(&tampered), "--material", "granite"]);
        let e = stderr(&out);
        assert!(!out.status.success() && e.contains(&format!("(it has: {shown})")), "{shown}: {e}");
        assert!(shows_nothing_raw(&e, name), "{shown}: {e}");
        std::fs::remove_file(&tampered).unwrap();
    }

    // A link planted in the export's directory where the material's
    // directory goes: the export refuses it and writes nothing outside.
    #[cfg(unix)]
    {
        let outside = sandbox.join("outside");
        std::fs::create_dir_all(&outside).unwrap();
        std::fs::create_dir_all(&export).unwrap();
        std::os::unix::fs::symlink(&outside, export.join("felt")).unwrap();
        let out = haptex(&["library", "export", "--db", s(&good), "--out", s(&export)]);
        let e = stderr(&out);
        assert!(!out.status.success() && e.contains("outside the output directory"), "{e}");
        assert_eq!(tree(&outside), BTreeSet::new(), "the export wrote through the link");
        assert!(!export.join("manifest.json").exists());
    }
}
