//! The texture library: an embedded SQLite database of materials, their
//! strokes (recordings or user profiles) with full provenance, and the
//! processed friction profiles (paper section 2.4: "a random selection from
//! the experimental set is performed ... of a selected material").
//!
//! Tables (`schema.rs`): `materials` (name, description, `synthetic`),
//! `imports` (one row per import run: haptex version, command, processing
//! configuration, start and finish time; a run without `finished_at` was
//! interrupted), `strokes` (one recorded stroke or user profile: material,
//! participant, stroke number, `synthetic`, source, licence, origin file,
//! SHA-256 of its content, the recording's metadata verbatim, rates,
//! duration) and `profiles` (exactly one per stroke: mu(x) and Fn(x) as
//! little-endian f64 blobs, the processing configuration, summary values
//! and the sliding segments).
//!
//! Concurrency and crashes: the database is in WAL mode, so readers
//! ([`Library::open_read_only`]) work while an import writes. Every stroke
//! is written with its profile (and, if new, its material) in one
//! transaction: a killed import leaves complete strokes only, and re-running
//! it skips what is already there (by content hash). A material holds
//! either synthetic or measured strokes, never both.
//!
//! A `Library` wraps one SQLite connection: it is `Send` but not `Sync`.
//! A server opens one per worker (opening is cheap) or guards one with a
//! mutex.

mod schema;

use std::path::{Path, PathBuf};
use std::time::Duration;

use rusqlite::{Connection, OpenFlags, OptionalExtension, TransactionBehavior, params};
use serde::Serialize;
use sha2::{Digest, Sha256};

use crate::name::{NameError, check_name};
use crate::profile::FrictionProfile;
use crate::recording::format::METADATA_SUFFIX;
use crate::recording::rng::SplitMix64;
use crate::recording::{ProcessedStroke, ProcessingConfig, Recording, RecordingError, process};
use crate::text::Quoted;

pub use schema::SCHEMA_VERSION;

/// Where the shipped demo library is, relative to the repository root.
pub const SHIPPED_LIBRARY: &str = "data/library/library.sqlite";

/// The environment variable naming the default library.
pub const LIBRARY_ENV_VAR: &str = "HAPTEX_LIBRARY";

/// The library used when none is given: $HAPTEX_LIBRARY, else the shipped
/// library of this source tree ([`crate::io::shipped_data`]).
pub fn default_library_path() -> PathBuf {
    crate::io::shipped_data(LIBRARY_ENV_VAR, SHIPPED_LIBRARY)
}

/// How long a connection waits for a lock before giving up.
const BUSY_TIMEOUT: Duration = Duration::from_secs(10);
/// Most material names an "unknown material" error lists.
const KNOWN_SHOWN: usize = 20;

/// A library operation failed.
#[derive(Debug, thiserror::Error)]
pub enum LibraryError {
    #[error("{path}: cannot open the library: {message}")]
    Open { path: String, message: String },
    #[error("{path}: not a haptex library (a SQLite database of another application)")]
    NotALibrary { path: String },
    #[error("{path}: library schema version {found} is newer than this haptex supports ({supported}): update haptex")]
    NewerSchema { path: String, found: i64, supported: i64 },
    #[error(
        "{path}: library schema version {found} is older than this haptex ({supported}): upgrade it with \
         `haptex library upgrade --db {path}`"
    )]
    OlderSchema { path: String, found: i64, supported: i64 },
    #[error("no material named {} in the library (it has: {known})", Quoted(name))]
    UnknownMaterial { name: String, known: String },
    #[error("no stroke with id {0} in the library")]
    UnknownStroke(i64),
    /// A material name that breaks the name rule ([`crate::name`]).
    #[error("material {0}")]
    InvalidName(#[from] NameError),
    #[error(
        "material {} holds {existing} strokes, this one is {new}: a material never mixes synthetic and \
         measured data; import it under another name (e.g. {name}-{new}) or into another library (--db)",
        Quoted(name)
    )]
    SyntheticMismatch { name: String, existing: &'static str, new: &'static str },
    #[error("stroke {id}: stored profile is corrupt: {message}")]
    Corrupt { id: i64, message: String },
    #[error("not stored: the profile would not read back from the library: {0}")]
    Unreadable(String),
    #[error("library database error: {0}")]
    Sqlite(#[from] rusqlite::Error),
}

