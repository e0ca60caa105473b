"""The GPU levels of a render, planner side: pack the frontier bins, then run the GL passes.

Below the bin level the classes of the frontier bins come from the GL passes of
:mod:`gloffset.gl.vector_pass`. This module makes what they draw, in float64 on the CPU: the
canvas of the bins (:class:`~gloffset.raster.layout.BinLayout`), their arc records
(:func:`gloffset.raster.records.records`), the margins and the geometry of every level,
handed over as one :class:`~gloffset.gl.vector_pass.BinPlan` (:func:`bin_plan`); and it spreads
the canvas read back over the whole level (:meth:`BinPasses.run`): every cell outside the
frontier bins is its bin's class.
"""

from __future__ import annotations

import math

import numpy as np

from ..edges import CurveArcs
from ..geometry.caps import cap_within, chord2
from ..geometry.sphere import pair_dots
from ..gl.arcs import arc_buffer
from ..gl.records_pass import DeviceRecords, records_pass, records_pass_made
from ..gl.refine_pass import ARC_MASK as REFINE_ARC_MASK
from ..gl.refine_pass import NEAR_UNSURE as REFINE_NEAR_UNSURE
from ..gl.refine_pass import UNSURE as REFINE_UNSURE
from ..gl.refine_pass import refine_pass
from ..gl.scatter_pass import ARC_MASK, CROSS, NEAR, NEAR_UNSURE, UNSURE, scatter_pass
from ..gl.vector_pass import BinPlan, vector_passes
from ..memo import once_attr
from .layout import BinLayout
from .records import ArcRecords, margins, record_inputs, records
from .vector.child_pairs import half_trig
from .vector.levels import ON_EDGE, Frontier
from .vector.scatter import BoxPairs, box_pairs

__all__ = [
    "BinPasses",
    "bin_plan",
    "bin_passes",
    "device_records",
    "gpu_box_pairs",
    "gpu_refine_pairs",
]

#: Margin about the threshold of a pair's cap test within which the compute shader leaves
#: the test to the host (``shaders/scatter_pairs.comp``'s ``MARGIN``): far above the 1e-14
#: by which its threshold may differ from the host's and the few ulp (1e-15) by which a
#: device's float64 ``c.m`` could differ from the host's, so no pair is misjudged.
GPU_PAIR_MARGIN = 1e-9
#: Fewest candidate pairs for which :func:`bin_plan` makes the records on the GL context
#: (``shaders/arc_records.comp``) rather than in numpy: below, numpy (about 1 us a pair)
#: costs less than the shaders' first run in a process (llvmpipe compiles them then: about
#: 0.1 s measured) plus their own time (about a quarter of numpy's there).
GPU_MIN_RECORDS = 100_000
#: Once this thread has compiled the records' shaders
#: (:func:`gloffset.gl.records_pass.records_pass_made`), the fewest pairs are this share
#: of :data:`GPU_MIN_RECORDS`: from about 15,000 pairs the
#: shader made them as fast as numpy on llvmpipe, in wall time (0.25-0.4 us a pair
#: either way, measured on the batches of a pyramid of countries_10m), and the host then
#: only counts the pairs (:func:`gloffset.raster.records.record_inputs`).
GPU_WARM_SHARE = 0.2
#: Fewest box cells for which :func:`gpu_box_pairs` runs the shader: below, the numpy path
#: costs less than the shader's first run in a process (llvmpipe compiles it then: 0.15-0.2
#: s measured; numpy took 0.3-0.5 us a box cell, the shader about half). See
#: ``benchmarks/README.md``, ab.py.
GPU_MIN_PAIRS = 500_000
#: Fewest parent pairs for which :func:`gpu_refine_pairs` runs the shader: below, numpy
#: (about 0.15 us a parent pair) costs less than the shader's first run in a process.
GPU_MIN_REFINE = 200_000


