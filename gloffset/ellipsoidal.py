"""``distance`` and ``contains`` on the ellipsoid (``ellipsoid="WGS84"``...).

With ``ellipsoid=None`` both are exactly the spherical functions (the great-circle
distance of :func:`gloffset.edges.distance_xyz`, and
:func:`gloffset.index.contains.contains_on_sphere`). With an ellipsoid, distances are geodesic
lengths in metres, latitudes are geodetic, and the edges of curves and polygons are
geodesics (the shortest ones between their vertices).

How. The shape is mapped to the conformal sphere of the ellipsoid
(:mod:`gloffset.ellipsoid.model`), where gloffset's spherical machinery runs as it is;
:mod:`gloffset.ellipsoid.bounds` bounds the ellipsoidal distance by the spherical one
both ways (a ratio over the latitudes within reach, plus each edge's deviation ``H``
from its great-circle arc). For ``contains``, two spherical :class:`~gloffset.Index`
tests at the distances those bounds give decide every point outside a thin band
(0.34 % of ``d`` wide, plus ``2 max H``); in the band each point's candidate edges
are bounded again with its own latitude window, and what is still open is decided
with the geodesic intercept (:func:`gloffset.ellipsoid.edge_distance`). A polygon's
inside uses its geodesic edges: a point that lies between a geodesic edge and that
edge's great-circle arc (their lune, less than ``H`` wide) flips the spherical
inside test, decided by the side of the geodesic at the point's foot (the azimuth
there).

Accuracy: distances within 1 um of the geodesic distance to the curves (the
intercept's bound, plus geographiclib's 15 nm). Membership is exact for points whose
distance differs from ``|d|`` by more than 1 um (and, for ``d = 0``, farther than that
from the boundary). Cost: two index queries for all points, and about 1 ms of
geodesic work (pure Python) per point of the band. The derivation in full:
``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .edges import distance_xyz
from .ellipsoid import (
    as_ellipsoid,
    edge_deviation,
    edge_distance,
    edge_distances,
    lower_distance,
    upper_distance,
    window_scale,
)
from .errors import OptionError
from .geometry.caps import arc_cap, pad
from .geometry.captree import CapTree
from .geometry.crossings import inside as crossings_inside
from .geometry.crossings import inside_indexed
from .geometry.sphere import (
    angle,
    arc_distance,
    dot,
    lonlat_to_xyz,
    normalize,
    robust_cross,
    xyz_to_lonlat,
)
from .index.contains import contains_angle, contains_on_sphere
from .index.tree import Index
from .shape import read
from .units import EARTH_RADIUS, check_lonlat, check_radius, offset_metres

__all__ = [
    "distance",
    "contains",
    "Conformal",
    "EllipsoidIndex",
    "conformal",
    "thresholds",
    "signed_distance",
]

#: Slack (rad) on the thresholds handed to the spherical index (its answers are exact
#: 1e-13 rad away from them).
INDEX_SLACK = 1e-12


class Conformal:
    """A shape's image on the conformal sphere of an ellipsoid, and what the bounds need.

    Attributes
    ----------
    shape : Shape
        The same rings and lines with conformal latitudes (seams stay seams: the map
        keeps longitudes, poles and the antimeridian).
    a_ll, b_ll : (m, 2) arrays
        The boundary edges' ends, geodetic (lat, lon) in degrees.
    a, b, n : (m, 3) arrays
        The same on the conformal sphere, with the arcs' unit normals.
    h : (m,) array
        Each edge's deviation bound (:func:`gloffset.ellipsoid.edge_deviation`), rad.
    h_max : float
        The largest ``h`` plus :data:`INDEX_SLACK`.
    group : (m,) int array
        Each edge's region component (-1 for lines).
    """

    def __init__(self, shape, ell):
        self.ell = ell

        def mapped(v):
            lon, lat = xyz_to_lonlat(v)
            return ell.to_sphere(lon, lat)

        self.shape = replace(
            shape,
            rings=[mapped(r) for r in shape.rings],
            lines=[mapped(ln) for ln in shape.lines],
            source=None,
        )
        e, ec = shape.edges(), self.shape.edges()
        a, b = e.a[e.boundary], e.b[e.boundary]
        self.group = e.group[e.boundary]
        self.a_ll = np.stack(xyz_to_lonlat(a)[::-1], axis=1)
        self.b_ll = np.stack(xyz_to_lonlat(b)[::-1], axis=1)
        self.a, self.b = ec.a[ec.boundary], ec.b[ec.boundary]
        self.n = normalize(robust_cross(self.a, self.b))
        self.theta = angle(self.a, self.b)
        self.h = edge_deviation(ell, self.theta)
        self.h_max = float(self.h.max(initial=0.0)) + INDEX_SLACK
        mid, half = arc_cap(self.a, self.b)
        self.tree = CapTree(mid, np.minimum(pad(half + self.h), np.pi))

    def chi(self, lat) -> np.ndarray:
        """Conformal latitudes (rad) of geodetic ``lat`` (degrees)."""
        return np.radians(self.ell.conformal(lat))

    def pairs(self, p, reach):
        """Candidate (point, edge) pairs within ``reach`` with their spherical distances.

        On the conformal sphere (``reach`` in radians, per point), counting each edge's
        deviation.
        """
        qi, ei, _ = self.tree.near(p, reach)
        theta = arc_distance(p[qi], self.a[ei], self.b[ei], self.n[ei])
        keep = theta - self.h[ei] <= np.asarray(reach, dtype=np.float64)[qi]
        return qi[keep], ei[keep], theta[keep]

    def nearest_pairs(self, p, chi):
        """Candidate (point, edge) pairs of :func:`nearest_geodesic`, and upper bounds.

        With their spherical distances, and each point's upper bound on its geodesic
        distance: the edges within the reach of the exact spherical distance to the image.
        That distance is the least over the edges within the reach of an upper bound of it
        (the nearest of every ``n / 256``-th vertex), so no (point, edge) matrix is made.
        """
        ell = self.ell
        sub = self.a[:: max(1, len(self.a) // 256)]
        near = sub[np.argmax(p @ sub.T, axis=1)]
        above = angle(p, near) + 1e-12
        reach = upper_distance(ell, chi, above + self.h_max) / ell.k_min + self.h_max
        qi, ei, theta = self.pairs(p, reach)
        theta0 = np.full(len(p), np.inf)
        np.minimum.at(theta0, qi, theta)
        upper0 = upper_distance(ell, chi, theta0 + self.h_max)
        keep = theta - self.h[ei] <= (upper0 / ell.k_min + self.h_max)[qi]
        return qi[keep], ei[keep], theta[keep], upper0

    def start(self, p, e) -> np.ndarray:
        """Where along edges ``e`` (fractions) the feet of points ``p`` lie on the conformal sphere.

        The intercept's starting points.
        """
        n = self.n[e]
        foot = p - dot(p, n)[:, None] * n
        t = np.arctan2(dot(foot, np.cross(n, self.a[e])), dot(foot, self.a[e]))
        return np.clip(t / np.maximum(self.theta[e], 1e-300), 0.0, 1.0)

    def exact_many(self, lat, lon, p, e) -> np.ndarray:
        """Geodesic intercepts (distances, metres) of points to edges ``e``, pair by pair.

        Vectorised (:func:`gloffset.ellipsoid.intercept.edge_distances`).
        """
        e = np.asarray(e, dtype=np.int64)
        s0 = self.start(p, e)
        return edge_distances(self.ell, lat, lon, self.a_ll[e], self.b_ll[e], s0)

    def exact(self, lat, lon, p, e) -> tuple[float, float, float]:
        """Return the geodesic intercept from one point to edge ``e``."""
        s0 = float(self.start(p[None], np.array([e]))[0])
        return edge_distance(
            self.ell.geodesic, float(lat), float(lon), self.a_ll[e], self.b_ll[e], s0
        )


def conformal(shape, ell) -> Conformal:
    """Return the shape's :class:`Conformal` image for ``ell``, made once per shape."""
    return shape.derived.conformal.once((ell.a, ell.f), lambda: Conformal(shape, ell))


