"""The C allocator's settings for long runs of large numpy temporaries (glibc only).

A tile pyramid classifies each zoom's cells with arrays of tens to hundreds of MB, made
and freed many times per zoom. By default glibc serves each allocation above its mmap
threshold (128 KiB, raised as large blocks are freed, to 32 MiB at most) with fresh
pages from the kernel and gives the memory freed at the heap's top back to it, so every
new temporary costs page faults and zeroing. :func:`keep_freed_memory` keeps that memory
for reuse instead: every block comes from the heap (no mmap at all, so the records of a
coarse zoom, hundreds of MB, reuse freed memory too), which is never trimmed and grows
in steps of 256 MiB. Measured on ``countries_10m`` at 127 km, zooms 0-7 in one process:
20.9 s (6.7 s of it in the kernel) before, 16.2-17.1 s (2.8-3.3 s) with blocks up to 32
MiB (glibc's largest mmap threshold) from the heap; z0-8 after reading the GeoJSON:
13.9-14.5 s (1.6-1.9 s in the kernel) with those, 13.3-14.1 s (1.5 s) with every block
from the heap, the same peak memory (1.6 GB). The process then keeps its peak heap until
it ends: :func:`gloffset.tiles.pyramid` and the workers of a Dask pyramid call it, a
library user's process otherwise keeps glibc's defaults.
"""

from __future__ import annotations

import ctypes
import functools

__all__ = ["give_back_freed_memory", "keep_freed_memory"]

# mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD = -1
_M_TOP_PAD = -2
_M_MMAP_THRESHOLD = -3
_M_MMAP_MAX = -4

SETTINGS = {
    _M_MMAP_THRESHOLD: 32 << 20,  # glibc's largest
    _M_TRIM_THRESHOLD: (1 << 31) - 1,  # never trim (mallopt takes an int)
    _M_TOP_PAD: 256 << 20,
    _M_MMAP_MAX: 0,  # no block from mmap: all from the heap
}


@functools.cache
def _libc(name: str, argtypes: tuple):
    """The C library's function ``name`` (returning an int), or None where it has none."""
    try:
        fn = getattr(ctypes.CDLL(None), name)
    except (AttributeError, OSError):
        return None
    fn.argtypes, fn.restype = argtypes, ctypes.c_int
    return fn


@functools.lru_cache(maxsize=1)
def keep_freed_memory() -> bool:
    """Set the settings above in this process, once; False where the C library has no
    ``mallopt`` (not glibc) or refuses one."""
    mallopt = _libc("mallopt", (ctypes.c_int, ctypes.c_int))
    return mallopt is not None and all(mallopt(k, v) == 1 for k, v in SETTINGS.items())


def give_back_freed_memory() -> bool:
    """Hand the C heap's free pages back to the system (glibc's ``malloc_trim(0)``, every
    arena); False where there is no ``malloc_trim``. A long-lived process whose work
    comes in bursts of different sizes (a tile server) otherwise keeps its largest burst's
    heap: its RSS steps up to the peak and stays there."""
    trim = _libc("malloc_trim", (ctypes.c_size_t,))
    if trim is None:
        return False
    trim(0)
    return True
