"""The command line on bad input and awkward outputs.

Every error is one line on stderr and exit status 2, and the file given to ``-o`` is left as it
was. ``-o`` replaces a regular file atomically but writes through symlinks, FIFOs and devices;
``-o -`` and ``-o /dev/stdout`` write to standard output (PNG included).
"""

import io
import json
import os
import stat
import subprocess
import sys
import threading

import numpy as np
import pytest
from conftest import assert_one_line_error
from PIL import Image

import gloffset

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]]}
OLD = b"the old output, left as it was\n"


def cli(*args, input=None, **kw):
    """Run ``python -m gloffset ARGS``: stdout and stderr as bytes."""
    if isinstance(input, str):
        input = input.encode()
    return subprocess.run(
        [sys.executable, "-m", "gloffset", *map(str, args)], input=input, capture_output=True, **kw
    )


@pytest.fixture(autouse=True)
def _in_tmp_path(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a wrong output named '-' would land here


@pytest.fixture
def square(tmp_path):
    path = tmp_path / "square.geojson"
    path.write_text(json.dumps(SQUARE))
    return path


@pytest.fixture
def points(tmp_path):
    path = tmp_path / "points.csv"
    path.write_text("id,lon,lat\na,5,5\nb,20,20\n")
    return path


def old_output(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(OLD)
    return path


def assert_unchanged(path):
    assert path.read_bytes() == OLD
    strays = [p.name for p in path.parent.iterdir() if p.name.endswith(".tmp")]
    assert strays == [], strays


# ------------------------------------------------------------------ bad input, -o unchanged


def test_huge_number_in_geojson(tmp_path):
    src = tmp_path / "huge.geojson"
    src.write_text('{"type": "Point",\n "coordinates": [1' + "0" * 4999 + ", 2]}")
    out = old_output(tmp_path, "out.geojson")
    proc = cli("offset", src, "-d", "1km", "-o", out)
    assert_one_line_error(proc, "huge.geojson, line 2, column 18", "5000 digits")
    assert_unchanged(out)


@pytest.mark.parametrize("command", ["offset", "render", "tiles"])
def test_missing_distance(tmp_path, square, command):
    out = old_output(tmp_path, "out.png")
    extra = ["-z", "0-1"] if command == "tiles" else []
    proc = cli(command, square, *extra, "-o", out)
    assert_one_line_error(proc, "Missing option '-d' / '--distance'")
    assert_unchanged(out)


def test_negative_digits(tmp_path, square):
    out = old_output(tmp_path, "out.geojson")
    proc = cli("offset", square, "-d", "10km", "--digits", "-3", "-o", out)
    assert_one_line_error(proc, "--digits", "-3")
    assert_unchanged(out)
    with pytest.raises(gloffset.OptionError, match="digits"):
        gloffset.offset(SQUARE, 1e4).to_geojson(digits=-3)


@pytest.mark.parametrize(
    "rows, words",
    [
        ("id,lon,lat\na,5,5\nb,20,20,extra\n", "line 3: 4 fields, but the header has 3"),
        ("id,lon,lat\na,5,5\nb,20\n", "line 3: 2 fields, but the header has 3"),
    ],
)
def test_csv_row_width(tmp_path, square, rows, words):
    src = tmp_path / "bad.csv"
    src.write_text(rows)
    out = old_output(tmp_path, "out.csv")
    proc = cli("contains", square, src, "-o", out)
    assert_one_line_error(proc, words)
    assert_unchanged(out)


def test_csv_error_after_output_began(tmp_path, square):
    """A bad row in a later batch: the output file was being written, and is left as it was."""
    src = tmp_path / "late.csv"
    src.write_text("lon,lat\n" + "5,5\n" * 50 + "5,x\n")
    out = old_output(tmp_path, "out.csv")
    proc = cli("contains", square, src, "--chunk", "7", "-o", out)
    assert_one_line_error(proc, "line 52: lat 'x' is not a number")
    assert_unchanged(out)


def test_colour_image_is_not_a_mask(tmp_path):
    rgb = np.zeros((32, 64, 3), dtype=np.uint8)
    rgb[16, 5:60] = (255, 255, 255)
    rgb[5:25, 30] = (200, 40, 40)  # a red line: colour
    src = tmp_path / "colour.png"
    Image.fromarray(rgb).save(src)
    out = old_output(tmp_path, "out.png")
    proc = cli("render", "--from-raster", src, "-d", "100km", "-o", out)
    assert_one_line_error(proc, "colour.png", "colour image", "row 5, column 30")
    assert_unchanged(out)


def test_what_a_mask_is(tmp_path):
    from gloffset.io.png import read_mask

    want = np.zeros((8, 16), dtype=bool)
    want[3, 2:14] = True
    grey = np.where(want, 200, 100).astype(np.uint8)  # threshold at 128
    cases = {
        "grey.png": Image.fromarray(grey),
        "grey16.png": Image.fromarray(grey.astype(np.uint16) * 257),
        "bits.png": Image.fromarray(want),
        "grey_rgb.png": Image.fromarray(np.dstack([grey] * 3)),
        # transparency decides, whatever the colour
        "alpha.png": Image.fromarray(
            np.dstack([np.full_like(grey, 30), np.full_like(grey, 200), grey, want * 255]).astype(
                np.uint8
            ),
            mode="RGBA",
        ),
        "grey.tif": Image.fromarray(grey),
    }
    for name, img in cases.items():
        img.save(tmp_path / name)
        np.testing.assert_array_equal(read_mask(tmp_path / name), want, err_msg=name)
    Image.fromarray(np.zeros((8, 16), np.float32)).save(tmp_path / "float.tif")
    with pytest.raises(gloffset.InputFormatError, match="has F pixels"):
        read_mask(tmp_path / "float.tif")


@pytest.mark.parametrize(
    "name, words",
    [
        ("out.jpg", "JPEG is lossy"),
        ("out.JPEG", "JPEG is lossy"),
        ("out.gif", "unsupported image extension '.gif'; use .png, .tif or .tiff"),
    ],
)
def test_unsupported_image_formats(tmp_path, square, name, words):
    out = old_output(tmp_path, name)
    proc = cli("render", square, "-d", "100km", "--size", "64x32", "-o", out)
    assert_one_line_error(proc, name, words)
    assert_unchanged(out)


def test_tiff_output(tmp_path, square):
    for name in ("out.tif", "out.png", "classes.tiff"):
        extra = ["--classes", "1"] if name.startswith("classes") else []
        proc = cli(
            "render", square, "-d", "300km", "--size", "64x32", *extra, "-o", tmp_path / name
        )
        assert proc.returncode == 0, proc.stderr
    with Image.open(tmp_path / "out.tif") as img:
        assert img.format == "TIFF"
        tif = np.asarray(img)
    with Image.open(tmp_path / "out.png") as img:
        assert img.format == "PNG"
        np.testing.assert_array_equal(tif, np.asarray(img))
    assert tif.any()
    with Image.open(tmp_path / "classes.tiff") as img:
        assert img.format == "TIFF" and img.mode == "RGBA"


# ------------------------------------------------------------------ write errors


@pytest.mark.parametrize("command", ["offset", "contains", "render", "render-cube"])
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_missing_folder(tmp_path, square, points, command):
    out = tmp_path / "nope" / "out"
    args = {
        "offset": ["offset", square, "-d", "1km"],
        "contains": ["contains", square, points],
        "render": ["render", square, "-d", "100km", "--size", "64x32"],
        "render-cube": ["render", square, "-d", "100km", "--grid", "cube", "--size", "8"],
    }[command]
    if command == "render-cube":  # a folder output: made, unless a file is in the way
        (tmp_path / "nope").write_bytes(OLD)
    proc = cli(*args, "-o", out)
    if command == "render-cube":
        assert_one_line_error(proc, "cannot create folder", "Not a directory")
        assert (tmp_path / "nope").read_bytes() == OLD
    else:
        assert_one_line_error(proc, f"cannot write '{out}'", "does not exist")
        assert not (tmp_path / "nope").exists()


def test_folder_or_link_loop_in_the_way(tmp_path, square):
    (tmp_path / "out.geojson").mkdir()
    proc = cli("offset", square, "-d", "1km", "-o", tmp_path / "out.geojson")
    assert_one_line_error(proc, "it is a folder")
    assert list((tmp_path / "out.geojson").iterdir()) == []
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    proc = cli("offset", square, "-d", "1km", "-o", tmp_path / "a")
    assert_one_line_error(proc, "too many levels of symbolic links")
    assert (tmp_path / "a").is_symlink() and (tmp_path / "b").is_symlink()


@pytest.mark.parametrize(
    "args, words",
    [
        (["render", "SQUARE", "-d", "1km", "--grid", "cube"], "six images into a folder"),
        (["tiles", "SQUARE", "-d", "1km", "-z", "0-1"], "tile pyramid"),
    ],
)
def test_folder_outputs_refuse_stdout(tmp_path, square, args, words):
    args = [square if a == "SQUARE" else a for a in args]
    proc = cli(*args, "-o", "-")
    assert_one_line_error(proc, "cannot write standard output (-o -)", words)
    assert proc.stdout == b"" and not (tmp_path / "-").exists()


@pytest.fixture
def device(tmp_path):
    """A character device like /dev/full or /dev/null. As root (who could replace the real
    /dev/full by a file if gloffset were wrong) it is a private node with the same device
    number, made with mknod; otherwise the real one."""

    def make(name):
        real = f"/dev/{name}"
        if not os.path.exists(real):
            pytest.skip(f"no {real}")
        if os.geteuid() != 0:
            return real
        node = tmp_path / name
        try:
            os.mknod(node, stat.S_IFCHR | 0o666, os.stat(real).st_rdev)
        except OSError:
            return real
        return str(node)

    return make


@pytest.mark.parametrize("command", ["offset", "contains", "render"])
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_device_full(square, points, device, command):
    full = device("full")
    args = {
        "offset": ["offset", square, "-d", "1km"],
        "contains": ["contains", square, points],
        "render": ["render", square, "-d", "100km", "--size", "64x32"],
    }[command]
    proc = cli(*args, "-o", full)
    assert_one_line_error(proc, f"cannot write '{full}'", "No space left on device")
    assert stat.S_ISCHR(os.stat(full).st_mode)
    with open(full, "rb") as fh:  # still the device: reads zeros
        assert fh.read(4) == b"\0\0\0\0"


def test_device_null(square, device):
    null = device("null")
    proc = cli("render", square, "-d", "100km", "--size", "64x32", "-o", null)
    assert proc.returncode == 0 and proc.stderr == b""
    assert stat.S_ISCHR(os.stat(null).st_mode) and os.path.getsize(null) == 0


def test_stdout_on_a_full_device(square, device):
    with open(device("full"), "wb") as full:
        proc = subprocess.run(
            [sys.executable, "-m", "gloffset", "offset", str(square), "-d", "1km", "-o", "-"],
            stdout=full,
            stderr=subprocess.PIPE,
        )
    assert_one_line_error(proc, "cannot write standard output: No space left on device")


# ------------------------------------------------------------------ where -o writes


def test_regular_file_replaced_keeping_its_mode(tmp_path, square, points):
    out = old_output(tmp_path, "out.csv")
    os.chmod(out, 0o640)
    proc = cli("contains", square, points, "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert out.read_text() == "id,lon,lat,inside\na,5,5,true\nb,20,20,false\n"
    assert stat.S_IMODE(os.stat(out).st_mode) == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv", "points.csv", "square.geojson"]


def test_writes_through_a_symlink(tmp_path, square):
    (tmp_path / "data").mkdir()
    real = old_output(tmp_path / "data", "real.geojson")
    link = tmp_path / "link.geojson"
    link.symlink_to(real)
    proc = cli("offset", square, "-d", "1km", "-o", link)
    assert proc.returncode == 0, proc.stderr
    assert link.is_symlink() and os.readlink(link) == str(real)
    assert json.loads(real.read_text())["type"] == "FeatureCollection"
    # a dangling link: the file it names is made
    dangling = tmp_path / "dangling.png"
    dangling.symlink_to(tmp_path / "data" / "new.png")
    proc = cli("render", square, "-d", "100km", "--size", "64x32", "-o", dangling)
    assert proc.returncode == 0, proc.stderr
    assert dangling.is_symlink() and (tmp_path / "data" / "new.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    "args",
    [
        ["render", "SQUARE", "-d", "100km", "--size", "64x32"],
        ["render", "SQUARE", "-d", "100km", "--size", "64x32", "--cog"],
        ["field", "SQUARE", "--size", "64x32"],
    ],
)
def test_a_geotiff_is_written_through_a_symlink(tmp_path, square, args):
    """GDAL writes to a name: the file the link points to is replaced (atomically, beside
    it), and the link stays a link."""
    rasterio = pytest.importorskip("rasterio")
    (tmp_path / "data").mkdir()
    real = old_output(tmp_path / "data", "real.tif")
    link = tmp_path / "link.tif"
    link.symlink_to(real)
    proc = cli(*[square if a == "SQUARE" else a for a in args], "-o", link)
    assert proc.returncode == 0, proc.stderr
    assert link.is_symlink() and os.readlink(link) == str(real)
    with rasterio.open(real) as src:
        assert (src.width, src.height) == (64, 32)
    assert sorted(p.name for p in (tmp_path / "data").iterdir()) == ["real.tif"]


def read_fifo(path):
    """Start reading the FIFO ``path`` in a thread; returns a function giving what was read."""
    got = {}

    def reader():
        with open(path, "rb") as fh:
            got["data"] = fh.read()

    thread = threading.Thread(target=reader, daemon=True)
    thread.start()

    def result():
        thread.join(60)
        return got.get("data")

    return result


@pytest.mark.parametrize("command", ["contains", "render"])
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_writes_through_a_fifo(tmp_path, square, points, command):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    result = read_fifo(fifo)
    if command == "contains":
        proc = cli("contains", square, points, "-o", fifo, timeout=60)
        assert proc.returncode == 0, proc.stderr
        assert result() == b"id,lon,lat,inside\na,5,5,true\nb,20,20,false\n"
    else:
        proc = cli("render", square, "-d", "300km", "--size", "64x32", "-o", fifo, timeout=60)
        assert proc.returncode == 0, proc.stderr
        want = gloffset.render(gloffset.read(SQUARE), 300e3, gloffset.grids.Equirect(64, 32))
        np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(result()))), want)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fifo", "points.csv", "square.geojson"]


