"""The distance field's sign from each pixel's nearest boundary features
(``gloffset.raster.fields.sign``): equal to the float64 levels' inside test at distance 0
at every pixel, on real borders and on pixels placed on vertices and edges; a broken
rule is caught; the GLSL rule agrees where it decides."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import DATA, SQUARE_WITH_HOLE, named_countries

import gloffset
from gloffset.edges import CurveArcs
from gloffset.geometry.classes import CONTAINED
from gloffset.grids import Cube, Equirect, Tile
from gloffset.raster.fields import sign as field_sign
from gloffset.raster.fields.sign import (
    INSIDE,
    OUTSIDE,
    UNDECIDED,
    Corners,
    block_signs,
    levels_inside,
    nearest_signs,
    signs,
)
from gloffset.raster.fields.walk import walk_levels
from gloffset.raster.vector.curves import classify_curves
from gloffset.raster.vector.node_levels import NodeArcs
from gloffset.shape import Shape

HERE = Path(__file__).resolve().parent / "glsl"


def today(shape, grid) -> np.ndarray:
    """The sign the field had before: the levels' test at distance 0, per face."""
    faces = [classify_curves(shape, 0.0, f)[0] == CONTAINED for f in grid.faces]
    return np.stack(faces) if grid.n_faces > 1 else faces[0]


def field_inside(shape, grid) -> np.ndarray:
    """The CPU field's sign bit (inside: negative, or -0.0)."""
    return np.signbit(gloffset.distance_field(shape, grid, backend="cpu").values)


def assert_same_sign(shape, grid):
    got, want = field_inside(shape, grid), today(shape, grid)
    bad = np.argwhere(got != want)
    assert len(bad) == 0, f"{len(bad)} pixels differ from the levels' sign, e.g. {bad[:3]}"
    return want


def rule(shape, grid, corners=None):
    """The rule alone on every pixel of a one-face grid: (inside, undecided)."""
    corners = corners or Corners.from_shape(shape)
    arcs = CurveArcs.from_shape(shape)
    last = grid.n_levels - 1
    h, w = grid.level_shape(last)
    ins, und = np.zeros((h, w), bool), np.zeros((h, w), bool)
    for f, dist, pairs in walk_levels(NodeArcs.from_shape(shape), grid, np.inf, last, pairs=True):
        i_, u_ = block_signs(corners, arcs, grid, f, dist, pairs)
        ins[f.cells[:, 0], f.cells[:, 1]] = i_
        und[f.cells[:, 0], f.cells[:, 1]] = u_
    return ins, und


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


@pytest.fixture(scope="module")
def world110():
    return gloffset.read(DATA / "world_110m.geojson")


def test_mexico_equirect_and_tiles(mexico):
    for grid in (Equirect(256, 128), Tile(5, 6, 13), Tile(10, 229, 446), Tile(8, 55, 110)):
        want = assert_same_sign(mexico, grid)
        if not isinstance(grid, Equirect):
            continue
        assert want.any() and not want.all()
        ins, und = rule(mexico, grid)
        assert not und.any()  # real borders: every pixel decided by the rule


def test_world_neighbours_cube_and_equirect(world110):
    """Every country at 1:110m (shared borders cancel, tripoints, the antimeridian,
    the pole) on a cube and a plate carree."""
    assert_same_sign(world110, Cube(16))
    assert_same_sign(world110, Equirect(360, 180))


def test_antimeridian_and_pole():
    """Fiji and Russia across the antimeridian, Antarctica round the pole."""
    shape = named_countries("Fiji", "Russia", "Antarctica", "United States of America")
    for grid in (Equirect(256, 128), Cube(16), Tile(3, 7, 2), Tile(2, 0, 3)):
        assert_same_sign(shape, grid)


@pytest.mark.slow
def test_every_country_10m():
    assert_same_sign(gloffset.read(DATA / "countries_10m.geojson"), Equirect(1024, 512))


def test_holes_reflex_corners_pinch_and_seam():
    cases = [
        SQUARE_WITH_HOLE,  # one polygon with a lake: the single component's check
        {  # an L (a reflex corner), a square touching it at a corner (a pinch), an island
            "type": "MultiPolygon",
            "coordinates": [
                [[[0, 0], [20, 0], [20, 10], [10, 10], [10, 20], [0, 20], [0, 0]]],
                [[[20, 10], [30, 10], [30, 25], [20, 25], [20, 10]]],
                [[[-20, -20], [-10, -20], [-10, -10], [-20, -10], [-20, -20]]],
            ],
        },
        # a polygon that ends on +-180 deg: its edge there is a seam (no distance)
        {"type": "Polygon", "coordinates": [[[170, -10], [180, -10], [180, 10], [170, 10]]]},
    ]
    for geo in cases:
        shape = gloffset.read(geo)
        assert Corners.from_shape(shape).trusted
        for grid in (Equirect(360, 180), Equirect(256, 128)):
            assert_same_sign(shape, grid)
    corners = Corners.from_shape(gloffset.read(cases[1]))
    assert (corners.corner == INSIDE).any() and (corners.corner == UNDECIDED).any()
    seam = gloffset.read(cases[2])
    _, und = rule(seam, Equirect(360, 180))
    assert und.any()  # beside the seam: left to the levels


