//! Outputs made of several files (a database: model matrices and
//! `metadata.json`; a library export: CSV files and `manifest.json`; a VTK
//! series; a recording's metadata and streams; a recipe's downloads).
//!
//! Every file written into an output directory goes through
//! [`OutputDir`]: its name relative to the directory is checked against
//! the name rule ([`crate::name::check_relative_path`]: no `..`, no
//! separators, no control or format characters ...), and the place it
//! resolves to (following symbolic links of the directories on the way
//! and of the file itself) must be inside the directory, or nothing is
//! written. So a name from a user, or a link planted in the directory,
//! never makes a writer write elsewhere.
//!
//! One file of a set, the *marker*, describes the others and lists the
//! SHA-256 of each. A [`FileSet`] removes the marker first, writes every
//! member atomically, and writes the marker last (atomically too). So the
//! set is either whole, or detectably incomplete: a run killed part way
//! leaves no marker, and a member that does not match the marker's hash
//! (a stray, older or half-updated file) is found by [`verify_members`].

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use super::atomic::follow_links;
use super::{WriteError, write_atomic};
use crate::name::check_relative_path;

/// Members of a file set: path relative to the set's directory (with `/`
/// separators) -> lowercase hex SHA-256 of the file's bytes.
pub type MemberHashes = BTreeMap<String, String>;

/// A directory that several files are written into; see the module
/// documentation.
#[derive(Debug, Clone)]
pub struct OutputDir {
    /// As given (for messages).
    dir: PathBuf,
    /// Resolved (symbolic links followed): what every member must be in.
    real: PathBuf,
}

impl OutputDir {
    /// `dir`, created if needed.
    pub fn create(dir: &Path) -> Result<Self, WriteError> {
        std::fs::create_dir_all(dir).map_err(|e| WriteError::new(dir, e))?;
        let real = std::fs::canonicalize(dir).map_err(|e| WriteError::new(dir, e))?;
        Ok(Self { dir: dir.to_path_buf(), real })
    }

    /// The directory as given.
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// The path of member `relative` (`name` or `sub/name`), after checking
    /// that it is a relative path of names and that it resolves inside the
    /// directory; its parent directories are created (each checked before
    /// the next is entered). The member itself is not created.
    pub fn member(&self, relative: &str) -> Result<PathBuf, WriteError> {
        // A refused name is quoted in the message, never printed as a path.
        check_relative_path(relative).map_err(|e| WriteError::refused(&self.dir, format!("a file {e}")))?;
        let path = self.dir.join(relative);
        let components: Vec<&str> = relative.split('/').collect();
        let (file, parents) = components.split_last().expect("split gives at least one component");
        let mut real = self.real.clone();
        for part in parents {
            let next = real.join(part);
            match std::fs::create_dir(&next) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
                Err(e) => return Err(WriteError::new(&path, e)),
            }
            real = std::fs::canonicalize(&next).map_err(|e| WriteError::new(&path, e))?;
            self.inside(&path, &real)?;
        }
        // Where a write lands: through a symbolic link, its target's directory.
        let target = follow_links(&real.join(file)).map_err(|e| WriteError::new(&path, e))?;
        let target_dir = match target.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir,
            _ => Path::new("."),
        };
        let target_dir = std::fs::canonicalize(target_dir).map_err(|e| WriteError::new(&path, e))?;
        self.inside(&path, &target_dir)?;
        Ok(path)
    }

    /// Refuses `path` unless `resolved` is the directory or inside it.
    fn inside(&self, path: &Path, resolved: &Path) -> Result<(), WriteError> {
        if resolved.starts_with(&self.real) {
            Ok(())
        } else {
            Err(WriteError::refused(
                path,
                format!(
                    "resolves to {}, outside the output directory {} (a symbolic link?): not written",
                    resolved.display(),
                    self.dir.display()
                ),
            ))
        }
    }

    /// Writes member `relative` atomically ([`OutputDir::member`], then
    /// [`write_atomic`]); its path.
    pub fn write<F>(&self, relative: &str, fill: F) -> Result<PathBuf, WriteError>
    where
        F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
    {
        let path = self.member(relative)?;
        write_atomic(&path, fill)?;
        Ok(path)
    }

    /// The subdirectory `name` (a member, checked as one), created if needed.
    pub fn subdir(&self, name: &str) -> Result<OutputDir, WriteError> {
        let path = self.member(name)?;
        Self::create(&path)
    }
}

/// A multi-file output being written; see the module documentation.
#[derive(Debug)]
pub struct FileSet {
    out: OutputDir,
    marker_name: String,
    members: MemberHashes,
}

