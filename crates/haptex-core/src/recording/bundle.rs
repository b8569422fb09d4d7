//! Recordings from a set of files held in memory (an upload: several files
//! or the entries of an archive), read exactly as [`Recording::load`] reads
//! them from a directory, but with no file system involved.
//!
//! Every name is a relative path with `/` separators (an archive's entry
//! name, an uploaded file's name). Names are only compared, never used to
//! open anything, and a name that could mean another place on a disk (an
//! absolute path, a drive letter, a `..` or `.` component, a backslash, an
//! empty component) or that breaks the name rule otherwise
//! ([`crate::name`]) is refused, so a set that passes here is also a set
//! of files that could sit side by side in one directory. A metadata file
//! (`*.recording.json`) names its streams relative to its own folder, as
//! on disk.

use std::collections::BTreeMap;

use super::error::RecordingError;
use super::format::{MAX_METADATA_BYTES, METADATA_SUFFIX, Recording, parse_meta};
use crate::text::Quoted;

/// A set of named files in memory.
#[derive(Debug, Default, Clone)]
pub struct FileBundle {
    files: BTreeMap<String, Vec<u8>>,
}

/// What [`FileBundle::recordings`] found: the recordings, in name order,
/// and the names no recording refers to.
#[derive(Debug, Clone)]
pub struct BundleRecordings {
    pub recordings: Vec<Recording>,
    pub unused: Vec<String>,
}

impl FileBundle {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a file. The name must be a plain relative path (see the module
    /// documentation) and new to the bundle.
    pub fn add(&mut self, name: &str, bytes: Vec<u8>) -> Result<(), RecordingError> {
        check_name(name)?;
        if self.files.contains_key(name) {
            return Err(RecordingError::Io {
                file: name.to_string(),
                message: "given twice: every file of an upload needs its own name".into(),
            });
        }
        self.files.insert(name.to_string(), bytes);
        Ok(())
    }

    /// Number of files.
    pub fn len(&self) -> usize {
        self.files.len()
    }

    pub fn is_empty(&self) -> bool {
        self.files.is_empty()
    }

    /// Total bytes of the files.
    pub fn total_bytes(&self) -> usize {
        self.files.values().map(Vec::len).sum()
    }

    /// Reads and validates every recording of the bundle (each
    /// `*.recording.json` with the two streams it names), as
    /// [`Recording::load`] does: the same checks, the same errors, the same
    /// content hash. The first invalid recording is the error; a bundle
    /// without any metadata file is one too.
    pub fn recordings(&self) -> Result<BundleRecordings, RecordingError> {
        let mut recordings = Vec::new();
        let mut used = std::collections::BTreeSet::new();
        for (name, bytes) in self.files.iter().filter(|(name, _)| name.ends_with(METADATA_SUFFIX)) {
            if bytes.len() as u64 > MAX_METADATA_BYTES {
                return Err(RecordingError::Io {
                    file: name.clone(),
                    message: format!(
                        "{} bytes, larger than the limit of {MAX_METADATA_BYTES} bytes for a metadata file",
                        bytes.len()
                    ),
                });
            }
            let meta = parse_meta(name, bytes)?;
            let folder = name.rsplit_once('/').map_or("", |(folder, _)| folder);
            let mut stream = |field: &str, file: &str| -> Result<(String, &[u8]), RecordingError> {
                let path = if folder.is_empty() { file.to_string() } else { format!("{folder}/{file}") };
                if check_name(file).is_err() {
                    return Err(RecordingError::field(
                        name,
                        field,
                        format!(
                            "{} is not a file name inside the recording's folder (no absolute paths, no '..'): \
                             streams sit beside their metadata",
                            Quoted(file)
                        ),
                    ));
                }
                match self.files.get(&path) {
                    Some(bytes) => {
                        used.insert(path.clone());
                        Ok((path, bytes.as_slice()))
                    }
                    None => Err(RecordingError::field(
                        name,
                        field,
                        format!("names {}, which is not among the files given", Quoted(&path)),
                    )),
                }
            };
            let force = stream("force.file", &meta.force.file)?;
            let position = stream("position.file", &meta.position.file)?;
            used.insert(name.clone());
            recordings.push(Recording::parse(name, bytes, (&force.0, force.1), (&position.0, position.1))?);
        }
        if recordings.is_empty() {
            return Err(RecordingError::Io {
                file: "the files given".into(),
                message: format!(
                    "no recording among them: a recording is a metadata file NAME{METADATA_SUFFIX} with the force and \
                     position streams it names (docs/recordings.md)"
                ),
            });
        }
        let unused = self.files.keys().filter(|name| !used.contains(*name)).cloned().collect();
        Ok(BundleRecordings { recordings, unused })
    }
}

/// A name is a plain relative path: `/`-separated components, each a name
/// by the one rule ([`crate::name::check_relative_path`]: none empty, `.`
/// or `..`, no backslash, colon, control or format character ...).
fn check_name(name: &str) -> Result<(), RecordingError> {
    crate::name::check_relative_path(name).map_err(|e| RecordingError::Io {
        file: Quoted(name).to_string(),
        message: format!("not accepted as a file name: {} (names stay inside the upload)", e.problem),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_that_could_leave_a_folder_are_refused() {
        for bad in ["", "/etc/passwd", "../x", "a/../b", "a//b", "./a", "a/", "c:x", "a\\b", "a\u{0}b"] {
            assert!(FileBundle::new().add(bad, vec![]).is_err(), "{bad:?}");
        }
        let mut bundle = FileBundle::new();
        bundle.add("demo/wood/w.recording.json", vec![1]).unwrap();
        assert!(bundle.add("demo/wood/w.recording.json", vec![2]).is_err());
        assert_eq!(bundle.len(), 1);
    }

    #[test]
    fn a_bundle_without_metadata_is_refused() {
        let mut bundle = FileBundle::new();
        bundle.add("x.force.csv", b"t_s,fn_n,ft_n\n".to_vec()).unwrap();
        let e = bundle.recordings().unwrap_err().to_string();
        assert!(e.contains("no recording among them"), "{e}");
    }
}
