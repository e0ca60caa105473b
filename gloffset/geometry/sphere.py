"""Unit-vector maths on the sphere, vectorised over numpy arrays (float64).

Conventions: points are unit vectors in the Earth frame (x towards 0N 0E, y towards
0N 90E, z towards the north pole); lon/lat are in degrees; angles in radians. Every
function broadcasts over leading dimensions; the last axis has length 3.

Accuracy: the functions here are written so that their absolute error is a few
units in the last place of an angle of order 1, i.e. below 1e-15 rad, for unit
inputs, including nearly equal and nearly antipodal points, except where a
docstring says otherwise. ``tests/test_sphere.py`` checks these bounds against
extended-precision (mpmath) values.
"""

from __future__ import annotations

import numpy as np

#: Degrees: a longitude within this of +-180, or a latitude within this of +-90, lies on
#: the antimeridian or at a pole (Natural Earth writes 180.00000000000006).
SEAM_EPS_DEG = 1e-9

__all__ = [
    "SEAM_EPS_DEG",
    "lonlat_to_xyz",
    "xyz_to_lonlat",
    "normalize",
    "dot",
    "chord2_between",
    "pair_dots",
    "column_dots",
    "pair_chord2",
    "pair_equal",
    "cross",
    "norm",
    "arc_foot",
    "nearest_on_arc",
    "robust_cross",
    "angle",
    "slerp",
    "rotate",
    "arc_distance",
    "arcs_cross",
    "crossing_rule",
    "orient",
]


def lonlat_to_xyz(lon, lat) -> np.ndarray:
    """Unit vectors for longitudes and latitudes in degrees.

    Accuracy: each component within 2 ulp of the exact value of the rounded
    input angles. Longitudes within :data:`SEAM_EPS_DEG` of +-180 and latitudes
    within it of +-90 are snapped to the exact antimeridian and pole.

    Examples
    --------
    >>> lonlat_to_xyz(90.0, 0.0).round(15)
    array([0., 1., 0.])
    """
    lon = np.asarray(lon, dtype=np.float64)
    lat = np.asarray(lat, dtype=np.float64)
    rlon, rlat = np.radians(lon), np.radians(lat)
    clat = np.cos(rlat)
    v = np.stack([clat * np.cos(rlon), clat * np.sin(rlon), np.sin(rlat)], axis=-1)
    # Snap the seams of lon/lat data to exact vectors: a vertex on +-180 deg has y == 0
    # exactly, and every vertex at +-90 deg latitude is the same pole, so the two sides
    # of an antimeridian cut and the edges along a pole give bit-identical points.
    on_am = np.abs(np.abs(lon) - 180.0) <= SEAM_EPS_DEG
    if on_am.any():
        v[..., 1] = np.where(on_am, 0.0, v[..., 1])
        v[..., 0] = np.where(on_am, -clat, v[..., 0])
    pole = np.abs(np.abs(lat) - 90.0) <= SEAM_EPS_DEG
    if pole.any():
        v[..., 0] = np.where(pole, 0.0, v[..., 0])
        v[..., 1] = np.where(pole, 0.0, v[..., 1])
        v[..., 2] = np.where(pole, np.sign(lat), v[..., 2])
    return v


def xyz_to_lonlat(v) -> tuple[np.ndarray, np.ndarray]:
    """Longitudes in (-180, 180] and latitudes in [-90, 90], in degrees, of vectors ``v``.

    ``v`` need not be normalised. Uses ``atan2`` for both angles, so the latitude is
    accurate to 1 ulp near the poles too. The longitude of a pole is 0 (or +-180
    from the sign of a zero ``y``).
    """
    v = np.asarray(v, dtype=np.float64)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    lon = np.degrees(np.arctan2(y, x))
    lat = np.degrees(np.arctan2(z, np.hypot(x, y)))
    return lon, lat


