#!/usr/bin/env python3
"""Compare the CalculiX reference with haptex's own curves; write results/comparison.md.

Usage: compare.py [--results results] [--haptex-vtk work]

Reads results/{press,flat,bump}_{linear,nlgeom}.csv and the press-only
variants (extract.py) and results/haptex/ (run.sh: haptex's profiles and
force histories; press_halfwidth.csv, recomputed with --haptex-vtk from the
VTK frames after haptex presses of 0.025 .. 0.25 mm).

haptex's half-width is computed here from its VTK frame the way haptex
integrates contact: 4 Gauss points per skin segment of the contact region
(mesh nodes 0..126), depth below the flat surface's polyline, pressure
200 MPa/mm with the 0.2 um C1 onset, weight = Gauss weight x reference
segment length; a = 2 sqrt(sum w p (x - xc)^2 / sum w p). Its sum w p
reproduces haptex's Fn (checked below).
"""
import argparse
import csv
import glob
import math
import os
import re

import numpy as np

PENALTY, DELTA = 200.0, 2e-4
E, NU, R = 0.1, 0.45, 8.0
E_STAR = E / (1 - NU * NU)
N_CONTACT = 127  # skin nodes 0..126 are haptex's contact region (make_decks.py checks the same set)


def read_csv(path):
    with open(path) as f:
        rows = [line for line in f if not line.startswith("#")]
    r = list(csv.DictReader(rows))
    return {k: np.array([float(row[k]) for row in r]) for k in r[0]}


def hertz_a(p):
    return math.sqrt(4 * p * R / (math.pi * E_STAR))


def haptex_half_width(vtu):
    text = open(vtu).read()
    arr = lambda name: re.search(r'<DataArray[^>]*Name="%s"[^>]*>(.*?)</DataArray>' % name, text, re.S).group(1).split()
    pts = np.array(re.search(r"<Points>\s*<DataArray[^>]*>(.*?)</DataArray>", text, re.S).group(1).split(), float).reshape(-1, 3)[:, :2]
    disp = np.array(arr("displacement"), float).reshape(-1, 3)[:, :2]
    conn = np.array(arr("connectivity"), int)
    offsets = np.array(arr("offsets"), int)
    sub = np.array(arr("subdomain"), int)
    k = int(np.where(sub == 6)[0][0])
    surf = conn[(offsets[k - 1] if k else 0):offsets[k]]
    ys = pts[surf, 1] + disp[surf, 1]
    assert np.ptp(ys) < 1e-12, "not a flat surface"
    y_surf = ys[0]
    cur = pts + disp
    a4 = math.sqrt(3 / 7 - 2 / 7 * math.sqrt(1.2))
    b4 = math.sqrt(3 / 7 + 2 / 7 * math.sqrt(1.2))
    wa, wb = (18 + math.sqrt(30)) / 36, (18 - math.sqrt(30)) / 36
    gp = [(-b4, wb), (-a4, wa), (a4, wa), (b4, wb)]
    xs, ws = [], []
    for n in range(N_CONTACT - 1):
        length = float(np.hypot(*(pts[n + 1] - pts[n])))
        for s, wg in gp:
            t = 0.5 * (1 + s)
            x, y = (1 - t) * cur[n] + t * cur[n + 1]
            d = y_surf - y
            if d <= 0:
                continue
            p = PENALTY * d * d / (2 * DELTA) if d < DELTA else PENALTY * (d - DELTA / 2)
            xs.append(x)
            ws.append(p * wg * length / 2)
    xs, ws = np.array(xs), np.array(ws)
    total = ws.sum()
    xc = (xs * ws).sum() / total
    return 2 * math.sqrt(((xs - xc) ** 2 * ws).sum() / total), total, (xs.max() - xs.min()) / 2


