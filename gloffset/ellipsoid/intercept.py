"""The geodesic intercept: the shortest geodesic from a point to a geodesic edge.

Given a point ``P`` and an edge ``A -> B`` (the shortest geodesic between them, as
:meth:`geographiclib.geodesic.Geodesic.InverseLine` gives it, of length ``L``), find
the point ``X(s)``, ``0 <= s <= L``, nearest to ``P``. Inverse problems only, in the
manner of Baselga and Martinez-Llario (2018):

1. start at ``s0`` (the caller's estimate, e.g. the foot on the conformal sphere);
2. at ``X(s)``, solve the inverse problem ``X -> P``: distance ``D`` and the angle
   ``alpha`` between the edge's azimuth at ``X`` and the azimuth of ``P`` seen from
   ``X``; on a sphere of radius ``a`` the foot of ``P`` would lie
   ``a atan2(sin(D/a) cos(alpha), cos(D/a))`` further along, so step by that, clamped
   to ``[0, L]``;
3. stop when the step is below :data:`TOL`.

**Error bound.** The value returned is the geodesic distance from ``P`` to a point of
the edge (geographiclib's inverse problem, accurate to 15 nm), so it is never below
the true distance by more than 15 nm. It exceeds it by at most ``|s - s*|`` (``D`` is
1-Lipschitz in ``s``) where ``s*`` is the true foot; with the contraction below 1/2
that is at most the last step, below :data:`TOL` (1e-7 m). So the result is within
0.2 um of the true distance (tested against brute force on edges densified to
sub-millimetre spacing, near the poles, across the antimeridian and for points on
the edges). If the iteration has not converged in :data:`MAX_STEPS` steps (never
seen; possible for points nearly antipodal to the edge) a golden-section search over
``[0, L]`` on the same inverse problems finishes it. The derivation in full:
``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

__all__ = ["TOL", "MAX_STEPS", "edge_distance", "edge_distances"]

#: Stop when a step along the edge is shorter than this (metres).
TOL = 1e-7
#: Steps of the iteration before the golden-section fallback.
MAX_STEPS = 40


def _masks():
    from geographiclib.geodesic import Geodesic

    return (
        Geodesic.LATITUDE | Geodesic.LONGITUDE | Geodesic.AZIMUTH | Geodesic.DISTANCE_IN,
        Geodesic.DISTANCE | Geodesic.AZIMUTH,
    )


def edge_distance(geod, lat, lon, a, b, s0: float | None = None) -> tuple[float, float, float]:
    """Distance (metres) from ``(lat, lon)`` (degrees) to the geodesic edge ``a -> b``
    (each a ``(lat, lon)`` pair), on geographiclib's ``geod``.

    ``s0`` is a start along the edge as a fraction of its length (default 0.5).

    Returns
    -------
    (distance, s, side) : tuple of float
        ``s`` is the nearest point's position along the edge (metres from ``a``), and
        ``side`` the sine of the angle from the direction of the point to the edge's
        direction at the nearest point (azimuths clockwise): positive when the point
        lies to the left of the edge, negative to the right, about 0 on it (and not
        meaningful at an end).
    """
    line_mask, inv_mask = _masks()
    line = geod.InverseLine(a[0], a[1], b[0], b[1], line_mask)
    length = line.s13
    if length == 0.0:
        inv = geod.Inverse(a[0], a[1], lat, lon, inv_mask)
        return inv["s12"], 0.0, 0.0
    radius = geod.a

    def probe(s):
        pos = line.Position(s, line_mask)
        inv = geod.Inverse(pos["lat2"], pos["lon2"], lat, lon, inv_mask)
        return inv["s12"], math.radians(inv["azi1"] - pos["azi2"])

    s = min(max(0.5 if s0 is None else float(s0), 0.0), 1.0) * length
    converged = False
    for _ in range(MAX_STEPS):
        dist, alpha = probe(s)
        step = radius * math.atan2(
            math.sin(dist / radius) * math.cos(alpha), math.cos(dist / radius)
        )
        nxt = min(max(s + step, 0.0), length)
        if abs(nxt - s) < TOL:
            converged = True
            break
        s = nxt
    if not converged:
        s = _golden(lambda x: probe(x)[0], 0.0, length)
    dist, alpha = probe(s)
    best = (dist, s, -math.sin(alpha))
    for end in (0.0, length):
        d_end = probe(end)[0]
        if d_end < best[0]:
            best = (d_end, end, 0.0)
    return best


def edge_distances(ell, lat, lon, a, b, s0) -> np.ndarray:
    """:func:`edge_distance` of many (point, edge) pairs at once: distances (metres) from
    ``lat``, ``lon`` (degrees, arrays) to the geodesic edges ``a -> b`` ((n, 2) arrays
    of ``(lat, lon)``), started at fractions ``s0``.

    The same iteration, error bound and ends, vectorised over the pairs on PROJ's
    geodesic routines (the C version of geographiclib, through ``pyproj.Geod``, whose
    direct and inverse problems are as accurate): a point of the edge at ``s`` is the
    direct problem from ``a`` along the edge's azimuth, the edge's direction there the
    reverse of its back azimuth. Without pyproj, one pair at a time on geographiclib
    (:func:`edge_distance`). Pairs that have not converged in :data:`MAX_STEPS` steps
    are finished one at a time as there.
    """
    lat, lon = np.asarray(lat, dtype=np.float64), np.asarray(lon, dtype=np.float64)
    a, b = (
        np.asarray(a, dtype=np.float64).reshape(-1, 2),
        np.asarray(b, dtype=np.float64).reshape(-1, 2),
    )
    s0 = np.broadcast_to(np.asarray(s0, dtype=np.float64), lat.shape)
    n = len(lat)
    out = np.empty(n)
    geod = _proj_geod(ell)
    if geod is None or n == 0:
        for k in range(n):
            out[k] = edge_distance(ell.geodesic, lat[k], lon[k], a[k], b[k], s0[k])[0]
        return out
    az, _, length = geod.inv(a[:, 1], a[:, 0], b[:, 1], b[:, 0])
    az, length = np.asarray(az), np.asarray(length)
    radius = ell.a

    def probe(idx, s):
        xlon, xlat, back = geod.fwd(a[idx, 1], a[idx, 0], az[idx], s)
        azi1, _, dist = geod.inv(xlon, xlat, lon[idx], lat[idx])
        return np.asarray(dist), np.radians(np.asarray(azi1) - (np.asarray(back) + 180.0))

    s = np.clip(s0, 0.0, 1.0) * length
    act = np.flatnonzero(length > 0.0)
    for _ in range(MAX_STEPS):
        if len(act) == 0:
            break
        dist, alpha = probe(act, s[act])
        step = radius * np.arctan2(np.sin(dist / radius) * np.cos(alpha), np.cos(dist / radius))
        nxt = np.clip(s[act] + step, 0.0, length[act])
        done = np.abs(nxt - s[act]) < TOL
        s[act[~done]] = nxt[~done]
        act = act[~done]
    for k in act.tolist():  # not converged: one at a time, with the golden-section fallback
        s[k] = edge_distance(ell.geodesic, lat[k], lon[k], a[k], b[k], s0[k])[1]
    every = np.arange(n)
    out = probe(every, s)[0]
    for end in (a, b):
        d_end = np.asarray(geod.inv(end[:, 1], end[:, 0], lon, lat)[2])
        np.minimum(out, d_end, out=out)
    return out


def geodesic_midpoints(ell, lon1, lat1, lon2, lat2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The midpoints (geodetic lon, lat in degrees) and lengths (metres) of the shortest
    geodesics between pairs of points: pyproj's C geodesics, vectorised, or
    geographiclib pair by pair without pyproj."""
    lon1, lat1, lon2, lat2 = (np.asarray(x, dtype=np.float64) for x in (lon1, lat1, lon2, lat2))
    geod = _proj_geod(ell)
    if geod is not None:
        az, _, length = geod.inv(lon1, lat1, lon2, lat2)
        lon, lat, _ = geod.fwd(lon1, lat1, az, 0.5 * np.asarray(length))
        return np.asarray(lon), np.asarray(lat), np.asarray(length)
    out = np.empty((3, len(lon1)))  # without pyproj
    for i in range(len(lon1)):
        line = ell.geodesic.InverseLine(lat1[i], lon1[i], lat2[i], lon2[i])
        pos = line.Position(0.5 * line.s13)
        out[:, i] = pos["lon2"], pos["lat2"], line.s13
    return out[0], out[1], out[2]


