"""Renders whose cost follows the output: the curves simplified to a fraction of a pixel.

A render costs about its (frontier bin, candidate arc) pairs, so an input far finer than
the output's pixels (a 1:10m coastline on a globe of 10 km pixels) pays for arcs the
image cannot show. The multiresolution decomposition (paper Sec. 4.2,
:mod:`gloffset.vector.multires`) gives a coarser curve with a rigorous bound on how far it
is from the original (Sec. 4.3, Eq. 9), and this module renders that curve instead,
then decides exactly the few pixels the bound leaves open.

The decomposition's arcs with ``err <= eps`` make a shape ``S`` whose distances are
within ``eps`` of the original's (:func:`cut`); ``S`` is rendered on the GPU at ``d - t``
and at ``d + t`` (``t = eps`` plus a margin), and the pixels in between, the *band*,
are decided by exact float64 distances to the original arcs.

Accuracy: every pixel outside the band is decided as by the exact distance (the GPU's
own error is inside the margin ``m``), and every band pixel by the exact float64
distance; so the mask equals the float64 reference except, as every GPU render, at
pixels within 1e-3 pixel of a seam's crossing test. Cost: two renders of ``S``, the
decomposition of the shape once (kept on it), and the band (``2 t`` wide: about half
of the pixels along the offset boundary).

:func:`gloffset.render` uses it for GPU masks where it pays: inputs of at least
:data:`MIN_ARCS` arcs whose simplified curve keeps at most :data:`MAX_FRACTION` of them. The
derivation in full: ``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

import numpy as np

from ..edges import CurveArcs
from ..geometry.caps import cap_within
from ..geometry.sphere import arc_distance, dot
from ..shape import Derived, Edges
from ..vector.multires import full_decomposition

__all__ = [
    "MAX_FRACTION",
    "PIXEL_FRACTION",
    "Simplified",
    "cut",
    "band_members",
    "simplified",
    "z_order",
]

#: ``eps`` as a fraction of the (median row's) pixel diameter (a band of about a quarter
#: of a pixel either side of the boundary; :func:`gloffset.raster.render.simplify_eps`).
PIXEL_FRACTION = 0.25
#: A simplified shape is rendered only when it keeps at most this fraction of the arcs.
MAX_FRACTION = 0.35
#: Arcs below which simplifying is never worth its second render.
MIN_ARCS = 2_000


def cut(shape, eps: float) -> np.ndarray:
    """The tree arcs (rows of the decomposition's :attr:`tree`) of the shape simplified
    to ``eps``: from the coarsest level, every arc whose error bound exceeds ``eps``,
    or that is a seam, replaced by the two it was made of, until none is; in the order
    of the curves."""
    dec = full_decomposition(shape)
    tree = dec.tree
    leaf = tree.child[:, 0] < 0
    ok = leaf | ((tree.e <= eps) & tree.boundary)
    cur = dec.level_nodes(dec.levels)
    while True:
        bad = ~ok[cur]
        if not bad.any():
            return cur
        reps = np.where(bad, 2, 1)
        pos = np.cumsum(reps) - reps
        new = np.repeat(cur, reps)
        bi = np.flatnonzero(bad)
        new[pos[bi]] = tree.child[cur[bi], 0]
        new[pos[bi] + 1] = tree.child[cur[bi], 1]
        cur = new


class Simplified:
    """The shape's curves simplified to within ``eps`` (:func:`cut`), as the raster levels
    read a shape: its edges, components and reference points (the original's, valid
    when they lie farther than ``eps`` from every ring edge: :func:`simplified` checks)."""

    def __init__(self, shape, eps: float, nodes: np.ndarray):
        tree = full_decomposition(shape).tree
        self.original, self.eps = shape, eps
        self._edges = Edges(tree.a[nodes], tree.b[nodes], tree.boundary[nodes], tree.group[nodes])
        self.n_groups, self.rings = shape.n_groups, shape.rings
        self.derived = Derived()

    def edges(self) -> Edges:
        return self._edges

    def arcs(self) -> CurveArcs:
        return CurveArcs.from_shape(self)

    def reference_points(self):
        return self.original.reference_points()

    def __len__(self) -> int:
        return len(self._edges.a)


def _clearance(shape) -> float:
    """The least distance (rad) from the shape's reference points to its ring edges,
    seams included (kept on the shape)."""

    def build() -> float:
        arcs = CurveArcs.from_shape(shape)
        ring = arcs.group >= 0
        if not ring.any():
            return np.inf
        refs, _ = shape.reference_points()
        a, b, n = arcs.a[ring], arcs.b[ring], arcs.n[ring]
        return float(min(arc_distance(r, a, b, n).min() for r in refs))

    return shape.derived.once("ref_clearance", build)


def simplified(shape, eps: float) -> Simplified | None:
    """The shape simplified to ``eps`` (rad), or None where that does not pay (fewer than
    :data:`MIN_ARCS` arcs, or more than :data:`MAX_FRACTION` of them kept) or is not
    safe (a reference point within ``eps`` of a ring edge). ``eps`` is rounded down to
    a quarter power of two; the result is kept on the shape, by that ``eps``."""
    if isinstance(shape, Simplified):
        return None  # simplified once
    n = len(shape.edges().a)
    if n < MIN_ARCS or not eps > 0.0:
        return None
    # a quarter power of two at most eps: a smaller eps is as valid, and a long-running
    # process (a tile server's many grids) keeps a few simplified shapes, not one per grid
    eps = float(2.0 ** (np.floor(4.0 * np.log2(eps)) / 4.0))

    def build() -> Simplified | None:
        nodes = cut(shape, eps)
        if len(nodes) > MAX_FRACTION * n or _clearance(shape) <= 2.0 * eps + 1e-12:
            return None
        return Simplified(shape, eps, nodes)

    return shape.derived.simplified.once(eps, build)


def band_members(shape, p: np.ndarray, d: float) -> np.ndarray:
    """Members of the region at signed distance ``d`` (rad) among points ``p`` (unit
    vectors) known to lie outside the polygons for ``d > 0`` (inside for ``d < 0``):
    whether an original boundary arc lies within ``|d|`` (exact float64 distances to
    the arcs whose caps reach, from the cap tree)."""
    arcs = CurveArcs.from_shape(shape)
    e = abs(d)
    within = np.zeros(len(p), dtype=bool)
    step = 1 << 16
    for s in range(0, len(p), step):
        q = p[s : s + step]
        qi, ai, _ = arcs.tree.near(q, e)
        keep = arcs.boundary[ai]
        qi, ai = qi[keep], ai[keep]
        # the cap test first (cheap, never false where it should hold), then the distance
        near = cap_within(dot(q[qi], arcs.mid[ai]), e + arcs.half[ai])
        qi, ai = qi[near], ai[near]
        hit = arc_distance(q[qi], arcs.a[ai], arcs.b[ai], arcs.n[ai]) <= e
        within[s : s + len(q)][qi[hit]] = True
    return within if d > 0 else ~within


def z_order(j: np.ndarray, i: np.ndarray) -> np.ndarray:
    """The Morton (Z-order) key of pixels ``(j, i)`` (each below 2**32): sorted by it,
    pixels near each other come together, as the cap tree's queries want them."""

    def spread(x):
        x = np.asarray(x).astype(np.uint64) & np.uint64(0xFFFFFFFF)
        for shift, mask in (
            (16, 0x0000FFFF0000FFFF),
            (8, 0x00FF00FF00FF00FF),
            (4, 0x0F0F0F0F0F0F0F0F),
            (2, 0x3333333333333333),
            (1, 0x5555555555555555),
        ):
            x = (x | (x << np.uint64(shift))) & np.uint64(mask)
        return x

    return spread(j) | (spread(i) << np.uint64(1))
