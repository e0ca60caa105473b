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
