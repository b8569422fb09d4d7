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
        }
    }
}
