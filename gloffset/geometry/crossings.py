"""Spherical point-in-polygon by crossing parity, right around the poles and across +-180.

A point ``p`` is inside region component ``g`` when the status of a reference point
``r`` (known once per shape, see :meth:`Shape.reference_points`) differs from
``p``'s by the parity of the crossings of the short arc ``p -> r`` with the edges of
``g``. Components are united. Seams take part (they close the rings).

Accuracy: the answer is exact for every point farther than about 1e-15 rad from
the boundary. Crossing tests use the signs of triple products with a half-open
rule (a point on a great circle counts as on its left), so an arc through a shared
vertex is counted once.

:func:`inside` tests every point against every edge (the reference does that);
:func:`inside_indexed` gives the same answers for points off the boundary through the cap
tree of the shape's ring edges (:attr:`gloffset.edges.CurveArcs.ring_tree`, reached
through the shape), testing only the edges near each point's arc (for the many points of
a large shape); on the boundary both are decided by rounding.
"""

from __future__ import annotations

import numpy as np

from .sphere import crossing_rule, dot, robust_cross

__all__ = ["crossings", "group_parity", "inside", "inside_indexed"]

# Work on at most this many point-edge pairs at once (bounded memory, good cache use).
_PAIRS = 1 << 22


def crossings(p: np.ndarray, r: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(len(p), len(a)) bool: does the short arc ``p[i] -> r`` (or ``r[i]``) cross ``a[j] -> b[j]``.

    ``r`` is one point (3,) or one per ``p``. Half-open rule as in
    :func:`gloffset.geometry.sphere.arcs_cross`, written as matrix products.
    """
    pr = np.cross(p, r)
    sa = (pr @ a.T) >= 0.0
    sb = (pr @ b.T) >= 0.0
    # the edge's normal from the robust cross product: a short edge's plain a x b has
    # an absolute error of ~1e-16, which flips the side of points within 1e-16 / length
    ab = robust_cross(a, b)
    sp = (p @ ab.T) >= 0.0
    if r.ndim == 1:
        sr = (ab @ r >= 0.0)[None, :]
    else:
        sr = np.einsum("ij,kj->ik", r, ab) >= 0.0
    return crossing_rule(sa, sb, sp, sr)


def group_parity(p: np.ndarray, r: np.ndarray, edges, group: int) -> np.ndarray:
    """Parity of crossings of arcs ``p[i] -> r`` with the edges of one component."""
    sel = edges.group == group
    return np.count_nonzero(crossings(p, r, edges.a[sel], edges.b[sel]), axis=1) % 2 == 1


def inside(shape, p, *, groups=None) -> np.ndarray:
    """Whether unit vectors ``p`` (n, 3) lie inside the shape's polygons (False for lines).

    ``groups`` restricts the test to some region components. Memory is bounded by
    working in chunks of points.
    """
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    out = np.zeros(len(p), dtype=bool)
    if shape.n_groups == 0:
        return out
    refs, status = shape.reference_points()
    e = shape.edges()
    ring = e.group >= 0
    if groups is not None:
        ring &= np.isin(e.group, groups)
    order = np.flatnonzero(ring)
    order = order[np.argsort(e.group[order], kind="stable")]
    a, b, grp = e.a[order], e.b[order], e.group[order]
    present, starts = np.unique(grp, return_index=True)
    wanted = status[:, present]  # (2, len(present))
    use_second = p @ refs[0] < -0.5
    chunk = max(1, _PAIRS // max(len(a), 1))
    for k in range(2):
        idx = np.flatnonzero(use_second == bool(k))
        for s in range(0, len(idx), chunk):
            ii = idx[s : s + chunk]
            cr = crossings(p[ii], refs[k], a, b).view(np.uint8)
            # parity per component: XOR over each component's run of edges
            par = np.bitwise_xor.reduceat(cr, starts, axis=1).astype(bool)
            out[ii] = (par ^ wanted[k][None, :]).any(axis=1)
    return out


def inside_indexed(shape, p, *, groups=None, skip=None, anchors: int = 0) -> np.ndarray:
    """:func:`inside` through a cap tree of the ring edges: the same answers, without
    testing every point against every edge.

    Only the edges whose bounding caps meet the arc ``p -> r`` (found with
    :meth:`gloffset.geometry.captree.CapTree.along`, a superset of the edges it can cross)
    are tested, with the predicate of :func:`crossings` written out per pair; an
    edge whose cap misses the arc is on one side of it by far more than rounding,
    so it never counts there either. Components the arc does not cross keep the
    reference point's status. Cost: O(log n) per point plus the edges near its arc.
    ``skip`` (one per point, optional) leaves out one more component per point.

    ``anchors > 0``: each point starts instead from the nearest of that many fixed,
    well spread points whose statuses are found once (by arcs to the reference
    points, cached on the shape), so its arc is short and meets few caps. The
    parity is the same wherever the three arcs avoid the edges' end points by more
    than rounding (points off the boundary, as the middles of offset pieces are);
    for points on the boundary itself, leave it at 0.
    """
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    out = np.zeros(len(p), dtype=bool)
    if shape.n_groups == 0 or len(p) == 0:
        return out
    skip = np.full(len(p), -1, np.int64) if skip is None else np.asarray(skip, np.int64)
    n_groups = shape.n_groups
    present = np.zeros(n_groups, dtype=bool)
    arcs = shape.arcs()
    present[arcs.group[arcs.ring]] = True
    if groups is not None:
        keep = np.zeros(n_groups, dtype=bool)
        keep[np.asarray(groups, dtype=np.int64)] = True
        present &= keep
    if anchors > 0:
        starts, state = shape.derived.anchors.once(anchors, lambda: _anchors(shape, anchors))
    else:
        starts, state = shape.reference_points()
    # inside a component: its status at the start point, flipped by odd crossings
    wanted = state & present[None, :]
    n_wanted = np.count_nonzero(wanted, axis=1)
    step = 1 << 15
    for s in range(0, len(p), step):
        ps, sk = p[s : s + step], skip[s : s + step]
        k = _start_of(ps, starts, anchors > 0)
        qi, gi = _odd_crossings(shape, ps, starts[k])
        use = present[gi] & (gi != sk[qi])
        qi, gi = qi[use], gi[use]
        # per point: odd components that were out at the start (now in), and odd
        # components that were in (now out); inside when some component is in
        was_in = wanted[k[qi], gi]
        gained = np.bincount(qi[~was_in], minlength=len(ps))
        lost = np.bincount(qi[was_in], minlength=len(ps))
        n_in = n_wanted[k] - np.where(sk >= 0, wanted[k, np.maximum(sk, 0)], False)
        out[s : s + step] = (gained > 0) | (lost < n_in)
    return out


def _start_of(p, starts, nearest: bool) -> np.ndarray:
    """Which start point each point's arc leaves from: the nearest anchor, or the first
    reference point unless that is more than 120 degrees away (as in :func:`inside`)."""
    if nearest:
        return np.argmax(p @ starts.T, axis=1)
    return (p @ starts[0] < -0.5).astype(np.int64)


def _odd_crossings(shape, p, r) -> tuple[np.ndarray, np.ndarray]:
    """``(point, component)`` pairs whose edges the arcs ``p[i] -> r[i]`` cross an odd
    number of times (the predicate of :func:`crossings`, on the edges near each arc)."""
    arcs = shape.arcs()
    a, b, grp = arcs.a, arcs.b, arcs.group
    n_groups = shape.n_groups
    si, ei = arcs.ring_tree.along(p, r)
    ei = arcs.ring[ei]
    if len(si) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    pr = np.cross(p, r)[si]
    ab = robust_cross(a[ei], b[ei])
    hit = crossing_rule(
        dot(pr, a[ei]) >= 0.0,
        dot(pr, b[ei]) >= 0.0,
        dot(p[si], ab) >= 0.0,
        dot(r[si], ab) >= 0.0,
    )
    keys, counts = np.unique(si[hit] * n_groups + grp[ei[hit]], return_counts=True)
    keys = keys[counts % 2 == 1]
    return keys // n_groups, keys % n_groups


def _anchors(shape, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` fixed, well spread points (a Fibonacci lattice, turned off the axes) and
    their (n, n_groups) statuses, by crossing parity from the reference points."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    lon = np.pi * (1.0 + 5.0**0.5) * k + 0.1234
    rho = np.sqrt(1.0 - z * z)
    pts = np.column_stack([rho * np.cos(lon), rho * np.sin(lon), z])
    refs, status = shape.reference_points()
    k = _start_of(pts, refs, False)
    state = status[k].copy()
    qi, gi = _odd_crossings(shape, pts, refs[k])
    state[qi, gi] ^= True
    return pts, state
