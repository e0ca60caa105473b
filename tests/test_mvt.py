"""Vector tiles (MVT 2.1) of the offset region, judged by the float64 reference.

Tiles are decoded by ``mapbox-vector-tile`` (not by gloffset), their rings checked by
shapely in tile coordinates and against the spec's winding, every vertex against the exact
distance and sample points against the exact membership (:mod:`gloffset.reference`).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import gloffset
from gloffset import reference

mvt = pytest.importorskip("mapbox_vector_tile")
shapely = pytest.importorskip("shapely")
from shapely.geometry import Polygon  # noqa: E402
from shapely.geometry import shape as as_shape  # noqa: E402

from gloffset.mvt import vector_tile  # noqa: E402
from gloffset.mvt.geometry import TileFrame  # noqa: E402

R = gloffset.EARTH_RADIUS


def decode(tile: bytes, layer: str = "offset"):
    """The layer's features, coordinates as stored (``y`` down)."""
    dec = mvt.decode(tile, default_options={"y_coord_down": True})
    if layer not in dec:
        return []
    return dec[layer]["features"]


def shoelace(ring) -> float:
    r = np.asarray(ring, dtype=np.float64)
    return 0.5 * float(np.sum(r[:-1, 0] * r[1:, 1] - r[1:, 0] * r[:-1, 1]))


def polygons_of(geom):
    if geom["type"] == "Polygon":
        return [geom["coordinates"]]
    assert geom["type"] == "MultiPolygon", geom["type"]
    return geom["coordinates"]


def check_tile(shape, d, z, x, y, *, extent=4096, buffer=64, samples=400, seed=0, tile=None):
    """Decode and judge one tile; returns the decoded geometry (shapely, or None)."""
    da = d / R
    if tile is None:
        tile = vector_tile(shape, d, z, x, y, extent=extent, buffer=buffer)
    feats = decode(tile)
    assert len(feats) <= 1
    frame = TileFrame.of(z, x, y, extent, buffer)
    u0, v0, u1, v1 = frame.rect
    geom = None
    if feats:
        f = feats[0]
        assert f["properties"]["distance_m"] == pytest.approx(d)
        polys = polygons_of(f["geometry"])
        for poly in polys:
            # the spec's winding (y down): exterior positive area, holes negative
            assert shoelace(poly[0]) > 0
            for hole in poly[1:]:
                assert shoelace(hole) < 0
            p = Polygon(poly[0], poly[1:])
            assert p.is_valid, shapely.validation.explain_validity(p)
            assert p.area > 0
        geom = as_shape(f["geometry"])
        assert geom.is_valid, shapely.validation.explain_validity(geom)
        # every vertex off the buffer's edge lies within 1 unit of the exact boundary
        pts = np.array([c for poly in polys for ring in poly for c in ring], dtype=np.float64)
        on_edge = (
            (np.abs(pts[:, 0] - u0) < 1e-9)
            | (np.abs(pts[:, 0] - u1) < 1e-9)
            | (np.abs(pts[:, 1] - v0) < 1e-9)
            | (np.abs(pts[:, 1] - v1) < 1e-9)
        )
        if z == 0:
            on_edge |= np.abs(pts[:, 0] - extent / 2) < 1e-9
        pts = pts[~on_edge]
        if len(pts):
            xyz = frame.unproject(pts)
            unit = (2 * math.pi / ((1 << z) * extent)) * np.sqrt(1 - xyz[:, 2] ** 2)
            dist = reference.distance_xyz(shape, xyz)
            err = np.abs(dist - abs(da)) / unit
            assert err.max() <= 1.0, (err.max(), pts[np.argmax(err)])
    # points at least 2 units from the boundary lie on the right side
    rng = np.random.default_rng(seed)
    uv = rng.uniform([u0, v0], [u1, v1], size=(samples, 2))
    xyz = frame.unproject(uv)
    unit = (2 * math.pi / ((1 << z) * extent)) * np.sqrt(1 - xyz[:, 2] ** 2)
    want = reference.contains_xyz(shape, xyz, da)
    dist = reference.distance_xyz(shape, xyz)
    far = np.abs(dist - abs(da)) >= 2 * unit
    if da > 0:
        far |= reference.inside_xyz(shape, xyz)
    got = (
        shapely.contains_xy(geom, uv[:, 0], uv[:, 1])
        if geom is not None
        else np.zeros(len(uv), bool)
    )
    bad = far & (got != want)
    assert not bad.any(), (int(bad.sum()), uv[bad][:5], want[bad][:5])
    return geom, tile, want


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


