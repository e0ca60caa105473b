"""Distances with units (``500m``, ``127km``, ``0.02rad``, ``1.5deg``) and query points in degrees.

What comes in at the edges, checked once.

Inside gloffset every distance is an angle on the unit sphere (radians). Metres
appear only at the edges, through the ``radius`` keyword (default
:data:`EARTH_RADIUS`, the IUGG mean Earth radius). The rule of every public function: a
distance is a number in the units of ``radius`` or a string with a unit, converted once,
where it comes in (:func:`to_angle`, :func:`offset_angle`; :func:`to_metres` for geodesic
lengths on an ellipsoid), and passed on as an angle. Query points come in as lon/lat
arrays in degrees (:func:`check_lonlat`).
"""

from __future__ import annotations

import math
import re

import numpy as np

from .errors import InvalidDistanceError, InvalidGeometryError

#: IUGG mean Earth radius R1 in metres (Moritz 2000).
EARTH_RADIUS = 6371008.8

_UNITS_TO_METRES = {"m": 1.0, "km": 1000.0, "mi": 1609.344, "nmi": 1852.0, "ft": 0.3048}
_ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}
UNITS = tuple(_UNITS_TO_METRES) + tuple(_ANGLE_UNITS)

_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_PATTERN = re.compile(rf"^\s*({_NUMBER})\s*([A-Za-z]*)\s*$")


def first_not_finite(lon: np.ndarray, lat: np.ndarray) -> int | None:
    """Return the index of the first point whose ``lon`` or ``lat`` is not finite.

    ``lon`` and ``lat`` are flat float arrays of one length; None when every coordinate
    is finite.
    """
    bad = ~(np.isfinite(lon) & np.isfinite(lat))
    return int(np.flatnonzero(bad)[0]) if bad.any() else None


