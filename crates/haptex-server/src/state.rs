//! Shared state of the application: the sources of friction profiles and
//! the limits every request is held to.
//!
//! Sources: the surface templates (the FE database and its CAE, loaded once
//! at start), the texture library (a SQLite file, read-only) and the
//! user's own profile (in the request).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use haptex_core::database::DatabaseError;
use haptex_core::library::{Library, LibraryError};
use serde::Serialize;
use tokio::sync::Semaphore;

use crate::error::ApiError;
use crate::guard::HostPolicy;
use crate::live::{LiveHub, LiveOutput};
use crate::templates::TemplateSet;

/// What one request may ask of the server.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Limits {
    /// Largest request body in bytes (1 MiB).
    pub max_body_bytes: usize,
    /// Most points of a profile or trajectory in a request.
    pub max_points: usize,
    /// Most samples of a rendered drive signal returned as WAV.
    pub max_wav_samples: usize,
    /// Most samples of a rendered drive signal returned as JSON.
    pub max_json_samples: usize,
    /// Longest request target (path and query) in bytes; then 414.
    pub max_uri_bytes: usize,
    /// Largest header section (names and values) in bytes; then 431.
    pub max_header_bytes: usize,
    /// Most header fields in a request; then 431.
    pub max_headers: usize,
    /// Longest time a request may take once its headers are in, body
    /// upload and processing included; then 408.
    #[serde(serialize_with = "seconds")]
    pub request_timeout: Duration,
    /// Longest wait for a request's headers (a new connection's first
    /// request, or the next one on a kept-alive connection); then the
    /// connection is closed.
    #[serde(serialize_with = "seconds")]
    pub header_timeout: Duration,
    /// Longest time a connection may accept none of the bytes of an answer
    /// (a client that does not read); then it is closed and the answer
    /// freed.
    #[serde(serialize_with = "seconds")]
    pub write_timeout: Duration,
    /// A request body larger than this is heavy: its parsing and
    /// computation take one of [`Limits::concurrent_heavy`] slots.
    pub heavy_body_bytes: usize,
    /// Heavy work done at once, whatever its kind: the parsing of a body
    /// over `heavy_body_bytes`, an FE run (check, compensation,
    /// simulation), a drive-signal render, an image turned into a map.
    /// Each holds a core (and up to `max_request_memory_bytes`) while it
    /// runs; others wait for a slot.
    pub concurrent_heavy: usize,
    /// Most heavy requests waiting for a slot; one more is answered 503
    /// at once (admission control: under overload a client hears "busy"
    /// rather than waiting behind a queue that only grows).
    pub max_queued_heavy: usize,
    /// Longest wait for a heavy slot; then 503.
    #[serde(serialize_with = "seconds")]
    pub heavy_wait: Duration,
    /// The working memory one request may take (its buffers, its answer),
    /// estimated from its parameters before the work starts: a play's
    /// samples x channels x bytes per sample, a map's pixels x bytes per
    /// pixel. A request over it is refused with 413 naming the field.
    pub max_request_memory_bytes: usize,
    /// Most bytes of finished answers the server holds for their clients
    /// at once (answers not yet handed to the connection). An answer of
    /// more than `small_answer_bytes` that would pass it is refused with
    /// 503.
    pub max_unsent_answer_bytes: usize,
    /// Answers up to this size (errors, health, small profiles) are never
    /// refused for the budget above.
    pub small_answer_bytes: usize,
    /// Drive-signal renders run at the same time (each holds up to
    /// `max_wav_samples` x 32 bytes of working memory).
    pub concurrent_renders: usize,
    /// FE simulations (`POST /api/simulate`, about half a second of one
    /// core each) run at the same time.
    pub concurrent_simulations: usize,
    /// How long a simulation request waits for its turn before the server
    /// answers 503.
    #[serde(serialize_with = "seconds")]
    pub simulation_wait: Duration,
    /// Most points of a profile checked on the finger model (`POST
    /// /api/check`, `/api/compensate`): the check's metrics average each
    /// point over the points within three contact lengths of it, up to n^2
    /// work per FE run.
    pub max_check_points: usize,
    /// Most FE slide steps a check or compensation may take, all its runs
    /// together (about 1.5 ms of one core each with the default mesh): the
    /// bound on the time it holds an FE slot.
    pub max_check_steps: usize,
    /// The same for the 3D fingertip (`model` 3d), whose steps cost more:
    /// about 0.28 s of one core each on its default mesh and 17 ms on the
    /// coarse one (a 10 mm profile, BENCHMARKS.md).
    pub max_check_steps_3d: usize,
    /// Largest upload of recordings (`POST /api/recordings`) in bytes,
    /// the whole multipart body, and also the most bytes its files may
    /// hold once unzipped (64 MiB).
    pub max_upload_bytes: usize,
    /// Most files in one upload of recordings, zip entries included.
    pub max_upload_files: usize,
    /// Most pixels of an image turned into a map (`POST /api/map`,
    /// `/api/map/path`): 512 x 512. The answer holds two numbers per
    /// pixel (about 10 MB of JSON at the limit); larger images are for
    /// `haptex map from-image`.
    pub max_map_pixels: usize,
    /// Expensive requests (those that take a heavy slot: FE runs, checks,
    /// renders, maps, calibrations, uploads) one client (IP address) may
    /// send at once, and per second after that ([`crate::clients`]):
    /// beyond, 429 with `Retry-After`.
    pub client_expensive_burst: f64,
    pub client_expensive_per_s: f64,
    /// Expensive requests of one client worked on at once
    /// ([`crate::clients`]): with fewer than `concurrent_heavy`, a heavy
    /// slot stays free for the other clients whatever one client sends.
    pub client_concurrent: usize,
    /// Connections one client may hold open at once (the next: 429, closed).
    pub client_connections: usize,
    /// Whether clients on this machine (loopback addresses) are limited
    /// too: by default they are not (they are the operator's, and behind
    /// a reverse proxy every client is loopback: limits per client then
    /// belong to the proxy).
    pub limit_loopback_clients: bool,
}

