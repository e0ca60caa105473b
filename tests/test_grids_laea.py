"""LAEA grids (EPSG:3035, the EuropeanETRS89_LAEAQuad tiles, every aspect, on the
ellipsoid or a sphere) compute their cell centres in a GLSL function, pyproj's inverse
through the authalic sphere with pyproj's own latitude series: the function against
pyproj at many points (the grids' clearance from the poles and the antipode included),
masks of the GLSL path against the float64 reference at pyproj's pixel centres (Europe,
frontier tiles), a broken function caught by them, the bounds' slack."""

import json
import math

import numpy as np
import pytest
from conftest import DATA

import gloffset
from gloffset.geometry.sphere import angle, lonlat_to_xyz

pyproj = pytest.importorskip("pyproj")
from test_grids_glsl import probe_grid  # noqa: E402
from test_grids_projected import assert_glsl_and_texture_masks, assert_reference  # noqa: E402

from gloffset.grids import Projected, TmsTile  # noqa: E402
from gloffset.grids.laea import LAEA_PYPROJ_BOUND, laea_clear, laea_params  # noqa: E402
from gloffset.grids.protocol import GlslCentres  # noqa: E402

EUROPE = (2.5e6, 1.4e6, 6.5e6, 5.5e6)  # EPSG:3035: the Canaries to the North Cape
SPHERE = "+proj=laea +lat_0=52 +lon_0=10 +R=6371007 +units=m"
#: CRS, a 4097 x 4097 grid's bounds where it takes the GLSL function: its cell centres
#: (their east and south edges reach 127 pixels past the grid's at the coarsest level)
#: come within 0.011-0.02 rad of a pole or the antipode in most
LAEA_CASES = [
    ("EPSG:3035", (-1.0e6, -2.0e6, 9.5e6, 7.29e6)),  # the north pole 80 km above
    ("EPSG:6931", (7.0e4, -6.0e6, 6.0e6, 6.0e6)),  # EASE-Grid 2.0 North, the pole to its west
    ("+proj=laea +lat_0=-90 +lon_0=30 +ellps=GRS80 +units=km", (-6e3, -6e3, 6e3, -70.0)),
    ("+proj=laea +lat_0=0 +lon_0=20 +x_0=500000 +ellps=WGS84", (-8e6, -6e6, 9e6, 6.2e6)),
    (SPHERE, (2.0e6, -11.443e6, 4.5e6, 3e6)),  # the antipode's circle 0.02 rad beyond
    ("EPSG:2163", (-6e6, -6e6, 6e6, 4.796e6)),  # US National Atlas, a sphere: the pole above
]


@pytest.fixture(scope="module")
def ctx():
    from gloffset.gl import get_context

    return get_context()


def feature(name):
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    return next(f for f in fc["features"] if f["properties"]["name"] == name)


@pytest.fixture(scope="module")
def europe():
    """The countries of Europe in world_110m (Russia too), one shape."""
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    feats = [f for f in fc["features"] if f["properties"]["continent"] == "Europe"]
    return gloffset.read({"type": "FeatureCollection", "features": feats})


def exact_inverse(crs, x, y) -> np.ndarray:
    """LAEA's inverse in float64 to a few ulp: the authalic sphere's point (arcsin and
    atan2), the geodetic latitude from ``q(phi) = q_p sin beta`` by Newton's method."""
    pp = laea_params(crs)
    X, Y = (x - pp["fe"]) * pp["kx"], (y - pp["fn"]) * pp["ky"]
    r = np.hypot(X, Y)
    c = 2.0 * np.arcsin(r / 2.0)
    az = np.arctan2(X, Y)
    sb, cb = pp["sb"], pp["cb"]
    sin_beta = np.cos(c) * sb + np.sin(c) * np.cos(az) * cb
    lam = pp["lon0"] + np.arctan2(
        np.sin(az) * np.sin(c), cb * np.cos(c) - sb * np.sin(c) * np.cos(az)
    )
    beta = np.arcsin(np.clip(sin_beta, -1.0, 1.0))
    es = pp["es"]
    phi = beta.copy()
    if es > 0:
        e = math.sqrt(es)

        def q(s):
            return (1 - es) * (s / (1 - es * s * s) - np.log((1 - e * s) / (1 + e * s)) / (2 * e))

        qp = q(1.0)
        for _ in range(6):  # dq/dphi = 2 (1 - e^2) cos phi / (1 - e^2 sin^2 phi)^2
            s = np.sin(phi)
            dq = 2 * (1 - es) * np.cos(phi) / (1 - es * s * s) ** 2
            phi = phi - (q(s) - qp * sin_beta) / np.where(dq > 0, dq, 1.0)
    return np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], -1)


