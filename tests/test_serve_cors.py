"""CORS of ``gloffset serve``: a map on another origin uses the tiles.

MapLibre fetches tiles with ``fetch`` and WebGL takes a cross-origin image into a texture
only when the server allows its origin (CORS). The browser test serves a blank page from
a second local HTTP server (another port: another origin) in Debian's chromium, driven by
playwright as in ``tests/test_serve_browser.py``, and from it fetches a tile of the
server, uploads it into a WebGL texture and reads the texture back: it works with the
default ``--cors '*'`` (the texture holds the tile's pixels) and fails with ``--cors
none``. Skipped, with the reason, only where chromium or playwright cannot be found.
"""

from __future__ import annotations

import contextlib
import functools
import http.server
import io
import shutil
import socket
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import gloffset
from gloffset.cli import main
from gloffset.errors import OptionError

pytest.importorskip("starlette")
uvicorn = pytest.importorskip("uvicorn")

from starlette.testclient import TestClient  # noqa: E402

from gloffset.serve.app import cors_origins, create_app  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MEXICO = ROOT / "data" / "mexico_10m.geojson"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
TILE = "/tiles/mexico/500km/0/0/0.png"


@pytest.fixture(scope="module")
def shape():
    # Mexico at 1:110m: the one tile rendered is cheap
    return gloffset.read(ROOT / "data" / "world_110m.geojson", where="NAME = 'Mexico'")


# ------------------------------------------------------------------ the headers
def test_cors_origins_reads_the_option_and_refuses_origins_that_never_match():
    assert cors_origins("*") == ("*",)
    assert cors_origins("none") is None
    assert cors_origins("https://example.com, http://localhost:3000") == (
        "https://example.com",
        "http://localhost:3000",
    )
    assert cors_origins("http://[::1]:8080") == ("http://[::1]:8080",)
    # a browser's Origin has no path, is in lower case and leaves out the default port:
    # these would match no request, silently
    for bad in (
        "https://example.com/",
        "https://example.com/maps",
        "example.com",
        "https://Example.com",
        "https://example.com:443",
        "http://example.com:80",
        "*,https://example.com",
        "",
    ):
        with pytest.raises(OptionError, match="--cors"):
            cors_origins(bad)


def test_the_answers_carry_cors_headers_for_the_origins_allowed(shape):
    page = {"Origin": "http://maps.example.org"}
    with TestClient(create_app({"mexico": shape})) as c:  # the default: any origin
        for path in ("/layers", "/field/mexico.json", "/distance/mexico?lon=-100&lat=20"):
            r = c.get(path, headers=page)
            assert r.status_code == 200 and r.headers["access-control-allow-origin"] == "*"
        r = c.get("/tiles/mexico/500km/5/0/0.png", headers=page)  # decided outside
        assert r.headers["access-control-allow-origin"] == "*"
        # a script may read the tile's tag and how it was found
        exposed = r.headers["access-control-expose-headers"].lower()
        assert {"etag", "x-gloffset-tile", "retry-after"} <= set(exposed.split(", "))
        pre = c.options(
            TILE, headers={**page, "Access-Control-Request-Method": "GET"}
        )  # a preflight
        assert pre.status_code == 200 and pre.headers["access-control-allow-origin"] == "*"
    listed = create_app({"mexico": shape}, cors=("http://maps.example.org",))
    with TestClient(listed) as c:
        r = c.get("/layers", headers=page)
        assert r.headers["access-control-allow-origin"] == "http://maps.example.org"
        assert "origin" in r.headers["vary"].lower()  # caches keep one answer per origin
        other = c.get("/layers", headers={"Origin": "http://elsewhere.example.org"})
        assert "access-control-allow-origin" not in other.headers
    with TestClient(create_app({"mexico": shape}, cors=None)) as c:
        r = c.get("/layers", headers=page)
        assert r.status_code == 200 and "access-control-allow-origin" not in r.headers


def test_cli_cors_option(monkeypatch):
    """``--cors`` reaches the application ('*' by default, 'none': no CORS); a bad
    origin is one line on stderr with exit status 2, before the inputs are read."""
    got = {}
    monkeypatch.setattr(uvicorn, "run", lambda target, **kw: got.update(app=target))
    for args, want in (([], "*"), (["--cors", "none"], None)):
        r = CliRunner().invoke(main, ["serve", str(MEXICO), *args])
        assert r.exit_code == 0, r.output
        with TestClient(got["app"]) as c:
            h = c.get("/layers", headers={"Origin": "http://a.example"}).headers
            assert h.get("access-control-allow-origin") == want
    r = CliRunner().invoke(main, ["serve", "no/such/file.geojson", "--cors", "http://a.example/"])
    assert r.exit_code == 2 and "--cors: 'http://a.example/' is not an origin" in r.output
    assert "no/such/file" not in r.output  # refused before the input was read


