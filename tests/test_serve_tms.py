"""The tile server in other TileMatrixSets: /tiles/{tms}/..., /field/{tms}/...,
/tileMatrixSets (as tests/test_serve.py tests the web-mercator routes)."""

import io

import morecantile
import numpy as np
import pytest
from PIL import Image

import gloffset
from gloffset.grids import TmsTile

pytest.importorskip("starlette")
pytest.importorskip("httpx")
from starlette.testclient import TestClient  # noqa: E402

from gloffset.serve.app import create_app  # noqa: E402
from gloffset.tiles.tiling.fieldtiles import decode_field  # noqa: E402

TRI = {"type": "Polygon", "coordinates": [[[-110, 15], [-90, 15], [-100, 30], [-110, 15]]]}
POLE = {"type": "Polygon", "coordinates": [[[0, -70], [120, -70], [-120, -70], [0, -70]]]}


@pytest.fixture(scope="module")
def client():
    layers = {"tri": gloffset.read(TRI), "pole": gloffset.read(POLE)}
    app = create_app(layers, queue_size=64, cache_mb=16, render_timeout=120)
    with TestClient(app) as c:
        yield c


def on_gl_thread(client, fn):
    return client.app.state.server.tiles.call(fn).result(timeout=120)


def alpha(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))[..., 3]


@pytest.mark.parametrize(
    "tms, layer, dist, z, x, y",
    [
        ("WorldCRS84Quad", "tri", "300km", 2, 1, 1),
        ("WorldCRS84Quad", "tri", "127km", 5, 15, 12),
        ("UPSAntarcticWGS84Quad", "pole", "200km", 2, 1, 1),
        ("UPSAntarcticWGS84Quad", "pole", "-100km", 3, 4, 3),
    ],
)
def test_tms_tiles_equal_render(client, tms, layer, dist, z, x, y):
    r = client.get(f"/tiles/{tms}/{layer}/{dist}/{z}/{x}/{y}.png")
    assert r.status_code == 200 and r.headers["content-type"] == "image/png", r.text
    shape = client.app.state.server.layers[layer]
    d = gloffset.parse_distance(dist)
    grid = TmsTile(tms, z, x, y)
    want = on_gl_thread(client, lambda: gloffset.render(shape, d, grid, radius=1.0)) > 0
    assert want.any() and not want.all()
    np.testing.assert_array_equal(alpha(r.content) > 0, want)


def test_web_mercator_quad_is_todays_route(client):
    a = client.get("/tiles/WebMercatorQuad/tri/300km/3/1/3.png")
    b = client.get("/tiles/tri/300km/3/1/3.png")
    assert a.status_code == b.status_code == 200 and a.content == b.content
    a = client.get("/field/WebMercatorQuad/tri/2/0/1.png")
    b = client.get("/field/tri/2/0/1.png")
    assert a.status_code == b.status_code == 200 and a.content == b.content


def test_tms_field_tile_is_the_distance_field(client):
    r = client.get("/field/WorldCRS84Quad/tri/3/3/3.png")
    assert r.status_code == 200, r.text
    shape = client.app.state.server.layers["tri"]
    grid = TmsTile("WorldCRS84Quad", 3, 3, 3)
    f = on_gl_thread(client, lambda: gloffset.distance_field(shape, grid))
    got = decode_field(r.content)
    assert np.abs(got - np.clip(np.round(f.values), -8388608, 8388607)).max() <= 1.0
    assert (got < 0).any() and (got > 0).any()


def test_tile_matrix_sets(client):
    r = client.get("/tileMatrixSets")
    assert r.status_code == 200
    ids = [t["id"] for t in r.json()["tileMatrixSets"]]
    for name in (
        "WebMercatorQuad",
        "WorldCRS84Quad",
        "UPSArcticWGS84Quad",
        "UPSAntarcticWGS84Quad",
    ):
        assert name in ids
    assert "CanadianNAD83_LCC" not in ids  # not a quadtree
    href = r.json()["tileMatrixSets"][ids.index("WorldCRS84Quad")]["links"][0]["href"]
    assert href.endswith("/tileMatrixSets/WorldCRS84Quad")
    doc = client.get("/tileMatrixSets/WorldCRS84Quad")
    assert doc.status_code == 200
    t = morecantile.TileMatrixSet.model_validate(doc.json())
    assert t.id == "WorldCRS84Quad" and t.matrix(0).matrixWidth == 2


