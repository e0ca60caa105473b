"""Multiresolution curves and offsets on the sphere (paper Sec. 4.2, Fig. 5).

Linear/Faber reverse subdivision: one decomposition step keeps every second point
of a curve (subsampling) and stores, for each discarded point ``B`` between kept
neighbours ``A`` and ``C``, the *detail* ``D = B - SLERP(A, C, 1/2)`` (a 3-vector).
Reconstruction inserts ``SLERP(A, C, 1/2) + D`` again. Levels are numbered from the
original curve, ``P[0]``, to the coarsest, ``P[levels]``; ``D[k]`` turns ``P[k]`` back
into ``P[k-1]``, and ``|P[k]| + |D[k]| = |P[k-1]|``.

Pairs of arcs ``A -> B -> C`` become ``A -> C`` (an arc without a partner is carried
over; seams survive at every level; a pair is left alone where merging would break the
bounds below).

Error bounds (paper Sec. 4.3). ``e[k][i]`` bounds the distance from every point of
the original curve between the ends of arc ``i`` of ``P[k]`` to that arc:
``e[0] = 0`` and ``e[k] = max(e_A->B, e_B->C) + dist(B, SLERP(A, C, 1/2))``. This is
rigorous when ``A -> B`` and ``B -> C`` are at most pi/2 long (the distance between
points at the same fraction of two arcs from a common end only grows along them),
which the pairing rule guarantees. Each step adds 2e-15 rad for rounding; bounds
above :data:`E_MAX` are clamped to pi ("unknown": always reconstruct).

Offsets (Sec. 4.2, six steps). The centres ``q_2i = cos(d) p_i`` of a coarse offset lie
on a sphere of radius ``cos(d)``; the same reconstruction with details scaled by
``cos(d)`` gives the vertex centres of the finer offset without restoring the curve,
and the edge centres and junctions follow from Eq. 3 and 4 (:func:`gloffset.vector.offset`).
The derivation in full: ``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidLevelError
from ..geometry.lonlat import MIN_EDGE
from ..geometry.sphere import angle, slerp
from ..shape import Edges, Shape, read
from ..units import EARTH_RADIUS
from .arcrings import line_arcs, ring_arcs
from .offset import Offset, offset

__all__ = ["ArcTree", "Decomposition", "MultiresOffset", "decompose", "full_decomposition", "E_MAX"]

#: Error bounds (rad) above this are clamped to pi: such an arc is always reconstructed
#: (beyond it the error region of an arc need not be a disk).
E_MAX = 0.5
#: Rounding slack (rad) added to an error bound at each level.
_E_SLACK = 2e-15
#: Longest arc (rad) that takes part in a merge, before or after it.
_MAX_ARC = math.pi / 2


@dataclass(frozen=True)
class ArcTree(Edges):
    """Every arc of every level of a decomposition as one binary tree (for queries).

    Nodes ``0 .. len(shape.edges()) - 1`` are the original edges, in the order of
    :meth:`Shape.edges`; every merge of two arcs adds a node. The arcs of level ``k``
    are the nodes of :attr:`Decomposition.level_nodes` ``[k]``. A table of arcs like
    the shape's :class:`~gloffset.shape.Edges`, with what the tree adds.

    Attributes
    ----------
    a, b : (m, 3) float64
        Ends of each arc: original vertices, bit for bit, at every level.
    boundary : (m,) bool
        False for seams (and arcs made of seams only).
    group : (m,) int64
        Region component of ring arcs, -1 for lines and points.
    e : (m,) float64
        Error bound of the arc (0 for original edges, pi for "unknown").
    child : (m, 2) int64
        The two arcs a merged arc replaces (-1, -1 for original edges).
    level : (m,) int64
        Level at which the arc was made (0 for original edges).
    """

    e: np.ndarray
    child: np.ndarray
    level: np.ndarray


@dataclass
class _Level:
    """One level, flat over all parts (rings first, then lines, as in Shape.edges)."""

    pts: np.ndarray  # (n,) int: original vertex (global row of the stacked parts)
    pt_part: np.ndarray  # (n,) int
    node: np.ndarray  # (m,) int: arc -> tree node
    arc_part: np.ndarray  # (m,) int
    seam: np.ndarray  # (m,) bool
    err: np.ndarray  # (m,) float
    merged: np.ndarray | None = None  # (m,) bool: arc has a detail (k >= 1)
    kept: np.ndarray | None = None  # (n_prev,) bool: which points of level k-1 stay
    details: np.ndarray | None = None  # (merged.sum(), 3)


class Decomposition:
    """A shape decomposed into levels ``P[0] .. P[levels]`` with details ``D[1] .. D[levels]``.

    Build with :func:`decompose`. Only the coarsest points ``P[levels]`` and the
    details are needed to reconstruct any level (:meth:`reconstruct`); the error
    bounds :meth:`errors` and the arc tree :attr:`tree` serve the inside/outside
    test (:mod:`gloffset.index.contains`).

    Notes
    -----
    Accuracy: reconstruction is lossless to 1 ulp per coordinate (below 2.3e-16 in
    norm), whatever the number of levels: details are computed coarse to fine from
    the *reconstructed* neighbours, so rounding does not accumulate. A detail
    therefore differs from "discarded point minus the SLERP midpoint of its original
    neighbours" by at most that ulp. Error bounds are rigorous upper bounds (see the
    module notes).
    """

    def __init__(self, shape: Shape, levels: int, *, exhaust: bool = False):
        """Decompose ``shape`` ``levels`` times (with ``exhaust``: until nothing merges)."""
        self.shape = shape
        self._parts = list(shape.rings) + list(shape.lines)
        self._closed = np.array([True] * len(shape.rings) + [False] * len(shape.lines), dtype=bool)
        sizes = np.array([len(p) for p in self._parts], dtype=np.int64)
        self._xyz = np.concatenate(self._parts)
        e = shape.edges()
        n_parts = len(self._parts)
        pt_part = np.repeat(np.arange(n_parts), sizes)
        arc_sizes = np.where(self._closed, sizes, np.maximum(sizes - 1, 1))
        arc_part = np.repeat(np.arange(n_parts), arc_sizes)
        part_group = np.concatenate(
            [shape.ring_groups, np.full(len(shape.lines), -1, dtype=np.int64)]
        )
        self._part_group = part_group
        lv0 = _Level(
            pts=np.arange(len(self._xyz)),
            pt_part=pt_part,
            node=np.arange(len(e)),
            arc_part=arc_part,
            seam=~e.boundary,
            err=np.zeros(len(e)),
        )
        self._levels = [lv0]
        tree = {
            "a": [e.a],
            "b": [e.b],
            "e": [np.zeros(len(e))],
            "child": [np.full((len(e), 2), -1, dtype=np.int64)],
            "level": [np.zeros(len(e), dtype=np.int64)],
            "group": [e.group],
            "boundary": [e.boundary],
        }
        n_nodes = len(e)
        for k in range(1, levels + 1):
            lv, new = self._merge(self._levels[-1], k, n_nodes)
            if exhaust and len(new["a"]) == 0:
                break
            self._levels.append(lv)
            for key, val in new.items():
                tree[key].append(val)
            n_nodes += len(new["a"])
        self.tree = ArcTree(**{key: np.concatenate(val) for key, val in tree.items()})
        self._compute_details()

    # ------------------------------------------------------------------ building
    def _arc_ends(self, lv: _Level):
        """Where the arcs of a level start and end, and the counts per part.

        Positions (into ``lv.pts``) of the start and end point of every arc of a level,
        each arc's index within its part, and the counts of arcs and points per part.
        """
        n_pts = np.bincount(lv.pt_part, minlength=len(self._parts))
        first = np.concatenate([[0], np.cumsum(n_pts)[:-1]])
        n_arcs = np.bincount(lv.arc_part, minlength=len(self._parts))
        arc_first = np.concatenate([[0], np.cumsum(n_arcs)[:-1]])
        part = lv.arc_part
        local = np.arange(len(part)) - arc_first[part]
        start = first[part] + local
        nxt = local + 1
        closed = self._closed[part]
        nxt = np.where(closed, nxt % n_pts[part], np.minimum(nxt, n_pts[part] - 1))
        return start, first[part] + nxt, local, n_arcs, n_pts

    def _merge(self, prev: _Level, k: int, n_nodes: int):
        """One reverse-subdivision step: level k from level k-1 (vectorised over parts)."""
        xyz = self._xyz
        start, end, local, n_arcs, n_pts = self._arc_ends(prev)
        part = prev.arc_part
        # candidate pairs: arcs 2i and 2i+1 of the same part
        first = np.flatnonzero((local % 2 == 0) & (local + 1 < n_arcs[part]))
        second = first + 1
        p = part[first]
        A = xyz[prev.pts[start[first]]]
        B = xyz[prev.pts[end[first]]]
        C = xyz[prev.pts[end[second]]]
        ok = (
            (angle(A, B) <= _MAX_ARC)
            & (angle(B, C) <= _MAX_ARC)
            & (angle(A, C) <= _MAX_ARC)
            & (angle(A, C) > MIN_EDGE)
            & (prev.seam[first] == prev.seam[second])
        )
        # a ring keeps at least 3 points: at most n - 3 merges, the first ones
        closed = self._closed[p]
        ok &= ~closed | (local[first] // 2 < n_pts[p] - 3)
        ok &= n_pts[p] >= 3
        first, second, A, B, C = first[ok], second[ok], A[ok], B[ok], C[ok]
        mid = slerp(A, C, 0.5)
        err = np.maximum(prev.err[first], prev.err[second]) + angle(B, mid) + _E_SLACK
        err = np.where(err > E_MAX, math.pi, err)
        err = np.maximum(err, np.maximum(prev.err[first], prev.err[second]))

        m = len(first)
        new_ids = n_nodes + np.arange(m)
        drop_arc = np.zeros(len(part), dtype=bool)
        drop_arc[second] = True
        node = prev.node.copy()
        node[first] = new_ids
        errs = prev.err.copy()
        errs[first] = err
        merged = np.zeros(len(part), dtype=bool)
        merged[first] = True
        kept = np.ones(len(prev.pts), dtype=bool)
        kept[end[first]] = False
        lv = _Level(
            pts=prev.pts[kept],
            pt_part=prev.pt_part[kept],
            node=node[~drop_arc],
            arc_part=part[~drop_arc],
            seam=prev.seam[~drop_arc],
            err=errs[~drop_arc],
            merged=merged[~drop_arc],
            kept=kept,
        )
        seam = prev.seam[first]
        new = {
            "a": A,
            "b": C,
            "e": err,
            "child": np.column_stack([prev.node[first], prev.node[second]]),
            "level": np.full(m, k, dtype=np.int64),
            "group": self._part_group[p[ok]],
            "boundary": ~seam,
        }
        return lv, new

    def _compute_details(self):
        """Details coarse to fine, from reconstructed neighbours (no rounding build-up)."""
        self._coarse = self._xyz[self._levels[-1].pts].copy()
        rec = self._coarse
        for k in range(self.levels, 0, -1):
            lv = self._levels[k]
            assert lv.kept is not None  # every level k >= 1 has them
            mid = self._midpoints(rec, k)
            lv.details = self._xyz[self._levels[k - 1].pts[~lv.kept]] - mid
            rec = self._refine_level(rec, k, mid=mid)

    def _midpoints(self, rec: np.ndarray, k: int) -> np.ndarray:
        """SLERP midpoints of the ends of the merged arcs of level ``k`` (points ``rec``)."""
        lv = self._levels[k]
        start, end = self._arc_ends(lv)[:2]
        return slerp(rec[start[lv.merged]], rec[end[lv.merged]], 0.5)

    def _refine_level(self, rec: np.ndarray, k: int, scale: float = 1.0, mid=None):
        """Points of level ``k-1`` from those of level ``k``.

        The midpoint of each merged arc plus its detail, inserted. With ``scale``, points
        and details lie on a sphere of that radius (the SLERP of two such vectors is the
        unit SLERP, scaled).
        """
        lv = self._levels[k]
        assert lv.kept is not None and lv.details is not None  # every level k >= 1 has them
        if mid is None:
            mid = scale * self._midpoints(rec, k)
        out = np.empty((len(lv.kept), rec.shape[1]))
        out[lv.kept] = rec
        out[~lv.kept] = mid + scale * lv.details
        return out

    # ------------------------------------------------------------------ access
    @property
    def levels(self) -> int:
        """Number of decomposition steps (the coarsest level)."""
        return len(self._levels) - 1

    def _check_level(self, k) -> int:
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise InvalidLevelError(f"level must be an integer, got {k!r}")
        if not 0 <= k <= self.levels:
            raise InvalidLevelError(
                f"level {k!r} out of range: this decomposition has 0..{self.levels}"
            )
        return int(k)

    def points(self, k: int) -> list[np.ndarray]:
        """``P[k]``: the points of each ring, then each line, at level ``k`` (reconstructed)."""
        k = self._check_level(k)
        return self._split(self._reconstruct(k), self._levels[k].pt_part)

    def details(self, k: int) -> list[np.ndarray]:
        """``D[k]`` (``k >= 1``): the details of each part, in the order of the discarded points."""
        k = self._check_level(k)
        if k == 0:
            raise InvalidLevelError("level 0 is the original curve: details start at level 1")
        lv = self._levels[k]
        assert lv.details is not None  # every level k >= 1 has them
        return self._split(lv.details, lv.arc_part[lv.merged])

    def errors(self, k: int) -> list[np.ndarray]:
        """``e[k]``: error bound (rad, in [0, pi]) of each arc of each part at level ``k``."""
        k = self._check_level(k)
        lv = self._levels[k]
        return self._split(lv.err, lv.arc_part)

    def level_nodes(self, k: int) -> np.ndarray:
        """Tree nodes (rows of :attr:`tree`) that are the arcs of level ``k``."""
        return self._levels[self._check_level(k)].node

    def _split(self, values: np.ndarray, part: np.ndarray) -> list[np.ndarray]:
        counts = np.bincount(part, minlength=len(self._parts))
        return np.split(values, np.cumsum(counts)[:-1])

    def _reconstruct(self, k: int, scale: float = 1.0, top=None, start: int | None = None):
        """Flat points of level ``k`` from those of level ``start`` and the details.

        By default from the coarsest points. With ``scale`` the points (``top``, of
        level ``start``) and the details are taken on a sphere of that radius: this is
        how offset centres are refined (Sec. 4.2, steps 1-4).
        """
        start = self.levels if start is None else start
        rec = self._coarse if top is None else top
        for j in range(start, k, -1):
            rec = self._refine_level(rec, j, scale)
        return rec

    def reconstruct(self, k: int = 0) -> Shape:
        """Return the shape at level ``k``, rebuilt from ``P[levels]`` and the details.

        Rings keep their seams, region components, holes and labels. ``k = 0``
        gives the original points to 1 ulp.
        """
        k = self._check_level(k)
        lv = self._levels[k]
        parts = self._split(self._reconstruct(k), lv.pt_part)
        nr = len(self.shape.rings)
        seams = self._split(lv.seam, lv.arc_part)[:nr]
        return Shape(
            rings=parts[:nr],
            ring_seams=seams,
            ring_groups=self.shape.ring_groups.copy(),
            ring_holes=self.shape.ring_holes.copy(),
            lines=parts[nr:],
            labels=list(self.shape.labels),
        )

    # ------------------------------------------------------------------ offsets
    def offset(self, distance: float, level: int, *, radius: float = EARTH_RADIUS):
        """Return the coarse offset of the level-``level`` curve (Sec. 4.1 on ``P[level]``).

        Returns a :class:`MultiresOffset`, which :meth:`MultiresOffset.refine` takes to
        any finer level from its centres and the details alone.
        """
        level = self._check_level(level)
        shape = self.reconstruct(level)
        base = offset(shape, distance, radius=radius)
        out = MultiresOffset(self, level, base.distance, base.rings)
        out._shape = shape
        out.given, out.radius = base.given, base.radius  # what to_geojson names
        return out

    def __repr__(self) -> str:
        sizes = [len(lv.pts) for lv in self._levels]
        return f"Decomposition({self.levels} levels, points per level {sizes})"


class MultiresOffset(Offset):
    """The offset of one level of a :class:`Decomposition`, refinable to finer levels.

    Attributes
    ----------
    decomposition : Decomposition
    level : int
        The level of the curve this offset belongs to.
    """

    def __init__(self, decomposition, level, d, rings):
        self.decomposition = decomposition
        self.level = level
        self.distance = d
        self.rings = rings
        self._shape = None

    @property
    def shape(self) -> Shape:
        """The curve of this level (reconstructed on first use; the refinement needs none)."""
        if self._shape is None:
            self._shape = self.decomposition.reconstruct(self.level)
        return self._shape

    @shape.setter
    def shape(self, value: Shape) -> None:
        self._shape = value

    def vertex_centers(self) -> np.ndarray:
        """Step 1 of Sec. 4.2: the centres ``q_2i = cos(d) p_i`` of this offset, flat over parts.

        They are read from the arcs (the first arc of each run of vertex arcs);
        a line's offset runs along it and back, so only its forward half is taken.
        """
        dec = self.decomposition
        n_pts = np.bincount(dec._levels[self.level].pt_part, minlength=len(dec._parts))
        out = []
        rings = iter(self.rings)
        for p, closed in enumerate(dec._closed):
            if not closed and self.distance <= 0.0:
                # lines have no inward offset: their slots are carried as zeros
                out.append(np.zeros((n_pts[p], 3)))
                continue
            ring = next(rings)
            if n_pts[p] == 1:  # an isolated point: a circle about q = cos(d) p
                out.append(ring.centers[:1])
                continue
            run = (ring.kind == 0) & (np.roll(ring.kind, 1) != 0)
            out.append(ring.centers[run][: n_pts[p]])
        return np.concatenate(out)

    def refine(self, level: int) -> MultiresOffset:
        """Return the offset at a finer ``level``, from this offset's centres and the details.

        The six steps of Sec. 4.2: take the vertex centres ``q_2i`` (step 1), apply the
        reconstruction with details scaled by ``cos(d)`` level by level (steps 2-4),
        then recompute the edge centres by Eq. 3 and the junctions by Eq. 4 (steps 5,
        6, with the same code as :func:`gloffset.vector.offset`, including its extra
        junctions on arcs that turn by more than 2 rad).

        Notes
        -----
        Accuracy: the centres and junctions equal those of
        ``gloffset.offset(decomposition.reconstruct(level), d)`` to 1e-15 (both come
        from the same points up to the reconstruction's ulp).
        """
        dec = self.decomposition
        level = dec._check_level(level)
        if level > self.level:
            raise InvalidLevelError(
                f"cannot refine a level-{self.level} offset to the coarser level {level}"
            )
        d = self.distance
        c = math.cos(d)
        if self.level == level:
            return self
        nr = len(dec.shape.rings)
        q = dec._reconstruct(level, scale=c, top=self.vertex_centers(), start=self.level)
        parts = dec._split(q / c, dec._levels[level].pt_part)
        rings = [ring_arcs(p, d) for p in parts[:nr]]
        if d > 0.0:
            rings += [line_arcs(p, d) for p in parts[nr:]]
        return MultiresOffset(dec, level, d, rings)


def full_decomposition(shape: Shape) -> Decomposition:
    """Return the shape's decomposition as far as arcs merge (``exhaust``), made once per shape.

    What the inside-test index (:mod:`gloffset.index.contains`) and the renders from
    simplified curves (:mod:`gloffset.raster.simplified`) share.
    """
    return shape.derived.once("exhaust", lambda: Decomposition(shape, 64, exhaust=True))


def decompose(shape, levels: int) -> Decomposition:
    """Decompose a shape into ``levels`` coarser levels (linear/Faber reverse subdivision).

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
    levels : int
        Number of reverse-subdivision steps (>= 0). Each step about halves the
        points of every ring and line; a part that cannot shrink further (a ring of
        3 points, a line of 2, a point) stays as it is.

    Returns
    -------
    Decomposition
        ``P[k]``, ``D[k]`` and ``e[k]`` for ``k = 0 .. levels`` (see the module notes for
        rings of odd and even length, lines, points and seams).

    Notes
    -----
    Accuracy: ``reconstruct(0)`` returns the original points to 1 ulp (lossless);
    the error bounds ``e[k]`` are rigorous (module notes).

    Examples
    --------
    >>> import gloffset
    >>> zigzag = [[0, 0], [1, 1], [2, 0], [3, 1], [4, 0]]
    >>> s = gloffset.read({"type": "LineString", "coordinates": zigzag})
    >>> dec = gloffset.decompose(s, 2)
    >>> [len(p[0]) for p in (dec.points(0), dec.points(1), dec.points(2))]
    [5, 3, 2]
    >>> bool(abs(dec.reconstruct(0).lines[0] - s.lines[0]).max() < 1e-15)
    True
    """
    shape = read(shape)
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 0:
        raise InvalidLevelError(f"levels must be a non-negative integer, got {levels!r}")
    return Decomposition(shape, int(levels))
