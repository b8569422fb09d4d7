//! `haptex recipe run` replays a recipe of the web application to the
//! files the server answers, byte for byte: the `haptex serve` binary is
//! asked each download's request over HTTP (as the page asks it), the
//! `haptex recipe run` binary writes the recipe's files, and the two are
//! compared. One recipe per kind of source the GUI has (a surface
//! template, a library stroke, an uploaded profile on the combined
//! display), each with the downloads the GUI puts in it (profile CSV,
//! voltage CSV and JSON, stroke WAV and its sidecar). A recipe made with
//! other data (its database SHA-256) is refused naming that field.

use std::io::{BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use serde_json::{Value, json};

mod common;

/// `haptex serve` on a free loopback port, stopped when dropped.
struct Server {
    child: Child,
    port: u16,
}

impl Server {
    fn start() -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_haptex"))
            .args(["serve", "--addr", "127.0.0.1:0"])
            .env_remove("HAPTEX_LIBRARY")
            .env_remove("HAPTEX_DB")
            .stderr(Stdio::piped())
            .spawn()
            .expect("run haptex serve");
        let mut stderr = BufReader::new(child.stderr.take().unwrap());
        let (port, _) = common::listening_port(&mut stderr);
        Self { child, port }
    }

    /// The body of the answer to `method path` (with a JSON `body`); panics
    /// unless the status is 200.
    fn ask(&self, method: &str, path: &str, body: Option<&Value>) -> Vec<u8> {
        let mut socket = TcpStream::connect(("127.0.0.1", self.port)).unwrap();
        socket.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        let payload = body.map(|b| serde_json::to_vec(b).unwrap()).unwrap_or_default();
        let mut head = format!("{method} {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n");
        if body.is_some() {
            head.push_str(&format!("Content-Type: application/json\r\nContent-Length: {}\r\n", payload.len()));
        }
        head.push_str("\r\n");
        socket.write_all(head.as_bytes()).unwrap();
        socket.write_all(&payload).unwrap();
        let mut answer = Vec::new();
        socket.read_to_end(&mut answer).unwrap();
        let split = answer.windows(4).position(|w| w == b"\r\n\r\n").expect("an HTTP answer");
        let head = String::from_utf8_lossy(&answer[..split]).to_lowercase();
        let body = answer[split + 4..].to_vec();
        assert!(head.starts_with("http/1.1 200"), "{method} {path}: {head}\n{}", String::from_utf8_lossy(&body));
        if head.contains("transfer-encoding: chunked") { dechunk(&body) } else { body }
    }

    fn json(&self, method: &str, path: &str, body: Option<&Value>) -> Value {
        serde_json::from_slice(&self.ask(method, path, body)).unwrap()
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The body of a chunked HTTP/1.1 answer.
fn dechunk(mut body: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let end = body.windows(2).position(|w| w == b"\r\n").expect("a chunk size");
        let size = usize::from_str_radix(std::str::from_utf8(&body[..end]).unwrap().trim(), 16).unwrap();
        if size == 0 {
            return out;
        }
        out.extend_from_slice(&body[end + 2..end + 2 + size]);
        body = &body[end + 2 + size + 2..];
    }
}

/// A recipe as the GUI writes it, with its downloads' requests.
fn recipe(config: &Value, source: Value, downloads: Vec<(&str, &str, &str, Option<Value>)>) -> Value {
    let mut r = json!({
        "format": "haptex-recipe/1",
        "haptex_version": config["version"],
        "source": source,
        "downloads": downloads.iter().map(|(file, method, path, body)| {
            let mut d = json!({ "file": file, "method": method, "path": path });
            if let Some(body) = body { d["body"] = body.clone(); }
            d
        }).collect::<Vec<_>>(),
    });
    // Every data set served, as the page records them (a replay refuses an unpinned one).
    r["database_sha256"] = config["data"]["database_sha256"].clone();
    r["library_sha256"] = config["data"]["library_sha256"].clone();
    r
}

/// The play requests of the GUI's stroke WAV and its sidecar for a voltage answer.
fn strokes(voltage: &Value) -> (Value, Value) {
    let mut v = json!({ "x_mm": voltage["x_mm"], "voltage_v": voltage["voltage_v"] });
    let mut wav = json!({ "voltage": v.clone(), "stroke": { "velocity_mm_s": 50 },
        "carrier": { "shape": "sine", "frequency_hz": 1000 }, "u_max_v": 100 });
    if voltage.get("amplitude_um").is_some() {
        v["amplitude_um"] = voltage["amplitude_um"].clone();
        wav["voltage"] = v;
        wav["a_max_um"] = voltage["summary"]["ultrasonic"]["a_max_um"].clone();
    }
    let mut sidecar = wav.clone();
    sidecar["format"] = json!("sidecar");
    (wav, sidecar)
}

/// Runs `haptex recipe run` on `recipe`; the output and the files written.
fn run_recipe(recipe: &Value) -> (std::process::Output, tempfile::TempDir) {
    run_recipe_with(recipe, &[])
}

/// [`run_recipe`] with more flags.
fn run_recipe_with(recipe: &Value, flags: &[&str]) -> (std::process::Output, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("recipe.json");
    std::fs::write(&file, serde_json::to_string_pretty(recipe).unwrap()).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_haptex"))
        .args(["recipe", "run", file.to_str().unwrap(), "-o", dir.path().join("out").to_str().unwrap()])
        .args(flags)
        .env_remove("HAPTEX_LIBRARY")
        .env_remove("HAPTEX_DB")
        .output()
        .unwrap();
    (output, dir)
}

/// Every download of `recipe` from the server equals the replayed file.
fn replays_byte_for_byte(server: &Server, recipe: &Value) {
    let (output, dir) = run_recipe(recipe);
    assert!(output.status.success(), "haptex recipe run: {}", String::from_utf8_lossy(&output.stderr));
    for d in recipe["downloads"].as_array().unwrap() {
        let file = d["file"].as_str().unwrap();
        let served = server.ask(d["method"].as_str().unwrap(), d["path"].as_str().unwrap(), d.get("body"));
        let replayed = std::fs::read(dir.path().join("out").join(file)).unwrap();
        assert!(served.len() > 40, "{file}: {} bytes served", served.len());
        assert!(served == replayed, "{file}: the replay differs from the server's download");
    }
}

#[test]
fn recipe_run_reproduces_each_kind_of_download_byte_for_byte() {
    let server = Server::start();
    let config = server.json("GET", "/api/config", None);
    assert_eq!(config["data"]["database_sha256"].as_str().map(str::len), Some(64), "{}", config["data"]);
    assert_eq!(config["data"]["library_sha256"].as_str().map(str::len), Some(64), "{}", config["data"]);

    // A template: the default bump, relative to mu_skin, eq. (8).
    let template = json!({ "surface": "bump", "x0_mm": 5, "width_mm": 1.3, "height_mm": 0.27, "velocity_mm_s": 20 });
    let predicted = server.json("POST", "/api/predict", Some(&template));
    let voltage_body = json!({ "profile": { "x_mm": predicted["x_mm"], "mu": predicted["mu"] }, "method": "physical",
        "device": { "mu_hd": 1, "u_max_v": 100 }, "relative": true, "flat_mu": 0.5 });
    let voltage = server.json("POST", "/api/voltage", Some(&voltage_body));
    let (wav, sidecar) = strokes(&voltage);
    let mut source = template.clone();
    source["kind"] = json!("template");
    let mut r = recipe(
        &config,
        source,
        vec![
            ("bump-w1.3-h0.27-v20.csv", "POST", "/api/predict?format=csv", Some(template.clone())),
            ("voltage.csv", "POST", "/api/voltage?format=csv", Some(voltage_body.clone())),
            ("voltage.json", "POST", "/api/voltage", Some(voltage_body.clone())),
            ("stroke-50mm_s.wav", "POST", "/api/play", Some(wav)),
            ("stroke-50mm_s.wav.json", "POST", "/api/play", Some(sidecar)),
        ],
    );
    // The page's design, as the GUI records it (the page reopens the
    // template from it; the replay does not read it).
    r["page"] = json!({ "source": "template", "template": template, "method": "physical", "relative": true,
        "flat_mu": 0.5, "both": true, "display": "electrovibration", "strategy": "split", "weight": null,
        "a_max_um": null, "device": { "mu_hd": 1, "u_max_v": 100, "fn_n": null },
        "play": { "velocity_mm_s": 50, "carrier_hz": 1000 } });
    replays_byte_for_byte(&server, &r);

    // The same recipe made with another FE database is refused, naming the field, nothing written.
    let mut other = r.clone();
    other["database_sha256"] = json!("0".repeat(64));
    let (output, dir) = run_recipe(&other);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success() && stderr.contains("database_sha256"), "{stderr}");
    assert!(!dir.path().join("out").exists(), "files written for a refused recipe");

    // A library stroke (latex, seed 3), eq. (8) as it is.
    let sample_path = "/api/materials/latex/sample?seed=3";
    let sample = server.json("GET", sample_path, None);
    // With its source, as the page sends it: the recipe in the answer's comments.
    let voltage_body = json!({ "profile": { "x_mm": sample["x_mm"], "mu": sample["mu"], "fn_n": sample["fn_n"] },
        "method": "physical", "device": { "mu_hd": 1 },
        "source": { "kind": "library", "material": "latex", "seed": "3" } });
    let csv = server.ask("POST", "/api/voltage?format=csv", Some(&voltage_body));
    assert!(csv.starts_with(b"# haptex ") && String::from_utf8_lossy(&csv).contains("# library_sha256: "));
    let voltage = server.json("POST", "/api/voltage", Some(&voltage_body));
    let (wav, _) = strokes(&voltage);
    let r = recipe(
        &config,
        json!({ "kind": "library", "material": "latex", "seed": "3" }),
        vec![
            ("latex-stroke.csv", "GET", "/api/materials/latex/sample?seed=3&format=csv", None),
            ("voltage.csv", "POST", "/api/voltage?format=csv", Some(voltage_body.clone())),
            ("voltage.json", "POST", "/api/voltage", Some(voltage_body)),
            ("stroke-50mm_s.wav", "POST", "/api/play", Some(wav)),
        ],
    );
    replays_byte_for_byte(&server, &r);

    // An uploaded profile on the combined display (two channels).
    let x: Vec<f64> = (0..41).map(|i| 0.25 * f64::from(i)).collect();
    let mu: Vec<f64> = x.iter().map(|x| 1.0 + 0.3 * (x * 1.3).sin()).collect();
    let profile = json!({ "x_mm": x, "mu": mu });
    let voltage_body = json!({ "profile": profile, "device": { "mu_hd": 1 }, "display": "combined",
        "strategy": "weighted", "weight": 5 });
    let voltage = server.json("POST", "/api/voltage", Some(&voltage_body));
    assert!(voltage.get("amplitude_um").is_some(), "{voltage}");
    let (wav, sidecar) = strokes(&voltage);
    let r = recipe(
        &config,
        json!({ "kind": "upload", "file": "wave.csv" }),
        vec![
            ("wave-profile.csv", "POST", "/api/profile?format=csv", Some(profile)),
            ("display-combined.csv", "POST", "/api/voltage?format=csv", Some(voltage_body.clone())),
            ("display-combined.json", "POST", "/api/voltage", Some(voltage_body)),
            ("stroke-50mm_s-combined-2ch.wav", "POST", "/api/play", Some(wav)),
            ("stroke-50mm_s-combined-2ch.wav.json", "POST", "/api/play", Some(sidecar)),
        ],
    );
    replays_byte_for_byte(&server, &r);
}

