#!/usr/bin/env python3
"""Write CalculiX decks for the half-disc reference from haptex's own mesh.

Reads the first frame of `haptex simulate --finger data/finger/half-disc.toml
--vtk DIR` (reference node positions, quads, per-cell subdomain ids) and
writes, into decks/:

  body_nodes.inp          the 2900 mesh nodes, twice (z = 0 and z = 1 mm)
  body_elements_<T>.inp   the soft quads (subdomains 0-3) as one layer of
                          3D bricks of type T (C3D8I by default, C3D8 for
                          the locking comparison), 1 mm thick
  body_sets.inp           node sets (all body nodes, the rigid set = bone
                          boundary + nail nodes, the contact nodes) and the
                          slave face surface
  strip_<surface>.inp     the rigid surface: one row of bricks below y = 0
                          whose top face follows the surface profile, all
                          of its nodes fixed
  <case>_<kin>[_<T>].inp  the decks (press, then slide), kin = linear
                          (small strain, linear elastic) or nlgeom (finite
                          strain, neo-Hookean)

Plane strain: every body node has u_z = 0; forces come out per mm of width
(the layer is 1 mm thick). The body never moves in x in haptex (the surface
slides towards -x); here the surface is fixed and the rigid set moves
towards +x, which is the same relative motion: the body's position on the
surface is the rigid set's x displacement.

Usage: make_decks.py FRAME.vtu [--out decks]
"""
import argparse
import math
import os
import re
import sys

import numpy as np

# --- haptex's contract for the half-disc (data/finger/half-disc.toml) -------
E_MPA, NU = 0.1, 0.45
MU_FRICTION = 0.5
PENALTY = 200.0  # MPa/mm = N/mm^3, haptex's --penalty default (normal and tangential)
INDENT = 0.25  # mm, rigid set pressed down from first touch
SLIDE = 10.0  # mm
CONTACT_HALF_ARC = 6.0  # mm, contact.contact_half_arc_mm
CENTRE_Y, RADIUS = 8.0, 8.0
# Gaussian bump h = r_h exp(-((x - x0)/(r_w/2))^2), surface coordinates
BUMP_X0, BUMP_RW, BUMP_RH = 5.0, 1.5, 0.3

# --- derived material constants ---------------------------------------------
MU_SHEAR = E_MPA / (2.0 * (1.0 + NU))  # 0.0344827...
K_BULK = E_MPA / (3.0 * (1.0 - 2.0 * NU))  # 0.3333...
C10 = MU_SHEAR / 2.0
D1 = 2.0 / K_BULK

SUB_SOFT = (0, 1, 2, 3)
SUB_BONE, SUB_NAIL, SUB_SURFACE = 4, 5, 6
LAYER1 = 10000  # node id offset of the z = 1 layer
STRIP_NODE0 = 20000
STRIP_ELEM0 = 50000
STRIP_X = (-7.0, 17.0)  # the slave nodes reach x = -5.5 .. 10 + 5.5


def read_vtu(path):
    text = open(path).read()

    def array(name):
        m = re.search(r'<DataArray[^>]*Name="%s"[^>]*>(.*?)</DataArray>' % name, text, re.S)
        if m is None:
            sys.exit(f"{path}: no DataArray {name}")
        return m.group(1).split()

    pts = re.search(r"<Points>\s*<DataArray[^>]*>(.*?)</DataArray>", text, re.S).group(1).split()
    pts = np.array(pts, float).reshape(-1, 3)[:, :2]
    conn = np.array(array("connectivity"), int)
    offsets = np.array(array("offsets"), int)
    sub = np.array(array("subdomain"), int)
    starts = np.r_[0, offsets[:-1]]
    cells = [conn[s:e] for s, e in zip(starts, offsets)]
    return pts, cells, sub


def fmt(v):
    return f"{v:.12g}"


