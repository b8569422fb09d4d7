//! `haptex map` end to end: a map from a profile and from an image, its
//! voltages, a path sampled over them against the 1-D design, and the
//! errors of mismatched or bad files.

use haptex_core::io::Table;
use haptex_core::profile::interpolate;

mod common;
use common::{haptex, stderr, write};

const EXAMPLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/examples/bump_friction.csv");

fn column(path: &std::path::Path, name: &str) -> Vec<f64> {
    let t = Table::read(std::fs::read(path).unwrap().as_slice(), "t").unwrap();
    t.column(name).unwrap().to_vec()
}

fn run_ok(args: &[&str]) -> String {
    let out = haptex(args);
    assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    stderr(&out)
}

/// The acceptance case through the CLI: the example bump extruded along y
/// (on its own 0.01 mm grid), mapped by eq. (8) to an NPY voltage map,
/// sampled along y = const: the `haptex voltage` design of the profile,
/// linearly interpolated, at every sample (1e-12).
#[test]
fn path_along_y_reproduces_the_profile_voltage() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    run_ok(&["voltage", "--profile", EXAMPLE, "-q", "-o", &p("u1.csv")]);
    run_ok(&[
        "map",
        "from-profile",
        "--profile",
        EXAMPLE,
        "--dx-mm",
        "0.01",
        "--dy-mm",
        "0.25",
        "--ny",
        "6",
        "-o",
        &p("m.npy"),
    ]);
    let e = run_ok(&["map", "voltage", "--map", &p("m.npy"), "-o", &p("v.npy")]);
    assert!(e.contains("area below mu_HD"), "{e}");
    let x1 = column(std::path::Path::new(&p("u1.csv")), "x_mm");
    let u1 = column(std::path::Path::new(&p("u1.csv")), "voltage_v");
    for y in ["0", "0.5", "0.6"] {
        let mut csv = String::from("t_s,x_mm,y_mm\n");
        for k in 0..=900 {
            csv += &format!("{},{},{y}\n", k as f64 * 1e-3, -0.5 + k as f64 * 0.01237);
        }
        let path = write(dir.path(), "path.csv", &csv);
        run_ok(&["map", "sample-path", "--voltage-map", &p("v.npy"), "--trajectory", &path, "-o", &p("u.csv")]);
        let out = std::path::Path::new(&p("u.csv")).to_path_buf();
        let (xs, us) = (column(&out, "x_mm"), column(&out, "voltage_v"));
        assert_eq!(xs.len(), 901);
        for (x, u) in xs.iter().zip(&us) {
            let want = interpolate(&x1, &u1, *x);
            assert!((u - want).abs() <= 1e-12 * want.max(1.0), "y {y}, x {x}: {u} vs {want}");
        }
    }
}

/// A 16-bit image to a CSV map: 3 x 2 pixels with known gray levels give
/// their mapped friction at the right (x, y), the top row at y = dy.
#[test]
fn image_pixels_land_on_their_cells() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("i.png");
    {
        let file = std::fs::File::create(&img).unwrap();
        let mut enc = png::Encoder::new(file, 3, 2);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Sixteen);
        let mut w = enc.write_header().unwrap();
        let levels: [u16; 6] = [0, 65535, 32768, 100, 200, 300];
        let data: Vec<u8> = levels.iter().flat_map(|v| v.to_be_bytes()).collect();
        w.write_image_data(&data).unwrap();
    }
    let out = dir.path().join("m.csv");
    run_ok(&[
        "map",
        "from-image",
        img.to_str().unwrap(),
        "--mu-black",
        "0.5",
        "--mu-white",
        "1.5",
        "--pixel-mm",
        "0.2",
        "--pixel-mm-y",
        "0.4",
        "--x0-mm",
        "-1",
        "-o",
        out.to_str().unwrap(),
    ]);
    let (x, y, mu) = (column(&out, "x_mm"), column(&out, "y_mm"), column(&out, "mu"));
    // Row-major from y = 0 (the image's bottom row: 100, 200, 300).
    let want_mu = [100.0, 200.0, 300.0, 0.0, 65535.0, 32768.0].map(|g: f64| 0.5 + g / 65535.0);
    for k in 0..6 {
        assert!((x[k] - (-1.0 + 0.2 * (k % 3) as f64)).abs() < 1e-12);
        assert!((y[k] - 0.4 * (k / 3) as f64).abs() < 1e-12);
        assert!((mu[k] - want_mu[k]).abs() < 1e-12, "{k}: {} vs {}", mu[k], want_mu[k]);
    }
}

