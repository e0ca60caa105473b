"""The GL passes of the GPU levels of a rasterized curve's offset (paper Sec. 5.2).

Below the grid's bin level, one fragment-shader pass per level
(``shaders/raster_classify.frag``) classifies the children of frontier cells, drawing
instanced quads over the frontier bins only (``shaders/bins.vert``); the other cells take
their bin's class (``shaders/upsample.frag``). The planner
(:mod:`gloffset.raster.rasterized.curve_gpu`) makes each level's data in float64 (a
:class:`CurveLevel`: the records of the intersected cells near each bin, the per-row
thresholds rounded outward, the cells' offsets from their bins), hands it to a run of
:class:`RasterizedPasses` level by level, and decides in float64 the cells a pass wrote as
ambiguous (:data:`gloffset.geometry.classes.AMBIGUOUS`) before the next level. This module only
uploads, draws and reads back; it knows no grid or curve.

A run on a grid whose rows are parallels (:meth:`RasterizedPasses.lonlat`) draws each level
into one target. A run on a cube (:meth:`RasterizedPasses.cube`: the six faces stacked as the
rows of one grid of cells, so that the records of a bin may come from any face) draws
each level face by face (the ``GRID_CUBE`` variant of the shader, with the face's axes as
uniforms) into a face-sized target; the records are shared by the six passes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .context import get_context, shared
from .shaders import program
from .textures import class_target, pot, pot_texture
from .textures import set_uniform as _set

__all__ = ["CurveLevel", "RasterizedPasses", "rasterized_passes", "RECORD_ROW"]

RECORD_ROW = 4096  # records (one RGBA32F texel each) per texture row


@dataclass
class CurveLevel:
    """One level's data for the passes of a run of :class:`RasterizedPasses`.

    ``shift``: the level minus the bin level; ``shape`` (h, w): the level's cells (a cube:
    its six faces stacked as rows). ``records`` (rows, :data:`RECORD_ROW`, 4) float32:
    per record ``(g - c, |g - c|)``, ``g`` an intersected cell's centre and ``c`` its bin's,
    by bin; ``info`` (bin rows, bin columns, 4) uint32: per bin its first record and record
    count. ``thresholds`` (rows, 1, 4) float32: per row of the level (a cube: of one face,
    every face's are the same) the squared chords ``lo-, lo+, hi-, hi+`` around the
    contained and outside thresholds. Lon/lat grids: ``dphi`` (1, h) and ``dlam`` (1, w)
    float32, each cell row's latitude and column's longitude minus its bin's. Cube:
    ``block``, the output pixels per cell side.
    """

    shift: int
    shape: tuple
    records: np.ndarray
    info: np.ndarray
    thresholds: np.ndarray
    dphi: np.ndarray | None = None
    dlam: np.ndarray | None = None
    block: float | None = None


class RasterizedPasses:
    """The programs of the curve-offset passes, compiled once; :meth:`lonlat` and
    :meth:`cube` start a run."""

    def __init__(self):
        self.ctx = get_context()
        self.prog = program(self.ctx, "bins.vert", "raster_classify.frag")
        self._cube_prog = None
        self.upsample = program(self.ctx, "fullscreen.vert", "upsample.frag")
        self.upsample_vao = self.ctx.vertex_array(self.upsample, [])

    @property
    def cube_prog(self):
        if self._cube_prog is None:
            self._cube_prog = program(
                self.ctx, "bins.vert", "raster_classify.frag", {"GRID_CUBE": 1}
            )
        return self._cube_prog

    def _tex(self, array: np.ndarray, comps: int, dtype: str):
        return pot_texture(self.ctx, array, comps, dtype)

    def lonlat(self, classes, bins, bin_lat, bin_lon) -> LonLatRun:
        """A run on a grid whose rows are parallels, from the bin level's ``classes``:
        ``bins`` (k, 2) the column and row of each frontier bin, ``bin_lat`` and
        ``bin_lon`` (1, rows or columns, 2) float32 the cosine and sine of the bin centres'
        latitudes and longitudes."""
        return LonLatRun(self, classes, bins, bin_lat, bin_lon)

    def cube(self, classes, bins, axes, px: float, bin_block: float) -> CubeRun:
        """A run on the six faces of a cube stacked as rows, from the bin level's
        ``classes``: ``bins`` per face (k_f, 2) the column and row of its frontier bins in
        the face, ``axes`` per face its axis and the directions of s and t, ``px`` the face
        coordinate per output pixel and ``bin_block`` the output pixels per bin side."""
        return CubeRun(self, classes, bins, axes, px, bin_block)


class LonLatRun:
    """A run of :class:`RasterizedPasses` on a grid whose rows are parallels: what every level
    shares is made once; :meth:`level` draws one level. A context manager: leaving it
    releases what the run made."""

    def __init__(self, eng: RasterizedPasses, classes, bins, bin_lat, bin_lon):
        ctx = self.ctx = eng.ctx
        self.eng = eng
        self.owned = [eng._tex(bin_lat, 2, "f4"), eng._tex(bin_lon, 2, "f4")]
        coarse = eng._tex(classes, 1, "u1")
        self.owned.append(coarse)
        fb = np.ascontiguousarray(bins, dtype=np.int32)
        self.n_bins = len(fb)
        self.inst = ctx.buffer(fb.tobytes() if len(fb) else b"\0" * 8)
        self.vao = ctx.vertex_array(eng.prog, [(self.inst, "2i/i", "in_bin")])
        p = eng.prog
        p["u_parent"] = 0
        p["u_bins"] = 1
        p["u_records"] = 2
        p["u_bin_lat"] = 3
        p["u_bin_lon"] = 4
        p["u_thresholds"] = 5
        p["u_row_dphi"] = 7
        p["u_col_dlam"] = 8
        p["u_record_row"] = RECORD_ROW
        eng.upsample["u_coarse"] = 6
        self.owned[0].use(3)
        self.owned[1].use(4)
        coarse.use(6)

    def level(self, parent: np.ndarray, lev: CurveLevel) -> np.ndarray:
        """The classes (h, w) of level ``lev`` from the ``parent`` level's (without
        ambiguous cells); cells too close to a threshold are ambiguous."""
        import moderngl

        ctx, eng, p = self.ctx, self.eng, self.eng.prog
        h, w = lev.shape
        assert lev.dphi is not None and lev.dlam is not None  # a lon/lat level has them
        level_tex = [
            eng._tex(parent, 1, "u1"),
            eng._tex(lev.info, 4, "u4"),
            eng._tex(lev.records, 4, "f4"),
            eng._tex(lev.thresholds, 4, "f4"),
            eng._tex(lev.dphi, 1, "f4"),
            eng._tex(lev.dlam, 1, "f4"),
        ]
        target, fbo, _ = class_target(ctx, w, h)
        try:
            fbo.use()
            ctx.viewport = (0, 0, w, h)
            eng.upsample["u_shift"] = lev.shift
            eng.upsample_vao.render(moderngl.TRIANGLES, vertices=3)
            for unit, t in zip((0, 1, 2, 5, 7, 8), level_tex):
                t.use(unit)
            p["u_shift"] = lev.shift
            p["u_size"] = (float(w), float(h))
            if self.n_bins:
                self.vao.render(moderngl.TRIANGLES, vertices=6, instances=self.n_bins)
            full = np.frombuffer(target.read(alignment=1), dtype=np.uint8)
        finally:
            fbo.release()
            target.release()
            for t in level_tex:
                t.release()
        return full.reshape(pot(h), pot(w))[:h, :w].copy()

    def close(self) -> None:
        self.vao.release()
        self.inst.release()
        for t in self.owned:
            t.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class CubeRun:
    """A run of :class:`RasterizedPasses` on a cube's six faces stacked as rows: per face its
    instanced bins and bin-level classes, made once; :meth:`level` draws one level face
    by face. A context manager: leaving it releases what the run made."""

    def __init__(self, eng: RasterizedPasses, classes, bins, axes, px: float, bin_block: float):
        ctx = self.ctx = eng.ctx
        self.eng, self.axes = eng, axes
        pb = self.pb = classes.shape[0] // 6  # stacked rows per face at the bin level
        p = eng.cube_prog
        _set(p, "u_parent", 0)
        _set(p, "u_bins", 1)
        _set(p, "u_records", 2)
        _set(p, "u_thresholds", 5)
        _set(p, "u_record_row", RECORD_ROW)
        _set(p, "u_px", px)
        _set(p, "u_bin_block", bin_block)
        eng.upsample["u_coarse"] = 6
        self.faces = []  # per face: the instanced quads and the bin-level classes texture
        for f in range(6):
            fb = np.ascontiguousarray(bins[f], np.int32)
            inst = ctx.buffer(fb.tobytes() if len(fb) else b"\0" * 8)
            vao = ctx.vertex_array(p, [(inst, "2i/i", "in_bin")])
            coarse = eng._tex(classes[f * pb : (f + 1) * pb], 1, "u1")
            self.faces.append((len(fb), inst, vao, coarse))

    def level(self, parent: np.ndarray, lev: CurveLevel) -> np.ndarray:
        """The classes (h, w) of level ``lev`` from the ``parent`` level's (without
        ambiguous cells), face by face; cells too close to a threshold are ambiguous."""
        eng = self.eng
        h, w = lev.shape
        ph, pp = parent.shape[0] // 6, h // 6
        shared_tex = [eng._tex(lev.records, 4, "f4"), eng._tex(lev.thresholds, 4, "f4")]
        shared_tex[0].use(2)
        shared_tex[1].use(5)
        new = np.empty((h, w), dtype=np.uint8)
        try:
            for f in range(6):
                new[f * pp : (f + 1) * pp] = self._face(
                    f, parent[f * ph : (f + 1) * ph], lev, (pp, w)
                )
        finally:
            for t in shared_tex:
                t.release()
        return new

    def _face(self, f: int, parent: np.ndarray, lev: CurveLevel, shape) -> np.ndarray:
        """Face ``f`` of level ``lev`` (``shape`` its rows and columns), from its parent
        level's classes ``parent``."""
        import moderngl

        ctx, eng, p = self.ctx, self.eng, self.eng.cube_prog
        count, _, vao, coarse = self.faces[f]
        pp, w = shape
        parent_t = eng._tex(parent, 1, "u1")
        binfo = eng._tex(lev.info[f * self.pb : (f + 1) * self.pb], 4, "u4")
        target, fbo, _ = class_target(ctx, w, pp)
        try:
            fbo.use()
            ctx.viewport = (0, 0, w, pp)
            coarse.use(6)
            eng.upsample["u_shift"] = lev.shift
            eng.upsample_vao.render(moderngl.TRIANGLES, vertices=3)
            parent_t.use(0)
            binfo.use(1)
            e_, u_, v_ = self.axes[f]
            _set(p, "u_face_e", e_)
            _set(p, "u_face_u", u_)
            _set(p, "u_face_v", v_)
            _set(p, "u_block", lev.block)
            p["u_shift"] = lev.shift
            p["u_size"] = (float(w), float(pp))
            if count:
                vao.render(moderngl.TRIANGLES, vertices=6, instances=count)
            full = np.frombuffer(target.read(alignment=1), dtype=np.uint8)
        finally:
            fbo.release()
            target.release()
            parent_t.release()
            binfo.release()
        return full.reshape(pot(pp), pot(w))[:pp, :w]

    def close(self) -> None:
        for _, inst, vao, coarse in self.faces:
            vao.release()
            inst.release()
            coarse.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def rasterized_passes() -> RasterizedPasses:
    """The process's :class:`RasterizedPasses` (made on first use, with the GL context)."""
    return shared(RasterizedPasses)
