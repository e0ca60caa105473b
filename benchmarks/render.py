"""Raster render of Mexico (10m) at d = 0.02 rad against the fill floor, the float64
reference and the tools users reach for instead, in one run.

Run: python benchmarks/render.py [--quick]
Writes benchmarks/results/render.json. Needs the ``bench`` extra (spherely, shapely,
scipy, rasterio).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from common import DATA, best_of, write

import gloffset
from gloffset.gl import context_info, get_context, program
from gloffset.grids import Equirect
from gloffset.raster.render import render
from gloffset.raster.vector.curves import classify_curves

D = 0.02  # radians, as in the paper's Table 1
REPEAT = 7  # best of, for the render and its fill floor alike (a 2-core machine is noisy)


def fill_floor(w: int, h: int) -> float:
    """One trivial fragment pass over a w x h uint8 target plus its read-back."""
    import moderngl

    ctx = get_context()
    prog = program(ctx, "fullscreen.vert", "fill.frag")
    vao = ctx.vertex_array(prog, [])
    tex = ctx.texture((w, h), 1, dtype="u1")
    fbo = ctx.framebuffer(color_attachments=[tex])

    def run():
        fbo.use()
        ctx.viewport = (0, 0, w, h)
        vao.render(moderngl.TRIANGLES, vertices=3)
        return tex.read(alignment=1)

    t, _ = best_of(run, REPEAT)
    fbo.release()
    tex.release()
    vao.release()
    return t


def per_level(shape, grid) -> list:
    """Seconds spent on each level (CPU levels, then GPU levels, each finished; the
    GPU level after the bins includes the arc records), the least of REPEAT runs."""
    from gloffset.raster.gpu import bin_passes as engine

    eng = engine()
    bins = grid.bin_level_for(D)
    best = {}
    for _ in range(REPEAT):
        marks = []
        t0 = time.perf_counter()
        classes, f, arcs = classify_curves(
            shape, D, grid, stop_level=bins, timings=marks, start="auto"
        )
        eng.run(grid, D, classes, f, arcs, stop_level=grid.n_levels - 1, timings=marks)
        prev = t0
        for lev, t in marks:
            best[lev] = min(best.get(lev, math.inf), t - prev)
            prev = t
    return [
        {
            "level": lev,
            "shape": list(grid.level_shape(lev)),
            "where": "cpu" if lev <= bins else "gpu",
            "s": s,
        }
        for lev, s in sorted(best.items())
    ]


def pixel_lonlat(grid):
    lon, _ = grid.pixel_lonlat(np.arange(grid.width), 0)
    _, lat = grid.pixel_lonlat(0, np.arange(grid.height))
    return np.asarray(lon), np.asarray(lat)


def prefilter(grid, shape):
    """Pixels inside Mexico's lon/lat box grown by D (in degrees of lat, and of lon at
    the box's highest latitude): the hand-written prefilter users add to exact tools."""
    lon, lat = pixel_lonlat(grid)
    from gloffset.geometry.sphere import xyz_to_lonlat

    lo, la = xyz_to_lonlat(np.concatenate(shape.rings))
    grow = math.degrees(D)
    glon = grow / math.cos(math.radians(max(abs(la.min()), abs(la.max())) + grow))
    ii = np.flatnonzero((lon >= lo.min() - glon) & (lon <= lo.max() + glon))
    jj = np.flatnonzero((lat >= la.min() - grow) & (lat <= la.max() + grow))
    return ii, jj, lon, lat


def alt_spherely(shape, grid):
    import spherely

    from gloffset.geometry.sphere import xyz_to_lonlat

    ii, jj, lon, lat = prefilter(grid, shape)
    polys, lines = [], []
    for r in shape.rings:
        lo, la = xyz_to_lonlat(r)
        ring = list(zip(lo.tolist(), la.tolist()))
        polys.append(spherely.create_polygon(ring, oriented=True))
        lines.append(ring + ring[:1])
    bnd = spherely.create_multilinestring(lines)

    def run():
        for p in polys:
            spherely.prepare(p)
        spherely.prepare(bnd)
        LO, LA = np.meshgrid(lon[ii], lat[jj])
        pts = spherely.points(LO.ravel(), LA.ravel())
        inside = np.zeros(pts.shape, dtype=bool)
        for p in polys:
            inside |= spherely.contains(p, pts)
        member = inside | (spherely.distance(bnd, pts, radius=1.0) <= D)
        mask = np.zeros(grid.shape, dtype=bool)
        mask[np.ix_(jj, ii)] = member.reshape(len(jj), len(ii))
        return mask

    return best_of(run, 1)


