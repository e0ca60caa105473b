"""The arc records and cluster headers made on the GL context (gloffset.gl.records_pass,
shaders/arc_records.comp): the numpy records' bits but for the culling bounds, and the
same classes in every render."""

from pathlib import Path

import numpy as np
import pytest
from conftest import LINES, SQUARE_WITH_HOLE, assert_cluster_headers, frontier_without_pairs
from test_engine_records import POINTS, frontier, pair_distances, reference_records

import gloffset
from gloffset.gl import context
from gloffset.grids import Cube, Equirect, Tile
from gloffset.raster import gpu
from gloffset.raster import records as E

DATA = Path(__file__).resolve().parent.parent / "data"
#: polygons and lines: ring edges and other arcs in the same bins
MIXED = {
    "type": "FeatureCollection",
    "features": [
        {"type": "Feature", "properties": {}, "geometry": g} for g in (SQUARE_WITH_HOLE, LINES)
    ],
}


@pytest.fixture(scope="module")
def cases(world, mexico_path):
    mexico = gloffset.read(mexico_path)
    return [
        (frontier(world["Japan"], 0.01, Equirect(600, 400, (125, 25, 150, 46))), 0.01),
        (frontier(world["Indonesia"], -0.004, Equirect(512, 256, (94, -11, 142, 6))), 0.004),
        (frontier(mexico, 0.02, Equirect(2048, 1024)), 0.02),
        (frontier(mexico, 2e-4, Tile(12, 775, 1731)), 2e-4),
        (frontier(SQUARE_WITH_HOLE, 0.0, Equirect(256, 128)), 0.0),
        (frontier(LINES, 0.04, Equirect(256, 128)), 0.04),
        (frontier(MIXED, 0.03, Equirect(256, 128)), 0.03),
        (frontier(POINTS, 0.2, Equirect(200, 100)), 0.2),
    ]


def on_gpu(f, arcs, e):
    made = gpu.device_records(f, arcs, e, min_pairs=0)
    assert made is not None
    host, dev = made
    try:
        rec, hdr = dev.read()
    finally:
        dev.release()
    return host, rec.copy(), hdr.copy()


def test_records_are_the_numpy_records(cases):
    """Every word but t0.x has the numpy records' value (same order: by bin, then arc);
    t0.x is a lower bound on the distance from the bin centre to the arc, within 1e-6 of
    numpy's but for the series' rest (5 x^7 / 7168 for the angle x to the cap centre);
    the per-bin arrays are the same."""
    for (f, arcs), e in cases:
        want = E.records(f, arcs, e)
        host, rec, _ = on_gpu(f, arcs, e)
        for name in ("first", "bits", "first_cluster", "n_clusters"):
            assert np.array_equal(getattr(host, name), getattr(want, name)), name
        assert rec.shape == want.records.shape
        # the codes and status bits of the direct computation (component ids per bin)
        ref_rec, ref_first, ref_bits = reference_records(f, arcs, e)
        assert np.array_equal(host.bits, ref_bits)
        ends = np.append(ref_first[1:], len(ref_rec))
        for b, (s0, s1) in enumerate(zip(ref_first, ends)):
            g0, g1 = host.first[b], host.first[b] + (s1 - s0)
            assert sorted(rec[g0:g1, 0, 1]) == sorted(ref_rec[s0:s1, 0, 1])
        got, ref = rec.reshape(-1, 24), want.records.reshape(-1, 24)
        assert np.array_equal(got[:, 1:], ref[:, 1:])  # values: +0 and -0 are alike
        d = rec[:, 0, 0].astype(np.float64)
        assert np.all(d <= pair_distances(f, arcs))
        x = ref[:, 0] + arcs.half[f.pair_arc]
        assert np.all(np.abs(d - ref[:, 0]) <= 1e-6 + 1e-3 * x**7)


