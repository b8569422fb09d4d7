#!/usr/bin/env python3
"""Write CalculiX decks for the 3D fingertip reference from haptex's own mesh.

Reads the first VTK frame of `haptex simulate --model 3d --finger
data/finger/half-disc.toml --vtk DIR` (reference node positions, hexes in
C3D8 order, the contact region's skin quads, the `driven` nodes, and the
61 x 61 surface grid, which gives haptex's surface lift) and writes ONE
self-contained deck (mesh inline):

  body        every hex (parts 0-3, all E = 0.1 MPa, nu = 0.45 in the
              half-disc file) as a C3D8I (default) or C3D8 brick, or with
              --etype C3D20R (C3D20) a quadratic brick with a node at the
              middle of each of its straight edges (driven where both
              ends are)
  DRIVEN      the nodes haptex drives (bone): prescribed displacement,
              down by the indent in z, then +s along x (the slide)
  SKIN        the contact region's skin faces (the VTK part-4 quads), as
              element faces of the bricks: the slave surface
  SURFACE     the rigid surface: a grid of C3D8 bricks below z = h(x) + lift,
              all nodes fixed; its top faces are the master surface.
              lift = haptex's own (grid z - h at frame 0), so the surface
              sits exactly where haptex puts it (touching the lowest of the
              skin faces' 4x4 Gauss points before the press)

Frames: haptex keeps the finger and moves the surface by -s under it; here
the surface is fixed and the driven nodes move +s along x: the same
relative motion (statics, no inertia). The finger's position on the surface
(haptex's x_mm, the distance travelled) is the step time of the slide step.

Contact: node-to-surface penalty (skin nodes slave, the rigid faces
master), linear pressure-overclosure with haptex's penalty slope (N/mm^3 =
MPa/mm), Coulomb friction mu with a stick slope equal to the penalty.

Usage: make_decks.py FRAME.vtu --job NAME --surface flat|bump [--x0 --width
       --height] [--indent 0.5 --slide 3 --kin linear|nlgeom --etype C3D8I
       --mu 0.5 --penalty 200 --stick 200 --contact "NODE TO SURFACE"
       --inc 0.1 --facet 0.05 --press-every-increment] --out DIR
"""
import argparse
import math
import os
import re
import sys

import numpy as np

E_MPA, NU = 0.1, 0.45  # every soft layer of data/finger/half-disc.toml
MU_SHEAR = E_MPA / (2.0 * (1.0 + NU))
K_BULK = E_MPA / (3.0 * (1.0 - 2.0 * NU))
C10, D1 = MU_SHEAR / 2.0, 2.0 / K_BULK
GRID = 61  # haptex's surface grid (slide::SURFACE_GRID)
PART_SKIN, PART_GRID = 4, 6
SURF_NODE0, SURF_ELEM0 = 100000, 100000

# C3D8 faces (CalculiX manual, element C3D8): node positions 1-based
C3D8_FACES = {1: (1, 2, 3, 4), 2: (5, 8, 7, 6), 3: (1, 5, 6, 2), 4: (2, 6, 7, 3), 5: (3, 7, 8, 4), 6: (4, 8, 5, 1)}


def read_vtu(path):
    text = open(path).read()

    def array(name):
        m = re.search(r'<DataArray[^>]*Name="%s"[^>]*>(.*?)</DataArray>' % name, text, re.S)
        if m is None:
            sys.exit(f"{path}: no DataArray {name}")
        return m.group(1).split()

    pts = re.search(r"<Points>\s*<DataArray[^>]*>(.*?)</DataArray>", text, re.S).group(1).split()
    pts = np.array(pts, float).reshape(-1, 3)
    conn = np.array(array("connectivity"), int)
    offsets = np.array(array("offsets"), int)
    types = np.array(array("types"), int)
    part = np.array(array("part"), int)
    driven = np.array(array("driven"), int)
    disp = np.array(array("displacement"), float).reshape(-1, 3)
    starts = np.r_[0, offsets[:-1]]
    cells = [conn[s:e] for s, e in zip(starts, offsets)]
    return pts, cells, types, part, driven, disp


def bump_height(x, x0, width, height):
    """haptex's Gaussian bump (surface.rs): h = r_h exp(-((x - x0)/(r_w/2))^2)."""
    return height * np.exp(-(((x - x0) / (width / 2.0)) ** 2))


def fmt(v):
    return f"{v:.12g}"


