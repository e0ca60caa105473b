"""The sign of a distance field from each pixel's nearest boundary features.

A pixel centre ``p`` at distance ``delta > 0`` from the boundary has an open disc of
radius ``delta`` with no boundary point, so its inside status is that of the points next
to a nearest point ``x``. Rings have their interior on the left and ``n``, the unit
normal ``normalize(a x b)`` of an edge ``a -> b``, points left. So: ``x`` the foot on an
edge (and on no other): inside iff ``p . n > 0``; ``x`` a vertex ``v`` of the edges ``u
-> v -> w`` (and of no other): inside iff the corner is reflex, ``w . n_uv < 0`` (the
direction from ``v`` to ``p`` makes at least a right angle with both edges: in the
exterior sector of a convex corner, the interior one of a reflex corner).

Every feature within :data:`ETA` of a pixel's least distance is asked, and the pixel is
decided only where they agree. Left undecided: pixels within :data:`NEAR` of the
boundary, pinch vertices, corners next to a seam or a degenerate edge or within
:data:`TURN` of straight, features of lines and points, pixels whose disc may hold a
seam, pixels with no nearest arc; a foot within :data:`LUNE` of an end also asks that
end's corner. The rule is used where the rings' left sides are the crossing parity's
inside (the union's rings; a single component's rings checked once), else every pixel
is undecided. :func:`levels_inside`, the float64 levels' test at distance 0 walked
over the undecided pixels' ancestors alone, settles them: the sign is
``classify_curves(shape, 0, grid)``'s, bit for bit (a pixel at distance 0 is inside).

:class:`Corners` is made once per shape (on its derived cache), :func:`signs` and
:func:`block_signs` are the rule on numpy arrays, ``shaders/lib/field_sign.glsl`` the
same rule in float32. The derivation and the measurements: ``docs/design.md``.
"""

from __future__ import annotations

import math

import numpy as np

from ...edges import CurveArcs, points_inside
from ...geometry.classes import CONTAINED, FRONTIER
from ...geometry.sphere import angle, arc_distance, dot, normalize
from ...memo import once_attr
from .. import driver
from ..vector.curves import CurveCells, classify_curves

__all__ = [
    "ETA",
    "INSIDE",
    "LUNE",
    "NEAR",
    "OUTSIDE",
    "TURN",
    "UNDECIDED",
    "BLOCK_SHIFTS",
    "Corners",
    "block_signs",
    "levels_inside",
    "nearest_signs",
    "signs",
]

#: The answers of the rule per feature and corner.
OUTSIDE, INSIDE, UNDECIDED = 0, 1, 2

#: Pixels at most this far (rad) from the boundary are undecided. The side values
#: ``p . n`` are good to a few 1e-16 (unit normals of ``robust_cross``, their direction
#: good to 1e-15 rad), and ``|p . n| = sin(delta)`` at a foot; the levels' crossing
#: tests are exact for points farther than 1e-15 rad from the edges.
NEAR = 1e-12
#: Features whose exact distance exceeds the least by at most this (rad) are asked too
#: (float64 distances are good to 1e-15 rad, so the true nearest is among them).
ETA = 1e-13
#: A corner whose turn ``|w . n_uv|`` is at most this is undecided (the value is good
#: to 2e-15: normals to 1e-15 rad, a unit dot product to 3e-16).
TURN = 1e-14
#: A foot whose lune values ``p . (n x a)``, ``p . (b x n)`` are at most this near an
#: end also asks that end's corner (the lune tests are good to a few 1e-16).
LUNE = 1e-14
#: A single component's vertex within this (rad) of another ring edge counts as touching.
TOUCH = 1e-9
#: Most seams a shape may have for the rule (each pixel is tested against each).
_MAX_SEAMS = 64
#: Most rings a single component may have for its check (one crossing count each).
_MAX_CHECKED = 4096
#: :func:`levels_inside` runs the whole grid's levels for more than 1 / _WHOLE of its pixels.
_WHOLE = 8
#: :func:`nearest_signs` searches at most this many points (more: all undecided).
_NEAREST_MAX = 4096


