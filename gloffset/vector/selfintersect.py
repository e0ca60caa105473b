"""Self-intersection removal (paper Sec. 4.4): from the raw offset to the true boundary of
the offset region; the entry point :func:`resolve` and the rings both methods start from.

The raw offset of Sec. 4.1 (:class:`gloffset.Offset`) loops over itself at concave
corners, and the offsets of separate parts overlap (paper Fig. 10d). Two methods
turn it into the boundary of the offset region

* ``R = {inside a polygon, or within d of a curve}`` for ``d > 0``,
* ``R = {inside a polygon and farther than |d| from every curve}`` for ``d < 0``:

``method="paper"`` (:mod:`gloffset.vector.paper`)
    Algorithm 1 of Sec. 4.4 as published, ring by ring: the arcs between an arc and
    the farthest later arc it meets are removed. Rings are not united and a loop that
    needs more than half the ring removed is mishandled, as in the paper.

``method="general"`` (the default, :mod:`gloffset.vector.arrangement`)
    The arrangement of all raw arcs: arcs are split where they cross, and the pieces
    whose middle lies at ``|d|`` from the curves (nothing closer) are linked into
    closed rings. Exact, united over all parts, with holes.

Both start from :func:`boundary_rings` (the raw rings, plus the other side of every
ring where edges cross, plus the reversed offsets of lines that carve holes for
``d < 0``), and both return a :class:`~gloffset.vector.resolved.ResolvedOffset` whose
rings are sorted into exteriors and holes by :mod:`gloffset.vector.rings`.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidDistanceError
from .arcrings import line_arcs, ring_arcs
from .arrangement import defects, resolve_general
from .paper import resolve_paper
from .resolved import ResolvedOffset

__all__ = ["METHODS", "MIN_DISTANCE", "boundary_rings", "resolve"]

METHODS = ("general", "paper")
#: Smallest ``|d|`` (radians) the general method accepts (6.4 mm on the Earth).
MIN_DISTANCE = 1e-9


def resolve(off, method: str = "general") -> ResolvedOffset:
    """Remove self-intersections from a raw offset (paper Sec. 4.4).

    Parameters
    ----------
    off : gloffset.Offset
        The raw offset (:func:`gloffset.vector.offset`).
    method : {"general", "paper"}
        ``"general"``: the exact boundary of the offset region, united over all
        parts, with holes. ``"paper"``: Algorithm 1 as published, ring by ring.

    Returns
    -------
    ResolvedOffset

    Notes
    -----
    Accuracy (``"general"``): see :class:`ResolvedOffset`. Cost: linear in the
    raw arcs for the pruning and the index, plus the number of arc pairs whose
    caps meet among arcs that come within ``|d|`` of the boundary.
    ``|distance|`` must be at least :data:`MIN_DISTANCE`.

    Examples
    --------
    >>> import gloffset
    >>> bay = gloffset.read({"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 10],
    ...     [6, 10], [6, 2], [4, 2], [4, 10], [0, 10], [0, 0]]]})
    >>> res = gloffset.offset(bay, 0.02, radius=1.0).resolve()
    >>> len(res.polygons), int(res.holes.sum())
    (1, 0)
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(map(repr, METHODS))}, got {method!r}")
    d = float(off.distance)
    if abs(d) < MIN_DISTANCE:
        raise InvalidDistanceError(
            f"distance {d!r} rad is too small to resolve (at least {MIN_DISTANCE} rad); "
            "the offset region is then the shape itself"
        )
    raw, from_line = boundary_rings(off)
    if method == "paper":
        return resolve_paper(off, raw)
    return resolve_general(off, raw, from_line)


def boundary_rings(off):
    """The raw rings whose arcs can bound the region, and whether each comes from a line.

    For self-intersecting input (:func:`gloffset.vector.arrangement.defects`) the
    other side of every ring is added too.

    For ``d < 0`` the offset of lines and points (which :class:`~gloffset.Offset`
    leaves out) still carves holes into polygons: their rings at ``|d|`` are added
    reversed, so that the region stays on their left.
    """
    rings = list(off.rings)
    n_shape_rings = len(off.shape.rings)
    from_line = [k >= n_shape_rings for k in range(len(rings))]
    if off.shape.rings and defects(off.shape)[0]:
        # edges cross: the region (inside by crossing parity) can lie on either side of
        # an edge, so both sides are offset and the inside test picks the pieces
        for ring in off.shape.rings:
            rings.append(ring_arcs(ring[::-1].copy(), off.distance))
            from_line.append(False)
    if off.distance < 0.0 and off.shape.rings:
        for line in off.shape.lines:
            rings.append(line_arcs(line, -off.distance).reversed())
            from_line.append(True)
    return rings, np.array(from_line, dtype=bool)
