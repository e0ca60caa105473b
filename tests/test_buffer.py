"""gloffset.buffer on GeoPandas data: a GeoDataFrame of lines, points and countries
(Fiji and Russia across the antimeridian, Antarctica round the pole) equals
gloffset.offset per feature; the CRS, the index, the properties and the options."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import gloffset

gpd = pytest.importorskip("geopandas")
shapely = pytest.importorskip("shapely")

DATA = Path(__file__).resolve().parents[1] / "data"
D = 100e3
RES = 16


def tolerance(d: float, res: int = RES) -> float:
    """The chord deviation of a circle drawn with ``res`` segments per quarter (radians)."""
    return np.sin(d / gloffset.EARTH_RADIUS) * (1 - np.cos(np.pi / (4 * res)))


@pytest.fixture(scope="module")
def frame():
    world = json.loads((DATA / "world_110m.geojson").read_text())["features"]
    countries = [f for f in world if f["properties"]["name"] in ("Fiji", "Russia", "Antarctica")]
    chile = next(f for f in world if f["properties"]["name"] == "Chile")
    border = shapely.geometry.shape(chile["geometry"]).boundary  # a line of many vertices
    rows = [(f["properties"]["name"], shapely.geometry.shape(f["geometry"])) for f in countries]
    rows += [
        ("chile border", border),
        ("river", shapely.LineString([(10, 50), (10.5, 50.3), (11, 50.1), (11.2, 50.6)])),
        ("segment across 180", shapely.LineString([(179.5, -16), (-179.5, -17)])),
        ("segment", shapely.LineString([(2.35, 48.85), (4.83, 45.76)])),
        ("point", shapely.Point(-99.13, 19.43)),
        ("point at 180", shapely.Point(180, 10)),
        ("point near the pole", shapely.Point(45, -89.5)),
        ("empty", None),
    ]
    names, geoms = zip(*rows)
    return gpd.GeoDataFrame(
        {"name": names, "k": range(len(names))}, geometry=list(geoms), crs="EPSG:4326"
    ).set_index(np.arange(100, 100 + len(names)))


@pytest.fixture(scope="module")
def buffered(frame):
    return gloffset.buffer(frame, D, resolution=RES)


def by_offset(geom, d=D):
    off = gloffset.offset(gloffset.read(shapely.geometry.mapping(geom)), d)
    return shapely.geometry.shape(off.to_geojson(tolerance=tolerance(d))["geometry"])


def test_frame_in_frame_out(frame, buffered):
    assert isinstance(buffered, gpd.GeoDataFrame)
    assert buffered.crs.equals("EPSG:4326")
    assert list(buffered.index) == list(frame.index)
    assert list(buffered["name"]) == list(frame["name"]) and list(buffered["k"]) == list(frame["k"])
    assert buffered.geometry.iloc[-1] is None
    assert buffered.geometry.iloc[:-1].is_valid.all()
    series = gloffset.buffer(frame.geometry, D, resolution=RES)
    assert isinstance(series, gpd.GeoSeries) and series.iloc[:-1].equals(
        buffered.geometry.iloc[:-1]
    )


@pytest.mark.parametrize("name", ["Fiji", "Russia", "Antarctica", "chile border", "river"])
def test_general_features_equal_offset(frame, buffered, name):
    k = list(frame["name"]).index(name)
    want = by_offset(frame.geometry.iloc[k])
    assert buffered.geometry.iloc[k].equals_exact(want, 0.0)


@pytest.mark.parametrize(
    "name", ["segment across 180", "segment", "point", "point at 180", "point near the pole"]
)
def test_points_and_segments_equal_offset(frame, buffered, name):
    """Computed all at once: vertices at exactly d, the region of offset's away from
    the boundary, the same area to the chords' deviation."""
    k = list(frame["name"]).index(name)
    geom = frame.geometry.iloc[k]
    got, want = buffered.geometry.iloc[k], by_offset(geom)
    shape = gloffset.read(shapely.geometry.mapping(geom))
    xy = shapely.get_coordinates(got)
    free = (np.abs(np.abs(xy[:, 0]) - 180) > 1e-9) & (np.abs(np.abs(xy[:, 1]) - 90) > 1e-9)
    assert np.abs(gloffset.distance(shape, *xy[free].T) - D).max() < 1e-4
    assert abs(got.area - want.area) <= 2e-3 * want.area
    rng = np.random.default_rng(k)
    lo, hi = np.array(want.bounds[:2]), np.array(want.bounds[2:])
    p = lo + (hi - lo) * rng.random((4000, 2))
    dist = gloffset.distance(shape, p[:, 0], p[:, 1])
    clear = np.abs(dist - D) > 0.01 * D
    assert np.array_equal(shapely.contains_xy(got, *p[clear].T), dist[clear] < D)


