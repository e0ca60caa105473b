"""A planet pyramid on Dask: one process against 1 and 2 worker processes, in one run.

Input: all 234 countries of ``countries_10m`` (308k vertices) as one region, at 127 km,
zooms 0 to ``--maxzoom`` (default 10), 256 px tiles, written to MBTiles. Per run: wall
time, tiles written and rendered, the CPU time of all its processes (this one and the
workers) and so the cores it kept busy on average, and the speed-up over one process
and over one worker. The outputs are checked to be byte-identical.

Run: python benchmarks/dask_pyramid.py [--maxzoom Z]   (not dask.py: that name would shadow
the dask package for scripts run from this folder)
Writes benchmarks/results/dask_pyramid.json.
"""

from __future__ import annotations

import argparse
import resource
import sqlite3
import tempfile
import time
from pathlib import Path

from common import DATA, write

import gloffset


def tiles_of(path: Path) -> dict:
    db = sqlite3.connect(path)
    out = {(z, x, y): bytes(b) for z, x, y, b in db.execute("SELECT * FROM tiles")}
    db.close()
    return out


def _cpu() -> float:
    """CPU seconds of this process and of its children that ended (the workers)."""
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--maxzoom", type=int, default=10)
    args = ap.parse_args()
    shape = gloffset.read(DATA / "countries_10m.geojson")
    zooms = f"0-{args.maxzoom}"
    tmp = Path(tempfile.mkdtemp())
    rec = {"input": "countries_10m", "vertices": shape.n_vertices, "zooms": zooms, "runs": {}}
    ref = None
    for workers in (None, 1, 2):
        name = "one_process" if workers is None else f"dask_{workers}_workers"
        out = tmp / f"{name}.mbtiles"
        cpu0 = _cpu()
        t = time.perf_counter()
        st = gloffset.tiles.pyramid(shape, 127e3, zooms, out, workers=workers)
        sec = time.perf_counter() - t
        cpu = _cpu() - cpu0
        got = tiles_of(out)
        ref = got if ref is None else ref
        rec["runs"][name] = {
            "seconds": sec,
            "written": st.written,
            "rendered": st.rendered,
            "identical_to_one_process": got == ref,
            "cpu_seconds": cpu,
            "cores_busy": cpu / sec,
        }
        print(name, rec["runs"][name], flush=True)
    base = rec["runs"]["one_process"]["seconds"]
    one = rec["runs"]["dask_1_workers"]["seconds"]
    for v in rec["runs"].values():
        v["speedup"] = base / v["seconds"]
        v["speedup_over_1_worker"] = one / v["seconds"]
    print("wrote", write("dask_pyramid", rec))


if __name__ == "__main__":
    main()
