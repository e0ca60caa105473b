"""Golden outputs: every benchmark case, rendered at a small size, hashed and compared
with the hashes checked in to ``tests/golden/hashes*.json`` (one file per platform).

A change of the engine that should not change any output (a refactor) must leave every
hash as it is: masks and classes (sha256 of the array's bytes with its dtype and shape),
tile pyramids (each tile's PNG bytes in sorted z/x/y order, and the metadata), vector
offsets (the arcs' float64 arrays, and the canonical JSON of the GeoJSON: sorted keys, no
spaces), the inside answers of ``contains`` and the union's rings. The cases follow
``benchmarks/`` (render.py, tiles.py, raster_input.py, selfintersect.py, table1.py,
vector.py, union.py): Mexico 10m at 0.02 rad on the globe and in the Mexico box, the
world's borders on a cube map, tile pyramids, resolved offsets, Table 1's points, the
union of neighbouring countries. Distances > 0 and < 0 and lines are covered, and every
grid kind: ``Equirect`` global and regional across the antimeridian, ``Cube``,
``CubeFace``, ``Tile``.

Run::

    python -m pytest -q tests/test_golden.py            # the small sizes (seconds)
    python -m pytest -q -m slow tests/test_golden.py    # the benchmarks' full sizes

A failure names the case whose output changed, with the recorded and the current
summary (pixel counts, rings, tiles) to show what moved.

Regenerate the hashes deliberately, after a change that is meant to change outputs::

    python tests/test_golden.py --update                # every case, slow ones included
    python tests/test_golden.py --update 'render/*'     # only the cases matching a pattern
    python tests/test_golden.py --list                  # the case names

(with gloffset importable, e.g. ``PYTHONPATH=.``). ``--update`` rewrites
``tests/golden/hashes.json``; review its diff like any other change.

Platform: the hashes hold for one platform. Float64 results (offset arcs, their GeoJSON
coordinates, distances) depend on numpy and its SIMD paths and BLAS, the masks and
classes on Mesa's llvmpipe, the tiles' PNG bytes on Pillow and zlib. The versions are
recorded in each file under ``platform``; a case is compared with the first file whose
platform fits it, and skipped, with the reason, when none does, i.e. when what it depends on
differs here: numpy's major.minor version or the CPU features
numpy dispatches to (every case), the GL renderer or GL version string of
:func:`gloffset.gl.context_info` (which names Mesa's version; cases that render), Pillow's
major.minor version or zlib's version (cases that write PNG tiles). ``--update`` on a new
platform writes a new ``hashes-<features>-<hash>.json`` beside the others (from the same
commit as the others: the files must agree on what the outputs are).
"""

from __future__ import annotations

import argparse
import fnmatch
import functools
import hashlib
import json
import platform
import sqlite3
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import mercantile
import numpy as np
import pytest

import gloffset
from gloffset.grids import Cube, CubeFace, Equirect, Tile

HERE = Path(__file__).resolve().parent
DATA = HERE.parent / "data"
GOLDEN = HERE / "golden" / "hashes.json"

D = 0.02  # rad, the benchmarks' distance (127 km)
MEXICO_BOX = (-118.5, 14.5, -86.7, 32.8)  # benchmarks/render.py
TABLE1_BOX = (-120.0, 12.0, -84.0, 35.0)  # benchmarks/table1.py
ANTIMERIDIAN_BOX = (140.0, -90.0, -130.0, 85.0)  # W > E: across 180 deg, down to the pole
SEAM_COUNTRIES = ("Russia", "Fiji", "United States of America", "Antarctica")
OUTLINE = "#202020"  # benchmarks/tiles.py


# ----------------------------------------------------------------------------- inputs
@functools.cache
def mexico():
    return gloffset.read(DATA / "mexico_10m.geojson")


@functools.cache
def world_features() -> dict:
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    return {f["properties"]["name"]: f for f in fc["features"]}


@functools.cache
def countries(names: tuple) -> gloffset.Shape:
    """world_110m countries united (one shape)."""
    feats = world_features()
    return gloffset.read({"type": "FeatureCollection", "features": [feats[n] for n in names]})


@functools.cache
def borders_as_lines():
    """Every ring of every world_110m country as a line (benchmarks/raster_input.py)."""
    parts = gloffset.io.geojson.parse(gloffset.io.geojson.load(DATA / "world_110m.geojson"))
    rings = [r.tolist() for poly in parts.polygons for r in poly]
    return gloffset.read({"type": "MultiLineString", "coordinates": rings})


