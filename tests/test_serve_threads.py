"""``gloffset serve`` under threads: a cold server with several layers (Mexico's 1:10m
border, Fiji across the antimeridian, a line across it), 64 concurrent clients mixing
tiles, field tiles, ``/distance``, ``/offset``, ``/tilejson`` and ``/shape`` at random
distances, and every answer equal to the library's on other, separately read shapes.

The server's shapes are cold (nothing derived yet, the grid caches emptied), so the
render thread, the field thread and the pool behind ``asyncio.to_thread`` (widened to 32
threads) build the shapes' lazy slots at the same time. The seed is random per run and
named in every failure (``GLOFFSET_STRESS_SEED`` replays one)."""

from __future__ import annotations

import asyncio
import io
import json
import os
import random
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import mercantile
import numpy as np
import pytest
from PIL import Image

import gloffset
from gloffset.edges import points_inside
from gloffset.geometry.sphere import lonlat_to_xyz
from gloffset.grids import Tile
from gloffset.io.geojson import offset_feature
from gloffset.tiles.tiling.fieldtiles import encode_field, field_tile
from gloffset.units import EARTH_RADIUS, offset_angle
from gloffset.vector.arcrings import DEFAULT_TOLERANCE
from gloffset.vector.offset import offset

pytest.importorskip("starlette")
pytest.importorskip("httpx")
from starlette.testclient import TestClient  # noqa: E402

from gloffset.serve.app import create_app  # noqa: E402
from gloffset.serve.bounds import region_bounds  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CLIENTS = 64
#: requests per client
EACH = 5
LINE_AM = {"type": "LineString", "coordinates": [[170, -10], [-170, 5], [-160, 20]]}


def _inputs() -> dict:
    """The layers' inputs (GeoJSON objects), read into shapes twice: once for the server,
    once for the expected answers."""
    world = json.loads((ROOT / "data" / "world_110m.geojson").read_text())
    fiji = next(f for f in world["features"] if f["properties"].get("name") == "Fiji")
    mexico = json.loads((ROOT / "data" / "mexico_10m.geojson").read_text())
    return {"mexico": mexico, "fiji": fiji, "am": LINE_AM}


def _requests(shapes: dict, rng: random.Random) -> list[tuple[str, str, tuple]]:
    """The pool of requests: (kind, url, what the expected answer needs)."""
    out = []
    for name, shape in shapes.items():
        polygons = bool(shape.rings)
        lon, lat = _vertices(shape)
        metres = [rng.uniform(1e3, 400e3) for _ in range(2)]
        if polygons:
            metres[1] = -rng.uniform(1e3, 60e3)  # inward too
        tiles = set()
        for _ in range(3):
            k = rng.randrange(len(lon))
            t = mercantile.tile(lon[k], lat[k], rng.randint(3, 8))
            tiles.update([(t.z, t.x, t.y), (t.z, (t.x + 1) % (1 << t.z), t.y)])
        tiles.add((rng.randint(1, 2), 0, 0))  # far away: decided at once
        for m in metres:
            text = f"{m:.0f}m"
            for z, x, y in sorted(tiles):
                out.append(("tile", f"/tiles/{name}/{text}/{z}/{x}/{y}.png", (name, text, z, x, y)))
            out.append(("tilejson", f"/tilejson/{name}.json?distance={text}", (name, text)))
        for z, x, y in sorted(tiles)[:2]:
            out.append(("field", f"/field/{name}/{z}/{x}/{y}.png", (name, z, x, y)))
        for _ in range(4):
            k = rng.randrange(len(lon))
            p = (round(lon[k] + rng.uniform(-3, 3), 6), round(lat[k] + rng.uniform(-3, 3), 6))
            p = (max(-180.0, min(180.0, p[0])), max(-90.0, min(90.0, p[1])))
            out.append(("distance", f"/distance/{name}?lon={p[0]}&lat={p[1]}", (name, *p)))
        text = f"{rng.uniform(5e3, 300e3):.0f}m"
        out.append(("offset", f"/offset/{name}.geojson?distance={text}", (name, text)))
        out.append(("shape", f"/shape/{name}.geojson", (name,)))
    return out


def _vertices(shape) -> tuple[np.ndarray, np.ndarray]:
    """Lon/lat (degrees) of the shape's edge starts."""
    a = shape.edges().a
    return np.degrees(np.arctan2(a[:, 1], a[:, 0])), np.degrees(np.arcsin(np.clip(a[:, 2], -1, 1)))


