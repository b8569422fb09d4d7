//! The texture library: storage, provenance, seeded sampling, schema
//! versions, consistency checks and a reader beside a writer.

use std::path::Path;

use haptex_core::FrictionProfile;
use haptex_core::library::{Added, Library, LibraryError, ProfileProvenance, SCHEMA_VERSION};
use haptex_core::recording::synth::demo_recordings;
use haptex_core::recording::{ProcessingConfig, Recording, process};

fn demo(strokes_per_material: usize) -> Vec<Recording> {
    demo_recordings(11, strokes_per_material).into_iter().map(|(_, r)| r).collect()
}

fn import(library: &mut Library, recordings: &[Recording]) -> Vec<Added> {
    let config = ProcessingConfig::default();
    let run = library.begin_import("test", &config).unwrap();
    let added = recordings
        .iter()
        .map(|r| library.add_recording(run, r, &process(r, &config).unwrap(), &config).unwrap())
        .collect();
    library.finish_import(run).unwrap();
    added
}

fn user_profile() -> FrictionProfile {
    FrictionProfile::new(vec![0.0, 0.5, 1.0, 1.5], vec![0.4, 0.45, 0.5, 0.42]).unwrap()
}

fn provenance(synthetic: bool) -> ProfileProvenance {
    ProfileProvenance { source: "hand-made".into(), licence: "CC0-1.0".into(), synthetic, origin_path: "p.csv".into() }
}

#[test]
fn stores_lists_and_returns_profiles_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lib.sqlite");
    let mut library = Library::open(&path).unwrap();
    assert_eq!(library.schema_version().unwrap(), SCHEMA_VERSION);
    let recordings = &demo(2)[..6]; // three materials, two strokes each
    let added = import(&mut library, recordings);
    assert!(added.iter().all(|a| matches!(a, Added::New(_))));

    let materials = library.materials().unwrap();
    let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["latex", "sandpaper-p24", "sponge"]);
    assert!(materials.iter().all(|m| m.synthetic && m.strokes == 2));
    // mean mu of a material is the mean of its strokes' profile means.
    let strokes = library.strokes("SANDPAPER-P24").unwrap(); // names are case-insensitive
    assert_eq!(strokes.len(), 2);
    let mean = (strokes[0].mean_mu + strokes[1].mean_mu) / 2.0;
    assert!((materials[1].mean_mu - mean).abs() < 1e-12);
    assert_eq!(strokes[0].participant.as_deref(), Some(recordings[0].meta.participant.as_str()));
    assert!(strokes[0].metadata_json.contains("haptex-demo-1"));
    assert!(strokes[0].config_json.as_ref().unwrap().contains("\"dx_mm\":0.1"));

    // The stored profile is bit-identical to the processed one.
    let processed = process(&recordings[0], &ProcessingConfig::default()).unwrap();
    let stored = library.profile(strokes[0].id).unwrap();
    assert_eq!(stored.profile, processed.profile);
    assert_eq!(stored.stroke.mean_fn_n, Some(processed.mean_fn_n));

    // The same content again is a duplicate, not a second stroke.
    assert!(matches!(import(&mut library, &recordings[..1])[0], Added::Duplicate(_)));
    assert_eq!(library.strokes("sandpaper-p24").unwrap().len(), 2);
    let imports = library.imports().unwrap();
    assert_eq!(imports.iter().map(|i| i.strokes).collect::<Vec<_>>(), [6, 0]);
    assert!(imports.iter().all(|i| i.finished_at.is_some()));
    assert!(library.check().unwrap().is_empty());
}

/// The paper's random selection: the same seed selects the same stroke,
/// and seeds reach every stroke of the material.
#[test]
fn seeded_sampling_is_reproducible_and_covers_the_set() {
    let dir = tempfile::tempdir().unwrap();
    let mut library = Library::open(&dir.path().join("lib.sqlite")).unwrap();
    import(&mut library, &demo(3)[..3]);
    let a = library.sample("sandpaper-p24", Some(42)).unwrap();
    let b = library.sample("sandpaper-p24", Some(42)).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.seed, 42);
    let mut seen: Vec<i64> =
        (0..40).map(|s| library.sample("sandpaper-p24", Some(s)).unwrap().stored.stroke.id).collect();
    seen.sort();
    seen.dedup();
    assert_eq!(seen.len(), 3);
    // Without a seed, the seed drawn is returned and repeats the choice.
    let drawn = library.sample("sandpaper-p24", None).unwrap();
    assert_eq!(library.sample("sandpaper-p24", Some(drawn.seed)).unwrap(), drawn);

    let err = library.sample("granite", Some(1)).unwrap_err();
    assert_eq!(err.to_string(), "no material named \"granite\" in the library (it has: \"sandpaper-p24\")");
}

