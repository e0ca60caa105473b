"""Signed distance fields (``gloffset.distance_field``): values against the float64
reference, thresholds against the renders byte for byte, clamping and bad input."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import DATA, assert_one_line_error

import gloffset
from gloffset import reference
from gloffset.grids import Cube, Equirect, Tile

R = gloffset.EARTH_RADIUS
DISTANCES = (-50e3, 0.0, 127e3)


def reference_field(shape, p):
    """The float64 signed distance (metres) of points ``p`` from the judge."""
    dist = reference.distance_xyz(shape, p) * R
    inside = reference.contains_xyz(shape, p, 0.0)
    return np.where(inside, -dist, dist)


def sample(grid, n, seed=0):
    """``n`` random pixels ``(j, i)`` of a grid and their centres."""
    rng = np.random.default_rng(seed)
    h, w = grid.level_shape(grid.n_levels - 1)
    j, i = rng.integers(0, h, n), rng.integers(0, w, n)
    return j, i, grid.centers(grid.n_levels - 1, j, i)


def assert_within_ulps(values, want, ulps=2.0):
    spacing = np.spacing(np.abs(want).astype(np.float32)).astype(np.float64)
    err = np.abs(values.astype(np.float64) - want) / spacing
    assert err.max() <= ulps, f"{err.max():.2f} float32 ulps from the reference"


def assert_thresholds(shape, field, distances=DISTANCES):
    for d in distances:
        mask = field.threshold(d)
        want = gloffset.render(shape, d, field.grid)
        assert mask.dtype == np.uint8 and mask.shape == want.shape
        bad = np.argwhere(mask != want)
        assert len(bad) == 0, f"d={d}: {len(bad)} pixels differ from render, e.g. {bad[:3]}"


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


@pytest.fixture(scope="module")
def neighbours():
    """Mexico and its southern neighbours at 1:10m (shared borders cancel)."""
    fc = json.loads((DATA / "countries_10m.geojson").read_text())
    keep = {"Guatemala", "Belize", "Honduras", "El Salvador"}
    feats = [f for f in fc["features"] if f["properties"]["name"] in keep]
    assert len(feats) == len(keep)
    mexico = json.loads((DATA / "mexico_10m.geojson").read_text())
    feats += mexico["features"] if "features" in mexico else [mexico]
    return gloffset.read({"type": "FeatureCollection", "features": feats})


def test_mexico_equirect_thresholds_and_values(mexico):
    grid = Equirect(1024, 512)
    field = gloffset.distance_field(mexico, grid, max_distance=400e3)
    assert field.values.dtype == np.float32 and field.values.shape == (512, 1024)
    assert_thresholds(mexico, field)
    j, i, p = sample(grid, 3000)
    want = np.clip(reference_field(mexico, p), -400e3, 400e3)
    assert_within_ulps(field.values[j, i], want)


def test_mexico_regional_unclamped(mexico):
    grid = Equirect(160, 120, (-120, 10, -84, 37))
    field = gloffset.distance_field(mexico, grid)
    assert field.max_distance is None
    assert_thresholds(mexico, field, (-100e3, -2e3, 0.0, 3e3, 300e3))
    j, i, p = sample(grid, 2000, seed=1)
    assert_within_ulps(field.values[j, i], reference_field(mexico, p))


def test_neighbours_at_10m(neighbours):
    grid = Equirect(300, 200, (-95, 12, -85, 20))
    field = gloffset.distance_field(neighbours, grid, max_distance=300e3)
    assert_thresholds(neighbours, field, (-20e3, 0.0, 10e3))
    j, i, p = sample(grid, 1000, seed=2)
    want = np.clip(reference_field(neighbours, p), -300e3, 300e3)
    assert_within_ulps(field.values[j, i], want)
    # a shared border is no boundary: inside, far from the sea, the values stay negative
    assert (field.values < 0).sum() == (gloffset.render(neighbours, 0.0, grid) > 0).sum()


@pytest.mark.parametrize(
    "name, size, bounds",
    [
        ("Fiji", (256, 128), (-180, -90, 180, 90)),
        ("Fiji", (200, 160), (170, -25, -170, -10)),  # across the antimeridian
        ("Russia", (300, 200), (160, 55, -160, 75)),
        ("Antarctica", (256, 96), (-180, -90, 180, -60)),  # round the pole
    ],
)
def test_seams(world, name, size, bounds):
    shape = gloffset.read(world[name])
    grid = Equirect(*size, bounds)
    field = gloffset.distance_field(shape, grid)
    assert_thresholds(shape, field, (-30e3, 0.0, 60e3))
    j, i, p = sample(grid, 1000, seed=3)
    assert_within_ulps(field.values[j, i], reference_field(shape, p))


def test_cube_and_tile(mexico):
    cube = Cube(48)
    field = gloffset.distance_field(mexico, cube, max_distance=300e3)
    assert field.values.shape == (6, 48, 48)
    assert_thresholds(mexico, field)
    face = gloffset.distance_field(mexico, cube.faces[4], max_distance=300e3)
    assert np.array_equal(face.values, field.values[4])
    tile = Tile(4, 3, 6, size=128)  # the tile of Mexico City
    field = gloffset.distance_field(mexico, tile, max_distance=300e3)
    assert field.values.shape == (128, 128)
    assert_thresholds(mexico, field)
    j, i, p = sample(tile, 1000, seed=4)
    want = np.clip(reference_field(mexico, p), -300e3, 300e3)
    assert_within_ulps(field.values[j, i], want)


def brute_field(shape, p, radius):
    """The field's value at points ``p`` by brute force: the least float64 distance to
    every boundary arc (:func:`~gloffset.geometry.sphere.arc_distance`), signed by the
    judge's inside test, times ``radius``, rounded once to float32."""
    from gloffset.edges import CurveArcs
    from gloffset.geometry.sphere import arc_distance

    arcs = CurveArcs.from_shape(shape)
    b = np.flatnonzero(arcs.boundary)
    d = np.array([arc_distance(q[None], arcs.a[b], arcs.b[b], arcs.n[b]).min() for q in p])
    v = d * radius
    return np.where(reference.contains_xyz(shape, p, 0.0), -v, v).astype(np.float32)


