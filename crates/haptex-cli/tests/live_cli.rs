//! Issue 18 acceptance: `haptex live` on a real ALSA device. The test
//! writes an asoundrc (HOME pointed at a temporary directory) defining
//! `haptex_capture`, ALSA's `file` PCM plugin (built into libasound)
//! wrapping the `null` PCM: the command opens, streams to and closes it
//! like any output device, and the plugin writes every frame it was given
//! to a raw file, which is compared with the offline `haptex play` of the
//! same touch log.
//!
//! The `null` PCM does not pace: it takes samples as fast as the callback
//! makes them (2 s of audio in under 1 ms here). The touch log is replayed
//! on the output's sample clock, so the captured samples are those a
//! paced device would get; the latency figures on this device are the
//! renderer's only (its reported buffer delay is 0).
//!
//! Built only with the `live` feature (cpal, libasound2-dev); without it,
//! the one test here checks that `haptex live` says how to get it.

mod common;

use common::{haptex, stderr, write};

#[cfg(not(feature = "live"))]
#[test]
fn without_the_feature_live_says_how_to_build_it() {
    let dir = tempfile::tempdir().unwrap();
    let profile = write(dir.path(), "u.csv", "x_mm,voltage_v\n0,10\n1,20\n");
    let out = haptex(&["live", "--profile", &profile, "--stdin"]);
    assert!(!out.status.success());
    let e = stderr(&out);
    assert!(e.contains("built without audio output") && e.contains("--features live"), "{e}");
}

#[cfg(feature = "live")]
mod device {
    use super::*;
    use common::KillOnDrop;
    use std::path::Path;
    use std::process::{Command, Output, Stdio};

    const FS: usize = 48_000;

    /// A HOME with an .asoundrc defining `haptex_capture`: the file plugin
    /// writing raw frames to `capture` through the null PCM.
    fn alsa_home(dir: &Path, capture: &Path) {
        let rc = format!(
            "pcm.haptex_capture {{\n    type file\n    slave.pcm \"null\"\n    file \"{}\"\n    format \"raw\"\n    \
             hint {{\n        show on\n        description \"haptex test capture\"\n    }}\n}}\n",
            capture.display()
        );
        std::fs::write(dir.join(".asoundrc"), rc).unwrap();
    }

    fn live(home: &Path, args: &[&str], stdin: Option<&str>) -> Output {
        let mut child = Command::new(env!("CARGO_BIN_EXE_haptex"))
            .arg("live")
            .args(args)
            .env("HOME", home)
            .env_remove("ALSA_CONFIG_PATH")
            .stdin(if stdin.is_some() { Stdio::piped() } else { Stdio::null() })
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run haptex live");
        if let Some(text) = stdin {
            use std::io::Write;
            child.stdin.take().unwrap().write_all(text.as_bytes()).unwrap();
        }
        child.wait_with_output().unwrap()
    }

    /// `haptex play` of `design` (its option and file) along the touch log
    /// `log`, as the float32 WAV's interleaved samples.
    fn offline_float32(dir: &Path, design: &[&str], log: &str) -> Vec<f32> {
        let wav = dir.join("offline.wav");
        let args = [&["play"][..], design, &["--trajectory", log, "--wav-format", "float32", "-q"]].concat();
        let out = haptex(&[&args[..], &["-o", wav.to_str().unwrap()]].concat());
        assert!(out.status.success(), "{}", stderr(&out));
        hound::WavReader::open(&wav).unwrap().samples::<f32>().map(Result::unwrap).collect()
    }

    fn read_f32(path: &Path) -> Vec<f32> {
        let bytes = std::fs::read(path).unwrap();
        bytes.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect()
    }

