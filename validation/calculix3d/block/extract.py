#!/usr/bin/env python3
"""The last increment's figures of CalculiX block runs (make_decks.py's
*NODE PRINT requests) as CSV lines `job,fz_n,ux_mid_mm,uy_mid_mm,uz_mid_mm,wall_s`.

Usage: extract.py RUNS_DIR TIMES_FILE > results/block.csv
TIMES_FILE has one `job seconds` line per run (run.sh writes it).
"""
import pathlib
import sys


def last_values(dat, header):
    """The numbers on the first data line after the last `header` line."""
    lines = dat.read_text().splitlines()
    at = max(i for i, l in enumerate(lines) if header in l)
    for l in lines[at + 1:]:
        if l.strip():
            return [float(v) for v in l.split()]
    raise SystemExit(f"{dat}: nothing after '{header}'")


def main():
    runs = pathlib.Path(sys.argv[1])
    times = dict(l.split() for l in open(sys.argv[2]) if l.strip())
    print("job,fz_n,ux_mid_mm,uy_mid_mm,uz_mid_mm,wall_s")
    for job in times:
        dat = runs / f"{job}.dat"
        time_line = [l for l in dat.read_text().splitlines() if "total force" in l]
        if not time_line or "0.1000000E+01" not in time_line[-1]:
            raise SystemExit(f"{dat}: the run did not reach time 1")
        fz = last_values(dat, "total force (fx,fy,fz) for set TOP")[2]
        u = last_values(dat, "displacements (vx,vy,vz) for set MID")[1:4]
        print(f"{job},{fz:.7g},{u[0]:.7g},{u[1]:.7g},{u[2]:.7g},{float(times[job]):.2f}")


if __name__ == "__main__":
    main()
