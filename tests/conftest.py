import inspect
import json
from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).resolve().parent.parent / "data"

# Synthetic shapes several test modules use
SQUARE_WITH_HOLE = {
    "type": "Polygon",
    "coordinates": [
        [[-20, -10], [20, -10], [20, 15], [-20, 15], [-20, -10]],
        [[-5, -3], [6, -3], [6, 4], [-5, 4], [-5, -3]],
    ],
}
LINES = {
    "type": "MultiLineString",
    "coordinates": [[[-150, 10], [-100, 40], [-60, 5]], [[170, -30], [-170, -35]]],
}


@pytest.fixture(scope="session")
def world():
    """Natural Earth 110m countries: {name: Feature}."""
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    return {f["properties"]["name"]: f for f in fc["features"]}


def named_countries(*names, path=DATA / "world_110m.geojson"):
    """The shape of the features of ``path`` (Natural Earth) with these names, all found."""
    import gloffset

    fc = json.loads(Path(path).read_text())
    feats = [f for f in fc["features"] if f["properties"].get("name") in names]
    assert len(feats) == len(names)
    return gloffset.read({"type": "FeatureCollection", "features": feats})


#: countries of 1:10m that share borders (France and the countries round it)
NEIGHBOURS = {"France", "Spain", "Portugal", "Andorra", "Germany", "Belgium", "Luxembourg"}


def border_shapes(neighbours=NEIGHBOURS) -> dict:
    """Real borders for the levels' tests: ``neighbours`` (1:10m, borders shared by
    neighbours, coasts and islands), the seams (1:110m: Russia and Fiji across the
    antimeridian, Antarctica around the pole, Greenland) and Mexico (1:10m)."""
    import gloffset

    return {
        "neighbours": named_countries(*neighbours, path=DATA / "countries_10m.geojson"),
        "seams": named_countries("Russia", "Fiji", "Antarctica", "Greenland"),
        "mexico": gloffset.read(DATA / "mexico_10m.geojson"),
    }


def same_bits(got, want) -> bool:
    """Whether two arrays have the same dtype and the same values, floats bit for bit."""
    assert got.dtype == want.dtype
    if got.dtype.kind == "f":
        return np.array_equal(got.view(np.uint64), want.view(np.uint64))
    return np.array_equal(got, want)


def level_grid(name: str):
    """The grids of the refined levels' tests: a tile pyramid, an odd and an even lon/lat."""
    from gloffset.grids import Equirect
    from gloffset.grids.mercator import TilePyramid

    return {
        "pyramid": lambda: TilePyramid(7),
        "lonlat-odd": lambda: Equirect(1200, 600),
        "lonlat": lambda: Equirect(2048, 1024),
    }[name]()


#: (shape of :func:`border_shapes`, distance, :func:`level_grid`) of the refined levels' tests
LEVEL_CASES = [
    ("neighbours", 0.01, "pyramid"),
    ("neighbours", -0.004, "lonlat-odd"),
    ("seams", 0.02, "lonlat"),
    ("seams", -0.01, "pyramid"),
    ("mexico", 0.002, "lonlat-odd"),
]


def frontier_without_pairs(k: int):
    """A level-0 frontier of ``k`` cells and no (cell, arc) pair, the second cell inside."""
    from gloffset.raster.vector.levels import Frontier

    status = np.zeros((k, 1), dtype=np.uint8)
    status[1, 0] = 1
    zeros = np.zeros(0, dtype=int)
    cells, centres = np.zeros((k, 2), dtype=int), np.tile([1.0, 0.0, 0.0], (k, 1))
    return Frontier(0, cells, centres, np.zeros(k), zeros, zeros, status)


