"""The ellipsoid's maths (gloffset.ellipsoid): the model and its conformal sphere, the
geodesic intercept against brute force, and the ellipsoid/sphere distance bounds
against geodesics from pyproj (Karney's C library)."""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import gloffset
from gloffset.ellipsoid import (
    Ellipsoid,
    as_ellipsoid,
    edge_deviation,
    edge_distance,
    edge_distances,
    lower_distance,
    upper_distance,
)
from gloffset.geometry.sphere import arc_distance, lonlat_to_xyz
from gloffset.reference import geodesic_edge_distance

pyproj = pytest.importorskip("pyproj")
WGS84 = as_ellipsoid("WGS84")
GEOD = pyproj.Geod(ellps="WGS84")


# ------------------------------------------------------------------------- the model
def test_names_pairs_and_errors():
    assert as_ellipsoid(None) is None
    assert as_ellipsoid("wgs84") == WGS84 and as_ellipsoid("GRS-80").name == "GRS80"
    e = as_ellipsoid((6378137.0, 1 / 298.257223563))
    assert e.a == WGS84.a and e.f == WGS84.f
    assert as_ellipsoid(WGS84) is WGS84
    for bad in ("Clarke", 5, (1.0,), (-1.0, 0.003), (6e6, 0.5), (6e6, -0.01), ("x", 0.0)):
        with pytest.raises(gloffset.InvalidEllipsoidError):
            as_ellipsoid(bad)
    assert issubclass(gloffset.InvalidEllipsoidError, ValueError)


def test_conformal_latitude_round_trips():
    lat = np.concatenate([np.linspace(-90, 90, 3601), [89.9999999, -89.99999, 1e-9]])
    chi = WGS84.conformal(lat)
    assert np.all(np.abs(chi) <= np.abs(lat) + 1e-12)  # towards the equator
    np.testing.assert_allclose(WGS84.geodetic(chi), lat, atol=1e-11)
    assert WGS84.conformal(90.0) == 90.0 and WGS84.conformal(-90.0) == -90.0


def test_scale_is_the_ellipsoid_metric_on_the_conformal_sphere():
    """K(phi) times a tiny angle on the conformal sphere is the geodesic length, in any
    direction (the map is conformal)."""
    rng = np.random.default_rng(0)
    lat = rng.uniform(-89.9, 89.9, 500)
    lon = rng.uniform(-180, 180, 500)
    az = rng.uniform(0, 360, 500)
    step = 1.0  # metres
    lon2, lat2, _ = GEOD.fwd(lon, lat, az, np.full(500, step))
    chord = np.linalg.norm(WGS84.to_sphere(lon, lat) - WGS84.to_sphere(lon2, lat2), axis=1)
    theta = 2 * np.arcsin(chord / 2)
    k = WGS84.scale(np.radians(lat))
    np.testing.assert_allclose(k * theta, step, rtol=2e-6)
    phi = np.linspace(0, np.pi / 2, 1001)
    assert np.all(np.diff(WGS84.scale(phi)) < 0)  # decreasing towards the poles
    assert WGS84.k_min == pytest.approx(6356800.05, abs=0.01)
    e = math.sqrt(WGS84.e2)
    pole = WGS84.a / math.sqrt(1 - WGS84.e2) * ((1 - e) / (1 + e)) ** (e / 2)
    assert WGS84.k_min == pytest.approx(pole, rel=1e-13)


def test_curvature_bound_holds_on_a_fine_grid():
    phi = np.linspace(0, np.pi / 2, 200001)
    chi = np.radians(WGS84.conformal(np.degrees(phi)))
    slope = np.abs(np.diff(np.log(WGS84.scale(phi))) / np.diff(chi))
    assert slope.max() <= WGS84.kappa
    assert WGS84.kappa < 1.001 * slope.max()
    assert as_ellipsoid((1.0, 0.0)).kappa < 1e-11  # the sphere


# ------------------------------------------------------------------------- the intercept
def _cases(rng, n, lat_range=(-89.0, 89.0), lon_range=(-180.0, 180.0), max_len=5.7):
    alat = rng.uniform(*lat_range, n)
    alon = rng.uniform(*lon_range, n)
    blon, blat, _ = GEOD.fwd(alon, alat, rng.uniform(0, 360, n), 10 ** rng.uniform(0, max_len, n))
    return alon, alat, blon, blat


