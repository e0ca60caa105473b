"""The page of ``gloffset serve`` in a real browser: Debian's chromium driven by
playwright against a real server. In the default mode (distance-field tiles drawn by a
color-relief layer), it loads the page, changes the distance with the slider and the URL
hash (inward too), checks that no tile or field was requested for it, and compares
screenshot pixels at points known to be inside and outside the region (gloffset.contains),
on the map and on the globe; the globe screenshot at an inward distance is the README's
(docs/serve_globe.png). With the server's exact tiles (the toggle, ``mode=exact``), it
checks that the tiles of a new distance are requested and drawn, and follows an inward
distance set through the URL hash after the page has loaded: the tiles, the slider, its
unit, the legend and the pixels at that distance.

Skipped, with the reason, only where chromium or playwright cannot be found (.ci/run
installs chromium with apt-get)."""

from __future__ import annotations

import io
import shutil
import socket
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import gloffset

pytest.importorskip("starlette")
uvicorn = pytest.importorskip("uvicorn")
sync_api = pytest.importorskip(
    "playwright.sync_api", reason="playwright is not installed (pip install -e '.[test]')"
)

from gloffset.serve.app import create_app  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
VIEW = (960, 640)


@pytest.fixture(scope="module")
def server():
    shape = gloffset.read(ROOT / "data" / "mexico_10m.geojson")
    # Mexico at 1:110m for the field tiles: a field costs 1-3 s a tile at 1:10m on the CPU
    coarse = gloffset.read(ROOT / "data" / "world_110m.geojson", where="NAME = 'Mexico'")
    app = create_app({"mexico": shape, "mexico110": coarse}, render_timeout=120)
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
    yield f"http://127.0.0.1:{port}", {"mexico": shape, "mexico110": coarse}
    srv.should_exit = True
    thread.join(timeout=30)


@pytest.fixture(scope="module")
def page(server):
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium)")
    with sync_api.sync_playwright() as pw, tempfile.TemporaryDirectory() as profile:
        ctx = pw.chromium.launch_persistent_context(
            profile,
            executable_path=CHROMIUM,
            headless=True,
            args=ARGS,
            viewport={"width": VIEW[0], "height": VIEW[1]},
            device_scale_factor=1,
        )
        ctx.set_default_timeout(120_000)
        pg = ctx.new_page()
        errors: list = []
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.tiles = []  # (url, status) of every tile response
        pg.on("response", lambda r: "/tiles/" in r.url and pg.tiles.append((r.url, r.status)))
        pg.asked = []  # the url of every tile or field request
        pg.on(
            "request",
            lambda r: ("/tiles/" in r.url or "/field/" in r.url) and pg.asked.append(r.url),
        )
        try:
            yield pg
        finally:
            ctx.close()
        assert not errors, errors


def _settle(pg, distance: str) -> None:
    """Wait until the map shows the tiles of ``distance`` and has stopped rendering."""
    pg.wait_for_function(
        """(d) => {
            const p = window.gloffsetPage;
            if (!p) return false;
            const src = p.map.getSource('offset');
            // a raster source has no tiles until its style is in place
            return src && src.tiles && src.tiles[0].includes('/' + d + '/') && p.map.loaded()
                && p.map.areTilesLoaded() && !p.map.isMoving();
        }""",
        arg=distance,
    )
    pg.evaluate(
        "() => new Promise((ok) => { const m = gloffsetPage.map;"
        " m.once('idle', ok); m.triggerRepaint(); })"
    )


def _settle_field(pg, metres: float) -> None:
    """Wait until the map draws the field at ``metres`` and has stopped rendering."""
    pg.wait_for_function(
        """(d) => {
            const p = window.gloffsetPage;
            if (!p || !p.map.getLayer('offset')) return false;
            const ramp = p.map.getPaintProperty('offset', 'color-relief-color');
            return p.map.getLayer('offset').type === 'color-relief' && ramp[3] === d - 1
                && ramp[5] === d && p.map.loaded() && p.map.areTilesLoaded()
                && !p.map.isMoving();
        }""",
        arg=metres,
    )
    pg.evaluate(
        "() => new Promise((ok) => { const m = gloffsetPage.map;"
        " m.once('idle', ok); m.triggerRepaint(); })"
    )


