"""The HTTP side of ``gloffset serve``: a Starlette application over a
:class:`~gloffset.serve.service.TileService`.

Endpoints (each input is a layer named after its file stem):

- ``GET /tiles/{layer}/{distance}/{z}/{x}/{y}.png`` (``{y}@2x.png``: 512 px): the offset
  region at that distance (``127km``, ``0.02rad``; a bare number is metres), the pixels
  of ``gloffset.render(shape, d, Tile(z, x, y))``, styled by the query (``fill``,
  ``opacity``, ``outline``, ``outline_width``) as ``gloffset tiles`` styles them;
- ``GET /tilejson/{layer}.json?distance=127km``: TileJSON 3.0.0, its ``bounds`` a box
  that holds the region at that distance (:func:`~gloffset.serve.bounds.region_bounds`);
- ``GET /field/{layer}/{z}/{x}/{y}.png`` (``@2x``): the tile's signed distance field in
  metres, a lossless RGB PNG in the ``raster-dem`` ``custom`` encoding of
  :data:`~gloffset.tiles.tiling.fieldtiles.FIELD_ENCODING` (1 m steps, +-8,388 km);
  ``GET /field/{layer}.json``: TileJSON 3.0.0 for them, with that ``encoding``;
- ``GET /mvt/{layer}/{z}/{x}/{y}.pbf?d=127km`` (:func:`gloffset.vector_tile`), its TileJSON;
  ``/offset/{layer}.geojson?distance=``, ``/shape/{layer}.geojson``, ``/layers``,
  ``/distance/{layer}?lon=..&lat=..`` (metres); ``/tiles/{tms}/...``, ``/field/{tms}/...``:
  another TileMatrixSet's tiles, their TileJSON (:mod:`gloffset.serve.tmsdocs`);
- ``GET /``: the page (``static/``, MapLibre GL JS vendored): a map, a globe, a slider.

HEAD works wherever GET does. Bad input is 400 with ``{"detail": ...}`` naming the
problem (tile numbers are ASCII digits only), an unknown layer 404, a full render queue
(or a tile not rendered within ``render_timeout``) 503 with ``Retry-After``. Tiles carry
a strong ETag (``If-None-Match`` with it, weak or strong, in a list, or ``*`` gives 304),
the configured ``Cache-Control``, and ``X-Gloffset-Tile``: how the tile was found
(``cached``, ``inside``, ``outside``, ``field``: the threshold of the tile's kept field,
or ``rendered``; field tiles say ``cached`` or ``computed``). With ``access_log``, a line
per request (:mod:`gloffset.serve.accesslog`). CORS headers (``cors``, :func:`cors_origins`)
let maps of other origins use the tiles: MapLibre fetches them, WebGL needs CORS for images."""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import os
import re
import threading
from pathlib import Path
from typing import NoReturn
from urllib.parse import urlencode

from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.middleware import Middleware
from starlette.middleware.cors import CORSMiddleware
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from ..edges import points_inside
from ..ellipsoidal import distance as distance_to
from ..errors import GloffsetError, OptionError
from ..geometry.sphere import lonlat_to_xyz
from ..grids.mercator import MAX_ZOOM
from ..grids.tms import WEB_MERCATOR, TmsQuad, tms_quad
from ..io.geojson import offset_feature
from ..mvt.boundary import ResolvedBoundary
from ..mvt.pyramid import vector_layers
from ..mvt.tile import encode as encode_mvt
from ..mvt.tile import tile_geometry
from ..shape import read
from ..tiles.tiling.fieldtiles import FIELD_ENCODING
from ..tiles.tiling.tilepaint import TileStyle
from ..units import (
    EARTH_RADIUS,
    RASTER_LIMIT,
    VECTOR_LIMIT,
    distance_properties,
    offset_angle,
)
from ..vector.arcrings import DEFAULT_TOLERANCE
from ..vector.offset import offset
from .accesslog import AccessLog, open_log
from .bounds import region_bounds
from .renderqueue import server_timing
from .service import (
    UNKNOWN,
    FieldKey,
    QueueFull,
    TileKey,
    TileService,
    etag,
)
from .tmsdocs import tms_list, tms_tilejson

