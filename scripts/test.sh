#!/usr/bin/env bash
# The whole haptex test suite: what the README's test command and CI run.
# Installs what the tests need beyond the Rust toolchain, then runs every
# test of the workspace with optimisations and debug assertions on.
set -euo pipefail
cd "$(dirname "$0")/.."

# Nothing here reads standard input. Cargo's compiler probe (`rustc -
# --print=...`) has been seen to read an inherited stdin in CI and fail
# parsing whatever text was there, so the suite never inherits one.
exec </dev/null

# The web GUI's browser test (crates/haptex-server/tests/browser.rs) drives
# Debian's headless Chromium through chromedriver: install them if missing.
if ! command -v chromium >/dev/null 2>&1 || ! command -v chromedriver >/dev/null 2>&1; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "scripts/test.sh: installing chromium and chromium-driver for the browser test" >&2
        apt-get update -qq >/dev/null
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null
    else
        echo "scripts/test.sh: the browser test needs Debian's chromium and chromium-driver (as root:" \
            "apt-get install chromium chromium-driver); HAPTEX_BROWSER_TEST=skip skips it" >&2
    fi
fi

# The OpenAPI description of the web API is validated against the OpenAPI
# 3.1 schema (crates/haptex-server/tests/api.rs) with openapi-spec-validator.
python3 -m pip install --quiet --disable-pip-version-check openapi-spec-validator==0.9.0

cargo fmt --all -- --check
cargo clippy --workspace --all-targets --locked -- -D warnings
cargo test --workspace --profile ci --locked "$@"
