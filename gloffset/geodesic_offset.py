"""Vector offsets on the ellipsoid: the boundary at geodesic distance ``|d|``.

``offset(shape, d, ellipsoid="WGS84")`` gives the boundary of the offset region on the
ellipsoid (edges are geodesics, ``d`` a geodesic length in metres) as densified rings,
every point of which lies within ``tolerance`` (default 1 m) of geodesic distance
``|d|`` from the curves. Without ``ellipsoid`` it is :func:`gloffset.vector.offset.offset`,
exactly.

How. On the conformal sphere of the ellipsoid (:mod:`gloffset.ellipsoid.model`) the
geodesic distance is the spherical one times a scale within 0.34 % of the local one
(:mod:`gloffset.ellipsoid.bounds`), so the *resolved* spherical offset (union,
self-intersections removed, Sec. 4.4) of the shape's image at ``|d| / K`` (``K`` the
scale at the shape's median latitude) has the topology of the ellipsoidal boundary
and lies within the ratio band of it. Its rings are densified, and every point is
moved along the great circle leaving its generator (the arc's vertex, or the foot on
the arc's edge: the direction in which the distance grows; at a junction of two arcs
the mean of both directions) until its geodesic distance
(:func:`gloffset.ellipsoidal.nearest_geodesic`, within 1 um) is ``|d|`` to within
:data:`VERTEX_TOL` times the tolerance (1 mm for 1 m): secant steps, started at ``|d|
/ K`` from the generator with ``K`` the scale at the middle of the path (right to a
relative ``O(f (d/a)^2)``, so one or two distances per point), moves bounded by twice
the ratio band. A point whose direction does not reach ``|d|`` (beside a corner of
the ellipsoidal boundary that the spherical one has elsewhere) takes Newton steps
along the distance's gradient (finite differences) instead. The parallel curves of
the geodesic edges and the geodesic circles about the vertices, with their
junctions, are what this traces; no formula of theirs is needed.

Tolerance. Between consecutive points a ring's edge is the geodesic (within
:func:`gloffset.ellipsoid.edge_deviation` of the great circle of the conformal
sphere). Each edge's midpoint on the conformal sphere is measured; while its
distance differs from ``|d|`` by more than ``tolerance / 2`` minus the edge's
deviation bound, the moved midpoint is inserted. Between two samples the boundary is
smooth (its deviation from the chord is largest near the middle) or has one corner
(a junction; the deviation at the midpoint is then at least half that at the
corner), so the whole edge is within ``tolerance``. This argument is not a proof
(two corners between samples would escape it); the tests check it against the brute
force of :mod:`gloffset.reference` at every vertex and every edge's geodesic midpoint.

Limits. Parts or gaps of the region narrower than the ratio band (0.34 % of ``d``
plus the edges' deviation bounds) may be joined or split as on the sphere at
``|d| / K`` rather than as on the ellipsoid. Cost: a few geodesic distances per
output point (about 1 ms each, pure Python).
"""

from __future__ import annotations

import numpy as np

from .ellipsoid import as_ellipsoid, edge_deviation
from .ellipsoidal import Conformal, conformal, nearest_geodesic
from .ellipsoidal import contains as ellipsoidal_contains
from .errors import InvalidDistanceError
from .shape import read
from .sphere import angle, dot, lonlat_to_xyz, normalize, xyz_to_lonlat
from .units import EARTH_RADIUS, VECTOR_LIMIT, offset_angle
from .vector.arcrings import sample_ring
from .vector.offset import Offset
from .vector.offset import offset as sphere_offset

__all__ = ["DEFAULT_TOLERANCE", "VERTEX_TOL", "GeodesicOffset", "offset"]

#: Default tolerance (metres) of the rings: every point within it of distance |d|.
DEFAULT_TOLERANCE = 1.0
#: Each moved point's distance is |d| to within this fraction of the tolerance.
VERTEX_TOL = 1e-3
#: Rounds of midpoint insertion before giving up (each halves the edges it touches).
MAX_ROUNDS = 30
#: Secant steps per point.
MAX_STEPS = 12