@pytest.fixture(params=["-", "/dev/stdout", "/dev/fd/1"])
def stdout_name(request, tmp_path):
    """Names of standard output. As root, /dev/stdout is a private link to /proc/self/fd/1
    like the real one (which a wrong gloffset would replace by a file)."""
    name = request.param
    if name == "/dev/stdout" and (os.geteuid() == 0 or not os.path.islink(name)):
        os.symlink("/proc/self/fd/1", tmp_path / "stdout")
        return str(tmp_path / "stdout")
    return name


@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_png_to_stdout_in_a_pipe(square, stdout_name):
    target = stdout_name
    proc = cli("render", square, "-d", "300km", "--size", "64x32", "-o", target)
    assert proc.returncode == 0 and proc.stderr == b"", proc.stderr
    want = gloffset.render(gloffset.read(SQUARE), 300e3, gloffset.grids.Equirect(64, 32))
    with Image.open(io.BytesIO(proc.stdout)) as img:
        assert img.format == "PNG"
        np.testing.assert_array_equal(np.asarray(img), want)


@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_text_to_stdout_in_a_pipe(square, points, stdout_name):
    target = stdout_name
    proc = cli("contains", square, points, "-o", target)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == b"id,lon,lat,inside\na,5,5,true\nb,20,20,false\n"
    proc = cli("offset", square, "-d", "1km", "-o", target)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["type"] == "FeatureCollection"


