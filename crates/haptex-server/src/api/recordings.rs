//! `POST /api/recordings`: recordings uploaded into the texture library
//! (`haptex serve --library FILE --writable`; a read-only server answers
//! 403).
//!
//! The body is `multipart/form-data` (what a browser's form and
//! `curl -F` send) with
//!
//! - `provenance`: `measured` (real finger strokes) or `synthetic`
//!   (generated): required, and it must agree with every recording's
//!   metadata field `synthetic`;
//! - `files`, repeated: the recordings in the documented format
//!   (docs/recordings.md): each `NAME.recording.json` with the two stream
//!   files it names, as separate parts or packed in `.zip` archives (a
//!   zip's folders are kept: a metadata file names its streams relative to
//!   its own folder).
//!
//! The files are read as `haptex library import` reads them from a
//! directory (the same checks and error messages, the same content hash),
//! processed with the default pipeline configuration, and stored all or
//! none: one invalid recording refuses the whole upload, and a refused
//! upload leaves the library as it was (not even the import run is
//! recorded). Content already in the library is reported as a duplicate,
//! not stored twice.
//!
//! Bounds: the body is at most [`Limits::max_upload_bytes`] (64 MiB), and
//! so are the files it holds once unzipped, all together; at most
//! [`Limits::max_upload_files`] files, zip entries included. A zip's entry
//! count and declared sizes are checked before anything is unzipped, and
//! an entry that unzips to more than it declared is refused. Nothing is
//! written to disk but the library: files are held in memory by name, and
//! a name that breaks the name rule ([`haptex_core::name`]: absolute, `..`,
//! a backslash, a control or format character ...) is refused; a zip's
//! hidden entries (`.DS_Store`, `._x`) are skipped like `__MACOSX/`. A
//! recording's material must be a name by the same rule (it names a
//! directory of a library export). One upload is processed at a time.
//!
//! The answer is the processing report: per recording, the stroke stored
//! (or the one it duplicates), the sliding segments kept and the runs
//! dropped with the reason, and the raw forces reduced to at most
//! [`PLOT_BUCKETS`] min/max pairs for plotting; and the library's
//! materials after the upload.
//!
//! [`Limits::max_upload_bytes`]: crate::Limits::max_upload_bytes
//! [`Limits::max_upload_files`]: crate::Limits::max_upload_files

use std::io::{Cursor, Read};
use std::sync::Arc;

use axum::Json;
use axum::body::Body;
use axum::extract::State;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use haptex_core::library::{Added, LibraryError};
use haptex_core::recording::bundle::FileBundle;
use haptex_core::recording::{Place, ProcessedStroke, ProcessingConfig, Recording, RecordingError, process};
use serde_json::{Value, json};

use crate::error::{ApiError, quote};
use crate::extract::NoQuery;
use crate::state::{AppState, Limits};
use crate::work;

/// Most min/max pairs of the raw forces in the report (so at most twice
/// as many points per channel).
pub const PLOT_BUCKETS: usize = 1000;

/// The form field of the provenance.
const PROVENANCE: &str = "provenance";
/// The form field of the files.
const FILES: &str = "files";

pub async fn post(
    State(state): State<AppState>,
    headers: HeaderMap,
    _: NoQuery,
    body: Body,
) -> Result<Response, ApiError> {
    let pool = Arc::clone(state.library()?);
    if !pool.writable() {
        return Err(ApiError::new(
            StatusCode::FORBIDDEN,
            "this server's library is read-only: recordings can be uploaded only to a server started with write \
             access to its library (haptex serve --library FILE --writable)",
            Some("library"),
        ));
    }
    let boundary = boundary(&headers)?;
    let limits = state.limits().clone();
    // One upload at a time, from reading its body to its write: the
    // memory of at most one upload, and one writer.
    let permit = work::slot(pool.writer()).await?;
    let upload = read_form(body, boundary, &limits).await?;
    work::cpu(&state, upload.bytes, move || {
        let _permit = permit;
        import(upload, &pool, &limits)
    })
    .await
}

