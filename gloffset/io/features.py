"""An input as GeoJSON: GeoJSON text and objects through :mod:`gloffset.io.geojson`, other
vector files (Shapefile, GeoPackage, FlatGeobuf, GeoParquet...) through
:mod:`gloffset.io.vectorfile`; and the features of any GeoJSON object, one by one (for
per-feature offsets).
"""

from __future__ import annotations

import os

from ..errors import InputFormatError
from . import geojson, vectorfile
from .crs import densify_tolerance, is_lonlat

__all__ = ["load", "features"]


def load(source, *, layer=None, where: str | None = None, densify=None) -> dict:
    """The GeoJSON object of ``source``: a path to a GeoJSON or other vector file, ``-``
    (GeoJSON on stdin), a GeoJSON string or dict, or an object with ``__geo_interface__``.

    ``layer`` and ``where`` select a layer and features of a vector file (a GeoJSON file
    with either is read through GDAL too). ``densify`` is the tolerance to which the
    edges of a file in a projected CRS are followed (:func:`gloffset.io.vectorfile.read`),
    checked whatever the input (:func:`gloffset.io.crs.densify_tolerance`), before it is
    read.
    """
    densify_tolerance(densify)  # a bad one is refused even where no edge needs it
    if vectorfile.is_vector_file(source) or (
        (layer is not None or where is not None)
        and isinstance(source, (str, os.PathLike))
        and os.fspath(source) != "-"
        and not os.fspath(source).lstrip().startswith("{")
    ):
        return vectorfile.read(source, layer=layer, where=where, densify=densify)
    if layer is not None or where is not None:
        raise InputFormatError(
            "layer and where (--layer, --where) select from a file; they do not apply to "
            "stdin, GeoJSON text or objects"
        )
    obj = geojson.load(source)
    legacy = _legacy_crs(obj)
    if legacy is None or is_lonlat(legacy, "the GeoJSON's 'crs'"):
        return obj
    if isinstance(source, (str, os.PathLike)) and os.path.isfile(os.fspath(source)):
        # GDAL reads the legacy member; then to lon/lat
        return vectorfile.read(source, densify=densify)
    raise InputFormatError(
        f"GeoJSON in CRS {legacy!r} (a pre-RFC 7946 'crs' member): give it as a file, which "
        "is transformed to lon/lat, or write it in lon/lat (EPSG:4326)"
    )


def _legacy_crs(obj):
    """The CRS named by a GeoJSON object's 'crs' member (GeoJSON 2008), or None."""
    crs = obj.get("crs") if isinstance(obj, dict) else None
    props = crs.get("properties") if isinstance(crs, dict) else None
    name = props.get("name") if isinstance(props, dict) else None
    return name if isinstance(name, str) and name.strip() else None


def features(obj: dict) -> list[dict]:
    """The features of a GeoJSON object: a FeatureCollection's, a Feature alone, or a bare
    geometry as a Feature with no properties."""
    feats = geojson.members(obj)
    return [{"type": "Feature", "properties": {}, "geometry": obj}] if feats is None else feats
