#!/usr/bin/env python3
"""results/comparison.md from the CSVs (CalculiX: results/<job>.csv and
results/<job>_press.csv; haptex: results/haptex/<case>.csv profiles and
<case>_history.csv), and results/runs.log for what did not finish.

Differences are CalculiX - haptex (or variant - reference) at the x where
both have a point (haptex's 0.1 mm grid; CalculiX prints every converged
increment): Fn relative (%), Ft/Fn absolute.

Usage: compare.py [--results results]
"""
import argparse
import csv
import math
import os

# job -> (haptex curve it is compared with, what it is)
JOBS = [
    ("flat_linear", "flat_coarse", "flat, C3D8I, small strain, s2s (the reference)"),
    ("flat_linear_n2s", "flat_coarse", "flat, C3D8I, node-to-surface, stick 200 (contact variant)"),
    ("flat_linear_C3D8", "flat_coarse", "flat, plain C3D8 (element variant)"),
    ("flat_linear_default", "flat_default", "flat, C3D8I, haptex's default mesh, 1 mm slide"),
    ("flat_nlgeom", "flat_coarse", "flat, C3D8I, NLGEOM neo-Hookean"),
    ("bump_linear", "bump_coarse", "bump, C3D8I, small strain, s2s (the reference)"),
    ("bump_nlgeom", "bump_coarse", "bump, C3D8I, NLGEOM neo-Hookean"),
    ("bump_linear_n2s", "bump_coarse", "bump, node-to-surface, stick 200"),
    ("bump_linear_n2s_stick20", "bump_coarse", "bump, node-to-surface, stick 20"),
    # the diagnosis of the bump (README, "Diagnosis of the bump")
    ("bump_linear_inc025", "bump_coarse", "bump, s2s as the reference, slide increments 0.025 mm"),
    ("bump_linear_inc01", "bump_coarse", "bump, s2s as the reference, slide increments 0.01 mm"),
    ("bump_linear_n2s_stick2", "bump_coarse", "bump, node-to-surface, stick 2"),
    ("bump_linear_n2s_ctrl", "bump_coarse", "bump, node-to-surface, stick 200, *CONTROLS"),
    ("bump_linear_n2s_stick2_ctrl", "bump_coarse", "bump, node-to-surface, stick 2, *CONTROLS"),
    ("bump_mu0_n2s", "bump_coarse_mu0", "bump, mu = 0, node-to-surface"),
    ("bump_mu0_s2s", "bump_coarse_mu0", "bump, mu = 0, s2s, increments 0.1 mm"),
    ("bump_mu0_s2s_inc025", "bump_coarse_mu0", "bump, mu = 0, s2s, increments 0.025 mm"),
    ("bump_mu0_s2s_inc01", "bump_coarse_mu0", "bump, mu = 0, s2s, increments 0.01 mm"),
    ("bump_mu0_s2s_nlgeom", "bump_coarse_mu0", "bump, mu = 0, s2s, NLGEOM neo-Hookean"),
    # the finite-strain slide (README, "NLGEOM, the slide"): C3D20R and C3D8, NLGEOM against
    # haptex's finite-strain run, linear against its small-strain run
    ("flat_nlgeom_C3D20R", "flat_coarse_finite", "flat, C3D20R, NLGEOM neo-Hookean"),
    ("flat_linear_C3D20R", "flat_coarse", "flat, C3D20R, small strain"),
    ("flat_nlgeom_C3D8", "flat_coarse_finite", "flat, plain C3D8, NLGEOM neo-Hookean"),
    ("bump_nlgeom_C3D8_inc025_pe", "bump_coarse_finite", "bump, plain C3D8, NLGEOM, slide increments 0.025 mm"),
    ("bump_linear_C3D8_inc025_pe", "bump_coarse", "bump, plain C3D8, small strain, slide increments 0.025 mm"),
    ("bump_nlgeom_C3D20R_inc025", "bump_coarse_finite", "bump, C3D20R, NLGEOM, 0.025 mm (stalled at x = 1.075 mm)"),
]
HAPTEX = {
    "flat_coarse": "haptex coarse mesh, flat",
    "flat_default": "haptex default mesh, flat",
    "bump_coarse": "haptex coarse mesh, bump",
    "bump_default": "haptex default mesh, bump",
    "bump_fine": "haptex fine mesh, bump",
    "bump_coarse_mu0": "haptex coarse mesh, bump, mu = 0",
    "bump_default_mu0": "haptex default mesh, bump, mu = 0",
    "bump_fine_mu0": "haptex fine mesh, bump, mu = 0",
    "flat_coarse_finite": "haptex coarse mesh, flat, finite strain",
    "flat_default_finite": "haptex default mesh, flat, finite strain",
    "bump_coarse_finite": "haptex coarse mesh, bump, finite strain",
    "bump_default_finite": "haptex default mesh, bump, finite strain",
}


def read(path):
    if not os.path.exists(path):
        return None
    with open(path) as f:
        rows = [l for l in f if not l.startswith("#")]
    r = list(csv.DictReader(rows))
    return {k: [float(row[k]) for row in r] for k in r[0]} if r else None


