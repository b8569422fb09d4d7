//! The GUI in a real browser: Debian's headless Chromium driven through
//! chromedriver (WebDriver, the `fantoccini` crate), against the server
//! started in-process on a loopback port.
//!
//! Checks, in one browser session (starting Chromium is the slow part):
//!
//! 1. the page loads and draws the first source, a bump template predicted
//!    from the shipped FE database, without a console error (Chromium's
//!    own console log, read through chromedriver, at level SEVERE): the
//!    surface height plot peaks at the default r_h = 0.27 mm; the page
//!    opens on the electrovibration display, the paper's Fig. 2 view
//!    (issue 37); one click away, the combined display with the physical
//!    values (issue 16): the friction plot is the prediction as it is,
//!    a(x) and U(x) the core's combined design of it (split, then bias in
//!    one click); on the electrovibration display the friction plot is the server's
//!    prediction relative to its flat value
//!    (paper Fig. 2a), the voltage plot eq. (8) and eq. (9) of it side by
//!    side (Fig. 2b), each the core's mapping bit for bit, eq. (8) above
//!    0 V; unticking *relative* plots the prediction as it is and eq. (8)
//!    at 0 V everywhere (mu_HD = 1 is above it); a typed mu_flat is used,
//!    and a bad one is refused with its field marked;
//! 2. moving the width slider with the mouse changes the plotted friction
//!    and voltage (to the server's prediction at the new width); the FE
//!    model run on demand is drawn beside the estimate; dragged beyond the
//!    database range the width is flagged as an extrapolation (and the FE
//!    profile of the old width is no longer drawn);
//! 3. the library source labels its synthetic materials;
//! 4. changing controls changes the plotted voltage: method -> normalized
//!    puts the largest voltage at U_max = 100 V; typing U_max = 60 scales
//!    every plotted voltage by 0.6 (1e-12 relative: eq. 9 is linear in
//!    U_max);
//! 5. uploading a profile file plots exactly its points;
//! 6. the downloads: Chromium's own download cannot be inspected here, so
//!    the test reads the blob behind the page's download link (the bytes
//!    the browser saves) and parses the voltage CSV with haptex's CSV
//!    reader: the same numbers as the plot; the profile CSV holds the
//!    uploaded points; the stroke WAV starts with a RIFF/WAVE header;
//! 7. the feel strip: a pointer moved over it shows U(x) of the plotted
//!    profile at the pointer's x (1e-9 relative);
//! 8. a phone-sized window (390 x 844) has no horizontal scrolling;
//! 9. the check on the finger model of the default template: the friction
//!    the FE finger felt drawn beside the target, the error figures, the
//!    progress of the run; *compensate* reports every FE run while it runs,
//!    draws the felt friction of the compensated voltage (at least 3 times
//!    closer to the target than eq. (8)'s), offers it as a CSV download
//!    (within U_max) and the feel strip plays it;
//! 10. the display selector (issue 16) on a library material below mu_HD:
//!     *combined* plots a(x) beside U(x), both the core's `map_display` of
//!     the plotted profile bit for bit, and the renderable band on the
//!     friction plot; the feel strip reads a(x) at the pointer; the weighted
//!     strategy takes its weight; an uploaded calibration is the plate used,
//!     a bad one is refused naming its file, line and column; the downloads
//!     have both channels (CSV columns, a two-channel WAV with channel 2's
//!     scale); *ultrasonic* alone has no voltage plot; *electrovibration*
//!     restores the one-channel page.
//!
//! 11. compare (issue 17): designs pinned (at least four) are drawn on the
//!     same axes as the current one, each series the core's numbers for
//!     its design, named in the plot legends (P1, P2, ...) and listed with
//!     a remove button that removes exactly its series; eq. (8) and eq. (9)
//!     together (Fig. 2b) can be switched off and on; a pinned upload on
//!     another x grid keeps its own points; a pin keeps the felt friction
//!     of a current check and the amplitude a(x) of a combined design;
//! 12. accessibility: every input, select, button and focusable element
//!     shown has an accessible name (Chromium's computed label, with the
//!     template, library and upload sources and the combined display);
//!     each plot is an image described by a text summary (x range, each
//!     series' extrema); the feel strip moves with the keyboard;
//! 13. phone viewports 360 and 430 px wide: no horizontal overflow, every
//!     plot inside the viewport at the column's width, controls at least
//!     44 px tall, the feel strip follows a finger (WebDriver touch
//!     actions, Chromium with the touch events API);
//! 14. recipes: the *recipe* download of a library stroke, replayed by
//!     `haptex_server::recipe::replay` (what `haptex recipe run` runs),
//!     gives the page's voltage CSV byte for byte; its link (#design=, the
//!     design's parameters), a link of an older page (#recipe=, the whole
//!     recipe) and the file opened in the page reopen the library source
//!     and plot the replayed voltage and friction, value for value.
//! 15. recordings uploaded in the browser (issue 17): the read-only
//!     server shows no upload panel; a second server on a writable copy of
//!     the shipped library does: recordings chosen in the file input with
//!     the wrong provenance are refused (the server's message shown, nothing
//!     added), with the right one they are added and their processing
//!     report drawn (the raw forces with the sliding segments kept, one plot
//!     per recording); the new material is listed, and its stroke sampled
//!     with a seed is plotted value for value as the command line's import
//!     and sample of the same files give it.
//! 16. the map view (issue 19, /map): a grayscale PNG written here is
//!     uploaded with its gray mapping; the heat map's voltages are the
//!     core's map of that image (`FrictionMap::read_gray_png`, then
//!     `FrictionMap::voltages`: what `haptex map from-image` and `haptex
//!     map voltage` call); the pointer over the map reads U there as the
//!     core's bilinear `VoltageMap::sample`; a path drawn over the map with
//!     WebDriver pointer actions (press, drag, release) is plotted as U(t)
//!     equal, value for value (1e-12), to the core's
//!     `PlanarTrajectory::sample` of that path (what `haptex map
//!     sample-path` calls); its path and U(t) CSV downloads hold the same
//!     numbers; a 390 px window does not scroll sideways.
//!
//! It saves screenshots (desktop and phone) in the target directory;
//! with HAPTEX_UPDATE_SCREENSHOTS=1 also to docs/img/ (what docs/web.md
//! and the README show).
//!
//! Needs /usr/bin/chromium and /usr/bin/chromedriver (Debian packages
//! chromium and chromium-driver; scripts/test.sh installs them), or
//! HAPTEX_CHROMIUM / HAPTEX_CHROMEDRIVER. HAPTEX_BROWSER_TEST=skip skips
//! the test, saying so.

#[path = "common/browser.rs"]
mod browser_common;
mod common;

use std::net::{SocketAddr, TcpListener as StdListener};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use axum::http::Method;
use fantoccini::actions::{InputSource, MouseActions, PointerAction};
use fantoccini::wd::WebDriverCompatibleCommand;
use fantoccini::{Client, ClientBuilder, Locator};
use haptex_core::electrovibration::{Device, Method as MapMethod, map_profile_relative};
use haptex_core::io::Table;
use haptex_core::library::Library;
use haptex_core::profile::FrictionProfile;
use haptex_core::recording::{ProcessingConfig, Recording, process};
use haptex_core::relative::FlatMu;
use haptex_server::{AppState, Limits};
use serde_json::{Value, json};

const WAIT: Duration = Duration::from_secs(20);
/// Seed of the stroke shown in the screenshots.
const SCREENSHOT_SEED: u64 = 3;

#[test]
fn gui_in_headless_chromium() {
    if std::env::var("HAPTEX_BROWSER_TEST").as_deref() == Ok("skip") {
        eprintln!("SKIPPED: HAPTEX_BROWSER_TEST=skip: the GUI was not tested in a browser");
        return;
    }
    let chromium = tool("HAPTEX_CHROMIUM", "/usr/bin/chromium");
    let chromedriver = tool("HAPTEX_CHROMEDRIVER", "/usr/bin/chromedriver");
    let scratch = tempfile::tempdir().unwrap();
    let runtime = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().unwrap();
    runtime.block_on(async {
        let (server, stop) = start_server().await;
        let driver = Driver::start(&chromedriver, scratch.path());
        let client = connect(&driver, &chromium, scratch.path()).await;
        let result = exercise(&client, &format!("http://{server}/"), scratch.path()).await;
        // Close the browser whatever happened, then report.
        let _ = client.close().await;
        let _ = stop.send(());
        if let Err(message) = result {
            panic!("{message}\nchromedriver log: {}", driver.log_path.display());
        }
    });
}

fn tool(variable: &str, default: &str) -> PathBuf {
    let path = std::env::var_os(variable).map(PathBuf::from).unwrap_or_else(|| PathBuf::from(default));
    assert!(
        path.is_file(),
        "{} not found: install Debian's chromium and chromium-driver (bash scripts/test.sh does), set {variable}, \
         or set HAPTEX_BROWSER_TEST=skip to skip the browser test",
        path.display()
    );
    path
}

async fn start_server() -> (SocketAddr, tokio::sync::oneshot::Sender<()>) {
    let (state, _) = app_state();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    tokio::spawn(haptex_server::serve(listener, state, async {
        let _ = stopped.await;
    }));
    (addr, stop)
}

/// chromedriver on a free loopback port, killed when dropped.
struct Driver {
    child: Child,
    port: u16,
    log_path: PathBuf,
}

impl Driver {
    fn start(chromedriver: &Path, scratch: &Path) -> Self {
        let port = StdListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let log_path = scratch.join("chromedriver.log");
        let child = Command::new(chromedriver)
            .arg(format!("--port={port}"))
            .arg(format!("--log-path={}", log_path.display()))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {}: {e}", chromedriver.display()));
        let driver = Self { child, port, log_path };
        let start = Instant::now();
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(start.elapsed() < WAIT, "chromedriver did not listen on port {port} within {WAIT:?}");
            std::thread::sleep(Duration::from_millis(50));
        }
        driver
    }
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

async fn connect(driver: &Driver, chromium: &Path, scratch: &Path) -> Client {
    let profile = scratch.join("chromium-profile");
    let downloads = scratch.join("downloads");
    std::fs::create_dir_all(&downloads).unwrap();
    let capabilities = json!({
        "browserName": "chrome",
        "goog:chromeOptions": {
            "binary": chromium,
            "args": [
                "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-dev-shm-usage",
                // The touch events API, as on a phone: the feel strip's touch handlers are tested.
                "--touch-events=enabled",
                format!("--user-data-dir={}", profile.display()), "--window-size=1280,1000",
            ],
            "prefs": { "download.default_directory": downloads, "download.prompt_for_download": false },
        },
        "goog:loggingPrefs": { "browser": "ALL" },
    });
    let Value::Object(capabilities) = capabilities else { unreachable!() };
    let connector = hyper_util::client::legacy::connect::HttpConnector::new();
    ClientBuilder::new(connector)
        .capabilities(capabilities)
        .connect(&format!("http://127.0.0.1:{}", driver.port))
        .await
        .expect("a WebDriver session with chromedriver")
}

/// chromedriver's browser console log (entries since the last call).
#[derive(Debug)]
struct BrowserLog;

impl WebDriverCompatibleCommand for BrowserLog {
    fn endpoint(&self, base_url: &url::Url, session_id: Option<&str>) -> Result<url::Url, url::ParseError> {
        base_url.join(&format!("session/{}/se/log", session_id.unwrap_or_default()))
    }

