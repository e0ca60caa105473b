"""``gloffset serve``: every endpoint, the error codes, ETag/304, HEAD, a full queue, a
client that goes away, tiles decided without rendering, and tiles equal to
gloffset.render on the same Tile. Nothing here can hang: every wait has a timeout."""

from __future__ import annotations

import io
import json
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from datetime import datetime
from pathlib import Path

import mercantile
import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import gloffset
from gloffset.cli import main
from gloffset.grids import Tile

pytest.importorskip("starlette")
pytest.importorskip("httpx")
from starlette.testclient import TestClient  # noqa: E402

from gloffset.serve.app import STATIC, create_app  # noqa: E402
from gloffset.serve.service import (  # noqa: E402
    EMPTY_PNG,
    ENTRY,
    UNKNOWN,
    QueueFull,
    TileKey,
    TileService,
    full_png,
)
from gloffset.tiles.tiling.tilepaint import TileStyle  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TRI = {"type": "Polygon", "coordinates": [[[-110, 15], [-90, 15], [-100, 30], [-110, 15]]]}
LINE_AM = {"type": "LineString", "coordinates": [[170, -10], [-170, 5], [-160, 20]]}


@pytest.fixture(scope="module")
def client():
    layers = {"tri": gloffset.read(TRI), "am": gloffset.read(LINE_AM)}
    app = create_app(layers, queue_size=64, cache_mb=16, render_timeout=60)
    with TestClient(app) as c:
        yield c


def on_gl_thread(client, fn):
    """``fn()`` on the server's render thread (the GL context is current there only)."""
    return client.app.state.server.tiles.call(fn).result(timeout=120)


def alpha(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))[..., 3]


@pytest.mark.parametrize(
    "layer, dist, z, x, y",
    [
        ("tri", "300km", 3, 1, 3),
        ("tri", "127km", 5, 6, 13),
        ("tri", "2000km", 2, 0, 1),
        ("am", "200km", 3, 7, 4),  # across the antimeridian
        ("am", "200km", 3, 0, 3),
        ("tri", "0.002rad", 7, 28, 58),
    ],
)
def test_tiles_equal_render(client, layer, dist, z, x, y):
    r = client.get(f"/tiles/{layer}/{dist}/{z}/{x}/{y}.png")
    assert r.status_code == 200 and r.headers["content-type"] == "image/png"
    shape = client.app.state.server.layers[layer]
    d = gloffset.parse_distance(dist)  # radians
    want = on_gl_thread(client, lambda: gloffset.render(shape, d, Tile(z, x, y), radius=1.0)) > 0
    assert want.any() and not want.all()
    np.testing.assert_array_equal(alpha(r.content) > 0, want)


def test_coarse_tiles_rendered_alone_are_the_bytes_of_render_tiles(client):
    """Zooms up to ALONE_ZOOM go through gloffset.render on their own Tile: the same
    bytes as the pyramid's levels give (the same pixels, the same encoding)."""
    from gloffset.tiles.tiling import ALONE_ZOOM, render_tiles

    shape = client.app.state.server.layers["tri"]
    style = TileStyle("#3070c0", 0.5)
    d = gloffset.parse_distance("2100km")
    for z, x, y in [(ALONE_ZOOM, 1, 3), (2, 0, 1), (1, 0, 0)]:
        r = client.get(f"/tiles/tri/2100km/{z}/{x}/{y}@2x.png?opacity=0.5")
        assert r.status_code == 200 and r.headers["x-gloffset-tile"] == "rendered"
        want = on_gl_thread(
            client,
            lambda z=z, x=x, y=y: render_tiles(
                shape, d, z, [(x, y)], size=512, style=style, alone_zoom=-1
            ),
        )[(x, y)]
        assert r.content == want


