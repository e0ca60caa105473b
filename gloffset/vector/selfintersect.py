"""Self-intersection removal: from the raw offset to the true boundary of the offset region.

The raw offset of Sec. 4.1 (:class:`gloffset.Offset`) loops over itself at concave
corners, and the offsets of separate parts overlap (paper Fig. 10d). Two methods
turn it into the boundary of the offset region

* ``R = {inside a polygon, or within d of a curve}`` for ``d > 0``,
* ``R = {inside a polygon and farther than |d| from every curve}`` for ``d < 0``:

``method="paper"``
    Algorithm 1 of Sec. 4.4 as published: per raw ring, each arc ``i`` is
    intersected with the later, non-adjacent arcs ``k`` (planes, then the sphere,
    keeping points on both arcs, the one nearest arc ``i``'s first end point);
    the ``j`` that maximises ``(j - i) mod |Q|/2`` wins and the arcs between are
    removed, or, when ``j - i >= |Q|/2``, the arcs outside ``i .. j`` (the wrap
    around case). Candidate ``k`` come from a cap hierarchy instead of a scan of
    all ``k``, which changes nothing: arcs whose caps do not meet cannot meet.
    What the paper leaves open stays open: rings are not united, no holes are
    made, and a loop that needs more than ``|Q|/2`` arcs removed is mishandled.

``method="general"`` (the default)
    The boundary of ``R`` is made of pieces of raw arcs, and along a raw arc the
    question "is this point on the boundary" changes answer only where another
    raw arc crosses it. So: arcs that lie wholly within ``|d| - margin`` of the
    curves are dropped first (a range query per arc on a
    :class:`~gloffset.captree.CapTree` of the edges), and so are the joins of
    concave corners, which always lie within ``|d|`` of the two edges there; the
    others are intersected pairwise (candidate pairs from a cap tree of the arcs,
    so the cost follows the number of nearby pairs, not n^2) and split at the
    crossings; a piece is kept when its middle point lies at ``|d|`` from the
    curves (nothing closer, exact float64 point-to-arc distances as in
    :mod:`gloffset.reference`); kept pieces are linked at their end points into
    closed rings (where several meet, in and out pieces are paired in clockwise
    order so that rings touch without crossing), and rings are sorted into
    exteriors and holes by crossing parity from a point outside the region.

Robustness. Intersections are computed from angular radii
(:func:`gloffset.vector.smallcircle.intersect`), which keeps circles of radius ``|d|``
accurate however small ``|d|`` is, and come with an error bound; an intersection
within its bound of an arc's end point is that end point, so a crossing near a
junction is never lost between the two arcs that meet there, and points closer
than :data:`MERGE_TOL` are one node. Where two edge arcs meet at a concave corner
their circles nearly coincide, so that crossing is found in closed form instead.
A piece is dropped when a curve comes closer than ``|d| - DOUBT_EPS`` to its
middle and is certain when none comes closer than ``|d| - KEEP_EPS``; pieces in
between lie within 1e-11 rad of the boundary and are kept only where they close up
into rings with certain pieces (open chains and rings made only of such pieces are
dropped). Two pieces between the same nodes that lie within 1e-9 rad of each other
are one boundary, or, run in opposite directions, a zero-width sliver that goes.
Certain pieces that still fail to close into rings are counted in
:attr:`ResolvedOffset.unlinked` (0 in every test and benchmark).

Input. Polygons are expected not to overlap and rings not to cross themselves;
both are detected, and then every piece is also checked with the inside test and
(for crossing edges) both sides of every ring are offset, so that the result is the
reference region (inside by crossing parity) in every case. A seam without a
partner across the antimeridian is offset and counted as boundary, as the raw
offset does (the reference ignores it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import crossings
from ..caps import arc_cap
from ..captree import CapTree
from ..errors import InvalidDistanceError
from ..sphere import angle, arc_distance, arcs_cross, normalize, robust_cross, rotate
from .offset import DEFAULT_TOLERANCE, ArcRings, OffsetRing, _circle, _ring_arcs, sample_rings
from .smallcircle import Arcs, circle_of, intersect, point_at, position, sweep

__all__ = ["METHODS", "ResolvedOffset", "resolve", "algorithm1"]

METHODS = ("general", "paper")
#: Points closer than this (radians, 6.4 micrometres on the Earth) are one node.
MERGE_TOL = 1e-12
#: A piece of arc is dropped when a curve is closer than ``|d| - DOUBT_EPS`` to its middle,
#: and certain when none is closer than ``|d| - KEEP_EPS`` (in between: in doubt).
DOUBT_EPS = 1e-11
KEEP_EPS = 2e-15
#: Arcs within ``|d| - PRUNE_MARGIN`` of the curves everywhere are dropped before intersecting.
PRUNE_MARGIN = 1e-12
#: Smallest ``|d|`` (radians) the general method accepts (6.4 mm on the Earth).
MIN_DISTANCE = 1e-9


# ----------------------------------------------------------------------------- result


@dataclass
class ResolvedOffset(ArcRings):
    """The boundary of an offset region: closed rings of small-circle arcs.

    Attributes
    ----------
    distance : float
        Signed angular distance (radians).
    method : str
        ``"general"`` or ``"paper"``.
    rings : list of :class:`gloffset.vector.offset.OffsetRing`
        Closed rings with the region on their left; arc ``k`` of a ring runs from
        ``junctions[k-1]`` to ``junctions[k]`` about ``centers[k]`` (Eq. 1), and
        ``kind``/``sources`` name the vertex or edge it keeps its distance from.
    holes : (len(rings),) bool
        True for rings that bound a hole (seen from a point outside the region).
    polygons : list of (int, list of int)
        Exterior ring index and the indices of its holes.
    unlinked : int
        Pieces of boundary that could not be closed into rings (0 unless arcs are
        tangent to within ~1e-12 rad); always 0 for ``method="paper"``.

    Notes
    -----
    Accuracy contract (``method="general"``): every point of every ring lies at
    ``|distance|`` from the curves to 1e-12 rad (the arcs are pieces of raw offset
    arcs, exact to ~1e-15, whose end points are intersections computed to their
    stated error; measured: below 1e-15 rad on all test data); no point of the
    curves is closer than ``|distance| - 1e-12`` to a ring; rings do not cross
    each other or themselves (they may touch at single points); and the region
    they bound equals the reference region (:func:`gloffset.index.contains`) except
    within 1e-9 rad of its boundary: gaps and parts narrower than that are closed
    or dropped rather than kept as slivers. ``method="paper"`` gives what
    Algorithm 1 gives: exact on the loops it handles, no union, no holes.
    """

    distance: float
    method: str
    rings: list
    holes: np.ndarray
    polygons: list
    unlinked: int = 0
    shape: object = None

    def __post_init__(self):
        self._parity = None

    def sample(self, tolerance: float = DEFAULT_TOLERANCE) -> list[np.ndarray]:
        """Densified rings (see :meth:`gloffset.Offset.sample`)."""
        return sample_rings(self.rings, tolerance)

    def contains_xyz(self, p) -> np.ndarray:
        """Whether unit vectors ``p`` (n, 3) lie in the region the rings bound.

        Crossing parity of short great-circle arcs against the rings' small-circle
        arcs: exact for points farther than ~1e-15 rad from every ring.
        """
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        return self._parity_index().contains(p)

    def area(self) -> float:
        """Area of the region in steradians (Gauss-Bonnet on the arcs; ~1e-13 absolute)."""
        if not self.rings:
            return 4.0 * np.pi if self._parity_index().outside_status else 0.0
        arcs, ring_id, first = _ring_table(self.rings)
        left = _left_areas(arcs, ring_id, first)
        ext = [i for i, _ in self.polygons]
        total = sum(left[i] for i in ext)
        total -= sum(4.0 * np.pi - left[j] for _, hs in self.polygons for j in hs)
        return float(total)

    def to_geojson(
        self, *, tolerance: float = DEFAULT_TOLERANCE, digits: int | None = None
    ) -> dict:
        """The region as an RFC 7946 Feature.

        Arcs are densified so that no written edge strays more than ``tolerance``
        (radians) from its arc; rings are cut at the antimeridian, exterior rings
        run counter-clockwise and holes clockwise.
        """
        from ..io.geojson import rings_to_geometry

        props = {"distance_rad": self.distance}
        rings = self.sample(tolerance)
        north = bool(self.contains_xyz(np.array([[0.0, 0.0, 1.0]]))[0])
        if not rings and not north:
            geom = {"type": "MultiPolygon", "coordinates": []}
        else:
            geom = rings_to_geometry(rings, north, digits)
        return {"type": "Feature", "properties": props, "geometry": geom}

    def _parity_index(self):
        if self._parity is None:
            self._parity = _Parity(self.rings, self.shape, self.distance)
        return self._parity

    def __repr__(self) -> str:
        nh = int(np.count_nonzero(self.holes))
        return (
            f"ResolvedOffset({len(self.polygons)} polygons, {len(self.rings) - nh} exteriors, "
            f"{nh} holes, {sum(len(r.centers) for r in self.rings)} arcs, method={self.method!r})"
        )


def resolve(off, method: str = "general") -> ResolvedOffset:
    """Remove self-intersections from a raw offset (paper Sec. 4.4).

    Parameters
    ----------
    off : gloffset.Offset
        The raw offset (:func:`gloffset.vector.offset`).
    method : {"general", "paper"}
        ``"general"``: the exact boundary of the offset region, united over all
        parts, with holes. ``"paper"``: Algorithm 1 as published, ring by ring.

    Returns
    -------
    ResolvedOffset

    Notes
    -----
    Accuracy (``"general"``): see :class:`ResolvedOffset`. Cost: linear in the
    raw arcs for the pruning and the index, plus the number of arc pairs whose
    caps meet among arcs that come within ``|d|`` of the boundary.
    ``|distance|`` must be at least :data:`MIN_DISTANCE`.

    Examples
    --------
    >>> import gloffset
    >>> bay = gloffset.read({"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 10],
    ...     [6, 10], [6, 2], [4, 2], [4, 10], [0, 10], [0, 0]]]})
    >>> res = gloffset.offset(bay, 0.02, radius=1.0).resolve()
    >>> len(res.polygons), int(res.holes.sum())
    (1, 0)
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(map(repr, METHODS))}, got {method!r}")
    d = float(off.distance)
    if abs(d) < MIN_DISTANCE:
        raise InvalidDistanceError(
            f"distance {d!r} rad is too small to resolve (at least {MIN_DISTANCE} rad); "
            "the offset region is then the shape itself"
        )
    if method == "paper":
        return _paper(off)
    return _general(off)


