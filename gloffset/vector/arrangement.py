"""The general method of self-intersection removal: the arrangement of the raw arcs (Sec. 4.4).

``method="general"`` (the default) of :func:`gloffset.vector.selfintersect.resolve`. The
boundary of the offset region is made of pieces of raw arcs (Sec. 4.1), and along a raw
arc the question "is this point on the boundary" changes answer only where another raw
arc crosses it. :func:`resolve_general` goes in named steps:

prune the arcs within ``|d|`` of the curves, pair the arcs whose caps meet, intersect
them, split them at the crossings, keep the pieces whose middle lies at ``|d|`` from the
curves (exact float64 point-to-arc distances) and link those into closed rings, sorted
into exteriors and holes by crossing parity (:mod:`gloffset.vector.rings`).

Robustness: intersections from angular radii with error bounds, nodes closer than
:data:`~gloffset.vector.smallcircle.MERGE_TOL` merged (a crossing merged with an arc's
end is placed along both arcs from that end, and circles within MERGE_TOL of each other
everywhere are one circle, split at each other's ends), doubtful pieces kept only where
they close into rings with certain pieces; certain pieces that fail to close are
counted in :attr:`~gloffset.vector.resolved.ResolvedOffset.unlinked`.

Input. Polygons are expected not to overlap and rings not to cross themselves;
both are detected (:func:`defects`), and then every piece is also checked with the
inside test and (for crossing edges) both sides of every ring are offset, so that the
result is the reference region (inside by crossing parity) in every case. A seam
without a partner across the antimeridian is offset and counted as boundary, as the
raw offset does (the reference ignores it). The derivation in full: ``docs/design.md``,
*Module notes*.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import crossings
from ..geometry.arrangement import candidate_pairs, components, cycles, split
from ..geometry.sphere import angle, arc_distance, arcs_cross, normalize
from .arcrings import OffsetRing
from .links import dedupe, link, prune_dangling
from .resolved import ResolvedOffset
from .smallcircle import MERGE_TOL, CircleArcs, circle_of, intersect, point_at, position

__all__ = [
    "DOUBT_EPS",
    "KEEP_EPS",
    "PRUNE_MARGIN",
    "defects",
    "resolve_general",
    # the steps, which gloffset.vector.window runs inside one cap
    "RawArcs",
    "Generators",
    "Events",
    "prune_arcs",
    "arc_pairs",
    "corner_events",
    "crossing_events",
    "split_pieces",
    "boundary_pieces",
]

#: A piece of arc is dropped when a curve is closer than ``|d| - DOUBT_EPS`` to its middle,
#: and certain when none is closer than ``|d| - KEEP_EPS`` (in between: in doubt).
DOUBT_EPS = 1e-11
KEEP_EPS = 2e-15
#: Arcs within ``|d| - PRUNE_MARGIN`` of the curves everywhere are dropped before intersecting.
PRUNE_MARGIN = 1e-12


def resolve_general(off, raw, from_line) -> ResolvedOffset:
    """The boundary of the offset region of ``off`` from the raw rings that can bound it.

    ``raw`` and ``from_line`` (whether each ring offsets a line) are those of
    :func:`gloffset.vector.selfintersect.boundary_rings`; the steps are those of the
    module notes.
    """
    d = float(off.distance)
    shape = off.shape
    if not raw:
        return ResolvedOffset(d, "general", [], np.zeros(0, bool), [], 0, shape)
    table = RawArcs.of(raw)
    gens = Generators(shape)
    live = prune_arcs(table, gens, d)
    if live is None:
        return ResolvedOffset(d, "general", [], np.zeros(0, bool), [], 0, shape)
    ia, ib, corners = arc_pairs(table, live, abs(d))
    events = Events(table, live)
    cut_start, cut_end = corner_events(events, table, live, corners)
    crossing_events(events, table, live, ia, ib)
    pts, ev_arc, ev_t, ev_node = events.merged()
    pieces = split_pieces(ev_arc, ev_t, ev_node, cut_start, cut_end)
    from_line_piece = from_line[table.ring_of[live.alive[pieces.arc]]]
    pieces, certain, unlinked = boundary_pieces(pieces, live, gens, shape, d, from_line_piece)
    rings, open_certain = _close_rings(pieces, certain, table, live, pts)
    return ResolvedOffset.from_rings(d, "general", rings, shape, unlinked + open_certain)


# ----------------------------------------------------------------------------- the arcs


@dataclass
class RawArcs:
    """Every arc of the raw rings in one table (global indices, ring after ring)."""

    arcs: CircleArcs  # arc k runs from junctions[prev[k]] to junctions[k]
    centers: np.ndarray  # (n, 3) Q
    junctions: np.ndarray  # (n, 3) R; node k (k < n) is junction k
    kind: np.ndarray  # (n,) 0: vertex arc, 1: edge arc
    sources: np.ndarray  # (n, 2, 3) generating vertex or edge
    prev: np.ndarray  # (n,) the arc before, in its ring
    ring_of: np.ndarray  # (n,) ring of each arc

    @classmethod
    def of(cls, raw) -> RawArcs:
        """The table of the rings ``raw`` (a list of OffsetRing)."""
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
        arcs = CircleArcs(axis, h, r_all[prev], r_all)
        return cls(arcs, q_all, r_all, kind_all, src_all, prev, ring_of)

    def __len__(self) -> int:
        return len(self.prev)


@dataclass
class _LiveArcs:
    """The raw arcs left after pruning (local indices ``0 .. len(alive) - 1``)."""

    alive: np.ndarray  # local -> global index
    g2l: np.ndarray  # global -> local index, -1 for pruned arcs
    A: CircleArcs  # the arcs ``alive``
    backward: np.ndarray  # (n global,) joins of concave corners (they turn backwards)
    cm: np.ndarray  # (n global, 3) bounding cap centres of all raw arcs
    cr: np.ndarray  # (n global,) and radii

    def __post_init__(self):
        self.sign = self.A.sign
        self.sinr = self.A.sin_radius
        self.phi_abs = np.abs(self.A.phi)

    def on_arc(self, idx, x, err):
        """Turn of points ``x`` along arcs ``idx`` (clamped), whether on them, near start,
        near end (within the error ``err`` plus MERGE_TOL)."""
        A = self.A
        t = position(A.axis[idx], A.h[idx], A.start[idx], self.sign[idx], x)
        tol = (err + MERGE_TOL) / np.maximum(self.sinr[idx], 1e-300)
        ph = self.phi_abs[idx]
        t = np.where(t > ph + tol, t - 2.0 * np.pi, t)  # just before the start
        on = (t >= -tol) & (t <= ph + tol)
        near_s = on & (t <= tol)
        near_e = on & (t >= ph - tol)
        return np.clip(t, 0.0, ph), on, near_s, near_e


@dataclass
class _Pieces:
    """Pieces of live arcs: arc (local index), turns from its start, end nodes."""

    arc: np.ndarray
    t0: np.ndarray
    t1: np.ndarray
    n0: np.ndarray
    n1: np.ndarray

    def take(self, idx) -> _Pieces:
        """The pieces ``idx``."""
        return _Pieces(self.arc[idx], self.t0[idx], self.t1[idx], self.n0[idx], self.n1[idx])

    def __len__(self) -> int:
        return len(self.arc)


# ----------------------------------------------------------------------------- the steps


def prune_arcs(table: RawArcs, gens, d: float, within=None) -> _LiveArcs | None:
    """Step 1: drop arcs that lie wholly within ``|d| - PRUNE_MARGIN`` of the curves, and
    the joins of concave corners, which turn backwards and lie within ``|d|`` of the two
    edges there (and, with a cap ``within = (centre, radius)``, the arcs whose caps miss
    it). None when nothing is left."""
    arcs = table.arcs
    backward = (table.kind == 0) & (arcs.phi * d < 0.0)
    cm, cr = arcs.caps()
    covered = backward.copy()
    if within is not None:
        c, r = within
        covered |= angle(cm, np.broadcast_to(c, cm.shape)) > cr + r + 1e-12
    test = ~covered
    covered[test] = gens.closer_than(cm[test], abs(d) - cr[test] - PRUNE_MARGIN)
    alive = np.flatnonzero(~covered)
    if len(alive) == 0:
        return None
    g2l = np.full(len(table), -1, dtype=np.int64)
    g2l[alive] = np.arange(len(alive))
    return _LiveArcs(alive, g2l, arcs.subset(alive), backward, cm, cr)


def arc_pairs(table: RawArcs, live: _LiveArcs, ad: float):
    """Step 2: pairs of live arcs whose caps meet, without ring neighbours: arcs that share
    a junction only touch there, and the two edge arcs around a join are handled by
    :func:`corner_events`.

    Returns ``(ia, ib, (before, after, corner))``: local indices of the pairs, and the
    corners of :func:`_corners`.
    """
    n_all = len(table)
    prev, alive = table.prev, live.alive
    nxt = np.empty(n_all, dtype=np.int64)
    nxt[prev] = np.arange(n_all)
    before, after, corner = _corners(table.kind, table.sources, prev, nxt)
    across = np.full(n_all, -1, dtype=np.int64)
    edge_len = angle(table.sources[:, 0], table.sources[:, 1])
    # their circles also meet near the antipode of the corner, out of reach of shorter edges
    short = np.minimum(edge_len[before], edge_len[after]) + 3.0 * ad < np.pi - 1e-2
    across[before[short]] = after[short]
    _, ia, ib = candidate_pairs(live.cm[alive], live.cr[alive], MERGE_TOL)
    ga, gb = alive[ia], alive[ib]
    neighbours = (prev[ga] == gb) | (prev[gb] == ga) | (across[ga] == gb) | (across[gb] == ga)
    return ia[~neighbours], ib[~neighbours], (before, after, corner)


class Events:
    """Where the live arcs are to be split: ``(arc, turn from its start, node)`` triples,
    the nodes' points, and pairs of nodes that are one (an end point and a crossing
    within its error bound of it). Nodes ``0 .. n-1`` are the raw junctions (node ``k``
    ends global arc ``k``); every arc has an event at its start and at its end."""

    def __init__(self, table: RawArcs, live: _LiveArcs):
        n_arc = len(live.alive)
        self.points = [table.junctions]
        self.arc = [np.arange(n_arc), np.arange(n_arc)]
        self.t = [np.zeros(n_arc), live.phi_abs]
        self.node = [table.prev[live.alive], live.alive]
        self.same_i: list[np.ndarray] = []
        self.same_j: list[np.ndarray] = []
        self.next_node = len(table)

    def add_nodes(self, x, arc1, t1, arc2, t2) -> np.ndarray:
        """New nodes at the points ``x``, each on arc ``arc1`` at turn ``t1`` and on arc
        ``arc2`` at ``t2``; returns their ids."""
        nid = self.next_node + np.arange(len(x))
        self.next_node += len(x)
        self.points.append(x)
        self.arc += [arc1, arc2]
        self.t += [t1, t2]
        self.node += [nid, nid]
        return nid

    def add_splits(self, arc, t, node) -> None:
        """Split arcs ``arc`` at turns ``t`` at the existing nodes ``node``."""
        self.arc.append(arc)
        self.t.append(t)
        self.node.append(node)

    def merged(self):
        """Step 4: the nodes' points and the events, with nodes closer than MERGE_TOL, and
        the pairs given as one, merged (each labelled by its smallest member).

        Returns ``(points, arc, t, node)``.
        """
        pts = np.concatenate(self.points)
        ev_arc = np.concatenate(self.arc)
        ev_t = np.concatenate(self.t)
        ev_node = np.concatenate(self.node)
        used = np.unique(ev_node)
        ci, cj = _close_pairs(pts[used], MERGE_TOL)
        pi = [used[ci]] + self.same_i
        pj = [used[cj]] + self.same_j
        lab = components(
            len(pts), np.concatenate(pi).astype(np.int64), np.concatenate(pj).astype(np.int64)
        )
        self.labels = lab
        return pts, ev_arc, ev_t, lab[ev_node]


def corner_events(events: Events, table: RawArcs, live: _LiveArcs, corners):
    """Step 3a: at a concave corner the two edge arcs cross near the vertex, where their
    circles are nearly the same: the point is found in closed form (:func:`_corner_point`),
    and what lies past it on either arc is covered.

    Returns ``(cut_start, cut_end)``: per live arc, the part of it that can be boundary.
    """
    before, after, corner = corners
    cut_start = np.zeros(len(live.alive))
    cut_end = live.phi_abs.copy()
    conc = np.flatnonzero(live.backward[corner])
    if len(conc):
        b, a = before[conc], after[conc]
        axis, h = table.arcs.axis, table.arcs.h
        x = _corner_point(axis[b], axis[a], h[b], table.sources[corner[conc], 0])
        lb, la = live.g2l[b], live.g2l[a]
        both = (lb >= 0) & (la >= 0)
        lb, la, x = lb[both], la[both], x[both]
        zero = np.zeros(len(lb))
        tb, inb, _, _ = live.on_arc(lb, x, zero)
        ta, ina, _, _ = live.on_arc(la, x, zero)
        k = np.flatnonzero(inb & ina)
        if len(k):
            events.add_nodes(x[k], lb[k], tb[k], la[k], ta[k])
            np.minimum.at(cut_end, lb[k], tb[k])
            np.maximum.at(cut_start, la[k], ta[k])
    return cut_start, cut_end


def crossing_events(events: Events, table: RawArcs, live: _LiveArcs, ia, ib) -> None:
    """Step 3b: the crossings of the pairs ``(ia, ib)`` become nodes on both arcs; a crossing
    within its error bound of an arc's end is that end (the two nodes are one), and arcs on
    the same circle are split at each other's end points."""
    if len(ia) == 0:
        return
    A, prev, alive = live.A, table.prev, live.alive
    x, ok, err, coin = intersect(A.axis[ia], A.rho[ia], A.axis[ib], A.rho[ib])
    # circles closer than MERGE_TOL everywhere (the edge arcs of two copies of an edge
    # whose ends differ by rounding) meet, if at all, at points their error bound cannot
    # place (err ~ 1 rad): they are one circle
    near = _same_circle(A.axis[ia], A.rho[ia], A.axis[ib], A.rho[ib])
    coin = coin | near
    ok = ok & ~near
    twin = np.linalg.norm(x[:, 0] - x[:, 1], axis=1) <= MERGE_TOL
    for s in range(2):
        xs = x[:, s]
        ta, ina, sa, ea = live.on_arc(ia, xs, err)
        tb, inb, sb, eb = live.on_arc(ib, xs, err)
        good = ok & ina & inb
        if s == 1:
            good &= ~twin
        k = np.flatnonzero(good)
        if len(k) == 0:
            continue
        # a crossing at an arc's end is that end: place it on both arcs from the end
        # point itself, which lies on its circle to rounding, not from the crossing,
        # which tangent circles (a join and the edge arc that leaves it, met by a third
        # arc on the join's circle) fix only to ~1e-8
        snap = _snapped(A, ia[k], ib[k], sa[k], ea[k], sb[k], eb[k])
        if len(snap[0]):
            j, xj = snap
            ta[k[j]] = live.on_arc(ia[k[j]], xj, err[k[j]])[0]
            tb[k[j]] = live.on_arc(ib[k[j]], xj, err[k[j]])[0]
        nid = events.add_nodes(xs[k], ia[k], ta[k], ib[k], tb[k])
        for near, arc_idx, which in (
            (sa[k], ia[k], "s"),
            (ea[k], ia[k], "e"),
            (sb[k], ib[k], "s"),
            (eb[k], ib[k], "e"),
        ):
            if near.any():
                g = alive[arc_idx[near]]
                events.same_i.append(nid[near])
                events.same_j.append(prev[g] if which == "s" else g)
    # coincident circles: split each arc at the other's end points
    kc = np.flatnonzero(coin)
    for a_idx, b_idx in ((ia[kc], ib[kc]), (ib[kc], ia[kc])):
        for pt, node in ((A.start[b_idx], prev[alive[b_idx]]), (A.end[b_idx], alive[b_idx])):
            t, inside_, _, _ = live.on_arc(a_idx, pt, np.zeros(len(a_idx)))
            events.add_splits(a_idx[inside_], t[inside_], node[inside_])


