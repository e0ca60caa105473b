"""How rings are read: rings round a pole (vertices on +-180 deg, any start and
direction), rings through a pole (an edge whose ends lie 180 deg of longitude apart, a
vertex on the pole; lon/lat and polar stereographic), rings read by their area on the
sphere, rings along the equator, rings whose edges cross each other (README, Input)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import gloffset
import gloffset.reference
from gloffset.grids import Equirect
from gloffset.region import left_area


def polygon(*rings):
    return {"type": "Polygon", "coordinates": [np.asarray(r, float).tolist() for r in rings]}


def closed(ring):
    ring = [list(map(float, p)) for p in ring]
    return ring + [ring[0]]


def variants(ring):
    """The ring (open, first vertex not repeated) from every start vertex, both ways."""
    out = []
    for r in (list(ring), list(ring)[::-1]):
        out += [closed(r[k:] + r[:k]) for k in range(len(r))]
    return out


def ring_along(lat, lons):
    return [[x, lat] for x in lons]


def test_pole_ring_with_a_vertex_on_the_antimeridian_encloses_the_pole():
    """A ring along 70 N or 60 S, from every start vertex (-180 and 180 included) and
    both ways, encloses its pole: points, the offset's area and the raster agree."""
    north = ring_along(70, range(-180, 180, 10))
    south = ring_along(-60, range(180, -180, -10))  # from 180, westward
    for ring, pole in ((north, 90.0), (south, -90.0)):
        areas = []
        for k, r in enumerate(variants(ring)):
            s = gloffset.read(polygon(r))
            got = gloffset.contains(s, [0.0, 0.0, 45.0, 180.0], [pole, -pole, 0.0, pole * 0.9])
            assert got.tolist() == [True, False, False, True], r[:2]
            if abs(r[0][0]) == 180.0 or k % 12 == 0:  # the seam vertex first, and others
                areas.append(gloffset.offset(s, -0.05, radius=1.0).resolve().area())
        # the region is the cap inside the ring, less than a hemisphere, whatever the start
        cap = left_area(gloffset.read(polygon(closed(ring))).rings[0])
        assert cap < 2.0 * np.pi
        assert np.ptp(areas) < 1e-12 and 0.0 < areas[0] < cap
    s = gloffset.read(polygon(closed(north)))
    mask = gloffset.render(s, -0.05, Equirect(36, 18), radius=1.0, backend="cpu")
    assert (mask[0] == 255).all() and (mask[3:] == 0).all()


def test_pole_ring_with_a_step_along_the_antimeridian():
    """A ring round a pole that steps along +-180 deg (an edge from 180 to -180 at another
    latitude, towards the pole or away from it) still encloses its pole."""
    for lat, step in ((70.0, 2.0), (70.0, -2.0), (-70.0, 2.0), (-70.0, -2.0)):
        base = ring_along(lat, range(-170, 180, 10))
        for extra in ([[180, lat], [-180, lat + step]], [[180, lat + step], [-180, lat]]):
            for r in variants(base + extra)[::9]:
                s = gloffset.read(polygon(r))
                got = gloffset.contains(s, [0.0, 0.0, 180.0], [90.0, -90.0, 0.0])
                assert got.tolist() == [lat > 0, lat < 0, False], (lat, extra, r[:2])


def test_pole_ring_through_the_seam_vertex_twice():
    """A ring round the north pole that repeats its seam vertex as 180 and -180 (the same
    point) encloses the pole from any start."""
    ring = ring_along(75, list(range(-180, 180, 20)) + [180])
    for r in variants(ring):
        s = gloffset.read(polygon(r))
        assert gloffset.contains(s, [0.0, 0.0], [90.0, 0.0]).tolist() == [True, False], r[:2]


def test_ring_along_the_equator_encloses_the_north_pole():
    """A ring exactly along the equator takes the northern hemisphere, either way round
    and from any start vertex (its vertices' mean latitude, exactly 0, ties north)."""
    for lons in (range(-180, 180, 30), range(-175, 180, 30)):
        for r in variants(ring_along(0, lons)):
            s = gloffset.read(polygon(r))
            got = gloffset.contains(s, [0.0, 0.0, 100.0, 100.0], [90.0, -90.0, 1.0, -1.0])
            assert got.tolist() == [True, False, True, False], r[:2]


