"""The HTTP side of ``gloffset serve``: a Starlette application over a
:class:`~gloffset.serve.service.TileService`.

Endpoints (each input is a layer named after its file stem):

- ``GET /tiles/{layer}/{distance}/{z}/{x}/{y}.png`` (``{y}@2x.png``: 512 px): the offset
  region at that distance (``127km``, ``500m``, ``0.02rad``, ``1.5deg``; a bare number is
  metres) as a web-mercator tile, the pixels of ``gloffset.render(shape, d, Tile(z, x,
  y))``, styled by the query (``fill``, ``opacity``, ``outline``, ``outline_width``) as
  ``gloffset tiles`` styles them;
- ``GET /tilejson/{layer}.json?distance=127km``: TileJSON 3.0.0 with absolute URLs;
- ``GET /offset/{layer}.geojson?distance=127km``: the resolved vector offset;
- ``GET /shape/{layer}.geojson``: the input;
- ``GET /distance/{layer}?lon=..&lat=..``: the distance to the layer in metres;
- ``GET /layers`` and ``GET /`` (a page listing the layers and their TileJSON).

HEAD works wherever GET does. Bad input is 400 with ``{"detail": ...}`` naming the
problem, an unknown layer 404, a full render queue 503 with ``Retry-After``. Tiles carry
a strong ETag (a hash of their bytes; ``If-None-Match`` gives 304) and the configured
``Cache-Control``.
"""

from __future__ import annotations

import asyncio
import math

from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, Response
from starlette.routing import Route

from ..errors import GloffsetError
from ..grids.mercator import MAX_ZOOM
from ..raster.tilepaint import TileStyle
from ..reference import contains as exact_contains
from ..reference import distance as exact_distance
from ..units import EARTH_RADIUS, RASTER_LIMIT, offset_angle, parse_distance
from ..vector.offset import offset
from .service import QueueFull, TileKey, TileService, etag

__all__ = ["create_app"]


def _bad(detail: str, status: int = 400):
    raise HTTPException(status_code=status, detail=detail)


class _Server:
    """The layers, the tile service and the response options."""

    def __init__(self, layers: dict, *, cache_control: str, queue_size: int, cache_mb: float):
        self.layers = layers
        self.cache_control = cache_control
        self.tiles = TileService(layers, queue_size=queue_size, cache_mb=cache_mb)

    def layer(self, name: str):
        if name not in self.layers:
            _bad(f"no layer {name!r}; the layers are {', '.join(sorted(self.layers))}", 404)
        return self.layers[name]

    def angle(self, shape, text: str | None) -> float:
        if text is None:
            _bad("give the distance, e.g. ?distance=127km")
        try:
            value = parse_distance(text, EARTH_RADIUS)  # an angle
            return offset_angle(shape, value, 1.0, limit=RASTER_LIMIT, what="a tile")
        except GloffsetError as exc:
            _bad(str(exc))

    # ------------------------------------------------------------------ endpoints
    async def tile(self, request: Request) -> Response:
        p = request.path_params
        shape = self.layer(p["layer"])
        d = self.angle(shape, p["distance"])
        z, x, y, size = _zxy(p["z"], p["x"], p["y"])
        style = _style(request.query_params)
        fut = None
        try:
            fut = self.tiles.submit(TileKey(p["layer"], d, z, x, y, size, style))
        except QueueFull:
            return JSONResponse(
                {"detail": "the render queue is full; try again"},
                status_code=503,
                headers={"Retry-After": "1"},
            )
        data = await asyncio.wrap_future(fut)
        tag = etag(data)
        headers = {"ETag": tag, "Cache-Control": self.cache_control}
        if tag in [t.strip() for t in request.headers.get("if-none-match", "").split(",")]:
            return Response(status_code=304, headers=headers)
        return Response(data, media_type="image/png", headers=headers)

    async def tilejson(self, request: Request) -> Response:
        name = request.path_params["layer"]
        shape = self.layer(name)
        text = request.query_params.get("distance")
        self.angle(shape, text)
        base = str(request.base_url).rstrip("/")
        w, s, e, n = _bounds(shape)
        query = str(request.query_params).replace(f"distance={text}", "").strip("&")
        tiles = f"{base}/tiles/{name}/{text}/{{z}}/{{x}}/{{y}}.png" + (f"?{query}" if query else "")
        return JSONResponse(
            {
                "tilejson": "3.0.0",
                "name": f"{name} within {text}",
                "tiles": [tiles],
                "minzoom": 0,
                "maxzoom": MAX_ZOOM,
                "bounds": [w, s, e, n],
                "center": [(w + e) / 2, (s + n) / 2, 2],
            }
        )

    async def offset_geojson(self, request: Request) -> Response:
        shape = self.layer(request.path_params["layer"])
        d = self.angle(shape, request.query_params.get("distance"))
        try:
            feat = await asyncio.to_thread(lambda: offset(shape, d, radius=1.0).to_geojson())
        except GloffsetError as exc:
            _bad(str(exc))
        return JSONResponse({"type": "FeatureCollection", "features": [feat]})

    async def shape_geojson(self, request: Request) -> Response:
        shape = self.layer(request.path_params["layer"])
        return JSONResponse(shape.to_geojson())

    async def distance(self, request: Request) -> Response:
        name = request.path_params["layer"]
        shape = self.layer(name)
        try:
            lon = float(request.query_params["lon"])
            lat = float(request.query_params["lat"])
        except (KeyError, ValueError):
            _bad("give lon and lat in degrees, e.g. ?lon=-100&lat=20")
        if not (math.isfinite(lon) and math.isfinite(lat) and -180 <= lon <= 180):
            _bad(f"lon must be in -180..180, got {lon}")
        if not -90 <= lat <= 90:
            _bad(f"lat must be in -90..90, got {lat}")
        metres = float(exact_distance(shape, [lon], [lat])[0])
        inside = bool(exact_contains(shape, [lon], [lat], distance=0.0)[0])
        body = {"layer": name, "lon": lon, "lat": lat, "distance_m": metres, "inside": inside}
        return JSONResponse(body)

    async def layer_list(self, request: Request) -> Response:
        return JSONResponse([_describe(n, s) for n, s in sorted(self.layers.items())])

    async def index(self, request: Request) -> Response:
        rows = "".join(
            f'<li>{n}: <a href="/tilejson/{n}.json?distance=127km">TileJSON at 127 km</a>, '
            f'<a href="/shape/{n}.geojson">input</a></li>'
            for n in sorted(self.layers)
        )
        return HTMLResponse(f"<!doctype html><title>gloffset serve</title><ul>{rows}</ul>")


