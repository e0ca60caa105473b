"""The GPU backend of ``gloffset.distance_field``: within 1 float32 ulp of the CPU's
values (same signs) on real borders, the float32 ranking's and the float64 finishing's
error bounds, and the finishing it cannot do without."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DATA, broken_field_pass, named_countries

import gloffset
from gloffset.geometry.sphere import normalize
from gloffset.gl.field_pass import FIELD_ERR, NEAREST_ERR, FieldPass, FieldPlan, field_pass
from gloffset.grids import Cube, Equirect, Tile
from gloffset.raster.fields import gpu as field_gpu
from gloffset.raster.fields.walk import exact_distances
from gloffset.raster.vector.node_levels import NodeArcs


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


@pytest.fixture(scope="module")
def edges():
    """Fiji and Russia (across the antimeridian) and Antarctica (round the pole), 1:110m."""
    return named_countries("Fiji", "Russia", "Antarctica")


def within_ulp(got: np.ndarray, want: np.ndarray) -> np.ndarray:
    """Where float32 ``got`` is within 1 float32 ulp of ``want`` with its sign (signs
    of zeros included; infinities equal)."""
    g, w = got.astype(np.float64), want.astype(np.float64)
    ulp = np.spacing(np.abs(want)).astype(np.float64)
    close = np.abs(g - w) <= ulp
    return (np.signbit(got) == np.signbit(want)) & (close | (g == w))


def assert_contract(shape, grid, **kw):
    """The GPU field is within 1 float32 ulp of the CPU field, with its signs; nearly
    every value has the CPU's bits (the float64 values differ by a few 1e-16 relative)."""
    gpu = gloffset.distance_field(shape, grid, **kw)
    cpu = gloffset.distance_field(shape, grid, backend="cpu", **kw)
    bad = np.argwhere(~within_ulp(gpu.values, cpu.values))
    assert len(bad) == 0, f"{len(bad)} values off the CPU's by more than 1 ulp, e.g. {bad[:3]}"
    same = gpu.values.view(np.uint32) == cpu.values.view(np.uint32)
    assert same.mean() > 0.999, f"{(~same).sum()} of {same.size} values differ"
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
def test_mexico_within_an_ulp(mexico, grid, kw):
    field = assert_contract(mexico, grid, **kw)
    assert len(np.unique(field.values)) > 1000


@pytest.mark.parametrize(
    "grid", [Equirect(360, 180), Cube(32), Equirect(256, 256, (150, -90, -150, -30))]
)
def test_seams_and_the_pole_within_an_ulp(edges, grid):
    assert_contract(edges, grid)
    assert_contract(edges, grid, max_distance=500e3)


def test_lines_and_points_within_an_ulp():
    lines = {
        "type": "MultiLineString",
        "coordinates": [[[-10, 40], [20, 45], [35, 30]], [[170, -20], [-170, -25]]],
    }
    point = {"type": "MultiPoint", "coordinates": [[30, 60], [-100, -89.5]]}
    for geom in (lines, point):
        shape = gloffset.read(geom)
        field = assert_contract(shape, Equirect(200, 100))
        assert (field.values >= 0).all()
        assert_contract(shape, Cube(16), max_distance=1000e3)


@pytest.mark.parametrize(
    "crs, kind",
    [("EPSG:3031", "glsl"), ("+proj=ortho +lat_0=-90 +lon_0=0", "texture")],
    ids=["polar-glsl", "ortho-texture"],
)
def test_projected_grids_within_an_ulp(edges, crs, kind, monkeypatch):
    """Antarctica on a polar stereographic grid (the shader's centres from the grid's GLSL
    function) and an orthographic one (the host's centres, pyproj's, handed over); in
    blocks of 32 pixels (each block's pixels from its own origin), the same values."""
    from gloffset.grids import Projected

    g = Projected(140, 120, crs=crs, bounds=(-3.2e6, -2.8e6, 3.2e6, 3.2e6))
    assert g.centres == kind
    field = assert_contract(edges, g)
    assert (field.values < 0).any() and (field.values > 0).any()
    monkeypatch.setattr(field_gpu, "_BLOCK", 32)
    assert gloffset.distance_field(edges, g).values.tobytes() == field.values.tobytes()


def test_cube_faces_in_blocks(edges, monkeypatch):
    """Cube faces in blocks of 16 pixels (each block's rows and columns of face
    coordinates its own): the same values as in one block, within an ulp of the CPU's."""
    whole = assert_contract(edges, Cube(48)).values
    monkeypatch.setattr(field_gpu, "_BLOCK", 16)
    assert gloffset.distance_field(edges, Cube(48)).values.tobytes() == whole.tobytes()


