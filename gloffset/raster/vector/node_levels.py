"""Coarse levels whose candidate lists hold arcs of the multiresolution curve.

A coarse cell of a tile pyramid (a zoom-3 tile is 0.3 rad across) lies within reach
of thousands of the input's arcs, and refining those lists level by level costs about
as much as a deep zoom, although no coarse cell needs the fine arcs to be decided. The
multiresolution decomposition (paper Sec. 4.2, :func:`gloffset.vector.multires.full_decomposition`)
gives every run of original edges a coarse arc and a bound ``err`` on how far the run
strays from it (Sec. 4.3, Eq. 9; two-sided, a Frechet match: every point of the run is
within ``err`` of the coarse arc, :mod:`gloffset.raster.simplified`). Here a cell's
candidate list holds *nodes* of the decomposition's tree (:class:`NodeArcs`; the
original edges are its leaves, with the indices of :class:`~gloffset.edges.CurveArcs`),
each with ``err <= KAPPA * rho`` of the cell. The rules of
:mod:`gloffset.raster.vector.levels` then hold with these bounds:
candidate nodes whose caps, grown by ``err``, come within ``e + rho``; classes decided
with the bound ``rho + E`` (``E`` the largest ``err`` of the cell's nodes), so a cell is
only ever called contained or outside when every descendant pixel is; statuses those of
the original polygons, exactly. The last coarse level hands over with every node split
into original edges, so a pyramid's pixels are unchanged.

Cost: the coarse levels' lists follow the cells' size, not the input: a few hundred
nodes for a zoom-3 tile of every country instead of hundreds of thousands of arcs. The
derivation in full: ``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

import numpy as np

from ...edges import CurveArcs, component_status, inside_any, status_bits
from ...geometry.caps import cap_bounds, cap_within, cap_within_pairs, decide_between, pad
from ...geometry.sphere import angle, arc_distance, arcs_cross, column_dots
from ...memo import once_attr
from ...vector.multires import full_decomposition
from .child_pairs import columns, dots
from .levels import Frontier, cell_distances, children, decide, on_edge

__all__ = ["KAPPA", "NodeArcs", "enter", "refine", "classify_nodes"]

#: A coarse cell's candidate nodes have an error bound of at most this fraction of its rho.
KAPPA = 1.0 / 16.0
#: Slack (rad) by which an end must lie farther than a node's error bound from its arc
#: for the node's arc to stand for its run in a crossing test (distances are exact
#: float64, good to 1e-15 rad).
_FAR = 1e-12


class NodeArcs:
    """Every arc of the shape's decomposition tree (:class:`~gloffset.vector.multires.ArcTree`)
    as the table the level operations read (``a, b, n, mid, half, boundary, group,
    n_groups``, as :class:`~gloffset.edges.CurveArcs`), with each node's error bound
    ``err``, the cap ``reach = half + err`` that holds its run, and its children. Rows
    ``0 .. n - 1`` are the original edges, the rows of :class:`CurveArcs` bit for bit;
    ``top`` the nodes of the coarsest level, in the order of the curves."""

    def __init__(self, shape):
        dec = full_decomposition(shape)
        tree = dec.tree
        # the leaves' ends are the original edges' bits: so are their normals and caps
        t = CurveArcs.of(tree.a, tree.b, tree.boundary, tree.group, shape.n_groups)
        self.a, self.b, self.n, self.mid, self.half = t.a, t.b, t.n, t.mid, t.half
        self.boundary, self.group, self.n_groups = t.boundary, t.group, t.n_groups
        self.child = tree.child
        self.leaf = tree.child[:, 0] < 0
        self.err = np.where(np.isfinite(tree.e), tree.e, np.pi)
        self.err[self.leaf] = 0.0
        # a merged node whose arc has no direction is never used as itself
        self.err[~self.leaf & ~(np.abs(self.n).sum(axis=1) > 0)] = np.pi
        self.reach = self.half + pad(self.err)
        # each node's first original edge (its run's place along the curves)
        self.first = np.arange(len(tree.a))
        for k in range(1, int(tree.level.max(initial=0)) + 1):
            made = np.flatnonzero(tree.level == k)
            self.first[made] = self.first[tree.child[made, 0]]
        self.top = dec.level_nodes(dec.levels)
        self.spread = _spread(self, tree.level)
        self.leaf_start, self.leaf_count, self.leaf_order = _leaf_runs(self, tree.level)
        #: whether every node's leaves are the edges ``first .. first + leaf_count - 1``
        #: (no node spans a ring's start)
        merged = ~self.leaf
        left, right = self.child[merged, 0], self.child[merged, 1]
        self.runs = bool(np.all(self.first[right] == self.first[left] + self.leaf_count[left]))

    @classmethod
    def from_shape(cls, shape) -> NodeArcs:
        """The shape's node table (made once per shape and kept on it)."""
        return shape.derived.once("node_arcs", lambda: cls(shape))


