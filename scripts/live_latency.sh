#!/usr/bin/env bash
# Touch-to-output latency of `haptex live` and `haptex serve --live` on a
# paced ALSA device: ALSA's jack plugin into a JACK server running its dummy
# driver (real-time paced, no hardware). BENCHMARKS.md, "Live output".
#
# Needs Debian's jackd2 and libasound2-plugins (apt-get install jackd2
# libasound2-plugins), python3 with `websockets` (pip install websockets)
# and a release build with the live feature:
#   cargo build --release -p haptex-cli --features live
# Usage: scripts/live_latency.sh FRAMES [RUNS]   (FRAMES: 256, 128, ...)
set -euo pipefail
FRAMES=${1:?give the buffer size in frames}
RUNS=${2:-3}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
HAPTEX=$ROOT/target/release/haptex
WORK=$(mktemp -d)
# The JACK server is waited for, not only signalled: a run right after
# this one (bench-all runs 256 then 128 frames) otherwise finds the old
# server still holding the default server's name, and its own fails to start.
trap 'kill "${JACKD:-}" "${SERVE:-}" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$WORK"' EXIT
cd "$WORK"
cat > .asoundrc <<'RC'
pcm.jackout {
    type jack
    playback_ports { 0 system:playback_1 1 system:playback_2 }
    hint { show on description "JACK dummy driver (paced)" }
}
RC
export HOME=$WORK JACK_NO_AUDIO_RESERVATION=1
jackd --no-realtime -d dummy -r 48000 -p "$FRAMES" -P 2 -C 0 >jackd.log 2>&1 &
JACKD=$!
sleep 2
if ! kill -0 "$JACKD" 2>/dev/null; then
    echo "live_latency.sh: jackd did not start:" >&2
    cat jackd.log >&2
    exit 1
fi
printf 'x_mm,voltage_v\n0,40\n10,80\n' > u.csv
# 5 s of touches at 120 Hz: x = 5 + 4 sin(2 pi t) mm.
python3 -c 'import math
print("t_s,x_mm")
for k in range(601): print(f"{k/120!r},{5+4*math.sin(2*math.pi*k/120)!r}")' > log.csv

OUT=(--device jackout --channels 2 --sample-rate 48000 --buffer-frames "$FRAMES")
for r in $(seq "$RUNS"); do
    "$HAPTEX" live --profile u.csv --touch-log log.csv "${OUT[@]}" --json "log-$r.json" -q
    python3 "$ROOT/scripts/live_feed.py" stdin 4 | "$HAPTEX" live --profile u.csv --stdin "${OUT[@]}" --json "stdin-$r.json" -q
done
"$HAPTEX" serve --addr 127.0.0.1:0 --live "${OUT[@]}" 2>serve.log &
SERVE=$!
for _ in $(seq 50); do grep -q "open http://" serve.log && break; sleep 0.1; done
ADDR=$(sed -n 's|.*open http://\([^/]*\)/.*|\1|p' serve.log)
for r in $(seq "$RUNS"); do python3 "$ROOT/scripts/live_feed.py" "ws://$ADDR/api/live/ws" 4 > "ws-$r.json"; done
kill -TERM "$SERVE"; wait "$SERVE" || true; SERVE=
python3 - "$FRAMES" <<'PY'
import glob, json, sys
frames = sys.argv[1]
print(f"48 kHz, {frames}-frame buffers; ms")
for kind in ("log", "stdin"):
    for p in sorted(glob.glob(f"{kind}-*.json")):
        r = json.load(open(p)); ms = lambda k: r[k] * 1e3
        print(f"{kind:5} render mean {ms('render_latency_mean_s'):.2f} max {ms('render_latency_max_s'):.2f}, queue max "
              f"{ms('queue_wait_max_s'):.2f}, buffer {ms('output_latency_max_s'):.2f}, sum {ms('touch_to_output_max_s'):.2f}; "
              f"{r['callback_ns_per_frame']:.1f} ns/frame, CPU {100 * r['cpu_fraction']:.2f}%, xruns {r['xruns']}")
for p in sorted(glob.glob("ws-*.json")):
    r = json.load(open(p))
    print(f"ws    render mean {r['render_latency_mean_ms']:.2f} max {r['render_latency_max_ms']:.2f}, queue max "
          f"{r['queue_wait_max_ms']:.2f}, buffer {r['output_latency_max_ms']:.2f}, sum {r['touch_to_output_max_ms']:.2f}; "
          f"underruns {r['underruns']}")
PY
