"""The offset region's boundary near one tile, as rings of small-circle arcs.

Two sources give the same curves inside a tile's cap:

* :class:`ResolvedBoundary`: the whole offset resolved once
  (:meth:`gloffset.Offset.resolve`), its arcs in a cap tree; a tile takes the arcs whose
  caps reach its own. What a pyramid uses: one resolve serves every tile.
* :class:`LocalBoundary`: nothing resolved beforehand. A tile takes the input's edges
  within ``|d|`` of its cap (the edge index :class:`gloffset.edges.CurveArcs` finds them),
  offsets them as lines and resolves that small offset inside the tile's cap only
  (:func:`gloffset.vector.window.boundary_within`). Inside the cap the points at
  distance ``|d|`` from those edges are exactly the points at distance ``|d|`` from all
  the curves (any nearer edge would lie within reach), so the resolved rings there are
  the region's boundary, or the boundary of the band around the curves: a piece that
  lies inside the polygons (``d > 0``) or outside them (``d < 0``) is no boundary and
  is dropped by the tile (``keep``). What a tile at a new distance uses: its cost
  follows the edges near the tile, not the input.

Both hand the tile :class:`Pieces`: chains of arcs with the region on their left, and
give the same tiles (``tests/test_mvt.py``). :func:`gloffset.mvt.vector_tile` uses the
resolved boundary where it is kept on the shape or where the tile reaches much of the
input (a low zoom), the local one otherwise (:func:`gloffset.mvt.tile.boundary_for`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..edges import CurveArcs, contains_xyz, points_inside
from ..geometry.caps import pad
from ..geometry.captree import CapTree
from ..geometry.sphere import angle
from ..shape import Shape
from ..vector.arcrings import sample_arc
from ..vector.offset import Offset
from ..vector.window import boundary_within

__all__ = ["Pieces", "ResolvedBoundary", "LocalBoundary"]


@dataclass
class Pieces:
    """Chains of arcs near a tile: ``chains`` a list of ``(centers, starts, ends, closed,
    ids)`` (region on their left; ``ids`` the arcs' indices in
    :attr:`ResolvedBoundary.arcs`, or None), ``keep`` which points of them are boundary
    (None: all)."""

    chains: list
    keep: Callable[[np.ndarray], np.ndarray] | None


def _arc_table(rings):
    """Flat arrays of the rings' arcs: centre, start, end, ring id."""
    if not rings:
        z = np.zeros((0, 3))
        return z, z, z, np.zeros(0, np.int64)
    q = np.concatenate([r.centers for r in rings])
    e = np.concatenate([r.junctions for r in rings])
    s = np.concatenate([np.roll(r.junctions, 1, axis=0) for r in rings])
    rid = np.concatenate([np.full(len(r.centers), k) for k, r in enumerate(rings)])
    return q, s, e, rid


def _arc_caps(q, s, e):
    """A cap holding each small-circle arc (turn below pi): its middle point and the
    angle to its ends (the distance along the circle grows to the ends)."""
    mid = sample_arc(q, s, e, np.full(len(q), 0.5))
    mid /= np.linalg.norm(mid, axis=1, keepdims=True)
    r = np.maximum(angle(mid, s), angle(mid, e))
    return mid, pad(r) + 1e-12


def _chains(rings, selected_by_ring, first=None):
    """Maximal runs of selected consecutive arcs of each ring (cyclically), as
    ``(centers, starts, ends, closed, ids)``: ``ids`` the arcs' indices in the table of
    all the rings' arcs (``first[k]`` that of ring ``k``'s first arc), None without
    ``first``."""
    out = []
    for k, sel in selected_by_ring.items():
        ring = rings[k]
        m = len(ring.centers)
        start = np.roll(ring.junctions, 1, axis=0)
        mask = np.zeros(m, dtype=bool)
        mask[sel] = True
        base = None if first is None else int(first[k])
        if mask.all():
            ids = None if base is None else base + np.arange(m)
            out.append((ring.centers, start, ring.junctions, True, ids))
            continue
        # rotate so that arc 0 is unselected, then split runs
        first_off = int(np.flatnonzero(~mask)[0])
        order = np.roll(np.arange(m), -first_off)
        mk = mask[order]
        edges = np.diff(np.concatenate([[0], mk.astype(np.int8), [0]]))
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            idx = order[a:b]
            ids = None if base is None else base + idx
            out.append((ring.centers[idx], start[idx], ring.junctions[idx], False, ids))
    return out


#: Up to this many arcs a tile's arcs are found by one vectorised test, not the tree.
_BRUTE = 20000


def _select(tree: CapTree, mid, rad, cap) -> np.ndarray:
    """The arcs (ascending) whose caps reach ``cap``."""
    c, r = cap
    if len(mid) <= _BRUTE:
        items = np.flatnonzero(angle(mid, np.broadcast_to(c, mid.shape)) <= rad + r + 1e-12)
    else:
        _, items, _ = tree.near(c[None, :], r)
    return np.unique(items)


