"""The options of a pyramid run (:class:`PyramidOptions`, the keywords of
:func:`~gloffset.tiles.pyramid`) and its job: what every tile depends on, sent whole to
the workers of a distributed run."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ...raster.options import check_keywords, option_names
from ...units import EARTH_RADIUS
from .tilepaint import TileStyle

__all__ = ["MAX_BLOCK", "PyramidJob", "PyramidOptions", "pyramid_options"]

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
    quad : TmsQuad or None
        The tile quadtree of the TileMatrixSet
        (:class:`~gloffset.grids.tms.TmsQuad`); None: web mercator.
    """

    shape: object
    d: float
    zlo: int
    zhi: int
    size: int
    style: TileStyle
    max_block: int = MAX_BLOCK
    quad: Any = None


@dataclass(frozen=True, kw_only=True)
class PyramidOptions:
    """The options of :func:`~gloffset.tiles.pyramid`, each documented there; ``style``
    holds its ``fill``, ``opacity``, ``outline`` and ``outline_width``."""

    radius: float = EARTH_RADIUS
    size: int = 256
    style: TileStyle = TileStyle()
    resume: bool = False
    overwrite: bool = False
    name: str | None = None
    source: str | None = None
    progress: Any = None
    max_block: int = MAX_BLOCK
    workers: int | None = None
    scheduler: str | None = None
    ellipsoid: Any = None
    tms: Any = None


def pyramid_options(options: dict[str, Any], what: str = "pyramid") -> PyramidOptions:
    """The keywords of :func:`~gloffset.tiles.pyramid` as :class:`PyramidOptions` (the
    style's checked); an unknown one is a :class:`TypeError` listing them."""
    styling = option_names(TileStyle)
    valid = [n for k in option_names(PyramidOptions) for n in (styling if k == "style" else [k])]
    check_keywords(what, options, valid)
    style = TileStyle(**{k: options[k] for k in styling if k in options})
    return PyramidOptions(**{k: v for k, v in options.items() if k not in styling}, style=style)
