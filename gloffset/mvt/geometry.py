"""The offset region's boundary in one web-mercator tile, as MVT polygons.

The boundary comes as rings of small-circle arcs (region on their left, as
:class:`~gloffset.ResolvedOffset` gives them). For one tile this module

1. projects points of the arcs to the tile's coordinates (``0 .. extent`` across the
   tile, ``v`` down), longitudes unwrapped about the tile's centre (:class:`TileFrame`);
2. densifies the arcs there adaptively, until each straight segment's middle lies within
   :data:`DENSIFY` units of the arc's (:mod:`gloffset.mvt.densify`); every vertex lies
   on an arc;
3. clips the polylines to the tile grown by its buffer, and joins the pieces along the
   clip rectangle into closed rings with the region on their left (:func:`clip_rings`,
   the stitching of a convex clip);
4. drops the vertices a straight segment can skip within half a unit (Douglas-Peucker),
   rounds to integers and repairs what rounding breaks (:func:`to_polygons`), so the
   rings obey the MVT 2.1 rules: no self-intersection, no zero-area ring; the encoder
   orients them (exterior clockwise with ``y`` down).

Accuracy: before rounding every vertex off the clip rectangle lies on an arc to 1e-9
units; rounding moves it by at most 0.71 units; no straight segment strays more than
``0.5 + DENSIFY`` units from the arcs before rounding.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry.sphere import angle

__all__ = [
    "DENSIFY",
    "TileFrame",
    "world_uv",
    "clip_rings",
    "to_polygons",
    "SIMPLIFY",
]

#: Largest distance (tile units) of a densified segment's middle from its arc.
DENSIFY = 0.125
#: Douglas-Peucker tolerance (tile units): a vertex stays only where a straight segment
#: would stray farther than this from the boundary.
SIMPLIFY = 0.5
#: |sin(lat)| is clamped here for the projection (lat 89.9999 deg): far outside any tile.
_SIN_MAX = 1.0 - 1e-12


@dataclass(frozen=True)
class TileFrame:
    """Tile ``z/x/y`` in units of ``extent`` per tile: ``u`` east, ``v`` south.

    ``rect`` is the clip rectangle ``(u0, v0, u1, v1)``: the tile grown by ``buffer``,
    cut at the world's edges (mercator's +-85.0511 deg; at zoom 0 also at +-180 deg);
    ``lon0`` the longitude (radians) that the longitudes are unwrapped about.
    """

    z: int
    x: int
    y: int
    extent: int
    rect: tuple[float, float, float, float]
    lon0: float

    @classmethod
    def of(cls, z: int, x: int, y: int, extent: int, buffer: int, *, u_range=None) -> TileFrame:
        n = 1 << z
        top, bottom = -y * extent, (n - y) * extent
        v0, v1 = max(-buffer, top), min(extent + buffer, bottom)
        u0, u1 = (-buffer, extent + buffer) if u_range is None else u_range
        umid = 0.5 * (u0 + u1)
        lon0 = ((x + umid / extent) / n) * 2.0 * math.pi - math.pi
        return cls(z, x, y, extent, (float(u0), float(v0), float(u1), float(v1)), lon0)

    @property
    def scale(self) -> float:
        """Tile units per radian of longitude."""
        return (1 << self.z) * self.extent / (2.0 * math.pi)

    @property
    def world(self) -> float:
        """Tile units around the world."""
        return float((1 << self.z) * self.extent)

    def project(self, p: np.ndarray) -> np.ndarray:
        """Unit vectors (n, 3) to tile coordinates (n, 2), ``u`` unwrapped about ``lon0``."""
        return self.local(world_uv(p, self.z, self.extent))

    def local(self, uv: np.ndarray) -> np.ndarray:
        """World coordinates (:func:`world_uv`) to the tile's, ``u`` unwrapped about the
        rectangle's middle (within half the world of it)."""
        world = self.world
        u = uv[:, 0] - self.x * self.extent
        umid = 0.5 * (self.rect[0] + self.rect[2])
        u = np.where(u - umid > 0.5 * world, u - world, u)
        u = np.where(u - umid < -0.5 * world, u + world, u)
        return np.column_stack([u, uv[:, 1] - self.y * self.extent])

    def unproject(self, uv) -> np.ndarray:
        """Tile coordinates (n, 2) to unit vectors (n, 3)."""
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        k = self.scale
        lon = (uv[:, 0] + self.x * self.extent) / k - math.pi
        lat = np.arctan(np.sinh(math.pi - (uv[:, 1] + self.y * self.extent) / k))
        c = np.cos(lat)
        return np.column_stack([c * np.cos(lon), c * np.sin(lon), np.sin(lat)])

    def cap(self) -> tuple[np.ndarray, float]:
        """A spherical cap ``(centre, radius)`` holding the clip rectangle."""
        u0, v0, u1, v1 = self.rect
        c = self.unproject([[0.5 * (u0 + u1), 0.5 * (v0 + v1)]])[0]
        if self.z >= 3:
            # the box spans less than 90 deg of longitude each side of its centre: the
            # distance from the centre grows along each side to the corners
            pts = self.unproject([[u0, v0], [u1, v0], [u0, v1], [u1, v1]])
            r = float(np.max(angle(pts, np.broadcast_to(c, pts.shape))))
            return c, min(math.pi, r * (1.0 + 1e-9) + 1e-12)
        t = np.linspace(0.0, 1.0, 33)
        edge = np.concatenate(
            [
                np.column_stack([u0 + (u1 - u0) * t, np.full_like(t, v0)]),
                np.column_stack([u0 + (u1 - u0) * t, np.full_like(t, v1)]),
                np.column_stack([np.full_like(t, u0), v0 + (v1 - v0) * t]),
                np.column_stack([np.full_like(t, u1), v0 + (v1 - v0) * t]),
            ]
        )
        pts = self.unproject(edge)
        r = float(np.max(np.arccos(np.clip(pts @ c, -1.0, 1.0))))
        return c, min(math.pi, 1.1 * r + 1e-9)


