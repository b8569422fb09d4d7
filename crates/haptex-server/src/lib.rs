//! haptex web application: the JSON API and the web GUI of `haptex serve`
//! (paper section 4, Fig. 3: pick a source, see the friction and voltage
//! profiles, use it from a PC or a phone).
//!
//! A library crate, so that tests start the whole application in-process
//! ([`app`] is a plain `axum::Router`, called with
//! `tower::ServiceExt::oneshot`) and the `haptex` binary only parses flags
//! and calls [`run`].
//!
//! Layout, one concept per module:
//!
//! - [`routes`]: the route table (method, path, handler), the one list the
//!   router is built from and the OpenAPI test checks;
//! - `api/*`: one module per resource (health, config, templates, predict,
//!   simulate, check, voltage, materials, recordings, play, profile,
//!   openapi);
//! - [`error`]: [`ApiError`] and the middleware that turns every 4xx into
//!   the JSON error `{"error": message, "field": name}`;
//! - [`params`]: device parameters with the paper's defaults and their
//!   accepted ranges; [`fields`]: the ranges of every other number;
//! - [`input`]: request bodies (JSON or `text/csv`) and query strings;
//!   `extract`: the preamble every handler starts from (query, body kind,
//!   bounded body, the slot of its work) as axum extractors;
//! - [`display`]: the friction display a request designs for
//!   (electrovibration, ultrasonic, combined) and its checks;
//! - [`state`]: shared state ([`AppState`]: the FE database, the texture
//!   library pool and the limits);
//! - [`templates`]: the FE database of surface templates and the ranges of
//!   their parameters;
//! - [`assets`]: the GUI, embedded in the binary (rust-embed), and the
//!   security headers;
//! - hardening: [`guard`] (head sizes, allowed hosts), `work` (CPU work
//!   off the async workers at a lower priority, heavy work in bounded
//!   slots with admission control), [`answers`] (the memory of unread
//!   answers), [`memory`] (freed memory given back to the system),
//!   `connection` (write timeout, hyper's own answers made like ours),
//!   `access_log`;
//! - [`live`]: the page's live output (`haptex serve --live`): the
//!   design a page sends, the WebSocket conversation, and the trait the
//!   binary implements with its audio device;
//! - `lines`: answers streamed as JSON lines (the progress of the check on
//!   the finger model, then its result).

pub mod access;
mod access_log;
pub mod answers;
mod api;
pub mod assets;
pub mod clients;
mod connection;
pub mod device_file;
pub mod display;
pub mod error;
pub mod explain;
mod extract;
pub mod fields;
pub mod guard;
pub mod input;
mod lines;
pub mod live;
pub mod memory;
pub mod params;
pub mod recipe;
pub mod routes;
pub mod state;
pub mod templates;
pub mod tls;
mod work;

use std::convert::Infallible;
use std::future::Future;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::body::Body;
use axum::extract::DefaultBodyLimit;
use axum::http::StatusCode;
use axum::middleware::{from_fn, from_fn_with_state, map_response};
use tower::ServiceExt;
use tower_http::catch_panic::CatchPanicLayer;
use tower_http::timeout::TimeoutLayer;

pub use error::ApiError;
pub use guard::{HostNameError, HostPolicy};
pub use state::{AppState, Limits};

/// How to start the server.
#[derive(Debug, Clone)]
pub struct Config {
    /// Address to listen on (default 127.0.0.1:8080: this machine only).
    pub addr: SocketAddr,
    /// The texture library (SQLite) to serve under `/api/materials`, opened
    /// read-only unless `writable`; `None` serves no materials.
    pub library: Option<PathBuf>,
    /// Let `POST /api/recordings` add uploaded recordings to the library
    /// (`haptex serve --writable`); read-only by default.
    pub writable: bool,
    /// The FE database of surface templates (a `haptex db` directory) to
    /// serve under `/api/templates`, `/api/predict` and `/api/simulate`;
    /// `None` serves none.
    pub database: Option<PathBuf>,
    pub limits: Limits,
    /// Host names to answer for besides `localhost` and IP addresses
    /// (`haptex serve --allow-host`).
    pub allowed_hosts: Vec<String>,
    /// Log every request (`haptex serve --access-log`); errors are logged
    /// either way.
    pub access_log: bool,
    /// The audio output the page plays designs on live (`haptex serve
    /// --live`); `None`: no live mode.
    pub live: Option<Arc<dyn live::LiveOutput>>,
    /// The device requests start from: the paper's, or a device file's
    /// (`haptex serve --device-file`).
    pub default_device: params::DefaultDevice,
    /// The access token every request but the health check must carry
    /// ([`access`]); required when [`Config::token_required`] says so.
    pub token: Option<access::Token>,
    /// PEM certificate chain and private key to serve HTTPS with
    /// (`haptex serve --tls-cert --tls-key`); `None`: plain HTTP.
    pub tls: Option<(PathBuf, PathBuf)>,
}

