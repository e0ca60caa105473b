"""A fine starting level for the raster hierarchy: each arc scattered to the cells near it.

The hierarchy (:mod:`gloffset.raster.vector.levels`) starts from the coarsest level and finds
each level's candidate arcs from the parent's. When the offset distance is small
compared with the grid, most of that work is spent on coarse cells whose lists hold
hundreds of arcs. On grids whose rows are parallels and columns meridians
(:class:`~gloffset.grids.base.LonLatGrid`: equirectangular, web mercator) a level
``L`` can instead be entered directly, in float64 and with the same rules:

each arc's cap scattered to the rows and columns of its lon/lat box (the pairs), the
inside status carried from cell to cell by crossings, and the classes from exact
distances to the pairs (:func:`gloffset.raster.vector.levels.decide`).

The result is the level's classes and its :class:`~gloffset.raster.vector.levels.Frontier`,
identical in meaning to what the hierarchy would have reached (a cell called
contained or outside has only descendant pixels of that class; candidate lists are
complete), from which the hierarchy goes on. The coarser levels, which were never
visited, are reported pooled from level ``L`` (a cell is contained or outside when
all its children at ``L`` are).

Cost: ``O(pairs)`` numpy work with a fixed number of calls. :func:`start_level`
picks the finest level whose box enumeration stays within :data:`PAIRS_PER_ARC`
pairs per arc (small offset distances; level 0 too, instead of the cap-tree queries
of the hierarchy's first level); large distances, for which whole coarse cells are
decided by distance, keep the hierarchy from level 0. The derivation in full:
``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ...edges import CurveArcs, status_bits
from ...geometry.caps import cap_within_pairs, pad
from ...geometry.sphere import angle, arcs_cross
from ...memo import Memo, once_attr
from .child_pairs import half_trig
from .levels import FRONTIER, Frontier, decide, nearest, prune, row_statuses

__all__ = ["start_level", "scatter", "box_pairs", "BoxPairs", "PAIRS_PER_ARC"]

#: Most box-enumerated (cell, arc) pairs per arc for a level to be entered directly.
PAIRS_PER_ARC = 48
# Slack (radians, relative and absolute) on every reach: boxes and cap tests are
# only ever too wide.
_REL, _ABS = 1e-9, 1e-12


def _levels_geometry(grid, level: int):
    """Row latitudes, column longitudes (unwrapped, increasing), rho and centre spacing
    (read-only arrays, kept on the grid: a grid used again, such as the tiles a server
    renders at every distance, does not compute them again)."""
    return once_attr(grid, "_scatter_geometry", Memo).once(level, lambda: _geometry(grid, level))


def _geometry(grid, level: int):
    h, w = grid.level_shape(level)
    rows = np.arange(h)
    lat = np.asarray(grid.cell_lat(level, rows), dtype=np.float64)
    lon = np.asarray(grid.cell_lon(level, np.arange(w)), dtype=np.float64)
    rho = np.asarray(grid.rho(level), dtype=np.float64)[:h]
    c0 = grid.centers(level, rows, 0)
    spacing = angle(c0, grid.centers(level, rows, min(1, w - 1)))  # left neighbour
    spacing[1:] = np.maximum(spacing[1:], angle(c0[:-1], c0[1:]))  # above (first column)
    out = lat, lon, rho, pad(spacing)
    for a in out:
        a.setflags(write=False)
    return out


def _boxes(arcs: CurveArcs, lat, lon, reach: float):
    """Per arc, the row range and up to three column ranges of cells whose centres can
    lie within ``reach + half`` of the arc's cap centre.

    Returns ``(arc, j0, j1, i0, i1)`` arrays, one entry per (arc, column range).
    """
    lon0, lat0 = arcs.cap_lonlat  # once per set of arcs
    r = (reach + arcs.half) * (1.0 + _REL) + _ABS
    # rows: centre latitudes decrease with the row
    neg = -lat
    j0 = np.searchsorted(neg, -(lat0 + r), side="left")
    j1 = np.searchsorted(neg, -(lat0 - r), side="right")
    # the arcs whose box has rows (j0 <= j1 always): on a grid that covers a band of
    # latitudes (a tile), most arcs have none, and an empty box holds no cell; the rest in
    # their order, so the entries are the same, less those of no cell
    idx = np.flatnonzero(j1 > j0)
    if len(idx) < len(j0):
        lon0, lat0, r, j0, j1 = (x[idx] for x in (lon0, lat0, r, j0, j1))
    else:
        idx = np.arange(len(j0))
    # columns: the cap's longitude half-width, or all of them where it holds a pole
    polar = (np.abs(lat0) + r >= 0.5 * math.pi) | (r >= 0.5 * math.pi)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.sin(np.minimum(r, 0.5 * math.pi)) / np.cos(lat0)
    dl = np.where(polar, math.pi, pad(np.arcsin(np.clip(s, 0.0, 1.0)), _REL, _ABS))
    out = []
    full = polar | (dl >= math.pi)
    if full.any():
        k = np.flatnonzero(full)
        out.append((idx[k], j0[k], j1[k], np.zeros(len(k), int), np.full(len(k), len(lon))))
    part = np.flatnonzero(~full)
    west, east = lon0[part] - dl[part], lon0[part] + dl[part]
    for turn in (-2.0 * math.pi, 0.0, 2.0 * math.pi):
        # only the ranges that reach the columns are searched: one that ends before the
        # first column (or starts after the last) has i1 = 0 (i0 = w), so no column
        if len(lon) == 0:
            reach_ = part[:0]
        elif turn == 0.0:
            reach_ = np.flatnonzero((east >= lon[0]) & (west <= lon[-1]))
        else:  # few ranges wrap: a superset unshifted (by far more than the roundings),
            # then the test of the shifted ranges on it alone
            wraps = east >= lon[0] - turn - 1e-9 if turn < 0 else west <= lon[-1] - turn + 1e-9
            near = np.flatnonzero(wraps)
            reach_ = near[(east[near] + turn >= lon[0]) & (west[near] + turn <= lon[-1])]
        k = part[reach_]
        lo, hi = west[reach_] + turn, east[reach_] + turn
        i0 = np.searchsorted(lon, lo, side="left")
        i1 = np.searchsorted(lon, hi, side="right")
        ok = i1 > i0
        k = k[ok]
        out.append((idx[k], j0[k], j1[k], i0[ok], i1[ok]))
    return tuple(np.concatenate([o[t] for o in out]) for t in range(5))


def _plan(arcs: CurveArcs, grid, e: float, level: int):
    """The geometry of ``level`` and its boxes (see :func:`_boxes`)."""
    lat, lon, rho, spacing = _levels_geometry(grid, level)
    row_reach = np.maximum(e + rho, spacing)
    return (lat, lon, rho, spacing, row_reach), _boxes(arcs, lat, lon, float(row_reach.max()))


def start_level(arcs: CurveArcs, grid, e: float, finest: int):
    """``(level, plan)``: the finest level ``<= finest`` whose box enumeration stays
    within :data:`PAIRS_PER_ARC` pairs per arc and its geometry and boxes (for
    :func:`scatter`), or ``(None, None)`` (start with the hierarchy)."""
    if len(arcs.a) == 0 or not grid.lonlat:
        return None, None
    budget = PAIRS_PER_ARC * len(arcs.a) + 4096
    for level in range(finest, -1, -1):
        plan = _plan(arcs, grid, e, level)
        _, j0, j1, i0, i1 = plan[1]
        if int(((j1 - j0) * (i1 - i0)).sum()) <= budget:
            return level, plan
    return None, None


class BoxPairs(NamedTuple):
    """The box pairs as :func:`scatter` takes them from a finder called with ``near``
    (:func:`box_pairs`, :func:`gloffset.raster.gpu.gpu_box_pairs`)."""

    cell: np.ndarray  # (pairs,) int64 or uint32: row * width + column
    arc: np.ndarray  # (pairs,) int64 or uint32
    cm: np.ndarray  # (pairs,) float64: c.m of the cell's centre and the arc's cap centre
    hit: np.ndarray | None  # which ring edges cross the short arc to the predecessor
    near: np.ndarray  # (pairs,) bool: within the cap test of the row's second reach


def box_pairs(arcs: CurveArcs, lat, lon, row_reach, boxes, w: int, *, near=None):
    """``(row, column, arc, cm)`` of every cell of every box (:func:`_boxes`) that passes
    the cap test ``cap_within(cm, row_reach[row] + half[arc])``, ``cm`` the float64 dot
    product of the cell's centre and the arc's cap centre (``w``: the level's width; the
    numpy path, in box order; :func:`gloffset.raster.gpu.gpu_box_pairs` is the same pairs
    from a compute shader, in any order). No two pairs share a cell and an arc.

    With ``near`` (per row, a second reach), a :class:`BoxPairs` instead (``hit`` None),
    its ``near`` the same cap test with ``near`` for ``row_reach``."""
    a_idx, j0, j1, i0, i1 = boxes
    nc = i1 - i0
    count = (j1 - j0) * nc
    # a box's values spread over its cells with np.repeat (far cheaper than gathers by
    # a box index per cell); the cell's offset in its box gives its row and column
    ncb = np.repeat(nc, count)
    off = np.arange(len(ncb)) - np.repeat(np.cumsum(count) - count, count)
    q = off // ncb
    jj = np.repeat(j0, count) + q
    ii = np.repeat(i0, count) + (off - q * ncb)
    ai = np.repeat(a_idx, count)
    cphi, sphi = np.cos(lat), np.sin(lat)
    clam, slam = np.cos(lon), np.sin(lon)
    m = arcs.mid[a_idx]
    m0, m1, m2 = (np.repeat(m[:, k], count) for k in range(3))
    cm = cphi[jj] * (clam[ii] * m0 + slam[ii] * m1) + sphi[jj] * m2
    keep = np.flatnonzero(
        cap_within_pairs(
            cm, row_reach, jj, arcs.half, ai, runs=(a_idx, count), trig=half_trig(arcs)
        )
    )
    jj, ii, ai, cm = jj[keep], ii[keep], ai[keep], cm[keep]
    if near is None:
        return jj, ii, ai, cm
    ok = cap_within_pairs(cm, near, jj, arcs.half, ai, trig=half_trig(arcs))
    return BoxPairs(jj * w + ii, ai, cm, None, ok)


def _by_cell(cell, ai, cm, keep, cells: int, arcs: int):
    """``(cell, ai, cm)`` of the pairs ``keep``, sorted by cell, then arc (``cells``,
    ``arcs``: bounds of the two; cells and arcs int64, from any integer type). The keys
    are unique (no two pairs share a cell and an arc), so any sort gives this order: where
    cell, arc and the pair's index fit 63 bits together, one sort of those packed values
    (several times faster than an argsort of the keys, and its cells and arcs read off the
    sorted values), else an argsort."""
    bi = max(len(cell) - 1, 1).bit_length()
    ba = max(arcs - 1, 1).bit_length()
    if max(cells - 1, 1).bit_length() + ba + bi > 63:
        order = keep[np.argsort(cell[keep].astype(np.int64) * arcs + ai[keep])]
        return cell[order].astype(np.int64), ai[order].astype(np.int64), cm[order]
    every = len(keep) == len(cell)  # keep is then arange(len(cell))
    key = np.left_shift(cell if every else cell[keep], ba + bi, dtype=np.int64)
    key |= np.left_shift(ai if every else ai[keep], bi, dtype=np.int64)
    key |= keep
    key.sort()
    out_cell = key >> (ba + bi)
    out_ai = key >> bi
    out_ai &= (1 << ba) - 1
    key &= (1 << bi) - 1
    return out_cell, out_ai, cm[key]


def scatter(
    shape, arcs: CurveArcs, grid, d: float, level: int, final: bool, *, plan=None, pairs=None
):
    """Classes of every cell of ``level`` and the :class:`Frontier` of its frontier cells.

    ``final``: ``level`` is the output level (decided at the centres); ``plan``: what
    :func:`start_level` gave for this level and distance, if it chose it; ``pairs``: what
    finds the box pairs (:func:`box_pairs`, the default, or a function with its arguments
    and results, such as :func:`gloffset.raster.gpu.gpu_box_pairs`), called with ``near``
    (the candidate lists' reach, ``e + rho``) for a :class:`BoxPairs`; its ``hit``, where
    given, tells which pairs' ring edges cross the short arc from the cell's centre to its
    predecessor's: the crossings the inside statuses take, found there instead of here.
    """
    e = abs(d)
    h, w = grid.level_shape(level)
    (lat, lon, rho, spacing, row_reach), boxes = plan or _plan(arcs, grid, e, level)

    # every cell of every box within the exact cap test (in the finder's order), and
    # which are within e + rho (the candidates)
    found = (pairs or box_pairs)(arcs, lat, lon, row_reach, boxes, w, near=e + rho)
    cell, ai, cm = found.cell, found.arc, found.cm
    cphi, sphi = np.cos(lat), np.sin(lat)
    clam, slam = np.cos(lon), np.sin(lon)

    def center(j, i):
        return np.stack([cphi[j] * clam[i], cphi[j] * slam[i], sphi[j]], axis=-1)

    # inside statuses: predecessor's, toggled by crossings of pred -> cell (in any order)
    status = status_bits(arcs.n_groups, h * w)
    if arcs.n_groups and found.hit is not None:  # the finder's crossings
        hit = np.flatnonzero(found.hit)
        status = row_statuses(shape, arcs, h, w, center(0, 0), cell[hit], ai[hit])
    elif arcs.n_groups:
        ring = np.flatnonzero((arcs.group[ai] >= 0) & (cell > 0))
        pj = cell[ring] // w
        pi_ = cell[ring] - pj * w
        pa = ai[ring]
        within = cap_within_pairs(cm[ring], spacing, pj, arcs.half, pa, trig=half_trig(arcs))
        ring, pj, pi_, pa = ring[within], pj[within], pi_[within], pa[within]
        qj = np.where(pi_ > 0, pj, pj - 1)
        qi = np.where(pi_ > 0, pi_ - 1, 0)
        hit = arcs_cross(center(pj, pi_), center(qj, qi), arcs.a[pa], arcs.b[pa], arcs.n[pa])
        status = row_statuses(shape, arcs, h, w, center(0, 0), cell[ring][hit], pa[hit])

    # candidate lists (within e + rho), sorted by cell, then arc
    cell, ai, cm = _by_cell(cell, ai, cm, np.flatnonzero(found.near), h * w, len(arcs.a))
    dist = np.full(h * w, np.inf)
    dring = np.full(h * w, np.inf)
    low = nearest(arcs, cell, ai, cm, lambda k: center(*np.divmod(cell[k], w)), dist, dring)
    inside = status.any(axis=1)
    cls = decide(dist, dring, inside, np.repeat(rho, w), d, final)
    classes = cls.reshape(h, w)

    # the frontier cells with their candidate pairs (sorted by cell, then arc)
    fr = np.flatnonzero(cls == FRONTIER)
    remap = np.full(h * w, -1)
    remap[fr] = np.arange(len(fr))
    at = remap[cell]  # each pair's frontier cell, -1 for the others
    sel = at >= 0
    fj, fi = fr // w, fr % w
    f = Frontier(
        level, np.column_stack([fj, fi]), center(fj, fi), rho[fj], at[sel], ai[sel], status[fr]
    )
    return classes, prune(f, low[sel], dist[fr], e)
