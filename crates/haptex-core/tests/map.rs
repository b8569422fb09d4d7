//! Friction maps (haptex_core::map): the CSV, NPY and PNG round trips,
//! the errors of bad files, eq. (8) per cell, and a path along a row of a
//! map built from a 1-D profile giving the 1-D voltage.

use haptex_core::map::{FrictionMap, GrayMapping, MapGrid, read_grid_json};
use haptex_core::profile::{FrictionProfile, interpolate};
use haptex_core::{Device, Method, map_profile};

fn grid(nx: usize, ny: usize) -> MapGrid {
    MapGrid { nx, ny, x0_mm: -1.0, y0_mm: 2.0, dx_mm: 0.05, dy_mm: 0.1 }
}

/// A smooth test map: a bump in x times a ramp in y, mu 0.9 .. 1.3.
fn test_map(nx: usize, ny: usize) -> FrictionMap {
    let g = grid(nx, ny);
    let mu = (0..ny)
        .flat_map(|j| {
            (0..nx).map(move |i| {
                let (x, y) = (g.x(i), g.y(j));
                0.9 + 0.3 * (-(x - 0.5) * (x - 0.5) / 0.2).exp() * (y - 1.5) / (g.y(ny - 1) - 1.5) + 0.1 * (y - 2.0)
            })
        })
        .collect();
    FrictionMap::new(g, mu, "test").unwrap()
}

#[test]
fn csv_round_trip_is_exact() {
    let m = test_map(37, 11);
    let mut bytes = Vec::new();
    m.write_csv(&mut bytes).unwrap();
    let back = FrictionMap::read_csv(bytes.as_slice(), "m.csv").unwrap();
    assert_eq!(back.grid.nx, 37);
    assert_eq!(back.grid.ny, 11);
    assert_eq!(back.mu, m.mu);
    for (a, b) in [(back.grid.dx_mm, 0.05), (back.grid.dy_mm, 0.1), (back.grid.x0_mm, -1.0), (back.grid.y0_mm, 2.0)] {
        assert!((a - b).abs() < 1e-12, "{a} {b}");
    }
}

