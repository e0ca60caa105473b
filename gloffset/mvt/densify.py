"""The points of the boundary's arcs in one zoom's tiles: one subdivision per circle.

A tile draws each small-circle arc as straight segments whose middles lie within
:data:`~gloffset.mvt.geometry.DENSIFY` units of the arc. The points are chosen on the
arc's whole circle, not on the arc: the circle's turn from a reference direction of its
own (:class:`Circles`) is cut into ``2**L`` equal parts (at least 16, about
:data:`PART0` world units each at the equator's scale: ``L`` depends on the circle's
radius and the zoom alone), and each part is halved until its
projected middle lies within ``DENSIFY`` of its chord (world coordinates of the zoom,
longitudes compared the short way round). The same part of the same circle is cut the
same way whatever arc it is met on, so an arc gets its ends and the circle's points
between them: a tile whose arcs were resolved from the edges near it
(:class:`~gloffset.mvt.boundary.LocalBoundary`) and one cut from the whole offset
(:class:`~gloffset.mvt.boundary.ResolvedBoundary`) get the same points wherever their
arcs agree, and a pyramid computes every arc's points once per zoom
(:class:`ZoomPoints`) for all its tiles. A part that lies far outside a tile's clip
rectangle is not halved for that tile (:func:`densify`): what remains near the
rectangle is the same.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry.sphere import angle
from .geometry import DENSIFY, TileFrame, world_uv

__all__ = ["Circles", "arc_points", "densify", "ZoomPoints"]

#: The first cut of a circle: 2**L equal parts, L at least LEVEL0 and such that the parts
#: are about PART0 world units long (at the equator's scale).
LEVEL0 = 4
PART0 = 2048.0
#: Parts are not halved past this level (2 pi / 2**40 rad, 6e-12 rad).
LEVEL_MAX = 40
_TWO_PI = 2.0 * math.pi


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=1, keepdims=True)


class Circles:
    """The circles of small-circle arcs (centre ``q``: the circle is ``x . q = |q|^2``
    on the sphere), each with its own reference frame: a point at turn ``a`` is
    ``q + rho (cos a e1 + sin a e2)``, normalised."""

    def __init__(self, centers: np.ndarray):
        q = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
        h = np.linalg.norm(q, axis=1)
        n = q / np.where(h > 0.0, h, 1.0)[:, None]
        # the reference: the first axis not near the circle's own (same choice every time)
        ref = np.zeros_like(n)
        use_x = np.abs(n[:, 0]) < 0.57
        use_y = ~use_x & (np.abs(n[:, 1]) < 0.57)
        ref[use_x, 0] = 1.0
        ref[use_y, 1] = 1.0
        ref[~use_x & ~use_y, 2] = 1.0
        self.q = q
        self.n = n
        self.e1 = _unit(np.cross(n, ref))
        self.e2 = np.cross(n, self.e1)
        self.rho = np.sqrt(np.maximum(0.0, 1.0 - h * h))

    def turn(self, k: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The turn of points ``p`` about circles ``k``, in [0, 2 pi)."""
        w = p - self.q[k]
        a = np.arctan2(np.sum(w * self.e2[k], axis=1), np.sum(w * self.e1[k], axis=1))
        return np.where(a < 0.0, a + _TWO_PI, a)

    def node(self, k: np.ndarray, level: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Unit vectors of the points ``j`` of ``2**level`` equal parts of circles ``k``
        (``j`` any integer: taken modulo the parts; the same point from every level)."""
        parts = np.left_shift(1, level)
        a = (_TWO_PI * np.remainder(j, parts)) / parts
        k = np.asarray(k)
        p = self.q[k] + self.rho[k][:, None] * (
            np.cos(a)[:, None] * self.e1[k] + np.sin(a)[:, None] * self.e2[k]
        )
        return _unit(p)


def arc_points(centers, starts, ends, z: int, extent: int, near: TileFrame | None = None):
    """Each arc's points at zoom ``z``: ``(xyz (k, 3), arc (k,))``, arc after arc, each
    from its start to its end (both included), the circle's points between (see the
    module notes). With ``near``, parts far outside its clip rectangle are not halved.
    """
    centers = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
    starts = np.asarray(starts, dtype=np.float64).reshape(-1, 3)
    ends = np.asarray(ends, dtype=np.float64).reshape(-1, 3)
    m = len(centers)
    if m == 0:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    circles = Circles(centers)
    idx = np.arange(m)
    a_s = circles.turn(idx, starts)
    sweep = angle(_unit(starts - centers), _unit(ends - centers))  # below pi
    ccw = np.einsum("ij,ij->i", np.cross(starts - centers, ends - centers), circles.n) >= 0.0
    lo = np.where(ccw, a_s, a_s - sweep)  # the arc is [lo, lo + sweep] (unwrapped turn)
    hi = lo + sweep
    parts = _first_cut(circles, lo, hi, z, extent)
    arc, level, j = _halve(circles, parts, lo, hi, z, extent, near)
    n_arc, n_level, n_j, turn = _inner_nodes(arc, level, j, lo, hi)
    pts = circles.node(n_arc, n_level, n_j)
    # arc after arc, from its start: the turn up (counter-clockwise) or down
    t = np.concatenate(
        [np.zeros(m), np.where(ccw[n_arc], turn - lo[n_arc], hi[n_arc] - turn), sweep]
    )
    a_all = np.concatenate([idx, n_arc, idx])
    order = np.lexsort((t, a_all))
    xyz = np.concatenate([starts, pts, ends])[order]
    return xyz, a_all[order]


def _first_cut(circles: Circles, lo, hi, z: int, extent: int):
    """The parts ``(arc, level, j)`` of each circle's first cut that meet its arc
    ``[lo, hi]``: parts of about :data:`PART0` world units at the equator's scale."""
    world = float((1 << z) * extent)
    span = circles.rho * world / PART0
    lv = np.floor(np.log2(np.maximum(span, 1.0)))
    lv0 = np.clip(lv, LEVEL0, LEVEL_MAX - 1).astype(np.int64)
    step0 = _TWO_PI / np.left_shift(1, lv0).astype(np.float64)
    j0 = np.floor(lo / step0).astype(np.int64)
    j1 = np.floor(hi / step0).astype(np.int64)
    cnt = j1 - j0 + 1
    arc = np.repeat(np.arange(len(lo)), cnt)
    j = np.repeat(j0, cnt) + np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    return arc, lv0[arc], j


