"""The globe preview: its pixels agree with gloffset.contains along each pixel's direction
(away from the boundary, where the cube map's texels decide), north is up, the options
are checked, and the command writes a PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import gloffset
from gloffset.cli import main
from gloffset.raster.globe import GlobeStyle, globe, view_frame

DATA = Path(__file__).resolve().parents[1] / "data"
FLAT = GlobeStyle(
    fill="#ff0000", ocean="#0000ff", input_color="#00ff00", background="0,0,0,0",
    grid_step=0.0, shading=0.0,
)  # fmt: skip


def directions(size: int, frame: np.ndarray):
    """Each pixel's direction (row 0 at the top), and whether it is on the disc."""
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(c, -c)  # row 0 at the top: y = +1
    r2 = x**2 + y**2
    z = np.sqrt(np.clip(1.0 - r2, 0.0, None))
    local = np.stack([x, y, z], axis=-1)
    return local @ frame.T, r2 < 1.0


@pytest.mark.parametrize(
    "source, d, center",
    [("mexico_10m.geojson", 300e3, (-100.0, 20.0)), ("world_110m.geojson", 200e3, (170.0, -60.0))],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_globe_pixels_agree_with_contains(source, d, center):
    size, n = 256, 192
    shape = gloffset.read(DATA / source)
    img = globe(shape, d, size=size, center=center, cube=n, style=FLAT)
    assert img.shape == (size, size, 4)
    dirs, disc = directions(size, view_frame(center))
    rows, cols = np.nonzero(disc)
    pick = np.random.default_rng(0).choice(len(rows), 6000, replace=False)
    rows, cols = rows[pick], cols[pick]
    p = dirs[rows, cols]
    lon, lat = gloffset.geometry.sphere.xyz_to_lonlat(p)
    dist = gloffset.distance(shape, lon, lat)
    inside = gloffset.contains(shape, lon, lat, distance=d)
    # the cube map decides at its texels' centres: leave out pixels within a texel
    texel = 2.0 / n * gloffset.EARTH_RADIUS
    clear = (np.abs(dist - d) > 1.5 * texel) | (
        inside & gloffset.contains(shape, lon, lat) & (dist > 1.5 * texel)
    )
    region = img[rows, cols, 0] == 255
    assert clear.sum() > 4000
    assert np.array_equal(region[clear], inside[clear])
    ocean = (img[rows, cols, :3] == (0, 0, 255)).all(axis=1)
    assert np.array_equal(ocean[clear], ~inside[clear])
    assert (img[~disc] == 0).all()


def test_north_is_up_and_the_frame_is_right_handed():
    f = view_frame((30.0, 45.0))
    assert np.allclose(f.T @ f, np.eye(3)) and np.isclose(np.linalg.det(f), 1.0)
    assert f[2, 1] > 0  # north has a positive z
    pole = view_frame((0.0, 90.0))
    assert np.allclose(pole[:, 2], [0, 0, 1])


def test_cli_writes_a_png(tmp_path):
    out = tmp_path / "globe.png"
    r = CliRunner().invoke(
        main,
        ["preview", str(DATA / "mexico_10m.geojson"), "-d", "127km", "-o", str(out),
         "--size", "128", "--center", "-100,20"],
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    img = np.asarray(Image.open(out))
    assert img.shape == (128, 128, 4) and img[64, 64, 3] == 255 and img[0, 0, 3] == 0
    bad = CliRunner().invoke(
        main,
        [
            "preview",
            str(DATA / "mexico_10m.geojson"),
            "-d",
            "1km",
            "-o",
            str(out),
            "--center",
            "200,0",
        ],
    )
    assert bad.exit_code == 2 and "--center" in bad.output
    with pytest.raises(gloffset.OptionError, match="shading"):
        GlobeStyle(shading=2.0).uniforms()


def test_spin_turns_the_globe(tmp_path):
    shape = gloffset.read(DATA / "mexico_10m.geojson")
    frames = globe(shape, 300e3, size=64, center=(-100.0, 20.0), spin=4, style=FLAT)
    assert len(frames) == 4
    assert np.array_equal(
        frames[0], globe(shape, 300e3, size=64, center=(-100.0, 20.0), style=FLAT)
    )
    assert np.array_equal(
        frames[1], globe(shape, 300e3, size=64, center=(-190.0 + 360, 20.0), style=FLAT)
    )
    out = tmp_path / "spin.gif"
    r = CliRunner().invoke(
        main,
        ["preview", str(DATA / "mexico_10m.geojson"), "-d", "127km", "-o", str(out),
         "--size", "64", "--spin", "3"],
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    assert Image.open(out).n_frames == 3
