"""The entry level's (cell, arc) pairs on the GL context (``shaders/scatter_pairs.comp``).

:func:`gloffset.raster.vector.scatter.scatter` enters a fine level with every cell of each
arc's box (rows and columns of the arc's lon/lat box) and the cap test ``c.m >= threshold``.
This pass does the box enumeration, ``c.m`` and the cap test of the cell's row in a compute
shader, one invocation per box (per :data:`CHUNK` of its cells), and returns the pairs that
do not fail it. The shader's threshold (``cos(reach) cos(h) - sin(reach) sin(h)``, from the
host's cosines and sines) is within 1e-14 of the host's ``cos(reach + h)``: a pair within a
margin (1e-9) of it is marked :data:`UNSURE`, and the host takes the exact test on those
alone. With a second reach per row (``near``), the same for that reach's test:
:data:`NEAR` where it passes, :data:`NEAR_UNSURE` where the host decides.

Accuracy: ``c.m`` is the same float64 expression as the host's, products and sums each
rounded once (``precise``: no fused multiply-add), so it has the host's bits where the
device's float64 ``+`` and ``*`` are IEEE (llvmpipe, NVIDIA; ``tests/test_scatter_gpu.py``
checks the bits). Pairs come back in no set order; the caller sorts them.

The pass keeps its storage buffers from run to run (written in place where they are large
enough): a fresh buffer costs its pages again (about 7 ms for 13 MB on llvmpipe).
"""

from __future__ import annotations

import numpy as np

from ..errors import GLContextError
from .context import context_info, get_context, shared
from .shaders import load_source
from .storage import SlotBuffers

__all__ = ["ARC_MASK", "CROSS", "NEAR", "NEAR_UNSURE", "UNSURE", "ScatterPass", "scatter_pass"]

_LOCAL = 64
#: Most box cells one invocation takes: llvmpipe ends a loop after 65535 iterations (and
#: the shader loops twice over its cells).
CHUNK = 4096
#: The bit of a returned arc that marks a pair near the threshold of its row's cap test
#: (the exact test is the host's).
UNSURE = 1 << 31
#: The bit of a returned arc that marks a ring edge crossing the short arc from the cell's
#: centre to its predecessor's (with ``cross``).
CROSS = 1 << 30
#: The bit of a returned arc that marks a pair passing the cap test of the row's second
#: reach (with ``near``).
NEAR = 1 << 29
#: The bit of a returned arc that marks a pair near the threshold of that second test.
NEAR_UNSURE = 1 << 28
#: The arc's index in a returned arc (the bits below the flags).
ARC_MASK = NEAR_UNSURE - 1
#: Largest buffer (bytes) the pass keeps for its next run.
KEEP_BYTES = 1 << 26


