"""The ellipsoid of revolution: parameters, geodesic problems, and its conformal sphere.

An :class:`Ellipsoid` is given by its semi-major axis ``a`` (metres) and flattening
``f``; :func:`as_ellipsoid` reads the ``ellipsoid=`` option (``"WGS84"``, ``"GRS80"``,
``(a, f)`` or an :class:`Ellipsoid`). Latitudes on it are geodetic.

The direct and inverse geodesic problems are geographiclib's
(:attr:`Ellipsoid.geodesic`, Karney 2013); nothing here re-implements its series.

**The conformal sphere.** gloffset's spherical machinery runs on the unit sphere
whose points have the longitude of the ellipsoid's and the *conformal* latitude
``chi`` (:meth:`Ellipsoid.conformal`). The map is conformal, so the ellipsoid's
length element is isotropic there::

    ds = K(phi) dsigma,   K(phi) = N(phi) cos(phi) / cos(chi)
                                 = N(phi) (cosh t - sin(phi) sinh t),  t = e atanh(e sin phi)

with ``N = a / sqrt(1 - e^2 sin^2 phi)`` the prime-vertical radius and ``dsigma`` the
unit sphere's length element (the second form, from ``cosh psi = cosh(psi_g - t)`` with
the Mercator ordinates ``psi = psi_g - t``, ``cos(phi) cosh(psi_g) = 1``, has no 0/0 at
the poles). ``K`` (metres per radian, :meth:`Ellipsoid.scale`) decreases monotonically
from ``a`` at the equator to ``K_pole = a / sqrt(1 - e^2) ((1 - e) / (1 + e))^(e / 2)``
at the poles (checked on a dense grid when an ellipsoid is made; 0.34 % less than
``a`` for WGS84). :mod:`gloffset.ellipsoid.bounds` turns this into the distance bounds.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InvalidEllipsoidError
from ..geometry.sphere import lonlat_to_xyz

__all__ = ["ELLIPSOIDS", "MAX_FLATTENING", "Ellipsoid", "as_ellipsoid"]

#: Named ellipsoids: semi-major axis (m) and flattening.
ELLIPSOIDS = {
    "WGS84": (6378137.0, 1 / 298.257223563),
    "GRS80": (6378137.0, 1 / 298.257222100882711),
}
#: Largest flattening accepted (the bounds of :mod:`.bounds` are checked up to it; the
#: Earth's is 1/298).
MAX_FLATTENING = 1 / 50
#: Points of the grid on which the monotony of ``K`` and the curvature bound are found.
_GRID = 1 << 14


@dataclass(frozen=True)
class Ellipsoid:
    """An oblate ellipsoid of revolution (or the sphere, ``f = 0``).

    Parameters
    ----------
    a : float
        Semi-major (equatorial) axis in metres.
    f : float
        Flattening ``(a - b) / a``, in [0, :data:`MAX_FLATTENING`].
    name : str
        A label (``"WGS84"``) for messages and ``repr``.

    Attributes
    ----------
    k_max, k_min : float
        The largest (``a``, on the equator) and smallest (at the poles) scale ``K``
        of the conformal sphere, metres per radian.
    kappa : float
        A bound on ``|d ln K / d chi|``: the geodesic curvature of the image of any
        geodesic on the conformal sphere (:mod:`.bounds`).
    """

    a: float
    f: float
    name: str = ""
    k_max: float = field(init=False, repr=False, compare=False)
    k_min: float = field(init=False, repr=False, compare=False)
    kappa: float = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        try:
            a, f = float(self.a), float(self.f)
        except (TypeError, ValueError):
            raise InvalidEllipsoidError(
                f"ellipsoid (a, f) must be two numbers, got ({self.a!r}, {self.f!r})"
            ) from None
        if not (math.isfinite(a) and a > 0.0):
            raise InvalidEllipsoidError(
                f"ellipsoid semi-major axis a must be a positive finite number of metres, got {a!r}"
            )
        if not (math.isfinite(f) and 0.0 <= f <= MAX_FLATTENING):
            raise InvalidEllipsoidError(
                f"ellipsoid flattening f must be in [0, 1/50] (oblate, Earth-like), got {f!r}"
            )
        object.__setattr__(self, "a", a)
        object.__setattr__(self, "f", f)
        phi = np.linspace(0.0, 0.5 * np.pi, _GRID)
        k = self.scale(phi)
        if np.any(np.diff(k) > 1e-9 * a):  # pragma: no cover  (holds for f in [0, 1/50])
            raise InvalidEllipsoidError(f"the conformal scale of {self} is not monotonic")
        object.__setattr__(self, "k_max", a)
        object.__setattr__(self, "k_min", float(self.scale(0.5 * np.pi)))
        slope = np.abs(self._log_scale_slope(phi)).max()
        # the grid's maximum is within h^2/8 max|f''| of the true one: a relative 1e-3
        # (and 1e-12 absolute) covers that by orders of magnitude
        object.__setattr__(self, "kappa", float(slope * (1.0 + 1e-3) + 1e-12))

    # ------------------------------------------------------------------ parameters
    @property
    def e2(self) -> float:
        """First eccentricity squared ``f (2 - f)``."""
        return self.f * (2.0 - self.f)

    @property
    def b(self) -> float:
        """Semi-minor (polar) axis ``a (1 - f)`` in metres."""
        return self.a * (1.0 - self.f)

    @property
    def geodesic(self):
        """Geographiclib's :class:`~geographiclib.geodesic.Geodesic` for this ellipsoid."""
        from geographiclib.geodesic import Geodesic

        g = self.__dict__.get("_geodesic")
        if g is None:
            g = Geodesic(self.a, self.f)
            object.__setattr__(self, "_geodesic", g)
        return g

    # ------------------------------------------------------------------ the conformal sphere
    def conformal(self, lat):
        """Conformal latitude (degrees) of geodetic latitudes ``lat`` (degrees).

        ``tan chi = tan(phi) sqrt(1 + s^2) - s sqrt(1 + tan^2 phi)``, ``s = sinh(e
        atanh(e sin phi))`` (Karney 2011, Eq. 7-9), accurate to a few ulp; the poles
        and the equator map to themselves exactly.
        """
        lat = np.asarray(lat, dtype=np.float64)
        e = math.sqrt(self.e2)
        phi = np.radians(lat)
        tau = np.tan(phi)
        s = np.sinh(e * np.arctanh(e * np.sin(phi)))
        taup = tau * np.sqrt(1.0 + s * s) - s * np.sqrt(1.0 + tau * tau)
        chi = np.degrees(np.arctan(taup))
        return np.where(np.abs(lat) >= 90.0, lat, chi)

    def geodetic(self, chi):
        """Geodetic latitude (degrees) of conformal latitudes ``chi`` (degrees).

        Newton's method on ``tan phi`` (Karney 2011, Eq. 19-20), to a few ulp.
        """
        chi = np.asarray(chi, dtype=np.float64)
        e2 = self.e2
        e = math.sqrt(e2)
        taup = np.tan(np.radians(np.clip(chi, -89.999999999, 89.999999999)))
        tau = taup / (1.0 - e2)
        for _ in range(6):
            s = np.sinh(e * np.arctanh(e * tau / np.sqrt(1.0 + tau * tau)))
            t1 = np.sqrt(1.0 + tau * tau)
            tp = tau * np.sqrt(1.0 + s * s) - s * t1
            dtau = (
                (taup - tp)
                / np.sqrt(1.0 + tp * tp)
                * (1.0 + (1.0 - e2) * tau * tau)
                / ((1.0 - e2) * t1)
            )
            tau = tau + dtau
        lat = np.degrees(np.arctan(tau))
        return np.where(np.abs(chi) >= 90.0, chi, lat)

    def to_sphere(self, lon, lat) -> np.ndarray:
        """Return unit vectors on the conformal sphere of geodetic ``lon, lat`` (degrees)."""
        return lonlat_to_xyz(lon, self.conformal(lat))

    def scale(self, phi):
        """Return the scale ``K(phi)`` at geodetic latitudes ``phi`` (radians).

        Metres of the ellipsoid per radian of the conformal sphere. Relative error a few
        ulp.
        """
        s = np.sin(np.asarray(phi, dtype=np.float64))
        e2 = self.e2
        e = math.sqrt(e2)
        t = e * np.arctanh(e * s)
        n = self.a / np.sqrt(1.0 - e2 * s * s)
        return n * (np.cosh(t) - s * np.sinh(t))

    def _log_scale_slope(self, phi):
        """``d ln K / d chi`` at geodetic latitudes ``phi`` (radians), in closed form.

        ``(dlnN/dphi + g'/g) K / M`` with ``g = cosh t - sin(phi) sinh t`` and ``dchi/dphi
        = M / K``.
        """
        s, c = np.sin(phi), np.cos(phi)
        e2 = self.e2
        e = math.sqrt(e2)
        w = 1.0 - e2 * s * s
        t = e * np.arctanh(e * s)
        dt = e2 * c / w
        g = np.cosh(t) - s * np.sinh(t)
        dg = dt * (np.sinh(t) - s * np.cosh(t)) - c * np.sinh(t)
        m = self.a * (1.0 - e2) / w**1.5
        return (e2 * s * c / w + dg / g) * self.scale(phi) / m

    def __str__(self) -> str:
        return self.name or f"ellipsoid(a={self.a!r}, f={self.f!r})"


