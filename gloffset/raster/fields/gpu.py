"""The GPU backend of :func:`gloffset.distance_field`: the unsigned distances, each
within :data:`~gloffset.gl.field_pass.FIELD_ERR` (relative) of the CPU walk's.

1. The float64 walk (:func:`~gloffset.raster.fields.walk.walk_levels`) stops at the level
   ``SHIFT`` above the output (cells of 8 x 8 pixels), its nodes split down to the
   original arcs: a cell's list holds every arc that can be the nearest (within
   ``max_distance``) of a point within the cell's ``rho``, so of each of its pixels.
2. ``shaders/field_pixels.comp`` (:mod:`gloffset.gl.field_pass`), per pixel, blocks of
   pixels at a time so that memory stays bounded: its centre in double on the GPU
   (lon/lat grids from the cosine and sine of their rows' latitudes and columns'
   longitudes, the host's products bit for bit; cube faces from their face
   coordinates; grids with a GLSL function of their centres from it; the others from
   the host's float64 centres); its cell's list ranked in float32 (each arc's nearest
   feature as a chord, good to ``NEAREST_ERR``): the six least features, how many lie
   within ``2 NEAREST_ERR`` of the least and whether more may; then those features
   (the cell's whole list where more may be) finished in double with the operations
   of :func:`~gloffset.geometry.sphere.arc_distance`, the least read back. A feature
   whose float32 chord exceeds the least by more than ``2 NEAREST_ERR`` has a true
   chord greater than the least one's (by more than the float64 error), so the
   nearest arc is among those finished.
3. With polygons, the sign from the features finished within ``ETA`` of the least.

The host hands over the lists and the arcs and reads back one float64 (and a sign
code) per pixel: no per-pixel work on the host but for pyproj's centres (a texture).
Accuracy: for the same centre, within ``FIELD_ERR`` relative of ``arc_distance`` (the
float32 field within 1 float32 ulp of the CPU's); the centres are the host's bit for
bit on lon/lat grids, within 3 ulp on cube faces, and on grids with a GLSL function
within that function's bound of the host's (pyproj's) centres. Pixels whose cell has
no arc (all beyond ``max_distance``) stay ``inf``, as on the CPU.
"""

from __future__ import annotations

import time
import warnings
import weakref

import numpy as np

from ...geometry.caps import chord, pad
from ...geometry.sphere import cross, dot
from ...gl.context import context_info, shared
from ...gl.field_pass import ARC_TEXELS, EXACT_DOUBLES, FieldPlan, field_pass
from ..vector.node_levels import NodeArcs
from . import dominance
from .lists import gpu_lists
from .sign import UNDECIDED, Corners
from .walk import exact_distances, walk_levels

__all__ = ["SHIFT", "gpu_distances"]

#: Levels between the cells of the lists and the output pixels (2^SHIFT pixels a side).
SHIFT = 3
#: Output pixels per side of a block run at once (a power of two).
_BLOCK = 1024

#: The float32 and float64 arc records of each node table (made once, kept while it lives).
_RECORDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _records(nodes: NodeArcs) -> tuple[np.ndarray, np.ndarray]:
    """Every node's arc as ``shaders/field_pixels.comp`` reads it: (nodes, 5, 4) float32
    for the ranking, (nodes, 16) float64 for the finishing (``(a, ok), (b, bn_x), (n,
    bn_y), (n x a, bn_z)`` with ``bn = b x n``: the values of
    :func:`~gloffset.geometry.sphere.arc_distance`, bit for bit)."""
    got = _RECORDS.get(nodes)
    if got is None:
        n = nodes.n
        na, bn = cross(n, nodes.a), cross(nodes.b, n)
        ok = dot(n, n) > 0.5
        rec = np.zeros((len(n), ARC_TEXELS, 4), dtype=np.float32)  # rounded as written
        rec[:, 0, :3], rec[:, 1, :3] = nodes.a, nodes.b
        rec[:, 2, :3], rec[:, 3, :3] = na, bn
        rec[:, :3, 3] = n
        rec[:, 3, 3] = ok
        rec[:, 4, :3] = nodes.mid
        rec[:, 4, 3] = pad(chord(np.minimum(nodes.half, np.pi)))
        ex = np.zeros((len(n), 4, 4))
        ex[:, 0, :3], ex[:, 1, :3], ex[:, 2, :3], ex[:, 3, :3] = nodes.a, nodes.b, n, na
        ex[:, 0, 3] = ok
        ex[:, 1:, 3] = bn
        got = _RECORDS[nodes] = (rec, ex.reshape(len(n), EXACT_DOUBLES))
    return got


