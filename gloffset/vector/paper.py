"""Algorithm 1 of the paper (Sec. 4.4): self-intersections removed ring by ring.

``method="paper"`` of :func:`gloffset.vector.selfintersect.resolve`, as published: per
raw ring (Q, R of Eq. 1-4), each arc ``i`` is intersected with the later, non-adjacent
arcs ``k`` (planes, then the sphere, keeping points on both arcs, the one nearest arc
``i``'s first end point); the ``j`` that maximises ``(j - i) mod |Q|/2`` wins and the
arcs between are removed, or, when ``j - i >= |Q|/2``, the arcs outside ``i .. j`` (the
wrap around case). Candidate ``k`` come from a cap hierarchy instead of a scan of all
``k``, which changes nothing: arcs whose caps do not meet cannot meet.

What the paper leaves open stays open: rings are not united, no holes are made (the
rings are only sorted into exteriors and holes, :mod:`gloffset.vector.rings`), and a loop
that needs more than ``|Q|/2`` arcs removed is mishandled. The general method
(:mod:`gloffset.vector.arrangement`) has none of these limits.

Intersections are those of :func:`gloffset.vector.smallcircle.intersect` (from angular
radii, with an error bound); a point within :data:`~gloffset.vector.smallcircle.MERGE_TOL`
of an arc's end counts as on the arc.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry.captree import CapTree
from ..geometry.sphere import angle
from .arcrings import OffsetRing
from .resolved import ResolvedOffset
from .smallcircle import MERGE_TOL, CircleArcs, circle_of, intersect, position, sweep

__all__ = ["algorithm1", "resolve_paper"]


def resolve_paper(off, raw) -> ResolvedOffset:
    """Algorithm 1 on each raw ring of ``raw`` (the rings of ``off`` that can bound the
    region, :func:`gloffset.vector.selfintersect.boundary_rings`)."""
    rings = []
    for ring in raw:
        keep, jr = algorithm1(ring.centers, ring.junctions)
        rings.append(OffsetRing(ring.centers[keep], jr, ring.kind[keep], ring.sources[keep]))
    return ResolvedOffset.from_rings(off.distance, "paper", rings, off.shape)


def algorithm1(centers, junctions, *, index: bool = True):
    """Algorithm 1 of the paper on one closed offset curve (Q, R).

    Parameters
    ----------
    centers, junctions : (m, 3) arrays
        Q and R; arc ``k`` runs from ``R[k-1]`` to ``R[k]`` about ``Q[k]``.
    index : bool
        Find the arcs ``k`` that may meet arc ``i`` with a cap hierarchy (default)
        instead of trying every ``k``; the result is the same.

    Returns
    -------
    keep : (m',) int array
        Indices into the input of the arcs that remain, in order.
    junctions : (m', 3) array
        The new junctions (arc ``k`` of the result ends at ``junctions[k]``).

    Notes
    -----
    The published pseudocode keeps one junction more than arcs when it removes
    ``r_{i+2} .. r_{j-1}`` and replaces ``r_{i+1}``; with R indexed as in Eq. 4
    (``r_i = q_i + q_{i+1}`` ends arc ``i``) the consistent update, used here, is
    that ``r_i .. r_{j-1}`` become the single junction ``r_hat`` (and, in the
    wrap-around case, ``r_j`` becomes ``r_hat``). Direct neighbours are skipped
    for every ``i``, including ``k = |Q| - 1`` when ``i = 0``, as the text says.
    """
    q = np.asarray(centers, dtype=np.float64)
    r = np.asarray(junctions, dtype=np.float64).copy()
    m_all = len(q)
    axis, h = circle_of(q)
    ids = list(range(m_all))  # current arcs, as indices into the input
    cand = _candidates(q, r) if index and m_all > 3 else None
    jr = {k: r[k] for k in range(m_all)}  # junction (end point) of each current arc
    i = 0
    while i <= len(ids) - 3:
        m = len(ids) / 2.0
        ks = _later_arcs(i, ids, cand)
        j, rhat = _farthest_meeting(i, ks, ids, jr, axis, h, m) if ks else (None, None)
        if j is not None:
            if (j - i) < m:
                # arcs i+1 .. j-1 go; arc i now ends (and arc j starts) at r_hat
                jr[ids[i]] = rhat
                del ids[i + 1 : j]
            else:
                # wrap around: only arcs i .. j stay; arc i starts (arc j ends) at r_hat
                jr[ids[j]] = rhat
                ids = ids[i : j + 1]
                i = 0
                continue
        i += 1
    keep = np.array(ids, dtype=np.int64)
    return keep, np.array([jr[g] for g in ids]).reshape(-1, 3)


def _candidates(q, r) -> list[list[int]]:
    """Per arc of the input, the arcs whose bounding caps meet its own (a cap tree)."""
    arcs = CircleArcs.from_rings(q, r)
    cm, cr = arcs.caps()
    ia, ib = CapTree(cm, cr).self_pairs(MERGE_TOL)
    cand: list[list[int]] = [[] for _ in range(len(q))]
    for a, b in zip(ia.tolist(), ib.tolist()):
        cand[a].append(b)
        cand[b].append(a)
    return cand


def _later_arcs(i: int, ids: list, cand) -> list[int]:
    """Positions ``k >= i + 2`` among the current arcs ``ids`` that may meet arc ``i``, in
    order; not ``k = |Q| - 1`` for ``i = 0`` (a direct neighbour). Every such ``k`` without
    candidate lists ``cand``, else those among arc ``i``'s candidates."""
    n = len(ids)
    if cand is None:
        return list(range(i + 2, n - (1 if i == 0 else 0)))
    pos = {g: p for p, g in enumerate(ids)}
    return sorted(
        pos[g]
        for g in cand[ids[i]]
        if g in pos and pos[g] >= i + 2 and not (i == 0 and pos[g] == n - 1)
    )


def _farthest_meeting(i, ks, ids, jr, axis, h, m):
    """Among the positions ``ks``, the ``j`` whose arc meets arc ``i`` and that maximises
    ``(j - i) mod m``, and the meeting point ``r_hat``; ``(None, None)`` if none meets."""
    gi = ids[i]
    gk = [ids[k] for k in ks]
    starts = np.array([jr[ids[k - 1]] for k in ks])
    ends = np.array([jr[g] for g in gk])
    pts, ok = _arc_pair_points(
        axis[gi], h[gi], jr[ids[i - 1]], jr[gi], axis[gk], h[gk], starts, ends
    )
    j, rhat = None, None
    for t, k in enumerate(ks):
        if not ok[t]:
            continue
        if rhat is None or (k - i) % m > (j - i) % m:
            j, rhat = k, pts[t]
    return j, rhat


def _arc_pair_points(a1, h1, s1, e1, a2, h2, s2, e2):
    """Algorithm 1's intersection of arc 1 with each arc 2: the point on both arcs nearest s1."""
    k = len(a2)
    a1b = np.broadcast_to(a1, (k, 3))
    x, ok, err, _ = intersect(a1b, np.full(k, angle(a1, s1)), a2, angle(a2, s2))
    phi1 = sweep(a1, h1, s1, e1)
    phi2 = sweep(a2, h2, s2, e2)
    sg1 = 1.0 if phi1 >= 0 else -1.0
    sg2 = np.where(phi2 >= 0, 1.0, -1.0)
    best = np.full(k, np.inf)
    pts = np.zeros((k, 3))
    sin1 = math.sqrt(max(1.0 - h1 * h1, 0.0))
    sin2 = np.sqrt(np.maximum(1.0 - h2 * h2, 0.0))
    for s in range(2):
        xs = x[:, s]
        t1 = position(a1b, np.full(k, h1), np.broadcast_to(s1, (k, 3)), sg1, xs)
        t2 = position(a2, h2, s2, sg2, xs)
        tol1 = MERGE_TOL / max(sin1, 1e-300)
        tol2 = MERGE_TOL / np.maximum(sin2, 1e-300)
        on1 = (t1 > tol1) & (t1 <= abs(phi1) + tol1)
        on2 = (t2 >= -tol2) & (t2 <= np.abs(phi2) + tol2)
        good = ok & on1 & on2 & (t1 < best)
        best = np.where(good, t1, best)
        pts[good] = xs[good]
    return pts, np.isfinite(best)
