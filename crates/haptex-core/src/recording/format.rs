//! The raw recording format: one finger stroke on one material.
//!
//! A recording is a metadata file `NAME.recording.json` that names two
//! streams, each sampled at its own rate on one shared clock:
//!
//! - the force stream, columns `t_s,fn_n,ft_n`: time in s, normal force in N
//!   (pressing on the surface: positive), tangential force in N along +x (the
//!   force the finger exerts on the surface: positive while the finger slides
//!   towards +x);
//! - the position stream, columns `t_s,x_mm`: finger position along the
//!   stroke in mm.
//!
//! Each stream is a CSV file (read with [`Table`]: header with those names,
//! `#` comments) or an NPY file (2-D float32 or float64 array, one row per
//! sample, the columns in that order) for large data. The metadata carries
//! the material, participant, stroke number, the nominal rates, the units
//! (which must be s, N and mm), the source and licence, and whether the data
//! are synthetic. `docs/recordings.md` documents the format with examples.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::error::{Place, RecordingError};
use crate::io::{OutputDir, Table, WriteError, write_atomic, write_csv_row};
use crate::num::{Fixed, Num};
use crate::text::Quoted;

/// Value of the metadata's `format` field.
pub const FORMAT: &str = "haptex-recording-1";
/// File name suffix of recording metadata files.
pub const METADATA_SUFFIX: &str = ".recording.json";

/// Relative tolerance between a stream's declared rate and its median
/// sample interval.
const RATE_TOLERANCE: f64 = 0.01;
/// Largest and smallest force-stream interval, in nominal intervals: the
/// anti-alias filter needs uniform sampling.
const FORCE_INTERVAL_RANGE: (f64, f64) = (0.5, 1.5);

/// The metadata of one recorded stroke (`NAME.recording.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordingMeta {
    /// Always [`FORMAT`].
    pub format: String,
    /// Material name, e.g. `velvet`; strokes of one material share it.
    pub material: String,
    /// Free text describing the material sample.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub material_description: String,
    /// Participant identifier (anonymous code), e.g. `P3`.
    pub participant: String,
    /// Stroke (trial) number of this participant on this material.
    pub stroke: u32,
    pub force: StreamMeta,
    pub position: StreamMeta,
    pub units: Units,
    /// Where the data come from (study, citation, instrument or generator).
    pub source: String,
    /// Licence of the data, e.g. `CC-BY-4.0`.
    #[serde(alias = "license")]
    pub licence: String,
    /// True for generated (not measured) data.
    #[serde(default)]
    pub synthetic: bool,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub notes: String,
    /// Anything else worth keeping as provenance (kept verbatim in the library).
    #[serde(default, skip_serializing_if = "serde_json::Value::is_null")]
    pub extra: serde_json::Value,
}

/// One stream's file (relative to the metadata file) and nominal rate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StreamMeta {
    pub file: String,
    pub rate_hz: f64,
}

/// The units of the streams. haptex accepts exactly s, N and mm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Units {
    pub time: String,
    pub force: String,
    pub position: String,
}

impl Default for Units {
    fn default() -> Self {
        Self { time: "s".into(), force: "N".into(), position: "mm".into() }
    }
}

/// Forces sampled uniformly at `rate_hz`.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceStream {
    pub t_s: Vec<f64>,
    pub fn_n: Vec<f64>,
    pub ft_n: Vec<f64>,
    pub rate_hz: f64,
}

/// Finger positions sampled at `rate_hz` (occasional gaps allowed).
#[derive(Debug, Clone, PartialEq)]
pub struct PositionStream {
    pub t_s: Vec<f64>,
    pub x_mm: Vec<f64>,
    pub rate_hz: f64,
}

/// A validated recording: metadata and both streams.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// Label for messages: the metadata path, or a name for in-memory data.
    pub name: String,
    pub meta: RecordingMeta,
    pub force: ForceStream,
    pub position: PositionStream,
    /// SHA-256 (hex) of the metadata and stream files as read, when loaded
    /// from files: the library's duplicate check and provenance.
    pub sha256: Option<String>,
}

/// File format of a stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StreamFormat {
    Csv,
    Npy,
}

impl StreamFormat {
    fn extension(self) -> &'static str {
        match self {
            StreamFormat::Csv => "csv",
            StreamFormat::Npy => "npy",
        }
    }
}

