"""How a map tile looks: fill colour and opacity on a transparent background, and an
optional outline of the original curves, encoded as a small palette PNG
(:func:`~gloffset.io.png.palette_png`).

The outline is drawn from the shape's boundary arcs (seams excluded): the part of
each great-circle arc within the tile's bound of its centre is densified to steps
of half a pixel, taken to web-mercator pixel coordinates of the tile (longitudes
unwrapped around the tile centre, so arcs across the antimeridian draw right) and
drawn with Pillow's ``ImageDraw.line``. The arcs are prepared once per shape
(:class:`OutlineArcs`) and a tile's arcs are clipped and sampled together in numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw

from ...errors import OptionError
from ...geometry.sphere import dot, xyz_to_lonlat
from ...io.png import palette_png, parse_color

__all__ = ["TileStyle", "StyleError", "OutlineArcs"]

#: Largest latitude drawn (mercator is infinite at the poles; tiles stop at 85.05 deg).
_LAT_CLIP = 89.0
#: Margin (radians) beyond which numpy decides an arc's drawn interval (:meth:`OutlineArcs.lines`).
_SURE = 1e-6


#: The former name of :class:`~gloffset.errors.OptionError` (a tile style option with a bad
#: value), kept so that ``except StyleError`` works.
StyleError = OptionError


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
            raise OptionError(f"opacity must be a number from 0 to 1, got {self.opacity!r}")
        if not (isinstance(self.outline_width, int) and 1 <= self.outline_width <= 32):
            raise OptionError(f"outline width must be 1..32 pixels, got {self.outline_width!r}")

    def palette(self) -> list[tuple[int, int, int, int]]:
        """RGBA of palette entries 0 (outside: transparent), 1 (fill), 2 (outline)."""
        r, g, b, a = parse_color(self.fill)
        fill = (r, g, b, int(round(a * self.opacity)))
        line = parse_color(self.outline) if self.outline is not None else (0, 0, 0, 0)
        return [(0, 0, 0, 0), fill, line]

    def encode(self, mask: np.ndarray, lines=()) -> bytes | None:
        """PNG bytes of a tile: ``mask`` (bool or 0/255, size x size) and outline polylines.

        ``lines`` holds polylines in Pillow pixel coordinates: (k, 2) arrays or flat
        lists ``[x0, y0, x1, y1, ...]`` (:meth:`OutlineArcs.lines`). Returns None when
        the tile shows nothing (no pixel inside and no outline pixel). The PNG is a
        palette image (:func:`~gloffset.io.png.palette_png`): 1 bit a pixel with entries
        0 and 1 of :meth:`palette`, 2 bits when outline pixels are drawn.
        """
        inside = np.asarray(mask)
        if inside.dtype != bool:
            inside = inside > 0
        if self.outline is not None and len(lines):
            img = Image.fromarray(inside.astype(np.uint8), mode="P")
            draw = ImageDraw.Draw(img)
            for pts in lines:
                if isinstance(pts, np.ndarray):
                    pts = pts.ravel().tolist()
                draw.line(pts, fill=2, width=self.outline_width)
            idx = np.asarray(img)
            if not idx.any():
                return None
            if (idx == 2).any():
                return palette_png(idx, self.palette())
        elif not inside.any():
            return None
        return palette_png(inside, self.palette()[:2])


class OutlineArcs:
    """The arcs of a shape prepared once for drawing outlines on many tiles.

    Holds, per arc ``a -> b``, the in-plane direction ``w = n x a`` (so the arc is
    ``cos(t) a + sin(t) w`` for ``t`` in ``0..theta``) and its length ``theta``.
    :meth:`lines` decides and samples the arcs of a tile in numpy; only the arcs that
    cross the edge of the tile's disc, or come within 1e-6 rad of it, go through the
    scalar formulas one by one (see :meth:`lines`).
    """

    def __init__(self, arcs):
        self.a = np.ascontiguousarray(arcs.a, dtype=np.float64)
        self.w = np.cross(arcs.n, arcs.a)
        self.drawable = np.any(arcs.n != 0, axis=1)  # a point has no line
        c = np.cross(arcs.a, arcs.b)
        sn, cs = np.sqrt(dot(c, c)).tolist(), dot(arcs.a, arcs.b).tolist()
        self.theta = np.array([math.atan2(s, q) for s, q in zip(sn, cs)], dtype=np.float64)

    def lines(self, which, center, r: float, z: int, x: int, y: int, size: int) -> list:
        """Polylines of the arcs ``which`` in Pillow pixel coordinates of tile ``z/x/y``,
        each a flat list ``[x0, y0, x1, y1, ...]``.

        Only the part of each arc within ``r`` (radians) of ``center`` (the tile
        centre, a unit vector) is drawn: with ``r`` at least the tile's bound, that is
        every point of the arc inside the tile. The parameter interval drawn is
        ``[max(0, t0 - h), min(theta, t0 + h)]``, ``t0`` the parameter nearest the
        centre and ``h = acos(cos(r) / rho) + r`` (``rho`` the length of the centre's
        projection on the arc's plane; ``+ r``: a margin for acos near 1), sampled
        every half pixel. Arcs whose interval is certainly ``[0, theta]`` (both ends
        beyond the disc's edge by 1e-6 rad) or certainly empty are decided in numpy;
        the others with the scalar ``math`` functions, so the points are the same
        floats for every arc wherever it sits in the list.
        """
        which = np.asarray(which, dtype=np.int64)
        which = which[self.drawable[which]]
        if len(which) == 0:
            return []
        world = float((1 << z) * size)
        lon0, _ = xyz_to_lonlat(center)
        lon_c = float(lon0)
        lat_c = math.asin(max(-1.0, min(1.0, float(center[2]))))
        step = 0.5 * 2.0 * math.pi * max(math.cos(lat_c), 1e-3) / world  # half a pixel
        a, w, theta = self.a[which], self.w[which], self.theta[which]
        ca, cw = dot(a, center), dot(w, center)
        cr = math.cos(r)
        with np.errstate(divide="ignore", invalid="ignore"):
            rho = np.hypot(ca, cw)
            t0 = np.arctan2(cw, ca)
            half = np.arccos(np.clip(cr / rho, -1.0, 1.0)) + r
        # numpy's hypot, arctan2 and arccos may differ from math's in the last bits
        # (3e-8 rad at most, for acos near 1): far from the thresholds that is moot
        live = (rho >= cr + 1e-12) & (rho > 1e-9)
        lo = np.maximum(0.0, t0 - half)
        hi = np.minimum(theta, t0 + half)
        gone = (rho < cr - 1e-12) | (live & (lo > hi + _SURE))
        whole = live & (t0 - half <= -_SURE) & (t0 + half >= theta + _SURE)
        lo = np.zeros(len(which))
        hi = theta.copy()
        keep = whole.copy()
        for k in np.flatnonzero(~gone & ~whole).tolist():
            kca, kcw = float(ca[k]), float(cw[k])
            krho = math.hypot(kca, kcw)
            if krho <= 0.0 or cr > krho:
                continue
            kt0 = math.atan2(kcw, kca)
            kh = math.acos(max(-1.0, min(1.0, cr / krho))) + r
            klo, khi = max(0.0, kt0 - kh), min(float(theta[k]), kt0 + kh)
            if klo > khi:
                continue
            lo[k], hi[k], keep[k] = klo, khi, True
        sel = np.flatnonzero(keep)
        if len(sel) == 0:
            return []
        lo, hi, a, w = lo[sel], hi[sel], a[sel], w[sel]
        # np.linspace(lo, hi, n) for every arc at once, in its arithmetic
        delta = hi - lo
        n = np.maximum(2, np.ceil(delta / step).astype(np.int64) + 1)
        ends = np.cumsum(n)
        arc = np.repeat(np.arange(len(sel)), n)
        k = (np.arange(ends[-1]) - np.repeat(ends - n, n)).astype(np.float64)
        div = (n - 1).astype(np.float64)
        dstep = delta / div
        t = np.where(dstep[arc] == 0.0, k / div[arc] * delta[arc], k * dstep[arc]) + lo[arc]
        t[ends - 1] = hi
        p = np.cos(t)[:, None] * a[arc] + np.sin(t)[:, None] * w[arc]
        lon, lat = xyz_to_lonlat(p)
        lon = lon_c + (np.asarray(lon) - lon_c + 180.0) % 360.0 - 180.0
        lat = np.clip(np.radians(lat), -math.radians(_LAT_CLIP), math.radians(_LAT_CLIP))
        px = ((lon + 180.0) / 360.0) * world - x * size - 0.5
        py = (0.5 - np.arcsinh(np.tan(lat)) / (2.0 * math.pi)) * world - y * size - 0.5
        flat = np.column_stack([px, py]).ravel().tolist()
        return [flat[2 * s : 2 * e] for s, e in zip((ends - n).tolist(), ends.tolist())]
