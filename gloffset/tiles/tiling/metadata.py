"""The metadata of a pyramid's output: the options a resumed run must match
(:func:`options_json`), the name, description, bounds and centre.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from ..._version import __version__
from ...errors import TilesError
from ...grids.mercator import lat_at
from ...units import EARTH_RADIUS
from ..store.tilestore import INPUT_KEY, input_digest

__all__ = [
    "options_json",
    "store_metadata",
    "source_name",
    "describe",
    "final_bounds",
    "check_resume",
]


def options_json(d, zooms, size, style, ell=None, quad=None) -> str:
    extra = {} if ell is None else {"ellipsoid": [ell.a, ell.f]}
    if quad is not None:
        extra["tms"] = quad.id
    return json.dumps(
        {
            **extra,
            "distance_rad": repr(float(d)),
            "zooms": list(zooms),
            "tile_size": size,
            "fill": style.fill,
            "opacity": style.opacity,
            "outline": style.outline,
            "outline_width": style.outline_width,
        },
        sort_keys=True,
    )


def store_metadata(name, description, zooms, params) -> dict:
    return {
        "name": name,
        "format": "png",
        "type": "overlay",
        "version": "1",
        "description": description,
        "minzoom": zooms[0],
        "maxzoom": zooms[1],
        "bounds": "-180.0,-85.051129,180.0,85.051129",
        "center": f"0.0,0.0,{zooms[0]}",
        "gloffset": params,
    }


def source_name(shape) -> str | None:
    """The file stem of an input given as a path (None for anything else)."""
    if isinstance(shape, Path):
        return shape.stem
    if isinstance(shape, str) and shape != "-" and not shape.lstrip().startswith(("{", "[")):
        return Path(shape).stem
    return None


def describe(distance, d: float, radius: float, source: str | None) -> str:
    """The ``description`` metadata of a pyramid: the distance as given (``"127km"``, or a
    number in metres), its value in metres and radians, and the input's name.

    Examples
    --------
    >>> describe("127km", 127e3 / EARTH_RADIUS, EARTH_RADIUS, "mexico_10m").split(";")[0]
    'Region within 127km of mexico_10m, polygons included (127km = 127000 m = 0.019934 rad)'
    """
    value = f"{d * radius:.10g} m = {d:.6g} rad"
    if isinstance(distance, str):
        given = distance.strip()
        value = f"{given} = {value}"
    else:
        given = f"{float(distance):.10g} m"
    if radius != EARTH_RADIUS:
        value += f" on a sphere of radius {radius:.10g} m"
    src = source or "the input"
    if d < 0:
        size = given[1:].lstrip() if given.startswith("-") else given
        what = f"Points of {src} inside its polygons and farther than {size} from their boundary"
    else:
        what = f"Region within {given} of {src}, polygons included"
    return f"{what} ({value}); gloffset {__version__}"


def final_bounds(store, zooms, quad=None) -> dict:
    """The ``bounds`` and ``center`` metadata of the tiles written (lon/lat degrees), from
    the deepest zoom that has any; ``quad``: a lon/lat TMS's quadtree (None: web
    mercator)."""
    for z in range(zooms[1], zooms[0] - 1, -1):
        ext = store.extent(z)
        if ext is not None:
            x0, y0, x1, y1 = ext
            if quad is None:
                w, e = x0 * 360.0 / (1 << z) - 180.0, (x1 + 1) * 360.0 / (1 << z) - 180.0
                n, s = (math.degrees(float(lat_at(v, 1 << z))) for v in (y0, y1 + 1))
            else:
                w, s, e, n = quad.tiles_lonlat(z, x0, y0, x1, y1)
            b = (round(w, 6), round(s, 6), round(e, 6), round(n, 6))
            cz = min(zooms[1], max(zooms[0], z - 2))
            return {
                "bounds": ",".join(repr(v) for v in b),
                "center": f"{round((w + e) / 2, 6)},{round((s + n) / 2, 6)},{cz}",
            }
    return {}


def check_resume(have: dict, params: str, shape, where) -> None:
    """Refuse to resume the output ``where`` whose metadata ``have`` records other options
    than ``params`` (:func:`options_json`), or the tiles of another input (or of one not
    recorded: an output of gloffset before 2026-11-26 has no digest, and its input cannot
    be checked)."""
    where = str(where)
    if have.get("gloffset") != params:
        raise TilesError(
            f"cannot resume {where!r}: it was written with other options "
            f"({have.get('gloffset')}); use --force to start again"
        )
    found, want = have.get(INPUT_KEY), input_digest(shape)
    if found is None:
        raise TilesError(
            f"cannot resume {where!r}: it records no digest of its input ({INPUT_KEY}), so "
            "whether it holds this input's tiles cannot be checked; use --force to start again"
        )
    if found != want:
        raise TilesError(
            f"cannot resume {where!r}: it holds the tiles of another input (its geometry's "
            f"{found[:19]}..., this input's {want[:19]}...); use --force to start again"
        )