#: whether the one warning that pyproj is missing has been given in this process
_warned_no_pyproj = False


def _proj_geod(ell):
    """``pyproj.Geod`` of the ellipsoid (made once per ellipsoid), or None without
    pyproj (a dependency of gloffset, but an install may lack it): then one warning per
    process says what the fallback costs and what to install."""
    global _warned_no_pyproj
    try:
        from pyproj import Geod
    except ImportError:
        if not _warned_no_pyproj:
            _warned_no_pyproj = True
            warnings.warn(
                "pyproj is not installed: geodesics on the ellipsoid run one at a time on "
                "geographiclib, 10-25x slower (an ellipsoid offset that takes 2 s with "
                "pyproj can take a minute); pip install 'pyproj>=3.4'",
                UserWarning,
                stacklevel=2,
            )
        return None
    cache = ell.__dict__.get("_proj_geod")
    if cache is None:
        cache = Geod(a=ell.a, f=ell.f)
        object.__setattr__(ell, "_proj_geod", cache)
    return cache


def _golden(f, lo: float, hi: float) -> float:
    """The minimiser of a unimodal ``f`` on ``[lo, hi]`` to :data:`TOL`."""
    g = (math.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(x1), f(x2)
    while hi - lo > TOL:
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = f(x1)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = f(x2)
    return 0.5 * (lo + hi)