# ----------------------------------------------------------------------------- Algorithm 1


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
    cand = None
    if index and m_all > 3:
        arcs = Arcs.from_rings(q, r)
        cm, cr = arcs.caps()
        ia, ib = CapTree(cm, cr).self_pairs(MERGE_TOL)
        cand = [[] for _ in range(m_all)]
        for a, b in zip(ia.tolist(), ib.tolist()):
            cand[a].append(b)
            cand[b].append(a)
    jr = {k: r[k] for k in range(m_all)}  # junction (end point) of each current arc
    i = 0
    while i <= len(ids) - 3:
        n = len(ids)
        m = n / 2.0
        gi = ids[i]
        start_i = jr[ids[i - 1]]
        if cand is None:
            ks = list(range(i + 2, n - (1 if i == 0 else 0)))
        else:
            pos = {g: p for p, g in enumerate(ids)}
            ks = sorted(
                pos[g]
                for g in cand[gi]
                if g in pos and pos[g] >= i + 2 and not (i == 0 and pos[g] == n - 1)
            )
        j, rhat = None, None
        if ks:
            gk = [ids[k] for k in ks]
            starts = np.array([jr[ids[k - 1]] for k in ks])
            ends = np.array([jr[g] for g in gk])
            pts, ok = _arc_pair_points(
                axis[gi], h[gi], start_i, jr[gi], axis[gk], h[gk], starts, ends
            )
            for t, k in enumerate(ks):
                if not ok[t]:
                    continue
                if rhat is None or (k - i) % m > (j - i) % m:
                    j, rhat = k, pts[t]
        if j is not None:
            if (j - i) < m:
                # arcs i+1 .. j-1 go; arc i now ends (and arc j starts) at r_hat
                jr[gi] = rhat
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


def _paper(off) -> ResolvedOffset:
    rings = []
    for ring in _boundary_rings(off)[0]:
        keep, jr = algorithm1(ring.centers, ring.junctions)
        rings.append(OffsetRing(ring.centers[keep], jr, ring.kind[keep], ring.sources[keep]))
    holes, polygons, par = _classify(rings, off.shape, off.distance)
    res = ResolvedOffset(off.distance, "paper", rings, holes, polygons, 0, off.shape)
    res._parity = par
    return res


# ----------------------------------------------------------------------------- general method


