"""The shape of the code (ARCHITECTURE.md): layers without cycles, short functions, no
private names shared across modules, grids that answer the Grid protocol, one level
driver whose walk does what its callers rely on."""

from __future__ import annotations

import ast
import importlib
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from gloffset.grids import Cube, CubeFace, Equirect, Tile
from gloffset.grids.cube import CubeCells
from gloffset.grids.mercator import TilePyramid
from gloffset.grids.protocol import CellSet, Grid
from gloffset.raster import driver

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "gloffset"
#: longest function body allowed (lines of code after the docstring)
MAX_BODY = 80
#: longest module docstring allowed (lines, its quotes included)
MAX_MODULE_DOCSTRING = 30


def _functions():
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                yield path, node


def _body_lines(node) -> int:
    body = node.body
    first = body[0]
    if isinstance(first, ast.Expr) and isinstance(getattr(first, "value", None), ast.Constant):
        body = body[1:]
    return 0 if not body else body[-1].end_lineno - body[0].lineno + 1


def test_no_function_longer_than_the_limit():
    long = [
        f"{p.relative_to(ROOT)}:{n.lineno} {n.name} ({_body_lines(n)} lines)"
        for p, n in _functions()
        if _body_lines(n) > MAX_BODY
    ]
    assert not long, "split these into named steps:\n" + "\n".join(long)


def test_no_module_docstring_is_longer_than_the_limit():
    # a module docstring states the design and the accuracy contract; derivations and
    # measurements are on the design page (docs/design.md, Module notes)
    long = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text())
        if ast.get_docstring(tree) is not None:
            first = tree.body[0]
            lines = first.end_lineno - first.lineno + 1
            if lines > MAX_MODULE_DOCSTRING:
                long.append(f"{path.relative_to(ROOT)} ({lines} lines)")
    assert not long, "shorten these module docstrings:\n" + "\n".join(long)


def test_no_private_name_is_imported_across_modules():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                for alias in node.names:
                    if alias.name.startswith("_") and not alias.name.startswith("__"):
                        found.append(f"{path.relative_to(ROOT)}:{node.lineno} {alias.name}")
    assert not found, "private names imported from another module:\n" + "\n".join(found)


def test_the_layering_contract_holds():
    exe = shutil.which("lint-imports")
    if exe is None:
        pytest.skip("import-linter is not installed (pip install -e '.[test]')")
    run = subprocess.run([exe], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]


def test_the_package_says_it_is_typed():
    """PEP 561: the marker ships in the wheel (every file under gloffset/ does)."""
    assert (PACKAGE / "py.typed").is_file()


def test_the_docstring_rules_cover_the_public_api():
    """Every module that defines a name of ``gloffset.__all__`` is in the scope of ruff's
    docstring rules (the negated pattern of ``[tool.ruff.lint.per-file-ignores]``)."""
    import inspect

    import gloffset

    tomllib = pytest.importorskip("tomllib")  # Python 3.11+

    ignores = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["ruff"]["lint"][
        "per-file-ignores"
    ]
    (pattern,) = [k for k, v in ignores.items() if k.startswith("!") and "D" in v]
    inner = re.fullmatch(r"!gloffset/\{(.*)\}\.py", pattern)
    assert inner, pattern
    covered = {"gloffset." + m.replace("/", ".") for m in inner[1].split(",")}
    covered = {m.removesuffix(".__init__") for m in covered}
    defining = set()
    for name in gloffset.__all__:
        obj = getattr(gloffset, name)
        module = obj.__name__ if inspect.ismodule(obj) else getattr(obj, "__module__", None)
        if module and module.startswith("gloffset"):
            defining.add(module)
    assert defining - covered == set(), "add these to the docstring rules' scope"


@pytest.mark.slow
def test_the_annotations_hold():
    """``mypy gloffset`` (its settings in pyproject.toml; .ci/run runs it too), which also
    checks that every grid answers its protocols (``gloffset/grids/__init__.py``)."""
    exe = shutil.which("mypy")
    if exe is None:
        pytest.skip("mypy is not installed (pip install -e '.[test]')")
    run = subprocess.run([exe, "gloffset"], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]


#: what a name in ARCHITECTURE.md looks like when it is a file or folder of the repository
_FILE = re.compile(r"[\w./-]+(?:/|\.(?:py|frag|vert|glsl|md|toml|json|geojson))")


def _named_paths(text: str) -> set[str]:
    """The paths ARCHITECTURE.md names: `quoted` paths, and the folders and modules of its
    layer diagram (a name without a top-level folder of the repository is under gloffset/)."""
    diagram = "\n".join(re.findall(r"```\n(.*?)```", text, re.S))
    names = set(re.findall(r"`([^`\s]+)`", text)) | set(re.findall(r"[\w.]+(?:/|\.py)\b", diagram))
    return {n for n in names if _FILE.fullmatch(n)}


