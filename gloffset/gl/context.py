"""One headless OpenGL 4.3 context per thread that renders (EGL), reused, and the objects
made on it.

The device is chosen by the environment variable ``GLOFFSET_DEVICE`` (an EGL
device index); without it gloffset prefers the first hardware device and falls
back to Mesa's llvmpipe (CPU rendering). GL contexts do not survive ``fork``: use
the ``spawn`` start method for worker processes. Objects that hold programs compiled on
the context (the passes of :mod:`gloffset.gl.vector_pass` and
:mod:`gloffset.gl.rasterized_pass`) are made once per process too (:func:`shared`); like
the context, they work only on the thread that made it.
"""

from __future__ import annotations

import os
import threading

from ..errors import GLContextError

__all__ = ["get_context", "context_info", "made", "shared"]

_LOCAL = threading.local()  # per thread: ctx, device, shared (class -> its one instance)
_SOFTWARE = ("llvmpipe", "softpipe", "swrast", "software")
_INSTALL = (
    "install an EGL driver: on Debian/Ubuntu 'apt-get install libegl1 libegl-mesa0 "
    "libgl1-mesa-dri' (Mesa, CPU rendering with llvmpipe), or the GPU vendor's driver"
)


def _create(index: int):
    import moderngl

    # moderngl's stub types the keyword settings as dicts (``**settings: Dict[str, Any]``)
    return moderngl.create_context(
        standalone=True,
        backend="egl",  # type: ignore[arg-type]
        require=430,
        device_index=index,  # type: ignore[arg-type]
    )


def _is_software(ctx) -> bool:
    return any(s in ctx.info["GL_RENDERER"].lower() for s in _SOFTWARE)


def get_context():
    """The process's moderngl context (created on first use).

    Raises :class:`~gloffset.errors.GLContextError` naming the backend, the error and
    what to install when no context can be made.
    """
    ctx = getattr(_LOCAL, "ctx", None)
    if ctx is not None:
        return ctx
    ctx, _LOCAL.device = _make()
    _LOCAL.ctx = ctx
    return ctx


def _make():
    """A new context and its device index (see :func:`get_context`)."""
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
            return _create(index), index
        except Exception as exc:
            raise GLContextError(
                f"cannot create an OpenGL 4.3 context with EGL on device {index} "
                f"(GLOFFSET_DEVICE): {exc}; {_INSTALL}"
            ) from None
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
            return ctx, index
        if first is None:
            first = (ctx, index)
        else:
            ctx.release()
    if first is None:
        raise GLContextError(
            f"cannot create an OpenGL 4.3 context with EGL (backend 'egl', device 0): "
            f"{first_exc}; {_INSTALL}"
        )
    return first


def context_info() -> dict:
    """Renderer, vendor, version, device index and the limits gloffset relies on."""
    ctx = get_context()
    info = ctx.info
    return {
        "device": _LOCAL.device,
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
    """This thread's one instance of ``cls``, made by ``cls()`` on first use (an engine
    that compiles its programs on the thread's context once)."""
    objs = getattr(_LOCAL, "shared", None)
    if objs is None:
        objs = _LOCAL.shared = {}
    obj = objs.get(cls)
    if obj is None:
        obj = objs[cls] = cls()
    return obj


def made(cls) -> bool:
    """Whether this thread has made its :func:`shared` instance of ``cls`` (its programs
    compiled: a further run costs no compilation)."""
    return getattr(_LOCAL, "shared", {}).get(cls) is not None
