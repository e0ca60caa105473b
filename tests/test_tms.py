"""Tiles of OGC TileMatrixSets (gloffset.grids.TmsTile, pyramids with tms=) against the
float64 reference at the pixel centres that morecantile gives the tiles."""

import json

import morecantile
import numpy as np
import pytest
from conftest import SQUARE_WITH_HOLE
from test_render import boundary_distance

import gloffset
from gloffset.geometry.sphere import angle, lonlat_to_xyz
from gloffset.grids import InvalidGridError, Tile, TmsTile
from gloffset.grids.mercator import TilePyramid
from gloffset.grids.tms import tms_quad
from gloffset.reference import contains_xyz, distance_xyz
from gloffset.tiles import TilesError

EPS = 1e-3  # of a pixel: the band around the boundary where float32 may differ


def tms_centres(tms, z, x, y, step=1):
    """Lon/lat (degrees) of the pixel centres of tile z/x/y as the TMS defines them
    (morecantile's tile bounds in the TMS's CRS, pyproj to lon/lat), every ``step``-th
    row and column; and the pixel's size (radians, at most)."""
    t = morecantile.tms.get(tms) if isinstance(tms, str) else tms
    m = t.matrix(z)
    b = t.xy_bounds(x, y, z)
    i = np.arange(0, m.tileWidth, step) + 0.5
    j = np.arange(0, m.tileHeight, step) + 0.5
    xs = b.left + i * (b.right - b.left) / m.tileWidth
    ys = b.top - j * (b.top - b.bottom) / m.tileHeight
    xx, yy = np.meshgrid(xs, ys)
    crs = t.crs._pyproj_crs
    if crs.is_geographic:
        return xx, yy, np.radians(m.cellSize) * 1.5
    from pyproj import Transformer

    tr = Transformer.from_crs(crs, "OGC:CRS84", always_xy=True)
    lon, lat = tr.transform(xx, yy)
    return lon, lat, 2.0 * m.cellSize / 6.3e6


def assert_tile_matches_reference(shape, d, tms, z, x, y, step=1):
    """The render of TmsTile(tms, z, x, y) equals the reference at the TMS's pixel
    centres except within EPS of a pixel of the boundary; returns the reference."""
    grid = TmsTile(tms, z, x, y)
    mask = gloffset.render(shape, d, grid, radius=1.0)[::step, ::step]
    lon, lat, pix = tms_centres(tms, z, x, y, step)
    p = lonlat_to_xyz(lon.ravel(), lat.ravel())
    # the grid's own centres are the TMS's
    last = grid.n_levels - 1
    jj, ii = np.meshgrid(
        np.arange(0, grid.height, step), np.arange(0, grid.width, step), indexing="ij"
    )
    assert angle(grid.centers(last, jj, ii).reshape(-1, 3), p).max() < 1e-12
    want = contains_xyz(shape, p, d).reshape(mask.shape)
    bad = np.flatnonzero((mask.ravel() == 255) != want.ravel())
    if len(bad):
        eps = EPS * pix
        near_offset = np.abs(distance_xyz(shape, p[bad]) - abs(d)) <= eps
        near_edge = boundary_distance(shape, p[bad]) <= eps
        assert np.all(near_offset | near_edge), f"{len(bad)} pixels differ beyond the epsilon"
    return want


def frontier_tile(tms, shape_lonlat, z):
    """The tile of zoom z holding a point of the boundary (a frontier tile at d = 0)."""
    t = morecantile.tms.get(tms) if isinstance(tms, str) else tms
    lon, lat = shape_lonlat
    tile = t.tile(lon, lat, z)
    return tile.x, tile.y


# ------------------------------------------------------------------------------ grids
@pytest.mark.parametrize("z, x, y", [(0, 0, 0), (3, 2, 1), (12, 2000, 1500), (22, 5, 9)])
def test_web_mercator_quad_is_tile(z, x, y):
    t = TmsTile("WebMercatorQuad", z, x, y)
    assert t == Tile(z, x, y) and type(t) is Tile
    assert TmsTile(morecantile.tms.get("WebMercatorQuad"), z, x, y) == Tile(z, x, y)
    lon, lat, _ = tms_centres("WebMercatorQuad", z, x, y, step=17)
    gl, ga = t.pixel_lonlat(*np.meshgrid(np.arange(0, 256, 17), np.arange(0, 256, 17)))
    assert np.abs(gl - lon).max() < 1e-9 and np.abs(ga - lat).max() < 1e-9


