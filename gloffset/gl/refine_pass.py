"""A refined level's children and their candidate pairs on the GL context
(``shaders/refine_pairs.comp``).

:func:`gloffset.raster.vector.levels.refine` gives each child its parent's candidate arcs
whose cap comes within ``first`` (``e + rho``) of the child's centre, with their ``c.m``,
toggles the child's status by the ring edges that cross the short arc to its parent's
centre, and asks which parents' centres lie on a ring edge. This pass does that per-pair
work in a compute shader, one invocation per chunk of :data:`CHUNK` pairs of a parent (so
that the invocations run alike), in two dispatches: the first counts each chunk's pairs
per child and lists the crossings and the pairs of a parent centre near a ring edge's
great circle, the second writes each chunk's pairs from their first places on (the host's
sums of the counts), so each child's in its parent's order.

The cap tests' thresholds (``cos f cos h - sin f sin h``, from the host's float64 cosines
and sines) are within 1e-14 of the host's ``cos(f + h)``: a pair within a margin (1e-9) of
one is marked (:data:`UNSURE`, :data:`NEAR_UNSURE`) and the host takes the exact test on it.
``c.m``, the crossing tests and the on-edge dot products are the host's float64
expressions, products and sums each rounded once (``precise``: no fused multiply-add), so
they have the host's bits where the device's float64 ``+`` and ``*`` are IEEE (llvmpipe,
NVIDIA; ``tests/test_refine_gpu.py`` checks the pairs, ``c.m`` and statuses against numpy).
"""

from __future__ import annotations

import numpy as np

from ..errors import GLContextError
from .context import context_info, get_context, shared
from .shaders import load_source
from .storage import SlotBuffers

__all__ = ["NEAR_UNSURE", "UNSURE", "ARC_MASK", "RefinePass", "refine_pass"]

_LOCAL = 64
#: Parent pairs per invocation.
CHUNK = 16
_MAX_GROUPS = 65535  # work groups per dispatch dimension (the GL minimum of the limit)
#: The bit of a returned arc whose cap test is the host's.
UNSURE = 1 << 31
#: The bit of a listed crossing whose cap test (of the child's distance to its parent's
#: centre) is the host's.
NEAR_UNSURE = 1 << 30
#: The arc's index in a returned arc (the bits below the flags).
ARC_MASK = NEAR_UNSURE - 1
#: Room for listed crossings and on-edge pairs: at least this many, and one per 16 (one per
#: 64) parent pairs (a level that lists more is numpy's).
TOGGLE_ROOM = 4096
#: Largest buffer (bytes) the pass keeps for its next run.
KEEP_BYTES = 1 << 27