# ---------------------------------------------------------------------- distance
def distance(shape, lon, lat, *, radius: float = EARTH_RADIUS, ellipsoid=None):
    """Distance from points to the nearest point of the shape's curves.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    lon, lat : array_like
        Query points in degrees (broadcast together); geodetic with an ellipsoid.
    radius : float
        Sphere radius (without ``ellipsoid``); the result is in its units.
    ellipsoid : None, "WGS84", "GRS80", (a, f) or Ellipsoid
        ``None``: great-circle distances on the sphere of ``radius``
        (:func:`gloffset.edges.distance_xyz`). Otherwise geodesic distances in metres on
        the ellipsoid, to geodesic edges.

    Returns
    -------
    float or numpy.ndarray
        A Python float for scalar ``lon`` and ``lat`` (as numpy's ufuncs give a scalar),
        else an array of their broadcast shape.

    Notes
    -----
    On the sphere the result is the exact distance to the nearest boundary arc,
    vertex or isolated point, with absolute error below ``1e-15 * radius``; the
    distance is to the boundary, also for points inside a polygon.
    On the ellipsoid the result is within 1 um of the geodesic distance (see
    :mod:`gloffset.ellipsoidal`); it costs about 1 ms per point (the geodesic
    intercept, in pure Python, on the point's one to three candidate edges).

    Examples
    --------
    >>> import gloffset
    >>> s = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [10, 0]]})
    >>> round(gloffset.distance(s, 5.0, 1.0, ellipsoid="WGS84"), 3)
    110574.389
    """
    ell = as_ellipsoid(ellipsoid)
    shape = read(shape)
    lon, lat, shp = check_lonlat(lon, lat)
    if ell is None:
        r = check_radius(radius)
        out = (distance_xyz(shape, lonlat_to_xyz(lon, lat)) * r).reshape(shp)
    else:
        out = nearest_geodesic(conformal(shape, ell), lon, lat).reshape(shp)
    return float(out) if out.ndim == 0 else out


