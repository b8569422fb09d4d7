#!/usr/bin/env python3
"""Times the check on the finger model through the web API.

Against a running `haptex serve` (default http://127.0.0.1:8080): the FE
database's central bump (r_w 1.5, r_h 0.3 mm, 20 mm/s, from POST
/api/predict: a database case, so its FE profile) as the target with the
display's mu_HD = 0.5 (its flat value), sent N times to POST /api/check
and to POST /api/compensate; then a library stroke (latex, seed 3) once
each. Prints the median and range of the wall time from sending the
request to the answer's last line, the FE time the result reports, and
when the first line arrived (BENCHMARKS.md, "Closing the loop").

Usage: python3 scripts/time_check_api.py [--url http://127.0.0.1:8080] [-n 7]
"""

import argparse
import json
import statistics
import time
import urllib.request


def post(url, body):
    request = urllib.request.Request(url, data=json.dumps(body).encode(), headers={"Content-Type": "application/json"})
    return urllib.request.urlopen(request)


def timed(url, body):
    """Wall time, time to the first line, and the result."""
    started = time.time()
    first = None
    lines = []
    with post(url, body) as answer:
        for line in answer:
            if first is None:
                first = time.time() - started
            lines.append(json.loads(line))
    last = lines[-1]
    if "result" not in last:
        raise SystemExit(f"no result: {last}")
    return time.time() - started, first, last["result"]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--url", default="http://127.0.0.1:8080")
    parser.add_argument("-n", type=int, default=7)
    args = parser.parse_args()
    bump = json.load(post(f"{args.url}/api/predict", {"surface": "bump", "x0_mm": 5, "width_mm": 1.5, "height_mm": 0.3}))
    body = {"profile": {"x_mm": bump["x_mm"], "mu": bump["mu"]}, "device": {"mu_hd": 0.5}}
    for route in ("check", "compensate"):
        runs = [timed(f"{args.url}/api/{route}", body) for _ in range(args.n)]
        walls = [r[0] for r in runs]
        result = runs[-1][2]
        print(
            f"bump, /api/{route}: {statistics.median(walls):.3f} s ({min(walls):.3f}-{max(walls):.3f}), "
            f"FE {statistics.median(r[2]['fe_seconds'] for r in runs):.3f} s, {result['fe_runs']} FE run(s), "
            f"first line after {statistics.median(r[1] for r in runs):.3f} s"
        )
    stroke = json.load(urllib.request.urlopen(f"{args.url}/api/materials/latex/sample?seed=3"))
    body = {"profile": {"x_mm": stroke["x_mm"], "mu": stroke["mu"], "fn_n": stroke["fn_n"]}}
    span = stroke["x_mm"][-1] - stroke["x_mm"][0]
    for route in ("check", "compensate"):
        wall, _, result = timed(f"{args.url}/api/{route}", body)
        errors = ", ".join(f"{t['metrics']['rms_error']:.3e}" for t in result["trials"])
        print(
            f"latex stroke ({span:.1f} mm, {stroke['n_points']} points), /api/{route}: {wall:.2f} s, "
            f"{result['fe_runs']} FE run(s) at {result['settings']['step_mm']} mm steps, RMS errors {errors}"
        )


if __name__ == "__main__":
    main()
