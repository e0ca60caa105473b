"""The cells' lists cut to the arcs that can be nearest: a pair dominated over its cell's
disc by the cell's nearest arc is dropped.

The walk (:mod:`gloffset.raster.fields.walk`) keeps, for a cell of centre ``c`` and
radius ``rho``, every arc ``j`` whose distance at ``c`` lies within ``2 rho`` of the
least, ``d_i(c)``: each distance moves by at most ``rho`` over the disc. Far from the
boundary (a coast seen from a few hundred cells away) that band holds tens of arcs, all
about as near, and each pixel of the cell ranks them all. But the two distances move
together there: over the disc, ``d_j - d_i`` moves by much less than ``2 rho``.

The bound, rigorous: let ``q*`` be the point of arc ``i`` nearest to ``c`` and ``D =
d_i(c) - rho > 0``. For a point ``p`` of the disc, ``d_i(p) <= angle(p, q*)``, and for
each point ``q`` of arc ``j``, ``f_q(p) = angle(p, q) - angle(p, q*)`` has the gradient
``g_q - g_q*``, the difference of the unit tangents at ``p`` away from ``q`` and ``q*``.
They are the normalised projections ``u = q - (p.q) p`` and ``u* = q* - (p.q*) p`` on the
tangent plane, ``|u| = sin angle(p, q) >= sin D`` where both angles lie in ``[D, pi -
D]``, and ``|u - u*| <= |q - q*|``; so (Dunkl-Williams, ``|x/|x| - y/|y|| <= 2 |x - y| /
(|x| + |y|)``) ``|g_q - g_q*| <= L = chord(delta) / sin D``, ``delta >= angle(q, q*)``
over arc ``j``: ``angle(q*, mid_j) + reach_j`` (its cap). Along the geodesic from ``c``
(the disc is convex), ``f_q(p) >= f_q(c) - rho L``, and ``f_q(c) >= d_j(c) - d_i(c)``:

    d_j(p) - d_i(p) >= d_j(c) - d_i(c) - rho L.

Where that is above :data:`ETA`, arc ``j`` is farther than arc ``i`` at every point of
the disc, by more than the float64 distances' error: it is never a pixel's nearest arc,
nor within the shader's reach of the least (:mod:`gloffset.gl.field_pass`: the features
finished and the sign's ``FIELD_ETA`` set are read from the exact distances), so the
field's values and sign codes are the same bits without it. The angles' upper end: each
``angle(p, q) <= d_i(c) + rho + delta`` (through ``q*``), asked to be at most ``pi - D``;
a pair where it is not, or a cell with ``D <= 0``, is kept.
"""

from __future__ import annotations

import numpy as np

from ...geometry.caps import pad
from ...geometry.sphere import angle

__all__ = ["ETA", "undominated", "vertex_dominates"]

#: Whether the walk's lists are cut by these bounds (:func:`vertex_dominates` in each
#: round of the walk, :func:`undominated` on the GPU field's lists).
DOMINANCE = True

#: The bounds are asked only of cells whose nearest arc lies at least this many of their
#: radii away (nearer, ``L`` is about 2 and they drop nothing: measured, below).
DEEP = 16.0

#: The least margin (rad) by which a dropped arc is farther than the cell's nearest arc
#: at every point of the disc: the float64 distances are good to 1e-15, the points ``q*``
#: to a few 1e-16, and the shader reads its features within 1e-13 of the least.
ETA = 1e-12


def _nearest_points(c: np.ndarray, nodes, arc: np.ndarray) -> np.ndarray:
    """Return the point of each arc ``arc`` nearest to the point ``c`` (one per row): its
    foot where it falls on the arc (``arc_distance``'s test), else its nearer end."""
    a, b, n = nodes.a[arc], nodes.b[arc], nodes.n[arc]
    cn = np.einsum("ij,ij->i", c, n)
    foot = c - cn[:, None] * n
    size = np.linalg.norm(foot, axis=1)
    on = np.einsum("ij,ij->i", c, np.cross(n, a)) >= 0.0
    on &= np.einsum("ij,ij->i", c, np.cross(b, n)) >= 0.0
    on &= np.abs(n).sum(axis=1) > 0
    on &= size > 0
    end = np.where((angle(c, a) <= angle(c, b))[:, None], a, b)
    return np.where(on[:, None], foot / np.where(size > 0, size, 1.0)[:, None], end)


