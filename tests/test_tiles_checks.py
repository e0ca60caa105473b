"""``tiles`` and ``render`` check the whole run before they write anything: every distance
of ``-d D1,D2,...``, every output (free, replaced with ``--force`` or continued by
``--resume`` with the same options and input) and every option (``--field`` takes none of
the raster styling options); a refusal is one line, exit status 2, and leaves the folder
as it was (no archive of the first distance, no staging file of a PMTiles resume)."""

import json
import subprocess
import sys

import pytest
from conftest import DATA, assert_one_line_error

import gloffset

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]]}
MEXICO = DATA / "mexico_10m.geojson"
OLD = b"the old output, left as it was\n"


def cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "gloffset", *map(str, args)], capture_output=True, check=False
    )


def listing(folder):
    """Every file under ``folder`` with its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


@pytest.fixture
def square(tmp_path):
    path = tmp_path / "square.geojson"
    path.write_text(json.dumps(SQUARE))
    return path


def test_a_distance_out_of_range_is_refused_before_the_first_pyramid(tmp_path):
    """``-d 10km,9600km``: 9600 km is beyond a pyramid's range; the 10 km archive was
    written before the refusal."""
    before = listing(tmp_path)
    proc = cli("tiles", MEXICO, "-d", "10km,9600km", "-z", "0-1", "-o", tmp_path / "x.mbtiles")
    assert_one_line_error(proc, "9600km", "too large")
    assert listing(tmp_path) == before


@pytest.mark.parametrize("name", ["x.mbtiles", "x"])
def test_an_existing_output_of_a_later_distance_is_refused_first(tmp_path, name):
    out = tmp_path / name
    later = tmp_path / ("x_50km.mbtiles" if name.endswith(".mbtiles") else "x/50km")
    if later.suffix:
        later.write_bytes(OLD)
    else:
        later.mkdir(parents=True)
        (later / "notes.txt").write_bytes(OLD)
    before = listing(tmp_path)
    proc = cli("tiles", MEXICO, "-d", "10km,50km", "-z", "0-1", "--tile-size", "64", "-o", out)
    assert_one_line_error(proc, str(later), "exists", "--resume", "--force")
    assert listing(tmp_path) == before


def test_a_resume_that_a_later_output_refuses_writes_nothing(tmp_path, square):
    """``--resume`` of two pyramids whose second holds another input's tiles: refused
    before the first is completed."""
    common = ["-z", "0-1", "--tile-size", "64"]
    assert (
        cli("tiles", square, "-d", "50km", *common, "-o", tmp_path / "x_50km.mbtiles").returncode
        == 0
    )
    before = listing(tmp_path)
    out = tmp_path / "x.mbtiles"
    proc = cli("tiles", MEXICO, "-d", "10km,50km", *common, "-o", out, "--resume")
    assert_one_line_error(proc, "cannot resume", "x_50km.mbtiles", "another input")
    assert listing(tmp_path) == before
    # the same input resumes the second and writes the first
    proc = cli("tiles", square, "-d", "10km,50km", *common, "-o", out, "--resume")
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "x_10km.mbtiles").exists()


def test_pyramids_check_every_output_before_writing(tmp_path):
    a, b = tmp_path / "a.mbtiles", tmp_path / "b.mbtiles"
    b.write_bytes(OLD)
    with pytest.raises(gloffset.OutputExistsError, match="b.mbtiles"):
        gloffset.tiles.pyramids(SQUARE, ["10km", "50km"], "0-1", [a, b], size=64)
    assert not a.exists() and b.read_bytes() == OLD


@pytest.mark.parametrize("how", ["other options", "another input"])
def test_a_refused_resume_of_a_pmtiles_archive_leaves_nothing_behind(tmp_path, square, how):
    """Resuming a finished archive unpacked it into ``NAME.pmtiles.partial.mbtiles``
    before the options were compared, and the refusal left that file (3 times the
    archive) behind."""
    pytest.importorskip("pmtiles")
    out = tmp_path / "p.pmtiles"
    args = ["-z", "0-2", "--tile-size", "64", "-o", out]
    assert cli("tiles", MEXICO, "-d", "100km", *args).returncode == 0
    before = listing(tmp_path)
    src, d = (MEXICO, "200km") if how == "other options" else (square, "100km")
    proc = cli("tiles", src, "-d", d, *args, "--resume")
    assert_one_line_error(proc, "cannot resume", how, "--force")
    assert listing(tmp_path) == before


@pytest.mark.parametrize(
    "option",
    [
        ["--fill", "red"],
        ["--fill", "#3070c0"],  # the default, given
        ["--opacity", "0.5"],
        ["--outline", "black"],
        ["--outline-width", "3"],
        ["--ellipsoid", "WGS84"],
        ["--workers", "2"],
        ["--scheduler", "tcp://127.0.0.1:8786"],
        ["-d", "10km"],
    ],
)
def test_field_tiles_refuse_the_options_of_raster_tiles(tmp_path, square, option):
    before = listing(tmp_path)
    proc = cli("tiles", square, "--field", "-z", "0", *option, "-o", tmp_path / "f.mbtiles")
    assert_one_line_error(proc, f"--field takes no {option[0]}")
    assert listing(tmp_path) == before


@pytest.mark.parametrize("name", ["out.jpg", "out.txt"])
def test_render_of_several_distances_names_the_output_as_typed(tmp_path, square, name):
    before = listing(tmp_path)
    proc = cli("render", square, "-d", "10km,20km", "--size", "64x32", "-o", tmp_path / name)
    assert_one_line_error(proc, f"{str(tmp_path / name)!r}:")
    assert "_10km" not in proc.stderr.decode()
    assert listing(tmp_path) == before
