"""The page's vector mode in a real browser (Debian's chromium, as
``tests/test_serve_browser.py``): the server's vector tiles (``/mvt``) filled and outlined
by MapLibre draw the region right at points away from its edge, on the map and on the
globe, and follow the slider to a new distance; the globe's screenshot is the README's
(docs/serve_vector.png). Skipped where chromium or playwright
cannot be found."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mapbox_vector_tile")
from test_serve_browser import (  # noqa: E402, F401  (the fixtures: server, page)
    _check_pixels,
    _move_slider,
    _probes,
    _screenshot,
    page,
    server,
)

ROOT = Path(__file__).resolve().parents[1]


def _settle_vector(pg, distance: str) -> None:
    """Wait until the map shows the vector tiles of ``distance`` and has stopped."""
    pg.wait_for_function(
        """(d) => {
            const p = window.gloffsetPage;
            if (!p) return false;
            const src = p.map.getSource('offset');
            return src && src.type === 'vector' && src.tiles
                && src.tiles[0].endsWith('?d=' + d) && p.map.loaded()
                && p.map.areTilesLoaded() && !p.map.isMoving();
        }""",
        arg=distance,
    )
    pg.evaluate(
        "() => new Promise((ok) => { const m = gloffsetPage.map;"
        " m.once('idle', ok); m.triggerRepaint(); })"
    )


@pytest.mark.slow  # about 45 s; run by .ci/run with -m slow
def test_page_vector_mode_on_the_map_and_the_globe(server, page):  # noqa: F811
    base, shapes = server
    shape = shapes["mexico"]
    pg = page
    asked: list = []
    pg.on("response", lambda r: "/mvt/" in r.url and asked.append((r.url, r.status)))
    pg.goto(f"{base}/#map=4.2/22/-100&layer=mexico&d=127km&mode=vector")
    _settle_vector(pg, "127km")
    style = pg.evaluate("() => gloffsetMap.getStyle()")
    assert style["sources"]["offset"]["type"] == "vector"
    kinds = {ly["id"]: ly["type"] for ly in style["layers"]}
    assert kinds["offset"] == "fill" and kinds["offset-outline"] == "line"
    assert pg.evaluate("() => document.getElementById('vector').checked")
    got = [(u, s) for u, s in asked if "/mvt/mexico/" in u and u.endswith("?d=127km")]
    assert got and all(s == 200 for _, s in got), asked
    img = _screenshot(pg)
    xy, inside, _, _ = _probes(pg, shape, 127e3, margin_m=40e3)
    assert inside.sum() > 20 and (~inside).sum() > 20
    _check_pixels(pg, img, xy, inside)

    # a new distance from the slider: its tiles asked for and drawn
    _move_slider(pg, 400)
    _settle_vector(pg, "400km")
    assert any(u.endswith("?d=400km") for u, _ in asked)
    assert "mode=vector" in pg.evaluate("() => location.hash")
    img = _screenshot(pg)
    xy, inside, _, _ = _probes(pg, shape, 400e3, margin_m=40e3)
    assert inside.sum() > 20 and (~inside).sum() > 10
    _check_pixels(pg, img, xy, inside)

    # the globe
    pg.locator("#globe").check()
    pg.wait_for_function("() => gloffsetMap.getProjection().type === 'globe'")
    _settle_vector(pg, "400km")
    img = _screenshot(pg, ROOT / "docs" / "serve_vector.png")  # the README's picture
    xy, inside, _, _ = _probes(pg, shape, 400e3, margin_m=60e3)
    assert inside.sum() > 20 and (~inside).sum() > 10
    _check_pixels(pg, img, xy, inside)
    assert np.isfinite(img).all()