/// Issue 35, "Bounded cost per request": an image's memory is checked on
/// its header against `--memory-budget-mib` before anything is decoded.
/// The case: a 16-bit PNG of 8192 x 8192 black pixels (a file of
/// a few hundred KB) took 1.06 GB and 7.8 s; it is refused at the default
/// budget (512 MiB) naming the file, its size and the flag, and nothing is
/// written. The budget is what decides: a 600 x 600 image passes the
/// default and is refused under `--memory-budget-mib 1`.
#[test]
fn an_image_over_the_memory_budget_is_refused_before_decoding() {
    let dir = tempfile::tempdir().unwrap();
    let gray = |path: &std::path::Path, side: u32, depth: png::BitDepth| {
        let mut enc = png::Encoder::new(std::fs::File::create(path).unwrap(), side, side);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(depth);
        let mut w = enc.write_header().unwrap().into_stream_writer().unwrap();
        let row = vec![0u8; side as usize * if depth == png::BitDepth::Sixteen { 2 } else { 1 }];
        for _ in 0..side {
            std::io::Write::write_all(&mut w, &row).unwrap();
        }
        w.finish().unwrap();
    };
    let big = dir.path().join("big.png");
    gray(&big, 8192, png::BitDepth::Sixteen);
    let small = dir.path().join("small.png");
    gray(&small, 600, png::BitDepth::Eight);
    let out = dir.path().join("m.npy");
    let from_image = |image: &std::path::Path, budget: Option<&str>| {
        let mut args = vec!["map", "from-image", image.to_str().unwrap(), "--mu-black", "0.4", "--mu-white", "1.2"];
        args.extend(["--pixel-mm", "0.1", "-o", out.to_str().unwrap()]);
        if let Some(b) = budget {
            args.extend(["--memory-budget-mib", b]);
        }
        haptex(&args)
    };
    let refused = from_image(&big, None);
    let e = stderr(&refused);
    assert!(!refused.status.success(), "{e}");
    assert!(e.contains("big.png") && e.contains("8192 x 8192") && e.contains("--memory-budget-mib 512"), "{e}");
    assert!(!out.exists());
    let e = stderr(&from_image(&small, Some("1")));
    assert!(e.contains("small.png") && e.contains("600 x 600") && e.contains("--memory-budget-mib 1"), "{e}");
    assert!(!out.exists());
    let ok = from_image(&small, None);
    assert!(ok.status.success(), "{}", stderr(&ok));
    assert!(out.exists());
}