#[test]
fn user_profiles_become_materials_and_never_mix_with_synthetic_data() {
    let dir = tempfile::tempdir().unwrap();
    let mut library = Library::open(&dir.path().join("lib.sqlite")).unwrap();
    import(&mut library, &demo(1)[..1]); // synthetic sandpaper-p24
    let run = library.begin_import("test", &ProcessingConfig::default()).unwrap();
    let added = library.add_profile(run, "my bump", "a bump", &user_profile(), &provenance(false)).unwrap();
    let Added::New(id) = added else { panic!("{added:?}") };
    let stored = library.profile(id).unwrap();
    assert_eq!(stored.profile, user_profile());
    assert!(!stored.stroke.synthetic);
    assert_eq!(stored.stroke.participant, None);
    let materials = library.materials().unwrap();
    assert_eq!(materials[0].name, "my bump");
    assert!(!materials[0].synthetic);
    assert_eq!(materials[0].mean_fn_n, None);
    assert!(matches!(
        library.add_profile(run, "my bump", "", &user_profile(), &provenance(false)).unwrap(),
        Added::Duplicate(_)
    ));

    // Measured data cannot join a synthetic material.
    let err = library.add_profile(run, "Sandpaper-P24", "", &user_profile(), &provenance(false)).unwrap_err();
    assert!(matches!(err, LibraryError::SyntheticMismatch { .. }), "{err}");
    assert!(err.to_string().contains("holds synthetic strokes, this one is measured"), "{err}");
    for bad in ["", " padded", "tab\there"] {
        let err = library.add_profile(run, bad, "", &user_profile(), &provenance(false)).unwrap_err();
        assert!(matches!(err, LibraryError::InvalidName(_)), "{bad:?}: {err}");
    }
    assert!(library.check().unwrap().is_empty());
}

#[test]
fn schema_versions_and_foreign_files_are_recognized() {
    let dir = tempfile::tempdir().unwrap();
    // A newer schema than this haptex knows.
    let newer = dir.path().join("newer.sqlite");
    drop(Library::open(&newer).unwrap());
    raw(&newer).pragma_update(None, "user_version", 99).unwrap();
    for err in [Library::open(&newer).unwrap_err(), Library::open_read_only(&newer).unwrap_err()] {
        assert!(matches!(err, LibraryError::NewerSchema { found: 99, .. }), "{err}");
    }
    // An older one (a haptex library before migration 1): read-only refuses
    // with the upgrade command; read-write migrates.
    let older = dir.path().join("older.sqlite");
    raw(&older).pragma_update(None, "application_id", 0x4850_5458).unwrap();
    let err = Library::open_read_only(&older).unwrap_err();
    assert!(err.to_string().contains("haptex library upgrade --db"), "{err}");
    assert_eq!(Library::open(&older).unwrap().schema_version().unwrap(), SCHEMA_VERSION);
    assert!(Library::open_read_only(&older).is_ok());
    // Another application's database, and a file that is no database.
    let other = dir.path().join("other.sqlite");
    raw(&other).execute_batch("CREATE TABLE t (x)").unwrap();
    assert!(matches!(Library::open(&other).unwrap_err(), LibraryError::NotALibrary { .. }));
    let text = dir.path().join("text.sqlite");
    std::fs::write(&text, "x_mm,mu\n0,1\n".repeat(100)).unwrap();
    let err = Library::open_read_only(&text).unwrap_err();
    assert!(err.to_string().contains("text.sqlite"), "{err}");
    let err = Library::open_read_only(&dir.path().join("missing.sqlite")).unwrap_err();
    assert!(err.to_string().contains("missing.sqlite: cannot open the library: no such file"), "{err}");
}

/// The consistency check finds a stroke without a profile (what a
/// non-transactional import could leave behind).
#[test]
fn check_reports_half_imported_strokes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lib.sqlite");
    let mut library = Library::open(&path).unwrap();
    import(&mut library, &demo(1)[..1]);
    raw(&path)
        .execute_batch(
            "INSERT INTO strokes (material_id, import_id, kind, synthetic, source, licence, origin_path,
                                  content_sha256, metadata_json)
             VALUES (1, 1, 'recording', 1, 's', 'l', 'o', 'abc', '{}')",
        )
        .unwrap();
    assert_eq!(library.check().unwrap(), ["stroke 2 has no profile (half-imported)"]);
}

