#!/usr/bin/env python3
"""Per-client limits (issue 41): one client floods the expensive routes,
another client's latency is measured before and during the flood.

Method. Against a running `haptex serve` (it starts nothing itself; to
tell two clients apart on one machine the server needs the hidden
`--limit-loopback-clients`, else loopback clients are not limited at all;
scripts/bench-load.sh starts one each way):

- client B, from source address `--b-source` (127.0.0.1), sends
  `--b-requests` requests of `--b-kind` at a steady `--b-rate` per
  second (within its own bucket of 10 expensive requests per second),
  open loop: a scheduler hands each request at its time to one of 4
  worker threads, each with its kept-alive connection, so that one slow
  answer does not delay the next request (a request that finds all 4
  busy starts late, and is counted as late). Each is timed from sending to the whole answer read.
  The default kind, `play`, is a real expensive request (it draws from
  the bucket and takes a heavy and a render slot) of a few ms:
  `POST /api/play` of a 10 mm voltage curve along 5 strokes at 50 mm/s,
  1 s of drive at 48 kHz answered as a 96 KB WAV. `map` is a 64 x 64
  PNG turned into friction and voltage maps (also expensive); `predict`
  and `voltage` are cheap routes (not limited: a CAE prediction, a
  1001-point eq. (8) mapping).
- phase 1, unloaded: B alone;
- phase 2, loaded: client A, from `--a-source` (127.0.0.2), floods the
  expensive routes from `--a-processes` processes of `--a-threads`
  threads each (default 2 x 16 = 32 connections, the server's limit per
  client), each thread on its kept-alive connection (reconnecting when
  the server closes it) sending request after request with no pause and
  no back-off, whatever the answer: in turn `POST /api/simulate` (the FE
  model on demand, about 1.3 s of a core with the shipped database),
  `POST /api/check` (a 10 mm bump on the FE finger), `POST /api/map` (the
  largest 512 x 512 image) and `POST /api/play` (20 s at 48 kHz). After
  `--a-warmup` seconds (A's burst spent, the server's queues full), B
  sends the same requests as in phase 1; then A stops.

A and B are separate processes (B's timing never waits for A's Python),
but they and the server share this machine's cores: A's flood costs CPU
whatever the server does with it, as a real attacker's would not on the
server's machine. That is in the figures. With `--pid` (the server's
process) each phase also says how many cores the server, this
benchmark's clients and every other process used: figures taken while
something else ran (a build) are not the server's alone.
`--a-nice N` runs A at a lower priority (a diagnostic, not the honest
case).

Printed: for each phase B's p50, p95, p99 and max over its 200 answers,
its other answers and late starts; A's answers by status (200 served,
429 refused by the per-client limits, 503 refused by the server's
admission control, "socket error"); and p99_loaded / p99_unloaded. The
limits are in effect when A got 429s (the script says which). The exit
status is 1 if the ratio is above `--max-ratio` (2: the issue's goal) or
B got any answer but 200 while loaded, unless `--report-only` (the run
without the limits, to show what they buy). `--json FILE` writes the
figures for scripts/bench-load.sh.

Usage:
  target/release/haptex serve --addr 127.0.0.1:8080 --limit-loopback-clients &
  python3 scripts/load_clients.py --url http://127.0.0.1:8080
"""

import argparse
import base64
import http.client
import json
import math
import multiprocessing
import os
import queue
import sys
import threading
import time
import urllib.parse

# The grayscale PNG of the map requests, as the health benchmark builds it
# (this script's directory is on the import path when it is run).
from load_health import png_gray

TIMEOUT_S = 60.0


# ---- request bodies ----


def rings(n):
    return png_gray(n, n, lambda i, j: int(127.5 + 127.5 * math.sin(math.hypot(i - n / 2, j - n / 2) / 4.0)))


def map_body(n):
    return {"image_png_base64": base64.b64encode(rings(n)).decode(), "mu_black": 0.4, "mu_white": 1.2, "pixel_mm": 0.1}


def play_body(strokes):
    x = [0.1 * i for i in range(101)]
    u = [50.0 + 50.0 * math.sin(2 * math.pi * xi / 2.0) for xi in x]
    return {"voltage": {"x_mm": x, "voltage_v": u}, "stroke": {"velocity_mm_s": 50, "strokes": strokes}}


def check_body():
    x = [0.05 * i for i in range(201)]
    mu = [0.5 + 0.1 * math.exp(-(((xi - 5.0) / 0.75) ** 2)) for xi in x]
    return {"profile": {"x_mm": x, "mu": mu}, "device": {"mu_hd": 0.5}}


def simulate_body():
    return {"surface": "bump", "width_mm": 1.3, "height_mm": 0.27, "velocity_mm_s": 20}


