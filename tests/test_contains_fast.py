"""The fast inside/outside index (paper Sec. 4.3) against the float64 reference (the judge)."""

import importlib

import numpy as np
import pytest
from conftest import uniform_sphere

import gloffset
from gloffset import InvalidGeometryError, InvalidLevelError, reference
from gloffset.geometry.sphere import (
    angle,
    arc_distance,
    lonlat_to_xyz,
    normalize,
    robust_cross,
    rotate,
    slerp,
    xyz_to_lonlat,
)

tree = importlib.import_module("gloffset.index.tree")
arcs = importlib.import_module("gloffset.index.arcs")

N = 20_000
LON, LAT = uniform_sphere(N, seed=21)
# antimeridian, pole, large, intricate and holed shapes
HARD = ["Fiji", "Russia", "Antarctica", "Canada", "Chile", "Indonesia", "Italy", "Sudan"]


def near_curves(shape, offset, n=400, seed=0, min_length=0.0):
    """Points ``offset`` rad to the left (> 0) or right (< 0) of random boundary edges,
    each a random 1e-9 nearer or farther (``offset = +-2e-9``: 1e-9 or 3e-9 off the edge)."""
    rng = np.random.default_rng(seed)
    e = shape.edges()
    long_enough = np.flatnonzero(angle(e.a, e.b) >= min_length)
    k = long_enough[rng.integers(0, len(long_enough), n)]
    mid = slerp(e.a[k], e.b[k], rng.uniform(0.2, 0.8, n))
    normal = normalize(robust_cross(e.a[k], e.b[k]))
    up = normalize(np.cross(mid, normal))  # axis turning mid towards the normal
    step = offset + rng.choice([-1e-9, 1e-9], n)
    return xyz_to_lonlat(rotate(mid, up, step))


def box(shape, n, seed, margin=3.0):
    """Points uniform in lon/lat around the shape."""
    rng = np.random.default_rng(seed)
    lon, lat = xyz_to_lonlat(np.vstack(shape.rings + shape.lines))
    w, e = lon.min() - margin, lon.max() + margin
    s, nn = max(lat.min() - margin, -90.0), min(lat.max() + margin, 90.0)
    return rng.uniform(w, e, n), rng.uniform(s, nn, n)


def assert_matches_reference(shape, lon, lat, d, **kw):
    got = gloffset.contains(shape, lon, lat, distance=d, radius=1.0, **kw)
    want = reference.contains_lonlat(shape, lon, lat, distance=d, radius=1.0)
    assert np.array_equal(got, want), int((got != want).sum())
    return got


@pytest.mark.slow  # 7-25 s on 2 cores: run by .ci/run with -m slow
def test_every_country_inside_outside(world):
    """d = 0: random points on the globe and points 1e-9 rad either side of the borders."""
    for name, feat in world.items():
        s = gloffset.read(feat)
        # edges of at least 1 micro-radian: 3e-9 off a shorter one may pass its neighbour
        lon1, lat1 = near_curves(s, 2e-9, seed=1, min_length=1e-6)
        lon2, lat2 = near_curves(s, -2e-9, seed=2, min_length=1e-6)
        lon3, lat3 = near_curves(s, 2e-9, seed=3)
        lon = np.r_[LON, lon1, lon2, lon3]
        lat = np.r_[LAT, lat1, lat2, lat3]
        got = assert_matches_reference(s, lon, lat, 0.0)
        if name != "Sudan":  # Natural Earth draws Sudan with crossing edges
            # the interior is on the left of every edge
            assert got[N : N + 400].all() and not got[N + 400 : N + 800].any(), name


@pytest.mark.parametrize("d", [0.01, -0.003, pytest.param(0.2, marks=pytest.mark.slow)])
def test_offset_regions_of_hard_countries(world, d):
    """d != 0: global, local and points within 1e-9 of the boundary and of the distance d."""
    for name in HARD:
        s = gloffset.read(world[name])
        lon1, lat1 = box(s, 5000, seed=3)
        lon2, lat2 = near_curves(s, 2e-9 if d > 0 else -2e-9, seed=4)
        lon3, lat3 = near_curves(s, -d, seed=5)  # outside for d > 0, inside for d < 0
        lon = np.r_[LON[:5000], lon1, lon2, lon3]
        lat = np.r_[LAT[:5000], lat1, lat2, lat3]
        got = assert_matches_reference(s, lon, lat, d)
        assert got.any() and not got.all()


