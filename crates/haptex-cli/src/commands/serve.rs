//! `haptex serve`: the web application (JSON API and GUI) on a local port.

use std::net::SocketAddr;
use std::path::PathBuf;

use clap::Args;
use haptex_server::{Config, Limits};

/// Start the haptex web application: the GUI at http://ADDR/ and the JSON
/// API under /api (described at /api/openapi.json).
///
/// The GUI shows the friction and voltage profiles of a surface template
/// (bump, edge or sine, predicted from the FE database as its sliders
/// move, or simulated by the FE model on demand), of a texture-library
/// material or of your own profile file, with the device and finger
/// constants (the paper's Fig. 2 defaults), and offers CSV, JSON and WAV
/// downloads. The default address serves this machine only; to use it
/// from a phone on the same network, listen on all interfaces with
/// --addr 0.0.0.0:8080 and open http://THIS-MACHINE'S-IP:8080/.
/// The server answers requests addressed to localhost or to an IP address
/// (a phone uses the address); to reach it by a host name, name it with
/// --allow-host (requests for other names are refused: a web page of
/// another site could otherwise reach the API by DNS rebinding).
/// The library is read-only unless --writable, which lets the GUI (and
/// POST /api/recordings) add uploaded recordings to it, as `haptex library
/// import` would (docs/web.md).
/// Access: a server that listens beyond this machine, takes uploads
/// (--writable) or drives a live output (--live) needs an access token.
/// It makes a random one at start and prints the address that carries it
/// (open it once: the page exchanges it for a session cookie); --token,
/// --token-file or $HAPTEX_TOKEN give one instead. API clients send it as
/// `Authorization: Bearer TOKEN`. A loopback-only server without
/// --writable and --live runs without one, unless given one (docs/web.md,
/// "Safety").
/// Ctrl-C stops the server after the requests in flight. Errors are
/// logged to stderr; --access-log logs every request too (RUST_LOG=debug
/// also logs every refused request with its field).
#[derive(Debug, Args)]
#[command(after_help = "Examples:\n  \
    haptex serve\n  \
    haptex serve --addr 0.0.0.0:8080   (prints the address with its access token: open it on the phone)\n  \
    HAPTEX_TOKEN=$(cat ~/.haptex-token) haptex serve --addr 0.0.0.0:8080\n  \
    haptex serve --addr 0.0.0.0:8080 --allow-host mypc.local --access-log\n  \
    haptex serve --library my-lab.sqlite --addr 127.0.0.1:9000\n  \
    haptex serve --library my-lab.sqlite --writable   (recordings uploaded in the GUI are added to it)\n  \
    haptex serve --db my-db/   (a database built by `haptex db build --out my-db`)\n  \
    haptex serve --live --device hw:CARD=USB,DEV=0 --buffer-frames 128   (the page's live panel plays on the interface)\n  \
    haptex serve --device-file my-display.toml   (the page's device starts from the calibrated display's constants)")]
pub struct ServeArgs {
    /// Address and port to listen on (0.0.0.0:PORT: every interface).
    #[arg(long, value_name = "IP:PORT", default_value = Config::DEFAULT_ADDR)]
    addr: SocketAddr,
    /// Texture library to serve (default: $HAPTEX_LIBRARY, else the shipped
    /// data/library/library.sqlite, whose 12 materials are SYNTHETIC).
    #[arg(long, value_name = "PATH")]
    library: Option<PathBuf>,
    /// Let the GUI upload recordings into the library (POST
    /// /api/recordings): it is opened for writing. Without it the library
    /// is read-only.
    #[arg(long)]
    writable: bool,
    /// FE database of surface templates to serve (default: $HAPTEX_DB, else
    /// the shipped data/db).
    #[arg(long, value_name = "DIR")]
    db: Option<PathBuf>,
    /// Also answer requests addressed to this host name (repeatable; e.g.
    /// mypc.local). localhost, *.localhost and IP addresses are always
    /// answered.
    #[arg(long = "allow-host", value_name = "NAME")]
    allow_host: Vec<String>,
    /// Log every request to stderr (method, path, status, latency); off by
    /// default, errors are logged either way.
    #[arg(long)]
    access_log: bool,
    #[command(flatten)]
    token: crate::args::TokenArgs,
    /// Serve HTTPS with this PEM certificate chain (the server's
    /// certificate first); needs --tls-key.
    #[arg(long, value_name = "CERT.pem", requires = "tls_key")]
    tls_cert: Option<PathBuf>,
    /// The PEM private key of --tls-cert's certificate (PKCS#8, PKCS#1 or SEC1).
    #[arg(long, value_name = "KEY.pem", requires = "tls_cert")]
    tls_key: Option<PathBuf>,
    /// Expensive requests (FE runs, checks, renders, maps, calibrations,
    /// uploads) one client (IP address) may send at once; beyond, and
    /// beyond --client-rate, 429 with Retry-After. Clients on this machine
    /// (loopback) are not limited.
    #[arg(long, value_name = "N", default_value_t = Limits::DEFAULT.client_expensive_burst, value_parser = client_limit)]
    client_burst: f64,
    /// Expensive requests per second one client may send after its burst.
    #[arg(long, value_name = "PER_S", default_value_t = Limits::DEFAULT.client_expensive_per_s, value_parser = client_limit)]
    client_rate: f64,
    /// Expensive requests of one client worked on at once; the next waits
    /// for one to end (up to 5 s, then 429). Below the server's 2 heavy
    /// slots, one client cannot take them all from the others.
    #[arg(long, value_name = "N", default_value_t = Limits::DEFAULT.client_concurrent as u32,
          value_parser = clap::value_parser!(u32).range(1..=1000))]
    client_concurrent: u32,
    /// Connections one client may hold open at once.
    #[arg(long, value_name = "N", default_value_t = Limits::DEFAULT.client_connections as u32,
          value_parser = clap::value_parser!(u32).range(1..=100_000))]
    client_connections: u32,
    /// Limit loopback clients too: for benchmarks and tests that use 127.0.0.x addresses as different clients.
    #[arg(long, hide = true)]
    limit_loopback_clients: bool,
    /// Play designs live on an audio output: the page's "live" panel then
    /// streams the finger's positions to this server, which renders the
    /// drive on the device (the options below are `haptex live`'s; needs a
    /// haptex built with the `live` feature; docs/live.md).
    #[arg(long)]
    live: bool,
    #[command(flatten, next_help_heading = "Live output (with --live)")]
    output: super::live::OutputArgs,
    /// The display's device file (`haptex calibrate`): the page's device
    /// fields and the API's default device start from its constants (for
    /// the default carrier, sine 1000 Hz); a request giving a constant
    /// still uses it. Recipes pin its SHA-256, and the voltage CSVs of its
    /// design name it.
    #[command(flatten)]
    device_file: crate::args::DeviceFileLongArgs,
}