def test_pixels_on_vertices_and_edges():
    """Vertices at pixel centres, meridian edges through them: the levels decide."""
    grid = Equirect(360, 180)  # centres at half degrees
    ring = [[10.5, 20.5], [30.5, 20.5], [30.5, 40.5], [20.5, 30.5], [10.5, 40.5], [10.5, 20.5]]
    shape = gloffset.read({"type": "Polygon", "coordinates": [ring]})
    assert_same_sign(shape, grid)
    ins, und = rule(shape, grid)
    assert und.any()
    dist = gloffset.distance_field(shape, grid, backend="cpu").values
    assert np.abs(dist).min() < 1e-6  # metres: centres on the boundary, to rounding


def test_shapes_the_rule_does_not_trust():
    """Overlapping components made by hand, a ring touching itself at a vertex with
    lobes of opposite turns, lines beside polygons: the answers stay the levels'."""
    sq = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]
    bowtie = [[0, 0], [10, 10], [20, 0], [20, 20], [10, 10], [0, 20], [0, 0]]
    lines = {
        "type": "GeometryCollection",
        "geometries": [
            {"type": "Polygon", "coordinates": [sq]},
            {"type": "LineString", "coordinates": [[-5, 5], [15, 6]]},
        ],
    }
    a = gloffset.read({"type": "Polygon", "coordinates": [sq]})
    b = gloffset.read({"type": "Polygon", "coordinates": [[[5, 5], [15, 5], [15, 15], [5, 15]]]})
    by_hand = Shape(
        rings=a.rings + b.rings,
        ring_seams=a.ring_seams + b.ring_seams,
        ring_groups=np.array([0, 1]),
        ring_holes=np.array([False, False]),
        labels=["a", "b"],
    )
    grid = Equirect(256, 128)
    assert not Corners.from_shape(by_hand).trusted
    assert_same_sign(by_hand, grid)
    shape = gloffset.read({"type": "Polygon", "coordinates": [bowtie]})
    assert not Corners.from_shape(shape).trusted
    assert_same_sign(shape, grid)
    shape = gloffset.read(lines)
    assert_same_sign(shape, grid)
    _, und = rule(shape, grid)
    assert und.any()  # nearest to the line: no side


def broken(corners: Corners, what: str) -> Corners:
    out = object.__new__(Corners)
    out.__dict__.update(corners.__dict__)
    if what == "reflex":
        c = corners.corner.copy()
        c[corners.corner == INSIDE] = OUTSIDE
        c[corners.corner == OUTSIDE] = INSIDE
        out.corner = c
    else:
        out.columns = [-x if k < 3 else x for k, x in enumerate(corners.columns)]
    return out


@pytest.mark.parametrize("what", ["reflex", "normal"])
def test_a_broken_rule_fails(mexico, what):
    grid = Equirect(256, 128)
    want = today(mexico, grid)
    ins, und = rule(mexico, grid)
    assert not (ins != want)[~und].any()
    ins, und = rule(mexico, grid, broken(Corners.from_shape(mexico), what))
    assert (ins != want)[~und].sum() > 100


def test_levels_inside_is_the_levels_answer(mexico):
    grid = Tile(5, 6, 13)
    want = today(mexico, grid)
    rng = np.random.default_rng(1)
    j, i = rng.integers(0, 256, 500), rng.integers(0, 256, 500)
    assert (levels_inside(mexico, grid, j, i) == want[j, i]).all()


def test_nearest_signs_are_the_levels_answer(mexico):
    """The float64 rule with the nearest features found in the arcs' tree: the levels'
    answer where it decides, nearly everywhere on random pixels, and at every pixel of
    a z10 tile the shader's float32 rule leaves open (none left to the levels)."""
    import math

    from gloffset.raster.fields.gpu import gpu_distances

    rng = np.random.default_rng(2)
    for grid, pick in ((Tile(5, 6, 13), "random"), (Tile(10, 199, 441), "shader")):
        codes = np.empty(grid.level_shape(grid.n_levels - 1), dtype=np.uint32)
        dist = gpu_distances(mexico, grid, math.inf, lambda n: None, codes=codes)
        if pick == "random":
            j, i = rng.integers(0, 256, 500), rng.integers(0, 256, 500)
        else:
            j, i = np.nonzero(codes == UNDECIDED)
            assert len(j)  # the float32 rule leaves a few open here
        c = grid.centers(grid.n_levels - 1, j, i)
        ins, und = nearest_signs(mexico, c, dist[j, i])
        want = today(mexico, grid)[j, i]
        assert np.array_equal(ins[~und], want[~und])
        assert und.mean() < 0.01 if pick == "random" else not und.any()
    # unknown or tiny distances: undecided
    ins, und = nearest_signs(mexico, c[:2], np.array([np.inf, 1e-13]))
    assert und.all() and not ins.any()


