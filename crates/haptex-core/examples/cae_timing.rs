//! Times `Cae::predict_into` over a file of queries, for the side-by-side
//! comparison with statsmodels (`scripts/compare_cae_statsmodels.py`).
//!
//! Usage: cae_timing MODEL.csv INPUTS(a,b,c) QUERIES.csv WIDTH REPEATS OUT.csv
//! Writes the predictions (one row per query) to OUT.csv and prints JSON:
//! {"n", "d", "m", "queries", "seconds_per_query"} (the fastest of REPEATS
//! passes over all queries, divided by the number of queries).

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
    write_atomic(Path::new(&args[6]), |w| {
        writeln!(w, "{}", cae.matrix().outputs().join(","))?;
        for row in out.chunks_exact(m) {
            write_csv_row(w, row)?;
        }
        Ok(())
    })?;
    println!(
        "{{\"n\": {}, \"d\": {}, \"m\": {m}, \"queries\": {}, \"seconds_per_query\": {:e}}}",
        cae.matrix().n(),
        cae.matrix().d(),
        queries.len(),
        best / queries.len() as f64
    );
    Ok(())
}