/// A recording could not be imported: it could not be read or processed,
/// or the library refused it.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    #[error(transparent)]
    Recording(#[from] RecordingError),
    #[error(transparent)]
    Library(#[from] LibraryError),
}

/// One material with its strokes summarized.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MaterialSummary {
    pub name: String,
    pub description: String,
    /// Generated, not measured (e.g. the shipped demo library).
    pub synthetic: bool,
    pub strokes: u64,
    /// Mean over the strokes of each profile's mean mu.
    pub mean_mu: f64,
    /// Smallest and largest stroke mean mu.
    pub mu_range: (f64, f64),
    /// Mean over the strokes of Fn_RS (N), where known.
    pub mean_fn_n: Option<f64>,
}

/// What a stroke is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StrokeKind {
    /// A processed recording.
    Recording,
    /// A friction profile added as is.
    Profile,
}

/// A stroke's provenance and profile summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StrokeInfo {
    pub id: i64,
    pub material: String,
    pub kind: StrokeKind,
    pub participant: Option<String>,
    pub stroke: Option<i64>,
    pub synthetic: bool,
    pub source: String,
    pub licence: String,
    /// The file it was imported from (as given at import).
    pub origin_path: String,
    pub content_sha256: String,
    pub imported_at: String,
    pub import_id: i64,
    /// The recording's metadata (or the profile's provenance) as JSON text.
    pub metadata_json: String,
    /// The processing configuration as JSON text (recordings).
    pub config_json: Option<String>,
    pub force_rate_hz: Option<f64>,
    pub position_rate_hz: Option<f64>,
    pub duration_s: Option<f64>,
    pub n_points: i64,
    pub span_mm: f64,
    pub mean_mu: f64,
    /// Fn_RS, the mean normal force while sliding (N), where known.
    pub mean_fn_n: Option<f64>,
    pub sliding_s: Option<f64>,
    /// Length of the profile bridged between sliding segments, mm.
    pub bridged_mm: Option<f64>,
    pub n_segments: Option<i64>,
}

impl StrokeInfo {
    /// Lines describing where the stroke comes from (synthetic or
    /// measured, source, licence, origin, Fn_RS), for `#` comments of an
    /// exported profile.
    pub fn provenance_lines(&self) -> Vec<String> {
        let mut lines = vec![
            format!(
                "stroke {}: {}{}",
                self.id,
                match (&self.participant, self.stroke) {
                    (Some(p), Some(n)) => format!("participant {p}, stroke {n}, "),
                    _ => String::new(),
                },
                if self.synthetic { "SYNTHETIC (generated, not measured)" } else { "measured" }
            ),
            format!("source: {}", self.source),
            format!("licence: {}", self.licence),
            format!("origin: {} (sha256 {})", self.origin_path, self.content_sha256),
        ];
        if let Some(f) = self.mean_fn_n {
            lines.push(format!(
                "fn_n: normal force along the stroke in N; Fn_RS (mean while sliding, paper section 2.4) = {f:.6} N"
            ));
        }
        lines
    }
}

/// A stored profile with its stroke.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredProfile {
    pub stroke: StrokeInfo,
    pub profile: FrictionProfile,
}

/// A randomly selected stroke and the seed that selected it.
#[derive(Debug, Clone, PartialEq)]
pub struct SampledProfile {
    pub seed: u64,
    pub stored: StoredProfile,
}

/// One import run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportInfo {
    pub id: i64,
    pub started_at: String,
    /// `None`: the run was interrupted (or is still running).
    pub finished_at: Option<String>,
    pub haptex_version: String,
    pub command: String,
    pub strokes: u64,
}

/// Identifies an import run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImportId(pub i64);

/// Result of adding a stroke.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Added {
    /// Stored under this stroke id.
    New(i64),
    /// The same content is already stored under this stroke id.
    Duplicate(i64),
}

/// Provenance of a user profile added as a stroke.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProfileProvenance {
    pub source: String,
    pub licence: String,
    pub synthetic: bool,
    /// The file the profile was read from.
    pub origin_path: String,
}

