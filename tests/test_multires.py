"""Multiresolution curves and offsets (paper Sec. 4.2): lossless levels, rigorous error
bounds, seams, and offsets refined from their centres alone."""

import math

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import gloffset
from gloffset import InvalidLevelError
from gloffset.geometry.sphere import angle, arc_distance, slerp


def circle_ring(n, radius_deg=5.0, wobble=0.0, seed=0):
    """A ring of ``n`` points on a small circle (optionally wobbly), as a Shape."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    r = radius_deg * (1.0 + wobble * rng.uniform(-1, 1, n))
    ll = np.column_stack([10 + r * np.cos(t), 20 + r * np.sin(t)])
    return gloffset.Shape.from_lonlat(ll[:, 0], ll[:, 1], closed=True)


def all_points(parts):
    return np.concatenate(parts) if parts else np.zeros((0, 3))


def original_edges_under(tree, node):
    """The original edges (leaf nodes) a tree node stands for."""
    todo, out = [node], []
    while todo:
        k = todo.pop()
        if tree.child[k, 0] < 0:
            out.append(k)
        else:
            todo.extend(tree.child[k])
    return np.array(out)


# ---------------------------------------------------------------------- decomposition
@pytest.mark.parametrize("n, sizes", [(16, [16, 8, 4, 3]), (15, [15, 8, 4, 3]), (5, [5, 3, 3])])
def test_ring_levels_halve_and_keep_three_points(n, sizes):
    """Even rings lose every odd point; odd rings carry their closing arc; >= 3 points."""
    dec = gloffset.decompose(circle_ring(n), len(sizes) - 1)
    assert [len(dec.points(k)[0]) for k in range(len(sizes))] == sizes
    for k in range(1, len(sizes)):
        assert len(dec.points(k)[0]) + len(dec.details(k)[0]) == len(dec.points(k - 1)[0])


def test_line_keeps_its_ends_and_points_stay():
    coords = [[0, 0], [1, 1], [2, 0], [3, 1], [4, 0], [5, 1]]  # 6 points: last arc carried
    s = gloffset.read(
        {
            "type": "GeometryCollection",
            "geometries": [
                {"type": "LineString", "coordinates": coords},
                {"type": "Point", "coordinates": [30, 30]},
            ],
        }
    )
    dec = gloffset.decompose(s, 3)
    line0 = s.lines[0]
    for k in range(4):
        line, point = dec.points(k)
        assert np.array_equal(line[0], line0[0]) and np.array_equal(line[-1], line0[-1])
        assert np.array_equal(point, s.lines[1])
    assert [len(dec.points(k)[0]) for k in range(4)] == [6, 4, 3, 2]


lonlats = hnp.arrays(
    np.float64,
    st.tuples(st.integers(3, 40), st.just(2)),
    elements=st.floats(-60, 60, allow_nan=False),
)


@given(lonlats, st.booleans(), st.integers(0, 6))
@settings(max_examples=60, deadline=None)
def test_reconstruction_is_lossless(ll, closed, levels):
    try:
        s = gloffset.Shape.from_lonlat(ll[:, 0], ll[:, 1], closed=closed)
    except gloffset.InvalidGeometryError:
        return
    dec = gloffset.decompose(s, levels)
    # the property is about one curve: a ring whose edges cross or overlap is read by
    # crossing parity as the union's rings (tests/test_ring_rules.py), not one curve
    assume(not closed or len(s.rings) == 1)
    orig = s.rings[0] if closed else s.lines[0]
    assert (
        np.abs(all_points(dec.reconstruct(0).rings + dec.reconstruct(0).lines) - orig).max()
        <= 1e-15
    )
    for k in range(levels + 1):
        # every level is a subsequence of the original points, as reconstructed from P[levels]
        pts = dec.points(k)[0]
        d = np.abs(pts[:, None, :] - orig[None, :, :]).max(axis=2).min(axis=1)
        assert d.max() <= 1e-15
        if k:
            # a detail is the discarded point minus the SLERP midpoint of its neighbours
            tree = dec.tree
            nodes = dec.level_nodes(k)
            merged = nodes[tree.level[nodes] == k]
            discarded = tree.b[tree.child[merged, 0]]
            mid = slerp(tree.a[merged], tree.b[merged], 0.5)
            assert len(dec.details(k)[0]) == len(merged)
            assert np.abs(discarded - mid - dec.details(k)[0]).max(initial=0) <= 1e-15


def test_mexico_is_lossless_and_bounds_are_rigorous(mexico_path):
    s = gloffset.read(mexico_path)
    dec = gloffset.decompose(s, 8)
    rec = dec.reconstruct(0)
    assert max(np.abs(a - b).max() for a, b in zip(rec.rings, s.rings)) <= 1e-15
    sizes = [sum(len(p) for p in dec.points(k)) for k in range(9)]
    assert sizes[0] == s.n_vertices and all(b < a for a, b in zip(sizes, sizes[1:]))
    tree = dec.tree
    rng = np.random.default_rng(0)
    for k in (1, 2, 4, 8):
        e = np.concatenate(dec.errors(k))
        assert (e >= 0).all() and (e <= np.pi).all()
        nodes = dec.level_nodes(k)
        merged = nodes[tree.level[nodes] > 0]
        for node in rng.choice(merged, 60, replace=False):
            leaves = original_edges_under(tree, node)
            t = np.hstack([np.zeros((len(leaves), 1)), rng.uniform(0, 1, (len(leaves), 25))])
            pts = slerp(tree.a[leaves][:, None], tree.b[leaves][:, None], t).reshape(-1, 3)
            dist = arc_distance(pts, tree.a[node], tree.b[node])
            # Eq. (e): every original point lies within e of the simplified arc
            assert dist.max() <= tree.e[node] + 1e-15
        # the paper's recursion: e = max(e of the two halves) + dist(B, SLERP(A, C, 1/2))
        made = nodes[tree.level[nodes] == k]
        c0, c1 = tree.child[made, 0], tree.child[made, 1]
        step = angle(tree.b[c0], slerp(tree.a[made], tree.b[made], 0.5))
        want = np.maximum(tree.e[c0], tree.e[c1]) + step
        assert np.abs(tree.e[made] - want).max() <= 3e-15
        # error regions nest: a child's lies inside its parent's
        assert (tree.e[c0] <= tree.e[made]).all() and (tree.e[c1] <= tree.e[made]).all()


def test_long_arcs_are_not_merged():
    """A pair of arcs longer than pi/2 has no error bound: it is carried over."""
    s = gloffset.read(
        {"type": "Polygon", "coordinates": [[[0, 0], [100, 0], [100, 60], [-100, 60], [0, 0]]]}
    )
    dec = gloffset.decompose(s, 3)
    assert len(dec.points(3)[0]) == len(s.rings[0])
    s2 = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [60, 0], [120, 0]]})
    assert len(gloffset.decompose(s2, 2).points(2)[0]) == 3  # the merged arc would be 120 deg
    s3 = gloffset.read({"type": "LineString", "coordinates": [[0, 0], [40, 0], [80, 0]]})
    dec3 = gloffset.decompose(s3, 2)
    assert len(dec3.points(1)[0]) == 2  # 80 deg: merged, and B lies on the arc
    assert np.concatenate(dec3.errors(1)).max() < 1e-14


SEAMED = {  # half of a box cut at 180 deg without its other half: an unpaired seam
    "type": "Polygon",
    "coordinates": [
        [[170, 0], [173, 0], [176, 0], [180, 0], [180, 2], [180, 4], [180, 6], [180, 8]]
        + [[180, 10], [176, 10], [173, 10], [170, 10], [170, 6], [170, 3], [170, 0]]
    ],
}


def test_seams_survive():
    """Seams stay seams at every level: seam arcs merge only with seam arcs."""
    s = gloffset.read(SEAMED)
    assert s.ring_seams[0].sum() == 5
    dec = gloffset.decompose(s, 4)
    tree = dec.tree
    assert np.array_equal(dec.reconstruct(0).ring_seams[0], s.ring_seams[0])
    for k in range(1, 5):
        r = dec.reconstruct(k)
        nodes = dec.level_nodes(k)
        seams = np.concatenate(r.ring_seams)
        assert seams.any() and not seams.all()
        for node, seam in zip(nodes, seams):
            edges = original_edges_under(tree, node)
            assert (~tree.boundary[edges]).all() == seam and (~tree.boundary[edges]).any() == seam
        assert np.array_equal(r.ring_groups, s.ring_groups)
        assert np.array_equal(r.ring_holes, s.ring_holes)


def test_level_errors():
    s = circle_ring(12)
    with pytest.raises(InvalidLevelError):
        gloffset.decompose(s, -1)
    with pytest.raises(InvalidLevelError):
        gloffset.decompose(s, 1.5)
    dec = gloffset.decompose(s, 2)
    with pytest.raises(InvalidLevelError, match="out of range"):
        dec.reconstruct(3)
    with pytest.raises(InvalidLevelError):
        dec.details(0)
    with pytest.raises(InvalidLevelError, match="coarser"):
        dec.offset(0.01, 1, radius=1.0).refine(2)


# ---------------------------------------------------------------------- offsets
def assert_same_offset(refined, direct, tol=1e-12):
    """Centres Q (Eq. 2, 3) and junctions R (Eq. 4) of every arc, extra junctions included."""
    assert len(refined.rings) == len(direct.rings)
    for a, b in zip(refined.rings, direct.rings):
        assert np.array_equal(a.kind, b.kind)
        assert np.abs(a.centers - b.centers).max() <= tol
        assert np.abs(a.junctions - b.junctions).max() <= tol


@pytest.mark.parametrize("d", [0.02, -0.01])
def test_refined_offset_equals_direct_offset(mexico_path, d):
    s = gloffset.read(mexico_path)
    dec = gloffset.decompose(s, 5)
    coarse = dec.offset(d, 5, radius=1.0)
    assert_same_offset(coarse, gloffset.offset(dec.reconstruct(5), d, radius=1.0), 0.0)
    c = math.cos(d)
    assert np.abs(coarse.vertex_centers() - c * all_points(dec.points(5))).max() <= 1e-15
    for k in (4, 2, 0):
        fine = coarse.refine(k)
        assert fine.level == k
        assert np.abs(fine.vertex_centers() - c * all_points(dec.points(k))).max() <= 1e-15
        assert_same_offset(fine, gloffset.offset(dec.reconstruct(k), d, radius=1.0))
    assert_same_offset(coarse.refine(0), gloffset.offset(s, d, radius=1.0))


@given(lonlats, st.booleans(), st.floats(1e-4, 0.5), st.integers(1, 4))
@example(  # a line that turns back on itself exactly: the join's side is the rounding's
    np.array([[27.0, 3.90625e-03], [3.90625e-03, 3.90625e-03], [3.90625e-03, 0.0]])[[0, 1, 2, 1]],
    False,
    0.5,
    1,
)
@settings(max_examples=40, deadline=None)
def test_refined_offsets_of_random_curves(ll, closed, d, levels):
    """Rings both ways, lines with caps (split junctions included), any level.

    The vertex centres always agree to 1e-15. Edge centres and junctions are compared
    where the curve's edges are at least 1e-6 rad long: the normal of a shorter edge,
    and the choice of an extra junction where a line turns back on itself, move by
    1e-16 / length for a 1e-16 change of its ends, in the direct offset as well. Nor
    where the curve turns back on itself exactly (a spike: the vertex before a turn is
    the one after it): the join there is a half circle either way round, the side a
    turn of pi is taken to, and so its extra junction, is the rounding's choice (the
    region is the same: the other half lies in the offset of the spike's edges).
    """
    try:
        s = gloffset.Shape.from_lonlat(ll[:, 0], ll[:, 1], closed=closed)
    except gloffset.InvalidGeometryError:
        return
    dec = gloffset.decompose(s, levels)
    short = angle(s.edges().a, s.edges().b).min()
    for sign in (1.0, -1.0) if closed else (1.0,):
        fine = dec.offset(sign * d, levels, radius=1.0).refine(0)
        direct = gloffset.offset(s, sign * d, radius=1.0)
        want = math.cos(d) * all_points(s.rings + s.lines)
        if fine.rings:
            assert np.abs(fine.vertex_centers() - want).max() <= 1e-15
        if short >= 1e-6 and not _spiked(s):
            assert_same_offset(fine, direct, tol=1e-15 + 1e-16 / short)


def _spiked(shape) -> bool:
    """Whether a curve turns back on itself exactly: its vertex before a turn is the one
    after it (within 1e-12 rad)."""
    for pts in shape.rings + shape.lines:
        ring = any(pts is r for r in shape.rings)
        p = np.concatenate([pts[-1:], pts, pts[:1]]) if ring else pts
        if len(p) >= 3 and (angle(p[:-2], p[2:]) <= 1e-12).any():
            return True
    return False


def test_refined_offset_of_points_and_lines_keeps_caps_and_circles():
    s = gloffset.read(
        {
            "type": "GeometryCollection",
            "geometries": [
                {"type": "LineString", "coordinates": [[0, 0], [1, 1], [2, 0], [3, 1], [4, 0]]},
                {"type": "Point", "coordinates": [30, 30]},
            ],
        }
    )
    dec = gloffset.decompose(s, 2)
    fine = dec.offset(0.05, 2, radius=1.0).refine(0)
    assert_same_offset(fine, gloffset.offset(s, 0.05, radius=1.0))
    assert fine.shape.lines[0].shape == (5, 3)
    # lines and points bound no region: an inward offset is refused
    with pytest.raises(gloffset.InvalidDistanceError, match="no polygon"):
        dec.offset(-0.05, 2, radius=1.0)
