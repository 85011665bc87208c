"""One malloc arena for the whole rtval process, where the C library is glibc.

The judge and the diagnosis make and drop arrays of an image's size (11 MB at 1200x800) by the
hundred, in several threads. glibc gives each thread an arena of its own, whose heaps it shrinks
as soon as their top is free, so the kernel zero-fills the same pages again at the next array:
a cold `rtval diagnose` at 1200x800 spent about 2.8 of its 24 CPU-seconds clearing pages
(`perf`, bench/NOTES.md). With one arena the freed blocks are reused; numpy's work holds no
lock of malloc's for long, so the threads do not wait on it.
"""

from __future__ import annotations

import ctypes
import platform

M_ARENA_MAX = -8  # mallopt's parameter number (glibc's malloc.h)


def use_one_arena() -> bool:
    """Asks glibc for a single arena; False where the C library is another or refuses.
    Called before the process starts its threads: arenas already made stay."""
    if platform.libc_ver()[0] != "glibc":
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return bool(mallopt(M_ARENA_MAX, 1))