@functools.cache
def seam_lines():
    """The rings of Russia and Fiji (cut at +-180 deg) as lines."""
    parts = gloffset.io.geojson.parse(
        {"type": "FeatureCollection", "features": [world_features()[n] for n in ("Russia", "Fiji")]}
    )
    rings = [r.tolist() for poly in parts.polygons for r in poly]
    return gloffset.read({"type": "MultiLineString", "coordinates": rings})


@functools.cache
def coastline(n: int = 70_000):
    """The seeded synthetic coastline of benchmarks/selfintersect.py (n vertices)."""
    return _bench_common().coastline(n)


def _bench_common():
    """benchmarks/common.py, which holds the synthetic inputs the benchmarks share."""
    bench = str(Path(__file__).resolve().parent.parent / "benchmarks")
    if bench not in sys.path:
        sys.path.insert(0, bench)
    import common

    return common


@functools.cache
def rasterized(which: str, size):
    """(mask, parts) of Mexico's border on Equirect(*size), or of the world's borders
    on Cube(size)."""
    if which == "mexico":
        return gloffset.rasterize(mexico(), Equirect(*size), ordered=True)
    return gloffset.rasterize(borders_as_lines(), Cube(size), ordered=True)


def table1_points(n: int, seed: int = 0):
    """``n`` points uniform in lon/lat over Table 1's box (benchmarks/common.py)."""
    rng = np.random.default_rng(seed)
    w, s, e, nn = TABLE1_BOX
    return rng.uniform(w, e, n), rng.uniform(s, nn, n)


def sphere_points(n: int, seed: int = 0):
    """``n`` points uniform on the sphere, lon/lat degrees."""
    rng = np.random.default_rng(seed)
    return rng.uniform(-180.0, 180.0, n), np.degrees(np.arcsin(rng.uniform(-1.0, 1.0, n)))