#: Which walk makes the lists: ``"gpu"`` (:func:`~gloffset.raster.fields.lists.gpu_lists`,
#: the float64 walk where it does not apply), ``"cpu"`` (the float64 walk), or ``"auto"``:
#: the GPU's on a hardware GL whose GPU walk passes :func:`walk_check` (once per thread);
#: on Mesa's llvmpipe (the GL the tests run on, not checked) the GPU's where the lists'
#: level has at least :data:`SOFTWARE_CELLS` cells, else the float64 walk; the float64
#: walk on other software GLs and where the check fails.
WALK = "auto"

#: On llvmpipe, "auto" walks on the GPU from this many cells at the lists' level (the
#: 8 x 8-pixel cells): there many short lists run on its SIMD lanes at about twice the
#: float64 walk's speed (all of ``countries_10m`` at 4096 x 2048, 131,072 cells), while a
#: few cells with long lists (a 256 px tile's 1,024; the globe at 2048 x 1024) run
#: slower than numpy runs them (``benchmarks/field_walk.py``).
SOFTWARE_CELLS = 1 << 16


def _auto(grid, level: int) -> str:
    """The walk ``"auto"`` means for the lists of ``level`` of ``grid`` (see :data:`WALK`)."""
    info = context_info()
    if not info["software"]:
        return "gpu" if shared(_WalkCheck).ok else "cpu"
    h, w = grid.level_shape(level)
    llvmpipe = "llvmpipe" in str(info.get("renderer", ""))
    return "gpu" if llvmpipe and h * w >= SOFTWARE_CELLS else "cpu"


class _Lists:
    """The cells of one level and their lists, by cell (row-major): ``start``, ``count``
    (per cell) into ``node`` (the pairs' nodes). Walked as :data:`WALK` says (or as
    ``walk`` says)."""

    def __init__(self, nodes: NodeArcs, grid, m: float, level: int, walk: str | None = None):
        self.shape = hc, wc = grid.level_shape(level)
        walk = WALK if walk is None else walk
        if walk == "auto":
            walk = _auto(grid, level)
        #: each cell's distance to its nearest arc over its rho (None: not known)
        self.depth: np.ndarray | None = None
        got = gpu_lists(nodes, grid, m, level) if walk == "gpu" else None
        if got is not None:
            self.count, self.node = got
            self.start = np.cumsum(self.count) - self.count
            return
        keys, vals = [], []
        self.depth = np.full(hc * wc, np.inf)
        for f, dist in walk_levels(nodes, grid, m, level):
            flat = f.cells[:, 0].astype(np.int64) * wc + f.cells[:, 1]
            keep = _undominated(f, dist, nodes)
            keys.append(flat[f.pair_cell[keep]])
            vals.append(f.pair_arc[keep])
            self.depth[flat] = dist / f.rho
        key = np.concatenate(keys) if keys else np.zeros(0, np.int64)
        val = np.concatenate(vals) if vals else np.zeros(0, np.int64)
        self.node = val[_by_key(key)]
        self.count = np.bincount(key, minlength=hc * wc)
        self.start = np.cumsum(self.count) - self.count

    def block_depth(self, rows: range, cols: range) -> float | None:
        """The median depth of the cells ``rows x cols`` (:attr:`FieldPlan.depth`)."""
        if self.depth is None:
            return None
        d = self.depth.reshape(self.shape)[rows.start : rows.stop, cols.start : cols.stop]
        return float(np.median(d))

    def block(self, rows: range, cols: range):
        """The cells ``rows x cols``: their first pair and count in the block's own list,
        and that list's nodes, each cell's ascending (the field pass then reads the
        arcs' records in order: a quarter faster on llvmpipe than in the walk's order)."""
        jj, ii = np.meshgrid(np.asarray(rows), np.asarray(cols), indexing="ij")
        flat = (jj * self.shape[1] + ii).ravel()
        cnt, st = self.count[flat], self.start[flat]
        first = np.cumsum(cnt) - cnt
        at = np.repeat(st - first, cnt) + np.arange(int(cnt.sum()))
        return first, cnt, _ascending(cnt, self.node[at])