def test_every_path_architecture_names_exists():
    named = _named_paths((ROOT / "ARCHITECTURE.md").read_text())
    assert len(named) > 80, sorted(named)  # the module list is read, not skipped
    top = {p.name for p in ROOT.iterdir()}
    missing = []
    for name in sorted(named):
        base = ROOT if name.split("/")[0] in top else PACKAGE
        if not (base / name).exists():
            missing.append(name)
    assert not missing, "ARCHITECTURE.md names paths that do not exist:\n" + "\n".join(missing)


def test_architecture_lists_every_module_once_in_its_layer_diagram():
    text = (ROOT / "ARCHITECTURE.md").read_text()
    diagram = re.findall(r"```\n(.*?)```", text, re.S)[0]
    packages = re.findall(r"^ (\w+)/", diagram, re.M)
    assert len(packages) == len(set(packages)), packages
    named = _named_paths(text)
    modules = [
        str(p.relative_to(ROOT))
        for p in PACKAGE.rglob("*.py")
        if p.name != "__init__.py" and "__pycache__" not in p.parts
    ]
    unnamed = [m for m in sorted(modules) if m not in named]
    assert not unnamed, "ARCHITECTURE.md does not describe:\n" + "\n".join(unnamed)


def test_the_readme_is_short_and_its_links_exist():
    """The README stays a front page (the rest is in docs/ and benchmarks/README.md), and
    every file it links to exists."""
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 300
    links = re.findall(r"\]\(([^)\s]+)\)", text)
    local = {link.split("#")[0] for link in links if not re.match(r"\w+:", link)} - {""}
    assert local, "no local links found"
    missing = sorted(link for link in local if not (ROOT / link).exists())
    assert not missing, missing


#: a Sphinx-style reference to a full name, e.g. :class:`~gloffset.raster.vector.curves.CurveCells`
_REFERENCE = re.compile(r":(?:class|func|mod|meth|attr|data|exc):`~?(gloffset(?:\.\w+)+)`")