def _halve(circles: Circles, parts, lo, hi, z: int, extent: int, near):
    """Halve the parts until their middles lie within :data:`DENSIFY` of their chords
    (or, with ``near``, they lie far outside its rectangle); the final parts."""
    arc, level, j = parts
    world = float((1 << z) * extent)
    half = 0.5 * world
    qa = world_uv(circles.node(arc, level, j), z, extent)
    qb = world_uv(circles.node(arc, level, j + 1), z, extent)
    done_arc, done_level, done_j = [], [], []
    while len(arc):
        qm = world_uv(circles.node(arc, level + 1, 2 * j + 1), z, extent)
        qb_ = qb.copy()
        qm_ = qm.copy()
        qb_[:, 0] = qa[:, 0] + np.remainder(qb[:, 0] - qa[:, 0] + half, world) - half
        qm_[:, 0] = qa[:, 0] + np.remainder(qm[:, 0] - qa[:, 0] + half, world) - half
        dev = np.hypot(*(qm_ - 0.5 * (qa + qb_)).T)
        split = (dev > DENSIFY) & (level < LEVEL_MAX)
        if near is not None:
            la = near.local(qa)
            lb = la + (qb_ - qa)
            lo_uv = np.minimum(la, lb) - 2.0 * dev[:, None] - 1.0
            hi_uv = np.maximum(la, lb) + 2.0 * dev[:, None] + 1.0
            u0, v0, u1, v1 = near.rect
            far = (hi_uv[:, 0] < u0) | (lo_uv[:, 0] > u1) | (hi_uv[:, 1] < v0)
            split &= ~(far | (lo_uv[:, 1] > v1))
        done_arc.append(arc[~split])
        done_level.append(level[~split])
        done_j.append(j[~split])
        if not split.any():
            break
        s_arc, s_level, s_j = arc[split], level[split] + 1, 2 * j[split]
        s_qa, s_qb, s_qm = qa[split], qb[split], qm[split]
        # the halves that meet the arc (the first starts at 2j, the second at 2j + 1)
        scale = _TWO_PI / np.left_shift(1, s_level).astype(np.float64)
        first = (s_j + 1) * scale > lo[s_arc]
        second = (s_j + 1) * scale < hi[s_arc]
        arc = np.concatenate([s_arc[first], s_arc[second]])
        level = np.concatenate([s_level[first], s_level[second]])
        j = np.concatenate([s_j[first], s_j[second] + 1])
        qa = np.concatenate([s_qa[first], s_qm[second]])
        qb = np.concatenate([s_qm[first], s_qb[second]])
    return np.concatenate(done_arc), np.concatenate(done_level), np.concatenate(done_j)


