"""gloffset: the region within a distance of curves and polygons on the sphere.

Exact vector offsets made of small-circle arcs, a float64 reference for distances
and membership, and (in later modules) GPU rasters. Distances are angles inside;
metres appear only through the ``radius`` keyword.
"""

from __future__ import annotations

__version__ = "0.1.0"

from . import errors, grids, tiles
from .contains import Index, contains
from .errors import *  # noqa: F403  (every exception class, listed in errors.__all__)
from .multires import Decomposition, decompose
from .offset import Offset, offset
from .raster_input import raster_offset, rasterize
from .reference import distance
from .render import render
from .selfintersect import ResolvedOffset
from .shape import Shape, read
from .units import EARTH_RADIUS, parse_distance

__all__ = [
    "EARTH_RADIUS",
    "Index",
    "Decomposition",
    "Offset",
    "ResolvedOffset",
    "Shape",
    "__version__",
    "contains",
    "decompose",
    "distance",
    "offset",
    "parse_distance",
    "raster_offset",
    "rasterize",
    "read",
    "render",
    "grids",
    "tiles",
    *errors.__all__,
]
