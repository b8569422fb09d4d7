//! `haptex simulate` end to end: outputs and bad input.

use std::process::{Command, Output};

fn haptex(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_haptex")).args(args).output().expect("run haptex")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

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
    let png = std::fs::read(p("finger.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
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
        (vec!["--surface", "bump", "--mu-skin", "-1"], "skin friction must be >= 0"),
    ];
    for (args, fragment) in cases {
        let mut full = vec!["simulate", "-q", "--mesh", "coarse", "--slide", "0.5"];
        full.extend(args.iter());
        let out = haptex(&full);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr(&out).contains(fragment), "{args:?}: {}", stderr(&out));
    }
}
