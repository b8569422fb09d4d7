//! Issue 19: `haptex map height`, the friction of a height map from the FE
//! finger model line by line, against `haptex simulate` of the analytic
//! templates (an independent path: the FE's own template surface, not a
//! sampled one), and the direction dependence of a ridge.

use haptex_core::io::Table;
use haptex_core::profile::interpolate as at;

mod common;
use common::{haptex, stderr, write};

/// Columns of a CSV written by haptex (`#` comments skipped).
fn columns(path: &str, names: &[&str]) -> Vec<Vec<f64>> {
    let t = Table::read(std::fs::read(path).unwrap().as_slice(), path).unwrap();
    names.iter().map(|n| t.column(n).unwrap().to_vec()).collect()
}

fn run_ok(args: &[&str]) -> String {
    let out = haptex(args);
    assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    stderr(&out)
}

/// Each `haptex map height` command line fails, its error contains the
/// text given, and `out_path` is not written.
fn assert_refused(out_path: &str, cases: Vec<(Vec<&str>, &str)>) {
    for (args, want) in cases {
        let all = [&["map", "height"][..], &args, &["-o", out_path]].concat();
        let out = haptex(&all);
        assert!(!out.status.success(), "{all:?}");
        assert!(stderr(&out).contains(want), "{all:?}: {}", stderr(&out));
        assert!(!std::path::Path::new(out_path).exists());
    }
}

/// `haptex simulate` of a bump (analytic template) placed where a map
/// line's bump is: the map's line starts 3 mm (the lead-in) after the
/// finger, so a bump at x on the map is at x + 3 in the run, which slides
/// 3 mm + the line's length in `step` mm steps.
fn simulated_bump(dir: &std::path::Path, name: &str, x0: f64, width: f64, slide: f64, step: f64) -> Vec<Vec<f64>> {
    let out = dir.join(name).to_str().unwrap().to_string();
    let (x0, width, slide, step) = (x0.to_string(), width.to_string(), slide.to_string(), step.to_string());
    run_ok(&[
        "simulate",
        "--surface",
        "bump",
        "--x0",
        &x0,
        "--width",
        &width,
        "--height",
        "0.2",
        "--slide",
        &slide,
        "--step",
        &step,
        "-q",
        "-o",
        &out,
    ]);
    columns(&out, &["x_mm", "mu"])
}

/// A height map whose rows are all the paper's bump (r_w 2 mm, r_h 0.2
/// mm at x = 6.5 mm), sampled every 0.05 mm, slid across at 0 degrees:
/// every row's friction is `haptex simulate`'s of the analytic bump at the
/// same place (x + 3 mm, the lead-in; the same 0.05 mm steps), within
/// 1e-3. The difference is the surface's representation (the map's
/// samples joined by a monotone cubic against the exact Gaussian): it
/// halves from 1.3e-3 at 0.1 mm sampling to 5.2e-4 at 0.05 mm (measured
/// 2026-11-25). Identical lines run once.
#[test]
fn rows_of_a_bump_match_the_simulated_template() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let mut csv = String::from("x_mm,y_mm,h_mm\n");
    for j in 0..3 {
        for i in 0..=240 {
            let x = i as f64 * 0.05;
            csv.push_str(&format!("{x:?},{:?},{:?}\n", j as f64 * 0.5, 0.2 * (-((x - 6.5) / 1.0).powi(2)).exp()));
        }
    }
    let h = write(dir.path(), "bump_h.csv", &csv);
    let e = run_ok(&["map", "height", "--height", &h, "-o", &p("bump_mu.csv")]);
    assert!(e.contains("3 lines of 241 points (12 mm) at 0 degrees, 1 distinct: 1 FE runs"), "{e}");
    let [x, _y, mu] = <[Vec<f64>; 3]>::try_from(columns(&p("bump_mu.csv"), &["x_mm", "y_mm", "mu"])).unwrap();
    let sim = simulated_bump(dir.path(), "sim.csv", 9.5, 2.0, 15.0, 0.05);
    let worst = x.iter().zip(&mu).fold(0.0f64, |m, (&x, &mu)| m.max((mu - at(&sim[0], &sim[1], x + 3.0)).abs()));
    let (lo, hi) = mu.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(hi - lo > 0.15, "the bump shows: mu {lo} .. {hi}");
    assert!(worst < 1e-3, "worst {worst}");
}