    /// A combined design (`haptex voltage --display combined`: voltage and
    /// ultrasonic amplitude) and a touch log of a constant-velocity sweep
    /// at 120 Hz, 1 s, crossing the bump. `haptex live` replays the log
    /// into the ALSA file device (48 kHz, 2 channels, f32, 256-frame
    /// buffers); `haptex play` renders the same log offline as a float32
    /// WAV. After the documented 20 ms start ramp and up to the last
    /// report, every captured sample equals the offline one within one f32
    /// step at full scale (2^-23): same positions (the extrapolation of a
    /// constant velocity is exact once two reports are in), same carrier
    /// polynomial, same scales (volts / volts_per_full_scale on channel 1,
    /// um / a_max on channel 2). During the ramp the output stays within
    /// gain x the U_max peak; after the stop ramp it is exactly 0.
    #[test]
    fn replayed_touch_log_on_the_alsa_file_device_equals_the_offline_render() {
        let dir = tempfile::tempdir().unwrap();
        let capture = dir.path().join("capture.raw");
        alsa_home(dir.path(), &capture);
        let design = dir.path().join("bump_ua.csv");
        let bump = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/examples/bump_friction.csv");
        let out =
            haptex(&["voltage", "--profile", bump, "--display", "combined", "-q", "-o", design.to_str().unwrap()]);
        assert!(out.status.success(), "{}", stderr(&out));
        let mut log = String::from("t_s,x_mm\n");
        for k in 0..=120 {
            let t = k as f64 / 120.0;
            log.push_str(&format!("{t:?},{:?}\n", 2.0 + 6.0 * t));
        }
        let log = write(dir.path(), "log.csv", &log);
        let json = dir.path().join("run.json");
        let args = [
            "--profile",
            design.to_str().unwrap(),
            "--touch-log",
            &log,
            "--device",
            "haptex_capture",
            "--sample-rate",
            "48000",
            "--buffer-frames",
            "256",
            "--json",
            json.to_str().unwrap(),
        ];
        let out = live(dir.path(), &args, None);
        let e = stderr(&out);
        assert!(out.status.success(), "{e}");
        assert!(
            e.contains("haptex_capture, 48000 Hz, 2 channels") && e.contains("latency: touch to first sample"),
            "{e}"
        );
        let run: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        assert_eq!(run["events"], 121);
        assert_eq!(run["sample_format"], "f32");
        assert_eq!(run["clamped_samples"], 0);
        assert!(run["render_latency_max_s"].as_f64().unwrap() < 1.0 / FS as f64, "{run}");

        let offline = offline_float32(dir.path(), &["--profile", design.to_str().unwrap()], &log);
        let captured = read_f32(&capture);
        let n = offline.len() / 2;
        assert_eq!(n, FS + 1);
        assert_eq!(captured.len() as u64, 2 * run["frames"].as_u64().unwrap(), "every frame reached the file");
        assert!(captured.len() >= offline.len());

        let ramp = FS / 50; // 20 ms
        let step = f32::EPSILON;
        let (mut worst_1, mut worst_2, mut moving) = (0.0f32, 0.0f32, 0usize);
        for i in ramp..n - 1 {
            worst_1 = worst_1.max((captured[2 * i] - offline[2 * i]).abs());
            worst_2 = worst_2.max((captured[2 * i + 1] - offline[2 * i + 1]).abs());
            moving += usize::from(offline[2 * i] != 0.0);
        }
        assert!(moving > FS / 2, "the offline drive is not silent ({moving} non-zero samples)");
        assert!(worst_1 <= step && worst_2 <= step, "channel 1 {worst_1}, channel 2 {worst_2} (f32 step {step})");
        // The start ramp: from 0 V, within gain x the U_max sine peak
        // (the full scale is that peak here).
        assert_eq!(captured[0], 0.0);
        for i in 0..ramp {
            let gain = (i + 1) as f32 / ramp as f32;
            assert!(captured[2 * i].abs() <= gain + step, "sample {i}: {}", captured[2 * i]);
        }
        // The stop ramp from the last report (1 s), then silence.
        assert!(captured[2 * (n + ramp + 1)..].iter().all(|&v| v == 0.0), "silent after the stop ramp");
    }

