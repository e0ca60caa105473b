"""Distance-field tiles: the signed distance at a tile's pixel centres
(:func:`gloffset.distance_field` on :class:`~gloffset.grids.Tile`) as a lossless RGB PNG
that map clients decode as elevation, and their pyramid (``gloffset tiles --field``).

The encoding is MapLibre's ``raster-dem`` ``custom`` encoding (Mapbox's ``terrain-rgb``
is the same formula with other numbers)::

    metres = R * redFactor + G * greenFactor + B * blueFactor - baseShift

with :data:`FIELD_ENCODING`: redFactor 65536, greenFactor 256, blueFactor 1, baseShift
8388608. A pixel holds the signed distance in metres rounded to the nearest metre, so
``R, G, B`` are the 24 bits of ``metres + 8388608``: steps of 1 m from -8,388,608 m to
+8,388,607 m; farther distances are clamped to that range. Negative is inside the union
of the polygons (unsigned for lines and points), as in :class:`~gloffset.DistanceField`.
"""

from __future__ import annotations

import io
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from ...errors import OptionError
from ...grids import Tile
from ...raster.field import distance_field
from ...units import EARTH_RADIUS
from ..store.tilestore import INPUT_KEY, check_store, input_digest, open_store
from .driver import TMS_DOCUMENT, PyramidOptions, parse_zooms, pyramid_quad
from .metadata import check_resume, final_bounds, store_metadata

__all__ = [
    "FIELD_ENCODING",
    "FIELD_MIN",
    "FIELD_MAX",
    "encode_field",
    "decode_field",
    "field_tile",
    "field_pyramid",
    "matrix_shapes",
]

#: The four numbers of the ``custom`` encoding of MapLibre's ``raster-dem`` sources:
#: ``metres = R * redFactor + G * greenFactor + B * blueFactor - baseShift``.
FIELD_ENCODING = {"redFactor": 65536, "greenFactor": 256, "blueFactor": 1, "baseShift": 8388608}
#: The range of the encoded distances in metres (beyond it, values are clamped).
FIELD_MIN, FIELD_MAX = -FIELD_ENCODING["baseShift"], (1 << 24) - 1 - FIELD_ENCODING["baseShift"]


def encode_field(values: np.ndarray, radius: float = 1.0) -> bytes:
    """The RGB PNG of a field tile: ``values`` (h x w, signed distances in the units of
    ``radius``; 1.0: radians) times ``radius`` in metres, rounded to the nearest metre
    and clamped to ``FIELD_MIN..FIELD_MAX``, as the 24 bits of ``metres + baseShift``
    (R high, B low). Decoded by :func:`decode_field` (or a client, with
    :data:`FIELD_ENCODING`), each pixel is within 0.5 m of ``values * radius`` inside
    the range."""
    metres = np.rint(np.asarray(values, dtype=np.float64) * radius)
    code = (np.clip(metres, FIELD_MIN, FIELD_MAX) + FIELD_ENCODING["baseShift"]).astype(np.uint32)
    rgb = np.stack([(code >> 16) & 255, (code >> 8) & 255, code & 255], axis=-1).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(rgb, mode="RGB").save(buf, format="PNG")
    return buf.getvalue()


def decode_field(png: bytes) -> np.ndarray:
    """The metres (float64, h x w) of a field tile's PNG, by :data:`FIELD_ENCODING`."""
    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(np.float64)
    f = FIELD_ENCODING
    return (
        rgb[..., 0] * f["redFactor"]
        + rgb[..., 1] * f["greenFactor"]
        + rgb[..., 2] * f["blueFactor"]
        - f["baseShift"]
    )


def field_tile(shape, z: int, x: int, y: int, size: int = 256, quad=None):
    """The :class:`~gloffset.DistanceField` of tile ``z/x/y`` (``size`` px) in radians
    (``radius=1``, unclamped): what a field tile encodes (times the Earth's radius) and
    what :meth:`~gloffset.DistanceField.threshold` answers any tile of it from."""
    grid = Tile(z, x, y, size) if quad is None else quad.tile(z, x, y)
    return distance_field(shape, grid, radius=1.0)


@dataclass(frozen=True)
class FieldPyramidOptions:
    """The keywords of :func:`field_pyramid`, as one value."""

    radius: float = EARTH_RADIUS
    size: int = 256
    name: str | None = None
    source: str | None = None
    overwrite: bool = False
    resume: bool = False
    progress: Any = None
    tms: Any = None


