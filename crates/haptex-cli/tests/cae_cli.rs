//! `haptex cae predict` and `haptex cae loo` end to end: the binary, its
//! files, its JSON and its errors.

mod common;
use common::{haptex, stderr, write};

/// Data rows of a CSV (comments and header skipped).
fn rows(text: &str) -> Vec<Vec<f64>> {
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

/// Two model vectors a = 0 -> y = 1, z = 10 and a = 1 -> y = 3, z = 30: at
/// a = 0.5 the two Gaussians are equal for any width, so eq. (11) gives the
/// plain mean (y = 2, z = 20) to rounding; at a = 0 with a tiny width the
/// first vector's outputs.
#[test]
fn predict_two_point_model_by_hand() {
    let dir = tempfile::tempdir().unwrap();
    let model = write(dir.path(), "m.csv", "# two vectors\ny,a,z\n1,0,10\n3,1,30\n");
    let out_path = dir.path().join("p.csv");
    let out = haptex(&[
        "cae",
        "predict",
        "--model",
        &model,
        "--inputs",
        "a",
        "--at",
        "a=0.5",
        "--at",
        "a=0",
        "--width",
        "0.001",
        "-o",
        out_path.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(&out_path).unwrap();
    assert!(text.lines().any(|l| l == "y,z"), "{text}");
    let p = rows(&text);
    assert_eq!(p.len(), 2);
    assert!((p[0][0] - 2.0).abs() < 1e-15 && (p[0][1] - 20.0).abs() < 1e-14, "{p:?}");
    assert_eq!(p[1], [1.0, 10.0]);
    // Two files: the model and the output (the temporary file was renamed).
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
}

#[test]
fn predict_from_a_query_file_matches_at_flags_and_warns_far_away() {
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/examples/cae_bump_model.csv");
    let dir = tempfile::tempdir().unwrap();
    let queries = write(dir.path(), "q.csv", "r_h_mm,extra,r_w_mm\n0.25,7,1.1\n0.3,7,6\n");
    let base = ["cae", "predict", "--model", example, "--inputs", "r_w_mm,r_h_mm", "--widths", "0.1,0.2"];
    let from_file = haptex(&[&base[..], &["--at-file", &queries]].concat());
    let from_flags = haptex(&[&base[..], &["--at", "r_w_mm=1.1,r_h_mm=0.25", "--at", "r_h_mm=0.3, r_w_mm=6"]].concat());
    assert!(from_file.status.success(), "{}", stderr(&from_file));
    assert!(from_flags.status.success(), "{}", stderr(&from_flags));
    let (a, b) = (String::from_utf8_lossy(&from_file.stdout), String::from_utf8_lossy(&from_flags.stdout));
    assert_eq!(rows(&a), rows(&b));
    assert_eq!(rows(&a).len(), 2);
    assert_eq!(rows(&a)[0].len(), 41);
    for out in [&from_file, &from_flags] {
        let message = stderr(out);
        assert_eq!(message.matches("extrapolation").count(), 1, "{message}");
        assert!(message.contains("'r_w_mm' = 6 is outside the database range 0.5 .. 2.5"), "{message}");
    }
    assert!(stderr(&from_file).contains("q.csv, line 3"), "{}", stderr(&from_file));
}

/// `cae loo` prints the fields the issue requires, and its optimum is the
/// width `cae predict` uses by default.
#[test]
fn loo_json_fields_and_default_predict_width() {
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/examples/cae_bump_model.csv");
    let out = haptex(&["cae", "loo", "--model", example, "--inputs", "r_w_mm,r_h_mm", "--constant"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((json["n"].as_u64(), json["d"].as_u64(), json["m"].as_u64()), (Some(45), Some(2), Some(41)));
    assert_eq!(json["w_min"], json["w_max"]);
    assert_eq!(json["constant"], true);
    assert!(json["rmse"].as_f64().unwrap() > 0.0);
    assert_eq!(json["rmse_per_output"].as_array().unwrap().len(), 41);
    assert_eq!(json["optimizer"]["at_bound"], false);
    assert!(json["optimizer"]["evaluations"].as_u64().unwrap() > 13);
    let w = json["w_min"].as_f64().unwrap();

    let out =
        haptex(&["cae", "predict", "--model", example, "--inputs", "r_w_mm,r_h_mm", "--at", "r_w_mm=1,r_h_mm=0.2"]);
    assert!(out.status.success(), "{}", stderr(&out));
    // The summary shows it by the rule for people (haptex_core::num::Num);
    // the JSON has it in full.
    assert!(stderr(&out).contains(&format!("width: {} ", haptex_core::num::Num(w))), "{}", stderr(&out));

    // Evaluating at given widths reports them and no optimizer.
    let out = haptex(&["cae", "loo", "--model", example, "--inputs", "r_w_mm,r_h_mm", "--widths", "0.05,0.2"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((json["w_min"].as_f64(), json["w_max"].as_f64()), (Some(0.05), Some(0.2)));
    assert!(json["optimizer"].is_null());
}

#[test]
fn bad_model_files_and_queries_fail_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let bad = write(dir.path(), "bad.csv", "a,y\n0,1\n1,oops\n");
    let out = haptex(&["cae", "loo", "--model", &bad, "--inputs", "a"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("bad.csv, line 3, column 'y': not a number"), "{}", stderr(&out));
    assert!(out.stdout.is_empty());

    let model = write(dir.path(), "m.csv", "a,b,y\n0,0,1\n1,1,2\n");
    let cases: &[(&[&str], &str)] = &[
        (&["--inputs", "a,c", "--at", "a=1,c=1"], "line 1, column 'c': required column is missing"),
        (&["--inputs", "a,b", "--at", "a=1"], "missing input(s): b"),
        (&["--inputs", "a,b", "--at", "a=1,b=2,a=3"], "'a' is given twice"),
        (&["--inputs", "a,b", "--at", "a=1,q=2"], "'q' is not an input"),
        (&["--inputs", "a,b", "--at", "a=1,b=inf"], "not finite"),
        (&["--inputs", "a,b"], "no queries"),
        (&["--inputs", "a,b", "--at", "a=1,b=1", "--width", "0"], "positive finite"),
        (&["--inputs", "a,b", "--at", "a=1,b=1", "--widths", "0.3,0.1"], "larger than w_max"),
        (&["--inputs", "a,b,y", "--at", "a=1,b=1,y=1"], "no output columns"),
        (&["--inputs", "a,a", "--at", "a=1"], "named twice"),
    ];
    for (args, fragment) in cases {
        let out = haptex(&[&["cae", "predict", "--model", &model][..], args].concat());
        assert!(!out.status.success(), "{args:?}");
        assert!(stderr(&out).contains(fragment), "{args:?}: {}", stderr(&out));
    }
}

/// Issue 13: `cae loo` and `cae predict` without `--width` allocated the
/// N x N leave-one-out matrix unchecked: 40 000 rows (12.8 GB) aborted with
/// SIGABRT. The memory is estimated first and refused beyond the budget,
/// with the flags that change it; a larger budget or a given width runs.
#[test]
fn leave_one_out_memory_is_bounded_by_a_budget() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("a,y\n");
    for i in 0..40_000 {
        text += &format!("{},{}\n", i as f64 / 40_000.0, (i % 7) as f64);
    }
    let model = write(dir.path(), "big.csv", &text);
    for command in [vec!["loo"], vec!["predict", "--at", "a=0.5"]] {
        let mut args = vec!["cae"];
        args.extend(command.iter().copied());
        args.extend(["--model", &model, "--inputs", "a"]);
        let out = haptex(&args);
        assert_eq!(out.status.code(), Some(1), "{command:?}: {}", stderr(&out));
        let message = stderr(&out);
        assert!(message.contains("40000 x 40000") && message.contains("11.9 GiB"), "{message}");
        assert!(message.contains("--memory-budget-mib") && message.contains("--width"), "{message}");
    }
    // With a width, no leave-one-out is needed.
    let out = haptex(&["cae", "predict", "--model", &model, "--inputs", "a", "--at", "a=0.5", "--width", "0.01", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    // A small model within a small budget runs; beyond it, it is refused.
    let small: String = (0..300).fold(String::from("a,y\n"), |t, i| t + &format!("{},{}\n", i, i % 5));
    let small = write(dir.path(), "small.csv", &small);
    let out = haptex(&["cae", "loo", "--model", &small, "--inputs", "a", "--constant", "--memory-budget-mib", "1"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let big_budget = haptex(&["cae", "loo", "--model", &model, "--inputs", "a", "--memory-budget-mib", "0"]);
    assert!(!big_budget.status.success() && stderr(&big_budget).contains("--memory-budget-mib"));
}

/// Issue 35: `cae loo --memory-budget-mib 100000` with 40 000 rows aborted
/// ("memory allocation of 12800000000 bytes failed", exit 134): within the
/// budget, the system refused the memory. Every allocation whose size
/// comes from the input is made fallibly. Here 4.5 million rows need a
/// 162 TB weight matrix, more than the address space of any 64-bit Linux
/// process (128 TiB), so the allocation fails on every machine whatever its
/// memory; the budget allows it. A clean error naming the matrix and exit
/// code 1, from `cae loo` and from `cae predict` (which runs the
/// leave-one-out to find the width).
#[test]
fn allocation_beyond_memory_is_a_clean_error_whatever_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let n = 4_500_000;
    let mut text = String::with_capacity(12 * n);
    text.push_str("a,y\n");
    for i in 0..n {
        use std::fmt::Write;
        writeln!(text, "{i},{}", i % 7).unwrap();
    }
    let model = write(dir.path(), "huge.csv", &text);
    drop(text);
    let budget = (u64::MAX >> 20).to_string();
    for command in [vec!["loo"], vec!["predict", "--at", "a=0.5"]] {
        let mut args = vec!["cae"];
        args.extend(command.iter().copied());
        args.extend(["--model", &model, "--inputs", "a", "--memory-budget-mib", &budget]);
        let out = haptex(&args);
        let message = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{command:?}: {message}");
        assert!(
            message.contains("cannot allocate the 4500000 x 4500000 weight matrix of the leave-one-out")
                && message.contains("TiB"),
            "{command:?}: {message}"
        );
    }
}