# ----------------------------------------------------------------------------- hashing
def canonical_json(obj) -> bytes:
    """Sorted keys, no spaces, no NaN: the same bytes for the same document."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()


def digest(parts) -> str:
    """sha256 of labelled parts: arrays with their dtype and shape, bytes, JSON values."""
    h = hashlib.sha256()
    for label, value in parts:
        if isinstance(value, np.ndarray):
            head = f"{label}\0array\0{value.dtype.str}\0{value.shape}\0"
            data = np.ascontiguousarray(value).tobytes()
        elif isinstance(value, bytes):
            head, data = f"{label}\0bytes\0", value
        else:
            head, data = f"{label}\0json\0", canonical_json(value)
        h.update(head.encode())
        h.update(len(data).to_bytes(8, "little"))
        h.update(data)
    return h.hexdigest()


def counts(a: np.ndarray) -> dict:
    """{value: count} of a uint8 / bool array (a summary for the failure message)."""
    vals, n = np.unique(a, return_counts=True)
    return {str(int(v)): int(c) for v, c in zip(vals, n)}


def array_output(name: str, a: np.ndarray):
    return [(name, a)], {"shape": list(a.shape), "dtype": a.dtype.str, "values": counts(a)}


def arc_ring_parts(prefix: str, rings) -> list:
    """Every array of every ring of small-circle arcs (OffsetRing)."""
    parts = []
    for k, r in enumerate(rings):
        for attr in ("centers", "junctions", "kind", "sources"):
            parts.append((f"{prefix}{k}.{attr}", np.asarray(getattr(r, attr))))
    return parts


def geojson_points(geom: dict) -> int:
    def count(c):
        return 1 if c and isinstance(c[0], (int, float)) else sum(count(x) for x in c)

    return count(geom["coordinates"])


# ----------------------------------------------------------------------------- cases
@dataclass(frozen=True)
class Case:
    """One output to hash. ``run()`` returns (parts, summary); ``needs`` names what the
    output depends on beyond numpy: ``"gl"`` (rendered) and ``"png"`` (PNG bytes)."""

    name: str
    run: object
    needs: tuple = ()
    slow: bool = False


CASES: dict[str, Case] = {}


def case(name: str, needs=(), slow: bool = False):
    def register(fn):
        if name in CASES:
            raise ValueError(f"duplicate golden case {name!r}")
        CASES[name] = Case(name, fn, tuple(needs), slow)
        return fn

    return register


def sd(d: float) -> str:
    return f"{d:+g}"


# --- render.py: Mexico at 0.02 rad on the globe and in the Mexico box; cube; tiles
def _render(shape_fn, d, grid, **kw):
    def run():
        return array_output("mask", gloffset.render(shape_fn(), d, grid, radius=1.0, **kw))

    return run


for _w, _h, _slow in ((1024, 512, False), (4096, 2048, True), (8192, 4096, True)):
    for _d in (D, -D):
        case(f"render/globe_{_w}x{_h}_d{sd(_d)}", ("gl",), _slow)(
            _render(mexico, _d, Equirect(_w, _h))
        )
for _n, _slow in ((512, False), (2048, True)):
    for _d in (D, -D):
        case(f"render/mexico_box_{_n}x{_n}_d{sd(_d)}", ("gl",), _slow)(
            _render(mexico, _d, Equirect(_n, _n, MEXICO_BOX))
        )
case("render/mexico_box_512x512_d+0.02_cpu")(
    _render(mexico, D, Equirect(512, 512, MEXICO_BOX), backend="cpu")
)
case("render/globe_1024x512_d+0.02_cpu")(_render(mexico, D, Equirect(1024, 512), backend="cpu"))


def _render_levels(shape_fn, d, grid):
    """The classes of every level handed to ``callback`` (the progressive answer), and
    the mask."""

    def run():
        levels = []
        mask = gloffset.render(
            shape_fn(), d, grid, radius=1.0, callback=lambda lev, c: levels.append((lev, c.copy()))
        )
        parts = [(f"level {lev} classes", c) for lev, c in levels] + [("mask", mask)]
        summary = {
            "levels": [lev for lev, _ in levels],
            "frontier": [int(np.count_nonzero(c == 1)) for _, c in levels],
            "mask": counts(mask),
        }
        return parts, summary

    return run


case("render/globe_1024x512_d+0.02_levels", ("gl",))(_render_levels(mexico, D, Equirect(1024, 512)))
case("render/mexico_box_512x512_d-0.02_levels", ("gl",))(
    _render_levels(mexico, -D, Equirect(512, 512, MEXICO_BOX))
)

for _d in (D, -D):
    case(f"render/antimeridian_512x768_d{sd(_d)}", ("gl",))(
        _render(lambda: countries(SEAM_COUNTRIES), _d, Equirect(512, 768, ANTIMERIDIAN_BOX))
    )
case("render/world_lines_antimeridian_512x768_d+0.005", ("gl",))(
    _render(borders_as_lines, 0.005, Equirect(512, 768, ANTIMERIDIAN_BOX))
)
for _n, _slow in ((128, False), (1024, True), (2048, True)):
    case(f"render/cube_6x{_n}_d+0.02", ("gl",), _slow)(_render(mexico, D, Cube(_n)))
case("render/world_cube_6x128_d+0.02", ("gl",))(
    _render(lambda: countries(tuple(world_features())), D, Cube(128))
)
case("render/world_cube_6x128_d-0.02", ("gl",))(
    _render(lambda: countries(tuple(world_features())), -D, Cube(128))
)
case("render/world_lines_cube_6x128_d+0.01", ("gl",))(_render(borders_as_lines, 0.01, Cube(128)))
case("render/antarctica_cubeface_nz_256_d+0.02", ("gl",))(
    _render(lambda: countries(("Antarctica",)), D, CubeFace(5, 256))
)


def _tile_output(shape_fn, distance, tile_fn, **kw):
    """One tile; ``distance`` in metres (the default radius) and the tile found lazily
    (``tile_fn``), so that registering the case reads no data."""

    def run():
        mask = gloffset.render(shape_fn(), distance, tile_fn(), **kw)
        return array_output("mask", mask)

    return run


def _border_tile(z: int, size: int = 256):
    """The XYZ tile at zoom ``z`` of the first vertex of Mexico's longest ring."""
    ring = max(mexico().rings, key=len)
    lon, lat = gloffset.sphere.xyz_to_lonlat(ring[:1])
    t = mercantile.tile(float(lon[0]), float(lat[0]), z)
    return Tile(t.z, t.x, t.y, size)


case("render/tile_5_7_14_127km", ("gl",))(_tile_output(mexico, 127e3, lambda: Tile(5, 7, 14)))
case("render/tile_z14_border_512px_500m", ("gl",))(
    _tile_output(mexico, 500.0, lambda: _border_tile(14, 512))
)
case("render/tile_z8_border_-20km", ("gl",))(_tile_output(mexico, -20e3, lambda: _border_tile(8)))
case("render/tile_z3_fiji_antimeridian_300km", ("gl",))(
    _tile_output(lambda: countries(("Fiji",)), 300e3, lambda: Tile(3, 7, 4))
)


