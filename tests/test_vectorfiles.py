"""Vector files (gloffset[files]): Shapefile, GeoPackage, FlatGeobuf and GeoParquet written
from the repository's GeoJSON give the same Shape as the GeoJSON; --layer and --where
select; another CRS is transformed to lon/lat or refused; offset -o writes vector files
with a distance field."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import gloffset
from gloffset.cli import main

pyogrio = pytest.importorskip("pyogrio")
gpd = pytest.importorskip("geopandas")
pytest.importorskip("pyproj")
pytest.importorskip("pyarrow")

DATA = Path(__file__).resolve().parents[1] / "data"
WORLD = DATA / "world_110m.geojson"
MEXICO = DATA / "mexico_10m.geojson"
FORMATS = ["shp", "gpkg", "fgb", "parquet"]


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def write(frame, path: Path) -> Path:
    if path.suffix == ".parquet":
        frame.to_parquet(path)
    elif path.suffix == ".fgb":  # without the spatial index, which reorders the features
        pyogrio.write_dataframe(frame, path, layer_options={"SPATIAL_INDEX": "NO"})
    else:
        pyogrio.write_dataframe(frame, path)
    return path


@pytest.fixture(scope="module")
def world():
    return pyogrio.read_dataframe(WORLD)


def assert_same_shape(a: gloffset.Shape, b: gloffset.Shape, atol: float = 0.0):
    assert len(a.rings) == len(b.rings) and len(a.lines) == len(b.lines)
    for x, y in zip(a.rings + a.lines, b.rings + b.lines):
        assert x.shape == y.shape
        np.testing.assert_allclose(x, y, rtol=0, atol=atol)
    assert np.array_equal(a.ring_groups, b.ring_groups)
    assert np.array_equal(a.ring_holes, b.ring_holes)


def assert_holds_the_vertices(a: gloffset.Shape, b: gloffset.Shape, atol: float):
    """``a`` is ``b`` with points added: each ring and line of ``b`` in order in ``a``'s."""
    assert len(a.rings) == len(b.rings) and len(a.lines) == len(b.lines)
    for x, y in zip(a.rings + a.lines, b.rings + b.lines):
        assert len(x) >= len(y)
        at, k = [], 0
        for v in y:
            while k < len(x) and np.abs(x[k] - v).max() > atol:
                k += 1
            assert k < len(x), "a vertex of the input is missing or out of order"
            at.append(k)
        assert at[0] == 0
    assert np.array_equal(a.ring_groups, b.ring_groups)
    assert np.array_equal(a.ring_holes, b.ring_holes)


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_each_format_gives_the_shape_of_the_geojson(tmp_path, world, fmt):
    path = write(world, tmp_path / f"world.{fmt}")
    assert_same_shape(gloffset.read(path), gloffset.read(WORLD))


@pytest.mark.parametrize("fmt", ["gpkg", "parquet", "shp"])
def test_where_selects_features(tmp_path, world, fmt):
    path = write(world, tmp_path / f"world.{fmt}")
    got = gloffset.read(path, where="continent = 'Africa'")
    africa = json.loads(WORLD.read_text())
    africa["features"] = [f for f in africa["features"] if f["properties"]["continent"] == "Africa"]
    assert_same_shape(got, gloffset.read(africa))
    r = run("offset", path, "-d", "50km", "--where", "name = 'Fiji'", "--each")
    assert r.exit_code == 0, r.output
    feats = json.loads(r.output)["features"]
    assert [f["properties"]["name"] for f in feats] == ["Fiji"]