    fn method_and_body(&self, _: &url::Url) -> (Method, Option<String>) {
        (Method::POST, Some(r#"{"type": "browser"}"#.to_string()))
    }
}

type Check<T> = Result<T, String>;

fn fail<T>(message: impl Into<String>) -> Check<T> {
    Err(message.into())
}

macro_rules! wd {
    ($e:expr) => {
        $e.await.map_err(|e| format!("{}: {e}", stringify!($e)))?
    };
}

/// Console messages at level SEVERE since the last call.
async fn console_errors(client: &Client) -> Check<Vec<String>> {
    let entries = wd!(client.issue_cmd(BrowserLog));
    Ok(entries
        .as_array()
        .map(|a| a.as_slice())
        .unwrap_or_default()
        .iter()
        .filter(|e| e["level"] == "SEVERE")
        .map(|e| e["message"].as_str().unwrap_or_default().to_string())
        .collect())
}

async fn script(client: &Client, code: &str) -> Check<Value> {
    Ok(wd!(client.execute(code, vec![])))
}

/// Waits until `code` (a JS expression) is truthy.
async fn wait_for(client: &Client, code: &str, what: &str) -> Check<()> {
    let start = Instant::now();
    loop {
        let value = script(client, &format!("return Boolean({code});")).await?;
        if value == Value::Bool(true) {
            return Ok(());
        }
        if start.elapsed() > WAIT {
            let message = script(client, "return document.getElementById('message').textContent;").await?;
            return fail(format!("timed out waiting for {what} ({code}); the page says: {message}"));
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

async fn updates(client: &Client) -> Check<u64> {
    let value = script(client, "return Number(document.body.dataset.updates);").await?;
    value.as_u64().ok_or_else(|| format!("data-updates is {value}"))
}

async fn wait_update(client: &Client, after: u64, what: &str) -> Check<()> {
    wait_for(client, &format!("Number(document.body.dataset.updates) > {after}"), what).await
}

fn numbers(value: &Value) -> Check<Vec<f64>> {
    value
        .as_array()
        .ok_or_else(|| format!("not an array: {value}"))?
        .iter()
        .map(|v| v.as_f64().ok_or_else(|| format!("not a number: {v}")))
        .collect()
}

/// The data the uPlot chart `name` draws: [x, series 1, ...].
async fn plotted(client: &Client, name: &str) -> Check<Vec<Vec<f64>>> {
    let data = script(client, &format!("return window.haptex.plots.{name}.data;")).await?;
    data.as_array().ok_or("no plot data")?.iter().map(numbers).collect()
}

/// Clicks a download button and returns the bytes behind the page's
/// download link (the blob the browser saves).
async fn download(client: &Client, kind: &str) -> Check<Vec<u8>> {
    let before = script(client, "return Number(document.getElementById('download-link').dataset.count || 0);").await?;
    let before = before.as_u64().unwrap_or(0);
    wd!(wd!(client.find(Locator::Css(&format!("[data-download='{kind}']")))).click());
    let link = "document.getElementById('download-link')";
    wait_for(
        client,
        &format!("Number({link}.dataset.count || 0) > {before} && {link}.dataset.kind === '{kind}'"),
        kind,
    )
    .await?;
    let fetch = format!(
        "const done = arguments[arguments.length - 1];
         fetch({link}.href).then(r => r.arrayBuffer()).then(b => done(Array.from(new Uint8Array(b))))
           .catch(e => done('error: ' + e));"
    );
    let bytes = wd!(client.execute_async(&fetch, vec![]));
    bytes
        .as_array()
        .ok_or_else(|| format!("fetching the download blob failed: {bytes}"))?
        .iter()
        .map(|b| b.as_u64().map(|b| b as u8).ok_or_else(|| format!("not a byte: {b}")))
        .collect()
}

/// The friction profile the server predicts for a bump (POST /api/predict
/// from inside the page).
async fn predicted_bump(client: &Client, width_mm: f64) -> Check<Vec<f64>> {
    let fetch = format!(
        "const done = arguments[arguments.length - 1];
         fetch('/api/predict', {{ method: 'POST', headers: {{ 'Content-Type': 'application/json' }},
           body: JSON.stringify({{ surface: 'bump', x0_mm: 5, width_mm: {width_mm}, height_mm: 0.27, velocity_mm_s: 20 }}) }})
           .then(r => r.json()).then(a => done(a.mu)).catch(e => done('error: ' + e));"
    );
    numbers(&wd!(client.execute_async(&fetch, vec![])))
}

/// The series labels of the uPlot chart `name` (after the x axis).
async fn labels(client: &Client, name: &str) -> Check<Vec<String>> {
    let value =
        script(client, &format!("return window.haptex.plots.{name}.series.slice(1).map(s => s.label);")).await?;
    Ok(value.as_array().ok_or("no series")?.iter().map(|v| v.as_str().unwrap_or_default().to_string()).collect())
}

/// Whether the friction plot draws the FE model's profile.
const FE_DRAWN: &str = "window.haptex.plots.friction.series.some(s => s.label === 'μ FE model')";

/// The profile relative to its flat value as the server makes it (paper
/// Fig. 2a): mu / mu_flat * mu_HD.
fn relative(mu: &[f64], flat_mu: f64, mu_hd: f64) -> Vec<f64> {
    mu.iter().map(|m| m / flat_mu * mu_hd).collect()
}

/// Eq. (8) and eq. (9) of a bump's predicted profile mapped relative to
/// `flat_mu` with the paper's device, by the core (what `haptex voltage
/// --relative` computes).
fn core_relative_voltages(x: &[f64], mu: &[f64], flat_mu: f64) -> (Vec<f64>, Vec<f64>) {
    let profile = FrictionProfile::new(x.to_vec(), mu.to_vec()).unwrap();
    let map = |method| {
        map_profile_relative(&profile, &Device::PAPER, method, None, FlatMu::Given(flat_mu)).unwrap().voltage_v
    };
    (map(MapMethod::Physical), map(MapMethod::Normalized))
}

/// Types `text` into the input `id` (cleared first).
async fn type_into(client: &Client, id: &str, text: &str) -> Check<()> {
    let input = wd!(client.find(Locator::Id(id)));
    wd!(input.clear());
    wd!(input.send_keys(text));
    Ok(())
}

/// Clicks the width slider at `fraction` of its length (0 = left end).
async fn click_slider(client: &Client, id: &str, fraction: f64) -> Check<()> {
    let slider = wd!(client.find(Locator::Id(id)));
    let width =
        script(client, &format!("return document.getElementById('{id}').getBoundingClientRect().width;")).await?;
    let x = (fraction - 0.5) * width.as_f64().ok_or("slider width")?;
    let click = MouseActions::new("mouse".into())
        .then(PointerAction::MoveToElement { element: slider, duration: Some(Duration::from_millis(30)), x, y: 0.0 })
        .then(PointerAction::Down { button: fantoccini::actions::MOUSE_BUTTON_LEFT })
        .then(PointerAction::Up { button: fantoccini::actions::MOUSE_BUTTON_LEFT });
    wd!(client.perform_actions(click));
    wd!(client.release_actions());
    Ok(())
}

/// Step 1, one click from the page's first design: the combined display
/// (issue 16; the page opened on it until issue 37), the template with its
/// physical values: the friction plot is the server's
/// prediction as it is (all of it below mu_HD = 1), a(x) and U(x) are the
/// core's `map_display` of it on the literature plate with the split
/// strategy bit for bit, nothing is outside the band, the page says why U
/// is 0 V and offers the bias strategy, which puts the detail on U.
async fn combined_default(client: &Client, friction: &[Vec<f64>], predicted: &[f64]) -> Check<()> {
    use haptex_core::combined::{Channels, Strategy, map_display};
    use haptex_core::ultrasonic::UltrasonicDevice;

    let shown = script(
        client,
        "return [window.haptex.state.voltage.summary.display, window.haptex.state.voltage.summary.strategy, \
         document.querySelector(\"input[name='display'][value='combined']\").checked, \
         window.haptex.state.relative, window.haptex.state.both];",
    )
    .await?;
    if shown != json!(["combined", "split", true, false, false]) {
        return fail(format!("the combined display shows [display, strategy, radio, relative, both] = {shown}"));
    }
    if friction[1] != predicted {
        return fail("on the combined display the template's friction is not the prediction as it is");
    }
    let profile = FrictionProfile::new(friction[0].clone(), predicted.to_vec()).map_err(|e| e.to_string())?;
    let plate = UltrasonicDevice::literature_default(None).map_err(|e| e.to_string())?;
    let design = |strategy| {
        map_display(&profile, &Device::PAPER, Channels::Combined(&plate, strategy), None, None)
            .map_err(|e| e.to_string())
    };
    let core = design(Strategy::Split)?;
    let (amplitude, voltage) = (plotted(client, "amplitude").await?, plotted(client, "voltage").await?);
    if Some(&amplitude[1]) != core.amplitude_um.as_ref() || Some(&voltage[1]) != core.voltage_v.as_ref() {
        return fail("the default template's plotted a(x) or U(x) is not the core's combined design");
    }
    let s = &core.summary;
    if s.below_band.fraction_of_length != 0.0 || s.above_band.fraction_of_length != 0.0 {
        return fail(format!("the default bump is not inside the combined band: {s:?}"));
    }
    if !amplitude[1].iter().any(|a| *a > 0.0) || voltage[1].iter().any(|u| *u != 0.0) {
        return fail("split below mu_HD: the plate should carry all of the bump and U be 0 V");
    }
    let note = wd!(wd!(client.find(Locator::Id("summary-plate-only"))).text());
    if !note.contains("below mu_HD everywhere") {
        return fail(format!("the plate-only note says {note:?}"));
    }
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("way-out-bias"))).click());
    wait_update(client, n, "the bias strategy").await?;
    wait_for(client, "window.haptex.state.voltage.summary.strategy === 'bias'", "the bias design").await?;
    let biased = design(Strategy::Bias)?;
    let (amplitude, voltage) = (plotted(client, "amplitude").await?, plotted(client, "voltage").await?);
    if Some(&amplitude[1]) != biased.amplitude_um.as_ref() || Some(&voltage[1]) != biased.voltage_v.as_ref() {
        return fail("bias: the plotted a(x) or U(x) is not the core's");
    }
    if !voltage[1].iter().any(|u| *u > 0.0) {
        return fail("bias: the voltage carries none of the bump");
    }
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css("#strategy option[value='split']"))).click());
    wait_update(client, n, "the split strategy again").await?;

    // The check on the finger model applies the combined design: the
    // finger on the plate vibrating with a(x) under U(x) (the compensation
    // is the electrovibration display's).
    let buttons = "return [document.getElementById('run-check').disabled, \
                   document.getElementById('run-compensate').disabled];";
    if script(client, buttons).await? != json!([false, true]) {
        return fail("combined: the check should be offered and the compensation not");
    }
    wd!(wd!(client.find(Locator::Id("run-check"))).click());
    let state = "window.haptex.state";
    wait_for(client, &format!("{state}.check && {state}.check.result.design"), "the combined check's result").await?;
    wait_for(client, "!document.getElementById('check-results').hidden", "the combined check's plots").await?;
    let result = script(client, &format!("return {state}.check.result;")).await?;
    let (check, friction) = (plotted(client, "check").await?, plotted(client, "friction").await?);
    let (amplitude, voltage) = (plotted(client, "amplitude").await?, plotted(client, "voltage").await?);
    let design = &result["design"];
    if check[1] != friction[1] || check[2] != numbers(&design["felt_mu"])? {
        return fail("combined check: the plot is not the target plotted above and the friction the finger felt");
    }
    if numbers(&design["voltage_v"])? != voltage[1] || numbers(&design["amplitude_um"])? != amplitude[1] {
        return fail("combined check: the design applied is not the U(x) and a(x) plotted");
    }
    let summary = wd!(wd!(client.find(Locator::Id("check-summary"))).text());
    if !summary.contains("combined display's band")
        || !labels(client, "check").await?.iter().any(|l| l == "felt, combined")
    {
        return fail(format!("combined check: the summary says {summary:?}"));
    }
    Ok(())
}

/// Step 1's checks of the relative mapping (issue 15), on the default
/// bump whose prediction is `predicted` at positions `x`.
async fn relative_fig2(client: &Client, x: &[f64], predicted: &[f64]) -> Check<()> {
    // Eq. (8) and eq. (9) side by side, both of the relative profile.
    let shown = labels(client, "voltage").await?;
    if shown != ["U eq. (8)", "U eq. (9)", "U_max"] {
        return fail(format!("the template's voltage plot shows {shown:?}, not eq. (8) beside eq. (9)"));
    }
    let voltage = plotted(client, "voltage").await?;
    let (eq8, eq9) = core_relative_voltages(x, predicted, 0.5);
    if voltage[1] != eq8 || voltage[2] != eq9 {
        return fail("the plotted eq. (8) and eq. (9) are not the core's relative mapping with mu_flat = 0.5");
    }
    let peak = eq8.iter().cloned().fold(0.0, f64::max);
    if !(peak > 0.0 && peak <= 100.0) {
        return fail(format!("relative eq. (8) of the default bump peaks at {peak} V"));
    }
    let note = wd!(wd!(client.find(Locator::Id("relative-info"))).text());
    if !note.contains("FE finger's skin friction") {
        return fail(format!("the relative note does not say mu_flat is the FE skin friction: {note:?}"));
    }

    // Unticked: the profile as it is, all below mu_HD = 1, so eq. (8) is
    // 0 V everywhere; eq. (9) sees the same pattern (1e-12 relative).
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("relative"))).click());
    wait_update(client, n, "the voltage without the relative mapping").await?;
    wait_for(client, "window.haptex.state.voltage.summary.relative === undefined", "the raw mapping").await?;
    let (friction, raw) = (plotted(client, "friction").await?, plotted(client, "voltage").await?);
    if friction[1] != predicted || raw[1].iter().any(|&u| u != 0.0) {
        return fail("without relative: the friction plot is not the prediction, or eq. (8) is not 0 V everywhere");
    }
    if raw[2].iter().zip(&eq9).any(|(a, b)| (a - b).abs() > 1e-12 * b.max(1.0)) {
        return fail("eq. (9) changed with the relative mapping: it should see the same pattern");
    }

    // Ticked again with a typed mu_flat of 0.45: the core's numbers for it.
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("relative"))).click());
    type_into(client, "flat-mu", "0.45").await?;
    wait_update(client, n, "the voltage with mu_flat = 0.45").await?;
    wait_for(client, "window.haptex.state.voltage.summary.relative?.flat_mu === 0.45", "mu_flat = 0.45").await?;
    let typed = plotted(client, "voltage").await?;
    if typed[1] != core_relative_voltages(x, predicted, 0.45).0 {
        return fail("eq. (8) with mu_flat = 0.45 is not the core's");
    }
    // A bad mu_flat: refused as typed beside the field (issue 37), in the
    // page's words, the field marked, nothing redrawn.
    type_into(client, "flat-mu", "0").await?;
    wait_for(client, "document.getElementById('flat-mu').getAttribute('aria-invalid') === 'true'", "flat_mu refused")
        .await?;
    let message = wd!(wd!(client.find(Locator::Id("flat-mu-error"))).text());
    if !message.starts_with("Flat-surface friction μ_flat must be from 0.001 to 10") {
        return fail(format!("a bad mu_flat is reported as {message:?}"));
    }
    // Refused before it is sent: no request, so nothing in the console.
    let logged = console_errors(client).await?;
    if !logged.is_empty() {
        return fail(format!("console after a bad mu_flat: {logged:#?}"));
    }
    let n = updates(client).await?;
    type_into(client, "flat-mu", "0.5").await?;
    wait_update(client, n, "the voltage with mu_flat = 0.5 again").await?;
    wait_for(client, "window.haptex.state.voltage.summary.relative?.flat_mu === 0.5", "mu_flat = 0.5").await?;
    if plotted(client, "voltage").await?[1] != eq8 {
        return fail("back at mu_flat = 0.5 the plotted eq. (8) differs from before");
    }
    Ok(())
}

/// The plot legends from the keyboard (issue 17): the voltage plot's
/// second series (eq. 9) is reached with Tab, hidden with Enter and shown
/// again with Space, its aria-pressed following.
async fn legend_keyboard(client: &Client) -> Check<()> {
    let entry = "document.querySelectorAll('#voltage-plot .u-legend tr.u-series')[2].querySelector('th')";
    let state = format!("return [window.haptex.plots.voltage.series[2].show, {entry}.getAttribute('aria-pressed')];");
    if script(client, &state).await? != json!([true, "true"]) {
        return fail("the voltage plot's eq. (9) entry is not a shown toggle");
    }
    // Focus the entry before it, then Tab to it (the browser's own focus order).
    script(
        client,
        "document.querySelectorAll('#voltage-plot .u-legend tr.u-series')[1].querySelector('th').focus(); return true;",
    )
    .await?;
    let active = wd!(client.active_element());
    wd!(active.send_keys("\u{E004}")); // Tab
    let focused = script(client, &format!("return document.activeElement === {entry};")).await?;
    if focused != Value::Bool(true) {
        return fail("Tab from the first legend entry does not reach the second");
    }
    wd!(wd!(client.active_element()).send_keys("\u{E007}")); // Enter
    if script(client, &state).await? != json!([false, "false"]) {
        return fail("Enter on a legend entry does not hide its series");
    }
    wd!(wd!(client.active_element()).send_keys(" "));
    if script(client, &state).await? != json!([true, "true"]) {
        return fail("Space on a hidden legend entry does not show its series again");
    }
    Ok(())
}

/// The model section, opened: eq. (8) with the Fig. 2 constant physics.md
/// quotes, the shipped finger's dermis modulus, the finger file with its
/// sources and the database's leave-one-out errors.
async fn model_section(client: &Client) -> Check<()> {
    wait_for(client, "document.querySelectorAll('#model-body table').length >= 6", "the model section's tables")
        .await?;
    wd!(wd!(client.find(Locator::Css("#model-box > summary"))).click());
    let text = wd!(wd!(client.find(Locator::Id("model-body"))).text());
    let dermis = haptex_fem::finger::FingerModel::default_model().materials.dermis.e_mpa;
    for expected in [
        "U = sqrt(50217.6 (mu_RS/mu_HD - 1)) V".to_string(),
        "U(x) = U_max sqrt((mu_RS(x) - min mu_RS) / (max mu_RS - min mu_RS))".to_string(),
        format!("dermis {dermis} 0.48"),
        "LOO RMSE".to_string(),
    ] {
        if !text.contains(&expected) {
            return fail(format!("the model section does not show {expected:?}: {text}"));
        }
    }
    let file = script(client, "return document.getElementById('model-finger-file').textContent;").await?;
    if !file.as_str().is_some_and(|f| f.contains("Provenance") && f.contains("Pawluk")) {
        return fail("the model section does not show the finger file with its sources");
    }
    Ok(())
}

