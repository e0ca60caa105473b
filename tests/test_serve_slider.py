"""A distance slider seen by ``gloffset serve`` from its requests
(:mod:`gloffset.serve.slider`): the share of a layer's tile requests that ask a place seen
before at a new distance switches it on under a slider and off under a pan; under a slider,
fields are bought at first sight (a rendered tile's, and those of the decided tiles the
slider's next steps bring to the frontier), so that a seen view's tiles at new distances are
thresholds of kept fields, byte-identical to the rendered tiles, even those decided at the
view's first distance; under a pan no field is bought. On Mexico's 1:10m borders."""

from __future__ import annotations

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

from gloffset.serve import service as svc  # noqa: E402
from gloffset.serve import slider  # noqa: E402
from gloffset.serve.app import create_app  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MEXICO = ROOT / "data" / "mexico_10m.geojson"


def view(z: int, x0: int, y0: int) -> list:
    """A map's 4 x 3 tiles from ``(x0, y0)`` at zoom ``z``."""
    return [(z, x, y) for y in range(y0, y0 + 3) for x in range(x0, x0 + 4)]


#: Mexico's coast: one frontier tile at -400 km, the others outside; four frontier at
#: -300 km, all twelve at -200 km
COAST = view(7, 22, 52)
#: outside at -2000 to -1600 km: the slider's first view
INLAND = view(8, 52, 108)


@pytest.fixture(scope="module")
def shape():
    return gloffset.read(MEXICO)


@pytest.fixture
def quiet(monkeypatch):
    """Fields only from the slider rule: none from their cost (``at_once``), none made
    when idle, and a slider's queued fields wait as long as the test needs."""
    monkeypatch.setattr(svc.TileService, "at_once", lambda self, layer: False)
    monkeypatch.setattr(svc.TileService, "_idle", lambda self: False)
    monkeypatch.setattr(slider, "STALE", 600.0)


def _key(dist: str, z: int, x: int, y: int) -> svc.TileKey:
    return svc.TileKey("mexico", parse_distance(dist, EARTH_RADIUS), z, x, y, 256, TileStyle())


def test_a_slider_is_seen_from_the_requests_and_a_pan_is_not(shape):
    """The share of requests at a new distance on a seen place: on once a view is asked
    at its second distance, off again after a pan's requests (new places, or the same at
    the same distance); per layer."""
    tiles = svc.TileService({"mexico": shape, "other": shape})
    try:
        for tile in view(6, 12, 26):
            assert not tiles.asked(_key("0km", *tile))
        assert not tiles.sliding("mexico")
        for tile in view(6, 12, 26):
            tiles.asked(_key("10km", *tile))
        assert tiles.sliding("mexico") and not tiles.sliding("other")
        for tile in view(6, 40, 26):  # the slider's next view, at its first distance
            tiles.asked(_key("10km", *tile))
        assert tiles.sliding("mexico")
        for tile in view(6, 12, 26):
            tiles.asked(_key("20km", *tile))
        for dist in ("30km", "40km"):
            for tile in view(6, 12, 26):
                tiles.asked(_key(dist, *tile))
                assert tiles.sliding("mexico")
        # a pan at 40 km: new views, each overlapping the last
        for x0 in range(14, 24, 2):
            for tile in view(6, x0, 26):
                tiles.asked(_key("40km", *tile))
        assert not tiles.sliding("mexico")
        # the same tiles again at one distance (a map redrawn, zoomed back): still off
        for tile in view(6, 12, 26) * 3:
            tiles.asked(_key("40km", *tile))
        assert not tiles.sliding("mexico")
    finally:
        tiles.close()


