#!/usr/bin/env python3
"""/api/health under heavy load: 12 clients send FE checks, maps and plays
for 40 s while a separate process samples GET /api/health.

Method. Against a running `haptex serve` (release build, default
http://127.0.0.1:8080), `--clients` processes (default 12) each send heavy
requests back to back for `--seconds` (default 40), in turn:

- POST /api/check: a 10 mm bump (201 points, mu 0.5 to 0.6, mu_HD 0.5),
  one FE run at the default 0.05 mm step;
- POST /api/map: a 512 x 512 8-bit grayscale PNG (concentric rings, the
  server's largest image), its friction and voltage maps as JSON;
- POST /api/play: a 10 mm voltage curve played over 100 back-and-forth
  strokes at 50 mm/s (20 s at 48 kHz: 960 001 samples) as a PCM16 WAV.

Meanwhile one more process (not a thread of the load's: its timing does
not wait for the load's Python) sends GET /api/health every
`--interval-ms` (default 10 ms) on a kept-alive connection and times each
from sending to the whole answer read. Printed: the health latency's
p50, p99 and max and its errors (any answer but 200, any socket error),
and for each heavy kind the number sent, the statuses answered (503 is
the server's admission control refusing work when its heavy slots are
full: expected under this load, and counted apart from errors) and the
median latency. With `--pid PID` (the server's process) the server's
resident memory is printed before the load, at its peak (VmHWM) and
`--settle` seconds (default 5) after the load has stopped.

The machine running this should be otherwise idle (the figures of a
shared machine are noisy); the server and this script share its cores.

Usage:
  cargo build --profile release -p haptex-cli
  target/release/haptex serve --addr 127.0.0.1:8080 &
  python3 scripts/load_health.py --pid $!
"""

import argparse
import base64
import http.client
import json
import math
import multiprocessing
import statistics
import struct
import sys
import time
import urllib.parse
import zlib


def check_body():
    x = [0.05 * i for i in range(201)]
    mu = [0.5 + 0.1 * math.exp(-(((xi - 5.0) / 0.75) ** 2)) for xi in x]
    return {"profile": {"x_mm": x, "mu": mu}, "device": {"mu_hd": 0.5}}


def png_gray(width, height, pixel):
    """An 8-bit grayscale PNG (no filter) of pixel(i, j) in 0..255."""
    rows = b"".join(b"\x00" + bytes(pixel(i, j) for i in range(width)) for j in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows, 6)) + chunk(b"IEND", b"")


def map_body():
    n = 512
    png = png_gray(n, n, lambda i, j: int(127.5 + 127.5 * math.sin(math.hypot(i - n / 2, j - n / 2) / 4.0)))
    return {
        "image_png_base64": base64.b64encode(png).decode(),
        "mu_black": 0.4,
        "mu_white": 1.2,
        "pixel_mm": 0.1,
    }


def play_body():
    x = [0.1 * i for i in range(101)]
    u = [50.0 + 50.0 * math.sin(2 * math.pi * xi / 2.0) for xi in x]
    return {"voltage": {"x_mm": x, "voltage_v": u}, "stroke": {"velocity_mm_s": 50, "strokes": 100}}


KINDS = [("check", "/api/check", check_body), ("map", "/api/map", map_body), ("play", "/api/play", play_body)]


def connect(url):
    parts = urllib.parse.urlsplit(url)
    return http.client.HTTPConnection(parts.hostname, parts.port or 80, timeout=60)


def heavy_client(url, index, seconds, queue):
    bodies = [(name, path, json.dumps(make()).encode()) for name, path, make in KINDS]
    deadline = time.monotonic() + seconds
    results = []  # (kind, status or "socket error", seconds)
    connection = connect(url)
    k = index
    while time.monotonic() < deadline:
        name, path, body = bodies[k % len(bodies)]
        k += 1
        started = time.perf_counter()
        try:
            connection.request("POST", path, body=body, headers={"Content-Type": "application/json"})
            answer = connection.getresponse()
            answer.read()
            status = answer.status
        except (OSError, http.client.HTTPException):
            status = "socket error"
            connection.close()
            connection = connect(url)
        results.append((name, status, time.perf_counter() - started))
        if status == 503:
            # Refused by the admission control: back off as a client should.
            time.sleep(0.05)
    queue.put(results)