def mesh(frame):
    pts, cells, types, part, driven, disp = read_vtu(frame)
    nn = len(pts) - GRID * GRID
    hexes = [(c, p) for c, t, p in zip(cells, types, part) if t == 12]
    assert all(p in (0, 1, 2, 3) for _, p in hexes)
    skin = [c for c, t, p in zip(cells, types, part) if t == 9 and p == PART_SKIN]
    grid = pts[nn:]
    return dict(pts=pts[:nn], hexes=hexes, skin=skin, driven=np.where(driven[:nn] == 1)[0], grid=grid,
                disp=disp[:nn])


def skin_faces(m):
    """(element id, face id) of every skin quad: the brick that has all its nodes."""
    by_node = {}
    for e, (c, _) in enumerate(m["hexes"]):
        for n in c:
            by_node.setdefault(int(n), []).append(e)
    faces = []
    for q in m["skin"]:
        q = set(int(n) for n in q)
        cands = set.intersection(*(set(by_node[n]) for n in q))
        assert len(cands) == 1, q
        e = cands.pop()
        c = m["hexes"][e][0]
        for f, loc in C3D8_FACES.items():
            if {int(c[i - 1]) for i in loc} == q:
                faces.append((e + 1, f))
                break
        else:
            sys.exit(f"no face of element {e + 1} is the skin quad {sorted(q)}")
    return faces


def gauss_lift(m, height):
    """min over the skin quads' 4x4 Gauss points of z - h(x): haptex's lift (check only)."""
    g, _ = np.polynomial.legendre.leggauss(4)
    best = math.inf
    for q in m["skin"]:
        X = m["pts"][q]
        for a in g:
            for b in g:
                N = 0.25 * np.array([(1 - a) * (1 - b), (1 + a) * (1 - b), (1 + a) * (1 + b), (1 - a) * (1 + b)])
                p = N @ X
                best = min(best, p[2] - height(p[0]))
    return best


def rigid_surface(xs, ys, hs, lift):
    """C3D8 bricks, one per (x, y) cell, between z = lift - 1 and z = h(x) + lift;
    top face S2 (nodes 5-8) is the master surface."""
    nx, ny = len(xs), len(ys)
    nid = lambda i, j, top: SURF_NODE0 + 1 + i + nx * (j + ny * top)
    L = [f"** rigid surface: {nx} x {ny} stations, x = {xs[0]:g} .. {xs[-1]:g}, y = {ys[0]:g} .. {ys[-1]:g} mm,"
         f" top z = h(x) + lift (lift = {lift:.9g} mm), all nodes fixed", "*NODE, NSET=SURFN"]
    for top in (0, 1):
        for j in range(ny):
            for i in range(nx):
                z = hs[i] + lift if top else lift - 1.0
                L.append(f"{nid(i, j, top)}, {fmt(xs[i])}, {fmt(ys[j])}, {fmt(z)}")
    L.append("*ELEMENT, TYPE=C3D8, ELSET=RIGIDS")
    faces = []
    e = SURF_ELEM0
    for j in range(ny - 1):
        for i in range(nx - 1):
            e += 1
            b = [nid(i, j, 0), nid(i + 1, j, 0), nid(i + 1, j + 1, 0), nid(i, j + 1, 0)]
            t = [nid(i, j, 1), nid(i + 1, j, 1), nid(i + 1, j + 1, 1), nid(i, j + 1, 1)]
            L.append(f"{e}, " + ", ".join(map(str, b + t)))
            faces.append(e)
    L += ["*SURFACE, NAME=SURFACE, TYPE=ELEMENT"] + [f"{e}, S2" for e in faces]
    return L


