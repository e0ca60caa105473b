"""Where the GPU levels draw the frontier bins: :class:`BinLayout`, the bins packed into a
small canvas, and the float64 geometry of their cell rows and columns at each level."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..geometry.classes import FRONTIER
from ..grids.protocol import GlslCentres
from .vector.levels import Frontier

__all__ = ["BinLayout"]

# Bins per canvas row, at least (BinLayout.side): llvmpipe's threads share the image in
# 64-pixel tiles, so the first levels, where a bin is a few pixels, need a wide canvas
# to run on more than one thread. Up to a canvas _CANVAS_WIDTH pixels wide.
_CANVAS_ROW = 128
_CANVAS_WIDTH = 4096


@dataclass
class BinLayout:
    """The frontier bins that the GPU levels classify, and the geometry each level needs.

    The passes draw the bins packed row by row into a small *canvas* (:meth:`pos`),
    whatever their place on the sphere (a grid's frontier, or the frontier bins of a
    batch of map tiles, see :mod:`gloffset.tiles.pyramid`); the caller fills in every other
    cell from its bin's class. Bin ``k`` (in the order of the :class:`Frontier`) has the
    *geo row and column* ``geo[k]``, which index the geometry. Level ``bin level + s``
    has ``2^s x 2^s`` cells per bin; per geo row ``g`` and sub-row ``q < 2^s`` of it:

    * ``rho[s][g, q]``: the bound of the cells of that row (for the decisions);
    * lon/lat grids: ``lat[g]``, the latitude of the bin centres, and ``dphi[s][g, q]``,
      the cell row's latitude minus it; per geo column ``lon`` and ``dlam`` the same;
    * cube faces (``basis`` set): geo rows and columns are the bin's own on the face;
    * grids with a GLSL function (``glsl`` set, the grid's ``centres`` is ``"glsl"``):
      geo rows and columns are the bins' own in the grid (the function places the cells
      by them); ``centre`` (k, 3) the bin centres (float64: the shader takes each cell's
      centre minus its bin's in double);
    * any other grid (``centre`` set, the grid's ``centres`` is ``"texture"``):
      ``centre`` (k, 3) the bin centres; :meth:`delta_canvas` each cell's centre minus its
      bin's, from the grid's float64 centres (``texture_centers``), a level at a time.

    ``last`` is the shift of the output level (decided at the centres) and ``stop``
    the shift to stop at. Differences are made in float64 before the cast, so the
    shader only adds small float32 terms to small numbers.
    """

    geo: np.ndarray
    last: int
    stop: int
    rho: dict
    lat: np.ndarray | None = None
    lon: np.ndarray | None = None
    dphi: dict | None = None
    dlam: dict | None = None
    basis: np.ndarray | None = None
    face_size: int | None = None
    centre: np.ndarray | None = None
    bins: np.ndarray | None = None
    centres_at: Callable | None = None
    glsl: GlslCentres | None = None

    @classmethod
    def build(
        cls,
        bins,
        last,
        stop,
        rho_at,
        lat_at=None,
        lon_at=None,
        basis=None,
        face_size=None,
        centres_at=None,
    ):
        """The layout of the bins ``bins`` (k, 2) (rows and columns of the bin level).

        ``rho_at(s, rows)``: bounds of the cells of (whole-level) rows ``rows`` at shift
        ``s``; lon/lat grids give ``lat_at(s, rows)`` and ``lon_at(s, cols)``, the
        latitude and longitude of cell centres (shift 0: the bins); cube faces give
        ``basis`` and ``face_size``; other grids ``centres_at(s, rows, cols)``, the unit
        vectors of cell centres (arrays of whole-level rows and columns). Geo rows and
        columns are the distinct rows and columns of the bins (a cube face's own, since
        its shader places bins by them).
        """
        bins = np.asarray(bins).reshape(-1, 2)
        if centres_at is not None:
            return cls._textured(bins, last, stop, rho_at, centres_at)
        if basis is not None:
            g = np.arange(int(bins[:, 0].max(initial=0)) + 1)
            gc, geo = None, bins
        else:
            g, ginv = np.unique(bins[:, 0], return_inverse=True)
            gc, cinv = np.unique(bins[:, 1], return_inverse=True)
            geo = np.column_stack([ginv, cinv])
        lat = None if gc is None else lat_at(0, g)
        lon = None if gc is None else lon_at(0, gc)
        rho, dphi, dlam = {}, {}, {}
        for s in range(1, stop + 1):
            q = np.arange(1 << s)
            rows = (g[:, None] << s) + q[None, :]
            rho[s] = np.zeros(rows.shape) if s == last else rho_at(s, rows)
            if gc is not None:
                assert lat is not None and lon is not None  # set with gc
                dphi[s] = lat_at(s, rows) - lat[:, None]
                dlam[s] = lon_at(s, (gc[:, None] << s) + q[None, :]) - lon[:, None]
        return cls(geo, last, stop, rho, lat, lon, dphi, dlam, basis, face_size)

    @classmethod
    def _textured(cls, bins, last, stop, rho_at, centres_at) -> BinLayout:
        """The layout of a grid whose cell centres the GPU reads from textures (made a
        level at a time, for the children of frontier cells only: :meth:`delta_canvas`)."""
        g, ginv = np.unique(bins[:, 0], return_inverse=True)
        _, cinv = np.unique(bins[:, 1], return_inverse=True)
        geo = np.column_stack([ginv, cinv])
        centre = centres_at(0, bins[:, 0], bins[:, 1]).reshape(-1, 3)
        rho = {}
        for s in range(1, stop + 1):
            rows = (g[:, None] << s) + np.arange(1 << s)[None, :]
            rho[s] = np.zeros(rows.shape) if s == last else rho_at(s, rows)
        out = cls(geo, last, stop, rho, centre=centre)
        out.bins, out.centres_at = bins, centres_at
        return out

    @classmethod
    def _glsl(cls, f: Frontier, last, stop, rho_at, glsl: GlslCentres) -> BinLayout:
        """The layout of a grid whose cell centres a GLSL function gives: the geo rows and
        columns are the bins' own (as a cube face's), the bin centres the frontier's."""
        bins = np.asarray(f.cells).reshape(-1, 2)
        g = np.arange(int(bins[:, 0].max(initial=0)) + 1)
        rho = {}
        for s in range(1, stop + 1):
            rows = (g[:, None] << s) + np.arange(1 << s)[None, :]
            rho[s] = np.zeros(rows.shape) if s == last else rho_at(s, rows)
        centre = np.asarray(f.centers, dtype=np.float64).reshape(-1, 3)
        return cls(bins, last, stop, rho, centre=centre, glsl=glsl)

    def delta_canvas(self, s: int, parent: np.ndarray) -> np.ndarray:
        """(hb 2^s, wb 2^s, 3) float32: on the canvas of shift ``s``, each child of a
        frontier cell of ``parent`` (the canvas classes of shift ``s - 1``) gets its
        centre minus its bin's, made in float64 (zeros elsewhere: never read)."""
        # a textured layout's
        assert self.centre is not None and self.bins is not None and self.centres_at is not None
        b = 1 << s
        hb = max(1, -(-len(self.geo) // self.side))
        out = np.zeros((hb * b, self.side * b, 3), dtype=np.float32)
        pj, pi = np.nonzero(parent == FRONTIER)
        cj = (2 * pj[:, None] + np.array([0, 0, 1, 1])).ravel()
        ci = (2 * pi[:, None] + np.array([0, 1, 0, 1])).ravel()
        k = (cj >> s) * self.side + (ci >> s)
        keep = k < len(self.geo)
        cj, ci, k = cj[keep], ci[keep], k[keep]
        rows = (self.bins[k, 0] << s) + (cj & (b - 1))
        cols = (self.bins[k, 1] << s) + (ci & (b - 1))
        dv = self.centres_at(s, rows, cols) - self.centre[k]
        out[cj, ci] = np.where(np.isfinite(dv), dv, 0.0)
        return out

    def canvas_of(self, per_bin: np.ndarray, s: int) -> np.ndarray:
        """Per-cell values ``per_bin`` (k, 2^s, 2^s, ...) of shift ``s`` laid out on the
        canvas ((hb 2^s, wb 2^s, ...), zeros where no bin is)."""
        b = 1 << s
        hb = max(1, -(-len(self.geo) // self.side))
        tail = per_bin.shape[3:]
        out = np.zeros((hb, self.side, b, b) + tail, dtype=per_bin.dtype)
        pos = self.pos()
        out[pos[:, 0], pos[:, 1]] = per_bin
        axes = (0, 2, 1, 3) + tuple(range(4, 4 + len(tail)))
        return out.transpose(axes).reshape((hb * b, self.side * b) + tail)

    @classmethod
    def of_grid(cls, grid, f: Frontier, stop_level: int) -> BinLayout:
        """The layout of the frontier bins ``f`` of a grid."""
        bl = f.level

        def rho_at(s, rows):
            r = grid.rho(bl + s)
            return r[np.minimum(rows, len(r) - 1)]

        if grid.centres == "texture":

            def centres_at(s, rows, cols):
                h, w = grid.level_shape(bl + s)
                rows, cols = np.minimum(rows, h - 1), np.minimum(cols, w - 1)
                return grid.texture_centers(bl + s, rows, cols)

            return cls.build(
                f.cells, grid.n_levels - 1 - bl, stop_level - bl, rho_at, centres_at=centres_at
            )
        if grid.centres == "glsl":
            return cls._glsl(
                f, grid.n_levels - 1 - bl, stop_level - bl, rho_at, grid.glsl_centres()
            )
        if grid.centres == "cube":
            return cls.build(
                f.cells,
                grid.n_levels - 1 - bl,
                stop_level - bl,
                rho_at,
                basis=grid.basis,
                face_size=int(grid.size),
            )
        return cls.build(
            f.cells,
            grid.n_levels - 1 - bl,
            stop_level - bl,
            rho_at,
            lambda s, rows: grid.cell_lat(bl + s, rows),
            lambda s, cols: grid.cell_lon(bl + s, cols),
        )

    @property
    def side(self) -> int:
        """Bins per row of the canvas: about the square root of their number, but at
        least :data:`_CANVAS_ROW` (see there) while the canvas stays within
        :data:`_CANVAS_WIDTH` pixels at the last shift."""
        k = len(self.geo)
        return max(1, math.ceil(math.sqrt(k)), min(k, _CANVAS_ROW, _CANVAS_WIDTH >> self.stop))

    def pos(self) -> np.ndarray:
        """(k, 2) canvas row and column of each bin."""
        k = np.arange(len(self.geo))
        return np.column_stack([k // self.side, k % self.side])

    def canvas(self) -> np.ndarray:
        """Bin-level classes of the canvas: FRONTIER where a bin is, OUTSIDE elsewhere."""
        out = np.zeros((max(1, -(-len(self.geo) // self.side)), self.side), dtype=np.uint8)
        pos = self.pos()
        out[pos[:, 0], pos[:, 1]] = FRONTIER
        return out

    def blocks(self, classes: np.ndarray) -> np.ndarray:
        """(k, 2^s, 2^s): each bin's cells, from the canvas ``classes`` of a shift s."""
        b = classes.shape[1] // self.side
        cells = classes.reshape(-1, b, self.side, b).transpose(0, 2, 1, 3).reshape(-1, b, b)
        return cells[: len(self.geo)]
