"""The children of a level's cells and their candidate pairs, worked in the parents' order.

A refined cell's candidates are its parent's, each tested again against the child's centre
(:func:`gloffset.raster.vector.levels.refine`). Expanding every parent pair to its four
children first and then gathering each pair's centre and arc cap costs seven gathers per
child pair. Here the parent's pairs are walked once per child slot (top-left, top-right,
bottom-left, bottom-right): the arcs' cap centres, radii and the cap tests' bounds are
gathered once per parent pair and shared by the four children, the child's centre is
spread along its parent's run, and only the pairs kept are placed, in the children's
row-major order. The dot products are those of
:func:`~gloffset.geometry.sphere.pair_dots` (same operands, same sum order) and the tests
those of :func:`~gloffset.geometry.caps.cap_within`, so every list, ``c.m`` and status is
the expanded pairs' bit for bit (the tests compare the two). The tables' contiguous
coordinate columns and cap radii's cosines, which the levels' other pair passes gather
from too, are kept here (:func:`columns`, :func:`dots`, :func:`half_trig`).
"""

from __future__ import annotations

import numpy as np

from ...geometry.caps import cap_bounds, cap_within, decide_between
from ...geometry.sphere import column_dots
from ...memo import once_attr

__all__ = ["child_slots", "columns", "dots", "half_trig", "mid_columns", "slot_pairs"]


def child_slots(level_cells: np.ndarray, grid, lev: int):
    """The children at level ``lev`` of the cells ``level_cells`` (rows, columns of level
    ``lev - 1``), sorted row-major: ``(cells, parent, slot)``, ``parent`` each child's
    cell index and ``slot`` (4, k) each parent's child index in slots (0, 0), (0, 1),
    (1, 0), (1, 1) (row, column offsets), -1 where the child lies outside the level."""
    h, w = grid.level_shape(lev)
    k = len(level_cells)
    r2, c2 = 2 * level_cells[:, 0], 2 * level_cells[:, 1]
    rows = np.concatenate([r2, r2, r2 + 1, r2 + 1])
    cols = np.concatenate([c2, c2 + 1, c2, c2 + 1])
    idx = np.flatnonzero((rows < h) & (cols < w))
    rows, cols = rows[idx], cols[idx]
    order = np.lexsort((cols, rows))
    idx = idx[order]
    cells = np.column_stack([rows[order], cols[order]])
    slot = np.full(4 * k, -1, dtype=np.int64)
    slot[idx] = np.arange(len(idx))
    return cells, idx % k if k else idx, slot.reshape(4, k)


def columns(table, name: str = "mid"):
    """The (n, 3) array ``table.<name>`` as three contiguous columns, kept on the table
    (they gather several times faster than the columns of the (n, 3) array)."""
    return once_attr(
        table,
        f"_{name}_columns",
        lambda: tuple(np.ascontiguousarray(getattr(table, name)[:, j]) for j in range(3)),
    )


def mid_columns(arcs):
    """The arcs' cap centres as three contiguous columns (:func:`columns`)."""
    return columns(arcs, "mid")


def half_trig(arcs):
    """``(cos(half), sin(half))`` of the arcs' cap radii, kept on the table (the cap
    tests' bounds without a cosine per arc, :func:`~gloffset.geometry.caps.cap_bounds`)."""
    return once_attr(arcs, "_half_trig", lambda: (np.cos(arcs.half), np.sin(arcs.half)))


def dots(points, idx, table_columns, ai) -> np.ndarray:
    """``points[idx] . table[ai]`` (``table_columns`` its :func:`columns`) with the bits of
    :func:`~gloffset.geometry.sphere.pair_dots`, the points spread along their runs where
    ``idx`` is sorted (a repeat, not a gather)."""
    if len(idx) > 1 and (idx[1:] >= idx[:-1]).all():
        counts = np.diff(np.searchsorted(idx, np.arange(len(points) + 1)))
        spread = [np.repeat(points[:, j], counts) for j in range(3)]
        return column_dots(spread, table_columns, None, ai)
    cols = [np.ascontiguousarray(points[:, j]) for j in range(3)]
    return column_dots(cols, table_columns, idx, ai)


