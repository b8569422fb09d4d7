//! Friction-profile CSV reading: every malformed file names its line, and
//! no input makes the reader panic (fuzzed with 100 000 proptest cases).

use haptex_core::profile::{FrictionProfile, ProfileError};
use proptest::prelude::*;

fn read(text: &str) -> Result<FrictionProfile, ProfileError> {
    FrictionProfile::read_csv(text.as_bytes(), "p.csv")
}

#[test]
fn reads_mu_and_force_forms() {
    let p = read("# comment\nx_mm,mu\n0,0.5\n0.5,0.7\n").unwrap();
    assert_eq!(p.mu(), [0.5, 0.7]);
    assert_eq!(p.fn_n(), None);
    let f = read("x_mm,ft_n,fn_n\n0,0.1,0.2\n1,0.25,1\n").unwrap();
    assert_eq!(f.mu(), [0.5, 0.25]);
    assert_eq!(f.mean_fn_n(), Some(0.6));
    // A voltage profile reads back as a friction profile (extra columns ignored).
    let v = read("x_mm,mu,voltage_v\n0,1.1,70\n1,1.2,99\n").unwrap();
    assert_eq!(v.mu(), [1.1, 1.2]);
}

/// Each malformed file, the line (1-based) and column the error must name,
/// and a fragment of the message.
#[test]
fn malformed_files_name_line_and_column() {
    let cases: &[(&str, Option<u64>, Option<&str>, &str)] = &[
        ("", Some(1), None, "no header"),
        ("# only a comment\n\n", Some(2), None, "no header"),
        ("x_mm,mu\n", Some(1), Some("x_mm"), "at least 2 points"),
        ("x_mm,mu\n0,1\n", Some(1), Some("x_mm"), "at least 2 points"),
        ("x_mm,mu\n0,1\n1,abc\n", Some(3), Some("mu"), "not a number"),
        ("x_mm,mu\n0,1\n1,\n", Some(3), Some("mu"), "not a number"),
        ("x_mm,mu\n0,1\n1,NaN\n", Some(3), Some("mu"), "not a finite number"),
        ("x_mm,mu\n0,1\ninf,1\n", Some(3), Some("x_mm"), "not a finite number"),
        ("x_mm,mu\n0,1\n1,1,3\n", Some(3), None, "expected 2 fields"),
        ("x_mm,mu\n0,1\n2\n", Some(3), None, "expected 2 fields"),
        ("x_mm,mu\n0,1\n1,1\n1,2\n", Some(4), Some("x_mm"), "strictly increasing"),
        ("x_mm,mu\n# c\n\n0,1\n2,1\n1,2\n", Some(6), Some("x_mm"), "strictly increasing"),
        ("x,mu\n0,1\n1,1\n", Some(1), Some("x_mm"), "missing"),
        ("x_mm,friction\n0,1\n1,1\n", Some(1), Some("mu (or ft_n and fn_n)"), "missing"),
        ("x_mm,ft_n\n0,1\n1,1\n", Some(1), Some("fn_n"), "missing"),
        ("x_mm,ft_n,fn_n\n0,1,1\n1,1,0\n", Some(3), Some("fn_n"), "must be positive"),
        ("x_mm,ft_n,fn_n\n0,1,-2\n1,1,1\n", Some(2), Some("fn_n"), "must be positive"),
        ("x_mm,mu,mu\n0,1,1\n1,1,1\n", Some(1), Some("mu"), "twice"),
        ("x_mm,,mu\n0,1,1\n1,1,1\n", Some(1), None, "empty column name"),
        ("\n\n# c\nx_mm;mu\n0;1\n", Some(5), Some("x_mm;mu"), "separated by commas"),
        ("x_mm,mu\n0,1\n1,\u{fffd}\n", Some(3), Some("mu"), "not a number"),
    ];
    for (text, line, column, fragment) in cases {
        let err = match read(text) {
            Err(ProfileError::Table(e)) => e,
            other => panic!("{text:?}: expected a table error, got {other:?}"),
        };
        assert_eq!(err.line, *line, "{text:?}: {err}");
        assert_eq!(err.column.as_deref(), *column, "{text:?}: {err}");
        let message = err.to_string();
        assert!(message.starts_with("p.csv"), "{message}");
        if let Some(line) = line {
            assert!(message.contains(&format!("line {line}")), "{message}");
        }
        assert!(message.contains(fragment), "{text:?}: {message}");
    }
}

#[test]
fn invalid_utf8_is_an_error_not_a_panic() {
    let bytes = b"x_mm,mu\n0,1\n1,\xff\xfe\n";
    let err = FrictionProfile::read_csv(&bytes[..], "p.csv").unwrap_err();
    assert!(err.to_string().contains("line 3"), "{err}");
}

/// Text that looks like a profile file: tokens that are numbers, near-numbers
/// and junk, joined by commas, newlines and comment markers.
fn csv_like() -> impl Strategy<Value = String> {
    let token = prop_oneof![
        Just("x_mm".to_string()),
        Just("mu".to_string()),
        Just("ft_n".to_string()),
        Just("fn_n".to_string()),
        Just(String::new()),
        Just("NaN".to_string()),
        Just("-inf".to_string()),
        Just("1e400".to_string()),
        Just("\"2\"".to_string()),
        (-5.0f64..5.0).prop_map(|v| v.to_string()),
        (0u32..20).prop_map(|v| v.to_string()),
        "[ -~]{0,4}",
    ];
    let sep = prop_oneof![Just(","), Just("\n"), Just("\r\n"), Just("\n#"), Just(" "), Just(";")];
    prop::collection::vec((token, sep), 0..24).prop_map(|parts| parts.into_iter().map(|(t, s)| t + s).collect())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 100_000, failure_persistence: None, ..ProptestConfig::default() })]

    /// Fuzz: 100 000 generated files (CSV-like text and raw bytes). The reader
    /// never panics; an accepted profile is valid; every error except "no
    /// header" names a line.
    #[test]
    fn fuzz_profile_reader(text in csv_like(), raw in prop::collection::vec(any::<u8>(), 0..40), use_raw in any::<bool>()) {
        let bytes = if use_raw { raw } else { text.into_bytes() };
        match FrictionProfile::read_csv(&bytes[..], "f.csv") {
            Ok(p) => {
                prop_assert!(p.len() >= 2);
                prop_assert!(p.x_mm().windows(2).all(|w| w[1] > w[0]));
                prop_assert!(p.mu().iter().all(|m| m.is_finite()));
            }
            Err(ProfileError::Table(e)) => {
                prop_assert!(e.line.is_some(), "{}", e);
            }
            Err(other) => prop_assert!(false, "unexpected error kind: {other}"),
        }
    }
}
