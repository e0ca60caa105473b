"""The GPU levels of a rasterized curve's offset (paper Sec. 5.2), planner side.

The CPU (:mod:`gloffset.raster.rasterized`, float64) classifies the levels down to the
grid's bin level; below it the GL passes of :mod:`gloffset.gl.rasterized_pass` classify the
children of frontier cells, one level at a time (:func:`gpu_levels`). This module makes
each level's data and finishes each level after read-back.

Exactness. For every frontier bin and level, :func:`cell_records` lists the intersected cells
``g`` of that level within ``d_max + rho_bin`` of the bin centre ``c`` (every cell that
can change a class in the bin), as records ``(g - c, |g - c|)`` made in float64 and
rounded to float32. The shader computes the cell centre relative to ``c``
(``lib/lonlat.glsl``; on a cube ``lib/cube.glsl`` from the cell's and the bin's pixel
coordinates, which float32 holds exactly) and, per record, rigorous lower and upper bounds
on the float64 squared chord (``lib/chord.glsl``); thresholds come per row as float32
values rounded outward (:func:`thresholds`). A cell whose bounds straddle a threshold is
written as *ambiguous* (:data:`~gloffset.geometry.classes.AMBIGUOUS`); after each level
:func:`decide_ambiguous` decides those cells with the float64 reference
(:func:`gloffset.raster.rasterized.curve_levels.classify_cells`), so the result equals the CPU
reference bit for bit. Ambiguous cells are rare (a band of about 1e-5 of the threshold's
squared chord) and counted in the result's info.

Cube grids (:class:`gloffset.grids.cube.CubeCells`: the six faces stacked as one grid of
cells): every face's rows have the same thresholds (congruent faces), which the passes,
drawn face by face, share.
"""

from __future__ import annotations

from typing import cast

import numpy as np

from ...geometry.classes import AMBIGUOUS, FRONTIER
from ...gl.rasterized_pass import RECORD_ROW, CurveLevel, rasterized_passes
from ...grids.protocol import FaceCells, LonLatCells
from .curve_levels import RasterizedCurve, classify_cells, level_centers, near_pairs

__all__ = ["decide_ambiguous", "gpu_levels", "level_data", "cell_records", "thresholds"]

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


def thresholds(lv: RasterizedCurve, level: int) -> np.ndarray:
    """(rows, 1, 4) float32: lo-, lo+, hi-, hi+ per row of ``level``."""
    lo, hi = lv.t_lo[level], lv.t_hi[level]
    out = np.stack(
        [_outward(lo, False), _outward(lo, True), _outward(hi, False), _outward(hi, True)],
        axis=-1,
    )
    return out[:, None, :]


