"""A pyramid's walk down the zooms: what each zoom writes (:class:`ZoomWriter`) and the
bin levels kept from zoom to zoom below its frontier tiles (:class:`BinChain`), whose
frontier bins the GPU levels render in batches (:func:`render_frontier_tiles`).
"""

from __future__ import annotations

import functools

import numpy as np

from ...grids.mercator import Tile
from ...raster.driver import CONTAINED, FRONTIER, NOT_FORCED, OUTSIDE, Level
from ...raster.layout import BinLayout
from ...raster.render import render_grid
from ...raster.vector.curves import CurveCells
from ...raster.vector.levels import subset
from .tilepaint import OutlineArcs

__all__ = [
    "BIN_LOG2",
    "PYRAMID_ALONE_ZOOM",
    "MemoryStore",
    "ZoomWriter",
    "BinChain",
    "tile_grid",
    "render_frontier_tiles",
]


#: Output pixels per side of a bin (below it the GPU takes over).
BIN_LOG2 = 4


def _subtree(x, y, z, zfrom, zto, chunk=65536):
    """XYZ coordinates of tile z/x/y and its descendants at zooms zfrom..zto, in chunks."""
    for zz in range(max(z, zfrom), zto + 1):
        k = zz - z
        n = 1 << k
        xs = np.arange(x << k, (x << k) + n)
        rows_per = max(1, chunk // n)
        for r0 in range(0, n, rows_per):
            ys = np.arange((y << k) + r0, (y << k) + min(n, r0 + rows_per))
            yy, xx = np.meshgrid(ys, xs, indexing="ij")
            yield zz, xx.ravel(), yy.ravel()


class MemoryStore:
    """A tile store that keeps the tiles of a task: ``groups`` maps each distinct image
    (its bytes) to the XYZ tiles that have it."""

    def __init__(self):
        self.groups: dict[bytes, list] = {}

    def existing(self) -> set:
        return set()

    def put(self, z: int, x: int, y: int, data: bytes) -> None:
        self.put_many([(z, x, y)], data)

    def put_many(self, tiles, data: bytes) -> None:
        self.groups.setdefault(data, []).extend((int(z), int(x), int(y)) for z, x, y in tiles)

    def commit(self) -> None:
        pass


class ZoomWriter:
    """What a zoom of the pyramid writes: fully inside tiles and their descendants (one
    shared image), decided tiles with an outline (drawn), frontier tiles (rendered)."""

    def __init__(self, cells, style, store, have, size, stats, track):
        self.cells, self.style, self.store, self.have = cells, style, store, have
        self.size, self.stats, self.track = size, stats, track
        self.full = style.encode(np.ones((size, size), dtype=bool))
        self.outline = OutlineArcs(cells.arcs) if style.outline is not None else None

    def lines_of(self, lev: Level, i: int, r):
        """The outline's lines in tile ``i`` of ``lev``."""
        if self.outline is None:
            return ()
        f, arcs = lev.state, self.cells.arcs
        s, t = np.searchsorted(f.pair_cell, [i, i + 1])
        cand = f.pair_arc[s:t]
        cand = cand[arcs.boundary[cand]]
        y, x = (int(v) for v in f.cells[i])
        return self.outline.lines(cand, f.centers[i], float(r[i]), lev.level, x, y, self.size)

    def run(
        self,
        lev: Level,
        chain,
        zooms: tuple[int, int],
        max_block: int,
        *,
        root: bool = False,
        chosen=None,
        kept_too: bool = False,
        final: bool = False,
    ):
        """Write the zoom's tiles and choose the cells refined next (``lev.keep``).

        ``root``: the level is a task's root tile, whose zoom the split counted.
        ``chosen``: a split run's zoom, :meth:`choose` made: the frontier tiles are
        returned, not rendered (with ``kept_too``, the outlined tiles are not drawn
        either). ``final``: the run's last zoom."""
        (zlo, zhi), z, cls, stats = zooms, lev.level, lev.cls, self.stats
        defer = chosen is not None
        r, carry = chosen if defer else self.choose(lev)
        cont = np.flatnonzero((cls == CONTAINED) & ~carry)
        front = np.flatnonzero(cls == FRONTIER)
        paint = np.flatnonzero(carry)
        zs = {
            "contained": int(len(cont)),
            "outside": int(((cls == OUTSIDE) & ~carry).sum()),
            "frontier": int(len(front)),
        }
        if not root:
            stats.zooms[z] = zs
        if z >= zlo:
            stats.outside += zs["outside"]
        # the bin levels below the frontier tiles: rendering needs them from zoom min on,
        # the estimate of the tiles to come from the zoom before (a split run renders
        # nothing: its tasks make their own)
        ahead = z >= zlo - 1 and not defer and not (final and self.alone(z))
        if ahead:
            chain.advance(subset(lev.state, front))
        self.track.plan(
            z,
            front=len(front),
            contained=len(cont),
            carried_in=int((cls[paint] == CONTAINED).sum()),
            carried_out=int((cls[paint] == OUTSIDE).sum()),
            ahead=chain.counts() if ahead else [],
        )
        self.inside(lev, cont, zlo, zhi)
        if z >= zlo:
            if not kept_too:
                self.painted(lev, paint, r)
            if not defer:
                self.rendered(lev, front, r, chain, max_block)
            self.store.commit()
        return front if z >= zlo else front[:0]

    def choose(self, lev: Level):
        """The cells refined next (``lev.keep``: frontier tiles, and decided tiles an
        outline crosses, whose children inherit the class: ``lev.forced``); returns the
        zoom's decision radii and which tiles are carried so."""
        cls = lev.cls
        r = self.cells.grid.decision_rho(lev.level, lev.cells[:, 0], lev.cells[:, 1])
        carry = (cls != FRONTIER) & (lev.measure <= r)
        if self.outline is None:
            carry[:] = False
        lev.keep = np.flatnonzero((cls == FRONTIER) | carry)
        lev.forced = np.where(carry, cls, NOT_FORCED).astype(np.uint8)[lev.keep]
        return r, carry

    def alone(self, z: int) -> bool:
        """Whether the frontier tiles of zoom ``z`` are rendered one by one (without
        the bin chain; every zoom of a grid without bin levels below its tiles)."""
        if not self.cells.grid.bins_below:
            return True
        return z <= PYRAMID_ALONE_ZOOM and self.outline is None

    def inside(self, lev: Level, cont, zlo: int, zhi: int):
        """Fully inside: the tiles ``cont`` and all their descendants, one shared image."""
        stats = self.stats
        rows, cols = lev.cells[:, 0], lev.cells[:, 1]
        with self.track.light():
            for i in cont:
                for zz, xs, ys in _subtree(int(cols[i]), int(rows[i]), lev.level, zlo, zhi):
                    tiles = [(zz, int(x), int(y)) for x, y in zip(xs, ys)]
                    if self.have:
                        new = [t for t in tiles if t not in self.have]
                        stats.present += len(tiles) - len(new)
                        tiles = new
                    if self.full is not None and tiles:
                        self.store.put_many(tiles, self.full)
                    stats.inside += len(tiles)
                    self.track.tick(light=len(xs), skipped=len(xs) - len(tiles))

    def painted(self, lev: Level, paint, r):
        """Decided tiles with an outline: drawn, not rendered."""
        z, rows, cols = lev.level, lev.cells[:, 0], lev.cells[:, 1]
        for i in paint:
            key = (z, int(cols[i]), int(rows[i]))
            if key in self.have:
                self.stats.present += 1
                self.track.tick(heavy=1, skipped=1)
                continue
            mask = np.full((self.size, self.size), lev.cls[i] == CONTAINED)
            data = self.style.encode(mask, self.lines_of(lev, i, r))
            if data is not None:
                self.store.put(*key, data)
                self.stats.painted += 1
            self.track.tick(heavy=1)

    def rendered(self, lev: Level, front, r, chain, max_block: int):
        """Frontier tiles: their frontier bins rendered in batches, from the chain."""
        z, rows, cols, stats = lev.level, lev.cells[:, 0], lev.cells[:, 1], self.stats
        todo = [k for k, i in enumerate(front) if (z, int(cols[i]), int(rows[i])) not in self.have]
        stats.present += len(front) - len(todo)
        self.track.tick(heavy=len(front) - len(todo), skipped=len(front) - len(todo))
        if todo:
            self.track.setup(_gl_passes)  # the GL context, once: not a tile's cost
        if self.alone(z):
            # few tiles, each far coarser than the input: one render per tile, from the
            # curves simplified to its pixels where that pays (as render_tiles does)
            shape, d, size = self.cells.shape, self.cells.d, self.size
            quad = self.cells.grid.quad
            masks = (
                (
                    k,
                    render_grid(
                        shape,
                        d,
                        tile_grid(z, int(cols[front[k]]), int(rows[front[k]]), size, quad),
                    )
                    > 0,
                )
                for k in todo
            )
        else:
            masks = render_frontier_tiles(
                chain, np.asarray(todo, dtype=np.int64), self.size, max_block, stats
            )
        for k, mask in masks:
            i = front[k]
            data = self.style.encode(mask, self.lines_of(lev, i, r))
            stats.rendered += 1
            if data is None:
                stats.empty += 1
            else:
                self.store.put(z, int(cols[i]), int(rows[i]), data)
            self.track.tick(heavy=1)


def _gl_passes():
    from ...gl.vector_pass import vector_passes

    return vector_passes()


def _keys(cells: np.ndarray, k: int = 0) -> np.ndarray:
    """Sort keys of the ancestors ``k`` levels up of ``cells`` (row-major order)."""
    return ((cells[:, 0] >> k) << 32) | (cells[:, 1] >> k)


def _member(keys: np.ndarray, sorted_keys: np.ndarray) -> np.ndarray:
    """Positions of ``keys`` in ``sorted_keys`` (-1 where absent)."""
    if len(sorted_keys) == 0:
        return np.full(len(keys), -1)
    pos = np.minimum(np.searchsorted(sorted_keys, keys), len(sorted_keys) - 1)
    return np.where(sorted_keys[pos] == keys, pos, -1)


class BinChain:
    """The levels between the frontier tiles of a zoom and their bins, kept from zoom
    to zoom.

    For the frontier tiles of zoom ``z`` (``size = 2^P`` pixels, bins of 16) the
    levels ``z + 1 .. z + nb`` (``nb = P - 4``) hold, per level, the decided cells
    with their classes and the :class:`~gloffset.raster.vector.levels.Frontier` of the others,
    all in float64 with the decision rules of :mod:`gloffset.raster.vector.levels` and the
    bound :meth:`~gloffset.grids.mercator.TilePyramid.decision_rho`. The frontier tiles
    of zoom ``z + 1`` are frontier
    cells of level ``z + 1`` here, so their levels ``z + 2 .. z + nb`` are already
    known: advancing a zoom filters them and computes one new level.
    """

    def __init__(self, cells: CurveCells, nb: int):
        self.cells, self.levels, self.nb = cells, cells.grid, nb
        self.arcs, self.d = cells.arcs, cells.d
        self.z = None
        self.lev: list[tuple] = []  # per level z + 1 + i: (decided cells, their classes, Frontier)

    def _next(self, f):
        """Level ``f.level + 1``: the children of ``f``'s cells, classified."""
        every = np.full(len(f.cells), FRONTIER, dtype=np.uint8)
        lev = self.cells.refine(Level(f.level, f.cells, every, f))
        dec = np.flatnonzero(lev.cls != FRONTIER)
        return lev.cells[dec], lev.cls[dec], subset(lev.state, lev.frontier())

    def advance(self, f):
        """Make the chain that of the tiles of ``f`` (frontier tiles of zoom ``f.level``)."""
        keys = _keys(f.cells)
        if self.z is not None and self.z + 1 == f.level and self.nb > 1:
            lev = []
            for k, (dc, dcls, fr) in enumerate(self.lev[1:], start=1):
                keep = _member(_keys(dc, k), keys) >= 0
                inner = np.flatnonzero(_member(_keys(fr.cells, k), keys) >= 0)
                lev.append((dc[keep], dcls[keep], subset(fr, inner)))
            lev.append(self._next(lev[-1][2]))
        else:
            lev, cur = [], f
            for _ in range(self.nb):
                lev.append(self._next(cur))
                cur = lev[-1][2]
        self.z, self.lev, self.f = f.level, lev, f

    def counts(self) -> list[tuple[int, int]]:
        """``(frontier, contained)`` cells of each level ``z + 1 .. z + nb`` of the chain:
        the frontier and newly contained tiles of those zooms (without an outline)."""
        return [(len(fr.cells), int((dcls == CONTAINED).sum())) for _, dcls, fr in self.lev]

    def batches(self, which, per_run: int, most: int | None):
        """The tiles ``which`` (indices into the chain's tiles) in runs of consecutive
        tiles: at most ``per_run`` tiles, and, where ``most`` is given, at most ``most``
        candidate pairs of their frontier bins (a run's records then fit the one storage
        buffer in which the GL context makes them, :func:`gloffset.raster.gpu.device_records`,
        instead of numpy), or a single tile. Each tile's pixels are its own whatever the
        runs: only the work moves."""
        which = np.asarray(which, dtype=np.int64)
        if most is None or len(which) <= 1:
            for s0 in range(0, len(which), per_run):
                yield which[s0 : s0 + per_run]
            return
        # the bin level's pairs under each tile of the chain
        fr = self.lev[-1][2] if self.nb else self.f
        per_cell = np.bincount(fr.pair_cell, minlength=len(fr.cells))
        keys = _keys(self.f.cells)
        order = np.argsort(keys)
        t = _member(_keys(fr.cells, self.nb), keys[order])
        ok = t >= 0
        per_tile = np.zeros(len(keys))
        per_tile[order] = np.bincount(t[ok], weights=per_cell[ok], minlength=len(keys))
        load = per_tile[which]
        s0 = 0
        while s0 < len(which):
            s1 = min(s0 + per_run, len(which))
            cum = np.cumsum(load[s0:s1])
            s1 = s0 + max(1, int(np.searchsorted(cum, most, side="right")))
            yield which[s0:s1]
            s0 = s1

    def layout(self, which, ns):
        """The tiles ``which`` (indices into the chain's tiles) down to their bins.

        Returns the bin-level classes of each tile ((n, 2^nb, 2^nb), every decided cell
        painted), the :class:`~gloffset.raster.layout.BinLayout` of the frontier bins
        (``ns`` GPU levels below them), their :class:`~gloffset.raster.vector.levels.Frontier`,
        and each frontier bin's tile (position in ``which``) and place in it."""
        nb = self.nb
        nbin = 1 << nb
        tiles = np.zeros((len(which), nbin, nbin), dtype=np.uint8)
        keys = _keys(self.f.cells[which])
        order = np.argsort(keys)
        tkeys = keys[order]  # the batch's tiles, sorted

        def place(cells, k):
            t = _member(_keys(cells, k), tkeys)
            sel = np.flatnonzero(t >= 0)
            m = (1 << k) - 1
            return sel, order[t[sel]], cells[sel, 0] & m, cells[sel, 1] & m

        if nb == 0:
            fb = subset(self.f, np.sort(np.asarray(which)))
        for k, (dc, dcls, fr) in enumerate(self.lev, start=1):
            sel, t, jr, jc = place(dc, k)
            span = 1 << (nb - k)  # bins per side of a cell of this level
            dd = np.arange(span)
            rr = (jr * span)[:, None, None] + dd[None, :, None]
            cc = (jc * span)[:, None, None] + dd[None, None, :]
            tiles[t[:, None, None], rr, cc] = dcls[sel][:, None, None]
            if k == nb:
                fb = subset(fr, place(fr.cells, k)[0])
        _, t, jr, jc = place(fb.cells, nb)
        tiles[t, jr, jc] = FRONTIER
        zb = self.f.level + nb
        layout = BinLayout.build(
            fb.cells,
            ns,
            ns,
            lambda s, rows: self.levels.decision_rho(zb + s, rows),
            lambda s, rows: self.levels.tile_lat(zb + s, rows + 0.5),
            lambda s, cols: self.levels.tile_lon(zb + s, cols + 0.5),
        )
        return tiles, layout, fb, (t, jr, jc)


#: zooms up to which a pyramid renders each frontier tile on its own grid (as
#: :func:`~.ondemand.render_tiles` does up to :data:`~.ondemand.ALONE_ZOOM`): there the
#: pyramid's bins hold thousands of arcs each and a tile's own render, from the simplified
#: curves, is 1.5-2.6 times faster (countries_10m, zooms 0-2); from zoom 3 on the batched
#: levels are faster
PYRAMID_ALONE_ZOOM = 2


@functools.lru_cache(maxsize=1024)
def tile_grid(z: int, x: int, y: int, size: int, quad=None):
    """The :class:`~gloffset.grids.Tile` (or the tile of the TMS quadtree ``quad``, a
    :class:`~gloffset.grids.tms.TmsQuad`), made once: it keeps its levels' bounds and
    geometry, the same for every distance (zooms 0-3 have 85 tiles)."""
    if quad is None:
        return Tile(z, x, y, size)
    return quad.tile(z, x, y)


def render_frontier_tiles(chain, which, size, max_block, stats):
    """Masks of the frontier tiles ``which`` (indices into the chain's tiles), as
    ``(index, mask)``: the GPU levels classify the frontier bins of up to
    ``(max_block / size)^2`` tiles per run, packed into one small canvas; every other
    pixel of a tile is its bin's class."""
    from ...raster.gpu import bin_passes

    plog = size.bit_length() - 1
    ns = plog - chain.nb  # GPU levels: a bin is 2^ns pixels on a side
    b = 1 << ns
    per_run = max(1, max_block // size) ** 2
    passes = bin_passes()
    most = getattr(passes.passes, "max_records", None)
    for batch in chain.batches(which, per_run, most):
        tiles, layout, fb, (t, jr, jc) = chain.layout(batch, ns)
        packed = passes.run_layout(layout, chain.d, fb, chain.arcs)
        stats.render_calls += 1
        n, nbin = len(batch), tiles.shape[1]
        out = np.repeat(np.repeat(tiles, b, 1), b, 2)
        view = out.reshape(n, nbin, b, nbin, b).transpose(0, 1, 3, 2, 4)
        view[t, jr, jc] = layout.blocks(packed)
        for k, i in enumerate(batch):
            yield int(i), out[k] == CONTAINED
