"""The render queue of ``gloffset serve`` (:class:`gloffset.serve.renderqueue.RenderQueue`): the
tiles of a view seen before (a distance slider) are rendered before those of new views,
which wait at most ``AGE`` seconds behind them; requests of one group are taken together;
the queue stays bounded. And the ``Server-Timing`` header of a rendered tile: the wait in
the queue, the render, and why the tile was rendered rather than thresholded from a field.
On Mexico's 1:10m borders."""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest

import gloffset
from gloffset.tiles.tiling import render_tiles
from gloffset.tiles.tiling.tilepaint import TileStyle
from gloffset.units import EARTH_RADIUS, parse_distance

pytest.importorskip("starlette")
pytest.importorskip("httpx")
from starlette.testclient import TestClient  # noqa: E402

from gloffset.serve import renderqueue as rq  # noqa: E402
from gloffset.serve import service as svc  # noqa: E402
from gloffset.serve.app import create_app  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MEXICO = ROOT / "data" / "mexico_10m.geojson"


@pytest.fixture(scope="module")
def shape():
    return gloffset.read(MEXICO)


def _key(d_km: float, z: int, x: int, y: int) -> svc.TileKey:
    return svc.TileKey(
        "mexico", parse_distance(f"{d_km}km", EARTH_RADIUS), z, x, y, 256, TileStyle()
    )


def test_the_most_pressing_group_is_taken_first_and_whole(monkeypatch):
    monkeypatch.setattr(rq, "AGE", 60.0)  # no request waits that long here
    q = rq.RenderQueue(5, svc._group)
    new_a, new_b = _key(100, 6, 13, 27), _key(100, 6, 14, 27)  # one group
    other = _key(50, 5, 7, 13)
    seen = _key(30, 6, 13, 27)
    futs = [rq.Job() for _ in range(5)]
    assert q.put(new_a, futs[0]) and q.put(other, futs[1]) and q.put(new_b, futs[2])
    assert q.put(seen, futs[3], urgent=True)
    assert q.put(svc.FieldKey("mexico", 6, 13, 27, 256), futs[4])
    assert not q.put(_key(10, 4, 3, 6), rq.Job())  # full: nothing queued
    assert q.qsize() == 5
    assert q.take() == [(seen, futs[3])]  # urgent, though the newest tile
    assert q.take() == [(new_a, futs[0]), (new_b, futs[2])]  # the oldest group, whole
    assert q.take() == [(other, futs[1])]
    # a field tile and the tiles answered from that field are one group
    ff = svc._FromField(_key(30, 6, 13, 27))
    assert q.put(ff, futs[0])
    assert [k for k, _ in q.take()] == [svc.FieldKey("mexico", 6, 13, 27, 256), ff]
    assert q.empty()
    # a request that waited AGE seconds goes first too: the oldest of the pressing ones
    assert q.put(new_a, futs[0])
    assert q.put(seen, futs[1], urgent=True)
    assert q.take()[0][0] == seen
    assert q.put(seen, futs[1], urgent=True)
    monkeypatch.setattr(rq, "AGE", 0.0)
    assert q.take()[0][0] == new_a  # older than the urgent one, and waited AGE
    assert q.take()[0][0] == seen and q.empty()


def test_a_seen_views_tile_is_rendered_before_new_views_tiles(shape, monkeypatch):
    monkeypatch.setattr(rq, "AGE", 60.0)  # however long the first render takes here
    tiles = svc.TileService({"mexico": shape})
    done: list = []
    try:
        tiles.gate.clear()  # the render thread waits after taking a request
        try:
            first = tiles.submit(_key(100, 6, 13, 27))
            end = time.monotonic() + 60
            while not tiles.queue.empty():
                assert time.monotonic() < end, "the render thread did not take the tile"
                time.sleep(0.01)
            keys = [_key(100, 5, 7, 13), _key(200, 6, 13, 27), _key(30, 6, 13, 27)]
            futs = [tiles.submit(k, urgent=(k.d == keys[2].d)) for k in keys]
            for k, f in zip(keys, futs):
                f.add_done_callback(lambda _, k=k: done.append(k))
        finally:
            tiles.gate.set()
        got = [f.result(timeout=120) for f in futs]
        assert first.result(timeout=120)
        assert done == [keys[2], keys[0], keys[1]]  # the urgent one first, then in order
        for k, data in zip(keys, got):  # the same bytes as any render
            want = render_tiles(shape, k.d, k.z, [(k.x, k.y)])[(k.x, k.y)]
            assert data == (svc.EMPTY_PNG[256] if want is None else want)
        assert all(f.began is not None and f.began >= f.queued for f in futs)
    finally:
        tiles.close()


