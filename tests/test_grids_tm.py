"""Transverse Mercator grids (UTM zones north and south, the British National Grid,
NZTM, a km grid; on the ellipsoid, with the formula bound) compute their cell centres in
a GLSL function: PROJ's inverse (Krueger's series, read from pyproj) with double exp,
sin and cos of lib/fp64.glsl. The function against pyproj at many points, masks of the
GLSL path against the float64 reference at pyproj's pixel centres (Italy), a broken
function caught by them; which grids take it."""

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import DATA

import gloffset

pyproj = pytest.importorskip("pyproj")
from test_grids_glsl import probe_grid  # noqa: E402
from test_grids_projected import assert_glsl_and_texture_masks, assert_reference  # noqa: E402

from gloffset.grids import Projected  # noqa: E402
from gloffset.grids.protocol import GlslCentres  # noqa: E402
from gloffset.grids.transverse import tm_clear  # noqa: E402

HERE = Path(__file__).parent / "glsl"
#: the GLSL centre's distance from pyproj's (rad): 1.8e-15 measured
PYPROJ_BOUND = 1e-12
ITALY = (0.0, 4.0e6, 1.2e6, 5.3e6)  # EPSG:32633, Sicily to the Alps
TM_CASES = [
    ("EPSG:32633", (-7e5, -9.5e6, 1.7e6, 9.5e6)),  # pole to pole, 1,200 km each side
    ("EPSG:32733", (-7e5, 1e5, 1.7e6, 1e7)),  # UTM 33S
    ("EPSG:27700", (-8e5, -3e6, 1.6e6, 3e6)),  # British National Grid: Airy, origin 49 N
    ("EPSG:2193", (4e5, 3e6, 2.8e6, 8e6)),  # NZTM
    (
        "+proj=tmerc +lat_0=-20 +lon_0=140 +x_0=500 +y_0=10000 +ellps=GRS80 +units=km",
        (-1.2e3, -6e3, 1.2e3, 6e3),
    ),
]


@pytest.fixture(scope="module")
def ctx():
    from gloffset.gl import get_context

    return get_context()


@pytest.fixture(scope="module")
def italy():
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    return gloffset.read(next(f for f in fc["features"] if f["properties"]["name"] == "Italy"))


