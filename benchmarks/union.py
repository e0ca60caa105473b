"""The region of an input is the union of its polygons: how long reading and uniting takes.

``gloffset.read`` validates the input and derives the boundary of the union of its
polygons (shared borders cancel, overlaps merge, seams join). Compared in the same run
with what users would do instead: shapely's ``unary_union`` (planar, in lon/lat) and
spherely's ``union`` (S2, on the sphere) folded over the polygons. Each union is checked
on random points against shapely's (away from the boundary, where planar and spherical
edges of 1:10m borders agree).

Usage: ``python benchmarks/union.py [--quick]``; writes ``benchmarks/results/union.json``.
"""

from __future__ import annotations

import argparse
import functools
import json
import time

import numpy as np
from common import DATA, best_of, in_box, write

import gloffset

CASES = {
    "France, Spain, Andorra": ["France", "Spain", "Andorra"],
    "Europe (centres in 25 W - 45 E, 34 - 72 N)": "europe",
    "planet (234 countries, 308k vertices)": "all",
}


def features(fc, which):
    feats = fc["features"]
    if which == "all":
        return feats
    if which == "europe":
        return [f for f in feats if in_box(f, (-25, 34, 45, 72))]
    by_name = {f["properties"]["name"]: f for f in feats}
    return [by_name[n] for n in which]


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="skip the planet and spherely on many")
    args = ap.parse_args()
    import shapely
    from shapely.geometry import shape as sh

    try:
        import spherely
    except ImportError:  # pragma: no cover - optional
        spherely = None
    fc = json.loads((DATA / "countries_10m.geojson").read_text())
    out = {"cases": {}}
    for label, which in CASES.items():
        if args.quick and which == "all":
            continue
        feats = features(fc, which)
        doc = {"type": "FeatureCollection", "features": feats}
        n_vert = sum(
            len(r)
            for f in feats
            for p in (
                f["geometry"]["coordinates"]
                if f["geometry"]["type"] == "MultiPolygon"
                else [f["geometry"]["coordinates"]]
            )
            for r in p
        )
        repeat = 1 if which == "all" else 3
        t_ours, ours = best_of(lambda doc=doc: gloffset.read(doc), repeat)
        geoms = [sh(f["geometry"]) for f in feats]
        t_shapely, theirs = best_of(lambda g=geoms: shapely.unary_union(g), repeat)
        rec = {
            "features": len(feats),
            "vertices": n_vert,
            "gloffset_read_and_unite_s": round(t_ours, 4),
            "union_vertices": ours.n_vertices,
            "union_rings": len(ours.rings),
            "shapely_unary_union_s": round(t_shapely, 4),
        }
        if spherely is not None and (len(feats) <= 40 or not args.quick):
            t0 = time.perf_counter()
            try:
                polys = [spherely.from_wkt(shapely.to_wkt(g)) for g in geoms]
                functools.reduce(spherely.union, polys)
                rec["spherely_union_fold_s"] = round(time.perf_counter() - t0, 4)
            except Exception as exc:  # S2 refuses some rings of the data
                rec["spherely_union_fold_s"] = f"failed: {type(exc).__name__}: {exc}"[:200]
        # agreement with shapely's union on random points away from its boundary
        shapely.prepare(theirs)
        w, s, e, n = theirs.bounds
        rng = np.random.default_rng(0)
        lon, lat = rng.uniform(w, e, 20000), rng.uniform(s, n, 20000)
        far = shapely.distance(theirs.boundary, shapely.points(lon, lat)) > 1e-3  # degrees
        got = gloffset.contains(ours, lon[far], lat[far])
        want = shapely.contains_xy(theirs, lon[far], lat[far])
        rec["points_compared"] = int(far.sum())
        rec["points_differing_from_shapely"] = int(np.count_nonzero(got != want))
        out["cases"][label] = rec
        print(label, json.dumps(rec))
    path = write("union", out)
    print("wrote", path)


if __name__ == "__main__":
    main()
