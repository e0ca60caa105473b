"""What the raster engine needs of a grid: the :class:`Grid` protocol and its capabilities.

A grid is a hierarchy of levels ``0`` (coarse) .. ``n_levels - 1`` (the output); a cell
of level ``l`` covers ``block(l) x block(l)`` output pixels. The level driver
(:mod:`gloffset.raster.driver`), the classifiers, the renders and the pyramids ask a grid
only what is written here. Optional capabilities are declared, not probed: a grid says
whether its rows are parallels (``lonlat``; then it is a :class:`LonLatCells`), an image
how many faces it has (``n_faces``: a :class:`~gloffset.grids.Cube` is an image of six
faces, every other image one, itself), whether it can be cut into parts (``subgrids``)
and whether curve masks live on it (``curve_masks``: :func:`gloffset.rasterize` and
:func:`gloffset.raster_offset`). Algorithms on sets of cells (the offsets of rasterized
curves) need a :class:`CellSet` as well.

The protocols, and the grids that answer them:

* :class:`Grid`: every level hierarchy below;
* :class:`LonLatCells`: :class:`~gloffset.grids.Equirect`, :class:`~gloffset.grids.Tile`,
  :class:`~gloffset.grids.conformal.ConformalRows`; :class:`RegularLonLat` (rows and
  columns evenly spaced, what a curve mask is rasterized on): Equirect;
* :class:`Image` (what :func:`gloffset.render` takes): those three, CubeFace and Cube;
  :class:`ImageGrid` (one face of an image, the grid a render draws): every image but
  Cube; :class:`FaceGrid` (a face of a cube): :class:`~gloffset.grids.CubeFace`;
  :class:`CurveMaskImage` (``curve_masks``): Equirect, Cube and ConformalRows;
* :class:`CellSet`: the lon/lat grids and the six faces of a cube as one set of cells
  (:class:`~gloffset.grids.cube.CubeCells`, a :class:`FaceCells`);
* :class:`TileLevels`: the XYZ tile quadtree (:class:`~gloffset.grids.mercator.TilePyramid`,
  level = zoom).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = [
    "GlslCentres",
    "Grid",
    "LonLatCells",
    "RegularLonLat",
    "Image",
    "ImageGrid",
    "FaceGrid",
    "CurveMaskImage",
    "CellSet",
    "FaceCells",
    "TileLevels",
]


@runtime_checkable
class Grid(Protocol):
    """A level hierarchy with cell centres and rigorous bounds (see :mod:`gloffset.grids`)."""

    #: rows are parallels and columns meridians (the grid is a :class:`LonLatCells`)
    lonlat: bool

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
        output level. Where the bound differs along a row, the row's largest."""
        ...

    def rho_at(self, level: int, j, i) -> np.ndarray:
        """The bound of cells (``j``, ``i``) of ``level``."""
        ...

    def decision_rho(self, level: int, j, i) -> np.ndarray:
        """The bound a cell is decided with (at most :meth:`rho_at`)."""
        ...


@runtime_checkable
class LonLatCells(Grid, Protocol):
    """A grid whose rows are parallels and columns meridians (``lonlat`` is True)."""

    def cell_lat(self, level: int, j) -> np.ndarray:
        """Latitude (radians) of the centres of rows ``j`` of ``level``."""
        ...

    def cell_lon(self, level: int, i) -> np.ndarray:
        """Longitude (radians) of the centres of columns ``i`` of ``level``."""
        ...

    def wraps(self, level: int) -> bool:
        """Whether the columns of ``level`` go round the sphere (column 0 follows the
        last)."""
        ...

    def pixel_size(self) -> float:
        """The largest angular diameter (rad) of a pixel (twice the farthest point of a
        pixel from its centre)."""
        ...


@runtime_checkable
class RegularLonLat(LonLatCells, Protocol):
    """A lon/lat grid whose rows and columns are evenly spaced in latitude and longitude
    (equirectangular), from the west and north edges of ``bounds``."""

    #: rasterized curves live on it (:class:`CurveMaskImage`)
    curve_masks: bool

    @property
    def bounds(self) -> tuple: ...

    @property
    def dlon(self) -> float: ...

    @property
    def dlat(self) -> float: ...

    @property
    def width(self) -> int: ...

    @property
    def height(self) -> int: ...


@runtime_checkable
class Image(Protocol):
    """What a render covers: one or more faces (:class:`ImageGrid`), rendered each on its
    own and stacked (``(n_faces, rows, columns)``) when there are several."""

    #: faces of the image: 6 for a cube, 1 (the grid itself) for every other image
    n_faces: int
    #: rasterized curves live on it (:class:`CurveMaskImage`)
    curve_masks: bool

    @property
    def faces(self) -> Sequence[ImageGrid]:
        """The faces, in order (the grid itself when there is one)."""
        ...

    @property
    def shape(self) -> tuple[int, ...]:
        """The shape of the image's arrays: ``(rows, columns)``, or ``(n_faces, rows,
        columns)`` when there are several faces."""
        ...