def test_the_double_helpers(ctx):
    """lib/fp64.glsl at 100,000 values of [-2.5, 2.5] (the ends included): exp within 4
    ulp relative, sin and cos within 5e-16, sqrt and the reciprocal within 2 ulp, of
    numpy's (itself within an ulp)."""
    from gloffset.gl.shaders import load_source

    src, _ = load_source("probe_fp64.comp", root=HERE)
    prog = ctx.compute_shader(src)
    x = np.random.default_rng(4).uniform(-2.5, 2.5, 100000)
    x[:4] = (-2.5, 2.5, 1e-300, 1e-20)
    prog["u_n"] = len(x)
    bin_ = ctx.buffer(x.tobytes())
    bout = ctx.buffer(reserve=40 * len(x))
    bin_.bind_to_storage_buffer(0)
    bout.bind_to_storage_buffer(1)
    prog.run(-(-len(x) // 64))
    got = np.frombuffer(bout.read(), dtype=np.float64).reshape(-1, 5)
    for r in (bin_, bout, prog):
        r.release()
    ulp = np.finfo(np.float64).eps
    assert np.max(np.abs(got[:, 0] / np.exp(x) - 1.0)) <= 4 * ulp
    sc = np.abs(x) <= 2.0
    assert np.max(np.abs(got[sc, 1] - np.sin(x[sc]))) <= 5e-16
    assert np.max(np.abs(got[sc, 2] - np.cos(x[sc]))) <= 5e-16
    big = np.abs(x) >= 1e-30
    assert np.max(np.abs(got[big, 3] / np.sqrt(np.abs(x[big])) - 1.0)) <= 2 * ulp
    assert np.max(np.abs(got[4:, 4] * np.abs(x[4:]) - 1.0)) <= 2 * ulp


@pytest.mark.parametrize("crs, box", TM_CASES)
def test_glsl_centres_against_pyproj(ctx, crs, box):
    """At 40,000 points of a 1025 x 1025 grid (its pixel centres among them, and the
    corners of its cell centres' box) the GLSL centre is within PYPROJ_BOUND of
    pyproj's, a unit vector to 1e-15; a subgrid's function gives the same points."""
    g = Projected(1025, 1025, crs=crs, bounds=box)
    rng = np.random.default_rng(9)
    px = rng.uniform(0.0, 1025.0, (40000, 2))
    px[1:100] = np.floor(px[1:100]) + 0.5
    px[100:104] = [(0.5, 0.5), (1088.0, 0.5), (0.5, 1088.0), (1088.0, 1088.0)]
    probe_grid(ctx, g, px, PYPROJ_BOUND, sub_at=(100, 30, 500, 700))


def test_which_tm_grids_take_the_glsl_function():
    """Ellipsoidal transverse Mercator grids with the formula bound (every cell centre
    within 3,900 km of the central meridian) take it; wider grids, a sphere's (PROJ's
    spherical inverse is off by 8e-10 rad near the equator) and South-oriented ones the
    texture."""
    assert Projected(64, 64, crs="EPSG:32633", bounds=ITALY).centres == "glsl"
    wide = Projected(110, 60, crs="EPSG:32633", bounds=(-6e6, 4.0e6, 6e6, 5.3e6))
    assert wide.centres == "texture"
    sphere = "+proj=tmerc +lat_0=30 +lon_0=-100 +k=0.9996 +R=6371007"
    assert Projected(64, 64, crs=sphere, bounds=(-1e6, -1e6, 1e6, 1e6)).centres == "texture"
    assert not tm_clear(pyproj.CRS(sphere), (-1e6, -1e6, 1e6, 1e6))
    south = pyproj.CRS("EPSG:2053")  # Hartebeesthoek94 / Lo29: South Orientated
    assert south.coordinate_operation.method_name.endswith("(South Orientated)")
    assert not tm_clear(south, (-1e5, 3e6, 1e5, 3.2e6))
    assert tm_clear(pyproj.CRS("EPSG:32633"), (-7e5, -9.5e6, 1.7e6, 9.5e6))
    assert not tm_clear(pyproj.CRS("EPSG:32633"), (-7e5, -9.5e6, 1.7e6, 1.3e7))  # |xi| > 1.9


@pytest.mark.slow
def test_glsl_masks_of_italy_are_the_reference(italy):
    """Italy at -50 km, 0 and 50 km on a 300 x 325 UTM 33N grid: the GLSL path's masks
    are the float64 reference at pyproj's pixel centres, and so are the texture's."""
    assert_glsl_and_texture_masks(
        italy,
        Projected(300, 325, crs="EPSG:32633", bounds=ITALY),
        Projected(300, 325, crs="EPSG:32633", bounds=ITALY),
    )


def test_a_broken_function_is_caught(italy, monkeypatch):
    """The masks test the GLSL function: without Krueger's series (up to 0.05 deg off)
    or with the central meridian turned by a pixel, the render of Italy is no longer
    the reference; right, it is."""
    g = Projected(151, 163, crs="EPSG:32633", bounds=ITALY)
    right = g.glsl_centres()
    assert right.constants[6] < 0.0  # b_1, about -n / 2
    dropped = right.constants[:6] + (0.0,) * 5 + right.constants[11:]
    a = 8e3 / 6.4e6  # a pixel (8 km) on the sphere
    cl, sl = right.constants[4], right.constants[5]
    turned = (
        right.constants[:4]
        + (np.cos(a) * cl - np.sin(a) * sl, np.sin(a) * cl + np.cos(a) * sl)
        + right.constants[6:]
    )
    for constants in (dropped, turned):
        broken = GlslCentres(right.source, tuple(float(c) for c in constants))
        monkeypatch.setattr(Projected, "glsl_centres", lambda self, b=broken: b)
        mask = gloffset.render(italy, 50e3, g)
        with pytest.raises(AssertionError, match="differ from the reference"):
            assert_reference(italy, 50e3, g, mask)
    monkeypatch.undo()
    assert_reference(italy, 50e3, g, gloffset.render(italy, 50e3, g))
