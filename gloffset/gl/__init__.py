"""OpenGL side of gloffset, GL only: one headless context per process (:mod:`.context`),
strict shader loading (:mod:`.shaders`), textures and render targets (:mod:`.textures`),
and the passes of the GPU levels (:mod:`.vector_pass` for shapes, :mod:`.rasterized_pass` for
rasterized curves) with their read-back. It imports nothing of the planner
(:mod:`gloffset.raster`): it is handed plans of plain arrays and draws them."""

from .context import context_info, get_context
from .shaders import ShaderError, load_source, program

__all__ = ["ShaderError", "context_info", "get_context", "load_source", "program"]
