"""The entry level's box pairs from the compute shader (gloffset.raster.gpu.gpu_box_pairs)
are the numpy path's (gloffset.raster.vector.scatter.box_pairs): the same pairs, the same
float64 bits of c.m, and so the same level."""

from pathlib import Path

import numpy as np
import pytest

import gloffset
from gloffset.edges import CurveArcs
from gloffset.geometry.caps import cap_within
from gloffset.geometry.sphere import arcs_cross
from gloffset.gl.scatter_pass import ARC_MASK, NEAR, NEAR_UNSURE, UNSURE, scatter_pass
from gloffset.grids import Equirect, Tile
from gloffset.raster.gpu import GPU_MIN_PAIRS, gpu_box_pairs
from gloffset.raster.vector.scatter import _plan, box_pairs, scatter, start_level

DATA = Path(__file__).resolve().parent.parent / "data"
LINE_OVER_POLE = {
    "type": "LineString",
    "coordinates": [[170, 60], [-170, 70], [-100, 85], [80, 88]],
}
CASES = [
    ("Fiji", 0.004, Equirect(200, 160, (170, -25, -170, -10)), 4),  # across the antimeridian
    ("Antarctica", 0.03, Equirect(256, 128), 3),  # round the pole
    ("Chile", 0.01, Tile(3, 2, 4, size=256), 4),  # web mercator
    (LINE_OVER_POLE, 0.02, Equirect(256, 256, (150, 50, -150, 90)), 4),
    ("Italy", 0.0, Equirect(240, 240, (6, 36, 19, 47.5)), 4),
]


def _sorted(pairs, w, n):
    jj, ii, ai, cm = pairs[:4]
    order = np.argsort((jj * w + ii) * n + ai)
    return [x[order] for x in (jj, ii, ai)], cm[order]


def _same_pairs(arcs, grid, e, level):
    (lat, lon, _, _, row_reach), boxes = _plan(arcs, grid, e, level)
    w = grid.level_shape(level)[1]
    ref = box_pairs(arcs, lat, lon, row_reach, boxes, w)
    got = gpu_box_pairs(arcs, lat, lon, row_reach, boxes, w, min_pairs=0)
    (rj, ri, ra), rcm = _sorted(ref, w, len(arcs.a))
    (gj, gi, ga), gcm = _sorted(got, w, len(arcs.a))
    assert len(rj) == len(gj)
    for a, b in ((rj, gj), (ri, gi), (ra, ga)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(rcm.view(np.int64), gcm.view(np.int64))  # the bits
    return len(rj)


def test_reach_near_pi_is_the_hosts(world):
    # Fiji's caps plus a reach of 3.3 rad pass pi: cap_within clamps (every cell passes),
    # the host decides
    arcs = CurveArcs.from_shape(gloffset.read(world["Fiji"]))
    grid = Equirect(128, 64)
    level = grid.n_levels - 1
    assert _same_pairs(arcs, grid, 3.3, level) == 128 * 64 * len(arcs.a)


def test_mexico_10m_pairs_and_bits(mexico_path):
    # a finer level than the render at 127 km enters (level 2): more than 100,000 pairs
    arcs = CurveArcs.from_shape(gloffset.read(mexico_path))
    grid, e = Equirect(4096, 2048), 0.02
    assert _same_pairs(arcs, grid, e, 4) > 100_000


@pytest.mark.slow
def test_countries_10m_pairs_and_bits():
    # the render of all countries at 127 km, 4096 x 2048: its entry level's million pairs
    shape = gloffset.read(DATA / "countries_10m.geojson")
    grid, e = Equirect(4096, 2048), 127e3 / 6371008.8
    arcs = CurveArcs.from_shape(shape)
    level, _ = start_level(arcs, grid, e, grid.bin_level_for(e))
    assert level is not None
    assert _same_pairs(arcs, grid, e, level) > GPU_MIN_PAIRS  # a render takes the shader


@pytest.mark.parametrize("what, d, grid, level", CASES)
def test_pairs_and_bits_on_borders(world, what, d, grid, level):
    shape = gloffset.read(world[what] if isinstance(what, str) else what)
    arcs = CurveArcs.from_shape(shape)
    assert _same_pairs(arcs, grid, abs(d), min(level, grid.n_levels - 1)) > 0


def _one_arc_run(lat, lon, mid, half, reach, second, host=0.0, **kw):
    """scatter_pass().run of one arc's box over every cell of the rows ``lat`` and
    columns ``lon``, with the rows' ``reach`` and ``second`` reach."""
    rows = np.column_stack(
        [np.cos(lat), np.sin(lat), reach, second, np.cos(reach), np.sin(reach)]
        + [np.cos(second), np.sin(second)]
    )
    ring = np.zeros((1, 20))
    ring[0, 15:18] = mid
    h, w = len(lat), len(lon)
    return scatter_pass().run(
        np.array([[0, h, 0, w]]),
        np.array([0]),
        np.array([[np.cos(half), np.sin(half), half, host]]),
        rows,
        np.column_stack([np.cos(lon), np.sin(lon)]),
        w,
        h * w,
        ring,
        **kw,
    )


def test_shader_leaves_the_pairs_at_the_threshold_to_the_host():
    # each row's reach puts one cell's c.m on the threshold of the exact test (column 5
    # for the row's reach, 7 for the second): the shader leaves those to the host, and
    # decides every other cell as the exact test does
    lat, lon = np.linspace(-0.6, 0.7, 20), np.linspace(-0.8, 0.9, 30)
    mid, half = np.array([0.8, 0.36, 0.48]), 0.01
    cphi, sphi, clam, slam = np.cos(lat), np.sin(lat), np.cos(lon), np.sin(lon)
    cm = cphi[:, None] * (clam * mid[0] + slam * mid[1]) + sphi[:, None] * mid[2]
    reach = np.arccos(cm[:, 5]) - half
    near = np.arccos(cm[:, 7]) - half
    cell, word, got = _one_arc_run(lat, lon, mid, half, reach, near, cross=False, near=True)
    j, i = np.divmod(cell.astype(np.int64), len(lon))
    np.testing.assert_array_equal(got.view(np.int64), cm[j, i].view(np.int64))
    unsure = word >= UNSURE
    assert ((word & ARC_MASK) == 0).all()
    # every cell the exact test keeps comes back; those decided here, as it decides them
    exact = cap_within(cm, reach[:, None] + half)
    assert set(np.flatnonzero(exact)) <= set(cell.tolist())
    assert exact[j[~unsure], i[~unsure]].all()
    assert unsure[i == 5].all() and unsure.sum() < len(lat) + 5
    near_unsure = (word & NEAR_UNSURE) != 0
    assert near_unsure[i == 7].all() and near_unsure.sum() < len(lat) + 5
    sure = ~near_unsure
    want = cap_within(cm[j, i], near[j] + half)
    np.testing.assert_array_equal((word[sure] & NEAR) != 0, want[sure])
    assert 0 < want.sum() < len(want)


def test_no_pairs():
    shape = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [1, 1]]})
    arcs = CurveArcs.from_shape(shape)
    grid = Equirect(256, 128, (100, -40, 140, -10))  # far from the line
    (lat, lon, _, _, row_reach), boxes = _plan(arcs, grid, 0.001, 2)
    jj, ii, ai, cm, hit = gpu_box_pairs(
        arcs, lat, lon, row_reach, boxes, grid.level_shape(2)[1], min_pairs=0
    )
    assert len(jj) == len(ii) == len(ai) == len(cm) == len(hit) == 0


