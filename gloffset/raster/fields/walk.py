"""The walk of :func:`gloffset.distance_field`: each pixel's nearest arc, exactly.

A branch and bound over the grid's levels, coarse to fine, every cell with a list of
candidate nodes of the multiresolution tree (paper Sec. 4.2, Eq. 9 bounds), pruned by
their bounds (:func:`_bound`) and by tests against the cell's nearest boundary vertex
(:mod:`gloffset.raster.fields.dominance`: its bisector with a node's cap, and the bound
on the difference of two distances over the disc); nodes are split as the cells
shrink, down to the original edges at the pixels, each pixel ending with the exact
float64 distance of its nearest arc (:func:`exact_distances`, the bits of
:func:`~gloffset.geometry.sphere.arc_distance`). :func:`walk_levels` yields the parts of
any level with their lists: the output level's with the distances (the CPU backend), or
a coarser one's whose lists hold every arc that can be nearest to one of their pixels
(the GPU backend). The derivation is in the design
notes (``docs/design.md``).
"""

from __future__ import annotations

import weakref

import numpy as np

from ...geometry.caps import CAP_SLACK, cap_range, pad
from ...geometry.sphere import angle, column_dots, cross, dot
from ..vector.levels import Frontier, children
from ..vector.node_levels import NodeArcs
from . import dominance, starts

__all__ = [
    "end_distances",
    "exact_distances",
    "kids_reach",
    "root_list",
    "start_pairs",
    "walk_levels",
]

#: Cells and candidate pairs of one part of a level (a larger level is walked in parts
#: of contiguous cells: the next level has about four times as many of each).
_PART_CELLS, _PART_PAIRS = 1 << 16, 1 << 20


def walk_levels(
    nodes: NodeArcs, grid, m: float, stop: int, split: bool = True, *, pairs: bool = False
):
    """Yield the parts of level ``stop`` with their lists, and their cells' distances.

    Each as ``(f, dist)``: the frontier ``f`` (its cells, centres and candidate pairs,
    sorted by cell) and each cell's distance to its nearest pair (rad, float64; ``inf``
    where it has none). At the output level (``stop`` the last) the distances are exact
    where at most ``m``; above it, the lists hold every original arc (nodes split down
    to the arcs) that can be the nearest arc within ``m`` of a point within ``rho`` of
    the cell's centre (so of any of its pixels' centres). The levels are walked depth
    first, in parts of contiguous cells. Without ``split``, the nodes of level ``stop``
    above the output are split as those of the levels above it (to ``KAPPA rho``): lists
    that a walk further down can start from.
    With ``pairs`` (the output level only), each as ``(f, dist, (cell, node, d))``: the
    pairs whose exact distance ``d`` was computed, sorted by cell (every pair that can be a pixel's
    nearest is among them, the least of their ``d`` being ``dist``, bit for bit): what
    each pixel's nearest features are read from (:mod:`gloffset.raster.fields.sign`).
    The distances are the same bits either way.
    """
    last = grid.n_levels - 1
    h0, w0 = grid.level_shape(0)
    top = nodes.top[nodes.boundary[nodes.top]]
    jj, ii = np.meshgrid(np.arange(h0), np.arange(w0), indexing="ij")
    cells = np.column_stack([jj.ravel(), ii.ravel()])
    k = len(cells)
    c = grid.centers(0, cells[:, 0], cells[:, 1])
    rho = grid.rho_at(0, cells[:, 0], cells[:, 1])
    pc, pn = start_pairs(nodes, m, (h0, w0), c, rho, top)
    stack = [(Frontier(0, cells, c, rho, pc, pn, np.zeros((k, 0), np.uint8)), False)]
    leaves = min(stop if split else last, last - 1)  # the level whose nodes are split to the arcs
    while stack:  # depth first: one part of each level at a time
        f, parent = stack.pop()
        if parent:
            cells, _, c, rho, pc, pn = children(f, grid)
            f = Frontier(f.level + 1, cells, c, rho, pc, pn, np.zeros((len(cells), 0), np.uint8))
        reach = kids_reach(f, grid) if f.level == last - 1 else f.rho
        final = f.level == last
        got = _bound(f, nodes, m, reach, final=final, leaves=f.level == leaves, pairs=pairs)
        f, dist = got[0], got[1]
        if f.level == stop:
            yield (f, dist, got[2]) if pairs and final else (f, dist)
            continue
        stack.extend((part, True) for part in reversed(list(_parts(f))))