/// A reader opened read-only works while a writer imports (WAL mode): it
/// never fails and sees a growing, consistent library.
#[test]
fn a_reader_works_during_an_import() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lib.sqlite");
    let recordings = demo(2);
    let config = ProcessingConfig::default();
    let processed: Vec<_> = recordings.iter().map(|r| process(r, &config).unwrap()).collect();
    let mut writer = Library::open(&path).unwrap();
    let reader = Library::open_read_only(&path).unwrap();
    let run = writer.begin_import("test", &config).unwrap();
    let mut last = 0;
    for (r, p) in recordings.iter().zip(&processed) {
        writer.add_recording(run, r, p, &config).unwrap();
        let total: u64 = reader.materials().unwrap().iter().map(|m| m.strokes).sum();
        assert!(total > last, "{total} after {last}");
        last = total;
        let newest = reader.materials().unwrap().into_iter().find(|m| m.name == r.meta.material).unwrap();
        reader.sample(&newest.name, Some(1)).unwrap();
    }
    writer.finish_import(run).unwrap();
    assert_eq!(last, 24);
    // And from another thread, concurrently.
    let path2 = path.clone();
    let handle = std::thread::spawn(move || {
        let reader = Library::open_read_only(&path2).unwrap();
        (0..50).map(|s| reader.sample("velvet", Some(s)).unwrap().stored.profile.len()).sum::<usize>()
    });
    let more = demo_recordings(12, 2);
    let run = writer.begin_import("test", &config).unwrap();
    for (_, r) in &more {
        writer.add_recording(run, r, &process(r, &config).unwrap(), &config).unwrap();
    }
    assert!(handle.join().unwrap() > 0);
    assert!(writer.check().unwrap().is_empty());
}

fn raw(path: &Path) -> rusqlite::Connection {
    rusqlite::Connection::open(path).unwrap()
}

/// After `settle` the library is one file again, and a read-only user
/// leaves no `-wal`/`-shm` files beside it (the shipped library lives in
/// the repository); with a reader still open, settle skips without waiting.
#[test]
fn settle_returns_to_a_single_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lib.sqlite");
    let mut library = Library::open(&path).unwrap();
    import(&mut library, &demo(1)[..1]);
    let reader = Library::open_read_only(&path).unwrap();
    reader.materials().unwrap();
    assert!(!library.settle().unwrap());
    drop(reader);
    assert!(library.settle().unwrap());
    drop(library);
    let files = || std::fs::read_dir(dir.path()).unwrap().count();
    assert_eq!(files(), 1);
    let reader = Library::open_read_only(&path).unwrap();
    assert_eq!(reader.materials().unwrap().len(), 1);
    assert_eq!(files(), 1);
    // Opening for writing again works (back in WAL mode).
    drop(reader);
    let library = Library::open(&path).unwrap();
    assert!(library.check().unwrap().is_empty());
}

/// An upload's write: all strokes or none. A stroke refused (here a
/// measured stroke of a synthetic material) leaves the library exactly as
/// it was, without even the import run.
#[test]
fn atomic_imports_store_all_or_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lib.sqlite");
    let mut library = Library::open(&path).unwrap();
    let config = ProcessingConfig::default();
    let recordings = demo(2);
    import(&mut library, &recordings[..1]); // one synthetic sandpaper stroke
    let before = (library.materials().unwrap(), library.imports().unwrap());

    let mut measured = recordings[1].clone(); // sandpaper again, claimed measured
    measured.meta.synthetic = false;
    measured.sha256 = Some("a different content".into());
    let good = &recordings[2]; // another material
    let processed: Vec<_> = [good, &measured].iter().map(|r| process(r, &config).unwrap()).collect();
    let refused =
        library.add_recordings_atomically("upload", &config, &[(good, &processed[0]), (&measured, &processed[1])]);
    assert!(matches!(refused, Err(LibraryError::SyntheticMismatch { .. })), "{refused:?}");
    assert_eq!((library.materials().unwrap(), library.imports().unwrap()), before);

    // Accepted: one run, finished, the strokes new; the same content given
    // twice (or already stored) is a duplicate.
    let (run, added) = library
        .add_recordings_atomically(
            "upload",
            &config,
            &[
                (good, &processed[0]),
                (good, &processed[0]),
                (&recordings[0], &process(&recordings[0], &config).unwrap()),
            ],
        )
        .unwrap();
    assert!(matches!(added[..], [Added::New(a), Added::Duplicate(b), Added::Duplicate(_)] if a == b), "{added:?}");
    let imports = library.imports().unwrap();
    assert_eq!(imports.len(), 2);
    assert_eq!(imports[1].id, run.0);
    assert!(imports[1].finished_at.is_some() && imports[1].strokes == 1);
    let Added::New(id) = added[0] else { unreachable!() };
    assert_eq!(library.profile(id).unwrap().profile, processed[0].profile);
    assert!(library.check().unwrap().is_empty());
}
