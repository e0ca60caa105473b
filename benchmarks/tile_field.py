"""A 256 px tile's distance field against a render of the same tile, zooms 3 to 10.

The tile server answers a seen tile at a new distance from the tile's field (a
threshold) once it has one; it computes fields at once where a field costs at most
``AT_ONCE`` renders (``gloffset/serve/service.py``). This measures that price: per
input (Mexico and all the countries of 1:10m) and zoom, the tiles of ``--tiles``
seeded boundary vertices of Mexico, each timed warm (best of ``--repeat``):
``gloffset.distance_field(shape, Tile(z, x, y))`` (default backend) and
``gloffset.render(shape, d, Tile(z, x, y))`` at ``d`` = 20 km (the offset's boundary
crosses such a tile at every zoom). Printed and recorded: both times and their ratio,
per tile, and the largest ratio per input.

The floor beside them: the field of a one-vertex shape (the antipode of the tile's
centre) on the same tile: one arc in every cell's list, every cell deep, each pixel
still finished in float64 (a point at the tile's centre, or 20 degrees away, costs as
much within the noise). No list can make a field cheaper than that on this GL, so ``floor / render``
is the least ratio the field can reach here whatever its walk (printed and recorded per
tile, ``floor_s`` and ``floor_ratio``; the largest per input).

``--walk cpu`` or ``gpu`` sets the fields' walk (``gloffset.raster.fields.gpu.WALK``;
default ``auto``).

``--at=LON,LAT`` measures the tiles about that point instead (an inland point: tiles whose
render is decided at once, while their field still finishes every pixel).

Run: python benchmarks/tile_field.py [--tiles 3] [--repeat 5] [-k mexico] [--walk auto]
     [--at=LON,LAT]
Writes benchmarks/results/tile_field.json (tile_field_at.json with ``--at``;
..._walk_WALK.json for another walk).
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from common import DATA, best_of, write

import gloffset
from gloffset.grids import Tile
from gloffset.raster.fields import gpu as field_gpu

D = 20e3  # metres


def tile_of(lon: float, lat: float, z: int) -> tuple[int, int]:
    """The web mercator tile (x, y) of zoom ``z`` that holds ``(lon, lat)``."""
    n = 1 << z
    x = int((lon + 180.0) / 360.0 * n)
    y = int((1.0 - math.asinh(math.tan(math.radians(lat))) / math.pi) / 2.0 * n)
    return min(x, n - 1), min(y, n - 1)


def boundary_points(k: int, seed: int = 0) -> np.ndarray:
    """``k`` seeded vertices (lon, lat) of Mexico's boundary."""
    mexico = gloffset.read(DATA / "mexico_10m.geojson")
    xyz = np.concatenate(mexico.rings)
    rng = np.random.default_rng(seed)
    x, y, z = xyz[rng.choice(len(xyz), k, replace=False)].T
    return np.column_stack([np.degrees(np.arctan2(y, x)), np.degrees(np.arcsin(z))])


def measure_tile(shape, z: int, x: int, y: int, repeat: int) -> dict:
    """One tile's record: its field, its render at :data:`D` and the floor (the field of
    the antipode of its centre), each warm, the best of ``repeat``; their ratios."""
    grid = Tile(z, x, y)
    half = grid.size / 2 - 0.5  # the pixel "centre" at the tile's centre
    lon, lat = (float(v) for v in grid.pixel_lonlat(half, half))
    antipode = [lon + 180.0 if lon < 0 else lon - 180.0, -lat]
    point = gloffset.read({"type": "Point", "coordinates": antipode})
    runs = {
        "field_s": lambda: gloffset.distance_field(shape, grid),
        "render_s": lambda: gloffset.render(shape, D, grid),
        "floor_s": lambda: gloffset.distance_field(point, grid),
    }
    row: dict = {"tile": [z, x, y]}
    for key, fn in runs.items():
        fn()  # warm: caches, GL, shaders
        row[key], _ = best_of(fn, repeat)
    row["ratio"] = row["field_s"] / row["render_s"]
    row["floor_ratio"] = row["floor_s"] / row["render_s"]
    return row


def measure_input(name: str, shape, points, repeat: int) -> dict:
    """The tiles of ``points`` (lon, lat) at zooms 3-10 of one input, printed; with the
    largest ratios."""
    rows = []
    for z in range(3, 11):
        for lon, lat in points:
            x, y = tile_of(float(lon), float(lat), z)
            row = measure_tile(shape, z, x, y, repeat)
            rows.append(row)
            print(
                f"{name:14s} {z:2d}/{x}/{y:<6d} field {row['field_s'] * 1e3:7.1f} ms  "
                f"render {row['render_s'] * 1e3:6.1f} ms  ratio {row['ratio']:5.1f}  "
                f"floor {row['floor_s'] * 1e3:6.1f} ms ({row['floor_ratio']:4.1f})",
                flush=True,
            )
    worst = max(r["ratio"] for r in rows)
    floor = max(r["floor_ratio"] for r in rows)
    print(f"{name}: largest field / render ratio {worst:.1f} (floor {floor:.1f})", flush=True)
    return {"tiles": rows, "largest_ratio": worst, "largest_floor_ratio": floor}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tiles", type=int, default=3, help="boundary vertices (tiles) per zoom")
    ap.add_argument("--repeat", type=int, default=5, help="warm runs, the best kept")
    ap.add_argument("-k", default="", help="only the inputs whose name contains this")
    ap.add_argument("--walk", default="auto", choices=("auto", "cpu", "gpu"), help="the walk")
    ap.add_argument(
        "--at",
        default=None,
        help="LON,LAT: the tiles about this point instead of boundary vertices (written to "
        "tile_field_at.json)",
    )
    args = ap.parse_args(argv)
    field_gpu.WALK = args.walk
    if args.at is None:
        points = boundary_points(args.tiles)
    else:
        try:
            lon, lat = (float(v) for v in args.at.split(","))
        except ValueError:
            ap.error(f"--at wants LON,LAT in degrees (as --at=-99.13,19.43), got {args.at!r}")
        points = np.array([[lon, lat]])
    record: dict = {"distance_m": D, "repeat": args.repeat, "walk": args.walk, "inputs": {}}
    record["points"] = points.tolist()
    for name in ("mexico_10m", "countries_10m"):
        if args.k not in name:
            continue
        shape = gloffset.read(DATA / f"{name}.geojson")
        record["inputs"][name] = measure_input(name, shape, points, args.repeat)
    name = "tile_field" if args.at is None else "tile_field_at"
    write(name if args.walk == "auto" else f"{name}_walk_{args.walk}", record)


if __name__ == "__main__":
    main()
