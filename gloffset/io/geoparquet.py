"""GeoParquet (1.0 / 1.1, WKB geometry) read and written with pyarrow.

GDAL builds without the Parquet driver (as in pyogrio's wheels) cannot open GeoParquet,
so :mod:`gloffset.io.vectorfile` hands such files here. A table is returned as a tuple
``(crs, wkb, columns)``, the parts :func:`gloffset.io.vectorfile.read` makes features of:
the CRS of the primary geometry column (PROJJSON, OGC:CRS84 when the file gives none, as
the specification says), its WKB values, and the other columns as numpy arrays.
"""

from __future__ import annotations

import json

import numpy as np

from ..errors import InputFormatError, OutputError

__all__ = ["read", "write"]


def _pyarrow(what: str, error):
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError:
        raise error(f"{what} GeoParquet needs pyarrow: pip install 'gloffset[files]'") from None
    return pyarrow


def read(path: str) -> tuple[object, list, dict]:
    """``(crs, wkb, columns)`` of the GeoParquet file ``path``."""
    pa = _pyarrow("reading", InputFormatError)
    try:
        table = pa.parquet.read_table(path)
    except (OSError, pa.ArrowException) as exc:
        raise InputFormatError(f"cannot read {path!r} as Parquet: {exc}") from None
    meta = (table.schema.metadata or {}).get(b"geo")
    if meta is None:
        raise InputFormatError(f"{path!r} is Parquet without GeoParquet metadata ('geo')")
    try:
        geo = json.loads(meta)
        name = geo["primary_column"]
        column = geo["columns"][name]
    except (ValueError, KeyError, TypeError) as exc:
        raise InputFormatError(f"{path!r}: malformed GeoParquet metadata: {exc}") from None
    if str(column.get("encoding", "WKB")).upper() != "WKB":
        raise InputFormatError(
            f"{path!r}: GeoParquet geometry encoding {column.get('encoding')!r} is not "
            "supported; write it as WKB"
        )
    crs = column.get("crs", "OGC:CRS84")
    wkb = table.column(name).to_pylist()
    columns = {
        c: np.asarray(table.column(c).to_pylist(), dtype=object)
        for c in table.column_names
        if c != name
    }
    return crs, wkb, columns


def write(path: str, wkb: list, columns: dict) -> None:
    """Write lon/lat WKB geometries and their columns as GeoParquet 1.0 to ``path`` (no
    ``crs`` key: OGC:CRS84, the specification's default)."""
    pa = _pyarrow("writing", OutputError)
    arrays = {k: pa.array(list(v)) for k, v in columns.items()}
    arrays["geometry"] = pa.array(wkb, type=pa.binary())
    geo = {
        "version": "1.0.0",
        "primary_column": "geometry",
        "columns": {"geometry": {"encoding": "WKB", "geometry_types": []}},
    }
    table = pa.table(arrays).replace_schema_metadata({"geo": json.dumps(geo)})
    try:
        pa.parquet.write_table(table, path)
    except (OSError, pa.ArrowException) as exc:
        raise OutputError(f"cannot write {path!r}: {exc}") from None
