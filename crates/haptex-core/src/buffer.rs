//! Large sample buffers: zeroed vectors the kernel may back with huge
//! pages.
//!
//! A minute of 48 kHz drive signal is three 23 MB vectors (positions,
//! envelope, signal) and the WAV bytes; writing them the first time costs
//! one page fault per 4 KiB page, which measured 37% of `haptex play`'s
//! time. On Linux with transparent huge pages in `madvise` mode (Debian's
//! default) a region must ask for huge pages (madvise MADV_HUGEPAGE, as
//! NumPy does for its arrays of 4 MB and more); then a fault maps 2 MiB.
//! Elsewhere, or if the kernel refuses, the buffer is an ordinary one:
//! only speed depends on it.

/// Buffers at least this large ask for huge pages (NumPy's threshold).
const HUGE_PAGE_THRESHOLD_BYTES: usize = 4 << 20;

/// `vec![0.0; n]`, asking the kernel for huge pages when it is large.
pub fn zeroed_f64(n: usize) -> Vec<f64> {
    let v = vec![0.0; n];
    advise_huge_pages(v.as_ptr().cast(), n * size_of::<f64>());
    v
}

/// A vector with room for `bytes` bytes, asking for huge pages when it is
/// large (the pages are touched as it is filled).
pub fn bytes_with_capacity(bytes: usize) -> Vec<u8> {
    let v = Vec::with_capacity(bytes);
    advise_huge_pages(v.as_ptr(), bytes);
    v
}

/// A buffer whose size comes from the input could not be allocated: what
/// it was for and how large it was. The allocation was asked fallibly
/// (`try_reserve_exact`), so the process answers with this error instead
/// of aborting ("memory allocation of N bytes failed", exit 134).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("cannot allocate {what}: {} of memory, more than the system gives this process", bytes_text(*.bytes))]
pub struct AllocationError {
    /// What the buffer was for, e.g. "the 40000 x 40000 weight matrix of
    /// the leave-one-out".
    pub what: String,
    /// Its size in bytes (beyond `usize` when the count itself overflows).
    pub bytes: u128,
}

/// `n` copies of `value` in a vector allocated fallibly: an
/// [`AllocationError`] naming `what` when the memory cannot be had (or
/// `n` elements overflow the address space), never an abort. Large
/// buffers ask for huge pages as [`zeroed_f64`] does.
pub fn try_filled<T: Clone>(n: usize, value: T, what: impl FnOnce() -> String) -> Result<Vec<T>, AllocationError> {
    let mut v: Vec<T> = try_with_capacity(n, what)?;
    advise_huge_pages(v.as_ptr().cast(), n * size_of::<T>());
    v.resize(n, value);
    Ok(v)
}

/// An empty vector with room for `n` elements, allocated fallibly (see
/// [`try_filled`]).
pub fn try_with_capacity<T>(n: usize, what: impl FnOnce() -> String) -> Result<Vec<T>, AllocationError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| AllocationError { what: what(), bytes: n as u128 * size_of::<T>() as u128 })?;
    Ok(v)
}

/// The number of elements of a `rows` x `columns` matrix, or an
/// [`AllocationError`] naming `what` if it overflows `usize`.
pub fn matrix_len<T>(rows: usize, columns: usize, what: impl FnOnce() -> String) -> Result<usize, AllocationError> {
    rows.checked_mul(columns)
        .filter(|n| n.checked_mul(size_of::<T>()).is_some())
        .ok_or_else(|| AllocationError { what: what(), bytes: rows as u128 * columns as u128 * size_of::<T>() as u128 })
}

/// A size in bytes for a person: `12.3 MiB`, `11.9 GiB`, `150.9 TiB`.
pub fn bytes_text(bytes: u128) -> String {
    let b = bytes as f64;
    let (unit, scale) = match b {
        b if b >= (1u64 << 40) as f64 => ("TiB", (1u64 << 40) as f64),
        b if b >= (1u64 << 30) as f64 => ("GiB", (1u64 << 30) as f64),
        _ => ("MiB", (1u64 << 20) as f64),
    };
    format!("{} {unit}", crate::num::Fixed(b / scale, 1))
}

#[cfg(target_os = "linux")]
fn advise_huge_pages(start: *const u8, len: usize) {
    if len < HUGE_PAGE_THRESHOLD_BYTES {
        return;
    }
    const PAGE: usize = 4096;
    let begin = (start as usize).div_ceil(PAGE) * PAGE;
    let end = (start as usize + len) / PAGE * PAGE;
    if end > begin {
        // SAFETY: [begin, end) lies inside the caller's live allocation
        // (rounded inwards to whole pages); MADV_HUGEPAGE only changes how
        // the kernel backs those pages, never their contents, and a failure
        // (e.g. a kernel without THP) is harmless, so it is ignored.
        unsafe {
            libc::madvise(begin as *mut libc::c_void, end - begin, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_start: *const u8, _len: usize) {
    let _ = HUGE_PAGE_THRESHOLD_BYTES;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buffers_are_zeroed_and_sized() {
        for n in [0, 10, 1 << 20] {
            let v = zeroed_f64(n);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|&x| x == 0.0));
            let b = bytes_with_capacity(8 * n);
            assert!(b.is_empty() && b.capacity() >= 8 * n);
            assert_eq!(try_filled(n, 1.5, String::new).unwrap(), vec![1.5; n]);
        }
    }

    /// More than the address space: an error naming the buffer, not an
    /// abort.
    #[test]
    fn impossible_allocations_are_errors() {
        let n = 1usize << 60;
        let e = try_filled(n, 0.0f64, || "the test buffer".into()).unwrap_err();
        assert_eq!(e.bytes, 8 << 60);
        assert!(e.to_string().starts_with("cannot allocate the test buffer: 8388608.0 TiB"), "{e}");
        let e = matrix_len::<f64>(usize::MAX / 2, 3, || "m".into()).unwrap_err();
        assert_eq!(e.bytes, (usize::MAX / 2) as u128 * 24);
        assert_eq!(matrix_len::<f64>(1000, 1000, String::new), Ok(1_000_000));
    }
}