def _undominated(f, dist: np.ndarray, nodes: NodeArcs):
    """The pairs of ``f`` that :func:`~gloffset.raster.fields.dominance.undominated`
    keeps (all without :data:`~gloffset.raster.fields.dominance.DOMINANCE`)."""
    if not dominance.DOMINANCE:
        return slice(None)
    deep = dist >= dominance.DEEP * f.rho
    on = np.flatnonzero(deep[f.pair_cell])
    if len(on) == 0:
        return slice(None)
    cell, arc = f.pair_cell[on], f.pair_arc[on]
    keep = np.ones(len(f.pair_cell), dtype=bool)
    d = exact_distances(f.centers, cell, nodes, arc)
    keep[on] = dominance.undominated(f.centers, f.rho, cell, arc, nodes, d)
    return keep


def _ascending(count: np.ndarray, node: np.ndarray) -> np.ndarray:
    """``node`` (by cell, ``count`` a cell) with each cell's nodes ascending: one sort of
    ``cell << 32 | node``."""
    key = np.repeat(np.arange(len(count), dtype=np.int64) << 32, count)
    key |= node
    key.sort()
    key &= 0xFFFFFFFF
    return key


def _by_key(key: np.ndarray) -> np.ndarray:
    """Return ``np.argsort(key, kind="stable")``, sorting the runs of equal keys (the
    walk gives each block's pairs by cell: a run per cell) instead of the pairs."""
    n = len(key)
    if n == 0:
        return np.zeros(0, np.int64)
    starts = np.flatnonzero(np.concatenate([[True], key[1:] != key[:-1]]))
    lens = np.diff(np.append(starts, n))
    order = np.argsort(key[starts], kind="stable")
    starts, lens = starts[order], lens[order]
    first = np.cumsum(lens) - lens  # each run's place in the answer
    return np.repeat(starts - first, lens) + np.arange(n)


