"""The GL pass of a distance field: each pixel's nearest arcs in float32
(``shaders/nearest.frag``), run from a :class:`NearestPlan`.

The planner (:mod:`gloffset.raster.field_gpu`) walks the levels in float64 down to cells
of ``2^shift x 2^shift`` output pixels, each with the list of every arc that can be the
nearest of one of its pixels, and hands a block of pixels over as plain arrays: their
centres, the cells' lists and the arcs, in float32. This module uploads them, draws one
fullscreen pass and reads back, per pixel, its six least features (an arc's foot or its
ends) in float32 chords, the least chord, how many lie within ``2 NEAREST_ERR`` of it
and whether more may; the planner finishes in float64. It knows no grid or shape.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import GLContextError
from .context import context_info, get_context, shared
from .shaders import program
from .textures import pot, pot_texture
from .textures import set_uniform as _set

__all__ = [
    "EVERY",
    "FEATURES",
    "NEAREST_ERR",
    "NONE",
    "NearestPass",
    "NearestPlan",
    "nearest_pass",
]

#: Bound on |float32 chord - chord of the float64 distance| of ``shaders/nearest.frag``
#: (the chord ``2 sin(t / 2)`` of an angle ``t``, at most 2), u = 2^-24. Every input
#: (pixel centre, arc ends, normal n, n x a, b x n: unit vectors made in float64) is
#: rounded once, off by at most u in norm, so a branch test p.(n x a) is off by at most
#: 5u (inputs 2u, three products summed 3u) and one beyond TEST (1e-6 = 16u) is decided
#: as float64 decides it. On the arc, s = p.n is off by 5u and |p - s n| = cos t by 12u;
#: the chord |s| sqrt(2 / (1 + cos t)) has slopes at most sqrt(2) and 1 / sqrt(2) in
#: them (15.6u) and its own rounding (1 + q, division, square root, product: 7u
#: relative, the chord <= sqrt(2): 10u): 26u. To an end, |p - a| is off by 2u from the
#: inputs and 8u from its rounding (4u relative, the chord <= 2): 10u. An arc whose test
#: is undecided has the lesser of both chords where they differ by at most NEAREST_ERR
#: / 8 (8u; else its pixel takes its whole list): 34u. The constant, 67u, leaves 33u for
#: GPUs whose square roots and divisions round less well, the rounding of ``m1 + gap``
#: (4u) and a float64 margin of 1e-13 (so that a feature whose float32 chord is more
#: than 2 NEAREST_ERR above the least has a float64 distance strictly greater than the
#: least one's, bit for bit). ``tests/test_field_gpu.py`` measures the largest error on
#: a million real pairs.
NEAREST_ERR = 4e-6
#: No feature (a cell with an empty list, or fewer features than asked for).
NONE = 0xFFFFFFFF
#: The flag of a pixel that needs its cell's whole list (column 3 of :meth:`NearestPass.run`).
EVERY = 0x100
#: The columns of the features of :meth:`NearestPass.run`, least first.
FEATURES = (0, 1, 4, 5, 6, 7)
#: vec4 per arc record (``Arcs`` in ``shaders/nearest.frag``).
ARC_TEXELS = 5


@dataclass
class NearestPlan:
    """One block of pixels for :class:`NearestPass`, as plain arrays.

    ``centers`` (h, w, 3) float32 the pixel centres (unit vectors made in float64 and
    rounded); ``shift``: pixel ``(j, i)`` lies in cell ``(j >> shift, i >> shift)``;
    ``cells`` (hc, wc, 2) uint32 each cell's first pair and pair count, ``pairs`` (n,)
    uint32 the lists (rows of ``arcs``), ``arcs`` (m, 5, 4) float32 the arcs:
    ``(a, n_x), (b, n_y), (n x a, n_z), (b x n, ok), (mid, r)`` with ``ok`` 1 where the
    arc has a normal (0: its ends only), ``mid`` and ``r`` the centre and chord radius
    (rounded up) of a cap that holds it; ``ends`` (m, 2) uint32 the ids of the arcs' ends (equal
    for the same vertex, below 2^31).
    """

    centers: np.ndarray
    shift: int
    cells: np.ndarray
    pairs: np.ndarray
    arcs: np.ndarray
    ends: np.ndarray


class NearestPass:
    """Draws :class:`NearestPlan` blocks: the program, compiled once, and :meth:`run`."""

    def __init__(self):
        self.ctx = get_context()
        info = context_info()
        #: the largest block side (pixels) and storage buffer (bytes) this context takes
        self.max_side = min(info["max_texture_size"], *info["max_viewport_dims"])
        self.max_bytes = info["max_storage_block_size"]
        self.prog = program(self.ctx, "fullscreen.vert", "nearest.frag")
        self.vao = self.ctx.vertex_array(self.prog, [])

    def fits(self, h: int, w: int, pairs: int, arcs: int) -> bool:
        """Whether a block of ``h x w`` pixels with these many pairs and arcs fits the
        GL limits (texture side, storage buffer size)."""
        return (
            pot(max(h, w)) <= self.max_side
            and 4 * pairs <= self.max_bytes
            and 16 * ARC_TEXELS * arcs <= self.max_bytes
            and 4 * pairs < 1 << 32
        )

    def run(self, plan: NearestPlan) -> np.ndarray:
        """Return (h, w, 8) uint32 per pixel: the ``K`` (6) least features, as ``(pair
        << 2) | kind`` (``pair`` a position in ``plan.pairs``; ``kind`` 0 the arc, 1 its
        end ``a``, 2 its end ``b``; :data:`NONE` for none) in columns 0, 1, 4, 5, 6, 7
        (ascending), the least chord's float32 bits (column 2) and the count of the
        others within ``2 NEAREST_ERR`` of the least, plus :data:`EVERY` where one more
        may be (column 3)."""
        import moderngl

        h, w = plan.centers.shape[:2]
        hc, wc = plan.cells.shape[:2]
        if not self.fits(h, w, len(plan.pairs), len(plan.arcs)):
            raise GLContextError(
                f"a distance-field block of {w} x {h} pixels, {len(plan.pairs)} pairs and "
                f"{len(plan.arcs)} arcs exceeds this GL context's limits (side "
                f"{self.max_side}, storage buffer {self.max_bytes} bytes)"
            )
        if (hc, wc) != (-(-h >> plan.shift), -(-w >> plan.shift)):
            raise ValueError(f"cells {plan.cells.shape} do not cover {h} x {w} pixels")
        ctx = self.ctx
        tex = pot_texture(ctx, plan.centers.astype(np.float32), 3, "f4")
        targets = [ctx.texture((pot(w), pot(h)), 4, dtype="u4") for _ in range(2)]
        fbo = ctx.framebuffer(color_attachments=targets)
        ctx.error  # noqa: B018  (see textures.class_target: an integer attachment's query)
        bufs = [
            ctx.buffer(np.ascontiguousarray(a, dtype=t).tobytes() or bytes(16))
            for a, t in (
                (plan.cells, np.uint32),
                (plan.pairs, np.uint32),
                (plan.arcs, np.float32),
                (plan.ends, np.uint32),
            )
        ]
        try:
            fbo.use()
            ctx.viewport = (0, 0, w, h)
            ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
            tex.use(0)
            _set(self.prog, "u_centers", 0)
            _set(self.prog, "u_shift", int(plan.shift))
            _set(self.prog, "u_cells_w", int(wc))
            _set(self.prog, "u_gap", 2.0 * NEAREST_ERR)
            _set(self.prog, "u_same", 0.125 * NEAREST_ERR)
            for k, b in enumerate(bufs):
                b.bind_to_storage_buffer(k)
            self.vao.render(moderngl.TRIANGLES, vertices=3)
            data = [
                fbo.read(viewport=(0, 0, w, h), components=4, attachment=k, dtype="u4")
                for k in range(2)
            ]
        finally:
            for obj in (*bufs, fbo, *targets, tex):
                obj.release()
        near, more = (np.frombuffer(d, dtype=np.uint32).reshape(h, w, 4) for d in data)
        out = np.empty((h, w, 8), dtype=np.uint32)
        out[..., :2], out[..., 2:4], out[..., 4:6] = near[..., :2], near[..., 2:], more[..., :2]
        out[..., 6:] = more[..., 2:]
        return out


def nearest_pass() -> NearestPass:
    """This thread's :class:`NearestPass` (made on first use, with the GL context)."""
    return shared(NearestPass)