async fn exercise(client: &Client, base: &str, scratch: &Path) -> Check<()> {
    // 1. Load: the first source is the template, the default bump drawn.
    wd!(client.goto(base));
    wait_for(client, "document.body.dataset.state === 'ready'", "the first plot").await?;
    let errors = console_errors(client).await?;
    if !errors.is_empty() {
        return fail(format!("console errors on load: {errors:#?}"));
    }
    wait_for(client, "window.haptex.plots.height !== null", "the surface height plot").await?;
    let height = plotted(client, "height").await?;
    let peak = height[1].iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if (peak - 0.27).abs() > 1e-12 {
        return fail(format!("the default bump's plotted height peaks at {peak} mm, not r_h = 0.27 mm"));
    }
    // The page opens on the electrovibration display (issue 37): the
    // template relative to its flat value, eq. (8) beside eq. (9), as the
    // paper's Fig. 2.
    let shown = script(
        client,
        "return [window.haptex.state.display, window.haptex.state.relative, window.haptex.state.both, \
         document.querySelector(\"input[name='display'][value='electrovibration']\").checked];",
    )
    .await?;
    if shown != json!(["electrovibration", true, true, true]) {
        return fail(format!("the page opens on [display, relative, both, radio] = {shown}"));
    }
    // The message names the estimator the database serves (the grid for
    // the shipped one), not always the CAE.
    let message = wd!(wd!(client.find(Locator::Id("message"))).text());
    if !message.starts_with("bump r_w 1.3 mm, r_h 0.27 mm, 20 mm/s (grid)") {
        return fail(format!("the message does not name the grid estimate: {message:?}"));
    }
    let predicted = predicted_bump(client, 1.3).await?;
    // One click away: the combined display, with the template's physical values.
    choose(client, "display", "combined").await?;
    let friction = plotted(client, "friction").await?;
    combined_default(client, &friction, &predicted).await?;
    choose(client, "display", "electrovibration").await?;
    wait_for(client, "window.haptex.state.voltage.summary.relative !== undefined", "the relative mapping").await?;
    let friction = plotted(client, "friction").await?;
    if friction[1] != relative(&predicted, 0.5, 1.0) {
        return fail(
            "the plotted friction is not the server's prediction for the default bump over its flat value 0.5",
        );
    }
    relative_fig2(client, &friction[0], &predicted).await?;
    legend_keyboard(client).await?;
    model_section(client).await?;
    let named = accessible_names(client, "the template source").await?;
    if named < 30 {
        return fail(format!("only {named} controls shown with the template source"));
    }
    compare_designs(client, &friction[0]).await?;

    // 2. The width slider, moved with the mouse, changes the plotted voltage.
    let before = plotted(client, "voltage").await?;
    let n = updates(client).await?;
    click_slider(client, "template-width_mm", 0.8).await?;
    wait_update(client, n, "the voltage after moving the width slider").await?;
    wait_for(
        client,
        "window.haptex.state.drawn.label.startsWith('bump r_w ') && window.haptex.state.template.width_mm !== 1.3",
        "the new width drawn",
    )
    .await?;
    let width = script(client, "return window.haptex.state.template.width_mm;").await?;
    let width = width.as_f64().ok_or("template width")?;
    if !(1.5..=2.5).contains(&width) {
        return fail(format!("clicking the width slider at 80% gave r_w = {width} mm"));
    }
    let after = plotted(client, "voltage").await?;
    if after[1] == before[1] {
        return fail("moving the width slider did not change the plotted voltage");
    }
    let friction = plotted(client, "friction").await?;
    let predicted = predicted_bump(client, width).await?;
    if friction[1] != relative(&predicted, 0.5, 1.0) {
        return fail(format!("the plotted friction is not the server's prediction for r_w = {width} mm over 0.5"));
    }
    // The FE model on demand for these parameters: its profile is drawn
    // beside the estimate (on the same relative scale), within 0.1 of it
    // everywhere in Ft/Fn (the estimate's worst random member was off by
    // 0.011 RMS, docs/database.md).
    wd!(wd!(client.find(Locator::Id("run-fe"))).click());
    wait_for(client, FE_DRAWN, "the FE profile in the friction plot").await?;
    let with_fe = plotted(client, "friction").await?;
    let fe = numbers(&script(client, "return window.haptex.state.fe.mu;").await?)?;
    if with_fe.last() != Some(&relative(&fe, 0.5, 1.0)) || with_fe[1] != friction[1] {
        return fail("the friction plot does not show the estimate and the FE profile just run");
    }
    let worst = fe.iter().zip(&predicted).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let info = wd!(wd!(client.find(Locator::Id("fe-info"))).text());
    if worst > 0.1 || !info.contains("RMS") {
        return fail(format!("FE vs CAE: largest difference {worst}; the note says {info:?}"));
    }
    let n = updates(client).await?;
    click_slider(client, "template-width_mm", 0.995).await?;
    wait_update(client, n, "the voltage at the slider's end").await?;
    wait_for(client, "window.haptex.state.drawn.extrapolation === true", "the extrapolated profile drawn").await?;
    if labels(client, "friction").await?.iter().any(|l| l == "μ FE model") {
        return fail("the FE profile of the previous width is still drawn");
    }
    let flagged = script(
        client,
        "return document.getElementById('template-width_mm').parentElement.classList.contains('outside') && \
         document.getElementById('template-info').textContent.includes('Extrapolation');",
    )
    .await?;
    if flagged != Value::Bool(true) {
        return fail("a width beyond the FE database is not flagged as an extrapolation");
    }

    // 3. The library: synthetic materials are labelled.
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css("input[name='source'][value='library']"))).click());
    wait_update(client, n, "the first library material").await?;
    wait_for(client, "window.haptex.plots.height === null", "the height plot gone for a material").await?;
    let material_info = wd!(wd!(client.find(Locator::Id("material-info"))).text());
    if !material_info.contains("SYNTHETIC") {
        return fail(format!("a synthetic material is not labelled as such: {material_info:?}"));
    }
    accessible_names(client, "the library source").await?;

    // 4. Controls change the plotted voltage.
    let before = plotted(client, "voltage").await?;
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css("input[name='method'][value='normalized']"))).click());
    wait_update(client, n, "the voltage after choosing the normalized method").await?;
    let normalized = plotted(client, "voltage").await?;
    let max = normalized[1].iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if max != 100.0 || normalized[1] == before[1] {
        return fail(format!("normalized method: largest plotted voltage {max} V, expected U_max = 100 V"));
    }
    let n = updates(client).await?;
    let u_max = wd!(client.find(Locator::Id("param-u_max_v")));
    wd!(u_max.clear());
    wd!(u_max.send_keys("60"));
    wait_for(client, "window.haptex.state.voltage.summary.u_max_v === 60", "U_max = 60 V").await?;
    wait_update(client, n, "the voltage after typing U_max").await?;
    let scaled = plotted(client, "voltage").await?;
    for (u60, u100) in scaled[1].iter().zip(&normalized[1]) {
        if (u60 - 0.6 * u100).abs() > 1e-12 * u100.max(1.0) {
            return fail(format!("U_max 100 -> 60 V should scale every voltage by 0.6: {u100} -> {u60}"));
        }
    }

    // 4b. Every parameter explained where it is set (GET /api/config,
    // explanations): d_sc shows its symbol, unit, typical range and source,
    // and turns to the warning style outside 0.2 .. 0.3 mm; the page's
    // messages name its controls, not command-line flags.
    let explained = script(client, "return document.querySelectorAll('p.explain').length;").await?;
    // 13 of eq. (3)-(9), the mapping and playback, and the display's a_max and weight.
    if explained != 15 {
        return fail(format!("{explained} parameters explained in the page, expected 15"));
    }
    let label = wd!(wd!(client.find(Locator::Css("label[for='param-mu_hd']"))).text());
    if !label.starts_with("μ_HD") {
        return fail(format!("the friction of the display is labelled {label:?}, not with the paper's μ_HD"));
    }
    let d_sc = "document.getElementById('explain-d_sc_mm')";
    let note = wd!(wd!(client.find(Locator::Id("explain-d_sc_mm"))).text());
    let outside = format!(
        "{d_sc}.classList.contains('outside') && document.getElementById('param-d_sc_mm').classList.contains('outside')"
    );
    if !note.contains("d_sc (mm)") || !note.contains("Typical 0.2 .. 0.3 mm") || !note.contains("physics notes") {
        return fail(format!("d_sc's explanation: {note:?}"));
    }
    if script(client, &format!("return {outside};")).await? != Value::Bool(false) {
        return fail("d_sc = 0.2 mm (the paper's) is flagged outside its typical range");
    }
    let n = updates(client).await?;
    type_into(client, "param-d_sc_mm", "0.5").await?;
    wait_for(client, &outside, "d_sc = 0.5 mm in the warning style").await?;
    wait_update(client, n, "the voltage after typing d_sc").await?;
    let note = wd!(wd!(client.find(Locator::Id("explain-d_sc_mm"))).text());
    if !note.contains("Outside the typical range 0.2 .. 0.3 mm") {
        return fail(format!("d_sc = 0.5 mm: the explanation says {note:?}"));
    }
    let n = updates(client).await?;
    type_into(client, "param-d_sc_mm", "0.2").await?;
    wait_for(client, &format!("!({outside})"), "d_sc = 0.2 mm back in the plain style").await?;
    wait_update(client, n, "the voltage after restoring d_sc").await?;
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css("input[name='method'][value='physical']"))).click());
    wait_update(client, n, "the voltage after choosing the physical method").await?;
    let summary = wd!(wd!(client.find(Locator::Id("summary"))).text());
    // The library's materials lie below mu_HD = 1 (physical, not relative):
    // the issue's "lower --mu-hd or use --method normalized", now in the
    // page's words.
    if summary.contains("--") || !summary.contains("lower mu_HD (Device and finger)") {
        return fail(format!("the summary does not name the page's controls: {summary:?}"));
    }
    // Among the ways out of the 0 V line, the combined display.
    if wd!(client.find_all(Locator::Id("way-out-combined"))).len() != 1 {
        return fail("the 0 V line offers no one-click way to the combined display");
    }
    // ... and a 0 V line comes with its one-click way out: relative to the
    // profile's flat-surface friction (its median), which gives a signal.
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("way-out-relative"))).click());
    wait_update(client, n, "the voltage after the one-click relative mapping").await?;
    wait_for(client, "window.haptex.state.voltage.summary.relative !== undefined", "the relative mapping").await?;
    let voltage = plotted(client, "voltage").await?;
    if !voltage[1].iter().any(|u| *u > 0.0) || !wd!(wd!(client.find(Locator::Id("relative"))).is_selected()) {
        return fail("the one-click relative mapping did not tick relative and give a voltage above 0 V");
    }
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("relative"))).click());
    wait_update(client, n, "the voltage after unticking relative").await?;
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css("input[name='method'][value='normalized']"))).click());
    wait_update(client, n, "the voltage after choosing the normalized method again").await?;

    // 5. Upload a profile file: its points are plotted.
    let x: Vec<f64> = (0..9).map(|i| 0.5 * i as f64).collect();
    let mu = [1.0, 1.05, 1.2, 1.4, 1.3, 1.1, 1.0, 1.02, 1.0];
    let mut csv = String::from("# browser test profile\nx_mm,mu\n");
    for (x, mu) in x.iter().zip(mu) {
        csv.push_str(&format!("{x},{mu}\n"));
    }
    let file = scratch.join("my-profile.csv");
    std::fs::write(&file, &csv).unwrap();
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css("input[name='source'][value='upload']"))).click());
    wd!(wd!(client.find(Locator::Id("upload"))).send_keys(&file.display().to_string()));
    wait_update(client, n, "the plot of the uploaded profile").await?;
    wait_for(client, "window.haptex.state.voltage.x_mm.length === 9", "the uploaded profile's 9 points").await?;
    let friction = plotted(client, "friction").await?;
    if friction[0] != x || friction[1] != mu {
        return fail(format!("uploaded profile plotted as {:?} / {:?}", friction[0], friction[1]));
    }
    let voltage = plotted(client, "voltage").await?;
    if voltage[1].iter().cloned().fold(0.0, f64::max) != 60.0 || voltage[1][0] != 0.0 {
        return fail(format!("normalized voltage of the upload: {:?}", voltage[1]));
    }
    let info = wd!(wd!(client.find(Locator::Id("upload-info"))).text());
    if !info.contains("my-profile.csv") || !info.contains("9 points") {
        return fail(format!("upload info: {info:?}"));
    }
    accessible_names(client, "the upload source").await?;

    // 6. Downloads: the blobs behind the download link.
    let bytes = download(client, "voltage-csv").await?;
    let table = Table::read(bytes.as_slice(), "downloaded voltage.csv").map_err(|e| e.to_string())?;
    if table.columns() != ["x_mm", "mu", "voltage_v"] {
        return fail(format!("voltage CSV columns {:?}", table.columns()));
    }
    for (column, want) in [("x_mm", &voltage[0]), ("mu", &friction[1]), ("voltage_v", &voltage[1])] {
        if table.column(column).unwrap() != want.as_slice() {
            return fail(format!("downloaded {column} differs from the plot: {:?}", table.column(column)));
        }
    }
    let bytes = download(client, "profile-csv").await?;
    let table = Table::read(bytes.as_slice(), "downloaded profile.csv").map_err(|e| e.to_string())?;
    if table.column("x_mm") != Some(x.as_slice()) || table.column("mu") != Some(mu.as_slice()) {
        return fail("downloaded profile CSV differs from the uploaded file");
    }
    let wav = download(client, "stroke-wav").await?;
    if wav.len() < 44 || &wav[..4] != b"RIFF" || &wav[8..12] != b"WAVE" {
        return fail(format!("stroke WAV download is not a WAV file ({} bytes)", wav.len()));
    }
    let json = download(client, "voltage-json").await?;
    let answer: Value = serde_json::from_slice(&json).map_err(|e| format!("voltage JSON download: {e}"))?;
    if numbers(&answer["voltage_v"])? != voltage[1] {
        return fail("voltage JSON download differs from the plot");
    }

    // 7. The feel strip: U at the pointer.
    let strip = wd!(client.find(Locator::Id("feel-strip")));
    let width = script(client, "return document.getElementById('feel-strip').getBoundingClientRect().width;").await?;
    let width = width.as_f64().ok_or("strip width")?;
    let offset = 0.3 * width; // from the centre: x at 80% of the span
    let moves = MouseActions::new("mouse".into()).then(PointerAction::MoveToElement {
        element: strip,
        duration: Some(Duration::from_millis(50)),
        x: offset,
        y: 0.0,
    });
    wd!(client.perform_actions(moves));
    wait_for(client, "document.getElementById('feel-readout').dataset.voltageV !== undefined", "the feel readout")
        .await?;
    let read = script(
        client,
        "const d = document.getElementById('feel-readout').dataset; return [Number(d.xMm), Number(d.voltageV)];",
    )
    .await?;
    let read = numbers(&read)?;
    let (x_read, u_read) = (read[0], read[1]);
    let span = (x[0], x[x.len() - 1]);
    if (x_read - (span.0 + 0.8 * (span.1 - span.0))).abs() > 0.05 {
        return fail(format!("feel strip: pointer at 80% of the strip read x = {x_read} mm"));
    }
    let expected = haptex_core::profile::interpolate(&voltage[0], &voltage[1], x_read);
    if (u_read - expected).abs() > 1e-9 * expected.max(1.0) {
        return fail(format!("feel strip at x = {x_read} mm shows U = {u_read} V, the profile has {expected} V"));
    }

    // 7b. ... and from the keyboard.
    strip_keyboard(client).await?;

    // 8. The uploaded profile pinned, compared with the template on other
    // x samples: one x axis, each design's own points.
    let upload_pin = pin(client).await?;
    show_template(client).await?;
    let pinned = series_of(client, "friction", &format!("{upload_pin} μ")).await?;
    let template_x = numbers(&script(client, "return window.haptex.state.voltage.x_mm;").await?)?;
    let current = series_of(client, "friction", "μ_RS / μ_flat · μ_HD").await?;
    if pinned.0 != x || pinned.1 != mu || current.0 != template_x {
        return fail(format!("the pinned upload over the template: {pinned:?} on the template's x"));
    }
    // Phone viewports, 360 and 430 px wide (with the pin's legends):
    // no horizontal scrolling, plots fit, thumb-sized controls, touch.
    phone_viewport(client, 360).await?;
    phone_viewport(client, 430).await?;
    unpin(client, &upload_pin).await?;
    // Redrawn, so that the screenshots show the design's message, not the removal's.
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("reset-device"))).click());
    wait_update(client, n, "the template redrawn").await?;
    wd!(client.set_window_size(390, 844));
    tokio::time::sleep(Duration::from_millis(400)).await;
    let overflow = script(client, "return document.documentElement.scrollWidth - window.innerWidth;").await?;
    if overflow.as_f64().unwrap_or(1.0) > 0.0 {
        return fail(format!("phone-sized window scrolls sideways by {overflow} px"));
    }
    // Screenshots for the docs: the default bump template as the page
    // opens it, the paper's Fig. 2 view (phone, and the 1366 x 900 desktop
    // of issue 37), and a library material with mu_RS above mu_HD, eq. 8.
    let phone = screenshot(client).await?;
    browser_common::set_viewport(client, 1366, 900).await?;
    tokio::time::sleep(Duration::from_millis(400)).await;
    let desktop = screenshot(client).await?;
    save_screenshot("web.png", &desktop);
    save_screenshot("web-phone.png", &phone);
    // 9. The check on the finger model and the compensation, on the
    // default template.
    finger_on_the_display(client).await?;
    save_screenshot("web-check.png", &screenshot_of(client, "check-results").await?);
    fingertip_3d_on_the_display(client).await?;
    show_library(client, "latex").await?;
    save_screenshot("web-library.png", &screenshot(client).await?);
    if script(client, "return document.getElementById('recordings-box').hidden;").await? != Value::Bool(true) {
        return fail("the read-only library's source offers an upload of recordings");
    }
    // 10. The display selector.
    display_selector(client, scratch).await?;
    // 14. Recipes: download, replay, open as a link and as a file.
    recipes(client, base, scratch).await?;
    // 15. Recordings uploaded into a writable library (another server).
    upload_recordings(client, scratch).await?;
    // 16. The map view (issue 19): an uploaded image, felt and drawn over.
    map_view(client, base, scratch).await?;
    // 17. The live output (issue 18): the strip drives a server's audio output.
    live_output(client, base).await?;

    let errors = console_errors(client).await?;
    if !errors.is_empty() {
        return fail(format!("console errors: {errors:#?}"));
    }
    Ok(())
}

