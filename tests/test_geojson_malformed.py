"""Malformed GeoJSON gives gloffset's own errors, never a TypeError, KeyError, IndexError...

Random JSON trees, geometries with wrong types, wrong nesting depths, missing keys, empty arrays,
strings and booleans for coordinates, huge numbers and NaN literals go to ``gloffset.read`` as
Python objects and as JSON text.
"""

import json
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import gloffset
from gloffset.errors import GloffsetError, InputFormatError

TYPES = [
    "Point",
    "MultiPoint",
    "LineString",
    "MultiLineString",
    "Polygon",
    "MultiPolygon",
    "GeometryCollection",
    "Feature",
    "FeatureCollection",
]

scalars = (
    st.none()
    | st.booleans()
    | st.integers()
    | st.integers(min_value=10**300, max_value=10**320)  # too large for a float
    | st.floats()  # NaN and infinities included
    | st.text(max_size=5)
    | st.sampled_from(TYPES)
)
json_trees = st.recursive(
    scalars,
    lambda kids: (
        st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=5), kids, max_size=4)
    ),
    max_leaves=20,
)

# coordinates: mostly real positions (seams and poles included), with garbage at every depth
lons = st.floats(-180, 180) | st.integers(-180, 180) | st.sampled_from([-180, 180, 0])
lats = st.floats(-90, 90) | st.integers(-90, 90) | st.sampled_from([-90, 90, 0])
good_position = st.builds(
    lambda lon, lat, alt: [lon, lat, *alt], lons, lats, st.lists(st.floats(), max_size=1)
)
position = st.one_of(
    good_position,
    good_position,
    good_position,
    st.lists(scalars, max_size=4),
    st.tuples(st.floats(), st.floats()).map(list),
    scalars,
)
DEPTH = {
    "Point": 0,
    "MultiPoint": 1,
    "LineString": 1,
    "MultiLineString": 2,
    "Polygon": 2,
    "MultiPolygon": 3,
}


def nest(depth):
    s = position
    for _ in range(depth):
        s = st.lists(s, max_size=6) | st.lists(s, max_size=6) | scalars
    return s


def geometry_of(kind):
    right = nest(DEPTH[kind])
    return st.fixed_dictionaries(
        {
            "type": st.just(kind),
            "coordinates": st.one_of(right, right, right, st.integers(0, 4).flatmap(nest)),
        }
    )


simple = st.sampled_from(sorted(DEPTH)).flatmap(geometry_of)
odd = st.fixed_dictionaries(
    {"type": st.sampled_from(TYPES) | scalars},
    optional={
        "coordinates": st.integers(0, 4).flatmap(nest),
        "geometries": st.lists(json_trees, max_size=3),
    },
)
geometry = st.recursive(
    simple | simple | odd,
    lambda kids: st.fixed_dictionaries(
        {"type": st.just("GeometryCollection"), "geometries": st.lists(kids, max_size=3)}
    ),
    max_leaves=4,
)
# valid geometries (random vertices, seams and poles included), and the same with one part, at any
# depth, replaced by garbage
line = st.lists(good_position, min_size=2, max_size=6)
ring = st.lists(good_position, min_size=3, max_size=8).map(lambda r: [*r, r[0]])
valid = st.one_of(
    st.builds(lambda c: {"type": "Point", "coordinates": c}, good_position),
    st.builds(lambda c: {"type": "LineString", "coordinates": c}, line),
    st.builds(lambda c: {"type": "MultiLineString", "coordinates": c}, st.lists(line, max_size=3)),
    st.builds(lambda c: {"type": "Polygon", "coordinates": c}, st.lists(ring, max_size=3)),
    st.builds(
        lambda c: {"type": "MultiPolygon", "coordinates": c},
        st.lists(st.lists(ring, min_size=1, max_size=2), max_size=3),
    ),
)


def paths(obj, here=()):
    yield here
    items = (
        obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    )
    for key, sub in items:
        yield from paths(sub, (*here, key))


def replaced(obj, path, value):
    if not path:
        return value
    out = dict(obj) if isinstance(obj, dict) else list(obj)
    out[path[0]] = replaced(obj[path[0]], path[1:], value)
    return out


def mutate(doc, k, value):
    where = list(paths(doc))
    return replaced(doc, where[k % len(where)], value)