impl Limits {
    /// 1 MiB bodies, 100 000 points, 2 000 000 WAV samples (41.7 s at
    /// 48 kHz), 200 000 JSON samples, 8 KiB request targets, 32 KiB and
    /// 100 header fields, 30 s per request (an FE check with the
    /// database's settings, 4-6 s of CPU, may wait for the FE slot first),
    /// 10 s for headers, 10 s without
    /// write progress, two heavy jobs at once (one per core of a 2-core
    /// machine: bodies over 64 KiB, FE runs, renders, maps) with at most 4
    /// waiting, each for at most 5 s, 96 MiB of working memory per request,
    /// 64 MiB of unsent answers, 2 renders at once, 1 FE simulation at once
    /// (the other core serves everything else) with a wait of up to 30 s
    /// for it (one FE check of the database's settings takes 4-6 s of CPU
    /// since its rows are averaged over the node passing); checks on
    /// the finger model of up to 4000 points and 4000 FE steps (about 6 s);
    /// uploads of recordings of up to 64 MiB and 1000 files; images of up
    /// to 512 x 512 pixels turned into maps; per client, 20 expensive
    /// requests at once and 10 per second after, one of them worked on at a
    /// time (the other heavy slot stays free for other clients), 32
    /// connections.
    pub const DEFAULT: Self = Self {
        max_body_bytes: 1 << 20,
        max_points: 100_000,
        max_wav_samples: 2_000_000,
        max_json_samples: 200_000,
        max_uri_bytes: 8 << 10,
        max_header_bytes: 32 << 10,
        max_headers: 100,
        request_timeout: Duration::from_secs(30),
        header_timeout: Duration::from_secs(10),
        write_timeout: Duration::from_secs(10),
        heavy_body_bytes: 64 << 10,
        concurrent_heavy: 2,
        max_queued_heavy: 4,
        heavy_wait: Duration::from_secs(5),
        max_request_memory_bytes: 96 << 20,
        max_unsent_answer_bytes: 64 << 20,
        small_answer_bytes: 64 << 10,
        concurrent_renders: 2,
        concurrent_simulations: 1,
        simulation_wait: Duration::from_secs(30),
        max_check_points: 4000,
        max_check_steps: 4000,
        max_check_steps_3d: 600,
        max_upload_bytes: 64 << 20,
        max_upload_files: 1000,
        max_map_pixels: 512 * 512,
        client_expensive_burst: 20.0,
        client_expensive_per_s: 10.0,
        client_concurrent: 1,
        client_connections: 32,
        limit_loopback_clients: false,
    };