@pytest.mark.slow  # 2.7 s; run by .ci/run with -m slow
def test_mexico_table1_points_at_every_level(mexico_path):
    """Table 1's set-up: 10,000 points in and around Mexico; the level changes no answer."""
    s = gloffset.read(mexico_path)
    rng = np.random.default_rng(0)
    lon, lat = rng.uniform(-120.0, -84.0, 10_000), rng.uniform(12.0, 35.0, 10_000)
    for d in (0.0, 0.02):
        want = reference.contains_lonlat(s, lon, lat, distance=d, radius=1.0)
        for level in range(6):
            ix = gloffset.Index(s, d, radius=1.0, level=level, depth=10)
            assert ix.level == level
            assert np.array_equal(ix.contains(lon, lat), want), level


@pytest.mark.slow  # 2.3 s; run by .ci/run with -m slow
def test_levels_and_depths_change_no_answer(world):
    s = gloffset.read(world["Chile"])
    lon, lat = box(s, 20_000, seed=6)
    for d in (0.0, 0.004, -0.002):
        want = reference.contains_lonlat(s, lon, lat, distance=d, radius=1.0)
        for level, depth in [(0, 3), (0, 12), (2, 8), (4, 11), (9, 9), (None, 6)]:
            ix = gloffset.Index(s, d, radius=1.0, level=level, depth=depth)
            assert np.array_equal(ix.contains(lon, lat), want), (d, level, depth)


SEAMED = {
    "type": "Polygon",
    "coordinates": [[[170, 0], [180, 0], [180, 5], [180, 10], [170, 10], [170, 0]]],
}


@pytest.mark.parametrize("d", [0.0, 0.03, -0.01, 2.0, -1.0, 3.5])
def test_lines_points_seams_and_large_distances(d):
    s = gloffset.read(
        {
            "type": "GeometryCollection",
            "geometries": [
                SEAMED,
                {"type": "LineString", "coordinates": [[0, 0], [5, 3], [10, 0], [15, 3]]},
                {"type": "MultiPoint", "coordinates": [[40, 40], [-60, -30]]},
                {
                    "type": "Polygon",
                    "coordinates": [
                        [[-20, -20], [-5, -20], [-5, -5], [-20, -5], [-20, -20]],
                        [[-15, -15], [-15, -10], [-10, -10], [-10, -15], [-15, -15]],
                    ],
                },
            ],
        }
    )
    lon1, lat1 = near_curves(s, -abs(d) if abs(d) < 1 else 2e-9, seed=7)
    lon2, lat2 = box(s, 4000, seed=8)
    assert_matches_reference(s, np.r_[LON[:8000], lon1, lon2], np.r_[LAT[:8000], lat1, lat2], d)


def test_poles_and_the_antimeridian(world):
    """Points exactly at the poles, on +-180 deg and beyond it (longitudes wrap)."""
    s = gloffset.read(world["Antarctica"])
    lon = np.array([0.0, 77.0, -180.0, 180.0, 540.0, -200.0, 160.0, 179.999999999])
    lat = np.array([-90.0, -90.0, -85.0, -85.0, -85.0, -70.0, -70.0, -80.0])
    for d in (0.0, 0.01, -0.01):
        assert_matches_reference(s, lon, lat, d)
    north = gloffset.read(world["Russia"])
    assert_matches_reference(
        north, np.array([0.0, 180.0, -180.0]), np.array([90.0, 65.0, 65.0]), 0.0
    )


def test_eq9_matches_the_exact_distance():
    """The error-region test (Eq. 9) agrees with arc_distance <= r away from ties."""
    rng = np.random.default_rng(9)
    n = 20_000
    a = normalize(rng.normal(size=(n, 3)))
    b = normalize(a + 10 ** rng.uniform(-6, 0, (n, 1)) * rng.normal(size=(n, 3)))
    p = normalize(a + 10 ** rng.uniform(-7, 0.3, (n, 1)) * rng.normal(size=(n, 3)))
    r = 10 ** rng.uniform(-8, 0.5, n)
    nrm = normalize(robust_cross(a, b))
    g = np.hstack([a, b, nrm, np.cross(nrm, a), np.cross(b, nrm)])
    chord2, sin_r = arcs.radius_terms(r, np.zeros(n, dtype=bool))
    got = arcs.within(p, g, chord2, sin_r)
    dist = arc_distance(p, a, b, nrm)
    clear = np.abs(dist - r) > 1e-14
    assert np.array_equal(got[clear], (dist <= r)[clear])
    assert got.any() and not got.all()


