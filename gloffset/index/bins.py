"""Lon/lat bins: a quadtree of cells over the sphere, for locating points fast.

Level ``l`` splits the sphere into ``2^l`` rows of latitude (row 0 at the north
pole) and ``2^(l+1)`` columns of longitude (column 0 at -180 deg): square cells of
``180 / 2^l`` degrees. A point is located from its longitude and latitude alone, with
a few multiplications and no trigonometry, which is what makes the inside/outside
index (:mod:`gloffset.index.contains`) fast for points far from the boundary.

Every cell has an *anchor*, a point at a fixed irrational position inside it (not
the centre: data often has vertices on round coordinates, and the inside/outside
test needs anchors off the boundary), and a radius: a rigorous bound on the
distance from the anchor to any point of the cell.
"""

from __future__ import annotations

import numpy as np

from ..geometry.sphere import angle, lonlat_to_xyz

__all__ = ["MAX_LEVEL", "anchors", "radii", "locate", "children"]

#: Deepest supported level (cells of ~5 m).
MAX_LEVEL = 22
#: Rounding slack (rad) added to cell radii (corner positions, angles, and points put
#: in a cell by :func:`locate` that lie a few ulp outside it).
RADIUS_SLACK = 1e-14
# Position of the anchor inside its cell, as fractions of the cell's width (from the
# west) and height (from the north): irrational, far from the edges.
_FX = 0.5 + 1.0 / (8.0 * np.pi)
_FY = 0.5 - 1.0 / (8.0 * np.e)


def _size(level: int) -> float:
    return 180.0 / (1 << level)


def anchors(j, i, level: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Anchors of cells (row ``j``, column ``i``) of ``level``: unit vectors, lon, lat (deg)."""
    h = _size(level)
    lon = -180.0 + (np.asarray(i) + _FX) * h
    lat = 90.0 - (np.asarray(j) + _FY) * h
    return lonlat_to_xyz(lon, lat), lon, lat


def radii(j, level: int) -> np.ndarray:
    """A rigorous bound (rad) on the distance from the anchor of a cell of row ``j`` to any
    point of the cell (it depends on the row only: the columns are turned copies).

    For a lon/lat rectangle at most 90 deg wide, the distance from a point inside it
    grows along each parallel away from the point's meridian and, along each
    meridian edge, has no interior maximum (the critical latitude lies beyond a
    pole). So the farthest points are corners; the bound is the largest corner
    angle plus :data:`RADIUS_SLACK` (which also covers the turn between columns).
    """
    if level < 1:
        raise ValueError("bins start at level 1 (cells at most 90 degrees wide)")
    rows, inv = np.unique(np.asarray(j), return_inverse=True)
    zero = np.zeros(len(rows), dtype=np.int64)
    anchor = anchors(rows, zero, level)[0]
    h = _size(level)
    lat0 = 90.0 - rows * h
    r = np.zeros(len(rows))
    for dlon in (0.0, h):
        for dlat in (0.0, h):
            corner = lonlat_to_xyz(
                np.full(len(rows), -180.0 + dlon), np.clip(lat0 - dlat, -90.0, 90.0)
            )
            r = np.maximum(r, angle(anchor, corner))
    return (r + RADIUS_SLACK)[inv.ravel()]


def locate(lon: np.ndarray, lat: np.ndarray, level: int) -> tuple[np.ndarray, np.ndarray]:
    """Row and column of the level-``level`` cells holding points (lon, lat in degrees).

    Longitudes are taken modulo 360; points on a cell edge go to one of the cells
    that share it.
    """
    scale = (1 << level) / 180.0
    ncol, nrow = 2 << level, 1 << level
    x = lon + 180.0
    x *= scale
    if len(x) and (x.min() < 0.0 or x.max() >= ncol):  # longitudes outside [-180, 180)
        x = np.mod(lon + 180.0, 360.0) * scale
        np.minimum(x, ncol - 1, out=x)
    y = 90.0 - lat
    y *= scale
    i = x.astype(np.int32)
    j = y.astype(np.int32)
    np.minimum(j, nrow - 1, out=j)  # the south pole
    return j, i


def children(j, i) -> tuple[np.ndarray, np.ndarray]:
    """The four children (next level) of each cell, flat (4n,): NW, NE, SW, SE of each."""
    dj = np.array([0, 0, 1, 1])
    di = np.array([0, 1, 0, 1])
    cj = (np.repeat(j, 4) << 1) + np.tile(dj, len(j))
    ci = (np.repeat(i, 4) << 1) + np.tile(di, len(i))
    return cj, ci