def _same_circle(a1, r1, a2, r2) -> np.ndarray:
    """Whether the circles ``(a1, r1)`` and ``(a2, r2)`` (unit axes, angular radii) lie
    within :data:`MERGE_TOL` of each other everywhere (the same circle, either way round)."""
    g = angle(a1, a2)
    return (
        np.where(g < 0.5 * np.pi, g + np.abs(r1 - r2), (np.pi - g) + np.abs(r1 + r2 - np.pi))
        < MERGE_TOL
    )


def _snapped(A: CircleArcs, ia, ib, sa, ea, sb, eb):
    """The crossings (of arcs ``ia``, ``ib``) that lie at an arc's end, and that end point.

    Returns ``(j, x)``: the indices of those crossings and the end each one is (the first
    of the start or end of ``ia``, then of ``ib``)."""
    j = np.flatnonzero(sa | ea | sb | eb)
    if len(j) == 0:
        return j, np.zeros((0, 3))
    x = np.where(
        sa[j, None],
        A.start[ia[j]],
        np.where(ea[j, None], A.end[ia[j]], np.where(sb[j, None], A.start[ib[j]], A.end[ib[j]])),
    )
    return j, x


def split_pieces(ev_arc, ev_t, ev_node, cut_start, cut_end) -> _Pieces:
    """Step 5: the pieces of arcs between consecutive events, less those of zero length
    (both ends one node) and those past a concave corner's crossing."""
    p = _Pieces(*split(ev_arc, ev_t, ev_node))
    real = (p.n0 != p.n1) & (p.t0 < cut_end[p.arc]) & (p.t1 > cut_start[p.arc])
    return p.take(real)


