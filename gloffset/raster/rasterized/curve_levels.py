"""The cells of a rasterized curve, level by level, and the distances between cells
(paper Sec. 5): what the classification of a raster offset works on, on the CPU
(:mod:`gloffset.raster.rasterized`) and for the GPU levels
(:mod:`gloffset.raster.rasterized.curve_gpu`).

:class:`RasterizedCurve` holds the curve's intersected cells on every level (a cell is
intersected when a descendant is) with the per-row thresholds of each level (see
:mod:`gloffset.raster.rasterized` for the bounds); :func:`near_pairs` finds the pairs of
cells within a reach with buckets of a coarser level; :func:`classify_cells` classifies
cells against every intersected cell within reach. Every cell centre comes from one
table per level (:func:`level_centers`), so a cell has the same float64 centre in every
code path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ...geometry.caps import cap_within, chord2, pad
from ...geometry.classes import CONTAINED, FRONTIER, OUTSIDE
from ...geometry.sphere import chord2_between
from ...grids.protocol import CellSet

__all__ = [
    "RasterizedCurve",
    "level_centers",
    "neighbours",
    "near_pairs",
    "classify_cells",
]

_PAIRS = 1 << 22  # cell pairs per chunk
_REACH_SLACK = 1e-9  # rad added to every search radius (so no float64 rounding hides a cell)


# ---------------------------------------------------------------------------- grid tables
@lru_cache(maxsize=64)
def _tables(grid, level: int):
    """(cos lat, sin lat) per row and (cos lon, sin lon) per column of ``level``.

    Every centre this module uses is ``(cphi cl, cphi sl, sphi)`` from these tables,
    so the same cell has the same float64 centre in every code path.
    """
    h, w = grid.level_shape(level)
    lam = grid.cell_lon(level, np.arange(w))
    phi = grid.cell_lat(level, np.arange(h))
    return np.cos(phi), np.sin(phi), np.cos(lam), np.sin(lam)


def level_centers(grid, level: int, flat: np.ndarray) -> np.ndarray:
    """Unit vectors (n, 3) of the cells ``flat`` (row * width + column) of ``level``.

    Grids whose rows are parallels use per-level tables (:func:`_tables`); other
    grids (the stacked cube faces, :class:`~gloffset.grids.cube.CubeCells`) their own
    ``centers``.
    """
    w = grid.level_shape(level)[1]
    j, i = np.divmod(np.asarray(flat, dtype=np.int64), w)
    if not grid.lonlat:
        return grid.centers(level, j, i)
    cp, sp, cl, sl = _tables(grid, level)
    return np.stack([cp[j] * cl[i], cp[j] * sl[i], sp[j]], axis=-1)


def neighbours(grid, level: int, flat: np.ndarray) -> np.ndarray:
    """The cells (flattened, unique) that touch the cells ``flat`` of ``level``: the
    8-neighbours, across the antimeridian on global grids and across face edges on
    :class:`~gloffset.grids.cube.CubeCells` (:meth:`CellSet.neighbours
    <gloffset.grids.protocol.CellSet.neighbours>`)."""
    return grid.neighbours(level, flat)


# ---------------------------------------------------------------------------- ordering
def _dfs_order(grid, level: int, mask: np.ndarray) -> list[np.ndarray]:
    """Intersected cells of ``level`` ordered by a depth-first walk of each 8-connected
    component (row-major start cells), one array of flat indices per component."""
    h, w = mask.shape
    flat = np.flatnonzero(mask.ravel())
    member = mask.ravel().copy()
    seen = np.zeros(h * w, dtype=bool)
    table = dict(zip(flat.tolist(), grid.neighbour_table(level, flat).tolist()))

    def around(c):
        return [q for q in table[c] if q >= 0]

    comps = []
    for start in flat.tolist():
        if seen[start]:
            continue
        seen[start] = True
        stack, comp = [start], []
        while stack:
            c = stack.pop()
            comp.append(c)
            for q in around(c):
                if member[q] and not seen[q]:
                    seen[q] = True
                    stack.append(q)
        comps.append(np.array(comp, dtype=np.int64))
    return comps


def _coarsen_order(grid, level: int, parts: list[np.ndarray]) -> list[np.ndarray]:
    """Output-level curve order mapped to the ancestors at ``level`` (first visits only)."""
    last = grid.n_levels - 1
    sh = last - level
    w_out = grid.width
    w = grid.level_shape(level)[1]
    seen: set = set()
    out = []
    for c in parts:
        j, i = np.divmod(c, w_out)
        a = (j >> sh) * w + (i >> sh)
        a = a[np.concatenate([[True], a[1:] != a[:-1]])]
        _, first = np.unique(a, return_index=True)
        keep = np.zeros(len(a), dtype=bool)
        keep[first] = True
        keep &= np.array([x not in seen for x in a.tolist()], dtype=bool)
        seen.update(a[keep].tolist())
        if keep.any():
            out.append(a[keep])
    return out


def _runs(grid, level: int, parts: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The sequence g_0..g_k and where a run of 8-adjacent cells starts."""
    if not parts:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool)
    seq = np.concatenate(parts)
    start = np.ones(len(seq), dtype=bool)
    start[1:] = ~grid.adjacent(level, seq[:-1], seq[1:])
    bounds = np.cumsum([len(p) for p in parts])[:-1]
    start[bounds] = True
    return seq, start


