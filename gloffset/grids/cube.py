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

import numpy as np

from ..sphere import angle, normalize
from .base import InvalidGridError, Levels, Square, check_size

__all__ = ["Cube", "CubeFace", "FACES", "FACE_NAMES", "locate"]

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


_RHO_CACHE: dict[int, list[np.ndarray]] = {}


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


@dataclass(frozen=True)
class CubeFace(Square, Levels):
    """One ``size x size`` face of a cube map (``face`` 0..5 in the order of FACE_NAMES)."""

    face: int
    size: int

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
        e, u, v = self.basis
        sc = 2.0 * np.asarray(x, dtype=np.float64) / self.size - 1.0
        tc = 2.0 * np.asarray(y, dtype=np.float64) / self.size - 1.0
        sc, tc = np.broadcast_arrays(sc, tc)
        return normalize(e + sc[..., None] * u + tc[..., None] * v)

    def centers(self, level: int, j, i) -> np.ndarray:
        b = self.block(level)
        return self._point((np.asarray(i) + 0.5) * b, (np.asarray(j) + 0.5) * b)

    def _rhos(self) -> list[np.ndarray]:
        n = self.n_levels
        out: list = [None] * n
        out[n - 1] = np.zeros(self.level_shape(n - 1))
        for lev in range(n - 2, -1, -1):
            h, w = self.level_shape(lev)
            b = self.block(lev)
            jj, ii = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
            c = self.centers(lev, jj, ii)
            r = np.zeros((h, w))
            for dx in (0, 1):
                for dy in (0, 1):
                    r = np.maximum(r, angle(c, self._point((ii + dx) * b, (jj + dy) * b)))
            child = out[lev + 1]
            ch, cw = child.shape
            for dj in (0, 1):
                for di in (0, 1):
                    cj = np.minimum(2 * jj + dj, ch - 1)
                    ci = np.minimum(2 * ii + di, cw - 1)
                    cc = self.centers(lev + 1, cj, ci)
                    r = np.maximum(r, angle(c, cc) + child[cj, ci])
            out[lev] = r * (1.0 + 1e-12) + 1e-15
        return out

    def _cache(self) -> list[np.ndarray]:
        # the six faces are congruent (rotations and mirror images of one another in
        # (s, t)), so their bounds are the same arrays: computed once per size
        cache = _RHO_CACHE.get(int(self.size))
        if cache is None:
            cache = CubeFace(0, int(self.size))._rhos()
            if len(_RHO_CACHE) >= 4:
                _RHO_CACHE.pop(next(iter(_RHO_CACHE)))
            _RHO_CACHE[int(self.size)] = cache
        return cache

    def rho(self, level: int) -> np.ndarray:
        """Per-row maximum of the cells' bounds (what the GPU margins use)."""
        return self._cache()[level].max(axis=1)

    def rho_at(self, level: int, j, i) -> np.ndarray:
        return self._cache()[level][np.asarray(j), np.asarray(i)]


@dataclass(frozen=True)
class Cube:
    """Six ``size x size`` faces covering the sphere (see the module notes)."""

    size: int

    def __post_init__(self):
        check_size(self.size, self.size)

    @property
    def faces(self) -> list[CubeFace]:
        return [CubeFace(k, int(self.size)) for k in range(6)]

    @property
    def shape(self) -> tuple[int, int, int]:
        return (6, int(self.size), int(self.size))
