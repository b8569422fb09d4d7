//! The server's memory after load: freed memory given back to the system.
//!
//! The allocator (glibc's malloc) keeps memory a program frees, to reuse
//! it: the RSS of `haptex serve` climbed from 88 MB to 1.0-1.26 GB under
//! load (12 clients sending FE checks, maps and plays) and stayed there.
//! Two of its habits keep large amounts:
//!
//! - its threshold above which a block is mapped on its own (and unmapped,
//!   given back, when freed) grows: once a block of 16 MB (a render's
//!   vector) is freed, blocks up to that size come from its heaps, whose
//!   free memory it keeps;
//! - each thread that allocates at once with another may get an arena of
//!   its own (up to 8 per core), each keeping the memory freed in it
//!   unless asked to give it back.
//!
//! [`configure`] (at the start of `haptex serve`) fixes that threshold at
//! [`MMAP_THRESHOLD_BYTES`], so that every large block (sample vectors,
//! maps, answers) is mapped and given back as soon as it is freed; and
//! once heavy work or a large answer has freed memory and no heavy work
//! is running, a trim (`malloc_trim`) gives back the free pages of every
//! arena, within a second ([`Trimmer`]: not while heavy work runs, since a
//! trim holds each arena's lock while it walks it, and the memory is being
//! reused then anyway). Elsewhere than on glibc this module does nothing.
//!
//! Measured with `scripts/load_health.py --pid` (12 clients, 30 s, on a
//! shared 2-core machine; RSS at peak / 5 s after the load, idle 21 MiB):
//! glibc's defaults 448 / 233 MiB, the fixed threshold alone 174 / 77, the
//! trim alone 263 / 40, both 149 / 23. Bounding the arenas as well (4
//! instead of 16) changed nothing measurable (24 MiB after either way),
//! so it is not done. RELIABILITY.md states the bound.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Blocks of at least this many bytes are mapped on their own, and given
/// back when freed (glibc's default is 128 KiB, growing up to 32 MiB).
pub const MMAP_THRESHOLD_BYTES: usize = 1 << 20;

/// How often the trimmer looks whether there is memory to give back.
pub const TRIM_EVERY: Duration = Duration::from_secs(1);

/// Fixes the allocator's mmap threshold (see the module docs): once, at
/// the start of the server process, before its threads start.
pub fn configure() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: mallopt only changes malloc's parameters; called before
        // the runtime's threads exist. A refusal (0) leaves the defaults.
        let ok = unsafe { libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES as libc::c_int) == 1 };
        if !ok {
            tracing::warn!("cannot set the allocator's mmap threshold: freed memory may be kept");
        }
    }
}

/// Notes that a large amount of memory was freed (heavy work done, a
/// large answer sent), for the next trim.
pub(crate) fn freed_large() {
    FREED.store(true, Ordering::Release);
}

static FREED: AtomicBool = AtomicBool::new(false);

/// Gives the allocator's free pages back to the system: every
/// [`TRIM_EVERY`], when large amounts were freed since the last time and
/// no heavy work is running.
pub(crate) struct Trimmer;

impl Trimmer {
    /// Runs until the runtime stops (spawned by [`crate::serve`]).
    pub(crate) async fn run(state: crate::AppState) {
        let mut every = tokio::time::interval(TRIM_EVERY);
        every.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let all_slots = state.limits().concurrent_heavy.max(1);
        loop {
            every.tick().await;
            let idle = state.heavy().available_permits() == all_slots;
            if idle && FREED.swap(false, Ordering::AcqRel) {
                // Off the async workers: a trim walks every arena.
                let _ = crate::work::spawn(trim).await;
            }
        }
    }
}

/// Gives the free pages of every malloc arena back to the system.
pub fn trim() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only releases free memory of malloc's own.
    unsafe {
        libc::malloc_trim(0);
    }
}