/// A ridge (the bump's cross-section, r_w 2 mm) laid along the line
/// y = x - 6, slid along +x: each row meets it at 45 degrees, where its
/// section along x is a bump of width 2 sqrt(2) mm centred at x = y + 6.
/// Each row's friction is `haptex simulate`'s of that wider bump (within
/// 1e-3, as above, the sampling at 0.05 mm). Slid along the ridge (45
/// degrees) every line is flat, and the friction is the flat surface's
/// everywhere the lines lie on the map's inside: the direction changes the
/// map from two bumps to none.
#[test]
fn a_ridge_at_45_degrees_is_a_wider_bump_and_nothing_along_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let template = ["--template", "bump:2,0.2", "--path", "0,-6;12,6", "--size-mm", "12,1", "--pixel-mm", "0.05"];
    let (across_out, h_out) = (p("across.csv"), p("h.csv"));
    let across = [&["map", "height"][..], &template, &["-o", &across_out, "--heights-out", &h_out]].concat();
    let e = run_ok(&across);
    assert!(e.contains("21 lines of 241 points"), "{e}");
    let [x, y, mu] = <[Vec<f64>; 3]>::try_from(columns(&p("across.csv"), &["x_mm", "y_mm", "mu"])).unwrap();
    let heights = columns(&p("h.csv"), &["h_mm"]).remove(0);
    let width = 2.0 * 2f64.sqrt();
    for (row_y, name) in [(0.0, "sim0.csv"), (1.0, "sim1.csv")] {
        let sim = simulated_bump(dir.path(), name, row_y + 6.0 + 3.0, width, 15.0, 0.05);
        let mut worst = 0.0f64;
        for k in (0..x.len()).filter(|&k| (y[k] - row_y).abs() < 1e-9) {
            worst = worst.max((mu[k] - at(&sim[0], &sim[1], x[k] + 3.0)).abs());
            let want_h = 0.2 * (-((x[k] - row_y - 6.0) / (width / 2.0)).powi(2)).exp();
            assert!((heights[k] - want_h).abs() < 1e-12, "height at ({}, {row_y})", x[k]);
        }
        assert!(worst < 1e-3, "row y = {row_y}: worst {worst}");
    }

    // Along the ridge, on a smaller map (4 x 1 mm, 0.1 mm cells; the ridge
    // on y = x - 1): 26 lines at 45 degrees.
    let small = ["--template", "bump:2,0.2", "--path", "-1,-2;5,4", "--size-mm", "4,1", "--pixel-mm", "0.1"];
    let along_out = p("along.csv");
    let along = [&["map", "height"][..], &small, &["--direction-deg", "45", "-o", &along_out]].concat();
    run_ok(&along);
    let mu_along = columns(&p("along.csv"), &["mu"]).remove(0);
    let flat = simulated_flat(dir.path());
    let (lo, hi) = mu_along.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    assert!((lo - flat).abs() < 1e-3 && (hi - flat).abs() < 1e-3, "along the ridge: mu {lo} .. {hi}, flat {flat}");
    let (lo, hi) = mu.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(hi - lo > 0.1, "across the ridge: mu {lo} .. {hi}");
}

/// The settled friction of the flat surface (the end of a 10 mm slide).
fn simulated_flat(dir: &std::path::Path) -> f64 {
    let out = dir.join("flat.csv").to_str().unwrap().to_string();
    run_ok(&["simulate", "--surface", "flat", "--slide", "10", "-q", "-o", &out]);
    *columns(&out, &["mu"]).remove(0).last().unwrap()
}

