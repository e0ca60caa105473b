"""The indexed inside test gives the answers of the all-edges crossing parity."""

import json

import numpy as np
import pytest
from conftest import DATA, SQUARE_WITH_HOLE, uniform_sphere

import gloffset
from gloffset.geometry import crossings
from gloffset.geometry.sphere import lonlat_to_xyz, normalize


def _points(shape, n=4000, seed=0):
    """Uniform points and points 1e-7 rad off the shape's vertices (generic, near edges)."""
    rng = np.random.default_rng(seed)
    lon, lat = uniform_sphere(n, seed=seed)
    v = np.concatenate(shape.rings)
    near = normalize(v[rng.integers(0, len(v), n)] + 1e-7 * rng.normal(size=(n, 3)))
    return np.vstack([lonlat_to_xyz(lon, lat), near])


def _shapes():
    world = json.loads((DATA / "world_110m.geojson").read_text())
    yield gloffset.read(world)
    yield gloffset.read(DATA / "mexico_10m.geojson")
    yield gloffset.read(SQUARE_WITH_HOLE)
    (antarctica,) = [f for f in world["features"] if f["properties"]["name"] == "Antarctica"]
    yield gloffset.read(antarctica)


@pytest.mark.slow  # 3 s; run by .ci/run with -m slow
def test_inside_indexed_equals_inside():
    for shape in _shapes():
        p = _points(shape)
        want = crossings.inside(shape, p)
        assert np.array_equal(crossings.inside_indexed(shape, p), want)
        assert want.any() and not want.all()
        # from the nearest of a few start points with known status: short arcs
        for n in (1, 64, 256):
            assert np.array_equal(crossings.inside_indexed(shape, p, anchors=n), want)


def test_inside_indexed_groups_and_skip():
    shape = gloffset.read(json.loads((DATA / "world_110m.geojson").read_text()))
    p = _points(shape, 1500, seed=3)
    rng = np.random.default_rng(4)
    some = rng.choice(shape.n_groups, 40, replace=False)
    want = crossings.inside(shape, p, groups=some)
    assert want.any()
    assert np.array_equal(crossings.inside_indexed(shape, p, groups=some), want)
    assert np.array_equal(crossings.inside_indexed(shape, p, groups=some, anchors=64), want)
    # skip: one component per point left out
    skip = rng.integers(0, shape.n_groups, len(p))
    got = crossings.inside_indexed(shape, p, skip=skip)
    for k in rng.choice(len(p), 60, replace=False).tolist():
        others = [g for g in range(shape.n_groups) if g != skip[k]]
        assert got[k] == crossings.inside(shape, p[k : k + 1], groups=others)[0]


def test_inside_indexed_empty():
    line = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [10, 5]]})
    assert not crossings.inside_indexed(line, lonlat_to_xyz([0.0], [1.0])).any()
    shape = gloffset.read(SQUARE_WITH_HOLE)
    assert crossings.inside_indexed(shape, np.zeros((0, 3))).shape == (0,)


def test_component_status_is_the_judges_inside_test():
    """``edges.component_status`` (the ring edges along each point's arc to its
    reference, from their cap tree) says inside exactly where the float64 judge does, on
    the world's borders (Fiji and Russia across 180 deg, Antarctica round the pole) and
    Mexico at 1:10m; points on the seam and at the poles included."""
    from gloffset import reference
    from gloffset.edges import CurveArcs, component_status, inside_any

    seams = lonlat_to_xyz(
        np.array([180.0, -180.0, 179.999, -179.999, 178.4, 0.0, 0.0, 45.0]),
        np.array([65.0, 68.5, -17.0, -16.5, -18.1, 90.0, -90.0, -89.9]),
    )
    for shape in list(_shapes())[:2]:
        p = np.vstack([_points(shape, n=1500, seed=3), seams])
        got = inside_any(component_status(shape, CurveArcs.from_shape(shape), p))
        want = reference.inside_xyz(shape, p)
        assert np.array_equal(got, want)
        assert want.any() and not want.all()