@pytest.mark.parametrize(
    "grid", [Tile(5, 6, 13), Tile(6, 13, 28), Tile(8, 57, 113), Equirect(512, 256)]
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_values_are_the_nearest_arcs(mexico, grid):
    """Each value is the least exact float64 distance over all the boundary arcs, whatever
    pruning found it: bit for bit with the CPU backend, within 1 float32 ulp (its sign
    the same) with the GPU's (its float64 finishing within FIELD_ERR); on the tiles the
    tile server asks for (Mexico's west coast at z5, its Pacific coast at z6, Mexico City
    at z8, radians) and a global grid (metres, far pixels included)."""
    radius = 1.0 if isinstance(grid, Tile) else R
    j, i, p = sample(grid, 300, seed=8)
    want = brute_field(mexico, p, radius)
    cpu = gloffset.distance_field(mexico, grid, radius=radius, backend="cpu").values[j, i]
    assert cpu.tobytes() == want.tobytes()
    gpu = gloffset.distance_field(mexico, grid, radius=radius).values[j, i]
    assert (np.signbit(gpu) == np.signbit(want)).all()
    assert (np.abs(gpu.astype(np.float64) - want) <= np.spacing(np.abs(want))).all()


def test_exact_is_arc_distance_bit_for_bit(mexico):
    """The field's own kernel of the arc distance (its per-node products made once, each
    branch on its own pairs) has the bits of :func:`arc_distance`, on Mexico's nodes,
    merged ones included, from points on and near its coast and far away."""
    from gloffset.geometry.sphere import arc_distance, normalize
    from gloffset.raster.fields.walk import exact_distances
    from gloffset.raster.vector.node_levels import NodeArcs

    nodes = NodeArcs.from_shape(mexico)
    rng = np.random.default_rng(9)
    near = nodes.a[rng.integers(0, len(nodes.a), 3000)] + rng.normal(size=(3000, 3)) * 1e-3
    c = np.concatenate([nodes.b[:1000], normalize(near), normalize(rng.normal(size=(3000, 3)))])
    cell = rng.integers(0, len(c), 200_000)
    node = rng.integers(0, len(nodes.a), 200_000)
    want = arc_distance(c[cell], nodes.a[node], nodes.b[node], nodes.n[node])
    assert exact_distances(c, cell, nodes, node).tobytes() == want.tobytes()


def test_lines_and_points_are_unsigned():
    lines = {
        "type": "MultiLineString",
        "coordinates": [[[-10, 40], [20, 45], [35, 30]], [[100, -20], [120, -25]]],
    }
    for geom in (lines, {"type": "Point", "coordinates": [30, 60]}):
        shape = gloffset.read(geom)
        grid = Equirect(128, 64)
        field = gloffset.distance_field(shape, grid)
        assert (field.values >= 0).all()
        assert_thresholds(shape, field, (1e3, 500e3))
        j, i, p = sample(grid, 500, seed=5)
        assert_within_ulps(field.values[j, i], reference.distance_xyz(shape, p) * R)
        with pytest.raises(gloffset.InvalidDistanceError, match="no polygon"):
            field.threshold(-1e3)


def test_max_distance_clamps(world):
    shape = gloffset.read(world["Italy"])
    grid = Equirect(200, 200, (0, 30, 25, 50))
    full = gloffset.distance_field(shape, grid).values
    m = 60e3
    clamped = gloffset.distance_field(shape, grid, max_distance=m)
    assert clamped.max_distance == m
    assert np.array_equal(clamped.values, np.clip(full, np.float32(-m), np.float32(m)))
    assert (clamped.values == np.float32(m)).any() and (clamped.values == -np.float32(m)).any()
    assert np.array_equal(clamped.threshold(m), gloffset.render(shape, m, grid))
    with pytest.raises(gloffset.OptionError, match="beyond the field's max_distance"):
        clamped.threshold(-70e3)


def test_radius_units(world):
    shape = gloffset.read(world["Italy"])
    grid = Equirect(64, 64, (5, 35, 20, 48))
    metres = gloffset.distance_field(shape, grid).values
    radians = gloffset.distance_field(shape, grid, radius=1.0)
    assert np.allclose(radians.values * R, metres, rtol=1e-6)
    assert np.array_equal(radians.threshold(0.01), gloffset.render(shape, 0.01, grid, radius=1.0))


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"max_distance": 0.0}, gloffset.OptionError, "max_distance must be a positive"),
        ({"max_distance": -5.0}, gloffset.OptionError, "max_distance must be a positive"),
        ({"max_distance": float("nan")}, gloffset.InvalidDistanceError, "finite"),
        ({"radius": -1.0}, gloffset.InvalidDistanceError, "radius"),
        ({"ellipsoid": "WGS84"}, gloffset.OptionError, "ellipsoid"),
        ({"max_distance": True}, gloffset.InvalidDistanceError, "got True"),
        ({"max_distance": "500 parsecs"}, gloffset.InvalidDistanceError, "unknown distance"),
        ({"max_distance": "-5km"}, gloffset.OptionError, "max_distance must be a positive"),
    ],
)
def test_bad_options(world, kwargs, error, match):
    with pytest.raises(error, match=match):
        gloffset.distance_field(world["Italy"], Equirect(32, 16), **kwargs)


