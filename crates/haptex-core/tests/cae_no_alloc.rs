//! Issue 4: the prediction API the server and the real-time path call
//! allocates nothing per query. A counting global allocator (this test
//! binary only, one test so nothing else runs at the same time) sees zero
//! allocations across 1000 predictions into caller-provided buffers.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use haptex_core::cae::{Cae, ModelMatrix, Widths};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator, only counting calls.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn predict_into_allocates_nothing_per_query() {
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
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        for q in 0..1000 {
            let query = [q as f64 * 0.003 - 0.5, (q % 17) as f64];
            let d = cae.predict_into(&query, &mut scratch, &mut out).unwrap();
            far += usize::from(d.is_extrapolation());
        }
        assert_eq!(ALLOCATIONS.load(Ordering::SeqCst) - before, 0);
        assert!(far > 0 && out.iter().all(|v| v.is_finite()));
    }
}
