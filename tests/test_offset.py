import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import gloffset
from gloffset import InvalidDistanceError
from gloffset.geometry.sphere import angle, arc_distance, lonlat_to_xyz
from gloffset.vector.arcrings import sample_arc

T = np.linspace(0.0, 1.0, 7)


def assert_arcs_at_distance(off, tol=1e-12):
    """Every sampled point of every arc lies at |d| from its generating vertex or edge."""
    d = abs(off.distance)
    for ring in off.rings:
        q, r = ring.centers, ring.junctions
        start = np.roll(r, 1, axis=0)
        for t in T:
            pts = sample_arc(q, start, r, np.full(len(q), t))
            assert np.abs(np.linalg.norm(pts, axis=1) - 1.0).max() < 1e-13
            dist = arc_distance(pts, ring.sources[:, 0], ring.sources[:, 1])
            assert np.abs(dist - d).max() < tol, (t, np.abs(dist - d).max())


def assert_eq4(off):
    """Junctions are the sums of consecutive centres (Eq. 4) wherever no split was inserted."""
    for ring in off.rings:
        q, r = ring.centers, ring.junctions
        same_circle = np.all(np.abs(q - np.roll(q, -1, axis=0)) < 1e-15, axis=1)
        s = q + np.roll(q, -1, axis=0)
        assert np.abs(s - r)[~same_circle].max() < 1e-15


lonlats = hnp.arrays(
    np.float64,
    st.tuples(st.integers(2, 12), st.just(2)),
    elements=st.floats(-60, 60, allow_nan=False),
)


@given(lonlats, st.floats(1e-6, 0.5), st.booleans())
@settings(max_examples=60, deadline=None)
def test_random_curves_offset_at_distance(ll, d, closed):
    try:
        shape = gloffset.Shape.from_lonlat(ll[:, 0], ll[:, 1], closed=closed)
    except gloffset.InvalidGeometryError:
        return  # too few distinct points
    for sign in (1.0, -1.0) if closed else (1.0,):
        off = gloffset.offset(shape, sign * d, radius=1.0)
        assert_arcs_at_distance(off)
        assert_eq4(off)


@pytest.mark.parametrize("name", ["Fiji", "Russia", "Antarctica", "Chile", "Canada"])
@pytest.mark.parametrize("d", [0.02, -0.005, 1e-7])
def test_world_borders(world, name, d):
    off = gloffset.offset(gloffset.read(world[name]), d, radius=1.0)
    assert_arcs_at_distance(off)


def test_mexico_10m(mexico_path):
    off = gloffset.offset(gloffset.read(mexico_path), 127e3)
    assert abs(off.distance - 127e3 / gloffset.EARTH_RADIUS) < 1e-18
    assert_arcs_at_distance(off)
    assert_eq4(off)


def test_paper_equations_for_a_single_arc():
    lon, lat = [0.0, 10.0, 10.0, 0.0], [0.0, 0.0, 10.0, 10.0]
    p0, p1 = lonlat_to_xyz(lon[:2], lat[:2])
    d = 0.1
    off = gloffset.offset(gloffset.Shape.from_lonlat(lon, lat, closed=True), d, radius=1.0)
    q = off.centers[0]
    n = np.cross(p1, p0) / np.linalg.norm(np.cross(p1, p0))
    assert np.allclose(q[0], np.cos(d) * p0, atol=1e-16)  # Eq. 2
    assert np.allclose(q[1], np.sin(d) * n, atol=1e-16)  # Eq. 3
    assert np.allclose(off.junctions[0][0], q[0] + q[1], atol=1e-16)  # Eq. 4


