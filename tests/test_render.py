"""The GPU raster engine against the float64 reference, pixel by pixel and level by level."""

import numpy as np
import pytest
from conftest import LINES, SQUARE_WITH_HOLE

import gloffset
from gloffset.grids import Equirect
from gloffset.raster.render import RenderError
from gloffset.raster.vector.levels import CONTAINED, FRONTIER, OUTSIDE
from gloffset.reference import contains_xyz, distance_xyz

EPS = 1e-3  # of a pixel: the band around the boundary where float32 may differ


def pixel_centers(grid):
    jj, ii = np.meshgrid(np.arange(grid.height), np.arange(grid.width), indexing="ij")
    return grid.centers(grid.n_levels - 1, jj.ravel(), ii.ravel())


def boundary_distance(shape, p):
    """Distance to ring edges including seams (where the inside status changes)."""
    from gloffset.edges import CurveArcs
    from gloffset.geometry.sphere import arc_distance

    arcs = CurveArcs.from_shape(shape)
    ring = arcs.group >= 0
    if not ring.any():
        return np.full(len(p), np.inf)
    a, b = arcs.a[ring], arcs.b[ring]
    out = np.full(len(p), np.inf)
    for s in range(0, len(a), 256):
        out = np.minimum(
            out, arc_distance(p[:, None], a[None, s : s + 256], b[None, s : s + 256]).min(axis=1)
        )
    return out


def assert_matches_reference(shape, d, grid, mask=None):
    """GPU mask == brute-force reference except within EPS of a pixel of the boundary."""
    if mask is None:
        mask = gloffset.render(shape, d, grid, radius=1.0)
    assert mask.shape == (grid.height, grid.width) and mask.dtype == np.uint8
    assert set(np.unique(mask)) <= {0, 255}
    p = pixel_centers(grid)
    want = contains_xyz(shape, p, d).reshape(grid.shape)
    bad = np.flatnonzero((mask.ravel() == 255) != want.ravel())
    if len(bad):
        eps = EPS * grid.dlat
        near_offset = np.abs(distance_xyz(shape, p[bad]) - abs(d)) <= eps
        near_edge = boundary_distance(shape, p[bad]) <= eps
        assert np.all(near_offset | near_edge), f"{len(bad)} pixels differ beyond the epsilon"
    return mask, want


@pytest.mark.parametrize(
    "geom, d, size",
    [
        (SQUARE_WITH_HOLE, 0.0, (256, 128)),
        (SQUARE_WITH_HOLE, 0.05, (300, 150)),
        (SQUARE_WITH_HOLE, -0.03, (257, 131)),
        (LINES, 0.04, (256, 128)),
        ({"type": "Point", "coordinates": [30, 60]}, 0.2, (200, 100)),
    ],
)
def test_synthetic_shapes(geom, d, size):
    mask, want = assert_matches_reference(gloffset.read(geom), d, Equirect(*size))
    assert want.any() and not want.all()


@pytest.mark.parametrize(
    "name, d, size, bounds",
    [
        ("Fiji", 0.03, (256, 128), (-180, -90, 180, 90)),
        ("Fiji", 0.01, (200, 160), (170, -25, -170, -10)),  # across the antimeridian
        pytest.param("Russia", 0.02, (512, 256), (-180, -90, 180, 90), marks=pytest.mark.slow),
        ("Russia", -0.01, (300, 200), (160, 55, -160, 75)),
        ("Antarctica", 0.03, (256, 128), (-180, -90, 180, 90)),
        ("Antarctica", -0.02, (256, 96), (-180, -90, 180, -60)),  # round the pole
        ("Italy", 0.002, (240, 240), (6, 36, 19, 47.5)),
        ("Chile", 0.0, (128, 256), (-80, -56, -66, -17)),
    ],
)
def test_world_borders(world, name, d, size, bounds):
    mask, want = assert_matches_reference(gloffset.read(world[name]), d, Equirect(*size, bounds))
    assert want.any()


