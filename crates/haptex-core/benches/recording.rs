//! Processing throughput of the recording pipeline on the shipped demo
//! library (36 synthetic strokes, 20 kHz forces, 400 Hz position), in
//! multiples of real time: recorded seconds / processing seconds.
//! Run: `cargo bench -p haptex-core --bench recording`.

use std::hint::black_box;
use std::path::{Path, PathBuf};

use criterion::{Criterion, criterion_group, criterion_main};
use haptex_core::recording::{ProcessingConfig, Recording, process};

fn recordings() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).expect("data/library/demo") {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.to_string_lossy().ends_with(".recording.json") {
                out.push(path);
            }
        }
    }
    let mut out = Vec::new();
    walk(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/library/demo"), &mut out);
    out.sort();
    out
}

fn bench(c: &mut Criterion) {
    let paths = recordings();
    let loaded: Vec<Recording> = paths.iter().map(|p| Recording::load(p).unwrap()).collect();
    let recorded_s: f64 = loaded.iter().map(Recording::duration_s).sum();
    let config = ProcessingConfig::default();
    eprintln!("demo library: {} recordings, {recorded_s:.3} s recorded", loaded.len());

    let mut group = c.benchmark_group("demo_library");
    group.sample_size(30);
    group.bench_function("process_all", |b| {
        b.iter(|| {
            for r in &loaded {
                black_box(process(black_box(r), &config).unwrap());
            }
        })
    });
    group.bench_function("load_and_process_all", |b| {
        b.iter(|| {
            for p in &paths {
                let r = Recording::load(p).unwrap();
                black_box(process(&r, &config).unwrap());
            }
        })
    });
    group.finish();

    // Real-time factor from a direct measurement (criterion's estimate is
    // in its report; this line gives the ratio without arithmetic).
    for (name, load) in [("process_all", false), ("load_and_process_all", true)] {
        let runs = 20;
        let start = std::time::Instant::now();
        for _ in 0..runs {
            for (p, r) in paths.iter().zip(&loaded) {
                if load {
                    black_box(process(&Recording::load(p).unwrap(), &config).unwrap());
                } else {
                    black_box(process(r, &config).unwrap());
                }
            }
        }
        let per_run = start.elapsed().as_secs_f64() / runs as f64;
        eprintln!("{name}: {:.2} ms per library, {:.0}x real time", per_run * 1e3, recorded_s / per_run);
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
