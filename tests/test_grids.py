"""Grids: pixel centres, rho bounds, cube faces and mercator tiles, against the reference."""

import mercantile
import numpy as np
import pytest
from test_render import assert_matches_reference

import gloffset
from gloffset.geometry.sphere import angle, lonlat_to_xyz
from gloffset.grids import Cube, CubeFace, Equirect, InvalidGridError, Tile, locate


@pytest.mark.parametrize(
    "grid",
    [
        Equirect(300, 170, (170, -40, -150, 10)),
        Tile(4, 3, 5, 128),
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
    from gloffset.reference import contains_lonlat as contains

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
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
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
        Tile(23, 0, 0)
    with pytest.raises(InvalidGridError, match="face"):
        CubeFace(6, 10)
    with pytest.raises(InvalidGridError, match="positive"):
        Cube(0)
    assert Tile(1, 0, 0).children()[0] == Tile(2, 0, 0)
    assert np.allclose(lonlat_to_xyz(0, 0), CubeFace(0, 2)._point(1, 1))


def test_tile_limits_are_those_of_the_pyramid_and_the_cli(tmp_path):
    """One MAX_ZOOM (22) and one tile-size rule (a power of two, 16..4096) for Tile,
    pyramid and the CLI; each refused with gloffset's own error."""
    from gloffset.grids import mercator
    from gloffset.tiles.tiling import MAX_ZOOM, TilesError, parse_zooms, pyramid

    assert MAX_ZOOM == mercator.MAX_ZOOM == 22
    assert Tile(22, (1 << 22) - 1, 5).z == 22
    for z in (23, 30, -1):
        with pytest.raises(InvalidGridError, match="zoom must be from 0 to 22"):
            Tile(z, 0, 0)
    with pytest.raises(InvalidGridError, match="z must be an integer"):
        Tile(1.0, 0, 0)
    with pytest.raises(InvalidGridError, match="from 0 to 22"):
        Tile(22, 0, 0, 16).children()
    for size in (16, 64, 4096):
        assert Tile(3, 1, 2, size).shape == (size, size)
    for size in (300, 8, 8192, 0, 256.0, True):
        with pytest.raises(InvalidGridError, match="power of two from 16 to 4096"):
            Tile(0, 0, 0, size)
        with pytest.raises(TilesError, match="power of two from 16 to 4096"):
            pyramid({"type": "Point", "coordinates": [0, 0]}, 1e3, "0", tmp_path / "t", size=size)
    for zooms in ("0-23", (0, 23), 23, "3-2"):
        with pytest.raises(TilesError, match="MAX <= 22"):
            parse_zooms(zooms)
    assert issubclass(TilesError, InvalidGridError) and issubclass(TilesError, ValueError)
    assert issubclass(InvalidGridError, gloffset.GloffsetError)
    assert not list(tmp_path.iterdir())  # refused before any output


@pytest.mark.parametrize("z, x, y, size", [(0, 0, 0, 16), (5, 7, 14, 256), (14, 9000, 3000, 64)])
def test_tile_pixels_are_the_pyramid_quadtree(z, x, y, size):
    """Pixel (i, j) of tile z/x/y is, to the bit, the centre of tile z+P / x 2^P + i /
    y 2^P + j of the pyramid's quadtree (size = 2^P): one copy of the mercator maths."""
    from gloffset.grids.mercator import TilePyramid

    t = Tile(z, x, y, size)
    zp = z + size.bit_length() - 1
    jj, ii = np.meshgrid(np.arange(size), np.arange(size), indexing="ij")
    got = t.centers(t.n_levels - 1, jj, ii)
    want = TilePyramid(zp).centers(zp, y * size + jj, x * size + ii)
    assert np.array_equal(got, want)
    lon, lat = t.pixel_lonlat(ii, jj)
    assert np.abs(lonlat_to_xyz(lon, lat) - want).max() < 1e-15


def test_tile_pyramid_decision_rho_memo_same_values():
    """Rows looked up in the memo, computed with many distinct rows, or computed alone:
    the same values."""
    from gloffset.grids.mercator import TilePyramid

    rows = np.random.default_rng(2).integers(0, 1 << 12, 3000)
    many = TilePyramid(14).decision_rho(12, rows)  # more distinct rows than the memo takes
    memo = TilePyramid(14)
    few = np.concatenate([memo.decision_rho(12, rows[i : i + 100]) for i in range(0, 3000, 100)])
    again = memo.decision_rho(12, rows[:100])
    alone = [TilePyramid(14).decision_rho(12, r) for r in rows[:20]]
    assert np.array_equal(many, few) and np.array_equal(again, few[:100])
    assert np.array_equal(np.asarray(alone), few[:20])
