"""Web-mercator tile pyramids of the offset region (the public face is
:mod:`gloffset.tiles`).

:mod:`.driver` is :func:`pyramid`: the run over the zooms, resumed outputs, the job of a
run; the other modules are its parts: :mod:`.tilepaint` (PNG encoding and outlines),
:mod:`.distributed` (the Dask split) and :mod:`.ellipsoid` (pyramids on the ellipsoid).
"""

from __future__ import annotations

from .driver import (
    ALONE_ZOOM,
    MAX_ZOOM,
    PyramidStats,
    TileCentre,
    TileProgress,
    TilesError,
    measure_tiles,
    parse_zooms,
    pyramid,
    render_tiles,
)

__all__ = [
    "pyramid",
    "parse_zooms",
    "PyramidStats",
    "TileProgress",
    "TilesError",
    "MAX_ZOOM",
    "render_tiles",
    "measure_tiles",
    "TileCentre",
    "ALONE_ZOOM",
]
