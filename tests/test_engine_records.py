"""The GPU levels' arc records and clusters (gloffset.raster.records.records) and the
shader's cluster culling, which must leave every class unchanged."""

import math

import numpy as np
import pytest
from conftest import LINES, SQUARE_WITH_HOLE, assert_cluster_headers, frontier_without_pairs

import gloffset
from gloffset.geometry.caps import cap_range
from gloffset.geometry.sphere import arc_distance, dot, pair_dots
from gloffset.grids import Cube, Equirect, Tile
from gloffset.raster import gpu
from gloffset.raster import records as E
from gloffset.raster.vector import levels
from gloffset.raster.vector.curves import classify_curves as classify
from gloffset.raster.vector.levels import cell_distances

POINTS = {"type": "MultiPoint", "coordinates": [[30, 60], [31, 60.5], [-120, -20]]}


def reference_records(f, arcs, e):
    """The records as first written: float64 (pairs, 6, 4) by lexsort, then the cast."""
    ci, ai = f.pair_cell, f.pair_arc
    dist = arc_distance(f.centers[ci], arcs.a[ai], arcs.b[ai], arcs.n[ai])
    order = np.lexsort((dist, ci))
    ci, ai, dist = ci[order], ai[order], dist[order]
    c = f.centers[ci]
    a, b, n = arcs.a[ai], arcs.b[ai], arcs.n[ai]
    se, chord_e = math.sin(e), 4.0 * math.sin(0.5 * e) ** 2
    h = dot(c, n)  # as the CPU's crossing tests make it (same sign at the centre)
    w1, w2 = np.cross(n, a), np.cross(b, n)
    ea, eb = c - a, c - b
    rec = np.empty((len(ci), 6, 4))
    cap = np.arccos(np.clip(dot(c, arcs.mid[ai]), -1.0, 1.0)) - arcs.half[ai] - 2e-7
    rec[:, 0, 0] = np.maximum(cap, 0.0) * (1.0 - 1e-7)
    tiny = float(np.finfo(np.float32).tiny)
    rec[:, 0, 2] = np.where((h < 0) & (h > -tiny), -tiny, h)  # stays negative in float32
    rec[:, 0, 3] = -h - se
    rec[:, 1, :3] = n
    rec[:, 1, 3] = h - se
    rec[:, 2, :3] = w1
    rec[:, 2, 3] = np.einsum("ij,ij->i", c, w1)
    rec[:, 3, :3] = w2
    rec[:, 3, 3] = np.einsum("ij,ij->i", c, w2)
    rec[:, 4, :3] = ea
    rec[:, 4, 3] = chord_e - np.einsum("ij,ij->i", ea, ea)
    rec[:, 5, :3] = eb
    rec[:, 5, 3] = chord_e - np.einsum("ij,ij->i", eb, eb)
    group = arcs.group[ai]
    flags = (
        np.where(np.any(n != 0.0, axis=1), E.ARC_IS_ARC, 0)
        | np.where(arcs.boundary[ai], E.ARC_HAS_DISTANCE, 0)
        | np.where(group >= 0, E.ARC_RING, 0)
    )
    k, ng = len(f.cells), arcs.n_groups
    local = np.full(len(ci), 31)
    bits = np.zeros(k, dtype=np.uint64)
    inside = np.unpackbits(f.status, axis=1, bitorder="little")[:, : max(ng, 1)]
    n_local = np.zeros(k)
    for j in range(k):  # per bin: components by increasing id get bits 0, 1, ...
        sel = (ci == j) & (group >= 0)
        for rank, g in enumerate(np.unique(group[sel])):
            r = min(rank, E.MAX_LOCAL)
            local[sel & (group == g)] = r
            if inside[j, g]:
                bits[j] |= np.uint64(1) << np.uint64(r)
                n_local[j] += 1
    other = inside.sum(axis=1) > n_local
    bits |= np.where(other, np.uint64(1) << np.uint64(E.OTHER_BIT), np.uint64(0))
    rec[:, 0, 1] = flags + 8 * local
    first = np.searchsorted(ci, np.arange(k)).astype(np.uint32)
    return rec.astype(np.float32), first, bits.astype(np.uint32)


def frontier(geom, d, grid):
    shape = gloffset.read(geom) if isinstance(geom, dict) else geom
    _, f, arcs = classify(shape, d, grid, stop_level=grid.bin_level)
    assert len(f.pair_cell) > 0
    return f, arcs


def rows_by_bin(rec, first):
    """Each bin's records as a sorted list of their bytes (order-free comparison)."""
    ends = np.append(first[1:], len(rec))
    return [sorted(r.tobytes() for r in rec[s:t]) for s, t in zip(first, ends)]