@pytest.mark.parametrize(
    "half_deg",
    [pytest.param(1e-2, marks=pytest.mark.slow), 1e-4, pytest.param(1e-6, marks=pytest.mark.slow)],
)
def test_small_regional_bounds(mexico_path, half_deg):
    """Pixels from about 40 m down to 4 mm wide, on the offset boundary of Mexico."""
    shape = gloffset.read(mexico_path)
    d = 0.02
    # a point on the offset boundary: 0.02 rad from the coast, found with the reference
    lon0 = -98.0

    def excess(lat):
        return float(gloffset.distance(shape, lon0, lat, radius=1.0)) - d

    lo, hi = 15.8, 12.0  # within d of the coast at lo, beyond it at hi
    assert excess(lo) < 0 < excess(hi)
    for _ in range(60):  # bisection to float64 resolution
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if excess(mid) < 0 else (lo, mid)
    c = (lon0, lo)
    grid = Equirect(96, 96, (c[0] - half_deg, c[1] - half_deg, c[0] + half_deg, c[1] + half_deg))
    mask, want = assert_matches_reference(shape, d, grid)
    assert want.any() and not want.all()  # the boundary runs through the window


def test_levels_never_contradict_the_reference(world):
    shape = gloffset.read(world["Indonesia"])
    grid = Equirect(512, 256, (90, -15, 145, 10))
    d = 0.01
    levels = {}
    mask = gloffset.render(
        shape, d, grid, radius=1.0, callback=lambda lv, c: levels.__setitem__(lv, c.copy())
    )
    want = contains_xyz(shape, pixel_centers(grid), d).reshape(grid.shape)
    assert sorted(levels) == list(range(grid.n_levels))
    for lev, cls in levels.items():
        b = grid.block(lev)
        up = np.repeat(np.repeat(cls, b, 0), b, 1)[: grid.height, : grid.width]
        assert not np.any((up == CONTAINED) & ~want), lev
        assert not np.any((up == OUTSIDE) & want), lev
    assert (levels[grid.n_levels - 1] != FRONTIER).all()
    assert np.array_equal(levels[grid.n_levels - 1] == CONTAINED, mask == 255)
    # frontier cells shrink to a band: most of the finest level is decided early
    assert (levels[grid.n_levels - 2] == FRONTIER).mean() < 0.2


def test_classes_output_and_cpu_backend(world):
    shape = gloffset.read(world["Madagascar"])
    grid = Equirect(256, 256, (40, -28, 53, -10))
    mask = gloffset.render(shape, 0.01, grid, radius=1.0)
    cpu = gloffset.render(shape, 0.01, grid, radius=1.0, backend="cpu")
    assert np.array_equal(mask, cpu)
    cls = gloffset.render(shape, 0.01, grid, radius=1.0, out="classes", level=2)
    assert cls.shape == grid.level_shape(2)
    assert set(np.unique(cls)) == {OUTSIDE, FRONTIER, CONTAINED}


def test_tiles_give_the_same_image(world):
    shape = gloffset.read(world["Japan"])
    grid = Equirect(300, 200, (125, 25, 150, 46))
    whole = gloffset.render(shape, 0.01, grid, radius=1.0)
    tiled = gloffset.render(shape, 0.01, grid, radius=1.0, tile=64)
    # tiles recompute their own hierarchy; pixel centres agree to rounding
    assert np.count_nonzero(whole != tiled) <= 2


def test_metres_and_mexico_10m(mexico_path):
    shape = gloffset.read(mexico_path)
    grid = Equirect(400, 300, (-118, 14, -86, 33))
    mask = gloffset.render(shape, 127e3, grid)
    cpu = gloffset.render(shape, 127e3 / gloffset.EARTH_RADIUS, grid, radius=1.0, backend="cpu")
    assert np.array_equal(mask, cpu)


def test_records_split_over_storage_buffers(world, monkeypatch):
    """When the candidate arcs exceed one GL storage buffer they go in groups of whole
    bins, one draw each, with the same image; a single bin over the limit is an error."""
    from gloffset.errors import GLContextError
    from gloffset.gl.vector_pass import vector_passes as engine

    shape = gloffset.read(world["Japan"])
    grid = Equirect(600, 400, (125, 25, 150, 46))
    whole = gloffset.render(shape, 0.01, grid, radius=1.0)
    assert (whole == 255).any() and (whole == 0).any()
    monkeypatch.setattr(engine(), "max_records", 40)
    assert np.array_equal(gloffset.render(shape, 0.01, grid, radius=1.0), whole)
    monkeypatch.setattr(engine(), "max_records", 1)
    with pytest.raises(GLContextError, match="storage buffer"):
        gloffset.render(shape, 0.01, grid, radius=1.0)


