"""A distance field's walk on the GL context, level by level (``shaders/field_walk.comp``).

Each cell's list of multiresolution nodes is its parent's pruned and split in float32 by
the rule of :func:`gloffset.raster.field_walk._bound` (no bisector test), every bound
widened so that each list is a superset of the float64 rule's. Inputs are float64 unit
vectors rounded once to float32 (off by at most u = 2^-24 in norm); radii (``reach``,
``err``, the cells' reach, ``m``) are rounded up. The bounds:

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
  below 16 (half an ulp: 9.5e-7): :data:`SUM_ERR` (4e-6) covers the four.

The float64 rule's own rounding (1e-14) is far below these margins. The slack is about
4e-6 rad (25 m) absolute: cells much smaller get longer lists, never shorter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import GLContextError
from .context import context_info, get_context, shared
from .shaders import load_source

__all__ = ["ASIN_REL", "CH_ABS", "CH_REL", "DOT_ERR", "SUM_ERR", "WalkPass", "walk_pass"]

CH_REL, CH_ABS = 1e-6, 2.5e-7
ASIN_REL = 4e-6
DOT_ERR = 2e-6
SUM_ERR = 4e-6
_LOCAL = 64
#: Bits of the shader's flags: the pool was too small; a stack or loop limit was hit.
FLAG_POOL, FLAG_LIMIT = 1, 2


@dataclass
class WalkLevel:
    """One level for :meth:`WalkPass.level`: ``cells`` (k, 2, 4) float32 (centre and
    reach rounded up; the split bound), row-major, ``width`` cells a row;
    ``pwidth`` the parent level's width (0: every cell's parent is parent 0)."""

    cells: np.ndarray
    width: int
    pwidth: int


class WalkPass:
    """The compiled program and its runs (one per GL thread)."""

    def __init__(self):
        self.ctx = get_context()
        self.max_bytes = context_info()["max_storage_block_size"]
        src, _ = load_source("field_walk.comp")
        self.prog = self.ctx.compute_shader(src)

    def run(self, table, root: np.ndarray, levels, m: float):
        """Walk ``levels`` from the ``root`` list (node ids); return the last level's
        per-cell ``(start, count)`` (k, 2) and its pool, or None where a limit is hit.

        ``table``: ``(nodes (n, 4, 4) float32, child (n, 2) int32)`` as
        ``shaders/field_walk.comp`` reads them; ``m`` rounded up, at most 4.
        """
        ctx = self.ctx
        nodes, child = table
        if nodes.nbytes > self.max_bytes:
            return None
        bufs = [ctx.buffer(nodes.tobytes()), ctx.buffer(child.tobytes())]
        par = ctx.buffer(np.array([0, len(root)], np.uint32).tobytes())
        pool = ctx.buffer(np.asarray(root, np.uint32).tobytes() or bytes(4))
        try:
            for k, b in enumerate(bufs):
                b.bind_to_storage_buffer(k)
            self.prog["u_m"] = float(m)
            for name, v in (
                ("u_ch_rel", CH_REL),
                ("u_ch_abs", CH_ABS),
                ("u_asin_rel", ASIN_REL),
                ("u_dot_err", DOT_ERR),
                ("u_sum_err", SUM_ERR),
            ):
                self.prog[name] = v
            cap = 4 * max(len(root), 1)
            for lev in levels:
                got = self._level(lev, par, pool, cap)
                if got is None:
                    return None
                out, new, cap = got
                par.release()
                pool.release()
                par, pool = out, new
            sc = np.frombuffer(par.read(), np.uint32).reshape(-1, 2)
            return sc, np.frombuffer(pool.read(), np.uint32)
        finally:
            for b in bufs + [par, pool]:
                b.release()

    def _level(self, lev: WalkLevel, par, pool, cap: int):
        ctx = self.ctx
        k = len(lev.cells)
        cells = ctx.buffer(np.ascontiguousarray(lev.cells, np.float32).tobytes())
        out = ctx.buffer(reserve=8 * k)
        try:
            while True:
                if 4 * cap > self.max_bytes or 32 * k > self.max_bytes:
                    out.release()
                    return None
                new = ctx.buffer(reserve=4 * cap)
                count = ctx.buffer(bytes(8))
                for b, at in ((cells, 2), (par, 3), (pool, 4), (out, 5), (new, 6), (count, 7)):
                    b.bind_to_storage_buffer(at)
                self.prog["u_cells"] = k
                self.prog["u_width"] = lev.width
                self.prog["u_pwidth"] = lev.pwidth
                self.prog["u_capacity"] = cap
                self.prog.run(group_x=max(1, -(-k // _LOCAL)))
                ctx.memory_barrier()
                total, flags = (int(x) for x in np.frombuffer(count.read(), np.uint32))
                count.release()
                if flags & FLAG_LIMIT:
                    new.release()
                    out.release()
                    return None
                if not flags & FLAG_POOL:
                    return out, new, max(cap, 4 * total)
                new.release()
                if total < cap:  # cannot happen: a full pool counts past its capacity
                    raise GLContextError("field walk: the pool was full below its capacity")
                cap = total + total // 4
        finally:
            cells.release()


def walk_pass() -> WalkPass:
    """This thread's :class:`WalkPass` (made on first use, with the GL context)."""
    return shared(WalkPass)
