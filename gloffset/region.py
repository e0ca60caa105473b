"""The region of an input: the union of its polygons, and the boundary of that union.

Every operation of gloffset (distance, inside tests, rasters, tiles, vector
offsets and the reference) works on one region: the union of the input's
polygons. Its boundary is derived here, once per shape, from the polygons as the
user gave them:

- edges traversed both ways (two neighbours sharing a border, an enclave filling
  a hole, the two sides of a cut) cancel;
- parts of polygons that overlap are merged: an edge piece inside another polygon
  is dropped, pieces that coincide in the same direction are kept once;
- seam edges (on the +-180 deg meridian or at a pole, as GeoJSON cuts Fiji,
  Russia and Antarctica) take part in the same arrangement, so the pieces of a
  polygon on both sides of +-180 deg join even where their end vertices on the
  seam differ: the common part of two seam edges cancels, and what is left of a
  seam stays in its ring as a seam (it closes the ring, but has no distance, no
  offset and no outline).

Tolerance: :data:`TOL` (1e-12 rad, 6 micrometres on the Earth) for merging vertices
and crossing edges; everything else is exact (float64 great-circle crossings, pieces
kept by an exact crossing-parity test).

The result is a set of closed rings, interior on the left, that do not cross one
another; rings are grouped into *components* (polygons that touch or overlap end
up in one component), so crossing parity within a component decides its inside
and a point is in the region when it is inside any component. The derivation in full:
``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InvalidGeometryError
from .geometry.arrangement import (
    bucket_order,
    candidate_pairs,
    components,
    equal_rows,
    permutation_cycles,
    row_keys,
    split_between,
)
from .geometry.caps import arc_cap, cap_threshold, pad
from .geometry.captree import CapTree
from .geometry.sphere import (
    angle,
    arc_distance,
    arcs_cross,
    column_dots,
    cross,
    crossing_rule,
    normalize,
    pair_chord2,
    pair_dots,
    pair_equal,
    robust_cross,
)

__all__ = ["TOL", "Boundary", "unite", "left_area", "left_areas"]

#: Distance (rad) below which vertices merge and a vertex lies on an edge.
TOL = 1e-12


@dataclass
class Boundary:
    """The boundary of a union: rings with seam flags, component and hole flags, labels."""

    rings: list
    seams: list
    groups: np.ndarray
    holes: np.ndarray
    labels: list


def left_area(ring: np.ndarray) -> float:
    """Area (steradians) on the left of a closed ring of unit vectors, by Gauss-Bonnet.

    ``2 pi`` minus the sum of the turning angles at the vertices (great-circle
    edges have no geodesic curvature). Accuracy: about 1e-15 rad per vertex.
    """
    v = np.asarray(ring, dtype=np.float64).reshape(-1, 3)
    return float(left_areas(v, np.array([0, len(v)]))[0])


def left_areas(v: np.ndarray, at: np.ndarray) -> np.ndarray:
    """:func:`left_area` of many rings at once: ring ``r`` is ``v[at[r]:at[r + 1]]``
    (the terms element by element, each ring's turns summed apart). Accuracy as
    :func:`left_area`'s."""
    v = np.asarray(v, dtype=np.float64)
    at = np.asarray(at, dtype=np.int64)
    sizes = np.diff(at)
    if len(sizes) == 0:
        return np.zeros(0)
    # each ring's next vertices and previous edges: the arrays shifted by one (cyclically)
    first, last = at[:-1][sizes > 0], at[1:][sizes > 0] - 1
    w = np.empty_like(v)
    w[:-1] = v[1:]
    w[last] = v[first]
    n = normalize(robust_cross(v, w))  # edge i: v[i] -> v[i+1]
    n_in = np.empty_like(n)
    n_in[1:] = n[:-1]
    n_in[first] = n[last]
    t_out = cross(n, v)  # direction of travel leaving v[i]
    t_in = cross(n_in, v)  # arriving at v[i] along edge i-1
    turn = np.arctan2(
        np.einsum("ij,ij->i", cross(t_in, t_out), v), np.einsum("ij,ij->i", t_in, t_out)
    )
    return np.array(
        [float(2.0 * np.pi - turn[a:b].sum()) % (4.0 * np.pi) for a, b in zip(at[:-1], at[1:])]
    )


def _proper_crossings(v, nxt, n, i, j) -> np.ndarray:
    """Whether edges ``i[k]`` and ``j[k]`` (edge ``e``: ``v[e] -> v[nxt[e]]``) cross
    properly: the ends of each lie farther than :data:`TOL` from the other's great circle
    (``n``: the edges' unit normals), on both sides of it, and the crossing is not the
    antipodal one."""
    return _proper(*_sides(v, n, i, nxt[i], j, nxt[j]))


def _sides(v, n, ai, bi, aj, bj):
    """The four side values of the pairs of edges ``i``: ``v[ai] -> v[bi]`` and ``j``:
    ``v[aj] -> v[bj]`` (normals ``n[ai]``, ``n[aj]``): ``aj.ni``, ``bj.ni``, ``ai.nj``,
    ``bi.nj`` (einsum's sums, so the same bits wherever they are computed)."""
    # pair_dots' sums, from contiguous columns made once for the four (faster gathers)
    vc, nc = ([np.ascontiguousarray(a[:, k], dtype=np.float64) for k in range(3)] for a in (v, n))
    pairs = ((aj, ai), (bj, ai), (ai, aj), (bi, aj))
    return tuple(column_dots(vc, nc, p, q) for p, q in pairs)


def _proper(o1, o2, o3, o4) -> np.ndarray:
    """:func:`_proper_crossings` from the side values of :func:`_sides`."""
    clear = np.minimum(np.minimum(np.abs(o1), np.abs(o2)), np.minimum(np.abs(o3), np.abs(o4))) > TOL
    return clear & crossing_rule(o1 >= 0, o2 >= 0, o3 >= 0, o4 >= 0)


def _crosses_itself(rings) -> bool:
    """Whether two edges of one polygon's rings (an exterior and its holes) cross properly.

    Such a polygon (a bowtie) has no consistent "interior on the left" and goes through
    the union, which reads it by crossing parity.
    """
    sizes = np.array([len(r) for r in rings])
    starts = np.repeat(np.concatenate([[0], np.cumsum(sizes)[:-1]]), sizes)
    pos = np.arange(sizes.sum()) - starts
    a = np.concatenate(rings).astype(np.float64)
    nxt = starts + (pos + 1) % np.repeat(sizes, sizes)
    b = a[nxt]
    _, i, j = candidate_pairs(*arc_cap(a, b), slack=2 * TOL)
    if len(i) == 0:
        return False
    return bool(_proper_crossings(a, nxt, normalize(robust_cross(a, b)), i, j).any())


def unite(rings, seams, comps, holes, labels) -> Boundary:
    """The boundary of the union of polygons (see the module notes).

    Parameters
    ----------
    rings : list of (n, 3) arrays
        Closed rings (first vertex not repeated), interior on the left.
    seams : list of (n,) bool arrays
        Edge ``i -> i+1`` of a ring is a seam.
    comps : sequence of int
        The polygon each ring belongs to (an exterior with its holes).
    holes, labels : per ring, for the result's flags and messages.
    """
    comps = np.asarray(comps, dtype=np.int64)
    n_comp = int(comps.max()) + 1 if len(comps) else 0
    if not rings:
        return Boundary([], [], np.zeros(0, np.int64), np.zeros(0, bool), [])
    any_seam = any(s.any() for s in seams)
    if n_comp <= 1 and not any_seam and not _crosses_itself(rings):
        return Boundary(
            list(rings),
            list(seams),
            np.zeros(len(rings), np.int64),
            np.asarray(holes, bool),
            list(labels),
        )
    return _Union(rings, seams, comps, labels).run()


class _Union:
    """One union: the input's edges, their pairs, pieces, and the rings made of them.

    Steps (:meth:`run`): candidate pairs of edges from a cap tree, vertices within
    :data:`TOL` merged, edges split at T-junctions and crossings, coincident pieces
    cancelled or kept once, pieces inside another polygon dropped, the rest linked
    into rings grouped by the polygons that touch.
    """

    def __init__(self, rings, seams, comps, labels):
        self.labels = list(labels)
        self.n_comp = int(comps.max()) + 1
        self.ring_comps = comps
        self._edges(rings, seams)

    # ------------------------------------------------------------------ edges
    def _edges(self, rings, seams):
        sizes = np.array([len(r) for r in rings])
        starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        ring_of = np.repeat(np.arange(len(rings)), sizes)
        pos = np.arange(sizes.sum()) - np.repeat(starts, sizes)
        self.v = np.concatenate(rings).astype(np.float64)
        self.nxt = np.repeat(starts, sizes) + (pos + 1) % np.repeat(sizes, sizes)
        self.ring_of = ring_of
        self.comp = self.ring_comps[ring_of]
        if np.any(np.diff(self.comp) < 0):
            raise ValueError("rings must come grouped by polygon")
        self.comp_start = np.searchsorted(self.comp, np.arange(self.n_comp))
        self.comp_end = np.searchsorted(self.comp, np.arange(self.n_comp), side="right")
        self.seam = np.concatenate(seams).astype(bool)

    def _ends(self, i, j):
        """The vertices at the ends ``a``, ``b`` of the edges ``i`` and ``j`` of the
        candidate pairs (indices into ``self.v``), for the tests of the pairs."""
        nx = self.nxt
        return i, nx[i], j, nx[j]

    def _snap_vertices(self, ends) -> bool:
        """Merge vertices of candidate edge pairs that lie within TOL (not identical)."""
        v = self.v
        ai, bi, aj, bj = ends
        pa, pb = [], []
        for x, y in ((ai, aj), (ai, bj), (bi, aj), (bi, bj)):
            # the ends within 2 TOL by a cheap square (of the ends apart: most ends so near
            # are one vertex), then the distance as it was taken
            c2 = pair_chord2(v, x, y)
            near = np.flatnonzero((c2 <= (2.0 * TOL) ** 2) & (c2 > 0.0))
            x, y = x[near], y[near]
            d = np.linalg.norm(v[x] - v[y], axis=1)
            near = (d > 0.0) & (d <= TOL)
            pa.append(x[near])
            pb.append(y[near])
        pa_c, pb_c = np.concatenate(pa), np.concatenate(pb)
        if len(pa_c) == 0:
            return False
        root = components(len(self.v), pa_c, pb_c)
        moved = np.unique(np.concatenate([pa_c, pb_c]))
        self.v[moved] = self.v[root[moved]]
        return True

    def _pairs(self):
        a, b = self.v, self.v[self.nxt]
        mid, self.half = arc_cap(a, b)  # the edges' half lengths, kept for later steps
        self.tree, i, j = candidate_pairs(mid, self.half, slack=2 * TOL)
        return i, j

    # ------------------------------------------------------------------ run
    def run(self) -> Boundary:
        i, j = self._pairs()
        ends = self._ends(i, j)
        if self._snap_vertices(ends):
            i, j = self._pairs()
            ends = self._ends(i, j)
        other = self.comp[i] != self.comp[j]
        self._pairs_other = (i[other], j[other])
        # pairs of polygons that touch, joined into one component
        self.meets: list[tuple[np.ndarray, np.ndarray]] = []
        splits = self._intersections(i, j, ends)
        pieces = self._split(splits)
        keep, excl = self._cancel(pieces)
        keep, flip = self._classify(pieces, keep, excl)
        turn = keep & flip
        pieces["start"][turn], pieces["end"][turn] = (
            pieces["end"][turn],
            pieces["start"][turn].copy(),
        )
        return self._link(pieces, keep)

    def _intersections(self, i, j, ends):
        """Split points per edge, ``(edge, vertex index)``: T-junctions and crossings.

        Polygons whose edges meet (a shared vertex, a split) are joined into one
        component of the result.
        """
        v, nx = self.v, self.nxt
        a, b = v, v[nx]
        self.b = b  # the edges' ends, kept for the inside tests (v does not move again)
        n = normalize(robust_cross(a, b))
        self.n = n
        out_e, out_p, meet_a, meet_b = [], [], [], []
        # the sides of each end against the other's great circle: for both tests below
        sides = _sides(v, n, *ends)
        # an end of one edge on the other (T-junctions, collinear overlaps); the tests
        # after the first only for the ends within TOL of the other's great circle
        # (most such ends are a vertex the two edges share: an end that is one of the
        # edge's own vertices is not on it, and the rest are tested far from its ends
        # before between them)
        for (e, f), e_sides in zip(((i, j), (j, i)), (sides[:2], sides[2:])):
            for head, side in zip((True, False), e_sides):
                near = np.flatnonzero(np.abs(side) <= TOL)
                e_, f_ = e[near], f[near]
                end_ = f_ if head else nx[f_]
                other = (end_ != e_) & (end_ != nx[e_])
                e_, f_, end_ = e_[other], f_[other], end_[other]
                # not far from the edge: an end at one of its ends (most: a vertex shared)
                apart = ~(pair_equal(v, end_, e_) | pair_equal(v, end_, nx[e_]))
                e_, f_, end_ = e_[apart], f_[apart], end_[apart]
                p = v[end_]
                far = (np.linalg.norm(p - a[e_], axis=1) > TOL) & (
                    np.linalg.norm(p - b[e_], axis=1) > TOL
                )
                e_, f_, end_, p = e_[far], f_[far], end_[far], p[far]
                on = (np.einsum("ij,ij->i", p, cross(n[e_], a[e_])) > 0.0) & (
                    np.einsum("ij,ij->i", p, cross(b[e_], n[e_])) > 0.0
                )
                out_e.append(e_[on])
                out_p.append(end_[on])
                meet_a.append(e_[on])
                meet_b.append(f_[on])
        # proper crossings: each edge's ends clearly on both sides of the other
        hit = _proper(*sides)
        ci, cj = i[hit], j[hit]
        x = normalize(cross(n[ci], n[cj]))
        flip = np.einsum("ij,ij->i", x, a[ci] + b[ci]) < 0
        x[flip] *= -1.0
        # a polygon whose edges cross each other (invalid, or valid in lon/lat but not with
        # great-circle edges) is decided by the sides of its pieces (see _classify)
        self.twisted = np.zeros(self.n_comp, bool)
        self.twisted[self.comp[ci[self.comp[ci] == self.comp[cj]]]] = True
        new = len(v) + np.arange(len(ci))
        self.v = np.vstack([v, x])
        out_e += [ci, cj]
        out_p += [new, new]
        meet_a.append(ci)
        meet_b.append(cj)
        # shared vertices (of pairs of two polygons: only those join components)
        o = np.flatnonzero(self.comp[i] != self.comp[j])
        ai, bi, aj, bj = (e[o] for e in ends)
        shared = pair_equal(v, ai, aj) | pair_equal(v, ai, bj)
        shared |= pair_equal(v, bi, aj) | pair_equal(v, bi, bj)
        meet_a.append(i[o[shared]])
        meet_b.append(j[o[shared]])
        ca = self.comp[np.concatenate(meet_a)]
        cb = self.comp[np.concatenate(meet_b)]
        diff = ca != cb
        self.meets.append((ca[diff], cb[diff]))
        return np.concatenate(out_e), np.concatenate(out_p)

    def _split(self, splits):
        """Edge pieces ``(start, end)`` as vertex indices, with the edge each came from."""
        e_all, p_all = splits
        m = len(self.nxt)
        v = self.v
        t = angle(v[e_all], v[p_all])
        order = np.lexsort((t, e_all))
        e_all, p_all, t = e_all[order], p_all[order], t[order]
        # the same point reached twice on one edge (two pairs agree) counts once
        dup = np.zeros(len(e_all), bool)
        dup[1:] = (e_all[1:] == e_all[:-1]) & (v[p_all[1:]] == v[p_all[:-1]]).all(axis=1)
        e_all, p_all, t = e_all[~dup], p_all[~dup], t[~dup]
        # a chain per edge: start, split points in order, end
        piece_edge, start, end = split_between(np.arange(m), self.nxt, e_all, p_all)
        ok = ~pair_equal(v, start, end)
        return {"start": start[ok], "end": end[ok], "edge": piece_edge[ok]}

    def _cancel(self, pieces):
        """Coincident pieces: keep one where exactly one side of them is in a polygon.

        Per polygon, the pieces along one stretch count +1 one way and -1 the other
        (a polygon's own slit, as a cut down to a pole, nets to nothing); the stretch
        has a polygon on its left when some polygon nets > 0, on its right when some
        nets < 0. It is boundary when exactly one side is covered: traversed both ways
        by two polygons it cancels, the same way twice it is kept once.

        Returns the kept pieces and, per kept piece that coincided with others, the
        polygons along it (left out of its inside test).
        """
        v = self.v
        # a canonical order of the two ends (the first coordinate that differs), from
        # the coordinates gathered one by one
        s_, e_ = pieces["start"], pieces["end"]
        d0, d1, d2 = ((v[:, k][s_] + 0.0) - (v[:, k][e_] + 0.0) for k in range(3))
        fwd = (d0 < 0) | ((d0 == 0) & ((d1 < 0) | ((d1 == 0) & (d2 < 0))))
        # the pieces with the same two ends, by the ends' vertex groups (equal rows)
        self.vid, _ = equal_rows(v)
        s_id, e_id = self.vid[pieces["start"]], self.vid[pieces["end"]]
        lo = np.where(fwd, s_id, e_id)
        hi = np.where(fwd, e_id, s_id)
        _, inv, counts = np.unique(lo * len(v) + hi, return_inverse=True, return_counts=True)
        keep = counts[inv] == 1
        excl: dict[int, set[int]] = {}
        self.side_test = np.zeros(len(keep), bool)
        members = np.flatnonzero(counts[inv] > 1)
        if len(members) == 0:
            return keep, excl
        comp = self.comp[pieces["edge"]]
        # a polygon whose edges cross has no consistent sides to count: one piece of a
        # stretch it shares is kept, and the union on its two sides decides (_classify)
        twisted = np.zeros(len(counts), bool)
        twisted[inv[members[self.twisted[comp[members]]]]] = True
        if twisted.any():
            tw_members = members[twisted[inv[members]]]
            _, first = np.unique(inv[tw_members], return_index=True)
            keep[tw_members[first]] = True
            self.side_test[tw_members[first]] = True
            members = members[~twisted[inv[members]]]
        # net count per (stretch, polygon)
        pair = inv[members] * self.n_comp + comp[members]
        upair, pinv = np.unique(pair, return_inverse=True)
        net = np.bincount(pinv, weights=np.where(fwd[members], 1.0, -1.0))
        g = upair // self.n_comp
        left = np.zeros(len(counts), bool)
        right = np.zeros(len(counts), bool)
        left[g[net > 0]] = True
        right[g[net < 0]] = True
        one_side = left[inv[members]] != right[inv[members]]
        want_fwd = left[inv[members]]
        cand = members[one_side & (fwd[members] == want_fwd)]
        # one piece per stretch: the first candidate of each
        _, first = np.unique(inv[cand], return_index=True)
        chosen = cand[first]
        keep[chosen] = True
        order = members[np.argsort(inv[members], kind="stable")]
        starts = np.searchsorted(inv[order], inv[chosen])
        ends = np.searchsorted(inv[order], inv[chosen], side="right")
        for c, a_, b_ in zip(chosen.tolist(), starts.tolist(), ends.tolist()):
            excl[c] = set(comp[order[a_:b_]].tolist())
        return keep, excl

    # ------------------------------------------------------------------ inside tests
    def _inner_points(self):
        """A point inside each input polygon (kept as ``self.inner``): just left of its
        longest non-seam edge, or just right of it for a polygon whose edges cross when
        the left side is in the parity class of the point opposite its vertices' mean."""
        v, nx = self.v, self.nxt
        m = len(nx)
        a, b = v[:m], self.b
        length = 2.0 * self.half  # angle(a, b), exactly (halving and doubling are)
        score = length * np.where(self.seam, 1e-3, 1.0)
        lo = self.comp_start
        # the longest edge of each polygon: the last of its edges in the order of score
        # (the greatest score, the last edge of those that have it)
        best = np.maximum.reduceat(score, lo)
        k = np.maximum.reduceat(np.where(score == best[self.comp], np.arange(m), -1), lo)
        mid = normalize(a[k] + b[k])
        left = normalize(robust_cross(a[k], b[k]))
        qi, di, _ = self.tree.near(mid, 1e-3, lo=lo, hi=self.comp_end)
        ok = di != k[qi]
        qi, di = qi[ok], di[ok]
        dmin = np.ones(self.n_comp)
        np.minimum.at(dmin, qi, arc_distance(mid[qi], a[di], b[di], self.n[di]))
        eps = np.minimum.reduce([np.full(self.n_comp, 1e-3), 0.25 * dmin, 0.25 * length[k]])
        self.inner = normalize(np.cos(eps)[:, None] * mid + np.sin(eps)[:, None] * left)
        # a polygon whose edges cross has no consistent left side: by crossing parity, the
        # point opposite the mean of its vertices is outside it, and the inner point is
        # the one of the edge's two sides that parity puts in the other class
        tw = np.flatnonzero(self.twisted)
        if len(tw):
            s = np.add.reduceat(a, lo, axis=0)[tw]
            ok = np.linalg.norm(s, axis=1) > 1e-9
            tw, far = tw[ok], -normalize(s[ok])
            wrong = tw[self._inside(far, tw)]
            self.inner[wrong] = normalize(
                np.cos(eps[wrong])[:, None] * mid[wrong] - np.sin(eps[wrong])[:, None] * left[wrong]
            )
        return self.inner

    def _inside_other(self, p, own, excl):
        """For points ``p``: inside any input polygon other than ``own``/``excl``?"""
        pi, ci = self._near_caps(p)
        mine = ci == own[pi]
        if excl:
            ex = np.flatnonzero(np.isin(pi, np.fromiter(excl, np.int64, len(excl))))
            mine[ex] |= [c in excl[k] for k, c in zip(pi[ex].tolist(), ci[ex].tolist())]
        pi, ci = pi[~mine], ci[~mine]
        out = np.zeros(len(p), bool)
        np.logical_or.at(out, pi, self._inside(p[pi], ci))
        return out

    def _near_caps(self, p):
        """(point, polygon) pairs, the point within the polygon's cap, sorted by point
        then polygon: :func:`~gloffset.geometry.caps.cap_within`'s test, its threshold
        once per polygon, on the pairs that a cap tree over the polygons' caps finds
        within 3e-6 rad of each point (the test's slack of 1e-12 on the cosine reaches
        at most 1.5e-6 rad beyond the cap). A point far outside a polygon's padded cap
        (1e-9) is outside it by crossing parity too, so the pairs a rounding of the
        product moves across the threshold change no answer."""
        caps_c, caps_r = self.caps
        qi, ci, _ = self.caps_tree.near(p, 3e-6)
        ok = pair_dots(p, qi, caps_c, ci) >= cap_threshold(caps_r)[ci]
        qi, ci = qi[ok], ci[ok]
        order = np.lexsort((ci, qi))
        return qi[order], ci[order]

    def _inside(self, p, ci):
        """Whether each point ``p[k]`` lies inside input polygon ``ci[k]``: parity of the
        crossings of the arc from it to the polygon's inner point (through a point off
        the way when the two are far apart)."""
        m = len(self.nxt)
        a, b = self.v[:m], self.b
        if len(p) == 0:
            return np.zeros(0, bool)
        q = self.inner[ci]
        via = np.einsum("ij,ij->i", p, q) < -0.5
        mid = np.where(via[:, None], _perp(p, q), q)
        par = np.zeros(len(p), bool)
        for ids, s, t in ((np.arange(len(p)), p, mid), (np.flatnonzero(via), mid[via], q[via])):
            if len(ids) == 0:
                continue
            c = ci[ids]
            si, ei = self.tree.along(s, t, lo=self.comp_start[c], hi=self.comp_end[c])
            ok = self.comp[ei] == c[si]
            si, ei = si[ok], ei[ok]
            hit = arcs_cross(s[si], t[si], a[ei], b[ei], self.n[ei])
            np.logical_xor.at(par, ids[si[hit]], True)
        return ~par  # the inner point is inside its polygon

    def _comp_caps(self):
        """A cap (centre, radius) holding each input polygon, its inside included.

        The cap around a polygon's edges holds its inside unless the inside is the far
        side: then the point opposite the cap's centre is inside, and the cap is the
        whole sphere.
        """
        a = self.v[: len(self.nxt)]
        lo = self.comp_start
        s = np.add.reduceat(a, lo, axis=0)
        big = np.linalg.norm(s, axis=1) < 1e-9
        c = normalize(np.where(big[:, None], [0.0, 0.0, 1.0], s))
        cc = c[self.comp]
        # the angle to an edge's far end is the one to the next edge's start (one ring)
        to_a = angle(cc, a)
        reach = np.maximum(to_a, to_a[self.nxt]) + self.half
        r = pad(np.maximum.reduceat(reach, lo), abs_=1e-9)
        big |= r >= np.pi
        small = np.flatnonzero(~big)
        big[small[self._inside(-c[small], small)]] = True
        return c, np.where(big, np.pi, r)

    def _classify(self, pieces, keep, excl):
        """Drop the kept pieces that lie inside another polygon.

        Only pieces of edges that come near another polygon's edges (or were split)
        can change their answer along a ring, so those are tested one by one; the
        others take the answer of the first piece of their run (each ring's first
        piece is tested too).

        A polygon whose edges cross each other has no consistent "inside on the left";
        its region is taken by crossing parity (as everywhere in gloffset), and each
        of its pieces is kept when the union lies on exactly one side of it, turned so
        that the union is on its left. Returns the kept pieces and those to turn.
        """
        m = len(self.nxt)
        edge = pieces["edge"]
        i, j = self._pairs_other
        involved = np.zeros(m, bool)
        involved[i] = True
        involved[j] = True
        involved |= np.bincount(edge, minlength=m) != 1
        inv = involved[edge]
        ring = self.ring_of[edge]
        head = np.ones(len(edge), bool)  # first piece of a ring, or after an involved one
        head[1:] = (ring[1:] != ring[:-1]) | inv[:-1]
        test = inv | head
        tests = np.flatnonzero(test)
        todo = tests[keep[tests]]
        drop = np.zeros(len(edge), bool)
        flip = np.zeros(len(edge), bool)
        if len(todo):
            self._inner_points()
            self.caps = self._comp_caps()
            self.caps_tree = CapTree(*self.caps)
            tw = self.twisted[self.comp[edge[todo]]] | self.side_test[todo]
            plain, twisted = todo[~tw], todo[tw]
            p = normalize(self.v[pieces["start"][plain]] + self.v[pieces["end"][plain]])
            own = self.comp[edge[plain]]
            ex = {k: excl[int(t)] for k, t in enumerate(plain) if int(t) in excl}
            drop[plain] = self._inside_other(p, own, ex)
            if len(twisted):
                left, right = self._sides(pieces, twisted)
                drop[twisted] = left == right
                flip[twisted] = right & ~left
        # every piece takes the answer of the last tested piece at or before it
        src = np.maximum.accumulate(np.where(test, np.arange(len(edge)), 0))
        return keep & ~drop[src], flip[src]

    def _sides(self, pieces, idx):
        """Whether the union lies just left and just right of pieces ``idx``."""
        a, b = self.v[pieces["start"][idx]], self.v[pieces["end"][idx]]
        mid = normalize(a + b)
        left = normalize(robust_cross(a, b))
        eps0 = np.minimum(1e-7, 0.25 * angle(a, b))
        m = len(self.nxt)
        qi, di, _ = self.tree.near(mid, 4.0 * eps0)
        mine = di == pieces["edge"][idx][qi]
        qi, di = qi[~mine], di[~mine]
        dmin = np.full(len(idx), np.inf)
        dist = arc_distance(mid[qi], self.v[:m][di], self.b[di], self.n[di])
        # edges along the piece (coincident ones) do not limit the step off it
        np.minimum.at(dmin, qi, np.where(dist > TOL, dist, np.inf))
        eps = np.minimum(eps0, 0.25 * dmin)[:, None]
        sides = []
        for sign in (1.0, -1.0):
            p = normalize(np.cos(eps) * mid + sign * np.sin(eps) * left)
            sides.append(self._in_union(p))
        return sides[0], sides[1]

    def _in_union(self, p):
        """Whether points ``p`` lie inside any input polygon."""
        pi, ci = self._near_caps(p)
        out = np.zeros(len(p), bool)
        np.logical_or.at(out, pi, self._inside(p[pi], ci))
        return out

    # ------------------------------------------------------------------ rings
    def _link(self, pieces, keep) -> Boundary:
        """Join the kept pieces into closed rings (interior on the left)."""
        idx = np.flatnonzero(keep)
        start, end, edge = pieces["start"][idx], pieces["end"][idx], pieces["edge"][idx]
        v = self.v
        vid = self.vid  # the vertex groups of _cancel
        s_id, e_id = vid[start], vid[end]
        k = len(idx)
        order, n_out, out_at = bucket_order(s_id, len(v))  # the pieces by start vertex
        # where each vertex's pieces start in that order (a search of e_id, by counting)
        first = out_at[e_id]
        n_in = np.bincount(e_id, minlength=len(v))
        bad = np.flatnonzero(n_out != n_in)
        if len(bad):
            from .geometry.sphere import xyz_to_lonlat

            # named as by the groups in the order of the rows' bytes
            _, vid = np.unique(row_keys(v), return_inverse=True)
            vid = vid.reshape(-1)
            n_out = np.bincount(vid[start], minlength=len(v))
            bad = np.flatnonzero(n_out != np.bincount(vid[end], minlength=len(v)))
            lon, lat = xyz_to_lonlat(v[np.flatnonzero(vid == bad[0])[0]])
            raise InvalidGeometryError(
                "cannot unite the polygons: their borders meet at angles too small to "
                f"resolve near lon {float(lon):.9f}, lat {float(lat):.9f}"
            )
        nxt = order[np.minimum(first, k - 1)]
        multi = np.flatnonzero(n_out[e_id] > 1)
        if len(multi):
            for p in multi.tolist():
                w = v[end[p]]
                cand = order[first[p] : first[p] + n_out[e_id[p]]]
                # the normals of the piece and of those leaving its end (row by row)
                normal = normalize(robust_cross(v[start[[p, *cand]]], v[end[[p, *cand]]]))
                r = -cross(normal[0], w)
                t = cross(normal[1:], w)
                ccw = np.arctan2(cross(r, t) @ w, t @ r)
                cw = np.mod(-ccw, 2.0 * np.pi)
                cw[cw <= 0.0] = 2.0 * np.pi
                nxt[p] = cand[int(np.argmin(cw))]
            if (np.bincount(nxt, minlength=k) != 1).any():  # not a permutation
                raise InvalidGeometryError(
                    "cannot unite the polygons: their borders touch in a way that leaves "
                    "the union's boundary ambiguous"
                )
        # every piece is on one cycle (nxt is a permutation); the rings' arrays at once
        flat, sizes = permutation_cycles(nxt)
        ring3 = sizes >= 3
        flat, sizes = flat[np.repeat(ring3, sizes)], sizes[ring3]
        at = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        e_flat = edge[flat]
        c_flat = self.comp[e_flat]
        ring_id = np.repeat(np.arange(len(sizes)), sizes)
        # the polygons along a ring are one component of the result, under its smallest
        first_comp = np.minimum.reduceat(c_flat, at[:-1]) if len(flat) else c_flat
        self.meets.append((first_comp[ring_id], c_flat))
        v_flat = v[start[flat]]
        s_flat = self.seam[e_flat]
        hole = left_areas(v_flat, at) > 2.0 * np.pi
        # the input rings along each ring, in the order met
        src = self.ring_of[e_flat]
        n_src = int(src.max()) + 1 if len(src) else 1
        _, first = np.unique(ring_id * n_src + src, return_index=True)
        first = np.sort(first)
        names_at = np.searchsorted(first, at)
        src_first = src[first].tolist()
        rings = [v_flat[at[r] : at[r + 1]] for r in range(len(sizes))]
        seams = [s_flat[at[r] : at[r + 1]] for r in range(len(sizes))]
        groups = first_comp.tolist()
        holes = hole.tolist()
        labels = [
            " + ".join(self.labels[q] for q in src_first[names_at[r] : names_at[r + 1]])
            for r in range(len(sizes))
        ]
        root = components(self.n_comp, *(np.concatenate(x) for x in zip(*self.meets)))
        roots = root[np.array(groups, dtype=np.int64)]
        _, group_of = np.unique(roots, return_inverse=True)
        return Boundary(rings, seams, group_of.astype(np.int64), np.array(holes, bool), labels)


def _perp(p, q):
    """A point between ``p`` and ``q`` (nearly antipodal) off their great circle."""
    axis = np.where(
        np.abs(p[:, 2:3]) < 0.9, np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]])
    )
    return normalize(cross(p, axis))
