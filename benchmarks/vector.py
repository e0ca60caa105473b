"""Vector offset of Mexico (10m) and reference distance/contains throughput vs spherely.

Run: python benchmarks/vector.py [--points 100000]
Writes benchmarks/results/vector.json.
"""

from __future__ import annotations

import argparse

import numpy as np
import spherely
from common import DATA, best_of, points_around, write

import gloffset
from gloffset.geometry.sphere import xyz_to_lonlat


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--points", type=int, default=100_000)
    args = ap.parse_args()

    shape = gloffset.read(DATA / "mexico_10m.geojson")
    d = 0.02  # rad, as in the paper's Table 1
    t_read, _ = best_of(lambda: gloffset.read(DATA / "mexico_10m.geojson"))
    t_off, off = best_of(lambda: gloffset.offset(shape, d, radius=1.0))
    t_sample, rings = best_of(lambda: off.sample())
    t_geojson, _ = best_of(lambda: off.to_geojson(), repeat=1)

    lon, lat = points_around((-120.0, 12.0, -84.0, 35.0), args.points, seed=0)
    t_dist, ours_d = best_of(lambda: gloffset.distance(shape, lon, lat, radius=1.0), repeat=1)
    t_cont, ours_c = best_of(
        lambda: gloffset.contains(shape, lon, lat, distance=d, radius=1.0), repeat=1
    )

    # spherely: distance to the boundary and region contains, prepared
    lines = []
    for r in shape.rings:
        lo, la = xyz_to_lonlat(np.vstack([r, r[:1]]))
        lines.append(list(zip(lo.tolist(), la.tolist())))
    polys = []
    for r in shape.rings:
        lo, la = xyz_to_lonlat(r)
        polys.append(spherely.create_polygon(list(zip(lo.tolist(), la.tolist())), oriented=True))
    bnd = spherely.create_multilinestring(lines)
    pts = spherely.points(lon, lat)
    spherely.prepare(bnd)
    for p in polys:
        spherely.prepare(p)
    t_sd, s_d = best_of(lambda: spherely.distance(bnd, pts, radius=1.0), repeat=1)

    def s_contains():
        inside = np.zeros(len(lon), dtype=bool)
        for p in polys:
            inside |= spherely.contains(p, pts)
        return inside | (spherely.distance(bnd, pts, radius=1.0) <= d)

    t_sc, s_c = best_of(s_contains, repeat=1)

    n = len(lon)
    rec = {
        "shape": {
            "file": "mexico_10m.geojson",
            "vertices": shape.n_vertices,
            "rings": len(shape.rings),
        },
        "distance_rad": d,
        "read_s": t_read,
        "offset_s": t_off,
        "offset_arcs": int(sum(len(q) for q in off.centers)),
        "sample_s": t_sample,
        "sample_points": int(sum(len(r) for r in rings)),
        "to_geojson_s": t_geojson,
        "points": n,
        "gloffset_distance_us_per_point": 1e6 * t_dist / n,
        "gloffset_contains_us_per_point": 1e6 * t_cont / n,
        "spherely_distance_us_per_point": 1e6 * t_sd / n,
        "spherely_contains_us_per_point": 1e6 * t_sc / n,
        "max_distance_difference_rad": float(np.abs(ours_d - s_d).max()),
        "contains_disagreements": int((ours_c != s_c).sum()),
    }
    path = write("vector", rec)
    for k, v in rec.items():
        print(f"{k:34s} {v}")
    print("wrote", path)


if __name__ == "__main__":
    main()