__all__ = ["create_app", "app_from_environment", "cors_origins", "ENVIRONMENT", "STATIC"]

#: the environment variable through which ``gloffset serve --workers N`` hands its options
#: to the worker processes (JSON: ``inputs`` and the keywords of :func:`create_app`)
ENVIRONMENT = "GLOFFSET_SERVE"

#: the page and the vendored MapLibre GL JS (package data)
STATIC = Path(__file__).resolve().parent / "static"


#: an origin as a browser sends it: scheme://host[:port], nothing after
_ORIGIN = re.compile(r"[a-z][a-z0-9+.-]*://(\[[0-9a-f:.]+\]|[^/?#:@\[\]\s]+)(:[0-9]{1,5})?")

#: the response headers a cross-origin script may read beside the safelisted ones
_EXPOSED = ("ETag", "Retry-After", "X-Gloffset-Tile", "Server-Timing")


def cors_origins(text: str) -> tuple[str, ...] | None:
    """The origins of ``--cors``: ``"*"`` (any), ``"none"`` (None: no CORS headers) or a
    comma-separated list of origins, each ``scheme://host[:port]`` as a browser sends it
    (lower case, no path, no trailing slash, no default port: an origin written otherwise
    would never match, and is refused, naming it)."""
    items = [t.strip() for t in text.split(",")]
    if items == ["none"]:
        return None
    if items == ["*"]:
        return ("*",)
    for t in items:
        if t in ("*", "none"):
            raise OptionError(f"--cors: {t!r} stands alone, not in a list: {text!r}")
        default_port = t.startswith("http://") and t.endswith(":80")
        default_port |= t.startswith("https://") and t.endswith(":443")
        if not _ORIGIN.fullmatch(t) or t != t.lower() or default_port:
            raise OptionError(
                f"--cors: {t!r} is not an origin as a browser sends it: give scheme://host[:port] "
                "in lower case, nothing after, no default port (e.g. https://example.com or "
                "http://localhost:3000), '*' for any origin or 'none'"
            )
    return tuple(items)


def _bad(detail: str, status: int = 400) -> NoReturn:
    raise HTTPException(status_code=status, detail=detail)


