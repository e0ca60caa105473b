"""The GPU backend of :func:`gloffset.distance_field`: the unsigned distances, bit for bit
those of the CPU walk.

1. The float64 walk (:func:`~gloffset.raster.field_walk.walk_levels`) stops at the level
   ``SHIFT`` above the output (cells of 8 x 8 pixels), its nodes split down to the
   original arcs: a cell's list holds every arc that can be the nearest (within
   ``max_distance``) of a point within the cell's ``rho``, so of each of its pixels.
2. ``shaders/nearest.frag`` (:mod:`gloffset.gl.nearest_pass`) measures each pixel
   against its cell's list in float32 (chords of its arcs' features, the foot on the arc
   or its ends, good to ``NEAREST_ERR``) and returns its six least features, how many
   lie within ``2 NEAREST_ERR`` of the least and whether more may; blocks of pixels at
   a time, so memory stays bounded.
3. Each pixel is finished in float64 with the CPU's kernel
   (:func:`~gloffset.raster.field_walk.exact_distances`, whose bits an end's distance
   has where the end is an arc's nearest point): the features within
   ``2 NEAREST_ERR`` of the least, the cell's whole list where more may be. A feature
   whose float32 chord exceeds the least by more than ``2 NEAREST_ERR`` has a true chord
   greater than the least one's (by more than the float64 error), so the least exact
   distance is among those evaluated, and the minimum of the same float64 values is the
   CPU's, bit for bit.

Pixels whose cell has no arc (all beyond ``max_distance``) stay ``inf``, as on the CPU.
"""

from __future__ import annotations

import time
import weakref

import numpy as np

from ..geometry.caps import chord, pad
from ..geometry.sphere import cross, dot
from ..gl.context import context_info
from ..gl.nearest_pass import EVERY, FEATURES, NONE, NearestPlan, nearest_pass
from .field_lists import gpu_lists
from .field_walk import end_distances, exact_distances, walk_levels
from .vector.node_levels import NodeArcs

__all__ = ["SHIFT", "gpu_distances"]

#: Levels between the cells of the lists and the output pixels (2^SHIFT pixels a side).
SHIFT = 3
#: Output pixels per side of a block drawn at once (a power of two).
_BLOCK = 1024

#: The float32 arc records of each node table (made once per table, kept while it lives).
_RECORDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _records(nodes: NodeArcs) -> np.ndarray:
    """Every node's arc as ``shaders/nearest.frag`` reads it, (nodes, 5, 4) float32."""
    got = _RECORDS.get(nodes)
    if got is None:
        n = nodes.n
        rec = np.zeros((len(n), 5, 4))
        rec[:, 0, :3], rec[:, 1, :3] = nodes.a, nodes.b
        rec[:, 2, :3], rec[:, 3, :3] = cross(n, nodes.a), cross(nodes.b, n)
        rec[:, :3, 3] = n
        rec[:, 3, 3] = dot(n, n) > 0.5
        rec[:, 4, :3] = nodes.mid
        rec[:, 4, 3] = _cap_chords(nodes)
        got = _RECORDS[nodes] = rec.astype(np.float32)
    return got


#: Which walk makes the lists: ``"gpu"`` (:func:`~gloffset.raster.field_lists.gpu_lists`,
#: the float64 walk where it does not apply), ``"cpu"`` (the float64 walk), or ``"auto"``:
#: the GPU's on a hardware GL, the float64 walk on a software one (Mesa's llvmpipe runs
#: the GPU walk's divergent loops slower than numpy runs the float64 walk).
WALK = "auto"


