"""The lists of the GPU backend of :func:`gloffset.distance_field`, walked on the GPU.

The cells of a level (``SHIFT`` above the output) with every original arc that can be the
nearest of one of their pixels (within ``max_distance``): the walk of
:func:`~gloffset.raster.fields.walk.walk_levels` (its branch and bound; the bisector test
against the nearest boundary vertex of the nodes measured), level by level on the GL context
(:mod:`gloffset.gl.walk_pass`, ``shaders/field_walk.comp``) from the first level of
:data:`GPU_CELLS` cells (the float64 walk the coarser ones), in float32 with every bound
widened by its float32 error bound, so that each list is a superset of what can be
nearest: a longer list costs time, never a value (the finishing is exact). The cells'
centres and bounds come from the grid in float64, rounded once (radii up).

:func:`gpu_lists` answers None where the GPU walk does not apply or hits a limit (a
grid of one level, a list too deep for the shader's stack, a buffer over the GL limits);
the caller then walks in float64.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from ...geometry.sphere import dot
from ...gl.walk_pass import WalkLevel, walk_pass
from ..vector.levels import Frontier
from ..vector.node_levels import KAPPA, NodeArcs
from . import dominance
from .walk import kids_reach, root_list, walk_levels

__all__ = ["gpu_lists", "up32"]

#: The float32 node tables (made once per table, kept while it lives).
_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def up32(x) -> np.ndarray:
    """``x`` (non-negative float64) rounded up to float32."""
    x = np.asarray(x, np.float64)
    y = x.astype(np.float32)
    low = y.astype(np.float64) < x
    y[low] = np.nextafter(y[low], np.float32(np.inf))
    return y


def _table(nodes: NodeArcs):
    """Every node as ``shaders/field_walk.comp`` reads it: (n, 5, 4) float32 records
    (``mid, reach``; ``a, err``; ``b, flags``; ``n``; ``1 - cos reach, sin reach``) and
    (n, 2) int32 children."""
    got = _TABLES.get(nodes)
    if got is None:
        k = len(nodes.a)
        rec = np.zeros((k, 5, 4), np.float32)
        rec[:, 0, :3], rec[:, 0, 3] = nodes.mid, up32(nodes.reach)
        rec[:, 1, :3], rec[:, 1, 3] = nodes.a, up32(nodes.err)
        ok = dot(nodes.n, nodes.n) > 0.5  # a unit normal (else none)
        rec[:, 2, :3], rec[:, 2, 3] = nodes.b, nodes.leaf + 2.0 * ok
        rec[:, 3, :3] = nodes.n
        r = np.minimum(nodes.reach, np.pi)
        rec[:, 4, 0], rec[:, 4, 1] = 2.0 * np.sin(0.5 * r) ** 2, up32(np.sin(r))
        got = _TABLES[nodes] = (rec, nodes.child.astype(np.int32))
    return got


def gpu_lists(nodes: NodeArcs, grid, m: float, stop: int):
    """Return each cell's count (row-major) and the pairs' arcs of level ``stop``, or None.

    The lists of :func:`~gloffset.raster.fields.walk.walk_levels` at ``stop`` (below the
    output level), as supersets (see the module notes): every original arc (node split
    down to the arcs) that can be the nearest arc within ``m`` of a point within ``rho``
    of a cell's centre. The arcs of a cell come in no set order.
    """
    last = grid.n_levels - 1
    if not 0 <= stop < last:
        return None
    first = next((lev for lev in range(stop) if _cells(grid, lev) >= GPU_CELLS), stop)
    parents = _parents(nodes, grid, m, first)
    levels = [_level(grid, lev, stop, last) for lev in range(first, stop + 1)]
    mm = float(up32(min(m, 4.0))) if math.isfinite(m) else 4.0
    deep = dominance.DEEP if dominance.DOMINANCE else 0.0
    got = walk_pass().run(_table(nodes), parents, levels, mm, deep)
    if got is None:
        return None
    return got[0], got[1].astype(np.int64)


#: The GPU walks the levels from the first with at least this many cells (the float64
#: walk the coarser ones: a few cells with long lists are a poor fit for the GPU).
GPU_CELLS = 4096


def _cells(grid, lev: int) -> int:
    h, w = grid.level_shape(lev)
    return h * w


def _parents(nodes: NodeArcs, grid, m: float, first: int):
    """The lists the GPU walk starts from: level 0's root list (one row, every cell's),
    or those of level ``first - 1`` from the float64 walk, by cell (row-major)."""
    if first == 0:
        h0, w0 = grid.level_shape(0)
        jj, ii = np.meshgrid(np.arange(h0), np.arange(w0), indexing="ij")
        c0 = grid.centers(0, jj.ravel(), ii.ravel())
        rho0 = grid.rho_at(0, jj.ravel(), ii.ravel())
        root = root_list(nodes, m, c0, rho0, nodes.top[nodes.boundary[nodes.top]])
        return np.array([[0, len(root)]], np.uint32), np.asarray(root, np.uint32)
    wc = grid.level_shape(first - 1)[1]
    keys, vals = [], []
    for f, _ in walk_levels(nodes, grid, m, first - 1, split=False):
        keys.append((f.cells[:, 0].astype(np.int64) * wc + f.cells[:, 1])[f.pair_cell])
        vals.append(f.pair_arc)
    key, val = np.concatenate(keys), np.concatenate(vals)
    order = np.argsort(key, kind="stable")
    count = np.bincount(key, minlength=_cells(grid, first - 1))
    sc = np.column_stack([np.cumsum(count) - count, count]).astype(np.uint32)
    return sc, val[order].astype(np.uint32)


def _level(grid, lev: int, stop: int, last: int) -> WalkLevel:
    """The cells of level ``lev`` as the shader reads them: centre and reach (the cell's
    ``rho``, or at the level above the output its children's farthest centre), and the
    error bound above which a node is split (``KAPPA rho``; 0 at ``stop``: the arcs)."""
    h, w = grid.level_shape(lev)
    jj, ii = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    j, i = jj.ravel(), ii.ravel()
    c = grid.centers(lev, j, i)
    rho = grid.rho_at(lev, j, i)
    reach = rho
    if lev == last - 1:
        f = Frontier(lev, np.column_stack([j, i]), c, rho, j[:0], j[:0], np.zeros((0, 0)))
        reach = kids_reach(f, grid)
    cells = np.zeros((len(j), 2, 4), np.float32)
    cells[:, 0, :3], cells[:, 0, 3] = c, up32(reach)
    cells[:, 1, 0] = 0.0 if lev == min(stop, last - 1) else KAPPA * rho
    cells[:, 1, 1], cells[:, 1, 2] = np.cos(reach), np.sin(np.minimum(reach, 0.5 * np.pi))
    return WalkLevel(cells, w, grid.level_shape(lev - 1)[1] if lev else 0)