/// Shows the default bump template as the GUI first shows it (relative
/// to its flat value, eq. 8 with eq. 9 beside it: the paper's Fig. 2),
/// the paper's defaults and the FE model's profile beside the estimate
/// (the upload source is active before).
async fn show_template(client: &Client) -> Check<()> {
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css("input[name='source'][value='template']"))).click());
    wait_update(client, n, "the template source again").await?;
    sharp_sine_caveat(client).await?;
    // Back to the default width (set-up, not a check).
    let n = updates(client).await?;
    script(
        client,
        "const s = document.getElementById('template-width_mm'); s.value = '1.3'; \
         s.dispatchEvent(new Event('input')); return true;",
    )
    .await?;
    wait_update(client, n, "the default width").await?;
    wait_for(client, "window.haptex.state.drawn.label.startsWith('bump r_w 1.3 mm')", "the default bump drawn").await?;
    paper_defaults(client, "physical").await?;
    wait_for(client, "window.haptex.state.voltage.summary.relative !== undefined", "the relative mapping").await?;
    // With the FE model's profile beside the estimate.
    wd!(wd!(client.find(Locator::Id("run-fe"))).click());
    wait_for(client, FE_DRAWN, "the FE profile drawn").await
}

/// A sine whose crests the database's fine mesh does not resolve (r_w 1.7,
/// r_h 0.4 mm: radius 0.183 mm): the page says so beside the estimate, in
/// the server's sentence (`fe_caveat`). Then back to the bump, at the
/// default height.
async fn sharp_sine_caveat(client: &Client) -> Check<()> {
    // The surface chosen, or sliders set, as a user's change and input events do.
    let surface = |name: &'static str| {
        let code = format!(
            "const s = document.getElementById('surface'); s.value = '{name}'; \
             s.dispatchEvent(new Event('change')); return true;"
        );
        async move { script(client, &code).await }
    };
    let sliders = |values: &'static [(&'static str, &'static str)]| {
        let pairs: Vec<String> = values.iter().map(|(id, v)| format!("['template-{id}', '{v}']")).collect();
        let code = format!(
            "for (const [id, v] of [{}]) {{ const s = document.getElementById(id); s.value = v; \
             s.dispatchEvent(new Event('input')); }} return true;",
            pairs.join(", ")
        );
        async move { script(client, &code).await }
    };
    let n = updates(client).await?;
    surface("sine").await?;
    wait_update(client, n, "the sine template").await?;
    sliders(&[("width_mm", "1.7"), ("height_mm", "0.4")]).await?;
    wait_for(client, "window.haptex.state.drawn.label.startsWith('sine r_w 1.7 mm, r_h 0.4 mm')", "the sharp sine")
        .await?;
    let shown = script(
        client,
        "const c = document.querySelector('#template-info .fe-caveat'); return c ? c.textContent : null;",
    )
    .await?;
    let shown = shown.as_str().unwrap_or_default();
    if !shown.starts_with("Not mesh-converged: the grating's crests (radius 0.183 mm) are sharper than the fine mesh")
        || !shown.contains("--mesh extra-fine")
    {
        return fail(format!("beside the sharp sine's estimate the page says {shown:?}"));
    }
    // A blunt sine (r_w 2.3, r_h 0.15 mm: radius 0.89 mm) has no caveat, and
    // is told the resolved members' figures, without the FE advice (their
    // worst was within 10% of the range).
    sliders(&[("width_mm", "2.3"), ("height_mm", "0.15")]).await?;
    wait_for(client, "window.haptex.state.drawn.label.startsWith('sine r_w 2.3 mm, r_h 0.15 mm')", "the blunt sine")
        .await?;
    let said = script(
        client,
        "const q = (s) => document.querySelector('#template-info ' + s); \
         return [q('.expected-error')?.textContent ?? '', !!q('.fe-caveat'), !!q('.fe-advice')];",
    )
    .await?;
    let expected = said[0].as_str().unwrap_or_default();
    if !expected.starts_with("On 15 of 30 random members whose crests the mesh resolves checked against fresh FE runs")
        || said[1] != Value::Bool(false)
        || said[2] != Value::Bool(false)
    {
        return fail(format!("beside the blunt sine's estimate the page says {said}"));
    }
    let n = updates(client).await?;
    surface("bump").await?;
    wait_update(client, n, "the bump template again").await?;
    let n = updates(client).await?;
    sliders(&[("height_mm", "0.27")]).await?;
    wait_update(client, n, "the default height").await?;
    let gone = script(client, "return document.querySelector('#template-info .fe-caveat') === null;").await?;
    if gone != Value::Bool(true) {
        return fail("the sine's caveat stays beside the bump's estimate");
    }
    Ok(())
}

/// The check on the finger model and the compensation of the template
/// shown (relative to its flat value, the paper's device): clicking
/// *check on the finger model* shows the progress and then draws the
/// friction the FE finger felt beside the target, with eq. (8)'s voltage
/// applied being the one the voltage plot shows; the error figures are
/// shown; *compensate* reports each FE run as it runs, draws the felt
/// friction of the compensated voltage, which is closer to the target than
/// eq. (8)'s (the server's figures), offers it as a CSV (read back with
/// haptex's reader: the compensated voltage, within U_max), and the feel
/// strip then plays it.
async fn finger_on_the_display(client: &Client) -> Check<()> {
    let state = "window.haptex.state";
    wd!(wd!(client.find(Locator::Id("run-check"))).click());
    wait_for(client, &format!("{state}.check && {state}.check.mode === 'check'"), "the check's result").await?;
    wait_for(client, "!document.getElementById('check-results').hidden", "the check's plots").await?;
    let result = script(client, &format!("return {state}.check.result;")).await?;
    let progress = script(client, &format!("return {state}.checkProgress;")).await?;
    if progress["lines"].as_u64().unwrap_or(0) < 1 {
        return fail(format!("no progress shown while the check ran: {progress}"));
    }
    let voltage = plotted(client, "voltage").await?;
    let friction = plotted(client, "friction").await?;
    let check = plotted(client, "check").await?;
    let felt = numbers(&result["eq8"]["felt_mu"])?;
    if check[0] != voltage[0] || check[1] != friction[1] || check[2] != felt {
        return fail("the check plot is not the target plotted above and the friction the finger felt");
    }
    if numbers(&result["eq8"]["voltage_v"])? != voltage[1] {
        return fail("the check applied another voltage than the eq. (8) voltage plotted");
    }
    let table = wd!(wd!(client.find(Locator::Id("check-metrics"))).text());
    let rms = result["eq8"]["metrics"]["rms_error"].as_f64().ok_or("rms_error")?;
    let shown = script(client, "return document.getElementById('check-metrics').rows[1].cells[1].textContent;").await?;
    let shown: f64 = shown.as_str().unwrap_or_default().parse().map_err(|_| format!("RMS shown as {shown}"))?;
    if !table.contains("RMS error") || !table.contains("k_FE") || (shown - rms).abs() > 1e-3 * rms {
        return fail(format!("the metrics table shows {table:?}, the server's RMS error is {rms}"));
    }

    wd!(wd!(client.find(Locator::Id("run-compensate"))).click());
    wait_for(client, &format!("{state}.check.mode === 'compensate'"), "the compensation's result").await?;
    let result = script(client, &format!("return {state}.check.result;")).await?;
    let progress = script(client, &format!("return {state}.checkProgress;")).await?;
    let runs = result["fe_runs"].as_u64().ok_or("fe_runs")?;
    if progress["maxRun"].as_u64() != Some(runs) || runs < 2 {
        return fail(format!("the progress reached run {} of the {runs} FE runs", progress["maxRun"]));
    }
    let check = plotted(client, "check").await?;
    let compensated = &result["compensated"];
    if labels(client, "check").await?.iter().all(|l| l != "felt, compensated")
        || check[3] != numbers(&compensated["felt_mu"])?
    {
        return fail("the felt friction of the compensated voltage is not drawn");
    }
    // Why it stopped, in the status line beside the buttons that asked.
    let stopped = result["stopped"]["message"].as_str().ok_or("stopped")?;
    let said = wd!(wd!(client.find(Locator::Id("check-info"))).text());
    if !said.starts_with("Compensated in ") || !said.contains(stopped) {
        return fail(format!("the compensation's status says {said:?}, not why it stopped ({stopped:?})"));
    }
    let (eq8, best) = (rms, compensated["metrics"]["rms_error"].as_f64().ok_or("compensated RMS")?);
    if best >= eq8 / 3.0 {
        return fail(format!("compensated RMS error {best} against eq. (8)'s {eq8}"));
    }
    let u_comp = numbers(&compensated["voltage_v"])?;
    let bytes = download(client, "compensated-csv").await?;
    let text = String::from_utf8(bytes.clone()).map_err(|e| e.to_string())?;
    let table = Table::read(bytes.as_slice(), "downloaded voltage-compensated.csv").map_err(|e| e.to_string())?;
    if table.column("voltage_v") != Some(u_comp.as_slice())
        || !text.starts_with("# haptex check on the finger model")
        || u_comp.iter().any(|&u| !(0.0..=100.0).contains(&u))
    {
        return fail(format!("the compensated voltage CSV: {:.300}", text));
    }
    // The feel strip plays the compensated voltage: U at the pointer.
    let playing = script(client, "return document.getElementById('play-compensated').checked;").await?;
    if playing != Value::Bool(true) {
        return fail("the compensated voltage is not chosen for playback after compensating");
    }
    let strip = wd!(client.find(Locator::Id("feel-strip")));
    let moves = MouseActions::new("mouse".into()).then(PointerAction::MoveToElement {
        element: strip,
        duration: Some(Duration::from_millis(50)),
        x: -0.1
            * script(client, "return document.getElementById('feel-strip').getBoundingClientRect().width;")
                .await?
                .as_f64()
                .ok_or("strip width")?,
        y: 0.0,
    });
    wd!(client.perform_actions(moves));
    tokio::time::sleep(Duration::from_millis(100)).await;
    let read = script(
        client,
        "const d = document.getElementById('feel-readout').dataset; return [Number(d.xMm), Number(d.voltageV)];",
    )
    .await?;
    let read = numbers(&read)?;
    let x = numbers(&result["x_mm"])?;
    let expected = haptex_core::profile::interpolate(&x, &u_comp, read[0]);
    if (read[1] - expected).abs() > 1e-9 * expected.max(1.0) {
        return fail(format!(
            "feel strip at x = {} mm plays {} V, the compensated voltage is {expected} V",
            read[0], read[1]
        ));
    }
    // Pinned with the check current: what the finger felt under the
    // compensated voltage is drawn in the felt-friction plot of the next
    // design (here the same one) and removed with its pin.
    let felt_pin = pin(client).await?;
    let felt = series_of(client, "check", &format!("{felt_pin} felt, compensated")).await?;
    if felt.1 != numbers(&result["compensated"]["felt_mu"])? {
        return fail("the pinned felt friction is not the compensated run's");
    }
    unpin(client, &felt_pin).await?;
    // The results fit a phone's width too.
    fits_a_phone(client, "with the check's results").await
}

/// The check on the 3D fingertip (issue 39): choosing it shows its load
/// in N and its direction in place of the 2D finger's load per mm and
/// hides the 2D check's results (no longer those of the settings shown);
/// a load beyond its range is refused as typed, beside the buttons, in the
/// field's words, with no FE run; a valid one runs the 3D finger (the
/// server's `model` 3d on the coarse mesh), whose felt friction is drawn
/// and whose summary names the finger and its real contact area. The 2D
/// finger is chosen again after.
async fn fingertip_3d_on_the_display(client: &Client) -> Check<()> {
    let state = "window.haptex.state";
    wd!(wd!(client.find(Locator::Css("#check-model option[value='3d-coarse']"))).click());
    let shown = "return ['check-load', 'check-load-3d', 'check-direction'].map((id) => \
                 document.getElementById(id).getClientRects().length > 0).concat(\
                 document.getElementById('check-results').hidden);";
    if script(client, shown).await? != json!([false, true, true, true]) {
        return fail(format!("the 3D fingertip's fields (2D load, 3D load, direction, results hidden): {}", {
            script(client, shown).await?
        }));
    }
    type_into(client, "check-load-3d", "5").await?;
    wd!(wd!(client.find(Locator::Id("run-check"))).click());
    wait_for(client, "document.getElementById('check-info').textContent.startsWith('Not run')", "the refused load")
        .await?;
    let said = wd!(wd!(client.find(Locator::Id("check-info"))).text());
    let marked =
        script(client, "return document.getElementById('check-load-3d').getAttribute('aria-invalid');").await?;
    if !said.contains("Load")
        || marked != json!("true")
        || script(client, &format!("return {state}.check.result.settings.model;")).await? != json!("2d")
    {
        return fail(format!("a 5 N load: the status says {said:?}, the field is marked {marked}"));
    }
    type_into(client, "check-load-3d", "0.4").await?;
    type_into(client, "check-direction", "30").await?;
    wd!(wd!(client.find(Locator::Id("run-check"))).click());
    wait_for(
        client,
        &format!("{state}.check && {state}.check.result.settings.model === '3d'"),
        "the 3D check's result",
    )
    .await?;
    wait_for(client, "!document.getElementById('check-results').hidden", "the 3D check's plots").await?;
    let result = script(client, &format!("return {state}.check.result;")).await?;
    let s = &result["settings"];
    if (s["mesh"].as_str(), s["load_n"].as_f64(), s["direction_deg"].as_f64())
        != (Some("coarse"), Some(0.4), Some(30.0))
    {
        return fail(format!("the 3D check ran with {s}"));
    }
    if plotted(client, "check").await?[2] != numbers(&result["eq8"]["felt_mu"])? {
        return fail("the check plot does not draw what the 3D fingertip felt");
    }
    let summary = wd!(wd!(client.find(Locator::Id("check-summary"))).text());
    if !summary.contains("3D fingertip (coarse mesh) sliding at 30°, load 0.4 N")
        || !summary.contains("real contact area per normal force")
    {
        return fail(format!("the 3D check's summary says {summary:?}"));
    }
    save_screenshot("web-check-3d.png", &screenshot_of(client, "check-box").await?);
    wd!(wd!(client.find(Locator::Css("#check-model option[value='2d']"))).click());
    if script(client, shown).await? != json!([true, false, false, true]) {
        return fail("the 2D finger chosen again: its load is not shown, or the 3D results stay");
    }
    Ok(())
}

/// At a phone's size (390 x 844) the page does not scroll sideways; the
/// desktop size (1280 x 1280) is restored after.
async fn fits_a_phone(client: &Client, what: &str) -> Check<()> {
    wd!(client.set_window_size(390, 844));
    tokio::time::sleep(Duration::from_millis(400)).await;
    let overflow = script(client, "return document.documentElement.scrollWidth - window.innerWidth;").await?;
    wd!(client.set_window_size(1280, 1280));
    tokio::time::sleep(Duration::from_millis(400)).await;
    if overflow.as_f64().unwrap_or(1.0) > 0.0 {
        return fail(format!("{what}: a phone-sized window scrolls sideways by {overflow} px"));
    }
    Ok(())
}

/// A screenshot with the element `id` scrolled to the top of the window.
async fn screenshot_of(client: &Client, id: &str) -> Check<Vec<u8>> {
    script(client, &format!("document.getElementById('{id}').scrollIntoView(); return true;")).await?;
    tokio::time::sleep(Duration::from_millis(200)).await;
    Ok(wd!(client.screenshot()))
}

/// Clicks the radio button `name` = `value` and waits for the voltage it gives.
async fn choose(client: &Client, name: &str, value: &str) -> Check<()> {
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css(&format!("input[name='{name}'][value='{value}']")))).click());
    wait_update(client, n, &format!("the voltage after choosing {name} {value}")).await
}

