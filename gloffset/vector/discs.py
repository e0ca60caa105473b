"""Offsets of many points (discs) and single great-circle segments (stadiums) at once.

The offset of a point by d is the small circle of angular radius d around it; the offset
of a segment a -> b is a stadium: the two small circles at distance d from its great
circle (points ``cos d g(t) +- sin d n``, with ``n`` the segment's unit normal and
``g(t)`` its points) joined by half circles around a and b. Both are exact (every vertex
at distance d from the feature, to rounding) and need no self-intersection removal for
0 < d < pi/2, so thousands of them are computed with a few numpy operations instead of
one :func:`~gloffset.offset` each. Rings run counter-clockwise (interior on the left).

:func:`rings_lonlat` gives the rings in lon/lat, with a flag for those that cross the
antimeridian or enclose a pole: those are kept as unit vectors, for the writers
(:func:`gloffset.io.geojson.disc_geometry`) to cut at +-180 deg and close along the pole.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidGeometryError
from ..geometry.sphere import angle, arc_distance, lonlat_to_xyz, normalize, xyz_to_lonlat

__all__ = [
    "disc_rings",
    "stadium_rings",
    "rings_lonlat",
    "segments_per_quarter",
    "resolution_for",
    "Rings",
    "discs",
    "stadiums",
]


def segments_per_quarter(resolution: int) -> int:
    """``resolution`` (segments per quarter circle, as GEOS and GeoPandas count) checked."""
    return max(1, int(resolution))


def _frame(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors tangent at each centre ``c`` (n, 3): east and north (a fixed
    axis at the poles)."""
    east = np.cross(np.array([0.0, 0.0, 1.0]), c)
    polar = np.linalg.norm(east, axis=1) < 1e-12
    east[polar] = np.array([0.0, 1.0, 0.0])
    east = normalize(east)
    return east, np.cross(c, east)


def _per_row(d, n: int) -> np.ndarray:
    """``d`` (one value, or one per ring) as an (n, 1, 1) array."""
    return np.broadcast_to(np.asarray(d, dtype=np.float64).reshape(-1, 1, 1), (n, 1, 1))


def disc_rings(centres: np.ndarray, d, resolution: int = 16) -> np.ndarray:
    """(n, 4 * resolution, 3) rings: the small circles of radius ``d`` (radians; one, or
    one per centre) around ``centres`` (n, 3), counter-clockwise, first vertex due east."""
    k = 4 * segments_per_quarter(resolution)
    t = 2.0 * np.pi * np.arange(k) / k
    east, north = _frame(centres)
    dd = _per_row(d, len(centres))
    # vertex = cos d c + sin d (cos t east + sin t north): one (k, 2) @ (2, 3) per centre
    around = np.column_stack([np.cos(t), np.sin(t)]) @ np.stack([east, north], axis=1)
    return np.cos(dd) * centres[:, None] + np.sin(dd) * around


def _side_count(length: np.ndarray, d, resolution: int) -> int:
    """Segments along a stadium's straight side that keep its chords as close to the
    small circle as the caps' chords are to theirs (the most any of the rings needs)."""
    if len(length) == 0:
        return 1
    step = np.pi / (2 * segments_per_quarter(resolution))
    d = np.asarray(d, dtype=np.float64)
    sag = np.sin(d) * (1.0 - np.cos(step / 2))  # the caps' chord deviation
    ratio = np.clip(1.0 - sag / np.maximum(np.cos(d), 1e-300), -1.0, 1.0)
    side_step = np.maximum(2.0 * np.arccos(ratio), 1e-9)
    return int(max(1, np.ceil(float(np.max(length / side_step)))))


def stadium_rings(a: np.ndarray, b: np.ndarray, d, resolution: int = 16) -> np.ndarray:
    """(n, m, 3) rings: the offsets by ``d`` (one, or one per segment) of the segments
    ``a[i] -> b[i]`` (n, 3).

    Each ring: the right side from a to b, the half circle around b, the left side
    back from b to a, the half circle around a; counter-clockwise. Every ring has the
    same number of vertices (the most any segment needs sets the sides' sampling).
    """
    n = normalize(np.cross(a, b))
    length = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))
    fa, fb = np.cross(n, a), np.cross(n, b)  # directions of travel at a and b
    q = 2 * segments_per_quarter(resolution)
    dd = _per_row(d, len(a))
    cd, sd = np.cos(dd), np.sin(dd)
    s = _side_count(length, dd[:, 0, 0], resolution)
    frac = np.arange(s) / s  # along the side, the far end excluded (the cap starts there)
    t = frac[None, :] * length[:, None]
    g = np.cos(t)[..., None] * a[:, None] + np.sin(t)[..., None] * fa[:, None]
    right = cd * g - sd * n[:, None]
    th = np.pi * np.arange(q) / q
    ub = -np.cos(th)[None, :, None] * n[:, None] + np.sin(th)[None, :, None] * fb[:, None]
    cap_b = cd * b[:, None] + sd * ub
    t2 = (1.0 - frac)[None, :] * length[:, None]
    g2 = np.cos(t2)[..., None] * a[:, None] + np.sin(t2)[..., None] * fa[:, None]
    left = cd * g2 + sd * n[:, None]
    ua = np.cos(th)[None, :, None] * n[:, None] - np.sin(th)[None, :, None] * fa[:, None]
    cap_a = cd * a[:, None] + sd * ua
    return np.concatenate([right, cap_b, left, cap_a], axis=1)