def test_no_gl_error_left_behind(world):
    from gloffset.gl import get_context

    ctx = get_context()
    ctx.error  # noqa: B018  (start clean)
    gloffset.render(gloffset.read(world["Chile"]), 0.01, Equirect(128, 128, (-80, -56, -66, -17)))
    assert ctx.error == "GL_NO_ERROR"


def test_bad_requests():
    s = gloffset.read({"type": "Point", "coordinates": [0, 0]})
    g = Equirect(64, 32)
    with pytest.raises(RenderError, match="out must be one of"):
        gloffset.render(s, 1.0, g, out="png")
    with pytest.raises(RenderError, match="backend"):
        gloffset.render(s, 1.0, g, backend="cuda")
    with pytest.raises(RenderError, match="level must be"):
        gloffset.render(s, 1.0, g, out="classes", level=99)
    with pytest.raises(RenderError, match="more than"):
        gloffset.render(s, 1.0, Equirect(70000, 40000))
    with pytest.raises(gloffset.InvalidDistanceError, match="1.5 rad"):
        gloffset.render(s, 2.0, g, radius=1.0)
    with pytest.raises(gloffset.grids.InvalidGridError, match="S < N"):
        Equirect(10, 10, (0, 10, 5, 5))
    with pytest.raises(gloffset.grids.InvalidGridError, match="positive"):
        Equirect(0, 10)


def test_bin_centre_on_an_edge_great_circle():
    """A bin centre exactly on the hole's meridian edge: the shader's crossing test and
    the CPU status at the centre must take the same side (once 410 pixels were wrong)."""
    shape = gloffset.read(SQUARE_WITH_HOLE)
    grid = Equirect(
        200, 256, (4.230136772928331, 2.230136772928331, 7.769863227071671, 5.769863227071671)
    )
    mask, _ = assert_matches_reference(shape, 0.000747, grid)
    np.testing.assert_array_equal(
        mask, gloffset.render(shape, 0.000747, grid, radius=1.0, backend="cpu")
    )


@pytest.mark.parametrize(
    "what, d, size",
    [
        ("Fiji", 0.1, (1024, 512)),  # across the antimeridian
        pytest.param("Antarctica", 0.06, (1024, 512), marks=pytest.mark.slow),  # round the pole
        (SQUARE_WITH_HOLE, -0.07, (800, 400)),
        (LINES, 0.05, (1024, 512)),
    ],
)
def test_wide_bins_for_wide_bands(world, what, d, size):
    """Offsets several pixels wide get 32-pixel bins; the answer is the same."""
    grid = Equirect(*size)
    assert grid.bin_level_for(abs(d)) == grid.bin_level - 1
    shape = gloffset.read(world[what] if isinstance(what, str) else what)
    mask, want = assert_matches_reference(shape, d, grid)
    assert want.any() and not want.all()
    np.testing.assert_array_equal(mask, gloffset.render(shape, d, grid, radius=1.0, backend="cpu"))


@pytest.mark.parametrize("d", [1.4, 0.9, -0.25])
def test_large_distances_keep_only_arcs_that_can_be_nearest(world, d):
    """At large distances every arc lies within d + rho of a coarse cell; the candidate
    lists keep the arcs that can be some point's nearest (hierarchy._nearest_bound), and
    the answers stay the reference's, on a globe and in a tile pyramid's grids."""
    fc = {"type": "FeatureCollection", "features": [world[n] for n in ("Chile", "Japan", "Fiji")]}
    shape = gloffset.read(fc)
    assert_matches_reference(shape, d, Equirect(256, 128))
    assert_matches_reference(shape, d, Equirect(128, 128, (170.0, -40.0, -170.0, 0.0)))