    /// A touch log with a gap (reports 0-0.5 s, then none until 1.0 s) on
    /// the ALSA file device: the output is exactly 0 V from 0.5 s + gap +
    /// ramp (100 + 20 ms, the documented drop-out time) until the reports
    /// resume, at full level before the gap, and back after it. The
    /// profile asks for 80 V under --u-max 70: no captured sample exceeds
    /// the 70 V sine peak (full scale, by default sqrt(2) U_max).
    #[test]
    fn a_gap_in_the_touch_log_fades_to_zero_within_the_documented_time() {
        let dir = tempfile::tempdir().unwrap();
        let capture = dir.path().join("capture.raw");
        alsa_home(dir.path(), &capture);
        let profile = write(
            dir.path(),
            "u.csv",
            "x_mm,voltage_v
0,80
10,80
",
        );
        let mut log = String::from(
            "t_s,x_mm
",
        );
        for k in (0..=60).chain(120..=180) {
            log.push_str(&format!(
                "{:?},{:?}
",
                k as f64 / 120.0,
                1.0 + k as f64 / 60.0
            ));
        }
        let log = write(dir.path(), "gap.csv", &log);
        let args = ["--profile", &profile, "--touch-log", &log, "--device", "haptex_capture", "--u-max", "70"];
        let out = live(dir.path(), &args, None);
        assert!(out.status.success(), "{}", stderr(&out));
        let c = read_f32(&capture);
        let at = |s: f64| (s * FS as f64) as usize;
        let level = |a: f64, b: f64| c[at(a)..at(b)].iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(level(0.4, 0.59) > 0.99, "full level before the gap: {}", level(0.4, 0.59));
        assert!(c[at(0.5 + 0.1 + 0.02) + 1..at(1.0)].iter().all(|&v| v == 0.0), "0 V from gap + ramp on");
        assert!(level(1.1, 1.4) > 0.99, "back after the gap");
        assert!(c.iter().all(|v| v.abs() <= 1.0), "never above the U_max peak");
    }

    /// A voltage map CSV over 8 x 4 mm (81 x 41 cells): U = 50 + 30 sin(2
    /// pi x / 2.5) cos(2 pi y / 3) + 5 y V.
    fn wavy_map(dir: &Path) -> String {
        let mut csv = String::from("x_mm,y_mm,voltage_v\n");
        let tau = std::f64::consts::TAU;
        for j in 0..=40 {
            for i in 0..=80 {
                let (x, y) = (i as f64 * 0.1, j as f64 * 0.1);
                let u = 50.0 + 30.0 * (tau * x / 2.5).sin() * (tau * y / 3.0).cos() + 5.0 * y;
                csv.push_str(&format!("{x:?},{y:?},{u:?}\n"));
            }
        }
        write(dir, "map.csv", &csv)
    }

    /// Issue 19: `haptex live --voltage-map` replays a planar touch log
    /// (`t_s,x_mm,y_mm`, a diagonal at 120 Hz for 1 s) into the ALSA file
    /// device (1 channel, f32), against `haptex play --voltage-map` of the
    /// same log as a float32 WAV: after the 20 ms start ramp and up to the
    /// last report every sample agrees within one f32 step at full scale
    /// (2^-23; the extrapolation of a constant velocity is exact in x and
    /// y, and the bilinear lookup and the carrier are the offline render's).
    /// Over a map stdin's lines need a y: an `x_mm` alone is refused naming
    /// the line and the field, and the output fades out.
    #[test]
    fn replayed_planar_log_over_a_voltage_map_equals_the_offline_render() {
        let dir = tempfile::tempdir().unwrap();
        let capture = dir.path().join("capture.raw");
        alsa_home(dir.path(), &capture);
        let map = wavy_map(dir.path());
        let mut log = String::from("t_s,x_mm,y_mm\n");
        for k in 0..=120 {
            let t = k as f64 / 120.0;
            log.push_str(&format!("{t:?},{:?},{:?}\n", 0.5 + 7.0 * t, 3.5 - 3.0 * t));
        }
        let log = write(dir.path(), "path.csv", &log);
        let json = dir.path().join("run.json");
        let args = ["--voltage-map", &map, "--touch-log", &log, "--device", "haptex_capture"];
        let args = [&args[..], &["--sample-rate", "48000", "--buffer-frames", "256", "--json", json.to_str().unwrap()]]
            .concat();
        let out = live(dir.path(), &args, None);
        let e = stderr(&out);
        assert!(out.status.success(), "{e}");
        assert!(e.contains("haptex_capture, 48000 Hz, 1 channel (drive over a 81 x 41 map"), "{e}");
        let run: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        assert_eq!(run["events"], 121);
        assert_eq!(run["clamped_samples"], 0);

        let offline = offline_float32(dir.path(), &["--voltage-map", &map], &log);
        let captured = read_f32(&capture);
        assert_eq!(offline.len(), FS + 1);
        assert_eq!(captured.len() as u64, run["frames"].as_u64().unwrap(), "every frame reached the file");
        let ramp = FS / 50;
        let worst = (ramp..FS).fold(0.0f32, |m, i| m.max((captured[i] - offline[i]).abs()));
        assert!(offline[ramp..FS].iter().filter(|v| v.abs() > 0.1).count() > FS / 2, "the drive plays");
        assert!(worst <= f32::EPSILON, "worst {worst} (f32 step {})", f32::EPSILON);
        assert_eq!(captured[0], 0.0);
        assert!(captured[FS + ramp + 2..].iter().all(|&v| v == 0.0), "silent after the stop ramp");

        // stdin over a map: x and y per line.
        let args = ["--voltage-map", &map, "--stdin", "--device", "haptex_capture"];
        let out = live(dir.path(), &args, Some("1.0,2.0\n3.0\n"));
        let e = stderr(&out);
        assert!(!out.status.success(), "{e}");
        assert!(e.contains("stdin, line 2, field 'y_mm': missing"), "{e}");
        assert!(e.contains("faded to 0 V"), "{e}");
    }