def world_uv(p: np.ndarray, z: int, extent: int) -> np.ndarray:
    """Unit vectors (n, 3) to world coordinates at zoom ``z``: ``u`` from 0 at -180 deg
    east to ``2**z * extent`` at 180 deg, ``v`` from 0 at the top (85.05 deg) down.
    Tile ``x, y``'s coordinates are these less ``(x, y) * extent``."""
    k = (1 << z) * extent / (2.0 * math.pi)
    lon = np.arctan2(p[:, 1], p[:, 0])
    s = np.clip(p[:, 2], -_SIN_MAX, _SIN_MAX)
    return np.column_stack([(lon + math.pi) * k, (math.pi - np.arctanh(s)) * k])


def _liang_barsky(p0: np.ndarray, p1: np.ndarray, rect) -> tuple[np.ndarray, np.ndarray]:
    """Parameters ``(t0, t1)`` of each segment's part inside ``rect`` (empty: t0 > t1)."""
    u0, v0, u1, v1 = rect
    d = p1 - p0
    t0 = np.zeros(len(p0))
    t1 = np.ones(len(p0))
    with np.errstate(divide="ignore", invalid="ignore"):
        for k, lo, hi in ((0, u0, u1), (1, v0, v1)):
            dk = d[:, k]
            a = (lo - p0[:, k]) / dk
            b = (hi - p0[:, k]) / dk
            enter = np.where(dk > 0, a, b)
            leave = np.where(dk > 0, b, a)
            flat = dk == 0
            inside = (p0[:, k] >= lo) & (p0[:, k] <= hi)
            enter = np.where(flat, np.where(inside, -np.inf, np.inf), enter)
            leave = np.where(flat, np.where(inside, np.inf, -np.inf), leave)
            t0 = np.maximum(t0, enter)
            t1 = np.minimum(t1, leave)
    return t0, t1


