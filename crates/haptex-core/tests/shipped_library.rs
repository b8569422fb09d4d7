//! The shipped demo library (data/library): its recordings are what the
//! documented generator makes from the documented seed, bit for bit, and
//! its database holds exactly their processed profiles, all flagged
//! synthetic.

use std::path::{Path, PathBuf};

use haptex_core::library::Library;
use haptex_core::recording::synth::{DEMO_MATERIALS, DEMO_SEED, DEMO_STROKES_PER_MATERIAL, write_demo};
use haptex_core::recording::{ProcessingConfig, Recording, process};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Every file below `dir`, relative to it, sorted.
fn files_below(dir: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() { walk(&path, out) } else { out.push(path) }
        }
    }
    let mut out = Vec::new();
    walk(dir, &mut out);
    let mut out: Vec<PathBuf> = out.iter().map(|p| p.strip_prefix(dir).unwrap().to_path_buf()).collect();
    out.sort();
    out
}

#[test]
fn shipped_demo_recordings_regenerate_bit_for_bit() {
    let shipped = repo().join("data/library/demo");
    let dir = tempfile::tempdir().unwrap();
    write_demo(dir.path(), DEMO_SEED, DEMO_STROKES_PER_MATERIAL).unwrap();
    let generated = files_below(dir.path());
    assert_eq!(generated.len(), 3 * 12 * DEMO_STROKES_PER_MATERIAL);
    assert_eq!(files_below(&shipped), generated);
    for file in &generated {
        let a = std::fs::read(dir.path().join(file)).unwrap();
        let b = std::fs::read(shipped.join(file)).unwrap();
        assert!(a == b, "{} differs from what `haptex library demo --seed {DEMO_SEED}` writes", file.display());
    }
}

#[test]
fn shipped_library_holds_the_processed_demo_recordings() {
    let library = Library::open_read_only(&repo().join("data/library/library.sqlite")).unwrap();
    assert_eq!(library.check().unwrap(), Vec::<String>::new());
    let materials = library.materials().unwrap();
    let mut names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    let mut expected: Vec<&str> = DEMO_MATERIALS.iter().map(|m| m.name).collect();
    names.sort();
    expected.sort();
    assert_eq!(names, expected);
    for material in &materials {
        assert!(material.synthetic, "{} must be flagged synthetic", material.name);
        assert_eq!(material.strokes, DEMO_STROKES_PER_MATERIAL as u64);
        for stroke in library.strokes(&material.name).unwrap() {
            assert!(stroke.synthetic);
            let recording = Recording::load(&repo().join(&stroke.origin_path)).unwrap();
            assert_eq!(recording.sha256.as_deref(), Some(stroke.content_sha256.as_str()));
            let config: ProcessingConfig = serde_json::from_str(stroke.config_json.as_deref().unwrap()).unwrap();
            assert_eq!(config, ProcessingConfig::default());
            let stored = library.profile(stroke.id).unwrap();
            assert_eq!(stored.profile, process(&recording, &config).unwrap().profile, "stroke {}", stroke.id);
        }
    }
}