class GeodesicOffset:
    """The offset region of a shape on an ellipsoid, as densified rings.

    Attributes
    ----------
    distance : float
        Signed geodesic distance in metres.
    ellipsoid : Ellipsoid
    tolerance : float
        Every point of the rings (edges read as geodesics) lies within this many
        metres of geodesic distance ``|distance|`` from the curves.
    rings : list of (n, 3) arrays
        Closed rings (first point not repeated) of unit vectors of geodetic lon/lat
        (:func:`gloffset.sphere.lonlat_to_xyz`), the region on their left.
    sphere : ResolvedOffset or None
        The resolved spherical offset on the conformal sphere the rings were traced from.
    vertex_error : float
        The largest ``| distance(vertex) - |d| |`` of the rings' points (metres).
    unresolved : int
        Edges still off the tolerance after :data:`MAX_ROUNDS` rounds of midpoints (0
        on every test case; kept rather than failing the whole offset).
    """

    def __init__(self, shape, ell, d: float, tolerance: float):
        self.shape, self.ellipsoid, self.distance, self.tolerance = shape, ell, d, tolerance
        self.rings: list[np.ndarray] = []
        self.sphere = None
        self.vertex_error = 0.0
        self.unresolved = 0
        if d != 0.0:
            self._trace()

    def _trace(self) -> None:
        ell, m, tol = self.ellipsoid, abs(self.distance), self.tolerance
        conf = conformal(self.shape, ell)
        lat = np.degrees(np.arcsin(np.clip(self.shape.edges().a[:, 2], -1.0, 1.0)))
        k_ref = float(ell.scale(np.radians(np.median(np.abs(lat))))) if len(lat) else ell.k_max
        d_s = np.copysign(m / k_ref, self.distance)
        self.sphere = Offset(conf.shape, d_s).resolve()
        tracer = _Tracer(conf, m, tol)
        for ring in self.sphere.rings:
            pts, arc = sample_ring(ring, tol / (2.0 * ell.k_max))
            gen = _generators(ring, arc)
            u = _away(pts, gen)
            # a junction (an arc's first point) leaves both arcs' generators: the sum of
            # the two directions increases both distances
            first = np.flatnonzero(arc != np.roll(arc, 1))
            prev = (gen[0][first - 1], gen[1][first - 1])
            u[first] = normalize(u[first] + _away(pts[first], prev))
            pts = tracer.move(pts, gen, u)
            pts, gen = tracer.densify(pts, gen)
            lon, chi = xyz_to_lonlat(pts)
            self.rings.append(lonlat_to_xyz(lon, ell.geodetic(chi)))
        self.vertex_error = tracer.worst
        self.unresolved = tracer.unresolved

    def lonlat(self) -> list[np.ndarray]:
        """The rings as (n, 2) arrays of geodetic lon/lat (degrees)."""
        return [np.column_stack(xyz_to_lonlat(r)) for r in self.rings]

    def to_geojson(self, *, digits: int | None = None) -> dict:
        """The region as an RFC 7946 Feature: rings cut at the antimeridian, exterior
        rings counter-clockwise, holes clockwise."""
        from .io.geojson import rings_to_geometry

        props = {
            "distance_m": self.distance,
            "ellipsoid": str(self.ellipsoid),
            "tolerance_m": self.tolerance,
        }
        if self.distance == 0.0:
            feat = self.shape.to_geojson(digits=digits)
            feat["properties"] = props
            return feat
        north = bool(
            ellipsoidal_contains(
                self.shape, 0.0, 90.0, distance=self.distance, ellipsoid=self.ellipsoid
            )
        )
        if not self.rings and not north:
            geom = {"type": "MultiPolygon", "coordinates": []}
        else:
            geom = rings_to_geometry(self.rings, north, digits)
        return {"type": "Feature", "properties": props, "geometry": geom}

    def __repr__(self) -> str:
        n = sum(len(r) for r in self.rings)
        return (
            f"GeodesicOffset({len(self.rings)} rings, {n} points, d={self.distance!r} m, "
            f"{self.ellipsoid}, tolerance={self.tolerance!r} m)"
        )


def _generators(ring, arc) -> tuple[np.ndarray, np.ndarray]:
    """Per point: whether its arc is about a vertex (else an edge), and the vertex or the
    edge's pole (unit vectors), from which the distance grows along great circles."""
    vertex = ring.kind[arc] == 0
    axis = np.where(vertex[:, None], ring.sources[arc, 0], normalize(ring.centers[arc]))
    return vertex, axis