    /// A minimal WebSocket client (RFC 6455: the upgrade, masked text
    /// frames out, unmasked frames in), enough to play the live page.
    struct WsClient(std::net::TcpStream);

    impl WsClient {
        /// With these extra header lines (each ending in CRLF).
        fn connect_with(addr: &str, path: &str, headers: &str) -> Self {
            use std::io::{Read, Write};
            let mut stream = std::net::TcpStream::connect(addr).unwrap();
            stream.set_read_timeout(Some(std::time::Duration::from_secs(10))).unwrap();
            write!(
                stream,
                "GET {path} HTTP/1.1\r\nHost: {addr}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\
                 Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n{headers}\r\n"
            )
            .unwrap();
            let mut head = Vec::new();
            let mut byte = [0u8];
            while !head.ends_with(b"\r\n\r\n") {
                stream.read_exact(&mut byte).unwrap();
                head.push(byte[0]);
            }
            let head = String::from_utf8_lossy(&head);
            assert!(head.starts_with("HTTP/1.1 101"), "{head}");
            // The accept key of RFC 6455's example nonce.
            assert!(head.contains("s3pPLMBiTxaQ9kYGzzhZRbK+xOo="), "{head}");
            Self(stream)
        }

        fn send(&mut self, text: &str) {
            use std::io::Write;
            let mask = [0x12u8, 0x34, 0x56, 0x78];
            let mut frame = match text.len() {
                n @ 0..126 => vec![0x81, 0x80 | n as u8],
                n => [vec![0x81, 0x80 | 126], u16::try_from(n).unwrap().to_be_bytes().to_vec()].concat(),
            };
            frame.extend_from_slice(&mask);
            frame.extend(text.bytes().enumerate().map(|(i, b)| b ^ mask[i % 4]));
            self.0.write_all(&frame).unwrap();
        }

        fn receive(&mut self) -> serde_json::Value {
            use std::io::Read;
            let mut head = [0u8; 2];
            self.0.read_exact(&mut head).unwrap();
            let mut n = usize::from(head[1] & 0x7f);
            if n == 126 {
                let mut ext = [0u8; 2];
                self.0.read_exact(&mut ext).unwrap();
                n = usize::from(u16::from_be_bytes(ext));
            }
            let mut payload = vec![0u8; n];
            self.0.read_exact(&mut payload).unwrap();
            serde_json::from_slice(&payload).unwrap()
        }

        /// Status frames until one satisfies `done` (at most 100, 10 s).
        fn until(&mut self, what: &str, done: impl Fn(&serde_json::Value) -> bool) -> serde_json::Value {
            for _ in 0..100 {
                let frame = self.receive();
                if done(&frame) {
                    return frame;
                }
            }
            panic!("no status frame with {what}; the last: {}", self.receive());
        }
    }