def gpu_distances(
    shape,
    grid,
    m: float,
    add,
    timings: dict | None = None,
    codes: np.ndarray | None = None,
    walk: str | None = None,
) -> np.ndarray:
    """Return the distance (rad, float64) from each pixel centre to the nearest arc.

    As :func:`gloffset.raster.field._distances` (the CPU walk), each value within
    :data:`~gloffset.gl.field_pass.FIELD_ERR` (relative) of its distance from the same
    centre (see the module notes): within ``m``, larger than ``m`` (or ``inf``)
    elsewhere. ``add(n)`` is called as the pixels are finished; ``timings`` (if given)
    gets the seconds of the stages added to its ``"walk"`` (to the lists' level),
    ``"plan"`` (the blocks' lists and arcs) and ``"gpu"`` (the pass: centres, ranking
    and finishing). The grid must have more than one level.

    ``codes`` (optional, (h, w) uint32 of the output pixels): filled with the sign rule's
    answer at each pixel from its nearest features, in the shader (0 outside, 1 inside,
    2 undecided; :mod:`gloffset.raster.fields.sign`'s rule in float32 with
    ``shaders/lib/field_sign.glsl``, the features within ``ETA`` of the least asked, a
    disc that may hold a seam undecided; all undecided where the shape's
    :class:`~gloffset.raster.fields.sign.Corners` are not trusted). Where it decides, it
    is the float64 levels' inside status at pixels farther than ``NEAR`` from the
    boundary and within ``m`` (the caller leaves the others undecided). ``walk``: the
    lists' walk (default :data:`WALK`).
    """
    t = {} if timings is None else timings
    for k in ("walk", "plan", "gpu"):
        t.setdefault(k, 0.0)
    nodes = NodeArcs.from_shape(shape)
    sign = None
    if codes is not None:
        corners = Corners.from_shape(shape)
        if not corners.trusted:
            codes[...] = UNDECIDED
        else:
            sign = (*corners.shader_records(len(nodes.a)), codes)
    last = grid.n_levels - 1
    shift = min(SHIFT, last)
    t0 = time.perf_counter()
    lists = _Lists(nodes, grid, m, last - shift, walk)
    t["walk"] += time.perf_counter() - t0
    h, w = grid.level_shape(last)
    out = np.empty((h, w))
    side = max(1, _BLOCK >> shift)  # cells per block side
    hc, wc = lists.shape
    for r0 in range(0, hc, side):
        for c0 in range(0, wc, side):
            rows, cols = range(r0, min(r0 + side, hc)), range(c0, min(c0 + side, wc))
            _block(nodes, grid, lists, (rows, cols, shift), out, t, sign)
            pj = min(h, rows.stop << shift) - (rows.start << shift)
            add(pj * (min(w, cols.stop << shift) - (cols.start << shift)))
    return out


def _block(nodes: NodeArcs, grid, lists: _Lists, where, out: np.ndarray, t: dict, sign=None):
    """Fill ``out`` at the pixels of the cells ``rows x cols`` (``where``, with the
    shift): their distances on the GPU (see the module notes); with ``sign`` (the
    nodes' flags, the seams' caps and the codes to fill), their sign codes too. A block
    over the GL limits is run in two halves of its rows."""
    rows, cols, shift = where
    eng = field_pass()
    t0 = time.perf_counter()
    first, cnt, node = lists.block(rows, cols)
    arcs, local = _compact(node, len(nodes.a))
    h, w = out.shape
    j0, j1 = rows.start << shift, min(h, rows.stop << shift)
    i0, i1 = cols.start << shift, min(w, cols.stop << shift)
    texture = grid.centres not in ("lonlat", "cube", "glsl")
    if len(rows) > 1 and not eng.fits(j1 - j0, i1 - i0, len(node), len(arcs), texture):
        half = rows.start + len(rows) // 2
        for part in (range(rows.start, half), range(half, rows.stop)):
            if len(part):
                _block(nodes, grid, lists, (part, cols, shift), out, t, sign)
        return
    rec, exact = _records(nodes)
    cells = np.stack([first, cnt], axis=-1).reshape(len(rows), len(cols), 2)
    plan = FieldPlan(
        (j1 - j0, i1 - i0),
        (j0, i0),
        shift,
        cells.astype(np.uint32),
        local,
        rec[arcs],
        _vertex_ids(nodes)[arcs],
        exact[arcs],
        **_centres(grid, range(j0, j1), range(i0, i1)),
    )
    plan.depth = lists.block_depth(rows, cols)
    if sign is not None:
        plan.flags, plan.seams = sign[0][arcs], sign[1]
    t1 = time.perf_counter()
    out[j0:j1, i0:i1] = eng.run(plan)
    if sign is not None:
        sign[2][j0:j1, i0:i1] = plan.codes
    t["plan"] += t1 - t0
    t["gpu"] += time.perf_counter() - t1


