"""The arcs' float64 rows in a GL storage buffer, uploaded once per set of arcs and thread.

The compute passes that read the arcs (:mod:`gloffset.gl.scatter_pass`'s crossings,
:mod:`gloffset.gl.records_pass`'s records) bind the same buffer: a render uploads the
arcs once, and a shape rendered again (at another distance, another grid) not again.
The buffers of the last :data:`KEEP` arrays are kept, each while its array lives.
"""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from .context import get_context, shared

__all__ = ["KEEP", "arc_buffer"]

#: Arrays of arcs whose buffers a thread keeps (a set of arcs has two: its rows and the
#: terms of its cap radii, :func:`gloffset.raster.gpu.gpu_box_pairs`'s).
KEEP = 4


class ArcBuffers:
    """This thread's buffers of arc rows, by array (the newest first)."""

    def __init__(self):
        self.ctx = get_context()
        self.kept: list[tuple[weakref.ref, Any]] = []

    def get(self, rows: np.ndarray):
        live = []
        for ref, buf in self.kept:
            if ref() is None:
                buf.release()
            else:
                live.append((ref, buf))
        self.kept = live
        for ref, buf in live:
            if ref() is rows:
                return buf
        data = np.ascontiguousarray(rows, dtype=np.float64)
        buf = self.ctx.buffer(data if rows.size else bytes(16))
        self.kept.insert(0, (weakref.ref(rows), buf))
        for _, old in self.kept[KEEP:]:
            old.release()
        del self.kept[KEEP:]
        return buf


def arc_buffer(rows: np.ndarray):
    """The GL buffer (``moderngl.Buffer``, owned here: never release it) of ``rows``, a
    read-only array such as :attr:`gloffset.edges.CurveArcs.rows`, on this thread's
    context: uploaded on first use, then kept while ``rows`` lives (the last
    :data:`KEEP` arrays)."""
    return shared(ArcBuffers).get(rows)