/// The multipart boundary; 415 for any other body.
fn boundary(headers: &HeaderMap) -> Result<String, ApiError> {
    let wanted = "send multipart/form-data with a field provenance (measured or synthetic) and the recordings' \
                  files in fields named files (several files, or a zip)";
    let Some(value) = headers.get(header::CONTENT_TYPE) else {
        return Err(ApiError::unsupported_media_type(format!("no Content-Type: {wanted}")));
    };
    let text = value.to_str().unwrap_or("");
    let essence = text.split(';').next().unwrap_or("").trim();
    if !essence.eq_ignore_ascii_case("multipart/form-data") {
        return Err(ApiError::unsupported_media_type(format!(
            "Content-Type {} is not accepted here: {wanted}",
            quote(if text.is_empty() { "(not text)" } else { text })
        )));
    }
    multer::parse_boundary(text).map_err(|e| ApiError::unsupported_media_type(format!("{e}: {wanted}")))
}

/// The form as sent.
struct Upload {
    provenance: Option<String>,
    files: Vec<(String, Vec<u8>)>,
    /// Bytes of the files.
    bytes: usize,
}

/// Reads the form: the body bounded by [`Limits::max_upload_bytes`], the
/// files by [`Limits::max_upload_files`].
async fn read_form(body: Body, boundary: String, limits: &Limits) -> Result<Upload, ApiError> {
    let max = limits.max_upload_bytes;
    let constraints =
        multer::Constraints::new().size_limit(multer::SizeLimit::new().whole_stream(max as u64).per_field(max as u64));
    let mut form = multer::Multipart::with_constraints(body.into_data_stream(), boundary, constraints);
    let form_error = |e: multer::Error| match e {
        multer::Error::StreamSizeExceeded { .. } | multer::Error::FieldSizeExceeded { .. } => ApiError::too_large(
            format!("the upload is larger than the limit of {max} bytes ({} MiB)", max >> 20),
            Some("body"),
        ),
        other => ApiError::bad_request(format!("malformed multipart/form-data body: {other}"), Some("body")),
    };
    let mut upload = Upload { provenance: None, files: Vec::new(), bytes: 0 };
    while let Some(field) = form.next_field().await.map_err(form_error)? {
        match field.name() {
            Some(PROVENANCE) => {
                if upload.provenance.is_some() {
                    return Err(ApiError::bad_request("given twice", Some(PROVENANCE)));
                }
                let text = field.text().await.map_err(form_error)?;
                upload.provenance = Some(text);
            }
            Some(FILES) => {
                let Some(name) = field.file_name().map(str::to_string) else {
                    return Err(ApiError::bad_request(
                        "a part named files needs a file name (Content-Disposition: form-data; name=\"files\"; \
                         filename=\"...\")",
                        Some(FILES),
                    ));
                };
                if upload.files.len() >= limits.max_upload_files {
                    return Err(ApiError::too_large(
                        format!("more than {} files in one upload", limits.max_upload_files),
                        Some(FILES),
                    ));
                }
                let bytes = field.bytes().await.map_err(form_error)?;
                upload.bytes += bytes.len();
                upload.files.push((name, bytes.to_vec()));
            }
            Some(other) => {
                return Err(ApiError::bad_request(
                    "unknown form field: the form has provenance and files",
                    Some(other),
                ));
            }
            None => return Err(ApiError::bad_request("a form part without a name", Some("body"))),
        }
    }
    if upload.provenance.is_none() && upload.files.is_empty() {
        return Err(ApiError::bad_request(
            "the form is empty: send the field provenance and the recordings' files (fields named files)",
            Some("body"),
        ));
    }
    Ok(upload)
}

