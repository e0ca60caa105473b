"""The distance field's sign: from the pixels' nearest features against the levels' test.

``python benchmarks/field_sign.py [--input data/countries_10m.geojson] [--skip-global]``

The CPU field (``distance_field(..., backend="cpu")``) reads each pixel's inside status
from its nearest boundary features (:mod:`gloffset.raster.fields.sign`); before, it ran
the float64 levels' inside test at distance 0 (``classify_curves(shape, 0.0, grid)``,
still the GPU backend's). Per case, both timed on the same pixels (the walk to the
pixels with its pairs, untimed, is shared): the rule (:func:`block_signs` over the walk's
parts), the levels' test on the pixels it leaves undecided, and the levels' test of the
whole grid; whether the signs are equal (they must be); the corners' one-time build.
Cases: all the countries at 4096 x 2048, and six 256-pixel tiles of Mexico (zooms 5
and 10).

Writes ``benchmarks/results/field_sign.json``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from common import DATA, write

import gloffset
from gloffset.edges import CurveArcs
from gloffset.geometry.classes import CONTAINED
from gloffset.grids import Equirect, Tile
from gloffset.raster.fields.sign import Corners, block_signs, levels_inside
from gloffset.raster.fields.walk import walk_levels
from gloffset.raster.vector.curves import classify_curves
from gloffset.raster.vector.node_levels import NodeArcs

TILES = [(5, 6, 13), (5, 7, 13), (5, 7, 14), (10, 229, 446), (10, 220, 440), (10, 230, 450)]


def case(shape, grid) -> dict:
    nodes, arcs = NodeArcs.from_shape(shape), CurveArcs.from_shape(shape)
    t = time.perf_counter()
    corners = Corners.from_shape(shape)
    once = time.perf_counter() - t
    last = grid.n_levels - 1
    h, w = grid.level_shape(last)
    inside, und = np.zeros((h, w), bool), np.zeros((h, w), bool)
    rule = 0.0
    for f, dist, pairs in walk_levels(nodes, grid, np.inf, last, pairs=True):
        t = time.perf_counter()
        i, u = block_signs(corners, arcs, grid, f, dist, pairs)
        rule += time.perf_counter() - t
        inside[f.cells[:, 0], f.cells[:, 1]], und[f.cells[:, 0], f.cells[:, 1]] = i, u
    j, i = np.nonzero(und)
    t = time.perf_counter()
    inside[j, i] = levels_inside(shape, grid, j, i)
    fallback = time.perf_counter() - t
    t = time.perf_counter()
    want = classify_curves(shape, 0.0, grid)[0] == CONTAINED
    levels = time.perf_counter() - t
    return {
        "pixels": h * w,
        "undecided": len(j),
        "equal": bool(np.array_equal(inside, want)),
        "corners_once_s": once,
        "rule_s": rule,
        "fallback_s": fallback,
        "sign_s": rule + fallback,
        "levels_inside_test_s": levels,
        "speedup": levels / max(rule + fallback, 1e-9),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--input", default=str(DATA / "countries_10m.geojson"))
    ap.add_argument("--skip-global", action="store_true")
    args = ap.parse_args()
    out: dict = {"tiles": {}}
    mexico = gloffset.read(DATA / "mexico_10m.geojson")
    for z, x, y in TILES:
        out["tiles"][f"mexico {z}/{x}/{y}"] = rec = case(mexico, Tile(z, x, y))
        print(f"mexico {z}/{x}/{y}", rec, flush=True)
    if not args.skip_global:
        shape = gloffset.read(args.input)
        out["global"] = rec = case(shape, Equirect(4096, 2048))
        print("global 4096 x 2048", rec, flush=True)
    write("field_sign", out)


if __name__ == "__main__":
    main()
