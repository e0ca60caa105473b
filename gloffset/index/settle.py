"""The settling of an index build's (cell, arc) pairs (Sec. 4.3), in cache-sized chunks.

:class:`Settle` takes the candidate arcs of one level's cells
(:class:`gloffset.index.cells.Cells`) and replaces arcs by their two halves until every
pair is settled: what :class:`gloffset.index.tree.Index`'s build keeps for a cell, and,
below a parent, the parity of the crossings of each cell's short arc to its parent's
anchor. Pairs go through in chunks of :data:`CHUNK`, each pass of the arcs in the order
the whole pass would have them: the temporaries of a chunk stay in the cache, and the
allocator hands back the same memory instead of fresh pages for each numpy temporary.
"""

from __future__ import annotations

import numpy as np

from ..geometry.caps import cos_sum_lower
from ..geometry.sphere import angle, cross, dot
from .arcs import BOUNDARY, INTERNAL, MARGIN, RING, crosses, pair_distance

__all__ = ["CHUNK", "Settle"]

#: (cell, arc) pairs per chunk: their temporaries (a few hundred bytes a pair) fit the cache.
CHUNK = 1 << 14


class Settle:
    """The settling of (cell, arc) pairs of ``cells`` at the distance ``absd`` (rad).

    With ``parent`` (each cell's parent anchor), :attr:`parity` counts, per cell, the
    crossings of its short arc anchor -> parent anchor with the ring arcs it inherited
    (those dropped as far, and those kept as settled).
    """

    def __init__(self, arcs, cells, absd: float, *, parent=None):
        self.arcs, self.cells, self.absd = arcs, cells, absd
        # per cell: rho, how far an arc may matter, and that reach's cos and sin
        reach = np.minimum(cells.rho + MARGIN + np.where(cells.dst, absd, 0.0), np.pi)
        self.reach = np.column_stack([cells.rho, reach, np.cos(reach), np.sin(reach)])
        self.parent = parent
        self.px = None if parent is None else cross(cells.x, parent)
        self.parity = np.zeros(len(cells.x), dtype=np.int64)
        # an arc farther from a cell's anchor than its short arc to the parent's anchor
        # (plus the margin) cannot cross that short arc (the rule by which a parent's list
        # dropped far arcs too): its crossing test is skipped. ``short``: cells whose
        # short arc lies within their reach, where every arc beyond it is that far
        self.span = np.zeros(len(cells.x))
        if parent is not None:
            self.span = angle(cells.x, parent) + MARGIN
        self.short = self.span <= reach

    def run(self, pc, pn, *, near: bool = False, floor=None):
        """Return the pairs that matter for the cells, ``(pc, pn, dist, par, dst)``.

        An arc is reconstructed when the cell's anchor lies in its error region (the
        parity rule needs the anchor outside), or when it is simplified and larger than
        the cell (with ``floor``, at a leaf: when its level is above ``floor``).
        ``near``: the pairs passed the cap test of these cells already (not repeated).
        """
        out = [(pc[:0], pn[:0], np.zeros(0), np.zeros(0, bool), np.zeros(0, bool))]
        while len(pc):
            more = [
                self._chunk(pc[s : s + CHUNK], pn[s : s + CHUNK], near, floor)
                for s in range(0, len(pc), CHUNK)
            ]
            out += [m[0] for m in more]
            pc = np.concatenate([m[1] for m in more])
            pn = np.concatenate([m[2] for m in more])
            near = False  # the halves of arcs are tested
        return tuple(np.concatenate([o[k] for o in out]) for k in range(5))

    def inherit(self, pos, pn):
        """Return the pairs ``(cell, arc)`` of the four children of each parent pair.

        ``pos``: the parent of each pair, as a position among the parents (whose
        children are cells ``4 pos .. 4 pos + 3``); ``pn``: its arc. A cheap cap test
        for the four children at once drops the arcs that cannot matter to a child;
        far ring arcs may still cross the short arcs child anchor -> parent anchor.
        """
        arcs, cells = self.arcs, self.cells
        reach4, x4, par4 = self.reach.reshape(-1, 4, 4), cells.x.reshape(-1, 4, 3), cells.par[::4]
        short4 = self.short.reshape(-1, 4)
        out_c, out_n = [pos[:0]], [pn[:0]]
        for s in range(0, len(pos), CHUNK // 4):
            p, a = pos[s : s + CHUNK // 4], pn[s : s + CHUNK // 4]
            f, c, xc = arcs.cap[a], reach4[p], x4[p]
            far = dot(xc, f[:, None, 0:3]) < cos_sum_lower(
                c[:, :, 1] + f[:, 5:6], c[:, :, 2], c[:, :, 3], f[:, 3:4], f[:, 4:5]
            )
            child = 4 * p[:, None] + np.arange(4)
            ring = ((arcs.kind[a] & RING) != 0) & par4[p]
            cp, cc = np.nonzero(far & ring[:, None] & ~short4[p])
            self._cross(child[cp, cc], a[cp], dot(xc[cp, cc], arcs.n[a[cp]]))
            near = ~far
            out_c.append(child[near])
            out_n.append(np.broadcast_to(a[:, None], near.shape)[near])
        return np.concatenate(out_c), np.concatenate(out_n)

    def _chunk(self, pc, pn, near, floor):
        """One pass over a chunk of pairs: what it keeps, and the pairs of the halves."""
        arcs, cells = self.arcs, self.cells
        x = cells.x[pc]
        kind = arcs.kind[pn]
        ring = ((kind & RING) != 0) & cells.par[pc]
        if not near:  # a cheap cap test first: arcs whose cap is beyond reach do not matter
            f, c = arcs.cap[pn], self.reach[pc]
            far = dot(x, f[:, 0:3]) < cos_sum_lower(
                c[:, 1] + f[:, 5], c[:, 2], c[:, 3], f[:, 3], f[:, 4]
            )
            if self.parent is not None:  # still crossed: their error region holds no anchor
                cnt = np.flatnonzero(far & ring & ~self.short[pc])
                self._cross(pc[cnt], pn[cnt], dot(x[cnt], arcs.n[pn[cnt]]))
            keep = np.flatnonzero(~far)
            pc, pn, x, kind, ring = pc[keep], pn[keep], x[keep], kind[keep], ring[keep]
        g = arcs.g[pn]
        dist, xn = pair_distance(x, g, arcs.solid[pn])
        e, r = arcs.e[pn], cells.rho[pc]
        par = ring & (dist <= r + e + MARGIN)
        dst = ((kind & BOUNDARY) != 0) & cells.dst[pc]
        dst &= dist <= self.absd + r + e + MARGIN
        internal = (kind & INTERNAL) != 0
        expand = internal & ring & (dist <= e + MARGIN)
        coarse = internal & (par | dst)
        if floor is None:
            coarse &= arcs.rad[pn] > r
        else:  # at the leaves: down to the level floor
            coarse &= arcs.level[pn] > floor
        expand |= coarse
        settled = ~expand
        if self.parent is not None:
            cnt = np.flatnonzero(settled & ring & (dist <= self.span[pc]))
            self._cross(pc[cnt], pn[cnt], xn[cnt], g[cnt, 0:9])
        keep = settled & (par | dst)
        ex = np.flatnonzero(expand)
        kept = (pc[keep], pn[keep], dist[keep], par[keep], dst[keep])
        return kept, np.repeat(pc[ex], 2), arcs.child[pn[ex]].ravel()

    def _cross(self, pc, pn, xn, g=None):
        """Add to :attr:`parity` the crossings of the short arcs anchor -> parent anchor of
        cells ``pc`` with arcs ``pn`` (``xn``: the anchors dotted with the arcs' normals;
        ``g``: the arcs' rows a, b, n, if gathered)."""
        if len(pc) == 0 or self.parent is None or self.px is None:
            return
        g = self.arcs.g[pn, 0:9] if g is None else g
        xp = self.parent[pc]
        cr = crosses(None, xp, self.px[pc], g[:, 0:3], g[:, 3:6], g[:, 6:9], xn)
        self.parity += np.bincount(pc[cr], minlength=len(self.parity))
