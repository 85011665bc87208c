"""compare/cli/allocator.py: one malloc arena where glibc is the C library, nothing elsewhere."""

from __future__ import annotations

import platform
import subprocess
import sys

import pytest

from compare.cli import allocator


def test_glibc_takes_one_arena_and_threads_then_share_it() -> None:
    if platform.libc_ver()[0] != "glibc":
        pytest.skip("the C library is not glibc")
    # In a fresh process: arenas made by this test process's own threads would stay. Two
    # threads that each malloc a block show one arena in malloc_info's XML (glibc's own count).
    code = """
import ctypes, threading
from compare.cli import allocator
assert allocator.use_one_arena()
libc = ctypes.CDLL(None)
libc.malloc.restype = ctypes.c_void_p
def grab():
    libc.malloc(1 << 10)  # small: from the thread's arena, not mmap
threads = [threading.Thread(target=grab) for _ in range(2)]
for t in threads: t.start()
for t in threads: t.join()
buf, size = ctypes.c_char_p(), ctypes.c_size_t()
libc.open_memstream.restype = ctypes.c_void_p
stream = libc.open_memstream(ctypes.byref(buf), ctypes.byref(size))
libc.malloc_info(0, ctypes.c_void_p(stream))
libc.fclose(ctypes.c_void_p(stream))
print(buf.value.decode().count("<heap nr="))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "1"


def test_another_c_library_is_left_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(allocator.platform, "libc_ver", lambda: ("musl", "1.2"))
    assert allocator.use_one_arena() is False
