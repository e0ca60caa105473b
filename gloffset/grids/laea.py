"""Lambert azimuthal equal-area projections (EPSG:3035 LAEA Europe, the
``EuropeanETRS89_LAEAQuad`` tiles, EASE-Grid 2.0 away from its pole, spherical LAEA
CRSs: every aspect) as :class:`~gloffset.grids.Projected` grids use them: pyproj's
parameters, where the GLSL function (``shaders/lib/grids/lambert_azimuthal.glsl``) may
stand for pyproj's inverse, and its constants.

PROJ's ellipsoidal inverse goes through the authalic sphere: the plane to the authalic
latitude ``beta`` and the longitude (a sphere's LAEA inverse), then ``beta`` to the
geodetic latitude by a truncated series (2.5e-10 rad off the exact latitude, measured
with PROJ 9.5.1). The GLSL function computes the same two steps, its series read from
pyproj (:func:`laea_series`), so that it stands for pyproj's centres to the roundings
(8e-15 rad measured), whatever the series of the PROJ at hand.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .polar import latitude_powers, sample_latitudes
from .protocol import GlslCentres
from .stretch import eccentricity_squared

__all__ = [
    "laea_params",
    "laea_series",
    "laea_clear",
    "laea_glsl",
    "LAEA_GLSL",
    "LAEA_PYPROJ_BOUND",
]

#: The GLSL function of the LAEA grids' centres, and the terms of its latitude series
LAEA_GLSL, _SERIES_TERMS = "lib/grids/lambert_azimuthal.glsl", 6
#: The GLSL centre's distance (rad) from pyproj's at any cell centre of a grid that
#: takes it (:func:`laea_clear`): tested at many points of every aspect (8e-15 measured;
#: pyproj's own rounding near the poles and the antipode grows as 2e-15 over the
#: distance to them, which :func:`laea_clear` keeps above :data:`_CLEAR`)
LAEA_PYPROJ_BOUND = 1e-12
#: Least angle (rad) from every cell centre to either pole and to the antipode of the
#: projection's centre for the GLSL function to stand for pyproj's (:func:`laea_clear`)
_CLEAR = 0.01
_EPS10 = 1e-10  # PROJ's test for the polar and equatorial aspects


def _q(sin_phi: float, e: float) -> float:
    """``q(phi)`` of the authalic latitude (EPSG Guidance Note 7-2, 1.3.11): ``(1 - e^2)
    (sin phi / (1 - e^2 sin^2 phi) - ln((1 - e sin phi) / (1 + e sin phi)) / (2 e))``."""
    if e == 0.0:
        return 2.0 * sin_phi
    es = e * sin_phi
    return (1.0 - e * e) * (
        sin_phi / (1.0 - es * es) - math.log((1.0 - es) / (1.0 + es)) / (2.0 * e)
    )


def laea_params(crs) -> dict | None:
    """What the LAEA inverse needs from ``crs`` (as PROJ sets it up), or None for other
    CRSs: ``lon0`` (rad), ``fe``, ``fn``, ``unit`` (metres per CRS unit), ``a``, ``es``
    (e^2), ``sb``, ``cb`` (sine and cosine of the authalic latitude ``beta_0`` of the
    origin), ``kx``, ``ky`` (unit sphere plane coordinates per metre: ``(X, Y) = ((x -
    fe) kx, (y - fn) ky)`` with ``X^2 + Y^2 = 4 sin^2(c / 2)``, ``c`` the angle from the
    origin on the authalic sphere)."""
    op = crs.coordinate_operation
    if op is None or not op.method_name.startswith("Lambert Azimuthal Equal Area"):
        return None
    es = eccentricity_squared(crs)
    if "Spherical" in op.method_name and es != 0.0:
        return None  # the spherical formulas on an ellipsoid: not PROJ's laea
    params = {p.name: p.value for p in op.params}
    lat0 = math.radians(params.get("Latitude of natural origin", 0.0))
    e = math.sqrt(es)
    a = crs.ellipsoid.semi_major_metre
    qp = _q(1.0, e)
    rq = math.sqrt(0.5 * qp)
    if abs(abs(lat0) - math.pi / 2) < _EPS10:
        sb, cb, dd = math.copysign(1.0, lat0), 0.0, 1.0
    else:
        s0 = math.sin(lat0)
        sb = _q(s0, e) / qp
        cb = math.sqrt(1.0 - sb * sb)
        dd = math.cos(lat0) / (math.sqrt(1.0 - es * s0 * s0) * rq * cb)
    unit = crs.axis_info[0].unit_conversion_factor or 1.0
    return {
        "lon0": math.radians(params.get("Longitude of natural origin", 0.0)),
        "fe": params.get("False easting", 0.0),
        "fn": params.get("False northing", 0.0),
        "unit": unit,
        "a": a,
        "es": es,
        "sb": sb,
        "cb": cb,
        "kx": unit / (a * dd * rq),
        "ky": unit * dd / (a * rq),
    }


@functools.lru_cache(maxsize=16)
def laea_series(a: float, inv_f: float) -> tuple[float, ...]:
    """The coefficients ``g_0..g_5`` (:func:`~gloffset.grids.polar.latitude_powers`) of
    pyproj's geodetic latitude less the authalic one on the ellipsoid ``(a, 1 / inv_f)``
    (0 for a sphere), read from pyproj: its polar LAEA inverse at 64 authalic latitudes
    ``beta`` (the plane point at ``x^2 + y^2 = a^2 q_p (1 - sin beta)`` on the central
    meridian). The sine transform of 64 samples gives its first six terms to the
    roundings (terms from the 32nd on would alias); PROJ's series has no more that
    matter (tested against pyproj at many points: within 8e-15 rad)."""
    if not inv_f:
        return (0.0,) * _SERIES_TERMS
    import pyproj

    f = 1.0 / inv_f
    e = math.sqrt(f * (2.0 - f))
    qp = _q(1.0, e)
    beta = sample_latitudes()
    y = -a * np.sqrt(qp * (1.0 - np.sin(beta)))
    proj = pyproj.Proj(f"+proj=laea +lat_0=90 +lon_0=0 +a={a!r} +rf={inv_f!r}")
    _, lat = proj(np.zeros_like(y[1:]), y[1:], inverse=True, errcheck=True)
    delta = np.concatenate([[0.0], np.radians(lat) - beta[1:]])  # the south pole: sin 0
    return latitude_powers(beta, delta, _SERIES_TERMS)


def _unit_plane(pp: dict, box) -> tuple[float, float, float, float]:
    """The box ``(xmin, ymin, xmax, ymax)`` (CRS units) on the unit sphere's plane."""
    x = sorted(((box[0] - pp["fe"]) * pp["kx"], (box[2] - pp["fe"]) * pp["kx"]))
    y = sorted(((box[1] - pp["fn"]) * pp["ky"], (box[3] - pp["fn"]) * pp["ky"]))
    return (x[0], y[0], x[1], y[1])