/// Recording metadata files: the files given, and every
/// `*.recording.json` below the directories given, each directory's sorted
/// (what `haptex library import` imports). A path that is neither is a
/// `NotFound` error, a directory without recordings an `InvalidInput` one.
pub fn collect_recordings(inputs: &[PathBuf]) -> std::io::Result<Vec<PathBuf>> {
    use std::collections::HashSet;
    use std::io::{Error, ErrorKind};
    let cannot_read =
        |dir: &Path, e: Error| Error::new(e.kind(), format!("cannot read directory {}: {e}", dir.display()));
    /// Walks `dir` depth first, entering each real directory once (a
    /// symbolic link back up the tree would otherwise make the walk
    /// endless, or exponential with two such links).
    fn walk(
        dir: &Path,
        out: &mut Vec<PathBuf>,
        seen: &mut HashSet<PathBuf>,
        cannot_read: &dyn Fn(&Path, Error) -> Error,
    ) -> std::io::Result<()> {
        let real = std::fs::canonicalize(dir).map_err(|e| cannot_read(dir, e))?;
        if !seen.insert(real) {
            return Ok(());
        }
        for entry in std::fs::read_dir(dir).map_err(|e| cannot_read(dir, e))? {
            let path = entry.map_err(|e| cannot_read(dir, e))?.path();
            if path.is_dir() {
                walk(&path, out, seen, cannot_read)?;
            } else if path.to_string_lossy().ends_with(METADATA_SUFFIX) {
                out.push(path);
            }
        }
        Ok(())
    }
    let mut files = Vec::new();
    let mut seen = HashSet::new();
    for input in inputs {
        if input.is_dir() {
            let before = files.len();
            walk(input, &mut files, &mut seen, &cannot_read)?;
            files[before..].sort();
            if files.len() == before {
                return Err(Error::new(
                    ErrorKind::InvalidInput,
                    format!("{}: no recordings (*{METADATA_SUFFIX}) in this directory", input.display()),
                ));
            }
        } else if input.is_file() {
            files.push(input.clone());
        } else {
            return Err(Error::new(ErrorKind::NotFound, format!("{}: no such file or directory", input.display())));
        }
    }
    Ok(files)
}

/// The texture library (see the module documentation).
pub struct Library {
    conn: Connection,
    path: PathBuf,
}

impl std::fmt::Debug for Library {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Library").field("path", &self.path).finish()
    }
}

impl Library {
    /// Opens a library for reading and writing, creating it (and its
    /// directory's file) if missing and migrating it to the current schema.
    pub fn open(path: &Path) -> Result<Self, LibraryError> {
        let label = path.display().to_string();
        let open_error = |e: rusqlite::Error| LibraryError::Open { path: label.clone(), message: e.to_string() };
        let mut conn = Connection::open(path).map_err(open_error)?;
        conn.busy_timeout(BUSY_TIMEOUT).map_err(open_error)?;
        Self::check_identity(&conn, &label, true)?;
        conn.pragma_update_and_check(None, "journal_mode", "WAL", |_| Ok(())).map_err(open_error)?;
        conn.pragma_update(None, "synchronous", "NORMAL")?;
        conn.pragma_update(None, "foreign_keys", "ON")?;
        schema::migrate(&mut conn)?;
        Ok(Self { conn, path: path.to_path_buf() })
    }

    /// Opens an existing library read-only (what a server does). Works
    /// while another process imports into it.
    pub fn open_read_only(path: &Path) -> Result<Self, LibraryError> {
        let label = path.display().to_string();
        if !path.is_file() {
            return Err(LibraryError::Open { path: label, message: "no such file".into() });
        }
        let open_error = |e: rusqlite::Error| LibraryError::Open { path: label.clone(), message: e.to_string() };
        let conn = Connection::open_with_flags(
            path,
            OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX | OpenFlags::SQLITE_OPEN_URI,
        )
        .map_err(open_error)?;
        conn.busy_timeout(BUSY_TIMEOUT).map_err(open_error)?;
        Self::check_identity(&conn, &label, false)?;
        let version = schema::user_version(&conn)?;
        if version < SCHEMA_VERSION {
            return Err(LibraryError::OlderSchema { path: label, found: version, supported: SCHEMA_VERSION });
        }
        Ok(Self { conn, path: path.to_path_buf() })
    }

    /// A haptex library, or (when creating) a new empty database.
    fn check_identity(conn: &Connection, label: &str, may_create: bool) -> Result<(), LibraryError> {
        let open_error = |e: rusqlite::Error| LibraryError::Open { path: label.to_string(), message: e.to_string() };
        let app = schema::application_id(conn).map_err(open_error)?;
        let tables = schema::table_count(conn).map_err(open_error)?;
        if app != schema::APPLICATION_ID && !(may_create && app == 0 && tables == 0) {
            return Err(LibraryError::NotALibrary { path: label.to_string() });
        }
        let version = schema::user_version(conn).map_err(open_error)?;
        if version > SCHEMA_VERSION {
            return Err(LibraryError::NewerSchema {
                path: label.to_string(),
                found: version,
                supported: SCHEMA_VERSION,
            });
        }
        Ok(())
    }

