"""The error bounds stated in gloffset.geometry.caps, against extended precision (np.longdouble)."""

import numpy as np

from gloffset.geometry import caps
from gloffset.geometry.caps import (
    CAP_SLACK,
    angle_of_chord,
    arc_cap,
    cap_range,
    cap_within,
    chord,
    chord2,
    cos_sum_lower,
    pad,
)
from gloffset.geometry.sphere import angle, arc_distance, dot, normalize, rotate, slerp
from gloffset.raster.vector import levels as hierarchy

rng = np.random.default_rng(11)
# angles at every scale, from 1e-12 rad (6 micrometres) to pi
T = np.concatenate([10.0 ** rng.uniform(-12, np.log10(np.pi), 4000), [np.pi, 0.5 * np.pi]])


def rand_unit(n):
    return normalize(rng.normal(size=(n, 3)))


def exact_chord(t):
    return 2.0 * np.sin(0.5 * np.asarray(t, dtype=np.longdouble))


def test_chords_are_accurate_and_pad_rounds_up():
    c = exact_chord(T)
    assert np.all(np.abs(chord(T) - c) <= 3e-16 * c)
    assert np.all(pad(chord(T)) >= c) and np.all(chord(T) * (1.0 - 1e-12) <= c)
    assert np.all(np.abs(chord2(T) - c * c) <= 6e-16 * c * c)
    assert np.all(chord2(T) * (1.0 + 1e-12) >= c * c)
    # clamped to the diameter above pi
    assert chord(4.0) == chord(np.pi) and chord2(4.0) == chord2(np.pi)


def test_angle_of_chord_inverts_chord():
    t = T[T <= 0.5 * np.pi]
    assert np.all(np.abs(angle_of_chord(chord(t)) - t) <= 1e-15 * t)
    assert angle_of_chord(2.5) == np.pi  # beyond the diameter


def test_arc_cap_holds_the_arc_at_every_scale():
    a = rand_unit(len(T))
    axis = normalize(np.cross(a, rand_unit(len(T))))
    t = np.minimum(T, 3.0)  # slerp itself loses accuracy toward antipodal ends
    b = rotate(a, axis, t)
    mid, half = arc_cap(a, b)
    assert np.all(np.abs(2.0 * half - angle(a, b)) <= 1e-15)
    r = pad(half)
    for s in (0.0, 0.1, 0.37, 0.5, 0.8, 1.0):
        assert np.all(angle(mid, slerp(a, b, np.full(len(t), s))) <= r)
    # antipodal ends (rejected on input) fall back to the start point
    m, h = arc_cap(np.array([1.0, 0.0, 0.0]), np.array([-1.0, 0.0, 0.0]))
    assert np.array_equal(m, [1.0, 0.0, 0.0]) and h == 0.5 * np.pi


def test_cap_tests_are_never_false_where_they_should_hold():
    c = rand_unit(len(T))
    axis = normalize(np.cross(c, rand_unit(len(T))))
    p = rotate(c, axis, T)
    t = angle(c, p)  # the distance actually realised by the rounded points
    assert np.all(cap_within(dot(c, p), t))
    assert np.all(cap_within(dot(c, p), t + 1.0))
    assert np.all(cap_within(-1.0, np.array([np.pi, 4.0])))
    # the same test with a reach of two angles whose cos and sin were taken once
    x = 0.5 * t
    y = t - x
    lim = cos_sum_lower(x + y, np.cos(x), np.sin(x), np.cos(y), np.sin(y))
    assert np.all(dot(c, p) >= lim)
    ld = np.cos(np.asarray(x, np.longdouble) + np.asarray(y, np.longdouble))
    below = x + y < np.pi
    assert np.all(lim <= ld) and np.all((lim >= ld - 2e-12)[below])
    assert cos_sum_lower(np.pi, -1.0, 0.0, 1.0, 0.0) == -2.0