def _centres(grid, pj: range, pi: range) -> dict:
    """What the shader makes the centres of pixels ``pj x pi`` (the output level) from
    (:class:`~gloffset.gl.field_pass.FieldPlan`): one value per row and column on
    lon/lat grids and cube faces (``LonLatGrid.centers``' cosines and sines, bit for bit;
    ``face_points``' face coordinates), the grid's GLSL function, else every centre."""
    last = grid.n_levels - 1
    kind = grid.centres
    if kind == "lonlat":
        phi, lam = grid.cell_lat(last, np.asarray(pj)), grid.cell_lon(last, np.asarray(pi))
        return {
            "kind": kind,
            "rows": np.column_stack([np.cos(phi), np.sin(phi)]),
            "cols": np.column_stack([np.cos(lam), np.sin(lam)]),
        }
    if kind == "cube":
        size = int(grid.size)
        return {
            "kind": kind,
            "rows": 2.0 * (np.asarray(pj, dtype=np.float64) + 0.5) / size - 1.0,
            "cols": 2.0 * (np.asarray(pi, dtype=np.float64) + 0.5) / size - 1.0,
            "basis": np.asarray(grid.basis),
        }
    if kind == "glsl":
        g = grid.glsl_centres()
        return {"kind": kind, "rows": np.zeros(1), "source": g.source, "constants": g.constants}
    jj, ii = np.meshgrid(np.asarray(pj), np.asarray(pi), indexing="ij")
    return {"kind": "texture", "rows": grid.centers(last, jj.ravel(), ii.ravel())}


def _compact(node: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the distinct values of ``node`` (ids below ``n``), ascending, and each
    value's place among them (uint32): ``np.unique(node, return_inverse=True)``'s
    answer, by a mark per id instead of a sort."""
    mark = np.zeros(n, dtype=bool)
    mark[node] = True
    arcs = np.flatnonzero(mark)
    place = np.empty(n, dtype=np.uint32)
    place[arcs] = np.arange(len(arcs), dtype=np.uint32)
    return arcs, place[node]


#: Odd 64-bit multipliers of :func:`_vertex_ids`' hash of a point's three coordinates.
_MIX = np.array([0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9], dtype=np.uint64)


#: :func:`_vertex_ids` of each node table (made once, kept while it lives).
_ENDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _vertex_ids(nodes: NodeArcs) -> np.ndarray:
    """Return (nodes, 2) uint32 ids of every node's ends, equal for equal points (the
    same bits), distinct for distinct ones, below 2^31 (the shader compares them only
    for equality). Numbered through a 64-bit hash of the bits, checked: where two
    distinct points share a hash, through the bits themselves. Made once per table."""
    got = _ENDS.get(nodes)
    if got is None:
        got = _ENDS[nodes] = _number_ends(nodes)
    return got


def _number_ends(nodes: NodeArcs) -> np.ndarray:
    """:func:`_vertex_ids`, made."""
    ends = np.ascontiguousarray(np.concatenate([nodes.a, nodes.b]))
    bits = ends.view(np.uint64).reshape(len(ends), 3)
    h = bits * _MIX
    key = h[:, 0] ^ h[:, 1] ^ h[:, 2]
    key ^= key >> np.uint64(29)
    _, ids = np.unique(key, return_inverse=True)
    ids = ids.ravel()
    one = np.empty(int(ids.max(initial=-1)) + 1, dtype=np.int64)
    one[ids] = np.arange(len(ids))  # one point of each hash
    if not np.array_equal(bits[one[ids]], bits):  # a collision: by the bits
        rows = ends.view(np.dtype((np.void, 24))).ravel()
        _, ids = np.unique(rows, return_inverse=True)
        ids = ids.ravel()
    return ids.reshape(2, -1).T.astype(np.uint32)


def check_shape():
    """The shape of :func:`walk_check`: three rings and a line, 6,300 vertices of
    fjord-like wiggles (three frequencies) across the antimeridian, round the south pole
    and along the equator."""
    from ...shape import Shape

    t = np.linspace(0.0, 2.0 * np.pi, 3000, endpoint=False)
    r = 12.0 + 3.0 * np.sin(5 * t) + 1.2 * np.sin(37 * t) + 0.4 * np.sin(211 * t)
    c, az = np.radians([178.0, 55.0]), t  # a ring about (178, 55), radius r degrees
    d = np.radians(r)
    lat = np.arcsin(np.sin(c[1]) * np.cos(d) + np.cos(c[1]) * np.sin(d) * np.cos(az))
    dlon = np.arctan2(np.sin(az) * np.sin(d) * np.cos(c[1]), np.cos(d) - np.sin(c[1]) * np.sin(lat))
    lon = (np.degrees(c[0] + dlon) + 180.0) % 360.0 - 180.0
    south = np.linspace(180.0, -180.0, 2000, endpoint=False)
    south_lat = -72.0 + 4.0 * np.sin(np.radians(9 * south)) + 0.7 * np.sin(np.radians(83 * south))
    hole_t = t[::10]
    hole = [[-60.0 + 5.0 * np.cos(a), -10.0 + 4.0 * np.sin(a)] for a in hole_t[::-1]]
    line_lon = np.linspace(-40.0, 40.0, 1000)
    line_lat = 3.0 * np.sin(np.radians(17 * line_lon)) + 0.5 * np.sin(np.radians(131 * line_lon))

    def ring(x, y):
        pts = np.column_stack([x, y]).tolist()
        return pts + pts[:1]

    box = [[-70.0, -20.0], [-50.0, -20.0], [-50.0, 0.0], [-70.0, 0.0], [-70.0, -20.0]]
    geoms = [
        {"type": "Polygon", "coordinates": [ring(lon, np.degrees(lat))]},
        {"type": "Polygon", "coordinates": [ring(south, south_lat)]},
        {"type": "Polygon", "coordinates": [box, hole + hole[:1]]},
        {"type": "LineString", "coordinates": np.column_stack([line_lon, line_lat]).tolist()},
    ]
    return Shape.from_geojson({"type": "GeometryCollection", "geometries": geoms})


class _WalkCheck:
    """This thread's answer to :func:`walk_check` (asked once)."""

    def __init__(self):
        self.ok = walk_check()
        if not self.ok:
            warnings.warn(
                "gloffset: this GL's field walk (shaders/field_walk.comp) missed arcs on a "
                "check shape; distance fields use the float64 walk on the host instead "
                f"(GL renderer: {context_info().get('renderer', '?')})",
                UserWarning,
                stacklevel=2,
            )