@pytest.mark.parametrize(
    "path, status, words",
    [
        ("/tiles/Nope/tri/100km/0/0/0.png", 404, "unknown TileMatrixSet 'Nope'"),
        ("/tiles/WorldCRS84Quad/tri/100km/1/4/0.png", 400, "does not exist in WorldCRS84Quad"),
        ("/tiles/WorldCRS84Quad/nope/100km/0/0/0.png", 404, "no layer 'nope'"),
        ("/tiles/WorldCRS84Quad/tri/100parsecs/0/0/0.png", 400, "parsecs"),
        ("/tiles/WorldCRS84Quad/tri/100km/0/+1/0.png", 400, "ASCII digits"),
        ("/field/CanadianNAD83_LCC/tri/0/0/0.png", 404, "not a quadtree"),
        ("/tileMatrixSets/Nope", 404, "unknown TileMatrixSet"),
    ],
)
def test_tms_bad_requests(client, path, status, words):
    r = client.get(path)
    assert r.status_code == status and words in r.json()["detail"], r.text


# ------------------------------------------------- the cache, the centres, the TileJSON
def test_tms_tiles_are_cached_under_their_tms(client):
    """A TMS tile asked again comes from the tile cache, under a key with the TMS's id:
    web mercator's tile of the same numbers is another tile."""
    srv = client.app.state.server
    path = "/tiles/WorldCRS84Quad/tri/250km/3/3/2.png"
    a = client.get(path)
    made = ("rendered", "field")  # the field at once where fields cost about a render
    assert a.status_code == 200 and a.headers["x-gloffset-tile"] in made, a.text
    b = client.get(path)
    assert b.headers["x-gloffset-tile"] == "cached" and b.content == a.content
    assert b.headers["etag"] == a.headers["etag"]
    keys = [k for k in srv.tiles.cache if getattr(k, "tms", None) == "WorldCRS84Quad"]
    assert any((k.z, k.x, k.y) == (3, 3, 2) for k in keys)
    wm = client.get("/tiles/tri/250km/3/3/2.png")
    assert wm.status_code == 200 and wm.content != a.content


@pytest.mark.parametrize(
    "tms, layer, dist, z, x, y, how",
    [
        ("UPSAntarcticWGS84Quad", "pole", "200km", 6, 31, 31, "inside"),  # at the pole
        ("UPSAntarcticWGS84Quad", "pole", "200km", 2, 0, 0, "outside"),
        ("WorldCRS84Quad", "tri", "300km", 6, 28, 24, "inside"),
        ("WorldCRS84Quad", "tri", "300km", 4, 0, 0, "outside"),
        ("EuropeanETRS89_LAEAQuad", "tri", "300km", 2, 1, 1, "outside"),
    ],
)
def test_tms_tiles_decided_from_their_centres(client, tms, layer, dist, z, x, y, how):
    """Tiles wholly inside or outside are answered from their centre, as web mercator's
    are (no render), and equal the render of their TmsTile."""
    srv = client.app.state.server
    before = srv.tiles.rendered
    r = client.get(f"/tiles/{tms}/{layer}/{dist}/{z}/{x}/{y}.png")
    assert r.status_code == 200 and r.headers["x-gloffset-tile"] == how, r.text
    assert srv.tiles.rendered == before
    shape = srv.layers[layer]
    d = gloffset.parse_distance(dist)
    grid = TmsTile(tms, z, x, y)
    want = on_gl_thread(client, lambda: gloffset.render(shape, d, grid, radius=1.0)) > 0
    assert want.all() if how == "inside" else not want.any()
    np.testing.assert_array_equal(alpha(r.content) > 0, want)


