import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import gloffset
import gloffset.reference
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
    assert feat["properties"] == {"distance_m": 127000.0, "distance": "127km"}
    shape = gloffset.read(fc)
    # the written region contains Mexico City and a point 100 km off the coast
    assert gloffset.reference.contains_lonlat(shape, [-99.13, -115.5], [19.43, 28.0]).all()


@pytest.mark.parametrize(
    "flags, extra",
    [
        ([], {}),
        (["--each"], {"name": "a line"}),
        (["--raw"], {"raw": True}),
        (["--ellipsoid", "WGS84"], {"ellipsoid": "WGS84", "tolerance_m": 1.0}),
    ],
)
def test_offset_outputs_name_the_distance_one_way(flags, extra):
    """The union, --each, --raw and --ellipsoid write the same two distance properties:
    ``distance_m`` (metres; the geodesic length on the ellipsoid) and ``distance`` (as
    given)."""
    line = {"type": "LineString", "coordinates": [[-99.1, 19.4], [-98.2, 19.0], [-97, 20]]}
    g = json.dumps({"type": "Feature", "properties": {"name": "a line"}, "geometry": line})
    r = run("offset", "-", "-d", "2.5km", *flags, input=g)
    assert r.exit_code == 0, r.output
    (feat,) = json.loads(r.output)["features"]
    assert feat["properties"] == {"distance_m": 2500.0, "distance": "2.5km"} | extra
    if "--ellipsoid" not in flags:  # on the sphere of --radius (metres)
        r = run("offset", "-", "-d", "0.001rad", "--radius", "1000", *flags, input=g)
        assert json.loads(r.output)["features"][0]["properties"]["distance_m"] == 1.0


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


def test_render_png_and_overlay(tmp_path, mexico_path):
    from PIL import Image

    out = tmp_path / "m.png"
    r = run("render", str(mexico_path), "-d", "127km", "--size", "256x128", "-o", str(out))
    assert r.exit_code == 0, r.output
    img = np.asarray(Image.open(out))
    assert img.shape == (128, 256) and set(np.unique(img)) == {0, 255}
    mask = gloffset.render(gloffset.read(mexico_path), 127e3, gloffset.grids.Equirect(256, 128))
    assert np.array_equal(img, mask)
    rgba = tmp_path / "o.png"
    r = run(
        "render",
        str(mexico_path),
        "-d",
        "127km",
        "--size",
        "128x128",
        "--bounds",
        "-120,10,-85,35",
        "--fill",
        "#3070c0cc",
        "--background",
        "0,0,0,0",
        "-o",
        str(rgba),
    )
    assert r.exit_code == 0, r.output
    px = np.asarray(Image.open(rgba))
    assert px.shape == (128, 128, 4)
    assert {tuple(v) for v in px.reshape(-1, 4)} == {(0x30, 0x70, 0xC0, 0xCC), (0, 0, 0, 0)}
    cls = tmp_path / "c.png"
    r = run(
        "render",
        str(mexico_path),
        "-d",
        "127km",
        "--size",
        "256x256",
        "--bounds",
        "-120,10,-85,35",
        "--classes",
        "2",
        "-o",
        str(cls),
    )
    assert r.exit_code == 0, r.output
    colours = {tuple(v) for v in np.asarray(Image.open(cls)).reshape(-1, 4)}
    assert (220, 30, 30, 255) in colours  # frontier cells in red


@pytest.mark.parametrize(
    "args, words",
    [
        (["--size", "10x"], "--size must be"),
        (["--bounds", "1,2,3"], "--bounds must be"),
        (["--bounds", "0,10,5,5"], "S < N"),
        (["--fill", "blurple"], "cannot read colour"),
        (["--classes", "42"], "level must be"),
    ],
)
def test_render_errors(tmp_path, args, words):
    g = json.dumps({"type": "LineString", "coordinates": [[0, 0], [1, 0]]})
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "gloffset",
            "render",
            "-",
            "-d",
            "10km",
            "-o",
            str(tmp_path / "x.png"),
            *args,
        ],
        input=g,
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0], proc.stderr


def test_info_and_bad_device():
    r = run("info")
    assert r.exit_code == 0 and "renderer:" in r.output and "max_texture_size:" in r.output
    import os

    env = dict(os.environ, GLOFFSET_DEVICE="7")
    proc = subprocess.run(
        [sys.executable, "-m", "gloffset", "info"], capture_output=True, text=True, env=env
    )
    assert proc.returncode == 2
    assert "EGL" in proc.stderr and "device 7" in proc.stderr and "install" in proc.stderr
    env["GLOFFSET_DEVICE"] = "gpu"
    proc = subprocess.run(
        [sys.executable, "-m", "gloffset", "info"], capture_output=True, text=True, env=env
    )
    assert proc.returncode == 2 and "GLOFFSET_DEVICE must be" in proc.stderr


def test_render_cube_faces(tmp_path, world):
    from PIL import Image

    src = tmp_path / "ant.geojson"
    src.write_text(json.dumps(world["Antarctica"]))
    out = tmp_path / "cube"
    r = run("render", str(src), "-d", "200km", "--grid", "cube", "--size", "64", "-o", str(out))
    assert r.exit_code == 0, r.output
    faces = {p.stem: np.asarray(Image.open(p)) for p in out.glob("*.png")}
    assert sorted(faces) == sorted(["px", "nx", "py", "ny", "pz", "nz"])
    want = gloffset.render(gloffset.read(src), 200e3, gloffset.grids.Cube(64))
    for k, name in enumerate(gloffset.grids.FACE_NAMES):
        assert np.array_equal(faces[name], want[k])
    assert faces["nz"].any() and not faces["pz"].any()


@pytest.mark.parametrize(
    "flags",
    [
        pytest.param([], marks=pytest.mark.slow),
        pytest.param(["--each"], marks=pytest.mark.slow),
        pytest.param(["--raw"], marks=pytest.mark.slow),
    ],
)
def test_offset_reports_its_stages_on_a_terminal_only(tmp_path, flags):
    """Long vector work says what it is doing on stderr: on a terminal, or forced with
    GLOFFSET_PROGRESS=1; nothing otherwise (stderr here is a pipe)."""
    src = Path(__file__).resolve().parents[1] / "data" / "world_110m.geojson"
    out = tmp_path / "w.geojson"
    args = [sys.executable, "-m", "gloffset", "offset", src, "-d", "50km", "-o", out, *flags]
    quiet = subprocess.run(args, capture_output=True, text=True)
    assert quiet.returncode == 0 and quiet.stderr == "", quiet.stderr
    written = out.read_bytes()
    env = {**os.environ, "GLOFFSET_PROGRESS": "1"}
    shown = subprocess.run(args, capture_output=True, text=True, env=env)
    assert shown.returncode == 0, shown.stderr
    stages = ["reading the input", f"writing {str(out)!r}"]
    if flags == ["--each"]:
        stages.insert(1, "offsetting each feature 177/177")
    else:
        stages.insert(1, "densifying the arcs")
        if not flags:
            stages.insert(1, "removing self-intersections")
    n = len(stages)
    for k, stage in enumerate(stages, 1):
        assert f"{k}/{n} {stage}" in shown.stderr, shown.stderr
    assert out.read_bytes() == written  # the same output either way