# ---------------------------------------------------------------------------- the problem
@dataclass
class RasterizedCurve:
    """A curve mask with what every level's classification needs (all float64): the
    levels of a rasterized curve (not to be confused with a grid's levels).

    ``masks[l]``: intersected cells of level ``l``; ``curve[l]``: their flat indices;
    ``s``: the output-cell area bound; ``R[l]``; ``t_lo[l]``, ``t_hi[l]``: per-row
    squared-chord thresholds (contained when ``chord^2 < t_lo``, outside when
    ``chord^2 >= t_hi``); ``reach[l]``: an angle beyond which no intersected cell
    matters for level ``l``.
    """

    grid: CellSet
    d: float
    masks: list
    curve: list
    s: float
    R: list
    t_lo: list
    t_hi: list
    reach: list
    parts: list | None = None

    @classmethod
    def build(cls, mask: np.ndarray, d: float, grid, parts=None) -> RasterizedCurve:
        last = grid.n_levels - 1
        masks: list = [None] * (last + 1)  # every level's set below
        masks[last] = mask
        for lev in range(last - 1, -1, -1):
            h, w = grid.level_shape(lev)
            m = masks[lev + 1]
            pad = np.zeros((2 * h, 2 * w), dtype=bool)
            pad[: m.shape[0], : m.shape[1]] = m
            masks[lev] = pad.reshape(h, 2, w, 2).any(axis=(1, 3))
        curve = [np.flatnonzero(m.ravel()) for m in masks]
        s = float(grid.area_rho_cells(last, curve[last]).max())
        R, t_lo, t_hi, reach = [], [], [], []
        for lev in range(last + 1):
            w = grid.level_shape(lev)[1]
            rho = np.asarray(grid.rho(lev), dtype=np.float64)
            r_l = 0.0 if lev == last else float(grid.rho_cells(lev, curve[lev]).max())
            rq = rho if lev < last else np.zeros_like(rho)
            lo = d - s - rq - r_l
            hi = d + 2.0 * s + rq + r_l
            R.append(r_l)
            lo2 = np.where(lo > 0.0, chord2(np.maximum(lo, 0.0)), -1.0)
            hi2 = np.where(hi < math.pi, chord2(hi), 5.0)
            ok = grid.row_valid(lev)  # padding rows hold no cell: always outside
            lo2, hi2 = np.where(ok, lo2, -1.0), np.where(ok, hi2, -1.0)
            t_lo.append(lo2)
            t_hi.append(hi2)
            reach.append(float(min(hi.max(), math.pi)) + _REACH_SLACK)
        return cls(grid, d, masks, curve, s, R, t_lo, t_hi, reach, parts)

    def sequence(self, level: int) -> tuple[np.ndarray, np.ndarray]:
        """The ordered intersected cells of ``level`` and run starts."""
        if self.parts is not None:
            parts = _coarsen_order(self.grid, level, self.parts)
            # cells of the mask that the given order misses are appended by walking
            got = np.zeros(self.masks[level].size, dtype=bool)
            for p in parts:
                got[p] = True
            rest = self.masks[level].ravel() & ~got
            if rest.any():
                parts = parts + _dfs_order(self.grid, level, rest.reshape(self.masks[level].shape))
        else:
            parts = _dfs_order(self.grid, level, self.masks[level])
        return _runs(self.grid, level, parts)

    def classes_of(self, level: int, flat: np.ndarray, best: np.ndarray) -> np.ndarray:
        """Classes of cells ``flat`` of ``level`` whose smallest squared chord is ``best``."""
        row = np.asarray(flat) // self.grid.level_shape(level)[1]
        out = np.full(len(flat), FRONTIER, dtype=np.uint8)
        out[best < self.t_lo[level][row]] = CONTAINED
        out[best >= self.t_hi[level][row]] = OUTSIDE
        return out


