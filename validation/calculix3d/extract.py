#!/usr/bin/env python3
"""Turn a CalculiX .dat of a make_decks.py deck into the reference CSV.

Usage: extract.py JOB.dat OUT.csv [--press OUT_press.csv]

The deck's step 1 is the press (step time 0..1 = indent x time), step 2 the
slide (total time 1 + x, x the distance travelled in mm). Forces are in N:

  fn_n = z-reaction summed over the fixed rigid surface's nodes (set SURFN),
         i.e. the z component of the contact force on the finger (> 0 pressing)
  ft_n = minus its x component: the friction force resisting the finger's
         motion towards +x (haptex: the surface moving towards -x under it)
  mu   = ft_n / fn_n

as haptex's profile `x_mm,mu,ft_n,fn_n`. The driven nodes' reaction (the
finger's equilibrium) is checked against it; the largest difference is
printed (relative to Fn). With --press the press rows (indent_mm,fn_n,ft_n)
are written too.
"""
import argparse
import re
import sys

HEAD = re.compile(r"^\s*total force \(fx,fy,fz\) for set (\w+) and time\s+(\S+)")


def parse_dat(path):
    """{time: {SET: (fx, fy, fz)}} (the last block of a time wins)"""
    data, cur = {}, None
    with open(path) as f:
        for line in f:
            m = HEAD.match(line)
            if m:
                cur = (m.group(1), float(m.group(2)))
                continue
            parts = line.split()
            if cur and len(parts) == 3:
                try:
                    data.setdefault(cur[1], {})[cur[0]] = tuple(float(v) for v in parts)
                except ValueError:
                    pass
                cur = None
    return data


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dat")
    ap.add_argument("csv")
    ap.add_argument("--press")
    ap.add_argument("--indent", type=float, default=0.5)
    a = ap.parse_args()
    data = parse_dat(a.dat)
    if not data:
        sys.exit(f"{a.dat}: no force output")
    worst = 0.0
    press, slide = [], []
    for t in sorted(data):
        rec = data[t]
        if "SURFN" not in rec:
            continue
        fx, fy, fz = rec["SURFN"]
        if "DRIVEN" in rec:
            d = rec["DRIVEN"]
            # equilibrium: driven reaction + surface reaction = 0
            worst = max(worst, max(abs(d[k] + rec["SURFN"][k]) for k in range(3)) / max(abs(fz), 1e-12))
        if t <= 1.0 + 1e-9:
            press.append((a.indent * t, fz, -fx))
        else:
            slide.append((t - 1.0, fz, -fx))
    with open(a.csv, "w") as f:
        f.write("x_mm,fn_n,ft_n,mu\n")
        for x, fn, ft in slide:
            f.write(f"{x:.6g},{fn:.7e},{ft:.7e},{ft / fn:.7f}\n")
    if a.press:
        with open(a.press, "w") as f:
            f.write("indent_mm,fn_n,ft_n\n")
            for d, fn, ft in press:
                f.write(f"{d:.6g},{fn:.7e},{ft:.7e}\n")
    last = slide[-1][0] if slide else None
    print(f"{a.csv}: {len(slide)} slide rows (last x = {last}), {len(press)} press rows; "
          f"max |RF(driven) + RF(surface)| / Fn = {worst:.2e}")


if __name__ == "__main__":
    main()
