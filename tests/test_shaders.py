"""Every shader compiles; the loader is strict; GLSL library functions agree with numpy."""

from pathlib import Path

import numpy as np
import pytest

from gloffset.gl import get_context
from gloffset.gl.shaders import ShaderError, load_source, program, shader_files

HERE = Path(__file__).parent / "glsl"


@pytest.fixture(scope="module")
def ctx():
    return get_context()


@pytest.mark.parametrize("name", shader_files())
def test_every_shader_file_compiles(ctx, name):
    if name.endswith(".comp"):
        prog = ctx.compute_shader(load_source(name)[0])
    elif name.endswith(".vert"):
        prog = program(ctx, name, "upsample.frag")
    elif name.endswith(".frag"):
        prog = program(ctx, "fullscreen.vert", name)
    else:  # a library file: compile it inside a minimal fragment shader
        src = f'#version 430\n#include "{name}"\nout vec4 o;\nvoid main() {{ o = vec4(0.0); }}\n'
        tmp = HERE / "_lib_probe.frag"
        tmp.write_text(src)
        try:
            prog = program(ctx, "fullscreen.vert", "_lib_probe.frag", root=HERE)
        finally:
            tmp.unlink()
    assert prog is not None
    assert ctx.error == "GL_NO_ERROR"


def test_refine_pairs_count_variant_compiles(ctx):
    prog = ctx.compute_shader(load_source("refine_pairs.comp", {"COUNT": 1})[0])
    assert prog is not None
    assert ctx.error == "GL_NO_ERROR"


@pytest.mark.parametrize("define", ["CLUSTERS", "ORDER"])
def test_arc_records_variants_compile(ctx, define):
    prog = ctx.compute_shader(load_source("arc_records.comp", {define: 1})[0])
    assert prog is not None
    assert ctx.error == "GL_NO_ERROR"


@pytest.mark.parametrize("name", ["classify.frag", "raster_classify.frag"])
def test_grid_cube_variants_compile(ctx, name):
    # the files above compile without defines; these also have a GRID_CUBE variant
    assert program(ctx, "bins.vert", name, {"GRID_CUBE": 1}) is not None
    assert ctx.error == "GL_NO_ERROR"


def test_textured_centres_variant_compiles(ctx):
    # grids whose cell centres come from textures (gloffset.grids.Projected)
    assert program(ctx, "bins.vert", "classify.frag", {"GRID_TEXTURE": 1}) is not None
    assert ctx.error == "GL_NO_ERROR"


GRID_FUNCTIONS = sorted(n for n in shader_files() if n.startswith("lib/grids/"))


@pytest.mark.parametrize("name", GRID_FUNCTIONS)
def test_grid_glsl_variants_compile(ctx, name):
    # a grid's GLSL function of its centres (gloffset.grids.protocol.GlslCentres) in the
    # level program: classify.frag with GRID_GLSL naming its file
    prog = program(ctx, "bins.vert", "classify.frag", {"GRID_GLSL": f'"{name}"'})
    assert "u_grid" in prog and "u_bin_centre_lo" in prog
    assert ctx.error == "GL_NO_ERROR"


@pytest.mark.parametrize(
    "defines",
    [{"GRID_CUBE": 1}, {"GRID_TEXTURE": 1}, {"PROBE_RANKING": 1}, {"PRUNE": 1}]
    + [{"GRID_GLSL": f'"{name}"'} for name in GRID_FUNCTIONS],
)
def test_field_pixels_variants_compile(ctx, defines):
    # the distance field's pass (gloffset/gl/field_pass.py): its centres per kind of grid,
    # the ranking's probe and the pruning of the lists
    assert ctx.compute_shader(load_source("field_pixels.comp", defines)[0]) is not None
    assert ctx.error == "GL_NO_ERROR"


def test_include_of_a_define():
    # "#include NAME" takes the file NAME names; nothing where NAME is not defined
    name = "lib/grids/polar_stereographic.glsl"
    src, files = load_source("classify.frag", {"GRID_GLSL": f'"{name}"'})
    assert name in files and "lib/fp64.glsl" in files
    assert "#define GRID_GLSL 1" in src and "dvec3 grid_centre(dvec2 px)" in src
    src, files = load_source("classify.frag")
    assert name not in files and "dvec3 grid_centre(" not in src
    with pytest.raises(ShaderError, match="must name a file in quotes"):
        load_source("classify.frag", {"GRID_GLSL": name})
    assert name in GRID_FUNCTIONS


def test_includes_once_with_line_directives():
    src, files = load_source("classify.frag")
    assert src.startswith("#version 430\n")
    assert files == [
        "classify.frag",
        "lib/lonlat.glsl",
        "lib/precise.glsl",
        "lib/cube.glsl",
        "lib/arcs.glsl",
    ]
    assert src.count("float precise_sin(float x)") == 1
    assert "#line 1 2" in src  # precise.glsl starts at its own line 1


def test_loader_errors(ctx):
    with pytest.raises(ShaderError, match="must start with #version"):
        load_source("no_version.frag", root=HERE)
    with pytest.raises(ShaderError, match="not found"):
        load_source("nope.frag")
    with pytest.raises(ShaderError) as err:
        program(ctx, "fullscreen.vert", "broken.frag", root=HERE)
    # the compiler's location is rewritten into the file and line
    assert "broken.frag:5" in str(err.value)


def test_lonlat_offset_matches_float64(ctx):
    rng = np.random.default_rng(4)
    n = 256
    phi = rng.uniform(-1.5, 1.5, n).astype(np.float32).astype(np.float64)
    lam = rng.uniform(-3.1, 3.1, n).astype(np.float32).astype(np.float64)
    scale = 10.0 ** rng.uniform(-9, -1, n)
    dphi = (rng.uniform(-1, 1, n) * scale).astype(np.float32).astype(np.float64)
    dlam = (rng.uniform(-1, 1, n) * scale).astype(np.float32).astype(np.float64)
    data = np.stack([phi, lam, dphi, dlam], axis=1).astype(np.float32)
    tex = ctx.texture((n, 1), 4, data.tobytes(), dtype="f4")
    out = ctx.texture((n, 1), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[out])
    prog = program(ctx, "fullscreen.vert", "probe_lonlat.frag", root=HERE)
    prog["u_in"] = 0
    tex.use(0)
    fbo.use()
    ctx.viewport = (0, 0, n, 1)
    ctx.vertex_array(prog, []).render(vertices=3)
    got = np.frombuffer(out.read(), dtype=np.float32).reshape(n, 4).astype(np.float64)

    def xyz(p, la):
        return np.stack([np.cos(p) * np.cos(la), np.cos(p) * np.sin(la), np.sin(p)], axis=1)

    # the reference uses the float32-rounded (cos, sin) of the centre, as the shader does
    want = xyz(phi + dphi, lam + dlam) - xyz(phi, lam)
    err = np.linalg.norm(got[:, :3] - want, axis=1) / np.linalg.norm(want, axis=1)
    # relative accuracy of a few float32 ulp of |p - c| (plus the centre's own rounding)
    assert np.all(err < 2e-6), err.max()
    assert np.all(np.abs(got[:, 3] - np.sin(dphi)) <= 3e-7 * np.abs(np.sin(dphi)) + 1e-45)
    for r in (fbo, out, tex):
        r.release()
