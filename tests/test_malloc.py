"""The allocator's settings for pyramids (gloffset.tiles.tiling.malloc)."""

import ctypes
import platform
import subprocess
import sys

import pytest

from gloffset.tiles.tiling.malloc import keep_freed_memory


def test_keep_freed_memory_sets_glibc_once():
    """On glibc every mallopt call is accepted (a refused one would be reported as
    False), and a second call does nothing."""
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        pytest.skip("mallopt is glibc's")
    assert keep_freed_memory() is True
    assert keep_freed_memory() is True
    assert keep_freed_memory.cache_info().misses == 1
    # the C library still allocates and frees large blocks
    buf = ctypes.create_string_buffer(64 << 20)
    assert len(buf) == 64 << 20


#: In a fresh interpreter: 200 MB of heap blocks (below the mmap threshold), touched, each
#: followed by a small block that stays, then freed; glibc's own trimming of the heap's top
#: cannot give them back, only malloc_trim's release of the free pages within the heap.
_HEAP_SCRIPT = """
import ctypes, sys
def rss():
    with open("/proc/self/status") as f:
        return next(int(l.split()[1]) for l in f if l.startswith("VmRSS:"))
libc = ctypes.CDLL(None)
libc.malloc.restype, libc.malloc.argtypes = ctypes.c_void_p, (ctypes.c_size_t,)
libc.free.argtypes = (ctypes.c_void_p,)
blocks, pins = [], []
for _ in range(2000):
    blocks.append(libc.malloc(100_000))
    ctypes.memset(blocks[-1], 1, 100_000)
    pins.append(libc.malloc(64))
held = rss()
for b in blocks:
    libc.free(b)
ok = True
if sys.argv[1] == "trim":  # imported after: with numpy imported first, glibc gave these back itself
    from gloffset.tiles.tiling.malloc import give_back_freed_memory
    ok = give_back_freed_memory()
print(ok, held, rss())
"""


def test_give_back_freed_memory_returns_the_free_pages():
    """After 200 MB of heap blocks are freed between blocks still in use, the RSS stays up
    (glibc keeps them) unless :func:`give_back_freed_memory` runs: then it falls back."""
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        pytest.skip("malloc_trim is glibc's")

    def run(mode):
        out = subprocess.run(
            [sys.executable, "-c", _HEAP_SCRIPT, mode], capture_output=True, text=True, check=True
        ).stdout.split()
        return out[0] == "True", int(out[1]), int(out[2])

    _, held, kept = run("keep")
    if kept < held - 100_000:
        pytest.skip("this C library gave the pages back by itself")
    ok, held, now = run("trim")
    assert ok and now < held - 100_000  # most of the 200 MB went back
