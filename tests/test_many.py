"""Many distances at once: ``render_many``, ``mask_bands``, ``render -d D1,D2,...`` and
``tiles -d D1,D2,...`` against the single-distance runs, byte for byte."""

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import DATA, LINES, read_tiles
from PIL import Image

import gloffset
from gloffset.cli import main
from gloffset.errors import InvalidDistanceError
from gloffset.grids import Cube, Equirect


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


@pytest.fixture(scope="module")
def fiji(world):
    """Fiji (Natural Earth): polygons on both sides of the antimeridian."""
    return gloffset.read(world["Fiji"])


@pytest.mark.parametrize(
    "grid",
    [Equirect(512, 256), Equirect(300, 200, (-120, 10, -80, 35)), Cube(64)],
    ids=["globe", "box", "cube"],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_render_many_equals_single_renders(mexico, grid):
    distances = [127e3, -20e3, 0.0, 10e3, 500e3]
    masks = gloffset.render_many(mexico, distances, grid)
    assert len(masks) == len(distances)
    for d, m in zip(distances, masks):
        want = gloffset.render(gloffset.read(DATA / "mexico_10m.geojson"), d, grid)
        assert m.dtype == want.dtype and m.shape == want.shape
        assert np.array_equal(m, want), d


def test_render_many_across_the_antimeridian_and_with_units(fiji):
    grid = Equirect(400, 200, (170, -25, -170, -10))
    masks = gloffset.render_many(fiji, ["30km", "5km", "-2km"], grid)
    for d, m in zip((30e3, 5e3, -2e3), masks):
        assert np.array_equal(m, gloffset.render(fiji, d, grid))
    assert masks[0].any() and masks[0].sum() > masks[1].sum() > masks[2].sum()


def test_render_many_lines():
    grid = Equirect(256, 128)
    masks = gloffset.render_many(LINES, [300e3, 100e3], grid, backend="cpu")
    for d, m in zip((300e3, 100e3), masks):
        assert np.array_equal(m, gloffset.render(LINES, d, grid, backend="cpu"))


def test_mask_bands_index_the_smallest_distance_holding_each_pixel(mexico):
    grid = Equirect(512, 256)
    distances = [127e3, -20e3, 10e3]
    masks = gloffset.render_many(mexico, distances, grid)
    bands, order = gloffset.mask_bands(masks, distances)
    assert order == [1, 2, 0] and bands.dtype == np.uint8
    assert set(np.unique(bands)) == {0, 1, 2, 3}
    ordered = [masks[k] > 0 for k in order]
    for k in range(1, 4):
        want = ordered[k - 1] & ~np.any(ordered[: k - 1], axis=0)
        assert np.array_equal(bands == k, want)
    assert np.array_equal(bands == 0, ~np.any(ordered, axis=0))


@pytest.mark.parametrize(
    "distances, words",
    [
        ([], ["empty"]),
        ([10e3, 20e3, 10e3], ["10000.0 is given twice"]),
        (["10km", "10000m"], ["10000m is given twice", "10km"]),
        (["10 parsecs"], ["10 parsecs"]),
        (127e3, ["a list of distances", "gloffset.render"]),
        ([1e9], ["too large"]),
    ],
)
def test_render_many_refuses_bad_distance_lists(mexico, distances, words):
    with pytest.raises(InvalidDistanceError) as exc:
        gloffset.render_many(mexico, distances, Equirect(64, 32))
    for w in words:
        assert w in str(exc.value)


def test_render_many_refuses_angles_on_an_ellipsoid(mexico):
    with pytest.raises(InvalidDistanceError, match="'0.1deg' is an angle"):
        gloffset.render_many(mexico, ["10km", "0.1deg"], Equirect(64, 32), ellipsoid="WGS84")


def test_render_many_on_the_ellipsoid_equals_single_renders(mexico):
    grid = Equirect(200, 100, (-120, 10, -80, 35))
    masks = gloffset.render_many(mexico, ["50km", 127e3], grid, ellipsoid="WGS84")
    for d, m in zip((50e3, 127e3), masks):
        assert np.array_equal(m, gloffset.render(mexico, d, grid, ellipsoid="WGS84"))


def read_png(path):
    return np.asarray(Image.open(path))


def test_cli_render_writes_one_mask_per_distance(tmp_path, mexico_path):
    out = tmp_path / "m.png"
    r = run("render", mexico_path, "-d", "127km,10km,-20km", "--size", "512x256", "-o", out)
    assert r.exit_code == 0, r.output
    for text in ("127km", "10km", "-20km"):
        single = tmp_path / f"single{text}.png"
        r = run("render", mexico_path, "-d", text, "--size", "512x256", "-o", single)
        assert r.exit_code == 0, r.output
        many = tmp_path / f"m_{text}.png"
        assert many.read_bytes() == single.read_bytes(), text
        assert (tmp_path / f"m_{text}.pgw").read_text() == (
            tmp_path / f"single{text}.pgw"
        ).read_text()


def test_cli_render_many_geotiffs_and_cube_folders(tmp_path, mexico_path):
    pytest.importorskip("rasterio")
    out = tmp_path / "m.cog.tif"
    r = run("render", mexico_path, "-d", "50km,1deg", "--size", "256x128", "-o", out)
    assert r.exit_code == 0, r.output
    assert (tmp_path / "m_50km.cog.tif").is_file() and (tmp_path / "m_1deg.cog.tif").is_file()
    r = run(
        "render",
        mexico_path,
        "-d",
        "50km,100km",
        "--grid",
        "cube",
        "--size",
        "32",
        "-o",
        tmp_path / "cube",
    )
    assert r.exit_code == 0, r.output
    want = gloffset.render(gloffset.read(mexico_path), 100e3, Cube(32))
    for k, name in enumerate(("px", "nx", "py", "ny", "pz", "nz")):
        assert np.array_equal(read_png(tmp_path / "cube_100km" / f"{name}.png"), want[k])


def test_cli_render_bands(tmp_path, mexico_path):
    out = tmp_path / "bands.png"
    r = run(
        "render", mexico_path, "-d", "127km,10km,50km", "--bands", "--size", "512x256", "-o", out
    )
    assert r.exit_code == 0, r.output
    img = Image.open(out)
    assert "1=10km, 2=50km, 3=127km" in img.info["Description"]
    shape = gloffset.read(mexico_path)
    masks = [gloffset.render(shape, d, Equirect(512, 256)) for d in (10e3, 50e3, 127e3)]
    want, _ = gloffset.mask_bands(masks, [10e3, 50e3, 127e3])
    assert np.array_equal(np.asarray(img), want)


@pytest.mark.parametrize(
    "ext",
    [
        ".mbtiles",
        pytest.param(".pmtiles", marks=pytest.mark.slow),
        pytest.param("", marks=pytest.mark.slow),
    ],
)
def test_cli_tiles_writes_one_pyramid_per_distance(tmp_path, mexico_path, ext):
    if ext == ".pmtiles":
        pytest.importorskip("pmtiles")
    texts = ("300km", "-20km", "50km")
    many = tmp_path / "many"
    many.mkdir()
    r = run(
        "tiles",
        mexico_path,
        "-d",
        ",".join(texts),
        "-z",
        "0-4",
        "--tile-size",
        "64",
        "-o",
        many / f"m{ext}",
    )
    assert r.exit_code == 0, r.output
    for text in texts:
        got = many / (f"m_{text}{ext}" if ext else f"m/{text}")
        alone = tmp_path / text
        alone.mkdir()
        want = alone / got.name
        r = run("tiles", mexico_path, "-d", text, "-z", "0-4", "--tile-size", "64", "-o", want)
        assert r.exit_code == 0, r.output
        got_tiles, got_meta = read_tiles(got)
        want_tiles, want_meta = read_tiles(want)
        assert got_tiles and got_tiles == want_tiles, text
        assert got_meta == want_meta, text


def test_pyramids_equal_single_pyramids(tmp_path, mexico_path):
    outs = [tmp_path / "a.mbtiles", tmp_path / "b.mbtiles"]
    stats = gloffset.tiles.pyramids(mexico_path, [200e3, "-30km"], "0-3", outs, size=64)
    assert len(stats) == 2
    for dist, out in zip([200e3, "-30km"], outs):
        alone = tmp_path / "alone" / out.name
        alone.parent.mkdir(exist_ok=True)
        gloffset.tiles.pyramid(mexico_path, dist, "0-3", alone, size=64)
        assert read_tiles(out) == read_tiles(alone)


@pytest.mark.parametrize(
    "distances, outs, words",
    [
        ([1e5], ["a.mbtiles", "b.mbtiles"], ["one output per distance"]),
        ([1e5, 2e5], ["a.mbtiles", "a.mbtiles"], ["a different output"]),
        ([1e5, "3 furlongs"], ["a.mbtiles", "b.mbtiles"], ["3 furlongs"]),
    ],
)
def test_pyramids_refuse_bad_lists_before_writing(tmp_path, mexico_path, distances, outs, words):
    outs = [tmp_path / o for o in outs]
    with pytest.raises(gloffset.GloffsetError) as exc:
        gloffset.tiles.pyramids(mexico_path, distances, "0-2", outs, size=64)
    for w in words:
        assert w in str(exc.value)
    assert not any(o.exists() for o in outs)
