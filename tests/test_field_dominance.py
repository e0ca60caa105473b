"""The walk's lists cut by dominance (:mod:`gloffset.raster.fields.dominance`): an arc
farther than the cell's nearest arc (or vertex) at every point of the cell's disc, by
the bound on the difference of the two distances, is dropped.

On real borders: every dropped arc is farther than the nearest at each pixel of its
cell and at random points of its disc (brute force); the field and the sign codes are
the same bits with and without the cut; the lists of deep tiles get several times
shorter; and a broken bound is caught."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DATA, field_and_codes, named_countries

import gloffset
from gloffset.gl.field_pass import FieldPass
from gloffset.grids import Equirect, Tile
from gloffset.raster.fields import dominance
from gloffset.raster.fields import gpu as field_gpu
from gloffset.raster.fields.walk import exact_distances, walk_levels
from gloffset.raster.vector.node_levels import NodeArcs


@pytest.fixture(scope="module")
def countries():
    return gloffset.read(DATA / "countries_10m.geojson")


@pytest.fixture(scope="module")
def fiji_antarctica():
    """Fiji (across the antimeridian) and Antarctica (round the pole), 1:110m."""
    return named_countries("Fiji", "Antarctica")


#: Tiles whose cells lie far from the boundary (hundreds of cells: inland and offshore)
#: and near it (Mexico's coast at z4).
DEEP_TILES = [Tile(10, 199, 441), Tile(9, 99, 220), Tile(8, 49, 110)]
#: The first in the quick suite, the others slow.
DEEP_PARAMS = [
    pytest.param(t, id=str(t), marks=[pytest.mark.slow] if k else [])
    for k, t in enumerate(DEEP_TILES)
]
#: Round the south pole: Antarctica's interior and the ocean to 45 S.
POLE = Equirect(2048, 256, (-180, -90, 180, -45))


def _lists(shape, grid, cut: bool):
    """The walk's frontiers at the lists' level (with the in-walk cut or without) and,
    per frontier, the final cut's kept pairs."""
    nodes = NodeArcs.from_shape(shape)
    level = grid.n_levels - 1 - field_gpu.SHIFT
    old = dominance.DOMINANCE
    dominance.DOMINANCE = cut
    try:
        out = []
        for f, dist in walk_levels(nodes, grid, np.inf, level):
            keep = field_gpu._undominated(f, dist, nodes) if cut else slice(None)
            out.append((f, dist, keep))
        return nodes, out
    finally:
        dominance.DOMINANCE = old


