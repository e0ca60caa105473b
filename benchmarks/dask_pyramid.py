"""A planet pyramid on Dask: one process against 1 and 2 worker processes, in one run.

Input: all 234 countries of ``countries_10m`` (308k vertices) as one region, at 127 km,
zooms 0 to ``--maxzoom`` (default 10), 256 px tiles, written to MBTiles. Per run: wall
time, tiles written and rendered, the CPU time of all its processes (this one and the
workers) and so the cores it kept busy on average, and the speed-up over one process
and over one worker. The outputs are checked to be byte-identical. Then the one writer
alone: a million tile entries that share one image (what fully inside tiles are) stored
into MBTiles and into PMTiles, per second (``--writer N`` entries; 0 skips it).

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


def _cpu(children: bool = True) -> float:
    """CPU seconds of this process and (``children``) of its children that ended (the
    workers)."""
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    own = me.ru_utime + me.ru_stime
    return own + (kids.ru_utime + kids.ru_stime if children else 0.0)


def writer_rate(path: Path, n: int) -> dict:
    """Seconds to store ``n`` entries of one image (the rows of z14 tiles from 0/0 on) and
    to finish the file, and the entries per second."""
    from gloffset.tiles.store.tilestore import open_store

    side = int(n**0.5) + 1
    t = time.perf_counter()
    store = open_store(path, {"name": "w", "format": "png", "minzoom": 14, "maxzoom": 14})
    for y in range(side):
        xs = range(min(side, n - y * side))
        if not xs:
            break
        store.put_many([(14, x, y) for x in xs], b"\x89PNG one image")
    store.commit()
    store.finish()
    store.close()
    sec = time.perf_counter() - t
    return {"entries": n, "seconds": sec, "entries_per_s": n / sec}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--maxzoom", type=int, default=10)
    ap.add_argument("--writer", type=int, default=1_000_000)
    args = ap.parse_args()
    shape = gloffset.read(DATA / "countries_10m.geojson")
    zooms = f"0-{args.maxzoom}"
    tmp = Path(tempfile.mkdtemp())
    rec = {"input": "countries_10m", "vertices": shape.n_vertices, "zooms": zooms, "runs": {}}
    ref = None
    for workers in (None, 1, 2):
        name = "one_process" if workers is None else f"dask_{workers}_workers"
        out = tmp / f"{name}.mbtiles"
        cpu0, own0 = _cpu(), _cpu(children=False)
        t = time.perf_counter()
        st = gloffset.tiles.pyramid(shape, 127e3, zooms, out, workers=workers)
        sec = time.perf_counter() - t
        cpu, own = _cpu() - cpu0, _cpu(children=False) - own0
        got = tiles_of(out)
        ref = got if ref is None else ref
        rec["runs"][name] = {
            "seconds": sec,
            "written": st.written,
            "rendered": st.rendered,
            "identical_to_one_process": got == ref,
            "cpu_seconds": cpu,
            "cores_busy": cpu / sec,
            "cpu_seconds_calling_process": own,
        }
        print(name, rec["runs"][name], flush=True)
    base = rec["runs"]["one_process"]["seconds"]
    one = rec["runs"]["dask_1_workers"]["seconds"]
    for v in rec["runs"].values():
        v["speedup"] = base / v["seconds"]
        v["speedup_over_1_worker"] = one / v["seconds"]
    if args.writer:
        rec["writer"] = {
            s: writer_rate(tmp / f"w{s}", args.writer) for s in (".mbtiles", ".pmtiles")
        }
        print("writer", rec["writer"], flush=True)
    print("wrote", write("dask_pyramid", rec))


if __name__ == "__main__":
    main()