def _same_crossings(arcs, grid, e, level):
    """The shader's crossing flags are arcs_cross of every ring edge's pair (cell, arc),
    the cell's centre to its predecessor's (but the first cell)."""
    (lat, lon, _, _, row_reach), boxes = _plan(arcs, grid, e, level)
    w = grid.level_shape(level)[1]
    jj, ii, ai, cm, hit = gpu_box_pairs(arcs, lat, lon, row_reach, boxes, w, min_pairs=0)
    ring = (arcs.group[ai] >= 0) & ((jj > 0) | (ii > 0))
    assert not hit[~ring].any()
    j, i, a = jj[ring], ii[ring], ai[ring]
    qj, qi = np.where(i > 0, j, j - 1), np.where(i > 0, i - 1, 0)

    def centre(j, i):
        cphi, sphi, clam, slam = np.cos(lat[j]), np.sin(lat[j]), np.cos(lon[i]), np.sin(lon[i])
        return np.stack([cphi * clam, cphi * slam, sphi], axis=-1)

    want = arcs_cross(centre(j, i), centre(qj, qi), arcs.a[a], arcs.b[a], arcs.n[a])
    np.testing.assert_array_equal(hit[ring], want)
    return int(want.sum())


def test_crossings_on_mexico_10m(mexico_path):
    arcs = CurveArcs.from_shape(gloffset.read(mexico_path))
    assert _same_crossings(arcs, Equirect(4096, 2048), 0.02, 4) > 100


@pytest.mark.parametrize("what, d, grid, level", CASES)
def test_crossings_on_borders(world, what, d, grid, level):
    shape = gloffset.read(world[what] if isinstance(what, str) else what)
    arcs = CurveArcs.from_shape(shape)
    _same_crossings(arcs, grid, abs(d), min(level, grid.n_levels - 1))


