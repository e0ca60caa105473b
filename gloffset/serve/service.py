"""The tile service behind ``gloffset serve``: tiles decided at once where they can be,
one GL render thread with a bounded queue and batches for the rest, and a cache of tile
bytes.

A tile wholly inside or wholly outside the offset region is decided without the render
thread or the GPU (:meth:`TileService.answer`): the exact distances from the tile's
centre to the curves and whether the centre is inside, against the tile's rigorous
bound, with the decision rule of the raster levels (:func:`gloffset.tiles.tiling.measure_tiles`,
:class:`~gloffset.tiles.tiling.TileCentre`); those distances do not depend on the offset
distance, so they are measured once per tile.
The answer is one shared PNG per size and style (empty: fully transparent).

A moderngl context is current on one thread only, so every other tile is rendered on one
render thread. Requests wait on a :class:`~gloffset.serve.renderqueue.Job`; the queue
(:class:`~gloffset.serve.renderqueue.RenderQueue`: a seen view's tiles first) holds at most
``queue_size`` of them (full, it raises :class:`QueueFull`: 503 and ``Retry-After``). The
render thread renders the pending tiles of one layer, distance, zoom, size and style
together (:func:`gloffset.tiles.tiling.render_tiles`), so throughput grows with load.
Rendered tiles are kept in an LRU bounded in bytes. A request whose client went away is
still rendered when its batch had started; one cancelled before is skipped.

A new tile is answered from its field, computed on the render thread, where a field costs
at most :data:`AT_ONCE` renders (:meth:`TileService.submit_from_field`). Else fields are
computed on a field thread (its own GL context): first for a tile asked for again at a new
distance once its renders cost a field (rent or buy, :meth:`TileService._again`); while a
distance slider sweeps the layer (:meth:`TileService.sliding`, seen from the requests), in
the render thread's spare time, those of its rendered tiles and of the decided tiles its
next steps bring to the frontier; where fields are cheap, those of a seen view's decided
tiles (:meth:`TileService.ahead_of`); the others when idle. They are kept in a second LRU
(``field_mb``); a tile whose field is kept is answered at any distance by its threshold."""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict
from concurrent.futures import Future
from dataclasses import dataclass

from ..errors import QueueFullError as QueueFull
from ..geometry.classes import CONTAINED, OUTSIDE
from ..raster.render import render_angle
from ..tiles.tiling import measure_tiles, render_tiles
from ..tiles.tiling.fieldtiles import encode_field, field_tile
from ..tiles.tiling.malloc import give_back_freed_memory
from ..tiles.tiling.ondemand import tms_levels
from ..units import EARTH_RADIUS
from .renderqueue import Job, RenderQueue
from .slider import FirstSight, Sliders
from .tilekeys import EMPTY_PNG, FieldKey, TileKey, empty_tile, etag, full_png, quad_of

__all__ = [
    "TileKey",
    "FieldKey",
    "TileService",
    "QueueFull",
    "EMPTY_PNG",
    "UNKNOWN",
    "full_png",
    "empty_tile",
    "etag",
]

log = logging.getLogger("gloffset.serve")


#: seconds without a render request after which the field thread computes the field of a
#: tile rendered once (a pause in the requests, not the gap between two views)
IDLE = 0.5
#: seconds between two looks of the field thread at the render thread, while fields queued
#: ahead (:meth:`TileService.ahead_of`) wait for it to have nothing to do
POLL = 0.05
#: rendered tiles whose fields wait, at most, in each of the two queues (the oldest go)
LATER = 4096
#: before any field's cost is known: a tile asked for after renders at this many other
#: distances has its field first (a slider; 1 also takes a map's tiles met again at another
#: distance, seldom asked once more)
AGAIN = 2
#: weight of the newest field in the running mean of a layer's field cost (seconds)
COST_WEIGHT = 0.3
#: a new tile has its field at once, and is answered by its threshold, where a field of
#: its layer costs at most this many of its renders (the running means): a GPU field
AT_ONCE = 2.0

#: seconds between two hand-backs of the freed heap to the system (after a render batch:
#: the RSS then follows the memory in use, not the largest batch so far)
TRIM = 5.0
#: tiles whose centre's distance and status are kept (about 450 bytes each with its key, measured)
CENTRES = 200_000
#: bytes each entry of the tile and field LRUs counts beside its data (its key, the
#: LRU's links, the field's object: about 300 measured for a tile), so that the LRUs'
#: bounds hold for many small tiles too
ENTRY = 512
#: :meth:`TileService.answer` without ``measure``: the tile's centre is not measured yet
UNKNOWN = object()


