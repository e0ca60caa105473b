"""The allocator's settings for pyramids (gloffset.raster.pyramid.malloc)."""

import ctypes
import platform

import pytest

from gloffset.raster.pyramid.malloc import give_back_freed_memory, keep_freed_memory


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


def test_give_back_freed_memory_calls_malloc_trim():
    """On glibc ``malloc_trim(0)`` is found and called (True); the heap still serves
    allocations after it. What it gives back is measured by ``benchmarks/serve.py`` (a
    server's RSS following the memory in use)."""
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        pytest.skip("malloc_trim is glibc's")
    bufs = [ctypes.create_string_buffer(100_000) for _ in range(100)]
    del bufs
    assert give_back_freed_memory() is True
    assert len(ctypes.create_string_buffer(100_000)) == 100_000
