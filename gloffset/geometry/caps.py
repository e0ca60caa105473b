"""Spherical bounds, each written once: rounding up, bounding caps, chords, cap tests.

Every path of gloffset (the raster planner, the GL engine, scatter, tiles, the inside
index, the vector offsets) decides "can this arc matter here?" with the same few
bounds. They live here, beside :mod:`gloffset.geometry.sphere`, with their error bounds, so
that a slack is chosen once and every caller inherits it. Each function rounds the
way its docstring says (up, or toward "maybe"), never the other way: a bound that
is too generous costs a little work, one that is too tight loses a pixel.

:mod:`gloffset.reference` keeps its own copies on purpose: the judge shares no code
with what it judges.

Accuracy notes use these facts: numpy's ``sin``, ``cos``, ``arcsin`` and ``arccos``
are within 1 ulp of the exact value of their (rounded) argument; a dot product of
unit vectors is within 3e-16 of its exact value; :func:`gloffset.geometry.sphere.angle` is
within 1e-15 rad of the exact angle.
"""

from __future__ import annotations

import numpy as np

from .sphere import angle, dot, normalize

__all__ = [
    "REL_PAD",
    "ABS_PAD",
    "CAP_SLACK",
    "COS_SLACK",
    "pad",
    "arc_cap",
    "chord",
    "chord2",
    "angle_of_chord",
    "cap_range",
    "cap_within",
    "cap_within_pairs",
    "cap_bounds",
    "decide_between",
    "cos_sum_lower",
]

#: Relative and absolute (radians) padding of :func:`pad`, the default rounding up.
REL_PAD, ABS_PAD = 1e-12, 1e-15

#: Slack on angles from arc caps: ``arccos(c.m)`` is good to 1e-7 rad (3e-16 on ``c.m``
#: near 1), so a bound from it is widened by twice that.
CAP_SLACK = 2e-7

#: Slack on a cosine compared with a dot product of unit vectors (:func:`cap_within`).
COS_SLACK = 1e-12


def pad(x, rel: float = REL_PAD, abs_: float = ABS_PAD):
    """``x (1 + rel) + abs_``: a non-negative angle (or chord) rounded up.

    Error bound: the result is at least the exact value whenever ``x`` was computed
    with relative error below ``rel`` (less 2 ulp for the two roundings here) or
    absolute error below ``abs_``. With the defaults that covers every angle and
    chord in gloffset (a few ulp of error, 1e-15 rad absolute), by a factor of about
    1e3. Callers that add errors of their own pass a larger ``abs_`` (1e-12 for
    component caps, 1e-9 where the radius comes from a sum of several angles, the
    cap tree's 1e-14) or ``rel`` (1e-9 for the reach of an arcsin); they are kept
    per caller so that no decision moves.
    """
    return x * (1.0 + rel) + abs_


