"""Linking the boundary pieces of the arrangement (:mod:`gloffset.vector.arrangement`)
into closed rings: duplicate pieces dropped and opposite twins cancelled, open chains
pruned, and at each node the pieces that arrive paired with those that leave in clockwise
order (Sec. 4.4)."""

from __future__ import annotations

import numpy as np

from ..geometry.sphere import angle, normalize
from .smallcircle import point_at

__all__ = ["dedupe", "link", "prune_dangling"]


def dedupe(n0, n1, mid):
    """Drop duplicate pieces (same ends, same place) and cancel opposite twins.

    Two pieces between the same two nodes whose middles are closer than 1e-9 rad are
    the same boundary: run the same way, one is kept; run opposite ways, they bound a
    zero-width sliver (parts that touch, or a gap narrower than 1e-9 rad between
    them) and both go.
    """
    keep = np.ones(len(n0), dtype=bool)
    lo, hi = np.minimum(n0, n1), np.maximum(n0, n1)
    key = lo * (int(max(hi.max(initial=0), 0)) + 1) + hi
    uniq, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
    for g in np.flatnonzero(counts > 1):
        members = np.flatnonzero(inv == g)
        for x in range(len(members)):
            a = members[x]
            if not keep[a]:
                continue
            for y in range(x + 1, len(members)):
                b = members[y]
                if not keep[b] or angle(mid[a], mid[b]) > 1e-9:
                    continue
                if n0[a] == n0[b]:
                    keep[b] = False  # the same piece twice
                else:
                    keep[a] = keep[b] = False  # a zero-width sliver
                    break
    return np.flatnonzero(keep)


def link(live, pieces, pts):
    """Successor of each piece: the piece that leaves its end node, paired in clockwise order
    (``live`` and ``pieces``: the arrangement's live arcs and pieces, ``pts`` its nodes)."""
    A, sign = live.A, live.sign
    p_arc, p_t0, p_t1, p_n0, p_n1 = pieces.arc, pieces.t0, pieces.t1, pieces.n0, pieces.n1
    m = len(p_arc)
    nxt = np.full(m, -1, dtype=np.int64)
    if m == 0:
        return nxt
    n_nodes = int(max(p_n0.max(), p_n1.max())) + 1
    outdeg = np.bincount(p_n0, minlength=n_nodes)
    indeg = np.bincount(p_n1, minlength=n_nodes)
    out_order = np.argsort(p_n0, kind="stable")
    out_first = np.concatenate([[0], np.cumsum(outdeg)])
    simple = (outdeg[p_n1] == 1) & (indeg[p_n1] == 1)
    nxt[simple] = out_order[out_first[p_n1[simple]]]
    busy = np.flatnonzero((indeg >= 1) & (outdeg >= 1) & ((indeg > 1) | (outdeg > 1)))
    if len(busy) == 0:
        return nxt
    in_order = np.argsort(p_n1, kind="stable")
    in_first = np.concatenate([[0], np.cumsum(indeg)])
    curv = sign * A.h / np.maximum(A.sin_radius, 1e-300)  # left-turning geodesic curvature
    for node in busy.tolist():
        outs = out_order[out_first[node] : out_first[node + 1]]
        ins = in_order[in_first[node] : in_first[node + 1]]
        P = pts[node]
        e1 = normalize(np.cross(P, [0.0, 0.0, 1.0] if abs(P[2]) < 0.9 else [1.0, 0.0, 0.0]))
        e2 = np.cross(P, e1)
        po = point_at(A.axis[p_arc[outs]], A.start[p_arc[outs]], sign[p_arc[outs]] * p_t0[outs])
        pi_ = point_at(A.axis[p_arc[ins]], A.start[p_arc[ins]], sign[p_arc[ins]] * p_t1[ins])
        to = sign[p_arc[outs], None] * np.cross(A.axis[p_arc[outs]], po)
        ti = -sign[p_arc[ins], None] * np.cross(A.axis[p_arc[ins]], pi_)
        key_o = np.arctan2(to @ e2, to @ e1) + np.clip(1e-9 * curv[p_arc[outs]], -1e-6, 1e-6)
        key_i = np.arctan2(ti @ e2, ti @ e1) - np.clip(1e-9 * curv[p_arc[ins]], -1e-6, 1e-6)
        items = np.concatenate([ins, outs])
        is_in = np.concatenate([np.ones(len(ins), bool), np.zeros(len(outs), bool)])
        cw = np.argsort(-np.concatenate([key_i, key_o]), kind="stable")
        items, is_in = items[cw], is_in[cw]
        depth = np.cumsum(np.where(is_in, 1, -1))
        start = (int(np.argmin(depth)) + 1) % len(items)
        stack = []
        for t in range(len(items)):
            k = (start + t) % len(items)
            if is_in[k]:
                stack.append(items[k])
            elif stack:
                nxt[stack.pop()] = items[k]
    return nxt


def prune_dangling(n0, n1, open_nodes=None):
    """Indices of the pieces left after repeatedly removing those that start where nothing
    arrives or end where nothing leaves (open chains cannot bound a region), except at
    ``open_nodes`` (where a chain may start or end)."""
    idx = np.arange(len(n0))
    while len(idx):
        size = int(max(n0[idx].max(), n1[idx].max())) + 1
        indeg = np.bincount(n1[idx], minlength=size)
        outdeg = np.bincount(n0[idx], minlength=size)
        if open_nodes is not None and len(open_nodes):
            at = open_nodes[open_nodes < size]
            indeg[at] += 1
            outdeg[at] += 1
        ok = (indeg[n0[idx]] > 0) & (outdeg[n1[idx]] > 0)
        if ok.all():
            break
        idx = idx[ok]
    return idx