def curve(d):
    """{round(x, 6): (fn, mu)}"""
    return {round(x, 6): (fn, ft / fn) for x, fn, ft in zip(d["x_mm"], d["fn_n"], d["ft_n"])}


def diff(a, b, xmin=0.0):
    """a - b on the common x >= xmin: (n, x range, max rel Fn (signed, x), rms rel Fn, max abs mu (signed, x), rms mu)"""
    xs = sorted(x for x in a if x in b and x >= xmin - 1e-9)
    if not xs:
        return None
    dfn = [(a[x][0] / b[x][0] - 1.0, x) for x in xs]
    dmu = [(a[x][1] - b[x][1], x) for x in xs]
    mfn = max(dfn, key=lambda t: abs(t[0]))
    mmu = max(dmu, key=lambda t: abs(t[0]))
    rms = lambda v: math.sqrt(sum(t[0] ** 2 for t in v) / len(v))
    return dict(n=len(xs), lo=xs[0], hi=xs[-1], mfn=mfn, rfn=rms(dfn), mmu=mmu, rmu=rms(dmu))


def haptex_press_fn(hist):
    """Fn after the press: the last history row before the slide."""
    rows = [fn for s, fn in zip(hist["slide_mm"], hist["fn_n"]) if s == 0.0]
    return rows[-1]


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--results", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "results"))
    a = ap.parse_args()
    R = a.results
    hx = {k: read(os.path.join(R, "haptex", k + ".csv")) for k in HAPTEX}
    hh = {k: read(os.path.join(R, "haptex", k + "_history.csv")) for k in HAPTEX}
    runs = {}
    if os.path.exists(os.path.join(R, "runs.log")):
        for line in open(os.path.join(R, "runs.log")):
            p = line.split()
            if len(p) > 2 and p[1].startswith("ccx:"):
                runs[p[1][4:]] = line.strip()
    out = ["# CalculiX 3D reference: comparison (generated by compare.py; do not edit)", "",
           "Differences: CalculiX - haptex at the common x (haptex's 0.1 mm grid). Fn relative, Ft/Fn absolute.", ""]

    out += ["## Press: Fn at the full indent (0.5 mm), before the slide", "",
            "| job | CalculiX Fn (N) | haptex Fn (N) | diff |", "|---|---|---|---|"]
    for job, ref, what in JOBS:
        p = read(os.path.join(R, job + "_press.csv"))
        h = hh.get(ref)
        if p is None or h is None or not p["indent_mm"] or abs(p["indent_mm"][-1] - 0.5) > 1e-6:
            continue
        fh = haptex_press_fn(h)
        out.append(f"| {job} ({what}) | {p['fn_n'][-1]:.5f} | {fh:.5f} ({ref}) | {100 * (p['fn_n'][-1] / fh - 1):+.2f} % |")
    out.append("")

    out += ["## Slide: CalculiX vs haptex", "",
            "| job | vs | x range (points) | Fn max diff (at x) | Fn RMS | Ft/Fn max diff (at x) | Ft/Fn RMS | CalculiX Fn, Ft/Fn at the last x | haptex there |",
            "|---|---|---|---|---|---|---|---|---|"]
    for job, ref, what in JOBS:
        c = read(os.path.join(R, job + ".csv"))
        h = hx.get(ref)
        if c is None or h is None or not c["x_mm"]:
            continue
        cc, ch = curve(c), curve(h)
        d = diff(cc, ch)
        if d is None:
            continue
        last = d["hi"]
        out.append(f"| {job} ({what}) | {ref} | {d['lo']:g} .. {d['hi']:g} mm ({d['n']}) | "
                   f"{100 * d['mfn'][0]:+.2f} % ({d['mfn'][1]:g}) | {100 * d['rfn']:.2f} % | "
                   f"{d['mmu'][0]:+.4f} ({d['mmu'][1]:g}) | {d['rmu']:.4f} | "
                   f"{cc[last][0]:.5f}, {cc[last][1]:.4f} | {ch[last][0]:.5f}, {ch[last][1]:.4f} |")
    out.append("")

    out += ["## Spreads (the same quantities between two curves of one code)", "",
            "| curve | vs | x range | Fn max diff (at x) | Fn RMS | Ft/Fn max diff (at x) | Ft/Fn RMS |", "|---|---|---|---|---|---|---|"]
    pairs = [("haptex:flat_default", "haptex:flat_coarse"), ("haptex:bump_default", "haptex:bump_coarse"),
             ("flat_linear_default", "flat_linear"), ("flat_linear_C3D8", "flat_linear"),
             ("flat_linear_n2s", "flat_linear"), ("bump_linear_n2s", "bump_linear"), ("bump_linear_n2s_stick20", "bump_linear"),
             ("flat_nlgeom", "flat_linear"), ("bump_nlgeom", "bump_linear"),
             ("haptex:bump_fine", "haptex:bump_default"), ("haptex:bump_default_mu0", "haptex:bump_coarse_mu0"),
             ("haptex:bump_fine_mu0", "haptex:bump_default_mu0"), ("bump_linear_inc025", "bump_linear"),
             ("bump_mu0_s2s", "bump_mu0_n2s"), ("bump_mu0_s2s_inc025", "bump_mu0_s2s"),
             ("bump_mu0_s2s_inc01", "bump_mu0_s2s_inc025"), ("bump_linear_inc01", "bump_linear_inc025"),
             ("bump_linear_inc01", "bump_linear"),
             # the finite-strain effect in each code, and haptex's finite-strain mesh spread
             ("flat_nlgeom_C3D20R", "flat_linear_C3D20R"), ("haptex:flat_coarse_finite", "haptex:flat_coarse"),
             ("flat_nlgeom_C3D8", "flat_linear_C3D8"), ("flat_linear_C3D20R", "flat_linear"),
             ("haptex:flat_default_finite", "haptex:flat_coarse_finite"), ("haptex:flat_default_finite", "haptex:flat_default"),
             ("bump_nlgeom_C3D8_inc025_pe", "bump_linear_C3D8_inc025_pe"), ("haptex:bump_coarse_finite", "haptex:bump_coarse"),
             ("haptex:bump_default_finite", "haptex:bump_default"), ("haptex:bump_default_finite", "haptex:bump_coarse_finite"),
             ("bump_linear_C3D8_inc025_pe", "bump_linear_inc025"), ("bump_nlgeom_C3D20R_inc025", "bump_nlgeom_C3D8_inc025_pe")]

    def load(name):
        if name.startswith("haptex:"):
            return hx.get(name[7:])
        return read(os.path.join(R, name + ".csv"))

    for a_, b_ in pairs:
        A, B = load(a_), load(b_)
        if not A or not B or not A["x_mm"] or not B["x_mm"]:
            continue
        d = diff(curve(A), curve(B))
        if d is None:
            continue
        out.append(f"| {a_} | {b_} | {d['lo']:g} .. {d['hi']:g} mm ({d['n']}) | {100 * d['mfn'][0]:+.2f} % ({d['mfn'][1]:g}) | "
                   f"{100 * d['rfn']:.2f} % | {d['mmu'][0]:+.4f} ({d['mmu'][1]:g}) | {d['rmu']:.4f} |")
    out.append("")

    # The bump's path is symmetric: the finger starts with the bump 1.5 mm ahead and ends 1.5 mm
    # past it, on a mesh symmetric in x. Without friction the problem is conservative (elastic body,
    # penalty contact), so Ft/Fn(x) = -Ft/Fn(3 - x) and its mean over the path is 0 (up to the end
    # points); with friction the mean is the dissipation per unit travel and normal force.
    out += ["## Bump: mean Ft/Fn over the path, and the frictionless runs' antisymmetry", "",
            "Mean over x = 0.1 .. 3 mm (haptex's grid). Antisymmetry (mu = 0 only): the largest and the RMS "
            "|Ft/Fn(x) + Ft/Fn(3 - x)| over x = 0.1 .. 1.5 mm (0 for a conservative model).", "",
            "| curve | points | mean Ft/Fn | max antisymmetry error | RMS antisymmetry error |", "|---|---|---|---|---|"]
    bump = ["haptex:bump_coarse", "haptex:bump_default", "haptex:bump_fine", "bump_linear", "bump_linear_inc025", "bump_linear_inc01",
            "haptex:bump_coarse_finite", "haptex:bump_default_finite", "bump_nlgeom_C3D8_inc025_pe", "bump_linear_C3D8_inc025_pe",
            "haptex:bump_coarse_mu0", "haptex:bump_default_mu0", "haptex:bump_fine_mu0", "bump_mu0_n2s", "bump_mu0_s2s",
            "bump_mu0_s2s_inc025", "bump_mu0_s2s_inc01", "bump_mu0_s2s_nlgeom"]
    for name in bump:
        A = load(name)
        if not A or not A["x_mm"]:
            continue
        c = curve(A)
        xs = [round(0.1 * k, 6) for k in range(1, 31)]
        if not all(x in c for x in xs):
            out.append(f"| {name} | {sum(x in c for x in xs)} of 30 (incomplete) | | | |")
            continue
        mean = sum(c[x][1] for x in xs) / len(xs)
        row = f"| {name} | 30 | {mean:+.4f} |"
        if "mu0" in name:
            e = [abs(c[x][1] + c[round(3.0 - x, 6)][1]) for x in xs[:15]]
            row += f" {max(e):.4f} | {math.sqrt(sum(v * v for v in e) / len(e)):.4f} |"
        else:
            row += " | |"
        out.append(row)
    out.append("")

    out += ["## Runs (results/runs.log)", "", "```"]
    if os.path.exists(os.path.join(R, "runs.log")):
        out += [l.rstrip() for l in open(os.path.join(R, "runs.log"))]
    out += ["```", ""]
    tpath = os.path.join(R, "timing.txt")
    if os.path.exists(tpath):
        out += ["## Timing (results/timing.txt)", "", "```"] + [l.rstrip() for l in open(tpath)] + ["```", ""]
    path = os.path.join(R, "comparison.md")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")
    print("\n".join(out))


if __name__ == "__main__":
    main()