class Corners:
    """What the sign rule reads of a shape's arcs (the rows of
    :class:`~gloffset.edges.CurveArcs`, so of the leaves of
    :class:`~gloffset.raster.vector.node_levels.NodeArcs`).

    Attributes
    ----------
    trusted : bool
        Whether the rings' left sides are the crossing parity's inside (see the module
        notes); without it ``ok`` is all False.
    ok : (arcs,) bool
        Ring edges with distance and a direction, of rings of three edges or more.
    corner : (arcs, 2) uint8
        The rule at each edge's start ``a`` and end ``b``: :data:`INSIDE` (reflex
        corner), :data:`OUTSIDE` (convex) or :data:`UNDECIDED` (a pinch, a seam or a
        degenerate edge next to it, nearly straight).
    seam_mid, seam_half : the bounding caps of the seams (a pixel's disc that may hold
        one is undecided).
    """

    def __init__(self, shape):
        arcs = CurveArcs.from_shape(shape)
        m = len(arcs.a)
        self.ok = np.zeros(m, dtype=bool)
        self.corner = np.full((m, 2), UNDECIDED, dtype=np.uint8)
        seam = (arcs.group >= 0) & ~arcs.boundary
        self.seam_mid, self.seam_half = arcs.mid[seam], arcs.half[seam]
        self.trusted = bool(shape.rings) and int(seam.sum()) <= _MAX_SEAMS
        if self.trusted:
            self.trusted = _trusted(shape, arcs)
        if self.trusted:
            self._corners(shape, arcs)
        na, bn = arcs.lunes
        vecs = (arcs.n, na, bn, arcs.a - arcs.b)
        #: ``n``, ``n x a``, ``b x n`` and ``a - b`` of each arc, 12 contiguous columns
        self.columns = [np.ascontiguousarray(v[:, x]) for v in vecs for x in range(3)]

    @property
    def flags(self) -> np.ndarray:
        """(arcs,) uint32, what ``shaders/lib/field_sign.glsl`` reads per arc: bits 0-1
        the corner at ``a``, bits 2-3 at ``b``, bit 4 :attr:`ok`."""
        c = self.corner.astype(np.uint32)
        return c[:, 0] | (c[:, 1] << 2) | (self.ok.astype(np.uint32) << 4)

    def shader_records(self, nodes: int) -> tuple[np.ndarray, np.ndarray]:
        """What ``shaders/field_pixels.comp`` reads for the sign (made once, kept): the
        :attr:`flags` of ``nodes`` nodes ((nodes,) uint32, the arcs' first, 0 for the
        merged nodes after them) and the seams' caps ((k, 4) float32: centre, half
        angle)."""

        def make():
            flags = np.zeros(nodes, dtype=np.uint32)
            flags[: len(self.ok)] = self.flags
            seams = np.zeros((len(self.seam_half), 4), dtype=np.float32)
            seams[:, :3], seams[:, 3] = self.seam_mid, self.seam_half
            return flags, seams

        return once_attr(self, "_shader_records", make)

    @classmethod
    def from_shape(cls, shape) -> Corners:
        """The shape's corner data (made once per shape and kept on it)."""
        return shape.derived.once("field_sign", lambda: cls(shape))

    def _corners(self, shape, arcs: CurveArcs) -> None:
        sizes = np.array([len(r) for r in shape.rings], dtype=np.int64)
        r = int(sizes.sum())  # ring edges come first, ring by ring (Shape.edges)
        start = np.repeat(np.cumsum(sizes) - sizes, sizes)
        size = np.repeat(sizes, sizes)
        j = np.arange(r)
        nxt = start + (j - start + 1) % size
        good = arcs.boundary[:r] & (dot(arcs.n[:r], arcs.n[:r]) > 0.5) & (size >= 3)
        self.ok[:r] = good
        # the corner at the end v of edge j (the start of edge nxt): w = b[nxt]
        turn = dot(arcs.n[:r], arcs.b[nxt])
        rule = np.where(turn < 0.0, INSIDE, OUTSIDE).astype(np.uint8)
        rule[~(np.abs(turn) > TURN) | ~good | ~good[nxt]] = UNDECIDED
        v = np.ascontiguousarray(arcs.b[:r]).view(np.dtype((np.void, 24))).ravel()
        _, inv, count = np.unique(v, return_inverse=True, return_counts=True)
        rule[count[inv.ravel()] > 1] = UNDECIDED  # a vertex of more than one corner
        self.corner[:r, 1] = rule
        self.corner[nxt, 0] = rule


