"""Lambert conformal conic grids (1SP and 2SP: EPSG:3978 Canada, EPSG:2154 Lambert-93,
EPSG:3347, a southern 1SP in km, a sphere's; with the formula bound) compute their cell
centres in a GLSL function: PROJ's inverse with double log, exp, atan2, sin and cos of
lib/fp64.glsl. The helpers against numpy, the function against pyproj at many points,
masks of the GLSL path against the float64 reference at pyproj's pixel centres (the
Canada/US border), a broken function caught by them; which grids take it."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import DATA

import gloffset

pyproj = pytest.importorskip("pyproj")
from test_grids_glsl import probe_grid  # noqa: E402
from test_grids_projected import assert_glsl_and_texture_masks, assert_reference  # noqa: E402

from gloffset.grids import Projected  # noqa: E402
from gloffset.grids.conic import lcc_clear  # noqa: E402
from gloffset.grids.protocol import GlslCentres  # noqa: E402

HERE = Path(__file__).parent / "glsl"
#: the GLSL centre's distance from pyproj's (rad): 1.4e-15 measured
PYPROJ_BOUND = 1e-12
BORDER = (-2.5e6, -1.2e6, 3.0e6, 1.2e6)  # EPSG:3978: the 49th parallel, BC to Nova Scotia
LCC_CASES = [
    ("EPSG:3978", (-2.5e6, -1.0e6, 3.0e6, 4.0e6)),  # LCC 2SP, Canada
    ("EPSG:2154", (1e5, 6.0e6, 1.2e6, 7.2e6)),  # LCC 2SP, France (Lambert-93)
    ("EPSG:3347", (3.5e6, 0.5e6, 9.0e6, 5.0e6)),  # Statistics Canada
    (
        "+proj=lcc +lat_1=-33 +lat_0=-33 +lon_0=150 +k_0=0.9995 +x_0=1e5 +ellps=GRS80 +units=km",
        (-2e3, -2e3, 2e3, 2e3),
    ),
    ("+proj=lcc +lat_1=30 +lat_2=60 +lat_0=40 +lon_0=-100 +R=6371007", (-3e6, -2e6, 3e6, 3e6)),
]


@pytest.fixture(scope="module")
def ctx():
    from gloffset.gl import get_context

    return get_context()


@pytest.fixture(scope="module")
def canada():
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    return gloffset.read(next(f for f in fc["features"] if f["properties"]["name"] == "Canada"))


def test_the_log_exp_and_atan2_helpers(ctx):
    """lib/fp64.glsl at 100,000 pairs: log over [1e-300, 1e300] within 1e-16 + 2 ulp
    (absolute plus relative), the wide exp over [-700, 700] within 5 ulp (relative),
    atan2(y, x) for x > 0 within 3e-16, of numpy's (itself within an ulp)."""
    from gloffset.gl.shaders import load_source

    src, _ = load_source("probe_fp64_log.comp", root=HERE)
    prog = ctx.compute_shader(src)
    rng = np.random.default_rng(5)
    n = 100000
    a = 10.0 ** rng.uniform(-300.0, 300.0, n)
    a[: n // 2] = rng.uniform(0.5, 2.0, n // 2)  # near 1, where log cancels
    a[:4] = (1.0, np.nextafter(1.0, 2.0), np.nextafter(1.0, 0.0), 2.0**-1000)
    b = rng.uniform(-700.0, 700.0, n)
    b[n // 2 :] = rng.uniform(-5.0, 5.0, n - n // 2)
    ab = np.stack([a, b], axis=1)
    prog["u_n"] = n
    bin_ = ctx.buffer(ab.tobytes())
    bout = ctx.buffer(reserve=24 * n)
    bin_.bind_to_storage_buffer(0)
    bout.bind_to_storage_buffer(1)
    prog.run(-(-n // 64))
    got = np.frombuffer(bout.read(), dtype=np.float64).reshape(-1, 3)
    for r in (bin_, bout, prog):
        r.release()
    ulp = np.finfo(np.float64).eps
    want = np.log(a)
    assert np.all(np.abs(got[:, 0] - want) <= 1e-16 + 2 * ulp * np.abs(want))
    assert np.max(np.abs(got[:, 1] / np.exp(b) - 1.0)) <= 5 * ulp
    # atan2 with x > 0 (the a of the first half, near 1, and of the second, any size)
    xs = a[: n // 2]
    assert np.max(np.abs(got[: n // 2, 2] - np.arctan2(b[: n // 2], xs))) <= 3e-16


@pytest.mark.parametrize("crs, box", LCC_CASES)
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


def test_which_lcc_grids_take_the_glsl_function():
    """LCC grids with the formula bound, below the cone's apex, take it; a grid over the
    apex (the pole), one across the ray where the longitudes jump (no formula bound)
    and Albers grids the texture."""
    assert Projected(64, 64, crs="EPSG:3978", bounds=BORDER).centres == "glsl"
    crs = pyproj.CRS("EPSG:3978")
    apex = pyproj.Transformer.from_crs(crs.geodetic_crs, crs, always_xy=True).transform(-95, 90)
    over = (apex[0] - 1e6, apex[1] - 2e6, apex[0] + 1e6, apex[1] + 1e6)
    assert not lcc_clear(crs, over)
    g = Projected(64, 64, crs="EPSG:3978", bounds=over, check_domain=False)
    assert g.centres == "texture"
    behind = (apex[0] - 1e6, apex[1] + 1e6, apex[0] + 1e6, apex[1] + 3e6)
    g = Projected(64, 64, crs="EPSG:3978", bounds=behind, check_domain=False)
    assert g.centres == "texture" and g._lipschitz() is None
    assert Projected(64, 64, crs="EPSG:5070", bounds=(-2e6, 0.3e6, 2e6, 3e6)).centres == "texture"
    assert lcc_clear(crs, BORDER) and not lcc_clear(pyproj.CRS("EPSG:5070"), BORDER)


@pytest.mark.slow
def test_glsl_masks_of_the_border_are_the_reference(canada):
    """Canada at -50 km, 0 and 50 km on a 300 x 140 EPSG:3978 grid over its border with
    the United States: the GLSL path's masks are the float64 reference at pyproj's pixel
    centres, and so are the texture's."""
    assert_glsl_and_texture_masks(
        canada,
        Projected(300, 140, crs="EPSG:3978", bounds=BORDER),
        Projected(300, 140, crs="EPSG:3978", bounds=BORDER),
    )


def test_a_broken_function_is_caught(canada, monkeypatch):
    """The masks test the GLSL function: without the latitude series (up to 0.19 deg
    off) or with the central meridian turned by a pixel, the render of Canada's border
    is no longer the reference; right, it is."""
    g = Projected(150, 70, crs="EPSG:3978", bounds=BORDER)
    right = g.glsl_centres()
    assert right.constants[7] > 0.0  # the series' first term, about e^2
    dropped = right.constants[:7] + (0.0,) * 6
    a = 37e3 / 6.4e6 / math.cos(math.radians(49.0))  # a pixel (37 km) at 49 N
    cl, sl = right.constants[5], right.constants[6]
    turned = (
        right.constants[:5]
        + (math.cos(a) * cl - math.sin(a) * sl, math.sin(a) * cl + math.cos(a) * sl)
        + right.constants[7:]
    )
    for constants in (dropped, turned):
        broken = GlslCentres(right.source, tuple(float(c) for c in constants))
        monkeypatch.setattr(Projected, "glsl_centres", lambda self, b=broken: b)
        mask = gloffset.render(canada, 50e3, g)
        with pytest.raises(AssertionError, match="differ from the reference"):
            assert_reference(canada, 50e3, g, mask)
    monkeypatch.undo()
    assert_reference(canada, 50e3, g, gloffset.render(canada, 50e3, g))