@pytest.mark.parametrize("what, d, grid, level", CASES)
def test_scatter_gives_the_same_level_on_borders(world, what, d, grid, level):
    shape = gloffset.read(world[what] if isinstance(what, str) else what)
    assert_scatter_on_gpu_same(shape, grid, d, min(level, grid.n_levels - 1))


def test_scatter_gives_the_same_level(mexico_path):
    assert_scatter_on_gpu_same(gloffset.read(mexico_path), Equirect(2048, 1024), 0.02, 4)


def assert_scatter_on_gpu_same(shape, grid, d, level):
    """The level entered with the GPU's pairs equals the numpy one, array for array."""
    arcs = CurveArcs.from_shape(shape)
    ref_cls, ref = scatter(shape, arcs, grid, d, level, False)

    def on_gpu(*args, **kw):
        return gpu_box_pairs(*args, min_pairs=0, **kw)

    cls, f = scatter(shape, arcs, grid, d, level, False, pairs=on_gpu)
    np.testing.assert_array_equal(cls, ref_cls)
    for name in ("cells", "centers", "rho", "pair_cell", "pair_arc", "status"):
        np.testing.assert_array_equal(getattr(f, name), getattr(ref, name))


def test_a_box_larger_than_a_shader_loop():
    # llvmpipe ends a loop after 65535 iterations: a box of 90,000 cells comes back whole
    h = w = 300
    lat = np.linspace(1.5, -1.5, h)
    lon = np.linspace(-3.0, 3.0, w)
    reach = np.full(h, np.pi)  # every cell passes, the test left to the host (reach ~ pi)
    cell, ai, cm = _one_arc_run(lat, lon, np.array([1.0, 0.0, 0.0]), 0.0, reach, reach, 1.0)
    np.testing.assert_array_equal(np.sort(cell), np.arange(h * w))
    assert (ai == UNSURE).all()
    j, i = np.divmod(cell.astype(np.int64), w)
    np.testing.assert_array_equal(
        cm, np.cos(lat[j]) * (np.cos(lon[i]) * 1.0 + np.sin(lon[i]) * 0.0) + np.sin(lat[j]) * 0.0
    )


@pytest.mark.slow
def test_countries_render_is_the_numpy_paths(monkeypatch):
    import gloffset.raster.gpu as gpu

    shape = gloffset.read(DATA / "countries_10m.geojson")
    grid = Equirect(4096, 2048)
    on_gpu = gloffset.render(shape, 127e3, grid)
    monkeypatch.setattr(gpu, "gpu_box_pairs", box_pairs)
    np.testing.assert_array_equal(on_gpu, gloffset.render(shape, 127e3, grid))


def test_shader_constants_are_the_hosts():
    import re

    from gloffset.geometry.caps import COS_SLACK
    from gloffset.gl import scatter_pass as sp
    from gloffset.gl.shaders import load_source
    from gloffset.raster.gpu import GPU_PAIR_MARGIN

    src = load_source("scatter_pairs.comp")[0]

    def const(name):
        return re.search(rf"const\s+\w+\s+{name}\s*=\s*([0-9.eE+-x]+?)(?:LF|u)?;", src).group(1)

    assert float(const("MARGIN")) == GPU_PAIR_MARGIN
    assert float(const("COS_SLACK")) == COS_SLACK
    for name in ("UNSURE", "CROSS", "NEAR", "NEAR_UNSURE"):
        assert int(const(name), 16) == getattr(sp, name)


@pytest.mark.parametrize("what, d, grid, level", CASES)
def test_near_flags_on_borders(world, what, d, grid, level):
    # the second reach's tests (the candidate lists') are the numpy path's booleans
    shape = gloffset.read(world[what] if isinstance(what, str) else what)
    arcs = CurveArcs.from_shape(shape)
    level = min(level, grid.n_levels - 1)
    (lat, lon, rho, _, row_reach), boxes = _plan(arcs, grid, d, level)
    w = grid.level_shape(level)[1]
    ref = box_pairs(arcs, lat, lon, row_reach, boxes, w, near=d + rho)
    got = gpu_box_pairs(arcs, lat, lon, row_reach, boxes, w, min_pairs=0, near=d + rho)
    n = len(arcs.a)
    r, g = np.argsort(ref.cell * n + ref.arc), np.argsort(got.cell * n + got.arc)
    for name in ("cell", "arc", "near"):
        np.testing.assert_array_equal(getattr(ref, name)[r], getattr(got, name)[g])
    np.testing.assert_array_equal(ref.cm[r].view(np.int64), got.cm[g].view(np.int64))
    assert ref.near.any()
    if d == 0:  # the lists' reach (rho) below the rows' (the cell spacing): fewer pairs
        assert not ref.near.all()
