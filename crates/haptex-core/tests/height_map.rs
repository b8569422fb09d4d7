//! Issue 19: height maps and the lines along a sliding direction
//! (`haptex_core::height`): the geometry of the lines, the way their
//! friction goes back on the map, templates along a path, and the files.

use haptex_core::height::{HeightMap, PathTemplate, SlidingLines, signed_distance};
use haptex_core::map::MapGrid;

fn grid() -> MapGrid {
    MapGrid { nx: 41, ny: 21, x0_mm: -1.0, y0_mm: 2.0, dx_mm: 0.1, dy_mm: 0.2 }
}

/// At 0 degrees the lines are the map's rows and at 90 its columns,
/// exactly (same positions, same spacing); at 180 the rows run backwards.
#[test]
fn lines_at_the_axes_are_the_rows_and_columns() {
    let g = grid();
    let h: Vec<f64> = (0..g.len()).map(|k| (k % g.nx) as f64 * 1e-3 + (k / g.nx) as f64 * 1e-2).collect();
    let map = HeightMap::new(g, h.clone(), "test").unwrap();
    let rows = SlidingLines::new(&g, 0.0).unwrap();
    assert_eq!(rows.grid, g);
    for k in [0, 7, g.ny - 1] {
        let (s, line) = rows.line(&map, k);
        assert_eq!(s, (0..g.nx).map(|i| g.x(i)).collect::<Vec<_>>());
        assert_eq!(line, h[k * g.nx..(k + 1) * g.nx]);
    }
    let columns = SlidingLines::new(&g, 90.0).unwrap();
    assert_eq!((columns.count(), columns.grid.nx), (g.nx, g.ny));
    assert_eq!((columns.grid.dx_mm, columns.grid.dy_mm), (g.dy_mm, g.dx_mm));
    // Line k at r = -x: the column x = -r, from the lowest r (the largest x).
    let (s, line) = columns.line(&map, 0);
    assert_eq!(s, (0..g.ny).map(|j| g.y(j)).collect::<Vec<_>>());
    assert_eq!(line, (0..g.ny).map(|j| h[j * g.nx + g.nx - 1]).collect::<Vec<_>>());
    let back = SlidingLines::new(&g, 180.0).unwrap();
    let (_, line) = back.line(&map, back.count() - 1);
    let reversed: Vec<f64> = h[..g.nx].iter().rev().copied().collect();
    assert_eq!(line, reversed);
}

/// Friction given on the lines as a linear function of (x, y) comes back
/// on every cell exactly (to 1e-12: bilinear interpolation reproduces a
/// linear function), at any direction; the lines cover every cell.
#[test]
fn assembled_friction_is_the_lines_friction_at_each_cell() {
    let g = grid();
    let f = |x: f64, y: f64| 0.5 + 0.03 * x - 0.02 * y;
    for angle in [0.0, 17.0, 45.0, 90.0, 135.0, -60.0, 270.0] {
        let lines = SlidingLines::new(&g, angle).unwrap();
        let mut mu = Vec::with_capacity(lines.grid.len());
        for k in 0..lines.count() {
            for i in 0..lines.grid.nx {
                let (x, y) = lines.to_map_frame(lines.grid.x(i), lines.grid.y(k));
                mu.push(f(x, y));
            }
        }
        let map = lines.assemble(&g, &mu, "test").unwrap();
        let mut worst = 0.0f64;
        for j in 0..g.ny {
            for i in 0..g.nx {
                let (s, r) = lines.to_line_frame(g.x(i), g.y(j));
                let l = &lines.grid;
                let inside = |v: f64, v0: f64, d: f64, n: usize| v >= v0 - 1e-9 && v <= v0 + d * (n - 1) as f64 + 1e-9;
                assert!(
                    inside(s, l.x0_mm, l.dx_mm, l.nx) && inside(r, l.y0_mm, l.dy_mm, l.ny),
                    "{angle}: cell outside"
                );
                worst = worst.max((map.mu[j * g.nx + i] - f(g.x(i), g.y(j))).abs());
            }
        }
        assert!(worst < 1e-12, "{angle} degrees: worst {worst}");
    }
    assert!(SlidingLines::new(&g, f64::NAN).is_err());
    assert!(SlidingLines::new(&g, 400.0).is_err());
}

