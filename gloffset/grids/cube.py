"""Cube-map grids in the OpenGL convention.

Faces in the order +X -X +Y -Y +Z -Z (files ``px nx py ny pz nz``). A direction
``r`` (the Earth-frame unit vector: x to 0N 0E, y to 0N 90E, z to the north pole)
falls on the face of its largest coordinate, at (GL spec, "Cube Map Texture
Selection")

    face  sc    tc    ma        face  sc    tc    ma
    +X   -rz   -ry    rx        -X   +rz   -ry    rx
    +Y   +rx   +rz    ry        -Y   +rx   -rz    ry
    +Z   +rx   -ry    rz        -Z   -rx   -ry    rz

    s = (sc / |ma| + 1) / 2,   t = (tc / |ma| + 1) / 2,

and pixel row ``j`` of an ``N x N`` face is at ``t = (j + 0.5) / N``, column ``i`` at
``s = (i + 0.5) / N``, so uploading the rows in order gives the GL texture. A point
of a face is ``normalize(e + sc u + tc v)`` with the axes of :data:`FACES`.

Cells are not congruent on a face: each cell of each level has its own bound
``rho`` = max(angle to the cell's corners (its edges are great-circle arcs, so the
farthest point is a corner), angle to each child centre + the child's rho).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..geometry.caps import pad
from ..geometry.sphere import angle, normalize
from ..memo import Memo
from .base import InvalidGridError, LevelHierarchy, Square, check_size

__all__ = [
    "Cube",
    "CubeCells",
    "CubeFace",
    "FACES",
    "FACE_NAMES",
    "cell_at",
    "face_points",
    "locate",
    "project",
]

FACE_NAMES = ("px", "nx", "py", "ny", "pz", "nz")
#: (e, u, v) per face: a point is normalize(e + sc u + tc v).
FACES = np.array(
    [
        [[1, 0, 0], [0, 0, -1], [0, -1, 0]],
        [[-1, 0, 0], [0, 0, 1], [0, -1, 0]],
        [[0, 1, 0], [1, 0, 0], [0, 0, 1]],
        [[0, -1, 0], [1, 0, 0], [0, 0, -1]],
        [[0, 0, 1], [1, 0, 0], [0, -1, 0]],
        [[0, 0, -1], [-1, 0, 0], [0, -1, 0]],
    ],
    dtype=np.float64,
)


_RHO_CACHE: Memo[list[np.ndarray]] = Memo()


def locate(r) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Face index, s and t of directions ``r`` (..., 3), by the GL selection rule."""
    r = np.asarray(r, dtype=np.float64)
    ax = np.argmax(np.abs(r), axis=-1)
    sign = np.take_along_axis(r, ax[..., None], axis=-1)[..., 0] < 0
    face = 2 * ax + sign
    e, u, v = FACES[face, 0], FACES[face, 1], FACES[face, 2]
    ma = np.abs(np.sum(r * e, axis=-1))
    sc = np.sum(r * u, axis=-1) / ma
    tc = np.sum(r * v, axis=-1) / ma
    return face, (sc + 1.0) / 2.0, (tc + 1.0) / 2.0


def face_points(face, x, y, size: int) -> np.ndarray:
    """Unit vectors at output-pixel coordinates ``(x, y)`` (fractional; 0 = the face's
    edge, ``size`` the opposite edge; values past the edges continue the face's plane)
    of faces ``face`` (0..5); the arguments broadcast."""
    face = np.asarray(face)
    sc = 2.0 * np.asarray(x, dtype=np.float64) / size - 1.0
    tc = 2.0 * np.asarray(y, dtype=np.float64) / size - 1.0
    face, sc, tc = np.broadcast_arrays(face, sc, tc)
    e, u, v = FACES[face, 0], FACES[face, 1], FACES[face, 2]
    return normalize(e + sc[..., None] * u + tc[..., None] * v)


