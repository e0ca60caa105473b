"""Entering a level directly (gloffset.raster.vector.scatter) gives what the hierarchy
reaches there."""

import numpy as np
import pytest

import gloffset
from gloffset.edges import CurveArcs
from gloffset.grids import Equirect, Tile
from gloffset.raster.driver import pooled
from gloffset.raster.vector.curves import classify_curves as classify
from gloffset.raster.vector.levels import CONTAINED, FRONTIER, OUTSIDE
from gloffset.raster.vector.scatter import PAIRS_PER_ARC, scatter, start_level

LINE_OVER_POLE = {
    "type": "LineString",
    "coordinates": [[170, 60], [-170, 70], [-100, 85], [80, 88]],
}
CASES = [
    ("Fiji", 0.02, Equirect(256, 128)),
    ("Fiji", 0.004, Equirect(200, 160, (170, -25, -170, -10))),  # across the antimeridian
    ("Russia", -0.01, Equirect(300, 200, (160, 55, -160, 75))),
    ("Antarctica", 0.03, Equirect(256, 128)),  # round the pole
    ("Antarctica", -0.02, Equirect(256, 96, (-180, -90, 180, -60))),
    ("Italy", 0.0, Equirect(240, 240, (6, 36, 19, 47.5))),
    ("Chile", 0.01, Tile(3, 2, 4, size=256)),  # web mercator
    (LINE_OVER_POLE, 0.02, Equirect(256, 256, (150, 50, -150, 90))),
    (LINE_OVER_POLE, 0.01, Equirect(320, 160)),
]


def _shape(world, what):
    return gloffset.read(world[what] if isinstance(what, str) else what)


@pytest.mark.parametrize("what, d, grid", CASES)
def test_every_start_level_gives_the_hierarchys_classes(world, what, d, grid):
    shape = _shape(world, what)
    last = grid.n_levels - 1
    ref, _, _ = classify(shape, d, grid)
    assert (ref == CONTAINED).any() and (ref == OUTSIDE).any()
    for level in range(0, last + 1):
        # the level itself: the same classes and frontier as the hierarchy's
        want, wf, _ = classify(shape, d, grid, stop_level=level)
        got, gf, _ = classify(shape, d, grid, stop_level=level, start=level)
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(gf.cells, wf.cells)
        np.testing.assert_array_equal(gf.status, wf.status)
        # and the output from there on
        out, _, _ = classify(shape, d, grid, start=level)
        np.testing.assert_array_equal(out, ref)


@pytest.mark.parametrize("what, d, grid", CASES[:4])
def test_candidate_lists_are_complete(world, what, d, grid):
    """Every arc within e + rho of a frontier cell's centre is on its list."""
    from gloffset.geometry.sphere import arc_distance

    shape = _shape(world, what)
    arcs = CurveArcs.from_shape(shape)
    level = grid.n_levels - 2
    _, f = scatter(shape, arcs, grid, d, level, final=False)
    assert len(f.cells)
    dist = arc_distance(f.centers[:, None], arcs.a[None], arcs.b[None], arcs.n[None])
    need = dist <= abs(d) + f.rho[:, None]
    have = np.zeros_like(need)
    have[f.pair_cell, f.pair_arc] = True
    assert not (need & ~have).any()
    assert np.all(np.diff(f.pair_cell) >= 0)


def test_pooled_levels_never_contradict_the_output(world):
    shape = _shape(world, "Fiji")
    grid = Equirect(512, 256)
    ref, _, _ = classify(shape, 0.02, grid)
    seen = []
    classify(shape, 0.02, grid, start=4, callback=lambda lev, c: seen.append((lev, c.copy())))
    assert [lev for lev, _ in seen] == list(range(grid.n_levels))
    for lev, c in seen:
        assert c.shape == grid.level_shape(lev)
        b = grid.block(lev)
        up = np.repeat(np.repeat(c, b, 0), b, 1)[: grid.height, : grid.width]
        assert not ((up == CONTAINED) & (ref != CONTAINED)).any()
        assert not ((up == OUTSIDE) & (ref != OUTSIDE)).any()
    assert (seen[0][1] == FRONTIER).any()


def test_pooled():
    c = np.array([[0, 0, 2], [0, 0, 2], [1, 2, 2]], dtype=np.uint8)
    np.testing.assert_array_equal(pooled(c), [[0, 2], [1, 2]])


def test_start_level_falls_back_for_large_distances(mexico_path):
    shape = gloffset.read(mexico_path)
    arcs = CurveArcs.from_shape(shape)
    grid = Equirect(2048, 1024)
    assert start_level(arcs, grid, 0.01, grid.n_levels - 1)[0] >= 3
    assert start_level(arcs, grid, 1.0, grid.n_levels - 1) == (None, None)
    assert PAIRS_PER_ARC > 0


