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
                          boundary + nail nodes, haptex's contact nodes) and
                          the skin face surface SKIN of the contact region
  strip_<surface>.inp     the rigid surface: one row of bricks below y = 0
                          whose top face (surface SURFACE) follows the
                          surface profile, all of its nodes fixed
  <case>_<kin>.inp        the reference decks (press, then slide 10 mm),
                          kin = linear (small strain, linear elastic) or
                          nlgeom (finite strain, neo-Hookean)
  press_*.inp             press-only variants (locking, frictionless, SVK)
  variants/               what was tried to get the bump slide through

Contact: node-to-surface penalty, skin nodes = slaves, the rigid surface's
faces = master; 200 N/mm^3 (= MPa/mm) linear pressure-overclosure, Coulomb
mu = 0.5 with a stick slope of 200 N/mm^3, as haptex's defaults.

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


def surface_nodes(kind, facet=0.05):
    """x stations of the rigid surface's top face and the heights there."""
    if kind == "flat":
        xs = np.arange(STRIP_X[0], STRIP_X[1] + 1e-9, 0.1)
        return xs, np.zeros_like(xs)
    # bump: `facet` mm facets within +-2.5 mm of the top (h < 5e-6 mm beyond),
    # 0.1 mm elsewhere; with 0.05 mm facets the chord error is below 0.4 um.
    lo, hi = BUMP_X0 - 2.5, BUMP_X0 + 2.5
    xs = np.unique(np.round(np.concatenate([
        np.arange(STRIP_X[0], lo, 0.1), np.arange(lo, hi + 1e-9, facet),
        np.arange(hi, STRIP_X[1] + 1e-9, 0.1)]), 9))
    return xs, BUMP_RH * np.exp(-(((xs - BUMP_X0) / (BUMP_RW / 2.0)) ** 2))


