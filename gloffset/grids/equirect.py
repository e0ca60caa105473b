"""Equirectangular (plate carree) grids and their level hierarchy.

Pixel ``(i, j)`` (column, row; row 0 north) of a ``width x height`` grid over
``bounds = (W, S, E, N)`` has its centre at

    lon = W + (i + 0.5) (E - W) / width,   lat = N - (j + 0.5) (N - S) / height.

Bounds may cross the antimeridian (``W > E``: the grid runs east from W through
180 deg to E).

Levels. Level ``L = n_levels - 1`` is the output; a cell of level ``l`` is the
block of ``2^(L-l) x 2^(L-l)`` output pixels with corner at ``(i, j) 2^(L-l)``
(blocks at the east and south edges are not clipped, so their centres may lie
past the edge; that changes nothing below). Its centre is the centre of the block
by the same formula with fractional pixel indices.

Bounds rho. ``rho(l)[j]`` bounds, for every cell of row ``j`` of level ``l``, the
distance from the cell centre to every point of the cell's lon/lat rectangle and
to every point within ``rho`` of any descendant's centre:
``rho_L = max(area bound, 0)`` at pixels is not used for the output (pixels are
decided at their centres), and ``rho_l >= angle(centre, child centre) + rho_child``
for every child, which makes candidate lists shrink from parent to child. The
area bound is exact: the farthest point of a lon/lat rectangle from its centre is
found on its meridian edges, at an end or at the one interior critical latitude.
All of it is float64 and rounded up by a relative 1e-12.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import GloffsetError
from ..sphere import angle

__all__ = ["Equirect", "InvalidGridError"]


class InvalidGridError(GloffsetError, ValueError):
    """A grid has a bad size or bounds."""


#: The coarsest level has at most this many cells on its longer side.
COARSE_CELLS = 32
#: Output pixels per side of a bin (the level below which the GPU takes over).
BIN_PIXELS = 16


def _rect_radius(dlon_half: np.ndarray, lat_c: np.ndarray, lat1: np.ndarray, lat2: np.ndarray):
    """Largest angle from (0, lat_c) to the lon/lat rectangle |lon| <= dlon_half, lat1..lat2."""
    dl = np.minimum(dlon_half, math.pi)
    a = np.sin(lat_c)
    b = np.cos(lat_c) * np.cos(dl)
    # cos(angle) on a meridian edge = a sin(lat) + b cos(lat) = r cos(lat - phi0)
    cands = [lat1, lat2]
    phi0 = np.arctan2(a, b)
    for k in (-1.0, 1.0):
        crit = phi0 + k * math.pi
        cands.append(np.where((crit > lat1) & (crit < lat2), crit, lat1))
    lat = np.stack(cands)
    cosang = a * np.sin(lat) + b * np.cos(lat)
    return np.arccos(np.clip(cosang.min(axis=0), -1.0, 1.0))


@dataclass(frozen=True)
class Equirect:
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

    def __post_init__(self):
        w, h = self.width, self.height
        if not (isinstance(w, (int, np.integer)) and isinstance(h, (int, np.integer))):
            raise InvalidGridError(f"grid size must be integers, got {w!r} x {h!r}")
        if w < 1 or h < 1:
            raise InvalidGridError(f"grid size must be positive, got {w} x {h}")
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
        object.__setattr__(self, "width", int(w))
        object.__setattr__(self, "height", int(h))

    # ------------------------------------------------------------------ geometry
    @property
    def shape(self) -> tuple[int, int]:
        return (self.height, self.width)

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

    def pixel_lonlat(self, i, j):
        """Centre (lon, lat) in degrees of pixel column ``i``, row ``j`` (fractional allowed)."""
        w, s, e, n = self.bounds
        lon = w + (np.asarray(i, dtype=np.float64) + 0.5) * self.span_lon / self.width
        lat = n - (np.asarray(j, dtype=np.float64) + 0.5) * (n - s) / self.height
        lon = (lon + 180.0) % 360.0 - 180.0
        if np.ndim(lon) == 0:
            return float(lon), float(lat)
        return lon, lat

    # ------------------------------------------------------------------ levels
    @property
    def n_levels(self) -> int:
        side = max(self.width, self.height)
        return 1 + max(0, math.ceil(math.log2(side / COARSE_CELLS))) if side > COARSE_CELLS else 1

    @property
    def bin_level(self) -> int:
        """The level whose cells are bins (``BIN_PIXELS`` output pixels on a side)."""
        return max(0, self.n_levels - 1 - int(math.log2(BIN_PIXELS)))

    def block(self, level: int) -> int:
        """Output pixels per side of a cell of ``level``."""
        return 1 << (self.n_levels - 1 - level)

    def level_shape(self, level: int) -> tuple[int, int]:
        b = self.block(level)
        return (-(-self.height // b), -(-self.width // b))

    def _cell_lon_lat_rad(self, level: int, j, i):
        b = self.block(level)
        w, _, _, n = self.bounds
        lam = math.radians(w) + (np.asarray(i, dtype=np.float64) + 0.5) * b * self.dlon
        phi = math.radians(n) - (np.asarray(j, dtype=np.float64) + 0.5) * b * self.dlat
        return lam, phi

    def centers(self, level: int, j, i) -> np.ndarray:
        """Unit vectors of the centres of cells (row ``j``, column ``i``) of ``level``."""
        lam, phi = self._cell_lon_lat_rad(level, j, i)
        lam, phi = np.broadcast_arrays(lam, phi)
        cphi = np.cos(phi)
        return np.stack([cphi * np.cos(lam), cphi * np.sin(lam), np.sin(phi)], axis=-1)

    def rho(self, level: int) -> np.ndarray:
        """Per-row bound (radians) for ``level`` (see the module notes)."""
        return self._rhos()[level]

    def _rhos(self) -> list[np.ndarray]:
        cache = getattr(self, "_rho_cache", None)
        if cache is not None:
            return cache
        n = self.n_levels
        out: list[np.ndarray] = [None] * n  # type: ignore[list-item]
        out[n - 1] = np.zeros(self.level_shape(n - 1)[0])
        for lev in range(n - 2, -1, -1):
            h = self.level_shape(lev)[0]
            j = np.arange(h)
            b = self.block(lev)
            lam, phi = self._cell_lon_lat_rad(lev, j, 0)
            half_lat = 0.5 * b * self.dlat
            area = _rect_radius(
                np.full(h, 0.5 * b * self.dlon), phi, phi - half_lat, phi + half_lat
            )
            c = self.centers(lev, j, 0)
            hier = np.zeros(h)
            child_rows = out[lev + 1]
            for dj in (0, 1):
                cj = np.minimum(2 * j + dj, len(child_rows) - 1)
                for di in (0, 1):
                    cc = self.centers(lev + 1, 2 * j + dj, di)
                    hier = np.maximum(hier, angle(c, cc) + child_rows[cj])
            out[lev] = np.maximum(area, hier) * (1.0 + 1e-12) + 1e-15
        object.__setattr__(self, "_rho_cache", out)
        return out

    def rho_at(self, level: int, j, i) -> np.ndarray:
        """The bound of cells (``j``, ``i``) of ``level`` (it depends on the row only)."""
        return self.rho(level)[np.asarray(j)] + 0.0 * np.asarray(i)

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