def _inner_nodes(arc, level, j, lo, hi):
    """The parts' ends strictly inside their arcs, once each: ``(arc, level, j, turn)``."""
    n_arc = np.concatenate([arc, arc])
    n_level = np.concatenate([level, level])
    n_j = np.concatenate([j, j + 1])
    # one key per point: its turn in the finest parts (2**LEVEL_MAX per circle turn)
    fine = np.left_shift(n_j, LEVEL_MAX - n_level)
    turn = fine * (_TWO_PI / float(1 << LEVEL_MAX))
    inner = (turn > lo[n_arc]) & (turn < hi[n_arc])
    n_arc, n_level, n_j, fine, turn = (x[inner] for x in (n_arc, n_level, n_j, fine, turn))
    key = np.unique(np.column_stack([n_arc, fine]), axis=0, return_index=True)[1]
    return n_arc[key], n_level[key], n_j[key], turn[key]


def densify(frame: TileFrame, centers, starts, ends) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each arc's points as ``(xyz (k, 3), uv (k, 2))``, from its start to its end, in the
    frame's coordinates: :func:`arc_points` near the frame's rectangle."""
    m = len(centers)
    if m == 0:
        return []
    xyz, arc = arc_points(centers, starts, ends, frame.z, frame.extent, near=frame)
    uv = frame.local(world_uv(xyz, frame.z, frame.extent))
    bounds = np.searchsorted(arc, np.arange(1, m))
    return list(zip(np.split(xyz, bounds), np.split(uv, bounds)))


class ZoomPoints:
    """The points of :func:`arc_points` of many arcs at one zoom, computed once for every
    tile of the zoom (a pyramid's): :meth:`chain` gives a chain of them as :func:`densify`
    gives it near each tile's rectangle, :meth:`tiles` the arcs near each tile."""

    def __init__(self, centers, starts, ends, z: int, extent: int):
        self.z, self.extent = z, extent
        self.xyz, arc = arc_points(centers, starts, ends, z, extent)
        self.uv = world_uv(self.xyz, z, extent)
        self.first = np.searchsorted(arc, np.arange(len(centers) + 1))

    def tiles(self, buffer: int) -> dict:
        """The arcs (ascending indices) whose points or segments come within ``buffer``
        units (plus one) of each tile of the zoom, by ``(x, y)``; a tile no arc comes
        near is absent. Its boundary lies more than ``buffer`` units away (the arcs
        stray at most :data:`DENSIFY` from their segments)."""
        n = 1 << self.z
        e = float(self.extent)
        m = len(self.first) - 1
        counts = np.diff(self.first)
        arc = np.repeat(np.arange(m), counts)
        # u of each point taken the short way round from its arc's start: no seam
        u0 = self.uv[self.first[:-1], 0]
        du = self.uv[:, 0] - u0[arc]
        world = n * e
        u = u0[arc] + np.remainder(du + 0.5 * world, world) - 0.5 * world
        v = self.uv[:, 1]
        lo_u = np.minimum.reduceat(u, self.first[:-1]) if m else u
        hi_u = np.maximum.reduceat(u, self.first[:-1]) if m else u
        lo_v = np.minimum.reduceat(v, self.first[:-1]) if m else v
        hi_v = np.maximum.reduceat(v, self.first[:-1]) if m else v
        pad = buffer + 1.0
        x0 = np.floor((lo_u - pad) / e).astype(np.int64)
        x1 = np.floor((hi_u + pad) / e).astype(np.int64)
        y0 = np.clip(np.floor((lo_v - pad) / e), 0, n - 1).astype(np.int64)
        y1 = np.clip(np.floor((hi_v + pad) / e), 0, n - 1).astype(np.int64)
        nx, ny = x1 - x0 + 1, y1 - y0 + 1
        nx = np.minimum(nx, n)  # an arc round the world reaches every column
        k = nx * ny
        pair_arc = np.repeat(np.arange(m), k)
        j = np.arange(int(k.sum())) - np.repeat(np.cumsum(k) - k, k)
        tx = np.remainder(x0[pair_arc] + j % nx[pair_arc], n)
        ty = y0[pair_arc] + j // nx[pair_arc]
        key = ty * n + tx
        order = np.lexsort((pair_arc, key))
        key, pair_arc = key[order], pair_arc[order]
        cuts = np.flatnonzero(np.diff(key)) + 1
        out = {}
        for part_key, part in zip(
            key[np.r_[0, cuts]] if len(key) else [], np.split(pair_arc, cuts)
        ):
            out[(int(part_key % n), int(part_key // n))] = np.unique(part)
        return out

    def chain(self, ids: np.ndarray, frame: TileFrame) -> tuple[np.ndarray, np.ndarray]:
        """The points ``(xyz, uv)`` of consecutive arcs ``ids``, each arc's end being the
        next one's start (kept once), in ``frame``'s coordinates."""
        lo, hi = self.first[ids], self.first[ids + 1] - 1  # each arc less its end
        hi = hi.copy()
        hi[-1] += 1
        counts = hi - lo
        idx = np.repeat(lo - np.cumsum(counts) + counts, counts) + np.arange(int(counts.sum()))
        return self.xyz[idx], frame.local(self.uv[idx])
