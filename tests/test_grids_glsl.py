"""Grids whose GPU levels compute their cell centres in a GLSL function (``centres ==
"glsl"``): the polar stereographic grids (EPSG:3031, 3413, 3976, UPS, on the ellipsoid
or a sphere). The function against pyproj and the exact inverse at many pixels, in
double, through a compute shader; masks of the GLSL path against the float64 reference
at pyproj's pixel centres, a broken function caught by them; the texture path kept for
the other CRSs. LAEA grids: tests/test_grids_laea.py; transverse Mercator:
tests/test_grids_tm.py."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import DATA

import gloffset
from gloffset.geometry.sphere import angle, lonlat_to_xyz

pyproj = pytest.importorskip("pyproj")
from test_grids_projected import ORTHO, assert_reference, pole_rings  # noqa: E402

from gloffset.grids import Projected, TmsTile  # noqa: E402
from gloffset.grids.polar import polar_inverse, polar_params  # noqa: E402
from gloffset.grids.protocol import GlslCentres  # noqa: E402

HERE = Path(__file__).parent / "glsl"
#: the GLSL centre's distance from pyproj's (rad): PROJ's ellipsoidal inverse stops its
#: iteration at steps of 1e-10 rad, which leaves it within about 7e-13 of the exact
#: one; the GLSL function is within 1e-15 of the exact one (measured 9e-16)
PYPROJ_BOUND, EXACT_BOUND = 1e-12, 4e-15
SPHERE_3031 = "+proj=stere +lat_0=-90 +lat_ts=-71 +lon_0=0 +R=6371007 +units=m"
POLAR_CRSS = [
    "EPSG:3031",
    "EPSG:3413",  # central meridian -45
    "EPSG:3976",
    "EPSG:5041",  # UPS north: variant A, k0 0.994, false origin 2000 km
    "EPSG:32761",  # UPS south
    SPHERE_3031,
    "+proj=stere +lat_0=90 +lat_ts=70 +lon_0=-45 +R=6371007 +units=m",
    "+proj=stere +lat_0=-90 +k=0.97 +lon_0=30 +x_0=1000 +y_0=-2000 +ellps=GRS80 +units=km",
]


@pytest.fixture(scope="module")
def ctx():
    from gloffset.gl import get_context

    return get_context()


@pytest.fixture(scope="module")
def antarctica():
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    feat = next(f for f in fc["features"] if f["properties"]["name"] == "Antarctica")
    return gloffset.read(feat)


def glsl_points(ctx, glsl: GlslCentres, px: np.ndarray) -> np.ndarray:
    """``grid_centre`` of ``glsl`` at the output-pixel coordinates ``px`` (n, 2), in
    double (tests/glsl/probe_grid.comp)."""
    from gloffset.gl.shaders import load_source
    from gloffset.gl.vector_pass import set_grid_constants

    src, _ = load_source("probe_grid.comp", {"GRID_GLSL": f'"{glsl.source}"'}, root=HERE)
    prog = ctx.compute_shader(src)
    set_grid_constants(prog, glsl.constants)
    n = len(px)
    prog["u_n"] = n
    bin_ = ctx.buffer(np.ascontiguousarray(px, dtype=np.float64).tobytes())
    bout = ctx.buffer(reserve=24 * n)
    bin_.bind_to_storage_buffer(0)
    bout.bind_to_storage_buffer(1)
    prog.run(-(-n // 64))
    out = np.frombuffer(bout.read(), dtype=np.float64).reshape(n, 3).copy()
    for r in (bin_, bout, prog):
        r.release()
    return out


def probe_grid(ctx, g, px, bound, *, sub_at, sub_tol=1e-15, unit_tol=1e-15):
    """The checks every grid's GLSL function passes at the output-pixel coordinates
    ``px`` (``px[1:100]`` pixel centres): ``g`` takes it; within ``bound`` of pyproj's
    points and of the grid's float64 pixel centres; unit vectors to ``unit_tol``; the
    subgrid ``sub_at`` (x0, y0, x1, y1) gives the same points to ``sub_tol``.

    Returns ``(got, x, y)``: the GLSL points and the CRS coordinates of ``px``."""
    assert g.centres == "glsl"
    got = glsl_points(ctx, g.glsl_centres(), px)
    x, y = g.pixel_xy(px[:, 0], px[:, 1])
    lon, lat = g.transformer.transform(x, y)
    err = angle(got, lonlat_to_xyz(lon, lat))
    assert np.max(err) <= bound, np.max(err)
    assert np.max(np.abs(np.linalg.norm(got, axis=1) - 1.0)) <= unit_tol
    jj, ii = (px[1:100, 1] - 0.5).astype(int), (px[1:100, 0] - 0.5).astype(int)
    assert np.max(angle(got[1:100], g.centers(g.n_levels - 1, jj, ii))) <= bound
    sub = g.subgrid(*sub_at)
    assert sub.centres == "glsl"
    got_sub = glsl_points(ctx, sub.glsl_centres(), px[:2000] - sub_at[:2])
    assert np.max(angle(got_sub, got[:2000])) <= sub_tol
    return got, x, y


def exact_inverse(crs, x, y) -> np.ndarray:
    """The polar stereographic inverse in float64 to a few ulp: the conformal latitude
    from the plane, the geodetic one by Newton's method
    (:meth:`gloffset.ellipsoid.Ellipsoid.geodetic`), the longitude by atan2."""
    from gloffset.ellipsoid import Ellipsoid

    pp = polar_params(crs)
    X = (x - pp["fe"]) * pp["unit"] / pp["scale"]
    Y = (y - pp["fn"]) * pp["unit"] / pp["scale"]
    chi = np.pi / 2 - 2.0 * np.arctan(np.hypot(X, Y))
    phi = chi
    if pp["es"] > 0:
        ell = Ellipsoid(1.0, 1.0 - math.sqrt(1.0 - pp["es"]))
        phi = np.radians(ell.geodetic(np.degrees(chi)))
    sg = -1.0 if pp["south"] else 1.0
    lam = pp["lon0"] + np.arctan2(X, -sg * Y)
    return np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), sg * np.sin(phi)], -1)


@pytest.mark.parametrize("crs", POLAR_CRSS)
def test_glsl_centres_against_pyproj(ctx, crs):
    """At 40,000 pixels of a grid over +-9,000 km (the pole's pixel, and points beyond
    the equator, included) the GLSL centre is within PYPROJ_BOUND of pyproj's and within
    EXACT_BOUND of the exact inverse; a subgrid's function gives the same points."""
    rng = np.random.default_rng(7)
    b = (-9e6, -9e6, 9e6, 9e6) if "+units=km" not in crs else (-9e3, -9e3, 9e3, 9e3)
    g = Projected(4097, 4097, crs=crs, bounds=b)
    px = rng.uniform(0.0, 4097.0, (40000, 2))
    pp = polar_params(g.crs)  # the pole: the false origin
    px[0] = ((pp["fe"] - b[0]) * 4097 / (b[2] - b[0]), (b[3] - pp["fn"]) * 4097 / (b[3] - b[1]))
    px[1:100] = np.floor(px[1:100]) + 0.5  # pixel centres
    got, x, y = probe_grid(ctx, g, px, PYPROJ_BOUND, sub_at=(1000, 300, 2000, 3000), unit_tol=2e-15)
    assert np.max(angle(got, exact_inverse(g.crs, x, y))) <= EXACT_BOUND
    assert abs(abs(got[0, 2]) - 1.0) <= 1e-15
    # pixel centres above the output level: the float64 twin's
    assert np.max(angle(got[1:100], polar_inverse(g.crs)(x[1:100], y[1:100]))) <= 1e-13


