"""Georeferenced rasters: GeoTIFF and COG output read back with rasterio (CRS, transform,
pixels equal to gloffset.render), world files that place pixel centres where Equirect
says, and GeoTIFF masks read with their own transform (other CRSs refused)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

import gloffset
from gloffset.cli import main
from gloffset.grids import Equirect

rasterio = pytest.importorskip("rasterio")

MEXICO = {
    "type": "Polygon",
    "coordinates": [[[-117, 32], [-97, 26], [-87, 21], [-92, 15], [-105, 20], [-117, 32]]],
}
LINE_AM = {"type": "LineString", "coordinates": [[170, -10], [-170, 5], [-160, 20]]}


def run(*args):
    r = CliRunner().invoke(main, [str(a) for a in args])
    return r


@pytest.fixture
def mexico(tmp_path):
    p = tmp_path / "mexico.geojson"
    p.write_text(json.dumps(MEXICO))
    return p


@pytest.mark.parametrize(
    "bounds, size",
    [(None, (360, 180)), ("-120,10,-80,35", (200, 125)), ("160,-30,-150,40", (250, 350))],
)
def test_geotiff_reads_back_with_crs_transform_and_the_render(tmp_path, bounds, size):
    src = tmp_path / "in.geojson"
    src.write_text(json.dumps(LINE_AM if bounds and bounds.startswith("160") else MEXICO))
    out = tmp_path / "out.tif"
    args = ["render", src, "-d", "300km", "--size", f"{size[0]}x{size[1]}", "-o", out]
    r = run(*args, *(["--bounds", bounds] if bounds else []))
    assert r.exit_code == 0, r.output
    b = tuple(float(v) for v in bounds.split(",")) if bounds else (-180.0, -90.0, 180.0, 90.0)
    grid = Equirect(*size, b)
    want = gloffset.render(gloffset.read(src), 300e3, grid)
    with rasterio.open(out) as ds:
        assert ds.crs.to_epsg() == 4326
        assert ds.count == 1 and ds.block_shapes[0] == (256, 256) or ds.height < 256
        assert ds.compression is not None
        got = ds.read(1)
        # pixel centres where Equirect puts them (modulo 360 across the antimeridian)
        for i, j in [(0, 0), (size[0] - 1, size[1] - 1), (size[0] // 2, size[1] // 3)]:
            x, y = ds.xy(j, i)  # row, column -> centre
            lon, lat = grid.pixel_lonlat(i, j)
            assert abs((x - lon + 180.0) % 360.0 - 180.0) < 1e-9 and abs(y - lat) < 1e-9
        assert "255 inside" in ds.tags()["DESCRIPTION"]
    np.testing.assert_array_equal(got, want)
    assert want.any()


def test_cog_and_rgba_geotiff(tmp_path, mexico):
    out = tmp_path / "m.cog.tif"
    r = run("render", mexico, "-d", "300km", "--size", "1024x512", "--fill", "#3070c0", "-o", out)
    assert r.exit_code == 0, r.output
    with rasterio.open(out) as ds:
        assert ds.driver == "GTiff" and ds.count == 4
        assert ds.overviews(1)  # a COG has overviews
        assert ds.block_shapes[0] == (256, 256)
        assert ds.colorinterp[3].name == "alpha"
    r = run("render", mexico, "-d", "1km", "--grid", "cube", "--size", "32", "--cog", "-o", "x")
    assert r.exit_code != 0 and "--cog" in r.output


def test_world_file_places_pixel_centres(tmp_path, mexico):
    out = tmp_path / "m.png"
    size, bounds = ("--size", "400x250"), ("--bounds", "-120,10,-80,35")
    r = run("render", mexico, "-d", "300km", *size, *bounds, "-o", out)
    assert r.exit_code == 0, r.output
    a, d, b, e, c, f = (float(v) for v in (tmp_path / "m.pgw").read_text().split())
    assert d == b == 0.0
    grid = Equirect(400, 250, (-120.0, 10.0, -80.0, 35.0))
    for i, j in [(0, 0), (399, 249), (123, 45)]:
        lon, lat = grid.pixel_lonlat(i, j)
        assert abs(c + a * i - lon) < 1e-9 and abs(f + e * j - lat) < 1e-9
    assert "WGS_1984" in (tmp_path / "m.prj").read_text()
    out2 = tmp_path / "n.png"
    r = run("render", mexico, "-d", "300km", "--size", "64x32", "--no-worldfile", "-o", out2)
    assert r.exit_code == 0 and not (tmp_path / "n.pgw").exists()


def test_from_raster_reads_a_geotiff_and_refuses_other_crs(tmp_path):
    from rasterio.transform import from_origin

    grid = Equirect(400, 200, (-120.0, 0.0, -80.0, 40.0))
    line = {"type": "LineString", "coordinates": [[-115, 30], [-90, 12]]}
    mask = gloffset.rasterize(line, grid)
    path = tmp_path / "curve.tif"
    profile = dict(driver="GTiff", width=400, height=200, count=1, dtype="uint8")
    with rasterio.open(
        path, "w", crs="EPSG:4326", transform=from_origin(-120, 40, 0.1, 0.2), **profile
    ) as ds:
        ds.write((mask * 255).astype(np.uint8), 1)
    out = tmp_path / "classes.tif"
    r = run("render", "--from-raster", path, "-d", "100km", "--mask-only", "-o", out)
    assert r.exit_code == 0, r.output
    want = gloffset.raster_offset(mask, 100e3, grid)
    with rasterio.open(out) as ds:
        np.testing.assert_array_equal(ds.read(1), np.where(want == 2, 255, 0))
        assert ds.transform == rasterio.transform.from_origin(-120, 40, 0.1, 0.2)
    merc = tmp_path / "merc.tif"
    with rasterio.open(
        merc, "w", crs="EPSG:3857", transform=from_origin(0, 0, 1000, 1000), **profile
    ) as ds:
        ds.write((mask * 255).astype(np.uint8), 1)
    r = run("render", "--from-raster", merc, "-d", "100km", "-o", tmp_path / "x.tif")
    assert r.exit_code == 2 and "EPSG:3857" in r.output and "EPSG:4326" in r.output


def test_mask_png_says_which_value_is_inside_and_opacity_scales_the_fill(tmp_path):
    """A plain mask PNG names its inside value in its Description; --fill with --opacity
    writes the fill's alpha times the opacity inside and the background outside."""
    from click.testing import CliRunner
    from PIL import Image

    from gloffset.cli import main

    src = tmp_path / "sq.geojson"
    src.write_text(
        '{"type": "Polygon", "coordinates": [[[0, 0], [20, 0], [20, 20], [0, 20], [0, 0]]]}'
    )
    plain, styled = tmp_path / "plain.png", tmp_path / "styled.png"
    args = ["render", str(src), "-d", "100km", "--size", "360x180"]
    r = CliRunner().invoke(main, [*args, "-o", str(plain)])
    assert r.exit_code == 0, r.output
    img = Image.open(plain)
    assert img.mode == "L" and "255 inside" in img.info["Description"]
    mask = np.asarray(img) == 255
    r = CliRunner().invoke(
        main, [*args, "--fill", "#ff000080", "--opacity", "0.5", "-o", str(styled)]
    )
    assert r.exit_code == 0, r.output
    rgba = np.asarray(Image.open(styled))
    assert (rgba[mask] == [255, 0, 0, 64]).all() and (rgba[~mask] == 0).all() and mask.any()
    r = CliRunner().invoke(main, [*args, "--opacity", "1.5", "-o", str(styled)])
    assert r.exit_code == 2 and "opacity" in r.output