def test_signs_per_pixel_equals_blocks(mexico):
    grid = Tile(5, 6, 13)
    corners, arcs = Corners.from_shape(mexico), CurveArcs.from_shape(mexico)
    last = grid.n_levels - 1
    for f, dist, pairs in walk_levels(NodeArcs.from_shape(mexico), grid, np.inf, last, pairs=True):
        a, ua = signs(corners, arcs, f.centers, dist, pairs)
        b, ub = block_signs(corners, arcs, grid, f, dist, pairs)
        both = ~ua & ~ub
        assert np.array_equal(a[both], b[both]) and not (ub & ~ua).any()
        assert both.mean() > 0.99


def nearest_features(shape, grid):
    """Each pixel's centre and nearest feature ((arc << 2) | kind) in float64."""
    arcs = CurveArcs.from_shape(shape)
    na, bn = arcs.lunes
    last = grid.n_levels - 1
    h, w = grid.level_shape(last)
    px = np.zeros((h, w, 4), np.float32)
    for f, _dist, (cell, node, d) in walk_levels(
        NodeArcs.from_shape(shape), grid, np.inf, last, pairs=True
    ):
        order = np.lexsort((d, cell))
        first = order[np.r_[True, np.diff(cell[order]) != 0]]
        cell, node = cell[first], node[first]
        p = f.centers[cell]
        la = np.einsum("ij,ij->i", p, na[node])
        lb = np.einsum("ij,ij->i", p, bn[node])
        foot = (la >= 0) & (lb >= 0)
        to_a = np.einsum("ij,ij->i", p, arcs.a[node]) >= np.einsum("ij,ij->i", p, arcs.b[node])
        kind = np.where(foot, 0, np.where(to_a, 1, 2)).astype(np.uint32)
        j, i = f.cells[cell, 0], f.cells[cell, 1]
        px[j, i, :3] = p
        px[j, i, 3] = ((node.astype(np.uint32) << 2) | kind).view(np.float32)
    return px.reshape(-1, 4)


def glsl_signs(ctx, px, records, flags):
    from gloffset.gl.shaders import load_source

    src, _ = load_source("probe_field_sign.comp", root=HERE)
    prog = ctx.compute_shader(src)
    n = len(px)
    prog["u_n"] = n
    bufs = [
        ctx.buffer(np.ascontiguousarray(px, np.float32).tobytes()),
        ctx.buffer(np.ascontiguousarray(records, np.float32).tobytes()),
        ctx.buffer(np.ascontiguousarray(flags, np.uint32).tobytes()),
        ctx.buffer(reserve=4 * n),
    ]
    for k, b in enumerate(bufs):
        b.bind_to_storage_buffer(k)
    prog.run(-(-n // 64))
    out = np.frombuffer(bufs[3].read(), dtype=np.uint32).copy()
    for r in (*bufs, prog):
        r.release()
    return out


def test_glsl_rule_agrees_where_it_decides(mexico):
    """shaders/lib/field_sign.glsl on real pixels: every pixel it decides has the
    levels' sign, most pixels are decided, and flipped normals are caught."""
    from gloffset.gl.context import get_context
    from gloffset.raster.fields.gpu import _records

    ctx = get_context()
    corners = Corners.from_shape(mexico)
    records = _records(NodeArcs.from_shape(mexico))[0][: len(corners.ok)]
    for grid in (Equirect(256, 128), Tile(5, 6, 13)):
        px = nearest_features(mexico, grid)
        want = today(mexico, grid).ravel()
        got = glsl_signs(ctx, px, records, corners.flags)
        decided = got != UNDECIDED
        assert decided.mean() > 0.9
        assert np.array_equal(got[decided] == INSIDE, want[decided])
        flipped = records.copy()
        flipped[:, :3, 3] *= -1.0
        got = glsl_signs(ctx, px, flipped, corners.flags)
        decided = got != UNDECIDED
        assert (got[decided] != want[decided]).sum() > 100


def test_thresholds_are_stated():
    # the float64 rule's thresholds lie well above its rounding and below a pixel
    assert 1e-15 < field_sign.NEAR <= 1e-11 and field_sign.ETA < field_sign.NEAR
    assert field_sign.TURN > 2e-15 and field_sign.LUNE > 1e-15