    /// Touches over the WebSocket of `haptex live --ws` from a test client
    /// (the page's protocol: one touch line per message): the renderer
    /// follows, position in and the expected voltage out, read from the
    /// status frames the page shows (U = 10 V/mm x, so 2 mm gives 20 V and
    /// 7.5 mm 75 V, within 1e-9 V). A bad message is answered with an
    /// error naming the field; the page is served with the profile's span.
    /// The horizon is 0 (the position is held at each report) and the gap
    /// 60 s: the test's `null` device does not pace, so its clock runs
    /// hundreds of times faster than the test's messages.
    #[test]
    fn websocket_touches_drive_the_renderer() {
        let dir = tempfile::tempdir().unwrap();
        alsa_home(dir.path(), &dir.path().join("unused.raw"));
        let profile = write(dir.path(), "ramp.csv", "x_mm,voltage_v\n0,0\n10,100\n");
        let json = dir.path().join("run.json");
        let design = ["--profile", &profile, "--json", json.to_str().unwrap()];
        let (mut child, stderr_lines, addr, page, cookie) = live_ws(dir.path(), &design);
        assert!(page.starts_with("HTTP/1.1 200") && page.contains("(0.0 .. 10.0 mm)"), "{page}");

        // The page and its WebSocket need the token (issue 41): without it,
        // or from a page of another site, the upgrade is refused.
        let raw = |request: String| {
            use std::io::{Read, Write};
            let mut stream = std::net::TcpStream::connect(&addr).unwrap();
            stream.set_read_timeout(Some(std::time::Duration::from_secs(10))).unwrap();
            stream.write_all(request.as_bytes()).unwrap();
            let mut head = [0u8; 12];
            stream.read_exact(&mut head).unwrap();
            String::from_utf8_lossy(&head).into_owned()
        };
        let upgrade = "Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\
                       Sec-WebSocket-Version: 13\r\n";
        assert_eq!(raw(format!("GET / HTTP/1.1\r\nHost: {addr}\r\n\r\n")), "HTTP/1.1 401");
        assert_eq!(raw(format!("GET /live/ws HTTP/1.1\r\nHost: {addr}\r\n{upgrade}\r\n")), "HTTP/1.1 401");
        let foreign = format!(
            "GET /live/ws HTTP/1.1\r\nHost: {addr}\r\n{upgrade}Cookie: {cookie}\r\nOrigin: http://evil.example\r\n\r\n"
        );
        assert_eq!(raw(foreign), "HTTP/1.1 403");

        let mut ws =
            WsClient::connect_with(&addr, "/live/ws", &format!("Cookie: {cookie}\r\nOrigin: http://{addr}\r\n"));
        let near = |v: &serde_json::Value, key: &str, want: f64| (v[key].as_f64().unwrap() - want).abs() < 1e-9;
        ws.send("2.0");
        ws.until("x = 2 mm, U = 20 V", |f| near(f, "x_mm", 2.0) && near(f, "envelope_v", 20.0));
        ws.send("0.25,7.5");
        let f = ws.until("x = 7.5 mm, U = 75 V", |f| near(f, "x_mm", 7.5) && near(f, "envelope_v", 75.0));
        assert!(f["events"].as_u64().unwrap() >= 2, "{f}");
        ws.send("1.0,abc");
        let f = ws.until("an error", |f| f.get("error").is_some());
        assert!(f["error"].as_str().unwrap().contains("field 'x_mm': expected a finite number, got 'abc'"), "{f}");
        ws.send("lift");
        ws.until("the finger lifted (0 V)", |f| f["envelope_v"].as_f64() == Some(0.0));
        drop(ws);

        // SIGTERM: the output fades out and the command ends normally.
        let status = Command::new("kill").args(["-TERM", &child.0.id().to_string()]).status().unwrap();
        assert!(status.success());
        let rest: Vec<String> = stderr_lines.map_while(Result::ok).collect();
        assert!(child.0.wait().unwrap().success(), "{rest:?}");
        let run: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        assert!(run["events"].as_u64().unwrap() >= 4, "{run}");
        assert!(run["peak_v"].as_f64().unwrap() <= 75.0 * std::f64::consts::SQRT_2 + 1e-3, "{run}");
    }