#[test]
fn recipe_run_refuses_a_bad_recipe_naming_the_field() {
    for (recipe, field) in [
        (
            json!({ "format": "haptex-recipe/9", "haptex_version": env!("CARGO_PKG_VERSION"), "downloads": [] }),
            "format",
        ),
        (
            json!({ "format": "haptex-recipe/1", "haptex_version": env!("CARGO_PKG_VERSION"),
                "downloads": [{ "file": "../x.csv", "method": "GET", "path": "/api/health" }] }),
            "downloads[0].file",
        ),
        (
            json!({ "format": "haptex-recipe/1", "haptex_version": env!("CARGO_PKG_VERSION"),
                "downloads": [{ "file": "x.csv", "method": "GET", "path": "/etc/passwd" }] }),
            "downloads[0].path",
        ),
        (
            json!({ "format": "haptex-recipe/1", "haptex_version": "0.0.0-other",
                "downloads": [{ "file": "x.json", "method": "GET", "path": "/api/health" }] }),
            "haptex_version",
        ),
    ] {
        let (output, _dir) = run_recipe(&recipe);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success() && stderr.contains(field), "{field}: {stderr}");
    }
}

/// Issue 35, "Bounded cost per request": a recipe's files may hold 64 MiB
/// together, checked on each play's request (duration x sample rate x
/// channels x bytes) before any download is answered. The case: a
/// 5 KB recipe of 32 plays took 738 MB and wrote 470 MB. Here 32 plays of
/// 40 s each (1 920 001 samples, 3.7 MiB as PCM16): the 18th passes the
/// budget, the error names it, nothing is rendered or written. The recipe
/// pins the shipped data it replays against.
#[test]
fn a_recipe_over_its_memory_budget_is_refused_before_any_answer() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let library = haptex_core::io::sha256_file(&root.join("data/library/library.sqlite")).unwrap();
    let database = haptex_server::state::database_sha256(&root.join("data/db")).unwrap();
    let play = json!({
        "voltage": { "x_mm": [0, 10], "voltage_v": [0, 100] },
        "stroke": { "velocity_mm_s": 1, "strokes": 4 },
    });
    let downloads: Vec<Value> = (0..32)
        .map(|i| json!({ "file": format!("stroke-{i}.wav"), "method": "POST", "path": "/api/play", "body": play }))
        .collect();
    let recipe = json!({
        "format": "haptex-recipe/1", "haptex_version": env!("CARGO_PKG_VERSION"),
        "library_sha256": library, "database_sha256": database, "downloads": downloads,
    });
    assert!(recipe.to_string().len() < 8192);
    let (output, dir) = run_recipe(&recipe);
    let e = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "{e}");
    assert!(e.contains("downloads[17]") && e.contains("64 MiB a recipe may write"), "{e}");
    assert!(!dir.path().join("out").exists());
    // Fewer of the same plays are answered and written.
    let mut fewer = recipe.clone();
    fewer["downloads"] = json!(recipe["downloads"].as_array().unwrap()[..2]);
    let (output, dir) = run_recipe(&fewer);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(std::fs::metadata(dir.path().join("out/stroke-1.wav")).unwrap().len() > 3_800_000);
}

