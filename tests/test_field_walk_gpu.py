"""The distance field's walk on the GPU (``shaders/field_walk.comp``): on real borders every
pixel's nearest arc is in its cell's GPU list, the fields have the CPU's bits, and a
broken bound loses arcs; the float32 ``asin`` within its stated bound."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import DATA, named_countries

import gloffset
from gloffset.gl import walk_pass
from gloffset.grids import Cube, Equirect, Tile
from gloffset.raster.fields import gpu as field_gpu
from gloffset.raster.fields.gpu import SHIFT, _Lists
from gloffset.raster.fields.walk import exact_distances
from gloffset.raster.vector.node_levels import NodeArcs


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


@pytest.fixture(scope="module")
def edges():
    """Fiji and Russia (across the antimeridian) and Antarctica (round the pole), 1:110m."""
    return named_countries("Fiji", "Russia", "Antarctica")


@pytest.fixture(scope="module")
def world():
    return gloffset.read(DATA / "world_110m.geojson")


def pixel_nearest(lists: _Lists, nodes: NodeArcs, grid, shift: int):
    """Each output pixel's least exact distance over its cell's list, and the arc that
    has it (-1 where the list is empty)."""
    last = grid.n_levels - 1
    h, w = grid.level_shape(last)
    jj, ii = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    c = grid.centers(last, jj.ravel(), ii.ravel())
    cell = ((jj >> shift) * lists.shape[1] + (ii >> shift)).ravel()
    k = lists.count[cell]
    pix = np.repeat(np.arange(len(c)), k)
    at = np.repeat(lists.start[cell] - (np.cumsum(k) - k), k) + np.arange(int(k.sum()))
    arc = lists.node[at]
    d = exact_distances(c, pix, nodes, arc)
    best = np.full(len(c), np.inf)
    np.minimum.at(best, pix, d)
    win = np.full(len(c), -1)
    hit = np.flatnonzero(d == best[pix])
    win[pix[hit]] = arc[hit]
    return best, win


def _check(shape, grid, m=math.inf):
    """Return the pixels within ``m`` whose CPU-nearest arc the GPU lists lack."""
    nodes = NodeArcs.from_shape(shape)
    last = grid.n_levels - 1
    shift = min(SHIFT, last)
    cpu = _Lists(nodes, grid, m, last - shift, walk="cpu")
    gpu = _Lists(nodes, grid, m, last - shift, walk="gpu")
    assert nodes.leaf[gpu.node].all()  # original edges only
    want, arc = pixel_nearest(cpu, nodes, grid, shift)
    got, _ = pixel_nearest(gpu, nodes, grid, shift)
    asked = np.flatnonzero(want <= m)
    assert len(asked) > 1000
    # the CPU's nearest arc of each pixel is in its cell's GPU list
    h, w = grid.level_shape(last)
    cell = ((asked // w) >> shift) * gpu.shape[1] + ((asked % w) >> shift)
    pairs = set(zip(np.repeat(np.arange(len(gpu.count)), gpu.count).tolist(), gpu.node.tolist()))
    missing = [
        p
        for p, (cl, a) in zip(asked, zip(cell.tolist(), arc[asked].tolist()))
        if (cl, a) not in pairs
    ]
    # and the least distance over the GPU list is the CPU's, bit for bit
    assert (got[asked] == want[asked]).all() or missing
    return missing, cpu, gpu


CASES = [
    ("mexico", Tile(5, 6, 13), math.inf),  # the west coast, z5
    ("mexico", Tile(10, 212, 451), math.inf),  # Puerto Vallarta, z10
    ("mexico", Equirect(500, 250, (-120, 10, -80, 30)), 200e3 / gloffset.EARTH_RADIUS),
    ("edges", Equirect(360, 180), math.inf),  # Fiji across the antimeridian
    ("edges", Equirect(256, 256, (150, -90, -150, -30)), math.inf),  # Antarctica, the pole
    ("world", Equirect(512, 256), math.inf),  # every country
]


@pytest.mark.parametrize(
    "which, grid, m", CASES, ids=["z5", "z10", "clamped", "fiji", "pole", "world"]
)
def test_every_nearest_arc_is_in_its_cells_gpu_list(request, which, grid, m):
    missing, _, _ = _check(request.getfixturevalue(which), grid, m)
    assert not missing, f"{len(missing)} pixels' nearest arcs missing, e.g. {missing[:3]}"


@pytest.mark.slow  # the 1:10m countries' node table alone takes a while
def test_cells_with_thousands_of_arcs():
    """Cells of a cube face of 96 pixels (0.05 rad) over 1:10m coasts, thousands of arcs
    each: the walk's steps far beyond 65535 (llvmpipe silently ends longer loops; the
    shader counts its steps and hands such levels to the float64 walk)."""
    shape = gloffset.read(DATA / "countries_10m.geojson")
    face = Cube(96).faces[4]
    missing, _, gpu = _check(shape, face, 300e3 / gloffset.EARTH_RADIUS)
    assert not missing and gpu.count.max() > 2000


def test_a_step_limit_hands_the_level_to_the_float64_walk(mexico, monkeypatch):
    nodes = NodeArcs.from_shape(mexico)
    grid = Tile(5, 6, 13)
    monkeypatch.setattr(walk_pass.walk_pass(), "max_steps", 100)
    from gloffset.raster.fields.lists import gpu_lists

    assert gpu_lists(nodes, grid, math.inf, 0) is None
    got = _Lists(nodes, grid, math.inf, 0, walk="gpu")
    want = _Lists(nodes, grid, math.inf, 0, walk="cpu")
    assert np.array_equal(got.node, want.node)


def test_a_broken_bound_loses_nearest_arcs(mexico, monkeypatch):
    """The slack turned against the lists (every lower bound raised by 3e-3 rad, about
    half the cells' reach): pixels' nearest arcs go missing, so the test above
    would catch a bound that is too tight."""
    monkeypatch.setattr(walk_pass, "SUM_ERR", -3e-3)
    missing, _, _ = _check(mexico, Tile(5, 6, 13))
    assert len(missing) > 10


@pytest.mark.parametrize(
    "which, grid, kw",
    [
        ("mexico", Tile(5, 6, 13), {"radius": 1.0}),
        ("mexico", Equirect(300, 170, (-118, 14, -86, 33)), {"max_distance": 200e3}),
        ("edges", Equirect(360, 180), {}),
        ("mexico", Tile(8, 53, 103), {"radius": 1.0}),  # deep: the dominance test cuts
    ],
    ids=["z5", "clamped", "fiji", "deep"],
)
def test_fields_with_the_gpu_walk_have_the_cpu_bits(request, which, grid, kw, monkeypatch):
    shape = request.getfixturevalue(which)
    want = gloffset.distance_field(shape, grid, backend="cpu", **kw).values
    monkeypatch.setattr(field_gpu, "WALK", "gpu")
    calls = []
    real = field_gpu.gpu_lists
    monkeypatch.setattr(field_gpu, "gpu_lists", lambda *a: calls.append(1) or real(*a))
    got = gloffset.distance_field(shape, grid, **kw).values
    assert calls
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))


def test_a_broken_bisector_test_loses_nearest_arcs(mexico, monkeypatch):
    """The bisector test's error bound turned against the lists: arcs go missing."""
    monkeypatch.setattr(walk_pass, "BIS_ABS", -1e-4)
    missing, _, _ = _check(mexico, Tile(5, 6, 13))
    assert len(missing) > 10


def test_the_bisector_test_shortens_the_lists(world, monkeypatch):
    """As the float64 walk's: about half as long without it on the countries."""
    nodes = NodeArcs.from_shape(world)
    grid = Equirect(512, 256)
    level = grid.n_levels - 1 - SHIFT
    cpu = _Lists(nodes, grid, math.inf, level, walk="cpu").count.sum()
    with_it = _Lists(nodes, grid, math.inf, level, walk="gpu").count.sum()
    monkeypatch.setattr(walk_pass, "BISECTOR", False)
    without = _Lists(nodes, grid, math.inf, level, walk="gpu").count.sum()
    assert with_it < 0.7 * without and with_it < 1.5 * cpu


def test_small_pools_split_the_last_level(mexico, monkeypatch):
    """Pools too small for the last level: it runs in parts of cells, retried with
    larger pools, the same lists; a pool too small for one cell's list: the float64
    walk's lists."""
    nodes = NodeArcs.from_shape(mexico)
    grid = Tile(5, 6, 13)
    want = _Lists(nodes, grid, math.inf, 0, walk="gpu")
    eng = walk_pass.walk_pass()
    runs = []
    real = walk_pass.WalkPass._run
    monkeypatch.setattr(walk_pass.WalkPass, "_run", lambda *a: runs.append(1) or real(*a))
    monkeypatch.setattr(eng, "max_pool", 20000)
    got = _Lists(nodes, grid, math.inf, 0, walk="gpu")
    assert len(runs) > 8
    assert np.array_equal(got.count, want.count)
    cell = np.repeat(np.arange(len(got.count)), got.count)
    key = cell * len(nodes.a)
    assert np.array_equal(np.sort(got.node + key), np.sort(want.node + key))
    monkeypatch.setattr(eng, "max_pool", 50)
    cpu = _Lists(nodes, grid, math.inf, 0, walk="cpu")
    got = _Lists(nodes, grid, math.inf, 0, walk="gpu")
    assert np.array_equal(got.count, cpu.count) and np.array_equal(got.node, cpu.node)


def test_one_level_grids_walk_in_float64(mexico):
    from gloffset.raster.fields.lists import gpu_lists

    nodes = NodeArcs.from_shape(mexico)
    grid = Equirect(8, 4)
    assert grid.n_levels == 1 and gpu_lists(nodes, grid, math.inf, 0) is None


def _asin_f(x):
    """``asin_f`` of ``shaders/field_walk.comp`` in float32, operation by operation."""
    f = np.float32
    x = np.asarray(x, f)
    big = x > f(0.5)
    z = np.where(big, f(0.5) * (f(1.0) - x), x * x).astype(f)
    y = np.where(big, np.sqrt(z), x).astype(f)
    p = f(4.2163199048e-2) * z + f(2.4181311049e-2)
    for coef in (4.5470025998e-2, 7.4953002686e-2, 1.6666752422e-1):
        p = (p * z + f(coef)).astype(f)
    r = (p * z * y + y).astype(f)
    return np.where(big, f(np.pi / 2) - f(2.0) * r, r)


def test_the_float32_asin_is_within_its_bound():
    """Relative error of ``asin_f`` on every scale of its input: within a quarter of
    ``ASIN_REL`` (the rest is the margin for GPUs' square roots)."""
    x = np.concatenate(
        [np.geomspace(1e-30, 1.0, 400_000), np.linspace(0.0, 1.0, 1_000_001)[1:]]
    ).astype(np.float32)
    x = np.concatenate([x, np.nextafter(x, np.float32(0)), np.float32([0.5, 1.0])])
    want = np.arcsin(x.astype(np.float64))
    rel = np.abs(_asin_f(x).astype(np.float64) - want) / np.maximum(want, 1e-300)
    assert rel.max() < walk_pass.ASIN_REL / 4


def test_levels_walked_on_the_gpu_read_their_parents_lists_in_chunks(world, monkeypatch):
    """Every level walked on the GPU (level 0 from the root list), each reading its parents' lists
    from the chunks the level above wrote, from pools too small at first (each level
    run again with the exact need): no pixel's nearest arc missing, the CPU's field."""
    from gloffset.raster.fields import lists

    monkeypatch.setattr(lists, "GPU_CELLS", 16)
    monkeypatch.setattr(walk_pass, "MIN_POOL", 64)
    monkeypatch.setattr(walk_pass, "_estimate", lambda lev, slots: 64)
    runs = []
    real = walk_pass.WalkPass._run
    monkeypatch.setattr(
        walk_pass.WalkPass, "_run", lambda *a: runs.append(a) or (r := real(*a)) and r
    )
    grid = Equirect(512, 256)
    missing, _, gpu = _check(world, grid)
    assert not missing
    sizes = [len(a[1].cells) for a in runs]
    assert len(set(sizes)) >= 2 and len(runs) > len(set(sizes))  # levels, retries
    assert {a[5] for a in runs} == {walk_pass.CONTIGUOUS, walk_pass.CHUNK - 1}
    want = gloffset.distance_field(world, grid, backend="cpu").values
    monkeypatch.setattr(field_gpu, "WALK", "gpu")
    got = gloffset.distance_field(world, grid).values
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))


