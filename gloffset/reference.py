"""The float64 reference: distances to a shape and offset-region membership, in numpy.

This is the judge that every faster path (the GPU renderer, the multiresolution
``contains``) is held to. It is exact brute force in float64, made fast enough for
tens of millions of points by two safe shortcuts and bounded memory:

* the distance to the nearest boundary *vertex* is an upper bound ``u`` on the
  distance to the shape (a matrix product picks the vertex);
* an edge whose bounding cap (centre ``c``, radius half its length ``h``) is farther
  than ``u + h`` from the point cannot be nearest, so only the remaining candidates
  get the exact point-to-arc distance of :func:`gloffset.sphere.arc_distance`.

Points are processed in chunks so memory stays bounded whatever their number.

The bounds here (an edge's bounding cap, the cap test ``c.p >= cos(u + h) - 1e-12``)
are deliberate copies of those in :mod:`gloffset.caps`, not imports: the judge shares
no code with what it judges, so a wrong bound there cannot hide itself here.
"""

from __future__ import annotations

import numpy as np

from . import crossings
from .errors import InvalidGeometryError
from .sphere import angle, arc_distance, lonlat_to_xyz, normalize, robust_cross
from .units import EARTH_RADIUS, check_radius, to_angle

__all__ = ["distance", "contains", "distance_xyz", "contains_xyz", "points_xyz", "check_lonlat"]

_PAIRS = 1 << 22  # point-edge pairs per chunk


def points_xyz(lon, lat) -> tuple[np.ndarray, tuple]:
    """Validate query lon/lat (degrees) and return unit vectors (n, 3) and the input shape."""
    lon, lat, shape = check_lonlat(lon, lat)
    return lonlat_to_xyz(lon, lat), shape


def check_lonlat(lon, lat) -> tuple[np.ndarray, np.ndarray, tuple]:
    """Validate query lon/lat (degrees): flat float64 arrays and their broadcast shape.

    Raises :class:`InvalidGeometryError` for shapes that do not broadcast, NaN or
    infinite coordinates and latitudes outside [-90, 90], naming the first bad point.
    """
    lon = np.asarray(lon, dtype=np.float64)
    lat = np.asarray(lat, dtype=np.float64)
    try:
        lon, lat = np.broadcast_arrays(lon, lat)
    except ValueError:
        raise InvalidGeometryError(
            f"lon and lat cannot be broadcast together: shapes {lon.shape} and {lat.shape}"
        ) from None
    shape = lon.shape
    lon, lat = lon.ravel(), lat.ravel()
    bad = ~(np.isfinite(lon) & np.isfinite(lat))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InvalidGeometryError(
            f"query point {i}: coordinate is not finite ({lon[i]}, {lat[i]})"
        )
    if (np.abs(lat) > 90.0).any():
        i = int(np.flatnonzero(np.abs(lat) > 90.0)[0])
        raise InvalidGeometryError(
            f"query point {i}: latitude {float(lat[i])!r} out of range [-90, 90]"
        )
    return lon, lat, shape


class _EdgeIndex:
    """Boundary edges of a shape with what the distance shortcut needs."""

    def __init__(self, shape):
        e = shape.edges()
        self.a = e.a[e.boundary]
        self.b = e.b[e.boundary]
        self.n = normalize(robust_cross(self.a, self.b))
        # deliberately not gloffset.caps.arc_cap: the judge shares no code with what it judges
        mid = normalize(self.a + self.b)
        self.c = np.where(np.linalg.norm(self.a + self.b, axis=1)[:, None] > 0, mid, self.a)
        self.h = 0.5 * angle(self.a, self.b)
        self.v = np.unique(np.concatenate([self.a, self.b]), axis=0)


def _index(shape) -> _EdgeIndex:
    return shape.cached("reference.index", lambda: _EdgeIndex(shape))


def distance_xyz(shape, p: np.ndarray) -> np.ndarray:
    """Great-circle distance in radians from unit vectors ``p`` (n, 3) to the shape's curves.

    Accuracy: the exact distance to the nearest boundary arc, vertex or isolated
    point, with absolute error below 1e-15 rad (that of
    :func:`gloffset.sphere.arc_distance`). Seams are not boundary and do not count.
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
        # a copy of gloffset.caps.cap_within on purpose (the judge shares no code)
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
    ins = crossings.inside(shape, p)
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


def distance(shape, lon, lat, *, radius: float = EARTH_RADIUS) -> np.ndarray:
    """Great-circle distance from points to the nearest point of the shape's curves.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    lon, lat : array_like
        Query points in degrees (broadcast together).
    radius : float
        Sphere radius; the result is in its units (``radius=1`` gives radians).

    Notes
    -----
    Accuracy: absolute error below ``1e-15 * radius`` (see :func:`distance_xyz`).
    The distance is to the boundary, also for points inside a polygon.

    Examples
    --------
    >>> import gloffset
    >>> s = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [10, 0]]})
    >>> float(gloffset.distance(s, 5.0, 1.0, radius=1.0).round(12))
    0.017453292520
    """
    from .shape import read

    shape = read(shape)
    r = check_radius(radius)
    p, shp = points_xyz(lon, lat)
    return (distance_xyz(shape, p) * r).reshape(shp)


def contains(shape, lon, lat, *, distance: float = 0.0, radius: float = EARTH_RADIUS) -> np.ndarray:
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

    Notes
    -----
    Exact for points farther than 1e-15 rad from the boundary and whose distance
    differs from ``|distance|`` by more than 1e-15 rad. Polygons are united;
    lines and points have no inside.
    """
    from .shape import read

    shape = read(shape)
    d = to_angle(distance, radius)
    p, shp = points_xyz(lon, lat)
    return contains_xyz(shape, p, d).reshape(shp)
