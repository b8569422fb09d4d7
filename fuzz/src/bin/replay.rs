//! Replays fuzz corpora through the parsers with a timer, to check that no
//! input costs more than linear time: for every input, the time per byte;
//! and for the slowest inputs per byte, the same input repeated to about
//! 1 MiB, whose time per byte must stay of the same order.
//!
//!     cargo run --release --bin replay -- fuzz/corpus      (from fuzz/)
//!
//! Prints one line per target: inputs replayed, the largest input, the
//! slowest input (time and size), the largest time per byte among inputs of
//! at least 256 bytes, and the ratio of time per byte when the 5 worst of
//! those are repeated to ~1 MiB (about 1 for linear cost; a quadratic
//! parser shows the growth factor of the input, thousands).

use std::path::Path;
use std::time::Instant;

fn main() {
    let root = std::env::args().nth(1).unwrap_or_else(|| "corpus".into());
    println!("target, inputs, largest_bytes, slowest_us (bytes), worst_ns_per_byte (>=256 B), repeat_1MiB_ratio");
    for (name, parse) in haptex_fuzz::TARGETS {
        let dir = Path::new(&root).join(name);
        let Ok(entries) = std::fs::read_dir(&dir) else {
            println!("{name}: no corpus at {}", dir.display());
            continue;
        };
        let inputs: Vec<Vec<u8>> = entries.flatten().filter_map(|e| std::fs::read(e.path()).ok()).collect();
        let mut timed: Vec<(f64, usize, usize)> = Vec::new(); // (seconds, bytes, index)
        for (i, input) in inputs.iter().enumerate() {
            let start = Instant::now();
            parse(input);
            timed.push((start.elapsed().as_secs_f64(), input.len(), i));
        }
        let largest = inputs.iter().map(Vec::len).max().unwrap_or(0);
        let slowest = timed.iter().copied().fold((0.0, 0, 0), |a, b| if b.0 > a.0 { b } else { a });
        let mut per_byte: Vec<(f64, usize)> =
            timed.iter().filter(|t| t.1 >= 256).map(|t| (t.0 / t.1 as f64, t.2)).collect();
        per_byte.sort_by(|a, b| b.0.total_cmp(&a.0));
        let worst = per_byte.first().map_or(0.0, |w| w.0);
        // Repeat the worst inputs to ~1 MiB: per-byte time must not grow
        // with the size.
        let mut ratio: f64 = 0.0;
        for &(small_per_byte, i) in per_byte.iter().take(5) {
            let input = &inputs[i];
            let big: Vec<u8> = input.iter().copied().cycle().take((1 << 20).max(input.len())).collect();
            let start = Instant::now();
            parse(&big);
            let big_per_byte = start.elapsed().as_secs_f64() / big.len() as f64;
            ratio = ratio.max(big_per_byte / small_per_byte);
        }
        println!(
            "{name}, {}, {largest}, {:.0} ({} B), {:.1}, {ratio:.2}",
            inputs.len(),
            slowest.0 * 1e6,
            slowest.1,
            worst * 1e9
        );
    }
}