class TileService:
    """Tiles of ``layers`` (name -> Shape): decided at once, cached, or rendered on one
    thread in batches (see the module notes)."""

    def __init__(
        self,
        layers: dict,
        *,
        queue_size: int = 256,
        cache_mb: float = 256.0,
        field_mb: float = 256.0,
    ):
        self.layers = layers
        self.queue = RenderQueue(max(1, int(queue_size)), _group)
        self.cache: OrderedDict = OrderedDict()
        self.cache_bytes, self.cache_limit = 0, int(cache_mb * (1 << 20))
        self.centres: OrderedDict = OrderedDict()  # (layer, z, x, y) -> what triage needs
        self.fields: OrderedDict = OrderedDict()  # FieldKey -> DistanceField (radians)
        self.field_bytes, self.field_limit = 0, int(field_mb * (1 << 20))
        #: FieldKey -> (the distances a tile was rendered at, the seconds its renders
        #: took): its field when idle, or first once the renders cost what the field does
        self.later: OrderedDict = OrderedDict()
        #: FieldKey -> None: tiles of views seen before, decided inside or outside at the
        #: distance asked, whose fields are made ahead where fields are cheap (ahead_of)
        self.ahead: OrderedDict = OrderedDict()
        self.soon = FirstSight()  # fields bought for a slider (sliding)
        self.sliders = Sliders()  # the distance sliders seen from the requests
        self.field_cost: dict = {}  # layer -> running mean of its fields' seconds
        self.render_cost: dict = {}  # layer -> running mean of a rendered tile's seconds
        self.wanted: OrderedDict = OrderedDict()  # FieldKey -> Future, tiles asked again: at once
        self.computing: dict = {}  # FieldKey -> Future, the field thread's field
        self.started = time.monotonic()  # when the field thread began its field
        self.computed = 0  # fields computed
        self.closed = False  # set by close(): no more fields in the background
        self.lock = threading.Lock()
        self.wake = threading.Condition(self.lock)  # the field thread waits on it
        self.busy = False  # the render thread runs a batch
        self.last_put = time.monotonic()  # when the last render request came
        #: cleared, the render thread waits after taking a request (tests, draining)
        self.gate = threading.Event()
        self.gate.set()
        self.rendered = 0  # tiles rendered on the render thread
        self.trimmed = time.monotonic()  # when the freed heap was last handed back
        self.thread = threading.Thread(target=self._loop, name="gloffset-render", daemon=True)
        self.thread.start()
        self.field_thread = threading.Thread(
            target=self._field_loop, name="gloffset-fields", daemon=True
        )
        self.field_thread.start()

    # ------------------------------------------------------------------ requests
    def cached(self, key: TileKey | FieldKey) -> bytes | None:
        with self.lock:
            data = self.cache.get(key)
            if data is not None:
                self.cache.move_to_end(key)
            return data

    def answer(self, key: TileKey, *, measure: bool = True):
        """The tile's bytes and how they were found (``"cached"``, ``"inside"`` or
        ``"outside"``) when that needs no rendering, else None. With ``measure=False``
        only what is known already is used (fast enough for the event loop), and
        :data:`UNKNOWN` says that the tile's centre must be measured first (call again
        with ``measure=True`` off the event loop)."""
        data = self.cached(key)
        if data is not None:
            return data, "cached"
        cls = self.triage(key, measure=measure)
        if cls is UNKNOWN:
            return UNKNOWN
        if cls == CONTAINED:
            return full_png(key.size, key.style), "inside"
        if cls == OUTSIDE:
            return empty_tile(key.size), "outside"
        return None

    def triage(self, key: TileKey, *, measure: bool = True):
        """CONTAINED or OUTSIDE when the whole tile is decided at its own zoom (the
        classification of the raster levels, :func:`gloffset.raster.vector.levels.decide`, with
        the tile's rigorous bound), else None (:data:`UNKNOWN` when the tile is not
        measured yet and ``measure`` is False). What the decision needs (the exact
        distances from the tile's centre to the nearest boundary arc and ring edge, and
        whether it is inside) does not depend on the offset distance: it is measured once
        per tile and kept. Tiles with an outline of the input are left to the renderer, and
        those of a TileMatrixSet without a bound of its tiles (:func:`tms_levels`)."""
        if key.style.outline is not None:
            return None
        if key.tms is not None and tms_levels(quad_of(key.tms), key.z) is None:
            return None
        where = key.where()
        with self.lock:
            geo = self.centres.get(where)
        if geo is None:
            if not measure:
                return UNKNOWN
            geo = self._measure(key)
            with self.lock:
                self.centres[where] = geo
                if len(self.centres) > CENTRES:
                    self.centres.popitem(last=False)
        return geo.decide(key.d)

    def _measure(self, key: TileKey):
        """The tile entered directly at its zoom (:func:`gloffset.raster.vector.levels.at_cells`)
        with every arc that can be its centre's nearest as candidates (no distance
        limit): the exact distances to the nearest boundary arc and ring edge, the
        centre's inside status and the tile's decision bound (1-element arrays)."""
        shape, quad = self.layers[key.layer], quad_of(key.tms)
        return measure_tiles(shape, key.z, [(key.x, key.y)], quad)[(key.x, key.y)]

    def measure(self, keys) -> None:
        """Measure the centres of the tiles ``keys`` not known yet, those of one layer and
        zoom together (one :func:`~gloffset.raster.vector.levels.at_cells` for the tiles of a
        view: the same values as :meth:`triage` measuring each)."""
        groups: dict = {}
        with self.lock:
            for k in keys:
                if k.where() not in self.centres:
                    groups.setdefault((k.layer, k.z, k.tms), set()).add((k.x, k.y))
        for (layer, z, tms), tiles in groups.items():
            if tms is not None and tms_levels(quad_of(tms), z) is None:
                continue  # rendered, never decided (triage)
            got = measure_tiles(self.layers[layer], z, sorted(tiles), quad_of(tms))
            with self.lock:
                for (x, y), geo in got.items():
                    self.centres[(layer, z, x, y, tms)] = geo
                while len(self.centres) > CENTRES:
                    self.centres.popitem(last=False)

    def close(self) -> None:
        """Compute no more fields in the background (the server is shutting down); requests
        are still answered."""
        with self.lock:
            self.closed = True
            self.later.clear()
            self.ahead.clear()
            self.soon.clear()
            for fut in self.wanted.values():
                fut.set_result(None)
            self.wanted.clear()
            self.wake.notify_all()

    def field(self, fkey: FieldKey):
        """The kept :class:`~gloffset.DistanceField` of a tile (radians), or None."""
        with self.lock:
            f = self.fields.get(fkey)
            if f is not None:
                self.fields.move_to_end(fkey)
            return f

    def from_field(self, key: TileKey) -> bytes | None:
        """The tile's bytes from its kept field: the threshold at ``key.d``
        (:meth:`~gloffset.DistanceField.threshold`: the float64 reference render's pixels)
        styled as :func:`~gloffset.tiles.tiling.render_tiles` styles a rendered tile;
        None when the field is not kept or the style has an outline (those tiles are
        rendered). The bytes are kept in the tile LRU. Runs on any thread (no GL)."""
        if key.style.outline is not None:
            return None
        f = self.field(key.field())
        return None if f is None else self._threshold(key, f)

    def _threshold(self, key: TileKey, f) -> bytes:
        """The tile's bytes from its field ``f``, kept in the tile LRU."""
        data = key.style.encode(f.threshold(key.d) > 0)
        data = empty_tile(key.size) if data is None else data
        self._keep(key, data)
        return data

    def submit_field(self, fkey: FieldKey) -> Future:
        """A future of the field tile's PNG bytes
        (:func:`~gloffset.tiles.tiling.fieldtiles.encode_field` of the field in metres on
        the Earth's sphere), the field computed on the render thread and kept (raises
        :class:`QueueFull`)."""
        data = self.cached(fkey)
        if data is not None:
            return _done(data)
        return self._put(fkey, Job())

    def at_once(self, layer: str) -> bool:
        """Whether a new tile of ``layer`` is answered from its field, computed at once: a
        field of the layer costs at most :data:`AT_ONCE` renders of a tile (the running
        means of those made; False before both are known)."""
        with self.lock:
            cost, render = self.field_cost.get(layer), self.render_cost.get(layer)
        return cost is not None and render is not None and cost <= AT_ONCE * render

    def submit_from_field(self, key: TileKey, *, urgent: bool = False) -> Future:
        """A future of the tile's PNG bytes from its field (:meth:`from_field`), the field
        computed on the render thread first where it is not kept, the requests of a batch
        that share a field with one computation (raises :class:`QueueFull`). ``urgent``:
        as :meth:`submit`'s."""
        data = self.cached(key)
        if data is not None:
            return _done(data)
        return self._put(_FromField(key), Job(), urgent)

    def submit(self, key: TileKey, *, urgent: bool = False) -> Future:
        """A future of the tile's PNG bytes, rendered on the render thread (raises
        :class:`QueueFull`); a :class:`Job` unless the tile is cached. ``urgent``: a tile
        of a view seen before (:meth:`seen`: a distance slider moves), taken before the
        tiles of new views (:class:`~gloffset.serve.renderqueue.RenderQueue`)."""
        data = self.cached(key)
        if data is not None:
            return _done(data)
        return self._put(key, Job(), urgent)

    def seen(self, key: TileKey) -> bool:
        """Whether the tile's place was asked for before (at any distance): its centre is
        measured, or it was rendered. A tile of a view seen before is asked for again as a
        distance slider moves; its renders go before those of new views (``urgent``)."""
        with self.lock:
            return key.where() in self.centres or key.field() in self.later

    def asked(self, key: TileKey) -> bool:
        """:meth:`seen`, as a request comes: also noted for :meth:`sliding`."""
        with self.lock:
            self.sliders.asked(key.layer, key.where(), key.d)
            return key.where() in self.centres or key.field() in self.later

    def sliding(self, layer: str) -> bool:
        """Whether a distance slider sweeps ``layer`` (:class:`~gloffset.serve.slider.Sliders`:
        half its recent requests asked a place seen before at a new distance): then fields
        are bought at first sight (:meth:`_queue_fields`, :meth:`ahead_of`)."""
        with self.lock:
            return self.sliders.sliding(layer)

    def why_rendered(self, key: TileKey, seen: bool) -> str:
        """Why tile ``key`` is rendered rather than answered from a field (the
        ``Server-Timing`` header's ``why``): ``outline`` (a style with an outline: always
        rendered), ``new`` (its place not asked for before: a new view), ``frontier`` (its
        place asked for before, decided inside or outside there: no renders yet to pay for a
        field), ``rent`` (rendered before, those renders cost less than a field so far:
        :meth:`_again`), ``busy`` (its field is due but would come later than a render:
        :meth:`_sooner`), ``coming`` (its field is bought or being made, not made yet:
        :meth:`sliding`), or ``closed`` (the server is stopping)."""
        if key.style.outline is not None:
            return "outline"
        fkey = key.field()
        with self.lock:
            if self.closed:
                return "closed"
            if fkey in self.soon or fkey in self.computing:
                return "coming"
            if fkey not in self.later:
                return "frontier" if seen else "new"
            if fkey in self.wanted or self._again(fkey, key.d):
                return "busy"
            return "rent"

    def call(self, fn) -> Future:
        """A future of ``fn()`` run on the render thread (GL work must run there: the
        context is current on that thread only). Raises :class:`QueueFull`."""
        return self._put(fn, Job())

    def _put(self, item, fut: Future, urgent: bool = False) -> Future:
        self.last_put = time.monotonic()
        if not self.queue.put(item, fut, urgent):
            raise QueueFull("the render queue is full")
        return fut

    def _keep(self, key: TileKey | FieldKey, data: bytes) -> None:
        with self.lock:
            if key in self.cache:
                return
            self.cache[key] = data
            self.cache_bytes += len(data) + ENTRY
            while self.cache_bytes > self.cache_limit and self.cache:
                _, old = self.cache.popitem(last=False)
                self.cache_bytes -= len(old) + ENTRY

    def _keep_field(self, fkey: FieldKey, field) -> None:
        with self.lock:
            self.later.pop(fkey, None)
            if fkey in self.fields:
                return
            self.fields[fkey] = field
            self.field_bytes += field.values.nbytes + ENTRY
            while self.field_bytes > self.field_limit and self.fields:
                _, old = self.fields.popitem(last=False)
                self.field_bytes -= old.values.nbytes + ENTRY

    def _field(self, fkey: FieldKey):
        """The tile's field, kept or computed (on the calling thread, with its GL context)
        and kept."""
        f = self.field(fkey)
        if f is None:
            t0 = time.perf_counter()
            shape = self.layers[fkey.layer]
            f = field_tile(shape, fkey.z, fkey.x, fkey.y, fkey.size, fkey.gridquad_of())
            took = time.perf_counter() - t0
            with self.lock:
                self.computed += 1
                old = self.field_cost.get(fkey.layer, took)
                self.field_cost[fkey.layer] = old + COST_WEIGHT * (took - old)
            self._keep_field(fkey, f)
        return f

    # ------------------------------------------------------------------ the field thread
    def field_future(self, key: TileKey) -> Future | None:
        """A future that is done when the field of tile ``key`` is kept (its result None
        when it could not be made), for a tile whose field is due (:meth:`_again`: a view
        seen before at another distance, as a distance slider asks; or queued ahead,
        :meth:`ahead_of`) when waiting for the
        field is expected to be no longer than waiting for a render (:meth:`_sooner`); the
        field is then queued first. Else None: render the tile. None too for styles with
        an outline (those tiles are rendered)."""
        if key.style.outline is not None:
            return None
        fkey = key.field()
        with self.lock:
            if fkey in self.computing:
                return self.computing[fkey]
            due = fkey in self.wanted or fkey in self.ahead  # not soon: spare time only
            if self.closed or not (due or self._again(fkey, key.d)):
                return None
            return self._want(fkey) if self._sooner(fkey.layer) else None

    def ahead_of(self, key: TileKey, seen: bool = True) -> None:
        """Queue the field of tile ``key``, decided at ``key.d``, that a later distance may
        bring to the frontier (then a threshold, not a render) on the field thread: where a
        slider sweeps the layer (:meth:`sliding`), at first sight, if its next steps do
        (:meth:`~gloffset.serve.slider.Sliders.margin`); else for a tile seen before
        (``seen``) where fields cost at most :data:`AT_ONCE` renders (:meth:`at_once`),
        made while the render thread is idle. Not for styles with an outline."""
        if key.style.outline is not None:
            return
        sliding = self.sliding(key.layer)
        if not sliding and not (seen and self.at_once(key.layer)):
            return
        fkey = key.field()
        with self.lock:
            if self.closed or fkey in self.fields or fkey in self.computing or fkey in self.wanted:
                return
            if sliding:
                margin = self.sliders.margin(key.layer, self.centres.get(key.where()), key.d)
                if margin is not None:
                    self.soon.put(fkey, margin)
            else:
                self.ahead[fkey] = None
                self.ahead.move_to_end(fkey)
                while len(self.ahead) > LATER:
                    self.ahead.popitem(last=False)
            self.wake.notify()

    def _sooner(self, layer: str) -> bool:
        """Whether a field queued first now comes no later than a render (holding the
        lock): the rest of the field being computed, those queued first and this one, at
        their mean cost, against the render queue's tiles and this one at the renders'.
        Before both costs are known: when no field is being computed or waits."""
        cost, render = self.field_cost.get(layer), self.render_cost.get(layer)
        if cost is None or render is None:
            return not self.computing and not self.wanted
        left = max(0.0, cost - (time.monotonic() - self.started)) if self.computing else 0.0
        return left + (len(self.wanted) + 1) * cost <= (self.queue.qsize() + 1) * render

    def _again(self, fkey: FieldKey, d: float) -> bool:
        """Whether the tile, asked for at ``d``, should have its field first (holding the
        lock): rendered before at another distance, and its renders took as long as a
        field of its layer takes (the running mean); before any field of the layer is
        made, rendered at :data:`AGAIN` other distances.

        This is the rent-or-buy rule: renders are paid until they add up to the field's
        price, then the field is bought, so a tile never costs more than twice what the
        best choice in hindsight would have cost, whether the slider stops at the next
        distance or goes on for ever. It applies where a field costs more than
        :data:`AT_ONCE` renders (the CPU field on a small CPU: 5-10): a slider gets fields
        from about the fifth to the tenth distance, and a loaded server keeps rendering.
        Where fields cost less (the GPU field), every new tile is answered from its field
        at once (:meth:`at_once`)."""
        ds, spent = self.later.get(fkey, ((), 0.0))
        others = len(set(ds) - {d})
        cost = self.field_cost.get(fkey.layer)
        return others >= AGAIN if cost is None else others >= 1 and spent >= cost

    def _want(self, fkey: FieldKey) -> Future:
        """Queue the field of ``fkey`` first (holding the lock); its future."""
        self.later.pop(fkey, None)
        self.ahead.pop(fkey, None)
        self.soon.pop(fkey, None)
        fut = self.wanted.get(fkey) or self.computing.get(fkey)
        if fut is None:
            fut = Future()
            fut.set_running_or_notify_cancel()  # a waiter that goes away cannot cancel it
        if fkey not in self.computing:
            self.wanted[fkey] = fut
            self.wanted.move_to_end(fkey)
            while len(self.wanted) > LATER:
                self.wanted.popitem(last=False)[1].set_result(None)
        self.wake.notify()
        return fut

    def _next_field(self) -> tuple[FieldKey, Future] | None:
        """The next field to compute and its future (None once closed): the oldest queued
        first (:meth:`_want`); else, while the render thread has nothing to do (a field
        would slow it), one bought for a slider (``soon``) or the newest queued ahead; else,
        when no render was asked for in :data:`IDLE` seconds, the newest tile rendered once."""
        with self.lock:
            while not self.closed:
                spare = not self.busy and self.queue.empty()  # the render thread's CPU
                if self.wanted:  # in turn: each waits for those before it (_sooner)
                    fkey, fut = self.wanted.popitem(last=False)
                elif self.soon and spare and (soon := self.soon.take()):
                    fkey, fut = soon, Future()
                    fut.set_running_or_notify_cancel()
                elif self.ahead and spare:
                    fkey, fut = self.ahead.popitem(last=True)[0], Future()
                    fut.set_running_or_notify_cancel()
                elif self.later and self._idle():
                    fkey, fut = self.later.popitem(last=True)[0], Future()
                    fut.set_running_or_notify_cancel()
                else:  # polled while fields wait for a free render thread or an idle server
                    self.wake.wait(POLL if self.ahead or self.soon else self.later and IDLE or None)
                    continue
                if fkey in self.fields or fkey in self.computing:
                    fut.set_result(None)
                    continue
                self.computing[fkey] = fut
                self.started = time.monotonic()
                return fkey, fut
            return None

    def _idle(self) -> bool:
        return not self.busy and self.queue.empty() and time.monotonic() - self.last_put >= IDLE

    def _field_loop(self) -> None:
        while (got := self._next_field()) is not None:
            fkey, fut = got
            try:
                self._field(fkey)
            except Exception:  # noqa: BLE001 - the thread must outlive any one field
                log.exception("field of %s failed", fkey)
            with self.lock:
                self.computing.pop(fkey, None)
            fut.set_result(None)

    # ------------------------------------------------------------------ the render thread
    def _loop(self) -> None:
        while True:
            batch = self.queue.take()
            self.gate.wait()
            self.busy = True
            began = time.monotonic()
            for _, fut in batch:
                if isinstance(fut, Job):
                    fut.began = began
            try:
                self._run(batch)
            except Exception:  # noqa: BLE001 - the thread must outlive any one batch
                log.exception("render batch failed")
                for _, fut in batch:
                    if not fut.done():
                        fut.set_exception(RuntimeError("the render thread failed"))
            finally:
                self.busy = False
            if time.monotonic() - self.trimmed >= TRIM:
                give_back_freed_memory()
                self.trimmed = time.monotonic()

    def _run(self, batch) -> None:
        # a request cancelled before it ran (its client went away) is skipped; the
        # others can no longer be cancelled
        batch = [(k, f) for k, f in batch if f.set_running_or_notify_cancel()]
        groups: dict = {}
        fields: dict = {}
        thresholds: dict = {}
        for key, fut in batch:
            if callable(key):
                _run_call(key, fut)
            elif isinstance(key, FieldKey):
                fields.setdefault(key, []).append(fut)
            elif isinstance(key, _FromField):
                thresholds.setdefault(key.key.field(), []).append((key.key, fut))
            else:
                groups.setdefault(key.group(), []).append((key, fut))
        for items in groups.values():
            self._render(items)
        for fkey, futs in fields.items():
            self._field_tile(fkey, futs)
        for fkey, items in thresholds.items():
            self._from_field(fkey, items)

    def _from_field(self, fkey: FieldKey, items) -> None:
        """Answer tiles of one field from it, computed first where it is not kept."""
        try:
            f = self._field(fkey)
            answers = [self._threshold(key, f) for key, _ in items]
        except Exception as exc:  # noqa: BLE001 - every waiting request hears of it
            for _, fut in items:
                fut.set_exception(exc)
            return
        for (_, fut), data in zip(items, answers):
            fut.set_result(data)

    def _field_tile(self, fkey: FieldKey, futs) -> None:
        try:
            data = self.cached(fkey)
            if data is None:
                data = encode_field(self._field(fkey).values, EARTH_RADIUS)
                self._keep(fkey, data)
        except Exception as exc:  # noqa: BLE001 - every waiting request hears of it
            for fut in futs:
                fut.set_exception(exc)
            return
        for fut in futs:
            fut.set_result(data)

    def _render(self, items) -> None:
        key0 = items[0][0]
        shape, tiles = self.layers[key0.layer], {(k.x, k.y) for k, _ in items}
        with self.lock:  # the centres measured already: their statuses spare the crossings
            centres = {t: self.centres.get((key0.layer, key0.z, *t, None)) for t in tiles}
        t0 = time.perf_counter()
        try:
            if key0.tms is not None:  # each tile on its own grid
                got = _tms_tiles(shape, key0, tiles)
            else:
                got = render_tiles(
                    shape, key0.d, key0.z, tiles, size=key0.size, style=key0.style, centres=centres
                )
        except Exception as exc:  # noqa: BLE001 - every waiting request hears of it
            for _, fut in items:
                fut.set_exception(exc)
            return
        share = (time.perf_counter() - t0) / len(items)
        if key0.style.outline is None:
            with self.lock:
                old = self.render_cost.get(key0.layer, share)
                self.render_cost[key0.layer] = old + COST_WEIGHT * (share - old)
        for key, fut in items:
            data = got[(key.x, key.y)]
            data = empty_tile(key.size) if data is None else data
            self._keep(key, data)
            self.rendered += 1
            fut.set_result(data)
        if key0.style.outline is None:
            self._queue_fields([key for key, _ in items], share)

    def _queue_fields(self, keys, share: float) -> None:
        """Queue the fields of tiles just rendered (``share`` seconds each): first for a
        tile whose field is due (:meth:`_again`); for a slider (:meth:`sliding`) also
        bought at first sight; else when the server is idle."""
        with self.lock:
            if self.closed:
                return
            for key in keys:
                fkey = key.field()
                if fkey in self.fields or fkey in self.computing:
                    continue
                if fkey in self.wanted or self._again(fkey, key.d):
                    self._want(fkey)
                    continue
                if self.sliders.sliding(key.layer):  # the slider's next step: a threshold
                    self.soon.put(fkey, 0.0)
                ds, spent = self.later.get(fkey, ((), 0.0))
                self.later[fkey] = (tuple(dict.fromkeys((*ds, key.d))), spent + share)
                self.later.move_to_end(fkey)
            while len(self.later) > LATER:
                self.later.popitem(last=False)
            self.wake.notify()


