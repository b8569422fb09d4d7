//! Output files: atomic replacement of regular files, direct writes to
//! streams, and refusal of everything else.
//!
//! What an output path names decides how it is written ([`OutputTarget`]):
//!
//! - a regular file, or a path that does not exist yet: written to a
//!   temporary file beside it (`.haptex-PID-SPACE-XXXXXX.tmp`), synced and renamed
//!   over it, so that a reader never sees a half-written file and a failed
//!   or killed write leaves the previous file untouched. A symbolic link to
//!   a regular file keeps the link: its target is replaced; a dangling link
//!   (to a file that does not exist yet) keeps the link too: its target is
//!   created (the temporary beside the target, chains of links and
//!   relative links followed), and a target whose directory does not exist
//!   is an error;
//! - `-`, a character device (`/dev/null`, a terminal), a FIFO, or a
//!   descriptor path (`/dev/stdout`, `/dev/fd/N`, `/proc/self/fd/N`):
//!   written directly, in place. Replacing them by rename would destroy
//!   them (run as root, `-o /dev/null` used to turn the system's
//!   `/dev/null` into a regular file);
//! - a directory, block device, socket or anything else: refused with an
//!   error saying what it is.
//!
//! A killed run leaves its temporary file behind; the next write into the
//! same directory removes those of processes that are no longer running.
//! A PID means something only to processes that see the same process
//! table: SPACE names it (a hash of the host's boot id and the PID
//! namespace), and only temporaries of the remover's own SPACE are ever
//! removed. Without it, Slurm tasks on several nodes sharing one scratch
//! directory deleted each other's files in progress (a task on node B saw
//! no process A's PID on B), which a test with tasks in separate PID
//! namespaces reproduced (17 of 80 tasks failed).

use std::collections::HashSet;
use std::fs::OpenOptions;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// An output file could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {cause}", path.display())]
pub struct WriteError {
    pub path: PathBuf,
    /// Part of the message, not also a `source()` (a printed error chain
    /// would repeat it).
    pub cause: std::io::Error,
}

impl WriteError {
    pub fn new(path: &Path, source: std::io::Error) -> Self {
        Self { path: path.to_path_buf(), cause: source }
    }

    pub(crate) fn refused(path: &Path, message: String) -> Self {
        Self::new(path, std::io::Error::new(std::io::ErrorKind::InvalidInput, message))
    }
}

/// How an output path is written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum OutputTarget {
    /// `-`: standard output.
    Stdout,
    /// A character device, FIFO or descriptor path, written in place.
    Stream(PathBuf),
    /// A regular file or a new path (symbolic links resolved), replaced
    /// atomically.
    File(PathBuf),
}

impl OutputTarget {
    /// What `path` names, or an error if it is nothing haptex may write
    /// (a directory, block device, socket ...).
    pub fn of(path: &Path) -> Result<Self, WriteError> {
        if path.as_os_str() == "-" {
            return Ok(Self::Stdout);
        }
        if is_descriptor_path(path) {
            return Ok(Self::Stream(path.to_path_buf()));
        }
        let metadata = match std::fs::metadata(path) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                if path.file_name().is_none() {
                    return Err(WriteError::refused(path, "not a file name".into()));
                }
                // A new file, or a dangling symbolic link: then the file
                // the link names is created, and the link kept.
                let target = follow_links(path).map_err(|e| WriteError::new(path, e))?;
                if target != path {
                    let dir = match target.parent() {
                        Some(p) if !p.as_os_str().is_empty() => p,
                        _ => Path::new("."),
                    };
                    if target.file_name().is_none() || !dir.is_dir() {
                        return Err(WriteError::refused(
                            path,
                            format!(
                                "is a symbolic link to {}, which cannot be created: {}",
                                target.display(),
                                if target.file_name().is_none() {
                                    "not a file name"
                                } else {
                                    "its directory does not exist"
                                }
                            ),
                        ));
                    }
                }
                return Ok(Self::File(target));
            }
            Err(e) => return Err(WriteError::new(path, e)),
        };
        let kind = metadata.file_type();
        if kind.is_file() {
            // Replace the file a symbolic link points to, not the link.
            return Ok(Self::File(follow_links(path).map_err(|e| WriteError::new(path, e))?));
        }
        if kind.is_dir() {
            return Err(WriteError::refused(path, "is a directory, not a file".into()));
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            if kind.is_char_device() || kind.is_fifo() {
                return Ok(Self::Stream(path.to_path_buf()));
            }
            let what = if kind.is_block_device() {
                "a block device"
            } else if kind.is_socket() {
                "a socket"
            } else {
                "a special file"
            };
            Err(WriteError::refused(
                path,
                format!(
                    "is {what}: haptex writes regular files, character devices (/dev/null), FIFOs, or - for \
                     standard output"
                ),
            ))
        }
        #[cfg(not(unix))]
        Err(WriteError::refused(path, "is not a regular file".into()))
    }

    /// Whether the output replaces a file atomically (a regular file or a
    /// new path), as opposed to a stream written in place.
    pub fn is_file(&self) -> bool {
        matches!(self, Self::File(_))
    }
}

