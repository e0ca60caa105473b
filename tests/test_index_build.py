"""The index build's kernels and chunks: the same bits as the plain formulas, and an index
that does not depend on how its pairs are cut into chunks."""

import importlib

import numpy as np
import pytest
from conftest import DATA

import gloffset
from gloffset.geometry.sphere import angle, arc_distance, dot, normalize

arcs_mod = importlib.import_module("gloffset.index.arcs")
settle_mod = importlib.import_module("gloffset.index.settle")


@pytest.fixture(scope="module")
def world_arcs():
    """The arc tree of the union of Natural Earth 110m (original edges and simplified arcs)."""
    return arcs_mod.arc_tree(gloffset.read(DATA / "world_110m.geojson"))


def _points(arcs, rng, n):
    """Points near and far from random arcs: uniform on the sphere, within 1e-16..1e-1 rad
    of an end, on the bisector of the two ends (a tie between them), near an end's
    antipode (beyond a right angle); with the arcs they go with."""
    k = rng.integers(0, len(arcs.a), 4 * n)
    a, b = arcs.a[k], arcs.b[k]
    jitter = rng.normal(size=(n, 3)) * 10.0 ** rng.uniform(-16, -1, (n, 1))
    mid = normalize(a[2 * n : 3 * n] + b[2 * n : 3 * n])
    side = normalize(np.cross(mid, b[2 * n : 3 * n] - a[2 * n : 3 * n]))
    t = rng.uniform(-1.5, 1.5, (n, 1))
    p = np.vstack(
        [
            normalize(rng.normal(size=(n, 3))),
            normalize(a[n : 2 * n] + jitter),
            normalize(np.cos(t) * mid + np.sin(t) * side),
            normalize(-b[3 * n :] + 0.3 * jitter),
        ]
    )
    return p, k


def test_pair_distance_has_the_bits_of_arc_distance(world_arcs):
    arcs = world_arcs
    p, k = _points(arcs, np.random.default_rng(5), 50_000)
    dist, pn = arcs_mod.pair_distance(p, arcs.g[k], arcs.solid[k])
    assert np.array_equal(dist, arc_distance(p, arcs.a[k], arcs.b[k], arcs.n[k]))
    assert np.array_equal(pn, dot(p, arcs.n[k]))
    ends = arcs_mod.end_distance(p, arcs.a[k], arcs.b[k])
    assert np.array_equal(ends, np.minimum(angle(p, arcs.a[k]), angle(p, arcs.b[k])))


def _fingerprint(ix):
    lists = [c[3] for c in ix._choices] if ix._choices else [ix._lists]
    return (
        (ix.level, ix.depth, ix.floor, ix.n_leaves, ix.n_candidates),
        [t.tobytes() for t in ix._tables],
        [[np.asarray(v).tobytes() for v in li] for li in lists],
        ix._leaf_status.tobytes(),
    )


@pytest.mark.parametrize(
    "d",
    [pytest.param(0.0, marks=pytest.mark.slow), 127e3, pytest.param(-50e3, marks=pytest.mark.slow)],
)
def test_chunk_sizes_change_no_index(monkeypatch, d):
    """Chunks of 1000 pairs (and blocks of 777 arcs) build the index of every country of
    Natural Earth 110m that the default chunks build, bit for bit."""
    path = DATA / "world_110m.geojson"
    want = _fingerprint(gloffset.Index(gloffset.read(path), d))
    monkeypatch.setattr(settle_mod, "CHUNK", 1000)
    monkeypatch.setattr(arcs_mod, "_ROWS", 777)
    got = _fingerprint(gloffset.Index(gloffset.read(path), d))
    assert got == want
