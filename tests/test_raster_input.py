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

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import gloffset
from gloffset.cli import main
from gloffset.errors import InvalidDistanceError
from gloffset.grids import Equirect
from gloffset.raster_input import (
    CONTAINED,
    FRONTIER,
    OUTSIDE,
    InvalidMaskError,
    pixel_radius,
    raster_offset,
    rasterize,
)
from gloffset.reference import distance_xyz
from gloffset.sphere import arc_distance, lonlat_to_xyz, slerp

WORLD = Equirect(512, 256)


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
        lat = np.degrees(grid._lat_px(j + fy))
        lon = np.degrees(grid._lon_px(i + fx))
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

    lon = np.linspace(0, 360, 40, endpoint=False)
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
    assert np.all(dist <= pixel_radius(grid)[j] + 1e-9)


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
    img[10:100, 128] = 7
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
    want = raster_offset(img != 0, 400e3, Equirect(256, 128))
    rgba = np.asarray(Image.open(out))
    assert (rgba[want == CONTAINED] == (0, 0, 0, 255)).all()
    assert (rgba[want == FRONTIER] == (220, 30, 30, 255)).all()
    assert (rgba[want == OUTSIDE] == (255, 255, 255, 255)).all()
    np.testing.assert_array_equal(np.asarray(Image.open(out_mask)), np.where(want == 2, 255, 0))
    r = run(main, ["render", "-d", "400km", "-o", str(out)])
    assert r.exit_code == 2 and "--from-raster" in r.output
