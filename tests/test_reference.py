"""The float64 reference against an independent library (spherely, on S2) and brute force."""

import numpy as np
import pytest
import spherely
from conftest import uniform_sphere
from spherely_ref import boundary, points, polygons

import gloffset
from gloffset import reference
from gloffset.geometry.sphere import arc_distance, lonlat_to_xyz, slerp

N = 100_000
LON, LAT = uniform_sphere(N, seed=1)
PTS = spherely.points(LON, LAT)

# Natural Earth 110m draws Sudan with an edge crossing another one; S2 rejects it as a
# polygon, so its inside test is checked against brute-force crossing counts instead.
S2_INVALID = {"Sudan"}


def brute_inside(shape, lon, lat):
    """Ray parity against every ring edge with a slow per-point loop (no shortcuts)."""
    from gloffset.geometry.sphere import arcs_cross

    p = lonlat_to_xyz(lon, lat)
    refs, status = shape.reference_points()
    e = shape.edges()
    out = np.zeros(len(p), dtype=bool)
    for i in range(len(p)):
        k = 0 if p[i] @ refs[0] >= -0.5 else 1
        for g in range(shape.n_groups):
            sel = e.group == g
            par = np.count_nonzero(arcs_cross(p[i], refs[k], e.a[sel], e.b[sel])) % 2
            out[i] |= bool(status[k, g] ^ par)
    return out


@pytest.mark.slow
def test_contains_matches_spherely_for_every_country(world):
    bad = {}
    for name, feat in world.items():
        shape = gloffset.read(feat)
        ours = reference.contains_lonlat(shape, LON, LAT)
        if name in S2_INVALID:
            sel = np.flatnonzero(ours | (gloffset.distance(shape, LON, LAT, radius=1) < 0.05))
            theirs = ours.copy()
            theirs[sel] = brute_inside(shape, LON[sel], LAT[sel])
        else:
            theirs = np.zeros(N, dtype=bool)
            for poly in polygons(shape):
                spherely.prepare(poly)
                theirs |= spherely.contains(poly, PTS)
        if (ours != theirs).any():
            bad[name] = int((ours != theirs).sum())
    assert not bad


@pytest.mark.slow
@pytest.mark.parametrize("n", [N])
def test_distance_matches_spherely_for_every_country(world, n):
    worst = 0.0
    # every country on a share of the points, the antimeridian/pole cases on all of them
    for name, feat in world.items():
        m = n if name in ("Fiji", "Russia", "Antarctica", "Canada") else n // 10
        shape = gloffset.read(feat)
        ours = gloffset.distance(shape, LON[:m], LAT[:m], radius=1.0)
        theirs = spherely.distance(boundary(shape), PTS[:m], radius=1.0)
        worst = max(worst, float(np.abs(ours - theirs).max()))
    assert worst < 1e-12


def test_distance_is_exact_brute_force_minimum(world):
    """The shortcut (nearest vertex, edge caps) gives exactly the brute-force minimum."""
    shape = gloffset.read(world["Chile"])
    lon, lat = uniform_sphere(3000, seed=5)
    p = lonlat_to_xyz(lon, lat)
    e = shape.edges()
    brute = arc_distance(p[:, None, :], e.a[None], e.b[None]).min(axis=1)
    assert np.array_equal(reference.distance_xyz(shape, p), brute)


def test_points_near_the_boundary(world):
    """Points 1e-7 rad either side of real borders, across the antimeridian and at the pole."""
    for name in ("Fiji", "Russia", "Antarctica", "Mexico"):
        shape = gloffset.read(world[name])
        e = shape.edges()
        rng = np.random.default_rng(3)
        k = rng.integers(0, len(e.a), 400)
        mid = slerp(e.a[k], e.b[k], rng.uniform(0.2, 0.8, len(k)))
        n = np.cross(e.a[k], e.b[k])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        for side in (1.0, -1.0):
            p = mid + side * 1e-7 * n
            p /= np.linalg.norm(p, axis=1, keepdims=True)
            lon, lat = np.degrees(np.arctan2(p[:, 1], p[:, 0])), np.degrees(np.arcsin(p[:, 2]))
            ours = reference.contains_lonlat(shape, lon, lat)
            theirs = np.zeros(len(p), dtype=bool)
            for poly in polygons(shape):
                theirs |= spherely.contains(poly, points(lon, lat))
            assert np.array_equal(ours, theirs), name
            # interior is on the left of every edge
            assert ours.all() if side > 0 else not ours.any()


@pytest.mark.parametrize("d", [0.01, -0.004])
def test_offset_membership_definition(world, d):
    shape = gloffset.read(world["Italy"])
    lon, lat = uniform_sphere(20000, seed=2)
    lon = 12 + (lon / 180) * 15
    lat = 42 + (lat / 90) * 12
    ins = reference.contains_lonlat(shape, lon, lat)
    dist = gloffset.distance(shape, lon, lat, radius=1.0)
    got = reference.contains_lonlat(shape, lon, lat, distance=d, radius=1.0)
    want = (ins | (dist <= d)) if d > 0 else (ins & (dist > -d))
    assert np.array_equal(got, want)
    assert got.any() and (~got).any()


def test_lines_and_radius():
    s = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [10, 0]]})
    assert gloffset.distance(s, 5.0, 1.0) == pytest.approx(np.radians(1) * gloffset.EARTH_RADIUS)
    assert gloffset.distance(s, 5.0, 1.0, radius=1.0) == pytest.approx(np.radians(1))
    assert reference.contains_lonlat(s, 5.0, 0.9, distance=1.0, radius=180 / np.pi)
    assert not reference.contains_lonlat(s, 5.0, 0.9, distance=-1.0, radius=180 / np.pi)
    got = reference.contains_lonlat(
        s, [[5.0, 5.0]], [[0.5], [2.0]], distance=1.0, radius=180 / np.pi
    )
    assert got.shape == (2, 2) and got.tolist() == [[True, True], [False, False]]


def test_query_errors():
    s = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [10, 0]]})
    with pytest.raises(gloffset.InvalidGeometryError, match="not finite"):
        gloffset.distance(s, [0.0, np.nan], [0.0, 0.0])
    with pytest.raises(gloffset.InvalidGeometryError, match="out of range"):
        reference.contains_lonlat(s, 0.0, 100.0)
    with pytest.raises(gloffset.InvalidGeometryError, match="broadcast"):
        reference.contains_lonlat(s, [1.0, 2.0], [1.0, 2.0, 3.0])


def test_chunking_gives_the_same_answer(monkeypatch):
    s = gloffset.read({"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 10], [0, 0]]]})
    lon, lat = uniform_sphere(5000, seed=9)
    full = reference.contains_lonlat(s, lon, lat, distance=1e5)
    monkeypatch.setattr(reference, "_PAIRS", 7)
    from gloffset.geometry import crossings

    monkeypatch.setattr(crossings, "_PAIRS", 5)
    assert np.array_equal(full, reference.contains_lonlat(s, lon, lat, distance=1e5))
    assert full.any() and not full.all()
