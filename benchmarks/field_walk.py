"""The distance field's walk to its lists' level (cells of 8 x 8 pixels): float64 on the
CPU against the GPU's (``shaders/field_walk.comp``), and the lists' lengths.

``python benchmarks/field_walk.py [--case global global-2048 mexico-z5 mexico-z10]``

Each case times ``field_gpu._Lists(nodes, grid, inf, last - SHIFT)`` warm (the shape's
node table made first, the GL programs compiled by a first GPU walk) once with
``walk="cpu"`` and once with ``walk="gpu"``, and records the lists' length per cell
(mean, p99, max) of both: the GPU's follow the float64 rule with float32 bounds widened
by their error bounds, so they are a little longer. ``global`` is all of
``countries_10m.geojson`` at 4096 x 2048, ``global-2048`` at 2048 x 1024, ``mexico-z5``
and ``mexico-z10`` 256-pixel tiles of Mexico's coast. Wall seconds and CPU seconds (the
process's, llvmpipe's threads too). Writes ``benchmarks/results/field_walk.json``.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from common import DATA, write

import gloffset
from gloffset.gl.context import context_info
from gloffset.grids import Equirect, Tile
from gloffset.raster.fields.gpu import SHIFT, _Lists
from gloffset.raster.vector.node_levels import NodeArcs

CASES = {
    "global": ("countries_10m.geojson", Equirect(4096, 2048)),
    "global-2048": ("countries_10m.geojson", Equirect(2048, 1024)),
    "mexico-z5": ("mexico_10m.geojson", Tile(5, 6, 13)),
    "mexico-z10": ("mexico_10m.geojson", Tile(10, 212, 451)),
}


def lengths(lists: _Lists) -> dict:
    c = lists.count
    return {"mean": float(c.mean()), "p99": float(np.percentile(c, 99)), "max": int(c.max())}


def case(name: str) -> dict:
    path, grid = CASES[name]
    shape = gloffset.read(DATA / path)
    nodes = NodeArcs.from_shape(shape)
    last = grid.n_levels - 1
    level = last - min(SHIFT, last)
    _Lists(nodes, grid, math.inf, level, walk="gpu")  # compiled, tables made
    out: dict = {"cells": int(np.prod(grid.level_shape(level)))}
    for walk in ("cpu", "gpu"):
        t, c = time.perf_counter(), time.process_time()
        lists = _Lists(nodes, grid, math.inf, level, walk=walk)
        out[walk] = {
            "seconds": time.perf_counter() - t,
            "cpu_seconds": time.process_time() - c,
            "lengths": lengths(lists),
        }
        print(name, walk, out[walk], flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", nargs="+", default=list(CASES), choices=list(CASES))
    args = ap.parse_args()
    info = context_info()
    record = {"renderer": info["renderer"], "cases": {n: case(n) for n in args.case}}
    print(write("field_walk", record))


if __name__ == "__main__":
    main()