@pytest.fixture(scope="module")
def cases(world):
    return [
        (frontier(world["Japan"], 0.01, Equirect(600, 400, (125, 25, 150, 46))), 0.01),
        (frontier(world["Indonesia"], -0.004, Equirect(512, 256, (94, -11, 142, 6))), 0.004),
        (frontier(SQUARE_WITH_HOLE, 0.0, Equirect(256, 128)), 0.0),
        (frontier(LINES, 0.04, Equirect(256, 128)), 0.04),
        (frontier(POINTS, 0.2, Equirect(200, 100)), 0.2),
    ]


def test_records_are_the_reference_records(cases):
    """Each bin holds the records of the direct float64 computation, bit for bit, with
    the same first record and status bits (only the order within a bin differs)."""
    for (f, arcs), e in cases:
        rec, first, bits, *_ = E.records(f, arcs, e)
        want, want_first, want_bits = reference_records(f, arcs, e)
        assert rec.dtype == np.float32 and rec.shape == want.shape
        assert np.array_equal(first, want_first)
        assert np.array_equal(bits, want_bits)
        assert rows_by_bin(rec, first) == rows_by_bin(want, want_first)


def test_records_with_the_sorted_component_keys(cases, monkeypatch):
    """The (bin, component) keys of a large frontier are ranked by a sort, not a dense
    table: the records are the same, and the sort equals ``np.unique``."""
    monkeypatch.setattr(E, "_DENSE", 0)
    for (f, arcs), e in cases:
        rec, first, bits, *_ = E.records(f, arcs, e)
        want, want_first, want_bits = reference_records(f, arcs, e)
        assert np.array_equal(bits, want_bits)
        assert rows_by_bin(rec, first) == rows_by_bin(want, want_first)
    rng = np.random.default_rng(3)
    for key in (
        np.sort(rng.integers(0, 50, 1000)),
        np.repeat(np.arange(300), 3) * 7 + rng.integers(0, 7, 900),  # nearly sorted
        rng.integers(0, 1 << 40, 5000),
        np.zeros(0, dtype=np.int64),
    ):
        got, want = E._unique_inverse(key), np.unique(key, return_inverse=True)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])


def test_record_distances_are_lower_bounds(cases):
    """t0.x, the distance the shader culls by, is at most the exact distance from the
    bin centre to the arc, and short of it by at most the arc's length and 3e-7."""
    for (f, arcs), e in cases:
        rec, *_ = E.records(f, arcs, e)
        exact = pair_distances(f, arcs)
        got = rec[:, 0, 0].astype(np.float64)
        assert np.all(got <= exact)
        assert np.all(got >= exact - 2.0 * arcs.half[f.pair_arc] - 3e-7)


def pair_distances(f, arcs):
    ci, ai = f.pair_cell, f.pair_arc
    return arc_distance(f.centers[ci], arcs.a[ai], arcs.b[ai], arcs.n[ai])


@pytest.mark.parametrize("block", [None, 5, 64])
def test_cell_distances_are_the_minima_over_all_pairs(cases, block, monkeypatch):
    """cell_distances measures only the pairs that can be nearest: the minima are
    those over every pair, bit for bit, and the pairs' lower bounds those of
    ``cap_range`` over the whole level, in blocks of any size (runs of a cell longer
    than a block included)."""
    if block is not None:
        monkeypatch.setattr(levels, "_BLOCK", block)
    for (f, arcs), _ in cases:
        dist = pair_distances(f, arcs)
        near, ring, low = cell_distances(f, arcs, lows=True)
        for kind, got in ((arcs.boundary[f.pair_arc], near), (arcs.group[f.pair_arc] >= 0, ring)):
            want = np.full(len(f.cells), np.inf)
            np.minimum.at(want, f.pair_cell[kind], dist[kind])
            assert np.array_equal(want, got)
        cm = pair_dots(f.centers, f.pair_cell, arcs.mid, f.pair_arc)
        assert np.array_equal(low, cap_range(cm, arcs.half[f.pair_arc])[0])


def test_cluster_headers_order_and_bounds(cases):
    """Clusters of at most CLUSTER records of consecutive arcs tile each bin's records;
    a bin's clusters come by Dmin; Dmin, hmin are the records' own values; the ball
    (Q, rho) holds every point of the cluster's arcs, and S >= |Q| + rho."""
    for (f, arcs), e in cases:
        rec, first, bits, hdr, cfirst, ccount = E.records(f, arcs, e)
        # records in the order of the pairs
        want, _, _ = reference_records(f, arcs, e)
        order = np.lexsort((pair_distances(f, arcs), f.pair_cell))
        assert np.array_equal(rec[order], want)
        fh = hdr.view(np.float32)
        start = (hdr[:, 1, 3] >> 4).astype(np.int64)
        count = (hdr[:, 1, 3] & 15).astype(np.int64) + 1
        assert np.all(count <= E.CLUSTER)
        for b in range(len(f.cells)):
            js = np.arange(cfirst[b], cfirst[b] + ccount[b])
            assert np.all(np.diff(fh[js, 1, 0]) >= 0)
            by_start = np.argsort(start[js])
            s, n = start[js][by_start], count[js][by_start]
            assert np.array_equal(s, np.append(first[b], (s + n)[:-1]))  # contiguous
            assert np.sum(count[js]) == np.sum(f.pair_cell == b)
        for j in range(len(hdr)):  # each cluster's arcs are consecutive, of one cell
            sl = slice(start[j], start[j] + count[j])
            ci, ai = f.pair_cell[sl], f.pair_arc[sl]
            assert np.all(ci == ci[0]) and np.all(np.diff(ai) == 1)
        assert_cluster_headers(hdr, rec, f, arcs)