/// Column names of the two streams, in file order.
pub const FORCE_COLUMNS: [&str; 3] = ["t_s", "fn_n", "ft_n"];
pub const POSITION_COLUMNS: [&str; 2] = ["t_s", "x_mm"];

impl Recording {
    /// Reads and validates a recording from its metadata file.
    pub fn load(metadata_path: &Path) -> Result<Self, RecordingError> {
        let name = metadata_path.display().to_string();
        let meta_bytes = read_bytes(metadata_path, MAX_METADATA_BYTES)?;
        let meta = parse_meta(&name, &meta_bytes)?;
        let dir = metadata_path.parent().unwrap_or(Path::new(""));
        let force_path = stream_path(&name, dir, "force.file", &meta.force.file)?;
        let position_path = stream_path(&name, dir, "position.file", &meta.position.file)?;
        let force_bytes = read_bytes(&force_path, MAX_STREAM_BYTES)?;
        let position_bytes = read_bytes(&position_path, MAX_STREAM_BYTES)?;
        Self::parse(
            &name,
            &meta_bytes,
            (&force_path.display().to_string(), &force_bytes),
            (&position_path.display().to_string(), &position_bytes),
        )
    }

    /// Parses and validates a recording from the bytes of its metadata and
    /// streams (what [`Recording::load`] does once the files are read; the
    /// stream names' extensions, `.csv` or `.npy`, give their format).
    pub fn parse(
        name: &str,
        meta_bytes: &[u8],
        (force_name, force_bytes): (&str, &[u8]),
        (position_name, position_bytes): (&str, &[u8]),
    ) -> Result<Self, RecordingError> {
        let meta = parse_meta(name, meta_bytes)?;
        let name = name.to_string();
        let mut hash = Sha256::new();
        for part in [&meta_bytes, &force_bytes, &position_bytes] {
            hash.update((part.len() as u64).to_le_bytes());
            hash.update(part);
        }
        let sha256 = hex(&hash.finalize());

        let force = read_stream(force_bytes, force_name, "force.file", &FORCE_COLUMNS)?;
        let position = read_stream(position_bytes, position_name, "position.file", &POSITION_COLUMNS)?;
        check_rate(&name, "force.rate_hz", force_name, &force.columns[0], meta.force.rate_hz)?;
        check_rate(&name, "position.rate_hz", position_name, &position.columns[0], meta.position.rate_hz)?;
        check_force_uniform(force_name, &force.columns[0], meta.force.rate_hz, &|row| force.place(row))?;
        check_spans((force_name, &force.columns[0]), (position_name, &position.columns[0]), meta.position.rate_hz)?;

        let [t_s, fn_n, ft_n]: [Vec<f64>; 3] = force.columns.try_into().expect("three force columns");
        let [tp_s, x_mm]: [Vec<f64>; 2] = position.columns.try_into().expect("two position columns");
        Ok(Self {
            name,
            force: ForceStream { t_s, fn_n, ft_n, rate_hz: meta.force.rate_hz },
            position: PositionStream { t_s: tp_s, x_mm, rate_hz: meta.position.rate_hz },
            meta,
            sha256: Some(sha256),
        })
    }

    /// A recording from in-memory streams, validated as if read from files
    /// (`name` labels errors; rows are reported as NPY rows).
    pub fn from_parts(
        name: &str,
        meta: RecordingMeta,
        force: ForceStream,
        position: PositionStream,
    ) -> Result<Self, RecordingError> {
        check_meta(name, &meta)?;
        let force_name = format!("{name} (force)");
        let position_name = format!("{name} (position)");
        let force_columns = [&force.t_s, &force.fn_n, &force.ft_n];
        check_columns(&force_name, &FORCE_COLUMNS, &force_columns.map(|c| c.as_slice()), &|row| Place::Row(row))?;
        check_columns(&position_name, &POSITION_COLUMNS, &[&position.t_s, &position.x_mm], &|row| Place::Row(row))?;
        check_rate(name, "force.rate_hz", &force_name, &force.t_s, meta.force.rate_hz)?;
        check_rate(name, "position.rate_hz", &position_name, &position.t_s, meta.position.rate_hz)?;
        check_force_uniform(&force_name, &force.t_s, meta.force.rate_hz, &|row| Place::Row(row))?;
        check_spans((&force_name, &force.t_s), (&position_name, &position.t_s), meta.position.rate_hz)?;
        let force = ForceStream { rate_hz: meta.force.rate_hz, ..force };
        let position = PositionStream { rate_hz: meta.position.rate_hz, ..position };
        Ok(Self { name: name.to_string(), meta, force, position, sha256: None })
    }

