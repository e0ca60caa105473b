"""Raster grids: pixel centres, the level hierarchy and per-cell bounds rho."""

from .equirect import Equirect, InvalidGridError

__all__ = ["Equirect", "InvalidGridError"]