    /// Ends a write session: checkpoints the write-ahead log into the
    /// database file and, if no other connection has the database open,
    /// returns it to a single-file database (rollback journal), so that
    /// read-only users (a server, `haptex library list`) leave no `-wal` and
    /// `-shm` files beside it. The next [`Library::open`] switches back to
    /// WAL. Returns whether the switch happened (it is skipped, not waited
    /// for, while a reader is open).
    pub fn settle(&self) -> Result<bool, LibraryError> {
        self.conn.busy_timeout(Duration::ZERO)?;
        let mode: rusqlite::Result<String> = self
            .conn
            .query_row("PRAGMA wal_checkpoint(TRUNCATE)", [], |_| Ok(()))
            .and_then(|()| self.conn.query_row("PRAGMA journal_mode = DELETE", [], |r| r.get(0)));
        self.conn.busy_timeout(BUSY_TIMEOUT)?;
        match mode {
            Ok(mode) => Ok(mode.eq_ignore_ascii_case("delete")),
            Err(rusqlite::Error::SqliteFailure(e, _)) if e.code == rusqlite::ErrorCode::DatabaseBusy => Ok(false),
            Err(e) => Err(e.into()),
        }
    }

    /// Path of the database file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Schema version of the open database.
    pub fn schema_version(&self) -> Result<i64, LibraryError> {
        Ok(schema::user_version(&self.conn)?)
    }

    /// Every material, by name, with stroke counts and mean friction.
    pub fn materials(&self) -> Result<Vec<MaterialSummary>, LibraryError> {
        let mut statement = self.conn.prepare(
            "SELECT m.name, m.description, m.synthetic, count(s.id), avg(p.mean_mu), min(p.mean_mu), max(p.mean_mu),
                    avg(p.mean_fn_n)
             FROM materials m JOIN strokes s ON s.material_id = m.id JOIN profiles p ON p.stroke_id = s.id
             GROUP BY m.id ORDER BY m.name COLLATE NOCASE",
        )?;
        let rows = statement.query_map([], |r| {
            Ok(MaterialSummary {
                name: r.get(0)?,
                description: r.get(1)?,
                synthetic: r.get(2)?,
                strokes: r.get::<_, i64>(3)? as u64,
                mean_mu: r.get(4)?,
                mu_range: (r.get(5)?, r.get(6)?),
                mean_fn_n: r.get(7)?,
            })
        })?;
        Ok(rows.collect::<Result<_, _>>()?)
    }

    /// The strokes of a material (name matched case-insensitively), by id.
    pub fn strokes(&self, material: &str) -> Result<Vec<StrokeInfo>, LibraryError> {
        let id = self.material_id(material)?;
        let mut statement = self.conn.prepare(&format!("{STROKE_SELECT} WHERE s.material_id = ?1 ORDER BY s.id"))?;
        let rows = statement.query_map([id], stroke_info)?;
        Ok(rows.collect::<Result<_, _>>()?)
    }

    /// One stroke's provenance and summary.
    pub fn stroke(&self, id: i64) -> Result<StrokeInfo, LibraryError> {
        self.conn
            .query_row(&format!("{STROKE_SELECT} WHERE s.id = ?1"), [id], stroke_info)
            .optional()?
            .ok_or(LibraryError::UnknownStroke(id))
    }

    /// A stroke's profile (x_mm, mu and, where known, fn_n).
    pub fn profile(&self, stroke_id: i64) -> Result<StoredProfile, LibraryError> {
        let stroke = self.stroke(stroke_id)?;
        let (x, mu, fnn): (Vec<u8>, Vec<u8>, Option<Vec<u8>>) =
            self.conn.query_row("SELECT x_mm, mu, fn_n FROM profiles WHERE stroke_id = ?1", [stroke_id], |r| {
                Ok((r.get(0)?, r.get(1)?, r.get(2)?))
            })?;
        let profile = read_back(&x, &mu, fnn.as_deref())
            .map_err(|e| LibraryError::Corrupt { id: stroke_id, message: e.to_string() })?;
        Ok(StoredProfile { stroke, profile })
    }

    /// A random stroke of `material` (the paper's "random selection from
    /// the experimental set"). The same seed on the same set of strokes
    /// selects the same stroke; without a seed one is drawn and returned.
    pub fn sample(&self, material: &str, seed: Option<u64>) -> Result<SampledProfile, LibraryError> {
        let ids: Vec<i64> = self.strokes(material)?.into_iter().map(|s| s.id).collect();
        if ids.is_empty() {
            return Err(LibraryError::UnknownMaterial {
                name: material.to_string(),
                known: "it has no strokes".into(),
            });
        }
        let seed = seed.unwrap_or_else(random_seed);
        let index = SplitMix64::new(seed).below(ids.len() as u64) as usize;
        Ok(SampledProfile { seed, stored: self.profile(ids[index])? })
    }

