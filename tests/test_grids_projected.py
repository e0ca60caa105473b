"""Projected grids (any CRS pyproj knows) against the float64 reference at pyproj's pixel
centres: polar stereographic (a formula for the bounds), LAEA, UTM and an orthographic
projection with pixels outside its domain (bounds from the pixel centres)."""

import json
import pickle

import numpy as np
import pytest
from conftest import DATA

import gloffset
from gloffset.errors import InvalidGridError
from gloffset.geometry.sphere import angle, lonlat_to_xyz
from gloffset.reference import contains_xyz, distance_xyz

pyproj = pytest.importorskip("pyproj")
from gloffset.grids import Projected  # noqa: E402
from gloffset.grids.projected import polar_scale_min  # noqa: E402

R = 6371008.8
EPS = 1e-3  # of a pixel: the band where the GPU's float32 may differ (render's contract)
ORTHO = "+proj=ortho +lat_0=-70 +lon_0=30 +ellps=WGS84"


@pytest.fixture(scope="module")
def world110():
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    return {f["properties"]["name"]: f for f in fc["features"]}


def pole_rings():
    """Antarctica-like rings round the south pole: a wavy coast about 70 S with a bay,
    and an island ring inside it that has a hole."""
    lon = np.linspace(-180.0, 180.0, 721)[:-1]
    lat = -70.0 + 4.0 * np.sin(np.radians(5 * lon)) + 2.0 * np.cos(np.radians(13 * lon))
    coast = np.column_stack([lon, lat])
    # a polygon around the pole: a ring cut at the antimeridian, closed along it
    outer = np.vstack([[-180.0, -90.0], coast, [180.0, lat[0]], [180.0, -90.0], [-180.0, -90.0]])
    t = np.linspace(0.0, 2 * np.pi, 200)[:-1]
    isle = np.column_stack([60 + 6 * np.cos(t), -62 + 2 * np.sin(t)])
    hole = np.column_stack([60 + 2 * np.cos(t[::-1]), -62 + 0.6 * np.sin(t[::-1])])
    return {
        "type": "MultiPolygon",
        "coordinates": [
            [outer[::-1].tolist()],
            [np.vstack([isle, isle[:1]]).tolist(), np.vstack([hole, hole[:1]]).tolist()],
        ],
    }


def centres(grid):
    jj, ii = np.meshgrid(np.arange(grid.height), np.arange(grid.width), indexing="ij")
    return grid.centers(grid.n_levels - 1, jj.ravel(), ii.ravel())


def boundary_distance(shape, p):
    from gloffset.edges import CurveArcs
    from gloffset.geometry.sphere import arc_distance

    arcs = CurveArcs.from_shape(shape)
    ring = arcs.group >= 0
    out = np.full(len(p), np.inf)
    a, b = arcs.a[ring], arcs.b[ring]
    for s in range(0, len(a), 256):
        out = np.minimum(
            out, arc_distance(p[:, None], a[None, s : s + 256], b[None, s : s + 256]).min(axis=1)
        )
    return out


def assert_reference(shape, d, grid, mask):
    """``mask`` is the float64 reference at pyproj's pixel centres (pixels outside the
    domain: outside), except within EPS of a pixel of the boundary."""
    assert mask.shape == (grid.height, grid.width) and mask.dtype == np.uint8
    p = centres(grid)
    valid = grid.valid(grid.n_levels - 1)
    valid = np.ones(grid.shape, bool) if valid is None else valid
    want = contains_xyz(shape, p, d / R).reshape(grid.shape) & valid
    bad = np.flatnonzero((mask.ravel() == 255) != want.ravel())
    if len(bad):
        eps = EPS * float(grid.area_rho_at(grid.n_levels - 1, 0, 0)) * 2.0
        near = np.abs(distance_xyz(shape, p[bad]) - abs(d) / R) <= eps
        near |= boundary_distance(shape, p[bad]) <= eps
        assert np.all(near), f"{len(bad)} pixels differ from the reference beyond the epsilon"
    return want


def assert_glsl_and_texture_masks(shape, grid, texture, distances=(-50e3, 0.0, 50e3)):
    """At each distance: ``grid`` takes its GLSL function and its masks are the float64
    reference at pyproj's pixel centres; so are those of ``texture`` (the same grid on the
    texture path) where they differ from the GLSL path's."""
    texture.centres = "texture"
    assert grid.centres == "glsl"
    for d in distances:
        mask = gloffset.render(shape, d, grid)
        want = assert_reference(shape, d, grid, mask)
        assert want.any() and not want.all()
        other = gloffset.render(shape, d, texture)
        if not np.array_equal(other, mask):
            assert_reference(shape, d, texture, other)