def boundary_pieces(
    pieces: _Pieces, live: _LiveArcs, gens, shape, d: float, from_line, open_nodes=None
):
    """Step 6: the pieces whose middle lies at ``|d|`` from the curves (nothing closer) and
    on the right side of the polygons, less duplicates and open chains.

    Returns ``(pieces, certain, unlinked)``: pieces a curve comes closer to than
    ``|d| - KEEP_EPS`` are in doubt (they lie within DOUBT_EPS of the boundary and stay
    only where they close up with certain pieces); ``unlinked`` counts the certain
    pieces dropped with open chains (chains may end at ``open_nodes``).
    """
    A, sign = live.A, live.sign
    mid = point_at(
        A.axis[pieces.arc], A.start[pieces.arc], sign[pieces.arc] * 0.5 * (pieces.t0 + pieces.t1)
    )
    dropped, deficit = gens.deficit(mid, abs(d))
    kept = ~dropped
    kept &= _side_ok(shape, d, mid, from_line)
    k = np.flatnonzero(kept)
    pieces, mid = pieces.take(k), mid[k]
    certain = deficit[k] <= KEEP_EPS
    keep = dedupe(pieces.n0, pieces.n1, mid)
    linked = keep[prune_dangling(pieces.n0[keep], pieces.n1[keep], open_nodes)]
    unlinked = int(np.count_nonzero(certain[keep])) - int(np.count_nonzero(certain[linked]))
    return pieces.take(linked), certain[linked], unlinked