# --- tiles.py: pyramids into MBTiles and directories
def read_tiles(out: Path) -> tuple[list, dict]:
    """[((z, x, y), png bytes)] in sorted XYZ order, and the metadata."""
    if out.suffix == ".mbtiles":
        db = sqlite3.connect(out)
        try:
            tiles = [
                ((z, x, (1 << z) - 1 - r), bytes(data))
                for z, x, r, data in db.execute(
                    "SELECT zoom_level, tile_column, tile_row, tile_data FROM tiles"
                )
            ]
            meta = dict(db.execute("SELECT name, value FROM metadata"))
        finally:
            db.close()
    else:
        tiles = [
            (tuple(int(v) for v in (p.parent.parent.name, p.parent.name, p.stem)), p.read_bytes())
            for p in out.glob("*/*/*.png")
        ]
        meta = json.loads((out / "metadata.json").read_text())
    meta = {k: str(v).replace(gloffset.__version__, "<version>") for k, v in meta.items()}
    return sorted(tiles), meta


def _pyramid(shape_fn, d, zooms, suffix, **kw):
    def run():
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / f"pyramid{suffix}"
            gloffset.tiles.pyramid(shape_fn(), d, zooms, out, radius=1.0, name="golden", **kw)
            tiles, meta = read_tiles(out)
        parts = [("metadata", meta)]
        parts += [("tile {}/{}/{}".format(*zxy), data) for zxy, data in tiles]
        per_zoom: dict[str, int] = {}
        for (z, _, _), _ in tiles:
            per_zoom[str(z)] = per_zoom.get(str(z), 0) + 1
        summary = {
            "tiles_per_zoom": per_zoom,
            "distinct_images": len({data for _, data in tiles}),
        }
        return parts, summary

    return run


case("tiles/mexico_z0-6_256_mbtiles", ("gl", "png"))(_pyramid(mexico, D, (0, 6), ".mbtiles"))
case("tiles/mexico_z0-6_256_outline_mbtiles", ("gl", "png"))(
    _pyramid(mexico, D, (0, 6), ".mbtiles", outline=OUTLINE)
)
case("tiles/mexico_z0-7_64_d-0.02_dir", ("gl", "png"))(
    _pyramid(mexico, -D, (0, 7), "", size=64, fill="#c03030", opacity=0.6)
)
case("tiles/seam_countries_z0-5_64_dir", ("gl", "png"))(
    _pyramid(lambda: countries(SEAM_COUNTRIES), D, (0, 5), "", size=64)
)
case("tiles/seam_lines_z0-4_128_outline_mbtiles", ("gl", "png"))(
    _pyramid(seam_lines, 0.01, (0, 4), ".mbtiles", size=128, outline=OUTLINE, outline_width=2)
)
case("tiles/mexico_z0-12_256_mbtiles", ("gl", "png"), slow=True)(
    _pyramid(mexico, D, (0, 12), ".mbtiles")
)
case("tiles/mexico_z0-12_256_outline_mbtiles", ("gl", "png"), slow=True)(
    _pyramid(mexico, D, (0, 12), ".mbtiles", outline=OUTLINE)
)


# --- raster_input.py: rasterized curves and their offsets
def _rasterize(which, size):
    def run():
        mask, order = rasterized(which, size)
        parts = [("mask", mask)] + [(f"part {k}", p) for k, p in enumerate(order)]
        return parts, {"curve_pixels": int(mask.sum()), "parts": len(order)}

    return run


def _raster_offset(which, size, d_km, *, levels=False, **kw):
    """The classes of the output level (and with ``levels`` those of every level
    handed to ``callback``, coarse first)."""

    def run():
        mask, order = rasterized(which, size)
        grid = Equirect(*size) if which == "mexico" else Cube(size)
        seen = []
        cls = gloffset.raster_offset(
            mask,
            d_km * 1e3,
            grid,
            order=order,
            callback=(lambda lev, c: seen.append((lev, c.copy()))) if levels else None,
            **kw,
        )
        parts, summary = array_output("classes", cls)
        if levels:
            parts += [(f"level {lev} classes", c) for lev, c in seen]
            summary["frontier_per_level"] = [int(np.count_nonzero(c == 1)) for _, c in seen]
        return parts, summary

    return run