@dataclass(frozen=True)
class _FromField:
    """A render-queue item: the tile ``key`` answered from its field (made if need be)."""

    key: TileKey


def _done(data) -> Future:
    fut: Future = Future()
    fut.set_result(data)
    return fut


def _group(item) -> tuple:
    """What requests the render thread runs together: tiles of one layer, distance, zoom,
    size and style (one :func:`~gloffset.tiles.tiling.render_tiles`), a field and the
    tiles answered from it, or one call."""
    if isinstance(item, TileKey):
        return ("tiles", *item.group())
    if isinstance(item, FieldKey):
        return ("field", item)
    if isinstance(item, _FromField):
        return ("field", item.key.field())
    return ("call", id(item))


def _tms_tiles(shape, key: TileKey, tiles) -> dict:
    """The styled PNG bytes (None: nothing to draw) of tiles ``(x, y)`` of ``key``'s zoom
    of its TileMatrixSet, each rendered on its own grid (:func:`gloffset.grids.TmsTile`)."""
    quad = quad_of(key.tms)
    return {
        (x, y): key.style.encode(render_angle(shape, key.d, quad.tile(key.z, x, y)) > 0)
        for x, y in sorted(tiles)
    }


def _run_call(fn, fut: Future) -> None:
    try:
        fut.set_result(fn())
    except Exception as exc:  # noqa: BLE001 - handed to the caller
        fut.set_exception(exc)
