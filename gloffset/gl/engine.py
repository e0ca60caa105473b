"""The GPU levels of the raster engine: one fragment-shader pass per level below the bins.

The CPU (:mod:`gloffset.hierarchy`, float64) classifies the coarse levels down to
the bin level and hands over, for every frontier bin, its candidate arcs as records
computed in float64 *relative to the bin centre* (``shaders/lib/arcs.glsl`` lists
them), the inside status of each region component at the bin centre as bits, and
per-level margins ``sin(x) - sin(e)`` and ``chord(x)^2 - chord(e)^2`` for the
distances ``x`` the decisions compare with. The shader then only adds small float32
terms to small float64-made numbers, so near the offset boundary its answer is
exact to a few float32 ulp of the bin's size, not of the unit sphere.

The frontier bins are packed into a small canvas (:class:`BinLayout`); each pass
draws one quad per bin (``shaders/bins.vert``), reads the parent level's classes
(texelFetch) and does real work only for children of frontier cells (see
``shaders/classify.frag``). Every cell outside the frontier bins is its bin's class,
filled in on the CPU.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import GLContextError
from ..hierarchy import FRONTIER, Arcs, Frontier
from ..sphere import arc_distance
from .context import get_context
from .shaders import program

__all__ = ["GpuLevels", "BinLayout", "records"]

RECORD_TEXELS = 6
MAX_LOCAL = 30  # components with their own status bit per bin; more share bit 30
OTHER_BIT = 31  # set when the bin centre is inside a component with no arc in the bin
ARC_IS_ARC, ARC_HAS_DISTANCE, ARC_RING = 1, 2, 4


def records(f: Frontier, arcs: Arcs, e: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Arc records (float32, (pairs, 6, 4)), first record and status bits per frontier bin.

    A bin's records come nearest first (by the distance ``D`` from its centre). All
    terms are computed in float64 relative to the bin centre ``c`` before the cast
    (see ``shaders/lib/arcs.glsl`` for the layout).
    """
    ci, ai = f.pair_cell, f.pair_arc
    dist = arc_distance(f.centers[ci], arcs.a[ai], arcs.b[ai], arcs.n[ai])
    order = np.lexsort((dist, ci))  # per bin, nearest first: passes stop at the first too far
    ci, ai, dist = ci[order], ai[order], dist[order]
    c = f.centers[ci]
    a, b, n = arcs.a[ai], arcs.b[ai], arcs.n[ai]
    se = math.sin(e)
    chord_e = 4.0 * math.sin(0.5 * e) ** 2
    h = np.einsum("ij,ij->i", c, n)
    w1 = np.cross(n, a)
    w2 = np.cross(b, n)
    ea = c - a
    eb = c - b
    rec = np.empty((len(ci), RECORD_TEXELS, 4))
    rec[:, 0, 0] = dist * (1.0 - 1e-7)  # rounded down: a lower bound after the cast
    rec[:, 0, 2] = h
    rec[:, 0, 3] = -h - se
    rec[:, 1, :3] = n
    rec[:, 1, 3] = h - se
    rec[:, 2, :3] = w1
    rec[:, 2, 3] = np.einsum("ij,ij->i", c, w1)
    rec[:, 3, :3] = w2
    rec[:, 3, 3] = np.einsum("ij,ij->i", c, w2)
    rec[:, 4, :3] = ea
    rec[:, 4, 3] = chord_e - np.einsum("ij,ij->i", ea, ea)
    rec[:, 5, :3] = eb
    rec[:, 5, 3] = chord_e - np.einsum("ij,ij->i", eb, eb)
    group = arcs.group[ai]
    flags = (
        np.where(np.any(n != 0.0, axis=1), ARC_IS_ARC, 0)
        | np.where(arcs.boundary[ai], ARC_HAS_DISTANCE, 0)
        | np.where(group >= 0, ARC_RING, 0)
    )

    # local component ids per bin, and the status bits at the bin centre
    k = len(f.cells)
    local = np.zeros(len(ci), dtype=np.int64)
    bits = np.zeros(k, dtype=np.uint64)
    ring = group >= 0
    if ring.any():
        key = ci[ring] * (arcs.n_groups + 1) + group[ring]
        ukey, inv = np.unique(key, return_inverse=True)
        ubin, ugrp = ukey // (arcs.n_groups + 1), ukey % (arcs.n_groups + 1)
        first = np.searchsorted(ubin, ubin)  # first key of the same bin
        rank = np.minimum(np.arange(len(ukey)) - first, MAX_LOCAL)
        local[ring] = rank[inv]
        inside_g = (f.status[ubin, ugrp >> 3] >> (ugrp & 7).astype(np.uint8)) & 1
        np.bitwise_or.at(
            bits, ubin[inside_g == 1], np.uint64(1) << rank[inside_g == 1].astype(np.uint64)
        )
        # inside a component that has no arc here: one shared bit
        n_inside = np.unpackbits(f.status, axis=1, bitorder="little")[:, : arcs.n_groups].sum(
            axis=1
        )
        n_local = np.bincount(ubin, weights=inside_g, minlength=k)
        other = n_inside > n_local
    else:
        other = np.unpackbits(f.status, axis=1, bitorder="little")[:, : max(arcs.n_groups, 1)].any(
            axis=1
        )
    bits |= np.where(other, np.uint64(1) << np.uint64(OTHER_BIT), np.uint64(0))
    rec[:, 0, 1] = flags + 8 * np.where(ring, local, 31)
    first_rec = np.searchsorted(ci, np.arange(k)).astype(np.uint32)
    return rec.astype(np.float32), first_rec, bits.astype(np.uint32)


