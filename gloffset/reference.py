"""The float64 reference: distances to a shape and offset-region membership, in numpy.

This is the judge that every faster path (the GPU renderer, the multiresolution
``contains``) is held to. It is exact brute force in float64, made fast enough for
tens of millions of points by two safe shortcuts and bounded memory:

* the distance to the nearest boundary *vertex* is an upper bound ``u`` on the
  distance to the shape (a matrix product picks the vertex);
* an edge whose bounding cap (centre ``c``, radius half its length ``h``) is farther
  than ``u + h`` from the point cannot be nearest, so only the remaining candidates
  get the exact point-to-arc distance of :func:`gloffset.geometry.sphere.arc_distance`.

Inside/outside is the judge's own crossing parity (:func:`inside_xyz`), written apart
from :mod:`gloffset.geometry.crossings`, which the production paths use. Points are processed
in chunks so memory stays bounded whatever their number.

**On the ellipsoid** (``ellipsoid=`` on :func:`distance` and :func:`contains_lonlat`) the
judge is brute force on pyproj's geodesics, edges sampled down to
:data:`GEODESIC_SPACING` (:func:`geodesic_edge_distance`, :func:`geodesic_inside`).

The bounds here (an edge's bounding cap, the cap test ``c.p >= cos(u + h) - 1e-12``)
are deliberate copies of those in :mod:`gloffset.geometry.caps`, not imports, and the crossing
test is not that of :mod:`gloffset.geometry.crossings`: the judge shares no code with what it
judges (it imports only the maths and the shape), so a wrong bound or rule there cannot
hide itself here. Nothing in gloffset outside the tests calls the judge. The derivation in
full: ``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

import numpy as np

from .geometry.sphere import angle, arc_distance, cross, dot, lonlat_to_xyz, normalize, robust_cross
from .units import EARTH_RADIUS, check_lonlat, check_radius, to_angle

__all__ = [
    "distance",
    "contains_lonlat",
    "distance_xyz",
    "contains_xyz",
    "inside_xyz",
    "points_xyz",
    "geodesic_distance",
    "geodesic_edge_distance",
    "geodesic_inside",
    "geodesic_contains",
]

_PAIRS = 1 << 22  # point-edge pairs per chunk
#: Final sample spacing (metres) along an edge of the ellipsoidal brute force.
GEODESIC_SPACING = 1e-5
#: Length (metres) of the geodesic pieces of the ellipsoidal inside test.
GEODESIC_PIECE = 1000.0


def points_xyz(lon, lat) -> tuple[np.ndarray, tuple]:
    """Validate query lon/lat (degrees) and return unit vectors (n, 3) and the input shape."""
    lon, lat, shape = check_lonlat(lon, lat)
    return lonlat_to_xyz(lon, lat), shape


def _ring_edges(shape) -> tuple:
    """The ring edges (seams included) grouped by region component: ends ``a``, ``b``,
    normals ``2 a x b`` (from :func:`gloffset.geometry.sphere.robust_cross`, accurate for short
    edges), the components present and where each one's run of edges starts."""
    e = shape.edges()
    order = np.flatnonzero(e.group >= 0)
    order = order[np.argsort(e.group[order], kind="stable")]
    a, b, grp = e.a[order], e.b[order], e.group[order]
    present, starts = np.unique(grp, return_index=True)
    return a, b, robust_cross(a, b), present, starts


def _arcs_meet(q, r, r_side, a, b, n) -> np.ndarray:
    """(len(q), len(a)) bool: whether the short arc ``q[i] -> r[i]`` crosses the edge
    ``a[j] -> b[j]`` (normal ``n[j]``); ``r_side[i, j] = r[i] . n[j]``.

    Both pairs of ends must lie on either side of the other's great circle (a point on
    it counts as on its left: the half-open rule); the two circles then meet at two
    antipodal points, and the arcs cross where the point of ``q -> r`` on the edge's
    circle, ``q |r.n| + r |q.n|`` (a positive combination, so on the short arc), lies
    on the edge's side of the sphere: a positive dot product with ``a + b``. That last
    test is far from rounding (the point is within half the edge's length of the
    edge's middle, or as far from it as the antipode), so only the side tests decide
    close calls.
    """
    qr = cross(q, r)
    a_left = (qr @ a.T) >= 0.0
    b_left = (qr @ b.T) >= 0.0
    q_side = q @ n.T
    both = (a_left != b_left) & ((q_side >= 0.0) != (r_side >= 0.0))
    i, j = np.nonzero(both)
    meet = q[i] * np.abs(r_side[i, j])[:, None] + r[i] * np.abs(q_side[i, j])[:, None]
    near_side = dot(meet, a[j] + b[j]) > 0.0
    out = np.zeros(both.shape, dtype=bool)
    out[i[near_side], j[near_side]] = True
    return out


