"""Web-mercator XYZ tiles as grids.

``Tile(z, x, y, size=256)`` is the tile ``z/x/y`` (y = 0 at the north, as XYZ map
tiles) of ``size x size`` pixels, with pixel centres equally spaced in mercator
space: pixel ``(i, j)`` has

    lon = -180 + 360 (x size + i + 0.5) / (2^z size)
    lat = gd(pi (1 - 2 (y size + j + 0.5) / (2^z size)))   (gd(v) = atan(sinh(v)))

so mercator stops at +-85.0511 deg. Tile bounds come from mercantile. Levels and the
bounds rho are those of :mod:`gloffset.grids.base`; mercator coordinates are in
float64, so pixel centres are exact to 1e-16 rad at every zoom up to 30.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mercantile
import numpy as np

from .base import InvalidGridError, LonLatGrid, Square, check_size

__all__ = ["Tile", "MAX_ZOOM"]

MAX_ZOOM = 30


@dataclass(frozen=True)
class Tile(Square, LonLatGrid):
    """The XYZ tile ``z/x/y`` as a ``size x size`` grid.

    Examples
    --------
    >>> t = Tile(1, 0, 0)
    >>> [round(v, 4) for v in t.bounds]
    [-180.0, 0.0, 0.0, 85.0511]
    """

    z: int
    x: int
    y: int
    size: int = 256

    def __post_init__(self):
        for name in ("z", "x", "y"):
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)):
                raise InvalidGridError(f"tile {name} must be an integer, got {v!r}")
        if not 0 <= self.z <= MAX_ZOOM:
            raise InvalidGridError(f"zoom must be in 0..{MAX_ZOOM}, got {self.z}")
        n = 1 << self.z
        if not (0 <= self.x < n and 0 <= self.y < n):
            raise InvalidGridError(
                f"tile {self.z}/{self.x}/{self.y} does not exist: x and y must be in 0..{n - 1}"
            )
        check_size(self.size, self.size)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(W, S, E, N) in degrees (mercantile)."""
        b = mercantile.bounds(mercantile.Tile(int(self.x), int(self.y), int(self.z)))
        return (b.west, b.south, b.east, b.north)

    def _px_per_world(self) -> float:
        return float((1 << self.z) * self.size)

    def _lon_px(self, xx):
        n = self._px_per_world()
        return (
            -math.pi + 2.0 * math.pi * (self.x * self.size + np.asarray(xx, dtype=np.float64)) / n
        )

    def _lat_px(self, yy):
        n = self._px_per_world()
        v = math.pi * (1.0 - 2.0 * (self.y * self.size + np.asarray(yy, dtype=np.float64)) / n)
        return np.arctan(np.sinh(v))

    def pixel_lonlat(self, i, j):
        """Centre (lon, lat) in degrees of pixel column ``i``, row ``j``."""
        lon = np.degrees(self._lon_px(np.asarray(i, dtype=np.float64) + 0.5))
        lat = np.degrees(self._lat_px(np.asarray(j, dtype=np.float64) + 0.5))
        return lon, lat

    def children(self) -> list[Tile]:
        """The four tiles of zoom z + 1 inside this one."""
        return [Tile(c.z, c.x, c.y, self.size) for c in mercantile.children(self.x, self.y, self.z)]