def voltage_body():
    x = [0.01 * i for i in range(1001)]
    mu = [1.1 + 0.1 * math.exp(-(((xi - 5.0) / 0.5) ** 2)) for xi in x]
    return {"profile": {"x_mm": x, "mu": mu}}


# B's kinds: (path, body); A's flood: the expensive routes in turn.
B_KINDS = {
    "play": lambda: ("/api/play", play_body(5)),
    "map": lambda: ("/api/map", map_body(64)),
    "predict": lambda: ("/api/predict", {"surface": "bump", "width_mm": 1.3, "height_mm": 0.27}),
    "voltage": lambda: ("/api/voltage", voltage_body()),
}
A_KINDS = {
    "simulate": lambda: ("/api/simulate", simulate_body()),
    "check": lambda: ("/api/check", check_body()),
    "map": lambda: ("/api/map", map_body(512)),
    "play": lambda: ("/api/play", play_body(100)),
}


# ---- connections ----


class Client:
    """A kept-alive HTTP connection from a given source address."""

    def __init__(self, url, source, token):
        parts = urllib.parse.urlsplit(url)
        self.host, self.port, self.source = parts.hostname, parts.port or 80, source
        self.headers = {"Content-Type": "application/json"}
        if token:
            self.headers["Authorization"] = f"Bearer {token}"
        self.connection = None

    def post(self, path, body):
        """POST `body`; the status (or "socket error") once the whole answer is read."""
        try:
            if self.connection is None:
                self.connection = http.client.HTTPConnection(
                    self.host, self.port, timeout=TIMEOUT_S, source_address=(self.source, 0)
                )
            self.connection.request("POST", path, body=body, headers=self.headers)
            answer = self.connection.getresponse()
            answer.read()
            if answer.will_close:
                self.close()
            return answer.status
        except (OSError, http.client.HTTPException):
            self.close()
            return "socket error"

    def close(self):
        if self.connection is not None:
            self.connection.close()
            self.connection = None


# ---- client A: the flood ----


def flood_process(url, source, token, kinds, threads, index, nice, stop, ready, results):
    """`threads` threads sending A's requests back to back until `stop`."""
    if nice:
        os.nice(nice)
    bodies = [(path, json.dumps(body).encode()) for path, body in (A_KINDS[k]() for k in kinds)]
    counts = [{} for _ in range(threads)]

    def flood(t):
        client = Client(url, source, token)
        k = index * threads + t
        previous = None
        while not stop.is_set():
            path, body = bodies[k % len(bodies)]
            k += 1
            status = client.post(path, body)
            key = f"{path} {status}"
            counts[t][key] = counts[t].get(key, 0) + 1
            # A socket error is mostly the server closing a connection
            # after refusing a request whose body it did not read: the
            # next request reconnects at once. Twice in a row, the server
            # may be gone: do not spin.
            if status == "socket error" and previous == "socket error":
                time.sleep(0.01)
            previous = status
        client.close()

    workers = [threading.Thread(target=flood, args=(t,)) for t in range(threads)]
    started = time.monotonic()
    for w in workers:
        w.start()
    ready.set()
    for w in workers:
        w.join()
    total = {}
    for c in counts:
        for key, n in c.items():
            total[key] = total.get(key, 0) + n
    results.put((total, time.monotonic() - started))


# ---- client B: the measured one ----


def measure(url, source, token, kind, n, rate, workers=4):
    """B's `n` requests at `rate` per second, open loop; returns
    (latencies of the 200 answers in s, other answers by status, late starts)."""
    path, body = B_KINDS[kind]()
    body = json.dumps(body).encode()
    jobs = queue.Queue()
    lock = threading.Lock()
    latencies, others, late = [], {}, [0]
    interval = 1.0 / rate

    def worker():
        client = Client(url, source, token)
        while True:
            due = jobs.get()
            if due is None:
                break
            started = time.perf_counter()
            status = client.post(path, body)
            elapsed = time.perf_counter() - started
            with lock:
                if started - due > interval:
                    late[0] += 1
                if status == 200:
                    latencies.append(elapsed)
                else:
                    others[str(status)] = others.get(str(status), 0) + 1
        client.close()

    threads = [threading.Thread(target=worker) for _ in range(workers)]
    for t in threads:
        t.start()
    start = time.perf_counter() + 0.05
    for i in range(n):
        due = start + i * interval
        time.sleep(max(0.0, due - time.perf_counter()))
        jobs.put(due)
    for _ in threads:
        jobs.put(None)
    for t in threads:
        t.join()
    return latencies, others, late[0]