garbage = st.one_of(scalars, st.just([]), st.lists(scalars, max_size=3), good_position, json_trees)
mutated = st.builds(mutate, valid, st.integers(0, 1000), garbage)
geometry = st.one_of(geometry, valid, mutated, mutated)

feature = st.fixed_dictionaries(
    {"type": st.just("Feature") | st.just("Feature") | scalars},
    optional={
        "geometry": geometry | geometry | json_trees,
        "properties": st.dictionaries(st.sampled_from(["name", "id", "x"]), json_trees)
        | json_trees,
        "id": json_trees,
    },
)
collection = st.fixed_dictionaries(
    {"type": st.just("FeatureCollection") | scalars},
    optional={"features": st.lists(feature | feature | json_trees, max_size=4) | json_trees},
)
documents = st.one_of(geometry, geometry, feature, collection, json_trees)


def read_or_gloffset_error(obj):
    try:
        gloffset.read(obj)
    except GloffsetError:
        pass


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(documents)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_objects_give_gloffset_errors_only(doc):
    read_or_gloffset_error(doc)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(documents, st.integers(0, 3), st.booleans())
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_text_gives_gloffset_errors_only(doc, cut, huge):
    text = json.dumps(doc)  # NaN and Infinity literals included
    if huge:  # a number (or a digit in a string) of 5000 digits, beyond Python's int parsing
        text = text.replace("1", "1" + "0" * 4999, 1)
    read_or_gloffset_error(text if cut == 0 else text[: len(text) * cut // 4])  # truncated too


def test_huge_integers_in_objects():
    huge = 10**5000  # more digits than Python's int <-> str conversion allows
    for doc in (
        {"type": "Point", "coordinates": [huge, 0]},
        {"type": "Point", "coordinates": huge},
        {"type": huge},
        {"type": "Feature", "properties": {"name": huge}, "geometry": {"type": huge}},
        {"type": "Feature", "id": huge, "geometry": {"type": "Point", "coordinates": [0, 99]}},
    ):
        with pytest.raises(GloffsetError):
            gloffset.read(doc)


def test_huge_integer_is_named():
    text = '{"type": "Point",\n "coordinates": [1' + "0" * 4999 + ", 2]}"
    with pytest.raises(InputFormatError, match=r"line 2, column 18: a number with 5000 digits"):
        gloffset.read(text)


def test_strings_and_booleans_are_not_coordinates():
    for bad in (["12", "34"], "12", [True, 5], [1], [[1, 2]], {"0": 1, "1": 2}):
        with pytest.raises(InputFormatError, match="position is"):
            gloffset.read({"type": "Point", "coordinates": bad})
    with pytest.raises(InputFormatError, match=r"line 1 vertex 1: a position is"):
        gloffset.read({"type": "MultiLineString", "coordinates": [[[0, 0], [1, 1]], [[0, 0], "x"]]})
    with pytest.raises(InputFormatError, match="too large for a float"):
        gloffset.read({"type": "Point", "coordinates": [10**400, 0]})


def test_wrong_nesting_and_deep_json():
    with pytest.raises(InputFormatError, match="expected a list of lists of positions, got 5"):
        gloffset.read({"type": "Polygon", "coordinates": 5})
    with pytest.raises(InputFormatError, match="expected a list of positions, got 0"):
        gloffset.read({"type": "MultiLineString", "coordinates": [0, 1]})
    with pytest.raises(InputFormatError, match="ring 0 vertex 0: a position is .* got 0"):
        gloffset.read({"type": "Polygon", "coordinates": [[0, 0], [1, 0], [1, 1], [0, 0]]})
    with pytest.raises(InputFormatError, match="nested too deeply"):
        gloffset.read("[" * 100_000 + "]" * 100_000)
    deep = {"type": "Point", "coordinates": [0, 0]}
    for _ in range(100_000):
        deep = {"type": "GeometryCollection", "geometries": [deep]}
    with pytest.raises(InputFormatError, match="nested too deeply"):
        gloffset.read(deep)


def test_nan_literal_is_an_invalid_coordinate():
    with pytest.raises(gloffset.InvalidGeometryError, match="not finite"):
        gloffset.read('{"type": "LineString", "coordinates": [[0, 0], [NaN, 1]]}')
    assert math.isnan(json.loads("NaN"))  # the literal reaches the parser as a float