@pytest.mark.parametrize("stdout_name", ["/dev/stdout", "/dev/fd/1"], indirect=True)
def test_dev_stdout_redirected_to_a_file_is_appended_to(tmp_path, square, points, stdout_name):
    """``-o /dev/stdout >> log``: the shell's file, at its position, is written, not replaced."""
    log = old_output(tmp_path, "log.csv")
    with open(log, "ab") as fh:
        proc = subprocess.run(
            [sys.executable, "-m", "gloffset", "contains", str(square), str(points)]
            + ["-o", stdout_name],
            stdout=fh,
            stderr=subprocess.PIPE,
        )
    assert proc.returncode == 0, proc.stderr
    assert log.read_bytes() == OLD + b"id,lon,lat,inside\na,5,5,true\nb,20,20,false\n"


# ------------------------------------------------------------------ limits of the region


@pytest.mark.parametrize(
    "geometry, args, words",
    [
        ({"type": "LineString", "coordinates": [[0, 0], [10, 0]]}, ["-d", "-5km"], ["no polygon"]),
        ({"type": "Point", "coordinates": [0, 0]}, ["-d", "0"], ["no polygon"]),
        (SQUARE, ["-d", "25000km"], ["pi/2", "contains() and distance() answer any distance"]),
        (
            {"type": "LineString", "coordinates": [[0, 0], [400, 0]]},
            ["-d", "5km"],
            ["longitude 400.0 out of range"],
        ),
        (
            {"type": "Polygon", "coordinates": [[[-180, -90], [180, -90], [180, 90], [-180, 90]]]},
            ["-d", "5km"],
            ["whole sphere"],
        ),
    ],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_limits_of_the_region(tmp_path, geometry, args, words):
    src = tmp_path / "in.geojson"
    src.write_text(json.dumps(geometry))
    out = old_output(tmp_path, "out.geojson")
    assert_one_line_error(cli("offset", src, *args, "-o", out), *words)
    assert_unchanged(out)
    png = old_output(tmp_path, "out.png")
    if "pi/2" not in words:
        assert_one_line_error(cli("render", src, *args, "--size", "64x32", "-o", png), *words[:1])
    assert_unchanged(png)


@pytest.mark.parametrize(
    "dist, each, words",
    [
        ("40000km", False, ("distance 40000km (6.278 rad", "radius 6371008.8", "pi/2")),
        ("-1km", False, ("distance -1km is negative", "no polygon")),
        ("40000km", True, ("feature 0: distance 40000km (", "pi/2")),
        ("-1km", True, ("feature 0: distance -1km is negative",)),
    ],
)
def test_offset_distance_errors_quote_the_distance_as_given(tmp_path, dist, each, words):
    """A distance out of range is named as the user wrote it, not as the internal angle."""
    line = tmp_path / "line.geojson"
    line.write_text(json.dumps({"type": "LineString", "coordinates": [[-99, 19], [-98, 20]]}))
    proc = cli("offset", line, "-d", dist, *(["--each"] if each else []))
    assert_one_line_error(proc, *words)
    assert "0.000156" not in proc.stderr.decode()


@pytest.mark.parametrize("command", ["render", "tiles"])
@pytest.mark.parametrize(
    "dlist, words",
    [
        ("10km,50parsecs", ["unknown distance unit 'parsecs'", "50parsecs"]),
        ("10km,,50km", ["empty item", "10km,,50km"]),
        ("10km,50km,", ["empty item"]),
        ("10km,50km,10km", ["10km twice"]),
        ("10km,10000m", ["10000m twice", "as 10km before"]),
    ],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_bad_distance_lists(tmp_path, square, command, dlist, words):
    """A -d list with a bad unit, an empty item or a distance twice: one line, exit 2,
    nothing written."""
    out = tmp_path / ("out.png" if command == "render" else "out.mbtiles")
    extra = ["--size", "64x32"] if command == "render" else ["-z", "0-1"]
    proc = cli(command, square, "-d", dlist, *extra, "-o", out)
    assert_one_line_error(proc, *words)
    assert list(tmp_path.iterdir()) == [square]


def test_render_bands_refuse_styles_and_raster_input(tmp_path, square):
    proc = cli("render", square, "-d", "10km,20km", "--bands", "--fill", "red", "-o", "b.png")
    assert_one_line_error(proc, "--bands", "--fill")
    proc = cli("render", square, "-d", "10km,20km", "--classes", "3", "-o", "b.png")
    assert_one_line_error(proc, "several distances", "--classes")
    proc = cli("render", square, "-d", "10km,20km", "-o", "-")
    assert_one_line_error(proc, "one file per distance")