for _size, _slow in (((1024, 512), False), ((4096, 2048), True)):
    _tag = "{}x{}".format(*_size)
    case(f"raster_input/rasterize_mexico_{_tag}", slow=_slow)(_rasterize("mexico", _size))
    for _km in (50.0, 127.0, 250.0):
        case(f"raster_input/mexico_{_tag}_{_km:g}km", ("gl",), _slow)(
            _raster_offset("mexico", _size, _km)
        )
    case(f"raster_input/mexico_{_tag}_127km_cpu", slow=_slow)(
        _raster_offset("mexico", _size, 127.0, backend="cpu")
    )
    case(f"raster_input/mexico_{_tag}_127km_cpu_single", slow=_slow)(
        _raster_offset("mexico", _size, 127.0, backend="cpu", mode="single")
    )
for _n, _slow in ((128, False), (1024, True)):
    case(f"raster_input/rasterize_world_borders_cube_6x{_n}", slow=_slow)(_rasterize("cube", _n))
    for _km in (50.0, 127.0, 250.0):
        case(f"raster_input/world_borders_cube_6x{_n}_{_km:g}km_levels", ("gl",), _slow)(
            _raster_offset("cube", _n, _km, levels=True)
        )
case("raster_input/world_borders_cube_6x128_250km_cpu")(
    _raster_offset("cube", 128, 250.0, backend="cpu")
)


# --- vector.py and selfintersect.py: raw and resolved offsets, GeoJSON
def _offset_raw(shape_fn, d):
    def run():
        off = gloffset.offset(shape_fn(), d, radius=1.0)
        feat = off.to_geojson(raw=True)
        parts = arc_ring_parts("ring ", off.rings)
        parts += [(f"sample {k}", r) for k, r in enumerate(off.sample())]
        parts.append(("geojson", feat))
        summary = {
            "rings": len(off.rings),
            "arcs": int(sum(len(q) for q in off.centers)),
            "geojson_points": geojson_points(feat["geometry"]),
        }
        return parts, summary

    return run


def _resolved(shape_fn, d, method="general"):
    def run():
        res = gloffset.offset(shape_fn(), d, radius=1.0).resolve(method)
        feat = res.to_geojson()
        parts = arc_ring_parts("ring ", res.rings)
        parts += [
            ("holes", np.asarray(res.holes)),
            ("polygons", [[int(i), [int(h) for h in hs]] for i, hs in res.polygons]),
            ("unlinked", int(res.unlinked)),
            ("area", np.float64(res.area()).reshape(1)),
            ("geojson", feat),
        ]
        summary = {
            "rings": len(res.rings),
            "holes": int(np.count_nonzero(res.holes)),
            "arcs": int(sum(len(q) for q in res.centers)),
            "geojson_points": geojson_points(feat["geometry"]),
        }
        return parts, summary

    return run


case("vector/mexico_raw_offset_d+0.02")(_offset_raw(mexico, D))
case("vector/seam_lines_raw_offset_d+0.01")(_offset_raw(seam_lines, 0.01))
for _d in (0.02, 0.005, -0.005, 0.001):
    case(f"selfintersect/mexico_d{sd(_d)}")(_resolved(mexico, _d))
case("selfintersect/mexico_d+0.02_paper")(_resolved(mexico, D, "paper"))
for _d in (0.005, -0.005, 0.001):
    case(f"selfintersect/mexico_d{sd(_d)}_paper", slow=True)(_resolved(mexico, _d, "paper"))
for _d in (0.02, -0.005):
    case(f"selfintersect/coastline_70k_d{sd(_d)}")(_resolved(coastline, _d))
for _d in (0.005, 0.001):
    case(f"selfintersect/coastline_70k_d{sd(_d)}", slow=True)(_resolved(coastline, _d))
# Fiji's islands are narrower than 2 x 0.02 rad: inward, 0.005 rad leaves some of them
for _name, _inward in (
    ("Russia", -D),
    ("Fiji", -0.005),
    ("Antarctica", -D),
    ("Canada", -D),
    ("Indonesia", -D),
    ("Chile", -D),
):
    for _d in (D, _inward):
        case(f"selfintersect/{_name.lower()}_110m_d{sd(_d)}")(
            _resolved(lambda _name=_name: countries((_name,)), _d)
        )
case("selfintersect/seam_lines_d+0.01")(_resolved(seam_lines, 0.01))