/// An NPY map without its sidecar, with another run's sidecar, a wrong
/// extension, a bad path line: each refused with the file and the reason.
#[test]
fn mismatched_and_bad_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    run_ok(&[
        "map",
        "from-profile",
        "--profile",
        EXAMPLE,
        "--dx-mm",
        "0.1",
        "--dy-mm",
        "1",
        "--ny",
        "3",
        "-o",
        &p("a.npy"),
    ]);
    run_ok(&[
        "map",
        "from-profile",
        "--profile",
        EXAMPLE,
        "--dx-mm",
        "0.1",
        "--dy-mm",
        "1",
        "--ny",
        "4",
        "-o",
        &p("b.npy"),
    ]);
    // b's sidecar next to a's data.
    std::fs::copy(p("b.npy.json"), p("a.npy.json")).unwrap();
    let out = haptex(&["map", "voltage", "--map", &p("a.npy"), "-o", &p("v.csv")]);
    assert!(!out.status.success());
    let e = stderr(&out);
    assert!(e.contains("a.npy.json") && e.contains("npy_sha256") && e.contains("different runs"), "{e}");
    std::fs::remove_file(p("a.npy.json")).unwrap();
    let e = stderr(&haptex(&["map", "voltage", "--map", &p("a.npy"), "-o", &p("v.csv")]));
    assert!(e.contains("a.npy.json") && e.contains("needs its JSON sidecar"), "{e}");
    // A friction map is not a voltage map.
    let e = stderr(&haptex(&["map", "sample-path", "--voltage-map", &p("b.npy"), "--trajectory", EXAMPLE]));
    assert!(e.contains("quantity") && e.contains("holds 'mu', expected 'voltage_v'"), "{e}");
    let e = stderr(&haptex(&["map", "voltage", "--map", &p("b.npy"), "-o", &p("v.txt")]));
    assert!(e.contains("v.txt") && e.contains(".csv or .npy"), "{e}");
    run_ok(&["map", "voltage", "--map", &p("b.npy"), "-o", &p("v.csv")]);
    let path = write(dir.path(), "t.csv", "t_s,x_mm,y_mm\n0,0,0\n0.1,1,1\n0.1,2,2\n");
    let e = stderr(&haptex(&["map", "sample-path", "--voltage-map", &p("v.csv"), "--trajectory", &path]));
    assert!(
        e.contains("t.csv") && e.contains("line 4") && e.contains("t_s") && e.contains("strictly increasing"),
        "{e}"
    );
    let img = write(dir.path(), "x.png", "not an image");
    let e = stderr(&haptex(&[
        "map",
        "from-image",
        &img,
        "--mu-black",
        "0",
        "--mu-white",
        "1",
        "--pixel-mm",
        "0.1",
        "-o",
        &p("m.csv"),
    ]));
    assert!(e.contains("x.png") && e.contains("not a readable PNG"), "{e}");
    assert!(!dir.path().join("m.csv").exists());
}

/// `haptex map grating`: ridges along the sliding direction are flat
/// friction; across it, the CAE line's periodic part stays within the
/// prediction's range; a line period outside the database is refused for
/// the CAE with the way out (the FE).
#[test]
fn grating_maps_by_direction() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let grating = |angle: &str, source: &str, out: &str| {
        haptex(&[
            "map",
            "grating",
            "--period-mm",
            "1.5",
            "--amplitude-mm",
            "0.2",
            "--angle-deg",
            angle,
            "--nx",
            "101",
            "--ny",
            "11",
            "--dx-mm",
            "0.1",
            "--dy-mm",
            "0.1",
            "--source",
            source,
            "-o",
            out,
        ])
    };
    let out = grating("90", "cae", &p("g90.csv"));
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(column(std::path::Path::new(&p("g90.csv")), "mu").iter().all(|&m| m == 0.5));
    let out = grating("0", "cae", &p("g0.csv"));
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("period 1.5000 mm"), "{}", stderr(&out));
    let run = haptex(&["predict", "--surface", "sine", "--x0", "0", "--width", "1.5", "--height", "0.2", "-q"]);
    let t = Table::read(run.stdout.as_slice(), "predict").unwrap();
    let (px, pm) = (t.column("x_mm").unwrap(), t.column("mu").unwrap());
    let steady: Vec<f64> = px.iter().zip(pm).filter(|(x, _)| **x > px[0] + 1.0).map(|(_, m)| *m).collect();
    let (lo, hi) = steady.iter().fold((f64::MAX, f64::MIN), |(a, b), &m| (a.min(m), b.max(m)));
    let mu = column(std::path::Path::new(&p("g0.csv")), "mu");
    let (mlo, mhi) = mu.iter().fold((f64::MAX, f64::MIN), |(a, b), &m| (a.min(m), b.max(m)));
    // The periodic part of a profile lies within its range (a fit may
    // overshoot a sharp corner a little: 0.01) and keeps most of its
    // modulation (the line is the periodic part, not a flat average).
    assert!(mlo > lo - 0.01 && mhi < hi + 0.01 && mhi - mlo > 0.5 * (hi - lo), "{mlo}..{mhi} vs {lo}..{hi}");
    let out = grating("60", "cae", &p("g60.csv"));
    assert!(!out.status.success());
    assert!(stderr(&out).contains("period 3.0000 mm") && stderr(&out).contains("--source fe"), "{}", stderr(&out));
}