/// Checks, processes and stores the upload; the processing report.
fn import(upload: Upload, pool: &crate::state::LibraryPool, limits: &Limits) -> Result<Response, ApiError> {
    let synthetic = match upload.provenance.as_deref().map(str::trim) {
        Some("measured") => false,
        Some("synthetic") => true,
        Some(other) => {
            return Err(ApiError::bad_request(
                format!("is {}: say measured (real finger strokes) or synthetic (generated data)", quote(other)),
                Some(PROVENANCE),
            ));
        }
        None => {
            return Err(ApiError::bad_request(
                "say where the recordings come from: provenance measured (real finger strokes) or synthetic \
                 (generated data); it is required and must agree with each recording's metadata",
                Some(PROVENANCE),
            ));
        }
    };
    if upload.files.is_empty() {
        return Err(ApiError::bad_request("no files: upload the recordings' files (or a zip of them)", Some(FILES)));
    }
    let mut bundle = FileBundle::new();
    let mut budget = Budget { bytes: limits.max_upload_bytes, files: limits.max_upload_files, limits };
    let mut skipped = Vec::new();
    for (name, bytes) in upload.files {
        if name.to_ascii_lowercase().ends_with(".zip") {
            unzip_into(&mut bundle, &name, &bytes, &mut budget, &mut skipped)?;
        } else {
            budget.take(&name, bytes.len())?;
            bundle.add(&name, bytes).map_err(recording_error)?;
        }
    }
    let found = bundle.recordings().map_err(recording_error)?;
    for recording in &found.recordings {
        if recording.meta.synthetic != synthetic {
            let word = |s: bool| if s { "synthetic" } else { "measured" };
            return Err(ApiError::bad_request(
                format!(
                    "{}: the metadata says \"synthetic\": {} ({} data), but the upload's provenance is {}: state the \
                     provenance the recordings have (a metadata file without \"synthetic\" is measured data)",
                    recording.name,
                    recording.meta.synthetic,
                    word(recording.meta.synthetic),
                    word(synthetic)
                ),
                Some(PROVENANCE),
            )
            .with_file(Some(recording.name.clone())));
        }
    }
    let config = ProcessingConfig::default();
    let processed: Vec<ProcessedStroke> =
        found.recordings.iter().map(|r| process(r, &config)).collect::<Result<_, _>>().map_err(recording_error)?;
    let pairs: Vec<(&Recording, &ProcessedStroke)> = found.recordings.iter().zip(&processed).collect();
    let names: Vec<&str> = found.recordings.iter().map(|r| r.name.as_str()).collect();
    let mut command = format!("haptex serve: POST /api/recordings ({} recordings: {})", names.len(), names.join(" "));
    if command.len() > 4096 {
        let mut end = 4090;
        while !command.is_char_boundary(end) {
            end -= 1;
        }
        command.truncate(end);
        command.push_str(" ...");
    }
    let (import, added, materials) = pool.write(|library| {
        let (import, added) =
            library.add_recordings_atomically(&command, &config, &pairs).map_err(library_write_error)?;
        let materials = library.materials().map_err(ApiError::library)?;
        Ok((import, added, materials))
    })?;
    let reports: Vec<Value> =
        pairs.iter().zip(&added).map(|((recording, processed), added)| report(recording, processed, *added)).collect();
    let new = added.iter().filter(|a| matches!(a, Added::New(_))).count();
    Ok(Json(json!({
        "library": pool.path().file_name().map(|n| n.to_string_lossy().into_owned()),
        "provenance": if synthetic { "synthetic" } else { "measured" },
        "import_id": import.0,
        "added": new,
        "duplicates": added.len() - new,
        "recordings": reports,
        "unused_files": found.unused,
        "skipped_files": skipped,
        "config": config,
        "materials": materials,
    }))
    .into_response())
}

/// What is left of an upload's bounds while its files are unpacked.
struct Budget<'a> {
    bytes: usize,
    files: usize,
    limits: &'a Limits,
}

impl Budget<'_> {
    fn take(&mut self, name: &str, bytes: usize) -> Result<(), ApiError> {
        if self.files == 0 {
            return Err(ApiError::too_large(
                format!("more than {} files in one upload, zip entries included", self.limits.max_upload_files),
                Some(FILES),
            )
            .with_file(Some(name.to_string())));
        }
        if bytes > self.bytes {
            return Err(self.too_large(name));
        }
        self.files -= 1;
        self.bytes -= bytes;
        Ok(())
    }

    fn too_large(&self, name: &str) -> ApiError {
        let max = self.limits.max_upload_bytes;
        ApiError::too_large(
            format!("the upload's files hold more than {max} bytes ({} MiB) unzipped", max >> 20),
            Some(FILES),
        )
        .with_file(Some(name.to_string()))
    }
}

