//! The adversarial table (issue 13): every route of `routes::table()`
//! under oversized, malformed, non-finite and hostile input, over real
//! TCP connections to `haptex_server::serve` (so that hyper's own parsing
//! is part of it). Each case must get its 4xx with the security headers
//! and a JSON error naming the field at fault (never a 5xx, never a bare
//! answer), while `/api/health`, asked every 10 ms by another client,
//! answers throughout, each time sooner than a maximal upload is answered
//! (its latency under load is a benchmark: scripts/load_health.py).
//!
//! The table is built from one valid request per route: generic cases
//! (method, query, host, head sizes, content type, body shape and size)
//! derived from it for every route, and each route's own fields (every
//! number at 1e308, -1e308, 5e-324, 1e999 where that is out of range,
//! wrong types, hostile strings and names). A route of the table without
//! a valid request here fails the test: a new route must come with its
//! cases.

mod common;

use std::collections::BTreeSet;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use haptex_core::ranges;
use haptex_server::params::DEVICE_PARAMS;
use haptex_server::routes;
use serde_json::{Value, json};

use common::{RawServer, check_json_error, shipped_db, shipped_library};

/// The multipart boundary of the upload cases.
const BOUNDARY: &str = "adversarial-0f3c";

/// A multipart/form-data body of these parts: (name, file name, bytes).
fn form(parts: &[(&str, Option<&str>, &[u8])]) -> Vec<u8> {
    let mut body = Vec::new();
    for (name, file, bytes) in parts {
        let file = file.map_or(String::new(), |f| format!("; filename=\"{f}\""));
        body.extend_from_slice(
            format!("--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"{name}\"{file}\r\n\r\n").as_bytes(),
        );
        body.extend_from_slice(bytes);
        body.extend_from_slice(b"\r\n");
    }
    body.extend_from_slice(format!("--{BOUNDARY}--\r\n").as_bytes());
    body
}

/// The files of the shipped demo recording tile-s1 (in the library
/// already: uploading it again stores nothing).
fn tile_s1() -> Vec<(String, Vec<u8>)> {
    let demo = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/library/demo/tile");
    [".recording.json", ".force.npy", ".position.npy"]
        .iter()
        .map(|suffix| {
            let name = format!("tile-s1{suffix}");
            let bytes = std::fs::read(demo.join(&name)).unwrap();
            (name, bytes)
        })
        .collect()
}

/// The upload form of `files`, with `provenance`.
fn upload_form(provenance: &str, files: &[(String, Vec<u8>)]) -> Vec<u8> {
    let mut parts: Vec<(&str, Option<&str>, &[u8])> = vec![("provenance", None, provenance.as_bytes())];
    parts.extend(files.iter().map(|(n, b)| ("files", Some(n.as_str()), b.as_slice())));
    form(&parts)
}

/// A zip of these (name, bytes) entries, stored.
fn zip_of(entries: &[(String, Vec<u8>)]) -> Vec<u8> {
    use std::io::Write;
    let mut writer = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (name, bytes) in entries {
        writer.start_file(name.as_str(), options).unwrap();
        writer.write_all(bytes).unwrap();
    }
    writer.finish().unwrap().into_inner()
}

/// One request of the table and the answer it must get.
#[derive(Debug, Clone)]
struct Case {
    /// The route (method and path as in `routes::table()`).
    route: (&'static str, &'static str),
    what: String,
    method: String,
    target: String,
    headers: Vec<(String, String)>,
    body: Vec<u8>,
    status: u16,
    field: Option<String>,
}

impl Case {
    /// The request as bytes: `Host: localhost` and `Content-Length` unless
    /// the case sets its own.
    fn bytes(&self) -> Vec<u8> {
        let mut head = format!("{} {} HTTP/1.1\r\n", self.method, self.target);
        let has = |name: &str| self.headers.iter().any(|(n, _)| n.eq_ignore_ascii_case(name));
        if !has("host") && !has("x-no-host") {
            head.push_str("Host: localhost\r\n");
        }
        if !has("content-length") && !has("transfer-encoding") {
            head.push_str(&format!("Content-Length: {}\r\n", self.body.len()));
        }
        for (name, value) in self.headers.iter().filter(|(n, _)| n != "x-no-host") {
            head.push_str(&format!("{name}: {value}\r\n"));
        }
        head.push_str("Connection: close\r\n\r\n");
        let mut bytes = head.into_bytes();
        bytes.extend_from_slice(&self.body);
        bytes
    }
}

/// The live output's WebSocket: its valid request is an upgrade (101), whose
/// headers every case of the route starts from.
const LIVE_SOCKET: &str = "/api/live/ws";
const WEBSOCKET_UPGRADE: [(&str, &str); 4] = [
    ("Connection", "Upgrade"),
    ("Upgrade", "websocket"),
    ("Sec-WebSocket-Version", "13"),
    ("Sec-WebSocket-Key", "dGhlIHNhbXBsZSBub25jZQ=="),
];

/// A valid request of a route, from which its cases are derived.
#[derive(Debug, Clone)]
struct Valid {
    route: (&'static str, &'static str),
    target: &'static str,
    content_type: Option<&'static str>,
    body: Vec<u8>,
}

impl Valid {
    /// A case: this request changed by `change`, expecting `status` and
    /// `field`.
    fn case(&self, what: impl Into<String>, status: u16, field: Option<&str>, change: impl FnOnce(&mut Case)) -> Case {
        let mut case = Case {
            route: self.route,
            what: what.into(),
            method: self.route.0.to_string(),
            target: self.target.to_string(),
            headers: if self.route.1 == LIVE_SOCKET {
                WEBSOCKET_UPGRADE.iter().map(|(n, v)| (n.to_string(), v.to_string())).collect()
            } else {
                self.content_type.map(|c| vec![("Content-Type".to_string(), c.to_string())]).unwrap_or_default()
            },
            body: self.body.clone(),
            status,
            field: field.map(str::to_string),
        };
        change(&mut case);
        case
    }

    /// A case with this JSON body.
    fn json(&self, what: impl Into<String>, body: &Value, status: u16, field: &str) -> Case {
        let body = body.to_string().into_bytes();
        self.case(what, status, Some(field), |c| c.body = body)
    }

    /// A case with `target` (the query changed).
    fn target(&self, what: impl Into<String>, target: String, status: u16, field: &str) -> Case {
        self.case(what, status, Some(field), |c| c.target = target)
    }
}

/// Sets the JSON value at `path` (`a.b`, `a.b[1]`).
fn set(body: &Value, path: &str, value: Value) -> Value {
    let mut body = body.clone();
    let mut at = &mut body;
    for part in path.split('.') {
        match part.split_once('[') {
            Some((name, index)) => {
                let i: usize = index.trim_end_matches(']').parse().unwrap();
                at = &mut at[name][i];
            }
            None => at = &mut at[part],
        }
    }
    *at = value;
    body
}

/// The body with `path` set to a raw JSON text (for numbers JSON cannot
/// hold, such as 1e999): set to a marker, then replaced in the text.
fn set_raw(body: &Value, path: &str, raw: &str) -> Vec<u8> {
    set(body, path, json!("@@raw@@")).to_string().replace("\"@@raw@@\"", raw).into_bytes()
}

const EXTREMES: [(&str, f64); 3] = [("1e308", 1e308), ("-1e308", -1e308), ("5e-324", 5e-324)];

/// Cases for a numeric JSON field accepted in [min, max]: each extreme
/// outside it, 1e999 (not a JSON number serde can hold), a string, null
/// where the field is required, an array, a huge exponent.
fn number_cases(valid: &Valid, body: &Value, path: &str, min: f64, max: f64, cases: &mut Vec<Case>) {
    for (text, value) in EXTREMES {
        if !(min..=max).contains(&value) {
            cases.push(valid.json(format!("{path} = {text}"), &set(body, path, json!(value)), 400, path));
        }
    }
    for raw in ["1e999", "-1e999", "\"1.5\"", "[1]", "{}", "true"] {
        let bytes = set_raw(body, path, raw);
        cases.push(valid.case(format!("{path} = {raw}"), 400, Some(path), |c| c.body = bytes));
    }
}

/// A string of `n` characters mixing control characters, quotes, path
/// traversal and non-ASCII.
fn hostile(n: usize) -> String {
    "../\u{0}\u{1b}[31m\"\\\n\r\u{202e}é∞".chars().cycle().take(n).collect()
}

