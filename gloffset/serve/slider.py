"""A distance slider seen from a tile server's requests (:class:`Sliders`): per layer, the
running share of tile requests that asked a place seen before at a new distance (a slider
over a view asks each of its tiles at each step; a pan asks new places, or the same at the
same distance), and the slider's running mean step and way; and which decided tiles its
next steps bring to the frontier (:meth:`Sliders.margin`); the queue of the fields so
bought (:class:`FirstSight`). Not thread-safe: the tile service calls them holding its
lock."""

from __future__ import annotations

import time
from collections import OrderedDict

__all__ = ["WEIGHT", "ON", "OFF", "STEPS", "PLACES", "STALE", "QUEUED", "Sliders", "FirstSight"]

#: weight of the newest request in a layer's running means: about the last 16
WEIGHT = 1 / 16
#: a layer whose share reaches this is being swept by a slider, until the share falls under
#: :data:`OFF` (a slider's new view, 12 new tiles, does not switch it off; a pan's two do)
ON = 0.5
OFF = 0.2
#: a decided tile has its field bought where it reaches the frontier within this many of
#: the slider's next steps (its mean step, in the way it moves)
STEPS = 2
#: places whose last distance is kept (the newest)
PLACES = 4096
#: seconds a field bought at first sight waits, at most, unless its view asks for the tile
#: again (a slider asks a view's tiles at each step)
STALE = 2.0
#: fields bought at first sight that wait, at most (the oldest go)
QUEUED = 4096


class Sliders:
    """The distance sliders of a tile server's layers (see the module notes)."""

    def __init__(self) -> None:
        self.last: OrderedDict = OrderedDict()  # place -> the last distance asked there
        self.share: dict = {}  # layer -> running share of requests at a new distance
        self.on: set = set()  # the layers a slider sweeps
        self.step: dict = {}  # layer -> running mean of a move (radians)
        self.heading: dict = {}  # layer -> running mean of the signed move (radians)

    def asked(self, layer: str, place, d: float) -> None:
        """Note a tile request of ``layer`` at ``place`` (any hashable key of the tile's
        place) and distance ``d`` (radians)."""
        last = self.last.get(place)
        self.last[place] = d
        self.last.move_to_end(place)
        while len(self.last) > PLACES:
            self.last.popitem(last=False)
        moved = last is not None and last != d
        if last is not None and moved:
            move = d - last
            old = self.step.get(layer, abs(move))
            self.step[layer] = old + WEIGHT * (abs(move) - old)
            old = self.heading.get(layer, move)
            self.heading[layer] = old + WEIGHT * (move - old)
        old = self.share.get(layer, 0.0)
        share = self.share[layer] = old + WEIGHT * (float(moved) - old)
        if share >= ON:
            self.on.add(layer)
        elif share < OFF:
            self.on.discard(layer)

    def sliding(self, layer: str) -> bool:
        """Whether a slider sweeps ``layer``: the share of its requests at a new distance
        reached :data:`ON` and has not fallen under :data:`OFF` since."""
        return layer in self.on

    def way(self, layer: str) -> int:
        """The way the layer's slider moves: 1 (growing distances), -1 (shrinking), or 0
        (either: the mean of its moves is under half their mean size)."""
        heading, step = self.heading.get(layer, 0.0), self.step.get(layer, 0.0)
        return 0 if abs(heading) < 0.5 * step else 1 if heading > 0 else -1

    def margin(self, layer: str, geo, d: float) -> float | None:
        """How far (radians) the layer's slider must move from ``d``, by its mean step in
        its way, for the tile whose centre is ``geo`` (a
        :class:`~gloffset.tiles.tiling.TileCentre`) to reach the frontier (the tile's own
        decision, :meth:`~gloffset.tiles.tiling.TileCentre.decide`, at each of its next
        :data:`STEPS` steps); None where it does not, or the tile is not measured."""
        step, way = self.step.get(layer, 0.0), self.way(layer)
        if geo is None or step <= 0:
            return None
        for k in range(1, STEPS + 1):
            for sign in (1, -1) if way == 0 else (way,):
                if geo.decide(d + sign * k * step) is None:
                    return k * step
        return None


class FirstSight(dict):
    """The fields bought at first sight for a slider: key -> (margin, when queued); a
    rendered tile's (margin 0) first, then the newest (a view the slider is on, not one it
    left); those queued over :data:`STALE` seconds ago are dropped (their view was left)."""

    def put(self, key, margin: float) -> None:
        self[key] = (margin, time.monotonic())
        if len(self) > QUEUED:
            self.pop(min(self, key=lambda k: self[k][1]))

    def take(self):
        """The next key, taken off the queue; None when there is none."""
        old = time.monotonic() - STALE
        for key in [k for k, (_, t) in self.items() if t < old]:
            del self[key]
        if not self:
            return None
        key = min(self, key=lambda k: (self[k][0] > 0, -self[k][1]))
        del self[key]
        return key
