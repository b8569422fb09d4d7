#!/usr/bin/env python3
"""Regenerates data/examples/bump_friction.csv, the analytic example profile.

It is an illustration, not a measurement or a simulation: the friction
coefficient seen by a finger sliding over a bump at x0 = 5 mm, modelled as a
base value plus the derivative of a Gaussian (friction rises while the finger
climbs the bump and drops while it descends, the shape the paper's Fig. 2a
shows). mu(x) = 1.1 - 0.12 * sqrt(2e) * (x - x0)/s * exp(-((x - x0)/s)^2),
s = 0.75 mm, scaled so mu spans 1.1 -/+ 0.12 (0.98 .. 1.22).
"""
import math
import pathlib

X0, S, BASE, AMP = 5.0, 0.75, 1.1, 0.12
out = pathlib.Path(__file__).resolve().parent.parent / "data" / "examples" / "bump_friction.csv"
lines = ["# analytic example profile (not measured, not simulated): see data/examples/README.md",
         "x_mm,mu"]
for i in range(1001):
    x = i * 0.01
    u = (x - X0) / S
    # -u exp(-u^2) peaks at +/- 1/sqrt(2e) at u = -/+ 1/sqrt(2): scale it to +/- AMP.
    mu = BASE - AMP * math.sqrt(2 * math.e) * u * math.exp(-u * u)
    lines.append(f"{x:.2f},{mu:.6f}")
out.write_text("\n".join(lines) + "\n")
print(f"wrote {out} ({len(lines) - 2} points)")