def write(path, lines):
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def surface_nodes(kind):
    """x stations of the rigid surface's top face and the heights there."""
    if kind == "flat":
        xs = np.arange(STRIP_X[0], STRIP_X[1] + 1e-9, 0.1)
        return xs, np.zeros_like(xs)
    # bump: 0.05 mm facets within +-2.5 mm of the top (h < 5e-6 mm beyond),
    # 0.1 mm elsewhere; the chord error of the facets is below 0.4 um.
    lo, hi = BUMP_X0 - 2.5, BUMP_X0 + 2.5
    xs = np.unique(np.round(np.concatenate([
        np.arange(STRIP_X[0], lo, 0.1), np.arange(lo, hi + 1e-9, 0.05),
        np.arange(hi, STRIP_X[1] + 1e-9, 0.1)]), 9))
    return xs, BUMP_RH * np.exp(-(((xs - BUMP_X0) / (BUMP_RW / 2.0)) ** 2))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("frame", help="haptex VTK frame (frame_0000.vtu)")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "decks"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    pts, cells, sub = read_vtu(args.frame)

    body_nodes = sorted({int(n) for c, s in zip(cells, sub) if s != SUB_SURFACE for n in c})
    assert body_nodes == list(range(len(body_nodes))), "body nodes are not 0..N-1"
    nb = len(body_nodes)
    assert pts[:nb, 1].min() == 0.0, "the lowest body node is not at y = 0"
    soft = [(i, c) for i, (c, s) in enumerate(zip(cells, sub)) if s in SUB_SOFT]
    assert all(len(c) == 4 for _, c in soft)
    bone = [c for c, s in zip(cells, sub) if s == SUB_BONE]
    nail = [c for c, s in zip(cells, sub) if s == SUB_NAIL]
    rigid = sorted({int(n) for c in bone + nail for n in c})
    # quads counter-clockwise (C3D8 needs nodes 1-4 counter-clockwise seen from +z)
    for _, c in soft:
        x, y = pts[c, 0], pts[c, 1]
        assert 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) > 0

    # contact nodes: on the outer circle within contact_half_arc of the bottom
    r = np.hypot(pts[:nb, 0], pts[:nb, 1] - CENTRE_Y)
    arc = RADIUS * np.abs(np.arctan2(pts[:nb, 0], CENTRE_Y - pts[:nb, 1]))
    contact = set(np.where((np.abs(r - RADIUS) < 1e-6) & (arc <= CONTACT_HALF_ARC + 1e-6))[0].tolist())
    # slave faces: quad edge k (nodes k, k+1) is brick face S(3+k)
    faces = []
    for i, c in soft:
        for k in range(4):
            if int(c[k]) in contact and int(c[(k + 1) % 4]) in contact:
                faces.append((i + 1, 3 + k))
    assert len(faces) == len(contact) - 1, (len(faces), len(contact))

    hdr = [f"** generated by make_decks.py from {os.path.basename(args.frame)} (haptex mesh of data/finger/half-disc.toml)"]
    lines = hdr + ["*NODE, NSET=NBODY"]
    for n in range(nb):
        x, y = pts[n]
        lines.append(f"{n + 1}, {fmt(x)}, {fmt(y)}, 0.")
    for n in range(nb):
        x, y = pts[n]
        lines.append(f"{n + 1 + LAYER1}, {fmt(x)}, {fmt(y)}, 1.")
    write(os.path.join(args.out, "body_nodes.inp"), lines)

    for etype in ("C3D8I", "C3D8"):
        lines = hdr + [f"*ELEMENT, TYPE={etype}, ELSET=SOFT"]
        for i, c in soft:
            a = [int(n) + 1 for n in c]
            lines.append(f"{i + 1}, " + ", ".join(str(n) for n in a + [n + LAYER1 for n in a]))
        write(os.path.join(args.out, f"body_elements_{etype}.inp"), lines)

    def nset(name, ids):
        out = [f"*NSET, NSET={name}"]
        for k in range(0, len(ids), 12):
            out.append(", ".join(str(n) for n in ids[k:k + 12]) + ",")
        return out

    ids = lambda nodes: [n + 1 for n in nodes] + [n + 1 + LAYER1 for n in nodes]
    lines = hdr + [f"** rigid set: {len(rigid)} nodes (bone boundary {len({int(n) for c in bone for n in c})}, nail {len({int(n) for c in nail for n in c})}), both layers"]
    lines += nset("RIGID", ids(rigid))
    lines += [f"** contact nodes: {len(contact)} skin nodes within {CONTACT_HALF_ARC} mm of arc of the bottom (haptex's contact region)"]
    lines += nset("SLAVEN", ids(sorted(contact)))
    lines += nset("SLAVE0", [n + 1 for n in sorted(contact)])
    lines += ["*SURFACE, NAME=SLAVE, TYPE=ELEMENT"] + [f"{e}, S{s}" for e, s in faces]
    write(os.path.join(args.out, "body_sets.inp"), lines)

    for kind in ("flat", "bump"):
        xs, hs = surface_nodes(kind)
        n = len(xs)
        # node grid: index j (x station), level (0: y = -1 bottom, 1: top y = h), z in (-1, 2)
        nid = lambda j, top, zl: STRIP_NODE0 + 1 + j + n * (top + 2 * zl)
        lines = [f"** rigid {kind} surface: {n} stations from x = {xs[0]:g} to {xs[-1]:g} mm, top face y = h(x); all nodes fixed",
                 "*NODE, NSET=STRIPN"]
        for zl, z in enumerate((-1.0, 2.0)):
            for top in (0, 1):
                for j in range(n):
                    lines.append(f"{nid(j, top, zl)}, {fmt(xs[j])}, {fmt(hs[j] if top else -1.0)}, {fmt(z)}")
        lines.append("*ELEMENT, TYPE=C3D8, ELSET=STRIP")
        for j in range(n - 1):
            q = [nid(j, 0, 0), nid(j + 1, 0, 0), nid(j + 1, 1, 0), nid(j, 1, 0)]
            q1 = [nid(j, 0, 1), nid(j + 1, 0, 1), nid(j + 1, 1, 1), nid(j, 1, 1)]
            lines.append(f"{STRIP_ELEM0 + j + 1}, " + ", ".join(map(str, q + q1)))
        # the top edge (nodes 3-4 of the quad) is face S5
        lines += ["*SURFACE, NAME=MASTER, TYPE=ELEMENT"] + [f"{STRIP_ELEM0 + j + 1}, S5" for j in range(n - 1)]
        write(os.path.join(args.out, f"strip_{kind}.inp"), lines)

    decks = []
    for case in ("flat", "bump"):
        for kin in ("linear", "nlgeom"):
            decks.append((case, kin, "C3D8I", MU_FRICTION, SLIDE))
    # press-only variants: locking (plain fully integrated bricks, both
    # kinematics), a frictionless press (Hertz), and NLGEOM with the linear
    # elastic law (St Venant-Kirchhoff: geometric nonlinearity alone)
    decks.append(("flat", "linear", "C3D8", MU_FRICTION, 0.0))
    decks.append(("flat", "nlgeom", "C3D8", MU_FRICTION, 0.0))
    decks.append(("flat", "linear", "C3D8I", 0.0, 0.0))
    decks.append(("flat", "nlgeomsvk", "C3D8I", MU_FRICTION, 0.0))
    for case, kin, etype, mu, slide in decks:
        name = f"{case}_{kin}"
        if slide == 0.0:
            name = f"press_{kin}_{etype}" + ("_mu0" if mu == 0.0 else "")
        write(os.path.join(args.out, name + ".inp"), deck(name, case, kin, etype, mu, slide))
        print("wrote", os.path.join(args.out, name + ".inp"))