def gpu_box_pairs(
    arcs: CurveArcs,
    lat,
    lon,
    row_reach,
    boxes,
    w: int,
    *,
    min_pairs=None,
    crossings=True,
    near=None,
):
    """:func:`gloffset.raster.vector.scatter.box_pairs` with the box cells enumerated, their
    ``c.m`` computed and their cap tests made by the compute shader of
    :mod:`gloffset.gl.scatter_pass`: the same pairs and ``cm`` (in another order; the
    caller sorts them).

    The shader decides each pair's cap test by a threshold within 1e-14 of the exact one
    and leaves to the host those within :data:`GPU_PAIR_MARGIN` of it (``cos``, ``min``
    and the sums are monotone and the margin is far above their rounding): the exact test
    (``cap_within``) runs on the host on those alone, and the result is its booleans.
    Fewer box cells than ``min_pairs`` (default :data:`GPU_MIN_PAIRS`), or boxes beyond the
    GL limits, take the numpy path.

    With ``crossings`` (the default), the shader also tells which ring edges cross the
    short arc from each pair's cell centre to its predecessor's
    (:func:`gloffset.geometry.sphere.arcs_cross`, the same booleans; for every pair of a
    ring edge and a cell but the first): the result has a fifth array, those booleans,
    where the shader ran. With ``near`` (per row, a second reach), the result is a
    :class:`~gloffset.raster.vector.scatter.BoxPairs` (as :func:`box_pairs` gives it),
    whose ``near`` the shader decides the same way.
    """
    a_idx, j0, j1, i0, i1 = boxes
    total = int(((j1 - j0) * (i1 - i0)).sum())
    least = GPU_MIN_PAIRS if min_pairs is None else min_pairs
    engine = scatter_pass() if total >= least else None
    if (
        engine is None
        or not engine.fits(total, len(a_idx))
        or not engine.fits_arcs(len(arcs.a))
        or len(lat) * w >= 1 << 31
    ):
        return box_pairs(arcs, lat, lon, row_reach, boxes, w, near=near)
    terms = _arc_terms(arcs)
    # arcs whose radius plus a reach comes near pi (where cap_within clamps): the host's
    most = max(float(row_reach.max()), -1.0 if near is None else float(near.max()))
    clamp = arcs.half + most >= math.pi - 1e-6
    if clamp.any():
        terms = terms.copy()
        terms[clamp, 3] = 1.0
    else:
        terms = arc_buffer(terms)
    rows = np.empty((len(lat), 8))
    rows[:, 0], rows[:, 1] = np.cos(lat), np.sin(lat)
    rows[:, 2] = row_reach
    rows[:, 3] = row_reach if near is None else near
    rows[:, 4], rows[:, 5] = np.cos(rows[:, 2]), np.sin(rows[:, 2])
    rows[:, 6], rows[:, 7] = np.cos(rows[:, 3]), np.sin(rows[:, 3])
    cols = np.empty((len(lon), 2))
    cols[:, 0], cols[:, 1] = np.cos(lon), np.sin(lon)
    boxes4 = np.empty((len(a_idx), 4), dtype=np.int64)
    for k, x in enumerate((j0, j1, i0, i1)):
        boxes4[:, k] = x
    cell, word, cm = engine.run(
        boxes4,
        a_idx,
        terms,
        rows,
        cols,
        w,
        total,
        arc_buffer(arcs.rows),
        cross=crossings,
        near=near is not None,
    )
    cell, word, cm, ok = _settle(arcs, cell, word, cm, w, row_reach, near)
    if near is not None:  # cells and arcs as uint32: the caller's sort widens them
        hit = (word & CROSS) != 0 if crossings else None
        return BoxPairs(cell, word & ARC_MASK, cm, hit, ok)
    ai = (word & ARC_MASK).astype(np.int64)
    cell = cell.astype(np.int64)
    hit = (word & CROSS) != 0
    jj = cell // w  # floor division and a product: divmod's values, in less time
    ii = cell - jj * w
    return (jj, ii, ai, cm, hit) if crossings else (jj, ii, ai, cm)