def test_which_grids_compute_their_centres_in_glsl():
    """Polar stereographic grids and UPS tiles (subgrids too) take the GLSL function,
    and so do LAEA grids clear of the poles (tests/test_grids_laea.py), UTM grids
    with the formula bound (tests/test_grids_tm.py) and LCC grids with it below the
    cone's apex (tests/test_grids_lcc.py); the others (orthographic, Albers) the texture
    of pyproj's centres."""
    box = (-3e6, -3e6, 3e6, 3e6)
    for crs in ("EPSG:3031", "EPSG:3413", "EPSG:3976", SPHERE_3031):
        g = Projected(64, 64, crs=crs, bounds=box)
        assert g.centres == "glsl" and g.subgrid(3, 4, 20, 30).centres == "glsl"
    for tms in ("UPSArcticWGS84Quad", "UPSAntarcticWGS84Quad"):
        t = TmsTile(tms, 3, 2, 5)
        assert t.centres == "glsl"
        assert t.glsl_centres().source == "lib/grids/polar_stereographic.glsl"
    g = Projected(64, 64, crs="EPSG:3035", bounds=(2.5e6, 1.4e6, 6.5e6, 5.5e6))
    assert g.centres == "glsl"
    assert g.glsl_centres().source == "lib/grids/lambert_azimuthal.glsl"
    g = Projected(64, 64, crs="EPSG:32633", bounds=(1.0e5, 4.0e6, 9.0e5, 5.3e6))
    assert g.glsl_centres().source == "lib/grids/transverse_mercator.glsl"
    g = Projected(64, 64, crs="EPSG:3978", bounds=(-2.5e6, -1.0e6, 3.0e6, 4.0e6))
    assert g.glsl_centres().source == "lib/grids/lambert_conformal_conic.glsl"
    g = Projected(64, 64, crs="EPSG:2154", bounds=(1e5, 6.0e6, 1.2e6, 7.2e6))
    assert g.centres == "glsl" and g.subgrid(3, 4, 20, 30).centres == "glsl"
    assert Projected(64, 64, crs="EPSG:5070", bounds=(-2e6, 3e5, 2e6, 3e6)).centres == "texture"
    assert Projected(64, 64, crs=ORTHO, bounds=(-8e6, -7e6, 8e6, 8e6)).centres == "texture"


