"""The GPU backend of ``gloffset.distance_field``: the CPU's values bit for bit on real
borders, the float32 pass's error bound, and the finishing it cannot do without."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import DATA

import gloffset
from gloffset.geometry.sphere import normalize
from gloffset.gl.nearest_pass import EVERY, NEAREST_ERR, NearestPass, NearestPlan, nearest_pass
from gloffset.grids import Cube, Equirect, Tile
from gloffset.raster import field_gpu
from gloffset.raster.field_walk import exact_distances
from gloffset.raster.vector.node_levels import NodeArcs


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


@pytest.fixture(scope="module")
def edges():
    """Fiji and Russia (across the antimeridian) and Antarctica (round the pole), 1:110m."""
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    keep = {"Fiji", "Russia", "Antarctica"}
    feats = [f for f in fc["features"] if f["properties"]["name"] in keep]
    assert len(feats) == len(keep)
    return gloffset.read({"type": "FeatureCollection", "features": feats})


def assert_same_bits(shape, grid, **kw):
    """The GPU field equals the CPU field bit for bit (signs of zeros included)."""
    gpu = gloffset.distance_field(shape, grid, **kw)
    cpu = gloffset.distance_field(shape, grid, backend="cpu", **kw)
    bad = np.argwhere(gpu.values.view(np.uint32) != cpu.values.view(np.uint32))
    assert len(bad) == 0, f"{len(bad)} values differ from the CPU's, e.g. at {bad[:3]}"
    return gpu


@pytest.mark.parametrize(
    "grid, kw",
    [
        (Tile(3, 1, 3), {"radius": 1.0}),  # Mexico and the Pacific, as the tile server asks
        (Tile(5, 6, 13), {"radius": 1.0}),  # its west coast
        (Tile(8, 57, 113), {"radius": 1.0}),  # Mexico City
        (Equirect(512, 256), {}),  # the globe, far pixels included
        (Equirect(500, 250, (-120, 10, -80, 30)), {"max_distance": 200e3}),  # clamped
    ],
    ids=["z3", "z5", "z8", "global", "clamped"],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_mexico_bit_for_bit(mexico, grid, kw):
    field = assert_same_bits(mexico, grid, **kw)
    assert len(np.unique(field.values)) > 1000


@pytest.mark.parametrize(
    "grid", [Equirect(360, 180), Cube(32), Equirect(256, 256, (150, -90, -150, -30))]
)
def test_seams_and_the_pole_bit_for_bit(edges, grid):
    assert_same_bits(edges, grid)
    assert_same_bits(edges, grid, max_distance=500e3)


def test_lines_and_points_bit_for_bit():
    lines = {
        "type": "MultiLineString",
        "coordinates": [[[-10, 40], [20, 45], [35, 30]], [[170, -20], [-170, -25]]],
    }
    point = {"type": "MultiPoint", "coordinates": [[30, 60], [-100, -89.5]]}
    for geom in (lines, point):
        shape = gloffset.read(geom)
        field = assert_same_bits(shape, Equirect(200, 100))
        assert (field.values >= 0).all()
        assert_same_bits(shape, Cube(16), max_distance=1000e3)


def test_blocks_and_their_halves(mexico, monkeypatch):
    """Many blocks with partial cells at the edges, and blocks over the GL limits drawn
    in halves of their rows: the same bits."""
    grid = Equirect(300, 170, (-118, 14, -86, 33))
    want = gloffset.distance_field(mexico, grid, backend="cpu").values
    monkeypatch.setattr(field_gpu, "_BLOCK", 64)
    assert np.array_equal(
        gloffset.distance_field(mexico, grid).values.view(np.uint32), want.view(np.uint32)
    )
    eng = nearest_pass()
    monkeypatch.setattr(eng, "max_bytes", 1 << 17)
    runs = []
    run = NearestPass.run
    monkeypatch.setattr(NearestPass, "run", lambda self, plan: runs.append(1) or run(self, plan))
    got = gloffset.distance_field(mexico, grid).values
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))
    assert len(runs) > 15  # 5 x 3 blocks of 64 pixels, some of them split


def _answers(monkeypatch):
    """Record the GPU's answers (counts and flags) that the finishing reads."""
    seen = []
    finish = field_gpu.finish

    def spy(c, got, *args):
        seen.append(got[:, 3].copy())
        return finish(c, got, *args)

    monkeypatch.setattr(field_gpu, "finish", spy)
    return seen


