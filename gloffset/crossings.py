"""Spherical point-in-polygon by crossing parity, right around the poles and across +-180.

A point ``p`` is inside region component ``g`` when the status of a reference point
``r`` (known once per shape, see :meth:`Shape.reference_points`) differs from
``p``'s by the parity of the crossings of the short arc ``p -> r`` with the edges of
``g``. Components are united. Seams take part (they close the rings).

Accuracy: the answer is exact for every point farther than about 1e-15 rad from
the boundary. Crossing tests use the signs of triple products with a half-open
rule (a point on a great circle counts as on its left), so an arc through a shared
vertex is counted once.
"""

from __future__ import annotations

import numpy as np

from .sphere import crossing_rule, robust_cross

__all__ = ["crossings", "group_parity", "inside"]

# Work on at most this many point-edge pairs at once (bounded memory, good cache use).
_PAIRS = 1 << 22


def crossings(p: np.ndarray, r: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(len(p), len(a)) bool: does the short arc ``p[i] -> r`` (or ``r[i]``) cross ``a[j] -> b[j]``.

    ``r`` is one point (3,) or one per ``p``. Half-open rule as in
    :func:`gloffset.sphere.arcs_cross`, written as matrix products.
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
