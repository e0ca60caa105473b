"""``gloffset serve`` under load: 1, 4, 16 and 64 concurrent clients on loopback against a
real server process, each asking for random tiles (z 0-14 around the input) at random
distances (1-500 km) for a fixed time; against, in the same run, what one would do
without the server: one ``gloffset.render(shape, d, Tile(z, x, y))`` per request.

A client behaves like a map page: it picks a distance (a new one, as a slider gives, in
whole km), a zoom and a centre near the input, and asks for the 4 x 3 tiles of that view
at once; one view in four is one it saw before (cached tiles). Each tile's latency is
classified by the server's ``X-Gloffset-Tile`` header: ``rendered`` (a new frontier tile,
rendered on the GL thread), ``cached``, ``inside`` / ``outside`` (decided without
rendering). Each client count gets a fresh server (an empty cache); its RSS is sampled
every second. The clients run in this process (asyncio + httpx) and share the machine's
cores with the server.

Run: python benchmarks/serve.py [--seconds 20] [--clients 1 4 16 64] [--input FILE]
     [--render-samples 60]
Writes benchmarks/results/serve.json (key: the input's file stem).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import httpx
import mercantile
import numpy as np
from common import DATA, ROOT, RESULTS, write

import gloffset
from gloffset.gl import context_info
from gloffset.grids import Tile
from gloffset.sphere import xyz_to_lonlat

#: today's figures of one gloffset.render per tile at a new distance (issue 16, Mexico)
TODAY = {"p50_ms": 115.0, "p90_ms": 545.0}
VIEW = (4, 3)  # tiles per view: columns, rows
MAXZOOM = 14


def rss_mb(pid: int) -> float | None:
    """Resident memory of process ``pid`` in MB (Linux), or None."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def pick_view(rng, bounds):
    """A zoom, the tiles of a view around a point near the input, and a distance (km)."""
    w, s, e, n = bounds
    lon = rng.uniform(w - 3.0, e + 3.0)
    lat = rng.uniform(max(s - 3.0, -85.0), min(n + 3.0, 85.0))
    z = int(rng.integers(0, MAXZOOM + 1))
    t = mercantile.tile(lon, lat, z)
    m = 1 << z
    xs = {(t.x + dx) % m for dx in range(-(VIEW[0] // 2), VIEW[0] - VIEW[0] // 2)}
    ys = {t.y + dy for dy in range(-(VIEW[1] // 2), VIEW[1] - VIEW[1] // 2) if 0 <= t.y + dy < m}
    km = int(rng.integers(1, 501))
    return km, z, sorted((x, y) for x in xs for y in ys)


async def client(http, base, layer, bounds, seed, stop_at, out):
    rng = np.random.default_rng(seed)
    seen = []
    while time.perf_counter() < stop_at:
        if seen and rng.random() < 0.25:
            km, z, tiles = seen[int(rng.integers(len(seen)))]
        else:
            km, z, tiles = pick_view(rng, bounds)
            seen.append((km, z, tiles))
        await asyncio.gather(
            *(fetch(http, f"{base}/tiles/{layer}/{km}km/{z}/{x}/{y}.png", out) for x, y in tiles)
        )


async def fetch(http, url, out):
    t = time.perf_counter()
    try:
        r = await http.get(url)
        ok = r.status_code == 200 and r.content[:4] == b"\x89PNG"
        kind = r.headers.get("x-gloffset-tile", "?") if ok else f"error {r.status_code}"
    except httpx.HTTPError as exc:
        kind = f"error {type(exc).__name__}"
    out.append((kind, time.perf_counter() - t))


def start_server(path: Path, port: int, log):
    cmd = [sys.executable, "-m", "gloffset", "serve", str(path), "--port", str(port)]
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen(cmd, stdout=log, stderr=log, env=env)
    end = time.monotonic() + 120
    while time.monotonic() < end:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/layers", timeout=1) as r:
                json.loads(r.read())
                return proc
        except OSError:
            time.sleep(0.2)
    proc.kill()
    raise SystemExit("the server did not start")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def summary(samples, seconds: float) -> dict:
    """Throughput and latency percentiles per kind of tile."""
    kinds: dict = {}
    for kind, dt in samples:
        kinds.setdefault(kind, []).append(dt)
    rec = {"tiles": len(samples), "tiles_per_s": len(samples) / seconds, "kinds": {}}
    for kind, dts in sorted(kinds.items()):
        ms = np.asarray(dts) * 1e3
        rec["kinds"][kind] = {
            "count": len(ms),
            "per_s": len(ms) / seconds,
            "p50_ms": float(np.percentile(ms, 50)),
            "p99_ms": float(np.percentile(ms, 99)),
        }
    rec["errors"] = sum(v["count"] for k, v in rec["kinds"].items() if k.startswith("error"))
    return rec


async def load(base, layer, bounds, n_clients, seconds, pid):
    out: list = []
    rss = []
    limits = httpx.Limits(max_connections=n_clients * 6, max_keepalive_connections=n_clients * 6)
    async with httpx.AsyncClient(limits=limits, timeout=120) as http:
        t0 = time.perf_counter()
        stop_at = t0 + seconds
        tasks = [
            asyncio.create_task(client(http, base, layer, bounds, 1000 + i, stop_at, out))
            for i in range(n_clients)
        ]
        while not all(t.done() for t in tasks):
            rss.append((time.perf_counter() - t0, rss_mb(pid)))
            await asyncio.wait(tasks, timeout=1.0)
        await asyncio.gather(*tasks)
        elapsed = time.perf_counter() - t0
    rec = summary(out, elapsed)
    rec["seconds"] = elapsed
    rec["rss_mb"] = {
        "after_1s": rss[1][1] if len(rss) > 1 else None,
        "end": rss_mb(pid),
        "max": max((m for _, m in rss if m is not None), default=None),
    }
    return rec


def plain_render(shape, bounds, samples: int, seed: int = 7) -> dict:
    """One ``gloffset.render(shape, d, Tile(z, x, y))`` per request, each at a new
    distance: p50/p99 over random tiles near the input (zooms 4-14, as issue 16)."""
    rng = np.random.default_rng(seed)
    gloffset.render(shape, 0.01, Tile(3, 1, 3))  # the context and programs
    times = []
    for _ in range(samples):
        km = int(rng.integers(1, 501))
        _, z, tiles = pick_view(rng, bounds)
        z = max(z, 4)
        w, s, e, n = bounds
        t = mercantile.tile(rng.uniform(w, e), rng.uniform(s, n), z)
        t0 = time.perf_counter()
        gloffset.render(shape, km * 1e3, Tile(z, t.x, t.y))
        times.append(time.perf_counter() - t0)
    ms = np.asarray(times) * 1e3
    return {
        "samples": samples,
        "p50_ms": float(np.percentile(ms, 50)),
        "p90_ms": float(np.percentile(ms, 90)),
        "p99_ms": float(np.percentile(ms, 99)),
        "max_ms": float(ms.max()),
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=20.0, help="per client count")
    ap.add_argument("--clients", type=int, nargs="+", default=[1, 4, 16, 64])
    ap.add_argument("--input", type=Path, default=DATA / "mexico_10m.geojson")
    ap.add_argument("--render-samples", type=int, default=60)
    args = ap.parse_args()
    shape = gloffset.read(args.input)
    layer = args.input.stem
    bounds = shape_bounds(shape)
    print(f"{layer}: {shape.n_vertices} vertices, bounds {bounds}", flush=True)
    plain = plain_render(shape, bounds, args.render_samples)
    print(f"gloffset.render per tile: p50 {plain['p50_ms']:.1f} ms, p99 {plain['p99_ms']:.1f} ms")
    runs = {}
    RESULTS.mkdir(exist_ok=True)
    for n_clients in args.clients:
        port = free_port()
        with open(RESULTS / "serve.log.tmp", "ab") as log:
            proc = start_server(args.input, port, log)
            try:
                base = f"http://127.0.0.1:{port}"
                rec = asyncio.run(load(base, layer, bounds, n_clients, args.seconds, proc.pid))
            finally:
                proc.terminate()
                proc.wait(timeout=60)
        runs[str(n_clients)] = rec
        print(f"{n_clients:>3} clients: {json.dumps(rec)}", flush=True)
    (RESULTS / "serve.log.tmp").unlink(missing_ok=True)
    record = load_previous()
    record[layer] = {
        "input": args.input.name,
        "vertices": int(shape.n_vertices),
        "seconds_per_run": args.seconds,
        "view_tiles": VIEW,
        "gl": context_info()["renderer"],
        "plain_render_per_tile": plain,
        "plain_render_today_issue16": TODAY,
        "server": runs,
    }
    print(write("serve", {"inputs": record}))


def load_previous() -> dict:
    """The inputs measured before (one JSON for all inputs)."""
    try:
        return json.loads((RESULTS / "serve.json").read_text()).get("inputs", {})
    except (OSError, ValueError):
        return {}


def shape_bounds(shape):
    """West, south, east, north of the shape's vertices (the benchmark inputs do not
    cross the antimeridian)."""
    pts = np.concatenate([np.asarray(r) for r in [*shape.rings, *shape.lines]])
    lon, lat = xyz_to_lonlat(pts)
    return float(lon.min()), float(lat.min()), float(lon.max()), float(lat.max())


if __name__ == "__main__":
    main()
