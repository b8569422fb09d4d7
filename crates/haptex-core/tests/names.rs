//! Issue 35, "a name from a user never escapes its directory": one rule
//! for every name that becomes a path component (`haptex_core::name`), and
//! every multi-file writer checks that each file it writes resolves inside
//! its output directory (`haptex_core::io::OutputDir`). The test walks the
//! library's writers and entry points here with hostile names (the CLI's
//! and the HTTP route's tests walk theirs: `library_cli.rs`,
//! `upload.rs`), and planted symbolic links; the property tests check the
//! rule itself on arbitrary strings.

use std::collections::BTreeSet;
use std::path::{Component, Path, PathBuf};

use haptex_core::FrictionProfile;
use haptex_core::database::Metadata;
use haptex_core::io::{FileSet, MemberHashes, OutputDir, verify_members};
use haptex_core::library::{Library, LibraryError, ProfileProvenance};
use haptex_core::name::{HOSTILE_NAMES, MAX_NAME_BYTES, MAX_NAME_CHARS, check_name, check_relative_path};
use haptex_core::recording::bundle::FileBundle;
use haptex_core::recording::synth::demo_recordings;
use haptex_core::recording::{ProcessingConfig, Recording, StreamFormat};
use haptex_core::text::Quoted;
use proptest::prelude::*;