def _spread(nodes: NodeArcs, level: np.ndarray) -> np.ndarray:
    """Per node ``v``, an upper bound on ``angle(mid_v, mid_u) - reach_u`` over the nodes
    ``u`` of its subtree (``v`` itself included): a point within ``R - spread_v`` of
    ``mid_v`` is within ``R + reach_u`` of every ``mid_u``. Made leaves up (the triangle
    inequality through each child), each step rounded up by 1e-14 rad (angles good to
    1e-15)."""
    out = -nodes.reach.copy()
    for k in range(1, int(level.max(initial=0)) + 1):
        made = np.flatnonzero(level == k)
        for j in (0, 1):
            w = nodes.child[made, j]
            via = angle(nodes.mid[made], nodes.mid[w]) + out[w] + 1e-14
            out[made] = np.maximum(out[made], via)
    return out


def _leaf_runs(nodes: NodeArcs, level: np.ndarray):
    """The leaves in the order of a walk of the tree (left child first), and each node's
    run of them: ``(start, count, order)``, ``order[start[v] : start[v] + count[v]]`` the
    leaves of ``v``'s subtree."""
    m, top = len(nodes.leaf), int(level.max(initial=0))
    count = nodes.leaf.astype(np.int64)
    for k in range(1, top + 1):
        made = np.flatnonzero(level == k)
        count[made] = count[nodes.child[made, 0]] + count[nodes.child[made, 1]]
    root = np.ones(m, dtype=bool)
    root[nodes.child[~nodes.leaf].ravel()] = False
    start = np.zeros(m, dtype=np.int64)
    roots = np.flatnonzero(root)
    start[roots] = np.cumsum(count[roots]) - count[roots]
    for k in range(top, 0, -1):
        made = np.flatnonzero(level == k)
        left, right = nodes.child[made, 0], nodes.child[made, 1]
        start[left] = start[made]
        start[right] = start[made] + count[left]
    order = np.empty(int(count[roots].sum()), dtype=np.int64)
    leaves = np.flatnonzero(nodes.leaf)
    order[start[leaves]] = leaves
    return start, count, order


def _columns(v: np.ndarray):
    return [np.ascontiguousarray(v[:, j]) for j in range(3)]


class _Near:
    """The cap test of :func:`_split`'s pairs, ``cap_within(c.m, reach[cell] +
    nodes.reach[node])`` with its per-node bounds made once, and the test that every node
    of the pair's subtree passes it (:func:`_spread`): ``c.m >= cos(reach[cell] - spread)
    + 1e-12``, far beyond the rounding of either (decided by per-node bounds from the
    least and greatest reach, by the pair's own reach between them)."""

    def __init__(self, nodes: NodeArcs, c, reach):
        self.nodes, self.reach = nodes, reach
        self.c = _columns(c)
        self.mid = columns(nodes)
        trig = once_attr(nodes, "_reach_trig", lambda: (np.cos(nodes.reach), np.sin(nodes.reach)))
        self.lo, self.hi = cap_bounds(reach, nodes.reach, trig)
        self.all_lo = _whole_table(nodes, reach.max())
        self.all_hi = _whole_table(nodes, reach.min())

    def __call__(self, cell, node):
        """``(near, whole)`` of the pairs: the test, and whether their whole subtree
        passes it (only where it passes itself)."""
        cm = column_dots(self.c, self.mid, cell, node)
        near = decide_between(
            cm,
            self.lo.take(node),
            self.hi.take(node),
            lambda u: cap_within(
                cm.take(u), self.reach.take(cell.take(u)) + self.nodes.reach.take(node.take(u))
            ),
        )
        whole = decide_between(
            cm,
            self.all_lo.take(node),
            self.all_hi.take(node),
            lambda u: (
                cm.take(u)
                >= _whole(self.reach.take(cell.take(u)) - self.nodes.spread.take(node.take(u)))
            ),
        )
        return near, whole & near


def _whole_table(nodes: NodeArcs, r: float) -> np.ndarray:
    """:func:`_whole` of ``r - spread`` for every node, from the spreads' cosines and
    sines kept on the table (``cos r cos s + sin r sin s``, within 1e-15 of the cosine,
    far inside the 1e-12)."""
    cs, ss = once_attr(nodes, "_spread_trig", lambda: (np.cos(nodes.spread), np.sin(nodes.spread)))
    r = float(r)
    x = r - nodes.spread
    out = np.cos(r) * cs + np.sin(r) * ss + 1e-12
    out[x >= np.pi] = -1.0 + 1e-12
    out[x < 0.0] = 2.0
    return out