/// Adds the files of a zip archive to the bundle, in memory. The entry
/// count and the declared sizes are checked against the budget before
/// anything is unzipped; an entry unzipping to other than its declared
/// size, an encrypted entry, a symbolic link or a compression other than
/// stored and deflate is refused. Entries under `__MACOSX/` (the resource
/// forks macOS's archiver adds) and hidden entries ([`is_hidden`]) are
/// skipped.
fn unzip_into(
    bundle: &mut FileBundle,
    zip_name: &str,
    bytes: &[u8],
    budget: &mut Budget,
    skipped: &mut Vec<String>,
) -> Result<(), ApiError> {
    let bad = |message: String| ApiError::bad_request(message, Some(FILES)).with_file(Some(zip_name.to_string()));
    // The end-of-central-directory record's entry count, before the
    // archive's directory is parsed (and allocated for).
    match declared_entries(bytes) {
        None => return Err(bad("not a zip archive (no end of central directory record)".into())),
        Some(0xFFFF) => {
            return Err(bad("a ZIP64 archive (65535 or more entries, or files over 4 GiB): not accepted".into()));
        }
        Some(n) if n as usize > budget.files => {
            return Err(ApiError::too_large(
                format!("{n} entries: more than the {} files one upload may hold", budget.limits.max_upload_files),
                Some(FILES),
            )
            .with_file(Some(zip_name.to_string())));
        }
        Some(_) => {}
    }
    let mut archive =
        zip::ZipArchive::new(Cursor::new(bytes)).map_err(|e| bad(format!("not a readable zip archive: {e}")))?;
    if archive.len() > budget.files {
        return Err(bad(format!("{} entries: more than the files one upload may hold", archive.len())));
    }
    let mut declared: u64 = 0;
    for i in 0..archive.len() {
        let entry = archive.by_index_raw(i).map_err(|e| bad(format!("entry {i}: {e}")))?;
        if !entry.is_dir() {
            declared = declared.saturating_add(entry.size());
        }
    }
    if declared > budget.bytes as u64 {
        return Err(budget.too_large(zip_name));
    }
    for i in 0..archive.len() {
        let mut entry = archive.by_index(i).map_err(|e| bad(format!("entry {i}: cannot unzip: {e}")))?;
        let name = entry.name().map_err(|e| bad(format!("entry {i}: unreadable name: {e}")))?.into_owned();
        if entry.is_dir() {
            continue;
        }
        if name.starts_with("__MACOSX/") || is_hidden(&name) {
            skipped.push(format!("{zip_name}: {name}"));
            continue;
        }
        if entry.encrypted() || entry.is_symlink() {
            return Err(bad(format!("entry {}: encrypted entries and symbolic links are not accepted", quote(&name))));
        }
        let size = entry.size();
        budget.take(&name, size as usize)?;
        let mut data = Vec::with_capacity(size as usize);
        (&mut entry)
            .take(size + 1)
            .read_to_end(&mut data)
            .map_err(|e| bad(format!("entry {}: cannot unzip: {e}", quote(&name))))?;
        if data.len() as u64 != size {
            return Err(bad(format!(
                "entry {}: unzips to {}{} bytes, but its header declares {size}",
                quote(&name),
                if data.len() as u64 > size { "more than " } else { "" },
                data.len()
            )));
        }
        bundle.add(&name, data).map_err(|e| recording_error(e).with_file(Some(format!("{zip_name}: {name}"))))?;
    }
    Ok(())
}

/// A hidden file (`.DS_Store`, `._x`, `.git/...`: a component beginning
/// with `.` other than `.` and `..`, which the name rule refuses as ways
/// out of a folder): what an archiver adds, skipped like `__MACOSX/`.
fn is_hidden(name: &str) -> bool {
    name.split('/').any(|part| part.starts_with('.') && part != "." && part != "..")
}

/// The entry count of a zip's end-of-central-directory record (the last
/// one within the last 64 KiB + 22 bytes), if there is one.
fn declared_entries(bytes: &[u8]) -> Option<u64> {
    const RECORD: usize = 22;
    if bytes.len() < RECORD {
        return None;
    }
    let lowest = bytes.len().saturating_sub(RECORD + 0xFFFF);
    (lowest..=bytes.len() - RECORD)
        .rev()
        .find(|&i| bytes[i..i + 4] == [0x50, 0x4b, 0x05, 0x06])
        .map(|i| u64::from(u16::from_le_bytes([bytes[i + 10], bytes[i + 11]])))
}