def inside_xyz(shape, p: np.ndarray) -> np.ndarray:
    """Whether unit vectors ``p`` (n, 3) lie inside the shape's polygons (united; False
    for lines and points), by crossing parity against every ring edge.

    Each point walks to the first of the shape's reference points, or to the second
    where the first is more than 120 degrees away (so the arc is short and never near
    antipodal); a component contains the point when its status at that reference point,
    flipped by each crossing with the component's own edges, says so.

    Accuracy: exact for points farther than about 1e-15 rad from the boundary (the
    side tests are float64 triple products of unit vectors, with the edges' normals
    from the robust cross product); on the boundary the half-open rule and rounding
    decide.
    """
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    out = np.zeros(len(p), dtype=bool)
    if shape.n_groups == 0 or len(p) == 0:
        return out
    a, b, n, present, starts = shape.derived.once("reference_rings", lambda: _ring_edges(shape))
    refs, status = shape.reference_points()
    ref_side = refs @ n.T  # (2, edges)
    which = (p @ refs[0] < -0.5).astype(np.int64)
    chunk = max(1, _PAIRS // max(len(a), 1))
    for s in range(0, len(p), chunk):
        q, k = p[s : s + chunk], which[s : s + chunk]
        hit = _arcs_meet(q, refs[k], ref_side[k], a, b, n)
        odd = np.add.reduceat(hit, starts, axis=1, dtype=np.int64) % 2 == 1
        out[s : s + chunk] = (odd != status[k][:, present]).any(axis=1)
    return out


class _EdgeIndex:
    """Boundary edges of a shape with what the distance shortcut needs."""

    def __init__(self, shape):
        e = shape.edges()
        self.a = e.a[e.boundary]
        self.b = e.b[e.boundary]
        self.n = normalize(robust_cross(self.a, self.b))
        # deliberately not gloffset.geometry.caps.arc_cap: the judge shares no code with what it
        # judges
        mid = normalize(self.a + self.b)
        self.c = np.where(np.linalg.norm(self.a + self.b, axis=1)[:, None] > 0, mid, self.a)
        self.h = 0.5 * angle(self.a, self.b)
        self.v = np.unique(np.concatenate([self.a, self.b]), axis=0)


def _index(shape) -> _EdgeIndex:
    return shape.derived.once("reference_index", lambda: _EdgeIndex(shape))


def distance_xyz(shape, p: np.ndarray) -> np.ndarray:
    """Great-circle distance in radians from unit vectors ``p`` (n, 3) to the shape's curves.

    Accuracy: the exact distance to the nearest boundary arc, vertex or isolated
    point, with absolute error below 1e-15 rad (that of
    :func:`gloffset.geometry.sphere.arc_distance`). Seams are not boundary and do not count.
    """
    ix = _index(shape)
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    out = np.empty(len(p))
    if len(ix.a) == 0:
        out.fill(np.inf)
        return out
    chunk = max(1, _PAIRS // max(len(ix.a), len(ix.v)))
    for s in range(0, len(p), chunk):
        q = p[s : s + chunk]
        best = np.argmax(q @ ix.v.T, axis=1)
        u = angle(q, ix.v[best])
        # candidate edges: cap centre within u + h (compared as dot products, with slack);
        # a copy of gloffset.geometry.caps.cap_within on purpose (the judge shares no code)
        lim = np.cos(np.minimum(u[:, None] + ix.h[None, :], np.pi)) - 1e-12
        rows, cols = np.nonzero((q @ ix.c.T) >= lim)
        d = arc_distance(q[rows], ix.a[cols], ix.b[cols], ix.n[cols])
        res = u.copy()
        np.minimum.at(res, rows, d)
        out[s : s + chunk] = res
    return out


def contains_xyz(shape, p: np.ndarray, d: float) -> np.ndarray:
    """Offset-region membership of unit vectors ``p`` for an angular distance ``d``.

    For ``d >= 0``: inside a polygon of the shape or within ``d`` of its curves.
    For ``d < 0``: inside a polygon and farther than ``|d|`` from its boundary.
    Exact for points whose distance differs from ``|d|`` by more than 1e-15 rad and
    that lie farther than 1e-15 rad from the boundary.
    """
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    ins = inside_xyz(shape, p)
    if d == 0.0:
        return ins
    if d > 0.0:
        out = ins.copy()
        rest = np.flatnonzero(~ins)
        out[rest] = distance_xyz(shape, p[rest]) <= d
        return out
    out = ins.copy()
    cand = np.flatnonzero(ins)
    out[cand] = distance_xyz(shape, p[cand]) > -d
    return out


def distance(shape, lon, lat, *, radius: float = EARTH_RADIUS, ellipsoid=None) -> np.ndarray:
    """Great-circle distance from points to the nearest point of the shape's curves.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    lon, lat : array_like
        Query points in degrees (broadcast together).
    radius : float
        Sphere radius; the result is in its units (``radius=1`` gives radians).
    ellipsoid : None, str, (a, f) or Ellipsoid
        ``None``: the sphere of ``radius``. Otherwise the geodesic distance in metres
        on that ellipsoid (latitudes geodetic, edges geodesics), by brute force
        (:func:`geodesic_distance`; slow, for tests).

    Notes
    -----
    Accuracy: absolute error below ``1e-15 * radius`` (see :func:`distance_xyz`).
    The distance is to the boundary, also for points inside a polygon.

    Examples
    --------
    >>> import gloffset
    >>> s = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [10, 0]]})
    >>> round(gloffset.distance(s, 5.0, 1.0, radius=1.0), 12)
    0.01745329252
    """
    from .shape import read

    shape = read(shape)
    if ellipsoid is not None:
        lon, lat, shp = check_lonlat(lon, lat)
        return geodesic_distance(shape, lon, lat, ellipsoid).reshape(shp)
    r = check_radius(radius)
    p, shp = points_xyz(lon, lat)
    return (distance_xyz(shape, p) * r).reshape(shp)


def contains_lonlat(
    shape, lon, lat, *, distance: float = 0.0, radius: float = EARTH_RADIUS, ellipsoid=None
) -> np.ndarray:
    """Whether points lie in the offset region of the shape (brute force float64 reference).

    Parameters
    ----------
    shape, lon, lat
        The shape and the query points, as for :func:`distance`.
    distance : float
        Offset distance in the units of ``radius``. ``0`` tests the polygons
        themselves; ``> 0`` adds everything within that distance of the curves;
        ``< 0`` keeps points of the polygons farther than ``|distance|`` from
        their boundary.
    radius : float
        Sphere radius (default :data:`gloffset.EARTH_RADIUS`, metres).
    ellipsoid : None, str, (a, f) or Ellipsoid
        ``None``: the sphere. Otherwise ``distance`` is a geodesic length in metres on
        that ellipsoid and polygons have geodesic edges (:func:`geodesic_contains`).

    Notes
    -----
    Exact for points farther than 1e-15 rad from the boundary and whose distance
    differs from ``|distance|`` by more than 1e-15 rad. Polygons are united;
    lines and points have no inside.
    """
    from .shape import read

    shape = read(shape)
    if ellipsoid is not None:
        d = to_angle(distance, 1.0)
        lon, lat, shp = check_lonlat(lon, lat)
        return geodesic_contains(shape, lon, lat, d, ellipsoid).reshape(shp)
    d = to_angle(distance, radius)
    p, shp = points_xyz(lon, lat)
    return contains_xyz(shape, p, d).reshape(shp)


# ---------------------------------------------------------------------- on the ellipsoid
def _geod(ellipsoid):
    """pyproj's Geod for a name, an (a, f) pair or anything with ``a`` and ``f``."""
    from pyproj import Geod

    if isinstance(ellipsoid, str):
        return Geod(ellps=ellipsoid.strip().upper().replace("-", ""))
    if hasattr(ellipsoid, "a") and hasattr(ellipsoid, "f"):
        return Geod(a=float(ellipsoid.a), f=float(ellipsoid.f))
    a, f = ellipsoid
    return Geod(a=float(a), f=float(f))


def _ecef(geod, lon, lat) -> np.ndarray:
    """Earth-centred coordinates (metres) of geodetic lon/lat (degrees) on the surface."""
    lam, phi = np.radians(lon), np.radians(lat)
    e2 = geod.es
    n = geod.a / np.sqrt(1.0 - e2 * np.sin(phi) ** 2)
    return np.stack(
        [n * np.cos(phi) * np.cos(lam), n * np.cos(phi) * np.sin(lam), n * (1 - e2) * np.sin(phi)],
        axis=-1,
    )


def _boundary_lonlat(shape):
    """Boundary edges as lon/lat (degrees): (alon, alat, blon, blat)."""
    e = shape.edges()
    a, b = e.a[e.boundary], e.b[e.boundary]
    alon, alat = (
        np.degrees(np.arctan2(a[:, 1], a[:, 0])),
        np.degrees(np.arcsin(np.clip(a[:, 2], -1, 1))),
    )
    blon, blat = (
        np.degrees(np.arctan2(b[:, 1], b[:, 0])),
        np.degrees(np.arcsin(np.clip(b[:, 2], -1, 1))),
    )
    return alon, alat, blon, blat


def geodesic_edge_distance(geod, plon, plat, alon, alat, blon, blat) -> np.ndarray:
    """Brute force: distance (metres) from points to geodesic edges, pair by pair (arrays
    broadcast), on pyproj's ``geod``.

    Each edge is sampled at 257 points along its geodesic (pyproj's direct problem
    from ``a`` with the edge's azimuth), then the stretch between the nearest sample's
    neighbours at 33 points, and so on until the spacing is below
    :data:`GEODESIC_SPACING` (10 um): the result is within that (plus pyproj's 15 nm)
    of the distance to the nearest point of the edge's basin found at the first level.
    """
    plon, plat, alon, alat, blon, blat = (
        np.ravel(x).astype(np.float64)
        for x in np.broadcast_arrays(plon, plat, alon, alat, blon, blat)
    )
    az, _, length = geod.inv(alon, alat, blon, blat)
    lo, hi = np.zeros_like(length), length.copy()
    best = np.full(len(length), np.inf)
    n = 257
    while True:
        t = np.linspace(0.0, 1.0, n)
        s = lo[:, None] + (hi - lo)[:, None] * t[None, :]
        k = np.repeat(np.arange(len(s)), n)
        xlon, xlat, _ = geod.fwd(alon[k], alat[k], az[k], s.ravel())
        d = geod.inv(plon[k], plat[k], xlon, xlat)[2].reshape(-1, n)
        j = np.argmin(d, axis=1)
        best = np.minimum(best, d[np.arange(len(d)), j])
        step = (hi - lo) / (n - 1)
        if np.all(step <= GEODESIC_SPACING):
            return best
        sj = s[np.arange(len(s)), j]
        lo, hi = np.maximum(sj - step, 0.0), np.minimum(sj + step, length)
        n = 33


def _lower_to_vertices(geod, q, v) -> np.ndarray:
    """Lower bounds (metres) on geodesic distances from surface points ``q`` (n, 3, ECEF)
    to surface points ``v`` (m, 3): the larger of the chord and ``b`` times the angle
    between their directions from the centre (the ellipsoid lies outside the sphere of
    radius ``b``, and the radial projection onto it shortens every curve)."""
    chord = np.linalg.norm(q[:, None, :] - v[None], axis=2)
    qu = q / np.linalg.norm(q, axis=1)[:, None]
    vu = v / np.linalg.norm(v, axis=1)[:, None]
    cosang = np.clip(qu @ vu.T, -1.0, 1.0)
    # the angle from the chord of unit vectors (accurate for small angles), rounded down
    unit_chord = np.sqrt(np.maximum(2.0 - 2.0 * cosang, 0.0))
    ang = 2.0 * np.arcsin(np.minimum(0.5 * unit_chord, 1.0)) * (1 - 1e-12) - 1e-15
    return np.maximum(chord, geod.b * ang) * (1 - 1e-12)


def geodesic_distance(shape, lon, lat, ellipsoid) -> np.ndarray:
    """Brute-force geodesic distance (metres) from geodetic lon/lat (degrees, flat arrays)
    to the shape's boundary on ``ellipsoid``: edges pruned by the chord and inner-sphere
    bounds, then by their first samples, the rest measured with
    :func:`geodesic_edge_distance`."""
    geod = _geod(ellipsoid)
    alon, alat, blon, blat = _boundary_lonlat(shape)
    out = np.full(len(lon), np.inf)
    if len(alon) == 0:
        return out
    pa, pb = _ecef(geod, alon, alat), _ecef(geod, blon, blat)
    length = geod.inv(alon, alat, blon, blat)[2]
    q = _ecef(geod, lon, lat)
    chunk = max(1, _PAIRS // (8 * len(alon)))
    for s in range(0, len(lon), chunk):
        sl = slice(s, s + chunk)
        la, lb = _lower_to_vertices(geod, q[sl], pa), _lower_to_vertices(geod, q[sl], pb)
        near = np.minimum(la, lb)
        j = np.argmin(near, axis=1)
        va = la[np.arange(len(j)), j] <= lb[np.arange(len(j)), j]
        vlon, vlat = np.where(va, alon[j], blon[j]), np.where(va, alat[j], blat[j])
        upper = geod.inv(lon[sl], lat[sl], vlon, vlat)[2]
        rows, cols = np.nonzero(near - 0.5 * length[None, :] <= upper[:, None] * (1 + 1e-9) + 1e-6)
        args = (lon[sl][rows], lat[sl][rows], alon[cols], alat[cols], blon[cols], blat[cols])
        # first samples of every candidate: an upper bound per point, and (the distance
        # to the edge being 1-Lipschitz along it) a lower bound per edge
        first, step = _first_samples(geod, *args)
        res = upper.copy()
        np.minimum.at(res, rows, first)
        keep = np.flatnonzero(first - 0.5 * step <= res[rows] * (1 + 1e-9) + 1e-6)
        d = geodesic_edge_distance(geod, *(a[keep] for a in args))
        np.minimum.at(res, rows[keep], d)
        out[sl] = res
    return out


def _first_samples(geod, plon, plat, alon, alat, blon, blat, n: int = 257):
    """The nearest of ``n`` evenly spaced samples of each edge, and their spacing."""
    az, _, length = geod.inv(alon, alat, blon, blat)
    t = np.linspace(0.0, 1.0, n)
    k = np.repeat(np.arange(len(az)), n)
    xlon, xlat, _ = geod.fwd(alon[k], alat[k], az[k], (length[:, None] * t[None, :]).ravel())
    d = geod.inv(plon[k], plat[k], xlon, xlat)[2].reshape(-1, n)
    return d.min(axis=1, initial=np.inf), length / (n - 1)


def _densified(shape, geod):
    """The shape with each boundary edge replaced by geodesic pieces of at most
    :data:`GEODESIC_PIECE` metres (seams kept as they are)."""
    from dataclasses import replace

    rings, seams = [], []
    for ring, seam in zip(shape.rings, shape.ring_seams):
        lon, lat = (
            np.degrees(np.arctan2(ring[:, 1], ring[:, 0])),
            np.degrees(np.arcsin(np.clip(ring[:, 2], -1, 1))),
        )
        nlon, nlat = np.roll(lon, -1), np.roll(lat, -1)
        az, _, length = geod.inv(lon, lat, nlon, nlat)
        pieces = np.where(seam, 1, np.maximum(1, np.ceil(length / GEODESIC_PIECE))).astype(int)
        k = np.repeat(np.arange(len(ring)), pieces)
        frac = np.arange(len(k)) - np.repeat(np.cumsum(pieces) - pieces, pieces)
        xlon, xlat, _ = geod.fwd(lon[k], lat[k], az[k], length[k] * frac / pieces[k])
        v = lonlat_to_xyz(xlon, xlat)
        first = frac == 0
        v[first] = ring[k[first]]  # the vertices themselves, bit for bit
        rings.append(v)
        seams.append(np.repeat(seam, pieces))
    return replace(shape, rings=rings, ring_seams=seams, source=None)


def geodesic_inside(shape, lon, lat, ellipsoid) -> np.ndarray:
    """Whether geodetic lon/lat (degrees) lie inside the shape's polygons whose edges are
    geodesics of ``ellipsoid`` (crossing parity against the densified edges; exact for
    points farther than 0.1 mm from the boundary)."""
    geod = _geod(ellipsoid)
    if not shape.rings:
        return np.zeros(len(lon), dtype=bool)
    dense = shape.derived.reference_geodesic.once((geod.a, geod.f), lambda: _densified(shape, geod))
    return inside_xyz(dense, lonlat_to_xyz(lon, lat))


def geodesic_contains(shape, lon, lat, d: float, ellipsoid) -> np.ndarray:
    """Offset-region membership on the ellipsoid (``d`` in metres, geodesic), by brute
    force: :func:`geodesic_inside` and :func:`geodesic_distance`."""
    ins = geodesic_inside(shape, lon, lat, ellipsoid)
    if d == 0.0:
        return ins
    out = ins.copy()
    rest = np.flatnonzero(~ins if d > 0 else ins)
    dist = geodesic_distance(shape, lon[rest], lat[rest], ellipsoid)
    out[rest] = dist <= d if d > 0 else dist > -d
    return out
