"""OpenGL side of gloffset: one headless context per process, strict shader loading,
and the level-by-level raster engine."""

from .context import context_info, get_context
from .shaders import ShaderError, load_source, program

__all__ = ["ShaderError", "context_info", "get_context", "load_source", "program"]
