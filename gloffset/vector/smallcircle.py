"""Small-circle arcs on the unit sphere: the maths of their intersections (paper Sec. 4.4).

A circle is the set ``{x : |x| = 1, x . a = h}`` for a unit *axis* ``a`` and a height
``h`` in [0, 1): ``h = 0`` is a great circle, and the circle of centre ``q`` (Eq. 1-4)
has ``a = q / |q|`` and ``h = |q|``. An arc starts at ``s``, turns about ``a`` by the
signed angle ``phi`` (positive counter-clockwise seen from outside the sphere along
``a``, i.e. the right-hand rule) and ends at ``e``; ``|phi| < pi``, as Eq. 1 needs.

Two circles meet where the line common to their planes meets the sphere (the
construction the paper gives for Algorithm 1); :func:`intersect` finds the same two
points from the angular radii and the angle between the axes (a haversine law),
which keeps small circles (radius ``|d|``) and nearly concentric ones accurate,
where the plane construction loses ``1e-16 / r`` to its heights ``cos r``.

Accuracy: the two points lie on both circles to a few 1e-16 rad. Along the circles
their position is as well conditioned as the problem: well apart from tangency the
error is a few 1e-16 divided by the sine of the crossing angle, and for tangent
circles (which part only quadratically) it grows to about ``sqrt(1e-15 r)``;
:func:`intersect` returns a bound with every point so that callers can treat
positions within it as equal.

:class:`CircleArcs` is the table of arcs (axes, heights, end points, turns) that the
methods of self-intersection removal work on, and :data:`MERGE_TOL` the distance below
which both take two points for one.
"""

from __future__ import annotations

import numpy as np

from ..geometry.caps import angle_of_chord, pad
from ..geometry.sphere import angle, normalize, robust_cross, rotate

__all__ = [
    "MERGE_TOL",
    "CircleArcs",
    "circle_of",
    "sweep",
    "position",
    "point_at",
    "tangent",
    "intersect",
]

#: Relative rounding of one float64 operation.
_EPS = 2.220446049250313e-16
#: Points closer than this (radians, 6.4 micrometres on the Earth) are one point: both
#: methods of Sec. 4.4 take an intersection this close to an arc's end for that end.
MERGE_TOL = 1e-12


def circle_of(centers) -> tuple[np.ndarray, np.ndarray]:
    """Axis ``a`` (unit) and height ``h = |q|`` of circles given by their centres ``q``.

    A zero centre (a great circle through nothing, the paper's d = 0 case) gets the
    axis 0 and must not be used.
    """
    q = np.asarray(centers, dtype=np.float64)
    h = np.linalg.norm(q, axis=-1)
    return normalize(q), h


def sweep(axis, h, start, end) -> np.ndarray:
    """Signed turn (radians, in (-pi, pi]) about ``axis`` from ``start`` to ``end``.

    Both points must lie on the circle ``x . axis = h``; the short way round is
    taken, as Eq. 1 (SLERP) does. Accurate to ``1e-16 / sqrt(1 - h^2)`` rad.
    """
    axis = np.asarray(axis, dtype=np.float64)
    h = np.asarray(h, dtype=np.float64)[..., None]
    u = np.asarray(start, dtype=np.float64) - h * axis
    v = np.asarray(end, dtype=np.float64) - h * axis
    return np.arctan2(np.sum(axis * np.cross(u, v), axis=-1), np.sum(u * v, axis=-1))


def position(axis, h, start, sign, x) -> np.ndarray:
    """Turn in [0, 2 pi) from ``start`` to ``x`` about ``axis``, in the direction ``sign``.

    ``sign`` is +1 (counter-clockwise about ``axis``) or -1. ``x`` should lie on the
    circle; only its direction about the axis matters.
    """
    t = sign * sweep(axis, h, start, x)
    return np.where(t < 0.0, t + 2.0 * np.pi, t)


def point_at(axis, start, turn) -> np.ndarray:
    """The point reached from ``start`` by turning ``turn`` radians about ``axis``.

    A rotation keeps the point on its circle to a few ulp.
    """
    return rotate(start, axis, turn)


def tangent(axis, sign, x) -> np.ndarray:
    """Unit direction of travel at ``x`` along a circle turning ``sign`` about ``axis``."""
    return np.asarray(sign, dtype=np.float64)[..., None] * normalize(np.cross(axis, x))


