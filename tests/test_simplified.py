"""Renders from the curves simplified to a fraction of a pixel (gloffset.raster.simplified)
on real borders: the two-sided error bound of the simplified curve, and masks equal to
the float64 reference pixel by pixel."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import DATA
from test_render import boundary_distance

import gloffset
from gloffset.geometry.sphere import arc_distance
from gloffset.grids import CubeFace, Equirect, Tile
from gloffset.raster import render as render_mod
from gloffset.raster import simplified as simp
from gloffset.reference import contains_xyz, distance_xyz


@pytest.fixture(scope="module")
def arctic():
    """Greenland and Iceland from countries_10m: fjords, 23,000 vertices, up to 83.6 N."""
    fc = json.loads((DATA / "countries_10m.geojson").read_text())
    names = ("Greenland", "Iceland")
    feats = [f for f in fc["features"] if f["properties"].get("name") in names]
    assert len(feats) == 2
    return gloffset.read({"type": "FeatureCollection", "features": feats})


def _near_points(shape, n, spread, seed=0):
    """Points near the curves: vertices moved up to ``spread`` rad in random directions."""
    rng = np.random.default_rng(seed)
    e = shape.edges()
    p = e.a[rng.integers(0, len(e.a), n)] + rng.normal(scale=spread, size=(n, 3))
    return p / np.linalg.norm(p, axis=1)[:, None]


@pytest.mark.parametrize("eps", [2e-5, 3e-4, 3e-3])
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_cut_is_within_eps_both_ways(arctic, eps):
    """|D(p) - D_S(p)| <= eps for points near the curves (D to the original boundary
    arcs, D_S to the simplified ones), and the simplified curve is much shorter."""
    nodes = simp.cut(arctic, eps)
    n = len(arctic.edges().a)
    assert len(nodes) < n
    s = simp.Simplified(arctic, eps, nodes)
    e = s.edges()
    a, b = e.a[e.boundary], e.b[e.boundary]
    p = _near_points(arctic, 400, 0.01)
    ds = np.full(len(p), np.inf)
    for k in range(0, len(a), 512):
        ds = np.minimum(
            ds, arc_distance(p[:, None], a[None, k : k + 512], b[None, k : k + 512]).min(1)
        )
    d = distance_xyz(arctic, p)
    assert np.all(np.abs(d - ds) <= eps + 1e-12), float(np.abs(d - ds).max())
    # the bound is used, not idle: some points are off by more than a tenth of it
    assert np.abs(d - ds).max() > 0.1 * eps


def test_seams_are_never_simplified():
    """A polygon cut at the antimeridian: its seam edges (along 180 degrees, no distance)
    stay the original ones however coarse the rest."""
    lat = np.linspace(0.0, 10.0, 41)
    west = np.column_stack([170.0 + 0.3 * np.sin(7.0 * lat[::-1]), lat[::-1]])
    seam = np.column_stack([np.full(len(lat), 180.0), lat])
    ring = np.vstack([west[-1:], seam, west[1:]]).tolist()
    shape = gloffset.read({"type": "Polygon", "coordinates": [ring + [ring[0]]]})
    e0 = shape.edges()
    nodes = simp.cut(shape, 0.05)
    s = simp.Simplified(shape, 0.05, nodes).edges()
    seams0 = {(tuple(a), tuple(b)) for a, b in zip(e0.a[~e0.boundary], e0.b[~e0.boundary])}
    seams = {(tuple(a), tuple(b)) for a, b in zip(s.a[~s.boundary], s.b[~s.boundary])}
    assert len(seams0) >= 30 and seams == seams0
    assert s.boundary.sum() < e0.boundary.sum()


def _taken(monkeypatch):
    """Record the band points of simplified renders (the path is taken)."""
    calls = []
    orig = render_mod.band_members

    def spy(shape, p, d):
        calls.append(p)
        return orig(shape, p, d)

    monkeypatch.setattr(render_mod, "band_members", spy)
    return calls


@pytest.mark.parametrize(
    "grid, d",
    [
        (Equirect(1024, 512), 0.02),
        pytest.param(Equirect(1024, 512), -0.012, marks=pytest.mark.slow),
        (Equirect(300, 150, bounds=(-75, 58, -10, 85)), 0.006),
        (Tile(0, 0, 0), 0.02),
        pytest.param(Tile(2, 1, 1), -0.01, marks=pytest.mark.slow),
        (CubeFace(4, 256), 0.015),  # +Z: the north pole
        # distances below a few pixels: simplified to an eighth of the distance
        (Equirect(64, 32), 0.02),
        (Equirect(128, 64), -0.03),
        (Tile(0, 0, 0, 64), 0.01),
    ],
)
def test_simplified_render_equals_reference(arctic, monkeypatch, grid, d):
    """The mask from the simplified curves equals the float64 reference renderer
    (``backend="cpu"``) at every pixel, and the brute-force reference at the band's
    pixels and at random pixels (but within 1e-9 rad of |d|: float64 rounding)."""
    monkeypatch.setattr(simp, "MIN_ARCS", 1000)
    calls = _taken(monkeypatch)
    mask = gloffset.render(arctic, d, grid, radius=1.0)
    assert len(calls) == 1 and len(calls[0]) > 0, "the simplified path was not taken"
    cpu = gloffset.render(arctic, d, grid, radius=1.0, backend="cpu")
    assert np.array_equal(mask, cpu)
    h, w = grid.shape
    assert 0 < np.count_nonzero(mask) < h * w
    rng = np.random.default_rng(1)
    jj, ii = rng.integers(0, h, 1500), rng.integers(0, w, 1500)
    p = np.vstack([calls[0], grid.centers(grid.n_levels - 1, jj, ii)])
    got = np.concatenate([simp.band_members(arctic, calls[0], d), mask[jj, ii] == 255])
    bad = got != contains_xyz(arctic, p, d)
    assert np.all(np.abs(distance_xyz(arctic, p[bad]) - abs(d)) <= 1e-9), int(bad.sum())
    # the render without simplification differs only where its own contract allows
    plain = render_mod._render_one(
        arctic, d, grid, backend="gpu", level=None, callback=None, mask=True, simplify=False
    )
    j, i = np.nonzero(plain != mask)
    if len(j):
        q = grid.centers(grid.n_levels - 1, j, i)
        pix = 2.0 * np.pi / (4 * max(h, w))  # no pixel is larger
        near = np.abs(distance_xyz(arctic, q) - abs(d)) <= 1e-3 * pix
        assert np.all(near | (boundary_distance(arctic, q) <= 1e-3 * pix))


def test_band_decided_by_distance(arctic):
    """band_members answers by the exact distance to the boundary arcs."""
    p = _near_points(arctic, 2000, 0.01, seed=3)
    d = 0.005
    got = simp.band_members(arctic, p, d)
    want = distance_xyz(arctic, p) <= d
    assert np.array_equal(got, want)
    assert np.array_equal(simp.band_members(arctic, p, -d), ~want)


def test_not_used_where_it_does_not_pay(arctic, world):
    """A small input, or a simplification that keeps most arcs, renders as before."""
    assert len(arctic.edges().a) > simp.MIN_ARCS
    assert simp.simplified(arctic, 1e-9) is None  # keeps every arc
    assert simp.simplified(arctic, 3e-3) is not None
    fiji = gloffset.read(world["Fiji"])
    assert len(fiji.edges().a) < simp.MIN_ARCS
    assert simp.simplified(fiji, 3e-3) is None


@pytest.mark.parametrize("d", [0.05, 0.5, 1.4, -0.06])
def test_mexico_equals_reference_renderer(monkeypatch, mexico_path, d):
    """Mexico 1:10m (7,368 arcs) on a 512 x 256 globe, out to 1.4 rad, where every bin
    sees most of the coast: from the simplified curves, equal to the float64 renderer."""
    mexico = gloffset.read(mexico_path)
    calls = _taken(monkeypatch)
    grid = Equirect(512, 256)
    mask = gloffset.render(mexico, d, grid, radius=1.0)
    assert len(calls) == 1, "the simplified path was not taken"
    assert np.array_equal(mask, gloffset.render(mexico, d, grid, radius=1.0, backend="cpu"))


def test_lines_equal_reference_renderer(monkeypatch):
    """Coastlines as lines (no inside: the band is decided by distance alone)."""
    fc = json.loads((DATA / "countries_10m.geojson").read_text())
    lines = []
    for f in fc["features"]:
        if f["properties"].get("name") in ("Greenland", "Iceland", "Norway", "Sweden"):
            g = f["geometry"]
            polys = [g["coordinates"]] if g["type"] == "Polygon" else g["coordinates"]
            lines += [p[0] for p in polys]
    shape = gloffset.read({"type": "MultiLineString", "coordinates": lines})
    calls = _taken(monkeypatch)
    grid = Equirect(1024, 512)
    mask = gloffset.render(shape, 0.02, grid, radius=1.0)
    assert len(calls) == 1, "the simplified path was not taken"
    assert np.array_equal(mask, gloffset.render(shape, 0.02, grid, radius=1.0, backend="cpu"))


@pytest.mark.parametrize(
    "grid, d",
    [
        (Equirect(160, 110, bounds=(-12, 34, 20, 56)), 0.006),
        (Equirect(512, 256), -0.015),
        (Tile(2, 2, 1), 0.01),
    ],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_neighbours_sharing_borders(monkeypatch, grid, d):
    """Nine western European countries of countries_10m united: their shared borders
    cancel, so the simplified curve is the union's coast and outer border only."""
    names = {
        "France", "Spain", "Portugal", "Andorra", "Germany",
        "Belgium", "Luxembourg", "Netherlands", "Austria",
    }  # fmt: skip
    fc = json.loads((DATA / "countries_10m.geojson").read_text())
    feats = [f for f in fc["features"] if f["properties"].get("name") in names]
    assert len(feats) == len(names)
    shape = gloffset.read({"type": "FeatureCollection", "features": feats})
    separate = sum(len(gloffset.read(f).edges().a) for f in feats)
    assert len(shape.edges().a) < separate - 1000  # the shared borders are gone
    calls = _taken(monkeypatch)
    mask = gloffset.render(shape, d, grid, radius=1.0)
    assert len(calls) == 1, "the simplified path was not taken"
    assert np.array_equal(mask, gloffset.render(shape, d, grid, radius=1.0, backend="cpu"))
    assert 0 < np.count_nonzero(mask) < mask.size


@pytest.mark.parametrize(
    "name, grid, d",
    [
        ("Russia", Equirect(360, 180), 0.05),
        ("Russia", Equirect(300, 150, bounds=(150, 40, -150, 80)), -0.02),  # across 180
        ("Fiji", Equirect(200, 100, bounds=(170, -25, -170, -10)), 0.01),
        ("Antarctica", Equirect(360, 180), -0.05),  # round the pole
    ],
)
def test_antimeridian_and_pole(monkeypatch, world, name, grid, d):
    """Shapes across the antimeridian and round the pole (world_110m, simplified however
    little that saves: the mechanism, not its payoff): equal to the float64 renderer."""
    monkeypatch.setattr(simp, "MIN_ARCS", 10)
    monkeypatch.setattr(simp, "MAX_FRACTION", 1.0)
    shape = gloffset.read(world[name])
    calls = _taken(monkeypatch)
    mask = gloffset.render(shape, d, grid, radius=1.0)
    assert len(calls) == 1, "the simplified path was not taken"
    assert np.array_equal(mask, gloffset.render(shape, d, grid, radius=1.0, backend="cpu"))
    assert 0 < np.count_nonzero(mask) < mask.size
