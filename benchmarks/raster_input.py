"""Offsets of a rasterized curve (paper Sec. 5): Mexico's 10m border rasterized by
gloffset on a 4096x2048 world grid, offset at three distances by the GPU engine, the
float64 CPU reference (hierarchical, Sec. 5.2, and single resolution, Sec. 5.1) and
scipy's Euclidean distance transform on pixels, in one run.

The true spherical answer is the float64 reference for the *vector* curve at pixel
centres (distance to the border <= d). Counts of disagreement with it are given for
scipy (pixel distance with the pixel size at the border's mean latitude, what users
do) and for the raster offset (contained pixels that are truly out, truly-in pixels
classed outside: both must be 0; frontier pixels are the undecided band).

Cube case (key ``cube``): the Natural Earth 110m borders (all countries) rasterized
by gloffset on a 6 x 1024 x 1024 cube map (the curve crosses every face edge), offset
by the GPU engine and the CPU reference (hierarchical); the true answer is checked on
a seeded sample of the pixels near the curve (the vector reference is slow for
hundreds of rings). No scipy comparison: a Euclidean transform cannot cross faces.

Run: python benchmarks/raster_input.py [--quick] [--cube-only]
Writes benchmarks/results/raster_input.json (``--cube-only`` updates only its
``cube`` record). Needs scipy (the ``bench`` extra).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from common import DATA, best_of, write

import gloffset
from gloffset.gl import context_info
from gloffset.grids import Cube, CubeFace, Equirect
from gloffset.grids.cube import face_points
from gloffset.raster.rasterized import CONTAINED, FRONTIER, OUTSIDE, raster_offset, rasterize
from gloffset.reference import distance_xyz
from gloffset.units import EARTH_RADIUS

DISTANCES_KM = (50.0, 127.0, 250.0)


def window(grid, shape, grow_rad):
    """Row and column ranges of the pixels within the border's lon/lat box grown by
    ``grow_rad`` (in latitude, and in longitude at the box's highest latitude)."""
    from gloffset.geometry.sphere import xyz_to_lonlat

    lo, la = xyz_to_lonlat(np.concatenate(shape.rings))
    g = math.degrees(grow_rad)
    glon = g / math.cos(math.radians(max(abs(la.min()), abs(la.max())) + g))
    w, s, e, n = grid.bounds
    i0 = max(0, int((lo.min() - glon - w) / grid.span_lon * grid.width) - 1)
    i1 = min(grid.width, int((lo.max() + glon - w) / grid.span_lon * grid.width) + 2)
    j0 = max(0, int((n - la.max() - g) / (n - s) * grid.height) - 1)
    j1 = min(grid.height, int((n - la.min() + g) / (n - s) * grid.height) + 2)
    return slice(j0, j1), slice(i0, i1)


def gpu_vs_cpu(mask, d_km, grid, parts):
    """One distance: the GPU and the float64 CPU classes, timed, and what they found."""
    d = d_km * 1e3
    t_gpu, (cls, info) = best_of(
        lambda: raster_offset(mask, d, grid, order=parts, return_info=True), 3
    )
    t_cpu, (ref, _) = best_of(
        lambda: raster_offset(mask, d, grid, order=parts, backend="cpu", return_info=True), 1
    )
    rec = {
        "distance_km": d_km,
        "gpu_s": t_gpu,
        "cpu_hierarchical_s": t_cpu,
        "gpu_equals_cpu": bool(np.array_equal(cls, ref)),
        "gpu_ambiguous_cells_decided_on_cpu": info.n_ambiguous,
        "method_level0": info.method,
        "contained": int(np.count_nonzero(cls == CONTAINED)),
        "frontier": int(np.count_nonzero(cls == FRONTIER)),
        "frontier_per_level": info.frontier,
    }
    return rec, cls, ref


def borders_as_lines(path):
    """Every ring of every country as a line: the borders themselves (read as polygons,
    the countries unite and the borders between them are no curve)."""
    parts = gloffset.io.geojson.parse(gloffset.io.geojson.load(path))
    rings = [r.tolist() for poly in parts.polygons for r in poly]
    return gloffset.read({"type": "MultiLineString", "coordinates": rings})


def cube_case(quick: bool, n_truth: int = 20000) -> dict:
    """World 110m borders on six cube faces: GPU vs CPU reference, sampled truth."""
    size = 256 if quick else 1024
    grid = Cube(size)
    shape = borders_as_lines(DATA / "world_110m.geojson")
    t_rast, (mask, parts) = best_of(lambda: rasterize(shape, grid, ordered=True), 3)
    # the sample: pixels whose 8x8 ancestor is not outside at the largest distance
    far = max(DISTANCES_KM) * 1e3
    raster_offset(mask, far, grid, order=parts)  # compile the shaders
    level = CubeFace(0, size).n_levels - 4
    near = raster_offset(mask, far, grid, order=parts, level=level) != OUTSIDE
    near = np.flatnonzero(np.repeat(np.repeat(near, 8, 1), 8, 2)[:, :size, :size].ravel())
    pick = np.sort(np.random.default_rng(0).choice(near, min(n_truth, len(near)), replace=False))
    f, r = np.divmod(pick, size * size)
    j, i = np.divmod(r, size)
    t0 = time.perf_counter()
    dist = distance_xyz(shape, face_points(f, i + 0.5, j + 0.5, size))
    t_truth = time.perf_counter() - t0
    runs = []
    for d_km in DISTANCES_KM:
        d = d_km * 1e3
        rec, cls, _ = gpu_vs_cpu(mask, d_km, grid, parts)
        truth = dist <= d / EARTH_RADIUS
        got = cls[f, j, i]
        rec |= {
            "sample_contained_but_truly_out": int(np.count_nonzero((got == CONTAINED) & ~truth)),
            "sample_truly_in_but_outside": int(np.count_nonzero((got == OUTSIDE) & truth)),
            "sample_truly_in": int(np.count_nonzero(truth)),
            "sample_frontier": int(np.count_nonzero(got == FRONTIER)),
        }
        runs.append(rec)
        print(rec, flush=True)
    return {
        "grid": f"cube 6x{size}x{size}",
        "curve": "Natural Earth 110m borders (all countries), rasterized by gloffset.rasterize",
        "curve_pixels": int(mask.sum()),
        "curve_pixels_per_face": [int(x) for x in mask.sum(axis=(1, 2))],
        "rasterize_s": t_rast,
        "truth_sample_pixels": len(pick),
        "truth_sample_s": t_truth,
        "runs": runs,
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="1024x512 (cube 6x256) instead")
    ap.add_argument("--no-single", action="store_true", help="skip the Sec. 5.1 CPU run")
    ap.add_argument("--cube-only", action="store_true", help="only the cube case")
    args = ap.parse_args()
    if args.cube_only:
        import json

        from common import RESULTS

        path = RESULTS / "raster_input.json"
        record = json.loads(path.read_text()) if path.exists() else {}
        record.pop("machine", None)
        record["cube"] = cube_case(args.quick)
        record["gl"] = {k: context_info()[k] for k in ("renderer", "version")}
        print(write("raster_input", record))
        return
    from scipy.ndimage import distance_transform_edt

    size = (1024, 512) if args.quick else (4096, 2048)
    grid = Equirect(*size)
    shape = gloffset.read(DATA / "mexico_10m.geojson")
    t_rast, (mask, parts) = best_of(lambda: rasterize(shape, grid, ordered=True), 3)
    last = grid.n_levels - 1

    # the true answer near the border: distance of each pixel centre to the vector curve
    dmax = max(DISTANCES_KM) * 1e3 / EARTH_RADIUS
    rows, cols = window(grid, shape, 1.5 * dmax + 4 * grid.dlat)
    jj, ii = np.meshgrid(np.arange(grid.height)[rows], np.arange(grid.width)[cols], indexing="ij")
    t0 = time.perf_counter()
    dist_true = distance_xyz(shape, grid.centers(last, jj.ravel(), ii.ravel())).reshape(jj.shape)
    t_truth = time.perf_counter() - t0

    lat_mean = float(np.mean(grid.cell_lat(last, np.nonzero(mask)[0])))
    px_y = grid.dlat * EARTH_RADIUS / 1e3
    px_x = grid.dlon * math.cos(lat_mean) * EARTH_RADIUS / 1e3

    raster_offset(mask, DISTANCES_KM[0] * 1e3, grid, order=parts)  # compile the shaders
    runs = []
    for d_km in DISTANCES_KM:
        d = d_km * 1e3
        truth = np.zeros(grid.shape, dtype=bool)
        truth[rows, cols] = dist_true <= d / EARTH_RADIUS
        rec, cls, ref = gpu_vs_cpu(mask, d_km, grid, parts)
        rec |= {
            "contained_but_truly_out": int(np.count_nonzero((cls == CONTAINED) & ~truth)),
            "truly_in_but_outside": int(np.count_nonzero((cls == OUTSIDE) & truth)),
            "truly_in": int(np.count_nonzero(truth)),
        }
        if not args.no_single:
            t_single, (single, info_s) = best_of(
                lambda d=d: raster_offset(
                    mask, d, grid, order=parts, backend="cpu", mode="single", return_info=True
                ),
                1,
            )
            rec.update(
                cpu_single_s=t_single,
                single_equals_hierarchical=bool(np.array_equal(single, ref)),
                single_method=info_s.method,
                single_reason=info_s.reason,
            )

        def edt(d_km=d_km):
            return distance_transform_edt(~mask, sampling=(px_y, px_x)) <= d_km

        t_edt, near = best_of(edt, 3)
        rec.update(
            scipy_edt_s=t_edt,
            scipy_edt_disagreements=int(np.count_nonzero(near != truth)),
            scipy_edt_false_in=int(np.count_nonzero(near & ~truth)),
            scipy_edt_false_out=int(np.count_nonzero(~near & truth)),
        )
        runs.append(rec)
        print(rec, flush=True)
    path = write(
        "raster_input",
        {
            "grid": list(size),
            "curve": "Mexico 10m border, rasterized by gloffset.rasterize",
            "curve_pixels": int(mask.sum()),
            "rasterize_s": t_rast,
            "truth_s": t_truth,
            "truth_pixels": int(dist_true.size),
            "scipy_sampling_km": [px_y, px_x],
            "gl": {k: context_info()[k] for k in ("renderer", "version")},
            "runs": runs,
            "cube": cube_case(args.quick),
        },
    )
    print(path)


if __name__ == "__main__":
    main()
