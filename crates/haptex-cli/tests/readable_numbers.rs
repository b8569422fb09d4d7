//! Issue 35, "readable numbers": every number shown to a person follows
//! one rule (`haptex_core::num::Num`): a value that needs 16 or 17 digits
//! to be exact reads as the 15-digit decimal it rounds to (0.1 + 0.6 reads
//! 0.7), and no value prints as hundreds of digits (`{}` of 1e-300, `{:.4}`
//! of 1e300). `cae predict --width 1e-300` and a profile with x = 5e-324
//! ("x 0 .. 0.000...0001 mm") printed 300 digits; 0.7000000000000001 and
//! 8.725000000000001 appeared in summaries and errors.
//!
//! This test drives a corpus of extreme numbers through the commands'
//! flags and files; `common::stderr`, which every CLI test reads messages
//! through, fails on any number that breaks the rule
//! (`haptex_core::num::unreadable_number`), so the existing error tests
//! check it too.

use std::path::Path;

mod common;
use common::{haptex, stderr, write};

/// Extreme values: tiny, subnormal, huge, and computed values whose exact
/// text needs 16-17 digits.
const EXTREMES: &[&str] =
    &["1e-300", "5e-324", "1e300", "-1e300", "0.7000000000000001", "8.725000000000001", "1.7976931348623157e308"];

/// Runs haptex and returns its messages (stderr, checked by
/// `common::stderr`) and whether it succeeded.
fn run(args: &[&str]) -> (bool, String) {
    let out = haptex(args);
    let text = stderr(&out);
    assert!(out.status.code().is_some_and(|c| c <= 2), "{args:?}: killed or aborted: {text}");
    (out.status.success(), text)
}

#[test]
fn numbers_in_messages_are_readable_whatever_the_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = |name: &str| d.join(name).to_str().unwrap().to_string();
    let files = [
        write(d, "tiny.csv", "x_mm,mu\n0,0.5\n5e-324,0.6\n"),
        write(d, "computed.csv", "x_mm,mu\n0,0.7000000000000001\n8.725000000000001,1.2000000000000002\n"),
        write(d, "huge.csv", "x_mm,mu\n-1e300,0.5\n1e300,0.6\n"),
        write(d, "forces.csv", "x_mm,ft_n,fn_n\n0,0.1,1e-300\n1,0.7000000000000001,0.5\n"),
    ];
    let voltage = write(d, "u.csv", "x_mm,voltage_v\n0,0.30000000000000004\n5e-324,50\n1,8.725000000000001\n");
    let model = write(d, "m.csv", "a,y\n0,1\n1,2\n2,3.0000000000000004\n3,1\n");

    // voltage: files and every device flag.
    for file in &files {
        run(&["voltage", "--profile", file, "-o", &p("v.csv")]);
    }
    let (ok, text) = run(&["voltage", "--profile", &files[0], "-o", &p("v.csv")]);
    assert!(ok && text.contains("x 0 .. 5e-324 mm"), "{text}");
    let (_, text) = run(&["voltage", "--profile", &files[1], "-o", &p("v.csv")]);
    assert!(text.contains("x 0 .. 8.725 mm") && text.contains("mu 0.7000 .. 1.2000"), "{text}");
    for flag in ["--u-max", "--mu-hd", "--eps-sc", "--d-sc-mm", "--d-i-mm", "--k-mm2-per-n"] {
        for value in EXTREMES {
            run(&["voltage", "--profile", &files[1], flag, value, "-o", &p("v.csv")]);
        }
    }

    // cae predict and loo: widths, queries.
    for value in EXTREMES {
        let (ok, text) = run(&["cae", "predict", "--model", &model, "--inputs", "a", "--width", value, "--at", "a=1"]);
        if *value == "1e-300" {
            assert!(!ok && text.contains("1e-300"), "{text}");
        }
        run(&["cae", "predict", "--model", &model, "--inputs", "a", "--width", "0.5", "--at", &format!("a={value}")]);
        run(&[
            "cae",
            "predict",
            "--model",
            &model,
            "--inputs",
            "a",
            "--widths",
            &format!("{value},1e300"),
            "--at",
            "a=1",
        ]);
    }
    run(&["cae", "predict", "--model", &model, "--inputs", "a", "--at", "a=1"]);
    run(&["cae", "loo", "--model", &model, "--inputs", "a"]);

    // play: trajectories, speeds, drive settings.
    let wav = p("o.wav");
    for value in EXTREMES {
        run(&["play", "--profile", &voltage, "--velocity", value, "-o", &wav]);
        run(&["play", "--profile", &voltage, "--velocity", "10", "--to-mm", value, "-o", &wav]);
        for flag in ["--carrier-hz", "--u-max", "--volts-per-full-scale", "--amp-range-v", "--slew-v-per-s"] {
            run(&["play", "--profile", &voltage, "--velocity", "10", flag, value, "-o", &wav]);
        }
        let t = write(d, "t.csv", &format!("t_s,x_mm\n0,0\n{},1\n", value.trim_start_matches('-')));
        run(&["play", "--profile", &voltage, "--trajectory", &t, "-o", &wav]);
    }

    // predict (the shipped database) and a library import.
    let csv = p("o.csv");
    for value in EXTREMES {
        for flag in ["--x0", "--width", "--height", "--velocity"] {
            let mut args = vec!["predict", "--surface", "bump", "--x0", "5", "--width", "1.5", "--height", "0.3"];
            let at = args.iter().position(|a| a == &flag).map(|i| i + 1);
            match at {
                Some(i) => args[i] = value,
                None => args.extend([flag, value]),
            }
            args.extend(["-o", &csv, "-q"]);
            run(&args);
        }
    }
    let db = p("lib.sqlite");
    for file in &files {
        run(&["library", "import", "--db", &db, "--profile", file, "--material", "m", "--synthetic"]);
    }
    assert!(!Path::new(&p("nothing")).exists());
}