def nearest_geodesic(conf: Conformal, lon, lat) -> np.ndarray:
    """Geodesic distance (metres) from flat geodetic lon/lat arrays to the shape of ``conf``.

    Spherical bounds choose each point's candidate edges, the intercept measures them
    (nearest lower bound first, stopping when no other can be nearer).
    """
    out = np.full(len(lon), np.inf)
    if len(conf.a) == 0 or len(lon) == 0:
        return out
    ell = conf.ell
    p = ell.to_sphere(lon, lat)
    chi = conf.chi(lat)
    qi, ei, theta, upper0 = conf.nearest_pairs(p, chi)
    low = lower_distance(ell, chi[qi], theta - conf.h[ei], upper0[qi])
    order = np.lexsort((low, qi))
    qi, ei, low = qi[order], ei[order], low[order]
    starts = np.searchsorted(qi, np.arange(len(lon) + 1))
    count = np.diff(starts)
    best = upper0 * (1 + 1e-9) + 1e-6  # no candidate: cannot happen, kept safe
    # rounds: each point's next candidate by lower bound, while it can still be nearer
    act = np.flatnonzero(count > 0)
    for r in range(int(count.max(initial=0))):
        act = act[count[act] > r]
        j = starts[act] + r
        go = low[j] <= np.minimum(best[act], out[act])
        act, j = act[go], j[go]
        if len(act) == 0:
            break
        np.minimum.at(out, act, conf.exact_many(lat[act], lon[act], p[act], ei[j]))
    return out


# ---------------------------------------------------------------------- contains
def contains(
    shape,
    lon,
    lat,
    *,
    distance: float = 0.0,
    radius: float = EARTH_RADIUS,
    level=None,
    ellipsoid=None,
) -> np.ndarray:
    """Whether points lie in the offset region of the shape (fast and exact).

    Parameters
    ----------
    shape, lon, lat, distance, radius, level
        As for :func:`gloffset.index.contains.contains_on_sphere` (``radius`` is not used with an
        ellipsoid).
    ellipsoid : None, "WGS84", "GRS80", (a, f) or Ellipsoid
        ``None``: the sphere of ``radius``, exactly as without this keyword. Otherwise
        ``distance`` is a geodesic length on the ellipsoid (metres, or a string with a
        length unit: ``"127km"``), latitudes are geodetic and polygon edges are geodesics.

    Notes
    -----
    On the ellipsoid: exact for points whose geodesic distance differs from
    ``|distance|`` by more than 1 um (see :mod:`gloffset.ellipsoidal` for the two
    slivers where it is not); the spherical index decides all points but a thin band,
    which costs about 1 ms per point.

    Examples
    --------
    >>> import gloffset
    >>> ring = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]
    >>> sq = gloffset.read({"type": "Polygon", "coordinates": [ring]})
    >>> gloffset.contains(sq, [5.0, 10.5], [5.0, 5.0], distance=56e3, ellipsoid="WGS84").tolist()
    [True, True]
    """
    ell = as_ellipsoid(ellipsoid)
    if ell is None:
        return contains_on_sphere(shape, lon, lat, distance=distance, radius=radius, level=level)
    shape = read(shape)
    d = offset_metres(shape, distance, 1.0)  # checks d <= 0 without polygons
    lon, lat, shp = check_lonlat(lon, lat)
    return members(conformal(shape, ell), lon, lat, d, level=level).reshape(shp)