/// `haptex play --voltage-map` along y = const over a map extruded from a
/// profile gives the envelope of `haptex play --profile` with the same x(t)
/// (1e-9 V: the two interpolate in different but equivalent arithmetic),
/// and the drive goes through the same limits (U_max clamp reported).
#[test]
fn play_over_a_map_along_a_row_is_the_profile_playback() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    run_ok(&["voltage", "--profile", EXAMPLE, "-q", "-o", &p("u1.csv")]);
    run_ok(&[
        "map",
        "from-profile",
        "--profile",
        EXAMPLE,
        "--dx-mm",
        "0.01",
        "--dy-mm",
        "0.5",
        "--ny",
        "3",
        "-o",
        &p("m.csv"),
    ]);
    run_ok(&["map", "voltage", "--map", &p("m.csv"), "-o", &p("v.npy")]);
    let (mut t1, mut t2) = (String::from("t_s,x_mm\n"), String::from("t_s,x_mm,y_mm\n"));
    for k in 0..=400 {
        let (t, x) = (k as f64 * 1e-3, 1.0 + 8.0 * (k as f64 / 400.0).powi(2));
        t1 += &format!("{t},{x}\n");
        t2 += &format!("{t},{x},0.5\n");
    }
    let (tr1, tr2) = (write(dir.path(), "t1.csv", &t1), write(dir.path(), "t2.csv", &t2));
    run_ok(&["play", "--profile", &p("u1.csv"), "--trajectory", &tr1, "--u-max", "90", "-o", &p("s1.csv")]);
    let e = run_ok(&["play", "--voltage-map", &p("v.npy"), "--trajectory", &tr2, "--u-max", "90", "-o", &p("s2.csv")]);
    assert!(e.contains("clamped at U_max = 90"), "{e}");
    let (a, b) = (std::path::Path::new(&p("s1.csv")).to_path_buf(), std::path::Path::new(&p("s2.csv")).to_path_buf());
    let names = Table::read(std::fs::read(&a).unwrap().as_slice(), "s").unwrap().columns().to_vec();
    let envelope = names.iter().find(|n| n.starts_with("envelope")).unwrap().clone();
    let (e1, e2) = (column(&a, &envelope), column(&b, &envelope));
    assert_eq!(e1.len(), e2.len());
    assert!(e1.iter().zip(&e2).all(|(x, y)| (x - y).abs() < 1e-9 && *y <= 90.0));
    // A 1-D trajectory is not a planar path.
    let out = haptex(&["play", "--voltage-map", &p("v.npy"), "--trajectory", &tr1, "-o", &p("s3.csv")]);
    assert!(!out.status.success() && stderr(&out).contains("y_mm"), "{}", stderr(&out));
    // A map holds its edges: a profile's --outside is refused, not ignored.
    let out =
        haptex(&["play", "--voltage-map", &p("v.npy"), "--trajectory", &tr2, "--outside", "zero", "-o", &p("s4.csv")]);
    assert!(!out.status.success() && stderr(&out).contains("--outside zero) is for a profile"), "{}", stderr(&out));
    assert!(!std::path::Path::new(&p("s4.csv")).exists());
    // A combined display's map (voltage_v beside amplitude_um): its voltages
    // assume the plate's amplitudes, so a one-channel drive over it is
    // refused, naming the column, as a combined profile is (issue 16).
    run_ok(&[
        "map",
        "voltage",
        "--map",
        &p("m.csv"),
        "--display",
        "combined",
        "--strategy",
        "split",
        "-o",
        &p("vc.csv"),
    ]);
    for command in ["play", "map"] {
        let out = if command == "play" {
            haptex(&["play", "--voltage-map", &p("vc.csv"), "--trajectory", &tr2, "-o", &p("s5.wav")])
        } else {
            haptex(&["map", "sample-path", "--voltage-map", &p("vc.csv"), "--trajectory", &tr2, "-o", &p("s5.wav")])
        };
        let e = stderr(&out);
        assert!(!out.status.success() && e.contains("amplitude_um") && e.contains("combined"), "{command}: {e}");
        assert!(!std::path::Path::new(&p("s5.wav")).exists());
    }
}

