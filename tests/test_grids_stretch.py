"""Bounds of the stretch of a projection's inverse without one smallest scale
(gloffset.grids.stretch: Lambert conformal conic, Albers, LAEA): above every secant slope
of pyproj's inverse, tight, refused where they cannot hold; the Projected grids in those
CRSs take them (their bounds cover every pixel centre, their masks are the reference's)."""

import numpy as np
import pyproj
import pytest
from test_grids_projected import assert_reference, world110  # noqa: F401  (a fixture)
from test_tms import _max_secant_stretch

import gloffset
from gloffset.geometry.sphere import angle, lonlat_to_xyz
from gloffset.grids import Projected
from gloffset.grids.stretch import _cone, conic_lipschitz, inverse_lipschitz

CONICS = [
    ("EPSG:3978", (-2.5e6, -1.0e6, 3.0e6, 4.0e6)),  # LCC 2SP, Canada
    ("EPSG:2154", (1e5, 6.0e6, 1.2e6, 7.2e6)),  # LCC 2SP, France
    ("EPSG:3112", (-2e6, -5e6, 2.2e6, -1e6)),  # LCC 2SP, southern (n < 0)
    ("EPSG:5070", (-2.4e6, 2.5e5, 2.3e6, 3.2e6)),  # Albers, CONUS
    ("EPSG:3577", (-2e6, -5e6, 2.2e6, -1e6)),  # Albers, southern
    ("ESRI:102008", (-3e6, -2e6, 3e6, 2.5e6)),  # Albers, North America
    (
        "+proj=lcc +lat_1=33 +lat_0=33 +lon_0=10 +k_0=0.9995 +x_0=1e5 +ellps=clrk80 +units=us-ft",
        (-3e6, -3e6, 4e6, 3e6),
    ),  # LCC 1SP, feet
    ("+proj=aea +lat_1=-20 +lat_2=-40 +lon_0=130 +R=6371000", (-3e6, -4e6, 3e6, 1e6)),  # sphere
]


@pytest.mark.parametrize("crs, box", CONICS)
def test_conic_bound_covers_the_stretch(crs, box):
    """The bound is above every secant slope of pyproj's inverse over the box (rows,
    columns, diagonals of a 301 x 301 sample), and within 2 % of the largest."""
    k = conic_lipschitz(pyproj.CRS(crs), box)
    m = _max_secant_stretch(crs, box, n=301)
    assert m <= k <= 1.02 * m


def test_conic_bound_refused_where_it_cannot_hold():
    """No bound across the ray from the apex away from the map (the inverse's longitudes
    jump there: the secant slopes explode), nor for Albers beyond the images of the
    poles; other CRSs have none."""
    crs = pyproj.CRS("EPSG:3978")
    fwd = pyproj.Transformer.from_crs(crs.geodetic_crs, crs, always_xy=True)
    (ax, ay), n, down = _cone(fwd, -95.0, 1.0)
    px, py = fwd.transform(-95.0, 90.0)  # the apex is the pole's image
    assert abs(ax - px) < 1e-3 and abs(ay - py) < 1e-3 and 0 < n < 1
    assert abs(down[0]) < 1e-12 and down[1] < 0
    across = (ax - 1e6, ay - 1e6, ax + 1e6, ay + 1e6)  # round the apex
    assert conic_lipschitz(crs, across) is None
    assert _max_secant_stretch("EPSG:3978", across) > 10 * conic_lipschitz(
        crs, (ax - 1e6, ay - 3e6, ax + 1e6, ay - 1e5)
    )
    beside = (ax + 1e5, ay - 1e6, ax + 2e6, ay + 1e6)  # east of the ray, near the apex
    assert _max_secant_stretch("EPSG:3978", beside) <= conic_lipschitz(crs, beside)
    north = (ax - 1e5, ay + 1e5, ax + 1e5, ay + 2e6)  # on the ray
    assert conic_lipschitz(crs, north) is None
    aea = pyproj.CRS("EPSG:5070")
    assert conic_lipschitz(aea, (-1e5, 8e6, 1e5, 9e6)) is None  # round the pole's image
    flat = pyproj.CRS("+proj=aea +lat_1=20 +lat_2=-19.9 +lon_0=0 +ellps=WGS84")  # n ~ 1e-3
    assert conic_lipschitz(flat, (-1e6, -1e6, 1e6, 1e6)) is None
    assert conic_lipschitz(pyproj.CRS("EPSG:3031"), (0, 0, 1, 1)) is None
    assert inverse_lipschitz(pyproj.CRS("EPSG:32633"), (0, 0, 1, 1)) is None


GRIDS = [
    ("EPSG:3978", (-2.5e6, -1.0e6, 3.0e6, 4.0e6), (150, 130)),
    ("EPSG:5070", (-2.4e6, 2.5e5, 2.3e6, 3.2e6), (131, 140)),
    ("EPSG:3577", (-2e6, -5e6, 2.2e6, -1e6), (120, 121)),
    ("EPSG:2154", (1e5, 6.0e6, 1.2e6, 7.2e6), (100, 150)),
]


@pytest.mark.parametrize("crs, bounds, size", GRIDS)
def test_conic_grids_bounds_cover_the_pixel_centres(crs, bounds, size):
    """A Projected grid in a conic CRS takes the formula (no pixel-centre tree), and
    rho of every cell of every level covers each of its pixels' centres (brute force),
    a subgrid's too."""
    g = Projected(*size, crs=crs, bounds=bounds)
    assert g._lipschitz() is not None and g.valid(0) is None
    assert "_tree_cache" not in g.__dict__
    for grid in (g, g.subgrid(17, 9, size[0] - 30, size[1] - 20)):
        last = grid.n_levels - 1
        jj, ii = np.meshgrid(np.arange(grid.height), np.arange(grid.width), indexing="ij")
        p = grid.centers(last, jj, ii)
        lon, lat = grid.pixel_lonlat(ii, jj)
        assert np.array_equal(p, lonlat_to_xyz(lon, lat))
        for lev in range(last):
            b = grid.block(lev)
            c = grid.centers(lev, jj // b, ii // b)
            assert np.all(angle(c, p) <= grid.rho_at(lev, jj // b, ii // b)), lev
        assert "_tree_cache" not in grid.__dict__


@pytest.mark.parametrize(
    "crs, bounds, names, size",
    [
        ("EPSG:3978", (-2.5e6, -1.0e6, 3.0e6, 4.0e6), ("Canada", "Greenland"), (72, 64)),
        pytest.param(
            "EPSG:3978",
            (-2.5e6, -1.0e6, 3.0e6, 4.0e6),
            ("Canada", "Greenland"),
            (200, 180),
            marks=pytest.mark.slow,
        ),
        pytest.param(
            "EPSG:5070",
            (-2.4e6, 2.5e5, 2.3e6, 3.2e6),
            ("United States of America", "Mexico"),
            (200, 180),
            marks=pytest.mark.slow,
        ),
    ],
)
def test_conic_grids_against_reference(world110, crs, bounds, names, size):  # noqa: F811
    """Canada in LCC, the United States in Albers: the GPU masks are the reference's."""
    g = Projected(*size, crs=crs, bounds=bounds)
    shape = gloffset.read({"type": "FeatureCollection", "features": [world110[n] for n in names]})
    for d in (-30e3, 60e3):
        assert_reference(shape, d, g, gloffset.render(shape, d, g))
