"""Offsets of rasterized curves (paper Sec. 5): rasterization, the CPU reference
(single resolution and hierarchical), the GPU levels, and the true vector offset.

What is claimed, for a mask made by ``rasterize`` (the cells a curve C meets), an
offset distance d and s the output cells' area bound (``info.s``):

* every *contained* pixel's centre is within d of C;
* every pixel whose centre is within d of C is contained or frontier;
* every point of an *outside* pixel is farther than d from C (checked at the
  corners and edge midpoints of its rectangle);
* the GPU classes, the hierarchical (Sec. 5.2) and the single-resolution (Sec. 5.1)
  CPU classes are identical, whatever the order in which the cells are walked.
"""

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import assert_options_refused
from PIL import Image

import gloffset
from gloffset.cli import main
from gloffset.errors import InvalidDistanceError
from gloffset.geometry.sphere import angle, arc_distance, lonlat_to_xyz, slerp
from gloffset.gl import get_context
from gloffset.gl.shaders import program
from gloffset.grids import Cube, CubeFace, Equirect
from gloffset.grids.cube import FACE_NAMES, FACES, CubeCells, cell_at, face_points
from gloffset.raster.rasterized import (
    CONTAINED,
    FRONTIER,
    OUTSIDE,
    InvalidMaskError,
    RasterOffsetError,
    raster_offset,
    rasterize,
)
from gloffset.reference import distance_xyz

WORLD = Equirect(512, 256)
GLSL = Path(__file__).parent / "glsl"


def all_ways(mask, d, grid, parts=None):
    """Classes by GPU, CPU hierarchical and CPU single resolution (all must agree)."""
    kw = dict(radius=1.0, order=parts, return_info=True)
    gpu, gi = raster_offset(mask, d, grid, **kw)
    hier, hi = raster_offset(mask, d, grid, backend="cpu", **kw)
    single, si = raster_offset(mask, d, grid, backend="cpu", mode="single", **kw)
    np.testing.assert_array_equal(hier, single)
    np.testing.assert_array_equal(gpu, hier)
    return gpu, gi, si


def assert_truth(shape, classes, d, grid, s):
    """The claims of the module docstring, against the vector curve."""
    last = grid.n_levels - 1
    jj, ii = np.divmod(np.arange(grid.width * grid.height), grid.width)
    dist = distance_xyz(shape, grid.centers(last, jj, ii))
    cls = classes.ravel()
    assert not np.any((cls == CONTAINED) & (dist > d)), "contained but farther than d"
    assert not np.any((cls == OUTSIDE) & (dist <= d)), "within d but outside"
    # outside pixels near the offset: their whole rectangle is farther than d
    near = np.flatnonzero((cls == OUTSIDE) & (dist <= d + 4 * s))
    for fx, fy in [(0, 0), (1, 0), (0, 1), (1, 1), (0.5, 0), (0, 0.5), (1, 0.5), (0.5, 1)]:
        j, i = np.divmod(near, grid.width)
        lat = np.degrees(grid.pixel_lat(j + fy))
        lon = np.degrees(grid.pixel_lon(i + fx))
        assert np.all(distance_xyz(shape, lonlat_to_xyz(lon, lat)) > d)
    return dist