/// The body of `POST /api/map`: a 4 x 3 grayscale image and its mapping.
fn map_body() -> Value {
    use haptex_core::map::{FrictionMap, GrayMapping, MapGrid};
    let grid = MapGrid { nx: 4, ny: 3, x0_mm: 0.0, y0_mm: 0.0, dx_mm: 1.0, dy_mm: 1.0 };
    let map = FrictionMap { grid, mu: (0..12).map(|k| k as f64 / 11.0).collect() };
    let mut png = Vec::new();
    map.write_gray_png(&mut png, &GrayMapping { mu_black: 0.0, mu_white: 1.0, gamma: 1.0 }, 8).unwrap();
    json!({
        "image_png_base64": common::base64(&png), "mu_black": 0.8, "mu_white": 1.4, "gamma": 1.0,
        "pixel_mm": 0.1, "x0_mm": 0.0, "y0_mm": 0.0, "method": "physical", "device": { "u_max_v": 100.0 },
    })
}

fn valid_requests() -> Vec<Valid> {
    let json_ct = Some("application/json");
    let profile = json!({ "x_mm": [0.0, 1.0, 2.0], "mu": [1.0, 1.2, 1.1] });
    // A check of 3 mm of slide in 0.1 mm steps: 30 FE steps a run.
    let check_profile = json!({ "x_mm": [0.0, 1.0, 2.0], "mu": [1.05, 1.1, 1.05] });
    vec![
        Valid { route: ("GET", "/"), target: "/", content_type: None, body: vec![] },
        Valid { route: ("GET", "/static/{*path}"), target: "/static/app.js", content_type: None, body: vec![] },
        Valid { route: ("GET", "/api/health"), target: "/api/health", content_type: None, body: vec![] },
        Valid { route: ("GET", "/api/config"), target: "/api/config", content_type: None, body: vec![] },
        Valid { route: ("GET", "/api/openapi.json"), target: "/api/openapi.json", content_type: None, body: vec![] },
        Valid { route: ("GET", "/api/model"), target: "/api/model", content_type: None, body: vec![] },
        Valid { route: ("GET", "/api/templates"), target: "/api/templates", content_type: None, body: vec![] },
        Valid {
            route: ("POST", "/api/predict"),
            target: "/api/predict",
            content_type: json_ct,
            body: json!({ "surface": "bump", "x0_mm": 5, "width_mm": 1.3, "height_mm": 0.27, "velocity_mm_s": 20 })
                .to_string()
                .into_bytes(),
        },
        Valid {
            route: ("POST", "/api/simulate"),
            target: "/api/simulate",
            content_type: json_ct,
            body: json!({ "surface": "bump", "width_mm": 1.5, "height_mm": 0.3, "velocity_mm_s": 20 })
                .to_string()
                .into_bytes(),
        },
        Valid {
            route: ("POST", "/api/check"),
            target: "/api/check",
            content_type: json_ct,
            body: json!({ "profile": check_profile, "load_n_per_mm": 0.0133, "step_mm": 0.1 }).to_string().into_bytes(),
        },
        Valid {
            route: ("POST", "/api/compensate"),
            target: "/api/compensate",
            content_type: json_ct,
            body: json!({ "profile": check_profile, "load_n_per_mm": 0.0133, "step_mm": 0.1, "max_runs": 2 })
                .to_string()
                .into_bytes(),
        },
        Valid {
            route: ("POST", "/api/voltage"),
            target: "/api/voltage",
            content_type: json_ct,
            body: json!({ "profile": profile, "method": "physical", "device": { "u_max_v": 100 } })
                .to_string()
                .into_bytes(),
        },
        Valid {
            route: ("POST", "/api/profile"),
            target: "/api/profile",
            content_type: json_ct,
            body: profile.to_string().into_bytes(),
        },
        Valid { route: ("GET", "/api/materials"), target: "/api/materials", content_type: None, body: vec![] },
        Valid { route: ("GET", "/api/live"), target: "/api/live", content_type: None, body: vec![] },
        Valid { route: ("GET", LIVE_SOCKET), target: LIVE_SOCKET, content_type: None, body: vec![] },
        Valid {
            route: ("GET", "/api/materials/{name}/sample"),
            target: "/api/materials/velvet/sample?seed=7",
            content_type: None,
            body: vec![],
        },
        Valid {
            route: ("POST", "/api/recordings"),
            target: "/api/recordings",
            content_type: Some("multipart/form-data; boundary=adversarial-0f3c"),
            body: upload_form("synthetic", &tile_s1()),
        },
        Valid {
            route: ("POST", "/api/calibrate"),
            target: "/api/calibrate",
            content_type: json_ct,
            body: calibrate_body().to_string().into_bytes(),
        },
        Valid {
            route: ("POST", "/api/compensate/measured"),
            target: "/api/compensate/measured",
            content_type: json_ct,
            body: measured_body().to_string().into_bytes(),
        },
        Valid { route: ("GET", "/map"), target: "/map", content_type: None, body: vec![] },
        Valid {
            route: ("POST", "/api/map"),
            target: "/api/map",
            content_type: json_ct,
            body: map_body().to_string().into_bytes(),
        },
        Valid {
            route: ("POST", "/api/map/path"),
            target: "/api/map/path",
            content_type: json_ct,
            body: set(&map_body(), "path", json!({ "t_s": [0.0, 0.1], "x_mm": [0.0, 0.3], "y_mm": [0.1, 0.2] }))
                .to_string()
                .into_bytes(),
        },
        Valid {
            route: ("POST", "/api/play"),
            target: "/api/play",
            content_type: json_ct,
            body: json!({
                "voltage": { "x_mm": [0.0, 10.0], "voltage_v": [50.0, 80.0] },
                "stroke": { "velocity_mm_s": 50.0 },
                "format": "json",
            })
            .to_string()
            .into_bytes(),
        },
    ]
}