class RefinePass:
    """The two compiled compute programs and :meth:`run` (one per GL thread)."""

    def __init__(self):
        self.ctx = get_context()
        self.max_bytes = context_info()["max_storage_block_size"]
        self.progs = {
            key: self.ctx.compute_shader(load_source("refine_pairs.comp", defines)[0])
            for key, defines in (("count", {"COUNT": 1}), ("write", None))
        }
        #: the storage buffers kept for the next run, by binding
        self.buffers = SlotBuffers(self.ctx, KEEP_BYTES)

    def fits(self, parents: int, pairs: int, children: int, arcs: int) -> bool:
        """Whether a level of ``parents`` cells with ``pairs`` pairs and ``children``
        children, of ``arcs`` arcs, fits the buffers (every output pair is one of four
        children's of a parent pair; a chunk takes 16 bytes)."""
        return (
            4 * 8 * max(pairs, 1) <= self.max_bytes
            and 16 * (max(pairs, 1) + parents) <= self.max_bytes
            and 96 * max(children, 1) <= self.max_bytes
            and 160 * max(arcs, 1) <= self.max_bytes
            and arcs <= ARC_MASK
            and 4 * pairs < 1 << 31
        )

    def _run(self, key: str, chunks: int) -> None:
        groups = max(1, -(-chunks // _LOCAL))
        gy = -(-groups // _MAX_GROUPS)
        self.progs[key]["u_chunks"] = chunks
        self.progs[key].run(group_x=-(-groups // gy), group_y=gy)
        self.ctx.memory_barrier()

    def run(self, starts, pair_arc, slot, children, parents, terms, rows):
        """The children's pairs, or None where a list outgrew its buffer.

        ``starts`` (k + 1) the parents' first pairs (``pair_arc`` grouped by parent, each
        parent's at most 2^31);
        ``slot`` (k, 4) each parent's children (-1 where none); ``children`` (n, 12)
        float64 ``c.x, c.y, c.z, first, cos first, sin first, cos seg, sin seg, seg`` and
        three zeros; ``parents`` (k, 4) the parents' centres and a zero; ``terms`` the
        arcs' ``cos h, sin h, h, 0`` and ``rows`` their
        :attr:`~gloffset.edges.CurveArcs.rows` (arrays or GL buffers).

        Returns ``(counts, arc, cm, toggles, on)``: each child's number of pairs, their
        arcs (uint32, :data:`UNSURE` where the host decides) and ``cm`` grouped by child,
        each child's in its parent's order; the crossings ``(child, arc)`` (uint32,
        :data:`NEAR_UNSURE` in the arc where the host decides the cap test); the pairs
        ``(parent, arc)`` of a ring edge whose great circle passes within ``ON_EDGE`` of
        the parent's centre.
        """
        k, n, npair = len(slot), len(children), len(pair_arc)
        toggle_cap = max(TOGGLE_ROOM, npair // 16) if TOGGLE_ROOM else 0
        on_cap = max(TOGGLE_ROOM // 4, npair // 64) if TOGGLE_ROOM else 0
        starts = np.asarray(starts, dtype=np.int64)
        runs = np.diff(starts)
        per = -(-runs // CHUNK)  # chunks of each parent
        nch = int(per.sum())
        chunk_parent = np.repeat(np.arange(k), per)
        first_chunk = np.cumsum(per) - per
        chunks = np.zeros((nch, 4), dtype=np.int32)
        chunks[:, 0] = chunk_parent
        within = np.arange(nch) - first_chunk[chunk_parent]
        first_pair = starts[:-1][chunk_parent] + CHUNK * within
        chunks[:, 1] = first_pair
        chunks[:, 2] = np.minimum(starts[1:][chunk_parent] - first_pair, CHUNK)
        self.buffers.bind(0, chunks)
        self.buffers.bind(1, np.ascontiguousarray(pair_arc, dtype=np.int32))
        self.buffers.bind(2, np.ascontiguousarray(slot, dtype=np.int32))
        self.buffers.bind(3, np.ascontiguousarray(children, dtype=np.float64))
        self.buffers.bind(4, np.ascontiguousarray(parents, dtype=np.float64))
        for at, given in ((5, terms), (6, rows)):
            if isinstance(given, np.ndarray):
                self.buffers.bind(at, np.ascontiguousarray(given, dtype=np.float64))
            else:
                given.bind_to_storage_buffer(at)
        counts_buf = self.buffers.bind(7, reserve=16 * nch)
        toggles = self.buffers.bind(11, reserve=8 * max(toggle_cap, 1))
        on = self.buffers.bind(12, reserve=8 * max(on_cap, 1))
        lists = self.buffers.bind(13, np.zeros(4, dtype=np.uint32))
        for at in (8, 9, 10):  # the second dispatch's, bound before the first too
            self.buffers.bind(at, reserve=16)
        try:
            count = self.progs["count"]
            count["u_toggle_capacity"] = toggle_cap
            count["u_on_capacity"] = on_cap
            self._run("count", nch)
            nt, non = (int(x) for x in np.frombuffer(lists.read(size=8), dtype=np.uint32))
            if nt > toggle_cap or non > on_cap:
                return None
            got = np.frombuffer(counts_buf.read(size=16 * nch), dtype=np.uint32) if nch else None
            per_chunk = np.zeros((nch, 4), np.int64) if got is None else got.reshape(nch, 4)
            # each chunk's place among its parent's: the sums of the chunks before it
            before = np.zeros((nch + 1, 4), dtype=np.int64)
            np.cumsum(per_chunk, axis=0, out=before[1:])
            base = before[first_chunk]  # (k, 4): the parents' first chunks
            counts = np.zeros(n, dtype=np.int64)
            slot = np.asarray(slot)
            has = slot >= 0
            counts[slot[has]] = (before[first_chunk + per] - base)[has]
            total = int(counts.sum())
            if total > 4 * npair:  # cannot happen: a child's pairs are its parent's
                raise GLContextError(f"refine pass: {total} pairs from {npair} parent pairs")
            first = np.cumsum(counts) - counts
            child_first = np.where(has, first[np.where(has, slot, 0)], 0)  # (k, 4)
            out_first = before[:-1] - base[chunk_parent] + child_first[chunk_parent]
            self.buffers.bind(8, out_first.astype(np.uint32))
            out_arc = self.buffers.bind(9, reserve=4 * total)
            out_cm = self.buffers.bind(10, reserve=8 * total)
            self._run("write", nch)

            def read(buf, n, dtype, width=1):
                """``n`` rows read straight into a new array (no bytes object between)."""
                out = np.empty((n, width) if width > 1 else n, dtype=dtype)
                if n:
                    buf.read_into(out, size=out.nbytes)
                return out

            arc = read(out_arc, total, np.uint32)
            cm = read(out_cm, total, np.float64)
            tog = read(toggles, nt, np.uint32, 2)
            ons = read(on, non, np.uint32, 2)
        finally:
            self.buffers.trim()
        return counts, arc, cm, tog, ons


def refine_pass() -> RefinePass:
    """This thread's :class:`RefinePass` (made on first use, with the GL context)."""
    return shared(RefinePass)
