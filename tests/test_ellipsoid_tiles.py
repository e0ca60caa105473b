"""Tile pyramids and the render CLI on the ellipsoid: every tile equal to
render(..., Tile(z, x, y), ellipsoid=...), tiles not written empty there, and the
pixels equal to the brute-force judge away from the boundary."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import gloffset
from gloffset import reference
from gloffset.cli import main
from gloffset.grids.mercator import Tile

pytest.importorskip("pyproj")

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [6, 0], [6, 6], [0, 6], [0, 0]]]}


def _tiles(folder):
    out = {}
    for f in folder.glob("*/*/*.png"):
        z, x, y = int(f.parent.parent.name), int(f.parent.name), int(f.stem)
        out[(z, x, y)] = np.asarray(Image.open(f)) == 1
    return out


@pytest.mark.parametrize("d", [300e3, -100e3])
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_pyramid_equals_render(tmp_path, d):
    st = gloffset.tiles.pyramid(SQUARE, d, "0-6", tmp_path / "t", size=16, ellipsoid="WGS84")
    got = _tiles(tmp_path / "t")
    assert st.written == len(got) > 0
    assert st.inside > 0 or d < 0
    for z in range(7):
        n = 1 << z
        for x in range(n):
            for y in range(n):
                w, s, e, nn = Tile(z, x, y, 16).bounds
                if z >= 3 and (e < -10 or w > 16 or nn < -10 or s > 16):
                    continue  # far from the square: checked at the coarse zooms
                want = gloffset.render(SQUARE, d, Tile(z, x, y, 16), ellipsoid="WGS84") > 0
                have = got.get((z, x, y), np.zeros((16, 16), bool))
                assert np.array_equal(have, want), (z, x, y)


def test_tile_against_judge():
    t = Tile(5, 16, 15, 16)
    mask = gloffset.render(SQUARE, 300e3, t, ellipsoid="WGS84") > 0
    lon, lat = _centres(t)
    shape = gloffset.read(SQUARE)
    truth = reference.geodesic_contains(shape, lon, lat, 300e3, "WGS84")
    dist = reference.geodesic_distance(shape, lon, lat, "WGS84")
    far = np.abs(dist - 300e3) > 1e-3
    assert np.array_equal(mask.ravel()[far], truth[far])
    assert mask.any() and not mask.all()


def _centres(t):
    w, s, e, n = t.bounds
    k = (np.arange(t.size) + 0.5) / t.size
    lon = w + (e - w) * k
    y0 = np.log(np.tan(np.pi / 4 + np.radians(n) / 2))
    y1 = np.log(np.tan(np.pi / 4 + np.radians(s) / 2))
    lat = np.degrees(2 * np.arctan(np.exp(y0 + (y1 - y0) * k)) - np.pi / 2)
    lon, lat = np.broadcast_arrays(lon[None, :], lat[:, None])
    return lon.ravel(), lat.ravel()


def test_cli_render_and_tiles(tmp_path):
    src = tmp_path / "sq.geojson"
    src.write_text(__import__("json").dumps(SQUARE))
    png = tmp_path / "r.png"
    r = CliRunner().invoke(
        main,
        ["render", str(src), "-d", "200km", "--ellipsoid", "WGS84", "--size", "64x32"]
        + ["--bounds", "-10,-10,16,16", "-o", str(png), "--no-worldfile"],
    )
    assert r.exit_code == 0, r.output
    from gloffset.grids import Equirect

    want = gloffset.render(SQUARE, 200e3, Equirect(64, 32, (-10, -10, 16, 16)), ellipsoid="WGS84")
    assert np.array_equal(np.asarray(Image.open(png).convert("L")) > 0, want > 0)
    r = CliRunner().invoke(
        main,
        ["tiles", str(src), "-d", "200km", "--ellipsoid", "WGS84", "-z", "0-3"]
        + ["--tile-size", "16", "-o", str(tmp_path / "t")],
    )
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(
        main, ["render", str(src), "-d", "1deg", "--ellipsoid", "WGS84", "-o", str(png)]
    )
    assert r.exit_code != 0 and "angle" in r.output
