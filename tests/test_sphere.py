import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gloffset.geometry.sphere import (
    angle,
    arc_distance,
    arc_foot,
    arcs_cross,
    lonlat_to_xyz,
    nearest_on_arc,
    normalize,
    robust_cross,
    rotate,
    slerp,
    xyz_to_lonlat,
)

rng = np.random.default_rng(7)


def rand_unit(n):
    return normalize(rng.normal(size=(n, 3)))


def test_lonlat_roundtrip_and_seams():
    lon = rng.uniform(-179.9, 179.9, 1000)
    lat = rng.uniform(-89.9, 89.9, 1000)
    lo, la = xyz_to_lonlat(lonlat_to_xyz(lon, lat))
    assert np.abs(lo - lon).max() < 1e-12 and np.abs(la - lat).max() < 1e-12
    # both sides of the antimeridian and every longitude at a pole give identical vectors
    assert np.array_equal(lonlat_to_xyz(180.0, 12.5), lonlat_to_xyz(-180.0, 12.5))
    assert np.array_equal(lonlat_to_xyz(180.00000000000006, 12.5), lonlat_to_xyz(-180, 12.5))
    assert np.array_equal(lonlat_to_xyz(37.0, -90.0), np.array([0.0, 0.0, -1.0]))


@given(st.floats(1e-12, np.pi - 1e-9))
@settings(max_examples=200)
def test_angle_is_accurate_at_every_scale(t):
    a = np.array([1.0, 0.0, 0.0])
    b = np.array([np.cos(t), np.sin(t), 0.0])
    # the only error left is the rounding of b itself
    assert abs(angle(a, b) - t) <= 4e-16 * max(t, 1.0) + 1e-16


def test_slerp_stays_on_the_arc():
    a, b = rand_unit(500), rand_unit(500)
    t = rng.uniform(0, 1, 500)
    p = slerp(a, b, t)
    assert np.abs(np.linalg.norm(p, axis=1) - 1).max() < 1e-15
    assert np.abs(angle(a, p) - t * angle(a, b)).max() < 1e-13
    assert np.abs(arc_distance(p, a, b)).max() < 1e-14


def test_arc_distance_known_cases():
    a = lonlat_to_xyz(0.0, 0.0)
    b = lonlat_to_xyz(10.0, 0.0)
    # perpendicular foot inside the arc
    assert abs(arc_distance(lonlat_to_xyz(5.0, 3.0), a, b) - np.radians(3.0)) < 1e-15
    # beyond an end: distance to the endpoint
    p = lonlat_to_xyz(20.0, 0.0)
    assert abs(arc_distance(p, a, b) - np.radians(10.0)) < 1e-15
    # tiny distances keep full relative accuracy (no acos)
    p = lonlat_to_xyz(5.0, 1e-9)
    assert abs(arc_distance(p, a, b) - np.radians(1e-9)) < 1e-24
    # a degenerate arc is a point
    assert abs(arc_distance(p, a, a) - angle(p, a)) < 1e-16


def test_arc_distance_matches_dense_sampling():
    a, b = rand_unit(200), rand_unit(200)
    p = rand_unit(200)
    t = np.linspace(0, 1, 4001)
    samples = slerp(a[:, None], b[:, None], t[None, :])
    brute = angle(p[:, None], samples).min(axis=1)
    d = arc_distance(p, a, b)
    assert np.all(d <= brute + 1e-14)
    assert np.all(brute - d < 1e-3)  # sampling step bound


def test_nearest_on_arc_is_on_the_arc_at_its_distance():
    # random arcs (feet on the arc and beyond either end), points on the arcs, a
    # degenerate arc: the point lies on the arc and its angle from p is arc_distance's
    a, b = rand_unit(2000), rand_unit(2000)
    a[-1] = b[-1]
    p = np.concatenate([rand_unit(1999), a[-1:]])
    p[:100] = slerp(a[:100], b[:100], rng.uniform(0, 1, 100))
    n = normalize(robust_cross(a, b))
    q = nearest_on_arc(p, a, b, n)
    assert np.abs(np.linalg.norm(q, axis=1) - 1.0).max() < 1e-15
    assert np.abs(arc_distance(q, a, b, n)).max() < 1e-14  # on the arc
    assert np.abs(angle(p, q) - arc_distance(p, a, b, n)).max() < 1e-14
    # where the foot falls off the arc, the nearer end, bit for bit
    inside, _, _ = arc_foot(p, a, b, n)
    off = np.flatnonzero(~inside)
    nearer = np.where((angle(p, a) <= angle(p, b))[:, None], a, b)
    assert len(off) > 100 and np.array_equal(q[off], nearer[off])


def test_arcs_cross_against_intersection_point():
    n = 20000
    p, q, a, b = rand_unit(n), rand_unit(n), rand_unit(n), rand_unit(n)
    x = normalize(np.cross(np.cross(p, q), np.cross(a, b)))

    def on(x, u, v):
        return np.abs(angle(u, x) + angle(x, v) - angle(u, v)) < 1e-9

    truth = (on(x, p, q) & on(x, a, b)) | (on(-x, p, q) & on(-x, a, b))
    assert np.array_equal(arcs_cross(p, q, a, b), truth)