/// Cases every route gets.
fn generic_cases(valid: &Valid) -> Vec<Case> {
    let mut cases = Vec::new();
    let (method, _) = valid.route;
    let with_query = |q: &str| {
        let sep = if valid.target.contains('?') { '&' } else { '?' };
        format!("{}{sep}{q}", valid.target)
    };
    let other = if method == "GET" { "POST" } else { "GET" };
    cases.push(valid.case(format!("{other} instead of {method}"), 405, Some("method"), |c| c.method = other.into()));
    cases.push(valid.case("DELETE", 405, Some("method"), |c| c.method = "DELETE".into()));
    cases.push(valid.target("unknown query parameter", with_query("zz_unknown=1"), 400, "zz_unknown"));
    cases.push(valid.target("parameter given twice", with_query("format=json&format=json"), 400, "format"));
    // The field names the parameter with its control characters escaped
    // (an error answer is printable whatever the request).
    cases.push(valid.target("control characters as a name", with_query("%01%0A%1B=1"), 400, "\\u{1}\\n\\u{1b}"));
    cases.push(valid.target(
        "a 200-character name",
        with_query(&format!("{}=1", "q".repeat(200))),
        400,
        &"q".repeat(200),
    ));
    cases.push(valid.target("invalid UTF-8 in the query", with_query("a=%FF%FE"), 400, "a"));
    cases.push(valid.target("a target over 8 KiB", with_query(&format!("a={}", "b".repeat(9000))), 414, "uri"));
    cases.push(valid.case("another site's host (DNS rebinding)", 421, Some("host"), |c| {
        c.headers.push(("Host".into(), "rebind.attacker.example".into()))
    }));
    cases.push(valid.case("a host with a bad port", 421, Some("host"), |c| {
        c.headers.push(("Host".into(), "localhost:80x".into()))
    }));
    cases.push(valid.case("two Host headers", 400, Some("host"), |c| {
        c.headers.push(("Host".into(), "localhost".into()));
        c.headers.push(("Host".into(), "127.0.0.1".into()));
    }));
    cases.push(valid.case("no Host", 400, Some("host"), |c| c.headers.push(("x-no-host".into(), String::new()))));
    cases.push(
        valid.case("a 40 KiB header field", 431, Some("x-big"), |c| {
            c.headers.push(("X-Big".into(), "v".repeat(40 << 10)))
        }),
    );
    cases.push(valid.case("150 header fields", 431, Some("headers"), |c| {
        c.headers.extend((0..150).map(|i| (format!("X-H{i}"), "v".into())))
    }));
    cases.push(valid.case("a header field without a colon", 400, Some("request"), |c| {
        c.headers.push(("Not a header".into(), "x".into()))
    }));
    if method == "POST" && valid.content_type.is_some_and(|c| c.starts_with("multipart/")) {
        cases.push(valid.case("no Content-Type", 415, Some("content-type"), |c| c.headers.clear()));
        for ct in
            ["text/plain", "application/json", "application/zip", "multipart/form-data", "multipart/mixed; boundary=x"]
        {
            cases.push(valid.case(format!("Content-Type {ct:?}"), 415, Some("content-type"), |c| {
                c.headers = vec![("Content-Type".into(), ct.into())]
            }));
        }
        cases.push(valid.case("an empty body", 400, Some("body"), |c| c.body.clear()));
        cases.push(valid.case("another boundary", 400, Some("body"), |c| {
            c.headers = vec![("Content-Type".into(), "multipart/form-data; boundary=x".into())]
        }));
        let mut truncated = valid.body.clone();
        truncated.truncate(valid.body.len() / 2);
        cases.push(valid.case("a truncated form", 400, Some("body"), |c| c.body = truncated));
        let big = upload_form("synthetic", &[("big.csv".into(), vec![b'0'; (64 << 20) + 1024])]);
        cases.push(valid.case("a body over 64 MiB", 413, Some("body"), |c| c.body = big));
        cases.push(valid.case("a chunked body with a bad chunk", 400, Some("body"), |c| {
            c.headers.push(("Transfer-Encoding".into(), "chunked".into()));
            c.body = b"zz\r\nabc\r\n0\r\n\r\n".to_vec();
        }));
    } else if method == "POST" {
        let json_only = !["/api/voltage", "/api/profile", "/api/calibrate"].contains(&valid.route.1);
        cases.push(valid.case("no Content-Type", 415, Some("content-type"), |c| c.headers.clear()));
        for ct in ["text/plain", "application/xml", "multipart/form-data; boundary=x", "application/json\u{1}"] {
            let status_field = if ct.contains('\u{1}') { (400, "request") } else { (415, "content-type") };
            cases.push(valid.case(format!("Content-Type {ct:?}"), status_field.0, Some(status_field.1), |c| {
                c.headers = vec![("Content-Type".into(), ct.into())]
            }));
        }
        if json_only {
            cases.push(valid.case("a CSV body", 415, Some("content-type"), |c| {
                c.headers = vec![("Content-Type".into(), "text/csv".into())];
                c.body = b"x_mm,mu\n0,1\n1,1\n".to_vec();
            }));
        }
        cases.push(valid.case("an empty body", 400, Some("body"), |c| c.body.clear()));
        for (what, body) in [
            ("a truncated document", b"{".to_vec()),
            ("an array", b"[]".to_vec()),
            ("null", b"null".to_vec()),
            ("a number", b"1e999".to_vec()),
            ("trailing bytes", [valid.body.as_slice(), b" x"].concat()),
            ("invalid UTF-8", b"\xff\xfe{}".to_vec()),
            ("100 000 nested arrays", "[".repeat(100_000).into_bytes()),
            ("NaN", b"NaN".to_vec()),
        ] {
            cases.push(valid.case(format!("JSON: {what}"), 400, Some("body"), |c| c.body = body));
        }
        let mut big = valid.body.clone();
        big.resize(2 << 20, b' ');
        cases.push(valid.case("a 2 MiB body", 413, Some("body"), |c| c.body = big));
        cases.push(valid.case("a chunked body with a bad chunk", 400, Some("body"), |c| {
            c.headers.push(("Transfer-Encoding".into(), "chunked".into()));
            c.body = b"zz\r\nabc\r\n0\r\n\r\n".to_vec();
        }));
        let body: Value = serde_json::from_slice(&valid.body).unwrap();
        cases.push(valid.json("an unknown field", &set(&body, "zz_unknown", json!(1)), 400, "zz_unknown"));
        let first = body.as_object().unwrap().keys().next().unwrap().clone();
        let nested = format!("{{\"{first}\": {}", "[".repeat(100_000)).into_bytes();
        // In an array of numbers the first element is already of the wrong type.
        let at = if body[&first].is_array() { format!("{first}[0]") } else { first.clone() };
        cases.push(valid.case(format!("100 000 nested arrays in {first}"), 400, Some(&at), |c| c.body = nested));
        let text = String::from_utf8(valid.body.clone()).unwrap();
        let duplicated = text.replacen('{', &format!("{{\"{first}\": {},", body[&first]), 1).into_bytes();
        cases.push(valid.case(format!("{first} given twice"), 400, Some(&first), |c| c.body = duplicated));
    }
    cases
}

