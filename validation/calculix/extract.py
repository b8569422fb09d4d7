#!/usr/bin/env python3
"""Turn CalculiX .dat output into the reference CSVs.

Usage: extract.py RUNDIR [--decks decks] [--out results]

For every JOB.dat in RUNDIR (JOB one of the decks make_decks.py writes):

  step 1 (press, total time 0..1, indent = 0.25 mm x time)
      -> results/press_<kin>[_<variant>].csv:
         indent_mm, fn_n, half_width_mm, half_width_nodes_mm
  slide steps (total time 1..11: body position x = time - 1 mm)
      -> results/<case>_<kin>.csv: x_mm, fn_n, ft_n, mu
         (variant decks: results/variants/<job>.csv)

Forces are per mm of width (the brick layer is 1 mm thick). fn_n is the
y-reaction summed over the fixed surface's nodes, i.e. the contact force the
surface exerts on the body (> 0 pressing); ft_n = minus its x component, the
friction force resisting the body's motion towards +x (the surface's motion
towards -x under the body in haptex), as in haptex's `x_mm,mu,ft_n,fn_n`.
The rigid set's reaction (body equilibrium) is checked against it.

Half-widths at each press increment, from the contact pressures CalculiX
prints per active slave node (CSTR) and the nodes' deformed x:
  half_width_mm       = 2 sqrt(sum w p (x - xc)^2 / sum w p), xc the pressure
                        centroid, w the node's tributary length (half its two
                        slave edges): a^2 = 4 int x^2 p / int p (Hertz);
  half_width_nodes_mm = (x_max - x_min)/2 over the nodes with p > 0.
"""
import argparse
import csv
import glob
import math
import os
import re
import sys

INDENT, SLIDE = 0.25, 10.0
LAYER1 = 10000

HEAD = re.compile(r"^\s*(total force \(fx,fy,fz\) for set (\w+)|displacements \(vx,vy,vz\) for set (\w+)|"
                  r"contact stress \(slave node,press,tang1,tang2\) for all contact elements) and time\s+(\S+)")


def parse_dat(path):
    """{time: {"RF:SET": (fx, fy, fz), "U:SET": {node: (ux, uy, uz)}, "CSTR": {node: (p, t1, t2)}}}"""
    data, cur = {}, None
    with open(path) as f:
        for line in f:
            m = HEAD.match(line)
            if m:
                t = float(m.group(4))
                rec = data.setdefault(t, {})
                if m.group(2):
                    key = "RF:" + m.group(2)
                    cur = (rec, key, "total")
                elif m.group(3):
                    key = "U:" + m.group(3)
                    rec[key] = {}
                    cur = (rec, key, "nodal")
                else:
                    rec["CSTR"] = {}
                    cur = (rec, "CSTR", "nodal")
                continue
            parts = line.split()
            if not parts or cur is None:
                continue
            rec, key, kind = cur
            try:
                vals = [float(v) for v in parts]
            except ValueError:
                cur = None
                continue
            if kind == "total" and len(vals) == 3:
                rec[key] = tuple(vals)
                cur = None
            elif kind == "nodal" and len(vals) == 4:
                rec[key][int(vals[0])] = tuple(vals[1:])
    return data


def read_mesh(decks):
    """Reference x of the z = 0 body nodes, and the slave edges' tributary lengths."""
    xy = {}
    with open(os.path.join(decks, "body_nodes.inp")) as f:
        for line in f:
            if line.startswith("*"):
                continue
            p = line.split(",")
            n = int(p[0])
            if n < LAYER1:
                xy[n] = (float(p[1]), float(p[2]))
    slave = []
    text = open(os.path.join(decks, "body_sets.inp")).read()
    m = re.search(r"\*NSET, NSET=CONTACT0\n(.*?)\n\*", text, re.S)
    slave = sorted(int(v) for v in m.group(1).replace("\n", "").split(",") if v.strip())
    # the contact nodes form one chain along the skin: tributary length = half of the two adjacent edges
    chain = sorted(slave, key=lambda n: xy[n][0])
    w = {n: 0.0 for n in chain}
    for a, b in zip(chain, chain[1:]):
        d = math.dist(xy[a], xy[b])
        w[a] += d / 2
        w[b] += d / 2
    return xy, w