/// Most symbolic links followed from one output path (Linux's own limit).
const MAX_LINKS: usize = 40;

/// Where a write to `path` lands: `path` itself, or, if its last component
/// is a symbolic link, the path the chain of links ends at (each relative
/// link read from the link's own directory), whether that exists or not.
pub(crate) fn follow_links(path: &Path) -> std::io::Result<PathBuf> {
    let mut current = path.to_path_buf();
    for _ in 0..=MAX_LINKS {
        match std::fs::symlink_metadata(&current) {
            Ok(m) if m.file_type().is_symlink() => {
                let next = std::fs::read_link(&current)?;
                current = match current.parent() {
                    Some(dir) if next.is_relative() => dir.join(next),
                    _ => next,
                };
            }
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e),
            _ => return Ok(current),
        }
    }
    Err(std::io::Error::other(format!("more than {MAX_LINKS} symbolic links in a chain (a loop?)")))
}

/// `/dev/stdout`, `/dev/stderr`, `/dev/fd/N`, `/proc/self/fd/N`: paths that
/// stand for an open descriptor of this process. They are written in place
/// whatever the descriptor is (a renamed file would not reach it).
fn is_descriptor_path(path: &Path) -> bool {
    let Some(text) = path.to_str() else { return false };
    matches!(text, "/dev/stdout" | "/dev/stderr")
        || ["/dev/fd/", "/proc/self/fd/"].iter().any(|prefix| {
            text.strip_prefix(prefix).is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
        })
}

/// Writes the output `path` names (see the module documentation): a
/// regular file or new path atomically, `-` and streams in place.
/// `fill` writes the content into a buffered writer; for an atomic target
/// nothing is replaced unless it succeeds.
pub fn write_atomic<F>(path: &Path, fill: F) -> Result<(), WriteError>
where
    F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
{
    match OutputTarget::of(path)? {
        OutputTarget::Stdout => {
            let stdout = std::io::stdout();
            let mut writer = BufWriter::with_capacity(1 << 16, stdout.lock());
            fill(&mut writer).and_then(|()| writer.flush()).map_err(|e| WriteError::new(path, e))
        }
        OutputTarget::Stream(stream) => {
            let file = OpenOptions::new().write(true).open(&stream).map_err(|e| WriteError::new(path, e))?;
            let mut writer = BufWriter::with_capacity(1 << 16, file);
            fill(&mut writer).and_then(|()| writer.flush()).map_err(|e| WriteError::new(path, e))
        }
        OutputTarget::File(file) => replace_file(&file, fill).map_err(|e| WriteError::new(path, e)),
    }
}

/// Writes `fill` to a temporary file beside `path` and renames it over
/// `path`.
fn replace_file<F>(path: &Path, fill: F) -> std::io::Result<()>
where
    F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
{
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    remove_stale_temporaries(dir);
    let tmp = tempfile::Builder::new().prefix(&temporary_prefix()).suffix(TEMPORARY_SUFFIX).tempfile_in(dir)?;
    let mut writer = BufWriter::with_capacity(1 << 16, tmp);
    fill(&mut writer)?;
    let tmp = writer.into_inner().map_err(|e| e.into_error())?;
    // Temporary files are created private (0600); an output is an ordinary
    // file: keep the permissions of the file it replaces, or use 0644.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path).map(|m| m.permissions().mode() & 0o7777).unwrap_or(0o644);
        tmp.as_file().set_permissions(std::fs::Permissions::from_mode(mode))?;
    }
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

const TEMPORARY_PREFIX: &str = ".haptex-";
const TEMPORARY_SUFFIX: &str = ".tmp";

/// `.haptex-PID-SPACE-`: the writing process and the process table its
/// PID belongs to are part of a temporary's name, so that a later run can
/// tell a dead run's leftovers from a live run's file, and leaves alone
/// those of processes it cannot see.
pub(crate) fn temporary_prefix() -> String {
    temporary_prefix_of(std::process::id())
}

/// The temporary-file prefix of process `pid` of this process's own
/// process table (`.haptex-PID-SPACE-`); public for tests that plant a
/// dead run's leftovers.
pub fn temporary_prefix_of(pid: u32) -> String {
    format!("{TEMPORARY_PREFIX}{pid}-{}-", process_space())
}

