"""The inside test's geometry kernels and its arc tree (paper Sec. 4.3, Eq. 9).

The kernels test points against arcs packed in rows (crossing, Eq. 9's distance test);
:class:`IndexArcs` is the multiresolution arc tree of a shape (:mod:`gloffset.vector.multires`)
with what :class:`gloffset.index.tree.Index` needs, made once per shape and kept on it.
Accuracy: the crossing bits are those of :func:`gloffset.geometry.sphere.crossing_rule` on
:func:`gloffset.geometry.sphere.dot`; the distance test is accurate to about 1e-16 rad.
"""

from __future__ import annotations

import numpy as np

from ..geometry.caps import arc_cap, chord2, pad
from ..geometry.sphere import angle, cross, crossing_rule, dot, norm, normalize, robust_cross
from ..memo import Memo
from ..vector.multires import full_decomposition

#: Slack (rad) on every error-region and relevance test, far above their rounding.
MARGIN = 1e-13
#: Arcs per block when :class:`IndexArcs` makes its rows (the temporaries fit the cache).
_ROWS = 1 << 14
#: Squared chords to an arc's two ends closer than this (relative) are a tie for
#: :func:`pair_distance`: both angles are taken (far above their rounding, ~1e-15).
_CHORD_TIE = 1e-6


# ---------------------------------------------------------------------- geometry kernels
def crosses(p, x, px, a, b, n, pn=None) -> np.ndarray:
    """Whether the short arc ``p -> x`` crosses arc ``a -> b`` (normal ``n``).

    ``px = p x x``; ``pn = p . n`` if known.

    The half-open rule of :func:`gloffset.geometry.sphere.crossing_rule`: a point on a great
    circle counts as on its left, so an arc through a shared vertex counts once. The
    sides of the ends and of ``x`` use :func:`gloffset.geometry.sphere.dot`, so that a vertex
    shared by two arcs, and an anchor, get the same bits in every test.
    """
    if pn is None:
        pn = dot(p, n)
    return crossing_rule(dot(px, a) >= 0.0, dot(px, b) >= 0.0, pn >= 0.0, dot(x, n) >= 0.0)


