"""Polar grids: a 4096 x 4096 EPSG:3031 render of Antarctica (1:110m, the pole inside) at
50 km against the equirectangular 4096 x 2048 render of the same region, per boundary
pixel of the mask (the polar grid's pixel centres computed on the GPU by its GLSL
function, and, in the same run, read from textures of the host's float64 centres as
every CRS without a GLSL function does), and against the usual recipe: an
equirectangular render (8192 x 4096) warped to the same polar grid with rasterio's
nearest-neighbour ``reproject`` (GDAL's warper, as ``gdalwarp -r near`` does), its time
and how many pixels it gets wrong. Then Europe (1:110m, the countries of the continent) at
50 km on a 4096 x 4096 EPSG:3035 (LAEA Europe) grid, its centres in GLSL and from
textures in the same run, and the first render's time (the grid's bounds made from every
pixel centre by pyproj, once per grid); Italy on a UTM 33N grid and Canada on an
EPSG:3978 (Lambert conformal conic) grid the same way.

Run: python benchmarks/grids.py [--quick]
Writes benchmarks/results/grids.json. Needs rasterio (the ``geo`` extra).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from common import DATA, best_of, write

import gloffset
from gloffset.grids import Equirect, Projected

D = 50e3  # metres
CRS = "EPSG:3031"
BOUNDS = (-3.4e6, -3.4e6, 3.4e6, 3.4e6)  # the continent and 50 km round it, the pole inside
LAEA, LAEA_BOUNDS = "EPSG:3035", (2.5e6, 1.4e6, 6.5e6, 5.5e6)  # the Canaries to the North Cape
UTM, UTM_BOUNDS = "EPSG:32633", (0.0, 4.0e6, 1.2e6, 5.3e6)  # UTM 33N: Sicily to the Alps
LCC, LCC_BOUNDS = "EPSG:3978", (-2.5e6, -1.0e6, 3.0e6, 4.0e6)  # Canada Atlas Lambert


def antarctica():
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    return gloffset.read(next(f for f in fc["features"] if f["properties"]["name"] == "Antarctica"))


def countries(key: str, value: str):
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    feats = [f for f in fc["features"] if f["properties"][key] == value]
    return gloffset.read({"type": "FeatureCollection", "features": feats})


def crs_record(shape, label: str, n: int, crs: str, bounds, repeat: int) -> dict:
    """``shape`` on an n x n grid of ``crs``: GLSL centres against textures, same run."""
    grid = Projected(n, n, crs=crs, bounds=bounds)
    textured = Projected(n, n, crs=crs, bounds=bounds)
    textured.centres = "texture"
    assert grid.centres == "glsl"
    t_first, _ = best_of(lambda: gloffset.render(shape, D, grid), 1)
    t_glsl, m_glsl = timed_render(shape, grid, repeat)
    t_tex, m_tex = timed_render(shape, textured, repeat)
    b = boundary_pixels(m_glsl)
    return {
        "input": f"Natural Earth 1:110m, {label}",
        "grid": f"Projected({n}, {n}, crs={crs!r}, bounds={bounds})",
        "first_render_s": t_first,
        "glsl_s": t_glsl,
        "texture_s": t_tex,
        "boundary_pixels": b,
        "us_per_boundary_pixel_glsl": 1e6 * t_glsl / b,
        "us_per_boundary_pixel_texture": 1e6 * t_tex / b,
        "pixels_differing": int(np.count_nonzero(m_tex != m_glsl)),
    }


def boundary_pixels(mask: np.ndarray) -> int:
    """Pixels with a 4-neighbour of the other value (the mask's boundary, both sides)."""
    m = mask > 0
    b = np.zeros_like(m)
    b[1:] |= m[1:] != m[:-1]
    b[:-1] |= m[1:] != m[:-1]
    b[:, 1:] |= m[:, 1:] != m[:, :-1]
    b[:, :-1] |= m[:, 1:] != m[:, :-1]
    return int(b.sum())


def timed_render(shape, grid, repeat: int) -> tuple[float, np.ndarray]:
    gloffset.render(shape, D, grid)  # warm: programs compiled, caches made
    return best_of(lambda: gloffset.render(shape, D, grid), repeat)


def warped(shape, polar: Projected, size: tuple[int, int]) -> tuple[float, float, np.ndarray]:
    """The render on an Equirect grid of ``size`` and its nearest-neighbour warp to
    ``polar``: (render seconds, warp seconds, the warped mask)."""
    from rasterio.crs import CRS as RCRS
    from rasterio.transform import Affine
    from rasterio.warp import Resampling, reproject

    eq = Equirect(*size)
    t_render, src = timed_render(shape, eq, 1)
    dst = np.zeros(polar.shape, dtype=np.uint8)

    def run():
        reproject(
            src,
            dst,
            src_transform=Affine(*eq.transform()),
            src_crs=RCRS.from_epsg(4326),
            dst_transform=Affine(*polar.transform()),
            dst_crs=RCRS.from_user_input(CRS),
            resampling=Resampling.nearest,
        )
        return dst.copy()

    t_warp, out = best_of(run, 1)
    return t_render, t_warp, out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="1024-pixel grids, one repeat")
    args = ap.parse_args()
    n = 1024 if args.quick else 4096
    repeat = 1 if args.quick else 3
    shape = antarctica()
    polar = Projected(n, n, crs=CRS, bounds=BOUNDS)
    eq = Equirect(n, n // 2)

    # the same grid with its centres from the host (the path of CRSs without a GLSL function)
    textured = Projected(n, n, crs=CRS, bounds=BOUNDS)
    textured.centres = "texture"
    assert polar.centres == "glsl"

    t_polar, m_polar = timed_render(shape, polar, repeat)
    t_tex, m_tex = timed_render(shape, textured, repeat)
    t_eq, m_eq = timed_render(shape, eq, repeat)
    b_polar, b_eq = boundary_pixels(m_polar), boundary_pixels(m_eq)
    per_polar, per_eq = t_polar / b_polar, t_eq / b_eq
    record = {
        "input": "Natural Earth 1:110m Antarctica",
        "distance_m": D,
        "polar": {
            "grid": f"Projected({n}, {n}, crs={CRS!r}, bounds={BOUNDS})",
            "s": t_polar,
            "boundary_pixels": b_polar,
            "us_per_boundary_pixel": 1e6 * per_polar,
            "centres": "glsl",
        },
        "polar_texture": {
            "grid": "the same, centres from textures of the host's float64 centres",
            "s": t_tex,
            "us_per_boundary_pixel": 1e6 * t_tex / b_polar,
            "pixels_differing_from_glsl": int(np.count_nonzero(m_tex != m_polar)),
        },
        "equirect": {
            "grid": f"Equirect({n}, {n // 2})",
            "s": t_eq,
            "boundary_pixels": b_eq,
            "us_per_boundary_pixel": 1e6 * per_eq,
        },
        "ratio_per_boundary_pixel": per_polar / per_eq,
        "ratio_per_boundary_pixel_texture": t_tex / b_polar / per_eq,
        "warps": [],
    }
    for size in ((2 * n, n), (n, n // 2)):
        t_r, t_w, m_w = warped(shape, polar, size)
        wrong = int(np.count_nonzero((m_w > 0) != (m_polar > 0)))
        record["warps"].append(
            {
                "source": f"Equirect{size}",
                "render_s": t_r,
                "reproject_nearest_s": t_w,
                "total_s": t_r + t_w,
                "wrong_pixels": wrong,
                "wrong_per_boundary_pixel": wrong / b_polar,
            }
        )
    europe = countries("continent", "Europe")
    record["laea"] = crs_record(europe, "the countries of Europe", n, LAEA, LAEA_BOUNDS, repeat)
    italy = countries("name", "Italy")
    record["utm"] = crs_record(italy, "Italy", n, UTM, UTM_BOUNDS, repeat)
    canada = countries("name", "Canada")
    record["lcc"] = crs_record(canada, "Canada", n, LCC, LCC_BOUNDS, repeat)
    print(json.dumps(record, indent=2))
    if not args.quick:
        print("wrote", write("grids", record))


if __name__ == "__main__":
    t0 = time.perf_counter()
    main()
    print(f"{time.perf_counter() - t0:.1f} s")
