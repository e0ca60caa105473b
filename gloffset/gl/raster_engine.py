"""The GPU levels of the offset of a rasterized curve (paper Sec. 5.2).

The CPU (:mod:`gloffset.raster.rasterized`, float64) classifies the levels down to the
grid's bin level. Below it, one fragment-shader pass per level
(``shaders/raster_classify.frag``) classifies the children of frontier cells,
drawing instanced quads over the frontier bins only (``shaders/bins.vert``); the
other cells take their bin's class (``shaders/upsample.frag``).

Exactness. For every frontier bin and level, the CPU lists the intersected cells
``g`` of that level within ``d_max + rho_bin`` of the bin centre ``c`` (every cell
that can change a class in the bin), as records ``(g - c, |g - c|)`` made in
float64 and rounded to float32. The shader computes the cell centre relative to
``c`` (``lib/lonlat.glsl``; on a cube ``lib/cube.glsl`` from the cell's and the bin's
pixel coordinates, which float32 holds exactly) and, per record, rigorous lower and
upper bounds on the float64 squared chord (``lib/chord.glsl``); thresholds come per
row as float32 values rounded outward. A cell whose bounds straddle a threshold is written as
*ambiguous* (3); after each level the CPU reads the level back and decides those
cells with the float64 reference (:func:`gloffset.raster.rasterized.classify_cells`), so
the result equals the CPU reference bit for bit. Ambiguous cells are rare (a band
of about 1e-5 of the threshold's squared chord) and counted in the result's info.

Cube grids (:class:`gloffset.grids.cube.CubeCells`: the six faces stacked as one
grid of cells, so that the records of a bin may come from any face): each level is
drawn face by face (the ``GRID_CUBE`` variant of the shader, with the face's axes as
uniforms) into a face-sized target; the records are shared by the six passes.
"""

from __future__ import annotations

import numpy as np

from ..raster.rasterized import FRONTIER, Levels, classify_cells, near_pairs
from ..raster.rasterized import level_centers as _centers
from .context import get_context
from .engine import _pot, _set, class_target, pot_texture
from .shaders import program

__all__ = ["RasterLevels", "engine", "AMBIGUOUS"]

AMBIGUOUS = 3
RECORD_ROW = 4096  # records (one RGBA32F texel each) per texture row
_T_REL = 1e-6  # relative outward rounding of the float32 thresholds


def _outward(t: np.ndarray, up: bool) -> np.ndarray:
    """float32 values below (``up=False``) or above the float64 ``t``."""
    x = t * (1.0 + _T_REL) if up else t * (1.0 - _T_REL)
    x = np.where(t < 0, t, x)  # the 'never' value -1 is exact
    f = x.astype(np.float32)
    if up:
        f = np.where(f.astype(np.float64) < t, np.nextafter(f, np.float32(np.inf)), f)
    else:
        f = np.where(f.astype(np.float64) > t, np.nextafter(f, np.float32(-np.inf)), f)
    return f.astype(np.float32)


def thresholds(lv: Levels, level: int) -> np.ndarray:
    """(rows, 1, 4) float32: lo-, lo+, hi-, hi+ per row of ``level``."""
    lo, hi = lv.t_lo[level], lv.t_hi[level]
    out = np.stack(
        [_outward(lo, False), _outward(lo, True), _outward(hi, False), _outward(hi, True)],
        axis=-1,
    )
    return out[:, None, :]