def test_polar_scale_is_the_smallest_scale():
    """The formula's k_min (EPSG:3031, 3413, UPS north) is pyproj's scale at the pole and
    at most the scale anywhere else."""
    for code, pole in (("EPSG:3031", -90.0), ("EPSG:3413", 90.0), ("EPSG:5041", 90.0)):
        crs = pyproj.CRS(code)
        k = polar_scale_min(crs)
        lat = np.concatenate([[pole * (1 - 1e-9)], np.linspace(pole, pole * 0.2, 200)[1:]])
        f = pyproj.Proj(crs).get_factors(np.zeros_like(lat), lat)
        assert abs(f.meridional_scale[0] - k) < 1e-8
        assert np.all(f.meridional_scale >= k * (1 - 1e-9))  # pyproj differentiates numerically
    assert polar_scale_min(pyproj.CRS("EPSG:3035")) is None


@pytest.mark.parametrize(
    "crs, bounds, size",
    [
        ("EPSG:3031", (-3.3e6, -3.1e6, 3.5e6, 3.0e6), (150, 120)),  # the formula
        ("EPSG:32633", (1.0e5, 4.0e6, 9.0e5, 5.3e6), (110, 150)),  # the formula (k0)
        ("EPSG:32633", (-6e6, 4.0e6, 6e6, 5.3e6), (110, 60)),  # too wide: the pixels
        ("EPSG:3035", (2.5e6, 1.4e6, 6.5e6, 5.5e6), (120, 130)),  # the formula (LAEA)
        (ORTHO, (-8e6, -7e6, 8e6, 8e6), (130, 110)),  # pixels outside the domain
    ],
)
def test_bounds_cover_the_pixel_centres(crs, bounds, size):
    """rho of every cell of every level covers each of its pixels' centres (by brute
    force), and the grid's pixel centres are pyproj's inverse read as sphere points."""
    g = Projected(*size, crs=crs, bounds=bounds)
    last = g.n_levels - 1
    jj, ii = np.meshgrid(np.arange(g.height), np.arange(g.width), indexing="ij")
    p = g.centers(last, jj, ii)
    valid = g.valid(last)
    valid = np.ones(g.shape, bool) if valid is None else valid
    x = bounds[0] + (ii + 0.5) * (bounds[2] - bounds[0]) / g.width
    y = bounds[3] - (jj + 0.5) * (bounds[3] - bounds[1]) / g.height
    inv = pyproj.Transformer.from_crs(g.crs, g.crs.geodetic_crs, always_xy=True)
    lon, lat = inv.transform(x, y)
    ok = np.isfinite(lon) & np.isfinite(lat)
    assert np.array_equal(ok, valid)
    assert np.array_equal(p[ok], lonlat_to_xyz(lon[ok], lat[ok]))
    for lev in range(last):
        b = g.block(lev)
        c = g.centers(lev, jj // b, ii // b)
        r = g.rho_at(lev, jj // b, ii // b)
        assert np.all(angle(c, p)[valid] <= r[valid]), lev
        assert np.all(g.rho(lev) >= g.rho_at(lev, np.arange(g.level_shape(lev)[0]), 0))


def test_antarctica_on_3031_pole_pixel_included(world110):
    """Every pixel of Antarctica (110m, the pole inside) and of rings round the pole, on
    EPSG:3031 at -50 km, 0 and 50 km is the reference's; an odd size puts a pixel
    centre on the pole."""
    g = Projected(127, 127, crs="EPSG:3031", bounds=(-3.4e6, -3.4e6, 3.4e6, 3.4e6))
    lon, lat = g.pixel_lonlat(63, 63)
    assert lat == -90.0
    for geom in (world110["Antarctica"], pole_rings()):
        shape = gloffset.read(geom)
        for d in (-50e3, 0.0, 50e3):
            mask = gloffset.render(shape, d, g)
            want = assert_reference(shape, d, g, mask)
            assert want[63, 63] == (mask[63, 63] == 255) == (d > -1e6)
            assert 0.05 < want.mean() < 0.8


@pytest.mark.parametrize(
    "crs, bounds, names",
    [
        ("EPSG:3413", (-3.0e6, -3.5e6, 2.5e6, 1.5e6), ("Greenland", "Iceland", "Norway")),
        ("EPSG:32633", (2.0e5, 4.0e6, 9.0e5, 5.3e6), ("Italy", "Croatia", "Slovenia")),
        ("EPSG:3035", (2.5e6, 1.4e6, 6.5e6, 5.5e6), ("France", "Germany", "Spain")),
    ],
)
def test_national_and_polar_grids(world110, crs, bounds, names):
    """EPSG:3413, a UTM zone and LAEA Europe: the GPU masks are the reference's."""
    g = Projected(200, 180, crs=crs, bounds=bounds)
    shape = gloffset.read({"type": "FeatureCollection", "features": [world110[n] for n in names]})
    for d in (-30e3, 60e3):
        assert_reference(shape, d, g, gloffset.render(shape, d, g))


def test_texture_fallback_outside_the_domain(world110):
    """An orthographic CRS (no formula): half the pixels have no lon/lat and are
    outside, the others are the reference's; the CPU backend gives the same mask."""
    g = Projected(170, 150, crs=ORTHO, bounds=(-8e6, -7e6, 8e6, 8e6))
    valid = g.valid(g.n_levels - 1)
    assert valid is not None and 0.2 < valid.mean() < 0.9
    shape = gloffset.read(world110["Antarctica"])
    for d in (-50e3, 100e3):
        mask = gloffset.render(shape, d, g)
        assert_reference(shape, d, g, mask)
        assert not mask[~valid].any()
        assert np.array_equal(mask, gloffset.render(shape, d, g, backend="cpu"))


@pytest.mark.parametrize("crs", ["EPSG:3031", ORTHO])
def test_threshold_of_a_projected_field_is_the_render(world110, crs):
    g = Projected(140, 120, crs=crs, bounds=(-3.2e6, -2.8e6, 3.2e6, 3.2e6))
    shape = gloffset.read(world110["Antarctica"])
    field = gloffset.distance_field(shape, g)
    for d in (-50e3, 0.0, 50e3):
        assert np.array_equal(field.threshold(d), gloffset.render(shape, d, g))
    if crs == ORTHO:
        valid = g.valid(g.n_levels - 1)
        assert valid is None or np.all(np.isinf(field.values[~valid]))


def test_parts_and_subgrids_keep_the_pixel_centres(world110):
    g = Projected(150, 130, crs="EPSG:3031", bounds=(-3.3e6, -3.1e6, 3.5e6, 3.0e6))
    sub = g.subgrid(40, 30, 70, 60)
    jj, ii = np.meshgrid(np.arange(60), np.arange(70), indexing="ij")
    assert np.array_equal(
        sub.centers(sub.n_levels - 1, jj, ii), g.centers(g.n_levels - 1, jj + 30, ii + 40)
    )
    shape = gloffset.read(world110["Antarctica"])
    whole = gloffset.render(shape, 40e3, g)
    assert np.array_equal(gloffset.render(shape, 40e3, g, tile=64), whole)
    back = pickle.loads(pickle.dumps(g))
    assert back == g and np.array_equal(gloffset.render(shape, 40e3, back), whole)


def test_default_bounds_are_the_area_of_use():
    g = Projected(64, 64, crs="EPSG:3031")
    xmin, ymin, xmax, ymax = g.bounds
    assert xmin < -3e6 and xmax > 3e6 and ymin < -3e6 and ymax > 3e6
    lon, lat = g.pixel_lonlat(np.arange(64), np.full(64, 32))
    assert np.all(lat < -59.0)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"crs": "EPSG:99999999", "bounds": (0, 0, 1, 1)}, "unknown CRS"),
        ({"crs": "EPSG:4326", "bounds": (0, 0, 1, 1)}, "not a projected CRS"),
        ({"crs": "EPSG:3031", "bounds": (0, 0, 0, 1)}, "xmin < xmax"),
        ({"crs": "EPSG:3031", "bounds": (0, 0, float("nan"), 1)}, "finite"),
        ({"crs": ORTHO, "bounds": (2e7, 2e7, 3e7, 3e7)}, "outside the domain"),
    ],
)
def test_bad_grids(kwargs, words):
    with pytest.raises(InvalidGridError, match=words):
        Projected(16, 16, **kwargs)