def normalize(v) -> np.ndarray:
    """``v / |v|`` along the last axis (zero vectors stay zero)."""
    v = np.asarray(v, dtype=np.float64)
    n = norm(v)[..., None]
    return np.divide(v, n, out=np.zeros_like(v), where=n > 0)


def dot(u, v) -> np.ndarray:
    """Dot products along the last axis (length 3), written out term by term.

    Much faster than ``np.sum(u * v, axis=-1)`` on (n, 3) arrays, and the same bits
    for the same inputs wherever they sit in an array (sign tests that must agree
    between two computations rely on that).
    """
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    return u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1] + u[..., 2] * v[..., 2]


def chord2_between(p, q) -> np.ndarray:
    """Squared chords ``|p - q|^2`` between points ``p`` and ``q`` (last axis length 3,
    broadcast together): the differences, then :func:`dot`'s sum term by term, so the
    same bits wherever the points sit. Relative error a few ulp beyond the rounding of
    the differences; for the squared chord of an angle see :func:`gloffset.geometry.caps.chord2`.
    """
    d = np.asarray(p, dtype=np.float64) - np.asarray(q, dtype=np.float64)
    return dot(d, d)


def einsum_dot(u, v) -> np.ndarray:
    """Dot products along the last axis (length 3) with the bits of
    ``np.einsum("ij,ij->i", u, v)``: its sum ``(x0 y0 + x2 y2) + x1 y1``, plus 0 (einsum's
    sum starts from +0, so products that are all -0 sum to +0). Rows of (3, k) arrays
    are taken as ``einsum_dot(u.T, v.T)`` (views, no copies)."""
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    return (u[..., 0] * v[..., 0] + u[..., 2] * v[..., 2]) + u[..., 1] * v[..., 1] + 0.0


def pair_dots(u, ui, v, vi) -> np.ndarray:
    """``u[ui] . v[vi]`` for index arrays ``ui``, ``vi`` into (n, 3) arrays: the values
    of ``np.einsum("ij,ij->i", u[ui], v[vi])``, whose sum is ``(x0 y0 + x2 y2) + x1 y1``
    (the same bits but for the sign of a zero: see :func:`einsum_dot`), from gathers of
    single coordinates (no (k, 3) copies: several times faster for millions of pairs)."""
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    return column_dots([u[:, k] for k in range(3)], [v[:, k] for k in range(3)], ui, vi)


def column_dots(u, v, ui=None, vi=None) -> np.ndarray:
    """:func:`pair_dots` of points given as coordinate columns ``u``, ``v`` (three 1-d
    arrays each), gathered at ``ui``, ``vi`` (or taken as they are where None): the same
    sum, ``(x0 y0 + x2 y2) + x1 y1``, so the same bits. Contiguous columns gather several
    times faster than the columns of (n, 3) arrays."""

    def at(x, i):
        if i is None:
            return x
        return x.take(i) if getattr(i, "dtype", None) is not None and i.dtype.kind in "iu" else x[i]

    out = at(u[0], ui) * at(v[0], vi)
    out += at(u[2], ui) * at(v[2], vi)
    out += at(u[1], ui) * at(v[1], vi)
    return out


def pair_chord2(v, i, j) -> np.ndarray:
    """``chord2_between(v[i], v[j])`` (the same bits: :func:`dot`'s sum of the squared
    differences) for index arrays ``i``, ``j`` into an (n, 3) array, from gathers of
    single coordinates (no (k, 3) copies)."""
    v = np.asarray(v, dtype=np.float64)
    d0 = v[:, 0][i] - v[:, 0][j]
    d1 = v[:, 1][i] - v[:, 1][j]
    d2 = v[:, 2][i] - v[:, 2][j]
    return d0 * d0 + d1 * d1 + d2 * d2


