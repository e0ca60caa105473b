"""What every grid shares: the level hierarchy, and for grids whose rows are parallels
and whose columns are meridians (equirectangular, web mercator) the cell centres and
the bounds rho.

Levels. Level ``L = n_levels - 1`` is the output; a cell of level ``l`` is the block
of ``2^(L-l) x 2^(L-l)`` output pixels with corner at ``(i, j) 2^(L-l)`` (blocks at
the east and south edges are not clipped, so their centres may lie past the edge;
that changes nothing). Its centre is given by the grid's own formula at fractional
pixel indices.

Bounds rho. ``rho(l)[j]`` bounds, for every cell of row ``j`` of level ``l``, the
distance from the cell centre to every point of the cell and to every point within
``rho`` of any descendant's centre: ``rho_l >= max(area bound, angle(centre, child
centre) + rho_child)``. The second term makes candidate lists shrink from parent to
child; at the output level ``rho = 0`` (pixels are decided at their centres). All
float64, rounded up by a relative 1e-12.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InvalidGridError
from ..geometry.caps import pad
from ..geometry.sphere import angle
from ..memo import once_attr
from .protocol import GlslCentres

__all__ = [
    "InvalidGridError",
    "LevelHierarchy",
    "LonLatGrid",
    "Square",
    "COARSE_CELLS",
    "BIN_PIXELS",
]

#: The coarsest level has at most this many cells on its longer side.
COARSE_CELLS = 32
#: Output pixels per side of a bin (the level below which the GPU takes over).
BIN_PIXELS = 16
#: Offset distances of at least this many pixels get bins twice as wide (``bin_level_for``).
WIDE_BINS_FROM = 6


class LevelHierarchy:
    """The level hierarchy of a ``width x height`` grid (subclasses set both).

    Subclasses declare their capabilities (:mod:`gloffset.grids.protocol`): ``lonlat``
    when rows are parallels and columns meridians (they then offer ``cell_lat``,
    ``cell_lon``, ``pixel_lat``, ``pixel_lon``), ``subgrids`` when they can be cut into
    parts (:meth:`subgrid`), ``curve_masks`` when rasterized curves live on them
    (:meth:`cell_set`). Each is an image of one face (``n_faces``, :attr:`faces`): itself.
    """

    if TYPE_CHECKING:
        # what subclasses provide: the size (dataclass fields, or :class:`Square`'s
        # properties) and the bounds of their cells

        @property
        def width(self) -> int: ...

        @property
        def height(self) -> int: ...

        def rho(self, level: int) -> np.ndarray: ...

    lonlat = False
    #: how the GPU levels get the cell centres (:mod:`gloffset.grids.protocol`):
    #: ``"texture"`` (made on the host from :meth:`centers`) unless a grid has a GLSL form
    centres = "texture"
    n_faces = 1
    subgrids = False
    curve_masks = False

    @property
    def faces(self) -> tuple:
        """The faces of the image: the grid itself."""
        return (self,)

    def subgrid(self, x0: int, y0: int, w: int, h: int):
        """The pixels ``[x0, x0+w) x [y0, y0+h)`` as a grid of their own (grids with
        ``subgrids``; the others raise :class:`InvalidGridError`)."""
        raise InvalidGridError(f"a {type(self).__name__} cannot be cut into parts")

    @property
    def shape(self) -> tuple[int, int]:
        return (self.height, self.width)

    @property
    def n_levels(self) -> int:
        side = max(self.width, self.height)
        if side <= COARSE_CELLS:
            return 1
        return 1 + math.ceil(math.log2(side / COARSE_CELLS))

    @property
    def bin_level(self) -> int:
        """The level whose cells are bins (``BIN_PIXELS`` output pixels on a side)."""
        return max(0, self.n_levels - 1 - int(math.log2(BIN_PIXELS)))

    def bin_level_for(self, e: float) -> int:
        """The bin level for an offset distance ``e`` (radians): bins of ``2 BIN_PIXELS``
        pixels when ``e`` spans at least :data:`WIDE_BINS_FROM` pixels, else
        :attr:`bin_level`. Wider bins leave fewer frontier bins to the float64 levels
        and to the arc records, at the cost of one more GPU level; that pays once the
        offset band is several pixels wide (Mexico at 127 km, 4096 x 2048: 0.040 to
        0.033 s), not for thin bands."""
        last = self.n_levels - 1
        if self.bin_level == 0 or last < 1:
            return self.bin_level
        pixel = float(np.max(self.rho(last - 1))) / math.sqrt(2.0)  # 2 x 2 pixel cells
        return self.bin_level - 1 if e >= WIDE_BINS_FROM * pixel else self.bin_level

    def block(self, level: int) -> int:
        """Output pixels per side of a cell of ``level``."""
        return 1 << (self.n_levels - 1 - level)

    def level_shape(self, level: int) -> tuple[int, int]:
        b = self.block(level)
        return (-(-self.height // b), -(-self.width // b))

    def rho_at(self, level: int, j, i) -> np.ndarray:
        """The bound of cells (``j``, ``i``) of ``level``."""
        return self.rho(level)[np.asarray(j)] + 0.0 * np.asarray(i)

    def texture_centers(self, level: int, j, i) -> np.ndarray:
        """The cell centres the GPU levels read from textures (``centres`` is
        ``"texture"``): :meth:`centers`, or a faster float64 twin of them."""
        return self.centers(level, j, i)  # type: ignore[attr-defined]

    def glsl_centres(self) -> GlslCentres:
        """The GLSL function of the cell centres, of grids whose ``centres`` is
        ``"glsl"`` (:class:`~gloffset.grids.protocol.GlslCentres`); the others raise."""
        raise InvalidGridError(f"a {type(self).__name__} has no GLSL function of its centres")

    def valid(self, level: int) -> np.ndarray | None:
        """Per cell of ``level``: whether a pixel of it has a place on the sphere; None
        when every pixel has (every grid but a projection with a limited domain)."""
        return None

    def decision_rho(self, level: int, j, i) -> np.ndarray:
        """The bound a cell is decided with: :meth:`rho_at` (a grid whose decisions need
        only the cell's own points, not its descendants' lists, overrides it)."""
        return self.rho_at(level, j, i)


class Square:
    """Mixin for ``size x size`` grids (cube faces, map tiles)."""

    size: int

    @property
    def width(self) -> int:
        return int(self.size)

    @property
    def height(self) -> int:
        return int(self.size)


def rect_radius(dlon_half, lat_c, lat1, lat2) -> np.ndarray:
    """Largest angle from (0, lat_c) to the lon/lat rectangle |lon| <= dlon_half, lat1..lat2.

    Exact: on a parallel the distance grows with the longitude difference, so the
    farthest point lies on a meridian edge, where cos(angle) = r cos(lat - phi0) is
    smallest at an end of the interval or at the one critical latitude inside it.
    """
    dl = np.minimum(dlon_half, math.pi)
    a = np.sin(lat_c)
    b = np.cos(lat_c) * np.cos(dl)
    phi0 = np.arctan2(a, b)
    cands = [lat1, lat2]
    for k in (-1.0, 1.0):
        crit = phi0 + k * math.pi
        cands.append(np.where((crit > lat1) & (crit < lat2), crit, lat1))
    lat = np.stack(cands)
    cosang = a * np.sin(lat) + b * np.cos(lat)
    return np.arccos(np.clip(cosang.min(axis=0), -1.0, 1.0))


class LonLatGrid(LevelHierarchy):
    """A grid whose rows are parallels and columns meridians.

    Subclasses give the latitude of a (fractional) row and the longitude of a
    (fractional) column of output pixels, in radians: ``pixel_lat(y)``, ``pixel_lon(x)``.
    Cells are addressed as ``(row, column)`` or by flat index ``row * width + column``
    of their level.
    """

    lonlat = True
    centres = "lonlat"

    def pixel_lat(self, y):  # pragma: no cover - abstract
        """Latitude (radians) at fractional output-pixel row ``y`` (0: the northern edge)."""
        raise NotImplementedError

    def pixel_lon(self, x):  # pragma: no cover - abstract
        """Longitude (radians) at fractional output-pixel column ``x`` (0: the western edge)."""
        raise NotImplementedError

    def wraps(self, level: int) -> bool:
        """Whether the columns of ``level`` go round the globe (column 0 is east of the last)."""
        return False

    def pixel_size(self) -> float:
        """The largest angular diameter (rad) of a pixel of the grid (twice the farthest
        point of a pixel from its centre)."""
        return 2.0 * float(np.max(self._area(self.n_levels - 1)))

    def cell_set(self):
        """The output pixels as one set of cells: the grid itself."""
        return self

    def cell_lat(self, level: int, j) -> np.ndarray:
        """Latitude (radians) of the centres of row ``j`` of ``level``."""
        return self.pixel_lat((np.asarray(j, dtype=np.float64) + 0.5) * self.block(level))

    def cell_lon(self, level: int, i) -> np.ndarray:
        """Longitude (radians) of the centres of column ``i`` of ``level``."""
        return self.pixel_lon((np.asarray(i, dtype=np.float64) + 0.5) * self.block(level))

    def centers(self, level: int, j, i) -> np.ndarray:
        """Unit vectors of the centres of cells (row ``j``, column ``i``) of ``level``."""
        lam, phi = np.broadcast_arrays(self.cell_lon(level, i), self.cell_lat(level, j))
        cphi = np.cos(phi)
        return np.stack([cphi * np.cos(lam), cphi * np.sin(lam), np.sin(phi)], axis=-1)

    def rho(self, level: int) -> np.ndarray:
        """Per-row bound (radians) for ``level`` (see the module notes)."""
        return once_attr(self, "_rho_cache", self._rhos)[level]

    def _area(self, level: int) -> np.ndarray:
        """Per row of ``level``: the farthest point of a cell's lon/lat rectangle from its
        centre (exact, :func:`rect_radius`; not rounded up)."""
        h = self.level_shape(level)[0]
        j = np.arange(h, dtype=np.float64)
        b = self.block(level)
        phi = self.cell_lat(level, j)
        north = self.pixel_lat(j * b)
        south = self.pixel_lat((j + 1) * b)
        dlon_half = 0.5 * abs(float(self.pixel_lon(b) - self.pixel_lon(0)))
        return rect_radius(
            np.full(h, dlon_half), phi, np.minimum(north, south), np.maximum(north, south)
        )

    def rho_cells(self, level: int, flat) -> np.ndarray:
        """The bound rho of cells ``flat`` (flat indices) of ``level``."""
        return self.rho(level)[np.asarray(flat, dtype=np.int64) // self.level_shape(level)[1]]

    def area_rho_cells(self, level: int, flat) -> np.ndarray:
        """The area bound of cells ``flat`` of ``level``: the farthest point of the cell
        from its centre (the paper's ``d_g / 2`` at the output level), rounded up."""
        rows = np.asarray(flat, dtype=np.int64) // self.level_shape(level)[1]
        return pad(self._area(level))[rows]

    def row_valid(self, level: int) -> np.ndarray:
        """Per row of ``level``: whether it holds cells (every row does)."""
        return np.ones(self.level_shape(level)[0], dtype=bool)

    def neighbour_table(self, level: int, flat) -> np.ndarray:
        """(len(flat), 8) flat indices of the 8-neighbours of cells ``flat`` of ``level``
        (rows -1, 0, 1 by columns -1, 0, 1, the cell itself left out; across the
        antimeridian where :meth:`wraps`); -1 where none."""
        h, w = self.level_shape(level)
        j, i = np.divmod(np.asarray(flat, dtype=np.int64), w)
        wrap = self.wraps(level)
        out = np.full((len(j), 8), -1, dtype=np.int64)
        k = 0
        for dj in (-1, 0, 1):
            for di in (-1, 0, 1):
                if dj == 0 and di == 0:
                    continue
                jj, ii = j + dj, i + di
                if wrap:
                    ii = ii % w
                ok = (jj >= 0) & (jj < h) & (ii >= 0) & (ii < w)
                out[ok, k] = jj[ok] * w + ii[ok]
                k += 1
        return out

    def neighbours(self, level: int, flat) -> np.ndarray:
        """The 8-neighbours (flattened, unique) of cells ``flat`` of ``level``."""
        nb = self.neighbour_table(level, flat).ravel()
        return np.unique(nb[nb >= 0])

    def adjacent(self, level: int, a, b) -> np.ndarray:
        """Whether cells ``a`` and ``b`` of ``level`` (arrays) touch (or are the same)."""
        w = self.level_shape(level)[1]
        ja, ia = np.divmod(np.asarray(a, dtype=np.int64), w)
        jb, ib = np.divmod(np.asarray(b, dtype=np.int64), w)
        di = np.abs(ia - ib)
        if self.wraps(level):
            di = np.minimum(di, w - di)
        return (np.abs(ja - jb) <= 1) & (di <= 1)

    def _rhos(self) -> list[np.ndarray]:
        n = self.n_levels
        out: list = [None] * n
        out[n - 1] = np.zeros(self.level_shape(n - 1)[0])
        for lev in range(n - 2, -1, -1):
            h = self.level_shape(lev)[0]
            j = np.arange(h, dtype=np.float64)
            area = self._area(lev)
            c = self.centers(lev, j, 0)
            hier = np.zeros(h)
            child = out[lev + 1]
            for dj in (0, 1):
                cj = np.minimum(2 * j.astype(np.int64) + dj, len(child) - 1)
                for di in (0, 1):
                    cc = self.centers(lev + 1, 2 * j + dj, di)
                    hier = np.maximum(hier, angle(c, cc) + child[cj])
            out[lev] = pad(np.maximum(area, hier))
        return out


def check_size(width, height) -> tuple[int, int]:
    if not (isinstance(width, (int, np.integer)) and isinstance(height, (int, np.integer))):
        raise InvalidGridError(f"grid size must be integers, got {width!r} x {height!r}")
    if width < 1 or height < 1:
        raise InvalidGridError(f"grid size must be positive, got {width} x {height}")
    return int(width), int(height)