def _check_intercept(plon, plat, alon, alat, blon, blat, tol=1e-3):
    brute = geodesic_edge_distance(GEOD, plon, plat, alon, alat, blon, blat)
    g = WGS84.geodesic
    ours = np.array(
        [
            edge_distance(g, plat[i], plon[i], (alat[i], alon[i]), (blat[i], blon[i]))[0]
            for i in range(len(plon))
        ]
    )
    assert np.all(np.abs(ours - brute) <= tol), np.abs(ours - brute).max()
    # the vectorised intercept (pyproj's C geodesics): the same iteration and bound
    a = np.column_stack([alat, alon])
    b = np.column_stack([blat, blon])
    many = edge_distances(WGS84, plat, plon, a, b, 0.5)
    assert np.all(np.abs(many - brute) <= tol), np.abs(many - brute).max()
    assert np.abs(many - ours).max() <= 1e-6
    return ours


def test_intercepts_without_pyproj_are_the_scalar_ones(monkeypatch):
    from gloffset.ellipsoid import intercept

    rng = np.random.default_rng(4)
    alon, alat, blon, blat = _cases(rng, 20)
    plon, plat = alon + rng.uniform(-1, 1, 20), np.clip(alat + rng.uniform(-1, 1, 20), -90, 90)
    a, b = np.column_stack([alat, alon]), np.column_stack([blat, blon])
    fast = edge_distances(WGS84, plat, plon, a, b, 0.3)
    monkeypatch.setattr(intercept, "_proj_geod", lambda ell: None)
    slow = edge_distances(WGS84, plat, plon, a, b, 0.3)
    g = WGS84.geodesic
    one = [edge_distance(g, plat[i], plon[i], a[i], b[i], 0.3)[0] for i in range(20)]
    assert np.array_equal(slow, one)
    assert np.abs(fast - slow).max() <= 1e-6


def test_intercept_against_brute_force_interior_and_vertices():
    rng = np.random.default_rng(1)
    alon, alat, blon, blat = _cases(rng, 60)
    _, _, length = GEOD.inv(alon, alat, blon, blat)
    # points off the middle of the edge (interior feet) and beyond its ends (vertex feet)
    mlon, mlat, maz = GEOD.fwd(alon, alat, GEOD.inv(alon, alat, blon, blat)[0], length * 0.4)
    plon, plat, _ = GEOD.fwd(mlon, mlat, maz + 90, 10 ** rng.uniform(0, 6, 60))
    _check_intercept(plon, plat, alon, alat, blon, blat)
    qlon, qlat, _ = GEOD.fwd(blon, blat, rng.uniform(0, 360, 60), 10 ** rng.uniform(0, 6, 60))
    _check_intercept(qlon, qlat, alon, alat, blon, blat)


def test_intercept_near_the_poles_and_across_the_antimeridian():
    rng = np.random.default_rng(2)
    for lat_range, lon_range in (((85.0, 90.0), (-180, 180)), ((-90.0, -86.0), (-180, 180))):
        alon, alat, blon, blat = _cases(rng, 30, lat_range, lon_range, max_len=5.5)
        plon, plat, _ = GEOD.fwd(alon, alat, rng.uniform(0, 360, 30), 10 ** rng.uniform(0, 5.5, 30))
        _check_intercept(plon, plat, alon, alat, blon, blat)
    # edges across +-180
    alon = rng.uniform(175, 180, 30)
    alat = rng.uniform(-70, 70, 30)
    blon, blat = rng.uniform(-180, -175, 30), alat + rng.uniform(-3, 3, 30)
    plon = np.where(rng.random(30) < 0.5, 179.9, -179.9)
    plat = alat + rng.uniform(-2, 2, 30)
    _check_intercept(plon, plat, alon, alat, blon, blat)


