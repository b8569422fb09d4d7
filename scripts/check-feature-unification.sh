#!/usr/bin/env bash
# Do the Python module's dependencies compile with the features of the
# workspace's test build? (crates/haptex-workspace-hack/Cargo.toml says why
# it matters: where they differ, the wheel compiles those crates, and all
# above them, a second time.) Prints each crate whose features differ, with
# both sets, and exits 1; exits 0 when they agree. Arguments are extra cargo
# flags of the test build (scripts/test.sh passes its --features).
set -euo pipefail
cd "$(dirname "$0")/.."
features() {
    cargo tree --locked -f '{p} [{f}]' --prefix none "$@" 2>/dev/null \
        | sed -e 's/ (\*)//' -e 's/ (proc-macro)//' -e 's/ ([^)]*)//' -e 's/ \[/|[/' | sort -u
}
module=$(features -p haptex-py -e normal,build)
workspace=$(features --workspace -e normal,build,dev "$@")
differ=$(join -t'|' <(echo "$module") <(echo "$workspace") | awk -F'|' '$2 != $3 { printf "  %s: the module has %s, the test build %s\n", $1, $2, $3 }')
if [ -n "$differ" ]; then
    echo "scripts/check-feature-unification.sh: these crates compile with other features for the Python module than for the test build, so the wheel compiles them (and what depends on them) again; add the test build's features to crates/haptex-workspace-hack/Cargo.toml:" >&2
    echo "$differ" >&2
    exit 1
fi
