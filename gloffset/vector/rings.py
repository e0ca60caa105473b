"""Ring classification: closed rings of small-circle arcs sorted into exteriors and holes.

The last step of both methods of self-intersection removal (paper Sec. 4.4, see
:mod:`gloffset.vector.selfintersect`): the rings that bound the offset region carry the
region on their left, and a ring bounds a hole when a point outside the region lies on
its left too. Which side a point lies on is decided by crossing parity
(:class:`RingParity`): the number of times the short great-circle arcs from a point
known to lie outside the region (checked with :func:`gloffset.edges.contains_xyz`) cross each
ring. Each hole goes to the smallest exterior around it, by the areas that
:func:`left_areas` finds with Gauss-Bonnet on the arcs.

The same parity answers "is this point in the region" for a
:class:`~gloffset.vector.resolved.ResolvedOffset` (exact for points farther than ~1e-15
rad from every ring), and the same areas give its area.
"""

from __future__ import annotations

import numpy as np

from ..geometry.captree import CapTree
from ..geometry.sphere import angle, normalize, robust_cross, rotate
from .smallcircle import CircleArcs, circle_of, intersect, point_at, position

__all__ = ["RingParity", "holes_and_polygons", "left_areas", "ring_table"]


def ring_table(rings) -> tuple[CircleArcs, np.ndarray, np.ndarray]:
    """All arcs of closed rings in one table, the ring of each arc and each ring's first arc."""
    sizes = np.array([len(r.centers) for r in rings], dtype=np.int64)
    q = np.concatenate([r.centers for r in rings])
    end = np.concatenate([r.junctions for r in rings])
    start = np.concatenate([np.roll(r.junctions, 1, axis=0) for r in rings])
    axis, h = circle_of(q)
    first = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    return CircleArcs(axis, h, start, end), np.repeat(np.arange(len(rings)), sizes), first


def left_areas(arcs: CircleArcs, ring_id: np.ndarray, first: np.ndarray) -> np.ndarray:
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


def _probes(arcs: CircleArcs, ring_id: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
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


def holes_and_polygons(rings, shape, d, parity=None):
    """Holes and polygons: a ring bounds a hole when a point outside the region lies on its left.

    Returns ``(holes, polygons, parity)``: a bool per ring, ``(exterior, [holes])``
    per polygon, and the :class:`RingParity` that decided them (``parity`` when given,
    the rings' own; kept for later queries); each hole goes to the smallest exterior
    whose left side holds it.
    """
    par = RingParity(rings, shape, d) if parity is None else parity
    n = len(rings)
    if n == 0:
        return np.zeros(0, bool), [], par
    probes, _ = _probes(par.arcs, par.ring_id, n)
    # probe k lies on the left of ring k: an even number of crossings of ring k on the way
    # from the outside point puts that point on the left too
    own = np.arange(n)
    holes = ~par.ring_parity(probes, own)
    areas = left_areas(par.arcs, par.ring_id, par.first)
    ext = np.flatnonzero(~holes)
    polygons: dict[int, list[int]] = {int(i): [] for i in ext}
    hole_idx = np.flatnonzero(holes)
    if len(hole_idx):
        # candidate owners: exteriors whose bounding cap holds the hole's probe
        caps_c, caps_r = par.ring_caps()
        pjs, pis = [], []
        for j in hole_idx.tolist():
            near = ext[angle(caps_c[ext], probes[j]) <= caps_r[ext] + 1e-12]
            pjs.append(np.full(len(near), j))
            pis.append(near)
        pj = np.concatenate(pjs).astype(np.int64)
        pi = np.concatenate(pis).astype(np.int64)
        inside = par.ring_parity(probes[pj], pi) if len(pj) else np.zeros(0, bool)
        for j in hole_idx.tolist():
            owners = pi[(pj == j) & inside]
            if len(owners):
                polygons[int(owners[np.argmin(areas[owners])])].append(j)
            else:  # nothing around it: the region holds the outside point's far side
                polygons[j] = []
    return holes, [(i, hs) for i, hs in polygons.items()], par


class RingParity:
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
            self.arcs, self.ring_id, self.first = ring_table(rings)
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
        from ..edges import contains_xyz, distance_xyz

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
        """Whether points ``p`` (n, 3) lie in the region the rings bound (odd crossings of
        all rings together on the way from the outside point)."""
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