@pytest.mark.parametrize("walk", ["cpu", "gpu"])
def test_each_cells_arcs_come_ascending_to_the_field_pass(world, walk):
    """Either walk's lists, as a block hands them to the field pass: each cell's arcs
    ascending, distinct (the pass reads the arcs' records in order), the lists' own."""
    nodes = NodeArcs.from_shape(world)
    grid = Equirect(512, 256)
    lists = _Lists(nodes, grid, math.inf, grid.n_levels - 1 - SHIFT, walk=walk)
    hc, wc = lists.shape
    first, cnt, node = lists.block(range(hc), range(wc))
    assert np.array_equal(cnt, lists.count)
    cell = np.repeat(np.arange(len(cnt)), cnt)
    same = cell[1:] == cell[:-1]
    assert same.sum() > 10000 and (np.diff(node)[same] > 0).all()
    key = cell * len(nodes.a)
    assert np.array_equal(node + key, np.sort(lists.node + key))


#: North of Mexico's border (New Mexico, Arizona): cells hundreds of reaches from it.
DEEP = Tile(8, 53, 103)


def test_the_dominance_test_shortens_deep_lists_and_keeps_the_nearest(mexico, monkeypatch):
    """On cells far from the boundary the walk's dominance test (``dominated``, as the
    float64 walk's) cuts the GPU lists (11,278 pairs to 5,439); every pixel's nearest arc
    stays."""
    from gloffset.raster.fields import dominance

    missing, cpu, gpu = _check(mexico, DEEP)
    assert not missing
    monkeypatch.setattr(dominance, "DOMINANCE", False)
    _, _, whole = _check(mexico, DEEP)
    assert 1.5 * gpu.count.sum() < whole.count.sum()


def test_a_broken_dominance_test_loses_nearest_arcs(mexico, monkeypatch):
    """Its ``R L`` term dropped: nearest arcs go missing, so the test above would see it."""
    from gloffset.gl.shaders import load_source
    from gloffset.raster.fields import lists

    src = load_source("field_walk.comp")[0]
    old = "lo - av - R * lip > 2.0 * u_sum_err"
    assert src.count(old) == 1
    wp = walk_pass.WalkPass()
    wp.prog = wp.ctx.compute_shader(src.replace(old, "lo - av > 2.0 * u_sum_err"))
    monkeypatch.setattr(lists, "walk_pass", lambda: wp)
    missing, _, _ = _check(mexico, DEEP)
    assert len(missing) > 10