/// Each route's own fields.
fn route_cases(valid: &Valid) -> Vec<Case> {
    let mut cases = Vec::new();
    let json = valid.content_type == Some("application/json");
    let body: Value = if json { serde_json::from_slice(&valid.body).unwrap() } else { Value::Null };
    match valid.route.1 {
        LIVE_SOCKET => {
            let header = |name: &str, value: &str| {
                let (name, value) = (name.to_string(), value.to_string());
                move |c: &mut Case| {
                    c.headers.retain(|(n, _)| !n.eq_ignore_ascii_case(&name));
                    if !value.is_empty() {
                        c.headers.push((name, value));
                    }
                }
            };
            cases.push(valid.case(
                "a page of another site",
                403,
                Some("origin"),
                header("Origin", "http://evil.example"),
            ));
            cases.push(valid.case("a sandboxed page (Origin null)", 403, Some("origin"), header("Origin", "null")));
            cases.push(valid.case(
                "an Origin with control characters",
                400,
                Some("request"),
                header("Origin", "http://a\u{1}b"),
            ));
            cases.push(valid.case("no Upgrade", 400, Some("upgrade"), header("Upgrade", "")));
            cases.push(valid.case("Upgrade: h2c", 400, Some("upgrade"), header("Upgrade", "h2c")));
            cases.push(valid.case("WebSocket version 8", 400, Some("upgrade"), header("Sec-WebSocket-Version", "8")));
            cases.push(valid.case("no key", 400, Some("upgrade"), header("Sec-WebSocket-Key", "")));
        }
        "/static/{*path}" => {
            for (what, target) in [
                ("traversal", "/static/../Cargo.toml".to_string()),
                ("encoded traversal", "/static/..%2F..%2Fetc%2Fpasswd".to_string()),
                ("NUL", "/static/app.js%00.png".to_string()),
                ("control characters", "/static/%1B%5B31m%0A".to_string()),
                ("a 6000-character name", format!("/static/{}", "a".repeat(6000))),
                ("invalid UTF-8", "/static/%FF%FE".to_string()),
            ] {
                let status = if what == "invalid UTF-8" { 400 } else { 404 };
                cases.push(valid.target(what, target, status, "path"));
            }
        }
        "/api/materials/{name}/sample" => {
            for (what, name) in [
                ("traversal", "..%2F..%2Fetc".to_string()),
                ("SQL", "velvet'%20OR%20'1'='1".to_string()),
                ("NUL", "velvet%00".to_string()),
                ("control characters", "%1B%5B31m%0A%0D".to_string()),
                ("a 6000-character name", "m".repeat(6000)),
            ] {
                cases.push(valid.target(what, format!("/api/materials/{name}/sample"), 404, "name"));
            }
            cases.push(valid.target("invalid UTF-8", "/api/materials/%FF%FE/sample".into(), 400, "name"));
            for seed in ["-1", "1e308", "18446744073709551616", "abc", "%00", "1.5"] {
                cases.push(valid.target(
                    format!("seed = {seed}"),
                    format!("/api/materials/velvet/sample?seed={seed}"),
                    400,
                    "seed",
                ));
            }
            cases.push(valid.target("format=xml", "/api/materials/velvet/sample?format=xml".into(), 400, "format"));
            cases.push(valid.target("seed twice", "/api/materials/velvet/sample?seed=1&seed=2".into(), 400, "seed"));
        }
        "/api/predict" | "/api/simulate" => {
            for (path, min, max) in [
                ("width_mm", 0.5, 3.0),
                ("height_mm", 0.1, 0.6),
                ("velocity_mm_s", 10.0, 122.0),
                ("x0_mm", -1000.0, 1000.0),
            ] {
                number_cases(valid, &body, path, min, max, &mut cases);
            }
            for surface in [json!("dome"), json!(hostile(100_000)), json!(1), json!(null), json!(["bump"])] {
                cases.push(valid.json("a bad surface", &set(&body, "surface", surface), 400, "surface"));
            }
            cases.push(valid.target("format=xml", format!("{}?format=xml", valid.target), 400, "format"));
        }
        "/api/voltage" | "/api/profile" => {
            let prefix = if valid.route.1 == "/api/voltage" { "profile." } else { "" };
            let at = |name: &str| format!("{prefix}{name}");
            // Arrays: extreme values out of range, wrong types, too many.
            for (name, min, max) in [("x_mm", -1e6, 1e6), ("mu", -1e3, 1e3)] {
                number_cases(valid, &body, &format!("{}[1]", at(name)), min, max, &mut cases);
            }
            let forces = |ft: Value, fn_n: Value| {
                let profile = json!({ "x_mm": [0.0, 1.0, 2.0], "ft_n": ft, "fn_n": fn_n });
                if prefix.is_empty() { profile } else { set(&body, "profile", profile) }
            };
            for (ft, fn_n, field) in [
                (json!([0.1, 1e308, 0.1]), json!([0.2, 0.2, 0.2]), at("ft_n[1]")),
                (json!([0.1, 0.1, 0.1]), json!([0.2, 5e-324, 0.2]), at("fn_n[1]")),
                (json!([0.1, 10.0, 0.1]), json!([0.2, 1e-5, 0.2]), at("fn_n[1]")),
                (json!([0.1, 0.1, 0.1]), json!([0.2, -0.2, 0.2]), at("fn_n[1]")),
                (json!([0.1, 0.1, 0.1]), json!([0.2, 0.2]), at("fn_n[0]")),
            ] {
                cases.push(valid.json(format!("forces {ft} / {fn_n}"), &forces(ft, fn_n), 400, &field));
            }
            let n = 100_001;
            let many = json!({ "x_mm": vec![0; n], "mu": vec![1; n] });
            let many = if prefix.is_empty() { many } else { set(&body, "profile", many) };
            cases.push(valid.json("100 001 points", &many, 413, &at("x_mm")));
            // CSV bodies: the same numbers in columns, named with the line.
            for (csv, field) in [
                ("x_mm,mu\n0,1\n1e308,1\n".to_string(), "x_mm"),
                ("x_mm,mu\n0,1\n1,-1e308\n".to_string(), "mu"),
                ("x_mm,ft_n,fn_n\n0,0.1,0.2\n1,1e308,0.2\n".to_string(), "ft_n"),
                ("x_mm,ft_n,fn_n\n0,0.1,0.2\n1,0.1,5e-324\n".to_string(), "fn_n"),
                ("x_mm,mu\n0,1\n1,1e999\n".to_string(), "mu"),
                ("x_mm,mu\n0,1\n1,nan\n".to_string(), "mu"),
                (format!("x_mm,mu\n0,1\n1,{}\n", "9".repeat(100_000)), "mu"),
                (format!("x_mm,mu\n0,1\n1,{}\n", hostile(50)), "mu"),
                ("x_mm,mu\n0,1\n1,1\n1,1\n".to_string(), "x_mm"),
                ("x_mm,x_mm\n0,1\n".to_string(), "x_mm"),
                (format!("x_mm,mu{}\n0,1\n", ",c".repeat(10)), "c"),
                // A column name with a control character is refused, named
                // with it escaped.
                ("\u{feff}\u{0}x_mm,mu\n0,1\n1,1\n".to_string(), "\\0x_mm"),
                (format!("x_mm,mu\n{}", "0,1,".repeat(200_000)), "body"),
            ] {
                cases.push(valid.case(format!("CSV {:?}", &csv[..csv.len().min(40)]), 400, Some(field), |c| {
                    c.headers = vec![("Content-Type".into(), "text/csv".into())];
                    c.target = valid.target.to_string();
                    c.body = csv.into_bytes();
                }));
            }
            let csv_body = b"x_mm,mu\n0,1\n1,1.2\n".to_vec();
            let csv = |what: String, target: String, status: u16, field: &str| {
                let body = csv_body.clone();
                valid.case(what, status, Some(field), |c| {
                    c.headers = vec![("Content-Type".into(), "text/csv".into())];
                    c.target = target;
                    c.body = body;
                })
            };
            if valid.route.1 == "/api/voltage" {
                for spec in DEVICE_PARAMS {
                    let field = format!("device.{}", spec.name);
                    number_cases(valid, &body, &field, spec.min, spec.max, &mut cases);
                    for text in ["1e308", "-1e308", "5e-324", "1e999", "NaN", "inf", "abc", "", "%00"] {
                        let target = format!("/api/voltage?{}={text}", spec.name);
                        cases.push(csv(format!("CSV with {}={text}", spec.name), target, 400, spec.name));
                    }
                }
                let twice = set(&body, "device", json!({}));
                let text = twice.to_string().replace("\"device\":{}", "\"device\":{\"u_max_v\":50,\"u_max_v\":60}");
                cases.push(
                    valid.case("device.u_max_v given twice", 400, Some("device.u_max_v"), |c| {
                        c.body = text.into_bytes()
                    }),
                );
                for method in [json!("eq10"), json!(hostile(1000)), json!(1)] {
                    cases.push(valid.json("a bad method", &set(&body, "method", method), 400, "method"));
                }
                cases.push(csv("CSV with method=eq10".into(), "/api/voltage?method=eq10".into(), 400, "method"));
                cases.push(csv(
                    "CSV with u_max_v twice".into(),
                    "/api/voltage?u_max_v=1&u_max_v=2".into(),
                    400,
                    "u_max_v",
                ));
                let power_law = set(&body, "device", json!({ "area_exponent": 0.5 }));
                cases.push(valid.json("a power law without fn_n", &power_law, 400, "device.fn_n"));
                // The relative mapping (paper Fig. 2): flat_mu in its range
                // and only with relative = true, relative a boolean.
                let relative = set(&set(&body, "relative", json!(true)), "flat_mu", json!(0.5));
                number_cases(valid, &relative, "flat_mu", ranges::FLAT_MU.min, ranges::FLAT_MU.max, &mut cases);
                for value in [json!(0.0), json!(-0.5), json!(10.5)] {
                    cases.push(valid.json(
                        format!("flat_mu = {value}"),
                        &set(&relative, "flat_mu", value),
                        400,
                        "flat_mu",
                    ));
                }
                cases.push(valid.json("flat_mu without relative", &set(&body, "flat_mu", json!(0.5)), 400, "flat_mu"));
                for value in [json!("true"), json!(1), json!(null), json!(hostile(100))] {
                    cases.push(valid.json(
                        format!("relative = {value}"),
                        &set(&body, "relative", value),
                        400,
                        "relative",
                    ));
                }
                for text in ["1e308", "5e-324", "1e999", "NaN", "inf", "abc", "", "%00", "0", "-1"] {
                    let target = format!("/api/voltage?relative=true&flat_mu={text}");
                    cases.push(csv(format!("CSV with flat_mu={text}"), target, 400, "flat_mu"));
                }
                cases.push(csv(
                    "CSV flat_mu without relative".into(),
                    "/api/voltage?flat_mu=0.5".into(),
                    400,
                    "flat_mu",
                ));
                for text in ["yes", "1", "TRUE", "", "%00"] {
                    let target = format!("/api/voltage?relative={text}");
                    cases.push(csv(format!("CSV with relative={text}"), target, 400, "relative"));
                }
                // The display models (issue 16): each field's range, type and
                // place, the calibration's size and content.
                let combined = set(&body, "display", json!("combined"));
                let a_max = ranges::A_MAX_UM;
                number_cases(
                    valid,
                    &set(&combined, "a_max_um", json!(1.0)),
                    "a_max_um",
                    a_max.min,
                    a_max.max,
                    &mut cases,
                );
                let weighted = set(&set(&combined, "strategy", json!("weighted")), "weight", json!(1.0));
                let weight = ranges::STRATEGY_WEIGHT;
                number_cases(valid, &weighted, "weight", weight.min, weight.max, &mut cases);
                let calibration = "amplitude_um,relative_friction\n0,1\n1,0.5\n";
                let calibrated = set(&combined, "ultrasonic_calibration", json!(calibration));
                for (what, body, field) in [
                    ("display = hologram", set(&body, "display", json!("hologram")), "display"),
                    ("display = hostile", set(&body, "display", json!(hostile(1000))), "display"),
                    ("display = 1", set(&body, "display", json!(1)), "display"),
                    ("display = [combined]", set(&body, "display", json!(["combined"])), "display"),
                    ("strategy = best", set(&combined, "strategy", json!("best")), "strategy"),
                    ("strategy = hostile", set(&combined, "strategy", json!(hostile(1000))), "strategy"),
                    ("strategy on electrovibration", set(&body, "strategy", json!("split")), "strategy"),
                    ("weight on electrovibration", set(&body, "weight", json!(1.0)), "weight"),
                    ("weight with split", set(&combined, "weight", json!(1.0)), "weight"),
                    ("weight = 1e7", set(&weighted, "weight", json!(1e7)), "weight"),
                    ("a_max_um on electrovibration", set(&body, "a_max_um", json!(1.0)), "a_max_um"),
                    ("a_max_um beyond the literature default", set(&combined, "a_max_um", json!(2.5)), "a_max_um"),
                    ("a_max_um beyond the calibration", set(&calibrated, "a_max_um", json!(1.5)), "a_max_um"),
                    ("a_max_um = 0", set(&combined, "a_max_um", json!(0.0)), "a_max_um"),
                    ("method normalized on combined", set(&combined, "method", json!("normalized")), "method"),
                    (
                        "calibration on electrovibration",
                        set(&body, "ultrasonic_calibration", json!(calibration)),
                        "ultrasonic_calibration",
                    ),
                    ("calibration = 5", set(&combined, "ultrasonic_calibration", json!(5)), "ultrasonic_calibration"),
                    (
                        "calibration = [..]",
                        set(&combined, "ultrasonic_calibration", json!([calibration])),
                        "ultrasonic_calibration",
                    ),
                    (
                        "calibration = hostile",
                        set(&combined, "ultrasonic_calibration", json!(hostile(10_000))),
                        "ultrasonic_calibration",
                    ),
                    (
                        "calibration with 1e308",
                        set(
                            &combined,
                            "ultrasonic_calibration",
                            json!("amplitude_um,relative_friction\n0,1\n1e308,0.5\n"),
                        ),
                        "ultrasonic_calibration",
                    ),
                    (
                        "calibration with nan",
                        set(&combined, "ultrasonic_calibration", json!("amplitude_um,relative_friction\n0,1\n1,nan\n")),
                        "ultrasonic_calibration",
                    ),
                    (
                        "calibration rising",
                        set(
                            &combined,
                            "ultrasonic_calibration",
                            json!("amplitude_um,relative_friction\n0,1\n1,0.5\n2,0.6\n"),
                        ),
                        "ultrasonic_calibration",
                    ),
                    (
                        "calibration of one row",
                        set(&combined, "ultrasonic_calibration", json!("amplitude_um,relative_friction\n0,1\n")),
                        "ultrasonic_calibration",
                    ),
                ] {
                    cases.push(valid.json(what, &body, 400, field));
                }
                let long = format!("amplitude_um,relative_friction\n{}", "0.5,0.5\n".repeat(40_000));
                cases.push(valid.json(
                    "a 320 kB calibration",
                    &set(&combined, "ultrasonic_calibration", json!(long)),
                    413,
                    "ultrasonic_calibration",
                ));
                for text in ["1e308", "-1e308", "5e-324", "1e999", "NaN", "inf", "abc", "", "%00", "0", "3"] {
                    let target = format!("/api/voltage?display=combined&a_max_um={text}");
                    cases.push(csv(format!("CSV with a_max_um={text}"), target, 400, "a_max_um"));
                }
                for text in ["-1e308", "1e308", "1e999", "NaN", "inf", "abc", "", "%00", "-1"] {
                    let target = format!("/api/voltage?display=combined&strategy=weighted&weight={text}");
                    cases.push(csv(format!("CSV with weight={text}"), target, 400, "weight"));
                }
                for text in ["hologram", "", "%00", "COMBINED"] {
                    let target = format!("/api/voltage?display={text}");
                    cases.push(csv(format!("CSV with display={text}"), target, 400, "display"));
                    let target = format!("/api/voltage?display=combined&strategy={text}");
                    cases.push(csv(format!("CSV with strategy={text}"), target, 400, "strategy"));
                }
                cases.push(csv(
                    "CSV with a calibration in the query".into(),
                    "/api/voltage?display=combined&ultrasonic_calibration=0,1".into(),
                    400,
                    "ultrasonic_calibration",
                ));
            }
        }
        "/api/check" | "/api/compensate" => {
            let compensate = valid.route.1 == "/api/compensate";
            let mut numbers = vec![
                ("load_n_per_mm", 0.001, 0.05),
                ("velocity_mm_s", 1.0, 500.0),
                ("step_mm", 0.005, 0.5),
                ("profile.x_mm[1]", -1e6, 1e6),
                ("profile.mu[1]", -1e3, 1e3),
            ];
            if compensate {
                numbers.push(("tolerance", 0.0, 1.0));
            }
            for (path, min, max) in numbers {
                number_cases(valid, &body, path, min, max, &mut cases);
            }
            for spec in DEVICE_PARAMS {
                let field = format!("device.{}", spec.name);
                let body = set(&body, "device", json!({}));
                number_cases(valid, &body, &field, spec.min, spec.max, &mut cases);
            }
            for (path, value, status, field) in [
                ("load_n_per_mm", json!(0.0), 400, "load_n_per_mm"),
                ("load_n_per_mm", json!(0.06), 400, "load_n_per_mm"),
                ("step_mm", json!(0.001), 400, "step_mm"),
                ("velocity_mm_s", json!(1e4), 400, "velocity_mm_s"),
                ("method", json!("normalized"), 400, "method"),
                ("method", json!(hostile(1000)), 400, "method"),
                ("device", json!({ "area_exponent": 0.5 }), 400, "device.area_exponent"),
                ("device", json!({ "u_max_v": 5000 }), 400, "device.u_max_v"),
                ("flat_mu", json!(0.5), 400, "flat_mu"),
                ("relative", json!("true"), 400, "relative"),
                ("profile", json!({ "x_mm": (0..4001).collect::<Vec<_>>(), "mu": vec![1; 4001] }), 413, "profile.x_mm"),
                ("profile", json!({ "x_mm": vec![0; 100_001], "mu": vec![1; 100_001] }), 413, "profile.x_mm"),
                ("profile", json!({ "x_mm": [0.0, 1e6], "mu": [1.1, 1.1] }), 413, "profile.x_mm"),
                ("profile", json!({ "x_mm": [0.0, 900.0], "mu": [1.1, 1.1] }), 413, "step_mm"),
                ("profile", json!({ "x_mm": [1.0, 0.0], "mu": [1.1, 1.1] }), 400, "profile.x_mm[1]"),
                ("profile", json!({ "x_mm": [0.0, 1.0] }), 400, "profile.mu"),
            ] {
                cases.push(valid.json(format!("{path} = {value:.40}"), &set(&body, path, value), status, field));
            }
            // Out of 1 ..= 8 on a compensation; given at all on a check.
            for value in [json!(0), json!(9), json!(1.5), json!(1e308), json!(-1), json!("2")] {
                cases.push(valid.json(format!("max_runs = {value}"), &set(&body, "max_runs", value), 400, "max_runs"));
            }
            if !compensate {
                cases.push(valid.json("tolerance on a check", &set(&body, "tolerance", json!(1e-3)), 400, "tolerance"));
            }
            cases.push(valid.target("format=csv", format!("{}?format=csv", valid.target), 400, "format"));
        }
        "/api/map" | "/api/map/path" => {
            for (path, min, max) in [
                ("mu_black", -1e3, 1e3),
                ("mu_white", -1e3, 1e3),
                ("gamma", 0.05, 20.0),
                ("pixel_mm", 5e-324, 1e5),
                ("x0_mm", -1e6, 1e6),
                ("device.u_max_v", 1e-3, 1e4),
            ] {
                number_cases(valid, &body, path, min, max, &mut cases);
            }
            for (path, value, status, field) in [
                ("image_png_base64", json!(hostile(1000)), 400, "image_png_base64"),
                ("image_png_base64", json!("iVBORw0KGgo="), 400, "image_png_base64"),
                ("image_png_base64", json!(1), 400, "image_png_base64"),
                ("device.area_exponent", json!(2.0), 400, "device.area_exponent"),
                ("method", json!(hostile(100)), 400, "method"),
            ] {
                cases.push(valid.json(format!("{path} = {value:.40}"), &set(&body, path, value), status, field));
            }
            if valid.route.1 == "/api/map/path" {
                for axis in ["t_s", "x_mm", "y_mm"] {
                    number_cases(valid, &body, &format!("path.{axis}[1]"), -1e6, 1e6, &mut cases);
                }
                for (value, status, field) in [
                    (json!({ "t_s": [0.0, 0.0], "x_mm": [0.0, 0.3], "y_mm": [0.1, 0.2] }), 400, "path.t_s[1]"),
                    (json!({ "t_s": [0.0, 0.1], "x_mm": [0.0, 0.3] }), 400, "path"),
                    (json!({ "t_s": vec![0; 100_001], "x_mm": [0.0], "y_mm": [0.0] }), 413, "path.t_s"),
                ] {
                    cases.push(valid.json(format!("path = {value:.40}"), &set(&body, "path", value), status, field));
                }
            } else {
                cases.push(valid.json("a path", &set(&body, "path", json!({})), 400, "path"));
            }
        }
        "/api/play" => {
            for (path, min, max) in [
                ("voltage.x_mm[1]", -1e6, 1e6),
                ("voltage.voltage_v[1]", 0.0, 1e6),
                ("stroke.velocity_mm_s", 1e-6, 1e4),
                ("u_max_v", 1e-3, 1e4),
                ("slew_v_per_s", 1e-3, 1e9),
                ("amplifier_range_v", 1e-3, 1e5),
                ("volts_per_full_scale", 1e-3, 1e5),
                ("stroke.from_mm", -1e6, 1e6),
                ("carrier.frequency_hz", 1e-3, 1e6),
            ] {
                let body = if path.starts_with("carrier") {
                    set(&body, "carrier", json!({ "shape": "sine", "frequency_hz": 1000.0 }))
                } else {
                    body.clone()
                };
                number_cases(valid, &body, path, min, max, &mut cases);
            }
            let trajectory = set(&body, "stroke", Value::Null).as_object().unwrap().clone();
            let mut with_trajectory = Value::Object(trajectory);
            with_trajectory.as_object_mut().unwrap().remove("stroke");
            let with_trajectory =
                set(&with_trajectory, "trajectory", json!({ "t_s": [0.0, 0.1], "x_mm": [0.0, 10.0] }));
            number_cases(valid, &with_trajectory, "trajectory.t_s[1]", -1e6, 1e6, &mut cases);
            number_cases(valid, &with_trajectory, "trajectory.x_mm[1]", -1e6, 1e6, &mut cases);
            for (path, value, status, field) in [
                ("sample_rate_hz", json!(1e308), 400, "sample_rate_hz"),
                ("sample_rate_hz", json!(-48000), 400, "sample_rate_hz"),
                ("sample_rate_hz", json!(10), 400, "sample_rate_hz"),
                ("stroke.strokes", json!(1e308), 400, "stroke.strokes"),
                ("stroke.strokes", json!(0), 400, "stroke.strokes"),
                ("stroke.strokes", json!(1_000_000), 400, "stroke.strokes"),
                ("stroke.velocity_mm_s", json!(1e-6), 413, "stroke"),
                ("format", json!(hostile(1000)), 400, "format"),
                ("wav_format", json!("mp3"), 400, "wav_format"),
                ("outside", json!("wrap"), 400, "outside"),
                ("carrier", json!({ "shape": "triangle", "frequency_hz": 100 }), 400, "carrier.shape"),
                ("carrier", json!({ "shape": "sine", "frequency_hz": 30000 }), 400, "carrier.frequency_hz"),
                ("voltage", json!({ "x_mm": [0.0, 1.0], "voltage_v": [1.0, -1.0] }), 400, "voltage.voltage_v[1]"),
                ("voltage", json!({ "x_mm": [1.0, 0.0], "voltage_v": [1.0, 1.0] }), 400, "voltage.x_mm[1]"),
                ("voltage", json!({ "x_mm": vec![0; 100_001], "voltage_v": vec![0; 100_001] }), 413, "voltage.x_mm"),
            ] {
                cases.push(valid.json(format!("{path} = {value:.40}"), &set(&body, path, value), status, field));
            }
            // Two channels (issue 16): the ultrasonic amplitude and its a_max.
            let two = set(
                &set(
                    &body,
                    "voltage",
                    json!({ "x_mm": [0.0, 10.0], "voltage_v": [50.0, 80.0], "amplitude_um": [0.5, 1.0] }),
                ),
                "a_max_um",
                json!(1.0),
            );
            let (a_max, amplitude) = (ranges::A_MAX_UM, ranges::AMPLITUDE_UM);
            number_cases(valid, &two, "a_max_um", a_max.min, a_max.max, &mut cases);
            number_cases(valid, &two, "voltage.amplitude_um[1]", amplitude.min, amplitude.max, &mut cases);
            for (what, body, status, field) in [
                ("a_max_um without amplitudes", set(&body, "a_max_um", json!(1.0)), 400, "a_max_um"),
                ("amplitudes without a_max_um", set(&two, "a_max_um", Value::Null), 400, "a_max_um"),
                (
                    "a negative amplitude",
                    set(&two, "voltage.amplitude_um[1]", json!(-0.5)),
                    400,
                    "voltage.amplitude_um[1]",
                ),
                (
                    "one amplitude for two positions",
                    set(&two, "voltage.amplitude_um", json!([0.5])),
                    400,
                    "voltage.amplitude_um",
                ),
                ("amplitudes as text", set(&two, "voltage.amplitude_um", json!("0.5,1")), 400, "voltage.amplitude_um"),
                (
                    "100 001 amplitudes",
                    set(&two, "voltage.amplitude_um", json!(vec![0; 100_001])),
                    400,
                    "voltage.amplitude_um",
                ),
            ] {
                cases.push(valid.json(what, &body, status, field));
            }
            let long = set(&with_trajectory, "trajectory", json!({ "t_s": [0.0, 1e5], "x_mm": [0.0, 10.0] }));
            cases.push(valid.json("a trajectory of 1e5 s", &long, 413, "trajectory"));
            let wav = set(&body, "format", json!("wav"));
            for (path, value) in [("volts_per_full_scale", json!(0)), ("volts_per_full_scale", json!(-1))] {
                cases.push(valid.json(format!("WAV with {path} = {value}"), &set(&wav, path, value), 400, path));
            }
        }
        "/api/recordings" => {
            let files = tile_s1();
            let body = |b: Vec<u8>| move |c: &mut Case| c.body = b;
            cases.push(valid.case("no provenance", 400, Some("provenance"), body(upload_form("", &files))));
            let no_provenance =
                form(&files.iter().map(|(n, b)| ("files", Some(n.as_str()), b.as_slice())).collect::<Vec<_>>());
            cases.push(valid.case("provenance missing", 400, Some("provenance"), body(no_provenance)));
            cases.push(valid.case(
                "a hostile provenance",
                400,
                Some("provenance"),
                body(upload_form(&hostile(10_000), &files)),
            ));
            cases.push(valid.case(
                "measured, not as the metadata says",
                400,
                Some("provenance"),
                body(upload_form("measured", &files)),
            ));
            let twice = form(&[("provenance", None, b"synthetic"), ("provenance", None, b"synthetic")]);
            cases.push(valid.case("provenance given twice", 400, Some("provenance"), body(twice)));
            cases.push(valid.case(
                "an unknown form field",
                400,
                Some("colour"),
                body(form(&[("colour", None, b"red")])),
            ));
            cases.push(valid.case(
                "a file part without a file name",
                400,
                Some("files"),
                body(form(&[("files", None, b"x")])),
            ));
            for name in ["../../etc/passwd.recording.json", "/etc/x.recording.json", "a\\b.csv", "c:x.npy"] {
                let mut renamed = files.clone();
                renamed[0].0 = name.into();
                cases.push(valid.case(
                    format!("a file named {name:?}"),
                    400,
                    Some("files"),
                    body(upload_form("synthetic", &renamed)),
                ));
            }
            let mut hostile_meta = files.clone();
            hostile_meta[0].1 = hostile(5000).into_bytes();
            cases.push(valid.case(
                "hostile metadata",
                400,
                Some("metadata"),
                body(upload_form("synthetic", &hostile_meta)),
            ));
            let mut units = files.clone();
            units[0].1 = String::from_utf8(units[0].1.clone()).unwrap().replace("\"mm\"", "\"m\"").into_bytes();
            cases.push(valid.case(
                "position in m",
                400,
                Some("units.position"),
                body(upload_form("synthetic", &units)),
            ));
            let mut npy = files.clone();
            npy[1].1.truncate(200);
            cases.push(valid.case("a truncated NPY stream", 400, Some("files"), body(upload_form("synthetic", &npy))));
            let bomb = zip_of(&[("zeros.npy".to_string(), vec![0u8; 65 << 20])]);
            cases.push(valid.case(
                "a zip bomb",
                413,
                Some("files"),
                body(upload_form("synthetic", &[("b.zip".into(), bomb)])),
            ));
            let flood: Vec<(String, Vec<u8>)> = (0..1001).map(|i| (format!("e{i}"), Vec::new())).collect();
            let flood = zip_of(&flood);
            cases.push(valid.case(
                "a zip of 1001 entries",
                413,
                Some("files"),
                body(upload_form("synthetic", &[("f.zip".into(), flood)])),
            ));
            let traversal = zip_of(&[("../up.recording.json".to_string(), b"{}".to_vec())]);
            cases.push(valid.case(
                "a zip entry named ../",
                400,
                Some("files"),
                body(upload_form("synthetic", &[("t.zip".into(), traversal)])),
            ));
            cases.push(valid.case(
                "not a zip",
                400,
                Some("files"),
                body(upload_form("synthetic", &[("n.zip".into(), hostile(3000).into_bytes())])),
            ));
            cases.push(valid.case(
                "no recording",
                400,
                Some("files"),
                body(upload_form("synthetic", &[("x.csv".into(), b"t_s\n".to_vec())])),
            ));
        }
        "/api/calibrate" => {
            number_cases(valid, &body, "u_max_v", 1e-3, 1e4, &mut cases);
            for (what, measurements) in [
                ("measurements without rows", json!("voltage_v,mu\n")),
                ("hostile measurements", json!(hostile(10_000))),
                ("measurements as a number", json!(3)),
                ("a voltage without a carrier", json!("voltage_v,mu\n0,0.5\n50,0.6\n")),
            ] {
                cases.push(valid.json(what, &set(&body, "measurements", measurements), 400, "measurements"));
            }
            cases.push(valid.case("a CSV body of a profile", 400, Some("measurements"), |c| {
                c.headers = vec![("Content-Type".into(), "text/csv".into())];
                c.body = b"x_mm,mu\n0,1\n1,1\n".to_vec();
            }));
        }
        "/api/compensate/measured" => {
            number_cases(valid, &body, "gain", 5e-324, 1.0, &mut cases);
            let one = set(&body, "strokes", json!([body["strokes"][0].clone()]));
            cases.push(valid.json("one stroke", &one, 400, "strokes"));
            cases.push(valid.json("a hostile design", &set(&body, "design", json!(hostile(10_000))), 400, "design"));
            let stroke = json!([{ "csv": hostile(5000) }, body["strokes"][1].clone()]);
            cases.push(valid.json("a hostile stroke", &set(&body, "strokes", stroke), 400, "strokes[0]"));
        }
        _ => {}
    }
    cases
}