def assert_cluster_headers(hdr, rec, f, arcs, every: int = 1) -> None:
    """Every ``every``-th cluster header of the records ``rec`` of frontier ``f``: Dmin
    and hmin the records' own least values, ``S >= |Q| + rho``, and the ball ``(Q, rho)``
    about the cell's centre holding every point of the cluster's arcs."""
    from gloffset.geometry.sphere import slerp
    from gloffset.raster.records import ARC_RING

    fh = hdr.view(np.float32)
    start = (hdr[:, 1, 3] >> 4).astype(np.int64)
    count = (hdr[:, 1, 3] & 15).astype(np.int64) + 1
    t0 = rec[:, 0]
    ring = (t0[:, 1].astype(int) & ARC_RING) != 0
    t = np.linspace(0.0, 1.0, 9)
    for j in range(0, len(hdr), every):
        sl = slice(start[j], start[j] + count[j])
        assert fh[j, 1, 0] == t0[sl, 0].min()
        hm = np.abs(t0[sl, 2][ring[sl]])
        assert fh[j, 1, 1] == (hm.min() if len(hm) else np.inf)
        q, rho, S = fh[j, 0, :3].astype(float), float(fh[j, 0, 3]), float(fh[j, 1, 2])
        assert S >= np.linalg.norm(q) + rho
        ci = f.pair_cell[sl]
        for arc in f.pair_arc[sl]:
            a, b = arcs.a[arc], arcs.b[arc]
            pts = slerp(a, b, t) if not np.array_equal(a, b) else a[None]
            assert np.all(np.linalg.norm(pts - f.centers[ci[0]] - q, axis=1) <= rho)


def field_and_codes(shape, grid, monkeypatch, *patches):
    """The field's values (radius 1) and the shader's sign codes of every block, in
    order; each ``(object, name, value)`` of ``patches`` set meanwhile."""
    import gloffset
    from gloffset.gl.field_pass import FieldPass

    codes = []
    run = FieldPass.run

    def keep(self, plan, probe=False):
        out = run(self, plan, probe)
        codes.append(None if plan.codes is None else plan.codes.copy())
        return out

    with monkeypatch.context() as m:
        m.setattr(FieldPass, "run", keep)
        for obj, name, value in patches:
            m.setattr(obj, name, value)
        values = gloffset.distance_field(shape, grid, radius=1.0).values
    return values, codes


def broken_field_pass(monkeypatch, tmp_path, old: str, new: str) -> None:
    """Run the field's pass from a copy of ``shaders/field_pixels.comp`` with ``old`` made
    ``new`` (each test's broken shader)."""
    from gloffset.gl.field_pass import field_pass
    from gloffset.gl.shaders import SHADER_DIR

    src = (SHADER_DIR / "field_pixels.comp").read_text()
    assert src.count(old) == 1, old
    (tmp_path / "field_pixels.comp").write_text(src.replace(old, new))
    monkeypatch.setattr(field_pass(), "root", tmp_path)


@pytest.fixture(scope="session")
def mexico_path():
    return DATA / "mexico_10m.geojson"


def uniform_sphere(n, seed=0):
    """n points uniform on the sphere, as lon/lat degrees."""
    rng = np.random.default_rng(seed)
    lon = rng.uniform(-180.0, 180.0, n)
    lat = np.degrees(np.arcsin(rng.uniform(-1.0, 1.0, n)))
    return lon, lat


# Readers of tile outputs and the one-line CLI error check, shared by the test modules


def read_mbtiles(path):
    """{(z, x, y): png bytes} with XYZ rows, and the metadata."""
    import sqlite3

    db = sqlite3.connect(path)
    tiles = {
        (z, x, (1 << z) - 1 - r): bytes(data) for z, x, r, data in db.execute("SELECT * FROM tiles")
    }
    meta = dict(db.execute("SELECT name, value FROM metadata"))
    db.close()
    return tiles, meta


def read_dir(path):
    """{(z, x, y): png bytes} of an XYZ folder."""
    import os

    out = {}
    for root, _, files in os.walk(path):
        for f in files:
            if f.endswith(".png"):
                z, x = (int(v) for v in os.path.relpath(root, path).split(os.sep))
                with open(os.path.join(root, f), "rb") as fh:
                    out[(z, x, int(f[:-4]))] = fh.read()
    return out


def read_tiles(path):
    """{(z, x, y): png bytes} and the metadata of an MBTiles, PMTiles or XYZ folder."""
    path = str(path)
    if path.endswith(".pmtiles"):
        from gloffset.tiles.store.pmtiles import read_pmtiles

        meta, tiles = read_pmtiles(path)
        return tiles, meta
    if path.endswith(".mbtiles"):
        return read_mbtiles(path)
    return read_dir(path), None


def assert_one_line_error(proc, *words):
    """A command that failed with exit 2 and one line naming ``words`` on stderr."""
    err = proc.stderr.decode()
    assert proc.returncode == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("gloffset: error: "), err
    for w in words:
        assert w in lines[0], err


