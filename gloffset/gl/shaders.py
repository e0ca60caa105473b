"""Strict loading of the GLSL sources in ``shaders/``.

Rules: a top-level shader starts with ``#version`` on line 1; library files
(``lib/*.glsl``) have no ``#version``; ``#include "lib/name.glsl"`` pulls a file in
once (later includes of the same file are dropped), recursively, and ``#include NAME``
the file that the define ``NAME`` names (``{"GRID_GLSL": '"lib/grids/x.glsl"'}``: a
grid's GLSL function; nothing where ``NAME`` is not defined; the shader sees ``NAME``
defined as 1); ``#line``
directives number every file so that compiler errors point at the file and line,
and :func:`program` rewrites the driver's ``0:12(3)`` / ``0(12)`` locations into
``lib/arcs.glsl:12``.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import ShaderError

__all__ = ["SHADER_DIR", "ShaderError", "load_source", "program", "shader_files"]


def _find_dir() -> Path:
    here = Path(__file__).resolve().parent.parent
    for cand in (here / "shaders", here.parent / "shaders"):
        if cand.is_dir():
            return cand
    raise ShaderError(f"no shaders/ folder next to {here} (a broken installation?)")


SHADER_DIR = _find_dir()
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')
_INCLUDE_DEFINE = re.compile(r"^\s*#\s*include\s+([A-Za-z_][A-Za-z0-9_]*)\s*$")


def shader_files() -> list[str]:
    """All shader files, relative to the shader folder."""
    return sorted(
        str(p.relative_to(SHADER_DIR))
        for p in SHADER_DIR.rglob("*")
        if p.suffix in (".glsl", ".vert", ".frag", ".comp")
    )


def load_source(name: str, defines: dict | None = None, *, root=None) -> tuple[str, list[str]]:
    """The full source of shader ``name`` with includes resolved, and the file of each id.

    ``name`` is looked up in ``root`` (default: the shader folder); includes always
    come from the shader folder.
    """
    files: list[str] = []
    seen: set[str] = set()

    def read(rel: str, top: bool) -> list[str]:
        base = Path(root) if (top and root is not None) else SHADER_DIR
        path = (base / rel).resolve()
        if base.resolve() not in path.parents or not path.is_file():
            raise ShaderError(f"shader file {rel!r} not found in {base}")
        lines = path.read_text().splitlines()
        fid = len(files)
        files.append(rel)
        if top and (not lines or not lines[0].startswith("#version")):
            raise ShaderError(f"{rel}:1: a shader must start with #version")
        if not top and any(ln.lstrip().startswith("#version") for ln in lines):
            raise ShaderError(f"{rel}: an included file must not have #version")
        out = []
        for k, ln in enumerate(lines, start=1):
            m = _INCLUDE.match(ln)
            named = _INCLUDE_DEFINE.match(ln)
            if named:
                value = str((defines or {}).get(named.group(1), "")).strip()
                if value and not (len(value) > 2 and value[0] == value[-1] == '"'):
                    raise ShaderError(
                        f"{rel}:{k}: {named.group(1)} must name a file in quotes, got {value!r}"
                    )
                m = _INCLUDE.match(f"#include {value}") if value else None
                if m is None:
                    out.append(f"// {ln.strip()}: not defined")
                    continue
            if m:
                inc = m.group(1)
                if inc not in seen:
                    seen.add(inc)
                    out.extend(read(inc, False))
                out.append(f"#line {k + 1} {fid}")
            elif top and k == 1:
                out.append(ln)
                for key, val in (defines or {}).items():
                    # a file's name (for #include NAME) is defined as 1 for the #ifdefs
                    val = 1 if str(val).startswith('"') else val
                    out.append(f"#define {key} {val}")
                out.append(f"#line 2 {fid}")
            else:
                out.append(ln)
        if not top:
            out.insert(0, f"#line 1 {fid}")
        return out

    seen.add(name)
    return "\n".join(read(name, True)) + "\n", files


_LOC = re.compile(r"\b(\d+):(\d+)\((\d+)\)|\b(\d+)\((\d+)\)")


def _relabel(log: str, files: list[str]) -> str:
    def sub(m):
        if m.group(1) is not None:
            fid, line = int(m.group(1)), m.group(2)
        else:
            fid, line = int(m.group(4)), m.group(5)
        return f"{files[fid]}:{line}" if fid < len(files) else m.group(0)

    return _LOC.sub(sub, log)


def program(ctx, vertex: str, fragment: str, defines: dict | None = None, *, root=None):
    """Compile and link a program from two shader files (errors name file and line).

    ``root`` is where the fragment shader is looked up (default: the shader folder).
    """
    vs, vfiles = load_source(vertex, defines)
    fs, ffiles = load_source(fragment, defines, root=root)
    try:
        return ctx.program(vertex_shader=vs, fragment_shader=fs)
    except Exception as exc:  # moderngl.Error carries the compiler log
        msg = str(exc)
        files = ffiles if "fragment" in msg.lower() else vfiles
        raise ShaderError(f"shader compile/link failed: {_relabel(msg, files)}") from None
