"""Distance-field tiles of ``gloffset serve`` and ``gloffset tiles --field``: the field
tiles decoded with their TileJSON's encoding equal ``gloffset.distance_field`` within one
step (1 m), tiles answered from kept fields are byte-identical to the rendered tiles at
positive, zero and negative distances, a rendered tile's field is computed when the server
is idle and at once when the tile is asked for again at a new distance, off the render
thread, and the fields' LRU is bounded. On Mexico's 1:10m borders."""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import gloffset
from gloffset.cli import main
from gloffset.grids import Tile
from gloffset.tiles.tiling import render_tiles
from gloffset.tiles.tiling.fieldtiles import FIELD_ENCODING, FIELD_MAX, FIELD_MIN
from gloffset.tiles.tiling.tilepaint import TileStyle
from gloffset.units import EARTH_RADIUS, parse_distance

pytest.importorskip("starlette")
pytest.importorskip("httpx")
from starlette.testclient import TestClient  # noqa: E402

from gloffset.serve.app import create_app  # noqa: E402
from gloffset.serve.service import EMPTY_PNG, FieldKey  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MEXICO = ROOT / "data" / "mexico_10m.geojson"
#: frontier tiles of Mexico at the distances of the tests (coast, Baja California)
TILES = [(5, 7, 13), (6, 13, 27)]


@pytest.fixture(scope="module")
def shape():
    return gloffset.read(MEXICO)


@pytest.fixture(scope="module")
def client(shape):
    app = create_app({"mexico": shape}, render_timeout=120)
    with TestClient(app) as c:
        yield c


def decode(png: bytes, enc: dict) -> np.ndarray:
    """A client's decoding: metres = R * redFactor + G * greenFactor + B * blueFactor -
    baseShift (MapLibre's raster-dem custom encoding)."""
    from io import BytesIO

    from PIL import Image

    img = Image.open(BytesIO(png))
    assert img.mode == "RGB"  # lossless 8-bit RGB
    rgb = np.asarray(img).astype(np.float64)
    return (
        rgb[..., 0] * enc["redFactor"]
        + rgb[..., 1] * enc["greenFactor"]
        + rgb[..., 2] * enc["blueFactor"]
        - enc["baseShift"]
    )


def within_a_step(got: np.ndarray, ref: np.ndarray) -> None:
    """``got`` (decoded metres) is ``ref`` (float32 metres) clamped to the encoding's range
    within one step (1 m) plus ``ref``'s own float32 rounding."""
    want = np.clip(ref.astype(np.float64), FIELD_MIN, FIELD_MAX)
    err = np.abs(got - want)
    slack = 1.0 + np.spacing(np.abs(ref)).astype(np.float64)
    assert (err <= slack).all(), float(err.max())


def test_field_tilejson(client):
    j = client.get("/field/mexico.json").json()
    assert j["tilejson"] == "3.0.0"
    assert j["encoding"] == FIELD_ENCODING
    assert j["tiles"] == ["http://testserver/field/mexico/{z}/{x}/{y}.png"]
    assert j["bounds"][0] == -180 and j["bounds"][2] == 180 and j["bounds"][3] > 85
    # 1 m steps, at least +-8,000 km
    assert FIELD_ENCODING["blueFactor"] == 1 and FIELD_MIN <= -8e6 and FIELD_MAX >= 8e6
    assert client.get("/field/nope.json").status_code == 404


@pytest.mark.parametrize("z, x, y, size", [(5, 7, 13, 256), (1, 0, 0, 256), (7, 28, 55, 512)])
def test_field_tiles_decode_to_the_field(client, shape, z, x, y, size):
    enc = client.get("/field/mexico.json").json()["encoding"]
    name = f"{y}@2x" if size == 512 else f"{y}"
    r = client.get(f"/field/mexico/{z}/{x}/{name}.png")
    assert r.status_code == 200 and r.headers["content-type"] == "image/png"
    assert r.headers["x-gloffset-tile"] == "computed"
    got = decode(r.content, enc)
    assert got.shape == (size, size)
    ref = gloffset.distance_field(shape, Tile(z, x, y, size)).values
    within_a_step(got, ref)
    assert (got < 0).any() or z == 1  # inside Mexico: negative
    # kept: the same bytes, an ETag, 304
    again = client.get(f"/field/mexico/{z}/{x}/{name}.png")
    assert again.headers["x-gloffset-tile"] == "cached" and again.content == r.content
    tag = again.headers["etag"]
    for match in (tag, "W/" + tag):
        r = client.get(f"/field/mexico/{z}/{x}/{name}.png", headers={"If-None-Match": match})
        assert r.status_code == 304 and r.headers["etag"] == tag


