"""How a map tile looks: fill colour and opacity on a transparent background, and an
optional outline of the original curves, encoded as a small palette PNG.

The outline is drawn from the shape's boundary arcs (seams excluded): the part of
each great-circle arc within the tile's bound of its centre is densified to steps
of half a pixel, taken to web-mercator pixel coordinates of the tile (longitudes
unwrapped around the tile centre, so arcs across the antimeridian draw right) and
drawn with Pillow's ``ImageDraw.line``.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw

from .errors import GloffsetError
from .io.png import parse_color
from .sphere import xyz_to_lonlat

__all__ = ["TileStyle", "StyleError", "outline_lines"]

#: Largest latitude drawn (mercator is infinite at the poles; tiles stop at 85.05 deg).
_LAT_CLIP = 89.0


class StyleError(GloffsetError, ValueError):
    """A tile style option has a bad value."""


@dataclass(frozen=True)
class TileStyle:
    """Fill, opacity and outline of pyramid tiles.

    Parameters
    ----------
    fill : str
        Colour of the region (see :func:`gloffset.io.png.parse_color`); its alpha is
        multiplied by ``opacity``.
    opacity : float
        0 (invisible) to 1.
    outline : str, optional
        Colour of the original curves, drawn on top; None draws none.
    outline_width : int
        Line width in pixels.

    Examples
    --------
    >>> TileStyle("#3070c0", 0.5).palette()[1]
    (48, 112, 192, 128)
    """

    fill: str = "#3070c0"
    opacity: float = 1.0
    outline: str | None = None
    outline_width: int = 1

    def __post_init__(self):
        parse_color(self.fill)
        if self.outline is not None:
            parse_color(self.outline)
        if not (isinstance(self.opacity, (int, float)) and 0.0 <= self.opacity <= 1.0):
            raise StyleError(f"opacity must be a number from 0 to 1, got {self.opacity!r}")
        if not (isinstance(self.outline_width, int) and 1 <= self.outline_width <= 32):
            raise StyleError(f"outline width must be 1..32 pixels, got {self.outline_width!r}")

    def palette(self) -> list[tuple[int, int, int, int]]:
        """RGBA of palette entries 0 (outside: transparent), 1 (fill), 2 (outline)."""
        r, g, b, a = parse_color(self.fill)
        fill = (r, g, b, int(round(a * self.opacity)))
        line = parse_color(self.outline) if self.outline is not None else (0, 0, 0, 0)
        return [(0, 0, 0, 0), fill, line]

    def encode(self, mask: np.ndarray, lines=()) -> bytes | None:
        """PNG bytes of a tile: ``mask`` (bool or 0/255, size x size) and outline polylines.

        ``lines`` holds (k, 2) arrays of Pillow pixel coordinates. Returns None when
        the tile shows nothing (no pixel inside and no outline pixel).
        """
        idx = (np.asarray(mask) > 0).astype(np.uint8)
        img = Image.fromarray(idx, mode="P")
        if self.outline is not None and len(lines):
            draw = ImageDraw.Draw(img)
            for pts in lines:
                draw.line([tuple(p) for p in pts.tolist()], fill=2, width=self.outline_width)
            if not np.asarray(img).any():
                return None
        elif not idx.any():
            return None
        pal = self.palette()
        img.putpalette([c for rgba in pal for c in rgba[:3]])
        buf = io.BytesIO()
        img.save(buf, format="PNG", transparency=bytes(rgba[3] for rgba in pal))
        return buf.getvalue()


def outline_lines(arcs, which, center, r: float, z: int, x: int, y: int, size: int) -> list:
    """Polylines (Pillow pixel coordinates of tile ``z/x/y``) of the arcs ``which``.

    Only the part of each arc within ``r`` (radians) of ``center`` (the tile centre,
    a unit vector) is drawn: with ``r`` at least the tile's bound, that is every
    point of the arc inside the tile.
    """
    out = []
    world = float((1 << z) * size)
    lon_c, _ = xyz_to_lonlat(center)
    lon_c = float(lon_c)
    lat_c = math.asin(max(-1.0, min(1.0, float(center[2]))))
    step = 0.5 * 2.0 * math.pi * max(math.cos(lat_c), 1e-3) / world  # half a pixel
    for k in which:
        a, n = arcs.a[k], arcs.n[k]
        if not np.any(n):
            continue  # a point: no line
        w = np.cross(n, a)
        theta = math.atan2(float(np.linalg.norm(np.cross(a, arcs.b[k]))), float(a @ arcs.b[k]))
        ca, cw = float(center @ a), float(center @ w)
        rho = math.hypot(ca, cw)
        if rho <= 0.0 or math.cos(r) > rho:
            continue
        t0 = math.atan2(cw, ca)
        half = math.acos(max(-1.0, min(1.0, math.cos(r) / rho))) + r  # + r: margin for acos near 1
        lo, hi = max(0.0, t0 - half), min(theta, t0 + half)
        if lo > hi:
            continue
        t = np.linspace(lo, hi, max(2, int(math.ceil((hi - lo) / step)) + 1))
        p = np.cos(t)[:, None] * a + np.sin(t)[:, None] * w
        lon, lat = xyz_to_lonlat(p)
        lon = lon_c + (np.asarray(lon) - lon_c + 180.0) % 360.0 - 180.0
        lat = np.clip(np.radians(lat), -math.radians(_LAT_CLIP), math.radians(_LAT_CLIP))
        px = ((lon + 180.0) / 360.0) * world - x * size - 0.5
        py = (0.5 - np.arcsinh(np.tan(lat)) / (2.0 * math.pi)) * world - y * size - 0.5
        out.append(np.column_stack([px, py]))
    return out
