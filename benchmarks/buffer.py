"""Metric buffers of GeoPandas data: ``gloffset.buffer`` against what GeoPandas users do.

GeoPandas buffers are planar. On lon/lat data users either buffer in degrees (the
distance divided by 111,320 m, the length of a degree at the equator) or follow the usual
recipe: reproject each feature to an azimuthal equidistant projection (AEQD) centred on
it, buffer in metres, reproject back (pyproj + shapely, one feature at a time). Each is
timed on the same data, and its error measured in metres: the largest difference between
the distance d and the exact spherical distance (``gloffset.distance``) from the feature
to the vertices of its buffer (vertices on the antimeridian cut or the pole edge left
out). Every method draws a circle with the same number of segments (16 per quarter).

- 100,000 random points uniform on the sphere, d = 500 m. The AEQD recipe runs on the
  first 1,000 (its time is given per feature and for all, extrapolated).
- The borders of a few countries of Natural Earth 1:10m as lines (the United States cross the
  antimeridian in the Aleutians), d = 10 km, one feature each.

The AEQD recipe is run on the WGS84 ellipsoid (as users write it, so it answers on the
ellipsoid, not on gloffset's sphere) and on the sphere of radius 6371008.8 m.

Usage: ``python benchmarks/buffer.py [--quick]``; writes ``benchmarks/results/buffer.json``.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from common import DATA, write

import gloffset

N_POINTS = 100_000
AEQD_POINTS = 1_000
D_POINTS = 500.0
D_BORDERS = 10e3
BORDERS = ["France", "Greenland", "Madagascar", "United States"]
RES = 16
DEG = 111_320.0  # metres per degree at the equator, the usual conversion
WGS84 = "+datum=WGS84"
SPHERE = f"+R={gloffset.EARTH_RADIUS}"


def points(n: int, seed: int = 0):
    import geopandas as gpd

    rng = np.random.default_rng(seed)
    lon = rng.uniform(-180.0, 180.0, n)
    lat = np.degrees(np.arcsin(rng.uniform(-1.0, 1.0, n)))
    return gpd.GeoSeries(gpd.points_from_xy(lon, lat), crs="EPSG:4326")


def borders():
    import geopandas as gpd
    import shapely

    fc = json.loads((DATA / "countries_10m.geojson").read_text())
    by_name = {f["properties"]["name"]: f for f in fc["features"]}
    geoms = [shapely.geometry.shape(by_name[n]["geometry"]).boundary for n in BORDERS]
    return gpd.GeoSeries(geoms, index=BORDERS, crs="EPSG:4326")


def aeqd(series, d: float, ellipsoid: str):
    """The usual recipe: each feature in its own azimuthal equidistant projection."""
    import shapely
    from pyproj import Transformer

    out = []
    for geom in series.values:
        c = geom.centroid
        proj = f"+proj=aeqd +lat_0={c.y} +lon_0={c.x} {ellipsoid} +units=m"
        fwd = Transformer.from_crs("EPSG:4326", proj, always_xy=True)
        back = Transformer.from_crs(proj, "EPSG:4326", always_xy=True)
        local = shapely.ops.transform(fwd.transform, geom)
        out.append(shapely.ops.transform(back.transform, local.buffer(d, quad_segs=RES)))
    return out


def worst_error(series, buffers, d: float, points_only: bool) -> float:
    """Largest |distance(feature, vertex) - d| in metres over all buffers' vertices."""
    import shapely

    worst = 0.0
    geoms = list(series.values)
    if points_only:  # the exact distance to a point is the angle: all at once
        counts = shapely.get_num_coordinates(np.asarray(buffers, dtype=object))
        xy = shapely.get_coordinates(np.asarray(buffers, dtype=object))
        centre = np.repeat(shapely.get_coordinates(np.asarray(geoms, dtype=object)), counts, 0)
        free = _free(xy)
        a = gloffset.geometry.sphere.lonlat_to_xyz(*_wrap(xy[free]).T)
        b = gloffset.geometry.sphere.lonlat_to_xyz(*centre[free].T)
        dist = gloffset.geometry.sphere.angle(a, b) * gloffset.EARTH_RADIUS
        return float(np.abs(dist - d).max())
    for geom, buf in zip(geoms, buffers):
        xy = shapely.get_coordinates(buf)
        xy = _wrap(xy[_free(xy)])
        shape = gloffset.read(shapely.geometry.mapping(geom))
        worst = max(worst, float(np.abs(gloffset.distance(shape, *xy.T) - d).max()))
    return worst