/// `haptex map compose`: a 4 x 3 label image with three gray levels, a
/// constant, a profile tiled along x and a library material (the stroke
/// `haptex library sample --seed 7` picks, tiled): each cell holds its
/// region's value at its x; a level without a region, a level given twice
/// and a colour image are refused.
#[test]
fn compose_fills_each_region() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let png_of = |name: &str, w: u32, h: u32, color: png::ColorType, data: &[u8]| {
        let file = std::fs::File::create(dir.path().join(name)).unwrap();
        let mut enc = png::Encoder::new(file, w, h);
        enc.set_color(color);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header().unwrap().write_image_data(data).unwrap();
        p(name)
    };
    // Top row first: the top row is y = 2 dy.
    let labels = png_of("l.png", 4, 3, png::ColorType::Grayscale, &[0, 0, 128, 128, 255, 255, 0, 0, 128, 255, 0, 128]);
    let out = haptex(&[
        "map",
        "compose",
        &labels,
        "--region",
        "0=0.45",
        "--region",
        &format!("128=profile:{EXAMPLE}"),
        "--region",
        "255=material:linen",
        "--seed",
        "7",
        "--pixel-mm",
        "3.5",
        "-o",
        &p("c.csv"),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("gray level 255: material linen"), "{}", stderr(&out));
    let sample = haptex(&["library", "sample", "--material", "linen", "--seed", "7"]);
    assert!(sample.status.success(), "{}", stderr(&sample));
    let st = Table::read(sample.stdout.as_slice(), "linen").unwrap();
    let (lx, lm) = (st.column("x_mm").unwrap().to_vec(), st.column("mu").unwrap().to_vec());
    let ex = Table::read(std::fs::read(EXAMPLE).unwrap().as_slice(), "ex").unwrap();
    let (px, pm) = (ex.column("x_mm").unwrap().to_vec(), ex.column("mu").unwrap().to_vec());
    let tiled = |xs: &[f64], ms: &[f64], x: f64| {
        let (x0, span) = (xs[0], xs[xs.len() - 1] - xs[0]);
        interpolate(xs, ms, x0 + (x - x0).rem_euclid(span))
    };
    let path = std::path::Path::new(&p("c.csv")).to_path_buf();
    let (x, mu) = (column(&path, "x_mm"), column(&path, "mu"));
    let image = [0u8, 0, 128, 128, 255, 255, 0, 0, 128, 255, 0, 128];
    for k in 0..12 {
        let (i, j) = (k % 4, k / 4);
        let label = image[(2 - j) * 4 + i];
        let want = match label {
            0 => 0.45,
            128 => tiled(&px, &pm, x[k]),
            _ => tiled(&lx, &lm, x[k]),
        };
        assert!((mu[k] - want).abs() < 1e-12, "cell {k} (label {label}, x {}): {} vs {want}", x[k], mu[k]);
    }
    let missing = haptex(&[
        "map",
        "compose",
        &labels,
        "--region",
        "0=0.45",
        "--region",
        "128=0.6",
        "--pixel-mm",
        "1",
        "-o",
        &p("d.csv"),
    ]);
    let e = stderr(&missing);
    assert!(
        !missing.status.success() && e.contains("gray level 255 has no region") && e.contains("column 0, row 1"),
        "{e}"
    );
    let twice = haptex(&[
        "map",
        "compose",
        &labels,
        "--region",
        "0=0.45",
        "--region",
        "0=0.6",
        "--pixel-mm",
        "1",
        "-o",
        &p("d.csv"),
    ]);
    assert!(stderr(&twice).contains("given twice"), "{}", stderr(&twice));
    let rgb = png_of("rgb.png", 2, 2, png::ColorType::Rgb, &[0; 12]);
    let e = stderr(&haptex(&["map", "compose", &rgb, "--region", "0=0.5", "--pixel-mm", "1", "-o", &p("d.csv")]));
    assert!(e.contains("rgb.png") && e.contains("8-bit grayscale"), "{e}");
    assert!(!dir.path().join("d.csv").exists());
}

