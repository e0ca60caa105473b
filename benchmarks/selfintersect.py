"""Self-intersection removal: Algorithm 1 vs the general method vs S2 and shapely buffers.

Inputs: Mexico (data/mexico_10m.geojson, 7,368 vertices) and a seeded synthetic
coastline of 70,000 vertices (a star-shaped ring with a 1/f spectrum of bays and
capes). For each distance every method runs in the same process:

* gloffset general: ``offset(...).resolve()`` (exact), and its GeoJSON output;
* gloffset paper: Algorithm 1 (candidate arcs from the cap index; the published
  quadratic scan is timed too where it finishes in reasonable time);
* S2 (``s2geometry``): ``S2BufferOperation`` at error fraction 1e-6;
* shapely: ``buffer`` of the polygon in an azimuthal equidistant projection about
  the shape's centre (planar: its error is measured on the sphere).

Errors: the largest ``|distance(boundary point, shape) - d|`` in km on the Earth
(reference distances of points along each result's boundary), and for Algorithm 1
the fraction of sample points that it puts on the wrong side.

Run: python benchmarks/selfintersect.py [--quick]
Writes benchmarks/results/selfintersect.json.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from common import DATA, best_of, coastline, write

import gloffset
from gloffset.geometry.sphere import normalize, xyz_to_lonlat
from gloffset.reference import contains_xyz, distance_xyz
from gloffset.vector.paper import algorithm1

R_KM = gloffset.EARTH_RADIUS / 1000.0


# ----------------------------------------------------------------------------- shapely


def _frame(c):
    east = normalize(np.cross([0.0, 0.0, 1.0], c))
    return east, np.cross(c, east)


def aeqd(p, c):
    """Azimuthal equidistant projection about c (radians on the unit sphere)."""
    east, north = _frame(c)
    ang = np.arctan2(np.linalg.norm(np.cross(p, c), axis=1), p @ c)
    x, y = p @ east, p @ north
    r = np.hypot(x, y)
    r = np.where(r > 0, r, 1.0)
    return np.column_stack([ang * x / r, ang * y / r])


def aeqd_inverse(xy, c):
    east, north = _frame(c)
    rho = np.hypot(xy[:, 0], xy[:, 1])
    th = np.arctan2(xy[:, 1], xy[:, 0])
    return normalize(
        np.cos(rho)[:, None] * c
        + np.sin(rho)[:, None] * (np.cos(th)[:, None] * east + np.sin(th)[:, None] * north)
    )


def shapely_polygon(shape, c):
    import shapely

    polys = []
    for g in range(shape.n_groups):
        idx = np.flatnonzero(shape.ring_groups == g)
        shells = [aeqd(shape.rings[i], c) for i in idx if not shape.ring_holes[i]]
        holes = [aeqd(shape.rings[i], c) for i in idx if shape.ring_holes[i]]
        polys.append(shapely.Polygon(shells[0], holes))
    return polys[0] if len(polys) == 1 else shapely.MultiPolygon(polys)


def shapely_rings(geom):
    geoms = getattr(geom, "geoms", [geom])
    out = []
    for g in geoms:
        out.append(np.asarray(g.exterior.coords))
        out.extend(np.asarray(h.coords) for h in g.interiors)
    return out


# ----------------------------------------------------------------------------- S2


def s2_buffer(shape, d, fraction):
    import s2geometry as s2

    loops = []
    for ring in shape.rings:
        lon, lat = xyz_to_lonlat(ring)
        pts = [s2.S2LatLng.FromDegrees(float(b), float(a)).ToPoint() for a, b in zip(lon, lat)]
        loop = s2.S2Loop(pts)
        loop.Normalize()
        loops.append(loop)
    poly = s2.S2Polygon()
    poly.InitNested(loops)
    out = s2.S2Polygon()
    opts = s2.S2BufferOperationOptions()
    opts.set_buffer_radius(s2.S1Angle.Radians(d))
    opts.set_error_fraction(fraction)
    op = s2.S2BufferOperation(s2.S2PolygonLayer(out), opts)
    op.AddPolygon(poly)
    if not op.Build():
        raise RuntimeError("S2BufferOperation failed")
    return out


def s2_vertices(poly):
    pts = []
    for k in range(poly.num_loops()):
        loop = poly.loop(k)
        for i in range(loop.num_vertices()):
            v = loop.vertex(i)
            pts.append([v.x(), v.y(), v.z()])
    return np.asarray(pts)


# ----------------------------------------------------------------------------- measures


def boundary_error_km(shape, pts, d):
    if len(pts) == 0:
        return 0.0
    return float(np.abs(distance_xyz(shape, pts) - abs(d)).max() * R_KM)


def thin(pts, m=20_000):
    return pts[:: max(1, len(pts) // m)]


def wrong_side(shape, res, d, n=4000, seed=0):
    """Fraction of points near the shape that the result puts on the wrong side."""
    rng = np.random.default_rng(seed)
    v = np.concatenate(shape.rings)
    p = normalize(v[rng.integers(0, len(v), n)] + rng.normal(size=(n, 3)) * 1.5 * abs(d))
    return float(np.mean(res.contains_xyz(p) != contains_xyz(shape, p, d)))


def run_case(name, shape, d, *, scan, repeat):
    rec = {"shape": name, "vertices": shape.n_vertices, "distance_rad": d, "distance_km": d * R_KM}
    v = np.concatenate(shape.rings)
    c = normalize(v.mean(axis=0))

    # gloffset, general: offset + resolve, exact
    def general():
        return gloffset.offset(shape, d, radius=1.0).resolve()

    general()  # warm caches of the shape (edge table, input checks)
    t, res = best_of(general, repeat)
    off = gloffset.offset(shape, d, radius=1.0)
    t_raw, _ = best_of(lambda: gloffset.offset(shape, d, radius=1.0), repeat)
    t_gj, _ = best_of(lambda: res.to_geojson(tolerance=1e-6), 1)
    pts = np.concatenate(res.sample(1e-5)) if res.rings else np.zeros((0, 3))
    rec["general"] = {
        "seconds": t,
        "raw_offset_seconds": t_raw,
        "to_geojson_seconds_at_1e-6rad": t_gj,
        "raw_arcs": int(sum(len(q) for q in off.centers)),
        "arcs": int(sum(len(q) for q in res.centers)),
        "exteriors": int(np.count_nonzero(~res.holes)),
        "holes": int(np.count_nonzero(res.holes)),
        "unlinked": res.unlinked,
        "max_error_km": boundary_error_km(shape, thin(pts), d),
        "wrong_side_fraction": wrong_side(shape, res, d),
    }

    # gloffset, Algorithm 1
    def paper():
        return [algorithm1(q, r) for q, r in zip(off.centers, off.junctions)]

    t_p, _ = best_of(paper, 1)
    pres = off.resolve("paper")
    ppts = np.concatenate(pres.sample(1e-5)) if pres.rings else np.zeros((0, 3))
    rec["paper"] = {
        "seconds": t_p,
        "arcs": int(sum(len(q) for q in pres.centers)),
        "max_error_km": boundary_error_km(shape, thin(ppts), d),
        "wrong_side_fraction": wrong_side(shape, pres, d),
    }
    if scan:
        t_s, _ = best_of(
            lambda: [algorithm1(q, r, index=False) for q, r in zip(off.centers, off.junctions)],
            1,
        )
        rec["paper"]["quadratic_scan_seconds"] = t_s

    # S2 buffer, error fraction 1e-6
    try:
        t_s2, out = best_of(lambda: s2_buffer(shape, d, 1e-6), 1)
        rec["s2_buffer"] = {
            "seconds": t_s2,
            "error_fraction": 1e-6,
            "vertices": out.num_vertices(),
            "max_error_km": boundary_error_km(shape, thin(s2_vertices(out)), d),
        }
    except ImportError:
        rec["s2_buffer"] = None

    # shapely, planar buffer in the azimuthal equidistant projection
    import shapely

    geom = shapely_polygon(shape, c)
    t_sh, buf = best_of(lambda: shapely.buffer(geom, d), repeat)
    spts = np.concatenate([aeqd_inverse(r, c) for r in shapely_rings(buf)])
    rec["shapely_buffer"] = {
        "seconds": t_sh,
        "vertices": int(shapely.get_num_coordinates(buf)),
        "max_error_km": boundary_error_km(shape, thin(spts), d),
    }
    return rec


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="one distance, fewer repeats")
    args = ap.parse_args()
    mexico = gloffset.read(DATA / "mexico_10m.geojson")
    t0 = time.perf_counter()
    coast = coastline()
    build = time.perf_counter() - t0
    cases = []
    dists = [0.02] if args.quick else [0.02, 0.005, -0.005, 0.001]
    repeat = 1 if args.quick else 3
    for name, shape in (("mexico_10m", mexico), ("coastline_70k", coast)):
        for d in dists:
            rec = run_case(name, shape, d, scan=name == "mexico_10m" and d == 0.02, repeat=repeat)
            cases.append(rec)
            g, sh = rec["general"], rec["shapely_buffer"]
            s2t = rec["s2_buffer"]["seconds"] if rec["s2_buffer"] else float("nan")
            print(
                f"{name:14s} d={d:+.3f} general {g['seconds']:.3f}s"
                f" (err {g['max_error_km']:.1e} km)"
                f"  paper {rec['paper']['seconds']:.3f}s  s2 {s2t:.3f}s"
                f"  shapely {sh['seconds']:.3f}s (err {sh['max_error_km']:.2f} km)",
                flush=True,
            )
    path = write(
        "selfintersect", {"coastline_build_seconds": build, "earth_radius_km": R_KM, "cases": cases}
    )
    print("wrote", path)


if __name__ == "__main__":
    main()