@pytest.mark.parametrize("epsg", [3857, 32614, 4269])
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_another_crs_is_transformed_to_lonlat(tmp_path, epsg):
    mexico = pyogrio.read_dataframe(MEXICO)
    path = write(mexico.to_crs(epsg), tmp_path / f"mexico_{epsg}.gpkg")
    if epsg != 4269:  # a projection's straight edges get points (tests/test_projected.py)
        assert_holds_the_vertices(gloffset.read(path), gloffset.read(MEXICO), atol=1e-9)
        assert run("offset", path, "-d", "100km").exit_code == 0
        return
    assert_same_shape(gloffset.read(path), gloffset.read(MEXICO), atol=1e-9)
    # the CLI reads it too, and its offset equals the GeoJSON's
    a = run("offset", path, "-d", "100km", "--digits", "5")
    b = run("offset", MEXICO, "-d", "100km", "--digits", "5")
    assert a.exit_code == 0 and b.exit_code == 0, a.output + b.output
    ga, gb = (json.loads(x.output)["features"][0]["geometry"] for x in (a, b))
    ca, cb = (np.concatenate([np.array(r) for p in g["coordinates"] for r in p]) for g in (ga, gb))
    assert ca.shape == cb.shape and np.abs(ca - cb).max() <= 2e-5


def test_a_crs_without_lonlat_is_refused(tmp_path, world):
    mexico = pyogrio.read_dataframe(MEXICO)
    geocentric = write(mexico.set_crs("EPSG:4978", allow_override=True), tmp_path / "g.gpkg")
    with pytest.raises(gloffset.InputFormatError, match="cannot be transformed to lon/lat"):
        gloffset.read(geocentric)
    r = run("offset", geocentric, "-d", "1km")
    assert r.exit_code == 2 and "cannot be transformed to lon/lat" in r.output


def test_layers_and_errors_name_the_problem(tmp_path, world):
    path = tmp_path / "two.gpkg"
    pyogrio.write_dataframe(world, path, layer="countries")
    pyogrio.write_dataframe(world[world.continent == "Oceania"], path, layer="oceania")
    with pytest.raises(gloffset.InputFormatError, match=r"2 layers.*choose one \(layer="):
        gloffset.read(path)
    assert_same_shape(gloffset.read(path, layer="countries"), gloffset.read(WORLD))
    assert len(gloffset.read(path, layer="oceania").rings) < 20
    with pytest.raises(gloffset.InputFormatError, match="no layer 'rivers'.*'oceania'"):
        gloffset.read(path, layer="rivers")
    with pytest.raises(gloffset.InputFormatError, match="bad where clause.*name, iso_a3"):
        gloffset.read(path, layer="countries", where="nome = 'Fiji'")
    r = run("render", path, "--layer", "nope", "-d", "1km", "--size", "36x18", "-o", "x.png")
    assert r.exit_code == 2 and "no layer 'nope'" in r.output
    with pytest.raises(gloffset.InputFormatError, match="do not apply"):
        gloffset.read(json.loads(WORLD.read_text()), where="name = 'Fiji'")


def test_a_missing_extra_is_named(tmp_path, world, monkeypatch):
    path = write(world, tmp_path / "w.fgb")
    projected = write(pyogrio.read_dataframe(MEXICO).to_crs(3857), tmp_path / "m.gpkg")
    monkeypatch.setitem(sys.modules, "pyproj", None)
    with pytest.raises(gloffset.InputFormatError, match=r"needs pyproj.*gloffset\[files\]"):
        gloffset.read(projected)
    monkeypatch.setitem(sys.modules, "pyogrio", None)
    with pytest.raises(gloffset.InputFormatError, match=r"needs pyogrio.*gloffset\[files\]"):
        gloffset.read(path)
    r = run("offset", MEXICO, "-d", "1km", "-o", tmp_path / "out.gpkg")
    assert r.exit_code == 2 and "needs pyogrio" in r.output
    assert not (tmp_path / "out.gpkg").exists()


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.slow  # a heavier repeat of quicker checks of the same ground
def test_offset_writes_vector_files_with_a_distance_field(tmp_path, fmt):
    out = tmp_path / f"out.{fmt}"
    r = run("offset", MEXICO, "-d", "127km", "-o", out)
    assert r.exit_code == 0, r.output
    got = gpd.read_parquet(out) if fmt == "parquet" else pyogrio.read_dataframe(out)
    assert got.crs.equals("EPSG:4326") or got.crs.to_string() == "OGC:CRS84"
    assert list(got["distance"]) == ["127km"]
    want = gloffset.offset(gloffset.read(MEXICO), 127e3).to_geojson()
    import shapely

    assert abs(got.geometry.iloc[0].area - shapely.geometry.shape(want["geometry"]).area) < 1e-9