def test_pole_rule_does_not_depend_on_the_order_of_the_latitudes():
    """Latitudes whose float sum changes sign with the order they are added in: the mean
    is taken exactly, so every start vertex and direction reads the same side."""
    lat = [-0.3, -0.2, -0.1, 0.3, 0.3, 0.1, 0.1, 0.1, 0.2, -0.3, -0.2, 0.0]
    signs = {np.mean(lat[k:] + lat[:k]) >= 0 for k in range(12)}
    assert len(signs) == 2  # in floating point, the mean's sign depends on the start
    ring = [[x, y] for x, y in zip(range(-180, 180, 30), lat)]
    got = {bool(gloffset.contains(gloffset.read(polygon(r)), 0.0, 90.0)) for r in variants(ring)}
    assert len(got) == 1


BOWTIE = [[0, 0], [10, 10], [10, 0], [0, 10]]


def test_bowtie_is_its_two_lobes():
    """A ring that crosses itself is read by crossing parity: its two lobes, never the
    sphere less them, from any start vertex and either way round."""
    lon = [2.0, 8.0, 5.0, 5.0, -5.0, 15.0, 180.0, 0.0, 0.0]
    lat = [5.0, 5.0, 2.0, 8.0, 5.0, 5.0, 0.0, 90.0, -90.0]
    want = [True, True, False, False, False, False, False, False, False]
    for r in variants(BOWTIE):
        s = gloffset.read(polygon(r))
        assert gloffset.contains(s, lon, lat).tolist() == want, r
        assert gloffset.reference.contains_lonlat(s, lon, lat).tolist() == want, r
        # two lobes of 25 square degrees each (spherical triangles, a little more)
        lobe = 25.0 * np.radians(1.0) ** 2
        areas = sorted(left_area(x) for x in s.rings)
        assert len(areas) == 2 and np.allclose(areas, lobe, rtol=0.02)
        assert gloffset.offset(s, 0.01, radius=1.0).resolve().area() < 0.1


def test_bowtie_with_a_square_is_the_union_of_lobes_and_square():
    """United with a polygon it overlaps, a bowtie still counts as its two lobes."""
    square = [[8, 2], [14, 2], [14, 8], [8, 8]]
    s = gloffset.read(
        {
            "type": "MultiPolygon",
            "coordinates": [
                polygon(closed(BOWTIE))["coordinates"],
                polygon(closed(square))["coordinates"],
            ],
        }
    )
    got = gloffset.contains(s, [2.0, 8.0, 12.0, 5.0, -5.0, 180.0], [5.0, 5.0, 5.0, 2.0, 5.0, 0.0])
    assert got.tolist() == [True, True, True, False, False, False]


def test_real_borders_keep_their_reading(world):
    """Fiji and Russia across the antimeridian, Antarctica round the south pole."""
    ant = gloffset.read(world["Antarctica"])
    assert gloffset.contains(ant, [0.0, 0.0, 0.0], [-90.0, 90.0, 0.0]).tolist() == [
        True,
        False,
        False,
    ]
    rus = gloffset.read(world["Russia"])
    got = gloffset.contains(rus, [100.0, 179.5, -179.5, 0.0], [60.0, 67.5, 67.0, 90.0])
    assert got.tolist() == [True, True, True, False]
    fiji = gloffset.read(world["Fiji"])
    assert gloffset.contains(fiji, [179.0, 0.0], [-90.0, -17.0]).tolist() == [False, False]


# ---------------------------------------------------------------------- properties


@st.composite
def pole_rings(draw):
    """A ring round a pole: integer longitudes (so that rotations are exact), +-180
    among them often (sometimes a step along the antimeridian), steps under 150 deg;
    latitudes 15-80 deg on the pole's side (so that no edge comes within 0.04 rad of
    the pole); a random start and direction."""
    pole = draw(st.sampled_from([1.0, -1.0]))
    lons = draw(st.lists(st.integers(-179, 179), min_size=2, max_size=14, unique=True))
    if draw(st.booleans()):
        lons.append(draw(st.sampled_from([-180, 180])))
    lons = sorted(lons, key=lambda x: x % 360)
    steps = np.diff(np.array([x % 360 for x in lons] + [lons[0] % 360 + 360]))
    if len(lons) < 3 or steps.max() >= 150:
        lons = sorted(set(lons) | {-180, -60, 60}, key=lambda x: x % 360)
        if 180 in lons and -180 in lons:
            lons.remove(180)
    lats = [pole * draw(st.floats(15.0, 80.0)) for _ in lons]
    ring = [[float(x), y] for x, y in zip(lons, lats)]
    seam = [k for k, x in enumerate(lons) if abs(x) == 180]
    if seam and draw(st.booleans()):
        # a step along the antimeridian: 180 then -180 eastward, at two latitudes
        k = seam[0]
        ring[k : k + 1] = [[180.0, lats[k]], [-180.0, pole * draw(st.floats(15.0, 80.0))]]
    k = draw(st.integers(0, len(ring) - 1))
    ring = ring[k:] + ring[:k]
    if draw(st.booleans()):
        ring = ring[::-1]
    return pole, ring


