"""What shapes, grids and indexes build lazily is built once, however many threads ask at
the same time (:mod:`gloffset.memo`, :class:`gloffset.shape.Derived`): every builder runs
once, every thread gets the same complete value, bounded memos evict without a race, and
the answers under threads are those of one thread. On real borders."""

from __future__ import annotations

import pickle
import threading
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import gloffset
from gloffset import memo as memo_mod
from gloffset.memo import Memo, kept_property, once_attr
from gloffset.shape import Derived

ROOT = Path(__file__).resolve().parents[1]
THREADS = 16


def together(fn, n: int = THREADS) -> list:
    """``fn(i)`` on ``n`` threads released at once (a barrier); their results in order."""
    gate = threading.Barrier(n)

    def run(i):
        gate.wait(timeout=30)
        return fn(i)

    with ThreadPoolExecutor(n) as pool:
        return list(pool.map(run, range(n)))


def test_memo_builds_each_key_once_under_threads():
    m: Memo = Memo()
    runs: Counter = Counter()

    def build(k):
        runs[k] += 1
        time.sleep(0.02)  # every thread arrives while the first builds
        return object()

    got = together(lambda i: m.once(i % 3, lambda: build(i % 3)))
    assert runs == Counter({0: 1, 1: 1, 2: 1})
    for i, v in enumerate(got):
        assert v is m[i % 3]
    assert len(m._locks) == 0  # the locks live only while a build runs


def test_memo_eviction_and_rebuilds_under_threads():
    """A bounded memo evicts the oldest without a race (the old ``pop(next(iter()))``
    could pop one key twice), and a stale value (``fresh``) is rebuilt, never replaced by
    a lesser one."""
    m: Memo = Memo()
    got = together(lambda i: m.once(i, lambda: i * i, keep=4), n=64)
    assert got == [i * i for i in range(64)] and len(m) <= 4
    assert set(m) <= set(range(64))

    deep: Memo = Memo()
    builds: list = []

    def build(want):
        builds.append(want)
        time.sleep(0.01)
        return want

    wants = [1 + i % 4 for i in range(32)]
    got = together(lambda i: deep.once("k", lambda: build(wants[i]), lambda v: v >= wants[i]), 32)
    assert all(g >= w for g, w in zip(got, wants))
    assert deep["k"] == max(builds) and builds == sorted(builds)  # each rebuild deeper


def test_a_failing_build_keeps_nothing_and_is_tried_again():
    m: Memo = Memo()

    def boom():
        raise ValueError("no")

    for _ in range(2):
        with pytest.raises(ValueError):
            m.once("k", boom)
    assert "k" not in m and len(m._locks) == 0
    assert m.once("k", lambda: 5) == 5


def test_kept_property_and_once_attr_build_once_per_object():
    runs: Counter = Counter()

    class Thing:
        @kept_property
        def value(self):
            runs[id(self)] += 1
            time.sleep(0.02)
            return [id(self)]

    a, b = Thing(), Thing()
    got = together(lambda i: (a, b)[i % 2].value)
    assert set(runs.values()) == {1} and len(runs) == 2
    assert all(g is (a, b)[i % 2].value for i, g in enumerate(got))
    assert "value" in a.__dict__  # later reads take no descriptor, no lock

    calls = []
    once_attr(a, "_x", lambda: calls.append(1) or 7)
    assert once_attr(a, "_x", lambda: calls.append(1) or 8) == 7 and calls == [1]
    assert len(memo_mod._ATTR_LOCKS) == 0


def test_derived_slots_are_assigned_only_through_once():
    s = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [10, 5]]})
    with pytest.raises(AttributeError, match="built once"):
        s.derived.arcs = None
    assert not hasattr(s.derived.anchors, "__setitem__")
    s.arcs()
    assert s.derived.arcs is not None
    assert pickle.loads(pickle.dumps(s.derived)).arcs is None  # never pickled


@pytest.fixture
def counted(monkeypatch):
    """Every build of a shape's slot (:meth:`Derived.once`, the slots' memos) and of a
    memo's key, counted by (object, name or key); the objects kept alive (an id is
    unique only while its object lives)."""
    runs: Counter = Counter()
    lock = threading.Lock()
    alive: list = []

    def counting(obj, key, build):
        def run():
            with lock:
                runs[id(obj), key] += 1
                alive.append(obj)
            return build()

        return run

    once, memo_once = Derived.once, Memo.once

    def derived_once(self, name, build):
        return once(self, name, counting(self, name, build))

    def memo_once_(self, key, build, fresh=None, keep=None):
        return memo_once(self, key, counting(self, key, build), fresh, keep)

    monkeypatch.setattr(Derived, "once", derived_once)
    monkeypatch.setattr(Memo, "once", memo_once_)
    return runs


def _queries(shape, i: int):
    """One thread's mix of what the tile server asks of a shape (no GL)."""
    from gloffset.edges import distance_xyz, points_inside
    from gloffset.geometry.sphere import lonlat_to_xyz
    from gloffset.raster.simplified import simplified
    from gloffset.serve.bounds import region_bounds
    from gloffset.tiles.tiling import measure_tiles

    rng = np.random.default_rng(i % 4)
    lon, lat = rng.uniform(-118, -86, 50), rng.uniform(14, 33, 50)
    p = lonlat_to_xyz(lon, lat)
    d = [0.0, 0.004, -0.002, 0.01][i % 4]
    out = [
        gloffset.contains(shape, lon, lat, distance=d, radius=1.0),
        distance_xyz(shape, p),
        points_inside(shape, p),
        np.array(region_bounds(shape, abs(d))),
        np.array(shape.overlapping_components()),
        simplified(shape, 1e-4) is None,
    ]
    got = measure_tiles(shape, 5, [(6, 13), (7, 13), (6, 14)])
    out.append(np.array([[t.dist, t.dring, t.inside] for _, t in sorted(got.items())]))
    return out


def test_a_cold_shape_hammered_by_threads_builds_each_slot_once(counted):
    """Threads released together on a cold shape (Mexico at 1:10m): the edge index, the
    decomposition, the inside test's indexes, the simplified curves, the boxes... each
    built once, and every answer that of one thread on another cold shape."""
    shape = gloffset.read(ROOT / "data" / "mexico_10m.geojson")
    got = together(lambda i: _queries(shape, i))
    assert counted and max(counted.values()) == 1, [k for k, v in counted.items() if v > 1]
    built = {k[1] for k in counted if isinstance(k[1], str)}
    assert {"edges", "arcs", "exhaust", "contains_arcs", "ref_status"} <= built
    alone = gloffset.read(ROOT / "data" / "mexico_10m.geojson")
    for i, answers in enumerate(got):
        for a, b in zip(answers, _queries(alone, i)):
            np.testing.assert_array_equal(a, b)


def test_kept_arrays_are_read_only(world):
    """What every thread reads cannot be changed in place by one of them: a write into a
    kept array raises (the values stay those of the shape)."""
    from gloffset.edges import CurveArcs
    from gloffset.geometry import crossings

    s = gloffset.read(world["Mexico"])
    p = gloffset.geometry.sphere.lonlat_to_xyz(np.array([-100.0]), np.array([20.0]))
    crossings.inside_indexed(s, p, anchors=16)
    arcs = CurveArcs.from_shape(s)
    kept = [s.edges().a, arcs.a, arcs.ring, arcs.lunes[0], s.reference_points()[1]]
    kept += list(s.derived.anchors[16])
    for a in kept:
        with pytest.raises(ValueError, match="read-only"):
            a[...] = 0
