"""The loop's memory kept resident, as a real-time process sets itself up: the C allocator (glibc) serves every
block from its heap and keeps what is freed, and the heap is grown and touched before the loop starts, so that no
control step waits for the kernel to map fresh pages. (Without it a step that lands on newly grown heap takes
hundreds of page faults at once: in a virtual machine each is a fault on the host too, milliseconds in all.)
Elsewhere than glibc it does nothing."""

from __future__ import annotations

import ctypes
import ctypes.util
from functools import cache

RESERVE_MB = 64  # free heap touched before the loop (a run's loop grows the heap by some 20 MB a minute)
M_TRIM_THRESHOLD, M_MMAP_MAX = -1, -4  # glibc's mallopt parameters (malloc.h)


@cache
def _glibc() -> ctypes.CDLL | None:
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
    except OSError:
        return None
    if not hasattr(libc, "mallopt") or not hasattr(libc, "gnu_get_libc_version"):
        return None
    return libc


def reserve_heap(megabytes: int = RESERVE_MB) -> bool:
    """Freed memory never returned to the kernel, no block mapped on its own, and `megabytes` of heap grown and
    touched now; whether the allocator is glibc's (else nothing is done)."""
    libc = _glibc()
    if libc is None:
        return False
    libc.mallopt(M_TRIM_THRESHOLD, 2**30)
    libc.mallopt(M_MMAP_MAX, 0)
    libc.malloc.restype = ctypes.c_void_p
    size = megabytes * 2**20
    block = libc.malloc(size)
    if block:
        ctypes.memset(block, 0, size)  # touched: its pages are the process's from now on
        libc.free(ctypes.c_void_p(block))
    return True
