"""Coordinate reference systems of input files: everything becomes lon/lat (EPSG:4326).

gloffset works in longitude and latitude on the sphere. A vector file in another CRS
(a projected one such as EPSG:3857 or a UTM zone, or a geographic CRS on another
datum) is transformed to lon/lat with pyproj (the ``files`` extra); a CRS that cannot
be transformed (geocentric, vertical, engineering, unknown to PROJ) is refused with a
message naming it. A file without a CRS is taken as lon/lat, as GeoJSON is.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputFormatError

__all__ = ["is_lonlat", "to_lonlat"]

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
        bad = ~(np.isfinite(lon) & np.isfinite(lat))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputFormatError(
                f"{where}: the point ({float(np.ravel(x)[i])!r}, {float(np.ravel(y)[i])!r}) "
                f"of CRS {src.name!r} has no lon/lat (outside the projection's domain)"
            )
        # a projection's round trip can step a hair over the antimeridian or a pole
        return np.clip(lon, -180.0, 180.0), np.clip(lat, -90.0, 90.0)

    transform.crs_name = src.name
    return transform
