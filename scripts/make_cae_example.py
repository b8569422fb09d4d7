#!/usr/bin/env python3
"""Regenerates data/examples/cae_bump_model.csv, a small CAE model matrix.

It is an analytic illustration, not an FE database: for each bump width r_w
(0.5 .. 2.5 mm, step 0.25, as in the paper's section 3.1) and height r_h
(0.1 .. 0.5 mm, step 0.1) one row holds the inputs r_w_mm, r_h_mm and the
friction profile mu(x) at x = 0, 0.25, .., 10 mm (41 outputs mu_x0.00 ..
mu_x10.00), with the shape of data/examples/bump_friction.csv:

    mu(x) = 1.1 - 0.3 r_h sqrt(2e) u exp(-u^2),  u = (x - 5 mm) / (r_w / 2)

(r_h = 0.4 mm, r_w = 1.5 mm gives that file's profile).
"""
import math
import pathlib

out = pathlib.Path(__file__).resolve().parent.parent / "data" / "examples" / "cae_bump_model.csv"
xs = [0.25 * i for i in range(41)]
lines = ["# analytic CAE model matrix (not an FE database): see data/examples/README.md",
         "r_w_mm,r_h_mm," + ",".join(f"mu_x{x:.2f}" for x in xs)]
for i in range(9):
    for j in range(5):
        rw, rh = 0.5 + 0.25 * i, 0.1 + 0.1 * j
        mus = []
        for x in xs:
            u = (x - 5.0) / (rw / 2)
            mus.append(1.1 - 0.3 * rh * math.sqrt(2 * math.e) * u * math.exp(-u * u))
        lines.append(f"{rw:.2f},{rh:.1f}," + ",".join(f"{m:.6f}" for m in mus))
out.write_text("\n".join(lines) + "\n")
print(f"wrote {out} ({len(lines) - 2} rows, {len(xs)} outputs)")
