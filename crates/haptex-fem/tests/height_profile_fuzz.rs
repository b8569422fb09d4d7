//! Fuzzing the height-profile reader of `haptex simulate --surface
//! file:H.csv` (issue 13): random CSV text (headers right, swapped, missing
//! or doubled, rows of numbers from 5e-324 to f64::MAX, non-finite and
//! malformed values, comments, blank lines, stray bytes) and random edits
//! of a valid file. The property: `SurfaceShape::read_csv_from` answers
//! with a surface or an error naming the source; never a panic. An
//! accepted surface is valid, its polyline over the finger's range builds
//! (or is refused cleanly), and its heights and closest points are finite.
//!
//! Cases per property: `HAPTEX_FUZZ_CASES` (default 1000). The generators
//! (`csv_text`, `mutated_csv`) are meant to be reused by a fuzz campaign
//! over every parser.

use std::sync::atomic::AtomicU32;
use std::sync::atomic::Ordering::Relaxed;

use haptex_fem::scenario::Scenario;
use haptex_fem::surface::{RigidSurface, SurfaceShape};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

fn runner() -> TestRunner {
    let cases = std::env::var("HAPTEX_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(1000);
    TestRunner::new(Config { cases, failure_persistence: None, ..Config::default() })
}

/// A field of a row: mostly a number of any magnitude, sometimes text that
/// is not one.
fn field() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => (-10.0f64..10.0).prop_map(|v| format!("{v}")),
        2 => (-320.0f64..308.0, any::<bool>()).prop_map(|(e, neg)| format!("{}{:e}", if neg { "-" } else { "" }, 10f64.powf(e))),
        1 => proptest::sample::select(vec![
            "0", "-0", "5e-324", "1e308", "1.7976931348623157e308", "1e309", "-1e309", "inf", "-inf", "NaN", "nan",
            "1e6", "1000000.0000001", "1000", "1000.0000000001", "", " ", "x", "1,5", "0x10", "1e", "--1", "1.2.3",
            "\u{feff}1", "１",
        ])
        .prop_map(str::to_string),
    ]
}

/// A header: the right one, swapped, with extra columns, missing a
/// column, doubled, or none.
fn header() -> impl Strategy<Value = String> {
    proptest::sample::select(vec![
        "x_mm,h_mm",
        "x_mm,h_mm",
        "x_mm,h_mm",
        "h_mm,x_mm",
        "x_mm,h_mm,note_mm",
        "x_mm",
        "x_mm,x_mm",
        "x,h",
        "",
        "\u{feff}x_mm,h_mm",
        " x_mm , h_mm ",
    ])
    .prop_map(str::to_string)
}

/// Random height-profile CSV text: a header, then rows (sorted x with
/// probability 1/2, so that many files get past the x check), comments and
/// blank lines, and rows of a different width.
pub fn csv_text() -> impl Strategy<Value = String> {
    let row = prop_oneof![
        8 => (field(), field()).prop_map(|(a, b)| format!("{a},{b}")),
        1 => (field(), field(), field()).prop_map(|(a, b, c)| format!("{a},{b},{c}")),
        1 => field(),
        1 => Just("# a comment".to_string()),
        1 => Just(String::new()),
    ];
    let sorted = (proptest::collection::vec((-20.0f64..30.0, -2.0f64..2.0), 0..60), any::<bool>()).prop_map(
        |(mut points, crlf)| {
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            let eol = if crlf { "\r\n" } else { "\n" };
            points.iter().map(|(x, h)| format!("{x},{h}{eol}")).collect::<String>()
        },
    );
    (header(), proptest::collection::vec(row, 0..40), sorted, any::<bool>()).prop_map(
        |(header, rows, sorted, use_sorted)| {
            let body = if use_sorted { sorted } else { rows.join("\n") };
            format!("# height profile\n{header}\n{body}")
        },
    )
}

