"""Self-intersection removal (paper Sec. 4.4): Algorithm 1 and the general method.

The general method is held to the float64 reference (gloffset.reference): every
boundary point at |d| from the curves, no point of the curves closer than |d|, rings
that do not cross, and the same region as the reference away from the boundary.
"""

import json

import numpy as np
import pytest

import gloffset
from gloffset.geometry.captree import CapTree
from gloffset.geometry.sphere import angle, lonlat_to_xyz, normalize
from gloffset.reference import contains_xyz, distance_xyz
from gloffset.vector.arcrings import sample_arc
from gloffset.vector.paper import algorithm1
from gloffset.vector.selfintersect import MIN_DISTANCE
from gloffset.vector.smallcircle import CircleArcs, intersect, position

EPS = 1e-9  # rad: boundary distance tolerance and the band ignored by region checks


# ----------------------------------------------------------------------------- helpers


def boundary_points(res, per_arc=5):
    """Points spread along every arc of every ring (ends and interior)."""
    out = []
    for ring in res.rings:
        q, r = ring.centers, ring.junctions
        start = np.roll(r, 1, axis=0)
        for t in np.linspace(0.0, 1.0, per_arc):
            out.append(sample_arc(q, start, r, np.full(len(q), t)))
    return normalize(np.concatenate(out)) if out else np.zeros((0, 3))