/// A ridge along a path: the height is the bump's at the distance from
/// the path (the FE template's formula); an edge is up on the path's left;
/// grooves are a sine of the distance. Bad templates and paths are refused.
#[test]
fn templates_along_a_path() {
    let g = MapGrid { nx: 101, ny: 61, x0_mm: 0.0, y0_mm: 0.0, dx_mm: 0.1, dy_mm: 0.1 };
    let path = [(1.0, 1.0), (9.0, 5.0)];
    let bump = PathTemplate::Bump { width_mm: 2.0, height_mm: 0.2 };
    let map = HeightMap::along_path(g, bump, &path).unwrap();
    let (ux, uy) = (8.0 / 80f64.sqrt(), 4.0 / 80f64.sqrt());
    for (i, j) in [(50, 30), (30, 40), (80, 10), (0, 60)] {
        let (x, y) = (g.x(i), g.y(j));
        let t = ((x - 1.0) * ux + (y - 1.0) * uy).clamp(0.0, 80f64.sqrt());
        let d = ((x - 1.0 - t * ux).powi(2) + (y - 1.0 - t * uy).powi(2)).sqrt();
        let want = 0.2 * (-(d / 1.0).powi(2)).exp();
        assert!((map.h_mm[j * g.nx + i] - want).abs() < 1e-12, "({x}, {y})");
    }
    // Left of the path (above this rising line) is positive.
    assert!(signed_distance(&path, 2.0, 4.0) > 0.0 && signed_distance(&path, 6.0, 1.0) < 0.0);
    let edge = HeightMap::along_path(g, PathTemplate::Edge { width_mm: 1.0, height_mm: 0.1 }, &path).unwrap();
    assert_eq!(edge.h_mm[50 * g.nx + 10], 0.1, "up on the left");
    assert_eq!(edge.h_mm[5 * g.nx + 90], 0.0, "down on the right");
    for bad in
        [PathTemplate::Bump { width_mm: 0.0, height_mm: 0.1 }, PathTemplate::Sine { width_mm: 1.0, height_mm: 2e3 }]
    {
        assert!(HeightMap::along_path(g, bad, &path).is_err(), "{bad:?}");
    }
    assert!(HeightMap::along_path(g, bump, &[(1.0, 1.0)]).is_err());
    assert!(HeightMap::along_path(g, bump, &[(1.0, 1.0), (1.0, 1.0)]).is_err());
    assert!(HeightMap::along_path(g, bump, &[(1.0, 1.0), (f64::NAN, 1.0)]).is_err());
}

/// `x_mm,y_mm,h_mm` CSV round trip to the bit; a height out of range is
/// refused naming the line and the field.
#[test]
fn height_csv_round_trip_and_errors() {
    let g = MapGrid { nx: 3, ny: 2, x0_mm: 0.5, y0_mm: -1.0, dx_mm: 0.25, dy_mm: 0.5 };
    let map = HeightMap::new(g, vec![0.0, 0.1, -0.2, 1.0 / 3.0, 1e-9, 0.25], "test").unwrap();
    let mut bytes = Vec::new();
    map.write_csv(&mut bytes).unwrap();
    let back = HeightMap::read_csv(bytes.as_slice(), "h.csv").unwrap();
    assert_eq!(back, map);
    let bad = "x_mm,y_mm,h_mm\n0,0,0\n1,0,0\n0,1,0\n1,1,5000\n";
    let e = HeightMap::read_csv(bad.as_bytes(), "h.csv").unwrap_err().to_string();
    assert!(e.contains("h.csv") && e.contains("line 5") && e.contains("h_mm"), "{e}");
    let e = HeightMap::new(g, vec![0.0; 5], "test").unwrap_err().to_string();
    assert!(e.contains("5 heights for a 3 x 2 grid"), "{e}");
}