def _screenshot(pg, path: Path | None = None) -> np.ndarray:
    png = pg.screenshot()
    if path is not None:
        path.write_bytes(png)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def _probes(pg, shape, d_m: float, margin_m: float):
    """Screen points with their expected membership: lon/lat on a grid around the
    input, kept where the answer is clear (farther than ``margin_m`` from the region's
    edge and from the drawn input) and visible away from the panel."""
    lon, lat = np.meshgrid(np.linspace(-125, -75, 41), np.linspace(5, 40, 29))
    lon, lat = lon.ravel(), lat.ravel()
    dist = gloffset.distance(shape, lon, lat)
    inside = gloffset.contains(shape, lon, lat, distance=d_m)
    clear = (np.abs(dist - abs(d_m)) > margin_m) & (dist > margin_m)
    pts = pg.evaluate(
        """(ll) => ll.map(([x, y]) => { const p = gloffsetPage.map.project([x, y]);
                return [p.x, p.y]; })""",
        np.c_[lon, lat].tolist(),
    )
    xy = np.asarray(pts)
    seen = (xy[:, 0] > 4) & (xy[:, 0] < VIEW[0] - 4) & (xy[:, 1] > 4) & (xy[:, 1] < VIEW[1] - 4)
    # no pixel is compared under the control panel or the legend
    boxes = pg.evaluate(
        """() => ['panel', 'legend'].map((id) => {
            const r = document.getElementById(id).getBoundingClientRect();
            return [r.left, r.top, r.right, r.bottom]; })"""
    )
    for x0, y0, x1, y1 in boxes:
        seen &= ~(
            (xy[:, 0] > x0 - 4) & (xy[:, 0] < x1 + 4) & (xy[:, 1] > y0 - 4) & (xy[:, 1] < y1 + 4)
        )
    keep = clear & seen
    return xy[keep].round().astype(int), inside[keep], lon[keep], lat[keep]


def _colours(pg) -> tuple[np.ndarray, np.ndarray]:
    fill, bg, a = pg.evaluate(
        "() => [gloffsetPage.FILL, gloffsetPage.BACKGROUND, gloffsetPage.FILL_OPACITY]"
    )

    def rgb(h):
        return np.array([int(h[i : i + 2], 16) for i in (1, 3, 5)])

    return a * rgb(fill) + (1 - a) * rgb(bg), rgb(bg)


def _check_pixels(pg, img, xy, inside) -> None:
    want_in, want_out = _colours(pg)
    px = img[xy[:, 1], xy[:, 0]]
    d_in = np.abs(px - want_in).max(axis=1)
    d_out = np.abs(px - want_out).max(axis=1)
    got = d_in < d_out
    bad = np.flatnonzero(got != inside)
    assert len(bad) == 0, [(tuple(xy[i]), bool(inside[i]), tuple(px[i])) for i in bad[:10]]
    far = np.flatnonzero(np.minimum(d_in, d_out) > 12)
    assert len(far) == 0, (
        "pixels match neither the fill nor the background",
        [(tuple(xy[i]), tuple(px[i])) for i in far[:10]],
    )


def _move_slider(pg, value: int) -> None:
    pg.locator("#distance").fill(str(value))