def laea_clear(crs, box) -> bool:
    """Whether every point of the box ``(xmin, ymin, xmax, ymax)`` (CRS units: a grid's
    cell centres, every level) lies at least :data:`_CLEAR` rad (on the authalic sphere)
    from both poles and from the antipode of the origin, where pyproj's rounding stays
    within :data:`LAEA_PYPROJ_BOUND` (its ``asin`` near 1 loses precision as 1 over the
    distance). The antipode: ``c <= c_max = 2 asin(r_max / 2)`` at the box's farthest
    corner ``r_max``. A pole at angle ``c_p`` from the origin, its plane point ``P``: a
    point within ``t0 = 0.1`` rad of it has ``c <= c_p + t0``, where LAEA's largest
    scale is ``1 / cos((c_p + t0) / 2)``, so a point of the box, at least ``D`` from
    ``P`` in the plane, lies at least ``min(t0, D cos((c_p + t0) / 2))`` from the pole;
    and at least ``c_p - c_max`` (the triangle inequality)."""
    pp = laea_params(crs)
    if pp is None:
        return False
    x0, y0, x1, y1 = _unit_plane(pp, box)
    r_max = max(math.hypot(x, y) for x in (x0, x1) for y in (y0, y1))
    if r_max >= 2.0:
        return False
    c_max = 2.0 * math.asin(r_max / 2.0)
    if c_max > math.pi - _CLEAR:
        return False
    t0 = 0.1
    beta0 = math.atan2(pp["sb"], pp["cb"])
    for c_p, py in ((math.pi / 2 - beta0, 1.0), (math.pi / 2 + beta0, -1.0)):
        p = py * 2.0 * math.sin(c_p / 2.0)  # the pole's plane point (0, p)
        dx = max(x0, 0.0, -x1)  # the box's distance from it
        dy = max(y0 - p, 0.0, p - y1)
        far = c_p - c_max
        if c_p + t0 < math.pi:
            far = max(far, min(t0, math.hypot(dx, dy) * math.cos((c_p + t0) / 2.0)))
        if far < _CLEAR:
            return False
    return True


def laea_glsl(crs, frame) -> GlslCentres | None:
    """The GLSL centres (``shaders/lib/grids/lambert_azimuthal.glsl``, its notes say what
    each constant is) of a LAEA ``crs`` over the pixel ``frame`` ``(x0, y0, full_w,
    full_h, full_bounds)`` of a :class:`Projected`, or None for other CRSs."""
    pp = laea_params(crs)
    if pp is None:
        return None
    x0, y0, fw, fh, (xmin, ymin, xmax, ymax) = frame
    dx, dy = (xmax - xmin) / fw, (ymax - ymin) / fh
    kx, ky = pp["kx"], pp["ky"]
    plane = ((xmin - pp["fe"] + x0 * dx) * kx, dx * kx, (ymax - pp["fn"] - y0 * dy) * ky, -dy * ky)
    turn = (pp["cb"], pp["sb"], math.cos(pp["lon0"]), math.sin(pp["lon0"]))
    ell = crs.ellipsoid
    series = laea_series(float(ell.semi_major_metre), float(ell.inverse_flattening or 0.0))
    return GlslCentres(LAEA_GLSL, plane + turn + series)
