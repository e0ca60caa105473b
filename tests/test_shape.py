import io
import json

import numpy as np
import pytest
import shapely.geometry as sg

import gloffset
from gloffset import InputFormatError, InvalidGeometryError
from gloffset.geometry.sphere import xyz_to_lonlat

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]]}


def test_read_all_forms(tmp_path, monkeypatch):
    p = tmp_path / "sq.geojson"
    p.write_text(json.dumps(SQUARE))
    feature = {"type": "Feature", "properties": {}, "geometry": SQUARE}
    shapes = [
        gloffset.read(SQUARE),
        gloffset.read(str(p)),
        gloffset.read(p),
        gloffset.read(json.dumps(SQUARE)),
        gloffset.read(feature),
        gloffset.read({"type": "FeatureCollection", "features": [feature]}),
        gloffset.read(sg.shape(SQUARE)),
        gloffset.read(np.array(SQUARE["coordinates"][0], dtype=float)),
    ]
    monkeypatch.setattr("sys.stdin", io.StringIO(json.dumps(SQUARE)))
    shapes.append(gloffset.read("-"))
    for s in shapes:
        assert len(s.rings) == 1 and len(s.rings[0]) == 4
        assert gloffset.contains(s, 5.0, 5.0) and not gloffset.contains(s, 15.0, 5.0)


def test_lines_points_and_holes():
    g = {
        "type": "GeometryCollection",
        "geometries": [
            {"type": "MultiLineString", "coordinates": [[[0, 0], [1, 1]], [[2, 2], [3, 2]]]},
            {"type": "Point", "coordinates": [50, 50]},
            {
                "type": "Polygon",
                "coordinates": [
                    [[20, 0], [30, 0], [30, 10], [20, 10], [20, 0]],
                    [[24, 4], [26, 4], [26, 6], [24, 6], [24, 4]],
                ],
            },
        ],
    }
    s = gloffset.read(g)
    assert len(s.lines) == 3 and len(s.rings) == 2
    assert list(s.ring_holes) == [False, True]
    lon = np.array([22.0, 25.0, 50.0, 0.5])
    lat = np.array([2.0, 5.0, 50.0, 0.5])
    assert gloffset.contains(s, lon, lat).tolist() == [True, False, False, False]
    assert gloffset.distance(s, 50.0, 50.0) == 0.0


def test_winding_is_not_trusted():
    cw = {"type": "Polygon", "coordinates": [SQUARE["coordinates"][0][::-1]]}
    for g in (SQUARE, cw):
        s = gloffset.read(g)
        assert gloffset.contains(s, 5.0, 5.0) and not gloffset.contains(s, -170.0, -5.0)


def test_repeated_points_are_dropped():
    s = gloffset.read(
        {"type": "LineString", "coordinates": [[0, 0], [0, 0], [1, 0], [1, 0], [2, 0]]}
    )
    assert len(s.lines[0]) == 3