/// `haptex map voltage --display combined` on a map whose rows are the
/// example profile on its own grid: every row is `haptex voltage --display
/// combined` of the profile, both channels (the same allocator and bias
/// level); the ultrasonic display alone writes amplitudes only.
#[test]
fn combined_display_map_rows_are_the_profile_design() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    run_ok(&["voltage", "--profile", EXAMPLE, "-q", "--display", "combined", "--strategy", "bias", "-o", &p("d1.csv")]);
    run_ok(&[
        "map",
        "from-profile",
        "--profile",
        EXAMPLE,
        "--dx-mm",
        "0.01",
        "--dy-mm",
        "1",
        "--ny",
        "3",
        "-o",
        &p("m.csv"),
    ]);
    let e = run_ok(&[
        "map",
        "voltage",
        "--map",
        &p("m.csv"),
        "--display",
        "combined",
        "--strategy",
        "bias",
        "-o",
        &p("d2.csv"),
    ]);
    assert!(e.contains("band mu"), "{e}");
    let (a, b) = (std::path::Path::new(&p("d1.csv")).to_path_buf(), std::path::Path::new(&p("d2.csv")).to_path_buf());
    let (u1, a1) = (column(&a, "voltage_v"), column(&a, "amplitude_um"));
    let (u2, a2) = (column(&b, "voltage_v"), column(&b, "amplitude_um"));
    assert_eq!(u2.len(), 3 * u1.len());
    // The profile's design takes Fe/Fn per V^2 at the profile's own Fn,
    // the map's at 1 N: with the linear area law the same value up to
    // rounding, so the channels agree to 1e-12 relative.
    let n = u1.len();
    for k in 0..3 * n {
        let (ua, ub, aa, ab) = (u2[k], u1[k % n], a2[k], a1[k % n]);
        assert!((ua - ub).abs() <= 1e-12 * ub.max(1.0), "cell {k}: U {ua} vs {ub}");
        assert!((aa - ab).abs() <= 1e-12 * ab.max(1.0), "cell {k}: a {aa} vs {ab}");
    }
    run_ok(&["map", "voltage", "--map", &p("m.csv"), "--display", "ultrasonic", "-o", &p("d3.csv")]);
    let t = Table::read(std::fs::read(p("d3.csv")).unwrap().as_slice(), "d3").unwrap();
    assert!(t.column("voltage_v").is_none() && t.column("amplitude_um").is_some());
    let e = stderr(&haptex(&["map", "voltage", "--map", &p("m.csv"), "--display", "combined", "-o", &p("d4.npy")]));
    assert!(e.contains("written as CSV"), "{e}");
    let e = stderr(&haptex(&["map", "voltage", "--map", &p("m.csv"), "--strategy", "bias", "-o", &p("d4.csv")]));
    assert!(e.contains("--strategy"), "{e}");
}