    /// Duration covered by the force stream, in s.
    pub fn duration_s(&self) -> f64 {
        self.force.t_s[self.force.t_s.len() - 1] - self.force.t_s[0]
    }

    /// Writes the recording as `dir/STEM.recording.json` with its two streams
    /// `STEM.force.EXT` and `STEM.position.EXT` (NPY: float32). Each file is
    /// written atomically, and the metadata, which names the streams, is
    /// removed first and written last: an interrupted write leaves no
    /// metadata (so no recording an import would find), never one beside
    /// streams of another write. `dir` is created if missing; the stem must
    /// be a name ([`crate::name::check_name`]) and every file must resolve
    /// inside `dir` ([`OutputDir`]). Returns the metadata path.
    pub fn write(&self, dir: &Path, stem: &str, format: StreamFormat) -> Result<PathBuf, WriteError> {
        let out = OutputDir::create(dir)?;
        crate::name::check_name(stem).map_err(|e| WriteError::refused(dir, format!("a recording's stem {e}")))?;
        let meta_path = out.member(&format!("{stem}{METADATA_SUFFIX}"))?;
        match std::fs::remove_file(&meta_path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(WriteError { path: meta_path, cause: e });
            }
            _ => {}
        }
        let ext = format.extension();
        let force_file = format!("{stem}.force.{ext}");
        let position_file = format!("{stem}.position.{ext}");
        let (force_path, position_path) = (out.member(&force_file)?, out.member(&position_file)?);
        let f = &self.force;
        let p = &self.position;
        match format {
            StreamFormat::Csv => {
                write_csv_stream(&force_path, &FORCE_COLUMNS, &[&f.t_s, &f.fn_n, &f.ft_n])?;
                write_csv_stream(&position_path, &POSITION_COLUMNS, &[&p.t_s, &p.x_mm])?;
            }
            StreamFormat::Npy => {
                write_npy_f32(&force_path, &[&f.t_s, &f.fn_n, &f.ft_n])?;
                write_npy_f32(&position_path, &[&p.t_s, &p.x_mm])?;
            }
        }
        let mut meta = self.meta.clone();
        meta.force.file = force_file;
        meta.position.file = position_file;
        crate::io::fault_point("before-recording-metadata");
        out.write(&format!("{stem}{METADATA_SUFFIX}"), |w| {
            serde_json::to_writer_pretty(&mut *w, &meta).map_err(std::io::Error::from)?;
            w.write_all(b"\n")
        })
    }
}

/// Writes a 2-D float32 NPY array (rows = samples, one column per slice),
/// atomically.
pub fn write_npy_f32(path: &Path, columns: &[&[f64]]) -> Result<(), WriteError> {
    use npyz::WriterBuilder;
    let rows = columns.first().map_or(0, |c| c.len());
    write_atomic(path, |w| {
        let mut writer = npyz::WriteOptions::<f32>::new()
            .default_dtype()
            .shape(&[rows as u64, columns.len() as u64])
            .writer(w)
            .begin_nd()?;
        for row in 0..rows {
            for column in columns {
                writer.push(&(column[row] as f32))?;
            }
        }
        writer.finish()
    })
}

fn write_csv_stream(path: &Path, names: &[&str], columns: &[&[f64]]) -> Result<(), WriteError> {
    write_atomic(path, |w| {
        writeln!(w, "{}", names.join(","))?;
        let mut row = vec![0.0; columns.len()];
        for i in 0..columns[0].len() {
            for (value, column) in row.iter_mut().zip(columns) {
                *value = column[i];
            }
            write_csv_row(w, &row)?;
        }
        Ok(())
    })
}

/// Largest metadata file read, in bytes (1 MiB; real ones are ~1 kB).
pub const MAX_METADATA_BYTES: u64 = 1 << 20;
/// Largest stream file read, in bytes (1 GiB: a CSV of 10 minutes of
/// forces at 20 kHz is ~0.5 GB).
pub const MAX_STREAM_BYTES: u64 = 1 << 30;

