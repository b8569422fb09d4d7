//! Limits per client (docs/web.md, "Safety: who may use the server"): the
//! server's own limits (its heavy slots, its one FE slot) are shared by
//! everyone, so one client could keep them busy for all. Per client (its
//! IP address, as the connection's peer):
//!
//! - **expensive requests per second**: the routes that take a heavy slot
//!   (FE runs, checks, compensations, renders, maps, calibrations,
//!   uploads) draw from a token bucket of [`Limits::client_expensive_burst`]
//!   requests refilled at [`Limits::client_expensive_per_s`]; an empty
//!   bucket is 429 with `Retry-After` (seconds until the next token), before
//!   any work;
//! - **expensive requests worked on at once**: at most
//!   [`Limits::client_concurrent`] (default 1, one less than the server's
//!   heavy slots); the next waits for one of them to end, up to
//!   [`Limits::heavy_wait`], then 429. The share is taken before any slot
//!   of the server's and held by the work the request starts until that
//!   work ends ([`CLIENT_WORK`], [`crate::work::spawn`]), even if the
//!   request was abandoned. A client's flood then holds at most that many
//!   of the server's slots, and the others stay free for other clients: a
//!   token bucket alone cannot do that, since the requests it lets through
//!   still take every slot a moment before another client asks (measured:
//!   a second client's p99 4.4-5.9 times its unloaded p99 without it);
//! - **connections at once**: at most [`Limits::client_connections`]; the
//!   next is answered 429 with `Retry-After` and closed.
//!
//! The table of clients is bounded: beyond [`MAX_CLIENTS`] addresses, those
//! with a full bucket and no connection (idle: nothing to remember) are
//! forgotten; if all are busy, the new address shares the state of a
//! single overflow entry (so an attacker with many addresses is limited
//! together, never unbounded). Clients on this machine (loopback
//! addresses) are not limited unless [`Limits::limit_loopback_clients`]:
//! they are the operator's, and behind a reverse proxy every client is
//! loopback (limits per client then belong to the proxy). Requests without
//! a peer address (the application called in-process) are not limited.
//!
//! [`Limits::client_expensive_burst`]: crate::Limits::client_expensive_burst
//! [`Limits::client_expensive_per_s`]: crate::Limits::client_expensive_per_s
//! [`Limits::client_connections`]: crate::Limits::client_connections
//! [`Limits::client_concurrent`]: crate::Limits::client_concurrent
//! [`Limits::heavy_wait`]: crate::Limits::heavy_wait
//! [`Limits::limit_loopback_clients`]: crate::Limits::limit_loopback_clients

use std::collections::HashMap;
use std::net::IpAddr;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use axum::extract::{Request, State};
use axum::http::{HeaderValue, Method, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};

use crate::error::ApiError;
use crate::state::AppState;

/// Most client addresses remembered at once.
pub const MAX_CLIENTS: usize = 4096;

/// The peer address of a request's connection (set by [`crate::serve`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientAddr(pub IpAddr);

/// The routes whose requests draw from a client's bucket: those that take
/// a heavy slot.
pub const EXPENSIVE: [&str; 9] = [
    "/api/simulate",
    "/api/check",
    "/api/compensate",
    "/api/compensate/measured",
    "/api/map",
    "/api/map/path",
    "/api/play",
    "/api/calibrate",
    "/api/recordings",
];

tokio::task_local! {
    /// The share of its client's work an expensive request holds
    /// ([`Limits::client_concurrent`](crate::Limits::client_concurrent)):
    /// set by [`limit`] around the request's handling; every thread of
    /// work the request starts ([`crate::work::spawn`]) keeps a clone
    /// until its work ends, so the share is free when the last of them
    /// and the request are done.
    pub(crate) static CLIENT_WORK: Arc<OwnedSemaphorePermit>;
}

#[derive(Debug)]
struct Client {
    tokens: f64,
    refilled: Instant,
    connections: usize,
    /// Its expensive requests worked on at once (made on its first).
    work: Option<Arc<Semaphore>>,
}

