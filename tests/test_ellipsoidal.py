"""distance() and contains() on the ellipsoid against the brute-force judge of
gloffset.reference (pyproj geodesics), on Natural Earth: Mexico 10m, neighbours of
countries_10m, and world_110m's antimeridian (Fiji, Russia) and pole (Antarctica)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import gloffset
from gloffset import ellipsoidal, reference

pyproj = pytest.importorskip("pyproj")
from conftest import DATA  # noqa: E402

GEOD = pyproj.Geod(ellps="WGS84")


def _feature_shape(path, names):
    fc = json.loads(path.read_text())
    feats = [f for f in fc["features"] if f["properties"].get("name") in names]
    assert len(feats) == len(names), names
    return gloffset.read({"type": "FeatureCollection", "features": feats})


@pytest.fixture(scope="module")
def mexico():
    return gloffset.read(DATA / "mexico_10m.geojson")


@pytest.fixture(scope="module")
def world_parts():
    return {
        "fiji": _feature_shape(DATA / "world_110m.geojson", ["Fiji"]),
        "russia": _feature_shape(DATA / "world_110m.geojson", ["Russia"]),
        "antarctica": _feature_shape(DATA / "world_110m.geojson", ["Antarctica"]),
    }


def _near_offset(shape, d, n, seed):
    """Points around the offset at |d| (and some on and near the boundary): vertices
    moved |d| (1 +- 2 %) in random directions, and a few metres off vertices."""
    rng = np.random.default_rng(seed)
    e = shape.edges()
    v = e.a[e.boundary]
    k = rng.integers(0, len(v), n)
    lon, lat = gloffset.geometry.sphere.xyz_to_lonlat(v[k])
    dist = abs(d) * rng.uniform(0.98, 1.02, n)
    dist[: n // 5] = rng.uniform(0.0, 30.0, n // 5)  # near the boundary itself
    plon, plat, _ = GEOD.fwd(lon, lat, rng.uniform(0, 360, n), dist)
    return plon, plat


def _check(shape, lon, lat, d):
    truth_d = reference.distance(shape, lon, lat, ellipsoid="WGS84")
    ours_d = ellipsoidal.distance(shape, lon, lat, ellipsoid="WGS84")
    np.testing.assert_allclose(ours_d, truth_d, atol=1e-3, rtol=0)
    ours = gloffset.contains(shape, lon, lat, distance=d, ellipsoid="WGS84")
    truth = reference.contains_lonlat(shape, lon, lat, distance=d, ellipsoid="WGS84")
    clear = np.abs(truth_d - abs(d)) > 1e-3
    if d == 0.0:
        clear &= truth_d > 1e-3
    bad = np.flatnonzero((ours != truth) & clear)
    assert not len(bad), (d, lon[bad][:5], lat[bad][:5], truth_d[bad][:5])
    return ours


def test_ellipsoid_none_is_the_sphere(mexico):
    lon, lat = np.array([-100.0, -90.0, -118.0]), np.array([20.0, 30.0, 32.5])
    np.testing.assert_array_equal(
        gloffset.distance(mexico, lon, lat), reference.distance(mexico, lon, lat)
    )
    for d in (0.0, 50e3, -20e3):
        np.testing.assert_array_equal(
            gloffset.contains(mexico, lon, lat, distance=d),
            gloffset.index.contains.contains_on_sphere(mexico, lon, lat, distance=d),
        )


def test_the_ellipsoid_differs_from_the_sphere():
    line = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [10, 0]]})
    d_e = gloffset.distance(line, 5.0, 1.0, ellipsoid="WGS84")
    assert d_e == pytest.approx(GEOD.inv(5.0, 1.0, 5.0, 0.0)[2], abs=1e-6)
    assert abs(d_e - gloffset.distance(line, 5.0, 1.0)) > 300.0
    with pytest.raises(gloffset.InvalidEllipsoidError):
        gloffset.contains(line, 0.0, 0.0, distance=1.0, ellipsoid="Mars")


@pytest.mark.parametrize("d", [10.0, 1000.0, 100e3, 1000e3, 0.0, -30.0, -20e3])
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_mexico(mexico, d):
    lon, lat = _near_offset(mexico, d if d else 50.0, 40, seed=int(abs(d)) % 1000)
    _check(mexico, lon, lat, d)


def test_mexico_random_points(mexico):
    rng = np.random.default_rng(7)
    lon, lat = rng.uniform(-120, -84, 60), rng.uniform(12, 34, 60)
    for d in (5e3, -5e3):
        _check(mexico, lon, lat, d)


def test_index_on_the_ellipsoid(mexico):
    """gloffset.Index(..., ellipsoid=) answers as contains() on the ellipsoid, against the
    brute force, and refuses what contains refuses."""
    lon, lat = _near_offset(mexico, 30e3, 40, seed=11)
    ix = gloffset.Index(mexico, 30e3, ellipsoid="WGS84")
    assert isinstance(ix, ellipsoidal.EllipsoidIndex)
    got = ix.contains(lon, lat)
    assert np.array_equal(got, _check(mexico, lon, lat, 30e3))
    assert ix.contains(lon.reshape(5, 8), lat.reshape(5, 8)).shape == (5, 8)
    with pytest.raises(gloffset.InvalidGeometryError):
        ix.contains([0.0], [91.0])
    with pytest.raises(gloffset.errors.InvalidEllipsoidError):
        gloffset.Index(mexico, 30e3, ellipsoid="Mars")
    line = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [1, 0]]})
    with pytest.raises(gloffset.InvalidDistanceError):
        gloffset.Index(line, -10.0, ellipsoid="WGS84")
    assert isinstance(gloffset.Index(mexico, 30e3), gloffset.Index)  # the sphere as before


def test_neighbours_of_countries_10m():
    shape = _feature_shape(DATA / "countries_10m.geojson", ["Guatemala", "Belize"])
    for d in (10.0, 200.0, -500.0):
        lon, lat = _near_offset(shape, d, 30, seed=3)
        _check(shape, lon, lat, d)


@pytest.mark.parametrize("name", ["fiji", "russia", "antarctica"])
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_antimeridian_and_pole(world_parts, name):
    shape = world_parts[name]
    for d in (20e3, -10e3, 500e3):
        lon, lat = _near_offset(shape, d, 20, seed=len(name))
        _check(shape, lon, lat, d)
    if name == "antarctica":
        lon, lat = np.array([0.0, 120.0, -60.0]), np.array([-90.0, -89.9, -85.0])
        assert gloffset.contains(shape, lon, lat, distance=-100e3, ellipsoid="WGS84").all()


def test_lines_and_points_have_no_inside():
    shape = gloffset.read(
        {
            "type": "GeometryCollection",
            "geometries": [
                {"type": "LineString", "coordinates": [[170, 60], [-170, 62], [-150, 61]]},
                {"type": "Point", "coordinates": [10, 89.5]},
            ],
        }
    )
    lon, lat = _near_offset(shape, 30e3, 30, seed=11)
    _check(shape, lon, lat, 30e3)
    with pytest.raises(gloffset.InvalidDistanceError):
        gloffset.contains(shape, 0.0, 0.0, distance=-1.0, ellipsoid="WGS84")


def test_long_geodesic_edges_decide_the_inside():
    """A polygon with 20-degree edges: the geodesics bulge poleward of the great circles
    on the conformal sphere by up to kilometres; points between them follow the geodesic."""
    ring = [[-40, 50], [-20, 50], [0, 50], [0, 60], [-40, 60], [-40, 50]]
    shape = gloffset.read({"type": "Polygon", "coordinates": [ring]})
    rng = np.random.default_rng(12)
    # points just north and south of the geodesic from (-40, 50) to (-20, 50)
    az, _, length = GEOD.inv(-40.0, 50.0, -20.0, 50.0)
    mlon, mlat, back = GEOD.fwd(
        np.full(40, -40.0), np.full(40, 50.0), np.full(40, az), length * rng.uniform(0.05, 0.95, 40)
    )
    plon, plat, _ = GEOD.fwd(
        mlon, mlat, back + 90 * rng.choice([-1, 1], 40), rng.uniform(0.01, 3.0, 40)
    )
    for d in (0.0, 1.0, -1.0):
        _check(shape, plon, plat, d)


def test_cli_contains_on_the_ellipsoid(tmp_path, mexico):
    from click.testing import CliRunner

    from gloffset.cli import main

    lon, lat = _near_offset(mexico, 20e3, 30, seed=21)
    pts = tmp_path / "pts.csv"
    pts.write_text(
        "lon,lat\n" + "".join(f"{a!r},{b!r}\n" for a, b in zip(lon.tolist(), lat.tolist()))
    )
    square = str(DATA / "mexico_10m.geojson")
    r = CliRunner().invoke(
        main, ["contains", square, str(pts), "-d", "20km", "--ellipsoid", "WGS84"]
    )
    assert r.exit_code == 0, r.output
    got = [line.split(",")[2] == "true" for line in r.output.strip().splitlines()[1:]]
    want = gloffset.contains(mexico, lon, lat, distance=20e3, ellipsoid="WGS84")
    assert got == want.tolist()
    for args, msg in (
        (["-d", "1deg", "--ellipsoid", "WGS84"], "geodesic lengths"),
        (["-d", "1km", "--ellipsoid", "Mars"], "unknown ellipsoid"),
        (["-d", "1km", "--ellipsoid", "6378137,x"], "expected a name"),
        (["-d", "1km", "--ellipsoid", "6378137,0.5"], "flattening"),
    ):
        r = CliRunner().invoke(main, ["contains", square, str(pts), *args])
        assert r.exit_code == 2 and msg in r.output, r.output


# ------------------------------------------------------------------------- render
def _check_render(shape, grid, d, pixel_m):
    mask = gloffset.render(shape, d, grid, ellipsoid="WGS84")
    h, w = grid.level_shape(grid.n_levels - 1)
    j, i = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    lon, lat = gloffset.geometry.sphere.xyz_to_lonlat(
        grid.centers(grid.n_levels - 1, j.ravel(), i.ravel())
    )
    truth = reference.contains_lonlat(shape, lon, lat, distance=d, ellipsoid="WGS84")
    got = mask.ravel() == 255
    wrong = np.flatnonzero(got != truth)
    if len(wrong):
        dist = reference.distance(shape, lon[wrong], lat[wrong], ellipsoid="WGS84")
        assert np.all(np.abs(dist - abs(d)) <= 1e-3 * pixel_m), (d, dist)
    return mask


@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_render_equirect_on_the_ellipsoid(mexico):
    from gloffset.grids import Equirect

    grid = Equirect(30, 18, (-120.0, 12.0, -84.0, 34.0))
    mask = _check_render(mexico, grid, 40e3, 130e3)
    assert mask.shape == gloffset.render(mexico, 40e3, grid, backend="cpu").shape
    with pytest.raises(gloffset.OptionError):
        gloffset.render(mexico, 40e3, grid, ellipsoid="WGS84", out="classes")


def test_render_z16_tile_on_the_ellipsoid(mexico):
    import mercantile

    from gloffset.grids import Tile

    e = mexico.edges()
    lon, lat = gloffset.geometry.sphere.xyz_to_lonlat(e.a[e.boundary][1000])
    t = mercantile.tile(float(lon), float(lat), 16)
    for d in (-50.0, 10.0):
        mask = _check_render(mexico, Tile(16, t.x, t.y, 16), d, 38.0)
        assert 0 < np.count_nonzero(mask) < mask.size


@pytest.mark.parametrize(
    "name", [pytest.param("mexico", marks=pytest.mark.slow), "antarctica", "russia", "fiji"]
)
def test_gpu_screen_equals_the_cpu_path(mexico, world_parts, name):
    """The GPU path of render(..., ellipsoid=) (two spherical renders on the conformal
    rows, the band between them decided exactly) gives the same pixels as the CPU path
    (every centre through the ellipsoidal contains): at the pole, across the
    antimeridian, at small, large and negative distances, in parts of an image too."""
    from gloffset.grids import Equirect, Tile

    shape = mexico if name == "mexico" else world_parts[name]
    grids = [Equirect(100, 50), Equirect(40, 30, (170.0, -90.0, -170.0, -60.0)), Tile(2, 0, 1)]
    for d in (10e3, 127e3, 1000e3, -50e3):
        for grid in grids:
            gpu = gloffset.render(shape, d, grid, ellipsoid="WGS84")
            cpu = gloffset.render(shape, d, grid, ellipsoid="WGS84", backend="cpu")
            assert np.array_equal(gpu, cpu), (name, d, grid, int((gpu != cpu).sum()))
    if name == "mexico":  # the polygons themselves and metres from them
        grid = Equirect(200, 100, (-120.0, 10.0, -80.0, 35.0))
        for d in (0.0, 10.0, -10.0):
            gpu = gloffset.render(shape, d, grid, ellipsoid="WGS84")
            cpu = gloffset.render(shape, d, grid, ellipsoid="WGS84", backend="cpu")
            assert np.array_equal(gpu, cpu), d
    if name == "mexico":  # a padded level (the mask a view of a larger array)
        grid = Equirect(720, 360)
        gpu = gloffset.render(shape, 1000e3, grid, ellipsoid="WGS84")
        cpu = gloffset.render(shape, 1000e3, grid, ellipsoid="WGS84", backend="cpu")
        assert np.array_equal(gpu, cpu)
    grid = Equirect(96, 48)
    parts = gloffset.render(shape, 127e3, grid, ellipsoid="WGS84", tile=32)
    assert np.array_equal(parts, gloffset.render(shape, 127e3, grid, ellipsoid="WGS84"))


def test_conformal_rows_bound_their_cells():
    """ConformalRows: rows at the conformal latitudes of the grid's, and bounds rho that
    hold every child centre (the level hierarchy's rule)."""
    from gloffset.ellipsoid import as_ellipsoid
    from gloffset.geometry.sphere import angle
    from gloffset.grids import Equirect
    from gloffset.grids.conformal import ConformalRows

    ell = as_ellipsoid("WGS84")
    base = Equirect(256, 128)
    grid = ConformalRows(base, ell)
    last = grid.n_levels - 1
    rows = np.arange(128)
    np.testing.assert_allclose(
        np.degrees(grid.cell_lat(last, rows)),
        ell.conformal(np.degrees(base.cell_lat(last, rows))),
        atol=1e-12,
    )
    for lev in range(last):
        h, w = grid.level_shape(lev)
        j = np.arange(h)
        c = grid.centers(lev, j, 0)
        for dj in (0, 1):
            for di in (0, 1):
                cc = grid.centers(
                    lev + 1, np.minimum(2 * j + dj, grid.level_shape(lev + 1)[0] - 1), di
                )
                assert np.all(angle(c, cc) <= grid.rho(lev))
    with pytest.raises(TypeError):
        from gloffset.grids import CubeFace

        ConformalRows(CubeFace(0, 16), ell)


@pytest.mark.slow
def test_render_cube_face_on_the_ellipsoid(mexico):
    from gloffset.grids import CubeFace

    _check_render(mexico, CubeFace(3, 24), 300e3, 400e3)


@pytest.mark.slow
@pytest.mark.parametrize("d", [10.0, 300.0, 5e3, 50e3, 500e3, 1000e3, 0.0, -10.0, -1e3, -100e3])
def test_mexico_many_points(mexico, d):
    lon, lat = _near_offset(mexico, d if d else 20.0, 1500, seed=int(abs(d)) % 977 + 1)
    _check(mexico, lon, lat, d)


@pytest.mark.slow
def test_world_110m_many_points(world_parts):
    shape = gloffset.read(DATA / "world_110m.geojson")
    for d in (1e3, 100e3, -50e3):
        lon, lat = _near_offset(shape, d, 1500, seed=41)
        _check(shape, lon, lat, d)


def test_a_round_ellipsoid_is_the_sphere(mexico):
    """With f = 0 geodesics are great circles: the same distances and answers as the
    sphere of radius a."""
    r = gloffset.EARTH_RADIUS
    lon, lat = _near_offset(mexico, 30e3, 40, seed=17)
    np.testing.assert_allclose(
        gloffset.distance(mexico, lon, lat, ellipsoid=(r, 0.0)),
        gloffset.distance(mexico, lon, lat, radius=r),
        rtol=0,
        atol=1e-6,
    )
    for d in (30e3, -30e3):
        sphere = gloffset.contains(mexico, lon, lat, distance=d, radius=r)
        assert np.array_equal(
            sphere, gloffset.contains(mexico, lon, lat, distance=d, ellipsoid=(r, 0.0))
        )
    grs = gloffset.distance(mexico, lon[:5], lat[:5], ellipsoid="GRS80")
    wgs = gloffset.distance(mexico, lon[:5], lat[:5], ellipsoid="WGS84")
    np.testing.assert_allclose(grs, wgs, rtol=1e-8, atol=1e-6)


def test_overlapping_polygons_with_long_edges():
    a = [[-40, 50], [0, 50], [0, 60], [-40, 60], [-40, 50]]
    b = [[-30, 45], [-10, 45], [-10, 55], [-30, 55], [-30, 45]]
    shape = gloffset.read(
        {"type": "MultiPolygon", "coordinates": [[a], [b]]},
    )
    rng = np.random.default_rng(13)
    az, _, length = GEOD.inv(-40.0, 50.0, 0.0, 50.0)
    n = 40
    mlon, mlat, back = GEOD.fwd(
        np.full(n, -40.0), np.full(n, 50.0), np.full(n, az), length * rng.uniform(0.05, 0.95, n)
    )
    plon, plat, _ = GEOD.fwd(mlon, mlat, back + 90 * rng.choice([-1, 1], n), rng.uniform(1, 3e3, n))
    for d in (0.0, 10.0, -10.0):
        _check(shape, plon, plat, d)


def test_conformal_tile_pyramid_bounds():
    """TilePyramid(maxzoom, ell) (the pyramid on the conformal sphere) takes its list
    bounds from the sphere's equator tiles: every conformal tile of zooms 0-12 is within
    them, and its centres are the conformal images of the tiles' centres."""
    from gloffset.ellipsoid import as_ellipsoid
    from gloffset.geometry.sphere import xyz_to_lonlat
    from gloffset.grids.mercator import TilePyramid

    ell = as_ellipsoid("WGS84")
    sphere, conf = TilePyramid(12), TilePyramid(12, ell)
    for z in range(13):
        rows = np.arange(1 << z, dtype=np.float64)
        eq = sphere.decision_rho(z, max(0, (1 << z) // 2 - 1))
        assert conf._row_rho(z, rows).max() <= eq
    assert conf._extra == sphere._extra
    j = np.arange(16)
    _, lat_s = xyz_to_lonlat(sphere.centers(4, j, 3))
    _, lat_c = xyz_to_lonlat(conf.centers(4, j, 3))
    np.testing.assert_allclose(lat_c, ell.conformal(lat_s), atol=1e-12)


def test_raster_offset_on_the_ellipsoid():
    """raster_offset(..., ellipsoid=) on a curve whose cells are known exactly (two
    meridian segments, geodesics through the centres of two columns): contained cell
    centres within d of the curve on the ellipsoid, outside cells farther (the brute
    force, geodesic distances), the GPU classes equal to the CPU's."""
    from gloffset.grids import Equirect

    grid = Equirect(80, 60, (-120.0, 5.0, -80.0, 35.0))  # 0.5 degree cells
    curve = gloffset.read(
        {
            "type": "MultiLineString",
            "coordinates": [
                [[-100.25, 10.25], [-100.25, 29.75]],
                [[-90.25, 20.25], [-90.25, 25.75]],
            ],
        }
    )
    mask = np.zeros(grid.shape, dtype=bool)
    mask[10:50, 39] = True  # rows of 10.25 .. 29.75
    mask[18:30, 59] = True  # rows of 20.25 .. 25.75
    for d in (150e3, 600e3):
        cls = gloffset.raster_offset(mask, d, grid, ellipsoid="WGS84", backend="cpu")
        assert np.array_equal(cls, gloffset.raster_offset(mask, d, grid, ellipsoid="WGS84"))
        rng = np.random.default_rng(int(d))
        for c in (2, 0):  # 150 cells of each class, against the brute force
            flat = np.flatnonzero(cls == c)
            assert len(flat) > 50
            j, i = np.divmod(rng.choice(flat, 150, replace=False), grid.width)
            lon, lat = grid.pixel_lonlat(i, j)
            dist = reference.distance(curve, lon, lat, ellipsoid="WGS84")
            assert np.all(dist <= d) if c == 2 else np.all(dist > d)
    with pytest.raises(gloffset.OptionError):
        gloffset.raster_offset(mask, 1e5, grid, ellipsoid="WGS84", return_info=True)
    with pytest.raises(gloffset.InvalidDistanceError):
        gloffset.raster_offset(mask, "0.1rad", grid, ellipsoid="WGS84")