def _disc_points(grid, f, cells, rng, k: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Points of the discs of ``cells`` of ``f``: their output pixels' centres and ``k``
    random points each, up to 0.999 rho from the centre. Returns (points, cell of each)."""
    last = grid.n_levels - 1
    s = 1 << field_gpu.SHIFT
    h, w = grid.level_shape(last)
    pts, owner = [], []
    for c in cells:
        j0, i0 = f.cells[c] * s
        jj, ii = np.meshgrid(
            np.arange(j0, min(j0 + s, h)), np.arange(i0, min(i0 + s, w)), indexing="ij"
        )
        pts.append(grid.centers(last, jj.ravel(), ii.ravel()))
        centre, rho = f.centers[c], f.rho[c]
        u = rng.normal(size=(k, 3))
        u -= (u @ centre)[:, None] * centre
        u /= np.linalg.norm(u, axis=1)[:, None]
        t = rho * 0.999 * np.sqrt(rng.uniform(size=k))
        pts.append(np.cos(t)[:, None] * centre + np.sin(t)[:, None] * u)
        owner.append(np.full(len(pts[-2]) + k, c))
    return np.concatenate(pts), np.concatenate(owner)


def _assert_dropped_are_farther(grid, nodes, f, keep, rng, most: int = 400) -> int:
    """Every pair that ``keep`` drops is farther than its cell's nearest arc, at each
    point of :func:`_disc_points`, by more than ETA / 2. Returns how many were dropped."""
    if isinstance(keep, slice):  # nothing cut
        return 0
    dropped = np.flatnonzero(~keep)
    if len(dropped) == 0:
        return 0
    cells = np.unique(f.pair_cell[dropped])
    cells = rng.choice(cells, min(most, len(cells)), replace=False)
    pts, owner = _disc_points(grid, f, cells, rng)
    start = np.searchsorted(f.pair_cell, np.arange(len(f.cells) + 1))
    for c in cells:
        mine = np.arange(start[c], start[c + 1])
        at = np.flatnonzero(owner == c)
        pi = np.repeat(at, len(mine))
        arc = np.tile(f.pair_arc[mine], len(at))
        d = exact_distances(pts, pi, nodes, arc).reshape(len(at), len(mine))
        near = d[:, keep[mine]].min(axis=1)
        far = d[:, ~keep[mine]]
        assert (far > near[:, None] + 0.5 * dominance.ETA).all(), f"cell {f.cells[c]}"
    return len(dropped)


@pytest.mark.parametrize("tile", DEEP_PARAMS)
def test_dropped_arcs_are_farther_deep_tiles(countries, tile):
    """The final cut on the uncut lists of deep tiles: what it drops is never nearest."""
    rng = np.random.default_rng(1)
    nodes, parts = _lists(countries, tile, cut=False)
    n = 0
    for f, dist, _ in parts:
        keep = field_gpu._undominated(f, dist, nodes)
        n += _assert_dropped_are_farther(tile, nodes, f, keep, rng)
    assert n > 1000  # the cut runs there


@pytest.mark.parametrize(
    "name, grid",
    [
        pytest.param("mexico", Tile(4, 3, 7), id="mexico-z4"),
        pytest.param("fiji_antarctica", POLE, id="antarctica-pole", marks=pytest.mark.slow),
        pytest.param(
            "fiji_antarctica", Tile(5, 0, 17), id="fiji-antimeridian", marks=pytest.mark.slow
        ),
    ],
)
def test_dropped_arcs_are_farther_near_and_round_the_pole(
    request, mexico_path, fiji_antarctica, name, grid
):
    shape = gloffset.read(mexico_path) if name == "mexico" else fiji_antarctica
    rng = np.random.default_rng(2)
    nodes, parts = _lists(shape, grid, cut=True)
    _, whole = _lists(shape, grid, cut=False)
    n = 0
    for f, _, keep in parts:
        n += _assert_dropped_are_farther(grid, nodes, f, keep, rng)
    assert n > 0
    # the in-walk cut keeps every arc the uncut lists hold that is some pixel's nearest:
    # checked through the field below (the same bits); here the lists are no longer
    assert sum(len(f.pair_arc[k]) for f, _, k in parts) < sum(len(f.pair_arc) for f, *_ in whole)


def _field_and_codes(shape, grid, monkeypatch, cut: bool):
    return field_and_codes(shape, grid, monkeypatch, (dominance, "DOMINANCE", cut))


@pytest.mark.parametrize(
    "which, grid",
    [
        pytest.param("countries", DEEP_TILES[0], id="deep-z10"),
        pytest.param("countries", DEEP_TILES[2], id="deep-z8", marks=pytest.mark.slow),
        pytest.param("countries", Tile(4, 3, 6), id="countries-z4", marks=pytest.mark.slow),
        pytest.param("mexico", Tile(3, 1, 3), id="mexico-z3", marks=pytest.mark.slow),
        pytest.param("fiji_antarctica", POLE, id="pole"),
        pytest.param("fiji_antarctica", Tile(5, 0, 17), id="antimeridian", marks=pytest.mark.slow),
    ],
)
def test_the_cut_changes_no_bit(
    request, countries, mexico_path, fiji_antarctica, monkeypatch, which, grid
):
    shape = {"countries": countries, "fiji_antarctica": fiji_antarctica}.get(which)
    if shape is None:
        shape = gloffset.read(mexico_path)
    cut, cut_codes = _field_and_codes(shape, grid, monkeypatch, True)
    whole, whole_codes = _field_and_codes(shape, grid, monkeypatch, False)
    assert cut.tobytes() == whole.tobytes()
    assert len(cut_codes) == len(whole_codes)
    for a, b in zip(cut_codes, whole_codes):
        assert (a is None and b is None) or np.array_equal(a, b)


@pytest.mark.parametrize(
    "grid",
    [
        pytest.param(DEEP_TILES[1], id="deep-z9"),
        pytest.param(POLE, id="pole", marks=pytest.mark.slow),
    ],
)
def test_the_cpu_backend_keeps_its_bits(countries, fiji_antarctica, monkeypatch, grid):
    """The CPU backend walks to the pixels with the in-walk cut: the same field (its
    values and signs) with and without it."""
    shape = fiji_antarctica if grid is POLE else countries
    got = gloffset.distance_field(shape, grid, radius=1.0, backend="cpu").values
    monkeypatch.setattr(dominance, "DOMINANCE", False)
    want = gloffset.distance_field(shape, grid, radius=1.0, backend="cpu").values
    assert got.tobytes() == want.tobytes()


def _pairs(shape, grid, monkeypatch, cut: bool) -> int:
    n = []
    run = FieldPass.run

    def count(self, plan, probe=False):
        n.append(len(plan.pairs))
        return run(self, plan, probe)

    with monkeypatch.context() as m:
        m.setattr(FieldPass, "run", count)
        m.setattr(dominance, "DOMINANCE", cut)
        gloffset.distance_field(shape, grid)
    return sum(n)


@pytest.mark.parametrize("tile", DEEP_PARAMS)
def test_deep_lists_get_several_times_shorter(countries, tile, monkeypatch):
    assert 4 * _pairs(countries, tile, monkeypatch, True) < _pairs(
        countries, tile, monkeypatch, False
    )


@pytest.mark.parametrize("where", ["final", "walk"])
def test_a_broken_bound_is_caught(countries, monkeypatch, where):
    """Without the bound's ``rho L`` term, arcs some pixel needs are dropped: the
    brute-force check fails and the field is off the CPU's values."""
    tile = DEEP_TILES[0]
    want = gloffset.distance_field(countries, tile, radius=1.0, backend="cpu").values
    if where == "final":
        monkeypatch.setattr(dominance, "vertex_dominates", lambda *a: np.zeros(len(a[3]), bool))
        real = dominance.undominated

        def broken(centers, rho, cell, arc, nodes, d):
            return real(centers, 0.0 * rho, cell, arc, nodes, d)

        monkeypatch.setattr(dominance, "undominated", broken)
    else:
        real = dominance.vertex_dominates

        def broken(c, v, mid, lo, r, reach):
            return real(c, v, mid, lo, r, 0.0 * reach)

        monkeypatch.setattr(dominance, "vertex_dominates", broken)
    bad = gloffset.distance_field(countries, tile, radius=1.0).values
    off = np.abs(bad.astype(np.float64) - want) > np.spacing(np.abs(want))
    assert off.sum() > 100


@pytest.mark.parametrize("tile", DEEP_PARAMS[:2])
def test_deep_short_lists_finished_directly_keep_their_bits(countries, tile, monkeypatch, tmp_path):
    """Deep blocks' short lists are finished whole in double, unranked
    (``field_pass.DIRECT``): the same values and sign codes as ranked; and the path runs
    there (a shader that finishes only a direct list's first arc is off the CPU)."""
    from conftest import broken_field_pass

    from gloffset.gl import field_pass

    direct, direct_codes = _field_and_codes(countries, tile, monkeypatch, True)
    with monkeypatch.context() as m:
        m.setattr(field_pass, "DIRECT", 0)
        ranked, ranked_codes = _field_and_codes(countries, tile, monkeypatch, True)
    assert direct.tobytes() == ranked.tobytes()
    for a, b in zip(direct_codes, ranked_codes):
        assert np.array_equal(a, b)
    want = gloffset.distance_field(countries, tile, radius=1.0, backend="cpu").values
    broken_field_pass(
        monkeypatch,
        tmp_path,
        "uint n = near_n + (whole ? list.y : 0u);",
        "uint n = near_n + (whole ? (direct ? min(list.y, 1u) : list.y) : 0u);",
    )
    bad = gloffset.distance_field(countries, tile, radius=1.0).values
    off = np.abs(bad.astype(np.float64) - want) > np.spacing(np.abs(want))
    assert off.sum() > 100