def test_cluster_headers_order_and_bounds(cases):
    """The clusters are numpy's runs; a bin's come by Dmin; Dmin, hmin are the records'
    own values; the ball (Q, rho) holds every point of the cluster's arcs, S >= |Q| +
    rho; Q is numpy's, rho and S at most an ulp of float32 from it."""
    for (f, arcs), e in cases:
        want = E.records(f, arcs, e)
        host, rec, hdr = on_gpu(f, arcs, e)
        assert hdr.shape == want.clusters.shape
        # the same clusters (by their record range), and their headers
        by = np.argsort(hdr[:, 1, 3])
        wby = np.argsort(want.clusters[:, 1, 3])
        assert np.array_equal(hdr[by, 1, 3], want.clusters[wby, 1, 3])
        fh, wf = hdr.view(np.float32)[by], want.clusters.view(np.float32)[wby]
        assert np.array_equal(fh[:, 0, :3], wf[:, 0, :3])
        assert np.array_equal(fh[:, 1, 1], wf[:, 1, 1])
        for j in (3, 6):  # rho, S
            a, b = fh.reshape(-1, 8)[:, j], wf.reshape(-1, 8)[:, j]
            assert np.all(np.abs(a - b) <= np.spacing(b))
        fh = hdr.view(np.float32)
        start = (hdr[:, 1, 3] >> 4).astype(np.int64)
        for b in range(len(f.cells)):
            js = np.arange(host.first_cluster[b], host.first_cluster[b] + host.n_clusters[b])
            assert np.all(np.diff(fh[js, 1, 0]) >= 0)
            assert np.all(f.pair_cell[start[js]] == b)
        assert_cluster_headers(hdr, rec, f, arcs, every=max(1, len(hdr) // 500))


def test_a_frontier_without_pairs(mexico_path):
    k = 3
    f = frontier_without_pairs(k)
    arcs = frontier(SQUARE_WITH_HOLE, 0.01, Equirect(64, 32))[1]
    host, rec, hdr = on_gpu(f, arcs, 0.01)
    assert rec.shape == (0, 6, 4) and hdr.shape == (0, 2, 4)
    assert np.array_equal(host.n_clusters, [0, 0, 0])
    assert np.array_equal(host.bits, [0, 1 << E.OTHER_BIT, 0])


@pytest.mark.parametrize(
    "what, d, grid",
    [
        ("mexico", 0.02, Equirect(2048, 1024)),
        ("mexico", -1e-4, Equirect(512, 512, (-111.9107, 26.7402, -111.8107, 26.8402))),
        ("mexico", 2e-4, Tile(12, 775, 1731)),
        ("world", 0.0, Equirect(1024, 512)),
        ("world", -0.03, Equirect(1024, 512)),
        ("world", 0.01, Cube(128)),
        ("lines", 0.04, Equirect(512, 256)),
    ],
)
def test_renders_are_those_of_the_numpy_records(monkeypatch, mexico_path, what, d, grid):
    """Every level's classes, with the records made on the GL context and in numpy."""
    shape = {
        "mexico": lambda: gloffset.read(mexico_path),
        "world": lambda: gloffset.read(mexico_path.parent / "world_110m.geojson"),
        "lines": lambda: gloffset.read(LINES),
    }[what]()

    def levels():
        out = []
        mask = gloffset.render(
            shape, d, grid, radius=1.0, callback=lambda lev, c: out.append(np.array(c, copy=True))
        )
        return out + [mask]

    made = []
    real = gpu.device_records

    def spy(*args, **kwargs):
        out = real(*args, **kwargs)
        made.append(out is not None)
        return out

    monkeypatch.setattr(gpu, "device_records", spy)
    monkeypatch.setattr(gpu, "GPU_MIN_RECORDS", 0)
    device = levels()
    assert made and all(made)
    monkeypatch.setattr(gpu, "GPU_MIN_RECORDS", 1 << 62)
    numpy_ = levels()
    assert len(device) == len(numpy_)
    for x, y in zip(device, numpy_):
        assert np.array_equal(x, y)


@pytest.mark.slow
def test_countries_render_is_that_of_the_numpy_records(monkeypatch):
    shape = gloffset.read(DATA / "countries_10m.geojson")
    grid = Equirect(4096, 2048)
    device = gloffset.render(shape, 127e3, grid)
    monkeypatch.setattr(gpu, "GPU_MIN_RECORDS", 1 << 62)
    np.testing.assert_array_equal(device, gloffset.render(shape, 127e3, grid))


def test_made_tells_this_threads_engines():
    """``made``, read by the records' threshold once their shaders are compiled: per
    thread, True once ``shared`` has made the engine."""
    import threading

    class Engine:
        pass

    assert not context.made(Engine)
    context.shared(Engine)
    assert context.made(Engine)
    other: list = []
    t = threading.Thread(target=lambda: other.append(context.made(Engine)))
    t.start()
    t.join()
    assert other == [False]


def test_records_buffers_kept_from_run_to_run(cases):
    # a drawing hands its buffers back: the next run writes into them (larger, then
    # smaller, then larger runs, each read back equal to numpy's records)
    from gloffset.gl.records_pass import records_pass

    (big, big_e), (small, small_e) = cases[2], cases[4]
    seen = []
    for (f, arcs), e in ((big, big_e), (small, small_e), (big, big_e)):
        host, dev = gpu.device_records(f, arcs, e, min_pairs=0)
        seen.append(dev.records.glo)
        try:
            rec, _ = dev.read()
            want = E.records(f, arcs, e).records.reshape(-1, 24)
            assert np.array_equal(rec.reshape(-1, 24)[:, 1:], want[:, 1:])
        finally:
            dev.release()
    assert seen[1] == seen[0] == seen[2]  # the first run's buffer, large enough for all
    assert records_pass().kept["records"].glo == seen[0]
