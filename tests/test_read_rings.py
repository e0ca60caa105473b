"""The rings of an input checked, converted and oriented all at once (``prepare_rings``):
the same arrays, bit for bit, and the same errors as ring by ring (``prepare_ring``)."""

import json

import numpy as np
import pytest
from conftest import DATA

import gloffset
from gloffset.errors import InvalidGeometryError
from gloffset.geometry.lonlat import prepare_ring, prepare_rings
from gloffset.io import geojson as gj


def ring_list(path, limit=None):
    parts = gj.parse(json.loads((DATA / path).read_text()))
    rings = [r for poly in parts.polygons[:limit] for r in poly]
    ext = [k == 0 for poly in parts.polygons[:limit] for k in range(len(poly))]
    return rings, ext


def assert_same(rings, exterior):
    labels = [f"ring {k}" for k in range(len(rings))]
    got = prepare_rings(rings, labels, exterior)
    want = [prepare_ring(r, lab, e) for r, lab, e in zip(rings, labels, exterior)]
    for k, w in enumerate(want):
        for g_arr, w_arr in zip((got[0][k], got[1][k], got[2][k]), w):
            assert g_arr.dtype == w_arr.dtype and g_arr.shape == w_arr.shape, k
            assert g_arr.tobytes() == w_arr.tobytes(), k


@pytest.mark.parametrize(
    "path,limit",
    [("world_110m.geojson", None), ("mexico_10m.geojson", None), ("countries_10m.geojson", 40)],
)
def test_rings_of_real_borders_bit_for_bit(path, limit):
    rings, ext = ring_list(path, limit)
    assert_same(rings, ext)
    assert_same(rings, [not e for e in ext])  # every ring turned the other way


def test_rings_that_take_the_ring_by_ring_path():
    square = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0], [0.0, 0.0]])
    rings = [
        square,
        np.array([[0.0, 0.0], [10.0, 0.0], [5.0, 5.0]]),  # 3 rows, not closed
        np.array([[-180.0, -90.0], [180.0, -90.0], [180.0, 90.0], [-180.0, 90.0]]),  # meridians
        np.array([[0.0, 80.0], [120.0, 80.0], [-120.0, 80.0], [0.0, 80.0]]),  # round a pole
        np.array([[0.0, 80.0], [0.0, 90.0], [90.0, 80.0], [0.0, 80.0]]),  # through a pole
        np.array([[10.0, 60.0], [-170.0, 70.0], [-160.0, 50.0], [10.0, 60.0]]),  # over one
        np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 1e-15], [0.5, 1.0], [0.0, 0.0]]),
        np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [1.0, 0.0]]),  # no area
        square[::-1] + 20.0,
    ]
    assert_same(rings, [True] * len(rings))
    assert_same(rings, [False] * len(rings))


BAD = {
    "not finite": np.array([[0.0, 0.0], [1.0, np.nan], [1.0, 1.0], [0.0, 1.0]]),
    "latitude": np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 91.0], [0.0, 1.0]]),
    "longitude": np.array([[0.0, 0.0], [181.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
    "distinct points": np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 0.0]]),
    "antipodal": np.array([[0.0, 0.0], [180.0, 0.0], [90.0, 10.0], [0.0, 0.0]]),
    "infinite": np.array([[0.0, 0.0], [np.inf, 0.0], [1.0, 1.0], [0.0, 1.0]]),
}


@pytest.mark.parametrize("kind", sorted(BAD))
def test_the_first_bad_ring_is_named_as_ring_by_ring(kind):
    rings, ext = ring_list("mexico_10m.geojson")
    second = BAD["latitude" if kind != "latitude" else "longitude"]
    rings = rings[:3] + [BAD[kind]] + rings[3:5] + [second]
    ext = ext[:3] + [True] + ext[3:5] + [True]
    labels = [f"feature {k}" for k in range(len(rings))]
    with pytest.raises(InvalidGeometryError) as want:
        for r, lab, e in zip(rings, labels, ext):
            prepare_ring(r, lab, e)
    with pytest.raises(InvalidGeometryError) as got:
        prepare_rings(rings, labels, ext)
    assert str(got.value) == str(want.value)
    assert "feature 3" in str(got.value)


def test_read_names_the_bad_vertex():
    doc = {
        "type": "MultiPolygon",
        "coordinates": [
            [[[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]],
            [[[20, 0], [30, 0], [-150, 0], [20, 10], [20, 0]]],
        ],
    }
    with pytest.raises(InvalidGeometryError, match="polygon 1 ring 0 vertices 1 and 2"):
        gloffset.read(doc)


def test_equal_rows_are_the_groups_of_equal_rows():
    from gloffset.geometry.arrangement import equal_rows, row_keys

    rng = np.random.default_rng(0)
    base = rng.normal(size=(300, 6))
    base[::7, 2] = 0.0
    rows = base[rng.integers(0, len(base), 5000)]
    rows[::3, 2] *= -1.0  # -0.0 where the value is 0.0: the same row
    rows[1::5, 4] = np.nextafter(rows[1::5, 4], np.inf)  # 1 ulp apart: another row
    for v in (rows, rows[:, :3]):
        inv, counts = equal_rows(v)
        _, want_inv, want_counts = np.unique(row_keys(v), return_inverse=True, return_counts=True)
        pairs = set(zip(inv.tolist(), want_inv.reshape(-1).tolist()))
        assert len(pairs) == len(counts) == len(want_counts)  # the same partition
        assert np.array_equal(counts[inv], want_counts[want_inv.reshape(-1)])


def test_reading_leaves_the_garbage_collector_as_it_was():
    import gc

    from gloffset.errors import InputFormatError

    was = gc.isenabled()
    try:
        for enabled in (True, False):
            (gc.enable if enabled else gc.disable)()
            gj.load('{"type": "Point", "coordinates": [1, 2]}')
            assert gc.isenabled() == enabled
            with pytest.raises(InputFormatError):
                gj.load('{"type": "Point", "coordinates": [1, 2')
            assert gc.isenabled() == enabled
            gloffset.read(DATA / "mexico_10m.geojson")
            assert gc.isenabled() == enabled
            with pytest.raises(InputFormatError):
                gloffset.read({"type": "Polygon", "coordinates": [[[0, 0], [1, "x"]]]})
            assert gc.isenabled() == enabled
    finally:
        (gc.enable if was else gc.disable)()
