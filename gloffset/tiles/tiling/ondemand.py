"""Tiles on demand (the tile server): a few tiles of one zoom, entered directly at
their zoom and rendered in batches (:func:`render_tiles`, :func:`tile_masks`), and what
decides a tile at any distance (:func:`measure_tiles`, :class:`TileCentre`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ...edges import CurveArcs, inside_any
from ...errors import InvalidGridError
from ...grids.conformal import ConformalRows
from ...grids.mercator import Tile, TilePyramid
from ...grids.tms import ProjectedQuadLevels
from ...raster.driver import CONTAINED, FRONTIER, OUTSIDE
from ...raster.render import render_angle, render_grid
from ...raster.vector.curves import CurveCells
from ...raster.vector.levels import at_cells, cell_distances, decide, subset
from .job import MAX_BLOCK
from .progress import PyramidStats, Tracker
from .tilepaint import TileStyle
from .walk import (
    BIN_LOG2,
    BinChain,
    MemoryStore,
    ZoomWriter,
    render_frontier_tiles,
    tile_grid,
)

__all__ = [
    "ALONE_ZOOM",
    "TileCentre",
    "measure_tiles",
    "render_tiles",
    "tile_masks",
    "tms_levels",
]


@functools.lru_cache(maxsize=64)
def _pyramid(maxzoom: int, ell=None) -> TilePyramid:
    """The :class:`TilePyramid` down to ``maxzoom`` (on the conformal sphere of ``ell``),
    made once (its bounds per zoom)."""
    return TilePyramid(maxzoom, ell)


#: zooms up to which :func:`render_tiles` renders each tile on its own grid
#: (:func:`gloffset.render` on a :class:`~gloffset.grids.Tile`), not with the pyramid's
#: levels: 2-5 times faster there (measured, Mexico and countries_10m), slower below (z4
#: on), where the levels also batch the tiles
ALONE_ZOOM = 3


@dataclass(frozen=True)
class TileCentre:
    """What decides a tile wholly inside or outside at any distance: the exact distances
    from its centre to the nearest boundary arc (``dist``) and ring edge (``dring``),
    whether the centre is inside, and the tile's rigorous bound ``rho``. None of it
    depends on the offset distance, so a tile server measures it once per tile (and keeps
    many: plain numbers, about 450 bytes a tile with its key)."""

    dist: float
    dring: float
    inside: bool
    rho: float
    #: the centre's status in each region component (packed bits, as
    #: :func:`~gloffset.raster.vector.levels.at_cells` gives them): a render of the tile
    #: at any distance takes them instead of counting crossings again
    status: bytes = b""

    def decide(self, d: float):
        """CONTAINED or OUTSIDE when every pixel of the tile is so at distance ``d``
        (radians), else None (the raster levels' rule at the tile's own zoom)."""
        dist, dring, rho = np.array([self.dist]), np.array([self.dring]), np.array([self.rho])
        cls = int(decide(dist, dring, np.array([self.inside]), rho, d, False)[0])
        return cls if cls in (CONTAINED, OUTSIDE) else None


@functools.lru_cache(maxsize=256)
def tms_levels(quad, z: int):
    """The tile levels of the TileMatrixSet ``quad`` (a
    :class:`~gloffset.grids.tms.TmsQuad`; None: web mercator) down to zoom ``z``, whose
    centres and rigorous bounds decide its tiles (the levels its pyramids walk), made
    once; None for a projected TMS that gloffset has no bound of (its tiles are
    rendered, never decided from their centres)."""
    if quad is None:
        return _pyramid(z)
    if quad.kind == "lonlat":
        return TilePyramid(z, quad=quad)
    if quad.kind == "projected":
        try:
            return ProjectedQuadLevels(quad, z)
        except InvalidGridError:
            return None
    return _pyramid(z)  # web mercator's own quad


def measure_tiles(shape, z: int, tiles, quad=None) -> dict:
    """The :class:`TileCentre` of each tile ``(x, y)`` of zoom ``z`` (of the TileMatrixSet
    ``quad``, :func:`tms_levels`; default web mercator), measured together: the tiles
    entered directly at their zoom (:func:`gloffset.raster.vector.levels.at_cells`) with
    every arc that can be a centre's nearest as candidates (no distance limit)."""
    grid = tms_levels(quad, z)
    if grid is None:
        raise InvalidGridError(f"{quad.id}'s tiles have no bound to be decided from their centres")
    arcs = CurveArcs.from_shape(shape)
    f = at_cells(shape, arcs, grid, math.pi, z, [(y, x) for x, y in tiles])
    dist, dring = cell_distances(f, arcs)
    inside, rho = inside_any(f.status), grid.decision_rho(z, f.cells[:, 0])
    return {
        (int(x), int(y)): TileCentre(
            float(dist[i]), float(dring[i]), bool(inside[i]), float(rho[i]), f.status[i].tobytes()
        )
        for i, (y, x) in enumerate(f.cells)
    }


