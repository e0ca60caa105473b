"""Golden outputs: every benchmark case, computed at a small size and compared with what
is recorded in ``tests/golden/golden.json``, one file for every platform.

A change of the engine that should not change any output (a refactor) must leave every
case as it is. The cases follow ``benchmarks/`` (render.py, tiles.py, raster_input.py,
selfintersect.py, table1.py, vector.py, union.py): Mexico 10m at 0.02 rad on the globe and
in the Mexico box, the world's borders on a cube map, tile pyramids, resolved offsets,
Table 1's points, the union of neighbouring countries. Distances > 0 and < 0 and lines are
covered, and every grid kind: ``Equirect`` global and regional across the antimeridian,
``Cube``, ``CubeFace``, ``Tile``.

What is compared, and how:

- Discrete outputs exactly (a sha256 of each, its dtype and shape included): masks and
  classes (the arrays), tiles (each tile's decoded RGBA pixels with its z/x/y, so neither
  zlib nor the PNG writer matters, and the metadata), the inside answers of ``contains``,
  arc kinds, ring lengths, seams, groups, holes, polygons, and the structure of every
  GeoJSON document (its types, properties, numbers of polygons, rings and vertices). Masks
  are decided by exact float64 predicates (the GPU's float32-undecidable cells are settled
  in float64), so they do not depend on numpy's SIMD kernels: measured identical with numpy
  dispatching to AVX512_ICL/X86_V4, to X86_V3 only and to its baseline only, and the GL
  masks equal the CPU backend's (the ``_cpu`` cases).
- Float64 outputs within a tolerance: the offsets' centres, junctions, source points and
  densified points (unit vectors), areas, distances and the union's rings within
  ``TOLERANCE["rad"]`` = 1e-12 (radians, steradians, unit-vector components), GeoJSON
  coordinates within ``TOLERANCE["deg"]`` = 1e-10 degrees (1.7e-12 rad). The offsets'
  contract is 1e-12 rad (``ResolvedOffset``: every point at ``|d|`` to 1e-12 rad; raw
  arcs exact to ~1e-15; areas ~1e-13): a platform may move a value within what the
  contract allows, and a regression moves it by more. Measured between numpy's SIMD
  paths: at most 2.8e-16 for unit vectors, 1.4e-14 sr for areas, 4.6e-14
  deg for coordinates. Near-tangent circles place an intersection less accurately along
  the circles (``smallcircle.py``: up to ``sqrt(1e-15 r)``), and whether they meet at
  all can turn on the last bit of a radius: ``selfintersect/seam_lines_d+0.01`` (lines
  on both sides of the antimeridian) resolves to 13 rings with numpy 2.x and to 12 with
  numpy 1.26, whose ``arctan2`` puts 26 of the circles' radii 1 ulp apart (Kaliningrad's
  ring is lost); the file records numpy 2's.

Floats are stored compactly: the sha256 of the values rounded to multiples of
``QUANTUM`` (2^-30 rad, 2^-25 deg), and, in full, the few values that lie within the
tolerance of a rounding boundary (0.2 % and 0.7 % of them). A value within the tolerance
of the recorded one rounds the same way or is one of those compared in full, so the case
passes; a value moved by more than the quantum (9.3e-10 rad, 3.0e-8 deg = 5.2e-10 rad)
always changes the rounded values, so the case fails; a move in between fails when it
crosses a rounding boundary. A GeoJSON vertex within the tolerance of the one before it is
the same vertex (the writer drops exact repeats only, which numpy's kernels can make or
not: ``selfintersect/mexico_d+0.005_paper`` has two vertices 1 ulp apart with AVX-512
and equal with X86_V3).

Run::

    python -m pytest -q tests/test_golden.py            # the small sizes (tens of seconds)
    python -m pytest -q -m slow tests/test_golden.py    # the benchmarks' full sizes

A failure names the case and what changed in it (which exact part, which float values,
beyond which tolerance), with the recorded and the current summary (pixel counts, rings,
tiles) to show what moved.

Regenerate the golden file deliberately, after a change that is meant to change outputs::

    python tests/test_golden.py --update                # every case, slow ones included
    python tests/test_golden.py --update 'render/*'     # only the cases matching a pattern
    python tests/test_golden.py --list                  # the case names

(with gloffset importable, e.g. ``PYTHONPATH=.``). ``--update`` rewrites
``tests/golden/golden.json`` (one line per case); review its diff like any other change.
"""

