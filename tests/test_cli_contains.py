"""``gloffset contains``: CSV in, CSV out, streamed in batches, one-line errors."""

import csv
import io
import json
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner

import gloffset
from gloffset.cli import main

SQUARE = json.dumps(
    {"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]]}
)


def run(*args, input=None):
    return CliRunner().invoke(main, list(args), input=input)


def rows(text):
    return list(csv.reader(io.StringIO(text)))


@pytest.fixture
def square(tmp_path):
    path = tmp_path / "square.geojson"
    path.write_text(SQUARE)
    return str(path)


def test_file_to_file_keeps_every_column(tmp_path, mexico_path):
    pts = tmp_path / "wells.csv"
    pts.write_text(
        'id,name,lon,lat\n1,"Mexico City, centre",-99.13,19.43\n2,gulf,-80,20\n'
        "3,off the coast,-115.5,28.0\n"
    )
    out = tmp_path / "out.csv"
    r = run("contains", str(mexico_path), str(pts), "--distance", "127km", "-o", str(out))
    assert r.exit_code == 0, r.output
    got = rows(out.read_text())
    assert got[0] == ["id", "name", "lon", "lat", "inside"]
    assert got[1] == ["1", "Mexico City, centre", "-99.13", "19.43", "true"]
    assert [g[-1] for g in got[1:]] == ["true", "false", "true"]
    # distance 0 (the default): the point off the coast is outside
    r = run("contains", str(mexico_path), str(pts))
    assert [g[-1] for g in rows(r.output)[1:]] == ["true", "false", "false"]


def test_stdin_to_stdout_in_batches_matches_the_library(square):
    rng = np.random.default_rng(0)
    lon, lat = rng.uniform(-5, 15, 1000), rng.uniform(-5, 15, 1000)
    text = "lat,lon\n" + "".join(f"{b!r},{a!r}\n" for a, b in zip(lon.tolist(), lat.tolist()))
    want = gloffset.contains(gloffset.read(SQUARE), lon, lat, distance=50e3)
    for chunk in ("7", "100000"):
        r = run("contains", square, "-", "-d", "50km", "--chunk", chunk, input=text)
        assert r.exit_code == 0, r.output
        got = rows(r.output)
        assert got[0] == ["lat", "lon", "inside"] and len(got) == 1001
        assert [g[2] == "true" for g in got[1:]] == want.tolist()


def test_inside_column_is_replaced_and_blank_lines_skipped(square):
    text = "Longitude,Latitude,inside\n5,5,maybe\n\n20,20,\n"
    r = run("contains", square, "-", input=text)
    assert r.exit_code == 0, r.output
    assert rows(r.output) == [
        ["Longitude", "Latitude", "inside"],
        ["5", "5", "true"],
        ["20", "20", "false"],
    ]


def test_header_only_gives_header_only(square):
    r = run("contains", square, "-", input="lon,lat\n")
    assert r.exit_code == 0 and rows(r.output) == [["lon", "lat", "inside"]]


def test_no_partial_output_file_on_error(tmp_path, square):
    pts = tmp_path / "p.csv"
    pts.write_text("lon,lat\n1,2\n" * 5 + "3,x\n")
    out = tmp_path / "out.csv"
    r = run("contains", square, str(pts), "-o", str(out), "--chunk", "2")
    assert r.exit_code == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.csv", "square.geojson"]


@pytest.mark.parametrize(
    "points, args, words",
    [
        ("lon,lat\n1,2\n3,abc\n", [], "line 3: lat 'abc' is not a number"),
        ("lon,lat\n1,2\n1,2\n1,2\n1\n", ["--chunk", "2"], "line 5: 1 field, but the header has 2"),
        ("lon,lat\n1,2\n3,95\n", [], "line 3: latitude 95.0 out of range"),
        ("lon,lat\n5,5\n365,5\n", [], "line 3: longitude 365.0 out of range [-180, 180]"),
        ("lon,lat\n5,5\n1,1\n725,5\n", ["--chunk", "2"], "line 4: longitude 725.0 out of"),
        ("lon,lat\n-180.5,5\n", ["--each"], "line 2: longitude -180.5 out of range"),
        ("lon,lat\n1,2\nnan,2\n", [], "line 3: coordinates must be finite"),
        ("x,y\n1,2\n", [], "no 'lon' column in the header (found: x, y)"),
        ("", [], "empty file"),
        ("lon,lat\n1,2\n", ["-d", "3 parsecs"], "unknown distance unit"),
        ("lon,lat\n1,2\n", ["--level", "-1"], "level must be >= 0"),
    ],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_errors_are_one_line(square, points, args, words):
    proc = subprocess.run(
        [sys.executable, "-m", "gloffset", "contains", square, "-", *args],
        input=points,
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gloffset: error:"), proc.stderr
    assert words in lines[0] and "Traceback" not in proc.stderr


@pytest.mark.parametrize(
    "args, words",
    [
        (["-", "-"], "cannot both be read from stdin"),
        (["SQUARE", "nope.csv"], "cannot read 'nope.csv'"),
        (["nope.geojson", "-"], "no such file"),
    ],
)
def test_file_errors_are_one_line(square, args, words):
    args = [square if a == "SQUARE" else a for a in args]
    proc = subprocess.run(
        [sys.executable, "-m", "gloffset", "contains", *args],
        input="lon,lat\n1,2\n",
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0], proc.stderr


def test_no_progress_bar_off_a_terminal(tmp_path, square):
    pts = tmp_path / "p.csv"
    pts.write_text("lon,lat\n" + "5,5\n" * 3000)
    proc = subprocess.run(
        [sys.executable, "-m", "gloffset", "contains", square, str(pts), "--chunk", "500"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0 and proc.stderr == ""
    assert proc.stdout.count("true") == 3000


def test_byte_order_mark_is_skipped(tmp_path, square):
    pts = tmp_path / "excel.csv"
    pts.write_bytes(b"\xef\xbb\xbflon,lat\r\n5,5\r\n")
    r = run("contains", square, str(pts))
    assert r.exit_code == 0, r.output
    assert rows(r.output) == [["lon", "lat", "inside"], ["5", "5", "true"]]
