#!/usr/bin/env python3
"""Convert a generic force/position export into a haptex recording.

Reads two CSV files (any column names, any of the units below), converts
them to haptex's units (s, N, mm) and writes NAME.force.csv,
NAME.position.csv and NAME.recording.json into --out. Standard library only.
docs/recordings.md explains the format; adapt this script to your lab's
export (for MATLAB .mat files, load the arrays with scipy.io.loadmat and
call write_recording() directly).

Example (a lab export in ms, mN and m, friction force reported on the
finger, i.e. opposing the motion):

    python3 scripts/convert_recording.py \\
        --force trial07_forces.csv --force-columns time,Fz,Fx \\
        --position trial07_track.csv --position-columns time,X \\
        --time-unit ms --force-unit mN --position-unit m --flip-ft \\
        --force-rate 20000 --position-rate 400 \\
        --material velvet --participant P3 --stroke 7 \\
        --source "Lab X 2025, protocol Y" --licence CC-BY-4.0 \\
        --out recordings/velvet --name velvet-P3-07
"""

import argparse
import csv
import json
import math
import os
import sys

TIME = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
FORCE = {"N": 1.0, "mN": 1e-3, "kN": 1e3}
LENGTH = {"mm": 1.0, "m": 1e3, "cm": 10.0, "um": 1e-3}


def read_columns(path, names):
    """The named columns of a CSV file (header row, '#' comments) as floats."""
    with open(path, newline="") as f:
        rows = csv.reader(line for line in f if line.strip() and not line.lstrip().startswith("#"))
        header = [h.strip() for h in next(rows)]
        missing = [n for n in names if n not in header]
        if missing:
            sys.exit(f"{path}: no column {missing[0]!r} (the header has {', '.join(header)})")
        index = [header.index(n) for n in names]
        columns = [[] for _ in names]
        for line_number, row in enumerate(rows, start=2):
            for column, i in zip(columns, index):
                try:
                    value = float(row[i])
                except (ValueError, IndexError):
                    sys.exit(f"{path}, data row near line {line_number}: not a number in column {header[i]!r}")
                if not math.isfinite(value):
                    sys.exit(f"{path}, data row near line {line_number}: {value} in column {header[i]!r}")
                column.append(value)
    return columns


def write_csv(path, header, columns):
    with open(path, "w", newline="") as f:
        f.write(",".join(header) + "\n")
        for row in zip(*columns):
            f.write(",".join(repr(v) for v in row) + "\n")


def write_recording(out, name, t_force_s, fn_n, ft_n, t_position_s, x_mm, metadata):
    """Writes the haptex recording NAME into directory OUT (units s, N, mm)."""
    os.makedirs(out, exist_ok=True)
    write_csv(os.path.join(out, f"{name}.force.csv"), ["t_s", "fn_n", "ft_n"], [t_force_s, fn_n, ft_n])
    write_csv(os.path.join(out, f"{name}.position.csv"), ["t_s", "x_mm"], [t_position_s, x_mm])
    meta = dict(metadata)
    meta["format"] = "haptex-recording-1"
    meta["force"] = {"file": f"{name}.force.csv", "rate_hz": meta.pop("force_rate_hz")}
    meta["position"] = {"file": f"{name}.position.csv", "rate_hz": meta.pop("position_rate_hz")}
    meta["units"] = {"time": "s", "force": "N", "position": "mm"}
    path = os.path.join(out, f"{name}.recording.json")
    with open(path, "w") as f:
        json.dump(meta, f, indent=2)
        f.write("\n")
    return path


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--force", required=True, help="CSV with time, normal force, tangential force")
    p.add_argument("--force-columns", required=True, help="their column names: TIME,NORMAL,TANGENTIAL")
    p.add_argument("--position", required=True, help="CSV with time and finger position")
    p.add_argument("--position-columns", required=True, help="their column names: TIME,POSITION")
    p.add_argument("--time-unit", choices=TIME, default="s")
    p.add_argument("--force-unit", choices=FORCE, default="N")
    p.add_argument("--position-unit", choices=LENGTH, default="mm")
    p.add_argument("--flip-ft", action="store_true",
                   help="negate the tangential force (haptex wants the force the finger exerts on the surface, "
                        "positive while sliding towards +x)")
    p.add_argument("--flip-x", action="store_true", help="negate the position")
    p.add_argument("--force-rate", type=float, required=True, help="force sampling rate, Hz")
    p.add_argument("--position-rate", type=float, required=True, help="position sampling rate, Hz")
    p.add_argument("--material", required=True)
    p.add_argument("--material-description", default="")
    p.add_argument("--participant", required=True)
    p.add_argument("--stroke", type=int, required=True)
    p.add_argument("--source", required=True, help="study, citation, instrument")
    p.add_argument("--licence", required=True, help="licence of the data, e.g. CC-BY-4.0")
    p.add_argument("--synthetic", action="store_true", help="the data are generated, not measured")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--name", required=True, help="file stem of the recording")
    a = p.parse_args()

    t, fn, ft = read_columns(a.force, a.force_columns.split(","))
    tp, x = read_columns(a.position, a.position_columns.split(","))
    ts, fs, ls = TIME[a.time_unit], FORCE[a.force_unit], LENGTH[a.position_unit]
    sign_ft = -1.0 if a.flip_ft else 1.0
    sign_x = -1.0 if a.flip_x else 1.0
    path = write_recording(
        a.out, a.name,
        [v * ts for v in t], [v * fs for v in fn], [sign_ft * v * fs for v in ft],
        [v * ts for v in tp], [sign_x * v * ls for v in x],
        {
            "material": a.material,
            "material_description": a.material_description,
            "participant": a.participant,
            "stroke": a.stroke,
            "force_rate_hz": a.force_rate,
            "position_rate_hz": a.position_rate,
            "source": a.source,
            "licence": a.licence,
            "synthetic": a.synthetic,
            "extra": {"converted_from": [os.path.abspath(a.force), os.path.abspath(a.position)]},
        },
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