/// A valid height file with random byte edits (replaced, inserted,
/// removed); invalid UTF-8 is kept as bytes (the reader takes bytes).
pub fn mutated_csv() -> impl Strategy<Value = Vec<u8>> {
    let edit = (0u8..3, any::<usize>(), any::<u8>());
    proptest::collection::vec(edit, 1..5).prop_map(|edits| {
        let mut bytes = b"# ramp and step\nx_mm,h_mm\n-5,0\n0,0\n1,0.2\n1.001,0\n2.5,0.1\n10,0\n".to_vec();
        for (kind, at, b) in edits {
            let n = bytes.len();
            match kind {
                0 if n > 0 => bytes[at % n] = b,
                1 => bytes.insert(at % (n + 1), b),
                _ if n > 0 => {
                    bytes.remove(at % n);
                }
                _ => {}
            }
        }
        bytes
    })
}

/// The property for one input.
fn check(bytes: &[u8]) -> Result<bool, TestCaseError> {
    match SurfaceShape::read_csv_from(bytes, "fuzz.csv") {
        Err(e) => {
            let message = e.to_string();
            prop_assert!(message.starts_with("fuzz.csv"), "{message}");
            prop_assert!(message.len() < 600, "a long message: {message}");
            Ok(false)
        }
        Ok(shape) => {
            prop_assert!(shape.validate().is_ok(), "{:?}", shape.validate());
            // The finger's range over a 10 mm slide, as `haptex simulate` uses.
            let scenario = Scenario::paper(shape.clone());
            scenario.validate().map_err(|e| TestCaseError::fail(format!("accepted surface refused: {e}")))?;
            let (x_min, x_max) = scenario.surface_range_mm();
            let surface = RigidSurface::new(&shape, x_min, x_max)
                .map_err(|e| TestCaseError::fail(format!("accepted surface has no polyline: {e}")))?;
            for i in 0..=40 {
                let x = x_min + (x_max - x_min) * i as f64 / 40.0;
                let h = surface.height(x);
                prop_assert!(h.is_finite());
                prop_assert!(surface.arc_at(x).is_finite());
                if let Some(p) = surface.project([x, h - 0.01]) {
                    prop_assert!(p.depth.is_finite() && p.arc_mm.is_finite());
                    prop_assert!(p.normal.iter().chain(&p.tangent).all(|v| v.is_finite()));
                }
            }
            Ok(true)
        }
    }
}

/// Runs `check` on every case of `strategy`; prints how many were accepted.
fn run<S: Strategy>(name: &str, strategy: S, bytes: impl Fn(&S::Value) -> Vec<u8>) {
    let (total, accepted) = (AtomicU32::new(0), AtomicU32::new(0));
    runner()
        .run(&strategy, |value| {
            total.fetch_add(1, Relaxed);
            accepted.fetch_add(check(&bytes(&value))? as u32, Relaxed);
            Ok(())
        })
        .unwrap();
    eprintln!("{name}: {} cases, {} accepted", total.into_inner(), accepted.into_inner());
}

#[test]
fn random_height_files_are_read_or_refused() {
    run("random height files", csv_text(), |text| text.as_bytes().to_vec());
}

#[test]
fn mutated_height_files_are_read_or_refused() {
    run("mutated height files", mutated_csv(), |bytes| bytes.clone());
}

/// The minimal failing input of `random_height_files_are_read_or_refused`
/// (a seed in about 15 runs of 1000 cases): two points 1e6 mm apart across
/// the finger's range. The interval was cut into 5 um pieces over its whole
/// width, 2e8 polyline vertices, so the scenario refused a surface the
/// reader had accepted; now only the part over the range is cut.
#[test]
fn a_wide_interval_across_the_range_is_read() {
    for text in ["# height profile\nx_mm,h_mm\n0,0\n1e6,0", "x_mm,h_mm\n-1e6,-1000\n-5e-324,0\n1e6,1000"] {
        let accepted = check(text.as_bytes()).unwrap_or_else(|e| panic!("{text:?}: {e}"));
        assert!(accepted, "{text:?} refused");
    }
}