def _rotate(lon, by):
    out = (np.asarray(lon, float) + by + 180.0) % 360.0 - 180.0
    return out


@settings(max_examples=30, deadline=None)
@given(pole_rings(), st.integers(-179, 180))
def test_random_pole_rings_enclose_their_pole(case, by):
    pole, ring = case
    s = gloffset.read(polygon(closed(ring)))
    got = gloffset.contains(s, [0.0, 0.0], [90.0 * pole, -90.0 * pole])
    assert got.tolist() == [True, False]
    # the far hemisphere is outside, whatever the longitude
    far = np.linspace(-180, 180, 13)
    assert not gloffset.contains(s, far, np.full(13, -10.0 * pole)).any()
    # the offset inward keeps the pole, the raster holds the pole's row
    res = gloffset.offset(s, -0.01, radius=1.0).resolve()
    pol = np.array([[0.0, 0.0, pole], [0.0, 0.0, -pole]])
    assert res.contains_xyz(pol).tolist() == [True, False]
    grid = Equirect(16, 8)
    mask = gloffset.render(s, -0.01, grid, radius=1.0, backend="cpu")
    lon, lat = np.meshgrid(-180 + 22.5 * (np.arange(16) + 0.5), 90 - 22.5 * (np.arange(8) + 0.5))
    want = gloffset.contains(s, lon.ravel(), lat.ravel(), distance=-0.01, radius=1.0)
    sure = np.abs(gloffset.distance(s, lon.ravel(), lat.ravel(), radius=1.0) - 0.01) > 1e-9
    assert np.array_equal((mask.ravel() == 255)[sure], want[sure])
    assert want[(lat.ravel() == 78.75 * pole) & sure].any()
    # rotated about the polar axis: the rotated region
    rot = [[float(_rotate(x, by)), y] for x, y in ring]
    r = gloffset.read(polygon(closed(rot)))
    rng = np.random.default_rng(abs(by))
    lon = rng.uniform(-180, 180, 200)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, 200)))
    away = gloffset.distance(s, lon, lat, radius=1.0) > 1e-9
    assert np.array_equal(
        gloffset.contains(s, lon, lat)[away], gloffset.contains(r, _rotate(lon, by), lat)[away]
    )


def test_pole_ring_examples_are_drawn():
    """The strategy does produce rings with vertices exactly on +-180, and steps along it."""
    seen = []

    @settings(max_examples=60, deadline=None, database=None)
    @given(pole_rings())
    def collect(case):
        lons = {x for x, _ in case[1]}
        seen.append((bool(lons & {-180.0, 180.0}), {-180.0, 180.0} <= lons))

    collect()
    assert any(v for v, _ in seen) and any(step for _, step in seen)


# ---------------------------------------------------------------------- through a pole

# The V of issue 37: its base, from 90 E to 90 W at 72 S, runs over the south pole
W_RING = [[-90, -72], [-45, -77], [0, -72], [45, -77], [90, -72]]


def _small_cap_area(ring):
    """S2's area (spherely, the smaller side) of a lon/lat ring on the unit sphere."""
    spherely = pytest.importorskip("spherely")
    return float(spherely.area(spherely.create_polygon([tuple(p) for p in ring]), radius=1.0))