    /// The id of the stroke with this content hash, if stored.
    pub fn find_content(&self, sha256: &str) -> Result<Option<i64>, LibraryError> {
        Ok(self
            .conn
            .query_row("SELECT id FROM strokes WHERE content_sha256 = ?1", [sha256], |r| r.get(0))
            .optional()?)
    }

    /// Records the start of an import run.
    pub fn begin_import(&self, command: &str, config: &ProcessingConfig) -> Result<ImportId, LibraryError> {
        let config_json = serde_json::to_string(config).expect("config serializes");
        self.conn.execute(
            "INSERT INTO imports (haptex_version, command, config_json) VALUES (?1, ?2, ?3)",
            params![env!("CARGO_PKG_VERSION"), command, config_json],
        )?;
        Ok(ImportId(self.conn.last_insert_rowid()))
    }

    /// Records the end of an import run.
    pub fn finish_import(&self, import: ImportId) -> Result<(), LibraryError> {
        self.conn.execute(
            "UPDATE imports SET finished_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now') WHERE id = ?1",
            [import.0],
        )?;
        Ok(())
    }

    /// Every import run, oldest first, with the strokes each added.
    pub fn imports(&self) -> Result<Vec<ImportInfo>, LibraryError> {
        let mut statement = self.conn.prepare(
            "SELECT i.id, i.started_at, i.finished_at, i.haptex_version, i.command,
                    (SELECT count(*) FROM strokes s WHERE s.import_id = i.id)
             FROM imports i ORDER BY i.id",
        )?;
        let rows = statement.query_map([], |r| {
            Ok(ImportInfo {
                id: r.get(0)?,
                started_at: r.get(1)?,
                finished_at: r.get(2)?,
                haptex_version: r.get(3)?,
                command: r.get(4)?,
                strokes: r.get::<_, i64>(5)? as u64,
            })
        })?;
        Ok(rows.collect::<Result<_, _>>()?)
    }

    /// Stores a processed recording with its provenance, in one
    /// transaction. `config` is the configuration it was processed with.
    pub fn add_recording(
        &mut self,
        import: ImportId,
        recording: &Recording,
        processed: &ProcessedStroke,
        config: &ProcessingConfig,
    ) -> Result<Added, LibraryError> {
        let sha = recording.sha256.clone().unwrap_or_else(|| recording_hash(recording));
        self.insert(import, &recording_row(recording, processed, config, &sha), &processed.profile)
    }

    /// Imports one recording (its metadata file `file`) in the import run
    /// `import`: skipped as a duplicate when its content is already
    /// stored, else processed with `config` and stored with its profile
    /// (what `haptex library import` does for each recording).
    pub fn import_recording(
        &mut self,
        import: ImportId,
        file: &Path,
        config: &ProcessingConfig,
    ) -> Result<Added, ImportError> {
        let recording = Recording::load(file)?;
        if let Some(id) = self.find_content(recording.sha256.as_deref().expect("loaded recordings have a hash"))? {
            return Ok(Added::Duplicate(id));
        }
        let processed = process(&recording, config)?;
        Ok(self.add_recording(import, &recording, &processed, config)?)
    }

    /// Stores processed recordings all or none: an import run (`command`,
    /// `config`), every stroke with its profile and new materials, in one
    /// transaction. If any stroke is refused (a material that mixes
    /// synthetic and measured data, a name out of bounds) nothing is
    /// written, not even the import run. Content already stored (or given
    /// twice) is reported as a duplicate, as [`Library::add_recording`]
    /// does. `config` is the configuration every stroke was processed with.
    pub fn add_recordings_atomically(
        &mut self,
        command: &str,
        config: &ProcessingConfig,
        strokes: &[(&Recording, &ProcessedStroke)],
    ) -> Result<(ImportId, Vec<Added>), LibraryError> {
        let config_json = serde_json::to_string(config).expect("config serializes");
        let tx = self.conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
        tx.execute(
            "INSERT INTO imports (haptex_version, command, config_json) VALUES (?1, ?2, ?3)",
            params![env!("CARGO_PKG_VERSION"), command, config_json],
        )?;
        let import = ImportId(tx.last_insert_rowid());
        let mut added = Vec::with_capacity(strokes.len());
        for (recording, processed) in strokes {
            let sha = recording.sha256.clone().unwrap_or_else(|| recording_hash(recording));
            added.push(insert_in(&tx, import, &recording_row(recording, processed, config, &sha), &processed.profile)?);
        }
        tx.execute("UPDATE imports SET finished_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now') WHERE id = ?1", [import.0])?;
        tx.commit()?;
        Ok((import, added))
    }

