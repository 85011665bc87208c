"""The system calls no renderer needs, denied in the sandbox with a seccomp filter that
bwrap installs (`--seccomp FD`) just before it starts the supervisor.

The filter is built with libseccomp (Debian's libseccomp2, reached through ctypes: no
compiler, no binding needed), which also refuses every call made through another
architecture's ABI (32-bit calls on x86-64) and resolves names the running kernel's
architecture knows. A denied call fails with EPERM, as it would for an unprivileged user; the
program is not killed, so a library probing for io_uring falls back to plain reads.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import errno
import functools
import os

# io_uring (its own path around every other check), the kernel keyring, tracing and
# performance counters, eBPF, userfaultfd (a kernel exploit's favourite), mounting and new
# namespaces, modules, kexec, swap, clock, reboot, and handles that open files by inode.
DENIED = [
    "io_uring_setup",
    "io_uring_enter",
    "io_uring_register",
    "ptrace",
    "process_vm_readv",
    "process_vm_writev",
    "kcmp",
    "keyctl",
    "add_key",
    "request_key",
    "perf_event_open",
    "bpf",
    "userfaultfd",
    "mount",
    "umount2",
    "pivot_root",
    "chroot",
    "fsopen",
    "fsconfig",
    "fsmount",
    "fspick",
    "move_mount",
    "open_tree",
    "mount_setattr",
    "unshare",
    "setns",
    "kexec_load",
    "kexec_file_load",
    "init_module",
    "finit_module",
    "delete_module",
    "swapon",
    "swapoff",
    "reboot",
    "acct",
    "quotactl",
    "syslog",
    "vhangup",
    "settimeofday",
    "clock_settime",
    "clock_adjtime",
    "adjtimex",
    "name_to_handle_at",
    "open_by_handle_at",
    "lookup_dcookie",
    "iopl",
    "ioperm",
]
_ALLOW = 0x7FFF0000  # SCMP_ACT_ALLOW
_ERRNO = 0x00050000  # SCMP_ACT_ERRNO(0)


@functools.lru_cache(maxsize=1)
def _library() -> ctypes.CDLL | None:
    name = ctypes.util.find_library("seccomp") or "libseccomp.so.2"
    try:
        lib = ctypes.CDLL(name, use_errno=True)
    except OSError:
        return None
    lib.seccomp_init.restype = ctypes.c_void_p
    lib.seccomp_init.argtypes = [ctypes.c_uint32]
    lib.seccomp_rule_add.argtypes = [ctypes.c_void_p, ctypes.c_uint32, ctypes.c_int, ctypes.c_uint]
    lib.seccomp_syscall_resolve_name.argtypes = [ctypes.c_char_p]
    lib.seccomp_export_bpf.argtypes = [ctypes.c_void_p, ctypes.c_int]
    lib.seccomp_release.argtypes = [ctypes.c_void_p]
    return lib


def unavailable() -> str | None:
    """Why no filter can be built here; None when it can."""
    if _library() is None:
        return "libseccomp is not installed (Debian: apt-get install libseccomp2)"
    return None


@functools.lru_cache(maxsize=1)
def program() -> bytes:
    """The filter as the classic BPF program bwrap reads (built once per process)."""
    lib = _library()
    if lib is None:
        raise OSError(errno.ENOSYS, unavailable())
    ctx = lib.seccomp_init(_ALLOW)
    if not ctx:
        raise OSError(errno.ENOMEM, "seccomp_init failed")
    fd = os.memfd_create("rtval-seccomp-build", os.MFD_CLOEXEC)
    try:
        for name in DENIED:
            nr = lib.seccomp_syscall_resolve_name(name.encode())
            if nr >= 0 and lib.seccomp_rule_add(ctx, _ERRNO | errno.EPERM, nr, 0) != 0:
                raise OSError(errno.EINVAL, f"seccomp: cannot deny {name}")
        if lib.seccomp_export_bpf(ctx, fd) != 0:
            raise OSError(errno.EIO, "seccomp: cannot export the filter")
        os.lseek(fd, 0, os.SEEK_SET)
        return os.read(fd, 1 << 20)
    finally:
        os.close(fd)
        lib.seccomp_release(ctx)


def filter_fd() -> int:
    """A fresh descriptor holding the filter, at its start, for one bwrap (which reads it
    to the end); inheritable, the caller closes it."""
    fd = os.memfd_create("rtval-seccomp")
    os.write(fd, program())
    os.lseek(fd, 0, os.SEEK_SET)
    return fd
