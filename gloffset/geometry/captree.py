"""A hierarchy of bounding caps over a sequence of items: the index behind pair and range queries.

Items of a curve (its edges, the arcs of its offset) come in an order that is
coherent in space, so the hierarchy needs no sorting: level 0 holds one cap per
item and node ``i`` of level ``k`` bounds items ``i 2^k .. (i+1) 2^k - 1``. Each
node's cap is the smallest cap that contains its two children's caps.

Queries walk the levels from the top, all queries at once (numpy arrays of
``(query, node)`` or ``(node, node)`` pairs), and drop a pair as soon as the two
caps are provably too far apart. Caps are compared through chords, which keep
their accuracy for tiny caps, and every radius is padded by a few ulp, so a pair
that can meet is never dropped: the queries return a superset of the true
answer, to be confirmed by an exact test.

Cost: building is O(n). A query costs O(log n) levels; the work per level is the
number of surviving pairs, about the size of the answer plus the number of nodes
the query's cap touches on each level. The pairs of items among themselves
(:meth:`CapTree.self_pairs`) come instead from a grid of cubes over the caps of the
nodes of level 1 (:func:`_grid_pairs`): a few sorts and searches, then the same chord
test per pair of items.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..memo import Memo, once_attr
from .caps import arc_cap, chord, pad
from .sphere import angle, arc_distance, normalize, robust_cross, slerp

__all__ = ["CapTree"]

# Points as their three coordinates: a (3, n) array, or three (n,) arrays
_Rows = np.ndarray | Sequence[np.ndarray]

# Caps are padded by this (radians, absolute and relative) to stay conservative.
_PAD = 1e-14

# CapTree.along walks this many segments at a time (a few 100k pairs per level at most)
_ALONG_BLOCK = 2048

# CapTree.self_pairs puts the nodes of this level in its grid (pairs of items: fewer balls)
_PAIR_LEVEL = 1
# CapTree.self_pairs tests the pairs of items this many at a time
_PAIR_BLOCK = 1 << 16


def _chord2_at(u_t: _Rows, ui: np.ndarray, v_t: _Rows, vi: np.ndarray) -> np.ndarray:
    """Squared chords ``|u[ui] - v[vi]|^2`` with the bits of ``np.einsum`` on the
    differences' rows (its sum, ``(x0^2 + x2^2) + x1^2``), from the points' three
    coordinates ``u_t``, ``v_t`` ((3, n) rows), gathered coordinate by coordinate (no
    (k, 3) copies: several times faster for a million pairs)."""
    d0 = u_t[0][ui] - v_t[0][vi]
    d1 = u_t[1][ui] - v_t[1][vi]
    d2 = u_t[2][ui] - v_t[2][vi]
    return (d0 * d0 + d2 * d2) + d1 * d1


def _reduce_levels(values: np.ndarray, op, depth: int) -> list:
    """Per-level reductions (max or min) of leaf values over the binary hierarchy."""
    out = [values]
    v = values
    for _ in range(depth - 1):
        m = len(v) // 2
        w = op(v[0 : 2 * m : 2], v[1 : 2 * m : 2])
        if len(v) % 2:
            w = np.concatenate([w, v[-1:]])
        out.append(w)
        v = w
    return out


def _query_ranges(depth: int, lo, hi, stop) -> tuple[list | None, list | None]:
    """:meth:`CapTree.near`'s item ranges per node of its query tree (``depth`` levels):
    the least ``lo`` and the greatest ``hi`` of each node's queries; None without them."""
    if lo is None:
        return None, None
    if stop is not None:
        raise ValueError("CapTree.near: item ranges and stop distances do not combine")
    lo_k = _reduce_levels(np.asarray(lo, np.int64), np.minimum, depth)
    return lo_k, _reduce_levels(np.asarray(hi, np.int64), np.maximum, depth)