class EllipsoidIndex:
    """A shape prepared for membership queries on an ellipsoid at one geodesic distance.

    Made by ``gloffset.Index(shape, d, ellipsoid=...)``: its conformal image with the
    geodesic edges' bounds, and the two spherical indexes of :func:`screen` (made on the
    first query, kept on the image).

    ``contains(lon, lat)`` equals :func:`contains` on the ellipsoid: exact for points
    whose geodesic distance differs from ``|distance|`` by more than 1 um.

    Examples
    --------
    >>> import gloffset
    >>> ring = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]
    >>> sq = gloffset.read({"type": "Polygon", "coordinates": [ring]})
    >>> ix = gloffset.Index(sq, 56e3, ellipsoid="WGS84")
    >>> ix.contains([5.0, 10.5, 12.0], [5.0, 5.0, 5.0]).tolist()
    [True, True, False]
    """

    def __init__(self, shape, distance: float = 0.0, *, ellipsoid="WGS84", level=None, **_):
        self.ellipsoid = as_ellipsoid(ellipsoid)
        if self.ellipsoid is None:
            raise OptionError("EllipsoidIndex needs an ellipsoid")
        self.shape = read(shape)
        self.distance = offset_metres(self.shape, distance, 1.0)  # checks d <= 0 too
        self.level = level
        self._conf = conformal(self.shape, self.ellipsoid)

    def contains(self, lon, lat) -> np.ndarray:
        """Membership of points given by geodetic lon/lat in degrees (broadcast)."""
        lon, lat, shp = check_lonlat(lon, lat)
        return members(self._conf, lon, lat, self.distance, level=self.level).reshape(shp)

    def __repr__(self) -> str:
        return f"EllipsoidIndex(distance={self.distance!r} m, {self.ellipsoid})"


Index.on_ellipsoid = EllipsoidIndex


def members(conf: Conformal, lon, lat, d: float, *, chi=None, level=None) -> np.ndarray:
    """Membership on the ellipsoid of checked flat geodetic ``lon``, ``lat`` (degrees).

    In the region at geodesic distance ``d`` (metres): :func:`screen`, then :func:`decide`
    on the band. ``chi``: the conformal latitudes of ``lat`` when the caller has them (a
    grid's rows share theirs).
    """
    out, band = screen(conf, lon, lat, d, level, chi=chi)
    idx = np.flatnonzero(band)
    t_in, t_out = thresholds(conf, d)
    lo = -np.inf if t_in is None else t_in - INDEX_SLACK
    out[idx] = decide(conf, lon[idx], lat[idx], d, band=(lo, t_out + INDEX_SLACK))
    return out


def thresholds(conf: Conformal, d: float, *, window=None) -> tuple[float | None, float]:
    """Signed spherical distances of the two index tests.

    Membership at ``t_in`` proves membership on the ellipsoid, non-membership at ``t_out``
    proves non-membership (``None``: no membership test; there is always a non-membership
    test).

    ``window``: ``(chi, r)`` (radians) when every point tested has its conformal
    latitude within ``chi +- r``: the scale's bounds are then those over that window
    widened by the reach ``m / k_min`` of any path that matters (:mod:`.ellipsoid.bounds`:
    the spherical path to the set within ``t_in`` and the geodesic within ``m`` both
    stay that close), tighter than the whole ellipsoid's ``k_min``, ``k_max``.
    """
    ell, hm = conf.ell, conf.h_max
    rings = bool(conf.shape.rings)
    m = abs(d)
    k_min, k_max = ell.k_min, ell.k_max
    if window is not None:
        reach = m / (ell.k_min * (1 - 1e-11)) + hm + INDEX_SLACK
        lo, hi = window_scale(ell, window[0], window[1] + reach)
        k_min, k_max = float(lo), float(hi)
    far = m / (k_min * (1 - 1e-11)) + hm + INDEX_SLACK  # beyond: D_e > m surely
    near = m / (k_max * (1 + 1e-11)) - hm - INDEX_SLACK  # within: D_e <= m surely
    if d > 0.0:
        t_in = near if near > hm else (-hm if rings else None)
        return t_in, far
    t_in = -far if rings else None
    t_out = -near if near > hm else hm
    return t_in, t_out


def signed_distance(conf: Conformal, p) -> np.ndarray:
    """Signed distance (rad) on the conformal sphere from unit vectors ``p`` to the shape's image.

    Negative inside its polygons (1-Lipschitz, as the thresholds of :func:`thresholds` are).
    """
    theta = distance_xyz(conf.shape, p)
    if conf.shape.rings:
        theta = np.where(inside_indexed(conf.shape, p), -theta, theta)
    return theta