def _reversed(centers, starts, ends, closed):
    """A chain run the other way (each arc from its end to its start)."""
    return centers[::-1].copy(), ends[::-1].copy(), starts[::-1].copy(), closed


class ResolvedBoundary:
    """The boundary of the offset region at angle ``d``, resolved once for all tiles
    (:meth:`of` keeps the last few per shape)."""

    #: How many distances :meth:`of` keeps per shape.
    KEEP = 8

    @classmethod
    def of(cls, shape: Shape, d: float) -> ResolvedBoundary:
        return shape.derived.mvt_boundaries.once(d, lambda: cls(shape, d), keep=cls.KEEP)

    def __init__(self, shape: Shape, d: float):
        self.shape = shape
        self.distance = d
        res = Offset(shape, d).resolve()
        self.rings = res.rings
        q, s, e, rid = _arc_table(self.rings)
        self.arcs = (q, s, e)  # every arc of the rings, ring after ring
        self._rid = rid
        first = np.concatenate([[0], np.cumsum([len(r.centers) for r in self.rings])])
        self._first = first
        mid, rad = _arc_caps(q, s, e) if len(q) else (q, np.zeros(0))
        self._mid, self._rad = mid, rad
        self._tree = CapTree(mid, rad)

    def pieces(self, cap) -> Pieces:
        """The chains of the arcs whose caps reach ``cap``."""
        return self.pieces_of(_select(self._tree, self._mid, self._rad, cap))

    def pieces_of(self, items: np.ndarray) -> Pieces:
        """The chains of the arcs ``items`` (ascending indices of :attr:`arcs`)."""
        by_ring: dict = {}
        if len(items):
            rings_of = self._rid[items]
            cuts = np.flatnonzero(np.diff(rings_of)) + 1
            for part in np.split(items, cuts):
                k = int(self._rid[part[0]])
                by_ring[k] = part - self._first[k]
        return Pieces(_chains(self.rings, by_ring, self._first), None)

    def contains(self, p: np.ndarray) -> np.ndarray:
        return contains_xyz(self.shape, p, self.distance)


class LocalBoundary:
    """The boundary near each tile from the input's edges near it (nothing resolved first)."""

    def __init__(self, shape: Shape, d: float):
        self.shape = shape
        self.distance = d
        self.arcs = CurveArcs.from_shape(shape)

    def edges_near(self, cap) -> np.ndarray:
        """The indices (ascending) of the input's edges that bound the region near ``cap``:
        those within ``|d|`` of it."""
        d = self.distance
        c, r = cap
        arcs = self.arcs
        _, items, _ = arcs.tree.near(c[None, :], abs(d) + r)
        items = np.unique(items)
        ok = arcs.boundary[items]
        if d < 0.0:
            ok &= arcs.group[items] >= 0
        return items[ok]

    def pieces(self, cap, items=None) -> Pieces:
        """The boundary's pieces near ``cap``; ``items`` the :meth:`edges_near` it when
        already found."""
        d = self.distance
        c, r = cap
        arcs = self.arcs
        if items is None:
            items = self.edges_near(cap)
        if len(items) == 0:
            return Pieces([], None)
        a, b = arcs.a[items], arcs.b[items]
        # chain consecutive edges (the end of one is the start of the next)
        joined = np.all(b[:-1] == a[1:], axis=1) & (np.diff(items) == 1)
        cuts = np.flatnonzero(~joined) + 1
        lines = []
        for lo, hi in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [len(items)]])):
            if np.array_equal(a[lo], b[lo]) and hi - lo == 1:
                lines.append(a[lo : lo + 1])
            else:
                line = np.vstack([a[lo:hi], b[hi - 1 : hi]])
                if len(line) > 3 and np.array_equal(line[0], line[-1]):
                    # a whole ring: two open halves sharing their ends (a line closing on
                    # itself was once not resolved right; the halves are what is tested)
                    h = len(line) // 2
                    lines.extend([line[: h + 1], line[h:]])
                else:
                    lines.append(line)
        local = Shape(lines=lines, labels=[f"edges near tile {k}" for k in range(len(lines))])
        # the boundary inside the cap (it holds the tile with a margin: chains end outside
        # the tile)
        chains = boundary_within(Offset(local, abs(d)), (c, r))
        if d < 0:
            chains = [_reversed(*ch) for ch in chains]
        chains = [(*ch, None) for ch in chains]
        keep = None
        if self.shape.rings:
            shape = self.shape
            if d > 0:

                def keep(p):
                    return ~points_inside(shape, p)

            else:

                def keep(p):
                    return points_inside(shape, p)

        return Pieces(chains, keep)

    def contains(self, p: np.ndarray) -> np.ndarray:
        return contains_xyz(self.shape, p, self.distance)
