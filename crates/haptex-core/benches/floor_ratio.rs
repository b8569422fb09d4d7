//! One CAE query against the streaming floor, the two timed in turns in
//! one process (issue 20): N = 405, D = 4, M = 500, constant width 0.13,
//! the same model, queries and floor as `cargo bench --bench cae`
//! (`predict_constant_w0.13`, `stream_floor_outputs_1.62MB`).
//!
//! Criterion times the two one after the other, each over a few seconds,
//! and where the process's memory landed moves the floor's time from one
//! process to the next (12.8-13.7 µs over three processes of one build, AMD
//! EPYC, 2026-11-28). Here each round times 4000 floor reads, then 4000
//! predictions cycling through the 16 queries, and the ratio is taken per
//! round; the median and quartiles over the rounds are printed.
//! Run: `cargo bench -p haptex-core --bench floor_ratio [-- ROUNDS]`.

use std::hint::black_box;
use std::time::Instant;

use haptex_core::cae::{Cae, Widths};

mod cae_common;

use cae_common::{M, aligned_chunks, database, queries, stream_sum};

/// Floor reads and predictions per round.
const REPEATS: usize = 4000;

fn main() {
    // `cargo bench` passes `--bench`; a number is the count of rounds.
    let rounds = std::env::args().skip(1).find_map(|a| a.parse::<usize>().ok()).unwrap_or(30).max(1);
    let cae = Cae::new(database(), Widths::constant(0.13).expect("a valid width")).expect("a valid model");
    let outputs = aligned_chunks(cae.matrix().outputs_flat());
    let queries = queries();
    let mut scratch = cae.scratch();
    let mut out = vec![0.0; M];
    let used: usize =
        queries.iter().map(|q| cae.predict_into(q, &mut scratch, &mut out).expect("a valid query").weights_used).sum();
    let (mut floor, mut predict, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..rounds {
        let start = Instant::now();
        for _ in 0..REPEATS {
            black_box(stream_sum(black_box(&outputs)));
        }
        let f = start.elapsed().as_secs_f64() / REPEATS as f64;
        let start = Instant::now();
        for r in 0..REPEATS {
            cae.predict_into(black_box(&queries[r % queries.len()]), &mut scratch, &mut out).expect("a valid query");
            black_box(&out);
        }
        let p = start.elapsed().as_secs_f64() / REPEATS as f64;
        floor.push(f);
        predict.push(p);
        ratio.push(p / f);
    }
    let quantiles = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        (at(0.25), at(0.5), at(0.75))
    };
    let ((_, f, _), (_, p, _), (r25, r, r75)) = (quantiles(&mut floor), quantiles(&mut predict), quantiles(&mut ratio));
    println!("rows entering eq. (11), mean over the 16 queries: {:.2} of {}", used as f64 / 16.0, cae.matrix().n());
    println!("{rounds} rounds of {REPEATS}: floor median {:.3} us, prediction median {:.3} us", f * 1e6, p * 1e6);
    println!("ratio prediction / floor: median {r:.4}, quartiles {r25:.4} .. {r75:.4}");
}