#[test]
fn npy_round_trip_is_exact_and_needs_its_grid() {
    let m = test_map(20, 7);
    let mut bytes = Vec::new();
    m.write_npy(&mut bytes).unwrap();
    let g = read_grid_json(serde_json::to_vec(&m.grid).unwrap().as_slice(), "m.json").unwrap();
    let back = FrictionMap::read_npy(&bytes, g, "m.npy").unwrap();
    assert_eq!(back, m);
    let wrong = MapGrid { nx: 7, ny: 20, ..m.grid };
    let e = FrictionMap::read_npy(&bytes, wrong, "m.npy").unwrap_err().to_string();
    assert!(e.contains("m.npy") && e.contains("array shape [7, 20]") && e.contains("(20, 7)"), "{e}");
    let e = FrictionMap::read_npy(b"not numpy", m.grid, "m.npy").unwrap_err().to_string();
    assert!(e.contains("not a valid NPY file"), "{e}");
    let e =
        read_grid_json(br#"{"nx": 2, "ny": 2, "x0_mm": 0, "y0_mm": 0, "dx_mm": -1, "dy_mm": 1}"#.as_slice(), "g.json")
            .unwrap_err()
            .to_string();
    assert!(e.contains("g.json, dx_mm") && e.contains("positive"), "{e}");
}

/// 8 and 16 bit: each value back within half a gray step of the mapping
/// (gamma 1: (mu_white - mu_black) / (2 (2^bits - 1))); gamma 2.2 within
/// the step's width at that level.
#[test]
fn png_round_trip_within_quantization() {
    let m = test_map(64, 48);
    for (bits, gamma) in [(8u8, 1.0), (16, 1.0), (8, 2.2), (16, 2.2)] {
        let mapping = GrayMapping { mu_black: 0.5, mu_white: 2.0, gamma };
        let mut bytes = Vec::new();
        m.write_gray_png(&mut bytes, &mapping, bits).unwrap();
        let back = FrictionMap::read_gray_png(&bytes, &mapping, (0.05, 0.1), (-1.0, 2.0), "m.png").unwrap();
        assert_eq!((back.grid.nx, back.grid.ny), (64, 48));
        let levels = if bits == 8 { 255.0 } else { 65535.0 };
        for (a, b) in back.mu.iter().zip(&m.mu) {
            let g = mapping.gray(*b);
            let step = (mapping.mu((g + 0.5 / levels).min(1.0)) - mapping.mu((g - 0.5 / levels).max(0.0))).abs();
            assert!((a - b).abs() <= step + 1e-12, "{bits} bit gamma {gamma}: {a} vs {b} (step {step})");
        }
        // The top image row is the largest y: the last row of the map.
        let top = &back.mu[47 * 64..];
        let gray_top = mapping.gray(m.mu[47 * 64 + 10]);
        assert!((mapping.gray(top[10]) - gray_top).abs() <= 0.5 / levels + 1e-12);
    }
}

/// Gray levels in memory (as a caller that decoded the image itself holds
/// them, top row first) give the PNG's map, bit for bit.
#[test]
fn gray_levels_in_memory_are_the_pngs_map() {
    use haptex_core::map::GrayLevels;
    let m = test_map(13, 7);
    for (bits, gamma) in [(8u8, 1.0), (16, 1.0), (8, 2.2), (16, 0.4)] {
        let mapping = GrayMapping { mu_black: 0.5, mu_white: 2.0, gamma };
        let mut bytes = Vec::new();
        m.write_gray_png(&mut bytes, &mapping, bits).unwrap();
        let from_png = FrictionMap::read_gray_png(&bytes, &mapping, (0.05, 0.1), (-1.0, 2.0), "m.png").unwrap();
        // The levels the PNG holds, from its top row (the map's last).
        let level = |j: usize, i: usize| {
            let full = if bits == 8 { 255.0 } else { 65535.0 };
            (mapping.gray(m.mu[j * 13 + i]) * full).round() as u16
        };
        let top_first: Vec<u16> = (0..7).rev().flat_map(|j| (0..13).map(move |i| level(j, i))).collect();
        let eight: Vec<u8> = top_first.iter().map(|&l| l as u8).collect();
        let levels = if bits == 8 { GrayLevels::Eight(&eight) } else { GrayLevels::Sixteen(&top_first) };
        let from_levels =
            FrictionMap::from_gray_levels(levels, 13, 7, &mapping, (0.05, 0.1), (-1.0, 2.0), "levels").unwrap();
        assert_eq!(from_levels, from_png, "{bits} bit, gamma {gamma}");
        let short = GrayLevels::Sixteen(&top_first[1..]);
        let err = FrictionMap::from_gray_levels(short, 13, 7, &mapping, (0.05, 0.1), (-1.0, 2.0), "levels");
        assert!(err.unwrap_err().to_string().contains("90 gray levels for 13 x 7 pixels"));
    }
}

#[test]
fn bad_images_are_refused_with_the_reason() {
    let mapping = GrayMapping { mu_black: 0.8, mu_white: 1.4, gamma: 1.0 };
    let mut rgb = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut rgb, 4, 4);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().unwrap();
        w.write_image_data(&[128; 48]).unwrap();
    }
    let e = FrictionMap::read_gray_png(&rgb, &mapping, (0.1, 0.1), (0.0, 0.0), "c.png").unwrap_err().to_string();
    assert!(e.contains("c.png") && e.contains("grayscale"), "{e}");
    let e = FrictionMap::read_gray_png(b"GIF89a", &mapping, (0.1, 0.1), (0.0, 0.0), "x.png").unwrap_err().to_string();
    assert!(e.contains("not a readable PNG"), "{e}");
    // A header claiming 100 000 x 100 000 pixels is refused before any
    // buffer is sized by it.
    let mut huge = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut huge, 2, 2);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().unwrap();
        w.write_image_data(&[0, 1, 2, 3]).unwrap();
    }
    // IHDR: bytes 8..12 length, 12..16 "IHDR", 16..20 width, 20..24 height,
    // its CRC over type and data at 29..33.
    huge[16..20].copy_from_slice(&100_000u32.to_be_bytes());
    huge[20..24].copy_from_slice(&100_000u32.to_be_bytes());
    let crc = crc32(&huge[12..29]);
    huge[29..33].copy_from_slice(&crc.to_be_bytes());
    let e = FrictionMap::read_gray_png(&huge, &mapping, (0.1, 0.1), (0.0, 0.0), "h.png").unwrap_err().to_string();
    assert!(e.contains("at most"), "{e}");
    let bad = GrayMapping { gamma: 0.0, ..mapping };
    let e = FrictionMap::read_gray_png(&rgb, &bad, (0.1, 0.1), (0.0, 0.0), "c.png").unwrap_err().to_string();
    assert!(e.contains("gamma"), "{e}");
}

