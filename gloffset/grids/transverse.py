"""Transverse Mercator projections (UTM zones, national grids: EPSG:326xx, 327xx,
27700, 2193...) as :class:`~gloffset.grids.Projected` grids' GLSL function uses them
(``shaders/lib/grids/transverse_mercator.glsl``, on the ellipsoid): pyproj's parameters
and Krueger's series of PROJ's inverse, read from pyproj itself.

PROJ's inverse (Poder/Engsager): ``zeta = xi + i eta``, the northing and easting over
``k0 A`` (``A`` the rectifying radius, the origin's rectifying latitude added), then
``zeta' = zeta + sum b_k sin(2k zeta)`` (complex), the conformal sphere's point from
``zeta'`` (Gauss-Schreiber), and the geodetic latitude from the conformal one. On the
central meridian ``eta = 0`` and ``xi' = chi`` (the conformal latitude): the ``b_k`` are
the sine series of ``chi - xi`` there, read from pyproj's inverse at 64 points of it;
the function stands for pyproj's centres to the roundings (2e-15 rad measured).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ..ellipsoid import Ellipsoid
from .polar import latitude_powers, sample_latitudes
from .protocol import GlslCentres

__all__ = ["tm_params", "tm_clear", "tm_glsl", "TM_GLSL"]

#: The GLSL function of transverse Mercator grids' centres, and the terms of its series
#: (Krueger's ``b_k`` and the latitude's: the sixth of each is below 1e-16 on WGS84)
TM_GLSL, _TERMS = "lib/grids/transverse_mercator.glsl", 5
#: The range of ``|xi|`` and ``|eta|`` where the function's exp, sin and cos hold
#: (``shaders/lib/fp64.glsl``) with room for the series' change
_XI_MAX, _ETA_MAX = 1.9, 0.95


def _sine_series(x: np.ndarray, delta: np.ndarray, terms: int) -> tuple[float, ...]:
    """The coefficients ``a_1..a_terms`` of ``delta = sum a_k sin(2k x)`` from samples at
    :func:`~gloffset.grids.polar.sample_latitudes` (a discrete sine transform)."""
    m = len(x)
    return tuple(2.0 / m * float(np.dot(delta, np.sin(2 * k * x))) for k in range(1, terms + 1))


def tm_params(crs) -> dict | None:
    """What the transverse Mercator inverse needs from ``crs``, or None for other CRSs:
    ``lon0`` (rad), ``fe``, ``fn``, ``unit``, ``scale`` (metres of ``xi`` and ``eta``:
    ``k0 A``), ``mu0`` (the origin's rectifying latitude, from pyproj's northing of the
    equator on the central meridian) and ``f`` (the flattening)."""
    op = crs.coordinate_operation
    if op is None or op.method_name != "Transverse Mercator":
        return None
    params = {p.name: p.value for p in op.params}
    a = crs.ellipsoid.semi_major_metre
    inv_f = crs.ellipsoid.inverse_flattening
    f = 1.0 / inv_f if inv_f else 0.0
    n = f / (2.0 - f)
    k0 = float(params.get("Scale factor at natural origin", 1.0))
    # A / a (Helmert's series; the next term, n^8 / 16384, is below 1e-22)
    scale = a * k0 / (1.0 + n) * (1.0 + n * n * (0.25 + n * n * (1.0 / 64 + n * n / 256)))
    unit = crs.axis_info[0].unit_conversion_factor or 1.0
    fe, fn = params.get("False easting", 0.0), params.get("False northing", 0.0)
    lon0 = math.radians(params.get("Longitude of natural origin", 0.0))
    pp = {"lon0": lon0, "fe": fe, "fn": fn, "unit": unit, "scale": scale, "f": f}
    pp["mu0"] = _origin(crs.to_wkt(), lon0, fn, unit, scale)
    return pp


@functools.lru_cache(maxsize=64)
def _origin(wkt: str, lon0: float, fn: float, unit: float, scale: float) -> float:
    """The origin's rectifying latitude: ``-(y - fn) unit / scale`` at pyproj's northing
    ``y`` of the equator on the central meridian."""
    import pyproj

    crs = pyproj.CRS.from_wkt(wkt)
    fwd = pyproj.Transformer.from_crs(crs.geodetic_crs, crs, always_xy=True)
    _, y_eq = fwd.transform(math.degrees(lon0), 0.0, errcheck=True)
    return -(float(y_eq) - fn) * unit / scale


@functools.lru_cache(maxsize=16)
def _series(wkt: str) -> tuple[float, ...]:
    """Krueger's ``b_1..b_5`` of pyproj's inverse of the CRS ``wkt`` and the latitude's
    ``g_0..g_4`` (:func:`~gloffset.grids.polar.latitude_powers`): 0 on a sphere."""
    import pyproj

    crs = pyproj.CRS.from_wkt(wkt)
    pp = tm_params(crs)
    assert pp is not None  # a transverse Mercator CRS's
    if pp["f"] == 0.0:
        return (0.0,) * (2 * _TERMS)
    mu = sample_latitudes()
    y = pp["fn"] + (mu[1:] - pp["mu0"]) * pp["scale"] / pp["unit"]
    inv = pyproj.Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True)
    _, lat = inv.transform(np.full_like(y, pp["fe"]), y, errcheck=True)
    ell = Ellipsoid(1.0, pp["f"])
    chi = np.radians(ell.conformal(np.asarray(lat, dtype=np.float64)))
    b = _sine_series(mu, np.concatenate([[0.0], chi - mu[1:]]), _TERMS)
    delta = np.radians(ell.geodetic(np.degrees(mu))) - mu
    return b + latitude_powers(mu, delta, _TERMS)


def _plane(pp: dict, box) -> tuple[float, float, float, float]:
    """``(xi_min, xi_max, eta_min, eta_max)`` over the box (CRS units)."""
    k = pp["unit"] / pp["scale"]
    xi = sorted(((box[1] - pp["fn"]) * k + pp["mu0"], (box[3] - pp["fn"]) * k + pp["mu0"]))
    eta = sorted(((box[0] - pp["fe"]) * k, (box[2] - pp["fe"]) * k))
    return (xi[0], xi[1], eta[0], eta[1])


def tm_clear(crs, box) -> bool:
    """Whether the GLSL function stands for pyproj over the box ``(xmin, ymin, xmax,
    ymax)`` (CRS units: a grid's cell centres, every level): an ellipsoid's CRS (PROJ's
    spherical inverse, ``asin(sqrt(1 - cos^2 D) / cosh x)``, is off by 8e-10 rad at
    0.1 m from the equator (measured), and more nearer: a sphere's grids take the
    texture), ``|xi| <= 1.9`` and ``|eta| <= 0.95``."""
    pp = tm_params(crs)
    if pp is None or pp["f"] == 0.0:
        return False
    x0, x1, e0, e1 = _plane(pp, box)
    return max(-x0, x1) <= _XI_MAX and max(-e0, e1) <= _ETA_MAX


def tm_glsl(crs, frame) -> GlslCentres | None:
    """The GLSL centres (``shaders/lib/grids/transverse_mercator.glsl``, its notes say
    what each constant is) of a transverse Mercator ``crs`` over the pixel ``frame``
    ``(x0, y0, full_w, full_h, full_bounds)`` of a :class:`Projected`, or None for other
    CRSs."""
    pp = tm_params(crs)
    if pp is None:
        return None
    x0, y0, fw, fh, (xmin, ymin, xmax, ymax) = frame
    dx, dy = (xmax - xmin) / fw, (ymax - ymin) / fh
    k = pp["unit"] / pp["scale"]
    plane = (
        (ymax - pp["fn"] - y0 * dy) * k + pp["mu0"],
        -dy * k,
        (xmin - pp["fe"] + x0 * dx) * k,
        dx * k,
    )
    turn = (math.cos(pp["lon0"]), math.sin(pp["lon0"]))
    return GlslCentres(TM_GLSL, plane + turn + _series(crs.to_wkt()))