def _margins(rho: np.ndarray, e: float) -> np.ndarray:
    """(rows, 2, 4) float32: (mu_lo, mu_hi, mu_rho) and (nu_lo, nu_hi, nu_rho) per row."""
    se, ce = math.sin(e), 4.0 * math.sin(0.5 * e) ** 2
    lo, hi = e - rho, e + rho
    out = np.zeros((len(rho), 2, 4))
    never = -1e30
    out[:, 0, 0] = np.where(lo >= 0, np.sin(np.clip(lo, 0, math.pi / 2)) - se, never)
    out[:, 0, 1] = np.sin(np.minimum(hi, math.pi / 2)) - se
    out[:, 0, 2] = np.sin(np.minimum(rho, math.pi / 2)) - se
    out[:, 1, 0] = np.where(lo >= 0, 4.0 * np.sin(0.5 * np.clip(lo, 0, math.pi)) ** 2 - ce, never)
    out[:, 1, 1] = 4.0 * np.sin(0.5 * np.minimum(hi, math.pi)) ** 2 - ce
    out[:, 1, 2] = 4.0 * np.sin(0.5 * np.minimum(rho, math.pi)) ** 2 - ce
    return out.astype(np.float32)


def _set(prog, name: str, value) -> None:
    """Set a uniform if the compiled variant uses it (unused ones are optimised away)."""
    if name in prog:
        prog[name].value = value


def _pot(n: int) -> int:
    """Next power of two: every texture gets power-of-two sides, because llvmpipe
    compiles a new shader variant (about 0.15 s) for each combination of
    power-of-two and other sizes among the bound textures."""
    return 1 << max(0, int(n) - 1).bit_length()


def _pad(a: np.ndarray, shape: tuple) -> np.ndarray:
    out = np.zeros(shape + a.shape[len(shape) :], dtype=a.dtype)
    out[tuple(slice(0, k) for k in a.shape[: len(shape)])] = a
    return out


def pot_texture(ctx, array: np.ndarray, comps: int, dtype: str):
    """A nearest-sampled texture from ``array`` (rows, cols[, comps]) padded to
    power-of-two sides (see :func:`_pot`)."""
    import moderngl

    h, w = array.shape[:2]
    data = _pad(np.ascontiguousarray(array), (_pot(h), _pot(w)))
    t = ctx.texture((_pot(w), _pot(h)), comps, data.tobytes(), dtype=dtype, alignment=1)
    t.filter = (moderngl.NEAREST, moderngl.NEAREST)
    t.repeat_x = t.repeat_y = False
    return t