def _foot(p, gen) -> np.ndarray:
    """The generators' points nearest to ``p``: the vertex, or the foot on the edge's
    great circle."""
    vertex, axis = gen
    return np.where(vertex[:, None], axis, normalize(p - dot(p, axis)[:, None] * axis))


def _away(p, gen) -> np.ndarray:
    """Unit tangents at ``p`` pointing away from the generators' feet."""
    foot = _foot(p, gen)
    return normalize(foot - dot(foot, p)[:, None] * p) * -1.0


class _Tracer:
    """Moves points of the conformal sphere to geodesic distance ``m`` and densifies."""

    def __init__(self, conf: Conformal, m: float, tol: float):
        self.conf, self.m, self.tol = conf, m, tol
        self.eps = VERTEX_TOL * tol
        self.unresolved = 0
        ell = conf.ell
        #: The farthest (rad) a point is moved: twice the width of the ratio band
        self.reach = 2.0 * (m / ell.k_min - m / ell.k_max + conf.h_max) + 10.0 * tol / ell.k_min
        self.worst = 0.0

    def excess(self, p) -> np.ndarray:
        """Geodesic distance minus ``m`` (metres) at points ``p`` of the conformal sphere."""
        lon, chi = xyz_to_lonlat(p)
        lat = self.conf.ell.geodetic(chi)
        return nearest_geodesic(self.conf, lon, lat) - self.m

    def move(self, p, gen, u=None, reach=None) -> np.ndarray:
        """The points moved along their great circles away from the generators (or along
        ``u``) to distance ``m`` (secant steps; the local scale as the first slope), by
        at most :attr:`reach`."""
        p = np.array(p, dtype=np.float64)
        if len(p) == 0:
            return p
        u = _away(p, gen) if u is None else u
        reach = np.broadcast_to(self.reach if reach is None else reach, (len(p),)).copy()
        ell = self.conf.ell
        # the start: the geodesic distance is about K at the path's middle times the
        # spherical one (to O(f (d / a)^2) relative), so aim at m / K
        foot = _foot(p, gen)
        _, chi = xyz_to_lonlat(normalize(p + foot))
        k = ell.scale(np.radians(ell.geodetic(chi)))
        s1 = self.m / k - angle(p, foot)
        s1[np.abs(s1) > 0.5 * reach] = 0.0  # another generator is nearer: no guess
        s0, f0, f1 = s1.copy(), np.zeros(len(p)), np.zeros(len(p))
        act = np.ones(len(p), dtype=bool)
        at = lambda i, s: np.cos(s)[:, None] * p[i] + np.sin(s)[:, None] * u[i]  # noqa: E731
        for _ in range(MAX_STEPS):
            idx = np.flatnonzero(act)
            if len(idx) == 0:
                break
            f1[idx] = self.excess(at(idx, s1[idx]))
            done = np.abs(f1[idx]) <= self.eps
            act[idx[done]] = False
            idx = idx[~done]
            ds = s1[idx] - s0[idx]
            slope = (f1[idx] - f0[idx]) / np.where(ds == 0.0, 1.0, ds)
            slope = np.where((slope < 0.2 * k[idx]) | (ds == 0.0), k[idx], slope)
            s0[idx], f0[idx] = s1[idx], f1[idx]
            s1[idx] = np.clip(s1[idx] - f1[idx] / slope, -reach[idx], reach[idx])
        out = normalize(at(np.arange(len(p)), s1))
        idx = np.flatnonzero(act)
        if len(idx):  # a corner where the generator's direction does not reach m
            out[idx], f1[idx] = self.climb(out[idx], reach[idx])
        self.worst = max(self.worst, float(np.max(np.abs(f1), initial=0.0)))
        return out

    def climb(self, p, reach) -> tuple[np.ndarray, np.ndarray]:
        """Newton steps along the distance's gradient (by finite differences east and
        north): for the points whose own direction did not reach ``m``."""
        k = self.conf.ell.k_max
        h = max(1e-3 * self.tol / k, 1e-10)
        f = self.excess(p)
        for _ in range(MAX_STEPS):
            act = np.flatnonzero(np.abs(f) > self.eps)
            if len(act) == 0:
                break
            q = p[act]
            east = normalize(np.cross([0.0, 0.0, 1.0], q))
            north = np.cross(q, east)
            ge = (self.excess(normalize(q + h * east)) - f[act]) / h
            gn = (self.excess(normalize(q + h * north)) - f[act]) / h
            g = ge[:, None] * east + gn[:, None] * north
            g2 = np.maximum(np.sum(g * g, axis=1), (0.2 * k) ** 2)
            step = (f[act] / g2)[:, None] * g
            size = np.linalg.norm(step, axis=1)
            step *= np.minimum(1.0, reach[act] / np.maximum(size, 1e-300))[:, None]
            p[act] = normalize(q - step)
            f[act] = self.excess(p[act])
        return p, f

    def densify(self, p, gen):
        """Insert moved midpoints where an edge's midpoint is off ``m`` by more than
        half the tolerance (less the edge's deviation from its great circle); only the
        edges made by the last round are measured again. An edge so short that its
        ends' errors plus half its length (the distance is 1-Lipschitz) stay within the
        tolerance needs no midpoint. Midpoints move at most a few times their own error
        (the boundary is that close)."""
        vertex, axis = gen
        ell = self.conf.ell
        todo = np.arange(len(p))  # edges (i, i + 1) to measure
        for _ in range(MAX_ROUNDS):
            q = np.roll(p, -1, axis=0)[todo]
            mid = normalize(p[todo] + q)
            chord = np.linalg.norm(p[todo] - q, axis=1)
            theta = 2.0 * np.arcsin(np.minimum(0.5 * chord, 1.0))
            slack = ell.k_max * edge_deviation(ell, theta)
            short = self.eps + 0.5 * ell.k_max * theta + slack <= self.tol
            f = self.excess(mid)
            off = (np.abs(f) + slack > 0.5 * self.tol) & ~short
            bad = todo[off]
            if len(bad) == 0:
                return p, gen
            sub = (vertex[bad], axis[bad])
            reach = 3.0 * np.abs(f[off]) / ell.k_min + self.tol / ell.k_min
            new = self.move(mid[off], sub, reach=reach)
            p = np.insert(p, bad + 1, new, axis=0)
            vertex = np.insert(vertex, bad + 1, sub[0])
            axis = np.insert(axis, bad + 1, sub[1], axis=0)
            gen = (vertex, axis)
            # after insertion edge bad[k] is at bad[k] + k, its new half right after it
            first = bad + np.arange(len(bad))
            todo = np.concatenate([first, first + 1])
            todo = np.sort(todo % len(p))
        self.unresolved += len(todo)
        return p, gen