@pytest.fixture(scope="module")
def antarctica_file(tmp_path_factory, world110):
    path = tmp_path_factory.mktemp("in") / "antarctica.geojson"
    path.write_text(json.dumps(world110["Antarctica"]))
    return path


def cli(*args):
    import subprocess
    import sys

    return subprocess.run(
        [sys.executable, "-m", "gloffset", *map(str, args)], capture_output=True, check=False
    )


def test_cli_geotiff_in_the_crs(tmp_path, antarctica_file):
    """``render --crs EPSG:3031 --bounds ... -o out.tif`` (and a COG): rasterio reads its
    CRS and transform back, and its pixels are the library's render; a PNG gets a world
    file and the CRS's .prj; ``field --crs`` writes the library's field, whose threshold
    is that render."""
    rasterio = pytest.importorskip("rasterio")
    bounds = (-3.2e6, -3.0e6, 3.4e6, 3.1e6)
    common = ["--crs", "EPSG:3031", "--bounds", ",".join(map(str, bounds)), "--size", "120x100"]
    tif, png, cog, fld = (tmp_path / n for n in ("a.tif", "a.png", "a.cog.tif", "f.tif"))
    for out in (tif, png, cog):
        proc = cli("render", antarctica_file, "-d", "50km", *common, "-o", out)
        assert proc.returncode == 0, proc.stderr.decode()
    proc = cli("field", antarctica_file, *common, "-o", fld)
    assert proc.returncode == 0, proc.stderr.decode()
    g = Projected(120, 100, crs="EPSG:3031", bounds=bounds)
    want = gloffset.render(gloffset.read(antarctica_file), 50e3, g)
    for path in (tif, cog):
        with rasterio.open(path) as src:
            assert src.crs.to_epsg() == 3031
            assert tuple(src.transform)[:6] == pytest.approx(g.transform())
            assert np.array_equal(src.read(1), want)
    from gloffset.io.png import read_mask

    assert np.array_equal(read_mask(png), want == 255)
    pgw = [float(v) for v in (tmp_path / "a.pgw").read_text().split()]
    assert pgw[4] == pytest.approx(bounds[0] + 0.5 * (bounds[2] - bounds[0]) / 120)
    prj = (tmp_path / "a.prj").read_text()
    assert "Stereographic" in prj and pyproj.CRS(prj).to_epsg() in (3031, None)
    with rasterio.open(fld) as src:
        assert src.crs.to_epsg() == 3031
        values = src.read(1)
    field = gloffset.distance_field(gloffset.read(antarctica_file), g)
    assert np.array_equal(values, field.values)
    assert np.array_equal(field.threshold(50e3), want)