def render_tiles(
    shape,
    d: float,
    z: int,
    tiles,
    *,
    size: int = 256,
    style=None,
    max_block=MAX_BLOCK,
    alone_zoom: int = ALONE_ZOOM,
    centres=None,
):
    """The styled PNG bytes of tiles ``(x, y)`` of zoom ``z`` (None where a tile has
    nothing to draw), the pixels those of a pyramid and of :func:`gloffset.render` on
    :class:`~gloffset.grids.Tile`; ``d`` in radians. ``centres``: the tiles'
    :class:`TileCentre` where measured (:func:`measure_tiles`), whose statuses spare the
    crossing counts of the tiles' centres (the same bits).

    The work follows the tiles, not the input: the tiles are classified directly at
    zoom ``z`` (their candidate arcs from the cap tree, within their reach:
    :meth:`~gloffset.raster.vector.curves.CurveCells.enter_cells`), a tile decided contained or
    outside is answered at once, and the frontier tiles are rendered together in
    batched GPU runs. Up to zoom ``alone_zoom`` (:data:`ALONE_ZOOM`), where that is
    slower, each tile is rendered on its own :class:`~gloffset.grids.Tile` (no outline).
    """
    style = style if style is not None else TileStyle()
    want = sorted({(int(x), int(y)) for x, y in tiles})
    if z <= alone_zoom and style.outline is None:
        return {
            (x, y): style.encode(render_angle(shape, d, tile_grid(z, x, y, size)) > 0)
            for x, y in want
        }
    plog = size.bit_length() - 1
    cells = CurveCells(shape, d, _pyramid(z + plog))
    chain = BinChain(cells, max(0, plog - BIN_LOG2))
    stats = PyramidStats()
    job = ZoomWriter(cells, style, MemoryStore(), set(), size, stats, Tracker(z, z, None))
    lev = cells.enter_cells(z, [(y, x) for x, y in want], _statuses(centres, want))
    rows, cols, cls = lev.cells[:, 0], lev.cells[:, 1], lev.cls
    r = cells.grid.decision_rho(z, rows)
    out = {}
    measure = lev.measure
    assert measure is not None  # entered cells carry their measures

    def keep(i, mask):
        lines = job.lines_of(lev, i, r) if mask is not None or measure[i] <= r[i] else ()
        if mask is None:  # decided: the one image of its class unless an outline crosses
            if not len(lines):
                out[(int(cols[i]), int(rows[i]))] = job.full if cls[i] == CONTAINED else None
                return
            mask = np.full((size, size), cls[i] == CONTAINED)
        out[(int(cols[i]), int(rows[i]))] = style.encode(mask, lines)

    for i in np.flatnonzero(cls != FRONTIER):
        keep(i, None)
    front = np.flatnonzero(cls == FRONTIER)
    if len(front):
        chain.advance(subset(lev.state, front))
        which = np.arange(len(front), dtype=np.int64)
        for k, mask in render_frontier_tiles(chain, which, size, max_block, stats):
            keep(front[k], mask)
    return {t: out.get(t) for t in want}


def _statuses(centres, want) -> np.ndarray | None:
    """The packed statuses of tiles ``want`` from their :class:`TileCentre` (None unless
    every tile has one with its status)."""
    if not centres:
        return None
    got = [centres.get(t) for t in want]
    if any(g is None or not g.status for g in got):
        return None
    return np.frombuffer(b"".join(g.status for g in got), dtype=np.uint8).reshape(len(got), -1)


def tile_masks(
    shape, d: float, z: int, tiles, *, size: int = 256, ell=None, alone_zoom: int = ALONE_ZOOM
) -> dict:
    """The masks (bool, ``size x size``) of tiles ``(x, y)`` of zoom ``z`` at ``d``
    (radians), the pixels of :func:`gloffset.render` on their :class:`~gloffset.grids.Tile`,
    by the route of :func:`render_tiles` (decided tiles answered at once, frontier tiles
    rendered in batched GPU runs). ``ell``: the tiles' latitudes are geodetic latitudes
    of that ellipsoid and ``shape`` lies on its conformal sphere (each pixel is the
    spherical answer at the conformal image of its centre,
    :class:`~gloffset.grids.conformal.ConformalRows`)."""
    want = sorted({(int(x), int(y)) for x, y in tiles})
    if z <= alone_zoom:
        out = {}
        for x, y in want:
            grid: Tile | ConformalRows = tile_grid(z, x, y, size)
            if ell is not None:
                grid = ConformalRows(grid, ell)
            out[(x, y)] = render_grid(shape, d, grid) > 0
        return out
    plog = size.bit_length() - 1
    cells = CurveCells(shape, d, _pyramid(z + plog, ell))
    chain = BinChain(cells, max(0, plog - BIN_LOG2))
    lev = cells.enter_cells(z, [(y, x) for x, y in want])
    rows, cols, cls = lev.cells[:, 0], lev.cells[:, 1], lev.cls
    out = {}
    for i in np.flatnonzero(cls != FRONTIER):
        out[(int(cols[i]), int(rows[i]))] = np.full((size, size), cls[i] == CONTAINED)
    front = np.flatnonzero(cls == FRONTIER)
    if len(front):
        chain.advance(subset(lev.state, front))
        which = np.arange(len(front), dtype=np.int64)
        for k, mask in render_frontier_tiles(chain, which, size, MAX_BLOCK, PyramidStats()):
            i = front[k]
            out[(int(cols[i]), int(rows[i]))] = mask
    return {t: out[t] for t in want}
