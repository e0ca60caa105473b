"""CapTree.self_pairs: its grid broad phase returns exactly the pairs of its chord test."""

import numpy as np
import pytest
from conftest import DATA

import gloffset
from gloffset.geometry import captree
from gloffset.geometry.caps import arc_cap, chord, pad
from gloffset.geometry.captree import CapTree, _grid_pairs
from gloffset.geometry.sphere import angle, arcs_cross, normalize


def brute_pairs(c, r_padded, slack):
    """Every pair i < j that passes the chord test of self_pairs (all n^2 pairs)."""
    ii, jj = np.triu_indices(len(c), 1)
    d2 = np.einsum("ij,ij->i", c[ii] - c[jj], c[ii] - c[jj])
    ok = d2 <= pad(chord(r_padded[ii] + r_padded[jj] + slack)) ** 2
    return ii[ok], jj[ok]


def mixed_caps(n, seed):
    """Caps along random walks, radii from 1e-12 rad to pi (most tiny, a few huge)."""
    rng = np.random.default_rng(seed)
    c = normalize(np.cumsum(rng.normal(size=(n, 3)) * 0.003, axis=0) + rng.normal(size=3))
    c[::50] = normalize(rng.normal(size=(len(c[::50]), 3)))  # scattered ones
    r = 10.0 ** rng.uniform(-12, -2.5, n)
    r[::97] = rng.uniform(0.0, np.pi, len(r[::97]))  # a few caps of any size
    r[::31] = 0.0
    return c, r


@pytest.fixture(params=[0, 1, 2], ids=["items", "pairs", "fours"])
def pair_level(request, monkeypatch):
    """self_pairs with its grid over the items, or over the nodes of level 1 or 2."""
    monkeypatch.setattr(captree, "_PAIR_LEVEL", request.param)
    return request.param


@pytest.mark.parametrize("slack", [0.0, 2e-12, 1e-3, 0.5])
@pytest.mark.parametrize("seed", [0, 1])
def test_self_pairs_equal_the_chord_test_of_every_pair(slack, seed, pair_level):
    c, r = mixed_caps(1500, seed)
    tree = CapTree(c, r)
    i, j = tree.self_pairs(slack)
    wi, wj = brute_pairs(tree.centers[0], tree.radii[0], slack)
    # the same pairs, sorted by i then j
    assert np.array_equal(i, wi) and np.array_equal(j, wj)
    assert len(i) > 0


def test_self_pairs_hold_every_pair_of_caps_that_meet(pair_level):
    c, r = mixed_caps(1200, 5)
    i, j = CapTree(c, r).self_pairs()
    got = set(zip(i.tolist(), j.tolist()))
    dist = angle(c[:, None], c[None])
    want = {(a, b) for a, b in zip(*np.nonzero(dist <= r[:, None] + r[None])) if a < b}
    assert want <= got


def test_grid_pairs_find_balls_that_touch_across_cell_faces():
    # balls of one size on a line whose spacing equals two radii: each touches the next,
    # many across the faces, edges and corners of cells
    rng = np.random.default_rng(3)
    axis = normalize(rng.normal(size=3))
    start = normalize(rng.normal(size=3))
    t = np.linspace(0.0, 2.0, 4001)
    side = normalize(np.cross(axis, start))
    p = normalize(np.cos(t)[:, None] * start + np.sin(t)[:, None] * side)
    step = np.linalg.norm(p[1:] - p[:-1], axis=1)
    ext = np.full(len(p), 0.5 * step.max())
    ii, jj = _grid_pairs(p, ext)
    got = set(zip(ii.tolist(), jj.tolist()))
    assert {(k, k + 1) for k in range(len(p) - 1)} <= got
    assert (ii < jj).all() and len(got) == len(ii)  # each pair once


