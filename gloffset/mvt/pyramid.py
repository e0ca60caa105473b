"""Pyramids of vector tiles: :func:`mvt_pyramid` writes the MVT tiles of a zoom range to
an MBTiles file, a PMTiles archive or an XYZ folder of ``z/x/y.pbf``.

The offset is resolved once (:class:`~gloffset.mvt.boundary.ResolvedBoundary`), then the
tiles are walked zoom by zoom: a tile whose cap no boundary arc reaches is wholly inside
or outside (one exact membership test decides); an inside tile is the one square polygon
of the buffered tile, written with its descendants without further work, and stored once
in MBTiles and PMTiles (one image, many entries); an outside tile is skipped with its
descendants; the other tiles (the frontier) get their boundary
(:func:`gloffset.mvt.tile.tile_geometry`). Every tile equals :func:`gloffset.vector_tile`
of the same tile.
"""

from __future__ import annotations

import gzip
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._version import __version__
from ..grids.mercator import check_zoom
from ..shape import read
from ..tiles.store.tilestore import INPUT_KEY, input_digest, open_store
from ..tiles.tiling.metadata import final_bounds
from ..units import EARTH_RADIUS, VECTOR_LIMIT, check_radius, distance_properties, offset_angle
from .boundary import ResolvedBoundary
from .densify import ZoomPoints
from .geometry import TileFrame, to_polygons
from .tile import (
    DEFAULT_LAYER,
    boxed,
    check_mvt_options,
    corner,
    encode,
    frame_rings,
    tile_geometry,
)

__all__ = ["MVTStats", "mvt_pyramid", "vector_layers"]


@dataclass
class MVTStats:
    """What a vector pyramid wrote: tiles with boundary, inside squares, seconds."""

    frontier: int = 0
    inside: int = 0
    empty: int = 0
    seconds: float = 0.0

    @property
    def written(self) -> int:
        return self.frontier + self.inside


def vector_layers(layer: str, zooms: tuple[int, int]) -> list[dict]:
    """The TileJSON ``vector_layers`` of a tileset of the region."""
    return [
        {
            "id": layer,
            "description": "the region within the distance",
            "minzoom": zooms[0],
            "maxzoom": zooms[1],
            "fields": {"distance_m": "Number", "distance": "String"},
        }
    ]


def _metadata(name, layer, zooms, params, digest) -> dict:
    layers = vector_layers(layer, zooms)
    meta = {
        "name": name,
        "format": "pbf",
        "type": "overlay",
        "version": "1",
        "description": f"{name}: the region within the distance, as vector tiles",
        "minzoom": zooms[0],
        "maxzoom": zooms[1],
        "bounds": "-180.0,-85.051129,180.0,85.051129",
        "center": f"0.0,0.0,{zooms[0]}",
        "json": json.dumps({"vector_layers": layers}),
        "gloffset": params,
        "generator": f"gloffset {__version__}",
        INPUT_KEY: digest,
    }
    return meta


def mvt_pyramid(
    shape,
    distance,
    zooms: tuple[int, int],
    out,
    *,
    radius: float = EARTH_RADIUS,
    extent: int = 4096,
    buffer: int = 64,
    layer: str | None = None,
    name: str | None = None,
    overwrite: bool = False,
) -> MVTStats:
    """Write the vector tiles of the region within ``distance`` for zooms ``zooms`` (a
    ``(min, max)`` pair) to ``out`` (``.mbtiles``, ``.pmtiles`` or a folder of
    ``z/x/y.pbf``). Tiles are those of :func:`gloffset.vector_tile` (same accuracy);
    MBTiles holds them gzip-compressed (MBTiles 1.3), the others as they are. The
    metadata has ``format`` ``pbf`` and the ``vector_layers``. Returns :class:`MVTStats`.
    """
    t0 = time.perf_counter()
    zlo, zhi = (check_zoom(int(z)) for z in zooms)
    extent, buffer = check_mvt_options(extent, buffer)
    shape = read(shape)
    r = check_radius(radius)
    d = offset_angle(shape, distance, r, limit=VECTOR_LIMIT)
    layer = layer or DEFAULT_LAYER
    props = distance_properties(distance, r)
    params = json.dumps(
        {"distance_rad": repr(float(d)), "zooms": [zlo, zhi], "extent": extent, "buffer": buffer},
        sort_keys=True,
    )
    label = name or Path(str(out)).stem
    meta = _metadata(label, layer, (zlo, zhi), params, input_digest(shape))
    walk = _Walk(
        ResolvedBoundary.of(shape, d),
        extent,
        buffer,
        layer,
        props,
        gzip_tiles=Path(str(out)).suffix.lower() == ".mbtiles",
    )
    store = open_store(out, meta, overwrite=overwrite)
    try:
        walk.run(store, zlo, zhi)
        store.set_metadata(final_bounds(store, (zlo, zhi)))
        store.finish()
    finally:
        store.close()
    walk.stats.seconds = time.perf_counter() - t0
    return walk.stats


