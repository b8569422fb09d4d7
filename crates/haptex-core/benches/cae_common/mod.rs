//! What the CAE benchmarks share: the benchmark's model matrix and
//! queries, and the streaming floor (one plain read of the outputs).

use haptex_core::cae::ModelMatrix;

/// Outputs per model vector.
pub const M: usize = 500;

/// A gridded database of smooth bump-like friction profiles: inputs
/// (width 0.5..2.5 mm, height 0.1..0.5 mm, velocity 10..50 mm/s, mu_skin
/// 0.4..0.6), outputs mu at 500 positions over 10 mm.
pub fn database() -> ModelMatrix {
    let mut b = Vec::new();
    let mut c = Vec::new();
    for i in 0..9 {
        for j in 0..5 {
            for k in 0..3 {
                for l in 0..3 {
                    let (rw, rh, v, mu) =
                        (0.5 + 0.25 * i as f64, 0.1 + 0.1 * j as f64, 10.0 + 20.0 * k as f64, 0.4 + 0.1 * l as f64);
                    b.extend([rw, rh, v, mu]);
                    c.extend((0..M).map(|p| {
                        let u = (p as f64 * 0.02 - 5.0) / rw;
                        mu * (1.0 - 0.6 * rh * u * (-u * u).exp() * (1.0 + 0.002 * v))
                    }));
                }
            }
        }
    }
    let names = |prefix: &str, n: usize| (0..n).map(|i| format!("{prefix}{i}")).collect::<Vec<_>>();
    let inputs = ["r_w", "r_h", "velocity", "mu_skin"].map(String::from).to_vec();
    ModelMatrix::new(inputs, names("mu_", M), b, c).unwrap()
}

/// The 16 queries one prediction benchmark cycles through, inside the
/// database's box.
pub fn queries() -> Vec<[f64; 4]> {
    (0..16)
        .map(|q| [0.6 + 0.12 * q as f64, 0.13 + 0.02 * q as f64, 12.0 + 2.3 * q as f64, 0.43 + 0.01 * q as f64])
        .collect()
}

/// Sixteen doubles on a 64-byte boundary.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub struct Chunk([f64; 16]);

/// `v` in aligned chunks, the last one padded with zeros.
pub fn aligned_chunks(v: &[f64]) -> Vec<Chunk> {
    v.chunks(16)
        .map(|c| {
            let mut chunk = Chunk([0.0; 16]);
            chunk.0[..c.len()].copy_from_slice(c);
            chunk
        })
        .collect()
}

/// The sum of `v` in 16 accumulators: a streaming read.
pub fn stream_sum(v: &[Chunk]) -> [f64; 16] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        return unsafe { stream_sum_avx2(v) };
    }
    stream_sum_lanes(v)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn stream_sum_avx2(v: &[Chunk]) -> [f64; 16] {
    stream_sum_lanes(v)
}

#[inline(always)]
fn stream_sum_lanes(v: &[Chunk]) -> [f64; 16] {
    let mut acc = [0.0f64; 16];
    for Chunk(chunk) in v {
        for (a, x) in acc.iter_mut().zip(chunk) {
            *a += x;
        }
    }
    acc
}
