"""Start lists kept per node table: the nodes that can hold the nearest arc of a point of
a canonical disc, from which the root list of any small grid inside that disc is
bounded (:func:`gloffset.raster.fields.walk.root_list`).

A grid walked as one cell (a tile, a regional box) first bounds the tree's top nodes on
a disc holding its cells, in a dozen rounds. Nearby grids (a map's tiles, or the same
tile at another distance) repeat most of those rounds, so the disc ``(c, reach)`` is
given a canonical disc that holds it: ``h = 2^ceil(log2 reach)``, the point ``y`` of the
lattice ``h Z^3`` nearest to ``c``, and the disc about ``y / |y|`` of radius ``h +
asin(sqrt(3) h / 2)``: ``|c - y| <= sqrt(3) h / 2`` and, for a unit vector ``c``, the
angle to ``y / |y|`` is at most ``asin |c - y|``, so every disc of its key lies inside
it. The canonical disc's list (bounded from the top nodes, the same rigorous walk) is
kept, a pure function of the key (:class:`~gloffset.memo.Memo`, bounded); a grid's own
list is bounded from it in a few rounds. Both hold every node that can hold the nearest
arc of a point of their discs, so the walk below finds the same nearest arcs, and the
distances are the same bits.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from ...memo import Memo

__all__ = ["KEEP", "canonical_disc", "kept_lists"]

#: Canonical discs' lists kept per node table (the oldest built go first).
KEEP = 256

#: The largest ``h`` keyed (the canonical radius, ``h + asin(sqrt(3) h / 2)``, then stays
#: under 1 rad, the walk's largest root disc).
_H_MAX = 0.5

_KEPT: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def canonical_disc(c: np.ndarray, reach: float):
    """Return ``(key, centre, radius)`` of the canonical disc holding the disc of radius
    ``reach`` about the unit vector ``c`` (see the module notes), or None where ``reach``
    is above ``_H_MAX``. The radius is rounded up (``1e-12`` relative and absolute)."""
    if not 0.0 < reach <= _H_MAX:
        return None
    level = math.ceil(math.log2(reach))
    h = math.ldexp(1.0, level)
    ijk = np.rint(np.asarray(c, dtype=np.float64) / h)
    y = ijk * h
    centre = y / np.sqrt(y @ y)
    radius = (h + math.asin(min(1.0, 0.8660254037844387 * h))) * (1.0 + 1e-12) + 1e-12
    return (level, *(int(v) for v in ijk)), centre, radius


def kept_lists(nodes) -> Memo:
    """The kept canonical lists of a node table, by ``(m, key)``."""
    got = _KEPT.get(nodes)
    if got is None:
        got = _KEPT.setdefault(nodes, Memo())
    return got
