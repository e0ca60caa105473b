"""Offsets of rasterized curves (paper Sec. 5): the curve is known only as grid cells.

A *curve mask* marks the cells of the output level ``L`` of a grid that a curve
passes through (a river or a border rasterized into an image). A parent cell is
intersected when any of its children is, which gives the intersected cells ``G_l``
of every level. This module holds the float64 side: rasterizing a :class:`Shape`
into such a mask, ordering the intersected cells, the paper's region growing at a
single resolution (Sec. 5.1), the hierarchical version (Sec. 5.2), the fallback,
and the public :func:`raster_offset`. The GPU levels are planned in
:mod:`gloffset.raster.curve_gpu` and drawn by :mod:`gloffset.gl.raster_engine`; they
return exactly these classes.

Grids: :class:`~gloffset.grids.Equirect`, and :class:`~gloffset.grids.Cube` whose six
faces are one set of cells (:class:`~gloffset.grids.cube.CubeCells`: faces stacked as
rows, neighbours across face edges and corners from the geometry), so the ordering
of the intersected cells, the region growing and the offset run across faces.

The classification (all of it in squared chords between float64 cell centres)
-------------------------------------------------------------------------------
Let ``s`` be the largest area bound (the paper's ``d_g / 2``) of the output cells
in the rows that hold intersected cells: the curve passes within ``s`` of the
centre of every intersected output cell, and every point of the curve lies within
``s`` of one (cube: the largest per-pixel bound, its farthest corner, of the
intersected pixels). For a cell ``q`` of level ``l`` with bound ``rho_q``
(:meth:`Equirect.rho`, per row; 0 at the output level) let ``D(q)`` be the angle
from its centre to the nearest centre of an intersected cell of the same level, and
``R_l`` the largest ``rho`` of the rows of level ``l`` that hold intersected cells
(cube: of the intersected cells themselves; 0 at the output level). Then, with
``d`` the offset distance,

* contained when ``D(q) < d_min = d - s - rho_q - R_l``,
* outside when ``D(q) >= d_max = d + 2 s + rho_q + R_l``,
* frontier otherwise.

At the output level these are the paper's ``d_min = d - d_g/2`` and
``d_max = d + d_g``. At coarser levels the paper's ``d_g`` of a cell and its
descendants becomes ``rho_q`` for the cell itself and ``R_l`` for the intersected
cells, on both sides: a descendant pixel ``p`` of ``q`` and a descendant ``g`` of an
intersected cell ``g'`` satisfy ``|D_L(p) - D_l(q)| <= rho_q + R_l``, so a coarse
decision is the decision of every descendant pixel, and the hierarchical answer
at the output level equals the single-resolution one (``d - rho`` alone, as the
paper writes, would not guarantee that). Comparisons are made as ``chord^2 <
4 sin^2(x / 2)`` in float64 with centres from one table per level, so every method
below gives bit-identical classes.

Meaning of the output classes (the accuracy contract): when the mask is exactly
the set of output cells that the curve ``C`` passes through, a *contained* cell's
centre lies within ``d`` of ``C``; an *outside* cell's centre is farther than
``d + s`` from ``C``, so the whole cell is farther than ``d`` when its own area bound
is at most ``s`` (pixels no larger than the curve's largest); *frontier* cells are
undecided. So ``contained ⊆ offset ⊆ contained ∪ frontier`` at cell centres.
:func:`rasterize` marks the cells an arc passes within 1e-7 pixel of, so for a
rasterized :class:`Shape` these hold up to 1e-7 of a pixel.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ..caps import cap_within, pad
from ..caps import chord2 as chord2_of_angle
from ..classes import CONTAINED, FRONTIER, OUTSIDE
from ..errors import InvalidDistanceError, InvalidMaskError, OptionError
from ..grids import Cube, Equirect
from ..grids.base import LonLatGrid, rect_radius
from ..grids.cube import CubeCells, locate, project
from ..shape import read
from ..sphere import angle, normalize, robust_cross
from ..units import EARTH_RADIUS, to_angle

__all__ = [
    "OUTSIDE",
    "FRONTIER",
    "CONTAINED",
    "InvalidMaskError",
    "RasterOffsetError",
    "RasterOffsetInfo",
    "rasterize",
    "raster_offset",
]

# region-growing states (the paper's active and inactive frontier cells)
_UNKNOWN, _ACTIVE, _INACTIVE = 0, 1, 4
_PAIRS = 1 << 22  # cell pairs per chunk
_REACH_SLACK = 1e-9  # rad added to every search radius (so no float64 rounding hides a cell)
_RASTER_EPS = 1e-7  # pixels: rasterize marks cells this close to the arc
_BACKENDS = ("gpu", "cpu")
_MODES = ("hierarchical", "single")


#: The former name of :class:`~gloffset.errors.OptionError` (a raster offset request with a
#: bad backend, mode, level or grid), kept so that ``except RasterOffsetError`` works.
RasterOffsetError = OptionError


# ---------------------------------------------------------------------------- grid tables
@lru_cache(maxsize=64)
def _tables(grid, level: int):
    """(cos lat, sin lat) per row and (cos lon, sin lon) per column of ``level``.

    Every centre this module uses is ``(cphi cl, cphi sl, sphi)`` from these tables,
    so the same cell has the same float64 centre in every code path.
    """
    h, w = grid.level_shape(level)
    lam = grid.cell_lon(level, np.arange(w))
    phi = grid.cell_lat(level, np.arange(h))
    return np.cos(phi), np.sin(phi), np.cos(lam), np.sin(lam)


def level_centers(grid, level: int, flat: np.ndarray) -> np.ndarray:
    """Unit vectors (n, 3) of the cells ``flat`` (row * width + column) of ``level``.

    Grids whose rows are parallels use per-level tables (:func:`_tables`); other
    grids (the stacked cube faces, :class:`~gloffset.grids.cube.CubeCells`) their own
    ``centers``.
    """
    w = grid.level_shape(level)[1]
    j, i = np.divmod(np.asarray(flat, dtype=np.int64), w)
    if not isinstance(grid, LonLatGrid):
        return grid.centers(level, j, i)
    cp, sp, cl, sl = _tables(grid, level)
    return np.stack([cp[j] * cl[i], cp[j] * sl[i], sp[j]], axis=-1)


def chord2(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Squared chord ``|p - q|^2`` (the one formula every classification uses)."""
    dx = p[..., 0] - q[..., 0]
    dy = p[..., 1] - q[..., 1]
    dz = p[..., 2] - q[..., 2]
    return dx * dx + dy * dy + dz * dz


