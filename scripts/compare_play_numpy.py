#!/usr/bin/env python3
"""`haptex play` side by side with the NumPy formulation of the same render.

The work (issue 20): a voltage profile U(x) (haptex voltage of the bump
example) played along a finger trajectory (t_s,x_mm at 1 kHz, back-and-forth
minimum-jerk strokes over 0..10 mm, DURATION seconds) at 48 kHz on a 1 kHz
sine carrier, clamped at U_max = 100 V, written as a pcm16 WAV whose full
scale is sqrt(2) U_max.

- haptex: `haptex play --profile U.csv --trajectory T.csv -o S.wav -q`, timed
  from outside (wall time of the whole process: start, reading both CSVs,
  the render, the safety report, the WAV with its scale chunk and hash,
  the JSON sidecar).
- NumPy: the obvious vector code for the same chain: read both CSVs
  (np.loadtxt), x(t) by np.interp, U(x) by np.interp, np.minimum(U, U_max),
  sqrt(2) U sin(2 pi f t), the peak and RMS, int16 codes by np.rint, the WAV
  written by the standard library's `wave`. Timed in-process, twice: the
  whole chain, and without the CSV reading (the stricter figure).

The two sides run alternately ROUNDS times; the best of each is kept. Prints
JSON with samples per second and the ratios (above 1: haptex faster), and
the largest difference between the two WAVs' codes (exits non-zero above 1
code: the two round the same values the same way up to ties and the last
bits of the sine).

Usage: python3 scripts/compare_play_numpy.py [--duration 60] [--rounds 5]
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time
import wave

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
FS, F_CARRIER, U_MAX = 48_000, 1000.0, 100.0


def trajectory(duration_s):
    t = np.arange(0.0, duration_s + 1e-9, 1e-3)
    phase = t % 1.0
    s = 10.0 * phase ** 3 * (10.0 - 15.0 * phase + 6.0 * phase * phase)
    x = np.where((t // 1.0).astype(int) % 2 == 0, s, 10.0 - s)
    return t, x


def numpy_play(profile_csv, trajectory_csv, out_wav, read=True, data=None):
    if read:
        p = np.loadtxt(profile_csv, delimiter=",", comments="#", skiprows=2)
        tr = np.loadtxt(trajectory_csv, delimiter=",", skiprows=1)
        xp, up = p[:, 0], p[:, -1]
        tt, xt = tr[:, 0], tr[:, 1]
    else:
        xp, up, tt, xt = data
    n = int(np.floor((tt[-1] - tt[0]) * FS)) + 1
    t = tt[0] + np.arange(n) / FS
    x = np.interp(t, tt, xt)
    u = np.minimum(np.interp(x, xp, up), U_MAX)
    s = u * (np.sqrt(2.0) * np.sin(2.0 * np.pi * F_CARRIER * np.arange(n) / FS))
    peak, rms = float(np.abs(s).max()), float(np.sqrt(np.mean(s * s)))
    full = np.sqrt(2.0) * U_MAX
    codes = np.rint(np.clip(s * (32767.0 / full), -32767.0, 32767.0)).astype("<i2")
    with wave.open(out_wav, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(FS)
        w.writeframes(codes.tobytes())
    return n, peak, rms


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=60.0)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    subprocess.run(["cargo", "build", "--quiet", "--release", "-p", "haptex-cli"], cwd=ROOT, check=True)
    haptex = str(ROOT / "target" / "release" / "haptex")
    with tempfile.TemporaryDirectory() as tmp:
        u_csv, t_csv = os.path.join(tmp, "u.csv"), os.path.join(tmp, "t.csv")
        hx_wav, np_wav = os.path.join(tmp, "hx.wav"), os.path.join(tmp, "np.wav")
        subprocess.run([haptex, "voltage", "--profile", str(ROOT / "data" / "examples" / "bump_friction.csv"),
                        "-o", u_csv, "-q"], check=True)
        t, x = trajectory(args.duration)
        np.savetxt(t_csv, np.column_stack([t, x]), delimiter=",", header="t_s,x_mm", comments="", fmt="%.17g")
        p = np.loadtxt(u_csv, delimiter=",", comments="#", skiprows=2)
        data = (p[:, 0], p[:, -1], t, x)
        best = {"haptex": float("inf"), "numpy": float("inf"), "numpy_without_reading": float("inf")}
        n = None
        for _ in range(args.rounds):
            start = time.perf_counter()
            subprocess.run([haptex, "play", "--profile", u_csv, "--trajectory", t_csv, "-o", hx_wav, "-q"], check=True)
            best["haptex"] = min(best["haptex"], time.perf_counter() - start)
            start = time.perf_counter()
            n, _, _ = numpy_play(u_csv, t_csv, np_wav)
            best["numpy"] = min(best["numpy"], time.perf_counter() - start)
            start = time.perf_counter()
            numpy_play(u_csv, t_csv, np_wav, read=False, data=data)
            best["numpy_without_reading"] = min(best["numpy_without_reading"], time.perf_counter() - start)
        with wave.open(hx_wav) as w:
            hx = np.frombuffer(w.readframes(w.getnframes()), dtype="<i2").astype(int)
        with wave.open(np_wav) as w:
            npc = np.frombuffer(w.readframes(w.getnframes()), dtype="<i2").astype(int)
        difference = int(np.abs(hx - npc).max()) if len(hx) == len(npc) else None
        result = {
            "samples": n,
            "seconds": best,
            "samples_per_second": {k: n / v for k, v in best.items()},
            "ratio_numpy_over_haptex": best["numpy"] / best["haptex"],
            "ratio_numpy_without_reading_over_haptex": best["numpy_without_reading"] / best["haptex"],
            "max_code_difference": difference,
            "numpy": np.__version__,
        }
        print(json.dumps(result))
        sys.exit(0 if difference is not None and difference <= 1 else 1)


if __name__ == "__main__":
    main()