def _zxy(z: str, x: str, y: str) -> tuple[int, int, int, int]:
    size = 256
    if y.endswith("@2x"):
        y, size = y[:-3], 512
    try:
        zi, xi, yi = int(z), int(x), int(y)
    except ValueError:
        _bad(f"z/x/y must be integers, got {z}/{x}/{y}")
    if not 0 <= zi <= MAX_ZOOM:
        _bad(f"zoom must be 0..{MAX_ZOOM}, got {zi}")
    n = 1 << zi
    if not (0 <= xi < n and 0 <= yi < n):
        _bad(f"tile {zi}/{xi}/{yi} does not exist: x and y must be in 0..{n - 1}")
    return zi, xi, yi, size


def _style(q) -> TileStyle:
    try:
        return TileStyle(
            q.get("fill", "#3070c0"),
            float(q.get("opacity", 1.0)),
            q.get("outline"),
            int(q.get("outline_width", 1)),
        )
    except (GloffsetError, ValueError) as exc:
        _bad(f"bad style: {exc}")


def _bounds(shape) -> tuple[float, float, float, float]:
    feats = shape.to_geojson()
    pts = []

    def walk(c):
        if c and isinstance(c[0], (int, float)):
            pts.append(c[:2])
        else:
            for v in c:
                walk(v)

    for f in feats.get("features", [feats]):
        g = f.get("geometry", f)
        walk(g.get("coordinates", []))
    lon, lat = zip(*pts)
    return (min(lon), max(min(lat), -85.0511), max(lon), min(max(lat), 85.0511))


def _describe(name: str, shape) -> dict:
    w, s, e, n = _bounds(shape)
    bounds = [w, s, e, n]
    return {"name": name, "bounds": bounds, "center": [(w + e) / 2, (s + n) / 2]} | {
        "vertices": int(shape.n_vertices)
    }


async def _error(request: Request, exc: HTTPException) -> Response:
    return JSONResponse({"detail": exc.detail}, status_code=exc.status_code)


def create_app(
    layers: dict,
    *,
    cache_control: str = "public, max-age=3600",
    queue_size: int = 256,
    cache_mb: float = 256.0,
) -> Starlette:
    """The application serving ``layers`` (name -> :class:`~gloffset.Shape`)."""
    srv = _Server(layers, cache_control=cache_control, queue_size=queue_size, cache_mb=cache_mb)
    get = ["GET", "HEAD"]
    routes = [
        Route("/", srv.index, methods=get),
        Route("/layers", srv.layer_list, methods=get),
        Route("/tiles/{layer}/{distance}/{z}/{x}/{y}.png", srv.tile, methods=get),
        Route("/tilejson/{layer}.json", srv.tilejson, methods=get),
        Route("/offset/{layer}.geojson", srv.offset_geojson, methods=get),
        Route("/shape/{layer}.geojson", srv.shape_geojson, methods=get),
        Route("/distance/{layer}", srv.distance, methods=get),
    ]
    app = Starlette(routes=routes, exception_handlers={HTTPException: _error})
    app.state.server = srv
    return app