def assert_on_distance(shape, res, most=6000):
    """Boundary points lie at |d| from the curves: none closer, none farther (every
    arc's ends and middle points, thinned evenly to at most ``most`` points)."""
    pts = boundary_points(res)
    pts = pts[:: max(1, len(pts) // most)]
    if len(pts):
        err = np.abs(distance_xyz(shape, pts) - abs(res.distance))
        assert err.max() < EPS, err.max()


def assert_rings_simple(res, tol=1e-10):
    """No two arcs of the result cross away from their end points."""
    if not res.rings:
        return
    q = np.concatenate(res.centers)
    end = np.concatenate(res.junctions)
    start = np.concatenate([np.roll(r, 1, axis=0) for r in res.junctions])
    arcs = CircleArcs(normalize(q), np.linalg.norm(q, axis=1), start, end)
    cm, cr = arcs.caps()
    ia, ib = CapTree(cm, cr).self_pairs()
    x, ok, err, _ = intersect(arcs.axis[ia], arcs.rho[ia], arcs.axis[ib], arcs.rho[ib])
    for s in range(2):
        inner = ok.copy()
        for idx in (ia, ib):
            t = position(arcs.axis[idx], arcs.h[idx], arcs.start[idx], arcs.sign[idx], x[:, s])
            margin = (tol + err) / arcs.sin_radius[idx]
            inner &= (t > margin) & (t < np.abs(arcs.phi[idx]) - margin)
        assert not inner.any(), f"{inner.sum()} arc pairs cross"


def sample_near(shape, d, n, seed=0):
    """Points around the shape's vertices, within about 2|d| of them, and uniform ones."""
    rng = np.random.default_rng(seed)
    v = np.concatenate(shape.rings + shape.lines)
    base = v[rng.integers(0, len(v), n)]
    near = normalize(base + rng.normal(size=(n, 3)) * 1.5 * abs(d))
    return np.vstack([near, normalize(rng.normal(size=(n // 4, 3)))])


def assert_region(shape, res, n=2000, seed=0):
    """The rings bound the reference region, except within EPS of its boundary."""
    d = res.distance
    p = sample_near(shape, d, n, seed)
    keep = np.abs(distance_xyz(shape, p) - abs(d)) > EPS
    p = p[keep]
    ref = contains_xyz(shape, p, d)
    mine = res.contains_xyz(p)
    assert np.array_equal(ref, mine), f"{np.count_nonzero(ref != mine)} of {len(p)} differ"


def check(shape, d, method="general", n=2000):
    res = gloffset.offset(shape, d, radius=1.0).resolve(method)
    assert res.unlinked == 0
    assert_on_distance(shape, res)
    assert_rings_simple(res)
    assert_region(shape, res, n)
    return res


def poly(coords):
    return gloffset.read({"type": "Polygon", "coordinates": coords})


def star(n=7, r_out=10.0, r_in=4.0, start_inner=False):
    t = np.linspace(0.0, 2.0 * np.pi, 2 * n, endpoint=False)
    r = np.where((np.arange(2 * n) % 2 == 0) != start_inner, r_out, r_in)
    return gloffset.Shape.from_lonlat(r * np.cos(t), r * np.sin(t), closed=True)


# a square with a bay 2 degrees wide and 8 deep
BAY = [[[0, 0], [10, 0], [10, 10], [6, 10], [6, 2], [4, 2], [4, 10], [0, 10], [0, 0]]]
# a square room reached through a corridor 1 degree wide
KEYHOLE = [
    [
        [0, 0],
        [20, 0],
        [20, 20],
        [10.5, 20],
        [10.5, 16],
        [16, 16],
        [16, 4],
        [4, 4],
        [4, 16],
        [9.5, 16],
        [9.5, 20],
        [0, 20],
        [0, 0],
    ]
]
# two squares joined by a neck 1 degree wide
DUMBBELL = [[[0, 0], [8, 0], [8, 3.5], [12, 3.5], [12, 0], [20, 0], [20, 8], [12, 8], [12, 4.5],
             [8, 4.5], [8, 8], [0, 8], [0, 0]]]  # fmt: skip


# ----------------------------------------------------------------------------- maths and index


@pytest.mark.parametrize("r2", [1e-7, 0.01, 1.0, np.pi / 2])
def test_circle_intersections(r2):
    """Points common to two circles lie on both to 1e-15, small circles included."""
    rng = np.random.default_rng(int(r2 * 1e7) % 1000)
    a1 = normalize(rng.normal(size=(500, 3)))
    r1 = rng.uniform(1e-7, 1.5, 500)
    # the second axis at a distance that makes the circles meet
    g = rng.uniform(np.abs(r1 - r2), np.minimum(r1 + r2, np.pi))
    perp = normalize(np.cross(a1, rng.normal(size=(500, 3))))
    a2 = np.cos(g)[:, None] * a1 + np.sin(g)[:, None] * perp
    x, ok, err, _ = intersect(a1, r1, a2, np.full(500, r2))
    assert ok.mean() > 0.99
    for s in range(2):
        assert np.abs(angle(x[ok, s], a1[ok]) - r1[ok]).max() < 1e-15
        assert np.abs(angle(x[ok, s], a2[ok]) - r2).max() < 1e-15
    assert (err[ok] < 1e-6).all()


def test_captree_queries_are_supersets():
    rng = np.random.default_rng(7)
    c = normalize(np.cumsum(rng.normal(size=(3000, 3)) * 0.01, axis=0) + [3.0, 0.0, 0.0])
    r = rng.uniform(0.0, 0.004, len(c))
    tree = CapTree(c, r, reps=c)
    ia, ib = tree.self_pairs()
    got = set(zip(ia.tolist(), ib.tolist()))
    dist = angle(c[:, None], c[None])
    want = {(i, j) for i, j in zip(*np.nonzero(dist <= r[:, None] + r[None])) if i < j}
    assert want <= got
    p = normalize(c[::7] + rng.normal(size=(len(c[::7]), 3)) * 0.01)
    reach = rng.uniform(0.0, 0.02, len(p))
    qi, ii, _ = tree.near(p, reach)
    got = set(zip(qi.tolist(), ii.tolist()))
    dist = angle(p[:, None], c[None])
    want = set(zip(*np.nonzero(dist <= reach[:, None] + r[None])))
    assert want <= got
    a, b = p[:-1], p[1:]
    si, ii = tree.along(a, b)
    got = set(zip(si.tolist(), ii.tolist()))
    for k in range(0, len(a), 25):
        near = np.nonzero(gloffset.geometry.sphere.arc_distance(c, a[k], b[k]) <= r)[0]
        assert {(k, int(i)) for i in near} <= got


@pytest.mark.parametrize("start_inner", [False, True])
@pytest.mark.parametrize("d", [0.01, 0.05])
def test_paper_concave_corners(start_inner, d):
    """Fig. 10d: loops at concave corners, including one across the ring's start."""
    res = check(star(start_inner=start_inner), d, method="paper")
    assert len(res.rings) == 1 and res.method == "paper"


@pytest.mark.parametrize("d", [0.01, 0.02, 0.05])
def test_paper_closes_a_bay(d):
    check(poly(BAY), d, method="paper")


def test_paper_index_gives_the_published_scan():
    for shape, d in [(star(), 0.03), (star(start_inner=True), 0.05), (poly(BAY), 0.02)]:
        off = gloffset.offset(shape, d, radius=1.0)
        q, r = off.centers[0], off.junctions[0]
        k1, r1 = algorithm1(q, r, index=True)
        k2, r2 = algorithm1(q, r, index=False)
        assert np.array_equal(k1, k2) and np.array_equal(r1, r2)


def test_paper_limits():
    """What the paper leaves open: no holes, and no union of separate parts."""
    off = gloffset.offset(poly(KEYHOLE), 0.012, radius=1.0)
    assert off.resolve("paper").holes.sum() == 0
    assert off.resolve("general").holes.sum() == 1
    two = gloffset.read(
        {"type": "MultiPolygon", "coordinates": [[[[0, 0], [5, 0], [5, 5], [0, 5], [0, 0]]],
                                                 [[[6, 0], [11, 0], [11, 5], [6, 5], [6, 0]]]]}
    )  # fmt: skip
    off = gloffset.offset(two, 0.02, radius=1.0)
    assert len(off.resolve("paper").rings) == 2
    assert len(off.resolve("general").rings) == 1


# ----------------------------------------------------------------------------- general method


@pytest.mark.parametrize("d", [0.01, 0.02, 0.05, -0.005, -0.02])
def test_bay(d):
    res = check(poly(BAY), d)
    assert len(res.polygons) == (2 if d == -0.02 else 1) and not res.holes.any()


def test_bay_narrower_than_2d_closes_off_a_room():
    res = check(poly(KEYHOLE), 0.012)  # corridor 0.0175 rad < 2d, room far wider
    assert len(res.polygons) == 1 and res.holes.sum() == 1
    assert len(res.polygons[0][1]) == 1
    assert not check(poly(KEYHOLE), 0.007).holes.any()  # corridor stays open


def test_inward_offset_splits_a_polygon():
    res = check(poly(DUMBBELL), -0.012)  # neck 0.0175 rad < 2|d|
    assert len(res.polygons) == 2 and not res.holes.any()
    assert len(check(poly(DUMBBELL), -0.007).polygons) == 1


def test_loop_longer_than_half_the_ring():
    """A bay whose walls hold most vertices: its loop needs more than |Q|/2 arcs removed."""
    wall = np.linspace(10.0, 2.0, 40)
    coords = (
        [[0, 0], [10, 0], [10, 10], [6, 10]]
        + [[6, y] for y in wall[1:]]
        + [[4, y] for y in wall[::-1][:-1]]
        + [[4, 10], [0, 10], [0, 0]]
    )
    shape = poly([coords])
    off = gloffset.offset(shape, 0.02, radius=1.0)
    q = off.centers[0]
    res = check(shape, 0.02)
    assert len(res.rings) == 1
    # Algorithm 1 keeps the wrong side of that loop (it assumes fewer than |Q|/2 arcs go)
    assert len(q) > 150
    paper = off.resolve("paper")
    p = sample_near(shape, 0.02, 500)
    assert (paper.contains_xyz(p) != contains_xyz(shape, p, 0.02)).mean() > 0.1


@pytest.mark.parametrize("d", [0.003, 0.01])
def test_lines_whose_sides_meet(d):
    hairpin = {"type": "LineString", "coordinates": [[0, 0], [3, 0], [3, 0.4], [0, 0.4]]}
    check(gloffset.read(hairpin), d)
    loop = {"type": "LineString", "coordinates": [[0, 0], [2, 0], [2, 2], [0.1, 0.05]]}
    res = check(gloffset.read(loop), d)
    assert res.holes.sum() == 1  # the triangle the line almost closes keeps a hole
    crossing = {"type": "LineString", "coordinates": [[0, 0], [2, 2], [2, 0], [0, 2]]}
    check(gloffset.read(crossing), d)


def test_union_of_separate_parts():
    shape = gloffset.read(
        {
            "type": "GeometryCollection",
            "geometries": [
                {"type": "Polygon", "coordinates": [[[0, 0], [5, 0], [5, 5], [0, 5], [0, 0]]]},
                {"type": "Polygon", "coordinates": [[[6, 0], [11, 0], [11, 5], [6, 5], [6, 0]]]},
                {"type": "LineString", "coordinates": [[-3, -1], [14, -1]]},
                {"type": "Point", "coordinates": [5.5, 7]},
                {"type": "Point", "coordinates": [30, 30]},
            ],
        }
    )
    res = check(shape, 0.02)
    assert len(res.polygons) == 2  # everything but the far point merges
    res = check(shape, -0.01)  # the line and points carve nothing outside the polygons
    assert len(res.polygons) == 2


def test_holes_and_lines_inside_polygons():
    square = [
        [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]],
        [[4, 4], [4, 6], [6, 6], [6, 4], [4, 4]],
    ]
    shape = poly(square)
    assert check(shape, -0.01).holes.sum() == 1
    assert check(shape, 0.01).holes.sum() == 1
    assert check(shape, 0.02).holes.sum() == 0  # the hole fills up
    with_line = gloffset.read(
        {
            "type": "GeometryCollection",
            "geometries": [
                {"type": "Polygon", "coordinates": square[:1]},
                {"type": "LineString", "coordinates": [[2, 2], [2, 8]]},
            ],
        }
    )
    assert check(with_line, -0.005).holes.sum() == 1  # the line carves a hole inward


@pytest.mark.parametrize("eps", [1e-9, -1e-9, 1e-13])
def test_near_tangent_disks(eps):
    """Two disks that nearly touch: no sliver, no lost component."""
    d = 0.01
    a = np.radians(0.0)
    gap = 2.0 * d * (1.0 + eps)
    shape = gloffset.read(
        {
            "type": "MultiPoint",
            "coordinates": [[np.degrees(a), 0.0], [np.degrees(a + gap), 0.0]],
        }
    )
    res = check(shape, d, n=4000)
    assert res.unlinked == 0
    assert len(res.polygons) == (1 if eps < 0 else 2) or eps == 1e-13


@pytest.mark.parametrize("eps", [1e-6, -1e-6, 1e-8, -1e-8])
def test_near_tangent_facing_edges(eps):
    """Two squares whose facing (meridian) edges are 2d apart on the equator, give or
    take eps: their offsets nearly coincide there. The meridians converge, so for
    eps > 0 the offsets still overlap off the equator and enclose a thin hole, at
    most 2 eps d wide; a gap narrower than 1e-9 rad is closed rather than kept."""
    d = 0.01
    w = np.degrees(2 * d * (1 + eps))
    shape = gloffset.read(
        {
            "type": "MultiPolygon",
            "coordinates": [
                [[[0, -5], [5, -5], [5, 5], [0, 5], [0, -5]]],
                [[[-w, -3], [-w, 3], [-w - 5, 3], [-w - 5, -3], [-w, -3]]],
            ],
        }
    )
    res = check(shape, d, n=4000)
    assert len(res.polygons) == 1
    assert res.holes.sum() == (1 if eps == 1e-6 else 0)


def test_self_intersecting_input_matches_the_reference():
    bowtie = poly([[[0, 0], [4, 4], [4, 0], [0, 4], [0, 0]]])
    for d in (0.01, -0.003):
        check(bowtie, d)


def test_tiny_distances_and_errors():
    for d in (1e-6, -1e-6):
        check(star(), d)
    off = gloffset.offset(star(), MIN_DISTANCE / 2, radius=1.0)
    with pytest.raises(gloffset.InvalidDistanceError, match="too small"):
        off.resolve()
    with pytest.raises(ValueError, match="method"):
        off.resolve("nope")


def test_result_api():
    off = gloffset.offset(poly(KEYHOLE), 0.012, radius=1.0)
    res = off.resolve()
    assert res is off.resolve()  # cached
    assert len(res.centers) == len(res.junctions) == len(res.rings)
    for q, r in zip(res.centers, res.junctions):
        assert q.shape == r.shape and q.shape[1] == 3
    # Gauss-Bonnet area against a Monte Carlo estimate on a lon/lat box
    rng = np.random.default_rng(3)
    lon, lat = (
        rng.uniform(-3, 23, 200_000),
        np.degrees(np.arcsin(rng.uniform(np.sin(np.radians(-3)), np.sin(np.radians(23)), 200_000))),
    )
    box = np.radians(26) * (np.sin(np.radians(23)) - np.sin(np.radians(-3)))
    frac = res.contains_xyz(lonlat_to_xyz(lon, lat)).mean()
    assert res.area() == pytest.approx(frac * box, rel=0.01)
    assert "1 holes" in repr(res)


def test_geojson_holes_and_raw(tmp_path):
    off = gloffset.offset(poly(KEYHOLE), 0.012, radius=1.0)
    geom = off.to_geojson()["geometry"]
    assert geom["type"] == "Polygon" and len(geom["coordinates"]) == 2
    shapely = pytest.importorskip("shapely")
    g = shapely.geometry.shape(geom)
    assert g.is_valid and len(g.interiors) == 1
    raw = off.to_geojson(raw=True)["geometry"]
    assert raw["type"] == "MultiLineString"
    assert not shapely.geometry.shape(raw).is_simple  # the raw rings loop over themselves


def test_cli_resolves_by_default(tmp_path):
    from click.testing import CliRunner

    from gloffset.cli import main

    src = tmp_path / "keyhole.geojson"
    src.write_text(json.dumps({"type": "Polygon", "coordinates": KEYHOLE}))
    out = {}
    for flags in ([], ["--raw"], ["--method", "paper"]):
        r = CliRunner().invoke(main, ["offset", str(src), "-d", "0.012rad", *flags])
        assert r.exit_code == 0, r.output
        out[" ".join(flags)] = json.loads(r.output)["features"][0]["geometry"]
    assert out[""]["type"] == "Polygon" and len(out[""]["coordinates"]) == 2  # with its hole
    assert out["--raw"] != out[""] and out["--method paper"] != out[""]


# ----------------------------------------------------------------------------- real data


@pytest.mark.slow  # 7-25 s on 2 cores: run by .ci/run with -m slow
def test_world_countries(world):
    """Every Natural Earth 110m country at an outward and an inward distance; the
    antimeridian (Fiji, Russia) and the pole (Antarctica) included."""
    for name, feat in world.items():
        shape = gloffset.read(feat)
        for d in (0.05, 0.01, -0.004):
            res = gloffset.offset(shape, d, radius=1.0).resolve()
            assert res.unlinked == 0, name
            assert_on_distance(shape, res)
            assert_region(shape, res, n=200, seed=len(name))
    for name in ("Fiji", "Russia", "Antarctica", "Chile", "Indonesia"):
        for d in (0.05, 0.002, -0.02, 1e-5):
            check(gloffset.read(world[name]), d, n=1000)


@pytest.mark.slow  # 7-25 s on 2 cores: run by .ci/run with -m slow
def test_mexico_10m(mexico_path):
    shape = gloffset.read(mexico_path)
    for d in (0.02, -0.005, 1e-4):
        res = check(shape, d, n=1500)
        feat = gloffset.offset(shape, d, radius=1.0).to_geojson(tolerance=1e-5)
        json.dumps(feat)
        assert res.polygons


def _lonlat_lines(lines_xyz):
    from gloffset.geometry.sphere import xyz_to_lonlat

    out = []
    for line in lines_xyz:
        lon, lat = xyz_to_lonlat(line)
        out.append(np.column_stack([lon, lat]).tolist())
    return {"type": "MultiLineString", "coordinates": out}


def _pieces(ring, k):
    """A ring cut into open lines of ``k`` edges, each starting where the last ends."""
    closed = np.vstack([ring, ring[:1]])
    return [closed[i : i + k + 1] for i in range(0, len(ring), k)]


def test_lines_that_share_an_end():
    """Two lines that meet at a vertex of Russia's border (Franz Josef Land) at 200 km:
    their round caps lie on one circle, which the edge arcs leaving it touch; the
    crossings there were placed ~1e-8 off, the two copies of the cap were not seen as
    one, and the whole region was lost (0 rings)."""
    lines = {
        "type": "MultiLineString",
        "coordinates": [
            [[49.79368452332071, 80.4154277615482], [51.13618655783127, 80.54728017854094]],
            [[51.13618655783127, 80.54728017854094], [50.03976769389462, 80.91888540315178]],
        ],
    }
    shape = gloffset.read(lines)
    res = check(shape, 200e3 / gloffset.EARTH_RADIUS)
    assert len(res.polygons) == 1
    one = gloffset.read(
        {"type": "LineString", "coordinates": lines["coordinates"][0] + lines["coordinates"][1][1:]}
    )
    assert res.area() == pytest.approx(
        gloffset.offset(one, 200e3 / gloffset.EARTH_RADIUS, radius=1.0).resolve().area(), rel=1e-9
    )


@pytest.mark.parametrize("name, d, k", [("Russia", 200e3, 5), ("Mexico", 127e3, 3)])
def test_borders_cut_into_lines(world, name, d, k):
    """A country's border given as many lines that touch end to end: the region is
    the band around the whole border, as the reference has it."""
    shape = gloffset.read(world[name])
    lines = [p for ring in shape.rings for p in _pieces(ring, k)]
    cut = gloffset.read(_lonlat_lines(lines))
    res = check(cut, d / gloffset.EARTH_RADIUS, n=3000)
    whole = gloffset.read(_lonlat_lines([np.vstack([r, r[:1]]) for r in shape.rings]))
    same = gloffset.offset(whole, d / gloffset.EARTH_RADIUS, radius=1.0).resolve()
    assert len(res.rings) == len(same.rings)
    # the outside point the rings are sorted from may lie in a hole with no exterior
    # around it (Russia's inside, for the cut border): the area holds all the same
    assert res.area() == pytest.approx(same.area(), rel=1e-9)


@pytest.mark.parametrize("d", [20e3, 127e3])
def test_line_and_its_copy_off_by_rounding(world, d):
    """A stretch of Mexico's border and the same stretch run back, one latitude one
    unit in the last place off (a border given by both countries): their edge arcs lie
    on circles 3e-15 rad apart, whose crossing no error bound places (it was taken as
    lying at every arc's end, which merged far nodes: 60% too much area at 20 km)."""
    ring = gloffset.read(world["Mexico"]).rings[0]
    stretch = _lonlat_lines([ring[:7]])["coordinates"][0]
    back = [list(p) for p in stretch[::-1]]
    back[3][1] = float(np.nextafter(back[3][1], 90.0))
    both = gloffset.read({"type": "MultiLineString", "coordinates": [stretch, back]})
    res = check(both, d / gloffset.EARTH_RADIUS, n=4000)
    one = gloffset.read({"type": "LineString", "coordinates": stretch})
    alone = gloffset.offset(one, d / gloffset.EARTH_RADIUS, radius=1.0).resolve()
    assert res.area() == pytest.approx(alone.area(), rel=1e-9)


def test_rings_cut_at_the_antimeridian_as_lines(world):
    """Russia's and Fiji's rings as lines: they meet end to end, and the two sides of
    each seam (+-180 deg) are copies of one edge that differ by rounding."""
    parts = gloffset.io.geojson.parse(
        {"type": "FeatureCollection", "features": [world["Russia"], world["Fiji"]]}
    )
    rings = [r.tolist() for poly in parts.polygons for r in poly]
    lines = gloffset.read({"type": "MultiLineString", "coordinates": rings})
    check(lines, 0.01, n=4000)


def test_edge_two_metres_long_between_lines():
    """Three lines along Russia's border (Caspian coast near 48.58 E), the middle one an
    edge 2 m long: the caps at its ends nearly coincide, and a doubtful detour between
    them (a sliver below 1e-9 rad) left the tangent certain edge arc unlinked."""
    lines = {
        "type": "MultiLineString",
        "coordinates": [
            [[47.98728315612598, 41.40581920019423], [48.58435339611342, 41.80886879162067]],
            [[48.58435339611342, 41.80886879162067], [48.58437000000015, 41.808880000000045]],
            [[48.58437000000015, 41.808880000000045], [47.49252000000007, 42.98658000000012]],
        ],
    }
    check(gloffset.read(lines), 127e3 / gloffset.EARTH_RADIUS)


# ----------------------------------------------------------------------------- S2 cross-check


def _s2_polygon(s2, rings):
    loops = []
    for ring in rings:
        lon, lat = gloffset.geometry.sphere.xyz_to_lonlat(ring)
        loop = s2.S2Loop(
            [s2.S2LatLng.FromDegrees(float(b), float(a)).ToPoint() for a, b in zip(lon, lat)]
        )
        loop.Normalize()
        loops.append(loop)
    poly = s2.S2Polygon()
    poly.InitNested(loops)
    return poly


@pytest.mark.parametrize(
    "name, d", [("Mexico", 0.02), ("Mexico", 0.005), ("Chile", 0.01), ("Canada", 0.003)]
)
def test_against_s2_buffer(world, name, d):
    """S2BufferOperation agrees within its stated error (error_fraction * radius)."""
    s2 = pytest.importorskip("s2geometry")
    shape = gloffset.read(world[name])
    res = gloffset.offset(shape, d, radius=1.0).resolve()
    frac = 1e-4
    out = s2.S2Polygon()
    opts = s2.S2BufferOperationOptions()
    opts.set_buffer_radius(s2.S1Angle.Radians(d))
    opts.set_error_fraction(frac)
    op = s2.S2BufferOperation(s2.S2PolygonLayer(out), opts)
    op.AddPolygon(_s2_polygon(s2, shape.rings))
    assert op.Build()
    band = frac * d + 1e-9
    # membership agrees wherever the distance is outside S2's error band
    p = sample_near(shape, d, 3000, seed=5)
    far = np.abs(distance_xyz(shape, p) - d) > 2 * band
    p = p[far]
    lon, lat = gloffset.geometry.sphere.xyz_to_lonlat(p)
    s2_in = np.array(
        [
            out.Contains(s2.S2LatLng.FromDegrees(float(b), float(a)).ToPoint())
            for a, b in zip(lon, lat)
        ]
    )
    assert np.array_equal(s2_in, res.contains_xyz(p))
    # the symmetric difference is a band along the boundary no wider than S2's error
    perimeter = sum(float(np.sum(angle(r, np.roll(r, -1, axis=0)))) for r in res.sample(1e-7))
    assert abs(out.GetArea() - res.area()) <= perimeter * band