    /// The read buffer hyper may fill with one request head: room for the
    /// largest head these limits accept and more, so that an oversized
    /// head reaches the server's own check (414 or 431 naming the field)
    /// rather than hyper's bare answer.
    pub fn head_buffer_bytes(&self) -> usize {
        (4 * (self.max_uri_bytes + self.max_header_bytes)).max(64 << 10)
    }
}

impl Default for Limits {
    fn default() -> Self {
        Self::DEFAULT
    }
}

fn seconds<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64())
}

/// Shared, cheaply cloned application state.
#[derive(Clone, Debug)]
pub struct AppState(Arc<Inner>);

#[derive(Debug)]
struct Inner {
    parts: Parts,
    heavy: Arc<Semaphore>,
    /// Heavy requests waiting for a slot of `heavy`.
    heavy_waiting: AtomicUsize,
    renders: Arc<Semaphore>,
    simulations: Arc<Semaphore>,
    /// Bytes of answers built and not yet handed to their connection.
    unsent_answer_bytes: AtomicUsize,
    /// Every client's bucket of expensive requests and its connections.
    clients: Arc<crate::clients::Clients>,
}

/// A profile source the GUI can offer.
#[derive(Debug, Clone, Serialize)]
pub struct SourceInfo {
    pub id: &'static str,
    pub label: &'static str,
    pub description: &'static str,
}

/// What a state is made of besides its slots and counters (which
/// [`AppState::build`] makes fresh).
#[derive(Debug, Clone)]
struct Parts {
    library: Option<Arc<LibraryPool>>,
    templates: Option<Arc<TemplateSet>>,
    /// SHA-256 of the FE database's files (see [`database_sha256`]).
    database_sha256: Option<String>,
    limits: Limits,
    hosts: HostPolicy,
    access_log: bool,
    /// The live output (`haptex serve --live`).
    live: Option<Arc<LiveHub>>,
    /// The device requests start from (`haptex serve --device-file`).
    default_device: crate::params::DefaultDevice,
    /// Who may use the server (`haptex serve --token`; [`crate::access`]).
    access: crate::access::Access,
}

impl AppState {
    /// State serving the library at `library` (opened read-only, checked
    /// now so that a bad path fails at start, not at the first request).
    pub fn new(library: Option<&Path>, limits: Limits) -> Result<Self, LibraryError> {
        let library = library.map(LibraryPool::open).transpose()?.map(Arc::new);
        Ok(Self::build(Parts {
            library,
            templates: None,
            database_sha256: None,
            limits,
            hosts: HostPolicy::default(),
            access_log: false,
            live: None,
            default_device: crate::params::DefaultDevice::PAPER,
            access: crate::access::Access::open(),
        }))
    }

    /// What this state is made of.
    fn parts(&self) -> Parts {
        self.0.parts.clone()
    }

    /// This state with its library writable: `POST /api/recordings`
    /// imports uploaded recordings into it (`haptex serve --writable`).
    /// Opened for writing now (which also migrates an older schema), so
    /// that a file the server may not write fails at start. Without a
    /// library this is the state as it was.
    pub fn with_writable_library(self) -> Result<Self, LibraryError> {
        let Some(pool) = &self.0.parts.library else { return Ok(self) };
        let writer = Library::open(&pool.path)?;
        writer.settle()?;
        drop(writer);
        let library = Some(Arc::new(LibraryPool::open_with(&pool.path, true)?));
        Ok(Self::build(Parts { library, ..self.parts() }))
    }

