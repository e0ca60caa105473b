"""One headless OpenGL 4.3 context per process (EGL), reused, and the objects made on it.

The device is chosen by the environment variable ``GLOFFSET_DEVICE`` (an EGL
device index); without it gloffset prefers the first hardware device and falls
back to Mesa's llvmpipe (CPU rendering). GL contexts do not survive ``fork``: use
the ``spawn`` start method for worker processes. Objects that hold programs compiled on
the context (the engines of :mod:`gloffset.gl.engine` and :mod:`gloffset.gl.raster_engine`)
are made once per process too (:func:`shared`); like the context, they work only on the
thread that made it.
"""

from __future__ import annotations

import os

from ..errors import GLContextError

__all__ = ["get_context", "context_info", "shared"]

_CTX = None
_DEVICE = None
_SHARED: dict = {}  # class -> its one instance (shared)
_SOFTWARE = ("llvmpipe", "softpipe", "swrast", "software")
_INSTALL = (
    "install an EGL driver: on Debian/Ubuntu 'apt-get install libegl1 libegl-mesa0 "
    "libgl1-mesa-dri' (Mesa, CPU rendering with llvmpipe), or the GPU vendor's driver"
)


def _create(index: int):
    import moderngl

    return moderngl.create_context(standalone=True, backend="egl", require=430, device_index=index)


def _is_software(ctx) -> bool:
    return any(s in ctx.info["GL_RENDERER"].lower() for s in _SOFTWARE)


def get_context():
    """The process's moderngl context (created on first use).

    Raises :class:`~gloffset.errors.GLContextError` naming the backend, the error and
    what to install when no context can be made.
    """
    global _CTX, _DEVICE
    if _CTX is not None:
        return _CTX
    try:
        import moderngl  # noqa: F401
    except ImportError as exc:  # pragma: no cover - moderngl is a core dependency
        raise GLContextError(f"moderngl is not installed ({exc}); pip install moderngl") from None
    env = os.environ.get("GLOFFSET_DEVICE")
    if env is not None and env.strip() != "":
        try:
            index = int(env)
        except ValueError:
            raise GLContextError(
                f"GLOFFSET_DEVICE must be an EGL device index (0, 1, ...), got {env!r}"
            ) from None
        try:
            _CTX, _DEVICE = _create(index), index
        except Exception as exc:
            raise GLContextError(
                f"cannot create an OpenGL 4.3 context with EGL on device {index} "
                f"(GLOFFSET_DEVICE): {exc}; {_INSTALL}"
            ) from None
        return _CTX
    first, first_exc = None, None
    for index in range(8):
        try:
            ctx = _create(index)
        except Exception as exc:
            if first_exc is None:
                first_exc = exc
            break
        if not _is_software(ctx):
            if first is not None:
                first[0].release()
            _CTX, _DEVICE = ctx, index
            return ctx
        if first is None:
            first = (ctx, index)
        else:
            ctx.release()
    if first is None:
        raise GLContextError(
            f"cannot create an OpenGL 4.3 context with EGL (backend 'egl', device 0): "
            f"{first_exc}; {_INSTALL}"
        )
    _CTX, _DEVICE = first
    return _CTX


def context_info() -> dict:
    """Renderer, vendor, version, device index and the limits gloffset relies on."""
    ctx = get_context()
    info = ctx.info
    return {
        "device": _DEVICE,
        "renderer": info["GL_RENDERER"],
        "vendor": info["GL_VENDOR"],
        "version": info["GL_VERSION"],
        "max_texture_size": int(info["GL_MAX_TEXTURE_SIZE"]),
        "max_viewport_dims": tuple(int(x) for x in info["GL_MAX_VIEWPORT_DIMS"]),
        "max_renderbuffer_size": int(info["GL_MAX_RENDERBUFFER_SIZE"]),
        "max_storage_block_size": int(info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"]),
        "software": _is_software(ctx),
    }


def shared(cls):
    """The process's one instance of ``cls``, made by ``cls()`` on first use (an engine
    that compiles its programs on the context once)."""
    obj = _SHARED.get(cls)
    if obj is None:
        obj = _SHARED[cls] = cls()
    return obj
