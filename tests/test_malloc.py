"""The allocator's settings for pyramids (gloffset.raster.pyramid.malloc)."""

import ctypes
import platform

import pytest

from gloffset.raster.pyramid.malloc import keep_freed_memory


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
