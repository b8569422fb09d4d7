//! One function per haptex parser, for the fuzz targets (`fuzz_targets/`,
//! run by `cargo fuzz`) and the replay that times every corpus input
//! (`src/bin/replay.rs`). Each function parses `data` and, when it is
//! accepted, checks what haptex promises of accepted input (every value
//! finite, the derived results finite, a read-back identical); a broken
//! promise panics, which is what the fuzzer reports. Errors are the
//! expected outcome for most inputs and are only checked to be short.

use haptex_core::cae::{Cae, Loo, ModelMatrix, Widths};
use haptex_core::electrovibration::{Device, Method, map_profile, map_profile_relative};
use haptex_core::profile::FrictionProfile;
use haptex_core::relative::FlatMu;
use haptex_core::recording::Recording;
use haptex_core::signal::{VoltageCurve, WavFormat, decode_drive_wav, decode_drive_wav_channels};
use haptex_core::trajectory::Trajectory;

/// The parsers, by name: what `replay` and the campaign script iterate.
pub const TARGETS: &[(&str, fn(&[u8]))] = &[
    ("profile_csv", profile_csv),
    ("voltage_csv", voltage_csv),
    ("trajectory_csv", trajectory_csv),
    ("model_matrix", model_matrix),
    ("recording", recording),
    ("drive_wav", drive_wav),
    ("finger_toml", finger_toml),
    ("surface_file", surface_file),
    ("http_body", http_body),
    ("library_names", library_names),
];

/// An error message must stay readable whatever the input.
fn short(message: String) {
    assert!(message.len() < 2000, "an error message of {} bytes: {}", message.len(), &message[..200]);
}

/// Friction profile CSV -> profile -> voltages by eqs. (8) and (9), as it
/// is and relative to its median (paper Fig. 2, `--relative`).
pub fn profile_csv(data: &[u8]) {
    match FrictionProfile::read_csv(data, "f.csv") {
        Ok(p) => {
            assert!(p.x_mm().iter().chain(p.mu()).all(|v| v.is_finite()));
            assert!(p.span_mm().is_finite() && p.span_mm() > 0.0);
            for method in [Method::Physical, Method::Normalized] {
                for mapped in [
                    map_profile(&p, &Device::PAPER, method, None),
                    map_profile_relative(&p, &Device::PAPER, method, None, FlatMu::Median),
                ] {
                    match mapped {
                        Ok(v) => assert!(v.voltage_v.iter().all(|u| u.is_finite() && *u >= 0.0 && *u <= 100.0)),
                        Err(e) => short(e.to_string()),
                    }
                }
            }
        }
        Err(e) => short(e.to_string()),
    }
}

/// Voltage profile CSV (`haptex play --profile`).
pub fn voltage_csv(data: &[u8]) {
    match VoltageCurve::read_csv(data, "u.csv") {
        Ok(c) => {
            let (a, b) = c.span_mm();
            assert!(a.is_finite() && b.is_finite() && b > a);
        }
        Err(e) => short(e.to_string()),
    }
}

/// Finger trajectory CSV.
pub fn trajectory_csv(data: &[u8]) {
    match Trajectory::read_csv(data, "t.csv") {
        Ok(t) => assert!(t.duration_s().is_finite() && t.duration_s() > 0.0),
        Err(e) => short(e.to_string()),
    }
}

/// CAE model matrix: the first header name is the input, the rest outputs;
/// an accepted matrix is predicted from and, when small, leave-one-out
/// evaluated (within a small memory budget).
pub fn model_matrix(data: &[u8]) {
    let header = data.split(|&b| b == b'\n').find(|l| !l.is_empty() && !l.starts_with(b"#"));
    let first = header.and_then(|h| std::str::from_utf8(h).ok()).and_then(|h| h.split(',').next()).unwrap_or("a");
    let input = first.trim().trim_matches('"').trim().to_string();
    match ModelMatrix::read_csv(data, "m.csv", &[&input]) {
        Ok(m) => {
            let cae = Cae::new(m.clone(), Widths::constant(0.1).unwrap()).unwrap();
            let mut scratch = cae.scratch();
            let mut out = vec![0.0; m.m()];
            let query = m.inputs_flat()[0];
            if let Err(e) = cae.predict_into(&[query], &mut scratch, &mut out) {
                short(e.to_string());
            } else {
                assert!(out.iter().all(|v| v.is_finite()), "prediction {out:?}");
            }
            match Loo::with_memory_budget(&m, 1 << 20) {
                Ok(mut loo) => assert!(!loo.rmse(Widths::constant(0.1).unwrap()).is_nan()),
                Err(e) => short(e.to_string()),
            }
        }
        Err(e) => short(e.to_string()),
    }
}

