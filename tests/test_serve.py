"""``gloffset serve``: every endpoint, the error codes, ETag/304, HEAD, a full queue, a
dropped request, and tiles equal to gloffset.render on the same Tile."""

from __future__ import annotations

import io
import json
import signal
import socket
import subprocess
import sys
import time
import urllib.request

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

from gloffset.raster.tilepaint import TileStyle  # noqa: E402
from gloffset.serve.app import create_app  # noqa: E402
from gloffset.serve.service import QueueFull, TileKey  # noqa: E402

TRI = {"type": "Polygon", "coordinates": [[[-110, 15], [-90, 15], [-100, 30], [-110, 15]]]}
LINE_AM = {"type": "LineString", "coordinates": [[170, -10], [-170, 5], [-160, 20]]}


@pytest.fixture(scope="module")
def client():
    layers = {"tri": gloffset.read(TRI), "am": gloffset.read(LINE_AM)}
    with TestClient(create_app(layers, queue_size=64, cache_mb=16)) as c:
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
    h = client.head(url)
    assert h.status_code == 200 and h.headers["etag"] == tag and h.content == b""
    assert client.head("/layers").status_code == 200


def test_inside_and_outside_tiles(client):
    # far from the triangle: empty; deep inside it at a large distance: full
    empty = client.get("/tiles/tri/100km/6/0/0.png")
    assert empty.status_code == 200 and not alpha(empty.content).any()
    full = client.get("/tiles/tri/1000km/7/28/56.png")
    assert full.status_code == 200 and alpha(full.content).all()


@pytest.mark.parametrize(
    "url, status, words",
    [
        ("/tiles/nope/100km/1/0/0.png", 404, "no layer 'nope'"),
        ("/tiles/tri/12parsec/1/0/0.png", 400, "parsec"),
        ("/tiles/tri/100km/23/0/0.png", 400, "zoom must be 0..22"),
        ("/tiles/tri/100km/2/4/0.png", 400, "does not exist"),
        ("/tiles/tri/100km/a/0/0.png", 400, "integers"),
        ("/tiles/tri/100km/1/0/0.png?opacity=2", 400, "opacity"),
        ("/tiles/tri/100km/1/0/0.png?fill=notacolour", 400, "colour"),
        ("/tilejson/tri.json", 400, "distance"),
        ("/distance/tri?lon=200&lat=0", 400, "lon"),
        ("/distance/tri?lat=0", 400, "lon and lat"),
        ("/offset/tri.geojson?distance=-1km", 200, ""),
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
    w, s, e, n = tj["bounds"]
    assert (w, s, e, n) == (-110, 15, -90, 30)
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
    assert "tilejson/tri.json" in client.get("/").text


def test_full_queue_is_503_and_dropped_requests_do_no_harm():
    shape = gloffset.read(TRI)
    app = create_app({"tri": shape}, queue_size=1)
    svc = app.state.server.tiles
    with TestClient(app) as c:
        svc.hold.set()  # the render thread waits after taking its first request
        style = TileStyle()
        keys = [TileKey("tri", 0.02, 4, x, 6, 256, style) for x in range(4)]
        futures = []
        with pytest.raises(QueueFull):
            for k in keys:
                futures.append(svc.submit(k))
        r = c.get("/tiles/tri/100km/4/3/6.png")
        assert r.status_code == 503 and r.headers["retry-after"] == "1"
        del futures[:1]  # a client that went away: its tile is rendered and dropped
        svc.hold.clear()
        for f in futures:
            assert f.result(timeout=60)[:8] == b"\x89PNG\r\n\x1a\n"
        assert c.get("/tiles/tri/100km/4/3/6.png").status_code == 200


def test_cli_refuses_two_layers_of_one_name(tmp_path):
    for sub in ("a", "b"):
        (tmp_path / sub).mkdir()
        (tmp_path / sub / "x.geojson").write_text(json.dumps(TRI))
    r = CliRunner().invoke(
        main, ["serve", str(tmp_path / "a" / "x.geojson"), str(tmp_path / "b" / "x.geojson")]
    )
    assert r.exit_code == 2 and "two inputs are named 'x'" in r.output


def test_cli_serves_and_stops_on_ctrl_c(tmp_path):
    src = tmp_path / "tri.geojson"
    src.write_text(json.dumps(TRI))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen(
        [sys.executable, "-m", "gloffset", "serve", str(src), "--port", str(port)],
        stderr=subprocess.PIPE,
    )
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
        url = f"http://127.0.0.1:{port}/tiles/tri/300km/3/1/3.png"
        with urllib.request.urlopen(url, timeout=30) as r:
            assert r.status == 200 and r.read()[:4] == b"\x89PNG"
    finally:
        proc.send_signal(signal.SIGINT)
        err = proc.communicate(timeout=30)[1].decode()
    assert proc.returncode == 0, err
    assert f"http://127.0.0.1:{port}/" in err
