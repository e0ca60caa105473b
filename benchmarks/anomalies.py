"""Renders that used to cost far more than their pixel count predicts, against renders of
the same pixels that do not.

Each case pairs an image of an unusual shape or distance with a reference of the same
number of pixels (or the same image at a usual distance), the same input, timed warm
(best of 3) in this process:

* a 4096 x 1 row across the planet (at 45 N, 211,690 arcs of ``countries_10m``; at 60 N
  across Russia, 1:110m) against a 64 x 64 globe of the same input (4,096 pixels each);
  and a 4096 x 2 strip against a 90 x 91 globe;
* Mexico 1:10m at 1024 x 512 at 0.5 rad and 1.4 rad (3,200 km and 8,900 km) against the
  same image at 0.02 rad (127 km).

The ratio of each case to its reference is the figure: the planet-scale work asks that
no input or distance cost more than 10 times what its pixel count predicts.

Run: python benchmarks/anomalies.py
Writes benchmarks/results/anomalies.json.
"""

from __future__ import annotations

import json

from common import DATA, best_of, write

import gloffset
from gloffset.grids import Equirect


def russia():
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    feats = [f for f in fc["features"] if f["properties"].get("name") == "Russia"]
    return gloffset.read({"type": "FeatureCollection", "features": feats})


def timed(shape, d, grid) -> float:
    return best_of(lambda: gloffset.render(shape, d, grid, radius=1.0))[0]


def main():
    countries = gloffset.read(DATA / "countries_10m.geojson")
    mexico = gloffset.read(DATA / "mexico_10m.geojson")
    cases = {}

    def pair(name, shape, d, grid, ref_grid, ref_d=None):
        gloffset.render(shape, d, grid, radius=1.0)  # warm: the shape's caches
        t = timed(shape, d, grid)
        r = timed(shape, d if ref_d is None else ref_d, ref_grid)
        cases[name] = {
            "seconds": t,
            "pixels": grid.width * grid.height,
            "reference_seconds": r,
            "reference_pixels": ref_grid.width * ref_grid.height,
            "ratio": t / r,
        }
        print(f"{name:36s} {t:8.4f} s  reference {r:8.4f} s  ratio {t / r:6.2f}", flush=True)

    row45 = Equirect(4096, 1, bounds=(-180, 45, 180, 45.044))
    pair("countries_10m row 4096x1 at 45N", countries, 0.02, row45, Equirect(64, 64))
    strip = Equirect(4096, 2, bounds=(-180, 45, 180, 45.088))
    pair("countries_10m strip 4096x2 at 45N", countries, 0.02, strip, Equirect(90, 91))
    row60 = Equirect(4096, 1, bounds=(-180, 60, 180, 60.044))
    pair("Russia 110m row 4096x1 at 60N", russia(), 0.02, row60, Equirect(64, 64))
    globe = Equirect(1024, 512)
    for d in (0.5, 1.4):
        pair(f"Mexico 1024x512 at {d} rad", mexico, d, globe, globe, ref_d=0.02)
    print("wrote", write("anomalies", {"cases": cases}))


if __name__ == "__main__":
    main()