def alt_shapely(shape, grid):
    import shapely

    ii, jj, lon, lat = prefilter(grid, shape)
    geom = shapely.from_geojson(__import__("json").dumps(shape.to_geojson()))

    def run():
        buf = shapely.buffer(geom, math.degrees(D), quad_segs=16)
        shapely.prepare(buf)
        LO, LA = np.meshgrid(lon[ii], lat[jj])
        member = shapely.contains_xy(buf, LO.ravel(), LA.ravel())
        mask = np.zeros(grid.shape, dtype=bool)
        mask[np.ix_(jj, ii)] = member.reshape(len(jj), len(ii))
        return mask

    return best_of(run, 1)


def alt_rasterio(shape, grid):
    import rasterio.features
    import shapely
    from rasterio.transform import from_bounds

    geom = shapely.from_geojson(__import__("json").dumps(shape.to_geojson()))
    w, s, e, n = grid.bounds
    transform = from_bounds(w, s, e, n, grid.width, grid.height)

    def run():
        buf = shapely.buffer(geom, math.degrees(D), quad_segs=16)
        return rasterio.features.rasterize(
            [buf], out_shape=grid.shape, transform=transform, dtype="uint8"
        ).astype(bool)

    return best_of(run, 1)


def alt_scipy(shape, grid):
    from scipy.ndimage import distance_transform_edt

    inside = render(shape, 0.0, grid, radius=1.0) == 255

    def run():
        # distance in pixels to the polygon raster, threshold at D in pixels of latitude
        dist = distance_transform_edt(~inside)
        return dist <= D / grid.dlat

    return best_of(run, 1)


def measure(shape, grid, *, alternatives: bool) -> dict:
    render(shape, D, grid, radius=1.0)  # warm: shaders, caches
    t_gpu, mask = best_of(lambda: render(shape, D, grid, radius=1.0), REPEAT)
    t_ref, ref = best_of(lambda: render(shape, D, grid, radius=1.0, backend="cpu"), 1)
    ref = ref == 255
    rec = {
        "size": [grid.width, grid.height],
        "bounds": list(grid.bounds),
        "gloffset_gpu_s": t_gpu,
        "gloffset_disagreements": int(((mask == 255) != ref).sum()),
        "fill_floor_s": fill_floor(grid.width, grid.height),
        "reference_cpu_float64_s": t_ref,
        "pixels_in_region": int(ref.sum()),
        "levels": per_level(shape, grid),
    }
    rec["gpu_over_fill_floor"] = rec["gloffset_gpu_s"] / rec["fill_floor_s"]
    if alternatives:
        for name, fn in [
            ("spherely_prefiltered", alt_spherely),
            ("shapely_buffer_degrees", alt_shapely),
            ("rasterio_rasterize_shapely_buffer", alt_rasterio),
            ("scipy_distance_transform_pixels", alt_scipy),
        ]:
            try:
                t, m = fn(shape, grid)
                rec[name] = {"s": t, "disagreements": int((m != ref).sum())}
            except ImportError as exc:
                rec[name] = {"skipped": str(exc)}
    return rec


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="skip 16384x8192 and the alternatives")
    args = ap.parse_args()
    shape = gloffset.read(DATA / "mexico_10m.geojson")
    info = context_info()
    rec = {"device": info["renderer"], "gl_version": info["version"], "distance_rad": D}
    rec["globe_4096x2048"] = measure(shape, Equirect(4096, 2048), alternatives=not args.quick)
    rec["mexico_box_2048x2048"] = measure(
        shape, Equirect(2048, 2048, (-118.5, 14.5, -86.7, 32.8)), alternatives=not args.quick
    )
    sizes = [(2048, 1024), (4096, 2048), (8192, 4096)] + ([] if args.quick else [(16384, 8192)])
    scaling = []
    for w, h in sizes:
        g = Equirect(w, h)
        render(shape, D, g, radius=1.0)
        t, _ = best_of(lambda g=g: render(shape, D, g, radius=1.0), 2)
        scaling.append({"size": [w, h], "gloffset_gpu_s": t, "fill_floor_s": fill_floor(w, h)})
    rec["scaling"] = scaling
    path = write("render", rec)
    for key in ("globe_4096x2048", "mexico_box_2048x2048"):
        r = rec[key]
        print(
            f"{key}: gpu {r['gloffset_gpu_s']:.3f} s (fill floor {r['fill_floor_s']:.3f} s, "
            f"x{r['gpu_over_fill_floor']:.1f}), reference {r['reference_cpu_float64_s']:.3f} s, "
            f"disagreements {r['gloffset_disagreements']}"
        )
        for name in (
            "spherely_prefiltered",
            "shapely_buffer_degrees",
            "rasterio_rasterize_shapely_buffer",
            "scipy_distance_transform_pixels",
        ):
            if name in r:
                print(f"   {name}: {r[name]}")
    for s in scaling:
        print(
            f"scaling {s['size']}: gpu {s['gloffset_gpu_s']:.3f} s, fill {s['fill_floor_s']:.3f} s"
        )
    print("wrote", path)


if __name__ == "__main__":
    main()