def nset(name, ids):
    out = [f"*NSET, NSET={name}"]
    for k in range(0, len(ids), 12):
        out.append(", ".join(str(n) for n in ids[k:k + 12]) + ",")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("frame")
    ap.add_argument("--job", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--surface", choices=("flat", "bump"), required=True)
    ap.add_argument("--x0", type=float, default=1.5)
    ap.add_argument("--width", type=float, default=1.5)
    ap.add_argument("--height", type=float, default=0.2)
    ap.add_argument("--indent", type=float, default=0.5)
    ap.add_argument("--slide", type=float, default=3.0)
    ap.add_argument("--kin", choices=("linear", "nlgeom"), default="linear")
    ap.add_argument("--etype", default="C3D8I")
    ap.add_argument("--mu", type=float, default=0.5)
    ap.add_argument("--penalty", type=float, default=200.0)
    ap.add_argument("--stick", type=float, default=200.0)
    ap.add_argument("--tension", type=float, default=1e-7)
    ap.add_argument("--contact", default="NODE TO SURFACE")
    ap.add_argument("--inc", type=float, default=0.1, help="largest slide increment (mm)")
    ap.add_argument("--facet", type=float, default=0.05, help="rigid facet length along x over the bump (mm)")
    ap.add_argument("--controls", default="", help="*CONTROLS lines for each step, ';'-separated")
    ap.add_argument("--frd", action="store_true", help="also write U at the end of the press to the .frd")
    ap.add_argument("--press-every-increment", action="store_true",
                    help="print the press at every increment instead of at the 10 time points (after a cutback "
                         "CalculiX 2.20 can land just short of a time point and then fail on a zero increment)")
    a = ap.parse_args()

    m = mesh(a.frame)
    P = m["pts"]
    if a.surface == "flat":
        h = lambda x: 0.0 * np.asarray(x, float)
    else:
        h = lambda x: bump_height(np.asarray(x, float), a.x0, a.width, a.height)
    # haptex's lift, from its own surface grid at frame 0 (s = 0): z_grid = h(x) + lift
    g = m["grid"]
    lifts = g[:, 2] - h(g[:, 0])
    lift = float(np.median(lifts))
    assert np.ptp(lifts) < 1e-9, np.ptp(lifts)
    lift_gauss = gauss_lift(m, h)
    faces = skin_faces(m)
    skin_nodes = sorted({int(n) for q in m["skin"] for n in q})
    sx = P[skin_nodes, 0]
    sy = P[skin_nodes, 1]
    x_lo, x_hi = sx.min() - 1.0, sx.max() + a.slide + 1.0
    y_hi = max(abs(sy.min()), abs(sy.max())) + 1.0
    if a.surface == "flat":
        xs = np.linspace(x_lo, x_hi, int(math.ceil((x_hi - x_lo) / 0.25)) + 1)
    else:
        lo, hi = a.x0 - 2.5 * a.width / 1.5, a.x0 + 2.5 * a.width / 1.5
        xs = np.unique(np.round(np.concatenate([
            np.arange(min(x_lo, lo), lo, 0.25), np.arange(lo, hi + 1e-9, a.facet),
            np.arange(hi, max(x_hi, hi) + 1e-9, 0.25)]), 9))
    ys = np.linspace(-y_hi, y_hi, int(math.ceil(2 * y_hi / 1.0)) + 1)

    nl = a.kin == "nlgeom"
    L = [f"** {a.job}: 3D fingertip (data/finger/half-disc.toml, haptex --model 3d mesh from {os.path.basename(a.frame)})",
         f"** {'finite strain (NLGEOM), neo-Hookean C10 = mu/2, D1 = 2/K' if nl else 'small strain, linear elastic'};"
         f" {len(m['hexes'])} {a.etype} bricks, {len(P)} nodes, {len(m['driven'])} driven nodes",
         f"** rigid {a.surface} surface" + (f" (bump x0 = {a.x0}, r_w = {a.width}, r_h = {a.height} mm)" if a.surface == "bump" else "")
         + f"; haptex lift {lift:.9g} mm (from its grid), recomputed from the skin's 4x4 Gauss points: {lift_gauss:.9g} mm",
         f"** press the driven nodes {a.indent} mm down (z), then slide them {a.slide} mm along +x",
         f"** contact {a.contact}: penalty {a.penalty} N/mm^3, mu {a.mu}, stick slope {a.stick} N/mm^3"
         + (f"; controls {a.controls}" if a.controls else ""),
         "*NODE, NSET=NBODY"]
    L += [f"{i + 1}, {fmt(p[0])}, {fmt(p[1])}, {fmt(p[2])}" for i, p in enumerate(P)]
    driven = [int(n) + 1 for n in m["driven"]]
    if a.etype.startswith("C3D20"):
        # Quadratic bricks on haptex's mesh: a node at the middle of every
        # edge (the hexahedra's straight edges are the geometry), driven
        # where both ends are.
        edges = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
        middle = {}
        driven_set = set(driven)
        L.append(f"*ELEMENT, TYPE={a.etype}, ELSET=SOFT")
        extra = []
        for e, (c, _) in enumerate(m["hexes"]):
            ids = [int(n) + 1 for n in c]
            for p, q in edges:
                key = (min(ids[p], ids[q]), max(ids[p], ids[q]))
                if key not in middle:
                    middle[key] = len(P) + len(middle) + 1
                    x = 0.5 * (P[key[0] - 1] + P[key[1] - 1])
                    extra.append(f"{middle[key]}, {fmt(x[0])}, {fmt(x[1])}, {fmt(x[2])}")
                    if key[0] in driven_set and key[1] in driven_set:
                        driven.append(middle[key])
                ids.append(middle[key])
            entries = [str(e + 1)] + [str(v) for v in ids]
            L.append(", ".join(entries[:16]) + ",")
            L.append(", ".join(entries[16:]))
        element_lines = L[L.index(f"*ELEMENT, TYPE={a.etype}, ELSET=SOFT"):]
        del L[-len(element_lines):]
        L += extra + element_lines
    else:
        L.append(f"*ELEMENT, TYPE={a.etype}, ELSET=SOFT")
        L += [f"{e + 1}, " + ", ".join(str(int(n) + 1) for n in c) for e, (c, _) in enumerate(m["hexes"])]
    L += nset("DRIVEN", driven)
    L += nset("SKINN", [n + 1 for n in skin_nodes])
    L += [f"** {len(faces)} skin faces of the contact region (haptex's part 4 quads)", "*SURFACE, NAME=SKIN, TYPE=ELEMENT"]
    L += [f"{e}, S{f}" for e, f in faces]
    L += rigid_surface(xs, ys, h(xs), lift)
    L += ["*MATERIAL, NAME=SOFT"]
    if nl:
        L += [f"** E = {E_MPA} MPa, nu = {NU}: mu = {MU_SHEAR:.10g}, K = {K_BULK:.10g}", "*HYPERELASTIC, NEO HOOKE",
              f"{C10:.10g}, {D1:.10g}"]
    else:
        L += ["*ELASTIC", f"{E_MPA}, {NU}"]
    L += ["*MATERIAL, NAME=STIFF", "*ELASTIC", "1e5, 0.3",
          "*SOLID SECTION, ELSET=SOFT, MATERIAL=SOFT", "*SOLID SECTION, ELSET=RIGIDS, MATERIAL=STIFF",
          "*SURFACE INTERACTION, NAME=SKINFRICTION",
          "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR", f"{a.penalty}, {a.tension}"]
    if a.mu > 0:
        L += ["*FRICTION", f"{a.mu}, {a.stick}"]
    L += [f"*CONTACT PAIR, INTERACTION=SKINFRICTION, TYPE={a.contact}", "SKIN, SURFACE",
          "*BOUNDARY", "SURFN, 1, 3"]
    out = lambda when: [f"*NODE PRINT, NSET=SURFN, TOTALS=ONLY, {when}", "RF",
                        f"*NODE PRINT, NSET=DRIVEN, TOTALS=ONLY, {when}", "RF"]
    step = "*STEP, NLGEOM, INC=100000" if nl else "*STEP, INC=100000"
    if a.controls:
        step += "\n" + "\n".join(a.controls.split(";"))
    # press: 10 increments of indent/10 as haptex's press (printed at each)
    press_out = "FREQUENCY=1" if a.press_every_increment else "TIME POINTS=PRESS"
    L += ["*TIME POINTS, NAME=PRESS, GENERATE", "0.1, 1., 0.1",
          "** step 1: press", step, "*STATIC", "0.1, 1., 1e-5, 0.1",
          "*BOUNDARY", "DRIVEN, 1, 2, 0.", f"DRIVEN, 3, 3, {-a.indent}"] + out(press_out)
    if a.frd:
        L += ["*NODE FILE, NSET=NBODY, TIME POINTS=PRESS", "U"]
    L += ["*END STEP"]
    if a.slide > 0:
        L += [f"** step 2: slide {a.slide} mm along +x, increments of at most {a.inc} mm (step time = x in mm)", step,
              "*STATIC", f"{a.inc}, {a.slide}, 1e-7, {a.inc}",
              "*BOUNDARY", f"DRIVEN, 1, 1, {a.slide}", "DRIVEN, 2, 2, 0.", f"DRIVEN, 3, 3, {-a.indent}"] \
             + out("FREQUENCY=1") + ["*END STEP"]
    os.makedirs(a.out, exist_ok=True)
    path = os.path.join(a.out, a.job + ".inp")
    with open(path, "w") as f:
        f.write("\n".join(L) + "\n")
    print(f"wrote {path}: {len(P)} nodes, {len(m['hexes'])} {a.etype}, {len(faces)} skin faces, "
          f"{len(m['driven'])} driven, rigid {len(xs)}x{len(ys)} stations, lift {lift:.9g} (Gauss check {lift_gauss:.9g})")


if __name__ == "__main__":
    main()
