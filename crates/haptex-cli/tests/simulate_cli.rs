//! `haptex simulate` end to end: outputs and bad input.

mod common;
use common::{haptex, stderr};

#[test]
fn simulate_writes_profile_history_vtk_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let out = haptex(&[
        "simulate",
        "--surface",
        "bump",
        "--x0",
        "2",
        "--width",
        "1",
        "--height",
        "0.2",
        "--slide",
        "4",
        "--mesh",
        "coarse",
        "-q",
        "-o",
        &p("profile.csv"),
        "--history",
        &p("history.csv"),
        "--vtk",
        &p("vtk"),
        "--png",
        &p("finger.png"),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    // The profile reads back as a friction profile and feeds haptex voltage.
    let profile = haptex_core::FrictionProfile::read_csv_file(std::path::Path::new(&p("profile.csv"))).unwrap();
    assert_eq!(profile.len(), 40);
    assert!((profile.x_mm()[39] - 4.0).abs() < 1e-9);
    assert!(profile.fn_n().is_some());
    let v = haptex(&["voltage", "--profile", &p("profile.csv"), "--method", "normalized", "-q"]);
    assert!(v.status.success(), "{}", stderr(&v));
    let history = haptex_core::io::Table::read_file(std::path::Path::new(&p("history.csv"))).unwrap();
    for column in ["t_s", "slide_mm", "fn_n", "ft_n", "contact_mm"] {
        assert!(history.column(column).is_some(), "{column}");
    }
    assert_eq!(history.n_rows(), 10 + 40);
    let pvd = std::fs::read_to_string(dir.path().join("vtk/simulation.pvd")).unwrap();
    let frames = pvd.matches("<DataSet").count();
    assert!(frames >= 3, "{pvd}");
    let vtu = std::fs::read_to_string(dir.path().join("vtk/frame_0000.vtu")).unwrap();
    assert!(
        vtu.contains("Name=\"displacement\"") && vtu.contains("Name=\"subdomain\"") && vtu.ends_with("</VTKFile>\n")
    );
    // The frames are a file set: the collection lists each frame's hash.
    let frame_0 = std::fs::read(dir.path().join("vtk/frame_0000.vtu")).unwrap();
    assert!(pvd.contains(&format!("{}  frame_0000.vtu", haptex_core::io::sha256_hex(&frame_0))), "{pvd}");
    let png = std::fs::read(p("finger.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    // Issue 13: a run killed before the collection is written leaves none
    // (the old one is removed first), not an old collection over new frames.
    let killed = std::process::Command::new(env!("CARGO_BIN_EXE_haptex"))
        .args(["simulate", "--surface", "bump", "--x0", "2", "--width", "1", "--height", "0.2", "--slide", "4"])
        .args(["--mesh", "coarse", "-q", "--vtk", &p("vtk")])
        .env("HAPTEX_FAULT_INJECT", "before-marker")
        .output()
        .unwrap();
    assert!(!killed.status.success(), "the fault hook did not fire");
    assert!(!dir.path().join("vtk/simulation.pvd").exists() && dir.path().join("vtk/frame_0000.vtu").exists());
}

#[test]
fn simulate_rejects_bad_input_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let heights = dir.path().join("h.csv");
    std::fs::write(&heights, "x_mm,h_mm\n0,0\n1,0.1\n1,0.2\n").unwrap();
    let surface = format!("file:{}", heights.display());
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--surface", "wavy"], "--surface must be"),
        (vec!["--surface", "bump", "--width", "0"], "--width"),
        (vec!["--surface", "bump", "--velocity", "-3"], "--velocity"),
        (vec!["--surface", "bump", "--indent", "0.2", "--load", "0.01"], "cannot be used with"),
        (vec!["--surface", &surface], "h.csv, line 4, column 'x_mm'"),
        (vec!["--surface", "file:/nonexistent/h.csv"], "/nonexistent/h.csv"),
        (vec!["--surface", "bump", "--finger", "/nonexistent/f.toml"], "/nonexistent/f.toml"),
        (vec!["--surface", "bump", "--mu-skin", "-1"], "skin friction mu = -1 is outside the supported range 0 .. 10"),
    ];
    for (args, fragment) in cases {
        let mut full = vec!["simulate", "-q", "--mesh", "coarse", "--slide", "0.5"];
        full.extend(args.iter());
        let out = haptex(&full);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr(&out).contains(fragment), "{args:?}: {}", stderr(&out));
    }
}

