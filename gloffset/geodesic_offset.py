"""Vector offsets on the ellipsoid: the boundary at geodesic distance ``|d|``.

``offset(shape, d, ellipsoid="WGS84")`` gives the boundary of the offset region on the
ellipsoid (edges are geodesics, ``d`` a geodesic length in metres) as densified rings,
every point of which lies within ``tolerance`` (default 1 m) of geodesic distance
``|d|`` from the curves. Without ``ellipsoid`` it is :func:`gloffset.vector.offset.offset`,
exactly.

How. The resolved spherical offset of the shape's image on the conformal sphere, at
``|d| / K``, has the topology of the ellipsoidal boundary; its densified points are
moved along great circles until their geodesic distance is ``|d|`` to within
:data:`VERTEX_TOL` times the tolerance, and ring edges get midpoints until bounds on
the curvature of the distance keep every point of them within ``tolerance`` of ``|d|``
(an argument, not a proof, of its premises; the tests check it against the brute
force of :mod:`gloffset.reference` at every vertex and edge midpoint).


Limits. Parts or gaps of the region narrower than the ratio band (0.34 % of ``d``
plus the edges' deviation bounds) may be joined or split as on the sphere at
``|d| / K`` rather than as on the ellipsoid. Cost: one or two geodesic distances per
output point (about 0.1 ms each: pyproj's C geodesics, vectorised, on the candidate
edges that spherical bounds leave). The derivation in full: ``docs/design.md``, *Module
notes*.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .ellipsoid import as_ellipsoid, geodesic_midpoints
from .ellipsoidal import Conformal, conformal, nearest_geodesic
from .ellipsoidal import contains as ellipsoidal_contains
from .errors import InvalidDistanceError
from .geometry.sphere import angle, dot, lonlat_to_xyz, normalize, xyz_to_lonlat
from .shape import read
from .units import EARTH_RADIUS, VECTOR_LIMIT, distance_properties, offset_metres
from .vector.arcrings import sample_ring
from .vector.offset import Offset
from .vector.offset import offset as sphere_offset

if TYPE_CHECKING:
    from .vector.resolved import ResolvedOffset

__all__ = ["DEFAULT_TOLERANCE", "VERTEX_TOL", "GeodesicOffset", "offset"]

#: Default tolerance (metres) of the rings: every point within it of distance |d|.
DEFAULT_TOLERANCE = 1.0
#: Each moved point's distance is |d| to within this fraction of the tolerance.
VERTEX_TOL = 1e-3
#: Rounds of midpoint insertion before giving up (each halves the edges it touches).
MAX_ROUNDS = 30
#: Secant steps per point.
MAX_STEPS = 12
#: The spherical rings are first sampled to this fraction of the tolerance (their
#: sagitta on the conformal sphere), below the midpoint rule's half so that its
#: curvature terms do not split every sampled edge once more.
SAMPLE = 0.45


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
        (:func:`gloffset.geometry.sphere.lonlat_to_xyz`), the region on their left.
    sphere : ResolvedOffset or None
        The resolved spherical offset on the conformal sphere the rings were traced from.
    vertex_error : float
        The largest ``| distance(vertex) - |d| |`` of the rings' points (metres).
    unresolved : int
        Edges still off the tolerance after :data:`MAX_ROUNDS` rounds of midpoints (0
        on every test case; kept rather than failing the whole offset).
    """

    #: The distance as given when it was a string (``"127km"``), for the output's properties.
    given: str | None = None

    def __init__(self, shape, ell, d: float, tolerance: float):
        self.shape, self.ellipsoid, self.distance, self.tolerance = shape, ell, d, tolerance
        self.rings: list[np.ndarray] = []
        self.sphere: ResolvedOffset | None = None
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
        tracer = _Tracer(conf, m, tol, self.distance < 0.0)
        for ring in self.sphere.rings:
            pts, arc = sample_ring(ring, SAMPLE * tol / ell.k_max)
            gen = _generators(ring, arc)
            u = _away(pts, gen)
            # a junction (an arc's first point) leaves both arcs' generators: the sum of
            # the two directions increases both distances
            first = np.flatnonzero(arc != np.roll(arc, 1))
            prev = (gen[0][first - 1], gen[1][first - 1])
            both = u[first] + _away(pts[first], prev)
            u[first] = normalize(both)
            # along it the distance grows as the cosine of half the angle between the
            # two directions: slowly at a sharp junction, which moves the more for it
            reach = np.full(len(pts), tracer.reach)
            reach[first] /= np.maximum(0.5 * np.linalg.norm(both, axis=1), 0.05)
            pts = tracer.move(pts, gen, u, reach)
            pts, gen = tracer.densify(pts, gen)
            lon, chi = xyz_to_lonlat(pts)
            self.rings.append(lonlat_to_xyz(lon, ell.geodetic(chi)))
        self.vertex_error = tracer.worst
        self.unresolved = tracer.unresolved

    def lonlat(self) -> list[np.ndarray]:
        """Return the rings as (n, 2) arrays of geodetic lon/lat (degrees)."""
        return [np.column_stack(xyz_to_lonlat(r)) for r in self.rings]

    def to_geojson(self, *, digits: int | None = None) -> dict:
        """Return the region as an RFC 7946 Feature.

        Rings cut at the antimeridian, exterior rings counter-clockwise, holes clockwise.
        Properties: ``distance_m`` and ``distance`` (as everywhere: the geodesic length in
        metres, and as given), ``ellipsoid`` and ``tolerance_m``.
        """
        from .io.geojson import rings_to_geometry

        given = self.distance if self.given is None else self.given
        props = distance_properties(given) | {
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
    """Per point, what its distance grows from along great circles.

    Whether its arc is about a vertex (else an edge), and the vertex or the edge's pole
    (unit vectors), from which the distance grows along great circles.
    """
    vertex = ring.kind[arc] == 0
    axis = np.where(vertex[:, None], ring.sources[arc, 0], normalize(ring.centers[arc]))
    return vertex, axis


def _foot(p, gen) -> np.ndarray:
    """Return the generators' points nearest to ``p``.

    The vertex, or the foot on the edge's great circle.
    """
    vertex, axis = gen
    return np.where(vertex[:, None], axis, normalize(p - dot(p, axis)[:, None] * axis))


def _away(p, gen) -> np.ndarray:
    """Return unit tangents at ``p`` pointing away from the generators' feet."""
    foot = _foot(p, gen)
    return normalize(foot - dot(foot, p)[:, None] * p) * -1.0


class _Tracer:
    """Moves points of the conformal sphere to geodesic distance ``m`` and densifies."""

    def __init__(self, conf: Conformal, m: float, tol: float, inward: bool = False):
        self.conf, self.m, self.tol = conf, m, tol
        #: The side of the rings' edges on which the distance grows: +1 left (inward
        #: offsets, the region farther than m), -1 right (the region within m on the left)
        self.side = 1.0 if inward else -1.0
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

    def move(self, p, gen, u=None, reach=None, f0=None) -> np.ndarray:
        """Move the points along their great circles to distance ``m``.

        Along their great circles away from the generators (or along ``u``, a direction in
        which the distance grows) to distance ``m``, by at most :attr:`reach` (or
        ``reach``, per point).

        Secant steps from ``m / K`` (``K`` the scale at the middle of the path to the
        generator), or, where the excess ``f0`` at the points themselves is given, from
        the points with the local scale as the first slope. Once the excess has taken
        both signs the root is bracketed: a step leaving the bracket, or one that did
        not halve the excess, bisects it instead. No floor on the slope: beside a sharp
        junction the distance grows slowly along the direction (as the cosine of half
        the angle between the two generators' directions).
        """
        p = np.array(p, dtype=np.float64)
        n = len(p)
        if n == 0:
            return p
        u = _away(p, gen) if u is None else u
        reach = np.broadcast_to(self.reach if reach is None else reach, (n,)).copy()
        ell = self.conf.ell
        if f0 is None:
            # the start: the geodesic distance is about K at the path's middle times the
            # spherical one (to O(f (d / a)^2) relative), so aim at m / K
            foot = _foot(p, gen)
            _, chi = xyz_to_lonlat(normalize(p + foot))
            k = ell.scale(np.radians(ell.geodetic(chi)))
            s1 = self.m / k - angle(p, foot)
            s1[np.abs(s1) > 0.5 * reach] = 0.0  # another generator is nearer: no guess
            s0, f0 = np.full(n, np.nan), np.full(n, np.nan)
        else:
            _, chi = xyz_to_lonlat(p)
            k = ell.scale(np.radians(ell.geodetic(chi)))
            s0, f0 = np.zeros(n), np.array(f0, dtype=np.float64)
            s1 = np.clip(-f0 / k, -reach, reach)
        f1 = np.zeros(n)
        s_neg, s_pos = np.full(n, np.nan), np.full(n, np.nan)  # the latest of each sign
        act = np.ones(n, dtype=bool)
        at = lambda i, s: np.cos(s)[:, None] * p[i] + np.sin(s)[:, None] * u[i]  # noqa: E731
        for _ in range(MAX_STEPS):
            idx = np.flatnonzero(act)
            if len(idx) == 0:
                break
            f1[idx] = self.excess(at(idx, s1[idx]))
            done = np.abs(f1[idx]) <= self.eps
            act[idx[done]] = False
            idx = idx[~done]
            s, f, ki = s1[idx], f1[idx], k[idx]
            s_neg[idx] = np.where(f < 0.0, s, s_neg[idx])
            s_pos[idx] = np.where(f > 0.0, s, s_pos[idx])
            ds = s - s0[idx]
            slope = (f - f0[idx]) / np.where(ds == 0.0, 1.0, ds)
            flat = ~(np.abs(slope) > 1e-3 * ki) | (ds == 0.0)  # also NaN: no previous
            new = s - f / np.where(flat, ki, slope)
            lo, hi = np.fmin(s_neg[idx], s_pos[idx]), np.fmax(s_neg[idx], s_pos[idx])
            bracket = np.isfinite(s_neg[idx]) & np.isfinite(s_pos[idx])
            slow = np.abs(f) > 0.5 * np.abs(f0[idx])  # False without a previous step
            bisect = bracket & ((new <= lo) | (new >= hi) | slow)
            new = np.where(bisect, 0.5 * (lo + hi), new)
            s0[idx], f0[idx] = s, f
            s1[idx] = np.clip(new, -reach[idx], reach[idx])
        out = normalize(at(np.arange(n), s1))
        idx = np.flatnonzero(act)
        if len(idx):  # a corner where the generator's direction does not reach m
            out[idx], f1[idx] = self.climb(out[idx], reach[idx])
        self.worst = max(self.worst, float(np.max(np.abs(f1), initial=0.0)))
        return out

    def climb(self, p, reach) -> tuple[np.ndarray, np.ndarray]:
        """Newton steps along the distance's gradient (by finite differences east and north).

        For the points whose own direction did not reach ``m``.
        """
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
        """Insert moved midpoints where an edge's geodesic midpoint breaks the rules.

        The rules of the module's docstring (half the tolerance, less the curvature terms
        of :func:`_curvatures` where the ends lie on different generators, see
        :func:`_corner`); only the edges made by the last round are measured again. An
        edge so short that its ends' errors plus half its length (the distance is
        1-Lipschitz) stay within the tolerance needs no midpoint. A midpoint moves along
        the edge's normal (its perpendicular bisector on the conformal sphere), which
        crosses the boundary between the ends also where a generator's own direction runs
        along the edge (beside a corner), by at most a few times its own error plus half
        the edge; it takes the generator of the end whose generator is nearer on the
        conformal sphere.
        """
        vertex, axis = gen
        ell = self.conf.ell
        half = 0.5 * (self.tol - self.eps)
        big_c, small_c = _curvatures(ell, self.m)
        lon, chi = xyz_to_lonlat(p)
        lat = ell.geodetic(chi)
        todo = np.arange(len(p))  # edges (i, i + 1) to measure
        for _ in range(MAX_ROUNDS):
            nxt = (todo + 1) % len(p)
            mlon, mlat, length = geodesic_midpoints(ell, lon[todo], lat[todo], lon[nxt], lat[nxt])
            f = nearest_geodesic(self.conf, mlon, mlat) - self.m
            corner = _corner((vertex[todo], axis[todo]), (vertex[nxt], axis[nxt]))
            big = np.where(corner & (vertex[todo] | vertex[nxt]), big_c, 0.0)
            k2 = 0.125 * length**2
            off = (
                (np.abs(f) > half)
                | (-f + (small_c + 0.25 * big) * k2 > half)
                | (corner & (f + (0.5 * small_c + big) * k2 > half))
                | (~corner & (self.eps + small_c * k2 > self.tol))
            )
            off &= self.eps + 0.5 * length > self.tol  # else short enough (1-Lipschitz)
            bad, nb = todo[off], nxt[off]
            if len(bad) == 0:
                return p, gen
            mid = ell.to_sphere(mlon[off], mlat[off])
            normal = np.cross(p[bad], p[nb])
            normal = self.side * normalize(normal - dot(normal, mid)[:, None] * mid)
            reach = (3.0 * np.abs(f[off]) + self.tol + 0.5 * length[off]) / ell.k_min
            ga, gb = (vertex[bad], axis[bad]), (vertex[nb], axis[nb])
            new = self.move(mid, ga, normal, reach, f0=f[off])
            nearer = angle(new, _foot(new, ga)) <= angle(new, _foot(new, gb))
            new_lon, new_chi = xyz_to_lonlat(new)
            p = np.insert(p, bad + 1, new, axis=0)
            lon = np.insert(lon, bad + 1, new_lon)
            lat = np.insert(lat, bad + 1, ell.geodetic(new_chi))
            vertex = np.insert(vertex, bad + 1, np.where(nearer, ga[0], gb[0]))
            axis = np.insert(axis, bad + 1, np.where(nearer[:, None], ga[1], gb[1]), axis=0)
            gen = (vertex, axis)
            # after insertion edge bad[k] is at bad[k] + k, its new half right after it
            first = bad + np.arange(len(bad))
            todo = np.concatenate([first, first + 1])
            todo = np.sort(todo % len(p))
        self.unresolved += len(todo)
        return p, gen


def _corner(ga, gb) -> np.ndarray:
    """Whether the boundary may turn (a junction) between points of generators ``ga`` and ``gb``.

    They differ, and are not a vertex and an edge through it (whose circle and parallel
    curve meet tangentially).
    """
    (va, aa), (vb, ab) = ga, gb
    c = dot(aa, ab)
    same = (va == vb) & (c > 1.0 - 1e-12)
    tangent = (va != vb) & (np.abs(c) < 1e-9)
    return ~(same | tangent)


def _curvatures(ell, m: float) -> tuple[float, float]:
    """Bounds on the second derivative of the distance to a geodesic edge, along a geodesic.

    At most ``C = 1 / m`` (beside its ends, the distance to a point, on a surface of
    positive curvature) and at least ``-c``, ``c = tan(m / b) / b`` (beside its middle;
    ``1 / b^2`` the largest curvature of the ellipsoid). Beside its middle it is also at
    most 0.
    """
    b = ell.a * (1.0 - ell.f)
    return 1.0 / m, float(np.tan(min(m / b, 1.5)) / b)


def offset(
    shape,
    distance: float,
    *,
    radius: float = EARTH_RADIUS,
    ellipsoid=None,
    tolerance: float = DEFAULT_TOLERANCE,
):
    """Offset a shape by ``distance``.

    Small-circle arcs on the sphere, or densified rings at geodesic distance on an
    ellipsoid.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    distance : float or str
        Positive: outward from polygons and around lines and points; negative: inward
        into polygons. In the units of ``radius``, or geodesic metres with ``ellipsoid``;
        or a string with a unit (``"127km"``; a length unit with ``ellipsoid``).
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
    metres = offset_metres(shape, distance, ell.k_min, limit=VECTOR_LIMIT)
    tol = float(tolerance)
    if not (np.isfinite(tol) and tol > 0.0):
        raise InvalidDistanceError(f"tolerance must be a positive number of metres, got {tol!r}")
    off = GeodesicOffset(shape, ell, metres, tol)
    if isinstance(distance, str):
        off.given = distance  # the output's properties quote it as given
    return off