def _close_rings(pieces: _Pieces, certain, table: RawArcs, live: _LiveArcs, pts):
    """Step 7: link the pieces into closed rings; a ring made only of doubtful pieces is a
    sliver and goes.

    Returns ``(rings, unlinked)``: OffsetRings, and the number of certain pieces left
    on open chains.
    """
    nxt = link(live, pieces, pts)
    closed, open_pieces = cycles(nxt)
    unlinked = int(np.count_nonzero(certain[open_pieces]))
    if unlinked:
        # a doubtful detour that leaves a node tangent to a certain piece can take its
        # place: link again without the doubtful pieces at the open certain ones' ends
        # and keep that when it leaves fewer certain pieces open
        ends = np.concatenate(
            [
                pieces.n0[open_pieces[certain[open_pieces]]],
                pieces.n1[open_pieces[certain[open_pieces]]],
            ]
        )
        drop = ~certain & (np.isin(pieces.n0, ends) | np.isin(pieces.n1, ends))
        if drop.any():
            keep = np.flatnonzero(~drop)
            keep = keep[prune_dangling(pieces.n0[keep], pieces.n1[keep])]
            sub = pieces.take(keep)
            closed2, _ = cycles(link(live, sub, pts))
            in_rings = sum(int(np.count_nonzero(certain[keep[c]])) for c in closed2)
            unlinked2 = int(np.count_nonzero(certain)) - in_rings
            if unlinked2 < unlinked:
                pieces, certain, unlinked = sub, certain[keep], unlinked2
                closed = closed2
    rings = []
    for cyc in closed:
        if not certain[cyc].any():
            continue
        ring = _ring_from_pieces(table, live.alive, pts, pieces.take(cyc))
        if ring is not None:
            rings.append(ring)
    return rings, unlinked