def test_cap_range_bounds_the_distance_to_the_arc():
    a = rand_unit(2000)
    b = normalize(a + 10.0 ** rng.uniform(-9, 0, (2000, 1)) * rand_unit(2000))
    mid, half = arc_cap(a, b)
    p = normalize(mid + 10.0 ** rng.uniform(-9, 0.5, (2000, 1)) * rand_unit(2000))
    lo, hi = cap_range(dot(p, mid), pad(half))
    d = arc_distance(p, a, b)
    assert np.all(lo - CAP_SLACK <= d) and np.all(d <= hi + CAP_SLACK)


def test_hierarchy_reexports_the_cap_bounds():
    assert hierarchy.cap_range is caps.cap_range
    assert hierarchy.cap_within is caps.cap_within
    assert hierarchy.CAP_SLACK == caps.CAP_SLACK


def test_cap_within_pairs_is_cap_within():
    """The bounded test gives the booleans of the plain one, at and around the thresholds
    (many pairs: the per-arc bounds; few: the plain test)."""
    rng = np.random.default_rng(5)
    mid = normalize(rng.normal(size=(300, 3)))
    half = rng.uniform(0.0, 0.2, 300)
    c = normalize(rng.normal(size=(50, 3)))
    first = 0.3 + rng.uniform(0.0, 1e-3, 50)
    for n in (20_000, 500):
        cell, arc = rng.integers(0, 50, n), rng.integers(0, 300, n)
        cm = np.einsum("ij,ij->i", c[cell], mid[arc])
        # some pairs exactly at their threshold, and one ulp either side
        thr = np.cos(np.minimum(first[cell] + half[arc], np.pi)) - caps.COS_SLACK
        k = rng.integers(0, n, n // 10)
        cm[k] = np.nextafter(thr[k], rng.choice([-2.0, 2.0], len(k)))
        cm[k[::3]] = thr[k[::3]]
        want = caps.cap_within(cm, first[cell] + half[arc])
        assert np.array_equal(caps.cap_within_pairs(cm, first, cell, half, arc), want)
        # the pairs in runs of one arc, the bounds spread by run: the same booleans
        o = np.argsort(arc, kind="stable")
        runs, counts = np.unique(arc[o], return_counts=True)
        got = caps.cap_within_pairs(cm[o], first, cell[o], half, arc[o], runs=(runs, counts))
        assert np.array_equal(got, want[o])


def test_cap_bounds_from_kept_cosines_hold_the_thresholds():
    """The bounds made from the radii's cosines and sines bracket every pair's exact
    threshold as the plain bounds do (reaches past pi included), and the bounded test
    with them gives the plain test's booleans."""
    rng = np.random.default_rng(7)
    half = np.concatenate([rng.uniform(0.0, 0.2, 300), [0.0, 1.5, 3.1, np.pi]])
    trig = (np.cos(half), np.sin(half))
    for first in (0.3 + rng.uniform(0.0, 1e-3, 50), rng.uniform(0.0, 3.0, 50)):
        lo, hi = caps.cap_bounds(first, half, trig)
        thr = caps.cap_threshold(first[:, None] + half[None, :])
        assert np.all(lo <= thr) and np.all(thr <= hi) and np.all(lo < hi)
        plain = caps.cap_bounds(first, half)
        assert np.allclose(lo, plain[0], rtol=0, atol=1e-14)
        assert np.allclose(hi, plain[1], rtol=0, atol=1e-14)
    mid = normalize(rng.normal(size=(len(half), 3)))
    c = normalize(rng.normal(size=(50, 3)))
    cell, arc = rng.integers(0, 50, 20_000), rng.integers(0, len(half), 20_000)
    cm = np.einsum("ij,ij->i", c[cell], mid[arc])
    thr = caps.cap_threshold(first[cell] + half[arc])
    cm[::7] = thr[::7]
    want = caps.cap_within(cm, first[cell] + half[arc])
    assert np.array_equal(caps.cap_within_pairs(cm, first, cell, half, arc, trig=trig), want)