@pytest.mark.parametrize("crs, box", LAEA_CASES)
def test_glsl_centres_against_pyproj(ctx, crs, box):
    """At 40,000 points of each grid (its pixel centres among them, and the corners of
    its cell centres' box, nearest a pole or the antipode) the GLSL centre is within
    LAEA_PYPROJ_BOUND (1e-12 rad) of pyproj's (8e-15 measured at 400,000 points of
    each); PROJ's series keeps pyproj within 1e-9 of the exact inverse (2.5e-10
    measured with PROJ 9.5.1); a subgrid's function gives the same points (to the
    roundings)."""
    g = Projected(4097, 4097, crs=crs, bounds=box)
    rng = np.random.default_rng(5)
    px = rng.uniform(0.0, 4097.0, (40000, 2))
    px[1:100] = np.floor(px[1:100]) + 0.5  # pixel centres
    # the corners of the box of every level's cell centres
    px[100:104] = [(0.5, 0.5), (4224.0, 0.5), (0.5, 4224.0), (4224.0, 4224.0)]
    # a subgrid: the same to the roundings of the plane coordinates (grown near the antipode)
    _, x, y = probe_grid(
        ctx, g, px, LAEA_PYPROJ_BOUND, sub_at=(1000, 300, 2000, 3000), sub_tol=1e-13, unit_tol=2e-15
    )
    lon, lat = g.transformer.transform(x, y)
    assert np.max(angle(lonlat_to_xyz(lon, lat), exact_inverse(g.crs, x, y))) <= 1e-9


def test_which_laea_grids_take_the_glsl_function():
    """A grid takes it while its cell centres (every level's) keep 0.01 rad from the
    poles and from the origin's antipode: EPSG:3035 over Europe, its area of use and
    its TMS tiles do; grids over the pole, or reaching it at a coarse level only (cells
    past the east and south edges), or the antipode's circle, take the texture, and so
    does a part of a grid whose own coarse cells reach the pole."""
    crs = pyproj.CRS("EPSG:3035")
    assert Projected(640, 640, crs=crs).centres == "glsl"
    for z, x, y in ((0, 0, 0), (3, 4, 3), (9, 261, 191)):
        assert TmsTile("EuropeanETRS89_LAEAQuad", z, x, y).centres == "glsl"
    pole = pyproj.Transformer.from_crs("EPSG:4258", crs, always_xy=True).transform(0, 90)[1]
    assert abs(pole - 7.3697e6) < 1e3
    assert Projected(100, 100, crs=crs, bounds=(3e6, 3e6, 5e6, pole + 1e3)).centres == "texture"
    assert not laea_clear(crs, (4.3e6, 7.3e6, 4.4e6, pole - 3e4))  # 30 km
    assert laea_clear(crs, (4.3e6, 7.0e6, 4.4e6, pole - 1e5))  # 100 km
    below = (3e6, -7e6, 5e6, pole - 1e5)
    assert Projected(4097, 4097, crs=crs, bounds=below).centres == "glsl"
    # beyond the pole (EPSG:3035's area of use ends before): 4097 rows, 255 more at level 0
    crs = pyproj.CRS("+proj=laea +lat_0=52 +lon_0=10 +x_0=4321000 +y_0=3210000 +ellps=GRS80")
    above = (3e6, pole + 1e5, 5e6, pole + 8.292e6)
    assert laea_clear(crs, above)
    assert Projected(4097, 4097, crs=crs, bounds=above).centres == "texture"
    g = Projected(8192, 8192, crs=crs, bounds=above)  # 2^13 rows: no cell past its edge
    assert g.centres == "glsl"
    assert g.subgrid(2048, 0, 4096, 8192).centres == "glsl"
    # 5000 rows: the centres of level 2 (128 rows a cell) 56 rows past, 44 km from the pole
    assert g.subgrid(2048, 3192, 4096, 5000).centres == "texture"
    assert Projected(64, 64, crs="EPSG:6931", bounds=(-1e6, -1e6, 1e6, 1e6)).centres == "texture"
    assert Projected(64, 64, crs=SPHERE, bounds=(-1e6, -1.27e7, 1e6, -1.2e7)).centres == "texture"
    utm = Projected(64, 64, crs="EPSG:32633", bounds=(1.0e5, 4.0e6, 9.0e5, 5.3e6))
    assert not laea_clear(utm.crs, utm.bounds)  # not LAEA (its own function: test_grids_tm)