def _expected(shapes: dict, kind: str, args: tuple):
    """The library's answer to a request, on its own shapes."""
    shape = shapes[args[0]]
    if kind == "tile":
        _, text, z, x, y = args
        d = offset_angle(shape, text, EARTH_RADIUS)
        return gloffset.render(shape, d, Tile(z, x, y), radius=1.0) > 0
    if kind == "field":
        _, z, x, y = args
        return encode_field(field_tile(shape, z, x, y).values, EARTH_RADIUS)
    if kind == "distance":
        _, lon, lat = args
        metres = float(gloffset.distance(shape, [lon], [lat])[0])
        inside = bool(points_inside(shape, lonlat_to_xyz(lon, lat).reshape(1, 3))[0])
        return metres, inside
    if kind == "offset":
        feat = offset_feature(
            offset(shape, args[1], radius=EARTH_RADIUS), tolerance=DEFAULT_TOLERANCE
        )
        return json.loads(json.dumps({"type": "FeatureCollection", "features": [feat]}))
    if kind == "tilejson":
        return list(region_bounds(shape, offset_angle(shape, args[1], EARTH_RADIUS)))
    return json.loads(json.dumps(shape.to_geojson()))


def _check(kind: str, r, want, what: str) -> None:
    assert r.status_code == 200, f"{what}: {r.status_code} {r.text[:200]}"
    if kind == "tile":
        mask = np.asarray(Image.open(io.BytesIO(r.content)).convert("RGBA"))[..., 3] > 0
        assert np.array_equal(mask, want), f"{what}: {np.count_nonzero(mask != want)} pixels"
    elif kind == "field":
        assert r.content == want, what
    elif kind == "distance":
        got = r.json()
        assert (got["distance_m"], got["inside"]) == want, f"{what}: {got}"
    elif kind == "tilejson":
        assert r.json()["bounds"] == want, what
    else:
        assert r.json() == want, what


@pytest.mark.slow
def test_a_cold_server_under_64_concurrent_clients_answers_as_the_library():
    from gloffset.tiles.tiling import ondemand, walk

    seed = int(os.environ.get("GLOFFSET_STRESS_SEED") or random.SystemRandom().randrange(1 << 30))
    rng = random.Random(seed)
    inputs = _inputs()
    mine = {name: gloffset.read(obj) for name, obj in inputs.items()}
    pool = _requests(mine, rng)
    # the library's answers, on a thread of their own (its GL context stays there)
    with ThreadPoolExecutor(1) as one:
        wants = list(one.map(lambda req: _expected(mine, req[0], req[2]), pool))
    # a cold server: its own shapes, nothing derived, the grids' caches emptied
    walk.tile_grid.cache_clear()
    ondemand._pyramid.cache_clear()
    layers = {name: gloffset.read(obj) for name, obj in inputs.items()}
    app = create_app(layers, queue_size=1024, render_timeout=600)
    # every request of the pool at least once, the rest at random (repeats: the same
    # tile or slot asked for by several clients at once)
    order = list(range(len(pool))) + [rng.randrange(len(pool)) for _ in range(CLIENTS * EACH)]
    order = order[: max(len(pool), CLIENTS * EACH)]
    rng.shuffle(order)
    plan = [order[c::CLIENTS] for c in range(CLIENTS)]
    failures: list = []
    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)  # threads interleave every 10 us, not 5 ms: races show
    try:
        _serve(app, pool, wants, plan, seed, failures)
    finally:
        sys.setswitchinterval(switch)
    assert not failures, f"{len(failures)} wrong answers, e.g. {failures[:3]}"
    assert {kind for kind, _, _ in pool} == {
        "tile",
        "field",
        "distance",
        "offset",
        "tilejson",
        "shape",
    }


def _serve(app, pool, wants, plan, seed, failures) -> None:
    """The clients' requests, each client on its own thread, all released together."""
    with TestClient(app) as client:

        async def widen():  # asyncio.to_thread's pool: 32 threads, not min(32, cpus + 4)
            asyncio.get_running_loop().set_default_executor(ThreadPoolExecutor(32))

        client.portal.call(widen)
        gate = threading.Barrier(CLIENTS)

        def run(picks):
            gate.wait(timeout=60)
            for i in picks:
                kind, url, _ = pool[i]
                try:
                    _check(kind, client.get(url), wants[i], f"seed {seed}: {url}")
                except AssertionError as exc:
                    failures.append(str(exc))

        with ThreadPoolExecutor(CLIENTS) as clients:
            list(clients.map(run, plan))
