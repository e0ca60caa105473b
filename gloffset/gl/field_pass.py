"""The GL pass of a distance field: each pixel's distance to its nearest arc, float64
(``shaders/field_pixels.comp``), run from a :class:`FieldPlan`.

The planner (:mod:`gloffset.raster.fields.gpu`) walks the levels in float64 down to cells
of ``2^shift x 2^shift`` output pixels, each with the list of every arc that can be the
nearest of one of its pixels, and hands a block of cells over as plain arrays: the
cells' lists, the arcs (float32 records for the ranking, float64 ones for the
finishing) and what the shader makes the pixel centres from. One compute dispatch
makes each pixel's centre in double, ranks its cell's list in float32 and finishes the
near-least features in double (the module notes of :mod:`gloffset.raster.fields.gpu`);
it reads back one float64 distance per pixel. It knows no shape. Each pixel ranks only the
arcs of its cell's list that come near enough (:data:`PRUNE_MARGIN`), found through
chunks of the list (:func:`chunk_caps`): on llvmpipe a pixel's cost follows the loads it
makes, about one per float read per arc. Storage buffers
throughout: the float64 records read from a texture instead (RGBA32UI pairs) made the pass
half as slow again on llvmpipe (measured).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from ..errors import GLContextError
from .context import context_info, get_context, shared
from .shaders import load_source
from .vector_pass import set_grid_constants

__all__ = [
    "FIELD_ERR",
    "NEAREST_ERR",
    "PRUNE_MARGIN",
    "FieldPass",
    "FieldPlan",
    "field_pass",
    "pruned",
]

#: Bound on |float32 chord - chord of the float64 distance| of the shader's ranking
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
#: (4u) and the float64 finishing's error (:data:`FIELD_ERR`), so that a feature whose
#: float32 chord is more than 2 NEAREST_ERR above the least has a float64 distance
#: greater than the least one's. ``tests/test_field_gpu.py`` measures the largest error
#: on a million real pairs.
NEAREST_ERR = 4e-6

#: Bound on |shader's float64 distance - gloffset.geometry.sphere.arc_distance| (rad),
#: relative, for the same pixel centre: the products and sums are the host's, rounded
#: once (``precise``); ``fp64_sqrt`` is within 2 ulp of the square root (relative 2.2e-16
#: each, half of that in the angle), ``fp64_atan2(y, x)`` within 3 ulp of its angle for
#: small angles (its float32 seed off by 1e-7 relative, one cubic Newton step, the
#: residual ``y cos t - x sin t`` rounded to an ulp of ``y``) and 3e-16 absolute at
#: worst: at most 1.5e-15 relative, 4e-16 absolute. Measured: ``tests/test_field_gpu.py``
#: (the largest relative error over a million real pixel/arc pairs: 6.7e-16 on llvmpipe).
#: A float32 ulp is 6e-8 relative: the float64 values round to the CPU's float32 values
#: or to a neighbour where the CPU's lies within 1.5e-15 of a rounding boundary.
FIELD_ERR = 1.5e-15

#: The margin (chord) of each pixel's pruning of its cell's list
#: (``shaders/field_pixels.comp``, ``prune_limit``, ``kept_bits``): an arc is ranked where
#: its bounding cap comes within ``U + PRUNE_MARGIN`` of the pixel, ``U`` an upper bound
#: of its nearest arc's float32 chord (to a chunk's cap, :func:`chunk_caps`, or to an
#: arc's end). The arcs the ranking and the finishing read at a pixel have caps within
#: ``m + 2 gap`` of it (``far_cap``, ``gap = 2 NEAREST_ERR``), ``m`` its least ranked
#: chord, at most ``U + NEAREST_ERR`` (an arc ranks no higher than a point of it, within
#: the ranking's error); this margin, 8 NEAREST_ERR, covers those 5 NEAREST_ERR with room
#: for the float32 roundings of the tests (a few 1e-7), so that the pruning changes no
#: value that is read (``tests/test_field_prune.py``: the same bits as unpruned).
PRUNE_MARGIN = 8.0 * NEAREST_ERR

#: No feature (a cell with an empty list, or fewer features than asked for).
NONE = 0xFFFFFFFF
#: vec4 per arc record (``Arcs`` in ``shaders/field_pixels.comp``); doubles per exact one.
ARC_TEXELS, EXACT_DOUBLES = 5, 16
_LOCAL = 8  # the work group's side (pixels)
#: rows of a block run by one dispatch (a multiple of ``_LOCAL``) where the process has
#: other threads: on a CPU driver (llvmpipe) a dispatch runs while the calling thread
#: holds Python's GIL, so a block is run in bands of rows, the GIL free between them (a
#: tile server's field thread then stalls its other threads for a band's time, a few ms,
#: not a whole 256 px tile's); the same pixels, the same bits. A process of one thread
#: runs a block in one dispatch (bands cost it about a tenth of a tile's field).
BAND = 32


@dataclass
class FieldPlan:
    """One block of pixels for :class:`FieldPass`, as plain arrays.

    ``size`` (h, w) the block's pixels, ``origin`` (row, column) of its first pixel in
    the grid; ``shift``: pixel ``(j, i)`` lies in cell ``(j >> shift, i >> shift)``;
    ``cells`` (hc, wc, 2) uint32 each cell's first pair and pair count, ``pairs`` (n,)
    uint32 the lists (rows of ``arcs``), ``arcs`` (m, 5, 4) float32 the arcs: ``(a,
    n_x), (b, n_y), (n x a, n_z), (b x n, ok)``, ``(mid, r)`` with ``ok`` 1 where the arc
    has a normal (0: its ends only), ``mid`` and ``r`` the centre and chord radius
    (rounded up) of a cap that holds it; ``ends`` (m, 2) uint32 the ids of the arcs' ends
    (equal for the same vertex, below 2^31); ``exact`` (m, 16) float64 ``(a, ok), (b,
    bn_x), (n, bn_y), (n x a, bn_z)`` with ``bn = b x n`` (the host's float64 values).

    The centres, by ``kind``: ``"lonlat"`` ``rows`` (h, 2) the cosine and sine of each
    row's latitude, ``cols`` (w, 2) of each column's longitude; ``"cube"`` ``rows`` (h,)
    and ``cols`` (w,) the face coordinates ``t`` and ``s``, ``basis`` (3, 3) the face's
    axes; ``"glsl"`` ``source`` and ``constants`` (a grid's
    :class:`~gloffset.grids.protocol.GlslCentres`) at output-pixel coordinates from
    ``origin``; ``"texture"`` ``rows`` (h, w, 3) float64 the centres themselves.

    The sign (optional): ``flags`` (m,) uint32 the arcs' corner flags
    (:attr:`gloffset.raster.fields.sign.Corners.flags`, 0 for an arc with none) and
    ``seams`` (k, 4) float32 the seams' bounding caps (centre, half angle); with
    ``flags``, :meth:`FieldPass.run` fills ``codes`` (h, w) uint32 with each pixel's
    answer from its nearest features (0 outside, 1 inside, 2 undecided;
    ``shaders/field_pixels.comp``).

    ``depth`` (optional): the median over the block's cells of their distance to their
    nearest arc in units of their ``rho`` (the choice of the pruned program,
    :func:`pruned`; None: unknown).
    """

    size: tuple[int, int]
    origin: tuple[int, int]
    shift: int
    cells: np.ndarray
    pairs: np.ndarray
    arcs: np.ndarray
    ends: np.ndarray
    exact: np.ndarray
    kind: str
    rows: np.ndarray
    cols: np.ndarray | None = None
    basis: np.ndarray | None = None
    source: str | None = None
    constants: tuple[float, ...] = ()
    flags: np.ndarray | None = None
    seams: np.ndarray | None = None
    codes: np.ndarray | None = None
    depth: float | None = None


class FieldPass:
    """Runs :class:`FieldPlan` blocks: the programs (one per kind of centres, compiled
    on first use) and :meth:`run`."""

    def __init__(self):
        self.ctx = get_context()
        info = context_info()
        self.max_bytes = info["max_storage_block_size"]
        self._progs: dict = {}
        #: where ``field_pixels.comp`` is read from (None: the shader folder)
        self.root = None

    def program(
        self, kind: str, source: str | None = None, probe: bool = False, prune: bool = False
    ):
        """The compiled program of a kind of centres (a grid's GLSL file for ``"glsl"``);
        with ``probe``, its variant that writes the ranking's least chord instead of the
        distance (negated where the pixel takes its cell's whole list); with ``prune``,
        its variant that prunes the lists (:data:`PRUNE_MARGIN`)."""
        key = (kind, source, probe, prune, self.root)
        prog = self._progs.get(key)
        if prog is None:
            variants: dict[str, dict] = {
                "cube": {"GRID_CUBE": 1},
                "texture": {"GRID_TEXTURE": 1},
                "glsl": {"GRID_GLSL": f'"{source}"'},
            }
            defines = variants.get(kind, {})
            if probe:
                defines = {**defines, "PROBE_RANKING": 1}
            if prune:
                defines = {**defines, "PRUNE": 1}
            src, _ = load_source("field_pixels.comp", defines, root=self.root)
            prog = self._progs[key] = self.ctx.compute_shader(src)
        return prog

    def fits(self, h: int, w: int, pairs: int, arcs: int, texture: bool) -> bool:
        """Whether a block of ``h x w`` pixels with these many pairs and arcs fits the
        storage buffers."""
        return (
            8 * h * w * (4 if texture else 1) <= self.max_bytes
            and 16 * pairs <= self.max_bytes
            and 8 * EXACT_DOUBLES * arcs <= self.max_bytes
            and 4 * pairs < 1 << 30
        )

    def run(self, plan: FieldPlan, probe: bool = False) -> np.ndarray:
        """Return (h, w) float64: each pixel's distance (rad) to the nearest arc of its
        cell's list, ``inf`` where the list is empty (see the module notes); with
        ``probe`` (the tests' measure of :data:`NEAREST_ERR`), the ranking's least
        float32 chord instead, negated where the pixel takes its cell's whole list."""
        h, w = plan.size
        hc, wc = plan.cells.shape[:2]
        if not self.fits(h, w, len(plan.pairs), len(plan.arcs), plan.kind == "texture"):
            raise GLContextError(
                f"a distance-field block of {w} x {h} pixels, {len(plan.pairs)} pairs and "
                f"{len(plan.arcs)} arcs exceeds this GL context's storage buffers "
                f"({self.max_bytes} bytes)"
            )
        if (hc, wc) != (-(-h >> plan.shift), -(-w >> plan.shift)):
            raise ValueError(f"cells {plan.cells.shape} do not cover {h} x {w} pixels")
        prune = pruned(len(plan.pairs), hc * wc, plan.depth)
        prog = self.program(plan.kind, plan.source, probe, prune)
        ctx = self.ctx

        def buf(a, t):
            return ctx.buffer(np.ascontiguousarray(a, dtype=t).tobytes() or bytes(16))

        cols = plan.cols if plan.cols is not None else np.zeros(1)
        signed = plan.flags is not None and not probe
        flags = plan.flags if signed else np.zeros(1)
        seams = plan.seams if signed and plan.seams is not None else np.zeros((0, 4))
        bufs = [
            buf(plan.cells, np.uint32),
            buf(plan.pairs, np.uint32),
            buf(plan.arcs, np.float32),
            buf(plan.ends, np.uint32),
            buf(plan.exact, np.float64),
            ctx.buffer(reserve=8 * h * w),
            buf(plan.rows, np.float64),
            buf(cols, np.float64),
            buf(flags, np.uint32),
            buf(seams, np.float32),
            ctx.buffer(reserve=4 * h * w if signed else 16),
            buf(
                chunk_caps(plan.cells, plan.pairs, plan.arcs) if prune else np.zeros(4), np.float32
            ),
        ]
        try:
            for k, b in enumerate(bufs):
                b.bind_to_storage_buffer(k)
            _set(prog, "u_size", (int(w), int(h)))
            _set(prog, "u_origin", (int(plan.origin[1]), int(plan.origin[0])))
            _set(prog, "u_shift", int(plan.shift))
            _set(prog, "u_cells_w", int(wc))
            _set(prog, "u_gap", 2.0 * NEAREST_ERR)
            _set(prog, "u_same", 0.125 * NEAREST_ERR)
            _set(prog, "u_prune", PRUNE_MARGIN)
            _set(prog, "u_signed", int(signed))
            _set(prog, "u_seams", len(seams))
            deep = plan.depth is not None and plan.depth >= PRUNE_DEPTH
            _set(prog, "u_direct", DIRECT if deep and not prune else 0)
            if plan.kind == "cube":
                assert plan.basis is not None  # a cube plan's
                for name, row in zip(("u_face_e", "u_face_u", "u_face_v"), plan.basis):
                    _set(prog, name, tuple(float(x) for x in row))
            if plan.kind == "glsl":
                set_grid_constants(prog, plan.constants)
            # bands where another thread may wait for the GIL (one dispatch is faster:
            # about a tenth on a 256 px tile, measured)
            band = BAND if threading.active_count() > 1 else h
            for row0 in range(0, h, band):
                _set(prog, "u_row0", row0)
                prog.run(group_x=-(-w // _LOCAL), group_y=-(-min(band, h - row0) // _LOCAL))
            ctx.memory_barrier()  # the shader's writes, before they are read back
            out = np.frombuffer(bufs[5].read(), dtype=np.float64).reshape(h, w).copy()
            if signed:
                plan.codes = np.frombuffer(bufs[10].read(), dtype=np.uint32).reshape(h, w).copy()
        finally:
            for b in bufs:
                b.release()
        return out


#: The pruning's variant of the pass runs blocks whose lists hold at least this many
#: pairs a cell on average (shorter lists rank as fast without it, or faster by about a
#: tenth: measured on llvmpipe at z7-z8, 8-12 pairs a cell).
PRUNE_MEAN = 16

#: Blocks whose cells lie deep, their median distance to the nearest arc at least this
#: many of their ``rho`` (:attr:`FieldPlan.depth`), with fewer than
#: :data:`PRUNE_DEEP_MEAN` pairs a cell, run the unpruned program: there a cell's list
#: holds arcs all about as near to each of its pixels (a coast seen from afar), the
#: pruning keeps most of them and costs more than it saves. Measured on llvmpipe (CPU
#: time of the pass, best of 7 alternating rounds, 256 px tiles of all the countries):
#: 16-25 pairs a cell at a median depth of 57-1,026 ``rho`` (z6-z10 inland tiles) ran in
#: 52-64 ms unpruned against 76-89 ms pruned, while 24-31 pairs a cell at depths of 4-14
#: (Mexico z5-z6, countries z5) ran in 52-61 ms pruned against 60-74 ms unpruned.
PRUNE_DEPTH = 32.0
#: See :data:`PRUNE_DEPTH`: deep blocks with at least this many pairs a cell stay pruned.
PRUNE_DEEP_MEAN = 32

#: In blocks at least :data:`PRUNE_DEPTH` deep (unpruned), a cell's list of at most this
#: many arcs is finished whole in double, without the float32 ranking: there most
#: pixels see several features within the ranking's gap of the least (a coast seen
#: from afar), so they finish the whole list anyway, after ranking it. The values are
#: the same bits (the least of the arcs' distances, each that of its nearest feature).
#: Measured on llvmpipe (CPU time of the pass, median of 40 alternating runs, 256 px
#: tiles of all the countries): 37 -> 30 ms at z10 (2.9 arcs a cell), 53 -> 40 ms at z8
#: (5.1); blocks of depth 11 (Mexico z6, z8) were no faster, and stay ranked.
DIRECT = 6


def pruned(pairs: int, cells: int, depth: float | None) -> bool:
    """Whether a block of ``cells`` cells with ``pairs`` pairs runs the pruned program:
    at least :data:`PRUNE_MEAN` pairs a cell, unless it lies deep (:data:`PRUNE_DEPTH`)
    with fewer than :data:`PRUNE_DEEP_MEAN`; every block where ``PRUNE_MEAN`` is 0."""
    if PRUNE_MEAN == 0:
        return True
    if pairs < PRUNE_MEAN * cells:
        return False
    return depth is None or depth < PRUNE_DEPTH or pairs >= PRUNE_DEEP_MEAN * cells


#: Pairs of a cell's list per chunk of the pruning (``CHUNK`` in ``field_pixels.comp``).
CHUNK = 8
#: Slack (chord) on a chunk's radius: the float32 roundings of its computation and of
#: the shader's chords (each a few 1e-7 on values of at most 4).
_CHUNK_SLACK = np.float32(2e-6)


def chunk_caps(cells: np.ndarray, pairs: np.ndarray, arcs: np.ndarray) -> np.ndarray:
    """Return (len(pairs), 4) float32: at the first pair of each chunk of :data:`CHUNK`
    consecutive pairs of a cell's list, a cap ``(centre, chord radius)`` holding the
    caps of its arcs (``arcs[:, 4]``, as the shader reads them): the centre that of its
    first arc's cap, the radius the largest ``|centre - mid| + r`` of its arcs' caps (in
    float32, plus :data:`_CHUNK_SLACK`, more than its roundings); 0 elsewhere. A point
    farther than ``x + R`` from the centre is farther than ``x + r`` from each of the
    chunk's caps (the chord is a metric): ``kept_bits`` tests a chunk's arcs only where
    its cap passes."""
    first = cells[..., 0].ravel().astype(np.int64)
    cnt = cells[..., 1].ravel().astype(np.int64)
    out = np.zeros((len(pairs), 4), np.float32)
    nch = (cnt + CHUNK - 1) // CHUNK
    total = int(nch.sum())
    if total == 0:
        return out
    cell = np.repeat(np.arange(len(cnt)), nch)
    start = first[cell] + CHUNK * (np.arange(total) - np.repeat(np.cumsum(nch) - nch, nch))
    size = np.minimum(CHUNK, first[cell] + cnt[cell] - start)
    at = np.cumsum(size) - size  # each chunk's first member
    pos = np.repeat(start - at, size) + np.arange(int(size.sum()))
    caps = np.ascontiguousarray(arcs[:, 4].T)  # float32, as read, by columns
    cap = caps.take(pairs.take(pos), axis=1)
    centre = cap[:3, at]
    d = [cap[k] - np.repeat(centre[k], size) for k in range(3)]
    far = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) + cap[3]
    out[start, :3], out[start, 3] = centre.T, np.maximum.reduceat(far, at) + _CHUNK_SLACK
    return out


def _set(prog, name: str, value) -> None:
    if name in prog:  # a driver drops a uniform the program does not read
        prog[name].value = value


def field_pass() -> FieldPass:
    """This thread's :class:`FieldPass` (made on first use, with the GL context)."""
    return shared(FieldPass)