def test_lonlat_centres_are_the_hosts(mexico):
    """On lon/lat grids the shader's centres are the host's bit for bit (its products of
    the rows' and columns' cosines and sines): on a Mexico tile every value has the
    CPU's bits but where the float64 values straddle a float32 rounding boundary."""
    field = gloffset.distance_field(mexico, Tile(6, 13, 28), radius=1.0)
    cpu = gloffset.distance_field(mexico, Tile(6, 13, 28), radius=1.0, backend="cpu")
    differ = field.values.view(np.uint32) != cpu.values.view(np.uint32)
    assert differ.sum() <= 3 and within_ulp(field.values, cpu.values).all()


def test_blocks_and_their_halves(mexico, monkeypatch):
    """Many blocks with partial cells at the edges, and blocks over the GL limits run
    in halves of their rows: within an ulp of the CPU's values."""
    grid = Equirect(300, 170, (-118, 14, -86, 33))
    want = gloffset.distance_field(mexico, grid, backend="cpu").values
    whole = gloffset.distance_field(mexico, grid).values
    assert within_ulp(whole, want).all()
    monkeypatch.setattr(field_gpu, "_BLOCK", 64)
    assert gloffset.distance_field(mexico, grid).values.tobytes() == whole.tobytes()
    eng = field_pass()
    monkeypatch.setattr(eng, "fits", lambda h, w, *rest: h <= 16)  # two rows of cells
    runs = []
    run = FieldPass.run
    monkeypatch.setattr(FieldPass, "run", lambda self, plan: runs.append(1) or run(self, plan))
    got = gloffset.distance_field(mexico, grid).values
    assert got.tobytes() == whole.tobytes()
    # 5 columns of blocks of 8, 8 and 6 rows of cells, halved to 4 + 4 + 4 pieces
    assert len(runs) == 5 * 12


@pytest.mark.parametrize(
    "old, new, least",
    [
        # the least float32 feature alone, never those within reach nor the whole list
        ("float reach = m0 + u_gap;", "float reach = m0 - 1.0;", 30),
        # a wrong candidate: the second feature in place of the least one
        (
            "uint w = listed ? k << 2 : w0;",
            "uint w = listed ? k << 2 : (i == 0u && w1 != NONE ? w1 : w0);",
            10000,
        ),
        # every pixel its cell's whole list: the same values
        pytest.param(
            "bool whole = direct || dropped <= reach || unsure <= reach;",
            "bool whole = true;",
            0,
            marks=pytest.mark.slow,
        ),
    ],
    ids=["least-only", "wrong-candidate", "whole-lists"],
)
def test_the_finishing_needs_the_features_within_reach(
    mexico, monkeypatch, tmp_path, old, new, least
):
    """Pixels whose float32 chords cannot tell the nearest feature are common (on the
    medial axis, and seen from afar along a coast: the Mexico 1:10m tile of z3): a
    shader that finishes only the least feature, or a wrong one, is off the CPU's values
    by more than an ulp; one that finishes every pixel's whole list is not."""
    grid = Tile(3, 1, 3)
    want = gloffset.distance_field(mexico, grid, radius=1.0, backend="cpu").values
    good = gloffset.distance_field(mexico, grid, radius=1.0).values
    assert within_ulp(good, want).all()
    broken_field_pass(monkeypatch, tmp_path, old, new)
    bad = gloffset.distance_field(mexico, grid, radius=1.0).values
    off = (~within_ulp(bad, want)).sum()
    if least:
        assert off >= least, f"{off} values off"
    else:
        assert off == 0 and bad.tobytes() == good.tobytes()


def test_the_whole_list_where_more_may_tie(monkeypatch, tmp_path):
    """Polygons of 64 edges about pixel centres, their edges' distances from the centre
    within 4 float32 ulps of each other (closer than float32 can rank them): more than
    six features tie, and the centre's pixel takes its cell's whole list. A shader that
    never does is off the CPU's values by more than an ulp there; this one is not."""
    from gloffset.geometry.sphere import xyz_to_lonlat

    rng = np.random.default_rng(5)
    grid = Equirect(360, 180)
    polys, centres = [], []
    for lon in range(-150, 180, 40):
        for lat in (-40, 0, 40):
            c = grid.centers(grid.n_levels - 1, np.array([89 - lat]), np.array([180 + lon]))[0]
            e1 = normalize(np.cross(c, [0.0, 0.0, 1.0]))
            e2 = np.cross(c, e1)
            theta = np.linspace(0, 2 * np.pi, 64, endpoint=False)
            r = 0.005 * (1 + 4e-6 * rng.uniform(size=64))
            v = np.cos(r)[:, None] * c + np.sin(r)[:, None] * (
                np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2
            )
            lo, la = xyz_to_lonlat(v)
            ring = np.column_stack([lo, la]).tolist()
            polys.append([ring + ring[:1]])
            centres.append((89 - lat, 180 + lon))
    shape = gloffset.read({"type": "MultiPolygon", "coordinates": polys})
    j, i = np.array(centres).T
    want = gloffset.distance_field(shape, grid, backend="cpu").values
    got = gloffset.distance_field(shape, grid).values
    assert within_ulp(got, want).all()
    broken_field_pass(
        monkeypatch,
        tmp_path,
        "bool whole = direct || dropped <= reach || unsure <= reach;",
        "bool whole = direct;",
    )
    bad = gloffset.distance_field(shape, grid).values
    assert within_ulp(bad[~np.isin(np.arange(180), j)], want[~np.isin(np.arange(180), j)]).all()
    assert (~within_ulp(bad[j, i], want[j, i])).sum() >= 3


