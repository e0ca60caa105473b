"""Vector tile pyramids (``gloffset tiles --format mvt``): tiles equal to the on-demand
ones, the metadata's ``vector_layers``, one stored copy of the inside square, GDAL's MVT
driver, and the refusals."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import assert_one_line_error, read_mbtiles

import gloffset

mvt = pytest.importorskip("mapbox_vector_tile")
pytest.importorskip("shapely")

from gloffset.mvt import vector_tile  # noqa: E402
from gloffset.mvt.pyramid import mvt_pyramid  # noqa: E402


def run_cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "gloffset", "tiles", *map(str, args)],
        capture_output=True,
        timeout=600,
    )


def read_pbf_dir(path):
    out = {}
    for f in path.rglob("*.pbf"):
        z, x = int(f.parent.parent.name), int(f.parent.name)
        out[(z, x, int(f.stem))] = f.read_bytes()
    return out


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


@pytest.fixture(scope="module")
def pyramid_pmtiles(tmp_path_factory, mexico_path):
    pytest.importorskip("pmtiles")
    out = tmp_path_factory.mktemp("mvt") / "mexico.pmtiles"
    proc = run_cli(mexico_path, "-d", "127km", "-z", "0-6", "--format", "mvt", "-o", out)
    assert proc.returncode == 0, proc.stderr.decode()
    return out


def test_pyramid_tiles_equal_the_on_demand_ones(pyramid_pmtiles, mexico):
    from gloffset.tiles.store.pmtiles import read_pmtiles

    meta, tiles = read_pmtiles(pyramid_pmtiles)
    assert meta["format"] == "pbf"
    (vl,) = meta["vector_layers"]
    assert vl["id"] == "mexico_10m" and set(vl["fields"]) == {"distance_m", "distance"}
    assert len(tiles) > 20
    frontier = local = 0
    # every tile to zoom 4, a seeded sample of 40 below (every one: the slow deep check)
    keys = sorted(tiles)
    deep = [k for k in keys if k[0] > 4]
    rng = np.random.default_rng(1)
    pick = [deep[i] for i in rng.choice(len(deep), min(40, len(deep)), replace=False)]
    for z, x, y in [k for k in keys if k[0] <= 4] + pick:
        data = tiles[(z, x, y)]
        # each on-demand tile at a distance not kept: most resolve only the edges near
        # them (LocalBoundary), where the pyramid cut every tile from the whole offset
        mexico.derived.mvt_boundaries.clear()
        want = vector_tile(mexico, "127km", z, x, y, layer="mexico_10m")
        local += len(mexico.derived.mvt_boundaries) == 0
        assert data == want, (z, x, y)
        feats = mvt.decode(data)["mexico_10m"]["features"]
        assert len(feats) == 1
        polys = feats[0]["geometry"]["coordinates"]
        frontier += not (feats[0]["geometry"]["type"] == "Polygon" and len(polys[0]) == 5)
    assert frontier > 10
    assert local > 10
    # every tile the region reaches is there: the frontier and inside tiles of zoom 6
    z6 = {(x, y) for z, x, y in tiles if z == 6}
    assert (14, 28) in z6  # Mexico City's


def test_pmtiles_stores_the_inside_square_once(pyramid_pmtiles):
    from pmtiles.reader import MmapSource, Reader

    with open(pyramid_pmtiles, "rb") as f:
        h = Reader(MmapSource(f)).header()
    assert h["tile_type"].name == "MVT"
    assert h["tile_contents_count"] < h["addressed_tiles_count"]


@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_mbtiles_and_folder_with_several_distances(tmp_path, mexico_path, mexico):
    out = tmp_path / "m.mbtiles"
    proc = run_cli(mexico_path, "-d", "50km,-20km", "-z", "3-4", "--format", "mvt", "-o", out)
    assert proc.returncode == 0, proc.stderr.decode()
    for text in ("50km", "-20km"):
        tiles, meta = read_mbtiles(tmp_path / f"m_{text}.mbtiles")
        assert meta["format"] == "pbf"
        assert json.loads(meta["json"])["vector_layers"][0]["id"] == "mexico_10m"
        assert tiles and min(z for z, _, _ in tiles) == 3
        for (z, x, y), data in list(tiles.items())[:6]:
            assert gzip.decompress(data) == vector_tile(mexico, text, z, x, y, layer="mexico_10m")
    folder = tmp_path / "xyz"
    proc = run_cli(mexico_path, "-d", "50km", "-z", "4", "--format", "mvt", "-o", folder)
    assert proc.returncode == 0, proc.stderr.decode()
    tiles = read_pbf_dir(folder)
    assert tiles
    for (z, x, y), data in tiles.items():
        assert data == vector_tile(mexico, "50km", z, x, y, layer="mexico_10m")
    assert json.loads(json.loads((folder / "metadata.json").read_text())["json"])["vector_layers"]


def test_gdal_opens_the_mbtiles_as_vector(tmp_path, mexico):
    pyogrio = pytest.importorskip("pyogrio")
    if "MVT" not in pyogrio.list_drivers():
        pytest.skip("this GDAL has no MVT driver")
    out = tmp_path / "g.mbtiles"
    mvt_pyramid(mexico, "127km", (0, 4), out, layer="coast")
    layers = pyogrio.list_layers(out)
    assert "coast" in [str(n) for n in layers[:, 0]]
    df = pyogrio.read_dataframe(out, layer="coast")
    assert len(df) > 0
    assert set(df.geometry.geom_type) <= {"Polygon", "MultiPolygon"}
    assert (df["distance_m"] == 127000.0).all()


@pytest.mark.parametrize(
    "args,words",
    [
        (["--extent", "4000", "-o", "t.pmtiles"], ["power of two"]),
        (["--buffer", "-3", "-o", "t.pmtiles"], ["buffer"]),
        (["-o", "t.png"], ["mvt", ".png"]),
        (["--outline", "red", "-o", "t.pmtiles"], ["--outline"]),
    ],
)
def test_cli_refusals(tmp_path, mexico_path, args, words):
    args = [a if not a.startswith("t.") else tmp_path / a for a in args]
    proc = run_cli(mexico_path, "-d", "127km", "-z", "0-3", "--format", "mvt", *args)
    assert_one_line_error(proc, *words)
    assert not any(tmp_path.iterdir())


def _pyramid_tiles(tmp_path, shape, distance, zooms, name):
    from gloffset.tiles.store.pmtiles import read_pmtiles

    out = tmp_path / f"{name}.pmtiles"
    mvt_pyramid(shape, distance, zooms, out, layer=name)
    return read_pmtiles(out)[1]


@pytest.mark.parametrize(
    "name,distance,zooms",
    [("Fiji", "127km", (0, 5)), ("Russia", "-150km", (0, 3))],
)
def test_pyramid_equals_on_demand_across_the_antimeridian(tmp_path, world, name, distance, zooms):
    # the pyramid finds each tile's arcs from the zoom's points (round the world's seam);
    # the on-demand tile from the arcs' caps
    shape = gloffset.read(world[name])
    tiles = _pyramid_tiles(tmp_path, shape, distance, zooms, name)
    assert {x for z, x, _ in tiles if z == zooms[1]} >= {0, (1 << zooms[1]) - 1}
    for (z, x, y), data in tiles.items():
        shape.derived.mvt_boundaries.clear()
        assert data == vector_tile(shape, distance, z, x, y, layer=name), (z, x, y)


@pytest.mark.slow  # deeper zooms of the check above
def test_pyramid_equals_on_demand_at_deep_zooms(tmp_path, mexico):
    tiles = _pyramid_tiles(tmp_path, mexico, "60km", (9, 10), "m")
    deep = sorted(k for k, v in tiles.items() if k[0] == 10)
    assert len(deep) > 100
    rng = np.random.default_rng(3)
    for i in rng.choice(len(deep), 80, replace=False):
        z, x, y = deep[i]
        mexico.derived.mvt_boundaries.clear()
        assert tiles[(z, x, y)] == vector_tile(mexico, "60km", z, x, y, layer="m"), (z, x, y)