def test_offset_each_writes_one_row_per_feature_with_its_properties(tmp_path, world):
    src = write(world[world.continent == "Oceania"], tmp_path / "oceania.fgb")
    out = tmp_path / "each.gpkg"
    r = run("offset", src, "-d", "20km", "--each", "-o", out)
    assert r.exit_code == 0, r.output
    got = pyogrio.read_dataframe(out)
    names = list(world[world.continent == "Oceania"].name)
    assert list(got.name) == names and set(got["distance"]) == {"20km"}
    assert (got.geom_type == "MultiPolygon").all() and got.is_valid.all()


def test_where_on_a_geojson_file_reads_it_through_gdal():
    got = gloffset.read(WORLD, where="name IN ('Fiji', 'Russia')")
    fc = json.loads(WORLD.read_text())
    fc["features"] = [f for f in fc["features"] if f["properties"]["name"] in ("Fiji", "Russia")]
    assert_same_shape(got, gloffset.read(fc))


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["gpkg", "parquet"])
def test_countries_10m_in_a_vector_file_give_the_geojson_shape(tmp_path, fmt):
    """All 234 countries at 1:10m (308k vertices; uniting them takes seconds)."""
    src = DATA / "countries_10m.geojson"
    path = write(pyogrio.read_dataframe(src), tmp_path / f"countries.{fmt}")
    assert_same_shape(gloffset.read(path), gloffset.read(src))
    europe = "name IN ('France', 'Spain', 'Andorra', 'Portugal')"
    fc = json.loads(src.read_text())
    names = ("France", "Spain", "Andorra", "Portugal")
    fc["features"] = [f for f in fc["features"] if f["properties"]["name"] in names]
    assert_same_shape(gloffset.read(path, where=europe), gloffset.read(fc))


def test_geojson_with_a_legacy_crs_member_is_transformed(tmp_path):
    mexico = pyogrio.read_dataframe(MEXICO).to_crs(3857)
    path = tmp_path / "mexico_3857.geojson"
    pyogrio.write_dataframe(mexico, path, driver="GeoJSON", layer_options={"RFC7946": "NO"})
    assert "crs" in json.loads(path.read_text())
    assert_holds_the_vertices(gloffset.read(path), gloffset.read(MEXICO), atol=1e-9)
    with pytest.raises(gloffset.InputFormatError, match="pre-RFC 7946 'crs' member"):
        gloffset.read(json.loads(path.read_text()))
    named = json.loads(MEXICO.read_text())
    named["crs"] = {"type": "name", "properties": {"name": "urn:ogc:def:crs:OGC:1.3:CRS84"}}
    assert_same_shape(gloffset.read(named), gloffset.read(MEXICO))


@pytest.mark.parametrize("fmt", ["geojson", "gpkg", "parquet"])
def test_where_errors_name_the_layer_and_the_clause(tmp_path, world, fmt):
    path = WORLD if fmt == "geojson" else write(world, tmp_path / f"world_110m.{fmt}")
    # worded for a Python caller, who gave no --where
    with pytest.raises(gloffset.InputFormatError, match="bad where clause .nome = 'Fiji'") as bad:
        gloffset.read(path, where="nome = 'Fiji'")
    assert "b'" not in str(bad.value) and "--where" not in str(bad.value)
    clause = "name = 'Atlantis'"
    words = f"no feature of layer 'world_110m' matched the where clause {clause!r}"
    with pytest.raises(gloffset.InputFormatError) as none:
        gloffset.read(path, where=clause)
    assert words in str(none.value) and "empty geometry" not in str(none.value)
    r = run("offset", path, "-d", "50km", "--where", clause)
    assert r.exit_code == 2 and words in r.output