def arc_cap(a, b) -> tuple[np.ndarray, np.ndarray]:
    """The bounding cap ``(mid, half)`` of the short great-circle arcs ``a -> b``, unpadded.

    ``mid = normalize(a + b)`` (``a`` where ``|a + b|^2 <= 1e-300``, i.e. for antipodal
    ends, which input validation rejects), ``half = angle(a, b) / 2``. The arc's end
    points are its farthest points from ``mid``, so the cap is the smallest one.

    Error bound: ``half`` is within 1e-15 rad of the exact half-length
    (:func:`gloffset.geometry.sphere.angle`) and ``mid`` within 2e-16 rad of the exact
    midpoint, so every point of the arc lies within ``half + 2e-15`` of ``mid``:
    :func:`pad` with its defaults (or more) makes it a rigorous bound. Callers that
    hand the cap to :class:`gloffset.geometry.captree.CapTree` leave it unpadded, the tree
    pads every radius itself.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    s = a + b
    mid = np.where(dot(s, s)[..., None] > 1e-300, normalize(s), a)
    return mid, 0.5 * angle(a, b)


def chord(x):
    """Chord ``2 sin(x / 2)`` of angles ``x`` in [0, pi] (clamped to pi above).

    Error bound: relative error below 2 ulp (``sin`` is within 1 ulp, halving and
    doubling are exact), so ``pad(chord(x))`` is at least the
    exact chord and ``chord(x) * (1 - 1e-12)`` at most. Chords keep their relative
    accuracy for tiny angles, where ``cos`` of the angle loses everything below 1e-8.
    """
    return 2.0 * np.sin(0.5 * np.minimum(x, np.pi))


def chord2(x):
    """Squared chord ``4 sin^2(x / 2) = |p - q|^2`` for points ``x`` apart, ``x`` in
    [0, pi] (clamped to pi above).

    Error bound: relative error below 4 ulp (``sin`` 1 ulp, doubled by the square,
    plus the product's rounding), so ``chord2(x) * (1 + 1e-12)`` is at least the exact
    value. Compare it with ``|p - q|^2`` of float64 unit vectors, never ``acos`` of a
    dot product.
    """
    return 4.0 * np.sin(0.5 * np.minimum(x, np.pi)) ** 2


def angle_of_chord(c):
    """Angle ``2 asin(c / 2)`` of chords ``c`` (clamped to the diameter 2 above).

    Error bound: relative error of a few ulp for chords up to about ``sqrt 2``
    (angles up to pi/2); toward the diameter ``asin`` is ill-conditioned and an error
    of 1 ulp in ``c`` grows to about 4e-8 rad at ``c = 2``. Callers pad the result
    (:func:`pad`) when they need a bound and their angles are far from pi.
    """
    return 2.0 * np.arcsin(np.minimum(0.5 * c, 1.0))


def cap_range(cm, half) -> tuple[np.ndarray, np.ndarray]:
    """``(t - half, t + half)`` with ``t = arccos(c.m)``: bounds on the distance from a
    point ``c`` to an arc with bounding cap (centre ``m``, radius ``half``), given ``cm =
    c.m``.

    Error bound: each is good to :data:`CAP_SLACK` / 2 (``arccos`` near 1 turns the
    3e-16 error of ``c.m`` into up to 3e-8 rad); widen by :data:`CAP_SLACK` where a
    rigorous bound is needed.
    """
    t = np.arccos(np.clip(cm, -1.0, 1.0))
    return t - half, t + half


def cap_within(cm, reach) -> np.ndarray:
    """The cap test: whether a cap (centre ``m``, radius ``half``) can come within
    ``reach - half`` of a point ``c``, given ``cm = c.m`` and ``reach`` (a distance plus
    the cap's radius): ``c.m >= cos(min(reach, pi)) - COS_SLACK``.

    Error bound: ``cos`` is within 1 ulp and ``c.m`` within 3e-16 of exact values, far
    below :data:`COS_SLACK` (1e-12), so the test is never false where it should hold.
    In angles the slack is ``1e-12 / sin(reach)``, at least 1e-12 rad, and about
    1.4e-6 rad for reaches near 0 or pi: a few extra candidates, never a missing one.
    """
    return cm >= cap_threshold(reach)


def cap_threshold(reach) -> np.ndarray:
    """The threshold of :func:`cap_within`, ``cos(min(reach, pi)) - COS_SLACK``: computed
    once per cap where many points meet the same caps (``c.m >= threshold``)."""
    return np.cos(np.minimum(reach, np.pi)) - COS_SLACK


#: Margin on the cosine thresholds of :func:`cap_within_pairs` (far above the 1 ulp by
#: which ``cos`` may be off, so the bounds never cross the exact thresholds).
_PAIR_MARGIN = 1e-12


def cap_within_pairs(cm, first, cell, half, arc, *, runs=None, trig=None) -> np.ndarray:
    """``cap_within(cm, first[cell] + half[arc])`` for pairs ``(cell, arc)``: the same
    booleans, with ``cos`` evaluated only for the pairs near their threshold.

    ``runs``: ``(arcs, counts)`` where ``arc`` is ``np.repeat(arcs, counts)`` (pairs in
    runs of one arc): the arcs' bounds are then spread by run, not gathered by pair.
    ``trig``: ``(cos(half), sin(half))`` where the caller keeps them (:func:`cap_bounds`).

    With ``first`` between its least and greatest value, each arc's reach lies between
    two values, so its threshold lies between two cosines computed once per arc; a pair
    above the higher (by :data:`_PAIR_MARGIN`) passes, one below the lower fails, and
    the others take the exact test. Addition, ``min`` and (to 1 ulp) ``cos`` are
    monotone, so the two bounds are on either side of every pair's exact threshold.
    """
    if len(cm) <= 4 * len(half):  # few pairs: the bounds of every arc would cost more
        return cap_within(cm, first[cell] + half[arc])
    out = np.zeros(len(cm), dtype=bool)
    lo, hi = cap_bounds(first, half, trig)
    may = np.flatnonzero(cm >= (lo[arc] if runs is None else np.repeat(lo[runs[0]], runs[1])))
    a, cmm = arc[may], cm[may]
    unsure = cmm < hi[a]
    out[may] = ~unsure
    u = may[unsure]
    out[u] = cap_within(cm[u], first[cell[u]] + half[arc[u]])
    return out


def decide_between(value, lo, hi, exact) -> np.ndarray:
    """A test ``value >= threshold`` from bounds ``lo < hi`` on each threshold: True at
    or above ``hi``, False below ``lo``, and ``exact(u)`` (the exact test of the entries
    ``u``) for the few in between. The bounded tests of the levels' pairs take this form
    (:func:`cap_bounds`)."""
    out = value >= hi
    u = np.flatnonzero((value >= lo) & ~out)
    if len(u):
        out[u] = exact(u)
    return out


def cap_bounds(first, half, trig=None) -> tuple[np.ndarray, np.ndarray]:
    """Per arc (radius ``half``), bounds ``(lo, hi)`` on the threshold of
    ``cap_within(cm, first[cell] + half)`` over every ``first`` value: ``cm < lo`` fails
    and ``cm >= hi`` passes for every cell (:func:`cap_within_pairs`' bounds, with
    :data:`_PAIR_MARGIN` on either side); ``lo < hi``.

    ``trig``: ``(cos(half), sin(half))`` where the caller keeps them: the cosines are then
    ``cos f cos h - sin f sin h`` (within 1e-15 of ``cos(f + h)``, far inside the margin),
    -1 where ``f + h >= pi``: no cosine per arc."""
    if trig is None:
        lo = np.cos(np.minimum(first.max() + half, np.pi))
        hi = np.cos(np.minimum(first.min() + half, np.pi))
    else:
        lo, hi = (_cos_sum(f, half, trig) for f in (first.max(), first.min()))
    return lo - COS_SLACK - _PAIR_MARGIN, hi - COS_SLACK + _PAIR_MARGIN


def _cos_sum(f: float, half, trig) -> np.ndarray:
    """``cos(min(f + half, pi))`` to 1e-15 from ``trig = (cos(half), sin(half))``."""
    f = float(f)
    out = np.cos(f) * trig[0] - np.sin(f) * trig[1]
    out[f + half >= np.pi] = -1.0
    return out


def cos_sum_lower(total, cos_x, sin_x, cos_y, sin_y):
    """A lower bound on ``cos(x + y)`` from the cosines and sines of ``x`` and ``y``
    (``total = x + y``): ``cos x cos y - sin x sin y - COS_SLACK``, and -2 (below every
    dot product) where ``total >= pi``. The cap test of :func:`cap_within` for a reach
    made of two angles whose cos and sin were computed once.

    Error bound: the four inputs within 1 ulp each give an error below 1e-15, far
    below :data:`COS_SLACK`; ``c.m >= cos_sum_lower(...)`` is never false where
    ``c.m >= cos(x + y)`` holds exactly.
    """
    return np.where(total >= np.pi, -2.0, cos_x * cos_y - sin_x * sin_y - COS_SLACK)
