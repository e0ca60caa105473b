"""What ``gloffset.distance`` and ``gloffset.contains`` return for empty and scalar input:
an empty array for empty input, a Python float (as numpy's ufuncs give a scalar) for a
scalar point, arrays of the broadcast shape otherwise."""

import numpy as np
import pytest
from conftest import DATA

import gloffset


@pytest.fixture(scope="module")
def mexico():
    return gloffset.read(DATA / "mexico_10m.geojson")


@pytest.mark.parametrize("distance", [0.0, 50e3, -20e3])
def test_contains_of_no_points_is_empty(mexico, distance):
    out = gloffset.contains(mexico, [], [], distance=distance)
    assert out.dtype == bool and out.shape == (0,)
    out = gloffset.Index(mexico, distance).contains(np.empty(0), np.empty(0))
    assert out.dtype == bool and out.shape == (0,)


def test_contains_of_no_points_on_the_ellipsoid(mexico):
    out = gloffset.contains(mexico, [], [], distance=10e3, ellipsoid="WGS84")
    assert out.dtype == bool and out.shape == (0,)


@pytest.mark.parametrize("ellipsoid", [None, "WGS84"])
def test_distance_of_a_scalar_is_a_float(mexico, ellipsoid):
    d = gloffset.distance(mexico, -100.0, 30.0, ellipsoid=ellipsoid)
    assert type(d) is float
    many = gloffset.distance(mexico, [-100.0], [30.0], ellipsoid=ellipsoid)
    assert isinstance(many, np.ndarray) and many.shape == (1,)
    assert many[0] == d
    grid = gloffset.distance(mexico, np.zeros((2, 3)), np.zeros((2, 3)), ellipsoid=ellipsoid)
    assert grid.shape == (2, 3)
    empty = gloffset.distance(mexico, [], [], ellipsoid=ellipsoid)
    assert isinstance(empty, np.ndarray) and empty.shape == (0,)