#[test]
fn bad_csv_names_the_line_and_field() {
    let cases: &[(&str, &str)] = &[
        (
            "x_mm,y_mm,mu\n0,0,1\n1,0,1\n0,1,1\n1.5,1,1\n",
            "m.csv, line 5: x_mm = 1.5, y_mm = 1 is not the grid point (1, 1)",
        ),
        ("x_mm,y_mm,mu\n0,0,1\n1,0,1\n0,1,1\n1,1,5000\n", "m.csv, line 5: field mu: mu must be"),
        ("x_mm,y_mm,mu\n0,0,1\n1,0,1\n0,1,1\n", "not a whole number of grid rows"),
        ("x_mm,y_mm\n0,0\n", "no 'mu' column"),
        ("x_mm,y_mm,mu\n0,0,1\n0,1,1\n", "at least 2 x values per y"),
        ("x_mm,y_mm,mu\n0,0,1\n1,0,1\n", "one value of y"),
        ("x_mm,y_mm,mu\n0,0,1\n1,0,1\n2,0,1\n0,1,1\n1,1,1\n2,2,1\n", "line 7"),
        ("x_mm,y_mm,mu\n1,0,1\n0,0,1\n1,1,1\n0,1,1\n", "spacing must be a positive number"),
    ];
    for (text, want) in cases {
        let e = FrictionMap::read_csv(text.as_bytes(), "m.csv").unwrap_err().to_string();
        assert!(e.contains(want), "{text:?}: {e}");
    }
}

/// The acceptance case: a map whose rows are a 1-D profile, mapped by eq.
/// (8), sampled along y = const (on a row and between rows, since every
/// row is the same), gives the 1-D voltage at any x: eq. (8) of the
/// profile's values at the grid's x, linearly interpolated.
#[test]
fn a_path_along_a_row_gives_the_one_dimensional_voltage() {
    let x: Vec<f64> = (0..=200).map(|i| i as f64 * 0.05).collect();
    let mu: Vec<f64> = x.iter().map(|x| 0.95 + 0.3 * (-(x - 5.0) * (x - 5.0) / 0.8).exp()).collect();
    let profile = FrictionProfile::new(x.clone(), mu).unwrap();
    let g = MapGrid { nx: 201, ny: 9, x0_mm: 0.0, y0_mm: -2.0, dx_mm: 0.05, dy_mm: 0.5 };
    let map = FrictionMap::extrude(&profile, g).unwrap();
    let device = Device::PAPER;
    let one_d = map_profile(&profile, &device, Method::Physical, None).unwrap();
    let v = map.voltages(&device, Method::Physical).unwrap();
    // On a row (y = -2, 0.5, 2) the other axis' weight is exactly 0;
    // between two equal rows (0.73) the blend of two equal values.
    for y in [-2.0, 0.5, 0.73, 2.0] {
        for k in 0..=997 {
            let xq = -0.3 + k as f64 * 0.0107;
            let want = interpolate(&x, &one_d.voltage_v, xq);
            let got = v.sample(xq, y);
            assert!((got - want).abs() <= 1e-12 * want.max(1.0), "y {y} x {xq}: {got} vs {want}");
        }
    }
    // The limits as areas equal the 1-D fractions (every row the same):
    // counted over the grid's points.
    let below = one_d.mu.iter().filter(|&&m| m < device.mu_hd).count() as f64 / 201.0;
    assert!((v.not_renderable_fraction - below).abs() < 1e-12, "{} vs {below}", v.not_renderable_fraction);
}

