"""The classifier of grid cells against the offset region of vector curves.

:class:`CurveCells` is the :class:`~gloffset.raster.driver.Classifier` that renders and
tile pyramids drive: level 0 from the arcs' cap tree (:func:`gloffset.raster.vector.levels.coarse`)
or a finer level entered directly (:func:`gloffset.raster.vector.scatter.scatter`), then the
children of the kept cells (:func:`gloffset.raster.vector.levels.refine`), every cell decided by
the rules of :mod:`gloffset.raster.vector.levels` with exact float64 distances.
:func:`classify_curves` runs it to a level (the float64 reference renderer when run to the
output level).
"""

from __future__ import annotations

import numpy as np

from ...edges import CurveArcs, inside_any
from .. import driver
from ..driver import FRONTIER, NOT_FORCED, Level
from . import node_levels
from .levels import Frontier, at_cells, cell_distances, coarse, decide, prune, refine, subset
from .scatter import scatter, start_level

__all__ = ["CurveCells", "classify_curves"]


class CurveCells:
    """The classifier of grid cells against the offset region of a shape's curves at
    signed distance ``d`` (:class:`gloffset.raster.driver.Classifier`; the rules of the
    module notes).

    ``start="coarse"`` enters at level 0 (the reference renderer); ``start="auto"``
    enters the finest level that :func:`gloffset.raster.vector.scatter.start_level` allows
    directly (lon/lat grids, small distances), and an int enters that level
    (:func:`gloffset.raster.vector.scatter.scatter`). All give the same classes from that level
    on. A :class:`~gloffset.raster.driver.Level`'s ``state`` is the :class:`Frontier` of
    its classified cells (of its frontier cells when the level was entered directly).
    """

    def __init__(
        self,
        shape,
        d: float,
        grid,
        *,
        start: str | int = "coarse",
        nodes_until: int | None = None,
        pairs=None,
        refine_pairs=None,
    ):
        self.shape, self.d, self.grid = shape, d, grid
        self.arcs = CurveArcs.from_shape(shape)
        self.e = abs(d)
        self.last = grid.n_levels - 1
        self.start = start
        #: what finds a directly entered level's box pairs (``scatter``'s ``pairs``)
        self.pairs = pairs
        #: what may do a refined level's per-pair work (``refine``'s ``pairs``)
        self.refine_pairs = refine_pairs
        if nodes_until is not None and not 0 <= nodes_until < self.last:
            nodes_until = None
        #: the last level whose lists hold arcs of the multiresolution curve
        #: (:mod:`gloffset.raster.vector.node_levels`), or None
        self.nodes_until = nodes_until
        #: refined levels kept for a second caller (:meth:`remember`), by parent cells
        self._memo: dict | None = None

    def remember(self, ahead: int | None) -> None:
        """Keep each refined level until it is asked for again (once), by the level and
        the cells of its parents. A tile pyramid refines the same frontier twice: its
        bin levels run ahead of the zoom walk (:class:`gloffset.tiles.tiling.walk.BinChain`)
        and the walk reaches the same cells later. The classes, candidates and
        measures are those of computing the level again: only the work is saved.
        ``ahead``: how many levels the first caller runs ahead of the second (levels
        further behind are dropped); ``None`` stops keeping them."""
        self._memo = None if ahead is None else {}
        self._ahead = ahead

    def _entry(self, stop: int):
        """The level entered directly and its plan, or ``(None, None)``."""
        if self.start == "auto":
            return start_level(self.arcs, self.grid, self.e, stop)
        if self.start != "coarse":
            ok = isinstance(self.start, int) and 0 <= self.start <= stop and self.grid.lonlat
            if not ok:
                raise ValueError(
                    f"start must be 'coarse', 'auto' or a level in 0..{stop} of a lon/lat "
                    f"grid, got {self.start!r}"
                )
            return self.start, None
        return None, None

    def enter(self, stop: int) -> Level:
        at, plan = self._entry(stop)
        if at is None and self.nodes_until is not None:
            return self._node_level(node_levels.enter(self.shape, self._nodes(), self.grid, self.e))
        if at is None:
            f = coarse(self.shape, self.arcs, self.grid, self.e)
            return self._level(f)
        dense, f = scatter(
            self.shape,
            self.arcs,
            self.grid,
            self.d,
            at,
            final=(at == self.last),
            plan=plan,
            pairs=self.pairs,
        )
        return Level(at, f.cells, np.full(len(f.cells), FRONTIER, dtype=np.uint8), f, dense)

    def enter_cells(self, level: int, cells, status=None) -> Level:
        """The cells ``(row, column)`` of ``level`` alone, classified without the levels
        above (:func:`gloffset.raster.vector.levels.at_cells`, ``status`` the cells'
        statuses where known): the work of a few cells of a fine level follows their
        neighbourhood, not the whole input."""
        f = at_cells(self.shape, self.arcs, self.grid, self.e, level, cells, status)
        return self._level(f)

    def _level(self, f: Frontier) -> Level:
        """The cells of ``f`` classified: exact float64 distances to their candidates
        (kept as ``measure``), decided with the grid's ``decision_rho``."""
        dist, dring, low = cell_distances(f, self.arcs, lows=True)
        rho = self.grid.decision_rho(f.level, f.cells[:, 0], f.cells[:, 1])
        final = f.level == self.last
        cls = decide(dist, dring, inside_any(f.status), rho, self.d, final)
        return Level(f.level, f.cells, cls, prune(f, low, dist, self.e), measure=dist)

    def _nodes(self) -> node_levels.NodeArcs:
        return node_levels.NodeArcs.from_shape(self.shape)

    def _node_level(self, f: Frontier) -> Level:
        """The cells of ``f`` (lists of nodes) classified (:func:`node_levels.classify_nodes`)."""
        rho = self.grid.decision_rho(f.level, f.cells[:, 0], f.cells[:, 1])
        cls, dist = node_levels.classify_nodes(f, self._nodes(), rho, self.d)
        return Level(f.level, f.cells, cls, f, measure=dist)

    def _children(self, parent: Frontier) -> Level:
        """The children of ``parent``'s cells, classified: lists of nodes down to
        ``nodes_until``, of the original arcs below."""
        until = self.nodes_until
        if until is not None and parent.level < until:
            nodes = self._nodes()
            return self._node_level(
                node_levels.refine(parent, self.grid, nodes, self.e, self.shape)
            )
        if until is not None and parent.level == until:
            nodes = self._nodes()
            f = node_levels.refine(parent, self.grid, nodes, self.e, self.shape, leaves=True)
            return self._level(f)
        return self._level(
            refine(parent, self.grid, self.arcs, self.e, self.shape, pairs=self.refine_pairs)
        )

    def kept(self, lev: Level) -> Frontier:
        """The :class:`Frontier` of the cells ``lev`` keeps (its frontier by default)."""
        keep = lev.frontier() if lev.keep is None else lev.keep
        if len(keep) == len(lev.cells):
            return lev.state
        return subset(lev.state, keep)

    def refine(self, prev: Level) -> Level:
        parent = self.kept(prev)
        lev = self._refined(parent)
        if prev.forced is not None and (prev.forced != NOT_FORCED).any():
            parent_keys = (parent.cells[:, 0] << 32) | parent.cells[:, 1]
            rows, cols = lev.cells[:, 0], lev.cells[:, 1]
            pf = prev.forced[np.searchsorted(parent_keys, ((rows >> 1) << 32) | (cols >> 1))]
            lev.cls = np.where(pf != NOT_FORCED, pf, lev.cls).astype(np.uint8)
        return lev

    def _refined(self, parent: Frontier) -> Level:
        """The children of ``parent``'s cells, classified (or kept from before)."""
        memo = self._memo
        if memo is None:
            return self._children(parent)
        key = (parent.level, parent.cells.tobytes())
        lev = memo.pop(key, None)
        if lev is None:
            lev = self._children(parent)
            assert self._ahead is not None  # set with the memo
            for k in [k for k in memo if k[0] < parent.level - self._ahead]:  # not asked for
                del memo[k]
            memo[key] = lev
        # a copy: callers set keep, forced and classes on the level they get
        return Level(lev.level, lev.cells, lev.cls, lev.state, measure=lev.measure)


def classify_curves(
    shape,
    d: float,
    grid,
    *,
    stop_level: int | None = None,
    callback=None,
    timings=None,
    start: str | int = "coarse",
):
    """Classify the grid level by level in float64 down to ``stop_level`` (default: output).

    Returns ``(classes, frontier, arcs)``: the full class array of ``stop_level``, the
    :class:`Frontier` of its frontier cells (empty at the output level) and the
    shape's :class:`~gloffset.edges.CurveArcs`. ``callback(level, classes)`` is called
    after each level; ``timings``, a list, gets ``(level, time.perf_counter())`` after
    each level. ``start``: see :class:`CurveCells` (the levels above the one entered
    directly are reported pooled from it).
    """
    cells = CurveCells(shape, d, grid, start=start)
    stop = grid.n_levels - 1 if stop_level is None else stop_level
    classes, lev = driver.classes_of_level(cells, stop, callback=callback, timings=timings)
    return classes, cells.kept(lev), cells.arcs