def undominated(centers, rho, cell, arc, nodes, d: np.ndarray) -> np.ndarray:
    """Return, per pair ``(cell, arc)`` (every original arc of each cell's list that
    is given, sorted by cell), whether the pair is kept: False where the cell's nearest
    arc dominates it over the cell's disc (``centers``, ``rho``; see the module notes).
    ``d``: the pairs' exact distances from the cells' centres."""
    keep = np.ones(len(cell), dtype=bool)
    if len(cell) == 0:
        return keep
    k = len(centers)
    best = np.full(k, np.inf)
    np.minimum.at(best, cell, d)
    low = best - rho
    deep = np.isfinite(best) & (low > 0.0)
    if not deep.any():
        return keep
    # each deep cell's nearest arc (its first pair at the least distance) and point
    win = np.flatnonzero((d == best[cell]) & deep[cell])
    win = win[np.diff(cell[win], prepend=-1) != 0]
    cw = cell[win]
    q = np.zeros((k, 3))
    q[cw] = _nearest_points(centers[cw], nodes, arc[win])
    on = np.flatnonzero(deep[cell])
    co, ao = cell[on], arc[on]
    delta = pad(angle(q[co], nodes.mid[ao]) + nodes.reach[ao])
    lo = low[co]
    lip = 2.0 * np.sin(np.minimum(0.5 * delta, 0.5 * np.pi)) / np.sin(lo) * (1.0 + 1e-12)
    fits = best[co] + rho[co] + delta <= np.pi - lo
    gap = d[on] - best[co] - rho[co] * lip
    keep[on] = ~(fits & (gap > ETA))
    return keep


def _chord(u, v) -> np.ndarray:
    """``|u - v|`` of points given as coordinate columns."""
    d = [u[k] - v[k] for k in range(3)]
    return np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])


def vertex_dominates(c, v, mid, lo, r, reach) -> np.ndarray:
    """Return, per pair, whether a boundary vertex dominates a node over a disc: the
    bound of the module notes with the vertex ``v`` for ``q*`` (``d_i(p) <= angle(p,
    v)`` for any point of the boundary) and the node's run for arc ``j``: it lies in the
    cap ``(mid, r)``, no nearer to the centre ``c`` than ``lo``; the disc's radius is
    ``reach``. Points as coordinate columns gathered per pair, the rest per pair.

    Every angle from a point ``p`` of the disc to the run is at least ``lo - reach``,
    to ``v`` at least ``angle(c, v) - reach``: ``D`` is the lesser; and ``delta =
    angle(v, mid) + r``. True where ``D > 0``, the angles fit under ``pi - D`` and ``lo
    - angle(c, v) - reach L > ETA``: then no point of the run is the nearest of a point
    of the disc (nor within ``ETA`` of it)."""
    av = 2.0 * np.arctan2(_chord(c, v), np.sqrt(np.maximum(4.0 - _chord(c, v) ** 2, 0.0)))
    av = pad(av)  # rounded up: it is subtracted
    low = np.minimum(lo, av) - reach
    delta = pad(2.0 * np.arcsin(np.minimum(0.5 * _chord(v, mid), 1.0)) + r)
    lip = 2.0 * np.sin(np.minimum(0.5 * delta, 0.5 * np.pi))
    lip /= np.sin(np.maximum(low, 1e-300))
    lip *= 1.0 + 1e-12
    out = low > 0.0
    out &= av + reach + delta <= np.pi - low
    out &= lo - av - reach * lip > ETA
    return out