def intersect(a1, r1, a2, r2):
    """The points common to the circles ``(a1, r1)`` and ``(a2, r2)``, vectorised.

    Circles are given by unit axes and *angular* radii (radians), so that small
    circles keep their full accuracy (a height ``h = cos r`` alone fixes a circle of
    radius 1e-6 only to 1e-10).

    Returns
    -------
    x : (..., 2, 3) float64
        The two points (equal for tangent circles); meaningless where ``ok`` is False.
    ok : (...) bool
        Whether the circles meet.
    err : (...) float64
        A bound on the error of each point's position along the circles (radians).
    coincident : (...) bool
        Whether the two circles are the same (to 4e-15): they then share all points
        and ``ok`` is False.

    Notes
    -----
    In the triangle (``a1``, ``a2``, ``x``) the angle ``t`` at ``a1`` follows from the
    haversine law ``hav t = sin((r2 + r1 - g) / 2) sin((r2 - r1 + g) / 2) /
    (sin r1 sin g)`` with ``g`` the angle between the axes, and ``x`` is ``a1``
    turned by ``r1`` towards ``a2`` and then by ``+-t`` about ``a1``. Every factor
    is computed from angles, without cancellation.
    """
    a1 = np.asarray(a1, dtype=np.float64)
    a2 = np.asarray(a2, dtype=np.float64)
    r1 = np.asarray(r1, dtype=np.float64)
    r2 = np.asarray(r2, dtype=np.float64)
    # work from the smaller circle: the angle found there fixes the point best
    swap = r1 > r2
    a1, a2 = np.where(swap[..., None], a2, a1), np.where(swap[..., None], a1, a2)
    r1, r2 = np.where(swap, r2, r1), np.where(swap, r1, r2)
    w = robust_cross(a1, a2)
    wn = np.linalg.norm(w, axis=-1)
    cos_g = np.sum(a1 * a2, axis=-1)
    g = np.arctan2(0.5 * wn, cos_g)  # angle between the axes, accurate near 0 and pi
    flat = (g < 4.0 * _EPS) | (g > np.pi - 4.0 * _EPS)
    same_circle = np.where(cos_g > 0.0, np.abs(r1 - r2), np.abs(r1 + r2 - np.pi))
    coincident = flat & (same_circle < 16.0 * _EPS)
    e2 = w / np.where(flat, 1.0, wn)[..., None]
    e1 = np.cross(e2, a1)  # from a1 towards a2
    s1 = np.sin(r1)
    den = s1 * np.sin(np.where(flat, 1.0, g))
    num = np.sin(0.5 * (r2 + r1 - g)) * np.sin(0.5 * (r2 - r1 + g))
    hav = num / np.where(den > 0.0, den, 1.0)
    ok = (hav >= 0.0) & (hav <= 1.0) & ~flat & (den > 0.0)
    hc = np.clip(hav, 0.0, 1.0)
    ct = 1.0 - 2.0 * hc  # cos t
    st = 2.0 * np.sqrt(hc * (1.0 - hc))  # sin t
    base = np.cos(r1)[..., None] * a1 + (s1 * ct)[..., None] * e1
    side = (s1 * st)[..., None] * e2
    x = normalize(np.stack([base + side, base - side], axis=-2))
    # error: each sine argument carries ~8 eps absolute (rounding, and inputs that are
    # themselves rounded), which the other factor scales; t then moves by
    # 2 dhav / sin t, and at most by 4 sqrt(dhav) (tangent circles)
    sa = np.abs(np.sin(0.5 * (r2 + r1 - g)))
    sb = np.abs(np.sin(0.5 * (r2 - r1 + g)))
    dnum = 8.0 * _EPS * (sa + sb) + 4.0 * _EPS * np.abs(num)
    dhav = dnum / np.where(den > 0.0, den, _EPS) + 4.0 * _EPS * hc
    dt = np.minimum(2.0 * dhav / np.maximum(st, 1e-300), 4.0 * np.sqrt(dhav))
    err = 8.0 * _EPS + s1 * dt
    return x, ok, err, coincident


class CircleArcs:
    """A table of small-circle arcs: the vectorised form every step here works on.

    Attributes
    ----------
    axis : (n, 3) float64
        Unit axes.
    h : (n,) float64
        Heights, ``cos`` of the angular radius of each circle.
    start, end : (n, 3) float64
        End points.
    phi : (n,) float64
        Signed turn from ``start`` to ``end`` about ``axis``.
    rho : (n,) float64
        Angular radius of each circle, from its axis and start point (to 1e-16).
    """

    def __init__(self, axis, h, start, end, phi=None):
        self.axis = np.asarray(axis, dtype=np.float64)
        self.h = np.asarray(h, dtype=np.float64)
        self.start = np.asarray(start, dtype=np.float64)
        self.end = np.asarray(end, dtype=np.float64)
        self.phi = sweep(self.axis, self.h, self.start, self.end) if phi is None else phi
        self.rho = angle(self.axis, self.start)

    @classmethod
    def from_rings(cls, centers, junctions) -> CircleArcs:
        """Arcs of closed cycles given by centres Q and junctions R (arc k: R[k-1] -> R[k])."""
        axis, h = circle_of(centers)
        start = np.roll(junctions, 1, axis=0)
        return cls(axis, h, start, junctions)

    def __len__(self) -> int:
        return len(self.h)

    @property
    def sign(self) -> np.ndarray:
        """+1 for arcs turning counter-clockwise about their axis, else -1."""
        return np.where(self.phi >= 0.0, 1.0, -1.0)

    @property
    def sin_radius(self) -> np.ndarray:
        """Sine of each circle's angular radius: arc length is ``|phi| * sin_radius``."""
        return np.sin(self.rho)

    @property
    def length(self) -> np.ndarray:
        """Arc lengths (radians on the unit sphere)."""
        return np.abs(self.phi) * self.sin_radius

    def midpoint(self) -> np.ndarray:
        """The point half-way along each arc."""
        return point_at(self.axis, self.start, 0.5 * self.phi)

    def caps(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounding caps: centre (the midpoint) and angular radius, a few ulp generous.

        For ``|phi| < 2 pi`` the end points are the points of the arc farthest from
        its midpoint, so the cap is tight.
        """
        m = self.midpoint()
        ca = np.linalg.norm(m - self.start, axis=1)
        cb = np.linalg.norm(m - self.end, axis=1)
        return m, pad(angle_of_chord(np.maximum(ca, cb)))

    def subset(self, idx) -> CircleArcs:
        """The arcs ``idx`` (their turns kept, not recomputed)."""
        return CircleArcs(
            self.axis[idx], self.h[idx], self.start[idx], self.end[idx], self.phi[idx]
        )