#: A grid whose level 0 lies within this angle (rad) of its centre is first walked as one
#: cell (:func:`root_list`): a tile, a regional box.
_ROOT_REACH = 1.0


def root_list(nodes: NodeArcs, m: float, c: np.ndarray, rho: np.ndarray, top):
    """Return the nodes every cell of level 0 starts with.

    For a small grid (its level-0 cells within :data:`_ROOT_REACH` of their mean
    direction), the nodes that can hold the nearest arc of a point of the disc about that
    centre holding every cell's disc: the grid's cells pruned and split as one (the same
    rigorous :func:`_bound`), instead of each cell testing and splitting the tree's top
    nodes. Else ``top``, the top boundary nodes.
    """
    centre = c.sum(axis=0)
    size = np.sqrt(dot(centre, centre))
    if len(top) == 0 or not size > 0.5 * len(c):
        return top
    centre = centre / size
    reach = float(pad(np.max(angle(c, centre[None, :]) + rho)))
    if not reach < _ROOT_REACH:
        return top
    canon = starts.canonical_disc(centre, reach) if KEEP_STARTS else None
    if canon is not None:  # bounded from a kept list of a canonical disc holding it
        key, cc, cr = canon
        top = starts.kept_lists(nodes).once(
            (m, key), lambda: _disc_list(nodes, m, cc, cr, top), keep=starts.KEEP
        )
    return _disc_list(nodes, m, centre, reach, top)


#: Whether :func:`root_list` bounds from kept lists of canonical discs
#: (:mod:`gloffset.raster.fields.starts`).
KEEP_STARTS = True


def _disc_list(nodes: NodeArcs, m: float, centre, reach: float, start) -> np.ndarray:
    """The nodes of ``start`` (or their descendants) that can hold the nearest arc of a
    point within ``reach`` of ``centre``: one cell bounded by :func:`_bound`."""
    root = Frontier(
        0,
        np.zeros((1, 2), np.int64),
        np.asarray(centre, dtype=np.float64)[None, :],
        np.array([reach]),
        np.zeros(len(start), np.int64),
        np.asarray(start),
        np.zeros((1, 0), np.uint8),
    )
    g, _ = _bound(root, nodes, m, np.array([reach]), final=False)
    return g.pair_arc


#: :func:`start_pairs` walks the quadtree where level 0 would start from at least this
#: many pairs (its cells times the root's list; below it the quadtree's own rounds cost
#: more than they save: 2-10 ms more on z8-z10 tiles of 20-40 nodes a root list, measured).
_QUAD_PAIRS = 1 << 17


