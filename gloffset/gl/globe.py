"""The globe pass: an orthographic view of cube-map masks, drawn in one fragment pass
(``shaders/globe.frag``). It is handed the masks and the view; it plans nothing."""

from __future__ import annotations

import numpy as np

from .context import get_context
from .shaders import program
from .textures import set_uniform

__all__ = ["draw_globe"]


def _cube_texture(ctx, faces: np.ndarray):
    """A cube-map texture from six (N, N) uint8 faces in GL order (+X -X +Y -Y +Z -Z),
    row j at t = (j + 0.5) / N, as gloffset renders them; sampled nearest."""
    import moderngl

    n = faces.shape[1]
    data = np.ascontiguousarray(faces, dtype=np.uint8).tobytes()
    tex = ctx.texture_cube((n, n), 1, data, alignment=1)
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return tex


def draw_globe(region: np.ndarray, input_: np.ndarray, frame: np.ndarray, size: int, style: dict):
    """An RGBA image (size, size, 4), row 0 at the top, of the sphere seen from far away
    along ``frame[:, 2]`` (columns: east, north, centre) with the cube-map masks ``region``
    and ``input_`` (6, N, N) uint8 (255 inside). ``style``: the colours (RGBA 0-1) and
    ``grid_step`` (degrees) and ``shading`` (0-1) uniforms of ``shaders/globe.frag``."""
    import moderngl

    ctx = get_context()
    prog = program(ctx, "fullscreen.vert", "globe.frag")
    tex_r, tex_i = _cube_texture(ctx, region), _cube_texture(ctx, input_)
    target = ctx.texture((size, size), 4, dtype="f1")
    fbo = ctx.framebuffer(color_attachments=[target])
    # moderngl's framebuffer set-up makes a query that GL rejects while the engine's
    # integer class target is bound (GL_INVALID_OPERATION, no effect; see
    # textures.class_target): clear it so that real errors stay visible
    ctx.error  # noqa: B018
    vao = ctx.vertex_array(prog, [])
    try:
        tex_r.use(0)
        tex_i.use(1)
        set_uniform(prog, "u_region", 0)
        set_uniform(prog, "u_input", 1)
        set_uniform(prog, "u_frame", tuple(np.asarray(frame, np.float64).T.ravel().tolist()))
        set_uniform(prog, "u_size", (float(size), float(size)))
        for name, value in style.items():
            set_uniform(prog, f"u_{name}", value)
        fbo.use()
        ctx.viewport = (0, 0, size, size)
        vao.render(moderngl.TRIANGLES, vertices=3)
        ctx.finish()
        img = np.frombuffer(fbo.read(components=4, alignment=1), dtype=np.uint8)
    finally:
        for obj in (vao, fbo, target, tex_r, tex_i, prog):
            obj.release()
    return img.reshape(size, size, 4)[::-1].copy()
