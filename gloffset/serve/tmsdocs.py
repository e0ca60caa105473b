"""What ``gloffset serve`` says of the TileMatrixSets: the list of those served (OGC API -
Tiles, as TiTiler lists them) and the TileJSON of a layer's tiles in one (TiTiler's
``/{tms}/tilejson.json``: TileJSON is web-mercator-centric, so the document names the
TMS and links its definition)."""

from __future__ import annotations

from ..errors import GloffsetError
from ..grids.mercator import MAX_ZOOM
from ..grids.tms import TmsQuad, as_tms, tms_ids, tms_quad
from .bounds import MERCATOR_LAT, region_bounds

__all__ = ["tms_list", "tms_tilejson", "served_tms"]


def tms_list(base: str) -> dict:
    """The ``/tileMatrixSets`` document: id, title and definition link of each TMS served
    (``base`` the server's URL)."""
    items = []
    for name in served_tms():
        t = as_tms(name)
        link = {
            "href": f"{base}/tileMatrixSets/{name}",
            "rel": "http://www.opengis.net/def/rel/ogc/1.0/tiling-scheme",
            "type": "application/json",
            "title": f"Definition of {name}",
        }
        items.append({"id": name, "title": t.title or name, "links": [link]})
    return {"tileMatrixSets": items}


def tms_tilejson(quad: TmsQuad, shape, d: float | None, base: str) -> dict:
    """The members of a TMS layer's TileJSON that ``/tiles/{tms}/{layer}/tilejson.json``
    and ``/field/{tms}/{layer}/tilejson.json`` share: ``bounds`` the region's box at ``d``
    (None: the TMS's whole extent) within the TMS's extent in lon/lat (pyproj's, its
    edges densified; web mercator's latitudes for ``WebMercatorQuad``), ``center`` the
    middle of the layer's own box there."""
    world = quad.kind == "mercator"
    limit = MERCATOR_LAT if world else 90.0
    rows, cols = quad.matrix_shape(0)
    ext = (
        (-180.0, -MERCATOR_LAT, 180.0, MERCATOR_LAT)
        if world
        else quad.tiles_lonlat(0, 0, 0, cols - 1, rows - 1)
    )
    box = ext if d is None else _within(region_bounds(shape, d, limit), ext)
    w, s, e, n = _within(region_bounds(shape, 0.0, limit), box)
    return {
        "tilejson": "3.0.0",
        "minzoom": 0,
        "maxzoom": min(quad.maxzoom, MAX_ZOOM),
        "tileSize": quad.size,
        "bounds": list(box),
        "center": [(w + e) / 2, (s + n) / 2, 0],
        "tileMatrixSet": quad.id,
        "tileMatrixSetURI": f"{base}/tileMatrixSets/{quad.id}",
    }


def _within(box, ext) -> tuple[float, float, float, float]:
    """``box`` (W, S, E, N) cut to ``ext``; ``ext`` where they do not meet."""
    w, s = max(box[0], ext[0]), max(box[1], ext[1])
    e, n = min(box[2], ext[2]), min(box[3], ext[3])
    return (w, s, e, n) if w <= e and s <= n else tuple(ext)


def served_tms() -> list[str]:
    """The TileMatrixSets whose tiles the server makes (the quadtrees of morecantile's)."""
    out = []
    for name in tms_ids():
        try:
            tms_quad(name)
        except GloffsetError:
            continue
        out.append(name)
    return out