def _resolves(name: str) -> bool:
    """Whether ``gloffset.a.b.C.d`` names something: the longest importable module, then
    attributes (a name only annotated in a class body counts as an attribute)."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        module = ".".join(parts[:i])
        try:
            obj = importlib.import_module(module)
        except ImportError:
            continue
        for attr in parts[i:]:
            if hasattr(obj, attr):
                obj = getattr(obj, attr)
            elif attr in getattr(obj, "__annotations__", {}):
                return attr == parts[-1]
            else:
                return False
        return True
    return False


def test_every_full_name_a_docstring_references_exists():
    broken = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for lineno, line in enumerate(path.read_text().splitlines(), 1):
            for name in _REFERENCE.findall(line):
                if not _resolves(name):
                    broken.append(f"{path.relative_to(ROOT)}:{lineno} {name}")
    assert not broken, "references to names that do not exist:\n" + "\n".join(broken)


def test_no_two_classes_share_a_name():
    seen: dict = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                seen.setdefault(node.name, []).append(str(path.relative_to(ROOT)))
    twice = {k: v for k, v in seen.items() if len(v) > 1}
    assert not twice, twice


# ------------------------------------------------------------------------- grids
GRIDS = [
    Equirect(100, 50),
    Equirect(64, 40, (170.0, -30.0, -170.0, 10.0)),
    Tile(3, 2, 5, 64),
    CubeFace(2, 96),
    CubeCells(96),
    TilePyramid(6),
]


@pytest.mark.parametrize("grid", GRIDS, ids=lambda g: type(g).__name__)
def test_every_grid_answers_the_protocol(grid):
    assert isinstance(grid, Grid)
    for level in range(grid.n_levels):
        h, w = grid.level_shape(level)
        j, i = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
        c = grid.centers(level, j.ravel(), i.ravel())
        np.testing.assert_allclose(np.linalg.norm(c, axis=1), 1.0, atol=1e-15)
        rho = grid.rho_at(level, j.ravel(), i.ravel())
        assert rho.shape == (h * w,) and np.all(rho >= 0)
        assert np.all(grid.decision_rho(level, j.ravel(), i.ravel()) <= rho)
        # the per-row bound is each row's largest
        assert np.allclose(grid.rho(level), rho.reshape(h, w).max(axis=1))
        if grid.lonlat:
            lat = grid.cell_lat(level, np.arange(h))
            np.testing.assert_allclose(c.reshape(h, w, 3)[:, 0, 2], np.sin(lat), atol=1e-15)


@pytest.mark.parametrize(
    "grid", [g for g in GRIDS if isinstance(g, CellSet)], ids=lambda g: type(g).__name__
)
def test_cell_set_neighbours_are_the_touching_cells(grid):
    """Neighbour tables agree with the geometry: two cells touch when their centres are
    within the sum of their area bounds plus one cell, and every listed neighbour is
    adjacent (and the relation is symmetric)."""
    level = grid.n_levels - 2
    h, w = grid.level_shape(level)
    ok = np.flatnonzero(np.repeat(grid.row_valid(level), w))
    table = grid.neighbour_table(level, ok)
    for c in ok[:: max(1, len(ok) // 300)]:
        row = table[np.searchsorted(ok, c)]
        nb = row[row >= 0]
        assert np.all(grid.adjacent(level, np.full(len(nb), c), nb))
        for q in nb:
            back = grid.neighbour_table(level, [q])[0]
            assert c in back
    if grid.lonlat and grid.wraps(level):
        # across the antimeridian: the last column touches the first
        assert grid.adjacent(level, [w - 1], [0])[0]


def test_equirect_wraps_only_round_the_globe():
    assert Equirect(64, 32).wraps(0)
    assert not Equirect(64, 32, (-100.0, -10.0, 100.0, 10.0)).wraps(0)
    assert not Tile(0, 0, 0, 64).wraps(0)


# ------------------------------------------------------------------------- driver
class _Stripes:
    """A toy classifier on a grid of three levels (32, 64, 128 cells a side): a cell is
    contained when its column is in the west quarter, outside when in the east quarter,
    else frontier; at the last level the west half is contained."""

    def __init__(self):
        self.grid = Equirect(128, 128)
        self.refined = []

    def _cls(self, level, cells):
        w = self.grid.level_shape(level)[1]
        x = (cells[:, 1] + 0.5) / w
        last = level == self.grid.n_levels - 1
        cls = np.full(len(cells), driver.FRONTIER, np.uint8)
        cls[x < (0.5 if last else 0.25)] = driver.CONTAINED
        cls[x >= (0.5 if last else 0.75)] = driver.OUTSIDE
        return cls

    def enter(self, stop):
        h, w = self.grid.level_shape(0)
        cells = np.argwhere(np.ones((h, w), bool))
        return driver.Level(0, cells, self._cls(0, cells))

    def refine(self, prev):
        keep = prev.frontier() if prev.keep is None else prev.keep
        self.refined.append((prev.level, len(keep)))
        kids = np.concatenate(
            [2 * prev.cells[keep] + np.array(d) for d in ((0, 0), (0, 1), (1, 0), (1, 1))]
        )
        kids = kids[np.lexsort((kids[:, 1], kids[:, 0]))]
        return driver.Level(prev.level + 1, kids, self._cls(prev.level + 1, kids))


def test_driver_paints_levels_and_refines_only_the_frontier():
    clf = _Stripes()
    grid = clf.grid
    seen = []
    classes = driver.run(clf, grid.n_levels - 1, callback=lambda lev, c: seen.append(lev))
    assert seen == list(range(grid.n_levels))
    w = grid.width
    want = np.where((np.arange(w) + 0.5) / w < 0.5, driver.CONTAINED, driver.OUTSIDE)
    assert np.array_equal(classes, np.broadcast_to(want, (grid.height, w)))
    # only frontier cells were refined: the middle half of the 32 x 32 cells
    assert clf.refined[0] == (0, 512)


def test_driver_hands_over_to_a_backend_at_the_handoff_level():
    clf = _Stripes()
    got = {}

    def backend(classes, lev):
        got["level"], got["shape"] = lev.level, classes.shape
        return np.full((128, 128), 7, np.uint8)

    out = driver.run(clf, clf.grid.n_levels - 1, handoff=0, backend=backend)
    assert got == {"level": 0, "shape": clf.grid.level_shape(0)} and out[0, 0] == 7
    # at or above the hand-off the classifier finishes alone
    assert driver.run(clf, 0, handoff=0, backend=backend).shape == clf.grid.level_shape(0)


def test_walk_refines_the_cells_the_consumer_keeps():
    clf = _Stripes()
    for lev in driver.walk(clf, clf.grid.n_levels - 1):
        if lev.level == 0:
            lev.keep = np.array([0, 1])  # two decided cells
    assert clf.refined[0] == (0, 2)


def test_pooled_levels():
    c = np.array([[2, 2, 0, 1], [2, 2, 0, 0]], np.uint8)
    assert np.array_equal(driver.pooled(c), [[2, 1]])


def test_cube_is_not_a_level_grid_but_its_faces_are():
    assert not isinstance(Cube(8), Grid)
    assert all(isinstance(f, Grid) for f in Cube(8).faces)


# ------------------------------------------------------------------- raster/ by concept
#: at most this many modules in a package of gloffset/ (itself included), and lines in a module
MAX_MODULES, MAX_LINES = 14, 700
#: the grid classes (raster/ and gl/ ask a grid what the protocol declares instead)
GRID_CLASSES = {"Equirect", "Tile", "Cube", "CubeFace", "CubeCells", "TilePyramid"}
GRID_CLASSES |= {"ConformalRows", "LevelHierarchy", "LonLatGrid"}


def _engine_modules():
    for top in ("raster", "gl", "tiles"):
        yield from sorted((PACKAGE / top).rglob("*.py"))


def test_gloffset_tiles_is_a_module_of_its_own():
    import gloffset.tiles

    assert gloffset.tiles.__name__ == "gloffset.tiles"
    assert Path(gloffset.tiles.__file__).resolve() == PACKAGE / "tiles" / "__init__.py"
    assert gloffset.tiles.pyramid.__module__.startswith("gloffset.tiles.tiling")


def test_modules_and_packages_are_small():
    """Every module of gloffset/ (not only the engine's) and every package, the top one too."""
    modules = sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)
    big = [
        f"{p.relative_to(ROOT)} ({n} lines)"
        for p in modules
        if (n := len(p.read_text().splitlines())) > MAX_LINES
    ]
    packages = {p.parent for p in modules}
    crowded = [
        f"{d.relative_to(ROOT)} ({n} modules)"
        for d in sorted(packages)
        if (n := len(list(d.glob("*.py")))) > MAX_MODULES
    ]
    assert not big and not crowded, big + crowded