def test_bad_grid_and_input(world):
    with pytest.raises(gloffset.OptionError, match="grid must be a gloffset.grids grid"):
        gloffset.distance_field(world["Italy"], (256, 128))
    with pytest.raises(gloffset.InvalidGeometryError):
        gloffset.distance_field({"type": "Point", "coordinates": [float("nan"), 0]}, Equirect(8, 4))
    field = gloffset.distance_field(world["Italy"], Equirect(32, 16))
    with pytest.raises(gloffset.InvalidDistanceError, match="finite"):
        field.threshold(float("nan"))


@pytest.mark.slow
def test_mexico_global_unclamped(mexico):
    grid = Equirect(512, 256)
    field = gloffset.distance_field(mexico, grid)
    assert_thresholds(mexico, field, (-200e3, 0.0, 127e3, 2000e3))
    j, i, p = sample(grid, 3000, seed=6)
    assert_within_ulps(field.values[j, i], reference_field(mexico, p))


def test_distances_with_units(mexico):
    """threshold and max_distance take "127km" as every public function does: the same
    field and masks as the numbers (a bare ValueError, and a whole field computed before
    an error, before)."""
    grid = Equirect(90, 60, (-120, 10, -80, 35))
    field = gloffset.distance_field(mexico, grid, max_distance="100km")
    plain = gloffset.distance_field(mexico, grid, max_distance=100e3)
    assert field.max_distance == 100e3 and np.array_equal(field.values, plain.values)
    for text, d in (("-50km", -50e3), ("0m", 0.0), ("60000", 60e3), ("0.01rad", 0.01 * R)):
        assert np.array_equal(field.threshold(text), plain.threshold(d)), text
    assert np.array_equal(field.threshold("-50km"), gloffset.render(mexico, -50e3, grid))
    with pytest.raises(gloffset.OptionError, match="beyond the field's max_distance"):
        field.threshold("101km")
    radians = gloffset.distance_field(mexico, grid, max_distance="0.02rad", radius=1.0)
    assert radians.max_distance == 0.02
    for bad, match in ((True, "got True"), ("far", "cannot read distance"), (None, "number")):
        with pytest.raises(gloffset.InvalidDistanceError, match=match):
            field.threshold(bad)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"grid": Equirect(200000, 100000)}, "the field has 20000000000 pixels, more than"),
        ({"grid": Cube(20000)}, "the field has 2400000000 pixels, more than"),
        ({"max_distance": "500km!"}, "cannot read distance"),
        ({"max_distance": False}, "got False"),
    ],
)
def test_refused_before_any_work(kwargs, match):
    """Refused before the input is read (it does not exist here), let alone the field."""
    args = {"grid": Equirect(8, 4), **kwargs}
    with pytest.raises(gloffset.GloffsetError, match=match):
        gloffset.distance_field("no/such/input.geojson", **args)


