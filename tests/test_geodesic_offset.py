"""Vector offsets on the ellipsoid (gloffset.offset(..., ellipsoid=...)) against the
brute-force judge of gloffset.reference (pyproj geodesics): every vertex and every
edge's geodesic midpoint within the tolerance of |d|, and the region bounded by the
rings (geodesic edges) equal to the judge's membership on points farther than the
tolerance from the boundary."""

from __future__ import annotations

import json

import numpy as np
import pytest

import gloffset
from gloffset import reference

pyproj = pytest.importorskip("pyproj")
from conftest import DATA  # noqa: E402

GEOD = pyproj.Geod(ellps="WGS84")


def _features(path, names):
    fc = json.loads(path.read_text())
    feats = [f for f in fc["features"] if f["properties"].get("name") in names]
    assert len(feats) == len(names), names
    return gloffset.read({"type": "FeatureCollection", "features": feats})


def _ring_points(off):
    """Every vertex and every edge's geodesic midpoint of the rings (lon, lat)."""
    lon, lat = [], []
    for ll in off.lonlat():
        a, b = ll, np.roll(ll, -1, axis=0)
        az, _, dist = GEOD.inv(a[:, 0], a[:, 1], b[:, 0], b[:, 1])
        mlon, mlat, _ = GEOD.fwd(a[:, 0], a[:, 1], az, 0.5 * dist)
        lon += [a[:, 0], mlon]
        lat += [a[:, 1], mlat]
    return np.concatenate(lon), np.concatenate(lat)


def _probe(off, n, seed):
    """Points near the rings: vertices moved 0 to 30 tolerances (and 0 to 5 % of |d|)
    in random directions."""
    rng = np.random.default_rng(seed)
    ll = np.vstack(off.lonlat())
    k = rng.integers(0, len(ll), n)
    step = np.where(
        rng.random(n) < 0.5,
        rng.uniform(0.0, 30.0, n) * off.tolerance,
        rng.uniform(0.0, 0.05, n) * abs(off.distance),
    )
    lon, lat, _ = GEOD.fwd(ll[k, 0], ll[k, 1], rng.uniform(-180, 180, n), step)
    return np.asarray(lon), np.asarray(lat)


def check_offset(shape, d, *, tol=1.0, n=300, seed=0):
    off = gloffset.offset(shape, d, ellipsoid="WGS84", tolerance=tol)
    assert off.rings, "no rings"
    lon, lat = _ring_points(off)
    dist = reference.geodesic_distance(shape, lon, lat, "WGS84")
    err = np.abs(dist - abs(d))
    assert err.max() <= tol, (d, float(err.max()))
    assert off.vertex_error <= 1e-3 * tol and off.unresolved == 0
    # the region: the rings read back as polygons with geodesic edges
    region = gloffset.read(off.to_geojson())
    plon, plat = _probe(off, n, seed)
    truth = reference.geodesic_contains(shape, plon, plat, d, "WGS84")
    pdist = reference.geodesic_distance(shape, plon, plat, "WGS84")
    far = np.abs(pdist - abs(d)) > tol
    ins = reference.geodesic_inside(shape, plon, plat, "WGS84")
    far &= ~ins if d > 0 else ins  # the boundary at |d| is where the rings are
    got = reference.geodesic_inside(region, plon, plat, "WGS84")
    bad = np.flatnonzero(far & (got != truth))
    assert len(bad) == 0, (d, plon[bad[:5]], plat[bad[:5]], pdist[bad[:5]])
    return off


@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_line_and_point():
    line = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [1, 0.5], [2, 0]]})
    check_offset(line, 1000.0, n=100)
    pt = gloffset.read({"type": "Point", "coordinates": [10.0, 60.0]})
    off = check_offset(pt, 20e3, tol=5.0, n=100)
    assert len(off.rings) == 1


@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_square_in_and_out():
    ring = [[0, 0], [3, 0], [3, 3], [0, 3], [0, 0]]
    sq = gloffset.read({"type": "Polygon", "coordinates": [ring]})
    check_offset(sq, 5e3, tol=2.0, n=100)
    check_offset(sq, -20e3, tol=2.0, n=100)


@pytest.mark.slow  # 2.3 s; run by .ci/run with -m slow
def test_polygon_with_hole():
    outer = [[0, 0], [2, 0], [2, 2], [0, 2], [0, 0]]
    hole = [[0.5, 0.5], [0.5, 1.5], [1.5, 1.5], [1.5, 0.5], [0.5, 0.5]]
    shape = gloffset.read({"type": "Polygon", "coordinates": [outer, hole]})
    off = check_offset(shape, 10e3, tol=5.0, n=100)
    assert len(off.rings) == 2  # the hole shrinks, and stays
    off = check_offset(shape, -10e3, tol=5.0, n=100)
    assert len(off.rings) == 2