    /// Issue 19: `haptex live --voltage-map --ws`: the page is a pad over
    /// the map's x and y, its messages are `t_s,x_mm,y_mm` lines, and the
    /// status frames carry y. On U = 10 x + 5 y (bilinear sampling is exact
    /// on it) a touch at (2, 1) mm plays 25 V and one at (7.5, 3) mm 90 V,
    /// within 1e-9 V; an x alone is answered with an error naming y_mm.
    #[test]
    fn websocket_touches_over_a_voltage_map() {
        let dir = tempfile::tempdir().unwrap();
        alsa_home(dir.path(), &dir.path().join("unused.raw"));
        let mut csv = String::from("x_mm,y_mm,voltage_v\n");
        for j in 0..=4 {
            for i in 0..=10 {
                csv.push_str(&format!("{i},{j},{}\n", 10 * i + 5 * j));
            }
        }
        let map = write(dir.path(), "plane.csv", &csv);
        let (mut child, stderr_lines, addr, page, cookie) =
            live_ws(dir.path(), &["--voltage-map", &map, "--u-max", "100"]);
        assert!(page.contains("const X0 = 0.0, X1 = 10.0;") && page.contains("const Y0 = 0.0, Y1 = 4.0,"), "{page}");

        let mut ws = WsClient::connect_with(&addr, "/live/ws", &format!("Cookie: {cookie}\r\n"));
        let near = |v: &serde_json::Value, key: &str, want: f64| (v[key].as_f64().unwrap() - want).abs() < 1e-9;
        ws.send("2.0,1.0");
        ws.until("(2, 1) mm at 25 V", |f| near(f, "x_mm", 2.0) && near(f, "y_mm", 1.0) && near(f, "envelope_v", 25.0));
        ws.send("0.25,7.5,3");
        ws.until("(7.5, 3) mm at 90 V", |f| {
            near(f, "x_mm", 7.5) && near(f, "y_mm", 3.0) && near(f, "envelope_v", 90.0)
        });
        ws.send("4.0");
        let f = ws.until("an error", |f| f.get("error").is_some());
        assert!(f["error"].as_str().unwrap().contains("field 'y_mm': missing"), "{f}");
        drop(ws);
        let status = Command::new("kill").args(["-TERM", &child.0.id().to_string()]).status().unwrap();
        assert!(status.success());
        let rest: Vec<String> = stderr_lines.map_while(Result::ok).collect();
        assert!(child.0.wait().unwrap().success(), "{rest:?}");
    }

