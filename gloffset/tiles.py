"""Web-mercator tile pyramids of the offset region: the public face of
:mod:`gloffset.raster.pyramid`.

:func:`pyramid` writes an XYZ folder, MBTiles or PMTiles pyramid of the region within a
distance of the input, :func:`pyramids` those of several distances from one read of it;
:func:`parse_zooms` reads a zoom range, :class:`PyramidStats`
and :class:`TileProgress` are what a run reports. The tile server's helpers
(:func:`render_tiles`, :func:`measure_tiles`, :class:`TileCentre`) are here too.
"""

from __future__ import annotations

from .raster.pyramid import (
    ALONE_ZOOM,
    MAX_ZOOM,
    PyramidStats,
    TileCentre,
    TileProgress,
    TilesError,
    measure_tiles,
    parse_zooms,
    pyramid,
    pyramids,
    render_tiles,
)

__all__ = [
    "pyramid",
    "pyramids",
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