def test_self_pairs_of_real_borders_hold_every_crossing_and_shared_vertex(pair_level):
    shape = gloffset.read(DATA / "world_110m.geojson")
    rings = shape.rings[:30]  # about 1500 edges: all their pairs fit in memory
    a = np.concatenate(rings)
    sizes = np.array([len(x) for x in rings])
    starts = np.repeat(np.concatenate([[0], np.cumsum(sizes)[:-1]]), sizes)
    b = a[starts + (np.arange(len(a)) - starts + 1) % np.repeat(sizes, sizes)]
    tree = CapTree(*arc_cap(a, b))
    i, j = tree.self_pairs(2e-12)
    wi, wj = brute_pairs(tree.centers[0], tree.radii[0], 2e-12)
    assert np.array_equal(i, wi) and np.array_equal(j, wj)
    # every pair of edges that share a vertex or cross is a candidate
    got = set(zip(i.tolist(), j.tolist()))
    ii, jj = np.triu_indices(len(a), 1)
    meet = (a[ii] == b[jj]).all(axis=1) | (b[ii] == a[jj]).all(axis=1)
    meet |= arcs_cross(a[ii], b[ii], a[jj], b[jj])
    assert set(zip(ii[meet].tolist(), jj[meet].tolist())) <= got
    assert meet.sum() > len(a) // 2


def brute_along(tree, a, b, lo=None, hi=None):
    """Every (segment, item) pair that along's item test keeps (all pairs)."""
    from gloffset.geometry.captree import _PAD
    from gloffset.geometry.sphere import arc_distance, robust_cross

    n = normalize(robust_cross(a, b))
    si, ni = np.divmod(np.arange(len(a) * tree.n), tree.n)
    if lo is not None:
        inr = (ni >= lo[si]) & (ni < hi[si])
        si, ni = si[inr], ni[inr]
    c, r = tree.centers[0], tree.radii[0]
    keep = arc_distance(c[ni], a[si], b[si], n[si]) <= pad(r[ni], abs_=_PAD)
    return set(zip(si[keep].tolist(), ni[keep].tolist()))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_along_returns_exactly_the_items_its_distance_test_keeps(seed):
    # the nodes above the items are pruned by cheaper necessary conditions; the answer
    # is still every item whose exact distance to the segment is within its radius
    c, r = mixed_caps(1500, seed)
    tree = CapTree(c, r)
    rng = np.random.default_rng(seed)
    a = normalize(rng.normal(size=(60, 3)))
    b = normalize(a + rng.normal(size=(60, 3)) * 10.0 ** rng.uniform(-6, 0.2, (60, 1)))
    a[:10] = c[rng.integers(0, len(c), 10)]  # segments from item centres
    b[10:15] = a[10:15]  # points
    si, ni = tree.along(a, b)
    got = set(zip(si.tolist(), ni.tolist()))
    assert len(got) == len(si)
    want = brute_along(tree, a, b)
    assert got == want and len(want) > 20
    lo = rng.integers(0, 1000, len(a))
    hi = lo + rng.integers(1, 600, len(a))
    si, ni = tree.along(a, b, lo=lo, hi=hi)
    assert set(zip(si.tolist(), ni.tolist())) == brute_along(tree, a, b, lo, hi)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_near_with_item_ranges_returns_the_pairs_without_them_that_lie_in_range(seed):
    # the union's inner points ask for the edges of their own polygon only: the walk
    # drops the nodes outside every range of its queries, and no pair in range is lost
    c, r = mixed_caps(1500, seed)
    tree = CapTree(c, r)
    rng = np.random.default_rng(seed)
    p = normalize(rng.normal(size=(200, 3)))
    p[:100] = c[rng.integers(0, len(c), 100)]  # points among the items
    reach = 10.0 ** rng.uniform(-6, -0.5, len(p))
    qi, di, _ = tree.near(p, reach)
    lo = rng.integers(0, 1400, len(p))
    hi = lo + rng.integers(0, 300, len(p))
    inr = (di >= lo[qi]) & (di < hi[qi])
    want = set(zip(qi[inr].tolist(), di[inr].tolist()))
    assert len(want) > 50
    qi, di, _ = tree.near(p, reach, lo=lo, hi=hi)
    assert ((di >= lo[qi]) & (di < hi[qi])).all()
    assert set(zip(qi.tolist(), di.tolist())) == want and len(want) == len(qi)


