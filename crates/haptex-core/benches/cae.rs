//! Speed of the conditional average estimator at the size of the FE
//! database (issue 4): N = 405 model vectors (a 9 x 5 x 3 x 3 grid), D = 4
//! inputs, M = 500 outputs (a sampled friction profile per row).
//! Run: `cargo bench -p haptex-core --bench cae`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use haptex_core::cae::{Cae, Loo, ModelMatrix, OptimizeOptions, Widths, optimize_widths};

mod cae_common;

use cae_common::{M, aligned_chunks, database, queries, stream_sum};

fn bench(c: &mut Criterion) {
    let x = database();
    assert_eq!((x.n(), x.d(), x.m()), (405, 4, 500));
    let queries = queries();

    let mut group = c.benchmark_group("cae_n405_d4_m500");
    let constant = Cae::new(x.clone(), Widths::constant(0.13).unwrap()).unwrap();
    let nonconstant = Cae::new(x.clone(), Widths::range(0.1, 0.2).unwrap()).unwrap();
    for (name, cae) in [("predict_constant_w0.13", &constant), ("predict_nonconstant_w0.1_0.2", &nonconstant)] {
        let mut scratch = cae.scratch();
        let mut out = vec![0.0; M];
        let mut q = 0;
        group.bench_function(name, |b| {
            b.iter(|| {
                q = (q + 1) % queries.len();
                cae.predict_into(black_box(&queries[q]), &mut scratch, &mut out).unwrap();
                black_box(&out);
            })
        });
    }
    // The weights alone (eqs. 12 and the rows that enter eq. 11): the same
    // inputs and width with only the first four outputs, so the sum is
    // negligible. predict_constant minus this is the time of the sum.
    let four: Vec<f64> = x.outputs_flat().chunks_exact(M).flat_map(|row| row[..4].to_vec()).collect();
    let x4 = ModelMatrix::new(x.inputs().to_vec(), x.outputs()[..4].to_vec(), x.inputs_flat().to_vec(), four).unwrap();
    let weights_only = Cae::new(x4, Widths::constant(0.13).unwrap()).unwrap();
    let mut scratch = weights_only.scratch();
    let mut out = [0.0; 4];
    let mut q = 0;
    group.bench_function("weights_constant_w0.13_m4", |b| {
        b.iter(|| {
            q = (q + 1) % queries.len();
            weights_only.predict_into(black_box(&queries[q]), &mut scratch, &mut out).unwrap();
            black_box(&out);
        })
    });
    // The streaming floor of one prediction: one read of the bytes it must
    // read (the N x M outputs, 1.62 MB), summed in 16 independent
    // accumulators, nothing else. A prediction cannot be faster than this
    // on the machine it runs on; BENCHMARKS.md reports the ratio
    // predict_constant / stream_floor. The outputs copied into 64-byte
    // aligned chunks (where the allocator put an unaligned copy, the same
    // read was 9% slower: AMD EPYC, 2026-11-26) and read with AVX2 where
    // the CPU has it: the fastest plain read measured on AMD EPYC,
    // 2026-11-25 (the two-lane build was 13% slower, AVX-512 2% slower).
    let outputs = aligned_chunks(constant.matrix().outputs_flat());
    group.bench_function("stream_floor_outputs_1.62MB", |b| b.iter(|| stream_sum(black_box(&outputs))));
    // 256 queries at once (four blocks), per call; divide by 256 for the
    // time per query.
    let batch: Vec<f64> = (0..256)
        .flat_map(|q| {
            let t = q as f64 / 255.0;
            [0.5 + 2.0 * t, 0.1 + 0.4 * (1.0 - t), 10.0 + 40.0 * (t * 7.0).fract(), 0.4 + 0.2 * (t * 3.0).fract()]
        })
        .collect();
    let cae = constant;
    let mut batch_scratch = cae.batch_scratch();
    let mut batch_out = vec![0.0; 256 * M];
    let mut diagnostics = Vec::with_capacity(256);
    group.bench_function("predict_batch256_one_thread_w0.13", |b| {
        b.iter(|| {
            cae.predict_batch_into(black_box(&batch), &mut batch_scratch, &mut batch_out, &mut diagnostics).unwrap();
            black_box(&batch_out);
        })
    });
    group.bench_function("predict_batch256_rayon_w0.13", |b| b.iter(|| cae.predict_batch(black_box(&batch)).unwrap()));
    let mut loo = Loo::new(&x).unwrap();
    group.bench_function("loo_rmse_one_width", |b| b.iter(|| loo.rmse(black_box(Widths::constant(0.13).unwrap()))));
    group.sample_size(10);
    group.bench_function("loo_optimize_constant", |b| {
        b.iter(|| optimize_widths(&x, OptimizeOptions { constant_only: true, ..OptimizeOptions::default() }).unwrap())
    });
    group.bench_function("loo_optimize_nonconstant", |b| {
        b.iter(|| optimize_widths(&x, OptimizeOptions::default()).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
