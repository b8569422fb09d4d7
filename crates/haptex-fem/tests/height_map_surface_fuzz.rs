//! Fuzzing the 3D finger's height-map surface (`haptex simulate --model 3d
//! --surface map:H.csv`, solid3d::surface::MapSurface): any map the map
//! reader accepts (2 x 2 cells and up, any positive spacing, heights of
//! any size within the accepted range, including spikes) and any query
//! point (inside, beyond, far beyond, non-finite). The property: the
//! surface is built in linear time without a panic, and its height, slope,
//! curvature, depth and normal are finite for every finite point; a point
//! at a sample gives the sample (to rounding relative to the map's
//! heights).
//!
//! Cases: `HAPTEX_FUZZ_CASES` (default 1000).

use haptex_core::height::HeightMap;
use haptex_core::map::MapGrid;
use haptex_fem::solid3d::surface::{HeightField, MapSurface};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

fn runner() -> TestRunner {
    let cases = std::env::var("HAPTEX_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(1000);
    TestRunner::new(Config { cases, failure_persistence: None, ..Config::default() })
}

fn height() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -1.0f64..1.0,
        1 => -1e3f64..1e3,
        1 => proptest::sample::select(vec![0.0, -0.0, 5e-324, 1e3, -1e3, 1e-300]),
    ]
}

fn coordinate() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -30.0f64..30.0,
        1 => -1e12f64..1e12,
        1 => proptest::sample::select(vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY, f64::MAX, -f64::MAX, 5e-324]),
    ]
}

#[test]
fn any_accepted_map_is_a_finite_surface() {
    let strategy = (
        (2usize..12, 2usize..12),
        (1e-3f64..5.0, 1e-3f64..5.0),
        (-20.0f64..20.0, -20.0f64..20.0),
        proptest::collection::vec(height(), 144),
        proptest::collection::vec((coordinate(), coordinate(), -5.0f64..5.0), 1..12),
    );
    runner()
        .run(&strategy, |((nx, ny), (dx, dy), (x0, y0), heights, queries)| {
            let grid = MapGrid { nx, ny, x0_mm: x0, y0_mm: y0, dx_mm: dx, dy_mm: dy };
            let Ok(map) = HeightMap::new(grid, heights[..nx * ny].to_vec(), "fuzz") else {
                return Ok(());
            };
            let scale = map.h_mm.iter().fold(1.0f64, |a, h| a.max(h.abs()));
            let surface = MapSurface::new(&map);
            for j in 0..ny {
                for i in 0..nx {
                    let (h, _, _) = surface.derivatives(x0 + dx * i as f64, y0 + dy * j as f64);
                    prop_assert!((h - map.h_mm[j * nx + i]).abs() <= 1e-9 * scale, "sample ({i}, {j}): {h}");
                }
            }
            let field = HeightField::Map { surface: std::sync::Arc::new(surface.clone()), origin_mm: [0.0; 2] };
            for (x, y, z) in queries {
                let (h, g, hessian) = surface.derivatives(x, y);
                prop_assert!(h.is_finite() && g.iter().all(|v| v.is_finite()), "({x}, {y}): {h} {g:?}");
                prop_assert!(hessian.iter().flatten().all(|v| v.is_finite()));
                if x.is_finite() && y.is_finite() {
                    let at = field.at([x, y, z]);
                    prop_assert!(at.depth.is_finite() && at.normal.iter().all(|v| v.is_finite()));
                    // The bounds hold the spline.
                    let (lo, hi) = surface.bounds([x - 1.0, x + 1.0], [y - 1.0, y + 1.0]);
                    prop_assert!(lo <= h + 1e-9 * scale && h <= hi + 1e-9 * scale, "{lo} <= {h} <= {hi}");
                }
            }
            Ok(())
        })
        .unwrap();
}
