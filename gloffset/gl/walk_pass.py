"""A distance field's walk on the GL context, level by level (``shaders/field_walk.comp``).

Each cell's list of multiresolution nodes is its parent's pruned and split in float32 by
the rule of :func:`gloffset.raster.fields.walk._bound` (the bisector test against the
nearest boundary vertex of the nodes measured), every bound widened: each list is a
superset of the float64 rule's (one walk per cell, written in chunks: :class:`WalkPass`).
Inputs are float64 unit vectors rounded once to float32 (off by at most u = 2^-24 in
norm); radii (``reach``, ``err``, the cells' reach, ``m``) are rounded up. The bounds:

* a chord ``|c - p|`` is off by 2u from its inputs and 8u relative from its rounding
  (differences, squares, sum: 4u; a square root two ulp off: 4u): :data:`CH_ABS` +
  :data:`CH_REL` times the chord (margins 2 and 8); ``2 asin(ch / 2)`` is monotone, so
  the chord is moved by that bound first (never ``acos`` of a dot near 1);
* ``asin_f`` (Cephes' ``asinf``: a minimax polynomial on [0, 1/2], the half-angle formula
  above, whose float32 square root GLSL allows 4.5 ulp) is within 5e-7 relative of
  ``asin`` (measured on every scale by ``tests/test_field_walk_gpu.py``); the angles are
  moved by :data:`ASIN_REL` (4e-6, a margin of 8) and up by ``CH_ABS``;
* ``c.n`` and ``c.(n x a)``, ``c.(b x n)`` (the cross products in float32) are off by 2u
  (inputs), 6u (the cross product) and 3u (the sum): 11u = 6.6e-7 < :data:`DOT_ERR`
  (2e-6). A foot is on the arc where both tests exceed ``DOT_ERR``, off it (an end is
  nearest) where one is below ``-DOT_ERR``; else the distance to the arc lies between
  that to its great circle and that to its nearest end;
* the bounds, ``best + 2 reach`` and ``m + reach`` are one float32 sum each of values
  below 16 (half an ulp: 9.5e-7): :data:`SUM_ERR` (4e-6) covers the four;
* the bisector test: see :data:`BIS_ABS`; the dominance test (``dominated`` in the
  shader; :mod:`gloffset.raster.fields.dominance`): see :meth:`WalkPass.run`.

The float64 rule's own rounding (1e-14) is far below these margins. The slack is about
4e-6 rad (25 m) absolute: cells much smaller get longer lists, never shorter.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from .context import context_info, get_context, shared
from .shaders import load_source

__all__ = [
    "ASIN_REL",
    "BISECTOR",
    "BIS_ABS",
    "BIS_REL",
    "CH_ABS",
    "CH_REL",
    "DOT_ERR",
    "SUM_ERR",
    "WalkPass",
    "walk_pass",
]

CH_REL, CH_ABS = 1e-6, 2.5e-7
ASIN_REL = 4e-6
DOT_ERR = 2e-6
SUM_ERR = 4e-6
#: The bisector test's bounds. Its least ``q.v`` over the disc, ``v = vtx - cos r mid``,
#: is computed as ``(c.v) cos R - |c x v| sin R`` with ``v = w + k mid``, ``w = vtx - mid``
#: (float32), ``k = 1 - cos r`` (from float64): no cancellation of nearly equal cosines.
#: ``c.v`` is off by 2u (inputs) + 6u |w| + 8u k, ``|c x v|`` by 2u + 16u |w| + 14u k, the
#: products with ``cos R``, ``sin R`` and the difference add 10u (|w| + k): at most
#: 4u + 32u (|w| + k) = 2.4e-7 + 1.9e-6 (|w| + k), against BIS_ABS + BIS_REL (|w| + k)
#: (margins 8 and 5). ``S >= sin(min(t + R, pi/2))`` from the chord to ``mid`` rounded up
#: (``sin t = ch sqrt(1 - ch^2 / 4)``, ``cos t = 1 - ch^2 / 2``, the sum formulas: off by
#: 1e-6 at most) is raised by BIS_ABS, 1 unless ``cos(t + R)`` exceeds BIS_ABS; the right
#: side, ``sin r`` rounded up, by the factor ``1 + BIS_ABS``. Below 1e-6 or so (cells of a
#: few hundred metres) the test can prune nothing: the lists are then the rule's without it.
BIS_ABS, BIS_REL = 2e-6, 1e-5
#: Whether the lists are shortened by the bisector test (as the float64 walk's are).
BISECTOR = True
_LOCAL = 64
#: Node tables whose buffers a :class:`WalkPass` keeps (the oldest dropped first).
KEEP_TABLES = 2
#: Slots of a pool at least (4 bytes each): a pool too small costs a second run.
MIN_POOL = 1 << 21
#: Bits of the shader's flags: the pool was too small; a stack or loop limit was hit.
FLAG_POOL, FLAG_LIMIT = 1, 2
#: Slots of a chunk of a level's pool: ``CHUNK - 1`` node ids, then the start of the
#: list's next chunk (``shaders/field_walk.comp``'s ``CHUNK``).
CHUNK = 16
#: The chunk size that says the parents' lists are contiguous (the first level's).
CONTIGUOUS = 0xFFFFFFFF


@dataclass
class WalkLevel:
    """One level for :meth:`WalkPass.run`: ``cells`` (k, 2, 4) float32 (centre and
    reach rounded up; the split bound, cos and sin of the reach), row-major, ``width``
    cells a row;
    ``pwidth`` the parent level's width (0: every cell's parent is parent 0)."""

    cells: np.ndarray
    width: int
    pwidth: int


class WalkPass:
    """The compiled programs and their runs (one per GL thread).

    One walk per cell (one invocation, depth first): a node is kept against the least
    upper bound found so far, which only falls, so the list is a superset of the one the
    final bound keeps. The lists are written as they are found, in chunks of
    :data:`CHUNK` slots reserved with an atomic counter; the next level reads its
    parents' lists from those chunks, and the last level's are gathered by cell
    (``shaders/field_walk_gather.comp``) before they are read back. The cells run in
    their parents' order (:func:`_ordered`). A pool too small is run again with the
    exact need (the walk counts on past its end).
    """

    def __init__(self):
        self.ctx = get_context()
        self.max_bytes = context_info()["max_storage_block_size"]
        self.max_pool = self.max_bytes // 4  # slots of a pool (node ids and links)
        # llvmpipe ends all loops of an invocation after 65535 iterations in all, silently
        self.max_steps = 60000 if context_info()["software"] else 1 << 30
        self.prog = self.ctx.compute_shader(load_source("field_walk.comp")[0])
        self.gather = self.ctx.compute_shader(load_source("field_walk_gather.comp")[0])
        self._table: list = []  # the node table's buffers of the run
        self._kept: dict = {}  # id of a table's nodes: (weak reference, buffers)

    def run(self, table, parents, levels, m: float, deep: float = 0.0):
        """Walk ``levels`` from the ``parents``' lists; return the last level's count per
        cell and its lists' node ids, by cell (row-major), or None where a limit is hit.

        ``table``: ``(nodes (n, 4, 4) float32, child (n, 2) int32)`` as
        ``shaders/field_walk.comp`` reads them; ``parents``: ``(start, count)`` (k, 2)
        of the cells above the first level (one row: the root list of every cell of
        level 0) and their pool of node ids; ``m`` rounded up, at most 4; ``deep``: the
        dominance test on the nodes at least this many of a cell's reaches away (0: none),
        its bounds: the angles from ``ang_lo`` / ``ang_hi``, ``chord(delta) <= min(delta,
        2)``, ``sin D >= D (1 - D^2 / 6)`` lowered by 1e-6 relative, and the gap (three
        float32 operations on values below 4: 7e-7) above ``2 SUM_ERR``.
        """
        ctx = self.ctx
        nodes, child = table
        sc, ids = parents
        if max(nodes.nbytes, ids.nbytes, sc.nbytes) > self.max_bytes:
            return None
        self._table = self._buffers(nodes, child)
        par = ctx.buffer(np.ascontiguousarray(sc, np.uint32).tobytes())
        pool = ctx.buffer(np.ascontiguousarray(ids, np.uint32).tobytes() or bytes(4))
        chunk = CONTIGUOUS
        try:
            self.prog["u_m"] = float(m)
            self.prog["u_bisector"] = int(BISECTOR)
            if "u_deep" in self.prog:
                self.prog["u_deep"] = float(deep)
            self.prog["u_max_steps"] = self.max_steps
            for name, v in (
                ("u_ch_rel", CH_REL),
                ("u_ch_abs", CH_ABS),
                ("u_asin_rel", ASIN_REL),
                ("u_dot_err", DOT_ERR),
                ("u_sum_err", SUM_ERR),
                ("u_bis_abs", BIS_ABS),
                ("u_bis_rel", BIS_REL),
            ):
                self.prog[name] = v
            slots = len(ids)
            for lev in levels[:-1]:
                cells = _ordered(lev)
                got = self._level(lev, cells, (par, pool, chunk), _estimate(lev, slots))
                if got is None:
                    return None
                out, new, slots = got
                par.release()
                pool.release()
                par, pool, chunk = out, new, CHUNK - 1
            cells = _ordered(levels[-1])
            return self._last(levels[-1], cells, (par, pool, chunk), _estimate(levels[-1], slots))
        finally:
            for b in (par, pool):
                b.release()
            self._table = []

    def _buffers(self, nodes: np.ndarray, child: np.ndarray) -> list:
        """The buffers of a node table, uploaded once while ``nodes`` lives (the last
        :data:`KEEP_TABLES` tables kept)."""
        got = self._kept.get(id(nodes))
        if got is not None and got[0]() is nodes:
            return got[1]
        for key in [k for k, (ref, _) in self._kept.items() if ref() is None]:
            self._drop(key)
        while len(self._kept) >= KEEP_TABLES:
            self._drop(next(iter(self._kept)))
        bufs = [self.ctx.buffer(nodes.tobytes()), self.ctx.buffer(child.tobytes())]
        self._kept[id(nodes)] = (weakref.ref(nodes), bufs)
        return bufs

    def _drop(self, key: int) -> None:
        for b in self._kept.pop(key)[1]:
            b.release()

    def _level(self, lev: WalkLevel, cells: np.ndarray, parents, cap: int):
        """Run a level above the last (its ``cells`` as :func:`_ordered` gives them): its
        ``(first chunk, count)`` and pool buffers and the pool's slots used (None where a
        limit is hit)."""
        par, pool, chunk = parents
        k = len(cells)
        if 32 * k > self.max_bytes:
            return None
        buf = self.ctx.buffer(cells.tobytes())
        out = self.ctx.buffer(reserve=8 * k)
        cap = min(cap, self.max_pool)
        try:
            while cap <= self.max_pool:
                new, total, flags = self._run(lev, (buf, par, pool, out), (0, k), cap, chunk)
                if not flags:
                    out, done = None, out  # handed over
                    return done, new, total
                new.release()
                if flags & FLAG_LIMIT or total <= cap:  # (a count past 2^32 wrapped)
                    return None
                cap = total  # the exact need (the walk counts on past a full pool)
            return None
        finally:
            buf.release()
            if out is not None:
                out.release()

    def _last(self, lev: WalkLevel, cells: np.ndarray, parents, cap: int):
        """Run the last level in runs of cells whose pools fit: each cell's count and
        the arcs by cell (row-major), or None where a limit is hit."""
        par, pool, chunk = parents
        k = len(cells)
        most = self.max_pool
        if 32 * k > self.max_bytes:
            return None
        order = cells.view(np.uint32)[:, 7]
        buf = self.ctx.buffer(cells.tobytes())
        out = self.ctx.buffer(reserve=8 * k)
        runs = []
        try:
            k0, step = 0, k
            while k0 < k:
                k1 = min(k, k0 + step)
                want = min(most, max(1024, cap * (k1 - k0) // k))
                new, total, flags = self._run(lev, (buf, par, pool, out), (k0, k1), want, chunk)
                if flags & FLAG_LIMIT:
                    new.release()
                    return None
                if flags & FLAG_POOL:
                    new.release()
                    if total <= want:  # (a count past 2^32 wrapped)
                        return None
                    if total <= most:
                        cap = max(cap, total * k // (k1 - k0) + 1)
                    elif step > 1:
                        step = (step + 1) // 2
                    else:
                        return None
                    continue
                which = np.sort(order[k0:k1])
                try:
                    runs.append((which, *self._gather(out, new, which)))
                finally:
                    new.release()
                k0 = k1
            return _by_cell(k, runs)
        finally:
            buf.release()
            out.release()

    def _run(self, lev: WalkLevel, bound, span, cap: int, chunk: int):
        """One dispatch over the invocations ``span`` of ``lev`` with a new pool of ``cap``
        slots, the parents' lists in chunks of ``chunk`` ids: the pool, the slots asked
        for and the flags."""
        k0, k1 = span
        new = self.ctx.buffer(reserve=4 * cap)
        count = self.ctx.buffer(bytes(8))
        try:
            for b, at in zip((*self._table, *bound, new, count), range(8)):
                b.bind_to_storage_buffer(at)
            self.prog["u_first"] = k0
            self.prog["u_cells"] = k1
            self.prog["u_width"] = lev.width
            self.prog["u_pwidth"] = lev.pwidth
            self.prog["u_capacity"] = cap
            self.prog["u_pchunk"] = chunk
            self.prog.run(group_x=max(1, -(-(k1 - k0) // _LOCAL)))
            self.ctx.memory_barrier()
            total, flags = (int(x) for x in np.frombuffer(count.read(), np.uint32))
        finally:
            count.release()
        return new, total, flags

    def _gather(self, out, pool, which: np.ndarray):
        """The lists of the cells ``which`` (ascending) of ``out`` (their first chunk and
        count, by cell), in chunks of ``pool``, gathered by cell
        (``shaders/field_walk_gather.comp``): the counts and the ids."""
        fc = np.frombuffer(out.read(), np.uint32).reshape(-1, 2)
        count = fc[which, 1].astype(np.int64)
        total = int(count.sum())
        if total == 0:
            return count, np.zeros(0, np.uint32)
        start = np.column_stack([which, np.cumsum(count) - count]).astype(np.uint32)
        sb = self.ctx.buffer(start.tobytes())
        ids = self.ctx.buffer(reserve=4 * total)
        try:
            for b, at in zip((out, sb, pool, ids), range(4)):
                b.bind_to_storage_buffer(at)
            self.gather["u_cells"] = len(which)
            self.gather["u_chunk"] = CHUNK - 1
            self.gather.run(group_x=max(1, -(-len(which) // _LOCAL)))
            self.ctx.memory_barrier()
            return count, np.frombuffer(ids.read(), np.uint32)
        finally:
            sb.release()
            ids.release()


def _estimate(lev: WalkLevel, slots: int) -> int:
    """A first pool for ``lev`` from the slots of its parents' pool: a list about four
    times as long as its parent's (each cell its first chunk), at least
    :data:`MIN_POOL`; a pool too small costs a second run (told the exact need), one
    too large only memory."""
    return max(MIN_POOL, 5 * slots + CHUNK * len(lev.cells))


def _ordered(lev: WalkLevel) -> np.ndarray:
    """The cells of ``lev`` as ``shaders/field_walk.comp`` reads them, (k, 8) float32
    (centre, reach; bound, cos and sin of the reach; the cell's index as uint32), in the
    order they are run: by parent (row-major), a parent's cells together. The lanes of a
    SIMD vector (neighbours in that order) then start from the same lists, about as long,
    and read the same nodes."""
    k = len(lev.cells)
    cell = np.arange(k)
    if lev.pwidth:
        w = lev.width
        h = k // w
        pj, pi = np.divmod(np.arange(((h + 1) // 2) * lev.pwidth), lev.pwidth)
        j = 2 * pj[:, None] + np.array([0, 0, 1, 1])
        i = 2 * pi[:, None] + np.array([0, 1, 0, 1])
        cell = (j * w + i)[(j < h) & (i < w)]
    out = np.ascontiguousarray(lev.cells.reshape(k, 8)[cell], np.float32)
    out.view(np.uint32)[:, 7] = cell
    return out


def _by_cell(k: int, runs) -> tuple[np.ndarray, np.ndarray]:
    """The runs' lists, ``(cells ascending, counts, ids)`` each, by cell (row-major):
    each cell's count and the ids."""
    if len(runs) == 1 and len(runs[0][0]) == k:
        return runs[0][1], runs[0][2]
    count = np.zeros(k, np.int64)
    for which, n, _ in runs:
        count[which] = n
    start = np.cumsum(count) - count
    ids = np.empty(int(count.sum()), np.uint32)
    for which, n, got in runs:
        at = np.repeat(start[which] - (np.cumsum(n) - n), n) + np.arange(len(got))
        ids[at] = got
    return count, ids


def walk_pass() -> WalkPass:
    """This thread's :class:`WalkPass` (made on first use, with the GL context)."""
    return shared(WalkPass)
