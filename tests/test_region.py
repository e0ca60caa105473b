"""The region of an input is the union of its polygons (gloffset.region).

Each wrong answer that real borders showed is reproduced here first: shared
borders treated as boundaries, seam pieces whose seam vertices differ, Antarctica
at +-180 deg, inward vector offsets across seams. The union is then checked against
an independent union (shapely's ``unary_union`` in lon/lat, fine for edges of a few
km) on neighbours from Natural Earth's 1:10m countries, at d = 0, > 0 and < 0,
through every operation: contains, render (equirect and tiles), resolved offsets.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import DATA
from test_selfintersect import assert_on_distance, assert_region

import gloffset
from gloffset.geometry.sphere import lonlat_to_xyz, normalize
from gloffset.grids import Equirect, Tile
from gloffset.reference import contains_xyz, distance_xyz

R = gloffset.EARTH_RADIUS
# edges of the 10m borders are straight in lon/lat for shapely and great circles for
# gloffset: they differ by well under a metre; points closer than this to the
# boundary (or to distance d from it) are not compared
MARGIN = 1e-5  # rad, 64 m


def mp(*polys):
    return {"type": "MultiPolygon", "coordinates": [[p] for p in polys]}


SQ_A = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]
SQ_B = [[10, 0], [20, 0], [20, 10], [10, 10], [10, 0]]
# the same rectangle (edges are great-circle arcs, so it keeps the squares' vertices)
RECT = [[0, 0], [10, 0], [20, 0], [20, 10], [10, 10], [0, 10], [0, 0]]
SEAM_E = [[179, -1], [180, -1], [180, 1], [179, 1], [179, -1]]
SEAM_W = [[-180, -1.001], [-179, -1.001], [-179, 1], [-180, 1], [-180, -1.001]]


@pytest.fixture(scope="module")
def countries():
    fc = json.loads((DATA / "countries_10m.geojson").read_text())
    return {f["properties"]["name"]: f for f in fc["features"]}


def random_points(bounds, n, seed=0):
    w, s, e, nn = bounds
    rng = np.random.default_rng(seed)
    return rng.uniform(w, e, n), rng.uniform(s, nn, n)


# --------------------------------------------------------------------------- 1. shared borders


def test_two_squares_sharing_an_edge_are_one_rectangle():
    two, one = gloffset.read(mp(SQ_A, SQ_B)), gloffset.read(mp(RECT))
    assert len(two.rings) == 1
    # the shared edge is no boundary: 5 deg to the rectangle's long sides
    assert gloffset.distance(two, 10, 5, radius=1) == pytest.approx(np.radians(5), abs=1e-15)
    assert gloffset.distance(two, 10, 5) == gloffset.distance(one, 10, 5)
    lon, lat = random_points((-2, -2, 22, 12), 20000)
    for d in (-100e3, 0.0, 100e3):
        assert np.array_equal(
            gloffset.contains(two, lon, lat, distance=d),
            gloffset.contains(one, lon, lat, distance=d),
        )
    grid = Equirect(480, 240, (-2, -2, 22, 10.0))
    for d in (-100e3, 100e3):
        a, b = gloffset.render(two, d, grid), gloffset.render(one, d, grid)
        near = np.abs(pixel_distance(one, grid) - abs(d) / R) < 1e-9
        assert np.array_equal(a[~near], b[~near])
    # the strip along the shared edge is kept at -100 km
    assert gloffset.contains(two, [10.0], [5.0], distance=-100e3)[0]


def test_overlap_and_duplicate_polygons():
    # the same square twice, a square inside it, one overlapping it: one ring
    s = gloffset.read(mp(SQ_A, SQ_A, [[2, 2], [4, 2], [4, 4], [2, 4], [2, 2]], SQ_B))
    assert len(s.rings) == 1 and len(s.overlapping_components()) == 0
    one = gloffset.read(mp(RECT))
    lon, lat = random_points((-2, -2, 22, 12), 5000)
    assert np.array_equal(gloffset.contains(s, lon, lat), gloffset.contains(one, lon, lat))
    # an enclave fills its hole: the hole's edges cancel
    holed = {
        "type": "Polygon",
        "coordinates": [RECT, [[5, 3], [5, 7], [15, 7], [15, 3], [5, 3]]],
    }
    fill = {"type": "Polygon", "coordinates": [[[5, 3], [15, 3], [15, 7], [5, 7], [5, 3]]]}
    fc = {
        "type": "FeatureCollection",
        "features": [{"type": "Feature", "properties": {}, "geometry": g} for g in (holed, fill)],
    }
    u = gloffset.read(fc)
    assert len(u.rings) == 1 and not u.ring_holes.any()
    assert gloffset.distance(u, 10, 5, radius=1) == pytest.approx(np.radians(5), abs=1e-15)


def pixel_distance(shape, grid):
    jj, ii = np.mgrid[0 : grid.height, 0 : grid.width]
    lon, lat = grid.pixel_lonlat(ii.ravel(), jj.ravel())
    return distance_xyz(shape, lonlat_to_xyz(lon, lat)).reshape(grid.height, grid.width)


def test_world_land_mask_has_no_gaps_along_borders(world):
    """A -100 km land mask of all 110m countries: the points of shared borders that lie
    farther than 100 km from the coast are inside it (they were gaps)."""
    fc = {"type": "FeatureCollection", "features": list(world.values())}
    land = gloffset.read(fc)
    parts = gloffset.io.geojson.parse(fc)
    # midpoints of edges used by two countries (in opposite directions)
    seen, shared = {}, []
    for poly in parts.polygons:
        ring = poly[0]
        for a, b in zip(ring[:-1], ring[1:]):
            key = (tuple(b), tuple(a))
            if key in seen:
                shared.append((a + b) / 2)
            seen[(tuple(a), tuple(b))] = True
    shared = np.array(shared)
    assert len(shared) > 300
    p = normalize(lonlat_to_xyz(shared[:, 0], shared[:, 1]))
    dist = distance_xyz(land, p)
    deep = dist > 100e3 / R + MARGIN
    assert deep.sum() > 100
    lon, lat = shared[deep, 0], shared[deep, 1]
    assert gloffset.contains(land, lon, lat, distance=-100e3).all()
    assert gloffset.reference.contains_lonlat(land, lon, lat, distance=-100e3).all()
    grid = Equirect(1440, 720)
    mask = gloffset.render(land, -100e3, grid)
    i = np.floor((lon + 180) / 0.25).astype(int)
    j = np.floor((90 - lat) / 0.25).astype(int)
    clon, clat = grid.pixel_lonlat(i, j)
    ok = distance_xyz(land, lonlat_to_xyz(clon, clat)) > 100e3 / R + MARGIN
    assert ok.sum() > 50
    assert (mask[j[ok], i[ok]] == 255).all()


# --------------------------------------------------------------------------- 2. seams


def test_seam_pieces_whose_seam_vertices_differ():
    s = gloffset.read(mp(SEAM_E, SEAM_W))
    assert len(s.rings) == 1
    lon, lat = [180.0, -180.0, 179.9999, -179.9999], [0.0, 0.0, 0.0, 0.0]
    assert gloffset.contains(s, lon, lat).all()
    assert gloffset.reference.contains_lonlat(s, lon, lat).all()
    # the seam is no boundary: 1 deg to the meridians 179 and -179 (the parallels are
    # 1 deg away too); at -50 km the seam's neighbourhood stays in
    assert gloffset.distance(s, 180, 0, radius=1) == pytest.approx(np.radians(1), abs=1e-12)
    assert gloffset.contains(s, lon, lat, distance=-50e3).all()
    # the render column at exactly 180 deg
    grid = Equirect(16, 40, (177.875, -1.5, -178.125, 1.5))
    lons, _ = grid.pixel_lonlat(np.arange(16), np.zeros(16, int))
    col = int(np.flatnonzero(np.isclose(np.abs(lons), 180.0, atol=1e-12))[0])
    for d in (0.0, -50e3):
        mask = gloffset.render(s, d, grid)
        _, lats = grid.pixel_lonlat(np.full(40, col), np.arange(40))
        want = gloffset.reference.contains_lonlat(s, np.full(40, 180.0), lats, distance=d)
        assert want[15:25].all()
        assert np.array_equal(mask[:, col] == 255, want)


def test_russia_and_fiji_at_the_seam(world):
    russia = gloffset.read(world["Russia"])
    lat = np.linspace(65.5, 68.5, 31)
    for lon in (180.0, -180.0):
        assert gloffset.contains(russia, np.full_like(lat, lon), lat).all()
        assert gloffset.reference.contains_lonlat(russia, np.full_like(lat, lon), lat).all()
    assert not any(s.any() for s in russia.ring_seams)  # every seam joined and gone
    fiji = gloffset.read(world["Fiji"])
    assert not any(s.any() for s in fiji.ring_seams)


def antarctica_10m_like(world):
    """Antarctica as Natural Earth 1:10m draws it: down lon 180 to lat
    -89.99999999999994, along that latitude to lon -179.99999999999991, up again, and
    the ring ending 3.5e-7 deg away from where it started."""
    ring = [list(p) for p in world["Antarctica"]["geometry"]["coordinates"][7][0]]
    assert ring[1] == [180.0, -90.0]
    ring[1] = [180.0, -89.99999999999994]
    ring[2] = [-179.99999999999991, -89.99999999999994]
    ring[3] = [-179.99999999999991, ring[3][1]]
    ring[-1] = [180.0, ring[0][1] - 3.5e-7]
    return {"type": "Polygon", "coordinates": [ring]}


def test_antarctica_at_the_antimeridian(world):
    ant = gloffset.read(antarctica_10m_like(world))
    lat = np.linspace(-89.99, -84.8, 50)
    for lon in (180.0, -180.0, 179.99, -179.99):
        assert gloffset.contains(ant, np.full_like(lat, lon), lat).all(), lon
        assert gloffset.reference.contains_lonlat(ant, np.full_like(lat, lon), lat).all(), lon
    assert gloffset.contains(ant, [0.0], [-90.0]).all()
    grid = Equirect(16, 200, (177.875, -90.0, -178.125, -80.0))
    mask = gloffset.render(ant, 0.0, grid)
    lons, lats = grid.pixel_lonlat(np.arange(16), np.full(16, 0))
    col = int(np.flatnonzero(np.isclose(np.abs(lons), 180.0, atol=1e-12))[0])
    _, lats = grid.pixel_lonlat(np.full(200, col), np.arange(200))
    want = gloffset.reference.contains_lonlat(ant, np.full(200, 180.0), lats)
    assert want[lats < -85.0].all()
    assert np.array_equal(mask[:, col] == 255, want)


def test_polar_cap_with_seam_ends_that_differ():
    def cap(end):
        ring = [[-180, end], [-90, -80], [0, -80], [90, -80], [180, -80], [180, -90]]
        return gloffset.read(
            {"type": "Polygon", "coordinates": [ring + [[-180, -90], [-180, end]]]}
        )

    s, exact = cap(-80.0000001), cap(-80.0)
    assert gloffset.contains(s, [180, -180, 0, 45], [-85, -85, -90, -84]).all()
    assert not gloffset.contains(s, [180, -180, 0], [-79, -79, 0]).any()
    lon, lat = random_points((-180, -89, 180, -70), 5000)
    for d in (-100e3, 0.0, 100e3):
        a = gloffset.contains(s, lon, lat, distance=d)
        b = gloffset.contains(exact, lon, lat, distance=d)
        assert np.count_nonzero(a != b) == 0
    assert gloffset.distance(s, 0, -90, radius=1) == pytest.approx(
        gloffset.distance(exact, 0, -90, radius=1), abs=1e-8
    )


def test_whole_world_ring():
    world = [[-180, -90], [180, -90], [180, 90], [-180, 90], [-180, -90]]
    with pytest.raises(gloffset.errors.InvalidGeometryError, match="whole sphere"):
        gloffset.read({"type": "Polygon", "coordinates": [world]})
    # with a hole (the ocean around a continent) it is the sphere less the hole
    hole = [[0, 0], [0, 10], [10, 10], [10, 0], [0, 0]]
    ocean = gloffset.read({"type": "Polygon", "coordinates": [world, hole]})
    assert gloffset.contains(ocean, [100, 180, 0, 5], [0, 0, 90, -1]).all()
    assert not gloffset.contains(ocean, [5], [5]).any()
    square = gloffset.read({"type": "Polygon", "coordinates": [hole[::-1]]})
    assert gloffset.distance(ocean, 5, 20) == gloffset.distance(square, 5, 20)
    # an island in the ocean is inside it (no boundary), an island in the hole is not
    island = [[100, 0], [101, 0], [101, 1], [100, 1], [100, 0]]
    lake_island = [[4, 4], [6, 4], [6, 6], [4, 6], [4, 4]]
    both = gloffset.read(
        {"type": "MultiPolygon", "coordinates": [[world, hole], [island], [lake_island]]}
    )
    assert len(both.rings) == 2
    assert gloffset.distance(both, 100.5, 0.5) == gloffset.distance(square, 100.5, 0.5)
    assert gloffset.contains(both, [5, 3], [5, 3]).tolist() == [True, False]


# --------------------------------------------------------------------------- 4. inward offsets


@pytest.mark.parametrize("dkm", [-127, -50, -10])
def test_inward_offsets_across_seams(world, dkm):
    d = dkm * 1e3 / R
    cases = {
        "Antarctica": gloffset.read(antarctica_10m_like(world)),
        "Russia": gloffset.read(world["Russia"]),
        "pair": gloffset.read(mp(SEAM_E, SEAM_W)),
    }
    for name, shape in cases.items():
        res = gloffset.offset(shape, d, radius=1.0).resolve()
        assert res.unlinked == 0, name
        assert res.rings or name == "pair", name
        assert_on_distance(shape, res)
        assert_region(shape, res, n=600)
    # the pair is not shrunk away from 180 deg on either side
    res = gloffset.offset(cases["pair"], -50e3).resolve()
    if res.rings:
        p = lonlat_to_xyz(np.array([180.0, 179.8, -179.8]), np.zeros(3))
        assert res.contains_xyz(p).all()


# --------------------------------------------------------------------------- against shapely


def shapely_union(features):
    shapely = pytest.importorskip("shapely")
    from shapely.geometry import shape as sh

    return shapely.unary_union([sh(f["geometry"]) for f in features])


def bbox(features, pad):
    lo = np.array([180.0, 90.0])
    hi = -lo
    for f in features:
        g = f["geometry"]
        polys = g["coordinates"] if g["type"] == "MultiPolygon" else [g["coordinates"]]
        pts = np.concatenate([np.asarray(r) for p in polys for r in p])
        lo, hi = np.minimum(lo, pts.min(axis=0)), np.maximum(hi, pts.max(axis=0))
    return (lo[0] - pad, max(lo[1] - pad, -89.0), hi[0] + pad, min(hi[1] + pad, 89.0))


def shapely_truth(features):
    """``truth(lon, lat, d) -> (want, sure)`` for the union of ``features`` by shapely:
    inside shapely's union, and the reference distance to its boundary; ``sure`` leaves
    out points within MARGIN of the boundary or of distance d from it."""
    import shapely

    theirs_geom = shapely_union(features)
    theirs = gloffset.read(theirs_geom)  # one polygon set without shared borders
    shapely.prepare(theirs_geom)

    def truth(lon, lat, d):
        p = lonlat_to_xyz(lon, lat)
        inside = shapely.contains_xy(theirs_geom, lon, lat)
        dist = distance_xyz(theirs, p)
        want = (inside & (dist > -d)) if d < 0 else (inside | (dist < d))
        sure = (dist > MARGIN) & (np.abs(dist - abs(d)) > MARGIN)
        return want, sure

    return truth


def check_against_shapely(features, ds, n=6000, render=True, offsets=True, seed=0):
    """contains, render, tiles and resolved offsets of the union of ``features`` agree
    with shapely's union (its inside, and the reference distance to its boundary)."""
    fc = {"type": "FeatureCollection", "features": features}
    ours = gloffset.read(fc)
    truth = shapely_truth(features)
    box = bbox(features, 1.5)
    lon, lat = random_points(box, n, seed)
    # points along the shared borders too: the vertices of every input ring
    verts = np.concatenate([r for poly in gloffset.io.geojson.parse(fc).polygons for r in poly])
    pick = np.random.default_rng(seed).integers(0, len(verts), n // 2)
    jitter = np.random.default_rng(seed + 1).normal(scale=0.05, size=(n // 2, 2))
    lon = np.concatenate([lon, np.clip(verts[pick, 0] + jitter[:, 0], -180, 180)])
    lat = np.concatenate([lat, np.clip(verts[pick, 1] + jitter[:, 1], -89.9, 89.9)])
    for d in ds:
        want, sure = truth(lon, lat, d / R)
        got = gloffset.contains(ours, lon[sure], lat[sure], distance=d)
        assert np.array_equal(got, want[sure]), (d, np.count_nonzero(got != want[sure]))
        if offsets and d != 0:
            res = gloffset.offset(ours, d).resolve()
            got = res.contains_xyz(lonlat_to_xyz(lon[sure], lat[sure]))
            assert np.array_equal(got, want[sure]), ("offset", d)
        if render:
            grid = Equirect(256, 256, box)
            check_raster(gloffset.render(ours, d, grid), grid, truth, d, seed)
            # a web-mercator tile over the middle of the box
            z = 6
            c = 0.5 * (np.array(box[:2]) + np.array(box[2:]))
            tile = Tile(z, *_tile_xy(c[0], c[1], z))
            check_raster(gloffset.render(ours, d, tile), tile, truth, d, seed)
    return ours


def check_raster(mask, grid, truth, d, seed, n=3000):
    """Pixels of a rendered mask (a random sample of them) against the truth."""
    rng = np.random.default_rng(seed)
    ii = rng.integers(0, mask.shape[1], n)
    jj = rng.integers(0, mask.shape[0], n)
    plon, plat = grid.pixel_lonlat(ii, jj)
    want, sure = truth(plon, plat, d / R)
    got = mask[jj, ii] == 255
    assert np.array_equal(got[sure], want[sure]), (type(grid).__name__, d)


def _tile_xy(lon, lat, z):
    n = 2**z
    x = int((lon + 180.0) / 360.0 * n)
    y = int((1.0 - np.arcsinh(np.tan(np.radians(lat))) / np.pi) / 2.0 * n)
    return x, y


NEIGHBOURS = [
    ("South Africa", "Lesotho"),  # an enclave: a hole filled
    ("Austria", "Liechtenstein"),
    pytest.param(("France", "Spain", "Andorra"), marks=pytest.mark.slow),
    ("Belgium", "Netherlands", "Luxembourg"),
    ("Ethiopia", "Eritrea", "Djibouti"),
]


@pytest.mark.parametrize("names", NEIGHBOURS, ids=lambda n: "-".join(n))
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_neighbours_against_shapely_union(countries, names):
    feats = [countries[n] for n in names]
    ours = check_against_shapely(feats, (0.0, 20e3, -20e3), n=3000, offsets=False)
    # fewer vertices than the parts: the shared borders are gone
    assert ours.n_vertices < sum(gloffset.read(f).n_vertices for f in feats)


@pytest.mark.slow  # 7-25 s on 2 cores: run by .ci/run with -m slow
def test_neighbours_pyramid_against_shapely_union(countries, tmp_path):
    """A tile pyramid of South Africa with Lesotho (its enclave): every tile of z3-z5 over
    them holds exactly the union's pixels."""
    import io
    import sqlite3

    from PIL import Image

    from gloffset.tiles.tiling import pyramid

    feats = [countries["South Africa"], countries["Lesotho"]]
    fc = {"type": "FeatureCollection", "features": feats}
    truth = shapely_truth(feats)
    box = bbox(feats, 0.5)
    size = 64
    for d in (-20e3, 20e3):
        path = tmp_path / f"t{d:g}.mbtiles"
        pyramid(fc, d, "3-5", path, size=size)
        db = sqlite3.connect(path)
        tiles = {
            (z, x, (1 << z) - 1 - r): bytes(b) for z, x, r, b in db.execute("SELECT * FROM tiles")
        }
        db.close()
        for z in range(3, 6):
            x0, y0 = _tile_xy(box[0], box[3], z)
            x1, y1 = _tile_xy(box[2], box[1], z)
            for x in range(x0, x1 + 1):
                for y in range(y0, y1 + 1):
                    tile = Tile(z, x, y, size)
                    png = tiles.get((z, x, y))
                    got = np.zeros((size, size), bool)
                    if png is not None:
                        got = np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))[..., 3] > 0
                    jj, ii = np.mgrid[0:size, 0:size]
                    lon, lat = tile.pixel_lonlat(ii.ravel(), jj.ravel())
                    want, sure = truth(lon, lat, d / R)
                    assert np.array_equal(got.ravel()[sure], want[sure]), (d, z, x, y)


@pytest.mark.parametrize("names", NEIGHBOURS[:2], ids=lambda n: "-".join(n))
def test_neighbours_offsets_against_shapely_union(countries, names):
    check_against_shapely(
        [countries[n] for n in names], (-10e3, 10e3), n=1500, render=False, offsets=True
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    "names",
    [
        ("Sweden", "Finland"),
        ("India", "Bangladesh", "Nepal"),
        ("Bolivia", "Peru"),
        ("Germany", "Poland", "Austria"),
        ("Guatemala", "Belize"),
        ("Portugal", "Spain"),
    ],
    ids=lambda n: "-".join(n),
)
def test_more_neighbours_against_shapely_union(countries, names):
    check_against_shapely([countries[n] for n in names], (0.0, 127e3, -127e3, -10e3), n=4000)


@pytest.mark.slow
def test_inward_offsets_of_every_country(countries):
    """Every 10m country with area, at -10 km and -127 km: the resolved boundary lies at
    |d| from the union's boundary and the region agrees with contains."""
    for name, feat in countries.items():
        shape = gloffset.read(feat)
        if not shape.rings:
            continue
        for d in (-10e3 / R, -127e3 / R):
            res = gloffset.offset(shape, d, radius=1.0).resolve()
            assert res.unlinked == 0, name
            assert_on_distance(shape, res, most=3000)
            p = np.random.default_rng(len(name)).normal(size=(400, 3))
            v = np.concatenate(shape.rings)
            near = normalize(
                v[:: max(1, len(v) // 400)][:400]
                + 0.02 * p[: len(v[:: max(1, len(v) // 400)][:400])]
            )
            keep = np.abs(distance_xyz(shape, near) - abs(d)) > 1e-9
            got = res.contains_xyz(near[keep])
            want = gloffset.contains(
                shape, *gloffset.geometry.sphere.xyz_to_lonlat(near[keep]), distance=d, radius=1.0
            )
            assert np.array_equal(got, want), name
            assert np.array_equal(want, contains_xyz(shape, near[keep], d)), name


def test_shape_keeps_the_polygons_as_given():
    """The union is derived; to_geojson writes the user's polygons back."""
    s = gloffset.read(mp(SQ_A, SQ_B))
    geom = s.to_geojson()["geometry"]
    assert geom["type"] == "MultiPolygon" and len(geom["coordinates"]) == 2
    assert geom["coordinates"][0][0] == [[float(x), float(y)] for x, y in SQ_A]
    again = gloffset.read(s.to_geojson())
    assert len(again.rings) == 1 and np.array_equal(again.rings[0], s.rings[0])
    # a hole given clockwise or not comes back clockwise, the exterior counter-clockwise
    holed = gloffset.read(
        {"type": "Polygon", "coordinates": [RECT[::-1], [[5, 3], [15, 3], [15, 7], [5, 7], [5, 3]]]}
    )
    ext, hole = holed.to_geojson()["geometry"]["coordinates"][0]
    area = [
        0.5
        * np.sum(
            np.array(r)[:-1, 0] * np.array(r)[1:, 1] - np.array(r)[1:, 0] * np.array(r)[:-1, 1]
        )
        for r in (ext, hole)
    ]
    assert area[0] > 0 > area[1]
    with pytest.raises(gloffset.errors.InvalidGeometryError, match="longitude 400.0 out of range"):
        gloffset.read({"type": "LineString", "coordinates": [[0, 0], [400, 0]]})


@pytest.mark.slow
def test_planet_union_against_shapely():
    """All 234 countries at 1:10m (308k vertices) united at once: the same region as
    shapely's union, at d = 0 and -50 km, on points uniform on the sphere."""
    fc = json.loads((DATA / "countries_10m.geojson").read_text())
    ours = gloffset.read(fc)
    truth = shapely_truth(fc["features"])
    rng = np.random.default_rng(1)
    lon = rng.uniform(-180, 180, 6000)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, 6000)))
    for d in (0.0, -50e3):
        want, sure = truth(lon, lat, d / R)
        got = gloffset.contains(ours, lon[sure], lat[sure], distance=d)
        assert np.array_equal(got, want[sure]), d


def _crosses_itself(ring):
    """Whether two edges of a closed lon/lat ring (great-circle edges) cross, edges that
    share an end excepted."""
    from gloffset.geometry.sphere import arcs_cross

    v = lonlat_to_xyz(ring[:-1, 0], ring[:-1, 1])
    a, b = v, np.roll(v, -1, axis=0)
    i, j = np.triu_indices(len(v), 1)
    shared = (a[i] == a[j]).all(1) | (a[i] == b[j]).all(1) | (b[i] == a[j]).all(1)
    shared |= (b[i] == b[j]).all(1)
    i, j = i[~shared], j[~shared]
    return bool(arcs_cross(a[i], b[i], a[j], b[j]).any())


def _random_polygons(rng, cx, cy):
    """2-5 random star-shaped polygons (valid on the sphere) near (cx, cy), overlapping."""
    out = []
    for _ in range(rng.integers(2, 6)):
        n = rng.integers(3, 12)
        t = np.sort(rng.uniform(0, 2 * np.pi, n))
        r = rng.uniform(1, 6) * rng.uniform(0.4, 1.0, n)
        x, y = cx + rng.normal(0, 3), cy + rng.normal(0, 3)
        ring = np.column_stack([x + r * np.cos(t), np.clip(y + r * np.sin(t), -89, 89)])
        ring = np.vstack([ring, ring[:1]])
        try:
            gloffset.read({"type": "Polygon", "coordinates": [ring.tolist()]})
        except gloffset.errors.GloffsetError:
            continue
        if not _crosses_itself(ring):
            out.append(ring)
    return out


@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_random_overlapping_polygons_against_spherely():
    """Unions of random overlapping polygons, and a triangle sharing an edge with one of
    them, against S2's union (spherely), on points farther than 1e-8 rad from any edge."""
    import functools

    shapely = pytest.importorskip("shapely")
    spherely = pytest.importorskip("spherely")
    rng = np.random.default_rng(5)
    compared = 0
    for _ in range(40):
        cx, cy = rng.uniform(-170, 170), rng.uniform(-70, 70)
        polys = _random_polygons(rng, cx, cy)
        if len(polys) < 2:
            continue
        a, b = polys[0][0], polys[0][1]
        normal = np.array([-(b - a)[1], (b - a)[0]])
        polys.append(np.array([b, a, (a + b) / 2 - 0.5 * normal, b]))  # shares edge a-b
        ours = gloffset.read({"type": "MultiPolygon", "coordinates": [[p.tolist()] for p in polys]})
        theirs = functools.reduce(
            spherely.union, [spherely.from_wkt(shapely.to_wkt(shapely.Polygon(p))) for p in polys]
        )
        lon = cx + rng.uniform(-12, 12, 2000)
        lat = np.clip(cy + rng.uniform(-12, 12, 2000), -89.9, 89.9)
        edges = gloffset.read(
            {"type": "MultiLineString", "coordinates": [p.tolist() for p in polys]}
        )
        far = distance_xyz(edges, lonlat_to_xyz(lon, lat)) > 1e-8
        got = gloffset.contains(ours, lon[far], lat[far])
        want = spherely.contains(theirs, spherely.points(lon[far], lat[far]))
        assert np.array_equal(got, want)
        compared += 1
    assert compared > 20


def test_polygons_that_cross_themselves_unite_by_parity():
    """A polygon whose edges cross (invalid, or valid in lon/lat but not with great-circle
    edges, as 110m Sudan) counts by crossing parity; the union is still exact."""
    bowtie = [[0, 0], [10, 10], [10, 0], [0, 10], [0, 0]]
    square = [[8, 2], [14, 2], [14, 8], [8, 8], [8, 2]]
    both = gloffset.read(mp(bowtie, square))
    lon, lat = random_points((-2, -2, 16, 12), 20000, seed=4)
    want = gloffset.contains(gloffset.read(mp(bowtie)), lon, lat) | gloffset.contains(
        gloffset.read(mp(square)), lon, lat
    )
    edges = gloffset.read({"type": "MultiLineString", "coordinates": [bowtie, square]})
    far = distance_xyz(edges, lonlat_to_xyz(lon, lat)) > 1e-9
    assert np.array_equal(gloffset.contains(both, lon, lat)[far], want[far])
    for d in (-50e3, 50e3):
        got = gloffset.contains(both, lon, lat, distance=d)
        assert np.array_equal(got, gloffset.reference.contains_lonlat(both, lon, lat, distance=d))


@pytest.mark.slow  # 3 s; run by .ci/run with -m slow
def test_random_polygons_against_the_union_of_their_parts():
    """Random polygons, some whose edges cross each other, with a triangle sharing an edge:
    the united shape answers as "inside any part" does, each part read alone (the
    reference per part), on points farther than 1e-9 rad from every edge."""
    rng = np.random.default_rng(7)
    done = 0
    for _ in range(60):
        cx, cy = rng.uniform(-179, 179), rng.uniform(-80, 80)
        polys = []
        for _ in range(rng.integers(2, 6)):
            n = rng.integers(3, 12)
            t = rng.uniform(0, 2 * np.pi, n)
            t = np.sort(t) if rng.uniform() < 0.7 else t  # unsorted: edges cross
            r = rng.uniform(1, 6) * rng.uniform(0.4, 1.0, n)
            x, y = cx + rng.normal(0, 3), cy + rng.normal(0, 3)
            ring = np.column_stack([x + r * np.cos(t), np.clip(y + r * np.sin(t), -89, 89)])
            polys.append(np.vstack([ring, ring[:1]]))
        a, b = polys[0][0], polys[0][1]
        normal = np.array([-(b - a)[1], (b - a)[0]])
        polys.append(np.array([b, a, (a + b) / 2 - 0.5 * normal, b]))
        parts, kept = [], []
        for p in polys:
            if np.abs(p[:, 0]).max() > 180:
                continue
            try:
                part = gloffset.read({"type": "Polygon", "coordinates": [p.tolist()]})
            except gloffset.errors.GloffsetError:
                continue
            c = p[:-1].mean(axis=0)
            if gloffset.contains(part, [c[0] - 180 if c[0] > 0 else c[0] + 180], [-c[1]])[0]:
                continue  # a crossing ring taken inside out: not a useful case
            parts.append(part)
            kept.append(p)
        if len(parts) < 2:
            continue
        united = gloffset.read(mp(*[p.tolist() for p in kept]))
        lon = np.clip(cx + rng.uniform(-12, 12, 1500), -180, 180)
        lat = np.clip(cy + rng.uniform(-12, 12, 1500), -89.9, 89.9)
        edges = gloffset.read(
            {"type": "MultiLineString", "coordinates": [p.tolist() for p in kept]}
        )
        far = distance_xyz(edges, lonlat_to_xyz(lon, lat)) > 1e-9
        want = np.zeros(len(lon), bool)
        for part in parts:
            want |= gloffset.reference.contains_lonlat(part, lon, lat)
        got = gloffset.contains(united, lon, lat)
        assert np.array_equal(got[far], want[far])
        done += 1
    assert done > 30


def test_left_areas_of_many_rings_are_those_of_each_ring():
    from gloffset.region import left_area, left_areas

    world = gloffset.read(DATA / "world_110m.geojson")
    rings = world.rings
    at = np.concatenate([[0], np.cumsum([len(r) for r in rings])])
    got = left_areas(np.concatenate(rings), at)
    want = np.array([left_area(r) for r in rings])
    assert np.array_equal(got, want)
    # the union's holes are the rings with more than a hemisphere on their left
    assert np.array_equal(got > 2.0 * np.pi, world.ring_holes)
    assert (got > 0.0).all() and len(got) > 100


def assert_same_union(a, b):
    """Two shapes with the same union, bit for bit: rings, seams, groups, holes, labels."""
    assert len(a.rings) == len(b.rings) > 0
    for x, y in zip(a.rings, b.rings):
        assert x.shape == y.shape and x.tobytes() == y.tobytes()
    for x, y in zip(a.ring_seams, b.ring_seams):
        assert np.array_equal(x, y)
    assert np.array_equal(a.ring_groups, b.ring_groups)
    assert np.array_equal(a.ring_holes, b.ring_holes)
    assert a.labels == b.labels


@pytest.mark.parametrize(
    "path",
    [
        pytest.param("neighbours", id="france-and-neighbours-10m"),
        pytest.param("countries_10m.geojson", id="countries-10m", marks=pytest.mark.slow),
    ],
)
def test_union_is_the_same_whichever_grid_finds_the_edge_pairs(countries, path, monkeypatch):
    # the broad phase of the union's edge pairs (CapTree.self_pairs) puts pairs of
    # edges in its grid: the union is the one of the grid over single edges, bit for bit
    from conftest import NEIGHBOURS as FRANCE

    from gloffset.geometry import captree

    if path == "neighbours":
        src = {"type": "FeatureCollection", "features": [countries[n] for n in FRANCE]}
    else:
        src = DATA / path
    got = gloffset.read(src)
    monkeypatch.setattr(captree, "_PAIR_LEVEL", 0)
    assert_same_union(got, gloffset.read(src))
