"""Every output of the CLI gets the permission bits the umask gives a new file (0644 under
umask 022; tested under 002, which SQLite's and private temporary files' modes do not
give), and a replaced file keeps its own; a tile output is a tile file or a folder."""

import os
import stat
import subprocess
import sys

import pytest
from click.testing import CliRunner
from conftest import DATA

from gloffset.cli import main
from gloffset.io.output import new_file_mode

MEXICO = str(DATA / "mexico_10m.geojson")
D = ["-d", "100km"]


def run(*args):
    r = CliRunner().invoke(main, [str(a) for a in args])
    assert r.exit_code == 0, r.output
    return r


@pytest.fixture
def umask002():
    old = os.umask(0o002)
    try:
        yield 0o664
    finally:
        os.umask(old)


def modes(folder):
    return {
        str(p.relative_to(folder)): stat.S_IMODE(p.stat().st_mode)
        for p in folder.rglob("*")
        if p.is_file()
    }


def make(kind, out, tmp_path):
    """Write the output ``out`` of ``kind``; the files it writes."""
    if kind in ("png", "tif", "cog.tif"):
        run("render", MEXICO, *D, "--size", "72x36", "-o", out)
    elif kind == "from-raster":
        mask = tmp_path / "mask.png"
        run("render", MEXICO, *D, "--size", "72x36", "-o", mask, "--no-worldfile")
        mask.chmod(0o644)
        run("render", "--from-raster", mask, *D, "-o", out)
    elif kind in ("geojson", "gpkg", "shp", "fgb", "parquet"):
        if kind != "geojson":
            pytest.importorskip("pyogrio")
        run("offset", MEXICO, *D, "-o", out)
    elif kind in ("mbtiles", "pmtiles", "xyz"):
        if kind == "pmtiles":
            pytest.importorskip("pmtiles")
        run("tiles", MEXICO, *D, "-z", "0-2", "--tile-size", "64", "-o", out)
    elif kind == "csv":
        points = tmp_path / "points.csv"
        points.write_text("lon,lat\n-100,25\n0,0\n")
        points.chmod(0o644)
        run("contains", MEXICO, points, *D, "-o", out)


KINDS = {
    "png": "a.png",
    "tif": "a.tif",
    "cog.tif": "a.cog.tif",
    "from-raster": "r.tif",
    "geojson": "a.geojson",
    "gpkg": "a.gpkg",
    "shp": "a.shp",
    "fgb": "a.fgb",
    "parquet": "a.parquet",
    "mbtiles": "a.mbtiles",
    "pmtiles": "a.pmtiles",
    "xyz": "xyz",
    "csv": "o.csv",
}


@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_outputs_get_the_umasks_mode(tmp_path, umask002, kind):
    if kind in ("tif", "cog.tif", "from-raster"):
        pytest.importorskip("rasterio")
    out = tmp_path / KINDS[kind]
    make(kind, out, tmp_path)
    got = {k: m for k, m in modes(tmp_path).items() if not k.startswith(("mask", "points"))}
    assert got and all(m == umask002 for m in got.values()), got
    assert new_file_mode() == umask002
    if out.is_file():  # replacing a file keeps its mode
        out.chmod(0o640)
        if kind in ("mbtiles", "pmtiles"):
            run("tiles", MEXICO, *D, "-z", "0-2", "--tile-size", "64", "-o", out, "--force")
        else:
            make(kind, out, tmp_path)
        assert stat.S_IMODE(out.stat().st_mode) == 0o640


@pytest.mark.parametrize("name", ["x.txt", "t.png", "tiles.v2", "a.geojson"])
def test_a_tile_output_that_is_no_tile_format_is_refused(tmp_path, name):
    out = tmp_path / name
    proc = subprocess.run(
        [sys.executable, "-m", "gloffset", "tiles", MEXICO, *D, "-z", "0-1", "-o", str(out)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "is no tile format" in lines[0], proc.stderr
    assert not out.exists()


@pytest.mark.parametrize("name", ["plain", "tiles.v2/", "done.d"])
def test_a_folder_is_a_name_without_an_extension_or_ending_in_a_slash(tmp_path, name):
    if name == "done.d":  # an existing folder is a folder, whatever its name
        (tmp_path / name).mkdir()
    out = str(tmp_path / name) + ("/" if name.endswith("/") else "")
    run("tiles", MEXICO, *D, "-z", "0-1", "--tile-size", "64", "-o", out, "--resume")
    assert (tmp_path / name.rstrip("/") / "metadata.json").is_file()