/// A small calibration: 0 to 100 V on a 1 kHz sine, three repetitions.
fn calibrate_body() -> Value {
    let mut csv = String::from("voltage_v,carrier,carrier_hz,mu,repetition\n");
    for r in 1..=3 {
        for (k, u) in [0.0f64, 25.0, 50.0, 75.0, 100.0].iter().enumerate() {
            let mu = 0.5 * (1.0 + 2e-5 * u * u) * (1.0 + 0.004 * (((k + r) % 3) as f64 - 1.0));
            csv += &format!("{u},sine,1000,{mu},{r}\n");
        }
    }
    json!({ "measurements": csv, "u_max_v": 100 })
}

/// A design (mu_HD 0.5, eq. 8 of the paper's device) and two strokes felt
/// 5% high.
fn measured_body() -> Value {
    let mut design = String::from("x_mm,mu,voltage_v\n");
    let mut strokes = [String::from("x_mm,ft_n,fn_n\n"), String::from("x_mm,ft_n,fn_n\n")];
    for i in 0..=40 {
        let x = i as f64 * 0.25;
        let mu = 0.55 + 0.01 * i as f64;
        let u = ((mu / 0.5 - 1.0) / 2e-5f64).sqrt().min(100.0);
        design += &format!("{x},{mu},{u}\n");
        for (s, stroke) in strokes.iter_mut().enumerate() {
            *stroke += &format!("{x},{},0.5\n", 0.5 * mu * (1.05 + 0.002 * s as f64));
        }
    }
    json!({
        "design": design,
        "strokes": [{ "name": "s1.csv", "csv": strokes[0] }, { "name": "s2.csv", "csv": strokes[1] }],
        "device": { "mu_hd": 0.5 },
    })
}