def test_index_api_and_cache(world):
    s = gloffset.read(world["Italy"])
    lon, lat = box(s, 3000, seed=10)
    a = gloffset.contains(s, lon, lat, distance=50e3)
    cache = s.derived.contains_indexes
    ix = cache[(50e3 / gloffset.EARTH_RADIUS, None)]
    b = gloffset.contains(s, lon[:10], lat[:10], distance=50e3)
    assert cache[(50e3 / gloffset.EARTH_RADIUS, None)] is ix  # reused
    assert np.array_equal(a[:10], b)
    # a later, larger call rebuilds deeper bins; the answers stay the same
    big_lon, big_lat = np.resize(lon, 400_000), np.resize(lat, 400_000)
    c = gloffset.contains(s, big_lon, big_lat, distance=50e3)
    assert cache[(50e3 / gloffset.EARTH_RADIUS, None)].depth > ix.depth
    assert np.array_equal(c[: len(lon)], a)
    # the prepared object, unit-vector queries and broadcasting
    prepared = gloffset.Index(s, 50e3)
    assert np.array_equal(prepared.contains(lon, lat), a)
    assert np.array_equal(prepared.contains_xyz(lonlat_to_xyz(lon, lat)), a)
    grid = prepared.contains(lon[:7][None, :], lat[:3][:, None])
    assert grid.shape == (3, 7)
    assert grid.tolist() == prepared.contains(*np.broadcast_arrays(lon[:7], lat[:3, None])).tolist()
    assert "frontier cells" in repr(prepared)


def test_query_and_level_errors():
    s = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [10, 0]]})
    for args, words in [
        (([0.0, np.nan], [0.0, 0.0]), "not finite"),
        ((0.0, 100.0), "out of range"),
        (([1.0, 2.0], [1.0, 2.0, 3.0]), "broadcast"),
    ]:
        with pytest.raises(InvalidGeometryError, match=words):
            gloffset.contains(s, *args, distance=1e3)
    with pytest.raises(InvalidLevelError):
        gloffset.contains(s, 0.0, 0.0, distance=1e3, level=-1)
    with pytest.raises(InvalidLevelError):
        gloffset.Index(s, 1e3, level=1.5)
    with pytest.raises(InvalidLevelError):
        gloffset.Index(s, 1e3, depth=0)
    # lines bound no region: zero and negative distances are refused, not empty
    for d in (0.0, -1e3):
        with pytest.raises(gloffset.InvalidDistanceError, match="no polygon"):
            gloffset.contains(s, 0.0, 0.0, distance=d)
    with pytest.raises(gloffset.InvalidDistanceError):
        gloffset.contains(s, 0.0, 0.0, distance=np.inf)
    # a level beyond the shape's last is its last
    assert gloffset.Index(s, 1e5, level=30).level == gloffset.Index(s, 1e5, level=5).level


def test_short_edges_keep_their_side(world):
    """Chile (Natural Earth 110m) has a 1.4e-8 rad edge: a point 1e-9 rad to its left is
    inside, in the reference too (whose edge normals come from the robust cross product;
    the plain one put this point outside)."""
    s = gloffset.read(world["Chile"])
    lon, lat = np.array([-73.70275681550596]), np.array([-52.83506970141735])
    assert reference.distance(s, lon, lat, radius=1.0)[0] < 1.01e-9
    assert reference.contains_lonlat(s, lon, lat).tolist() == [True]
    assert gloffset.contains(s, lon, lat).tolist() == [True]


def test_row_kernels_are_numpy_bit_for_bit():
    from gloffset.geometry.sphere import cross, dot, norm

    rng = np.random.default_rng(12)
    u, v = rng.normal(size=(1000, 3)), rng.normal(size=(1000, 3))
    assert np.array_equal(dot(u, v), np.sum(u * v, axis=-1))
    assert np.array_equal(cross(u, v), np.cross(u, v))
    assert np.array_equal(norm(u), np.linalg.norm(u, axis=-1))
    assert dot([1.0, 2.0, 3.0], [1.0, 1.0, 1.0]) == 6.0


def test_overlapping_features_are_united():
    """Overlapping and nested features: the fast path unites them like the reference."""
    sq = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]
    fc = {
        "type": "FeatureCollection",
        "features": [
            {
                "type": "Feature",
                "properties": {},
                "geometry": {"type": "Polygon", "coordinates": [c]},
            }
            for c in (
                sq,
                [[5, 5], [15, 5], [15, 15], [5, 15], [5, 5]],  # crosses the first
                [[2, 2], [4, 2], [4, 4], [2, 4], [2, 2]],  # nested in the first
            )
        ],
    }
    shape = gloffset.read(fc)
    # united on reading: one ring around both squares, the nested one gone
    assert len(shape.rings) == 1 and len(shape.rings[0]) == 8
    assert len(shape.overlapping_components()) == 0
    rng = np.random.default_rng(3)
    lon, lat = rng.uniform(-5, 20, 20000), rng.uniform(-5, 20, 20000)
    for d in (0.0, 50e3, -50e3):
        fast = gloffset.contains(shape, lon, lat, distance=d)
        ref = gloffset.reference.contains_lonlat(shape, lon, lat, distance=d)
        assert np.array_equal(fast, ref), d
    assert gloffset.contains(shape, [7.0, 3.0], [7.0, 3.0]).all()  # overlap and nest


