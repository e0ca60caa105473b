"""The arc records of the frontier bins, packed in float64 for the GPU levels (pure numpy).

Below the bin level the GL passes (:mod:`gloffset.gl.vector_pass`, ``shaders/classify.frag``)
classify the cells of the frontier bins. For every bin they read its candidate arcs as
records computed in float64 *relative to the bin centre* and then cast to float32
(:func:`records`; ``shaders/lib/arcs.glsl`` lists the six texels), the inside status of
each region component at the bin centre as bits, and per cell row the margins
``sin(x) - sin(e)`` and ``chord(x)^2 - chord(e)^2`` of the distances ``x`` the decisions
compare with (:func:`margins`). The shader then only adds small float32 terms to small
float64-made numbers, so near the offset boundary its answer is exact to a few float32
ulp of the bin's size, not of the unit sphere.

A bin's records come in *clusters*: runs of up to :data:`CLUSTER` arcs that follow each
other along a ring, each with a header bounding them by a ball around the bin centre, so
that a cell skips, with a handful of operations, the clusters that provably cannot change
its class (``shaders/classify.frag``). The constants below are those of the shaders'
record format (``tests/test_layers.py`` compares them).

For many pairs a render makes the records on the GL context instead
(:mod:`gloffset.gl.records_pass`, ``shaders/arc_records.comp``): the host keeps the integer
part (:func:`record_inputs`: the pairs, the component ids and status bits, the clusters'
runs), the shader the float words, with these functions' bits.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..edges import CurveArcs
from ..errors import GLContextError
from ..geometry.caps import CAP_SLACK, cap_range, chord2
from ..geometry.sphere import dot, einsum_dot
from ..memo import once_attr
from .vector.levels import Frontier

__all__ = [
    "ARC_HAS_DISTANCE",
    "ARC_IS_ARC",
    "ARC_RING",
    "ArcRecords",
    "RecordInputs",
    "CLUSTER",
    "MAX_LOCAL",
    "OTHER_BIT",
    "RECORD_TEXELS",
    "margins",
    "record_inputs",
    "records",
]

RECORD_TEXELS = 6  # vec4 texels per record (shaders/classify.frag, lib/arcs.glsl)
MAX_LOCAL = 30  # components with their own status bit per bin; more share bit 30
OTHER_BIT = 31  # set when the bin centre is inside a component with no arc in the bin
ARC_IS_ARC, ARC_HAS_DISTANCE, ARC_RING = 1, 2, 4  # record flags (lib/arcs.glsl)
CLUSTER = 8  # records per cluster at most (shaders/classify.frag); 8 and 16 cull about alike
_DENSE = 1 << 22  # (bin, component) keys counted in a dense table up to this many
_BLOCK = 4096  # pairs per block of float64 work in records()
_F32_TINY = float(np.finfo(np.float32).tiny)  # least positive normal float32
_POPCOUNT = np.unpackbits(np.arange(256, dtype=np.uint8)[:, None], axis=1).sum(axis=1)


class ArcRecords(NamedTuple):
    """The records of the frontier bins and their clusters (:func:`records`)."""

    records: np.ndarray  # (pairs, RECORD_TEXELS, 4) float32, by bin
    first: np.ndarray  # (k,) uint32: each bin's first record
    bits: np.ndarray  # (k,) uint32: the status bits at the bin centres
    clusters: np.ndarray  # (m, 2, 4) uint32: the cluster headers
    first_cluster: np.ndarray  # (k,) uint32: each bin's first cluster
    n_clusters: np.ndarray  # (k,) uint32: each bin's clusters


class RecordInputs(NamedTuple):
    """What the records' compute shader takes (:func:`record_inputs`), and the per-bin
    arrays the level passes read beside its records."""

    pairs: np.ndarray  # (pairs, 2) uint32: bin, arc (by bin)
    codes: np.ndarray  # (pairs,) int64: flags + 8 * local component id
    first: np.ndarray  # (k,) uint32: each bin's first record
    bits: np.ndarray  # (k,) uint32: the status bits at the bin centres
    ranges: np.ndarray  # (m, 4) int64: per cluster its first record, records, its bin's clusters
    first_cluster: np.ndarray  # (k,) uint32
    n_clusters: np.ndarray  # (k,) uint32


def record_inputs(f: Frontier, arcs: CurveArcs, cluster: int = CLUSTER) -> RecordInputs:
    """The integer part of :func:`records`, for the records made on the GPU
    (:mod:`gloffset.gl.records_pass`): the pairs by bin with their codes, the status bits,
    and the clusters (the same runs as :func:`records`'s; their order within a bin, by
    ``Dmin``, is the shader's to make)."""
    if not 1 <= cluster <= 16:
        raise ValueError(f"cluster must be 1..16, got {cluster}")
    ci, ai = _pairs(f)
    k = len(f.cells)
    code = np.take(_arc_codes(arcs)[2], ai)
    _, bits = _components(f, arcs, ci, ai, code)
    cfirst, csize = _cluster_starts(ci, ai, cluster)
    cbin = ci[cfirst]
    bins = np.arange(k)
    first_cluster = np.searchsorted(cbin, bins)
    end = np.searchsorted(cbin, bins, side="right")
    ranges = np.column_stack([cfirst, csize, first_cluster[cbin], end[cbin]])
    pairs = np.empty((len(ci), 2), dtype=np.uint32)  # what the shader reads
    pairs[:, 0] = ci
    pairs[:, 1] = ai
    return RecordInputs(
        pairs,
        code,
        np.searchsorted(ci, bins).astype(np.uint32),
        bits.astype(np.uint32),
        ranges,
        first_cluster.astype(np.uint32),
        (end - first_cluster).astype(np.uint32),
    )


def records(f: Frontier, arcs: CurveArcs, e: float, cluster: int = CLUSTER) -> ArcRecords:
    """Arc records and their clusters for the frontier bins ``f`` (``shaders/lib/arcs.glsl``).

    Returns ``(rec, first, bits, clusters, first_cluster, n_clusters)``: ``rec``
    (pairs, 6, 4) float32, the records of the candidate pairs in their order (by bin);
    ``first`` (k,) uint32, the first record of each bin; ``bits`` (k,) uint32, the
    status bits at the bin centres; ``clusters`` (m, 2, 4) uint32, the cluster headers
    (float32 bits, and ``16 * first record + records - 1`` last); ``first_cluster`` and
    ``n_clusters`` (k,) uint32, each bin's clusters, in increasing order of their
    nearest record ``Dmin``.

    A cluster is a run of up to ``cluster`` (<= 16) pairs of one bin whose arcs follow
    each other along a ring (consecutive arc indices); its header bounds them by a ball
    around the bin centre. All terms are computed in float64 relative to the bin centre
    ``c`` before the cast, in blocks of pairs (small temporaries, reused).
    """
    if not 1 <= cluster <= 16:
        raise ValueError(f"cluster must be 1..16, got {cluster}")
    ci, ai = _pairs(f)
    k, npair = len(f.cells), len(ci)
    out, code, cols = _arc_terms(f, arcs, ci, ai, e)
    code += np.take(_arc_codes(arcs)[1], ai)
    ring, bits = _components(f, arcs, ci, ai, code)
    out[:, 1] = code
    hdr, first_cluster, n_clusters = _clusters(cols, ci, ai, ring, k, cluster)
    first = np.searchsorted(ci, np.arange(k)).astype(np.uint32)
    return ArcRecords(
        out.reshape(npair, RECORD_TEXELS, 4),
        first,
        bits.astype(np.uint32),
        hdr,
        first_cluster.astype(np.uint32),
        n_clusters.astype(np.uint32),
    )


def _pairs(f: Frontier) -> tuple[np.ndarray, np.ndarray]:
    """The candidate pairs (bin, arc) of ``f``, sorted by bin (as they come, if they do)."""
    ci = np.asarray(f.pair_cell, dtype=np.int64)
    ai = np.asarray(f.pair_arc, dtype=np.int64)
    if np.any(ci[1:] < ci[:-1]):  # pairs come sorted by cell; keep to that
        perm = np.argsort(ci, kind="stable")
        ci, ai = ci[perm], ai[perm]
    if len(ci) >= 1 << 28:
        raise GLContextError(f"{len(ci)} candidate pairs: too many for one render")
    return ci, ai


def _arc_terms(f: Frontier, arcs: CurveArcs, ci, ai, e: float):
    """The records' float terms, (pairs, 24) float32 (word 1, the code, left to fill);
    the code's first flag (:data:`ARC_IS_ARC`); and (8, pairs) float32 copies of the
    words ``t0.x``, ``t0.z``, ``t4.xyz`` and ``t5.xyz`` for the clusters.

    Made in float64 in blocks of pairs, coordinate by coordinate (rows of
    :attr:`CurveArcs.columns` and of the centres), then cast once per block. Dot products
    are :func:`gloffset.geometry.sphere.dot` or :func:`gloffset.geometry.sphere.einsum_dot` of the
    rows (as ``.T`` views): the records' bits are those of the (pairs, 3) computation.
    """
    npair = len(ci)
    se = math.sin(e)
    chord_e = float(chord2(e))
    out = np.empty((npair, RECORD_TEXELS * 4), dtype=np.float32)  # cast on assignment
    code = np.empty(npair, dtype=np.int64)
    cols = np.empty((8, npair), dtype=np.float32)
    arc_rows = arcs.columns
    center_rows = np.ascontiguousarray(f.centers.T, dtype=np.float64)
    w = np.empty((RECORD_TEXELS * 4, min(_BLOCK, npair)))
    for s0 in range(0, npair, _BLOCK):
        s1 = min(s0 + _BLOCK, npair)
        m = s1 - s0
        c = np.take(center_rows, ci[s0:s1], axis=1)
        g = np.take(arc_rows, ai[s0:s1], axis=1)
        a, b, n, w1, w2, mid, half = g[0:3], g[3:6], g[6:9], g[9:12], g[12:15], g[15:18], g[18]
        t = w[:, :m]
        ea, eb = t[16:19], t[20:23]
        np.subtract(c, a, out=ea)
        np.subtract(c, b, out=eb)
        is_arc = dot(n.T, n.T) > 0.5  # n is a unit vector or zero
        # D: a lower bound on the distance from c to the arc, by its bounding cap
        d = cap_range(dot(c.T, mid.T), half)[0] - CAP_SLACK
        np.maximum(d, 0.0, out=d)
        h = dot(c.T, n.T)
        t[0] = d * (1.0 - 1e-7)  # rounded down: still a lower bound after the cast
        t[1] = 0.0
        t[2] = np.where((h < 0.0) & (h > -_F32_TINY), -_F32_TINY, h)
        t[3] = -h - se
        t[4:7] = n
        t[7] = h - se
        t[8:11] = w1
        t[11] = einsum_dot(c.T, w1.T)
        t[12:15] = w2
        t[15] = einsum_dot(c.T, w2.T)
        t[19] = chord_e - einsum_dot(ea.T, ea.T)
        t[23] = chord_e - einsum_dot(eb.T, eb.T)
        out[s0:s1] = t.T
        cols[0:2, s0:s1] = t[0:3:2]
        cols[2:5, s0:s1] = ea
        cols[5:8, s0:s1] = eb
        code[s0:s1] = np.where(is_arc, ARC_IS_ARC, 0)
    return out, code, cols


def _components(f: Frontier, arcs: CurveArcs, ci, ai, code: np.ndarray):
    """Completes ``code`` (in place; the arcs' codes, :func:`_arc_codes`'s flags and id 31):
    flags + 8 * local component id (31 for arcs of no ring, at most :data:`MAX_LOCAL`).
    Returns which pairs are ring edges and the status
    bits at the bin centres (uint64, :data:`OTHER_BIT` for the components without an arc
    in the bin)."""
    k = len(f.cells)
    group = np.take(arcs.group, ai)
    ring = group >= 0
    ng = arcs.n_groups
    bits = np.zeros(k, dtype=np.uint64)
    # components the centre is inside: popcount of the first max(ng, 1) status bits
    width = np.clip(max(ng, 1) - 8 * np.arange(f.status.shape[1]), 0, 8)
    n_inside = _POPCOUNT[f.status & ((1 << width) - 1).astype(np.uint8)].sum(axis=1)
    if ring.any():
        every = bool(ring.all())  # polygons only: no mask to apply
        key = ci * ng + group if every else ci[ring] * ng + group[ring]  # (bin, component)
        # runs of one key (a bin's pairs come by arc, and a ring's arcs follow each other):
        # the keys of the runs are ranked, far fewer than those of the pairs
        new = np.empty(len(key), dtype=bool)
        new[:1] = True
        np.not_equal(key[1:], key[:-1], out=new[1:])
        first = np.flatnonzero(new)
        rkey = key[first]
        size = np.diff(np.append(first, len(key)))  # each run's pairs
        if k * ng <= _DENSE:
            present = np.zeros(k * ng, dtype=bool)
            present[rkey] = True
            ukey = np.flatnonzero(present)
            lut = np.empty(k * ng, dtype=np.int64)
            lut[ukey] = np.arange(len(ukey))
            rinv = lut[rkey]
        else:
            ukey, rinv = _unique_inverse(rkey)
        ubin, ugrp = ukey // ng, ukey % ng
        rank = np.minimum(np.arange(len(ukey)) - np.searchsorted(ubin, ubin), MAX_LOCAL)
        shift = np.take(8 * (rank - 31), rinv)  # per run of one key
        if every:
            code += np.repeat(shift, size)
        else:
            code[ring] += np.repeat(shift, size)
        inside_g = ((f.status[ubin, ugrp >> 3] >> (ugrp & 7).astype(np.uint8)) & 1) == 1
        np.bitwise_or.at(bits, ubin[inside_g], np.uint64(1) << rank[inside_g].astype(np.uint64))
        # inside a component that has no arc here: one shared bit
        other = n_inside > np.bincount(ubin[inside_g], minlength=k)
    else:
        other = n_inside > 0
    bits |= np.where(other, np.uint64(1) << np.uint64(OTHER_BIT), np.uint64(0))
    return ring, bits


def _arc_codes(arcs: CurveArcs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per arc, the parts of a pair's code that depend on the arc alone: its flag
    :data:`ARC_IS_ARC` (``n`` a unit vector, not zero: the test of :func:`_arc_terms`);
    its flags :data:`ARC_RING` and :data:`ARC_HAS_DISTANCE` and the local id 31 (``+ 8 *
    31``), which :func:`_components` then lowers for ring edges; and their sum (made once
    per set of arcs)."""

    def build() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        is_arc = np.where(dot(arcs.n, arcs.n) > 0.5, ARC_IS_ARC, 0).astype(np.int64)
        rest = (
            np.where(arcs.group >= 0, ARC_RING, 0)
            + np.where(arcs.boundary, ARC_HAS_DISTANCE, 0)
            + 8 * 31
        ).astype(np.int64)
        both = is_arc + rest
        for a in (is_arc, rest, both):
            a.setflags(write=False)
        return is_arc, rest, both

    return once_attr(arcs, "_record_codes", build)


def _unique_inverse(key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(key, return_inverse=True)`` for keys that come nearly sorted (the
    (bin, component) keys of pairs by bin, then arc: components follow the arcs): a
    stable sort, which is a merge of sorted runs there, instead of a quicksort (about
    20 times faster for a million pairs)."""
    order = np.argsort(key, kind="stable")
    sk = key[order]
    new = np.empty(len(sk), dtype=bool)
    new[:1] = True
    np.not_equal(sk[1:], sk[:-1], out=new[1:])
    inv = np.empty(len(key), dtype=np.int64)
    inv[order] = np.cumsum(new) - 1
    return sk[new], inv


def _clusters(cols: np.ndarray, ci, ai, ring, k: int, cluster: int):
    """The cluster headers (m, 2, 4) uint32 of the records whose words ``t0.x``, ``t0.z``,
    ``t4.xyz``, ``t5.xyz`` are the rows of ``cols`` (8, pairs) float32, each bin's by
    increasing ``Dmin``; and each bin's first cluster and cluster count.

    A cluster is a run of consecutive arcs of a bin, cut every ``cluster`` pairs.
    """
    cfirst, csize = _cluster_starts(ci, ai, cluster)
    q32, rho32, s32 = _balls(cols[2:5], cols[5:8], cfirst, csize)
    dmin = np.minimum.reduceat(cols[0], cfirst)  # the smallest t0.x, exactly
    hmin = np.minimum.reduceat(np.where(ring, np.abs(cols[1]), np.float32(np.inf)), cfirst)

    # A bin's clusters by Dmin: the key is the float32 value itself (nonnegative, so
    # its bits sort as integers), so the shader's break on Dmin > skip is exact.
    cbin = ci[cfirst]
    corder = np.argsort((cbin << 32) | dmin.view(np.uint32), kind="stable")
    hdr = np.empty((len(cfirst), 2, 4), dtype=np.float32)
    hdr[:, 0, :3] = q32
    hdr[:, 0, 3] = rho32
    hdr[:, 1, 0] = dmin
    hdr[:, 1, 1] = hmin
    hdr[:, 1, 2] = s32
    hdr = hdr.view(np.uint32)
    hdr[:, 1, 3] = 16 * cfirst + csize - 1
    hdr = np.take(hdr, corder, axis=0)
    bins = np.arange(k)
    cb = cbin[corder]
    first_cluster = np.searchsorted(cb, bins)
    n_clusters = np.searchsorted(cb, bins, side="right") - first_cluster
    return hdr, first_cluster, n_clusters


def _cluster_starts(ci, ai, cluster: int) -> tuple[np.ndarray, np.ndarray]:
    """The first pair and the size of each cluster: runs of consecutive arcs of a bin,
    cut every ``cluster`` pairs (made from the runs: far fewer than the pairs)."""
    npair = len(ci)
    start = np.ones(npair, dtype=bool)
    np.not_equal(ci[1:], ci[:-1], out=start[1:])
    start[1:] |= ai[1:] != ai[:-1] + 1
    run_first = np.flatnonzero(start)
    run_end = np.append(run_first[1:], npair)[: len(run_first)]  # none without pairs
    per = (run_end - run_first + (cluster - 1)) // cluster  # clusters per run
    first = np.repeat(run_first, per)
    # each cluster's place in its run, times the cluster size
    first += cluster * (np.arange(len(first)) - np.repeat(np.cumsum(per) - per, per))
    return first, np.minimum(np.repeat(run_end, per) - first, cluster)


def _balls(t4: np.ndarray, t5: np.ndarray, cfirst: np.ndarray, csize: np.ndarray):
    """Per cluster (records ``cfirst`` .. ``+ csize``), float32 ``(Q, rho, S)``: the
    ball around the bin centre ``c`` that holds every point of its arcs, and ``S >=
    |Q| + rho``; ``t4``, ``t5`` (3, pairs) float32 are the records' words ``t4.xyz`` and
    ``t5.xyz``, coordinate by coordinate.

    A short arc lies in the ball of centre (a + b) / 2 and radius |a - b| / 2. The offsets
    A = a - c, B = b - c are taken from the records: -t4, -t5 are within 6e-8 |A|, 6e-8
    |B| of them (float64 rounding of c - a, then float32), so the arc lies in the ball of
    centre -(t4 + t5) / 2 and radius |t4 - t5| / 2 + 1.2e-7 (|t4| + |t5|). Q is the centre
    of the box of the -t4, -t5 (exact in float32); rho, computed in float64, is widened by
    far more than its rounding (1e-9 relative) and by Q's float32 rounding, then rho and
    S = |Q| + rho are rounded up to float32.
    """
    npair, m = t4.shape[1], len(cfirst)
    cid = np.repeat(np.arange(m), csize)
    q = np.empty((m, 3))
    for j in range(3):
        lo = np.minimum.reduceat(np.minimum(t4[j], t5[j]), cfirst)
        hi = np.maximum.reduceat(np.maximum(t4[j], t5[j]), cfirst)
        q[:, j] = -0.5 * (lo.astype(np.float64) + hi)
    q_rows = np.ascontiguousarray(q.T)
    r = np.empty(npair)
    for s0 in range(0, npair, _BLOCK):
        sl = slice(s0, min(s0 + _BLOCK, npair))
        u, v = t4[:, sl].astype(np.float64), t5[:, sl].astype(np.float64)
        dm = np.take(q_rows, cid[sl], axis=1)
        dm += 0.5 * (u + v)  # Q - centre
        uv = u - v
        u, v, dm, uv = u.T, v.T, dm.T, uv.T  # (k, 3) views for dot
        lu, lv = np.sqrt(dot(u, u)), np.sqrt(dot(v, v))
        r[sl] = np.sqrt(dot(dm, dm)) + 0.5 * np.sqrt(dot(uv, uv)) + 1.2e-7 * (lu + lv)
    rho = np.maximum.reduceat(r, cfirst) if m else np.zeros(0)
    q32 = q.astype(np.float32)
    dq = q - q32
    rho32 = _round_up((rho + np.sqrt(dot(dq, dq))) * (1.0 + 1e-9) + 1e-30)
    q64 = q32.astype(np.float64)
    s32 = _round_up((np.sqrt(dot(q64, q64)) + rho32) * (1.0 + 1e-9))
    return q32, rho32, s32


def _round_up(x: np.ndarray) -> np.ndarray:
    """float32 values >= the float64 values ``x``."""
    y = x.astype(np.float32)
    return np.where(y < x, np.nextafter(y, np.float32(np.inf)), y)


def margins(rho: np.ndarray, e: float) -> np.ndarray:
    """(rows, 2, 4) float32: (mu_lo, mu_hi, mu_rho) and (nu_lo, nu_hi, nu_rho) per row of
    cells with bound ``rho``: ``sin(x) - sin(e)`` and ``chord(x)^2 - chord(e)^2`` for
    ``x = e - rho`` (a "never" value where negative), ``e + rho`` and ``rho``."""
    se, ce = math.sin(e), float(chord2(e))
    lo, hi = e - rho, e + rho
    out = np.zeros((len(rho), 2, 4))
    never = -1e30
    out[:, 0, 0] = np.where(lo >= 0, np.sin(np.clip(lo, 0, math.pi / 2)) - se, never)
    out[:, 0, 1] = np.sin(np.minimum(hi, math.pi / 2)) - se
    out[:, 0, 2] = np.sin(np.minimum(rho, math.pi / 2)) - se
    out[:, 1, 0] = np.where(lo >= 0, chord2(lo) - ce, never)
    out[:, 1, 1] = chord2(hi) - ce
    out[:, 1, 2] = chord2(rho) - ce
    return out.astype(np.float32)