class _Lists:
    """The cells of one level and their lists, by cell (row-major): ``start``, ``count``
    (per cell) into ``node`` (the pairs' nodes). Walked as :data:`WALK` says (or as
    ``walk`` says)."""

    def __init__(self, nodes: NodeArcs, grid, m: float, level: int, walk: str | None = None):
        self.shape = hc, wc = grid.level_shape(level)
        walk = WALK if walk is None else walk
        if walk == "auto":
            walk = "cpu" if context_info()["software"] else "gpu"
        got = gpu_lists(nodes, grid, m, level) if walk == "gpu" else None
        if got is not None:
            self.count, self.node = got
            self.start = np.cumsum(self.count) - self.count
            return
        keys, vals = [], []
        for f, _ in walk_levels(nodes, grid, m, level):
            flat = f.cells[:, 0].astype(np.int64) * wc + f.cells[:, 1]
            keys.append(flat[f.pair_cell])
            vals.append(f.pair_arc)
        key = np.concatenate(keys) if keys else np.zeros(0, np.int64)
        order = np.argsort(key, kind="stable")
        self.node = np.concatenate(vals)[order] if vals else np.zeros(0, np.int64)
        self.count = np.bincount(key, minlength=hc * wc)
        self.start = np.cumsum(self.count) - self.count

    def block(self, rows: range, cols: range):
        """The cells ``rows x cols``: their first pair and count in the block's own list,
        and that list's nodes."""
        jj, ii = np.meshgrid(np.asarray(rows), np.asarray(cols), indexing="ij")
        flat = (jj * self.shape[1] + ii).ravel()
        cnt, st = self.count[flat], self.start[flat]
        first = np.cumsum(cnt) - cnt
        at = np.repeat(st - first, cnt) + np.arange(int(cnt.sum()))
        return first, cnt, self.node[at]


def gpu_distances(shape, grid, m: float, add, timings: dict | None = None) -> np.ndarray:
    """Return the distance (rad, float64) from each pixel centre to the nearest arc.

    As :func:`gloffset.raster.field._distances` (the CPU walk), bit for bit: exact where
    at most ``m``, larger than ``m`` (or ``inf``) elsewhere. ``add(n)`` is called as the
    pixels are finished; ``timings`` (if given) gets the seconds of the stages added to
    its ``"walk"`` (to the lists' level), ``"plan"`` (the blocks' lists and centres),
    ``"gpu"`` and ``"finish"``. The grid must have more than one level.
    """
    t = {} if timings is None else timings
    for k in ("walk", "plan", "gpu", "finish"):
        t.setdefault(k, 0.0)
    nodes = NodeArcs.from_shape(shape)
    last = grid.n_levels - 1
    shift = min(SHIFT, last)
    t0 = time.perf_counter()
    lists = _Lists(nodes, grid, m, last - shift)
    t["walk"] += time.perf_counter() - t0
    h, w = grid.level_shape(last)
    out = np.empty((h, w))
    side = max(1, _BLOCK >> shift)  # cells per block side
    hc, wc = lists.shape
    for r0 in range(0, hc, side):
        for c0 in range(0, wc, side):
            rows, cols = range(r0, min(r0 + side, hc)), range(c0, min(c0 + side, wc))
            _block(nodes, grid, lists, (rows, cols, shift), out, t)
            pj = min(h, rows.stop << shift) - (rows.start << shift)
            add(pj * (min(w, cols.stop << shift) - (cols.start << shift)))
    return out


def _block(nodes: NodeArcs, grid, lists: _Lists, where, out: np.ndarray, t: dict) -> None:
    """Fill ``out`` at the pixels of the cells ``rows x cols`` (``where``, with the
    shift): their nearest arcs on the GPU, finished in float64 (see the module notes).
    A block over the GL limits is drawn in two halves of its rows."""
    rows, cols, shift = where
    eng = nearest_pass()
    t0 = time.perf_counter()
    first, cnt, node = lists.block(rows, cols)
    arcs, local = np.unique(node, return_inverse=True)
    ends = _vertex_ids(nodes, arcs)
    last = grid.n_levels - 1
    h, w = out.shape
    pj = np.arange(rows.start << shift, min(h, rows.stop << shift))
    pi = np.arange(cols.start << shift, min(w, cols.stop << shift))
    if len(rows) > 1 and not eng.fits(len(pj), len(pi), len(node), len(arcs)):
        half = rows.start + len(rows) // 2
        for part in (range(rows.start, half), range(half, rows.stop)):
            if len(part):
                _block(nodes, grid, lists, (part, cols, shift), out, t)
        return
    jj, ii = np.meshgrid(pj, pi, indexing="ij")
    c = grid.centers(last, jj.ravel(), ii.ravel())
    cells = np.stack([first, cnt], axis=-1).reshape(len(rows), len(cols), 2)
    plan = NearestPlan(
        c.reshape(len(pj), len(pi), 3).astype(np.float32),
        shift,
        cells.astype(np.uint32),
        local.astype(np.uint32),
        _records(nodes)[arcs],
        ends,
    )
    t1 = time.perf_counter()
    got = eng.run(plan).reshape(-1, 8)
    t2 = time.perf_counter()
    cell = (np.arange(len(pj))[:, None] >> shift) * len(cols) + (np.arange(len(pi)) >> shift)
    dist = finish(c, got, node, (first, cnt, cell.ravel()), nodes)
    out[pj[0] : pj[-1] + 1, pi[0] : pi[-1] + 1] = dist.reshape(len(pj), len(pi))
    t3 = time.perf_counter()
    t["plan"] += t1 - t0
    t["gpu"] += t2 - t1
    t["finish"] += t3 - t2


