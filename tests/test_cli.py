import json
import subprocess
import sys

import pytest
from click.testing import CliRunner

import gloffset
from gloffset.cli import main


def run(*args, input=None):
    return CliRunner().invoke(main, list(args), input=input)


def test_version():
    r = run("--version")
    assert r.exit_code == 0 and gloffset.__version__ in r.output


def test_offset_file_to_file(tmp_path, mexico_path):
    out = tmp_path / "m.geojson"
    r = run("offset", str(mexico_path), "--distance", "127km", "-o", str(out))
    assert r.exit_code == 0, r.output
    fc = json.loads(out.read_text())
    feat = fc["features"][0]
    assert feat["geometry"]["type"] in ("Polygon", "MultiPolygon")
    assert feat["properties"]["distance"] == "127km"
    shape = gloffset.read(fc)
    # the written region contains Mexico City and a point 100 km off the coast
    assert gloffset.contains(shape, [-99.13, -115.5], [19.43, 28.0]).all()


def test_offset_stdin_to_stdout():
    g = json.dumps({"type": "LineString", "coordinates": [[0, 0], [1, 0]]})
    r = run("offset", "-", "-d", "0.01rad", input=g)
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["type"] == "FeatureCollection"


@pytest.mark.parametrize(
    "args, words",
    [
        (["offset", "nope.geojson", "-d", "1km"], "no such file"),
        (["offset", "{BAD", "-d", "1km"], "not valid JSON"),
        (["offset", "-", "-d", "3 parsecs"], "unknown distance unit"),
        (["offset", "-", "-d", "nan"], "distance"),
    ],
)
def test_errors_are_one_line(args, words):
    g = json.dumps({"type": "LineString", "coordinates": [[0, 0], [1, 0]]})
    proc = subprocess.run(
        [sys.executable, "-m", "gloffset", *args], input=g, capture_output=True, text=True
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gloffset: error:") and words in lines[0]
    assert "Traceback" not in proc.stderr
