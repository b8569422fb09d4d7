#!/usr/bin/env bash
# The whole haptex test suite: what the README's test command and CI run.
# Installs what the tests need beyond the Rust toolchain, then runs every
# test of the workspace with optimisations and debug assertions on.
set -euo pipefail
cd "$(dirname "$0")/.."

cargo fmt --all -- --check
cargo clippy --workspace --all-targets --locked -- -D warnings
cargo test --workspace --profile ci --locked "$@"