def assert_options_refused(call, func, what):
    """``call()`` passes ``func`` an unknown keyword (``sise``): a TypeError names it and
    lists the options, those its docstring's "Other Parameters" documents, in its order."""
    with pytest.raises(TypeError) as err:
        call()
    head = f"{what}() got an unexpected keyword argument 'sise'; its options are "
    msg = str(err.value)
    assert msg.startswith(head), msg
    section = inspect.getdoc(func).split("Other Parameters\n----------------\n")[1]
    names: list[str] = []
    for line in section.splitlines():
        if line and not line[0].isspace():
            if set(line) == {"-"}:  # the next section's underline: its title was last
                names.pop()
                break
            names += [n.strip() for n in line.split(" : ")[0].split(",")]
    assert msg[len(head) :].split(", ") == names


#: Cases that repeat a quicker case's ground (another distance, format, option or error of
#: the same check): marked slow here, so that the README's test command stays within 5
#: minutes on 2 cores; ``.ci/run`` runs them with ``-m slow``. Prefixes of node ids.
REPEATS = (
    "tests/test_walk_check.py::test_a_broken_bound_fails_the_check[SUM_ERR",
    "tests/test_golden.py::test_golden[contains/table1_10000]",
    "tests/test_golden.py::test_golden[raster_input/world_borders_cube_6x128_127km_levels]",
    "tests/test_golden.py::test_golden[raster_input/world_borders_cube_6x128_250km_cpu]",
    "tests/test_golden.py::test_golden[raster_input/world_borders_cube_6x128_250km_levels]",
    "tests/test_golden.py::test_golden[selfintersect/mexico_d+0.02_paper]",
    "tests/test_cli_errors.py::test_a_geotiff_is_written_through_a_symlink[args1]",
    "tests/test_cli_errors.py::test_a_geotiff_is_written_through_a_symlink[args2]",
    "tests/test_cli_errors.py::test_dev_stdout_redirected_to_a_file_is_appended_to[/dev/fd/1]",
    "tests/test_cli_errors.py::test_missing_distance[offset]",
    "tests/test_cli_errors.py::test_missing_distance[render]",
    "tests/test_cli_errors.py::test_offset_distance_errors_quote_the_distance_as_given[40000km-True",
    "tests/test_cli_errors.py::test_offset_distance_errors_quote_the_distance_as_given[-1km-True",
    "tests/test_cli_errors.py::test_unsupported_image_formats[out.JPEG",
    "tests/test_field.py::test_cli_bad_input[args1-",
    "tests/test_field.py::test_cli_bad_input[args2-",
    "tests/test_field.py::test_cli_bad_input[args5-",
    "tests/test_field.py::test_cli_bad_input[args7-",
    "tests/test_tiles_checks.py::test_a_refused_resume_of_a_pmtiles_archive_leaves_nothing_behind[other",
    "tests/test_tiles_checks.py::test_an_existing_output_of_a_later_distance_is_refused_first[x]",
    "tests/test_tiles_checks.py::test_field_tiles_refuse_the_options_of_raster_tiles[option1]",
    "tests/test_tiles_checks.py::test_field_tiles_refuse_the_options_of_raster_tiles[option2]",
    "tests/test_tiles_checks.py::test_field_tiles_refuse_the_options_of_raster_tiles[option3]",
    "tests/test_tiles_checks.py::test_field_tiles_refuse_the_options_of_raster_tiles[option5]",
    "tests/test_tiles_checks.py::test_field_tiles_refuse_the_options_of_raster_tiles[option6]",
    "tests/test_tiles_checks.py::test_field_tiles_refuse_the_options_of_raster_tiles[option7]",
    "tests/test_tiles_checks.py::test_render_of_several_distances_names_the_output_as_typed[out.txt]",
    "tests/test_cli.py::test_errors_are_one_line[args2-",
    "tests/test_cli.py::test_errors_are_one_line[args3-",
    "tests/test_cli.py::test_render_errors[args2-",
    "tests/test_cli.py::test_render_errors[args3-",
    "tests/test_cli.py::test_render_errors[args4-",
    "tests/test_tiles_resume.py::test_an_interrupted_field_pyramid_resumes_to_the_uninterrupted_one[f.pmtiles]",
    "tests/test_tiles_resume.py::test_an_interrupted_field_pyramid_resumes_to_the_uninterrupted_one[fxyz]",
    "tests/test_tiles_resume.py::test_resume_over_another_inputs_archive_is_refused[t.mbtiles]",
    "tests/test_tiles_resume.py::test_resume_over_another_inputs_archive_is_refused[xyz]",
    "tests/test_grids_projected.py::test_cli_bad_crs_or_bounds[args1-",
    "tests/test_grids_projected.py::test_cli_bad_crs_or_bounds[args2-",
    "tests/test_grids_projected.py::test_cli_bad_crs_or_bounds[args3-",
    "tests/test_grids_projected.py::test_cli_bad_crs_or_bounds[args5-",
    "tests/test_simplified.py::test_simplified_render_equals_reference[grid2-",
    "tests/test_simplified.py::test_simplified_render_equals_reference[grid6-",
    "tests/test_simplified.py::test_simplified_render_equals_reference[grid8-",
    "tests/test_tiles.py::test_split_pyramid_tasks_make_the_same_tiles[Mexico--60000.0-3-6-1-kw2]",
    "tests/test_tms.py::test_world_crs84_pyramid_tiles_are_single_renders[400km]",
    "tests/test_ellipsoidal.py::test_gpu_screen_equals_the_cpu_path[russia]",
    "tests/test_mvt_pyramid.py::test_cli_refusals[args1-",
    "tests/test_mvt_pyramid.py::test_cli_refusals[args3-",
    "tests/test_tiles.py::test_split_pyramid_tasks_make_the_same_tiles[Mexico-127000.0-0-6-1-kw0]",
    "tests/test_serve_cors.py::test_a_page_of_another_origin_draws_the_tiles_with_cors_only",
    "tests/test_simplified.py::test_simplified_render_equals_reference[grid3-",
    "tests/test_golden.py::test_golden[vector/mexico_raw_offset_d+0.02]",
    "tests/test_tiles_checks.py::test_a_refused_resume_of_a_pmtiles_archive_leaves_nothing_behind[another",
    "tests/test_tms.py::test_world_crs84_tiles_against_reference[Mexico-0.0002-12]",
    "tests/test_tms.py::test_world_crs84_tiles_against_reference[Mexico--0.001-9]",
    "tests/test_tms.py::test_world_crs84_pyramid_real_border",
    "tests/test_render.py::test_small_regional_bounds[0.0001]",
    "tests/test_ring_rules.py::test_random_pole_rings_enclose_their_pole",
    "tests/test_grids_lcc.py::test_a_broken_function_is_caught",
    "tests/test_grids_laea.py::test_a_broken_function_is_caught",
    "tests/test_cli_errors.py::test_render_bands_refuse_styles_and_raster_input",
    "tests/test_golden.py::test_golden[raster_input/world_borders_cube_6x128_50km_levels]",
    "tests/test_field.py::test_cli_geotiff_npy_and_cube",
    "tests/test_field_walk_gpu.py::test_every_nearest_arc_is_in_its_cells_gpu_list[clamped]",
    "tests/test_field_walk_gpu.py::test_every_nearest_arc_is_in_its_cells_gpu_list[fiji]",
    "tests/test_field_gpu_sign.py::test_a_broken_sign_is_caught[side-flipped]",
    "tests/test_field_gpu.py::test_the_finishing_needs_the_features_within_reach[wrong-candidate]",
    "tests/test_field_gpu.py::test_the_whole_list_where_more_may_tie",
    "tests/test_field_walk_gpu.py::test_every_nearest_arc_is_in_its_cells_gpu_list[z5]",
    "tests/test_field_walk_gpu.py::test_fields_with_the_gpu_walk_have_the_cpu_bits[clamped]",
    "tests/test_field_sign.py::test_antimeridian_and_pole",
    "tests/test_simplified.py::test_simplified_render_equals_reference[grid5-0.015]",
    "tests/test_many.py::test_cli_tiles_writes_one_pyramid_per_distance[.mbtiles]",
    "tests/test_cli_errors.py::test_tiff_output",
    "tests/test_contains_fast.py::test_offset_regions_of_hard_countries[-0.003]",
)


def pytest_collection_modifyitems(config, items):
    """Mark the :data:`REPEATS` slow."""
    for item in items:
        if item.nodeid.startswith(REPEATS):
            item.add_marker(pytest.mark.slow)