/// The shipped finger model with `old` replaced by `new`, written to `dir`.
fn finger_file(dir: &std::path::Path, name: &str, old: &str, new: &str) -> String {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/finger/finger-2d.toml")).unwrap();
    assert!(text.contains(old), "{old}");
    let path = dir.join(name);
    std::fs::write(&path, text.replace(old, new)).unwrap();
    path.to_str().unwrap().to_string()
}

/// Issue 13: a finger file whose contact arc reaches the nail made the
/// solver panic, and 7 Prony terms overflowed a fixed table. Now a bad
/// field fails with the file, the line of its key and the field, before
/// any output is written; 7 terms simulate.
#[test]
fn bad_finger_files_fail_with_file_line_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("profile.csv");
    let cases = [
        (
            finger_file(dir.path(), "arc.toml", "contact_half_arc_mm = 6.0", "contact_half_arc_mm = 18"),
            "arc.toml: line 77: contact.contact_half_arc_mm = 18 mm is longer than the contour allows (at most 14.4",
        ),
        (
            finger_file(
                dir.path(),
                "nu.toml",
                "e_mpa = 0.15         # range 0.1-0.2, middle\nnu = 0.48",
                "e_mpa = 0.15\nnu = 0.5",
            ),
            "nu.toml: line 49: materials.dermis.nu = 0.5 is outside the supported range -0.9 .. 0.4999",
        ),
        (
            finger_file(dir.path(), "huge.toml", "half_width_mm = 8.0", "half_width_mm = 1e300"),
            "huge.toml: line 15: geometry.half_width_mm = 1e300 mm is outside the supported range 2 .. 20 mm",
        ),
        (
            finger_file(dir.path(), "tau.toml", "{ g = 0.2, tau_s = 0.07 }", "{ g = 0.2, tau_s = -0.07 }"),
            "tau.toml: line 67: viscoelasticity.prony[1].tau_s = -0.07 s is outside the supported range",
        ),
        (
            finger_file(
                dir.path(),
                "many.toml",
                "    { g = 0.2, tau_s = 1.4 },\n",
                &"    { g = 0.001, tau_s = 1.4 },\n".repeat(40),
            ),
            "many.toml: line 65: viscoelasticity.prony has 42 terms; at most 32 are supported",
        ),
    ];
    for (path, expected) in cases {
        let out = haptex(&[
            "simulate",
            "-q",
            "--surface",
            "flat",
            "--mesh",
            "coarse",
            "--finger",
            &path,
            "-o",
            output.to_str().unwrap(),
        ]);
        let err = stderr(&out);
        assert!(!out.status.success(), "{path} succeeded");
        assert!(err.contains(expected), "{path}: expected '{expected}' in: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!output.exists(), "no output for a refused model");
    }

    let seven = finger_file(
        dir.path(),
        "seven.toml",
        "    { g = 0.2, tau_s = 1.4 },\n",
        &(0..5).map(|i| format!("    {{ g = 0.05, tau_s = {} }},\n", 0.2 * 2f64.powi(i))).collect::<String>(),
    );
    let out = haptex(&[
        "simulate",
        "-q",
        "--surface",
        "flat",
        "--mesh",
        "coarse",
        "--slide",
        "0.3",
        "--finger",
        &seven,
        "-o",
        output.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(std::fs::read_to_string(&output).unwrap().lines().count() > 3);
}

/// Flags at absurd magnitudes, or that size a loop, a vector or the
/// surface polyline: each is an error naming the setting, not a panic, an
/// overflow or an allocation of gigabytes (before: --step 1e-300
/// overflowed the step count, --vtk-every 1 over a long slide kept every
/// frame, --width 1e-4 sampled the surface at 0.5 nm).
#[test]
fn extreme_simulate_flags_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let vtk = dir.path().join("vtk");
    let heights = dir.path().join("tall.csv");
    std::fs::write(&heights, "x_mm,h_mm\n0,0\n1,1e300\n").unwrap();
    let tall = format!("file:{}", heights.display());
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--step", "1e-300"], "steps of 1e-300 mm takes 1e301 steps; at most 1000000"),
        (vec!["--slide", "1e300"], "slide = 1e300 mm is outside the supported range"),
        (vec!["--velocity", "1e-300"], "velocity = 1e-300 mm/s is outside"),
        (vec!["--press-time", "1e300"], "press time = 1e300 s is outside"),
        (vec!["--penalty", "1e300"], "penalty = 1e300 MPa/mm is outside"),
        (vec!["--mu-skin", "nan"], "skin friction mu = NaN is outside"),
        (vec!["--indent", "1e300"], "indentation = 1e300 mm must be positive and less than the pulp"),
        (vec!["--load", "1e300"], "load = 1e300 N/mm must be positive and at most 100 N/mm"),
        (vec!["--x0", "1e300"], "surface x0 = 1e300 mm is outside"),
        (vec!["--height", "-1e300"], "surface height r_h = -1e300 mm is outside"),
        (vec!["--width", "1e-300"], "surface width r_w = 1e-300 mm is outside"),
        (vec!["--width", "1e-3"], "takes 6000000 points, more than 4000000"),
        (vec!["--slide", "1000", "--vtk", vtk.to_str().unwrap(), "--vtk-every", "1"], "at most 1000 are kept"),
        (vec!["--surface", &tall], "tall.csv, line 3, column 'h_mm': h = 1e300 mm is outside"),
    ];
    for (args, fragment) in cases {
        let mut full = vec!["simulate", "-q", "--mesh", "coarse"];
        if !args.contains(&"--surface") {
            full.extend(["--surface", "bump"]);
        }
        full.extend(args.iter());
        let out = haptex(&full);
        let err = stderr(&out);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(err.contains(fragment), "{args:?}: expected '{fragment}' in: {err}");
        assert!(!err.contains("panicked") && err.len() < 400, "{args:?}: {err}");
    }
    assert!(!vtk.exists(), "nothing written for refused settings");
}