# --- table1.py: inside answers on Table 1's points, at 0..5 decompositions
def _table1(n: int, levels, n_distance: int):
    """``gloffset.index.contains`` and the index at some decompositions on ``n`` points, and
    the distances of the first ``n_distance`` (brute force: slow)."""

    def run():
        lon, lat = table1_points(n)
        shape = mexico()
        parts, summary = [], {}
        for name, d in (("curve", 0.0), ("offset", D), ("inward", -D)):
            got = gloffset.contains(shape, lon, lat, distance=d, radius=1.0)
            parts.append((f"contains {name}", got))
            summary[name] = int(np.count_nonzero(got))
            for level in levels:
                ix = gloffset.Index(shape, d, radius=1.0, level=level)
                parts.append((f"Index level {level} {name}", ix.contains(lon, lat)))
        dist = gloffset.distance(shape, lon[:n_distance], lat[:n_distance], radius=1.0)
        parts.append(("distance", dist))
        return parts, summary

    return run


case("contains/table1_10000")(_table1(10_000, (0, 3, 5), 1000))
case("contains/table1_1000000", slow=True)(_table1(1_000_000, range(6), 10_000))


def _contains_world(n: int):
    def run():
        lon, lat = sphere_points(n)
        shape = countries(tuple(world_features()))
        parts, summary = [], {}
        for d in (D, 0.0, -D):
            got = gloffset.contains(shape, lon, lat, distance=d, radius=1.0)
            parts.append((f"contains {d:+g}", got))
            summary[f"{d:+g}"] = int(np.count_nonzero(got))
        parts.append(("distance", gloffset.distance(shape, lon[:1000], lat[:1000], radius=1.0)))
        lines = gloffset.contains(borders_as_lines(), lon, lat, distance=D, radius=1.0)
        parts.append(("lines contains +0.02", lines))
        summary["lines +0.02"] = int(np.count_nonzero(lines))
        return parts, summary

    return run


case("contains/world_110m_sphere_10000")(_contains_world(10_000))


# --- union.py: the region of neighbouring 10m countries
@functools.cache
def countries_10m() -> list:
    return json.loads((DATA / "countries_10m.geojson").read_text())["features"]


def _union(which):
    """The union's rings (float64 unit vectors), their seams, groups and holes
    (benchmarks/union.py's cases)."""

    def run():
        feats = countries_10m()
        if which == "europe":
            feats = [f for f in feats if _bench_common().in_box(f, (-25, 34, 45, 72))]
        elif which != "all":
            by_name = {f["properties"]["name"]: f for f in feats}
            feats = [by_name[n] for n in which]
        shape = gloffset.read({"type": "FeatureCollection", "features": feats})
        parts = []
        for k, (r, s) in enumerate(zip(shape.rings, shape.ring_seams)):
            parts += [(f"ring {k}", r), (f"seams {k}", s)]
        parts += [("groups", shape.ring_groups), ("holes", shape.ring_holes)]
        summary = {
            "features": len(feats),
            "rings": len(shape.rings),
            "holes": int(np.count_nonzero(shape.ring_holes)),
            "vertices": int(shape.n_vertices),
        }
        return parts, summary

    return run


case("union/france_spain_andorra_10m")(_union(("France", "Spain", "Andorra")))
case("union/europe_10m")(_union("europe"))
case("union/planet_10m", slow=True)(_union("all"))


# ----------------------------------------------------------------------------- platform
def _simd() -> list:
    """The CPU features numpy dispatches to here (its float results depend on them)."""
    try:
        from numpy._core import _multiarray_umath as mu
    except ImportError:  # numpy < 2
        from numpy.core import _multiarray_umath as mu
    return sorted(f for f in mu.__cpu_dispatch__ if mu.__cpu_features__.get(f))


def _blas() -> str:
    try:
        cfg = np.show_config(mode="dicts")["Build Dependencies"]["blas"]
        return f"{cfg.get('name')} {cfg.get('version')}"
    except Exception:  # older numpy: no dict mode
        return "unknown"


@functools.cache
def platform_info(gl: bool = True) -> dict:
    """What the hashes depend on, here (see the module notes)."""
    import PIL
    from PIL import features

    info = {
        "numpy": np.__version__,
        "numpy_simd": _simd(),
        "blas": _blas(),
        "python": platform.python_version(),
        "libc": " ".join(platform.libc_ver()),
        "machine": platform.machine(),
        "pillow": PIL.__version__,
        "zlib": features.version("zlib"),
    }
    if gl:
        import moderngl

        from gloffset.gl import context_info

        ctx = context_info()
        info |= {
            "gl_renderer": ctx["renderer"],
            "gl_version": ctx["version"],
            "moderngl": moderngl.__version__,
        }
    return info