@dataclass(frozen=True)
class GlslCentres:
    """A grid's cell centres as a GLSL function: ``source`` (a file of ``shaders/``,
    conventionally ``lib/grids/NAME.glsl``) defines ``dvec3 grid_centre(dvec2 px)``, the
    unit vector (float64) of the point at output-pixel coordinates ``px`` of the grid
    (``(i + 0.5, j + 0.5)`` the centre of pixel ``i, j``), from ``uniform double
    u_grid[16]``, which the engine sets to ``constants`` (at most 16). The GPU levels
    take each cell's centre minus its bin's (made on the host in float64) in double,
    then cast it: the function must be within :meth:`centers` by less than the slack the
    grid's bounds ``rho`` keep at the coarse levels and, at the output level, well
    within 1e-3 of a pixel (:func:`gloffset.render`'s contract), with double add,
    multiply and fma only
    (``lib/fp64.glsl``: GLSL promises no precision for double division or sqrt)."""

    source: str
    constants: tuple[float, ...]


@runtime_checkable
class ImageGrid(Grid, Image, Protocol):
    """One face of an image: the output pixels a render draws, its levels and bins."""

    #: the grid can be cut into parts (:meth:`subgrid`)
    subgrids: bool
    #: how the GPU levels get the cell centres: ``"lonlat"`` (rows and columns from
    #: their latitude and longitude, ``lib/lonlat.glsl``), ``"cube"`` (a cube face,
    #: ``lib/cube.glsl``), ``"glsl"`` (the grid's own GLSL function,
    #: :meth:`glsl_centres`) or ``"texture"`` (each cell's centre minus its bin's, made on
    #: the host from :meth:`centers` in float64: any grid)
    centres: str

    @property
    def width(self) -> int: ...

    @property
    def height(self) -> int: ...

    @property
    def bin_level(self) -> int:
        """The level whose cells are bins (16 output pixels on a side)."""
        ...

    def bin_level_for(self, e: float) -> int:
        """The bin level for an offset distance ``e`` (radians)."""
        ...

    def block(self, level: int) -> int:
        """Output pixels per side of a cell of ``level``."""
        ...

    def subgrid(self, x0: int, y0: int, w: int, h: int) -> ImageGrid:
        """The ``w x h`` pixels from column ``x0``, row ``y0`` as a grid of their own
        (where ``subgrids``)."""
        ...

    def texture_centers(self, level: int, j, i) -> np.ndarray:
        """The cell centres that textured GPU levels read: :meth:`centers` or a float64
        twin of them (a few 1e-13 rad apart at most)."""
        ...

    def valid(self, level: int) -> np.ndarray | None:
        """Per cell of ``level``: whether a pixel of it has a place on the sphere (a
        projection's domain); None when all have. Pixels without one are outside."""
        ...

    def glsl_centres(self) -> GlslCentres:
        """The GLSL function of the cell centres (grids whose ``centres`` is
        ``"glsl"``)."""
        ...


@runtime_checkable
class FaceGrid(ImageGrid, Protocol):
    """A face of a cube (``lonlat`` is False): square, its pixels' bound differs along a
    row."""

    @property
    def size(self) -> int: ...

    @property
    def basis(self) -> np.ndarray:
        """(3, 3): the face's axis and its s and t directions (the cube-map table)."""
        ...

    def area_rho_at(self, level: int, j, i) -> np.ndarray:
        """The area bound (farthest point of the cell from its centre) of cells (``j``,
        ``i``)."""
        ...


@runtime_checkable
class CellSet(Grid, Protocol):
    """A grid that algorithms on cell sets walk (flat indices ``row * columns + column``)."""

    @property
    def bin_level(self) -> int: ...

    def block(self, level: int) -> int:
        """Output pixels per side of a cell of ``level``."""
        ...

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


@runtime_checkable
class FaceCells(CellSet, Protocol):
    """The faces of a multi-face image as one set of cells (``lonlat`` is False): faces
    stacked as rows, each ``size x size`` at the output level."""

    #: per level, the rows of a face (its cells' rows, then padding rows that hold none)
    P: list[int]

    @property
    def size(self) -> int: ...

    def split(self, level: int, flat) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(face, row, column)`` of cells ``flat`` of ``level``."""
        ...

    def face_axes(self, face: int) -> tuple[tuple, tuple, tuple]:
        """The axis and the s and t directions of ``face``."""
        ...

    def stack(self, faces: np.ndarray) -> np.ndarray:
        """An image's ``(n_faces, size, size)`` array as this grid's output level."""
        ...

    def unstack(self, level: int, cells: np.ndarray) -> np.ndarray:
        """The classes of ``level`` as ``(n_faces, rows, columns)``."""
        ...

    def from_faces_flat(self, flat) -> np.ndarray:
        """Flat indices of the image's ``(n_faces, size, size)`` array as this grid's."""
        ...


@runtime_checkable
class CurveMaskImage(Image, Protocol):
    """An image that curve masks live on (``curve_masks`` is True)."""

    def cell_set(self) -> CellSet:
        """The output pixels as one set of cells: the grid itself, or for several faces
        their :class:`FaceCells` (made once)."""
        ...


@runtime_checkable
class TileLevels(Grid, Protocol):
    """The XYZ tile quadtree as levels (level = zoom): rows of tiles are parallels bounded
    by the web-mercator latitudes."""

    def tile_lat(self, z: int, yy) -> np.ndarray:
        """Latitude (radians) at tile-row position ``yy`` (fractional) of zoom ``z``."""
        ...

    def tile_lon(self, z: int, xx) -> np.ndarray:
        """Longitude (radians) at tile-column position ``xx`` (fractional) of zoom ``z``."""
        ...