/// The shared hostile names, a very long one and one of NUL bytes.
fn hostile() -> Vec<String> {
    let mut names: Vec<String> = HOSTILE_NAMES.iter().map(|s| s.to_string()).collect();
    names.push("x".repeat(5000));
    names.push("\0".repeat(300));
    names.push("é".repeat(MAX_NAME_CHARS + 1));
    names
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

/// A demo recording (of the first material; the generator makes all 12).
fn recording() -> Recording {
    demo_recordings(3, 1).into_iter().next().unwrap().1
}

/// A recording's metadata as JSON with its material replaced.
fn metadata_with_material(recording: &Recording, material: &str) -> Vec<u8> {
    let mut meta = serde_json::to_value(&recording.meta).unwrap();
    meta["material"] = serde_json::json!(material);
    meta["force"]["file"] = serde_json::json!("s.force.csv");
    meta["position"]["file"] = serde_json::json!("s.position.csv");
    serde_json::to_vec(&meta).unwrap()
}

fn profile() -> FrictionProfile {
    FrictionProfile::new(vec![0.0, 1.0, 2.0], vec![0.5, 0.6, 0.5]).unwrap()
}

fn provenance() -> ProfileProvenance {
    ProfileProvenance { source: "test".into(), licence: "CC0-1.0".into(), synthetic: true, origin_path: "p.csv".into() }
}

/// Every writer and entry point of the library refuses each hostile name
/// with an error that quotes it and says why, and nothing is written,
/// inside the output directory or out of it.
#[test]
fn user_names_never_escape_their_directory() {
    let sandbox = tempfile::tempdir().unwrap();
    let out = sandbox.path().join("out");
    let db_path = sandbox.path().join("lib.sqlite");
    let mut library = Library::open(&db_path).unwrap();
    let run = library.begin_import("test", &ProcessingConfig::default()).unwrap();
    let shipped_metadata: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/db/metadata.json")).unwrap(),
    )
    .unwrap();
    let before = tree(sandbox.path());
    let recording = recording();
    for name in hostile() {
        let shown = Quoted(&name).to_string();
        let refused = |what: &str, e: &dyn std::fmt::Display| {
            let e = e.to_string();
            assert!(e.contains("is not accepted as a name"), "{what} {shown}: {e}");
            assert!(e.len() < 1000 && !e.contains('\0') && !e.contains('\u{202e}'), "{what} {shown}: {e}");
        };
        check_name(&name).expect_err(&shown);

        // The multi-file writers: a file set (library export, database
        // merge, VTK series), a plain output directory (recipe run, runs of
        // a database build), a recording.
        let mut set = FileSet::begin(&out, "manifest.json").unwrap();
        refused("file set", &set.write(&name, |w| w.write_all(b"x")).unwrap_err());
        refused("file set subdir", &set.write(&format!("{name}/stroke-1.csv"), |w| w.write_all(b"x")).unwrap_err());
        let dir = OutputDir::create(&out).unwrap();
        refused("output dir", &dir.write(&name, |w| w.write_all(b"x")).unwrap_err());
        refused("output subdir", &dir.subdir(&name).unwrap_err());
        refused("recording stem", &recording.write(&out, &name, StreamFormat::Csv).unwrap_err());
        assert_eq!(tree(&out), BTreeSet::new(), "{shown}: a file was written");

        // The library: a material is refused, nothing stored.
        let e = library.add_profile(run, &name, "", &profile(), &provenance()).unwrap_err();
        assert!(matches!(e, LibraryError::InvalidName(_)), "{shown}: {e}");
        refused("library", &e);
        assert!(library.materials().unwrap().is_empty());

        // A recording's metadata: the material field.
        let e = Recording::parse(
            "s.recording.json",
            &metadata_with_material(&recording, &name),
            ("s.force.csv", b"t_s,fn_n,ft_n\n"),
            ("s.position.csv", b"t_s,x_mm\n"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("field 'material'"), "{shown}: {e}");
        refused("recording metadata", &e);

        // An upload's file names, a stream named in metadata.
        assert!(FileBundle::new().add(&name, vec![1]).is_err(), "{shown}");
        check_relative_path(&format!("{name}/x.csv")).expect_err(&shown);

        // Names read back from files someone else wrote: a database's
        // metadata.json and the members a manifest lists.
        let db_dir = sandbox.path().join("db");
        std::fs::create_dir_all(&db_dir).unwrap();
        let mut metadata = shipped_metadata.clone();
        metadata["templates"][0]["file"] = serde_json::json!(name);
        std::fs::write(db_dir.join("metadata.json"), serde_json::to_vec(&metadata).unwrap()).unwrap();
        let e = Metadata::read(&db_dir).unwrap_err().to_string();
        assert!(e.contains("templates[0].file") && e.contains("is not accepted as a name"), "{shown}: {e}");
        let members = MemberHashes::from([(name.clone(), "0".repeat(64))]);
        refused("manifest", &verify_members(&out, &members).unwrap_err());
        std::fs::remove_dir_all(&db_dir).unwrap();
    }
    // A name the rule takes but that would take the marker's place (a
    // material named manifest.json in a library export) is refused too.
    let mut set = FileSet::begin(&out, "manifest.json").unwrap();
    let e = set.write("Manifest.json/stroke-1.csv", |w| w.write_all(b"x")).unwrap_err().to_string();
    assert!(e.contains("the set's marker"), "{e}");
    assert_eq!(tree(&out), BTreeSet::new());
    let mut expected = before.clone();
    expected.insert("out".into());
    assert_eq!(tree(sandbox.path()), expected, "something was written outside");
}

/// Defence in depth: a symbolic link planted in an output directory (to a
/// directory outside it, to a file outside it, dangling to a new file
/// outside it) makes every writer refuse that file, and nothing outside is
/// created or changed; links that stay inside are followed.
#[cfg(unix)]
#[test]
fn planted_links_do_not_lead_writers_out_of_their_directory() {
    use std::os::unix::fs::symlink;
    let sandbox = tempfile::tempdir().unwrap();
    let out = sandbox.path().join("out");
    let outside = sandbox.path().join("outside");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::create_dir_all(&outside).unwrap();
    std::fs::write(outside.join("victim.csv"), "precious\n").unwrap();
    symlink(&outside, out.join("velvet")).unwrap();
    symlink(outside.join("victim.csv"), out.join("stroke-1.csv")).unwrap();
    symlink("../outside/new.csv", out.join("stroke-2.csv")).unwrap();
    symlink("../outside", out.join("latex")).unwrap();
    let outside_before = tree(&outside);
    let mut set = FileSet::begin(&out, "manifest.json").unwrap();
    for member in ["velvet/stroke-3.csv", "stroke-1.csv", "stroke-2.csv", "latex/new.csv"] {
        let e = set.write(member, |w| w.write_all(b"x_mm,mu\n0,1\n")).unwrap_err().to_string();
        assert!(e.contains("outside the output directory"), "{member}: {e}");
        let e = OutputDir::create(&out).unwrap().write(member, |w| w.write_all(b"x")).unwrap_err().to_string();
        assert!(e.contains("outside the output directory"), "{member}: {e}");
    }
    assert_eq!(tree(&outside), outside_before);
    assert_eq!(std::fs::read_to_string(outside.join("victim.csv")).unwrap(), "precious\n");
    // A link inside the directory is followed.
    std::fs::create_dir(out.join("real")).unwrap();
    symlink("real", out.join("alias")).unwrap();
    set.write("alias/stroke-4.csv", |w| w.write_all(b"x_mm,mu\n0,1\n")).unwrap();
    assert!(out.join("real/stroke-4.csv").is_file());
    set.finish(|w, m| writeln!(w, "{}", m.len())).unwrap();
    // A manifest listing a link that leads out is not verified through it.
    let members = MemberHashes::from([("stroke-1.csv".to_string(), "0".repeat(64))]);
    let e = verify_members(&out, &members).unwrap_err().to_string();
    assert!(e.contains("not a regular file inside"), "{e}");
}

/// What an accepted name is: one plain component of at most 100
/// characters and 200 bytes, none a control, format, private-use,
/// unassigned or separator character, that a joined path keeps inside its
/// directory, and that quotes (`text::Quoted`) without an escape.
fn accepted_name_is_plain(name: &str) {
    let base = Path::new("/base/dir");
    let joined = base.join(name);
    assert_eq!(joined.parent(), Some(base), "{name:?}");
    assert_eq!(joined.components().next_back(), Some(Component::Normal(name.as_ref())), "{name:?}");
    assert!(name.chars().count() <= MAX_NAME_CHARS && name.len() <= MAX_NAME_BYTES);
    assert!(!name.chars().any(|c| c.is_control() || "/\\:".contains(c)), "{name:?}");
    assert!(!name.starts_with(['.', '-']) && name.trim() == name && !name.is_empty(), "{name:?}");
}

/// Characters a hostile name is made of, and any character.
fn name_char() -> impl Strategy<Value = char> {
    prop_oneof![
        prop::sample::select(vec![
            '.',
            '/',
            '\\',
            ':',
            ' ',
            '-',
            '\0',
            '\t',
            '\n',
            '\u{1b}',
            '\u{7f}',
            '\u{85}',
            '\u{a0}',
            '\u{ad}',
            '\u{200b}',
            '\u{200d}',
            '\u{200e}',
            '\u{202e}',
            '\u{2028}',
            '\u{2060}',
            '\u{feff}',
            '\u{e000}',
            '\u{fff9}',
            '\u{e0001}',
            '\u{10ffff}',
            'a',
            'Z',
            '0',
            'é',
            '木',
            '🦀',
        ]),
        any::<char>(),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, failure_persistence: None, ..ProptestConfig::default() })]

    /// The rule on arbitrary strings: an accepted name is a plain
    /// component; a refused one is refused whichever way it arrives (alone
    /// or inside a relative path).
    #[test]
    fn the_name_rule_accepts_only_plain_components(chars in prop::collection::vec(name_char(), 0..130)) {
        let name: String = chars.into_iter().collect();
        match check_name(&name) {
            Ok(()) => {
                accepted_name_is_plain(&name);
                check_relative_path(&format!("a/{name}/b")).unwrap();
            }
            Err(e) => {
                prop_assert_eq!(&e.name, &name);
                let inside = format!("a/{name}/b");
                prop_assert!(check_relative_path(&inside).is_err());
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, ..ProptestConfig::default() })]

    /// The writer on arbitrary relative paths: a path accepted is written
    /// inside the directory at that path; a refused one writes nothing.
    #[test]
    fn an_output_directory_writes_inside_or_nothing(parts in prop::collection::vec(
        prop::collection::vec(name_char(), 0..12).prop_map(|c| c.into_iter().collect::<String>()), 1..4)) {
        let relative = parts.join("/");
        let sandbox = tempfile::tempdir().unwrap();
        let out = sandbox.path().join("out");
        let dir = OutputDir::create(&out).unwrap();
        match dir.write(&relative, |w| w.write_all(b"x")) {
            Ok(path) => {
                prop_assert!(check_relative_path(&relative).is_ok());
                prop_assert_eq!(&path, &out.join(&relative));
                prop_assert_eq!(std::fs::read(&path).unwrap(), b"x");
                let written: BTreeSet<PathBuf> = tree(sandbox.path());
                prop_assert!(written.iter().all(|p| p.starts_with("out")), "{:?}", written);
            }
            Err(_) => {
                prop_assert!(check_relative_path(&relative).is_err());
                prop_assert_eq!(tree(sandbox.path()), BTreeSet::from([PathBuf::from("out")]));
            }
        }
    }
}

