"""One exception hierarchy: every exception class of gloffset lives in gloffset.errors.

Each is exported from :mod:`gloffset`, derives from :class:`gloffset.GloffsetError` and from
the builtin a Python user expects, and says in its docstring when it is raised. Modules that
used to define a class (or a class since merged into another) still give it under the old
name. How the command line prints each error is tested in ``test_cli_errors.py``.
"""

import ast
import importlib
import pkgutil
from pathlib import Path

import pytest

import gloffset
import gloffset.errors

BUILTINS = (ValueError, OSError, RuntimeError, LookupError)


def _modules():
    """Every module of the package, imported (``__main__`` would run the command line)."""
    mods = [gloffset]
    for info in pkgutil.walk_packages(gloffset.__path__, "gloffset."):
        if info.name.rsplit(".", 1)[-1] != "__main__":
            mods.append(importlib.import_module(info.name))
    return mods


def _exception_classes():
    """Exception classes defined in gloffset: those bound in a module and, to find classes
    defined anywhere else, every subclass of BaseException created by importing them."""
    found = set()
    for mod in _modules():
        for obj in vars(mod).values():
            if isinstance(obj, type) and issubclass(obj, BaseException):
                found.add(obj)
    todo = [BaseException]
    while todo:
        cls = todo.pop()
        found.add(cls)
        todo.extend(cls.__subclasses__())
    return sorted(
        (c for c in found if c.__module__.split(".")[0] == "gloffset"), key=lambda c: c.__name__
    )


CLASSES = _exception_classes()


def test_classes_found():
    names = {c.__name__ for c in CLASSES}
    assert {"GloffsetError", "InvalidGridError", "TilesError", "ShaderError"} <= names
    assert names == set(gloffset.errors.__all__)


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_in_one_hierarchy(cls):
    assert cls.__module__ == "gloffset.errors", f"{cls.__name__} is defined in {cls.__module__}"
    assert getattr(gloffset, cls.__name__, None) is cls and cls.__name__ in gloffset.__all__
    assert getattr(gloffset.errors, cls.__name__) is cls
    assert issubclass(cls, gloffset.GloffsetError)
    if cls is not gloffset.GloffsetError:
        assert issubclass(cls, BUILTINS), f"{cls.__name__} derives from none of {BUILTINS}"
    doc = cls.__dict__.get("__doc__")
    assert doc and doc.strip(), f"{cls.__name__} has no docstring"


def test_base_class_never_raised():
    """Code raises a class that says what went wrong, never GloffsetError itself."""
    root = Path(gloffset.__file__).parent
    bare = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Raise) and node.exc is not None:
                exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
                if isinstance(exc, ast.Name) and exc.id == "GloffsetError":
                    bare.append(f"{path.relative_to(root)}:{node.lineno}")
    assert not bare, bare


# (module, name there, the class of gloffset.errors it is)
OLD_NAMES = [
    ("gloffset.grids", "InvalidGridError", "InvalidGridError"),
    ("gloffset.grids.base", "InvalidGridError", "InvalidGridError"),
    ("gloffset.tiles", "TilesError", "TilesError"),
    ("gloffset.gl", "ShaderError", "ShaderError"),
    ("gloffset.gl.shaders", "ShaderError", "ShaderError"),
    ("gloffset.tiles.store.tilestore", "OutputExistsError", "OutputExistsError"),
    ("gloffset.raster.rasterized", "InvalidMaskError", "InvalidMaskError"),
    ("gloffset.raster.render", "RenderError", "OptionError"),
    ("gloffset.raster.rasterized", "RasterOffsetError", "OptionError"),
    ("gloffset.tiles.tiling.tilepaint", "StyleError", "OptionError"),
    ("gloffset.io.png", "ColorError", "OptionError"),
    ("gloffset.cli.render", "CubeFacesError", "InputFormatError"),
]


@pytest.mark.parametrize("module, name, canonical", OLD_NAMES)
def test_old_names(module, name, canonical):
    assert getattr(importlib.import_module(module), name) is getattr(gloffset.errors, canonical)


def test_relations():
    e = gloffset.errors
    assert issubclass(e.TilesError, e.InvalidGridError)
    assert issubclass(e.InvalidMaskError, e.OptionError)
    assert issubclass(e.OutputExistsError, e.OutputError)
    assert issubclass(e.OutputExistsError, FileExistsError)
    err = e.OutputExistsError("out.mbtiles")
    assert "'out.mbtiles' exists" in str(err) and "--force" in str(err)