def test_many_points_at_once():
    rng = np.random.default_rng(0)
    n = 20_000
    lon, lat = rng.uniform(-180, 180, n), np.degrees(np.arcsin(rng.uniform(-1, 1, n)))
    pts = gpd.GeoSeries(gpd.points_from_xy(lon, lat), crs="OGC:CRS84")
    out = gloffset.buffer(pts, "500m", resolution=4)
    assert len(out) == n and out.is_valid.all()
    for k in rng.choice(n, 50, replace=False):
        xy = shapely.get_coordinates(out.iloc[k])
        free = (np.abs(np.abs(xy[:, 0]) - 180) > 1e-9) & (np.abs(np.abs(xy[:, 1]) - 90) > 1e-9)
        shape = gloffset.read({"type": "Point", "coordinates": [lon[k], lat[k]]})
        assert np.abs(gloffset.distance(shape, *xy[free].T) - 500).max() < 1e-6


def test_crs_distances_and_the_union(frame):
    with pytest.raises(gloffset.InputFormatError, match="projected CRS 'EPSG:3857'"):
        gloffset.buffer(frame.iloc[:-1].to_crs(3857), D)
    nad = frame.iloc[[7, 8]].to_crs("EPSG:4269")  # another geographic CRS: transformed
    assert gloffset.buffer(nad, D).crs.equals("EPSG:4326")
    assert gloffset.buffer(frame.iloc[[7, 8]].set_crs(None, allow_override=True), D).crs
    d = np.array([20e3, 50e3, 100e3, 30e3])  # one per feature: points and segments
    four = gloffset.buffer(frame.iloc[[7, 8, 5, 6]], d)
    for k, (geom, buf) in enumerate(zip(frame.geometry.iloc[[7, 8, 5, 6]], four.geometry)):
        xy = shapely.get_coordinates(buf)
        free = (np.abs(np.abs(xy[:, 0]) - 180) > 1e-9) & (np.abs(np.abs(xy[:, 1]) - 90) > 1e-9)
        shape = gloffset.read(shapely.geometry.mapping(geom))
        assert np.abs(gloffset.distance(shape, *xy[free].T) - d[k]).max() < 1e-4
    assert gloffset.buffer(frame.iloc[[7]], -1e3).geometry.iloc[0].is_empty
    fiji = frame.iloc[[0]]
    assert gloffset.buffer(fiji, -1e3).geometry.iloc[0].area < fiji.geometry.iloc[0].area
    union = gloffset.buffer(frame.iloc[[7, 8]], D, each=False)
    both = gloffset.read({"type": "GeometryCollection", "geometries": [
        shapely.geometry.mapping(g) for g in frame.geometry.iloc[[7, 8]]]})  # fmt: skip
    assert union.iloc[0].equals_exact(by_offset_shape(both), 0.0)
    with pytest.raises(gloffset.InvalidDistanceError, match="one distance"):
        gloffset.buffer(frame.iloc[[7, 8]], [1e3, 2e3], each=False)
    with pytest.raises(gloffset.InputFormatError, match="GeoSeries or GeoDataFrame"):
        gloffset.buffer([shapely.Point(0, 0)], D)


def by_offset_shape(shape):
    off = gloffset.offset(shape, D)
    return shapely.geometry.shape(off.to_geojson(tolerance=tolerance(D))["geometry"])


@pytest.mark.slow
def test_countries_10m_buffered_equal_offset_per_feature():
    """Natural Earth 1:10m: Kiribati across 180 degrees, Greenland near the pole, France's
    border as lines; each buffer equals offset of the feature alone."""
    fc = json.loads((DATA / "countries_10m.geojson").read_text())["features"]
    by_name = {f["properties"]["name"]: f for f in fc}
    rows = [shapely.geometry.shape(by_name[n]["geometry"]) for n in ("Kiribati", "Greenland")]
    rows.append(shapely.geometry.shape(by_name["France"]["geometry"]).boundary)
    frame = gpd.GeoDataFrame({"k": range(3)}, geometry=rows, crs="EPSG:4326")
    got = gloffset.buffer(frame, 50e3, resolution=RES)
    for geom, buf in zip(frame.geometry, got.geometry):
        want = by_offset(geom, 50e3)
        assert buf.equals_exact(want, 0.0) and buf.is_valid