# ---------------------------------------------------------------------------- near pairs
def near_pairs(
    grid, level_q: int, q: np.ndarray, extra_q, level_p: int, p: np.ndarray, reach: float
):
    """Pairs ``(iq, ip)`` (indices into ``q`` and ``p``) whose centres are within
    ``reach + extra_q[iq]`` of each other: a superset, found with buckets of a
    coarser level (children's centres lie within ``rho`` of the bucket centre).

    Yields chunks ``(iq, ip, c2)`` with the squared chord of each pair.
    """
    q = np.asarray(q, dtype=np.int64)
    p = np.asarray(p, dtype=np.int64)
    extra_q = np.broadcast_to(np.asarray(extra_q, dtype=np.float64), q.shape)
    if len(q) == 0 or len(p) == 0:
        return
    m = _bucket_level(grid, level_q, q, level_p, p, reach)

    def buckets(level, cells):
        w = grid.level_shape(level)[1]
        sh = level - m
        j, i = np.divmod(cells, w)
        key = (j >> sh) * grid.level_shape(m)[1] + (i >> sh)
        order = np.argsort(key, kind="stable")
        ukey, start, count = np.unique(key[order], return_index=True, return_counts=True)
        return order, ukey, start, count

    qo, qk, qs, qc = buckets(level_q, q)
    po, pk, ps, pc = buckets(level_p, p)
    wm = grid.level_shape(m)[1]
    rho_m = np.asarray(grid.rho(m))
    cq = level_centers(grid, m, qk)
    cp = level_centers(grid, m, pk)
    eq = np.maximum.reduceat(extra_q[qo], qs) + rho_m[qk // wm]
    ep = rho_m[pk // wm]
    cq_all = level_centers(grid, level_q, q)
    cp_all = level_centers(grid, level_p, p)
    step = max(1, _PAIRS // max(len(pk), 1))
    for s0 in range(0, len(qk), step):
        sl = slice(s0, s0 + step)
        bq, bp = np.nonzero(
            cap_within(cq[sl] @ cp.T, reach + eq[sl, None] + ep[None, :] + _REACH_SLACK)
        )
        bq += s0
        cnt = qc[bq] * pc[bp]
        # cartesian products of the bucket pairs, in chunks of about _PAIRS pairs
        cum = np.cumsum(cnt)
        lo = 0
        while lo < len(bq):
            hi = int(np.searchsorted(cum, (cum[lo - 1] if lo else 0) + _PAIRS, side="right"))
            hi = max(hi, lo + 1)
            b_q, b_p, c = bq[lo:hi], bp[lo:hi], cnt[lo:hi]
            tot = int(c.sum())
            k = np.arange(tot) - np.repeat(np.cumsum(c) - c, c)
            npc = np.repeat(pc[b_p], c)
            iq = qo[np.repeat(qs[b_q], c) + k // npc]
            ip = po[np.repeat(ps[b_p], c) + k % npc]
            c2 = chord2_between(cq_all[iq], cp_all[ip])
            keep = c2 <= pad(chord2(reach + extra_q[iq] + _REACH_SLACK), abs_=0.0)
            yield iq[keep], ip[keep], c2[keep]
            lo = hi


def _bucket_level(grid, level_q, q, level_p, p, reach) -> int:
    """The bucket level with the least estimated work: bucket pairs tested plus cell
    pairs expanded (buckets of side ~rho near a disc of radius reach)."""
    best, m_best = math.inf, 0
    for m in range(min(level_q, level_p) + 1):
        wm = grid.level_shape(m)[1]
        nb = []
        for lev, cells in ((level_q, q), (level_p, p)):
            sh = lev - m
            j, i = np.divmod(cells, grid.level_shape(lev)[1])
            nb.append(len(np.unique((j >> sh) * wm + (i >> sh))))
        r = max(float(np.max(grid.rho(m))), 1e-12)
        near = min(float(nb[1]), min((reach + 2.0 * r) / r, 1e6) ** 2)
        cost = nb[0] * nb[1] + len(q) * len(p) / nb[1] * near
        if cost < best:
            best, m_best = cost, m
    return m_best


def classify_cells(lv: RasterizedCurve, level: int, flat: np.ndarray) -> np.ndarray:
    """Direct classification of cells ``flat`` of ``level`` against every intersected
    cell within reach (the fallback, and the hierarchical levels)."""
    flat = np.asarray(flat, dtype=np.int64)
    best = np.full(len(flat), np.inf)
    for iq, _, c2 in near_pairs(lv.grid, level, flat, 0.0, level, lv.curve[level], lv.reach[level]):
        np.minimum.at(best, iq, c2)
    return lv.classes_of(level, flat, best)