def test_along_in_blocks_of_segments_returns_the_pairs_of_one_walk_in_its_order(monkeypatch):
    c, r = mixed_caps(1500, 3)
    tree = CapTree(c, r)
    rng = np.random.default_rng(3)
    a = normalize(rng.normal(size=(100, 3)))
    b = normalize(a + rng.normal(size=(100, 3)) * 10.0 ** rng.uniform(-6, 0.2, (100, 1)))
    lo = rng.integers(0, 1000, len(a))
    hi = lo + rng.integers(1, 600, len(a))
    hi[:30:3], hi[1:30:3] = lo[:30:3], lo[1:30:3] + rng.integers(1, 3, 10)  # empty, 1 or 2
    lo[30:35], lo[35:40], hi[35:40] = -5, len(c) - 3, len(c) + 40  # beyond the items
    one = tree.along(a, b), tree.along(a, b, lo=lo, hi=hi)
    monkeypatch.setattr(captree, "_ALONG_BLOCK", 7)
    blocks = tree.along(a, b), tree.along(a, b, lo=lo, hi=hi)
    for (si, ni), (sj, nj) in zip(one, blocks):
        assert len(si) > 50
        assert np.array_equal(si, sj) and np.array_equal(ni, nj)
        assert (np.diff(si) >= 0).all()
    assert set(zip(*blocks[1])) == brute_along(tree, a, b, lo, hi)


def input_edges(names):
    """The edges of the input rings of the countries ``names`` of 1:10m, before the union:
    each border shared by two neighbours is there twice, once from each side."""
    import json

    from conftest import NEIGHBOURS

    from gloffset.geometry.lonlat import prepare_rings
    from gloffset.io import geojson

    fc = json.loads((DATA / "countries_10m.geojson").read_text())
    names = names or NEIGHBOURS
    feats = [f for f in fc["features"] if f["properties"].get("name") in names]
    assert len(feats) == len(names)
    parts = geojson.parse({"type": "FeatureCollection", "features": feats})
    ll = [ring for poly in parts.polygons for ring in poly]
    rings = prepare_rings(ll, ["r"] * len(ll), [True] * len(ll))[0]
    a = np.concatenate(rings)
    sizes = np.array([len(x) for x in rings])
    starts = np.repeat(np.concatenate([[0], np.cumsum(sizes)[:-1]]), sizes)
    return a, a[starts + (np.arange(len(a)) - starts + 1) % np.repeat(sizes, sizes)]


def test_self_pairs_of_a_union_input_equal_every_pair_of_sampled_edges(monkeypatch):
    # the union's broad phase on real input (France and its neighbours at 1:10m, ~30k
    # edges, shared borders twice): the pairs of 400 sampled edges with every edge,
    # by brute force, are those self_pairs returns, from its grid over pairs of edges,
    # over fours, and over the edges themselves
    a, b = input_edges(None)
    tree = CapTree(*arc_cap(a, b))
    c, r, slack = tree.centers[0], tree.radii[0], 2e-12
    sample = np.random.default_rng(0).choice(len(a), 400, replace=False)
    si, sj = np.repeat(sample, len(a)), np.tile(np.arange(len(a)), len(sample))
    d2 = np.einsum("ij,ij->i", c[si] - c[sj], c[si] - c[sj])
    near = (d2 <= pad(chord(r[si] + r[sj] + slack)) ** 2) & (si != sj)
    want = {(min(x, y), max(x, y)) for x, y in zip(si[near].tolist(), sj[near].tolist())}
    assert len(want) > 3 * len(sample)  # next edges and the other side of shared borders
    got = []
    for level in (0, 1, 2):
        monkeypatch.setattr(captree, "_PAIR_LEVEL", level)
        i, j = tree.self_pairs(slack)
        got.append((i, j))
        mine = np.isin(i, sample) | np.isin(j, sample)
        assert set(zip(i[mine].tolist(), j[mine].tolist())) == want
    for i, j in got[1:]:  # all the pairs, in one order
        assert np.array_equal(i, got[0][0]) and np.array_equal(j, got[0][1])