def test_boxes_of_a_tile_are_its_arcs_pairs(mexico_path):
    """On a tile (a band of latitudes) the arcs beyond its rows have no box, every box
    holds cells, and the pairs are those of every cell and arc within the cap test."""
    from gloffset.geometry.caps import cap_within
    from gloffset.raster.vector.scatter import _plan, box_pairs

    shape = gloffset.read(mexico_path)
    arcs = CurveArcs.from_shape(shape)
    grid = Tile(4, 3, 6, size=256)  # the Gulf of Mexico: part of the arcs
    level = 1  # 64 x 64
    (lat, lon, _, _, row_reach), boxes = _plan(arcs, grid, 0.01, level)
    a_idx, j0, j1, i0, i1 = boxes
    assert 0 < len(np.unique(a_idx)) < len(arcs.a)
    assert np.all(j1 > j0) and np.all(i1 > i0)
    h, w = grid.level_shape(level)
    jj, ii, ai, cm = box_pairs(arcs, lat, lon, row_reach, boxes, w)
    got = set(zip((jj * w + ii).tolist(), ai.tolist()))
    j, i = np.divmod(np.arange(h * w), w)
    c = np.stack(
        [np.cos(lat[j]) * np.cos(lon[i]), np.cos(lat[j]) * np.sin(lon[i]), np.sin(lat[j])], -1
    )
    dots = c @ arcs.mid.T
    near = cap_within(dots, row_reach[j][:, None] + arcs.half[None])
    want = set(zip(*(x.tolist() for x in np.nonzero(near))))
    assert got == want and len(got) == len(jj)


def test_bad_start(world):
    shape = _shape(world, "Fiji")
    with pytest.raises(ValueError, match="start must be"):
        classify(shape, 0.01, Equirect(64, 32), start="fast")
    with pytest.raises(ValueError, match="start must be"):
        classify(shape, 0.01, Equirect(64, 32), start=99)


def test_a_refined_level_hands_over_its_dot_products_bit_for_bit():
    """``refine`` keeps each pair's ``c.m`` on the :class:`Frontier` it makes
    (``cm``), and ``cell_distances`` takes it instead of computing it again: the values
    are :func:`~gloffset.geometry.sphere.pair_dots`'s bits, so the distances and lower
    bounds are those of the level without it (South America's countries at 1:110m,
    refined whole and in parts of a few pairs each; ``subset`` and ``prune`` drop it)."""
    from conftest import named_countries

    from gloffset.geometry.sphere import pair_dots
    from gloffset.raster.vector import levels

    shape = named_countries("Brazil", "Argentina", "Chile", "Peru", "Bolivia", "Uruguay")
    arcs = CurveArcs.from_shape(shape)
    grid = Equirect(512, 256)
    e = 0.02
    f = levels.coarse(shape, arcs, grid, e)
    for parts in (False, True):
        if parts:  # refine in parts of a few pairs: the parts' cm are concatenated
            old = levels._REFINE_PAIRS
            levels._REFINE_PAIRS = 64
        try:
            g = levels.refine(f, grid, arcs, e, shape)
        finally:
            if parts:
                levels._REFINE_PAIRS = old
        assert g.cm is not None and len(g.cm) == len(g.pair_cell) > 500
        assert np.array_equal(g.cm, pair_dots(g.centers, g.pair_cell, arcs.mid, g.pair_arc))
        bare = levels.Frontier(
            g.level, g.cells, g.centers, g.rho, g.pair_cell, g.pair_arc, g.status
        )
        for a, b in zip(
            levels.cell_distances(g, arcs, lows=True), levels.cell_distances(bare, arcs, lows=True)
        ):
            assert np.array_equal(a, b)
        assert levels.subset(g, np.arange(0, len(g.cells), 2)).cm is None
        dist, _, low = levels.cell_distances(g, arcs, lows=True)
        assert levels.prune(g, low, dist, e).cm is None


def test_pairs_by_cell_packed_and_argsort_agree():
    # the candidates' sort: packed (cell, arc, index) values, or an argsort where they
    # do not fit 63 bits; both the order of (cell, arc) keys, from uint32 or int64 input
    from gloffset.raster.vector.scatter import _by_cell

    rng = np.random.default_rng(3)
    key = rng.choice(5000 * 700, size=20_000, replace=False)
    cell, ai = (key // 700).astype(np.uint32), (key % 700).astype(np.uint32)
    cm = rng.random(len(key))
    keep = np.flatnonzero(rng.random(len(key)) < 0.8)
    order = keep[np.lexsort((ai[keep], cell[keep]))]
    for cells in (5000, 1 << 40):  # the second one leaves no room: an argsort
        for c, a in ((cell, ai), (cell.astype(np.int64), ai.astype(np.int64))):
            got = _by_cell(c, a, cm, keep, cells, 700)
            for x, want in zip(got, (cell[order], ai[order], cm[order])):
                assert x.dtype != np.uint32
                np.testing.assert_array_equal(x, want)
