"""The level driver: coarse to fine over any grid, one loop for every raster.

Every raster of gloffset (a render of a vector offset, the offset of a rasterized
curve, a tile pyramid) classifies the cells of a grid (:class:`~gloffset.grids.protocol.Grid`)
level by level: a level's cells are *contained*, *outside* or *frontier*, and only the
children of frontier cells are classified at the next level (the paper's Sec. 5.2). What
differs is how a cell is classified; that is a :class:`Classifier`:

* :class:`gloffset.raster.vector.curves.CurveCells`: against the offset region of vector curves
  (exact float64 distances to candidate arcs);
* :class:`gloffset.raster.rasterized.offset.RasterCells`: against the cells of a rasterized curve.

The driver walks the levels (:func:`walk`, sparse: a :class:`Level` per level) and paints
them into one class array per level (:func:`classes_of_level`, dense, with the ``callback`` and
``timings`` every raster offers). The backend is pluggable: the classifier on the CPU
(float64 numpy, every level), or the classifier down to a hand-off level and a GL
backend (:mod:`gloffset.gl`) below it (:func:`run`).

Class codes: :data:`OUTSIDE`, :data:`FRONTIER`, :data:`CONTAINED`
(:mod:`gloffset.geometry.classes`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from ..geometry.classes import CONTAINED, FRONTIER, OUTSIDE
from ..grids.protocol import Grid

__all__ = [
    "OUTSIDE",
    "FRONTIER",
    "CONTAINED",
    "NOT_FORCED",
    "Level",
    "Classifier",
    "walk",
    "classes_of_level",
    "run",
    "pooled",
    "upsample",
]


@dataclass
class Level:
    """The cells classified at one level.

    ``cells`` (k, 2) rows and columns and ``cls`` their classes; ``state`` what the
    classifier needs to go on from here (e.g. the candidate arcs of each cell);
    ``measure`` what it measured per cell (e.g. the distance to the nearest curve);
    ``dense``, when the classifier classified the whole level at once, its class array
    (``cells`` then holds its frontier cells only; the coarser levels are reported
    pooled from it, :func:`pooled`).

    The cells refined at the next level are the frontier ones, unless the consumer of
    :func:`walk` sets ``keep`` (sorted indices into ``cells``) before asking for the next level;
    ``forced`` (one class per kept cell, :data:`NOT_FORCED` for none) then gives their
    children a class instead of classifying them (a tile pyramid keeps decided tiles
    that an outline crosses, to draw it at every zoom).
    """

    level: int
    cells: np.ndarray
    cls: np.ndarray
    state: Any = None  # the classifier's own (e.g. a Frontier)
    dense: np.ndarray | None = None
    measure: np.ndarray | None = None
    keep: np.ndarray | None = None
    forced: np.ndarray | None = None

    def frontier(self) -> np.ndarray:
        """Indices (into ``cells``) of the frontier cells."""
        return np.flatnonzero(self.cls == FRONTIER)


#: ``Level.forced`` value of a kept cell whose children are classified as usual
NOT_FORCED = 255


class Classifier(Protocol):
    """How the cells of a grid are classified (see the module notes)."""

    @property
    def grid(self) -> Grid:
        """The grid whose cells it classifies."""
        ...

    def enter(self, stop: int) -> Level:
        """The first level classified (level 0, or a finer level ``<= stop`` entered
        directly, with ``dense`` and ``above`` set)."""
        ...

    def refine(self, prev: Level) -> Level:
        """The next level: the children of the cells ``prev`` keeps (its frontier by
        default), classified."""
        ...


def walk(classifier: Classifier, stop: int, *, start: Level | None = None) -> Iterator[Level]:
    """The levels from the classifier's first (or from ``start``, a level classified
    before, e.g. in another process) down to ``stop``, one :class:`Level` each (sparse:
    only the cells classified at that level). Set ``keep`` / ``forced`` on a yielded
    level to choose the cells refined next."""
    lev = classifier.enter(stop) if start is None else start
    yield lev
    while lev.level < stop:
        lev = classifier.refine(lev)
        yield lev


def upsample(classes: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """The classes of a level repeated over its children (the next level's ``shape``)."""
    h, w = shape
    return np.repeat(np.repeat(classes, 2, axis=0), 2, axis=1)[:h, :w]


def pooled(classes: np.ndarray) -> np.ndarray:
    """Classes of the next coarser level: a cell's class where its (up to four) children
    agree, frontier where they differ."""
    h, w = classes.shape
    p = np.pad(classes, ((0, h % 2), (0, w % 2)), mode="edge")
    q = p.reshape(p.shape[0] // 2, 2, p.shape[1] // 2, 2)
    lo, hi = q.min(axis=(1, 3)), q.max(axis=(1, 3))
    return np.where(lo == hi, lo, FRONTIER).astype(np.uint8)


def classes_of_level(
    classifier: Classifier,
    stop: int,
    *,
    callback: Callable | None = None,
    timings: list | None = None,
) -> tuple[np.ndarray, Level]:
    """The class array of ``stop`` and its :class:`Level`, coarse to fine.

    Each level's array is its parent's repeated over the children, with the classified
    cells painted over. ``callback(level, classes)`` is called after each level, coarse
    first (the levels above one a classifier entered directly are reported pooled);
    ``timings``, a list, gets ``(level, time.perf_counter())`` after each level.
    """
    grid = classifier.grid
    classes = None
    lev = None
    for lev in walk(classifier, stop):
        if lev.dense is not None:
            classes = lev.dense
            if callback is not None:
                coarse = [classes]
                for _ in range(lev.level):
                    coarse.append(pooled(coarse[-1]))
                for k in range(lev.level):
                    callback(k, coarse[lev.level - k])
        else:
            shape = grid.level_shape(lev.level)
            if classes is None:
                classes = np.zeros(shape, dtype=np.uint8)
            else:
                classes = upsample(classes, shape)
            classes[lev.cells[:, 0], lev.cells[:, 1]] = lev.cls
        if callback is not None:
            callback(lev.level, classes)
        if timings is not None:
            timings.append((lev.level, time.perf_counter()))
    assert classes is not None and lev is not None  # the walk yields one level at least
    return classes, lev


def run(
    classifier: Classifier,
    stop: int,
    *,
    handoff: int | None = None,
    backend: Callable | None = None,
    callback: Callable | None = None,
    timings: list | None = None,
) -> np.ndarray:
    """The class array of ``stop``: the classifier on the CPU down to ``stop``, or, with
    a ``backend``, down to ``handoff`` and then ``backend(classes, level)`` (the GL
    levels below the bins, given the hand-off level's classes and :class:`Level`) for the
    levels below it."""
    if backend is None or handoff is None or stop <= handoff:
        return classes_of_level(classifier, stop, callback=callback, timings=timings)[0]
    classes, lev = classes_of_level(classifier, handoff, callback=callback, timings=timings)
    return backend(classes, lev)
