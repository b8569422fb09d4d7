"""Touches at 120 Hz, x = 5 + 4 sin(2 pi t) mm, stamped t_s on this
process's clock, for the live-latency benchmark (scripts/live_latency.sh).

  live_feed.py stdin SECONDS      lines t_s,x_mm on stdout (haptex live --stdin)
  live_feed.py ws://HOST:PORT/api/live/ws SECONDS
                                  the page's protocol to haptex serve --live: a
                                  design (U = 40..80 V over 0..10 mm), the
                                  touches, a stop; prints the close's figures
"""
import asyncio
import json
import math
import sys
import time


def touches(seconds):
    t0 = time.monotonic()
    for k in range(int(seconds * 120) + 1):
        t = k / 120
        while time.monotonic() - t0 < t:
            time.sleep(0.0005)
        yield f"{time.monotonic() - t0!r},{5 + 4 * math.sin(2 * math.pi * t)!r}"


async def websocket(url, seconds):
    import websockets

    async with websockets.connect(url) as ws:
        await ws.send(json.dumps({"design": {"x_mm": [0, 10], "voltage_v": [40, 80]}}))
        while True:
            m = json.loads(await ws.recv())
            if "error" in m:
                raise SystemExit(m)
            if "opened" in m:
                break

        async def closed():
            async for text in ws:
                m = json.loads(text)
                if "closed" in m:
                    return m["closed"]

        task = asyncio.create_task(closed())
        t0 = time.monotonic()
        for k in range(int(seconds * 120) + 1):
            t = k / 120
            while time.monotonic() - t0 < t:
                await asyncio.sleep(0.0005)
            await ws.send(f"{time.monotonic() - t0!r},{5 + 4 * math.sin(2 * math.pi * t)!r}")
        await ws.send(json.dumps({"stop": True}))
        print(json.dumps(await task))


if __name__ == "__main__":
    where, seconds = sys.argv[1], float(sys.argv[2])
    if where == "stdin":
        for line in touches(seconds):
            print(line, flush=True)
    else:
        asyncio.run(websocket(where, seconds))