def _major_minor(v: str) -> str:
    return ".".join(str(v).split(".")[:2])


def platform_mismatch(case_: Case, recorded: dict) -> str | None:
    """Why the recorded hashes do not apply here for ``case_`` (None when they do)."""
    here = platform_info(gl="gl" in case_.needs)
    checks = [
        ("numpy major.minor", _major_minor(recorded.get("numpy")), _major_minor(here["numpy"])),
        ("numpy's CPU dispatch features", recorded.get("numpy_simd"), here["numpy_simd"]),
    ]
    if "gl" in case_.needs:
        checks += [
            ("GL renderer", recorded.get("gl_renderer"), here["gl_renderer"]),
            ("GL version (Mesa)", recorded.get("gl_version"), here["gl_version"]),
        ]
    if "png" in case_.needs:
        checks += [
            (
                "Pillow major.minor",
                _major_minor(recorded.get("pillow")),
                _major_minor(here["pillow"]),
            ),
            ("zlib", recorded.get("zlib"), here["zlib"]),
        ]
    diffs = [f"{what} {want!r} recorded, {got!r} here" for what, want, got in checks if want != got]
    if diffs:
        return (
            "golden hashes were recorded on another platform ("
            + "; ".join(diffs)
            + "); regenerate them here with python tests/test_golden.py --update to compare"
        )
    return None


# ----------------------------------------------------------------------------- the tests
def compute(case_: Case) -> dict:
    parts, summary = case_.run()
    return {"sha256": digest(parts), "summary": summary}


def golden_files() -> list[Path]:
    """``hashes.json`` and one ``hashes-<platform>.json`` per further platform."""
    return sorted(GOLDEN.parent.glob("hashes*.json"))


def load_golden(path: Path = GOLDEN) -> dict:
    return json.loads(path.read_text())


def applicable(case_: Case, docs: list[dict]) -> tuple[dict | None, str | None]:
    """The first recorded file whose platform fits ``case_`` here, or None and why not."""
    why = None
    for doc in docs:
        w = platform_mismatch(case_, doc["platform"])
        if w is None:
            return doc, None
        why = why or w
    return None, why


@pytest.fixture(scope="module")
def golden():
    if not GOLDEN.exists():
        pytest.fail(f"{GOLDEN} is missing; write it with python tests/test_golden.py --update")
    return [load_golden(p) for p in golden_files()]


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, id=n, marks=[pytest.mark.slow] if c.slow else []) for n, c in CASES.items()],
)
def test_golden(name, golden):
    case_ = CASES[name]
    doc, why = applicable(case_, golden)
    if why:
        pytest.skip(why)
    want = doc["cases"].get(name)
    if want is None:
        pytest.fail(
            f"no golden hash recorded for case {name!r}; "
            f"record it with python tests/test_golden.py --update {name!r}"
        )
    got = compute(case_)
    was, now = (json.dumps(r["summary"], sort_keys=True) for r in (want, got))
    assert got["sha256"] == want["sha256"], (
        f"golden output changed: case {name!r}\n"
        f"  recorded sha256 {want['sha256']}, summary {was}\n"
        f"  now      sha256 {got['sha256']}, summary {now}\n"
        f"If the change is intended, regenerate with python tests/test_golden.py --update {name!r}"
    )


def test_golden_file_names_only_known_cases(golden):
    stale = sorted({n for doc in golden for n in doc["cases"]} - set(CASES))
    assert not stale, (
        f"hashes.json records cases that no longer exist: {stale}; "
        "regenerate it with python tests/test_golden.py --update"
    )


def test_platform_mismatch_skips_only_the_cases_that_depend_on_it():
    here = platform_info(gl=True)
    vector, raster, tiles = (
        CASES[n]
        for n in (
            "selfintersect/mexico_d+0.02",
            "render/cube_6x128_d+0.02",
            "tiles/mexico_z0-6_256_mbtiles",
        )
    )
    for c in (vector, raster, tiles):
        assert platform_mismatch(c, here) is None
    patch = here["numpy"].split(".")
    assert platform_mismatch(vector, here | {"numpy": ".".join(patch[:2] + ["999"])}) is None
    older = here | {"numpy": "1.26.4"}
    assert all("numpy major.minor" in platform_mismatch(c, older) for c in (vector, raster, tiles))
    mesa = here | {"gl_version": "4.5 (Core Profile) Mesa 0.0.1"}
    assert platform_mismatch(vector, mesa) is None
    assert "GL version (Mesa)" in platform_mismatch(raster, mesa)
    gpu = here | {"gl_renderer": "NVIDIA H100"}
    assert "'NVIDIA H100' recorded" in platform_mismatch(tiles, gpu)
    zlib = here | {"zlib": "0.9"}
    assert platform_mismatch(raster, zlib) is None
    assert "zlib" in platform_mismatch(tiles, zlib)


