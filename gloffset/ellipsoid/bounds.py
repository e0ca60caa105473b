"""Rigorous bounds between geodesic distances on the ellipsoid and great-circle distances
on its conformal sphere (:mod:`.model`), each written once with its derivation.

**Ratio bound.** On the conformal sphere the ellipsoid's metric is ``ds = K dsigma``
with ``K`` depending on the latitude only, decreasing in ``|chi|``. For any curve
``c`` that stays in a latitude window ``W``, its ellipsoidal length and its length on
the unit sphere satisfy ``K_min(W) len_s(c) <= len_e(c) <= K_max(W) len_s(c)``.

With the whole sphere as window the ratio ``k_max / k_min`` is 1.0034 for WGS84
(against 1.0101 for the geodetic latitude, whose metric ``M^2 dphi^2 + N^2 cos^2 phi
dlambda^2`` is not isotropic); for a window of +-0.001 rad (6 km) it is below 1 + 7e-6.

**Edges.** The edges of a shape are geodesics on the ellipsoid; their images on the
conformal sphere are not great circles, but every point of one lies within
:func:`edge_deviation` of the great-circle arc between its ends, and every point of
the arc that close to the image: 1.3 cm for a 10 km WGS84 edge, 1.3 m for 100 km,
133 m for 1000 km. The derivation in full: ``docs/design.md``, *Module notes*.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "edge_deviation",
    "window_scale",
    "upper_distance",
    "lower_distance",
    "REL_SLACK",
    "ABS_SLACK",
]

#: Relative slack on every bound here (far above the few-ulp rounding of K, the
#: conformal latitude and the spherical distances).
REL_SLACK = 1e-11
#: Absolute slack (radians) on the spherical distances handed in: those of
#: :mod:`gloffset.geometry.sphere` are good to 1e-15 rad, and the conformal sphere's unit
#: vectors to a few ulp.
ABS_SLACK = 1e-14


def window_scale(ell, chi, r) -> tuple[np.ndarray, np.ndarray]:
    """``(K_min, K_max)`` over the latitude windows ``chi +- r`` (radians, conformal)
    of the ellipsoid ``ell``, rounded outward.

    ``K`` decreases in ``|chi|`` (:mod:`.model`), so its extremes over a window are
    at the window's smallest and largest ``|chi|``.
    """
    chi = np.abs(np.asarray(chi, dtype=np.float64))
    r = np.asarray(r, dtype=np.float64) * (1.0 + REL_SLACK) + 1e-14
    lo = np.maximum(chi - r, 0.0)
    hi = np.minimum(chi + r, 0.5 * np.pi)
    phi_lo = np.radians(ell.geodetic(np.degrees(lo)))
    phi_hi = np.radians(ell.geodetic(np.degrees(hi)))
    k_max = np.minimum(ell.scale(phi_lo) * (1.0 + REL_SLACK), ell.k_max * (1.0 + REL_SLACK))
    k_min = np.maximum(ell.scale(phi_hi) * (1.0 - REL_SLACK), ell.k_min * (1.0 - REL_SLACK))
    return k_min, k_max


def upper_distance(ell, chi, theta) -> np.ndarray:
    """An upper bound (metres) on the ellipsoidal distance from a point at conformal
    latitude ``chi`` (rad) to a set whose image is ``theta`` (rad) away on the conformal
    sphere (``theta`` already an upper bound, e.g. plus :func:`edge_deviation`)."""
    theta = np.asarray(theta, dtype=np.float64) + ABS_SLACK
    _, k_max = window_scale(ell, chi, theta)
    return k_max * theta


def lower_distance(ell, chi, theta, reach) -> np.ndarray:
    """A lower bound (metres) on the ellipsoidal distance from a point at conformal
    latitude ``chi`` to a set ``theta`` (rad, already a lower bound) away on the conformal
    sphere, valid whenever that distance is at most ``reach`` metres; a result above
    ``reach`` proves the distance is above ``reach``."""
    r = np.asarray(reach, dtype=np.float64) / (ell.k_min * (1.0 - REL_SLACK))
    k_min, _ = window_scale(ell, chi, r)
    return k_min * np.maximum(np.asarray(theta, dtype=np.float64) - ABS_SLACK, 0.0)


def edge_deviation(ell, theta) -> np.ndarray:
    """A bound (radians) on the Hausdorff distance between the image on the conformal
    sphere of a geodesic edge and the great-circle arc joining its ends, ``theta``
    (rad) apart; ``pi`` where the bound does not apply (image length ``>= pi``)."""
    theta = np.asarray(theta, dtype=np.float64)
    length = theta * (ell.k_max / ell.k_min) * (1.0 + REL_SLACK)
    ok = length < 0.99 * np.pi
    half = 0.5 * np.where(ok, length, 0.0)
    # sec(L/2) - 1 = 2 sin^2(L/4) / cos(L/2), without cancellation for small L
    z = ell.kappa * 2.0 * np.sin(0.5 * half) ** 2 / np.cos(half)
    h = 2.0 * np.arcsin(np.minimum(z, 1.0)) * (1.0 + REL_SLACK) + 1e-15 * (ell.f > 0.0)
    return np.where(ok, h, np.pi)
