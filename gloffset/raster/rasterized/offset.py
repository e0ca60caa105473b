"""Offsets of rasterized curves (paper Sec. 5): the curve is known only as grid cells.

A *curve mask* marks the cells of the output level ``L`` of a grid that a curve
passes through (a river or a border rasterized into an image). A parent cell is
intersected when any of its children is, which gives the intersected cells ``G_l``
of every level. This module holds the float64 side: the paper's region growing at a
single resolution (Sec. 5.1), the hierarchical version (Sec. 5.2), the fallback, and
the public :func:`raster_offset`; :mod:`.curve_mask` rasterizes a :class:`Shape` into
such a mask and :mod:`.curve_levels` orders the intersected cells. The GPU levels are
planned in :mod:`.curve_gpu` and drawn by :mod:`gloffset.gl.rasterized_pass`; they
return exactly these classes.

Grids: :class:`~gloffset.grids.Equirect`, and :class:`~gloffset.grids.Cube` with its six
faces one set of cells (the offset runs across faces).

The classification compares squared chords between float64 cell centres, with bounds
that make a coarse decision that of every descendant pixel, so the hierarchical answer
equals the single-resolution one and every method gives bit-identical classes.

Meaning of the output classes (the accuracy contract): when the mask is exactly
the set of output cells that the curve ``C`` passes through, a *contained* cell's
centre lies within ``d`` of ``C``; an *outside* cell's centre is farther than
``d + s`` from ``C``, so the whole cell is farther than ``d`` when its own area bound
is at most ``s`` (pixels no larger than the curve's largest); *frontier* cells are
undecided. So ``contained ⊆ offset ⊆ contained ∪ frontier`` at cell centres.
:func:`rasterize` marks the cells an arc passes within 1e-7 pixel of, so for a
rasterized :class:`Shape` these hold up to 1e-7 of a pixel. The derivation in full:
``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...ellipsoid import as_ellipsoid
from ...errors import InvalidDistanceError, InvalidMaskError, OptionError
from ...geometry.classes import CONTAINED, FRONTIER, OUTSIDE
from ...geometry.sphere import chord2_between
from ...grids.conformal import ConformalRows
from ...grids.protocol import CurveMaskImage, RegularLonLat
from ...units import EARTH_RADIUS, to_angle, to_metres
from .. import driver
from ..options import keyword_options
from .curve_levels import (
    RasterizedCurve,
    classify_cells,
    level_centers,
    near_pairs,
    neighbours,
)

__all__ = [
    "OUTSIDE",
    "FRONTIER",
    "CONTAINED",
    "InvalidMaskError",
    "RasterOffsetError",
    "RasterOffsetInfo",
    "RasterOffsetOptions",
    "raster_offset",
    "raster_offset_angle",
    "raster_offset_with",
]

# region-growing states (the paper's active and inactive frontier cells)
_UNKNOWN, _ACTIVE, _INACTIVE = 0, 1, 4
_BACKENDS = ("gpu", "cpu")
_MODES = ("hierarchical", "single")


#: The former name of :class:`~gloffset.errors.OptionError` (a raster offset request with a
#: bad backend, mode, level or grid), kept so that ``except RasterOffsetError`` works.
RasterOffsetError = OptionError


# ---------------------------------------------------------------------------- Sec. 5.1
def region_grow(lv: RasterizedCurve, level: int) -> tuple[np.ndarray, str, str | None]:
    """Sec. 5.1 on the cells of ``level``: classes, method and fallback reason.

    Walks ``g_0..g_k`` (runs of 8-adjacent cells; each run starts by growing the
    region of its first cell through every cell within ``d_max``). For each next
    cell, active frontier cells farther than ``d_max`` become inactive; the rest
    seed a flood over unknown and frontier cells within ``d_max`` (an inactive cell
    reached this way is evaluated again).

    Breakdowns are detected and handled by methods that do not break down:

    * an empty active frontier (the paper's failure case: the curve runs deep
      inside the region already grown, e.g. where it intersects itself or doubles
      back): the region of that cell is grown afresh through every cell within
      ``d_max`` ("regrown");
    * afterwards every frontier cell, and every unknown cell next to the region, is
      checked against :func:`classify_cells`; any difference sends the whole level
      to the direct classification of every cell within reach.

    ``method`` is ``"region-growing"`` when neither happened, else ``"fallback"``
    with the reason. The classes are the same in every case.
    """
    grid = lv.grid
    h, w = grid.level_shape(level)
    seq, start = lv.sequence(level)
    state, regrown = _grow(lv, level, seq, start)
    cls = np.zeros(h * w, dtype=np.uint8)
    cls[state == CONTAINED] = CONTAINED
    cls[(state == _ACTIVE) | (state == _INACTIVE)] = FRONTIER
    front = np.flatnonzero(cls == FRONTIER)
    known = np.flatnonzero(state != _UNKNOWN)
    ring = neighbours(grid, level, known)
    ring = ring[state[ring] == _UNKNOWN]
    check = np.concatenate([front, ring])
    want = classify_cells(lv, level, check)
    bad = int(np.count_nonzero(want != cls[check]))
    reason = None
    if regrown:
        reason = (
            f"empty active frontier at {len(regrown)} of {len(seq)} curve cells of level "
            f"{level} (first at cell {regrown[0]}): regrown from each of them"
        )
    if bad:
        more = f"{bad} cells of level {level} missed by region growing: level classified directly"
        return _fallback(lv, level), "fallback", more if reason is None else f"{reason}; {more}"
    return cls.reshape(h, w), ("fallback" if regrown else "region-growing"), reason


def _grow(lv: RasterizedCurve, level: int, seq: np.ndarray, start: np.ndarray):
    grid = lv.grid
    h, w = grid.level_shape(level)
    state = np.zeros(h * w, dtype=np.uint8)
    best = np.full(h * w, np.inf)
    stamp = np.full(h * w, -1, dtype=np.int64)
    t_lo, t_hi = lv.t_lo[level], lv.t_hi[level]
    active = np.zeros(0, dtype=np.int64)
    gc = level_centers(grid, level, seq)
    regrown = []

    def update(cells, c2):
        best[cells] = np.minimum(best[cells], c2)
        row = cells // w
        cont = best[cells] < t_lo[row]
        st = state[cells]
        state[cells] = np.where(cont | (st == CONTAINED), CONTAINED, _ACTIVE)

    for k in range(len(seq)):
        g, gk = seq[k], gc[k]
        through = bool(start[k])
        if not through:
            c2 = chord2_between(level_centers(grid, level, active), gk)
            near = c2 < t_hi[active // w]
            state[active[~near]] = _INACTIVE
            if near.any():
                wave = active[near]
                update(wave, c2[near])
            else:  # the paper's breakdown: no active frontier cell near g_k
                regrown.append(k)
                through = True
        if through:
            state[active[state[active] == _ACTIVE]] = _INACTIVE
            wave = np.array([g], dtype=np.int64)
            update(wave, np.zeros(1))
        stamp[wave] = k
        new = [wave]
        while len(wave):
            nb = neighbours(grid, level, wave)
            nb = nb[stamp[nb] != k]
            if not through:
                nb = nb[state[nb] != CONTAINED]
            c2 = chord2_between(level_centers(grid, level, nb), gk)
            ok = c2 < t_hi[nb // w]
            wave = nb[ok]
            stamp[wave] = k
            update(wave, c2[ok])
            new.append(wave)
        cand = np.concatenate(new) if through else np.concatenate([active] + new[1:])
        active = np.unique(cand[state[cand] == _ACTIVE])
    return state, regrown


def _fallback(lv: RasterizedCurve, level: int) -> np.ndarray:
    """Every cell within reach of an intersected cell, classified directly."""
    grid = lv.grid
    h, w = grid.level_shape(level)
    cls = np.zeros(h * w, dtype=np.uint8)
    # candidate cells: those of buckets near the curve, found with near_pairs on a
    # coarse level whose cells bound their descendants
    m = 0
    for lev in range(level + 1):
        if float(np.max(grid.rho(lev))) <= 0.25 * lv.reach[level]:
            m = lev
            break
    else:
        m = level
    hm, wm = grid.level_shape(m)
    allm = np.arange(hm * wm)
    rho_m = np.asarray(grid.rho(m))
    sh = level - m
    cj, ci = np.divmod(lv.curve[level], w)
    cb = np.unique((cj >> sh) * wm + (ci >> sh))
    hit = np.zeros(hm * wm, dtype=bool)
    for iq, _, _ in near_pairs(
        grid, m, allm, rho_m[allm // wm], m, cb, lv.reach[level] + float(rho_m.max())
    ):
        hit[iq] = True
    bj, bi = np.divmod(np.flatnonzero(hit), wm)
    side = 1 << sh
    dj, di = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    jj = (bj[:, None] * side + dj.ravel()[None, :]).ravel()
    ii = (bi[:, None] * side + di.ravel()[None, :]).ravel()
    ok = (jj < h) & (ii < w)
    cells = jj[ok] * w + ii[ok]
    cls[cells] = classify_cells(lv, level, cells)
    return cls.reshape(h, w)


# ---------------------------------------------------------------------------- Sec. 5.2
class RasterCells:
    """The classifier of the cells of a grid against a rasterized curve.

    Sec. 5.2, a :class:`gloffset.raster.driver.Classifier`: level 0 by region growing
    (:func:`region_grow`, Sec. 5.1), then the children of each level's frontier cells
    (active and inactive) by :func:`classify_cells`. ``method`` and ``reason`` tell how
    level 0 was classified.
    """

    def __init__(self, lv: RasterizedCurve):
        self.lv, self.grid = lv, lv.grid
        self.method: str | None = None
        self.reason: str | None = None

    def enter(self, stop: int) -> driver.Level:
        classes, self.method, self.reason = region_grow(self.lv, 0)
        front = np.argwhere(classes == FRONTIER)
        return driver.Level(0, front, np.full(len(front), FRONTIER, np.uint8), dense=classes)

    def refine(self, prev: driver.Level) -> driver.Level:
        level = prev.level + 1
        h, w = self.grid.level_shape(level)
        front = prev.cells[prev.cls == FRONTIER]
        quarters = []
        for dj in (0, 1):
            for di in (0, 1):
                j, i = 2 * front[:, 0] + dj, 2 * front[:, 1] + di
                ok = (j < h) & (i < w)
                quarters.append(j[ok] * w + i[ok])
        kids = np.sort(np.concatenate(quarters))
        cells = np.column_stack(np.divmod(kids, w))
        return driver.Level(level, cells, classify_cells(self.lv, level, kids))


def hierarchical(
    lv: RasterizedCurve, *, stop_level: int | None = None, callback=None, timings=None
):
    """Classify the cells of ``lv``'s grid down to ``stop_level`` (Sec. 5.2).

    Level 0 by region growing (Sec. 5.1), then each level evaluates only the children of the
    previous level's frontier cells (:class:`RasterCells`).

    Returns ``(classes of stop_level, method, reason)``.
    """
    stop = lv.grid.n_levels - 1 if stop_level is None else stop_level
    cells = RasterCells(lv)
    classes, _ = driver.classes_of_level(cells, stop, callback=callback, timings=timings)
    return classes, cells.method, cells.reason


# ---------------------------------------------------------------------------- API
@dataclass
class RasterOffsetInfo:
    """How a raster offset was computed.

    Attributes
    ----------
    method : {"region-growing", "fallback"}
        ``"fallback"`` when the paper's region growing broke down (an empty active
        frontier, e.g. for a self-intersecting curve, or cells it missed) and the
        level was classified directly instead; the classes are the same either way.
    reason : str or None
        Why the fallback was taken.
    backend, mode : str
    s : float
        The output-cell area bound used (radians).
    d_min, d_max : float
        The output level's thresholds (radians).
    n_ambiguous : int
        GPU cells whose float32 value was too close to a threshold and that were
        decided in float64 on the CPU (0 on the CPU backend).
    frontier : list of int
        Frontier cells per level computed.
    seconds : float
    """

    method: str
    reason: str | None
    backend: str
    mode: str
    s: float
    d_min: float
    d_max: float
    n_ambiguous: int = 0
    frontier: list = field(default_factory=list)
    seconds: float = 0.0


@dataclass(frozen=True, kw_only=True)
class RasterOffsetOptions:
    """The options of :func:`raster_offset`, each documented there."""

    radius: float = EARTH_RADIUS
    backend: str = "gpu"
    mode: str = "hierarchical"
    level: int | None = None
    order: Any = None
    return_info: bool = False
    callback: Any = None
    ellipsoid: Any = None


def _on_ellipsoid(mask, distance, grid, options: RasterOffsetOptions):
    """:func:`raster_offset` on an ellipsoid (see its ``ellipsoid``).

    Two spherical offsets on the conformal rows, contained from the nearer, outside from the
    farther.
    """
    ell = as_ellipsoid(options.ellipsoid)
    assert ell is not None  # called with an ellipsoid
    if not (isinstance(grid, RegularLonLat) and grid.curve_masks):
        raise OptionError(
            f"raster offsets on an ellipsoid take an Equirect grid, got {type(grid).__name__}"
        )
    if options.return_info or options.callback is not None:
        raise OptionError(
            "raster offsets on an ellipsoid give classes only (no return_info, callback)"
        )
    m = to_metres(distance)
    if m <= 0.0:
        raise InvalidDistanceError(
            f"distance must be a positive number of metres on the ellipsoid, got {distance!r}"
        )
    near = m / (ell.k_max * (1.0 + 1e-11))  # within it on the sphere: within m surely
    far = m / (ell.k_min * (1.0 - 1e-11))  # beyond it on the sphere: beyond m surely
    if far >= 1.5:
        raise InvalidDistanceError(
            f"distance {m!r} m is {far:.4g} rad on the conformal sphere; raster offsets need "
            "less than 1.5 rad"
        )
    cgrid = ConformalRows(grid, ell)
    inner = raster_offset_angle(mask, near, cgrid, options)
    outer = raster_offset_angle(mask, far, cgrid, options)
    out = np.where(inner == CONTAINED, CONTAINED, np.where(outer == OUTSIDE, OUTSIDE, FRONTIER))
    return out.astype(np.uint8)


def _check_mask(mask, grid) -> np.ndarray:
    if not (isinstance(grid, CurveMaskImage) and grid.curve_masks):
        raise OptionError(
            f"grid must be a gloffset.grids.Equirect or Cube grid, got {type(grid).__name__}"
        )
    m = np.asarray(mask)
    if m.dtype != bool and not np.issubdtype(m.dtype, np.integer):
        raise InvalidMaskError(f"mask must be a boolean (or integer) array, got dtype {m.dtype}")
    if m.shape != grid.shape:
        want = "(face, row, column)" if grid.n_faces > 1 else "(height, width)"
        raise InvalidMaskError(f"mask has shape {m.shape}, the grid needs {want} = {grid.shape}")
    m = m != 0
    if not m.any():
        raise InvalidMaskError("mask is empty: no curve cell to offset")
    return m


def raster_offset(mask, distance: float | str, grid, **options):
    """Offset a rasterized curve without its vector data (paper Sec. 5).

    Parameters
    ----------
    mask : (height, width) bool array, or (6, N, N) for ``Cube(N)``
        The output cells of ``grid`` that the curve passes through (row 0 north;
        cube: [face, row, column], faces +X -X +Y -Y +Z -Z as :func:`gloffset.render`
        returns them); integer arrays count non-zero as True.
    distance : float or str
        Offset distance in the units of ``radius`` (metres by default), or a string with
        a unit (``"127km"``), > 0; with ``ellipsoid``, a geodesic length.
    grid : gloffset.grids.Equirect or gloffset.grids.Cube
        On a cube the six faces are one set of cells: the curve, the region growing
        and the offset run across face edges and corners.
    **options
        Keywords, below (:class:`RasterOffsetOptions`); another is a :class:`TypeError`
        that lists them.

    Other Parameters
    ----------------
    radius : float
        The sphere's radius (default :data:`gloffset.EARTH_RADIUS`, metres).
    backend : {"gpu", "cpu"}
        ``"gpu"``: the coarse levels on the CPU, the levels below the bins in
        fragment shaders (:mod:`gloffset.raster.rasterized.curve_gpu`); ``"cpu"``: float64
        numpy only (the reference).
    mode : {"hierarchical", "single"}
        CPU only: Sec. 5.2 coarse to fine, or Sec. 5.1 region growing on the output
        level alone. Both give the same classes.
    level : int, optional
        Return the classes of this level (hierarchical) instead of the output's.
    order : list of int arrays, optional
        The curve's cells in curve order (flat indices of ``mask``, as from
        ``rasterize(..., ordered=True)``); default: a depth-first walk of the mask.
    return_info : bool
        Also return a :class:`RasterOffsetInfo`.
    callback : callable, optional
        ``callback(level, classes)`` after each level (CPU levels only).
    ellipsoid : None, "WGS84", "GRS80", (a, f) or Ellipsoid
        ``None``: the sphere of ``radius``. Otherwise (Equirect grids) ``distance`` is a
        geodesic length in metres and the grid's latitudes are geodetic: the classes
        are those of the spherical offsets on the ellipsoid's conformal sphere
        (:class:`~gloffset.grids.conformal.ConformalRows`) at ``distance / K_max``
        (contained) and ``distance / K_min`` (outside), frontier between, so the
        contract below holds with geodesic distances (the frontier is wider by the
        ratio bound, 0.34 % of ``distance``). No ``return_info`` or ``callback``.

    Returns
    -------
    classes : uint8 array of ``grid.level_shape(level)`` (cube: ``(6, n, n)``)
        0 outside, 1 frontier, 2 contained. With ``return_info``, ``(classes, info)``.

    Notes
    -----
    See the module notes for the thresholds. When ``mask`` holds exactly the cells
    that a curve passes through: a contained cell's centre is within ``distance``
    of the curve; every point of an outside cell is farther; frontier cells are
    undecided. The GPU returns exactly the CPU classes (cells whose float32 value
    falls within a rigorous error bound of a threshold are decided in float64).

    Examples
    --------
    >>> import numpy as np
    >>> from gloffset.grids import Equirect
    >>> g = Equirect(64, 32)
    >>> m = np.zeros(g.shape, bool); m[16, 20:40] = True
    >>> c = raster_offset(m, 1500e3, g, backend="cpu")
    >>> bool(c[16, 30] == 2), bool(c[0, 0] == 0)
    (True, True)
    """
    return raster_offset_with(
        mask, distance, grid, keyword_options(RasterOffsetOptions, options, "raster_offset")
    )


def raster_offset_with(mask, distance, grid, options: RasterOffsetOptions):
    """Return :func:`raster_offset` with its keywords as one :class:`RasterOffsetOptions`."""
    if options.ellipsoid is not None:
        return _on_ellipsoid(mask, distance, grid, options)
    d = to_angle(distance, options.radius)
    if not 0.0 < d < 1.5:
        raise InvalidDistanceError(
            f"distance {distance!r} is {d:.4g} rad; raster offsets need 0 < d < 1.5 rad"
        )
    return raster_offset_angle(mask, d, grid, options)


def raster_offset_angle(mask, d: float, grid, options: RasterOffsetOptions):
    """Return :func:`raster_offset` at the angle ``d`` (radians).

    The angle is checked by the caller (``0 < d < 1.5``); ``options.radius`` and
    ``options.ellipsoid`` are not read.
    """
    backend, mode, level = options.backend, options.mode, options.level
    order, callback = options.order, options.callback
    t0 = time.perf_counter()
    m = _check_mask(mask, grid)
    cube = grid.cell_set() if grid.n_faces > 1 else None
    if cube is not None:  # the six faces as one grid of cells (stacked rows)
        grid, m = cube, cube.stack(m)
        if order is not None:
            order = [cube.from_faces_flat(p) for p in order]
    if backend not in _BACKENDS:
        raise OptionError(f"backend must be one of {', '.join(_BACKENDS)}, got {backend!r}")
    if mode not in _MODES:
        raise OptionError(f"mode must be one of {', '.join(_MODES)}, got {mode!r}")
    last = grid.n_levels - 1
    if level is not None and not (isinstance(level, (int, np.integer)) and 0 <= level <= last):
        raise OptionError(f"level must be in 0..{last}, got {level!r}")
    stop = last if level is None else int(level)
    lv = RasterizedCurve.build(m, d, grid, parts=order)
    frontier: list = []

    def cb(lev, cls):
        frontier.append(int(np.count_nonzero(cls == FRONTIER)))
        if callback is not None:
            callback(lev, cls if cube is None else cube.unstack(lev, cls))

    n_amb = []
    if backend == "cpu" and mode == "single":
        classes, method, reason = region_grow(lv, stop)
        cb(stop, classes)
    else:
        cells = RasterCells(lv)
        gpu = None
        if backend == "gpu":
            from .curve_gpu import gpu_levels

            def gpu(classes, _lev):
                classes, n = gpu_levels(lv, classes, stop_level=stop, callback=cb)
                n_amb.append(n)
                return classes

        classes = driver.run(cells, stop, handoff=grid.bin_level, backend=gpu, callback=cb)
        assert cells.method is not None  # set on entering level 0
        method, reason = cells.method, cells.reason
    if cube is not None:
        classes = cube.unstack(stop, classes)
    info = RasterOffsetInfo(
        method=method,
        reason=reason,
        backend=backend,
        mode=mode if backend == "cpu" else "hierarchical",
        s=lv.s,
        d_min=d - lv.s,
        d_max=d + 2.0 * lv.s,
        n_ambiguous=sum(n_amb),
        frontier=frontier,
        seconds=time.perf_counter() - t0,
    )
    return (classes, info) if options.return_info else classes