def test_an_edge_through_a_pole_bounds_the_region_between_the_ring_and_the_pole():
    """The V with its base over the south pole is the small region between the V and the
    pole (0.1008 sr, S2's area), not the rest of the sphere: from every start vertex,
    both ways, and mirrored to the north pole. Contains, the area, the inward offset, the
    render and the distance field all read it so."""
    want = _small_cap_area(W_RING)
    assert 0.1 < want < 0.102
    for pole in (-1.0, 1.0):
        ring = [[x, y * -pole] for x, y in W_RING]
        for r in variants(ring):
            s = gloffset.read(polygon(r))
            assert len(s.rings) == 1
            assert abs(left_area(s.rings[0]) - want) < 1e-12, r[:2]
            got = gloffset.contains(
                s, [0.0, 0.0, 0.0, 180.0, 30.0], pole * np.array([0, 80, 74.5, 80, 89])
            )
            assert got.tolist() == [False, True, True, False, True], r[:2]
    s = gloffset.read(polygon(closed(W_RING)))
    assert gloffset.offset(s, -0.005, radius=1.0).resolve().area() < want
    assert abs(gloffset.offset(s, 0.005, radius=1.0).resolve().area() - want) < 0.03
    grid = Equirect(72, 36)
    mask = gloffset.render(s, 1e-6, grid, radius=1.0, backend="cpu")
    field = gloffset.distance_field(s, grid, radius=1.0, backend="cpu").values
    lon, lat = np.meshgrid(-180 + 5 * (np.arange(72) + 0.5), 90 - 5 * (np.arange(36) + 0.5))
    inside = gloffset.contains(s, lon.ravel(), lat.ravel()).reshape(lon.shape)
    assert inside.sum() <= 3 * 36 and not inside[:33].any()  # only round the south pole
    assert inside[-1, 36:54].all() and not inside[-1, :18].any()  # 0-90 E in, 180-90 W out
    assert np.array_equal(mask == 255, inside)
    assert np.array_equal(field < 0, inside)


def test_a_base_near_the_pole_on_either_side_is_read_alike():
    """The V's base 0.01 deg of longitude short of 180 (the great circle passes the pole
    on the V's side) or beyond it (on the far side): both are the small region, with the
    pole outside and inside respectively; S2 agrees on the area."""
    for end, pole_in in ((89.99, False), (90.01, True)):
        ring = [p for p in W_RING[:-1]] + [[end, -72.0]]
        want = _small_cap_area(ring)
        for r in variants(ring)[::3]:
            s = gloffset.read(polygon(r))
            assert abs(left_area(s.rings[0]) - want) < 1e-12, (end, r[:2])
            got = gloffset.contains(s, [0.0, 0.0, 0.0], [0.0, -80.0, -90.0])
            assert got.tolist() == [False, True, pole_in], (end, r[:2])


def test_a_vertex_on_the_pole_instead_of_the_edge_through_it():
    """The V closed through a vertex at the south pole, whatever longitude the pole
    vertex is given: the same small region."""
    want = _small_cap_area(W_RING)
    for plon in (0.0, 180.0, -135.0, 90.0):
        for r in variants(W_RING + [[plon, -90.0]])[::2]:
            s = gloffset.read(polygon(r))
            assert abs(left_area(s.rings[0]) - want) < 1e-12, (plon, r[:2])
            got = gloffset.contains(s, [0.0, 0.0, 180.0], [0.0, -80.0, -80.0])
            assert got.tolist() == [False, True, False], (plon, r[:2])


def test_a_polar_stereographic_triangle_with_its_base_through_the_pole(tmp_path):
    """An EPSG:3031 triangle whose straight base runs through the south pole (so its ends'
    longitudes, read back, are 180 deg apart to rounding): the triangle, not the rest of
    the sphere; and the same in the north (EPSG:3413)."""
    pyproj = pytest.importorskip("pyproj")
    gpd = pytest.importorskip("geopandas")
    shapely = pytest.importorskip("shapely")
    pytest.importorskip("pyogrio")
    for crs, sign in (("EPSG:3031", -1.0), ("EPSG:3413", 1.0)):
        to = pyproj.Transformer.from_crs("OGC:CRS84", crs, always_xy=True)
        lon0 = 0.0 if sign < 0 else -45.0  # EPSG:3413's y axis runs along 45 W
        x, y = to.transform([lon0 + 90, lon0, lon0 - 90], [72 * sign, 75 * sign, 72 * sign])
        path = tmp_path / f"{crs[5:]}.gpkg"
        tri = shapely.Polygon(zip(x, y))
        gpd.GeoDataFrame({"n": [1]}, geometry=[tri], crs=crs).to_file(path)
        s = gloffset.read(path)
        assert left_area(s.rings[0]) < 0.1
        got = gloffset.contains(s, [lon0, lon0, lon0, lon0 + 180], sign * np.array([0, 74, 80, 80]))
        assert got.tolist() == [False, False, True, False], crs


