#!/usr/bin/env bash
# Re-measures every figure of BENCHMARKS.md in one run, on this machine,
# one step after another (nothing in parallel: the steps would share the
# cores and time each other). Writes each step's full output to
# OUT/NN-name.txt and the machine (lscpu, commit, date, load) to
# OUT/00-machine.txt; BENCHMARKS.md's "Current figures" table is read off
# these files.
#
# Needs: the Rust toolchain; Debian's hyperfine, wrk, time, jackd2,
# libasound2-plugins and libasound2-dev (for the live feature); Python 3
# with numpy, scipy, statsmodels and websockets:
#   sudo apt-get install hyperfine wrk time jackd2 libasound2-plugins libasound2-dev
#   python3 -m pip install numpy scipy statsmodels websockets
# Usage: scripts/bench-all.sh [OUT]   (default: bench-runs/DATE; about 35 min
# on 2 cores, most of it the criterion benches, the database build and the FE
# robustness matrix)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
OUT=${1:-bench-runs/$(date -u +%Y-%m-%dT%H%M)}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
WORK=$(mktemp -d)
SERVE=
trap 'kill $SERVE 2>/dev/null || true; rm -rf "$WORK"' EXIT
HAPTEX=$ROOT/target/release/haptex

step() { # step NAME COMMAND...: runs COMMAND, its output to OUT/NAME.txt
    local name=$1
    shift
    echo "== $name ($(date -u +%H:%M:%S), load $(cut -d' ' -f1-3 /proc/loadavg))"
    {
        echo "# $(date -u +%Y-%m-%dT%H:%M:%SZ), load $(cut -d' ' -f1-3 /proc/loadavg)"
        echo "# $*"
        "$@"
    } > "$OUT/$name.txt" 2>&1 || echo "   failed: see $OUT/$name.txt"
}

{
    date -u +%Y-%m-%dT%H:%M:%SZ
    git rev-parse HEAD
    git status --short | head -20
    lscpu | grep -E "Model name|CPU family|Model:|^CPU\(s\)|L1d|L2|L3"
    rustc --version
    uptime
} > "$OUT/00-machine.txt"

cargo build --release -p haptex-cli --features live

# Criterion, every bench of the workspace.
for bench in cae:haptex-core database:haptex-core voltage:haptex-core combined:haptex-core \
    realtime:haptex-core recording:haptex-core simulate:haptex-fem render:haptex-fem; do
    step "10-criterion-${bench%%:*}" cargo bench -p "${bench#*:}" --bench "${bench%%:*}"
done
# One query against the streaming floor, timed in turns in one process;
# three processes, since where a process's memory lands moves the floor.
for run in 1 2 3; do
    step "11-floor-ratio-$run" cargo bench -p haptex-core --bench floor_ratio
done

# Peers, both sides in one process or interleaved.
step 20-cae-numpy-one-thread env OPENBLAS_NUM_THREADS=1 RAYON_NUM_THREADS=1 \
    python3 scripts/compare_cae_numpy.py --queries 1000 --rounds 3
step 21-cae-numpy-both-cores python3 scripts/compare_cae_numpy.py --queries 1000 --rounds 3
step 22-play-numpy-60s python3 scripts/compare_play_numpy.py --duration 60 --rounds 5
step 23-play-numpy-10s python3 scripts/compare_play_numpy.py --duration 10 --rounds 5
step 24-cae-statsmodels python3 scripts/compare_cae_statsmodels.py

# Whole processes.
python3 - "$WORK" <<'PY'
import math, sys, zlib, struct
import numpy as np
w = sys.argv[1]
with open(f"{w}/p1e6.csv", "w") as f:  # eq. (8) input, 1e6 samples
    f.write("x_mm,mu\n")
    for i in range(1000000):
        x = i * 1e-4
        f.write(f"{x:.4f},{1.1 + 0.3 * math.sin(2 * x):.6f}\n")
