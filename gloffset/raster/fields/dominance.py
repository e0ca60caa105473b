"""The walk's tests that cut a cell's list by the cell's nearest boundary vertex or arc:
a node whose run is nearer to no point of the cell's disc (centre ``c``, radius
``rho``) is dropped. :func:`maybe_nearer`: the bisector of the vertex and the node's
cap. :func:`vertex_dominates`, :func:`undominated`: far from the boundary (a coast
seen from hundreds of cells away) the walk's ``2 rho`` band holds tens of arcs all
about as near, but two distances move together over the disc; this bounds how much.

The bound, rigorous: let ``q*`` be a point of the boundary (the nearest point of the
cell's nearest arc, or a vertex) and ``D > 0`` a lower bound of every angle from the
disc to ``q*`` and to the node's run. For ``p`` in the disc, ``d_i(p) <=
angle(p, q*)``, and for ``q`` in the run, ``f_q(p) = angle(p, q) - angle(p, q*)`` has
the gradient ``g_q - g_q*``, the unit tangents at ``p`` away from ``q`` and ``q*``:
the normalised projections ``u``, ``u*`` of ``q``, ``q*`` on the tangent plane, ``|u|
>= sin D`` while the angles lie in ``[D, pi - D]``, ``|u - u*| <= |q - q*|``; so
(Dunkl-Williams) ``|g_q - g_q*| <= L = chord(delta) / sin D``, ``delta`` at least
``angle(q*, mid) + r`` (the run's cap). The disc is convex, so

    d_j(p) - d_i(p) >= d_j(c) - angle(c, q*) - rho L.

Where that is above :data:`ETA`, the node is farther than ``q*`` at every point of the
disc by more than the float64 distances' error: it holds no pixel's nearest arc nor a
feature within the shader's reach of it (the features finished and the sign's
``FIELD_ETA`` set come from exact distances), so fields and sign codes keep their bits.
"""

from __future__ import annotations

import numpy as np

from ...geometry.caps import CAP_SLACK, angle_of_chord, chord, pad
from ...geometry.sphere import angle, column_dots, nearest_on_arc

__all__ = ["ETA", "maybe_nearer", "nearest_vertices", "undominated", "vertex_dominates"]

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
    aw = arc[win]
    q[cw] = nearest_on_arc(centers[cw], nodes.a[aw], nodes.b[aw], nodes.n[aw])
    on = np.flatnonzero(deep[cell])
    co, ao = cell[on], arc[on]
    delta = pad(angle(q[co], nodes.mid[ao]) + nodes.reach[ao])
    keep[on] = ~_dominated(d[on], best[co], rho[co], delta)
    return keep


def _dominated(lo, near, reach, delta) -> np.ndarray:
    """The bound of the module notes, per pair: True where the run (no nearer to the
    centre than ``lo``) is farther than ``q*`` (at most ``near`` from the centre) at every
    point of the disc of radius ``reach`` by more than :data:`ETA`; ``delta`` at least the
    angle from ``q*`` to every point of the run. ``D = min(lo, near) - reach``, ``L =
    chord(delta) / sin D`` (rounded up), and the angles asked to fit under ``pi - D``."""
    low = np.minimum(lo, near) - reach
    lip = chord(delta)
    lip /= np.sin(np.maximum(low, 1e-300))
    lip *= 1.0 + 1e-12
    out = low > 0.0
    out &= near + reach + delta <= np.pi - low
    out &= lo - near - reach * lip > ETA
    return out


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
    cv = _chord(c, v)
    av = pad(2.0 * np.arctan2(cv, np.sqrt(np.maximum(4.0 - cv * cv, 0.0))))  # rounded up
    return _dominated(lo, av, reach, pad(angle_of_chord(_chord(v, mid)) + r))


#: Slack on the dot products of :func:`maybe_nearer` (unit vectors and sums of two: each
#: computed to a few 1e-16).
DOT_SLACK = 1e-12
#: Slack under the square root of :func:`maybe_nearer` (its argument is a difference of
#: values of at most 4, each good to 1e-15).
SQ_SLACK = 1e-13


def nearest_vertices(cc, cell, node, tab, vcos, vtx) -> None:
    """Update each cell's nearest boundary vertex with the ends of the nodes ``node``
    (``tab`` the walk's node table: their ends ``a``, ``b`` as columns).

    ``cc`` the cells' centres, ``vcos`` the cosine of the vertex's angle to the centre,
    ``vtx`` the point (as coordinate columns); the ends of a boundary node are original
    vertices of the boundary, bit for bit.
    """
    for ends in (tab.a, tab.b):
        cos = column_dots(cc, ends, cell, node)
        np.maximum.at(vcos, cell, cos)
        win = np.flatnonzero(cos == vcos.take(cell))
        cw, nw = cell.take(win), node.take(win)
        for k in range(3):
            vtx[k][cw] = ends[k].take(nw)


def maybe_nearer(centre, cap, disc) -> np.ndarray:
    """Return whether a node's run can be as near as the cell's vertex to some point.

    Whether it can be as near as the cell's vertex ``vtx`` to some point
    within ``reach`` of the cell's centre ``c``: False only where every such point is
    nearer to the vertex than to every point of the node's cap (centre ``mid``, radius
    ``r`` = ``nodes.reach``, which holds its run), so that the run holds no nearest point.
    Per pair: ``centre`` is ``(c.mid, t, c.vtx, vtx.mid)`` (``t`` the angle of ``c.mid``,
    good to ``CAP_SLACK / 2``), ``cap`` ``(r, cos r, sin r)`` and ``disc`` ``(reach,
    cos(reach), sin(reach))``.

    The test, rigorous: for ``q`` outside the cap, the cap's nearest point ``y`` has ``q.y
    = cos(angle(q, mid) - r) = cos r (q.mid) + sin r sin(angle(q, mid))``, so ``q.v > sin
    r S`` with ``v = vtx - cos r mid`` and ``S >= max(sin(angle(q, mid)), sin r)`` puts
    ``q`` nearer to the vertex (and outside the cap: inside, ``q.v <= 1 - cos^2 r = sin^2
    r``, which fails the test). The least of the linear ``q.v`` over the disc of radius
    ``reach`` about ``c`` is ``c.v cos(reach) - sqrt(|v|^2 - (c.v)^2) sin(reach)``, with
    ``c.v = c.vtx - cos r c.mid`` and ``|v|^2 = 1 + cos^2 r - 2 cos r vtx.mid``; and ``S =
    sin(min(pi / 2, t + reach))``. The rounding of these (a few 1e-16 on values of at
    most 4) is covered by :data:`DOT_SLACK` and by :data:`SQ_SLACK` under the root.
    """
    cm, t, vcos, vm = centre
    r, cr, sin_r = cap
    rr, cos_rr, sin_rr = disc
    cv = vcos - cr * cm
    vv = 1.0 + cr * cr - 2.0 * cr * vm
    s2 = np.maximum(vv - cv * cv, 0.0) + SQ_SLACK
    least = cv * cos_rr - np.sqrt(s2) * sin_rr
    sin_s = np.sin(np.minimum(t + rr + CAP_SLACK, 0.5 * np.pi))
    out = least <= sin_r * np.maximum(sin_s, sin_r) + DOT_SLACK
    # the test holds for caps and discs smaller than a quarter circle only
    return out | (r >= 1.0) | (rr >= 1.0)