    /// Stores a friction profile as a stroke of `material` (created with
    /// `description` if new), in one transaction.
    pub fn add_profile(
        &mut self,
        import: ImportId,
        material: &str,
        description: &str,
        profile: &FrictionProfile,
        provenance: &ProfileProvenance,
    ) -> Result<Added, LibraryError> {
        let mut hash = Sha256::new();
        hash.update(b"haptex-profile\0");
        for column in [Some(profile.x_mm()), Some(profile.mu()), profile.fn_n()].into_iter().flatten() {
            hash.update(encode(column));
        }
        hash.update(material.to_lowercase().as_bytes());
        let sha = hex(&hash.finalize());
        let row = StrokeRow {
            material,
            description,
            kind: StrokeKind::Profile,
            participant: None,
            stroke: None,
            synthetic: provenance.synthetic,
            source: &provenance.source,
            licence: &provenance.licence,
            origin_path: &provenance.origin_path,
            sha256: &sha,
            metadata_json: serde_json::to_string(provenance).expect("provenance serializes"),
            force_rate_hz: None,
            position_rate_hz: None,
            duration_s: None,
            config_json: None,
            sliding_s: None,
            bridged_mm: None,
            segments_json: None,
            n_segments: None,
        };
        self.insert(import, &row, profile)
    }

    fn insert(&mut self, import: ImportId, row: &StrokeRow, profile: &FrictionProfile) -> Result<Added, LibraryError> {
        let tx = self.conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
        let added = insert_in(&tx, import, row, profile)?;
        if let Added::New(_) = added {
            tx.commit()?;
        }
        Ok(added)
    }

    /// Checks the database: SQLite's integrity and foreign-key checks, and
    /// haptex's invariants (every stroke has exactly one readable profile,
    /// every material has a stroke). Returns the problems (empty: consistent).
    pub fn check(&self) -> Result<Vec<String>, LibraryError> {
        let mut problems = Vec::new();
        let integrity: Vec<String> =
            self.conn.prepare("PRAGMA integrity_check")?.query_map([], |r| r.get(0))?.collect::<Result<_, _>>()?;
        if integrity != ["ok"] {
            problems.extend(integrity.into_iter().map(|m| format!("integrity_check: {m}")));
        }
        let fk: Vec<String> = self
            .conn
            .prepare("PRAGMA foreign_key_check")?
            .query_map([], |r| {
                Ok(format!("foreign key violation in {} row {:?}", r.get::<_, String>(0)?, r.get::<_, Option<i64>>(1)?))
            })?
            .collect::<Result<_, _>>()?;
        problems.extend(fk);
        let orphans: Vec<i64> = self
            .conn
            .prepare("SELECT id FROM strokes WHERE id NOT IN (SELECT stroke_id FROM profiles) ORDER BY id")?
            .query_map([], |r| r.get(0))?
            .collect::<Result<_, _>>()?;
        problems.extend(orphans.iter().map(|id| format!("stroke {id} has no profile (half-imported)")));
        let empty: Vec<String> = self
            .conn
            .prepare("SELECT name FROM materials WHERE id NOT IN (SELECT material_id FROM strokes)")?
            .query_map([], |r| r.get(0))?
            .collect::<Result<_, _>>()?;
        problems.extend(empty.iter().map(|name| format!("material {} has no strokes", Quoted(name))));
        // Names a foreign or edited file may hold though no import takes
        // them: each would be refused by an export.
        let names: Vec<String> = self
            .conn
            .prepare("SELECT name FROM materials ORDER BY id")?
            .query_map([], |r| r.get(0))?
            .collect::<Result<_, _>>()?;
        problems.extend(names.iter().filter_map(|name| check_name(name).err()).map(|e| {
            format!("material {e}; rename it (a material name is a file name of an export: docs/recordings.md)")
        }));
        let ids: Vec<i64> = self
            .conn
            .prepare("SELECT stroke_id FROM profiles")?
            .query_map([], |r| r.get(0))?
            .collect::<Result<_, _>>()?;
        for id in ids {
            if let Err(e) = self.profile(id) {
                problems.push(e.to_string());
            }
        }
        Ok(problems)
    }

    fn material_id(&self, name: &str) -> Result<i64, LibraryError> {
        if let Some(id) =
            self.conn.query_row("SELECT id FROM materials WHERE name = ?1", [name], |r| r.get(0)).optional()?
        {
            return Ok(id);
        }
        let known: Vec<String> = self.materials()?.into_iter().map(|m| m.name).collect();
        let mut shown: Vec<String> = known.iter().take(KNOWN_SHOWN).map(|n| Quoted(n).to_string()).collect();
        if known.len() > KNOWN_SHOWN {
            shown.push(format!("and {} more", known.len() - KNOWN_SHOWN));
        }
        Err(LibraryError::UnknownMaterial {
            name: name.to_string(),
            known: if known.is_empty() { "no materials".into() } else { shown.join(", ") },
        })
    }
}

