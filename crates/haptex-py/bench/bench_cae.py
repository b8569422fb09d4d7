"""Call overhead of haptex.Cae from Python, against the same prediction
timed in Rust in the same process (issue 38: one query through Python
within 2 us of Rust; a batched call for many queries).

Run from the repository root with the package installed (README, "From
Python"):

    python crates/haptex-py/bench/bench_cae.py

The model is the shipped FE database's bump template (405 FE profiles of
501 points; inputs r_w, r_h, velocity) at its own widths; the queries are
spread over the database's range. Prints one Markdown table row per
figure (best of 7 rounds, each long enough to take ~0.2 s).
"""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import numpy as np

import haptex
from haptex import _haptex

REPO = Path(__file__).resolve().parents[3]


def best_per_call(fn, calls: int, rounds: int = 7) -> float:
    best = float("inf")
    for _ in range(rounds):
        start = time.perf_counter()
        fn(calls)
        best = min(best, (time.perf_counter() - start) / calls)
    return best


def main() -> None:
    metadata = json.loads((REPO / "data/db/metadata.json").read_text())
    bump = next(t for t in metadata["templates"] if t["template"] == "bump")
    cae = haptex.Cae.read_csv(
        REPO / "data/db/bump.csv",
        ["r_w_mm", "r_h_mm", "velocity_mm_s"],
        widths=(bump["widths"]["w_min"], bump["widths"]["w_max"]),
    )
    rng = np.random.default_rng(38)
    queries = np.column_stack(
        [rng.uniform(0.5, 2.5, 4096), rng.uniform(0.1, 0.5, 4096), rng.uniform(10.0, 50.0, 4096)]
    )
    q = queries[0].copy()
    # Both sides compute the same bits.
    assert np.array_equal(cae.predict(q), cae.predict_batch(q[None, :])[0])

    def python_one(n: int) -> None:
        predict = cae.predict
        for _ in range(n):
            predict(q)

    # Rounds alternate between the two sides, so that a slower moment of
    # the machine falls on both; each side's best round is reported.
    calls = max(1, int(0.2 / _haptex._bench_rust_predict(cae, q, 200)))
    rust_one, py_one = float("inf"), float("inf")
    for _ in range(7):
        rust_one = min(rust_one, _haptex._bench_rust_predict(cae, q, calls))
        py_one = min(py_one, best_per_call(python_one, calls, rounds=1))

    rows = [("one query", 1, py_one, rust_one)]
    for k in (64, 4096):
        batch = queries[:k]
        reps = max(1, int(0.2 / _haptex._bench_rust_predict_batch(cae, batch, 1)))
        rust, py = float("inf"), float("inf")
        for _ in range(7):
            rust = min(rust, _haptex._bench_rust_predict_batch(cae, batch, reps))
            py = min(py, best_per_call(lambda n: [cae.predict_batch(batch) for _ in range(n)], reps, rounds=1))
        rows.append((f"batch of {k}", k, py, rust))

    print(f"# haptex {haptex.__version__}, Python {platform.python_version()}, NumPy {np.__version__}")
    print(f"# model: {cae!r}")
    print("| call | queries | Python (us) | Rust (us) | Python - Rust (us) | per query, Python (us) |")
    print("|---|---|---|---|---|---|")
    for name, k, py, rust in rows:
        print(f"| {name} | {k} | {py * 1e6:.2f} | {rust * 1e6:.2f} | {(py - rust) * 1e6:.2f} | {py / k * 1e6:.3f} |")


if __name__ == "__main__":
    main()