/// A file far larger than any recipe is refused by its size, before it is
/// parsed, and nothing is written.
#[test]
fn an_oversized_recipe_is_refused_unread() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.json");
    std::fs::write(&path, vec![b' '; (16 << 20) + 1]).unwrap();
    let out_dir = dir.path().join("out");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_haptex"))
        .args(["recipe", "run", path.to_str().unwrap(), "-o", out_dir.to_str().unwrap()])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && e.contains("big.json") && e.contains("larger than 16 MiB"), "{e}");
    assert!(!out_dir.exists());
}

/// Issue 35: a recipe replays only against the data it was made with. The
/// answers depend on the texture library and the FE database served
/// (their strokes and templates, and their SHA-256 in the voltage CSV's
/// recipe comments and the WAV sidecar), so a recipe that does not pin one
/// (no `library_sha256` or `database_sha256`, or `null`) is refused naming
/// the field, nothing written; `--allow-unpinned` replays it and says on
/// stderr what was not checked; a hash that differs is refused either way.
#[test]
fn a_recipe_must_pin_every_data_set_it_depends_on() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let library_sha256 = haptex_core::io::sha256_file(&root.join("data/library/library.sqlite")).unwrap();
    let database_sha256 = haptex_server::state::database_sha256(&root.join("data/db")).unwrap();
    let pinned = json!({ "format": "haptex-recipe/1", "haptex_version": env!("CARGO_PKG_VERSION"),
        "library_sha256": library_sha256, "database_sha256": database_sha256,
        "source": { "kind": "library", "material": "latex", "seed": "3" },
        "downloads": [{ "file": "latex-stroke.csv", "method": "GET", "path": "/api/materials/latex/sample?seed=3&format=csv" }] });
    let (output, dir) = run_recipe(&pinned);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let replayed = std::fs::read(dir.path().join("out/latex-stroke.csv")).unwrap();
    assert!(String::from_utf8_lossy(&replayed).contains(&format!("library_sha256: {library_sha256}")));

    for field in ["library_sha256", "database_sha256"] {
        for unpinned in [None, Some(Value::Null)] {
            let mut r = pinned.clone();
            match &unpinned {
                None => drop(r.as_object_mut().unwrap().remove(field)),
                Some(null) => r[field] = null.clone(),
            }
            let (output, dir) = run_recipe(&r);
            let stderr = String::from_utf8_lossy(&output.stderr);
            assert!(!output.status.success(), "{field} {unpinned:?}: replayed unpinned");
            assert!(
                stderr.contains(&format!("{field}: missing (or null)")) && stderr.contains("--allow-unpinned"),
                "{stderr}"
            );
            assert!(!dir.path().join("out").exists(), "files written for a refused recipe");

            let (output, dir) = run_recipe_with(&r, &["--allow-unpinned"]);
            let stderr = String::from_utf8_lossy(&output.stderr);
            assert!(output.status.success(), "{stderr}");
            assert!(stderr.contains(&format!("warning: {field}: the recipe does not pin")), "{stderr}");
            assert!(stderr.contains("not checked"), "{stderr}");
            assert_eq!(stderr.matches("warning:").count(), 1, "{stderr}");
            assert_eq!(std::fs::read(dir.path().join("out/latex-stroke.csv")).unwrap(), replayed);
        }
        // Another data set's hash is refused, --allow-unpinned or not.
        let mut r = pinned.clone();
        r[field] = json!("0".repeat(64));
        let (output, dir) = run_recipe_with(&r, &["--allow-unpinned"]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success() && stderr.contains(field), "{stderr}");
        assert!(!dir.path().join("out").exists());
    }
}