impl FileSet {
    /// Starts writing a set in `dir` (created if needed) whose marker is
    /// `dir/marker_name`: the marker is removed now, so that until
    /// [`FileSet::finish`] the directory reads as incomplete.
    pub fn begin(dir: &Path, marker_name: &str) -> Result<Self, WriteError> {
        let out = OutputDir::create(dir)?;
        let marker = out.member(marker_name)?;
        match std::fs::remove_file(&marker) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(source) => return Err(WriteError { path: marker, cause: source }),
        }
        Ok(Self { out, marker_name: marker_name.to_string(), members: MemberHashes::new() })
    }

    /// The set's directory.
    pub fn dir(&self) -> &Path {
        self.out.path()
    }

    /// Writes member `relative` (a path inside the set's directory, checked
    /// by [`OutputDir::member`]; its parent directories are created)
    /// atomically and records its hash.
    pub fn write<F>(&mut self, relative: &str, fill: F) -> Result<PathBuf, WriteError>
    where
        F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
    {
        // A member in the marker's place (a material named manifest.json)
        // would leave no room for the marker: refused, the set incomplete.
        let first = relative.split('/').next().unwrap_or_default();
        if first.eq_ignore_ascii_case(&self.marker_name) {
            return Err(WriteError::refused(
                &self.out.path().join(&self.marker_name),
                format!("a member {} would take the place of the set's marker", crate::text::Quoted(relative)),
            ));
        }
        let mut hasher = Sha256::new();
        let path = self.out.write(relative, |w| {
            let mut hashing = HashingWriter { inner: w, hasher: &mut hasher };
            fill(&mut hashing)
        })?;
        self.members.insert(relative.to_string(), hex(&hasher.finalize()));
        Ok(path)
    }

    /// The members written so far and their hashes.
    pub fn members(&self) -> &MemberHashes {
        &self.members
    }

    /// Writes the marker last: `fill` gets the members' hashes to record.
    pub fn finish<F>(self, fill: F) -> Result<PathBuf, WriteError>
    where
        F: FnOnce(&mut dyn Write, &MemberHashes) -> std::io::Result<()>,
    {
        super::fault_point("before-marker");
        let members = self.members;
        self.out.write(&self.marker_name, |w| fill(w, &members))
    }
}

/// A member of a set is missing or differs from its recorded hash.
#[derive(Debug, thiserror::Error)]
#[error("{}: {problem} (the set was not written completely, or was changed since; write it again)", path.display())]
pub struct MemberError {
    pub path: PathBuf,
    pub problem: String,
}

/// Checks that every member listed in `members` exists under `dir` with
/// its recorded SHA-256.
/// Every name listed must be a relative path of names
/// ([`check_relative_path`]): a marker someone else wrote cannot make this
/// read a file outside `dir`.
pub fn verify_members(dir: &Path, members: &MemberHashes) -> Result<(), MemberError> {
    for (relative, expected) in members {
        check_relative_path(relative)
            .map_err(|e| MemberError { path: dir.to_path_buf(), problem: format!("a member {e}") })?;
        let path = dir.join(relative);
        let problem = |problem: String| MemberError { path: path.clone(), problem };
        let real = std::fs::canonicalize(&path).map_err(|e| problem(e.to_string()))?;
        let home = std::fs::canonicalize(dir).map_err(|e| problem(e.to_string()))?;
        if !real.starts_with(&home) || !real.is_file() {
            return Err(problem(format!(
                "not a regular file inside {} (resolves to {})",
                dir.display(),
                real.display()
            )));
        }
        let actual = sha256_file(&path).map_err(|e| MemberError { path: path.clone(), problem: e.to_string() })?;
        if &actual != expected {
            return Err(MemberError {
                path,
                problem: format!("SHA-256 {actual} differs from {expected} recorded beside it"),
            });
        }
    }
    Ok(())
}

/// Lowercase hex SHA-256 of a file's bytes (read in blocks).
pub fn sha256_file(path: &Path) -> std::io::Result<String> {
    use std::io::Read;
    let mut file = std::fs::File::open(path)?;
    let mut hasher = Sha256::new();
    let mut buffer = vec![0u8; 1 << 16];
    loop {
        match file.read(&mut buffer) {
            Ok(0) => return Ok(hex(&hasher.finalize())),
            Ok(n) => hasher.update(&buffer[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

/// Lowercase hex SHA-256 of bytes.
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

fn hex(bytes: &[u8]) -> String {
    use std::fmt::Write as _;
    bytes.iter().fold(String::with_capacity(2 * bytes.len()), |mut s, b| {
        let _ = write!(s, "{b:02x}");
        s
    })
}

/// A writer that hashes what passes through it.
struct HashingWriter<'a> {
    inner: &'a mut dyn Write,
    hasher: &'a mut Sha256,
}

impl Write for HashingWriter<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hasher.update(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marker_lists_the_hashes_and_verification_finds_a_changed_member() {
        let dir = tempfile::tempdir().unwrap();
        let mut set = FileSet::begin(dir.path(), "manifest.json").unwrap();
        set.write("a/one.csv", |w| w.write_all(b"x,y\n1,2\n")).unwrap();
        set.write("two.csv", |w| w.write_all(b"x\n3\n")).unwrap();
        let members = set.members().clone();
        set.finish(|w, m| writeln!(w, "{}", m.len())).unwrap();
        assert_eq!(std::fs::read_to_string(dir.path().join("manifest.json")).unwrap(), "2\n");
        assert_eq!(members["two.csv"], sha256_hex(b"x\n3\n"));
        verify_members(dir.path(), &members).unwrap();
        std::fs::write(dir.path().join("two.csv"), "x\n4\n").unwrap();
        let e = verify_members(dir.path(), &members).unwrap_err();
        assert!(e.to_string().contains("two.csv"), "{e}");
        std::fs::remove_file(dir.path().join("a/one.csv")).unwrap();
        assert!(verify_members(dir.path(), &members).is_err());
    }

    #[test]
    fn beginning_a_set_removes_the_old_marker() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("metadata.json"), "{}").unwrap();
        let _set = FileSet::begin(dir.path(), "metadata.json").unwrap();
        assert!(!dir.path().join("metadata.json").exists());
    }
}