def walk_check(grids=None) -> bool:
    """Whether the GPU walk's lists give the float64 walk's field, bit for bit, on
    :func:`check_shape` over each of ``grids`` (default :func:`check_grids`).

    The guard of ``WALK = "auto"`` on a GL where the tests have not run: a driver whose
    float32 arithmetic breaks the walk's error bounds by more than about 1e-3 rad in a
    lower bound, or 1e-5 in the bisector test, loses nearest arcs on these grids, which
    changes field values (``tests/test_walk_check.py``); an error below the bounds' slack
    costs nothing. Milliseconds of a hardware GPU and a fraction of a second of the
    host's float64 walk, once per thread; seconds on llvmpipe (where "auto" does not ask).
    """
    shape = check_shape()
    for grid in check_grids() if grids is None else grids:
        got = [gpu_distances(shape, grid, float("inf"), lambda n: None, walk=w) for w in WALKS]
        if not np.array_equal(got[0].view(np.uint64), got[1].view(np.uint64)):
            return False
    return True


#: The walks :func:`walk_check` compares.
WALKS = ("cpu", "gpu")


def check_grids() -> tuple:
    """The grids of :func:`walk_check`: the globe at 1024 x 512 (the antimeridian, the
    pole) and a 10-degree box at 1024 x 1024 (cells of 0.08 degrees: small slack)."""
    from ...grids import Equirect

    return Equirect(1024, 512), Equirect(1024, 1024, (-10.0, -5.0, 0.0, 5.0))