def test_batched_tiles_equal_render_on_a_real_border(client):
    """Views of 3 x 3 tiles of Mexico's border at random zooms and distances (inward
    too), rendered as one batch each (render_tiles, as the server batches them): every
    tile has the pixels of gloffset.render on its Tile."""
    from gloffset.tiles.tiling import render_tiles

    shape = gloffset.read(ROOT / "data" / "mexico_10m.geojson")
    rng = np.random.default_rng(16)
    kinds = {"frontier": 0, "full": 0, "empty": 0}
    views = [(8, 0.05, -102.0, 24.0), (7, -0.01, -102.0, 24.0), (6, 0.01, -60.0, 0.0)]
    for _ in range(6):
        z = int(rng.integers(3, 13))
        d = float(rng.choice([-1.0, 1.0])) * rng.uniform(1e3, 500e3) / gloffset.EARTH_RADIUS
        views.append((z, d, rng.uniform(-117, -87), rng.uniform(15, 32)))
    for z, d, lon, lat in views:
        t = mercantile.tile(lon, lat, z)
        view = [(t.x + dx, t.y + dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]
        got = on_gl_thread(client, lambda v=view, z=z, d=d: render_tiles(shape, d, z, v))
        for x, y in view:
            want = on_gl_thread(
                client,
                lambda x=x, y=y, z=z, d=d: gloffset.render(shape, d, Tile(z, x, y), radius=1.0),
            )
            png = got[(x, y)]
            mask = np.zeros((256, 256), bool) if png is None else alpha(png) > 0
            np.testing.assert_array_equal(mask, want > 0, err_msg=f"{z}/{x}/{y} at {d}")
            kind = "full" if want.all() else "frontier" if want.any() else "empty"
            kinds[kind] += 1
    assert min(kinds.values()) >= 5, kinds


def test_retina_tiles_and_style(client):
    r = client.get("/tiles/tri/300km/4/3/6@2x.png?fill=%23ff0000&opacity=0.5")
    assert r.status_code == 200
    a = alpha(r.content)
    assert a.shape == (512, 512)
    shape = client.app.state.server.layers["tri"]
    want = on_gl_thread(client, lambda: gloffset.render(shape, 300e3, Tile(4, 3, 6, 512)))
    np.testing.assert_array_equal(a > 0, want > 0)
    assert set(np.unique(a)) <= {0, 128}


def test_etag_304_head_and_cache_control(client):
    url = "/tiles/tri/300km/3/1/3.png"
    r = client.get(url)
    tag = r.headers["etag"]
    assert tag.startswith('"') and r.headers["cache-control"] == "public, max-age=3600"
    again = client.get(url)
    assert again.headers["etag"] == tag and again.content == r.content
    assert client.get(url, headers={"If-None-Match": tag}).status_code == 304
    assert client.get(url, headers={"If-None-Match": f'"x", {tag}'}).status_code == 304
    assert client.get(url, headers={"If-None-Match": "*"}).status_code == 304
    # If-None-Match compares weakly (RFC 9110, 13.1.2): a weak tag of the same bytes matches
    weak = "W/" + tag
    assert client.get(url, headers={"If-None-Match": weak}).status_code == 304
    assert client.get(url, headers={"If-None-Match": f'W/"x",{weak}'}).status_code == 304
    assert client.get(url, headers={"If-None-Match": f'"x" , {weak} '}).status_code == 304
    assert client.get(url, headers={"If-None-Match": 'W/"x", "y"'}).status_code == 200
    assert client.get(url, headers={"If-None-Match": "W/" + tag[:-2] + '"'}).status_code == 200
    other = client.get(url, headers={"If-None-Match": '"something else"'})
    assert other.status_code == 200 and other.content == r.content
    h = client.head(url)
    assert h.status_code == 200 and h.headers["etag"] == tag and h.content == b""
    assert client.head("/layers").status_code == 200


def test_inside_and_outside_tiles_need_no_rendering(client):
    svc = client.app.state.server.tiles
    before = svc.rendered
    # far from the triangle: empty; deep inside it at a large distance: full
    empty = client.get("/tiles/tri/100km/6/0/0.png")
    assert empty.status_code == 200 and not alpha(empty.content).any()
    assert empty.headers["x-gloffset-tile"] == "outside" and empty.content == EMPTY_PNG[256]
    full = client.get("/tiles/tri/1000km/7/28/56.png")
    assert full.status_code == 200 and alpha(full.content).all()
    assert full.headers["x-gloffset-tile"] == "inside"
    assert full.content == full_png(256, TileStyle())
    # another distance and tile: the same shared bytes, the same ETag
    other = client.get("/tiles/tri/900km/7/28/56.png")
    assert other.content == full.content and other.headers["etag"] == full.headers["etag"]
    assert svc.rendered == before  # the render thread (and the GPU) had no part in it
    # the same pixels as a render
    shape = client.app.state.server.layers["tri"]
    want = on_gl_thread(client, lambda: gloffset.render(shape, 1000e3, Tile(7, 28, 56)))
    assert (want > 0).all()
    # a frontier tile is rendered, then cached
    r = client.get("/tiles/tri/300km/3/1/3.png?opacity=0.9")
    assert r.headers["x-gloffset-tile"] == "rendered" and svc.rendered == before + 1
    again = client.get("/tiles/tri/300km/3/1/3.png?opacity=0.9")
    assert again.headers["x-gloffset-tile"] == "cached" and again.content == r.content


def test_tiles_decided_at_once_agree_with_render_everywhere(client):
    """Every tile of zooms 2-6 around the triangle, at an outward and an inward distance:
    the triage's inside/outside tiles are those of gloffset.render."""
    svc = client.app.state.server.tiles
    shape = client.app.state.server.layers["tri"]
    style, seen = TileStyle(), set()
    for d in (0.03, -0.01):
        for z in range(2, 7):
            n = 1 << z
            for x in range(int(n * 0.19), int(n * 0.27) + 1):
                for y in range(int(n * 0.40), int(n * 0.48) + 1):
                    cls = svc.triage(TileKey("tri", d, z, x, y, 256, style))
                    if cls is None:
                        continue
                    seen.add(cls)
                    tile = Tile(z, x, y)
                    got = on_gl_thread(
                        client, lambda t=tile, d=d: gloffset.render(shape, d, t, radius=1.0)
                    )
                    assert (got > 0).all() if cls == 2 else not got.any(), (d, z, x, y)
    assert seen == {0, 2}


def test_centres_measured_together_as_alone():
    """TileService.measure (the tiles of a view at once) keeps the same values as the
    triage measuring each tile on its own, bit for bit, and then answers without
    measuring."""
    shape = gloffset.read(ROOT / "data" / "mexico_10m.geojson")
    alone, together = TileService({"m": shape}), TileService({"m": shape})
    style = TileStyle()
    for z, x0, y0 in [(4, 2, 6), (6, 12, 26), (9, 110, 220), (12, 900, 1760)]:
        keys = [
            TileKey("m", 0.02, z, x0 + i, y0 + j, 256, style) for i in range(4) for j in range(3)
        ]
        together.measure(keys)
        for k in keys:
            assert together.triage(k, measure=False) is not UNKNOWN
            alone.triage(k)
            where = k.where()
            for a, b in zip(
                vars(alone.centres[where]).values(), vars(together.centres[where]).values()
            ):
                assert np.array_equal(a, b), (where, a, b)


@pytest.mark.parametrize(
    "url, status, words",
    [
        ("/tiles/nope/100km/1/0/0.png", 404, "no layer 'nope'"),
        ("/tiles/tri/12parsec/1/0/0.png", 400, "parsec"),
        ("/tiles/tri/100km/23/0/0.png", 400, "zoom must be 0..22"),
        ("/tiles/tri/100km/2/4/0.png", 400, "does not exist"),
        ("/tiles/tri/100km/a/0/0.png", 400, "integers"),
        ("/tiles/tri/100km/1_0/0/0.png", 400, "ASCII digits, got '1_0'/'0'"),
        ("/tiles/tri/100km/4/1_0/0.png", 400, "ASCII digits"),
        ("/tiles/tri/100km/%D9%A3/0/0.png", 400, "ASCII digits"),  # Arabic-Indic 3
        ("/tiles/tri/100km/3/%D9%A1/%DB%B2.png", 400, "ASCII digits"),  # Arabic-Indic 1, 2
        ("/tiles/tri/100km/3/%EF%BC%91/1.png", 400, "ASCII digits"),  # fullwidth 1
        ("/tiles/tri/100km/3/+1/1.png", 400, "ASCII digits"),
        ("/tiles/tri/100km/3/1/%201.png", 400, "ASCII digits"),
        ("/tiles/tri/100km/3/1/1_0@2x.png", 400, "ASCII digits"),
        ("/tiles/tri/100km/1/0/0.png?opacity=2", 400, "opacity"),
        ("/tiles/tri/100km/1/0/0.png?fill=notacolour", 400, "colour"),
        ("/tilejson/tri.json", 400, "distance"),
        ("/distance/tri?lon=200&lat=0", 400, "lon"),
        ("/distance/tri?lat=0", 400, "lon and lat"),
        ("/offset/tri.geojson?distance=-1km", 200, ""),
        ("/offset/tri.geojson?distance=abc", 400, "abc"),
        ("/offset/tri.geojson", 400, "distance"),
        ("/tiles/tri/nan/1/0/0.png", 400, "nan"),
        ("/tiles/tri/1e999km/1/0/0.png", 400, "1e999km"),
        ("/tiles/tri/20000km/1/0/0.png", 400, "a tile"),
        ("/tiles/am/-5km/1/0/0.png", 400, "no polygon"),
        ("/tiles/tri/100km/99999999/0/0.png", 400, "zoom must be 0..22"),
        ("/tiles/tri/100km/99999999999999999999/0/0.png", 400, "ASCII digits"),
        ("/tiles/tri/100km/1/-1/0.png", 400, "ASCII digits"),
        ("/tiles/tri/100km/1/0/0.png?outline_width=x", 400, "style"),
        ("/tiles/tri/100km/1/0/0.png?outline_width=99&outline=%23000000", 400, "outline width"),
        ("/tilejson/nope.json?distance=1km", 404, "no layer"),
        ("/tilejson/tri.json?distance=1km&opacity=-1", 400, "opacity"),
        ("/distance/tri?lon=nan&lat=0", 400, "lon"),
        ("/distance/tri?lon=0&lat=nan", 400, "lat must be in -90..90, got nan"),
        ("/offset/tri.geojson?distance=1.6rad", 400, "vector offsets need |d| < pi/2"),
        ("/offset/tri.geojson?distance=-40000km", 400, "distance -40000km ("),
        ("/distance/tri?lon=0&lat=x", 400, "lon and lat"),
        ("/shape/nope.geojson", 404, "no layer"),
        ("/nothing", 404, ""),
    ],
)
def test_errors_name_the_problem(client, url, status, words):
    r = client.get(url)
    assert r.status_code == status, r.text
    if status != 200:
        assert words in r.json()["detail"]


def test_tilejson_shape_offset_distance_layers(client):
    tj = client.get("/tilejson/tri.json?distance=127km&outline=%23000000").json()
    assert tj["tilejson"] == "3.0.0" and tj["maxzoom"] == 22
    assert tj["tiles"][0].startswith("http://testserver/tiles/tri/127km/{z}/{x}/{y}.png")
    assert "outline" in tj["tiles"][0]
    w, s, e, n = tj["bounds"]  # the triangle grown by 127 km (1.142 deg of latitude)
    assert (w, s, e, n) == (-111.318856, 13.857863, -88.681144, 31.142137)
    assert client.get("/shape/tri.geojson").json()["geometry"]["type"] in (
        "Polygon",
        "MultiPolygon",
    )
    off = client.get("/offset/tri.geojson?distance=127km").json()
    assert off["features"][0]["geometry"]["type"] == "Polygon"
    got = client.get("/distance/tri?lon=-100&lat=10").json()
    want = float(gloffset.distance(TRI, [-100.0], [10.0])[0])
    assert abs(got["distance_m"] - want) < 1e-6 and got["inside"] is False
    assert client.get("/distance/tri?lon=-100&lat=20").json()["inside"] is True
    layers = client.get("/layers").json()
    assert [x["name"] for x in layers] == ["am", "tri"] and layers[1]["vertices"] == 3
    page = client.get("/")
    assert page.status_code == 200 and "/static/vendor/maplibre-gl.js" in page.text
    js = client.get("/static/page.js")
    assert js.status_code == 200 and "setProjection" in js.text and "/distance/" in js.text
    assert client.head("/").status_code == 200


def _country(name: str):
    fc = json.loads((ROOT / "data" / "countries_10m.geojson").read_text())
    feats = [f for f in fc["features"] if f["properties"]["name"] == name]
    return gloffset.read({"type": "FeatureCollection", "features": feats})


def _lonlat_box(geojson) -> tuple[float, float, float, float]:
    pts = []

    def walk(c):
        if c and isinstance(c[0], (int, float)):
            pts.append(c[:2])
        else:
            for v in c:
                walk(v)

    walk(geojson["coordinates"])
    lon, lat = np.asarray(pts).T
    return lon.min(), lat.min(), lon.max(), lat.max()


def test_tilejson_bounds_hold_the_region_at_the_distance(tmp_path):
    """A client that honours the TileJSON's bounds (MapLibre does) asks for no tile
    outside them: they hold the region at the requested distance, whose box for a 500 km
    offset of Luxembourg is 17 times the input's; an inward offset lies in the input's
    box; a line across the antimeridian takes every longitude. A pyramid written at the
    same distance (MBTiles: the box of its tiles) has no tile outside them."""
    lux = _country("Luxembourg")
    layers = {"lux": lux, "am": gloffset.read(LINE_AM), "tri": gloffset.read(TRI)}
    with TestClient(create_app(layers, render_timeout=60)) as c:
        w, s, e, n = c.get("/tilejson/lux.json?distance=500km").json()["bounds"]
        ow, os_, oe, on = _lonlat_box(gloffset.offset(lux, "500km").to_geojson()["geometry"])
        assert w <= ow and s <= os_ and e >= oe and n >= on, ((w, s, e, n), (ow, os_, oe, on))
        # and not much more: within 0.01 deg of the region's own box
        assert max(ow - w, os_ - s, e - oe, n - on) < 0.01
        # d < 0: inside the input, so within the input's box (the layer's own bounds)
        inward = c.get("/tilejson/lux.json?distance=-5km").json()["bounds"]
        layer = next(x for x in c.get("/layers").json() if x["name"] == "lux")
        assert inward == layer["bounds"]
        iw, is_, ie, in_ = _lonlat_box(c.get("/shape/lux.geojson").json()["geometry"])
        assert inward[0] <= iw and inward[1] <= is_ and inward[2] >= ie and inward[3] >= in_
        assert max(iw - inward[0], is_ - inward[1], inward[2] - ie, inward[3] - in_) < 1e-3
        # across the antimeridian: every longitude
        am = c.get("/tilejson/am.json?distance=100km").json()["bounds"]
        assert am[0] == -180 and am[2] == 180 and am[1] < -10.8 and am[3] > 20.8
        # far enough from the triangle to reach the pole: the whole world
        tri = c.get("/tilejson/tri.json?distance=7000km").json()["bounds"]
        assert tri[0] == -180 and tri[2] == 180 and tri[3] == 85.051129
    # a pyramid at the same distance has no tile beyond the bounds (zoom 6: its tiles'
    # box, the archive's bounds, within the bounds rounded out to zoom 6's tiles)
    out = tmp_path / "lux.mbtiles"
    gloffset.tiles.pyramid(lux, "500km", "6-6", out)
    import sqlite3

    with sqlite3.connect(out) as db:
        meta = dict(db.execute("SELECT name, value FROM metadata").fetchall())
    aw, as_, ae, an = (float(v) for v in meta["bounds"].split(","))
    ul, lr = mercantile.tile(w, n, 6), mercantile.tile(e, s, 6)
    tw, tn = mercantile.bounds(ul).west, mercantile.bounds(ul).north
    te, ts = mercantile.bounds(lr).east, mercantile.bounds(lr).south
    assert tw - 1e-6 <= aw and ts - 1e-6 <= as_ and ae <= te + 1e-6 and an <= tn + 1e-6
    assert (aw, as_, ae, an) != (-180.0, -85.051129, 180.0, 85.051129)


def test_access_log_a_line_per_request(tmp_path):
    log = tmp_path / "access.log"
    app = create_app({"tri": gloffset.read(TRI)}, access_log=str(log))
    with TestClient(app) as c:
        tile = c.get("/tiles/tri/300km/3/1/3.png")
        c.get("/tiles/tri/300km/3/1/3.png", headers={"If-None-Match": tile.headers["etag"]})
        c.get("/tiles/tri/1_0km/3/1/3.png")
        c.get("/tilejson/tri.json?distance=127km")
        c.head("/layers")
    lines = log.read_text().splitlines()
    assert len(lines) == 5, lines
    rows = [line.split(" ") for line in lines]
    assert all(len(r) == 6 for r in rows), lines
    when, method, path, status, size, ms = rows[0]
    assert (
        when.endswith("Z")
        and abs(datetime.fromisoformat(when.replace("Z", "+00:00")).timestamp() - time.time()) < 600
    )
    assert (method, path, status, int(size)) == (
        "GET",
        "/tiles/tri/300km/3/1/3.png",
        "200",
        len(tile.content),
    )
    assert 0 <= float(ms) < 600_000
    assert rows[1][3:5] == ["304", "0"]
    assert rows[2][3] == "400" and int(rows[2][4]) > 0
    assert rows[3][2] == "/tilejson/tri.json?distance=127km" and rows[3][3] == "200"
    assert rows[4][1:5] == ["HEAD", "/layers", "200", "0"]
    # off by default
    plain = create_app({"tri": gloffset.read(TRI)}, cors=None)
    assert plain.user_middleware == []
    with pytest.raises(gloffset.errors.OutputError, match="cannot open the access log '/nowhere"):
        create_app({"tri": gloffset.read(TRI)}, access_log="/nowhere/at/all.log")


def test_cli_access_log_option():
    """``--access-log FILE``, ``--access-log -`` and the option alone (standard output)."""
    from gloffset.cli.serve import serve_cmd

    for args, want in [
        ([], None),
        (["--access-log"], "-"),
        (["--access-log", "-"], "-"),
        (["--access-log", "x.log"], "x.log"),
    ]:
        ctx = serve_cmd.make_context("serve", ["tri.geojson", *args])
        assert ctx.params["access_log"] == want, args


def test_offset_endpoint_takes_what_offsets_take_and_names_the_distance_as_given(client):
    """Vector offsets go up to pi/2, farther than tiles (1.5 rad): the offset endpoint
    answers 1.5 rad, a tile at 1.5 rad is refused with the tiles' limit, and the
    feature names the distance as the other outputs do."""
    r = client.get("/offset/tri.geojson?distance=1.5rad")
    assert r.status_code == 200, r.text
    assert r.json()["features"][0]["properties"]["distance"] == "1.5rad"
    tile = client.get("/tiles/tri/1.5rad/1/0/0.png")
    assert tile.status_code == 400 and "a tile needs |d| < 1.5 rad" in tile.json()["detail"]
    props = client.get("/offset/tri.geojson?distance=127km").json()["features"][0]["properties"]
    assert props == {"distance_m": 127000.0, "distance": "127km"}


def test_distance_endpoint_answers_for_lines_and_across_the_antimeridian(client):
    got = client.get("/distance/am?lon=180&lat=-2").json()
    want = float(gloffset.distance(LINE_AM, [180.0], [-2.0])[0])
    assert abs(got["distance_m"] - want) < 1e-6 and got["inside"] is False
    assert client.get("/distance/tri?lon=0&lat=91").status_code == 400


def test_vendored_maplibre_matches_its_pinned_integrity():
    """The page's MapLibre GL JS ships in the package (no CDN) and is the version the
    vendoring script pins."""
    vendor = STATIC / "vendor"
    for name in ("maplibre-gl.js", "maplibre-gl.css", "maplibre-gl.LICENSE.txt"):
        assert (vendor / name).stat().st_size > 1000, name
    version, integrity = (vendor / "VERSION").read_text().split()[1:3]
    assert version.startswith("5.")
    script = (STATIC.parents[2] / "scripts" / "vendor_maplibre.py").read_text()
    assert f'VERSION = "{version}"' in script and integrity in script
    head = (vendor / "maplibre-gl.js").read_bytes()[:2000].decode("utf-8", "replace")
    assert "maplibre" in head.lower() and version in head
    # package data: the wheel holds every file under gloffset/ that git does not ignore
    root = STATIC.parents[2]
    if (root / ".git").exists() and shutil.which("git"):
        files = [str(p.relative_to(root)) for p in STATIC.rglob("*") if p.is_file()]
        run = subprocess.run(["git", "check-ignore", *files], cwd=root, capture_output=True)
        assert run.returncode == 1, run.stdout.decode()  # 1: none is ignored


def _wait(cond, what: str, timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > end:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.01)


def test_full_queue_is_503_and_dropped_requests_do_no_harm():
    shape = gloffset.read(TRI)
    app = create_app({"tri": shape}, queue_size=1, render_timeout=60)
    svc = app.state.server.tiles
    style = TileStyle()
    keys = [TileKey("tri", 0.02, 4, x, 6, 256, style) for x in (3, 4, 5)]
    with TestClient(app) as c:
        svc.gate.clear()  # the render thread waits after taking a request
        try:
            first = svc.submit(keys[0])
            _wait(svc.queue.empty, "the render thread to take the first tile")
            second = svc.submit(keys[1])  # the queue (of one) is full now
            with pytest.raises(QueueFull):
                svc.submit(keys[2])
            r = c.get("/tiles/tri/100km/4/3/6.png")
            assert r.status_code == 503 and r.headers["retry-after"] == "1"
            assert "queue is full" in r.json()["detail"]
            # a request whose client went away before its turn: skipped, no harm done
            assert second.cancel()
        finally:
            svc.gate.set()
        assert first.result(timeout=60)[:8] == b"\x89PNG\r\n\x1a\n"
        assert second.cancelled()
        _wait(lambda: svc.queue.empty(), "the queue to drain")
        r = c.get("/tiles/tri/100km/4/3/6.png")
        assert r.status_code == 200 and svc.thread.is_alive()


def test_the_render_thread_outlives_a_failing_batch(monkeypatch):
    import gloffset.serve.service as service

    app = create_app({"tri": gloffset.read(TRI)}, render_timeout=60)
    svc = app.state.server.tiles
    real = service.render_tiles
    calls = []

    def broken(*args, **kw):
        calls.append(1)
        if len(calls) == 1:
            raise RuntimeError("the GPU went away")
        return real(*args, **kw)

    monkeypatch.setattr(service, "render_tiles", broken)
    with TestClient(app, raise_server_exceptions=False) as c:
        assert c.get("/tiles/tri/100km/4/3/6.png").status_code == 500
        with pytest.raises(ZeroDivisionError):
            svc.call(lambda: 1 / 0).result(timeout=60)
        r = c.get("/tiles/tri/100km/4/3/6.png")
        assert r.status_code == 200 and r.headers["x-gloffset-tile"] == "rendered"
    assert svc.thread.is_alive() and len(calls) == 2


def test_a_tile_not_rendered_in_time_is_503():
    app = create_app({"tri": gloffset.read(TRI)}, render_timeout=0.2)
    svc = app.state.server.tiles
    with TestClient(app) as c:
        svc.gate.clear()
        try:
            r = c.get("/tiles/tri/100km/4/3/6.png")
        finally:
            svc.gate.set()
        assert r.status_code == 503 and "within 0.2 s" in r.json()["detail"]
        assert r.headers["retry-after"] == "1"
        # the render goes on after the timeout: the tile comes once made (a retry, as the
        # header asks, where a loaded machine makes it slower than 0.2 s again)
        for _ in range(100):
            again = c.get("/tiles/tri/100km/4/3/6.png")
            if again.status_code != 503:
                break
            time.sleep(0.1)
        assert again.status_code == 200


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def live_server():
    """A real uvicorn server on a free port, in a thread; yields (base URL, app)."""
    uvicorn = pytest.importorskip("uvicorn")
    app = create_app({"tri": gloffset.read(TRI)}, render_timeout=60)
    port = _free_port()
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="error"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    _wait(lambda: server.started, "the server to start")
    yield f"http://127.0.0.1:{port}", app
    server.should_exit = True
    thread.join(timeout=30)


def test_a_client_that_disconnects_mid_request(live_server):
    base, app = live_server
    svc = app.state.server.tiles
    port = int(base.rsplit(":", 1)[1])
    path = "/tiles/tri/100km/4/3/6.png"
    svc.gate.clear()
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
            s.sendall(f"GET {path} HTTP/1.1\r\nHost: x\r\n\r\n".encode())
            _wait(svc.queue.empty, "the render thread to take the tile")
        # the client is gone while its tile waits on the render thread
    finally:
        svc.gate.set()
    _wait(lambda: svc.rendered >= 1, "the tile to render")
    with urllib.request.urlopen(base + path, timeout=60) as r:
        assert r.status == 200 and r.headers["X-Gloffset-Tile"] == "cached"
    assert svc.thread.is_alive()


def test_cli_refuses_two_layers_of_one_name(tmp_path):
    for sub in ("a", "b"):
        (tmp_path / sub).mkdir()
        (tmp_path / sub / "x.geojson").write_text(json.dumps(TRI))
    r = CliRunner().invoke(
        main, ["serve", str(tmp_path / "a" / "x.geojson"), str(tmp_path / "b" / "x.geojson")]
    )
    assert r.exit_code == 2 and "two inputs are named 'x'" in r.output


def _children(pid: int) -> int:
    """How many processes have ``pid`` as parent (Linux /proc; -1 elsewhere)."""
    proc = Path("/proc")
    if not proc.is_dir():
        return -1
    n = 0
    for stat in proc.glob("[0-9]*/stat"):
        try:
            n += int(stat.read_text().rsplit(")", 1)[1].split()[1]) == pid
        except (OSError, ValueError, IndexError):
            pass
    return n


@pytest.mark.parametrize("workers", [1, 2])
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_cli_serves_and_stops_on_ctrl_c(tmp_path, workers):
    src = tmp_path / "tri.geojson"
    src.write_text(json.dumps(TRI))
    port = _free_port()
    cmd = [sys.executable, "-m", "gloffset", "serve", str(src), "--port", str(port)]
    log = tmp_path / "access.log"  # the workers append to one file
    cmd += ["--access-log", str(log.relative_to(tmp_path))]
    proc = subprocess.Popen(cmd + ["--workers", str(workers)], stderr=subprocess.PIPE, cwd=tmp_path)
    try:
        for _ in range(200):
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/layers", timeout=1) as r:
                    layers = json.loads(r.read())
                break
            except OSError:
                time.sleep(0.1)
        else:
            pytest.fail("the server did not answer")
        assert layers[0]["name"] == "tri"
        for z, x, y in [(3, 1, 3), (5, 6, 13), (4, 3, 6), (6, 12, 27)]:
            url = f"http://127.0.0.1:{port}/tiles/tri/300km/{z}/{x}/{y}.png"
            with urllib.request.urlopen(url, timeout=60) as r:
                assert r.status == 200 and r.read()[:4] == b"\x89PNG"
        if workers > 1:  # the worker processes run beside the supervisor
            n = _children(proc.pid)  # the workers (and multiprocessing's resource tracker)
            assert n == -1 or n >= workers
    finally:
        proc.send_signal(signal.SIGINT)
        err = proc.communicate(timeout=30)[1].decode()
    assert proc.returncode == 0, err
    assert f"http://127.0.0.1:{port}/" in err
    rows = [line.split(" ") for line in log.read_text().splitlines()]
    tiles = [r for r in rows if r[2].startswith("/tiles/tri/300km/")]
    assert len(tiles) == 4 and all(r[3] == "200" and int(r[4]) > 0 for r in tiles), rows


def test_caches_stay_within_their_bounds_for_many_small_tiles():
    """The tile LRU counts each entry's keeping (:data:`ENTRY` bytes) beside its bytes, so
    a bound of 64 KiB holds a hundred-odd tiny tiles, not thousands (their keys and links
    once grew a server's memory past its bound); the newest stay."""
    svc = TileService({"m": gloffset.read(ROOT / "data" / "mexico_10m.geojson")}, cache_mb=1 / 16)
    style = TileStyle()
    try:
        keys = [TileKey("m", 0.01, 12, x, 7, 256, style) for x in range(5000)]
        for k in keys:
            svc._keep(k, b"tiny")
        assert svc.cache_bytes <= svc.cache_limit
        assert len(svc.cache) * (ENTRY + 4) <= svc.cache_limit < (len(svc.cache) + 1) * (ENTRY + 4)
        assert svc.cached(keys[-1]) == b"tiny" and svc.cached(keys[0]) is None
    finally:
        svc.close()


def test_the_row_bounds_memo_stays_small():
    """A tile server asks a pyramid for a few rows at a time, at every zoom, for hours: the
    memo of :meth:`TilePyramid.decision_rho` holds at most :data:`_MEMO_SIZE` rows (then
    starts again), and every value is the one computed afresh."""
    from gloffset.grids import mercator

    pyr = mercator.TilePyramid(20)
    rng = np.random.default_rng(3)
    for _ in range(600):
        z = int(rng.integers(8, 21))
        rows = rng.integers(0, 1 << z, size=30).astype(np.float64)
        got = pyr.decision_rho(z, rows)
        assert np.array_equal(got, pyr._row_rho(z, rows))
        assert len(pyr._rho_memo) <= mercator._MEMO_SIZE + mercator._MEMO_ROWS
    assert mercator._MEMO_SIZE <= 1 << 13  # about 1 MB a pyramid


@pytest.mark.parametrize("layer", ["mexico", "europe"])
def test_renders_take_the_measured_statuses(layer, world):
    """``render_tiles(..., centres=...)`` (a server's tiles, their centres measured for the
    triage) takes the centres' statuses instead of counting crossings again: the same bytes
    as without them, at positive, zero and negative distances, on one country and on a
    union of neighbours (a status bit per country); statuses turned over change the tiles,
    so they are read."""
    from gloffset.tiles.tiling import measure_tiles, render_tiles
    from gloffset.tiles.tiling.ondemand import TileCentre

    if layer == "mexico":
        shape = gloffset.read(ROOT / "data" / "mexico_10m.geojson")
        views = [(5, 6, 13), (7, 27, 51), (10, 220, 440)]
    else:
        names = ["France", "Germany", "Spain", "Italy", "Switzerland", "Austria", "Belgium"]
        shape = gloffset.read({"type": "FeatureCollection", "features": [world[n] for n in names]})
        views = [(5, 16, 11), (6, 33, 22), (8, 133, 90)]
    turned = 0
    for z, x0, y0 in views:
        tiles = [(x0 + i, y0 + j) for i in range(3) for j in range(2)]
        centres = measure_tiles(shape, z, tiles)
        for d in (-0.004, 0.0, 0.003):
            want = render_tiles(shape, d, z, tiles)
            assert render_tiles(shape, d, z, tiles, centres=centres) == want, (z, d)
            flipped = {
                t: TileCentre(c.dist, c.dring, c.inside, c.rho, bytes(255 ^ b for b in c.status))
                for t, c in centres.items()
            }
            turned += render_tiles(shape, d, z, tiles, centres=flipped) != want
    assert turned


def test_the_render_thread_hands_freed_memory_back(monkeypatch):
    """After a render batch, at most every :data:`TRIM` seconds, the render thread hands the
    freed heap back to the system (so the RSS follows the memory in use, not the largest
    batch so far)."""
    from gloffset.serve import service as svc

    calls = []
    monkeypatch.setattr(svc, "give_back_freed_memory", lambda: calls.append(1) or True)
    monkeypatch.setattr(svc, "TRIM", 0.0)
    tiles = svc.TileService({"m": gloffset.read(ROOT / "data" / "mexico_10m.geojson")})
    try:
        for _ in range(3):
            assert tiles.call(lambda: 1).result(timeout=60) == 1
        deadline = time.monotonic() + 10
        while len(calls) < 3 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert len(calls) >= 3
        monkeypatch.setattr(svc, "TRIM", 3600.0)
        before = len(calls)
        assert tiles.call(lambda: 2).result(timeout=60) == 2
        time.sleep(0.2)
        assert len(calls) == before
    finally:
        tiles.close()
