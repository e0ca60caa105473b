"""The entry level's (cell, arc) pairs on the GL context (``shaders/scatter_pairs.comp``).

:func:`gloffset.raster.vector.scatter.scatter` enters a fine level with every cell of each
arc's box (rows and columns of the arc's lon/lat box) and the cap test ``c.m >= threshold``.
This pass does the box enumeration and ``c.m`` in a compute shader, one invocation per box
(per :data:`CHUNK` of its cells),
and returns the pairs whose ``c.m`` reaches the arc's lowest threshold: a superset of those
the exact test keeps. Those below the arc's highest threshold are marked :data:`UNSURE`:
the host takes the exact test on them alone.

Accuracy: ``c.m`` is the same float64 expression as the host's, products and sums each
rounded once (``precise``: no fused multiply-add), so it has the host's bits where the
device's float64 ``+`` and ``*`` are IEEE (llvmpipe, NVIDIA; ``tests/test_scatter_gpu.py``
checks the bits). Pairs come back in no set order; the caller sorts them.
"""

from __future__ import annotations

import numpy as np

from ..errors import GLContextError
from .context import context_info, get_context, shared
from .shaders import load_source

__all__ = ["CROSS", "UNSURE", "ScatterPass", "scatter_pass"]

_LOCAL = 64
#: Most box cells one invocation takes: llvmpipe ends a loop after 65535 iterations (and
#: the shader loops twice over its cells).
CHUNK = 4096
#: The bit of a returned arc that marks ``lo <= cm < hi`` (the exact test is the host's).
UNSURE = 1 << 31
#: The bit of a returned arc that marks a ring edge crossing the short arc from the cell's
#: centre to its predecessor's (with ``ring_arcs``).
CROSS = 1 << 30


class ScatterPass:
    """The compiled compute program and :meth:`run` (one per GL thread)."""

    def __init__(self):
        self.ctx = get_context()
        self.max_bytes = context_info()["max_storage_block_size"]
        src, _ = load_source("scatter_pairs.comp")
        self.prog = self.ctx.compute_shader(src)

    def fits(self, pairs: int, boxes: int) -> bool:
        """Whether ``pairs`` box cells and ``boxes`` boxes fit the storage buffers."""
        chunks = boxes + pairs // CHUNK
        return 8 * pairs <= self.max_bytes and 16 * chunks <= self.max_bytes and pairs < UNSURE

    def fits_arcs(self, arcs: int) -> bool:
        """Whether ``arcs`` arcs' rows fit a storage buffer and their indices the flags."""
        return 160 * arcs <= self.max_bytes and arcs < CROSS

    def run(self, boxes, box_arc, arcs, hi, rows, cols, width: int, pairs: int, ring_arcs=None):
        """``(cell, arc, cm)`` of the box cells whose ``cm >= lo`` (any order).

        ``boxes`` (n, 4) int ``j0, j1, i0, i1`` (non-empty); ``box_arc`` (n,) the arc of
        each box;
        ``arcs`` (m, 4) float64 cap centre and ``lo``, ``hi`` (m,) float64; ``rows`` (h, 2)
        cos and sin of the row latitudes, ``cols`` (w, 2) of the column longitudes;
        ``pairs`` the number of box cells (the output's capacity). Returns uint32 cells
        and arcs (with :data:`UNSURE` set where ``cm < hi``), float64 ``cm``.
        ``ring_arcs``: the arcs' rows (:attr:`gloffset.edges.CurveArcs.rows`, the last
        column nonzero for ring edges) as an array or a GL buffer; with them, a ring
        edge's pair gets :data:`CROSS` where the edge crosses the short arc from the
        cell's centre to its predecessor's (``arcs_cross``, the same booleans).
        """
        ctx = self.ctx
        cap = max(int(pairs), 1)
        boxes = np.asarray(boxes, dtype=np.int64).reshape(-1, 4)
        nc = boxes[:, 3] - boxes[:, 2]
        count = (boxes[:, 1] - boxes[:, 0]) * nc
        # each box in chunks of at most CHUNK cells
        per = -(-count // CHUNK)
        box = np.repeat(np.arange(len(count)), per)
        start = (np.arange(len(box)) - np.repeat(np.cumsum(per) - per, per)) * CHUNK
        chunks = np.column_stack([box, start, np.minimum(count[box] - start, CHUNK), box])
        box_rows = np.column_stack([boxes[:, 0], boxes[:, 2], nc, box_arc])

        def buf(a, t):  # read in place where it is already contiguous and of type t
            a = np.ascontiguousarray(a, dtype=t)
            return ctx.buffer(a if a.size else bytes(16))

        bufs = [
            buf(box_rows, np.int32),
            buf(chunks, np.int32),
            buf(arcs, np.float64),
            buf(rows, np.float64),
            buf(cols, np.float64),
            ctx.buffer(reserve=8 * cap),
            ctx.buffer(reserve=8 * cap),
            ctx.buffer(bytes(4)),
            buf(hi, np.float64),
        ]
        if ring_arcs is None or isinstance(ring_arcs, np.ndarray):
            bufs.append(buf(np.zeros(20) if ring_arcs is None else ring_arcs, np.float64))
            ring_buf = bufs[-1]
        else:
            ring_buf = ring_arcs  # the caller's
        try:
            ring_buf.bind_to_storage_buffer(9)
            self.prog["u_cross"] = ring_arcs is not None
            for k, b in enumerate(bufs):
                b.bind_to_storage_buffer(k)
            self.prog["u_chunks"] = len(chunks)
            self.prog["u_width"] = int(width)
            self.prog["u_capacity"] = cap
            self.prog.run(group_x=max(1, -(-len(chunks) // _LOCAL)))
            ctx.memory_barrier()  # the shader's writes, before they are read back
            n = int(np.frombuffer(bufs[7].read(), dtype=np.uint32)[0])
            if n > cap:  # cannot happen: the kept pairs are box cells
                raise GLContextError(f"scatter pass: {n} pairs exceed the {cap} box cells")
            pair = np.zeros((0, 2), dtype=np.uint32)
            cm = np.zeros(0)
            if n:
                pair = np.frombuffer(bufs[5].read(size=8 * n), dtype=np.uint32).reshape(n, 2)
                cm = np.frombuffer(bufs[6].read(size=8 * n), dtype=np.float64)
        finally:
            for b in bufs:
                b.release()
        return pair[:, 0], pair[:, 1], cm


def scatter_pass() -> ScatterPass:
    """This thread's :class:`ScatterPass` (made on first use, with the GL context)."""
    return shared(ScatterPass)
