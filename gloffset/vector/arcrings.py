"""Offset rings made of small-circle arcs (paper Sec. 4.1, Eq. 1-4) and their sampling.

For a closed path ``p_0 .. p_{n-1}`` with right-hand normals
``n_i = (p_{i+1} x p_i) / |p_{i+1} x p_i|`` the offset at signed angular distance ``d``
is a cycle of small-circle arcs (:func:`ring_arcs`):

* around each vertex, centre ``q_{2i} = cos(d) p_i`` (Eq. 2), the round join;
* along each edge, centre ``q_{2i+1} = sin(d) n_i`` (Eq. 3);
* consecutive arcs meet at the junctions ``r = q_k + q_{k+1}`` (Eq. 4), and the
  points of arc ``k`` are ``SLERP(r_{k-1} - q_k, r_k - q_k, t) + q_k`` (Eq. 1).

A line is offset on both sides as the closed path that runs along it and back, which
gives round caps at its ends (:func:`line_arcs`); an isolated point gives a circle. An
arc that would turn by more than :data:`_MAX_SWEEP` (a cap turns by pi, where SLERP is
undefined) is split at its middle by an extra junction on the same circle, so Eq. 1 is
always well conditioned. :class:`ArcRings` is what holds rings of arcs (a raw
:class:`~gloffset.vector.offset.Offset`, a resolved offset) and samples them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import InvalidDistanceError
from ..geometry.sphere import normalize, robust_cross, rotate, slerp

__all__ = [
    "ArcRings",
    "DEFAULT_TOLERANCE",
    "OffsetRing",
    "line_arcs",
    "ring_arcs",
    "sample_arc",
    "sample_ring",
    "sample_rings",
]

#: Largest turn (radians) of one arc; longer arcs get an extra junction at their middle.
_MAX_SWEEP = 2.0
#: Default densification tolerance in radians (6.4 m on the Earth).
DEFAULT_TOLERANCE = 1e-6


@dataclass
class OffsetRing:
    """One closed cycle of small-circle arcs.

    Arc ``k`` runs from ``junctions[k-1]`` to ``junctions[k]`` on the circle of centre
    ``centers[k]``; ``sources[k]`` is the generating vertex (``kind[k] == 0``, then
    ``sources[k, 0] == sources[k, 1]``) or edge (``kind[k] == 1``).
    """

    centers: np.ndarray
    junctions: np.ndarray
    kind: np.ndarray
    sources: np.ndarray  # (m, 2, 3)

    def reversed(self) -> OffsetRing:
        """The same cycle run the other way (what lay on its right now lies on its left)."""
        return OffsetRing(
            self.centers[::-1].copy(),
            np.roll(self.junctions[::-1], -1, axis=0),
            self.kind[::-1].copy(),
            self.sources[::-1].copy(),
        )


def ring_arcs(path: np.ndarray, d: float, *, cap_ends: tuple[int, ...] = ()) -> OffsetRing:
    """Offset arcs of the closed path ``path`` (n, 3) at signed distance ``d``.

    Per vertex ``i`` four slots, in order: the middle of the round join (only when
    it turns by more than :data:`_MAX_SWEEP`, or a cap), the end of the join, the
    middle of the edge arc (only for edges longer than :data:`_MAX_SWEEP`) and the
    end of the edge arc.
    """
    n = len(path)
    nxt = np.roll(path, -1, axis=0)
    u1 = normalize(robust_cross(nxt, path))  # right-hand normals n_i
    u0 = np.roll(u1, 1, axis=0)  # normal of the edge arriving at p_i
    cd, sd = math.cos(d), math.sin(d)
    q_pt = cd * path  # Eq. 2
    q_edge = sd * u1  # Eq. 3
    c = np.sum(u0 * u1, axis=1)
    s = np.sum(path * np.cross(u0, u1), axis=1)
    turn = np.arctan2(s, c)
    is_cap = np.zeros(n, dtype=bool)
    is_cap[list(cap_ends)] = True
    cap = (c < 0.0) & (is_cap | (np.abs(s) < 1e-12))
    split_join = cap | (np.abs(turn) > _MAX_SWEEP)
    mid_dir = np.where(cap[:, None], normalize(np.cross(path, u0)), rotate(u0, path, 0.5 * turn))
    length = np.arctan2(np.linalg.norm(np.cross(path, nxt), axis=1), np.sum(path * nxt, axis=1))
    split_edge = length > _MAX_SWEEP
    mid_pt = slerp(path, nxt, 0.5)

    centers = np.stack([q_pt, q_pt, q_edge, q_edge], axis=1)
    junctions = np.stack(
        [q_pt + sd * mid_dir, q_pt + q_edge, cd * mid_pt + q_edge, cd * nxt + q_edge], axis=1
    )  # the second and last slots are Eq. 4: r = q_k + q_{k+1}
    kind = np.broadcast_to(np.array([0, 0, 1, 1], dtype=np.int8), (n, 4))
    src_a = np.broadcast_to(path[:, None, :], (n, 4, 3))
    src_b = np.stack([path, path, nxt, nxt], axis=1)
    used = np.column_stack([split_join, np.ones(n, bool), split_edge, np.ones(n, bool)])
    return OffsetRing(
        centers[used],
        junctions[used],
        kind[used],
        np.stack([src_a[used], src_b[used]], axis=1),
    )


def _circle(p: np.ndarray, d: float) -> OffsetRing:
    """A point's offset: a full circle as three arcs, counter-clockwise about ``p``."""
    e1 = normalize(np.cross(p, [0.0, 0.0, 1.0] if abs(p[2]) < 0.9 else [1.0, 0.0, 0.0]))
    e2 = np.cross(p, e1)
    q = math.cos(d) * p
    ang = 2.0 * np.pi * np.arange(1, 4) / 3.0
    r = q + math.sin(d) * (np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2)
    src = np.broadcast_to(p, (3, 2, 3)).copy()
    return OffsetRing(np.tile(q, (3, 1)), r, np.zeros(3, dtype=np.int8), src)


