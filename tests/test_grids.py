"""Grids: pixel centres, rho bounds, cube faces and mercator tiles, against the reference."""

import mercantile
import numpy as np
import pytest
from test_render import assert_matches_reference

import gloffset
from gloffset.grids import Cube, CubeFace, Equirect, InvalidGridError, Tile, locate
from gloffset.sphere import angle, lonlat_to_xyz


@pytest.mark.parametrize(
    "grid",
    [
        Equirect(300, 170, (170, -40, -150, 10)),
        Tile(4, 3, 5, 200),
        CubeFace(2, 150),
        CubeFace(5, 64),
    ],
)
def test_rho_covers_descendant_pixels_and_children(grid):
    last = grid.n_levels - 1
    h, w = grid.shape
    jj, ii = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    pix = grid.centers(last, jj, ii)
    for lev in range(last):
        b = grid.block(lev)
        c = grid.centers(lev, jj // b, ii // b)
        r = grid.rho_at(lev, jj // b, ii // b)
        assert np.all(angle(c, pix) <= r)
        # the bound of a cell covers each child's whole disc
        if lev + 1 < last:
            cj, ci = jj // (b // 2), ii // (b // 2)
            child = grid.centers(lev + 1, cj, ci)
            assert np.all(angle(c, child) + grid.rho_at(lev + 1, cj, ci) <= r * (1 + 1e-12))


def test_cube_round_trip_and_gl_table():
    rng = np.random.default_rng(1)
    r = rng.normal(size=(5000, 3))
    r /= np.linalg.norm(r, axis=1, keepdims=True)
    face, s, t = locate(r)
    back = np.stack([CubeFace(int(f), 4)._point(4 * s_, 4 * t_) for f, s_, t_ in zip(face, s, t)])
    assert np.abs(back - r).max() < 1e-15
    # the GL table: +X centre is (1, 0, 0); on +Z, s grows with x and t grows with -y
    assert np.allclose(CubeFace(0, 2)._point(1, 1), [1, 0, 0])
    f, s, t = locate(np.array([[0.1, -0.2, 1.0]]))
    assert f[0] == 4 and s[0] > 0.5 and t[0] > 0.5
    # pixel row j is at t = (j + 0.5) / N
    g = CubeFace(4, 8)
    f, s, t = locate(g.centers(g.n_levels - 1, 3, 5))
    assert (f, s, t) == (4, 5.5 / 8, 3.5 / 8)


def test_cube_render_shape_and_faces(world):
    m = gloffset.render(gloffset.read(world["Antarctica"]), 0.03, Cube(64), radius=1.0)
    assert m.shape == (6, 64, 64)
    assert m[5].any() and not m[4].any()  # the south pole is on -Z


@pytest.mark.parametrize(
    "lonlat, faces",
    [((45.0, 0.0), (0, 2)), ((45.0, 35.26438968), (0, 2, 4))],  # an edge, a corner
)
def test_cube_edges_and_corners(lonlat, faces):
    shape = gloffset.read({"type": "Point", "coordinates": list(lonlat)})
    for k in faces:
        mask, want = assert_matches_reference(shape, 0.05, CubeFace(k, 96))
        assert want.any()


def test_tiles_at_the_poles_and_antimeridian(world):
    # mercator stops at 85.0511 deg: the top row of z0 is just below it
    t = Tile(0, 0, 0)
    _, lat = t.pixel_lonlat(0, 0)
    assert 84.0 < lat < 85.0511
    assert_matches_reference(gloffset.read(world["Antarctica"]), 0.02, Tile(2, 1, 3))
    assert_matches_reference(gloffset.read(world["Russia"]), 0.01, Tile(3, 7, 1))  # at 180 deg
    assert_matches_reference(gloffset.read(world["Russia"]), 0.01, Tile(3, 0, 1))  # at -180 deg


def _on_boundary_tile(shape, d, z):
    """A tile at zoom z through which the offset boundary passes (found by bisection)."""
    from gloffset.reference import contains

    lon0 = -98.0

    def member(lat):
        return bool(contains(shape, lon0, lat, distance=d, radius=1.0))

    lo, hi = 18.5, -10.0  # inside Mexico at lo, far out at sea at hi
    assert member(lo) and not member(hi)
    for _ in range(80):  # bisection on membership: lo stays in, hi out
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if member(mid) else (lo, mid)
    t = mercantile.tile(lon0, lo, z)
    return Tile(t.z, t.x, t.y, size=64)


@pytest.mark.parametrize("z", [16, 19, 22])
@pytest.mark.parametrize("metres", [1.0, 1e3, 1e6])
def test_deep_zoom(mexico_path, z, metres):
    shape = gloffset.read(mexico_path)
    d = metres / gloffset.EARTH_RADIUS
    tile = _on_boundary_tile(shape, d, z)
    mask, want = assert_matches_reference(shape, d, tile)
    assert want.any() and not want.all(), "the boundary crosses the tile"


def test_grid_errors():
    with pytest.raises(InvalidGridError, match="does not exist"):
        Tile(2, 4, 0)
    with pytest.raises(InvalidGridError, match="zoom"):
        Tile(31, 0, 0)
    with pytest.raises(InvalidGridError, match="face"):
        CubeFace(6, 10)
    with pytest.raises(InvalidGridError, match="positive"):
        Cube(0)
    assert Tile(1, 0, 0).children()[0] == Tile(2, 0, 0)
    assert np.allclose(lonlat_to_xyz(0, 0), CubeFace(0, 2)._point(1, 1))
