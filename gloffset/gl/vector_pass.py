"""The GL passes of the raster engine's GPU levels: one fragment-shader pass per level
below the bins (``shaders/classify.frag``), run from a :class:`BinPlan`.

The planner (:mod:`gloffset.raster.gpu`) classifies the coarse levels in float64 down to
the bin level, packs the frontier bins into a small canvas
(:class:`gloffset.raster.layout.BinLayout`) and their candidate arcs into float32 records
made in float64 relative to the bin centres (:mod:`gloffset.raster.records`), and hands
all of it over as plain arrays: a :class:`BinPlan`. This module only uploads them, draws
and reads back; it knows no grid, shape or level.

Each pass draws one quad per bin (``shaders/bins.vert``) twice: a prepass gives the cells
whose parent (in the previous level's classes) is decided their parent's class and marks
the children of frontier cells in a depth buffer, and the level's pass does the real
work for those only (llvmpipe skips whole blocks that fail the depth test; without it,
every fragment would run the whole shader under an empty mask). The records and their
clusters go to storage buffers, in groups of whole bins that each fit the GL limit on
one buffer (:func:`_groups`), one draw per group.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import GLContextError
from .context import context_info, get_context, shared
from .records_pass import DeviceRecords
from .shaders import program
from .textures import class_target, pot_texture
from .textures import set_uniform as _set

__all__ = ["BinPlan", "VectorPasses", "set_grid_constants", "vector_passes"]

RECORD_TEXELS = 6  # vec4 texels per arc record (shaders/classify.frag)
_CLUSTER_BYTES = 32  # two uvec4 per cluster header (CLUSTER_TEXELS in classify.frag)
_MASK_FROM = 2  # the first shift with a prepass and depth mask
_GRID_CONSTANTS = 16  # u_grid's length (a grid's GLSL function, lib/grids/)


def set_grid_constants(prog, constants) -> None:
    """Set ``u_grid`` (``double[16]``, a grid's GLSL function) of ``prog`` to
    ``constants`` (zeros after them): as many as the compiled program keeps (a driver
    trims the array after the last element read)."""
    consts = [float(c) for c in constants]
    if len(consts) > _GRID_CONSTANTS:
        raise ValueError(f"a grid's GLSL function takes {_GRID_CONSTANTS} constants at most")
    if "u_grid" in prog:
        n = prog["u_grid"].array_length
        prog["u_grid"].value = tuple((consts + [0.0] * n)[:n])


@dataclass
class BinPlan:
    """What the passes of :class:`VectorPasses` draw: the frontier bins on their canvas, their
    records and the geometry of every level, as plain arrays (made in float64 and cast by
    the planner, :func:`gloffset.raster.gpu.bin_plan`).

    Canvas: ``canvas`` (hb, wb) uint8, the bin-level classes (FRONTIER where a bin is);
    ``pos`` (k, 2) the canvas row and column of each bin, ``geo`` (k, 2) its geo row and
    column (they index the geometry). Shift ``s`` (level ``bin level + s``, ``1..stop``)
    has ``2^s x 2^s`` cells per bin; ``last`` is the shift of the output level (decided
    at the centres); ``e = |d|``, ``positive``: ``d >= 0``.

    Records (``shaders/lib/arcs.glsl``, :func:`gloffset.raster.records.records`):
    ``records`` (pairs, 6, 4) float32 by bin, ``first`` and ``counts`` (k,) uint32 each
    bin's, ``bits`` (k,) uint32 the status bits at the bin centres, ``clusters`` (m, 2, 4)
    uint32 the cluster headers, ``first_cluster`` and ``n_clusters`` (k,) each bin's.

    Per shift ``s``: ``margins[s]`` (geo rows, 2 * 2^s, 4) float32 (per sub-row the mu and
    nu margins), ``rho_max[s]`` the largest cell bound (0 at ``last``). Lon/lat grids:
    ``bin_lat``, ``bin_lon`` (1, geo rows or columns, 2) float32 the cosine and sine of the
    bin centres' latitude and longitude, ``dphi[s]`` (geo rows, 2^s) and ``dlam[s]`` (geo
    columns, 2^s) float32 the cell rows' latitude and columns' longitude minus their bin's.
    Cube faces: ``basis`` (3, 3) the face's axes and ``face_size`` its pixels per side.
    Grids with a GLSL function of their centres: ``grid_source`` its file (defining
    ``grid_centre``, :class:`gloffset.grids.protocol.GlslCentres`), ``grid_constants``
    its ``u_grid``, ``bin_centre`` and ``bin_centre_lo`` (hb, wb, 3) float32 the bin
    centres in two parts (their sum: the float64 centre to 48 bits); ``geo`` the bins'
    rows and columns in the grid.
    Other grids (textured centres): ``bin_centre`` (hb, wb, 3) float32 the bin centres on
    the canvas, ``cell_delta(s, parent)`` (hb 2^s, wb 2^s, 3) float32 each cell's centre
    minus its bin's (made in float64) for the children of the frontier cells of
    ``parent``, the classes read back from shift ``s - 1`` (the canvas at shift 1).
    Records made on the GL context (:mod:`gloffset.gl.records_pass`): ``device`` their
    buffers, bound as they are in one draw (``records`` and ``clusters`` are then empty;
    the run releases the buffers).
    """

    canvas: np.ndarray
    pos: np.ndarray
    geo: np.ndarray
    last: int
    stop: int
    e: float
    positive: bool
    records: np.ndarray
    first: np.ndarray
    counts: np.ndarray
    bits: np.ndarray
    clusters: np.ndarray
    first_cluster: np.ndarray
    n_clusters: np.ndarray
    margins: dict
    rho_max: dict
    bin_lat: np.ndarray | None = None
    bin_lon: np.ndarray | None = None
    dphi: dict | None = None
    dlam: dict | None = None
    basis: np.ndarray | None = None
    face_size: int | None = None
    bin_centre: np.ndarray | None = None
    cell_delta: Callable[[int, np.ndarray], np.ndarray] | None = None
    bin_centre_lo: np.ndarray | None = None
    grid_source: str | None = None
    grid_constants: tuple = ()
    device: DeviceRecords | None = None

    @property
    def cube(self) -> bool:
        return self.basis is not None

    @property
    def kind(self) -> str:
        """The program variant: ``"cube"``, ``"texture"``, ``"lonlat"`` or, for a grid's
        GLSL function, its file."""
        if self.basis is not None:
            return "cube"
        if self.grid_source is not None:
            return self.grid_source
        return "texture" if self.bin_centre is not None else "lonlat"


def _groups(first: np.ndarray, counts: np.ndarray, limit: int) -> list[tuple[int, int]]:
    """Consecutive bins ``[g0, g1)`` whose records (``first``, ``counts``, contiguous and
    in bin order) number at most ``limit`` per group (one GL storage buffer each)."""
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


class VectorPasses:
    """Runs the levels below the bin level on the GPU (lon/lat grids, cube faces, tiles):
    the programs, compiled once, and :meth:`run`."""

    def __init__(self):
        self.ctx = get_context()
        limit = context_info()["max_storage_block_size"]
        self.max_records = max(1, limit // (RECORD_TEXELS * 16))
        self.progs = {
            "lonlat": program(self.ctx, "bins.vert", "classify.frag"),
            "cube": program(self.ctx, "bins.vert", "classify.frag", {"GRID_CUBE": 1}),
        }

    def _program(self, kind: str):
        """The level program of a grid kind (the textured one, and that of each grid's
        GLSL function, compiled on first use)."""
        p = self.progs.get(kind)
        if p is None:
            defines = {"GRID_TEXTURE": 1} if kind == "texture" else {"GRID_GLSL": f'"{kind}"'}
            p = self.progs[kind] = program(self.ctx, "bins.vert", "classify.frag", defines)
        return p

    def _tex(self, array: np.ndarray, comps: int, dtype: str):
        return pot_texture(self.ctx, array, comps, dtype)

    def run(self, plan: BinPlan, *, callback=None, timings: list | None = None) -> np.ndarray:
        """Classes of the canvas at shift ``plan.stop``; ``callback(s, classes)`` after each
        pass, ``timings`` gets ``(s, time)`` when each pass has finished."""
        if plan.records.shape[1:] != (RECORD_TEXELS, 4):
            raise ValueError(
                f"records must be (pairs, {RECORD_TEXELS}, 4), got {plan.records.shape}"
            )
        try:
            return self._run(plan, callback, timings)
        finally:
            if plan.device is not None:
                plan.device.release()

    def _run(self, plan: BinPlan, callback, timings) -> np.ndarray:
        ctx = self.ctx
        groups = _groups(plan.first, plan.counts, self.max_records)
        if plan.device is not None and len(groups) > 1:
            raise GLContextError("records made on the GL context must fit one storage buffer")
        p = self._program(plan.kind)
        textures = self._bin_textures(p, plan, groups)
        parent = self._tex(plan.canvas, 1, "u1")
        fb = np.ascontiguousarray(plan.pos[:, ::-1], dtype=np.int32)  # (column, row)
        pre = self._prepass()
        everyone = ctx.buffer(fb.tobytes())
        pre_vao = ctx.vertex_array(pre, [(everyone, "2i/i", "in_bin")])
        draws = self._draws(p, plan, groups, fb)
        out = plan.canvas
        owned = [parent]
        try:
            textured = plan.kind == "texture"
            for s in range(1, plan.stop + 1):
                # a textured plan reads every level back: its next level's centres are
                # made for the children of the frontier cells only
                read = callback is not None or s == plan.stop or textured
                delta = None
                if textured:
                    assert plan.cell_delta is not None  # a textured plan's
                    delta = plan.cell_delta(s, out)
                target, got, done = self._level(
                    s,
                    plan,
                    p,
                    (pre, pre_vao, len(fb)),
                    draws,
                    (parent, delta),
                    read,
                    timings is not None,
                )
                if timings is not None:
                    timings.append((s, done))
                if read:
                    out = got
                    if callback is not None:
                        callback(s, out)
                for t in owned:
                    t.release()
                owned = [target]
                parent = target
        finally:
            import moderngl

            ctx.disable(moderngl.DEPTH_TEST)
            ctx.depth_func = "<"
            for objs in draws:
                for o in objs[:4] if plan.device is None else objs[2:4]:
                    o.release()
            pre_vao.release()
            everyone.release()
            for t in owned + textures:
                t.release()
        return out.copy()

    def _prepass(self):
        """The prepass program (``PREPASS`` in classify.frag), compiled on first use."""
        pre = self.progs.get("prepass")
        if pre is None:
            pre = self.progs["prepass"] = program(
                self.ctx, "bins.vert", "classify.frag", {"PREPASS": 1}
            )
        _set(pre, "u_parent", 0)
        return pre

    def _bin_textures(self, p, plan: BinPlan, groups) -> list:
        """The per-bin textures (clusters and status bits, geo row and column; lon/lat: the
        bin centres), bound to their units, and the uniforms of the whole run."""
        hb, wb = plan.canvas.shape
        g0s = np.array([g0 for g0, _ in groups])
        sizes = [g1 - g0 for g0, g1 in groups]
        pj, pi = plan.pos[:, 0], plan.pos[:, 1]
        info = np.zeros((hb, wb, 3), dtype=np.uint32)
        info[pj, pi, 0] = plan.first_cluster - np.repeat(plan.first_cluster[g0s], sizes)
        info[pj, pi, 1] = plan.n_clusters
        info[pj, pi, 2] = plan.bits
        geo = np.zeros((hb, wb, 2), dtype=np.uint32)
        geo[pj, pi] = plan.geo
        bins = self._tex(info, 3, "u4")
        geo_t = self._tex(geo, 2, "u4")
        textures = [bins, geo_t]
        if plan.cube:
            assert plan.basis is not None and plan.face_size is not None  # a cube plan's
            e_, u_, v_ = plan.basis
            _set(p, "u_face_e", tuple(float(x) for x in e_))
            _set(p, "u_face_u", tuple(float(x) for x in u_))
            _set(p, "u_face_v", tuple(float(x) for x in v_))
            _set(p, "u_px", 2.0 / plan.face_size)
        elif plan.grid_source is not None:
            assert plan.bin_centre is not None and plan.bin_centre_lo is not None
            textures += [
                self._tex(plan.bin_centre, 3, "f4"),
                self._tex(plan.bin_centre_lo, 3, "f4"),
            ]
            textures[-2].use(3)
            textures[-1].use(4)
            _set(p, "u_bin_centre", 3)
            _set(p, "u_bin_centre_lo", 4)
            set_grid_constants(p, plan.grid_constants)
        elif plan.kind == "texture":
            assert plan.bin_centre is not None  # a textured plan's
            textures.append(self._tex(plan.bin_centre, 3, "f4"))
            textures[-1].use(3)
            _set(p, "u_bin_centre", 3)
        else:
            assert plan.bin_lat is not None and plan.bin_lon is not None  # a lon/lat plan's
            textures += [self._tex(plan.bin_lat, 2, "f4"), self._tex(plan.bin_lon, 2, "f4")]
            textures[-2].use(3)
            textures[-1].use(4)
            _set(p, "u_bin_lat", 3)
            _set(p, "u_bin_lon", 4)
        _set(p, "u_parent", 0)
        _set(p, "u_bins", 1)
        _set(p, "u_margins", 5)
        _set(p, "u_bin_geo", 9)
        _set(p, "u_bin_block", float(1 << plan.last))
        _set(p, "u_positive", plan.positive)
        _set(p, "u_e", plan.e)
        bins.use(1)
        geo_t.use(9)
        return textures

    def _draws(self, p, plan: BinPlan, groups, fb: np.ndarray) -> list:
        """Per group of bins: its records and clusters (storage buffers), the instance
        buffer of its bins' canvas positions, the vertex array and the number of bins."""
        ctx = self.ctx
        first, counts, hdr = plan.first, plan.counts, plan.clusters
        cfirst, ccount = plan.first_cluster, plan.n_clusters
        draws = []
        if plan.device is not None:  # one group (run checks), the buffers as they are
            inst = ctx.buffer(fb.tobytes())
            vao = ctx.vertex_array(p, [(inst, "2i/i", "in_bin")])
            return [(plan.device.records, plan.device.clusters, inst, vao, len(fb))]
        for g0, g1 in groups:
            r0, r1 = int(first[g0]), int(first[g1 - 1] + counts[g1 - 1])
            c0, c1 = int(cfirst[g0]), int(cfirst[g1 - 1] + ccount[g1 - 1])
            # the records are read in place (no bytes copy: they are most of the upload)
            recs = ctx.buffer(
                np.ascontiguousarray(plan.records[r0:r1]) if r1 > r0 else bytes(RECORD_TEXELS * 16)
            )
            hg = hdr[c0:c1].copy()
            hg[:, 1, 3] -= np.uint32(16 * r0)  # first records within the group's buffer
            clus = ctx.buffer(hg if c1 > c0 else bytes(_CLUSTER_BYTES))
            inst = ctx.buffer(fb[g0:g1].tobytes())
            vao = ctx.vertex_array(p, [(inst, "2i/i", "in_bin")])
            draws.append((recs, clus, inst, vao, g1 - g0))
        return draws

    def _level(self, s: int, plan: BinPlan, p, prepass, draws, parent, read: bool, timed: bool):
        """Shift ``s`` drawn into a new class target from the ``parent`` classes (and, for
        a textured plan, the level's centres: ``parent`` is ``(classes, centres)``): the
        prepass (from :data:`_MASK_FROM` on), then the level's pass. Returns the target
        (the next parent), the classes read back (with ``read``, else None) and, with
        ``timed``, the time the pass finished (else None)."""
        import moderngl

        parent, delta = parent
        ctx = self.ctx
        pre, pre_vao, n_bins = prepass
        hb, wb = plan.canvas.shape
        h, w = hb << s, wb << s
        final = s == plan.last
        mt = self._tex(plan.margins[s], 4, "f4")
        # at shift 1 every cell of a frontier bin is a child of a frontier cell
        masked = s >= _MASK_FROM
        target, fbo, depth = class_target(ctx, w, h, depth=masked)
        level_tex = []
        try:
            fbo.use()
            ctx.viewport = (0, 0, w, h)
            parent.use(0)
            mt.use(5)
            if delta is not None:  # a textured plan's
                level_tex = [self._tex(delta, 3, "f4")]
                level_tex[0].use(7)
                _set(p, "u_cell_delta", 7)
            elif not plan.cube and plan.grid_source is None:
                assert plan.dphi is not None and plan.dlam is not None  # a lon/lat plan's
                level_tex = [self._tex(plan.dphi[s], 1, "f4"), self._tex(plan.dlam[s], 1, "f4")]
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
                pre_vao.render(moderngl.TRIANGLES, vertices=6, instances=n_bins)
                ctx.depth_func = "<"
            else:
                ctx.disable(moderngl.DEPTH_TEST)
            _set(p, "u_block", float(1 << (plan.last - s)))
            _set(p, "u_final", final)
            _set(p, "u_rho_max", plan.rho_max[s])
            for recs, clus, _, vao, n in draws:
                recs.bind_to_storage_buffer(0)
                clus.bind_to_storage_buffer(1)
                vao.render(moderngl.TRIANGLES, vertices=6, instances=n)
            done = out = None
            if timed:
                ctx.finish()
                done = time.perf_counter()
            if read:
                data = fbo.read(viewport=(0, 0, w, h), components=1, dtype="u1")
                out = np.frombuffer(data, dtype=np.uint8).reshape(h, w)
        except BaseException:
            target.release()
            raise
        finally:
            fbo.release()
            if depth is not None:
                depth.release()
            mt.release()
            for t in level_tex:
                t.release()
        return target, out, done


def vector_passes() -> VectorPasses:
    """The process's :class:`VectorPasses` (made on first use, with the GL context)."""
    return shared(VectorPasses)