def _whole(x):
    """The threshold on ``c.m`` above which ``c`` lies within ``x`` of a node's centre (by
    1e-12 beyond the rounding), 2 (never) for ``x < 0``."""
    return np.where(x < 0.0, 2.0, np.cos(np.minimum(x, np.pi)) + 1e-12)


def _split(nodes: NodeArcs, cell, node, c, reach, bound):
    """Pairs ``(cell, node)`` with every node whose ``err`` exceeds ``bound[cell]`` (or,
    with ``bound < 0``, every merged node) replaced by the two it was made of, and every
    pair whose grown cap lies farther than ``reach[cell]`` from the centre ``c[cell]``
    dropped; sorted by cell, each cell's nodes in the order of the curves (by their first
    original edge). Each round splits only the pairs left to split, and tests only those
    whose subtree may hold a node that fails (:class:`_Near`): the others are split
    untested (or, with ``bound < 0``, replaced by their leaves at once)."""
    if not len(cell):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    test = _Near(nodes, c, reach)
    leaves = bool(len(bound)) and bool((bound < 0).all())
    done: list = []
    whole: list = []
    sure_cell = sure_node = np.zeros(0, dtype=np.int64)
    while len(cell) or len(sure_cell):
        near, every = test(cell, node)
        if leaves:
            whole.append((cell[every], node[every]))
            near &= ~every
        else:
            sure_cell = np.concatenate([sure_cell, cell[every]])
            sure_node = np.concatenate([sure_node, node[every]])
            near &= ~every
        cell, node = cell[near], node[near]
        cell, node = _split_step(nodes, cell, node, bound, done)
        sure_cell, sure_node = _split_step(nodes, sure_cell, sure_node, bound, done)
    if leaves:
        return _leaf_pairs(nodes, done, whole)
    cell = np.concatenate([d[0] for d in done]) if done else np.zeros(0, dtype=np.int64)
    node = np.concatenate([d[1] for d in done]) if done else np.zeros(0, dtype=np.int64)
    # each cell's nodes are disjoint runs: (cell, first edge) is a unique key
    order = np.argsort(cell * len(nodes.first) + nodes.first[node], kind="stable")
    return cell[order], node[order]


def _split_step(nodes: NodeArcs, cell, node, bound, done):
    """One round's split: the pairs whose node is fine enough go to ``done``, the others
    are returned as the pairs of their two halves."""
    if not len(cell):
        return cell, node
    bad = ~nodes.leaf[node] & (nodes.err[node] > bound[cell])
    done.append((cell[~bad], node[~bad]))
    split = np.flatnonzero(bad)
    return np.repeat(cell[split], 2), nodes.child[node[split]].ravel()


def _leaf_pairs(nodes: NodeArcs, done, whole):
    """:func:`_split`'s pairs with every node a leaf: the leaves reached (``done``) and
    every leaf of the subtrees kept whole, sorted by cell and leaf (a leaf is its edge's
    index, unique in a cell's list). Where every subtree's leaves are a run of edges (no
    node spans a ring's start) the runs are sorted, not the leaves: each round's pairs come
    sorted by cell and first edge, and a stable sort merges the rounds."""
    parts = done + whole
    if not parts:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    cell = np.concatenate([p[0] for p in parts])
    node = np.concatenate([p[1] for p in parts])
    count = nodes.leaf_count.take(node)
    start = (nodes.first if nodes.runs else nodes.leaf_start).take(node)
    n = len(nodes.first)
    if nodes.runs:
        order = np.argsort(cell * n + start, kind="stable")
        cell, start, count = cell.take(order), start.take(order), count.take(order)
    leaf = np.arange(int(count.sum())) + np.repeat(start - (np.cumsum(count) - count), count)
    cell = np.repeat(cell, count)
    if nodes.runs:
        return cell, leaf
    key = np.sort(cell * n + nodes.leaf_order.take(leaf))
    cell = key // n
    return cell, key - cell * n


