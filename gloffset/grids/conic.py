"""Lambert conformal conic projections (1SP and 2SP: EPSG:3978 Canada, EPSG:2154
Lambert-93, EPSG:3347, spherical LCC CRSs) as :class:`~gloffset.grids.Projected` grids'
GLSL function uses them (``shaders/lib/grids/lambert_conformal_conic.glsl``): pyproj's
parameters, where the function may stand for pyproj's inverse, and its constants.

PROJ's inverse: ``rho = sign(n) hypot(x', rho0 - y')``, ``theta = atan2(sign(n) x',
sign(n) (rho0 - y'))``, ``lambda = lambda0 + theta / n``, ``t = (rho / c)^(1 / n) =
tan(pi/4 - chi/2)`` (``chi`` the conformal latitude), the geodetic latitude from the
conformal one (PROJ iterates; the function sums the conformal latitude's series,
:func:`~gloffset.grids.polar.latitude_powers`, to the roundings). ``n``, ``c`` and
``rho0`` are PROJ's (``lcc.cpp``: ``n = ln(m1 / m2) / ln(t1 / t2)`` or ``sin phi1``,
``c = m1 t1^-n / n``, ``rho0 = c t0^n``, on the unit ellipsoid, then ``a k0``).
"""

from __future__ import annotations

import math

from .polar import conformal_series
from .protocol import GlslCentres
from .stretch import eccentricity_squared

__all__ = ["lcc_params", "lcc_clear", "lcc_glsl", "LCC_GLSL"]

#: The GLSL function of the Lambert conformal conic grids' centres
LCC_GLSL = "lib/grids/lambert_conformal_conic.glsl"
#: The largest ``|theta / n|`` (rad) where the function's sine and cosine of its half
#: hold (``shaders/lib/fp64.glsl``: ``|x| <= 2``), and the least ``Y`` (the distance
#: below the apex over ``c``) it takes
_LAMBDA_MAX, _Y_MIN = 3.8, 1e-6


def _msfn(phi: float, es: float) -> float:
    s = math.sin(phi)
    return math.cos(phi) / math.sqrt(1.0 - es * s * s)


def _tsfn(phi: float, es: float) -> float:
    e, s = math.sqrt(es), math.sin(phi)
    return math.tan(0.5 * (0.5 * math.pi - phi)) / ((1.0 - e * s) / (1.0 + e * s)) ** (0.5 * e)


def lcc_params(crs) -> dict | None:
    """What the LCC inverse needs from ``crs``, or None for other CRSs: ``lon0`` (rad),
    ``fe``, ``fn``, ``unit``, ``es``, ``n`` (the cone constant), ``c`` (metres: ``rho =
    c t^n``) and ``rho0`` (metres: the false origin's distance from the apex); ``c``
    and ``rho0`` have the sign of ``n``, as PROJ's."""
    op = crs.coordinate_operation
    if op is None or op.method_name not in (
        "Lambert Conic Conformal (1SP)",
        "Lambert Conic Conformal (2SP)",
    ):
        return None
    p = {q.name: q.value for q in op.params}
    need: tuple[str, ...] = ("Latitude of natural origin", "Longitude of natural origin")
    if op.method_name.endswith("(2SP)"):
        need = (
            "Latitude of false origin",
            "Longitude of false origin",
            "Latitude of 1st standard parallel",
            "Latitude of 2nd standard parallel",
        )
    if any(p.get(k) is None for k in need):
        return None
    es = eccentricity_squared(crs)
    a = crs.ellipsoid.semi_major_metre
    if op.method_name.endswith("(1SP)"):
        phi0 = math.radians(p["Latitude of natural origin"])
        phi1 = phi2 = phi0
        lon0 = p["Longitude of natural origin"]
        k0 = p.get("Scale factor at natural origin", 1.0)
        fe, fn = p.get("False easting", 0.0), p.get("False northing", 0.0)
    else:
        phi0 = math.radians(p["Latitude of false origin"])
        phi1 = math.radians(p["Latitude of 1st standard parallel"])
        phi2 = math.radians(p["Latitude of 2nd standard parallel"])
        lon0 = p["Longitude of false origin"]
        k0 = 1.0
        fe, fn = p.get("Easting at false origin", 0.0), p.get("Northing at false origin", 0.0)
    m1, t1 = _msfn(phi1, es), _tsfn(phi1, es)
    if abs(phi1 - phi2) >= 1e-10:
        n = math.log(m1 / _msfn(phi2, es)) / math.log(t1 / _tsfn(phi2, es))
    else:
        n = math.sin(phi1)
    if n == 0.0:
        return None
    c = m1 * t1**-n / n
    rho0 = 0.0 if abs(abs(phi0) - 0.5 * math.pi) < 1e-10 else c * _tsfn(phi0, es) ** n
    return {
        "lon0": math.radians(lon0),
        "fe": fe,
        "fn": fn,
        "unit": crs.axis_info[0].unit_conversion_factor or 1.0,
        "es": es,
        "n": n,
        "c": a * k0 * c,
        "rho0": a * k0 * rho0,
    }


def _plane(pp: dict, box) -> tuple[float, float, float, float]:
    """``(X_min, X_max, Y_min, Y_max)`` over the box (CRS units), the sign of ``n`` in."""
    k = pp["unit"] / pp["c"]  # sign(n) / |c| (c has the sign of n)
    xs = sorted(((box[0] - pp["fe"]) * k, (box[2] - pp["fe"]) * k))
    r0 = pp["rho0"] / pp["c"]
    ys = sorted((r0 - (box[1] - pp["fn"]) * k, r0 - (box[3] - pp["fn"]) * k))
    return (xs[0], xs[1], ys[0], ys[1])


def lcc_clear(crs, box) -> bool:
    """Whether the GLSL function stands for pyproj over the box ``(xmin, ymin, xmax,
    ymax)`` (CRS units: a grid's cell centres, every level): an LCC CRS, the box on the
    equator's side of the apex (``Y >= 1e-6``, so ``theta`` within ``+-pi/2``) and
    ``|theta / n| <= 3.8`` (the largest at a corner)."""
    pp = lcc_params(crs)
    if pp is None:
        return False
    x0, x1, y0, y1 = _plane(pp, box)
    if not y0 >= _Y_MIN:
        return False
    theta = max(abs(math.atan2(x, y)) for x in (x0, x1) for y in (y0, y1))
    return theta / abs(pp["n"]) <= _LAMBDA_MAX


def lcc_glsl(crs, frame) -> GlslCentres | None:
    """The GLSL centres (``shaders/lib/grids/lambert_conformal_conic.glsl``, its notes
    say what each constant is) of an LCC ``crs`` over the pixel ``frame`` ``(x0, y0,
    full_w, full_h, full_bounds)`` of a :class:`Projected`, or None for other CRSs."""
    pp = lcc_params(crs)
    if pp is None:
        return None
    x0, y0, fw, fh, (xmin, ymin, xmax, ymax) = frame
    dx, dy = (xmax - xmin) / fw, (ymax - ymin) / fh
    k = pp["unit"] / pp["c"]  # sign(n) / |c| (c has the sign of n)
    r0 = pp["rho0"] / pp["c"]
    plane = ((xmin - pp["fe"] + x0 * dx) * k, dx * k, r0 - (ymax - pp["fn"] - y0 * dy) * k, dy * k)
    turn = (0.5 / pp["n"], math.cos(pp["lon0"]), math.sin(pp["lon0"]))
    return GlslCentres(LCC_GLSL, plane + turn + conformal_series(pp["es"]))