/// The state the campaign runs against: a writable copy of the shipped
/// library (POST /api/recordings needs one; its valid request uploads a
/// recording the library holds, so nothing is added), the shipped FE
/// database, a live output. The directory holds the library's copy.
fn campaign_state() -> (haptex_server::AppState, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let library = dir.path().join("library.sqlite");
    std::fs::copy(shipped_library(), &library).unwrap();
    let state = haptex_server::AppState::new(Some(&library), haptex_server::Limits::DEFAULT)
        .and_then(haptex_server::AppState::with_writable_library)
        .unwrap()
        .with_database(&shipped_db())
        .unwrap()
        .with_live_output(Arc::new(common::paced_output::PacedOutput::new(None)));
    (state, dir)
}

/// The token of the campaign against a protected server.
const TOKEN: &str = "adversarial-token-5f1e9a0c3b7d";

/// The status code of a raw answer.
fn status_of(answer: &str) -> u16 {
    answer.get(9..12).and_then(|s| s.parse().ok()).unwrap_or(0)
}

/// The body of a raw answer (after the head).
fn body_of(answer: &str) -> &str {
    answer.split_once("\r\n\r\n").map_or("", |(_, b)| b)
}

/// Issue 41: the whole campaign (every case of every route, and each
/// route's valid request) against a server that needs a token, without
/// it: no case is answered (2xx, 3xx or 5xx) but the health check's
/// minimal `{"status": "ok"}`; every valid request is 401 naming the
/// token; no answer carries the token.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn behind_a_token_no_case_of_the_campaign_is_answered_without_it() {
    use haptex_server::access::{Access, Token};
    let (state, _dir) = campaign_state();
    let state = state.with_access(Access::open().with_token(Token::new(TOKEN).unwrap()).unwrap());
    let server = RawServer::start(state).await;
    let valid = valid_requests();
    let mut failures = Vec::new();
    let mut refused = 0;
    for v in &valid {
        let case = v.case("the valid request", 401, Some("token"), |_| {});
        let answer = server.raw(&case.bytes()).await;
        if v.route.1 == "/api/health" {
            let body: Value = serde_json::from_str(body_of(&answer)).unwrap_or(Value::Null);
            if status_of(&answer) != 200 || body != json!({ "status": "ok" }) {
                failures.push(format!("GET /api/health: {answer}"));
            }
        } else if let Err(e) = check_json_error(&answer, 401, Some("token")) {
            failures.push(format!("{} {} [valid request]: {e}", v.route.0, v.route.1));
        }
        for case in [generic_cases(v), route_cases(v)].concat() {
            let answer = server.raw(&case.bytes()).await;
            let status = status_of(&answer);
            let minimal_health = v.route.1 == "/api/health"
                && status == 200
                && serde_json::from_str::<Value>(body_of(&answer)).is_ok_and(|b| b == json!({ "status": "ok" }));
            if !(400..500).contains(&status) && !minimal_health {
                let shown: String = answer.chars().take(300).collect();
                failures
                    .push(format!("{} {} [{}]: answered {status}: {shown:?}", case.route.0, case.route.1, case.what));
            }
            refused += usize::from(status == 401);
            if answer.contains(TOKEN) {
                failures.push(format!("{} {} [{}]: the token in the answer", case.route.0, case.route.1, case.what));
            }
        }
    }
    eprintln!("{refused} cases refused with 401 over {} routes", valid.len());
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
    server.stop().await;
}

