"""Vector files through GDAL (pyogrio): Shapefile, GeoPackage, FlatGeobuf, GeoParquet and
anything else GDAL reads, as GeoJSON features in lon/lat.

Reading (:func:`read`) selects a layer (``layer=``, by name or index; a file with several
layers and no ``layer`` is refused with their names) and features (``where=``, an
attribute filter in OGR SQL, e.g. ``"continent = 'Africa'"``), transforms another CRS to
lon/lat (:mod:`gloffset.io.crs`) and returns a GeoJSON FeatureCollection with each
feature's attributes as its properties, which :mod:`gloffset.shape` then validates like
any GeoJSON. Writing (:func:`write`) puts GeoJSON features (offset polygons and their
properties) in a file of the format its name says (:data:`WRITE_FORMATS`), in EPSG:4326,
atomically. GeoParquet goes through pyarrow (:mod:`gloffset.io.geoparquet`) where GDAL
has no Parquet driver. Everything here needs the ``files`` extra (pyogrio, pyproj,
pyarrow, shapely).
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputFormatError, OutputError
from . import geoparquet
from .crs import densify, densify_tolerance, to_lonlat
from .output import keep_mode

__all__ = ["READ_SUFFIXES", "WRITE_FORMATS", "check_writable", "is_vector_file", "read", "write"]

#: File name endings read through GDAL rather than as GeoJSON text.
READ_SUFFIXES = (
    ".shp",
    ".shp.zip",
    ".gpkg",
    ".fgb",
    ".parquet",
    ".geoparquet",
    ".gdb",
    ".gml",
    ".kml",
    ".sqlite",
    ".geojsonl",
    ".geojsons",
)
#: The GDAL driver written for each output name ending.
WRITE_FORMATS = {
    ".gpkg": "GPKG",
    ".shp": "ESRI Shapefile",
    ".fgb": "FlatGeobuf",
    ".parquet": "Parquet",
    ".geoparquet": "Parquet",
}


def is_vector_file(source) -> bool:
    """Whether ``source`` names a file to read through GDAL (by its ending)."""
    if not isinstance(source, (str, os.PathLike)):
        return False
    name = os.fspath(source).lower()
    return name.endswith(READ_SUFFIXES) or (
        name.endswith(".zip") and not name.lstrip().startswith("{")
    )


def _needs(what: str, error=InputFormatError):
    try:
        import pyogrio
        import shapely
    except ImportError as exc:
        raise error(f"{what} needs {exc.name}: pip install 'gloffset[files]'") from None
    return pyogrio, shapely


def _parquet(path: str) -> bool:
    return path.lower().endswith((".parquet", ".geoparquet"))


def _has_driver(pyogrio, name: str) -> bool:
    return name in pyogrio.list_drivers()


# ---------------------------------------------------------------------------- reading


def read(path, *, layer=None, where: str | None = None, densify=None) -> dict:
    """A GeoJSON FeatureCollection (lon/lat) of the features of a vector file.

    A file in a projected CRS has its edges densified (:func:`gloffset.io.crs.densify`:
    points along each straight edge of the projection until the great circles between
    them follow it to ``densify``, metres or a distance with its unit; default 1 m or a
    hundredth of the edge, whichever is smaller); lon/lat edges are kept as they are.

    Raises :class:`~gloffset.errors.InputFormatError` naming the problem: the extra is not
    installed, the file is missing or not a vector file, the layer is unknown (the message
    lists the file's layers), the ``where`` clause is bad, or the CRS cannot be
    transformed to lon/lat.
    """
    path = os.fspath(path)
    tolerance = densify_tolerance(densify)
    pyogrio, shapely = _needs(f"reading {path!r}")
    if not os.path.exists(path):
        raise InputFormatError(f"no such file: {path!r}")
    if _parquet(path) and not _has_driver(pyogrio, "Parquet"):
        crs, wkb, columns = _parquet_layer(pyogrio, path, layer, where)
    else:
        crs, wkb, columns = _gdal_layer(pyogrio, path, layer, where)
    return _features(shapely, path, crs, wkb, columns, tolerance)


def _gdal_layer(pyogrio, path: str, layer, where, shown: str | None = None):
    """``(crs, wkb, columns)`` of one layer of a GDAL dataset (``shown``: the name in
    messages, when ``path`` is a temporary copy)."""
    from pyogrio.errors import DataSourceError

    shown = path if shown is None else shown

    try:
        names = [str(n) for n in pyogrio.list_layers(path)[:, 0]]
    except DataSourceError as exc:
        raise InputFormatError(f"cannot read {shown!r}: {exc}") from None
    if layer is None and len(names) > 1:
        listed = ", ".join(repr(n) for n in names)
        raise InputFormatError(
            f"{shown!r} has {len(names)} layers ({listed}); choose one (layer=, --layer)"
        )
    if layer is not None and str(layer) not in names:
        if not (str(layer).isdigit() and int(layer) < len(names)):
            listed = ", ".join(repr(n) for n in names)
            raise InputFormatError(f"{shown!r} has no layer {layer!r}; its layers: {listed}")
        layer = int(layer)
    try:
        meta, _, wkb, data = pyogrio.raw.read(
            path, layer=layer, where=where, datetime_as_string=True
        )
    except Exception as exc:  # GDAL's errors: pyogrio.errors, ValueError
        if where is not None:
            raise InputFormatError(
                f"{shown!r}: bad where clause {where!r} ({_first_line(exc)}); it is an OGR SQL "
                f"condition on the attributes {_field_names(pyogrio, path, layer)}, e.g. "
                "\"name = 'Fiji'\""
            ) from None
        raise InputFormatError(f"cannot read {shown!r}: {_first_line(exc)}") from None
    if where is not None and len(wkb) == 0:
        name = names[layer] if isinstance(layer, int) else (layer or names[0])
        raise InputFormatError(
            f"{shown!r}: no feature of layer {name!r} matched the where clause {where!r}"
        )
    return meta["crs"], list(wkb), dict(zip(meta["fields"], data))


def _first_line(exc: Exception) -> str:
    """The first line of a GDAL error, with the bytes reprs (``b'name'``) that some of
    its messages carry shown as the text they are."""
    text = str(exc).strip()
    if not text:
        return type(exc).__name__
    return re.sub(r"\bb'([^']*)'", r"\1", text.splitlines()[0])


def _field_names(pyogrio, path: str, layer) -> str:
    try:
        fields = pyogrio.read_info(path, layer=layer)["fields"]
    except Exception:  # pragma: no cover
        return "(unknown)"
    return ", ".join(str(f) for f in fields) or "(none)"


def _parquet_layer(pyogrio, path: str, layer, where):
    """GeoParquet without GDAL's Parquet driver: pyarrow, and a ``where`` clause through a
    temporary GeoPackage (one OGR SQL dialect for every format)."""
    stem = Path(path).name.split(".")[0]
    if layer not in (None, 0, "0", stem):
        raise InputFormatError(f"{path!r} has no layer {layer!r}; its layers: {stem!r}")
    crs, wkb, columns = geoparquet.read(path)
    if where is None:
        return crs, wkb, columns
    with tempfile.TemporaryDirectory(prefix="gloffset-") as tmp:
        gpkg = os.path.join(tmp, f"{stem}.gpkg")
        fields = list(columns)
        data = [_column(columns[f]) for f in fields]
        pyogrio.raw.write(
            gpkg, np.array(wkb, dtype=object), data, fields, layer=stem, driver="GPKG",
            geometry_type="Unknown", crs=json.dumps(crs) if isinstance(crs, dict) else crs,
        )  # fmt: skip
        _, wkb, columns = _gdal_layer(pyogrio, gpkg, stem, where, shown=path)
    return crs, wkb, columns


def _column(values: np.ndarray) -> np.ndarray:
    """A column as a numpy array GDAL can store (numbers as numbers, else text)."""
    vals = [v for v in values.tolist() if v is not None]
    if vals and all(isinstance(v, bool) for v in vals):
        return np.array([bool(v) if v is not None else False for v in values.tolist()])
    if vals and all(isinstance(v, int) and not isinstance(v, bool) for v in vals):
        if len(vals) == len(values):
            return np.array(values.tolist(), dtype=np.int64)
    if vals and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
        return np.array([np.nan if v is None else float(v) for v in values.tolist()])
    return np.array([None if v is None else str(v) for v in values.tolist()], dtype=object)


def _features(shapely, path: str, crs, wkb: list, columns: dict, tolerance=None) -> dict:
    """GeoJSON features from WKB geometries (transformed to lon/lat; the edges of a
    projected CRS densified to ``tolerance``, :func:`gloffset.io.crs.densify`) and their
    columns."""
    transform = to_lonlat(crs, repr(path))
    geoms = shapely.from_wkb(np.array(wkb, dtype=object))
    projected = transform is not None and transform.projected
    if transform is not None and not projected:
        geoms = shapely.transform(geoms, lambda xy: np.column_stack(transform(xy[:, 0], xy[:, 1])))
    texts = shapely.to_geojson(geoms)
    names = list(columns)
    values = [_plain(columns[n]) for n in names]
    features = []
    for i, text in enumerate(texts.tolist()):
        geometry = None if text is None else json.loads(text)
        props = {n: v[i] for n, v in zip(names, values)}
        features.append({"type": "Feature", "properties": props, "geometry": geometry})
    if projected:
        _densify_features(transform, features, tolerance)
    return {"type": "FeatureCollection", "name": Path(path).name, "features": features}


def _densify_features(transform, features: list[dict], tolerance) -> None:
    """Replace the projected coordinates of the features' geometries by lon/lat, each
    edge densified (all of them in one :func:`~gloffset.io.crs.densify` call)."""
    slots: list[tuple[Any, Any, bool]] = []  # (list, index, is a path): where coordinates are
    for f in features:
        if f["geometry"] is not None:
            _coordinate_slots(f["geometry"], slots)
    parts = []
    for holder, i, path in slots:
        xy = np.asarray(holder[i] if path else [holder[i]], dtype=np.float64)
        parts.append(xy.reshape(len(xy), -1)[:, :2])
    for (holder, i, path), lonlat in zip(slots, densify(transform, parts, tolerance)):
        holder[i] = lonlat.tolist() if path else lonlat[0].tolist()


def _coordinate_slots(geometry: dict, slots: list) -> None:
    """Where the coordinates of a GeoJSON geometry (shapely's, well formed) are: each
    path (a line or a ring: its edges are the projection's straight lines) and each
    point, as ``(list, index, is a path)``."""
    kind = geometry["type"]
    coords: Any = geometry.get("coordinates")  # None in a collection
    if kind == "GeometryCollection":
        for g in geometry["geometries"]:
            _coordinate_slots(g, slots)
    elif kind == "Point":
        if coords:
            slots.append((geometry, "coordinates", False))
    elif kind == "MultiPoint":
        slots.extend((coords, i, False) for i in range(len(coords)))
    elif kind == "LineString":
        if coords:
            slots.append((geometry, "coordinates", True))
    elif kind in ("MultiLineString", "Polygon"):
        slots.extend((coords, i, True) for i in range(len(coords)) if coords[i])
    elif kind == "MultiPolygon":
        slots.extend((p, i, True) for p in coords for i in range(len(p)) if p[i])


def _plain(column) -> list:
    """A column as JSON values (NaN and missing values as None, binary as hex, dates as
    text)."""
    out = np.asarray(column).tolist()
    return [_json_value(v) for v in out]


def _json_value(v):
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, (bytes, bytearray)):
        return v.hex()  # binary fields: as hex text
    if v is not None and not isinstance(v, (str, int, float, bool, list, dict)):
        return str(v)  # dates, decimals and other values pyarrow gives
    return v


# ---------------------------------------------------------------------------- writing


def check_writable(path) -> None:
    """Fail early (before the work) when ``path`` names no vector format gloffset writes
    or the ``files`` extra is missing."""
    path = os.fspath(path)
    if not path.lower().endswith(tuple(WRITE_FORMATS)):
        raise OutputError(
            f"{path!r}: unknown vector format; name the output .geojson, "
            + ", ".join(WRITE_FORMATS)
        )
    _needs(f"writing {path!r}", OutputError)


def write(path, features: list[dict]) -> None:
    """Write GeoJSON features (lon/lat) to ``path`` in the format its ending names
    (:data:`WRITE_FORMATS`), EPSG:4326, with their properties as attributes.

    Polygons are written as MultiPolygons (one geometry type per layer, as Shapefiles
    need). The file is replaced atomically: written in a temporary folder beside it, then
    moved over it (a Shapefile's side files with it).
    """
    path = os.fspath(path)
    suffix = next((s for s in WRITE_FORMATS if path.lower().endswith(s)), None)
    if suffix is None:
        raise OutputError(
            f"{path!r}: unknown vector format; name the output .geojson, "
            + ", ".join(WRITE_FORMATS)
        )
    pyogrio, shapely = _needs(f"writing {path!r}", OutputError)
    geoms = shapely.from_geojson([json.dumps(f["geometry"]) for f in features])
    geoms = np.array([_multi(shapely, g) for g in geoms], dtype=object)
    wkb = shapely.to_wkb(geoms)
    fields = list(dict.fromkeys(k for f in features for k in (f.get("properties") or {})))
    columns = {
        k: np.array([(f.get("properties") or {}).get(k) for f in features], dtype=object)
        for k in fields
    }
    folder = os.path.dirname(os.path.abspath(path))
    try:
        with tempfile.TemporaryDirectory(prefix=".gloffset-", dir=folder) as tmp:
            name = os.path.join(tmp, os.path.basename(path))
            if WRITE_FORMATS[suffix] == "Parquet" and not _has_driver(pyogrio, "Parquet"):
                geoparquet.write(name, list(wkb), columns)
            else:
                data = [_column(columns[k]) for k in fields]
                driver = WRITE_FORMATS[suffix]
                # FlatGeobuf's spatial index would reorder the features
                options = {"SPATIAL_INDEX": "NO"} if driver == "FlatGeobuf" else None
                with warnings.catch_warnings():  # Shapefiles cut field names to 10 letters
                    warnings.simplefilter("ignore", RuntimeWarning)
                    pyogrio.raw.write(
                        name, wkb, data, fields, driver=driver, geometry_type="MultiPolygon",
                        crs="EPSG:4326", promote_to_multi=True, layer_options=options,
                    )  # fmt: skip
            _move_all(tmp, folder)
    except OSError as exc:
        if isinstance(exc, OutputError):
            raise
        raise OutputError(f"cannot write {path!r}: {exc}") from None
    except Exception as exc:  # GDAL's own errors
        raise OutputError(f"cannot write {path!r}: {exc}") from None


def _multi(shapely, g):
    if g is None or shapely.get_type_id(g) != 3:  # 3: Polygon
        return g
    return shapely.multipolygons([g])


def _move_all(src: str, dst: str) -> None:
    """Move the files of ``src`` into ``dst``, each with the permission bits of the file it
    replaces or of a new file (GDAL's SQLite makes a GeoPackage 0644 whatever the umask)."""
    for name in sorted(os.listdir(src)):
        tmp, path = os.path.join(src, name), os.path.join(dst, name)
        keep_mode(tmp, path)
        os.replace(tmp, path)