def _single_arcs(nodes, p, arc):
    """A plan of one pixel per point ``p`` (host centres), each with the one arc ``arc``."""
    n = len(p)
    side = int(np.sqrt(n))
    arcs, local = np.unique(arc, return_inverse=True)
    rec, exact = field_gpu._records(nodes)
    return FieldPlan(
        (side, side),
        (0, 0),
        0,
        np.stack([np.arange(n), np.ones(n)], axis=-1).reshape(side, side, 2).astype(np.uint32),
        local.astype(np.uint32),
        rec[arcs],
        np.stack([2 * np.arange(len(arcs)), 2 * np.arange(len(arcs)) + 1], axis=-1).astype(
            np.uint32
        ),
        exact[arcs],
        "texture",
        p.reshape(side, side, 3),
    )


@pytest.fixture(scope="module")
def pairs(mexico):
    """A million pairs of Mexico's arcs and points on and near its coast (at the arcs'
    ends, beside them, over them), far away and at right angles."""
    nodes = NodeArcs.from_shape(mexico)
    rng = np.random.default_rng(3)
    n = 1 << 20
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
    return nodes, p, arc, exact_distances(p, np.arange(n), nodes, arc)


def test_float32_chords_within_their_bound(pairs):
    """NEAREST_ERR bounds |float32 chord - chord of the float64 distance|: the ranking's
    least chord over lists of one arc, on a million real pairs: the largest error seen
    is well within it."""
    nodes, p, arc, exact = pairs
    got = field_pass().run(_single_arcs(nodes, p, arc), probe=True).ravel()
    chord32 = np.abs(got)
    err = np.abs(chord32 - 2.0 * np.sin(0.5 * exact))
    # the far side of a short arc seen from near its circle's pole: float32 cannot tell
    # the side, and such a pixel takes its whole list (a negative chord)
    whole = np.signbit(got)
    assert 0 < whole.sum() < len(p) // 200
    assert err[~whole].max() < NEAREST_ERR / 4, f"{err[~whole].max():.3g} of {NEAREST_ERR}"


def test_float64_finishing_within_its_bound(pairs):
    """FIELD_ERR bounds |shader's float64 distance - arc_distance| (relative) from the
    same centre: on a million real pairs, distances from 1e-17 to pi, the largest error
    seen (6.7e-16 on llvmpipe) is within it; most have arc_distance's bits."""
    nodes, p, arc, exact = pairs
    got = field_pass().run(_single_arcs(nodes, p, arc)).ravel()
    assert (got[exact == 0] == 0).all()
    rel = np.abs(got - exact) / np.where(exact > 0, exact, 1.0)
    assert rel.max() <= FIELD_ERR, f"{rel.max():.3g} of {FIELD_ERR}"
    assert (got == exact).mean() > 0.5


@pytest.mark.slow
def test_all_countries_within_an_ulp():
    """The 234 countries of 1:10m (307,857 vertices), on the globe and on a cube."""
    shape = gloffset.read(DATA / "countries_10m.geojson")
    assert_contract(shape, Equirect(1024, 512))
    assert_contract(shape, Cube(96), max_distance=300e3)


def test_a_block_runs_in_bands_where_other_threads_wait(mexico, monkeypatch):
    """With another thread alive, a block is dispatched in bands of ``BAND`` rows (the GIL
    free between them); alone, in one dispatch; the same bits either way."""
    import threading

    import moderngl

    from gloffset.gl import field_pass

    grid = Tile(5, 7, 14)
    runs = []
    real = moderngl.ComputeShader.run
    monkeypatch.setattr(
        moderngl.ComputeShader, "run", lambda self, *a, **k: runs.append(1) or real(self, *a, **k)
    )
    monkeypatch.setattr(threading, "active_count", lambda: 1)
    alone = gloffset.distance_field(mexico, grid, radius=1.0).values
    n_alone, runs[:] = len(runs), []
    monkeypatch.setattr(threading, "active_count", lambda: 2)
    banded = gloffset.distance_field(mexico, grid, radius=1.0).values
    assert len(runs) >= n_alone + 256 // field_pass.BAND - 1
    assert alone.tobytes() == banded.tobytes()