def test_a_frontier_without_pairs():
    k = 3
    f = frontier_without_pairs(k)
    arcs = classify(gloffset.read(SQUARE_WITH_HOLE), 0.01, Equirect(64, 32))[2]
    rec, first, bits, hdr, cfirst, ccount = E.records(f, arcs, 0.01)
    assert rec.shape == (0, 6, 4) and hdr.shape == (0, 2, 4)
    assert np.array_equal(first, [0, 0, 0]) and np.array_equal(ccount, [0, 0, 0])
    assert np.array_equal(bits, [0, 1 << E.OTHER_BIT, 0])


def spy_records(monkeypatch, *, cull: bool) -> list:
    """Count the calls of records; with ``cull=False`` make every cluster's ball
    infinite, so that the shader visits every cluster."""
    real, calls = gpu.records, []
    monkeypatch.setattr(gpu, "GPU_MIN_RECORDS", 1 << 62)  # the records of numpy

    def records(*args, **kwargs):
        out = list(real(*args, **kwargs))
        calls.append(len(out[3]))
        if not cull:
            hdr = out[3].copy()
            hdr.view(np.float32)[:, 0, 3] = np.inf
            out[3] = hdr
        return tuple(out)

    monkeypatch.setattr(gpu, "records", records)
    return calls


def all_levels(shape, d, grid):
    out = []
    mask = gloffset.render(
        shape, d, grid, radius=1.0, callback=lambda lev, c: out.append(np.array(c, copy=True))
    )
    return out + [mask]


@pytest.mark.parametrize(
    "what, d, grid",
    [
        ("mexico", 0.02, Equirect(2048, 1024)),
        ("mexico", -1e-4, Equirect(512, 512, (-111.9107, 26.7402, -111.8107, 26.8402))),
        ("mexico", 1e-5, Equirect(512, 512, (-111.9107, 26.7402, -111.8107, 26.8402))),
        ("mexico", 0.005, Tile(6, 12, 27)),
        ("mexico", 2e-4, Tile(12, 775, 1731)),
        ("world", 0.0, Equirect(1024, 512)),
        ("world", -0.03, Equirect(1024, 512)),
        ("world", 0.01, Cube(128)),
        ("lines", 0.04, Equirect(512, 256)),
        ("points", 0.2, Equirect(400, 200)),
    ],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_cluster_culling_changes_no_class(monkeypatch, world, mexico_path, what, d, grid):
    shape = {
        "mexico": lambda: gloffset.read(mexico_path),
        "world": lambda: gloffset.read(mexico_path.parent / "world_110m.geojson"),
        "lines": lambda: gloffset.read(LINES),
        "points": lambda: gloffset.read(POINTS),
    }[what]()
    calls = spy_records(monkeypatch, cull=True)
    culled = all_levels(shape, d, grid)
    assert sum(calls) > 0  # the GPU levels ran, with clusters
    spy_records(monkeypatch, cull=False)
    every = all_levels(shape, d, grid)
    assert len(culled) == len(every)
    for x, y in zip(culled, every):
        assert np.array_equal(x, y)


def test_cluster_starts_are_the_runs_cut_every_cluster_pairs(cases):
    """The clusters made from the runs: a cut at every pair whose place in its run of
    consecutive arcs of one bin is a multiple of the cluster size."""
    rng = np.random.default_rng(5)
    ci = np.sort(rng.integers(0, 40, 1500))
    ai = np.concatenate(
        [np.sort(rng.choice(80, np.sum(ci == b), replace=False)) for b in range(40)]
    )
    pairs = [(f.pair_cell, f.pair_arc) for (f, _), _ in cases] + [(ci, ai)]
    pairs.append((np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)))
    for ci, ai in pairs:
        for cluster in (1, 3, 8, 16):
            start = np.ones(len(ci), dtype=bool)
            start[1:] = (ci[1:] != ci[:-1]) | (ai[1:] != ai[:-1] + 1)
            run = np.cumsum(start) - 1
            pos = np.arange(len(ci)) - np.flatnonzero(start)[run]
            want = np.flatnonzero(pos % cluster == 0)
            got, size = E._cluster_starts(ci, ai, cluster)
            np.testing.assert_array_equal(got, want)
            np.testing.assert_array_equal(size, np.diff(np.append(want, len(ci))))
