#!/usr/bin/env python3
"""haptex's CAE side by side with NumPy, one query at a time and batched.

Two cases (issue 20):

- "shipped bump": the shipped FE database's bump model matrix
  (data/db/bump.csv: N = 135 rows, inputs r_w, r_h, velocity, M = 101
  outputs) with its leave-one-out width from data/db/metadata.json;
- "synthetic 405": the seeded 405 x (4 + 500) matrix of the statsmodels
  comparison (a 9 x 5 x 3 x 3 grid), width 0.13.

NumPy computes eqs. (11)-(12) with a constant width as the obvious vector
code: squared normalized distances, log weights less their maximum, exp,
weights normalized, weights @ outputs; one query at a time (a loop of
vector operations) and batched (one (Q x N) @ (N x M) matrix product).
haptex is the `cae_timing` example, which times `Cae::predict_into` per
query, `Cae::predict_batch_into` over all queries on one thread and
`Cae::predict_batch` on rayon's threads. NumPy's matrix product uses
OpenBLAS's threads (all cores by default); for a one-thread comparison
run with OPENBLAS_NUM_THREADS=1 RAYON_NUM_THREADS=1. Each side is timed
as the best of REPEATS passes; the two sides run alternately ROUNDS times
and the best of each is kept, so both see the same machine state.

Prints one JSON object per case with the times per query, the ratios
(NumPy time / haptex time: above 1 means haptex is faster) and the largest
relative difference of the predictions; exits non-zero if they differ by
more than 1e-12 relative.

Usage: python3 scripts/compare_cae_numpy.py [--queries 1000] [--rounds 3]
Needs numpy (python3 -m pip install numpy).
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent


def read_model(path, n_inputs):
    lines = [l for l in open(path) if not l.startswith("#")]
    names = lines[0].strip().split(",")
    data = np.array([[float(v) for v in l.split(",")] for l in lines[1:]])
    return names, data[:, :n_inputs], data[:, n_inputs:]


def synthetic():
    grid = np.array([(0.5 + 0.25 * i, 0.1 + 0.1 * j, 10.0 + 20.0 * k, 0.4 + 0.1 * l)
                     for i in range(9) for j in range(5) for k in range(3) for l in range(3)])
    x = np.linspace(0.0, 10.0, 500)
    rw, rh, v, mu = (grid[:, c:c + 1] for c in range(4))
    u = (x[None, :] - 5.0) / rw
    outputs = mu * (1.0 - 0.6 * rh * u * np.exp(-u * u) * (1.0 + 0.002 * v))
    names = ["r_w", "r_h", "v", "mu"] + [f"c{k}" for k in range(500)]
    return names, grid, outputs


def write_csv(path, names, values):
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for row in values:
            f.write(",".join(repr(float(v)) for v in row) + "\n")


class NumpyCae:
    """Eqs. (11)-(12), constant width w in normalized units."""

    def __init__(self, inputs, outputs, w):
        self.lo = inputs.min(0)
        span = inputs.max(0) - self.lo
        self.keep = span > 0
        self.span = np.where(self.keep, span, 1.0)
        self.x = ((inputs - self.lo) / self.span)[:, self.keep]
        self.c = np.ascontiguousarray(outputs)
        self.inv2w2 = 1.0 / (2.0 * w * w)

    def one(self, q):
        b = ((q - self.lo) / self.span)[self.keep]
        e = -((self.x - b) ** 2).sum(1) * self.inv2w2
        a = np.exp(e - e.max())
        return (a / a.sum()) @ self.c

    def batch(self, queries):
        b = ((queries - self.lo) / self.span)[:, self.keep]
        d2 = (b * b).sum(1)[:, None] - 2.0 * b @ self.x.T + (self.x * self.x).sum(1)[None, :]
        e = -np.maximum(d2, 0.0) * self.inv2w2
        a = np.exp(e - e.max(1, keepdims=True))
        a /= a.sum(1, keepdims=True)
        return a @ self.c


def best_of(repeats, f):
    best = float("inf")
    out = None
    for _ in range(repeats):
        t = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t)
    return best, out


def run_case(label, names, inputs, outputs, width, n_queries, rounds, example, tmp):
    d = inputs.shape[1]
    rng = np.random.default_rng(20)
    lo, hi = inputs.min(0), inputs.max(0)
    queries = lo + (hi - lo) * rng.uniform(0.0, 1.0, size=(n_queries, d))
    model_csv, query_csv, out_csv = (os.path.join(tmp, f"{label}-{s}.csv") for s in ("model", "queries", "out"))
    write_csv(model_csv, names, np.hstack([inputs, outputs]))
    write_csv(query_csv, names[:d], queries)
    np_cae = NumpyCae(inputs, outputs, width)
    repeats_hx = 20
    repeats_np = 3
    best = {"haptex_one": float("inf"), "haptex_batch": float("inf"), "haptex_batch_parallel": float("inf"),
            "numpy_one": float("inf"), "numpy_batch": float("inf")}
    threads = None
    for _ in range(rounds):
        proc = subprocess.run([example, model_csv, ",".join(names[:d]), query_csv, repr(width),
                               str(repeats_hx), out_csv], check=True, capture_output=True, text=True)
        t = json.loads(proc.stdout)
        assert t["batch_max_relative_difference"] <= 1e-12, t
        best["haptex_one"] = min(best["haptex_one"], t["seconds_per_query"])
        best["haptex_batch"] = min(best["haptex_batch"], t["seconds_per_query_batch"])
        best["haptex_batch_parallel"] = min(best["haptex_batch_parallel"], t["seconds_per_query_batch_parallel"])
        threads = t["threads"]
        s, one = best_of(repeats_np, lambda: np.array([np_cae.one(q) for q in queries]))
        best["numpy_one"] = min(best["numpy_one"], s / n_queries)
        s, batch = best_of(repeats_np, lambda: np_cae.batch(queries))
        best["numpy_batch"] = min(best["numpy_batch"], s / n_queries)
    hx = np.array([[float(v) for v in l.split(",")] for l in open(out_csv).readlines()[1:]])
    difference = float(np.max(np.abs(hx - one) / np.abs(one)))
    difference_batch = float(np.max(np.abs(hx - batch) / np.abs(batch)))
    return {
        "case": label,
        "n": int(inputs.shape[0]), "d": d, "m": int(outputs.shape[1]), "queries": n_queries, "width": width,
        "seconds_per_query": best,
        "ratio_one_numpy_over_haptex": best["numpy_one"] / best["haptex_one"],
        "ratio_batch_numpy_over_haptex_one_thread": best["numpy_batch"] / best["haptex_batch"],
        "ratio_batch_numpy_over_haptex_parallel": best["numpy_batch"] / best["haptex_batch_parallel"],
        "haptex_threads": threads,
        "max_relative_difference": max(difference, difference_batch),
        "numpy": np.__version__,
        "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS", "default (all cores)"),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--queries", type=int, default=1000)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    subprocess.run(["cargo", "build", "--quiet", "--release", "-p", "haptex-core", "--example", "cae_timing"],
                   cwd=ROOT, check=True)
    example = str(ROOT / "target" / "release" / "examples" / "cae_timing")
    metadata = json.load(open(ROOT / "data" / "db" / "metadata.json"))
    entry = next(t for t in metadata["templates"] if t["template"] == "bump")
    width = entry["widths"]["w_min"]
    inputs_bump = ["r_w_mm", "r_h_mm", "velocity_mm_s"]
    _, b_in, b_out = read_model(ROOT / "data" / "db" / "bump.csv", 3)
    bump_names = inputs_bump + [f"c{k}" for k in range(b_out.shape[1])]
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        for label, names, x, c, w in [
            ("shipped bump", bump_names, b_in, b_out, width),
            ("synthetic 405", *synthetic(), 0.13),
        ]:
            result = run_case(label.replace(" ", "-"), names, x, c, w, args.queries, args.rounds, example, tmp)
            result["case"] = label
            print(json.dumps(result))
            ok &= result["max_relative_difference"] <= 1e-12
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