def class_target(ctx, w: int, h: int):
    """A ``w x h`` R8UI render target for classes (power-of-two sides, see :func:`_pot`)
    and its framebuffer."""
    import moderngl

    target = ctx.texture((_pot(w), _pot(h)), 1, dtype="u1")
    target.filter = (moderngl.NEAREST, moderngl.NEAREST)
    fbo = ctx.framebuffer(color_attachments=[target])
    # moderngl's framebuffer set-up makes one query that GL rejects for an integer
    # colour attachment (GL_INVALID_OPERATION, no effect): clear it so that real
    # errors stay visible
    ctx.error  # noqa: B018
    return target, fbo


@dataclass
class BinLayout:
    """The frontier bins that the GPU levels classify, and the geometry each level needs.

    The passes draw the bins packed row by row into a small *canvas* (:meth:`pos`),
    whatever their place on the sphere (a grid's frontier, or the frontier bins of a
    batch of map tiles, see :mod:`gloffset.tiles`); the caller fills in every other
    cell from its bin's class. Bin ``k`` (in the order of the :class:`Frontier`) has the
    *geo row and column* ``geo[k]``, which index the geometry. Level ``bin level + s``
    has ``2^s x 2^s`` cells per bin; per geo row ``g`` and sub-row ``q < 2^s`` of it:

    * ``rho[s][g, q]``: the bound of the cells of that row (for the decisions);
    * lon/lat grids: ``lat[g]``, the latitude of the bin centres, and ``dphi[s][g, q]``,
      the cell row's latitude minus it; per geo column ``lon`` and ``dlam`` the same;
    * cube faces (``basis`` set): geo rows and columns are the bin's own on the face.

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

    @classmethod
    def build(cls, bins, last, stop, rho_at, lat_at=None, lon_at=None, basis=None, face_size=None):
        """The layout of the bins ``bins`` (k, 2) (rows and columns of the bin level).

        ``rho_at(s, rows)``: bounds of the cells of (whole-level) rows ``rows`` at shift
        ``s``; lon/lat grids give ``lat_at(s, rows)`` and ``lon_at(s, cols)``, the
        latitude and longitude of cell centres (shift 0: the bins); cube faces give
        ``basis`` and ``face_size``. Geo rows and columns are the distinct rows and
        columns of the bins (a cube face's own, since its shader places bins by them).
        """
        bins = np.asarray(bins).reshape(-1, 2)
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
                dphi[s] = lat_at(s, rows) - lat[:, None]
                dlam[s] = lon_at(s, (gc[:, None] << s) + q[None, :]) - lon[:, None]
        return cls(geo, last, stop, rho, lat, lon, dphi, dlam, basis, face_size)

    @classmethod
    def of_grid(cls, grid, f: Frontier, stop_level: int) -> BinLayout:
        """The layout of the frontier bins ``f`` of a grid."""
        bl = f.level

        def rho_at(s, rows):
            r = grid.rho(bl + s)
            return r[np.minimum(rows, len(r) - 1)]

        if hasattr(grid, "face"):
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
        """Bins per row of the canvas."""
        return max(1, math.ceil(math.sqrt(len(self.geo))))

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


def _groups(first: np.ndarray, counts: np.ndarray, limit: int) -> list[tuple[int, int]]:
    """Consecutive bins ``[g0, g1)`` whose records (``first``, ``counts``, contiguous and
    in bin order) number at most ``limit`` per group."""
    if len(first) == 0:
        return []
    if counts.max(initial=0) > limit:
        raise GLContextError(
            f"a bin has {int(counts.max())} candidate arcs, more than the {limit} records one "
            "GL storage buffer holds here; render a smaller image or simplify the shape"
        )
    ends = first.astype(np.int64) + counts
    out, g0 = [], 0
    while g0 < len(first):
        g1 = int(np.searchsorted(ends, int(first[g0]) + limit, side="right"))
        g1 = max(g1, g0 + 1)
        out.append((g0, g1))
        g0 = g1
    return out


class GpuLevels:
    """Runs the levels below the bin level on the GPU (lon/lat grids, cube faces, tiles)."""

    def __init__(self):
        self.ctx = get_context()
        limit = int(self.ctx.info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"])
        self.max_records = max(1, limit // (RECORD_TEXELS * 16))
        self.progs = {
            "lonlat": program(self.ctx, "bins.vert", "classify.frag"),
            "cube": program(self.ctx, "bins.vert", "classify.frag", {"GRID_CUBE": 1}),
        }

    def _tex(self, array: np.ndarray, comps: int, dtype: str):
        return pot_texture(self.ctx, array, comps, dtype)

    def run(
        self,
        grid,
        d: float,
        classes: np.ndarray,
        f: Frontier,
        arcs: Arcs,
        *,
        stop_level: int,
        callback=None,
        timings: list | None = None,
    ) -> np.ndarray:
        """Classes of ``stop_level`` from the bin level's ``classes`` and frontier ``f``.

        Only the frontier bins go through the GPU, packed into a small canvas; every other
        cell of the level is its bin's class, filled in here."""
        layout = BinLayout.of_grid(grid, f, stop_level)
        bl = f.level
        hb, wb = classes.shape

        def full(s, packed):
            """The whole level: bins' classes, with the frontier bins from ``packed``."""
            b = 1 << s
            h, w = grid.level_shape(bl + s)
            out = np.repeat(np.repeat(classes, b, 0), b, 1)
            view = out.reshape(hb, b, wb, b).transpose(0, 2, 1, 3)
            view[f.cells[:, 0], f.cells[:, 1]] = layout.blocks(packed)
            return out[:h, :w]

        def cb(s, packed):
            callback(bl + s, full(s, packed))

        t = None if timings is None else []
        packed = self.run_layout(
            layout, d, f, arcs, callback=cb if callback is not None else None, timings=t
        )
        if timings is not None:
            timings += [(bl + s, tt) for s, tt in t]
        return full(layout.stop, packed)

    def run_layout(
        self,
        layout: BinLayout,
        d: float,
        f: Frontier,
        arcs: Arcs,
        *,
        callback=None,
        timings: list | None = None,
    ) -> np.ndarray:
        """Classes of the canvas at shift ``layout.stop`` (:meth:`BinLayout.blocks` cuts
        out each bin); ``callback(s, classes)`` after each pass."""
        import moderngl

        ctx = self.ctx
        e = abs(d)
        canvas = layout.canvas()
        hb, wb = canvas.shape
        if len(layout.geo) == 0:  # nothing undecided
            for s in range(1, layout.stop + 1) if callback is not None else ():
                callback(s, np.zeros((hb << s, wb << s), dtype=np.uint8))
            return np.zeros((hb << layout.stop, wb << layout.stop), dtype=np.uint8)
        rec, first, bits = records(f, arcs, e)
        counts = np.bincount(f.pair_cell, minlength=len(f.cells)).astype(np.uint32)
        # the records go to storage buffers (faster than textures on llvmpipe), in
        # groups of whole bins that each fit the GL limit on one buffer
        groups = _groups(first, counts, self.max_records)
        pos = layout.pos()
        pj, pi = pos[:, 0], pos[:, 1]
        info = np.zeros((hb, wb, 3), dtype=np.uint32)
        info[pj, pi, 0] = first - np.repeat(
            first[[g0 for g0, _ in groups]], [g1 - g0 for g0, g1 in groups]
        )
        info[pj, pi, 1] = counts
        info[pj, pi, 2] = bits
        geo = np.zeros((hb, wb, 2), dtype=np.uint32)
        geo[pj, pi] = layout.geo
        cube = layout.basis is not None
        p = self.progs["cube" if cube else "lonlat"]
        # the records go to storage buffers (faster than textures on llvmpipe), in
        # groups of whole bins that each fit the GL limit on one buffer
        groups = _groups(first, counts, self.max_records)
        info[pj, pi, 0] = first - np.repeat(
            first[[g0 for g0, _ in groups]], [g1 - g0 for g0, g1 in groups]
        )
        bins = self._tex(info, 3, "u4")
        geo_t = self._tex(geo, 2, "u4")
        textures = [bins, geo_t]
        if cube:
            e_, u_, v_ = layout.basis
            _set(p, "u_face_e", tuple(float(x) for x in e_))
            _set(p, "u_face_u", tuple(float(x) for x in u_))
            _set(p, "u_face_v", tuple(float(x) for x in v_))
            _set(p, "u_px", 2.0 / layout.face_size)
        else:
            lat, lon = layout.lat, layout.lon
            lon_cs = np.stack([np.cos(lon), np.sin(lon)], axis=-1).astype(np.float32)
            lat_cs = np.stack([np.cos(lat), np.sin(lat)], axis=-1).astype(np.float32)
            textures += [self._tex(lat_cs[None], 2, "f4"), self._tex(lon_cs[None], 2, "f4")]
            textures[-2].use(3)
            textures[-1].use(4)
            _set(p, "u_bin_lat", 3)
            _set(p, "u_bin_lon", 4)
        _set(p, "u_parent", 0)
        _set(p, "u_bins", 1)
        _set(p, "u_margins", 5)
        _set(p, "u_bin_geo", 9)
        _set(p, "u_bin_block", float(1 << layout.last))
        _set(p, "u_positive", d >= 0)
        _set(p, "u_e", e)
        bins.use(1)
        geo_t.use(9)
        parent = self._tex(canvas, 1, "u1")
        fb = np.ascontiguousarray(pos[:, ::-1], dtype=np.int32)  # (column, row)
        draws = []  # per group: records, instance buffer (bin positions), vertex array
        for g0, g1 in groups:
            r0, r1 = int(first[g0]), int(first[g1 - 1] + counts[g1 - 1])
            recs = ctx.buffer(rec[r0:r1].tobytes() if r1 > r0 else bytes(RECORD_TEXELS * 16))
            inst = ctx.buffer(fb[g0:g1].tobytes())
            draws.append((recs, inst, ctx.vertex_array(p, [(inst, "2i/i", "in_bin")]), g1 - g0))
        out = canvas
        owned = [parent]
        try:
            for s in range(1, layout.stop + 1):
                h, w = hb << s, wb << s
                final = s == layout.last
                rho = layout.rho[s]
                mt = self._tex(_margins(rho.ravel(), e).reshape(len(rho), -1, 4), 4, "f4")
                target, fbo = class_target(ctx, w, h)
                fbo.use()
                ctx.viewport = (0, 0, w, h)
                parent.use(0)
                mt.use(5)
                level_tex = []
                if not cube:
                    level_tex = [
                        self._tex(layout.dphi[s].astype(np.float32), 1, "f4"),
                        self._tex(layout.dlam[s].astype(np.float32), 1, "f4"),
                    ]
                    level_tex[0].use(7)
                    level_tex[1].use(8)
                    _set(p, "u_row_dphi", 7)
                    _set(p, "u_col_dlam", 8)
                _set(p, "u_shift", s)
                _set(p, "u_size", (float(w), float(h)))
                _set(p, "u_block", float(1 << (layout.last - s)))
                _set(p, "u_final", final)
                _set(p, "u_rho_max", 0.0 if final else float(rho.max()))
                for recs, _, vao, n in draws:
                    recs.bind_to_storage_buffer(0)
                    vao.render(moderngl.TRIANGLES, vertices=6, instances=n)
                if timings is not None:
                    ctx.finish()
                    timings.append((s, time.perf_counter()))
                if callback is not None or s == layout.stop:
                    data = fbo.read(viewport=(0, 0, w, h), components=1, dtype="u1")
                    out = np.frombuffer(data, dtype=np.uint8).reshape(h, w)
                    if callback is not None:
                        callback(s, out)
                fbo.release()
                mt.release()
                for t in level_tex:
                    t.release()
                for t in owned:
                    t.release()
                owned = [target]
                parent = target
        finally:
            for objs in draws:
                for o in objs[:3]:
                    o.release()
            for t in owned + textures:
                t.release()
        return out.copy()


_ENGINE: GpuLevels | None = None


def engine() -> GpuLevels:
    global _ENGINE
    if _ENGINE is None:
        _ENGINE = GpuLevels()
    return _ENGINE