def enter(shape, nodes: NodeArcs, grid, e: float) -> Frontier:
    """All cells of level 0 with their candidate nodes (the coarsest curve, split to
    ``KAPPA * rho``) and their statuses (by crossings to the shape's reference points)."""
    h, w = grid.level_shape(0)
    jj, ii = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    cells = np.column_stack([jj.ravel(), ii.ravel()])
    c = grid.centers(0, cells[:, 0], cells[:, 1])
    rho = grid.rho_at(0, cells[:, 0], cells[:, 1])
    arcs = CurveArcs.from_shape(shape)
    status = status_bits(arcs.n_groups, len(c))
    if arcs.n_groups:
        status = component_status(shape, arcs, c)
    k = len(c)
    cell = np.repeat(np.arange(k), len(nodes.top))
    node = np.tile(nodes.top, k)
    cell, node = _split(nodes, cell, node, c, e + rho, KAPPA * rho)
    return Frontier(0, cells, c, rho, cell, node, status)


def refine(f: Frontier, grid, nodes: NodeArcs, e: float, shape, *, leaves: bool = False):
    """Children of the cells of ``f`` (all assumed frontier, lists of nodes) with their
    lists (nodes split to ``KAPPA * rho``, or with ``leaves`` to original edges: a
    :class:`Frontier` of :class:`CurveArcs` rows) and exact statuses."""
    lev = f.level + 1
    cells, parent, c, rho, cell, node = children(f, grid)
    pc = f.centers[parent]

    status = f.status[parent].copy()
    if nodes.n_groups:
        seg = angle(c, pc)
        ring = nodes.group[node] >= 0
        near = np.flatnonzero(ring)
        near = near[
            cap_within(
                dots(c, cell[near], columns(nodes), node[near]),
                seg[cell[near]] + nodes.reach[node[near]],
            )
        ]
        toggles, on = _crossings(nodes, c, pc, seg, cell[near], node[near])
        g = nodes.group[toggles[1]]
        np.bitwise_xor.at(status, (toggles[0], g >> 3), (1 << (g & 7)).astype(np.uint8))
        if on.any():  # a parent centre on a ring edge is no anchor: ask the reference points
            status[on] = component_status(shape, CurveArcs.from_shape(shape), c[on])

    bound = np.full(len(cells), -1.0) if leaves else KAPPA * rho
    cell, node = _split(nodes, cell, node, c, e + rho, bound)
    return Frontier(lev, cells, c, rho, cell, node, status)


def _crossings(nodes: NodeArcs, c, pc, seg, cell, node):
    """The original ring edges that cross the arcs ``c[cell] -> pc[cell]``, from the
    nodes near them: ``((cells, one node each of the crossing runs), on)``, the node
    standing for a run of which an odd number of edges cross, and ``on`` which cells'
    parent centre lies on one of the edges (see the module notes)."""
    hit_cell, hit_node = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)]
    on = np.zeros(len(c), dtype=bool)
    while len(cell):
        a, b, n = nodes.a[node], nodes.b[node], nodes.n[node]
        p, q = c[cell], pc[cell]
        leaf = nodes.leaf[node]
        err = nodes.err[node]
        sure = leaf.copy()
        m = np.flatnonzero(~leaf)
        if len(m):
            lim = err[m] + _FAR
            sure[m] = (arc_distance(p[m], a[m], b[m], n[m]) > lim) & (
                arc_distance(q[m], a[m], b[m], n[m]) > lim
            )
        s = np.flatnonzero(sure)
        cr = arcs_cross(p[s], q[s], a[s], b[s], n[s])
        hit_cell.append(cell[s[cr]])
        hit_node.append(node[s[cr]])
        lf = s[leaf[s]]  # the guard of levels.refine: a parent centre on an edge
        on[cell[lf[on_edge(q[lf], nodes, node[lf])]]] = True
        # the others: their halves, where they come near the arc
        u = np.flatnonzero(~sure)
        cell = np.repeat(cell[u], 2)
        node = nodes.child[node[u]].ravel()
        keep = cap_within_pairs(dots(c, cell, columns(nodes), node), seg, cell, nodes.reach, node)
        cell, node = cell[keep], node[keep]
    return (np.concatenate(hit_cell), np.concatenate(hit_node)), on


def classify_nodes(
    f: Frontier, nodes: NodeArcs, rho_decide, d: float
) -> tuple[np.ndarray, np.ndarray]:
    """Classes and distances (to the nearest candidate node) of the cells of ``f`` (lists
    of nodes), decided with the bound ``rho_decide`` widened by the largest error bound
    of each cell's nodes."""
    dist, dring = cell_distances(f, nodes)
    worst = np.zeros(len(f.cells))
    if len(f.pair_cell):
        np.maximum.at(worst, f.pair_cell, nodes.err[f.pair_arc])
    inside = inside_any(f.status)
    return decide(dist, dring, inside, rho_decide + pad(worst), d, final=False), dist
