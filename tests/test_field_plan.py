"""The host's plan of the GPU field's blocks (``gloffset.raster.fields.gpu``): the
blocks' arc tables by a mark per node (``np.unique``'s answer) and the arcs' vertex ids
through a checked hash (equal exactly for the same bits), on real borders."""

from __future__ import annotations

import numpy as np
import pytest

import gloffset
from gloffset.grids import Equirect
from gloffset.raster.fields import gpu as field_gpu
from gloffset.raster.vector.node_levels import NodeArcs


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


@pytest.fixture(scope="module")
def nodes(mexico):
    return NodeArcs.from_shape(mexico)


def by_bits(nodes: NodeArcs) -> np.ndarray:
    """The ends' ids as the bytes of the points number them (the reference)."""
    ends = np.ascontiguousarray(np.concatenate([nodes.a, nodes.b]))
    _, ids = np.unique(ends.view(np.dtype((np.void, 24))).ravel(), return_inverse=True)
    return ids.ravel().reshape(2, -1).T


def same_partition(got: np.ndarray, want: np.ndarray) -> bool:
    """Whether two numberings make the same classes (equal exactly where equal)."""
    g, w = got.ravel().astype(np.int64), want.ravel().astype(np.int64)
    pairs = np.unique(np.stack([g, w], axis=1), axis=0)
    return len(pairs) == len(np.unique(g)) == len(np.unique(w))


def test_blocks_arcs_are_uniques(mexico, nodes):
    grid = Equirect(512, 512, (-118.0, 14.0, -86.0, 33.0))
    lists = field_gpu._Lists(nodes, grid, np.inf, grid.n_levels - 1 - field_gpu.SHIFT, "cpu")
    hc, wc = lists.shape
    assert len(lists.node) > 1000
    for rows, cols in [
        (range(hc), range(wc)),
        (range(3, 17), range(5, 40)),
        (range(hc - 2, hc), range(wc - 1, wc)),
    ]:
        _, _, node = lists.block(rows, cols)
        arcs, local = field_gpu._compact(node, len(nodes.a))
        want_arcs, want_local = np.unique(node, return_inverse=True)
        assert np.array_equal(arcs, want_arcs)
        assert local.dtype == np.uint32 and np.array_equal(local, want_local.ravel())


def test_vertex_ids_equal_exactly_for_equal_points(nodes):
    ids = field_gpu._number_ends(nodes)
    want = by_bits(nodes)
    assert ids.shape == (len(nodes.a), 2) and ids.dtype == np.uint32
    assert ids.max() < 2**31
    assert len(np.unique(want)) < want.size  # shared vertices: the test means something
    assert same_partition(ids, want)
    assert field_gpu._vertex_ids(nodes) is field_gpu._vertex_ids(nodes)  # made once


def test_vertex_ids_through_the_bits_where_hashes_collide(nodes, monkeypatch):
    # every point's hash alike: the check must see it and number the points by their bits
    monkeypatch.setattr(field_gpu, "_MIX", np.zeros(3, dtype=np.uint64))
    ids = field_gpu._number_ends(nodes)
    assert same_partition(ids, by_bits(nodes))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_by_key_is_the_stable_argsort(seed):
    rng = np.random.default_rng(seed)
    runs = rng.integers(0, 50, 400)  # keys in runs, repeated across runs, and singles
    key = np.repeat(runs, rng.integers(1, 6, len(runs)))
    key = np.concatenate([key, rng.integers(0, 50, 300)])
    assert np.array_equal(field_gpu._by_key(key), np.argsort(key, kind="stable"))
    assert len(field_gpu._by_key(np.zeros(0, np.int64))) == 0


def test_lists_are_the_stable_sort_of_the_walks_pairs(nodes):
    grid = Equirect(512, 512, (-118.0, 14.0, -86.0, 33.0))
    level = grid.n_levels - 1 - field_gpu.SHIFT
    lists = field_gpu._Lists(nodes, grid, np.inf, level, "cpu")
    wc = lists.shape[1]
    keys, vals = [], []
    for f, dist in field_gpu.walk_levels(nodes, grid, np.inf, level):
        keep = field_gpu._undominated(f, dist, nodes)  # the dominated pairs cut
        keys.append((f.cells[:, 0].astype(np.int64) * wc + f.cells[:, 1])[f.pair_cell[keep]])
        vals.append(f.pair_arc[keep])
    key, val = np.concatenate(keys), np.concatenate(vals)
    assert np.array_equal(lists.node, val[np.argsort(key, kind="stable")])
    assert np.array_equal(lists.count, np.bincount(key, minlength=lists.count.size))


@pytest.mark.parametrize(
    "grid",
    [
        pytest.param(gloffset.grids.Tile(6, 15, 29), id="z6"),
        pytest.param(gloffset.grids.Tile(3, 1, 3), id="z3", marks=pytest.mark.slow),
        pytest.param(
            Equirect(512, 512, (-118.0, 14.0, -86.0, 33.0)), id="box", marks=pytest.mark.slow
        ),
    ],
)
def test_nodes_split_two_levels_at_once_change_no_bit(mexico, grid, monkeypatch):
    """A split node whose halves would be split too goes down two levels in one round
    (``walk.DEEPER``): fewer rounds, the same field bits, both backends."""
    from gloffset.raster.fields import walk

    rounds = []
    real = walk._round

    def counted(*a):
        rounds.append(1)
        return real(*a)

    monkeypatch.setattr(walk, "_round", counted)
    monkeypatch.setattr(walk, "KEEP_STARTS", False)  # the same rounds each call
    got = [
        gloffset.distance_field(mexico, grid, radius=1.0, backend=b).values for b in ("gpu", "cpu")
    ]
    n_deeper, rounds[:] = len(rounds), []
    monkeypatch.setattr(walk, "DEEPER", 0)
    want = [
        gloffset.distance_field(mexico, grid, radius=1.0, backend=b).values for b in ("gpu", "cpu")
    ]
    assert n_deeper < 0.8 * len(rounds)
    for g, w in zip(got, want):
        assert g.tobytes() == w.tobytes()