    /// This state, also serving the surface templates of the FE database in
    /// `dir` (loaded now, so that a bad database fails at start).
    pub fn with_database(self, dir: &Path) -> Result<Self, DatabaseError> {
        let templates = Some(Arc::new(TemplateSet::load(dir)?));
        let hash = database_sha256(dir).map_err(|e| DatabaseError::File {
            path: dir.to_path_buf(),
            message: format!("cannot hash its files: {e}"),
        })?;
        Ok(Self::build(Parts { templates, database_sha256: Some(hash), ..self.parts() }))
    }

    /// This state, answering requests for these host names too (besides
    /// `localhost` and IP addresses; see [`HostPolicy`]).
    pub fn with_hosts(self, hosts: HostPolicy) -> Self {
        Self::build(Parts { hosts, ..self.parts() })
    }

    /// This state, logging every request (method, path, status, latency)
    /// at info level when `on`; errors are logged either way.
    pub fn with_access_log(self, on: bool) -> Self {
        Self::build(Parts { access_log: on, ..self.parts() })
    }

    /// This state, playing designs live on `output` for the page
    /// (`haptex serve --live`; [`crate::live`]).
    pub fn with_live_output(self, output: Arc<dyn LiveOutput>) -> Self {
        Self::build(Parts { live: Some(Arc::new(LiveHub::new(output))), ..self.parts() })
    }

    /// This state, its requests' device parameters starting from
    /// `device` (a device file's: `haptex serve --device-file`) instead of
    /// the paper's.
    pub fn with_default_device(self, device: crate::params::DefaultDevice) -> Self {
        Self::build(Parts { default_device: device, ..self.parts() })
    }

    /// This state, answering only requests that carry the access rules'
    /// token ([`crate::access`]).
    pub fn with_access(self, access: crate::access::Access) -> Self {
        Self::build(Parts { access, ..self.parts() })
    }

    /// Who may use the server.
    pub fn access(&self) -> &crate::access::Access {
        &self.0.parts.access
    }

    /// The device requests start from.
    pub fn default_device(&self) -> &crate::params::DefaultDevice {
        &self.0.parts.default_device
    }

    /// The state of these parts, with fresh slots and counters for its limits.
    fn build(parts: Parts) -> Self {
        let limits = &parts.limits;
        let heavy = Arc::new(Semaphore::new(limits.concurrent_heavy.max(1)));
        let renders = Arc::new(Semaphore::new(limits.concurrent_renders.max(1)));
        let simulations = Arc::new(Semaphore::new(limits.concurrent_simulations));
        Self(Arc::new(Inner {
            parts,
            heavy,
            heavy_waiting: AtomicUsize::new(0),
            renders,
            simulations,
            unsent_answer_bytes: AtomicUsize::new(0),
            clients: Arc::default(),
        }))
    }

    /// The clients' buckets and connections ([`crate::clients`]).
    pub fn clients(&self) -> &Arc<crate::clients::Clients> {
        &self.0.clients
    }

    /// The live output, if the server has one (`haptex serve --live`).
    pub fn live(&self) -> Option<&Arc<LiveHub>> {
        self.0.parts.live.as_ref()
    }

    /// SHA-256 of the texture library file served (None without a
    /// library); a writable library's changes with every upload.
    pub fn library_sha256(&self) -> Option<String> {
        self.0.parts.library.as_ref().map(|l| l.sha256())
    }

    /// Whether the library takes uploads (`haptex serve --writable`).
    pub fn library_writable(&self) -> bool {
        self.0.parts.library.as_ref().is_some_and(|l| l.writable)
    }

    /// SHA-256 of the FE database served (None without one): see
    /// [`database_sha256`].
    pub fn database_sha256(&self) -> Option<&str> {
        self.0.parts.database_sha256.as_deref()
    }

    /// The surface templates, or 404 if the server has no FE database.
    pub fn templates(&self) -> Result<&Arc<TemplateSet>, ApiError> {
        self.0
            .parts
            .templates
            .as_ref()
            .ok_or_else(|| ApiError::not_found("this server has no FE database of templates", None))
    }