class _Walk:
    """The zoom-by-zoom walk of a vector pyramid (see the module notes)."""

    def __init__(self, boundary, extent, buffer, layer, props, *, gzip_tiles: bool):
        self.boundary = boundary
        self.extent, self.buffer = extent, buffer
        self.layer, self.props = layer, props
        self.gzip_tiles = gzip_tiles
        self.stats = MVTStats()
        self._square: bytes | None = None  # an inside tile off the world's top and bottom

    def tile(self, z, x, y, pieces=None):
        """The tile's bytes as stored, or None for a tile without the region."""
        b = self.boundary
        return self.encoded(tile_geometry(b, z, x, y, self.extent, self.buffer, pieces=pieces))

    def encoded(self, g):
        """A tile's geometry as stored, or None for none."""
        if g is None:
            return None
        data = encode(g, self.layer, self.props, self.extent)
        return gzip.compress(data, mtime=0) if self.gzip_tiles else data

    def inside_tile(self, z, x, y) -> bytes:
        """An inside tile's bytes: one square, cut at the world's top and bottom."""
        if y == 0 or y == (1 << z) - 1 or z == 0:
            data = self.tile(z, x, y)
            assert data is not None
            return data
        if self._square is None:
            self._square = self.tile(z, x, y)
        assert self._square is not None
        return self._square

    def run(self, store, zlo: int, zhi: int) -> None:
        open_tiles = [(0, 0)]
        inside: list[tuple[int, int]] = []
        for z in range(0, zhi + 1):
            if z >= zlo:
                self.write_inside(store, z, inside)
            next_open, uniform = self.frontier(store, z, zlo, open_tiles)
            next_inside = self.settle(store, z, zlo, uniform)
            inside = [c for x, y in inside for c in _children(x, y)] + next_inside
            open_tiles = next_open
            store.commit()

    def write_inside(self, store, z, inside) -> None:
        """The tiles known to be inside from their parents."""
        n = 1 << z
        mids = [(z, x, y) for x, y in inside if 0 < y < n - 1]
        if mids:
            store.put_many(mids, self.inside_tile(z, mids[0][1], mids[0][2]))
        for x, y in inside:
            if not 0 < y < n - 1:
                store.put(z, x, y, self.inside_tile(z, x, y))
        self.stats.inside += len(inside)

    def frontier(self, store, z, zlo, open_tiles):
        """Write the tiles that arcs reach; return their children and the others. The
        tiles that no boundary crosses are decided by one membership test together."""
        next_open, uniform, undecided = [], [], []
        points = near = None
        if z > 0:  # the arcs' points once for the zoom's tiles, and the arcs near each
            q, s, e = self.boundary.arcs
            points = ZoomPoints(q, s, e, z, self.extent)
            near = points.tiles(self.buffer)
        for x, y in open_tiles:
            frame = TileFrame.of(z, x, y, self.extent, self.buffer)
            pieces = None
            if near is not None:
                items = near.get((x, y))
                pieces = self.boundary.pieces_of(items if items is not None else [])
            if pieces is not None and not pieces.chains:
                u0, v0, u1, v1 = frame.rect
                uniform.append((x, y, frame.unproject([[0.5 * (u0 + u1), 0.5 * (v0 + v1)]])))
                continue
            next_open.extend(_children(x, y))
            if z < zlo:
                continue
            if z == 0:
                self.put(store, z, x, y, self.tile(z, x, y))
                continue
            rings, crossed = frame_rings(self.boundary, frame, pieces, points)
            if crossed:
                self.put(store, z, x, y, self.encoded(to_polygons(rings)))
            else:
                undecided.append((x, y, rings, frame))
        if undecided:
            ins = self.boundary.contains(np.vstack([corner(f) for _, _, _, f in undecided]))
            for (x, y, rings, frame), i in zip(undecided, ins):
                self.put(store, z, x, y, self.encoded(to_polygons(boxed(rings, frame, i))))
        return next_open, uniform

    def put(self, store, z, x, y, data) -> None:
        if data is None:
            self.stats.empty += 1
        else:
            store.put(z, x, y, data)
            self.stats.frontier += 1

    def settle(self, store, z, zlo, uniform) -> list:
        """Decide the tiles no arc reaches in one exact membership test; write the inside
        ones and return their children."""
        if not uniform:
            return []
        centres = np.vstack([c for _, _, c in uniform])
        out = []
        for (x, y, _), ins in zip(uniform, self.boundary.contains(centres)):
            if ins:
                if z >= zlo:
                    store.put(z, x, y, self.inside_tile(z, x, y))
                    self.stats.inside += 1
                out.extend(_children(x, y))
        return out


def _children(x: int, y: int):
    return [(2 * x, 2 * y), (2 * x + 1, 2 * y), (2 * x, 2 * y + 1), (2 * x + 1, 2 * y + 1)]
