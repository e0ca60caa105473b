"""Per-feature offsets (--each): every feature's result equals a run on that feature alone,
with its properties kept; points and segments (computed all at once) lie exactly at the
distance, across the antimeridian and round the poles too."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import gloffset
from gloffset.cli import main
from gloffset.io.geojson import disc_geometry
from gloffset.vector.discs import discs, stadiums

shapely = pytest.importorskip("shapely")

DATA = Path(__file__).resolve().parents[1] / "data"
D = 50e3


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def features():
    mexico = json.loads((DATA / "mexico_10m.geojson").read_text())["features"][0]
    geoms = [
        mexico["geometry"],
        {"type": "LineString", "coordinates": [[-100, 40], [-99, 41], [-97, 40.5]]},
        {"type": "LineString", "coordinates": [[179.5, -16], [-179.5, -17]]},
        {"type": "Point", "coordinates": [-99.13, 19.43]},
        None,
        {"type": "Point", "coordinates": [179.99, 0.0]},
        {"type": "Point", "coordinates": [30.0, 89.9]},
        {"type": "LineString", "coordinates": [[0, -89.8], [90, -89.9]]},
    ]
    return [
        {"type": "Feature", "properties": {"name": f"f{i}", "n": i}, "geometry": g}
        for i, g in enumerate(geoms)
    ]


@pytest.fixture(scope="module")
def each(tmp_path_factory):
    src = tmp_path_factory.mktemp("each") / "in.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": features()}))
    r = run("offset", src, "-d", "50km", "--each")
    assert r.exit_code == 0, r.output
    return json.loads(r.output)["features"]


def alone(tmp_path, feature) -> dict:
    src = tmp_path / "one.geojson"
    src.write_text(json.dumps(feature))
    r = run("offset", src, "-d", "50km")
    assert r.exit_code == 0, r.output
    return json.loads(r.output)["features"][0]["geometry"]


def test_properties_are_kept_and_the_distance_added(each):
    assert len(each) == len(features())
    for i, f in enumerate(each):
        want = {"name": f"f{i}", "n": i, "distance_m": 50000.0, "distance": "50km"}
        assert f["properties"] == want
    assert each[4]["geometry"] is None


@pytest.mark.parametrize("i", [0, 1])
def test_general_features_equal_their_single_runs(tmp_path, each, i):
    assert each[i]["geometry"] == alone(tmp_path, features()[i])


@pytest.mark.parametrize("i", [2, 3, 5, 6, 7])
def test_points_and_segments_are_the_regions_of_their_single_runs(tmp_path, each, i):
    """Computed all at once, sampled differently: every vertex at exactly d from the
    feature, the same region as the single run away from the boundary."""
    got = shapely.geometry.shape(each[i]["geometry"])
    want = shapely.geometry.shape(alone(tmp_path, features()[i]))
    assert got.is_valid
    shape = gloffset.read(features()[i])
    xy = shapely.get_coordinates(got)
    # vertices on the cut and the pole edge are not on the circle: drop them
    free = (np.abs(np.abs(xy[:, 0]) - 180) > 1e-9) & (np.abs(np.abs(xy[:, 1]) - 90) > 1e-9)
    err = np.abs(gloffset.distance(shape, xy[free, 0], xy[free, 1]) - D)
    assert err.max() < 1e-4  # metres
    assert abs(got.area - want.area) <= 2e-3 * want.area
    rng = np.random.default_rng(i)
    lo, hi = np.array(want.bounds[:2]), np.array(want.bounds[2:])
    p = lo + (hi - lo) * rng.random((4000, 2))
    dist = gloffset.distance(shape, p[:, 0], p[:, 1])
    clear = np.abs(dist - D) > 0.01 * D
    inside = shapely.contains_xy(got, p[clear, 0], p[clear, 1])
    assert np.array_equal(inside, dist[clear] < D)


def test_many_points_at_once_lie_on_their_circles():
    rng = np.random.default_rng(3)
    ll = np.column_stack([rng.uniform(-180, 180, 2000), rng.uniform(-90, 90, 2000)])
    d = 0.01
    rings = discs(ll, d, 8)
    for j in range(0, 2000, 97):
        g = shapely.geometry.shape(disc_geometry(rings, j))
        xy = shapely.get_coordinates(g)
        free = (np.abs(np.abs(xy[:, 0]) - 180) > 1e-9) & (np.abs(np.abs(xy[:, 1]) - 90) > 1e-9)
        point = gloffset.read({"type": "Point", "coordinates": ll[j].tolist()})
        dist = gloffset.distance(point, *xy[free].T, radius=1)
        assert np.abs(dist - d).max() < 1e-12
    seg = stadiums(ll[:100], ll[:100] + 0.1 * rng.standard_normal((100, 2)).clip(-1, 1), d, 8)
    assert seg.lonlat.shape[0] == 100


def test_contains_each_matches_single_runs(tmp_path):
    feats = [f for f in features() if f["geometry"] is not None][:4]
    src = tmp_path / "in.geojson"
    src.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    rng = np.random.default_rng(1)
    pts = tmp_path / "p.csv"
    lon, lat = rng.uniform(-120, -85, 300), rng.uniform(10, 45, 300)
    pts.write_text(
        "id,lon,lat\n" + "".join(f"{k},{x},{y}\n" for k, (x, y) in enumerate(zip(lon, lat)))
    )
    r = run("contains", src, pts, "-d", "50km", "--each")
    assert r.exit_code == 0, r.output
    rows = list(csv.DictReader(io.StringIO(r.output)))
    got = {(int(row["id"]), int(row["feature"])) for row in rows if row["feature"]}
    want = set()
    for k, f in enumerate(feats):
        inside = gloffset.contains(gloffset.read(f), lon, lat, distance=D)
        want |= {(int(i), k) for i in np.flatnonzero(inside)}
    assert got == want and want
    names = {(int(row["id"]), row["name"]) for row in rows if row["feature"]}
    assert names == {(i, feats[k]["properties"]["name"]) for i, k in want}
    assert {int(row["id"]) for row in rows} == set(range(300))


def test_an_error_names_the_feature(tmp_path):
    src = tmp_path / "in.geojson"
    feats = features()[:4]
    src.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    r = run("offset", src, "-d", "-10km", "--each")
    assert r.exit_code == 2 and "feature 1" in r.output
    feats[1]["geometry"]["coordinates"][1] = [-99, 95]
    src.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    r = run("offset", src, "-d", "10km", "--each")
    assert r.exit_code == 2 and "feature 1" in r.output and "latitude" in r.output