def cpu_seconds(pid):
    """CPU seconds so far: the machine's in processes (user, nice, system),
    in interrupts (irq, softirq: the loopback's packets among them) and
    taken by the hypervisor (steal); process `pid`'s (None if not given);
    this script's and its children's that have ended."""
    tick = os.sysconf("SC_CLK_TCK")
    with open("/proc/stat") as f:
        user, nice, system, _idle, _iowait, irq, softirq, steal = [int(v) for v in f.readline().split()[1:9]]
    server = None
    if pid:
        with open(f"/proc/{pid}/stat") as f:
            stat = f.read().rsplit(")", 1)[1].split()
        server = (int(stat[11]) + int(stat[12])) / tick  # utime, stime of all its threads
    t = os.times()
    return {
        "processes": (user + nice + system) / tick,
        "interrupts": (irq + softirq) / tick,
        "steal": steal / tick,
        "server": server,
        "clients": t.user + t.system + t.children_user + t.children_system,
    }


def cpu_use(before, after, seconds):
    """Cores used on average between two `cpu_seconds`: by the server, this
    benchmark's clients, every other process, interrupts and the
    hypervisor."""
    use = {k: None if after[k] is None else (after[k] - before[k]) / seconds for k in after}
    if use["server"] is not None:
        use["others"] = use["processes"] - use["server"] - use["clients"]
    return use


def show_cpu(use):
    text = f"cores: clients {use['clients']:.2f}"
    if use.get("server") is not None:
        text += f", server {use['server']:.2f}, other processes {use['others']:.2f}"
    return text + f", interrupts {use['interrupts']:.2f}, steal {use['steal']:.2f}"


