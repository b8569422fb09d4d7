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

# Debian packages the tests need, installed as root when missing: one
# `apt-get update` for all of them, and no service started by the packages'
# scripts (the tests start their own daemons; in a container without
# policy-rc.d, slurmctld's would fail the install for want of a slurm.conf).
APT_UPDATED=
apt_install() {
    local policy=/usr/sbin/policy-rc.d added= status=0
    if [ ! -e "$policy" ]; then
        printf '#!/bin/sh\n# scripts/test.sh: no service starts during its apt-get install\nexit 101\n' >"$policy"
        chmod 755 "$policy"
        added=1
    fi
    if [ -z "$APT_UPDATED" ]; then
        apt-get update -qq >/dev/null || status=$?
        APT_UPDATED=1
    fi
    [ "$status" = 0 ] && { DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null || status=$?; }
    [ -z "$added" ] || rm -f "$policy"
    return "$status"
}
can_apt() { [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; }

# The web GUI's browser test (crates/haptex-server/tests/browser.rs) drives
# Debian's headless Chromium through chromedriver: install them if missing.
if ! command -v chromium >/dev/null 2>&1 || ! command -v chromedriver >/dev/null 2>&1; then
    if can_apt; then
        echo "scripts/test.sh: installing chromium and chromium-driver for the browser test" >&2
        apt_install chromium chromium-driver
    else
        echo "scripts/test.sh: the browser test needs Debian's chromium and chromium-driver (as root:" \
            "apt-get install chromium chromium-driver); HAPTEX_BROWSER_TEST=skip skips it" >&2
    fi
fi

# The Slurm test (crates/haptex-cli/tests/slurm_cli.rs) builds a database as
# an sbatch job array on a single-node cluster of Debian's munge, slurmctld
# and slurmd that it starts itself (scripts/slurm-cluster.sh, as root).
# Without them, or not as root, the test says why and is skipped.
if ! command -v slurmctld >/dev/null 2>&1 || ! command -v slurmd >/dev/null 2>&1 \
    || ! command -v sbatch >/dev/null 2>&1 || ! command -v munged >/dev/null 2>&1; then
    if can_apt; then
        echo "scripts/test.sh: installing munge, slurmctld, slurmd and slurm-client for the Slurm test" >&2
        apt_install --no-install-recommends munge slurmctld slurmd slurm-client
    else
        echo "scripts/test.sh: the Slurm test needs root and Debian's munge, slurmctld, slurmd and" \
            "slurm-client (apt-get install munge slurmctld slurmd slurm-client); it is skipped without them" >&2
    fi
fi

# `haptex live` (crates/haptex-cli/tests/live_cli.rs) streams to a real ALSA
# device, ALSA's file plugin over the null PCM (both built into libasound),
# through cpal, whose ALSA backend needs Debian's libasound2-dev (and
# pkg-config) to build: the `live` feature of haptex-cli is enabled when
# they are there, installed as root when missing. Without them the live
# tests are skipped, and this says so.
if ! { command -v pkg-config >/dev/null 2>&1 && pkg-config --exists alsa; }; then
    if can_apt; then
        echo "scripts/test.sh: installing pkg-config and libasound2-dev for the live audio output tests" >&2
        apt_install --no-install-recommends pkg-config libasound2-dev || true
    fi
fi
LIVE_FEATURE=()
if command -v pkg-config >/dev/null 2>&1 && pkg-config --exists alsa; then
    LIVE_FEATURE=(--features haptex-cli/live)
else
    echo "scripts/test.sh: SKIPPING the live audio output tests (haptex live on an ALSA device): cpal's ALSA" \
        "backend needs pkg-config and libasound2-dev (alsa.pc), which are missing and could not be installed" \
        "(as root: apt-get install pkg-config libasound2-dev). The rest of the suite runs without the live feature." >&2
fi

# The OpenAPI description of the web API is validated against the OpenAPI
# 3.1 schema (crates/haptex-server/tests/api.rs) with openapi-spec-validator.
python3 -m pip install --quiet --disable-pip-version-check openapi-spec-validator==0.9.0

cargo fmt --all -- --check
cargo clippy --workspace --all-targets --locked -- -D warnings
if [ "${#LIVE_FEATURE[@]}" -gt 0 ]; then
    cargo clippy --workspace --all-targets --locked "${LIVE_FEATURE[@]}" -- -D warnings
fi
# The web GUI's pure JavaScript modules (format, validation, recipe links,
# interpolation, ...) have unit tests run by Node's built-in test runner
# (node:test, Node 18 or later; no npm package): Debian's nodejs, installed
# as root when missing. Without it they are skipped, and this says so.
if ! command -v node >/dev/null 2>&1 && can_apt; then
    echo "scripts/test.sh: installing nodejs for the web GUI's JavaScript unit tests" >&2
    apt_install --no-install-recommends nodejs || true
fi
NODE_MAJOR=$(node -p 'process.versions.node.split(".")[0]' 2>/dev/null || echo 0)
if [ "$NODE_MAJOR" -ge 18 ]; then
    node --test crates/haptex-server/assets/js/test/*.test.mjs
else
    echo "scripts/test.sh: SKIPPING the web GUI's JavaScript unit tests (crates/haptex-server/assets/js/test):" \
        "they need Node.js 18 or later (node --test), which is missing and could not be installed" \
        "(as root: apt-get install nodejs)." >&2
fi

status=0
cargo test --workspace --profile ci --locked --no-fail-fast "${LIVE_FEATURE[@]}" "$@" || status=$?

# The Python package (crates/haptex-py): its wheel built by maturin,
# installed into a fresh virtual environment, and its pytest suite (parity
# with the command line just built, Hypothesis properties, the
# docs/python.md example): scripts/test-python.sh. It needs CPython 3.9+
# with the venv module (Debian: python3-venv), installed as root when
# missing; the packages come from PyPI.
if ! python3 -c 'import ensurepip, venv' >/dev/null 2>&1 && can_apt; then
    echo "scripts/test.sh: installing python3-venv for the Python package's tests" >&2
    apt_install --no-install-recommends python3 python3-venv || true
fi
if python3 -c 'import ensurepip, venv, sys; assert sys.version_info >= (3, 9)' >/dev/null 2>&1; then
    HAPTEX_BIN="$PWD/target/ci/haptex" HAPTEX_FEATURES="${LIVE_FEATURE[*]}" bash scripts/test-python.sh || status=$?
else
    echo "scripts/test.sh: FAILING: the Python package's tests (scripts/test-python.sh) need CPython 3.9 or" \
        "later with the venv module, which is missing and could not be installed (as root: apt-get install" \
        "python3 python3-venv)." >&2
    status=1
fi
exit "$status"
