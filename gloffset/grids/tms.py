"""Tiles of an OGC TileMatrixSet (TMS) as grids: :func:`TmsTile`, and :class:`TmsQuad`,
what the tile quadtree of a TMS is on the sphere.

A TMS (OGC 17-083r4) is given as a morecantile ``TileMatrixSet`` or by its identifier
(``"WebMercatorQuad"``, ``"WorldCRS84Quad"``, ``"UPSAntarcticWGS84Quad"``...: the sets
morecantile ships, :func:`tms_ids`). gloffset takes those whose matrices make a
quadtree: zoom ``z`` has ``cols0 2^z x rows0 2^z`` tiles of one size, over the extent of
zoom 0, origin at the top left. Its tiles are grids of three kinds:

* ``WebMercatorQuad``: :class:`~gloffset.grids.Tile` (``TmsTile("WebMercatorQuad", z,
  x, y)`` is ``Tile(z, x, y)``);
* a TMS in a geographic CRS (``WorldCRS84Quad``: two tiles at zoom 0):
  :class:`LonLatTile`, rows parallels and columns meridians evenly spaced over the
  tile's lon/lat bounds: pixel ``(i, j)`` of tile ``z/x/y`` (``size`` pixels a side) has
  its centre at

      lon = W + (E - W) (x size + i + 0.5) / (cols0 2^z size)
      lat = N - (N - S) (y size + j + 0.5) / (rows0 2^z size)

  (``W, S, E, N`` the extent of the TMS; :meth:`TmsQuad.lon_at`, :meth:`TmsQuad.lat_at`
  are the one copy of it, which the pyramids use too);
* a TMS in a projected CRS (the polar ``UPS...Quad``, ``EuropeanETRS89_LAEAQuad``...):
  :class:`~gloffset.grids.Projected` over the tile's bounds in the CRS (morecantile's),
  pixel centres at ``x = xmin + (i + 0.5) (xmax - xmin) / size``, ``y = ymax - (j +
  0.5) (ymax - ymin) / size``.

The CRSs are pyproj's, the matrices morecantile's: neither is written here.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from ..geometry.caps import pad
from .base import InvalidGridError, LonLatGrid, check_size
from .mercator import MAX_ZOOM, Tile
from .projected import Projected
from .stretch import inverse_lipschitz

__all__ = [
    "TmsTile",
    "TmsQuad",
    "LonLatTile",
    "ProjectedQuadLevels",
    "tms_quad",
    "tms_ids",
    "as_tms",
    "WEB_MERCATOR",
]

#: The identifier of the web-mercator TMS (the tiles of :class:`~gloffset.grids.Tile`).
WEB_MERCATOR = "WebMercatorQuad"


def tms_ids() -> list[str]:
    """The identifiers of the TMSs that morecantile ships (sorted)."""
    import morecantile

    return sorted(morecantile.tms.list())


def as_tms(tms, error: type[Exception] = InvalidGridError):
    """``tms`` (a morecantile ``TileMatrixSet`` or its identifier) as a ``TileMatrixSet``;
    raises ``error`` for an unknown identifier (the message lists the known ones)."""
    import morecantile

    if isinstance(tms, morecantile.TileMatrixSet):
        return tms
    if not isinstance(tms, str):
        raise error(f"a TileMatrixSet must be a morecantile TileMatrixSet or its id, got {tms!r}")
    try:
        return _registered(tms)
    except Exception:  # morecantile raises its own InvalidIdentifier
        raise error(
            f"unknown TileMatrixSet {tms!r}: known ones are {', '.join(tms_ids())}"
        ) from None


@functools.lru_cache(maxsize=64)
def _registered(name: str):
    import morecantile

    return morecantile.tms.get(name)


@dataclass(frozen=True)
class TmsQuad:
    """The tile quadtree of a TMS: zoom ``z`` has ``rows0 2^z x cols0 2^z`` tiles of
    ``size`` pixels a side, zooms 0..``maxzoom``; ``kind`` is ``"mercator"``
    (web mercator), ``"lonlat"`` (a geographic CRS; ``bounds`` W, S, E, N in degrees)
    or ``"projected"`` (``bounds`` xmin, ymin, xmax, ymax in the units of ``crs``).
    Hashable: the pyramids keep their levels per quadtree."""

    id: str
    kind: str
    cols0: int
    rows0: int
    size: int
    maxzoom: int
    bounds: tuple[float, float, float, float]
    crs: str
    #: the TMS's OGC JSON document (a TMS given as an object need not be registered)
    doc: str = field(default="", repr=False, compare=False)

    def tms(self):
        """The morecantile ``TileMatrixSet``."""
        return _parsed(self.doc) if self.doc else as_tms(self.id)

    # ------------------------------------------------------------ lon/lat quadtrees
    def lon_at(self, pos, n) -> np.ndarray:
        """Longitude (radians) at column position ``pos`` (fractional) of ``n`` columns
        over the extent."""
        west, _, east, _ = self.bounds
        p = np.asarray(pos, dtype=np.float64) / n
        return np.radians(west + (east - west) * p)

    def lat_at(self, pos, n) -> np.ndarray:
        """Latitude (radians) at row position ``pos`` (fractional, 0 north) of ``n`` rows
        over the extent."""
        _, south, _, north = self.bounds
        p = np.asarray(pos, dtype=np.float64) / n
        return np.radians(north - (north - south) * p)

    def matrix_shape(self, z: int) -> tuple[int, int]:
        """``(rows, columns)`` of tiles at zoom ``z``."""
        return (self.rows0 << z, self.cols0 << z)

    def check_tile(self, z, x, y, error: type[Exception] = InvalidGridError) -> None:
        """Raise ``error`` unless ``z/x/y`` is a tile of the quadtree."""
        for name, v in (("z", z), ("x", x), ("y", y)):
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool):
                raise error(f"tile {name} must be an integer, got {v!r}")
        top = min(self.maxzoom, MAX_ZOOM)
        if not 0 <= z <= top:
            raise error(f"zoom must be from 0 to {top} in {self.id}, got {int(z)}")
        rows, cols = self.matrix_shape(int(z))
        if not (0 <= x < cols and 0 <= y < rows):
            raise error(
                f"tile {z}/{x}/{y} does not exist in {self.id}: x must be in 0..{cols - 1} "
                f"and y in 0..{rows - 1}"
            )

    def tile(self, z: int, x: int, y: int):
        """The grid of tile ``z/x/y`` (see the module notes)."""
        self.check_tile(z, x, y)
        if self.kind == "mercator":
            return Tile(int(z), int(x), int(y), self.size)
        if self.kind == "lonlat":
            return LonLatTile(self, int(z), int(x), int(y))
        return _projected_tile(self, int(z), int(x), int(y))

    def tiles_lonlat(self, z: int, x0: int, y0: int, x1: int, y1: int) -> tuple:
        """(W, S, E, N) degrees of the tiles ``x0..x1``, ``y0..y1`` of zoom ``z`` (a
        projected TMS's through pyproj, its edges densified, the poles inside included)."""
        if self.kind == "lonlat":
            rows, cols = self.matrix_shape(z)
            w, e = (float(np.degrees(self.lon_at(v, cols))) for v in (x0, x1 + 1))
            n, s = (float(np.degrees(self.lat_at(v, rows))) for v in (y0, y1 + 1))
            return (w, s, e, n)
        from pyproj import Transformer

        tms = self.tms()
        a, b = tms.xy_bounds(x0, y0, z), tms.xy_bounds(x1, y1, z)
        tr = Transformer.from_crs(self.crs, "OGC:CRS84", always_xy=True)
        w, s, e, n = tr.transform_bounds(a.left, b.bottom, b.right, a.top, densify_pts=64)
        return (float(w), float(s), float(e), float(n))

    def lonlat_bounds(self) -> tuple[float, float, float, float]:
        """The extent as (W, S, E, N) degrees (a lon/lat TMS's own; the world's else)."""
        if self.kind == "lonlat":
            return self.bounds
        return (-180.0, -90.0, 180.0, 90.0)

    def document(self) -> str:
        """The TMS as its OGC JSON document (morecantile's)."""
        return self.tms().model_dump_json(exclude_none=True, indent=2)


def _projected_tile(quad: TmsQuad, z: int, x: int, y: int) -> Projected:
    b = quad.tms().xy_bounds(x, y, z)
    bounds = (b.left, b.bottom, b.right, b.top)
    # the TMS places the tile, in the CRS's area of use or not
    return Projected(quad.size, quad.size, crs=quad.crs, bounds=bounds, check_domain=False)


@functools.lru_cache(maxsize=64)
def _parsed(doc: str):
    import morecantile

    return morecantile.TileMatrixSet.model_validate_json(doc)


@functools.lru_cache(maxsize=64)
def _registered_quad(name: str) -> TmsQuad:
    return _quad_of(_registered(name))


def _quad_of(tms) -> TmsQuad:
    m0 = tms.matrix(tms.minzoom)
    name = tms.id or "a custom TileMatrixSet"
    if tms.minzoom != 0:
        raise InvalidGridError(f"{name} has no zoom 0 (its zooms start at {tms.minzoom})")
    if tms.is_variable:
        raise InvalidGridError(f"{name} has variable matrix widths: gloffset needs a quadtree")
    size = int(m0.tileWidth)
    if m0.tileHeight != size:
        raise InvalidGridError(f"{name} has tiles of {m0.tileWidth} x {m0.tileHeight} pixels")
    top = min(int(tms.maxzoom), MAX_ZOOM)
    for z in range(1, top + 1):
        m = tms.matrix(z)
        ok = (
            m.matrixWidth == m0.matrixWidth << z
            and m.matrixHeight == m0.matrixHeight << z
            and m.tileWidth == size
            and m.tileHeight == size
            and abs(m.cellSize * (1 << z) / m0.cellSize - 1.0) < 1e-6
            and (m.cornerOfOrigin or "topLeft") == "topLeft"
        )
        if not ok:
            raise InvalidGridError(f"{name} is not a quadtree at zoom {z}: gloffset needs one")
    left = tms.xy_bounds(0, 0, 0)
    right = tms.xy_bounds(m0.matrixWidth - 1, m0.matrixHeight - 1, 0)
    bounds = (float(left.left), float(right.bottom), float(right.right), float(left.top))
    crs = tms.crs._pyproj_crs
    if crs.to_epsg() == 3857 and (m0.matrixWidth, m0.matrixHeight) == (1, 1):
        kind = "mercator"
        if abs(bounds[2] - 20037508.342789244) > 1e-3 or abs(bounds[3] - 20037508.342789244) > 1e-3:
            raise InvalidGridError(f"{name} is web mercator over another extent than the world")
    elif crs.is_geographic:
        kind = "lonlat"
    else:
        kind = "projected"
    return TmsQuad(
        str(tms.id),
        kind,
        int(m0.matrixWidth),
        int(m0.matrixHeight),
        size,
        int(tms.maxzoom),
        bounds,
        crs.to_string(),
        tms.model_dump_json(exclude_none=True),
    )


def tms_quad(tms, error: type[Exception] = InvalidGridError) -> TmsQuad:
    """The :class:`TmsQuad` of ``tms`` (a morecantile ``TileMatrixSet`` or its id);
    raises ``error`` for an unknown id or a TMS that is not a quadtree."""
    t = as_tms(tms, error)
    try:
        if isinstance(tms, str):
            return _registered_quad(tms)
        return _quad_of(t)
    except InvalidGridError as e:
        if error is InvalidGridError:
            raise
        raise error(str(e)) from None


def TmsTile(tms, z: int, x: int, y: int):  # noqa: N802  (a grid, named as one)
    """The tile ``z/x/y`` of the TileMatrixSet ``tms`` (a morecantile ``TileMatrixSet``
    or its identifier) as a grid, its size the TMS's.

    Pixel centres are those of the TMS's tile (see :mod:`gloffset.grids.tms`): a render
    on it is exact at them as on every grid. ``TmsTile("WebMercatorQuad", z, x, y)``
    is ``Tile(z, x, y)``.

    Raises :class:`~gloffset.grids.InvalidGridError` for an unknown TMS, one that is not
    a quadtree, or a tile it does not have.

    Examples
    --------
    >>> t = TmsTile("WorldCRS84Quad", 0, 1, 0)
    >>> t.bounds
    (0.0, -90.0, 180.0, 90.0)
    >>> TmsTile("WebMercatorQuad", 3, 2, 1) == Tile(3, 2, 1)
    True
    """
    return tms_quad(tms).tile(z, x, y)


@dataclass(frozen=True)
class LonLatTile(LonLatGrid):
    """Tile ``z/x/y`` of a TMS in a geographic CRS (``quad.kind == "lonlat"``): a
    ``size x size`` lon/lat grid (see :mod:`gloffset.grids.tms`)."""

    quad: TmsQuad
    z: int
    x: int
    y: int

    def __post_init__(self):
        if self.quad.kind != "lonlat":
            raise InvalidGridError(f"{self.quad.id} is not a TMS in a geographic CRS")
        self.quad.check_tile(self.z, self.x, self.y)
        check_size(self.quad.size, self.quad.size)

    @property
    def size(self) -> int:
        return self.quad.size

    @property
    def width(self) -> int:
        return self.quad.size

    @property
    def height(self) -> int:
        return self.quad.size

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(W, S, E, N) in degrees."""
        rows, cols = self.quad.matrix_shape(self.z)
        w, e = (float(np.degrees(self.quad.lon_at(v, cols))) for v in (self.x, self.x + 1))
        n, s = (float(np.degrees(self.quad.lat_at(v, rows))) for v in (self.y, self.y + 1))
        return (w, s, e, n)

    def _px(self) -> tuple[float, float]:
        rows, cols = self.quad.matrix_shape(self.z)
        return float(rows * self.size), float(cols * self.size)

    def pixel_lon(self, xx):
        return self.quad.lon_at(
            self.x * self.size + np.asarray(xx, dtype=np.float64), self._px()[1]
        )

    def pixel_lat(self, yy):
        return self.quad.lat_at(
            self.y * self.size + np.asarray(yy, dtype=np.float64), self._px()[0]
        )

    def pixel_lonlat(self, i, j):
        """Centre (lon, lat) in degrees of pixel column ``i``, row ``j``."""
        lon = np.degrees(self.pixel_lon(np.asarray(i, dtype=np.float64) + 0.5))
        lat = np.degrees(self.pixel_lat(np.asarray(j, dtype=np.float64) + 0.5))
        return lon, lat

    def wraps(self, level: int) -> bool:
        """Whether the columns go round the globe (a tile 360 degrees wide whose level
        tiles its width exactly)."""
        w, _, e, _ = self.bounds
        if abs(e - w - 360.0) > 1e-9:
            return False
        return self.level_shape(level)[1] * self.block(level) == self.width

    def __repr__(self) -> str:
        return f"TmsTile({self.quad.id!r}, {self.z}, {self.x}, {self.y})"


class ProjectedQuadLevels:
    """The tile quadtree of a TMS in a projected CRS down to zoom ``maxzoom`` as a level
    hierarchy (level = zoom, cell ``(row, column)`` = tile ``(y, x)``): the grid a
    pyramid walks to decide its tiles.

    Zoom ``z``'s tiles are those of the TMS's matrix ``z`` (its own origin and cell size,
    morecantile's); a tile's centre is pyproj's inverse of its centre in the CRS, as for
    :class:`~gloffset.grids.Projected` (a zoom is a ``Projected`` grid of one pixel a
    tile). Bounds: the inverse is ``K``-Lipschitz from the plane to the unit sphere where
    the projection gives ``K`` over the TMS's extent (polar stereographic: the UPS quads;
    Lambert azimuthal equal-area, :func:`~gloffset.grids.stretch.inverse_lipschitz`:
    ``EuropeanETRS89_LAEAQuad``), so every point of a
    tile lies within ``K h`` of its centre (``h`` the tile's half-diagonal), plus the
    inverse's error and ``K`` times the largest gap between a zoom's extent and zoom
    0's (the matrices' cell sizes are rounded: a tile's children may stick out of it by
    that much). :meth:`decision_rho` is that bound; :meth:`rho_at` (the list bound)
    adds those of the zooms below (down to one level below ``maxzoom``, the last, which
    a walk to ``maxzoom`` does not reach). No bin levels below the tiles: a pyramid renders each
    frontier tile on its own grid (``bins_below`` is False).
    """

    lonlat = False
    #: the levels below a tile are not its pixels' (tiles render on their own grids)
    bins_below = False

    def __init__(self, quad: TmsQuad, maxzoom: int):
        if quad.kind != "projected":
            raise InvalidGridError(f"{quad.id} is not a TMS in a projected CRS")
        self.quad, self.maxzoom = quad, int(maxzoom)
        tms = quad.tms()
        self._zooms = []
        gap = 0.0
        for z in range(self.maxzoom + 1):
            rows, cols = quad.matrix_shape(z)
            a, b = tms.xy_bounds(0, 0, z), tms.xy_bounds(cols - 1, rows - 1, z)
            ext = (a.left, b.bottom, b.right, a.top)
            gap = max(gap, *(abs(u - v) for u, v in zip(ext, quad.bounds)))
            self._zooms.append(Projected(cols, rows, crs=quad.crs, bounds=ext, check_domain=False))
        # one level below the deepest tiles (never walked): the driver decides the cells
        # of a grid's last level at their centres, as pixels, and tiles are not pixels
        rows, cols = quad.matrix_shape(self.maxzoom + 1)
        self._zooms.append(Projected(cols, rows, crs=quad.crs, bounds=ext, check_domain=False))
        xmin, ymin, xmax, ymax = quad.bounds
        # over the extent grown by the gap, where every tile lies (tighter than the
        # zoom grid's own, over its bounds grown by their size)
        box = (xmin - gap, ymin - gap, xmax + gap, ymax + gap)
        lip = inverse_lipschitz(self._zooms[0].crs, box)
        if lip is None:
            lip = self._zooms[0]._lipschitz()
        if lip is None:
            raise InvalidGridError(
                f"pyramids of {quad.id} need a bound of its projection ({quad.crs}) that "
                "gloffset does not have (it has one for polar stereographic, Lambert "
                "azimuthal equal-area and, within 3900 km of the central meridian, "
                "transverse Mercator CRSs)"
            )
        self._decision = []
        for z in range(self.maxzoom + 2):
            rows, cols = quad.matrix_shape(z)
            half = 0.5 * math.hypot((xmax - xmin) / cols, (ymax - ymin) / rows) + gap
            self._decision.append(pad(lip * half * (1.0 + 1e-9) + _INVERSE_SLACK))
        tail = np.cumsum(self._decision[::-1])[::-1]
        last = self.maxzoom + 1
        self._extra = [float(tail[z + 1]) if z < last else 0.0 for z in range(len(tail))]

    @property
    def n_levels(self) -> int:
        """The zooms 0..``maxzoom`` and one below (see the notes in ``__init__``)."""
        return self.maxzoom + 2

    def level_shape(self, z: int) -> tuple[int, int]:
        return self.quad.matrix_shape(z)

    def centers(self, z: int, j, i) -> np.ndarray:
        """Unit vectors of the centres of tiles (row ``j`` = y, column ``i`` = x) of zoom z."""
        g = self._zooms[z]
        return g.centers(g.n_levels - 1, j, i)

    def decision_rho(self, z: int, j, i=0) -> np.ndarray:
        """Largest angle from a tile's centre to any point of the tile (every tile of a
        zoom alike)."""
        return np.full(np.broadcast(np.asarray(j), np.asarray(i)).shape, self._decision[z])

    def rho_at(self, z: int, j, i) -> np.ndarray:
        """The list bound ``L`` of tiles (``j``, ``i``) of zoom ``z``."""
        return pad(self.decision_rho(z, j, i) + self._extra[z])

    def rho(self, z: int) -> np.ndarray:
        """Per-row list bound of zoom ``z``."""
        return self.rho_at(z, np.arange(self.level_shape(z)[0]), 0)


#: Allowance (rad) for pyproj's inverse's own error at a tile's centre.
_INVERSE_SLACK = 3e-9
