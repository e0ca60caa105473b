"""Signed distance fields: every distance at once (``distance_field(shape, grid)``).

The region of a shape at signed distance ``d`` is ``{s <= d}`` (``{s < d}`` for ``d < 0``),
where ``s(p)`` is the great-circle distance from ``p`` to the shape's curves, negated
inside the union of its polygons (lines and points bound no region: their ``s`` is
never negative). ``s`` does not depend on ``d``, so one field answers every distance:
:meth:`DistanceField.threshold` gives the mask of :func:`gloffset.render` at any ``d``.

How it is computed. The levels of the grid are walked coarse to fine, as a render walks
them (:mod:`gloffset.raster.levels`), with every cell frontier: each cell keeps the arcs
that can be nearest to one of its points, those whose lower bound on their distance to
the cell's centre is at most the least upper bound ``dist + 2 rho``
(:func:`~gloffset.raster.levels.prune`: the usual pruning of a nearest-neighbour
search), and its children filter that list again. At the output level every pixel has
the exact float64 distance to its nearest candidate (:func:`~gloffset.raster.levels.
cell_distances`, :func:`gloffset.sphere.arc_distance`) and its inside status from the
crossings the levels carry down, so the lists, and the cost, follow the pixels: a cell
far from the curves keeps the few arcs near its nearest one. With ``max_distance`` the
lists hold the arcs within ``max_distance + rho`` only, and a cell whose centre is
farther than ``max_distance + rho`` from the curves, with no ring edge within ``rho``,
is decided whole (every pixel ``+-max_distance``, no pixel work). Large levels are
walked in parts of contiguous cells, depth first, so memory stays bounded.

Accuracy: each value is the float64 distance (exact to 1e-15 rad) times ``radius``,
clamped to ``[-max_distance, max_distance]`` and rounded to float32 once: within 1
float32 ulp of the exact signed distance. A threshold compares the float32 values
with ``d``; pixels whose value lies within two float32 spacings of ``d`` are decided
again in float64 (their distance against the arcs whose caps reach, the predicate
the renders settle their band with, :func:`gloffset.raster.simplified.band_members`;
their inside status is the sign bit of the value, kept exactly: ``-0.0`` inside).
"""

from __future__ import annotations

import math

import numpy as np

from ..edges import CurveArcs, inside_any
from ..errors import OptionError
from ..grids import Cube, CubeFace, Equirect, Tile
from ..shape import read
from ..units import EARTH_RADIUS, RASTER_LIMIT, check_radius, offset_angle, to_angle
from .levels import Frontier, cell_distances, coarse, prune, refine, subset
from .simplified import band_members

__all__ = ["DistanceField", "distance_field"]

#: Cells and candidate pairs of one part of a level (a larger level is walked in parts
#: of contiguous cells: the next level has about four times as many of each).
_PART_CELLS, _PART_PAIRS = 1 << 16, 1 << 20

#: Slack (rad) of the whole-cell decision beyond ``max_distance`` (as the levels' own).
_SLACK = 1e-15

#: Pixels decided again in float64 per batch of :meth:`DistanceField.threshold`.
_BATCH = 1 << 16