def _merge_caps(c1, r1, c2, r2):
    """Smallest caps containing each pair of caps (vectorised)."""
    theta = angle(c1, c2)
    r = 0.5 * (theta + r1 + r2)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(theta > 0.0, (r - r1) / np.where(theta > 0.0, theta, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    far = theta > np.pi - 1e-6  # nearly antipodal centres: SLERP is undefined
    if far.any():  # from c1 to itself there (an angle of 0, exactly)
        c = slerp(
            c1, np.where(far[:, None], c1, c2), np.where(far, 0.0, t), np.where(far, 0.0, theta)
        )
    else:
        c = slerp(c1, c2, t, theta)
    r = np.where(far, np.pi, r)
    first = theta + r2 <= r1  # one cap already holds the other
    second = theta + r1 <= r2
    c = np.where(first[:, None], c1, np.where(second[:, None], c2, c))
    r = np.where(first, r1, np.where(second, r2, r))
    return c, np.minimum(pad(r, abs_=_PAD), np.pi)


def _grid_pairs(
    c: np.ndarray, ext: np.ndarray, radii: np.ndarray | None = None, slack: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``i < j`` of balls (centres ``c`` on the unit sphere, radii ``ext`` in
    chord units) whose boxes may meet: a superset of those with
    ``|c_i - c_j| <= ext_i + ext_j``. With ``radii`` (the caps' angular radii, padded),
    only the pairs that pass the chord test of :meth:`CapTree.self_pairs`,
    ``|c_i - c_j| <= pad(chord(r_i + r_j + slack))``, taken block by block on the
    centres as the grid holds them (gathered in order, not at random).

    Cells are cubes of side ``h_k = h_0 2^k``; a ball goes to the first level whose
    side is at least its diameter, and into the cell of its centre. A ball of level
    ``k`` is compared with the balls of lower levels in the cells of level ``k`` next to
    its own that its reach (its radius plus the largest radius of those levels, at
    most ``h_k``) touches, and with the balls of its own level in the cells that come
    after its own in the order of the keys (and in its own cell those of greater
    index): a pair that meets lies within the reach of each of its two balls, so it is
    met from the first of them, once. Rounding: the scaled coordinates ``(c + 1) / h``
    are good to ``4e-16 / h`` cell widths (``h >= 1e-5``), and the reach is widened by
    ``1e-6`` relative and ``1e-7`` cell widths absolute, far above that. The cells of
    level ``k`` are those of level 0 shifted by ``k`` bits: ``(c + 1) / h_k`` is
    ``(c + 1) / h_0`` scaled by a power of 2, exactly, so its floor is the same.
    """
    h0, order, bounds = _grid_levels(ext)
    c_rows = c.T.copy()
    # the centres and their cells of level 0 in the order of the levels, by coordinate:
    # the balls of level k and those below it are slices
    c_o = [x[order] for x in c_rows]
    cell_o = [np.floor((x + 1.0) / h0).astype(np.int64) for x in c_o]
    out_i: list[np.ndarray] = []
    out_j: list[np.ndarray] = []
    # (dx, dy) columns of cells: all nine below, the four after (0, 0) and (0, 0) itself
    # within the level
    every = [(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]
    after = [(0, 0), (0, 1), (1, -1), (1, 0), (1, 1)]
    for k in range(len(bounds) - 1):
        q = order[bounds[k] : bounds[k + 1]]  # the balls of level k
        if len(q) == 0:
            continue
        h = h0 * 2.0**k
        m = int(np.floor(2.0 / h)) + 3
        uq = [(x[bounds[k] : bounds[k + 1]] + 1.0) / h for x in c_o]
        cell_q = [np.floor(u).astype(np.int64) for u in uq]
        key_q = (cell_q[0] * m + cell_q[1]) * m + cell_q[2]
        by_q = np.argsort(key_q)  # sorted needles: searchsorted's fast path
        q, key_q = q[by_q], key_q[by_q]
        frac = np.stack([(u - cq)[by_q] for u, cq in zip(uq, cell_q)], axis=1)
        level = _Level(q, key_q, frac, h, m)
        _column_pairs(level, q, key_q, after, c_rows, ext, radii, slack, out_i, out_j)
        if bounds[k] > 0:
            t = order[: bounds[k]]  # the balls of lower levels
            cell_t = [x[: bounds[k]] >> k for x in cell_o]
            key_t = (cell_t[0] * m + cell_t[1]) * m + cell_t[2]
            by_key = np.argsort(key_t)  # any order of equal keys: the pairs are a set
            _column_pairs(
                level, t[by_key], key_t[by_key], every, c_rows, ext, radii, slack, out_i, out_j
            )
    if not out_i:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    ii = np.concatenate(out_i)
    jj = np.concatenate(out_j)
    return np.minimum(ii, jj), np.maximum(ii, jj)


def _grid_levels(ext: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """The grid's levels (:func:`_grid_pairs`): the cell side ``h_0`` of level 0, the
    balls in the order of their levels and where each level starts in it."""
    n = len(ext)
    diam = 2.0 * ext * (1.0 + 1e-6) + 1e-12  # two diameters of a level fit a cell
    # the median diameter (any size works, this one makes few levels; np.median would
    # import numpy.ma, 12 ms, at a first read)
    h0 = max(float(np.partition(diam, n // 2)[n // 2]), 1e-5)
    lev = np.zeros(n, np.int64)
    big = diam > h0
    if big.any():
        lev[big] = np.ceil(np.log2(diam[big] / h0)).astype(np.int64)
        while True:  # log2's rounding, made good
            short = diam > h0 * np.exp2(lev)
            if not short.any():
                break
            lev[short] += 1
    top = int(min(lev.max(), np.ceil(np.log2(4.0 / h0)) + 1))
    lev = np.minimum(lev, top)  # cells of side >= 4 hold the whole sphere
    order = np.argsort(lev.astype(np.int16), kind="stable")  # small ints: a radix sort
    return h0, order, np.searchsorted(lev[order], np.arange(top + 2))


@dataclass
class _Level:
    """The balls of one level of the grid, sorted by their cells' keys: their cells'
    keys, their places in their cells (``frac``, in cell widths), the cells' side and
    the keys' base."""

    q: np.ndarray
    key_q: np.ndarray
    frac: np.ndarray
    h: float
    m: int


def _column_pairs(lv, t_sorted, key_sorted, columns, c_rows, ext, radii, slack, out_i, out_j):
    """The pairs of the balls of level ``lv`` with the balls ``t_sorted`` (sorted by
    their cells' keys ``key_sorted``: the level's own, or those of lower levels) in the
    columns of cells ``columns`` around each ball's own (:func:`_grid_pairs`),
    appended to ``out_i``, ``out_j``; ``c_rows``: the centres' three coordinates."""
    q, key_q, frac, h, m = lv.q, lv.key_q, lv.frac, lv.h, lv.m
    same = t_sorted is q
    # the distinct keys and where each starts (with sentinels after the last)
    first = np.ones(len(key_sorted), bool)
    first[1:] = key_sorted[1:] != key_sorted[:-1]
    at = np.flatnonzero(first)
    keys = np.append(key_sorted[at], np.full(3, np.iinfo(np.int64).max))
    at = np.append(at, len(key_sorted))
    if radii is not None:  # the chord test's operands in the grid's order, by coordinate
        c_q = [x[q] for x in c_rows]
        c_t = c_q if same else [x[t_sorted] for x in c_rows]
        r_q, r_t = radii[q], radii[t_sorted]
    reach = (ext[q] + float(ext[t_sorted].max())) / h * (1.0 + 1e-6) + 1e-7
    lo_need = frac < reach[:, None]  # the cell below along each axis
    hi_need = 1.0 - frac < reach[:, None]
    for dx, dy in columns:
        sel = np.ones(len(q), bool)
        for ax, d in ((0, dx), (1, dy)):
            if d < 0:
                sel &= lo_need[:, ax]
            elif d > 0:
                sel &= hi_need[:, ax]
        qs = np.flatnonzero(sel)
        if len(qs) == 0:
            continue
        # the cells z - 1, z, z + 1 of a column are consecutive keys: one range (from z
        # itself in the ball's own column of its own level); the first distinct key >=
        # its start, and those up to its end (at most 3: counted, no second search)
        kq = key_q[qs] + (dx * m + dy) * m
        below = 0 if same and dx == dy == 0 else lo_need[qs, 2]
        u = np.searchsorted(keys[:-3], kq - below, side="left")
        top_key = kq + hi_need[qs, 2]
        u_end = u + (keys[u] <= top_key) + (keys[u + 1] <= top_key)
        u_end += keys[u + 2] <= top_key
        lo = at[u]
        cnt = at[u_end] - lo
        has = cnt > 0
        qs, lo, cnt = qs[has], lo[has], cnt[has]
        if len(qs) == 0:
            continue
        total = int(cnt.sum())
        pos = np.repeat(lo - np.cumsum(cnt) + cnt, cnt) + np.arange(total)
        qq = np.repeat(qs, cnt)
        if same and dx == dy == 0:  # its own cell: each pair from one side
            keep = (key_sorted[pos] != key_q[qq]) | (t_sorted[pos] > q[qq])
            qq, pos = qq[keep], pos[keep]
        if radii is not None:
            lim = pad(chord(r_q[qq] + r_t[pos] + slack))
            keep = _chord2_at(c_q, qq, c_t, pos) <= lim * lim
            qq, pos = qq[keep], pos[keep]
        out_i.append(q[qq])
        out_j.append(t_sorted[pos])


class CapTree:
    """Bounding caps over consecutive runs of items.

    Parameters
    ----------
    centers : (n, 3) array
        Cap centres of the items (unit vectors).
    radii : (n,) array
        Angular radii (radians); each item must lie within its cap.
    reps : (n, 3) array, optional
        A point that lies on each item. Nodes take their first item's point; range
        queries use these points for early answers (see :meth:`near`).
    """

    def __init__(self, centers, radii, reps=None):
        c = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
        r = np.asarray(radii, dtype=np.float64).reshape(-1)
        self.n = len(c)
        self.centers = [c]
        self.radii = [np.minimum(pad(r, abs_=_PAD), np.pi)]
        while len(c) > 1:
            m = len(c) // 2
            cm, rm = _merge_caps(
                c[0 : 2 * m : 2], r[0 : 2 * m : 2], c[1 : 2 * m : 2], r[1 : 2 * m : 2]
            )
            if len(c) % 2:
                cm = np.vstack([cm, c[-1:]])
                rm = np.concatenate([rm, r[-1:]])
            c, r = cm, rm
            self.centers.append(c)
            self.radii.append(r)
        self.reps = None
        if reps is not None:
            reps = np.asarray(reps, dtype=np.float64).reshape(-1, 3)
            self.reps = [reps[:: 1 << k] for k in range(len(self.centers))]

    @property
    def depth(self) -> int:
        return len(self.centers)

    def self_pairs(self, slack: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """All item pairs ``i < j`` whose caps come within ``slack`` of each other.

        Returns two int64 arrays, sorted by ``i`` then ``j``. Exactness: a superset of
        the pairs whose caps overlap (radii are padded by a few ulp); the decision per
        pair is the chord test ``|c_i - c_j| <= pad(chord(r_i + r_j + slack))`` on the
        padded radii, and every pair that passes it is returned.

        Notes
        -----
        The broad phase is a grid of cubes over the unit vectors (:func:`_grid_pairs`),
        not the hierarchy: a hash of cells finds the nearby pairs of 300k edges in a
        few numpy passes, where a walk down the levels makes one pass per level over
        all the surviving node pairs. The grid holds the nodes of level
        :data:`_PAIR_LEVEL` (runs of consecutive items, whose caps hold their items'):
        half as many balls for the edges of a curve, each next to the one after it
        (:func:`_node_pairs`).
        """
        if self.n < 2:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        k = min(_PAIR_LEVEL, self.depth - 1)
        if k > 0:
            ci, cj = self._node_pairs(k, slack)
        else:
            c, r = self.centers[0], self.radii[0]
            ext = chord(r) + 0.5 * chord(min(max(slack, 0.0), np.pi))
            ci, cj = _grid_pairs(c, ext, r, slack)  # the chord test taken in the grid
        order = np.argsort(ci * self.n + cj)  # by i, then j (n^2 < 2^63)
        return ci[order], cj[order]

    def _node_pairs(self, k: int, slack: float) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`self_pairs`'s pairs (unsorted) from a grid over the nodes of level ``k``.

        A node of ``2^k`` items whose cap is no larger than 1.5 times the sum of its
        items' radii (consecutive edges of one ring: not two rings' ends) is one ball of
        the grid; the items of the other nodes are balls of their own. The pairs of
        balls that may hold a pair of items within ``slack``, by the grid's chord test
        on radii padded by ``1e-9`` relative and ``1e-11`` rad: a node's cap holds its
        items' caps (:func:`_merge_caps` pads them), so by the triangle inequality on
        angles two items within ``r_i + r_j + slack`` of each other lie in two balls
        within ``R_a + R_b + slack``, and the padding is far above the roundings of
        those radii and of the items' chord test (a few ulp, 1e-14 rad absolute). Each
        pair of balls gives all the pairs of their items, and each node the pairs of its
        own items; every such pair takes the chord test of the items (the same bits as
        in the grid: its terms commute), which decides.
        """
        n, s = self.n, 1 << k
        r = self.radii[0]
        big = self.radii[k]
        full = n >> k  # the nodes 0 .. full - 1 hold 2^k items each
        node = np.zeros(len(big), bool)
        node[:full] = big[:full] <= 1.5 * r[: full << k].reshape(full, s).sum(axis=1)
        nodes = np.flatnonzero(node)
        items = np.flatnonzero(~np.repeat(node, s)[:n])
        m = len(nodes)
        start = np.concatenate([nodes << k, items])
        c = np.concatenate([self.centers[k][nodes], self.centers[0][items]])
        rb = np.concatenate([big[nodes], r[items]]) * (1.0 + 1e-9) + 1e-11
        ext = chord(rb) + 0.5 * chord(min(max(slack, 0.0), np.pi))
        a, b = _grid_pairs(c, ext, rb, slack)
        # the pairs of items of each pair of balls: node-node, node-item, item-node,
        # item-item, then those within each node
        off = np.arange(s)
        an, bn = a < m, b < m
        out_i, out_j = [], []
        for sel, wa, wb in ((an & bn, s, s), (an & ~bn, s, 1), (~an & bn, 1, s), (~an & ~bn, 1, 1)):
            sa, sb = start[a[sel]], start[b[sel]]
            shape = (len(sa), wa, wb)
            out_i.append(np.broadcast_to(sa[:, None, None] + off[:wa, None], shape).ravel())
            out_j.append(np.broadcast_to(sb[:, None, None] + off[:wb], shape).ravel())
        tu, tv = np.triu_indices(s, 1)
        out_i.append((start[:m, None] + tu).ravel())
        out_j.append((start[:m, None] + tv).ravel())
        i, j = np.concatenate(out_i), np.concatenate(out_j)
        rows = self._rows(0)
        keep = np.empty(len(i), bool)
        # the test a block of pairs at a time: its temporaries stay in the caches (and
        # are not fresh memory for each of its steps)
        for s0 in range(0, len(i), _PAIR_BLOCK):
            x, y = i[s0 : s0 + _PAIR_BLOCK], j[s0 : s0 + _PAIR_BLOCK]
            x[:], y[:] = np.minimum(x, y), np.maximum(x, y)
            lim = pad(chord(r[x] + r[y] + slack))
            keep[s0 : s0 + _PAIR_BLOCK] = _chord2_at(rows, x, rows, y) <= lim * lim
        return i[keep], j[keep]

    def near(self, points, reach, *, stop=None, lo=None, hi=None):
        """Items whose cap comes within ``reach`` of each point.

        Parameters
        ----------
        points : (m, 3) array
        reach : (m,) array or float
            Search radius per point (radians).
        stop : (m,) array, optional
            With ``reps``: a point ``p`` is *done* as soon as a visited node's
            representative point lies closer than ``stop[p]`` to it; its remaining
            pairs are dropped. Use it when any item within ``stop`` answers the query.
        lo, hi : (m,) int arrays, optional
            Only items ``lo[p] <= item < hi[p]`` for point ``p`` (the same pairs as
            without them, less those outside the range: a node of the walk is dropped
            when its items lie outside the ranges of all the queries of its pair).
            Not with ``stop`` (an item out of a query's range would stop it).

        Returns
        -------
        query, item : int64 arrays
            Candidate pairs, a superset of those with the item's cap within reach.
        done : (m,) bool
            Points answered early (only with ``stop``).

        Notes
        -----
        Distances are compared as chords: a cap of radius ``r`` lies within ``reach``
        of ``p`` only if ``|p - c| <= chord(reach) + chord(r)`` (chords are
        subadditive), a test without trigonometry per pair.
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        reach = np.broadcast_to(np.asarray(reach, dtype=np.float64), (len(p),))
        m = len(p)
        if self.n == 0 or m == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(m, dtype=bool)
        use_stop = stop is not None and self.reps is not None
        # the queries get a hierarchy of their own (they come in curve order too): caps
        # around the points alone, the largest reach, and the smallest stop per node
        qt = CapTree(p, np.zeros(m))
        q_rows = [c.T.copy() for c in qt.centers]
        q_reach = _reduce_levels(np.clip(reach, 0.0, np.pi), np.maximum, qt.depth)
        if use_stop:
            st = np.broadcast_to(np.asarray(stop, dtype=np.float64), (m,))
            q_stop = _reduce_levels(np.clip(st, -1.0, np.pi), np.minimum, qt.depth)
        lq, ld = qt.depth - 1, self.depth - 1
        # per query node: chord of its cap plus chord of its reach, and what is left of
        # its smallest stop once its own cap is taken off (chords are subadditive)
        q_chords = [pad(chord(r)) for r in qt.radii]  # the query tree is used once
        d_chords = [self._chords(k) for k in range(self.depth)]
        q_lim = [
            q_chords[k] + np.where(q_reach[k] > 0.0, pad(chord(q_reach[k])), 0.0)
            for k in range(qt.depth)
        ]
        if use_stop:
            q_left = []
            for k in range(qt.depth):
                st_k = q_stop[k]
                s_ch = chord(np.maximum(st_k, 0.0)) * (1.0 - 1e-12)  # rounded down
                q_left.append(np.where(st_k > 0.0, s_ch - q_chords[k], -1.0))
        q_lo, q_hi = _query_ranges(qt.depth, lo, hi, stop)
        q_size = [float(np.mean(qt.radii[k] + q_reach[k])) for k in range(qt.depth)]
        d_size = [float(np.mean(r)) for r in self.radii]
        qi = np.zeros(1, dtype=np.int64)
        di = np.zeros(1, dtype=np.int64)
        done = np.zeros(1, dtype=bool)  # per query node of level lq
        while True:
            if q_lo is not None and q_hi is not None:  # node di holds di 2^ld .. (di+1) 2^ld - 1
                inr = (di << ld < q_hi[lq][qi]) & ((di + 1) << ld > q_lo[lq][qi])
                qi, di = qi[inr], di[inr]
            lim = q_lim[lq][qi] + d_chords[ld][di]
            keep = _chord2_at(q_rows[lq], qi, self._rows(ld), di) <= lim * lim
            qi, di = qi[keep], di[keep]
            if use_stop and len(qi):
                # every query of the node lies closer than its stop to the item's point:
                # |c - rep| + chord(r) < chord(stop) suffices (chords are subadditive)
                left = q_left[lq][qi]
                assert self.reps is not None  # use_stop
                reps = self._rows(ld, "reps")
                hit = (left > 0.0) & (_chord2_at(q_rows[lq], qi, reps, di) < left * left)
                if hit.any():
                    done[qi[hit]] = True
                    keep = ~done[qi]
                    qi, di = qi[keep], di[keep]
            if lq == 0 and ld == 0:
                break
            # split the side whose caps are larger (queries spread far apart go first)
            if lq > 0 and (ld == 0 or q_size[lq] >= d_size[ld]):
                n_next = len(qt.centers[lq - 1])
                qi = np.repeat(2 * qi, 2)
                qi[1::2] += 1
                di = np.repeat(di, 2)
                done = np.repeat(done, 2)[:n_next]
                lq -= 1
                ok = qi < n_next
            else:
                n_next = len(self.centers[ld - 1])
                qi = np.repeat(qi, 2)
                di = np.repeat(2 * di, 2)
                di[1::2] += 1
                ld -= 1
                ok = di < n_next
            if not ok.all():
                qi, di = qi[ok], di[ok]
        out_done = np.zeros(m, dtype=bool)
        if use_stop:
            out_done[:] = done[:m]
            keep = ~out_done[qi]
            qi, di = qi[keep], di[keep]
        return qi, di, out_done

    def _rows(self, k: int, of: str = "centers") -> np.ndarray:
        """The cap centres (or with ``of="reps"`` the points) of level ``k`` as (3, n)
        rows, for gathers coordinate by coordinate (cached)."""
        rows: Memo[np.ndarray] = once_attr(self, "_rows_cache", Memo)
        return rows.once((of, k), lambda: getattr(self, of)[k].T.copy())

    def _chords(self, k: int) -> np.ndarray:
        """Chords of the cap radii of level ``k`` (cached)."""
        chords: Memo[np.ndarray] = once_attr(self, "_chord_cache", Memo)
        return chords.once(k, lambda: pad(chord(self.radii[k])))

    def along(self, a, b, *, lo=None, hi=None) -> tuple[np.ndarray, np.ndarray]:
        """Items whose cap meets the short great-circle arc ``a[i] -> b[i]``.

        Returns ``(segment, item)`` int64 arrays, a superset of the true answer (caps
        are padded). The test per item is the exact distance from the cap centre to
        the segment; per node above the items, two necessary conditions without
        trigonometry (:meth:`_meets_segment`), so long segments only visit the nodes
        along their way. ``lo``, ``hi`` (per segment, optional): only items
        ``lo[i] <= item < hi[i]``.
        """
        a = np.asarray(a, dtype=np.float64).reshape(-1, 3)
        b = np.asarray(b, dtype=np.float64).reshape(-1, 3)
        if self.n == 0 or len(a) == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        n = normalize(robust_cross(a, b))
        mid, half = arc_cap(a, b)
        seg_chord = pad(chord(half), abs_=1e-14)  # the arc lies within half + 2e-15 of mid
        if lo is not None:
            lo, hi = np.asarray(lo, np.int64), np.asarray(hi, np.int64)
        # the walk a block of segments at a time: its pairs' arrays stay in the caches
        # (the pairs come out by segment, then item, as from one walk)
        out = [
            self._along_walk(s, min(s + _ALONG_BLOCK, len(a)), a, b, n, mid, seg_chord, lo, hi)
            for s in range(0, len(a), _ALONG_BLOCK)
        ]
        if len(out) == 1:
            return out[0]
        return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])

    def _along_walk(self, s0, s1, a, b, n, mid, seg_chord, lo, hi):
        """:meth:`along`'s walk down the levels for the segments ``s0 .. s1 - 1``."""
        si = np.arange(s1 - s0, dtype=np.int64)  # the segments from s0 on
        ni = np.zeros(s1 - s0, dtype=np.int64)
        a, b, n, seg_chord = a[s0:s1], b[s0:s1], n[s0:s1], seg_chord[s0:s1]
        # the segments' normals and midpoints as rows of coordinates (gathered by row)
        n_t, mid_t = n.T.copy(), mid[s0:s1].T.copy()
        ranged = lo is not None
        if ranged:
            # a segment enters the walk on the highest level whose nodes hold its items
            # in at most two (its nodes' ancestors only hold them too, and their caps
            # hold those nodes' caps: their tests would drop nothing more)
            lo, hi = np.maximum(lo[s0:s1], 0), np.minimum(hi[s0:s1], self.n)  # items only
            enter = np.full(s1 - s0, self.depth - 1)
            for k in range(self.depth - 2, -1, -1):
                enter[((hi - 1) >> k) - (lo >> k) <= 1] = k
            enter[hi <= lo] = -1  # no items: never
            si, ni = si[:0], ni[:0]
        for k in range(self.depth - 1, -1, -1):
            if ranged:  # node ni of level k holds items ni 2^k .. (ni+1) 2^k - 1
                new = np.flatnonzero(enter == k)
                if len(new):  # the segments entering here, each with its one or two nodes
                    two = ((hi[new] - 1) >> k) > (lo[new] >> k)
                    add_n = np.repeat(lo[new] >> k, 1 + two)
                    add_n[np.cumsum(1 + two)[two] - 1] += 1
                    si = np.concatenate([si, np.repeat(new, 1 + two)])
                    ni = np.concatenate([ni, add_n])
                    by_seg = np.argsort(si, kind="stable")  # two sorted runs merged
                    si, ni = si[by_seg], ni[by_seg]
                inr = (ni << k < hi[si]) & ((ni + 1) << k > lo[si])
                si, ni = si[inr], ni[inr]
            keep = self._meets_segment(k, ni, n_t, mid_t, seg_chord, si)
            si, ni = si[keep], ni[keep]
            if k == 0:  # the items that pass those necessary conditions: the exact test
                c, r = self.centers[0], self.radii[0]
                dist = arc_distance(c[ni], a[si], b[si], n[si])
                keep = dist <= pad(r[ni], abs_=_PAD)
                si, ni = si[keep], ni[keep]
            if k > 0:
                nk = len(self.centers[k - 1])
                si = np.repeat(si, 2)
                ni = np.repeat(2 * ni, 2)
                ni[1::2] += 1
                ok = ni < nk
                if not ok.all():
                    si, ni = si[ok], ni[ok]
        return si + s0, ni

    def _meets_segment(self, k, ni, n_t, mid_t, seg_chord, si) -> np.ndarray:
        """Whether the caps ``ni`` of level ``k`` may meet the arcs ``si`` (unit normals
        ``n_t``, bounding caps of centre ``mid_t`` and chord ``seg_chord``; the normals
        and centres as (3, n) rows): the cap meets the arc's great circle (``|c.n| <=
        sin R``) and the arc's bounding cap (``|c - mid| <= chord R + seg_chord``), ``R``
        the radius padded as :meth:`along`'s item test pads it. Both hold wherever the
        cap meets the arc, so no pair that the exact distance would keep is dropped (the
        bounds are padded well above their rounding, 1e-12 relative)."""
        bounds: Memo[tuple[np.ndarray, np.ndarray]] = once_attr(self, "_segment_bounds", Memo)
        sin_r, chord_r = bounds.once(k, lambda: self._segment_bounds_of(k))
        c_t = self._rows(k)
        # the products of dot(), coordinate by coordinate (gathers of single coordinates)
        cx, cy, cz = c_t[0][ni], c_t[1][ni], c_t[2][ni]
        cn = cx * n_t[0][si] + cy * n_t[1][si] + cz * n_t[2][si]
        dx, dy, dz = cx - mid_t[0][si], cy - mid_t[1][si], cz - mid_t[2][si]
        lim = chord_r[ni] + seg_chord[si]
        return (np.abs(cn) <= sin_r[ni]) & (dx * dx + dy * dy + dz * dz <= lim * lim)

    def _segment_bounds_of(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``pad(sin R)`` (2 from R >= pi/2 on: every great circle) and ``pad(chord R)``
        of the padded radii ``R`` of level ``k``."""
        r = pad(self.radii[k], abs_=_PAD)
        sin_r = np.where(r >= 0.5 * np.pi, 2.0, pad(np.sin(np.minimum(r, 0.5 * np.pi))))
        return sin_r, pad(chord(r))
