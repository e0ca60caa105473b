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
from ...geometry.caps import cap_within, cap_within_pairs, pad
from ...geometry.sphere import angle, arc_distance, arcs_cross, pair_dots
from ...vector.multires import full_decomposition
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

    @classmethod
    def from_shape(cls, shape) -> NodeArcs:
        """The shape's node table (made once per shape and kept on it)."""
        return shape.derived.once("node_arcs", lambda: cls(shape))


def _split(nodes: NodeArcs, cell, node, c, reach, bound):
    """Pairs ``(cell, node)`` with every node whose ``err`` exceeds ``bound[cell]`` (or,
    with ``bound < 0``, every merged node) replaced by the two it was made of, and every
    pair whose grown cap lies farther than ``reach[cell]`` from the centre ``c[cell]``
    dropped; sorted by cell, each cell's nodes in the order of the curves (by their first
    original edge). Each round splits only the pairs left to split."""
    done_cell, done_node = [], []
    while len(cell):
        near = cap_within_pairs(pair_dots(c, cell, nodes.mid, node), reach, cell, nodes.reach, node)
        cell, node = cell[near], node[near]
        bad = ~nodes.leaf[node] & (nodes.err[node] > bound[cell])
        done_cell.append(cell[~bad])
        done_node.append(node[~bad])
        split = np.flatnonzero(bad)
        cell = np.repeat(cell[split], 2)
        node = nodes.child[node[split]].ravel()
    cell = np.concatenate(done_cell) if done_cell else np.zeros(0, dtype=np.int64)
    node = np.concatenate(done_node) if done_node else np.zeros(0, dtype=np.int64)
    # each round's pairs come sorted: a stable sort merges the rounds
    order = np.argsort(cell * len(nodes.first) + nodes.first[node], kind="stable")
    return cell[order], node[order]


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
                pair_dots(c, cell[near], nodes.mid, node[near]),
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
        keep = cap_within_pairs(pair_dots(c, cell, nodes.mid, node), seg, cell, nodes.reach, node)
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