def test_line_caps_and_point_circle():
    s = gloffset.read(
        {
            "type": "GeometryCollection",
            "geometries": [
                {"type": "LineString", "coordinates": [[0, 0], [10, 0]]},
                {"type": "Point", "coordinates": [40, 40]},
            ],
        }
    )
    off = gloffset.offset(s, 0.05, radius=1.0)
    assert len(off.rings) == 2
    assert_arcs_at_distance(off)
    pts = off.sample(1e-6)
    # the cap reaches 0.05 rad beyond the line's end
    tip = lonlat_to_xyz(10.0, 0.0)
    assert angle(pts[0], tip).max() == pytest.approx(np.radians(10) + 0.05, abs=1e-6)
    assert np.abs(angle(pts[1], lonlat_to_xyz(40.0, 40.0)) - 0.05).max() < 1e-12
    # lines have no inside: a negative or zero offset is refused
    for d in (-0.05, 0.0):
        with pytest.raises(gloffset.InvalidDistanceError, match="no polygon"):
            gloffset.offset(s, d, radius=1.0)


def test_sample_tolerance():
    s = gloffset.read({"type": "Point", "coordinates": [0, 0]})
    off = gloffset.offset(s, 0.3, radius=1.0)
    for tol in (1e-3, 1e-5):
        ring = off.sample(tol)[0]
        mid = ring + np.roll(ring, -1, axis=0)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        # great-circle midpoints stay within tol of the circle
        assert np.abs(angle(mid, lonlat_to_xyz(0, 0)) - 0.3).max() <= tol


def test_geojson_is_rfc7946(world):
    for name, d in [("Fiji", 50e3), ("Russia", 100e3), ("Antarctica", 200e3), ("Mexico", -20e3)]:
        feat = gloffset.offset(gloffset.read(world[name]), d).to_geojson()
        geom = feat["geometry"]
        polys = geom["coordinates"] if geom["type"] == "MultiPolygon" else [geom["coordinates"]]
        assert polys
        for poly in polys:
            for k, ring in enumerate(poly):
                a = np.asarray(ring)
                assert np.array_equal(a[0], a[-1])
                assert (np.abs(a[:, 0]) <= 180).all() and (np.abs(a[:, 1]) <= 90).all()
                x, y = a[:, 0], a[:, 1]
                area = 0.5 * np.sum(x[:-1] * y[1:] - x[1:] * y[:-1])
                assert (area > 0) == (k == 0), (name, k, area)
        json.dumps(feat)
    # a ring round the south pole: its offset is closed along the -90 deg edge
    lon = np.linspace(-180, 180, 37)[:-1] + 3.0
    polar = gloffset.Shape.from_lonlat(lon, np.full(36, -80.0), closed=True)
    feat = gloffset.offset(polar, 100e3).to_geojson()
    ring = np.asarray(feat["geometry"]["coordinates"][0])
    assert (ring[:, 1] == -90).sum() == 2 and ring[:, 1].max() < -78.9


def test_distance_errors():
    s = gloffset.read({"type": "Point", "coordinates": [0, 0]})
    with pytest.raises(InvalidDistanceError):
        gloffset.offset(s, float("nan"))
    with pytest.raises(InvalidDistanceError, match="quarter"):
        gloffset.offset(s, 2.0, radius=1.0)
    with pytest.raises(InvalidDistanceError, match="radius"):
        gloffset.offset(s, 1.0, radius=-1.0)
    # the distance as given, in the units of the radius, never the internal angle
    with pytest.raises(InvalidDistanceError, match=r"^distance 40000000.0 \(6.278 rad on a sph"):
        gloffset.offset(s, 4e7)
    with pytest.raises(InvalidDistanceError, match=r"^distance -1000 is negative"):
        gloffset.offset(s, -1000)
    with pytest.raises(InvalidDistanceError, match=r"^distance 20000km \(3.139 rad"):
        gloffset.offset(s, "20000km")
    with pytest.raises(InvalidDistanceError, match="unknown distance unit"):
        gloffset.parse_distance("5 furlongs")
    assert gloffset.parse_distance("1.5deg") == pytest.approx(np.radians(1.5))
    assert gloffset.parse_distance("500") == pytest.approx(500 / gloffset.EARTH_RADIUS)