def test_an_unknown_path_names_the_endpoints(shape):
    """``/distance?lon=..`` is no endpoint (the route is ``/distance/{layer}``): the 404
    says so and lists the endpoints."""
    with TestClient(create_app({"mexico": shape})) as c:
        r = c.get("/distance?lon=-100&lat=20")
        assert r.status_code == 404
        detail = r.json()["detail"]
        assert "no endpoint at '/distance'" in detail and "/distance/{layer}" in detail
        assert c.get("/distance/mexico?lon=-100&lat=20").status_code == 200


# ------------------------------------------------------------------ in a browser
@contextlib.contextmanager
def _uvicorn(app):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    srv = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="error"))
    thread = threading.Thread(target=srv.run, daemon=True)
    thread.start()
    end = time.monotonic() + 60
    while not srv.started:
        assert time.monotonic() < end, "the server did not start"
        time.sleep(0.05)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        srv.should_exit = True
        thread.join(timeout=30)


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@contextlib.contextmanager
def _other_origin():
    """A second HTTP server on another port (another origin) serving a blank page."""
    with tempfile.TemporaryDirectory() as root:
        Path(root, "index.html").write_text("<!doctype html><title>a map elsewhere</title>")
        handler = functools.partial(_Quiet, directory=root)
        httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
        thread = threading.Thread(target=httpd.serve_forever, daemon=True)
        thread.start()
        try:
            yield f"http://127.0.0.1:{httpd.server_address[1]}"
        finally:
            httpd.shutdown()
            httpd.server_close()


#: From the page: fetch the tile, decode it, upload it into a WebGL texture and read the
#: texture back through a framebuffer; then the same through an <img crossorigin>.
#: Returns what happened to each, and the opaque pixels the texture held.
PROBE = """async (url) => {
    const gl = document.createElement('canvas').getContext('webgl');
    if (!gl) return {error: 'no WebGL'};
    gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, gl.NONE);
    gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
    const texture = (img) => {
        const tex = gl.createTexture();
        gl.bindTexture(gl.TEXTURE_2D, tex);
        gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA, gl.RGBA, gl.UNSIGNED_BYTE, img);
        const fb = gl.createFramebuffer();
        gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
        gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
        const px = new Uint8Array(img.width * img.height * 4);
        gl.readPixels(0, 0, img.width, img.height, gl.RGBA, gl.UNSIGNED_BYTE, px);
        if (gl.getError() !== gl.NO_ERROR) throw new Error('GL error');
        let opaque = 0;
        for (let i = 3; i < px.length; i += 4) opaque += px[i] === 255;
        return opaque;
    };
    const out = {};
    try {
        const r = await fetch(url);
        const bitmap = await createImageBitmap(await r.blob());
        out.fetch = {ok: true, status: r.status, opaque: texture(bitmap)};
    } catch (e) {
        out.fetch = {ok: false, error: String(e)};
    }
    try {
        const img = new Image();
        img.crossOrigin = 'anonymous';
        await new Promise((ok, fail) => {
            img.onload = ok;
            img.onerror = () => fail(new Error('the image did not load'));
            img.src = url + '?img';
        });
        out.image = {ok: true, opaque: texture(img)};
    } catch (e) {
        out.image = {ok: false, error: String(e)};
    }
    return out;
}"""


def test_a_page_of_another_origin_draws_the_tiles_with_cors_only(shape):
    """With CORS (the default), a page of another origin fetches a tile and takes it into
    a WebGL texture holding the tile's pixels; with ``cors=None`` (``--cors none``) the
    browser refuses both the fetch and the image."""
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium)")
    sync_api = pytest.importorskip(
        "playwright.sync_api", reason="playwright is not installed (pip install -e '.[test]')"
    )
    with (
        _uvicorn(create_app({"mexico": shape}, render_timeout=120)) as open_,
        _uvicorn(create_app({"mexico": shape}, render_timeout=120, cors=None)) as closed,
        _other_origin() as page_origin,
        sync_api.sync_playwright() as pw,
        tempfile.TemporaryDirectory() as profile,
    ):
        png = urllib.request.urlopen(open_ + TILE).read()  # same-origin: no CORS involved
        alpha = np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))[..., 3]
        opaque = int((alpha == 255).sum())
        assert 0 < opaque < alpha.size  # the tile holds the region and the outside
        ctx = pw.chromium.launch_persistent_context(
            profile, executable_path=CHROMIUM, headless=True, args=ARGS
        )
        try:
            ctx.set_default_timeout(120_000)
            pg = ctx.new_page()
            pg.goto(page_origin + "/index.html")
            assert pg.evaluate("() => location.origin") != open_
            got = pg.evaluate(PROBE, open_ + TILE)
            assert got["fetch"] == {"ok": True, "status": 200, "opaque": opaque}, got
            assert got["image"] == {"ok": True, "opaque": opaque}, got
            refused = pg.evaluate(PROBE, closed + TILE)
            assert not refused["fetch"]["ok"] and "fetch" in refused["fetch"]["error"], refused
            assert not refused["image"]["ok"], refused
        finally:
            ctx.close()