/// Step 10: the display selector on the library's sponge (mean mu 0.996:
/// about half of it below mu_HD = 1, which electrovibration alone cannot
/// render), with the paper's device (the library source is active before).
async fn display_selector(client: &Client, scratch: &Path) -> Check<()> {
    use haptex_core::combined::{Channels, Strategy, map_display};
    use haptex_core::ultrasonic::UltrasonicDevice;

    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css("#material option[value='sponge']"))).click());
    wait_update(client, n, "the sponge").await?;
    let n = updates(client).await?;
    let set_seed = format!(
        "const s = document.getElementById('seed'); s.value = '{SCREENSHOT_SEED}'; \
         s.dispatchEvent(new Event('change')); return true;"
    );
    script(client, &set_seed).await?;
    wait_update(client, n, "the sponge's stroke of the fixed seed").await?;
    wait_for(client, "window.haptex.state.drawn.material === 'sponge'", "the sponge drawn").await?;
    choose(client, "display", "combined").await?;
    wait_for(client, "window.haptex.state.voltage.summary.display === 'combined'", "the combined display").await?;
    let visible = script(
        client,
        "return !document.getElementById('amplitude-figure').hidden && !document.getElementById('display-options').hidden          && !document.getElementById('strategy-row').hidden && document.getElementById('weight-row').hidden          && document.querySelector(\"input[name='method'][value='normalized']\").disabled;",
    )
    .await?;
    if visible != Value::Bool(true) {
        return fail("combined: the amplitude plot, strategy and a_max are not shown, or eq. (9) is still offered");
    }
    // The plots are the core's design of the plotted profile (haptex voltage --display combined).
    let friction = plotted(client, "friction").await?;
    let (x, mu) = (&friction[0], &friction[1]);
    let profile = FrictionProfile::new(x.clone(), mu.clone()).map_err(|e| e.to_string())?;
    let plate = UltrasonicDevice::literature_default(None).map_err(|e| e.to_string())?;
    let core = map_display(&profile, &Device::PAPER, Channels::Combined(&plate, Strategy::Split), None, None)
        .map_err(|e| e.to_string())?;
    let amplitude = plotted(client, "amplitude").await?;
    let voltage = plotted(client, "voltage").await?;
    if Some(&amplitude[1]) != core.amplitude_um.as_ref() || Some(&voltage[1]) != core.voltage_v.as_ref() {
        return fail("combined: the plotted a(x) or U(x) is not the core's map_display of the plotted profile");
    }
    let a_max = plate.a_max_um();
    if amplitude[2].iter().any(|a| *a != a_max) {
        return fail(format!("combined: a_max line {:?}, expected {a_max} um", amplitude[2]));
    }
    // Split: the plate below mu_HD, the voltage above; the sponge has both.
    if !amplitude[1].iter().any(|a| *a > 0.0) || !voltage[1].iter().any(|u| *u > 0.0) {
        return fail("combined (split) on the sponge: no vibration or no voltage anywhere");
    }
    // The band on the friction plot.
    let shown = labels(client, "friction").await?;
    let band = core.summary.band_mu;
    let at = |label: &str| shown.iter().position(|l| l == label).map(|i| &friction[i + 1]);
    match (at("band min (μ_HD ρ_min)"), at("band max (μ at U_max)")) {
        (Some(lo), Some(hi)) if lo.iter().all(|m| *m == band[0]) && hi.iter().all(|m| *m == band[1]) => {}
        _ => return fail(format!("combined: the friction plot's series {shown:?} do not draw the band {band:?}")),
    }
    let summary = wd!(wd!(client.find(Locator::Id("summary-band"))).text());
    if !summary.contains("renderable band") {
        return fail(format!("combined: the summary does not state the band: {summary:?}"));
    }
    // The feel strip: a(x) at the pointer, beside U(x).
    let strip = wd!(client.find(Locator::Id("feel-strip")));
    let width = script(client, "return document.getElementById('feel-strip').getBoundingClientRect().width;").await?;
    let moves = MouseActions::new("mouse".into()).then(PointerAction::MoveToElement {
        element: strip,
        duration: Some(Duration::from_millis(50)),
        x: -0.2 * width.as_f64().ok_or("strip width")?,
        y: 0.0,
    });
    wd!(client.perform_actions(moves));
    wait_for(client, "document.getElementById('feel-readout').dataset.amplitudeUm !== undefined", "a at the pointer")
        .await?;
    let read = script(
        client,
        "const d = document.getElementById('feel-readout').dataset;          return [Number(d.xMm), Number(d.voltageV), Number(d.amplitudeUm)];",
    )
    .await?;
    let read = numbers(&read)?;
    let (a_want, u_want) = (
        haptex_core::profile::interpolate(x, &amplitude[1], read[0]),
        haptex_core::profile::interpolate(x, &voltage[1], read[0]),
    );
    let readout = wd!(wd!(client.find(Locator::Id("feel-readout"))).text());
    if (read[2] - a_want).abs() > 1e-9 * a_want.max(1.0) || (read[1] - u_want).abs() > 1e-9 * u_want.max(1.0) {
        return fail(format!(
            "feel strip at x = {} mm: U {} a {}, the profile has U {u_want} a {a_want}",
            read[0], read[1], read[2]
        ));
    }
    if !readout.contains(" µm") {
        return fail(format!("the feel readout does not show a: {readout:?}"));
    }

    // The weighted strategy and its weight.
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css("#strategy option[value='weighted']"))).click());
    wait_update(client, n, "the weighted strategy").await?;
    wait_for(client, "!document.getElementById('weight-row').hidden", "the weight shown").await?;
    accessible_names(client, "the combined display, weighted").await?;
    let n = updates(client).await?;
    type_into(client, "weight", "5").await?;
    wait_update(client, n, "the voltage with weight 5").await?;
    wait_for(client, "window.haptex.state.voltage.summary.weight === 5", "weight 5 used").await?;
    let weighted = plotted(client, "amplitude").await?;
    let core = map_display(
        &profile,
        &Device::PAPER,
        Channels::Combined(&plate, Strategy::Weighted { weight: 5.0 }),
        None,
        None,
    )
    .map_err(|e| e.to_string())?;
    if Some(&weighted[1]) != core.amplitude_um.as_ref() {
        return fail("weighted (w = 5): the plotted a(x) is not the core's");
    }

    // A calibration upload: the plate used; a bad one refused naming its line and column.
    let good = scratch.join("my-plate.csv");
    std::fs::write(&good, "amplitude_um,relative_friction\n0,1\n0.5,0.8\n1.0,0.5\n2.0,0.25\n").unwrap();
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("calibration"))).send_keys(&good.display().to_string()));
    wait_update(client, n, "the voltage with the calibration").await?;
    wait_for(client, "window.haptex.state.voltage.summary.ultrasonic.source === 'calibration'", "the calibrated plate")
        .await?;
    let calibrated = plotted(client, "amplitude").await?;
    if calibrated[2].iter().any(|a| *a != 2.0) {
        return fail("with the calibration, a_max is not its last amplitude, 2 um");
    }
    let bad = scratch.join("bad-plate.csv");
    std::fs::write(&bad, "amplitude_um,relative_friction\n0,1\n0.5,0.8\n0.4,0.5\n").unwrap();
    wd!(wd!(client.find(Locator::Id("calibration"))).send_keys(&bad.display().to_string()));
    wait_for(
        client,
        "document.getElementById('calibration').getAttribute('aria-invalid') === 'true'",
        "the bad calibration refused",
    )
    .await?;
    // Beside the file field (issue 37), naming the file, its line and column.
    let message = wd!(wd!(client.find(Locator::Id("calibration-error"))).text());
    if !message.starts_with("bad-plate.csv, line 4, column 'amplitude_um'") || message.contains("--") {
        return fail(format!("a bad calibration is reported as {message:?}"));
    }
    let logged = console_errors(client).await?;
    if logged.is_empty() || logged.iter().any(|e| !(e.contains("/api/voltage") && e.contains("400"))) {
        return fail(format!("console after a bad calibration: {logged:#?}"));
    }
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("calibration"))).send_keys(&good.display().to_string()));
    wait_update(client, n, "the voltage with the good calibration again").await?;

    // Downloads with both channels.
    let bytes = download(client, "voltage-csv").await?;
    let table = Table::read(bytes.as_slice(), "downloaded display.csv").map_err(|e| e.to_string())?;
    let state = script(client, "return window.haptex.state.voltage;").await?;
    if table.columns() != ["x_mm", "mu", "voltage_v", "amplitude_um"]
        || table.column("amplitude_um") != Some(numbers(&state["amplitude_um"])?.as_slice())
    {
        return fail(format!("combined: the downloaded CSV's columns {:?} or amplitudes", table.columns()));
    }
    let wav = download(client, "stroke-wav").await?;
    let (scale, volts, channel_2) = haptex_core::signal::decode_drive_wav_channels(&wav)?;
    match (&scale.channel_2, channel_2) {
        (Some(c2), Some(a)) if c2.um_per_full_scale == 2.0 && a.len() == volts.len() && a.iter().any(|v| *v > 0.0) => {}
        _ => return fail("combined: the stroke WAV has no channel 2 at the calibration's a_max = 2 um"),
    }
    // Its sidecar, as haptex play writes it: the same samples and channel 2's scale.
    let sidecar = download(client, "stroke-sidecar").await?;
    let sidecar: haptex_core::signal::WavSidecar =
        serde_json::from_slice(&sidecar).map_err(|e| format!("the stroke WAV's sidecar: {e}"))?;
    if sidecar.samples_sha256 != scale.samples_sha256 || sidecar.channel_2 != scale.channel_2 || sidecar.channels != 2 {
        return fail("combined: the sidecar download does not belong to the stroke WAV");
    }

    save_screenshot("web-combined.png", &screenshot(client).await?);
    // The display's controls fit a phone too.
    fits_a_phone(client, "combined display").await?;

    // The ultrasonic display alone: no voltage, the band's top at mu_HD.
    let combined = (plotted(client, "amplitude").await?, plotted(client, "voltage").await?);
    let combined_pin = pin(client).await?;
    choose(client, "display", "ultrasonic").await?;
    wait_for(client, "window.haptex.state.voltage.summary.display === 'ultrasonic'", "the ultrasonic display").await?;
    // The pinned combined design beside the ultrasonic one: its a(x) on
    // the amplitude plot, its U(x) alone on the voltage plot.
    let pinned_a = series_of(client, "amplitude", &format!("{combined_pin} a(x)")).await?;
    let pinned_u = series_of(client, "voltage", &format!("{combined_pin} U(x)")).await?;
    if pinned_a.1 != combined.0[1] || pinned_u.1 != combined.1[1] || labels(client, "voltage").await?.len() != 1 {
        return fail("the pinned combined design is not drawn beside the ultrasonic one");
    }
    unpin(client, &combined_pin).await?;
    let hidden = script(
        client,
        "return document.getElementById('voltage-figure').hidden && window.haptex.plots.voltage === null \
         && document.getElementById('strategy-row').hidden;",
    )
    .await?;
    if hidden != Value::Bool(true) || !labels(client, "friction").await?.iter().any(|l| l == "band max (μ_HD)") {
        return fail("ultrasonic: a voltage plot or the strategy is still shown, or the band's top is not mu_HD");
    }
    // Back to electrovibration: the one-channel page.
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("clear-calibration"))).click());
    wait_update(client, n, "the literature default again").await?;
    choose(client, "display", "electrovibration").await?;
    let restored = script(
        client,
        "return document.getElementById('amplitude-figure').hidden && window.haptex.plots.amplitude === null \
         && window.haptex.state.voltage.summary.method === 'physical' \
         && !document.querySelector(\"input[name='method'][value='normalized']\").disabled;",
    )
    .await?;
    if restored != Value::Bool(true) {
        return fail("electrovibration: the amplitude plot is still shown or eq. (9) not offered");
    }
    Ok(())
}

/// Shows `material` of the library with the physical method and the
/// paper's defaults (the template source is active before).
async fn show_library(client: &Client, material: &str) -> Check<()> {
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css("input[name='source'][value='library']"))).click());
    wait_update(client, n, "the library source again").await?;
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css(&format!("#material option[value='{material}']")))).click());
    wait_update(client, n, "the material").await?;
    // A fixed stroke, so that the screenshots do not change from run to run
    // (set by script: this is set-up, not a check).
    let n = updates(client).await?;
    let set_seed = format!(
        "const s = document.getElementById('seed'); s.value = '{SCREENSHOT_SEED}'; \
         s.dispatchEvent(new Event('change')); return true;"
    );
    script(client, &set_seed).await?;
    wait_update(client, n, "the stroke of the fixed seed").await?;
    let drawn = format!(
        "window.haptex.state.drawn.material === '{material}' && window.haptex.state.drawn.seed === '{SCREENSHOT_SEED}'"
    );
    wait_for(client, &drawn, "the fixed stroke drawn").await?;
    paper_defaults(client, "physical").await
}

/// The method `method` and the paper's device constants.
async fn paper_defaults(client: &Client, method: &str) -> Check<()> {
    wd!(wd!(client.find(Locator::Css(&format!("input[name='method'][value='{method}']")))).click());
    wd!(wd!(client.find(Locator::Id("reset-device"))).click());
    let summary = "window.haptex.state.voltage.summary";
    wait_for(client, &format!("{summary}.u_max_v === 100 && {summary}.method === '{method}'"), "the paper's defaults")
        .await
}

/// A screenshot of the top of the page with the feel pointer on the strip.
async fn screenshot(client: &Client) -> Check<Vec<u8>> {
    let strip = wd!(client.find(Locator::Id("feel-strip")));
    let moves = MouseActions::new("mouse".into()).then(PointerAction::MoveToElement {
        element: strip,
        duration: Some(Duration::from_millis(50)),
        x: -40.0,
        y: 0.0,
    });
    wd!(client.perform_actions(moves));
    tokio::time::sleep(Duration::from_millis(200)).await;
    // The page and its results column (which scrolls on its own on a desktop) at their tops.
    script(client, "window.scrollTo(0, 0); document.querySelector('.results').scrollTop = 0; return true;").await?;
    Ok(wd!(client.screenshot()))
}

fn save_screenshot(name: &str, png: &[u8]) {
    let target = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::write(&target, png).unwrap();
    eprintln!("screenshot: {}", target.display());
    if std::env::var("HAPTEX_UPDATE_SCREENSHOTS").as_deref() == Ok("1") {
        let docs = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/img").join(name);
        std::fs::write(&docs, png).unwrap();
        eprintln!("screenshot: {}", docs.display());
    }
}

/// chromedriver's computed accessible name of an element (WebDriver "Get
/// Computed Label": what a screen reader announces).
#[derive(Debug)]
struct ComputedLabel(String);

impl WebDriverCompatibleCommand for ComputedLabel {
    fn endpoint(&self, base_url: &url::Url, session_id: Option<&str>) -> Result<url::Url, url::ParseError> {
        base_url.join(&format!("session/{}/element/{}/computedlabel", session_id.unwrap_or_default(), self.0))
    }

    fn method_and_body(&self, _: &url::Url) -> (Method, Option<String>) {
        (Method::GET, None)
    }
}

/// Every input, select, button and focusable element shown has an
/// accessible name (Chromium's own computation, through chromedriver);
/// returns how many were checked.
async fn accessible_names(client: &Client, when: &str) -> Check<usize> {
    let mut checked = 0;
    for element in wd!(client.find_all(Locator::Css("input, select, button, textarea, [tabindex]"))) {
        if !wd!(element.is_displayed()) {
            continue;
        }
        let name = wd!(client.issue_cmd(ComputedLabel(element.element_id().to_string())));
        if name.as_str().unwrap_or_default().trim().is_empty() {
            let html = wd!(element.html(false));
            return fail(format!("{when}: a control without an accessible name: {html}"));
        }
        checked += 1;
    }
    Ok(checked)
}

/// The data of the uPlot chart `name` with its gaps (null: a design with
/// no sample at that x, when pinned designs are drawn).
async fn plotted_with_gaps(client: &Client, name: &str) -> Check<Vec<Vec<Option<f64>>>> {
    let data = script(client, &format!("return window.haptex.plots.{name}.data;")).await?;
    data.as_array()
        .ok_or("no plot data")?
        .iter()
        .map(|column| {
            column
                .as_array()
                .ok_or_else(|| format!("not an array: {column}"))
                .map(|c| c.iter().map(Value::as_f64).collect())
        })
        .collect()
}

