"""What a pyramid run reports: its counts (:class:`PyramidStats`), its progress
(:class:`TileProgress`) and the estimate of the time left (:class:`Tracker`).
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager
from dataclasses import dataclass, field

__all__ = ["PyramidStats", "TileProgress", "Tracker"]


# ---------------------------------------------------------------------- results
@dataclass
class PyramidStats:
    """What a pyramid run did (counts of tiles at zooms min..max).

    ``rendered``: frontier tiles rendered on the GPU; ``empty``: of those, tiles
    with no pixel inside (not written); ``inside``: tiles written as fully inside
    without rendering (descendants of contained tiles included); ``painted``:
    decided tiles drawn with an outline without rendering; ``outside``: tiles found
    outside (their descendants never visited); ``present``: tiles skipped because a
    resumed output had them; ``render_calls``: batched render calls.
    """

    rendered: int = 0
    empty: int = 0
    inside: int = 0
    painted: int = 0
    outside: int = 0
    present: int = 0
    render_calls: int = 0
    seconds: float = 0.0
    zooms: dict = field(default_factory=dict)

    @property
    def written(self) -> int:
        """Tiles written by this run (rendered non-empty, inside, painted)."""
        return self.rendered - self.empty + self.inside + self.painted

    @property
    def handled(self) -> int:
        """Tiles the run's progress counts (:class:`TileProgress`): those written, the
        rendered ones found empty (not written) and those already present."""
        return self.written + self.empty + self.present

    def as_dict(self) -> dict:
        return {
            "rendered": self.rendered,
            "empty": self.empty,
            "inside": self.inside,
            "painted": self.painted,
            "outside": self.outside,
            "present": self.present,
            "written": self.written,
            "handled": self.handled,
            "render_calls": self.render_calls,
            "seconds": self.seconds,
            "zooms": self.zooms,
        }


# ---------------------------------------------------------------------- progress
@dataclass(frozen=True)
class TileProgress:
    """Where a pyramid run stands; :func:`~.driver.pyramid` hands one to ``progress`` before the
    first tile, after each tile or batch of tiles handled, and at the end.

    Tiles count at zooms min..max: frontier tiles (rendered, written or empty),
    outlined tiles and every tile of a fully-inside subtree, already present ones
    included; tiles found outside are not counted.

    Attributes
    ----------
    zoom : int
        The zoom being classified or written.
    done : int
        Tiles handled so far.
    total : int
        Estimate of the tiles the run handles in all: the tiles of the zooms classified
        so far are known exactly, the next zooms' frontier and inside tiles too where the
        bin levels below the frontier tiles already hold them (from the zoom before the
        first one written; 4 zooms ahead for 256 px tiles), and deeper zooms follow the
        growth of the frontier from zoom to zoom. On Dask workers, once a task has
        ended, the tasks left count the mean tiles of those ended. Never below ``done``;
        equal to it at the end, and only there.
    seconds : float
        Since the run started.
    eta : float or None
        Estimated seconds left: the tiles left of each kind (rendered or outlined, and
        inside) at the seconds per tile measured so far for that kind, plus a fixed cost
        per zoom (measured too); None during the first zoom (for a one-zoom run: until a
        tile has been rendered); 0 at the end. On Dask workers: the heavy tiles left at
        the pace the tasks have kept so far (None until one has ended).
    """

    zoom: int
    done: int
    total: int
    seconds: float
    eta: float | None

    @property
    def fraction(self) -> float:
        """Share of the run's time done, ``seconds / (seconds + eta)`` (0 while the ETA
        is unknown); exactly 1 at the end and only there."""
        if self.done >= self.total:
            return 1.0
        if self.eta is None or self.seconds + self.eta <= 0.0:
            return 0.0
        return min(self.seconds / (self.seconds + self.eta), 1.0 - 1e-9)


#: Seconds per inside tile over seconds per rendered tile, until both are measured
#: (MBTiles: about 1/500, a directory of hard links: about 1/30).
_LIGHT_PRIOR = 0.01
#: A zoom's fixed cost is taken as at most that of this many rendered tiles (one GPU run
#: of 256 px tiles), until a zoom has more tiles than that.
_ZOOM_TILES = 256


class Tracker:
    """Counts the tiles of a run by kind (heavy: frontier and outlined tiles; light: the
    tiles of fully-inside subtrees), estimates the tiles still to come (see
    :class:`TileProgress`) and the time they take, and calls ``progress``.

    Time model: a zoom's heavy work costs ``a + b n`` seconds for ``n`` heavy tiles
    (``a``: the float64 levels, GPU runs and commit that every zoom has; ``b``: a tile's
    share of rendering, encoding and writing), ``a`` the cheapest zoom so far and ``b``
    from the latest zoom (at least ``a / 256``); inside tiles cost the mean measured so
    far.
    """

    def __init__(self, zlo: int, zhi: int, progress):
        self.zlo, self.zhi, self.progress = zlo, zhi, progress
        self.t0 = time.perf_counter()
        self.zoom = 0
        self.done = [0, 0]  # heavy, light
        self.known = [0, 0]  # tiles of the zooms classified so far (done included)
        self.future = [0.0, 0.0]  # estimated tiles of the zooms below
        self.future_zooms = 0  # zooms below with heavy tiles (estimated)
        self.skipped = [0, 0]  # already present (no time spent)
        self.light_s = 0.0  # seconds writing inside tiles
        self.setup_s = 0.0  # seconds spent once (the GL context)
        self.frontier: dict[int, int] = {}  # zoom -> frontier tiles (classified or ahead)
        self.contained: dict[int, int] = {}  # zoom -> newly contained tiles
        self.zooms: list[tuple[int, float]] = []  # per finished zoom: heavy tiles, seconds
        # at the current zoom's start: (heavy worked, heavy seconds)
        self.mark: tuple[int, float] | None = None
        self.last: TileProgress | None = None
        self.tasks: dict | None = None  # a split run's tasks (:meth:`start_tasks`)

    def _sub(self, z: int) -> int:
        """Tiles of a subtree rooted at zoom ``z`` within zooms min..max."""
        return sum(4 ** (zz - z) for zz in range(max(z, self.zlo), self.zhi + 1))

    def _heavy(self, now: float) -> tuple[int, float]:
        """Heavy tiles worked (not skipped) and heavy seconds, so far."""
        return self.done[0] - self.skipped[0], now - self.t0 - self.light_s - self.setup_s

    def plan(self, z, *, front, contained, carried_in, carried_out, ahead):
        """Zoom ``z`` is classified: its tiles are known, the deeper zooms re-estimated
        (``ahead``: (frontier, contained) of zooms z+1.. from the bin levels)."""
        now = time.perf_counter()
        if self.mark is not None:
            n, sec = self._heavy(now)
            self.zooms.append((n - self.mark[0], sec - self.mark[1]))
        self.mark = self._heavy(now) if z >= self.zlo else None
        self.zoom = z
        inz = z >= self.zlo
        self.known[0] += (front + carried_in + carried_out) * inz
        self.known[1] += contained * self._sub(z)
        self.frontier[z], self.contained[z] = front, contained
        for k, (fr, co) in enumerate(ahead, start=z + 1):
            if k > self.zhi:
                break
            self.frontier[k], self.contained[k] = fr, co
        deep = max(self.frontier)
        # frontier growth per zoom and contained tiles per parent frontier tile, from
        # the two deepest zooms known
        prev = self.frontier.get(deep - 1, 0)
        grow = min(max(self.frontier[deep] / prev, 1.0), 4.0) if prev else 2.0
        per = min(self.contained[deep] / prev, 4.0) if prev else 0.0
        heavy = light = 0.0
        zooms = 0
        f = float(self.frontier[deep])
        fz: float
        cz: float
        for zz in range(z + 1, self.zhi + 1):
            if zz <= deep:
                fz, cz = self.frontier[zz], self.contained[zz]
            else:
                fz, cz = f * grow, per * f
                f = fz
            light += cz * self._sub(zz)
            if zz >= self.zlo:
                # outlined tiles: their children along the outline (about twice as many
                # per zoom) are outlined again, the others of the inside ones are inside
                line = 2.0 ** (zz - z)
                h = fz + (carried_in + carried_out) * line
                light += carried_in * (4.0 ** (zz - z) - line)
                heavy += h
                zooms += h >= 0.5
        self.future = [heavy, light]
        self.future_zooms = zooms
        self._emit()

    @contextmanager
    def light(self):
        """Times the writing of inside tiles."""
        t = time.perf_counter()
        try:
            yield
        finally:
            self.light_s += time.perf_counter() - t

    def setup(self, fn):
        """Call ``fn`` and keep its time out of the tiles' rates."""
        t = time.perf_counter()
        fn()
        self.setup_s += time.perf_counter() - t

    def tick(self, heavy: int = 0, light: int = 0, skipped: int = 0):
        if heavy:
            self.done[0] += heavy
            self.skipped[0] += skipped
        if light:
            self.done[1] += light
            self.skipped[1] += skipped
        if heavy or light:
            self._emit()

    def finish(self):
        self.known = list(self.done)
        self.future = [0.0, 0.0]
        self.future_zooms = 0
        self._emit()

    def _eta(self, now: float, left: list[float]) -> float | None:
        """Seconds left for ``left`` (heavy, light) tiles, or None before any measure."""
        n, sec = self._heavy(now)
        if self.zooms:
            a = min(t for _, t in self.zooms)
            last_n, last_t = self.zooms[-1]
            b = (last_t - a) / last_n if last_n else 0.0
            if self.mark is not None and n - self.mark[0] > last_n:
                b = (sec - self.mark[1] - a) / (n - self.mark[0])  # this zoom is larger
            b = max(b, a / _ZOOM_TILES)
        elif n > 0 and self.zlo == self.zhi:
            a, b = 0.0, sec / n  # one zoom: its rate so far
        else:
            return None  # within the first zoom
        worked_light = self.done[1] - self.skipped[1]
        light = self.light_s / worked_light if worked_light else b * _LIGHT_PRIOR
        return a * self.future_zooms + b * left[0] + light * left[1]

    def start_tasks(self, n: int):
        """The split is made: ``n`` tasks (run elsewhere) bring the tiles left."""
        self.tasks = {"n": n, "done": 0, "t0": time.perf_counter(), "heavy": 0, "light": 0}
        self._emit()

    def task_done(self, heavy: int, light: int, skipped: int):
        """A task ended with ``heavy`` rendered or outlined tiles, ``light`` inside ones
        and ``skipped`` already present (counted as done, as in one process)."""
        t = self.tasks
        assert t is not None  # after start_tasks
        t["done"] += 1
        t["heavy"] += heavy
        t["light"] += light + skipped
        self.done[0] += heavy
        self.done[1] += light + skipped
        self.skipped[1] += skipped
        self._emit()

    def _task_left(self, now: float):
        """Tiles left (heavy, light) and the ETA while tasks run: the tasks left at the
        mean tiles of those ended, and the time per heavy tile the tasks took so far
        (the split's estimates, and no ETA, until a task has ended); at least one tile
        per task left, so that the total is reached at the end only."""
        t = self.tasks
        assert t is not None  # after start_tasks
        n_left = t["n"] - t["done"]
        if t["done"] == 0:
            left = [max(0.0, self.known[i] + self.future[i] - self.done[i]) for i in (0, 1)]
            left[0] = max(left[0], float(n_left))
            return left, None
        left = [n_left * t["heavy"] / t["done"], n_left * t["light"] / t["done"]]
        left[0] = max(left[0], float(n_left))
        if n_left == 0:
            return [0.0, 0.0], 0.0
        work = max(t["heavy"], t["done"])
        return left, (now - t["t0"]) * max(left[0], n_left) / work

    def _emit(self):
        if self.progress is None:
            return
        done = self.done[0] + self.done[1]
        now = time.perf_counter()
        if self.tasks is not None:
            left, eta = self._task_left(now)
        else:
            left = [max(0.0, self.known[i] + self.future[i] - self.done[i]) for i in (0, 1)]
        total = done + math.ceil(left[0] + left[1])
        if total == done and self.last is not None and self.last.done == self.last.total:
            return  # the end, already reported
        if self.tasks is None or total == done:
            eta = 0.0 if total == done else self._eta(now, left)
        self.last = TileProgress(self.zoom, done, total, now - self.t0, eta)
        self.progress(self.last)
