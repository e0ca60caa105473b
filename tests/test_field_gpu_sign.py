"""The GPU field's sign from the pixel shader (``shaders/field_pixels.comp`` with
``shaders/lib/field_sign.glsl``): equal to the float64 levels' inside test at distance 0
at every pixel, on real borders (a coast, the antimeridian, the pole, cube faces) and on
drawn corner cases; the levels walked only for the pixels the shader leaves undecided;
a shader that ignores the corners or flips the normals is caught."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DATA, SQUARE_WITH_HOLE, broken_field_pass

import gloffset
from gloffset.geometry.classes import CONTAINED
from gloffset.grids import Cube, Equirect, Tile
from gloffset.raster import field as field_mod
from gloffset.raster.vector.curves import classify_curves


def today(shape, grid) -> np.ndarray:
    """The levels' test at distance 0, per face."""
    faces = [classify_curves(shape, 0.0, f)[0] == CONTAINED for f in grid.faces]
    return np.stack(faces) if grid.n_faces > 1 else faces[0]


def gpu_inside(shape, grid, **kw) -> np.ndarray:
    return np.signbit(gloffset.distance_field(shape, grid, **kw).values)


def assert_same_sign(shape, grid, **kw):
    got, want = gpu_inside(shape, grid, **kw), today(shape, grid)
    bad = np.argwhere(got != want)
    assert len(bad) == 0, f"{len(bad)} pixels differ from the levels' sign, e.g. {bad[:3]}"
    return want


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


@pytest.fixture(scope="module")
def world110():
    return gloffset.read(DATA / "world_110m.geojson")


@pytest.fixture
def levels(monkeypatch):
    """The pixels handed to the levels' test (``levels_inside``), one count per call."""
    calls: list[int] = []
    inner = field_mod.levels_inside

    def spy(shape, grid, rows, cols):
        calls.append(len(rows))
        return inner(shape, grid, rows, cols)

    monkeypatch.setattr(field_mod, "levels_inside", spy)
    return calls


def test_mexico(mexico, levels):
    """A coast: the plate carree and tiles of z5 and z10 (inside Mexico: no level walked)."""
    for grid in (Equirect(512, 256), Tile(5, 7, 14), Tile(5, 6, 13)):
        want = assert_same_sign(mexico, grid)
        assert want.any() and not want.all()
    assert_same_sign(mexico, Tile(8, 55, 110))
    assert sum(levels) < 0.001 * 4 * 256 * 256  # nearly every pixel decided by the shader
    levels.clear()
    assert assert_same_sign(mexico, Tile(10, 234, 457)).all()
    assert levels == []  # every pixel decided: no level walked


def test_world_antimeridian_pole_and_cube(world110, levels):
    """Every country at 1:110m: shared borders cancel, tripoints, the antimeridian, the
    pole; a plate carree, a clamped one and every cube face."""
    assert_same_sign(world110, Equirect(1024, 512))
    assert sum(levels) < 0.001 * 1024 * 512  # nearly every pixel decided by the shader
    assert_same_sign(world110, Equirect(512, 256), max_distance=300e3)
    assert_same_sign(world110, Cube(64))
    assert_same_sign(world110, Tile(2, 0, 3))


@pytest.mark.slow
def test_every_country_10m():
    assert_same_sign(gloffset.read(DATA / "countries_10m.geojson"), Equirect(1024, 512))


def test_holes_reflex_corners_pinch_seam_and_untrusted(levels):
    """A lake, a reflex corner, a pinch, a seam at +-180 deg, vertices at pixel centres,
    and shapes the rule does not trust (a polygon beside a line, a bow tie)."""
    sq = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]
    cases = [
        SQUARE_WITH_HOLE,
        {
            "type": "MultiPolygon",
            "coordinates": [
                [[[0, 0], [20, 0], [20, 10], [10, 10], [10, 20], [0, 20], [0, 0]]],
                [[[20, 10], [30, 10], [30, 25], [20, 25], [20, 10]]],
                [[[-20, -20], [-10, -20], [-10, -10], [-20, -10], [-20, -20]]],
            ],
        },
        {"type": "Polygon", "coordinates": [[[170, -10], [180, -10], [180, 10], [170, 10]]]},
        {
            "type": "Polygon",
            "coordinates": [
                [[10.5, 20.5], [30.5, 20.5], [30.5, 40.5], [20.5, 30.5], [10.5, 40.5], [10.5, 20.5]]
            ],
        },
        {
            "type": "GeometryCollection",
            "geometries": [
                {"type": "Polygon", "coordinates": [sq]},
                {"type": "LineString", "coordinates": [[-5, 5], [15, 6]]},
            ],
        },
        {
            "type": "Polygon",
            "coordinates": [[[0, 0], [10, 10], [20, 0], [20, 20], [10, 10], [0, 20], [0, 0]]],
        },
    ]
    for geo in cases:
        shape = gloffset.read(geo)
        for grid in (Equirect(360, 180), Equirect(256, 128)):
            assert_same_sign(shape, grid)
    assert levels  # the pixels on the boundary, the seam's and the untrusted: the levels'


@pytest.mark.parametrize(
    "old, new",
    [
        # every corner taken as convex (the flags' corner bits ignored)
        ("uint corner = flags[k];", "uint corner = flags[k] & 16u;"),
        # the side of the foot flipped (the edges' normals, in double)
        ("got = pn > 0.0LF ? 4u : 0u;", "got = pn < 0.0LF ? 4u : 0u;"),
    ],
    ids=["corners-ignored", "side-flipped"],
)
def test_a_broken_sign_is_caught(mexico, world110, monkeypatch, tmp_path, old, new):
    cases = [(mexico, Tile(5, 7, 14)), (world110, Equirect(512, 256))]
    wants = [today(s, g) for s, g in cases]
    for (s, g), want in zip(cases, wants):
        assert (gpu_inside(s, g) == want).all()
    broken_field_pass(monkeypatch, tmp_path, old, new)
    for (s, g), want in zip(cases, wants):
        assert (gpu_inside(s, g) != want).sum() > 100