@pytest.mark.slow  # about 35 s (fields of the globe's tiles on the CPU); .ci/run runs it
def test_page_field_mode_slider_hash_and_globe(server, page):
    """The default mode draws the field tiles: the slider and the hash (to an inward
    distance too) change the drawing with no request, on the map and on the globe; a click
    shows the distance at a point; the toggle switches to the exact tiles."""
    base, shapes = server
    shape = shapes["mexico110"]
    pg = page
    pg.goto(f"{base}/#map=3.6/23/-102&layer=mexico110&d=127km")
    _settle_field(pg, 127e3)
    assert pg.evaluate("() => gloffsetMap.getStyle().sources.offset.type") == "raster-dem"
    assert any("/field/mexico110/" in u for u in pg.asked)
    assert not any("/tiles/" in u for u in pg.asked)
    # the view comes from the URL hash
    zoom, lon, lat = pg.evaluate(
        "() => { const m = gloffsetPage.map; const c = m.getCenter();"
        " return [m.getZoom(), c.lng, c.lat]; }"
    )
    assert abs(zoom - 3.6) < 1e-6 and abs(lon + 102) < 1e-6 and abs(lat - 23) < 1e-6

    # the slider: the region at the new distance, with no request
    seen = len(pg.asked)
    _move_slider(pg, 400)
    _settle_field(pg, 400e3)
    assert pg.asked[seen:] == []
    assert "d=400km" in pg.evaluate("() => location.hash")
    img = _screenshot(pg)
    xy, inside, lon, lat = _probes(pg, shape, 400e3, margin_m=60e3)
    before = gloffset.contains(shape, lon, lat, distance=127e3)
    assert inside.sum() > 20 and (~inside).sum() > 20 and (inside & ~before).sum() > 10
    _check_pixels(pg, img, xy, inside)
    # inward, by the slider
    _move_slider(pg, -150)
    _settle_field(pg, -150e3)
    assert pg.asked[seen:] == []
    xy, inside, lon, lat = _probes(pg, shape, -150e3, margin_m=60e3)
    near = gloffset.contains(shape, lon, lat, distance=0.0) & ~inside
    assert inside.sum() > 5 and near.sum() > 5
    _check_pixels(pg, _screenshot(pg), xy, inside)
    # inward, by the hash, in another unit
    pg.evaluate("() => { location.hash = 'map=3.6/23/-102&layer=mexico110&d=-60nmi'; }")
    _settle_field(pg, -60 * 1852.0)
    assert pg.asked[seen:] == []
    assert "d = -60 nmi" in pg.locator("#legend").text_content()
    xy, inside, _, _ = _probes(pg, shape, -60 * 1852.0, margin_m=60e3)
    assert inside.sum() > 10 and (~inside).sum() > 20
    _check_pixels(pg, _screenshot(pg), xy, inside)

    # a click shows the distance to the curves
    x, y = xy[np.flatnonzero(~inside)[0]]
    ll = pg.evaluate(f"() => gloffsetPage.map.unproject([{x}, {y}]).toArray()")
    pg.mouse.click(int(x), int(y))
    pg.wait_for_function("() => document.getElementById('info').textContent.includes('km from')")
    text = pg.locator("#info").text_content()
    want = float(gloffset.distance(shape, [round(ll[0], 6)], [round(ll[1], 6)])[0]) / 1e3
    assert abs(float(text.split()[0]) - want) < 0.01, (text, want)
    pg.keyboard.press("Escape")
    pg.evaluate("() => document.querySelectorAll('.maplibregl-popup').forEach((e) => e.remove())")

    # the globe, at an inward distance (the README's picture), then outward by the hash
    pg.locator("#globe").check()
    pg.evaluate("() => gloffsetPage.map.jumpTo({zoom: 2.3, center: [-100, 22]})")
    pg.locator("#unit").select_option("km")
    _move_slider(pg, -100)
    _settle_field(pg, -100e3)
    assert pg.evaluate("() => gloffsetPage.map.getProjection().type") == "globe"
    assert "globe=1" in pg.evaluate("() => location.hash")
    img = _screenshot(pg, ROOT / "docs" / "serve_globe.png")
    xy, inside, _, _ = _probes(pg, shape, -100e3, margin_m=100e3)
    assert inside.sum() > 3 and (~inside).sum() > 10
    _check_pixels(pg, img, xy, inside)
    # off the globe's disc the page's own background shows: the map is a sphere
    assert img[VIEW[1] - 3, VIEW[0] - 3].tolist() == [0x10, 0x20, 0x2E]
    seen = len(pg.asked)
    pg.evaluate("() => { location.hash = 'map=2.3/22/-100&layer=mexico110&d=700km&globe=1'; }")
    _settle_field(pg, 700e3)
    assert pg.asked[seen:] == []
    xy, inside, _, _ = _probes(pg, shape, 700e3, margin_m=150e3)
    assert inside.sum() > 10 and (~inside).sum() > 10
    _check_pixels(pg, _screenshot(pg), xy, inside)
    mercator_corner = _colours(pg)[1].tolist()
    pg.locator("#globe").uncheck()
    _settle_field(pg, 700e3)
    assert pg.evaluate("() => gloffsetPage.map.getProjection().type") == "mercator"
    assert _screenshot(pg)[VIEW[1] - 3, VIEW[0] - 3].tolist() == mercator_corner

    # the toggle: the server's exact tiles at the same distance
    pg.locator("#exact").check()
    _settle(pg, "700km")
    assert pg.evaluate("() => gloffsetMap.getStyle().sources.offset.type") == "raster"
    assert "mode=exact" in pg.evaluate("() => location.hash")
    new = [(u, s) for u, s in pg.tiles if "/tiles/mexico110/700km/" in u]
    assert new and all(s == 200 for _, s in new)
    xy, inside, _, _ = _probes(pg, shape, 700e3, margin_m=60e3)
    _check_pixels(pg, _screenshot(pg), xy, inside)