/// `--slide 0` is a press only (issue 14): the output is the press curve
/// `t_s,indent_mm,fn_n,ft_n,contact_mm`, ending at the indentation, with a
/// positive normal force growing over the press.
#[test]
fn press_only_writes_the_press_curve() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("press.csv");
    let out =
        haptex(&["simulate", "--surface", "flat", "--slide", "0", "--mesh", "coarse", "-o", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("press only: Fn = "), "{}", stderr(&out));
    let text = std::fs::read_to_string(&path).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip_while(|l| l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert!(text.lines().any(|l| l == "t_s,indent_mm,fn_n,ft_n,contact_mm"), "{text}");
    assert_eq!(rows.len(), 10, "one row per press step");
    assert!((rows[9][1] - 0.25).abs() < 1e-12, "ends at the 0.25 mm indentation: {:?}", rows[9]);
    assert!(rows.windows(2).all(|w| w[1][2] > w[0][2] && w[0][2] > 0.0), "Fn grows over the press");
}

/// A sine whose crests the mesh does not resolve (radius 2^2 / (4 pi^2
/// 0.3) = 0.338 mm, under the coarse mesh's 5 x 0.2 mm) is simulated, with
/// a warning before the run and the caveat in the file's header, naming the
/// mesh that resolves it; a bump of the same size is not a grating.
#[test]
fn a_sine_sharper_than_the_mesh_is_said_to_be() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sine.csv");
    let run = |surface: &str| {
        let out = haptex(&[
            "simulate",
            "--surface",
            surface,
            "--width",
            "2",
            "--height",
            "0.3",
            "--slide",
            "0",
            "--mesh",
            "coarse",
            "-o",
            path.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        (stderr(&out), std::fs::read_to_string(&path).unwrap())
    };
    let (said, text) = run("sine");
    let warning = "the grating's crests (radius 0.338 mm) are sharper than the coarse mesh resolves (5 pad node \
                   spacings, 1 mm)";
    assert!(said.starts_with(&format!("warning: {warning}")), "{said}");
    assert!(said.contains("`haptex simulate --mesh fine --step 0.0125` resolves them"), "{said}");
    let header = text.lines().next().unwrap();
    assert!(header.starts_with("# ") && header.contains(&format!("; not mesh-converged: {warning}")), "{header}");
    let (said, text) = run("bump");
    assert!(!said.contains("warning") && !text.contains("not mesh-converged"), "{said}");
}

/// An error's cause is printed once (issue 14 found "element 927: element
/// has a non-positive Jacobian (...): element has a non-positive Jacobian
/// (...)"; the same doubling was in every error that formats its cause).
#[test]
fn error_causes_are_printed_once() {
    let out = haptex(&["simulate", "--surface", "flat", "--slide", "1", "-q", "-o", "/nonexistent-dir/x.csv"]);
    assert!(!out.status.success());
    let message = stderr(&out);
    let cause = "No such file or directory";
    assert_eq!(message.matches(cause).count(), 1, "{message}");
}

/// `--model 3d` (issue 39): the profile reads back as a friction profile
/// and feeds `haptex voltage`; the history and the contact-patch PNG are
/// written; x is the distance travelled.
#[test]
fn simulate_3d_writes_profile_history_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let out = haptex(&[
        "simulate",
        "--model",
        "3d",
        "--mesh",
        "coarse",
        "--surface",
        "bump",
        "--x0",
        "1",
        "--width",
        "1.5",
        "--height",
        "0.1",
        "--slide",
        "1.5",
        "--direction-deg",
        "30",
        "-o",
        &p("profile.csv"),
        "--history",
        &p("history.csv"),
        "--png",
        &p("patch.png"),
    ]);
    let text = stderr(&out);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("direction 30 degrees") && text.contains("3D mesh:"), "{text}");
    let profile = haptex_core::FrictionProfile::read_csv_file(std::path::Path::new(&p("profile.csv"))).unwrap();
    assert_eq!(profile.len(), 15);
    assert!((profile.x_mm()[14] - 1.5).abs() < 1e-9);
    let table = haptex_core::io::Table::read_file(std::path::Path::new(&p("profile.csv"))).unwrap();
    for column in ["x_mm", "mu", "ft_n", "fn_n", "ft_lateral_n", "force_angle_deg"] {
        assert!(table.column(column).is_some(), "{column}");
    }
    // Forces in N on the whole finger: about 0.3 N at 0.5 mm.
    let fn_n = profile.fn_n().unwrap();
    assert!(fn_n.iter().all(|&f| f > 0.1 && f < 1.0), "{fn_n:?}");
    let v = haptex(&["voltage", "--profile", &p("profile.csv"), "--method", "normalized", "-q"]);
    assert!(v.status.success(), "{}", stderr(&v));
    let history = haptex_core::io::Table::read_file(std::path::Path::new(&p("history.csv"))).unwrap();
    for column in ["t_s", "slide_mm", "fn_n", "ft_n", "ft_lateral_n", "contact_area_mm2", "drive_z_mm"] {
        assert!(history.column(column).is_some(), "{column}");
    }
    assert_eq!(history.n_rows(), 10 + 15);
    let png = std::fs::read(p("patch.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}

/// `--model 3d --kinematics finite`: the finite-strain fingertip runs from
/// the command line, its profile's header says so, and it is not the
/// small-strain profile (the shipped finger, elastic, coarse mesh, over a
/// flat at the default 0.5 mm indentation: 3.9% less normal force at
/// finite strain; asserted between 0.5% and 10% apart).
#[test]
fn simulate_3d_at_finite_strain() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let run = |kinematics: &str, out: &str| {
        haptex(&[
            "simulate",
            "--model",
            "3d",
            "--mesh",
            "coarse",
            "--material",
            "elastic",
            "--surface",
            "flat",
            "--slide",
            "0.5",
            "--kinematics",
            kinematics,
            "-q",
            "-o",
            &p(out),
        ])
    };
    for (kinematics, out) in [("finite", "finite.csv"), ("small", "small.csv")] {
        let result = run(kinematics, out);
        assert!(result.status.success(), "{}", stderr(&result));
    }
    let text = std::fs::read_to_string(p("finite.csv")).unwrap();
    assert!(text.lines().next().unwrap().contains("finite strain"), "{text}");
    let read = |name: &str| haptex_core::FrictionProfile::read_csv_file(std::path::Path::new(&p(name))).unwrap();
    let table = |name: &str| haptex_core::io::Table::read_file(std::path::Path::new(&p(name))).unwrap();
    assert_eq!(read("finite.csv").len(), read("small.csv").len());
    let fn_finite = table("finite.csv").column("fn_n").unwrap().to_vec();
    let fn_small = table("small.csv").column("fn_n").unwrap().to_vec();
    let change = (fn_finite[0] / fn_small[0] - 1.0).abs();
    assert!(change > 0.005 && change < 0.1, "finite over small strain: {}", fn_finite[0] / fn_small[0]);
}

/// A surface whose crest passes between the 3D skin's contact points (a
/// bump of 0.5 by 0.5 mm on the coarse mesh) completes with a warning on
/// stderr, even with -q, and in the profile's comments, which the profile
/// reader skips; the resolved default bump has none, nor the narrow one
/// with its contact points on 2 x 2 parts of each face, which the header
/// states.
#[test]
fn simulate_3d_warns_where_the_mesh_does_not_resolve_the_surface() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    for (width, height, out, parts, warned) in [
        ("0.5", "0.5", "spike.csv", "1", true),
        ("1.5", "0.3", "bump.csv", "1", false),
        ("0.5", "0.5", "parts.csv", "2", false),
    ] {
        let result = haptex(&[
            "simulate",
            "--contact-parts",
            parts,
            "--model",
            "3d",
            "--mesh",
            "coarse",
            "--surface",
            "bump",
            "--x0",
            "3.5",
            "--width",
            width,
            "--height",
            height,
            "--slide",
            "0.5",
            "-q",
            "-o",
            &p(out),
        ]);
        assert!(result.status.success(), "{}", stderr(&result));
        let err = stderr(&result);
        assert_eq!(err.contains("warning: the surface reached"), warned, "{err}");
        let text = std::fs::read_to_string(p(out)).unwrap();
        assert_eq!(text.contains("# warning: the surface reached"), warned, "{text}");
        assert_eq!(text.contains("contact points on 2 x 2 parts of each face"), parts == "2", "{text}");
        if warned {
            assert!(err.contains("a finer --mesh, or more --contact-parts"), "{err}");
        }
        let profile = haptex_core::FrictionProfile::read_csv_file(std::path::Path::new(&p(out))).unwrap();
        assert!(profile.len() >= 5, "{} rows", profile.len());
    }
}

/// What the 3D finger does not do is refused by the flag's name, before
/// any work; a 3D-only flag is refused in 2D.
#[test]
fn simulate_3d_refuses_what_it_does_not_support() {
    let dir = tempfile::tempdir().unwrap();
    let vtk = dir.path().join("vtk");
    let vtk = vtk.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--model", "3d", "--vtk", vtk, "--vtk-every", "0", "--step", "1e-7"], "slide"),
        (vec!["--model", "3d", "--direction-deg", "NaN"], "--direction-deg NaN must be a finite angle"),
        (vec!["--model", "3d", "--direction-deg", "400"], "--direction-deg 400 must be a finite angle"),
        (vec!["--direction-deg", "30"], "--direction-deg applies to --model 3d only"),
        (vec!["--contact-parts", "2"], "--contact-parts applies to --model 3d only"),
        (vec!["--model", "3d", "--contact-parts", "0"], "0 is not in 1..=8"),
        (vec!["--model", "3d", "--contact-parts", "9"], "9 is not in 1..=8"),
        (vec!["--surface", "map:h.csv"], "a height map needs --model 3d"),
        (vec!["--model", "3d", "--load", "1000"], "load = 1000 N must be positive and at most 100 N"),
        (vec!["--model", "3d", "--surface", "map:/nonexistent/h.csv"], "/nonexistent/h.csv"),
        (vec!["--model", "4d"], "invalid value '4d'"),
        (vec!["--model", "3d", "--indent", "7"], "indent"),
    ];
    for (args, fragment) in cases {
        let mut full = vec!["simulate", "-q", "--mesh", "coarse", "--slide", "0.5"];
        if !args.contains(&"--surface") {
            full.extend(["--surface", "flat"]);
        }
        full.extend(args.iter());
        let out = haptex(&full);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr(&out).contains(fragment), "{args:?}: {}", stderr(&out));
        assert!(!vtk.is_empty() && !std::path::Path::new(vtk).exists(), "{args:?} wrote {vtk}");
    }
}