/// Polygons over a base: a rectangle fills exactly the cells with x in
/// [2, 6) and y in [1, 3) (even-odd at the cell positions), a triangle
/// drawn after it over part of it; bad vertices are refused by position.
#[test]
fn polygons_fill_their_cells_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.csv");
    let e = run_ok(&[
        "map",
        "compose",
        "--base",
        "0.5",
        "--size-mm",
        "10,5",
        "--pixel-mm",
        "0.5",
        "--polygon",
        "2,1;6,1;6,3;2,3=0.9",
        "--polygon",
        "5,0;9,0;9,4=1.2",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(e.contains("32 cells"), "{e}");
    let (x, y, mu) = (column(&out, "x_mm"), column(&out, "y_mm"), column(&out, "mu"));
    assert_eq!(mu.len(), 21 * 11);
    for k in 0..mu.len() {
        let (xk, yk) = (x[k], y[k]);
        // The triangle (5,0)-(9,0)-(9,4): on a row y in [0, 4) the span
        // from its slanted edge x = 5 + y (included) to x = 9 (excluded).
        let in_triangle = (0.0..4.0).contains(&yk) && xk >= 5.0 + yk && xk < 9.0;
        let in_rectangle = (2.0..6.0).contains(&xk) && (1.0..3.0).contains(&yk);
        let want = if in_triangle {
            1.2
        } else if in_rectangle {
            0.9
        } else {
            0.5
        };
        assert_eq!(mu[k], want, "({xk}, {yk})");
    }
    for (polygon, want) in
        [("1,1;2,2=0.7", "3 to 10000"), ("1,1;2,x;3,3=0.7", "vertex 2 '2,x'"), ("1,1;2,2;3,3", "X,Y;X,Y;X,Y=FILL")]
    {
        let bad = haptex(&[
            "map",
            "compose",
            "--base",
            "0.5",
            "--size-mm",
            "10,5",
            "--pixel-mm",
            "0.5",
            "--polygon",
            polygon,
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(!bad.status.success() && stderr(&bad).contains(want), "{polygon}: {}", stderr(&bad));
    }
}

/// `haptex map export-png` then the `from-image` command it prints: the
/// map back within half a 16-bit gray step, on the same grid.
#[test]
fn exported_png_reads_back_with_the_printed_command() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    run_ok(&[
        "map",
        "from-profile",
        "--profile",
        EXAMPLE,
        "--dx-mm",
        "0.05",
        "--dy-mm",
        "0.2",
        "--ny",
        "4",
        "-o",
        &p("m.csv"),
    ]);
    let e = run_ok(&["map", "export-png", "--map", &p("m.csv"), "-o", &p("m.png")]);
    let command = e.lines().find_map(|l| l.strip_prefix("read back: haptex ")).expect("the read-back command");
    let mut args: Vec<String> = command.split_whitespace().map(str::to_string).collect();
    let last = args.len() - 1;
    args[last] = p("back.csv");
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    run_ok(&refs);
    let (a, b) = (std::path::Path::new(&p("m.csv")).to_path_buf(), std::path::Path::new(&p("back.csv")).to_path_buf());
    let (ma, mb) = (column(&a, "mu"), column(&b, "mu"));
    let (xa, xb, ya, yb) = (column(&a, "x_mm"), column(&b, "x_mm"), column(&a, "y_mm"), column(&b, "y_mm"));
    let (lo, hi) = ma.iter().fold((f64::MAX, f64::MIN), |(l, h), &m| (l.min(m), h.max(m)));
    let half_step = 0.5 * (hi - lo) / 65535.0;
    assert_eq!(ma.len(), mb.len());
    for k in 0..ma.len() {
        assert!((ma[k] - mb[k]).abs() <= half_step * (1.0 + 1e-9), "cell {k}: {} vs {}", ma[k], mb[k]);
        assert!((xa[k] - xb[k]).abs() < 1e-9 && (ya[k] - yb[k]).abs() < 1e-9);
    }
}
