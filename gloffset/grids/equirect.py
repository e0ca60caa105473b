"""Equirectangular (plate carree) grids.

Pixel ``(i, j)`` (column, row; row 0 north) of a ``width x height`` grid over
``bounds = (W, S, E, N)`` has its centre at

    lon = W + (i + 0.5) (E - W) / width,   lat = N - (j + 0.5) (N - S) / height.

Bounds may cross the antimeridian (``W > E``: the grid runs east from W through
180 deg to E). Levels and the bounds rho are those of :mod:`gloffset.grids.base`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .base import InvalidGridError, LonLatGrid, check_size

__all__ = ["Equirect"]


@dataclass(frozen=True)
class Equirect(LonLatGrid):
    """A ``width x height`` equirectangular grid over ``bounds`` (W, S, E, N) in degrees.

    Examples
    --------
    >>> g = Equirect(360, 180)
    >>> g.pixel_lonlat(0, 0)
    (-179.5, 89.5)
    """

    width: int
    height: int
    bounds: tuple = (-180.0, -90.0, 180.0, 90.0)
    subgrids = True
    curve_masks = True

    def __post_init__(self):
        w, h = check_size(self.width, self.height)
        try:
            b = tuple(float(x) for x in self.bounds)
        except (TypeError, ValueError):
            raise InvalidGridError(
                f"bounds must be 4 numbers W,S,E,N, got {self.bounds!r}"
            ) from None
        if len(b) != 4 or not all(math.isfinite(x) for x in b):
            raise InvalidGridError(f"bounds must be 4 finite numbers W,S,E,N, got {self.bounds!r}")
        west, south, east, north = b
        if not (-90.0 <= south < north <= 90.0):
            raise InvalidGridError(f"bounds need -90 <= S < N <= 90, got S={south}, N={north}")
        if not (-180.0 <= west <= 180.0 and -180.0 <= east <= 180.0) or west == east:
            raise InvalidGridError(
                f"bounds need W and E in [-180, 180] and W != E, got W={west}, E={east}"
            )
        object.__setattr__(self, "bounds", b)
        object.__setattr__(self, "width", w)
        object.__setattr__(self, "height", h)

    # ------------------------------------------------------------------ geometry
    @property
    def span_lon(self) -> float:
        """Degrees of longitude covered (E - W, plus 360 across the antimeridian)."""
        w, _, e, _ = self.bounds
        return e - w if e > w else e - w + 360.0

    @property
    def dlon(self) -> float:
        """Pixel width in radians of longitude."""
        return math.radians(self.span_lon) / self.width

    @property
    def dlat(self) -> float:
        """Pixel height in radians of latitude."""
        return math.radians(self.bounds[3] - self.bounds[1]) / self.height

    def transform(self) -> tuple:
        """The affine transform of the image in GDAL order ``(a, b, c, d, e, f)``, lon/lat
        degrees at pixel *edges* (``x = a col + c``, ``y = e row + f``): what GeoTIFFs and
        rasterio use. Across 180 degrees the longitudes continue past 180 (west 170,
        east 190): each pixel centre is :meth:`pixel_lonlat`'s modulo 360."""
        west, south, _, north = self.bounds
        return (self.span_lon / self.width, 0.0, west, 0.0, -(north - south) / self.height, north)

    def pixel_lonlat(self, i, j):
        """Centre (lon, lat) in degrees of pixel column ``i``, row ``j`` (fractional allowed)."""
        w, s, e, n = self.bounds
        lon = w + (np.asarray(i, dtype=np.float64) + 0.5) * self.span_lon / self.width
        lat = n - (np.asarray(j, dtype=np.float64) + 0.5) * (n - s) / self.height
        lon = (lon + 180.0) % 360.0 - 180.0
        lon, lat = np.broadcast_arrays(lon, lat)
        if lon.ndim == 0:
            return float(lon), float(lat)
        return lon, lat

    def pixel_lat(self, y):
        return math.radians(self.bounds[3]) - np.asarray(y, dtype=np.float64) * self.dlat

    def pixel_lon(self, x):
        return math.radians(self.bounds[0]) + np.asarray(x, dtype=np.float64) * self.dlon

    def wraps(self, level: int) -> bool:
        """Whether the columns of ``level`` go round the globe: the grid spans 360 degrees
        of longitude and the level's cells tile the width exactly."""
        if abs(self.span_lon - 360.0) > 1e-9:
            return False
        return self.level_shape(level)[1] * self.block(level) == self.width

    def subgrid(self, x0: int, y0: int, w: int, h: int) -> Equirect:
        """The pixels ``[x0, x0+w) x [y0, y0+h)`` as a grid of their own (same pixel centres)."""
        west, south, east, north = self.bounds
        lon0 = west + x0 * self.span_lon / self.width
        lon1 = west + (x0 + w) * self.span_lon / self.width
        lat1 = north - y0 * (north - south) / self.height
        lat0 = north - (y0 + h) * (north - south) / self.height

        def wrap(x):
            return x if -180.0 <= x <= 180.0 else (x + 180.0) % 360.0 - 180.0

        return Equirect(w, h, (wrap(lon0), max(lat0, -90.0), wrap(lon1), min(lat1, 90.0)))
