"""The guard of the field's GPU walk on a GL the tests have not run on: ``WALK = "auto"``
uses the GPU walk only where :func:`~gloffset.raster.fields.gpu.walk_check` finds its
field equal to the float64 walk's, and says so where it does not."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import gloffset
from gloffset.gl import context as gl_context
from gloffset.gl import walk_pass
from gloffset.grids import Equirect, Tile
from gloffset.raster.fields import gpu as field_gpu

BOX = field_gpu.check_grids()[1:]  # the fine grid alone: seconds on llvmpipe


def test_the_check_shape_crosses_the_antimeridian_and_holds_the_pole():
    shape = field_gpu.check_shape()
    field = gloffset.distance_field(shape, Equirect(72, 36), backend="cpu").values
    assert (field[-1] < 0).all()  # the south pole's row inside its ring
    assert (field[6:10, 0] < 0).any() and (field[6:10, -1] < 0).any()  # both sides of 180
    assert len(shape.lines) == 1 and len(shape.rings) == 4  # the box's hole a ring


def test_this_gl_passes_the_check():
    assert field_gpu.walk_check(BOX)


@pytest.mark.slow
def test_this_gl_passes_the_whole_check():
    assert field_gpu.walk_check()


@pytest.mark.parametrize("name, value", [("BIS_ABS", -1e-5), ("SUM_ERR", -1e-3)])
def test_a_broken_bound_fails_the_check(monkeypatch, name, value):
    """The bisector test's or the lower bounds' slack turned against the lists, by the
    amounts the check's docstring says it catches."""
    monkeypatch.setattr(walk_pass, name, value)
    assert not field_gpu.walk_check(BOX)


def _hardware(monkeypatch, ok: bool):
    """Make this thread's GL look like a hardware one whose check answers ``ok``; return
    the list of the GPU walk's calls."""
    real = field_gpu.context_info
    monkeypatch.setattr(field_gpu, "context_info", lambda: {**real(), "software": False})
    monkeypatch.setattr(field_gpu, "walk_check", lambda grid=None: ok)
    field_gpu.field_pass()  # this thread's engines exist
    monkeypatch.setitem(gl_context._LOCAL.shared, field_gpu._WalkCheck, None)  # asked afresh
    calls: list = []
    lists = field_gpu.gpu_lists
    monkeypatch.setattr(field_gpu, "gpu_lists", lambda *a: calls.append(1) or lists(*a))
    return calls


def test_auto_uses_the_gpu_walk_where_the_check_passes(mexico_path, monkeypatch):
    calls = _hardware(monkeypatch, True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gloffset.distance_field(gloffset.read(mexico_path), Tile(5, 6, 13))
    assert calls


def test_auto_uses_the_float64_walk_where_the_check_fails(mexico_path, monkeypatch):
    shape, grid = gloffset.read(mexico_path), Tile(5, 6, 13)
    want = gloffset.distance_field(shape, grid, backend="cpu").values
    calls = _hardware(monkeypatch, False)
    with pytest.warns(UserWarning, match="missed arcs on a check shape"):
        got = gloffset.distance_field(shape, grid).values
    assert not calls
    assert np.array_equal(got, want)
    with warnings.catch_warnings():  # once per thread
        warnings.simplefilter("error")
        gloffset.distance_field(shape, grid)


def _llvmpipe(monkeypatch):
    """The GPU walk's calls (this thread's GL llvmpipe, else the test is skipped)."""
    if "llvmpipe" not in str(gl_context.context_info().get("renderer", "")):
        pytest.skip("not llvmpipe")
    calls: list = []
    lists = field_gpu.gpu_lists
    monkeypatch.setattr(field_gpu, "gpu_lists", lambda *a: calls.append(1) or lists(*a))
    return calls


def test_auto_on_llvmpipe_walks_grids_of_many_cells_on_the_gpu(mexico_path, monkeypatch):
    """On llvmpipe "auto" walks on the GPU where the lists' level has at least
    SOFTWARE_CELLS cells (here lowered to a tile's 1,024), unchecked: the float64
    walk's field, bit for bit; in float64 below that."""
    shape, grid = gloffset.read(mexico_path), Tile(5, 6, 13)
    want = gloffset.distance_field(shape, grid, backend="cpu").values
    calls = _llvmpipe(monkeypatch)
    monkeypatch.setattr(field_gpu, "walk_check", lambda grid=None: 1 / 0)  # not asked
    monkeypatch.setattr(field_gpu, "SOFTWARE_CELLS", 1024)
    got = gloffset.distance_field(shape, grid).values
    assert calls and np.array_equal(got.view(np.uint32), want.view(np.uint32))
    calls.clear()
    monkeypatch.setattr(field_gpu, "SOFTWARE_CELLS", 1025)
    gloffset.distance_field(shape, grid)
    assert not calls
