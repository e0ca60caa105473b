"""GL objects shared by the engines' passes: data textures and class render targets of
power-of-two sides, and uniforms set only where a program variant uses them."""

from __future__ import annotations

import numpy as np

__all__ = ["class_target", "pot", "pot_texture", "set_uniform"]


def set_uniform(prog, name: str, value) -> None:
    """Set a uniform if the compiled variant uses it (unused ones are optimised away)."""
    if name in prog:
        prog[name].value = value


def pot(n: int) -> int:
    """Next power of two: every texture gets power-of-two sides, because llvmpipe
    compiles a new shader variant (about 0.15 s) for each combination of
    power-of-two and other sizes among the bound textures."""
    return 1 << max(0, int(n) - 1).bit_length()


def _pad(a: np.ndarray, shape: tuple) -> np.ndarray:
    """``a`` in the corner of zeros of ``shape`` (its leading axes)."""
    out = np.zeros(shape + a.shape[len(shape) :], dtype=a.dtype)
    out[tuple(slice(0, k) for k in a.shape[: len(shape)])] = a
    return out


def pot_texture(ctx, array: np.ndarray, comps: int, dtype: str):
    """A nearest-sampled texture from ``array`` (rows, cols[, comps]) padded to
    power-of-two sides (see :func:`pot`)."""
    import moderngl

    h, w = array.shape[:2]
    data = _pad(np.ascontiguousarray(array), (pot(h), pot(w)))
    t = ctx.texture((pot(w), pot(h)), comps, data.tobytes(), dtype=dtype, alignment=1)
    t.filter = (moderngl.NEAREST, moderngl.NEAREST)
    t.repeat_x = t.repeat_y = False
    return t


def class_target(ctx, w: int, h: int, depth: bool = False):
    """A ``w x h`` R8UI render target for classes (power-of-two sides, see :func:`pot`)
    with its framebuffer and, with ``depth``, a depth buffer (else None)."""
    import moderngl

    target = ctx.texture((pot(w), pot(h)), 1, dtype="u1")
    target.filter = (moderngl.NEAREST, moderngl.NEAREST)
    zbuf = ctx.depth_renderbuffer(target.size) if depth else None
    fbo = ctx.framebuffer(color_attachments=[target], depth_attachment=zbuf)
    # moderngl's framebuffer set-up makes one query that GL rejects for an integer
    # colour attachment (GL_INVALID_OPERATION, no effect): clear it so that real
    # errors stay visible
    ctx.error  # noqa: B018
    return target, fbo, zbuf