# ----------------------------------------------------------------------------- helpers


class Generators:
    """The shape's vertices and edges with a cap hierarchy, for "is a curve closer than t"."""

    def __init__(self, shape):
        arcs = shape.arcs()
        self.a, self.b, self.n, self.tree = arcs.a, arcs.b, arcs.n, arcs.tree

    def closer_than(self, p: np.ndarray, thr: np.ndarray) -> np.ndarray:
        """Whether some point of the curves lies closer than ``thr`` to each ``p``.

        Exact in float64 (the distances are those of :func:`gloffset.geometry.sphere.arc_distance`,
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
    crossing, overlap = defects(shape)
    if crossing or (overlap and d > 0.0):
        check[:] = True
    idx = np.flatnonzero(check)
    if len(idx):
        ins = crossings.inside_indexed(shape, mid[idx], anchors=_SIDE_ANCHORS)
        ok[idx] = ~ins if d > 0.0 else ins
    return ok


def defects(shape) -> tuple[bool, bool]:
    """Whether edges of the shape's rings cross (self-intersecting input), and whether
    a region component lies inside another (overlapping parts). Kept on the shape."""
    return shape.derived.once("defects", lambda: _find_defects(shape))


def _find_defects(shape) -> tuple[bool, bool]:
    """:func:`defects`, computed."""
    arcs = shape.arcs()
    a, b = arcs.a[arcs.ring], arcs.b[arcs.ring]
    ia, ib = arcs.ring_tree.self_pairs()
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


def _ring_from_pieces(table: RawArcs, alive, pts, pieces: _Pieces):
    """An OffsetRing from its pieces (a closed cycle, in order), joining consecutive pieces
    of the same raw arc."""
    arc, t0, t1, n1 = pieces.arc, pieces.t0, pieces.t1, pieces.n1
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
    return OffsetRing(
        table.centers[g].copy(),
        pts[n1[last]].copy(),
        table.kind[g].copy(),
        table.sources[g].copy(),
    )
