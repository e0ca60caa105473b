"""Web-mercator tile pyramids of the offset region (the public face is
:mod:`gloffset.tiles`).

:mod:`.driver` is :func:`pyramid`: the run over the zooms, resumed outputs, the job of a
run. Its parts: :mod:`.walk` (what each zoom writes, the bin levels below its frontier
tiles), :mod:`.progress` (counts, progress and the time left), :mod:`.metadata` (the
output's metadata), :mod:`.tilepaint` (PNG encoding and outlines), :mod:`.distributed`
(the Dask split), :mod:`.ellipsoid` (pyramids on the ellipsoid) and :mod:`.ondemand`
(a few tiles of one zoom, for the tile server).
"""

from __future__ import annotations

from .driver import MAX_ZOOM, TilesError, parse_zooms, pyramid, pyramids
from .ondemand import ALONE_ZOOM, TileCentre, measure_tiles, render_tiles
from .progress import PyramidStats, TileProgress

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