/// Bad input: an unknown template kind, a path that is one point, a
/// template without its grid, a height file with a bad row; each names
/// what is wrong, and nothing is written.
#[test]
fn bad_height_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let grid = ["--size-mm", "4,1", "--pixel-mm", "0.1"];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        ([&["--template", "cone:1,0.1", "--path", "0,0;4,1"][..], &grid].concat(), "unknown kind 'cone'"),
        ([&["--template", "bump:1,0.1", "--path", "0,0"][..], &grid].concat(), "2 to 10000 vertices"),
        ([&["--template", "bump:1,0.1", "--path", "0,0;x,1"][..], &grid].concat(), "--path, vertex 2 'x,1'"),
        ([&["--template", "bump:-1,0.1", "--path", "0,0;4,1"][..], &grid].concat(), "width"),
        (vec!["--template", "bump:1,0.1", "--path", "0,0;4,1"], "--size-mm"),
    ];
    let h = write(dir.path(), "h.csv", "x_mm,y_mm,h_mm\n0,0,0\n1,0,0\n0,1,nan\n1,1,0\n");
    let nan = (vec!["--height", h.as_str()], "line 4");
    assert_refused(&p("out.csv"), cases.into_iter().chain([nan]).collect());
}

/// A height map through a grayscale PNG and back: `map export-png
/// --quantity h_mm` prints the `map height --height H.png` command that
/// reads it, whose heights equal the CSV's within half a gray step (the
/// height range / 65535 / 2 at 16 bit, / 255 / 2 at 8 bit), and whose friction is,
/// bit for bit, the friction of those decoded heights given as a CSV (the
/// PNG is only another way in to the same FE lines).
#[test]
fn a_height_map_round_trips_through_a_png() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let mut csv = String::from("x_mm,y_mm,h_mm\n");
    let mut h0 = Vec::new();
    for j in 0..2 {
        for i in 0..=60 {
            let x = i as f64 * 0.1;
            let h = 0.2 * (-((x - 3.0) / 0.5).powi(2)).exp();
            h0.push(h);
            csv.push_str(&format!("{x:?},{:?},{h:?}\n", 0.25 + j as f64 * 0.5));
        }
    }
    let h = write(dir.path(), "h.csv", &csv);
    for bits in ["16", "8"] {
        let png = p(&format!("h{bits}.png"));
        let e = run_ok(&["map", "export-png", "--map", &h, "--quantity", "h_mm", "--bits", bits, "-o", &png]);
        let command = e.lines().find_map(|l| l.strip_prefix("read back: haptex ")).expect("the read-back command");
        let (mu_png, h_png) = (p(&format!("mu{bits}.csv")), p(&format!("h{bits}_back.csv")));
        let mut args: Vec<&str> = command.split_whitespace().collect();
        assert_eq!(args.pop(), Some("MAP.csv"), "{command}");
        args.extend([mu_png.as_str(), "--heights-out", &h_png, "-q"]);
        assert!(command.contains("--origin-mm 0,0.25"), "{command}");
        run_ok(&args);
        let back = columns(&h_png, &["x_mm", "y_mm", "h_mm"]);
        // Black is the lowest height, white the highest (export-png's default).
        let top = h0.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let bottom = h0.iter().cloned().fold(f64::INFINITY, f64::min);
        let step = (top - bottom) / if bits == "16" { 65535.0 } else { 255.0 };
        let worst = back[2].iter().zip(&h0).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(worst <= step / 2.0 + 1e-12, "{bits} bit: worst {worst}, half step {}", step / 2.0);
        assert_eq!(back[0][..61], (0..=60).map(|i| i as f64 * 0.1).collect::<Vec<_>>()[..], "x positions");
        assert_eq!(back[1][61], 0.75, "the second row's y");
        // The same FE lines as the decoded heights given as a CSV.
        let mu_csv = p(&format!("mu{bits}_from_csv.csv"));
        run_ok(&["map", "height", "--height", &h_png, "-q", "-o", &mu_csv]);
        assert_eq!(columns(&mu_png, &["mu"]), columns(&mu_csv, &["mu"]), "{bits} bit");
    }
}

