"""The box of the region at a distance, for the TileJSON ``bounds`` of ``gloffset serve``.

A client that honours a TileJSON's ``bounds`` (MapLibre does) asks for no tile outside
them, so they must hold the whole region at the requested distance, not only the input:
:func:`region_bounds` is the input's box grown by ``d``.
"""

from __future__ import annotations

import math

import numpy as np

from ..edges import CurveArcs, points_inside

__all__ = ["region_bounds", "WORLD", "MERCATOR_LAT"]

#: the latitude limit of web mercator, degrees (rounded up)
MERCATOR_LAT = 85.051129
#: west, south, east, north of the whole web-mercator world
WORLD = (-180.0, -MERCATOR_LAT, 180.0, MERCATOR_LAT)
#: boxes kept per shape (one per distance asked for)
_KEPT = 256
_POLES = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])


def region_bounds(
    shape, d: float, lat_limit: float = MERCATOR_LAT
) -> tuple[float, float, float, float]:
    """West, south, east, north (degrees) of a box that holds the region within ``d``
    (radians; ``d < 0``: inside the polygons and farther than ``|d|`` from their
    boundary) of ``shape``.

    Each boundary arc (seams left out) spans the latitudes of its ends, and of the
    highest or lowest point of its great circle where that lies on it, and the
    longitudes between its ends (monotonic along an arc that misses the poles). A point
    within ``d`` of a point at latitude ``phi`` differs from it by at most ``d`` in
    latitude and ``asin(sin d / cos phi)`` in longitude, so each arc's box grown so
    (by ``max(d, 0)``: the region at ``d < 0`` lies inside the polygons) holds the points
    within ``d`` of it. A polygon's inside, unless it holds a pole, lies within its
    boundary's box; a pole inside a polygon, or within ``d`` of an arc, is reached. The
    box is the whole range of longitudes where a pole is reached or any arc's box
    crosses the antimeridian (a box with ``west > east`` is not read by every client),
    latitudes clipped to ``+-lat_limit`` (default web mercator's; 90 for the tiles of
    other TileMatrixSets).

    Accuracy: the box holds the region. Every angle is widened by 1e-9 rad (far more
    than its rounding) and the degrees rounded outward to 1e-6; in latitude the box is
    the region's own within that, in longitude it grows each arc by the longitude reach
    at its highest latitude (at most that of its ends, and of its great circle's
    extreme point where it lies on the arc).

    Kept on the shape per distance (one ``numpy`` pass over the arcs).

    Examples
    --------
    >>> import gloffset
    >>> sq = gloffset.read({"type": "Polygon",
    ...     "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]})
    >>> region_bounds(sq, 0.0)
    (-1e-06, -1e-06, 1.000001, 1.000039)
    >>> w, s, e, n = region_bounds(sq, 100e3 / 6371008.8)
    >>> -0.91 < w < -0.89 and -0.91 < s < -0.89 and 1.89 < e < 1.91 and 1.89 < n < 1.91
    True
    """
    key = max(float(d), 0.0)
    w, s, e, n = shape.derived.serve_bounds.once(key, lambda: _grown_box(shape, key), keep=_KEPT)
    return w, min(max(s, -lat_limit), lat_limit), e, max(min(n, lat_limit), -lat_limit)


#: the widening of every angle of :func:`region_bounds`, radians
_PAD = 1e-9


def _grown_box(shape, d: float) -> tuple[float, float, float, float]:
    arcs = CurveArcs.from_shape(shape)
    bd = arcs.boundary
    if not bd.any():
        return (-180.0, -90.0, 180.0, 90.0)
    a, b, nrm = arcs.a[bd], arcs.b[bd], arcs.n[bd]
    lune1, lune2 = (v[bd] for v in arcs.lunes)
    lat_a, lat_b = (np.arcsin(np.clip(p[:, 2], -1.0, 1.0)) for p in (a, b))
    hi, lo = np.maximum(lat_a, lat_b), np.minimum(lat_a, lat_b)
    # the highest point of each great circle, normalize(z - n_z n), and the lowest (its
    # antipode): where one lies on its arc (inclusively), the arc reaches its latitude
    top = np.hypot(nrm[:, 0], nrm[:, 1])  # cos of the great circle's top latitude
    v = np.c_[-nrm[:, 2:3] * nrm[:, :2], 1.0 - nrm[:, 2:3] ** 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        v = v / top[:, None]
    line = top > 0  # an arc of positive length (points have no normal)
    on_top = line & ((v * lune1).sum(1) >= -1e-12) & ((v * lune2).sum(1) >= -1e-12)
    on_bottom = line & ((v * lune1).sum(1) <= 1e-12) & ((v * lune2).sum(1) <= 1e-12)
    peak = np.arctan2(top, np.abs(nrm[:, 2]))
    hi = np.where(on_top, np.maximum(hi, peak), hi) + (d + _PAD)
    lo = np.where(on_bottom, np.minimum(lo, -peak), lo) - (d + _PAD)
    north = bool((hi >= 0.5 * math.pi).any())
    south = bool((lo <= -0.5 * math.pi).any())
    if arcs.n_groups:
        pole_in = points_inside(shape, _POLES)
        north, south = north or bool(pole_in[0]), south or bool(pole_in[1])
    n = 90.0 if north else math.degrees(float(hi.max()))
    s = -90.0 if south else math.degrees(float(lo.min()))
    w, e = -180.0, 180.0
    if not (north or south):
        # every arc's box misses the poles: |phi| + d < pi/2, so sin d < cos phi
        phi = np.maximum(np.abs(hi), np.abs(lo)) - d  # the arc's own highest |latitude|
        reach = np.arcsin(np.minimum(math.sin(d) / np.cos(phi), 1.0)) + _PAD
        m = a + b
        lon_m = np.arctan2(m[:, 1], m[:, 0])
        da, db = (_wrap(np.arctan2(p[:, 1], p[:, 0]) - lon_m) for p in (a, b))
        west = lon_m + np.minimum(np.minimum(da, db), 0.0) - reach
        east = lon_m + np.maximum(np.maximum(da, db), 0.0) + reach
        if west.min() > -math.pi and east.max() < math.pi:  # else it wraps: the whole range
            w, e = math.degrees(float(west.min())), math.degrees(float(east.max()))
    s = max(math.floor(s * 1e6) / 1e6, -90.0)
    n = min(math.ceil(n * 1e6) / 1e6, 90.0)
    return max(math.floor(w * 1e6) / 1e6, -180.0), s, min(math.ceil(e * 1e6) / 1e6, 180.0), n


def _wrap(x: np.ndarray) -> np.ndarray:
    """Angles wrapped into (-pi, pi]."""
    return np.pi - np.mod(np.pi - x, 2.0 * np.pi)