def _runs(uv: np.ndarray, xyz: np.ndarray, closed: bool, rect):
    """Pieces of a polyline inside ``rect``: ``(points uv, a middle xyz, closed)``.

    Open pieces start and end on the rectangle's boundary. A closed polyline wholly
    inside is returned closed.
    """
    u0, v0, u1, v1 = rect
    ins = (uv[:, 0] >= u0) & (uv[:, 0] <= u1) & (uv[:, 1] >= v0) & (uv[:, 1] <= v1)
    if closed:
        if ins.all():
            return [(uv, xyz[len(xyz) // 2], True)]
        out = int(np.flatnonzero(~ins)[0])
        uv = np.vstack([np.roll(uv, -out, axis=0), uv[out : out + 1]])
        xyz = np.vstack([np.roll(xyz, -out, axis=0), xyz[out : out + 1]])
    if len(uv) < 2:
        return []
    p0, p1 = uv[:-1], uv[1:]
    t0, t1 = _liang_barsky(p0, p1, rect)
    seg = np.flatnonzero(t0 <= t1)
    if len(seg) == 0:
        return []
    a, b = t0[seg], t1[seg]
    d = p1[seg] - p0[seg]
    entry = p0[seg] + a[:, None] * d
    end = np.where((b >= 1.0)[:, None], p1[seg], p0[seg] + b[:, None] * d)
    # a run starts where a segment enters the rectangle or follows one that left it
    prev_b = np.concatenate([[0.0], b[:-1]])
    starts = (a > 0.0) | (prev_b < 1.0)
    starts[0] = True
    idx_end = np.cumsum(1 + starts.astype(np.int64)) - 1
    pts = np.empty((int(idx_end[-1]) + 1, 2))
    pts[idx_end] = end
    pts[idx_end[starts] - 1] = entry[starts]
    run_of = np.cumsum(starts) - 1
    # a point of the run on the sphere: the end of its first segment that ends inside
    probe: list = [None] * int(run_of[-1] + 1)
    inner = np.flatnonzero(b >= 1.0)
    runs_with, first = np.unique(run_of[inner], return_index=True)
    for r, k in zip(runs_with, inner[first]):
        probe[int(r)] = xyz[seg[k] + 1]
    parts = np.split(pts, idx_end[starts][1:] - 1)
    return [(part, probe[r], False) for r, part in enumerate(parts)]


def _perimeter(p: np.ndarray, rect) -> float:
    """Position of a point of the rectangle's boundary along it, counter-clockwise in
    (u, -v) from the corner (u0, v1) (bottom left on the map)."""
    u0, v0, u1, v1 = rect
    w, h = u1 - u0, v1 - v0
    u, v = float(p[0]), float(p[1])
    du = [abs(v - v1), abs(u - u1), abs(v - v0), abs(u - u0)]
    side = int(np.argmin(du))
    if side == 0:
        return min(max(u - u0, 0.0), w)
    if side == 1:
        return w + min(max(v1 - v, 0.0), h)
    if side == 2:
        return w + h + min(max(u1 - u, 0.0), w)
    return 2 * w + h + min(max(v - v0, 0.0), h)


def clip_rings(polylines, frame: TileFrame, keep=None):
    """Closed rings (region on their left in (u, -v)) of the region inside the frame's
    clip rectangle.

    Parameters
    ----------
    polylines : list of ``(uv, xyz, closed)``
        Pieces of the boundary (region on their left), in tile coordinates, with their
        points on the sphere; open ones start and end outside ``rect``.
    keep : callable or None
        ``keep(xyz (k, 3)) -> (k,) bool``: which pieces (by one of their points) are
        boundary; None keeps all.

    Returns
    -------
    rings : list of (k, 2) arrays, closed (last point repeated)
    crossed : bool
        Whether any piece crossed the rectangle (else its status is unknown here).
    """
    rect = frame.rect
    runs = []
    for uv, xyz, closed in polylines:
        runs.extend(_runs(uv, xyz, closed, rect))
    if keep is not None and runs:
        probe = np.array(
            [
                r[1] if r[1] is not None else frame.unproject(0.5 * (r[0][0] + r[0][1]))[0]
                for r in runs
            ],
            dtype=np.float64,
        )
        ok = keep(probe)
        runs = [r for r, k in zip(runs, ok) if k]
    rings = [np.vstack([r[0], r[0][:1]]) for r in runs if r[2]]
    open_runs = [r[0] for r in runs if not r[2]]
    if not open_runs:
        return rings, False
    u0, v0, u1, v1 = rect
    w, h = u1 - u0, v1 - v0
    total = 2 * (w + h)
    corners = [(0.0, (u0, v1)), (w, (u1, v1)), (w + h, (u1, v0)), (2 * w + h, (u0, v0))]
    entry = np.array([_perimeter(r[0], rect) for r in open_runs])
    exit_ = np.array([_perimeter(r[-1], rect) for r in open_runs])
    used = np.zeros(len(open_runs), dtype=bool)
    for first in range(len(open_runs)):
        if used[first]:
            continue
        pts = []
        cur = first
        for _ in range(len(open_runs) + 1):
            used[cur] = True
            pts.append(open_runs[cur])
            s = exit_[cur]
            gap = np.remainder(entry - s, total)
            nxt = int(np.argmin(np.where(used & (np.arange(len(gap)) != first), np.inf, gap)))
            g = gap[nxt]
            for cs, cp in sorted(corners, key=lambda c: np.remainder(c[0] - s, total)):
                if 0.0 < np.remainder(cs - s, total) < g:
                    pts.append(np.array([cp]))
            if nxt == first:
                break
            cur = nxt
        ring = np.vstack(pts)
        rings.append(np.vstack([ring, ring[:1]]))
    return rings, True


def _signed_area(ring: np.ndarray) -> float:
    """Shoelace area in (u, -v): positive for counter-clockwise on the map."""
    u, v = ring[:, 0], -ring[:, 1]
    return 0.5 * float(np.sum(u[:-1] * v[1:] - u[1:] * v[:-1]))


def _least_first(ring: np.ndarray) -> np.ndarray:
    """The closed ring ``ring`` (first vertex repeated last) started at its least vertex:
    least rounded ``u``, then least rounded ``v``, then the first of those."""
    body = ring[:-1] if np.array_equal(ring[0], ring[-1]) else ring
    key = np.rint(body)
    k = int(np.lexsort((key[:, 1], key[:, 0]))[0])
    if k == 0:
        return ring
    body = np.roll(body, -k, axis=0)
    return np.vstack([body, body[:1]])


def to_polygons(rings, rect=None):
    """Rings (region on their left, float tile units) to a valid shapely (Multi)Polygon
    with integer coordinates (``v`` down), or None when nothing is left.

    Exteriors run counter-clockwise on the map, holes clockwise; each hole goes to the
    smallest exterior that holds it. Vertices a straight segment can skip within
    :data:`SIMPLIFY` units are dropped, the rest rounded; what rounding makes invalid is
    repaired by :func:`shapely.make_valid`, and zero-area parts are dropped. Each ring
    starts at its least vertex (rounded ``u``, then ``v``) and the polygons come in the
    order of their exteriors' first vertices, so the same rings found from other arcs or
    in another order give the same polygons.
    """
    import shapely
    from shapely.geometry import LinearRing, MultiPolygon, Polygon

    ext, holes = [], []
    for r in rings:
        if len(r) < 4:
            continue
        r = _least_first(np.asarray(r, dtype=np.float64))
        simple = shapely.simplify(LinearRing(r), SIMPLIFY, preserve_topology=False)
        c = np.asarray(simple.coords) if not simple.is_empty else np.zeros((0, 2))
        if len(c) < 4:
            continue
        c = np.rint(c)
        keep = np.concatenate([[True], np.any(np.diff(c, axis=0) != 0, axis=1)])
        c = c[keep]
        if len(c) < 4:
            continue
        c = _least_first(c)
        a = _signed_area(c)
        if a > 0:
            ext.append(c)
        elif a < 0:
            holes.append(c)
    if not ext:
        return None
    ext.sort(key=lambda e: (e[0, 0], e[0, 1]))
    holes.sort(key=lambda h: (h[0, 0], h[0, 1]))
    polys = [Polygon(e) for e in ext]
    areas = [p.area for p in polys]
    assigned: list[list] = [[] for _ in ext]
    for hole in holes:
        hp = Polygon(hole)
        probe = hp.representative_point() if hp.is_valid and hp.area > 0 else shapely.Point(hole[0])
        best = None
        for i, p in enumerate(polys):
            if p.covers(probe) and (best is None or areas[i] < areas[best]):
                best = i
        if best is not None:
            assigned[best].append(hole)
    parts = [Polygon(e, hs) for e, hs in zip(ext, assigned)]
    geom = parts[0] if len(parts) == 1 else MultiPolygon(parts)
    if not geom.is_valid:
        geom = shapely.make_valid(geom)
        polys2 = [g for g in shapely.get_parts(geom) if g.geom_type in ("Polygon", "MultiPolygon")]
        pieces = []
        for g in polys2:
            pieces.extend(shapely.get_parts(g))
        pieces = [p for p in pieces if p.area > 0]
        if not pieces:
            return None
        geom = pieces[0] if len(pieces) == 1 else MultiPolygon(pieces)
        if not geom.is_valid:  # overlapping pieces: their union
            geom = shapely.unary_union(pieces)
    return geom if not geom.is_empty and geom.area > 0 else None