/// The path of a stream named in the metadata (`field`), checked before
/// anything is read from it: a plain relative path to a regular file inside
/// the recording's directory (symbolic links resolved), so that metadata
/// cannot make haptex read `/dev/zero`, a FIFO, or a file elsewhere.
fn stream_path(file: &str, dir: &Path, field: &str, relative: &str) -> Result<PathBuf, RecordingError> {
    let named = Path::new(relative);
    if let Err(e) = crate::name::check_relative_path(relative) {
        return Err(RecordingError::field(
            file,
            field,
            format!(
                "{} is not a file name inside the recording's directory (no absolute paths, no '..'): streams \
                 sit beside their metadata ({})",
                Quoted(relative),
                e.problem
            ),
        ));
    }
    let path = dir.join(named);
    let resolved = std::fs::canonicalize(&path)
        .map_err(|e| RecordingError::Io { file: path.display().to_string(), message: e.to_string() })?;
    let home = std::fs::canonicalize(if dir.as_os_str().is_empty() { Path::new(".") } else { dir })
        .map_err(|e| RecordingError::field(file, field, format!("{}: {e}", dir.display())))?;
    if !resolved.starts_with(&home) {
        return Err(RecordingError::field(
            file,
            field,
            format!("{} leads outside the recording's directory (to {})", path.display(), resolved.display()),
        ));
    }
    Ok(path)
}

