"""Storage buffers kept by binding from one run of a compute pass to the next.

A pass binds the same slots on every run; remaking its buffers each time costs an
allocation and, on a hardware GL, a mapping per buffer. :class:`SlotBuffers` keeps one
buffer per binding, grows it where a run needs more, and releases those larger than its
bound after a run (:meth:`SlotBuffers.trim`), so a large input does not pin its memory.
"""

from __future__ import annotations

from typing import Any

__all__ = ["SlotBuffers"]


class SlotBuffers:
    """One kept storage buffer per binding of a GL context's compute pass.

    Parameters
    ----------
    ctx : moderngl.Context
        The context the buffers belong to (used on its own thread only).
    keep_bytes : int
        Buffers larger than this are released by :meth:`trim`.
    """

    def __init__(self, ctx, keep_bytes: int) -> None:
        self.ctx = ctx
        self.keep_bytes = keep_bytes
        #: the buffers kept for the next run, by binding
        self.kept: dict[int, Any] = {}

    def bind(self, slot: int, data=None, reserve: int = 0):
        """The kept buffer of ``slot`` holding ``data`` (or room for ``reserve`` bytes),
        made anew where the kept one is too small; bound to ``slot``."""
        nbytes = reserve if data is None else data.nbytes
        buf = self.kept.get(slot)
        if buf is None or buf.size < nbytes:
            if buf is not None:
                buf.release()
            buf = self.kept[slot] = self.ctx.buffer(reserve=max(nbytes, 16))
        if data is not None and data.size:
            buf.write(data)
        buf.bind_to_storage_buffer(slot)
        return buf

    def trim(self) -> None:
        """Release the kept buffers larger than ``keep_bytes``."""
        for slot, buf in list(self.kept.items()):
            if buf.size > self.keep_bytes:
                buf.release()
                del self.kept[slot]