@pytest.mark.parametrize(
    "args, words",
    [
        (["--crs", "EPSG:99999999"], ["unknown CRS"]),
        (["--crs", "EPSG:3031", "--bounds", "1e12,1e12,2e12,2e12"], ["outside the domain"]),
        (["--crs", ORTHO, "--bounds", "2e7,2e7,3e7,3e7"], ["outside the domain"]),
        (["--crs", "EPSG:3031", "--bounds", "1,2,3"], ["XMIN,YMIN,XMAX,YMAX"]),
        (["--crs", "EPSG:4326"], ["not a projected CRS"]),
        (["--crs", "EPSG:3031", "--grid", "cube"], ["--crs"]),
    ],
)
def test_cli_bad_crs_or_bounds(tmp_path, antarctica_file, args, words):
    from conftest import assert_one_line_error

    out = tmp_path / "x.tif"
    proc = cli("render", antarctica_file, "-d", "50km", *args, "-o", out)
    assert_one_line_error(proc, *words)
    assert not out.exists()


def test_polar_twin_is_pyprojs_inverse():
    """The float64 twin that the coarse levels and the GPU's textures use is pyproj's
    inverse to within 1e-12 rad (both hemispheres, variants A and B, false origins)."""
    from gloffset.grids.projected import polar_inverse

    rng = np.random.default_rng(1)
    for code in ("EPSG:3031", "EPSG:3413", "EPSG:5041", "EPSG:3976", "EPSG:32761"):
        crs = pyproj.CRS(code)
        x, y = rng.uniform(-9e6, 9e6, (2, 20000))
        lon, lat = pyproj.Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True).transform(
            x, y
        )
        assert np.max(angle(polar_inverse(crs)(x, y), lonlat_to_xyz(lon, lat))) < 1e-12, code
    assert polar_inverse(pyproj.CRS("EPSG:3035")) is None