def records(lv: Levels, level: int, bins: np.ndarray):
    """Records (float32 (n, 4)) of the intersected cells of ``level`` near each frontier
    bin (flat indices of the bin level), sorted by bin; and per-bin first/count."""
    grid = lv.grid
    bl = grid.bin_level
    wb = grid.level_shape(bl)[1]
    rho_b = np.asarray(grid.rho(bl))[bins // wb]
    iq, ip = [], []
    for q, p, _ in near_pairs(grid, bl, bins, rho_b, level, lv.curve[level], lv.reach[level]):
        iq.append(q)
        ip.append(p)
    iq = np.concatenate(iq) if iq else np.zeros(0, dtype=np.int64)
    ip = np.concatenate(ip) if ip else np.zeros(0, dtype=np.int64)
    order = np.lexsort((ip, iq))
    iq, ip = iq[order], ip[order]
    c = _centers(grid, bl, bins)
    g = _centers(grid, level, lv.curve[level][ip])
    rel = g - c[iq]
    rec = np.empty((len(iq), 4))
    rec[:, :3] = rel
    rec[:, 3] = np.linalg.norm(rel, axis=1)
    first = np.searchsorted(iq, np.arange(len(bins)))
    count = np.bincount(iq, minlength=len(bins))
    return rec.astype(np.float32), first.astype(np.uint32), count.astype(np.uint32)


def _level_inputs(lv: Levels, level: int, bins: np.ndarray, hb: int, wb: int):
    """The record texture data (rows, RECORD_ROW, 4) and the per-bin (first, count)
    table (hb, wb, 4) of ``level``."""
    rec, first, count = records(lv, level, bins)
    rows = max(1, -(-len(rec) // RECORD_ROW))
    buf = np.zeros((rows * RECORD_ROW, 4), dtype=np.float32)
    buf[: len(rec)] = rec
    info = np.zeros((hb, wb, 4), dtype=np.uint32)
    info.reshape(-1, 4)[bins, 0] = first
    info.reshape(-1, 4)[bins, 1] = count
    return buf.reshape(rows, RECORD_ROW, 4), info


class RasterLevels:
    """Runs the levels below the bin level on the GPU (grids whose rows are parallels,
    and cube grids face by face)."""

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

    def run(self, lv: Levels, classes: np.ndarray, *, stop_level: int, callback=None):
        """Classes of ``stop_level`` from the bin level's ``classes``; and the number of
        ambiguous cells decided on the CPU."""
        if not lv.grid.lonlat:  # the cube faces as one cell set
            return self._run_cube(lv, classes, stop_level=stop_level, callback=callback)
        import moderngl

        ctx = self.ctx
        grid = lv.grid
        bl = grid.bin_level
        hb, wb = classes.shape
        bins = np.flatnonzero(classes.ravel() == FRONTIER)
        lam = grid.cell_lon(bl, np.arange(wb))
        phi = grid.cell_lat(bl, np.arange(hb))
        lon_cs = np.stack([np.cos(lam), np.sin(lam)], axis=-1).astype(np.float32)
        lat_cs = np.stack([np.cos(phi), np.sin(phi)], axis=-1).astype(np.float32)
        owned = [self._tex(lat_cs[None], 2, "f4"), self._tex(lon_cs[None], 2, "f4")]
        coarse = self._tex(classes, 1, "u1")
        owned.append(coarse)
        fb = np.ascontiguousarray(np.column_stack([bins % wb, bins // wb]), dtype=np.int32)
        inst = ctx.buffer(fb.tobytes() if len(fb) else b"\0" * 8)
        vao = ctx.vertex_array(self.prog, [(inst, "2i/i", "in_bin")])
        p = self.prog
        p["u_parent"] = 0
        p["u_bins"] = 1
        p["u_records"] = 2
        p["u_bin_lat"] = 3
        p["u_bin_lon"] = 4
        p["u_thresholds"] = 5
        p["u_row_dphi"] = 7
        p["u_col_dlam"] = 8
        p["u_record_row"] = RECORD_ROW
        self.upsample["u_coarse"] = 6
        owned[0].use(3)
        owned[1].use(4)
        coarse.use(6)
        out, n_amb = classes, 0
        try:
            for lev in range(bl + 1, stop_level + 1):
                h, w = grid.level_shape(lev)
                buf, info = _level_inputs(lv, lev, bins, hb, wb)
                # each cell's latitude and longitude minus its bin's, float64-made
                j, i = np.arange(h), np.arange(w)
                sh = lev - bl
                dphi = grid.cell_lat(lev, j) - grid.cell_lat(bl, j >> sh)
                dlam = grid.cell_lon(lev, i) - grid.cell_lon(bl, i >> sh)
                level_tex = [
                    self._tex(out, 1, "u1"),
                    self._tex(info, 4, "u4"),
                    self._tex(buf, 4, "f4"),
                    self._tex(thresholds(lv, lev), 4, "f4"),
                    self._tex(dphi.astype(np.float32)[None], 1, "f4"),
                    self._tex(dlam.astype(np.float32)[None], 1, "f4"),
                ]
                target, fbo, _ = class_target(ctx, w, h)
                try:
                    fbo.use()
                    ctx.viewport = (0, 0, w, h)
                    self.upsample["u_shift"] = lev - bl
                    self.upsample_vao.render(moderngl.TRIANGLES, vertices=3)
                    for unit, t in zip((0, 1, 2, 5, 7, 8), level_tex):
                        t.use(unit)
                    p["u_shift"] = lev - bl
                    p["u_size"] = (float(w), float(h))
                    if len(fb):
                        vao.render(moderngl.TRIANGLES, vertices=6, instances=len(fb))
                    full = np.frombuffer(target.read(alignment=1), dtype=np.uint8)
                finally:
                    fbo.release()
                    target.release()
                    for t in level_tex:
                        t.release()
                out = full.reshape(_pot(h), _pot(w))[:h, :w].copy()
                n_amb += _decide_ambiguous(lv, lev, out)
                if callback is not None:
                    callback(lev, out)
        finally:
            vao.release()
            inst.release()
            for t in owned:
                t.release()
        return out, n_amb

    def _run_cube(self, lv: Levels, classes: np.ndarray, *, stop_level: int, callback=None):
        """:meth:`run` on a :class:`~gloffset.grids.cube.CubeCells` grid: per level, the
        records of every frontier bin once, then one pass per face into a face target."""
        import moderngl

        ctx = self.ctx
        grid = lv.grid
        bl = grid.bin_level
        hb, wb = classes.shape
        pb = grid.P[bl]  # stacked rows per face at the bin level
        bins = np.flatnonzero(classes.ravel() == FRONTIER)
        bf, bj, bi = grid.split(bl, bins)
        p = self.cube_prog
        _set(p, "u_parent", 0)
        _set(p, "u_bins", 1)
        _set(p, "u_records", 2)
        _set(p, "u_thresholds", 5)
        _set(p, "u_record_row", RECORD_ROW)
        _set(p, "u_px", 2.0 / grid.size)
        _set(p, "u_bin_block", float(grid.block(bl)))
        self.upsample["u_coarse"] = 6
        faces = []  # per face: the bin-level classes texture and the instanced quads
        for f in range(6):
            fb = np.ascontiguousarray(np.column_stack([bi[bf == f], bj[bf == f]]), np.int32)
            inst = ctx.buffer(fb.tobytes() if len(fb) else b"\0" * 8)
            vao = ctx.vertex_array(p, [(inst, "2i/i", "in_bin")])
            coarse = self._tex(classes[f * pb : (f + 1) * pb], 1, "u1")
            faces.append((len(fb), inst, vao, coarse))
        out, n_amb = classes, 0
        try:
            for lev in range(bl + 1, stop_level + 1):
                h, w = grid.level_shape(lev)
                ph, pp = grid.P[lev - 1], grid.P[lev]
                buf, info = _level_inputs(lv, lev, bins, hb, wb)
                # every face's rows have the same thresholds (congruent faces)
                thr = thresholds(lv, lev)
                if not np.array_equal(thr, np.tile(thr[:pp], (6, 1, 1))):
                    raise RuntimeError("cube faces with different row thresholds")
                shared = [
                    self._tex(buf, 4, "f4"),
                    self._tex(thr[:pp], 4, "f4"),
                ]
                shared[0].use(2)
                shared[1].use(5)
                new = np.empty((h, w), dtype=np.uint8)
                try:
                    for f, (count, _, vao, coarse) in enumerate(faces):
                        parent = self._tex(out[f * ph : (f + 1) * ph], 1, "u1")
                        binfo = self._tex(info[f * pb : (f + 1) * pb], 4, "u4")
                        target, fbo, _ = class_target(ctx, w, pp)
                        try:
                            fbo.use()
                            ctx.viewport = (0, 0, w, pp)
                            coarse.use(6)
                            self.upsample["u_shift"] = lev - bl
                            self.upsample_vao.render(moderngl.TRIANGLES, vertices=3)
                            parent.use(0)
                            binfo.use(1)
                            e_, u_, v_ = grid.face_axes(f)
                            _set(p, "u_face_e", e_)
                            _set(p, "u_face_u", u_)
                            _set(p, "u_face_v", v_)
                            _set(p, "u_block", float(grid.block(lev)))
                            p["u_shift"] = lev - bl
                            p["u_size"] = (float(w), float(pp))
                            if count:
                                vao.render(moderngl.TRIANGLES, vertices=6, instances=count)
                            full = np.frombuffer(target.read(alignment=1), dtype=np.uint8)
                        finally:
                            fbo.release()
                            target.release()
                            parent.release()
                            binfo.release()
                        new[f * pp : (f + 1) * pp] = full.reshape(_pot(pp), _pot(w))[:pp, :w]
                finally:
                    for t in shared:
                        t.release()
                out = new
                n_amb += _decide_ambiguous(lv, lev, out)
                if callback is not None:
                    callback(lev, out)
        finally:
            for _, inst, vao, coarse in faces:
                vao.release()
                inst.release()
                coarse.release()
        return out, n_amb


def _decide_ambiguous(lv: Levels, level: int, out: np.ndarray) -> int:
    """Cells the shader wrote as ambiguous, decided in float64 (in place); their count."""
    amb = np.flatnonzero(out.ravel() == AMBIGUOUS)
    if len(amb):
        out.ravel()[amb] = classify_cells(lv, level, amb)
    return len(amb)


_ENGINE: RasterLevels | None = None


def engine() -> RasterLevels:
    global _ENGINE
    if _ENGINE is None:
        _ENGINE = RasterLevels()
    return _ENGINE
