"""Signed distance fields: ``gloffset.distance_field`` against the recipes people use.

``python benchmarks/field.py [--case NAME ...] [--input data/countries_10m.geojson]``

One run, one input (default: the 234 countries of 1:10m), three grids (``--case``):
``global`` (4096 x 2048), ``global-8k`` (8640 x 4320) and ``europe`` (2048 x 1024 over
Europe's box, -26,35,46,71: square pixels, as GDAL's proximity in degrees needs), each with:

* gloffset: the exact signed distance field (float32, metres), timed once (the first
  case cold: the shape's multiresolution tree is built inside), with the default GPU
  backend (its stages timed again on their own: ``gpu_split``) and with
  ``backend="cpu"`` (``gloffset_cpu``: its time, whether its values have the same bits
  and the largest difference in float32 ulps, at most 1);
* scipy's ``distance_transform_edt`` on the land mask (the field's sign), the pixel
  spacing in degrees, converted to km as users do (1 degree = R pi / 180);
* GDAL's ``ComputeProximity`` on the same mask (``DISTUNITS=GEO``: degrees, converted the
  same way), run in Debian's system Python (``/usr/bin/python3`` with ``python3-gdal``)
  when present; the record says so when it is absent;
* spherely (S2) distances per pixel on a sample (exact, slow; signed with the reference's
  inside test): its time per pixel, and that time for the whole grid;
* (``global`` only) the floor this machine sets for the CPU's passes: the field of a
  single point (one candidate arc per cell at every level, each pixel finished in float64
  against it) plus the inside test of the pixels (the float64 render at distance 0), and
  the float64 finishing alone (one exact arc distance per pixel); the field's time as a
  ratio to it.

Errors are the median, p99 and max in km, on a seeded sample of pixels, against the
float64 reference (:mod:`gloffset.reference`). And two measurements beside the fields:

* a render's cost per boundary pixel of its mask (``gloffset.render``, default backend,
  warm: the render time over the pixels of the mask with a 4-neighbour of the other
  value), the union of all the countries against Mexico alone, 4096 x 2048, d = 127 km;
* the build of a ``gloffset.Index`` of all the countries (cold: from a copy of the shape
  without its derived data), at 0 and 127 km.

Writes ``benchmarks/results/field.json``: ``cases`` (one record per grid), ``render_cost``
and ``index_build``.
"""

from __future__ import annotations

import argparse
import json
import pickle
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
#: The grids of ``--case``: (width, height, bounds W, S, E, N).
CASES = {
    "global": (4096, 2048, (-180.0, -90.0, 180.0, 90.0)),
    "global-8k": (8640, 4320, (-180.0, -90.0, 180.0, 90.0)),
    "europe": (2048, 1024, (-26.0, 35.0, 46.0, 71.0)),  # square pixels, as GDAL needs
}
KM_PER_DEG = R * np.pi / 180.0 / 1e3

