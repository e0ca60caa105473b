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
every second. The clients run in this process (asyncio, a minimal keep-alive HTTP/1.1
client, 6 connections per client as browsers open) and share the machine's cores with
the server; the CPU seconds of both are recorded.

Two more workloads (``--workload``, issue 29, the live map):

- ``slider``: each client has its own view (4 x 3 tiles, zoom 4-12, never asked by another
  client) and sweeps the distance slider over it: the view's 12 tiles at each of
  :data:`SLIDER_KM` (-200 .. +500 km, 20 steps), then a new view. Its tiles are reported
  apart: ``first`` (the view's first distance, new tiles) and ``seen`` (a seen view at a
  new distance: what the slider's target is about).
- ``pan``: new views (never asked by any client) at one distance (:data:`PAN_KM`).

For these two, the ``Server-Timing`` header of each tile made on the render thread (its
wait for that thread, the work there, and why a tile was rendered rather than thresholded
from a kept field) is summed up per phase, kind, reason and zoom (``server_timing`` in the
record, printed after each run).

With ``--pause S`` a slider or pan client waits S seconds after each view's tiles came (a
user's pace; 0, the default, is a closed loop: the clients then measure the server's
saturation, their latency the queue).

Run: python benchmarks/serve.py [--workload random|slider|pan|all ...] [--seconds 20] [--pause 0]
     [--clients 1 4 16 64] [--input FILE [FILE ...]] [--render-samples 60] [--workers 1]
Writes benchmarks/results/serve.json (key: the input's file stem, then the workload unless
it is ``random``, the pause, the workers if more than one, the seconds if over 30 and the
caches if given). RSS and CPU are those of the server
process and its workers together; RSS is reported at start (after 1 s), middle and end with
its slope (least squares over the run, and over its second half, MB/min).
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

import mercantile
import numpy as np
from common import DATA, RESULTS, ROOT, write

import gloffset
from gloffset.geometry.sphere import xyz_to_lonlat
from gloffset.gl import context_info
from gloffset.grids import Tile

#: today's figures of one gloffset.render per tile at a new distance (issue 16, Mexico)
TODAY = {"p50_ms": 115.0, "p90_ms": 545.0}
VIEW = (4, 3)  # tiles per view: columns, rows
MAXZOOM = 14
#: the slider's sweep (km): 20 distances from -200 to +500 km
SLIDER_KM = [int(round(v)) for v in np.linspace(-200, 500, 20)]
#: the pan workload's one distance (km)
PAN_KM = 100
#: the zooms of the slider's and pan's views
VIEW_ZOOMS = (4, 12)
WORKLOADS = ("random", "slider", "pan")