from __future__ import annotations

import argparse
import base64
import fnmatch
import functools
import hashlib
import io
import json
import sqlite3
import sys
import tempfile
import time
import zlib
from dataclasses import dataclass
from pathlib import Path

import mercantile
import numpy as np
import pytest
from PIL import Image

import gloffset
from gloffset.grids import Cube, CubeFace, Equirect, Tile

HERE = Path(__file__).resolve().parent
DATA = HERE.parent / "data"
GOLDEN = HERE / "golden" / "golden.json"

D = 0.02  # rad, the benchmarks' distance (127 km)
MEXICO_BOX = (-118.5, 14.5, -86.7, 32.8)  # benchmarks/render.py
TABLE1_BOX = (-120.0, 12.0, -84.0, 35.0)  # benchmarks/table1.py
ANTIMERIDIAN_BOX = (140.0, -90.0, -130.0, 85.0)  # W > E: across 180 deg, down to the pole
SEAM_COUNTRIES = ("Russia", "Fiji", "United States of America", "Antarctica")
OUTLINE = "#202020"  # benchmarks/tiles.py

#: How far a float output may move from the recorded value, by unit: "rad" for radians,
#: steradians and unit-vector components, "deg" for GeoJSON coordinates (module notes).
TOLERANCE = {"rad": 1e-12, "deg": 1e-10}
#: The rounding step of the recorded hash (a power of two: the scaling is exact); any move
#: beyond it fails.
QUANTUM = {"rad": 2.0**-30, "deg": 2.0**-25}


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


# ----------------------------------------------------------------------------- recording
@dataclass(frozen=True)
class Floats:
    """Float64 output compared within ``TOLERANCE[unit]`` (a bare float array is "rad")."""

    values: np.ndarray
    unit: str = "rad"


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


def concat(arrays, tail: tuple, dtype) -> np.ndarray:
    """The arrays one after the other (shape ``(0, *tail)`` when there are none)."""
    arrays = [np.asarray(a, dtype=dtype).reshape(-1, *tail) for a in arrays]
    return np.concatenate(arrays) if arrays else np.zeros((0, *tail), dtype)


def arc_ring_parts(rings) -> list:
    """Rings of small-circle arcs (OffsetRing): their lengths and the arcs' kinds exactly,
    centres, junctions and source points (unit vectors) within the tolerance."""
    return [
        ("ring lengths", np.array([len(r.centers) for r in rings], dtype=np.int64)),
        ("kind", concat([r.kind for r in rings], (), np.int8)),
        ("centers", concat([r.centers for r in rings], (3,), np.float64)),
        ("junctions", concat([r.junctions for r in rings], (3,), np.float64)),
        ("sources", concat([r.sources for r in rings], (2, 3), np.float64)),
    ]


def point_rings_parts(label: str, rings) -> list:
    """Rings of points (unit vectors): their lengths exactly, the points within the
    tolerance."""
    return [
        (f"{label} lengths", np.array([len(r) for r in rings], dtype=np.int64)),
        (label, concat(rings, (3,), np.float64)),
    ]


def is_position(x) -> bool:
    return (
        isinstance(x, list)
        and len(x) >= 2
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in x)
    )


