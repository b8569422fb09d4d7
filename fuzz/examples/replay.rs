//! The timing half of the fuzz campaign (RELIABILITY.md).
//!
//!     cargo run --release --example replay -- corpus      (from fuzz/)
//!
//! 1. Replays every corpus input of every target through its parser with a
//!    timer: inputs, the largest, the slowest, and the largest time per
//!    byte among inputs of at least 256 bytes.
//! 2. Scaling: for every target, a valid input that exercises the whole
//!    accepted path (a profile of N rows, a recording of N samples, a
//!    header of N column names ...) at two sizes 16 times apart, 60 KiB and
//!    960 KiB; the ratio of the time per byte of the large to the
//!    small one is about 1 for linear cost, and about 16 for quadratic
//!    cost. Each time is the best of 3.

use std::path::Path;
use std::time::Instant;

fn main() {
    let root = std::env::args().nth(1).unwrap_or_else(|| "corpus".into());
    println!("corpus replay:");
    println!("target | inputs | largest (bytes) | slowest (us, at bytes) | worst ns/byte (inputs >= 256 B)");
    for (name, parse) in haptex_fuzz::TARGETS {
        let dir = Path::new(&root).join(name);
        let Ok(entries) = std::fs::read_dir(&dir) else {
            println!("{name} | no corpus at {}", dir.display());
            continue;
        };
        let inputs: Vec<Vec<u8>> = entries.flatten().filter_map(|e| std::fs::read(e.path()).ok()).collect();
        let (mut slowest, mut slowest_len, mut worst) = (0.0f64, 0, 0.0f64);
        for input in &inputs {
            let start = Instant::now();
            parse(input);
            let t = start.elapsed().as_secs_f64();
            if t > slowest {
                (slowest, slowest_len) = (t, input.len());
            }
            if input.len() >= 256 {
                worst = worst.max(t / input.len() as f64);
            }
        }
        let largest = inputs.iter().map(Vec::len).max().unwrap_or(0);
        println!("{name} | {} | {largest} | {:.0} ({slowest_len} B) | {:.1}", inputs.len(), slowest * 1e6, worst * 1e9);
    }

    println!();
    println!("scaling (valid inputs, best of 3):");
    println!("target: input | small: bytes, ns/byte | large: bytes, ns/byte | ratio");
    for (name, what, make) in GROWERS {
        let parse = haptex_fuzz::TARGETS.iter().find(|(n, _)| n == name).expect("a target").1;
        let per_byte = |input: &[u8]| {
            let best = (0..3)
                .map(|_| {
                    let start = Instant::now();
                    parse(input);
                    start.elapsed().as_secs_f64()
                })
                .fold(f64::INFINITY, f64::min);
            best / input.len() as f64
        };
        // 60 KiB and 960 KiB: under the 1 MiB limits of a line, a finger
        // file and a request body, so the large input is read, not refused.
        let small = make(60 << 10);
        let large = make(960 << 10);
        let (a, b) = (per_byte(&small), per_byte(&large));
        println!("{name}: {what} | {}, {:.1} | {}, {:.1} | {:.2}", small.len(), a * 1e9, large.len(), b * 1e9, b / a);
    }
}

type Grower = fn(usize) -> Vec<u8>;

