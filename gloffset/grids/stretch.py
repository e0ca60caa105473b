"""Bounds of the stretch of a projection's inverse where its scale has no one smallest
value (:mod:`gloffset.grids.projected` has the polar and transverse ones): Lambert
azimuthal equal-area (LAEA Europe, EPSG:3035, :func:`azimuthal_lipschitz`), Lambert
conformal conic and Albers equal-area (:func:`conic_lipschitz`). ``Projected`` grids in
those CRSs take their bounds from them instead of every pixel centre, and the tile
pyramids of ``EuropeanETRS89_LAEAQuad`` decide their tiles with them (derivations:
docs/design.md, "gloffset.grids.projected")."""

from __future__ import annotations

import math

__all__ = ["inverse_lipschitz", "azimuthal_lipschitz", "conic_lipschitz", "eccentricity_squared"]


def inverse_lipschitz(crs, box) -> float | None:
    """An upper bound on the stretch of pyproj's inverse of ``crs`` over the box ``(xmin,
    ymin, xmax, ymax)`` (CRS units), radians of the unit sphere per CRS unit:
    :func:`azimuthal_lipschitz` or :func:`conic_lipschitz`; None for other CRSs."""
    lip = azimuthal_lipschitz(crs, box)
    return lip if lip is not None else conic_lipschitz(crs, box)


def eccentricity_squared(crs) -> float:
    """The first eccentricity squared ``f (2 - f)`` of the ellipsoid of ``crs`` (0 on a
    sphere)."""
    inv_f = crs.ellipsoid.inverse_flattening
    f = 1.0 / inv_f if inv_f else 0.0
    return f * (2.0 - f)


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


#: the normal-aspect conics whose stretch :func:`conic_lipschitz` bounds
_CONICS = {
    "Lambert Conic Conformal (1SP)": "lcc",
    "Lambert Conic Conformal (2SP)": "lcc",
    "Albers Equal Area": "aea",
}
#: the latitude band (degrees from a pole) where the conic bound is not used
_POLE_BAND = 1e-6


def conic_lipschitz(crs, box) -> float | None:
    """An upper bound on the stretch of pyproj's inverse of a Lambert conformal conic or
    Albers equal-area ``crs`` (EPSG:3978, 2154, 5070, 3577...: 1SP and 2SP, on the
    ellipsoid, either hemisphere) over the box ``(xmin, ymin, xmax, ymax)`` (CRS units),
    in radians of the unit sphere per CRS unit; None for other CRSs, or a box that an
    Albers inverse does not cover (beyond the images of the poles).

    Parallels are arcs of circles about the cone's apex, ``rho`` (the distance from it)
    a monotonic function of the latitude, and the scale along a parallel is ``k = |n|
    rho / (a m)`` (``n`` the cone constant, ``m = cos phi / sqrt(1 - e^2 sin^2 phi)``).
    From ``rho``'s formulas (EPSG Guidance Note 7-2, 1.3.1 and 1.3.8), ``d ln k / dphi =
    (1 - e^2) g / (cos phi (1 - e^2 sin^2 phi))`` with ``g = sin phi - n`` (conformal;
    the meridian scale is ``k``) or ``g = sin phi - n / k^2`` (equal area; the meridian
    scale is ``1 / k``). ``g < 0`` holds on a lower interval of latitudes (``n >= 0``:
    where ``g > 0``, ``k`` grows northwards, ``n / k^2`` falls and ``sin phi`` grows, so
    ``g`` stays positive; ``n < 0``: where ``g < 0``, ``k`` grows southwards and ``g =
    sin phi + |n| / k^2`` falls, so it stays negative), so ``k`` falls, then rises: over
    the box's latitudes (those of its nearest and farthest points from the apex) its
    least value is at ``g = 0`` (bisection) or an end, its largest at an end. The
    inverse's stretch from the plane to the ellipsoid is ``1 / min k`` (conformal) or
    ``max(1 / min k, max k)`` (equal area), from the ellipsoid to the unit sphere at most
    ``1 / (a (1 - e^2))``. A box that meets the ray from the apex away from the central
    meridian, where the inverse's longitudes jump (``lambda_0 +- pi / n``), has no bound.
    The apex and ``n`` come from pyproj's images of the 45th parallel (a circle's
    centre, its angle per longitude); the bound is rounded up by a relative 1e-7.
    """
    op = crs.coordinate_operation
    kind = None if op is None else _CONICS.get(op.method_name)
    if kind is None:
        return None
    params = {p.name: p.value for p in op.params}
    lon0 = params.get("Longitude of false origin", params.get("Longitude of natural origin"))
    if lon0 is None:
        return None
    from pyproj import Transformer

    fwd = Transformer.from_crs(crs.geodetic_crs, crs, always_xy=True)
    inv = Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True)
    unit = crs.axis_info[0].unit_conversion_factor or 1.0
    es = eccentricity_squared(crs)
    a = crs.ellipsoid.semi_major_metre
    apex, n, down = _cone(fwd, lon0, unit)
    if apex is None:
        return None
    # the box's nearest and farthest points from the apex (metres)
    x0, y0, x1, y1 = (v * unit for v in box)
    near = math.hypot(max(x0 - apex[0], 0.0, apex[0] - x1), max(y0 - apex[1], 0.0, apex[1] - y1))
    far = max(math.hypot(x - apex[0], y - apex[1]) for x in (x0, x1) for y in (y0, y1))

    def lat_at(r: float) -> float:
        """The latitude (radians) at distance ``r`` from the apex (pyproj's inverse)."""
        lon, lat = inv.transform((apex[0] + r * down[0]) / unit, (apex[1] + r * down[1]) / unit)
        return math.radians(lat) if math.isfinite(lat) and abs(lat) <= 90.0 else math.nan

    def scale(phi: float) -> float:
        """``k`` at latitude ``phi`` (radians)."""
        x, y = fwd.transform(lon0, math.degrees(phi))
        r = math.hypot(x * unit - apex[0], y * unit - apex[1])
        s = math.sin(phi)
        return abs(n) * r * math.sqrt(1.0 - es * s * s) / (a * math.cos(phi))

    if _ray_meets_box(apex, (-down[0], -down[1]), (x0, y0, x1, y1)):
        return None  # the inverse's longitudes jump across that ray (atan2's cut)
    lats = sorted((lat_at(near), lat_at(far)))
    if not all(math.isfinite(v) for v in lats):
        return None
    if kind == "aea":  # the box must lie between the images of the poles
        poles = [
            math.hypot(*(np_ * unit - c for np_, c in zip(fwd.transform(lon0, p), apex)))
            for p in (90.0, -90.0)
        ]
        if not min(poles) < near <= far < max(poles):
            return None
    edge = math.radians(90.0 - _POLE_BAND)
    lo, hi = max(lats[0], -edge), min(lats[1], edge)

    def g(phi: float) -> float:
        if kind == "lcc":
            return math.sin(phi) - n
        return math.sin(phi) - n / scale(phi) ** 2

    if g(lo) >= 0.0:
        low = lo
    elif g(hi) < 0.0:
        low = hi
    else:  # bisection to the last bit
        a_, b_ = lo, hi
        for _ in range(100):
            mid = 0.5 * (a_ + b_)
            if mid in (a_, b_):
                break
            if g(mid) < 0.0:
                a_ = mid
            else:
                b_ = mid
        low = b_
    kmin = min(scale(low), scale(lo), scale(hi)) if lo < hi else scale(lo)
    stretch = 1.0 / kmin
    if kind == "aea":
        stretch = max(stretch, scale(lo), scale(hi))
    return unit * stretch / (a * (1.0 - es)) * (1.0 + 1e-7)