/// Reads a file of at most `limit` bytes, refusing anything but a regular
/// file, and a larger file, before reading it.
fn read_bytes(path: &Path, limit: u64) -> Result<Vec<u8>, RecordingError> {
    crate::io::read_file_bounded(path, limit)
        .map_err(|e| RecordingError::Io { file: path.display().to_string(), message: e.to_string() })
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Parses and checks a metadata file's bytes. A value of the wrong type
/// is reported at its field (`force.rate_hz`); a missing or unknown field,
/// or malformed JSON, with serde's message (which names the field, or the
/// line and column).
pub(crate) fn parse_meta(name: &str, bytes: &[u8]) -> Result<RecordingMeta, RecordingError> {
    let mut deserializer = serde_json::Deserializer::from_slice(bytes);
    let meta: RecordingMeta = serde_path_to_error::deserialize(&mut deserializer).map_err(|e| {
        let path = e.path().to_string();
        let message = format!("invalid metadata: {}", e.inner());
        if path == "." || path == "?" {
            RecordingError::Metadata { file: name.to_string(), message }
        } else {
            RecordingError::field(name, &path, message)
        }
    })?;
    deserializer
        .end()
        .map_err(|e| RecordingError::Metadata { file: name.to_string(), message: format!("invalid metadata: {e}") })?;
    check_meta(name, &meta)?;
    Ok(meta)
}

/// Checks the metadata fields that the JSON types cannot.
fn check_meta(file: &str, meta: &RecordingMeta) -> Result<(), RecordingError> {
    if meta.format != FORMAT {
        return Err(RecordingError::field(
            file,
            "format",
            format!("is {}; this haptex reads {FORMAT:?}", Quoted(&meta.format)),
        ));
    }
    // A material names the directory a library export writes its strokes
    // into: one rule for every such name (docs/recordings.md).
    crate::name::check_name(&meta.material).map_err(|e| RecordingError::field(file, "material", e.to_string()))?;
    if meta.participant.trim().is_empty() {
        return Err(RecordingError::field(file, "participant", "must not be empty"));
    }
    for (field, rate) in [("force.rate_hz", meta.force.rate_hz), ("position.rate_hz", meta.position.rate_hz)] {
        if !(rate.is_finite() && rate > 0.0) {
            return Err(RecordingError::field(
                file,
                field,
                format!("must be a positive rate in Hz, got {}", Num(rate)),
            ));
        }
    }
    if meta.force.rate_hz < 2.0 * meta.position.rate_hz {
        return Err(RecordingError::field(
            file,
            "force.rate_hz",
            format!(
                "{} Hz: the force stream must be sampled at least twice as fast as the position stream ({} Hz), \
                 which is the rate the pipeline resamples it to",
                meta.force.rate_hz, meta.position.rate_hz
            ),
        ));
    }
    let units = [
        ("units.time", &meta.units.time, "s", "seconds"),
        ("units.force", &meta.units.force, "N", "newtons"),
        ("units.position", &meta.units.position, "mm", "millimetres"),
    ];
    for (field, unit, expected, word) in units {
        if unit != expected {
            return Err(RecordingError::field(
                file,
                field,
                format!(
                    "is {}; haptex recordings are in {word} ({expected:?}): convert the data when exporting them \
                     (docs/recordings.md)",
                    Quoted(unit)
                ),
            ));
        }
    }
    Ok(())
}

/// A parsed stream: columns in the order asked for, and the CSV line of
/// each row (NPY: none, rows are reported by index).
struct StreamColumns {
    columns: Vec<Vec<f64>>,
    lines: Option<Vec<u64>>,
}

impl StreamColumns {
    fn place(&self, row: usize) -> Place {
        match &self.lines {
            Some(lines) => Place::Line(lines[row]),
            None => Place::Row(row),
        }
    }
}

/// Reads a CSV or NPY stream and checks its values (finite, time
/// increasing). `field` names the metadata field for errors about the file
/// as a whole.
fn read_stream(bytes: &[u8], file: &str, field: &str, names: &[&str]) -> Result<StreamColumns, RecordingError> {
    let lower = file.to_ascii_lowercase();
    if lower.ends_with(".csv") {
        let table = Table::read(bytes, file)?;
        let mut columns = Vec::with_capacity(names.len());
        for name in names {
            match table.column(name) {
                Some(values) => columns.push(values.to_vec()),
                None => return Err(missing_column(&table, name)),
            }
        }
        let place = |row: usize| Place::Line(table.line_of_row(row));
        let refs: Vec<&[f64]> = columns.iter().map(Vec::as_slice).collect();
        if table.n_rows() < 2 {
            return Err(table
                .error_at(None, None, format!("a stream needs at least 2 samples, found {}", table.n_rows()))
                .into());
        }
        check_columns(file, names, &refs, &place)?;
        let lines = Some((0..table.n_rows()).map(|row| table.line_of_row(row)).collect());
        Ok(StreamColumns { columns, lines })
    } else if lower.ends_with(".npy") {
        let columns = read_npy_columns(bytes, file, names)?;
        let refs: Vec<&[f64]> = columns.iter().map(Vec::as_slice).collect();
        check_columns(file, names, &refs, &|row| Place::Row(row))?;
        Ok(StreamColumns { columns, lines: None })
    } else {
        Err(RecordingError::invalid(
            file,
            Place::File,
            None,
            format!("unknown stream format (field '{field}'): use .csv or .npy"),
        ))
    }
}

/// The error for a missing CSV column: "wrong unit" when a column of the same
/// quantity with another unit is there (`t_ms` for `t_s`), else "missing".
fn missing_column(table: &Table, name: &str) -> RecordingError {
    let stem = |c: &str| c.rsplit_once('_').map_or(c, |(s, _)| s).to_ascii_lowercase();
    let wanted = stem(name);
    if let Some(other) = table.columns().iter().find(|c| stem(c) == wanted || c.eq_ignore_ascii_case(&wanted)) {
        let unit = match name.rsplit_once('_').map(|(_, u)| u) {
            Some("s") => "seconds",
            Some("n") => "newtons",
            Some("mm") => "millimetres",
            _ => "the haptex unit",
        };
        return table
            .error_at(
                None,
                Some(other),
                format!("wrong unit in the header: haptex recordings need column '{name}' ({unit}); convert the data"),
            )
            .into();
    }
    table.missing(name).into()
}

/// Reads a 2-D float NPY array with `names.len()` columns (C or Fortran order).
fn read_npy_columns(bytes: &[u8], file: &str, names: &[&str]) -> Result<Vec<Vec<f64>>, RecordingError> {
    let npy_error = |message: String| RecordingError::invalid(file, Place::File, None, message);
    let k = names.len();
    let (rows, cols, flat) = crate::io::npy::read_2d(bytes, |shape| {
        (shape.len() == 2 && shape[1] == k as u64)
            .then_some(())
            .ok_or_else(|| format!("array shape {shape:?}: expected (samples, {k}) with columns {}", names.join(", ")))
    })
    .map_err(npy_error)?;
    debug_assert_eq!(cols, k);
    Ok((0..k).map(|c| (0..rows).map(|r| flat[r * k + c]).collect()).collect())
}

/// Every value finite, at least two rows, time strictly increasing.
fn check_columns(
    file: &str,
    names: &[&str],
    columns: &[&[f64]],
    place: &dyn Fn(usize) -> Place,
) -> Result<(), RecordingError> {
    let rows = columns[0].len();
    for (name, column) in names.iter().zip(columns) {
        if column.len() != rows {
            return Err(RecordingError::invalid(
                file,
                Place::File,
                Some(name),
                format!("{} values, but column '{}' has {rows}: mismatched lengths", column.len(), names[0]),
            ));
        }
        if let Some(i) = column.iter().position(|v| !v.is_finite()) {
            return Err(RecordingError::invalid(
                file,
                place(i),
                Some(name),
                format!("not a finite number: {}", Num(column[i])),
            ));
        }
    }
    if rows < 2 {
        return Err(RecordingError::invalid(
            file,
            Place::File,
            None,
            format!("a stream needs at least 2 samples, found {rows}"),
        ));
    }
    let t = columns[0];
    if let Some(i) = t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(RecordingError::invalid(file, place(i + 1), Some("t_s"), {
            let (next, previous) = crate::num::distinct(t[i + 1], t[i]);
            format!("time must increase strictly: {next} s follows {previous} s")
        }));
    }
    Ok(())
}

