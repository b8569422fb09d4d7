#!/usr/bin/env python3
"""The periodic part of a 3D grating profile, as `haptex map grating` takes it.

For profiles written by `haptex simulate --model 3d --surface sine --x0 0
--width LAMBDA ... --direction-deg THETA -o F.csv`: the line period along
the motion is P = LAMBDA / cos(THETA). As haptex_core::map's PeriodicFit
does for the 2D line-by-line maps, fits the least-squares Fourier series of
period P (the mean and K = min(10, samples per period / 2 - 1) harmonics)
through the profile after its first mm of slide, and prints per file: the
periodic part's range (max - min over a period: the modulation the map
keeps), the RMS of the profile minus the series (what is not P-periodic),
the mean, the raw range of Ft/Fn for x >= 2 mm (the earlier measure) and
the largest angle of the tangential force off the motion. At 90 degrees
(ridges along the motion) only the mean and range are printed.

Usage: scripts/grating_periodic_part.py [--wavelength 1.5] F_THETA.csv ...
(the angle is read from the profile's header line). Needs numpy.
"""
import argparse
import re

import numpy as np


def load(path):
    header = ""
    rows = []
    names = None
    for line in open(path):
        if line.startswith("#"):
            header += line
            continue
        if names is None:
            names = line.strip().split(",")
            continue
        rows.append([float(v) for v in line.split(",")])
    data = np.array(rows)
    angle = re.search(r"direction (-?[0-9.]+) degrees", header)
    if angle is None:
        raise SystemExit(f"{path}: no 'direction ... degrees' in the header")
    col = {n: i for i, n in enumerate(names)}
    return float(angle.group(1)), data[:, col["x_mm"]], data[:, col["mu"]], data[:, col["force_angle_deg"]]


def periodic_part(x, mu, period, skip_mm=1.0):
    keep = x >= x[0] + skip_mm
    xs, ys = x[keep], mu[keep]
    per_period = period / ((xs[-1] - xs[0]) / (len(xs) - 1))
    k = max(1, min(10, int(per_period / 2) - 1))

    def basis(v):
        w = 2 * np.pi * v / period
        return np.array([np.ones_like(v)] + sum([[np.cos(h * w), np.sin(h * w)] for h in range(1, k + 1)], [])).T

    coef, *_ = np.linalg.lstsq(basis(xs), ys, rcond=None)
    series = basis(np.linspace(0.0, period, 2001)) @ coef
    remainder = ys - basis(xs) @ coef
    return series.max() - series.min(), float(np.sqrt(np.mean(remainder ** 2))), coef[0], k


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--wavelength", type=float, default=1.5, help="the grating's wavelength (mm)")
    ap.add_argument("profiles", nargs="+")
    a = ap.parse_args()
    for path in a.profiles:
        theta, x, mu, angle = load(path)
        late = x >= 1.0
        if abs(theta - 90.0) < 1e-9:
            print(f"{path}: theta 90: mean {mu[late].mean():.3f}, range {np.ptp(mu[late]):.4f}, "
                  f"largest force angle {np.abs(angle[late]).max():.1f} deg")
            continue
        period = a.wavelength / np.cos(np.radians(theta))
        rng, rms, mean, k = periodic_part(x, mu, period)
        raw = np.ptp(mu[x >= 2.0])
        print(f"{path}: theta {theta:g}, P {period:.3f} mm, K {k}: periodic part range {rng:.3f}, "
              f"remainder RMS {rms:.4f}, mean {mean:.3f}, raw range (x >= 2 mm) {raw:.3f}, "
              f"largest force angle {np.abs(angle[late]).max():.1f} deg")


if __name__ == "__main__":
    main()