def test_intercept_points_on_the_edge_and_sides():
    rng = np.random.default_rng(3)
    alon, alat, blon, blat = _cases(rng, 30)
    az, _, length = GEOD.inv(alon, alat, blon, blat)
    plon, plat, _ = GEOD.fwd(alon, alat, az, length * rng.uniform(0.05, 0.95, 30))
    ours = _check_intercept(plon, plat, alon, alat, blon, blat)
    assert np.all(ours < 1e-6)
    g = WGS84.geodesic
    for i in range(10):  # a point 10 m to the left of the edge's middle
        mlon, mlat, maz = GEOD.fwd(alon[i], alat[i], az[i], 0.5 * length[i])
        # pyproj gives back azimuths: the edge runs on towards maz + 180
        left_lon, left_lat, _ = GEOD.fwd(mlon, mlat, maz + 90, 10.0)
        d, s, side = edge_distance(g, left_lat, left_lon, (alat[i], alon[i]), (blat[i], blon[i]))
        assert d == pytest.approx(10.0, abs=1e-6) and side > 0.99
        assert s == pytest.approx(0.5 * length[i], abs=1e-4)


# ------------------------------------------------------------------------- the bounds
def test_ratio_bound_on_random_pairs():
    """K_min(window) theta <= geodesic distance <= K_max(window) theta, on pairs at all
    distances, near the poles too."""
    rng = np.random.default_rng(4)
    n = 20000
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, n)))
    lat[:2000] = rng.uniform(88, 90, 2000) * rng.choice([-1, 1], 2000)
    lon = rng.uniform(-180, 180, n)
    lon2, lat2, _ = GEOD.fwd(lon, lat, rng.uniform(0, 360, n), 10 ** rng.uniform(0, 7.2, n))
    dist = GEOD.inv(lon, lat, lon2, lat2)[2]
    p, q = WGS84.to_sphere(lon, lat), WGS84.to_sphere(lon2, lat2)
    theta = arc_distance(p, q, q)
    chi = np.radians(WGS84.conformal(lat))
    up = upper_distance(WGS84, chi, theta)
    low = lower_distance(WGS84, chi, theta, dist)
    assert np.all(dist <= up * (1 + 1e-12) + 1e-9)
    assert np.all(low <= dist * (1 + 1e-12) + 1e-9)
    short = dist < 10e3  # tight for short distances: the window is small
    assert np.all((up - low)[short] <= 2e-5 * dist[short] + 3e-7)
    assert np.all(up - low <= 0.0034 * dist + 3e-7)


def test_edge_deviation_bounds_the_image_of_geodesics():
    rng = np.random.default_rng(5)
    alon, alat, blon, blat = _cases(rng, 300, max_len=6.8)
    az, _, length = GEOD.inv(alon, alat, blon, blat)
    a, b = WGS84.to_sphere(alon, alat), WGS84.to_sphere(blon, blat)
    theta = 2 * np.arcsin(np.linalg.norm(a - b, axis=1) / 2)
    h = edge_deviation(WGS84, theta)
    worst = np.zeros(300)
    for t in np.linspace(0.0, 1.0, 41):
        xlon, xlat, _ = GEOD.fwd(alon, alat, az, length * t)
        worst = np.maximum(worst, arc_distance(WGS84.to_sphere(xlon, xlat), a, b))
    assert np.all(worst <= h)
    some = worst > 1e-9
    assert np.median(h[some] / worst[some]) < 10  # and not loose by much
    assert edge_deviation(WGS84, np.array([100e3 / 6371e3]))[0] * 6371e3 < 1.5


def test_sphere_is_an_ellipsoid_too():
    e = Ellipsoid(1.0, 0.0)
    np.testing.assert_allclose(e.conformal([10.0, 45.0]), [10.0, 45.0])
    assert e.k_min == e.k_max == 1.0
    p = lonlat_to_xyz(0.0, 0.0)
    assert np.allclose(e.to_sphere(0.0, 0.0), p)


@pytest.mark.slow
def test_intercept_against_brute_force_many():
    """2,000 random edges up to 5,000 km and points up to 3,000 km away, everywhere."""
    rng = np.random.default_rng(31)
    n = 2000
    alat = np.degrees(np.arcsin(rng.uniform(-1, 1, n)))
    alon = rng.uniform(-180, 180, n)
    blon, blat, _ = GEOD.fwd(alon, alat, rng.uniform(0, 360, n), 10 ** rng.uniform(0, 6.7, n))
    plon, plat, _ = GEOD.fwd(alon, alat, rng.uniform(0, 360, n), 10 ** rng.uniform(-1, 6.5, n))
    _check_intercept(plon, plat, alon, alat, blon, blat)


