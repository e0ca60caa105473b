"""How ``offset(shape, d).resolve()`` scales with the input: time per vertex on real borders.

Inputs (all in ``data/``): Mexico 1:10m; the 20 countries of ``countries_10m`` with the
most vertices, each alone and all 20 as one FeatureCollection (united on reading, shared
borders cancel); all 234 countries of ``countries_10m`` as one region; Antarctica
(``world_110m``) at +1000 km; and the United States with Mexico's outline as lines (the
pieces of the lines' offsets are checked with the inside test).

Per case: vertices, raw offset arcs, resolved arcs, and the resolve time twice: on a
fresh shape (``cold``: includes the checks the shape caches, its input defects and
reference points, as a one-off CLI call pays them) and again on the same shape (``warm``,
best of ``--repeat``); ``us_per_vertex`` is the cold time per input vertex, so the
scaling is visible across sizes. For Mexico and the United States, shapely's planar
``buffer`` in an azimuthal equidistant projection about the shape's centre (the
approach of ``benchmarks/selfintersect.py``; planar, so off by kilometres) runs in the
same process for comparison.

Run: python benchmarks/resolve_scale.py [--quick] [--repeat N]
Writes benchmarks/results/resolve_scale.json.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from common import DATA, best_of, write
from selfintersect import R_KM, shapely_polygon

import gloffset
from gloffset.geometry.sphere import normalize

#: Antarctica's offset distance: 1000 km on the mean Earth radius.
D_ANTARCTICA = 1000.0 / R_KM


def _vertices(geom) -> int:
    c = geom["coordinates"]
    if geom["type"] == "Polygon":
        return sum(len(r) for r in c)
    return sum(len(r) for p in c for r in p)


def _rings(obj) -> list:
    """All rings of the polygons of a GeoJSON object, as coordinate lists."""
    if obj["type"] == "FeatureCollection":
        return [r for f in obj["features"] for r in _rings(f)]
    g = obj.get("geometry", obj)
    return g["coordinates"] if g["type"] == "Polygon" else [r for p in g["coordinates"] for r in p]


def _collection(features) -> dict:
    return {"type": "FeatureCollection", "features": list(features)}


def inputs(quick: bool):
    """(name, GeoJSON object, distances) per case, smallest first."""
    c10 = json.loads((DATA / "countries_10m.geojson").read_text())["features"]
    w110 = json.loads((DATA / "world_110m.geojson").read_text())["features"]
    top = sorted(c10, key=lambda f: -_vertices(f["geometry"]))[: 5 if quick else 20]
    cases = [("Mexico 10m", json.loads((DATA / "mexico_10m.geojson").read_text()), [0.02])]
    for f in reversed(top):
        cases.append((f"{f['properties']['name']} 10m", f, [0.02, -0.02]))
    cases.append((f"{len(top)} largest 10m, united", _collection(top), [0.02, -0.02]))
    antarctica = [f for f in w110 if f["properties"]["name"] == "Antarctica"]
    cases.append(("Antarctica 110m", _collection(antarctica), [D_ANTARCTICA]))
    # polygons and lines: the pieces of the lines' offsets are checked with the inside test
    us = [f for f in c10 if f["properties"]["name"] == "United States"]
    mexico = json.loads((DATA / "mexico_10m.geojson").read_text())
    outline = {"type": "MultiLineString", "coordinates": _rings(mexico)}
    lines = us + [{"type": "Feature", "properties": {}, "geometry": outline}]
    cases.append(("US 10m + Mexico's outline as lines", _collection(lines), [0.02, -0.02]))
    if not quick:
        cases.append(("all countries 10m, united", _collection(c10), [0.02]))
    return cases


def run_case(name, obj, d, repeat):
    shape = gloffset.read(obj)
    t0 = time.perf_counter()
    off = gloffset.offset(shape, d, radius=1.0)
    t_off = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = off.resolve()
    cold = time.perf_counter() - t0
    # inputs above 100,000 vertices are resolved warm once
    repeat = repeat if shape.n_vertices <= 100_000 else 1
    warm, _ = best_of(lambda: gloffset.offset(shape, d, radius=1.0).resolve(), repeat)
    nv = shape.n_vertices
    return {
        "shape": name,
        "vertices": nv,
        "components": shape.n_groups,
        "distance_rad": d,
        "distance_km": d * R_KM,
        "raw_arcs": int(sum(len(r.centers) for r in off.rings)),
        "arcs": int(sum(len(r.centers) for r in res.rings)),
        "exteriors": int(np.count_nonzero(~res.holes)),
        "holes": int(np.count_nonzero(res.holes)),
        "unlinked": res.unlinked,
        "offset_seconds": t_off,
        "resolve_seconds_cold": cold,
        "resolve_seconds_warm": warm,
        "us_per_vertex": 1e6 * cold / nv,
    }


def shapely_case(name, obj, d, repeat):
    import shapely

    shape = gloffset.read(obj)
    c = normalize(np.concatenate(shape.rings).mean(axis=0))
    t0 = time.perf_counter()
    geom = shapely_polygon(shape, c)
    t_proj = time.perf_counter() - t0
    t, buf = best_of(lambda: shapely.buffer(geom, d), repeat)
    return {
        "shape": name,
        "vertices": shape.n_vertices,
        "distance_rad": d,
        "project_seconds": t_proj,
        "buffer_seconds": t,
        "us_per_vertex": 1e6 * (t + t_proj) / shape.n_vertices,
        "output_vertices": int(shapely.get_num_coordinates(buf)),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="5 largest countries, no world case")
    ap.add_argument("--repeat", type=int, default=3, help="warm repeats (default 3)")
    ap.add_argument("--out", default="resolve_scale", help="result name (default resolve_scale)")
    args = ap.parse_args()
    cases, baseline = [], []
    for name, obj, dists in inputs(args.quick):
        for d in dists:
            rec = run_case(name, obj, d, args.repeat)
            cases.append(rec)
            print(
                f"{name:36s} {rec['vertices']:7d} v  d={d:+.3f}"
                f"  cold {rec['resolve_seconds_cold']:7.3f}s"
                f"  warm {rec['resolve_seconds_warm']:7.3f}s"
                f"  {rec['us_per_vertex']:6.1f} us/vertex"
                f"  {rec['arcs']} arcs",
                flush=True,
            )
            if name in ("Mexico 10m", "United States 10m") and d > 0:
                sh = shapely_case(name, obj, d, args.repeat)
                baseline.append(sh)
                print(
                    f"{'  shapely buffer (aeqd)':36s} {sh['vertices']:7d} v  d={d:+.3f}"
                    f"  {sh['project_seconds'] + sh['buffer_seconds']:.3f}s"
                    f"  {sh['us_per_vertex']:6.1f} us/vertex",
                    flush=True,
                )
    path = write(args.out, {"earth_radius_km": R_KM, "cases": cases, "shapely_buffer": baseline})
    print("wrote", path)


if __name__ == "__main__":
    main()