def cli(*args, cwd=None):
    """Run ``python -m gloffset ARGS``."""
    return subprocess.run(
        [sys.executable, "-m", "gloffset", *map(str, args)], capture_output=True, cwd=cwd
    )


def test_cli_geotiff_npy_and_cube(mexico_path, mexico, tmp_path):
    rasterio = pytest.importorskip("rasterio")
    tif, npy = tmp_path / "dist.tif", tmp_path / "dist.npy"
    common = (mexico_path, "--size", "200x100", "--bounds", "-125,5,-75,40")
    proc = cli("field", *common, "--max-distance", "300km", "-o", tif)
    assert proc.returncode == 0, proc.stderr.decode()
    grid = Equirect(200, 100, (-125, 5, -75, 40))
    want = gloffset.distance_field(mexico, grid, max_distance=300e3).values
    with rasterio.open(tif) as src:
        band = src.read(1)
        assert src.crs.to_epsg() == 4326 and src.dtypes == ("float32",)
        assert tuple(src.transform)[:6] == pytest.approx((0.25, 0, -125, 0, -0.35, 40))
        assert src.nodata is None and "negative inside" in src.tags()["DESCRIPTION"]
        assert float(src.tags()["MAX_DISTANCE"]) == 300e3
    beyond = np.abs(want) >= np.float32(300e3)
    assert beyond.any() and np.array_equal(band, want)  # clamped to +-300 km, as the .npy
    assert cli("field", *common, "-o", npy).returncode == 0
    full = gloffset.distance_field(mexico, grid).values
    assert np.array_equal(np.load(npy), full)
    assert cli("field", *common, "--backend", "cpu", "-o", npy).returncode == 0
    cpu = np.load(npy)  # the GPU's values within 1 float32 ulp of the CPU's, same signs
    assert (np.signbit(cpu) == np.signbit(full)).all()
    assert (np.abs(cpu.astype(np.float64) - full) <= np.spacing(np.abs(cpu))).all()
    bad = cli("field", *common, "--backend", "cuda", "-o", npy)
    assert bad.returncode == 2 and b"'cuda' is not one of 'gpu', 'cpu'" in bad.stderr
    folder = tmp_path / "faces"
    proc = cli("field", mexico_path, "--grid", "cube", "--size", "16", "-o", folder)
    assert proc.returncode == 0, proc.stderr.decode()
    faces = gloffset.distance_field(mexico, Cube(16)).values
    for k, name in enumerate(("px", "nx", "py", "ny", "pz", "nz")):
        assert np.array_equal(np.load(folder / f"{name}.npy"), faces[k])


def test_cli_geotiff_with_max_distance_keeps_the_sign(mexico_path, mexico, tmp_path):
    """Beyond --max-distance a field GeoTIFF holds -max inside and +max outside (as the
    .npy): a reader's threshold at any |d| < max is the render at d. With NaN there (the
    deep interior and the far exterior alike) v <= -50 km found 126 px of the 480."""
    rasterio = pytest.importorskip("rasterio")
    tif = tmp_path / "mx.tif"
    proc = cli("field", mexico_path, "--size", "720x360", "--max-distance", "100km", "-o", tif)
    assert proc.returncode == 0, proc.stderr.decode()
    with rasterio.open(tif) as src:
        v, tags, nodata = src.read(1), src.tags(), src.nodata
    grid = Equirect(720, 360)
    for d in (-50e3, -99e3, 0.0, 50e3, 99e3):
        mine = (v < d) if d < 0 else (v <= d)
        want = gloffset.render(mexico, d, grid, backend="cpu") == 255
        assert want.any() and np.array_equal(mine, want), d
    assert int((v < -50e3).sum()) == 480
    assert (v == np.float32(-100e3)).any() and (v == np.float32(100e3)).any()
    assert "clamped" in tags["DESCRIPTION"] and nodata is None