    /// Whether surface templates are served.
    pub fn has_templates(&self) -> bool {
        self.0.parts.templates.is_some()
    }

    pub fn limits(&self) -> &Limits {
        &self.0.parts.limits
    }

    /// The texture library, or 404 if the server has none.
    pub fn library(&self) -> Result<&Arc<LibraryPool>, ApiError> {
        self.0.parts.library.as_ref().ok_or_else(|| ApiError::not_found("this server has no texture library", None))
    }

    /// Whether a texture library is served.
    pub fn has_library(&self) -> bool {
        self.0.parts.library.is_some()
    }

    /// The host names this server answers for.
    pub fn hosts(&self) -> &HostPolicy {
        &self.0.parts.hosts
    }

    /// Whether every request is logged.
    pub fn access_log(&self) -> bool {
        self.0.parts.access_log
    }

    /// Bounds the heavy work done at once ([`Limits::concurrent_heavy`]).
    pub fn heavy(&self) -> &Arc<Semaphore> {
        &self.0.heavy
    }

    /// Heavy requests waiting for a slot (the queue
    /// [`Limits::max_queued_heavy`] bounds).
    pub fn heavy_waiting(&self) -> usize {
        self.0.heavy_waiting.load(Ordering::Acquire)
    }

    /// The counter of [`AppState::heavy_waiting`].
    pub(crate) fn heavy_queue(&self) -> &AtomicUsize {
        &self.0.heavy_waiting
    }

    /// Bounds the number of renders running at once.
    pub fn renders(&self) -> &Arc<Semaphore> {
        &self.0.renders
    }

    /// Bounds the number of FE simulations running at once (0 permits:
    /// simulation switched off).
    pub fn simulations(&self) -> &Arc<Semaphore> {
        &self.0.simulations
    }

    /// Bytes of answers built and not yet handed to their connections (the
    /// gauge that [`Limits::max_unsent_answer_bytes`] bounds).
    pub fn unsent_answer_bytes(&self) -> usize {
        self.0.unsent_answer_bytes.load(Ordering::Acquire)
    }

    /// Counts `bytes` of a new answer, if they fit the budget (`always`:
    /// count them even if they do not); false when refused.
    pub(crate) fn reserve_answer(&self, bytes: usize, always: bool) -> bool {
        let max = self.0.parts.limits.max_unsent_answer_bytes;
        self.0
            .unsent_answer_bytes
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |held| {
                let total = held.saturating_add(bytes);
                (always || total <= max).then_some(total)
            })
            .is_ok()
    }

    /// Releases `bytes` counted by [`AppState::reserve_answer`].
    pub(crate) fn release_answer(&self, bytes: usize) {
        self.0.unsent_answer_bytes.fetch_sub(bytes, Ordering::AcqRel);
    }

    /// The profile sources available, in the order the GUI offers them.
    pub fn sources(&self) -> Vec<SourceInfo> {
        let mut sources = Vec::new();
        if self.has_templates() {
            sources.push(SourceInfo {
                id: "template",
                label: "surface template",
                description: "a bump, edge or sine surface: its friction profile predicted from the FE database by the \
                              conditional average estimator (paper sections 3.1-3.2)",
            });
        }
        if self.has_library() {
            sources.push(SourceInfo {
                id: "library",
                label: "library material",
                description: "a random stroke of a material of the texture library (paper section 2.4)",
            });
        }
        sources.push(SourceInfo {
            id: "upload",
            label: "your profile (CSV)",
            description: "a friction profile file: x_mm,mu or x_mm,ft_n,fn_n",
        });
        sources
    }
}

