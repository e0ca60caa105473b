"""The render thread's queue of the tile service (:class:`RenderQueue`): at most so many
requests, taken a group at a time (the requests one batched render or one field answers),
the most pressing group first: a tile of a view asked for before at another distance (a
distance slider moves) goes before the tiles of new views, which wait at most :data:`AGE`
seconds behind such tiles, then are served in turn. Each request's future is a :class:`Job`,
which says when it was queued and when the render thread took it: the ``Server-Timing``
header of the answer (:func:`server_timing`)."""

from __future__ import annotations

import threading
import time
from concurrent.futures import Future

__all__ = ["AGE", "Job", "RenderQueue", "server_timing"]

#: seconds a request of a new view waits, at most, behind the tiles of views seen before
#: (:class:`_Pending`): then it goes first too (no view starves). Short, so that a saturated
#: server serves in turn (fair) and the seen views go first while waits are short, where a
#: slider's target of tens of milliseconds is within reach
AGE = 0.25


class Job(Future):
    """The future of a render-queue request, with when it was queued and when the render
    thread took it (:func:`time.monotonic` seconds; ``began`` None until then): what the
    ``Server-Timing`` header reports (the wait in the queue, then the work)."""

    def __init__(self) -> None:
        super().__init__()
        self.queued = time.monotonic()
        self.began: float | None = None


class RenderQueue:
    """The render thread's queue: at most ``maxsize`` requests, taken a group at a time
    (``group(item)``: equal for the requests run together), the most pressing group first:
    one with an urgent request (a tile of a view seen before, as a distance slider asks) or
    with a request that waited :data:`AGE` seconds, before the others; among equals the
    group of the oldest request. So the tiles of a slider's view wait for the group being
    run and the other slider tiles, not behind the new views' renders, and no request
    waits for ever."""

    def __init__(self, maxsize: int, group):
        self.maxsize, self.group = maxsize, group
        self.items: list = []  # [group, urgent, queued at, item, future], oldest first
        self.cond = threading.Condition()

    def put(self, item, fut: Future, urgent: bool = False) -> bool:
        """Queue ``item``; False, and nothing queued, when the queue is full."""
        with self.cond:
            if len(self.items) >= self.maxsize:
                return False
            self.items.append((self.group(item), urgent, time.monotonic(), item, fut))
            self.cond.notify()
            return True

    def take(self) -> list:
        """The ``(item, future)`` pairs of the most pressing group, taken off the queue
        (waits for a request)."""
        with self.cond:
            while not self.items:
                self.cond.wait()
            late = time.monotonic() - AGE
            first = min(self.items, key=lambda e: (not (e[1] or e[2] <= late), e[2]))
            taken = [e for e in self.items if e[0] == first[0]]
            self.items = [e for e in self.items if e[0] != first[0]]
            return [(e[3], e[4]) for e in taken]

    def qsize(self) -> int:
        with self.cond:
            return len(self.items)

    def empty(self) -> bool:
        return not self.qsize()


def server_timing(fut, why: str | None = None) -> str:
    """The ``Server-Timing`` header of an answer made on the render thread (``fut``, a
    :class:`Job`): ``queue`` the milliseconds it waited for the
    render thread, ``render`` those from then to the answer (its group's render, or field),
    and ``why`` a tile was rendered (:meth:`~gloffset.serve.service.TileService.why_rendered`).
    Empty for an answer that was cached by then."""
    if not isinstance(fut, Job) or fut.began is None:
        return ""
    now = time.monotonic()
    parts = [f"queue;dur={1e3 * (fut.began - fut.queued):.1f}"]
    parts.append(f"render;dur={1e3 * (now - fut.began):.1f}")
    if why is not None:
        parts.append(f'why;desc="{why}"')
    return ", ".join(parts)
