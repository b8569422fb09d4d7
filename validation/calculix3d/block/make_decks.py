#!/usr/bin/env python3
"""CalculiX decks of a block whose whole surface is moved by a smooth,
non-affine displacement (issue 39, the finite-strain 3D body's reference;
README.md here).

The block [0, 2]^3 mm, n elements per side; every boundary node is moved
by u(X) of xi = X / 2 mm:

    u_x = 2 (0.08 xi_y xi_z),  u_y = 2 (-0.06 xi_x xi_z),
    u_z = 2 (-0.25 xi_z + 0.10 xi_x xi_y xi_z)   (mm),

a 25% compression with shear and twist. The interior is free, so its
deformation is not homogeneous, and with smooth data on the whole
boundary of a convex body the solution is smooth: no edge singularity
slows the convergence with the mesh. E = 0.1 MPa, nu = 0.45 as haptex's
half-disc finger; finite strain with CalculiX's neo-Hookean law
(*HYPERELASTIC, NEO HOOKE, C10 = mu/2, D1 = 2/K: U(J) = (J - 1)^2 / D1,
which haptex's Volumetric::Quadratic is), or small strain (*ELASTIC).

Outputs asked of CalculiX: the total reaction on the top face (NSET=TOP,
its edges included) and the displacement of the centre node (NSET=MID).

Usage: make_decks.py --n N --etype C3D8|C3D8I|C3D20|C3D20R --kin nlgeom|linear -o DECK
"""
import argparse

L = 2.0


def displacement(x, y, z):
    """The prescribed displacement (mm) at the point (x, y, z) (mm)."""
    a, b, c = x / L, y / L, z / L
    return (L * 0.08 * b * c, L * -0.06 * a * c, L * (-0.25 * c + 0.10 * a * b * c))

E, NU = 0.1, 0.45
MU = E / (2 * (1 + NU))
K = E / (3 * (1 - 2 * NU))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, required=True, help="elements per side (even)")
    ap.add_argument("--etype", default="C3D20R")
    ap.add_argument("--kin", default="nlgeom", choices=["nlgeom", "linear"])
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args()
    if a.n % 2:
        raise SystemExit("--n must be even (the centre node is a grid node)")
    quadratic = a.etype.startswith("C3D20")
    m = 2 * a.n if quadratic else a.n  # grid intervals per side
    h = L / m
    ids = {}
    lines = ["** block moved on its whole surface (25% compression, shear, twist), written by make_decks.py",
             f"** n = {a.n}, element {a.etype}, {a.kin}", "*NODE"]
    for k in range(m + 1):
        for j in range(m + 1):
            for i in range(m + 1):
                if quadratic and (i % 2) + (j % 2) + (k % 2) > 1:
                    continue  # not a corner or mid-edge node of a C3D20
                ids[(i, j, k)] = len(ids) + 1
                lines.append(f"{ids[(i, j, k)]}, {i * h:.12g}, {j * h:.12g}, {k * h:.12g}")
    lines.append(f"*ELEMENT, TYPE={a.etype}, ELSET=BLOCK")
    s = 2 if quadratic else 1
    number = 0
    for k in range(0, m, s):
        for j in range(0, m, s):
            for i in range(0, m, s):
                c = [(i, j, k), (i + s, j, k), (i + s, j + s, k), (i, j + s, k),
                     (i, j, k + s), (i + s, j, k + s), (i + s, j + s, k + s), (i, j + s, k + s)]
                nodes = [ids[p] for p in c]
                if quadratic:
                    mid = lambda p, q: tuple((x + y) // 2 for x, y in zip(p, q))
                    edges = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4),
                             (0, 4), (1, 5), (2, 6), (3, 7)]
                    nodes += [ids[mid(c[p], c[q])] for p, q in edges]
                number += 1
                # CalculiX reads at most 16 entries per line: continue the rest.
                entries = [str(number)] + [str(v) for v in nodes]
                lines.append(", ".join(entries[:16]) + ("," if len(entries) > 16 else ""))
                if len(entries) > 16:
                    lines.append(", ".join(entries[16:]))
    top = [v for p, v in ids.items() if p[2] == m]
    boundary = [(p, v) for p, v in ids.items() if min(p) == 0 or max(p) == m]
    for name, nodes in (("TOP", top), ("MID", [ids[(m // 2, m // 2, m // 2)]])):
        lines.append(f"*NSET, NSET={name}")
        for c in range(0, len(nodes), 16):
            lines.append(", ".join(str(v) for v in nodes[c:c + 16]))
    lines += ["*MATERIAL, NAME=TISSUE"]
    if a.kin == "nlgeom":
        lines += ["*HYPERELASTIC, NEO HOOKE", f"{MU / 2:.12g}, {2 / K:.12g}"]
    else:
        lines += ["*ELASTIC", f"{E:.12g}, {NU:.12g}"]
    lines += ["*SOLID SECTION, ELSET=BLOCK, MATERIAL=TISSUE",
              "*STEP, NLGEOM, INC=1000" if a.kin == "nlgeom" else "*STEP, INC=1000",
              "*STATIC", "0.1, 1., 1e-4, 0.1",
              "*BOUNDARY"]
    for p, v in boundary:
        u = displacement(*(c * h for c in p))
        lines += [f"{v}, {d + 1}, {d + 1}, {u[d]:.15g}" for d in range(3)]
    lines += ["*NODE PRINT, NSET=TOP, TOTALS=ONLY", "RF", "*NODE PRINT, NSET=MID", "U", "*END STEP"]
    with open(a.output, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