class _Server:
    """The layers, the tile service and the response options."""

    def __init__(
        self,
        layers: dict,
        *,
        cache_control: str,
        queue_size: int,
        cache_mb: float,
        field_mb: float,
        render_timeout: float,
    ):
        self.layers = layers
        self.cache_control = cache_control
        self.render_timeout = render_timeout
        self.tiles = TileService(
            layers, queue_size=queue_size, cache_mb=cache_mb, field_mb=field_mb
        )
        # the tiles whose centres are about to be measured, and the task
        self._batch: tuple[list, asyncio.Future] | None = None
        self._mvt_lock = threading.Lock()

    def layer(self, name: str):
        if name not in self.layers:
            _bad(f"no layer {name!r}; the layers are {', '.join(sorted(self.layers))}", 404)
        return self.layers[name]

    def angle(self, shape, text: str | None, *, vector: bool = False) -> float:
        """The distance ``text`` as an angle, checked against the limit of tiles
        (``|d| < 1.5 rad``), or of vector offsets (``vector``: ``|d| < pi/2``)."""
        if text is None:
            _bad("give the distance, e.g. ?distance=127km")
        if vector:
            limit, what = VECTOR_LIMIT, "an offset"
        else:
            limit, what = RASTER_LIMIT, "a tile"
        try:
            return offset_angle(shape, text, EARTH_RADIUS, limit=limit, what=what)
        except GloffsetError as exc:
            _bad(str(exc))

    # ------------------------------------------------------------------ endpoints
    async def tile(self, request: Request) -> Response:
        p = request.path_params
        shape = self.layer(p["layer"])
        d = self.angle(shape, p["distance"])
        z, x, y, size = _zxy(p["z"], p["x"], p["y"])
        key = TileKey(p["layer"], d, z, x, y, size, _style(request.query_params))
        return await self._tile_answer(request, key)

    async def _tile_answer(self, request: Request, key: TileKey) -> Response:
        """The tile ``key`` (web mercator's or another TileMatrixSet's): cached, decided
        from its centre, the threshold of its kept field, or rendered."""
        seen = self.tiles.asked(key)  # a view asked for before: its renders go first
        found = self.tiles.answer(key, measure=False)  # the cache, a known centre
        if found is UNKNOWN:
            await self._measured(key)
            found = self.tiles.answer(key, measure=False)
        if found is UNKNOWN:  # measured but since forgotten: measure it alone
            found = await asyncio.to_thread(self.tiles.answer, key)
        if found is not None and found[1] in ("inside", "outside"):
            self.tiles.ahead_of(key, seen)  # a slider's next distance may need its field
        if found is None and await self._field_kept(key):
            thresholded = await asyncio.to_thread(self.tiles.from_field, key)
            found = None if thresholded is None else (thresholded, "field")
        timing = ""
        if found is None and key.style.outline is None and self.tiles.at_once(key.layer):
            fut = self._submit(lambda: self.tiles.submit_from_field(key, urgent=seen))
            made = await self._wait(fut, "tile")
            if isinstance(made, Response):
                return made
            found, timing = (made, "field"), server_timing(fut)
        if found is not None:
            data, how = found
        else:
            why = self.tiles.why_rendered(key, seen)
            fut = self._submit(lambda: self.tiles.submit(key, urgent=seen))
            rendered = await self._wait(fut, "tile")
            if isinstance(rendered, Response):
                return rendered
            data, how = rendered, "rendered"
            timing = server_timing(fut, why)
        return self._png(request, data, how, timing)

    def _png(self, request: Request, data: bytes, how: str, timing: str = "") -> Response:
        tag = etag(data)
        headers = {"ETag": tag, "Cache-Control": self.cache_control, "X-Gloffset-Tile": how}
        if timing:
            headers["Server-Timing"] = timing
        if not_modified(request.headers.get("if-none-match"), tag):
            return Response(status_code=304, headers=headers)
        return Response(data, media_type="image/png", headers=headers)

    async def field_tile(self, request: Request) -> Response:
        p = request.path_params
        self.layer(p["layer"])
        z, x, y, size = _zxy(p["z"], p["x"], p["y"])
        return await self._field_answer(request, FieldKey(p["layer"], z, x, y, size))

    async def _field_answer(self, request: Request, fkey: FieldKey) -> Response:
        """The field tile ``fkey``: cached, or computed on the render thread and kept."""
        kept = self.tiles.cached(fkey)
        if kept is not None:
            return self._png(request, kept, "cached")
        fut = self._submit(lambda: self.tiles.submit_field(fkey))
        made = await self._wait(fut, "field")
        if isinstance(made, Response):
            return made
        return self._png(request, made, "computed", server_timing(fut))

    async def field_tilejson(self, request: Request) -> Response:
        name = request.path_params["layer"]
        self.layer(name)
        base = str(request.base_url).rstrip("/")
        w, s, e, n = await asyncio.to_thread(region_bounds, self.layers[name], 0.0)
        return JSONResponse(
            {
                "tilejson": "3.0.0",
                "name": f"{name} signed distance (m)",
                "description": "signed distance to the curves in metres, negative inside the "
                "polygons: metres = R * redFactor + G * greenFactor + B * blueFactor - baseShift",
                "tiles": [f"{base}/field/{name}/{{z}}/{{x}}/{{y}}.png"],
                "minzoom": 0,
                "maxzoom": MAX_ZOOM,
                "tileSize": 256,
                "encoding": dict(FIELD_ENCODING),
                # every tile has a field: the whole map
                "bounds": [-180.0, -85.0511287798066, 180.0, 85.0511287798066],
                "center": [(w + e) / 2, (s + n) / 2, 2],
            }
        )

    async def _measured(self, key: TileKey) -> None:
        """Wait until the centre of the tile is measured: the requests that arrive together
        (the tiles of a view) are measured together, off the event loop
        (:meth:`~gloffset.serve.service.TileService.measure`)."""
        if self._batch is None:
            keys: list = []
            self._batch = (keys, asyncio.ensure_future(self._measure_batch(keys)))
        keys, task = self._batch
        keys.append(key)
        await asyncio.shield(task)

    async def _measure_batch(self, keys: list) -> None:
        await asyncio.sleep(0)  # the requests read with the first one join it
        self._batch = None
        await asyncio.to_thread(self.tiles.measure, keys)

    async def _field_kept(self, key: TileKey) -> bool:
        """Whether the tile's field is kept, once the field on its way is made (a tile of a
        view seen before at another distance: the slider), within ``render_timeout``."""
        if self.tiles.field(key.field()) is not None:
            return True
        fut = self.tiles.field_future(key)
        if fut is None:
            return False
        with contextlib.suppress(asyncio.TimeoutError):
            await asyncio.wait_for(asyncio.wrap_future(fut), self.render_timeout)
        return self.tiles.field(key.field()) is not None

    @staticmethod
    def _submit(submit):
        """``submit()``'s future (work queued for the render thread), or the 503 that says
        the queue is full."""
        try:
            return submit()
        except QueueFull:
            detail = "the render queue is full; try again"
            return JSONResponse({"detail": detail}, status_code=503, headers={"Retry-After": "1"})

    async def _wait(self, fut, what: str) -> bytes | Response:
        """The bytes of ``fut`` (work on the render thread, or the 503 of :meth:`_submit`),
        or the 503 that says why not."""
        if isinstance(fut, Response):
            return fut
        try:
            return await asyncio.wait_for(asyncio.wrap_future(fut), self.render_timeout)
        except asyncio.TimeoutError:
            detail = f"the {what} was not rendered within {self.render_timeout:g} s; try again"
            return JSONResponse({"detail": detail}, status_code=503, headers={"Retry-After": "1"})
        except GloffsetError as exc:
            _bad(str(exc))

    async def tilejson(self, request: Request) -> Response:
        name = request.path_params["layer"]
        shape = self.layer(name)
        text = request.query_params.get("distance")
        d = self.angle(shape, text)
        _style(request.query_params)
        base = str(request.base_url).rstrip("/")
        w, s, e, n = await asyncio.to_thread(region_bounds, shape, d)  # kept once made
        rest = [(k, v) for k, v in request.query_params.multi_items() if k != "distance"]
        query = urlencode(rest)
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

    def _vector_distance(self, request: Request, shape) -> tuple[str, float]:
        """The ``d`` (or ``distance``) of a vector tile request, as given and as an angle."""
        q = request.query_params
        text = q.get("d", q.get("distance"))
        if text is None:
            _bad("give the distance, e.g. ?d=127km")
        return text, self.angle(shape, text, vector=True)

    async def mvt_tile(self, request: Request) -> Response:
        p = request.path_params
        name = p["layer"]
        shape = self.layer(name)
        text, d = self._vector_distance(request, shape)
        z, x, y, size = _zxy(p["z"], p["x"], p["y"])
        if size != 256:
            _bad("vector tiles have no @2x: their extent serves every pixel ratio")
        try:
            data = await asyncio.to_thread(self._mvt_bytes, shape, name, text, d, z, x, y)
        except GloffsetError as exc:
            _bad(str(exc))
        tag = etag(data)
        headers = {"ETag": tag, "Cache-Control": self.cache_control, "X-Gloffset-Tile": "vector"}
        if not_modified(request.headers.get("if-none-match"), tag):
            return Response(status_code=304, headers=headers)
        return Response(data, media_type="application/vnd.mapbox-vector-tile", headers=headers)

    def _mvt_bytes(self, shape, name: str, text: str, d: float, z: int, x: int, y: int):
        """One vector tile (:mod:`gloffset.mvt`), the distance's boundary resolved once
        (one thread resolves a new distance while the others wait for it)."""
        with self._mvt_lock:
            boundary = ResolvedBoundary.of(shape, d)
        geom = tile_geometry(boundary, z, x, y)
        return encode_mvt(geom, name, distance_properties(text, EARTH_RADIUS), 4096)

    async def mvt_tilejson(self, request: Request) -> Response:
        name = request.path_params["layer"]
        shape = self.layer(name)
        text, d = self._vector_distance(request, shape)
        base = str(request.base_url).rstrip("/")
        w, s, e, n = await asyncio.to_thread(region_bounds, shape, d)
        query = urlencode({"d": text})
        return JSONResponse(
            {
                "tilejson": "3.0.0",
                "name": f"{name} within {text}",
                "tiles": [f"{base}/mvt/{name}/{{z}}/{{x}}/{{y}}.pbf?{query}"],
                "minzoom": 0,
                "maxzoom": MAX_ZOOM,
                "bounds": [w, s, e, n],
                "center": [(w + e) / 2, (s + n) / 2, 2],
                "vector_layers": vector_layers(name, (0, MAX_ZOOM)),
            }
        )

    async def offset_geojson(self, request: Request) -> Response:
        shape = self.layer(request.path_params["layer"])
        text = request.query_params.get("distance")
        self.angle(shape, text, vector=True)
        assert text is not None  # angle() answers 400 without it
        try:
            off = await asyncio.to_thread(offset, shape, text, radius=EARTH_RADIUS)
            feat = await asyncio.to_thread(offset_feature, off, tolerance=DEFAULT_TOLERANCE)
        except GloffsetError as exc:
            _bad(str(exc))
        return JSONResponse({"type": "FeatureCollection", "features": [feat]})

    async def shape_geojson(self, request: Request) -> Response:
        shape = self.layer(request.path_params["layer"])
        body = await asyncio.to_thread(_geojson_bytes, shape)
        return Response(body, media_type="application/geo+json")

    async def distance(self, request: Request) -> Response:
        name = request.path_params["layer"]
        shape = self.layer(name)
        try:
            lon = float(request.query_params["lon"])
            lat = float(request.query_params["lat"])
        except (KeyError, ValueError):
            _bad("give lon and lat in degrees, e.g. ?lon=-100&lat=20")
        if not (math.isfinite(lon) and -180 <= lon <= 180):
            _bad(f"lon must be in -180..180, got {lon}")
        if not (math.isfinite(lat) and -90 <= lat <= 90):
            _bad(f"lat must be in -90..90, got {lat}")
        metres, inside = await asyncio.to_thread(_distance_inside, shape, lon, lat)
        body = {"layer": name, "lon": lon, "lat": lat, "distance_m": metres, "inside": inside}
        return JSONResponse(body)

    # ------------------------------------------------------ other TileMatrixSets
    def tms(self, name: str) -> TmsQuad:
        """The quadtree of the TileMatrixSet ``name`` (404 when gloffset has none)."""
        try:
            return tms_quad(name)
        except GloffsetError as exc:
            _bad(str(exc), 404)

    def tms_tile_at(self, quad: TmsQuad, z: str, x: str, y: str) -> tuple[int, int, int]:
        if not all(_NUMBER.fullmatch(v) for v in (z, x, y)):
            _bad(f"z/x/y must be integers of at most 8 ASCII digits, got {z!r}/{x!r}/{y!r}")
        zi, xi, yi = int(z), int(x), int(y)
        try:
            quad.check_tile(zi, xi, yi)
        except GloffsetError as exc:
            _bad(str(exc))
        return zi, xi, yi

    async def tms_tile(self, request: Request) -> Response:
        """A tile of a TileMatrixSet: web mercator's as :meth:`tile`, another's by the
        same route (the cache, its centre, its kept field), rendered on its own grid
        (:func:`gloffset.grids.TmsTile`) on the render thread; keys carry the TMS's id."""
        p = request.path_params
        if p["tms"] == WEB_MERCATOR:
            return await self.tile(request)
        quad = self.tms(p["tms"])
        shape = self.layer(p["layer"])
        d = self.angle(shape, p["distance"])
        z, x, y = self.tms_tile_at(quad, p["z"], p["x"], p["y"])
        style = _style(request.query_params)
        if style.outline is not None:
            _bad(f"tiles of {quad.id} take no outline")
        key = TileKey(p["layer"], d, z, x, y, quad.size, style, quad.id)
        return await self._tile_answer(request, key)

    async def tms_field_tile(self, request: Request) -> Response:
        """A distance-field tile of a TileMatrixSet (web mercator's as :meth:`field_tile`),
        cached as web mercator's are."""
        p = request.path_params
        if p["tms"] == WEB_MERCATOR:
            return await self.field_tile(request)
        quad = self.tms(p["tms"])
        self.layer(p["layer"])
        z, x, y = self.tms_tile_at(quad, p["z"], p["x"], p["y"])
        return await self._field_answer(request, FieldKey(p["layer"], z, x, y, quad.size, quad.id))

    async def tms_tilejson(self, request: Request) -> Response:
        """TileJSON 3.0.0 of a layer's tiles in a TileMatrixSet at ``?distance=`` (as
        TiTiler's ``/{tms}/tilejson.json``): the ``tiles`` template of
        ``/tiles/{tms}/...``, the TMS's zooms and tile size, ``bounds`` (lon/lat) a box
        that holds the region at that distance within the TMS's extent, and the TMS's id
        and the link to its definition (``tileMatrixSet``, ``tileMatrixSetURI``)."""
        p = request.path_params
        quad = self.tms(p["tms"])
        name = p["layer"]
        shape = self.layer(name)
        text = request.query_params.get("distance")
        d = self.angle(shape, text)
        _style(request.query_params)
        base = str(request.base_url).rstrip("/")
        rest = [(k, v) for k, v in request.query_params.multi_items() if k != "distance"]
        query = urlencode(rest)
        tiles = f"{base}/tiles/{quad.id}/{name}/{text}/{{z}}/{{x}}/{{y}}.png"
        doc = await asyncio.to_thread(tms_tilejson, quad, shape, d, base)
        doc |= {"name": f"{name} within {text}", "tiles": [tiles + (f"?{query}" if query else "")]}
        return JSONResponse(doc)

    async def tms_field_tilejson(self, request: Request) -> Response:
        """TileJSON 3.0.0 of a layer's field tiles in a TileMatrixSet (as
        :meth:`tms_tilejson`; every tile has a field: ``bounds`` the TMS's extent), with
        the field's ``encoding``."""
        p = request.path_params
        quad = self.tms(p["tms"])
        name = p["layer"]
        shape = self.layer(name)
        base = str(request.base_url).rstrip("/")
        doc = await asyncio.to_thread(tms_tilejson, quad, shape, None, base)
        doc |= {
            "name": f"{name} signed distance (m)",
            "description": "signed distance to the curves in metres, negative inside the "
            "polygons: metres = R * redFactor + G * greenFactor + B * blueFactor - baseShift",
            "tiles": [f"{base}/field/{quad.id}/{name}/{{z}}/{{x}}/{{y}}.png"],
            "encoding": dict(FIELD_ENCODING),
        }
        return JSONResponse(doc)

    async def tile_matrix_sets(self, request: Request) -> Response:
        """The TileMatrixSets served (OGC API - Tiles, as TiTiler lists them)."""
        base = str(request.base_url).rstrip("/")
        return JSONResponse(await asyncio.to_thread(tms_list, base))

    async def tile_matrix_set(self, request: Request) -> Response:
        quad = self.tms(request.path_params["tms"])
        return Response(quad.document(), media_type="application/json")

    async def layer_list(self, request: Request) -> Response:
        items = sorted(self.layers.items())
        return JSONResponse(await asyncio.to_thread(lambda: [_describe(n, s) for n, s in items]))

    async def index(self, request: Request) -> Response:
        return HTMLResponse((STATIC / "index.html").read_text())


