"""Signed distance fields: ``gloffset.distance_field`` against the recipes people use.

``python benchmarks/field.py [--size 4096x2048] [--input data/countries_10m.geojson]``

One run, one input (default: the 234 countries of 1:10m), one global equirectangular grid:

* gloffset: the exact signed distance field (float32, metres), timed once (cold: the
  shape's multiresolution tree is built inside);
* scipy's ``distance_transform_edt`` on the land mask (the field's sign), in pixels,
  converted from degrees of latitude to km as users do (1 degree = R pi / 180);
* GDAL's ``ComputeProximity`` on the same mask (``DISTUNITS=GEO``: degrees, converted the
  same way), run in Debian's system Python (``/usr/bin/python3`` with ``python3-gdal``)
  when present; the record says so when it is absent;
* spherely (S2) distances per pixel on a sample (exact, slow; signed with the reference's
  inside test): its time per pixel, and that time for the whole grid;
* the floor this machine sets for the same passes: the field of a single point (one
  candidate arc per cell at every level, each pixel finished in float64 against it) plus
  the inside test of the pixels (the float64 render at distance 0), and the float64
  finishing alone (one exact arc distance per pixel); the field's time as a ratio to it.

Errors are the median, p99 and max in km, on a seeded sample of pixels, against the
float64 reference (:mod:`gloffset.reference`). Writes ``benchmarks/results/field.json``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from common import DATA, write

import gloffset
from gloffset import reference
from gloffset.edges import CurveArcs
from gloffset.geometry.sphere import arc_distance, xyz_to_lonlat
from gloffset.grids import Equirect

R = gloffset.EARTH_RADIUS
KM_PER_DEG = R * np.pi / 180.0 / 1e3

GDAL_SCRIPT = """
import sys, time
import numpy as np
from osgeo import gdal
mask = np.load(sys.argv[1])
h, w = mask.shape
drv = gdal.GetDriverByName("MEM")
out = {}
t = time.perf_counter()
for name, values in (("out", "1"), ("in", "0")):
    src = drv.Create("", w, h, 1, gdal.GDT_Byte)
    src.SetGeoTransform([-180.0, 360.0 / w, 0.0, 90.0, 0.0, -180.0 / h])
    src.GetRasterBand(1).WriteArray(mask.astype(np.uint8))
    dst = drv.Create("", w, h, 1, gdal.GDT_Float32)
    dst.SetGeoTransform(src.GetGeoTransform())
    gdal.ComputeProximity(src.GetRasterBand(1), dst.GetRasterBand(1),
                          ["VALUES=" + values, "DISTUNITS=GEO"])
    out[name] = dst.GetRasterBand(1).ReadAsArray()
print(time.perf_counter() - t)
np.save(sys.argv[2], out["out"] - out["in"])
"""


def errors_km(got_km: np.ndarray, want_km: np.ndarray) -> dict:
    e = np.abs(got_km - want_km)
    return {
        "median_km": float(np.median(e)),
        "p99_km": float(np.percentile(e, 99)),
        "max_km": float(e.max()),
    }


def scipy_edt(land: np.ndarray, grid: Equirect):
    from scipy.ndimage import distance_transform_edt

    t = time.perf_counter()
    signed = distance_transform_edt(~land) - distance_transform_edt(land)
    return time.perf_counter() - t, signed * (np.degrees(grid.dlat) * KM_PER_DEG)


def gdal_proximity(land: np.ndarray):
    """``(seconds, signed degrees)`` from the system Python's GDAL, or the reason it is absent."""
    py = Path("/usr/bin/python3")
    if not py.exists():
        return "absent: no /usr/bin/python3"
    ok = subprocess.run([str(py), "-c", "from osgeo import gdal"], capture_output=True)
    if ok.returncode:
        return "absent: /usr/bin/python3 has no osgeo.gdal (apt-get install python3-gdal)"
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = Path(tmp) / "mask.npy", Path(tmp) / "prox.npy"
        np.save(src, land)
        proc = subprocess.run(
            [str(py), "-c", GDAL_SCRIPT, str(src), str(dst)], capture_output=True, text=True
        )
        if proc.returncode:
            return f"failed: {proc.stderr.strip().splitlines()[-1]}"
        return float(proc.stdout.strip()), np.load(dst)