def test_rings_collections_and_bad_rows_as_geopandas_users_expect(frame, recwarn):
    """A frame mixing good and bad rows: a LinearRing is buffered as its line (Chile's
    border, closed), a collection of points and lines shrinks to an empty polygon, rows
    that cannot be buffered give None with one warning naming them, and every other row
    is buffered as it is alone."""
    border = frame.geometry.iloc[3]
    chile = max(getattr(border, "geoms", [border]), key=lambda g: len(g.coords))  # mainland
    ring = shapely.LinearRing(chile.coords)
    mixed = shapely.GeometryCollection([frame.geometry.iloc[7], frame.geometry.iloc[4]])
    rows = {
        "ring": ring,
        "collection": mixed,
        "latitude 100": shapely.Point(10, 100),
        "one point": shapely.LineString([(3, 4), (3, 4), (3, 4)]),
        "river": frame.geometry.iloc[4],
        "point": frame.geometry.iloc[7],
    }
    data = gpd.GeoDataFrame({"name": list(rows)}, geometry=list(rows.values()), crs=4326)
    data.index = list(rows)
    with pytest.warns(UserWarning) as caught:
        out = gloffset.buffer(data, D, resolution=RES)
    (w,) = [w for w in caught if "gloffset.buffer" in str(w.message)]
    msg = str(w.message)
    assert "2 of 6 rows" in msg and "'latitude 100'" in msg and "'one point'" in msg
    assert "latitude 100.0 out of range" in msg and "2 distinct points" in msg
    assert out.loc["latitude 100"].geometry is None and out.loc["one point"].geometry is None
    assert list(out["name"]) == list(rows)
    want = by_offset(shapely.LineString(chile.coords))
    assert out.loc["ring"].geometry.equals_exact(want, 1e-9)
    assert len(out.loc["ring"].geometry.interiors) >= 1  # a band round the line, not a disc
    assert out.loc["collection"].geometry.equals_exact(by_offset(mixed), 1e-9)
    for name in ("river", "point"):
        alone = gloffset.buffer(data.loc[[name]], D, resolution=RES)
        assert out.loc[name].geometry.equals_exact(alone.geometry.iloc[0], 0.0)
    inward = gloffset.buffer(data.loc[["ring", "collection"]], -D)
    assert inward.geometry.is_empty.all() and inward.geometry.geom_type.eq("Polygon").all()


def test_a_distance_too_far_names_its_row(frame):
    dist = np.full(len(frame), D)
    dist[5] = 4e7
    with pytest.raises(gloffset.InvalidDistanceError, match=r"^distance 40000000.0 of row 105 "):
        gloffset.buffer(frame, dist)


def test_progress_counts_the_rows_and_changes_nothing(frame, buffered, capsys):
    """``progress``: a callable hears ``(done, total)`` rising to the rows, points and
    segments at once and each other row alone; True draws a bar on stderr; the buffers
    are those without it; off by default, and anything else is refused."""
    seen = []
    got = gloffset.buffer(frame, D, resolution=RES, progress=lambda d, t: seen.append((d, t)))
    n = len(frame)
    general = 5  # Fiji, Russia, Antarctica, Chile's border, the river
    assert seen == [(k, n) for k in range(n - general, n + 1)]
    assert got.geometry.to_wkb().tolist() == buffered.geometry.to_wkb().tolist()
    assert capsys.readouterr().err == ""  # the callable only; nothing without progress
    shown = gloffset.buffer(frame, D, resolution=RES, progress=True)
    err = capsys.readouterr().err
    assert "gloffset.buffer" in err and f"| {n}/{n} [" in err, err
    assert shown.geometry.to_wkb().tolist() == buffered.geometry.to_wkb().tolist()
    union = []
    gloffset.buffer(frame.iloc[[7, 8]], D, each=False, progress=lambda *a: union.append(a))
    assert union == [(1, 1)]
    with pytest.raises(gloffset.errors.OptionError, match="progress must be"):
        gloffset.buffer(frame, D, progress="yes")