def _free(xy: np.ndarray) -> np.ndarray:
    """Vertices not on the antimeridian cut or a pole edge (where a buffer is cut, not
    drawn)."""
    return (np.abs(np.abs(xy[:, 0]) - 180.0) > 1e-9) & (np.abs(np.abs(xy[:, 1]) - 90.0) > 1e-9)


def _wrap(xy: np.ndarray) -> np.ndarray:
    """Longitudes back into [-180, 180] (planar buffers run past 180), latitudes clipped."""
    out = xy.copy()
    out[:, 0] = (out[:, 0] + 180.0) % 360.0 - 180.0
    out[:, 1] = np.clip(out[:, 1], -90.0, 90.0)
    return out


def measure(label, fn, series, d, points_only, per=None):
    t = time.perf_counter()
    buffers = fn()
    seconds = time.perf_counter() - t
    buffers = list(getattr(buffers, "values", buffers))
    err = worst_error(series if per is None else series.iloc[:per], buffers, d, points_only)
    row = {"method": label, "seconds": round(seconds, 4), "worst_error_m": err}
    if per is not None:
        row["features_timed"] = per
        row["seconds_per_feature"] = seconds / per
        row["seconds_all_extrapolated"] = round(seconds / per * len(series), 2)
    print(f"  {label:<32} {seconds:9.3f} s  worst error {err:.3g} m", flush=True)
    return row


def case(series, d: float, points_only: bool, aeqd_n: int | None):
    sub = series if aeqd_n is None else series.iloc[:aeqd_n]
    return [
        measure(
            "gloffset.buffer",
            lambda: gloffset.buffer(series, d, resolution=RES),
            series,
            d,
            points_only,
        ),
        measure(
            "GeoPandas buffer in degrees",
            lambda: series.buffer(d / DEG, quad_segs=RES),
            series,
            d,
            points_only,
        ),
        measure(
            "AEQD per feature (WGS84)",
            lambda: aeqd(sub, d, WGS84),
            series,
            d,
            points_only,
            per=aeqd_n,
        ),
        measure(
            "AEQD per feature (sphere)",
            lambda: aeqd(sub, d, SPHERE),
            series,
            d,
            points_only,
            per=aeqd_n,
        ),
    ]


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="10,000 points, two borders")
    args = ap.parse_args()
    import geopandas
    import pyproj
    import shapely

    n = 10_000 if args.quick else N_POINTS
    out = {
        "versions": {
            "geopandas": geopandas.__version__,
            "shapely": shapely.__version__,
            "pyproj": pyproj.__version__,
            "gloffset": gloffset.__version__,
        },
        "resolution": RES,
        "cases": {},
    }
    pts = points(n)
    label = f"{n:,} random points, d = {D_POINTS:g} m"
    print(label)
    out["cases"][label] = case(pts, D_POINTS, True, min(AEQD_POINTS, n))
    lines = borders()
    if args.quick:
        lines = lines.iloc[:2]
    nv = int(shapely.get_num_coordinates(lines.values).sum())
    label = f"borders of {', '.join(lines.index)} ({nv:,} vertices), d = {D_BORDERS / 1e3:g} km"
    print(label)
    out["cases"][label] = case(lines, D_BORDERS, False, None)
    print("wrote", write("buffer", out))


if __name__ == "__main__":
    main()