#: a tile number: ASCII digits only (``int()`` also takes ``1_0``, ``+1``, `` 1`` and the
#: digits of other scripts), at most 8 of them (zooms stop at 22)
_NUMBER = re.compile(r"[0-9]{1,8}")


def _zxy(z: str, x: str, y: str) -> tuple[int, int, int, int]:
    size = 256
    if y.endswith("@2x"):
        y, size = y[:-3], 512
    if not all(_NUMBER.fullmatch(v) for v in (z, x, y)):
        _bad(f"z/x/y must be integers of at most 8 ASCII digits, got {z!r}/{x!r}/{y!r}")
    zi, xi, yi = int(z), int(x), int(y)
    if not 0 <= zi <= MAX_ZOOM:
        _bad(f"zoom must be 0..{MAX_ZOOM}, got {zi}")
    n = 1 << zi
    if not (0 <= xi < n and 0 <= yi < n):
        _bad(f"tile {zi}/{xi}/{yi} does not exist: x and y must be in 0..{n - 1}")
    return zi, xi, yi, size


def not_modified(header: str | None, tag: str) -> bool:
    """Whether an ``If-None-Match`` header matches the entity tag ``tag``: ``*``, or a
    tag of its comma-separated list equal to ``tag`` by the weak comparison (RFC 9110,
    13.1.2: ``W/"x"`` matches ``"x"``)."""
    if not header:
        return False
    opaque = tag.removeprefix("W/")
    for t in header.split(","):
        t = t.strip()
        if t == "*" or t.removeprefix("W/") == opaque:
            return True
    return False


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