def test_touching_countries_do_not_count_as_overlapping(world):
    fc = {
        "type": "FeatureCollection",
        "features": [world["France"], world["Spain"], world["Italy"]],
    }
    assert len(gloffset.read(fc).overlapping_components()) == 0


@pytest.mark.parametrize("budget", [1 << 8, 1 << 11])
def test_cell_budget_keeps_simplified_arcs_and_every_answer(world, monkeypatch, budget):
    """A long boundary stops the default depth at the cell budget, and leaves with many
    arcs keep simplified ones (levels up to ``floor``); every answer is still the
    reference's, on the borders as read and densified tenfold, near the curves and
    around them."""
    s = gloffset.read(world["Chile"])
    dense = gloffset.read(
        {"type": "Polygon", "coordinates": [_densified(r, 10) for r in s.rings]}
        if len(s.rings) == 1
        else {"type": "MultiPolygon", "coordinates": [[_densified(r, 10)] for r in s.rings]}
    )
    monkeypatch.setattr(tree, "BUILD_CELLS", budget)
    monkeypatch.setattr(tree, "LEAF_PAIRS", 2)
    floors = []
    for shape in (s, dense):
        lon, lat = box(shape, 6000, seed=8)
        nl, nt = near_curves(shape, 2e-9, n=300, seed=9)
        lon, lat = np.r_[lon, nl], np.r_[lat, nt]
        for d in (0.0, 0.004, -0.002):
            ix = gloffset.Index(shape, d, radius=1.0)
            assert ix.depth < tree.DEFAULT_DEPTH, ix.depth
            floors.append(ix.floor)
            want = reference.contains_lonlat(shape, lon, lat, distance=d, radius=1.0)
            assert np.array_equal(ix.contains(lon, lat), want), (budget, d)
    assert max(floors) > 0, floors


def _densified(ring_xyz, k):
    """A ring (unit vectors, closed) as lon/lat with ``k - 1`` points added on each edge."""
    t = np.arange(k) / k
    pts = slerp(
        ring_xyz[:-1, None, :], ring_xyz[1:, None, :], np.broadcast_to(t, (len(ring_xyz) - 1, k))
    )
    pts = np.vstack([pts.reshape(-1, 3), ring_xyz[-1:]])
    lon, lat = xyz_to_lonlat(pts)
    return np.column_stack([lon, lat]).tolist()


def _spiked_square(k=40):
    """A 10 x 10 degree square, its edges densified (``k`` points each), with a needle
    0.02 degrees wide and 3 degrees long on its east side: a detail that every coarse
    level of the decomposition cuts off."""
    t = np.linspace(0.0, 10.0, k, endpoint=False)
    south = [[x, 0.0] for x in t]
    east = [[10.0, y] for y in t if y < 4.99 or y > 5.01]
    i = next(j for j, p in enumerate(east) if p[1] > 5.0)
    needle = [[10.0, 4.99], [11.5, 4.99], [13.0, 4.99], [13.0, 5.01], [11.5, 5.01], [10.0, 5.01]]
    east = east[:i] + needle + east[i:]
    north = [[10.0 - x, 10.0] for x in t]
    west = [[0.0, 10.0 - y] for y in t]
    ring = south + east + north + west
    return {"type": "Polygon", "coordinates": [ring + [ring[0]]]}


@pytest.mark.parametrize("d", [0.0, 0.001, -0.0005])
def test_simplified_leaves_keep_a_detail_the_coarse_levels_miss(monkeypatch, d):
    """With leaves of simplified arcs (small budgets, ``floor > 0``), points in and
    beside a needle that the coarse levels cut off get the reference's answer: the
    arcs' error bounds widen every test that uses a simplified arc."""
    s = gloffset.read(_spiked_square())
    monkeypatch.setattr(tree, "BUILD_CELLS", 1 << 6)
    monkeypatch.setattr(tree, "LEAF_PAIRS", 1)
    ix = gloffset.Index(s, d, radius=1.0)
    assert ix.floor > 0
    rng = np.random.default_rng(3)
    lon = np.r_[rng.uniform(9.5, 13.5, 20_000), rng.uniform(0.0, 10.0, 2000)]
    lat = np.r_[rng.uniform(4.9, 5.1, 20_000), rng.uniform(0.0, 10.0, 2000)]
    want = reference.contains_lonlat(s, lon, lat, distance=d, radius=1.0)
    assert np.array_equal(ix.contains(lon, lat), want)