def percentile(values, p):
    """Nearest-rank percentile (as scripts/load_health.py)."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, int(math.ceil(p / 100.0 * len(ordered))) - 1))]


def summary(latencies, others, late, seconds, cpu):
    ms = [1000.0 * v for v in latencies]
    figures = {"answered_200": len(ms), "other_answers": others, "late_starts": late, "seconds": seconds}
    figures["cpu"] = cpu
    if ms:
        for p in (50, 95, 99):
            figures[f"p{p}_ms"] = percentile(ms, p)
        figures["max_ms"] = max(ms)
    return figures


def show(name, f):
    if "p99_ms" not in f:
        return f"  B {name}: no 200 answer; other answers {f['other_answers']}"
    return (
        f"  B {name}: p50 {f['p50_ms']:.2f} ms, p95 {f['p95_ms']:.2f} ms, p99 {f['p99_ms']:.2f} ms, "
        f"max {f['max_ms']:.2f} ms over {f['answered_200']} answers 200; other answers "
        f"{f['other_answers'] or 'none'}; {f['late_starts']} late starts; {f['seconds']:.1f} s; "
        f"{show_cpu(f['cpu'])}"
    )


def main():
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--url", default="http://127.0.0.1:8080", help="the server's base URL")
    parser.add_argument("--token", default=os.environ.get("HAPTEX_TOKEN"), help="access token, if the server needs one")
    parser.add_argument("--b-source", default="127.0.0.1", help="client B's source address")
    parser.add_argument("--a-source", default="127.0.0.2", help="client A's source address")
    parser.add_argument("--b-kind", choices=sorted(B_KINDS), default="play")
    parser.add_argument("--b-requests", type=int, default=480, help="B's requests per phase")
    parser.add_argument("--b-rate", type=float, default=8.0, help="B's requests per second")
    parser.add_argument("--b-warmup", type=int, default=20, help="B's requests before phase 1, not counted")
    parser.add_argument("--a-processes", type=int, default=2)
    parser.add_argument("--a-threads", type=int, default=16, help="threads (connections) per A process")
    parser.add_argument("--a-kinds", default="simulate,check,map,play", help="A's requests, in turn")
    parser.add_argument(
        "--a-nice",
        type=int,
        default=0,
        help="run A's processes at this niceness (a diagnostic: A's client then yields the cores, as if it ran "
        "on another machine; default 0, the honest case)",
    )
    parser.add_argument("--a-warmup", type=float, default=3.0, help="seconds of flood before B's phase 2")
    parser.add_argument(
        "--pid", type=int, help="the server's process id: the cores it used, and other processes', are printed"
    )
    parser.add_argument("--max-ratio", type=float, default=2.0, help="most p99_loaded / p99_unloaded")
    parser.add_argument("--report-only", action="store_true", help="exit 0 whatever the figures")
    parser.add_argument("--json", metavar="FILE", help="write the figures as JSON")
    args = parser.parse_args()
    kinds = [k.strip() for k in args.a_kinds.split(",") if k.strip()]
    unknown = [k for k in kinds if k not in A_KINDS]
    if unknown or not kinds:
        parser.error(f"--a-kinds: expected some of {','.join(A_KINDS)}, got {args.a_kinds}")

    probe = Client(args.url, args.b_source, args.token)
    path, body = B_KINDS[args.b_kind]()
    status = probe.post(path, json.dumps(body).encode())
    probe.close()
    if status != 200:
        sys.exit(f"{args.url}{path} answers {status} to client B's request; is the server up?")

    print(
        f"client B ({args.b_source}): {args.b_requests} x {args.b_kind} at {args.b_rate:g}/s per phase; client A "
        f"({args.a_source}): {args.a_processes} x {args.a_threads} connections flooding {','.join(kinds)}",
        flush=True,
    )
    measure(args.url, args.b_source, args.token, args.b_kind, args.b_warmup, args.b_rate)

    started, cpu = time.monotonic(), cpu_seconds(args.pid)
    unloaded = measure(args.url, args.b_source, args.token, args.b_kind, args.b_requests, args.b_rate)
    seconds = time.monotonic() - started
    phase1 = summary(*unloaded, seconds, cpu_use(cpu, cpu_seconds(args.pid), seconds))
    print(show("unloaded", phase1), flush=True)

    stop = multiprocessing.Event()
    results = multiprocessing.Queue()
    readies = [multiprocessing.Event() for _ in range(args.a_processes)]
    flooders = [
        multiprocessing.Process(
            target=flood_process,
            args=(args.url, args.a_source, args.token, kinds, args.a_threads, i, args.a_nice, stop, readies[i])
            + (results,),
        )
        for i in range(args.a_processes)
    ]
    flood_started, cpu = time.monotonic(), cpu_seconds(args.pid)
    for p in flooders:
        p.start()
    for r in readies:
        r.wait()
    time.sleep(args.a_warmup)
    started = time.monotonic()
    loaded = measure(args.url, args.b_source, args.token, args.b_kind, args.b_requests, args.b_rate)
    b_seconds = time.monotonic() - started
    stop.set()
    a_counts, a_seconds = {}, 0.0
    for _ in flooders:
        counts, seconds = results.get()
        a_seconds = max(a_seconds, seconds)
        for key, n in counts.items():
            a_counts[key] = a_counts.get(key, 0) + n
    for p in flooders:
        p.join()
    # The cores used from A's start to its end (A's CPU is counted once its processes have ended).
    phase2 = summary(*loaded, b_seconds, cpu_use(cpu, cpu_seconds(args.pid), time.monotonic() - flood_started))
    print(show("loaded", phase2))

    by_status = {}
    for key, n in a_counts.items():
        status = key.split(" ", 1)[1]
        by_status[status] = by_status.get(status, 0) + n
    sent = sum(by_status.values())
    print(
        f"  A: {sent} requests in {a_seconds:.1f} s ({sent / a_seconds:.0f}/s): "
        + ", ".join(f"{n} {'answered ' if s.isdigit() else ''}{s}" for s, n in sorted(by_status.items()))
        + (
            " (a socket error: mostly the server closing a connection after refusing a request whose body it did"
            " not read; A reconnects)"
            if "socket error" in by_status
            else ""
        )
    )
    for key in sorted(a_counts):
        print(f"    {key}: {a_counts[key]}")
    limited = by_status.get("429", 0) > 0
    print(
        "  per-client limits: "
        + ("in effect (A was answered 429)" if limited else "NOT in effect (A got no 429: loopback clients unlimited?)")
    )

    ratio = None
    if "p99_ms" in phase1 and "p99_ms" in phase2:
        ratio = phase2["p99_ms"] / phase1["p99_ms"]
        print(f"  B p99 loaded / unloaded: {ratio:.2f} (goal: at most {args.max_ratio:g})")
    failed = ratio is None or ratio > args.max_ratio or bool(phase2["other_answers"])
    if args.json:
        with open(args.json, "w") as f:
            json.dump(
                {
                    "url": args.url,
                    "b_kind": args.b_kind,
                    "b_rate": args.b_rate,
                    "b_requests": args.b_requests,
                    "a_kinds": kinds,
                    "a_connections": args.a_processes * args.a_threads,
                    "a_nice": args.a_nice,
                    "unloaded": phase1,
                    "loaded": phase2,
                    "a_by_status": by_status,
                    "a_by_route": a_counts,
                    "a_seconds": a_seconds,
                    "limits_in_effect": limited,
                    "ratio_p99": ratio,
                    "met": not failed,
                },
                f,
                indent=1,
            )
    if failed and not args.report_only:
        why = "no ratio" if ratio is None else f"ratio {ratio:.2f} over {args.max_ratio:g}"
        if phase2["other_answers"]:
            why += f", B answered {phase2['other_answers']} while loaded"
        print(f"FAIL: {why}")
        sys.exit(1)


if __name__ == "__main__":
    main()
