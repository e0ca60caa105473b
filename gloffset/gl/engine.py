"""The GPU levels of the raster engine: one fragment-shader pass per level below the bins.

The CPU (:mod:`gloffset.raster.levels`, float64) classifies the coarse levels down to
the bin level and hands over, for every frontier bin, its candidate arcs as records
computed in float64 *relative to the bin centre* (``shaders/lib/arcs.glsl`` lists
them), the inside status of each region component at the bin centre as bits, and
per-level margins ``sin(x) - sin(e)`` and ``chord(x)^2 - chord(e)^2`` for the
distances ``x`` the decisions compare with. The shader then only adds small float32
terms to small float64-made numbers, so near the offset boundary its answer is
exact to a few float32 ulp of the bin's size, not of the unit sphere.

A bin's records come in *clusters* (:func:`records`): runs of up to :data:`CLUSTER`
arcs that follow each other along a ring, each with a header bounding them by a ball
around the bin centre, so that a cell skips, with a handful of operations, the
clusters that provably cannot change its class (too far for every distance test and
unable to cross the arc from the cell to the bin centre); the classes are the same
bit for bit as when every record is visited (``shaders/classify.frag``).

The frontier bins are packed into a small canvas (:class:`BinLayout`); each pass
draws one quad per bin (``shaders/bins.vert``) twice: a prepass gives the cells whose
parent (in the previous level's classes) is decided their parent's class and marks
the children of frontier cells in a depth buffer, and the level's pass does the real
work for those only (llvmpipe skips whole blocks that fail the depth test; without
it, every fragment would run the whole shader under an empty mask). Every cell
outside the frontier bins is its bin's class, filled in on the CPU.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..caps import CAP_SLACK, cap_range, chord2
from ..edges import CurveArcs as Arcs
from ..errors import GLContextError
from ..raster.levels import FRONTIER, Frontier
from ..sphere import dot
from .context import context_info, get_context
from .shaders import program

__all__ = ["GpuLevels", "BinLayout", "records"]

RECORD_TEXELS = 6
MAX_LOCAL = 30  # components with their own status bit per bin; more share bit 30
OTHER_BIT = 31  # set when the bin centre is inside a component with no arc in the bin
ARC_IS_ARC, ARC_HAS_DISTANCE, ARC_RING = 1, 2, 4
CLUSTER = 8  # records per cluster at most (shaders/classify.frag); 8 and 16 cull about alike
_DENSE = 1 << 22  # (bin, component) keys counted in a dense table up to this many
_BLOCK = 4096  # pairs per block of float64 work in records()
_MASK_FROM = 2  # the first shift with a prepass and depth mask (run_layout)
# Bins per canvas row, at least (BinLayout.side): llvmpipe's threads share the image in
# 64-pixel tiles, so the first levels, where a bin is a few pixels, need a wide canvas
# to run on more than one thread. Up to a canvas _CANVAS_WIDTH pixels wide.
_CANVAS_ROW = 128
_CANVAS_WIDTH = 4096
_F32_TINY = float(np.finfo(np.float32).tiny)  # least positive normal float32
_POPCOUNT = np.unpackbits(np.arange(256, dtype=np.uint8)[:, None], axis=1).sum(axis=1)


def records(f: Frontier, arcs: Arcs, e: float, cluster: int = CLUSTER) -> tuple[np.ndarray, ...]:
    """Arc records and their clusters for the frontier bins ``f`` (``shaders/lib/arcs.glsl``).

    Returns ``(rec, first, bits, clusters, first_cluster, n_clusters)``: ``rec``
    (pairs, 6, 4) float32, the records of the candidate pairs in their order (by bin);
    ``first`` (k,) uint32, the first record of each bin; ``bits`` (k,) uint32, the
    status bits at the bin centres; ``clusters`` (m, 2, 4) uint32, the cluster headers
    (float32 bits, and ``16 * first record + records - 1`` last); ``first_cluster`` and
    ``n_clusters`` (k,) uint32, each bin's clusters, in increasing order of their
    nearest record ``Dmin``.

    A cluster is a run of up to ``cluster`` (<= 16) pairs of one bin whose arcs follow
    each other along a ring (consecutive arc indices); its header bounds them by a ball
    around the bin centre. All terms are computed in float64 relative to the bin centre
    ``c`` before the cast, in blocks of pairs (small temporaries, reused).
    """
    if not 1 <= cluster <= 16:
        raise ValueError(f"cluster must be 1..16, got {cluster}")
    ci = np.asarray(f.pair_cell, dtype=np.int64)
    ai = np.asarray(f.pair_arc, dtype=np.int64)
    if np.any(ci[1:] < ci[:-1]):  # pairs come sorted by cell; keep to that
        perm = np.argsort(ci, kind="stable")
        ci, ai = ci[perm], ai[perm]
    k, npair = len(f.cells), len(ci)
    if npair >= 1 << 28:
        raise GLContextError(f"{npair} candidate pairs: too many for one render")
    se = math.sin(e)
    chord_e = float(chord2(e))
    out = np.empty((npair, RECORD_TEXELS * 4), dtype=np.float32)  # cast on assignment
    code = np.empty(npair, dtype=np.int64)
    lune1, lune2 = arcs.lunes
    for s0 in range(0, npair, _BLOCK):
        sl = slice(s0, min(s0 + _BLOCK, npair))
        c = np.take(f.centers, ci[sl], axis=0)
        a, b, n, w1, w2, mid = (
            np.take(v, ai[sl], axis=0) for v in (arcs.a, arcs.b, arcs.n, lune1, lune2, arcs.mid)
        )
        ea = c - a
        eb = c - b
        is_arc = dot(n, n) > 0.5  # n is a unit vector or zero
        # D: a lower bound on the distance from c to the arc, by its bounding cap
        d = cap_range(dot(c, mid), np.take(arcs.half, ai[sl]))[0] - CAP_SLACK
        np.maximum(d, 0.0, out=d)
        h = dot(c, n)
        o = out[sl]
        o[:, 0] = d * (1.0 - 1e-7)  # rounded down: still a lower bound after the cast
        o[:, 2] = np.where((h < 0.0) & (h > -_F32_TINY), -_F32_TINY, h)
        o[:, 3] = -h - se
        o[:, 4:7] = n
        o[:, 7] = h - se
        o[:, 8:11] = w1
        o[:, 11] = np.einsum("ij,ij->i", c, w1)
        o[:, 12:15] = w2
        o[:, 15] = np.einsum("ij,ij->i", c, w2)
        o[:, 16:19] = ea
        o[:, 19] = chord_e - np.einsum("ij,ij->i", ea, ea)
        o[:, 20:23] = eb
        o[:, 23] = chord_e - np.einsum("ij,ij->i", eb, eb)
        code[sl] = np.where(is_arc, ARC_IS_ARC, 0)

    # flags + 8 * local component id (31 for arcs of no ring), and the status bits at
    # the bin centre
    group = np.take(arcs.group, ai)
    ring = group >= 0
    code += np.where(ring, ARC_RING, 0) + np.where(np.take(arcs.boundary, ai), ARC_HAS_DISTANCE, 0)
    code += 8 * 31
    ng = arcs.n_groups
    bits = np.zeros(k, dtype=np.uint64)
    # components the centre is inside: popcount of the first max(ng, 1) status bits
    width = np.clip(max(ng, 1) - 8 * np.arange(f.status.shape[1]), 0, 8)
    n_inside = _POPCOUNT[f.status & ((1 << width) - 1).astype(np.uint8)].sum(axis=1)
    if ring.any():
        key = ci[ring] * ng + group[ring]  # (bin, component); ranks among sorted keys
        if k * ng <= _DENSE:
            present = np.zeros(k * ng, dtype=bool)
            present[key] = True
            ukey = np.flatnonzero(present)
            lut = np.empty(k * ng, dtype=np.int64)
            lut[ukey] = np.arange(len(ukey))
            inv = lut[key]
        else:
            ukey, inv = np.unique(key, return_inverse=True)
        ubin, ugrp = ukey // ng, ukey % ng
        rank = np.minimum(np.arange(len(ukey)) - np.searchsorted(ubin, ubin), MAX_LOCAL)
        code[ring] += 8 * (rank[inv] - 31)
        inside_g = ((f.status[ubin, ugrp >> 3] >> (ugrp & 7).astype(np.uint8)) & 1) == 1
        np.bitwise_or.at(bits, ubin[inside_g], np.uint64(1) << rank[inside_g].astype(np.uint64))
        # inside a component that has no arc here: one shared bit
        other = n_inside > np.bincount(ubin[inside_g], minlength=k)
    else:
        other = n_inside > 0
    bits |= np.where(other, np.uint64(1) << np.uint64(OTHER_BIT), np.uint64(0))
    out[:, 1] = code

    # clusters: runs of consecutive arcs of a bin, cut every `cluster` pairs
    start = np.ones(npair, dtype=bool)
    start[1:] = (ci[1:] != ci[:-1]) | (ai[1:] != ai[:-1] + 1)
    run_first = np.flatnonzero(start)
    pos = np.arange(npair) - np.repeat(run_first, np.diff(np.append(run_first, npair)))
    cfirst = np.flatnonzero(start | (pos % cluster == 0))
    m = len(cfirst)
    csize = np.diff(np.append(cfirst, npair))
    cid = np.repeat(np.arange(m), csize)
    # The ball (Q, rho) around c holds every point of the cluster's arcs. A short arc
    # lies in the ball of centre (a + b) / 2 and radius |a - b| / 2. The offsets
    # A = a - c, B = b - c are taken from the records: -t4, -t5 are within 6e-8 |A|,
    # 6e-8 |B| of them (float64 rounding of c - a, then float32), so the arc lies in the
    # ball of centre -(t4 + t5) / 2 and radius |t4 - t5| / 2 + 1.2e-7 (|t4| + |t5|). Q is
    # the centre of the box of the -t4, -t5 (exact in float32); rho, computed in
    # float64, is widened by far more than its rounding (1e-9 relative) and by Q's
    # float32 rounding, then rho and S = |Q| + rho are rounded up to float32.
    t4, t5 = out[:, 16:19], out[:, 20:23]
    q = np.empty((m, 3))
    for j in range(3):
        lo = np.minimum.reduceat(np.minimum(t4[:, j], t5[:, j]), cfirst)
        hi = np.maximum.reduceat(np.maximum(t4[:, j], t5[:, j]), cfirst)
        q[:, j] = -0.5 * (lo.astype(np.float64) + hi)
    r = np.empty(npair)
    for s0 in range(0, npair, _BLOCK):
        sl = slice(s0, min(s0 + _BLOCK, npair))
        u, v = t4[sl].astype(np.float64), t5[sl].astype(np.float64)
        dm = np.take(q, cid[sl], axis=0)
        dm += 0.5 * (u + v)  # Q - centre
        uv = u - v
        lu, lv = np.sqrt(dot(u, u)), np.sqrt(dot(v, v))
        r[sl] = np.sqrt(dot(dm, dm)) + 0.5 * np.sqrt(dot(uv, uv)) + 1.2e-7 * (lu + lv)
    rho = np.maximum.reduceat(r, cfirst) if m else np.zeros(0)
    q32 = q.astype(np.float32)
    dq = q - q32
    rho32 = _round_up((rho + np.sqrt(dot(dq, dq))) * (1.0 + 1e-9) + 1e-30)
    q64 = q32.astype(np.float64)
    s32 = _round_up((np.sqrt(dot(q64, q64)) + rho32) * (1.0 + 1e-9))
    dmin = np.minimum.reduceat(out[:, 0], cfirst)  # the smallest t0.x, exactly
    hmin = np.minimum.reduceat(np.where(ring, np.abs(out[:, 2]), np.float32(np.inf)), cfirst)

    # A bin's clusters by Dmin: the key is the float32 value itself (nonnegative, so
    # its bits sort as integers), so the shader's break on Dmin > skip is exact.
    cbin = ci[cfirst]
    corder = np.argsort((cbin << 32) | dmin.view(np.uint32), kind="stable")
    hdr = np.empty((m, 2, 4), dtype=np.float32)
    hdr[:, 0, :3] = q32
    hdr[:, 0, 3] = rho32
    hdr[:, 1, 0] = dmin
    hdr[:, 1, 1] = hmin
    hdr[:, 1, 2] = s32
    hdr = hdr.view(np.uint32)
    hdr[:, 1, 3] = 16 * cfirst + csize - 1
    hdr = np.take(hdr, corder, axis=0)
    bins = np.arange(k)
    first = np.searchsorted(ci, bins).astype(np.uint32)
    cb = cbin[corder]
    first_cluster = np.searchsorted(cb, bins)
    n_clusters = np.searchsorted(cb, bins, side="right") - first_cluster
    return (
        out.reshape(npair, RECORD_TEXELS, 4),
        first,
        bits.astype(np.uint32),
        hdr,
        first_cluster.astype(np.uint32),
        n_clusters.astype(np.uint32),
    )


def _round_up(x: np.ndarray) -> np.ndarray:
    """float32 values >= the float64 values ``x``."""
    y = x.astype(np.float32)
    return np.where(y < x, np.nextafter(y, np.float32(np.inf)), y)


def _margins(rho: np.ndarray, e: float) -> np.ndarray:
    """(rows, 2, 4) float32: (mu_lo, mu_hi, mu_rho) and (nu_lo, nu_hi, nu_rho) per row."""
    se, ce = math.sin(e), float(chord2(e))
    lo, hi = e - rho, e + rho
    out = np.zeros((len(rho), 2, 4))
    never = -1e30
    out[:, 0, 0] = np.where(lo >= 0, np.sin(np.clip(lo, 0, math.pi / 2)) - se, never)
    out[:, 0, 1] = np.sin(np.minimum(hi, math.pi / 2)) - se
    out[:, 0, 2] = np.sin(np.minimum(rho, math.pi / 2)) - se
    out[:, 1, 0] = np.where(lo >= 0, chord2(lo) - ce, never)
    out[:, 1, 1] = chord2(hi) - ce
    out[:, 1, 2] = chord2(rho) - ce
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


def class_target(ctx, w: int, h: int, depth: bool = False):
    """A ``w x h`` R8UI render target for classes (power-of-two sides, see :func:`_pot`)
    with its framebuffer and, with ``depth``, a depth buffer (else None)."""
    import moderngl

    target = ctx.texture((_pot(w), _pot(h)), 1, dtype="u1")
    target.filter = (moderngl.NEAREST, moderngl.NEAREST)
    zbuf = ctx.depth_renderbuffer(target.size) if depth else None
    fbo = ctx.framebuffer(color_attachments=[target], depth_attachment=zbuf)
    # moderngl's framebuffer set-up makes one query that GL rejects for an integer
    # colour attachment (GL_INVALID_OPERATION, no effect): clear it so that real
    # errors stay visible
    ctx.error  # noqa: B018
    return target, fbo, zbuf


@dataclass
class BinLayout:
    """The frontier bins that the GPU levels classify, and the geometry each level needs.

    The passes draw the bins packed row by row into a small *canvas* (:meth:`pos`),
    whatever their place on the sphere (a grid's frontier, or the frontier bins of a
    batch of map tiles, see :mod:`gloffset.raster.tiles`); the caller fills in every other
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
        limit = context_info()["max_storage_block_size"]
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
        values: np.ndarray | None = None,
    ) -> np.ndarray:
        """Classes of ``stop_level`` from the bin level's ``classes`` and frontier ``f``.

        Only the frontier bins go through the GPU, packed into a small canvas; every other
        cell of the level is its bin's class, filled in here. ``values`` (uint8, indexed
        by class) gives ``values[classes]`` instead, made before the cells are spread out
        (a mask costs no pass over the whole image)."""
        layout = BinLayout.of_grid(grid, f, stop_level)
        bl = f.level
        hb, wb = classes.shape

        def full(s, packed, lut=None):
            """The whole level: bins' classes, with the frontier bins from ``packed``
            (mapped through ``lut`` first, on the small arrays)."""
            b = 1 << s
            h, w = grid.level_shape(bl + s)
            src, blocks = classes, layout.blocks(packed)
            if lut is not None:
                src, blocks = lut[src], lut[blocks]
            # columns spread on the small array, then whole rows copied b times
            out = np.empty((hb * b, wb * b), dtype=np.uint8)
            out.reshape(hb, b, wb * b)[...] = np.repeat(src, b, axis=1)[:, None, :]
            view = out.reshape(hb, b, wb, b).transpose(0, 2, 1, 3)
            view[f.cells[:, 0], f.cells[:, 1]] = blocks
            return out[:h, :w]

        def cb(s, packed):
            callback(bl + s, full(s, packed))

        t = None if timings is None else []
        packed = self.run_layout(
            layout, d, f, arcs, callback=cb if callback is not None else None, timings=t
        )
        if timings is not None:
            timings += [(bl + s, tt) for s, tt in t]
        return full(layout.stop, packed, values)

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
        rec, first, bits, hdr, cfirst, ccount = records(f, arcs, e)
        counts = np.bincount(f.pair_cell, minlength=len(f.cells)).astype(np.uint32)
        # the records and their clusters go to storage buffers (faster than textures on
        # llvmpipe), in groups of whole bins that each fit the GL limit on one buffer
        # (a cluster takes less room than a record)
        groups = _groups(first, counts, self.max_records)
        g0s = np.array([g0 for g0, _ in groups])
        sizes = [g1 - g0 for g0, g1 in groups]
        pos = layout.pos()
        pj, pi = pos[:, 0], pos[:, 1]
        info = np.zeros((hb, wb, 3), dtype=np.uint32)
        info[pj, pi, 0] = cfirst - np.repeat(cfirst[g0s], sizes)
        info[pj, pi, 1] = ccount
        info[pj, pi, 2] = bits
        geo = np.zeros((hb, wb, 2), dtype=np.uint32)
        geo[pj, pi] = layout.geo
        cube = layout.basis is not None
        p = self.progs["cube" if cube else "lonlat"]
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
        pre = self.progs.get("prepass")
        if pre is None:
            pre = self.progs["prepass"] = program(ctx, "bins.vert", "classify.frag", {"PREPASS": 1})
        _set(pre, "u_parent", 0)
        everyone = ctx.buffer(fb.tobytes())
        pre_vao = ctx.vertex_array(pre, [(everyone, "2i/i", "in_bin")])
        draws = []  # per group: records, clusters, instance buffer (bin positions), vertex array
        for g0, g1 in groups:
            r0, r1 = int(first[g0]), int(first[g1 - 1] + counts[g1 - 1])
            c0, c1 = int(cfirst[g0]), int(cfirst[g1 - 1] + ccount[g1 - 1])
            recs = ctx.buffer(rec[r0:r1].tobytes() if r1 > r0 else bytes(RECORD_TEXELS * 16))
            hg = hdr[c0:c1].copy()
            hg[:, 1, 3] -= np.uint32(16 * r0)  # first records within the group's buffer
            clus = ctx.buffer(hg.tobytes() if c1 > c0 else bytes(32))
            inst = ctx.buffer(fb[g0:g1].tobytes())
            vao = ctx.vertex_array(p, [(inst, "2i/i", "in_bin")])
            draws.append((recs, clus, inst, vao, g1 - g0))
        out = canvas
        owned = [parent]
        try:
            for s in range(1, layout.stop + 1):
                h, w = hb << s, wb << s
                final = s == layout.last
                rho = layout.rho[s]
                mt = self._tex(_margins(rho.ravel(), e).reshape(len(rho), -1, 4), 4, "f4")
                # at shift 1 every cell of a frontier bin is a child of a frontier cell
                masked = s >= _MASK_FROM
                target, fbo, depth = class_target(ctx, w, h, depth=masked)
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
                for prog in (pre, p):
                    _set(prog, "u_shift", s)
                    _set(prog, "u_size", (float(w), float(h)))
                # decided cells and the depth mask of the frontier's children, then the
                # level's pass over those only (see PREPASS in classify.frag)
                if masked:
                    ctx.enable(moderngl.DEPTH_TEST)
                    ctx.depth_func = "1"
                    pre_vao.render(moderngl.TRIANGLES, vertices=6, instances=len(fb))
                    ctx.depth_func = "<"
                else:
                    ctx.disable(moderngl.DEPTH_TEST)
                _set(p, "u_block", float(1 << (layout.last - s)))
                _set(p, "u_final", final)
                _set(p, "u_rho_max", 0.0 if final else float(rho.max()))
                for recs, clus, _, vao, n in draws:
                    recs.bind_to_storage_buffer(0)
                    clus.bind_to_storage_buffer(1)
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
                if depth is not None:
                    depth.release()
                mt.release()
                for t in level_tex:
                    t.release()
                for t in owned:
                    t.release()
                owned = [target]
                parent = target
        finally:
            ctx.disable(moderngl.DEPTH_TEST)
            ctx.depth_func = "<"
            for objs in draws:
                for o in objs[:4]:
                    o.release()
            pre_vao.release()
            everyone.release()
            for t in owned + textures:
                t.release()
        return out.copy()


_ENGINE: GpuLevels | None = None


def engine() -> GpuLevels:
    global _ENGINE
    if _ENGINE is None:
        _ENGINE = GpuLevels()
    return _ENGINE
