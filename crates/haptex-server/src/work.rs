//! CPU work of a request, off the async workers, in bounded slots.
//!
//! The async workers only move bytes: they accept connections, read
//! bodies, answer `/api/health` and write answers. Everything that costs
//! CPU in proportion to the input (parsing a JSON or CSV body, checking a
//! profile, the voltage mapping, a CAE prediction, rendering, building
//! and serializing the answer) runs through [`Slot::run`], [`cpu`] or
//! [`blocking`] on tokio's blocking threads, so that:
//!
//! - a worker is never held by one request: `/api/health` answers while
//!   any request is being processed;
//! - the workers come first: a thread doing a request's work runs at a
//!   lower scheduling priority ([`WORK_NICENESS`] on Linux), so that when
//!   the cores are busy with work, the kernel still runs a worker as soon
//!   as it has something to do (a health check is answered within
//!   milliseconds, not after the work's time slice);
//! - the request timeout covers the work: the handler awaits the result,
//!   so the timeout layer can answer 408 while the work is still running
//!   (the work then finishes on its thread and its result is dropped; it
//!   keeps its slot until then, so abandoned work still counts);
//! - heavy work (an FE run, a render, an image turned into a map, a body
//!   over [`Limits::heavy_body_bytes`]) takes one of
//!   [`Limits::concurrent_heavy`] slots, whatever its kind: N heavy
//!   requests at once cannot occupy more than that many cores, nor more
//!   than that many times [`Limits::max_request_memory_bytes`], whatever
//!   N. At most [`Limits::max_queued_heavy`] wait for a slot, each for at
//!   most [`Limits::heavy_wait`]; beyond either the answer is 503 (busy,
//!   try again), before any work and before a streamed answer starts.
//!
//! [`Limits::heavy_body_bytes`]: crate::Limits::heavy_body_bytes
//! [`Limits::concurrent_heavy`]: crate::Limits::concurrent_heavy
//! [`Limits::max_queued_heavy`]: crate::Limits::max_queued_heavy
//! [`Limits::heavy_wait`]: crate::Limits::heavy_wait
//! [`Limits::max_request_memory_bytes`]: crate::Limits::max_request_memory_bytes

use std::sync::Arc;
use std::sync::atomic::Ordering;

use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tokio::task::JoinHandle;

use crate::error::ApiError;
use crate::state::AppState;

/// The slot of a request's work, taken before the work starts: a heavy
/// slot ([`heavy_slot`]) or none; [`Slot::run`] runs the work in it.
#[derive(Debug)]
pub(crate) struct Slot(Option<OwnedSemaphorePermit>);

impl Slot {
    /// The slot of work on an input of `input_bytes`: heavy if the input
    /// is over [`Limits::heavy_body_bytes`].
    ///
    /// [`Limits::heavy_body_bytes`]: crate::Limits::heavy_body_bytes
    pub async fn for_input(state: &AppState, input_bytes: usize) -> Result<Self, ApiError> {
        if input_bytes > state.limits().heavy_body_bytes { Self::heavy(state).await } else { Ok(Self(None)) }
    }

    /// A heavy slot, whatever the input's size.
    pub async fn heavy(state: &AppState) -> Result<Self, ApiError> {
        Ok(Self(Some(heavy_slot(state).await?)))
    }

    /// Runs `work` on a blocking thread ([`blocking`]), holding the slot
    /// until the work ends.
    pub async fn run<T, F>(self, work: F) -> Result<T, ApiError>
    where
        T: Send + 'static,
        F: FnOnce() -> Result<T, ApiError> + Send + 'static,
    {
        blocking(self.0.into_iter().collect(), work).await
    }
}

/// Runs `work` for a request whose input is `input_bytes` long: on a
/// blocking thread, in a heavy slot if the input is large.
pub(crate) async fn cpu<T, F>(state: &AppState, input_bytes: usize, work: F) -> Result<T, ApiError>
where
    T: Send + 'static,
    F: FnOnce() -> Result<T, ApiError> + Send + 'static,
{
    Slot::for_input(state, input_bytes).await?.run(work).await
}