with open(f"{w}/p1e6c.csv", "w") as f:  # combined display input
    f.write("x_mm,mu\n")
    for i in range(1000000):
        x = i * 1e-4
        f.write(f"{x:.4f},{0.7 + 0.6 * math.sin(2 * x):.6f}\n")
# 2000 x 2000 8-bit grayscale PNG, a product of two sines.
i = np.arange(2000)
g = (127.5 + 127.5 * np.outer(np.sin(i / 37.0), np.sin(i / 53.0))).astype(np.uint8)
raw = b"".join(b"\x00" + row.tobytes() for row in g)
def chunk(t, d):
    return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 2000, 2000, 8, 0, 0, 0, 0))
png += chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b"")
open(f"{w}/big.png", "wb").write(png)
# 60 s of a 1 kHz trajectory x = 5 + 4.5 sin(2 pi t / 2 s), on y = 1 mm for the map.
t = np.arange(60001) / 1000.0
x = 5 + 4.5 * np.sin(2 * np.pi * t / 2.0)
np.savetxt(f"{w}/t1.csv", np.c_[t, x], delimiter=",", header="t_s,x_mm", comments="", fmt="%.6f")
np.savetxt(f"{w}/t2.csv", np.c_[t, x, np.ones_like(t)], delimiter=",", header="t_s,x_mm,y_mm", comments="", fmt="%.6f")
PY
"$HAPTEX" voltage --profile data/examples/bump_friction.csv -o "$WORK/u1.csv" -q
"$HAPTEX" map from-profile --profile data/examples/bump_friction.csv --dx-mm 0.01 --dy-mm 0.5 --ny 5 -o "$WORK/fm.npy"
"$HAPTEX" map voltage --map "$WORK/fm.npy" -o "$WORK/vm.npy" > /dev/null

step 30-voltage-1e6 hyperfine -w 2 -r 10 \
    "$HAPTEX voltage --profile $WORK/p1e6.csv -o $WORK/v1e6.csv -q" \
    "$HAPTEX voltage --profile $WORK/p1e6.csv -q > /dev/null"
step 31-voltage-combined-1e6 hyperfine -w 1 -r 5 \
    "$HAPTEX voltage --profile $WORK/p1e6c.csv --display combined --strategy weighted -o $WORK/d1e6.csv -q"
step 32-map-image-to-voltage /usr/bin/time -v bash -c \
    "$HAPTEX map from-image $WORK/big.png --mu-black 0.8 --mu-white 1.3 --pixel-mm 0.01 -o $WORK/big.npy \
     && /usr/bin/time -f 'voltage step: %e s, %M KB' $HAPTEX map voltage --map $WORK/big.npy -o $WORK/bigv.npy"
step 33-map-play hyperfine -w 1 -r 10 \
    "$HAPTEX play --profile $WORK/u1.csv --trajectory $WORK/t1.csv -o $WORK/a1.wav -q" \
    "$HAPTEX play --voltage-map $WORK/vm.npy --trajectory $WORK/t2.csv -o $WORK/a2.wav -q"
step 34-play-strokes hyperfine -w 2 -r 10 \
    "$HAPTEX play --profile $WORK/u1.csv --velocity 20 --strokes 20 -o $WORK/s10.wav -q" \
    "$HAPTEX play --profile $WORK/u1.csv --velocity 20 --strokes 20 -o $WORK/s10.wav --png $WORK/s10.png -q"
step 35-library-import hyperfine -w 1 -r 10 --prepare "rm -f $WORK/lib.sqlite*" \
    "$HAPTEX library import --quiet --db $WORK/lib.sqlite data/library/demo"
step 36-simulate hyperfine -w 1 -r 5 \
    "$HAPTEX simulate --surface bump --x0 5 --width 1.5 --height 0.3 -o $WORK/b.csv -q" \
    "$HAPTEX simulate --finger data/finger/half-disc.toml --material elastic --surface bump -o $WORK/h.csv -q"