class _Test:
    """A cap test of parent pairs against their children: ``cap_within(cm, first[child] +
    half)``, its per-arc bounds gathered once per parent pair."""

    def __init__(self, first, arcs, arc, half):
        lo, hi = cap_bounds(first, arcs.half, half_trig(arcs))
        self.first, self.half = first, half
        self.lo, self.hi = lo.take(arc), hi.take(arc)

    def __call__(self, cm, ch, pair_cell) -> np.ndarray:
        """The test of the pairs of slot children ``ch`` (by parent), ``c.m`` ``cm``."""

        def exact(u):
            reach = self.first.take(ch).take(pair_cell.take(u)) + self.half.take(u)
            return cap_within(cm.take(u), reach)

        return decide_between(cm, self.lo, self.hi, exact)


def slot_pairs(pair_cell, pair_arc, arcs, c, slot, first, seg=None):
    """The children's candidate pairs from their parents' (``pair_cell`` sorted, into the
    parents; ``pair_arc`` into ``arcs``): those whose cap comes within ``first[child]``
    of the child's centre ``c[child]`` (``cap_within(c.m, first + half)``).

    Returns ``(cell, arc, cm, toggles)``: the kept pairs grouped by child (row-major, each
    child's in its parent's order) with their ``c.m``, and, with ``seg`` (each child's
    distance to its parent's centre), the ring edges whose cap comes within ``seg`` of
    the child ``(child, parent, arc)``, else None."""
    k, n = slot.shape[1], len(c)
    if n == 0 or len(pair_cell) == 0:  # no pair: no bounds to make
        none = np.zeros(0, dtype=np.int64)
        return none, pair_arc[:0], np.zeros(0), None if seg is None else (none, none, none)
    counts = np.bincount(pair_cell, minlength=k)
    m = [col.take(pair_arc) for col in mid_columns(arcs)]
    half = arcs.half.take(pair_arc)
    keep = _Test(first, arcs, pair_arc, half)
    near = None if seg is None else _Test(seg, arcs, pair_arc, half)
    ring = None if seg is None else arcs.group.take(pair_arc) >= 0
    kept, toggles = [], []
    cnt = np.zeros(n, dtype=np.int64)
    for s in range(4):
        ch = slot[s]
        valid = ch >= 0
        chv = np.where(valid, ch, 0) if not valid.all() else ch
        cm = np.repeat(c[:, 0].take(chv), counts) * m[0]
        cm += np.repeat(c[:, 2].take(chv), counts) * m[2]
        cm += np.repeat(c[:, 1].take(chv), counts) * m[1]
        ok = keep(cm, chv, pair_cell)
        inside = None if valid.all() else np.repeat(valid, counts)
        if inside is not None:
            ok &= inside
        if near is not None:
            hit = near(cm, chv, pair_cell) & ring
            t = np.flatnonzero(hit if inside is None else hit & inside)
            toggles.append((chv.take(pair_cell.take(t)), pair_cell.take(t), pair_arc.take(t)))
        ks = np.flatnonzero(ok)
        pk = pair_cell.take(ks)
        per_parent = np.bincount(pk, minlength=k)
        cnt[ch[valid]] = per_parent[valid]
        # kept pairs of the parents before each parent
        kept.append((ks, pk, cm.take(ks), chv, np.cumsum(per_parent) - per_parent))
    start = np.cumsum(cnt) - cnt
    arc = np.empty(int(cnt.sum()), dtype=pair_arc.dtype)
    cmo = np.empty(len(arc))
    for ks, pk, cmk, chv, first_kept in kept:
        pos = (start.take(chv) - first_kept).take(pk) + np.arange(len(ks))
        arc[pos] = pair_arc.take(ks)
        cmo[pos] = cmk
    cell = np.repeat(np.arange(n), cnt)
    if seg is None:
        return cell, arc, cmo, None
    return cell, arc, cmo, tuple(np.concatenate(t) for t in zip(*toggles))