@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_the_finishing_needs_the_features_within_reach(mexico, monkeypatch):
    """Pixels whose float32 chords cannot tell the nearest feature are common (on the
    medial axis, and seen from afar along a coast: the Mexico 1:10m tile of z3): some
    need more features than the least, a few the cell's whole list; and each feature
    within reach is needed: without them, values change."""
    grid = Tile(3, 1, 3)
    want = gloffset.distance_field(mexico, grid, radius=1.0, backend="cpu").values
    seen = _answers(monkeypatch)
    got = gloffset.distance_field(mexico, grid, radius=1.0).values
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))
    flags = np.concatenate(seen)
    assert (flags & 0xFF != 0).sum() > 1000 and (flags & EVERY != 0).sum() > 10

    def corrupt(fn):
        run = NearestPass.run

        def wrong(self, plan):
            return fn(run(self, plan).copy())

        monkeypatch.setattr(NearestPass, "run", wrong)
        return gloffset.distance_field(mexico, grid, radius=1.0).values

    def least_only(got):
        got[..., 3] = 0
        return got

    def second_first(got):  # the second feature as the least one
        two = got[..., 1] != 0xFFFFFFFF
        got[two, 0] = got[two, 1]
        return got

    def fewer(got):  # one feature fewer within reach
        got[..., 3] = np.where(got[..., 3] & 0xFF != 0, got[..., 3] - 1, got[..., 3])
        return got

    for fn in (least_only, second_first, fewer):
        bad = corrupt(fn)
        assert (bad.view(np.uint32) != want.view(np.uint32)).sum() > 10, fn.__name__

    def whole_lists(got):  # a wrong feature, but every pixel with its cell's whole list
        second_first(got)
        got[..., 3] = EVERY
        return got

    assert corrupt(whole_lists).tobytes() == want.tobytes()


def test_float32_chords_within_their_bound(mexico):
    """NEAREST_ERR bounds |float32 chord - chord of the float64 distance|: the shader's
    least chord over lists of one arc, on a million pairs of Mexico's arcs and points
    on and near its coast (at the arcs' ends, beside them, over them), far away and at
    right angles: the largest error seen is well within it."""
    nodes = NodeArcs.from_shape(mexico)
    rng = np.random.default_rng(3)
    n, side = 1 << 20, 1 << 10
    arc = np.flatnonzero(nodes.leaf)[rng.integers(0, int(nodes.leaf.sum()), n)]
    t = rng.uniform(-0.2, 1.2, n)[:, None]
    along = normalize((1 - t) * nodes.a[arc] + t * nodes.b[arc])
    scale = 10.0 ** rng.uniform(-9, 0.3, n)[:, None]
    p = normalize(along + scale * rng.normal(size=(n, 3)))
    p[: n // 8] = normalize(rng.normal(size=(n // 8, 3)))  # anywhere
    p[n // 8 : n // 4] = normalize(
        nodes.n[arc[n // 8 : n // 4]] + 1e-4 * rng.normal(size=(n // 8, 3))
    )
    p[n // 4 : n // 4 + 1000] = nodes.a[arc[n // 4 : n // 4 + 1000]]  # on the ends
    arcs, local = np.unique(arc, return_inverse=True)
    plan = NearestPlan(
        p.reshape(side, side, 3).astype(np.float32),
        0,
        np.stack([np.arange(n), np.ones(n)], axis=-1).reshape(side, side, 2).astype(np.uint32),
        local.astype(np.uint32),
        field_gpu._records(nodes)[arcs],
        np.stack([2 * np.arange(len(arcs)), 2 * np.arange(len(arcs)) + 1], axis=-1).astype(
            np.uint32
        ),
    )
    got = nearest_pass().run(plan).reshape(-1, 8)
    chord32 = got[:, 2].view(np.float32).astype(np.float64)
    exact = exact_distances(p, np.arange(n), nodes, arc)
    err = np.abs(chord32 - 2.0 * np.sin(0.5 * exact))
    # the far side of a short arc seen from near its circle's pole: float32 cannot tell
    # the side, and such a pixel takes its whole list (flag 2)
    whole = got[:, 3] & EVERY != 0
    assert 0 < whole.sum() < n // 200
    assert err[~whole].max() < NEAREST_ERR / 4, f"{err[~whole].max():.3g} of {NEAREST_ERR}"


@pytest.mark.slow
def test_all_countries_bit_for_bit():
    """The 234 countries of 1:10m (307,857 vertices), on the globe and on a cube."""
    shape = gloffset.read(DATA / "countries_10m.geojson")
    assert_same_bits(shape, Equirect(1024, 512))
    assert_same_bits(shape, Cube(96), max_distance=300e3)
