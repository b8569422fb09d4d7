#!/usr/bin/env bash
# The Python package's tests (crates/haptex-py): builds the wheel with
# maturin, installs it into a fresh virtual environment and runs the pytest
# suite in crates/haptex-py/pytests, whose parity tests run the command
# line beside each function. scripts/test.sh runs this after cargo test
# (which builds target/ci/haptex); alone, it builds that binary first.
# Arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
MATURIN_VERSION=1.16.0

if ! "$PYTHON" -c 'import sys; assert sys.version_info >= (3, 9)' 2>/dev/null; then
    echo "scripts/test-python.sh: the Python package needs CPython 3.9 or later as $PYTHON" >&2
    exit 1
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/haptex-python.XXXXXX")
trap 'rm -rf "$work"' EXIT
# One fresh environment: maturin, then the wheel and what the tests import
# (--no-compile: modules are byte-compiled when first imported, not all of
# NumPy, Matplotlib and mypy at install time).
"$PYTHON" -m venv "$work/env"
"$work/env/bin/pip" install --quiet --disable-pip-version-check --no-compile "maturin==$MATURIN_VERSION" \
    -r crates/haptex-py/pytests/requirements.txt

# The wheel is built in scripts/test.sh's ci profile (optimised, as the tests
# are), reusing cargo test's compiled dependencies: crates/haptex-workspace-hack
# gives the module's build the features the test build unifies. Where they
# have drifted apart, this says which crates compile twice (a slower build,
# not a wrong one). HAPTEX_FEATURES: the test build's extra cargo flags.
bash scripts/check-feature-unification.sh ${HAPTEX_FEATURES:-} || true
# HAPTEX_BIN given (scripts/test.sh: the binary its cargo test built, with
# its features) is the command line the parity tests run; else it is built.
if [ -z "${HAPTEX_BIN:-}" ]; then
    cargo build --profile ci --locked -p haptex-cli --bin haptex
    HAPTEX_BIN="$PWD/target/ci/haptex"
fi
"$work/env/bin/maturin" build --quiet --profile ci --locked -m crates/haptex-py/Cargo.toml -o "$work/wheels"
"$work/env/bin/pip" install --quiet --disable-pip-version-check --no-deps --no-compile "$work"/wheels/haptex-*.whl

# From outside the source tree: `import haptex` is the installed wheel.
HAPTEX_BIN="$HAPTEX_BIN" "$work/env/bin/python" -m pytest -q -p no:cacheprovider \
    --rootdir crates/haptex-py/pytests crates/haptex-py/pytests "$@"