def _trusted(shape, arcs: CurveArcs) -> bool:
    """Whether the rings' left sides are the crossing parity's inside (module notes)."""
    if shape.source is None:  # made by hand: components may overlap, rings cross
        return False
    if shape.n_groups > 1 or any(s.any() for s in shape.ring_seams):
        return True  # the union's rings (gloffset.region): interior on the left
    return _simple_and_oriented(shape, arcs)


def _simple_and_oriented(shape, arcs: CurveArcs) -> bool:
    """Whether one component's rings are disjoint simple curves, each with its left
    side inside by the levels' test (:func:`gloffset.edges.points_inside`).

    Its rings cross nowhere (:mod:`gloffset.region` checks that, or unites them); no
    vertex repeated and none within :data:`TOUCH` of another edge makes them disjoint
    simple closed curves, whose left sides are the same face all along each.
    """
    sizes = np.array([len(r) for r in shape.rings], dtype=np.int64)
    if len(sizes) > _MAX_CHECKED or (sizes < 3).any():
        return False
    r = int(sizes.sum())
    a, b, n = arcs.a[:r], arcs.b[:r], arcs.n[:r]
    v = np.ascontiguousarray(a).view(np.dtype((np.void, 24))).ravel()
    if len(np.unique(v)) < r:
        return False
    start = np.repeat(np.cumsum(sizes) - sizes, sizes)
    size = np.repeat(sizes, sizes)
    j = np.arange(r)
    prv = start + (j - start - 1) % size
    # a vertex near an edge other than its two
    qi, item, _ = arcs.ring_tree.near(a, TOUCH)
    e = arcs.ring[item]
    far = (e != qi) & (e != prv[qi])
    qi, e = qi[far], e[far]
    if len(qi) and (arc_distance(a[qi], a[e], b[e], n[e]) <= TOUCH).any():
        return False
    # a point just left of each ring's longest edge, nearer to it than to any other
    length = angle(a, b)
    first = np.cumsum(sizes) - sizes
    pick = first + np.array(
        [np.argmax(length[s : s + z]) for s, z in zip(first, sizes)], dtype=np.int64
    )
    mid = normalize(a[pick] + b[pick])
    reach = length[pick]
    qi, item, _ = arcs.ring_tree.near(mid, reach)
    e = arcs.ring[item]
    other = e != pick[qi]
    clear = reach.copy()
    np.minimum.at(clear, qi[other], arc_distance(mid[qi[other]], a[e[other]], b[e[other]]))
    eps = np.minimum(0.25 * clear, 1e-6)
    if not (eps > 1e-10).all():
        return False
    q = normalize(np.cos(eps)[:, None] * mid + np.sin(eps)[:, None] * n[pick])
    return bool(points_inside(shape, q).all())