def line_arcs(line: np.ndarray, d: float) -> OffsetRing:
    """A line's offset (``d > 0``): the path along it and back, with round caps at its ends;
    an isolated point gives a circle."""
    if len(line) == 1:
        return _circle(line[0], d)
    there_and_back = np.vstack([line, line[-2:0:-1]])
    return ring_arcs(there_and_back, d, cap_ends=(0, len(line) - 1))


def sample_arc(center, start, end, t) -> np.ndarray:
    """Points of the small-circle arc from ``start`` to ``end`` about ``center`` (Eq. 1).

    ``t`` in [0, 1]; the arc turns the short way (less than pi). Points lie on the
    unit sphere and on the circle to about 1e-16.
    """
    rad = np.linalg.norm(start - center, axis=-1, keepdims=True)
    return slerp(start - center, end - center, t) * rad + center


def sample_rings(rings, tolerance: float = DEFAULT_TOLERANCE) -> list[np.ndarray]:
    """Densify closed rings of small-circle arcs (:class:`OffsetRing`) into points.

    ``tolerance`` is an angle (radians): the great-circle segment between two
    consecutive points stays within it of the true small-circle arc.
    """
    if not tolerance > 0:
        raise InvalidDistanceError(f"tolerance must be positive, got {tolerance!r}")
    return [sample_ring(ring, tolerance)[0] for ring in rings]


def sample_ring(ring: OffsetRing, tolerance: float = DEFAULT_TOLERANCE):
    """One ring of :func:`sample_rings`: ``(points, arc)``, ``arc[i]`` the index of the
    arc that point ``i`` lies on (its first point being the arc's start)."""
    if not tolerance > 0:
        raise InvalidDistanceError(f"tolerance must be positive, got {tolerance!r}")
    q, r = ring.centers, ring.junctions
    start = np.roll(r, 1, axis=0)
    rad = np.linalg.norm(start - q, axis=1)  # sin of the circle's angular radius
    u0 = normalize(start - q)
    u1 = normalize(r - q)
    sweep = 2.0 * np.arctan2(np.linalg.norm(u0 - u1, axis=1), np.linalg.norm(u0 + u1, axis=1))
    # sagitta of a sub-arc of turn a: rad * (1 - cos(a / 2)) <= tolerance
    ratio = np.clip(1.0 - tolerance / np.maximum(rad, 1e-300), -1.0, 1.0)
    step = 2.0 * np.arccos(ratio)
    counts = np.maximum(1, np.ceil(sweep / np.maximum(step, 1e-12))).astype(np.int64)
    counts = np.minimum(counts, 1 << 20)
    arc_id = np.repeat(np.arange(len(q)), counts)
    first = np.cumsum(counts) - counts
    t = (np.arange(counts.sum()) - first[arc_id]) / counts[arc_id]
    pts = sample_arc(q[arc_id], start[arc_id], r[arc_id], t)
    return normalize(pts), arc_id


class ArcRings:
    """What every set of rings of small-circle arcs offers (``self.rings``: OffsetRing)."""

    rings: list
    #: What writes rings of arcs as GeoJSON: the module :mod:`gloffset.io.geojson`, set
    #: when :mod:`gloffset` is imported. ``vector/`` makes rings and imports no file format
    #: (an import-linter contract); ``to_geojson`` is a convenience that calls the writer.
    writer: ClassVar[Any] = None

    @property
    def centers(self) -> list[np.ndarray]:
        """Small-circle centres Q of each ring (Eq. 2, 3), each (m, 3)."""
        return [r.centers for r in self.rings]

    @property
    def junctions(self) -> list[np.ndarray]:
        """Junction points R of each ring (Eq. 4), each (m, 3); arc k ends at R[k]."""
        return [r.junctions for r in self.rings]
