"""A globe preview: the region within a distance, its input and a graticule on an
orthographic globe, drawn from cube maps (:func:`globe`).

The offset region and the input are rendered as cube maps (:class:`~gloffset.grids.Cube`,
the engine's own output), and one GL pass (:mod:`gloffset.gl.globe`) samples them along
each pixel's direction, so the preview is also a check of a globe texture: what it shows
is what a GL or three.js cube texture of those faces shows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import OptionError
from ..geometry.sphere import lonlat_to_xyz, normalize
from ..grids import Cube
from ..io.png import parse_color
from ..shape import read
from ..units import EARTH_RADIUS, RASTER_LIMIT, offset_angle
from .render import render_angle

__all__ = ["GlobeStyle", "globe", "view_frame"]


@dataclass(frozen=True)
class GlobeStyle:
    """Colours (any :func:`gloffset.io.png.parse_color` form), graticule spacing in
    degrees (0: none) and shading (0: flat, 1: full)."""

    fill: str = "#d0402ccc"
    ocean: str = "#f4f1ea"
    input_color: str = "#505050"
    background: str = "0,0,0,0"
    grid_color: str = "#8090a080"
    grid_step: float = 15.0
    shading: float = 0.6

    def uniforms(self) -> dict:
        out: dict[str, tuple[float, ...] | float] = {}
        for name in ("fill", "ocean", "input_color", "background", "grid_color"):
            out[name] = tuple(v / 255.0 for v in parse_color(getattr(self, name)))
        if not 0.0 <= float(self.shading) <= 1.0:
            raise OptionError(f"shading must be in [0, 1], got {self.shading!r}")
        if not 0.0 <= float(self.grid_step) <= 90.0:
            raise OptionError(
                f"the graticule step must be in [0, 90] degrees, got {self.grid_step!r}"
            )
        out["grid_step"] = float(self.grid_step)
        out["shading"] = float(self.shading)
        return out


def view_frame(center) -> np.ndarray:
    """(3, 3) columns east, north, centre: the view from far above ``center`` (lon, lat
    in degrees), north up (at a pole, 0 deg E up)."""
    c = lonlat_to_xyz(np.array([float(center[0])]), np.array([float(center[1])]))[0]
    east = np.cross([0.0, 0.0, 1.0], c)
    if np.linalg.norm(east) < 1e-12:
        east = np.array([0.0, 1.0, 0.0]) if c[2] > 0 else np.array([0.0, -1.0, 0.0])
    east = normalize(east)
    return np.column_stack([east, np.cross(c, east), c])


def _default_center(shape) -> tuple[float, float]:
    e = shape.edges()
    m = np.concatenate([e.a, e.b]).sum(axis=0)
    if np.linalg.norm(m) < 1e-9:
        return 0.0, 0.0
    m = normalize(m)
    return float(np.degrees(np.arctan2(m[1], m[0]))), float(np.degrees(np.arcsin(m[2])))


def globe(
    shape,
    distance: float | str,
    *,
    size: int = 1024,
    center=None,
    cube: int | None = None,
    style: GlobeStyle | None = None,
    radius: float = EARTH_RADIUS,
    spin: int | None = None,
):
    """An RGBA image (size, size, 4) of the region within ``distance`` of ``shape`` on an
    orthographic globe centred on ``center`` (lon, lat; default: the input's centre).

    ``distance``: in the units of ``radius`` (metres by default) or a string with a unit
    (``"127km"``), as in :func:`gloffset.render`.
    ``cube``: the side of the cube-map faces (default: ``size``, about two texels per
    pixel at the centre of the disc). ``spin``: a list of that many images instead, the
    globe turning eastwards once round (the cube maps are rendered once).
    """
    from ..gl.globe import draw_globe

    if not isinstance(size, (int, np.integer)) or not 16 <= size <= 8192:
        raise OptionError(f"size must be a whole number of pixels in 16..8192, got {size!r}")
    if spin is not None and (not isinstance(spin, (int, np.integer)) or not 1 <= spin <= 3600):
        raise OptionError(f"spin must be a number of frames in 1..3600, got {spin!r}")
    shape = read(shape)
    style = style or GlobeStyle()
    uniforms = style.uniforms()  # fail before the work
    n = int(cube) if cube is not None else max(64, int(size))
    d = offset_angle(shape, distance, radius, limit=RASTER_LIMIT, what="render")
    region = render_angle(shape, d, Cube(n))
    texel = 2.0 / n  # a texel's angular size at the face centre
    curves = 0.0 if shape.rings and not shape.lines else 0.75 * texel
    own = render_angle(shape, curves, Cube(n))
    lon, lat = center if center is not None else _default_center(shape)
    if spin is None:
        return draw_globe(region, own, view_frame((lon, lat)), int(size), uniforms)
    return [
        draw_globe(region, own, view_frame((lon - 360.0 * k / spin, lat)), int(size), uniforms)
        for k in range(spin)
    ]
