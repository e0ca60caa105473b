"""Coordinate reference systems of input files: everything becomes lon/lat (EPSG:4326).

gloffset works in longitude and latitude on the sphere. A vector file in another CRS
(a projected one such as EPSG:3857 or a UTM zone, or a geographic CRS on another
datum) is transformed to lon/lat with pyproj (the ``files`` extra); a CRS that cannot
be transformed (geocentric, vertical, engineering, unknown to PROJ) is refused with a
message naming it. A file without a CRS is taken as lon/lat, as GeoJSON is.

An edge of a projected file is the straight line between its vertices in the
projection, not the great circle between them: :func:`densify` adds points along it
(in the projection, before the transform) until the great circle between consecutive
points stays within a tolerance of it. Edges in lon/lat (any geographic CRS) are
great circles, as gloffset takes every lon/lat edge, and get no points.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputFormatError
from ..geometry.sphere import arc_distance, lonlat_to_xyz
from ..units import EARTH_RADIUS, first_not_finite, parse_distance

__all__ = [
    "DENSIFY_MIN",
    "DENSIFY_TOLERANCE",
    "densify",
    "densify_tolerance",
    "is_lonlat",
    "to_lonlat",
]

#: The default tolerance of projected edges, metres: each edge is followed to within
#: this, or to a hundredth of its length where that is smaller (never below
#: :data:`_FLOOR`).
DENSIFY_TOLERANCE = 1.0
_FLOOR = 1e-6  # metres: below the transforms' own rounding
#: The smallest tolerance ``densify=`` takes, metres: 1 mm. Each halving of the tolerance
#: gives about 1.4 times the points (Mexico in UTM 14N: 7,391 points at 1 m, 35,205 at
#: 1 mm, in 0.6 s); a nanometre would ask for points past the transforms' own rounding
#: and run out of memory.
DENSIFY_MIN = 1e-3
_MAX_DEPTH = 40  # halvings of one edge
_SAMPLES = np.array([0.25, 0.5, 0.75])  # where a piece is tested; its middle splits it

#: Names of plain WGS84 lon/lat, read as they are (no pyproj needed).
_LONLAT = {
    "EPSG:4326",
    "OGC:CRS84",
    "CRS84",
    "WGS84",
    "EPSG:4979",
    "URN:OGC:DEF:CRS:OGC:1.3:CRS84",
    "URN:OGC:DEF:CRS:EPSG::4326",
}


def _pyproj(where: str):
    try:
        import pyproj
    except ImportError:
        raise InputFormatError(
            f"{where}: transforming its coordinates to lon/lat needs pyproj: "
            "pip install 'gloffset[files]'"
        ) from None
    return pyproj


def _parse(crs, where: str):
    pyproj = _pyproj(where)
    try:
        return pyproj.CRS.from_user_input(crs)
    except pyproj.exceptions.CRSError as exc:
        raise InputFormatError(f"{where}: unsupported CRS {_name(crs)}: {exc}") from None


def _name(crs) -> str:
    text = str(crs)
    return repr(text if len(text) <= 60 else text[:57] + "...")


def is_lonlat(crs, where: str = "input") -> bool:
    """Whether ``crs`` (a string, WKT, PROJJSON dict, pyproj CRS or None) is WGS84 lon/lat
    already: None (no CRS, as in GeoJSON), EPSG:4326 or OGC:CRS84."""
    if crs is None:
        return True
    if isinstance(crs, str) and crs.strip().upper() in _LONLAT:
        return True
    parsed = _parse(crs, where)
    return any(parsed.equals(c, ignore_axis_order=True) for c in ("EPSG:4326", "OGC:CRS84"))


def to_lonlat(crs, where: str = "input"):
    """A function ``(x, y) -> (lon, lat)`` of arrays, from ``crs`` to lon/lat degrees.

    Returns None when ``crs`` is lon/lat already (:func:`is_lonlat`). Raises
    :class:`~gloffset.errors.InputFormatError` when pyproj is missing or the CRS cannot
    be transformed to lon/lat.
    """
    if is_lonlat(crs, where):
        return None
    pyproj = _pyproj(where)
    src = _parse(crs, where)
    if not (src.is_projected or src.is_geographic) or src.is_geocentric:
        kind = src.type_name or "this kind of"
        raise InputFormatError(
            f"{where}: CRS {src.name!r} ({kind}) cannot be transformed to lon/lat; "
            "give a geographic or projected CRS"
        )
    try:
        tr = pyproj.Transformer.from_crs(src, "OGC:CRS84", always_xy=True)
    except pyproj.exceptions.ProjError as exc:
        raise InputFormatError(
            f"{where}: no transformation from CRS {src.name!r} to lon/lat: {exc}"
        ) from None

    def transform(x: np.ndarray, y: np.ndarray):
        lon, lat = tr.transform(np.asarray(x, np.float64), np.asarray(y, np.float64))
        lon, lat = np.asarray(lon, np.float64), np.asarray(lat, np.float64)
        i = first_not_finite(lon, lat)
        if i is not None:
            raise InputFormatError(
                f"{where}: the point ({float(np.ravel(x)[i])!r}, {float(np.ravel(y)[i])!r}) "
                f"of CRS {src.name!r} has no lon/lat (outside the projection's domain)"
            )
        # a projection's round trip can step a hair over the antimeridian or a pole
        return np.clip(lon, -180.0, 180.0), np.clip(lat, -90.0, 90.0)

    # what the readers tell of the input (attributes of the function, which mypy does
    # not model)
    transform.crs_name = src.name  # type: ignore[attr-defined]
    transform.projected = bool(src.is_projected)  # type: ignore[attr-defined]
    return transform


def densify_tolerance(densify) -> float | None:
    """The ``densify=`` option as an angle on the unit sphere (radians): a length in
    metres (a number, on the sphere of :data:`~gloffset.EARTH_RADIUS`) or a distance
    with its unit (``"0.1m"``... :func:`gloffset.parse_distance`); None for the default
    (:data:`DENSIFY_TOLERANCE` or a hundredth of each edge). Raises
    :class:`~gloffset.errors.InvalidDistanceError` for a value that is not a distance (a
    bool included) or is below :data:`DENSIFY_MIN` (1 mm)."""
    if densify is None:
        return None
    from ..errors import InvalidDistanceError

    if isinstance(densify, str):
        tol = parse_distance(densify, EARTH_RADIUS)
    elif isinstance(densify, (bool, np.bool_)):  # float(True) is 1.0: never meant
        tol = float("nan")
    else:
        try:
            tol = float(densify) / EARTH_RADIUS
        except (TypeError, ValueError):
            tol = float("nan")
    if not (np.isfinite(tol) and tol > 0.0):
        raise InvalidDistanceError(
            f"densify tolerance {densify!r}: expected a positive distance, e.g. 1m or 0.1m"
        )
    if tol < DENSIFY_MIN / EARTH_RADIUS:
        raise InvalidDistanceError(
            f"densify tolerance {densify!r} is below the smallest, {DENSIFY_MIN * 1e3:g} mm "
            "(0.001m): finer would ask for points past the transforms' own rounding"
        )
    return tol


def densify(transform, parts: list[np.ndarray], tolerance: float | None = None) -> list:
    """Lon/lat of the paths ``parts`` ((n, 2) arrays in the projected CRS of
    ``transform``, from :func:`to_lonlat`), with points added along each edge.

    Each edge ``p -> q`` is the straight line between them in the projection. It is
    halved (adaptively, all edges at once) until the great-circle arc between
    consecutive points lies within the tolerance of that line: the line's images at a
    quarter, half and three quarters of each piece are within the tolerance of the
    piece's arc (:func:`gloffset.geometry.sphere.arc_distance`). ``tolerance`` is an angle on the
    unit sphere (:func:`densify_tolerance`); None: :data:`DENSIFY_TOLERANCE` metres or a
    hundredth of the edge's chord (its arc to 1e-6 below 100 m), whichever is smaller.
    The added points are the transforms of points of the line: the original vertices are
    kept, in order.

    Accuracy: a sampled test. A projection's image of a segment is smooth, so its
    distance from the piece's arc is a smooth function of ``t`` that is 0 at both ends;
    with it within the tolerance at three interior points it can exceed the tolerance
    only by its variation between samples a quarter piece apart, which halving makes
    small (tested: points along every edge of EPSG:3857 and UTM boxes and of Mexico in
    UTM within 1 m). Each point is exact to the transform's rounding.

    Raises :class:`~gloffset.errors.InputFormatError` for an edge that cannot be
    followed (a projection's singularity: still off after 2^40 halvings).
    """
    if not parts:
        return []
    sizes = np.array([len(p) for p in parts], dtype=np.int64)
    xy = np.concatenate([np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in parts])
    lon, lat = transform(xy[:, 0], xy[:, 1])
    v = lonlat_to_xyz(lon, lat)
    starts = np.concatenate([[0], np.cumsum(sizes)])
    has_next = np.ones(len(xy), dtype=bool)
    has_next[starts[1:] - 1] = False  # the last point of each part
    e = np.flatnonzero(has_next)  # edge e -> e + 1
    if tolerance is None:
        length = np.sqrt(np.square(v[e + 1] - v[e]).sum(axis=1))  # the chord: <= the arc
        tol = np.maximum(np.minimum(DENSIFY_TOLERANCE / EARTH_RADIUS, length / 100.0), 0.0)
        tol = np.maximum(tol, _FLOOR / EARTH_RADIUS)
    else:
        tol = np.full(len(e), float(tolerance))
    # the pieces still tested: their edge (index into e), t0, t1 and end points' vectors
    k = np.arange(len(e))
    t0, t1 = np.zeros(len(e)), np.ones(len(e))
    a, b = v[e], v[e + 1]
    p0, d = xy[e], xy[e + 1] - xy[e]
    added = []  # (edge, t, lon, lat) of the points added
    for _ in range(_MAX_DEPTH):
        if len(k) == 0:
            break
        ts = t0[:, None] + (t1 - t0)[:, None] * _SAMPLES  # (m, 3)
        sx = p0[k, 0][:, None] + ts * d[k, 0][:, None]
        sy = p0[k, 1][:, None] + ts * d[k, 1][:, None]
        slon, slat = transform(sx.ravel(), sy.ravel())
        s = lonlat_to_xyz(slon, slat).reshape(-1, 3, 3)
        off = arc_distance(s, a[:, None, :], b[:, None, :]).max(axis=1)
        split = np.flatnonzero(off > tol[k])
        if len(split) == 0:
            k = split
            break
        mid = s[split, 1]
        tm = ts[split, 1]
        added.append((k[split], tm, slon.reshape(-1, 3)[split, 1], slat.reshape(-1, 3)[split, 1]))
        k = np.concatenate([k[split], k[split]])
        t0, t1 = np.concatenate([t0[split], tm]), np.concatenate([tm, t1[split]])
        a, b = np.concatenate([a[split], mid]), np.concatenate([mid, b[split]])
    if len(k):
        i = int(e[k[0]])
        name = getattr(transform, "crs_name", "the input's CRS")
        raise InputFormatError(
            f"the edge from ({xy[i, 0]!r}, {xy[i, 1]!r}) to ({xy[i + 1, 0]!r}, "
            f"{xy[i + 1, 1]!r}) of CRS {name!r} cannot be followed on the sphere (a "
            "singularity of the projection?)"
        )
    if not added:
        out_lon, out_lat, at = lon, lat, starts
    else:
        ek = np.concatenate([e[x[0]] for x in added])  # the point each follows
        key_i = np.concatenate([np.arange(len(xy)), ek])
        key_t = np.concatenate([np.zeros(len(xy)), np.concatenate([x[1] for x in added])])
        order = np.lexsort((key_t, key_i))
        out_lon = np.concatenate([lon, np.concatenate([x[2] for x in added])])[order]
        out_lat = np.concatenate([lat, np.concatenate([x[3] for x in added])])[order]
        at = np.searchsorted(key_i[order], starts)
    out = np.column_stack([out_lon, out_lat])
    return [out[at[j] : at[j + 1]] for j in range(len(parts))]