/// SPACE: 8 hex digits of a hash (FNV-1a) of the host's boot id and this
/// process's PID namespace (Linux: /proc/sys/kernel/random/boot_id and the
/// /proc/self/ns/pid link). "x" elsewhere, where nothing is ever removed.
fn process_space() -> &'static str {
    static SPACE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    SPACE.get_or_init(|| {
        let boot = std::fs::read_to_string("/proc/sys/kernel/random/boot_id");
        let namespace = std::fs::read_link("/proc/self/ns/pid");
        match (boot, namespace) {
            (Ok(boot), Ok(namespace)) => {
                let mut hash: u32 = 0x811c_9dc5;
                for byte in boot.trim().bytes().chain(namespace.to_string_lossy().bytes()) {
                    hash = (hash ^ u32::from(byte)).wrapping_mul(0x0100_0193);
                }
                format!("{hash:08x}")
            }
            _ => "x".to_string(),
        }
    })
}

/// Removes the `.haptex-PID-SPACE-*.tmp` files (and directories) in `dir`
/// of this process table (SPACE) whose process is no longer running: what
/// killed runs left behind. Others (another node's, another container's,
/// an older haptex's without SPACE) are never touched. Each
/// directory is swept once per process; errors are ignored (a leftover is
/// harmless, and another process may be sweeping too).
pub fn remove_stale_temporaries(dir: &Path) {
    static SWEPT: Mutex<Option<HashSet<PathBuf>>> = Mutex::new(None);
    let key = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    match SWEPT.lock() {
        Ok(mut swept) => {
            if !swept.get_or_insert_with(HashSet::new).insert(key) {
                return;
            }
        }
        Err(_) => return,
    }
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some((pid, space)) = name.to_str().and_then(temporary_owner) else { continue };
        if space != process_space() || space == "x" || pid == std::process::id() || process_is_running(pid) {
            continue;
        }
        let path = entry.path();
        let _ = if entry.file_type().is_ok_and(|t| t.is_dir()) {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
    }
}

/// The PID and SPACE in a temporary's name `.haptex-PID-SPACE-XXXX.tmp`,
/// if it is one.
fn temporary_owner(name: &str) -> Option<(u32, &str)> {
    let rest = name.strip_prefix(TEMPORARY_PREFIX)?.strip_suffix(TEMPORARY_SUFFIX)?;
    let mut parts = rest.splitn(3, '-');
    let pid = parts.next()?.parse().ok()?;
    let space = parts.next()?;
    parts.next()?;
    Some((pid, space))
}

/// Whether process `pid` is running. Linux: `/proc/PID` exists. Elsewhere
/// a process cannot be checked without libc: assume it runs (never remove a
/// live run's file).
fn process_is_running(pid: u32) -> bool {
    let proc = Path::new("/proc");
    if proc.join("self").exists() { proc.join(pid.to_string()).exists() } else { true }
}

/// A test hook: if the environment variable `HAPTEX_FAULT_INJECT` equals
/// `name`, the process aborts here, as if killed. Tests use it to check
/// that an output interrupted between two of its files is detected.
pub fn fault_point(name: &str) {
    if std::env::var_os("HAPTEX_FAULT_INJECT").is_some_and(|v| v == name) {
        eprintln!("haptex: HAPTEX_FAULT_INJECT={name}: aborting here (test hook)");
        std::process::abort();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_fill_leaves_previous_content() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        write_atomic(&path, |w| w.write_all(b"first\n")).unwrap();
        let err = write_atomic(&path, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("boom"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("out.csv"), "{err}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "first\n");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(std::fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o644);
        }
        // No temporary file is left behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn temporary_names_carry_the_pid() {
        assert_eq!(temporary_owner(".haptex-1234-0a1b2c3d-aBc123.tmp"), Some((1234, "0a1b2c3d")));
        // An older haptex's name (no SPACE) is nobody's to remove.
        assert_eq!(temporary_owner(".haptex-1234-aBc123.tmp"), None);
        assert_eq!(temporary_owner(".haptex-aBc123.tmp"), None);
        assert_eq!(temporary_owner("haptex-1-x-y.tmp"), None);
        let prefix = temporary_prefix();
        assert!(prefix.starts_with(&format!(".haptex-{}-", std::process::id())) && prefix.ends_with('-'));
        assert_eq!(temporary_owner(&format!("{prefix}Zz9.tmp")), Some((std::process::id(), process_space())));
    }

    #[test]
    fn descriptor_paths_are_streams() {
        for p in ["/dev/stdout", "/dev/stderr", "/dev/fd/1", "/proc/self/fd/7"] {
            assert!(is_descriptor_path(Path::new(p)), "{p}");
        }
        for p in ["/dev/fd/", "/dev/fd/x", "/dev/null", "out.csv", "/proc/self/fd/1/x"] {
            assert!(!is_descriptor_path(Path::new(p)), "{p}");
        }
    }
}
