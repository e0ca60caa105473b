"""``render --from-raster``: a PNG's lon/lat extent is never guessed (without --bounds
only a 2:1 image is the whole globe), ``--mask`` writes render's plain or styled mask of
the contained cells, and ``--classes`` of a coarser level says on stderr the size it
writes (for a vector INPUT too)."""

import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import DATA, assert_one_line_error
from PIL import Image

from gloffset.cli import main
from gloffset.grids import Equirect
from gloffset.io.png import parse_color
from gloffset.raster.rasterized import CONTAINED, raster_offset

MEXICO = DATA / "mexico_10m.geojson"
BOUNDS = "-120,10,-85,35"


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def masks(tmp_path_factory):
    """Mexico's border rendered as curve masks: a 2:1 globe and a square over Mexico."""
    tmp = tmp_path_factory.mktemp("masks")
    globe, square = tmp / "globe.png", tmp / "square.png"
    for out, extra in ((globe, ["--size", "360x180"]), (square, ["--size", "128x128"])):
        extra += ["--bounds", BOUNDS] if out == square else []
        r = run("render", MEXICO, "-d", "0.1km", *extra, "--no-worldfile", "-o", out)
        assert r.exit_code == 0, r.output
    return globe, square


def test_a_png_that_is_not_2_to_1_needs_bounds(tmp_path, masks):
    globe, square = masks
    out = tmp_path / "o.png"
    proc = subprocess.run(
        [sys.executable, "-m", "gloffset", "render", "--from-raster", str(square), "-d", "50km"]
        + ["-o", str(out)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "128x128 pixels, not 2:1" in lines[0] and "--bounds" in lines[0]
    assert not out.exists()
    r = run("render", "--from-raster", square, "--bounds", BOUNDS, "-d", "50km", "-o", out)
    assert r.exit_code == 0, r.output
    # a 2:1 image without --bounds is the whole globe: its world file says so
    r = run("render", "--from-raster", globe, "-d", "50km", "-o", out)
    assert r.exit_code == 0, r.output
    a, _, _, e, cx, cy = (float(v) for v in out.with_suffix(".pgw").read_text().split())
    assert (a, e, cx, cy) == (1.0, -1.0, -179.5, 89.5)


def test_mask_is_the_contained_cells_plain_or_styled(tmp_path, masks):
    _, square = masks
    curve = np.asarray(Image.open(square)) >= 128
    want = raster_offset(curve, 50e3, Equirect(128, 128, (-120, 10, -85, 35)))
    args = ["render", "--from-raster", square, "--bounds", BOUNDS, "-d", "50km"]
    for flag in ("--mask", "--mask-only"):
        r = run(*args, flag, "-o", tmp_path / "m.png")
        assert r.exit_code == 0, r.output
        got = np.asarray(Image.open(tmp_path / "m.png"))
        np.testing.assert_array_equal(got, np.where(want == CONTAINED, 255, 0))
    styled = ["--fill", "#3070c0", "--opacity", "0.5", "--background", "0,0,0,0"]
    r = run(*args, "--mask", *styled, "-o", tmp_path / "s.png")
    assert r.exit_code == 0, r.output
    rgba = np.asarray(Image.open(tmp_path / "s.png").convert("RGBA"))
    fill = parse_color("#3070c0")
    assert (rgba[want == CONTAINED] == (*fill[:3], 128)).all()
    assert (rgba[want != CONTAINED] == (0, 0, 0, 0)).all()
    # the style of a mask is refused, not ignored, on the classes picture
    r = run(*args, "--fill", "red", "-o", tmp_path / "c.png")
    assert r.exit_code == 2 and "add --mask" in r.stderr
    r = run("render", MEXICO, "-d", "50km", "--mask", "-o", tmp_path / "x.png")
    assert r.exit_code == 2 and "--mask is for --from-raster" in r.stderr


@pytest.mark.parametrize("source", ["from-raster", "input"])
def test_a_coarser_level_of_classes_says_its_size(tmp_path, masks, source):
    globe, _ = masks
    out = tmp_path / "c.png"
    if source == "input":
        args = ["render", MEXICO, "-d", "50km", "--size", "360x180"]
    else:
        args = ["render", "--from-raster", globe, "-d", "50km"]
    grid = Equirect(360, 180)
    last = grid.n_levels - 1
    r = run(*args, "--classes", "1", "-o", out)
    assert r.exit_code == 0, r.stderr
    h, w = grid.level_shape(1)
    b = grid.block(1)
    assert Image.open(out).size == (w, h) != (360, 180)
    assert f"--classes 1: written at that level's size, {w}x{h} cells of {b}x{b} pixels" in (
        r.stderr
    )
    assert "360x180 grid" in r.stderr
    r = run(*args, "--classes", str(last), "-o", out)  # the output level: as asked, no note
    assert r.exit_code == 0 and r.stderr == "" and Image.open(out).size == (360, 180)


def test_the_distance_is_converted_once_and_quoted_as_given(tmp_path, masks):
    """The library takes ``-d`` as given, with ``--radius``: the mask of Mexico's border
    is that of the library's call with the same distance and radius, and a distance too
    large for a raster offset is refused naming it as typed."""
    globe, _ = masks
    curve = np.asarray(Image.open(globe)) >= 128
    want = raster_offset(curve, "900km", Equirect(360, 180), radius=3e6, backend="cpu")
    out = tmp_path / "m.png"
    r = run("render", "--from-raster", globe, "-d", "900km", "--radius", "3e6", "--mask", "-o", out)
    assert r.exit_code == 0, r.output
    got = np.asarray(Image.open(out))
    np.testing.assert_array_equal(got, np.where(want == CONTAINED, 255, 0))
    assert (want == CONTAINED).sum() > (curve.sum() * 4)  # wider than the border itself
    out.unlink()
    proc = subprocess.run(
        [sys.executable, "-m", "gloffset", "render", "--from-raster", str(globe)]
        + ["-d", "5000km", "--radius", "3e6", "-o", str(out)],
        capture_output=True,
    )
    assert_one_line_error(proc, "distance '5000km' is 1.667 rad", "0 < d < 1.5 rad")
    assert not out.exists()