def start_pairs(nodes: NodeArcs, m: float, shape: tuple[int, int], c, rho, top):
    """Return the pairs (cells, nodes) level 0 starts from, sorted by cell.

    ``shape`` (h, w) the cells of level 0 (row-major), ``c`` and ``rho`` their centres
    and radii. A grid that :func:`root_list` walks as one cell (a tile, a regional box)
    is then walked down a quadtree of blocks of its level-0 cells, halving the block's
    side each step (blocks of ``2^s x 2^s`` cells from the root's down to 2 x 2): each
    block bounds its parent's list (the same rigorous :func:`_bound`) on a disc about
    its cells' mean direction that holds each of its cells' discs, and each cell starts
    from its 2 x 2 block's list. A list holds every node that can hold the nearest arc
    of a point of its cells' discs (a block keeps, from its parent's list, the nodes
    that can be nearest to a point of its own disc among that list: the cells' discs
    lie in every ancestor's), so the walk below finds the same nearest arcs (the
    values bit for bit) from lists a level of the quadtree shorter: a 256 px tile's
    1,024 cells bound a few times their lists' pairs instead of each the root's. Where
    that would be fewer than :data:`_QUAD_PAIRS` pairs, every cell starts from the
    root's list; on a larger grid, from ``top`` (the top boundary nodes).
    """
    k = len(c)
    root = root_list(nodes, m, c, rho, top)
    h, w = shape
    side = 1 << max(0, max(h, w) - 1).bit_length()  # the root's block
    if root is top or len(root) * k < _QUAD_PAIRS or side < 4:
        return np.repeat(np.arange(k), len(root)), np.tile(root, k)
    j, i = np.divmod(np.arange(k), w)
    start, count, node = np.zeros(1, np.int64), np.array([len(root)]), np.asarray(root)
    nw = 1  # blocks per row of the level above
    while side > 2:
        side >>= 1
        bw = -(-w // side)
        block = (j // side) * bw + i // side
        nb = -(-h // side) * bw
        has = np.bincount(block, minlength=nb) > 0
        up = (np.arange(nb) // bw // 2) * nw + (np.arange(nb) % bw) // 2  # the parent
        cnt = np.where(has, count[up], 0)
        at = np.cumsum(cnt) - cnt
        pn = node[np.repeat(start[up] - at, cnt) + np.arange(int(cnt.sum()))]
        pc = np.repeat(np.arange(nb), cnt)
        sums = np.stack([np.bincount(block, c[:, x], minlength=nb) for x in range(3)], -1)
        size = np.sqrt(dot(sums, sums))
        bound = has & (size > 0.5 * np.bincount(block, minlength=nb))
        centre = sums / np.where(bound, size, 1.0)[:, None]
        reach = np.zeros(nb)
        np.maximum.at(reach, block, angle(c, centre[block]) + rho)
        reach = pad(reach)
        sel = np.flatnonzero(bound & (cnt > 0))  # the others keep their parent's list
        keep = ~bound[pc]
        if len(sel):
            pick = np.flatnonzero(bound[pc])
            f = Frontier(
                0,
                np.zeros((len(sel), 2), np.int64),
                centre[sel],
                reach[sel],
                np.searchsorted(sel, pc[pick]),
                pn[pick],
                np.zeros((len(sel), 0), np.uint8),
            )
            g, _ = _bound(f, nodes, m, reach[sel], final=False)
            pc = np.concatenate([pc[keep], sel[g.pair_cell]])
            pn = np.concatenate([pn[keep], g.pair_arc])
            order = np.argsort(pc, kind="stable")
            pc, pn = pc[order], pn[order]
        count = np.bincount(pc, minlength=nb)
        start, node, nw = np.cumsum(count) - count, pn, bw
    b = (j // 2) * nw + i // 2  # each cell's 2 x 2 block
    cnt = count[b]
    at = np.cumsum(cnt) - cnt
    return np.repeat(np.arange(k), cnt), node[
        np.repeat(start[b] - at, cnt) + np.arange(int(cnt.sum()))
    ]


#: Above the output level a cell's nodes have error bounds of at most this fraction of
#: its rho (finer nodes tighten the bounds, coarser ones shorten the lists).
_KAPPA = 0.0625

#: Absolute slack (rad) on the bounds of :func:`_bound` (exact float64 distances are good
#: to 1e-15 rad; the error bounds of the nodes are padded already).
_TINY = 1e-14


def kids_reach(f: Frontier, grid) -> np.ndarray:
    """Return the farthest child centre (output level) from each cell's centre, rounded up.

    These are the only points of the next level whose distances are asked for, so the
    lists of the level above the output need hold their nearest arcs only (at about half
    the cell's ``rho``).
    """
    h, w = grid.level_shape(f.level + 1)
    out = np.zeros(len(f.cells))
    for dj in (0, 1):
        for di in (0, 1):
            j = np.minimum(2 * f.cells[:, 0] + dj, h - 1)
            i = np.minimum(2 * f.cells[:, 1] + di, w - 1)
            out = np.maximum(out, angle(grid.centers(f.level + 1, j, i), f.centers))
    return pad(out)


def _bound(
    f: Frontier,
    nodes: NodeArcs,
    m: float,
    reach,
    final: bool,
    leaves: bool = False,
    pairs: bool = False,
):
    """Return the pairs (cells, nodes) that can hold a nearest arc, and the distances.

    The pairs of ``f`` that can hold the nearest boundary arc of some point within
    ``reach`` (``rho``, or less: :func:`kids_reach`) of a cell's centre,
    every node split until its error bound is at most :data:`_KAPPA` ``rho``; and each
    cell's distance to its nearest pair (``inf`` where it has none). At the output level
    (``final``) only the pixel centre is asked for (``reach`` is not read): nodes are
    split down to the original arcs, the distance is exact and ``f`` comes back as it
    was (no list goes further down). With ``leaves`` (the level above the output) the
    nodes are split down to the original arcs too.

    Branch and bound, rigorous both ways: a pair's run lies no nearer to the centre than
    its lower bound (the angle to the node's cap centre less the cap's radius,
    :func:`~gloffset.geometry.caps.cap_range`, widened by
    :data:`~gloffset.geometry.caps.CAP_SLACK`; or the
    exact distance to its arc less its error bound), and no farther than the exact
    distance to its arc plus its error bound. A pair whose lower bound exceeds the least
    upper bound of the cell by more than ``2 reach`` (by nothing at the output level) is
    nearer to no point within ``reach`` than that one (nor within ``m`` of any, beyond
    ``m + reach``). Above the output level a pair kept for that slack alone must also
    pass the tests against the cell's nearest boundary vertex found so far
    (:mod:`~gloffset.raster.fields.dominance`: ``maybe_nearer``, and ``vertex_dominates``
    on cells at least ``DEEP`` of their reach from it). Each pair's bounds are computed
    once: a round computes those of the halves of the nodes split in the round before,
    the least upper bounds carried over. At the output level with arcs only (as the
    level above leaves its lists), every pair's exact distance instead (:func:`_least`).
    With ``pairs`` at the output level, also the pairs measured, ``(cell, node,
    exact)`` (see :func:`walk_levels`).

    Each round's pairs come sorted by cell (the frontier's are, and a split pair's
    halves follow it) and are bounded in pieces of about :data:`_BOUND_PAIRS` pairs cut
    between cells (:func:`_round`; every value is its cell's own, so the pieces change
    no bit); the values per cell are gathered by runs (``np.repeat``) and reduced by them
    (``reduceat``), each node's values gathered once per pair (:class:`_Table`), and the
    rounds' pairs merged by cell with a counting sort (:func:`_merge`): the values of the
    formulas applied pair by pair, bit for bit.
    """
    if final and nodes.leaf[f.pair_arc].all():
        d = exact_distances(f.centers, f.pair_cell, nodes, f.pair_arc)
        dist = _least(len(f.cells), f.pair_cell, d)
        return (f, dist, (f.pair_cell, f.pair_arc, d)) if pairs else (f, dist)
    tab = _table(nodes)
    k = len(f.cells)
    st = _Cells(f, m, reach, final, leaves)
    cell, node = f.pair_cell, f.pair_arc
    # (cells, nodes, lower bounds[, exact distances]) of the pairs left as they are
    done: list = [(cell[:0], node[:0], np.zeros(0), np.zeros(0))] if final else []
    while len(cell):
        pieces = [_round(st, tab, cell[a:b], node[a:b]) for a, b in _pieces(cell)]
        done.append(tuple(np.concatenate(x) for x in zip(*(x[0] for x in pieces))))
        cell, node = (np.concatenate(x) for x in zip(*(x[1] for x in pieces)))
    dist = st.dist
    if final:  # the distances are all that is asked for (no list goes further down)
        cell, node, lo, exact = (np.concatenate(x) for x in zip(*done))
        np.minimum.at(dist, cell, exact)
        if not pairs:
            return f, dist
        order = np.argsort(cell, kind="stable")
        return f, dist, (cell[order], node[order], exact[order])
    # the rounds' pairs against the least upper bounds of all rounds, sorted by cell
    thr = st.threshold()
    left = []
    for cell, node, lo in done:
        keep = lo <= thr.take(cell)
        left.append((cell.compress(keep), node.compress(keep)))
    cell, node = _merge(k, left, f.pair_arc.dtype)
    g = Frontier(f.level, f.cells, f.centers, f.rho, cell, node, f.status)
    return g, dist


#: Pairs per piece of a round of :func:`_bound` (whose arrays then stay in the processor's
#: caches; the cells are bounded one by one, so the pieces change no bit).
_BOUND_PAIRS = 1 << 17

#: Above this fraction of a round's pairs kept for the slack alone, the bisector test runs
#: on every pair of the round (and is read where kept) rather than on those gathered.
_ALL_KEPT = 0.85


def _pieces(cell) -> list[tuple[int, int]]:
    """Return ranges of about :data:`_BOUND_PAIRS` pairs that cut the pairs (sorted by
    cell) between cells."""
    n = len(cell)
    if n <= _BOUND_PAIRS:
        return [(0, n)]
    cuts = np.searchsorted(cell, cell[_BOUND_PAIRS::_BOUND_PAIRS])  # each one's cell's first
    cuts = np.unique(np.r_[0, cuts, n])
    return list(zip(cuts[:-1].tolist(), cuts[1:].tolist()))


class _Cells:
    """The cells of a call of :func:`_bound` as its rounds read and update them.

    Their centres (columns), ``reach`` (its cosine and sine), the error bound above
    which a node is split (None: 0, the arcs), the slack and ``far`` of the pruning;
    ``best`` (each cell's least upper bound so far), ``dist`` (its least exact distance
    of the pairs left as they are) and, above the output level, its nearest boundary
    vertex so far (``vcos`` the cosine of its angle to the centre, ``vtx`` the point as
    columns).
    """

    def __init__(self, f: Frontier, m: float, reach, final: bool, leaves: bool):
        k = len(f.cells)
        self.final = final
        self.cc = [np.ascontiguousarray(f.centers[:, i]) for i in range(3)]
        self.bound = None if (leaves or final) else _KAPPA * f.rho
        self.slack = 0.0 if final else 2.0 * reach
        self.far = m if final else m + reach
        self.best = np.full(k, np.inf)
        self.dist = np.full(k, np.inf)
        if not final:
            self.reach = reach
            self.cos_reach, self.sin_reach = np.cos(reach), np.sin(reach)
            self.vcos, self.vtx = np.full(k, -2.0), [np.zeros(k) for _ in range(3)]

    def threshold(self) -> np.ndarray:
        """Each cell's bound above which a pair's lower bound prunes it."""
        return np.minimum(self.best + self.slack, self.far) + _TINY


def _round(st: _Cells, tab: _Table, cell, node):
    """One round of :func:`_bound` on the pairs ``(cell, node)`` (sorted by cell, every
    pair of their cells in the round): return the pairs left as they are (cells, nodes,
    lower bounds, and at the output level exact distances, ``inf`` where not measured)
    and the halves of those split, ``(cell, node)``."""
    best = st.best
    at, cnt, has = _cell_runs(cell)  # cell has[i] holds pairs at[i] .. at[i] + cnt[i]
    runs = has, cnt
    mid = [x.take(node) for x in tab.mid]
    cm = column_dots([_per_pair(runs, x) for x in st.cc], mid)
    r = tab.reach.take(node)
    lo, hi = cap_range(cm, r)
    t = lo + hi
    t *= 0.5  # the angle to the cap's centre
    lo -= CAP_SLACK
    hi += CAP_SLACK
    # first each cell's likeliest pair of the round (least upper bound): its exact
    # distance tightens the bound that the others are tested against
    least = np.minimum.reduceat(hi, at)
    best[has] = np.minimum(best[has], least)
    first = np.flatnonzero(hi == np.repeat(least, cnt))
    first = first[np.diff(cell[first], prepend=-1) != 0]  # one per cell (sorted)
    cf, fi = cell[first], node[first]
    exact_f = _exact(st.cc, cf, tab, fi)
    best[cf] = np.minimum(best[cf], exact_f + tab.err[fi])  # one pair per cell
    is_near = lo <= _per_pair(runs, best)
    is_near[first] = False
    rest = np.flatnonzero(is_near)
    exact_r = _exact(st.cc, cell[rest], tab, node[rest])
    is_near[first] = True
    near = np.flatnonzero(is_near)
    # the exact distances of the pairs ``near`` (``first`` and ``rest``, merged)
    exact = np.empty(len(near))
    is_first = np.zeros(len(near), dtype=bool)
    is_first[np.searchsorted(near, first)] = True
    exact[is_first] = exact_f
    exact[~is_first] = exact_r
    cn, ni = cell[near], node[near]
    err = tab.err[ni]
    np.minimum.at(best, cn, exact + err)
    lo[near] = np.maximum(lo[near], exact - err)
    keep = lo <= _per_pair(runs, st.threshold())
    if not st.final:
        dominance.nearest_vertices(st.cc, cn, ni, tab, st.vcos, st.vtx)
        _vertex_tests(st, tab, (runs, cell, node), (mid, cm, t, r, lo), best, keep)
    split = tab.cut.take(node)
    split = split > (0.0 if st.bound is None else _per_pair(runs, st.bound))
    split &= keep
    stay = keep & ~split
    if st.final:
        measured = np.full(len(cell), np.inf)
        measured[near] = exact
        left = (*(x.compress(stay) for x in (cell, node, lo)), measured.compress(stay))
    else:
        left = tuple(x.compress(stay) for x in (cell, node, lo))
        on = stay.take(near)  # the exact distances of the pairs left as they are
        np.minimum.at(st.dist, cn.compress(on), exact.compress(on))
    s = np.flatnonzero(split)
    return left, _halves(st, tab, cell[s], node[s])


#: How many more levels a split node goes down at once where its halves would be split
#: too (their halves replacing them: one round instead of two).
DEEPER = 1


def _halves(st: _Cells, tab: _Table, cell, node):
    """The pairs that replace the split pairs ``(cell, node)``: each node's two halves,
    sorted by cell as they are; with :data:`DEEPER`, a half that would be split in the
    next round (its error above the cell's bound) by its own halves already."""
    cell, node = np.repeat(cell, 2), tab.child.take(node, axis=0).ravel()
    for _ in range(DEEPER):
        if st.final or len(node) == 0:
            break
        bound = 0.0 if st.bound is None else st.bound.take(cell)
        deep = tab.cut.take(node) > bound
        if not deep.any():
            break
        two = np.where(deep[:, None], tab.child.take(node, axis=0), node[:, None])
        two[:, 1] = np.where(deep, two[:, 1], -1)
        real = two.ravel() >= 0
        cell, node = np.repeat(cell, 2).compress(real), two.ravel().compress(real)
    return cell, node


def _vertex_tests(st: _Cells, tab: _Table, pairs, caps, best, keep) -> None:
    """Clear ``keep`` where a pair kept for the slack alone fails the tests against its
    cell's vertex (:mod:`~gloffset.raster.fields.dominance`). ``pairs``: the round's
    ``(runs, cell, node)``; ``caps``: per pair ``(mid, c.mid, t, r, lo)``."""
    runs, cell, node = pairs
    mid, cm, t, r, lo = caps
    # the pairs kept for the slack alone (a pair that may be the nearest at the
    # centre stays whatever the test says, nearly always)
    is_kept = keep & (lo > _per_pair(runs, best))
    n_kept = np.count_nonzero(is_kept)
    disc = st.reach, st.cos_reach, st.sin_reach
    if n_kept > _ALL_KEPT * len(cell):
        # the test on every pair (no gathers of the kept ones), read where kept
        vm = column_dots([_per_pair(runs, x) for x in st.vtx], mid)
        ok = dominance.maybe_nearer(
            (cm, t, _per_pair(runs, st.vcos), vm),
            (r, tab.cos_r.take(node), tab.sin_r.take(node)),
            [_per_pair(runs, x) for x in disc],
        )
        keep &= ok | ~is_kept
    elif n_kept:
        kept = np.flatnonzero(is_kept)
        ck, nk = cell.take(kept), node.take(kept)
        vm = column_dots(st.vtx, [x.take(kept) for x in mid], ck)
        keep[kept] = dominance.maybe_nearer(
            (cm.take(kept), t.take(kept), st.vcos.take(ck), vm),
            (r.take(kept), tab.cos_r.take(nk), tab.sin_r.take(nk)),
            [x.take(ck) for x in disc],
        )
    if dominance.DOMINANCE and n_kept:  # the cell's vertex dominates them
        deep = keep & is_kept & (lo >= _per_pair(runs, dominance.DEEP * st.reach))
        kept = np.flatnonzero(deep & (_per_pair(runs, st.vcos) > -1.5))
        ck = cell.take(kept)
        keep[kept] = ~dominance.vertex_dominates(
            [x.take(ck) for x in st.cc],
            [x.take(ck) for x in st.vtx],
            [x.take(kept) for x in mid],
            lo.take(kept),
            r.take(kept),
            st.reach.take(ck),
        )


def _cell_runs(cell) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The runs of equal values of ``cell`` (sorted, not empty): each run's first pair,
    its count and its cell."""
    c0 = int(cell[0])
    at = np.searchsorted(cell, np.arange(c0, int(cell[-1]) + 2))
    cnt = np.diff(at)
    has = np.flatnonzero(cnt)
    return at[has], cnt[has], has + c0


def _per_pair(runs, x) -> np.ndarray:
    """``x[cell]`` for a value ``x`` per cell, the pairs' cells given as ``runs``: the
    cells that have pairs and how many each (the pairs sorted by cell)."""
    has, cnt = runs
    return np.repeat(x[has], cnt)


def _merge(k: int, runs, dtype):
    """Return the pairs ``(cell, node)`` of ``runs`` sorted by cell, stably.

    Each run's pairs sorted by cell (cells ``0 .. k - 1``): a counting sort, the order
    of ``np.argsort(cell, kind="stable")`` on the runs one after the other.
    """
    counts = [np.bincount(cell, minlength=k) for cell, _ in runs]
    total = np.sum(counts, axis=0) if counts else np.zeros(k, np.int64)
    at = np.cumsum(total) - total  # where each cell's next pair goes
    out = np.empty(int(total.sum()), dtype=dtype)
    for (cell, node), n in zip(runs, counts):
        if len(cell):
            out[np.repeat(at - (np.cumsum(n) - n), n) + np.arange(len(cell))] = node
        at += n
    return np.repeat(np.arange(k), total), out


def _least(k: int, cell, d) -> np.ndarray:
    """Return each of ``k`` cells' least ``d`` of its pairs (``inf`` where it has none).

    At the output level every pair gets its exact distance, with no bound computed
    first: nearly every pair needs it (the lists hold the arcs that can be nearest to
    the pixel's centre), and the least of them is the least of those a pruning would
    leave, bit for bit (a pair pruned is never the nearest one).
    """
    dist = np.full(k, np.inf)
    np.minimum.at(dist, cell, d)
    return dist


#: Pairs per call of the kernel of :func:`exact_distances` (its temporaries then stay in the
#: processor's caches).
_CHUNK = 1 << 15


class _Table:
    """The node table as the walk reads it, made once per table.

    Coordinates as contiguous columns (gathered one at a time, no (k, 3) copies), and
    what :func:`~gloffset.geometry.sphere.arc_distance` computes per arc (``n x a``,
    ``b x n`` and ``n.n > 0.5``) computed once per node, with the same bits; for
    :func:`_bound`, each node's cap (``mid``, ``reach`` and its cosine and sine), its
    padded error bound plus :data:`_TINY` (``err``) and ``cut``: its error bound, or
    ``-inf`` for an original arc (a pair is split where ``cut`` exceeds the cell's bound,
    which is never negative). Each value the bits of the formula applied to the node
    where it is read.
    """

    def __init__(self, nodes: NodeArcs):
        def cols(x):
            return [np.ascontiguousarray(x[:, k]) for k in range(3)]

        n = nodes.n
        self.a, self.b, self.n = cols(nodes.a), cols(nodes.b), cols(n)
        self.na, self.bn = cols(cross(n, nodes.a)), cols(cross(nodes.b, n))
        self.ok = dot(n, n) > 0.5
        self.mid = cols(nodes.mid)
        self.reach = np.ascontiguousarray(nodes.reach)
        self.cos_r, self.sin_r = np.cos(self.reach), np.sin(self.reach)
        self.err = pad(nodes.err) + _TINY
        self.cut = np.where(nodes.leaf, -np.inf, nodes.err)
        self.child = np.ascontiguousarray(nodes.child)


#: The :class:`_Table` of each node table (made once per table, kept while it lives).
_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _table(nodes: NodeArcs) -> _Table:
    got = _TABLES.get(nodes)
    if got is None:
        got = _TABLES[nodes] = _Table(nodes)
    return got


def exact_distances(c, cell, nodes: NodeArcs, node) -> np.ndarray:
    """Return the distances from ``c[cell]`` to the arcs of ``node``.

    :func:`~gloffset.geometry.sphere.arc_distance` bit for bit (the same operations on
    the same values, each in the same order), in chunks of :data:`_CHUNK` pairs, with
    each pair's distance to the line computed only where its foot falls on the arc and
    its distance to the ends only where it does not.
    """
    return _exact([np.ascontiguousarray(c[:, k]) for k in range(3)], cell, _table(nodes), node)


def _exact(cols, cell, ends: _Table, node) -> np.ndarray:
    """:func:`exact_distances` from the points' coordinate columns ``cols``."""
    out = np.empty(len(cell))
    for s in range(0, len(cell), _CHUNK):
        ci, ni = cell[s : s + _CHUNK], node[s : s + _CHUNK]
        out[s : s + _CHUNK] = _arc_distance([x.take(ci) for x in cols], ends, ni)
    return out


def end_distances(c, cell, v) -> np.ndarray:
    """Return the distances from ``c[cell]`` to the points ``v`` (one per pair).

    The bits :func:`exact_distances` gives an arc's end where a point's foot is off the
    arc (the arc's distance is then the lesser of its ends').
    """
    q = [np.ascontiguousarray(c[cell, k]) for k in range(3)]
    p = [v[:, k] for k in range(3)]
    dm = [q[k] - p[k] for k in range(3)]
    dp = [q[k] + p[k] for k in range(3)]
    return 2.0 * np.arctan2(np.sqrt(_dot3(dm, dm)), np.sqrt(_dot3(dp, dp)))


def _dot3(u, v, i=None):
    """Return ``u . v`` for columns ``u``, ``v`` (``v`` gathered at ``i``).

    Summed as :func:`~gloffset.geometry.sphere.dot` sums: ``(u0 v0 + u1 v1) + u2 v2``.
    """
    if i is None:
        return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
    out = u[0] * v[0].take(i)
    out += u[1] * v[1].take(i)
    out += u[2] * v[2].take(i)
    return out


def _arc_distance(p, ends: _Table, ni) -> np.ndarray:
    """Return the distances from points ``p`` (columns) to the arcs ``ni`` of ``ends``.

    :func:`~gloffset.geometry.sphere.arc_distance`'s, each branch on its own pairs (see
    :func:`exact_distances`).
    """
    inside = _dot3(p, ends.na, ni) >= 0.0
    inside &= _dot3(p, ends.bn, ni) >= 0.0
    inside &= ends.ok.take(ni)
    out = np.empty(len(ni))
    on = np.flatnonzero(inside)
    if len(on):
        q, j = [x.take(on) for x in p], ni.take(on)
        n = [x.take(j) for x in ends.n]
        pn = _dot3(q, n)
        foot = [q[k] - pn * n[k] for k in range(3)]
        out[on] = np.arctan2(np.abs(pn), np.sqrt(_dot3(foot, foot)))
    off = np.flatnonzero(~inside)
    if len(off):
        q, j = [x.take(off) for x in p], ni.take(off)
        to = []
        for e in (ends.a, ends.b):
            v = [x.take(j) for x in e]
            dm = [q[k] - v[k] for k in range(3)]
            dp = [q[k] + v[k] for k in range(3)]
            to.append(2.0 * np.arctan2(np.sqrt(_dot3(dm, dm)), np.sqrt(_dot3(dp, dp))))
        out[off] = np.minimum(to[0], to[1])
    return out


def _parts(f: Frontier):
    """Return ``f`` cut into parts of contiguous cells.

    Each part has at most :data:`_PART_CELLS` cells and about :data:`_PART_PAIRS` pairs
    (the pairs are sorted by cell).
    """
    k = len(f.cells)
    if k <= _PART_CELLS and len(f.pair_cell) <= _PART_PAIRS:
        yield f
        return
    before = np.searchsorted(f.pair_cell, np.arange(k))  # pairs before each cell
    part = np.maximum(before // _PART_PAIRS, np.arange(k) // _PART_CELLS)
    cuts = np.flatnonzero(np.r_[True, part[1:] != part[:-1]])
    at = np.r_[before[cuts], len(f.pair_cell)]
    for n, (a, b) in enumerate(zip(cuts, np.r_[cuts[1:], k])):
        yield f.part(int(a), int(b), int(at[n]), int(at[n + 1]))