def interp_on(x_ref, x, y):
    """y(x) at x_ref, NaN outside x's range."""
    out = np.interp(x_ref, x, y)
    out[(x_ref < x[0] - 1e-9) | (x_ref > x[-1] + 1e-9)] = np.nan
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--results", default=os.path.join(here, "results"))
    ap.add_argument("--haptex-vtk", help="directory with press_<indent>/frame_0000.vtu from haptex (run.sh's work/): "
                    "recompute results/haptex/press_halfwidth.csv")
    args = ap.parse_args()
    res = args.results
    hx = os.path.join(res, "haptex")
    md = []
    load = lambda name: read_csv(os.path.join(res, name)) if os.path.exists(os.path.join(res, name)) else None

    # ---------------- press ----------------
    hist = read_csv(os.path.join(hx, "flat_history.csv"))
    press_h = {round(-d, 6): f for d, f, s in zip(hist["drive_y_mm"], hist["fn_n"], hist["slide_mm"]) if s == 0.0}
    hist0 = read_csv(os.path.join(hx, "press_mu0_history.csv"))
    press_h0 = {round(-d, 6): f for d, f, s in zip(hist0["drive_y_mm"], hist0["fn_n"], hist0["slide_mm"]) if s == 0.0}
    hw_path = os.path.join(hx, "press_halfwidth.csv")
    if args.haptex_vtk:
        with open(hw_path, "w") as f:
            f.write("indent_mm,fn_n,half_width_mm,half_width_nodes_mm\n")
            for vtu in sorted(glob.glob(os.path.join(args.haptex_vtk, "press_*", "frame_0000.vtu")),
                              key=lambda v: float(os.path.basename(os.path.dirname(v)).split("_")[1])):
                d = float(os.path.basename(os.path.dirname(vtu)).split("_")[1])
                a, total, an = haptex_half_width(vtu)
                f.write(f"{d:g},{total:.9g},{a:.9g},{an:.9g}\n")
    hw = read_csv(hw_path)
    hw_h = {round(d, 6): (a, an, t) for d, a, an, t in zip(hw["indent_mm"], hw["half_width_mm"], hw["half_width_nodes_mm"], hw["fn_n"])}
    lin, nlg = load("press_linear.csv"), load("press_nlgeom.csv")
    c8, mu0 = load("press_linear_C3D8.csv"), load("press_linear_C3D8I_mu0.csv")
    md += ["## Press on the flat (mu = 0.5 during the press, as in haptex's runs)", "",
           "Normal force P' (N/mm) and contact half-width a (mm, second moment of the pressure; in brackets: half the span of the nodes in contact). "
           "Hertz: a = sqrt(4 P' R / (pi E*)) from each model's own P'.", "",
           "| indent mm | haptex P' | ccx linear P' | diff | ccx NLGEOM P' | NLGEOM/linear | haptex a [nodes] | ccx linear a [nodes] | ccx NLGEOM a [nodes] | Hertz a (haptex P') | Hertz a (ccx lin P') |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    check = []
    for i, d in enumerate(lin["indent_mm"]):
        key = round(d, 6)
        ph = press_h.get(key, float("nan"))
        pl = lin["fn_n"][i]
        pn = nlg["fn_n"][i] if nlg is not None and i < len(nlg["fn_n"]) else float("nan")
        ah = hw_h.get(key, (float("nan"),) * 3)
        if key in hw_h:
            check.append(abs(ah[2] / ph - 1))
        an_ = (nlg["half_width_mm"][i], nlg["half_width_nodes_mm"][i]) if nlg is not None and i < len(nlg["fn_n"]) else (float("nan"),) * 2
        md.append(f"| {d:.3f} | {ph:.6f} | {pl:.6f} | {100 * (pl / ph - 1):+.2f} % | {pn:.6f} | {100 * (pn / pl - 1):+.2f} % | "
                  f"{ah[0]:.4f} [{ah[1]:.3f}] | {lin['half_width_mm'][i]:.4f} [{lin['half_width_nodes_mm'][i]:.3f}] | "
                  f"{an_[0]:.4f} [{an_[1]:.3f}] | {hertz_a(ph):.4f} | {hertz_a(pl):.4f} |")
    md += ["", f"(haptex's half-width recomputed from its VTK frames: the Gauss-point pressures integrate to its Fn within {max(check):.1e}.)", ""]

    md += ["## Locking: element choice in CalculiX vs haptex's B-bar Q4 (small strain, mu = 0.5)", "",
           "| indent mm | haptex B-bar P' | ccx C3D8I P' | C3D8I vs haptex | ccx C3D8 (full integration) P' | C3D8 vs haptex | C3D8 vs C3D8I |",
           "|---|---|---|---|---|---|---|"]
    for i, d in enumerate(lin["indent_mm"]):
        if c8 is None:
            break
        ph = press_h.get(round(d, 6), float("nan"))
        pl, p8 = lin["fn_n"][i], c8["fn_n"][i]
        md.append(f"| {d:.3f} | {ph:.6f} | {pl:.6f} | {100 * (pl / ph - 1):+.2f} % | {p8:.6f} | {100 * (p8 / ph - 1):+.2f} % | {100 * (p8 / pl - 1):+.2f} % |")
    if mu0 is not None:
        i = len(mu0["fn_n"]) - 1
        ph0 = press_h0.get(round(mu0["indent_mm"][i], 6), float("nan"))
        md += ["", f"Frictionless press to {mu0['indent_mm'][i]:.2f} mm (`--mu-skin 0`; C3D8I): haptex P' = {ph0:.6f}, ccx P' = {mu0['fn_n'][i]:.6f} "
               f"({100 * (mu0['fn_n'][i] / ph0 - 1):+.2f} %); ccx a = {mu0['half_width_mm'][i]:.4f} mm vs Hertz {hertz_a(mu0['fn_n'][i]):.4f} mm "
               f"({100 * (mu0['half_width_mm'][i] / hertz_a(mu0['fn_n'][i]) - 1):+.1f} %); friction during the press changes ccx's P' by "
               f"{100 * (lin['fn_n'][i] / mu0['fn_n'][i] - 1):+.2f} %."]
    md.append("")

    # haptex's finite-strain option (if run.sh found it) against the NLGEOM press
    fin_path = os.path.join(hx, "flat_finite_history.csv")
    if os.path.exists(fin_path) and nlg is not None:
        hf = read_csv(fin_path)
        press_f = {round(-d, 6): f for d, f, s in zip(hf["drive_y_mm"], hf["fn_n"], hf["slide_mm"]) if s == 0.0}
        md += ["## Press: haptex `--kinematics finite` vs CalculiX NLGEOM (neo-Hookean)", "",
               "| indent mm | haptex finite P' | ccx NLGEOM P' | ccx vs haptex finite | haptex finite/small | ccx NLGEOM/linear |", "|---|---|---|---|---|---|"]
        for i, d in enumerate(nlg["indent_mm"]):
            pf, pn = press_f.get(round(d, 6), float("nan")), nlg["fn_n"][i]
            ph, pl = press_h.get(round(d, 6), float("nan")), lin["fn_n"][i]
            md.append(f"| {d:.3f} | {pf:.6f} | {pn:.6f} | {100 * (pn / pf - 1):+.2f} % | {100 * (pf / ph - 1):+.2f} % | {100 * (pn / pl - 1):+.2f} % |")
        md.append("")

    # ---------------- slides ----------------
    for case in ("flat", "bump"):
        h = read_csv(os.path.join(hx, f"{case}.csv"))
        cl, cn = load(f"{case}_linear.csv"), load(f"{case}_nlgeom.csv")
        md += [f"## {case.capitalize()} slide, mu = 0.5", ""]
        md += ["| run | x range mm | Fn at x = 0.1 | Fn max | Ft max | mu min (at x) | mu max (at x) | mu at last x | first x with mu >= 0.499 |", "|---|---|---|---|---|---|---|---|---|"]
        hf = load(os.path.join("haptex", f"{case}_finite.csv"))
        for label, d, fcol in (("haptex small strain", h, "fn_n"), ("ccx linear", cl, "fn_n"), ("ccx NLGEOM", cn, "fn_n"),
                               ("haptex finite strain", hf, "fn_n")):
            if d is None and label.startswith("haptex finite"):
                continue
            if d is None:
                md.append(f"| {label} | no run |  |  |  |  |  |  |  |")
                continue
            x, mu = d["x_mm"], d["mu"]
            i0 = int(np.argmin(np.abs(x - 0.1)))
            imin, imax = int(np.argmin(mu)), int(np.argmax(mu))
            md.append(f"| {label} | {x[0]:.2f} .. {x[-1]:.2f} | {d[fcol][i0]:.6f} | {d[fcol].max():.6f} | {d['ft_n'].max():.6f} | "
                      f"{mu[imin]:.4f} ({x[imin]:.2f}) | {mu[imax]:.4f} ({x[imax]:.2f}) | {mu[-1]:.4f} | "
                      f"{x[np.argmax(mu >= 0.499)]:.2f} |")
        md.append("")
        pairs = (("ccx linear vs haptex", cl, h), ("ccx NLGEOM vs ccx linear", cn, cl), ("ccx NLGEOM vs haptex", cn, h))
        if hf is not None:
            pairs += (("ccx NLGEOM vs haptex finite", cn, hf), ("haptex finite vs haptex small", hf, h))
        if case == "bump":
            # the linear run without its last 0.5 mm before the stall (increments with frozen pairing)
            pairs += (("ccx linear vs haptex, x <= 3.7 mm", cl, h),)
        md += ["Differences on haptex's x grid, over the range where both ran (interpolated linearly in x):", "",
               "| comparison | x range mm | mu RMS diff | mu RMS diff, x >= 2 mm | mu max abs diff (at x) | Fn rel. RMS diff | Fn rel. max diff (at x) | Ft rel. RMS diff |", "|---|---|---|---|---|---|---|---|"]
        for label, a, b in pairs:
            if a is None or b is None:
                md.append(f"| {label} | no run |  |  |  |  |  |  |")
                continue
            xg = h["x_mm"]
            am, bm = interp_on(xg, a["x_mm"], a["mu"]), interp_on(xg, b["x_mm"], b["mu"])
            af, bf = interp_on(xg, a["x_mm"], a["fn_n"]), interp_on(xg, b["x_mm"], b["fn_n"])
            at, bt = interp_on(xg, a["x_mm"], a["ft_n"]), interp_on(xg, b["x_mm"], b["ft_n"])
            ok = ~(np.isnan(am) | np.isnan(bm))
            if label.endswith("x <= 3.7 mm"):
                ok &= xg <= 3.7 + 1e-9
            if not ok.any():
                md.append(f"| {label} | no overlap |  |  |  |  |  |  |")
                continue
            dm = am[ok] - bm[ok]
            rf = af[ok] / bf[ok] - 1
            rt = at[ok] / bt[ok] - 1
            k, kf = int(np.argmax(np.abs(dm))), int(np.argmax(np.abs(rf)))
            late = xg[ok] >= 2.0 - 1e-9
            rms_late = f"{math.sqrt(np.mean(dm[late] ** 2)):.4f}" if late.any() else "-"
            md.append(f"| {label} | {xg[ok][0]:.2f} .. {xg[ok][-1]:.2f} | {math.sqrt(np.mean(dm ** 2)):.4f} | {rms_late} | {dm[k]:+.4f} ({xg[ok][k]:.2f}) | "
                      f"{100 * math.sqrt(np.mean(rf ** 2)):.2f} % | {100 * rf[kf]:+.2f} % ({xg[ok][kf]:.2f}) | {100 * math.sqrt(np.mean(rt ** 2)):.2f} % |")
        md.append("")
    variants = sorted(glob.glob(os.path.join(res, "variants", "*.csv")))
    if variants:
        h = read_csv(os.path.join(hx, "bump.csv"))
        cl = load("bump_linear.csv")
        md += ["## Bump variants (decks/variants, `run.sh variants`)", "",
               "Where each run got to, and its Ft/Fn against haptex's (small strain; for the NLGEOM variant haptex `--kinematics finite` when available) "
               "and the reference ccx linear run's, on haptex's x grid where both ran.", "",
               "| run | last x mm | mu RMS diff vs haptex, x >= 2 mm | mu max abs diff vs haptex (at x) | mu RMS diff vs ccx linear (reference deck), x >= 2 mm | mu max (at x) |",
               "|---|---|---|---|---|---|"]
        for path in variants:
            v = read_csv(path)
            name = os.path.basename(path)[:-4]
            xg = h["x_mm"]
            vm = interp_on(xg, v["x_mm"], v["mu"])
            cols = []
            hfin = load(os.path.join("haptex", "bump_finite.csv"))
            refs = (hfin if (hfin is not None and "nlgeom" in name) else h, cl)
            for ref in refs:
                rm = interp_on(xg, ref["x_mm"], ref["mu"])
                ok = ~(np.isnan(vm) | np.isnan(rm)) & (xg >= 2.0 - 1e-9)
                if ok.any():
                    d = vm[ok] - rm[ok]
                    k = int(np.argmax(np.abs(d)))
                    cols.append((f"{math.sqrt(np.mean(d ** 2)):.4f}", f"{d[k]:+.4f} ({xg[ok][k]:.2f})"))
                else:
                    cols.append(("-", "-"))
            im = int(np.argmax(v["mu"]))
            md.append(f"| {name} | {v['x_mm'][-1]:.3f} | {cols[0][0]} | {cols[0][1]} | {cols[1][0]} | {v['mu'][im]:.4f} ({v['x_mm'][im]:.2f}) |")
        md.append("")
    out = os.path.join(res, "comparison.md")
    with open(out, "w") as f:
        f.write("# CalculiX reference vs haptex (generated by compare.py)\n\n" + "\n".join(md) + "\n")
    print("wrote", out)


if __name__ == "__main__":
    main()