@pytest.mark.slow
def test_ratio_bound_on_many_pairs_and_ellipsoids():
    rng = np.random.default_rng(32)
    for ell in (
        WGS84,
        as_ellipsoid("GRS80"),
        as_ellipsoid((6378137.0, 1 / 50)),
        as_ellipsoid((1.0, 0.01)),
    ):
        geod = pyproj.Geod(a=ell.a, f=ell.f)
        n = 200000
        lat = np.degrees(np.arcsin(rng.uniform(-1, 1, n)))
        lon = rng.uniform(-180, 180, n)
        far = 10 ** rng.uniform(-6, 0.5, n) * ell.a
        lon2, lat2, _ = geod.fwd(lon, lat, rng.uniform(0, 360, n), far)
        dist = geod.inv(lon, lat, lon2, lat2)[2]
        p, q = ell.to_sphere(lon, lat), ell.to_sphere(lon2, lat2)
        theta = arc_distance(p, q, q)
        chi = np.radians(ell.conformal(lat))
        scale = 1e-9 * ell.a
        assert np.all(dist <= upper_distance(ell, chi, theta) * (1 + 1e-12) + scale)
        assert np.all(lower_distance(ell, chi, theta, dist) <= dist * (1 + 1e-12) + scale)


@pytest.mark.slow
def test_intercept_against_geographiclib_lines_at_1mm():
    """The brute force in its plainest form: short edges densified with geographiclib's
    own lines every millimetre, the minimum of the inverse distances."""
    g = WGS84.geodesic
    rng = np.random.default_rng(33)
    for lat, lon, az, length, off in (
        (45.0, 10.0, 30.0, 40.0, 3.0),
        (89.9995, 0.0, 100.0, 60.0, 20.0),
        (-10.0, 179.99995, 80.0, 30.0, 0.5),
        (0.0, 0.0, 90.0, 50.0, 0.0),
    ):
        line = g.DirectLine(lat, lon, az, length)
        b = line.Position(length)
        s = np.arange(0.0, length + 1e-9, 1e-3)
        t = rng.uniform(-0.3, 1.3)  # feet inside the edge and beyond its ends
        m = line.Position(t * length)
        p = g.Direct(m["lat2"], m["lon2"], m["azi2"] + 90.0, off)
        brute = min(
            g.Inverse(p["lat2"], p["lon2"], x["lat2"], x["lon2"])["s12"]
            for x in (line.Position(si) for si in s)
        )
        ours = edge_distance(g, p["lat2"], p["lon2"], (lat, lon), (b["lat2"], b["lon2"]))[0]
        assert abs(ours - brute) <= 1e-3 and ours <= brute + 1e-7


def test_without_pyproj_one_warning_says_what_to_install(monkeypatch):
    """pyproj is a dependency, but an install may lack it: the geographiclib fallback
    gives the same midpoints and says once per process what it costs and what to
    install."""
    from gloffset.ellipsoid import intercept

    rng = np.random.default_rng(5)
    alon, alat, blon, blat = _cases(rng, 8)
    fast = intercept.geodesic_midpoints(WGS84, alon, alat, blon, blat)
    monkeypatch.setitem(sys.modules, "pyproj", None)  # import pyproj raises ImportError
    monkeypatch.setattr(intercept, "_warned_no_pyproj", False)
    with pytest.warns(UserWarning, match=r"pyproj is not installed.*pip install 'pyproj"):
        slow = intercept.geodesic_midpoints(WGS84, alon, alat, blon, blat)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once only
        again = intercept.geodesic_midpoints(WGS84, alon, alat, blon, blat)
    for f, s, t in zip(fast, slow, again):
        assert np.abs(f - s).max() <= 1e-8 and np.array_equal(s, t)


def test_pyproj_is_a_dependency_and_the_ellipsoid_extra_still_installs():
    tomllib = pytest.importorskip("tomllib")
    meta = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())
    project = meta["project"]
    assert "pyproj>=3.4" in project["dependencies"]
    assert project["optional-dependencies"]["ellipsoid"] == ["pyproj>=3.4"]