/// A recording: the input is split into metadata, force and position
/// streams at `\n---\n`; the first byte chooses CSV or NPY streams.
pub fn recording(data: &[u8]) {
    let npy = data.first().is_some_and(|b| b & 1 == 1);
    let body = data.get(1..).unwrap_or(&[]);
    let mut parts = split(body, b"\n---\n");
    let meta = parts.next().unwrap_or(&[]);
    let force = parts.next().unwrap_or(&[]);
    let position = parts.next().unwrap_or(&[]);
    let ext = if npy { "npy" } else { "csv" };
    match Recording::parse("r.recording.json", meta, (&format!("f.{ext}"), force), (&format!("p.{ext}"), position)) {
        Ok(r) => assert!(r.duration_s().is_finite() && r.duration_s() > 0.0),
        Err(e) => short(e.to_string()),
    }
}

fn split<'a>(data: &'a [u8], separator: &'a [u8]) -> impl Iterator<Item = &'a [u8]> + 'a {
    let mut rest = Some(data);
    std::iter::from_fn(move || {
        let r = rest?;
        match r.windows(separator.len()).position(|w| w == separator) {
            Some(i) => {
                rest = Some(&r[i + separator.len()..]);
                Some(&r[..i])
            }
            None => {
                rest = None;
                Some(r)
            }
        }
    })
}

/// A drive-signal WAV read back with its scale chunk. A WAV haptex
/// accepts must be, to every reader, what its scale chunk says: every
/// sample of every channel finite and within the stated full scale
/// (channel 1 within volts_per_full_scale, channel 2 within its um per
/// full scale); and hound, an independent reader that knows nothing of
/// the scale chunk, must read from the fmt chunk the chunk's format,
/// channel count and rate, and the same samples, code for code.
pub fn drive_wav(data: &[u8]) {
    let (scale, volts, amplitude) = match decode_drive_wav_channels(data) {
        Ok(decoded) => decoded,
        Err(message) => return short(message),
    };
    assert_eq!(decode_drive_wav(data).map(|(_, v)| v).as_ref(), Ok(&volts));
    let channels: usize = if scale.channel_2.is_some() { 2 } else { 1 };
    assert_eq!((volts.len(), amplitude.is_some()), (scale.n_samples, channels == 2));
    let vpfs = scale.volts_per_full_scale;
    assert!(volts.iter().all(|v| v.is_finite() && v.abs() <= vpfs), "channel 1 beyond {vpfs} V");
    let upfs = scale.channel_2.as_ref().map_or(1.0, |c| c.um_per_full_scale);
    if let Some(a) = &amplitude {
        assert!(a.iter().all(|v| v.is_finite() && v.abs() <= upfs), "channel 2 beyond {upfs} um");
    }
    let reader = hound::WavReader::new(std::io::Cursor::new(data)).expect("an accepted WAV reads with hound");
    let spec = reader.spec();
    let (float, bits) = match scale.sample_format {
        WavFormat::Pcm16 => (false, 16),
        WavFormat::Pcm24 => (false, 24),
        WavFormat::Float32 => (true, 32),
    };
    assert_eq!(
        (usize::from(spec.channels), spec.sample_rate, spec.bits_per_sample, spec.sample_format == hound::SampleFormat::Float),
        (channels, scale.sample_rate_hz, bits, float),
        "hound reads another format from the fmt chunk"
    );
    let codes: Vec<f64> = if float {
        reader.into_samples::<f32>().map(|s| f64::from(s.expect("hound reads the samples"))).collect()
    } else {
        reader.into_samples::<i32>().map(|s| f64::from(s.expect("hound reads the samples"))).collect()
    };
    assert_eq!(codes.len(), scale.n_samples * channels, "hound reads another number of samples");
    let full = scale.full_scale_value;
    for (k, code) in codes.iter().enumerate() {
        let (ours, per_full_scale) = match (k % channels, &amplitude) {
            (1, Some(a)) => (a[k / channels], upfs),
            _ => (volts[k / channels], vpfs),
        };
        assert!(code.abs() <= full, "hound reads code {code} beyond the full scale {full}");
        assert_eq!(code / full * per_full_scale, ours, "hound reads sample {k} as another value");
    }
}

/// A finger model TOML, meshed at the coarse resolution when accepted.
pub fn finger_toml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    match haptex_fem::finger::FingerModel::from_toml(text, "f.toml") {
        Ok(model) => {
            if let Err(e) = model.mesh(haptex_fem::finger::Resolution::Coarse) {
                short(e.to_string());
            }
        }
        Err(e) => short(e.to_string()),
    }
}