def gpu_refine_pairs(f: Frontier, arcs: CurveArcs, c, slot, first, seg, *, min_pairs=None):
    """The per-pair work of :func:`gloffset.raster.vector.levels.refine` on the GL context
    (:mod:`gloffset.gl.refine_pass`): the children's candidate pairs and ``c.m``
    (:func:`~gloffset.raster.vector.child_pairs.slot_pairs`'s, grouped by child, each
    child's in its parent's order), the ring edges that cross the short arc from each
    child ``c`` to its parent's centre (``arcs_cross`` of the pairs whose cap comes within
    ``seg`` of the child) and which parents' centres lie on one of their ring edges
    (:func:`~gloffset.raster.vector.levels.on_edge`).

    Returns ``(cell, arc, cm, (child, arc), on)``, the same pairs, ``c.m`` bits, crossings
    and booleans as the numpy path, or None where numpy takes the level (fewer parent
    pairs than ``min_pairs``, default :data:`GPU_MIN_REFINE`; beyond the GL limits).

    The shader's cap tests are within 1e-14 of the host's thresholds and leave those
    within :data:`GPU_PAIR_MARGIN` of them to the exact test here; its ``c.m``, crossing
    tests and on-edge dot products are the host's float64 expressions (see the pass).
    """
    npair, k, n = len(f.pair_cell), len(f.cells), len(c)
    least = GPU_MIN_REFINE if min_pairs is None else min_pairs
    if npair < least or n == 0:
        return None
    starts = np.searchsorted(f.pair_cell, np.arange(k + 1))
    engine = refine_pass()
    if not engine.fits(k, npair, n, len(arcs.a)):
        return None
    kids = np.zeros((n, 12))
    kids[:, :3] = c
    kids[:, 3] = first
    kids[:, 4], kids[:, 5] = np.cos(first), np.sin(first)
    kids[:, 6], kids[:, 7] = np.cos(seg), np.sin(seg)
    kids[:, 8] = seg
    parents = np.zeros((k, 4))
    parents[:, :3] = f.centers
    got = engine.run(
        starts,
        f.pair_arc,
        slot.T,
        kids,
        parents,
        arc_buffer(_refine_terms(arcs)),
        arc_buffer(arcs.rows),
    )
    if got is None:
        return None
    counts, word, cm, toggles, on_pairs = got
    cell = np.repeat(np.arange(n), counts)
    unsure = np.flatnonzero(word >= REFINE_UNSURE)
    if len(unsure):
        np.bitwise_and(word, REFINE_ARC_MASK, out=word)  # the pass's own array
    arc = word.astype(f.pair_arc.dtype)
    if len(unsure):
        ok = cap_within(cm[unsure], first[cell[unsure]] + arcs.half[arc[unsure]])
        if not ok.all():
            keep = np.ones(len(arc), dtype=bool)
            keep[unsure[~ok]] = False
            cell, arc, cm = cell[keep], arc[keep], cm[keep]
    tc = toggles[:, 0].astype(np.int64)
    ta = (toggles[:, 1] & REFINE_ARC_MASK).astype(np.int64)
    u = np.flatnonzero(toggles[:, 1] & REFINE_NEAR_UNSURE)
    if len(u):
        ok = np.ones(len(tc), dtype=bool)
        ok[u] = cap_within(pair_dots(c, tc[u], arcs.mid, ta[u]), seg[tc[u]] + arcs.half[ta[u]])
        tc, ta = tc[ok], ta[ok]
    on = np.zeros(k, dtype=bool)
    if len(on_pairs):
        op = on_pairs[:, 0].astype(np.int64)
        oa = on_pairs[:, 1].astype(np.int64)
        hit = cap_within(pair_dots(f.centers, op, arcs.mid, oa), arcs.half[oa] + ON_EDGE)
        on[op[hit]] = True
    return cell, arc, cm, (tc, ta), on


def _refine_terms(arcs: CurveArcs) -> np.ndarray:
    """(arcs, 12) float64, read-only, what :func:`gpu_refine_pairs`'s shader reads per
    arc: the cap centre ``m`` and radius ``h``; ``cos h``, ``sin h`` (the ones kept on the
    table, :func:`~gloffset.raster.vector.child_pairs.half_trig`), 1 for a ring edge (else
    0), 0; the normal ``n``, 0 (made once per set of arcs)."""

    def build() -> np.ndarray:
        out = np.zeros((len(arcs.half), 12))
        out[:, :3] = arcs.mid
        out[:, 3] = arcs.half
        out[:, 4], out[:, 5] = half_trig(arcs)
        out[:, 6] = arcs.group >= 0
        out[:, 8:11] = arcs.n
        out.setflags(write=False)
        return out

    return once_attr(arcs, "_refine_terms", build)


def _arc_terms(arcs: CurveArcs) -> np.ndarray:
    """(arcs, 4) float64 ``cos h, sin h, h, 0`` of the arcs' cap radii ``h`` (the cosines and
    sines kept on the table, :func:`~gloffset.raster.vector.child_pairs.half_trig`), read-only
    (made once per set of arcs, what :func:`gpu_box_pairs`'s shader reads; a 1 last
    leaves all the arc's tests to the host)."""

    def build() -> np.ndarray:
        out = np.zeros((len(arcs.half), 4))
        out[:, 0], out[:, 1] = half_trig(arcs)
        out[:, 2] = arcs.half
        out.setflags(write=False)
        return out

    return once_attr(arcs, "_scatter_arc_terms", build)