def health_sampler(url, seconds, interval_s, queue):
    latencies, errors = [], {}
    connection = connect(url)
    deadline = time.monotonic() + seconds
    next_at = time.monotonic()
    while time.monotonic() < deadline:
        started = time.perf_counter()
        try:
            connection.request("GET", "/api/health")
            answer = connection.getresponse()
            answer.read()
            if answer.status != 200:
                errors[answer.status] = errors.get(answer.status, 0) + 1
        except (OSError, http.client.HTTPException) as e:
            errors[type(e).__name__] = errors.get(type(e).__name__, 0) + 1
            connection.close()
            connection = connect(url)
        latencies.append(time.perf_counter() - started)
        next_at += interval_s
        time.sleep(max(0.0, next_at - time.monotonic()))
    queue.put((latencies, errors))


def rss_kib(pid, field="VmRSS"):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def percentile(values, p):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(math.ceil(p / 100.0 * len(ordered))) - 1)]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--url", default="http://127.0.0.1:8080")
    parser.add_argument("--clients", type=int, default=12)
    parser.add_argument("--seconds", type=float, default=40.0)
    parser.add_argument("--interval-ms", type=float, default=10.0)
    parser.add_argument("--pid", type=int, help="the server's process id, to print its resident memory")
    parser.add_argument("--settle", type=float, default=5.0, help="seconds after the load before the last RSS")
    args = parser.parse_args()

    c = connect(args.url)
    c.request("GET", "/api/health")
    if c.getresponse().status != 200:
        sys.exit(f"{args.url}/api/health does not answer 200")
    c.close()
    rss_before = rss_kib(args.pid) if args.pid else None

    queue = multiprocessing.Queue()
    sampler = multiprocessing.Process(
        target=health_sampler, args=(args.url, args.seconds, args.interval_ms / 1000.0, queue)
    )
    clients = [
        multiprocessing.Process(target=heavy_client, args=(args.url, i, args.seconds, queue))
        for i in range(args.clients)
    ]
    sampler.start()
    for c in clients:
        c.start()
    outputs = [queue.get() for _ in range(args.clients + 1)]
    for p in [sampler, *clients]:
        p.join()

    health = next(o for o in outputs if isinstance(o, tuple))
    heavy = [r for o in outputs if isinstance(o, list) for r in o]
    latencies, errors = health
    ms = [1000.0 * v for v in latencies]
    print(
        f"/api/health under {args.clients} heavy clients for {args.seconds:g} s: {len(ms)} samples, "
        f"p50 {statistics.median(ms):.2f} ms, p99 {percentile(ms, 99):.2f} ms, max {max(ms):.2f} ms, "
        f"errors {sum(errors.values())} {errors if errors else ''}".rstrip()
    )
    for name, path, _ in KINDS:
        mine = [r for r in heavy if r[0] == name]
        statuses = {}
        for _, status, _ in mine:
            statuses[status] = statuses.get(status, 0) + 1
        served = [r[2] for r in mine if r[1] == 200]
        median = f", median {statistics.median(served):.3f} s when 200" if served else ""
        print(f"  {path}: {len(mine)} sent, statuses {dict(sorted(statuses.items(), key=str))}{median}")
    if args.pid:
        peak = rss_kib(args.pid, "VmHWM")
        time.sleep(args.settle)
        after = rss_kib(args.pid)
        mib = lambda k: "?" if k is None else f"{k / 1024:.0f} MiB"
        print(
            f"server RSS: {mib(rss_before)} before, peak {mib(peak)} (VmHWM, since start), "
            f"{mib(after)} {args.settle:g} s after the load"
        )


if __name__ == "__main__":
    main()