@st.composite
def through_pole_rings(draw):
    """A ring through a pole: a base from longitude ``lon0`` to ``lon0 + 180`` (integers,
    +-180 among them often) over the pole, and a chain back through the half between
    them, its steps at most 60 deg; or, instead of the base, two meridians meeting at a
    vertex on the pole (with any longitude). Latitudes 15-80 deg on the pole's side, so
    that the chain stays under 82 deg. A random start and direction. Returns the pole
    (+-1), the half's middle longitude and the ring."""
    pole = draw(st.sampled_from([1.0, -1.0]))
    lon0 = draw(st.sampled_from([-180, 0, 180]) | st.integers(-179, 179))
    east = draw(st.booleans())  # the chain on the east or the west side of the base
    us = set(draw(st.lists(st.integers(1, 179), max_size=6)))
    us |= {u for u in (60, 120) if not any(abs(u - v) < 30 for v in us)}
    us = sorted(us)
    while max(np.diff([0, *us, 180])) > 60:  # fill the widest gap
        gaps = np.diff([0, *us, 180])
        k = int(np.argmax(gaps))
        us = sorted({*us, [0, *us][k] + int(gaps[k]) // 2})
    sign = 1 if east else -1

    def wrap(x):
        return float((x + 180) % 360 - 180) if abs(x) != 180 else float(x)

    lon1 = wrap(lon0 + 180 * sign) if lon0 not in (-180, 180) else 0.0
    chain = [[wrap(lon0 + sign * u), pole * draw(st.floats(15.0, 80.0))] for u in us]
    ring = [[float(lon0), pole * draw(st.floats(15.0, 80.0))], *chain]
    ring.append([lon1, pole * draw(st.floats(15.0, 80.0))])
    if draw(st.booleans()):  # a vertex on the pole instead of the edge through it
        ring.append([float(draw(st.integers(-180, 180))), 90.0 * pole])
    mid = wrap(lon0 + 90 * sign)
    k = draw(st.integers(0, len(ring) - 1))
    ring = ring[k:] + ring[:k]
    if draw(st.booleans()):
        ring = ring[::-1]
    return pole, mid, ring


def _check_through_pole(s, pole, mid):
    """The region of a ring through a pole: the half-lune's side of the pole inside, the
    other half and the far hemisphere outside; its area, its points and the signs of its
    distance field as S2 (spherely) and gloffset's own inside test have them."""
    spherely = pytest.importorskip("spherely")
    from gloffset.geometry.sphere import xyz_to_lonlat

    assert len(s.rings) == 1
    lon, lat = xyz_to_lonlat(s.rings[0])
    theirs = spherely.create_polygon(list(zip(lon.tolist(), lat.tolist())))
    area = float(spherely.area(theirs, radius=1.0))
    assert area < 2.0 * np.pi and abs(left_area(s.rings[0]) - area) < 1e-9
    opposite = mid - 180.0 if mid > 0 else mid + 180.0
    got = gloffset.contains(s, [mid, opposite, mid], pole * np.array([88.0, 88.0, -10.0]))
    assert got.tolist() == [True, False, False]
    rng = np.random.default_rng(int(abs(mid)) + 7)
    plon = rng.uniform(-180, 180, 300)
    plat = np.degrees(np.arcsin(rng.uniform(-1, 1, 300)))
    plat[:150] = pole * np.abs(plat[:150])  # half of them on the pole's side
    far = gloffset.distance(s, plon, plat, radius=1.0) > 1e-9
    want = spherely.contains(theirs, spherely.points(plon[far], plat[far]))
    assert np.array_equal(gloffset.contains(s, plon, plat)[far], want)
    grid = Equirect(24, 12)
    field = gloffset.distance_field(s, grid, radius=1.0, backend="cpu").values.ravel()
    glon, glat = np.meshgrid(-180 + 15 * (np.arange(24) + 0.5), 90 - 15 * (np.arange(12) + 0.5))
    inside = gloffset.contains(s, glon.ravel(), glat.ravel())
    sure = np.abs(field) > 1e-9
    assert np.array_equal((field < 0)[sure], inside[sure]) and inside.any()


@settings(max_examples=30, deadline=None)
@given(through_pole_rings())
def test_random_rings_through_a_pole(case):
    """Rings with an edge through a pole (or a vertex on it), in both hemispheres, both
    ways round, from any start vertex: the small region between the ring and the pole."""
    pole, mid, ring = case
    _check_through_pole(gloffset.read(polygon(closed(ring))), pole, mid)


@settings(max_examples=10, deadline=None)
@given(through_pole_rings())
def test_random_projected_rings_through_a_pole(tmp_path_factory, case):
    """The same rings in a polar stereographic file (EPSG:3031 in the south, EPSG:3413 in
    the north): the base is the projection's straight line through the pole, the chain
    its straight lines, densified."""
    pyproj = pytest.importorskip("pyproj")
    gpd = pytest.importorskip("geopandas")
    shapely = pytest.importorskip("shapely")
    pytest.importorskip("pyogrio")
    pole, mid, ring = case
    ring = [p for p in ring if abs(p[1]) != 90.0]  # the base is the straight line
    crs = "EPSG:3413" if pole > 0 else "EPSG:3031"
    to = pyproj.Transformer.from_crs("OGC:CRS84", crs, always_xy=True)
    x, y = to.transform([p[0] for p in ring], [p[1] for p in ring])
    path = tmp_path_factory.mktemp("through") / "ring.gpkg"
    frame = gpd.GeoDataFrame({"n": [1]}, geometry=[shapely.Polygon(zip(x, y))], crs=crs)
    frame.to_file(path)
    _check_through_pole(gloffset.read(path), pole, mid)


def test_through_pole_examples_are_drawn():
    """The strategy draws both poles, both sides, bases from +-180 and vertices on the pole."""
    seen = set()

    @settings(max_examples=80, deadline=None, database=None)
    @given(through_pole_rings())
    def collect(case):
        pole, _, ring = case
        lons = {x for x, _ in ring}
        seen.add(("pole", pole))
        seen.add(("on pole", any(abs(y) == 90.0 for _, y in ring)))
        seen.add(("seam", bool(lons & {-180.0, 180.0})))

    collect()
    assert {("pole", 1.0), ("pole", -1.0), ("on pole", True), ("on pole", False)} <= seen
    assert ("seam", True) in seen


def test_a_long_edge_is_read_as_its_great_circle():
    """A thin triangle whose long edge, a great circle from 65 E to 120 E, bows south of
    the middle vertex while its straight lon/lat line passes north of it: the sliver
    between them (S2's area), not the rest of the sphere, from every start and both ways."""
    ring = [[120, -21], [85, -21.5], [65, -18.5]]
    want = _small_cap_area(ring)
    assert want < 1e-3
    for r in variants(ring):
        s = gloffset.read(polygon(r))
        assert abs(left_area(s.rings[0]) - want) < 1e-12, r
        assert not gloffset.contains(s, [0.0, 85.0, 85.0], [60.0, -20.0, -60.0]).any()


@st.composite
def star_rings(draw):
    """A star-shaped ring round a random centre (vertices at 0.5-60 deg from it, in
    angular order round it, 5 deg apart at least), either way, holding neither pole."""
    spherely = pytest.importorskip("spherely")
    clon, clat = draw(st.floats(-180, 180)), draw(st.floats(-80, 80))
    ang = sorted(draw(st.lists(st.integers(0, 71), min_size=3, max_size=10, unique=True)))
    assume(max(np.diff([*ang, ang[0] + 72])) < 36)  # round the centre, not beside it
    ang = np.radians(5.0 * np.array(ang))
    rad = np.radians(draw(st.lists(st.floats(0.5, 60.0), min_size=len(ang), max_size=len(ang))))
    c = np.array(gloffset.geometry.sphere.lonlat_to_xyz(clon, clat), float).ravel()
    e1 = np.cross(c, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(c, e1)
    pts = np.cos(rad)[:, None] * c + np.sin(rad)[:, None] * (
        np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2
    )
    lon, lat = gloffset.geometry.sphere.xyz_to_lonlat(pts)
    ring = np.column_stack([lon, lat]).tolist()
    if draw(st.booleans()):
        ring = ring[::-1]
    theirs = spherely.create_polygon([tuple(p) for p in ring])
    poles = spherely.points([0.0, 0.0], [90.0, -90.0])
    assume(not spherely.contains(theirs, poles).any())
    return ring, float(spherely.area(theirs, radius=1.0))


@settings(max_examples=60, deadline=None)
@given(star_rings())
def test_random_star_rings_are_their_star(case):
    """A ring round neither pole is the side that holds neither pole, on the sphere (its
    edges great circles), as S2 has it, whatever its edges' straight lon/lat lines do."""
    ring, want = case
    s = gloffset.read(polygon(closed(ring)))
    assert abs(sum(left_area(r) for r in s.rings) - want) < 1e-9