@pytest.mark.slow
@pytest.mark.parametrize("crs", ["EPSG:3031", "EPSG:3976", SPHERE_3031])
def test_glsl_and_texture_masks_are_the_reference(antarctica, crs):
    """Antarctica (the pole inside) and rings round the pole at -50 km, 0 and 50 km on a
    201 x 201 grid whose middle pixel's centre is the pole: the GLSL path's masks are
    the float64 reference's at pyproj's pixel centres, and so are the texture path's."""
    g = Projected(201, 201, crs=crs, bounds=(-3.2e6, -3.2e6, 3.2e6, 3.2e6))
    tex = Projected(201, 201, crs=crs, bounds=g.bounds)
    tex.centres = "texture"
    assert g.centres == "glsl" and g.pixel_lonlat(100, 100)[1] == -90.0
    for shape in (antarctica, gloffset.read(pole_rings())):
        for d in (-50e3, 0.0, 50e3):
            mask = gloffset.render(shape, d, g)
            want = assert_reference(shape, d, g, mask)
            assert (mask[100, 100] == 255) == want[100, 100]
            other = gloffset.render(shape, d, tex)
            if not np.array_equal(other, mask):
                assert_reference(shape, d, tex, other)


def test_a_broken_function_is_caught(antarctica, monkeypatch):
    """The masks above test the GLSL function: with the sphere's latitude on the
    ellipsoid (the series dropped, up to 0.19 deg off) or the central meridian turned
    by a pixel, the render is no longer the reference."""
    g = Projected(101, 101, crs="EPSG:3031", bounds=(-3.2e6, -3.2e6, 3.2e6, 3.2e6))
    right = g.glsl_centres()
    assert right.constants[9] > 0.0  # the series' first term, about e^2
    dropped = right.constants[:9] + (0.0,) * 6
    a = 63e3 / 2.6e6  # turned by a pixel (63 km) at 2,600 km from the pole
    ca, sa = math.cos(a), math.sin(a)
    m = right.constants[4:8]
    turned = (
        right.constants[:4]
        + (
            ca * m[0] - sa * m[2],
            ca * m[1] - sa * m[3],
            sa * m[0] + ca * m[2],
            sa * m[1] + ca * m[3],
        )
        + right.constants[8:]
    )
    for constants in (dropped, turned):
        broken = GlslCentres(right.source, constants)
        monkeypatch.setattr(Projected, "glsl_centres", lambda self, b=broken: b)
        mask = gloffset.render(antarctica, 50e3, g)
        with pytest.raises(AssertionError, match="differ from the reference"):
            assert_reference(antarctica, 50e3, g, mask)
    monkeypatch.undo()
    assert_reference(antarctica, 50e3, g, gloffset.render(antarctica, 50e3, g))


@pytest.mark.slow
@pytest.mark.parametrize(
    "tms, name, z, d",
    [
        ("UPSAntarcticWGS84Quad", "Antarctica", 2, -30e3),
        ("UPSArcticWGS84Quad", "Greenland", 4, 20e3),
    ],
)
def test_ups_tiles_on_the_glsl_path(antarctica, tms, name, z, d):
    """Frontier UPS tiles (the GLSL path) are the reference at pyproj's pixel centres
    (as in tests/test_tms.py, whose polar tiles take the GLSL path too)."""
    from test_tms import frontier_tile

    fc = json.loads((DATA / "world_110m.geojson").read_text())
    feat = next(f for f in fc["features"] if f["properties"]["name"] == name)
    shape = antarctica if name == "Antarctica" else gloffset.read(feat)
    geom = feat["geometry"]
    polys = [geom["coordinates"]] if geom["type"] == "Polygon" else geom["coordinates"]
    ring = max((p[0] for p in polys), key=len)
    x, y = frontier_tile(tms, ring[len(ring) // 3], z)
    t = TmsTile(tms, z, x, y)
    assert t.centres == "glsl"
    want = assert_reference(shape, d, t, gloffset.render(shape, d, t))
    assert want.any() and not want.all()