impl Client {
    /// Whether requests of the client are still being worked on, or wait
    /// for their turn (each holds a reference to the semaphore).
    fn working(&self) -> bool {
        self.work.as_ref().is_some_and(|w| Arc::strong_count(w) > 1)
    }
}

/// Every client's bucket and connections.
#[derive(Debug, Default)]
pub struct Clients {
    table: Mutex<HashMap<Option<IpAddr>, Client>>,
}

/// A connection counted for its client until dropped.
#[derive(Debug)]
pub struct ConnectionSlot {
    clients: Arc<Clients>,
    key: Option<IpAddr>,
}

impl Drop for ConnectionSlot {
    fn drop(&mut self) {
        let mut table = self.clients.table.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(c) = table.get_mut(&self.key) {
            c.connections = c.connections.saturating_sub(1);
        }
    }
}

impl Clients {
    /// The entry of `ip` (refilled to now), making room in a full table.
    fn entry(
        table: &mut HashMap<Option<IpAddr>, Client>,
        ip: IpAddr,
        burst: f64,
        per_s: f64,
        now: Instant,
    ) -> (&mut Client, Option<IpAddr>) {
        let mut key = Some(ip);
        if !table.contains_key(&key) && table.len() >= MAX_CLIENTS {
            table.retain(|_, c| {
                let full = c.tokens + per_s * now.duration_since(c.refilled).as_secs_f64() >= burst;
                c.connections > 0 || !full || c.working()
            });
            if table.len() >= MAX_CLIENTS {
                key = None;
            }
        }
        let client = table.entry(key).or_insert(Client { tokens: burst, refilled: now, connections: 0, work: None });
        client.tokens = (client.tokens + per_s * now.duration_since(client.refilled).as_secs_f64()).min(burst);
        client.refilled = now;
        (client, key)
    }

    /// One expensive request of `ip`: if its bucket had a token, the
    /// semaphore of its work at once (`concurrent` permits), else the
    /// seconds until it has a token.
    pub fn take(&self, ip: IpAddr, burst: f64, per_s: f64, concurrent: usize) -> Result<Arc<Semaphore>, f64> {
        let mut table = self.table.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let (client, _) = Self::entry(&mut table, ip, burst, per_s, Instant::now());
        if client.tokens >= 1.0 {
            client.tokens -= 1.0;
            Ok(Arc::clone(client.work.get_or_insert_with(|| Arc::new(Semaphore::new(concurrent.max(1))))))
        } else {
            Err((1.0 - client.tokens) / per_s)
        }
    }

    /// A connection of `ip`, if it has fewer than `max` open.
    pub fn connect(self: &Arc<Self>, ip: IpAddr, max: usize, burst: f64, per_s: f64) -> Option<ConnectionSlot> {
        let mut table = self.table.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let (client, key) = Self::entry(&mut table, ip, burst, per_s, Instant::now());
        if client.connections >= max {
            return None;
        }
        client.connections += 1;
        Some(ConnectionSlot { clients: Arc::clone(self), key })
    }
}

/// 429 with `Retry-After` (whole seconds, at least 1).
pub fn too_many(message: String, retry_after_s: f64) -> Response {
    let mut response = ApiError::new(StatusCode::TOO_MANY_REQUESTS, message, None).into_response();
    let seconds = retry_after_s.ceil().clamp(1.0, 3600.0) as u64;
    response.headers_mut().insert(header::RETRY_AFTER, HeaderValue::from(seconds));
    response
}

