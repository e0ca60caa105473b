"""The cells of an index's build: the frontier of a level, and the lookup tables.

:class:`Cells` carries a level's cells through :class:`gloffset.index.tree.Index`'s build;
:func:`paint_table` writes decided cells into the row-major lookup tables the query reads.
"""

from __future__ import annotations

import numpy as np

from ..geometry.sphere import lonlat_to_xyz


class Cells:
    """Cells of one level with what the build carries for them.

    Anchors, radii, the anchors' inside status, and whether parity (``par``) and distance
    (``dst``) tests are still needed below them.
    """

    def __init__(self, level, j, i, x, rho, status):
        self.level, self.j, self.i, self.x, self.rho = level, j, i, x, rho
        self.status = np.asarray(status, dtype=bool)
        self.par = np.zeros(len(x), dtype=bool)
        self.dst = np.zeros(len(x), dtype=bool)

    def subset(self, sel):
        out = Cells(
            self.level, self.j[sel], self.i[sel], self.x[sel], self.rho[sel], self.status[sel]
        )
        out.par, out.dst = self.par[sel], self.dst[sel]
        return out


def subset_pairs(kept, sel):
    """Return the pairs of cells ``sel`` (sorted), with cells renumbered to positions in ``sel``."""
    pc = kept[0]
    pos = np.searchsorted(sel, pc)
    ok = (pos < len(sel)) & (sel[np.minimum(pos, len(sel) - 1)] == pc)
    return (pos[ok],) + tuple(k[ok] for k in kept[1:])


def paint_table(tiles, level: int, parents, step: int) -> np.ndarray:
    """Return a row-major lookup table of cells of ``level`` from tiles ``(lev, j, i, code)``.

    Without ``parents``: the whole sphere (``2^level x 2^(level+1)``). With them (sorted
    row-major keys of cells ``step`` levels up): one ``2^step x 2^step`` block per
    parent. The tiles must cover every entry exactly once.
    """
    if parents is None:
        table = np.full(2 << (2 * level), -(2**31), dtype=np.int32)
    else:
        table = np.full(len(parents) << (2 * step), -(2**31), dtype=np.int32)
    filled = 0
    for lev, j, i, code in tiles:
        if len(j) == 0:
            continue
        side = 1 << (level - lev)
        d = np.arange(side)
        rows = (np.asarray(j)[:, None, None] * side + d[None, :, None]).astype(np.int64)
        cols = (np.asarray(i)[:, None, None] * side + d[None, None, :]).astype(np.int64)
        if parents is None:
            idx = (rows << (level + 1)) + cols
        else:
            up = ((rows >> step) << (level - step + 1)) + (cols >> step)
            block = np.searchsorted(parents, up)
            mask = (1 << step) - 1
            idx = (block << (2 * step)) | ((rows & mask) << step) | (cols & mask)
        table[idx] = np.broadcast_to(np.asarray(code, dtype=np.int32)[:, None, None], idx.shape)
        filled += idx.size
    if filled != table.size or (table == -(2**31)).any():
        raise RuntimeError("internal error: bins do not tile the sphere")  # pragma: no cover
    return table


def sample_points(leaves, n_max: int):
    """Return a seeded random point in each of (at most ``n_max``) frontier leaves: (p, leaf)."""
    rng = np.random.default_rng(0)
    leaf = np.arange(len(leaves.x))
    if len(leaf) > n_max:
        leaf = np.sort(rng.choice(leaf, n_max, replace=False))
    h = 180.0 / (1 << leaves.level)
    lon = -180.0 + (leaves.i[leaf] + rng.uniform(0, 1, len(leaf))) * h
    lat = 90.0 - (leaves.j[leaf] + rng.uniform(0, 1, len(leaf))) * h
    return lonlat_to_xyz(lon, lat), leaf