def family(pid: int) -> list[int]:
    """``pid`` and its descendants (Linux /proc): the server and its workers."""
    parent = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            parent[int(stat.parent.name)] = int(stat.read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            pass
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo += [c for c, pp in parent.items() if pp == p]
    return out


def rss_mb(pid: int) -> float | None:
    """Resident memory of process ``pid`` and its descendants in MB (Linux), or None."""
    total = None
    for p in family(pid):
        try:
            for line in Path(f"/proc/{p}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    total = (total or 0.0) + int(line.split()[1]) / 1024.0
        except OSError:
            pass
    return total


def cpu_s(pid: int) -> float | None:
    """CPU seconds (user + system) used so far by process ``pid`` and its descendants
    (Linux), or None."""
    total = None
    for p in family(pid):
        try:
            fields = Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()
            total = (total or 0.0) + (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
        except (OSError, ValueError, IndexError):
            pass
    return total


def pick_view(rng, bounds, zooms=(0, MAXZOOM)):
    """A zoom, the tiles of a view around a point near the input, and a distance (km)."""
    w, s, e, n = bounds
    lon = rng.uniform(w - 3.0, e + 3.0)
    lat = rng.uniform(max(s - 3.0, -85.0), min(n + 3.0, 85.0))
    z = int(rng.integers(zooms[0], zooms[1] + 1))
    t = mercantile.tile(lon, lat, z)
    m = 1 << z
    xs = {(t.x + dx) % m for dx in range(-(VIEW[0] // 2), VIEW[0] - VIEW[0] // 2)}
    ys = {t.y + dy for dy in range(-(VIEW[1] // 2), VIEW[1] - VIEW[1] // 2) if 0 <= t.y + dy < m}
    km = int(rng.integers(1, 501))
    return km, z, sorted((x, y) for x in xs for y in ys)


class Connection:
    """One HTTP/1.1 keep-alive connection (a minimal client: GET, status, headers,
    Content-Length body), so that the clients' own cost stays small beside the server's
    on a shared machine."""

    def __init__(self, host: str, port: int):
        self.host, self.port = host, port
        self.reader = self.writer = None

    async def get(self, path: str) -> tuple[int, dict, bytes]:
        """The response to ``GET path``; a kept-alive connection that the server closed
        meanwhile (its idle timeout) is opened again once, as browsers do."""
        reused = self.writer is not None
        try:
            return await self._get(path)
        except (asyncio.IncompleteReadError, ConnectionError) as exc:
            await self.close()
            if not reused or getattr(exc, "partial", b""):
                raise
            return await self._get(path)

    async def _get(self, path: str) -> tuple[int, dict, bytes]:
        if self.writer is None:
            self.reader, self.writer = await asyncio.open_connection(self.host, self.port)
        self.writer.write(f"GET {path} HTTP/1.1\r\nHost: {self.host}\r\n\r\n".encode())
        head = await self.reader.readuntil(b"\r\n\r\n")
        lines = head.decode("latin-1").split("\r\n")
        status = int(lines[0].split()[1])
        headers = {}
        for line in lines[1:]:
            if ":" in line:
                k, v = line.split(":", 1)
                headers[k.strip().lower()] = v.strip()
        body = await self.reader.readexactly(int(headers.get("content-length", 0)))
        if headers.get("connection", "").lower() == "close":
            await self.close()
        return status, headers, body

    async def close(self):
        if self.writer is not None:
            self.writer.close()
            self.reader = self.writer = None


async def client(host, port, layer, bounds, seed, stop_at, out):
    """A map page: views of tiles fetched over 6 connections at once (as browsers do)."""
    rng = np.random.default_rng(seed)
    conns = [Connection(host, port) for _ in range(6)]
    seen = []
    try:
        while time.perf_counter() < stop_at:
            if seen and rng.random() < 0.25:
                km, z, tiles = seen[int(rng.integers(len(seen)))]
            else:
                km, z, tiles = pick_view(rng, bounds)
                seen.append((km, z, tiles))
            paths = [f"/tiles/{layer}/{km}km/{z}/{x}/{y}.png" for x, y in tiles]
            await asyncio.gather(
                *(fetch(c, paths[i :: len(conns)], out) for i, c in enumerate(conns))
            )
    finally:
        for c in conns:
            await c.close()


def new_view(rng, bounds, taken: set):
    """A view (zoom, tiles) of zooms :data:`VIEW_ZOOMS` none of whose tiles any client asked
    for before (``taken``, shared by the clients, is updated)."""
    for _ in range(1000):
        _, z, tiles = pick_view(rng, bounds, VIEW_ZOOMS)
        keys = {(z, x, y) for x, y in tiles}
        if not keys & taken:
            taken |= keys
            return z, tiles
    raise SystemExit("no new view left near the input")


async def view(conns, paths, out, phase, timings=None):
    """The tiles ``paths`` over the connections at once; each sample tagged ``phase``
    (and each ``Server-Timing`` of a tile made on the render thread added to ``timings``
    as ``(phase, zoom, kind, queue ms, render ms, why)``)."""
    got: list = []
    made: list = []
    await asyncio.gather(
        *(fetch(c, paths[i :: len(conns)], got, made) for i, c in enumerate(conns))
    )
    out += [(kind, dt, phase) for kind, dt in got]
    if timings is not None:
        timings += [(phase, *t) for t in made]


async def slider_client(
    host, port, layer, bounds, seed, stop_at, out, taken, pause=0.0, timings=None
):
    """A map page whose user drags the distance slider: a view of its own at each of
    :data:`SLIDER_KM` in turn (the first distance ``first``, the others ``seen``), then a
    new view; ``pause`` seconds after each distance's tiles came (0: a closed loop)."""
    rng = np.random.default_rng(seed)
    conns = [Connection(host, port) for _ in range(6)]
    try:
        while time.perf_counter() < stop_at:
            z, tiles = new_view(rng, bounds, taken)
            for i, km in enumerate(SLIDER_KM):
                if time.perf_counter() >= stop_at:
                    break
                paths = [f"/tiles/{layer}/{km}km/{z}/{x}/{y}.png" for x, y in tiles]
                await view(conns, paths, out, "first" if i == 0 else "seen", timings)
                await asyncio.sleep(pause)
    finally:
        for c in conns:
            await c.close()


async def pan_client(host, port, layer, bounds, seed, stop_at, out, taken, pause=0.0, timings=None):
    """A map page panned and zoomed at one distance (:data:`PAN_KM`): every view new."""
    rng = np.random.default_rng(seed)
    conns = [Connection(host, port) for _ in range(6)]
    try:
        while time.perf_counter() < stop_at:
            z, tiles = new_view(rng, bounds, taken)
            paths = [f"/tiles/{layer}/{PAN_KM}km/{z}/{x}/{y}.png" for x, y in tiles]
            await view(conns, paths, out, "new", timings)
            await asyncio.sleep(pause)
    finally:
        for c in conns:
            await c.close()


async def fetch(conn, paths, out, made=None):
    """GET each of ``paths`` in turn: ``(kind, seconds)`` to ``out``; with ``made``, the
    ``Server-Timing`` of each tile made on the render thread (:func:`server_timing`)."""
    for path in paths:
        t = time.perf_counter()
        try:
            status, headers, body = await conn.get(path)
            ok = status == 200 and body[:4] == b"\x89PNG"
            kind = headers.get("x-gloffset-tile", "?") if ok else f"error {status}"
        except (OSError, asyncio.IncompleteReadError, ValueError) as exc:
            kind = f"error {type(exc).__name__}"
            headers = {}
            await conn.close()
        out.append((kind, time.perf_counter() - t))
        timing = server_timing(headers.get("server-timing"))
        if made is not None and timing is not None:
            made.append((int(path.split("/")[-3]), kind, *timing))


def server_timing(header: str | None):
    """``(queue ms, render ms, why)`` of a ``Server-Timing`` header (the server's wait for
    its render thread, the work there, why a tile was rendered: None for a field), or None."""
    if not header:
        return None
    got: dict = {}
    for part in header.split(","):
        name, *params = (p.strip() for p in part.split(";"))
        for param in params:
            k, _, v = param.partition("=")
            got[name] = float(v) if k == "dur" else v.strip('"')
    if "queue" not in got:
        return None
    return got["queue"], got.get("render"), got.get("why")


def timing_summary(timings) -> dict:
    """Per phase and kind of tile made on the render thread: the count, the wait for the
    render thread and the work there (p50 / p99 ms), the count of each reason for a
    rendered tile, and per zoom the count and the p99 of queue + render."""
    out: dict = {}
    for phase, kind in sorted({(t[0], t[2]) for t in timings}):
        got = [t for t in timings if t[0] == phase and t[2] == kind]
        q = np.asarray([t[3] for t in got])
        w = np.asarray([t[4] for t in got])
        whys: dict = {}
        zooms: dict = {}
        for t in got:
            whys[str(t[5])] = whys.get(str(t[5]), 0) + 1
            zooms.setdefault(t[1], []).append(t[3] + t[4])
        out.setdefault(phase, {})[kind] = {
            "count": len(got),
            "queue_p50_ms": float(np.percentile(q, 50)),
            "queue_p99_ms": float(np.percentile(q, 99)),
            "render_p50_ms": float(np.percentile(w, 50)),
            "render_p99_ms": float(np.percentile(w, 99)),
            "why": whys,
            "zooms": {
                str(z): {"count": len(v), "p99_ms": float(np.percentile(v, 99))}
                for z, v in sorted(zooms.items())
            },
        }
    return out


def start_server(path: Path, port: int, log, workers: int = 1, caches=None):
    cmd = [sys.executable, "-m", "gloffset", "serve", str(path), "--port", str(port)]
    cmd += ["--workers", str(workers)]
    if caches is not None:  # the tile and field LRUs' bounds, MB
        cmd += ["--cache-mb", f"{caches[0]:g}", "--field-mb", f"{caches[1]:g}"]
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


async def load(host, port, layer, bounds, n_clients, seconds, pid, workload="random", pause=0.0):
    out: list = []
    rss = []
    cpu0, own0 = cpu_s(pid), time.process_time()
    t0 = time.perf_counter()
    stop_at = t0 + seconds
    taken: set = set()
    timings: list = []
    if workload == "random":
        runs = [client(host, port, layer, bounds, 1000 + i, stop_at, out) for i in range(n_clients)]
    else:
        fn = slider_client if workload == "slider" else pan_client
        runs = [
            fn(host, port, layer, bounds, 1000 + i, stop_at, out, taken, pause, timings)
            for i in range(n_clients)
        ]
    tasks = [asyncio.create_task(r) for r in runs]
    while not all(t.done() for t in tasks):
        rss.append((time.perf_counter() - t0, rss_mb(pid)))
        await asyncio.wait(tasks, timeout=1.0)
    await asyncio.gather(*tasks)
    elapsed = time.perf_counter() - t0
    if workload == "random":
        rec = summary(out, elapsed)
    else:  # the tiles of each phase apart, and all of them
        rec = summary([(k, dt) for k, dt, _ in out], elapsed)
        rec["all"] = overall([dt for _, dt, _ in out])
        rec["phases"] = {}
        for phase in sorted({p for _, _, p in out}):
            got = [(k, dt) for k, dt, p in out if p == phase]
            rec["phases"][phase] = summary(got, elapsed) | {"all": overall([dt for _, dt in got])}
        rec["server_timing"] = timing_summary(timings)
    rec["seconds"] = elapsed
    cpu1 = cpu_s(pid)
    rec["cpu_s"] = {
        "server": None if cpu0 is None or cpu1 is None else cpu1 - cpu0,
        "clients": time.process_time() - own0,
    }
    rec["rss_mb"] = {
        "after_1s": rss[1][1] if len(rss) > 1 else None,
        "middle": rss[len(rss) // 2][1] if rss else None,
        "end": rss_mb(pid),
        "max": max((m for _, m in rss if m is not None), default=None),
        "slope_mb_per_min": rss_slope(rss),
        "slope_second_half_mb_per_min": rss_slope(rss, elapsed / 2.0),
        "samples": [(round(t, 1), m) for t, m in rss],
    }
    return rec


def overall(dts) -> dict:
    """Count, p50 and p99 (ms) of latencies ``dts`` (seconds) whatever answered them."""
    if not dts:
        return {"count": 0, "p50_ms": None, "p99_ms": None}
    ms = np.asarray(dts) * 1e3
    p50, p99 = np.percentile(ms, [50, 99])
    return {"count": len(ms), "p50_ms": float(p50), "p99_ms": float(p99)}


def rss_slope(rss, after: float = 1.0) -> float | None:
    """The least-squares slope (MB per minute) of the RSS samples after ``after`` seconds
    (the first second by default; the second half of the run: once the caches are warm)."""
    pts = [(t, m) for t, m in rss if m is not None and t >= after]
    if len(pts) < 3:
        return None
    t, m = np.asarray(pts).T
    return float(np.polyfit(t, m, 1)[0] * 60.0)


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
    ap.add_argument("--input", type=Path, nargs="+", default=[DATA / "mexico_10m.geojson"])
    ap.add_argument("--workload", choices=[*WORKLOADS, "all"], nargs="+", default=["random"])
    ap.add_argument("--render-samples", type=int, default=60)
    ap.add_argument(
        "--pause",
        type=float,
        default=0.0,
        help="slider, pan: seconds a client waits after each view's tiles came (0: closed loop)",
    )
    ap.add_argument(
        "--workers", type=int, default=1, help="server processes (gloffset serve --workers)"
    )
    ap.add_argument(
        "--caches",
        type=float,
        nargs=2,
        metavar=("TILE_MB", "FIELD_MB"),
        help="the server's --cache-mb and --field-mb (default: the server's, 256 MB each)",
    )
    args = ap.parse_args()
    workloads = WORKLOADS if "all" in args.workload else args.workload
    tables = []
    for path in args.input:
        for workload in workloads:
            tables.append(run_input(args, path, workload))
    print("\n\n".join(tables))


def run_input(args, path: Path, workload: str) -> str:
    """Run ``workload`` on ``path`` at each client count, record it, return its table."""
    shape = gloffset.read(path)
    layer = path.stem
    bounds = shape_bounds(shape)
    print(f"{layer} ({workload}): {shape.n_vertices} vertices, bounds {bounds}", flush=True)
    plain = None
    if workload == "random":
        plain = plain_render(shape, bounds, args.render_samples)
        print(
            f"gloffset.render per tile: p50 {plain['p50_ms']:.1f} ms, p99 {plain['p99_ms']:.1f} ms"
        )
    runs = {}
    RESULTS.mkdir(exist_ok=True)
    for n_clients in args.clients:
        port = free_port()
        with open(RESULTS / "serve.log.tmp", "ab") as log:
            proc = start_server(path, port, log, args.workers, args.caches)
            try:
                rec = asyncio.run(
                    load(
                        "127.0.0.1",
                        port,
                        layer,
                        bounds,
                        n_clients,
                        args.seconds,
                        proc.pid,
                        workload,
                        args.pause,
                    )
                )
            finally:
                proc.terminate()
                proc.wait(timeout=60)
        runs[str(n_clients)] = rec
        print(f"{n_clients:>3} clients: {json.dumps(rec)}", flush=True)
        for phase, kinds in rec.get("server_timing", {}).items():
            for kind, t in kinds.items():
                print(
                    f"    {phase} {kind}: {t['count']} tiles, queue p50 / p99 "
                    f"{t['queue_p50_ms']:.0f} / {t['queue_p99_ms']:.0f} ms, render "
                    f"{t['render_p50_ms']:.0f} / {t['render_p99_ms']:.0f} ms, why {t['why']}",
                    flush=True,
                )
    (RESULTS / "serve.log.tmp").unlink(missing_ok=True)
    record = load_previous()
    key = layer if workload == "random" else f"{layer} {workload}"
    key += f" --pause {args.pause:g}" if args.pause and workload != "random" else ""
    key = key if args.workers == 1 else f"{key} --workers {args.workers}"
    key += f" --seconds {args.seconds:g}" if args.seconds > 30 else ""  # longer runs apart
    key += "" if args.caches is None else " --caches {:g} {:g}".format(*args.caches)
    record[key] = {
        "input": path.name,
        "workload": workload,
        "vertices": int(shape.n_vertices),
        "workers": args.workers,
        "seconds_per_run": args.seconds,
        "view_tiles": VIEW,
        "gl": context_info()["renderer"],
        "server": runs,
    }
    if workload == "random":
        record[key] |= {"plain_render_per_tile": plain, "plain_render_today_issue16": TODAY}
    elif workload == "slider":
        record[key] |= {"slider_km": SLIDER_KM, "view_zooms": VIEW_ZOOMS, "pause_s": args.pause}
    else:
        record[key] |= {"pan_km": PAN_KM, "view_zooms": VIEW_ZOOMS, "pause_s": args.pause}
    print(write("serve", {"inputs": record}))
    return f"{key}:\n" + (table(record[key]) if workload == "random" else phase_table(record[key]))


def phase_table(rec: dict) -> str:
    """The README's table of a slider or pan run (markdown): every tile of each phase
    whatever answered it, and the share answered from a kept field or decided at once."""
    phases = ["first", "seen"] if rec["workload"] == "slider" else ["new"]

    def cell(r, phase):
        got = r["phases"].get(phase)
        if not got or not got["all"]["count"]:
            return "- | -"
        a, k = got["all"], got["kinds"]
        quick = sum(k.get(n, {}).get("count", 0) for n in ("field", "cached", "inside", "outside"))
        return f"{a['p50_ms']:.1f} / {a['p99_ms']:.0f} ms | {100.0 * quick / a['count']:.0f} %"

    head = " | ".join(f"{p} p50 / p99 | {p} not rendered" for p in phases)
    rows = [
        f"| clients | tiles/s | {head} | RSS start / middle / end (slope) | errors |",
        "|---|---|" + "---|---|" * len(phases) + "---|---|",
    ]
    for n, r in rec["server"].items():
        m = r["rss_mb"]
        slope = "-" if m["slope_mb_per_min"] is None else f"{m['slope_mb_per_min']:+.1f} MB/min"
        half = m.get("slope_second_half_mb_per_min")
        slope += "" if half is None else f"; 2nd half {half:+.1f}"
        cells = " | ".join(cell(r, p) for p in phases)
        rows.append(
            f"| {n} | {r['tiles_per_s']:.0f} | {cells} "
            f"| {m['after_1s']:.0f} / {m['middle']:.0f} / {m['end']:.0f} MB ({slope}) "
            f"| {r['errors']} |"
        )
    return "\n".join(rows)


def table(rec: dict) -> str:
    """The README's table of one input's runs (markdown)."""

    def cell(kinds, *names):
        got = [kinds[n] for n in names if n in kinds]
        if not got:
            return "-"
        best = max(got, key=lambda v: v["count"])
        return f"{best['p50_ms']:.1f} / {best['p99_ms']:.0f} ms"

    rows = [
        "| clients | tiles/s (rendered/s) | new frontier tiles p50 / p99 | cached p50 / p99 "
        "| inside p50 / p99 | outside p50 / p99 | RSS after 1 s / end / max | errors |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for n, r in rec["server"].items():
        k, m = r["kinds"], r["rss_mb"]
        rendered = k.get("rendered", {}).get("per_s", 0.0)
        rows.append(
            f"| {n} | {r['tiles_per_s']:.0f} ({rendered:.0f}) | {cell(k, 'rendered')} "
            f"| {cell(k, 'cached')} | {cell(k, 'inside')} | {cell(k, 'outside')} "
            f"| {m['after_1s']:.0f} / {m['end']:.0f} / {m['max']:.0f} MB | {r['errors']} |"
        )
    p = rec["plain_render_per_tile"]
    rows.append(
        f"\nOne `gloffset.render(shape, d, Tile(z, x, y))` per tile at a new distance: "
        f"p50 {p['p50_ms']:.0f} ms, p90 {p['p90_ms']:.0f} ms, p99 {p['p99_ms']:.0f} ms "
        f"({p['samples']} tiles)."
    )
    return "\n".join(rows)


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