def _geojson_bytes(shape) -> bytes:
    """The layer's input as GeoJSON bytes, made once and kept on the shape."""
    return shape.derived.once("serve_geojson", lambda: json.dumps(shape.to_geojson()).encode())


def _distance_inside(shape, lon: float, lat: float) -> tuple[float, bool]:
    """The distance in metres from a point to the layer's curves (:func:`gloffset.distance`:
    the nearest candidate arcs only) and whether the point is inside its polygons."""
    metres = float(distance_to(shape, [lon], [lat])[0])
    inside = bool(points_inside(shape, lonlat_to_xyz(lon, lat).reshape(1, 3))[0])
    return metres, inside


def _describe(name: str, shape) -> dict:
    w, s, e, n = region_bounds(shape, 0.0)
    bounds = [w, s, e, n]
    return {"name": name, "bounds": bounds, "center": [(w + e) / 2, (s + n) / 2]} | {
        "vertices": int(shape.n_vertices)
    }


async def _error(request: Request, exc: HTTPException) -> Response:
    detail = exc.detail
    if exc.status_code == 404 and detail == "Not Found":  # the router's: no such path
        paths = ", ".join(getattr(r, "path", "") for r in request.app.routes)
        detail = f"no endpoint at {request.url.path!r}; the endpoints are {paths}"
    return JSONResponse({"detail": detail}, status_code=exc.status_code)


