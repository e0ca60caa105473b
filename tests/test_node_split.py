"""The split of node lists (gloffset.raster.vector.node_levels._split): the subtrees whose
every node passes the cap test are split untested (or replaced by their leaves at once),
and the lists are, pair for pair, those of testing every node of every round, on real
borders (shared borders at 1:10m, Mexico, the antimeridian and the pole), to the leaves
and to ``KAPPA * rho``, with the leaves' runs of edges and without them."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import NEIGHBOURS, border_shapes

from gloffset.geometry.caps import cap_within
from gloffset.geometry.sphere import pair_dots
from gloffset.grids import Equirect
from gloffset.grids.mercator import TilePyramid
from gloffset.raster import driver
from gloffset.raster.vector import node_levels
from gloffset.raster.vector.curves import CurveCells
from gloffset.raster.vector.levels import children


@pytest.fixture(scope="module")
def shapes():
    return border_shapes(NEIGHBOURS)


def _tested(nodes, cell, node, c, reach, bound):
    """The split with every pair of every round tested (the plain rule)."""
    done_cell, done_node = [], []
    while len(cell):
        cm = pair_dots(c, cell, nodes.mid, node)
        near = cap_within(cm, reach[cell] + nodes.reach[node])
        cell, node = cell[near], node[near]
        bad = ~nodes.leaf[node] & (nodes.err[node] > bound[cell])
        done_cell.append(cell[~bad])
        done_node.append(node[~bad])
        split = np.flatnonzero(bad)
        cell = np.repeat(cell[split], 2)
        node = nodes.child[node[split]].ravel()
    cell, node = np.concatenate(done_cell), np.concatenate(done_node)
    order = np.argsort(cell * len(nodes.first) + nodes.first[node], kind="stable")
    return cell[order], node[order]


def _inputs(shape, d, grid, until):
    """``(cell, node, c, rho)`` of the children of every node level's kept cells, then
    every cell of the levels down to ``until`` with every node of the coarsest curve
    (whose subtrees reach far; levels 0 to 3)."""
    cells = CurveCells(shape, d, grid, nodes_until=until)
    for lev in driver.walk(cells, until):
        f = cells.kept(lev)
        if len(f.cells):
            _, _, c, rho, cell, node = children(f, grid)
            yield cell, node, c, rho
    top = node_levels.NodeArcs.from_shape(shape).top
    for lev in range(min(until, 3) + 1):
        h, w = grid.level_shape(lev)
        jj, ii = np.divmod(np.arange(h * w), w)
        c, rho = grid.centers(lev, jj, ii), grid.rho_at(lev, jj, ii)
        yield np.repeat(np.arange(h * w), len(top)), np.tile(top, h * w), c, rho


CASES = [
    ("neighbours", 0.01, lambda: TilePyramid(7), 5),
    ("seams", 0.02, lambda: TilePyramid(7), 5),
    ("seams", -0.01, lambda: Equirect(1200, 600), 5),
    ("mexico", 0.002, lambda: Equirect(2048, 1024), 6),
]


@pytest.mark.parametrize("runs", [True, False])
@pytest.mark.parametrize("name, d, grid, until", CASES)
def test_split_is_every_node_tested(shapes, name, d, grid, until, runs, monkeypatch):
    shape = shapes[name]
    nodes = node_levels.NodeArcs.from_shape(shape)
    assert nodes.runs  # the real borders' trees: every node a run of edges
    monkeypatch.setattr(nodes, "runs", runs)
    whole = 0
    real = node_levels._Near.__call__

    def count(self, cell, node):
        nonlocal whole
        near, every = real(self, cell, node)
        whole += int(every.sum())
        return near, every

    monkeypatch.setattr(node_levels._Near, "__call__", count)
    pairs = 0
    for cell, node, c, rho in _inputs(shape, d, grid(), until):
        for bound in (np.full(len(c), -1.0), node_levels.KAPPA * rho):
            reach = abs(d) + rho
            got = node_levels._split(nodes, cell, node, c, reach, bound)
            want = _tested(nodes, cell, node, c, reach, bound)
            assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
            assert got[0].dtype == want[0].dtype and got[1].dtype == want[1].dtype
            pairs += len(want[0])
    assert pairs > 10000 and whole > 1000  # subtrees were kept whole


def test_split_sees_a_subtree_kept_whole_wrongly(shapes, monkeypatch):
    """The comparison fails where a subtree is taken whole too eagerly."""
    shape = shapes["mexico"]
    nodes = node_levels.NodeArcs.from_shape(shape)
    monkeypatch.setattr(nodes, "spread", nodes.spread - 0.01)
    differs = False
    for cell, node, c, rho in _inputs(shape, 0.002, Equirect(2048, 1024), 4):
        bound = np.full(len(c), -1.0)
        got = node_levels._split(nodes, cell, node, c, 0.002 + rho, bound)
        want = _tested(nodes, cell, node, c, 0.002 + rho, bound)
        differs |= not np.array_equal(got[1], want[1])
    assert differs


def test_leaf_runs_hold_every_leaf_once(shapes):
    for shape in shapes.values():
        nodes = node_levels.NodeArcs.from_shape(shape)
        assert np.array_equal(np.sort(nodes.leaf_order), np.flatnonzero(nodes.leaf))
        top = nodes.top
        runs = [
            nodes.leaf_order[s : s + n]
            for s, n in zip(nodes.leaf_start[top], nodes.leaf_count[top])
        ]
        every = np.concatenate(runs)
        assert np.array_equal(np.sort(every), np.flatnonzero(nodes.leaf))
        for v in np.flatnonzero(~nodes.leaf)[::97]:  # each node's leaves: a run of edges
            s, n = nodes.leaf_start[v], nodes.leaf_count[v]
            assert np.array_equal(nodes.leaf_order[s : s + n], nodes.first[v] + np.arange(n))