GDAL_SCRIPT = """
import sys, time
import numpy as np
from osgeo import gdal
mask = np.load(sys.argv[1])
h, w = mask.shape
west, south, east, north = (float(v) for v in sys.argv[3].split(","))
drv = gdal.GetDriverByName("MEM")
out = {}
t = time.perf_counter()
for name, values in (("out", "1"), ("in", "0")):
    src = drv.Create("", w, h, 1, gdal.GDT_Byte)
    src.SetGeoTransform([west, (east - west) / w, 0.0, north, 0.0, (south - north) / h])
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
    """``(seconds, signed km)``: the EDT in degrees (pixel spacing in degrees), to km."""
    from scipy.ndimage import distance_transform_edt

    step = (float(np.degrees(grid.dlat)), float(np.degrees(grid.dlon)))
    t = time.perf_counter()
    signed = distance_transform_edt(~land, sampling=step) - distance_transform_edt(
        land, sampling=step
    )
    return time.perf_counter() - t, signed * KM_PER_DEG


def gdal_proximity(land: np.ndarray, bounds):
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
            [str(py), "-c", GDAL_SCRIPT, str(src), str(dst), ",".join(map(str, bounds))],
            capture_output=True,
            text=True,
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
    gloffset.distance_field(point, grid, backend="cpu")
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


def gpu_split(shape, grid: Equirect) -> dict:
    """The GPU backend's stages, timed on their own: the walk to the lists' level, the
    blocks' lists, the GL pass (centres, float32 ranking, float64 finishing), the inside
    test."""
    from gloffset.raster.fields import gpu as field_gpu
    from gloffset.raster.vector import curves

    split: dict = {}
    field_gpu.gpu_distances(shape, grid, np.inf, lambda n: None, split)
    t = time.perf_counter()
    if shape.rings:
        curves.classify_curves(shape, 0.0, grid)
    split["inside"] = time.perf_counter() - t
    return {f"{k}_s": v for k, v in split.items()}


def field_case(shape, name: str, args) -> dict:
    """The record of one grid of :data:`CASES`: gloffset and the recipes beside it."""
    w, h, bounds = CASES[name]
    grid = Equirect(w, h, bounds)
    t = time.perf_counter()
    values = gloffset.distance_field(shape, grid).values
    t_field = time.perf_counter() - t
    t = time.perf_counter()
    cpu = gloffset.distance_field(shape, grid, backend="cpu").values
    t_cpu = time.perf_counter() - t

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
        "case": name,
        "size": [w, h],
        "bounds": list(bounds),
        "gloffset": {"s": t_field, **errors_km(values[j, i] / 1e3, want)},
        "gloffset_cpu": {
            "s": t_cpu,
            "same_bits": bool(np.array_equal(values.view(np.uint32), cpu.view(np.uint32))),
            "max_ulps": float(
                np.max(np.abs(values.astype(np.float64) - cpu) / np.spacing(np.abs(cpu)))
            ),
        },
        "gpu_split": gpu_split(shape, grid),
        "reference_sample": {"pixels": args.sample, "s": t_ref},
    }
    t_edt, edt = scipy_edt(land, grid)
    rec["scipy_edt"] = {"s": t_edt, **errors_km(edt[j, i], want)}
    prox = gdal_proximity(land, bounds)
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
    if name == "global":  # the floor of one grid is enough
        rec["floor"] = floor(shape, grid)
        rec["floor"]["field_over_floor"] = t_field / rec["floor"]["s"]
        rec["floor"]["cpu_field_over_floor"] = t_cpu / rec["floor"]["s"]
    targets = {}
    if "s" in rec["gdal_proximity"]:
        targets["gdal_ratio"] = t_field / rec["gdal_proximity"]["s"]
        targets["within_5x_gdal"] = t_field <= 5.0 * rec["gdal_proximity"]["s"]
    if "s_per_pixel" in rec["spherely_sample"]:
        targets["20x_faster_than_s2"] = (
            20.0 * t_field <= rec["spherely_sample"]["whole_grid_s_estimate"]
        )
    rec["targets"] = targets
    print(json.dumps(rec, indent=2), flush=True)
    return rec


def boundary_pixels(mask: np.ndarray, wrap: bool) -> int:
    """The pixels of ``mask`` with a 4-neighbour of the other value (the columns wrap
    round with ``wrap``, a global grid's antimeridian)."""
    m = mask > 0
    edge = np.zeros(m.shape, dtype=bool)
    dy = m[1:] != m[:-1]
    edge[1:] |= dy
    edge[:-1] |= dy
    dx = m[:, 1:] != m[:, :-1]
    edge[:, 1:] |= dx
    edge[:, :-1] |= dx
    if wrap:
        seam = m[:, 0] != m[:, -1]
        edge[:, 0] |= seam
        edge[:, -1] |= seam
    return int(edge.sum())


def render_cost(shape, mexico, size=(4096, 2048), d: float = 127e3) -> dict:
    """A render's time per boundary pixel of its mask: all the countries against Mexico
    (each shape's first render, at 256 x 128, builds what it keeps; the one timed is
    the next)."""
    rec = {"size": list(size), "d_m": d}
    for name, s in (("all_countries", shape), ("mexico", mexico)):
        gloffset.render(s, d, Equirect(256, 128))
        t = time.perf_counter()
        mask = gloffset.render(s, d, Equirect(*size))
        seconds = time.perf_counter() - t
        n = boundary_pixels(mask, wrap=True)
        rec[name] = {"s": seconds, "boundary_pixels": n, "us_per_boundary_pixel": seconds / n * 1e6}
    ratio = rec["all_countries"]["us_per_boundary_pixel"] / rec["mexico"]["us_per_boundary_pixel"]
    rec["ratio_all_over_mexico"] = ratio
    rec["target_within_2x"] = ratio <= 2.0
    print(json.dumps(rec, indent=2), flush=True)
    return rec


def index_build(shape) -> dict:
    """The build of a ``gloffset.Index`` of ``shape``, from a copy without its derived
    data (a pickle leaves it out), at 0 and 127 km."""
    rec = {}
    for d in (0.0, 127e3):
        fresh = pickle.loads(pickle.dumps(shape))
        t = time.perf_counter()
        gloffset.Index(fresh, d)
        rec[f"d_{d / 1e3:g}km_s"] = time.perf_counter() - t
    rec["target_within_2s"] = max(rec.values()) <= 2.0
    print(json.dumps(rec, indent=2), flush=True)
    return rec


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", action="append", choices=sorted(CASES), help="default: all")
    ap.add_argument("--input", default=str(DATA / "countries_10m.geojson"))
    ap.add_argument("--sample", type=int, default=3_000, help="pixels for the errors")
    ap.add_argument("--s2-sample", type=int, default=300, help="pixels S2 is timed on")
    ap.add_argument("--skip-extras", action="store_true", help="no render cost, no Index")
    args = ap.parse_args()
    t = time.perf_counter()
    shape = gloffset.read(args.input)
    rec = {"input": Path(args.input).name, "read_s": time.perf_counter() - t}
    rec["cases"] = [field_case(shape, name, args) for name in args.case or CASES]
    if not args.skip_extras:
        mexico = gloffset.read(DATA / "mexico_10m.geojson")
        rec["render_cost"] = render_cost(shape, mexico)
        rec["index_build"] = index_build(shape)
    path = write("field", rec)
    print(f"wrote {path}", file=sys.stderr)


if __name__ == "__main__":
    main()
