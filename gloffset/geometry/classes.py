"""The class codes of grid cells, one definition for the CPU levels and the GL passes.

Every level of the raster engine writes one uint8 class per cell; the shaders
(``shaders/classify.frag``, ``shaders/raster_classify.frag``) keep GLSL copies of these
numbers, which ``tests/test_layers.py`` compares with them.
"""

from __future__ import annotations

__all__ = ["OUTSIDE", "FRONTIER", "CONTAINED", "AMBIGUOUS"]

OUTSIDE = 0  # decided: outside the region, and so is every descendant pixel
FRONTIER = 1  # undecided at this level: its children are classified at the next
CONTAINED = 2  # decided: inside the region, and so is every descendant pixel
AMBIGUOUS = 3  # written by a GL pass where float32 cannot decide; decided in float64 after
