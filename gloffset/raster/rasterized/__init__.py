"""Offsets of rasterized curves (paper Sec. 5): the curve is known only as grid cells.

:func:`rasterize` (:mod:`.curve_mask`) makes the curve mask of a shape;
:func:`raster_offset` (:mod:`.offset`) offsets a curve mask by region growing
(Sec. 5.1) and level by level (Sec. 5.2): the rasterized curve's cells per level and
their near pairs in :mod:`.curve_levels`, the GPU levels planned in :mod:`.curve_gpu`.
"""

from __future__ import annotations

from .curve_mask import rasterize
from .offset import *  # noqa: F403  (the names listed in offset.__all__)
from .offset import __all__ as _OFFSET_NAMES

__all__ = [*_OFFSET_NAMES, "rasterize"]