def test_lonlat_tiles_are_the_tms_tiles():
    t = TmsTile("WorldCRS84Quad", 0, 1, 0)
    assert t.shape == (256, 256) and t.bounds == (0.0, -90.0, 180.0, 90.0)
    tms = morecantile.tms.get("WorldCRS84Quad")
    for z, x, y in [(0, 0, 0), (1, 3, 1), (7, 200, 33), (12, 8191, 0), (12, 0, 4095)]:
        g = TmsTile("WorldCRS84Quad", z, x, y)
        b = tms.xy_bounds(x, y, z)
        assert np.allclose(g.bounds, (b.left, b.bottom, b.right, b.top), rtol=0, atol=1e-12)
    # EPSG:4326's latitude-first axes give the same tiles
    assert TmsTile("WGS1984Quad", 5, 9, 3).bounds == TmsTile("WorldCRS84Quad", 5, 9, 3).bounds


def test_tms_errors():
    with pytest.raises(InvalidGridError, match="unknown TileMatrixSet 'Nope'.*WorldCRS84Quad"):
        TmsTile("Nope", 0, 0, 0)
    with pytest.raises(InvalidGridError, match="does not exist in WorldCRS84Quad"):
        TmsTile("WorldCRS84Quad", 1, 4, 0)
    with pytest.raises(InvalidGridError, match="zoom must be from 0 to 22"):
        TmsTile("WorldCRS84Quad", 23, 0, 0)
    with pytest.raises(InvalidGridError, match="not a quadtree"):
        TmsTile("CanadianNAD83_LCC", 1, 0, 0)
    with pytest.raises(InvalidGridError, match="no zoom 0"):
        TmsTile("UTM31WGS84Quad", 1, 0, 0)
    with pytest.raises(InvalidGridError, match="morecantile TileMatrixSet or its id"):
        TmsTile(3857, 0, 0, 0)


