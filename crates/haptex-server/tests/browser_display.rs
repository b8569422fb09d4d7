//! "Your display" in a real browser (issue 36; headless Chromium through
//! chromedriver, the server in-process on a loopback port, as browser.rs):
//!
//! 1. a measurements file with a bad friction is refused beside its upload
//!    field (line and column named there; the page's header does not carry
//!    it);
//! 2. the shipped example uploaded: the fit drawn beside the panel (the
//!    model curves with their 95% bands for seven carriers, the measured
//!    points, the residuals, the plate), the estimates table with rho_sc
//!    identified;
//! 3. "Save device file" gives the TOML the server fitted (read back by the
//!    core); "Use for designs": the next design is made with it, the
//!    device fields show its constants, read-only, with a note naming it;
//! 4. one stroke is refused beside the strokes field; three strokes
//!    measured under the current design give the next design within U_max,
//!    with its iteration history drawn beside the panel.
//!
//! Needs /usr/bin/chromium and /usr/bin/chromedriver, or HAPTEX_CHROMIUM /
//! HAPTEX_CHROMEDRIVER; HAPTEX_BROWSER_TEST=skip skips it, saying so.

#[path = "common/browser.rs"]
mod browser;
mod common;

use std::path::{Path, PathBuf};

use browser::{Check, console_errors, script, wait_for};
use fantoccini::{Client, Locator};
use haptex_core::calibration::device_file::DeviceFile;
use haptex_core::io::Table;
use serde_json::Value;

#[test]
fn your_display_in_headless_chromium() {
    browser::run(common::shipped_state(), exercise);
}

macro_rules! wd {
    ($e:expr) => {
        $e.await.map_err(|e| format!("{}: {e}", stringify!($e)))?
    };
}

/// The page's rectangle of an element: [left, top, right, bottom].
async fn rect(client: &Client, id: &str) -> Check<[f64; 4]> {
    let r = script(
        client,
        &format!(
            "const r = document.getElementById('{id}').getBoundingClientRect(); return [r.left, r.top + \
                  window.scrollY, r.right, r.bottom + window.scrollY];"
        ),
    )
    .await?;
    let v: Vec<f64> = r.as_array().ok_or("no rect")?.iter().filter_map(Value::as_f64).collect();
    Ok([v[0], v[1], v[2], v[3]])
}

/// The error note `note` is shown right under the control `input` (within
/// 60 px), holds `words`, and the page's header does not.
async fn error_beside(client: &Client, note: &str, input: &str, words: &[&str]) -> Check<()> {
    let text = script(
        client,
        &format!("const e = document.getElementById('{note}'); return e.hidden ? null : e.textContent;"),
    )
    .await?;
    let text = text.as_str().ok_or(format!("{note} is hidden"))?.to_string();
    for w in words {
        if !text.contains(w) {
            return Err(format!("{note} says {text:?}, without {w:?}"));
        }
    }
    let (n, i) = (rect(client, note).await?, rect(client, input).await?);
    if !(n[1] >= i[3] - 1.0 && n[1] - i[3] < 60.0 && (n[0] - i[0]).abs() < 40.0) {
        return Err(format!("{note} at {n:?} is not beside {input} at {i:?}"));
    }
    let invalid =
        script(client, &format!("return document.getElementById('{input}').getAttribute('aria-invalid');")).await?;
    if invalid != "true" {
        return Err(format!("{input} is not marked invalid ({invalid})"));
    }
    let header = script(client, "return document.getElementById('message').textContent;").await?;
    if words.iter().all(|w| header.as_str().unwrap_or("").contains(w)) {
        return Err(format!("the error is in the page's header too: {header}"));
    }
    Ok(())
}

/// `results` lies beside the panel's controls (to their right on this
/// 1280 px window), in the "Your display" section.
async fn beside_the_panel(client: &Client, results: &str) -> Check<()> {
    let (r, c, s) =
        (rect(client, results).await?, rect(client, "yd-controls").await?, rect(client, "your-display").await?);
    if !(r[0] >= c[2] && r[1] < c[3] && r[1] >= s[1] && r[3] <= s[3] + 1.0) {
        return Err(format!("{results} at {r:?} is not beside the panel's controls at {c:?} (section {s:?})"));
    }
    Ok(())
}

async fn counter(client: &Client, name: &str) -> Check<u64> {
    Ok(script(client, &format!("return Number(document.body.dataset.{name} || 0);")).await?.as_u64().unwrap_or(0))
}