@pytest.mark.parametrize(
    "name, size, d",
    [
        ("Fiji", 512, 0.03),  # across the antimeridian, islands
        ("Russia", 256, 0.06),  # across the antimeridian, long border
        ("Antarctica", 256, 0.08),  # round the south pole
        ("Mexico", 512, 0.02),
        ("Chile", 512, 0.06),  # fjords: the region growing regrows where it breaks down
    ],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_world_borders_gpu_equals_cpu_and_truth(world, name, size, d):
    grid = Equirect(size, size // 2)
    shape = gloffset.read(world[name])
    mask, parts = rasterize(shape, grid, ordered=True)
    classes, gi, si = all_ways(mask, d, grid, parts)
    assert si.method in ("region-growing", "fallback")
    assert np.count_nonzero(classes == CONTAINED) > 0
    assert_truth(shape, classes, d, grid, gi.s)
    # the walk order changes nothing: a depth-first walk of the mask gives the same classes
    np.testing.assert_array_equal(
        raster_offset(mask, d, grid, radius=1.0, backend="cpu", mode="single"), classes
    )


def test_antimeridian_regional_grid_and_pole_ring():
    grid = Equirect(384, 256, (150.0, -40.0, -150.0, 20.0))  # W > E: across 180 deg
    line = gloffset.read(
        {"type": "LineString", "coordinates": [[160, -30], [179.5, -5], [-170, 10], [-160, -20]]}
    )
    mask, parts = rasterize(line, grid, ordered=True)
    assert mask[:, :192].any() and mask[:, 192:].any()
    classes, gi, _ = all_ways(mask, 0.05, grid, parts)
    assert_truth(line, classes, 0.05, grid, gi.s)

    lon = (np.linspace(0, 360, 40, endpoint=False) + 180.0) % 360.0 - 180.0
    ring = gloffset.Shape.from_lonlat(lon, np.full_like(lon, 75.0), closed=True)
    mask, parts = rasterize(ring, WORLD, ordered=True)
    classes, gi, _ = all_ways(mask, 0.1, WORLD, parts)
    assert_truth(ring, classes, 0.1, WORLD, gi.s)


def test_self_intersecting_curve_falls_back_with_the_same_classes():
    # a loop of radius 5 deg, then a diameter through its centre: with d = 0.15 rad the
    # centre lies deep inside the region grown along the loop, where no active frontier
    # cell is within d_max (the paper's breakdown)
    t = np.linspace(0, 2 * np.pi, 60)
    lon = list(20 + 5 * np.cos(t) / np.cos(np.radians(10))) + [20 - 5 / np.cos(np.radians(10))]
    lat = list(10 + 5 * np.sin(t)) + [10.0]
    curve = gloffset.read(
        {"type": "LineString", "coordinates": np.column_stack([lon, lat]).tolist()}
    )
    mask, parts = rasterize(curve, WORLD, ordered=True)
    classes, gi, si = all_ways(mask, 0.15, WORLD, parts)
    assert si.method == "fallback" and "empty active frontier" in si.reason
    assert_truth(curve, classes, 0.15, WORLD, gi.s)


def test_hierarchy_is_consistent_across_levels():
    shape = gloffset.read({"type": "LineString", "coordinates": [[-40, -10], [10, 30], [50, 0]]})
    mask = rasterize(shape, WORLD)
    last = WORLD.n_levels - 1
    fine = raster_offset(mask, 0.05, WORLD, radius=1.0)
    for lev in range(last):
        coarse = raster_offset(mask, 0.05, WORLD, radius=1.0, level=lev)
        np.testing.assert_array_equal(
            coarse, raster_offset(mask, 0.05, WORLD, radius=1.0, level=lev, backend="cpu")
        )
        b = WORLD.block(lev)
        up = np.repeat(np.repeat(coarse, b, 0), b, 1)[: WORLD.height, : WORLD.width]
        decided = up != FRONTIER
        np.testing.assert_array_equal(fine[decided], up[decided])


def test_rasterize_is_conservative_and_tight():
    rng = np.random.default_rng(7)
    grid = Equirect(720, 360, (-60.0, -50.0, 60.0, 70.0))
    lon = rng.uniform(-55, 55, 12)
    lat = rng.uniform(-45, 65, 12)
    line = gloffset.Shape.from_lonlat(lon, lat)
    mask = rasterize(line, grid)
    e = line.edges()
    # every point of the arcs lies in a marked pixel
    t = np.linspace(0, 1, 4000)
    for a, b in zip(e.a, e.b):
        p = slerp(a[None], b[None], t).reshape(-1, 3)
        lo = np.degrees(np.arctan2(p[:, 1], p[:, 0]))
        la = np.degrees(np.arcsin(p[:, 2]))
        i = np.floor((lo + 60.0) / 120.0 * 720).astype(int)
        j = np.floor((70.0 - la) / 120.0 * 360).astype(int)
        assert mask[j, i].all()
    # and every marked pixel's rectangle comes within its area bound of an arc
    j, i = np.nonzero(mask)
    c = grid.centers(grid.n_levels - 1, j, i)
    dist = arc_distance(c[:, None], e.a[None], e.b[None]).min(axis=1)
    assert np.all(dist <= grid.area_rho_cells(grid.n_levels - 1, j * grid.width) + 1e-9)


def test_small_example_and_errors():
    g = Equirect(64, 32)
    m = np.zeros(g.shape, dtype=bool)
    m[16, 20:40] = True
    c = gloffset.raster_offset(m, 1500e3, g)
    assert c.dtype == np.uint8 and c.shape == g.shape
    assert c[16, 30] == CONTAINED and c[0, 0] == OUTSIDE
    with pytest.raises(InvalidMaskError, match="shape"):
        raster_offset(m[:, :10], 1e5, g)
    with pytest.raises(InvalidMaskError, match="dtype"):
        raster_offset(m.astype(float), 1e5, g)
    with pytest.raises(InvalidMaskError, match="empty"):
        raster_offset(np.zeros_like(m), 1e5, g)
    for bad in (-5.0, 0.0, float("nan"), "far"):
        with pytest.raises(InvalidDistanceError):
            raster_offset(m, bad, g)
    with pytest.raises(ValueError, match="backend"):
        raster_offset(m, 1e5, g, backend="tpu")


def test_cli_from_raster(tmp_path):
    img = np.zeros((128, 256), dtype=np.uint8)
    img[64, 20:200] = 255
    img[10:100, 128] = 128  # at least half white: curve
    img[100:120, 60] = 127  # darker: not curve
    src = tmp_path / "curve.png"
    Image.fromarray(img).save(src)
    out, out_mask = tmp_path / "classes.png", tmp_path / "mask.png"
    run = CliRunner().invoke
    r = run(main, ["render", "--from-raster", str(src), "-d", "400km", "-o", str(out)])
    assert r.exit_code == 0, r.output
    r = run(
        main,
        ["render", "--from-raster", str(src), "-d", "400km", "--mask-only", "-o", str(out_mask)],
    )
    assert r.exit_code == 0, r.output
    want = raster_offset(img >= 128, 400e3, Equirect(256, 128))
    rgba = np.asarray(Image.open(out))
    assert (rgba[want == CONTAINED] == (0, 0, 0, 255)).all()
    assert (rgba[want == FRONTIER] == (220, 30, 30, 255)).all()
    assert (rgba[want == OUTSIDE] == (255, 255, 255, 255)).all()
    np.testing.assert_array_equal(np.asarray(Image.open(out_mask)), np.where(want == 2, 255, 0))
    r = run(main, ["render", "-d", "400km", "-o", str(out)])
    assert r.exit_code == 2 and "--from-raster" in r.output
    # on the ellipsoid: geodesic metres, the classes of raster_offset(..., ellipsoid=)
    args = ["render", "--from-raster", str(src), "-d", "400km", "--ellipsoid", "WGS84"]
    r = run(main, [*args, "--mask-only", "-o", str(out_mask)])
    assert r.exit_code == 0, r.output
    want_e = raster_offset(img >= 128, 400e3, Equirect(256, 128), ellipsoid="WGS84")
    np.testing.assert_array_equal(np.asarray(Image.open(out_mask)), np.where(want_e == 2, 255, 0))
    assert (want_e != want).any()
    r = run(main, [*args[:-2], "--ellipsoid", "WGS84", "-d", "0.1rad", "-o", str(out)])
    assert r.exit_code == 2 and "angle" in r.output


# ---------------------------------------------------------------------------- cube grids
def cube_centres(n):
    """(6, n, n, 3) pixel centres of Cube(n), from CubeFace (what gloffset.raster.render uses)."""
    jj, ii = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    faces = [CubeFace(f, n) for f in range(6)]
    return np.stack([f.centers(f.n_levels - 1, jj, ii) for f in faces])


def assert_cube_truth(shape, classes, d, n, s):
    """Contained centres within d, centres within d not outside, outside centres farther
    than d + s (so every point within s of them, the whole pixel when its own bound is
    at most s, is farther than d: checked at the corners of those pixels)."""
    dist = distance_xyz(shape, cube_centres(n).reshape(-1, 3)).reshape(6, n, n)
    assert not np.any((classes == CONTAINED) & (dist > d)), "contained but farther than d"
    assert not np.any((classes == OUTSIDE) & (dist <= d)), "within d but outside"
    out = classes == OUTSIDE
    assert np.all(dist[out] > d + s)
    f, j, i = np.nonzero(out & (dist <= d + 4 * s))
    small = CubeFace(0, n).area_rho_at(CubeFace(0, n).n_levels - 1, j, i) <= s
    f, j, i = f[small], j[small], i[small]
    for dx in (0, 1):
        for dy in (0, 1):
            p = face_points(f, i + dx, j + dy, n)
            assert np.all(distance_xyz(shape, p) > d)
    return dist


def corner_circle(radius_deg=6.0, corner=(1.0, 1.0, 1.0), k=72):
    """A small circle round a cube corner: it crosses three faces and three face edges."""
    c = np.asarray(corner) / np.linalg.norm(corner)
    a = np.cross(c, [0.0, 0.0, 1.0])
    a /= np.linalg.norm(a)
    b = np.cross(c, a)
    t = np.linspace(0, 2 * np.pi, k, endpoint=False)[:, None]
    r = np.radians(radius_deg)
    p = np.cos(r) * c + np.sin(r) * (np.cos(t) * a + np.sin(t) * b)
    lon, lat = np.degrees(np.arctan2(p[:, 1], p[:, 0])), np.degrees(np.arcsin(p[:, 2]))
    return gloffset.Shape.from_lonlat(lon, lat, closed=True)


@pytest.mark.parametrize(
    "name, size, d",
    [
        ("Iraq", 128, 0.03),  # round the cube corner (1, 1, 1): three faces
        ("Japan", 128, 0.02),  # islands round the corner (-1, 1, 1)
        ("Iraq", 90, 0.05),  # 90 = 23 * 4: faces padded to 92 rows inside
    ],
)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_cube_world_borders_gpu_equals_cpu_and_truth(world, name, size, d):
    grid = Cube(size)
    shape = gloffset.read(world[name])
    mask, parts = rasterize(shape, grid, ordered=True)
    assert mask.shape == (6, size, size)
    assert np.count_nonzero(mask.any(axis=(1, 2))) == 3  # the curve crosses face edges
    classes, gi, si = all_ways(mask, d, grid, parts)
    assert classes.shape == (6, size, size) and classes.dtype == np.uint8
    assert si.method == "region-growing", si.reason
    on = np.count_nonzero((classes != OUTSIDE).any(axis=(1, 2)))
    assert on >= 3 and np.count_nonzero(classes == CONTAINED) > 0
    assert_cube_truth(shape, classes, d, size, gi.s)
    # the walk order changes nothing
    np.testing.assert_array_equal(
        raster_offset(mask, d, grid, radius=1.0, backend="cpu", mode="single"), classes
    )


@pytest.mark.parametrize("size", [64, 70])
def test_cube_corner_circle_and_pole_line(size):
    grid = Cube(size)
    circle = corner_circle()
    mask, parts = rasterize(circle, grid, ordered=True)
    assert list(np.flatnonzero(mask.any(axis=(1, 2)))) == [0, 2, 4]  # +X, +Y, +Z
    classes, gi, _ = all_ways(mask, 0.05, grid, parts)
    dist = assert_cube_truth(circle, classes, 0.05, size, gi.s)
    assert np.count_nonzero(classes == CONTAINED) > 0.5 * np.count_nonzero(dist <= 0.05)
    # a line over the north pole, across +Z and its edges with +X and -X
    line = gloffset.read({"type": "LineString", "coordinates": [[0, 30], [0, 89], [180, 40]]})
    mask, parts = rasterize(line, grid, ordered=True)
    assert list(np.flatnonzero(mask.any(axis=(1, 2)))) == [0, 1, 4]
    classes, gi, _ = all_ways(mask, 0.1, grid, parts)
    assert_cube_truth(line, classes, 0.1, size, gi.s)


@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_cube_1024_gpu_equals_cpu_and_sampled_truth(world):
    """Deeper GPU levels (bins of 16 pixels below level 1) on six 1024 faces; the
    containment contract on a sample of the cells near the curve."""
    grid = Cube(1024)
    shape = gloffset.read(world["Japan"])
    mask, parts = rasterize(shape, grid, ordered=True)
    gpu, gi = raster_offset(mask, 0.01, grid, radius=1.0, order=parts, return_info=True)
    cpu = raster_offset(mask, 0.01, grid, radius=1.0, order=parts, backend="cpu")
    np.testing.assert_array_equal(gpu, cpu)
    assert len(gi.frontier) == CubeFace(0, 1024).n_levels
    # a sample of the pixels whose level-2 ancestor (8 x 8 pixels) is not outside at 2 d
    rng = np.random.default_rng(3)
    coarse = raster_offset(mask, 0.02, grid, radius=1.0, level=2) != OUTSIDE
    near = np.flatnonzero(np.repeat(np.repeat(coarse, 8, 1), 8, 2).ravel())
    f, r = np.divmod(rng.choice(near, 30000, replace=False), 1024 * 1024)
    j, i = np.divmod(r, 1024)
    dist = distance_xyz(shape, face_points(f, i + 0.5, j + 0.5, 1024))
    cls = gpu[f, j, i]
    assert np.count_nonzero(cls == CONTAINED) > 1000 and np.count_nonzero(cls == OUTSIDE) > 1000
    assert not np.any((cls == CONTAINED) & (dist > 0.01))
    assert not np.any((cls == OUTSIDE) & (dist <= 0.01 + gi.s))


def test_cube_hierarchy_is_consistent_across_levels():
    grid = Cube(128)
    mask = rasterize(corner_circle(10.0, (-1.0, 1.0, -1.0)), grid)
    fine = raster_offset(mask, 0.04, grid, radius=1.0)
    single = raster_offset(mask, 0.04, grid, radius=1.0, backend="cpu", mode="single")
    np.testing.assert_array_equal(fine, single)
    face = CubeFace(0, 128)
    sides = [-(-128 // face.block(k)) for k in range(face.n_levels)]
    for lev in range(face.n_levels - 1):
        coarse = raster_offset(mask, 0.04, grid, radius=1.0, level=lev)
        np.testing.assert_array_equal(
            coarse, raster_offset(mask, 0.04, grid, radius=1.0, level=lev, backend="cpu")
        )
        assert coarse.shape == (6, sides[lev], sides[lev])
        b = face.block(lev)
        up = np.repeat(np.repeat(coarse, b, 1), b, 2)[:, :128, :128]
        decided = up != FRONTIER
        assert np.count_nonzero(decided) > 0.9 * up.size
        np.testing.assert_array_equal(fine[decided], up[decided])
    # the callback gets every level in the (6, n, n) layout
    got = []
    raster_offset(mask, 0.04, grid, radius=1.0, callback=lambda lev, c: got.append(c.shape))
    assert got == [(6, n, n) for n in sides]


def test_cube_rasterize_is_conservative_and_tight():
    rng = np.random.default_rng(11)
    n = 96
    grid = Cube(n)
    line = gloffset.Shape.from_lonlat(rng.uniform(-180, 180, 10), rng.uniform(-80, 80, 10))
    mask, parts = rasterize(line, grid, ordered=True)
    assert mask.any(axis=(1, 2)).sum() >= 4
    e = line.edges()
    last = CubeFace(0, n).n_levels - 1
    # every point of the arcs lies in a marked pixel
    t = np.linspace(0, 1, 3000)
    for a, b in zip(e.a, e.b):
        f, j, i = cell_at(n, last, slerp(a[None], b[None], t).reshape(-1, 3))
        assert mask[f, j, i].all()
    # every marked pixel comes within its own area bound of an arc
    f, j, i = np.nonzero(mask)
    c = cube_centres(n)[f, j, i]
    dist = arc_distance(c[:, None], e.a[None], e.b[None]).min(axis=1)
    assert np.all(dist <= CubeFace(0, n).area_rho_at(last, j, i) + 1e-12)
    # the order lists every marked pixel, as flat indices of the (6, n, n) mask
    order = np.concatenate(parts)
    np.testing.assert_array_equal(np.unique(order), np.flatnonzero(mask.ravel()))


def test_cube_cells_neighbours_touch_across_face_edges():
    for size, level in ((64, 1), (64, 0), (90, 1)):
        cells = CubeCells(size)
        face = CubeFace(0, size)
        keys, table = cells.edge_neighbours(level)
        assert len(keys) == 6 * (4 * cells.n[level] - 4)
        a = np.repeat(keys, 8)
        b = table.ravel()
        a, b = a[b >= 0], b[b >= 0]
        fa, ja, ia = cells.split(level, a)
        fb, jb, ib = cells.split(level, b)
        assert np.all(fa != fb)
        # touching cells: centres no farther apart than the sum of their area bounds
        ca = cells.centers(level, fa * cells.P[level] + ja, ia)
        cb = cells.centers(level, fb * cells.P[level] + jb, ib)
        reach = face.area_rho_at(level, ja, ia) + face.area_rho_at(level, jb, ib)
        assert np.all(angle(ca, cb) <= reach * (1 + 1e-9))
        # every border cell has neighbours on other faces; corner cells on two of them
        per = [len(set(fb[a == k])) for k in keys]
        assert min(per) >= 1
        corner = fb[a == keys[0]] // 1  # cell (0, 0) of face +X
        assert len(set(corner.tolist())) == 2
        # symmetric where the blocks line up on both sides of the edge
        if size % face.block(level) == 0:
            pairs = set(zip(a.tolist(), b.tolist()))
            assert all((q, p) in pairs for p, q in pairs)


def test_cube_offset_shader_is_accurate():
    """lib/cube.glsl's cube_offset, called as raster_classify.frag (GRID_CUBE) calls it,
    is within the 2e-6 relative error that lib/chord.glsl's bounds assume."""
    ctx = get_context()
    rng = np.random.default_rng(5)
    m = 512
    prog = program(ctx, "fullscreen.vert", "probe_cube.frag", root=GLSL)
    errs = []
    for face in range(6):
        size = int(rng.choice([64, 1000, 4096, 16384]))
        bin_block = int(rng.choice([2, 16, 256]))
        k = rng.integers(1, 5, m)  # the level: 2^k cells a bin side
        block = bin_block / 2.0**k
        ib = rng.integers(0, max(1, size // bin_block), (2, m))
        bxy = (ib + 0.5) * bin_block  # bin centres, output pixels
        cxy = ib * bin_block + (np.floor(rng.uniform(0, 2.0**k, (2, m))) + 0.5) * block
        data = np.stack([bxy[0], bxy[1], cxy[0] - bxy[0], cxy[1] - bxy[1]], axis=1)
        assert np.array_equal(data.astype(np.float32), data)  # exact, as in the shader
        tex = ctx.texture((m, 1), 4, data.astype(np.float32).tobytes(), dtype="f4")
        target = ctx.texture((m, 1), 4, dtype="f4")
        fbo = ctx.framebuffer(color_attachments=[target])
        prog["u_in"] = 0
        for name, axis in zip(("u_face_e", "u_face_u", "u_face_v"), FACES[face]):
            prog[name].value = tuple(float(x) for x in axis)
        prog["u_px"].value = 2.0 / size
        tex.use(0)
        fbo.use()
        ctx.viewport = (0, 0, m, 1)
        ctx.vertex_array(prog, []).render(vertices=3)
        got = np.frombuffer(target.read(), dtype=np.float32).reshape(m, 4)[:, :3].astype(float)
        want = face_points(face, cxy[0], cxy[1], size) - face_points(face, bxy[0], bxy[1], size)
        errs.append(np.linalg.norm(got - want, axis=1) / np.linalg.norm(want, axis=1))
        for r in (fbo, target, tex):
            r.release()
    assert np.max(np.concatenate(errs)) < 2e-6


def write_faces(folder, faces, names=FACE_NAMES):
    folder.mkdir(parents=True, exist_ok=True)
    for name, img in zip(names, faces):
        Image.fromarray(np.where(img, 255, 0).astype(np.uint8)).save(folder / f"{name}.png")


def test_cli_from_raster_cube_round_trip(tmp_path):
    grid = Cube(64)
    mask = rasterize(corner_circle(8.0, (-1.0, -1.0, 1.0)), grid)
    write_faces(tmp_path / "in", mask)
    run = CliRunner().invoke
    args = ["render", "--from-raster", str(tmp_path / "in"), "--grid", "cube", "-d", "300km"]
    r = run(main, [*args, "-o", str(tmp_path / "classes")])
    assert r.exit_code == 0, r.output
    r = run(main, [*args, "--mask-only", "-o", str(tmp_path / "mask")])
    assert r.exit_code == 0, r.output
    want = raster_offset(mask, 300e3, grid)
    assert {k: np.count_nonzero(want[k] != OUTSIDE) > 0 for k in range(6)} == {
        0: False,
        1: True,
        2: False,
        3: True,
        4: True,
        5: False,
    }
    for k, name in enumerate(FACE_NAMES):
        rgba = np.asarray(Image.open(tmp_path / "classes" / f"{name}.png"))
        assert rgba.shape == (64, 64, 4)
        assert (rgba[want[k] == CONTAINED] == (0, 0, 0, 255)).all()
        assert (rgba[want[k] == FRONTIER] == (220, 30, 30, 255)).all()
        assert (rgba[want[k] == OUTSIDE] == (255, 255, 255, 255)).all()
        got = np.asarray(Image.open(tmp_path / "mask" / f"{name}.png"))
        np.testing.assert_array_equal(got, np.where(want[k] == CONTAINED, 255, 0))
    # a coarse level of the classes, on the CPU backend
    r = run(main, [*args, "--classes", "0", "--backend", "cpu", "-o", str(tmp_path / "c0")])
    assert r.exit_code == 0, r.output
    want0 = raster_offset(mask, 300e3, grid, level=0)
    got0 = np.asarray(Image.open(tmp_path / "c0" / "nz.png"))
    assert got0.shape == (32, 32, 4)
    assert (got0[want0[5] == OUTSIDE] == (255, 255, 255, 255)).all()


def test_cube_errors(tmp_path):
    grid = Cube(32)
    m = np.zeros(grid.shape, dtype=bool)
    m[4, 10, 5:20] = True
    with pytest.raises(InvalidMaskError, match=r"\(6, 32, 32\)"):
        raster_offset(m[:5], 1e5, grid)
    with pytest.raises(InvalidMaskError, match="shape"):
        raster_offset(m[0], 1e5, grid)
    with pytest.raises(InvalidMaskError, match="empty"):
        raster_offset(np.zeros_like(m), 1e5, grid)
    with pytest.raises(InvalidMaskError, match="dtype"):
        raster_offset(m.astype(np.float32), 1e5, grid)
    with pytest.raises(RasterOffsetError, match="level"):
        raster_offset(m, 1e5, grid, level=3)
    with pytest.raises(RasterOffsetError, match="Equirect or Cube"):
        rasterize({"type": "LineString", "coordinates": [[0, 0], [1, 1]]}, CubeFace(0, 32))

    run = CliRunner().invoke

    def cli(src, *extra):
        args = ["render", "--from-raster", str(src), "--grid", "cube", "-d", "100km"]
        r = run(main, [*args, *extra, "-o", str(tmp_path / "out")])
        assert r.exit_code == 2, r.output
        assert "gloffset: error: " in r.output  # one line, no traceback
        return r.output

    good = [np.zeros((32, 32), bool)] * 6
    write_faces(tmp_path / "missing", good[:4])
    assert "missing" in cli(tmp_path / "missing") and "pz.png, nz.png" in cli(tmp_path / "missing")
    write_faces(tmp_path / "oblong", [np.zeros((32, 40), bool)] * 6)
    assert "px.png is 40x32" in cli(tmp_path / "oblong") and "square" in cli(tmp_path / "oblong")
    write_faces(tmp_path / "sizes", good[:5] + [np.zeros((16, 16), bool)])
    assert "one size" in cli(tmp_path / "sizes") and "nz.png 16" in cli(tmp_path / "sizes")
    write_faces(tmp_path / "empty", good)
    assert "empty" in cli(tmp_path / "empty")
    (tmp_path / "empty" / "notes.txt").write_text("x")
    assert "not a folder" in cli(tmp_path / "empty" / "notes.txt")
    (tmp_path / "bad").mkdir()
    for name in FACE_NAMES:
        (tmp_path / "bad" / f"{name}.png").write_text("not a png")
    assert "cannot read mask image" in cli(tmp_path / "bad")
    assert "--bounds" in cli(tmp_path / "empty", "--bounds", "0,0,10,10")
    r = run(main, ["render", "--from-raster", str(tmp_path / "empty"), "-d", "1km", "-o", "x.png"])
    assert r.exit_code == 2 and "--grid cube" in r.output


def test_an_unknown_option_is_refused_naming_the_documented_ones(world):
    """``raster_offset(**options)`` refuses a misspelt option, listing every option its
    docstring documents; the options it takes reach the offset (``level``, ``order``,
    ``callback``: a level's classes are those the whole run called back with)."""
    grid = Equirect(512, 256)
    mask, parts = rasterize(gloffset.read(world["Chile"]), grid, ordered=True)
    assert_options_refused(
        lambda: raster_offset(mask, "127km", grid, sise=64), raster_offset, "raster_offset"
    )
    coarse, info = raster_offset(
        mask, "127km", grid, backend="cpu", level=3, order=parts, return_info=True
    )
    assert coarse.shape == grid.level_shape(3) and info.backend == "cpu"
    seen: dict = {}
    full = raster_offset(mask, "127km", grid, backend="cpu", callback=seen.setdefault)
    np.testing.assert_array_equal(seen[3], coarse)
    assert np.count_nonzero(full == CONTAINED) > 0 and np.count_nonzero(coarse == FRONTIER) > 0