def signs(corners: Corners, arcs: CurveArcs, c, dist, pairs) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(inside, undecided)`` of pixel centres ``c`` from their nearest features.

    Parameters
    ----------
    corners : the shape's :class:`Corners`
    arcs : the shape's :class:`~gloffset.edges.CurveArcs`
    c : (k, 3) float64 pixel centres
    dist : (k,) float64 each pixel's exact distance to the boundary (``inf`` where it
        has none or it is not known: such pixels come back undecided)
    pairs : ``(pixel, arc, d)``: candidate features (arc rows; rows past the arcs',
        merged nodes of the multiresolution tree, count as undecided) with their exact
        distances, the true nearest among them; those within :data:`ETA` of the
        pixel's least are read.

    Returns
    -------
    inside, undecided : (k,) bool
        ``inside`` is exact where ``undecided`` is False: the float64 levels' inside
        status at distance 0 (a pixel at distance 0 is inside, as there).

    Accuracy: see the module notes (the thresholds :data:`NEAR`, :data:`ETA`,
    :data:`TURN`, :data:`LUNE`). An arc's nearer end is the one with the greater
    ``p . a`` (``|p - a|^2 = 2 - 2 p . a``); the two are within ``ETA`` of each other
    only where ``|p . (a - b)| <= ETA`` (a chord squared changes by at most twice its
    angle's change), and both are asked where ``|p . (a - b)| <= 2 ETA``.
    """
    pix, arc, d = pairs
    k = len(c)
    zero = dist == 0.0
    und = ~(dist > NEAR) & ~zero
    und |= ~np.isfinite(dist)
    if not corners.trusted:
        return zero.copy(), ~zero
    sel = np.flatnonzero((d <= dist[pix] + ETA) & ~und[pix] & ~zero[pix])
    pix, arc = pix[sel], arc[sel]
    ok = arc < len(corners.ok)
    ai = np.where(ok, arc, 0)
    ok &= corners.ok[ai]
    col = corners.columns
    p = [np.ascontiguousarray(c[:, x])[pix] for x in range(3)]
    la, lb = _dot3(p, col[3:6], ai), _dot3(p, col[6:9], ai)
    foot = ok & (la >= 0.0) & (lb >= 0.0)
    ans = np.where(_dot3(p, col[0:3], ai) > 0.0, INSIDE, OUTSIDE).astype(np.uint8)
    pab = _dot3(p, col[9:12], ai)  # > 0: a is the nearer end
    end = ok & ~foot
    ans[end] = 3  # no answer yet
    ask_a = np.where(foot, la <= LUNE, end & (pab >= -2.0 * ETA))
    ask_b = np.where(foot, lb <= LUNE, end & (pab <= 2.0 * ETA))
    for ask, at in ((ask_a, 0), (ask_b, 1)):
        rule = corners.corner[ai[ask], at]
        now = ans[ask]
        ans[ask] = np.where((now == 3) | (now == rule), rule, UNDECIDED)
    ans[~ok | (ans == 3)] = UNDECIDED
    seen = np.zeros(k, dtype=np.uint8)
    np.bitwise_or.at(seen, pix, (1 << ans).astype(np.uint8))
    inside = (seen == 1 << INSIDE) | zero
    und |= ~zero & (seen != 1 << INSIDE) & (seen != 1 << OUTSIDE)
    if len(corners.seam_half):
        todo = np.flatnonzero(~und)
        for mid, half in zip(corners.seam_mid, corners.seam_half):
            near = angle(c[todo], mid[None, :]) - half <= dist[todo] + ETA
            und[todo[near]] = True
    return inside & ~und, und


def nearest_signs(shape, c: np.ndarray, near: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(inside, undecided)`` of points ``c`` by :func:`signs`, their nearest
    features found in the arcs' tree.

    ``near`` (k,) float64: a distance (rad) within 1e-9 relative of each point's
    distance to the curves (a point with none finite, or of one at most :data:`NEAR`,
    comes back undecided). Every arc whose cap comes within ``near (1 + 1e-6) + 1e-9``
    is measured with :func:`~gloffset.geometry.sphere.arc_distance` (the float64 walk's
    distance), so the nearest and every feature within :data:`ETA` of it are among
    them: exact as :func:`signs` (the float64 levels' inside status where decided).
    For the few pixels a faster rule leaves open (the GPU's, in float32); all are
    undecided where the shape's :class:`Corners` are not trusted or there are more
    than ``_NEAREST_MAX`` points.
    """
    k = len(c)
    inside, und = np.zeros(k, dtype=bool), np.ones(k, dtype=bool)
    corners = Corners.from_shape(shape)
    ok = np.isfinite(near) & (near > NEAR)
    if not corners.trusted or not ok.any() or k > _NEAREST_MAX:
        return inside, und
    sel = np.flatnonzero(ok)
    arcs = CurveArcs.from_shape(shape)
    qi, item, _ = arcs.tree.near(c[sel], near[sel] * (1.0 + 1e-6) + 1e-9)
    d = arc_distance(c[sel][qi], arcs.a[item], arcs.b[item], arcs.n[item])
    dist = np.full(len(sel), np.inf)
    np.minimum.at(dist, qi, d)
    inside[sel], und[sel] = signs(corners, arcs, c[sel], dist, (qi, item, d))
    return inside, und


def _dot3(p, v, i) -> np.ndarray:
    """``p . v[i]`` for columns ``p`` and columns ``v`` gathered at ``i``."""
    out = p[0] * v[0][i]
    out += p[1] * v[1][i]
    out += p[2] * v[2][i]
    return out


#: The blocks' sizes, largest first: ``2^shift`` output pixels a side.
BLOCK_SHIFTS = (3,)


def block_signs(corners: Corners, arcs: CurveArcs, grid, f, dist, pairs):
    """:func:`signs` of the output pixels ``f.cells`` (centres ``f.centers``), by blocks.

    ``pairs`` sorted by pixel. The pixels are grouped in blocks of ``2^shift`` pixels a
    side (the cells of the level ``shift`` above the output, :data:`BLOCK_SHIFTS`), each
    with one of its pixels as its sample ``s``. A pixel ``q`` of the block nearer to a
    decided ``s`` than ``s``'s distance to the boundary less ``2 NEAR`` (the whole block
    where that distance exceeds ``2 rho``, ``rho`` the block cell's rigorous bound from
    its centre to its pixels' centres; else chords compared, rounded the safe way) lies
    in the open disc about ``s`` that holds no boundary point: it has ``s``'s status, at
    more than ``NEAR`` from the boundary. The
    pixels left go to the next blocks, then one by one. Exact as :func:`signs` (the
    answers it gives where both decide; a pixel in a sample's disc is decided even
    where its own features would leave it open), for about one evaluation per block
    away from the boundary.
    """
    cells = f.cells
    k = len(cells)
    last = grid.n_levels - 1
    if not corners.trusted or k == 0:
        return signs(corners, arcs, f.centers, dist, pairs)
    start = np.r_[0, np.cumsum(np.bincount(pairs[0], minlength=k))]
    inside = np.zeros(k, dtype=bool)
    und = np.ones(k, dtype=bool)
    c = f.centers
    todo = None  # every pixel
    for b in BLOCK_SHIFTS:
        b = min(b, last)
        n = k if todo is None else len(todo)
        if b == 0 or n < 4 << (2 * b):
            continue
        cj, ci = (cells[:, 0], cells[:, 1]) if todo is None else (cells[todo, 0], cells[todo, 1])
        j, i = cj >> b, ci >> b
        j0, i0 = j.min(), i.min()
        key = (j - j0) * (int(i.max() - i0) + 1) + (i - i0)
        rep = np.full(int(key.max()) + 1, -1, dtype=np.int64)
        rep[key] = np.arange(n)  # one pixel of each block (any)
        has = rep >= 0
        local = rep[has]
        s = local if todo is None else todo[local]
        ins_s, und_s = signs(corners, arcs, c[s], dist[s], _pairs_of(pairs, start, s))
        inside[s], und[s] = ins_s, und_s
        # the chord of (dist - 2 NEAR), rounded down; an undecided sample reaches nothing
        reach = 2.0 * np.sin(0.5 * np.clip(dist[s] - 2.0 * NEAR, 0.0, np.pi))
        reach = np.where(und_s, -1.0, reach * reach * (1.0 - 1e-12))
        at = (np.cumsum(has) - 1)[key]  # each pixel's sample
        # a whole block within the sample's disc: |q - s| <= 2 rho of the block's cell
        rho = grid.rho_at(last - b, cells[s, 0] >> b, cells[s, 1] >> b)
        got = (~und_s & (dist[s] > 2.0 * rho + 2.0 * NEAR))[at]
        part = np.flatnonzero(~got)  # else pixel by pixel: the chord to the sample
        cq = c[part] if todo is None else c[todo[part]]
        dq = cq - c[s[at[part]]]
        got[part] = np.einsum("ij,ij->i", dq, dq) < reach[at[part]]
        hit = np.flatnonzero(got) if todo is None else todo[got]
        inside[hit], und[hit] = ins_s[at[got]], False
        got[local] = True  # the samples are done either way
        todo = np.flatnonzero(~got) if todo is None else todo[~got]
    if todo is None:
        return signs(corners, arcs, c, dist, pairs)
    if len(todo):
        ins_r, und_r = signs(corners, arcs, c[todo], dist[todo], _pairs_of(pairs, start, todo))
        inside[todo], und[todo] = ins_r, und_r
    return inside, und


def _pairs_of(pairs, start, which):
    """The pairs (sorted by pixel, pixel ``p``'s at ``start[p]:start[p + 1]``) of the
    pixels ``which``, their pixels renumbered ``0 ..``."""
    pix, arc, d = pairs
    count = start[which + 1] - start[which]
    first = np.cumsum(count) - count
    at = np.repeat(start[which] - first, count) + np.arange(int(count.sum()))
    return np.repeat(np.arange(len(which)), count), arc[at], d[at]


def levels_inside(shape, grid, rows, cols) -> np.ndarray:
    """Return the float64 levels' inside status at distance 0 of output pixels.

    ``classify_curves(shape, 0.0, grid)[0][rows, cols] == CONTAINED``, bit for bit: the
    same levels (:class:`~gloffset.raster.vector.curves.CurveCells`, entered at level 0),
    each refining only the frontier cells that are ancestors of the pixels (a cell's
    status, list and class depend on its parent's alone). Cost: the level 0 and about
    ``levels x pixels`` cells; for more than ``1 / _WHOLE`` of the grid's pixels
    (``max_distance`` leaves those beyond it undecided) the whole grid's levels.
    """
    rows = np.asarray(rows, dtype=np.int64)
    cols = np.asarray(cols, dtype=np.int64)
    out = np.zeros(len(rows), dtype=bool)
    if not len(rows):
        return out
    last = grid.n_levels - 1
    if len(rows) * _WHOLE > math.prod(grid.level_shape(last)):  # the whole grid's levels
        return classify_curves(shape, 0.0, grid)[0][rows, cols] == CONTAINED
    pending = np.arange(len(rows))
    for lev in driver.walk(CurveCells(shape, 0.0, grid), last):
        shift = last - lev.level
        want = ((rows[pending] >> shift) << 32) | (cols[pending] >> shift)
        have = (lev.cells[:, 0].astype(np.int64) << 32) | lev.cells[:, 1]
        order = np.argsort(have, kind="stable")
        at = order[np.searchsorted(have[order], want)]
        cls = lev.cls[at]
        done = cls != FRONTIER
        out[pending[done]] = cls[done] == CONTAINED
        pending = pending[~done]
        if not len(pending):
            break
        lev.keep = np.unique(at[~done])
    return out
