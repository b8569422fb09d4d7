//! Times `Cae::predict_into` (one query at a time),
//! `Cae::predict_batch_into` (all queries at once, one thread) and
//! `Cae::predict_batch` (the same on rayon's threads) over a file of queries,
//! for the side-by-side comparisons with statsmodels and NumPy
//! (`scripts/compare_cae_statsmodels.py`, `scripts/compare_cae_numpy.py`).
//!
//! Usage: cae_timing MODEL.csv INPUTS(a,b,c) QUERIES.csv WIDTH REPEATS OUT.csv
//! Writes the predictions (one row per query, one query at a time) to
//! OUT.csv and prints JSON: {"n", "d", "m", "queries", "seconds_per_query",
//! "seconds_per_query_batch", "seconds_per_query_batch_parallel",
//! "threads", "batch_max_relative_difference"} (each the
//! fastest of REPEATS passes over all queries, divided by the number of
//! queries; the difference is the batch's largest from the one-at-a-time
//! predictions, relative to the output's magnitude).

use std::path::Path;
use std::time::Instant;

use haptex_core::cae::{Cae, ModelMatrix, Widths};
use haptex_core::io::{Table, write_atomic, write_csv_row};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 7 {
        return Err("usage: cae_timing MODEL.csv a,b,c QUERIES.csv WIDTH REPEATS OUT.csv".into());
    }
    let inputs: Vec<&str> = args[2].split(',').collect();
    let matrix = ModelMatrix::read_csv_file(Path::new(&args[1]), &inputs)?;
    let table = Table::read_file(Path::new(&args[3]))?;
    let columns = inputs.iter().map(|name| table.require(name)).collect::<Result<Vec<_>, _>>()?;
    let queries: Vec<Vec<f64>> = (0..table.n_rows()).map(|r| columns.iter().map(|c| c[r]).collect()).collect();
    let width: f64 = args[4].parse()?;
    let repeats: usize = args[5].parse()?;

    let cae = Cae::new(matrix, Widths::constant(width)?)?;
    let m = cae.matrix().m();
    let mut scratch = cae.scratch();
    let mut out = vec![0.0; queries.len() * m];
    let mut best = f64::INFINITY;
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        for (q, o) in queries.iter().zip(out.chunks_exact_mut(m)) {
            cae.predict_into(q, &mut scratch, o)?;
        }
        best = best.min(start.elapsed().as_secs_f64());
    }
    let flat: Vec<f64> = queries.iter().flatten().copied().collect();
    let mut batch_scratch = cae.batch_scratch();
    let mut batch_out = vec![0.0; queries.len() * m];
    let mut diagnostics = Vec::with_capacity(queries.len());
    let mut best_batch = f64::INFINITY;
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        cae.predict_batch_into(&flat, &mut batch_scratch, &mut batch_out, &mut diagnostics)?;
        best_batch = best_batch.min(start.elapsed().as_secs_f64());
    }
    // The same on rayon's threads (RAYON_NUM_THREADS sets how many).
    let mut best_parallel = f64::INFINITY;
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        let (parallel, _) = cae.predict_batch(&flat)?;
        best_parallel = best_parallel.min(start.elapsed().as_secs_f64());
        if parallel != batch_out {
            return Err("the parallel batch differs from the sequential one".into());
        }
    }
    let difference = out.iter().zip(&batch_out).map(|(a, b)| (a - b).abs() / a.abs().max(1e-300)).fold(0.0, f64::max);
    write_atomic(Path::new(&args[6]), |w| {
        writeln!(w, "{}", cae.matrix().outputs().join(","))?;
        for row in out.chunks_exact(m) {
            write_csv_row(w, row)?;
        }
        Ok(())
    })?;
    println!(
        "{{\"n\": {}, \"d\": {}, \"m\": {m}, \"queries\": {}, \"seconds_per_query\": {:e}, \
         \"seconds_per_query_batch\": {:e}, \"seconds_per_query_batch_parallel\": {:e}, \"threads\": {}, \
         \"batch_max_relative_difference\": {:e}}}",
        cae.matrix().n(),
        cae.matrix().d(),
        queries.len(),
        best / queries.len() as f64,
        best_batch / queries.len() as f64,
        best_parallel / queries.len() as f64,
        rayon::current_num_threads(),
        difference
    );
    Ok(())
}
