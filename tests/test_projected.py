"""The edges of a vector file in a projected CRS are the projection's straight lines: read
into lon/lat, each gets points until the great circles between them follow it to the
tolerance (1 m, or a hundredth of the edge where that is smaller; ``densify=`` and
``--densify`` set it). Lon/lat edges are great circles and get no points."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import DATA

import gloffset
from gloffset.cli import main
from gloffset.geometry.sphere import xyz_to_lonlat

pyogrio = pytest.importorskip("pyogrio")
pyproj = pytest.importorskip("pyproj")
gpd = pytest.importorskip("geopandas")
shapely = pytest.importorskip("shapely")

MEXICO = DATA / "mexico_10m.geojson"


def box_file(tmp_path, crs, lon0, lat0, lon1, lat1, name="box.gpkg"):
    """A 4-vertex box in ``crs`` with corners at these lon/lat; the file and the
    transformer from lon/lat to ``crs``."""
    to = pyproj.Transformer.from_crs("OGC:CRS84", crs, always_xy=True)
    x, y = to.transform([lon0, lon1, lon1, lon0, lon0], [lat0, lat0, lat1, lat1, lat0])
    frame = gpd.GeoDataFrame({"n": [1]}, geometry=[shapely.Polygon(zip(x, y))], crs=crs)
    path = tmp_path / name
    frame.to_file(path)
    return path, to, np.column_stack([x, y])


def along_edges(to, corners, n=400):
    """Lon/lat of ``n`` points on each straight edge (in the projection) of the box."""
    back = pyproj.Transformer.from_crs(to.target_crs, "OGC:CRS84", always_xy=True)
    t = (np.arange(n) + 0.5) / n
    pts = np.concatenate([a + t[:, None] * (b - a) for a, b in zip(corners[:-1], corners[1:])])
    return back.transform(pts[:, 0], pts[:, 1])


def test_a_mercator_box_follows_its_parallels(tmp_path):
    """EPSG:3857 box over 0-40 E, 40-60 N: its edges are parallels and meridians; as four
    great circles its northern edge bulged 196 km north, its southern one south."""
    path, to, corners = box_file(tmp_path, "EPSG:3857", 0, 40, 40, 60)
    shape = gloffset.read(path)
    assert gloffset.contains(shape, [20, 20, 20, 20], [40.3, 61, 40.01, 59.99]).tolist() == [
        True,
        False,
        True,
        True,
    ]
    lon, lat = along_edges(to, corners)
    assert np.abs(gloffset.distance(shape, lon, lat)).max() <= 1.0
    # every added point is on the projected line: the parallels stay at 40 and 60 N
    lo, la = xyz_to_lonlat(shape.rings[0])
    on_parallel = np.isclose(la, 40.0, atol=1e-9) | np.isclose(la, 60.0, atol=1e-9)
    on_meridian = np.isclose(lo, 0.0, atol=1e-9) | np.isclose(lo, 40.0, atol=1e-9)
    assert (on_parallel | on_meridian).all()


def test_a_utm_box_within_a_metre(tmp_path):
    """A 4 x 3 degree box in UTM zone 33N: 50 m off as four great circles."""
    path, to, corners = box_file(tmp_path, "EPSG:32633", 13, 45, 17, 48)
    shape = gloffset.read(path)
    lon, lat = along_edges(to, corners)
    d = gloffset.distance(shape, lon, lat)
    assert d.max() <= 1.0
    # a coarser tolerance: fewer points, within it
    coarse = gloffset.read(path, densify="20m")
    assert 5 < coarse.n_vertices < shape.n_vertices
    assert 1.0 < gloffset.distance(coarse, lon, lat).max() <= 20.0
    finer = gloffset.read(path, densify=0.05)  # metres
    assert finer.n_vertices > shape.n_vertices
    assert gloffset.distance(finer, lon, lat).max() <= 0.05


def test_lonlat_edges_get_no_points(tmp_path):
    path, _, _ = box_file(tmp_path, "EPSG:4326", 0, 40, 40, 60)
    assert gloffset.read(path).n_vertices == 4
    nad, _, _ = box_file(tmp_path, "EPSG:4269", 0, 40, 40, 60, name="nad.gpkg")
    assert gloffset.read(nad).n_vertices == 4  # another datum: lon/lat edges too


def test_mexico_in_utm_follows_its_projected_edges(tmp_path):
    """Natural Earth's Mexico in UTM 14N: the added points lie on the projected lines, and
    the border's long straight edges (great circles in the GeoJSON) are followed."""
    frame = pyogrio.read_dataframe(MEXICO).to_crs(32614)
    path = tmp_path / "mx.gpkg"
    pyogrio.write_dataframe(frame, path)
    shape = gloffset.read(path)
    assert shape.n_vertices > gloffset.read(MEXICO).n_vertices
    # points along every long projected edge of the file are within 1 m of its curves
    back = pyproj.Transformer.from_crs("EPSG:32614", "OGC:CRS84", always_xy=True)
    lon, lat = [], []
    for poly in frame.geometry.iloc[0].geoms:
        xy = np.asarray(poly.exterior.coords)
        long = np.hypot(*(xy[1:] - xy[:-1]).T) > 20e3  # the edges over 20 km
        if long.any():
            a, b = xy[:-1][long], xy[1:][long]
            t = np.linspace(0.05, 0.95, 19)
            pts = (a[:, None] + t[None, :, None] * (b - a)[:, None]).reshape(-1, 2)
            lo, la = back.transform(pts[:, 0], pts[:, 1])
            lon.append(lo)
            lat.append(la)
    assert lon  # the file has long edges
    assert gloffset.distance(shape, np.concatenate(lon), np.concatenate(lat)).max() <= 1.0