@functools.cache
def _named(key: str) -> Ellipsoid:
    """Return the named ellipsoids, made once."""
    a, f = ELLIPSOIDS[key]
    return Ellipsoid(a, f, key)


def as_ellipsoid(spec) -> Ellipsoid | None:
    """Read an ``ellipsoid=`` option.

    ``None`` (the sphere of ``radius``), a name among :data:`ELLIPSOIDS` (any case), an
    ``(a, f)`` pair or an :class:`Ellipsoid`.

    Raises :class:`~gloffset.InvalidEllipsoidError` for anything else.
    """
    if spec is None or isinstance(spec, Ellipsoid):
        return spec
    if isinstance(spec, str):
        key = spec.strip().upper().replace("-", "").replace(" ", "")
        if key in ELLIPSOIDS:
            return _named(key)
        raise InvalidEllipsoidError(
            f"unknown ellipsoid {spec!r}; use one of {', '.join(ELLIPSOIDS)} or an (a, f) pair"
        )
    try:
        a, f = spec
    except (TypeError, ValueError):
        raise InvalidEllipsoidError(
            f"ellipsoid must be a name ({', '.join(ELLIPSOIDS)}), an (a, f) pair or an "
            f"Ellipsoid, got {spec!r}"
        ) from None
    return Ellipsoid(a, f)
