"""The job of a pyramid run: what every tile depends on, sent whole to the workers of a
distributed run."""

from __future__ import annotations

from dataclasses import dataclass

from .tilepaint import TileStyle

__all__ = ["MAX_BLOCK", "PyramidJob"]

#: Frontier tiles rendered per GPU run: (MAX_BLOCK / tile size)^2.
MAX_BLOCK = 4096


@dataclass(frozen=True, kw_only=True)
class PyramidJob:
    """What every tile of a pyramid depends on, the same in every process of a run.

    Attributes
    ----------
    shape : Shape
        The input, read once.
    d : float
        The offset distance, an angle (radians; on the ellipsoid, on its sphere of
        radius ``a``).
    zlo, zhi : int
        The zooms written, inclusive.
    size : int
        The tile side in pixels (a power of two).
    style : TileStyle
        The colours and the outline.
    max_block : int
        Frontier tiles per GPU run: at most ``(max_block / size)^2``; the tiles do not
        depend on it.
    """

    shape: object
    d: float
    zlo: int
    zhi: int
    size: int
    style: TileStyle
    max_block: int = MAX_BLOCK