def test_under_a_slider_a_seen_views_tiles_come_from_fields(shape, quiet):
    """After a first view swept by 100 km steps, a new view at its first distance: its
    frontier tile is rendered and its field bought at once, and the fields of its decided
    tiles that reach the frontier within two steps are made on the field thread; at the
    next two distances every frontier tile, most of them decided at the first distance, is
    a threshold of those fields (no render, no field made while the slider waits),
    byte-identical to the rendered tiles."""
    app = create_app({"mexico": shape}, render_timeout=120)
    path = "/tiles/mexico/{}/{}/{}/{}.png"
    with TestClient(app) as c:
        tiles = app.state.server.tiles
        for dist in ("-2000km", "-1900km", "-1800km"):
            for tile in INLAND:
                assert c.get(path.format(dist, *tile)).headers["x-gloffset-tile"] == "outside"
        assert tiles.sliding("mexico") and tiles.rendered == 0
        assert tiles.computed == 0 and not tiles.soon  # none reaches the frontier soon
        first = {}
        for tile in COAST:
            first[tile] = c.get(path.format("-400km", *tile)).headers["x-gloffset-tile"]
        assert sorted(set(first.values())) == ["outside", "rendered"], first
        rendered = tiles.rendered
        assert rendered >= 1 and tiles.soon
        end = time.monotonic() + 120
        while tiles.soon or tiles.computing or tiles.wanted:
            assert time.monotonic() < end, "the slider's fields never came"
            time.sleep(0.05)
        made, decided_then_field = tiles.computed, 0
        assert made >= 4
        for dist in ("-300km", "-200km"):
            d = parse_distance(dist, EARTH_RADIUS)
            want = render_tiles(shape, d, 7, [(x, y) for _, x, y in COAST])
            for tile in COAST:
                r = c.get(path.format(dist, *tile))
                how = r.headers["x-gloffset-tile"]
                assert how in ("field", "inside", "outside"), (dist, tile, how)
                if how == "field":
                    decided_then_field += first[tile] == "outside"
                    w = want[tile[1:]]
                    assert r.content == (svc.EMPTY_PNG[256] if w is None else w), (dist, tile)
        assert decided_then_field >= 4  # decided at the first distance, a threshold since
        assert tiles.rendered == rendered and tiles.computed == made


def test_under_a_pan_no_field_is_bought_at_first_sight(shape, quiet):
    """New views at one distance (each overlapping the last): the frontier tiles are
    rendered, the decided ones queue no field, and no field is made."""
    app = create_app({"mexico": shape}, render_timeout=120)
    with TestClient(app) as c:
        tiles = app.state.server.tiles
        hows = []
        for x0 in (22, 23, 24):
            for z, x, y in view(7, x0, 52):
                r = c.get(f"/tiles/mexico/100km/{z}/{x}/{y}.png")
                hows.append(r.headers["x-gloffset-tile"])
        assert "rendered" in hows and "inside" in hows and "cached" in hows
        assert not tiles.sliding("mexico")
        assert tiles.computed == 0 and not tiles.soon and not tiles.wanted


def test_fields_bought_at_first_sight_go_rendered_first_then_newest(monkeypatch):
    """A rendered tile's field (margin 0) before those ahead of the frontier, the newest
    first among equals; those queued over ``STALE`` seconds ago are dropped; and the way a
    slider moves follows its steps."""
    now = [100.0]
    monkeypatch.setattr(slider.time, "monotonic", lambda: now[0])
    q = slider.FirstSight()
    q.put("ahead-old", 0.01)
    now[0] += 1
    q.put("ahead-new", 0.02)
    q.put("rendered", 0.0)
    assert [q.take(), q.take(), q.take(), q.take()] == ["rendered", "ahead-new", "ahead-old", None]
    q.put("left", 0.0)
    now[0] += slider.STALE + 0.1
    q.put("on", 0.01)
    assert q.take() == "on" and q.take() is None
    s = slider.Sliders()
    for d in (0.0, 0.01, 0.02, 0.03):
        s.asked("a", "p", d)
    assert s.way("a") == 1 and abs(s.step["a"] - 0.01) < 1e-12
    for d in (0.02, 0.03) * 12:
        s.asked("a", "p", d)
    assert s.way("a") == 0  # back and forth: either way