def test_the_cli_densify_option(tmp_path):
    path, _, _ = box_file(tmp_path, "EPSG:32633", 13, 45, 17, 48)
    points = tmp_path / "p.csv"
    points.write_text("lon,lat\n15,45.0\n15,48.0\n")
    r = CliRunner().invoke(main, ["offset", str(path), "-d", "1km", "--densify", "0.5m"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["features"]
    for bad in ("0m", "-1m", "far"):
        r = CliRunner().invoke(main, ["contains", str(path), str(points), "--densify", bad])
        assert r.exit_code == 2 and "distance" in r.output, (bad, r.output)


@pytest.mark.parametrize("bad", [True, np.True_, -1, 0.0, "-1", 1e-9, "1e-12m", "0.0009", "far"])
def test_a_bad_densify_is_refused_for_every_input_before_it_is_read(tmp_path, bad):
    """A tolerance that is no positive distance, or under 1 mm, is refused whatever the
    input, before it is read: a GeoJSON has no projected edge but was given it (True and
    -1 were taken silently), and 1e-12 m on a projected file ran for a minute into a
    numpy ArrayMemoryError."""
    path, _, _ = box_file(tmp_path, "EPSG:32633", 13, 45, 17, 48)
    for source in (path, MEXICO, tmp_path / "no_such.gpkg", np.array([[0.0, 0], [1, 1]])):
        with pytest.raises(gloffset.InvalidDistanceError, match="densify tolerance|distance"):
            gloffset.read(source, densify=bad)


def test_the_smallest_densify_is_a_millimetre(tmp_path):
    path, to, corners = box_file(tmp_path, "EPSG:32633", 13, 45, 17, 48)
    fine = gloffset.read(path, densify=0.001)
    assert fine.n_vertices > gloffset.read(path, densify="0.01m").n_vertices
    lon, lat = along_edges(to, corners)
    assert gloffset.distance(fine, lon, lat).max() <= 0.001
    with pytest.raises(gloffset.InvalidDistanceError, match=r"below the smallest, 1 mm"):
        gloffset.read(path, densify=0.000999)
    for bad in ("1e-12m", "-1"):
        out = tmp_path / "x.png"
        r = CliRunner().invoke(
            main, ["render", str(path), "-d", "1km", "--densify", bad, "-o", str(out)]
        )
        assert r.exit_code == 2 and "densify tolerance" in r.output, r.output
        assert not out.exists()
