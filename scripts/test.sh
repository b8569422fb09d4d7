#!/usr/bin/env bash
# The whole haptex test suite: what the README's test command and CI run.
# Installs what the tests need beyond the Rust toolchain, then runs every
# test of the workspace with optimisations and debug assertions on.
set -euo pipefail
cd "$(dirname "$0")/.."

# /dev/null must be the null device. haptex once replaced any output path
# by rename, so `-o /dev/null` run as root turned it into a regular file;
# then apt-get fails and cargo's compiler probe (`rustc - --print=...`),
# reading an inherited stdin, parses stray text from it (the CI failure
# this script used to work around). Say so plainly instead of failing later.
if [ ! -c /dev/null ]; then
    echo "scripts/test.sh: /dev/null is not a character device ($(ls -l /dev/null 2>&1))." >&2
    echo "  Something replaced it (an older haptex run as root with -o /dev/null does that). Restore it as root:" >&2
    echo "  rm -f /dev/null && mknod -m 666 /dev/null c 1 3" >&2
    exit 1
fi
# Nothing here reads standard input: the suite never inherits one.
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