/// Read-only connections to the texture library. A [`Library`] is `Send`
/// but not `Sync`, so each request borrows one connection (opening one
/// when none is idle) and returns it; at most `MAX_IDLE` are kept.
///
/// A writable library (`haptex serve --writable`) is written by one upload
/// at a time ([`LibraryPool::writer`]), each through its own read-write
/// connection; readers see an upload once it has committed.
#[derive(Debug)]
pub struct LibraryPool {
    path: PathBuf,
    /// SHA-256 of the file (what a recipe records): when it was opened,
    /// and again after each upload.
    sha256: Mutex<String>,
    idle: Mutex<Vec<Library>>,
    writable: bool,
    /// One upload at a time.
    writer: Arc<Semaphore>,
}

impl LibraryPool {
    const MAX_IDLE: usize = 8;

    fn open(path: &Path) -> Result<Self, LibraryError> {
        Self::open_with(path, false)
    }

    fn open_with(path: &Path, writable: bool) -> Result<Self, LibraryError> {
        let first = Library::open_read_only(path)?;
        let sha256 = Self::hash(path)?;
        Ok(Self {
            path: path.to_path_buf(),
            sha256: Mutex::new(sha256),
            idle: Mutex::new(vec![first]),
            writable,
            writer: Arc::new(Semaphore::new(1)),
        })
    }

    fn hash(path: &Path) -> Result<String, LibraryError> {
        haptex_core::io::sha256_file(path).map_err(|e| LibraryError::Open {
            path: path.display().to_string(),
            message: format!("cannot hash it: {e}"),
        })
    }

    /// The library file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// SHA-256 of the library file, as of the last upload.
    pub fn sha256(&self) -> String {
        self.sha256.lock().map(|s| s.clone()).unwrap_or_default()
    }

    /// Whether uploads may write to the library.
    pub fn writable(&self) -> bool {
        self.writable
    }

    /// The slot of the one upload written at a time.
    pub fn writer(&self) -> &Arc<Semaphore> {
        &self.writer
    }

    /// Runs `f` with a read-write connection (on the calling thread: call
    /// it from blocking work, holding [`LibraryPool::writer`]), then
    /// settles the file and hashes it again.
    pub fn write<T>(&self, f: impl FnOnce(&mut Library) -> Result<T, ApiError>) -> Result<T, ApiError> {
        if !self.writable {
            return Err(ApiError::internal("a write to a read-only library"));
        }
        let mut library = Library::open(&self.path).map_err(ApiError::library)?;
        let result = f(&mut library);
        library.settle().map_err(ApiError::library)?;
        drop(library);
        let hash = Self::hash(&self.path).map_err(ApiError::library)?;
        if let Ok(mut sha) = self.sha256.lock() {
            *sha = hash;
        }
        result
    }

    /// Runs `f` with a connection on a blocking thread (SQLite is
    /// synchronous).
    pub async fn with<T, F>(self: &Arc<Self>, f: F) -> Result<T, ApiError>
    where
        T: Send + 'static,
        F: FnOnce(&Library) -> Result<T, ApiError> + Send + 'static,
    {
        let pool = Arc::clone(self);
        crate::work::spawn(move || {
            let library = match pool.idle.lock().map(|mut idle| idle.pop()) {
                Ok(Some(library)) => library,
                _ => Library::open_read_only(&pool.path).map_err(ApiError::library)?,
            };
            let result = f(&library);
            if let Ok(mut idle) = pool.idle.lock()
                && idle.len() < Self::MAX_IDLE
            {
                idle.push(library);
            }
            result
        })
        .await
        .map_err(|e| ApiError::internal(format!("library task failed: {e}")))?
    }
}

/// SHA-256 of an FE database directory: of the lines `NAME SHA256\n` of its
/// files (metadata.json and the template CSVs, every regular file at its
/// top level), sorted by name. Two databases with the same files give the
/// same hash wherever they are.
pub fn database_sha256(dir: &Path) -> std::io::Result<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok())
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .filter_map(|e| e.file_name().into_string().ok())
        .collect();
    names.sort();
    let mut lines = String::new();
    for name in names {
        let hash = haptex_core::io::sha256_file(&dir.join(&name))?;
        lines.push_str(&format!("{name} {hash}\n"));
    }
    Ok(haptex_core::io::sha256_hex(lines.as_bytes()))
}