def create_app(
    layers: dict,
    *,
    cache_control: str = "public, max-age=3600",
    queue_size: int = 256,
    cache_mb: float = 256.0,
    field_mb: float = 256.0,
    render_timeout: float = 60.0,
    access_log: str | None = None,
    cors: tuple[str, ...] | list[str] | None = ("*",),
) -> Starlette:
    """The application serving ``layers`` (name -> :class:`~gloffset.Shape`).

    ``cache_control``: the tiles' Cache-Control header; ``queue_size``: tiles waiting to
    render at most (more are answered 503); ``cache_mb``: the LRU of rendered tiles;
    ``field_mb``: the LRU of distance fields (256 KiB a 256 px tile);
    ``render_timeout``: seconds a request waits for its tile before a 503;
    ``access_log``: a file to append a line per request to, ``"-"`` for standard output
    (:mod:`gloffset.serve.accesslog`), None for none; ``cors``: the origins whose pages may
    read the answers (:func:`cors_origins`; ``("*",)``: any, None: no CORS headers).
    """
    srv = _Server(
        layers,
        cache_control=cache_control,
        queue_size=queue_size,
        cache_mb=cache_mb,
        field_mb=field_mb,
        render_timeout=render_timeout,
    )
    get = ["GET", "HEAD"]
    routes = [
        Route("/", srv.index, methods=get),
        Route("/layers", srv.layer_list, methods=get),
        Route("/tiles/{layer}/{distance}/{z}/{x}/{y}.png", srv.tile, methods=get),
        Route("/tiles/{tms}/{layer}/{distance}/{z}/{x}/{y}.png", srv.tms_tile, methods=get),
        Route("/field/{tms}/{layer}/{z}/{x}/{y}.png", srv.tms_field_tile, methods=get),
        Route("/tiles/{tms}/{layer}/tilejson.json", srv.tms_tilejson, methods=get),
        Route("/field/{tms}/{layer}/tilejson.json", srv.tms_field_tilejson, methods=get),
        Route("/tileMatrixSets", srv.tile_matrix_sets, methods=get),
        Route("/tileMatrixSets/{tms}", srv.tile_matrix_set, methods=get),
        Route("/tilejson/{layer}.json", srv.tilejson, methods=get),
        Route("/field/{layer}/{z}/{x}/{y}.png", srv.field_tile, methods=get),
        Route("/field/{layer}.json", srv.field_tilejson, methods=get),
        Route("/offset/{layer}.geojson", srv.offset_geojson, methods=get),
        Route("/shape/{layer}.geojson", srv.shape_geojson, methods=get),
        Route("/distance/{layer}", srv.distance, methods=get),
        Route("/mvt/{layer}/{z}/{x}/{y}.pbf", srv.mvt_tile, methods=get),
        Route("/mvt/{layer}.json", srv.mvt_tilejson, methods=get),
        Mount("/static", StaticFiles(directory=STATIC), name="static"),
    ]
    middleware = []
    if access_log is not None:
        middleware.append(Middleware(AccessLog, stream=open_log(access_log)))
    if cors:  # inside the log, which then logs preflight requests too
        middleware.append(
            Middleware(
                CORSMiddleware,
                allow_origins=list(cors),
                allow_methods=get,
                expose_headers=_EXPOSED,
            )
        )

    @contextlib.asynccontextmanager
    async def lifespan(app):
        try:
            yield
        finally:  # no more background fields once the server stops
            srv.tiles.close()

    # Starlette types every handler as taking an Exception; this one is for HTTPException
    handlers = {HTTPException: _error}
    app = Starlette(
        routes=routes,
        exception_handlers=handlers,  # type: ignore[arg-type]
        middleware=middleware,
        lifespan=lifespan,
    )
    app.state.server = srv
    return app


def app_from_environment() -> Starlette:
    """The application of one worker process of ``gloffset serve --workers N`` (a factory
    for uvicorn): the inputs and options from :data:`ENVIRONMENT`. Each worker reads the
    inputs and makes its own GL context on its own render thread (workers are spawned,
    never forked)."""
    opts = json.loads(os.environ[ENVIRONMENT])
    layers = {Path(p).stem: read(p) for p in opts.pop("inputs")}
    return create_app(layers, **opts)