/// A surface height profile (`--surface file:H.csv`).
pub fn surface_file(data: &[u8]) {
    let dir = std::env::temp_dir().join(format!("haptex-fuzz-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join("h.csv");
    if std::fs::write(&path, data).is_err() {
        return;
    }
    match haptex_fem::surface::SurfaceShape::read_csv(&path) {
        Ok(shape) => {
            if let Err(e) = shape.validate() {
                short(e.to_string());
            }
        }
        Err(e) => short(e.to_string()),
    }
}

/// The web API: the first byte picks a route and body type, the rest is
/// the request body (or, for the material sample, the name and query).
/// Every answer must be a 2xx, or a 4xx (or 503) with a JSON error body
/// that has an `error` message and a `field` key; never a 5xx otherwise.
pub fn http_body(data: &[u8]) {
    use axum::body::Body;
    use axum::http::{Request, header};
    use tower::ServiceExt;

    static APP: std::sync::OnceLock<(tokio::runtime::Runtime, axum::Router)> = std::sync::OnceLock::new();
    let (runtime, router) = APP.get_or_init(|| {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let state = haptex_server::AppState::new(
            Some(&root.join("data/library/library.sqlite")),
            haptex_server::Limits::DEFAULT,
        )
        .and_then(|s| Ok(s.with_database(&root.join("data/db")).expect("the shipped database loads")))
        .expect("the shipped library opens");
        let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build().expect("a runtime");
        (runtime, haptex_server::app(state))
    });
    const ROUTES: &[(&str, &str)] = &[
        ("/api/profile", "text/csv"),
        ("/api/profile", "application/json"),
        ("/api/profile?format=csv", "text/csv"),
        ("/api/voltage", "text/csv"),
        ("/api/voltage?method=normalized&format=csv", "text/csv"),
        ("/api/voltage", "application/json"),
        ("/api/play", "application/json"),
        ("/api/predict", "application/json"),
        ("/api/predict?format=csv", "application/json"),
    ];
    let (Some(&selector), body) = (data.first(), data.get(1..).unwrap_or(&[])) else { return };
    let request = if usize::from(selector) < ROUTES.len() {
        let (uri, content_type) = ROUTES[usize::from(selector)];
        Request::post(uri)
            .header(header::HOST, "localhost")
            .header(header::CONTENT_TYPE, content_type)
            .body(Body::from(body.to_vec()))
    } else {
        // A GET with the bytes in the path and query of the sample route.
        let text: String = String::from_utf8_lossy(body).chars().filter(|c| !c.is_control() && *c != ' ').collect();
        Request::get(format!("/api/materials/{text}")).header(header::HOST, "localhost").body(Body::empty())
    };
    let Ok(request) = request else { return };
    let (status, bytes) = runtime.block_on(async {
        let response = router.clone().oneshot(request).await.expect("the router is infallible");
        let status = response.status();
        let bytes = axum::body::to_bytes(response.into_body(), usize::MAX).await.expect("the body is read");
        (status, bytes)
    });
    assert!(
        !status.is_server_error() || status.as_u16() == 503,
        "{status}: {}",
        String::from_utf8_lossy(&bytes[..bytes.len().min(300)])
    );
    if status.is_client_error() || status.as_u16() == 503 {
        let json: serde_json::Value = serde_json::from_slice(&bytes).expect("an error answer is JSON");
        assert!(json["error"].is_string() && json.get("field").is_some(), "{json}");
        // A message is at most 2 KiB and a field 256 bytes before JSON
        // escaping (quotes and backslashes double).
        assert!(bytes.len() <= 6 * 1024, "an error answer of {} bytes", bytes.len());
    }
}

/// Library names (issue 35, RELIABILITY.md "a name never escapes its
/// directory"): the input, as UTF-8 (invalid bytes replaced), is a name
/// given to every entry point of the library's path: the name rule, a
/// profile imported under it as a material, a recording whose metadata
/// names it, the file a library export writes the stored material's
/// stroke to, and a multi-file writer given it as a relative path. The
/// promise: the rule and every entry point agree; a name accepted yields
/// only paths inside the output directory; a name refused leaves nothing
/// written.
pub fn library_names(data: &[u8]) {
    use haptex_core::io::{FileSet, OutputDir};
    use haptex_core::library::{Added, Library, ProfileProvenance, export_file};
    use haptex_core::name::check_name;
    use std::path::{Component, Path};

    thread_local! {
        /// An in-memory library and an import run, one per thread.
        static LIBRARY: std::cell::RefCell<(Library, haptex_core::library::ImportId)> = {
            let library = Library::open(Path::new(":memory:")).expect("an in-memory library");
            let run = library.begin_import("fuzz", &Default::default()).expect("an import run");
            std::cell::RefCell::new((library, run))
        };
        /// A scratch directory, one per thread: `out/` is written into.
        static SCRATCH: std::path::PathBuf = {
            let dir = std::env::temp_dir().join(format!("haptex-fuzz-names-{}", std::process::id()));
            std::fs::create_dir_all(&dir).expect("a scratch directory");
            dir
        };
    }
    let name = String::from_utf8_lossy(data);
    let name = name.as_ref();
    let accepted = check_name(name).is_ok();
    if let Err(e) = check_name(name) {
        short(e.to_string());
    }
    if accepted {
        let base = Path::new("/export");
        let joined = base.join(name);
        assert_eq!(joined.parent(), Some(base), "{name:?} leaves its directory");
        assert_eq!(joined.components().next_back(), Some(Component::Normal(name.as_ref())), "{name:?}");
    }

    // A recording whose metadata names the material.
    let meta = serde_json::json!({
        "format": "haptex-recording-1", "material": name, "participant": "P1", "stroke": 1,
        "force": {"file": "f.csv", "rate_hz": 1000}, "position": {"file": "p.csv", "rate_hz": 100},
        "units": {"time": "s", "force": "N", "position": "mm"}, "source": "fuzz", "licence": "CC0-1.0" });
    let force: String = std::iter::once("t_s,fn_n,ft_n\n".to_string())
        .chain((0..=100).map(|i| format!("{},0.5,0.25\n", i as f64 / 1000.0)))
        .collect();
    let position: String = std::iter::once("t_s,x_mm\n".to_string())
        .chain((0..=10).map(|k| format!("{},{k}\n", k as f64 / 100.0)))
        .collect();
    let meta = serde_json::to_vec(&meta).expect("JSON");
    match Recording::parse("r.recording.json", &meta, ("f.csv", force.as_bytes()), ("p.csv", position.as_bytes())) {
        Ok(_) => assert!(accepted, "a recording of material {name:?} was accepted"),
        Err(e) => {
            assert!(!accepted, "a recording of material {name:?} was refused: {e}");
            short(e.to_string());
        }
    }

    // A profile imported under the name, then exported as the CLI does.
    let profile = FrictionProfile::new(vec![0.0, 1.0], vec![0.5, 0.6]).expect("a profile");
    let provenance = ProfileProvenance {
        source: "fuzz".into(),
        licence: "CC0-1.0".into(),
        synthetic: true,
        origin_path: "p.csv".into(),
    };
    let stored = LIBRARY.with(|cell| {
        let (library, run) = &mut *cell.borrow_mut();
        match library.add_profile(*run, name, "", &profile, &provenance) {
            Ok(Added::New(id) | Added::Duplicate(id)) => {
                assert!(accepted, "material {name:?} was stored");
                Some((library.stroke(id).expect("the stroke stored").material, id))
            }
            Err(e) => {
                assert!(!accepted, "material {name:?} was refused: {e}");
                short(e.to_string());
                None
            }
        }
    });
    SCRATCH.with(|scratch| {
        let out = scratch.join("out");
        let _ = std::fs::remove_dir_all(&out);
        if let Some((material, id)) = stored {
            let file = export_file(&material, id).expect("a stored name exports");
            let mut set = FileSet::begin(&out, "manifest.json").expect("the export's directory");
            // Written inside, or refused (a material in the manifest's place).
            match set.write(&file, |w| w.write_all(b"x_mm,mu\n0,1\n")) {
                Ok(path) => {
                    let real = std::fs::canonicalize(&path).expect("written");
                    let home = std::fs::canonicalize(&out).expect("out");
                    assert!(real.starts_with(home), "{name:?} wrote {}", real.display());
                    set.finish(|w, _| w.write_all(b"{}")).expect("the manifest");
                }
                Err(e) => short(e.to_string()),
            }
        } else {
            assert!(export_file(name, 1).is_err(), "a refused name {name:?} exports");
        }
        // The name as a relative path given to a multi-file writer: inside, or nothing.
        let _ = std::fs::remove_dir_all(&out);
        let dir = OutputDir::create(&out).expect("out");
        match dir.write(name, |w| w.write_all(b"x")) {
            Ok(path) => {
                let real = std::fs::canonicalize(&path).expect("written");
                assert!(
                    real.starts_with(std::fs::canonicalize(&out).expect("out")),
                    "{name:?} wrote {}",
                    real.display()
                );
                assert!(haptex_core::name::check_relative_path(name).is_ok());
            }
            Err(e) => {
                short(e.to_string());
                assert!(std::fs::read_dir(&out).expect("out").next().is_none(), "a refused {name:?} wrote a file");
            }
        }
        let mut siblings: Vec<_> =
            std::fs::read_dir(scratch).expect("scratch").flatten().map(|e| e.file_name()).collect();
        siblings.retain(|n| n != "out");
        assert!(siblings.is_empty(), "{name:?} wrote beside the output: {siblings:?}");
    });
}