def pixel_radius(grid) -> np.ndarray:
    """Per-row area bound of the output cells: the farthest point of a pixel's
    lon/lat rectangle from its centre (the paper's ``d_g / 2``), rounded up."""
    if hasattr(grid, "area_rho"):
        return np.asarray(grid.area_rho(grid.n_levels - 1))
    if not isinstance(grid, LonLatGrid):
        raise OptionError(f"no pixel area bound for a {type(grid).__name__} grid")
    last = grid.n_levels - 1
    j = np.arange(grid.level_shape(last)[0], dtype=np.float64)
    phi = grid.cell_lat(last, j)
    north, south = grid._lat_px(j), grid._lat_px(j + 1)
    half = 0.5 * abs(float(grid._lon_px(1) - grid._lon_px(0)))
    r = rect_radius(np.full(len(j), half), phi, np.minimum(north, south), np.maximum(north, south))
    return pad(r)


def _wraps(grid, level: int) -> bool:
    """Whether columns of ``level`` wrap round the globe (east neighbour of the last is 0)."""
    if not isinstance(grid, Equirect) or abs(grid.span_lon - 360.0) > 1e-9:
        return False
    return grid.level_shape(level)[1] * grid.block(level) == grid.width


def neighbours(grid, level: int, flat: np.ndarray) -> np.ndarray:
    """The 8-neighbours (flattened, unique) of the cells ``flat`` of ``level`` (on a
    :class:`~gloffset.grids.cube.CubeCells` grid: every cell touching, across face edges)."""
    if hasattr(grid, "neighbours"):
        return grid.neighbours(level, flat)
    h, w = grid.level_shape(level)
    j, i = np.divmod(np.asarray(flat, dtype=np.int64), w)
    wrap = _wraps(grid, level)
    out = []
    for dj in (-1, 0, 1):
        for di in (-1, 0, 1):
            if dj == 0 and di == 0:
                continue
            jj, ii = j + dj, i + di
            if wrap:
                ii = ii % w
            ok = (jj >= 0) & (jj < h) & (ii >= 0) & (ii < w)
            out.append(jj[ok] * w + ii[ok])
    return np.unique(np.concatenate(out)) if out else np.zeros(0, dtype=np.int64)


