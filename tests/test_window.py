"""The boundary inside one cap (:func:`gloffset.vector.window.boundary_within`): the
resolved boundary's arcs inside the cap, as closed rings and chains that end on the
cap's circle, on real borders (Mexico's coast, Fiji across the antimeridian)."""

from __future__ import annotations

import numpy as np
import pytest

import gloffset
from gloffset.edges import distance_xyz, points_inside
from gloffset.geometry.sphere import angle
from gloffset.units import EARTH_RADIUS
from gloffset.vector.arcrings import sample_arc
from gloffset.vector.offset import Offset
from gloffset.vector.window import boundary_within


def _cap(lon, lat, radius_km):
    lon, lat = np.radians(lon), np.radians(lat)
    c = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    return c, radius_km / (EARTH_RADIUS / 1e3)


def _chain_points(chains, per_arc=24):
    pts = []
    t = np.linspace(0.0, 1.0, per_arc)
    for q, s, e, _ in chains:
        k = np.repeat(np.arange(len(q)), per_arc)
        p = sample_arc(q[k], s[k], e[k], np.tile(t, len(q)))
        pts.append(p / np.linalg.norm(p, axis=1, keepdims=True))
    return np.vstack(pts) if pts else np.zeros((0, 3))


def _nearest(a, b):
    """Angle from each point of ``a`` to the nearest of ``b``."""
    out = np.empty(len(a))
    for s in range(0, len(a), 512):
        dots = a[s : s + 512] @ b.T
        out[s : s + 512] = np.arccos(np.clip(dots.max(axis=1), -1.0, 1.0))
    return out


@pytest.mark.parametrize(
    "which,d_km,cap",
    [
        ("mexico", 60.0, (-105.5, 21.0, 150.0)),  # the Pacific coast near Puerto Vallarta
        ("mexico", -40.0, (-87.5, 20.5, 200.0)),  # Yucatan, inward
        ("mexico", 127.0, (-112.0, 27.5, 400.0)),  # the Gulf of California: both coasts
        ("fiji", 80.0, (180.0, -17.0, 300.0)),  # across the antimeridian
    ],
)
def test_boundary_within_is_the_resolved_boundary_inside_the_cap(which, d_km, cap, world):
    shape = gloffset.read("data/mexico_10m.geojson" if which == "mexico" else world["Fiji"])
    d = d_km / (EARTH_RADIUS / 1e3)
    c, r = _cap(*cap)
    chains = boundary_within(Offset(shape, d), (c, r))
    assert chains
    got = _chain_points(chains)
    # on the cap (to rounding) and at |d| from the curves
    assert np.all(angle(got, np.broadcast_to(c, got.shape)) <= r + 1e-12)
    assert np.max(np.abs(distance_xyz(shape, got) - abs(d))) < 1e-9
    # open chains start and end on the cap's circle
    for _q, s, e, closed in chains:
        if not closed:
            for p in (s[0], e[-1]):
                assert abs(angle(p, c) - r) < 1e-9
    # the whole offset's boundary inside the cap (less a rim) is covered, and vice versa
    ref = np.vstack(Offset(shape, d).resolve().sample(1e-5))
    inner = ref[angle(ref, np.broadcast_to(c, ref.shape)) < r - 1e-4]
    assert len(inner) > 20
    dense = _chain_points(chains, per_arc=400)
    assert np.max(_nearest(inner, dense)) < 2e-5
    # and every point of the chains is on the boundary: at |d| and outside the polygons
    # (d > 0) or inside them (d < 0)
    assert np.all(points_inside(shape, got) == (d < 0))


def test_region_on_the_left(world):
    # a point just left of a chain's arc lies inside the region (d > 0: within d)
    shape = gloffset.read("data/mexico_10m.geojson")
    d = 60.0 / (EARTH_RADIUS / 1e3)
    c, r = _cap(-105.5, 21.0, 150.0)
    for q, s, e, _ in boundary_within(Offset(shape, d), (c, r)):
        m = sample_arc(q, s, e, np.full(len(q), 0.5))
        m /= np.linalg.norm(m, axis=1, keepdims=True)
        left = np.cross(m, e - s)
        left /= np.linalg.norm(left, axis=1, keepdims=True)
        inside = distance_xyz(shape, m + 1e-6 * left) < d
        assert inside.mean() > 0.99