def dots(g: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``p`` dotted with each 3-vector of the rows of ``g`` (n, 3k) -> (n, k), in one call.

    Only for tests whose bits need not agree with another computation (the sides of
    shared vertices and of anchors go through :func:`gloffset.geometry.sphere.dot`).
    """
    return np.einsum("ijk,ik->ij", g.reshape(len(g), -1, 3), p)


def within(p, g, chord2, sin_r, pg=None) -> np.ndarray:
    """Eq. 9: is ``p`` within angle ``r`` of the arc? ``g`` holds a, b, n, n x a, b x n.

    In the arc's wedge (``p . (n x a) >= 0`` and ``p . (b x n) >= 0``) the distance is
    ``asin |p . n|``; it is never more than the distance to the nearer end, compared
    through squared chords (exact for tiny angles). ``chord2 = (2 sin(r/2))^2`` and
    ``sin_r = sin(r)`` (2 for ``r >= pi/2``, -1 for a degenerate arc); ``pg``, if
    given, is ``dots(g, p)``. Accurate to about 1e-16 rad.
    """
    if pg is None:
        pg = dots(g, p)
    line = (np.abs(pg[:, 2]) <= sin_r) & (pg[:, 3] >= 0.0) & (pg[:, 4] >= 0.0)
    da = p - g[:, 0:3]
    db = p - g[:, 3:6]
    return (
        line | (np.einsum("ij,ij->i", da, da) <= chord2) | (np.einsum("ij,ij->i", db, db) <= chord2)
    )


def pair_distance(p, g, solid) -> tuple[np.ndarray, np.ndarray]:
    """Distances (rad) from points ``p`` to the arcs of the rows of ``g`` (a, b, n, n x a,
    b x n; ``solid``: not degenerate), one point per row, and ``p . n``.

    The bits of :func:`gloffset.geometry.sphere.arc_distance`, with less work: the wedge
    normals are ``g``'s, each pair takes only the branch it uses, and off the wedge
    :func:`end_distance`.
    """
    n = g[:, 6:9]
    pn = dot(p, n)
    wedge = (dot(p, g[:, 9:12]) >= 0.0) & (dot(p, g[:, 12:15]) >= 0.0) & solid
    out = np.empty(len(p))
    on = np.flatnonzero(wedge)
    pw, pnw = p[on], pn[on]
    out[on] = np.arctan2(np.abs(pnw), norm(pw - pnw[:, None] * n[on]))
    off = np.flatnonzero(~wedge)
    ab = g[off, 0:6]  # the columns used (narrow rows: several times faster than g[off])
    out[off] = end_distance(p[off], ab[:, 0:3], ab[:, 3:6])
    return out, pn


def end_distance(p, a, b) -> np.ndarray:
    """``min(angle(p, a), angle(p, b))`` (:func:`gloffset.geometry.sphere.angle`), the same
    bits, taking only the angle to the nearer end where the squared chords to the ends
    (those ``angle`` takes its square root of) differ by far more than rounding, below a
    right angle (where that angle is well conditioned, so the other end's can only be
    larger); both elsewhere.
    """
    da, db = p - a, p - b
    ca, cb = dot(da, da), dot(db, db)
    near_b = cb < ca
    c = np.where(near_b, cb, ca)
    sm = p + np.where(near_b[:, None], b, a)
    out = 2.0 * np.arctan2(np.sqrt(c), np.sqrt(dot(sm, sm)))
    both = np.flatnonzero((np.abs(ca - cb) <= _CHORD_TIE * c) | (c > 2.0))
    if len(both):
        other = np.where(near_b[both, None], a[both], b[both])
        out[both] = np.minimum(out[both], angle(p[both], other))
    return out


def radius_terms(r: np.ndarray, degenerate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``chord2`` and ``sin_r`` of :func:`within` for angles ``r``."""
    c2 = np.where(r >= np.pi, 5.0, chord2(r))
    sin_r = np.where(r >= 0.5 * np.pi, 2.0, np.sin(np.minimum(r, 0.5 * np.pi)))
    return c2, np.where(degenerate, -1.0, sin_r)


# ---------------------------------------------------------------------- the arc tree
RING, BOUNDARY, INTERNAL = 1, 2, 4  # arc kinds, as bits


class IndexArcs:
    """The arc tree of a full decomposition, with what the index needs (distance-free)."""

    def __init__(self, shape):
        dec = full_decomposition(shape)  # as far as arcs merge, shared with renders
        t = dec.tree
        self.decomposition = dec
        self.top = dec.level_nodes(dec.levels)
        self.levels = dec.levels
        self.a, self.b, self.e = t.a, t.b, t.e
        self.child, self.level = t.child, t.level
        self.internal = t.level > 0
        self.ring = t.group >= 0
        self.boundary = t.boundary
        # per arc, in one row each: a, b, n, n x a, b x n (the exact tests' g); the
        # bounding cap, the middle of the arc and half its length plus its error (padded),
        # with the cap radius' cos, sin (the cap test's); made in cache-sized blocks
        self.g, self.cap = np.empty((len(t.a), 15)), np.empty((len(t.a), 6))
        for s in range(0, len(t.a), _ROWS):
            self._rows(
                slice(s, s + _ROWS), t.a[s : s + _ROWS], t.b[s : s + _ROWS], t.e[s : s + _ROWS]
            )
        self.n = self.g[:, 6:9]
        self.mid, self.cos_rad, self.sin_rad = self.cap[:, 0:3], self.cap[:, 3], self.cap[:, 4]
        self.rad = self.cap[:, 5].copy()
        self.degenerate = np.sum(self.n * self.n, axis=1) < 0.5
        self.solid = dot(self.n, self.n) > 0.5  # arc_distance's own test
        self.kind = (
            np.where(self.ring, RING, 0)
            | np.where(self.boundary, BOUNDARY, 0)
            | np.where(self.internal, INTERNAL, 0)
        ).astype(np.int8)
        self.saus_c2, self.saus_s = radius_terms(t.e + MARGIN, self.degenerate)
        self._ancestors: Memo[np.ndarray] = Memo()

    def _rows(self, rows: slice, a, b, e) -> None:
        """Fill ``rows`` of :attr:`g` and :attr:`cap` for the arcs ``a -> b`` of errors ``e``."""
        n = normalize(robust_cross(a, b))
        g = self.g[rows]
        g[:, 0:3], g[:, 3:6], g[:, 6:9] = a, b, n
        g[:, 9:12], g[:, 12:15] = cross(n, a), cross(b, n)
        mid, half = arc_cap(a, b)
        rad = np.minimum(pad(half + e), np.pi)
        self.cap[rows] = np.column_stack([mid, np.cos(rad), np.sin(rad), rad])

    def ancestors(self, k: int) -> np.ndarray:
        """Return the arc of level ``k`` that stands for every tree node of level ``<= k``.

        Nodes in order, original edges first; -1 for the nodes above level ``k``.
        """
        return self._ancestors.once(k, lambda: self._ancestors_of(k))

    def _ancestors_of(self, k: int) -> np.ndarray:
        count = np.ones(len(self.a), dtype=np.int64)
        first = np.arange(len(self.a))  # each node's first original edge
        for lev in range(1, self.levels + 1):  # children are made before parents
            ids = np.flatnonzero(self.level == lev)
            count[ids] = count[self.child[ids, 0]] + count[self.child[ids, 1]]
            first[ids] = first[self.child[ids, 0]]
        cut = self.decomposition.level_nodes(k)
        by_edge = np.repeat(cut, count[cut])
        return np.where(self.level <= k, by_edge[first], -1)


def arc_tree(shape) -> IndexArcs:
    return shape.derived.once("contains_arcs", lambda: IndexArcs(shape))