def pair_equal(v, i, j) -> np.ndarray:
    """``(v[i] == v[j]).all(axis=1)`` for index arrays ``i``, ``j`` into an (n, 3) array
    (``-0.0`` equal to ``0.0``), coordinate by coordinate."""
    v = np.asarray(v)
    out = v[:, 0][i] == v[:, 0][j]
    out &= v[:, 1][i] == v[:, 1][j]
    out &= v[:, 2][i] == v[:, 2][j]
    return out


def cross(u, v) -> np.ndarray:
    """Cross products along the last axis, written out (as :func:`numpy.cross`, faster)."""
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    return np.stack(
        [
            u[..., 1] * v[..., 2] - u[..., 2] * v[..., 1],
            u[..., 2] * v[..., 0] - u[..., 0] * v[..., 2],
            u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0],
        ],
        axis=-1,
    )


def norm(v) -> np.ndarray:
    """Euclidean lengths along the last axis."""
    return np.sqrt(dot(v, v))


def robust_cross(a, b) -> np.ndarray:
    """``2 (a x b)`` computed as ``(b + a) x (b - a)``.

    For nearly equal unit vectors this keeps the full relative accuracy of the
    direction (the plain cross product loses it to cancellation), as S2's
    ``RobustCrossProd`` does. Only the direction is meant to be used.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return cross(b + a, b - a)


def angle(a, b) -> np.ndarray:
    """Angle between unit vectors ``a`` and ``b`` in radians, in [0, pi].

    Computed as ``2 atan2(|a - b|, |a + b|)``: absolute error below 1e-15 rad for
    every angle, including 0 and pi (``acos`` of a dot product loses everything
    below ~1e-8 rad).
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return 2.0 * np.arctan2(norm(a - b), norm(a + b))


