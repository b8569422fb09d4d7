#!/usr/bin/env bash
# Exploratory runs of the property tests with a new random seed.
#
# The suite runs every property test deterministically: .cargo/config.toml
# fixes proptest's seed (PROPTEST_RNG_SEED), so CI never fails on a case
# nobody changed. This script is the other half: it draws a fresh seed,
# prints it, and runs the property tests with it and more cases, so that
# new inputs keep being tried. It is part of the fuzz campaign
# (RELIABILITY.md), not of the test suite. A failure is reproduced with
# the printed seed:
#
#   bash scripts/proptest-random.sh                 # one random seed
#   SEED=1234 bash scripts/proptest-random.sh       # that seed again
#   ROUNDS=10 bash scripts/proptest-random.sh       # ten seeds in a row
#
# Property tests live in haptex-core's tests, haptex-fem's element patch
# test and model/height fuzz tests, and haptex-server's streaming-route
# property test; `PROPTEST_CASES` multiplies nothing here, each test keeps
# its own case count (HAPTEX_FUZZ_CASES raises the FE fuzz tests' count).
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${ROUNDS:-1}
for ((round = 1; round <= rounds; round++)); do
    seed=${SEED:-$(od -An -N8 -tu8 /dev/urandom | tr -d ' ')}
    echo "scripts/proptest-random.sh: round $round of $rounds, PROPTEST_RNG_SEED=$seed" >&2
    export PROPTEST_RNG_SEED=$seed
    # tells deterministic_suite.rs that this seed replaces the committed one on purpose
    export HAPTEX_PROPTEST_EXPLORING=1
    cargo test --profile ci --locked -p haptex-core
    cargo test --profile ci --locked -p haptex-fem --lib --test finger_model_fuzz --test height_profile_fuzz
    cargo test --profile ci --locked -p haptex-server --lib
    # the streaming routes' property test (each case an FE check; more with
    # HAPTEX_STREAM_CASES)
    cargo test --profile ci --locked -p haptex-server --test streams
    [ -z "${SEED:-}" ] || break
done