def half_widths(rec, xy, w, x_body):
    cstr = rec.get("CSTR", {})
    u = rec.get("U:CONTACT0", {})
    pts = []
    for n, (p, _, _) in cstr.items():
        if n not in xy or p <= 0.0:  # z = 1 layer (same values) or not a skin node
            continue
        pts.append((xy[n][0] + u[n][0] - x_body, p * w[n]))
    if not pts:
        return float("nan"), float("nan")
    total = sum(f for _, f in pts)
    xc = sum(x * f for x, f in pts) / total
    a = 2.0 * math.sqrt(sum((x - xc) ** 2 * f for x, f in pts) / total)
    xs = [x for x, _ in pts]
    return a, (max(xs) - min(xs)) / 2.0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("rundir")
    ap.add_argument("--decks", default=os.path.join(here, "decks"))
    ap.add_argument("--out", default=os.path.join(here, "results"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    xy, w = read_mesh(args.decks)
    for dat in sorted(glob.glob(os.path.join(args.rundir, "*.dat"))):
        job = os.path.basename(dat)[:-4]
        data = parse_dat(dat)
        if not data:
            print(f"{job}: no output", file=sys.stderr)
            continue
        case, kin = job.split("_")[:2]
        reference = job in ("flat_linear", "flat_nlgeom", "bump_linear", "bump_nlgeom")
        press_name = slide_name = None
        if job in ("flat_linear", "flat_nlgeom"):
            press_name = f"press_{kin}.csv"
        if case == "press":
            press_name = job + ".csv"
        elif reference:
            slide_name = f"{case}_{kin}.csv"
        else:
            slide_name = os.path.join("variants", job + ".csv")
        press, slide, worst = [], [], 0.0
        # the fixed surface's reaction is the contact force on the body; with
        # mortar contact ccx prints no reaction on the surface, then the
        # rigid set's (body equilibrium: minus the contact force) is used
        mortar = all(abs(rec.get("RF:STRIPN", (0.0, 0.0, 0.0))[1]) == 0.0 for rec in data.values())
        for t in sorted(data):
            rec = data[t]
            if "RF:RIGID" not in rec:
                continue
            rx, ry, _ = rec["RF:RIGID"]
            fx, fy, _ = (-rx, -ry, 0.0) if mortar else rec["RF:STRIPN"]
            if fy > 1e-4:
                worst = max(worst, abs(fy + ry) / fy)
            if t <= 1.0 + 1e-9:
                a, an = half_widths(rec, xy, w, 0.0)
                press.append((INDENT * t, fy, a, an))
            else:
                x = t - 1.0  # the slide steps run for as many time units as mm
                slide.append((x, fy, -fx, -fx / fy if fy > 0 else float("nan")))
        if press_name:
            with open(os.path.join(args.out, press_name), "w", newline="") as f:
                c = csv.writer(f)
                c.writerow(["indent_mm", "fn_n", "half_width_mm", "half_width_nodes_mm"])
                for row in press:
                    c.writerow([f"{row[0]:.6g}"] + [f"{v:.9g}" for v in row[1:]])
        if slide_name and slide:
            os.makedirs(os.path.dirname(os.path.join(args.out, slide_name)), exist_ok=True)
            with open(os.path.join(args.out, slide_name), "w", newline="") as f:
                c = csv.writer(f)
                c.writerow(["x_mm", "fn_n", "ft_n", "mu"])
                for row in slide:
                    c.writerow([f"{row[0]:.6g}"] + [f"{v:.9g}" for v in row[1:]])
        print(f"{job}: {len(press)} press outputs (Fn at {press[-1][0] if press else 0:.4g} mm = "
              f"{press[-1][1] if press else float('nan'):.6g} N/mm), {len(slide)} slide increments"
              + (f" up to x = {slide[-1][0]:.4g} mm" if slide else "")
              + ("; forces from the rigid set (mortar)" if mortar else
                 f"; surface vs rigid-set reaction: max relative difference {worst:.1e}"))


if __name__ == "__main__":
    main()