def strip(kind, facet=0.05, z=(-1.0, 2.0)):
    """The rigid surface as one row of C3D8 bricks (all nodes fixed in the
    decks), top face S5 = surface SURFACE. z = (-1, 2) overhangs the 1 mm
    body so that no skin node projects onto a face's edge."""
    xs, hs = surface_nodes(kind, facet)
    n = len(xs)
    nid = lambda j, top, zl: STRIP_NODE0 + 1 + j + n * (top + 2 * zl)
    lines = [f"** rigid {kind} surface: {n} stations from x = {xs[0]:g} to {xs[-1]:g} mm"
             + (f" ({facet} mm facets over the bump)" if kind == "bump" else "")
             + f", top face y = h(x), z = {z[0]:g} .. {z[1]:g}; all nodes fixed",
             "*NODE, NSET=STRIPN"]
    for zl, zz in enumerate(z):
        for top in (0, 1):
            for j in range(n):
                lines.append(f"{nid(j, top, zl)}, {fmt(xs[j])}, {fmt(hs[j] if top else -1.0)}, {fmt(zz)}")
    lines.append("*ELEMENT, TYPE=C3D8, ELSET=STRIP")
    for j in range(n - 1):
        q = [nid(j, 0, 0), nid(j + 1, 0, 0), nid(j + 1, 1, 0), nid(j, 1, 0)]
        q1 = [nid(j, 0, 1), nid(j + 1, 0, 1), nid(j + 1, 1, 1), nid(j, 1, 1)]
        lines.append(f"{STRIP_ELEM0 + j + 1}, " + ", ".join(map(str, q + q1)))
    # the top edge (nodes 3-4 of the quad) is face S5
    lines += ["*SURFACE, NAME=SURFACE, TYPE=ELEMENT"] + [f"{STRIP_ELEM0 + j + 1}, S5" for j in range(n - 1)]
    return lines


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
    # skin faces of the contact region: quad edge k (nodes k, k+1) is brick face S(3+k)
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
    lines += nset("CONTACTN", ids(sorted(contact)))
    lines += nset("CONTACT0", [n + 1 for n in sorted(contact)])
    lines += ["*SURFACE, NAME=SKIN, TYPE=ELEMENT"] + [f"{e}, S{s}" for e, s in faces]
    write(os.path.join(args.out, "body_sets.inp"), lines)

    write(os.path.join(args.out, "strip_flat.inp"), strip("flat"))
    write(os.path.join(args.out, "strip_bump.inp"), strip("bump"))

    # the reference decks: node-to-surface penalty contact, skin = slave
    decks = []
    for case in ("flat", "bump"):
        for kin in ("linear", "nlgeom"):
            decks.append((f"{case}_{kin}", dict(case=case, kin=kin)))
    # press-only variants: locking (plain fully integrated bricks, both
    # kinematics), a frictionless press (Hertz), and NLGEOM with the linear
    # elastic law (St Venant-Kirchhoff: geometric nonlinearity alone)
    decks.append(("press_linear_C3D8", dict(case="flat", kin="linear", etype="C3D8", slide=0.0)))
    decks.append(("press_nlgeom_C3D8", dict(case="flat", kin="nlgeom", etype="C3D8", slide=0.0)))
    decks.append(("press_linear_C3D8I_mu0", dict(case="flat", kin="linear", mu=0.0, slide=0.0)))
    decks.append(("press_nlgeomsvk_C3D8I", dict(case="flat", kin="nlgeomsvk", slide=0.0)))
    for name, kw in decks:
        write(os.path.join(args.out, name + ".inp"), deck(name, **kw))
        print("wrote", os.path.join(args.out, name + ".inp"))

    # what else was tried to get the small-strain bump slide through (README,
    # "The bump"): run with `run.sh variants`
    vdir = os.path.join(args.out, "variants")
    os.makedirs(vdir, exist_ok=True)
    write(os.path.join(vdir, "strip_bump_facet0.01.inp"), strip("bump", facet=0.01))
    write(os.path.join(vdir, "strip_bump_z01.inp"), strip("bump", z=(0.0, 1.0)))
    variants = [
        ("bump_linear_inc0.025", dict(bump_inc=0.025)),
        ("bump_linear_smallsliding", dict(contact="NODE TO SURFACE, SMALL SLIDING")),
        ("bump_linear_smallsliding_inc0.025", dict(contact="NODE TO SURFACE, SMALL SLIDING", bump_inc=0.025)),
        ("bump_linear_stick20", dict(stick=20.0)),
        ("bump_linear_stick20_inc0.025", dict(stick=20.0, bump_inc=0.025)),
        ("bump_linear_facet0.01_inc0.025", dict(strip_file="variants/strip_bump_facet0.01.inp", bump_inc=0.025)),
        ("bump_linear_surface2surface", dict(contact="SURFACE TO SURFACE")),
        ("bump_linear_surfaceslave", dict(strip_file="variants/strip_bump_z01.inp", pair="SURFACE, SKIN")),
        ("bump_linear_linmortar", dict(contact="LINMORTAR")),
        ("bump_nlgeom_linmortar", dict(contact="LINMORTAR", kin="nlgeom")),
    ]
    for name, kw in variants:
        kw.setdefault("kin", "linear")
        write(os.path.join(vdir, name + ".inp"), deck(name, case="bump", **kw))
    print(f"wrote {len(variants)} variant decks in {vdir}")


