"""The layers of the raster engine: gloffset.gl holds only GL (it imports nothing of the
planner), and the numbers that the planner, the GL passes and the shaders share are the
same in each (class codes, the record format)."""

import ast
import re
from pathlib import Path

import pytest

from gloffset.geometry import classes
from gloffset.gl import vector_pass as gl_engine
from gloffset.gl.context import shared
from gloffset.gl.shaders import SHADER_DIR
from gloffset.raster import records

PACKAGE = Path(classes.__file__).resolve().parents[1]
GL_MAY_IMPORT = ("gloffset.gl", "gloffset.errors", "gloffset.geometry.classes")


def _imports(path: Path, package: str) -> set[str]:
    """The gloffset modules that the module at ``path`` (in ``package``) imports."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module
            out.add(mod)
            if not node.module:  # from . import name: the name may be a module
                out.update(f"{mod}.{a.name}" for a in node.names)
    return {m for m in out if m.split(".")[0] == "gloffset"}


@pytest.mark.parametrize("path", sorted((PACKAGE / "gl").glob("*.py")), ids=lambda p: p.name)
def test_gl_imports_nothing_of_the_planner(path):
    bad = {
        m
        for m in _imports(path, "gloffset.gl")
        if not any(m == a or m.startswith(a + ".") for a in GL_MAY_IMPORT)
    }
    assert not bad, f"gloffset/gl/{path.name} imports {sorted(bad)}"


@pytest.mark.parametrize("name", ["records.py", "layout.py"])
def test_planner_data_needs_no_gl(name):
    """The record packing and the bin layout are plain numpy (no GL context to test)."""
    mods = _imports(PACKAGE / "raster" / name, "gloffset.raster")
    assert not any(m.startswith("gloffset.gl") for m in mods), mods


def _consts(name: str) -> dict[str, int]:
    """``const uint|int NAME = N[u];`` of a shader file."""
    text = (SHADER_DIR / name).read_text()
    return {
        m.group(1): int(m.group(2))
        for m in re.finditer(r"const\s+(?:uint|int)\s+(\w+)\s*=\s*(\d+)u?\s*;", text)
    }


@pytest.mark.parametrize("name", ["classify.frag", "raster_classify.frag"])
def test_shader_class_codes(name):
    got = {k: v for k, v in _consts(name).items() if k in classes.__all__}
    assert {"OUTSIDE", "FRONTIER", "CONTAINED"} <= set(got)
    assert got == {k: getattr(classes, k) for k in got}


def test_class_codes_are_distinct_bytes():
    codes = [getattr(classes, k) for k in classes.__all__]
    assert len(set(codes)) == len(codes) and all(0 <= c < 256 for c in codes)


def test_record_format():
    frag, arcs = _consts("classify.frag"), _consts("lib/arcs.glsl")
    assert frag["RECORD_TEXELS"] == records.RECORD_TEXELS == gl_engine.RECORD_TEXELS
    assert frag["CLUSTER_TEXELS"] * 16 == gl_engine._CLUSTER_BYTES
    for flag in ("ARC_IS_ARC", "ARC_HAS_DISTANCE", "ARC_RING"):
        assert arcs[flag] == getattr(records, flag)
    # a cluster header holds 16 * first record + records - 1: up to 16 records
    assert 1 <= records.CLUSTER <= 16
    assert records.OTHER_BIT == 31 and records.MAX_LOCAL < records.OTHER_BIT


def test_shared_makes_one_instance():
    class Made:
        count = 0

        def __init__(self):
            Made.count += 1

    assert shared(Made) is shared(Made) and Made.count == 1


def test_nothing_outside_the_tests_imports_the_judge():
    """The reference judges the production code; no module of the package calls it (the
    import-linter contract says the same; this also covers modules added later)."""
    bad = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        mods = _imports(path, ".".join(rel.parts[:-1]))
        if rel.parts != ("gloffset", "reference") and "gloffset.reference" in mods:
            bad[str(rel)] = sorted(m for m in mods if m.startswith("gloffset.reference"))
    assert not bad


def test_the_judge_imports_only_the_maths_and_the_shape():
    """The reference has its own crossing test and distance (no gloffset.geometry.crossings, no
    gloffset.edges): the two implementations check each other."""
    mods = _imports(PACKAGE / "reference.py", "gloffset")
    allowed = ("gloffset.geometry.sphere", "gloffset.units", "gloffset.errors", "gloffset.shape")
    assert mods and all(m in allowed for m in mods), sorted(mods)


@pytest.mark.parametrize("path", sorted((PACKAGE / "vector").glob("*.py")), ids=lambda p: p.name)
def test_vector_imports_no_file_format(path):
    """vector/ makes rings; io/ writes them (the import-linter contract says the same)."""
    mods = _imports(path, "gloffset.vector")
    assert not [m for m in mods if m == "gloffset.io" or m.startswith("gloffset.io.")]