def drop_repeats(coords, tol: float):
    """GeoJSON ``coordinates`` with every position within ``tol`` of the position before
    it dropped (a platform's rounding may make two vertices equal, which the writer drops,
    or 1 ulp apart)."""
    if isinstance(coords, list) and len(coords) > 1 and all(is_position(p) for p in coords):
        xy = np.asarray(coords, dtype=np.float64)
        keep = np.ones(len(xy), dtype=bool)
        keep[1:] = np.max(np.abs(np.diff(xy, axis=0)), axis=1) > tol
        return [p for p, k in zip(coords, keep) if k]
    if isinstance(coords, list):
        return [drop_repeats(c, tol) for c in coords]
    return coords


def json_floats(doc):
    """``doc`` with every float replaced by ``"<f>"``, and its floats in document order
    (keys sorted)."""
    floats: list[float] = []

    def walk(x):
        if isinstance(x, float):
            floats.append(x)
            return "<f>"
        if isinstance(x, dict):
            return {k: walk(x[k]) for k in sorted(x)}
        if isinstance(x, (list, tuple)):
            return [walk(v) for v in x]
        return x

    return walk(doc), floats


def geojson_parts(label: str, feature: dict) -> list:
    """A GeoJSON document: its structure exactly (types, properties, numbers of polygons,
    rings and vertices), its floats within ``TOLERANCE["deg"]``; a vertex within the
    tolerance of the one before it is the same vertex."""
    feature = dict(feature, geometry=dict(feature["geometry"]))
    geom = feature["geometry"]
    geom["coordinates"] = drop_repeats(geom["coordinates"], TOLERANCE["deg"])
    skeleton, floats = json_floats(feature)
    return [
        (f"{label} structure", skeleton),
        (f"{label} floats", Floats(np.asarray(floats, dtype=np.float64), "deg")),
    ]


def _scaled(values: np.ndarray, unit: str) -> np.ndarray:
    """The values in units of ``QUANTUM[unit]`` (exact: a power of two), flat."""
    x = np.asarray(values, dtype=np.float64).ravel()
    if not np.all(np.isfinite(x)):
        raise ValueError(f"golden floats must be finite, got {x[~np.isfinite(x)][:3]}")
    return x / QUANTUM[unit]


def _rounded_sha(scaled: np.ndarray, near: np.ndarray) -> str:
    """sha256 of the values rounded to the quantum, those near a boundary left out."""
    r = np.rint(scaled).astype("<i8")
    r[near] = 0
    return hashlib.sha256(r.tobytes()).hexdigest()[:32]


def _pack(index: np.ndarray, values: np.ndarray) -> str:
    """Indices (increasing) and float64 values: zlib, base64."""
    if not len(index):
        return ""
    steps = np.diff(index, prepend=0).astype("<u4")
    raw = steps.tobytes() + np.asarray(values, dtype="<f8").tobytes()
    return base64.b64encode(zlib.compress(raw, 9)).decode("ascii")


def _unpack(text: str) -> tuple[np.ndarray, np.ndarray]:
    if not text:
        return np.zeros(0, np.int64), np.zeros(0, np.float64)
    raw = zlib.decompress(base64.b64decode(text))
    n = len(raw) // 12
    index = np.cumsum(np.frombuffer(raw[: 4 * n], dtype="<u4").astype(np.int64))
    return index, np.frombuffer(raw[4 * n :], dtype="<f8")


def float_record(f: Floats) -> dict:
    """What is stored of a float output: its shape, the sha256 of its values rounded to
    ``QUANTUM``, and in full the values within ``TOLERANCE`` of a rounding boundary."""
    values = np.asarray(f.values)
    s = _scaled(values, f.unit)
    near = np.flatnonzero(np.abs(s - np.floor(s) - 0.5) <= TOLERANCE[f.unit] / QUANTUM[f.unit])
    return {
        "unit": f.unit,
        "shape": list(values.shape),
        "rounded_sha256": _rounded_sha(s, near),
        "near": _pack(near, values.ravel()[near]),
    }