def check_lonlat(lon, lat) -> tuple[np.ndarray, np.ndarray, tuple]:
    """Validate query lon/lat (degrees): flat float64 arrays and their broadcast shape.

    Raises :class:`InvalidGeometryError` for shapes that do not broadcast, NaN or
    infinite coordinates and latitudes outside [-90, 90], naming the first bad point.
    Longitudes are not limited (they wrap).
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
    i = first_not_finite(lon, lat)
    if i is not None:
        raise InvalidGeometryError(
            f"query point {i}: coordinate is not finite ({lon[i]}, {lat[i]})"
        )
    if (np.abs(lat) > 90.0).any():
        i = int(np.flatnonzero(np.abs(lat) > 90.0)[0])
        raise InvalidGeometryError(
            f"query point {i}: latitude {float(lat[i])!r} out of range [-90, 90]"
        )
    return lon, lat, shape


def check_radius(radius: float) -> float:
    """Return ``radius`` as a float, or raise if it is not a positive finite number."""
    try:
        r = float(radius)
    except (TypeError, ValueError):
        raise InvalidDistanceError(f"radius must be a number, got {radius!r}") from None
    if not math.isfinite(r) or r <= 0:
        raise InvalidDistanceError(f"radius must be a positive finite number, got {radius!r}")
    return r


def to_angle(distance: float | str, radius: float) -> float:
    """Convert a distance to an angle in radians: the one conversion of every public function.

    ``distance`` is a number in the units of ``radius`` or a string with a unit
    (``"127km"``, ``"0.02rad"``: :func:`parse_distance`); both give the same angle
    (``to_angle("127km", r) == to_angle(127e3, r)``). A number takes one division by
    ``radius`` (correctly rounded); a string one product by its unit's length and that
    division (``rad``: exact; ``deg``: one product by ``pi/180``).

    Raises :class:`InvalidDistanceError` when ``distance`` is not a finite number (a bool
    is not one) or a readable distance string, or ``radius`` not a positive finite number.
    """
    if isinstance(distance, str):
        return parse_distance(distance, radius)
    r = check_radius(radius)
    if isinstance(distance, (bool, np.bool_)):  # float(True) is 1.0: never meant
        raise InvalidDistanceError(
            f"distance must be a number or a string with a unit (500m, 127km, 0.02rad), "
            f"got {distance!r}"
        )
    try:
        d = float(distance)
    except (TypeError, ValueError):
        raise InvalidDistanceError(
            f"distance must be a number or a string with a unit (500m, 127km, 0.02rad), "
            f"got {distance!r}"
        ) from None
    if not math.isfinite(d):
        raise InvalidDistanceError(f"distance must be finite, got {distance!r}")
    return d / r


def to_metres(distance: float | str) -> float:
    """Return a geodesic distance on an ellipsoid in metres.

    ``distance`` is a number (metres) or a string with a length unit (``"127km"``);
    exact for numbers and metres, one product otherwise.

    Raises :class:`InvalidDistanceError` for an angle (``"0.02rad"``, ``"1.5deg"``: on an
    ellipsoid distances are geodesic lengths), an unreadable string or a number that is not
    finite.
    """
    if isinstance(distance, str) and _read(distance)[1] in _ANGLE_UNITS:
        raise InvalidDistanceError(
            f"distance {distance!r} is an angle, but on an ellipsoid distances are geodesic "
            "lengths: give it in m, km, mi, nmi or ft"
        )
    return parse_length(distance, 1.0)


#: Largest |d| (rad) of a vector offset: the offset of a curve by a quarter of a
#: great circle or more is no longer a curve at distance d on the near side.
VECTOR_LIMIT = math.pi / 2
#: Largest |d| (rad) of a raster (render, tiles, raster offsets): the engine's cap
#: bounds need the reach d + rho of a cell below pi/2.
RASTER_LIMIT = 1.5


def offset_angle(shape, distance, radius, *, limit: float | None = None, what: str = "") -> float:
    """Return the offset distance of an operation as an angle, with the limits that hold for it.

    ``distance`` is a number in the units of ``radius`` or a string with a unit
    (``"127km"``, ``"0.02rad"``), converted by :func:`to_angle`. The messages quote it as
    given, never as the internal angle.

    Raises :class:`InvalidDistanceError` when the distance is not a finite number,
    when ``|d| >= limit`` (``what`` names the operation), and when ``d <= 0`` on an
    input without polygons: lines and points bound no region, so a zero or negative
    distance would leave nothing.
    """
    d = to_angle(distance, radius)
    given = distance.strip() if isinstance(distance, str) else repr(distance)
    if d <= 0.0 and not shape.rings:
        raise InvalidDistanceError(
            f"distance {given} is {'zero' if d == 0 else 'negative'}, but the input has no "
            "polygon: lines and points bound no region, so only a positive distance gives one "
            "(negative distances shrink polygons)"
        )
    if limit is not None and abs(d) >= limit:
        if limit == VECTOR_LIMIT:
            need = "vector offsets need |d| < pi/2 rad (a quarter of a great circle)"
            other = (
                "render(), tiles and contains() take up to 1.5 rad"
                if abs(d) < RASTER_LIMIT
                else "contains() and distance() answer any distance"
            )
        else:
            need = f"{what} needs |d| < {limit:g} rad"
            other = "contains() and distance() answer any distance"
        r = check_radius(radius)
        sphere = "" if r == 1.0 else f" on a sphere of radius {r:.10g}"
        raise InvalidDistanceError(
            f"distance {given} ({abs(d):.4g} rad{sphere}) is too large: {need}; {other}"
        )
    return d


def offset_metres(
    shape, distance, radius: float, *, limit: float | None = None, what: str = ""
) -> float:
    """Return a geodesic offset distance on an ellipsoid in metres (:func:`to_metres`).

    With the checks of :func:`offset_angle` on the angle ``distance / radius``
    (``radius`` in metres: the ellipsoid's radius that bounds the operation's angle).

    Raises :class:`InvalidDistanceError` as :func:`to_metres` and :func:`offset_angle` do.
    """
    m = to_metres(distance)
    offset_angle(shape, distance, radius, limit=limit, what=what)
    return m


def _read(text: str) -> tuple[float, str]:
    """Return the number and the unit (lower case, ``"m"`` for none) of a distance string."""
    m = _PATTERN.match(str(text))
    if not m:
        raise InvalidDistanceError(
            f"cannot read distance {text!r}: expected a number and a unit, e.g. 500m, 127km, "
            f"0.02rad, 1.5deg"
        )
    value, unit = float(m.group(1)), m.group(2).lower() or "m"
    if not math.isfinite(value):
        raise InvalidDistanceError(f"distance must be finite, got {text!r}")
    if unit not in _ANGLE_UNITS and unit not in _UNITS_TO_METRES:
        raise InvalidDistanceError(
            f"unknown distance unit {m.group(2)!r} in {text!r}; use one of {', '.join(UNITS)}"
        )
    return value, unit


def parse_distance(text: str | float, radius: float = EARTH_RADIUS) -> float:
    """Parse a distance such as ``"500m"``, ``"127km"``, ``"0.02rad"`` or ``"1.5deg"``.

    Parameters
    ----------
    text : str or float
        A number followed by a unit among ``m, km, mi, nmi, ft, rad, deg``. A bare
        number is metres.
    radius : float
        Sphere radius in metres, used to turn metres into an angle.

    Returns
    -------
    float
        The distance as an angle on the sphere, in radians (exact for ``rad``;
        one division for metric units; ``deg`` is converted with ``pi/180``).

    Examples
    --------
    >>> round(parse_distance("6371.0088km"), 12)  # one Earth radius
    1.0
    >>> parse_distance("0.02rad")
    0.02
    """
    if not isinstance(text, str):
        return to_angle(text, radius)
    value, unit = _read(text)
    if unit in _ANGLE_UNITS:
        return value * _ANGLE_UNITS[unit]
    return to_angle(value * _UNITS_TO_METRES[unit], radius)


def parse_length(text: str | float, radius: float = EARTH_RADIUS) -> float:
    """Convert a distance such as ``"127km"`` to a length in the units of ``radius``.

    Metres for the default radius and for every metric unit.

    Exact for metric units (one product by the unit's length in metres) and for numbers
    (returned as they are); angles are multiplied by ``radius``.

    Examples
    --------
    >>> parse_length("127km")
    127000.0
    >>> parse_length("0.5rad", radius=2.0)
    1.0
    """
    if not isinstance(text, str):
        to_angle(text, radius)  # checks both
        return float(text)
    value, unit = _read(text)
    if unit in _ANGLE_UNITS:
        return value * _ANGLE_UNITS[unit] * check_radius(radius)
    return value * _UNITS_TO_METRES[unit]


def distance_properties(distance, radius: float = 1.0) -> dict:
    """Return the properties that name the distance of an output feature, the same everywhere.

    ``distance_m`` (the length in metres, or in the units of ``radius``) and ``distance``
    (the distance as given: ``"127km"``, or the number).

    Examples
    --------
    >>> distance_properties("127km", 6371008.8)
    {'distance_m': 127000.0, 'distance': '127km'}
    """
    given = distance.strip() if isinstance(distance, str) else distance
    return {"distance_m": parse_length(distance, radius), "distance": given}
