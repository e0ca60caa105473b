"""The skeleton of an arrangement of arcs: pairs, pieces, components and cycles.

Two operations of gloffset build an arrangement of arcs on the sphere: the union of the
input's polygons (:mod:`gloffset.region`, great-circle edges) and the removal of an
offset's self-intersections (:mod:`gloffset.vector.arrangement`, small-circle arcs). Both
go through the same steps, and those steps live here, once:

1. :func:`candidate_pairs`: the pairs of arcs whose bounding caps come within a slack of
   each other (a :class:`~gloffset.geometry.captree.CapTree`, so the cost follows the number of
   nearby pairs, not n^2);
2. the exact meeting points of each candidate pair, which are the callers' own (great
   circles with the union's tolerance, small circles with their error bounds): they
   become *events*, ``(arc, position along it, node)``;
3. :func:`components`: nodes (or vertices, or polygons) that are one, labelled by the
   smallest member of each connected set; :func:`equal_rows`: the vertices that are one
   point (equal coordinates);
4. :func:`split`: the arcs cut into pieces between consecutive events
   (:func:`split_between` where the events come sorted, between each arc's two ends);
5. :func:`cycles`: the pieces, once each is given its successor (the callers' rule at a
   node where several meet), followed into closed rings (:func:`permutation_cycles`, all
   at once, where every piece has one successor and one predecessor).

Everything here is combinatorial (sorting and labelling) or a conservative cap test, so
it decides nothing by rounding: the answers are exactly those of the callers'
predicates.
"""

from __future__ import annotations

import numpy as np

from .captree import CapTree

__all__ = [
    "candidate_pairs",
    "components",
    "equal_rows",
    "row_keys",
    "split",
    "split_between",
    "cycles",
    "permutation_cycles",
    "bucket_order",
]


def candidate_pairs(mid, half, slack: float = 0.0) -> tuple[CapTree, np.ndarray, np.ndarray]:
    """The cap tree of arcs with bounding caps ``(mid, half)`` and the pairs ``i < j`` of
    arcs whose caps come within ``slack`` (rad) of each other.

    A superset of the pairs of arcs that meet or come within ``slack``: the tree pads
    every radius (:meth:`gloffset.geometry.captree.CapTree.self_pairs`). Returns
    ``(tree, i, j)``; the tree serves the callers' later range queries.
    """
    tree = CapTree(mid, half)
    i, j = tree.self_pairs(slack)
    return tree, i, j