def test_field_tiles_bad_requests(client):
    assert client.get("/field/nope/1/0/0.png").status_code == 404
    for bad in ("1/0/1_0", "1/0/٠", "23/0/0", "1/2/0"):
        r = client.get(f"/field/mexico/{bad}.png")
        assert r.status_code == 400, bad
        assert "detail" in r.json()


@pytest.mark.parametrize("z, x, y", TILES)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_tiles_from_kept_fields_are_the_rendered_tiles(client, shape, z, x, y):
    """Byte-identical to the rendered tile (render_tiles: the GPU render of the tile) at
    positive, zero and negative distances, in two styles, at 256 and 512 px."""
    thresholded = 0
    for size, name in ((256, f"{y}"), (512, f"{y}@2x")):
        assert client.get(f"/field/mexico/{z}/{x}/{name}.png").status_code == 200
        for dist in ("127km", "30km", "0km", "-10km", "-60km", "0.002rad"):
            for query, style in (("", TileStyle()), ("?fill=%23ff0000&opacity=0.5", None)):
                style = style or TileStyle("#ff0000", 0.5)
                r = client.get(f"/tiles/mexico/{dist}/{z}/{x}/{name}.png{query}")
                assert r.status_code == 200
                if r.headers["x-gloffset-tile"] in ("inside", "outside"):
                    continue  # decided from the tile's centre, before the field
                assert r.headers["x-gloffset-tile"] == "field", (dist, r.headers)
                d = parse_distance(dist, EARTH_RADIUS)
                want = render_tiles(shape, d, z, [(x, y)], size=size, style=style)[(x, y)]
                want = EMPTY_PNG[size] if want is None else want
                assert r.content == want, (dist, z, x, y, size)
                thresholded += 1
    assert thresholded >= 16


def test_rendered_tiles_leave_their_field(shape):
    """A tile rendered at one distance leaves its field when the render thread is idle;
    the same tile at other distances is then a threshold of it."""
    app = create_app({"mexico": shape}, render_timeout=120)
    with TestClient(app) as c:
        tiles = app.state.server.tiles
        z, x, y = 6, 14, 27
        r = c.get(f"/tiles/mexico/100km/{z}/{x}/{y}.png")
        assert r.headers["x-gloffset-tile"] == "rendered"
        end = time.monotonic() + 60
        while tiles.field(FieldKey("mexico", z, x, y, 256)) is None:
            assert time.monotonic() < end, "the field was not computed"
            time.sleep(0.05)
        assert tiles.computed == 1
        for dist in ("100.5km", "-20km", "0km"):
            r = c.get(f"/tiles/mexico/{dist}/{z}/{x}/{y}.png")
            assert r.headers["x-gloffset-tile"] in ("field", "inside", "outside")
        assert tiles.rendered == 1
        # an outline is drawn by the renderer
        r = c.get(f"/tiles/mexico/-20km/{z}/{x}/{y}.png?outline=%23000000")
        assert r.headers["x-gloffset-tile"] == "rendered"


def test_the_fields_lru_is_bounded(shape):
    app = create_app({"mexico": shape}, field_mb=0.3, render_timeout=120)  # one 256 px field
    with TestClient(app) as c:
        tiles = app.state.server.tiles
        for x, y in ((14, 27), (13, 27)):
            assert c.get(f"/field/mexico/6/{x}/{y}.png").status_code == 200
        assert tiles.field_bytes <= tiles.field_limit and len(tiles.fields) == 1
        assert tiles.field(FieldKey("mexico", 6, 13, 27, 256)) is not None


