"""On the ellipsoid (WGS84) against the sphere and against UTM-projected planar buffers.

In one run, for Mexico 10m (Natural Earth, 7,368 vertices):

* ``contains`` on a million points uniform in lon/lat around Mexico, at d = 10 km,
  100 km and -10 km: the spherical mode (``ellipsoid=None``) and ``ellipsoid="WGS84"``,
  each the first call (indexes built) and a second one (indexes cached);
* ``distance`` on points near the border, sphere and ellipsoid;
* ``render`` of 4096 x 2048 and 16384 x 8192 globes at 127 km, sphere (GPU) and
  ellipsoid;
* ``offset`` at 10 km and 100 km: the sphere's resolved offset written as GeoJSON at
  its default tolerance (1e-6 rad, 6.4 m) and the ellipsoid's at 1 m, with the
  largest error of the ellipsoid's vertices and geodesic midpoints (brute force);
* ``tiles.pyramid`` z0-10 (``--zooms``; 256 px tiles) at 127 km, sphere (GPU) and
  ellipsoid;
* what users do today: the border projected with pyproj to UTM, buffered with shapely
  (``buffer(d)``, 16 segments a quarter circle) and tested with ``contains_xy``, both
  in one zone (14N, Mexico's middle) and per zone (each point tested in its own zone,
  zones 11N-16N);
* accuracy against the brute-force judge of :mod:`gloffset.reference` (pyproj
  geodesics, edges sampled to 10 um) on points near the offset's boundary: the number
  of points each method puts on the wrong side, how far from the true boundary the
  worst of them lies (metres), and for distances the largest error (metres).

Run: python benchmarks/ellipsoid.py [--points 1000000] [--sample 600] [--zooms 0-10]
[--only vector|raster]
Writes benchmarks/results/ellipsoid.json (``--only vector``: the offset figures only,
``--only raster``: the render and pyramid figures only, merged into the file).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pyproj
import shapely
from common import DATA, best_of, points_around, write

import gloffset
from gloffset import reference
from gloffset.geometry.sphere import xyz_to_lonlat

BOX = (-120.0, 12.0, -84.0, 35.0)  # W, S, E, N
DISTANCES = (10e3, 100e3, -10e3)
GEOD = pyproj.Geod(ellps="WGS84")


def _timed(fn):
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def _rings(shape):
    return [np.column_stack(xyz_to_lonlat(r)) for r in shape.rings]


def _utm(zone: int):
    return pyproj.Transformer.from_crs("EPSG:4326", f"EPSG:{32600 + zone}", always_xy=True)


def _projected(rings, zone, d):
    """The region projected to a UTM zone and buffered by ``d`` metres, prepared; with
    its boundary (for distances)."""
    tr = _utm(zone)
    polys = []
    for r in rings:
        x, y = tr.transform(r[:, 0], r[:, 1])
        polys.append(shapely.Polygon(np.column_stack([x, y])).buffer(0))
    region = shapely.union_all(polys)
    buf = region.buffer(d, quad_segs=16)
    shapely.prepare(buf)
    return tr, buf, region.boundary


def utm_contains(rings, lon, lat, d, zones):
    """Planar buffers: one zone, or each point in its own zone."""
    out = np.zeros(len(lon), dtype=bool)
    own = np.clip(np.floor((lon + 180.0) / 6.0).astype(int) + 1, min(zones), max(zones))
    for z in zones:
        sel = np.flatnonzero(own == z) if len(zones) > 1 else np.arange(len(lon))
        tr, buf, _ = _projected(rings, z, d)
        x, y = tr.transform(lon[sel], lat[sel])
        out[sel] = shapely.contains_xy(buf, x, y)
    return out


def utm_distance(rings, lon, lat, zone):
    tr, _, bnd = _projected(rings, zone, 0.0)
    x, y = tr.transform(lon, lat)
    return shapely.distance(bnd, shapely.points(x, y))


def utm_distance_per_zone(rings, lon, lat):
    """Planar distances, each point in its own UTM zone (11N-16N)."""
    own = np.clip(np.floor((lon + 180.0) / 6.0).astype(int) + 1, 11, 16)
    out = np.empty(len(lon))
    for z in np.unique(own):
        sel = own == z
        out[sel] = utm_distance(rings, lon[sel], lat[sel], int(z))
    return out


def near_offset(shape, d, n, seed):
    """Points about |d| (1 +- 1 %) off the border, seeded: from the middle of random
    boundary edges, square to the edge, outwards for d > 0 and inwards for d < 0."""
    rng = np.random.default_rng(seed)
    e = shape.edges()
    k = rng.choice(np.flatnonzero(e.boundary), n)
    alon, alat = xyz_to_lonlat(e.a[k])
    blon, blat = xyz_to_lonlat(e.b[k])
    az, _, length = GEOD.inv(alon, alat, blon, blat)
    mlon, mlat, back = GEOD.fwd(alon, alat, az, 0.5 * length)
    # pyproj returns the back azimuth: the edge runs on towards back + 180, its
    # outside (the right, interiors are on the left) is towards back + 270
    side = back - 90.0 if d > 0 else back + 90.0
    plon, plat, _ = GEOD.fwd(mlon, mlat, side, abs(d) * rng.uniform(0.99, 1.01, n))
    return plon, plat


def _errors(got, truth, truth_d, d):
    wrong = got != truth
    return {
        "wrong": int(wrong.sum()),
        "worst_m": float(np.abs(truth_d[wrong] - abs(d)).max()) if wrong.any() else 0.0,
    }


def accuracy(shape, rings, d, sample, seed):
    lon, lat = near_offset(shape, d, sample, seed)
    truth_d = reference.distance(shape, lon, lat, ellipsoid="WGS84")
    truth = reference.contains_lonlat(shape, lon, lat, distance=d, ellipsoid="WGS84")
    out = {
        "ellipsoid": _errors(
            gloffset.contains(shape, lon, lat, distance=d, ellipsoid="WGS84"), truth, truth_d, d
        ),
        "sphere": _errors(gloffset.contains(shape, lon, lat, distance=d), truth, truth_d, d),
        "utm_one_zone": _errors(utm_contains(rings, lon, lat, d, [14]), truth, truth_d, d),
        "utm_per_zone": _errors(
            utm_contains(rings, lon, lat, d, list(range(11, 17))), truth, truth_d, d
        ),
    }
    ours = gloffset.distance(shape, lon, lat, ellipsoid="WGS84")
    sph = gloffset.distance(shape, lon, lat)
    out["distance_max_error_m"] = {
        "ellipsoid": float(np.abs(ours - truth_d).max()),
        "sphere": float(np.abs(sph - truth_d).max()),
        "utm_one_zone": float(np.abs(utm_distance(rings, lon, lat, 14) - truth_d).max()),
        "utm_per_zone": float(np.abs(utm_distance_per_zone(rings, lon, lat) - truth_d).max()),
    }
    return out


def timings(shape, rings, lon, lat, d):
    t_sphere, a = _timed(lambda: gloffset.contains(shape, lon, lat, distance=d))
    t_sphere2, _ = best_of(lambda: gloffset.contains(shape, lon, lat, distance=d), 2)
    t_ell, b = _timed(lambda: gloffset.contains(shape, lon, lat, distance=d, ellipsoid="WGS84"))
    t_ell2, _ = best_of(
        lambda: gloffset.contains(shape, lon, lat, distance=d, ellipsoid="WGS84"), 2
    )
    t_one, _ = _timed(lambda: utm_contains(rings, lon, lat, d, [14]))
    t_per, _ = _timed(lambda: utm_contains(rings, lon, lat, d, list(range(11, 17))))
    return {
        "sphere_first_s": t_sphere,
        "sphere_s": t_sphere2,
        "ellipsoid_first_s": t_ell,
        "ellipsoid_s": t_ell2,
        "ellipsoid_over_sphere_first": t_ell / t_sphere,
        "utm_one_zone_s": t_one,
        "utm_per_zone_s": t_per,
        "points_differing_from_sphere": int((a != b).sum()),
    }


def render_globe(d=127e3, sizes=(4096, 16384)):
    """Mexico at 127 km on globes of ``sizes`` (width; height half of it): the GPU on the
    sphere, and the mask on the ellipsoid (two GPU renders on the conformal sphere and
    the band between them exact), first call and best of three."""
    from gloffset.grids import Equirect

    shape = gloffset.read(DATA / "mexico_10m.geojson")
    gloffset.render(shape, d, Equirect(256, 128))  # the GL context, once
    out = {}
    for w in sizes:
        grid = Equirect(w, w // 2)
        t_s, a = _timed(lambda g=grid: gloffset.render(shape, d, g))
        t_s2, _ = best_of(lambda g=grid: gloffset.render(shape, d, g), 3)
        t_e, b = _timed(lambda g=grid: gloffset.render(shape, d, g, ellipsoid="WGS84"))
        t_e2, _ = best_of(lambda g=grid: gloffset.render(shape, d, g, ellipsoid="WGS84"), 3)
        out[f"{w}x{w // 2}"] = {
            "sphere_gpu_first_s": t_s,
            "sphere_gpu_s": t_s2,
            "ellipsoid_first_s": t_e,
            "ellipsoid_s": t_e2,
            "ellipsoid_over_sphere": t_e2 / t_s2,
            "pixels_differing": int((a != b).sum()),
        }
        print("render", w, out[f"{w}x{w // 2}"], flush=True)
    return out


def offsets(distances=(10e3, 100e3)):
    """Vector offsets of Mexico: sphere (resolved, GeoJSON) and ellipsoid (1 m)."""
    out = {}
    for d in distances:
        shape = gloffset.read(DATA / "mexico_10m.geojson")
        t_s, _ = _timed(lambda s=shape, d=d: gloffset.offset(s, d).to_geojson())
        t_e, off = _timed(lambda s=shape, d=d: gloffset.offset(s, d, ellipsoid="WGS84"))
        lon, lat = [], []
        for ll in off.lonlat():
            b = np.roll(ll, -1, axis=0)
            az, _, dist = GEOD.inv(ll[:, 0], ll[:, 1], b[:, 0], b[:, 1])
            mlon, mlat, _ = GEOD.fwd(ll[:, 0], ll[:, 1], az, 0.5 * dist)
            lon += [ll[:, 0], mlon]
            lat += [ll[:, 1], mlat]
        truth = reference.geodesic_distance(
            shape, np.concatenate(lon), np.concatenate(lat), "WGS84"
        )
        out[f"{d:g}"] = {
            "sphere_s": t_s,
            "ellipsoid_s": t_e,
            "ellipsoid_points": int(sum(len(r) for r in off.rings)),
            "ellipsoid_max_error_m": float(np.abs(truth - abs(d)).max()),
        }
        print(f"offset d={d:g}", out[f"{d:g}"], flush=True)
    return out


def pyramids(d=127e3, zooms="0-10"):
    """Tile pyramids of Mexico into folders: sphere (GPU) and ellipsoid (the frontier
    tiles of a zoom on the GPU on the conformal sphere, the band exact)."""
    import tempfile

    shape = gloffset.read(DATA / "mexico_10m.geojson")
    out = {"zooms": zooms, "distance_m": d}
    with tempfile.TemporaryDirectory() as tmp:
        for key, ell in (("sphere", None), ("ellipsoid", "WGS84")):
            st = gloffset.tiles.pyramid(shape, d, zooms, f"{tmp}/{key}", ellipsoid=ell)
            out[key] = {"s": st.seconds, "written": st.written, "rendered": st.rendered}
    out["ellipsoid_over_sphere"] = out["ellipsoid"]["s"] / out["sphere"]["s"]
    print("pyramid", out, flush=True)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--sample", type=int, default=600)
    ap.add_argument("--only", choices=["vector", "raster"], default=None)
    ap.add_argument("--zooms", default="0-10", help="zooms of the pyramids")
    args = ap.parse_args()
    if args.only is not None:
        import json

        from common import RESULTS

        record = json.loads((RESULTS / "ellipsoid.json").read_text())
        record.pop("machine", None)
        if args.only == "vector":
            record["offset"] = offsets()
        else:
            record["render_globe"] = render_globe()
            record["pyramid"] = pyramids(zooms=args.zooms)
        for old in ("render_globe_4096x2048", "pyramid_z0_6"):
            record.pop(old, None)
        print(write("ellipsoid", record))
        return
    lon, lat = points_around(BOX, args.points, seed=0)
    record = {"points": args.points, "sample": args.sample, "contains": {}, "accuracy": {}}
    for d in DISTANCES:
        shape = gloffset.read(DATA / "mexico_10m.geojson")  # fresh: no cached index
        rings = _rings(shape)
        record["contains"][f"{d:g}"] = timings(shape, rings, lon, lat, d)
        record["accuracy"][f"{d:g}"] = accuracy(shape, rings, d, args.sample, seed=int(d) % 9973)
        print(f"d={d:g}", record["contains"][f"{d:g}"], record["accuracy"][f"{d:g}"], flush=True)
    shape = gloffset.read(DATA / "mexico_10m.geojson")
    dlon, dlat = near_offset(shape, 20e3, args.sample, seed=5)
    t_s, _ = best_of(lambda: gloffset.distance(shape, dlon, dlat), 2)
    t_e, _ = best_of(lambda: gloffset.distance(shape, dlon, dlat, ellipsoid="WGS84"), 2)
    record["distance"] = {
        "points": args.sample,
        "sphere_s": t_s,
        "ellipsoid_s": t_e,
        "ellipsoid_ms_per_point": 1e3 * t_e / args.sample,
    }
    print(record["distance"])
    record["render_globe"] = render_globe()
    record["offset"] = offsets()
    record["pyramid"] = pyramids(zooms=args.zooms)
    print(write("ellipsoid", record))


if __name__ == "__main__":
    main()