def screen(
    conf: Conformal, lon, lat, d: float, level, *, chi=None
) -> tuple[np.ndarray, np.ndarray]:
    """Decide points with the spherical ``contains`` on the conformal sphere.

    ``(out, band)``, ``out`` right wherever ``band`` is False (``chi``: the conformal
    latitudes of ``lat``, made here when not given).
    """
    t_in, t_out = thresholds(conf, d)
    if chi is None:
        chi = conf.ell.conformal(lat)
    sure_in = np.zeros(len(lon), dtype=bool)
    maybe = np.ones(len(lon), dtype=bool)
    if t_in is not None:
        sure_in = contains_angle(conf.shape, lon, chi, t_in, level)
    if t_out is not None:
        maybe = contains_angle(conf.shape, lon, chi, t_out, level)
    return sure_in, maybe & ~sure_in


def decide(conf: Conformal, lon, lat, d: float, *, band=None) -> np.ndarray:
    """Exact membership on the ellipsoid of band points (flat geodetic lon/lat).

    ``band``: ``(lo, hi)``, bounds on the points' signed spherical distance on the
    conformal sphere (:func:`signed_distance`) when the caller knows them: a band that
    excludes 0 tells the points' spherical inside without a crossing count.
    """
    ell = conf.ell
    m = abs(d)
    p = ell.to_sphere(lon, lat)
    chi = conf.chi(lat)
    qi, ei, theta = conf.pairs(p, np.full(len(lon), m / ell.k_min + conf.h_max + INDEX_SLACK))
    up = upper_distance(ell, chi[qi], theta + conf.h[ei])
    low = lower_distance(ell, chi[qi], theta - conf.h[ei], m)
    near = np.zeros(len(lon), dtype=bool)  # within m surely
    np.logical_or.at(near, qi, up <= m)
    if not conf.shape.rings or (band is not None and band[0] > 0.0):
        ins = np.zeros(len(lon), dtype=bool)
    elif band is not None and band[1] < 0.0:
        ins = np.ones(len(lon), dtype=bool)
    else:
        ins = inside_indexed(conf.shape, p)
    lune = theta <= conf.h[ei] + INDEX_SLACK
    # the points the bounds decide, at once: within m surely, or beyond m surely (no
    # pair's lower bound within m) with no lune about them (the spherical inside holds)
    maybe = np.zeros(len(lon), dtype=bool)
    np.logical_or.at(maybe, qi, low <= m)
    in_lune = np.zeros(len(lon), dtype=bool)
    np.logical_or.at(in_lune, qi, lune)
    within = near & (m > 0.0)
    out = np.where(within, d > 0.0, ins)
    slow = np.flatnonzero(~within & ((maybe & (m > 0.0)) | in_lune))
    if len(slow) == 0:
        return out
    is_slow = np.zeros(len(lon), dtype=bool)
    is_slow[slow] = True
    if m > 0.0:  # the intercepts of the slow points' pairs that can be within m
        j = np.flatnonzero(is_slow[qi] & (low <= m))
        k = qi[j]
        hit = conf.exact_many(lat[k], lon[k], p[k], ei[j]) <= m
        found = np.zeros(len(lon), dtype=bool)
        found[k[hit]] = True
        out[found] = d > 0.0
        is_slow &= ~found
    # the rest lie beyond m: inside the polygons with geodesic edges, one at a time
    order = np.lexsort((ei, qi))
    qi, ei, lune = qi[order], ei[order], lune[order]
    starts = np.searchsorted(qi, np.arange(len(lon) + 1))
    for k in np.flatnonzero(is_slow):
        js = range(starts[k], starts[k + 1])
        out[k] = _inside(conf, lat[k], lon[k], p[k], bool(ins[k]), [ei[j] for j in js if lune[j]])
    return out


def _inside(conf: Conformal, lat, lon, p, inside_sphere: bool, edges) -> bool:
    """Inside the polygons with geodesic edges.

    Each region component's spherical answer flipped once for each of its lunes (between a
    geodesic edge and its great-circle arc) that holds the point, the components united.
    """
    flipped: set[int] = set()
    for e in edges:
        _, _, side = conf.exact(lat, lon, p, e)
        if side == 0.0:  # the foot is an end: the point is not between the two curves
            continue
        left_sphere = dot(p, conf.n[e]) >= 0.0
        if left_sphere != (side > 0.0):
            flipped ^= {int(conf.group[e])}
    if not flipped:
        return inside_sphere
    q = p[None]
    for g in flipped:
        if not crossings_inside(conf.shape, q, groups=[g])[0]:
            return True  # out on the sphere, flipped in
    others = [g for g in range(conf.shape.n_groups) if g not in flipped]
    return bool(others) and bool(crossings_inside(conf.shape, q, groups=others)[0])