/// Eq. (9) per cell: min mu -> 0 V, max mu -> U_max, and a constant map
/// gives 0 V.
#[test]
fn normalized_map_spans_zero_to_u_max() {
    let m = test_map(30, 10);
    let v = m.voltages(&Device::PAPER, Method::Normalized).unwrap();
    let (lo, hi) = v.voltage_v.iter().fold((f64::MAX, f64::MIN), |(a, b), &u| (a.min(u), b.max(u)));
    assert_eq!((lo, hi), (0.0, 100.0));
    let flat = FrictionMap::new(grid(3, 3), vec![1.0; 9], "flat").unwrap();
    assert!(flat.voltages(&Device::PAPER, Method::Normalized).unwrap().voltage_v.iter().all(|&u| u == 0.0));
}

/// CRC-32 (IEEE), bit by bit: to patch a PNG header in a test.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

/// A grating at an angle: each line y = const is the line profile's
/// periodic part shifted by y tan(theta), with period lambda / cos(theta);
/// a line profile that is exactly periodic is kept to round-off (its own
/// Fourier series), at 90 degrees the map is the flat friction.
#[test]
fn grating_lines_are_the_shifted_periodic_line() {
    use haptex_core::map::Grating;
    let g = Grating { period_mm: 1.0, amplitude_mm: 0.2, angle_deg: 40.0, velocity_mm_s: 20.0 };
    let p = g.line_period_mm();
    assert!((p - 1.0 / 40f64.to_radians().cos()).abs() < 1e-12);
    // A line profile of two harmonics of P with phase x0 = 5, on 0..10 mm,
    // and a start transient in the first mm (left out by the fit).
    let x0 = 5.0;
    let f = |x: f64| {
        let w = 2.0 * std::f64::consts::PI * (x - x0) / p;
        0.5 + 0.03 * w.sin() + 0.01 * (2.0 * w).cos()
    };
    let xs: Vec<f64> = (0..=1000).map(|i| i as f64 * 0.01).collect();
    let mu: Vec<f64> = xs.iter().map(|&x| if x < 0.8 { 0.3 } else { f(x) }).collect();
    let grid = MapGrid { nx: 50, ny: 20, x0_mm: -3.0, y0_mm: -1.0, dx_mm: 0.13, dy_mm: 0.21 };
    let (map, rms) = g.friction_map(Some((&xs, &mu, x0)), 0.5, grid).unwrap();
    assert!(rms.unwrap() < 1e-12, "{rms:?}");
    let t = 40f64.to_radians().tan();
    for j in 0..grid.ny {
        for i in 0..grid.nx {
            let (x, y) = (grid.x(i), grid.y(j));
            let want = f(x + y * t + x0);
            let got = map.mu[j * grid.nx + i];
            assert!((got - want).abs() < 1e-10, "({x}, {y}): {got} vs {want}");
        }
    }
    let along = Grating { angle_deg: 90.0, ..g };
    let (flat, none) = along.friction_map(Some((&xs, &mu, x0)), 0.47, grid).unwrap();
    assert!(none.is_none() && flat.mu.iter().all(|&m| m == 0.47));
    for bad in
        [Grating { angle_deg: 91.0, ..g }, Grating { period_mm: 0.0, ..g }, Grating { amplitude_mm: f64::NAN, ..g }]
    {
        assert!(bad.friction_map(Some((&xs, &mu, x0)), 0.5, grid).is_err(), "{bad:?}");
    }
    // A line too short for the first mm plus one period.
    let short: Vec<f64> = (0..=150).map(|i| i as f64 * 0.01).collect();
    let e = g.friction_map(Some((&short, &vec![0.5; 151], 0.0)), 0.5, grid).unwrap_err().to_string();
    assert!(e.contains("shorter"), "{e}");
}
