//! The library's SQLite schema and its migrations.
//!
//! `PRAGMA user_version` holds the number of migrations applied;
//! `PRAGMA application_id` marks the file as a haptex library. Each
//! migration runs in its own transaction together with the version bump,
//! so a database is always at one exact version.

use rusqlite::{Connection, TransactionBehavior};

/// `PRAGMA application_id` of haptex libraries: "HPTX".
pub const APPLICATION_ID: i64 = 0x4850_5458;

/// Migrations in order; the schema version is their count.
pub const MIGRATIONS: &[&str] = &[
    // 1: materials, import runs, strokes with provenance, processed profiles.
    r#"
    CREATE TABLE materials (
        id          INTEGER PRIMARY KEY,
        name        TEXT NOT NULL UNIQUE COLLATE NOCASE,
        description TEXT NOT NULL DEFAULT '',
        synthetic   INTEGER NOT NULL CHECK (synthetic IN (0, 1)),
        created_at  TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
    );
    CREATE TABLE imports (
        id             INTEGER PRIMARY KEY,
        started_at     TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
        finished_at    TEXT,
        haptex_version TEXT NOT NULL,
        command        TEXT NOT NULL,
        config_json    TEXT NOT NULL
    );
    CREATE TABLE strokes (
        id               INTEGER PRIMARY KEY,
        material_id      INTEGER NOT NULL REFERENCES materials(id),
        import_id        INTEGER NOT NULL REFERENCES imports(id),
        kind             TEXT NOT NULL CHECK (kind IN ('recording', 'profile')),
        participant      TEXT,
        stroke           INTEGER,
        synthetic        INTEGER NOT NULL CHECK (synthetic IN (0, 1)),
        source           TEXT NOT NULL,
        licence          TEXT NOT NULL,
        origin_path      TEXT NOT NULL,
        content_sha256   TEXT NOT NULL UNIQUE,
        metadata_json    TEXT NOT NULL,
        force_rate_hz    REAL,
        position_rate_hz REAL,
        duration_s       REAL,
        imported_at      TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
    );
    CREATE INDEX strokes_by_material ON strokes(material_id);
    CREATE TABLE profiles (
        stroke_id     INTEGER PRIMARY KEY REFERENCES strokes(id) ON DELETE CASCADE,
        config_json   TEXT,
        n_points      INTEGER NOT NULL CHECK (n_points >= 2),
        x_mm          BLOB NOT NULL CHECK (length(x_mm) = 8 * n_points),
        mu            BLOB NOT NULL CHECK (length(mu) = 8 * n_points),
        fn_n          BLOB CHECK (fn_n IS NULL OR length(fn_n) = 8 * n_points),
        mean_mu       REAL NOT NULL,
        mean_fn_n     REAL,
        span_mm       REAL NOT NULL,
        sliding_s     REAL,
        bridged_mm    REAL,
        n_segments    INTEGER,
        segments_json TEXT
    );
    "#,
];

/// The schema version this haptex writes and reads.
pub const SCHEMA_VERSION: i64 = MIGRATIONS.len() as i64;

pub fn user_version(conn: &Connection) -> rusqlite::Result<i64> {
    conn.pragma_query_value(None, "user_version", |r| r.get(0))
}

pub fn application_id(conn: &Connection) -> rusqlite::Result<i64> {
    conn.pragma_query_value(None, "application_id", |r| r.get(0))
}

/// Number of tables in the database (0 for a new, empty file).
pub fn table_count(conn: &Connection) -> rusqlite::Result<i64> {
    conn.query_row("SELECT count(*) FROM sqlite_schema WHERE type = 'table'", [], |r| r.get(0))
}

/// Applies the migrations after the database's current version, each in
/// an immediate transaction with its version bump.
pub fn migrate(conn: &mut Connection) -> rusqlite::Result<()> {
    loop {
        let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
        let version = user_version(&tx)?;
        let Some(sql) = MIGRATIONS.get(version as usize) else {
            return Ok(());
        };
        tx.execute_batch(sql)?;
        tx.pragma_update(None, "user_version", version + 1)?;
        tx.pragma_update(None, "application_id", APPLICATION_ID)?;
        tx.commit()?;
    }
}
