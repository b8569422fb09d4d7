//! CPU work of a request, off the async workers.
//!
//! The async workers only move bytes: they accept connections, read
//! bodies, answer `/api/health` and write answers. Everything that costs
//! CPU in proportion to the input (parsing a JSON or CSV body, checking a
//! profile, the voltage mapping, a CAE prediction, rendering, building
//! and serializing the answer) runs through [`cpu`] or [`blocking`] on
//! tokio's blocking threads, so that:
//!
//! - a worker is never held by one request: `/api/health` answers while
//!   any request is being processed;
//! - the request timeout covers the work: the handler awaits the result,
//!   so the timeout layer can answer 408 while the work is still running
//!   (the work then finishes on its thread and its result is dropped; it
//!   keeps its slot until then, so abandoned work still counts);
//! - heavy requests (bodies over [`Limits::heavy_body_bytes`]) take one of
//!   [`Limits::concurrent_heavy`] slots: N large uploads at once cannot
//!   occupy more than that many cores, whatever N.
//!
//! [`Limits::heavy_body_bytes`]: crate::Limits::heavy_body_bytes
//! [`Limits::concurrent_heavy`]: crate::Limits::concurrent_heavy

use std::sync::Arc;

use tokio::sync::{OwnedSemaphorePermit, Semaphore};

use crate::error::ApiError;
use crate::state::AppState;

/// Runs `work` for a request whose input is `input_bytes` long: on a
/// blocking thread, in a heavy slot if the input is large.
pub(crate) async fn cpu<T, F>(state: &AppState, input_bytes: usize, work: F) -> Result<T, ApiError>
where
    T: Send + 'static,
    F: FnOnce() -> Result<T, ApiError> + Send + 'static,
{
    let permit = if input_bytes > state.limits().heavy_body_bytes { Some(slot(state.heavy()).await?) } else { None };
    blocking(permit, work).await
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

/// Runs `work` on a blocking thread, holding `permit` (if any) until the
/// work ends, even if the request was abandoned meanwhile. A panic in the
/// work is resumed here, so that the panic layer answers it as any other
/// (500, logged).
pub(crate) async fn blocking<T, F>(permit: Option<OwnedSemaphorePermit>, work: F) -> Result<T, ApiError>
where
    T: Send + 'static,
    F: FnOnce() -> Result<T, ApiError> + Send + 'static,
{
    let task = tokio::task::spawn_blocking(move || {
        let _permit = permit;
        work()
    });
    match task.await {
        Ok(result) => result,
        Err(e) if e.is_panic() => std::panic::resume_unwind(e.into_panic()),
        Err(_) => Err(ApiError::unavailable("the server is shutting down")),
    }
}