class ScatterPass:
    """The compiled compute program and :meth:`run` (one per GL thread)."""

    def __init__(self):
        self.ctx = get_context()
        self.max_bytes = context_info()["max_storage_block_size"]
        src, _ = load_source("scatter_pairs.comp")
        self.prog = self.ctx.compute_shader(src)
        #: the storage buffers kept for the next run, by binding
        self.buffers = SlotBuffers(self.ctx, KEEP_BYTES)

    def fits(self, pairs: int, boxes: int) -> bool:
        """Whether ``pairs`` box cells and ``boxes`` boxes fit the storage buffers."""
        chunks = boxes + pairs // CHUNK
        return 8 * pairs <= self.max_bytes and 16 * chunks <= self.max_bytes and pairs < UNSURE

    def fits_arcs(self, arcs: int) -> bool:
        """Whether ``arcs`` arcs' rows fit a storage buffer and their indices the flags."""
        return 160 * arcs <= self.max_bytes and arcs <= ARC_MASK

    def run(
        self,
        boxes,
        box_arc,
        arc_terms,
        rows,
        cols,
        width: int,
        pairs: int,
        ring_arcs,
        *,
        cross: bool = True,
        near: bool = False,
    ):
        """``(cell, arc, cm)`` of the box cells that do not fail their row's cap test
        (any order).

        ``boxes`` (n, 4) int ``j0, j1, i0, i1`` (non-empty); ``box_arc`` (n,) the arc of
        each box; ``arc_terms`` (m, 4) float64 ``cos h, sin h, h, f`` of each arc's cap
        radius ``h``, ``f`` 1 where all its tests are the host's (``h`` plus a reach near
        pi: ``cap_within`` clamps there), else 0 (an array or a GL buffer); ``rows`` (h,
        8) float64 per row: ``cos`` and ``sin`` of the latitude, the reach, the second
        reach, then ``cos`` and ``sin`` of each reach; ``cols`` (w, 2) ``cos`` and ``sin``
        of the column longitudes;
        ``pairs`` the number of box cells (the output's capacity); ``ring_arcs`` the arcs'
        rows (:attr:`gloffset.edges.CurveArcs.rows`: the cap centres, the last column
        nonzero for ring edges) as an array or a GL buffer. The test of a row: ``cm >=
        cos(min(reach + h, pi)) - COS_SLACK`` (:func:`gloffset.geometry.caps.cap_within`).

        Returns uint32 cells and arcs, float64 ``cm``; an arc has :data:`UNSURE` set where
        the host takes the test; with ``cross``, :data:`CROSS` where a ring edge crosses the
        short arc from the cell's centre to its predecessor's (``arcs_cross``, the same
        booleans); with ``near``, :data:`NEAR` where the pair passes the test of the
        second reach, :data:`NEAR_UNSURE` where the host takes it.
        """
        cap = max(int(pairs), 1)
        boxes = np.asarray(boxes, dtype=np.int64).reshape(-1, 4)
        nc = boxes[:, 3] - boxes[:, 2]
        count = (boxes[:, 1] - boxes[:, 0]) * nc
        # each box in chunks of at most CHUNK cells: (box, start, count, box)
        per = -(-count // CHUNK)
        chunks = np.empty((int(per.sum()), 4), dtype=np.int32)
        box = np.repeat(np.arange(len(count), dtype=np.int32), per)
        start = np.arange(len(box), dtype=np.int64) - np.repeat(np.cumsum(per) - per, per)
        start *= CHUNK
        chunks[:, 0] = box
        chunks[:, 1] = start
        chunks[:, 2] = np.minimum(count[box] - start, CHUNK)
        chunks[:, 3] = box
        box_rows = np.empty((len(boxes), 4), dtype=np.int32)
        box_rows[:, 0] = boxes[:, 0]
        box_rows[:, 1] = boxes[:, 2]
        box_rows[:, 2] = nc
        box_rows[:, 3] = box_arc

        def f64(a):
            return np.ascontiguousarray(a, dtype=np.float64)

        self.buffers.bind(0, box_rows)
        self.buffers.bind(1, chunks)
        for slot, given in ((2, arc_terms), (9, ring_arcs)):
            if isinstance(given, np.ndarray):
                self.buffers.bind(slot, f64(given))
            else:
                given.bind_to_storage_buffer(slot)
        self.buffers.bind(3, f64(rows))
        self.buffers.bind(4, f64(cols))
        out_pairs = self.buffers.bind(5, reserve=8 * cap)
        out_cm = self.buffers.bind(6, reserve=8 * cap)
        counter = self.buffers.bind(7, np.zeros(4, dtype=np.uint32))
        try:
            self.prog["u_cross"] = bool(cross)
            self.prog["u_near"] = bool(near)
            self.prog["u_chunks"] = len(chunks)
            self.prog["u_width"] = int(width)
            self.prog["u_capacity"] = cap
            self.prog.run(group_x=max(1, -(-len(chunks) // _LOCAL)))
            self.ctx.memory_barrier()  # the shader's writes, before they are read back
            n = int(np.frombuffer(counter.read(size=4), dtype=np.uint32)[0])
            if n > cap:  # cannot happen: the kept pairs are box cells
                raise GLContextError(f"scatter pass: {n} pairs exceed the {cap} box cells")
            pair = np.zeros((0, 2), dtype=np.uint32)
            cm = np.zeros(0)
            if n:
                pair = np.frombuffer(out_pairs.read(size=8 * n), dtype=np.uint32).reshape(n, 2)
                cm = np.frombuffer(out_cm.read(size=8 * n), dtype=np.float64)
        finally:
            self.buffers.trim()
        return pair[:, 0], pair[:, 1], cm


def scatter_pass() -> ScatterPass:
    """This thread's :class:`ScatterPass` (made on first use, with the GL context)."""
    return shared(ScatterPass)
