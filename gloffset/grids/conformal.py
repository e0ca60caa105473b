"""A lon/lat grid seen on the conformal sphere of an ellipsoid: :class:`ConformalRows`.

On the ellipsoid a grid's latitudes are geodetic. The conformal sphere of the ellipsoid
(:mod:`gloffset.ellipsoid.model`) keeps longitudes and maps each geodetic latitude to
its conformal latitude, monotonically, so a grid whose rows are parallels and columns
meridians is still one there: the same pixels, each row at the conformal latitude of
its geodetic one. :class:`ConformalRows` is that grid. Its cell centres are the images
of the pixel centres, and its bounds rho are those of the image cells (a cell's image
is the lon/lat rectangle between the images of its edges, and
:meth:`~gloffset.grids.base.LonLatGrid._area` is exact for such rectangles), so the
spherical renderer runs on it unchanged: a pixel of ``render(shape_image, t,
ConformalRows(grid, ell))`` is the spherical answer at the image of the pixel's centre.
"""

from __future__ import annotations

import numpy as np

from .base import LonLatGrid

__all__ = ["ConformalRows"]


class ConformalRows(LonLatGrid):
    """The lon/lat grid ``grid`` (geodetic latitudes of ``ell``) on the conformal sphere
    (its :meth:`pixel_size` is that of the pixels' images).

    Examples
    --------
    >>> from gloffset.ellipsoid import as_ellipsoid
    >>> from gloffset.grids import Equirect
    >>> g = ConformalRows(Equirect(4, 2), as_ellipsoid("WGS84"))
    >>> round(float(np.degrees(g.cell_lat(g.n_levels - 1, 0))), 4)  # 45 deg geodetic
    44.8077
    """

    width: int
    height: int
    curve_masks = True

    def __init__(self, grid, ell):
        if not grid.lonlat:
            raise TypeError(f"ConformalRows needs a lon/lat grid, got {type(grid).__name__}")
        self.grid, self.ell = grid, ell
        self.width, self.height = int(grid.width), int(grid.height)

    def pixel_lat(self, y):
        return np.radians(self.ell.conformal(np.degrees(self.grid.pixel_lat(y))))

    def pixel_lon(self, x):
        return self.grid.pixel_lon(x)

    def wraps(self, level: int) -> bool:
        return self.grid.wraps(level)

    def __repr__(self) -> str:
        return f"ConformalRows({self.grid!r}, {self.ell})"