@pytest.mark.parametrize(
    ("tip", "d"), [pytest.param(0.02, 1000.0, marks=pytest.mark.slow), (0.01, 500.0)]
)
def test_hairpin_far_from_the_median_latitude(tip, d):
    """A hairpin at the equator whose inner parallels meet at a sharp junction, the
    shape's median latitude (hence the spherical offset's scale) at 60 degrees: the
    junction lies hundreds of metres from the sphere's, and the ring's edge beside it
    runs along a generator's direction (its midpoint used to fall back onto its end,
    2.3 m off)."""
    far = [[20, 60], [20.5, 60.2], [21, 60], [21.5, 60.2], [22, 60]]
    coords = [[[0, 0], [1, 0], [0, tip]], far]
    shape = gloffset.read({"type": "MultiLineString", "coordinates": coords})
    check_offset(shape, d, n=100)


@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_fiji_antimeridian():
    fiji = _features(DATA / "world_110m.geojson", ["Fiji"])
    off = check_offset(fiji, 10e3, tol=5.0, n=100)
    geom = off.to_geojson()["geometry"]
    lons = [c[0] for poly in geom["coordinates"] for ring in poly for c in ring]
    assert max(lons) <= 180.0 and min(lons) >= -180.0 and max(lons) > 179 and min(lons) < -179


def test_sphere_unchanged():
    sq = gloffset.read({"type": "Polygon", "coordinates": [[[0, 0], [3, 0], [3, 3], [0, 0]]]})
    a = gloffset.offset(sq, 1e4)
    b = gloffset.vector.offset.offset(sq, 1e4)
    assert type(a) is type(b) and np.array_equal(a.centers[0], b.centers[0])


def test_zero_and_errors():
    sq = gloffset.read({"type": "Polygon", "coordinates": [[[0, 0], [3, 0], [3, 3], [0, 0]]]})
    off = gloffset.offset(sq, 0.0, ellipsoid="WGS84")
    assert off.to_geojson()["geometry"]["type"] in ("Polygon", "MultiPolygon")
    line = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [1, 0]]})
    with pytest.raises(gloffset.InvalidDistanceError):
        gloffset.offset(line, -10.0, ellipsoid="WGS84")
    with pytest.raises(gloffset.InvalidDistanceError):
        gloffset.offset(line, 10.0, ellipsoid="WGS84", tolerance=0.0)
    with pytest.raises(gloffset.InvalidEllipsoidError):
        gloffset.offset(line, 10.0, ellipsoid="Mars")


def test_cli(tmp_path):
    from click.testing import CliRunner

    from gloffset.cli import main

    src = tmp_path / "line.geojson"
    src.write_text(json.dumps({"type": "LineString", "coordinates": [[0, 0], [1, 0]]}))
    out = tmp_path / "off.geojson"
    args = ["offset", str(src), "-d", "2km", "--ellipsoid", "WGS84", "--tolerance", "0.5m"]
    r = CliRunner().invoke(main, args + ["-o", str(out)])
    assert r.exit_code == 0, r.output
    feat = json.loads(out.read_text())["features"][0]
    assert feat["properties"]["ellipsoid"] == "WGS84" and feat["properties"]["tolerance_m"] == 0.5
    ring = np.array(feat["geometry"]["coordinates"][0])
    shape = gloffset.read(json.loads(src.read_text()))
    dist = reference.geodesic_distance(shape, ring[:, 0], ring[:, 1], "WGS84")
    assert np.abs(dist - 2000.0).max() < 1e-3
    r = CliRunner().invoke(main, ["offset", str(src), "-d", "0.1rad", "--ellipsoid", "WGS84"])
    assert r.exit_code != 0 and "angle" in r.output


@pytest.mark.slow
@pytest.mark.parametrize("d", [10.0, 1e3, 100e3, 1000e3, -10e3, -100e3])
def test_mexico(d):
    mexico = gloffset.read(DATA / "mexico_10m.geojson")
    check_offset(mexico, d, n=400, seed=int(abs(d)))


@pytest.mark.slow
@pytest.mark.parametrize("d", [10e3, -5e3])
def test_neighbours(d):
    pair = _features(DATA / "countries_10m.geojson", ["Belgium", "Luxembourg"])
    check_offset(pair, d, n=300)


@pytest.mark.slow
@pytest.mark.parametrize("d", [100e3, -200e3])
def test_antarctica_pole(d):
    ant = _features(DATA / "world_110m.geojson", ["Antarctica"])
    check_offset(ant, d, n=300)
