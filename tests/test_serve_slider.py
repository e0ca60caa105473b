"""A distance slider seen by ``gloffset serve`` from its requests
(:meth:`gloffset.serve.service.TileService.sliding`): the share of a layer's tile requests
that ask a place seen before at a new distance switches it on under a slider and off under
a pan; under a slider, fields are bought at first sight (a frontier tile answered from its
field made at once, the decided tiles' fields queued on the field thread), so that a seen
view's tiles at new distances are thresholds of kept fields, byte-identical to the rendered
tiles, even those decided at the view's first distance; under a pan no field is bought. On
Mexico's 1:10m borders."""

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

from gloffset.serve import service as svc  # noqa: E402
from gloffset.serve.app import create_app  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MEXICO = ROOT / "data" / "mexico_10m.geojson"
TIMING = re.compile(r'queue;dur=([0-9.]+), render;dur=([0-9.]+)(?:, why;desc="([a-z]+)")?')


def view(z: int, x0: int, y0: int) -> list:
    """A map's 4 x 3 tiles from ``(x0, y0)`` at zoom ``z``."""
    return [(z, x, y) for y in range(y0, y0 + 3) for x in range(x0, x0 + 4)]


#: Mexico's coast: every tile outside at -2000 km, most frontier from -50 to 100 km
COAST = view(7, 26, 54)
#: inland: inside at every distance here (cheap fields), the slider's first view
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
    monkeypatch.setattr(svc, "STALE", 600.0)


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
    """After a first view swept, a new view's tiles, all decided outside at its first
    distance, have their fields made on the field thread; at the next distances its
    tiles, now at the frontier, are thresholds of those fields (no render, no field made
    while the slider waits), byte-identical to the rendered tiles. A new frontier tile is
    answered from its field made at once, its ``Server-Timing`` saying ``slider``."""
    app = create_app({"mexico": shape}, render_timeout=120)
    path = "/tiles/mexico/{}/{}/{}/{}.png"
    with TestClient(app) as c:
        tiles = app.state.server.tiles
        for dist in ("-2000km", "-1900km", "-1800km"):
            for tile in INLAND:
                assert c.get(path.format(dist, *tile)).headers["x-gloffset-tile"] == "outside"
        assert tiles.sliding("mexico") and tiles.rendered == 0
        for tile in COAST:
            r = c.get(path.format("-2000km", *tile))
            assert r.headers["x-gloffset-tile"] == "outside"
        fkeys = [_key("0km", *tile).field() for tile in COAST]
        end = time.monotonic() + 120
        while any(tiles.field(f) is None for f in fkeys):
            assert time.monotonic() < end, "the slider's fields never came"
            time.sleep(0.05)
        made, fields = tiles.computed, 0
        for dist in ("-50km", "0km", "100km"):
            d = parse_distance(dist, EARTH_RADIUS)
            want = render_tiles(shape, d, 7, [(x, y) for _, x, y in COAST])
            for z, x, y in COAST:
                r = c.get(path.format(dist, z, x, y))
                how = r.headers["x-gloffset-tile"]
                assert how in ("field", "inside", "outside"), (dist, z, x, y, how)
                fields += how == "field"
                if how == "field":
                    assert r.content == (
                        svc.EMPTY_PNG[256] if want[(x, y)] is None else want[(x, y)]
                    )
        assert fields >= 12  # frontier at -50 km and more: each a threshold
        assert tiles.rendered == 0 and tiles.computed == made
        # a new frontier tile while the slider moves: its field at once, not a render
        r = c.get(path.format("0km", 6, 13, 27))
        assert r.headers["x-gloffset-tile"] == "field", r.headers
        assert TIMING.fullmatch(r.headers["server-timing"])[3] == "slider"
        want = render_tiles(shape, 0.0, 6, [(13, 27)])[(13, 27)]
        assert r.content == want and tiles.rendered == 0


def test_under_a_pan_no_field_is_bought_at_first_sight(shape, quiet):
    """New views at one distance (each overlapping the last): the frontier tiles are
    rendered, the decided ones queue no field, and no field is made."""
    app = create_app({"mexico": shape}, render_timeout=120)
    with TestClient(app) as c:
        tiles = app.state.server.tiles
        hows = []
        for x0 in (26, 27, 28):
            for z, x, y in view(7, x0, 54):
                r = c.get(f"/tiles/mexico/100km/{z}/{x}/{y}.png")
                hows.append(r.headers["x-gloffset-tile"])
        assert "rendered" in hows and "inside" in hows and "cached" in hows
        assert not tiles.sliding("mexico")
        assert tiles.computed == 0 and not tiles.soon and not tiles.wanted