/// The force stream must be uniformly sampled: every interval within
/// [0.5, 1.5] nominal intervals.
fn check_force_uniform(
    file: &str,
    t: &[f64],
    rate_hz: f64,
    place: &dyn Fn(usize) -> Place,
) -> Result<(), RecordingError> {
    let nominal = 1.0 / rate_hz;
    let (lo, hi) = (FORCE_INTERVAL_RANGE.0 * nominal, FORCE_INTERVAL_RANGE.1 * nominal);
    if let Some(i) = t.windows(2).position(|w| !(lo..=hi).contains(&(w[1] - w[0]))) {
        return Err(RecordingError::invalid(
            file,
            place(i + 1),
            Some("t_s"),
            format!(
                "sample interval {:.4e} s is not the nominal 1/{rate_hz} Hz = {nominal:.4e} s: the force stream must be \
                 uniformly sampled (no gaps or repeated blocks)",
                t[i + 1] - t[i]
            ),
        ));
    }
    Ok(())
}

/// The declared rate must match the median sample interval within 1%.
fn check_rate(meta_file: &str, field: &str, stream_file: &str, t: &[f64], rate_hz: f64) -> Result<(), RecordingError> {
    let mut dt: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mid = dt.len() / 2;
    let median = *dt.select_nth_unstable_by(mid, f64::total_cmp).1;
    if ((median * rate_hz) - 1.0).abs() > RATE_TOLERANCE {
        return Err(RecordingError::field(
            meta_file,
            field,
            format!(
                "declares {} Hz, but the median sample interval of {stream_file} is {} s ({} Hz)",
                Num(rate_hz),
                Num(median),
                Fixed(1.0 / median, 6)
            ),
        ));
    }
    Ok(())
}

/// Both streams must cover the same time span, within two position samples
/// or 1% of the duration, whichever is larger.
fn check_spans(force: (&str, &[f64]), position: (&str, &[f64]), position_rate_hz: f64) -> Result<(), RecordingError> {
    let span = |t: &[f64]| (t[0], t[t.len() - 1]);
    let (f0, f1) = span(force.1);
    let (p0, p1) = span(position.1);
    let tolerance = (2.0 / position_rate_hz).max(0.01 * (f1 - f0).max(p1 - p0));
    if (f0 - p0).abs() > tolerance || (f1 - p1).abs() > tolerance {
        return Err(RecordingError::Mismatch {
            message: format!(
                "mismatched lengths: the force stream {} ({} samples, t = {f0} .. {f1} s) and the position stream {} \
                 ({} samples, t = {p0} .. {p1} s) must cover the same time on one clock (tolerance {tolerance:.4} s)",
                force.0,
                force.1.len(),
                position.0,
                position.1.len()
            ),
        });
    }
    Ok(())
}
