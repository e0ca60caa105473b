"""What the raster engine needs of a grid: the :class:`Grid` protocol.

A grid is a hierarchy of levels ``0`` (coarse) .. ``n_levels - 1`` (the output); a cell
of level ``l`` covers ``block(l) x block(l)`` output pixels. The level driver
(:mod:`gloffset.raster.driver`) and the classifiers ask a grid only what is written
here. Optional capabilities are declared, not probed: a grid says whether its rows are
parallels (``lonlat``; then it is a :class:`LonLatCells`) and whether its bound differs
along a row (``per_cell_rho``). Algorithms on sets of cells (the offsets of rasterized
curves) need a :class:`CellSet` as well.

Implementations: :class:`~gloffset.grids.Equirect`, :class:`~gloffset.grids.Tile`
(lon/lat rows), :class:`~gloffset.grids.CubeFace`, the six faces as one cell set
(:class:`~gloffset.grids.cube.CubeCells`) and the XYZ tile quadtree
(:class:`~gloffset.grids.mercator.TilePyramid`, level = zoom).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Grid", "LonLatCells", "CellSet"]


@runtime_checkable
class Grid(Protocol):
    """A level hierarchy with cell centres and rigorous bounds (see :mod:`gloffset.grids`)."""

    #: rows are parallels and columns meridians (the grid is a :class:`LonLatCells`)
    lonlat: bool
    #: the bound rho differs along a row (``rho(level)`` is then the row's largest)
    per_cell_rho: bool

    @property
    def n_levels(self) -> int: ...

    def level_shape(self, level: int) -> tuple[int, int]:
        """``(rows, columns)`` of ``level``."""
        ...

    def centers(self, level: int, j, i) -> np.ndarray:
        """Unit vectors (..., 3) of the centres of cells (row ``j``, column ``i``)."""
        ...

    def rho(self, level: int) -> np.ndarray:
        """Per-row bound (radians): the largest distance from a cell's centre to any point
        of the cell and to any point within the bound of a descendant's centre; 0 at the
        output level."""
        ...

    def rho_at(self, level: int, j, i) -> np.ndarray:
        """The bound of cells (``j``, ``i``) of ``level``."""
        ...


class LonLatCells(Grid, Protocol):
    """A grid whose rows are parallels and columns meridians (``lonlat`` is True)."""

    def cell_lat(self, level: int, j) -> np.ndarray:
        """Latitude (radians) of the centres of rows ``j`` of ``level``."""
        ...

    def cell_lon(self, level: int, i) -> np.ndarray:
        """Longitude (radians) of the centres of columns ``i`` of ``level``."""
        ...


class CellSet(Grid, Protocol):
    """A grid that algorithms on cell sets walk (flat indices ``row * columns + column``)."""

    @property
    def bin_level(self) -> int: ...

    def neighbour_table(self, level: int, flat) -> np.ndarray:
        """Per cell, the flat indices of the cells that touch it (-1 where none), in a
        fixed order."""
        ...

    def neighbours(self, level: int, flat) -> np.ndarray:
        """The cells (unique, sorted) that touch cells ``flat``."""
        ...

    def adjacent(self, level: int, a, b) -> np.ndarray:
        """Whether cells ``a`` and ``b`` (arrays) touch or are the same."""
        ...

    def row_valid(self, level: int) -> np.ndarray:
        """Per row: whether it holds cells (padding rows hold none)."""
        ...

    def rho_cells(self, level: int, flat) -> np.ndarray:
        """The bound rho of cells ``flat``."""
        ...

    def area_rho_cells(self, level: int, flat) -> np.ndarray:
        """The area bound (farthest point of the cell from its centre) of cells ``flat``."""
        ...