@pytest.mark.parametrize("z", [0, 1, 3])
def test_lonlat_quad_bounds_cover_tiles_and_descendants(z):
    """The pyramid's bound of each tile covers every pixel centre of it, and of its
    children's bounds (the list bound), on WorldCRS84Quad's quadtree."""
    quad = tms_quad("WorldCRS84Quad")
    p = TilePyramid(z + 4, quad=quad)  # 16 x 16 pixels a tile
    rows, cols = p.level_shape(z)
    jj, ii = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    c = p.centers(z, jj, ii)
    r = p.decision_rho(z, jj)
    pj, pi = np.meshgrid(np.arange(16), np.arange(16), indexing="ij")
    pixels = TilePyramid(z + 8, quad=quad)
    for k in range(rows * cols):
        j, i = divmod(k, cols)
        pix = p.centers(z + 4, j * 16 + pj, i * 16 + pi)
        assert angle(c[j, i], pix).max() <= r[j, i]
        # pixel (a, b) of the tile is, to the bit, tile (z + 8, 256 i + a, 256 j + b) of
        # the quadtree: one copy of the lon/lat maths
        g = TmsTile("WorldCRS84Quad", z, i, j)
        aj, ai = pj * 16 + 3, pi * 16 + 5
        want = pixels.centers(z + 8, j * 256 + aj, i * 256 + ai)
        assert np.array_equal(g.centers(g.n_levels - 1, aj, ai), want)
    kj, ki = np.meshgrid(np.arange(2 * rows), np.arange(2 * cols), indexing="ij")
    child = p.centers(z + 1, kj, ki)
    up = p.centers(z, kj // 2, ki // 2)
    assert np.all(angle(up, child) + p.rho_at(z + 1, kj, ki) <= p.rho_at(z, kj // 2, ki // 2))


# --------------------------------------------------------------- against the reference
@pytest.fixture(scope="module")
def shapes(world):
    names = ("Mexico", "Russia", "Antarctica", "Fiji", "Greenland")
    return {n: gloffset.read(world[n]) for n in names}


def _point_on(world, name, k=0):
    """A vertex of the outer ring of ``name``'s largest polygon (k: another one)."""
    geom = world[name]["geometry"]
    polys = [geom["coordinates"]] if geom["type"] == "Polygon" else geom["coordinates"]
    ring = max((p[0] for p in polys), key=len)
    return ring[(len(ring) // 3 + k * len(ring) // 2) % len(ring)]


FAST = [
    # (shape, d in rad, zoom): a frontier tile at each zoom, and whole zoom 0
    ("Mexico", 0.02, 0),
    ("Antarctica", 0.02, 1),
    ("Russia", 0.01, 3),  # up to the antimeridian
    ("Mexico", 0.0, 6),
    ("Mexico", -0.001, 9),
    ("Mexico", 2e-4, 12),
]


@pytest.mark.parametrize("name, d, z", FAST)
def test_world_crs84_tiles_against_reference(world, shapes, name, d, z):
    tms = "WorldCRS84Quad"
    x, y = frontier_tile(tms, _point_on(world, name), z)
    want = assert_tile_matches_reference(shapes[name], d, tms, z, x, y, step=2)
    assert z <= 1 or (want.any() and not want.all()), "the boundary crosses the tile"
    if z == 0:  # the other tile of zoom 0 too
        assert_tile_matches_reference(shapes[name], d, tms, 0, 1 - x, 0, step=2)


@pytest.mark.slow
@pytest.mark.parametrize("z", range(13))
@pytest.mark.parametrize("tms", ["WorldCRS84Quad", "WGS1984Quad"])
def test_lonlat_tms_every_zoom_against_reference(world, shapes, tms, z):
    """Three frontier tiles a zoom (Mexico, Russia, Antarctica) and their east neighbour."""
    rows, cols = 1 << z, 2 << z
    for name, d in (("Mexico", 0.003), ("Russia", -0.002), ("Antarctica", 0.0)):
        x, y = frontier_tile(tms, _point_on(world, name), z)
        assert_tile_matches_reference(shapes[name], d, tms, z, x, y)
        assert_tile_matches_reference(shapes[name], d, tms, z, (x + 1) % cols, min(y, rows - 1))


POLAR = [
    # (TMS, shape, d in rad, zoom): frontier tiles of the polar quads
    ("UPSAntarcticWGS84Quad", "Antarctica", 0.02, 0),
    ("UPSArcticWGS84Quad", "Russia", 0.01, 2),
    ("UPSAntarcticWGS84Quad", "Antarctica", -0.002, 6),
    ("UPSArcticWGS84Quad", "Greenland", 0.0, 9),
    ("UPSAntarcticWGS84Quad", "Antarctica", 1e-4, 12),
]


@pytest.mark.parametrize("tms, name, d, z", POLAR)
def test_polar_tiles_against_reference(world, shapes, tms, name, d, z):
    x, y = frontier_tile(tms, _point_on(world, name), z)
    want = assert_tile_matches_reference(shapes[name], d, tms, z, x, y, step=2)
    assert z == 0 or (want.any() and not want.all()), "the boundary crosses the tile"


@pytest.mark.slow
@pytest.mark.parametrize("z", range(13))
@pytest.mark.parametrize("tms", ["UPSArcticWGS84Quad", "UPSAntarcticWGS84Quad"])
def test_polar_tms_every_zoom_against_reference(world, shapes, tms, z):
    """Two frontier tiles a zoom and the neighbour east of each."""
    n = 1 << z
    names = ["Russia", "Greenland"] if "Arctic" in tms and "Ant" not in tms else ["Antarctica"]
    for name in names:
        for k, d in ((0, 0.003), (1, -0.001)):
            x, y = frontier_tile(tms, _point_on(world, name, k), z)
            assert_tile_matches_reference(shapes[name], d, tms, z, x, y)
            assert_tile_matches_reference(shapes[name], d, tms, z, min(x + 1, n - 1), y)


# --------------------------------------------------------------------------- pyramids
def _tile_bytes(path, z, x, y):
    f = path / str(z) / str(x) / f"{y}.png"
    return f.read_bytes() if f.exists() else None


@pytest.mark.parametrize("d", ["400km", pytest.param("-150km", marks=pytest.mark.slow)])
def test_world_crs84_pyramid_tiles_are_single_renders(tmp_path, d):
    """Every tile of the pyramid (z0-3, all 170) equals the render of its TmsTile; the
    folder holds the TileMatrixSet beside the tiles."""
    from gloffset.tiles.tiling.tilepaint import TileStyle

    out = tmp_path / "t"
    st = gloffset.tiles.pyramid(SQUARE_WITH_HOLE, d, "0-3", out, tms="WorldCRS84Quad")
    assert st.rendered > 0
    style = TileStyle()
    n = 0
    for z in range(4):
        for x in range(2 << z):
            for y in range(1 << z):
                mask = gloffset.render(SQUARE_WITH_HOLE, d, TmsTile("WorldCRS84Quad", z, x, y))
                assert _tile_bytes(out, z, x, y) == style.encode(mask > 0), (z, x, y)
                n += mask.any()
    assert n == st.written
    doc = json.loads((out / "tileMatrixSet.json").read_text())
    assert doc["id"] == "WorldCRS84Quad"
    meta = json.loads((out / "metadata.json").read_text())
    assert meta["tileMatrixSet"] == "WorldCRS84Quad"
    assert morecantile.TileMatrixSet.model_validate(doc).matrix(3).matrixWidth == 16


def test_world_crs84_pyramid_real_border(tmp_path, mexico_path):
    """Mexico (1:10m) at 127 km, z4-6: the pyramid's frontier tiles (batched levels) equal
    single-tile renders."""
    from gloffset.tiles.tiling.tilepaint import TileStyle

    out = tmp_path / "m"
    shape = gloffset.read(mexico_path)
    st = gloffset.tiles.pyramid(shape, "127km", "4-6", out, tms="WorldCRS84Quad")
    assert st.rendered > 10
    style = TileStyle()
    for z in range(4, 7):
        for xdir in (out / str(z)).iterdir():
            for f in xdir.iterdir():
                x, y = int(xdir.name), int(f.stem)
                mask = gloffset.render(shape, "127km", TmsTile("WorldCRS84Quad", z, x, y))
                assert f.read_bytes() == style.encode(mask > 0), (z, x, y)


@pytest.mark.parametrize(
    "tms, name, d",
    [
        ("UPSAntarcticWGS84Quad", "Antarctica", "300km"),
        pytest.param("UPSArcticWGS84Quad", "Greenland", "-100km", marks=pytest.mark.slow),
    ],
)
def test_polar_pyramid_tiles_are_single_renders(tmp_path, world, tms, name, d):
    """Every tile of a polar pyramid (z0-3, all 85) equals the render of its TmsTile."""
    from gloffset.tiles.tiling.tilepaint import TileStyle

    shape = gloffset.read(world[name])
    out = tmp_path / "p"
    st = gloffset.tiles.pyramid(shape, d, "0-3", out, tms=tms)
    assert st.rendered > 5
    style = TileStyle()
    for z in range(4):
        for x in range(1 << z):
            for y in range(1 << z):
                mask = gloffset.render(shape, d, TmsTile(tms, z, x, y))
                assert _tile_bytes(out, z, x, y) == style.encode(mask > 0), (z, x, y)
    assert json.loads((out / "tileMatrixSet.json").read_text())["id"] == tms
    # the bounds metadata in lon/lat (pyproj's), the pole inside the tiles written
    w, s, e, n = (
        float(v) for v in json.loads((out / "metadata.json").read_text())["bounds"].split(",")
    )
    if "Antarctic" in tms:  # round the pole
        assert (w, s, e) == (-180.0, -90.0, 180.0) and -70 < n < 0
    else:  # Greenland's tiles
        assert -180 <= w < e <= 180 and 30 < s < n <= 90


@pytest.mark.parametrize("z, x, y", [(0, 0, 0), (2, 1, 2), (5, 15, 16), (9, 300, 200)])
def test_projected_quad_bounds_cover_the_tiles(z, x, y):
    """A polar quad's tile bound covers every pixel centre of the tile (as TmsTile has
    them), and its list bound the children's discs."""
    from gloffset.grids.tms import ProjectedQuadLevels

    quad = tms_quad("UPSArcticWGS84Quad")
    levels = ProjectedQuadLevels(quad, z + 1)
    t = TmsTile(quad.id, z, x, y)
    jj, ii = np.meshgrid(np.arange(0, 256, 5), np.arange(0, 256, 5), indexing="ij")
    pix = t.centers(t.n_levels - 1, jj, ii)
    c = levels.centers(z, y, x)
    assert angle(c, pix).max() <= levels.decision_rho(z, y, x)
    if z >= 5:  # small tiles, the scale nearly constant over each: the bound is tight
        assert angle(c, pix).max() > 0.5 * levels.decision_rho(z, y, x)
    for dj in (0, 1):
        for di in (0, 1):
            cj, ci = 2 * y + dj, 2 * x + di
            far = angle(c, levels.centers(z + 1, cj, ci)) + levels.rho_at(z + 1, cj, ci)
            assert far <= levels.rho_at(z, y, x)


@pytest.mark.parametrize(
    "out, tms, match",
    [
        ("t.mbtiles", "WorldCRS84Quad", r"\.mbtiles holds web-mercator tiles only"),
        ("t.pmtiles", "UPSAntarcticWGS84Quad", r"\.pmtiles holds web-mercator tiles only"),
        ("t", "Nope", "unknown TileMatrixSet 'Nope'"),
        ("t", "CanadianNAD83_LCC", "not a quadtree"),
        ("t", "NZTM2000Quad", "need a bound of its projection"),
    ],
)
def test_pyramid_tms_refused_before_any_output(tmp_path, out, tms, match):
    with pytest.raises(TilesError, match=match):
        gloffset.tiles.pyramid(SQUARE_WITH_HOLE, "100km", "0-2", tmp_path / out, tms=tms)
    assert not list(tmp_path.iterdir())


# ------------------------------------------------------------------------- the command
def _cli(*args):
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    env = {**os.environ, "PYTHONPATH": str(root)}
    cmd = [sys.executable, "-m", "gloffset", *map(str, args)]
    return subprocess.run(cmd, capture_output=True, env=env, timeout=300)


@pytest.mark.parametrize(
    "tms, out, words",
    [
        ("UPSAntarcticWGS84Quad", "t.mbtiles", [".mbtiles holds web-mercator tiles only"]),
        ("UPSArcticWGS84Quad", "t.pmtiles", [".pmtiles holds web-mercator tiles only"]),
        ("Nope", "t", ["unknown TileMatrixSet 'Nope'", "WorldCRS84Quad"]),
        ("WGS1984Quad", "t", ["tiles of WGS1984Quad are 256 pixels, not 512"]),
    ],
)
def test_cli_tms_refused_before_any_work(tmp_path, mexico_path, tms, out, words):
    from conftest import assert_one_line_error

    extra = ["--tile-size", "512"] if tms == "WGS1984Quad" else []
    proc = _cli(
        "tiles", mexico_path, "-d", "127km", "-z", "0-8", "--tms", tms, *extra, "-o", tmp_path / out
    )
    assert_one_line_error(proc, *words)
    assert not list(tmp_path.iterdir())


def test_cli_tms_writes_the_folder_and_its_tms(tmp_path, mexico_path):
    out = tmp_path / "out"
    proc = _cli(
        "tiles", mexico_path, "-d", "127km", "-z", "0-2", "--tms", "WorldCRS84Quad", "-o", out
    )
    assert proc.returncode == 0, proc.stderr.decode()
    assert json.loads((out / "tileMatrixSet.json").read_text())["id"] == "WorldCRS84Quad"
    shape = gloffset.read(mexico_path)
    from gloffset.tiles.tiling.tilepaint import TileStyle

    for z, x, y in [(0, 0, 0), (1, 0, 0), (2, 1, 1), (2, 0, 0)]:
        mask = gloffset.render(shape, "127km", TmsTile("WorldCRS84Quad", z, x, y))
        assert _tile_bytes(out, z, x, y) == TileStyle().encode(mask > 0)
    assert (out / "2" / "1" / "1.png").exists()  # Mexico's tile at zoom 2


@pytest.mark.parametrize("tms", ["WorldCRS84Quad", "UPSArcticWGS84Quad"])
def test_field_pyramid_of_a_tms(tmp_path, world, tms):
    """--field --tms: every tile of z0-1 is the distance field of its TmsTile (to the
    metre), with the TileMatrixSet beside the tiles; MBTiles refused before any work."""
    from gloffset.tiles.tiling.fieldtiles import decode_field, field_pyramid

    shape = gloffset.read(world["Greenland"])
    out = tmp_path / "f"
    n = field_pyramid(shape, "0-1", out, tms=tms)
    rows, cols = tms_quad(tms).matrix_shape(1)
    assert n == rows * cols * 5 // 4
    for z, x, y in [(0, 0, 0), (1, cols - 1, rows - 1), (1, 0, 0)]:
        f = gloffset.distance_field(shape, TmsTile(tms, z, x, y))
        got = decode_field(_tile_bytes(out, z, x, y))
        assert np.abs(got - np.clip(f.values, -8388608, 8388607)).max() <= 1.0  # to the metre
    assert json.loads((out / "tileMatrixSet.json").read_text())["id"] == tms
    meta = json.loads((out / "metadata.json").read_text())
    w, s, e, n_ = (float(v) for v in meta["bounds"].split(","))
    assert -180 <= w < e <= 180 and -90 <= s < n_ <= 90
    with pytest.raises(TilesError, match="web-mercator tiles only"):
        field_pyramid(shape, "0-1", tmp_path / "f.mbtiles", tms=tms)
    assert not (tmp_path / "f.mbtiles").exists()


def test_web_mercator_quad_pyramid_is_the_default(tmp_path):
    """tms="WebMercatorQuad" is today's pyramid, MBTiles included, byte for byte."""
    from conftest import read_mbtiles

    a, b = tmp_path / "a.mbtiles", tmp_path / "b.mbtiles"
    gloffset.tiles.pyramid(SQUARE_WITH_HOLE, "300km", "0-3", a)
    gloffset.tiles.pyramid(SQUARE_WITH_HOLE, "300km", "0-3", b, tms="WebMercatorQuad")
    (ta, ma), (tb, mb) = read_mbtiles(a), read_mbtiles(b)
    assert ta == tb and len(ta) > 10
    assert ma["gloffset"] == mb["gloffset"]


def test_a_custom_polar_tms(tmp_path, world, shapes):
    """A TileMatrixSet given as a morecantile object, not registered (a NASA-style
    EPSG:3031 quad): its tiles against the reference, its pyramid against single renders."""
    import pyproj

    from gloffset.tiles.tiling.tilepaint import TileStyle

    half = 4194304.0
    tms = morecantile.TileMatrixSet.custom(
        [-half, -half, half, half], pyproj.CRS("EPSG:3031"), id="Antarctic3031", maxzoom=12
    )
    x, y = frontier_tile(tms, _point_on(world, "Antarctica"), 4)
    want = assert_tile_matches_reference(shapes["Antarctica"], 0.01, tms, 4, x, y, step=2)
    assert want.any() and not want.all()
    out = tmp_path / "c"
    gloffset.tiles.pyramid(shapes["Antarctica"], "200km", "0-2", out, tms=tms)
    for z in range(3):
        for x in range(1 << z):
            for y in range(1 << z):
                mask = gloffset.render(shapes["Antarctica"], "200km", TmsTile(tms, z, x, y))
                assert _tile_bytes(out, z, x, y) == TileStyle().encode(mask > 0)
    assert json.loads((out / "tileMatrixSet.json").read_text())["id"] == "Antarctic3031"


@pytest.mark.parametrize(
    "tms, zooms", [(None, (0, 3)), ("WorldCRS84Quad", (0, 3)), ("WorldCRS84Quad", (2, 4))]
)
def test_field_progress_shows_the_zoom_of_the_tms_tiles(tms, zooms):
    """`gloffset tiles --field --tms`'s bar: the zoom shown after tile k is the zoom of
    the k-th tile the field pyramid writes, and the total its tiles (WorldCRS84Quad has
    2 x 1 tiles at zoom 0, not web mercator's 1)."""
    from gloffset.cli.tiles import _field_progress
    from gloffset.tiles.tiling.fieldtiles import _tiles, matrix_shapes

    quad = None if tms is None else tms_quad(tms)
    zlo, zhi = zooms
    order = [z for z, _, _ in _tiles(matrix_shapes(quad, zhi), zlo, zhi)]
    shown = []
    progress = _field_progress(shown.append, zooms, quad)
    assert shown[0].total == len(order) and shown[0].done == 0 and shown[0].zoom == zlo
    for k in range(1, len(order) + 1):
        progress(k, len(order))
    assert [p.zoom for p in shown[1:]] == order
    assert shown[-1].done == shown[-1].total == len(order)


def test_projected_check_domain_switch():
    """A UPS quad's corner tile lies outside UPS's area of use: ``Projected`` refuses its
    bounds by default, takes them with ``check_domain=False`` (as ``TmsTile`` makes its
    tiles), and its pixels are the TMS's there too."""
    b = morecantile.tms.get("UPSArcticWGS84Quad").xy_bounds(0, 0, 2)
    bounds = (b.left, b.bottom, b.right, b.top)
    with pytest.raises(InvalidGridError, match="outside the domain"):
        gloffset.grids.Projected(256, 256, crs="EPSG:5041", bounds=bounds)
    g = gloffset.grids.Projected(256, 256, crs="EPSG:5041", bounds=bounds, check_domain=False)
    t = TmsTile("UPSArcticWGS84Quad", 2, 0, 0)
    assert g == t and type(t) is gloffset.grids.Projected
    lon, lat, _ = tms_centres("UPSArcticWGS84Quad", 2, 0, 0, step=51)
    jj, ii = np.meshgrid(np.arange(0, 256, 51), np.arange(0, 256, 51), indexing="ij")
    got = g.centers(g.n_levels - 1, jj, ii)
    assert angle(got.reshape(-1, 3), lonlat_to_xyz(lon.ravel(), lat.ravel())).max() < 1e-12


# ------------------------------------------------- Lambert azimuthal equal-area pyramids
LAEA = "EuropeanETRS89_LAEAQuad"


def _max_secant_stretch(crs, box, n=201):
    """The largest angle per CRS unit between neighbouring points (rows, columns and
    diagonals) of an n x n sample of ``box``: what a bound of the inverse's stretch
    must reach."""
    import pyproj

    crs = pyproj.CRS(crs)
    tr = pyproj.Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True)
    xs, ys = np.linspace(box[0], box[2], n), np.linspace(box[1], box[3], n)
    lon, lat = tr.transform(*np.meshgrid(xs, ys))
    p = lonlat_to_xyz(lon, lat)
    h, v = xs[1] - xs[0], ys[1] - ys[0]
    return max(
        (angle(p[:, 1:], p[:, :-1]) / h).max(),
        (angle(p[1:], p[:-1]) / v).max(),
        (angle(p[1:, 1:], p[:-1, :-1]) / np.hypot(h, v)).max(),
        (angle(p[1:, :-1], p[:-1, 1:]) / np.hypot(h, v)).max(),
    )


@pytest.mark.parametrize(
    "crs, box",
    [
        ("EPSG:3035", (2.0e6, 1.0e6, 6.5e6, 5.5e6)),  # the quad's extent
        ("EPSG:3035", (4.3e6, 3.2e6, 4.4e6, 3.3e6)),  # at the centre
        ("+proj=laea +lat_0=90 +lon_0=0 +ellps=WGS84", (-4e6, -4e6, 4e6, 4e6)),  # polar
        ("+proj=laea +lat_0=0 +lon_0=20 +ellps=WGS84", (-5e6, -5e6, 5e6, 5e6)),  # equatorial
        ("+proj=laea +lat_0=-40 +lon_0=20 +ellps=clrk66 +x_0=1e5", (-5e6, -4e6, 6e6, 5e6)),
        ("+proj=laea +lat_0=45 +lon_0=0 +R=6371000 +units=km", (-5e3, -5e3, 5e3, 5e3)),
    ],
)
def test_laea_bound_covers_the_stretch(crs, box):
    """The LAEA bound is above every secant slope of pyproj's inverse over the box, and
    within 1 % of the largest (the formula is tight)."""
    import pyproj

    from gloffset.grids.stretch import azimuthal_lipschitz

    k = azimuthal_lipschitz(pyproj.CRS(crs), box)
    m = _max_secant_stretch(crs, box)
    assert m <= k <= 1.01 * m


def test_laea_bound_authalic_facts_and_refusals():
    """The authalic latitude's two facts the LAEA bound rests on, at every latitude (GRS80):
    dphi/dbeta is largest at the equator, q_p / (2 (1 - e^2)), and |beta| <= |phi|;
    no bound for other CRSs, or a box reaching too near the antipode."""
    import pyproj

    from gloffset.grids.stretch import _authalic_q, azimuthal_lipschitz, eccentricity_squared

    crs = pyproj.CRS("EPSG:3035")
    es = eccentricity_squared(crs)
    qp = _authalic_q(1.0, es)
    phi = np.radians(np.linspace(0.0, 89.99, 20001))
    s = np.sin(phi)
    e = np.sqrt(es)
    q = (1 - es) * (s / (1 - es * s * s) - np.log((1 - e * s) / (1 + e * s)) / (2 * e))
    sb = q / qp
    cb = np.sqrt((1 - sb) * (1 + sb))
    dbeta = 2 * (1 - es) * np.cos(phi) / ((1 - es * s * s) ** 2 * qp * cb)
    assert (1.0 / dbeta).max() <= qp / (2 * (1 - es)) * (1 + 1e-12)
    assert np.all(np.arcsin(sb) <= phi + 1e-15)
    assert azimuthal_lipschitz(pyproj.CRS("EPSG:3031"), (-1e6, -1e6, 1e6, 1e6)) is None
    assert azimuthal_lipschitz(crs, (-9e6, -9e6, 1.6e7, 1.6e7)) is None  # near the antipode


@pytest.mark.parametrize("z, x, y", [(0, 0, 0), (2, 3, 0), (3, 0, 7), (5, 31, 31), (9, 300, 200)])
def test_laea_quad_bounds_cover_the_tiles(z, x, y):
    """EuropeanETRS89_LAEAQuad's tile bound covers every pixel centre of the tile (corner
    tiles, where the stretch is largest, included), and its list bound the children's."""
    from gloffset.grids.tms import ProjectedQuadLevels

    quad = tms_quad(LAEA)
    levels = ProjectedQuadLevels(quad, z + 1)
    t = TmsTile(LAEA, z, x, y)
    jj, ii = np.meshgrid(np.arange(0, 256, 5), np.arange(0, 256, 5), indexing="ij")
    pix = t.centers(t.n_levels - 1, jj, ii)
    c = levels.centers(z, y, x)
    got = angle(c, pix).max()
    assert got <= levels.decision_rho(z, y, x) and got > 0.9 * levels.decision_rho(z, y, x)
    for dj in (0, 1):
        for di in (0, 1):
            cj, ci = 2 * y + dj, 2 * x + di
            far = angle(c, levels.centers(z + 1, cj, ci)) + levels.rho_at(z + 1, cj, ci)
            assert far <= levels.rho_at(z, y, x)


def _europe(path, names):
    fc = json.loads(path.read_text())
    feats = [f for f in fc["features"] if f["properties"]["name"] in names]
    assert len(feats) == len(names)
    return gloffset.read({"type": "FeatureCollection", "features": feats})


@pytest.mark.slow
def test_laea_pyramid_every_tile_is_a_single_render(tmp_path):
    """Every tile of a LAEA Europe pyramid (z0-3, all 85) equals the render of its
    TmsTile: the tiles decided inside (written without rendering) and outside (skipped)
    at zoom 3 too."""
    from conftest import DATA

    from gloffset.tiles.tiling.tilepaint import TileStyle

    shape = _europe(DATA / "world_110m.geojson", ["France", "Germany", "Italy", "Spain"])
    out = tmp_path / "eu"
    st = gloffset.tiles.pyramid(shape, "700km", "0-3", out, tms=LAEA)
    style = TileStyle()
    for z in range(4):
        for x in range(1 << z):
            for y in range(1 << z):
                mask = gloffset.render(shape, "700km", TmsTile(LAEA, z, x, y))
                assert _tile_bytes(out, z, x, y) == style.encode(mask > 0), (z, x, y)
    assert st.zooms[3]["contained"] > 5 and st.zooms[3]["outside"] > 5 and st.inside > 5
    assert json.loads((out / "tileMatrixSet.json").read_text())["id"] == LAEA


@pytest.mark.slow
def test_laea_pyramid_real_border_10m(tmp_path):
    """France, Spain and Germany at 1:10m, 300 km, z3-4: every tile written equals its
    single render (frontier tiles and inside ones), and tiles not written render empty
    (a sample of them)."""
    from conftest import DATA

    from gloffset.tiles.tiling.tilepaint import TileStyle

    shape = _europe(DATA / "countries_10m.geojson", ["France", "Spain", "Germany"])
    out = tmp_path / "eu"
    st = gloffset.tiles.pyramid(shape, "300km", "3-4", out, tms=LAEA)
    assert st.rendered > 10 and st.inside > 0, st
    style = TileStyle()
    written = set()
    for z in range(3, 5):
        for xdir in (out / str(z)).iterdir():
            for f in xdir.iterdir():
                x, y = int(xdir.name), int(f.stem)
                written.add((z, x, y))
                mask = gloffset.render(shape, "300km", TmsTile(LAEA, z, x, y))
                assert f.read_bytes() == style.encode(mask > 0), (z, x, y)
    rng = np.random.default_rng(3)
    absent = [
        (z, x, y)
        for z in range(3, 5)
        for x in range(1 << z)
        for y in range(1 << z)
        if (z, x, y) not in written
    ]
    # the absent tiles nearest the written ones first: those are the ones at risk
    near = [
        t
        for t in absent
        if any((t[0], t[1] + a, t[2] + b) in written for a in (-1, 1) for b in (-1, 0, 1))
    ]
    for k in rng.choice(len(near), size=min(12, len(near)), replace=False):
        z, x, y = near[k]
        assert not gloffset.render(shape, "300km", TmsTile(LAEA, z, x, y)).any(), (z, x, y)


@pytest.mark.slow
def test_cli_laea_tiles_and_field(tmp_path, world):
    """``gloffset tiles --tms EuropeanETRS89_LAEAQuad``, raster and --field, z0-1."""
    from gloffset.tiles.tiling.fieldtiles import decode_field
    from gloffset.tiles.tiling.tilepaint import TileStyle

    src = tmp_path / "fr.geojson"
    src.write_text(json.dumps(world["France"]))
    shape = gloffset.read(world["France"])
    out, fout = tmp_path / "t", tmp_path / "f"
    proc = _cli("tiles", src, "-d", "300km", "-z", "0-1", "--tms", LAEA, "-o", out)
    assert proc.returncode == 0, proc.stderr.decode()
    proc = _cli("tiles", src, "--field", "-z", "0-1", "--tms", LAEA, "-o", fout)
    assert proc.returncode == 0, proc.stderr.decode()
    for z, x, y in [(0, 0, 0), (1, 0, 0), (1, 0, 1), (1, 1, 1)]:
        mask = gloffset.render(shape, "300km", TmsTile(LAEA, z, x, y))
        assert _tile_bytes(out, z, x, y) == TileStyle().encode(mask > 0)
        f = gloffset.distance_field(shape, TmsTile(LAEA, z, x, y))
        assert np.abs(decode_field(_tile_bytes(fout, z, x, y)) - f.values).max() <= 1.0
    assert json.loads((fout / "tileMatrixSet.json").read_text())["id"] == LAEA