def slerp(a, b, t, theta=None) -> np.ndarray:
    """Spherical linear interpolation from ``a`` (t=0) to ``b`` (t=1) along the short arc.

    ``t`` broadcasts against the leading dimensions of ``a`` and ``b`` (use
    ``t[..., None]`` shapes as needed). Undefined for antipodal ``a``, ``b``.
    Points lie on the unit sphere to 1 ulp and on the arc to 1e-15 rad. ``theta``: the
    angle ``angle(a, b)`` where the caller has it (the same bits).
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)[..., None]
    theta = (angle(a, b) if theta is None else np.asarray(theta, dtype=np.float64))[..., None]
    s = np.sin(theta)
    small = s < 1e-300
    s_safe = np.where(small, 1.0, s)
    wa = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / s_safe)
    wb = np.where(small, t, np.sin(t * theta) / s_safe)
    return normalize(wa * a + wb * b)


def rotate(v, axis, theta) -> np.ndarray:
    """Rotate vectors ``v`` about unit ``axis`` by ``theta`` radians (right-hand rule).

    Rodrigues' formula; exact to a few ulp.
    """
    v = np.asarray(v, dtype=np.float64)
    axis = np.asarray(axis, dtype=np.float64)
    theta = np.asarray(theta, dtype=np.float64)[..., None]
    c, s = np.cos(theta), np.sin(theta)
    kdotv = dot(axis, v)[..., None]
    return v * c + cross(axis, v) * s + axis * kdotv * (1.0 - c)


def orient(a, b, c) -> np.ndarray:
    """Triple product ``a . (b x c)``: > 0 when ``c`` lies to the left of the arc a -> b."""
    return dot(np.asarray(a, dtype=np.float64), cross(b, c))


def arc_distance(p, a, b, n=None) -> np.ndarray:
    """Great-circle distance (radians) from points ``p`` to the short arcs ``a -> b``.

    Parameters
    ----------
    p, a, b : array_like (..., 3)
        Unit vectors; they broadcast against each other. ``a == b`` is a point.
    n : array_like (..., 3), optional
        Unit normals ``normalize(a x b)`` if the caller has them (saves work).

    Notes
    -----
    When the foot of ``p`` on the great circle of the arc falls between ``a`` and
    ``b`` the distance is ``atan2(|p.n|, |p - (p.n) n|)``, otherwise the angle to the
    nearer endpoint. Absolute error below 1e-15 rad for arcs longer than 1e-8 rad,
    and below ``1e-16 / length`` times the distance along the arc for shorter ones.
    Arcs must be shorter than pi (consecutive antipodal points are rejected on input).
    """
    p = np.asarray(p, dtype=np.float64)
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if n is None:
        n = normalize(robust_cross(a, b))
    n = np.asarray(n, dtype=np.float64)
    inside, pn, foot = arc_foot(p, a, b, n)
    d_line = np.arctan2(np.abs(pn), norm(foot))
    d_ends = np.minimum(angle(p, a), angle(p, b))
    return np.where(inside, d_line, d_ends)


def arc_foot(p, a, b, n):
    """``(inside, p.n, foot)``: whether the foot of ``p`` on the great circle of the arc
    ``a -> b`` (unit normal ``n``, zero for a point) falls on the arc, as
    :func:`arc_distance` decides it, ``p.n`` and the foot ``p - (p.n) n`` (not
    normalised)."""
    pn = dot(p, n)
    inside = (dot(p, cross(n, a)) >= 0.0) & (dot(p, cross(b, n)) >= 0.0) & (dot(n, n) > 0.5)
    return inside, pn, p - pn[..., None] * n


def nearest_on_arc(p, a, b, n) -> np.ndarray:
    """The point of the arc ``a -> b`` (unit normal ``n``) nearest to ``p``: the foot on
    its great circle, normalised, where :func:`arc_distance` takes it, else the nearer
    end (the one :func:`arc_distance` measures), each within a few 1e-16."""
    inside, _, foot = arc_foot(p, a, b, n)
    size = norm(foot)
    inside &= size > 0
    end = np.where((angle(p, a) <= angle(p, b))[..., None], a, b)
    return np.where(inside[..., None], foot / np.where(size > 0, size, 1.0)[..., None], end)


def arcs_cross(p, q, a, b, n=None) -> np.ndarray:
    """Whether the short arc ``p -> q`` crosses the short arc ``a -> b``.

    ``n``, optional: the arcs' normals ``normalize(robust_cross(a, b))`` if the caller
    has them (saves work; only the signs of ``n.p`` and ``n.q`` are used).

    Uses the half-open rule (a point exactly on a great circle counts as being on
    its left), so that when ``p -> q`` passes exactly through a vertex shared by two
    consecutive arcs it is counted once. Summing the result over the arcs of a
    closed ring therefore gives the right crossing parity. The answer is exact
    except when ``p`` or ``q`` lies within ~1e-15 rad of the great circle of ``a -> b``
    and of the arc itself.
    """
    p, q, a, b = (np.asarray(v, dtype=np.float64) for v in (p, q, a, b))
    pq = cross(p, q)
    sa = dot(pq, a) >= 0.0
    sb = dot(pq, b) >= 0.0
    ab = robust_cross(a, b) if n is None else np.asarray(n)  # accurate also for short edges
    sp = dot(ab, p) >= 0.0
    sq = dot(ab, q) >= 0.0
    return crossing_rule(sa, sb, sp, sq)


def crossing_rule(sa, sb, sp, sq):
    """Whether arc ``p -> q`` crosses arc ``a -> b``, from the four side tests.

    ``sa``, ``sb``: ``a``, ``b`` lie on the left of (or on) the great circle ``p -> q``
    (``(p x q) . a >= 0``); ``sp``, ``sq``: ``p``, ``q`` lie on the left of (or on)
    ``a -> b``. The arcs cross when both pairs straddle the other's great circle and
    the crossing is not the antipodal one. This is the half-open rule of
    :func:`arcs_cross`; every crossing test in gloffset goes through it.
    """
    return (sa != sb) & (sp != sq) & (sp == sb)
