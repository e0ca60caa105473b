"""The tile service behind ``gloffset serve``: one GL render thread, a bounded queue,
batches, and a cache of tile bytes.

A moderngl context is current on one thread only, so every tile is rendered on one
render thread. Requests wait on a :class:`concurrent.futures.Future`; the queue holds at
most ``queue`` pending tiles (a full queue raises :class:`QueueFull`, which the server
answers with 503 and ``Retry-After``). The render thread takes every pending request at
once and renders those of one layer, distance, zoom, size and style together
(:func:`gloffset.raster.tiles.render_tiles`: one walk down the zooms and batched GPU
runs), so throughput grows with load. Rendered tiles are kept in an LRU bounded in
bytes; a tile with nothing in it and a fully inside tile are the same few bytes each.
A request whose client went away is still rendered (its batch shares the work) and its
result simply dropped.
"""

from __future__ import annotations

import hashlib
import io
import queue
import threading
import time
from collections import OrderedDict
from concurrent.futures import Future
from dataclasses import dataclass

import numpy as np
from PIL import Image

from ..errors import QueueFullError as QueueFull
from ..raster.tilepaint import TileStyle
from ..raster.tiles import render_tiles

__all__ = ["TileKey", "TileService", "QueueFull", "EMPTY_PNG"]


def _empty_png(size: int) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(np.zeros((size, size, 4), np.uint8), mode="RGBA").save(buf, format="PNG")
    return buf.getvalue()


#: A fully transparent tile of 256 and 512 pixels.
EMPTY_PNG = {256: _empty_png(256), 512: _empty_png(512)}


@dataclass(frozen=True)
class TileKey:
    """What a tile is: layer, distance (radians), z/x/y, pixel size and style."""

    layer: str
    d: float
    z: int
    x: int
    y: int
    size: int
    style: TileStyle

    def group(self) -> tuple:
        return (self.layer, self.d, self.z, self.size, self.style)


class TileService:
    """Render tiles of ``layers`` (name -> Shape) on one thread (see the module notes)."""

    def __init__(self, layers: dict, *, queue_size: int = 256, cache_mb: float = 256.0):
        self.layers = layers
        self.queue: queue.Queue = queue.Queue(maxsize=max(1, int(queue_size)))
        self.cache: OrderedDict = OrderedDict()
        self.cache_bytes, self.cache_limit = 0, int(cache_mb * (1 << 20))
        self.lock = threading.Lock()
        self.hold = threading.Event()  # tests: set to pause the render thread
        self.thread = threading.Thread(target=self._loop, name="gloffset-render", daemon=True)
        self.thread.start()

    # ------------------------------------------------------------------ requests
    def cached(self, key: TileKey) -> bytes | None:
        with self.lock:
            data = self.cache.get(key)
            if data is not None:
                self.cache.move_to_end(key)
            return data

    def submit(self, key: TileKey) -> Future:
        """A future of the tile's PNG bytes (raises :class:`QueueFull`)."""
        fut: Future = Future()
        data = self.cached(key)
        if data is not None:
            fut.set_result(data)
            return fut
        try:
            self.queue.put_nowait((key, fut))
        except queue.Full:
            raise QueueFull from None
        return fut

    def call(self, fn) -> Future:
        """A future of ``fn()`` run on the render thread (GL work must run there: the
        context is current on that thread only). Raises :class:`QueueFull`."""
        fut: Future = Future()
        try:
            self.queue.put_nowait((fn, fut))
        except queue.Full:
            raise QueueFull from None
        return fut

    def _keep(self, key: TileKey, data: bytes) -> None:
        with self.lock:
            if key in self.cache:
                return
            self.cache[key] = data
            self.cache_bytes += len(data)
            while self.cache_bytes > self.cache_limit and self.cache:
                _, old = self.cache.popitem(last=False)
                self.cache_bytes -= len(old)

    # ------------------------------------------------------------------ the render thread
    def _loop(self) -> None:
        while True:
            batch = [self.queue.get()]
            while self.hold.is_set():
                time.sleep(0.01)
            while True:
                try:
                    batch.append(self.queue.get_nowait())
                except queue.Empty:
                    break
            groups: dict = {}
            for key, fut in batch:
                if callable(key):
                    _run_call(key, fut)
                else:
                    groups.setdefault(key.group(), []).append((key, fut))
            for items in groups.values():
                self._render(items)

    def _render(self, items) -> None:
        key0 = items[0][0]
        try:
            got = render_tiles(
                self.layers[key0.layer],
                key0.d,
                key0.z,
                {(k.x, k.y) for k, _ in items},
                size=key0.size,
                style=key0.style,
            )
        except Exception as exc:  # noqa: BLE001 - every waiting request hears of it
            for _, fut in items:
                if not fut.done():
                    fut.set_exception(exc)
            return
        for key, fut in items:
            data = got[(key.x, key.y)]
            data = EMPTY_PNG[key.size] if data is None else data
            self._keep(key, data)
            if not fut.done():
                fut.set_result(data)


def _run_call(fn, fut: Future) -> None:
    try:
        fut.set_result(fn())
    except Exception as exc:  # noqa: BLE001 - handed to the caller
        fut.set_exception(exc)


def etag(data: bytes) -> str:
    """A strong ETag: the same bytes, the same tag."""
    return '"' + hashlib.sha256(data).hexdigest()[:32] + '"'