/// The samples of the series `label` of plot `name`, at the x where it
/// has one: (x, y) pairs.
async fn series_of(client: &Client, name: &str, label: &str) -> Check<(Vec<f64>, Vec<f64>)> {
    let shown = labels(client, name).await?;
    let i = shown.iter().position(|l| l == label).ok_or_else(|| format!("plot {name} has no {label:?}: {shown:?}"))?;
    let data = plotted_with_gaps(client, name).await?;
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for (xi, yi) in data[0].iter().zip(&data[i + 1]) {
        if let (Some(xi), Some(yi)) = (xi, yi) {
            x.push(*xi);
            y.push(*yi);
        }
    }
    Ok((x, y))
}

async fn pin_count(client: &Client) -> Check<u64> {
    let n = script(client, "return document.querySelectorAll('#pins li').length;").await?;
    n.as_u64().ok_or_else(|| format!("pins: {n}"))
}

/// Clicks *pin this design* and returns the new pin's name (P1, P2, ...).
async fn pin(client: &Client) -> Check<String> {
    let before = pin_count(client).await?;
    wd!(wd!(client.find(Locator::Id("pin-design"))).click());
    wait_for(client, &format!("document.querySelectorAll('#pins li').length === {}", before + 1), "the new pin")
        .await?;
    let name =
        script(client, "const l = document.querySelectorAll('#pins li'); return l[l.length - 1].dataset.pin;").await?;
    name.as_str().map(str::to_string).ok_or_else(|| format!("pin name {name}"))
}

/// Clicks the remove button of pin `name`.
async fn unpin(client: &Client, name: &str) -> Check<()> {
    let before = pin_count(client).await?;
    wd!(wd!(client.find(Locator::Css(&format!("#pins li[data-pin='{name}'] .remove-pin")))).click());
    wait_for(client, &format!("document.querySelectorAll('#pins li').length === {}", before - 1), "a pin removed").await
}

/// Sets the template's width slider (set-up, by script) and waits for it drawn.
async fn template_width(client: &Client, width_mm: f64) -> Check<()> {
    let n = updates(client).await?;
    script(
        client,
        &format!(
            "const s = document.getElementById('template-width_mm'); s.value = '{width_mm}'; \
             s.dispatchEvent(new Event('input')); return true;"
        ),
    )
    .await?;
    wait_update(client, n, "the new width").await?;
    wait_for(
        client,
        &format!("window.haptex.state.drawn.label.startsWith('bump r_w {width_mm} mm')"),
        "the width drawn",
    )
    .await
}

/// Compare (issue 17): the default bump pinned (P1, relative, eq. 8 and
/// eq. 9 together as in Fig. 2b), a wider bump pinned (P2), a narrower one
/// shown: each plot draws the current design and both pins on the same
/// axes, each pin's series the core's numbers for its design, named in
/// the plot's legend and in the list with a remove button; four pins at
/// once; removing one takes exactly its series away; the plots' text
/// summaries (for screen readers) name the pins; eq. (8) and eq. (9)
/// together can be switched off and on.
async fn compare_designs(client: &Client, x: &[f64]) -> Check<()> {
    let default = predicted_bump(client, 1.3).await?;
    let p1 = pin(client).await?;
    template_width(client, 2.0).await?;
    let p2 = pin(client).await?;
    template_width(client, 1.0).await?;
    let shown = labels(client, "voltage").await?;
    let expected: Vec<String> = ["U eq. (8)", "U eq. (9)", "U_max"]
        .iter()
        .map(|s| s.to_string())
        .chain([&p1, &p2].iter().flat_map(|p| [format!("{p} U eq. (8)"), format!("{p} U eq. (9)")]))
        .collect();
    if shown != expected {
        return fail(format!("with two pins the voltage plot shows {shown:?}, expected {expected:?}"));
    }
    // Each design's numbers: the core's relative mapping of its prediction.
    for (name, width) in [(None, 1.0), (Some(&p1), 1.3), (Some(&p2), 2.0)] {
        let predicted = if width == 1.3 { default.clone() } else { predicted_bump(client, width).await? };
        let (eq8, eq9) = core_relative_voltages(x, &predicted, 0.5);
        let prefix = name.map(|p| format!("{p} ")).unwrap_or_default();
        let mu_label = name.map(|p| format!("{p} μ")).unwrap_or_else(|| "μ_RS / μ_flat · μ_HD".into());
        let friction = series_of(client, "friction", &mu_label).await?;
        let v8 = series_of(client, "voltage", &format!("{prefix}U eq. (8)")).await?;
        let v9 = series_of(client, "voltage", &format!("{prefix}U eq. (9)")).await?;
        if friction.0 != x || friction.1 != relative(&predicted, 0.5, 1.0) || v8.1 != eq8 || v9.1 != eq9 {
            return fail(format!("the plotted design {mu_label:?} (r_w = {width} mm) is not the core's"));
        }
    }
    // The legends and the list of pins.
    let legend = wd!(wd!(client.find(Locator::Css("#friction-plot .u-legend"))).text());
    let list = wd!(wd!(client.find(Locator::Id("pins"))).text());
    for p in [&p1, &p2] {
        if !legend.contains(&format!("{p} μ")) {
            return fail(format!("the friction plot's legend does not name {p}: {legend:?}"));
        }
    }
    if !list.contains(&format!("{p1}: bump r_w 1.3 mm")) || !list.contains(&format!("{p2}: bump r_w 2 mm")) {
        return fail(format!("the list of pinned designs: {list:?}"));
    }
    // The plots' text summaries name the current design and the pins.
    let summary = script(
        client,
        "const p = document.getElementById('voltage-plot'); \
         return [p.getAttribute('role'), p.getAttribute('aria-describedby'), \
                 document.getElementById(p.getAttribute('aria-describedby')).textContent];",
    )
    .await?;
    let text = summary[2].as_str().unwrap_or_default();
    if summary[0] != "img"
        || !text.starts_with("x from ")
        || !text.contains("U_max: 100 throughout")
        || !text.contains(&format!("{p2} U eq. (9): min 0 at x = "))
    {
        return fail(format!("the voltage plot's text summary: {summary}"));
    }
    // Four at once.
    let p3 = pin(client).await?;
    template_width(client, 1.6).await?;
    let p4 = pin(client).await?;
    let shown = labels(client, "friction").await?;
    for p in [&p1, &p2, &p3, &p4] {
        if !shown.contains(&format!("{p} μ")) {
            return fail(format!("with four pins the friction plot shows {shown:?}"));
        }
    }
    wd!(client.set_window_size(1280, 1700));
    tokio::time::sleep(Duration::from_millis(400)).await;
    save_screenshot("web-compare.png", &screenshot_of(client, "compare-box").await?);
    wd!(client.set_window_size(1280, 1000));
    tokio::time::sleep(Duration::from_millis(400)).await;
    // Removing P2 takes its series, and only those, away.
    unpin(client, &p2).await?;
    let shown = labels(client, "voltage").await?;
    if shown.iter().any(|l| l.starts_with(&format!("{p2} "))) || !shown.contains(&format!("{p3} U eq. (8)")) {
        return fail(format!("after removing {p2} the voltage plot shows {shown:?}"));
    }
    if series_of(client, "voltage", &format!("{p1} U eq. (8)")).await?.1 != core_relative_voltages(x, &default, 0.5).0 {
        return fail(format!("after removing {p2}, {p1}'s eq. (8) changed"));
    }
    // eq. (8) and eq. (9) together: off, then on again.
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("both-methods"))).click());
    wait_update(client, n, "the voltage without eq. (9)").await?;
    let shown = labels(client, "voltage").await?;
    if shown.iter().take(2).cloned().collect::<Vec<_>>() != ["U eq. (8)", "U_max"] {
        return fail(format!("eq. (9) unticked: the voltage plot shows {shown:?}"));
    }
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("both-methods"))).click());
    wait_update(client, n, "the voltage with eq. (9) again").await?;
    // Remove all: the plots are the current design alone, as before.
    wd!(wd!(client.find(Locator::Id("unpin-all"))).click());
    wait_for(client, "document.querySelectorAll('#pins li').length === 0", "no pins").await?;
    if labels(client, "voltage").await? != ["U eq. (8)", "U eq. (9)", "U_max"] {
        return fail("after removing every pin the voltage plot still shows pinned series");
    }
    template_width(client, 1.3).await
}

/// The phone viewport at `width` px: no sideways scrolling, every plot
/// inside the viewport and as wide as the column (resized to it), the
/// controls tall enough for a thumb (44 px), and the feel strip follows a
/// finger (WebDriver touch actions).
async fn phone_viewport(client: &Client, width: u32) -> Check<()> {
    wd!(client.set_window_size(width, 844));
    wait_for(client, &format!("window.innerWidth === {width}"), &format!("a {width} px wide viewport")).await?;
    tokio::time::sleep(Duration::from_millis(400)).await;
    let overflow = script(client, "return document.documentElement.scrollWidth - window.innerWidth;").await?;
    if overflow.as_f64().unwrap_or(1.0) > 0.0 {
        return fail(format!("{width} px: the page scrolls sideways by {overflow} px"));
    }
    let plots = script(
        client,
        "return Array.from(document.querySelectorAll('.plot .uplot')).filter(p => p.getClientRects().length) \
           .map(p => { const r = p.getBoundingClientRect(); \
             return [p.parentElement.id, r.left, r.right, p.querySelector('canvas').getBoundingClientRect().width]; });",
    )
    .await?;
    let plots = plots.as_array().ok_or("plots")?;
    if plots.len() < 3 {
        return fail(format!(
            "{width} px: {} plots shown, expected the height, friction and voltage plots",
            plots.len()
        ));
    }
    for p in plots {
        let (left, right, canvas) = (p[1].as_f64().unwrap_or(-1.0), p[2].as_f64().unwrap_or(1e9), p[3].as_f64());
        if left < 0.0 || right > width as f64 || canvas.unwrap_or(0.0) < 0.85 * width as f64 {
            return fail(format!("{width} px: plot {p} is not inside the viewport at the column's width"));
        }
    }
    let small = script(
        client,
        "const shown = e => e.getClientRects().length > 0; \
         const target = e => (e.type === 'checkbox' || e.type === 'radio') ? e.closest('label') || e : e; \
         return Array.from(document.querySelectorAll('#controls button, #controls select, #controls input, \
             #compare-box button, #feel-strip, .feel input')) \
           .filter(shown).map(target).filter(e => e.getBoundingClientRect().height < 44) \
           .map(e => e.id || e.outerHTML.slice(0, 80));",
    )
    .await?;
    if small.as_array().is_none_or(|s| !s.is_empty()) {
        return fail(format!("{width} px: controls less than 44 px tall (too small for a thumb): {small}"));
    }
    // A finger on the feel strip: down at 20% of its length, dragged to 70%.
    let strip = wd!(client.find(Locator::Id("feel-strip")));
    script(client, "document.getElementById('feel-strip').scrollIntoView({block: 'center'}); return true;").await?;
    let strip_width =
        script(client, "return document.getElementById('feel-strip').getBoundingClientRect().width;").await?;
    let strip_width = strip_width.as_f64().ok_or("strip width")?;
    let at = |fraction: f64| PointerAction::MoveToElement {
        element: strip.clone(),
        duration: Some(Duration::from_millis(30)),
        x: (fraction - 0.5) * strip_width,
        y: 0.0,
    };
    let finger = fantoccini::actions::TouchActions::new("finger".into())
        .then(at(0.2))
        .then(PointerAction::Down { button: fantoccini::actions::MOUSE_BUTTON_LEFT })
        .then(at(0.7))
        .then(PointerAction::Up { button: fantoccini::actions::MOUSE_BUTTON_LEFT });
    wd!(client.perform_actions(finger));
    wd!(client.release_actions());
    let read = script(
        client,
        "const d = document.getElementById('feel-readout').dataset; const v = window.haptex.state.voltage; \
         return [d.input, Number(d.xMm), v.x_mm[0], v.x_mm[v.x_mm.length - 1], 'ontouchstart' in window];",
    )
    .await?;
    let (x, x0, x1) =
        (read[1].as_f64().unwrap_or(f64::NAN), read[2].as_f64().unwrap_or(0.0), read[3].as_f64().unwrap_or(0.0));
    let fraction = (x - x0) / (x1 - x0);
    // With the touch events API (as on a phone, and here with
    // --touch-events=enabled) the page follows the finger by touch events.
    if read[0] != "touch" || (fraction - 0.7).abs() > 0.02 || read[4] != Value::Bool(true) {
        return fail(format!("{width} px: a finger dragged to 70% of the feel strip reads {read}"));
    }
    Ok(())
}

/// The feel strip from the keyboard: Home, End and the arrow keys move
/// the position read out (and its aria-valuenow).
async fn strip_keyboard(client: &Client) -> Check<()> {
    let strip = wd!(client.find(Locator::Id("feel-strip")));
    let read = "const d = document.getElementById('feel-readout').dataset; const v = window.haptex.state.voltage; \
                return [d.input, (Number(d.xMm) - v.x_mm[0]) / (v.x_mm[v.x_mm.length - 1] - v.x_mm[0]), \
                Number(document.getElementById('feel-strip').getAttribute('aria-valuenow'))];";
    for (keys, fraction) in [("\u{E011}", 0.0), ("\u{E010}", 1.0), ("\u{E012}\u{E012}", 0.98)] {
        wd!(strip.send_keys(keys));
        let r = script(client, read).await?;
        let got = r[1].as_f64().unwrap_or(f64::NAN);
        if r[0] != "keyboard" || (got - fraction).abs() > 1e-9 || r[2].as_f64() != Some((100.0 * fraction).round()) {
            return fail(format!("the feel strip from the keyboard: expected {fraction} of the length, read {r}"));
        }
    }
    Ok(())
}