def deck(name, case, kin, etype, mu, slide):
    nl = kin.startswith("nlgeom")
    hyper = kin == "nlgeom"
    L = [f"** {name}: half-disc (data/finger/half-disc.toml) on the rigid {case} surface",
         f"** {'finite strain (NLGEOM), neo-Hookean C10 = mu/2, D1 = 2/K' if hyper else 'finite strain (NLGEOM), linear elastic law on Green-Lagrange strain (St Venant-Kirchhoff)' if nl else 'small strain, linear elastic'};"
         f" {etype} bricks, one layer 1 mm thick, u_z = 0 (plane strain)",
         f"** press the rigid set {INDENT} mm down, then slide it {slide} mm towards +x over the fixed surface",
         "*INCLUDE, INPUT=body_nodes.inp",
         f"*INCLUDE, INPUT=body_elements_{etype}.inp",
         "*INCLUDE, INPUT=body_sets.inp",
         f"*INCLUDE, INPUT=strip_{case}.inp",
         "*MATERIAL, NAME=SOFT"]
    if hyper:
        L += [f"** E = {E_MPA} MPa, nu = {NU}: mu = {MU_SHEAR:.10g}, K = {K_BULK:.10g}",
              "*HYPERELASTIC, NEO HOOKE", f"{C10:.10g}, {D1:.10g}"]
    else:
        L += ["*ELASTIC", f"{E_MPA}, {NU}"]
    L += ["*MATERIAL, NAME=STIFF", "*ELASTIC", "1e5, 0.3",
          "*SOLID SECTION, ELSET=SOFT, MATERIAL=SOFT", "1.",
          "*SOLID SECTION, ELSET=STRIP, MATERIAL=STIFF", "1.",
          "*SURFACE INTERACTION, NAME=SKIN",
          "** linear pressure-overclosure: slope 200 N/mm^3 (MPa per mm), tension at large clearance 1e-7 MPa (1e-5 of the peak pressure:"
          " with 1e-5 MPa the few slave nodes just outside the contact pulled on it and the surface and body reactions differed by 7e-4)",
          "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR", f"{PENALTY}, 1e-7"]
    if mu > 0:
        L += ["** Coulomb mu, stick slope (N/mm^3) = haptex's tangential penalty", "*FRICTION", f"{mu}, {PENALTY}"]
    L += ["*CONTACT PAIR, INTERACTION=SKIN, TYPE=NODE TO SURFACE", "SLAVE, MASTER",
          "*BOUNDARY", "NBODY, 3, 3", "STRIPN, 1, 3"]
    outputs = lambda when: [f"*NODE PRINT, NSET=RIGID, TOTALS=ONLY, {when}", "RF",
                            f"*NODE PRINT, NSET=STRIPN, TOTALS=ONLY, {when}", "RF",
                            f"*NODE PRINT, NSET=SLAVE0, {when}", "U",
                            f"*CONTACT PRINT, {when}", "CSTR"]
    step = "*STEP, NLGEOM, INC=100000" if nl else "*STEP, INC=100000"
    # the press is printed at every 0.025 mm whatever increments ccx takes;
    # the slide at every converged increment (at most 0.1 mm apart)
    L += ["*TIME POINTS, NAME=PRESS, GENERATE", "0.1, 1., 0.1"]
    L += ["** step 1: press, increments of at most 0.025 mm", step, "*STATIC", "0.1, 1., 1e-5, 0.1",
          "*BOUNDARY", "RIGID, 1, 1, 0.", f"RIGID, 2, 2, {-INDENT}"] + outputs("TIME POINTS=PRESS") + ["*END STEP"]
    if slide > 0:
        L += [f"** step 2: slide {slide} mm, increments of at most 0.1 mm", step, "*STATIC",
              f"{0.1 / slide:.6g}, 1., 1e-6, {0.1 / slide:.6g}",
              "*BOUNDARY", f"RIGID, 1, 1, {slide}", f"RIGID, 2, 2, {-INDENT}"] + outputs("FREQUENCY=1") + ["*END STEP"]
    return L


if __name__ == "__main__":
    main()
