"""A bound of the stretch of Lambert azimuthal equal-area's inverse (LAEA Europe,
EPSG:3035): :func:`azimuthal_lipschitz`, what the tile pyramids of a LAEA TileMatrixSet
(``EuropeanETRS89_LAEAQuad``) decide their tiles with (derivation: docs/design.md,
"gloffset.grids.projected")."""

from __future__ import annotations

import math

from .projected import eccentricity_squared

__all__ = ["azimuthal_lipschitz"]

#: Lambert azimuthal equal-area: the formula bound is used over boxes whose farthest point
#: lies at most this far (a chord of the authalic unit sphere, 2 at the antipode) from the
#: projection's centre, where the inverse's stretch is at most 1 / sqrt(1 - 0.95^2) = 3.2
_LAEA_REACH = 1.9


def azimuthal_lipschitz(crs, box) -> float | None:
    """An upper bound on the stretch of pyproj's inverse of a Lambert azimuthal equal-area
    ``crs`` (LAEA Europe, EPSG:3035; any aspect, on the ellipsoid) over the box ``(xmin,
    ymin, xmax, ymax)`` (CRS units): radians of the unit sphere (lon and geodetic lat
    read as a point of it) per CRS unit; None for other CRSs or a box reaching past
    :data:`_LAEA_REACH`.

    PROJ's ellipsoidal LAEA (Snyder 1987, eq. 24-12 to 24-16) is the spherical one on
    the authalic unit sphere, ``(u, v)``, scaled: ``x - x_0 = a R_q D u``, ``y - y_0 = a
    (R_q / D) v`` (``R_q^2 = q_p / 2``, ``D = cos phi_0 / (sqrt(1 - e^2 sin^2 phi_0) R_q
    cos beta_0)``, 1 for a polar aspect). The inverse is the composition of

    * the scaling back: stretch ``max(D, 1 / D) / (a R_q)``;
    * the spherical LAEA's inverse: its forward scales are ``cos(c / 2)`` (radial) and
      ``1 / cos(c / 2)``, ``c`` the angle from the centre and ``r = |(u, v)| = 2 sin(c /
      2)``, so its stretch is ``1 / sqrt(1 - r^2 / 4)``, largest at the box's farthest
      corner (the box is a box in ``(u, v)``; a segment of it stays in it);
    * the authalic latitude ``beta`` to the geodetic ``phi`` at the same longitude:
      stretch ``max(dphi / dbeta, cos phi / cos beta)``, at most ``q_p / (2 (1 - e^2))``
      (``dphi / dbeta`` at the equator, where it is largest; ``|beta| <= |phi|``: both
      checked over every latitude by the tests).

    Rounded up by a relative 1e-9.
    """
    op = crs.coordinate_operation
    es = eccentricity_squared(crs)
    spherical = op is not None and op.method_name == "Lambert Azimuthal Equal Area (Spherical)"
    if op is None or not (op.method_name == "Lambert Azimuthal Equal Area" or spherical):
        return None
    if spherical and es != 0.0:  # the spherical formulas on an ellipsoid's numbers
        return None
    params = {p.name: p.value for p in op.params}
    phi0 = math.radians(params.get("Latitude of natural origin", 0.0))
    fe = params.get("False easting", 0.0)
    fn = params.get("False northing", 0.0)
    qp = _authalic_q(1.0, es)
    rq = math.sqrt(0.5 * qp)
    if abs(abs(phi0) - math.pi / 2) < 1e-12:
        dd = 1.0
    else:
        s0 = math.sin(phi0)
        sb0 = _authalic_q(s0, es) / qp
        dd = math.cos(phi0) / (math.sqrt(1.0 - es * s0 * s0) * rq * math.sqrt(1.0 - sb0 * sb0))
    a = crs.ellipsoid.semi_major_metre
    unit = crs.axis_info[0].unit_conversion_factor or 1.0
    r = max(
        math.hypot((x - fe) * unit / (a * rq * dd), (y - fn) * unit * dd / (a * rq))
        for x in (box[0], box[2])
        for y in (box[1], box[3])
    )
    if not r <= _LAEA_REACH:
        return None
    authalic = qp / (2.0 * (1.0 - es)) if es > 0.0 else 1.0
    stretch = authalic * max(dd, 1.0 / dd) / (a * rq * math.sqrt(1.0 - 0.25 * r * r))
    return unit * stretch * (1.0 + 1e-9)


def _authalic_q(s: float, es: float) -> float:
    """Snyder's ``q`` (eq. 3-12) at ``sin phi = s``: ``sin beta = q / q_p``; ``2 s`` on
    the sphere."""
    if es == 0.0:
        return 2.0 * s
    e = math.sqrt(es)
    return (1.0 - es) * (s / (1.0 - es * s * s) - math.log((1.0 - e * s) / (1.0 + e * s)) / (2 * e))
