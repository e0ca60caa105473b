"""How gloffset scales with the input: the planet-scale table, in one run.

Inputs: Mexico 1:10m (7k vertices), the 16 countries of ``countries_10m`` with the most
vertices after the 4 largest (a mid-size subset, united on reading), and all 234
countries of ``countries_10m`` (308k vertices) as one region. Per input, at d = 0.02 rad
(127 km): reading (validation and the union); GPU renders at 1024x512 (and the same
without the simplified curves of :mod:`gloffset.raster.simplified`), of the z0 tile, at
4096x2048 and at 16384x8192 (``--big``); the inside-test index build
(``gloffset.Index``); ``offset(...).resolve()`` at +127 km and -127 km; a z0-8 tile
pyramid (256 px, MBTiles); and the planar pipeline users write instead: shapely's
``buffer`` in degrees, then rasterio's ``rasterize`` at 4096x2048 (planar and in
degrees, so not the same region: its time is the comparison, not its answer).

Every measurement runs in its own process with a time limit (``--limit``, default
120 s), so a case that takes too long is reported as over the limit instead of stopping
the run.

Run: python benchmarks/scale.py [--big] [--limit S] [--only NAME]
Writes benchmarks/results/scale.json.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

from common import DATA, write

HERE = Path(__file__).resolve().parent
D = 0.02  # radians

#: name -> code that builds ``shape_input`` (a path or a GeoJSON object)
INPUTS = {
    "mexico": f"shape_input = {str(DATA / 'mexico_10m.geojson')!r}",
    "sixteen_countries": f"""
feats = json.loads(open({str(DATA / "countries_10m.geojson")!r}).read())["features"]
def nv(f):
    g = f["geometry"]; c = g["coordinates"]
    return sum(len(r) for r in c) if g["type"] == "Polygon" else sum(len(r) for p in c for r in p)
feats = sorted(feats, key=nv, reverse=True)[4:20]
shape_input = {{"type": "FeatureCollection", "features": feats}}
""",
    "countries_10m": f"shape_input = {str(DATA / 'countries_10m.geojson')!r}",
}

SETUP = """
import json, tempfile, time, os
import numpy as np
import gloffset as g
from gloffset.grids import Equirect
{input}
t0 = time.perf_counter()
shape = g.read(shape_input)
t_read = time.perf_counter() - t0
"""

#: name -> (code timed after a warm-up where ``warm`` is True, warm)
TASKS = {
    "read_and_unite": ("shape = g.read(shape_input)", False),
    "render_1024x512": (f"g.render(shape, {D}, Equirect(1024, 512), radius=1.0)", True),
    # the same render without the simplified curves (what the release before did)
    "render_1024x512_unsimplified": (
        "from gloffset.raster.render import _render_one\n"
        f"_render_one(shape, {D}, Equirect(1024, 512), backend='gpu', level=None, "
        "callback=None, mask=True, simplify=False)",
        True,
    ),
    "render_tile_z0": (f"g.render(shape, {D}, g.grids.Tile(0, 0, 0), radius=1.0)", True),
    "render_4096x2048": (f"g.render(shape, {D}, Equirect(4096, 2048), radius=1.0)", True),
    "render_16384x8192": (f"g.render(shape, {D}, Equirect(16384, 8192), radius=1.0)", True),
    "index_build": (f"g.Index(shape, {D}, radius=1.0)", False),
    "resolve_+127km": (f"g.offset(shape, {D}, radius=1.0).resolve()", False),
    "resolve_-127km": (f"g.offset(shape, {-D}, radius=1.0).resolve()", False),
    "tiles_z0-8": (
        f"g.tiles.pyramid(shape, {D} * g.EARTH_RADIUS, '0-8', "
        "os.path.join(tempfile.mkdtemp(), 't.mbtiles'))",
        False,
    ),
    "planar_shapely_buffer_rasterio": (
        f"""
import shapely
from rasterio.features import rasterize
from rasterio.transform import from_bounds
geom = shapely.from_geojson(json.dumps(shape.to_geojson()))
buf = shapely.buffer(geom, float(np.degrees({D})))
rasterize([buf], out_shape=(2048, 4096), transform=from_bounds(-180, -90, 180, 90, 4096, 2048))
""",
        False,
    ),
}

TIMER = """
{warm}
t0 = time.perf_counter()
{code}
print(json.dumps({{"seconds": time.perf_counter() - t0, "vertices": int(shape.n_vertices)}}))
"""


def measure(input_code: str, code: str, warm: bool, limit: float) -> dict:
    src = SETUP.format(input=input_code) + TIMER.format(code=code, warm=code if warm else "")
    env = dict(os.environ, PYTHONPATH=str(HERE.parent))
    try:
        out = subprocess.run(
            [sys.executable, "-c", src], env=env, capture_output=True, text=True, timeout=limit
        )
    except subprocess.TimeoutExpired:
        return {"over_limit_s": limit}
    if out.returncode != 0:
        return {"error": out.stderr.strip().splitlines()[-1][:300]}
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--big", action="store_true", help="also render 16384x8192")
    ap.add_argument("--limit", type=float, default=120.0, help="seconds per measurement")
    ap.add_argument("--only", default="", help="only the inputs whose name contains this")
    args = ap.parse_args(argv)
    rows = {}
    for name, input_code in INPUTS.items():
        if args.only not in name:
            continue
        rows[name] = {}
        for task, (code, warm) in TASKS.items():
            if task == "render_16384x8192" and not args.big:
                continue
            r = measure(input_code, code, warm, args.limit)
            rows[name][task] = r
            print(f"{name:18s} {task:32s} {r}", flush=True)
    path = write("scale", {"distance_rad": D, "limit_s": args.limit, "cases": rows})
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1:])
