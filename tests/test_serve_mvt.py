"""The tile server's vector tiles: ``/mvt/{layer}/{z}/{x}/{y}.pbf?d=`` and its TileJSON."""

from __future__ import annotations

import pytest

import gloffset

pytest.importorskip("starlette")
pytest.importorskip("httpx")
mvt = pytest.importorskip("mapbox_vector_tile")
from starlette.testclient import TestClient  # noqa: E402

from gloffset.mvt import vector_tile  # noqa: E402
from gloffset.serve.app import create_app  # noqa: E402


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


@pytest.fixture(scope="module")
def client(mexico):
    with TestClient(create_app({"mexico": mexico}, render_timeout=60)) as c:
        yield c


@pytest.mark.parametrize("zxy", [(0, 0, 0), (4, 3, 6), (7, 28, 54), (10, 230, 456)])
def test_vector_tiles_equal_vector_tile(client, mexico, zxy):
    z, x, y = zxy
    r = client.get(f"/mvt/mexico/{z}/{x}/{y}.pbf?d=127km")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "application/vnd.mapbox-vector-tile"
    assert r.content == vector_tile(mexico, "127km", z, x, y, layer="mexico")
    feats = mvt.decode(r.content)["mexico"]["features"]
    assert feats[0]["properties"] == {"distance_m": 127000.0, "distance": "127km"}
    tag = r.headers["etag"]
    again = client.get(f"/mvt/mexico/{z}/{x}/{y}.pbf?d=127km", headers={"If-None-Match": tag})
    assert again.status_code == 304


def test_a_new_distance_and_an_outside_tile(client, mexico):
    r = client.get("/mvt/mexico/6/13/27.pbf?d=-33km")
    assert r.status_code == 200
    assert r.content == vector_tile(mexico, "-33km", 6, 13, 27, layer="mexico")
    empty = client.get("/mvt/mexico/6/40/20.pbf?d=33km")
    assert empty.status_code == 200
    assert mvt.decode(empty.content).get("mexico", {"features": []})["features"] == []


def test_tilejson_has_the_vector_layers(client):
    r = client.get("/mvt/mexico.json?d=127km")
    assert r.status_code == 200
    tj = r.json()
    assert tj["tiles"][0].endswith("/mvt/mexico/{z}/{x}/{y}.pbf?d=127km")
    (vl,) = tj["vector_layers"]
    assert vl["id"] == "mexico" and set(vl["fields"]) == {"distance_m", "distance"}
    w, s, e, n = tj["bounds"]
    assert w < -118 and e > -86 and s < 14 and n > 33


@pytest.mark.parametrize(
    "url,status,words",
    [
        ("/mvt/mexico/4/3/6.pbf", 400, ["distance"]),
        ("/mvt/mexico/4/3/6.pbf?d=2.0rad", 400, ["quarter"]),
        ("/mvt/mexico/4/3/6@2x.pbf?d=1km", 400, ["@2x"]),
        ("/mvt/mexico/4/16/6.pbf?d=1km", 400, ["does not exist"]),
        ("/mvt/nope/4/3/6.pbf?d=1km", 404, ["no layer"]),
        ("/mvt/mexico.json", 400, ["distance"]),
    ],
)
def test_errors_name_the_problem(client, url, status, words):
    r = client.get(url)
    assert r.status_code == status, r.text
    for w in words:
        assert w in r.json()["detail"]