MEXICO_TILES = [
    (0, 0, 0),
    (2, 0, 1),
    (4, 3, 6),
    (5, 7, 13),
    (6, 13, 27),
    (7, 28, 54),
    (8, 55, 111),
    (9, 110, 220),
    (11, 445, 889),
]


@pytest.mark.parametrize("zxy", MEXICO_TILES)
def test_mexico_tiles_match_the_reference(mexico, zxy):
    check_tile(mexico, 127e3, *zxy, samples=300)


def frontier_tiles(shape, d, z, n, seed=0):
    """``n`` tiles at zoom ``z`` that the boundary crosses (sampled near it)."""
    off = gloffset.offset(shape, d).resolve()
    pts = np.concatenate(off.sample(1e-3))
    lon = np.degrees(np.arctan2(pts[:, 1], pts[:, 0]))
    lat = np.degrees(np.arcsin(np.clip(pts[:, 2], -1, 1)))
    keep = np.abs(lat) < 85
    import mercantile

    tiles = sorted({tuple(mercantile.tile(a, b, z))[::1] for a, b in zip(lon[keep], lat[keep])})
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(tiles), size=min(n, len(tiles)), replace=False)
    return [(z, tiles[i][0], tiles[i][1]) for i in pick]


@pytest.mark.parametrize(
    "z", [5, pytest.param(8, marks=pytest.mark.slow), pytest.param(10, marks=pytest.mark.slow), 12]
)
def test_mexico_frontier_tiles_at_new_distances(mexico, z):
    for d in (33e3, -21e3):
        for zxy in frontier_tiles(mexico, d, z, 2, seed=z):
            check_tile(mexico, d, *zxy, samples=200)


def test_frontier_tile_holds_the_boundary(mexico):
    z, x, y = frontier_tiles(mexico, 127e3, 9, 1, seed=3)[0]
    geom, _, want = check_tile(mexico, 127e3, z, x, y, samples=400)
    assert geom is not None and want.any() and not want.all()
    assert geom.area < 4224**2 * 0.999


def test_inside_tile_is_one_square(mexico):
    # Mexico City's tile at zoom 10: wholly inside
    tile = vector_tile(mexico, 127e3, 10, 230, 456)
    feats = decode(tile)
    (poly,) = polygons_of(feats[0]["geometry"])
    assert len(poly) == 1
    assert sorted(map(tuple, poly[0][:-1])) == [(-64, -64), (-64, 4160), (4160, -64), (4160, 4160)]
    assert vector_tile(mexico, 127e3, 10, 230, 456) == tile


def test_outside_tile_has_no_feature(mexico):
    assert decode(vector_tile(mexico, 127e3, 10, 100, 300)) == []


@pytest.fixture(scope="module")
def world_shape(world):
    return world


def feature_shape(world, name):
    return gloffset.read(world[name])


@pytest.mark.parametrize(
    "name,d,zxy",
    [
        ("Fiji", 127e3, (4, 15, 8)),  # east of 180
        ("Fiji", 127e3, (4, 0, 8)),  # west of 180
        ("Fiji", 127e3, (1, 1, 1)),
        ("Fiji", 127e3, (0, 0, 0)),
        ("Russia", 200e3, (3, 7, 1)),
        ("Russia", 200e3, (3, 0, 1)),
        ("Russia", 200e3, (2, 0, 0)),  # up to 85 deg
        ("Russia", -150e3, (3, 5, 2)),
        ("Greenland", 300e3, (4, 6, 0)),  # the tile's top at 85.05 deg
        ("Antarctica", 100e3, (2, 1, 3)),
    ],
)
def test_world_seams_and_high_latitudes(world, name, d, zxy):
    check_tile(feature_shape(world, name), d, *zxy, samples=300)