def components(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Connected-component labels of ``n`` items joined by the pairs ``(i[k], j[k])``.

    Each item is labelled by the smallest member of its component (so the labels do not
    depend on the order of the pairs).
    """
    lab = np.arange(n, dtype=np.int64)
    i = np.asarray(i, dtype=np.int64)
    j = np.asarray(j, dtype=np.int64)
    if len(i) == 0:
        return lab
    while True:
        li, lj = lab[i], lab[j]
        if np.array_equal(li, lj):
            return lab
        lo = np.minimum(li, lj)
        np.minimum.at(lab, li, lo)
        np.minimum.at(lab, lj, lo)
        while True:  # pointer jumping to the roots
            nxt = lab[lab]
            if np.array_equal(nxt, lab):
                break
            lab = nxt


def split(arc, t, node):
    """The pieces of arcs between consecutive events.

    Events are ``(arc[k], t[k], node[k])``: a point at position ``t`` along arc ``arc``
    (any increasing measure from the arc's start), which is node ``node``. Events are
    sorted by arc, then position; events at the same position keep their given order.
    Each arc's events should include its start and its end.

    Returns ``(arc, t0, t1, n0, n1)`` per piece, arc by arc and in order along each arc:
    the piece of ``arc`` from ``t0`` (node ``n0``) to ``t1`` (node ``n1``). Pieces whose
    two ends are one node are kept; callers drop them by their own rule.
    """
    arc = np.asarray(arc)
    order = np.lexsort((t, arc))
    arc, t, node = arc[order], np.asarray(t)[order], np.asarray(node)[order]
    same = arc[1:] == arc[:-1]
    return arc[:-1][same], t[:-1][same], t[1:][same], node[:-1][same], node[1:][same]


def split_between(first_node, last_node, arc, node):
    """:func:`split`'s pieces of the arcs ``0 .. n-1`` from node ``first_node[a]`` to
    ``last_node[a]`` through their events ``(arc[k], node[k])``, given sorted by arc
    and then by position along it: ``(arc, n0, n1)`` per piece, in :func:`split`'s
    order, without its sort (the events are placed by counting).
    """
    first_node = np.asarray(first_node, dtype=np.int64)
    n = len(first_node)
    arc = np.asarray(arc, dtype=np.int64)
    cnt = np.bincount(arc, minlength=n)
    size = cnt + 2  # each arc's nodes: its first, its events, its last
    at = np.cumsum(size) - size
    seq = np.empty(int(size.sum()), np.int64)
    seq[at] = first_node
    seq[at + size - 1] = last_node
    rank = np.arange(len(arc)) - (np.cumsum(cnt) - cnt)[arc]
    seq[at[arc] + 1 + rank] = node
    piece = np.ones(len(seq), bool)  # a piece from every node but the last of its arc
    piece[at + size - 1] = False
    k = np.flatnonzero(piece)
    return np.repeat(np.arange(n), cnt + 1), seq[k], seq[k + 1]


def cycles(nxt) -> tuple[list[np.ndarray], np.ndarray]:
    """Closed cycles of a successor map, and the items left on open chains.

    ``nxt[k]`` is the item after ``k`` (``-1``: none). Each cycle starts at its smallest
    item, and cycles come in the order of those; the
    items of chains that do not close (and of those that lead into them) are returned
    apart, as an int64 array.
    """
    nxt = np.asarray(nxt)
    m = len(nxt)
    seen = np.zeros(m, dtype=bool)
    out = []
    # items that nothing leads to start open chains: mark them first
    has_pred = np.zeros(m, dtype=bool)
    has_pred[nxt[nxt >= 0]] = True
    unlinked = []
    nl = nxt.tolist()
    for s in np.flatnonzero(~has_pred).tolist():
        e = s
        while e >= 0 and not seen[e]:
            seen[e] = True
            unlinked.append(e)
            e = nl[e]
    for s in range(m):
        if seen[s]:
            continue
        path = []
        e = s
        while e >= 0 and not seen[e]:
            seen[e] = True
            path.append(e)
            e = nl[e]
        if e == s:
            out.append(np.array(path, dtype=np.int64))
        else:
            unlinked.extend(path)
    return out, np.array(unlinked, dtype=np.int64)


def permutation_cycles(nxt) -> tuple[np.ndarray, np.ndarray]:
    """The cycles of a permutation ``nxt`` (every item on one cycle), all at once.

    Returns ``(items, sizes)``: the items of the cycles one after another, and the
    length of each; the cycles and their items in the order of :func:`cycles` (each
    cycle from its smallest item on, the cycles in the order of those). Pointer
    doubling, ``log2(len(nxt))`` numpy passes: each item's smallest item along the
    next ``2^k``, then its distance from its cycle's smallest item.
    """
    nxt = np.asarray(nxt, dtype=np.int64)
    n = len(nxt)
    items = np.arange(n, dtype=np.int64)
    # runs of consecutive items (k -> k + 1), as a ring's pieces mostly come, are
    # followed as one: a cycle's smallest item starts a run, so the cycles of the runs'
    # successor map, each run expanded in place, are the cycles in the same order
    last = np.flatnonzero(nxt != items + 1)  # the last item of each run
    if 0 < len(last) < n // 2:
        first = np.concatenate([[0], last[:-1] + 1])
        run_of = np.repeat(np.arange(len(last)), last - first + 1)
        runs, run_sizes = permutation_cycles(run_of[nxt[last]])
        length = (last - first + 1)[runs]
        out = np.repeat(first[runs] - np.cumsum(length) + length, length) + np.arange(n)
        cycle_of_run = np.repeat(np.arange(len(run_sizes)), run_sizes)
        return out, np.bincount(cycle_of_run, weights=length, minlength=len(run_sizes)).astype(
            np.int64
        )
    lab, p, span = items.copy(), nxt, 1
    while span < n:  # lab: the smallest item of the next 2 span (all of the cycle at the end)
        lab = np.minimum(lab, lab[p])
        p = p[p]
        span *= 2
    start = lab == items
    prev = np.empty(n, np.int64)
    prev[nxt] = items
    q = np.where(start, items, prev)
    d = (~start).astype(np.int64)  # d: the steps from q to the item
    span = 1
    while span < n:
        d = d + d[q]
        q = q[q]
        span *= 2
    firsts = np.flatnonzero(start)
    sizes = np.bincount(lab, minlength=n)[firsts]
    offset = np.zeros(n, np.int64)
    offset[firsts] = np.cumsum(sizes) - sizes
    out = np.empty(n, np.int64)
    out[offset[lab] + d] = items
    return out, sizes


def bucket_order(ids: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``np.argsort(ids, kind="stable")`` of integers ``0 <= ids < n``, by counting.

    Returns ``(order, counts, starts)``: the order, how many items each id has and where
    its items start in the order. Items alone with their id are placed by their id's
    start; those that share an id (few, where pieces of a boundary meet) by a stable
    sort of their own. Linear in ``len(ids) + n`` where most ids are unique.
    """
    ids = np.asarray(ids, dtype=np.int64)
    counts = np.bincount(ids, minlength=n)
    starts = np.cumsum(counts) - counts
    pos = starts[ids]
    shared = np.flatnonzero(counts[ids] > 1)
    if len(shared):
        shared = shared[np.argsort(ids[shared], kind="stable")]
        sid = ids[shared]
        pos[shared] += np.arange(len(shared)) - np.searchsorted(sid, sid)
    order = np.empty(len(ids), np.int64)
    order[pos] = np.arange(len(ids))
    return order, counts, starts


def row_keys(v: np.ndarray) -> np.ndarray:
    """Exact row keys of unit vectors (``-0.0`` made ``0.0``), as a void view."""
    v = np.ascontiguousarray(v + 0.0)
    return v.view(np.dtype((np.void, v.dtype.itemsize * v.shape[1]))).ravel()


def equal_rows(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``v`` that are equal (``-0.0`` equal to ``0.0``): a label per row and the
    size of each label's group (``np.unique``'s ``inverse`` and ``counts`` of
    :func:`row_keys`, up to the numbering of the groups).

    The rows are sorted by a 64-bit hash of their bits (one sort of integers, several
    times faster than sorting the rows' bytes); rows with equal hashes must be equal,
    which is checked: where two are not (a collision) the bytes are sorted instead.
    """
    bits = np.ascontiguousarray(v + 0.0).view(np.uint64)
    h = np.zeros(len(bits), np.uint64)
    with np.errstate(over="ignore"):
        for col in range(bits.shape[1]):
            h = (h ^ bits[:, col]) * np.uint64(0x9E3779B97F4A7C15)
            h ^= h >> np.uint64(29)
    order = np.argsort(h)
    hs = h[order]
    same_h = hs[1:] == hs[:-1]
    same_row = np.ones(len(hs) - 1 if len(hs) else 0, bool)
    for col in range(bits.shape[1]):  # the rows in that order, a coordinate at a time
        b = bits[:, col][order]
        same_row &= b[1:] == b[:-1]
    if np.any(same_h & ~same_row):  # a collision
        _, inv, counts = np.unique(row_keys(v), return_inverse=True, return_counts=True)
        return inv.reshape(-1), counts
    new = np.ones(len(hs), bool)
    new[1:] = ~same_h
    ids = np.cumsum(new) - 1
    inv = np.empty(len(hs), np.int64)
    inv[order] = ids
    return inv, np.diff(np.append(np.flatnonzero(new), len(hs)))
