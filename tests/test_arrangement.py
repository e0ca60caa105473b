"""The arrangement skeleton shared by the union and the offsets' self-intersections."""

import numpy as np
import pytest

from gloffset.geometry.arrangement import (
    candidate_pairs,
    components,
    cycles,
    permutation_cycles,
    split,
)
from gloffset.geometry.caps import arc_cap
from gloffset.shape import read


def test_components_label_by_smallest_member():
    lab = components(7, np.array([5, 3, 6]), np.array([3, 1, 4]))
    assert lab.tolist() == [0, 1, 2, 1, 4, 1, 4]
    assert components(3, np.zeros(0, np.int64), np.zeros(0, np.int64)).tolist() == [0, 1, 2]


def test_split_pieces_between_consecutive_events():
    # arc 1: start (node 10), a point (node 12), end (node 11); arc 0: start and end only
    arc = np.array([1, 0, 1, 1, 0])
    t = np.array([0.5, 1.0, 0.0, 1.0, 0.0])
    node = np.array([12, 21, 10, 11, 20])
    a, t0, t1, n0, n1 = split(arc, t, node)
    assert a.tolist() == [0, 1, 1]
    assert t0.tolist() == [0.0, 0.0, 0.5] and t1.tolist() == [1.0, 0.5, 1.0]
    assert n0.tolist() == [20, 10, 12] and n1.tolist() == [21, 12, 11]


def test_cycles_and_open_chains():
    closed, open_ = cycles(np.array([2, -1, 0, 1, 5, 6, 4]))
    assert [c.tolist() for c in closed] == [[0, 2], [4, 5, 6]]
    assert sorted(open_.tolist()) == [1, 3]


def test_candidate_pairs_hold_every_touching_border():
    # Mexico's border at 1:10m: every pair of edges that share a vertex is a candidate
    shape = read("data/mexico_10m.geojson")
    e = shape.edges()
    ring = np.flatnonzero(e.group >= 0)
    a, b = e.a[ring], e.b[ring]
    _, i, j = candidate_pairs(*arc_cap(a, b))
    pairs = set(zip(i.tolist(), j.tolist()))
    touch = np.flatnonzero((b[:-1] == a[1:]).all(axis=1))
    assert all((k, k + 1) in pairs for k in touch.tolist())


def test_permutation_cycles_are_those_of_cycles():
    rng = np.random.default_rng(0)
    perms = [rng.permutation(n) for n in (1, 2, 3, 50, 5000) for _ in range(3)]
    perms.append(np.roll(np.arange(4097), -1))  # one long cycle
    perms.append(np.arange(7))  # fixed points
    for n in (10, 3000):  # rings of consecutive items (a boundary's pieces), some spliced
        sizes = rng.integers(1, min(40, n // 2), n)
        ends = np.cumsum(sizes)[np.cumsum(sizes) <= n]
        starts = np.concatenate([[0], ends[:-1]])
        ring = np.arange(n) + 1  # each item to the next, the last of a ring to its first
        ring[ends - 1] = starts
        ring[ends[-1] :] = np.arange(ends[-1], n)
        spliced = ring.copy()
        a, b = rng.permutation(n)[:10].reshape(2, 5)  # successors swapped: a permutation still
        spliced[a], spliced[b] = ring[b], ring[a]
        perms += [ring, spliced]
    for nxt in perms:
        want = cycles(nxt)[0]
        items, sizes = permutation_cycles(nxt)
        assert sizes.tolist() == [len(c) for c in want]
        assert np.array_equal(items, np.concatenate(want))


@pytest.mark.parametrize("seed", [0, 1])
def test_bucket_order_is_the_stable_argsort(seed):
    from gloffset.geometry.arrangement import bucket_order

    rng = np.random.default_rng(seed)
    n = 5000
    ids = rng.permutation(n)[:4000]  # mostly unique ids, as a boundary's vertices
    ids[rng.integers(0, 4000, 300)] = rng.integers(0, 50, 300)  # and some shared
    order, counts, starts = bucket_order(ids, n)
    assert np.array_equal(order, np.argsort(ids, kind="stable"))
    assert np.array_equal(counts, np.bincount(ids, minlength=n))
    assert np.array_equal(starts, np.searchsorted(ids[order], np.arange(n)))
    assert (counts > 1).sum() > 20


def test_split_between_is_split_with_the_arcs_ends_as_events():
    from gloffset.geometry.arrangement import split_between

    rng = np.random.default_rng(2)
    n = 300
    first, last = np.arange(n), rng.permutation(n)
    arc = rng.integers(0, n, 700)
    t = rng.integers(0, 5, 700).astype(float)  # ties keep their order, in both
    node = n + np.arange(700)
    order = np.lexsort((t, arc))
    arc, t, node = arc[order], t[order], node[order]
    want = split(
        np.concatenate([arc, np.arange(n), np.arange(n)]),
        np.concatenate([t, np.full(n, -1.0), np.full(n, np.inf)]),
        np.concatenate([node, first, last]),
    )
    got = split_between(first, last, arc, node)
    for g, w in zip(got, (want[0], want[3], want[4])):
        assert np.array_equal(g, w)
    assert len(got[0]) == n + 700
