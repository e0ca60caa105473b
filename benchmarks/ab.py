"""A/B timing of two source trees of gloffset on the same workloads, in one run.

For a change that must not slow anything (a refactor): the workloads of the benchmarks
(renders on the GPU and in float64, raster offsets, tile pyramids, vector offsets, the
inside test) run through the public API in a fresh process per tree, the trees
alternating round by round so that both see the same machine load; the best of the
rounds is kept, of the wall time and of the host time (the CPU time of the calling thread,
``time.thread_time``: the numpy and Python work and the GL calls' own; the shaders run on
llvmpipe's threads or on the GPU and are left out).

Run: python benchmarks/ab.py --before /path/to/old/checkout --after . [--rounds 5]
Writes benchmarks/results/ab.json (``--out NAME``: NAME.json): seconds per workload and
tree, and after/before, of the wall and the host time.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from common import write

HERE = Path(__file__).resolve().parent
DATA = HERE.parent / "data"

#: name -> code run in the tree's process (``g`` is gloffset, ``mexico`` the shape,
#: ``Equirect``/``Cube`` the grids); timed with a warm-up run first.
WORKLOADS = {
    "render gpu mexico 4096x2048": "g.render(mexico, 0.02, Equirect(4096, 2048), radius=1.0)",
    "render gpu countries 4096x2048": (
        "g.render(countries, 0.02, Equirect(4096, 2048), radius=1.0)"
    ),
    "render gpu mexico cube 6x1024": "g.render(mexico, 0.02, Cube(1024), radius=1.0)",
    "render cpu mexico 1024x512": (
        "g.render(mexico, 0.02, Equirect(1024, 512), radius=1.0, backend='cpu')"
    ),
    "render gpu world 2048x1024 d=0.3": ("g.render(world, 0.3, Equirect(2048, 1024), radius=1.0)"),
    "raster_offset gpu 2048x1024": (
        "g.raster_offset(line_mask, 0.01, Equirect(2048, 1024), radius=1.0)"
    ),
    "raster_offset cpu 1024x512": (
        "g.raster_offset(line_mask_small, 0.01, Equirect(1024, 512), radius=1.0, backend='cpu')"
    ),
    "tiles mexico z0-8 256": (
        "g.tiles.pyramid(mexico, 0.02 * 6371008.8, '0-8', tmp(), overwrite=True)"
    ),
    "tiles countries z0-7 256": (
        "g.tiles.pyramid(countries, 0.02 * 6371008.8, '0-7', tmp(), overwrite=True)"
    ),
    "serve views mexico z4-14 (render_tiles)": (
        "[render_tiles(mexico, d, z, tiles) for d, z, tiles in views]"
    ),
    "offset+resolve mexico": "g.offset(mexico, 0.02, radius=1.0).resolve()",
    "contains mexico 1e6 points": "g.contains(mexico, lon, lat, distance=0.02, radius=1.0)",
    "read countries_10m": "g.read(countries_path)",
    "distance_field countries 4096x2048": "g.distance_field(countries, Equirect(4096, 2048))",
    "distance_field mexico tiles z5 z10": (
        "[g.distance_field(mexico, Tile(*t)) for t in ((5, 7, 14), (10, 234, 457))]"
    ),
}

SETUP = """
import itertools, tempfile, time, os
import numpy as np
import gloffset as g
from gloffset.grids import Cube, Equirect, Tile
mexico = g.read({data!r} + '/mexico_10m.geojson')
world = g.read({data!r} + '/world_110m.geojson')
countries_path = {data!r} + '/countries_10m.geojson'
countries = g.read({data!r} + '/countries_10m.geojson') if {countries} else None
line_mask = g.rasterize(mexico, Equirect(2048, 1024))
line_mask_small = g.rasterize(mexico, Equirect(1024, 512))
rng = np.random.default_rng(0)
lon = rng.uniform(-120.0, -85.0, 1_000_000)
lat = rng.uniform(12.0, 34.0, 1_000_000)
import mercantile
from gloffset.tiles.tiling import render_tiles
# 40 map views near Mexico as benchmarks/serve.py makes them (zooms 4-14, 4 x 3 tiles, a
# new distance each): the tiles the render thread of gloffset serve renders
views = []
for _ in range(40):
    z = int(rng.integers(4, 15))
    t = mercantile.tile(rng.uniform(-121.0, -83.0), rng.uniform(11.0, 36.0), z)
    tiles = [(t.x + i, t.y + j) for i in range(-2, 2) for j in range(-1, 2)]
    views.append((int(rng.integers(1, 501)) / 6371.0088, z, tiles))
_tmp = tempfile.mkdtemp()
_n = itertools.count()
def tmp():
    return os.path.join(_tmp, f"t{{next(_n)}}.mbtiles")
"""

TIMER = """
{code}
t0, h0 = time.perf_counter(), time.thread_time()
{code}
print(repr(time.perf_counter() - t0), repr(time.thread_time() - h0))
"""


def time_in(tree: Path, code: str) -> tuple[float, float]:
    """``(wall, host)`` seconds of ``code`` run in ``tree`` (after a warm-up run)."""
    src = SETUP.format(data=str(DATA), countries="countries" in code) + TIMER.format(code=code)
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run(
        [sys.executable, "-c", src],
        cwd=tree,  # "python -c" puts the working directory first on sys.path
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    wall, host = out.stdout.strip().splitlines()[-1].split()
    return float(wall), float(host)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", required=True, type=Path)
    ap.add_argument("--after", required=True, type=Path)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("-k", default="", help="only the workloads whose name contains this")
    ap.add_argument("--out", default="ab", help="results/OUT.json (default: ab)")
    args = ap.parse_args(argv)
    trees = {"before": args.before.resolve(), "after": args.after.resolve()}
    rows = {}
    for name, code in WORKLOADS.items():
        if args.k not in name:
            continue
        best = {k: float("inf") for k in trees}
        host = {k: float("inf") for k in trees}
        for r in range(args.rounds):
            order = list(trees) if r % 2 == 0 else list(trees)[::-1]
            for k in order:
                wall, cpu = time_in(trees[k], code)
                best[k], host[k] = min(best[k], wall), min(host[k], cpu)
        rows[name] = {
            **best,
            "after/before": best["after"] / best["before"],
            "host": host,
            "host after/before": host["after"] / host["before"],
        }
        print(
            f"{name:36s} before {best['before']:8.3f} s  after {best['after']:8.3f} s  "
            f"ratio {rows[name]['after/before']:.3f}  host ratio "
            f"{rows[name]['host after/before']:.3f}",
            flush=True,
        )
    write(args.out, {"rounds": args.rounds, "trees": {k: str(v) for k, v in trees.items()}, **rows})


if __name__ == "__main__":
    main(sys.argv[1:])