def _vertex_ids(nodes: NodeArcs, arcs: np.ndarray) -> np.ndarray:
    """Return (arcs, 2) uint32 ids of the ends of ``arcs``, equal for equal points."""
    ends = np.concatenate([nodes.a[arcs], nodes.b[arcs]])
    rows = np.ascontiguousarray(ends).view(np.dtype((np.void, 24))).ravel()
    _, ids = np.unique(rows, return_inverse=True)
    return ids.reshape(2, -1).T.astype(np.uint32)


def finish(c: np.ndarray, got: np.ndarray, node: np.ndarray, lists, nodes: NodeArcs):
    """Return the exact distances (rad, float64) of pixels ``c`` from the GPU's answer.

    ``got`` (pixels, 8) as :meth:`~gloffset.gl.nearest_pass.NearestPass.run` returns
    it, ``node`` the block's list (pair positions to nodes), ``lists`` each cell's first
    pair and count and each pixel's cell. The exact distances of the features within
    reach of the least one, the cell's whole list where more may be (those arcs whose
    caps come within the distance found); an arc's end has the bits the arc's distance
    has when the end is its nearest point
    (:func:`~gloffset.raster.field_walk.end_distances`).
    """
    first, cnt, cell = lists
    info = got[:, 3]
    dist = np.full(len(c), np.inf)
    # the features within reach of the least: (pixel, column) pairs, the least first
    count = np.where(got[:, 0] != NONE, (info & 0xFF).astype(np.int64) + 1, 0)
    pix = np.repeat(np.arange(len(c)), count)
    col = np.arange(len(pix)) - np.repeat(np.cumsum(count) - count, count)
    what = got[pix, np.asarray(FEATURES)[col]]
    pair, kind = node[what >> 2], what & 3
    d = np.empty(len(pix))
    arc = np.flatnonzero(kind == 0)
    d[arc] = exact_distances(c, pix[arc], nodes, pair[arc])
    for end, pts in ((1, nodes.a), (2, nodes.b)):
        e = np.flatnonzero(kind == end)
        d[e] = end_distances(c, pix[e], pts[pair[e]])
    has = np.flatnonzero(count)
    if len(has):
        dist[has] = np.minimum.reduceat(d, (np.cumsum(count) - count)[has])
    every = np.flatnonzero((got[:, 0] != NONE) & (info & EVERY != 0))
    if len(every):
        k = cnt[cell[every]]
        px = np.repeat(every, k)
        at = np.repeat(first[cell[every]] - (np.cumsum(k) - k), k) + np.arange(int(k.sum()))
        # an arc whose cap lies farther than the distance found (a chord from the centre
        # less the cap's, rounded down by _CAP_SLACK) cannot be nearer
        pair = node[at]
        dm = c[px] - nodes.mid[pair]
        lb = np.sqrt(dot(dm, dm)) - _cap_chords(nodes)[pair]
        near = lb <= chord(dist[px]) + _CAP_SLACK
        np.minimum.at(dist, px[near], exact_distances(c, px[near], nodes, pair[near]))
    return dist


#: Slack (chord) on the cap test of :func:`finish` (float64 chords good to 1e-15).
_CAP_SLACK = 1e-12

#: The chord radii (rounded up) of each node table's caps.
_CAPS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _cap_chords(nodes: NodeArcs) -> np.ndarray:
    got = _CAPS.get(nodes)
    if got is None:
        got = _CAPS[nodes] = pad(chord(np.minimum(nodes.half, np.pi)))
    return got