def test_tms_without_a_bound_renders_every_tile(client):
    """NZTM2000Quad's tiles have no bound: never decided from their centre (this one is
    outside), made (and then cached)."""
    r = client.get("/tiles/NZTM2000Quad/tri/300km/0/0/0.png")
    assert r.status_code == 200 and r.headers["x-gloffset-tile"] in ("rendered", "field"), r.text
    assert not (alpha(r.content) > 0).any()
    r = client.get("/tiles/NZTM2000Quad/tri/300km/0/0/0.png")
    assert r.headers["x-gloffset-tile"] == "cached"


def test_tms_field_tiles_cached_and_thresholded(client):
    """A TMS field tile asked again is the cached one; a tile of a TMS whose field is kept
    is its threshold, the render's pixels."""
    path = "/field/UPSAntarcticWGS84Quad/pole/2/1/2.png"
    a = client.get(path)
    assert a.status_code == 200 and a.headers["x-gloffset-tile"] == "computed", a.text
    b = client.get(path)
    assert b.headers["x-gloffset-tile"] == "cached" and b.content == a.content
    r = client.get("/tiles/UPSAntarcticWGS84Quad/pole/150km/2/1/2.png")
    assert r.status_code == 200 and r.headers["x-gloffset-tile"] == "field", r.text
    shape = client.app.state.server.layers["pole"]
    grid = TmsTile("UPSAntarcticWGS84Quad", 2, 1, 2)
    d = gloffset.parse_distance("150km")
    want = on_gl_thread(client, lambda: gloffset.render(shape, d, grid, radius=1.0)) > 0
    assert want.any() and not want.all()
    np.testing.assert_array_equal(alpha(r.content) > 0, want)


def test_tms_tilejson(client):
    """TileJSON per TMS layer: the tiles' template (a tile fetched through it), the TMS's
    zooms, size and id, bounds that hold the region in lon/lat (a polar TMS's reach the
    pole, not web mercator's 85 degrees)."""
    r = client.get("/tiles/WorldCRS84Quad/tri/tilejson.json?distance=300km&fill=%23ff0000")
    assert r.status_code == 200, r.text
    tj = r.json()
    assert tj["tilejson"] == "3.0.0" and tj["tileMatrixSet"] == "WorldCRS84Quad"
    assert tj["minzoom"] == 0 and tj["maxzoom"] == 22 and tj["tileSize"] == 256
    assert tj["tileMatrixSetURI"].endswith("/tileMatrixSets/WorldCRS84Quad")
    w, s, e, n = tj["bounds"]
    assert w < -110 - 2.6 and e > -90 + 2.6 and s < 15 - 2.6 and n > 30 + 2.6  # 300 km out
    assert e - w < 30 and n - s < 30
    url = tj["tiles"][0]
    assert "/tiles/WorldCRS84Quad/tri/300km/{z}/{x}/{y}.png" in url and "fill=%23ff0000" in url
    path = url.split("testserver", 1)[1].format(z=5, x=15, y=12)
    t = client.get(path)
    assert t.status_code == 200 and t.headers["content-type"] == "image/png"
    assert (np.asarray(Image.open(io.BytesIO(t.content)).convert("RGBA"))[..., 0] > 0).any()
    polar = client.get("/tiles/UPSAntarcticWGS84Quad/pole/tilejson.json?distance=200km").json()
    assert polar["bounds"][1] == -90.0 and polar["bounds"][3] < -60
    f = client.get("/field/EuropeanETRS89_LAEAQuad/tri/tilejson.json")
    assert f.status_code == 200, f.text
    fj = f.json()
    assert fj["encoding"]["baseShift"] == 8388608 and fj["maxzoom"] == 15
    assert fj["tiles"][0].endswith("/field/EuropeanETRS89_LAEAQuad/tri/{z}/{x}/{y}.png")
    w, s, e, n = fj["bounds"]  # the TMS's extent: Europe
    assert -60 < w < 0 < e < 80 and 20 < s < 40 < 70 < n <= 90
    for bad, status in [
        ("/tiles/Nope/tri/tilejson.json?distance=1km", 404),
        ("/tiles/WorldCRS84Quad/tri/tilejson.json", 400),
        ("/tiles/WorldCRS84Quad/nope/tilejson.json?distance=1km", 404),
    ]:
        assert client.get(bad).status_code == status, bad