def spherely_sample(shape, p: np.ndarray, inside: np.ndarray):
    """``(seconds, signed km)`` of S2's distances from the points ``p`` to the shape's
    boundary (signed with ``inside``, the reference's: only the distances are S2's)."""
    import spherely

    lines = []
    for r in shape.rings:
        lo, la = xyz_to_lonlat(r)
        ring = list(zip(lo.tolist(), la.tolist()))
        lines.append(ring + ring[:1])
    bnd = spherely.create_multilinestring(lines)
    lon, lat = xyz_to_lonlat(p)
    t = time.perf_counter()
    spherely.prepare(bnd)
    dist = spherely.distance(bnd, spherely.points(lon, lat), radius=R) / 1e3
    return time.perf_counter() - t, np.where(inside, -dist, dist)


def floor(shape, grid: Equirect) -> dict:
    """The time the same passes take with one candidate arc per cell, and the float64
    finishing alone (see the module notes)."""
    point = gloffset.read({"type": "Point", "coordinates": [-99.1, 19.4]})
    t = time.perf_counter()
    gloffset.distance_field(point, grid)
    t_walk = time.perf_counter() - t
    t = time.perf_counter()
    gloffset.render(shape, 0.0, grid, backend="cpu")
    t_sign = time.perf_counter() - t
    arcs = CurveArcs.from_shape(shape)
    h, w = grid.level_shape(grid.n_levels - 1)
    pick = np.random.default_rng(1).integers(0, len(arcs.a), w)
    t = time.perf_counter()
    for j in range(h):  # a row at a time, each pixel against one arc
        p = grid.centers(grid.n_levels - 1, np.full(w, j), np.arange(w))
        arc_distance(p, arcs.a[pick], arcs.b[pick], arcs.n[pick])
    t_finish = time.perf_counter() - t
    return {
        "one_candidate_walk_s": t_walk,
        "inside_test_s": t_sign,
        "float64_finishing_alone_s": t_finish,
        "s": t_walk + t_sign,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="4096x2048")
    ap.add_argument("--input", default=str(DATA / "countries_10m.geojson"))
    ap.add_argument("--sample", type=int, default=20_000, help="pixels for the errors")
    ap.add_argument("--s2-sample", type=int, default=2_000, help="pixels S2 is timed on")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    grid = Equirect(w, h)
    t = time.perf_counter()
    shape = gloffset.read(args.input)
    t_read = time.perf_counter() - t

    t = time.perf_counter()
    field = gloffset.distance_field(shape, grid)
    t_field = time.perf_counter() - t
    values = field.values

    rng = np.random.default_rng(0)
    j, i = rng.integers(0, h, args.sample), rng.integers(0, w, args.sample)
    p = grid.centers(grid.n_levels - 1, j, i)
    t = time.perf_counter()
    dist = reference.distance_xyz(shape, p) * R / 1e3
    inside = reference.contains_xyz(shape, p, 0.0)
    t_ref = time.perf_counter() - t
    want = np.where(inside, -dist, dist)

    land = values < 0
    rec = {
        "input": Path(args.input).name,
        "size": [w, h],
        "read_s": t_read,
        "gloffset": {"s": t_field, **errors_km(values[j, i] / 1e3, want)},
        "reference_sample": {"pixels": args.sample, "s": t_ref},
    }
    t_edt, edt = scipy_edt(land, grid)
    rec["scipy_edt"] = {"s": t_edt, **errors_km(edt[j, i], want)}
    prox = gdal_proximity(land)
    if isinstance(prox, str):
        rec["gdal_proximity"] = {"skipped": prox}
    else:
        rec["gdal_proximity"] = {"s": prox[0], **errors_km(prox[1][j, i] * KM_PER_DEG, want)}
    try:
        k = min(args.s2_sample, args.sample)
        t_s2, s2 = spherely_sample(shape, p[:k], inside[:k])
        rec["spherely_sample"] = {
            "pixels": k,
            "s": t_s2,
            "s_per_pixel": t_s2 / k,
            "whole_grid_s_estimate": t_s2 / k * w * h,
            **errors_km(s2, want[:k]),
        }
    except ImportError as exc:
        rec["spherely_sample"] = {"skipped": str(exc)}
    rec["floor"] = floor(shape, grid)
    rec["floor"]["field_over_floor"] = t_field / rec["floor"]["s"]
    targets = {}
    if "s" in rec["gdal_proximity"]:
        targets["within_5x_gdal"] = t_field <= 5.0 * rec["gdal_proximity"]["s"]
    if "s_per_pixel" in rec["spherely_sample"]:
        targets["20x_faster_than_s2"] = (
            20.0 * t_field <= rec["spherely_sample"]["whole_grid_s_estimate"]
        )
    rec["targets"] = targets
    print(json.dumps(rec, indent=2))
    path = write("field", rec)
    print(f"wrote {path}", file=sys.stderr)


if __name__ == "__main__":
    main()