/// A recording error as the API's: 400 naming the file, and the metadata
/// field, the CSV line and column, or the NPY row.
fn recording_error(error: RecordingError) -> ApiError {
    let message = error.to_string();
    match error {
        RecordingError::Io { file, .. } => ApiError::bad_request(message, Some(FILES)).with_file(Some(file)),
        RecordingError::Metadata { file, message: text } => {
            // serde names a missing or unknown field in its message.
            let field = ["missing field `", "unknown field `"]
                .iter()
                .find_map(|p| text.split_once(p).and_then(|(_, rest)| rest.split('`').next()))
                .unwrap_or("metadata")
                .to_string();
            ApiError::bad_request(message, Some(&field)).with_file(Some(file))
        }
        RecordingError::Table(table) => {
            let field = table.column.clone().unwrap_or_else(|| FILES.to_string());
            ApiError::bad_request(message, Some(&field)).with_line(table.line).with_file(Some(table.source_name))
        }
        RecordingError::Invalid { at, .. } => {
            let (field, line) = match &at.place {
                Place::Field(field) => (field.clone(), None),
                Place::Line(line) => (at.column.clone().unwrap_or_else(|| FILES.to_string()), Some(*line)),
                Place::Row(_) | Place::File => (at.column.clone().unwrap_or_else(|| FILES.to_string()), None),
            };
            ApiError::bad_request(message, Some(&field)).with_line(line).with_column(at.column).with_file(Some(at.file))
        }
        RecordingError::Mismatch { .. } => ApiError::bad_request(message, Some(FILES)),
        RecordingError::NoSliding { file, .. } | RecordingError::Processing { file, .. } => {
            ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, message, Some(FILES)).with_file(Some(file))
        }
        RecordingError::Config { name, .. } => ApiError::internal(format!("processing parameter {name}: {message}")),
    }
}

/// A refused write: 409 for a material that would mix synthetic and
/// measured strokes, 400 for a bad material name; the library is
/// unchanged either way.
fn library_write_error(error: LibraryError) -> ApiError {
    match error {
        LibraryError::SyntheticMismatch { name, existing, new } => ApiError::new(
            StatusCode::CONFLICT,
            format!(
                "material {} in this library holds {existing} strokes, these are {new}: a material never mixes \
                 synthetic and measured data; name the material otherwise in the recordings' metadata (field \
                 material, e.g. {name}-{new}) or use another library. Nothing was stored.",
                quote(&name)
            ),
            Some("material"),
        ),
        LibraryError::InvalidName(e) => {
            ApiError::bad_request(format!("material {e}. Nothing was stored."), Some("material"))
        }
        other => ApiError::library(other),
    }
}

/// One recording's processing report.
fn report(recording: &Recording, processed: &ProcessedStroke, added: Added) -> Value {
    let meta = &recording.meta;
    let (stroke_id, duplicate) = match added {
        Added::New(id) => (id, false),
        Added::Duplicate(id) => (id, true),
    };
    let segments: Vec<Value> = processed
        .segments
        .iter()
        .zip(&processed.used)
        .map(|(s, used)| {
            json!({
                "direction": s.direction,
                "t_start_s": s.t_start_s,
                "t_end_s": s.t_end_s,
                "x_start_mm": s.x_start_mm,
                "x_end_mm": s.x_end_mm,
                "mean_speed_mm_s": s.mean_speed_mm_s,
                "mean_fn_n": s.mean_fn_n,
                "used": used,
            })
        })
        .collect();
    let mut dropped: Vec<Value> = processed.dropped.iter().map(|d| json!(d)).collect();
    dropped.extend(processed.segments.iter().zip(&processed.used).filter(|(_, used)| !**used).map(|(s, _)| {
        json!({
            "direction": s.direction,
            "t_start_s": s.t_start_s,
            "t_end_s": s.t_end_s,
            "x_start_mm": s.x_start_mm,
            "x_end_mm": s.x_end_mm,
            "reason": "not in the direction selected for the profile",
        })
    }));
    let f = &recording.force;
    let (t_s, [fn_n, ft_n]) = envelope(&f.t_s, [&f.fn_n, &f.ft_n], PLOT_BUCKETS);
    let p = &processed.profile;
    json!({
        "file": recording.name,
        "material": meta.material,
        "participant": meta.participant,
        "stroke": meta.stroke,
        "synthetic": meta.synthetic,
        "content_sha256": recording.sha256,
        "stroke_id": stroke_id,
        "duplicate": duplicate,
        "duration_s": recording.duration_s(),
        "force_rate_hz": f.rate_hz,
        "position_rate_hz": recording.position.rate_hz,
        "filter_taps": processed.filter_taps,
        "profile": {
            "points": p.len(),
            "x_start_mm": p.x_mm()[0],
            "x_end_mm": p.x_mm()[p.len() - 1],
            "mean_mu": processed.mean_mu,
            "mean_fn_n": processed.mean_fn_n,
            "sliding_s": processed.sliding_s,
            "bridged_mm": processed.bridged_mm,
        },
        "segments": segments,
        "dropped": dropped,
        "forces": {
            "samples": f.t_s.len(),
            "decimated": t_s.len() < f.t_s.len(),
            "t_s": t_s,
            "fn_n": fn_n,
            "ft_n": ft_n,
        },
    })
}