/// The values of one new stroke row.
/// Writes a stroke, its profile and (if new) its material within `tx`
/// (which the caller commits): a duplicate of stored content is reported,
/// not written.
fn insert_in(
    tx: &rusqlite::Transaction,
    import: ImportId,
    row: &StrokeRow,
    profile: &FrictionProfile,
) -> Result<Added, LibraryError> {
    check_name(row.material)?;
    // The library never accepts what it cannot read back: decode what
    // would be stored exactly as `profile()` will.
    read_back(&encode(profile.x_mm()), &encode(profile.mu()), profile.fn_n().map(encode).as_deref())
        .map_err(|e| LibraryError::Unreadable(e.to_string()))?;
    if let Some(id) =
        tx.query_row("SELECT id FROM strokes WHERE content_sha256 = ?1", [row.sha256], |r| r.get(0)).optional()?
    {
        return Ok(Added::Duplicate(id));
    }
    let existing: Option<(i64, String, bool)> = tx
        .query_row("SELECT id, name, synthetic FROM materials WHERE name = ?1", [row.material], |r| {
            Ok((r.get(0)?, r.get(1)?, r.get(2)?))
        })
        .optional()?;
    let kind_word = |synthetic: bool| if synthetic { "synthetic" } else { "measured" };
    let material_id = match existing {
        Some((_, name, synthetic)) if synthetic != row.synthetic => {
            return Err(LibraryError::SyntheticMismatch {
                name,
                existing: kind_word(synthetic),
                new: kind_word(row.synthetic),
            });
        }
        Some((id, _, _)) => id,
        None => {
            tx.execute(
                "INSERT INTO materials (name, description, synthetic) VALUES (?1, ?2, ?3)",
                params![row.material, row.description, row.synthetic],
            )?;
            tx.last_insert_rowid()
        }
    };
    tx.execute(
        "INSERT INTO strokes (material_id, import_id, kind, participant, stroke, synthetic, source, licence,
                              origin_path, content_sha256, metadata_json, force_rate_hz, position_rate_hz,
                              duration_s)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14)",
        params![
            material_id,
            import.0,
            match row.kind {
                StrokeKind::Recording => "recording",
                StrokeKind::Profile => "profile",
            },
            row.participant,
            row.stroke,
            row.synthetic,
            row.source,
            row.licence,
            row.origin_path,
            row.sha256,
            row.metadata_json,
            row.force_rate_hz,
            row.position_rate_hz,
            row.duration_s,
        ],
    )?;
    let stroke_id = tx.last_insert_rowid();
    let mean_mu = profile.mu().iter().sum::<f64>() / profile.len() as f64;
    tx.execute(
        "INSERT INTO profiles (stroke_id, config_json, n_points, x_mm, mu, fn_n, mean_mu, mean_fn_n, span_mm,
                               sliding_s, bridged_mm, n_segments, segments_json)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13)",
        params![
            stroke_id,
            row.config_json,
            profile.len() as i64,
            encode(profile.x_mm()),
            encode(profile.mu()),
            profile.fn_n().map(encode),
            mean_mu,
            profile.mean_fn_n(),
            profile.span_mm(),
            row.sliding_s,
            row.bridged_mm,
            row.n_segments,
            row.segments_json,
        ],
    )?;
    Ok(Added::New(stroke_id))
}

/// The stroke row of a processed recording.
fn recording_row<'a>(
    recording: &'a Recording,
    processed: &ProcessedStroke,
    config: &ProcessingConfig,
    sha: &'a str,
) -> StrokeRow<'a> {
    let meta = &recording.meta;
    let used: Vec<_> = processed.segments.iter().zip(&processed.used).filter(|(_, u)| **u).map(|(s, _)| s).collect();
    StrokeRow {
        material: &meta.material,
        description: &meta.material_description,
        kind: StrokeKind::Recording,
        participant: Some(&meta.participant),
        stroke: Some(i64::from(meta.stroke)),
        synthetic: meta.synthetic,
        source: &meta.source,
        licence: &meta.licence,
        origin_path: &recording.name,
        sha256: sha,
        metadata_json: serde_json::to_string(meta).expect("metadata serializes"),
        force_rate_hz: Some(recording.force.rate_hz),
        position_rate_hz: Some(recording.position.rate_hz),
        duration_s: Some(recording.duration_s()),
        config_json: Some(serde_json::to_string(config).expect("config serializes")),
        sliding_s: Some(processed.sliding_s),
        bridged_mm: Some(processed.bridged_mm),
        segments_json: Some(serde_json::to_string(&used).expect("segments serialize")),
        n_segments: Some(used.len() as i64),
    }
}

