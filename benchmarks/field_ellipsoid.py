"""What a WGS84 distance field would cost: the geodesic floor against the spherical field.

``python benchmarks/field_ellipsoid.py [--input data/countries_10m.geojson] [--size 4096x2048]
[--sample 20000]``

``gloffset.distance_field(..., ellipsoid="WGS84")`` is refused: the issue asked for it
within 3 times the spherical field's time, or a clear refusal. This measures why, in one
run:

* the spherical field of the input on the global grid (``distance_field``, default
  backend), timed once;
* on a seeded sample of the grid's pixels, the geodesic distance as
  :func:`gloffset.distance` computes it on the ellipsoid (spherical bounds on the
  conformal sphere choose each pixel's candidate edges, the geodesic intercept measures
  them: :func:`gloffset.ellipsoidal.nearest_geodesic`), and the floor under any such
  field: one intercept per pixel, against the geodesic edge of its nearest arc only
  (:func:`gloffset.ellipsoid.intercept.edge_distances`, vectorised on PROJ's geodesics);
* both per pixel, times the grid's pixels, as ratios to the spherical field.

A field within 2 float32 ulps of the geodesic distance needs at least the floor's
intercept at every pixel (a bound cannot give metre-exact values), so a ratio above 3
for the floor alone means no WGS84 field meets the issue's budget with these tools.
Writes ``benchmarks/results/field_ellipsoid.json``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from common import DATA, write

import gloffset
from gloffset.edges import CurveArcs, distance_xyz
from gloffset.ellipsoid import as_ellipsoid
from gloffset.ellipsoid.intercept import edge_distances
from gloffset.ellipsoidal import conformal, nearest_geodesic
from gloffset.geometry.sphere import arc_distance, xyz_to_lonlat
from gloffset.grids import Equirect


def nearest_arcs(shape, arcs: CurveArcs, p: np.ndarray) -> np.ndarray:
    """The index of each point's nearest boundary arc (exact float64 distances)."""
    u = distance_xyz(shape, p)
    qi, ai, _ = arcs.tree.near(p, u * (1 + 1e-9) + 1e-12)
    keep = arcs.boundary[ai]
    qi, ai = qi[keep], ai[keep]
    dist = arc_distance(p[qi], arcs.a[ai], arcs.b[ai], arcs.n[ai])
    order = np.lexsort((dist, qi))  # each point's nearest pair first
    qi, ai = qi[order], ai[order]
    first = np.flatnonzero(np.diff(qi, prepend=-1) != 0)
    out = np.zeros(len(p), dtype=np.int64)
    out[qi[first]] = ai[first]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--input", default=str(DATA / "countries_10m.geojson"))
    ap.add_argument("--size", default="4096x2048")
    ap.add_argument("--sample", type=int, default=20_000, help="pixels timed on the ellipsoid")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    shape = gloffset.read(args.input)
    grid = Equirect(w, h)
    t = time.perf_counter()
    gloffset.distance_field(shape, grid)
    t_sphere = time.perf_counter() - t
    print(f"spherical field {w}x{h}: {t_sphere:.1f} s", file=sys.stderr)

    last = grid.n_levels - 1
    rng = np.random.default_rng(3)
    j, i = rng.integers(0, h, args.sample), rng.integers(0, w, args.sample)
    p = grid.centers(last, j, i)
    lon, lat = xyz_to_lonlat(p)
    ell = as_ellipsoid("WGS84")
    assert ell is not None
    conf = conformal(shape, ell)
    nearest_geodesic(conf, lon[:50], lat[:50])  # the conformal image and its index, built
    t = time.perf_counter()
    nearest_geodesic(conf, lon, lat)
    us_geodesic = (time.perf_counter() - t) / args.sample * 1e6

    arcs = CurveArcs.from_shape(shape)
    k = nearest_arcs(shape, arcs, p[:2000])  # the floor's edges: each pixel's nearest arc
    a_lon, a_lat = xyz_to_lonlat(arcs.a[k])
    b_lon, b_lat = xyz_to_lonlat(arcs.b[k])
    n = len(k)
    t = time.perf_counter()
    edge_distances(
        ell,
        lat[:n],
        lon[:n],
        np.column_stack([a_lat, a_lon]),
        np.column_stack([b_lat, b_lon]),
        np.full(n, 0.5),
    )
    us_floor = (time.perf_counter() - t) / n * 1e6
    pixels = w * h
    rec = {
        "input": Path(args.input).name,
        "grid": f"{w}x{h}",
        "spherical_field_s": round(t_sphere, 2),
        "geodesic_us_per_pixel": round(us_geodesic, 2),
        "geodesic_grid_s": round(us_geodesic * pixels / 1e6, 1),
        "geodesic_ratio": round(us_geodesic * pixels / 1e6 / t_sphere, 1),
        "one_intercept_us_per_pixel": round(us_floor, 2),
        "one_intercept_grid_s": round(us_floor * pixels / 1e6, 1),
        "one_intercept_ratio": round(us_floor * pixels / 1e6 / t_sphere, 1),
        "budget_ratio": 3.0,
    }
    for key, value in rec.items():
        print(f"{key}: {value}")
    print(f"wrote {write('field_ellipsoid', rec)}", file=sys.stderr)


if __name__ == "__main__":
    main()