def compare_floats(label: str, rec: dict, f: Floats) -> str | None:
    """Why ``f`` is not within the tolerance of the recorded values (None when it is)."""
    values = np.asarray(f.values)
    if f.unit != rec["unit"] or list(values.shape) != rec["shape"]:
        return (
            f"{label}: shape {list(values.shape)} ({f.unit}) where "
            f"{rec['shape']} ({rec['unit']}) was recorded"
        )
    tol = TOLERANCE[f.unit]
    flat = values.ravel()
    index, recorded = _unpack(rec["near"])
    dev = np.abs(flat[index] - recorded)
    bad = np.flatnonzero(~(dev <= tol))
    if len(bad):
        k = int(bad[0])
        at = tuple(int(i) for i in np.unravel_index(int(index[k]), values.shape))
        return (
            f"{label}{list(at)} is {flat[index[k]]!r} where {recorded[k]!r} was recorded: "
            f"moved by {dev[k]:.3g} {f.unit}, beyond the tolerance {tol:g} {f.unit}"
        )
    if _rounded_sha(_scaled(values, f.unit), index) != rec["rounded_sha256"]:
        return (
            f"{label}: values moved beyond the tolerance {tol:g} {f.unit} (rounded to "
            f"multiples of {QUANTUM[f.unit]:.3g} {f.unit} they differ from the recorded ones)"
        )
    return None


def as_floats(value) -> Floats | None:
    if isinstance(value, Floats):
        return value
    if isinstance(value, np.ndarray) and value.dtype.kind == "f":
        return Floats(value)
    return None


def record(parts) -> dict:
    """What is stored of a case's labelled outputs: a sha256 of each discrete one, a
    :func:`float_record` of each float one."""
    exact, floats = {}, {}
    for label, value in parts:
        if label in exact or label in floats:
            raise ValueError(f"duplicate golden part {label!r}")
        f = as_floats(value)
        if f is None:
            exact[label] = digest([(label, value)])[:32]
        else:
            floats[label] = float_record(f)
    return {"exact": exact, "floats": floats}


def compare(recorded: dict, parts) -> list[str]:
    """What differs between the recorded outputs and ``parts`` (empty when they agree)."""
    problems = []
    seen = set()
    for label, value in parts:
        seen.add(label)
        f = as_floats(value)
        if f is None:
            want = recorded["exact"].get(label)
            if want is None:
                problems.append(f"{label}: not recorded as a discrete output")
            elif digest([(label, value)])[:32] != want:
                problems.append(f"{label}: changed (compared exactly)")
        else:
            want = recorded["floats"].get(label)
            if want is None:
                problems.append(f"{label}: not recorded as a float output")
            elif why := compare_floats(label, want, f):
                problems.append(why)
    missing = sorted((set(recorded["exact"]) | set(recorded["floats"])) - seen)
    problems += [f"{label}: recorded but no longer produced" for label in missing]
    return problems


def geojson_points(geom: dict) -> int:
    """The number of positions of a geometry, repeats within the tolerance left out."""

    def count(c):
        return 1 if c and isinstance(c[0], (int, float)) else sum(count(x) for x in c)

    return count(drop_repeats(geom["coordinates"], TOLERANCE["deg"]))


# ----------------------------------------------------------------------------- cases
@dataclass(frozen=True)
class Case:
    """One case. ``run()`` returns (parts, summary): labelled outputs (see :func:`record`)
    and what the failure message shows of them."""

    name: str
    run: object
    slow: bool = False


CASES: dict[str, Case] = {}


def case(name: str, slow: bool = False):
    def register(fn):
        if name in CASES:
            raise ValueError(f"duplicate golden case {name!r}")
        CASES[name] = Case(name, fn, slow)
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
        case(f"render/globe_{_w}x{_h}_d{sd(_d)}", _slow)(_render(mexico, _d, Equirect(_w, _h)))
