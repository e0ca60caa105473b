"""Polar stereographic projections (variants A and B: EPSG:3031, 3413, 3976, UPS) as
:class:`~gloffset.grids.Projected` grids use them: the scale at the pole (the grids'
formula bound), pyproj's parameters, the float64 twin of pyproj's inverse and the
constants of its GLSL function (``shaders/lib/grids/polar_stereographic.glsl``).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ..ellipsoid import Ellipsoid
from .protocol import GlslCentres
from .stretch import eccentricity_squared

__all__ = [
    "conformal_series",
    "polar_scale_min",
    "polar_params",
    "polar_inverse",
    "polar_glsl",
    "POLAR_GLSL",
]


def polar_scale_min(crs) -> float | None:
    """The smallest scale factor of a polar stereographic ``crs`` (at its pole), or None
    when ``crs`` is not polar stereographic.

    Variant A: the scale factor at the natural origin (the pole). Variant B (a standard
    parallel ``phi_c``): ``m_c sqrt((1 + e)^(1 + e) (1 - e)^(1 - e)) / (2 t_c)`` (EPSG
    Guidance Note 7-2, 1.3.7.2), 1 when the standard parallel is the pole.
    """
    op = crs.coordinate_operation
    if op is None or not op.method_name.startswith("Polar Stereographic"):
        return None
    params = {p.name: p.value for p in op.params}
    e = math.sqrt(eccentricity_squared(crs))
    if "variant A" in op.method_name:
        lat0 = params.get("Latitude of natural origin")
        if lat0 is None or abs(abs(lat0) - 90.0) > 1e-12:
            return None
        return float(params.get("Scale factor at natural origin", 1.0))
    if "variant B" in op.method_name:
        lat_c = params.get("Latitude of standard parallel")
        if lat_c is None:
            return None
        phi = math.radians(abs(lat_c))
        if abs(phi - math.pi / 2) < 1e-15:
            return 1.0
        s = math.sin(phi)
        m_c = math.cos(phi) / math.sqrt(1.0 - e * e * s * s)
        t_c = math.tan(math.pi / 4 - phi / 2) / ((1.0 - e * s) / (1.0 + e * s)) ** (e / 2)
        return m_c * math.sqrt((1 + e) ** (1 + e) * (1 - e) ** (1 - e)) / (2.0 * t_c)
    return None


def polar_params(crs) -> dict | None:
    """What the polar stereographic inverse needs from ``crs`` (pyproj's parameters),
    or None for other CRSs: ``south``, ``lon0`` (rad), ``fe``, ``fn``, ``unit`` (metres
    per CRS unit), ``es`` (e^2) and ``scale``, ``2 a k_p / sqrt((1 + e)^(1 + e) (1 -
    e)^(1 - e))`` (``k_p`` the scale at the pole, :func:`polar_scale_min`), the metres
    of ``tan(pi/4 - |chi|/2)`` (``chi`` the conformal latitude; EPSG Guidance Note 7-2,
    1.3.7)."""
    k = polar_scale_min(crs)
    if k is None:
        return None
    op = crs.coordinate_operation
    params = {p.name: p.value for p in op.params}
    lat0 = params.get("Latitude of natural origin", params.get("Latitude of standard parallel"))
    es = eccentricity_squared(crs)
    e = math.sqrt(es)
    a = crs.ellipsoid.semi_major_metre
    return {
        "south": lat0 is not None and lat0 < 0,
        "lon0": math.radians(
            params.get("Longitude of origin", params.get("Longitude of natural origin", 0.0))
        ),
        "fe": params.get("False easting", 0.0),
        "fn": params.get("False northing", 0.0),
        "unit": crs.axis_info[0].unit_conversion_factor or 1.0,
        "es": es,
        "scale": 2.0 * a * k / math.sqrt((1 + e) ** (1 + e) * (1 - e) ** (1 - e)),
    }


def polar_inverse(crs):
    """The float64 twin of pyproj's inverse of a polar stereographic ``crs``: a function
    ``(x, y) -> unit vectors (..., 3)`` (numpy, a few times faster than pyproj and
    :func:`~gloffset.geometry.sphere.lonlat_to_xyz`), or None for other CRSs. EPSG
    Guidance Note 7-2, 1.3.7: the conformal latitude from ``t = rho / scale``
    (:func:`polar_params`), the geodetic latitude from its series to ``e^8`` and one
    fixed-point step (which divides the error by about ``1 / e^2``), the longitude's
    cosine and sine straight from ``x`` and ``y``: within 1e-12 rad of pyproj's (tested)."""
    pp = polar_params(crs)
    if pp is None:
        return None
    south, lon0, fe, fn, unit = pp["south"], pp["lon0"], pp["fe"], pp["fn"], pp["unit"]
    es, scale = pp["es"], pp["scale"]
    e = math.sqrt(es)
    e4, e6, e8 = es * es, es**3, es**4
    c2 = es / 2 + 5 * e4 / 24 + e6 / 12 + 13 * e8 / 360
    c4 = 7 * e4 / 48 + 29 * e6 / 240 + 811 * e8 / 11520
    c6 = 7 * e6 / 120 + 81 * e8 / 1120
    c8 = 4279 * e8 / 161280
    cl0, sl0 = math.cos(lon0), math.sin(lon0)

    def inverse(x, y):
        dx = (np.asarray(x, dtype=np.float64) - fe) * unit
        dy = (np.asarray(y, dtype=np.float64) - fn) * unit
        rho = np.hypot(dx, dy)
        t = rho / scale
        chi = np.pi / 2 - 2.0 * np.arctan(t)
        s2, c2x = np.sin(2 * chi), np.cos(2 * chi)
        s4 = 2 * s2 * c2x
        c4x = 1 - 2 * s2 * s2
        s6 = s4 * c2x + c4x * s2
        s8 = 2 * s4 * c4x
        phi = chi + c2 * s2 + c4 * s4 + c6 * s6 + c8 * s8
        es_ = e * np.sin(phi)
        phi = np.pi / 2 - 2.0 * np.arctan(t * ((1.0 - es_) / (1.0 + es_)) ** (e / 2))
        # longitude lon0 + atan2(dx, -dy) (north) or atan2(dx, dy) (south)
        safe = np.where(rho > 0.0, rho, 1.0)
        ct = np.where(rho > 0.0, (dy if south else -dy) / safe, 1.0)
        st = np.where(rho > 0.0, dx / safe, 0.0)
        cl, sl = cl0 * ct - sl0 * st, sl0 * ct + cl0 * st
        cp, sp = np.cos(phi), np.sin(phi)
        if south:
            sp = -sp
        return np.stack([cp * cl, cp * sl, sp], axis=-1)

    return inverse


#: The GLSL function of the polar stereographic grids' centres, and the terms of its
#: conformal latitude series (the next is below 1e-17 rad on WGS84: a_2k ~ n^k)
POLAR_GLSL, _SERIES_TERMS = "lib/grids/polar_stereographic.glsl", 6


def latitude_powers(chi: np.ndarray, delta: np.ndarray, terms: int) -> tuple[float, ...]:
    """The coefficients ``g_0..g_terms-1`` (of powers of ``cos^2 chi``) of ``delta =
    cos chi sin chi G(cos^2 chi)`` from ``m`` samples ``delta`` at ``chi = pi (k / m -
    1/2)``, ``k < m``, of an odd function of period ``pi`` (a latitude less an auxiliary
    one): its Fourier series ``sum a_2k sin(2k chi)`` (a discrete sine transform, exact
    but for the terms from ``m / 2`` on), each ``sin(2k chi) = sin chi U_2k-1(cos chi)``
    written in powers of ``cos^2 chi`` (``U`` Chebyshev's of the second kind)."""
    m = len(chi)
    out = np.zeros(terms)
    u = [np.array([1.0]), np.array([0.0, 2.0])]  # U_n by its recurrence, low powers first
    while len(u) < 2 * terms:
        u.append(np.concatenate([[0.0], 2.0 * u[-1]]) - np.pad(u[-2], (0, 2)))
    for k in range(1, terms + 1):
        a_k = 2.0 / m * float(np.dot(delta, np.sin(2 * k * chi)))
        out[:k] += a_k * u[2 * k - 1][1::2]  # U_2k-1(x) / x in powers of x^2
    return tuple(float(g) for g in out)


def sample_latitudes(m: int = 64) -> np.ndarray:
    """The ``m`` latitudes (rad) :func:`latitude_powers` samples at."""
    return np.pi * (np.arange(m) / m - 0.5)


@functools.lru_cache(maxsize=16)
def conformal_series(es: float) -> tuple[float, ...]:
    """The coefficients ``g_0..g_5`` of the geodetic latitude ``phi`` less the conformal
    one ``chi`` (:func:`latitude_powers`; 64 samples of
    :meth:`~gloffset.ellipsoid.Ellipsoid.geodetic`, exact to the sum's rounding, since
    ``a_2k`` falls as ``n^k``)."""
    if es == 0.0:
        return (0.0,) * _SERIES_TERMS
    chi = sample_latitudes()
    delta = np.radians(Ellipsoid(1.0, 1.0 - math.sqrt(1.0 - es)).geodetic(np.degrees(chi))) - chi
    return latitude_powers(chi, delta, _SERIES_TERMS)


def polar_glsl(crs, frame) -> GlslCentres | None:
    """The GLSL centres (``shaders/lib/grids/polar_stereographic.glsl``, its notes say
    what each constant is) of a polar stereographic ``crs`` over the pixel ``frame``
    ``(x0, y0, full_w, full_h, full_bounds)`` of a :class:`Projected`, or None for other
    CRSs: the same parameters as :func:`polar_inverse`, from pyproj's CRS."""
    pp = polar_params(crs)
    if pp is None:
        return None
    x0, y0, fw, fh, (xmin, ymin, xmax, ymax) = frame
    k = pp["unit"] / pp["scale"]
    dx, dy = (xmax - xmin) / fw, (ymax - ymin) / fh
    sg = -1.0 if pp["south"] else 1.0
    cl, sl = math.cos(pp["lon0"]), math.sin(pp["lon0"])
    plane = ((xmin - pp["fe"] + x0 * dx) * k, dx * k, (ymax - pp["fn"] - y0 * dy) * k, -dy * k)
    turn = (-2.0 * sl, -2.0 * sg * cl, 2.0 * cl, -2.0 * sg * sl)
    return GlslCentres(POLAR_GLSL, plane + turn + (sg,) + conformal_series(pp["es"]))