def _ray_meets_box(p, u, box) -> bool:
    """Whether the ray from ``p`` along ``u`` meets the box ``(x0, y0, x1, y1)``
    (closed; slabs), or passes within a relative 1e-9 of it."""
    x0, y0, x1, y1 = box
    pad_ = 1e-9 * max(x1 - x0, y1 - y0, abs(p[0]), abs(p[1]))
    lo, hi = 0.0, math.inf
    for o, d, a, b in ((p[0], u[0], x0 - pad_, x1 + pad_), (p[1], u[1], y0 - pad_, y1 + pad_)):
        if abs(d) < 1e-300:
            if not a <= o <= b:
                return False
            continue
        t0, t1 = sorted(((a - o) / d, (b - o) / d))
        lo, hi = max(lo, t0), min(hi, t1)
    return lo <= hi


def _cone(fwd, lon0: float, unit: float):
    """The apex (metres), the cone constant ``n`` and the unit vector from the apex along
    the central meridian, from the images of three points of the 45th parallel north (a
    fourth checks the circle); (None, 0, None) where they do not make one about an apex
    with ``|n| >= 0.01`` (a cone that is nearly a cylinder has no bound here)."""
    pts = [fwd.transform(lon0 + dl, 45.0) for dl in (-20.0, 0.0, 20.0, 10.0)]
    (bx, by) = (pts[1][0] * unit, pts[1][1] * unit)
    # relative to the middle point, for the roundings
    (ax, ay), (cx, cy), (qx, qy) = ((x * unit - bx, y * unit - by) for x, y in pts[::2] + pts[3:])
    d = 2.0 * (ax * cy - cx * ay)
    if not (math.isfinite(d) and abs(d) > 0.0):
        return None, 0.0, None
    a2, c2 = ax * ax + ay * ay, cx * cx + cy * cy
    ux, uy = (a2 * cy - c2 * ay) / d, (c2 * ax - a2 * cx) / d
    r = math.hypot(ux, uy)
    t_a, t_c = math.atan2(ay - uy, ax - ux), math.atan2(cy - uy, cx - ux)
    n = math.remainder(t_c - t_a, 2.0 * math.pi) / math.radians(40.0)
    on_circle = abs(math.hypot(qx - ux, qy - uy) - r) <= 1e-9 * r
    if not (math.isfinite(r) and on_circle and abs(n) >= 0.01):
        return None, 0.0, None
    return (bx + ux, by + uy), n, (-ux / r, -uy / r)
