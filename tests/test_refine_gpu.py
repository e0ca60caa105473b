"""A refined level's pairs from the compute shader (gloffset.raster.gpu.gpu_refine_pairs,
shaders/refine_pairs.comp) are the numpy path's (gloffset.raster.vector.levels._refine with
child_pairs.slot_pairs): the same cells, lists, float64 bits of c.m and statuses, on real
borders (shared borders at 1:10m, Mexico, the antimeridian and the pole), on a tile
pyramid's grid and on lon/lat grids whose odd level sizes leave parents without children;
and a tile pyramid that refines on the GL context writes the same tiles."""

from __future__ import annotations

import functools
import sqlite3

import numpy as np
import pytest
from conftest import LEVEL_CASES, NEIGHBOURS, border_shapes, level_grid, same_bits

import gloffset
from gloffset.edges import CurveArcs
from gloffset.gl import refine_pass as refine_pass_module
from gloffset.grids import Equirect
from gloffset.grids.mercator import TilePyramid
from gloffset.raster import driver
from gloffset.raster import gpu as raster_gpu
from gloffset.raster.gpu import gpu_refine_pairs
from gloffset.raster.vector import levels
from gloffset.raster.vector.child_pairs import child_slots, slot_pairs
from gloffset.raster.vector.curves import CurveCells

NAMES = ("cells", "centers", "rho", "pair_cell", "pair_arc", "status", "cm")
ON_GPU = functools.partial(gpu_refine_pairs, min_pairs=0)


@pytest.fixture(scope="module")
def shapes():
    return border_shapes(NEIGHBOURS)


def _compare(f, grid, arcs, e, shape):
    want = levels._refine(f, grid, arcs, e, shape)
    got = levels._refine(f, grid, arcs, e, shape, ON_GPU)
    assert got is not None
    for k in NAMES:
        assert same_bits(getattr(got, k), getattr(want, k)), (f.level, k)
    return got


@pytest.mark.parametrize("name, d, grid", LEVEL_CASES)
def test_refined_levels_are_numpys(shapes, name, d, grid):
    shape, grid = shapes[name], level_grid(grid)
    cells = CurveCells(shape, d, grid)
    compared = toggled = 0
    for lev in driver.walk(cells, grid.n_levels - 2):
        f = cells.kept(lev)
        if len(f.cells) == 0:
            continue
        got = _compare(f, grid, cells.arcs, abs(d), shape)
        compared += len(got.pair_cell)
        # the statuses changed from the parents' by crossings: the shader's list is used
        parent = child_slots(f.cells, grid, f.level + 1)[1]
        toggled += int((got.status != f.status[parent]).any(axis=1).sum())
    assert compared > 1000
    assert toggled > 0


def _raw(f, grid, arcs, e):
    """gpu_refine_pairs' answer for the children of ``f``."""
    lev = f.level + 1
    cells, parent, slot = child_slots(f.cells, grid, lev)
    c = grid.centers(lev, cells[:, 0], cells[:, 1])
    rho = grid.rho_at(lev, cells[:, 0], cells[:, 1])
    seg = levels.angle(c, f.centers[parent])
    return ON_GPU(f, arcs, c, slot, e + rho, seg)


def test_crossings_are_numpys(shapes):
    """The crossings the shader lists are those of arcs_cross over the pairs near each
    child's segment to its parent (numpy's toggles), as sets."""
    shape, grid, d = shapes["neighbours"], TilePyramid(7), 0.01
    cells = CurveCells(shape, d, grid)
    arcs = cells.arcs
    seen = 0
    for lev in driver.walk(cells, 5):
        f = cells.kept(lev)
        if not len(f.cells):
            continue
        lv = f.level + 1
        kids, parent, slot = child_slots(f.cells, grid, lv)
        c = grid.centers(lv, kids[:, 0], kids[:, 1])
        rho = grid.rho_at(lv, kids[:, 0], kids[:, 1])
        seg = levels.angle(c, f.centers[parent])
        _, _, _, (pc, pp, pa) = slot_pairs(f.pair_cell, f.pair_arc, arcs, c, slot, d + rho, seg)
        cr = levels.arcs_cross(c[pc], f.centers[pp], arcs.a[pa], arcs.b[pa], arcs.n[pa])
        want = set(zip(pc[cr].tolist(), pa[cr].tolist()))
        got = ON_GPU(f, arcs, c, slot, d + rho, seg)
        assert set(zip(got[3][0].tolist(), got[3][1].tolist())) == want
        assert np.array_equal(got[4], levels._on_ring(f, arcs))
        seen += len(want)
    assert seen > 0