def test_geojson_properties_name_the_distance_in_metres_and_as_given(mexico_path):
    """One scheme for every output: ``distance_m`` (the length in the radius' units) and
    ``distance`` (as given), for the resolved, the raw and the zero offset."""
    mexico = gloffset.read(mexico_path)
    want = {"distance_m": 127000.0, "distance": "127km"}
    off = gloffset.offset(mexico, "127km")
    assert off.distance == pytest.approx(127000.0 / gloffset.EARTH_RADIUS, rel=1e-15)
    assert off.to_geojson(tolerance=1e-4)["properties"] == want
    assert off.to_geojson(tolerance=1e-4, raw=True)["properties"] == want | {"raw": True}
    props = gloffset.offset(mexico, 5000.0).to_geojson(tolerance=1e-4)["properties"]
    assert props == {"distance_m": 5000.0, "distance": 5000.0}
    props = gloffset.offset(mexico, 0.0).to_geojson()["properties"]
    assert props == {"distance_m": 0.0, "distance": 0.0}
    props = gloffset.offset(mexico, "0.01rad", radius=2.0).to_geojson(tolerance=1e-4)
    assert props["properties"] == {"distance_m": 0.02, "distance": "0.01rad"}


def test_raw_offset_is_written_as_the_closed_curves_it_is(mexico_path):
    """The raw offset crosses itself, so it is no (Multi)Polygon: each ring is a closed
    LineString, cut at the antimeridian only where a ring crosses it."""
    shapely = pytest.importorskip("shapely")
    off = gloffset.offset(gloffset.read(mexico_path), 0.02, radius=1.0)
    feat = off.to_geojson(raw=True, tolerance=1e-5)
    geom = feat["geometry"]
    assert geom["type"] == "MultiLineString" and feat["properties"]["raw"] is True
    lines = geom["coordinates"]
    assert len(lines) == len(off.rings)  # Mexico is far from the antimeridian
    for line in lines:
        assert line[0] == line[-1]
    assert not shapely.geometry.shape(geom).is_simple  # loops at concave corners


def test_to_geojson_is_the_io_writer(world):
    """Offset.to_geojson and ResolvedOffset.to_geojson are the writers of gloffset.io.geojson,
    byte for byte, raw and resolved (Fiji: rings across the antimeridian)."""
    from gloffset.io.geojson import offset_feature, region_feature

    off = gloffset.offset(world["Fiji"], "50km")
    for kw in ({}, {"raw": True}, {"digits": 5, "tolerance": 1e-5}):
        want = offset_feature(off, **{"tolerance": 1e-6, **kw})
        assert json.dumps(off.to_geojson(**kw)) == json.dumps(want)
    res = off.resolve()
    assert json.dumps(res.to_geojson()) == json.dumps(region_feature(res, tolerance=1e-6))
    assert off.to_geojson()["geometry"]["type"] == "MultiPolygon"


def test_repr_names_the_distance_the_rings_and_whether_resolved(mexico_path):
    """An offset printed in a session says what it holds, not ``<... object at 0x...>``:
    the distance as given and as an angle, the raw rings and arcs, and what resolve gave
    once called; ``off.centers`` is a list with one (m, 3) array of centres per ring."""
    off = gloffset.offset(gloffset.read(mexico_path), "127km")
    arcs = sum(len(c) for c in off.centers)
    assert len(off.centers) == len(off.rings) > 1 and off.centers[0].shape[1] == 3
    text = repr(off)
    assert "object at" not in text and text.startswith("Offset('127km' = 0.019934 rad: ")
    assert f"{len(off.rings):,} rings, {arcs:,} arcs, raw; not resolved" in text
    res = off.resolve()
    assert repr(off).endswith(f"raw; resolved: {res!r})") and "polygons" in repr(res)
    line = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [10, 0]]})
    assert repr(gloffset.offset(line, 0.01, radius=1.0)) == (
        "Offset(0.01 = 0.01 rad: 1 ring, 6 arcs, raw; not resolved)"
    )