TIMING = re.compile(r'queue;dur=([0-9.]+), render;dur=([0-9.]+), why;desc="([a-z]+)"')


def test_a_rendered_tile_says_what_it_waited_for_and_why_it_was_rendered(shape, monkeypatch):
    """``Server-Timing``: ``new`` for a tile of a new view, ``frontier`` for a seen place
    that was decided at the other distances (no renders to pay for a field), ``rent`` for
    one rendered before whose renders cost less than its field so far; none for the
    tiles decided at once or cached. Tiles seen before are urgent in the queue."""
    monkeypatch.setattr(svc.TileService, "_idle", lambda self: False)
    urgent = []
    real = svc.TileService.submit

    def spy(self, key, *, urgent=False, _seen=urgent):
        _seen.append(urgent)
        return real(self, key, urgent=urgent)

    monkeypatch.setattr(svc.TileService, "submit", spy)
    app = create_app({"mexico": shape}, render_timeout=120)
    z, x, y = 6, 13, 27
    with TestClient(app) as c:
        tiles = app.state.server.tiles
        tiles.field_cost["mexico"] = 1e9  # no field is ever worth it here
        whys = []
        for dist in ["-2000km", "127km", "30km", "127km"]:
            r = c.get(f"/tiles/mexico/{dist}/{z}/{x}/{y}.png")
            m = TIMING.fullmatch(r.headers.get("server-timing", ""))
            if r.headers["x-gloffset-tile"] != "rendered":
                assert m is None and "server-timing" not in r.headers
                whys.append(r.headers["x-gloffset-tile"])
                continue
            assert m is not None, r.headers
            assert float(m[1]) >= 0 and float(m[2]) > 0
            whys.append(m[3])
            want = render_tiles(shape, parse_distance(dist, EARTH_RADIUS), z, [(x, y)])
            assert r.content == want[(x, y)]
        assert whys == ["outside", "frontier", "rent", "cached"]
        r = c.get("/tiles/mexico/127km/6/14/27.png", headers={"Origin": "https://a.org"})
        assert TIMING.fullmatch(r.headers["server-timing"])[3] == "new"
        assert urgent == [True, True, False]
        assert "server-timing" in r.headers["access-control-expose-headers"].lower()


def test_a_seen_views_decided_tiles_have_their_fields_ahead_where_fields_are_cheap(shape):
    """Where a field costs at most ``AT_ONCE`` renders, a tile of a view seen before that
    is decided at the distance asked has its field made ahead on the field thread; at a
    later distance that brings it to the frontier it is that field's threshold (no render,
    no field made while the slider waits), byte-identical to the rendered tile. Where
    fields are dear, nothing is made ahead."""
    app = create_app({"mexico": shape}, render_timeout=120)
    z, x, y = 6, 13, 27
    path = "/tiles/mexico/{}/6/13/27.png"
    with TestClient(app) as c:
        tiles = app.state.server.tiles
        tiles.render_cost["mexico"], tiles.field_cost["mexico"] = 1.0, 50.0  # dear fields
        assert c.get(path.format("-2000km")).headers["x-gloffset-tile"] == "outside"
        assert c.get(path.format("-1500km")).headers["x-gloffset-tile"] == "outside"
        time.sleep(0.3)
        assert not tiles.ahead and tiles.computed == 0
        tiles.field_cost["mexico"] = 1.0  # as cheap as a render: fields at once
        assert c.get(path.format("-1800km")).headers["x-gloffset-tile"] == "outside"
        end = time.monotonic() + 120
        while tiles.field(svc.FieldKey("mexico", z, x, y, 256)) is None:
            assert time.monotonic() < end, "the field made ahead never came"
            time.sleep(0.05)
        assert tiles.computed == 1 and tiles.rendered == 0
        for dist in ("127km", "-20km"):
            r = c.get(path.format(dist))
            assert r.headers["x-gloffset-tile"] == "field", r.headers
            want = render_tiles(shape, parse_distance(dist, EARTH_RADIUS), z, [(x, y)])
            assert r.content == want[(x, y)]
        assert tiles.computed == 1 and tiles.rendered == 0
        # a new view's decided tile: nothing ahead
        assert c.get("/tiles/mexico/-2000km/6/14/27.png").headers["x-gloffset-tile"] == "outside"
        assert not tiles.ahead