impl Config {
    /// The default address, 127.0.0.1:8080.
    pub const DEFAULT_ADDR: &'static str = "127.0.0.1:8080";

    /// Why this server needs an access token, if it does: it listens
    /// beyond loopback (anyone on the network could use it), takes uploads
    /// into the library, or drives a live output.
    pub fn token_required(&self) -> Option<&'static str> {
        if !self.addr.ip().is_loopback() {
            Some("it listens beyond this machine")
        } else if self.writable {
            Some("--writable lets requests add recordings to the library")
        } else if self.live.is_some() {
            Some("--live lets requests drive the audio output")
        } else {
            None
        }
    }
}

/// The server could not start or stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    #[error("cannot listen on {addr}: {cause}")]
    Bind { addr: SocketAddr, cause: std::io::Error },
    #[error("cannot start the async runtime: {0}")]
    Runtime(std::io::Error),
    #[error("server error: {0}")]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Library(#[from] haptex_core::library::LibraryError),
    #[error(transparent)]
    Database(#[from] haptex_core::database::DatabaseError),
    #[error(transparent)]
    HostName(#[from] HostNameError),
    #[error("this server needs an access token: {0}")]
    TokenRequired(&'static str),
    #[error(transparent)]
    Token(#[from] access::TokenError),
    #[error(transparent)]
    Tls(#[from] tls::TlsError),
}

/// The whole application: API routes, GUI, middleware.
///
/// Layers, outermost first: request log (errors always, every request
/// with `access_log`), security headers (on every answer, a panic's
/// included), panic catcher (a 500, never a dropped connection), the
/// budget of unsent answers, 4xx-to-JSON, the request guard (head sizes,
/// host), the access rules (token, Origin: [`access`]), timeout (covering the body upload and the handler's work),
/// body limit.
pub fn app(state: AppState) -> Router {
    let limits = state.limits().clone();
    let tls = state.access().tls();
    let router = routes::router()
        .fallback(error::not_found)
        .with_state(state.clone())
        .layer(DefaultBodyLimit::max(limits.max_body_bytes))
        .layer(TimeoutLayer::with_status_code(StatusCode::REQUEST_TIMEOUT, limits.request_timeout))
        .layer(from_fn_with_state(state.clone(), clients::limit))
        .layer(from_fn_with_state(state.clone(), access::check))
        .layer(from_fn_with_state(state.clone(), guard::check_request))
        .layer(from_fn(error::json_client_errors))
        .layer(from_fn_with_state(state.clone(), answers::budget))
        .layer(CatchPanicLayer::custom(error::panic_response))
        .layer(map_response(assets::add_security_headers));
    // HSTS under TLS only: over plain HTTP a browser ignores it anyway.
    let router = if tls { router.layer(map_response(tls::add_hsts)) } else { router };
    router.layer(from_fn_with_state(state, access_log::log))
}

/// Serves the application on `listener` until `shutdown` completes, then
/// stops accepting and lets the requests in flight finish (graceful
/// shutdown, at most [`Limits::request_timeout`] more).
///
/// HTTP/1.1 through hyper directly (not `axum::serve`) for the timeouts
/// and limits of a connection: a client that sends its headers slowly,
/// or not at all, is dropped after [`Limits::header_timeout`]; once the
/// headers are in, [`Limits::request_timeout`] bounds the rest; a client
/// that reads nothing of its answer is dropped after
/// [`Limits::write_timeout`]; hyper reads heads up to
/// [`Limits::head_buffer_bytes`] so that the application's own checks
/// answer oversized ones, and what hyper still answers itself is rewritten
/// with the security headers and a JSON body (`connection`).
pub async fn serve(
    listener: tokio::net::TcpListener,
    state: AppState,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<(), ServeError> {
    serve_with(listener, state, None, shutdown).await
}

/// [`serve`] over TLS when `tls` is given (`haptex serve --tls-cert
/// --tls-key`; the state's access rules should say so:
/// [`access::Access::with_tls`]): each connection's handshake on its own
/// task, within [`Limits::header_timeout`].
pub async fn serve_with(
    listener: tokio::net::TcpListener,
    state: AppState,
    tls: Option<tls::Acceptor>,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<(), ServeError> {
    use hyper_util::rt::TokioTimer;

    let limits = state.limits().clone();
    let trimmer = tokio::spawn(memory::Trimmer::run(state.clone()));
    let clients = Arc::clone(state.clients());
    let router = app(state);
    let head = connection::HeadLimits { head_bytes: limits.head_buffer_bytes(), headers: 2 * limits.max_headers };
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(TokioTimer::new())
        .header_read_timeout(limits.header_timeout)
        .max_buf_size(head.head_bytes)
        .max_headers(head.headers);
    // Graceful shutdown: each connection's task holds a clone of `open`
    // and watches `stop`; at shutdown every connection finishes its request
    // in flight, and `closed` ends when the last task has dropped its clone.
    // (hyper-util's GracefulShutdown does not take the connections with
    // upgrades that the live page's WebSocket needs.)
    let (stop, stopped) = tokio::sync::watch::channel(false);
    let (open, mut closed) = tokio::sync::mpsc::channel::<()>(1);
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        let (stream, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(accepted) => accepted,
                Err(e) => {
                    // Out of file descriptors and the like: wait, do not spin.
                    tracing::warn!("cannot accept a connection: {e}");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
            () = &mut shutdown => break,
        };
        let _ = stream.set_nodelay(true);
        let connection = Connection {
            clients: Arc::clone(&clients),
            limits: limits.clone(),
            http: http.clone(),
            router: router.clone(),
            head,
            write_timeout: limits.write_timeout,
            stop: stopped.clone(),
            open: open.clone(),
            peer,
        };
        let (tls, handshake_timeout) = (tls.clone(), limits.header_timeout);
        tokio::spawn(async move {
            match tls {
                None => connection.run(stream).await,
                // The handshake on the connection's own task, within the
                // time a client has to send its headers.
                Some(acceptor) => match tokio::time::timeout(handshake_timeout, acceptor.accept(stream)).await {
                    Ok(Ok(stream)) => connection.run(stream).await,
                    Ok(Err(e)) => tracing::debug!(%peer, "TLS handshake failed: {e}"),
                    Err(_) => tracing::debug!(%peer, "no TLS handshake within {handshake_timeout:?}"),
                },
            }
        });
    }
    drop(listener);
    trimmer.abort();
    let _ = stop.send(true);
    drop(open);
    if tokio::time::timeout(limits.request_timeout, closed.recv()).await.is_err() {
        tracing::warn!("connections still open after {:?}: closing them", limits.request_timeout);
    }
    Ok(())
}

/// One accepted connection: what its task needs to serve it.
struct Connection {
    clients: Arc<clients::Clients>,
    limits: Limits,
    http: hyper::server::conn::http1::Builder,
    router: Router,
    head: connection::HeadLimits,
    write_timeout: Duration,
    stop: tokio::sync::watch::Receiver<bool>,
    /// Held until the connection ends (graceful shutdown waits for all).
    open: tokio::sync::mpsc::Sender<()>,
    peer: SocketAddr,
}

impl Connection {
    /// Serves HTTP/1.1 on `io` (a TCP stream, or the plaintext side of a
    /// TLS one) until the client closes or the server stops.
    async fn run<T>(self, io: T)
    where
        T: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin + Send + 'static,
    {
        use hyper_util::rt::TokioIo;
        let Self { clients, limits, http, router, head, write_timeout, mut stop, open, peer } = self;
        let ip = peer.ip();
        // Clients on this machine are limited only if the limits say so.
        let limited = limits.limit_loopback_clients || !ip.is_loopback();
        let slot = if limited {
            clients.connect(ip, limits.client_connections, limits.client_expensive_burst, limits.client_expensive_per_s)
        } else {
            None
        };
        if limited && slot.is_none() {
            // Over the client's connections: one 429 and the connection closed.
            let answer = clients::too_many(
                format!("this client has {} connections open, the most this server takes", limits.client_connections),
                1.0,
            );
            connection::write_and_close(io, answer, write_timeout).await;
            drop(open);
            return;
        }
        let requests = Arc::new(connection::Requests::default());
        let socket = connection::Socket::new(io, Arc::clone(&requests), head, write_timeout);
        let service = hyper::service::service_fn(move |request: hyper::Request<hyper::body::Incoming>| {
            // Open from the head's arrival until hyper has taken the
            // answer's last byte (see `connection`).
            let open = requests.open();
            let mut request = request.map(Body::new);
            if limited {
                request.extensions_mut().insert(clients::ClientAddr(ip));
            }
            let answer = router.clone().oneshot(request);
            async move {
                let response = answer.await.unwrap_or_else(|never: Infallible| match never {});
                Ok::<_, Infallible>(response.map(|body| Body::new(connection::Held::new(body, open))))
            }
        });
        let connection = http.serve_connection(TokioIo::new(socket), service).with_upgrades();
        let mut connection = std::pin::pin!(connection);
        let ended = tokio::select! {
            ended = connection.as_mut() => ended,
            _ = async { stop.wait_for(|&s| s).await.map(|_| ()) } => {
                connection.as_mut().graceful_shutdown();
                connection.await
            }
        };
        if let Err(e) = ended {
            tracing::debug!(%peer, "connection ended with an error: {e}");
        }
        drop(open);
    }
}

/// Starts the server with `config` and blocks until Ctrl-C (or SIGTERM),
/// then shuts down gracefully. `on_listening` is called with the bound
/// address once the server accepts connections.
pub fn run(config: Config, on_listening: impl FnOnce(SocketAddr)) -> Result<(), ServeError> {
    if let (Some(why), None) = (config.token_required(), &config.token) {
        return Err(ServeError::TokenRequired(why));
    }
    let acceptor = config.tls.as_ref().map(|(cert, key)| tls::acceptor(cert, key)).transpose()?;
    let access = access::Access::open().with_tls(acceptor.is_some());
    let access = match &config.token {
        Some(token) => access.with_token(token.clone())?,
        None => access,
    };
    memory::configure();
    let mut state = AppState::new(config.library.as_deref(), config.limits.clone())?
        .with_access(access)
        .with_hosts(HostPolicy::new(&config.allowed_hosts)?)
        .with_access_log(config.access_log)
        .with_default_device(config.default_device.clone());
    if config.writable {
        state = state.with_writable_library()?;
    }
    if let Some(dir) = &config.database {
        state = state.with_database(dir)?;
    }
    if let Some(output) = &config.live {
        state = state.with_live_output(Arc::clone(output));
    }
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build().map_err(ServeError::Runtime)?;
    runtime.block_on(async move {
        // Before the server says it listens: a signal from then on stops it.
        let shutdown = shutdown_signal();
        let listener = tokio::net::TcpListener::bind(config.addr)
            .await
            .map_err(|cause| ServeError::Bind { addr: config.addr, cause })?;
        on_listening(listener.local_addr()?);
        serve_with(listener, state, acceptor, shutdown).await
    })?;
    // Blocking tasks (library reads, renders) are bounded by the limits;
    // do not wait long for a stuck one.
    runtime.shutdown_timeout(Duration::from_secs(5));
    Ok(())
}

/// Completes on Ctrl-C, or on SIGTERM on Unix. The handlers are installed
/// when this is called (inside the runtime), not when the future is first
/// polled: a signal that arrives once the server has said it listens, but
/// before the accept loop has polled this future (it may accept at once),
/// would otherwise find the default action and kill the process instead of
/// stopping it gracefully.
fn shutdown_signal() -> impl Future<Output = ()> + Send + 'static {
    #[cfg(unix)]
    let signals = {
        use tokio::signal::unix::{SignalKind, signal};
        (signal(SignalKind::interrupt()).ok(), signal(SignalKind::terminate()).ok())
    };
    async move {
        #[cfg(unix)]
        {
            async fn next(signal: Option<tokio::signal::unix::Signal>) {
                match signal {
                    Some(mut s) => {
                        s.recv().await;
                    }
                    None => std::future::pending::<()>().await,
                }
            }
            let (interrupt, terminate) = signals;
            tokio::select! {
                () = next(interrupt) => {},
                () = next(terminate) => {},
            }
        }
        #[cfg(not(unix))]
        if tokio::signal::ctrl_c().await.is_err() {
            std::future::pending::<()>().await;
        }
        tracing::info!("shutting down: finishing the requests in flight");
    }
}