for _n, _slow in ((512, False), (2048, True)):
    for _d in (D, -D):
        case(f"render/mexico_box_{_n}x{_n}_d{sd(_d)}", _slow)(
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


case("render/globe_1024x512_d+0.02_levels")(_render_levels(mexico, D, Equirect(1024, 512)))
case("render/mexico_box_512x512_d-0.02_levels")(
    _render_levels(mexico, -D, Equirect(512, 512, MEXICO_BOX))
)

for _d in (D, -D):
    case(f"render/antimeridian_512x768_d{sd(_d)}")(
        _render(lambda: countries(SEAM_COUNTRIES), _d, Equirect(512, 768, ANTIMERIDIAN_BOX))
    )
case("render/world_lines_antimeridian_512x768_d+0.005")(
    _render(borders_as_lines, 0.005, Equirect(512, 768, ANTIMERIDIAN_BOX))
)
for _n, _slow in ((128, False), (1024, True), (2048, True)):
    case(f"render/cube_6x{_n}_d+0.02", _slow)(_render(mexico, D, Cube(_n)))
case("render/world_cube_6x128_d+0.02")(
    _render(lambda: countries(tuple(world_features())), D, Cube(128))
)
case("render/world_cube_6x128_d-0.02")(
    _render(lambda: countries(tuple(world_features())), -D, Cube(128))
)
case("render/world_lines_cube_6x128_d+0.01")(_render(borders_as_lines, 0.01, Cube(128)))
case("render/antarctica_cubeface_nz_256_d+0.02")(
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
    lon, lat = gloffset.geometry.sphere.xyz_to_lonlat(ring[:1])
    t = mercantile.tile(float(lon[0]), float(lat[0]), z)
    return Tile(t.z, t.x, t.y, size)


case("render/tile_5_7_14_127km")(_tile_output(mexico, 127e3, lambda: Tile(5, 7, 14)))
case("render/tile_z14_border_512px_500m")(
    _tile_output(mexico, 500.0, lambda: _border_tile(14, 512))
)
case("render/tile_z8_border_-20km")(_tile_output(mexico, -20e3, lambda: _border_tile(8)))
case("render/tile_z3_fiji_antimeridian_300km")(
    _tile_output(lambda: countries(("Fiji",)), 300e3, lambda: Tile(3, 7, 4))
)


# --- tiles.py: pyramids into MBTiles and directories
def decode_png(data: bytes) -> np.ndarray:
    """A PNG's pixels as RGBA (height, width, 4) uint8."""
    with Image.open(io.BytesIO(data)) as im:
        return np.asarray(im.convert("RGBA"))


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
        rgba: dict[bytes, str] = {}  # each distinct PNG decoded once: its pixels' sha256
        for _, data in tiles:
            if data not in rgba:
                rgba[data] = digest([("rgba", decode_png(data))])
        pixels = [("tile {}/{}/{}".format(*zxy), rgba[data]) for zxy, data in tiles]
        parts = [("metadata", meta), ("tiles", digest(pixels))]
        per_zoom: dict[str, int] = {}
        for (z, _, _), _ in tiles:
            per_zoom[str(z)] = per_zoom.get(str(z), 0) + 1
        summary = {"tiles_per_zoom": per_zoom, "distinct_images": len(set(rgba.values()))}
        return parts, summary

    return run


case(
    "tiles/mexico_z0-6_256_mbtiles",
)(_pyramid(mexico, D, (0, 6), ".mbtiles"))
case(
    "tiles/mexico_z0-6_256_outline_mbtiles",
)(_pyramid(mexico, D, (0, 6), ".mbtiles", outline=OUTLINE))
case(
    "tiles/mexico_z0-7_64_d-0.02_dir",
)(_pyramid(mexico, -D, (0, 7), "", size=64, fill="#c03030", opacity=0.6))
case(
    "tiles/seam_countries_z0-5_64_dir",
)(_pyramid(lambda: countries(SEAM_COUNTRIES), D, (0, 5), "", size=64))
case(
    "tiles/seam_lines_z0-4_128_outline_mbtiles",
)(_pyramid(seam_lines, 0.01, (0, 4), ".mbtiles", size=128, outline=OUTLINE, outline_width=2))
case("tiles/mexico_z0-12_256_mbtiles", slow=True)(_pyramid(mexico, D, (0, 12), ".mbtiles"))
case("tiles/mexico_z0-12_256_outline_mbtiles", slow=True)(
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
        case(f"raster_input/mexico_{_tag}_{_km:g}km", _slow)(_raster_offset("mexico", _size, _km))
    case(f"raster_input/mexico_{_tag}_127km_cpu", slow=_slow)(
        _raster_offset("mexico", _size, 127.0, backend="cpu")
    )
    case(f"raster_input/mexico_{_tag}_127km_cpu_single", slow=_slow)(
        _raster_offset("mexico", _size, 127.0, backend="cpu", mode="single")
    )
for _n, _slow in ((128, False), (1024, True)):
    case(f"raster_input/rasterize_world_borders_cube_6x{_n}", slow=_slow)(_rasterize("cube", _n))
    for _km in (50.0, 127.0, 250.0):
        case(f"raster_input/world_borders_cube_6x{_n}_{_km:g}km_levels", _slow)(
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
        parts = arc_ring_parts(off.rings) + point_rings_parts("samples", off.sample())
        parts += geojson_parts("geojson", feat)
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
        parts = arc_ring_parts(res.rings)
        parts += [
            ("holes", np.asarray(res.holes)),
            ("polygons", [[int(i), [int(h) for h in hs]] for i, hs in res.polygons]),
            ("unlinked", int(res.unlinked)),
            ("area", np.float64(res.area()).reshape(1)),
        ]
        parts += geojson_parts("geojson", feat)
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
        if which == "world_110m":  # all 110m countries: the seams of Russia, Fiji, Antarctica
            feats = json.loads((DATA / "world_110m.geojson").read_text())["features"]
        elif which == "europe":
            feats = [f for f in feats if _bench_common().in_box(f, (-25, 34, 45, 72))]
        elif which not in ("all", "world_110m"):
            by_name = {f["properties"]["name"]: f for f in feats}
            feats = [by_name[n] for n in which]
        shape = gloffset.read({"type": "FeatureCollection", "features": feats})
        parts = point_rings_parts("rings", shape.rings)
        parts += [
            ("seams", concat(shape.ring_seams, (), bool)),
            ("groups", shape.ring_groups),
            ("holes", shape.ring_holes),
        ]
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
case("union/world_110m")(_union("world_110m"))
case("union/planet_10m", slow=True)(_union("all"))


# ----------------------------------------------------------------------------- the tests
def compute(case_: Case) -> tuple[list, dict]:
    return case_.run()


def load_golden(path: Path = GOLDEN) -> dict:
    return json.loads(path.read_text())


@pytest.fixture(scope="module")
def golden():
    if not GOLDEN.exists():
        pytest.fail(f"{GOLDEN} is missing; write it with python tests/test_golden.py --update")
    return load_golden()


def check(name: str, golden: dict, parts, summary) -> None:
    """Assert that ``parts`` agree with what ``golden`` records for case ``name``."""
    want = golden["cases"].get(name)
    if want is None:
        pytest.fail(
            f"nothing recorded for golden case {name!r}; "
            f"record it with python tests/test_golden.py --update {name!r}"
        )
    problems = compare(want, parts)
    was, now = (json.dumps(s, sort_keys=True) for s in (want["summary"], summary))
    assert not problems, (
        f"golden output changed: case {name!r}\n  "
        + "\n  ".join(problems)
        + f"\n  recorded summary {was}\n  now      summary {now}\n"
        f"If the change is intended, regenerate with python tests/test_golden.py --update {name!r}"
    )


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, id=n, marks=[pytest.mark.slow] if c.slow else []) for n, c in CASES.items()],
)
def test_golden(name, golden):
    check(name, golden, *compute(CASES[name]))


def test_golden_file_names_only_known_cases(golden):
    stale = sorted(set(golden["cases"]) - set(CASES))
    assert not stale, (
        f"golden.json records cases that no longer exist: {stale}; "
        "regenerate it with python tests/test_golden.py --update"
    )


def test_digest_sees_dtype_shape_and_labels():
    a = np.arange(6, dtype=np.int32)
    base = digest([("a", a)])
    assert base == digest([("a", a.copy())])
    assert base != digest([("a", a.astype(np.int64))])
    assert base != digest([("a", a.reshape(2, 3))])
    assert base != digest([("b", a)])
    assert digest([("j", {"b": 1, "a": [1.5]})]) == digest([("j", {"a": [1.5], "b": 1})])
    assert digest([("x", b"ab"), ("y", b"c")]) != digest([("x", b"a"), ("y", b"bc")])


@pytest.mark.parametrize("unit", ["rad", "deg"])
def test_floats_pass_within_the_tolerance_and_fail_beyond_the_quantum(unit):
    """Every value moved by up to the tolerance, either way, passes; one value moved by
    the quantum (or, where it lies near a rounding boundary, by twice the tolerance)
    fails."""
    rng = np.random.default_rng(1)
    scale = 1.0 if unit == "rad" else 180.0
    values = rng.uniform(-scale, scale, (4000, 3))
    tol, q = TOLERANCE[unit], QUANTUM[unit]
    # values right at a rounding boundary, and within the tolerance of one on either side
    values[:3, 0] = (np.floor(values[:3, 0] / q) + 0.5) * q + np.array([0.0, -0.9, 0.9]) * tol
    rec = json.loads(json.dumps(float_record(Floats(values, unit))))
    index, _ = _unpack(rec["near"])
    assert {0, 3, 6} <= set(index.tolist()) and len(index) < 0.01 * values.size
    for sign in (0.999, -0.999):
        assert compare_floats("x", rec, Floats(values + sign * tol, unit)) is None
        assert compare_floats("x", rec, Floats(values + sign * rng.uniform(0, tol), unit)) is None
    far = int(np.setdiff1d(np.arange(values.size), index)[0])
    for at, move in ((far, q), (far, -q), (int(index[0]), 2 * tol), (int(index[-1]), -2 * tol)):
        moved = values.copy()
        moved.flat[at] += move
        why = compare_floats("x", rec, Floats(moved, unit))
        assert why is not None and why.startswith("x"), (at, move)
    assert "shape" in compare_floats("x", rec, Floats(values[:-1], unit))
    assert "shape" in compare_floats("x", rec, Floats(values, "deg" if unit == "rad" else "rad"))


def _move_first(parts, label: str, move: float, at: int = 0) -> list:
    out = []
    for lab, value in parts:
        if lab == label:
            f = as_floats(value)
            moved = np.array(f.values, dtype=np.float64)
            moved.flat[min(at, moved.size - 1)] += move
            value = Floats(moved, f.unit)
        out.append((lab, value))
    return out


def test_perturbed_outputs_fail_against_the_golden_file(golden):
    """A real case's outputs, recorded in golden.json: within the tolerance they pass;
    one coordinate moved by 1e-9 rad beyond it, one GeoJSON coordinate moved by the
    equivalent in degrees, or one pixel flipped, fail."""
    name = "selfintersect/mexico_d+0.02"
    parts, summary = compute(CASES[name])
    check(name, golden, parts, summary)
    tol = TOLERANCE["rad"]
    check(name, golden, _move_first(parts, "junctions", 0.5 * tol, at=7), summary)
    beyond = 1e-9 + tol
    for label, move in (
        ("junctions", beyond),
        ("centers", -beyond),
        ("area", beyond),
        ("geojson floats", np.degrees(beyond)),
    ):
        with pytest.raises(AssertionError, match=f"{label}.*beyond the tolerance"):
            check(name, golden, _move_first(parts, label, move, at=7), summary)

    name = "render/tile_z8_border_-20km"
    parts, summary = compute(CASES[name])
    check(name, golden, parts, summary)
    mask = parts[0][1].copy()
    mask.flat[mask.size // 2] ^= True
    with pytest.raises(AssertionError, match="mask: changed"):
        check(name, golden, [("mask", mask)], summary)


def test_geojson_vertices_one_ulp_apart_are_one_vertex():
    """The writer drops exact repeats only: 1 ulp apart here, equal on another platform,
    both compare the same; a vertex moved beyond the tolerance does not."""
    ring = [[-108.55185977, 31.70697728], [-108.55183426, 31.69994941], [-108.5518, 31.692]]
    twin = [ring[0], ring[1], [np.nextafter(ring[1][0], 0.0), ring[1][1]], ring[2]]
    one, two = (
        {"type": "Feature", "geometry": {"type": "Polygon", "coordinates": [r + [r[0]]]}}
        for r in (ring, twin)
    )
    rec = record(geojson_parts("g", one))
    assert compare(rec, geojson_parts("g", two)) == []
    assert geojson_points(two["geometry"]) == geojson_points(one["geometry"]) == 4
    moved = [ring[0], ring[1], [ring[1][0] + 1e-8, ring[1][1]], ring[2]]
    far = {"type": "Feature", "geometry": {"type": "Polygon", "coordinates": [moved + [ring[0]]]}}
    assert compare(rec, geojson_parts("g", far))


# ----------------------------------------------------------------------------- --update
def dump_golden(doc: dict) -> str:
    """The file's text: the notes, then one line per case (a changed output is a
    one-line diff)."""
    lines = [f"  {json.dumps(n)}: {json.dumps(v, sort_keys=True)}" for n, v in doc["cases"].items()]
    notes = json.dumps(doc["notes"], sort_keys=True)
    return '{\n "notes": ' + notes + ',\n "cases": {\n' + ",\n".join(lines) + "\n }\n}\n"


def update(patterns: list[str], *, verbose: bool = True) -> dict:
    """Recompute the cases matching ``patterns`` (all when empty) and rewrite the file;
    the other cases keep what is recorded."""
    names = [n for n in CASES if not patterns or any(fnmatch.fnmatch(n, p) for p in patterns)]
    if not names:
        raise SystemExit(f"no case matches {patterns}; see --list")
    old = load_golden() if GOLDEN.exists() else {"cases": {}}
    cases = {n: v for n, v in old["cases"].items() if n in CASES and n not in names}
    total = time.perf_counter()
    for n in names:
        t = time.perf_counter()
        parts, summary = compute(CASES[n])
        was = old["cases"].get(n)
        cases[n] = record(parts) | {"summary": summary}
        if verbose:
            mark = "" if was is not None and not compare(was, parts) else "  changed"
            print(f"{time.perf_counter() - t:7.2f} s  {n}{mark}", flush=True)
    notes = {
        "tolerance": TOLERANCE,
        "quantum": QUANTUM,
        "about": "tests/test_golden.py's module notes; written by its --update",
    }
    doc = {"notes": notes, "cases": {n: cases[n] for n in sorted(cases)}}
    GOLDEN.parent.mkdir(exist_ok=True)
    tmp = GOLDEN.with_suffix(".json.tmp")
    tmp.write_text(dump_golden(doc))
    tmp.replace(GOLDEN)
    if verbose:
        print(f"wrote {GOLDEN} ({len(names)} cases in {time.perf_counter() - total:.1f} s)")
    return doc


def main(argv=None):
    ap = argparse.ArgumentParser(description="Golden outputs of the benchmark cases.")
    ap.add_argument("--update", action="store_true", help="recompute and rewrite golden.json")
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