def cell_records(lv: RasterizedCurve, level: int, bins: np.ndarray):
    """Records (float32 (n, 4)) of the intersected cells of ``level`` near each frontier
    bin (flat indices of the bin level), sorted by bin; and per-bin first/count."""
    grid = lv.grid
    bl = grid.bin_level
    wb = grid.level_shape(bl)[1]
    rho_b = np.asarray(grid.rho(bl))[bins // wb]
    qs, ps = [], []
    for q, p, _ in near_pairs(grid, bl, bins, rho_b, level, lv.curve[level], lv.reach[level]):
        qs.append(q)
        ps.append(p)
    iq = np.concatenate(qs) if qs else np.zeros(0, dtype=np.int64)
    ip = np.concatenate(ps) if ps else np.zeros(0, dtype=np.int64)
    order = np.lexsort((ip, iq))
    iq, ip = iq[order], ip[order]
    c = level_centers(grid, bl, bins)
    g = level_centers(grid, level, lv.curve[level][ip])
    rel = g - c[iq]
    rec = np.empty((len(iq), 4))
    rec[:, :3] = rel
    rec[:, 3] = np.linalg.norm(rel, axis=1)
    first = np.searchsorted(iq, np.arange(len(bins)))
    count = np.bincount(iq, minlength=len(bins))
    return rec.astype(np.float32), first.astype(np.uint32), count.astype(np.uint32)


def _record_tables(lv: RasterizedCurve, level: int, bins: np.ndarray, hb: int, wb: int):
    """The record texture data (rows, RECORD_ROW, 4) and the per-bin (first, count)
    table (hb, wb, 4) of ``level``."""
    rec, first, count = cell_records(lv, level, bins)
    rows = max(1, -(-len(rec) // RECORD_ROW))
    buf = np.zeros((rows * RECORD_ROW, 4), dtype=np.float32)
    buf[: len(rec)] = rec
    info = np.zeros((hb, wb, 4), dtype=np.uint32)
    info.reshape(-1, 4)[bins, 0] = first
    info.reshape(-1, 4)[bins, 1] = count
    return buf.reshape(rows, RECORD_ROW, 4), info


def level_data(lv: RasterizedCurve, level: int, bins: np.ndarray, bin_shape) -> CurveLevel:
    """What the passes need for ``level`` below the frontier bins ``bins`` (flat indices
    of the bin level, of shape ``bin_shape``)."""
    grid = lv.grid
    bl = grid.bin_level
    h, w = grid.level_shape(level)
    buf, info = _record_tables(lv, level, bins, *bin_shape)
    thr = thresholds(lv, level)
    if not grid.lonlat:  # a cube's stacked faces: one face's rows
        pp = cast(FaceCells, grid).P[level]
        if not np.array_equal(thr, np.tile(thr[:pp], (6, 1, 1))):
            raise RuntimeError("cube faces with different row thresholds")
        return CurveLevel(level - bl, (h, w), buf, info, thr[:pp], block=float(grid.block(level)))
    # each cell's latitude and longitude minus its bin's, float64-made
    j, i = np.arange(h), np.arange(w)
    sh = level - bl
    ll = cast(LonLatCells, grid)  # lonlat declared
    dphi = ll.cell_lat(level, j) - ll.cell_lat(bl, j >> sh)
    dlam = ll.cell_lon(level, i) - ll.cell_lon(bl, i >> sh)
    return CurveLevel(
        sh, (h, w), buf, info, thr, dphi.astype(np.float32)[None], dlam.astype(np.float32)[None]
    )


def decide_ambiguous(lv: RasterizedCurve, level: int, out: np.ndarray) -> int:
    """Cells the shader wrote as ambiguous, decided in float64 (in place); their count."""
    amb = np.flatnonzero(out.ravel() == AMBIGUOUS)
    if len(amb):
        out.ravel()[amb] = classify_cells(lv, level, amb)
    return len(amb)


def _start(lv: RasterizedCurve, classes: np.ndarray, bins: np.ndarray):
    """A run of the GL passes from the bin level's ``classes`` (frontier bins ``bins``)."""
    grid = lv.grid
    bl = grid.bin_level
    hb, wb = classes.shape
    if not grid.lonlat:  # a cube's stacked faces
        faces = cast(FaceCells, grid)
        bf, bj, bi = faces.split(bl, bins)
        per_face = [np.column_stack([bi[bf == f], bj[bf == f]]) for f in range(6)]
        axes = [faces.face_axes(f) for f in range(6)]
        return rasterized_passes().cube(
            classes, per_face, axes, 2.0 / faces.size, float(faces.block(bl))
        )
    ll = cast(LonLatCells, grid)  # lonlat declared
    lam = ll.cell_lon(bl, np.arange(wb))
    phi = ll.cell_lat(bl, np.arange(hb))
    lon_cs = np.stack([np.cos(lam), np.sin(lam)], axis=-1).astype(np.float32)
    lat_cs = np.stack([np.cos(phi), np.sin(phi)], axis=-1).astype(np.float32)
    fb = np.column_stack([bins % wb, bins // wb])
    return rasterized_passes().lonlat(classes, fb, lat_cs[None], lon_cs[None])


def gpu_levels(lv: RasterizedCurve, classes: np.ndarray, *, stop_level: int, callback=None):
    """Classes of ``stop_level`` from the bin level's ``classes``, the levels below the
    bins run on the GPU; and the number of ambiguous cells decided on the CPU.
    ``callback(level, classes)`` after each level."""
    bl = lv.grid.bin_level
    bins = np.flatnonzero(classes.ravel() == FRONTIER)
    out, n_amb = classes, 0
    with _start(lv, classes, bins) as run:
        for lev in range(bl + 1, stop_level + 1):
            out = run.level(out, level_data(lv, lev, bins, classes.shape))
            n_amb += decide_ambiguous(lv, lev, out)
            if callback is not None:
                callback(lev, out)
    return out, n_amb
