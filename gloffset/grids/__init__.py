"""Raster grids: pixel centres, the level hierarchy and per-cell bounds rho.

``Equirect`` (lon/lat plate carree), ``Tile`` (web-mercator XYZ tile), ``Cube`` and
``CubeFace`` (GL cube maps).
"""

from .base import InvalidGridError
from .cube import FACE_NAMES, Cube, CubeFace, locate
from .equirect import Equirect
from .mercator import Tile

__all__ = ["Cube", "CubeFace", "Equirect", "FACE_NAMES", "InvalidGridError", "Tile", "locate"]