@pytest.mark.parametrize(
    "args, words",
    [
        (["--size", "200000x100000", "-o", "x.npy"], "the field has 20000000000 pixels"),
        (["--grid", "cube", "--size", "20000", "-o", "faces"], "2400000000 pixels, more than"),
        (["--grid", "cube", "--size", "8", "-o", "x.tif"], "give a folder name"),
        (["--grid", "cube", "--size", "8", "-o", "x.npy"], "give a folder name"),
        (["--grid", "cube", "--size", "8", "-o", "a_file"], "a file is in the way"),
        (["--size", "64x32", "--densify", "-1", "-o", "x.npy"], "densify tolerance '-1'"),
    ],
)
def test_cli_refused_before_any_work(mexico_path, tmp_path, args, words):
    """One line, exit status 2, nothing written (a field of 2e10 pixels ended in a numpy
    ArrayMemoryError at 4.6 GB; --grid cube -o x.tif made a folder x.tif)."""
    (tmp_path / "a_file").write_bytes(b"kept")
    proc = cli("field", mexico_path, *args, cwd=tmp_path)
    assert_one_line_error(proc, words)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]
    assert (tmp_path / "a_file").read_bytes() == b"kept"


def test_cli_geotiff_without_rasterio_refused_first(mexico_path, tmp_path, monkeypatch):
    """Without rasterio, -o x.tif is refused before the input is read (the whole field
    was computed first, 5 s at 4096 x 2048); a .npy needs no rasterio."""
    from click.testing import CliRunner

    from gloffset.cli import field as field_cli
    from gloffset.cli import main

    monkeypatch.setitem(sys.modules, "rasterio", None)  # import rasterio: ImportError

    def no_read(*args, **kwargs):
        raise AssertionError("the input was read")

    monkeypatch.setattr(field_cli, "read", no_read)
    for name in ("x.tif", "x.cog.tif"):
        r = CliRunner().invoke(main, ["field", str(mexico_path), "-o", str(tmp_path / name)])
        assert r.exit_code == 2 and "needs rasterio" in r.output, r.output
        assert "the input was read" not in r.output
    monkeypatch.undo()
    monkeypatch.setitem(sys.modules, "rasterio", None)
    assert list(tmp_path.iterdir()) == []
    npy = tmp_path / "x.npy"
    r = CliRunner().invoke(main, ["field", str(mexico_path), "--size", "32x16", "-o", str(npy)])
    assert r.exit_code == 0 and np.load(npy).shape == (16, 32), r.output


