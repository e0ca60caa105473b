"""The float64 level operations of the vector raster: classify one level's cells.

Every level of a grid classifies its cells against the offset region of a shape at
signed angular distance ``d`` (``e = |d|``), with the cell bound ``R`` (rho):

* ``d >= 0`` (inside or within d): *contained* when ``dist <= d - R`` or when the
  centre is inside and no ring edge is within ``R``; *outside* when the centre is
  outside, no ring edge is within ``R`` and ``dist > d + R``;
* ``d < 0`` (inside and farther than e): *contained* when the centre is inside, no
  ring edge is within ``R`` and ``dist > e + R``; *outside* when ``dist <= e - R`` or
  the centre is outside with no ring edge within ``R``;
* *frontier* otherwise. At the output level ``R = 0`` and every cell is decided.

Only children of frontier cells are evaluated at the next level, each with its
parent's candidate arcs filtered again (complete by the grids' bound ``R``), and the
inside status carried from parent to child by crossings, per region component.

Accuracy: distances are exact float64 point-to-arc distances (error < 1e-15 rad);
decisions at ``R > 0`` use a slack of 1e-15 rad toward *frontier*, so a cell is
only called contained or outside when all its descendant pixels are.

The GPU engine (:mod:`gloffset.gl.vector_pass`) takes over below the bin level with the
same rules. The classifier :class:`~gloffset.raster.vector.curves.CurveCells`, driven by
:mod:`gloffset.raster.driver`, strings these operations into levels;
:func:`gloffset.raster.vector.curves.classify_curves` run to the output level is the float64
reference renderer. The derivation in full: ``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ...edges import CurveArcs, component_status, status_bits
from ...geometry.caps import CAP_SLACK, arc_cap, cap_range, cap_within, pad
from ...geometry.classes import CONTAINED, FRONTIER, OUTSIDE
from ...geometry.sphere import angle, arc_distance, arcs_cross, pair_dots
from ...memo import once_attr
from .child_pairs import child_slots, columns, dots, mid_columns, slot_pairs

__all__ = [
    "CurveArcs",
    "Frontier",
    "at_cells",
    "cell_distances",
    "nearest",
    "row_statuses",
    "cap_range",
    "cap_within",
    "CAP_SLACK",
    "decide",
    "OUTSIDE",
    "FRONTIER",
    "CONTAINED",
]

_SLACK = 1e-15
_PAIRS = 1 << 22


class ArcTable(Protocol):
    """What the level operations read of a set of arcs: :class:`CurveArcs`, or every arc
    of the decomposition tree (:class:`~gloffset.raster.vector.node_levels.NodeArcs`)."""

    a: np.ndarray
    b: np.ndarray
    n: np.ndarray
    mid: np.ndarray
    half: np.ndarray
    boundary: np.ndarray
    group: np.ndarray
    n_groups: int


@dataclass
class Frontier:
    """Frontier cells of one level with their candidate arcs and component statuses.

    ``cells`` (k, 2) rows and columns; ``pair_cell``/``pair_arc`` the candidate
    pairs sorted by cell; ``status`` (k, ceil(G/8)) uint8 bitsets, bit ``g`` set when
    the cell centre is inside component ``g``. ``cm``, where the level that made the
    cells computed it, is each pair's ``c.m`` (the cell centre and the arc's cap centre,
    :func:`~gloffset.geometry.sphere.pair_dots`'s bits), which :func:`cell_distances`
    then takes instead of computing it again; None elsewhere.
    """

    level: int
    cells: np.ndarray
    centers: np.ndarray
    rho: np.ndarray
    pair_cell: np.ndarray
    pair_arc: np.ndarray
    status: np.ndarray
    cm: np.ndarray | None = None

    def part(self, a: int, b: int, pa: int, pb: int) -> Frontier:
        """Return cells ``a:b`` with their pairs ``pa:pb`` (those of cells ``a:b``)."""
        return Frontier(
            self.level,
            self.cells[a:b],
            self.centers[a:b],
            self.rho[a:b],
            self.pair_cell[pa:pb] - a,
            self.pair_arc[pa:pb],
            self.status[a:b],
            None if self.cm is None else self.cm[pa:pb],
        )


def row_statuses(shape, arcs: CurveArcs, h: int, w: int, first, cells, crossing) -> np.ndarray:
    """Packed statuses of every cell of an ``h x w`` level, row-major: cell 0's (centre
    ``first``) by crossings to the shape's reference point, every other cell's its
    predecessor's (left, or above in the first column) toggled by the arcs that cross
    the short arc between their centres, given as pairs ``(cells, crossing)`` (cell
    index, arc index; cell 0 excluded)."""
    toggles = status_bits(arcs.n_groups, h * w)
    g = arcs.group[crossing]
    np.bitwise_xor.at(toggles, (cells, g >> 3), (1 << (g & 7)).astype(np.uint8))
    toggles[0] = component_status(shape, arcs, np.reshape(first, (1, 3)))[0]
    t = toggles.reshape(h, w, -1)
    t[:, 0] = np.bitwise_xor.accumulate(t[:, 0], axis=0)
    return np.bitwise_xor.accumulate(t, axis=1).reshape(h * w, -1)


def coarse(shape, arcs: CurveArcs, grid, e: float) -> Frontier:
    """All cells of level 0 with their candidate lists and component statuses.

    Candidates come from the arcs' bounding-cap tree (every arc whose cap is within
    ``e + rho``). Statuses: the first cell's by crossings to the shape's reference
    point, every other cell's from its neighbour (left, or above for the first
    column) toggled by the crossings of the short arc between their centres.
    """
    h, w = grid.level_shape(0)
    jj, ii = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    cells = np.column_stack([jj.ravel(), ii.ravel()])
    c = grid.centers(0, cells[:, 0], cells[:, 1])
    rho = grid.rho_at(0, cells[:, 0], cells[:, 1])
    tree = arcs.tree
    status = status_bits(arcs.n_groups, len(c))
    if arcs.n_groups:
        cgrid = c.reshape(h, w, 3)
        # predecessor of each cell: above for the first column, else left
        pred = np.empty((h, w, 3))
        pred[1:, 0] = cgrid[:-1, 0]
        pred[:, 1:] = cgrid[:, :-1]
        pred[0, 0] = cgrid[0, 0]
        a_seg = pred.reshape(-1, 3)
        mid, half = arc_cap(a_seg, c)
        half = half + 1e-9
        qi, ai, _ = tree.near(mid, half)
        ring = arcs.group[ai] >= 0
        qi, ai = qi[ring], ai[ring]
        hit = arcs_cross(c[qi], a_seg[qi], arcs.a[ai], arcs.b[ai], arcs.n[ai]) & (qi > 0)
        status = row_statuses(shape, arcs, h, w, c[0], qi[hit], ai[hit])
    qi, ai, _ = tree.near(c, _list_reach(arcs, c, e, rho))
    order = np.lexsort((ai, qi))
    return Frontier(0, cells, c, rho, qi[order], ai[order], status)


def at_cells(shape, arcs: CurveArcs, grid, e: float, level: int, cells, status=None) -> Frontier:
    """Cells ``(row, column)`` of ``level`` entered directly, no coarser level
    classified: candidates from the arcs' bounding-cap tree as in :func:`coarse` (every
    arc whose cap is within ``e + rho``, capped by the nearest-arc bound), statuses by
    crossings to the shape's reference points (a crossing count per cell: for a few
    cells, such as the tiles a server is asked for). The cells are sorted row-major.

    ``status``: the cells' statuses when known already (packed bits, one row per cell
    in the order of ``cells``, as an earlier :func:`at_cells` of the same cells gave
    them: they do not depend on ``e``), so that no crossing is counted again.
    """
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
    order = np.lexsort((cells[:, 1], cells[:, 0]))
    cells = cells[order]
    c = grid.centers(level, cells[:, 0], cells[:, 1])
    rho = grid.rho_at(level, cells[:, 0], cells[:, 1])
    if status is not None:
        status = np.asarray(status, dtype=np.uint8).reshape(len(cells), -1)[order]
    elif arcs.n_groups:
        status = component_status(shape, arcs, c)
    else:
        status = status_bits(arcs.n_groups, len(c))
    qi, ai, _ = arcs.tree.near(c, _list_reach(arcs, c, e, rho))
    order = np.lexsort((ai, qi))
    return Frontier(level, cells, c, rho, qi[order], ai[order], status)


def _list_reach(arcs: CurveArcs, c, e: float, rho) -> np.ndarray:
    """How far from each centre a candidate arc's cap may lie: ``e + rho``, capped by the
    nearest-arc bound plus ``2 rho`` (:func:`_nearest_bound`), computed only where it can
    cap anything (``e > rho``: the bound is never negative, so ``e + rho <= 2 rho`` is the
    least of the two, bit for bit; at ``e = 0``, as a field's inside test, never)."""
    reach = e + rho
    if np.any(e > rho):
        reach = np.minimum(reach, _nearest_bound(arcs, c) + 2.0 * rho)
    return reach


def _nearest_bound(arcs: CurveArcs, c) -> np.ndarray:
    """An upper bound on each centre's distance to its nearest boundary arc and to its
    nearest ring edge: the distance to the farther of the two nearest arc ends (of at
    most 4096 ends of each kind, spread along the curves: any end bounds the nearest
    arc, so a sample keeps the bound valid and its cost small).

    A point within ``rho`` of a centre is at most ``bound + rho`` from its nearest arc,
    and an arc farther than ``bound + 2 rho`` from the centre is farther than that from
    the point, so no candidate list needs it (ring edges within ``rho``, which the
    crossing tests of the cell's points can meet, are nearer still). At a large
    distance every arc lies within ``d + rho`` of a coarse cell; this bound keeps the
    lists to the arcs near the cell's nearest. Exact angles (:func:`angle`), padded.
    """
    out = np.zeros(len(c))
    for ends in arcs.end_samples:
        best = np.empty(len(c), dtype=np.int64)
        step = max(1, (1 << 22) // len(ends))
        for s in range(0, len(c), step):
            best[s : s + step] = np.argmax(c[s : s + step] @ ends.T, axis=1)
        out = np.maximum(out, pad(angle(c, ends[best]), 1e-9, 1e-9))
    return out


def cell_distances(f: Frontier, arcs: ArcTable, *, lows: bool = False):
    """Exact float64 distances from the cells of ``f`` to their candidate arcs.

    Returns ``(dist, dring)``: the distance to the nearest candidate boundary arc
    (the offset distance) and to the nearest candidate ring edge, seams included
    (inside uniformity); ``inf`` where a cell has none. Only the pairs that can be a
    cell's nearest are measured (:func:`nearest`). With ``lows``, also each pair's
    lower bound on its distance (:func:`~gloffset.geometry.caps.cap_range`), for :func:`prune`.
    """
    k, n = len(f.cells), len(f.pair_cell)
    dist = np.full(k, np.inf)  # to boundary arcs (distance)
    dring = np.full(k, np.inf)  # to ring edges including seams (inside uniformity)
    step = _PAIRS if f.cm is None else max(n, 1)  # c.m to compute: in chunks
    parts = []
    for s in range(0, n, step):
        ci, ai = f.pair_cell[s : s + step], f.pair_arc[s : s + step]
        cm = dots(f.centers, ci, mid_columns(arcs), ai) if f.cm is None else f.cm[s : s + step]
        parts.append(nearest(arcs, ci, ai, cm, lambda idx, ci=ci: f.centers[ci[idx]], dist, dring))
    if not lows:
        return dist, dring
    return dist, dring, parts[0] if len(parts) == 1 else np.concatenate(parts or [np.zeros(0)])


#: Relative slack of :func:`prune` on the cell bound (the GPU levels' float32 work is
#: good to a few 1e-8 of a bin: an arc pruned is farther than the nearest by more).
PRUNE_SLACK = 1e-6


def prune(f: Frontier, low: np.ndarray, dist: np.ndarray, e: float) -> Frontier:
    """``f`` with the pairs no descendant point needs: an arc whose lower bound ``low``
    exceeds ``min(e + rho, dist + 2 rho)`` (``dist`` the cell's nearest boundary arc).

    Every point within ``rho`` of the centre is within ``dist + rho`` of that arc, and
    such an arc is farther than that from it, so it is never a point's nearest (nor
    within ``e`` of a point whose nearest is farther than ``e``); ring edges within
    ``rho``, which the crossing tests of the descendants can meet, are kept
    (``dist + 2 rho >= rho``). The bound is widened by :data:`~gloffset.geometry.caps.CAP_SLACK`
    and :data:`PRUNE_SLACK` ``rho``, so the pixels are those without pruning, bit for
    bit. Candidate lists then hold the arcs near the nearest, not every arc within
    ``e + rho``: at large distances the lists of coarse cells shrink by orders of
    magnitude.
    """
    if len(f.pair_cell) == 0:
        return f
    reach = np.minimum(e + f.rho, dist + 2.0 * f.rho) * (1.0 + PRUNE_SLACK) + CAP_SLACK
    keep = low <= reach[f.pair_cell]
    if keep.all():
        return Frontier(f.level, f.cells, f.centers, f.rho, f.pair_cell, f.pair_arc, f.status)
    return Frontier(
        f.level, f.cells, f.centers, f.rho, f.pair_cell[keep], f.pair_arc[keep], f.status
    )


def nearest(arcs: ArcTable, cell, ai, cm, point, dist, dring) -> np.ndarray:
    """Lower ``dist`` and ``dring`` of each cell to the exact distance of its nearest
    boundary arc and ring edge among its pairs ``(cell, ai)`` (grouped by cell).

    ``cm``: ``c.m`` of each pair (cell centre, arc's cap centre); ``point(idx)``: the
    cell centres of pairs ``idx``. Only pairs that can be the nearest are measured:
    with ``t = angle(c, m)`` and the cap radius ``h``, ``t - h <= dist(c, arc) <= t + h``,
    so a pair whose lower bound exceeds the cell's least upper bound is skipped.
    The comparison allows :data:`CAP_SLACK` (:func:`cap_range`), so the minima are
    those of all pairs, bit for bit. Returns each pair's lower bound ``t - h``.

    The per-pair work runs in blocks of whole runs of about :data:`_BLOCK` pairs
    (:func:`_near_pairs`), its temporaries in the cache: the same values, element for
    element.
    """
    n = len(cell)
    if n == 0:
        return np.zeros(0)
    new = np.empty(n, dtype=bool)
    new[0] = True
    np.not_equal(cell[1:], cell[:-1], out=new[1:])
    starts = np.flatnonzero(new)
    kinds = _kinds(arcs, ai, dist, dring)
    lo = np.empty(n)
    measure = np.zeros(n, dtype=bool)
    first = np.searchsorted(starts, np.arange(0, n, _BLOCK))  # each block's first run
    first = np.unique(first[first < len(starts)])
    at = np.r_[starts[first], n]
    runs = np.r_[first, len(starts)]
    for s, e, r0, r1 in zip(
        at[:-1].tolist(), at[1:].tolist(), runs[:-1].tolist(), runs[1:].tolist()
    ):
        _near_pairs(arcs, ai[s:e], cm[s:e], starts[r0:r1] - s, kinds, s, lo[s:e], measure[s:e])
    k = np.flatnonzero(measure)
    if len(k) == 0:
        return lo
    dd = np.empty(len(k))
    for s in range(0, len(k), _BLOCK):
        kb = k[s : s + _BLOCK]
        ak = np.take(ai, kb)
        dd[s : s + len(kb)] = arc_distance(point(kb), arcs.a[ak], arcs.b[ak], arcs.n[ak])
    ck = np.take(cell, k)
    runs = np.flatnonzero(np.r_[True, ck[1:] != ck[:-1]])  # the measured pairs' runs
    for kind, outs in kinds:
        mk = dd if kind is None else np.where(np.take(kind, k), dd, np.inf)
        low = np.minimum.reduceat(mk, runs)
        for out in outs:
            np.minimum.at(out, ck[runs], low)
    return lo


#: Pairs per block of :func:`nearest` (its temporaries of a block stay in the cache).
_BLOCK = 1 << 15


def _near_pairs(arcs: ArcTable, ai, cm, starts, kinds, s: int, lo, measure) -> None:
    """One block of :func:`nearest`: whole runs of pairs (arcs ``ai``, ``c.m`` ``cm``,
    ``starts`` where each run begins in the block), the level's pairs from ``s`` on
    (``kinds``: the level's masks). Writes each pair's lower bound into ``lo`` and sets
    ``measure`` where a pair's bound is within :data:`CAP_SLACK` of its run's least upper
    bound among the pairs of its kind."""
    lo[:], hi = cap_range(cm, np.take(arcs.half, ai))
    counts = np.diff(starts, append=len(ai))
    for kind, _ in kinds:
        mask = None if kind is None else kind[s : s + len(ai)]
        best = np.minimum.reduceat(hi if mask is None else np.where(mask, hi, np.inf), starts)
        near = lo <= (best + CAP_SLACK).repeat(counts)
        if mask is not None:
            near &= mask
        measure |= near


def _kinds(arcs: ArcTable, ai, dist, dring):
    """The kinds of pairs :func:`nearest` measures, as ``(mask, outputs)``: the boundary
    arcs (``dist``) and the ring edges (``dring``), a kind without a pair left out, one
    that holds every pair as ``None``, and the two as one where they are the same pairs
    (polygons: every edge is both)."""
    every_b, every_r = once_attr(
        arcs, "_every_kind", lambda: (bool(arcs.boundary.all()), bool((arcs.group >= 0).all()))
    )
    kb = None if every_b else np.take(arcs.boundary, ai)
    kr = None if every_r else np.take(arcs.group, ai) >= 0
    masks = []
    for kind, out in ((kb, dist), (kr, dring)):
        if kind is None or kind.all():
            masks.append((None, out))
        elif kind.any():
            masks.append((kind, out))
    if len(masks) == 2:
        a, b = masks[0][0], masks[1][0]
        if (a is None) == (b is None) and (a is None or np.array_equal(a, b)):
            return [(a, [dist, dring])]
    return [(kind, [out]) for kind, out in masks]


def decide(dist, dring, inside, rho, d: float, final: bool) -> np.ndarray:
    """The decision rules of the module notes: classes of cells with bound ``rho``.

    ``dist``, ``dring`` from :func:`cell_distances` (complete within ``|d| + rho``),
    ``inside`` whether each centre is inside the shape, ``final`` for the output
    level (decided at the centres, ``rho`` unused).
    """
    e = abs(d)
    if final:
        if d >= 0:
            member = inside | (dist <= d)
        else:
            member = inside & (dist > e)
        return np.where(member, CONTAINED, OUTSIDE).astype(np.uint8)
    r = rho + _SLACK
    uniform = dring > r
    cls = np.full(len(dist), FRONTIER, dtype=np.uint8)
    if d >= 0:
        cont = (dist <= d - r) | (inside & uniform)
        out = ~inside & uniform & (dist > d + r)
    else:
        cont = inside & uniform & (dist > e + r)
        out = (dist <= e - r) | (~inside & uniform)
    cls[out] = OUTSIDE
    cls[cont] = CONTAINED
    return cls


#: Parent pairs per part of :func:`refine` (their children's pairs, about four times as
#: many, stay below glibc's largest mmap threshold: reused heap, not fresh pages).
_REFINE_PAIRS = 1 << 19


def refine(f: Frontier, grid, arcs: CurveArcs, e: float, shape, *, pairs=None) -> Frontier:
    """Children of the cells of ``f`` (all assumed frontier) with refined lists and
    statuses (``shape``: the shape of ``arcs``, for its reference points).

    Refined in parts of whole rows of parents (their children are whole rows too, so
    the parts' results follow each other in row-major order): the same result, with
    temporaries of a few million pairs at most.

    ``pairs``: what may do the per-pair work of the whole level instead
    (:func:`gloffset.raster.gpu.gpu_refine_pairs`, on the GL context: the same lists,
    ``c.m`` and statuses), returning None where it leaves the level to numpy."""
    k = len(f.cells)
    if pairs is not None:
        out = _refine(f, grid, arcs, e, shape, pairs)
        if out is not None:
            return out
    if len(f.pair_cell) <= _REFINE_PAIRS or k < 2:
        return _numpy_refine(f, grid, arcs, e, shape)
    rows = f.cells[:, 0]
    row_start = np.flatnonzero(np.r_[True, rows[1:] != rows[:-1]])
    before = np.searchsorted(f.pair_cell, row_start)  # pairs before each row
    part = before // _REFINE_PAIRS
    cuts = row_start[np.flatnonzero(np.r_[True, part[1:] != part[:-1]])]
    if len(cuts) < 2:
        return _numpy_refine(f, grid, arcs, e, shape)
    bounds = np.asarray(np.r_[cuts, k])
    pair_at = np.searchsorted(f.pair_cell, bounds)
    outs = []
    for (a, b), (pa, pb) in zip(zip(bounds[:-1], bounds[1:]), zip(pair_at[:-1], pair_at[1:])):
        outs.append(_numpy_refine(f.part(a, b, pa, pb), grid, arcs, e, shape))
    offsets = np.cumsum([0] + [len(o.cells) for o in outs[:-1]])
    return Frontier(
        f.level + 1,
        np.concatenate([o.cells for o in outs]),
        np.concatenate([o.centers for o in outs]),
        np.concatenate([o.rho for o in outs]),
        np.concatenate([o.pair_cell + off for o, off in zip(outs, offsets)]),
        np.concatenate([o.pair_arc for o in outs]),
        np.concatenate([o.status for o in outs]),
        np.concatenate([o.cm for o in outs]),  # _refine's, all set
    )


def _numpy_refine(f: Frontier, grid, arcs: CurveArcs, e: float, shape) -> Frontier:
    out = _refine(f, grid, arcs, e, shape)
    assert out is not None  # numpy's: always made
    return out


def children(f: Frontier, grid):
    """The children of the cells of ``f`` at the next level, sorted row-major, with
    their parent's candidate pairs: ``(cells, parent, centres, rho, pair_child,
    pair_arc)`` (``parent`` each child's index in ``f``; the pairs grouped by child, each
    child's in its parent's order)."""
    lev = f.level + 1
    cells, parent, _ = child_slots(f.cells, grid, lev)
    c = grid.centers(lev, cells[:, 0], cells[:, 1])
    rho = grid.rho_at(lev, cells[:, 0], cells[:, 1])

    # expand the parent's pairs to each child: child k's pairs are its parent's, pairs
    # starts[parent] .. + counts, placed after those of the children before it
    bounds = np.searchsorted(f.pair_cell, np.arange(len(f.cells) + 1))
    starts = bounds[:-1]
    counts = np.take(np.diff(bounds), parent)
    child_of_pair = np.repeat(np.arange(len(cells)), counts)
    shift = np.take(starts, parent) - (np.cumsum(counts) - counts)
    src = np.arange(int(counts.sum()))
    src += np.take(shift, child_of_pair)
    return cells, parent, c, rho, child_of_pair, np.take(f.pair_arc, src)


def _refine(f: Frontier, grid, arcs: CurveArcs, e: float, shape, pairs=None) -> Frontier | None:
    """:func:`refine` of all the cells of ``f`` at once (the pairs worked in the parents'
    order, :func:`~gloffset.raster.vector.child_pairs.slot_pairs`, or by ``pairs``: None
    where that leaves the level to numpy)."""
    lev = f.level + 1
    cells, parent, slot = child_slots(f.cells, grid, lev)
    c = grid.centers(lev, cells[:, 0], cells[:, 1])
    rho = grid.rho_at(lev, cells[:, 0], cells[:, 1])

    # candidates: arcs whose bounding cap comes within e + rho of the child's centre;
    # statuses: parent's, toggled by crossings of child -> parent centre (an arc that
    # crosses it has its bounding cap within angle(child, parent) of the child)
    seg = angle(c, f.centers[parent])
    if pairs is not None:
        got = pairs(f, arcs, c, slot, e + rho, seg)
        if got is None:
            return None
        cell, arc, cm, (tc, ta), on_parent = got
    else:
        cell, arc, cm, (pc, pp, pa) = slot_pairs(
            f.pair_cell, f.pair_arc, arcs, c, slot, e + rho, seg
        )
        tc = ta = pc[:0]
        if len(pc):
            cr = arcs_cross(c[pc], f.centers[pp], arcs.a[pa], arcs.b[pa], arcs.n[pa])
            tc, ta = pc[cr], pa[cr]
        on_parent = _on_ring(f, arcs)
    status = f.status[parent].copy()
    if len(tc):
        g = arcs.group[ta]
        np.bitwise_xor.at(status, (tc, g >> 3), (1 << (g & 7)).astype(np.uint8))

    on = on_parent[parent]
    if on.any():  # a parent centre on a ring edge is no anchor: ask the reference points
        status[on] = component_status(shape, arcs, c[on])
    return Frontier(lev, cells, c, rho, cell, arc, status, cm)


#: A centre within this angle (rad) of a ring edge's great circle, inside the edge's cap,
#: is taken to lie on the edge (crossing tests that end there are not exact).
ON_EDGE = 1e-13


def _on_ring(f: Frontier, arcs: CurveArcs) -> np.ndarray:
    """Which cells of ``f`` have their centre on one of their candidate ring edges (to
    :data:`ON_EDGE`). A child's status is its parent's toggled by the crossings of the
    arc child -> parent, and :func:`~gloffset.geometry.sphere.arcs_cross` is exact only when
    neither end lies on the other arc (a parent centre at a shared vertex, e.g. a tile
    corner at (0, 0), counts the two edges there inconsistently)."""
    pc, pa = f.pair_cell, f.pair_arc
    ring = np.take(arcs.group, pa) >= 0
    if not ring.all():  # polygons alone: every arc is a ring edge
        k = np.flatnonzero(ring)
        pc, pa = np.take(pc, k), np.take(pa, k)
    out = np.zeros(len(f.cells), dtype=bool)
    out[pc[on_edge(f.centers, arcs, pa, pc)]] = True
    return out


def on_edge(p: np.ndarray, arcs, ai: np.ndarray, pi: np.ndarray | None = None) -> np.ndarray:
    """Whether each point ``p`` (or ``p[pi]``, with ``pi``) lies on its arc ``ai`` (to
    :data:`ON_EDGE`): on the great circle, and inside the arc's cap."""
    idx = np.arange(len(p)) if pi is None else pi
    on = np.abs(dots(p, idx, columns(arcs, "n"), ai)) <= ON_EDGE
    k = np.flatnonzero(on)
    if len(k):
        ik, ak = idx[k], ai[k]
        on[k] = cap_within(pair_dots(p, ik, arcs.mid, ak), arcs.half[ak] + ON_EDGE)
    return on


def subset(f: Frontier, sel: np.ndarray) -> Frontier:
    """The cells ``sel`` (sorted indices) of ``f`` with their pairs."""
    pc = f.pair_cell
    if len(pc) and not (pc[1:] >= pc[:-1]).all():  # pairs not by cell: map each
        remap = np.full(len(f.cells), -1)
        remap[sel] = np.arange(len(sel))
        keep = remap[pc] >= 0
        cell, arc = remap[pc[keep]], f.pair_arc[keep]
    else:  # each cell's pairs are one run: keep the runs of the cells kept
        counts = np.diff(np.searchsorted(pc, np.arange(len(f.cells) + 1)))
        chosen = np.zeros(len(f.cells), dtype=bool)
        chosen[sel] = True
        arc = f.pair_arc[np.repeat(chosen, counts)]
        cell = np.repeat(np.arange(len(sel)), np.take(counts, sel))
    return Frontier(
        f.level,
        f.cells[sel],
        f.centers[sel],
        f.rho[sel],
        cell,
        arc,
        f.status[sel],
    )