/// A PNG height map needs its gray-to-height mapping and its pixel size;
/// a CSV's grid is its own. Each refusal names the flag, nothing written.
#[test]
fn png_height_input_is_checked() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let h = write(dir.path(), "h.csv", "x_mm,y_mm,h_mm\n0,0,0\n1,0,0.1\n0,1,0\n1,1,0.1\n");
    let png = p("h.png");
    run_ok(&["map", "export-png", "--map", &h, "--quantity", "h_mm", "-o", &png]);
    let junk = write(dir.path(), "junk.png", "not an image");
    let map = ["--h-black-mm", "0", "--h-white-mm", "0.1"];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--height", &png, "--pixel-mm", "0.1"], "--h-black-mm and --h-white-mm"),
        ([&["--height", &png][..], &map].concat(), "needs --pixel-mm"),
        (vec!["--height", &png, "--h-black-mm", "0.1", "--h-white-mm", "0.1", "--pixel-mm", "1"], "h_white_mm"),
        (vec!["--height", &png, "--h-black-mm", "0", "--h-white-mm", "2000", "--pixel-mm", "1"], "h_white_mm"),
        ([&["--height", &junk, "--pixel-mm", "1"][..], &map].concat(), "not a readable PNG"),
        (vec!["--height", &h, "--pixel-mm", "0.1"], "--pixel-mm is for a PNG or a template"),
        (vec!["--height", &h, "--origin-mm", "1,1"], "--origin-mm is for a PNG or a template"),
    ];
    assert_refused(&p("out.csv"), cases);
}

/// `--model 3d` (issue 39): the 3D fingertip over the whole height map,
/// runs every --line-spacing-mm across the direction and the rows between
/// interpolated. A ridge along y met across (0 degrees) is the same for
/// every row, so every row of the map is the same to rounding, and each is
/// what `haptex simulate --model 3d` gives over the analytic bump placed
/// where the row's ridge is (an independent surface: the template, not
/// the map's spline; measured within 3.1e-5 in Ft/Fn, tolerance 1e-3).
/// 3D-only flags are refused in 2D.
#[test]
fn a_ridge_mapped_by_the_3d_finger_is_the_simulated_bump() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let ridge = ["--template", "bump:1.5,0.2", "--path", "0,-20;0,20", "--size-mm", "8,2", "--origin-mm", "-4,-1"];
    let m3 = p("m3.csv");
    let mut three = vec!["map", "height", "--pixel-mm", "0.1", "--direction-deg", "0", "-q"];
    three.extend(ridge);
    // Runs on the first and the last row, the 19 between interpolated.
    three.extend(["--model", "3d", "--mesh", "coarse", "--line-spacing-mm", "2", "-o", &m3]);
    run_ok(&three);
    let [x, mu3] = <[Vec<f64>; 2]>::try_from(columns(&m3, &["x_mm", "mu"])).unwrap();
    assert_eq!(mu3.len(), 81 * 21);
    // Row by row the same (rows at y = -1 .. 1, 81 points each).
    for row in mu3.chunks_exact(81).skip(1) {
        for (a, b) in row.iter().zip(&mu3[..81]) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
    }
    // The row's finger starts 3 mm (the lead-in) before x = -4: the ridge
    // at x = 0 is 7 mm from its start, the row's end 11 mm.
    let profile = p("bump.csv");
    run_ok(&[
        "simulate",
        "--model",
        "3d",
        "--mesh",
        "coarse",
        "--surface",
        "bump",
        "--x0",
        "7",
        "--width",
        "1.5",
        "--height",
        "0.2",
        "--slide",
        "11",
        "--step",
        "0.1",
        "-q",
        "-o",
        &profile,
    ]);
    let [px, pmu] = <[Vec<f64>; 2]>::try_from(columns(&profile, &["x_mm", "mu"])).unwrap();
    let mut worst = 0.0f64;
    for (xi, m) in x[..81].iter().zip(&mu3[..81]) {
        worst = worst.max((at(&px, &pmu, xi + 7.0) - m).abs());
    }
    let range =
        mu3.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - mu3.iter().cloned().fold(f64::INFINITY, f64::min);
    eprintln!("Ft/Fn range {range:.4}; largest difference from the simulated bump {worst:.2e}");
    assert!(range > 0.05, "the ridge is not felt: {range}");
    assert!(worst < 1e-3, "{worst}");

    let out = p("refused.csv");
    assert_refused(
        &out,
        vec![
            ([&["--pixel-mm", "0.1"][..], &ridge, &["--mesh", "coarse"]].concat(), "--mesh is for --model 3d"),
            ([&["--pixel-mm", "0.1"][..], &ridge, &["--line-spacing-mm", "1"]].concat(), "--line-spacing-mm is for"),
            ([&["--pixel-mm", "0.1"][..], &ridge, &["--model", "3d", "--line-spacing-mm", "0"]].concat(), "0"),
        ],
    );
}