def _settle(arcs: CurveArcs, cell, word, cm, w: int, row_reach, near):
    """The shader's pairs with the exact cap tests taken where it left them to the host:
    those that fail the row's dropped; and the booleans of the test of ``near`` (None
    without it)."""
    unsure = np.flatnonzero(word >= UNSURE)
    if len(unsure):
        u = (word[unsure] & ARC_MASK).astype(np.int64)
        ok = cap_within(cm[unsure], row_reach[cell[unsure] // w] + arcs.half[u])
        if not ok.all():
            keep = np.ones(len(word), dtype=bool)
            keep[unsure[~ok]] = False
            cell, word, cm = cell[keep], word[keep], cm[keep]
    if near is None:
        return cell, word, cm, None
    ok = (word & NEAR) != 0
    undecided = np.flatnonzero(word & NEAR_UNSURE)
    if len(undecided):
        u = (word[undecided] & ARC_MASK).astype(np.int64)
        ok[undecided] = cap_within(cm[undecided], near[cell[undecided] // w] + arcs.half[u])
    return cell, word, cm, ok


def device_records(
    f: Frontier, arcs: CurveArcs, e: float, passes=None, *, min_pairs=None
) -> tuple[ArcRecords, DeviceRecords] | None:
    """The records of the frontier bins ``f`` at distance ``e`` made on the GL context
    (:mod:`gloffset.gl.records_pass`): the per-bin arrays (records and clusters empty)
    and the buffers; None where numpy makes them (fewer pairs than ``min_pairs``,
    default :data:`GPU_MIN_RECORDS`, or more than one storage buffer of the level passes
    ``passes``, default the process's, holds; :data:`GPU_WARM_SHARE` of it where the
    shaders are compiled already)."""
    npair = len(f.pair_cell)
    if min_pairs is not None:
        least = min_pairs
    elif records_pass_made():
        least = int(GPU_MIN_RECORDS * GPU_WARM_SHARE)
    else:
        least = GPU_MIN_RECORDS
    # the level passes bind the records as one storage buffer (those of vector_pass)
    limit = getattr(vector_passes() if passes is None else passes, "max_records", None)
    if npair < least or limit is None or npair > limit:
        return None
    engine = records_pass()
    inp = record_inputs(f, arcs)
    most = int(inp.n_clusters.max(initial=0))
    if not engine.fits(npair, len(arcs.a), len(inp.ranges), most):
        return None
    dev = engine.run(
        inp.pairs,
        inp.codes,
        f.centers,
        arcs.rows,
        inp.ranges,
        math.sin(e),
        float(chord2(e)),
    )
    empty = ArcRecords(
        np.zeros((0, 6, 4), dtype=np.float32),
        inp.first,
        inp.bits,
        np.zeros((0, 2, 4), dtype=np.uint32),
        inp.first_cluster,
        inp.n_clusters,
    )
    return empty, dev


def bin_plan(layout: BinLayout, d: float, f: Frontier, arcs: CurveArcs, passes=None) -> BinPlan:
    """What the GL passes draw for the frontier bins ``f`` placed by ``layout``, at the
    signed distance ``d``: their records and every level's margins and geometry (the
    records on the GL context where :func:`device_records` makes them, for the level
    passes ``passes``; else in numpy)."""
    e = abs(d)
    made = device_records(f, arcs, e, passes)
    if made is None:
        rec, first, bits, hdr, cfirst, ccount = records(f, arcs, e)
        device = None
    else:
        (rec, first, bits, hdr, cfirst, ccount), device = made
    # each bin's pairs: the records of a bin are its pairs, from its first on (the pairs
    # come by bin), so the steps between the bins' first records, without a count
    counts = np.diff(first, append=np.uint32(len(f.pair_cell))).astype(np.uint32)
    shifts = range(1, layout.stop + 1)
    rho = layout.rho
    plan = BinPlan(
        canvas=layout.canvas(),
        pos=layout.pos(),
        geo=layout.geo,
        last=layout.last,
        stop=layout.stop,
        e=e,
        positive=bool(d >= 0),
        records=rec,
        first=first,
        counts=counts,
        bits=bits,
        clusters=hdr,
        first_cluster=cfirst,
        n_clusters=ccount,
        margins={s: margins(rho[s].ravel(), e).reshape(len(rho[s]), -1, 4) for s in shifts},
        rho_max={s: 0.0 if s == layout.last else float(rho[s].max()) for s in shifts},
        device=device,
    )
    if layout.basis is not None:
        plan.basis, plan.face_size = layout.basis, layout.face_size
    elif layout.glsl is not None:
        assert layout.centre is not None  # a GLSL layout's
        # the bin centres in two float32 parts: their sum has 48 bits of the float64
        hi = layout.centre.astype(np.float32)
        lo = (layout.centre - hi).astype(np.float32)
        plan.bin_centre = layout.canvas_of(hi[:, None, None, :], 0)
        plan.bin_centre_lo = layout.canvas_of(lo[:, None, None, :], 0)
        plan.grid_source, plan.grid_constants = layout.glsl.source, layout.glsl.constants
    elif layout.centre is not None:
        plan.bin_centre = layout.canvas_of(layout.centre[:, None, None, :], 0).astype(np.float32)
        plan.cell_delta = layout.delta_canvas
    else:
        lat, lon = layout.lat, layout.lon
        # a lon/lat layout (no basis) has them all
        assert lat is not None and lon is not None
        assert layout.dphi is not None and layout.dlam is not None
        plan.bin_lat = np.stack([np.cos(lat), np.sin(lat)], axis=-1).astype(np.float32)[None]
        plan.bin_lon = np.stack([np.cos(lon), np.sin(lon)], axis=-1).astype(np.float32)[None]
        plan.dphi = {s: layout.dphi[s].astype(np.float32) for s in shifts}
        plan.dlam = {s: layout.dlam[s].astype(np.float32) for s in shifts}
    return plan


class BinPasses:
    """Runs the levels below the bin level on the GPU (lon/lat grids, cube faces, tiles):
    plans each run (:func:`bin_plan`) and hands it to the GL passes ``passes`` (default:
    the process's :class:`~gloffset.gl.vector_pass.VectorPasses`)."""

    def __init__(self, passes=None):
        self.passes = vector_passes() if passes is None else passes

    def run(
        self,
        grid,
        d: float,
        classes: np.ndarray,
        f: Frontier,
        arcs: CurveArcs,
        *,
        stop_level: int,
        callback=None,
        timings: list | None = None,
        values: np.ndarray | None = None,
    ) -> np.ndarray:
        """Classes of ``stop_level`` from the bin level's ``classes`` and frontier ``f``.

        Only the frontier bins go through the GPU, packed into a small canvas; every other
        cell of the level is its bin's class, filled in here. ``values`` (uint8, indexed
        by class) gives ``values[classes]`` instead, made before the cells are spread out
        (a mask costs no pass over the whole image)."""
        layout = BinLayout.of_grid(grid, f, stop_level)
        bl = f.level
        hb, wb = classes.shape

        def full(s, packed, lut=None):
            """The whole level: bins' classes, with the frontier bins from ``packed``
            (mapped through ``lut`` first, on the small arrays)."""
            b = 1 << s
            h, w = grid.level_shape(bl + s)
            src, blocks = classes, layout.blocks(packed)
            if lut is not None:
                src, blocks = lut[src], lut[blocks]
            # columns spread on the small array, then whole rows copied b times
            out = np.empty((hb * b, wb * b), dtype=np.uint8)
            out.reshape(hb, b, wb * b)[...] = np.repeat(src, b, axis=1)[:, None, :]
            view = out.reshape(hb, b, wb, b).transpose(0, 2, 1, 3)
            view[f.cells[:, 0], f.cells[:, 1]] = blocks
            return out[:h, :w]

        def cb(s, packed):
            callback(bl + s, full(s, packed))

        t: list | None = None if timings is None else []
        packed = self.run_layout(
            layout, d, f, arcs, callback=cb if callback is not None else None, timings=t
        )
        if timings is not None:
            assert t is not None  # a list with timings
            timings += [(bl + s, tt) for s, tt in t]
        return full(layout.stop, packed, values)

    def run_layout(
        self,
        layout: BinLayout,
        d: float,
        f: Frontier,
        arcs: CurveArcs,
        *,
        callback=None,
        timings: list | None = None,
    ) -> np.ndarray:
        """Classes of the canvas at shift ``layout.stop`` (:meth:`BinLayout.blocks` cuts
        out each bin); ``callback(s, classes)`` after each pass."""
        if len(layout.geo) == 0:  # nothing undecided
            hb, wb = layout.canvas().shape
            for s in range(1, layout.stop + 1) if callback is not None else ():
                callback(s, np.zeros((hb << s, wb << s), dtype=np.uint8))
            return np.zeros((hb << layout.stop, wb << layout.stop), dtype=np.uint8)
        plan = bin_plan(layout, d, f, arcs, self.passes)
        return self.passes.run(plan, callback=callback, timings=timings)


def bin_passes() -> BinPasses:
    """The GPU levels of renders, on the process's GL passes (made on first use, with the
    GL context: call it before the CPU levels so that a missing context fails first)."""
    return BinPasses()