def test_engine_functions_take_few_parameters():
    """At most 10 parameters: a public function with more takes them as ``**options``,
    one frozen dataclass of them."""
    many = []
    for path in _engine_modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
                n = len(names) + (a.vararg is not None) + (a.kwarg is not None)
                n -= bool(names) and names[0] in ("self", "cls")
                if n > 10:
                    many.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({n})")
    assert not many, many


#: the command-line commands still longer than MAX_COMMAND lines (to be split into steps)
LONG_COMMANDS = {"contains_cmd", "field_cmd", "offset_cmd", "serve_cmd"}
#: the longest command function of gloffset/cli, its decorators (the options) included
MAX_COMMAND = 60


def _cli_functions():
    for path in sorted((PACKAGE / "cli").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef):
                command = any("command" in ast.unparse(d) for d in node.decorator_list)
                yield path, node, command


def test_cli_helpers_take_few_parameters_and_commands_are_short():
    """A helper of a command takes at most 7 parameters (several options travel as one
    dataclass); a command (click passes it every option by name) is at most MAX_COMMAND
    lines with its decorators: option groups and steps are helpers."""
    many, long = [], []
    for path, node, command in _cli_functions():
        a = node.args
        n = len(a.posonlyargs + a.args + a.kwonlyargs) + (a.vararg is not None)
        n += a.kwarg is not None
        start = min([d.lineno for d in node.decorator_list] + [node.lineno])
        lines = node.end_lineno - start + 1
        where = f"{path.relative_to(ROOT)}:{node.lineno} {node.name}"
        if not command and n > 7:
            many.append(f"{where} ({n} parameters)")
        if command and lines > MAX_COMMAND and node.name not in LONG_COMMANDS:
            long.append(f"{where} ({lines} lines)")
    assert not many and not long, many + long


def test_engine_names_are_defined_once():
    """Public functions and classes of raster/ and gl/ say which they are: no name twice
    (the level operations' ``refine`` of cells and of nodes aside)."""
    seen: dict = {}
    for path in _engine_modules():
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and node.name[0] != "_":
                seen.setdefault(node.name, []).append(str(path.relative_to(ROOT)))
    twice = {k: v for k, v in seen.items() if len(v) > 1 and k != "refine"}
    assert not twice, twice


def test_engine_dispatches_on_no_grid_class():
    """raster/ and gl/ ask a grid its declared capabilities (grids/protocol.py), never
    its class."""
    found = []
    for path in _engine_modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "isinstance":
                arg = node.args[1]
                names = {getattr(e, "id", getattr(e, "attr", None)) for e in ast.walk(arg)}
                if names & GRID_CLASSES:
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not found, found


@pytest.mark.parametrize("grid", [*GRIDS, Cube(8)], ids=lambda g: type(g).__name__)
def test_images_declare_their_faces(grid):
    from gloffset.grids.protocol import Image, ImageGrid

    if not isinstance(grid, Image):
        return
    assert len(grid.faces) == grid.n_faces
    assert all(isinstance(f, ImageGrid) and f.n_faces == 1 for f in grid.faces)
    assert grid.n_faces == 1 and grid.faces[0] is grid or grid.shape[0] == grid.n_faces
