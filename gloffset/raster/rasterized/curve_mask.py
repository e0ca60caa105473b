"""Curve masks from shapes.

The output cells of a grid that the curves of a shape pass through (:func:`rasterize`),
exact up to 1e-7 pixel, in curve order on request (what :func:`gloffset.raster_offset`
takes as ``mask`` and ``order``).
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import OptionError
from ...geometry.sphere import angle, normalize, robust_cross
from ...grids.cube import locate, project
from ...grids.protocol import Image, RegularLonLat
from ...shape import read

__all__ = ["rasterize"]

_RASTER_EPS = 1e-7  # pixels: rasterize marks cells this close to the arc


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
    wrap = grid.wraps(grid.n_levels - 1)
    pid_parts, cell_parts = [], []
    for dx in (-eps, eps):
        for dy in (-eps, eps):
            ii = np.floor(x + dx).astype(np.int64)
            jj = np.floor(y + dy).astype(np.int64)
            if wrap:
                ii = ii % grid.width
            ok = (ii >= 0) & (ii < grid.width) & (jj >= 0) & (jj < grid.height)
            pid_parts.append(np.flatnonzero(ok))
            cell_parts.append(jj[ok] * grid.width + ii[ok])
    # a point on a pole touches every cell of the pole row
    pole = np.flatnonzero(np.hypot(p[:, 0], p[:, 1]) < 1e-12)
    for k in pole:
        row = 0 if p[k, 2] > 0 else grid.height - 1
        if (row == 0 and n_ >= 90.0 - 1e-12) or (row == grid.height - 1 and s_ <= -90.0 + 1e-12):
            pid_parts.append(np.full(grid.width, k))
            cell_parts.append(row * grid.width + np.arange(grid.width))
    pid = np.concatenate(pid_parts)
    cells = np.concatenate(cell_parts)
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
    z_at = [a[:, 2], b[:, 2]]
    for tc in (t0, t0 + math.pi, t0 - math.pi):
        inside = (tc > 0) & (tc < theta)
        z_at.append(np.where(inside, amp * np.cos(tc - t0), a[:, 2]))
    zs = np.stack(z_at)
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
    """Return the curve's arcs ``p(t) = cos t a + sin t u``, ``0 <= t <= theta``.

    Ring edges but antimeridian/pole seams, and lines, with their part (ring or line) and
    normal.
    """
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
    """Where straight segments cross the integer lines ``x = k`` and ``y = k``.

    ``(segment, lambda)`` where straight segments ``p0 -> p1`` (pixel coordinates,
    (n, 2)) cross them.
    """
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
    """:func:`rasterize` on ``Cube(size)``.

    Each arc is cut where it crosses the planes of the face boundaries; on one face a
    piece is a straight segment of the face plane (central projection), cut again at the
    pixel lines, so each sub-segment lies in one pixel. Flat indices are those of a (6,
    size, size) array.
    """
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
    pid_parts, cell_parts = [], []
    for dx in (-_RASTER_EPS, _RASTER_EPS):
        for dy in (-_RASTER_EPS, _RASTER_EPS):
            ii = np.floor(xy[:, 0] + dx).astype(np.int64)
            jj = np.floor(xy[:, 1] + dy).astype(np.int64)
            ok = (ii >= 0) & (ii < size) & (jj >= 0) & (jj < size)
            pid_parts.append(np.flatnonzero(ok))
            cell_parts.append((face[seg[ok]] * size + jj[ok]) * size + ii[ok])
    pid, cells = np.concatenate(pid_parts), np.concatenate(cell_parts)
    order = np.lexsort((cells, pid))
    pid, cells = pid[order], cells[order]
    mask = np.zeros(6 * size * size, dtype=bool)
    mask[cells] = True
    return mask.reshape(6, size, size), _ordered_parts(cells, part[e[seg[pid]]])


def rasterize(shape, grid, *, ordered: bool = False):
    """Return the output cells of ``grid`` that the curves of ``shape`` pass through.

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
    if isinstance(grid, Image) and grid.curve_masks and grid.n_faces > 1:
        mask, parts = _rasterize_cube(read(shape), int(grid.faces[0].width))
    elif isinstance(grid, RegularLonLat) and grid.curve_masks:
        mask, parts = _rasterize(read(shape), grid)
    else:
        raise OptionError(
            f"grid must be a gloffset.grids.Equirect or Cube grid, got {type(grid).__name__}"
        )
    return (mask, parts) if ordered else mask