def test_the_bounds_keep_the_slack():
    """Bounds made from pyproj's pixel centres (LAEA beyond the reach of the formula bound:
    here 150 deg from the centre) grow by 2 LAEA_PYPROJ_BOUND a level on the GLSL path (each
    of a cell's and its child's centres may move by that much), not on the texture path;
    the formula bound's own slack a level (EPSG:3035's grids) covers it already."""
    from gloffset.grids.projected import _LEVEL_SLACK

    far = "+proj=laea +lat_0=0 +lon_0=0 +R=6371000"
    g = Projected(64, 64, crs=far, bounds=(1.222e7, -1e5, 1.24e7, 1e5))
    assert g.centres == "glsl" and g._lipschitz() is None
    tex = Projected(64, 64, crs=far, bounds=(1.222e7, -1e5, 1.24e7, 1e5))
    tex.centres = "texture"
    last = g.n_levels - 1
    for lev in range(last):
        slack = 2.0 * LAEA_PYPROJ_BOUND * (last - lev)
        assert np.all(g.rho(lev) - tex.rho(lev) == pytest.approx(slack, rel=1e-3))
        assert np.all(g.rho_at(lev, 0, 1) - tex.rho_at(lev, 0, 1) == pytest.approx(slack, rel=1e-3))
    assert np.all(g.rho(last) == 0.0)
    europe = Projected(300, 200, crs="EPSG:3035", bounds=EUROPE)
    assert europe.centres == "glsl" and europe._lipschitz() is not None
    assert _LEVEL_SLACK >= 2.0 * LAEA_PYPROJ_BOUND


@pytest.mark.slow
def test_glsl_masks_of_europe_are_the_reference(europe):
    """Europe (world_110m, Russia included) at -50 km, 0 and 50 km on a 400 x 400
    EPSG:3035 grid: the GLSL path's masks are the float64 reference at pyproj's pixel
    centres, and so are the texture path's."""
    assert_glsl_and_texture_masks(
        europe,
        Projected(400, 400, crs="EPSG:3035", bounds=EUROPE),
        Projected(400, 400, crs="EPSG:3035", bounds=EUROPE),
    )


def test_a_broken_function_is_caught(europe, monkeypatch):
    """The masks test the GLSL function: with the authalic latitude taken for the
    geodetic one (the series dropped: up to 0.13 deg off) or the central meridian
    turned by a pixel, the render of Europe is no longer the reference; right, it is."""
    g = Projected(151, 151, crs="EPSG:3035", bounds=EUROPE)
    right = g.glsl_centres()
    assert right.constants[8] > 0.0  # the series' first term, about 2 e^2 / 3
    dropped = right.constants[:8] + (0.0,) * 6
    a = 27e3 / 2.5e6  # a pixel (27 km) at 2,500 km from the origin
    cl, sl = right.constants[6], right.constants[7]
    turned = (
        right.constants[:6]
        + (math.cos(a) * cl - math.sin(a) * sl, math.sin(a) * cl + math.cos(a) * sl)
        + right.constants[8:]
    )
    for constants in (dropped, turned):
        broken = GlslCentres(right.source, constants)
        monkeypatch.setattr(Projected, "glsl_centres", lambda self, b=broken: b)
        mask = gloffset.render(europe, 50e3, g)
        with pytest.raises(AssertionError, match="differ from the reference"):
            assert_reference(europe, 50e3, g, mask)
    monkeypatch.undo()
    assert_reference(europe, 50e3, g, gloffset.render(europe, 50e3, g))


@pytest.mark.slow
@pytest.mark.parametrize(
    "name, z, d",
    [("France", 2, -30e3), ("Italy", 5, 20e3), ("Norway", 8, 1e3), ("Greece", 12, -100.0)],
)
def test_laea_quad_tiles_on_the_glsl_path(name, z, d):
    """Frontier EuropeanETRS89_LAEAQuad tiles (the GLSL path) are the reference at
    pyproj's pixel centres, from zoom 2 (17 km pixels) to 12 (4 m)."""
    from test_tms import frontier_tile

    feat = feature(name)
    shape = gloffset.read(feat)
    geom = feat["geometry"]
    polys = [geom["coordinates"]] if geom["type"] == "Polygon" else geom["coordinates"]
    ring = max((p[0] for p in polys), key=len)
    x, y = frontier_tile("EuropeanETRS89_LAEAQuad", ring[len(ring) // 3], z)
    t = TmsTile("EuropeanETRS89_LAEAQuad", z, x, y)
    assert t.centres == "glsl"
    want = assert_reference(shape, d, t, gloffset.render(shape, d, t))
    assert want.any() and not want.all()