class DistanceField:
    """The signed distance field of a shape on a grid (:func:`distance_field`).

    Attributes
    ----------
    values : numpy.ndarray
        float32, the grid's shape (``Equirect``: (height, width); ``Tile``: (size,
        size); ``Cube``: (6, size, size), faces as :func:`gloffset.render` stacks them):
        the signed great-circle distance of each pixel centre to the curves, in the
        units of ``radius``, negative inside the union of the polygons, clamped to
        ``[-max_distance, max_distance]``. Each is the exact float64 value rounded
        once to float32 (within 1 float32 ulp).
    grid : the grid
    radius : float
    max_distance : float or None
    """

    def __init__(self, shape, grid, values: np.ndarray, radius: float, max_distance):
        self.shape = shape
        self.grid = grid
        self.values = values
        self.radius = radius
        self.max_distance = max_distance

    def __repr__(self) -> str:
        return (
            f"DistanceField({type(self.grid).__name__}, values {self.values.shape} float32, "
            f"radius={self.radius!r}, max_distance={self.max_distance!r})"
        )

    def threshold(self, d: float) -> np.ndarray:
        """The mask of the region at signed distance ``d`` (units of ``radius``): uint8,
        255 inside, 0 outside, in the shape of :attr:`values`.

        Byte-identical to ``gloffset.render(shape, d, grid, radius=radius)`` wherever that
        render equals the float64 reference (its accuracy contract): a pixel is in when
        its exact signed distance is ``<= d`` (``< d`` for ``d < 0``); pixels whose
        float32 value cannot tell are decided in float64.

        Raises :class:`~gloffset.errors.InvalidDistanceError` for a ``d`` that
        ``render`` refuses, and :class:`~gloffset.errors.OptionError` when ``|d|``
        exceeds ``max_distance`` (the field does not know the pixels beyond it).
        """
        e = offset_angle(self.shape, d, self.radius, limit=RASTER_LIMIT, what="render")
        d = float(d)
        if self.max_distance is not None and abs(d) > self.max_distance:
            raise OptionError(
                f"threshold distance {d!r} is beyond the field's max_distance "
                f"{self.max_distance!r}; compute the field with a larger max_distance"
            )
        v = self.values
        member = np.empty(v.shape, dtype=bool)
        amb = []
        rows = max(1, _BATCH // max(1, v.shape[-1]))
        flat = v.reshape(-1, v.shape[-1])  # rows of every face
        mflat = member.reshape(flat.shape)
        for r0 in range(0, len(flat), rows):
            x = flat[r0 : r0 + rows].astype(np.float64)
            mflat[r0 : r0 + rows] = (x <= d) if d >= 0 else (x < d)
            # float32 spacing at the larger of |x|, |d|: the values that round to x
            sp = np.spacing(np.maximum(np.abs(x), abs(d)).astype(np.float32)).astype(np.float64)
            j, i = np.nonzero(np.abs(x - d) <= 2.0 * sp)
            if len(j):
                amb.append((j + r0, i))
        if amb:
            j = np.concatenate([a[0] for a in amb])
            i = np.concatenate([a[1] for a in amb])
            mflat[j, i] = self._settle(j, i, e)
        return np.where(member, np.uint8(255), np.uint8(0))

    def _settle(self, rows: np.ndarray, cols: np.ndarray, e: float) -> np.ndarray:
        """Membership at signed angle ``e`` of the pixels (flat rows of every face,
        columns), decided in float64."""
        size = self.values.shape[-2]
        out = np.empty(len(rows), dtype=bool)
        inside = np.signbit(self.values.reshape(-1, self.values.shape[-1])[rows, cols])
        grids = self.grid.faces if isinstance(self.grid, Cube) else [self.grid]
        face, j = np.divmod(rows, size)
        for k, g in enumerate(grids):
            sel = np.flatnonzero(face == k)
            if not len(sel):
                continue
            p = g.centers(g.n_levels - 1, j[sel], cols[sel])
            out[sel] = _members(self.shape, p, inside[sel], e)
        return out


def _members(shape, p: np.ndarray, inside: np.ndarray, e: float) -> np.ndarray:
    """Members at signed angle ``e`` among points ``p`` whose inside status is known:
    inside, or within ``e`` (``e >= 0``); inside and farther than ``|e|`` (``e < 0``),
    with the exact float64 distances of :func:`band_members`."""
    out = inside.copy()
    todo = np.flatnonzero(inside if e < 0 else ~inside)
    for s in range(0, len(todo), _BATCH):
        part = todo[s : s + _BATCH]
        # band_members(d) is "within |d|" for d > 0 and "farther than |d|" for d <= 0
        got = band_members(shape, p[part], e)
        out[part] = got if e != 0 else ~got
    return out


def _check_grid(grid) -> None:
    if not isinstance(grid, (Equirect, Tile, Cube, CubeFace)):
        raise OptionError(
            f"grid must be a gloffset.grids grid (Equirect, Tile, Cube), got {type(grid).__name__}"
        )


def _max_angle(max_distance, radius: float) -> float:
    """``max_distance`` as an angle (``inf`` for None); a clear error unless positive."""
    if max_distance is None:
        return math.inf
    m = to_angle(max_distance, radius)
    if not m > 0.0:
        raise OptionError(f"max_distance must be a positive distance, got {max_distance!r}")
    return m


def distance_field(
    shape, grid, *, max_distance: float | None = None, radius: float = EARTH_RADIUS, ellipsoid=None
) -> DistanceField:
    """The signed distance field of ``shape`` on ``grid``.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    grid : gloffset.grids.Equirect, Tile, Cube or CubeFace
    max_distance : float, optional
        Clamp the field to ``[-max_distance, max_distance]`` (units of ``radius``); the
        work then follows the band within it (cells wholly beyond it cost no pixel work).
    radius : float
        Sphere radius; the values are in its units (metres by default).
    ellipsoid : None
        Only the sphere for now: any other value raises
        :class:`~gloffset.errors.OptionError`.

    Returns
    -------
    DistanceField
        ``.values`` float32 in the grid's shape (as :func:`gloffset.render`'s mask):
        negative inside the union of the polygons, unsigned for lines and points.

    Notes
    -----
    Accuracy: every value is the exact float64 signed distance (error below 1e-15 rad
    times ``radius``) rounded once to float32, so within 1 float32 ulp of the exact
    value; its sign is the inside status of the levels' crossing parity, as in the
    float64 reference renderer. ``threshold(d)`` equals ``render(shape, d, grid)`` (see
    :meth:`DistanceField.threshold`). Cost: the output pixels, each against the few
    arcs that can be its nearest (see the module notes), on the CPU in float64.
    """
    if ellipsoid is not None:
        raise OptionError(
            f"distance_field does not support ellipsoid={ellipsoid!r} yet: only the sphere "
            "(ellipsoid=None, distances on the sphere of radius=)"
        )
    radius = check_radius(radius)
    shape = read(shape)
    _check_grid(grid)
    m = _max_angle(max_distance, radius)
    if isinstance(grid, Cube):
        values = np.stack([_field(shape, f, m, radius) for f in grid.faces])
    else:
        values = _field(shape, grid, m, radius)
    return DistanceField(
        shape, grid, values, radius, None if max_distance is None else float(max_distance)
    )


def _field(shape, grid, m: float, radius: float) -> np.ndarray:
    """The float32 field of one grid (clamped to ``+-m`` rad, ``m`` may be inf)."""
    arcs = CurveArcs.from_shape(shape)
    last = grid.n_levels - 1
    h0, w0 = grid.level_shape(0)
    out = np.empty((h0 << last, w0 << last), dtype=np.float32)
    clamp = None if math.isinf(m) else np.float32(m * radius)
    stack = [(coarse(shape, arcs, grid, m), False)]
    while stack:  # depth first: one part of each level at a time
        f, parent = stack.pop()
        if parent:
            f = refine(f, grid, arcs, m, shape)
        if len(f.cells) == 0:
            continue
        dist, dring, low = cell_distances(f, arcs, lows=True)
        inside = inside_any(f.status)
        if f.level == last:
            s = np.where(inside, -dist, dist) * radius
            v = s.astype(np.float32) if clamp is None else np.clip(s, -m * radius, m * radius)
            out[f.cells[:, 0], f.cells[:, 1]] = v
            continue
        f = prune(f, low, dist, m)
        if clamp is not None:
            r = f.rho + _SLACK
            whole = (dring > r) & (dist > m + r)
            if whole.any():
                _paint(out, grid, f.level, f.cells[whole], np.where(inside[whole], -clamp, clamp))
                f = subset(f, np.flatnonzero(~whole))
        stack.extend((part, True) for part in reversed(list(_parts(f))))
    h, w = grid.level_shape(last)
    return out[:h, :w]


def _paint(out: np.ndarray, grid, level: int, cells: np.ndarray, vals: np.ndarray) -> None:
    """Every output pixel of the cells ``(row, column)`` of ``level`` set to their value."""
    b = grid.block(level)
    view = out.reshape(out.shape[0] // b, b, out.shape[1] // b, b)
    view[cells[:, 0], :, cells[:, 1], :] = vals[:, None, None]


def _parts(f: Frontier):
    """``f`` cut into parts of contiguous cells of at most :data:`_PART_CELLS` cells and
    about :data:`_PART_PAIRS` pairs (the pairs are sorted by cell)."""
    k = len(f.cells)
    if k <= _PART_CELLS and len(f.pair_cell) <= _PART_PAIRS:
        yield f
        return
    before = np.searchsorted(f.pair_cell, np.arange(k))  # pairs before each cell
    part = np.maximum(before // _PART_PAIRS, np.arange(k) // _PART_CELLS)
    cuts = np.flatnonzero(np.r_[True, part[1:] != part[:-1]])
    at = np.r_[before[cuts], len(f.pair_cell)]
    for n, (a, b) in enumerate(zip(cuts, np.r_[cuts[1:], k])):
        pa, pb = at[n], at[n + 1]
        yield Frontier(
            f.level,
            f.cells[a:b],
            f.centers[a:b],
            f.rho[a:b],
            f.pair_cell[pa:pb] - a,
            f.pair_arc[pa:pb],
            f.status[a:b],
        )
