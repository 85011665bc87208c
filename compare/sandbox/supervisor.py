"""The sandbox's supervisor: the first process of rtval's inside a sandbox (docs/sandbox.md).

It runs with the system's Python (`python3 -I -S -c SOURCE CONFIG`, so it imports nothing
but the standard library, and only its cheapest modules: a run starts in a few ms; CONFIG
is rtval's settings, marshalled) and:

1. copies the program's files from the read-only /sandbox/src into its writable, size-bound
   work folder, and makes again the links a build made;
2. starts the program with the limits set (setrlimit in the child, inherited by everything it
   starts), as a child subreaper, so every orphan of the sandbox comes back to it;
3. watches every process of the sandbox every SAMPLE seconds: the CPU time of all of them
   together (what a run is judged by), their resident memory together, and the time they
   waited for a CPU (the evidence that the machine, not the program, was slow); it ends
   the sandbox when the CPU time or the wall time is used up, so that even an orphaned
   sandbox ends by itself;
4. when the program ends, kills what is left, reaps everything and writes one JSON line to
   the report descriptor: the program's own wait status (a signal is a signal, never an exit
   code of 128 + N), CPU seconds and peak memory of all processes, why it was stopped;
5. waits (a bounded time) on the control descriptor while rtval reads the output back, then
   ends, and the sandbox with it.
"""

from __future__ import annotations

import _signal  # signal without the enum module: a few ms less per run
import ctypes
import marshal
import os
import resource
import select
import sys
import time

TYPE_CHECKING = False  # typing (and re with it) is not imported at run time
if TYPE_CHECKING:
    from typing import Any

SAMPLE = 0.05  # seconds between two looks at the sandbox's processes
SIGKILL, SIGPIPE, SIGXFSZ = 9, 13, 25
_PR_SET_PDEATHSIG = 1
_PR_SET_DUMPABLE = 4
_PR_SET_CHILD_SUBREAPER = 36
_TICK = os.sysconf("SC_CLK_TCK")
_PAGE = os.sysconf("SC_PAGE_SIZE")


def copy_in(src: str, dest: str, links: list[list[str]]) -> None:
    """src's files into dest (folders first, as os.walk gives them), then the links."""
    if not src:
        return
    for folder, dirs, files in os.walk(src):
        rel = os.path.relpath(folder, src)
        here = dest if rel == "." else os.path.join(dest, rel)
        for d in dirs:
            os.mkdir(os.path.join(here, d), 0o755)
        for f in files:
            source = os.path.join(folder, f)
            mode = 0o755 if os.stat(source).st_mode & 0o111 else 0o644
            with open(source, "rb") as i, open(os.path.join(here, f), "xb") as o:
                while chunk := i.read(1 << 20):
                    o.write(chunk)
            os.chmod(os.path.join(here, f), mode)
    for rel, target in links:
        try:  # noqa: SIM105 - contextlib would cost this process's start a few ms
            os.symlink(target, os.path.join(dest, rel))
        except OSError:
            pass


def start(cfg: dict[str, Any]) -> int:
    """Forks the program under its limits; its pid."""
    pid = os.fork()
    if pid:
        return pid
    try:
        for sig in (SIGPIPE, SIGXFSZ):  # Python ignores them; exec would keep that
            _signal.signal(sig, _signal.SIG_DFL)
        if not cfg["sandboxed"]:
            os.setsid()  # its own group: what is left of it can be killed as one
            ctypes.CDLL(None).prctl(_PR_SET_PDEATHSIG, SIGKILL, 0, 0, 0)
        for name, soft, hard in cfg["rlimits"]:
            resource.setrlimit(getattr(resource, name), (soft, hard))
        os.chdir(cfg["cwd"])
        os.execvp(cfg["argv"][0], cfg["argv"])
    except OSError as e:
        os.write(2, f"cannot run {cfg['argv'][0]}: {e.strerror}\n".encode())
    os._exit(127)


def sample(pids: list[int]) -> tuple[float, int, float]:
    """(CPU seconds, resident bytes, seconds waited for a CPU) of these processes together;
    the CPU time includes their children that they have reaped."""
    cpu, rss, delay = 0, 0, 0
    for pid in pids:
        try:
            with open(f"/proc/{pid}/stat", "rb") as f:
                fields = f.read().rsplit(b")", 1)[1].split()
            cpu += sum(int(v) for v in fields[11:15])  # utime stime cutime cstime
            rss += int(fields[21]) * _PAGE
            with open(f"/proc/{pid}/schedstat", "rb") as f:
                delay += int(f.read().split()[1])
        except (OSError, IndexError, ValueError):
            continue  # gone meanwhile, or no schedstat here
    return cpu / _TICK, rss, delay / 1e9


def others(sandboxed: bool, main: int) -> list[int]:
    """The processes to watch: every one of the sandbox's but this one and its init (the
    sandbox's /proc shows only them); unsandboxed, only the program's main process."""
    if not sandboxed:
        return [main]
    me = os.getpid()
    return [int(p) for p in os.listdir("/proc") if p.isdigit() and int(p) not in (1, me)]