def project(face, r) -> tuple[np.ndarray, np.ndarray]:
    """Face coordinates ``(sc, tc)`` in the plane of ``face`` of directions ``r`` (central
    (gnomonic) projection, so great circles are straight lines); needs ``r . e > 0``."""
    r = np.asarray(r, dtype=np.float64)
    face = np.asarray(face)
    e, u, v = FACES[face, 0], FACES[face, 1], FACES[face, 2]
    ma = np.sum(r * e, axis=-1)
    return np.sum(r * u, axis=-1) / ma, np.sum(r * v, axis=-1) / ma


def cell_at(size: int, level: int, r) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Face, row and column of the cells of ``level`` of a ``Cube(size)`` holding the
    directions ``r`` (..., 3) (:func:`locate`, then the pixel, then its ancestor)."""
    face, s, t = locate(r)
    sh = CubeFace(0, size).n_levels - 1 - level
    i = np.clip(np.floor(s * size), 0, size - 1).astype(np.int64) >> sh
    j = np.clip(np.floor(t * size), 0, size - 1).astype(np.int64) >> sh
    return face, j, i


@dataclass(frozen=True)
class CubeFace(Square, LevelHierarchy):
    """One ``size x size`` face of a cube map (``face`` 0..5 in the order of FACE_NAMES)."""

    face: int
    size: int
    centres = "cube"

    def __post_init__(self):
        if self.face not in range(6):
            raise InvalidGridError(f"cube face must be 0..5, got {self.face!r}")
        check_size(self.size, self.size)

    @property
    def name(self) -> str:
        return FACE_NAMES[self.face]

    @property
    def basis(self) -> np.ndarray:
        return FACES[self.face]

    def _point(self, x, y) -> np.ndarray:
        """Unit vectors at output-pixel coordinates (x, y) (fractional; 0 = the face's edge)."""
        return face_points(self.face, x, y, self.size)

    def centers(self, level: int, j, i) -> np.ndarray:
        b = self.block(level)
        return self._point((np.asarray(i) + 0.5) * b, (np.asarray(j) + 0.5) * b)

    def _rhos(self) -> list[np.ndarray]:
        n = self.n_levels
        out: list = [None] * n
        out[n - 1] = np.zeros(self.level_shape(n - 1))
        for lev in range(n - 2, -1, -1):
            h, w = self.level_shape(lev)
            jj, ii = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
            c = self.centers(lev, jj, ii)
            r = self._corner_angle(lev, jj, ii, c)
            child = out[lev + 1]
            ch, cw = child.shape
            for dj in (0, 1):
                for di in (0, 1):
                    cj = np.minimum(2 * jj + dj, ch - 1)
                    ci = np.minimum(2 * ii + di, cw - 1)
                    cc = self.centers(lev + 1, cj, ci)
                    r = np.maximum(r, angle(c, cc) + child[cj, ci])
            out[lev] = pad(r)
        return out

    def _cache(self) -> list[np.ndarray]:
        # the six faces are congruent (rotations and mirror images of one another in
        # (s, t)), so their bounds are the same arrays: computed once per size
        size = int(self.size)
        return _RHO_CACHE.once(size, lambda: CubeFace(0, size)._rhos(), keep=4)

    def rho(self, level: int) -> np.ndarray:
        """Per-row maximum of the cells' bounds (what the GPU margins use)."""
        return self._cache()[level].max(axis=1)

    def rho_at(self, level: int, j, i) -> np.ndarray:
        return self._cache()[level][np.asarray(j), np.asarray(i)]

    def area_rho_at(self, level: int, j, i) -> np.ndarray:
        """Rigorous per-cell area bound: the largest angle from the centres of cells
        (``j``, ``i``) of ``level`` to their corners (cell edges are great-circle arcs,
        so the farthest point of a cell is a corner), rounded up like ``rho``. At the
        output level it is the pixel's own bound (where ``rho`` is 0)."""
        j, i = np.broadcast_arrays(np.asarray(j), np.asarray(i))
        return pad(self._corner_angle(level, j, i, self.centers(level, j, i)))

    def _corner_angle(self, level: int, j, i, c) -> np.ndarray:
        """Largest angle from the centres ``c`` of cells (``j``, ``i``) to their corners."""
        b = self.block(level)
        r = np.zeros(np.shape(j))
        for dx in (0, 1):
            for dy in (0, 1):
                r = np.maximum(r, angle(c, self._point((i + dx) * b, (j + dy) * b)))
        return r


@dataclass(frozen=True)
class Cube:
    """Six ``size x size`` faces covering the sphere (see the module notes)."""

    size: int
    n_faces = 6
    curve_masks = True

    def __post_init__(self):
        check_size(self.size, self.size)

    @property
    def faces(self) -> list[CubeFace]:
        return [CubeFace(k, int(self.size)) for k in range(6)]

    def cell_set(self) -> CubeCells:
        """The six faces as one set of cells (:class:`CubeCells`, made once per size)."""
        return _cube_cells(int(self.size))

    @property
    def shape(self) -> tuple[int, int, int]:
        return (6, int(self.size), int(self.size))


@lru_cache(maxsize=8)
def _cube_cells(size: int) -> CubeCells:
    """The cell grid of ``Cube(size)`` that the CPU reference and the GPU levels work on."""
    return CubeCells(size)


_EDGE_EPS = 1e-3  # output pixels: how far past a cell's side the neighbour samples lie


class CubeCells:
    """The six faces of ``Cube(size)`` as one grid of cells, for algorithms on cell sets
    (the offsets of rasterized curves, :mod:`gloffset.raster.rasterized`).

    Level ``l`` is a ``(6 P_l) x n_l`` array: face ``f``'s cells (row ``j``, column
    ``i``; :class:`CubeFace` levels, ``n_l`` cells a side) are at row ``f P_l + j``,
    flat index ``(f P_l + j) n_l + i``. ``P_l = n_0 2^l`` is ``n_l`` rounded up so that
    the parent of row ``r`` is row ``r >> 1`` on every face; the rows ``n_l .. P_l - 1``
    of a face (only when ``2^L`` does not divide ``size``) are padding and hold no cell
    (:meth:`row_valid`). When ``P_L = size`` the output level's flat index is that of a
    ``(6, size, size)`` array. Neighbours across face edges come from the geometry.

    Bounds: ``rho(l)`` per row (the largest :meth:`CubeFace.rho_at` of the face row;
    padding rows get the face's largest), :meth:`rho_cells` and :meth:`area_rho_cells`
    per cell. The six faces are congruent, so every row's bound is that of face 0.
    """

    lonlat = False

    def __init__(self, size: int):
        self.face = CubeFace(0, size)
        self.size = self.face.size
        L = self.face.n_levels - 1
        self.n = [self.face.level_shape(lev)[0] for lev in range(L + 1)]
        self.P = [self.n[0] << lev for lev in range(L + 1)]
        self._rho: Memo[np.ndarray] = Memo()
        self._edges: Memo[tuple[np.ndarray, np.ndarray]] = Memo()

    # ------------------------------------------------------------- hierarchy
    @property
    def n_levels(self) -> int:
        return self.face.n_levels

    @property
    def bin_level(self) -> int:
        return self.face.bin_level

    def block(self, level: int) -> int:
        return self.face.block(level)

    def level_shape(self, level: int) -> tuple[int, int]:
        return (6 * self.P[level], self.n[level])

    @property
    def width(self) -> int:
        return self.size

    @property
    def height(self) -> int:
        return 6 * self.P[-1]

    @property
    def shape(self) -> tuple[int, int]:
        return (self.height, self.width)

    def row_valid(self, level: int) -> np.ndarray:
        """Per row of ``level``: whether it holds cells (False for padding rows)."""
        return np.tile(np.arange(self.P[level]) < self.n[level], 6)

    # ------------------------------------------------------------- layout
    def split(self, level: int, flat) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Face, row and column of flat indices of ``level``."""
        r, i = np.divmod(np.asarray(flat, dtype=np.int64), self.n[level])
        f, j = np.divmod(r, self.P[level])
        return f, j, i

    def flat(self, level: int, f, j, i) -> np.ndarray:
        return (np.asarray(f, dtype=np.int64) * self.P[level] + j) * self.n[level] + i

    def stack(self, faces: np.ndarray) -> np.ndarray:
        """A ``(6, size, size)`` array as the output level's ``(6 P_L, size)`` array."""
        pad = np.zeros((6, self.P[-1], self.size), dtype=faces.dtype)
        pad[:, : self.size] = faces
        return pad.reshape(6 * self.P[-1], self.size)

    def unstack(self, level: int, cells: np.ndarray) -> np.ndarray:
        """A level's ``(6 P_l, n_l)`` array as ``(6, n_l, n_l)`` (padding dropped)."""
        return cells.reshape(6, self.P[level], self.n[level])[:, : self.n[level]].copy()

    def from_faces_flat(self, flat) -> np.ndarray:
        """Flat indices of a ``(6, size, size)`` array as flat indices of the output level."""
        f, r = np.divmod(np.asarray(flat, dtype=np.int64), self.size * self.size)
        j, i = np.divmod(r, self.size)
        return self.flat(self.n_levels - 1, f, j, i)

    # ------------------------------------------------------------- geometry
    def face_axes(self, face: int) -> tuple[tuple, tuple, tuple]:
        """(e, u, v) of ``face`` as tuples of floats (:data:`FACES`)."""
        e, u, v = (tuple(float(x) for x in a) for a in FACES[face])
        return e, u, v

    def centers(self, level: int, j, i) -> np.ndarray:
        """Unit vectors of the centres of cells (stacked row ``j``, column ``i``)."""
        f, jj = np.divmod(np.asarray(j, dtype=np.int64), self.P[level])
        b = self.block(level)
        return face_points(f, (np.asarray(i) + 0.5) * b, (jj + 0.5) * b, self.size)

    def rho(self, level: int) -> np.ndarray:
        """Per-row bound (radians) of ``level`` (see the class notes)."""

        def build() -> np.ndarray:
            face = self.face.rho(level)
            pad = np.full(self.P[level], float(face.max()))
            pad[: self.n[level]] = face
            return np.tile(pad, 6)

        return self._rho.once(level, build)

    def rho_at(self, level: int, j, i) -> np.ndarray:
        """The bound of cells (stacked row ``j``, column ``i``) of ``level`` (padding rows:
        the face's largest)."""
        j, i = np.broadcast_arrays(np.asarray(j, dtype=np.int64), np.asarray(i, dtype=np.int64))
        jj = j % self.P[level]
        ok = jj < self.n[level]
        out = np.full(j.shape, float(self.face.rho(level).max()))
        out[ok] = self.face.rho_at(level, jj[ok], i[ok])
        return out

    def decision_rho(self, level: int, j, i) -> np.ndarray:
        """The bound a cell is decided with: :meth:`rho_at`."""
        return self.rho_at(level, j, i)

    def rho_cells(self, level: int, flat) -> np.ndarray:
        """Per-cell bound ``rho`` of cells ``flat`` of ``level`` (0 at the output level)."""
        _, j, i = self.split(level, flat)
        return self.face.rho_at(level, j, i)

    def area_rho_cells(self, level: int, flat) -> np.ndarray:
        """Per-cell area bound (farthest corner) of cells ``flat`` of ``level``."""
        _, j, i = self.split(level, flat)
        return self.face.area_rho_at(level, j, i)

    # ------------------------------------------------------------- neighbours
    def edge_neighbours(self, level: int) -> tuple[np.ndarray, np.ndarray]:
        """Cells of ``level`` on a face's border (sorted flat indices) and, per cell, the
        cells of other faces that touch it (8 samples each, repeats possible).

        The samples are the cell's corners and side midpoints moved just past its sides
        (``1e-3`` pixel past a face edge, twice that along it, so that the sample stays
        clear of the cell lines of the next face), located with :func:`cell_at`.
        """
        return self._edges.once(level, lambda: self._border_cells(level))

    def _border_cells(self, level: int) -> tuple[np.ndarray, np.ndarray]:
        n, b, N = self.n[level], self.block(level), self.size
        k = np.arange(n)
        jb = np.concatenate([np.zeros(n, np.int64), np.full(n, n - 1), k, k])
        ib = np.concatenate([k, k, np.zeros(n, np.int64), np.full(n, n - 1)])
        ji = np.unique(jb * n + ib)
        jb, ib = np.divmod(ji, n)
        f = np.repeat(np.arange(6), len(ji))
        jb, ib = np.tile(jb, 6), np.tile(ib, 6)

        def sides(c):
            lo, hi = c * b, np.minimum((c + 1) * b, N)
            d_lo = np.where(lo == 0, _EDGE_EPS, 2 * _EDGE_EPS)
            d_hi = np.where(hi == N, _EDGE_EPS, 2 * _EDGE_EPS)
            return [lo - d_lo, 0.5 * (lo + hi), hi + d_hi]

        xs, ys = sides(ib), sides(jb)
        nb = []
        for a in range(3):
            for c in range(3):
                if a == 1 and c == 1:
                    continue
                p = face_points(f, xs[a], ys[c], N)
                nf, nj, ni = cell_at(N, level, p)
                cells = self.flat(level, nf, nj, ni)
                # a sample on the cell's own face is an in-face neighbour: not listed
                nb.append(np.where(nf == f, -1, cells))
        keys = self.flat(level, f, jb, ib)
        table = np.stack(nb, axis=1)
        order = np.argsort(keys)
        return keys[order], table[order]

    def neighbour_table(self, level: int, flat) -> np.ndarray:
        """(len(flat), 16) flat indices of the cells that touch cells ``flat`` of
        ``level``: the 8 of the same face, then those across face edges; -1 where none."""
        flat = np.asarray(flat, dtype=np.int64)
        f, j, i = self.split(level, flat)
        n = self.n[level]
        out = np.full((len(flat), 16), -1, dtype=np.int64)
        k = 0
        for dj in (-1, 0, 1):
            for di in (-1, 0, 1):
                if dj or di:
                    jj, ii = j + dj, i + di
                    ok = (jj >= 0) & (jj < n) & (ii >= 0) & (ii < n)
                    out[ok, k] = self.flat(level, f[ok], jj[ok], ii[ok])
                    k += 1
        keys, table = self.edge_neighbours(level)
        at = np.minimum(np.searchsorted(keys, flat), len(keys) - 1)
        hit = keys[at] == flat
        out[hit, 8:] = table[at[hit]]
        return out

    def neighbours(self, level: int, flat) -> np.ndarray:
        """The cells (flattened, unique) that touch cells ``flat`` of ``level``, across
        face edges too."""
        nb = self.neighbour_table(level, flat).ravel()
        return np.unique(nb[nb >= 0])

    def adjacent(self, level: int, a, b) -> np.ndarray:
        """Whether cells ``a`` and ``b`` of ``level`` (arrays) touch."""
        a = np.asarray(a, dtype=np.int64)
        b = np.asarray(b, dtype=np.int64)
        fa, ja, ia = self.split(level, a)
        fb, jb, ib = self.split(level, b)
        out = (fa == fb) & (np.abs(ja - jb) <= 1) & (np.abs(ia - ib) <= 1)
        other = np.flatnonzero(fa != fb)
        if len(other):
            table = self.neighbour_table(level, a[other])[:, 8:]
            out[other] = np.any(table == b[other, None], axis=1)
        return out