/// A valid input of about `bytes` bytes for each target.
const GROWERS: &[(&str, &str, Grower)] = &[
    ("profile_csv", "x_mm,ft_n,fn_n rows", |bytes| rows(bytes, "x_mm,ft_n,fn_n", |i| format!("{i},0.5,0.4"))),
    ("profile_csv", "header of distinct names", |bytes| header(bytes, "x_mm,mu")),
    ("voltage_csv", "x_mm,voltage_v rows", |bytes| rows(bytes, "x_mm,voltage_v", |i| format!("{i},{}", i % 90))),
    ("trajectory_csv", "t_s,x_mm rows", |bytes| rows(bytes, "t_s,x_mm", |i| format!("{},{}", i as f64 * 1e-3, i % 10))),
    ("model_matrix", "rows of 1 input, 4 outputs", |bytes| {
        rows(bytes, "a,y1,y2,y3,y4", |i| format!("{},{},{},{},{}", i as f64 * 1e-3, i % 7, i % 5, i % 3, i % 2))
    }),
    ("model_matrix", "header of distinct names", |bytes| {
        let mut text = header(bytes, "a");
        let n = text.iter().filter(|&&b| b == b',').count() + 1;
        for row in 0..2 {
            text.extend(
                (0..n).map(|k| if k == 0 { format!("{row}") } else { ",1".into() }).collect::<String>().bytes(),
            );
            text.push(b'\n');
        }
        text
    }),
    ("recording", "force samples (position at 1/10 the rate)", recording),
    ("finger_toml", "the shipped model and comment lines", |bytes| {
        let mut text = haptex_fem::finger::DEFAULT_MODEL_TOML.to_string();
        while text.len() < bytes {
            text.push_str("# a comment line that the reader skips, as many as the file has\n");
        }
        text.into_bytes()
    }),
    ("surface_file", "x_mm,h_mm rows", |bytes| {
        rows(bytes, "x_mm,h_mm", |i| format!("{},{}", i as f64 * 1e-2, (i % 9) as f64 * 1e-2))
    }),
    ("drive_wav", "samples", drive_wav),
    ("http_body", "profile CSV body to /api/voltage", |bytes| {
        let mut body = vec![3u8];
        body.extend(rows(bytes, "x_mm,mu", |i| format!("{},1.{}", i as f64 * 1e-3, i % 7)));
        body
    }),
];

/// A CSV of `header` and rows made by `row(i)`, about `bytes` long.
fn rows(bytes: usize, header: &str, row: impl Fn(usize) -> String) -> Vec<u8> {
    let mut text = format!("{header}\n");
    let mut i = 0;
    while text.len() < bytes {
        text += &row(i);
        text.push('\n');
        i += 1;
    }
    text.into_bytes()
}

/// A header line of distinct column names, starting with `first`, about
/// `bytes` long (the issue's quadratic duplicate check), and no rows.
fn header(bytes: usize, first: &str) -> Vec<u8> {
    let mut text = first.to_string();
    let mut i = 0;
    while text.len() < bytes {
        text += &format!(",c{i:07}");
        i += 1;
    }
    text.push('\n');
    text.into_bytes()
}

/// A recording (the `recording` target's layout) of about `bytes`.
fn recording(bytes: usize) -> Vec<u8> {
    let meta = r#"{"format": "haptex-recording-1", "material": "m", "participant": "P1", "stroke": 1,
 "force": {"file": "f.csv", "rate_hz": 1000}, "position": {"file": "p.csv", "rate_hz": 100},
 "units": {"time": "s", "force": "N", "position": "mm"}, "source": "scaling", "licence": "CC0-1.0"}"#;
    let n = bytes / 22;
    let mut force = String::from("t_s,fn_n,ft_n\n");
    for i in 0..=n {
        force += &format!("{},0.5,0.25\n", i as f64 / 1000.0);
    }
    let mut position = String::from("t_s,x_mm\n");
    for k in 0..=n / 10 {
        position += &format!("{},{}\n", k as f64 / 100.0, k as f64 * 0.1);
    }
    let mut data = vec![0u8];
    data.extend(meta.bytes());
    data.extend(b"\n---\n");
    data.extend(force.bytes());
    data.extend(b"\n---\n");
    data.extend(position.bytes());
    data
}

/// A haptex drive-signal WAV of about `bytes` (16-bit samples).
fn drive_wav(bytes: usize) -> Vec<u8> {
    use haptex_core::signal::{RenderSettings, VoltageCurve, WavFormat, WavOptions, encode_wav, render};
    use haptex_core::trajectory::Trajectory;
    let samples = bytes / 2;
    let rate = 48_000u32;
    let duration = samples as f64 / f64::from(rate);
    let curve = VoltageCurve::new(vec![0.0, 10.0], vec![10.0, 90.0]).unwrap();
    let trajectory = Trajectory::constant_velocity(0.0, 10.0, 10.0 / duration, 1000.0).unwrap();
    let settings = RenderSettings { sample_rate_hz: rate, ..RenderSettings::DEFAULT };
    let signal = render(&curve, &trajectory, &settings).unwrap();
    let options = WavOptions { format: WavFormat::Pcm16, volts_per_full_scale: 150.0 };
    encode_wav(&signal, &options, "scaling").unwrap().bytes
}