@pytest.mark.parametrize(
    "geom, words",
    [
        (
            {"type": "LineString", "coordinates": [[0, 0], [float("nan"), 1]]},
            "vertex 1: coordinate is not finite",
        ),
        ({"type": "LineString", "coordinates": [[0, 0], [float("inf"), 1]]}, "not finite"),
        ({"type": "LineString", "coordinates": [[0, 0], [1, 91]]}, "latitude 91.0 out of range"),
        ({"type": "LineString", "coordinates": [[3, 3], [3, 3]]}, "at least 2 distinct points"),
        ({"type": "LineString", "coordinates": []}, "at least 2 distinct points"),
        (
            {"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [0, 0]]]},
            "at least 3 distinct points",
        ),
        ({"type": "LineString", "coordinates": [[0, 10], [180, -10]]}, "antipodal"),
        ({"type": "FeatureCollection", "features": []}, "empty geometry"),
        ({"type": "Polygon", "coordinates": []}, "empty geometry"),
    ],
)
def test_bad_geometry_errors(geom, words):
    with pytest.raises((InvalidGeometryError, InputFormatError), match=words):
        gloffset.read(geom)


def test_error_names_the_feature():
    fc = {
        "type": "FeatureCollection",
        "features": [
            {"type": "Feature", "properties": {"name": "Good"}, "geometry": SQUARE},
            {
                "type": "Feature",
                "properties": {"name": "Broken"},
                "geometry": {"type": "LineString", "coordinates": [[0, 0], [1, 95]]},
            },
        ],
    }
    with pytest.raises(InvalidGeometryError, match=r"feature 1 \(Broken\).*vertex 1"):
        gloffset.read(fc)


@pytest.mark.parametrize(
    "src, words",
    [
        ("/no/such/file.geojson", "no such file"),
        ("{not json", "not valid JSON"),
        ({"type": "Circle", "coordinates": [0, 0]}, "unsupported geometry type"),
        ({"coordinates": []}, "no 'type'"),
        (42, "cannot read geometry"),
        (np.zeros((3, 3)), "shape \\(n, 2\\)"),
    ],
)
def test_bad_input_errors(src, words):
    with pytest.raises(InputFormatError, match=words):
        gloffset.read(src)


def test_fiji_pieces_join_across_the_antimeridian(world):
    s = gloffset.read(world["Fiji"])
    # three input polygons, two of them cut at 180 deg: joined into one ring
    assert len(s.rings) == 2 and not any(x.any() for x in s.ring_seams)
    joined = max(s.rings, key=len)
    lon, _ = xyz_to_lonlat(joined)
    assert (lon > 179).any() and (lon < -179).any()
    # the seam has no distance: a point on it inside the island is far from the coast
    d = gloffset.distance(s, 180.0, -16.3)
    assert d > 2000.0 and gloffset.contains(s, 180.0, -16.3)


def test_antarctica_pole_seams_are_not_boundary(world):
    s = gloffset.read(world["Antarctica"])
    assert not any(x.any() for x in s.ring_seams)
    assert gloffset.contains(s, 0.0, -90.0) and gloffset.contains(s, 123.0, -89.0)
    # the pole is far from the coast (the +-90 deg edges and the 180 deg cut are seams)
    assert gloffset.distance(s, 0.0, -90.0) > 400e3
    assert gloffset.distance(s, 180.0, -86.0) > 50e3


def test_unpaired_seam_is_kept_as_seam():
    # half of a square cut at 180 deg without its other half
    g = {"type": "Polygon", "coordinates": [[[170, 0], [180, 0], [180, 10], [170, 10], [170, 0]]]}
    s = gloffset.read(g)
    assert s.ring_seams[0].sum() == 1
    assert gloffset.contains(s, 175.0, 5.0)
    # the distance to the seam side is the distance to the corners/other sides
    assert gloffset.distance(s, 180.0, 5.0, radius=1.0) > np.radians(4.9)


@pytest.mark.parametrize("name", ["Fiji", "Russia", "Antarctica", "Italy"])
def test_to_geojson_round_trip(world, name):
    s = gloffset.read(world[name])
    again = gloffset.read(s.to_geojson())
    lon = np.random.default_rng(0).uniform(-180, 180, 20000)
    lat = np.degrees(np.arcsin(np.random.default_rng(1).uniform(-1, 1, 20000)))
    assert np.array_equal(gloffset.contains(s, lon, lat), gloffset.contains(again, lon, lat))


def test_one_edge_index_kept_on_the_shape_and_left_out_of_a_pickle(world):
    import pickle

    from gloffset.edges import CurveArcs, distance_xyz
    from gloffset.geometry import crossings
    from gloffset.vector.arrangement import defects

    s = gloffset.read(world["France"])
    rng = np.random.default_rng(3)
    p = rng.normal(size=(400, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    # the inside tests, the distance, the overlap and defect checks share one edge index
    arcs = s.arcs()
    assert CurveArcs.from_shape(s) is arcs and s.derived.arcs is arcs
    assert np.array_equal(arcs.ring, np.flatnonzero(s.edges().group >= 0))
    assert np.array_equal(crossings.inside_indexed(s, p), crossings.inside(s, p))
    assert np.array_equal(crossings.inside_indexed(s, p, anchors=64), crossings.inside(s, p))
    assert len(s.overlapping_components()) == 0 and defects(s) == (False, False)
    assert np.all(distance_xyz(s, p) >= 0.0)
    assert s.arcs() is arcs and s.derived.defects == (False, False) and 64 in s.derived.anchors
    # what is derived is left out of a pickle, and rebuilt the same
    back = pickle.loads(pickle.dumps(s))
    assert back.derived.arcs is None and not back.derived.anchors and back.derived.defects is None
    assert len(pickle.dumps(s)) == len(pickle.dumps(back))
    assert np.array_equal(crossings.inside_indexed(back, p, anchors=64), crossings.inside(s, p))
    assert s.derived.arcs is arcs  # the original keeps its own
