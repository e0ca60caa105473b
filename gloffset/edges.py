"""The edges of a shape as arcs, with what the distance and inside tests need.

:class:`CurveArcs` holds every edge of a :class:`~gloffset.shape.Shape` (ring edges,
seams, line segments, points) as an arc ``a -> b`` with its unit normal, its bounding cap
(padded: :func:`gloffset.geometry.caps.arc_cap`, :func:`gloffset.geometry.caps.pad`), whether it is
boundary (has distance; seams do not) and its region component, and the cap trees over
them (:attr:`CurveArcs.tree` over every arc, :attr:`CurveArcs.ring_tree` over the ring
edges). It is the shape's one edge index: made once per shape (:meth:`Shape.arcs
<gloffset.shape.Shape.arcs>`, kept in :class:`~gloffset.shape.Derived`) and shared by the
raster engine, the GPU records, the inside tests by crossing parity, the offsets'
self-intersection removal and the shape's own checks. :func:`component_status` tells,
for a few points, which region components contain them, by exact crossing parity to the
shape's reference points.
:func:`distance_xyz` is the exact distance from points to the shape's curves (the
nearest vertex bounds it, the cap tree of the arcs finds the only arcs that can be
nearer), and :func:`contains_xyz` the offset region's membership from it: what
:func:`gloffset.distance` and the exact checks of the vector offsets and the index use.

Accuracy: the caps contain their arcs (padded by a relative 1e-12); the crossing tests
are those of :func:`gloffset.geometry.sphere.arcs_cross`; distances are those of
:func:`gloffset.geometry.sphere.arc_distance` (absolute error below 1e-15 rad).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry.caps import arc_cap, pad
from .geometry.crossings import inside
from .geometry.sphere import angle, arc_distance, arcs_cross, cross, normalize, robust_cross
from .memo import kept_property

__all__ = [
    "CurveArcs",
    "status_bits",
    "inside_any",
    "component_status",
    "points_inside",
    "distance_xyz",
    "contains_xyz",
]

#: Points times boundary vertices per chunk of :func:`distance_xyz` (bounded memory).
_PAIRS = 1 << 22


@dataclass
class CurveArcs:
    """The arcs of a shape with what the engine needs (all float64)."""

    a: np.ndarray
    b: np.ndarray
    n: np.ndarray  # unit left normal normalize(a x b); zero for points
    mid: np.ndarray  # bounding cap centre
    half: np.ndarray  # bounding cap radius
    boundary: np.ndarray  # has distance (not a seam)
    group: np.ndarray  # region component, -1 for lines and points
    n_groups: int

    @kept_property
    def lunes(self) -> tuple[np.ndarray, np.ndarray]:
        """``(n x a, b x n)``: the normals of the planes that bound each arc's lune (the
        points whose nearest point of the great circle lies on the arc)."""
        return cross(self.n, self.a), cross(self.b, self.n)

    @kept_property
    def cap_lonlat(self) -> tuple[np.ndarray, np.ndarray]:
        """``(lon, lat)`` (radians) of the bounding caps' centres :attr:`mid` (made once)."""
        m = self.mid
        return np.arctan2(m[:, 1], m[:, 0]), np.arctan2(m[:, 2], np.hypot(m[:, 0], m[:, 1]))

    @kept_property
    def columns(self) -> np.ndarray:
        """(19, n) float64, one row per coordinate: ``a``, ``b``, ``n``, the two
        :attr:`lunes` normals, ``mid`` (three rows each) and ``half``; what the GPU
        records gather per (bin, arc) pair, in one gather (made once)."""
        lune1, lune2 = self.lunes
        parts = (self.a, self.b, self.n, lune1, lune2, self.mid)
        return np.ascontiguousarray(np.vstack([v.T for v in parts] + [self.half[None, :]]))

    @kept_property
    def rows(self) -> np.ndarray:
        """(n, 20) float64, read-only: :attr:`columns` arc by arc, then 1 for a ring edge
        (0 else): what the compute shaders read per arc (``shaders/arc_records.comp``,
        ``shaders/scatter_pairs.comp``; made once)."""
        out = np.empty((len(self.half), 20))
        out[:, :19] = self.columns.T
        out[:, 19] = self.group >= 0
        out.setflags(write=False)
        return out

    @kept_property
    def tree(self):
        """The bounding-cap tree over the arcs (built once), each arc's start ``a`` its
        point for early answers (:meth:`gloffset.geometry.captree.CapTree.near` with ``stop``)."""
        from .geometry.captree import CapTree

        return CapTree(self.mid, self.half, reps=self.a)

    @kept_property
    def ring(self) -> np.ndarray:
        """Indices of the ring edges (seams included; line segments and points left out)."""
        return np.flatnonzero(self.group >= 0)

    @kept_property
    def ring_tree(self):
        """The bounding-cap tree over the ring edges :attr:`ring` (built once): item ``k``
        is arc ``ring[k]``. What the inside tests by crossing parity and the checks of
        crossing or overlapping rings search."""
        from .geometry.captree import CapTree

        return CapTree(self.mid[self.ring], self.half[self.ring])

    @kept_property
    def end_samples(self) -> list[np.ndarray]:
        """At most 4096 arc ends of each kind present (boundary arcs, then ring edges),
        spread along the curves: what :func:`gloffset.raster.vector.levels.coarse` bounds the
        nearest arc with (made once)."""
        out = []
        kinds = [self.boundary, self.group >= 0]
        if np.array_equal(kinds[0], kinds[1]):  # polygons without seams: one set serves
            kinds.pop()
        for kind in kinds:
            if kind.any():
                ends = self.a[kind]
                out.append(ends[:: max(1, len(ends) // 4096)])
        return out

    @kept_property
    def ring_present(self) -> np.ndarray:
        """Which components have ring edges (for :func:`component_status`, made once)."""
        return np.bincount(self.group[self.ring], minlength=self.n_groups) > 0

    @classmethod
    def from_shape(cls, shape) -> CurveArcs:
        """The arcs of ``shape`` (made once per shape and kept on it, like its edges)."""
        got = shape.derived.arcs  # the hot path: one read, no call
        return got if got is not None else shape.derived.once("arcs", lambda: cls._make(shape))

    @classmethod
    def _make(cls, shape) -> CurveArcs:
        e = shape.edges()
        return cls.of(e.a, e.b, e.boundary, e.group, shape.n_groups)

    @classmethod
    def of(cls, a, b, boundary, group, n_groups: int) -> CurveArcs:
        """The arcs ``a -> b`` with their normals and bounding caps (row by row: the
        same bits for the same ends wherever they sit)."""
        n = normalize(robust_cross(a, b))
        mid, half = arc_cap(a, b)
        return cls(a, b, n, mid, pad(half), boundary, group, n_groups)


def status_bits(n_groups: int, k: int) -> np.ndarray:
    return np.zeros((k, max(1, -(-n_groups // 8))), dtype=np.uint8)


def inside_any(status: np.ndarray) -> np.ndarray:
    return np.asarray(status.any(axis=1))


def points_inside(shape, p: np.ndarray) -> np.ndarray:
    """Whether points ``p`` (unit vectors, (k, 3)) are inside the shape's polygons: the
    raster levels' own test (crossings to the shape's reference points against the arcs
    whose caps reach, :func:`component_status`), a few milliseconds a point whatever the
    input, with no index to build first. Lines and points have no inside."""
    arcs = CurveArcs.from_shape(shape)
    if not arcs.n_groups:
        return np.zeros(len(p), dtype=bool)
    return inside_any(component_status(shape, arcs, np.asarray(p, dtype=np.float64)))


def _boundary_vertices(shape, arcs: CurveArcs) -> np.ndarray:
    """The distinct ends of the boundary arcs (seams left out), made once per shape."""

    bd = arcs.boundary
    return shape.derived.once(
        "boundary_vertices", lambda: np.unique(np.concatenate([arcs.a[bd], arcs.b[bd]]), axis=0)
    )


def distance_xyz(shape, p: np.ndarray) -> np.ndarray:
    """Great-circle distance in radians from unit vectors ``p`` (n, 3) to the shape's curves
    (``inf`` for a shape without any).

    The nearest boundary vertex (one matrix product per chunk of points) gives each point
    an upper bound ``u`` on its distance; only the boundary arcs whose bounding caps come
    within ``u`` (found with :meth:`gloffset.geometry.captree.CapTree.near` in the cap tree of
    :attr:`CurveArcs.tree`) can be nearer, and those get the exact point-to-arc distance.

    Accuracy: the exact distance to the nearest boundary arc, vertex or isolated point,
    with absolute error below 1e-15 rad (that of :func:`gloffset.geometry.sphere.arc_distance`).
    Seams are not boundary and do not count. The caps are padded and the tree's test
    is rigorous, so the shortcut never drops the nearest arc.
    """
    arcs = CurveArcs.from_shape(shape)
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    out = np.full(len(p), np.inf)
    v = _boundary_vertices(shape, arcs)
    if len(v) == 0 or len(p) == 0:
        return out
    chunk = max(1, _PAIRS // len(v))
    for s in range(0, len(p), chunk):
        q = p[s : s + chunk]
        u = angle(q, v[np.argmax(q @ v.T, axis=1)])
        qi, ai, _ = arcs.tree.near(q, u)
        keep = arcs.boundary[ai]
        qi, ai = qi[keep], ai[keep]
        np.minimum.at(u, qi, arc_distance(q[qi], arcs.a[ai], arcs.b[ai], arcs.n[ai]))
        out[s : s + chunk] = u
    return out


def contains_xyz(shape, p: np.ndarray, d: float) -> np.ndarray:
    """Offset-region membership of unit vectors ``p`` (n, 3) for an angular distance ``d``.

    ``d > 0``: inside a polygon of the shape or within ``d`` of its curves; ``d < 0``:
    inside a polygon and farther than ``|d|`` from its boundary; ``d = 0``: inside a
    polygon (:func:`gloffset.geometry.crossings.inside`, every point against every ring edge).

    Accuracy: exact for points whose distance differs from ``|d|`` by more than
    1e-15 rad and that lie farther than 1e-15 rad from the boundary.
    """
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    ins = inside(shape, p)
    if d == 0.0:
        return ins
    out = ins.copy()
    if d > 0.0:
        rest = np.flatnonzero(~ins)
        out[rest] = distance_xyz(shape, p[rest]) <= d
    else:
        cand = np.flatnonzero(ins)
        out[cand] = distance_xyz(shape, p[cand]) > -d
    return out


def component_status(shape, arcs: CurveArcs, p: np.ndarray) -> np.ndarray:
    """Packed component statuses of points by crossings to a reference point.

    Only the ring edges whose bounding caps meet the arc ``p -> ref`` can cross it: they
    are found for all the points at once in the ring edges' cap tree
    (:meth:`~gloffset.geometry.captree.CapTree.along`, a padded superset), so a point costs
    the edges along its way, not all of them (all 211,690 arcs of ``countries_10m``: 0.3
    ms a point instead of 6). The crossings are those of every ring edge, exactly.
    """
    status = status_bits(arcs.n_groups, len(p))
    if len(p) == 0:
        return status
    refs, ref_status = shape.reference_points()
    k = (p @ refs[0] < -0.5).astype(np.int64)  # the reference within 120 degrees
    r = refs[k]
    pr = np.cross(p, r)
    short = np.sqrt(np.einsum("ij,ij->i", pr, pr)) <= 1e-6  # no direction: every edge
    far = np.flatnonzero(~short)
    seg, item = arcs.ring_tree.along(p[far], r[far])
    order = np.argsort(seg, kind="stable")
    bounds = np.searchsorted(seg[order], np.arange(1, len(far)))
    along = iter(np.split(arcs.ring[item[order]], bounds))
    present = arcs.ring_present
    for i, pt in enumerate(p):
        idx = arcs.ring if short[i] else next(along)
        hit = arcs_cross(pt, r[i], arcs.a[idx], arcs.b[idx], arcs.n[idx])
        par = np.bincount(arcs.group[idx[hit]], minlength=arcs.n_groups) % 2 == 1
        ins = np.zeros(arcs.n_groups, dtype=bool)
        ins[present] = par[present] ^ ref_status[int(k[i])][present]
        status[i] = np.packbits(ins, bitorder="little")[: status.shape[1]]
    return status