def test_lines_and_points():
    shape = gloffset.read(
        {
            "type": "GeometryCollection",
            "geometries": [
                {"type": "LineString", "coordinates": [[-100, 20], [-95, 22], [-97, 25]]},
                {"type": "Point", "coordinates": [-99, 19]},
            ],
        }
    )
    for zxy in [(4, 3, 6), (6, 14, 27), (8, 57, 112)]:
        check_tile(shape, 80e3, *zxy, samples=300)


def test_layer_name_and_properties(mexico):
    tile = vector_tile(mexico, "127km", 4, 3, 6, layer="coast")
    feats = decode(tile, "coast")
    assert feats[0]["properties"] == {"distance_m": 127000.0, "distance": "127km"}


def test_no_needless_vertices(mexico):
    """No vertex where a straight segment would stay within half a unit."""
    geom, _, _ = check_tile(mexico, 127e3, 7, 28, 54, samples=10)
    for poly in getattr(geom, "geoms", [geom]):
        for ring in [poly.exterior, *poly.interiors]:
            c = np.asarray(ring.coords)[:-1]
            prev, nxt = np.roll(c, 1, axis=0), np.roll(c, -1, axis=0)
            seg = nxt - prev
            w = c - prev
            dev = np.abs(seg[:, 0] * w[:, 1] - seg[:, 1] * w[:, 0]) / np.maximum(
                np.hypot(*seg.T), 1e-9
            )
            # rounding moves each vertex by up to 0.71: a removable vertex would deviate
            # by no more than 0.5 + 2 x 0.71
            assert np.mean(dev < 0.5) < 0.05


@pytest.mark.parametrize(
    "kw,word",
    [
        ({"extent": 4000}, "power of two"),
        ({"extent": 4096.0}, "power of two"),
        ({"buffer": -1}, "buffer"),
        ({"buffer": 5000}, "buffer"),
    ],
)
def test_bad_options(mexico, kw, word):
    with pytest.raises(gloffset.OptionError, match=word):
        vector_tile(mexico, 127e3, 4, 3, 6, **kw)


def test_bad_tile(mexico):
    with pytest.raises(gloffset.InvalidGridError):
        vector_tile(mexico, 127e3, 4, 16, 6)


def test_decoded_by_json_roundtrip(mexico):
    # the tile decodes as GeoJSON-like dicts that json can write
    json.dumps(decode(vector_tile(mexico, 127e3, 5, 7, 13)))


def test_local_boundary_matches_the_resolved_one(world):
    """The local boundary (edges near the tile offset as lines) gives the same tile as the
    resolved one: Russia's edges near Chukotka at 200 km, whose offset as lines lost parts
    of the region before lines sharing an end were resolved right."""
    from gloffset.mvt.boundary import LocalBoundary, ResolvedBoundary
    from gloffset.mvt.tile import tile_geometry

    shape = feature_shape(world, "Russia")
    d = 200e3 / R
    a = tile_geometry(LocalBoundary(shape, d), 2, 0, 0)
    b = tile_geometry(ResolvedBoundary(shape, d), 2, 0, 0)
    assert a is not None and b is not None
    assert a.symmetric_difference(b).area < 1e-3 * b.area