@pytest.mark.slow  # 7 s; run by .ci/run with -m slow
def test_page_follows_the_hash_to_an_inward_offset(server, page):
    """With the exact tiles (mode=exact), the slider asks for the tiles of the new
    distance, and a distance set in the URL hash after the page has loaded (a link, a
    script) is followed: a negative one (inside the polygons and farther than |d| from their
    boundary) in another unit, its tiles requested and drawn, the slider, its unit and
    the legend showing it; the map is window.gloffsetMap."""
    base, shapes = server
    shape = shapes["mexico"]
    pg = page
    pg.goto(f"{base}/#map=4.2/22/-100&layer=mexico&d=127km&mode=exact")
    _settle(pg, "127km")
    assert pg.evaluate("() => window.gloffsetMap === window.gloffsetPage.map")
    assert pg.evaluate("() => window.gloffsetMap.getStyle().sources.offset.type") == "raster"
    # the slider: tiles of the new distance are requested and drawn
    _move_slider(pg, 400)
    _settle(pg, "400km")
    new = [(u, s) for u, s in pg.tiles if "/tiles/mexico/400km/" in u]
    assert new and all(s == 200 for _, s in new)
    assert "d=400km" in pg.evaluate("() => location.hash")
    seen = len(pg.tiles)
    pg.evaluate("() => { location.hash = 'map=4.2/22/-100&layer=mexico&d=-100nmi&mode=exact'; }")
    _settle(pg, "-100nmi")
    new = [(u, s) for u, s in pg.tiles[seen:] if "/tiles/mexico/-100nmi/" in u]
    assert new and all(s == 200 for _, s in new), pg.tiles[seen:]
    slider = pg.evaluate(
        """() => { const s = document.getElementById('distance');
            return [s.value, s.min, s.max, document.getElementById('unit').value,
                    document.getElementById('distance-text').textContent,
                    document.getElementById('legend').textContent]; }"""
    )
    value, lo, hi, unit, text, legend = slider
    assert (float(value), unit, text) == (-100, "nmi", "-100 nmi")
    assert float(lo) == -float(hi) and float(hi) >= 1000
    assert "d = -100 nmi" in legend and "farther than 100 nmi" in legend
    img = _screenshot(pg)
    d_m = -100 * 1852.0
    xy, inside, _, _ = _probes(pg, shape, d_m, margin_m=60e3)
    # inside Mexico, some probes are farther than 185 km from the coast, some nearer
    near = gloffset.contains(shape, *_lonlat(pg, xy), distance=0.0) & ~inside
    assert inside.sum() > 10 and near.sum() > 10 and (~inside).sum() > 20
    _check_pixels(pg, img, xy, inside)

    # the unit selector keeps the distance: -100 nmi is -185 km
    pg.locator("#unit").select_option("km")
    _settle(pg, "-185km")
    assert pg.evaluate("() => document.getElementById('distance').value") == "-185"
    assert "d=-185km" in pg.evaluate("() => location.hash")


def _lonlat(pg, xy) -> tuple[np.ndarray, np.ndarray]:
    ll = pg.evaluate(
        "(pts) => pts.map((p) => window.gloffsetMap.unproject(p).toArray())", xy.tolist()
    )
    lon, lat = np.asarray(ll).T
    return lon, lat