/// The Cf set comes from the Unicode data: every format character the
/// issue names and every control character (`char::is_control`) in the
/// whole code space is refused; and, checked against Rust's own tables
/// (`{:?}` escapes what they count as not printable), no character the
/// rule refuses is printable, but the three separators.
#[test]
fn every_format_and_control_character_is_refused() {
    let named = [
        0xad, 0x600, 0x61c, 0x6dd, 0x180e, 0x200b, 0x200c, 0x200d, 0x200e, 0x200f, 0x202a, 0x202b, 0x202c, 0x202d,
        0x202e, 0x2060, 0x2061, 0x2062, 0x2063, 0x2064, 0x2066, 0x2069, 0xfeff, 0xfff9, 0xfffb, 0x110bd, 0x1d173,
        0xe0001, 0xe0020, 0xe007f,
    ];
    for c in named.map(|c| char::from_u32(c).unwrap()) {
        assert!(check_name(&format!("a{c}b")).is_err(), "U+{:04X}", u32::from(c));
    }
    for c in (0..=0x10ffff).filter_map(char::from_u32) {
        let refused = check_name(&format!("a{c}b")).is_err();
        if c.is_control() {
            assert!(refused, "U+{:04X}", u32::from(c));
        }
        // The other way round: nothing Rust counts as printable is refused
        // but the separators (a character refused is one `{:?}` escapes).
        if refused && !"/\\:".contains(c) {
            assert!(format!("{:?}", c.to_string()).contains('\\'), "U+{:04X} is printable", u32::from(c));
        }
    }
}