/// Recipes (issue 17): the *recipe* download of the design shown (a
/// library stroke) lists the requests of its downloads with the library's
/// SHA-256; replayed by `haptex_server::recipe::replay` (what `haptex
/// recipe run` calls; crates/haptex-cli/tests/recipe_cli.rs runs the
/// binary) its voltage CSV is the page's download byte for byte; the
/// design's link (#design=..., its parameters) opened in a fresh page
/// reopens the library source and plots the replayed voltage and friction,
/// value for value, and so do a link of an older page (#recipe=..., the
/// whole recipe) and the recipe file opened with *Open a recipe*.
async fn recipes(client: &Client, base: &str, scratch: &Path) -> Check<()> {
    // From the template source (show_library switches to the library).
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css("input[name='source'][value='template']"))).click());
    wait_update(client, n, "the template source").await?;
    show_library(client, "latex").await?;
    let page_csv = download(client, "voltage-csv").await?;
    // The download carries the recipe in its comments.
    let head =
        String::from_utf8_lossy(&page_csv).lines().take_while(|l| l.starts_with('#')).collect::<Vec<_>>().join("\n");
    if !head.starts_with("# haptex ")
        || !head.contains("\"material\":\"latex\"")
        || !head.contains("# library_sha256: ")
        || !head.contains("\"mu_hd\":1.0")
    {
        return fail(format!("the voltage CSV's recipe comments: {head}"));
    }
    let bytes = download(client, "recipe").await?;
    let recipe_text = String::from_utf8(bytes).map_err(|e| e.to_string())?;
    let recipe = haptex_server::recipe::Recipe::parse(&recipe_text).map_err(|e| e.to_string())?;
    let kinds: Vec<&str> = recipe.downloads.iter().map(|d| d.path.split('?').next().unwrap_or_default()).collect();
    if kinds != ["/api/materials/latex/sample", "/api/voltage", "/api/voltage", "/api/play", "/api/play"]
        || recipe.source["material"] != "latex"
        || recipe.library_sha256.as_deref().map(str::len) != Some(64)
    {
        return fail(format!("the recipe download: {recipe_text}"));
    }
    let (state, _) = app_state();
    let files = haptex_server::recipe::replay(state, &recipe).await.map_err(|e| e.to_string())?;
    let replayed = files.iter().find(|(name, _)| name == "voltage.csv").ok_or("no voltage.csv replayed")?;
    if replayed.1 != page_csv {
        return fail("the replayed voltage.csv differs from the page's download");
    }
    // The stroke WAV's sidecar records the recipe's source and the data's SHA-256.
    let sidecar = files.iter().find(|(name, _)| name.ends_with(".wav.json")).ok_or("no sidecar replayed")?;
    let sidecar: Value = serde_json::from_slice(&sidecar.1).map_err(|e| e.to_string())?;
    let recorded = &sidecar["source"]["recipe"];
    if recorded["design"]["material"] != "latex" || recorded["library_sha256"] != json!(recipe.library_sha256) {
        return fail(format!("the stroke WAV sidecar's recipe: {sidecar}"));
    }
    let table = Table::read(replayed.1.as_slice(), "replayed voltage.csv").map_err(|e| e.to_string())?;
    let (mu, voltage) =
        (table.column("mu").ok_or("mu")?.to_vec(), table.column("voltage_v").ok_or("voltage_v")?.to_vec());
    // The link carries the design's parameters (material, stroke seed,
    // controls), not the stroke's data.
    let link = script(client, "return document.getElementById('share-link').href;").await?;
    let link = link.as_str().ok_or("no share link")?.to_string();
    if !link.starts_with(base)
        || !link.contains("#design=1&")
        || !link.contains("library.material=latex")
        || link.len() > 1024
    {
        return fail(format!("the design's link: {link}"));
    }
    if recipe.page.as_ref().and_then(|p| p.get("source")) != Some(&json!("library")) {
        return fail(format!("the recipe's page: {recipe_text}"));
    }
    // The link in a fresh page: the library source, the stroke the replay has.
    wd!(client.goto("about:blank"));
    wd!(client.goto(&link));
    let opened = "document.body.dataset.state === 'ready' && window.haptex.state.drawn \
                  && window.haptex.state.drawn.label.startsWith('recipe: latex')";
    wait_for(client, opened, "the recipe's design drawn").await?;
    if plotted(client, "voltage").await?[1] != voltage || plotted(client, "friction").await?[1] != mu {
        return fail("the link's design is not the replayed voltage and friction");
    }
    if script(client, "return window.haptex.state.source;").await? != "library" {
        return fail("the link's library design does not reopen the library source");
    }
    // A link of an older page: the whole recipe, without its page, as base64url.
    let mut older: Value = serde_json::from_str(&recipe_text).map_err(|e| e.to_string())?;
    older.as_object_mut().ok_or("the recipe is not an object")?.remove("page");
    use base64::Engine as _;
    let older = base64::engine::general_purpose::URL_SAFE_NO_PAD.encode(older.to_string());
    wd!(client.goto("about:blank"));
    wd!(client.goto(&format!("{base}#recipe={older}")));
    wait_for(client, opened, "an older page's recipe link drawn").await?;
    if plotted(client, "voltage").await?[1] != voltage || plotted(client, "friction").await?[1] != mu {
        return fail("an older page's recipe link is not the replayed voltage and friction");
    }
    // Then the recipe file opened in the page.
    wd!(client.goto("about:blank"));
    wd!(client.goto(base));
    wait_for(client, "document.body.dataset.state === 'ready'", "the page again").await?;
    let file = scratch.join("haptex-recipe.json");
    std::fs::write(&file, &recipe_text).unwrap();
    wd!(wd!(client.find(Locator::Id("recipe-file"))).send_keys(&file.display().to_string()));
    wait_for(client, opened, "the recipe file's design drawn").await?;
    if plotted(client, "voltage").await?[1] != voltage || plotted(client, "friction").await?[1] != mu {
        return fail("the opened recipe file's design is not the replayed voltage and friction");
    }
    if download(client, "voltage-csv").await? != replayed.1 {
        return fail("the opened recipe's voltage CSV differs from the replay");
    }
    // A link whose recipe cannot be read: said so, and the page works on.
    wd!(client.goto("about:blank"));
    wd!(client.goto(&format!("{base}#recipe=not-a-recipe")));
    wait_for(
        client,
        "document.body.dataset.state === 'ready' && \
         document.getElementById('message').textContent.startsWith(\"The link's recipe cannot be read\")",
        "a bad recipe link reported",
    )
    .await?;
    Ok(())
}

/// The server's state on the shipped data (library and FE database).
fn app_state() -> (AppState, PathBuf) {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data");
    let state = AppState::new(Some(&data.join("library/library.sqlite")), Limits::DEFAULT)
        .unwrap()
        .with_database(&data.join("db"))
        .unwrap();
    (state, data)
}

/// Step 17: the live output. A third server has a live output (the paced
/// test output of `common::paced_output`: the core's LiveEngine called
/// every 5 ms, with an ultrasonic channel of a_max 10 um): the page shows
/// the panel with the output; *Go live* sends the design the strip plays;
/// the strip from the keyboard (End: the profile's last x) drives it, and
/// the panel reads the position and the voltage played back from the
/// server (equal to the design's there within 1e-9 V, the fade done) with
/// the latency; a mouse hovering over the strip without a button sends
/// nothing; *Stop live* closes the output (faded). The page of a server
/// without a live output has no panel (checked on the first server).
async fn live_output(client: &Client, first: &str) -> Check<()> {
    wd!(client.goto(first));
    wait_for(client, "document.body.dataset.state === 'ready'", "the first server's page").await?;
    if script(client, "return document.getElementById('live-box').hidden;").await? != Value::Bool(true) {
        return fail("a server without a live output shows the live panel");
    }
    let output = std::sync::Arc::new(common::paced_output::PacedOutput::new(Some(10.0)));
    let (state, _) = app_state();
    let state =
        state.with_live_output(std::sync::Arc::clone(&output) as std::sync::Arc<dyn haptex_server::live::LiveOutput>);
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.map_err(|e| e.to_string())?;
    let addr = listener.local_addr().map_err(|e| e.to_string())?;
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    tokio::spawn(haptex_server::serve(listener, state, async {
        let _ = stopped.await;
    }));
    let result = drive_live(client, &format!("http://{addr}/"), &output).await;
    let _ = stop.send(());
    result
}

async fn drive_live(client: &Client, base: &str, output: &common::paced_output::PacedOutput) -> Check<()> {
    use std::sync::atomic::Ordering;
    wd!(client.set_window_size(1280, 1000));
    wd!(client.goto(base));
    wait_for(client, "document.body.dataset.state === 'ready' && window.haptex.state.voltage", "the page").await?;
    wait_for(client, "!document.getElementById('live-box').hidden", "the live panel").await?;
    let told = script(client, "return document.getElementById('live-output').textContent;").await?;
    if !told.as_str().is_some_and(|t| t.starts_with("paced test output, 48000 Hz, U_max 100 V")) {
        return fail(format!("the live panel names the output as {told}"));
    }
    wd!(wd!(client.find(Locator::Id("live-toggle"))).click());
    wait_for(client, "document.getElementById('live-box').dataset.live === 'on'", "the output opened").await?;
    let strip = wd!(client.find(Locator::Id("feel-strip")));
    wd!(strip.send_keys("\u{E010}")); // End
    let expected = script(
        client,
        "const v = window.haptex.state.voltage; return [v.x_mm[v.x_mm.length - 1], v.voltage_v[v.voltage_v.length - 1]];",
    )
    .await?;
    let expected = numbers(&expected)?;
    let code = format!(
        "Math.abs(Number(document.getElementById('live-box').dataset.xMm) - {:?}) < 1e-9 && \
         Math.abs(Number(document.getElementById('live-box').dataset.outputV) - {:?}) < 1e-9",
        expected[0], expected[1]
    );
    wait_for(client, &code, "the position and the voltage played back from the live output").await?;
    let read = script(
        client,
        "const d = document.getElementById('live-box').dataset; return [Number(d.events), Number(d.touchToOutputMs), \
         document.getElementById('live-readout').textContent];",
    )
    .await?;
    let (events, latency) = (read[0].as_f64().unwrap_or(0.0), read[1].as_f64().unwrap_or(f64::NAN));
    let text = read[2].as_str().unwrap_or("");
    if events < 1.0 || !(latency > 0.0 && latency < 100.0) || !text.contains("end to end") {
        return fail(format!("the live readout after a touch: {read}"));
    }
    // The feel strip with the live panel, for docs/live.md.
    script(client, "document.getElementById('feel').scrollIntoView(); return true;").await?;
    tokio::time::sleep(Duration::from_millis(200)).await;
    save_screenshot("web-live.png", &wd!(wd!(client.find(Locator::Id("feel"))).screenshot()));
    // A hovering mouse (no button) sends no touch.
    let hover = MouseActions::new("mouse".into()).then(PointerAction::MoveToElement {
        element: strip,
        duration: Some(Duration::from_millis(50)),
        x: 0.0,
        y: 0.0,
    });
    wd!(client.perform_actions(hover));
    tokio::time::sleep(Duration::from_millis(300)).await;
    let after = script(client, "return Number(document.getElementById('live-box').dataset.events);").await?;
    // The keyboard's touch was one event; the blur when the mouse moved may lift the finger (one more).
    if after.as_f64().unwrap_or(0.0) > events + 1.0 {
        return fail(format!("a hovering mouse drove the live output: {events} events before, {after} after"));
    }
    wd!(wd!(client.find(Locator::Id("live-toggle"))).click());
    let start = Instant::now();
    while output.closed.load(Ordering::SeqCst) < 1 {
        if start.elapsed() > WAIT {
            return fail("Stop live did not close the output");
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    if output.opened.load(Ordering::SeqCst) != 1 {
        return fail(format!("the output was opened {} times for one design", output.opened.load(Ordering::SeqCst)));
    }
    Ok(())
}

/// Step 15: recordings uploaded into a writable library and sampled back.
/// A second server serves a writable copy of the shipped library (no FE
/// database: the library is its first source); three demo velvet strokes,
/// renamed to a new material and flagged measured, are chosen in the file
/// input.
async fn upload_recordings(client: &Client, scratch: &Path) -> Check<()> {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/library");
    let lab = scratch.join("lab.sqlite");
    std::fs::copy(data.join("library.sqlite"), &lab).map_err(|e| e.to_string())?;
    let state = AppState::new(Some(&lab), Limits::DEFAULT)
        .and_then(AppState::with_writable_library)
        .map_err(|e| e.to_string())?;
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.map_err(|e| e.to_string())?;
    let addr = listener.local_addr().map_err(|e| e.to_string())?;
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    tokio::spawn(haptex_server::serve(listener, state, async {
        let _ = stopped.await;
    }));
    let result = upload_into(client, &format!("http://{addr}/"), &lab, scratch, &data.join("demo/velvet")).await;
    let _ = stop.send(());
    result
}

async fn upload_into(client: &Client, base: &str, lab: &Path, scratch: &Path, demo: &Path) -> Check<()> {
    const MATERIAL: &str = "velvet-lab";
    let folder = scratch.join("recordings");
    std::fs::create_dir_all(&folder).map_err(|e| e.to_string())?;
    let mut paths = Vec::new();
    for stroke in 1..=3 {
        for suffix in [".recording.json", ".force.npy", ".position.npy"] {
            let name = format!("velvet-s{stroke}{suffix}");
            let mut bytes = std::fs::read(demo.join(&name)).map_err(|e| e.to_string())?;
            if suffix == ".recording.json" {
                let text = String::from_utf8(bytes).map_err(|e| e.to_string())?;
                bytes = text
                    .replace("\"material\": \"velvet\"", &format!("\"material\": \"{MATERIAL}\""))
                    .replace("\"synthetic\": true", "\"synthetic\": false")
                    .into_bytes();
            }
            std::fs::write(folder.join(&name), bytes).map_err(|e| e.to_string())?;
            paths.push(folder.join(&name));
        }
    }
    wd!(client.goto(base));
    wait_for(client, "document.body.dataset.state === 'ready'", "the writable library's page").await?;
    wait_for(client, "!document.getElementById('recordings-box').hidden", "the upload panel").await?;
    accessible_names(client, "the upload panel").await?;
    let input = wd!(client.find(Locator::Id("recording-files")));
    let list: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    wd!(input.send_keys(&list.join("\n")));
    let chosen = script(client, "return document.getElementById('recording-files').files.length;").await?;
    if chosen != json!(9) {
        return fail(format!("{chosen} files chosen in the input, not 9"));
    }

    // The wrong provenance: refused by the server, its message shown.
    wd!(wd!(client.find(Locator::Id("provenance-synthetic"))).click());
    wd!(wd!(client.find(Locator::Id("upload-recordings"))).click());
    wait_for(client, "document.body.dataset.recordingsError === '1'", "the refusal").await?;
    let info = script(client, "return document.getElementById('recordings-info').textContent;").await?;
    let info = info.as_str().unwrap_or_default().to_string();
    if !info.starts_with("Not added: ") || !info.contains("\"synthetic\": false") {
        return fail(format!("the refused upload says: {info}"));
    }
    let listed =
        script(client, &format!("return Boolean(document.querySelector(\"#material option[value='{MATERIAL}']\"));"))
            .await?;
    if listed != Value::Bool(false) {
        return fail("a refused upload added its material");
    }

    // Measured: added, the report drawn, the material shown.
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Id("provenance-measured"))).click());
    wd!(wd!(client.find(Locator::Id("upload-recordings"))).click());
    wait_for(client, "document.body.dataset.recordings === '1'", "the upload's report").await?;
    wait_update(client, n, "a stroke of the uploaded material").await?;
    let report = script(client, "return window.haptex.state.recordings;").await?;
    let info = script(client, "return document.getElementById('recordings-info').textContent;").await?;
    if report["added"] != 3 || !info.as_str().unwrap_or_default().starts_with("3 strokes added") {
        return fail(format!("the upload's report: {info}"));
    }
    let plotted_reports =
        script(client, "return window.haptex.plots.recordings.map((p) => [p.data[0].length, p.series.length]);")
            .await?;
    if plotted_reports.as_array().map(Vec::len) != Some(3)
        || plotted_reports.as_array().unwrap().iter().any(|p| p[1] != 3 || p[0].as_u64().unwrap_or(0) < 1000)
    {
        return fail(format!("the report plots (points, series): {plotted_reports}"));
    }
    for (i, recording) in report["recordings"].as_array().ok_or("no recordings in the report")?.iter().enumerate() {
        let kept = recording["segments"].as_array().map_or(0, Vec::len);
        let listed = script(
            client,
            &format!(
                "return document.querySelectorAll('#recordings-report figure')[{i}].querySelectorAll('li.kept').length;"
            ),
        )
        .await?;
        if kept == 0 || listed != json!(kept) {
            return fail(format!("recording {i}: {kept} segments kept, {listed} listed"));
        }
    }
    save_screenshot("web-upload.png", &screenshot_of(client, "recordings-box").await?);
    let selected = script(client, "return document.getElementById('material').value;").await?;
    if selected != MATERIAL {
        return fail(format!("the material shown after the upload is {selected}"));
    }

    // Sampled back with a seed: the command line's import and sample of
    // the same files, value for value.
    let cli_path = scratch.join("cli.sqlite");
    let mut cli = Library::open(&cli_path).map_err(|e| e.to_string())?;
    let config = ProcessingConfig::default();
    let run = cli.begin_import("haptex library import", &config).map_err(|e| e.to_string())?;
    let mut metadata: Vec<&PathBuf> =
        paths.iter().filter(|p| p.to_string_lossy().ends_with(".recording.json")).collect();
    metadata.sort();
    for path in metadata {
        let recording = Recording::load(path).map_err(|e| e.to_string())?;
        let processed = process(&recording, &config).map_err(|e| e.to_string())?;
        cli.add_recording(run, &recording, &processed, &config).map_err(|e| e.to_string())?;
    }
    cli.finish_import(run).map_err(|e| e.to_string())?;
    for seed in [1u64, 4] {
        let n = updates(client).await?;
        let set_seed = format!(
            "const s = document.getElementById('seed'); s.value = '{seed}'; s.dispatchEvent(new Event('change')); return true;"
        );
        script(client, &set_seed).await?;
        wait_update(client, n, "the stroke of the seed").await?;
        let drawn = format!(
            "window.haptex.state.drawn.material === '{MATERIAL}' && window.haptex.state.drawn.seed === '{seed}'"
        );
        wait_for(client, &drawn, "the uploaded material's stroke drawn").await?;
        let friction = plotted(client, "friction").await?;
        let expected = cli.sample(MATERIAL, Some(seed)).map_err(|e| e.to_string())?;
        let profile = &expected.stored.profile;
        if friction[0] != profile.x_mm() || friction[1] != profile.mu() {
            return fail(format!("seed {seed}: the plotted stroke of {MATERIAL} is not the command line's sample"));
        }
        let label = script(client, "return window.haptex.state.drawn.label;").await?;
        if !label.as_str().unwrap_or_default().contains("(measured)") {
            return fail(format!("the uploaded stroke's label: {label}"));
        }
    }
    let stored = Library::open_read_only(lab).map_err(|e| e.to_string())?;
    if stored.strokes(MATERIAL).map_err(|e| e.to_string())?.len() != 3
        || !stored.check().map_err(|e| e.to_string())?.is_empty()
    {
        return fail("the writable library after the upload");
    }
    let errors = console_errors(client).await?;
    // The refused upload's 400 is logged by Chromium as a failed resource.
    let unexpected: Vec<&String> = errors.iter().filter(|e| !e.contains("/api/recordings")).collect();
    if !unexpected.is_empty() {
        return fail(format!("console errors during the upload: {unexpected:#?}"));
    }
    Ok(())
}