def _boundary_rings(off):
    """The raw rings whose arcs can bound the region, and whether each comes from a line.

    For self-intersecting input the other side of every ring is added too.

    For ``d < 0`` the offset of lines and points (which :class:`~gloffset.Offset`
    leaves out) still carves holes into polygons: their rings at ``|d|`` are added
    reversed, so that the region stays on their left.
    """
    rings = list(off.rings)
    n_shape_rings = len(off.shape.rings)
    from_line = [k >= n_shape_rings for k in range(len(rings))]
    if off.shape.rings and _defects(off.shape)[0]:
        # edges cross: the region (inside by crossing parity) can lie on either side of
        # an edge, so both sides are offset and the inside test picks the pieces
        for ring in off.shape.rings:
            rings.append(_ring_arcs(ring[::-1].copy(), off.distance))
            from_line.append(False)
    if off.distance < 0.0 and off.shape.rings:
        ad = -off.distance
        for line in off.shape.lines:
            if len(line) == 1:
                r = _circle(line[0], ad)
            else:
                there_and_back = np.vstack([line, line[-2:0:-1]])
                r = _ring_arcs(there_and_back, ad, cap_ends=(0, len(line) - 1))
            rev = OffsetRing(
                r.centers[::-1].copy(),
                np.roll(r.junctions[::-1], -1, axis=0),
                r.kind[::-1].copy(),
                r.sources[::-1].copy(),
            )
            rings.append(rev)
            from_line.append(True)
    return rings, np.array(from_line, dtype=bool)


class _Generators:
    """The shape's vertices and edges with a cap hierarchy, for "is a curve closer than t"."""

    def __init__(self, shape):
        e = shape.edges()
        self.a, self.b = e.a, e.b
        self.n = normalize(robust_cross(self.a, self.b))
        self.tree = CapTree(*arc_cap(self.a, self.b), reps=self.a)

    def closer_than(self, p: np.ndarray, thr: np.ndarray) -> np.ndarray:
        """Whether some point of the curves lies closer than ``thr`` to each ``p``.

        Exact in float64 (the distances are those of :func:`gloffset.sphere.arc_distance`,
        error below 1e-15 rad), so decisions are right whenever the distance differs
        from ``thr`` by more than that.
        """
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        thr = np.broadcast_to(np.asarray(thr, dtype=np.float64), (len(p),))
        out = np.zeros(len(p), dtype=bool)
        sel = np.flatnonzero(thr > 0.0)
        if len(sel) == 0:
            return out
        ps, ts = p[sel], thr[sel]
        found = np.zeros(len(sel), dtype=bool)
        # in chunks, to bound the memory of the candidate pairs
        step = 1 << 15
        for s in range(0, len(sel), step):
            qi, ii, done = self.tree.near(ps[s : s + step], ts[s : s + step], stop=ts[s : s + step])
            f = done
            if len(qi):
                dist = arc_distance(ps[s + qi], self.a[ii], self.b[ii], self.n[ii])
                hit = dist < ts[s + qi]
                f[qi[hit]] = True
            found[s : s + step] = f
        out[sel] = found
        return out

    def deficit(self, p: np.ndarray, ad: float) -> tuple[np.ndarray, np.ndarray]:
        """How much closer than ``ad`` the curves come to each ``p``.

        Returns ``(dropped, deficit)``: ``dropped`` where a curve lies closer than
        ``ad - DOUBT_EPS`` (found early, the deficit is then not computed), else the
        exact ``ad - distance`` clipped at 0.
        """
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        dropped = np.zeros(len(p), dtype=bool)
        dist = np.full(len(p), float(ad))
        step = 1 << 15
        for s in range(0, len(p), step):
            ps = p[s : s + step]
            thr = np.full(len(ps), ad - DOUBT_EPS)
            qi, ii, done = self.tree.near(ps, ad, stop=thr)
            if len(qi):
                d = arc_distance(ps[qi], self.a[ii], self.b[ii], self.n[ii])
                np.minimum.at(dist, s + qi, d)
            dropped[s : s + step] = done
        dropped |= dist < ad - DOUBT_EPS
        return dropped, np.where(dropped, np.inf, ad - dist)


