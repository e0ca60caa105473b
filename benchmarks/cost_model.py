"""What a render and a tile pyramid cost, against what their output holds.

The raster engine's work at the output level is proportional to the boundary of the
region, not to its area nor to the input's vertex count (docs/design.md, "The cost
model").
This benchmark measures that on real borders: per input and image, the time of a GPU
mask (warm, best of 3), the pixels of the output's boundary (pixels with a 4-neighbour
of the other value) and the time per boundary pixel; per input, a z0-8 pyramid (256 px,
MBTiles) and its time per rendered (frontier) tile.

Inputs, at d = 0.02 rad (127 km): Mexico 1:10m (7k vertices), the sixteen countries of
``benchmarks/scale.py`` (64k vertices) and all of ``countries_10m`` as one region (308k
vertices). Images: 1024 x 512, 4096 x 2048 and 16384 x 8192 (``--big``).

If the cost follows the output, the time per boundary pixel is about the same for every
input at one image size, and an input's time relative to Mexico's is its boundary
relative to Mexico's. The comparison with the tools users would pick instead (shapely
and rasterio) is in ``benchmarks/scale.py``.

Run: python benchmarks/cost_model.py [--big] [--no-tiles]
Writes benchmarks/results/cost_model.json.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np
from common import DATA, best_of, write

import gloffset
from gloffset.grids import Equirect

D = 0.02  # radians


def inputs() -> dict:
    feats = json.loads((DATA / "countries_10m.geojson").read_text())["features"]

    def nv(f):
        g = f["geometry"]
        c = g["coordinates"]
        rings = c if g["type"] == "Polygon" else [r for p in c for r in p]
        return sum(len(r) for r in rings)

    sixteen = sorted(feats, key=nv, reverse=True)[4:20]
    return {
        "mexico": lambda: gloffset.read(DATA / "mexico_10m.geojson"),
        "sixteen_countries": lambda: gloffset.read(
            {"type": "FeatureCollection", "features": sixteen}
        ),
        "countries_10m": lambda: gloffset.read(DATA / "countries_10m.geojson"),
    }


def boundary_pixels(mask: np.ndarray) -> int:
    """Pixels with a 4-neighbour (in the image) of the other value."""
    m = np.asarray(mask) > 0
    edge = np.zeros(m.shape, dtype=bool)
    dv = m[1:, :] != m[:-1, :]
    dh = m[:, 1:] != m[:, :-1]
    edge[1:, :] |= dv
    edge[:-1, :] |= dv
    edge[:, 1:] |= dh
    edge[:, :-1] |= dh
    return int(edge.sum())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--big", action="store_true", help="also render 16384x8192")
    ap.add_argument("--no-tiles", action="store_true", help="skip the z0-8 pyramids")
    args = ap.parse_args(argv)
    sizes = [(1024, 512), (4096, 2048)] + ([(16384, 8192)] if args.big else [])
    renders, pyramids = {}, {}
    for name, make in inputs().items():
        shape = make()
        for w, h in sizes:
            grid = Equirect(w, h)
            gloffset.render(shape, D, grid, radius=1.0)  # warm: the shape's caches
            t, mask = best_of(
                lambda grid=grid, shape=shape: gloffset.render(shape, D, grid, radius=1.0)
            )
            b = boundary_pixels(mask)
            renders.setdefault(f"{w}x{h}", {})[name] = {
                "seconds": t,
                "vertices": int(shape.n_vertices),
                "boundary_pixels": b,
                "us_per_boundary_pixel": 1e6 * t / max(b, 1),
            }
            print(
                f"{name:18s} {w}x{h:<6d} {t:8.3f} s  boundary {b:8d} px  "
                f"{1e6 * t / max(b, 1):6.1f} us/px",
                flush=True,
            )
        if not args.no_tiles:
            out = os.path.join(tempfile.mkdtemp(), "t.mbtiles")
            t0 = time.perf_counter()
            stats = gloffset.tiles.pyramid(shape, D * gloffset.EARTH_RADIUS, "0-8", out)
            t = time.perf_counter() - t0
            pyramids[name] = {
                "seconds": t,
                "rendered_tiles": stats.rendered,
                "ms_per_rendered_tile": 1e3 * t / max(stats.rendered, 1),
            }
            print(
                f"{name:18s} z0-8 {t:8.2f} s  rendered {stats.rendered} tiles  "
                f"{1e3 * t / max(stats.rendered, 1):6.2f} ms/tile",
                flush=True,
            )
    # each input against Mexico: time and boundary
    for row in renders.values():
        ref = row.get("mexico")
        for r in row.values():
            if ref:
                r["time_vs_mexico"] = r["seconds"] / ref["seconds"]
                r["boundary_vs_mexico"] = r["boundary_pixels"] / max(ref["boundary_pixels"], 1)
    ref = pyramids.get("mexico")
    for r in pyramids.values():
        if ref:
            r["time_vs_mexico"] = r["seconds"] / ref["seconds"]
            r["rendered_vs_mexico"] = r["rendered_tiles"] / max(ref["rendered_tiles"], 1)
    for size, row in renders.items():
        for name, r in row.items():
            if "time_vs_mexico" in r:
                print(
                    f"{size:10s} {name:18s} time x{r['time_vs_mexico']:5.1f}  "
                    f"boundary x{r['boundary_vs_mexico']:5.1f}"
                )
    for name, r in pyramids.items():
        if "time_vs_mexico" in r:
            print(
                f"z0-8       {name:18s} time x{r['time_vs_mexico']:5.1f}  "
                f"rendered tiles x{r['rendered_vs_mexico']:5.1f}"
            )
    path = write("cost_model", {"distance_rad": D, "renders": renders, "pyramids": pyramids})
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1:])
