//! Reading a whole input file with a size bound: refused before it is read
//! when it is not a regular file or is larger than the bound.

use std::io::Read;
use std::path::Path;

/// Why a bounded read refused or failed.
#[derive(Debug, thiserror::Error)]
pub enum BoundedReadError {
    #[error("not a regular file (a directory, device or FIFO): not read")]
    NotAFile,
    #[error("{len} bytes: larger than the limit of {limit} bytes, not read")]
    TooLarge { len: u64, limit: u64 },
    #[error("grew beyond the limit of {limit} bytes while being read")]
    Grew { limit: u64 },
    #[error("{0}")]
    Io(#[from] std::io::Error),
}

/// Reads the file at `path` of at most `limit` bytes: a regular file only,
/// its size checked before any buffer is sized by it.
pub fn read_file_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, BoundedReadError> {
    let metadata = std::fs::metadata(path)?;
    if !metadata.is_file() {
        return Err(BoundedReadError::NotAFile);
    }
    if metadata.len() > limit {
        return Err(BoundedReadError::TooLarge { len: metadata.len(), limit });
    }
    let mut bytes = Vec::with_capacity(metadata.len() as usize);
    std::fs::File::open(path)?.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(BoundedReadError::Grew { limit });
    }
    Ok(bytes)
}