def test_tiles_field_cli(tmp_path, shape):
    out = tmp_path / "field"
    args = ["tiles", str(MEXICO), "--field", "-z", "0-1", "--tile-size", "64", "-o", str(out)]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    meta = json.loads((out / "metadata.json").read_text())
    enc = json.loads(meta["encoding"])
    assert enc == FIELD_ENCODING
    for z, x, y in ((0, 0, 0), (1, 0, 0), (1, 1, 1)):
        got = decode((out / str(z) / str(x) / f"{y}.png").read_bytes(), enc)
        ref = gloffset.distance_field(shape, Tile(z, x, y, 64)).values
        within_a_step(got, ref)
        assert got.shape == (64, 64)
        assert (got == FIELD_MAX).any() if z == 0 else True  # clamped beyond 8,388 km
    # no distance with --field; a distance or the field
    r = CliRunner().invoke(main, args[:3] + ["-d", "10km", "-z", "0", "-o", str(tmp_path / "x")])
    assert r.exit_code == 2 and "--field takes no -d" in r.output
    r = CliRunner().invoke(main, ["tiles", str(MEXICO), "-z", "0", "-o", str(tmp_path / "y")])
    assert r.exit_code == 2 and "--distance" in r.output


def test_a_tile_asked_again_at_a_new_distance_has_its_field_at_once(shape, monkeypatch):
    """A distance slider over a view: a tile rendered at two distances and asked for at a
    third has its field computed at once, even on a server never idle (the field of a tile
    rendered once waits for an idle server), and is answered from it, byte-identical to
    the rendered tile, at that distance and the next ones."""
    from gloffset.serve.service import AGAIN, TileService

    monkeypatch.setattr(TileService, "_idle", lambda self: False)
    app = create_app({"mexico": shape}, render_timeout=120)
    z, x, y = 6, 13, 27
    dists = ["127km", "30km", "-20km", "80km", "0km", "-20km"]
    with TestClient(app) as c:
        tiles = app.state.server.tiles
        for i, dist in enumerate(dists):
            r = c.get(f"/tiles/mexico/{dist}/{z}/{x}/{y}.png")
            how = "rendered" if i < AGAIN else "field" if i < 5 else "cached"
            assert r.headers["x-gloffset-tile"] == how, (dist, r.headers)
            want = render_tiles(shape, parse_distance(dist, EARTH_RADIUS), z, [(x, y)])[(x, y)]
            assert r.content == (EMPTY_PNG[256] if want is None else want), dist
            if i == AGAIN - 1:
                time.sleep(0.3)
                assert tiles.computed == 0  # never idle: no field yet
        assert tiles.computed == 1 and tiles.rendered == AGAIN


def test_a_seen_tile_has_its_field_first_once_its_renders_cost_as_much(shape, monkeypatch):
    """Rent or buy: once a field's cost is known, a tile asked for at new distances is
    rendered until its renders took as long as a field, then answered from its field;
    byte-identical to the rendered tile either way."""
    from gloffset.serve.service import TileService

    monkeypatch.setattr(TileService, "_idle", lambda self: False)
    app = create_app({"mexico": shape}, render_timeout=120)
    z, x, y = 6, 13, 27
    with TestClient(app) as c:
        tiles = app.state.server.tiles
        tiles.field_cost["mexico"] = 1e9  # a field dearer than any number of renders
        for dist in ["127km", "30km", "-20km", "80km", "0km"]:
            r = c.get(f"/tiles/mexico/{dist}/{z}/{x}/{y}.png")
            assert r.headers["x-gloffset-tile"] == "rendered", dist
        assert tiles.computed == 0 and tiles.rendered == 5
        tiles.field_cost["mexico"] = 1e-9  # cheaper than the renders paid so far
        r = c.get(f"/tiles/mexico/-60km/{z}/{x}/{y}.png")
        assert r.headers["x-gloffset-tile"] == "field" and tiles.computed == 1
        want = render_tiles(shape, parse_distance("-60km", EARTH_RADIUS), z, [(x, y)])[(x, y)]
        assert r.content == (EMPTY_PNG[256] if want is None else want)
        assert tiles.field_cost["mexico"] > 1e-6  # the field made updates the mean