/// The map view (issue 19): uploads a grayscale PNG written here with a
/// gray mapping, checks the heat map's voltages and the pointer's reading
/// against the core, draws a path over the map with the mouse (press, drag,
/// release) and checks the plotted U(t) against the core's sampling of the
/// same path over the same map: the functions `haptex map from-image`,
/// `haptex map voltage` and `haptex map sample-path` call, in-process
/// (`FrictionMap::read_gray_png`, `FrictionMap::voltages`,
/// `PlanarTrajectory::sample`), value for value within 1e-12.
async fn map_view(client: &Client, base: &str, scratch: &Path) -> Check<()> {
    use haptex_core::map::{FrictionMap, GrayMapping, MapGrid};
    use haptex_core::planar::PlanarTrajectory;
    // A 64 x 40 image: a ramp along x, a bright disc and dark stripes.
    let (nx, ny) = (64usize, 40usize);
    let grid = MapGrid { nx, ny, x0_mm: 0.0, y0_mm: 0.0, dx_mm: 1.0, dy_mm: 1.0 };
    let levels: Vec<f64> = (0..nx * ny)
        .map(|k| {
            let (i, j) = ((k % nx) as f64, (k / nx) as f64);
            let disc = if (i - 40.0).powi(2) + (j - 22.0).powi(2) < 100.0 { 0.5 } else { 0.0 };
            let stripe = if (i as usize / 4).is_multiple_of(2) && j < 12.0 { -0.2 } else { 0.0 };
            (0.2 + 0.5 * i / 63.0 + disc + stripe).clamp(0.0, 1.0)
        })
        .collect();
    let mut png = Vec::new();
    FrictionMap { grid, mu: levels }
        .write_gray_png(&mut png, &GrayMapping { mu_black: 0.0, mu_white: 1.0, gamma: 1.0 }, 8)
        .map_err(|e| e.to_string())?;
    let file = scratch.join("map-texture.png");
    std::fs::write(&file, &png).map_err(|e| e.to_string())?;
    // The core's maps of it with the mapping typed below (the paper's device).
    let mapping = GrayMapping { mu_black: 0.95, mu_white: 1.25, gamma: 1.0 };
    let friction = FrictionMap::read_gray_png(&png, &mapping, (0.25, 0.25), (0.0, 0.0), "map-texture.png")
        .map_err(|e| e.to_string())?;
    let voltage = friction.voltages(&Device::PAPER, MapMethod::Physical).map_err(|e| e.to_string())?;

    wd!(client.set_window_size(1280, 1000));
    wd!(client.goto(&format!("{base}map")));
    wait_for(client, "document.body.dataset.state === 'empty' && window.haptexMap", "the map page").await?;
    accessible_names(client, "the map view").await?;
    for (id, value) in [("mu_black", "0.95"), ("mu_white", "1.25"), ("gamma", "1"), ("pixel_mm", "0.25")] {
        type_into(client, id, value).await?;
    }
    wd!(wd!(client.find(Locator::Id("image"))).send_keys(&file.display().to_string()));
    wait_for(client, "document.body.dataset.state === 'ready'", "the map of the uploaded image").await?;
    let map = script(client, "return window.haptexMap.state.map;").await?;
    if numbers(&map["voltage_v"])? != voltage.voltage_v || numbers(&map["mu"])? != friction.mu {
        return fail("the map page's friction or voltage map is not the core's map of the uploaded image");
    }
    if voltage.voltage_v.iter().all(|&u| u == voltage.voltage_v[0]) {
        return fail("the test image gives a constant voltage map: nothing is tested");
    }
    accessible_names(client, "the map view with a map").await?;

    // The pointer over the map reads U there (the core's bilinear sample).
    let canvas = wd!(client.find(Locator::Id("map-canvas")));
    let size = script(
        client,
        "const r = document.getElementById('map-canvas').getBoundingClientRect(); return [r.width, r.height];",
    )
    .await?;
    let size = numbers(&size)?;
    let (w, h) = (size[0], size[1]);
    let at = |fx: f64, fy: f64| PointerAction::MoveToElement {
        element: canvas.clone(),
        duration: Some(Duration::from_millis(25)),
        x: (fx - 0.5) * w,
        y: (fy - 0.5) * h,
    };
    wd!(client.perform_actions(MouseActions::new("mouse".into()).then(at(0.37, 0.41))));
    tokio::time::sleep(Duration::from_millis(100)).await;
    let read = script(
        client,
        "const d = document.getElementById('map-readout').dataset; return [Number(d.xMm), Number(d.yMm), Number(d.voltageV)];",
    )
    .await?;
    let read = numbers(&read)?;
    let expected = voltage.sample(read[0], read[1]);
    if (read[2] - expected).abs() > 1e-12 || (read[0] - 0.37 * 16.0).abs() > 0.3 || (read[1] - 0.59 * 10.0).abs() > 0.3
    {
        return fail(format!("the pointer over the map reads {read:?}; the core's U there is {expected} V"));
    }
    // The browser's audio follows the reading: U / U_max of full scale
    // (the audio output itself is switched on by the checkbox; headless
    // Chromium has no sound device, so the level asked for is read).
    wd!(wd!(client.find(Locator::Id("audio"))).click());
    wd!(client.perform_actions(MouseActions::new("mouse".into()).then(at(0.37, 0.42)).then(at(0.37, 0.41))));
    tokio::time::sleep(Duration::from_millis(100)).await;
    let heard = script(
        client,
        "const a = window.haptexMap.audio; return [a.level, a.context !== null, \
         Number(document.getElementById('map-readout').dataset.voltageV) / window.haptexMap.state.map.u_max_v];",
    )
    .await?;
    if heard[1] != Value::Bool(true)
        || (heard[0].as_f64().unwrap_or(f64::NAN) - heard[2].as_f64().unwrap_or(0.0)).abs() > 1e-12
    {
        return fail(format!("the map's audio: [level, on, U / U_max] = {heard}"));
    }
    wd!(wd!(client.find(Locator::Id("audio"))).click());

    // A path drawn with the mouse: pressed, dragged through the disc, released.
    let before = script(client, "return Number(document.body.dataset.path || 0);").await?;
    let before = before.as_u64().unwrap_or(0);
    let mut drag = MouseActions::new("mouse".into())
        .then(at(0.1, 0.8))
        .then(PointerAction::Down { button: fantoccini::actions::MOUSE_BUTTON_LEFT });
    for k in 1..=16 {
        let f = k as f64 / 16.0;
        drag = drag.then(at(0.1 + 0.8 * f, 0.8 - 0.6 * f * f));
    }
    drag = drag.then(PointerAction::Up { button: fantoccini::actions::MOUSE_BUTTON_LEFT });
    wd!(client.perform_actions(drag));
    wd!(client.release_actions());
    wait_for(client, &format!("Number(document.body.dataset.path || 0) > {before}"), "U(t) of the drawn path").await?;
    let path = script(client, "return window.haptexMap.state.path;").await?;
    let (t, x, y) = (numbers(&path["t_s"])?, numbers(&path["x_mm"])?, numbers(&path["y_mm"])?);
    let drawn = PlanarTrajectory::new(t.clone(), x.clone(), y.clone()).map_err(|e| e.to_string())?;
    let expected = drawn.sample(&voltage.grid, &voltage.voltage_v);
    let plotted = plotted_map(client).await?;
    if t.len() < 10 || (x[0] - 0.1 * 16.0).abs() > 0.3 || (x[x.len() - 1] - 0.9 * 16.0).abs() > 0.3 {
        return fail(format!(
            "the path recorded from the drag: {} samples, x from {} to {} mm",
            t.len(),
            x[0],
            x[x.len() - 1]
        ));
    }
    if plotted[0] != t || plotted[1].len() != expected.len() {
        return fail("the U(t) plot is not over the path's times");
    }
    if let Some(k) = (0..expected.len()).find(|&k| (plotted[1][k] - expected[k]).abs() > 1e-12) {
        return fail(format!(
            "U(t) at t = {} s (x {} mm, y {} mm): plotted {} V, the core's sample-path gives {} V",
            t[k], x[k], y[k], plotted[1][k], expected[k]
        ));
    }
    let (lo, hi) = expected.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &u| (a.min(u), b.max(u)));
    if hi - lo < 1.0 {
        return fail(format!("the drawn path's U(t) hardly varies ({lo} .. {hi} V): nothing is tested"));
    }
    // The downloads: the path and U(t) as the command line writes it.
    let bytes = download(client, "path-csv").await?;
    let table = Table::read(bytes.as_slice(), "map-path.csv").map_err(|e| e.to_string())?;
    if table.column("t_s") != Some(t.as_slice())
        || table.column("x_mm") != Some(x.as_slice())
        || table.column("y_mm") != Some(y.as_slice())
    {
        return fail("the path CSV download is not the path drawn");
    }
    let bytes = download(client, "voltage-csv").await?;
    let table = Table::read(bytes.as_slice(), "map-path-voltage.csv").map_err(|e| e.to_string())?;
    if table.column("voltage_v") != Some(expected.as_slice()) || table.column("t_s") != Some(t.as_slice()) {
        return fail("the U(t) CSV download is not the core's samples of the path drawn");
    }
    // The keyboard: Enter starts a path at the reading, five Right arrows
    // add a sample a cell (0.25 mm) further each at 20 mm/s, Enter ends
    // it; its U(t) is the core's sample-path of those six samples.
    let canvas = wd!(client.find(Locator::Id("map-canvas")));
    let n = script(client, "return Number(document.body.dataset.path || 0);").await?.as_u64().unwrap_or(0);
    wd!(canvas.send_keys("\u{E007}\u{E014}\u{E014}\u{E014}\u{E014}\u{E014}\u{E007}"));
    wait_for(client, &format!("Number(document.body.dataset.path || 0) > {n}"), "the keyboard path's U(t)").await?;
    let path = script(client, "return window.haptexMap.state.path;").await?;
    let (t, x, y) = (numbers(&path["t_s"])?, numbers(&path["x_mm"])?, numbers(&path["y_mm"])?);
    let steps_ok = t.len() == 6
        && (1..6).all(|k| (x[k] - x[k - 1] - 0.25).abs() < 1e-12 && (t[k] - t[k - 1] - 0.25 / 20.0).abs() < 1e-12)
        && y.iter().all(|&v| v == y[0]);
    let input = script(client, "return document.getElementById('map-readout').dataset.input;").await?;
    if !steps_ok || input != json!("keyboard") {
        return fail(format!("the keyboard path: t {t:?}, x {x:?}, y {y:?}; readout from {input}"));
    }
    let keyed = PlanarTrajectory::new(t, x, y).map_err(|e| e.to_string())?;
    if plotted_map(client).await?[1] != keyed.sample(&voltage.grid, &voltage.voltage_v) {
        return fail("the keyboard path's U(t) is not the core's sample-path");
    }
    // A finger (WebDriver touch actions): dragged across the map, it draws
    // a path as the mouse does (the map takes the drag instead of the
    // page's scrolling), read as touch, its U(t) the core's.
    let n = script(client, "return Number(document.body.dataset.path || 0);").await?.as_u64().unwrap_or(0);
    let mut finger = fantoccini::actions::TouchActions::new("finger".into())
        .then(at(0.15, 0.3))
        .then(PointerAction::Down { button: fantoccini::actions::MOUSE_BUTTON_LEFT });
    for k in 1..=12 {
        finger = finger.then(at(0.15 + 0.7 * k as f64 / 12.0, 0.3 + 0.4 * k as f64 / 12.0));
    }
    wd!(client.perform_actions(finger.then(PointerAction::Up { button: fantoccini::actions::MOUSE_BUTTON_LEFT })));
    wd!(client.release_actions());
    wait_for(client, &format!("Number(document.body.dataset.path || 0) > {n}"), "the finger path's U(t)").await?;
    let path = script(client, "return window.haptexMap.state.path;").await?;
    let (t, x, y) = (numbers(&path["t_s"])?, numbers(&path["x_mm"])?, numbers(&path["y_mm"])?);
    let input = script(client, "return document.getElementById('map-readout').dataset.input;").await?;
    if t.len() < 5
        || (x[0] - 0.15 * 16.0).abs() > 0.3
        || (x[x.len() - 1] - 0.85 * 16.0).abs() > 0.3
        || input != json!("touch")
    {
        return fail(format!(
            "the finger path: {} samples, x {:?} .. {:?}; read from {input}",
            t.len(),
            x.first(),
            x.last()
        ));
    }
    let touched = PlanarTrajectory::new(t, x, y).map_err(|e| e.to_string())?;
    if plotted_map(client).await?[1] != touched.sample(&voltage.grid, &voltage.voltage_v) {
        return fail("the finger path's U(t) is not the core's sample-path");
    }
    // The friction view and its colour bar.
    show_map(client, "friction").await?;
    let title = wd!(wd!(client.find(Locator::Id("map-title"))).text());
    let bar = script(client, "return document.getElementById('colour-bar').getAttribute('aria-label');").await?;
    if !title.contains("Friction") || !bar.as_str().unwrap_or_default().contains("μ from 0.95") {
        return fail(format!("the friction view: title {title:?}, colour bar {bar}"));
    }
    show_map(client, "voltage").await?;
    let bar = script(client, "return document.getElementById('colour-bar').getAttribute('aria-label');").await?;
    if !bar.as_str().unwrap_or_default().contains("V RMS") {
        return fail(format!("the voltage colour bar has no unit: {bar}"));
    }
    wd!(client.set_window_size(1280, 1250));
    tokio::time::sleep(Duration::from_millis(400)).await;
    script(client, "document.activeElement.blur(); window.scrollTo(0, 0); return true;").await?;
    save_screenshot("web-map.png", &wd!(client.screenshot()));
    // A phone's width: no sideways scrolling, the map inside the viewport.
    wd!(client.set_window_size(390, 844));
    wait_for(client, "window.innerWidth === 390", "a 390 px wide viewport").await?;
    tokio::time::sleep(Duration::from_millis(400)).await;
    let overflow = script(
        client,
        "const r = document.getElementById('colour-bar').getBoundingClientRect(); \
         return [document.documentElement.scrollWidth - window.innerWidth, r.right - window.innerWidth];",
    )
    .await?;
    wd!(client.set_window_size(1280, 1000));
    let overflow = numbers(&overflow)?;
    if overflow[0] > 0.0 || overflow[1] > 0.0 {
        return fail(format!("the map view at 390 px scrolls sideways ({overflow:?})"));
    }
    let errors = console_errors(client).await?;
    if !errors.is_empty() {
        return fail(format!("console errors on the map page: {errors:#?}"));
    }
    Ok(())
}

/// The data of the map page's U(t) plot: [t, U].
async fn plotted_map(client: &Client) -> Check<Vec<Vec<f64>>> {
    let data = script(client, "return window.haptexMap.plots.path.data;").await?;
    data.as_array().ok_or("no U(t) plot data")?.iter().map(numbers).collect()
}

/// Shows the friction or the voltage map (the page's select).
async fn show_map(client: &Client, what: &str) -> Check<()> {
    let n = updates(client).await?;
    wd!(wd!(client.find(Locator::Css(&format!("#show option[value='{what}']")))).click());
    wait_update(client, n, &format!("the {what} map shown")).await
}
