"""The inside test's index: lon/lat bins refined where the answer varies (Sec. 4.3, Eq. 9).

:class:`Index` is built once per shape and distance and answers many points; its
accuracy contract is that of :func:`gloffset.index.contains.contains_on_sphere`, which
keeps one on each shape. The derivation: ``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidLevelError, OptionError
from ..geometry.crossings import inside as _inside_reference
from ..geometry.sphere import arc_distance, cross, lonlat_to_xyz, xyz_to_lonlat
from ..shape import Shape, read
from ..units import EARTH_RADIUS, check_lonlat, offset_angle
from . import bins
from .arcs import MARGIN, arc_tree, crosses, dots, end_distance, radius_terms, within
from .cells import Cells, paint_table, sample_points, subset_pairs
from .settle import CHUNK as PAIR_CHUNK
from .settle import Settle

__all__ = ["Index"]

#: Level of the first lookup table (cells of 0.7 deg).
ROOT_LEVEL = 8
#: Levels between lookup tables: a frontier cell of one table gets a block of
#: ``4^TABLE_STEP`` entries in the next.
TABLE_STEP = 5
#: Depth of the bins of an :class:`Index` (cells of 0.022 deg, 2.4 km, at level 13).
DEFAULT_DEPTH = 13
#: Deepest allowed level.
MAX_DEPTH = bins.MAX_LEVEL
#: Refinement stops before the frontier would hold more cells than this.
MAX_CELLS = 1 << 21
#: With the default depth, refinement stops before the frontier would hold more cells
#: than this (a long boundary: the build costs about its frontier cells).
BUILD_CELLS = 1 << 16
#: The leaves' arcs are expanded toward original edges, a decomposition level at a time,
#: while they stay within this many candidate pairs per cell (see :attr:`Index.floor`).
LEAF_PAIRS = 8
#: The automatic level is chosen among 0 .. this, on this many sample points.
AUTO_MAX_LEVEL = 5
AUTO_SAMPLE = 1024
#: With fewer frontier cells than this the level is 0 (not worth choosing).
AUTO_MIN_LEAVES = 256
#: Cost of one pass over a batch of frontier points, in tested (point, arc) pairs
#: (numpy call overheads; measured: about 40 calls of ~1.2 us against ~170 ns a pair).
PASS_COST = 256
#: Points per chunk in a query (bounded memory, cache-sized temporaries).
CHUNK = 1 << 16
#: Indexes kept on a shape (by distance and level).
CACHE_SIZE = 4
_OUT, _IN = 0, 1
_PAR, _DST = 1, 2  # candidate flags: counts for parity, for the distance test


# ---------------------------------------------------------------------- the index
class Index:
    """A shape prepared for fast offset-membership queries at one distance.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    distance : float
        Offset distance in the units of ``radius`` (0: the polygons themselves;
        ``> 0``: grown; ``< 0``: shrunk).
    radius : float
        Sphere radius (default :data:`gloffset.EARTH_RADIUS`, metres).
    level : int, optional
        Decomposition level ``K`` of the candidate arcs of frontier cells (Sec. 4.3):
        a frontier point starts from simplified arcs of level ``K`` and reconstructs
        only those whose error region it lies in. ``0`` uses the original edges;
        levels beyond the shape's last are its last. ``None`` chooses per query,
        among 0 to :data:`AUTO_MAX_LEVEL`: the build counts, for a random point in
        each frontier cell, the (point, arc) pairs each level tests and the passes it
        needs, and a query takes the level cheapest for its number of frontier
        points (a pass costs :data:`PASS_COST` pairs).
    depth : int, optional
        Level of the finest bins (default :data:`DEFAULT_DEPTH`: cells of 0.022 deg).
        Deeper bins cost more to build and leave fewer points to the exact tests
        (see :func:`depth_for`). By default the bins also stop before the frontier
        exceeds :data:`BUILD_CELLS` cells.
    ellipsoid : None, "WGS84", "GRS80", (a, f) or Ellipsoid
        ``None``: the sphere of ``radius``. Otherwise ``distance`` is a geodesic length
        in metres, latitudes are geodetic and polygon edges geodesics: the result is a
        :class:`gloffset.ellipsoidal.EllipsoidIndex` (the same ``contains``, exact as
        :func:`gloffset.contains` is on the ellipsoid).

    Attributes
    ----------
    level, depth : int
        The decomposition level (when chosen: the choice for :data:`AUTO_SAMPLE`
        frontier points) and the bin depth in use (the bins end shallower when
        nothing is left to refine, or when the frontier would exceed
        :data:`MAX_CELLS` cells).
    n_leaves, n_candidates : int
        Frontier cells of the deepest level, and their candidate arcs in all.
    floor : int
        The lowest decomposition level in the leaves' lists: 0 (original edges) unless
        that would put more than :data:`LEAF_PAIRS` candidate arcs per cell in the
        leaves (large cells on a long, fine boundary); then the leaves keep simplified
        arcs of levels up to ``floor`` where their error regions hold no anchor, and
        levels below ``floor`` are not offered.

    Notes
    -----
    Accuracy: the same answer as the float64 reference
    (:func:`gloffset.reference.contains_xyz`) for every point farther than 1e-13 rad
    from the boundary whose distance to the curves differs from ``|d|`` by more than
    1e-13 rad (in both, every decision is a float64 predicate accurate to about
    1e-15 rad). Error bounds and cell radii are rigorous and padded by
    :data:`MARGIN`, so no shortcut changes an answer; the level and the depth change
    the speed, never the answer.

    Cost: building is proportional to the length of the boundary (and of the offset
    boundary) measured in cells of the deepest level: about 0.1-0.3 s for Mexico
    (7,368 vertices) at the default depth. With the default depth a long boundary
    stops the bins at :data:`BUILD_CELLS` frontier cells, and large leaves on a fine
    boundary keep simplified arcs (:attr:`floor`): all 234 countries of Natural Earth
    1:10m at 0.02 rad build at depth 9 with leaves of level 5 in about 1.5 s instead of
    6.5 s at depth 13, at the price of more points in frontier cells (1e6 uniform
    points on the globe: about 0.6 s instead of 0.02 s); pass ``depth=13`` for the
    deep bins, or let :func:`contains_on_sphere` choose by the number of
    points (:func:`depth_for`). A query costs a table look-up from the
    lon/lat of each point (a few tens of nanoseconds), plus, for the few points in
    frontier cells, a lon/lat to vector conversion and the tests against their
    cell's candidate arcs.

    Examples
    --------
    >>> import gloffset
    >>> ring = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]
    >>> sq = gloffset.read({"type": "Polygon", "coordinates": [ring]})
    >>> ix = gloffset.Index(sq, 100e3)
    >>> ix.contains([5.0, 10.5, 12.0], [5.0, 5.0, 5.0]).tolist()
    [True, True, False]
    """

    #: The class of the index on an ellipsoid (``Index(..., ellipsoid=...)`` makes one):
    #: :class:`gloffset.ellipsoidal.EllipsoidIndex`, which sets it on import.
    on_ellipsoid: type | None = None

    def __new__(cls, shape=None, distance: float = 0.0, *, ellipsoid=None, **options):
        """Make an index, or with ``ellipsoid`` one on that ellipsoid (:attr:`on_ellipsoid`)."""
        if ellipsoid is None:
            return super().__new__(cls)
        if Index.on_ellipsoid is None:  # pragma: no cover - gloffset imports it
            raise OptionError("an index on an ellipsoid needs gloffset.ellipsoidal")
        options.pop("radius", None)  # distances are metres on the ellipsoid
        return Index.on_ellipsoid(shape, distance, ellipsoid=ellipsoid, **options)

    def __init__(
        self,
        shape,
        distance: float = 0.0,
        *,
        radius: float = EARTH_RADIUS,
        level=None,
        depth=None,
        ellipsoid=None,
    ):
        shape = read(shape)
        self._make(shape, offset_angle(shape, distance, radius), level, depth)

    @classmethod
    def at_angle(cls, shape: Shape, d: float, *, level=None, depth=None) -> Index:
        """Return the index of a read ``shape`` at the angle ``d`` (radians).

        The angle is checked by the caller (:func:`gloffset.units.offset_angle`).
        """
        index = object.__new__(cls)
        index._make(shape, d, level, depth)
        return index

    def _make(self, shape: Shape, d: float, level, depth) -> None:
        self.shape, self.distance = shape, d
        self._arcs = arc_tree(self.shape)
        self.level = self._choose_level(level)
        default_depth = depth is None
        if default_depth:
            depth = DEFAULT_DEPTH
        if isinstance(depth, bool) or not isinstance(depth, (int, np.integer)):
            raise InvalidLevelError(f"depth must be an integer or None, got {depth!r}")
        if not 1 <= depth <= MAX_DEPTH:
            raise InvalidLevelError(f"depth must be in 1..{MAX_DEPTH}, got {depth!r}")
        self.requested_depth = self.depth = int(depth)
        self._budget = BUILD_CELLS if default_depth else MAX_CELLS
        self.floor = 0
        self._build()

    # ------------------------------------------------------------------ level
    def _choose_level(self, level) -> int | None:
        """Return the level asked for (None: chosen when the leaves are known)."""
        if level is None:
            return None
        if isinstance(level, bool) or not isinstance(level, (int, np.integer)):
            raise InvalidLevelError(f"level must be an integer or None, got {level!r}")
        if level < 0:
            raise InvalidLevelError(f"level must be >= 0, got {level!r}")
        # beyond the last level where arcs still merge, every level is the same
        return int(min(level, self._arcs.levels))

    # ------------------------------------------------------------------ build
    def _build(self):
        arcs = self._arcs
        d = self.distance
        self._absd = abs(d)
        self._sign = 0 if d == 0.0 else (1 if d > 0.0 else -1)
        # distance test radii: |d| + e + margin for simplified arcs (can a point be within
        # |d| of what they stand for?), exactly |d| for original edges
        r = np.where(arcs.internal, self._absd + arcs.e + MARGIN, self._absd)
        self._dist_c2, self._dist_s = radius_terms(r, arcs.degenerate)

        tiles = []  # (level, j, i, code) of every decided cell
        fronts = {}  # level -> (j, i) of its frontier cells
        lev = 1
        j, i = np.divmod(np.arange(8), 4)
        x = bins.anchors(j, i, lev)[0]
        n = len(x)
        cells = Cells(lev, j, i, x, bins.radii(j, lev), _inside_reference(self.shape, x))
        cells.par[:] = True
        cells.dst[:] = d != 0.0
        pc = np.repeat(np.arange(n), len(arcs.top))
        pn = np.tile(arcs.top, n)
        self._forced = self.depth == 1
        if self._forced:
            kept = self._settle_leaves(cells, pc, pn)
        else:
            kept = Settle(self._arcs, cells, self._absd).run(pc, pn)
        leaves = None
        while True:
            state, par_need, dst_need, kept = self._classify(cells, kept)
            decided = state != 2
            tiles.append((cells.level, cells.j[decided], cells.i[decided], state[decided]))
            front = np.flatnonzero(~decided)
            fronts[cells.level] = (cells.j[front], cells.i[front])
            if len(front) == 0:
                break
            if cells.level >= self.depth or 4 * len(front) > self._budget:
                self.depth = cells.level
                leaves = cells.subset(front)
                leaves.par[:] = par_need[front]
                leaves.dst[:] = dst_need[front]
                pc, pn, _, par, dst = subset_pairs(kept, front)
                if not self._forced:  # settle as leaves (the last level did)
                    pc, pn, _, par, dst = self._settle_leaves(leaves, pc, pn)
                self._leaf_lists(leaves, pc, pn, par, dst)
                tiles.append((leaves.level, leaves.j, leaves.i, 2 + np.arange(len(front))))
                break
            cells, kept = self._refine(cells, front, par_need, dst_need, kept)
        if leaves is None:  # everything decided above the depth asked for
            self.depth, self.floor = cells.level, 0
            none, no = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool)
            self._leaf_lists(None, none, none, no, no)
        self._paint(tiles, fronts)

    def _settle_leaves(self, cells, pc, pn, settle=None, near=False):
        """Settle the pairs of the leaves (:class:`Settle`, through ``settle`` if given).

        The arcs expanded down to the highest level a query may use, then one
        decomposition level at a time while the pairs stay within :data:`LEAF_PAIRS` per
        cell, down to original edges for a short boundary; sets :attr:`floor` to the level
        reached. An arc kept counts for parity as the edges it stands for (its error
        region holds neither anchor), so only the first pass counts crossings.
        """
        arcs = self._arcs
        top = min(AUTO_MAX_LEVEL, arcs.levels) if self.level is None else self.level
        self.floor = top
        settle = Settle(arcs, cells, self._absd) if settle is None else settle
        kept = settle.run(pc, pn, near=near, floor=self.floor)
        plain = Settle(arcs, cells, self._absd)  # no parent: no crossings counted
        budget = LEAF_PAIRS * len(cells.x)
        while self.floor > 0:
            at = arcs.level[kept[1]] == self.floor
            if len(kept[0]) + np.count_nonzero(at) > budget:
                break
            self.floor -= 1
            if at.any():
                more = plain.run(kept[0][at], kept[1][at], near=True, floor=self.floor)
                kept = tuple(np.concatenate([k[~at], m]) for k, m in zip(kept, more))
        return kept

    def _classify(self, cells, kept):
        """State (0 out, 1 in, 2 frontier) of each cell and what its children inherit.

        What frontier cells need, and the pairs their children inherit.
        """
        arcs = self._arcs
        pc, pn, dist, par, dst = kept
        n = len(cells.x)
        par_need = np.bincount(pc[par], minlength=n) > 0
        has_dst = np.bincount(pc[dst], minlength=n) > 0
        uniform = ~par_need
        st = cells.status
        all_within = np.zeros(n, dtype=bool)
        if self._sign != 0 and dst.any():
            # within |d| of the curves wherever in the cell, if one pair's upper bound on
            # the anchor's distance (exact for edges, the nearer end, an original vertex,
            # for simplified arcs) plus the cell's radius is (a rounded sum is monotone:
            # the test of the smallest bound); simplified arcs only where it can matter
            sel = np.flatnonzero(dst)
            val, cs = dist[sel], pc[sel]
            coarse = arcs.internal[pn[sel]]
            limit, rho = self._absd - MARGIN, cells.rho
            all_within = np.bincount(cs[~coarse & (val + rho[cs] <= limit)], minlength=n) > 0
            decided = all_within | (uniform & (st if self._sign > 0 else ~st))
            coarse = np.flatnonzero(coarse & ~decided[cs])
            for k in range(0, len(coarse), PAIR_CHUNK):  # cache-sized chunks
                c = coarse[k : k + PAIR_CHUNK]
                val[c] = end_distance(cells.x[cs[c]], arcs.a[pn[sel[c]]], arcs.b[pn[sel[c]]])
            all_within[cs[coarse[val[coarse] + rho[cs[coarse]] <= limit]]] = True
        if self._sign > 0:
            is_in = all_within | (uniform & st)
            is_out = ~is_in & uniform & ~has_dst
        elif self._sign < 0:
            is_out = all_within | (uniform & ~st)
            is_in = ~is_out & uniform & ~has_dst
        else:
            is_in = uniform & st
            is_out = uniform & ~st
        state = np.full(n, 2, dtype=np.int64)
        state[is_in] = _IN
        state[is_out] = _OUT
        dst_need = has_dst & (self._sign != 0)
        front = state == 2
        keep = front[pc] & ((par & par_need[pc]) | (dst & dst_need[pc]))
        return state, par_need, dst_need, tuple(k[keep] for k in kept)

    def _refine(self, cells, front, par_need, dst_need, kept):
        """Children of the frontier cells, their statuses and settled candidate lists."""
        lev = cells.level + 1
        cj, ci = bins.children(cells.j[front], cells.i[front])
        parent = np.repeat(front, 4)
        x = bins.anchors(cj, ci, lev)[0]
        child = Cells(lev, cj, ci, x, bins.radii(cj, lev), cells.status[parent])
        child.par[:] = par_need[parent]
        child.dst[:] = dst_need[parent]
        # each child inherits its parent's pairs, less those far from it (a cap test)
        settle = Settle(self._arcs, child, self._absd, parent=cells.x[parent])
        pc, pn = settle.inherit(np.searchsorted(front, kept[0]), kept[1])
        self._forced = lev >= self.depth  # the last level: leaves (_settle_leaves)
        if self._forced:
            kept = self._settle_leaves(child, pc, pn, settle, near=True)
        else:
            kept = settle.run(pc, pn, near=True)
        child.status = child.status ^ (settle.parity & 1).astype(bool)
        return child, kept

    def _leaf_lists(self, leaves, pc, pn, par, dst):
        """Candidate lists of the frontier leaves at level K (chosen here when automatic)."""
        arcs = self._arcs
        n_leaves = 0 if leaves is None else len(leaves.x)
        self._leaf_x = np.zeros((0, 3)) if leaves is None else leaves.x
        self._leaf_status = np.zeros(0, bool) if leaves is None else leaves.status
        self.n_leaves = n_leaves
        if self.level is None:
            # for each level, the (point, arc) pairs tested per point (a random point in
            # each leaf) and the passes needed; a query picks by its count of points
            top = min(AUTO_MAX_LEVEL, arcs.levels) if n_leaves >= AUTO_MIN_LEAVES else 0
            top = max(top, self.floor)
            sample = sample_points(leaves, AUTO_SAMPLE) if top > self.floor else None
            self._choices: list[tuple] | None = []
            for k in range(self.floor, top + 1):
                lists = self._lift(k, leaves, pc, pn, par, dst)
                pairs, passes = (
                    (0, 1) if sample is None else self._frontier(*sample, lists=lists, cost=True)
                )
                per_point = pairs / max(1, 0 if sample is None else len(sample[1]))
                self._choices.append((per_point, passes, k, lists))
            # reported as ``level``: the choice for a batch of AUTO_SAMPLE frontier points
            self._lists: tuple | None = None
            lists = self._lists_for(AUTO_SAMPLE)
            self.level = next(c[2] for c in self._choices if c[3] is lists)
        else:
            self._choices = None
            lists = self._lift(self.level, leaves, pc, pn, par, dst)
        self._lists = lists
        self.n_candidates = len(lists[0])

    def _lists_for(self, n_points: int):
        """Return the candidate lists a batch of ``n_points`` frontier points is cheapest with."""
        if self._choices is None:
            return self._lists
        return min(self._choices, key=lambda c: n_points * c[0] + PASS_COST * c[1])[3]

    def _lift(self, level, leaves, pc, pn, par, dst):
        """Candidate lists with original edges lifted to ``level``.

        ``(arc, flags, start, count)``.

        Each edge is replaced by its highest ancestor of level <= K whose error region
        does not hold the leaf's anchor (for parity; any ancestor of level K for the
        distance alone). These ancestors never nest, so no crossing counts twice.
        """
        arcs = self._arcs
        node = pn.copy()
        if level > 0 and len(pn):
            node = arcs.ancestors(level)[pn]
            todo = np.flatnonzero(par)
            for k in range(level, 0, -1):
                # an arc of level k or above was kept: its region holds no anchor
                final = arcs.level[pn[todo]] >= k
                node[todo[final]] = pn[todo[final]]
                todo = todo[~final]
                if len(todo) == 0:
                    break
                nd = arcs.ancestors(k)[pn[todo]]
                held = arcs.internal[nd] & (
                    arc_distance(leaves.x[pc[todo]], arcs.a[nd], arcs.b[nd], arcs.n[nd])
                    <= arcs.e[nd] + MARGIN
                )
                node[todo] = nd
                todo = todo[held]
            node[todo] = pn[todo]
        flags = np.where(par, _PAR, 0) | np.where(dst, _DST, 0)
        # one entry per (leaf, arc), flags united
        m = len(arcs.a)
        key = pc * m + node
        order = np.argsort(key, kind="stable")
        key, flags = key[order], flags[order]
        first = np.flatnonzero(np.r_[True, key[1:] != key[:-1]]) if len(key) else key
        flags = np.bitwise_or.reduceat(flags, first) if len(key) else flags
        counts = np.bincount(key[first] // m, minlength=len(self._leaf_x))
        return key[first] % m, flags.astype(np.int8), np.cumsum(counts) - counts, counts

    def _paint(self, tiles, fronts):
        """Return the lookup tables, row-major.

        One for the cells of level ``ROOT_LEVEL``, then, every ``TABLE_STEP`` levels down
        to the depth, one block per frontier cell of the level above, holding its
        descendants (a negative code ``-1 - b`` points to block ``b`` of the next table).
        """
        L = self.depth
        levels = [min(ROOT_LEVEL, L)]
        while levels[-1] < L:
            levels.append(min(levels[-1] + TABLE_STEP, L))
        self._table_levels = levels
        self._tables = []
        parents = None  # row-major keys of the blocks of this table (frontier cells above)
        for k, t in enumerate(levels):
            lo = levels[k - 1] if k else -1
            parts = [(lev, j, i, code) for lev, j, i, code in tiles if lo < lev <= t]
            blocks = None
            if t < L and len(fronts.get(t, ((),))[0]):
                fj, fi = fronts[t]
                blocks = np.sort((fj << (t + 1)) + fi)
                parts.append(
                    (t, blocks >> (t + 1), blocks & ((2 << t) - 1), -1 - np.arange(len(blocks)))
                )
            if k == 0:
                table = paint_table(parts, t, None, 0)
            else:
                table = paint_table(parts, t, parents, t - lo)
            self._tables.append(table)
            parents = blocks
            if blocks is None:
                break

    # ------------------------------------------------------------------ queries
    def contains(self, lon, lat) -> np.ndarray:
        """Offset-region membership of points given by lon/lat in degrees (broadcast).

        Raises :class:`~gloffset.InvalidGeometryError` for NaN, infinite coordinates
        or latitudes outside [-90, 90] (as the reference does).
        """
        lon, lat, shp = check_lonlat(lon, lat)
        return self._query(lon, lat).reshape(shp)

    def contains_xyz(self, p) -> np.ndarray:
        """Membership of unit vectors ``p`` (n, 3)."""
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        lon, lat = xyz_to_lonlat(p)
        return self._query(lon, lat, p)

    def _lookup(self, lon, lat) -> np.ndarray:
        """Cell codes of points: 0 out, 1 in, ``2 + leaf`` for frontier leaves."""
        levels, tables = self._table_levels, self._tables
        L = self.depth
        j, i = bins.locate(lon, lat, L)
        t0 = levels[0]
        root = j >> (L - t0)
        root <<= t0 + 1
        root += i >> (L - t0)
        code = tables[0][root]
        sel = np.flatnonzero(code < 0)
        for k in range(1, len(tables)):
            if len(sel) == 0:
                break
            step = levels[k] - levels[k - 1]
            shift, mask = L - levels[k], (1 << step) - 1
            local = (((j[sel] >> shift) & mask) << step) | ((i[sel] >> shift) & mask)
            block = (-1 - code[sel]).astype(np.int64)
            code[sel] = tables[k][(block << (2 * step)) | local]
            sel = sel[code[sel] < 0]
        return code

    def _query(self, lon, lat, p=None) -> np.ndarray:
        out = np.empty(len(lon), dtype=bool)
        if len(lon) == 0:
            return out
        wheres, leaves_of = [], []
        for s in range(0, len(lon), CHUNK):
            code = self._lookup(lon[s : s + CHUNK], lat[s : s + CHUNK])
            out[s : s + CHUNK] = code == _IN
            front = np.flatnonzero(code >= 2)
            wheres.append(front + s)
            leaves_of.append(code[front] - 2)
        # the few points in frontier cells, together (fewer, larger numpy calls)
        where, leaves = np.concatenate(wheres), np.concatenate(leaves_of)
        lists = self._lists_for(len(where))
        for s in range(0, len(where), CHUNK):
            w = where[s : s + CHUNK]
            pf = lonlat_to_xyz(lon[w], lat[w]) if p is None else p[w]
            out[w] = self._frontier(pf, leaves[s : s + CHUNK], lists=lists)
        return out

    def _frontier(self, p: np.ndarray, leaf: np.ndarray, *, lists=None, cost=False):
        """Exact answers for points ``p`` in frontier leaves ``leaf`` (Eq. 9 and parity).

        With ``cost``, the number of (point, arc) pairs tested and of passes instead (to
        choose a level).
        """
        arcs = self._arcs
        lists = self._lists if lists is None else lists
        assert lists is not None  # set by _leaf_lists
        cand, cand_flags, start, count = lists
        n = len(p)
        x = self._leaf_x[leaf]
        px = cross(p, x)
        counts = count[leaf]
        pt = np.repeat(np.arange(n), counts)
        first = np.repeat(start[leaf] - (np.cumsum(counts) - counts), counts)
        idx = first + np.arange(len(pt))
        node = cand[idx]
        flags = cand_flags[idx]
        crossings = np.zeros(n, dtype=np.int64)
        near = np.zeros(n, dtype=bool)
        tested = passes = 0
        while len(node):
            tested += len(node)
            passes += 1
            g = arcs.g[node]
            pp = p[pt]
            pg = dots(g, pp)
            par = (flags & _PAR) != 0
            dst = (flags & _DST) != 0
            internal = arcs.internal[node]
            expand = np.zeros(len(node), dtype=bool)
            if internal.any():
                # Eq. 9: reconstruct where p lies in the error region (parity) or within
                # |d| + e (distance)
                ci = np.flatnonzero(internal & par)
                if len(ci):
                    nd = node[ci]
                    expand[ci] = within(pp[ci], g[ci], arcs.saus_c2[nd], arcs.saus_s[nd], pg[ci])
                ci = np.flatnonzero(internal & dst & ~expand)
                if len(ci):
                    nd = node[ci]
                    expand[ci] = within(pp[ci], g[ci], self._dist_c2[nd], self._dist_s[nd], pg[ci])
            # settled pairs: parity with the arc as it is (simplified or original); the
            # sides of its ends and of the anchor with the same arithmetic everywhere
            cnt = np.flatnonzero(par & ~expand)
            if len(cnt):
                t = pt[cnt]
                gc = g[cnt]
                cr = crosses(None, x[t], px[t], gc[:, 0:3], gc[:, 3:6], gc[:, 6:9], pg[cnt, 2])
                crossings += np.bincount(t[cr], minlength=n)
            # original edges: the exact distance test
            fin = np.flatnonzero(dst & ~internal)
            if len(fin):
                nd = node[fin]
                w = within(pp[fin], g[fin], self._dist_c2[nd], self._dist_s[nd], pg[fin])
                near[pt[fin[w]]] = True
            ex = np.flatnonzero(expand)
            pt = np.repeat(pt[ex], 2)
            flags = np.repeat(flags[ex], 2)
            node = arcs.child[node[ex]].ravel()
        if cost:
            return tested, passes
        inside = self._leaf_status[leaf] ^ (crossings & 1).astype(bool)
        if self._sign > 0:
            return inside | near
        if self._sign < 0:
            return inside & ~near
        return inside

    def __repr__(self) -> str:
        return (
            f"Index(distance={self.distance:.6g} rad, level={self.level}, bins to level "
            f"{self.depth}, {self.n_leaves} frontier cells, {self.n_candidates} candidates)"
        )