def offset(
    shape,
    distance: float,
    *,
    radius: float = EARTH_RADIUS,
    ellipsoid=None,
    tolerance: float = DEFAULT_TOLERANCE,
):
    """Offset a shape by ``distance``: small-circle arcs on the sphere, or densified rings at
    geodesic distance on an ellipsoid.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    distance : float
        Positive: outward from polygons and around lines and points; negative: inward
        into polygons. In the units of ``radius``, or geodesic metres with ``ellipsoid``.
    radius : float
        Sphere radius (without ``ellipsoid``).
    ellipsoid : None, "WGS84", "GRS80", (a, f) or Ellipsoid
        ``None``: :func:`gloffset.vector.offset.offset` on the sphere of ``radius``
        (the raw :class:`~gloffset.Offset`, exactly as without this keyword).
        Otherwise a :class:`GeodesicOffset`: the resolved region's boundary on the
        ellipsoid (edges of the shape are geodesics, latitudes geodetic).
    tolerance : float
        With ``ellipsoid``: every point of the rings lies within this many metres of
        geodesic distance ``|distance|`` (default 1 m).

    Examples
    --------
    >>> import gloffset
    >>> line = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [1, 0]]})
    >>> off = gloffset.offset(line, 1000.0, ellipsoid="WGS84")
    >>> len(off.rings), off.vertex_error < 1e-3
    (1, True)
    """
    ell = as_ellipsoid(ellipsoid)
    if ell is None:
        return sphere_offset(shape, distance, radius=radius)
    shape = read(shape)
    offset_angle(shape, distance, ell.k_min, limit=VECTOR_LIMIT)  # checks sign and size
    tol = float(tolerance)
    if not (np.isfinite(tol) and tol > 0.0):
        raise InvalidDistanceError(f"tolerance must be a positive number of metres, got {tol!r}")
    return GeodesicOffset(shape, ell, float(distance), tol)