pub fn run(args: ServeArgs) -> anyhow::Result<()> {
    init_logging();
    let library = args.library.unwrap_or_else(super::library::default_db);
    if !library.is_file() {
        anyhow::bail!(
            "{}: no library there; pass --library PATH (a library made by `haptex library import`)",
            library.display()
        );
    }
    let db = args.db.unwrap_or_else(super::db::default_db);
    if !db.join("metadata.json").is_file() {
        anyhow::bail!(
            "{}: no FE database there (no metadata.json); pass --db DIR (a database made by `haptex db build`)",
            db.display()
        );
    }
    let device_file = args.device_file.read()?;
    let default_device = match &device_file {
        Some(file) => crate::args::server_default(file)?,
        None => haptex_server::params::DefaultDevice::PAPER,
    };
    let live = live_output(args.live, args.output)?;
    let given = args.token.given()?;
    let mut config = Config {
        addr: args.addr,
        library: Some(library.clone()),
        writable: args.writable,
        database: Some(db.clone()),
        limits: Limits {
            client_expensive_burst: args.client_burst,
            client_expensive_per_s: args.client_rate,
            client_concurrent: args.client_concurrent as usize,
            client_connections: args.client_connections as usize,
            limit_loopback_clients: args.limit_loopback_clients,
            ..Limits::DEFAULT
        },
        allowed_hosts: args.allow_host,
        access_log: args.access_log,
        live: live.clone(),
        default_device,
        token: given.as_ref().map(|(t, _)| t.clone()),
        tls: args.tls_cert.clone().zip(args.tls_key.clone()),
    };
    let scheme = if config.tls.is_some() { "https" } else { "http" };
    let generated = config.token.is_none() && config.token_required().is_some();
    if generated {
        config.token = Some(haptex_server::access::Token::generate()?);
    }
    let token = config.token.clone();
    let why = config.token_required();
    haptex_server::run(config, |addr| {
        eprintln!(
            "haptex serve: library {} ({}), FE database {}",
            library.display(),
            if args.writable { "writable: uploaded recordings are added to it" } else { "read-only" },
            db.display()
        );
        if let Some(file) = &device_file {
            eprintln!("default device: {}", file.comment());
        }
        if let Some(output) = &live {
            let info = output.info();
            eprintln!(
                "live output: {}, {} Hz, U_max {} V, {} V per full scale{}; the page's live panel drives it",
                info.device,
                info.sample_rate_hz,
                haptex_core::num::Num(info.u_max_v),
                haptex_core::num::Num(info.volts_per_full_scale),
                info.a_max_um.map_or(String::new(), |a| format!(", channel 2 a_max {} um", haptex_core::num::Num(a)))
            );
        }
        // The address to open, with the token when there is one: printed
        // in full when made here (the only way to learn it), else with a
        // placeholder naming where it came from.
        let query = token.as_ref().map_or(String::new(), |t| {
            crate::args::TokenArgs::query(t, given.as_ref().map(|(_, source)| source.as_str()))
        });
        match (&token, why) {
            (Some(_), Some(why)) => {
                eprintln!("access token required ({why}): API clients send 'Authorization: Bearer TOKEN'")
            }
            (Some(_), None) => eprintln!("access token required: API clients send 'Authorization: Bearer TOKEN'"),
            (None, _) => eprintln!(
                "no access token: this server listens on this machine only and neither takes uploads nor drives a \
                 live output, so any program on this machine may use it (--token to require one)"
            ),
        }
        if addr.ip().is_unspecified() {
            eprintln!(
                "listening on every interface, port {}: open {scheme}://<this machine's address>:{}/{query}",
                addr.port(),
                addr.port()
            );
        } else {
            eprintln!("open {scheme}://{addr}/{query} (Ctrl-C stops)");
        }
    })?;
    eprintln!("haptex serve: stopped");
    Ok(())
}

