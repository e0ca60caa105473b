"""The boundary of the offset region inside one cap: :func:`boundary_within`.

The general method (:mod:`gloffset.vector.arrangement`) resolves the whole raw offset into
closed rings. A vector tile needs the boundary inside its own cap only. This module runs
the same steps on the raw arcs that reach the cap, with each arc also cut where it
crosses the cap's circle:

prune the arcs within ``|d|`` of the curves and those whose caps miss the window, pair,
intersect and split them (and at the window's circle), keep the pieces inside the window
whose middle lies at ``|d|`` from the curves, and link them: into closed rings where they
close inside the window, else into chains from the window's circle to the window's
circle.

Inside the window every piece is split where any raw arc crosses it (an arc that crosses
it there reaches the window), so each piece's status, decided at its middle by exact
distances, is that of all its points, as in the whole resolve: the chains are the
boundary's arcs inside the window, the same circles between the same crossings.
"""

from __future__ import annotations

import numpy as np

from ..geometry.arrangement import cycles
from ..geometry.sphere import angle
from .arrangement import (
    Events,
    Generators,
    RawArcs,
    arc_pairs,
    boundary_pieces,
    corner_events,
    crossing_events,
    prune_arcs,
    split_pieces,
)
from .links import link
from .selfintersect import MIN_DISTANCE, boundary_rings
from .smallcircle import intersect, point_at

__all__ = ["boundary_within"]


def boundary_within(off, cap) -> list:
    """The boundary of the offset region of ``off`` inside ``cap = (centre, radius)``.

    Returns a list of ``(centers, starts, ends, closed)`` chains of small-circle arcs
    with the region on their left: closed rings wholly inside the cap, and open chains
    whose first start and last end lie on the cap's circle.

    Accuracy: as :class:`~gloffset.vector.resolved.ResolvedOffset`'s rings, inside the
    cap (the same arcs, pieces of the raw arcs, between the same crossings).
    """
    d = float(off.distance)
    if abs(d) < MIN_DISTANCE:
        return []
    raw, from_line = boundary_rings(off)
    if not raw:
        return []
    c, big_r = np.asarray(cap[0], dtype=np.float64), float(cap[1])
    table = RawArcs.of(raw)
    gens = Generators(off.shape)
    live = prune_arcs(table, gens, d, (c, big_r))
    if live is None:
        return []
    ia, ib, corners = arc_pairs(table, live, abs(d))
    events = Events(table, live)
    cut_start, cut_end = corner_events(events, table, live, corners)
    crossing_events(events, table, live, ia, ib)
    cut_nodes = _window_events(events, live, c, big_r)
    pts, ev_arc, ev_t, ev_node = events.merged()
    open_nodes = np.unique(events.labels[cut_nodes]) if len(cut_nodes) else cut_nodes
    pieces = split_pieces(ev_arc, ev_t, ev_node, cut_start, cut_end)
    A, sign = live.A, live.sign
    mid = point_at(
        A.axis[pieces.arc], A.start[pieces.arc], sign[pieces.arc] * 0.5 * (pieces.t0 + pieces.t1)
    )
    pieces = pieces.take(np.flatnonzero(angle(mid, np.broadcast_to(c, mid.shape)) < big_r))
    from_line_piece = from_line[table.ring_of[live.alive[pieces.arc]]]
    pieces, certain, _ = boundary_pieces(
        pieces, live, gens, off.shape, d, from_line_piece, open_nodes
    )
    nxt = link(live, pieces, pts)
    out = []
    for path, closed in _paths(nxt):
        if certain[path].any():
            out.append(_chain(table, live.alive, pts, pieces.take(path), closed))
    return out


def _window_events(events: Events, live, c, big_r) -> np.ndarray:
    """Cut the live arcs where they cross the circle of the cap ``(c, big_r)``; returns
    the new nodes."""
    A = live.A
    n = len(live.alive)
    axis = np.broadcast_to(c, (n, 3))
    rho = np.full(n, big_r)
    x, ok, err, _ = intersect(A.axis, A.rho, axis, rho)
    nodes = []
    for s in range(2):
        t, on, _, _ = live.on_arc(np.arange(n), x[:, s], err)
        k = np.flatnonzero(ok & on)
        if len(k):
            nodes.append(events.add_nodes(x[k, s], k, t[k], k, t[k]))
    return np.concatenate(nodes) if nodes else np.zeros(0, np.int64)


def _paths(nxt):
    """The chains of a successor map: open ones (from an item nothing leads to, to one
    that leads nowhere) first, then the closed cycles; ``(items, closed)`` each."""
    nxt = np.asarray(nxt)
    has_pred = np.zeros(len(nxt), dtype=bool)
    has_pred[nxt[nxt >= 0]] = True
    out = []
    nl = nxt.tolist()
    for s in np.flatnonzero(~has_pred).tolist():
        path: list[int] = []
        e = s
        while e >= 0 and len(path) <= len(nl):
            path.append(e)
            e = nl[e]
        out.append((np.array(path, dtype=np.int64), False))
    closed, _ = cycles(nxt)
    out.extend((cyc, True) for cyc in closed)
    return out


def _chain(table, alive, pts, pieces, closed: bool):
    """``(centers, starts, ends, closed)`` of consecutive pieces, the pieces that continue
    the same raw arc joined."""
    arc, t0, t1, n0, n1 = pieces.arc, pieces.t0, pieces.t1, pieces.n0, pieces.n1
    m = len(arc)
    cont = (arc == np.roll(arc, 1)) & (t0 == np.roll(t1, 1))
    if not closed or cont.all():
        cont[0] = False
    if closed:  # start at a piece that does not continue its predecessor
        order = (np.arange(m) + int(np.flatnonzero(~cont)[0])) % m
        arc, n0, n1, cont = arc[order], n0[order], n1[order], cont[order]
    first = np.flatnonzero(~cont)
    last = np.append(first[1:] - 1, m - 1)
    g = alive[arc[first]]
    return table.centers[g].copy(), pts[n0[first]].copy(), pts[n1[last]].copy(), closed
