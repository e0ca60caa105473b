"""Web-mercator tile pyramids of the offset region.

The public face of :mod:`gloffset.tiles.tiling`.

:func:`pyramid` writes an XYZ folder, MBTiles or PMTiles pyramid of the region within a
distance of the input, :func:`pyramids` those of several distances from one read of it;
:func:`parse_zooms` reads a zoom range, :class:`PyramidStats`
and :class:`TileProgress` are what a run reports. The tile server's helpers
(:func:`render_tiles`, :func:`measure_tiles`, :class:`TileCentre`) are here too.
"""

from __future__ import annotations

from .tiling import *  # noqa: F403  (the names listed in tiling.__all__)
from .tiling import __all__  # noqa: F401  (the same list, once)