def rings_lonlat(rings: np.ndarray, reach: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Rings (n, m, 3) as closed lon/lat rings (n, m + 1, 2), and a flag per ring for
    those that cross the antimeridian or come within ``reach`` (radians: d plus the
    feature's own size) of a pole, which plain lon/lat rings cannot draw."""
    lon, lat = xyz_to_lonlat(rings.reshape(-1, 3))
    ll = np.stack([lon.reshape(rings.shape[:2]), lat.reshape(rings.shape[:2])], axis=-1)
    ll = np.concatenate([ll, ll[:, :1]], axis=1)
    jump = np.abs(np.diff(ll[..., 0], axis=1)).max(axis=1) > 180.0
    centre = normalize(rings.mean(axis=1))
    polar = np.abs(centre[:, 2]) >= np.cos(np.minimum(np.asarray(reach) * 1.01 + 1e-9, np.pi))
    return ll, jump | polar


def resolution_for(d: float, tolerance: float) -> int:
    """Segments per quarter circle that keep a disc's chords within ``tolerance`` (radians)
    of its circle of radius ``d``."""
    ratio = 1.0 - tolerance / max(np.sin(abs(d)), 1e-300)
    step = 2.0 * np.arccos(np.clip(ratio, -1.0, 1.0))
    return int(np.clip(np.ceil((np.pi / 2) / max(step, 1e-12)), 1, 1 << 16))


class Rings:
    """Offsets of many points or segments: ``lonlat`` (n, m + 1, 2) closed lon/lat rings,
    and ``special``: {row: (ring, north)} for the rows whose ring crosses the antimeridian
    or encloses a pole (their ``lonlat`` row is not to be used): the ring as (m, 3) unit
    vectors, interior on the left, and whether it encloses the north pole. Written as
    GeoJSON by :func:`gloffset.io.geojson.disc_geometry`."""

    def __init__(self, lonlat: np.ndarray, special: dict):
        self.lonlat = lonlat
        self.special = special


def _unit(ll: np.ndarray, labels) -> np.ndarray:
    """Unit vectors of (n, 2) lon/lat, checked as :mod:`gloffset.shape` checks vertices."""
    ll = np.asarray(ll, dtype=np.float64).reshape(-1, 2)
    bad = ~np.isfinite(ll).all(axis=1) | (np.abs(ll[:, 0]) > 180.0) | (np.abs(ll[:, 1]) > 90.0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InvalidGeometryError(
            f"{labels(i)}: coordinate {ll[i].tolist()} is not a longitude in [-180, 180] and "
            "a latitude in [-90, 90]"
        )
    return lonlat_to_xyz(ll[:, 0], ll[:, 1])


def _finish(rings: np.ndarray, reach, north) -> Rings:
    """Lon/lat rings; those across the antimeridian or round a pole kept as unit vectors
    with ``north`` (whether each ring encloses the north pole)."""
    lonlat, flag = rings_lonlat(rings, reach)
    special = {i: (rings[i], bool(north[i])) for i in np.flatnonzero(flag).tolist()}
    return Rings(lonlat, special)


def discs(ll: np.ndarray, d, resolution: int, *, labels=str) -> Rings:
    """The offsets by ``d`` (radians, 0 < d < pi/2; one, or one per point) of the points
    ``ll`` (n, 2) lon/lat.

    ``labels(i)`` names point ``i`` in error messages."""
    c = _unit(ll, labels)
    rings = disc_rings(c, d, resolution)
    north = c[:, 2] > np.cos(d)
    return _finish(rings, d, north)


def stadiums(a_ll, b_ll, d, resolution: int, *, labels=str) -> Rings:
    """The offsets by ``d`` (radians, 0 < d < pi/2; one, or one per segment) of the
    segments ``a_ll[i] -> b_ll[i]`` (lon/lat, distinct and not antipodal)."""
    a, b = _unit(a_ll, labels), _unit(b_ll, labels)
    rings = stadium_rings(a, b, d, resolution)
    north = arc_distance(np.array([0.0, 0.0, 1.0]), a, b) < d
    return _finish(rings, d + angle(a, b), north)
