"""One rule for distances at every public function: a number in the units of ``radius`` or
a string with a unit, converted once where it comes in. ``"127km"`` gives what ``127e3``
gives, on the sphere and on the ellipsoid, and an angle is refused where a length is due."""

import numpy as np
import pytest

import gloffset
from gloffset import InvalidDistanceError
from gloffset.grids import Cube, Equirect
from gloffset.raster.globe import globe
from gloffset.raster.render import render_angle
from gloffset.units import EARTH_RADIUS, offset_angle, to_angle, to_metres

#: around Iceland: a small grid over a real coastline
GRID = Equirect(96, 48, bounds=(-30.0, 60.0, -6.0, 70.0))
LON, LAT = np.meshgrid(np.linspace(-28.0, -8.0, 41), np.linspace(61.0, 69.0, 17))


@pytest.fixture(scope="module")
def iceland(world):
    return gloffset.read(world["Iceland"])


def test_to_angle_reads_strings_and_numbers_alike():
    assert to_angle("127km", EARTH_RADIUS) == to_angle(127e3, EARTH_RADIUS) == 127e3 / EARTH_RADIUS
    assert to_angle("0.02rad", 2.0) == 0.02 and to_angle(np.float32(1.0), 4.0) == 0.25
    assert to_metres("127km") == to_metres(127e3) == 127e3
    for bad in ("12 parsecs", "km", None, float("nan"), True, np.False_):
        with pytest.raises(InvalidDistanceError):
            to_angle(bad, EARTH_RADIUS)
    with pytest.raises(InvalidDistanceError, match="got True"):  # float(True) is 1.0
        to_metres(True)


def test_a_bool_is_no_distance(iceland):
    """True was 1 metre (or 1 radian on the unit sphere), silently."""
    with pytest.raises(InvalidDistanceError, match="got True"):
        gloffset.render(iceland, True, GRID, backend="cpu")
    with pytest.raises(InvalidDistanceError, match="got True"):
        gloffset.contains(iceland, LON, LAT, distance=True)


@pytest.mark.parametrize("angle", ["0.02rad", " 1.5DEG "])
def test_an_angle_is_no_geodesic_length(iceland, angle):
    """On an ellipsoid a distance is a geodesic length: every public function refuses an
    angle, naming it."""
    calls = [
        lambda: to_metres(angle),
        lambda: gloffset.render(iceland, angle, GRID, backend="cpu", ellipsoid="WGS84"),
        lambda: gloffset.offset(iceland, angle, ellipsoid="WGS84"),
        lambda: gloffset.contains(iceland, LON, LAT, distance=angle, ellipsoid="WGS84"),
        lambda: gloffset.Index(iceland, angle, ellipsoid="WGS84"),
        lambda: gloffset.raster_offset(
            gloffset.rasterize(iceland, GRID), angle, GRID, ellipsoid="WGS84", backend="cpu"
        ),
    ]
    for call in calls:
        with pytest.raises(InvalidDistanceError, match="is an angle"):
            call()


def test_render_takes_strings(iceland):
    for kw in ({}, {"ellipsoid": "WGS84"}):
        want = gloffset.render(iceland, 127e3, GRID, backend="cpu", **kw)
        assert 0 < np.count_nonzero(want) < want.size
        assert np.array_equal(gloffset.render(iceland, "127km", GRID, backend="cpu", **kw), want)
    with pytest.raises(InvalidDistanceError, match="12 parsecs"):
        gloffset.render(iceland, "12 parsecs", GRID)


def test_render_angle_is_render_at_the_angle(iceland):
    """The package's own entry, for distances that are angles already."""
    d = offset_angle(iceland, "127km", EARTH_RADIUS)
    for grid in (GRID, Cube(16)):
        want = gloffset.render(iceland, "127km", grid, backend="cpu")
        assert np.array_equal(render_angle(iceland, d, grid, backend="cpu"), want)
    classes = gloffset.render(iceland, 127e3, GRID, out="classes", level=1, backend="cpu")
    got = render_angle(iceland, d, GRID, out="classes", level=1, backend="cpu")
    assert np.array_equal(got, classes)


def test_offset_takes_strings(iceland):
    sphere = gloffset.offset(iceland, "127km").to_geojson()
    assert sphere["geometry"] == gloffset.offset(iceland, 127e3).to_geojson()["geometry"]
    assert sphere["properties"] == {"distance_m": 127000.0, "distance": "127km"}
    geodesic = gloffset.offset(iceland, "127km", ellipsoid="WGS84")
    want = gloffset.offset(iceland, 127e3, ellipsoid="WGS84")
    assert geodesic.distance == want.distance == 127e3
    assert geodesic.to_geojson()["geometry"] == want.to_geojson()["geometry"]
    props = geodesic.to_geojson()["properties"]
    assert (props["distance_m"], props["distance"]) == (127e3, "127km")


def test_contains_and_index_take_strings(iceland):
    for kw in ({}, {"ellipsoid": "WGS84"}):
        want = gloffset.contains(iceland, LON, LAT, distance=127e3, **kw)
        assert 0 < np.count_nonzero(want) < want.size
        got = gloffset.contains(iceland, LON, LAT, distance="127km", **kw)
        assert np.array_equal(got, want)
        index = gloffset.Index(iceland, "127km", **kw)
        assert np.array_equal(index.contains(LON, LAT), want)


def test_raster_offset_takes_strings(iceland):
    mask = gloffset.rasterize(iceland, GRID)
    for kw in ({}, {"ellipsoid": "WGS84"}):
        want = gloffset.raster_offset(mask, 127e3, GRID, backend="cpu", **kw)
        assert (want == 2).any() and (want == 0).any()
        got = gloffset.raster_offset(mask, "127km", GRID, backend="cpu", **kw)
        assert np.array_equal(got, want)


def test_tiles_and_preview_take_strings(iceland, tmp_path):
    for name, distance in (("a", "127km"), ("b", 127e3)):
        gloffset.tiles.pyramid(iceland, distance, "2-3", tmp_path / name, size=16)
    tiles = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*.png"))
    assert tiles == sorted(p.relative_to(tmp_path / "b") for p in (tmp_path / "b").rglob("*.png"))
    for t in tiles:
        assert (tmp_path / "a" / t).read_bytes() == (tmp_path / "b" / t).read_bytes()
    with pytest.raises(InvalidDistanceError, match="is an angle"):
        gloffset.tiles.pyramid(iceland, "0.02rad", "2", tmp_path / "c", ellipsoid="WGS84")
    img = globe(iceland, "127km", size=32, center=(-18.0, 65.0))
    assert np.array_equal(img, globe(iceland, 127e3, size=32, center=(-18.0, 65.0)))


def test_buffer_takes_strings_per_feature(world):
    gpd = pytest.importorskip("geopandas")
    shapely = pytest.importorskip("shapely")
    series = gpd.GeoSeries(
        [shapely.geometry.shape(world[n]["geometry"]) for n in ("Iceland", "Ireland")],
        crs="EPSG:4326",
    )
    want = gloffset.buffer(series, [127e3, 5e3])
    got = gloffset.buffer(series, ["127km", 5000.0])
    assert all(a.equals_exact(b, 0.0) for a, b in zip(got, want))
    assert (
        gloffset.buffer(series, "127km")
        .geom_equals_exact(gloffset.buffer(series, 127e3), 0.0)
        .all()
    )
    with pytest.raises(InvalidDistanceError, match="parsecs"):
        gloffset.buffer(series, ["127km", "5 parsecs"])