/// One of the [`Limits::concurrent_heavy`] slots of heavy work: at once
/// when one is free; else a wait of up to [`Limits::heavy_wait`] if fewer
/// than [`Limits::max_queued_heavy`] requests are waiting already; 503
/// otherwise. Taken last, after any slot of a kind (an FE slot, a render
/// slot), and never held while waiting for another, so that no two
/// requests wait for each other.
///
/// [`Limits::concurrent_heavy`]: crate::Limits::concurrent_heavy
/// [`Limits::heavy_wait`]: crate::Limits::heavy_wait
/// [`Limits::max_queued_heavy`]: crate::Limits::max_queued_heavy
pub(crate) async fn heavy_slot(state: &AppState) -> Result<OwnedSemaphorePermit, ApiError> {
    if let Ok(permit) = Arc::clone(state.heavy()).try_acquire_owned() {
        return Ok(permit);
    }
    let limits = state.limits();
    let busy = || {
        ApiError::unavailable(format!(
            "the server is busy with other heavy requests (FE runs, renders, maps: {} at once, {} waiting); try \
             again in a few seconds",
            limits.concurrent_heavy, limits.max_queued_heavy
        ))
    };
    let waiting = state.heavy_queue();
    if waiting
        .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| (n < limits.max_queued_heavy).then_some(n + 1))
        .is_err()
    {
        return Err(busy());
    }
    let permit = tokio::time::timeout(limits.heavy_wait, Arc::clone(state.heavy()).acquire_owned()).await;
    waiting.fetch_sub(1, Ordering::AcqRel);
    permit.map_err(|_| busy())?.map_err(|_| ApiError::unavailable("the server is shutting down"))
}

/// Waits up to [`Limits::simulation_wait`] for one of the
/// [`Limits::concurrent_simulations`] FE slots (the FE model on demand,
/// the check on the finger model and the compensation share them: each
/// holds a core for its run); 503 when none frees up in time.
///
/// [`Limits::simulation_wait`]: crate::Limits::simulation_wait
/// [`Limits::concurrent_simulations`]: crate::Limits::concurrent_simulations
pub(crate) async fn fe_slot(state: &AppState) -> Result<OwnedSemaphorePermit, ApiError> {
    let limits = state.limits();
    tokio::time::timeout(limits.simulation_wait, Arc::clone(state.simulations()).acquire_owned())
        .await
        .map_err(|_| {
            ApiError::unavailable(format!(
                "the server is busy with other FE simulations (at most {} at once); try again in a few seconds",
                limits.concurrent_simulations
            ))
        })?
        .map_err(|_| ApiError::unavailable("the server is shutting down"))
}

/// Waits for a slot of `slots`.
pub(crate) async fn slot(slots: &Arc<Semaphore>) -> Result<OwnedSemaphorePermit, ApiError> {
    Arc::clone(slots).acquire_owned().await.map_err(|_| ApiError::unavailable("the server is shutting down"))
}

/// Runs `work` on a blocking thread at the work's priority ([`spawn`]),
/// holding `permits` until the work ends, even if the request was
/// abandoned meanwhile. A panic in the work is resumed here, so that the
/// panic layer answers it as any other (500, logged).
pub(crate) async fn blocking<T, F>(permits: Vec<OwnedSemaphorePermit>, work: F) -> Result<T, ApiError>
where
    T: Send + 'static,
    F: FnOnce() -> Result<T, ApiError> + Send + 'static,
{
    blocking_with(permits, work, false).await
}

/// [`blocking`] for an FE run ([`spawn_long`]).
pub(crate) async fn blocking_long<T, F>(permits: Vec<OwnedSemaphorePermit>, work: F) -> Result<T, ApiError>
where
    T: Send + 'static,
    F: FnOnce() -> Result<T, ApiError> + Send + 'static,
{
    blocking_with(permits, work, true).await
}

async fn blocking_with<T, F>(permits: Vec<OwnedSemaphorePermit>, work: F, long: bool) -> Result<T, ApiError>
where
    T: Send + 'static,
    F: FnOnce() -> Result<T, ApiError> + Send + 'static,
{
    let work = move || {
        let heavy = !permits.is_empty();
        let result = work();
        drop(permits);
        if heavy {
            crate::memory::freed_large();
        }
        result
    };
    let task = if long { spawn_long(work) } else { spawn(work) };
    match task.await {
        Ok(result) => result,
        Err(e) if e.is_panic() => std::panic::resume_unwind(e.into_panic()),
        Err(_) => Err(ApiError::unavailable("the server is shutting down")),
    }
}

/// The niceness of the threads doing a request's work (Linux: 0 is the
/// default, 19 the lowest priority): 10 gives a waiting async worker
/// about ten times the work's share of a core, so that it runs at once.
pub const WORK_NICENESS: i32 = 10;

/// The niceness of an FE run's thread ([`spawn_long`]): below other work,
/// so that a request of milliseconds (a play, a prediction) sharing a core
/// with a run of seconds gets three times its share (the kernel's weights
/// of niceness 10 and 15 are 110 and 36): short requests keep their
/// latency while FE runs go on, and the runs lose little.
pub const LONG_WORK_NICENESS: i32 = 15;