# The model matrix of the CAE benches (405 x (4 + 500), no noise), for
# `cae loo`: the synthetic case of compare_cae_numpy.py.
python3 -c "
import sys
sys.path.insert(0, 'scripts')
from compare_cae_numpy import synthetic, write_csv
import numpy as np
names, inputs, outputs = synthetic()
write_csv('$WORK/m500.csv', names, np.hstack([inputs, outputs]))
"
step 37-cae-loo hyperfine -w 1 -r 10 \
    "$HAPTEX cae loo --model $WORK/m500.csv --inputs r_w,r_h,v,mu -o $WORK/l.json" \
    "$HAPTEX cae loo --model $WORK/m500.csv --inputs r_w,r_h,v,mu --constant -o $WORK/l.json"
step 38-db-build /usr/bin/time -v "$HAPTEX" db build -q --out "$WORK/db"
# The model matrices against the shipped ones, byte for byte.
step 39-db-compare bash -c "cd data/db && for f in *.csv; do cmp \$f $WORK/db/\$f && echo \"\$f: identical\"; done"
step 39-db-merge /usr/bin/time -f '%e s wall, %M KB' "$HAPTEX" db merge --from "$WORK/db" --out "$WORK/merged"
step 39-predict hyperfine -N -w 3 -r 20 "$HAPTEX predict --surface bump --x0 5 --width 1.3 --height 0.27"

# The web server under load, then the check through its API.
"$HAPTEX" serve > "$WORK/serve.log" 2>&1 &
SERVE=$!
for _ in $(seq 100); do curl -s -o /dev/null http://127.0.0.1:8080/ && break; sleep 0.1; done
step 40-wrk-predict wrk -t2 -c32 -d30s --latency -s scripts/wrk-predict.lua http://127.0.0.1:8080/api/predict
step 41-wrk-voltage-csv wrk -t2 -c32 -d30s --latency -s scripts/wrk-voltage.lua http://127.0.0.1:8080/api/voltage
step 42-wrk-voltage-json env HAPTEX_WRK_BODY=json \
    wrk -t2 -c32 -d30s --latency -s scripts/wrk-voltage.lua http://127.0.0.1:8080/api/voltage
step 43-wrk-predict-during-uploads bash -c "
    wrk -t1 -c2 -d40s -s scripts/wrk-upload.lua http://127.0.0.1:8080/api/profile > $OUT/43-uploads.txt 2>&1 &
    sleep 3
    wrk -t2 -c32 -d30s --latency -s scripts/wrk-predict.lua http://127.0.0.1:8080/api/predict
    wait"
step 44-check-api python3 scripts/time_check_api.py -n 7
kill $SERVE
wait $SERVE 2>/dev/null || true
SERVE=
# /api/health while 12 clients send FE checks, maps and plays (issue 35):
# a fresh server each time, so that its RSS before, at peak and after is
# this load's.
for run in 1 2 3; do
    "$HAPTEX" serve > "$WORK/serve-health.log" 2>&1 &
    SERVE=$!
    for _ in $(seq 100); do curl -s -o /dev/null http://127.0.0.1:8080/api/health && break; sleep 0.1; done
    step "45-health-under-load-$run" python3 scripts/load_health.py --pid $SERVE
    kill $SERVE
    wait $SERVE 2>/dev/null || true
    SERVE=
done
# The FE's hardest inputs, one run each with its time (the robustness
# matrix, 100 runs on the suite's two test threads; issue 35's per-run goal).
step 46-fe-robustness-matrix cargo test --profile ci -p haptex-fem --test robustness_matrix -- --nocapture
# A calibration of 10 120 measurements with all its intervals (issue 36; target 2 s).
step 47-calibration cargo bench -p haptex-core --bench calibration

# Live output on a paced device (JACK's dummy driver). The peer scripts
# above rebuilt haptex without the live feature.
cargo build --release -p haptex-cli --features live
step 50-live-latency-256 scripts/live_latency.sh 256 3
step 51-live-latency-128 scripts/live_latency.sh 128 3
echo "done: $OUT"