/// The signals reduced for plotting: all samples if at most `2 buckets`,
/// else per bucket of consecutive samples its first and last time with
/// each channel's extremes (min and max, in the order they occur), so the
/// plot keeps the envelope of a noisy force.
fn envelope(t: &[f64], columns: [&[f64]; 2], buckets: usize) -> (Vec<f64>, [Vec<f64>; 2]) {
    let n = t.len();
    if n <= 2 * buckets {
        return (t.to_vec(), columns.map(<[f64]>::to_vec));
    }
    let size = n.div_ceil(buckets);
    let mut times = Vec::with_capacity(2 * buckets);
    let mut out = [Vec::with_capacity(2 * buckets), Vec::with_capacity(2 * buckets)];
    for start in (0..n).step_by(size) {
        let end = (start + size).min(n);
        times.push(t[start]);
        times.push(t[end - 1]);
        for (column, values) in columns.iter().zip(out.iter_mut()) {
            let slice = &column[start..end];
            let (mut lo, mut hi) = (0, 0);
            for (i, v) in slice.iter().enumerate() {
                if *v < slice[lo] {
                    lo = i;
                }
                if *v > slice[hi] {
                    hi = i;
                }
            }
            let (first, second) = if lo <= hi { (lo, hi) } else { (hi, lo) };
            values.push(slice[first]);
            values.push(slice[second]);
        }
    }
    (times, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_envelope_keeps_every_extreme_and_bounds_the_points() {
        let t: Vec<f64> = (0..10_001).map(|i| i as f64).collect();
        let a: Vec<f64> = t.iter().map(|x| (x * 0.37).sin()).collect();
        let b: Vec<f64> = t.iter().map(|x| if *x as usize == 5000 { 9.0 } else { -x }).collect();
        let (times, [ea, eb]) = envelope(&t, [&a, &b], 100);
        assert!(times.len() <= 200 && ea.len() == times.len() && eb.len() == times.len());
        let max = |v: &[f64]| v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let min = |v: &[f64]| v.iter().cloned().fold(f64::INFINITY, f64::min);
        assert_eq!(max(&ea), max(&a));
        assert_eq!(min(&ea), min(&a));
        assert_eq!(max(&eb), 9.0);
        assert_eq!(min(&eb), -10_000.0);
        assert!(times.windows(2).all(|w| w[1] >= w[0]));
        let (short, _) = envelope(&t[..50], [&a[..50], &b[..50]], 100);
        assert_eq!(short.len(), 50);
    }

    #[test]
    fn the_entry_count_is_read_from_the_end_record() {
        let mut zip = vec![0u8; 30];
        zip.extend_from_slice(&[0x50, 0x4b, 0x05, 0x06, 0, 0, 0, 0, 7, 0, 7, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(declared_entries(&zip), Some(7));
        assert_eq!(declared_entries(&zip[..10]), None);
        assert_eq!(declared_entries(&[0u8; 100]), None);
    }
}
