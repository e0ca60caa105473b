"""Coarse levels whose candidate lists hold arcs of the multiresolution curve
(gloffset.raster.vector.node_levels): exact statuses, classes never decided otherwise than by
the original arcs, the same pixels below the hand-over, on real borders."""

from __future__ import annotations

import sqlite3

import conftest
import numpy as np
import pytest
from conftest import border_shapes

from gloffset.edges import CurveArcs, component_status
from gloffset.grids.mercator import TilePyramid
from gloffset.raster import driver
from gloffset.raster.driver import FRONTIER
from gloffset.raster.vector import node_levels
from gloffset.raster.vector.curves import CurveCells
from gloffset.tiles.tiling import driver as tl

#: France's neighbours and theirs
NEIGHBOURS = conftest.NEIGHBOURS | {"Netherlands", "Austria", "Czechia", "Poland", "Croatia"}
NEIGHBOURS |= {"Denmark"}


@pytest.fixture(scope="module")
def shapes():
    return border_shapes(NEIGHBOURS)


CASES = [
    ("neighbours", 0.01),
    ("neighbours", -0.004),
    ("seams", 0.02),
    ("seams", -0.01),
    ("mexico", 0.002),
]


def _levels(cells, stop):
    """Every level's Level and dense classes, coarse to fine."""
    dense = {}
    levs = []
    for lev in driver.walk(cells, stop):
        levs.append(lev)
    driver.classes_of_level(cells, stop, callback=lambda k, c: dense.__setitem__(k, c.copy()))
    return levs, dense


@pytest.mark.parametrize("name, d", CASES)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_node_levels_decide_as_the_original_arcs(shapes, name, d):
    """Down to the hand-over, every cell the node lists decide has the class the
    original arcs give it, and every status is the exact one (crossings to the
    reference points); below it, the pixels are those of the original arcs."""
    shape = shapes[name]
    grid = TilePyramid(7)  # levels 0..7: a 128 x 128 world at the last
    until = 4
    exact = CurveCells(shape, d, grid)
    nodes = CurveCells(shape, d, grid, nodes_until=until)
    _, want = _levels(exact, grid.n_levels - 1)
    levs, got = _levels(nodes, grid.n_levels - 1)
    arcs = CurveArcs.from_shape(shape)
    node_arcs = node_levels.NodeArcs.from_shape(shape)
    decided_by_nodes = 0
    for lev in levs:
        f = lev.state
        if lev.level <= until:
            # lists of nodes, each within KAPPA rho of its cell
            err = node_arcs.err[f.pair_arc]
            assert np.all(err <= node_levels.KAPPA * f.rho[f.pair_cell])
            sure = got[lev.level] != FRONTIER
            assert np.array_equal(got[lev.level][sure], want[lev.level][sure]), lev.level
            decided_by_nodes += int((lev.cls != FRONTIER).sum())
        else:
            assert f.pair_arc.max(initial=0) < len(arcs.a)  # original arcs only
        if arcs.n_groups and len(f.cells):
            assert np.array_equal(f.status, component_status(shape, arcs, f.centers)), lev.level
    assert decided_by_nodes > 0
    assert np.array_equal(got[grid.n_levels - 1], want[grid.n_levels - 1])


def test_leaves_are_the_original_arcs(shapes):
    for shape in shapes.values():
        arcs = CurveArcs.from_shape(shape)
        nodes = node_levels.NodeArcs.from_shape(shape)
        n = len(arcs.a)
        for k in ("a", "b", "n", "mid", "half", "boundary", "group"):
            assert np.array_equal(getattr(nodes, k)[:n], getattr(arcs, k)), k
        assert np.all(nodes.leaf[:n]) and not np.any(nodes.leaf[n:])
        assert np.all(nodes.err[:n] == 0.0) and np.all(nodes.err[n:] >= 0.0)


def test_crossings_of_a_run_need_both_ends_away_from_its_node(shapes, monkeypatch):
    """The node's arc stands for its run in a crossing test only with both ends farther
    than its error bound: with that check every status is exact, without it (every
    node's arc taken for its run) statuses go wrong. Coarser nodes (a larger KAPPA) make
    more cells meet the case."""
    shape = shapes["neighbours"]
    grid = TilePyramid(9)
    arcs = CurveArcs.from_shape(shape)
    monkeypatch.setattr(node_levels, "KAPPA", 0.25)

    def wrong():
        n = 0
        for lev in driver.walk(CurveCells(shape, 0.01, grid, nodes_until=8), 8):
            f = lev.state
            n += int(np.any(f.status != component_status(shape, arcs, f.centers), axis=1).sum())
        return n

    assert wrong() == 0
    monkeypatch.setattr(node_levels, "_FAR", -10.0)
    assert wrong() > 0


def _tiles(path):
    with sqlite3.connect(path) as con:
        return sorted(con.execute("SELECT zoom_level, tile_column, tile_row, tile_data FROM tiles"))


@pytest.mark.parametrize(
    "name, d, zooms",
    [pytest.param("neighbours", 60e3, "0-6", marks=pytest.mark.slow), ("seams", -80e3, "1-5")],
)
def test_pyramid_tiles_with_and_without_node_levels(tmp_path, shapes, monkeypatch, name, d, zooms):
    """A pyramid whose coarse zooms are classified from the multiresolution curve writes
    the tiles of one classified from the original arcs, byte for byte."""
    shape = shapes[name]
    levels = []
    refine = node_levels.refine

    def counting(f, *args, **kw):
        levels.append(f.level)
        return refine(f, *args, **kw)

    monkeypatch.setattr(node_levels, "refine", counting)
    a = tl.pyramid(shape, d, zooms, tmp_path / "a.mbtiles", size=64)
    assert levels and min(levels) == 0  # the coarse levels were those of the nodes
    orig = tl.CurveCells

    def without(*args, nodes_until=None, **kw):
        return orig(*args, **kw)

    monkeypatch.setattr(tl, "CurveCells", without)
    b = tl.pyramid(shape, d, zooms, tmp_path / "b.mbtiles", size=64)
    assert _tiles(tmp_path / "a.mbtiles") == _tiles(tmp_path / "b.mbtiles")
    assert a.written == b.written and a.rendered >= b.rendered


@pytest.mark.parametrize("name, d", [("neighbours", 0.01), ("seams", -0.01)])
def test_refine_in_parts_of_rows_is_refine_at_once(shapes, monkeypatch, name, d):
    """levels.refine refines a large frontier in parts of whole rows of parents: the
    children, their lists and statuses are those of one refine of all of them."""
    from gloffset.raster.vector import levels

    shape = shapes[name]
    grid = TilePyramid(9)
    cells = CurveCells(shape, d, grid)
    f = cells.kept(list(driver.walk(cells, 6))[-1])
    arcs = cells.arcs
    whole = levels._refine(f, grid, arcs, abs(d), shape)
    monkeypatch.setattr(levels, "_REFINE_PAIRS", 97)  # many parts, rows of every size
    parts = levels.refine(f, grid, arcs, abs(d), shape)
    assert len(f.pair_cell) > 20 * 97
    for k in ("cells", "centers", "rho", "pair_cell", "pair_arc", "status"):
        assert np.array_equal(getattr(parts, k), getattr(whole, k)), k
    assert parts.level == whole.level == 7