def test_rotate_preserves_angle():
    v, axis = rand_unit(100), rand_unit(100)
    w = rotate(v, axis, 0.7)
    assert np.allclose(np.sum(v * axis, 1), np.sum(w * axis, 1), atol=1e-15)


def test_einsum_dot_is_einsum_bit_for_bit():
    """``einsum_dot`` gives einsum's bits, the sign of zero included (the GPU records
    are compared byte for byte), on (k, 3) arrays and on (3, k) rows taken as ``.T``."""
    from gloffset.geometry.sphere import einsum_dot

    rng = np.random.default_rng(5)
    u, v = rng.normal(size=(5000, 3)), rng.normal(size=(5000, 3))
    u[:10] = [-0.0, 0.0, -0.0]  # products all -0 (einsum: +0)
    v[:10] = [1.0, -2.0, 3.0]
    want = np.einsum("ij,ij->i", u, v).view(np.int64)
    assert np.array_equal(einsum_dot(u, v).view(np.int64), want)
    rows_u, rows_v = np.ascontiguousarray(u.T), np.ascontiguousarray(v.T)
    assert np.array_equal(einsum_dot(rows_u.T, rows_v.T).view(np.int64), want)


def test_pair_dots_are_einsum_bits():
    from gloffset.geometry.sphere import pair_dots

    rng = np.random.default_rng(3)
    u, v = rng.normal(size=(100, 3)), rng.normal(size=(80, 3))
    ui, vi = rng.integers(0, 100, 5000), rng.integers(0, 80, 5000)
    assert np.array_equal(pair_dots(u, ui, v, vi), np.einsum("ij,ij->i", u[ui], v[vi]))


def test_column_dots_are_the_pair_dots_bits():
    """From coordinate columns, gathered or not, by indices of any integer type or by a
    mask: the bits of :func:`pair_dots` (its sum order, not :func:`dot`'s)."""
    from gloffset.geometry.sphere import column_dots, dot, pair_dots

    rng = np.random.default_rng(5)
    u, v = rng.normal(size=(100, 3)), rng.normal(size=(80, 3))
    ui, vi = rng.integers(0, 100, 5000), rng.integers(0, 80, 5000)
    want = pair_dots(u, ui, v, vi).view(np.int64)
    uc = [np.ascontiguousarray(u[:, k]) for k in range(3)]
    vc = [np.ascontiguousarray(v[:, k]) for k in range(3)]
    assert np.array_equal(column_dots(uc, vc, ui, vi).view(np.int64), want)
    got = column_dots(uc, vc, ui.astype(np.int32), vi.astype(np.uint32))
    assert np.array_equal(got.view(np.int64), want)
    vg = [x[vi] for x in vc]
    assert np.array_equal(column_dots(uc, vg, ui).view(np.int64), want)
    mask = np.arange(100) % 3 == 0
    got = column_dots(uc, uc[::-1], mask, mask)
    at = np.flatnonzero(mask)
    assert np.array_equal(got, pair_dots(u, at, u[:, ::-1], at))
    assert not np.array_equal(want, dot(u[ui], v[vi]).view(np.int64))  # another sum order


def test_pair_chord2_and_pair_equal_are_the_row_by_row_answers():
    from gloffset.geometry.sphere import chord2_between, pair_chord2, pair_equal

    rng = np.random.default_rng(4)
    v = normalize(rng.normal(size=(300, 3)))
    v[200:250] = v[:50] + rng.normal(size=(50, 3)) * 1e-13  # near twins
    v[250:] = v[:50]  # exact twins
    v[260, 2], v[10, 2] = 0.0, -0.0  # a signed zero: equal rows all the same
    i, j = rng.integers(0, 300, 20000), rng.integers(0, 300, 20000)
    i[:300], j[:300] = np.arange(300), (np.arange(300) + 250) % 300
    want = chord2_between(v[i], v[j])
    assert np.array_equal(pair_chord2(v, i, j).view(np.int64), want.view(np.int64))
    same = pair_equal(v, i, j)
    assert np.array_equal(same, (v[i] == v[j]).all(axis=1))
    assert same.sum() > 50 and same[260 - 250]


def test_slerp_with_the_callers_angle_is_the_same_bits():
    from gloffset.geometry.sphere import angle, slerp

    rng = np.random.default_rng(5)
    a, b = normalize(rng.normal(size=(2000, 3))), normalize(rng.normal(size=(2000, 3)))
    b[:100] = normalize(a[:100] + rng.normal(size=(100, 3)) * 1e-9)
    t = rng.uniform(size=2000)
    want = slerp(a, b, t)
    assert np.array_equal(slerp(a, b, t, angle(a, b)).view(np.int64), want.view(np.int64))