/// Issue 41: with the token, every route's valid request gets the answer
/// a server without a token gives, byte for byte but for the `Date`
/// header and the wall times the FE routes report (`fe_seconds`,
/// `seconds`, and so the `Content-Length`, which counts their digits).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_its_token_every_route_answers_as_an_open_server_does() {
    use haptex_server::access::{Access, Token};
    let (open, _a) = campaign_state();
    let (protected, _b) = campaign_state();
    let protected = protected.with_access(Access::open().with_token(Token::new(TOKEN).unwrap()).unwrap());
    let (open, protected) = (RawServer::start(open).await, RawServer::start(protected).await);
    // Wall times, anywhere in a JSON answer or JSON line: masked.
    fn masked(text: &str) -> String {
        let mask = |mut v: Value| {
            fn walk(v: &mut Value) {
                match v {
                    Value::Object(map) => {
                        for (k, x) in map.iter_mut() {
                            if k == "fe_seconds" || k == "seconds" {
                                *x = Value::Null;
                            } else {
                                walk(x);
                            }
                        }
                    }
                    Value::Array(items) => items.iter_mut().for_each(walk),
                    _ => {}
                }
            }
            walk(&mut v);
            v.to_string()
        };
        text.lines()
            // The length follows the wall times' digits: the bodies are compared instead.
            .filter(|l| {
                let l = l.to_ascii_lowercase();
                !l.starts_with("date:") && !l.starts_with("content-length:")
            })
            .map(|l| serde_json::from_str::<Value>(l).map_or_else(|_| l.to_string(), mask))
            .collect::<Vec<_>>()
            .join("\n")
    }
    for v in valid_requests() {
        let plain = v.case("the valid request", 200, None, |_| {});
        let with_token = v.case("the valid request with the token", 200, None, |c| {
            c.headers.push(("Authorization".to_string(), format!("Bearer {TOKEN}")));
        });
        let (a, b) = (open.raw(&plain.bytes()).await, protected.raw(&with_token.bytes()).await);
        let expected = if v.route.1 == LIVE_SOCKET { 101 } else { 200 };
        assert_eq!(status_of(&a), expected, "{} {}: {a}", v.route.0, v.route.1);
        let (ma, mb) = (masked(&a), masked(&b));
        if ma != mb {
            // The first difference, not two whole answers.
            let at = ma.bytes().zip(mb.bytes()).position(|(x, y)| x != y).unwrap_or(ma.len().min(mb.len()));
            let around = |t: &str| t.get(at.saturating_sub(200)..(at + 200).min(t.len())).unwrap_or("").to_string();
            panic!(
                "{} {}: the answers differ at byte {at}:\n{}\n---\n{}",
                v.route.0,
                v.route.1,
                around(&ma),
                around(&mb)
            );
        }
        assert!(!b.contains(TOKEN));
    }
    open.stop().await;
    protected.stop().await;
}