def test_parent_centres_on_a_ring_edge():
    """A square whose corners are cell centres of a level: the parents there lie on two
    edges each (the on-edge list), and the level is numpy's."""
    grid = Equirect(256, 128)
    lev = 1  # 32 x 64 cells, refined to the 64 x 128 of level 2
    rows, cols = np.array([10, 10, 14, 14]), np.array([30, 36, 36, 30])
    lon = np.degrees(grid.cell_lon(lev, cols))
    lat = np.degrees(grid.cell_lat(lev, rows))
    ring = [[float(x), float(y)] for x, y in zip(lon, lat)]
    shape = gloffset.read({"type": "Polygon", "coordinates": [ring + [ring[0]]]})
    cells = CurveCells(shape, 0.05, grid)
    arcs = cells.arcs
    f = [cells.kept(lv) for lv in driver.walk(cells, lev)][-1]
    assert f.level == lev
    on = levels._on_ring(f, arcs)
    assert on.sum() >= 4  # the corners (and the cells on the edges' great circles)
    got = _raw(f, grid, arcs, 0.05)
    assert np.array_equal(got[4], on)
    _compare(f, grid, arcs, 0.05, shape)


def test_reach_near_pi_is_the_hosts(world):
    """Caps plus a reach of 3.3 rad pass pi (cap_within clamps there): every pair is the
    host's exact test, and the level is numpy's."""
    shape = gloffset.read(world["Fiji"])
    grid, d = Equirect(64, 32), 3.3
    arcs = CurveArcs.from_shape(shape)
    f = levels.coarse(shape, arcs, grid, d)  # every cell of level 0, every arc
    assert len(f.pair_cell) == len(f.cells) * len(arcs.a)
    got = _compare(f, grid, arcs, d, shape)
    assert len(got.pair_cell) == 4 * len(f.pair_cell)


def test_a_list_past_its_room_leaves_the_level_to_numpy(shapes, monkeypatch):
    """Crossings beyond the list's room: the pass says so and refine takes numpy's path."""
    shape, grid, d = shapes["neighbours"], TilePyramid(7), 0.01
    cells = CurveCells(shape, d, grid)
    fs = [cells.kept(lev) for lev in driver.walk(cells, 5)]
    f = fs[-1]
    monkeypatch.setattr(refine_pass_module, "TOGGLE_ROOM", 0)
    assert _raw(f, grid, cells.arcs, d) is None
    got = levels.refine(f, grid, cells.arcs, d, shape, pairs=ON_GPU)
    want = levels._refine(f, grid, cells.arcs, d, shape)
    for k in NAMES:
        assert same_bits(getattr(got, k), getattr(want, k)), k


def _tiles(path):
    con = sqlite3.connect(path)
    try:
        rows = con.execute("select zoom_level, tile_column, tile_row, tile_data from tiles")
        return {(z, x, y): bytes(t) for z, x, y, t in rows}
    finally:
        con.close()


def test_pyramid_tiles_are_numpys(mexico_path, tmp_path, monkeypatch):
    """A pyramid of Mexico whose refined levels take the shader (every level, whatever its
    pairs) writes the tiles of one that refines in numpy, byte for byte."""
    shape = gloffset.read(mexico_path)
    ran = []
    real = refine_pass_module.RefinePass.run

    def counted(self, *args):
        ran.append(len(args[1]))
        return real(self, *args)

    monkeypatch.setattr(raster_gpu, "GPU_MIN_REFINE", 0)
    monkeypatch.setattr(refine_pass_module.RefinePass, "run", counted)
    gloffset.tiles.pyramid(shape, 100e3, "0-6", tmp_path / "gpu.mbtiles")
    assert len(ran) > 0 and sum(ran) > 10_000
    monkeypatch.setattr(raster_gpu, "GPU_MIN_REFINE", 1 << 62)
    gloffset.tiles.pyramid(shape, 100e3, "0-6", tmp_path / "numpy.mbtiles")
    a, b = _tiles(tmp_path / "gpu.mbtiles"), _tiles(tmp_path / "numpy.mbtiles")
    assert len(a) > 40 and a == b


def test_the_comparison_sees_a_wrong_pair(shapes, monkeypatch):
    """The comparison fails where the host's exact test of the unsure pairs is wrong."""
    shape, grid, d = shapes["seams"], Equirect(64, 32), 3.3
    arcs = CurveArcs.from_shape(shape)
    f = levels.coarse(shape, arcs, grid, d)
    monkeypatch.setattr(raster_gpu, "cap_within", lambda cm, reach: cm > 2.0)
    got = levels._refine(f, grid, arcs, d, shape, ON_GPU)
    want = levels._refine(f, grid, arcs, d, shape)
    assert got is not None and len(got.pair_arc) != len(want.pair_arc)


def test_arcs_table_is_shared():
    """The arcs' terms are made once per set of arcs (a read-only table the pass uploads
    once)."""
    shape = gloffset.read({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 0]]]})
    arcs = CurveArcs.from_shape(shape)
    a = raster_gpu._refine_terms(arcs)
    assert a is raster_gpu._refine_terms(arcs) and not a.flags.writeable
    np.testing.assert_array_equal(a[:, :3], arcs.mid)
    np.testing.assert_array_equal(a[:, 8:11], arcs.n)
