"""Raster grids: pixel centres, the level hierarchy and per-cell bounds rho.

``Equirect`` (lon/lat plate carree), ``Tile`` (web-mercator XYZ tile), ``TmsTile`` (a
tile of an OGC TileMatrixSet), ``Cube`` and ``CubeFace`` (GL cube maps), ``Projected``
(an image in any projected CRS, pyproj).
"""

from typing import TYPE_CHECKING

from .base import InvalidGridError
from .cube import FACE_NAMES, Cube, CubeFace, locate
from .equirect import Equirect
from .mercator import Tile
from .projected import Projected
from .tms import TmsTile

__all__ = [
    "Cube",
    "CubeFace",
    "Equirect",
    "FACE_NAMES",
    "InvalidGridError",
    "Projected",
    "Tile",
    "TmsTile",
    "locate",
]

if TYPE_CHECKING:  # read by mypy (`mypy gloffset`): every grid answers its protocols
    from .conformal import ConformalRows
    from .cube import CubeCells
    from .mercator import TilePyramid
    from .protocol import (
        CurveMaskImage,
        FaceCells,
        FaceGrid,
        Image,
        ImageGrid,
        LonLatCells,
        RegularLonLat,
        TileLevels,
    )
    from .tms import LonLatTile

    def _answers(
        e: Equirect,
        t: Tile,
        r: ConformalRows,
        f: CubeFace,
        c: Cube,
        cc: CubeCells,
        p: TilePyramid,
        pr: Projected,
        g: LonLatTile,
    ) -> None:
        regular: list[RegularLonLat] = [e]
        lonlat: list[LonLatCells] = [e, t, r, g]
        images: list[Image] = [e, t, r, f, c, pr, g]
        image_grids: list[ImageGrid] = [e, t, r, f, pr, g]
        faces: list[FaceGrid] = [f]
        curve_masks: list[CurveMaskImage] = [e, c, r]
        cell_sets: list[FaceCells] = [cc]
        tiles: list[TileLevels] = [p]
        del regular, lonlat, images, image_grids, faces, curve_masks, cell_sets, tiles