def field_pyramid(shape, zooms, out, **options) -> int:
    """Write the field tiles of ``shape`` (every tile of ``zooms``, ``"MIN-MAX"``) to
    ``out`` (``.mbtiles``, ``.pmtiles`` or an XYZ folder), encoded by
    :data:`FIELD_ENCODING` in metres on the sphere of ``radius``; the encoding is in the
    output's metadata (``encoding``). ``progress(done, total)`` is called after each
    tile. Returns the number of tiles written (a resumed run skips those there). ``tms``:
    the tiles of another OGC TileMatrixSet (:func:`gloffset.grids.TmsTile`; an XYZ folder
    only, the TMS's tile size), as :func:`~gloffset.tiles.pyramid` takes it.

    ``resume`` completes an interrupted run: the tiles the output holds are kept, the
    others written, and the result is the output of one uninterrupted run. It is refused
    (:class:`~gloffset.errors.TilesError`, before anything is written) when the output
    was written with another size, radius, zoom range or TMS, or from another input.

    Accuracy: each pixel is the exact signed distance rounded once to float32 radians
    (:func:`gloffset.distance_field`), times ``radius``, rounded to the metre: within 1 m
    of the exact distance up to 8,000 km (float32's relative 6e-8 is 0.48 m there).

    The keywords (:class:`FieldPyramidOptions`): ``radius`` (default the Earth's),
    ``size`` (256), ``name``, ``source``, ``overwrite``, ``resume``, ``progress``, ``tms``.
    """
    try:
        o = FieldPyramidOptions(**options)
    except TypeError:
        bad = sorted(set(options) - set(FieldPyramidOptions.__dataclass_fields__))
        raise OptionError(f"field_pyramid takes no {', '.join(bad)}") from None
    radius, size, name, source = o.radius, o.size, o.name, o.source
    overwrite, resume, progress, tms = o.overwrite, o.resume, o.progress, o.tms
    zlo, zhi = parse_zooms(zooms)
    if size & (size - 1) or not 16 <= size <= 4096:
        raise OptionError(f"tile size must be a power of two from 16 to 4096, got {size!r}")
    quad = pyramid_quad(PyramidOptions(size=size, tms=tms), out, zhi)
    extra = {} if quad is None else {"tms": quad.id}
    params = json.dumps(
        {"field": True, "size": size, "radius": radius, "zooms": [zlo, zhi], **extra},
        sort_keys=True,
    )
    have = check_store(out, resume=resume, overwrite=overwrite)  # reads only
    if resume and have is not None:
        check_resume(have, params, shape, out)
    store = open_store(
        out,
        _field_metadata(shape, (zlo, zhi), params, name, source, quad),
        resume=resume,
        overwrite=overwrite,
    )
    present = store.existing() if resume else set()
    shapes = matrix_shapes(quad, zhi)
    total = sum(rows * cols for rows, cols in shapes[zlo:])
    done, written, saved = 0, 0, time.monotonic()
    try:
        for z, x, y in _tiles(shapes, zlo, zhi):
            if (z, x, y) not in present:
                f = field_tile(shape, z, x, y, size, quad)
                store.put(z, x, y, encode_field(f.values, radius))
                written += 1
                if time.monotonic() - saved >= COMMIT_SECONDS:  # a killed run keeps them
                    store.commit()
                    saved = time.monotonic()
            done += 1
            if progress is not None:
                progress(done, total)
        store.set_metadata(final_bounds(store, (zlo, zhi), quad))
        if quad is not None and isinstance(out, (str, Path)):  # a folder (pyramid_quad)
            store.put_document(TMS_DOCUMENT, quad.document().encode())
        store.finish()
    finally:
        store.close()
    return written


#: A field pyramid commits its tiles at least this often (seconds), so that a killed run
#: loses at most the tiles of the last few seconds and ``resume`` continues from there.
COMMIT_SECONDS = 2.0


def matrix_shapes(quad, zhi: int) -> list[tuple[int, int]]:
    """``(rows, columns)`` of tiles of zooms ``0..zhi``: web mercator's ``2^z x 2^z``
    (``quad`` None), else the matrices of ``quad`` (a :class:`~gloffset.grids.tms.TmsQuad`:
    ``WorldCRS84Quad`` has ``1 x 2`` at zoom 0)."""
    return [(1 << z, 1 << z) if quad is None else quad.matrix_shape(z) for z in range(zhi + 1)]


def _tiles(shapes, zlo: int, zhi: int):
    """Every tile ``(z, x, y)`` of the zooms, row by row (``shapes[z]``: rows, columns)."""
    for z in range(zlo, zhi + 1):
        rows, cols = shapes[z]
        for y in range(rows):
            for x in range(cols):
                yield z, x, y


def _field_metadata(shape, zooms, params: str, name, source, quad=None) -> dict:
    label = name or (source or "field")
    desc = (
        f"Signed distance to the curves of {source or 'the input'} in metres (negative inside "
        "its polygons), as raster-dem custom encoding: metres = R * redFactor + G * "
        "greenFactor + B * blueFactor - baseShift"
    )
    meta = {**store_metadata(label, desc, zooms, params), INPUT_KEY: input_digest(shape)}
    if quad is not None:
        meta["tileMatrixSet"] = quad.id
        meta["bounds"] = ",".join(repr(v) for v in quad.lonlat_bounds())
    meta["encoding"] = json.dumps(FIELD_ENCODING)  # JSON, as "gloffset" is
    return meta
