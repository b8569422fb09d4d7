#!/usr/bin/env bash
# The fuzz campaign over every haptex parser (RELIABILITY.md): builds the
# cargo-fuzz targets of fuzz/ (libFuzzer, coverage guided, no sanitizer),
# runs each for RUNS executions starting from the committed seeds
# (fuzz/seeds/TARGET), then replays every corpus with a timer to check that
# no input costs more than linear time. Not part of the test suite (it
# takes tens of minutes); its figures are in RELIABILITY.md.
#
#   bash scripts/fuzz-campaign.sh              # every target, 200 000 runs each
#   RUNS=1000000 bash scripts/fuzz-campaign.sh profile_csv model_matrix
#
# Needs cargo-fuzz (`cargo install cargo-fuzz --locked`) and a C++ compiler
# (g++) for libFuzzer. A crash stops the script with libFuzzer's report; the
# input that caused it is in fuzz/artifacts/TARGET/.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"
RUNS=${RUNS:-200000}
MAX_LEN=${MAX_LEN:-65536}
# cargo-fuzz passes flags that stable rustc accepts only with this set.
export RUSTC_BOOTSTRAP=1
if ! command -v cargo-fuzz >/dev/null 2>&1; then
    echo "scripts/fuzz-campaign.sh: needs cargo-fuzz: cargo install cargo-fuzz --locked" >&2
    exit 1
fi
if [ "$#" -gt 0 ]; then targets=("$@"); else mapfile -t targets < <(ls fuzz_targets | sed 's/\.rs$//'); fi
mkdir -p logs
total=0
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t"
    start=$(date +%s)
    cargo fuzz run -s none -O -a "$t" "corpus/$t" "seeds/$t" -- \
        -runs="$RUNS" -max_len="$MAX_LEN" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
        >"logs/$t.log" 2>&1 || { tail -40 "logs/$t.log"; echo "fuzz target $t failed (log: fuzz/logs/$t.log)" >&2; exit 1; }
    runs=$(grep -o 'Done [0-9]* runs' "logs/$t.log" | tail -1 | grep -o '[0-9]*')
    secs=$(( $(date +%s) - start ))
    total=$(( total + runs ))
    echo "$t: $runs executions in ${secs} s, corpus $(ls "corpus/$t" | wc -l) inputs, no crash"
done
echo "total: $total executions"
echo "replaying every corpus with a timer (linear-time check):"
cargo run --quiet --release --example replay -- corpus