def test_new_tiles_come_from_their_fields_where_a_field_costs_under_two_renders(shape):
    """Where a field of the layer costs at most two renders of a tile (a GPU field), a
    tile never asked for is answered from its field, computed on the render thread at
    once (no render), byte-identical to the rendered tile; a dear field is not."""
    from gloffset.serve.service import AT_ONCE

    app = create_app({"mexico": shape}, render_timeout=120)
    with TestClient(app) as c:
        tiles = app.state.server.tiles
        r = c.get("/tiles/mexico/127km/6/13/27.png")  # no cost known: rendered
        assert r.headers["x-gloffset-tile"] == "rendered" and not tiles.at_once("mexico")
        tiles.field_cost["mexico"] = tiles.render_cost["mexico"] * AT_ONCE * 1.5
        r = c.get("/tiles/mexico/127km/5/7/13.png")
        assert r.headers["x-gloffset-tile"] == "rendered"
        assert tiles.rendered == 2 and tiles.computed == 0
        for dist, (z, x, y) in [("-30km", (6, 13, 27)), ("50km", TILES[0]), ("0km", (6, 13, 27))]:
            # a cheap field (each field made moves the running mean to its real cost)
            tiles.field_cost["mexico"] = tiles.render_cost["mexico"] * AT_ONCE * 0.5
            assert tiles.at_once("mexico")
            r = c.get(f"/tiles/mexico/{dist}/{z}/{x}/{y}.png")
            assert r.headers["x-gloffset-tile"] == "field", (dist, z, x, y)
            want = render_tiles(shape, parse_distance(dist, EARTH_RADIUS), z, [(x, y)])[(x, y)]
            assert r.content == (EMPTY_PNG[256] if want is None else want), (dist, z, x, y)
        assert tiles.rendered == 2 and tiles.computed == 2  # the third: a kept field


def test_renders_do_not_wait_behind_a_field(shape, monkeypatch):
    """Fields are computed off the render thread: while a tile's field is being computed
    (held here until the end), another tile is rendered and answered."""
    from gloffset.serve import service as svc

    started, release = threading.Event(), threading.Event()
    real = svc.field_tile

    def held(*args, **kw):
        started.set()
        assert release.wait(120)
        return real(*args, **kw)

    monkeypatch.setattr(svc, "field_tile", held)
    tiles = svc.TileService({"mexico": shape})
    try:
        style = TileStyle()
        d = parse_distance("127km", EARTH_RADIUS)
        first = svc.TileKey("mexico", d, 6, 13, 27, 256, style)
        assert tiles.submit(first).result(timeout=120)
        assert started.wait(60), "the field of the rendered tile did not start when idle"
        other = svc.TileKey("mexico", d, 5, 7, 13, 256, style)
        got = tiles.submit(other).result(timeout=60)  # not behind the held field
        assert got == render_tiles(shape, d, 5, [(7, 13)])[(7, 13)]
        assert tiles.computed == 0
    finally:
        release.set()
        tiles.close()


def test_a_seen_tile_waits_for_its_field_only_when_that_comes_sooner_than_a_render(shape):
    """A tile whose field is due waits for it when the field being computed and its own
    are expected no later than the render queue and its render; else it is rendered."""
    from gloffset.serve.service import TileService

    tiles = TileService({"mexico": shape})
    try:
        with tiles.lock:
            tiles.field_cost["mexico"], tiles.render_cost["mexico"] = 0.1, 0.01
            assert not tiles._sooner("mexico")  # a field is ten renders: render it
            tiles.render_cost["mexico"] = 0.2
            assert tiles._sooner("mexico")
            tiles.computing[FieldKey("mexico", 6, 13, 27, 256)] = None  # one on its way
            tiles.started = time.monotonic()
            assert tiles._sooner("mexico")  # 0.1 s + 0.1 s against 0.2 s
            tiles.render_cost["mexico"] = 0.15
            assert not tiles._sooner("mexico")
            tiles.started -= 0.1  # the field on its way is done, as expected
            assert tiles._sooner("mexico")
            tiles.computing.clear()
    finally:
        tiles.close()