@pytest.mark.parametrize(
    "name,d,zxy",
    [
        (None, 127e3, (7, 28, 54)),  # Mexico's Pacific coast
        (None, -21e3, (9, 110, 220)),
        ("Russia", 200e3, (3, 0, 1)),  # Chukotka, east of 180 deg
        ("Russia", 200e3, (3, 7, 1)),  # west of 180 deg
        ("Greenland", 300e3, (6, 27, 3)),  # 80 deg north
    ],
)
def test_tile_at_a_new_distance_resolves_only_the_edges_near_it(
    monkeypatch, mexico_path, world, name, d, zxy
):
    """A tile at a distance not yet resolved does not resolve the whole offset, and equals
    (byte for byte) the tile cut from the whole resolved boundary."""
    from gloffset.mvt.boundary import ResolvedBoundary
    from gloffset.mvt.tile import encode, tile_geometry
    from gloffset.units import distance_properties
    from gloffset.vector.offset import Offset

    shape = gloffset.read(mexico_path) if name is None else feature_shape(world, name)
    real = Offset.resolve

    def resolve(self, *args, **kwargs):
        assert self.shape is not shape, "the whole offset was resolved"
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Offset, "resolve", resolve)
    tile = vector_tile(shape, d, *zxy)
    assert len(shape.derived.mvt_boundaries) == 0
    monkeypatch.setattr(Offset, "resolve", real)
    whole = tile_geometry(ResolvedBoundary(shape, d / R), *zxy)
    assert whole is not None
    assert tile == encode(whole, "offset", distance_properties(d, R), 4096)
    check_tile(shape, d, *zxy, samples=100, tile=tile)


def test_a_kept_distance_uses_its_resolved_boundary(monkeypatch, mexico):
    """Once the whole offset is resolved and kept (a pyramid, a low zoom), tiles at that
    distance are cut from it."""
    from gloffset.mvt import boundary

    vector_tile(mexico, 45e3, 0, 0, 0)  # zoom 0: the whole offset, kept
    monkeypatch.setattr(boundary.LocalBoundary, "pieces", None)
    check_tile(mexico, 45e3, 7, 28, 54, samples=50)


@pytest.mark.slow  # many tiles of the check above
@pytest.mark.parametrize("name", ["Greenland", "Iceland", "islands: Croatia", "Mexico inward"])
def test_new_distance_tiles_equal_the_resolved_ones_at_random(mexico_path, name):
    """Seeded random frontier tiles z5-z11 at new distances: the tile from the edges near it
    (resolved inside its cap) equals the one cut from the whole resolved boundary, byte for
    byte, on fjord coasts and inward."""
    import json
    import math

    import mercantile

    from gloffset.mvt.boundary import ResolvedBoundary
    from gloffset.mvt.tile import encode, tile_geometry
    from gloffset.units import distance_properties

    if name == "Mexico inward":
        shape, lo, hi = gloffset.read(mexico_path), -60e3, -10e3
    else:
        fc = json.loads((mexico_path.parent / "countries_10m.geojson").read_text())
        want = name.split(": ")[-1]
        (feat,) = [f for f in fc["features"] if f["properties"]["name"] == want]
        shape, lo, hi = gloffset.read(feat), 20e3, 150e3
    rng = np.random.default_rng(7)
    local = 0
    for _ in range(10):
        d = float(rng.uniform(lo, hi))
        z = int(rng.integers(5, 12))
        whole = ResolvedBoundary(shape, d / R)
        pts = np.concatenate(gloffset.offset(shape, d).resolve().sample(1e-4))
        p = pts[rng.integers(len(pts))]
        lon = math.degrees(math.atan2(p[1], p[0]))
        lat = math.degrees(math.asin(max(-1.0, min(1.0, p[2]))))
        t = mercantile.tile(lon, lat, z)
        shape.derived.mvt_boundaries.clear()
        tile = vector_tile(shape, d, z, t.x, t.y)
        local += len(shape.derived.mvt_boundaries) == 0
        g = tile_geometry(whole, z, t.x, t.y)
        assert tile == encode(g, "offset", distance_properties(d, R), 4096), (name, d, z, t)
    if name in ("Greenland", "Mexico inward"):
        assert local >= 5  # most from the edges near them (small inputs: the whole offset)