@pytest.mark.parametrize(
    "grid, max_distance, steps",
    [(Equirect(2048, 1024), None, 3), (Cube(64), 300e3, 12), (Tile(4, 3, 6), 1.0, 2)],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_progress_rises_to_the_total(mexico, grid, max_distance, steps):
    """``progress(done, total)`` follows the pixels: rising, a step per block of pixels
    (1024 a side) and face, ending at the total (the pixels, twice for a shape with
    polygons: the distances, then the signs); the values are those without it."""
    seen = []
    radius = 1.0 if isinstance(grid, Tile) else R
    field = gloffset.distance_field(
        mexico,
        grid,
        max_distance=max_distance,
        radius=radius,
        progress=lambda done, total: seen.append((done, total)),
    )
    done = np.array([d for d, _ in seen])
    pixels = field.values.size
    assert {t for _, t in seen} == {2 * pixels}
    assert (np.diff(done) > 0).all() and done[-1] == 2 * pixels
    assert pixels in done  # the walk's pixels all counted before the inside test
    assert len(seen) >= steps
    plain = gloffset.distance_field(mexico, grid, max_distance=max_distance, radius=radius)
    assert np.array_equal(field.values, plain.values)


@pytest.mark.slow
def test_cli_progress_on_a_terminal_only(mexico_path, tmp_path):
    """The field shows a progress bar on stderr when forced (GLOFFSET_PROGRESS=1, as on
    a terminal), nothing otherwise; the file is the same either way."""
    out = tmp_path / "f.npy"
    args = (mexico_path, "--size", "1024x512", "--max-distance", "500km", "-o", out)
    quiet = cli("field", *args)
    assert quiet.returncode == 0 and quiet.stderr == b"", quiet.stderr.decode()
    written = out.read_bytes()
    env = {**os.environ, "GLOFFSET_PROGRESS": "1"}
    shown = subprocess.run(
        [sys.executable, "-m", "gloffset", "field", *map(str, args)],
        capture_output=True,
        text=True,
        env=env,
    )
    assert shown.returncode == 0, shown.stderr
    assert "100%" in shown.stderr and "1.05M/1.05M px" in shown.stderr, shown.stderr
    assert out.read_bytes() == written


@pytest.mark.parametrize(
    "args, words",
    [
        (("--max-distance", "0km", "-o", "d.tif"), ("--max-distance", "'0km'")),
        (("--max-distance", "-5km", "-o", "d.tif"), ("--max-distance",)),
        (("--max-distance", "5parsec", "-o", "d.tif"), ("5parsec",)),
        (("--size", "big", "-o", "d.tif"), ("--size", "'big'")),
        (("-o", "d.png"), ("d.png", ".tif", ".npy")),
        (("--grid", "hexagons", "-o", "d.tif"), ("hexagons",)),
        (("--grid", "cube", "--bounds", "0,0,1,1", "-o", "faces"), ("--bounds",)),
        (("--ellipsoid", "WGS84", "-o", "d.tif"), ("'WGS84'", "intercept", "3 times")),
        (("--ellipsoid", "Mars", "-o", "d.tif"), ("'Mars'", "WGS84")),
    ],
)
def test_cli_bad_input(mexico_path, tmp_path, args, words):
    proc = cli("field", mexico_path, *args, cwd=tmp_path)
    assert_one_line_error(proc, *words)
    assert not (tmp_path / "d.tif").exists()


@pytest.mark.parametrize("grid", [Equirect(512, 256, (-120, 10, -80, 30)), Cube(32)])
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_thresholds_at_a_pixels_own_value(mexico, grid):
    """At ``d`` equal to a pixel's float32 value the float32 values cannot tell: those
    pixels are decided in float64. The mask is then the float64 render's byte for byte;
    the GPU render may differ from that only within its stated error (1e-3 of a pixel) of
    ``d``, and does, at such pixels."""
    field = gloffset.distance_field(mexico, grid, max_distance=500e3)
    v = field.values.ravel()
    pick = np.flatnonzero((np.abs(v) > 1e3) & (np.abs(v) < 400e3))
    level = grid.faces[0] if isinstance(grid, Cube) else grid
    pixel = 2.0 * float(np.max(level.rho(level.n_levels - 2))) * R  # a 2 x 2 cell's diameter
    for d in (float(v[pick[0]]), float(v[pick[len(pick) // 2]]), float(v[pick[-1]])):
        mask = field.threshold(d)
        assert np.array_equal(mask, gloffset.render(mexico, d, grid, backend="cpu"))
        off = mask != gloffset.render(mexico, d, grid)
        assert (np.abs(field.values[off].astype(np.float64) - d) <= 1e-3 * pixel).all()


def test_the_lists_follow_the_pixels(mexico, monkeypatch):
    """Far from the coast a cell's candidates are the few arcs that can be nearest to one
    of its pixels, not every arc within a cell's width of its nearest distance: the
    output level gets a handful of candidates per pixel (27 with the plain ``2 rho``
    pruning of a nearest-neighbour search, here), and the values stay exact."""
    from gloffset.raster.fields import walk as walkmod

    seen = {}
    bound = walkmod._bound

    def counting(f, *args, final, **kw):
        if final:
            seen["cells"] = seen.get("cells", 0) + len(f.cells)
            seen["pairs"] = seen.get("pairs", 0) + len(f.pair_cell)
        return bound(f, *args, final=final, **kw)

    monkeypatch.setattr(walkmod, "_bound", counting)
    grid = Equirect(1024, 512)
    field = gloffset.distance_field(mexico, grid, backend="cpu")
    assert seen["cells"] == 1024 * 512
    assert seen["pairs"] / seen["cells"] < 8.0
    j, i, p = sample(grid, 2000, seed=7)
    assert_within_ulps(field.values[j, i], reference_field(mexico, p))


@pytest.mark.parametrize("m", [np.inf, 0.02])
def test_the_walks_pieces_change_no_bit(mexico, monkeypatch, m):
    """The bound's rounds cut into pieces of a few pairs (between cells), and the
    bisector test run on the gathered pairs it reads or on every pair: the same lists in
    the same order, the same distances and measured pairs, bit for bit (each cell is
    bounded on its own)."""
    from gloffset.raster.fields import walk as walkmod
    from gloffset.raster.vector.node_levels import NodeArcs

    nodes = NodeArcs.from_shape(mexico)
    grid = Equirect(160, 100, (-118, 14, -86, 33))
    last = grid.n_levels - 1
    one = Equirect(12, 12, (-118, 14, -86, 33))  # one level: the tree's nodes at the pixels

    def walked():
        got = []
        for stop, split in ((last - 2, True), (last - 2, False)):
            for f, dist in walkmod.walk_levels(nodes, grid, m, stop, split):
                got += [f.cells, f.pair_cell, f.pair_arc, dist]
        for g in (grid, one):
            for f, dist, pairs in walkmod.walk_levels(nodes, g, m, g.n_levels - 1, pairs=True):
                got += [f.cells, dist, *pairs]
        return got

    want = walked()
    assert sum(len(x) for x in want[1::4]) > 1000  # lists of the levels above
    for pieces, every in ((100, 0.0), (1 << 30, 2.0)):
        monkeypatch.setattr(walkmod, "_BOUND_PAIRS", pieces)
        monkeypatch.setattr(walkmod, "_ALL_KEPT", every)
        got = walked()
        assert len(got) == len(want)
        for a, b in zip(got, want):
            assert a.dtype == b.dtype and np.array_equal(a.view(np.uint8), b.view(np.uint8))


def test_bisector_pruning_is_rigorous():
    """A node is dropped from a cell only where every point within ``reach`` of the
    centre is nearer to the cell's vertex than to every point of the node's cap: checked
    on random caps, vertices and discs, at points sampled over each disc (its rim
    included), caps large and small, near and far."""

    from gloffset.geometry.sphere import angle, normalize, rotate
    from gloffset.raster.fields.dominance import maybe_nearer

    rng = np.random.default_rng(11)
    n = 4000
    c = normalize(rng.normal(size=(n, 3)))
    reach = 10.0 ** rng.uniform(-4, -0.5, n)
    r = 10.0 ** rng.uniform(-5, -0.5, n)

    # vertices and cap centres at random distances from the centre, in random directions
    def away(p, dist):
        axis = normalize(np.cross(p, rng.normal(size=p.shape)))
        return rotate(p, axis, dist)

    x = away(c, 10.0 ** rng.uniform(-4, 0, n))
    mid = away(x, 10.0 ** rng.uniform(-4, 0, n))
    cm = np.einsum("ij,ij->i", c, mid)
    t = np.arccos(np.clip(cm, -1, 1))
    vcos = np.einsum("ij,ij->i", c, x)
    vm = np.einsum("ij,ij->i", x, mid)
    keep = maybe_nearer(
        (cm, t, vcos, vm), (r, np.cos(r), np.sin(r)), (reach, np.cos(reach), np.sin(reach))
    )
    dropped = np.flatnonzero(~keep)
    assert 0.2 * n < len(dropped) < 0.9 * n
    for _ in range(40):
        k = dropped
        frac = np.sqrt(rng.uniform(0, 1, len(k)))
        frac[: len(k) // 4] = 1.0  # the rims
        q = away(c[k], reach[k] * frac * (1 - 1e-12))
        to_cap = np.maximum(angle(q, mid[k]) - r[k], 0.0)
        assert (angle(q, x[k]) < to_cap).all()


def test_threshold_cuts_compare_float32_values_as_float64_does():
    """The float32 comparisons of ``threshold`` agree with comparing the values in float64
    with ``d``, for ``d`` on, between and beside float32 numbers (and 0, -0, tiny), and the
    band it decides again in float64 holds every value within two float32 spacings of d."""
    from gloffset.raster.field import _cuts

    rng = np.random.default_rng(7)
    base = rng.uniform(-0.2, 0.2, 300).astype(np.float32)
    ds = [0.0, -0.0, 1e-40, -1e-40, 1e-9, -1e-9]
    for b in base:
        ds += [float(b), float(np.nextafter(float(b), 1.0)), float(np.nextafter(float(b), -1.0))]
    for d in ds:
        c32 = np.float32(d)
        x = c32 + np.arange(-12, 13, dtype=np.float32) * np.spacing(c32)
        x = np.concatenate([x, -x, np.float32([0.0, -0.0, 1e-45, -1e-45])])
        cut, lo, hi = _cuts(d)
        xd = x.astype(np.float64)
        want = (xd <= d) if d >= 0 else (xd < d)
        got = (x <= cut) if d >= 0 else (x < cut)
        assert np.array_equal(got, want), d
        sp = np.spacing(np.maximum(np.abs(xd), abs(d)).astype(np.float32)).astype(np.float64)
        near = np.abs(xd - d) <= 2.0 * sp
        assert ((x >= lo) & (x <= hi))[near].all(), d


def _level0(grid):
    """The level-0 shape of ``grid`` and its cells' centres and radii, row by row."""
    h, w = grid.level_shape(0)
    j, i = np.divmod(np.arange(h * w), w)
    return h, w, grid.centers(0, j, i), grid.rho_at(0, j, i)


@pytest.mark.parametrize(
    "which, grid",
    [
        ("mexico", Tile(5, 6, 13)),
        ("mexico", Tile(8, 55, 110)),
        ("world", Tile(4, 0, 4)),  # Chukotka and Alaska, at the antimeridian
        ("world", Equirect(256, 256, (170, -30, -170, -10))),  # Fiji, across 180 degrees
    ],
)
def test_a_small_grid_starts_from_its_own_list(which, grid, request, monkeypatch):
    """A tile or a regional box is first walked as one cell: its level-0 cells start from
    the nodes that can be nearest to some point of the grid, not from the tree's top. The
    values are those of the walk from the top, bit for bit; a global grid starts from the
    top."""
    from gloffset.raster.fields import walk as field_walk
    from gloffset.raster.vector.node_levels import NodeArcs

    if which == "mexico":
        shape = request.getfixturevalue("mexico")
    else:
        shape = gloffset.read(DATA / "world_110m.geojson")
    nodes = NodeArcs.from_shape(shape)
    top = nodes.top[nodes.boundary[nodes.top]]
    h, w, c, rho = _level0(grid)
    own = field_walk.root_list(nodes, np.inf, c, rho, top)
    assert not np.array_equal(np.sort(own), np.sort(top))
    world = Equirect(64, 32)
    h, w, c, rho = _level0(world)
    assert field_walk.root_list(nodes, np.inf, c, rho, top) is top
    got = gloffset.distance_field(shape, grid, radius=1.0).values
    monkeypatch.setattr(field_walk, "_ROOT_REACH", 0.0)  # every grid from the top
    want = gloffset.distance_field(shape, grid, radius=1.0).values
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))


@pytest.mark.parametrize(
    "which, grid",
    [
        ("mexico", Tile(5, 6, 13)),
        ("countries", Tile(3, 1, 3)),  # the US, Mexico and the Caribbean: long lists
        ("world", Equirect(256, 256, (170, -30, -170, -10))),  # across 180 degrees
    ],
)
def test_start_lists_hold_the_nearest_arcs(which, grid, request, monkeypatch):
    """A small grid's level-0 cells start from the lists of a quadtree of blocks of
    cells (``start_pairs``), each bounded from its parent's: shorter than the root's
    list, and each still holds the nearest arc of every point of its cell: at the corner
    pixels of sampled cells, the least exact distance over the leaves of the cell's
    list is that over all arcs, bit for bit."""
    from gloffset.raster.fields import walk as field_walk
    from gloffset.raster.vector.node_levels import NodeArcs

    if which == "mexico":
        shape = request.getfixturevalue("mexico")
    else:
        shape = gloffset.read(
            DATA / f"{'countries_10m' if which == 'countries' else 'world_110m'}.geojson"
        )
    nodes = NodeArcs.from_shape(shape)
    top = nodes.top[nodes.boundary[nodes.top]]
    h, w, c, rho = _level0(grid)
    root = field_walk.root_list(nodes, np.inf, c, rho, top)
    if which == "countries":  # long enough a root list for the quadtree
        assert len(root) * h * w >= field_walk._QUAD_PAIRS
    monkeypatch.setattr(field_walk, "_QUAD_PAIRS", 0)  # the quadtree, however short
    pc, pn = field_walk.start_pairs(nodes, np.inf, (h, w), c, rho, top)
    assert np.all(np.diff(pc) >= 0)  # sorted by cell
    assert len(pn) < 0.5 * h * w * len(root)
    last = grid.n_levels - 1
    side = 1 << last  # output pixels per level-0 cell side
    hp, wp = grid.level_shape(last)
    rng = np.random.default_rng(3)
    leaves = np.flatnonzero(nodes.leaf)
    for cell in rng.choice(h * w, 24, replace=False):
        mine = pn[pc == cell]
        own = np.concatenate(
            [
                nodes.leaf_order[s : s + n]
                for s, n in zip(nodes.leaf_start[mine], nodes.leaf_count[mine])
            ]
        )
        cj, ci = divmod(int(cell), w)
        rows = np.minimum(
            [cj * side, cj * side, cj * side + side - 1, cj * side + side - 1], hp - 1
        )
        cols = np.minimum(
            [ci * side, ci * side + side - 1, ci * side, ci * side + side - 1], wp - 1
        )
        p = grid.centers(last, rows, cols)
        for q in p:
            one = q[None, :]
            got = field_walk.exact_distances(one, np.zeros(len(own), np.int64), nodes, own).min()
            want = field_walk.exact_distances(
                one, np.zeros(len(leaves), np.int64), nodes, leaves
            ).min()
            assert got.view(np.uint64) == want.view(np.uint64), (cell, q)
