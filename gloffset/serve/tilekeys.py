"""What the tile service's tiles are: the keys of a tile (:class:`TileKey`) and of its
distance field (:class:`FieldKey`), the shared PNGs of tiles decided at once (empty: fully
transparent; full: every pixel inside), and the tiles' ETags."""

from __future__ import annotations

import functools
import hashlib
import io
from dataclasses import dataclass

import numpy as np
from PIL import Image

from ..grids.tms import tms_quad
from ..tiles.tiling.tilepaint import TileStyle

__all__ = [
    "TileKey",
    "FieldKey",
    "EMPTY_PNG",
    "empty_png",
    "empty_tile",
    "full_png",
    "quad_of",
    "etag",
]


def empty_png(size: int) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(np.zeros((size, size, 4), np.uint8), mode="RGBA").save(buf, format="PNG")
    return buf.getvalue()


#: A fully transparent tile of 256 and 512 pixels (every tile with nothing in it).
EMPTY_PNG = {256: empty_png(256), 512: empty_png(512)}


@functools.lru_cache(maxsize=64)
def full_png(size: int, style: TileStyle) -> bytes:
    """The one PNG of a tile wholly inside the region, per size and style."""
    png = style.encode(np.ones((size, size), dtype=bool))
    assert png is not None  # every pixel inside shows
    return png


@dataclass(frozen=True)
class TileKey:
    """What a tile is: layer, distance (radians), z/x/y, pixel size, style and
    TileMatrixSet (``tms``: its id, None for web mercator)."""

    layer: str
    d: float
    z: int
    x: int
    y: int
    size: int
    style: TileStyle
    tms: str | None = None

    def group(self) -> tuple:
        return (self.layer, self.d, self.z, self.size, self.style, self.tms)

    def where(self) -> tuple:
        """The tile's place, whose centre decides it at any distance (any size, style)."""
        return (self.layer, self.z, self.x, self.y, self.tms)

    def field(self) -> FieldKey:
        """The key of the tile's distance field."""
        return FieldKey(self.layer, self.z, self.x, self.y, self.size, self.tms)


@dataclass(frozen=True)
class FieldKey:
    """A tile's distance field: layer, z/x/y, pixel size and TileMatrixSet (any
    distance, any style)."""

    layer: str
    z: int
    x: int
    y: int
    size: int
    tms: str | None = None

    def gridquad_of(self):
        """The :class:`~gloffset.grids.tms.TmsQuad` of the tile's TMS (None: web mercator)."""
        return quad_of(self.tms)


def quad_of(tms: str | None):
    """The :class:`~gloffset.grids.tms.TmsQuad` of the TileMatrixSet ``tms`` (None: web
    mercator, None)."""
    return None if tms is None else tms_quad(tms)


@functools.lru_cache(maxsize=16)
def empty_tile(size: int) -> bytes:
    """The fully transparent tile of ``size`` pixels (:data:`EMPTY_PNG`'s where it has one)."""
    return EMPTY_PNG.get(size) or empty_png(size)


def etag(data: bytes) -> str:
    """A strong ETag: the same bytes, the same tag."""
    return '"' + hashlib.sha256(data).hexdigest()[:32] + '"'