def deck(name, case, kin, etype="C3D8I", mu=MU_FRICTION, slide=SLIDE, contact="NODE TO SURFACE",
         stick=PENALTY, bump_inc=0.1, strip_file=None, pair="SKIN, SURFACE"):
    """One deck: press the rigid set INDENT down, then slide it `slide` mm
    towards +x. kin: linear (small strain, linear elastic), nlgeom (finite
    strain, neo-Hookean), nlgeomsvk (finite strain, linear elastic law on
    the Green-Lagrange strain)."""
    nl = kin.startswith("nlgeom")
    hyper = kin == "nlgeom"
    law = ("finite strain (NLGEOM), neo-Hookean C10 = mu/2, D1 = 2/K" if hyper else
           "finite strain (NLGEOM), linear elastic law on the Green-Lagrange strain (St Venant-Kirchhoff)" if nl else
           "small strain, linear elastic")
    L = [f"** {name}: half-disc (data/finger/half-disc.toml) on the rigid {case} surface",
         f"** {law}; {etype} bricks, one layer 1 mm thick, u_z = 0 (plane strain)",
         f"** press the rigid set {INDENT} mm down, then slide it {slide:g} mm towards +x over the fixed surface",
         "*INCLUDE, INPUT=body_nodes.inp",
         f"*INCLUDE, INPUT=body_elements_{etype}.inp",
         "*INCLUDE, INPUT=body_sets.inp",
         f"*INCLUDE, INPUT={strip_file or f'strip_{case}.inp'}",
         "*MATERIAL, NAME=SOFT"]
    if hyper:
        L += [f"** E = {E_MPA} MPa, nu = {NU}: mu = {MU_SHEAR:.10g}, K = {K_BULK:.10g}",
              "*HYPERELASTIC, NEO HOOKE", f"{C10:.10g}, {D1:.10g}"]
    else:
        L += ["*ELASTIC", f"{E_MPA}, {NU}"]
    L += ["*MATERIAL, NAME=STIFF", "*ELASTIC", "1e5, 0.3",
          "*SOLID SECTION, ELSET=SOFT, MATERIAL=SOFT", "1.",
          "*SOLID SECTION, ELSET=STRIP, MATERIAL=STIFF", "1.",
          "*SURFACE INTERACTION, NAME=SKINFRICTION",
          "** linear pressure-overclosure: slope 200 N/mm^3 (MPa per mm), tension at large clearance 1e-7 MPa (1e-5 of the peak pressure:"
          " with 1e-5 MPa the few slave nodes just outside the contact pulled on it and the surface and body reactions differed by 7e-4)",
          "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR", f"{PENALTY}, 1e-7"]
    if mu > 0:
        L += ["** Coulomb mu, stick slope (N/mm^3; haptex's tangential penalty is 200)", "*FRICTION", f"{mu}, {stick}"]
    L += [f"*CONTACT PAIR, INTERACTION=SKINFRICTION, TYPE={contact}", pair,
          "*BOUNDARY", "NBODY, 3, 3", "STRIPN, 1, 3"]
    outputs = lambda when: [f"*NODE PRINT, NSET=RIGID, TOTALS=ONLY, {when}", "RF",
                            f"*NODE PRINT, NSET=STRIPN, TOTALS=ONLY, {when}", "RF",
                            f"*NODE PRINT, NSET=CONTACT0, {when}", "U",
                            f"*CONTACT PRINT, {when}", "CSTR"]
    step = "*STEP, NLGEOM, INC=100000" if nl else "*STEP, INC=100000"
    # the press is printed at every 0.025 mm whatever increments ccx takes;
    # the slide at every converged increment
    L += ["*TIME POINTS, NAME=PRESS, GENERATE", "0.1, 1., 0.1"]
    L += ["** step 1: press, increments of at most 0.025 mm", step, "*STATIC", "0.1, 1., 1e-5, 0.1",
          "*BOUNDARY", "RIGID, 1, 1, 0.", f"RIGID, 2, 2, {-INDENT}"] + outputs("TIME POINTS=PRESS") + ["*END STEP"]
    # slide steps: the step time is the slide in mm, so total time - 1 = the
    # body's position x on the surface
    segments = [(slide, 0.1)]
    if case == "bump" and bump_inc != 0.1:
        segments = [(2.0, 0.1), (8.5, bump_inc), (slide, 0.1)]
    x = 0.0
    for k, (x_end, inc) in enumerate(segments if slide > 0 else []):
        L += [f"** step {k + 2}: slide from x = {x:g} to {x_end:g} mm, increments of at most {inc} mm", step, "*STATIC",
              f"{inc}, {x_end - x:.10g}, 1e-7, {inc}",
              "*BOUNDARY", f"RIGID, 1, 1, {x_end}", f"RIGID, 2, 2, {-INDENT}"] + outputs("FREQUENCY=1") + ["*END STEP"]
        x = x_end
    return L


if __name__ == "__main__":
    main()
