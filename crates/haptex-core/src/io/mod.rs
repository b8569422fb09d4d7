//! File formats shared by every haptex command: the numeric CSV table
//! reader, CSV number formatting, output files (atomic replacement,
//! streams) and multi-file outputs.

mod atomic;
mod bounded;
mod fileset;
pub mod npy;
mod table;

pub use atomic::{OutputTarget, WriteError, fault_point, remove_stale_temporaries, temporary_prefix_of, write_atomic};
pub use bounded::{BoundedReadError, read_file_bounded};
pub use fileset::{FileSet, MemberError, MemberHashes, OutputDir, sha256_file, sha256_hex, verify_members};
pub use table::{Category, MAX_LINE_BYTES, Table, TableError, TableErrorKind};

use std::io::Write;
use std::path::{Component, Path, PathBuf};

/// Writes one CSV row of numbers (shortest representation that round-trips).
pub fn write_csv_row(w: &mut dyn Write, values: &[f64]) -> std::io::Result<()> {
    let mut buffer = ryu::Buffer::new();
    for (i, v) in values.iter().enumerate() {
        if i > 0 {
            w.write_all(b",")?;
        }
        w.write_all(buffer.format(*v).as_bytes())?;
    }
    w.write_all(b"\n")
}

/// A shipped data file or directory (the texture library, the FE
/// database): the path in environment variable `env_var` if set, else
/// `relative` (e.g. `data/db`) in the source tree haptex was built from.
/// The command line and the Python package find shipped data by this one
/// rule.
pub fn shipped_data(env_var: &str, relative: &str) -> PathBuf {
    if let Some(path) = std::env::var_os(env_var) {
        return PathBuf::from(path);
    }
    normalize(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(relative))
}

/// Removes `.` and `..` components lexically (for readable messages).
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for component in path.components() {
        match component {
            Component::ParentDir if out.file_name().is_some() => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}