/// Middleware: an expensive request of a client whose bucket is empty is
/// 429, before any work; one that finds its client's share of work taken
/// waits for it ([`Limits::heavy_wait`](crate::Limits::heavy_wait)), then
/// 429; it is handled holding the share ([`CLIENT_WORK`]).
pub async fn limit(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let expensive = request.method() == Method::POST && EXPENSIVE.contains(&request.uri().path());
    let (true, Some(ClientAddr(ip))) = (expensive, request.extensions().get::<ClientAddr>().copied()) else {
        return next.run(request).await;
    };
    let limits = state.limits();
    let work = match state.clients().take(
        ip,
        limits.client_expensive_burst,
        limits.client_expensive_per_s,
        limits.client_concurrent,
    ) {
        Ok(work) => work,
        Err(wait) => {
            return too_many(
                format!(
                    "this client sent more than {} expensive requests (FE runs, checks, renders, maps, uploads) in a \
                     burst, or more than {} per second since: try again in {:.1} s",
                    limits.client_expensive_burst, limits.client_expensive_per_s, wait
                ),
                wait,
            );
        }
    };
    let share = match tokio::time::timeout(limits.heavy_wait, work.acquire_owned()).await {
        Ok(Ok(share)) => share,
        Ok(Err(_)) => return ApiError::unavailable("the server is shutting down").into_response(),
        Err(_) => {
            return too_many(
                format!(
                    "this client's {} expensive request{} (FE runs, checks, renders, maps, uploads) still being \
                     worked on after {} s: one client may have {} at once; try again when {} has finished",
                    limits.client_concurrent,
                    if limits.client_concurrent == 1 { " is" } else { "s are" },
                    limits.heavy_wait.as_secs_f64(),
                    limits.client_concurrent,
                    if limits.client_concurrent == 1 { "it" } else { "one" },
                ),
                1.0,
            );
        }
    };
    CLIENT_WORK.scope(Arc::new(share), next.run(request)).await
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bucket of 3 refilled at 2 per second: three at once, then one per
    /// half second; others' buckets are their own.
    #[test]
    fn buckets_refill_at_their_rate() {
        let clients = Clients::default();
        let (a, b): (IpAddr, IpAddr) = ("10.0.0.1".parse().unwrap(), "10.0.0.2".parse().unwrap());
        for _ in 0..3 {
            assert!(clients.take(a, 3.0, 2.0, 1).is_ok());
        }
        let wait = clients.take(a, 3.0, 2.0, 1).unwrap_err();
        assert!(wait > 0.4 && wait <= 0.5, "{wait}");
        assert!(clients.take(b, 3.0, 2.0, 1).is_ok());
        std::thread::sleep(std::time::Duration::from_millis(600));
        assert!(clients.take(a, 3.0, 2.0, 1).is_ok());
    }

    /// Connections are counted until their slot is dropped.
    #[test]
    fn connections_are_counted_until_closed() {
        let clients = Arc::new(Clients::default());
        let a: IpAddr = "10.0.0.1".parse().unwrap();
        let first = clients.connect(a, 2, 1.0, 1.0).unwrap();
        let _second = clients.connect(a, 2, 1.0, 1.0).unwrap();
        assert!(clients.connect(a, 2, 1.0, 1.0).is_none());
        drop(first);
        assert!(clients.connect(a, 2, 1.0, 1.0).is_some());
    }

    /// However many addresses, the table stays bounded: idle ones are
    /// forgotten, and with every entry busy a new address shares the one
    /// overflow entry.
    #[test]
    fn the_table_of_clients_is_bounded() {
        let clients = Arc::new(Clients::default());
        let mut slots = Vec::new();
        for i in 0..(MAX_CLIENTS as u32 + 100) {
            let ip = IpAddr::from(std::net::Ipv4Addr::from(0x0a00_0000 + i));
            slots.extend(clients.connect(ip, 4, 2.0, 1.0));
        }
        let len = clients.table.lock().unwrap().len();
        assert!(len <= MAX_CLIENTS + 1, "{len}");
        // The overflow entry holds at most 4 connections, all the rest alike.
        assert_eq!(slots.len(), MAX_CLIENTS + 4);
        drop(slots);
        // The idle entries are forgotten for new addresses; once every
        // entry is a client that spent a token, the rest share the overflow
        // entry's bucket (2 requests, then refused).
        let mut refused = 0;
        for i in 0..(2 * MAX_CLIENTS as u32) {
            let ip = IpAddr::from(std::net::Ipv4Addr::from(0x0b00_0000 + i));
            refused += usize::from(clients.take(ip, 2.0, 1e-3, 1).is_err());
        }
        assert!(clients.table.lock().unwrap().len() <= MAX_CLIENTS + 1);
        assert_eq!(refused, MAX_CLIENTS - 2);
    }
}