/// The live output of `--live` (its device checked now); the live options
/// without `--live` are refused rather than ignored.
fn live_output(
    live: bool,
    output: super::live::OutputArgs,
) -> anyhow::Result<Option<std::sync::Arc<dyn haptex_server::live::LiveOutput>>> {
    if !live {
        if output != super::live::OutputArgs::defaults() {
            anyhow::bail!("the live output options (--device, --u-max, ...) are for --live: add --live");
        }
        return Ok(None);
    }
    #[cfg(feature = "live")]
    {
        Ok(Some(std::sync::Arc::new(super::live::served::ServedOutput::new(output)?)))
    }
    #[cfg(not(feature = "live"))]
    {
        anyhow::bail!(
            "--live: this haptex was built without audio output (the `live` cargo feature): build it with \
             `cargo build --release -p haptex-cli --features live` (on Linux: apt-get install libasound2-dev)"
        )
    }
}

/// Logging to stderr: RUST_LOG if set, else info for the server (errors,
/// start and stop; each request with --access-log).
fn init_logging() {
    use tracing_subscriber::EnvFilter;
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("haptex_server=info"));
    // Fails only if a subscriber is already set, which then logs instead.
    let ansi = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let _ = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).with_ansi(ansi).try_init();
}

/// A per-client limit: a finite number from 0.01 to 1e6.
fn client_limit(text: &str) -> Result<f64, String> {
    let v: f64 = text.trim().parse().map_err(|_| format!("expected a number, got '{text}'"))?;
    if v.is_finite() && (0.01..=1e6).contains(&v) {
        Ok(v)
    } else {
        Err(format!("must be from 0.01 to 1e6, got {text}"))
    }
}
