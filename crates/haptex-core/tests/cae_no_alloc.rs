//! Issue 4: the prediction API the server and the real-time path call
//! allocates nothing per query. A counting global allocator
//! (`support/counting_alloc.rs`) counts the allocations the test's own
//! thread makes across 1000 predictions into caller-provided buffers; the
//! expected count is exactly 0.

#[path = "support/counting_alloc.rs"]
mod counting_alloc;

use counting_alloc::allocations_in;
use haptex_core::cae::{Cae, ModelMatrix, Widths};

#[test]
fn predict_into_allocates_nothing_per_query() {
    // The counter works: a Vec allocates.
    assert_eq!(allocations_in(|| drop(std::hint::black_box(vec![1u8; 16]))), 1);
    let (n, m) = (200, 50);
    let b: Vec<f64> = (0..n).flat_map(|i| [i as f64 * 0.01, (i * 7 % 13) as f64]).collect();
    let c: Vec<f64> = (0..n * m).map(|i| (i as f64 * 0.001).sin()).collect();
    let names = |p: &str, k: usize| (0..k).map(|i| format!("{p}{i}")).collect::<Vec<_>>();
    let x = ModelMatrix::new(names("b", 2), names("c", m), b, c).unwrap();
    for widths in [Widths::constant(0.1).unwrap(), Widths::range(0.05, 0.2).unwrap()] {
        let cae = Cae::new(x.clone(), widths).unwrap();
        let mut scratch = cae.scratch();
        let mut out = vec![0.0; m];
        let mut far = 0;
        let allocations = allocations_in(|| {
            for q in 0..1000 {
                let query = [q as f64 * 0.003 - 0.5, (q % 17) as f64];
                let d = cae.predict_into(&query, &mut scratch, &mut out).unwrap();
                far += usize::from(d.is_extrapolation());
            }
        });
        assert_eq!(allocations, 0);
        assert!(far > 0 && out.iter().all(|v| v.is_finite()));
    }
}

/// The batched prediction over caller-provided buffers allocates at most
/// the matrix product's packing buffer, once per block of BATCH_BLOCK
/// queries: 4 BATCH_BLOCK + 44 queries, 5 blocks, at most 5 allocations, whatever the
/// number of model vectors (faer's product keeps its buffer between calls:
/// 1 measured; matrixmultiply, before it, allocated one per call).
#[test]
fn predict_batch_into_allocations() {
    let (n, m) = (200, 50);
    let b: Vec<f64> = (0..n).flat_map(|i| [i as f64 * 0.01, (i * 7 % 13) as f64]).collect();
    let c: Vec<f64> = (0..n * m).map(|i| (i as f64 * 0.001).sin()).collect();
    let names = |p: &str, k: usize| (0..k).map(|i| format!("{p}{i}")).collect::<Vec<_>>();
    let x = ModelMatrix::new(names("b", 2), names("c", m), b, c).unwrap();
    let cae = Cae::new(x, Widths::constant(0.1).unwrap()).unwrap();
    let count = 4 * haptex_core::cae::BATCH_BLOCK + 44;
    let queries: Vec<f64> = (0..count).flat_map(|q| [q as f64 * 0.9 / count as f64 - 0.5, (q % 17) as f64]).collect();
    let mut scratch = cae.batch_scratch();
    let mut out = vec![0.0; count * m];
    let mut diagnostics = Vec::with_capacity(count);
    let allocations =
        allocations_in(|| cae.predict_batch_into(&queries, &mut scratch, &mut out, &mut diagnostics).unwrap());
    assert_eq!(count.div_ceil(haptex_core::cae::BATCH_BLOCK), 5);
    assert!((1..=5).contains(&allocations), "{allocations} allocations");
    assert_eq!(diagnostics.len(), count);
}