/// `--model 3d --vtk`: a series ParaView reads (checked with VTK's own
/// reader when this was written: every hexahedron of positive volume): the
/// frames after the press, every --vtk-every slide steps and at the end,
/// each with the mesh, the contact faces and the surface grid; the bone's
/// nodes are marked `driven` and sit 0.5 mm down (the default indent).
#[test]
fn simulate_3d_writes_a_vtk_series() {
    let dir = tempfile::tempdir().unwrap();
    let vtk = dir.path().join("vtk");
    let out = haptex(&[
        "simulate",
        "--model",
        "3d",
        "--mesh",
        "coarse",
        "--surface",
        "flat",
        "--slide",
        "1",
        "--vtk",
        vtk.to_str().unwrap(),
        "--vtk-every",
        "4",
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let pvd = std::fs::read_to_string(vtk.join("simulation.pvd")).unwrap();
    // The press, slide steps 4 and 8, and the end (10).
    assert_eq!(pvd.matches("<DataSet ").count(), 4, "{pvd}");
    let frame = std::fs::read_to_string(vtk.join("frame_0000.vtu")).unwrap();
    let array = |name: &str| -> Vec<f64> {
        let start = frame.find(&format!("Name=\"{name}\"")).unwrap_or_else(|| panic!("{name}"));
        let body = &frame[start..];
        let body = &body[body.find('>').unwrap() + 1..body.find("</DataArray>").unwrap()];
        body.split_whitespace().map(|v| v.parse().unwrap()).collect()
    };
    let types = array("types");
    let hexes = types.iter().filter(|&&t| t == 12.0).count();
    let quads = types.iter().filter(|&&t| t == 9.0).count();
    assert_eq!(hexes + quads, types.len());
    assert_eq!(hexes, 864, "the coarse fingertip's elements");
    let part = array("part");
    assert_eq!(part.iter().filter(|&&p| p == 6.0).count(), 60 * 60, "the surface grid");
    let driven = array("driven");
    let displacement = array("displacement");
    assert_eq!(displacement.len(), 3 * driven.len());
    let bone: Vec<usize> = (0..driven.len()).filter(|&n| driven[n] == 1.0).collect();
    assert!(!bone.is_empty());
    for n in bone {
        assert!((displacement[3 * n + 2] + 0.5).abs() < 1e-12, "node {n}: {}", displacement[3 * n + 2]);
    }
    // Some contact face carries pressure after the press.
    assert!(array("pressure_MPa").iter().any(|&p| p > 0.0));
}

/// `--model 3d --surface map:H.csv`: the 3D finger over a height map as
/// `haptex map height` writes it (here a ridge laid along a path); the
/// description names the map; a bad cell is refused by file, line and
/// column.
#[test]
fn simulate_3d_slides_over_a_height_map() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let out = haptex(&[
        "map",
        "height",
        "--template",
        "bump:1.5,0.2",
        "--path",
        "-20,1;20,1",
        "--size-mm",
        "26,26",
        "--origin-mm",
        "-13,-13",
        "--pixel-mm",
        "0.2",
        "--direction-deg",
        "90",
        "-q",
        "-o",
        &p("mu.csv"),
        "--heights-out",
        &p("h.csv"),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let surface = format!("map:{}", p("h.csv"));
    let out = haptex(&[
        "simulate",
        "--model",
        "3d",
        "--mesh",
        "coarse",
        "--surface",
        &surface,
        "--slide",
        "2",
        "--direction-deg",
        "90",
        "-o",
        &p("profile.csv"),
    ]);
    let text = stderr(&out);
    assert!(out.status.success(), "{text}");
    assert!(text.contains(&format!("height map {}", p("h.csv"))), "{text}");
    // The ridge along y = 1 mm is met across as the finger slides along y.
    let profile = haptex_core::FrictionProfile::read_csv_file(std::path::Path::new(&p("profile.csv"))).unwrap();
    let (lo, hi) = profile.mu().iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &m| (a.min(m), b.max(m)));
    assert!(hi - lo > 0.02, "Ft/Fn {lo} .. {hi}: the ridge is not felt");
    std::fs::write(p("bad.csv"), "x_mm,y_mm,h_mm\n0,0,0\n1,0,nan\n0,1,0\n1,1,0\n").unwrap();
    let out = haptex(&["simulate", "--model", "3d", "--surface", &format!("map:{}", p("bad.csv")), "-q"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("bad.csv: line 3, column 'h_mm'"), "{}", stderr(&out));
}