def watch(cfg: dict[str, Any], pid: int, started: float) -> dict[str, Any]:
    """Waits for the program, stopping it at its CPU or wall limit; what happened."""
    pidfd = os.pidfd_open(pid)
    seen: dict[str, Any] = {"status": None, "stopped": "", "peak": 0, "delay": 0.0, "max_rss": 0}
    while seen["status"] is None:
        cpu, rss, delay = sample(others(cfg["sandboxed"], pid))
        done = resource.getrusage(resource.RUSAGE_CHILDREN)
        seen["peak"] = max(seen["peak"], rss)
        seen["delay"] = max(seen["delay"], delay)
        if cpu + done.ru_utime + done.ru_stime > cfg["time"]:
            seen["stopped"] = "cpu"
        elif time.monotonic() - started > cfg["wall"]:
            seen["stopped"] = "wall"
        elif cfg["disk_root"] and too_many_files(cfg["disk_root"], cfg["inodes"]):
            seen["stopped"] = "inodes"
        if seen["stopped"]:
            break
        select.select([pidfd], [], [], SAMPLE)
        reap(pid, seen, block=False)
    os.close(pidfd)
    # Once more at the end: a program quicker than one sample still finds the bound.
    if not seen["stopped"] and cfg["disk_root"] and too_many_files(cfg["disk_root"], cfg["inodes"]):
        seen["stopped"] = "inodes"
    return seen


def reap(main: int, seen: dict[str, Any], block: bool) -> None:
    """Collects ended children (every one, with block); the main one's status is kept."""
    while True:
        try:
            pid, status, ru = os.wait4(-1, 0 if block else os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return
        seen["max_rss"] = max(seen["max_rss"], ru.ru_maxrss * 1024)
        if pid == main:
            seen["status"] = status
            seen["main_cpu"] = ru.ru_utime + ru.ru_stime


def end_all(sandboxed: bool, main: int) -> None:
    """Kills what is left: in the sandbox every process of its namespace but this one;
    unsandboxed, the program's process group (a daemon that left it is out of reach)."""
    try:
        if sandboxed:
            os.kill(-1, SIGKILL)
        else:
            os.killpg(main, SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def too_many_files(path: str, most: int) -> bool:
    try:
        st = os.statvfs(path)
    except OSError:
        return False
    return st.f_files - st.f_ffree > most


def disk_full(path: str) -> bool:
    """Whether the size-bound folder of the sandbox is (nearly) full: the kernel's word."""
    try:
        st = os.statvfs(path)
    except OSError:
        return False
    return st.f_bavail * st.f_frsize < (1 << 20) or (st.f_files > 0 and st.f_ffree < 16)


def as_json(seen: dict[str, Any]) -> str:
    """The report as one line of JSON (numbers, booleans, null and plain words only)."""

    def value(v: object) -> str:
        if v is None:
            return "null"
        if isinstance(v, bool):
            return "true" if v else "false"
        return f'"{v}"' if isinstance(v, str) else repr(v)

    return "{" + ", ".join(f'"{k}": {value(v)}' for k, v in seen.items()) + "}\n"


def main() -> None:
    cfg = marshal.loads(bytes.fromhex(sys.argv[1]))
    for fd in (cfg["report"], cfg["control"]):  # the program must not forge a report
        os.set_inheritable(fd, False)
    libc = ctypes.CDLL(None, use_errno=True)
    # Not dumpable: the program, the same user, may not open its descriptors or its memory
    # through /proc (and so may not write a report of its own).
    libc.prctl(_PR_SET_DUMPABLE, 0, 0, 0, 0)
    libc.prctl(_PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)
    if not cfg["sandboxed"]:  # in a sandbox, bwrap's --die-with-parent does this
        libc.prctl(_PR_SET_PDEATHSIG, SIGKILL, 0, 0, 0)
    try:
        copy_in(cfg["src"], cfg["cwd"], cfg["links"])
    except OSError as e:
        os.write(2, f"cannot copy the program into its folder: {e.strerror}\n".encode())
    started = time.monotonic()
    pid = start(cfg)
    seen = watch(cfg, pid, started)
    end_all(cfg["sandboxed"], pid)
    reap(pid, seen, block=True)
    done = resource.getrusage(resource.RUSAGE_CHILDREN)
    seen["cpu"] = done.ru_utime + done.ru_stime
    seen["seconds"] = time.monotonic() - started
    seen["disk_full"] = bool(cfg["disk_root"]) and disk_full(cfg["disk_root"])
    os.write(cfg["report"], as_json(seen).encode())
    os.close(cfg["report"])
    select.select([cfg["control"]], [], [], cfg["grace"])  # rtval reads the output meanwhile


if __name__ == "__main__":
    try:
        main()
    except Exception as e:  # rtval's own failure, never the program's: it says so
        os.write(2, f"rtval's sandbox supervisor failed: {e}\n".encode())
        raise SystemExit(70) from None