def test_digest_sees_dtype_shape_and_labels():
    a = np.arange(6, dtype=np.int32)
    base = digest([("a", a)])
    assert base == digest([("a", a.copy())])
    assert base != digest([("a", a.astype(np.int64))])
    assert base != digest([("a", a.reshape(2, 3))])
    assert base != digest([("b", a)])
    assert digest([("j", {"b": 1, "a": [1.5]})]) == digest([("j", {"a": [1.5], "b": 1})])
    assert digest([("x", b"ab"), ("y", b"c")]) != digest([("x", b"a"), ("y", b"bc")])


# ----------------------------------------------------------------------------- --update
def dump_golden(doc: dict) -> str:
    """The file's text: the platform, then one line per case (a changed output is a
    one-line diff)."""
    lines = [f"  {json.dumps(n)}: {json.dumps(v, sort_keys=True)}" for n, v in doc["cases"].items()]
    platform_ = json.dumps(doc["platform"], indent=2, sort_keys=True).replace("\n", "\n ")
    return '{\n "platform": ' + platform_ + ',\n "cases": {\n' + ",\n".join(lines) + "\n }\n}\n"


def target_file(here: dict) -> Path:
    """The file to write on this platform: the one recorded on a platform that every case
    accepts here, else ``hashes.json`` when there is none yet, else a new
    ``hashes-<numpy CPU features>-<hash of the platform>.json``."""
    every = Case(name="", run=None, needs=("gl", "png"), slow=False)
    for path in golden_files():
        if platform_mismatch(every, load_golden(path)["platform"]) is None:
            return path
    if not GOLDEN.exists():
        return GOLDEN
    tag = hashlib.sha256(json.dumps(here, sort_keys=True).encode()).hexdigest()[:8]
    return GOLDEN.parent / f"hashes-{'-'.join(here['numpy_simd']).lower()}-{tag}.json"


def update(patterns: list[str], *, verbose: bool = True) -> dict:
    """Recompute the cases matching ``patterns`` (all when empty) and rewrite the file.

    Cases left out keep their hashes, which is allowed only on the platform they were
    recorded on."""
    names = [n for n in CASES if not patterns or any(fnmatch.fnmatch(n, p) for p in patterns)]
    if not names:
        raise SystemExit(f"no case matches {patterns}; see --list")
    here = platform_info(gl=True)
    path = target_file(here)
    old = load_golden(path) if path.exists() else {"platform": here, "cases": {}}
    kept = {n: v for n, v in old["cases"].items() if n in CASES and n not in names}
    if kept and old["platform"] != here:
        raise SystemExit(
            "the recorded platform differs from this one; regenerate every case "
            "(python tests/test_golden.py --update, no pattern)"
        )
    cases = dict(kept)
    total = time.perf_counter()
    for n in names:
        t = time.perf_counter()
        cases[n] = compute(CASES[n])
        if verbose:
            mark = (
                "" if old["cases"].get(n, {}).get("sha256") == cases[n]["sha256"] else "  changed"
            )
            print(f"{time.perf_counter() - t:7.2f} s  {n}{mark}", flush=True)
    doc = {"platform": here, "cases": {n: cases[n] for n in sorted(cases)}}
    path.parent.mkdir(exist_ok=True)
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(dump_golden(doc))
    tmp.replace(path)
    if verbose:
        print(f"wrote {path} ({len(names)} cases in {time.perf_counter() - total:.1f} s)")
    return doc


def main(argv=None):
    ap = argparse.ArgumentParser(description="Golden output hashes of the benchmark cases.")
    ap.add_argument("--update", action="store_true", help="recompute and rewrite hashes.json")
    ap.add_argument("--list", action="store_true", help="print the case names")
    ap.add_argument("patterns", nargs="*", help="only the cases matching these (fnmatch)")
    args = ap.parse_args(argv)
    if args.list:
        for n, c in CASES.items():
            print(n + ("  (slow)" if c.slow else ""))
    elif args.update:
        update(args.patterns)
    else:
        ap.print_help()


if __name__ == "__main__":
    main(sys.argv[1:])
