"""Web-mercator XYZ tiles as grids, and the web-mercator maths and limits of gloffset.

``Tile(z, x, y, size=256)`` is the tile ``z/x/y`` (y = 0 at the north, as XYZ map
tiles) of ``size x size`` pixels, with pixel centres equally spaced in mercator
space: pixel ``(i, j)`` has

    lon = -180 + 360 (x size + i + 0.5) / (2^z size)
    lat = gd(pi (1 - 2 (y size + j + 0.5) / (2^z size)))   (gd(v) = atan(sinh(v)))

so mercator stops at +-85.0511 deg. Tile bounds come from mercantile. Levels and the
bounds rho are those of :mod:`gloffset.grids.base`; mercator coordinates are in
float64, so pixel centres are exact to 1e-16 rad at every zoom.

The limits (zooms 0..:data:`MAX_ZOOM`, tile sizes a power of two from
:data:`MIN_TILE_SIZE` to :data:`MAX_TILE_SIZE`) hold for a ``Tile``, for
:func:`gloffset.tiles.pyramid` and for ``gloffset tiles`` alike; :func:`lon_at` and
:func:`lat_at` are the one copy of the projection's inverse that the grid and the
pyramid use.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mercantile
import numpy as np

from ..geometry.caps import pad
from ..geometry.sphere import angle
from .base import InvalidGridError, LonLatGrid, Square, rect_radius

__all__ = [
    "Tile",
    "TilePyramid",
    "MAX_ZOOM",
    "MIN_TILE_SIZE",
    "MAX_TILE_SIZE",
    "check_zoom",
    "check_tile_size",
    "lat_at",
    "lon_at",
]

#: Deepest zoom of a tile (the raster engine is exact to a fraction of a pixel up to here).
MAX_ZOOM = 22
#: Smallest and largest tile side in pixels (powers of two).
MIN_TILE_SIZE = 16
MAX_TILE_SIZE = 4096


def check_zoom(z, error: type[Exception] = InvalidGridError) -> int:
    """``z`` as an int, or raise ``error`` unless it is an integer from 0 to :data:`MAX_ZOOM`."""
    if not isinstance(z, (int, np.integer)) or isinstance(z, bool):
        raise error(f"zoom must be an integer from 0 to {MAX_ZOOM}, got {z!r}")
    if not 0 <= z <= MAX_ZOOM:
        raise error(
            f"zoom must be from 0 to {MAX_ZOOM}, got {int(z)} "
            f"(gloffset renders tiles up to zoom {MAX_ZOOM})"
        )
    return int(z)


def check_tile_size(size, error: type[Exception] = InvalidGridError) -> int:
    """``size`` as an int, or raise ``error`` unless it is a power of two from
    :data:`MIN_TILE_SIZE` to :data:`MAX_TILE_SIZE`."""
    if not (
        isinstance(size, (int, np.integer))
        and not isinstance(size, bool)
        and MIN_TILE_SIZE <= size <= MAX_TILE_SIZE
        and size & (size - 1) == 0
    ):
        raise error(
            f"tile size must be a power of two from {MIN_TILE_SIZE} to {MAX_TILE_SIZE} "
            f"pixels (256, 512, ...), got {size!r}"
        )
    return int(size)


def lon_at(pos, n) -> np.ndarray:
    """Longitude (radians) at ``pos`` of ``n`` equal columns of the world (fractional)."""
    return -math.pi + 2.0 * math.pi * np.asarray(pos, dtype=np.float64) / n


def lat_at(pos, n) -> np.ndarray:
    """Latitude (radians) at ``pos`` of ``n`` rows of the world (fractional, 0 north),
    equally spaced in mercator ``y``."""
    return np.arctan(np.sinh(math.pi * (1.0 - 2.0 * np.asarray(pos, dtype=np.float64) / n)))


@dataclass(frozen=True)
class Tile(Square, LonLatGrid):
    """The XYZ tile ``z/x/y`` as a ``size x size`` grid.

    Raises :class:`~gloffset.grids.InvalidGridError` unless ``z`` is 0..22, ``x`` and
    ``y`` are 0..2^z - 1 and ``size`` is a power of two from 16 to 4096.

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
        check_zoom(self.z)
        n = 1 << self.z
        if not (0 <= self.x < n and 0 <= self.y < n):
            raise InvalidGridError(
                f"tile {self.z}/{self.x}/{self.y} does not exist: x and y must be in 0..{n - 1}"
            )
        check_tile_size(self.size)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(W, S, E, N) in degrees (mercantile)."""
        b = mercantile.bounds(mercantile.Tile(int(self.x), int(self.y), int(self.z)))
        return (b.west, b.south, b.east, b.north)

    def _px_per_world(self) -> float:
        return float((1 << self.z) * self.size)

    def pixel_lon(self, xx):
        return lon_at(self.x * self.size + np.asarray(xx, dtype=np.float64), self._px_per_world())

    def pixel_lat(self, yy):
        return lat_at(self.y * self.size + np.asarray(yy, dtype=np.float64), self._px_per_world())

    def pixel_lonlat(self, i, j):
        """Centre (lon, lat) in degrees of pixel column ``i``, row ``j``."""
        lon = np.degrees(self.pixel_lon(np.asarray(i, dtype=np.float64) + 0.5))
        lat = np.degrees(self.pixel_lat(np.asarray(j, dtype=np.float64) + 0.5))
        return lon, lat

    def children(self) -> list[Tile]:
        """The four tiles of zoom z + 1 inside this one."""
        return [Tile(c.z, c.x, c.y, self.size) for c in mercantile.children(self.x, self.y, self.z)]


def _xyz(lon, lat) -> np.ndarray:
    """Unit vectors at ``lon``, ``lat`` (radians; broadcast)."""
    lon, lat = np.broadcast_arrays(lon, lat)
    c = np.cos(lat)
    return np.stack([c * np.cos(lon), c * np.sin(lon), np.sin(lat)], axis=-1)


#: :meth:`TilePyramid.decision_rho`: calls with at most this many distinct rows use the
#: memo, which holds up to :data:`_MEMO_SIZE` rows (then starts again): about 1 MB a
#: pyramid (a tile server keeps a pyramid for each zoom it is asked for; at 1 << 20 rows
#: each could grow to 150 MB, the server's memory rising for minutes)
_MEMO_ROWS = 512
_MEMO_SIZE = 1 << 13


class TilePyramid:
    """The XYZ quadtree down to zoom ``maxzoom`` as a level hierarchy (level = zoom, cell
    ``(row, column)`` = tile ``(y, x)``): the grid of tile pyramids.

    Bounds: :meth:`decision_rho` is the tight bound of a tile (every point of it is
    within it of the centre), used to decide a tile; :meth:`rho_at` (the list bound ``L``)
    adds the sum of the decision bounds of the zooms below, so that a tile's candidate
    arcs serve every descendant down to ``maxzoom``.

    ``ell``: an ellipsoid whose geodetic latitudes the tiles' are: the pyramid is then
    the one on its conformal sphere (every latitude mapped to its conformal latitude,
    as :class:`~gloffset.grids.conformal.ConformalRows` does for one grid).

    ``quad``: the quadtree of a TMS in a geographic CRS
    (:class:`~gloffset.grids.tms.TmsQuad`, ``kind == "lonlat"``, e.g. ``WorldCRS84Quad``)
    instead of web mercator: zoom ``z`` has ``rows0 2^z x cols0 2^z`` tiles, rows and
    columns evenly spaced in latitude and longitude over the TMS's extent.
    """

    lonlat = False
    #: the levels below a tile are its pixels' (lon/lat rows: the GPU bin levels)
    bins_below = True

    def __init__(self, maxzoom: int, ell=None, quad=None):
        self.maxzoom = int(maxzoom)
        self.ell = ell
        if quad is not None and (ell is not None or quad.kind != "lonlat"):
            raise ValueError("a TilePyramid's quad is a lon/lat TMS's, on the sphere")
        self.quad = quad
        # the tiles next to the equator are the largest of a zoom (web mercator, and
        # rows evenly spaced in latitude alike); on the conformal sphere every tile is
        # smaller than those (0.3 % smaller from zoom 5 on, tested), so their bounds
        # serve the conformal pyramid too
        sphere = self if ell is None else TilePyramid(maxzoom)
        eq = [
            float(np.max(sphere.decision_rho(z, self._equator_rows(z))))
            for z in range(self.maxzoom + 1)
        ]
        tail = np.cumsum(eq[::-1])[::-1]  # tail[z] = sum of eq[z..Z]
        self._extra = [float(tail[z + 1]) if z < self.maxzoom else 0.0 for z in range(len(eq))]

    def _equator_rows(self, z: int) -> np.ndarray:
        """The rows of zoom ``z`` next to the equator (the largest tiles of the zoom)."""
        rows = self.level_shape(z)[0]
        if self.quad is None:
            return np.array([max(0, rows // 2 - 1)])
        _, south, _, north = self.quad.bounds
        at = rows * north / (north - south) if south < 0.0 < north else 0.0
        near = np.floor(at) + np.arange(-1.0, 2.0)
        if north <= 0.0:
            near = np.array([0.0])
        elif south >= 0.0:
            near = np.array([rows - 1.0])
        return np.clip(near, 0, rows - 1)

    @property
    def n_levels(self) -> int:
        return self.maxzoom + 1

    def level_shape(self, z: int) -> tuple[int, int]:
        if self.quad is not None:
            return self.quad.matrix_shape(z)
        return (1 << z, 1 << z)

    def centers(self, z: int, j, i) -> np.ndarray:
        """Unit vectors of the centres of tiles (row ``j`` = y, column ``i`` = x) of zoom z."""
        lon = self.tile_lon(z, np.asarray(i, dtype=np.float64) + 0.5)
        return _xyz(lon, self.tile_lat(z, np.asarray(j, dtype=np.float64) + 0.5))

    def _lat(self, pos, n) -> np.ndarray:
        """:func:`lat_at` (the quad's), or its conformal latitude on the ellipsoid ``ell``."""
        if self.quad is not None:
            return self.quad.lat_at(pos, n)
        lat = lat_at(pos, n)
        if self.ell is None:
            return lat
        return np.radians(self.ell.conformal(np.degrees(lat)))

    def tile_lat(self, z: int, yy) -> np.ndarray:
        """Latitude (radians) at fractional tile row ``yy`` of zoom ``z``."""
        return self._lat(yy, self.level_shape(z)[0])

    def tile_lon(self, z: int, xx) -> np.ndarray:
        """Longitude (radians) at fractional tile column ``xx`` of zoom ``z``."""
        if self.quad is not None:
            return self.quad.lon_at(xx, self.level_shape(z)[1])
        return lon_at(xx, 1 << z)

    def decision_rho(self, z: int, j, i=0) -> np.ndarray:
        """Largest angle from the centre of a tile of row ``j`` to any point of the tile.

        ``rect_radius`` is exact but loses digits for tiny tiles (arccos near 1); the
        corners, the farthest points of every tile below zoom 0, are measured with
        the robust :func:`gloffset.geometry.sphere.angle` too and the larger value is kept.
        Rows are computed once each: a call's few distinct rows are looked up in (and
        added to) a memo of the pyramid's, many are computed as they come.
        """
        j = np.asarray(j, dtype=np.float64)
        rows, inv = np.unique(j, return_inverse=True)
        if len(rows) > _MEMO_ROWS:
            return self._row_rho(z, rows)[inv].reshape(j.shape)
        memo = self.__dict__.setdefault("_rho_memo", {})
        got = np.array([memo.get((z, r), -1.0) for r in rows.tolist()])
        miss = np.flatnonzero(got < 0.0)
        if len(miss):
            got[miss] = self._row_rho(z, rows[miss])
            if len(memo) > _MEMO_SIZE:
                memo.clear()
            memo.update(zip([(z, r) for r in rows[miss].tolist()], got[miss].tolist()))
        return got[inv].reshape(j.shape)

    def _row_rho(self, z: int, j: np.ndarray) -> np.ndarray:
        """:meth:`decision_rho` of rows ``j`` (float64), computed."""
        north, south, mid = (
            self.tile_lat(z, j),
            self.tile_lat(z, j + 1.0),
            self.tile_lat(z, j + 0.5),
        )
        if self.quad is None:
            dl = math.pi / (1 << z)
        else:
            west, _, east, _ = self.quad.bounds
            dl = 0.5 * math.radians(east - west) / self.level_shape(z)[1]
        exact = rect_radius(np.full(j.shape, dl), mid, south, north)
        c = _xyz(0.0, mid)
        corners = np.maximum(angle(c, _xyz(dl, north)), angle(c, _xyz(dl, south)))
        return pad(np.maximum(exact, corners))

    def rho(self, z: int) -> np.ndarray:
        """Per-row list bound ``L`` of zoom ``z``."""
        return self.rho_at(z, np.arange(self.level_shape(z)[0]), 0)

    def rho_at(self, z: int, j, i) -> np.ndarray:
        """The list bound ``L`` of tiles (``j``, ``i``) of zoom ``z``."""
        r = self.decision_rho(z, j) + self._extra[z]
        return pad(r) + 0.0 * np.asarray(i)