struct StrokeRow<'a> {
    material: &'a str,
    description: &'a str,
    kind: StrokeKind,
    participant: Option<&'a str>,
    stroke: Option<i64>,
    synthetic: bool,
    source: &'a str,
    licence: &'a str,
    origin_path: &'a str,
    sha256: &'a str,
    metadata_json: String,
    force_rate_hz: Option<f64>,
    position_rate_hz: Option<f64>,
    duration_s: Option<f64>,
    config_json: Option<String>,
    sliding_s: Option<f64>,
    bridged_mm: Option<f64>,
    segments_json: Option<String>,
    n_segments: Option<i64>,
}

const STROKE_SELECT: &str = "SELECT s.id, m.name, s.kind, s.participant, s.stroke, s.synthetic, s.source, s.licence,
        s.origin_path, s.content_sha256, s.imported_at, s.import_id, s.metadata_json, p.config_json,
        s.force_rate_hz, s.position_rate_hz, s.duration_s, p.n_points, p.span_mm, p.mean_mu, p.mean_fn_n,
        p.sliding_s, p.bridged_mm, p.n_segments
    FROM strokes s JOIN materials m ON m.id = s.material_id JOIN profiles p ON p.stroke_id = s.id";

fn stroke_info(r: &rusqlite::Row<'_>) -> rusqlite::Result<StrokeInfo> {
    Ok(StrokeInfo {
        id: r.get(0)?,
        material: r.get(1)?,
        kind: if r.get::<_, String>(2)? == "recording" { StrokeKind::Recording } else { StrokeKind::Profile },
        participant: r.get(3)?,
        stroke: r.get(4)?,
        synthetic: r.get(5)?,
        source: r.get(6)?,
        licence: r.get(7)?,
        origin_path: r.get(8)?,
        content_sha256: r.get(9)?,
        imported_at: r.get(10)?,
        import_id: r.get(11)?,
        metadata_json: r.get(12)?,
        config_json: r.get(13)?,
        force_rate_hz: r.get(14)?,
        position_rate_hz: r.get(15)?,
        duration_s: r.get(16)?,
        n_points: r.get(17)?,
        span_mm: r.get(18)?,
        mean_mu: r.get(19)?,
        mean_fn_n: r.get(20)?,
        sliding_s: r.get(21)?,
        bridged_mm: r.get(22)?,
        n_segments: r.get(23)?,
    })
}

/// The file a library export writes stroke `stroke_id` of `material` to,
/// relative to the export's directory: `MATERIAL/stroke-ID.csv`, the
/// material's name with anything but letters, digits, `-`, `_` and `.`
/// replaced by `_`. A name read from a library file is checked here by
/// the name rule ([`crate::name`]) an import applies: one that breaks it
/// (a foreign or edited file) is an error, never a path.
pub fn export_file(material: &str, stroke_id: i64) -> Result<String, NameError> {
    check_name(material)?;
    let dir: String =
        material.chars().map(|c| if c.is_alphanumeric() || "-_.".contains(c) { c } else { '_' }).collect();
    Ok(format!("{dir}/stroke-{stroke_id}.csv"))
}

/// A profile from its stored blobs, validated as any profile is.
fn read_back(x: &[u8], mu: &[u8], fn_n: Option<&[u8]>) -> Result<FrictionProfile, crate::profile::ProfileError> {
    let profile = FrictionProfile::new(decode(x), decode(mu))?;
    match fn_n {
        Some(f) => profile.with_normal_force(decode(f)),
        None => Ok(profile),
    }
}

fn encode(values: &[f64]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn decode(bytes: &[u8]) -> Vec<f64> {
    bytes.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes"))).collect()
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Content hash of an in-memory recording (metadata and stream values).
fn recording_hash(recording: &Recording) -> String {
    let mut hash = Sha256::new();
    hash.update(b"haptex-recording-memory\0");
    hash.update(serde_json::to_vec(&recording.meta).expect("metadata serializes"));
    let f = &recording.force;
    let p = &recording.position;
    for column in [&f.t_s, &f.fn_n, &f.ft_n, &p.t_s, &p.x_mm] {
        hash.update(encode(column));
    }
    hex(&hash.finalize())
}

/// A seed from the operating system's randomness (std's hasher keys).
fn random_seed() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    let mut hasher = std::collections::hash_map::RandomState::new().build_hasher();
    hasher.write_u128(std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos()));
    hasher.finish()
}