# ---------------------------------------------------------------------------- rasterization
def _point_cells(grid, p: np.ndarray, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """Output cells within ``eps`` pixel (index units) of points ``p`` (n, 3): (point, flat)."""
    w_, s_, e_, n_ = grid.bounds
    lon = np.arctan2(p[:, 1], p[:, 0])
    lat = np.arctan2(p[:, 2], np.hypot(p[:, 0], p[:, 1]))
    x = np.mod(lon - math.radians(w_), 2.0 * math.pi) / grid.dlon
    # a point just west of W lands near 2 pi / dlon: bring it to x < 0 for regional grids
    x = np.where(x > 0.5 * (grid.width + 2.0 * math.pi / grid.dlon), x - 2 * math.pi / grid.dlon, x)
    y = (math.radians(n_) - lat) / grid.dlat
    wrap = _wraps(grid, grid.n_levels - 1)
    pid, cells = [], []
    for dx in (-eps, eps):
        for dy in (-eps, eps):
            ii = np.floor(x + dx).astype(np.int64)
            jj = np.floor(y + dy).astype(np.int64)
            if wrap:
                ii = ii % grid.width
            ok = (ii >= 0) & (ii < grid.width) & (jj >= 0) & (jj < grid.height)
            pid.append(np.flatnonzero(ok))
            cells.append(jj[ok] * grid.width + ii[ok])
    # a point on a pole touches every cell of the pole row
    pole = np.flatnonzero(np.hypot(p[:, 0], p[:, 1]) < 1e-12)
    for k in pole:
        row = 0 if p[k, 2] > 0 else grid.height - 1
        if (row == 0 and n_ >= 90.0 - 1e-12) or (row == grid.height - 1 and s_ <= -90.0 + 1e-12):
            pid.append(np.full(grid.width, k))
            cells.append(row * grid.width + np.arange(grid.width))
    pid = np.concatenate(pid)
    cells = np.concatenate(cells)
    order = np.lexsort((cells, pid))  # by point, keeping each point's cells together
    return pid[order], cells[order]


def _crossings(grid, a, b, n, u, theta):
    """Parameters (edge, t) where edges cross pixel meridians and parallels."""
    w_, _, _, n_ = grid.bounds
    lon_a = np.arctan2(a[:, 1], a[:, 0])
    lon_b = np.arctan2(b[:, 1], b[:, 0])
    dlam = np.mod(lon_b - lon_a + math.pi, 2 * math.pi) - math.pi
    xa = np.mod(lon_a - math.radians(w_), 2 * math.pi) / grid.dlon
    xb = xa + dlam / grid.dlon
    k0 = np.floor(np.minimum(xa, xb)).astype(np.int64) + 1
    k1 = np.floor(np.maximum(xa, xb)).astype(np.int64)
    cnt = np.maximum(k1 - k0 + 1, 0)
    e_m = np.repeat(np.arange(len(a)), cnt)
    k = np.repeat(k0, cnt) + (np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    lam = math.radians(w_) + k * grid.dlon
    merid = np.stack([np.cos(lam), np.sin(lam), np.zeros_like(lam)], axis=1)
    mplane = np.stack([-np.sin(lam), np.cos(lam), np.zeros_like(lam)], axis=1)
    q = normalize(np.cross(n[e_m], mplane))
    q = np.where(np.sum(q * merid, axis=1)[:, None] < 0, -q, q)
    t_m = np.arctan2(np.sum(q * u[e_m], axis=1), np.sum(q * a[e_m], axis=1))

    # parallels: z(t) = A cos(t - t0)
    az, uz = a[:, 2], u[:, 2]
    amp = np.hypot(az, uz)
    t0 = np.arctan2(uz, az)
    zs = [a[:, 2], b[:, 2]]
    for tc in (t0, t0 + math.pi, t0 - math.pi):
        inside = (tc > 0) & (tc < theta)
        zs.append(np.where(inside, amp * np.cos(tc - t0), a[:, 2]))
    zs = np.stack(zs)
    lat_lo = np.arcsin(np.clip(zs.min(axis=0), -1, 1))
    lat_hi = np.arcsin(np.clip(zs.max(axis=0), -1, 1))
    y_lo = (math.radians(n_) - lat_hi) / grid.dlat
    y_hi = (math.radians(n_) - lat_lo) / grid.dlat
    r0 = np.maximum(np.floor(y_lo).astype(np.int64) + 1, 0)
    r1 = np.minimum(np.floor(y_hi).astype(np.int64), grid.height)
    cnt = np.maximum(r1 - r0 + 1, 0)
    e_p = np.repeat(np.arange(len(a)), cnt)
    r = np.repeat(r0, cnt) + (np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    zk = np.sin(math.radians(n_) - r * grid.dlat)
    ac = np.arccos(np.clip(zk / np.maximum(amp[e_p], 1e-300), -1.0, 1.0))
    t_p = np.concatenate([t0[e_p] + ac, t0[e_p] - ac])
    e_p3 = np.concatenate([e_p, e_p])
    t_p = np.mod(t_p + math.pi, 2 * math.pi) - math.pi
    ok = (t_p > 0) & (t_p < theta[e_p3])
    edges = np.concatenate([e_m, e_p3[ok]])
    ts = np.concatenate([np.clip(t_m, 0, theta[e_m]), t_p[ok]])
    return edges, ts


def _arcs(shape):
    """The curve's arcs ``p(t) = cos t a + sin t u``, ``0 <= t <= theta`` (ring edges but
    antimeridian/pole seams, and lines), with their part (ring or line) and normal."""
    e = shape.edges()
    # parts: each ring and each line, in edge order; seams are no curve
    part = np.concatenate(
        [np.full(len(r), k) for k, r in enumerate(shape.rings)]
        + [np.full(max(len(ln) - 1, 1), len(shape.rings) + k) for k, ln in enumerate(shape.lines)]
    )
    keep = np.flatnonzero(e.boundary)
    a, b, part = e.a[keep], e.b[keep], part[keep]
    n = normalize(robust_cross(a, b))
    is_arc = np.linalg.norm(n, axis=1) > 0.5
    u = np.where(is_arc[:, None], np.cross(n, a), 0.0)
    theta = np.where(is_arc, angle(a, b), 0.0)
    return a, b, part, n, is_arc, u, theta


def _ordered_parts(cells: np.ndarray, cpart: np.ndarray) -> list[np.ndarray]:
    """Cells in curve order per part (``cells`` already in order), repeats dropped."""
    parts = []
    for k in np.unique(cpart):
        c = cells[cpart == k]
        if len(c):
            c = c[np.concatenate([[True], c[1:] != c[:-1]])]
            parts.append(c)
    return parts


def _rasterize(shape, grid) -> tuple[np.ndarray, list[np.ndarray]]:
    a, b, part, n, is_arc, u, theta = _arcs(shape)
    ce, ct = _crossings(grid, a[is_arc], b[is_arc], n[is_arc], u[is_arc], theta[is_arc])
    arc_ids = np.flatnonzero(is_arc)
    edges = np.concatenate([np.arange(len(a)), np.flatnonzero(is_arc), arc_ids[ce]])
    ts = np.concatenate([np.zeros(len(a)), theta[is_arc], ct])
    order = np.lexsort((ts, edges))
    edges, ts = edges[order], ts[order]
    # midpoints of consecutive parameters of one edge: each sub-arc lies in one cell
    same = edges[1:] == edges[:-1]
    me = edges[1:][same]
    mt = 0.5 * (ts[1:][same] + ts[:-1][same])
    edges = np.concatenate([edges, me])
    ts = np.concatenate([ts, mt])
    order = np.lexsort((ts, edges))
    edges, ts = edges[order], ts[order]
    p = np.cos(ts)[:, None] * a[edges] + np.sin(ts)[:, None] * u[edges]
    pid, cells = _point_cells(grid, p, _RASTER_EPS)
    mask = np.zeros(grid.height * grid.width, dtype=bool)
    mask[cells] = True
    # order along each part: cells in parameter order, consecutive repeats dropped
    return mask.reshape(grid.shape), _ordered_parts(cells, part[edges[pid]])


# the planes where two coordinates have the same magnitude: the face boundaries lie on them
_FACE_PLANES = np.array(
    [[1, -1, 0], [1, 1, 0], [1, 0, -1], [1, 0, 1], [0, 1, -1], [0, 1, 1]], dtype=np.float64
)


def _segment_params(p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(segment, lambda) where straight segments ``p0 -> p1`` (pixel coordinates, (n, 2))
    cross the integer lines ``x = k`` and ``y = k``."""
    seg, lam = [], []
    for ax in (0, 1):
        x0, x1 = p0[:, ax], p1[:, ax]
        k0 = np.floor(np.minimum(x0, x1)).astype(np.int64) + 1
        k1 = np.floor(np.maximum(x0, x1)).astype(np.int64)
        cnt = np.maximum(k1 - k0 + 1, 0)
        e = np.repeat(np.arange(len(x0)), cnt)
        k = np.repeat(k0, cnt) + (np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt))
        seg.append(e)
        lam.append(np.clip((k - x0[e]) / (x1[e] - x0[e]), 0.0, 1.0))
    return np.concatenate(seg), np.concatenate(lam)


def _rasterize_cube(shape, size: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """:func:`rasterize` on ``Cube(size)``: each arc is cut where it crosses the planes
    of the face boundaries; on one face a piece is a straight segment of the face plane
    (central projection), cut again at the pixel lines, so each sub-segment lies in
    one pixel. Flat indices are those of a (6, size, size) array."""
    a, _, part, _, _, u, theta = _arcs(shape)
    # split parameters: t in (0, theta) where p(t) . m = 0 for a face-boundary plane m
    am, um = a @ _FACE_PLANES.T, u @ _FACE_PLANES.T
    t1 = np.arctan2(-am, um).ravel()
    eid = np.repeat(np.arange(len(a)), len(_FACE_PLANES))
    cand_e = np.concatenate([eid, eid, eid])
    cand_t = np.concatenate([t1, t1 + math.pi, t1 - math.pi])
    ok = (cand_t > 0.0) & (cand_t < theta[cand_e])
    pe = np.concatenate([np.arange(len(a)), np.arange(len(a)), cand_e[ok]])
    pt = np.concatenate([np.zeros(len(a)), theta, cand_t[ok]])
    order = np.lexsort((pt, pe))
    pe, pt = pe[order], pt[order]
    # pieces between consecutive parameters of one edge (a zero-length edge: one piece)
    same = np.flatnonzero(pe[1:] == pe[:-1])
    e, ta, tb = pe[same], pt[same], pt[same + 1]

    def at(t):
        return np.cos(t)[:, None] * a[e] + np.sin(t)[:, None] * u[e]

    face, _, _ = locate(at(0.5 * (ta + tb)))
    p0 = np.stack(project(face, at(ta)), axis=1)
    p1 = np.stack(project(face, at(tb)), axis=1)
    p0, p1 = (p0 + 1.0) * (0.5 * size), (p1 + 1.0) * (0.5 * size)
    seg, lam = _segment_params(p0, p1)
    seg = np.concatenate([np.arange(len(e)), np.arange(len(e)), seg])
    lam = np.concatenate([np.zeros(len(e)), np.ones(len(e)), lam])
    order = np.lexsort((lam, seg))
    seg, lam = seg[order], lam[order]
    same = seg[1:] == seg[:-1]
    seg = np.concatenate([seg, seg[1:][same]])
    lam = np.concatenate([lam, 0.5 * (lam[1:][same] + lam[:-1][same])])
    order = np.lexsort((lam, seg))  # pieces are in curve order, so this is the curve order
    seg, lam = seg[order], lam[order]
    xy = p0[seg] + lam[:, None] * (p1[seg] - p0[seg])
    pid, cells = [], []
    for dx in (-_RASTER_EPS, _RASTER_EPS):
        for dy in (-_RASTER_EPS, _RASTER_EPS):
            ii = np.floor(xy[:, 0] + dx).astype(np.int64)
            jj = np.floor(xy[:, 1] + dy).astype(np.int64)
            ok = (ii >= 0) & (ii < size) & (jj >= 0) & (jj < size)
            pid.append(np.flatnonzero(ok))
            cells.append((face[seg[ok]] * size + jj[ok]) * size + ii[ok])
    pid, cells = np.concatenate(pid), np.concatenate(cells)
    order = np.lexsort((cells, pid))
    pid, cells = pid[order], cells[order]
    mask = np.zeros(6 * size * size, dtype=bool)
    mask[cells] = True
    return mask.reshape(6, size, size), _ordered_parts(cells, part[e[seg[pid]]])


def rasterize(shape, grid, *, ordered: bool = False):
    """The output cells of ``grid`` that the curves of ``shape`` pass through.

    Parameters
    ----------
    shape : Shape or anything :func:`gloffset.read` accepts
        Its boundary arcs (ring edges except antimeridian/pole seams, and lines) are
        rasterized; polygon interiors are not.
    grid : gloffset.grids.Equirect or gloffset.grids.Cube
    ordered : bool
        Also return the cells in curve order: a list with one int array per ring
        or line of flat indices ``row * width + column`` (cube: ``(face * N + row) * N
        + column``, the flat index of the (6, N, N) mask; consecutive repeats
        dropped; a cell may reappear where the curve comes back).

    Returns
    -------
    mask : (height, width) bool, row 0 north; for ``Cube(N)`` (6, N, N) [face, row,
        column], faces +X -X +Y -Y +Z -Z as :func:`gloffset.render` returns them
        True where a great-circle arc of the shape meets the pixel's lon/lat
        rectangle (cube: the pixel's square on its face). With ``ordered=True``,
        ``(mask, parts)``.

    Notes
    -----
    Exact up to 1e-7 pixel (conservative): the parameters where each arc crosses
    the pixel meridians (great circles) and parallels (small circles, solved in
    closed form) cut it into pieces that each lie in one pixel; the pixels of the
    pieces' midpoints, ends and crossing points are marked, each point marking
    every pixel within 1e-7 pixel (index units) of it. Points on a pole mark the
    whole pole row. No supersampling: a corner clipped by an arc is found.

    On a cube the arcs are cut at the face boundaries; on a face a piece is a
    straight segment of the face plane (the faces' pixel lines are great circles),
    cut at the pixel lines and marked the same way, so the same 1e-7 pixel holds.
    A point on a face edge marks the pixels of the face its piece lies on (the
    next piece marks the other face's).

    Examples
    --------
    >>> from gloffset.grids import Equirect
    >>> m = rasterize({"type": "LineString", "coordinates": [[0.5, 0.5], [3.5, 0.5]]},
    ...               Equirect(360, 180))
    >>> int(m.sum())
    4
    """
    if isinstance(grid, Cube):
        mask, parts = _rasterize_cube(read(shape), int(grid.size))
    elif isinstance(grid, Equirect):
        mask, parts = _rasterize(read(shape), grid)
    else:
        raise OptionError(
            f"grid must be a gloffset.grids.Equirect or Cube grid, got {type(grid).__name__}"
        )
    return (mask, parts) if ordered else mask


# ---------------------------------------------------------------------------- ordering
def _dfs_order(grid, level: int, mask: np.ndarray) -> list[np.ndarray]:
    """Intersected cells of ``level`` ordered by a depth-first walk of each 8-connected
    component (row-major start cells), one array of flat indices per component."""
    h, w = mask.shape
    flat = np.flatnonzero(mask.ravel())
    member = mask.ravel().copy()
    seen = np.zeros(h * w, dtype=bool)
    if hasattr(grid, "neighbour_table"):  # cube faces: neighbours across edges too
        table = dict(zip(flat.tolist(), grid.neighbour_table(level, flat).tolist()))

        def around(c):
            return [q for q in table[c] if q >= 0]
    else:
        wrap = _wraps(grid, level)
        offs = [(dj, di) for dj in (-1, 0, 1) for di in (-1, 0, 1) if dj or di]

        def around(c):
            j, i = divmod(c, w)
            out = []
            for dj, di in offs:
                jj, ii = j + dj, i + di
                if wrap:
                    ii %= w
                if 0 <= jj < h and 0 <= ii < w:
                    out.append(jj * w + ii)
            return out

    comps = []
    for start in flat.tolist():
        if seen[start]:
            continue
        seen[start] = True
        stack, comp = [start], []
        while stack:
            c = stack.pop()
            comp.append(c)
            for q in around(c):
                if member[q] and not seen[q]:
                    seen[q] = True
                    stack.append(q)
        comps.append(np.array(comp, dtype=np.int64))
    return comps


def _coarsen_order(grid, level: int, parts: list[np.ndarray]) -> list[np.ndarray]:
    """Output-level curve order mapped to the ancestors at ``level`` (first visits only)."""
    last = grid.n_levels - 1
    sh = last - level
    w_out = grid.width
    w = grid.level_shape(level)[1]
    seen: set = set()
    out = []
    for c in parts:
        j, i = np.divmod(c, w_out)
        a = (j >> sh) * w + (i >> sh)
        a = a[np.concatenate([[True], a[1:] != a[:-1]])]
        _, first = np.unique(a, return_index=True)
        keep = np.zeros(len(a), dtype=bool)
        keep[first] = True
        keep &= np.array([x not in seen for x in a.tolist()], dtype=bool)
        seen.update(a[keep].tolist())
        if keep.any():
            out.append(a[keep])
    return out


def _runs(grid, level: int, parts: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The sequence g_0..g_k and where a run of 8-adjacent cells starts."""
    if not parts:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool)
    seq = np.concatenate(parts)
    start = np.ones(len(seq), dtype=bool)
    if hasattr(grid, "adjacent"):
        start[1:] = ~grid.adjacent(level, seq[:-1], seq[1:])
    else:
        w = grid.level_shape(level)[1]
        j, i = np.divmod(seq, w)
        dj = np.abs(np.diff(j))
        di = np.abs(np.diff(i))
        if _wraps(grid, level):
            di = np.minimum(di, w - di)
        start[1:] = (dj > 1) | (di > 1)
    bounds = np.cumsum([len(p) for p in parts])[:-1]
    start[bounds] = True
    return seq, start


# ---------------------------------------------------------------------------- the problem
@dataclass
class CurveLevels:
    """A curve mask with what every level's classification needs (all float64): the
    levels of a rasterized curve (not to be confused with a grid's levels).

    ``masks[l]``: intersected cells of level ``l``; ``curve[l]``: their flat indices;
    ``s``: the output-cell area bound; ``R[l]``; ``t_lo[l]``, ``t_hi[l]``: per-row
    squared-chord thresholds (contained when ``chord^2 < t_lo``, outside when
    ``chord^2 >= t_hi``); ``reach[l]``: an angle beyond which no intersected cell
    matters for level ``l``.
    """

    grid: object
    d: float
    masks: list
    curve: list
    s: float
    R: list
    t_lo: list
    t_hi: list
    reach: list
    parts: list | None = None

    @classmethod
    def build(cls, mask: np.ndarray, d: float, grid, parts=None) -> CurveLevels:
        last = grid.n_levels - 1
        masks = [None] * (last + 1)
        masks[last] = mask
        for lev in range(last - 1, -1, -1):
            h, w = grid.level_shape(lev)
            m = masks[lev + 1]
            pad = np.zeros((2 * h, 2 * w), dtype=bool)
            pad[: m.shape[0], : m.shape[1]] = m
            masks[lev] = pad.reshape(h, 2, w, 2).any(axis=(1, 3))
        curve = [np.flatnonzero(m.ravel()) for m in masks]
        cells = hasattr(grid, "rho_cells")  # per-cell bounds (cube faces)
        if cells:
            s = float(grid.area_rho_cells(last, curve[last]).max())
        else:
            rows_out = np.unique(curve[last] // grid.width)
            s = float(pixel_radius(grid)[rows_out].max())
        R, t_lo, t_hi, reach = [], [], [], []
        for lev in range(last + 1):
            w = grid.level_shape(lev)[1]
            rho = np.asarray(grid.rho(lev), dtype=np.float64)
            if lev == last:
                r_l = 0.0
            elif cells:
                r_l = float(grid.rho_cells(lev, curve[lev]).max())
            else:
                r_l = float(rho[np.unique(curve[lev] // w)].max())
            rq = rho if lev < last else np.zeros_like(rho)
            lo = d - s - rq - r_l
            hi = d + 2.0 * s + rq + r_l
            R.append(r_l)
            lo2 = np.where(lo > 0.0, chord2_of_angle(np.maximum(lo, 0.0)), -1.0)
            hi2 = np.where(hi < math.pi, chord2_of_angle(hi), 5.0)
            if hasattr(grid, "row_valid"):  # padding rows hold no cell: always outside
                ok = grid.row_valid(lev)
                lo2, hi2 = np.where(ok, lo2, -1.0), np.where(ok, hi2, -1.0)
            t_lo.append(lo2)
            t_hi.append(hi2)
            reach.append(float(min(hi.max(), math.pi)) + _REACH_SLACK)
        return cls(grid, d, masks, curve, s, R, t_lo, t_hi, reach, parts)

    def sequence(self, level: int) -> tuple[np.ndarray, np.ndarray]:
        """The ordered intersected cells of ``level`` and run starts."""
        if self.parts is not None:
            parts = _coarsen_order(self.grid, level, self.parts)
            # cells of the mask that the given order misses are appended by walking
            got = np.zeros(self.masks[level].size, dtype=bool)
            for p in parts:
                got[p] = True
            rest = self.masks[level].ravel() & ~got
            if rest.any():
                parts = parts + _dfs_order(self.grid, level, rest.reshape(self.masks[level].shape))
        else:
            parts = _dfs_order(self.grid, level, self.masks[level])
        return _runs(self.grid, level, parts)

    def classes_of(self, level: int, flat: np.ndarray, best: np.ndarray) -> np.ndarray:
        """Classes of cells ``flat`` of ``level`` whose smallest squared chord is ``best``."""
        row = np.asarray(flat) // self.grid.level_shape(level)[1]
        out = np.full(len(flat), FRONTIER, dtype=np.uint8)
        out[best < self.t_lo[level][row]] = CONTAINED
        out[best >= self.t_hi[level][row]] = OUTSIDE
        return out


# ---------------------------------------------------------------------------- near pairs
def near_pairs(
    grid, level_q: int, q: np.ndarray, extra_q, level_p: int, p: np.ndarray, reach: float
):
    """Pairs ``(iq, ip)`` (indices into ``q`` and ``p``) whose centres are within
    ``reach + extra_q[iq]`` of each other: a superset, found with buckets of a
    coarser level (children's centres lie within ``rho`` of the bucket centre).

    Yields chunks ``(iq, ip, c2)`` with the squared chord of each pair.
    """
    q = np.asarray(q, dtype=np.int64)
    p = np.asarray(p, dtype=np.int64)
    extra_q = np.broadcast_to(np.asarray(extra_q, dtype=np.float64), q.shape)
    if len(q) == 0 or len(p) == 0:
        return
    m = _bucket_level(grid, level_q, q, level_p, p, reach)

    def buckets(level, cells):
        w = grid.level_shape(level)[1]
        sh = level - m
        j, i = np.divmod(cells, w)
        key = (j >> sh) * grid.level_shape(m)[1] + (i >> sh)
        order = np.argsort(key, kind="stable")
        ukey, start, count = np.unique(key[order], return_index=True, return_counts=True)
        return order, ukey, start, count

    qo, qk, qs, qc = buckets(level_q, q)
    po, pk, ps, pc = buckets(level_p, p)
    wm = grid.level_shape(m)[1]
    rho_m = np.asarray(grid.rho(m))
    cq = level_centers(grid, m, qk)
    cp = level_centers(grid, m, pk)
    eq = np.maximum.reduceat(extra_q[qo], qs) + rho_m[qk // wm]
    ep = rho_m[pk // wm]
    cq_all = level_centers(grid, level_q, q)
    cp_all = level_centers(grid, level_p, p)
    step = max(1, _PAIRS // max(len(pk), 1))
    for s0 in range(0, len(qk), step):
        sl = slice(s0, s0 + step)
        bq, bp = np.nonzero(
            cap_within(cq[sl] @ cp.T, reach + eq[sl, None] + ep[None, :] + _REACH_SLACK)
        )
        bq += s0
        cnt = qc[bq] * pc[bp]
        # cartesian products of the bucket pairs, in chunks of about _PAIRS pairs
        cum = np.cumsum(cnt)
        lo = 0
        while lo < len(bq):
            hi = int(np.searchsorted(cum, (cum[lo - 1] if lo else 0) + _PAIRS, side="right"))
            hi = max(hi, lo + 1)
            b_q, b_p, c = bq[lo:hi], bp[lo:hi], cnt[lo:hi]
            tot = int(c.sum())
            k = np.arange(tot) - np.repeat(np.cumsum(c) - c, c)
            npc = np.repeat(pc[b_p], c)
            iq = qo[np.repeat(qs[b_q], c) + k // npc]
            ip = po[np.repeat(ps[b_p], c) + k % npc]
            c2 = chord2(cq_all[iq], cp_all[ip])
            keep = c2 <= pad(chord2_of_angle(reach + extra_q[iq] + _REACH_SLACK), abs_=0.0)
            yield iq[keep], ip[keep], c2[keep]
            lo = hi


def _bucket_level(grid, level_q, q, level_p, p, reach) -> int:
    """The bucket level with the least estimated work: bucket pairs tested plus cell
    pairs expanded (buckets of side ~rho near a disc of radius reach)."""
    best, m_best = math.inf, 0
    for m in range(min(level_q, level_p) + 1):
        wm = grid.level_shape(m)[1]
        nb = []
        for lev, cells in ((level_q, q), (level_p, p)):
            sh = lev - m
            j, i = np.divmod(cells, grid.level_shape(lev)[1])
            nb.append(len(np.unique((j >> sh) * wm + (i >> sh))))
        r = max(float(np.max(grid.rho(m))), 1e-12)
        near = min(float(nb[1]), min((reach + 2.0 * r) / r, 1e6) ** 2)
        cost = nb[0] * nb[1] + len(q) * len(p) / nb[1] * near
        if cost < best:
            best, m_best = cost, m
    return m_best


def classify_cells(lv: CurveLevels, level: int, flat: np.ndarray) -> np.ndarray:
    """Direct classification of cells ``flat`` of ``level`` against every intersected
    cell within reach (the fallback, and the hierarchical levels)."""
    flat = np.asarray(flat, dtype=np.int64)
    best = np.full(len(flat), np.inf)
    for iq, _, c2 in near_pairs(lv.grid, level, flat, 0.0, level, lv.curve[level], lv.reach[level]):
        np.minimum.at(best, iq, c2)
    return lv.classes_of(level, flat, best)


# ---------------------------------------------------------------------------- Sec. 5.1
def region_grow(lv: CurveLevels, level: int) -> tuple[np.ndarray, str, str | None]:
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


def _grow(lv: CurveLevels, level: int, seq: np.ndarray, start: np.ndarray):
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
            c2 = chord2(level_centers(grid, level, active), gk)
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
            c2 = chord2(level_centers(grid, level, nb), gk)
            ok = c2 < t_hi[nb // w]
            wave = nb[ok]
            stamp[wave] = k
            update(wave, c2[ok])
            new.append(wave)
        cand = np.concatenate(new) if through else np.concatenate([active] + new[1:])
        active = np.unique(cand[state[cand] == _ACTIVE])
    return state, regrown


def _fallback(lv: CurveLevels, level: int) -> np.ndarray:
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
def hierarchical(lv: CurveLevels, *, stop_level: int | None = None, callback=None, timings=None):
    """Sec. 5.2: level 0 by region growing (Sec. 5.1), then each level evaluates only
    the children of the previous level's frontier cells (active and inactive).

    Returns ``(classes of stop_level, method, reason)``.
    """
    grid = lv.grid
    stop = grid.n_levels - 1 if stop_level is None else stop_level
    classes, method, reason = region_grow(lv, 0)
    if callback is not None:
        callback(0, classes)
    if timings is not None:
        timings.append((0, time.perf_counter()))
    for lev in range(1, stop + 1):
        classes = refine(lv, lev, classes)
        if callback is not None:
            callback(lev, classes)
        if timings is not None:
            timings.append((lev, time.perf_counter()))
    return classes, method, reason


def children_of_frontier(grid, level: int, parent: np.ndarray) -> np.ndarray:
    """Flat indices of the cells of ``level`` whose parent is frontier."""
    h, w = grid.level_shape(level)
    pj, pi = np.nonzero(parent == FRONTIER)
    kids = []
    for dj in (0, 1):
        for di in (0, 1):
            j, i = 2 * pj + dj, 2 * pi + di
            ok = (j < h) & (i < w)
            kids.append(j[ok] * w + i[ok])
    return np.sort(np.concatenate(kids))


def upsample(grid, level: int, parent: np.ndarray) -> np.ndarray:
    h, w = grid.level_shape(level)
    return np.repeat(np.repeat(parent, 2, axis=0), 2, axis=1)[:h, :w].copy()


def refine(lv: CurveLevels, level: int, parent: np.ndarray) -> np.ndarray:
    """Classes of ``level`` from the classes of ``level - 1``: descendants of contained
    and outside cells inherit, children of frontier cells are classified."""
    out = upsample(lv.grid, level, parent)
    kids = children_of_frontier(lv.grid, level, parent)
    out.ravel()[kids] = classify_cells(lv, level, kids)
    return out


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


@lru_cache(maxsize=8)
def cube_cells(size: int) -> CubeCells:
    """The cell grid of ``Cube(size)`` that the CPU reference and the GPU levels work on."""
    return CubeCells(size)


def _check_mask(mask, grid) -> np.ndarray:
    if not isinstance(grid, (Equirect, Cube)):
        raise OptionError(
            f"grid must be a gloffset.grids.Equirect or Cube grid, got {type(grid).__name__}"
        )
    m = np.asarray(mask)
    if m.dtype != bool and not np.issubdtype(m.dtype, np.integer):
        raise InvalidMaskError(f"mask must be a boolean (or integer) array, got dtype {m.dtype}")
    if m.shape != grid.shape:
        want = "(face, row, column)" if isinstance(grid, Cube) else "(height, width)"
        raise InvalidMaskError(f"mask has shape {m.shape}, the grid needs {want} = {grid.shape}")
    m = m != 0
    if not m.any():
        raise InvalidMaskError("mask is empty: no curve cell to offset")
    return m


def raster_offset(
    mask,
    distance: float,
    grid,
    *,
    radius: float = EARTH_RADIUS,
    backend: str = "gpu",
    mode: str = "hierarchical",
    level: int | None = None,
    order=None,
    return_info: bool = False,
    callback=None,
):
    """Offset a rasterized curve without its vector data (paper Sec. 5).

    Parameters
    ----------
    mask : (height, width) bool array, or (6, N, N) for ``Cube(N)``
        The output cells of ``grid`` that the curve passes through (row 0 north;
        cube: [face, row, column], faces +X -X +Y -Y +Z -Z as :func:`gloffset.render`
        returns them); integer arrays count non-zero as True.
    distance : float
        Offset distance in the units of ``radius`` (metres by default), > 0.
    grid : gloffset.grids.Equirect or gloffset.grids.Cube
        On a cube the six faces are one set of cells: the curve, the region growing
        and the offset run across face edges and corners.
    backend : {"gpu", "cpu"}
        ``"gpu"``: the coarse levels on the CPU, the levels below the bins in
        fragment shaders (:mod:`gloffset.raster.curve_gpu`); ``"cpu"``: float64
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
    t0 = time.perf_counter()
    m = _check_mask(mask, grid)
    cube = cube_cells(int(grid.size)) if isinstance(grid, Cube) else None
    if cube is not None:  # the six faces as one grid of cells (stacked rows)
        grid, m = cube, cube.stack(m)
        if order is not None:
            order = [cube.from_faces_flat(p) for p in order]
    d = to_angle(distance, radius)
    if not 0.0 < d < 1.5:
        raise InvalidDistanceError(
            f"distance {distance!r} is {d:.4g} rad; raster offsets need 0 < d < 1.5 rad"
        )
    if backend not in _BACKENDS:
        raise OptionError(f"backend must be one of {', '.join(_BACKENDS)}, got {backend!r}")
    if mode not in _MODES:
        raise OptionError(f"mode must be one of {', '.join(_MODES)}, got {mode!r}")
    last = grid.n_levels - 1
    if level is not None and not (isinstance(level, (int, np.integer)) and 0 <= level <= last):
        raise OptionError(f"level must be in 0..{last}, got {level!r}")
    stop = last if level is None else int(level)
    lv = CurveLevels.build(m, d, grid, parts=order)
    frontier: list = []

    def cb(lev, cls):
        frontier.append(int(np.count_nonzero(cls == FRONTIER)))
        if callback is not None:
            callback(lev, cls if cube is None else cube.unstack(lev, cls))

    n_amb = 0
    if backend == "cpu" and mode == "single":
        classes, method, reason = region_grow(lv, stop)
        cb(stop, classes)
    elif backend == "cpu" or stop <= grid.bin_level:
        classes, method, reason = hierarchical(lv, stop_level=stop, callback=cb)
    else:
        from .curve_gpu import gpu_levels

        classes, method, reason = hierarchical(lv, stop_level=grid.bin_level, callback=cb)
        classes, n_amb = gpu_levels(lv, classes, stop_level=stop, callback=cb)
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
        n_ambiguous=n_amb,
        frontier=frontier,
        seconds=time.perf_counter() - t0,
    )
    return (classes, info) if return_info else classes