/// Sends every case on its own connection, two clients at a time, while
/// two more upload maximal bodies back to back and another asks
/// `/api/health` every 10 ms; checks each answer.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_route_answers_hostile_input_with_a_4xx_naming_the_field() {
    let valid = valid_requests();
    let served: BTreeSet<(String, String)> =
        routes::table().iter().map(|e| (e.method.to_string(), e.path.to_string())).collect();
    let covered: BTreeSet<(String, String)> =
        valid.iter().map(|v| (v.route.0.to_string(), v.route.1.to_string())).collect();
    assert_eq!(covered, served, "every route of routes::table() needs its valid request and cases here");

    let (state, _dir) = campaign_state();
    let server = Arc::new(RawServer::start(state).await);
    // The valid requests are served (so the cases' refusals are theirs).
    for v in &valid {
        let case = v.case("the valid request", 200, None, |_| {});
        let answer = server.raw(&case.bytes()).await;
        // The WebSocket's valid request switches protocols (and the socket
        // is closed at once, releasing the output).
        let ok = if v.route.1 == LIVE_SOCKET { "HTTP/1.1 101" } else { "HTTP/1.1 200" };
        assert!(answer.starts_with(ok), "{} {}: {}", v.route.0, v.route.1, &answer[..answer.len().min(300)]);
    }
    let mut cases: Vec<Case> = valid.iter().flat_map(|v| [generic_cases(v), route_cases(v)].concat()).collect();
    for v in &valid {
        let n = cases.iter().filter(|c| c.route == v.route).count();
        assert!(n >= 15, "{} {}: only {n} cases", v.route.0, v.route.1);
    }

    let stop = Arc::new(AtomicBool::new(false));
    let health = {
        let (server, stop) = (server.clone(), stop.clone());
        tokio::spawn(async move {
            let mut worst = Duration::ZERO;
            let mut n = 0;
            while !stop.load(Ordering::Relaxed) {
                let t = Instant::now();
                let answer = server.get("/api/health").await;
                worst = worst.max(t.elapsed());
                n += 1;
                assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
                tokio::time::sleep(Duration::from_millis(10)).await;
            }
            (n, worst)
        })
    };
    // Two clients keep the server busy with maximal uploads meanwhile.
    let uploads = [
        ("/api/profile", "text/csv", common::maximal_csv()),
        ("/api/voltage", "application/json", common::maximal_voltage_json()),
    ]
    .map(|(uri, content_type, body)| {
        let (server, stop) = (server.clone(), stop.clone());
        tokio::spawn(async move {
            let request = format!(
                "POST {uri} HTTP/1.1\r\nHost: localhost\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\n\
                 Connection: close\r\n\r\n{body}",
                body.len()
            );
            let mut took = Vec::new();
            while !stop.load(Ordering::Relaxed) {
                let t = Instant::now();
                let answer = server.raw(request.as_bytes()).await;
                took.push(t.elapsed());
                assert!(answer.starts_with("HTTP/1.1 200"), "{}", &answer[..answer.len().min(300)]);
            }
            took
        })
    });
    let total = cases.len();
    let half = cases.split_off(total / 2);
    let senders = [cases, half].map(|cases| {
        let server = server.clone();
        tokio::spawn(async move {
            let mut failures = Vec::new();
            for case in cases {
                let answer = server.raw(&case.bytes()).await;
                if let Err(e) = check_json_error(&answer, case.status, case.field.as_deref()) {
                    let shown: String = answer.chars().take(400).collect();
                    failures.push(format!(
                        "{} {} [{}]: expected {} {:?}: {e}; got: {shown:?}",
                        case.route.0, case.route.1, case.what, case.status, case.field
                    ));
                }
            }
            failures
        })
    });
    let mut failures = Vec::new();
    for sender in senders {
        failures.extend(sender.await.unwrap());
    }
    stop.store(true, Ordering::Relaxed);
    let (n, worst) = health.await.unwrap();
    let mut uploaded = Vec::new();
    for u in uploads {
        uploaded.extend(u.await.unwrap());
    }
    uploaded.sort();
    let upload = uploaded[uploaded.len() / 2];
    eprintln!(
        "{total} cases over {} routes with {} maximal uploads meanwhile (median {upload:?}); /api/health: {n} \
         answers, worst {worst:?}",
        valid.len(),
        uploaded.len()
    );
    assert!(failures.is_empty(), "{} of {total} cases failed:\n{}", failures.len(), failures.join("\n"));
    // Relative to the uploads of the same run (a loaded machine slows both
    // alike): health never waited behind a request's work. The latency
    // itself is a benchmark (scripts/load_health.py, BENCHMARKS.md).
    assert!(worst < upload, "/api/health took up to {worst:?} during the table, a maximal upload {upload:?}");
    Arc::try_unwrap(server).ok().unwrap().stop().await;
}
