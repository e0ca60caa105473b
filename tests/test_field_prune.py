"""The GPU field's pruning of its cells' lists (``shaders/field_pixels.comp``,
``prune_limit``, ``kept_bits``): each pixel ranks only the arcs whose caps come within
``U + PRUNE_MARGIN`` of it, ``U`` its least chord to the caps of its list's chunks and
to the ends of the arcs of the chunks that may hold a nearer one.
It changes no value that is read: the field and the sign codes are those of the
unpruned lists bit for bit, on real borders; a broken bound is off the CPU's values."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DATA, field_and_codes, named_countries

import gloffset
from gloffset.gl.field_pass import FieldPass
from gloffset.grids import Equirect, Tile

#: The shader's test that turns the pruning on (made ``false``: never pruned).
PRUNED = "bool prune = list.y >= PRUNE_MIN;"


@pytest.fixture(autouse=True)
def always_pruned(monkeypatch):
    """The pruning's variant of the pass on every block, whatever its lists' lengths."""
    from gloffset.gl import field_pass

    monkeypatch.setattr(field_pass, "PRUNE_MEAN", 0)


@pytest.fixture(scope="module")
def mexico(mexico_path):
    return gloffset.read(mexico_path)


@pytest.fixture(scope="module")
def fiji_antarctica():
    """Fiji (across the antimeridian) and Antarctica (round the pole), 1:110m."""
    return named_countries("Fiji", "Antarctica")


@pytest.fixture(scope="module")
def pieces():
    """Countries of 1:10m with long, wiggly coasts: the United States (its Aleutians
    across the antimeridian), Greece and the Philippines."""
    return named_countries(
        "United States", "Greece", "Philippines", path=DATA / "countries_10m.geojson"
    )


#: Every list pruned, however short (1:110m borders have short lists).
EVERY = ("const uint PRUNE_MIN = 8u;", "const uint PRUNE_MIN = 1u;")


def shader_with(monkeypatch, folder, *subs) -> None:
    """Run the field's pass from a copy of ``shaders/field_pixels.comp`` in ``folder``
    with each ``(old, new)`` of ``subs`` made."""
    from gloffset.gl.field_pass import field_pass
    from gloffset.gl.shaders import SHADER_DIR

    src = (SHADER_DIR / "field_pixels.comp").read_text()
    for old, new in subs:
        assert src.count(old) == 1, old
        src = src.replace(old, new)
    folder.mkdir(exist_ok=True)
    (folder / "field_pixels.comp").write_text(src)
    monkeypatch.setattr(field_pass(), "root", folder)


def assert_pruning_changes_nothing(shape, grid, monkeypatch, tmp_path):
    with monkeypatch.context() as m:
        shader_with(m, tmp_path / "every", EVERY)
        pruned, codes = field_and_codes(shape, grid, monkeypatch)
    with monkeypatch.context() as m:
        shader_with(m, tmp_path / "none", EVERY, (PRUNED, "bool prune = false;"))
        whole, whole_codes = field_and_codes(shape, grid, monkeypatch)
    assert pruned.tobytes() == whole.tobytes()
    assert len(codes) == len(whole_codes)
    for a, b in zip(codes, whole_codes):
        assert (a is None and b is None) or np.array_equal(a, b)
    return pruned


@pytest.mark.parametrize(
    "grid", [Tile(3, 1, 3), Tile(5, 6, 13), Tile(7, 24, 55)], ids=["z3", "z5", "z7"]
)
def test_mexico_tiles_as_unpruned(mexico, grid, monkeypatch, tmp_path):
    field = assert_pruning_changes_nothing(mexico, grid, monkeypatch, tmp_path)
    assert (field < 0).any() and (field > 0).any()


@pytest.mark.parametrize(
    "grid",
    [
        Equirect(256, 128, (170.0, -22.0, -172.0, -12.0)),  # Fiji across the antimeridian
        Equirect(512, 64, (-180.0, -90.0, 180.0, -60.0)),  # Antarctica round the pole
    ],
    ids=["antimeridian", "pole"],
)
def test_seams_and_the_pole_as_unpruned(fiji_antarctica, grid, monkeypatch, tmp_path):
    assert_pruning_changes_nothing(fiji_antarctica, grid, monkeypatch, tmp_path)


def test_cube_faces_and_a_polar_grid_as_unpruned(fiji_antarctica, monkeypatch, tmp_path):
    """The centres made on the GPU from cube faces' coordinates and from a grid's GLSL
    function (Antarctica on polar stereographic): pruned as the lon/lat grids."""
    from gloffset.grids import Cube, Projected

    polar = Projected(140, 120, crs="EPSG:3031", bounds=(-3.2e6, -2.8e6, 3.2e6, 3.2e6))
    assert polar.centres == "glsl"
    for grid in (Cube(32), polar):
        assert_pruning_changes_nothing(fiji_antarctica, grid, monkeypatch, tmp_path)


@pytest.mark.parametrize(
    "grid",
    [Tile(4, 0, 5), Tile(5, 17, 12), Tile(6, 53, 29)],
    ids=["aleutians-z4", "greece-z5", "philippines-z6"],
)
def test_countries_pieces_as_unpruned(pieces, grid, monkeypatch, tmp_path):
    assert_pruning_changes_nothing(pieces, grid, monkeypatch, tmp_path)


@pytest.mark.parametrize(
    "old, new",
    [
        ("float r = lim + cap.w;", "float r = lim;"),  # the caps taken for their centres
        ("return u + u_prune;", "return 0.5 * u;"),  # a bound below the least chord
        # a chunk's arcs skipped where its cap passes
        ("uint m = dot(dc, dc) <= rc * rc ?", "uint m = dot(dc, dc) <= 0.25 * rc * rc ?"),
    ],
    ids=["no-radius", "half-bound", "chunk-cap"],
)
def test_a_broken_bound_is_off(mexico, fiji_antarctica, monkeypatch, tmp_path, old, new):
    """A pruning that drops arcs some pixel needs is off the CPU's values by more than
    an ulp (so the pruning runs, and the tests above would see a broken one): on a
    Mexico tile and round the pole."""
    cases = [(mexico, Tile(5, 6, 13)), (fiji_antarctica, Equirect(512, 64, (-180, -90, 180, -60)))]
    wants = [gloffset.distance_field(s, g, radius=1.0, backend="cpu").values for s, g in cases]
    shader_with(monkeypatch, tmp_path, EVERY, (old, new))
    for (shape, grid), want in zip(cases, wants):
        bad = gloffset.distance_field(shape, grid, radius=1.0).values
        ulp = np.spacing(np.abs(want))
        off = np.abs(bad.astype(np.float64) - want.astype(np.float64)) > ulp
        assert off.sum() > 100


def test_chunk_caps_hold_their_arcs_caps(mexico, monkeypatch):
    """Each chunk's cap holds the float32 caps of its arcs (as the shader reads them),
    in float64: a point beyond ``x + R`` of its centre is beyond ``x + r`` of each."""
    from gloffset.gl.field_pass import CHUNK, chunk_caps

    plans = []
    run = FieldPass.run
    monkeypatch.setattr(FieldPass, "run", lambda self, plan: plans.append(plan) or run(self, plan))
    gloffset.distance_field(mexico, Tile(4, 3, 6), radius=1.0)
    plan = plans[0]
    caps = chunk_caps(plan.cells, plan.pairs, plan.arcs).astype(np.float64)
    first, cnt = plan.cells[..., 0].ravel(), plan.cells[..., 1].ravel()
    starts = []
    for f, n in zip(first.tolist(), cnt.tolist()):
        for s in range(f, f + n, CHUNK):
            arc = plan.arcs[plan.pairs[s : min(s + CHUNK, f + n)], 4].astype(np.float64)
            c, radius = caps[s, :3], caps[s, 3]
            assert abs(np.linalg.norm(c) - 1.0) < 1e-6
            assert (np.linalg.norm(arc[:, :3] - c, axis=1) + arc[:, 3] <= radius).all()
            starts.append(s)
    assert len(starts) > 1000 and cnt.max() > 4 * CHUNK
    others = np.setdiff1d(np.arange(len(plan.pairs)), starts)
    assert (caps[others] == 0).all()


def test_deep_blocks_with_short_lists_run_unpruned(mexico, monkeypatch):
    """A block whose cells lie deep (their median distance to the nearest arc at least
    ``PRUNE_DEPTH`` of their ``rho``) with short lists runs the unpruned program, one
    near the coast the pruned one (``pruned``, the depth from the float64 walk): the
    same values either way. Mexico's lists are short: here the rule from 2 pairs a cell."""
    from gloffset.gl import field_pass
    from gloffset.gl.field_pass import PRUNE_DEPTH, pruned
    from gloffset.raster.fields import gpu as field_gpu

    monkeypatch.setattr(field_gpu, "WALK", "cpu")
    assert pruned(100, 10, None) and pruned(100, 10, 1.0) and pruned(100, 10, PRUNE_DEPTH)
    monkeypatch.setattr(field_pass, "PRUNE_MEAN", 16)
    assert not pruned(200, 10, PRUNE_DEPTH) and not pruned(100, 10, None)
    assert pruned(200, 10, 0.5 * PRUNE_DEPTH) and pruned(400, 10, 10 * PRUNE_DEPTH)
    monkeypatch.setattr(field_pass, "PRUNE_MEAN", 2)
    seen = []
    program = FieldPass.program

    def record(self, kind, source=None, probe=False, prune=False):
        seen.append(prune)
        return program(self, kind, source, probe, prune)

    monkeypatch.setattr(FieldPass, "program", record)
    deep, coast = Tile(8, 57, 113), Tile(5, 7, 14)  # about Mexico City; the Pacific coast
    got = gloffset.distance_field(mexico, deep, radius=1.0).values
    assert seen == [False]
    gloffset.distance_field(mexico, coast, radius=1.0)
    assert seen == [False, True]
    monkeypatch.setattr(field_pass, "PRUNE_DEPTH", np.inf)
    want = gloffset.distance_field(mexico, deep, radius=1.0).values
    assert seen == [False, True, True]
    assert got.tobytes() == want.tobytes()