    /// `haptex live --ws` on the `null` device with `design`'s options (the
    /// horizon 0, the gap 60 s: the device does not pace), its stderr lines
    /// after the address line, the address, the page it serves at the
    /// address it printed (with the token it made) and the session cookie
    /// (`name=value`) it set.
    #[allow(clippy::type_complexity)]
    fn live_ws(
        home: &Path,
        design: &[&str],
    ) -> (KillOnDrop, std::io::Lines<std::io::BufReader<std::process::ChildStderr>>, String, String, String) {
        use std::io::{BufRead, Read, Write};
        let child = Command::new(env!("CARGO_BIN_EXE_haptex"))
            .args(["live", "--ws", "127.0.0.1:0", "--device", "null", "--gap-ms", "60000", "--horizon-ms", "0"])
            .args(design)
            .env("HOME", home)
            .stdin(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut child = KillOnDrop(child);
        let mut stderr_lines = std::io::BufReader::new(child.0.stderr.take().unwrap()).lines();
        let (addr, token) = loop {
            let line = stderr_lines.next().expect("haptex live printed its address").unwrap();
            if let Some(rest) = line.split("WebSocket ws://").nth(1) {
                let token = line.split("?token=").nth(1).expect("the page's token").split(' ').next().unwrap();
                break (rest.split('/').next().unwrap().to_string(), token.to_string());
            }
        };
        assert_eq!(token.len(), 64, "a made token: {token}");
        let mut http = std::net::TcpStream::connect(&addr).unwrap();
        write!(http, "GET /?token={token} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n").unwrap();
        let mut page = String::new();
        http.read_to_string(&mut page).unwrap();
        let cookie = page
            .lines()
            .find_map(|l| l.strip_prefix("set-cookie: "))
            .and_then(|c| c.split(';').next())
            .unwrap_or_else(|| panic!("no session cookie: {page}"))
            .to_string();
        (child, stderr_lines, addr, page, cookie)
    }

    /// `haptex serve --live` on the ALSA file device: the page's WebSocket
    /// (`/api/live/ws`, a test client speaking the page's protocol) sends a
    /// design (U = 10 V/mm x), a touch and a stop; the run's figures come
    /// back with the close (x = 2 mm, 20 V, within 1e-9 V). The captured
    /// frames stay within the 20 V sine's peak sqrt(2) x 20 V (0.2 of the
    /// sqrt(2) x 100 V full scale) and end at exactly 0. (Following a
    /// finger's touches in the status frames is `websocket_touches_drive_the_renderer`
    /// here and, paced, crates/haptex-server/tests/live_api.rs.) The server starts
    /// only with a device it can open; the live options need --live.
    #[test]
    fn serve_live_on_the_alsa_file_device() {
        use std::io::BufRead;
        let dir = tempfile::tempdir().unwrap();
        let capture = dir.path().join("capture.raw");
        alsa_home(dir.path(), &capture);
        let serve = |args: &[&str]| {
            Command::new(env!("CARGO_BIN_EXE_haptex"))
                .args(["serve", "--addr", "127.0.0.1:0"])
                .args(args)
                .env("HOME", dir.path())
                .env_remove("ALSA_CONFIG_PATH")
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        };
        let out = serve(&["--live", "--device", "no_such_pcm"]).wait_with_output().unwrap();
        assert!(!out.status.success());
        assert!(stderr(&out).contains("no output device named 'no_such_pcm'"), "{}", stderr(&out));
        let out = serve(&["--device", "haptex_capture"]).wait_with_output().unwrap();
        assert!(stderr(&out).contains("are for --live: add --live"), "{}", stderr(&out));

        let mut child = KillOnDrop(serve(&[
            "--live",
            "--device",
            "haptex_capture",
            "--sample-rate",
            "48000",
            "--buffer-frames",
            "256",
            "--gap-ms",
            "60000",
            "--horizon-ms",
            "0",
        ]));
        let mut lines = std::io::BufReader::new(child.0.stderr.take().unwrap()).lines();
        let mut said = Vec::new();
        let (addr, token) = loop {
            let line = lines.next().expect("haptex serve printed its address").unwrap();
            if let Some(rest) = line.split("open http://").nth(1) {
                let token = rest.split("?token=").nth(1).expect("--live needs a token").split(' ').next().unwrap();
                break (rest.split('/').next().unwrap().to_string(), token.to_string());
            }
            said.push(line);
        };
        assert!(said.iter().any(|l| l.contains("live output: haptex_capture, 48000 Hz, U_max 100 V")), "{said:?}");
        assert!(said.iter().any(|l| l.contains("access token required (--live lets requests drive")), "{said:?}");
        let mut ws = WsClient::connect_with(&addr, "/api/live/ws", &format!("Authorization: Bearer {token}\r\n"));
        let design = serde_json::json!({ "design": { "x_mm": [0.0, 10.0], "voltage_v": [0.0, 100.0] } });
        ws.send(&design.to_string());
        let opened = ws.until("opened", |f| f.get("opened").is_some());
        assert_eq!(opened["opened"]["output"]["device"], "haptex_capture");
        assert_eq!(opened["opened"]["output"]["buffer_frames"], 256);
        // The file device does not pace: its clock runs hundreds of times
        // faster than the wall clock (the 60 s gap passes in about a
        // millisecond, and the capture grows by megabytes per second). So
        // the page's touch is repeated every millisecond for 20 ms (each
        // renews the gap; a single touch could reach the callback together
        // with the stop, and the fade-in would never start), the stop
        // follows at once, and the run's figures come with the close.
        for _ in 0..20 {
            ws.send("2.0");
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        ws.send(r#"{"stop": true}"#);
        let closed = ws.until("closed", |f| f.get("closed").is_some());
        let near = |v: &serde_json::Value, key: &str, want: f64| (v[key].as_f64().unwrap() - want).abs() < 1e-9;
        let figures = &closed["closed"];
        assert!(near(figures, "x_mm", 2.0) && near(figures, "envelope_v", 20.0), "{closed}");
        assert_eq!(figures["events"], 20, "{closed}");
        assert_eq!(figures["finished"], true, "{closed}");
        let samples = read_f32(&capture);
        let peak = samples.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(peak > 0.0 && peak <= 0.2 + 1e-6, "peak {peak} of full scale");
        assert_eq!(samples.last(), Some(&0.0));
        drop(ws);
        let status = Command::new("kill").args(["-TERM", &child.0.id().to_string()]).status().unwrap();
        assert!(status.success());
        let rest: Vec<String> = lines.map_while(Result::ok).collect();
        assert!(child.0.wait().unwrap().success(), "{rest:?}");
    }

    /// Touches from stdin: events applied, the output faded at end of
    /// input; a bad line stops the output with an error naming the line
    /// and field. An unknown device is refused with the list of devices.
    #[test]
    fn stdin_touches_and_errors() {
        let dir = tempfile::tempdir().unwrap();
        let capture = dir.path().join("capture.raw");
        alsa_home(dir.path(), &capture);
        let profile = write(dir.path(), "u.csv", "x_mm,voltage_v\n0,40\n10,80\n");
        let json = dir.path().join("run.json");
        let args = ["--profile", &profile, "--stdin", "--device", "haptex_capture", "--json", json.to_str().unwrap()];
        let out = live(dir.path(), &args, Some("# a comment\nx_mm\n1.0\n2.5\n0.5,3.0\nlift\n4\n"));
        assert!(out.status.success(), "{}", stderr(&out));
        let run: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        assert_eq!(run["events"], 5, "{run}");
        assert_eq!(run["channels"], 1);
        let peak = run["peak_v"].as_f64().unwrap();
        assert!(peak <= 80.0 * std::f64::consts::SQRT_2 + 1e-3, "peak {peak} V");
        assert!(read_f32(&capture).iter().all(|v| v.abs() <= 1.0));

        let out = live(dir.path(), &args, Some("1.0\n2.0,abc\n"));
        assert!(!out.status.success());
        let e = stderr(&out);
        assert!(e.contains("stdin, line 2, field 'x_mm': expected a finite number, got 'abc'"), "{e}");
        assert!(e.contains("faded to 0 V"), "{e}");

        let out = live(dir.path(), &["--profile", &profile, "--stdin", "--device", "no_such_pcm"], Some(""));
        assert!(!out.status.success());
        let e = stderr(&out);
        assert!(e.contains("no output device named 'no_such_pcm'") && e.contains("haptex_capture"), "{e}");

        let out = live(dir.path(), &["--list-devices"], None);
        assert!(out.status.success());
        assert!(String::from_utf8_lossy(&out.stdout).contains("haptex_capture  haptex test capture"));

        let out = live(dir.path(), &["--profile", "-", "--stdin", "--device", "null"], Some(""));
        assert!(stderr(&out).contains("--profile - and --stdin both read stdin"), "{}", stderr(&out));
        let out = live(dir.path(), &["--profile", &profile, "--stdin", "--ramp-ms", "20000"], Some(""));
        assert!(stderr(&out).contains("--ramp-ms must be at most 10000 ms, got 20000"), "{}", stderr(&out));

        // A full scale below the drive's peak is refused before anything plays.
        let out = live(
            dir.path(),
            &["--profile", &profile, "--stdin", "--device", "null", "--volts-per-full-scale", "50"],
            Some(""),
        );
        assert!(!out.status.success());
        let e = stderr(&out);
        assert!(e.contains("exceeds the output's full scale of 50 V (--volts-per-full-scale)"), "{e}");
        assert!(!e.contains("live: null"), "refused before the device was started: {e}");

        // A combined design needs two channels.
        let design = write(
            dir.path(),
            "d.csv",
            "# at most a_max = 2 um\nx_mm,mu,voltage_v,amplitude_um\n0,1,10,0.5\n1,1,20,1\n",
        );
        let out = live(
            dir.path(),
            &["--profile", &design, "--stdin", "--device", "haptex_capture", "--channels", "1"],
            Some(""),
        );
        assert!(!out.status.success());
        let e = stderr(&out);
        assert!(e.contains("the design has 2 channels") && e.contains("give at least 2 channels"), "{e}");
    }
}