def _close_pairs(p: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs of points closer than ``tol`` (chord), by sorting along a generic direction."""
    u = normalize(
        np.array([0.5773502691896258, 0.5773502691896257, 0.577350269189626])
        + 1e-3 * np.array([0.3, -0.7, 0.4])
    )
    key = p @ u
    order = np.argsort(key, kind="stable")
    ks = key[order]
    ps = p[order]
    out_i, out_j = [], []
    s = 1
    while s < len(ps):
        cand = np.flatnonzero(ks[s:] - ks[:-s] <= tol)
        if len(cand) == 0:
            break
        diff = ps[cand] - ps[cand + s]
        close = np.einsum("ij,ij->i", diff, diff) <= tol * tol
        out_i.append(order[cand[close]])
        out_j.append(order[cand[close] + s])
        s += 1
    if not out_i:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(out_i), np.concatenate(out_j)


def _components(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Connected-component labels (the smallest member) of n items joined by pairs (i, j)."""
    lab = np.arange(n, dtype=np.int64)
    if len(i) == 0:
        return lab
    while True:
        li, lj = lab[i], lab[j]
        if np.array_equal(li, lj):
            return lab
        lo = np.minimum(li, lj)
        np.minimum.at(lab, li, lo)
        np.minimum.at(lab, lj, lo)
        while True:  # pointer jumping to the roots
            nxt = lab[lab]
            if np.array_equal(nxt, lab):
                break
            lab = nxt


def _general(off) -> ResolvedOffset:
    d = float(off.distance)
    ad = abs(d)
    shape = off.shape
    raw, from_line_ring = _boundary_rings(off)
    if not raw:
        return ResolvedOffset(d, "general", [], np.zeros(0, bool), [], 0, shape)
    sizes = np.array([len(r.centers) for r in raw])
    first = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    ring_of = np.repeat(np.arange(len(raw)), sizes)
    n_all = int(sizes.sum())
    local = np.arange(n_all) - first[ring_of]
    prev = np.where(local == 0, first[ring_of] + sizes[ring_of] - 1, np.arange(n_all) - 1)
    q_all = np.concatenate([r.centers for r in raw])
    r_all = np.concatenate([r.junctions for r in raw])
    kind_all = np.concatenate([r.kind for r in raw])
    src_all = np.concatenate([r.sources for r in raw])
    axis, h = circle_of(q_all)
    arcs = Arcs(axis, h, r_all[prev], r_all)
    gens = shape.cached("selfintersect.generators", lambda: _Generators(shape))

    # 1. drop arcs that lie wholly within |d| - margin of the curves, and the joins of
    # concave corners, which turn backwards and lie within |d| of the two edges there
    backward = (kind_all == 0) & (arcs.phi * d < 0.0)
    cm, cr = arcs.caps()
    covered = backward.copy()
    covered[~backward] = gens.closer_than(cm[~backward], ad - cr[~backward] - PRUNE_MARGIN)
    alive = np.flatnonzero(~covered)
    if len(alive) == 0:
        return ResolvedOffset(d, "general", [], np.zeros(0, bool), [], 0, shape)
    A = arcs.subset(alive)
    sign = A.sign
    sinr = A.sin_radius
    phi_abs = np.abs(A.phi)
    n_arc = len(alive)

    # 2. candidate pairs from the caps, without ring neighbours: arcs that share a
    # junction only touch there, and the two edge arcs around a join are handled below
    g2l = np.full(n_all, -1, dtype=np.int64)
    g2l[alive] = np.arange(n_arc)
    nxt = np.empty(n_all, dtype=np.int64)
    nxt[prev] = np.arange(n_all)
    before, after, corner = _corners(kind_all, src_all, prev, nxt)
    across = np.full(n_all, -1, dtype=np.int64)
    edge_len = angle(src_all[:, 0], src_all[:, 1])
    # their circles also meet near the antipode of the corner, out of reach of shorter edges
    short = np.minimum(edge_len[before], edge_len[after]) + 3.0 * ad < np.pi - 1e-2
    across[before[short]] = after[short]
    tree = CapTree(cm[alive], cr[alive])
    ia, ib = tree.self_pairs(MERGE_TOL)
    ga, gb = alive[ia], alive[ib]
    neighbours = (prev[ga] == gb) | (prev[gb] == ga) | (across[ga] == gb) | (across[gb] == ga)
    ia, ib = ia[~neighbours], ib[~neighbours]

    # 3. intersections -> events (arc, turn from its start, node)
    # nodes 0 .. n_all-1 are the junctions (node k ends global arc k)
    node_pts = [r_all]
    ev_arc = [np.arange(n_arc), np.arange(n_arc)]
    ev_t = [np.zeros(n_arc), phi_abs]
    ev_node = [prev[alive], alive]
    uni_i, uni_j = [], []
    next_node = n_all
    # at a concave corner the two edge arcs cross near the vertex, where their circles are
    # nearly the same: the point is found in closed form, and what lies past it is covered
    cut_start = np.zeros(n_arc)
    cut_end = phi_abs.copy()
    conc = np.flatnonzero(backward[corner])
    if len(conc):
        b, a = before[conc], after[conc]
        x = _corner_point(axis[b], axis[a], h[b], src_all[corner[conc], 0])
        lb, la = g2l[b], g2l[a]
        both = (lb >= 0) & (la >= 0)
        lb, la, x = lb[both], la[both], x[both]
        zero = np.zeros(len(lb))
        tb, inb, _, _ = _on_arc(A, sign, sinr, phi_abs, lb, x, zero)
        ta, ina, _, _ = _on_arc(A, sign, sinr, phi_abs, la, x, zero)
        k = np.flatnonzero(inb & ina)
        if len(k):
            nid = next_node + np.arange(len(k))
            next_node += len(k)
            node_pts.append(x[k])
            ev_arc += [lb[k], la[k]]
            ev_t += [tb[k], ta[k]]
            ev_node += [nid, nid]
            np.minimum.at(cut_end, lb[k], tb[k])
            np.maximum.at(cut_start, la[k], ta[k])
    if len(ia):
        x, ok, err, coin = intersect(A.axis[ia], A.rho[ia], A.axis[ib], A.rho[ib])
        twin = np.linalg.norm(x[:, 0] - x[:, 1], axis=1) <= MERGE_TOL
        for s in range(2):
            xs = x[:, s]
            ta, ina, sa, ea = _on_arc(A, sign, sinr, phi_abs, ia, xs, err)
            tb, inb, sb, eb = _on_arc(A, sign, sinr, phi_abs, ib, xs, err)
            good = ok & ina & inb
            if s == 1:
                good &= ~twin
            k = np.flatnonzero(good)
            if len(k) == 0:
                continue
            nid = next_node + np.arange(len(k))
            next_node += len(k)
            node_pts.append(xs[k])
            ev_arc += [ia[k], ib[k]]
            ev_t += [ta[k], tb[k]]
            ev_node += [nid, nid]
            for near, arc_idx, which in (
                (sa[k], ia[k], "s"),
                (ea[k], ia[k], "e"),
                (sb[k], ib[k], "s"),
                (eb[k], ib[k], "e"),
            ):
                if near.any():
                    g = alive[arc_idx[near]]
                    uni_i.append(nid[near])
                    uni_j.append(prev[g] if which == "s" else g)
        # coincident circles: split each arc at the other's end points
        kc = np.flatnonzero(coin)
        for a_idx, b_idx in ((ia[kc], ib[kc]), (ib[kc], ia[kc])):
            for pt, node in ((A.start[b_idx], prev[alive[b_idx]]), (A.end[b_idx], alive[b_idx])):
                t, inside_, _, _ = _on_arc(A, sign, sinr, phi_abs, a_idx, pt, np.zeros(len(a_idx)))
                ev_arc.append(a_idx[inside_])
                ev_t.append(t[inside_])
                ev_node.append(node[inside_])
    pts = np.concatenate(node_pts)
    ev_arc = np.concatenate(ev_arc)
    ev_t = np.concatenate(ev_t)
    ev_node = np.concatenate(ev_node)

    # 4. nodes: merge points closer than MERGE_TOL and the end-point relations
    used = np.unique(ev_node)
    ci, cj = _close_pairs(pts[used], MERGE_TOL)
    pi = [used[ci]] + uni_i
    pj = [used[cj]] + uni_j
    lab = _components(
        len(pts), np.concatenate(pi).astype(np.int64), np.concatenate(pj).astype(np.int64)
    )
    ev_node = lab[ev_node]

    # 5. split arcs into pieces between consecutive events
    order = np.lexsort((ev_t, ev_arc))
    ev_arc, ev_t, ev_node = ev_arc[order], ev_t[order], ev_node[order]
    same = ev_arc[1:] == ev_arc[:-1]
    p_arc = ev_arc[:-1][same]
    p_t0, p_t1 = ev_t[:-1][same], ev_t[1:][same]
    p_n0, p_n1 = ev_node[:-1][same], ev_node[1:][same]
    real = (p_n0 != p_n1) & (p_t0 < cut_end[p_arc]) & (p_t1 > cut_start[p_arc])
    p_arc, p_t0, p_t1, p_n0, p_n1 = p_arc[real], p_t0[real], p_t1[real], p_n0[real], p_n1[real]

    # 6. keep the pieces whose middle lies at |d| from the curves (nothing closer)
    mid = point_at(A.axis[p_arc], A.start[p_arc], sign[p_arc] * 0.5 * (p_t0 + p_t1))
    dropped, deficit = gens.deficit(mid, ad)
    kept = ~dropped
    kept &= _side_ok(shape, d, mid, from_line_ring[ring_of[alive[p_arc]]])
    k = np.flatnonzero(kept)
    p_arc, p_t0, p_t1, p_n0, p_n1, mid = p_arc[k], p_t0[k], p_t1[k], p_n0[k], p_n1[k], mid[k]
    # pieces a curve comes closer to than |d| - KEEP_EPS are in doubt: they lie within
    # DOUBT_EPS of the boundary and stay only where they close up with certain pieces
    certain = deficit[k] <= KEEP_EPS
    keep = _dedupe(p_n0, p_n1, mid)
    linked = keep[_prune_dangling(p_n0[keep], p_n1[keep])]
    unlinked = int(np.count_nonzero(certain[keep])) - int(np.count_nonzero(certain[linked]))
    keep = linked
    p_arc, p_t0, p_t1, p_n0, p_n1 = p_arc[keep], p_t0[keep], p_t1[keep], p_n0[keep], p_n1[keep]
    certain = certain[keep]

    # 7. link pieces into rings; a ring made only of doubtful pieces is a sliver
    nxt = _link(A, sign, p_arc, p_t0, p_t1, p_n0, p_n1, pts)
    cycles, open_pieces = _cycles(nxt)
    unlinked += int(np.count_nonzero(certain[open_pieces]))
    rings = []
    for cyc in cycles:
        if not certain[cyc].any():
            continue
        ring = _ring_from_pieces(
            A, alive, q_all, kind_all, src_all, pts, p_arc[cyc], p_t0[cyc], p_t1[cyc], p_n1[cyc]
        )
        if ring is not None:
            rings.append(ring)
    holes, polygons, par = _classify(rings, shape, d)
    res = ResolvedOffset(d, "general", rings, holes, polygons, unlinked, shape)
    res._parity = par
    return res


def _corners(kind, src, prev, nxt):
    """For each join (the one or two vertex arcs of a corner): the edge arcs before and after.

    Returns global indices ``before``, ``after`` and ``corner`` (the join arc next to
    ``before``), one entry per corner whose neighbours are edge arcs.
    """
    join = kind == 0
    second = join & join[prev] & np.all(src[:, 0] == src[prev, 0], axis=1)
    first_arc = np.flatnonzero(join & ~second)
    last_arc = np.where(second[nxt[first_arc]], nxt[first_arc], first_arc)
    b, a = prev[first_arc], nxt[last_arc]
    ok = (kind[b] == 1) & (kind[a] == 1)
    return b[ok], a[ok], first_arc[ok]


def _corner_point(a1, a2, h, p):
    """Where the circles ``(a1, h)`` and ``(a2, h)`` of two edge arcs meet next to their
    common vertex ``p`` (both axes are orthogonal to ``p``); well conditioned however
    small the turn between the edges."""
    m = normalize(a1 + a2)
    beta = h / np.sum(m * a1, axis=-1)
    alpha = np.sqrt(np.maximum(1.0 - beta * beta, 0.0))
    return normalize(alpha[:, None] * p + beta[:, None] * m)


def _on_arc(A, sign, sinr, phi_abs, idx, x, err):
    """Turn of points ``x`` along arcs ``idx`` (clamped), whether on them, near start, near end."""
    t = position(A.axis[idx], A.h[idx], A.start[idx], sign[idx], x)
    tol = (err + MERGE_TOL) / np.maximum(sinr[idx], 1e-300)
    ph = phi_abs[idx]
    t = np.where(t > ph + tol, t - 2.0 * np.pi, t)  # just before the start
    on = (t >= -tol) & (t <= ph + tol)
    near_s = on & (t <= tol)
    near_e = on & (t >= ph - tol)
    return np.clip(t, 0.0, ph), on, near_s, near_e


#: Start points of the inside test of pieces (short arcs: few edges to test per piece).
_SIDE_ANCHORS = 256


def _side_ok(shape, d, mid, from_line):
    """Which pieces lie on the right side of the polygons.

    For valid polygons this follows from the distance alone, except for the offsets
    of lines; where polygons overlap or edges cross, every piece is tested.
    """
    ok = np.ones(len(mid), dtype=bool)
    if shape.n_groups == 0:
        return ok
    check = from_line.copy()
    crossing, overlap = _defects(shape)
    if crossing or (overlap and d > 0.0):
        check[:] = True
    idx = np.flatnonzero(check)
    if len(idx):
        ins = crossings.inside_indexed(shape, mid[idx], anchors=_SIDE_ANCHORS)
        ok[idx] = ~ins if d > 0.0 else ins
    return ok


def _defects(shape) -> tuple[bool, bool]:
    """Whether edges of the shape's rings cross (self-intersecting input), and whether
    a region component lies inside another (overlapping parts). Cached on the shape."""
    return shape.cached("selfintersect.defects", lambda: _find_defects(shape))


def _find_defects(shape) -> tuple[bool, bool]:
    e = shape.edges()
    ring = np.flatnonzero(e.group >= 0)
    a, b = e.a[ring], e.b[ring]
    ia, ib = CapTree(*arc_cap(a, b)).self_pairs()
    # edges that share an end point only touch there
    shared = (
        np.all(a[ia] == a[ib], axis=1)
        | np.all(a[ia] == b[ib], axis=1)
        | np.all(b[ia] == a[ib], axis=1)
        | np.all(b[ia] == b[ib], axis=1)
    )
    ia, ib = ia[~shared], ib[~shared]
    crossing = bool(arcs_cross(a[ia], b[ia], a[ib], b[ib]).any())
    overlap = False
    if not crossing and shape.n_groups > 1:
        # the first vertex of each component, tested against all the other components
        first_ring = np.unique(shape.ring_groups, return_index=True)[1]
        probes = np.array([shape.rings[int(k)][0] for k in first_ring])
        own = shape.ring_groups[first_ring]
        overlap = bool(crossings.inside_indexed(shape, probes, skip=own).any())
    return crossing, overlap


def _dedupe(n0, n1, mid):
    """Drop duplicate pieces (same ends, same place) and cancel opposite twins.

    Two pieces between the same two nodes whose middles are closer than 1e-9 rad are
    the same boundary: run the same way, one is kept; run opposite ways, they bound a
    zero-width sliver (parts that touch, or a gap narrower than 1e-9 rad between
    them) and both go.
    """
    keep = np.ones(len(n0), dtype=bool)
    lo, hi = np.minimum(n0, n1), np.maximum(n0, n1)
    key = lo * (int(max(hi.max(initial=0), 0)) + 1) + hi
    uniq, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
    for g in np.flatnonzero(counts > 1):
        members = np.flatnonzero(inv == g)
        for x in range(len(members)):
            a = members[x]
            if not keep[a]:
                continue
            for y in range(x + 1, len(members)):
                b = members[y]
                if not keep[b] or angle(mid[a], mid[b]) > 1e-9:
                    continue
                if n0[a] == n0[b]:
                    keep[b] = False  # the same piece twice
                else:
                    keep[a] = keep[b] = False  # a zero-width sliver
                    break
    return np.flatnonzero(keep)


def _link(A, sign, p_arc, p_t0, p_t1, p_n0, p_n1, pts):
    """Successor of each piece: the piece that leaves its end node, paired in clockwise order."""
    m = len(p_arc)
    nxt = np.full(m, -1, dtype=np.int64)
    if m == 0:
        return nxt
    n_nodes = int(max(p_n0.max(), p_n1.max())) + 1
    outdeg = np.bincount(p_n0, minlength=n_nodes)
    indeg = np.bincount(p_n1, minlength=n_nodes)
    out_order = np.argsort(p_n0, kind="stable")
    out_first = np.concatenate([[0], np.cumsum(outdeg)])
    simple = (outdeg[p_n1] == 1) & (indeg[p_n1] == 1)
    nxt[simple] = out_order[out_first[p_n1[simple]]]
    busy = np.flatnonzero((indeg >= 1) & (outdeg >= 1) & ((indeg > 1) | (outdeg > 1)))
    if len(busy) == 0:
        return nxt
    in_order = np.argsort(p_n1, kind="stable")
    in_first = np.concatenate([[0], np.cumsum(indeg)])
    curv = sign * A.h / np.maximum(A.sin_radius, 1e-300)  # left-turning geodesic curvature
    for node in busy.tolist():
        outs = out_order[out_first[node] : out_first[node + 1]]
        ins = in_order[in_first[node] : in_first[node + 1]]
        P = pts[node]
        e1 = normalize(np.cross(P, [0.0, 0.0, 1.0] if abs(P[2]) < 0.9 else [1.0, 0.0, 0.0]))
        e2 = np.cross(P, e1)
        po = point_at(A.axis[p_arc[outs]], A.start[p_arc[outs]], sign[p_arc[outs]] * p_t0[outs])
        pi_ = point_at(A.axis[p_arc[ins]], A.start[p_arc[ins]], sign[p_arc[ins]] * p_t1[ins])
        to = sign[p_arc[outs], None] * np.cross(A.axis[p_arc[outs]], po)
        ti = -sign[p_arc[ins], None] * np.cross(A.axis[p_arc[ins]], pi_)
        key_o = np.arctan2(to @ e2, to @ e1) + np.clip(1e-9 * curv[p_arc[outs]], -1e-6, 1e-6)
        key_i = np.arctan2(ti @ e2, ti @ e1) - np.clip(1e-9 * curv[p_arc[ins]], -1e-6, 1e-6)
        items = np.concatenate([ins, outs])
        is_in = np.concatenate([np.ones(len(ins), bool), np.zeros(len(outs), bool)])
        cw = np.argsort(-np.concatenate([key_i, key_o]), kind="stable")
        items, is_in = items[cw], is_in[cw]
        depth = np.cumsum(np.where(is_in, 1, -1))
        start = (int(np.argmin(depth)) + 1) % len(items)
        stack = []
        for t in range(len(items)):
            k = (start + t) % len(items)
            if is_in[k]:
                stack.append(items[k])
            elif stack:
                nxt[stack.pop()] = items[k]
    return nxt


def _prune_dangling(n0, n1):
    """Indices of the pieces left after repeatedly removing those that start where nothing
    arrives or end where nothing leaves (open chains cannot bound a region)."""
    idx = np.arange(len(n0))
    while len(idx):
        size = int(max(n0[idx].max(), n1[idx].max())) + 1
        indeg = np.bincount(n1[idx], minlength=size)
        outdeg = np.bincount(n0[idx], minlength=size)
        ok = (indeg[n0[idx]] > 0) & (outdeg[n1[idx]] > 0)
        if ok.all():
            break
        idx = idx[ok]
    return idx


def _cycles(nxt):
    """Closed cycles of the successor map, and the indices of pieces left on open chains."""
    m = len(nxt)
    seen = np.zeros(m, dtype=bool)
    cycles = []
    # pieces that nothing leads to start open chains: mark them first
    has_pred = np.zeros(m, dtype=bool)
    has_pred[nxt[nxt >= 0]] = True
    unlinked = []
    nl = nxt.tolist()
    for s in np.flatnonzero(~has_pred).tolist():
        e = s
        while e >= 0 and not seen[e]:
            seen[e] = True
            unlinked.append(e)
            e = nl[e]
    for s in range(m):
        if seen[s]:
            continue
        path = []
        e = s
        while e >= 0 and not seen[e]:
            seen[e] = True
            path.append(e)
            e = nl[e]
        if e == s:
            cycles.append(np.array(path, dtype=np.int64))
        else:
            unlinked.extend(path)
    return cycles, np.array(unlinked, dtype=np.int64)


def _ring_from_pieces(A, alive, q_all, kind_all, src_all, pts, arc, t0, t1, n1):
    """An OffsetRing from its pieces, joining consecutive pieces of the same raw arc."""
    m = len(arc)
    if m == 0:
        return None
    # a piece continues the previous one when it is the next part of the same arc
    cont = (arc == np.roll(arc, 1)) & (np.abs(t0 - np.roll(t1, 1)) <= 0.0)
    if cont.all():
        cont[0] = False
    if m > 1:
        # start the ring at a piece that does not continue its predecessor
        s = int(np.flatnonzero(~cont)[0])
        order = (np.arange(m) + s) % m
        arc, n1, cont = arc[order], n1[order], cont[order]
    last = np.append(np.flatnonzero(~cont)[1:] - 1, m - 1)
    g = alive[arc[last]]
    return OffsetRing(q_all[g].copy(), pts[n1[last]].copy(), kind_all[g].copy(), src_all[g].copy())


# ----------------------------------------------------------------------------- rings -> polygons


def _ring_table(rings) -> tuple[Arcs, np.ndarray, np.ndarray]:
    """All arcs of closed rings in one table, the ring of each arc and each ring's first arc."""
    sizes = np.array([len(r.centers) for r in rings], dtype=np.int64)
    q = np.concatenate([r.centers for r in rings])
    end = np.concatenate([r.junctions for r in rings])
    start = np.concatenate([np.roll(r.junctions, 1, axis=0) for r in rings])
    axis, h = circle_of(q)
    first = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    return Arcs(axis, h, start, end), np.repeat(np.arange(len(rings)), sizes), first


def _left_areas(arcs: Arcs, ring_id: np.ndarray, first: np.ndarray) -> np.ndarray:
    """Area on the left of each closed ring of small-circle arcs (Gauss-Bonnet).

    ``2 pi - sum(turn at junctions) - sum(phi cos r)``; accurate to ~1e-15 per arc.
    """
    sgn = arcs.sign
    t_out = sgn[:, None] * normalize(np.cross(arcs.axis, arcs.start))  # leaving each arc's start
    t_in = sgn[:, None] * normalize(np.cross(arcs.axis, arcs.end))  # arriving at its end
    nxt = np.arange(len(arcs)) + 1
    last = np.append(first[1:], len(arcs)) - 1
    nxt[last] = first
    t_next = t_out[nxt]
    turn = np.arctan2(
        np.sum(arcs.end * np.cross(t_in, t_next), axis=1), np.sum(t_in * t_next, axis=1)
    )
    per_arc = arcs.phi * np.cos(arcs.rho) + turn
    total = np.add.reduceat(per_arc, first) if len(first) else np.zeros(0)
    return (2.0 * np.pi - total) % (4.0 * np.pi)


def _probes(arcs: Arcs, ring_id: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per ring: a point just left of the middle of its longest arc (so on the region's
    side of it), and that arc's index."""
    length = arcs.length
    order = np.lexsort((-length, ring_id))
    firsts = np.flatnonzero(np.r_[True, ring_id[order][1:] != ring_id[order][:-1]])
    k = order[firsts]
    m = point_at(arcs.axis[k], arcs.start[k], 0.5 * arcs.phi[k])
    eps = np.minimum(1e-9, 0.01 * length[k])
    # left of an arc turning counter-clockwise about its axis is towards the axis
    side = normalize(np.cross(arcs.axis[k], m))
    return rotate(m, side, -arcs.sign[k] * eps), k


def _classify(rings, shape, d):
    """Holes and polygons: a ring bounds a hole when a point outside the region lies on its left.

    Returns ``(holes, polygons, parity)``; each hole goes to the smallest exterior
    whose left side holds it.
    """
    par = _Parity(rings, shape, d)
    n = len(rings)
    if n == 0:
        return np.zeros(0, bool), [], par
    probes, _ = _probes(par.arcs, par.ring_id, n)
    # probe k lies on the left of ring k: an even number of crossings of ring k on the way
    # from the outside point puts that point on the left too
    own = np.arange(n)
    holes = ~par.ring_parity(probes, own)
    areas = _left_areas(par.arcs, par.ring_id, par.first)
    ext = np.flatnonzero(~holes)
    polygons = {int(i): [] for i in ext}
    hole_idx = np.flatnonzero(holes)
    if len(hole_idx):
        # candidate owners: exteriors whose bounding cap holds the hole's probe
        caps_c, caps_r = par.ring_caps()
        pj, pi = [], []
        for j in hole_idx.tolist():
            near = ext[angle(caps_c[ext], probes[j]) <= caps_r[ext] + 1e-12]
            pj.append(np.full(len(near), j))
            pi.append(near)
        pj = np.concatenate(pj).astype(np.int64)
        pi = np.concatenate(pi).astype(np.int64)
        inside = par.ring_parity(probes[pj], pi) if len(pj) else np.zeros(0, bool)
        for j in hole_idx.tolist():
            owners = pi[(pj == j) & inside]
            if len(owners):
                polygons[int(owners[np.argmin(areas[owners])])].append(j)
            else:  # nothing around it: the region holds the outside point's far side
                polygons[j] = []
    return holes, [(i, hs) for i, hs in polygons.items()], par


class _Parity:
    """Crossing parity against the rings, from a point known to lie outside the region.

    The outside point ``X`` (checked with the reference predicate, away from the
    boundary) is joined to a fixed set of anchor points by short great-circle arcs;
    the parity of each anchor, per ring, is accumulated along that tree, so a query
    only needs the short arc from a nearby anchor. A query whose arc passes within
    rounding of a junction, or touches a circle, is repeated from the next anchor.
    """

    _N_ANCHORS = 128
    _TRIES = 6

    def __init__(self, rings, shape, d):
        self.rings = rings
        self.n = len(rings)
        if self.n:
            self.arcs, self.ring_id, self.first = _ring_table(rings)
            cm, cr = self.arcs.caps()
            self.tree = CapTree(cm, cr)
        self.outside_status = False
        self.root = self._outside_point(shape, d)
        anchors = _fibonacci(self._N_ANCHORS)
        order = np.argsort(-(anchors @ self.root))
        pts = np.vstack([self.root[None], anchors[order]])
        parent = np.zeros(len(pts), dtype=np.int64)
        for k in range(2, len(pts)):  # each anchor hangs from the nearest earlier point
            parent[k] = int(np.argmax(pts[:k] @ pts[k]))
        self.anchors = pts
        self.anchor_par = np.zeros((len(pts), max(self.n, 1)), dtype=bool)
        if self.n:
            seg_par = self._hop_parity(pts[parent[1:]], pts[1:])
            for k in range(1, len(pts)):
                self.anchor_par[k] = self.anchor_par[parent[k]] ^ seg_par[k - 1]

    def _hop_parity(self, a, b) -> np.ndarray:
        """(len(a), n rings) parities of the hops a -> b; a degenerate hop (the anchors are
        fixed points) goes round through a nudged middle point instead."""
        out = np.zeros((len(a), self.n), dtype=bool)
        keys, odd, bad = self._crossings(a, b)
        good = ~bad[keys // self.n]
        np.bitwise_xor.at(out, (keys[good & odd] // self.n, keys[good & odd] % self.n), True)
        for k in np.flatnonzero(bad).tolist():
            for nudge in (1e-7, -3e-7, 7e-7, -1e-6):
                mid = normalize(a[k] + b[k] + nudge * np.array([1.0, -2.0, 3.0]))[None]
                k1, o1, b1 = self._crossings(a[k][None], mid)
                k2, o2, b2 = self._crossings(mid, b[k][None])
                if not (b1[0] or b2[0]):
                    break
            rings = np.concatenate([k1[o1], k2[o2]]) % self.n
            np.bitwise_xor.at(out[k], rings, True)
        return out

    def _outside_point(self, shape, d):
        """A point outside the region, farther than 1e-10 rad from its boundary."""
        from ..reference import contains_xyz, distance_xyz

        def candidates():
            if self.n:
                for k in np.argsort(-self.arcs.length)[:8]:
                    m = point_at(self.arcs.axis[k], self.arcs.start[k], 0.5 * self.arcs.phi[k])
                    side = normalize(np.cross(self.arcs.axis[k], m))
                    for eps in (min(0.5 * abs(d), 1e-2), 1e-5, 1e-8):
                        yield rotate(m, side, self.arcs.sign[k] * eps)
            yield from _fibonacci(32)

        for x in candidates():
            x = x[None]
            if contains_xyz(shape, x, d)[0]:
                continue
            if abs(distance_xyz(shape, x)[0] - abs(d)) > 1e-10:
                return x[0]
        # the region covers every candidate: the whole sphere but tiny holes
        self.outside_status = True
        return _fibonacci(1)[0]

    def ring_caps(self) -> tuple[np.ndarray, np.ndarray]:
        """A bounding cap (centre, radius) of each ring."""
        cm, cr = self.arcs.caps()
        c = normalize(np.add.reduceat(cm, self.first))
        r = np.zeros(self.n)
        np.maximum.at(r, self.ring_id, angle(cm, c[self.ring_id]) + cr)
        return c, r

    def _crossings(self, a, b):
        """Crossings of the arcs ``a[i] -> b[i]`` with the rings.

        Returns ``(keys, odd, degenerate)``: ``keys = i * n + ring`` per candidate
        (segment, arc) pair, ``odd`` whether that arc is crossed an odd number of
        times, and per segment whether a crossing came within rounding of an end
        point or a tangency (its count is then not to be trusted).
        """
        si, ai = self.tree.along(a, b)
        degenerate = np.zeros(len(a), dtype=bool)
        if len(si) == 0:
            return np.zeros(0, np.int64), np.zeros(0, bool), degenerate
        length = angle(a, b)
        nq = normalize(robust_cross(a[si], b[si]))
        x, ok, err, _ = intersect(
            nq, np.full(len(si), 0.5 * np.pi), self.arcs.axis[ai], self.arcs.rho[ai]
        )
        arcs = self.arcs
        sg, ph, sr = arcs.sign[ai], np.abs(arcs.phi[ai]), arcs.sin_radius[ai]
        count = np.zeros(len(si), dtype=np.int64)
        bad = np.zeros(len(si), dtype=bool)
        tol = err + 1e-13
        for s in range(2):
            xs = x[:, s]
            ts = position(nq, np.zeros(len(si)), a[si], 1.0, xs)
            ts = np.where(ts > np.pi, ts - 2.0 * np.pi, ts)
            t = position(arcs.axis[ai], arcs.h[ai], arcs.start[ai], sg, xs)
            t = np.where(t > ph + 0.5 * (2.0 * np.pi - ph), t - 2.0 * np.pi, t)
            on_seg = (ts >= 0.0) & (ts < length[si])
            on_arc = (t >= 0.0) & (t < ph)  # half-open: a junction belongs to the arc it starts
            count += ok & on_seg & on_arc
            near_seg = (ts > -tol) & (ts < length[si] + tol)
            near_arc = (t * sr > -tol) & ((t - ph) * sr < tol)
            edge = (np.abs(ts) <= tol) | (np.abs(ts - length[si]) <= tol)
            edge |= (np.abs(t) * sr <= tol) | (np.abs(t - ph) * sr <= tol)
            bad |= ok & near_seg & near_arc & (edge | (err > 1e-9))
        degenerate[si[bad]] = True
        return si * self.n + self.ring_id[ai], count % 2 == 1, degenerate

    def _paths(self, p):
        """For each point: its anchor and the crossings of the arc from that anchor.

        Returns ``(anchor, keys_odd)`` with ``keys_odd`` the sorted ``i * n + ring``
        keys of the rings crossed an odd number of times on the way.
        """
        order = np.argsort(-(p @ self.anchors.T), axis=1)[:, : self._TRIES]
        anchor = order[:, 0].copy()
        pending = np.arange(len(p))
        out_keys = []
        for attempt in range(self._TRIES):
            a = self.anchors[order[pending, attempt]]
            keys, odd, bad = self._crossings(a, p[pending])
            final = ~bad if attempt < self._TRIES - 1 else np.ones(len(pending), dtype=bool)
            seg = keys // max(self.n, 1)
            use = final[seg] & odd
            ring = keys[use] % self.n
            out_keys.append(pending[seg[use]] * self.n + ring)
            anchor[pending[final]] = order[pending[final], attempt]
            pending = pending[~final]
            if len(pending) == 0:
                break
        keys = np.concatenate(out_keys) if out_keys else np.zeros(0, np.int64)
        uniq, cnt = np.unique(keys, return_counts=True)
        return anchor, uniq[cnt % 2 == 1]

    def ring_parity(self, p, ring) -> np.ndarray:
        """Parity of the crossings of ring ``ring[i]`` on the way from the outside point
        to ``p[i]``."""
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        ring = np.asarray(ring, dtype=np.int64)
        anchor, odd_keys = self._paths(p)
        want = np.arange(len(p)) * self.n + ring
        hit = np.isin(want, odd_keys)
        return self.anchor_par[anchor, ring] ^ hit

    def contains(self, p) -> np.ndarray:
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        if self.n == 0:
            return np.full(len(p), self.outside_status)
        out = np.zeros(len(p), dtype=bool)
        total = np.count_nonzero(self.anchor_par, axis=1) % 2 == 1
        step = 1 << 14
        for s in range(0, len(p), step):
            ps = p[s : s + step]
            anchor, odd_keys = self._paths(ps)
            crossed = np.bincount(odd_keys // self.n, minlength=len(ps)) % 2 == 1
            out[s : s + step] = total[anchor] ^ crossed ^ self.outside_status
        return out


def _fibonacci(n: int) -> np.ndarray:
    """n well spread unit vectors (a Fibonacci lattice), slightly rotated off the axes."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    lon = np.pi * (1.0 + 5.0**0.5) * k + 0.1234
    rho = np.sqrt(1.0 - z * z)
    return np.column_stack([rho * np.cos(lon), rho * np.sin(lon), z])
