//! Issue 35, "the test suite is deterministic": a fresh clone's CI failed
//! on a property test whose random seed of that run found a case nobody had
//! changed (two gains equal to rounding compared strictly), and the failing
//! binary stopped the rest of the suite. Every property test of the suite
//! now draws its cases from one fixed seed, set for every process cargo
//! runs by `.cargo/config.toml` (`[env] PROPTEST_RNG_SEED`, overridable);
//! the exploratory random runs are `scripts/proptest-random.sh`, part of
//! the fuzz campaign. These tests fail when the seed is not fixed.

use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config, RngSeed, TestRunner};

/// The values one property test would draw, with the configuration every
/// `proptest!` block of the suite starts from.
fn drawn() -> Vec<(f64, u64)> {
    let mut runner = TestRunner::new(Config::default());
    let strategy = (-1e3..1e3f64, any::<u64>());
    (0..32).map(|_| strategy.new_tree(&mut runner).unwrap().current()).collect()
}

#[test]
fn the_test_suite_is_deterministic() {
    let seed = std::env::var("PROPTEST_RNG_SEED")
        .expect("PROPTEST_RNG_SEED is not set: run the suite through cargo, whose .cargo/config.toml sets it");
    let seed: u64 = seed.parse().expect("PROPTEST_RNG_SEED is a u64");
    assert_eq!(Config::default().rng_seed, RngSeed::Fixed(seed), "proptest does not read the fixed seed");
    let (first, second) = (drawn(), drawn());
    assert_eq!(first, second, "two runners with the default configuration drew different cases");
}

/// The committed seed is the one CI runs with, unless a run overrides it
/// on purpose (`scripts/proptest-random.sh` exports its own).
#[test]
fn the_committed_seed_is_overridable_only_on_purpose() {
    let config = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../.cargo/config.toml")).unwrap();
    let line = config.lines().find(|l| l.starts_with("PROPTEST_RNG_SEED")).expect("the seed line");
    assert!(line.contains("force = false"), "an explicit PROPTEST_RNG_SEED must win: {line}");
    let committed: u64 = line.split('"').nth(1).and_then(|v| v.parse().ok()).expect("a u64 seed");
    if std::env::var_os("HAPTEX_PROPTEST_EXPLORING").is_none() {
        assert_eq!(std::env::var("PROPTEST_RNG_SEED").unwrap(), committed.to_string());
    }
}