/// `tokio::task::spawn_blocking`, the thread first lowered to
/// [`WORK_NICENESS`]: every thread that does a request's work goes
/// through here (the blocking threads serve nothing else). Started for an
/// expensive request of a limited client, it holds that client's share of
/// work ([`crate::clients::CLIENT_WORK`]) until `work` ends.
pub(crate) fn spawn<T, F>(work: F) -> JoinHandle<T>
where
    T: Send + 'static,
    F: FnOnce() -> T + Send + 'static,
{
    let share = crate::clients::CLIENT_WORK.try_with(Arc::clone).ok();
    tokio::task::spawn_blocking(move || {
        lower_priority();
        let result = work();
        drop(share);
        result
    })
}

/// [`spawn`] for an FE run (seconds of a core): on a thread of its own
/// at [`LONG_WORK_NICENESS`], started and joined by a work thread (a
/// thread's niceness cannot be raised back without privilege, so the
/// pool's threads are not lowered further). Where no thread can be
/// started, the work runs on the work thread.
pub(crate) fn spawn_long<T, F>(work: F) -> JoinHandle<T>
where
    T: Send + 'static,
    F: FnOnce() -> T + Send + 'static,
{
    spawn(move || {
        let mut work = Some(work);
        let done = std::thread::scope(|scope| {
            let thread = std::thread::Builder::new().name("haptex-fe".into()).spawn_scoped(scope, || {
                set_niceness(LONG_WORK_NICENESS);
                (work.take().expect("the work runs once"))()
            });
            thread.ok().map(|t| t.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)))
        });
        done.unwrap_or_else(|| (work.take().expect("the thread did not start"))())
    })
}

/// Lowers the calling thread's scheduling priority to [`WORK_NICENESS`]
/// (once per thread; a no-op where threads have no niceness of their own).
fn lower_priority() {
    #[cfg(target_os = "linux")]
    {
        thread_local! {
            static LOWERED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
        }
        if !LOWERED.get() {
            LOWERED.set(true);
            set_niceness(WORK_NICENESS);
        }
    }
}

/// Sets the calling thread's niceness (Linux; raising it needs no
/// privilege, a failure leaves it as it was).
fn set_niceness(niceness: i32) {
    #[cfg(target_os = "linux")]
    {
        // On Linux, PRIO_PROCESS with a thread id sets that thread's
        // niceness only (setpriority(2), "BUGS").
        // SAFETY: plain system calls on the calling thread, no memory passed.
        let failed = unsafe {
            let tid = libc::syscall(libc::SYS_gettid) as libc::id_t;
            libc::setpriority(libc::PRIO_PROCESS, tid, niceness) != 0
        };
        if failed {
            tracing::debug!("cannot lower a work thread's priority: {}", std::io::Error::last_os_error());
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = niceness;
}

/// Runs `f` on a new thread at the default priority (not on a work
/// thread, whose lowered priority the threads `f` starts would inherit:
/// an audio output's callback); None if it panicked or could not start.
pub(crate) async fn on_new_thread<T, F>(f: F) -> Option<T>
where
    T: Send + 'static,
    F: FnOnce() -> T + Send + 'static,
{
    let (tx, rx) = tokio::sync::oneshot::channel();
    std::thread::Builder::new()
        .name("haptex-output".into())
        .spawn(move || {
            let _ = tx.send(f());
        })
        .ok()?;
    rx.await.ok()
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    /// The calling thread's niceness (0 is the default, 19 the lowest
    /// priority).
    fn niceness() -> i32 {
        // SAFETY: plain system calls on the calling thread.
        unsafe { libc::getpriority(libc::PRIO_PROCESS, libc::syscall(libc::SYS_gettid) as libc::id_t) }
    }

    /// A request's work runs below the async workers' priority, so that a
    /// worker with a health check to answer runs before it (issue 35,
    /// "Bounded cost per request"); a thread started for an audio output
    /// does not inherit the lowered priority; an FE run is lower still.
    #[tokio::test]
    async fn work_runs_below_the_async_workers_priority() {
        let worker = niceness();
        let work = spawn(niceness).await.unwrap();
        assert!(work >= WORK_NICENESS.max(worker), "work at niceness {work}, the worker at {worker}");
        // Again on the same (already lowered) thread.
        assert_eq!(spawn(niceness).await.unwrap(), work);
        assert_eq!(on_new_thread(niceness).await, Some(worker));
        // An FE run below other work, on a thread of its own: the pool's
        // thread is not lowered further.
        let long = spawn_long(niceness).await.unwrap();
        assert!(long >= LONG_WORK_NICENESS.max(work), "an FE run at niceness {long}, other work at {work}");
        assert_eq!(spawn(niceness).await.unwrap(), work);
        // A panic in it reaches the caller.
        assert!(spawn_long(|| panic!("in the FE run")).await.unwrap_err().is_panic());
    }
}