async fn upload(client: &Client, id: &str, files: &[PathBuf]) -> Check<()> {
    let paths: Vec<String> =
        files.iter().map(|p| p.canonicalize().unwrap_or_else(|_| p.clone()).display().to_string()).collect();
    wd!(wd!(client.find(Locator::Id(id))).send_keys(&paths.join("\n")));
    Ok(())
}

async fn exercise(client: &Client, base: &str, scratch: &Path) -> Check<()> {
    wd!(client.goto(base));
    wait_for(client, "document.body.dataset.state === 'ready' && window.haptex.state.voltage", "the first design")
        .await?;
    let example = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/examples/calibration-measurements.csv");
    let text = std::fs::read_to_string(&example).map_err(|e| e.to_string())?;

    // 1. A bad file: refused beside its field, naming the line and the column.
    let bad: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| if i == 8 { l.replacen(",0.", ",x0.", 1) } else { l.to_string() })
        .collect();
    let bad_path = scratch.join("bad-measurements.csv");
    std::fs::write(&bad_path, bad.join("\n")).map_err(|e| e.to_string())?;
    let errors = counter(client, "ydErrors").await?;
    upload(client, "yd-measurements", &[bad_path]).await?;
    wait_for(client, &format!("Number(document.body.dataset.ydErrors || 0) > {errors}"), "the refusal").await?;
    error_beside(client, "yd-measurements-error", "yd-measurements", &["bad-measurements.csv", "line 9", "column"])
        .await?;

    // 2. The shipped example: the fit drawn beside the panel.
    upload(client, "yd-measurements", std::slice::from_ref(&example)).await?;
    wait_for(client, "Number(document.body.dataset.ydFits || 0) >= 1", "the fit").await?;
    let hidden = script(client, "return document.getElementById('yd-measurements-error').hidden;").await?;
    if hidden != Value::Bool(true) {
        return Err("the refusal is still shown after a good file".into());
    }
    beside_the_panel(client, "yd-fit-results").await?;
    let fit = script(
        client,
        "const p = window.haptex.plots; return { series: p.ydFit.series.length, bands: p.ydFit.bands.length, \
         points: p.ydFit.measured.reduce((n, s) => n + s.x.length, 0), residuals: p.ydResiduals.measured.length, \
         plate: Boolean(p.ydPlate), rows: document.querySelectorAll('#yd-estimates tbody tr').length, \
         rho: Array.from(document.querySelectorAll('#yd-estimates tbody tr')).find(r => r.cells[0].textContent \
           .startsWith('ρ_sc')).cells[3].textContent };",
    )
    .await?;
    if fit["series"] != 1 + 3 * 7 || fit["bands"] != 7 || fit["points"].as_u64() < Some(300) || fit["plate"] != true {
        return Err(format!("the fit drawn: {fit}"));
    }
    if fit["rho"] != "yes" || fit["rows"].as_u64() < Some(10) {
        return Err(format!("the estimates table: {fit}"));
    }

    // 3. Save the device file; use it for designs.
    wd!(wd!(client.find(Locator::Id("yd-save"))).click());
    wait_for(client, "Number(document.getElementById('yd-save-link').dataset.count || 0) >= 1", "the saved file")
        .await?;
    let fetch = "const done = arguments[arguments.length - 1];
        fetch(document.getElementById('yd-save-link').href).then(r => r.text()).then(done).catch(e => done('error: ' + e));";
    let toml = wd!(client.execute_async(fetch, vec![]));
    let toml = toml.as_str().ok_or("no device file text")?.to_string();
    let file = DeviceFile::from_toml(&toml, "saved").map_err(|e| format!("the saved device file: {e}"))?;
    let electro = file.electrovibration.as_ref().ok_or("no electrovibration in the saved file")?;
    if electro.model != "circuit" {
        return Err(format!("the saved file's model is {}", electro.model));
    }
    let updates = counter(client, "updates").await?;
    wd!(wd!(client.find(Locator::Id("yd-use"))).click());
    wait_for(
        client,
        &format!("Number(document.body.dataset.updates) > {updates} && window.haptex.state.voltage.device_file"),
        "the design with the device file",
    )
    .await?;
    let used = script(
        client,
        "const v = window.haptex.state.voltage; const mu = document.getElementById('param-mu_hd'); \
         return { mu_hd: v.parameters.mu_hd, field: Number(mu.value), readonly: mu.readOnly, \
         sha: v.device_file.sha256, note: (document.getElementById('device-file-note') || {}).textContent || '', \
         in_box: Boolean(document.querySelector('#device-box #device-file-note')) };",
    )
    .await?;
    let mu = used["mu_hd"].as_f64().unwrap_or(f64::NAN);
    if (mu - electro.mu_hd.value).abs() > 1e-12 || (used["field"].as_f64().unwrap_or(0.0) - mu).abs() > 1e-5 * mu {
        return Err(format!("the design's mu_HD is not the file's {}: {used}", electro.mu_hd.value));
    }
    if used["readonly"] != true
        || used["in_box"] != true
        || !used["note"].as_str().unwrap_or("").contains("device file")
    {
        return Err(format!("the device fields do not say where the constants came from: {used}"));
    }
    if used["sha"] != haptex_core::io::sha256_hex(toml.as_bytes()) {
        return Err(format!("the design names another device file: {used}"));
    }

    // 4. Strokes: one is refused beside the field; three give the next design.
    let design = script(client, "const v = window.haptex.state.voltage; return [v.x_mm, v.mu];").await?;
    let (x, target): (Vec<f64>, Vec<f64>) = (
        design[0].as_array().ok_or("x")?.iter().filter_map(Value::as_f64).collect(),
        design[1].as_array().ok_or("mu")?.iter().filter_map(Value::as_f64).collect(),
    );
    let strokes: Vec<PathBuf> = (0..3)
        .map(|k| {
            let mut csv = String::from("x_mm,mu\n");
            let (x0, x1) = (x[0] - 0.5, x[x.len() - 1] + 0.5);
            let n = ((x1 - x0) / 0.01) as usize;
            for i in 0..=n {
                let xi = x0 + 0.01 * i as f64;
                let j = x.partition_point(|&v| v < xi).min(x.len() - 1);
                let wobble =
                    1.0 + 0.01 * (3.0 * xi + k as f64).sin() + 0.004 * ((i * 7919 + k * 31) % 13) as f64 / 13.0;
                csv += &format!("{xi:.4},{:.6}\n", target[j] * 0.97 * wobble);
            }
            let path = scratch.join(format!("stroke-{}.csv", k + 1));
            std::fs::write(&path, csv).unwrap();
            path
        })
        .collect();
    let errors = counter(client, "ydErrors").await?;
    upload(client, "yd-strokes", &strokes[..1]).await?;
    wd!(wd!(client.find(Locator::Id("yd-next"))).click());
    wait_for(client, &format!("Number(document.body.dataset.ydErrors || 0) > {errors}"), "the strokes' refusal")
        .await?;
    error_beside(client, "yd-strokes-error", "yd-strokes", &["at least 2"]).await?;
    wd!(wd!(client.find(Locator::Id("yd-strokes"))).clear());
    upload(client, "yd-strokes", &strokes).await?;
    wd!(wd!(client.find(Locator::Id("yd-next"))).click());
    wait_for(client, "Number(document.body.dataset.ydIterations || 0) >= 1", "the next design").await?;
    beside_the_panel(client, "yd-ilc-results").await?;
    let step = script(
        client,
        "const c = window.haptex.calibration.history; return { csv: c.design_csv, u_max: c.u_max_v, \
         history: window.haptex.plots.ydHistory.data[1].length, info: document.getElementById('yd-ilc-info').textContent };",
    )
    .await?;
    if step["history"] != 1 || !step["info"].as_str().unwrap_or("").starts_with("Iteration 0") {
        return Err(format!("the iteration shown: {step}"));
    }
    let table = Table::read(step["csv"].as_str().unwrap_or("").as_bytes(), "next design").map_err(|e| e.to_string())?;
    let u_max = step["u_max"].as_f64().unwrap_or(0.0);
    let voltage = table.require("voltage_v").map_err(|e| e.to_string())?;
    if !voltage.iter().all(|u| (0.0..=u_max).contains(u))
        || !table.comments().iter().any(|c| c.contains("ilc iteration 0"))
    {
        return Err(format!("the next design is not within U_max = {u_max} V or has no history"));
    }
    // The browser logs the refusal of the bad measurements (step 1) itself; nothing else.
    let console: Vec<String> = console_errors(client)
        .await?
        .into_iter()
        .filter(|e| !(e.contains("/api/calibrate - Failed to load resource") && e.contains("status of 400")))
        .collect();
    if !console.is_empty() {
        return Err(format!("console errors: {console:?}"));
    }
    Ok(())
}
