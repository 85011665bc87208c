"""Running untrusted programs (a student's build and renders) in a bubblewrap sandbox.

    ws = Workspace()                      # a fresh folder tree the sandbox may use
    copy the program into ws.work, the scene into ws.inputs
    outcome = run_sandboxed(["./rt", "/sandbox/in/scene.json"], ws, Limits(wall=60))
    outcome.reason                        # "" on success, else "timed out after 60 s", ...
    ws.close()

Inside the sandbox (docs/sandbox.md) the program sees the system read-only (/usr, /etc and
the /bin, /lib links), its own copy at /sandbox/work (writable, the current folder), its inputs
at /sandbox/in (read-only), /sandbox/out (writable, for {out}), a private /tmp of bounded
size, a fresh /proc and a minimal /dev. Nothing else of the machine exists there: no home, no
render cache, no other student. It has no network (a new network namespace), runs as uid
65534 (when rtval runs as root, bwrap itself is started as that user, so not even the
namespace's owner is root), in a new PID namespace (when its main process ends, or the wall
time runs out, every process it started dies with the namespace) and a new session.

Limits are per build or per run: wall time (the whole sandbox is killed), and, set with
prlimit inside the sandbox so that every process inherits them, CPU seconds, address space,
file size, processes (counted in the sandbox's own user namespace: other sandboxes and the
machine's processes do not count) and open files. The captured stdout and stderr keep a
bounded head and tail.
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import selectors
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

from compare.errors import ToolError
from compare.sandbox.trees import remove_tree
from compare.sizes import human_size

WORK_DIR = "/sandbox/work"  # the program's copy, its current folder
IN_DIR = "/sandbox/in"  # its inputs, read-only
OUT_DIR = "/sandbox/out"  # where {out} points
SANDBOX_UID = 65534  # nobody
SYSTEM_DIRS = ("/usr", "/etc")  # bound read-only; /bin, /lib... follow as links or binds
SYSTEM_LINKS = ("/bin", "/sbin", "/lib", "/lib32", "/lib64", "/libx32")
PATH = "/usr/local/bin:/usr/bin:/bin:/usr/local/sbin:/usr/sbin:/sbin"
_ALLOC_FAILED = re.compile(
    r"bad_alloc|cannot allocate memory|out of memory|memoryerror|failed to allocate|"
    r"memory allocation failed|memory exhausted",
    re.IGNORECASE,
)


class SandboxUnavailable(ToolError):
    """No sandbox can be made here (bwrap missing or failing its probe)."""


@dataclass(frozen=True)
class Limits:
    """What one build or one run may use. Defaults: docs/sandbox.md."""

    wall: float = 60.0  # seconds for the whole sandbox
    cpu: float = 600.0  # CPU seconds per process (RLIMIT_CPU): threads add up
    memory: int = 2 << 30  # address space per process (RLIMIT_AS)
    file_size: int = 256 << 20  # largest file a process may write (RLIMIT_FSIZE)
    processes: int = 128  # processes and threads in the sandbox (RLIMIT_NPROC)
    open_files: int = 256  # per process (RLIMIT_NOFILE)
    log: int = 64 << 10  # bytes of stdout+stderr kept: half from the start, half from the end
    tmp: int = 64 << 20  # size of the private /tmp (memory-backed)

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not (value > 0 and value < 2**62):  # also refuses NaN
                raise ValueError(f"limit {name} must be positive, got {value!r}")

    def prlimit_args(self) -> list[str]:
        cpu = max(1, int(self.cpu + 0.999))
        # Soft CPU limit first: SIGXCPU says which limit it was; the hard one a second later
        # stops a program that ignores it. No core files: they would fill the folder.
        return [
            f"--cpu={cpu}:{cpu + 1}",
            f"--as={self.memory}",
            f"--fsize={self.file_size}",
            f"--nproc={self.processes}",
            f"--nofile={self.open_files}",
            "--core=0",
        ]


@dataclass
class Outcome:
    """How one sandboxed command ended, in words for a gradebook row."""

    status: str  # ok, exit, crashed, timeout, cpu, memory, file_size, sandbox
    limits: Limits
    exit_code: int | None = None
    signal: str | None = None  # SIGSEGV, ...
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    peak_memory: int = 0  # bytes: the largest resident set of any one process
    log: str = ""  # head and tail of stdout+stderr
    log_bytes: int = 0  # all it printed
    sandboxed: bool = True
    command: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def reason(self) -> str:
        lim = self.limits
        return {
            "ok": "",
            "exit": f"exit {self.exit_code}",
            "crashed": f"crashed: {self.signal}",
            "timeout": f"timed out after {lim.wall:g} s",
            "cpu": f"killed: CPU time limit {lim.cpu:g} s",
            "memory": f"killed: memory limit {human_size(lim.memory)}",
            "file_size": f"killed: file size limit {human_size(lim.file_size)}",
            "sandbox": "the sandbox could not start: " + last_line(self.log),
        }[self.status]

    def as_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["limits"] = asdict(self.limits)
        d["reason"] = self.reason
        return d


def last_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1][:300] if lines else "(no message)"


# -- the folders a sandbox sees ------------------------------------------------------------


def sandbox_owner() -> tuple[int, int] | None:
    """(uid, gid) that bwrap runs as when rtval is root; None: as the calling user (whose
    processes are then mapped to 65534 inside)."""
    return (SANDBOX_UID, SANDBOX_UID) if os.geteuid() == 0 else None


class Workspace:
    """A fresh folder tree for one sandboxed command: work/ (the program's copy, writable by
    the sandbox), inputs/ (read-only inside) and out/ (writable). It lives in the system's
    temporary folder, whose ancestors the unprivileged sandbox user can traverse (rtval's
    --out folder may lie below a private one); close() removes it."""

    def __init__(self, base: str | None = None) -> None:
        self.root = Path(tempfile.mkdtemp(prefix="rtval-sandbox-", dir=base))
        os.chmod(self.root, 0o711)  # traversable, not listable
        self.work = self.root / "work"
        self.inputs = self.root / "inputs"
        self.out = self.root / "out"
        for d in (self.work, self.inputs, self.out):
            d.mkdir(mode=0o755)
        owner = sandbox_owner()
        if owner:
            for d in (self.work, self.out):
                os.chown(d, *owner)

    def hand_over(self) -> None:
        """Gives everything in work/ to the sandbox user (a copy made as root is root's)."""
        owner = sandbox_owner()
        if owner is None:
            return
        os.chown(self.work, *owner)
        for dirpath, dirnames, filenames in os.walk(self.work):
            for name in dirnames + filenames:
                os.lchown(os.path.join(dirpath, name), *owner)

    def seen(self, sandboxed: bool) -> tuple[str, str, str]:
        """(work, inputs, out) as the program sees them."""
        if sandboxed:
            return WORK_DIR, IN_DIR, OUT_DIR
        return str(self.work), str(self.inputs), str(self.out)

    def close(self) -> None:
        """Removes the whole tree, however deep or odd what the program left there."""
        remove_tree(self.root)

    def __enter__(self) -> Workspace:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# -- bubblewrap ------------------------------------------------------------------------------


def bwrap_path() -> str:
    """$RTVAL_BWRAP (another build, or a missing path in tests), else bwrap on PATH."""
    return os.environ.get("RTVAL_BWRAP") or shutil.which("bwrap") or "/usr/bin/bwrap"


def _system_mounts() -> list[str]:
    args: list[str] = []
    for d in SYSTEM_DIRS:
        args += ["--ro-bind", d, d]
    for d in SYSTEM_LINKS:  # merged /usr: links; older systems: folders
        if os.path.islink(d):
            args += ["--symlink", os.readlink(d), d]
        elif os.path.isdir(d):
            args += ["--ro-bind", d, d]
    return args


def _hidden(hide: Sequence[str | Path]) -> list[str]:
    """Covers those of the teacher's paths that lie inside a bound system folder (rtval
    installed under /usr, a cache in /etc...): a folder by an empty tmpfs, a file by
    /dev/null. The rest never exist in the sandbox at all."""
    args: list[str] = []
    for p in hide:
        try:
            real = os.path.realpath(p)
            st = os.stat(real)
        except OSError:
            continue
        if not any(real == d or real.startswith(d + "/") for d in SYSTEM_DIRS):
            continue
        args += ["--tmpfs", real] if stat.S_ISDIR(st.st_mode) else ["--ro-bind", "/dev/null", real]
    return args


def bwrap_argv(
    ws: Workspace, limits: Limits, status_fd: int, hide: Sequence[str | Path] = ()
) -> list[str]:
    """The bwrap command line up to (and including) prlimit's '--'."""
    env = {"PATH": PATH, "HOME": "/tmp", "TMPDIR": "/tmp", "LANG": "C.UTF-8", "TERM": "dumb"}
    args = [
        bwrap_path(),
        "--unshare-all",
        "--unshare-user",
        "--disable-userns",
        "--uid",
        str(SANDBOX_UID),
        "--gid",
        str(SANDBOX_UID),
        "--hostname",
        "sandbox",
        "--die-with-parent",
        "--new-session",
        *_system_mounts(),
        "--proc",
        "/proc",
        "--dev",
        "/dev",
        "--size",
        str(limits.tmp),
        "--tmpfs",
        "/tmp",
        *_hidden(hide),
        "--ro-bind",
        str(ws.inputs),
        IN_DIR,
        "--bind",
        str(ws.work),
        WORK_DIR,
        "--bind",
        str(ws.out),
        OUT_DIR,
        "--chdir",
        WORK_DIR,
        "--remount-ro",
        "/",
        "--json-status-fd",
        str(status_fd),
        "--clearenv",
    ]
    for k, v in env.items():
        args += ["--setenv", k, v]
    return [*args, "--", "/usr/bin/prlimit", *limits.prlimit_args(), "--"]


@functools.lru_cache(maxsize=1)
def probe() -> str | None:
    """None when a sandbox works here, else why not (checked once per process)."""
    bwrap = bwrap_path()
    if not (os.path.isfile(bwrap) and os.access(bwrap, os.X_OK)):
        return f"bubblewrap is not installed ({bwrap} missing; Debian: apt-get install bubblewrap)"
    if not os.path.isfile("/usr/bin/prlimit"):
        return "/usr/bin/prlimit (util-linux) is missing"
    if not hasattr(os, "pidfd_open"):
        return "this Python or kernel has no pidfd_open (Linux 5.3+ needed)"
    try:
        with Workspace() as ws:
            out = run_sandboxed(["true"], ws, Limits(wall=30))
    except OSError as e:
        return f"cannot start {bwrap}: {e}"
    return None if out.ok else f"{bwrap} fails here: {last_line(out.log)}"


def require_sandbox() -> None:
    why = probe()
    if why:
        raise SandboxUnavailable(
            f"no sandbox for the students' programs: {why}. Install bubblewrap "
            "(scripts/setup.sh), or pass --unsandboxed to run them with limits only, "
            "unisolated (only for code you trust)"
        )


# -- running and watching --------------------------------------------------------------------


class _Log:
    """stdout+stderr as they come, keeping a bounded head and tail."""

    def __init__(self, keep: int) -> None:
        self.half = max(1, keep // 2)
        self.head = bytearray()
        self.tail = bytearray()
        self.total = 0

    def add(self, chunk: bytes) -> None:
        self.total += len(chunk)
        room = self.half - len(self.head)
        if room > 0:
            self.head += chunk[:room]
            chunk = chunk[room:]
        self.tail += chunk
        if len(self.tail) > 2 * self.half:  # trim now and then, not per chunk
            del self.tail[: len(self.tail) - self.half]

    def text(self) -> str:
        tail = bytes(self.tail[-self.half :])
        dropped = self.total - len(self.head) - len(tail)
        gap = f"\n[... {dropped} bytes not kept ...]\n" if dropped > 0 else ""
        raw = bytes(self.head).decode("utf-8", "replace") + gap + tail.decode("utf-8", "replace")
        return raw.replace("\x00", "")


@dataclass
class _Watch:
    log: _Log
    status: bytearray = field(default_factory=bytearray)  # bwrap's JSON
    report: bytearray = field(default_factory=bytearray)  # the launcher's line
    timed_out: bool = False

    def usage(self) -> tuple[int, int, float] | None:
        """bwrap's wait status, the peak resident KiB and the CPU seconds, when the launcher
        said."""
        try:
            status, rss, cpu = self.report.split()
            return int(status), int(rss), float(cpu)
        except ValueError:
            return None

    def child_pid(self) -> int | None:
        m = re.search(rb'"child-pid"\s*:\s*([0-9]+)', self.status)
        return int(m.group(1)) if m else None


# The launcher between rtval and bwrap: it forks bwrap, reaps it and reports how it ended.
# It is a child subreaper: bwrap returns as soon as its init says the program ended, and the
# init (PID 1 of the sandbox, which takes every process of the namespace down with it) then
# comes back to the launcher, which waits for it too. So (1) when the launcher ends, nothing
# of the sandbox is left, and (2) the CPU time and peak memory of the program's processes
# reach the report (bwrap's own rusage lacks them). The peak is that of the largest process;
# a few MiB at least, since bwrap starts with the small launcher's resident set (rtval does not
# fork bwrap itself: a forked process starts with its parent's, hundreds of MiB in a grading
# worker). The sandbox user is taken in the child only.
_LAUNCHER = """
import os, signal, sys
report, uid, gid, reap = (int(v) for v in sys.argv[1:5])
argv = sys.argv[5:]
os.set_inheritable(report, False)
if reap:
    import ctypes
    ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0)  # PR_SET_CHILD_SUBREAPER
pid = os.fork()
if pid == 0:
    for sig in (signal.SIGPIPE, signal.SIGXFSZ):  # Python ignores them; exec would keep that
        signal.signal(sig, signal.SIG_DFL)
    try:
        if uid >= 0:
            os.setgroups([])
            os.setgid(gid)
            os.setuid(uid)
        os.execv(argv[0], argv)
    except OSError as e:
        os.write(2, f"cannot start {argv[0]}: {e.strerror}\\n".encode())
    os._exit(127)
_, status, ru = os.wait4(pid, 0)
rss, cpu = ru.ru_maxrss, ru.ru_utime + ru.ru_stime
while reap:  # the sandbox's init, once bwrap let it go: gone only when all of it is
    try:
        _, _, ru = os.wait4(-1, 0)
    except ChildProcessError:
        break
    rss, cpu = max(rss, ru.ru_maxrss), cpu + ru.ru_utime + ru.ru_stime
os.write(report, f"{status} {rss} {cpu}\\n".encode())
"""


def _launcher(report_fd: int, uid: int, gid: int, reap: bool) -> list[str]:
    args = (report_fd, uid, gid, int(reap))
    return [sys.executable, "-I", "-S", "-c", _LAUNCHER, *(str(a) for a in args)]


def run_sandboxed(
    argv: Sequence[str],
    ws: Workspace,
    limits: Limits,
    *,
    sandboxed: bool = True,
    hide: Sequence[str | Path] = (),
) -> Outcome:
    """Runs argv in the workspace under the limits and says how it ended. Never raises for
    anything the program does; OSError only when the launcher itself cannot be started."""
    pipes = [os.pipe() for _ in range(3)]  # log, bwrap's JSON status, the launcher's report
    (log_r, log_w), (status_r, status_w), (report_r, report_w) = pipes
    if sandboxed:
        full = [*bwrap_argv(ws, limits, status_w, hide), *argv]
    else:  # limits only: the program sees the machine (--unsandboxed)
        full = ["/usr/bin/prlimit", *limits.prlimit_args(), "--", *argv]
    uid, gid = sandbox_owner() or (-1, -1)  # as root: never run it as root, even unsandboxed
    start = time.monotonic()
    try:
        proc = subprocess.Popen(
            [*_launcher(report_w, uid, gid, sandboxed), *full],
            stdin=subprocess.DEVNULL,
            stdout=log_w,
            stderr=log_w,
            pass_fds=(status_w, report_w),
            cwd=None if sandboxed else str(ws.work),
            env={"PATH": PATH, "HOME": str(ws.work), "LANG": "C.UTF-8"},
            start_new_session=True,  # its own process group: the unsandboxed kill takes all
        )
    except BaseException:
        for fd in (fd for pair in pipes for fd in pair):
            os.close(fd)
        raise
    for fd in (log_w, status_w, report_w):
        os.close(fd)
    watch = _Watch(_Log(limits.log))
    try:
        _supervise(
            proc,
            {log_r: "log", status_r: "status", report_r: "report"},
            limits.wall,
            watch,
            sandboxed,
        )
    finally:
        for fd in (log_r, status_r, report_r):
            os.close(fd)
    return _outcome(proc, time.monotonic() - start, watch, limits, sandboxed, [*argv])


def _supervise(
    proc: subprocess.Popen[bytes],
    pipes: dict[int, str],
    wall: float,
    watch: _Watch,
    sandboxed: bool,
) -> None:
    """Reads the pipes until the launcher ends or the wall time is up (then kills the
    sandbox), and reaps it. Waits on events (the launcher's pidfd, the pipes), never by
    sleeping and polling."""
    pidfd = os.pidfd_open(proc.pid)
    sel = selectors.DefaultSelector()
    for fd, what in pipes.items():
        os.set_blocking(fd, False)
        sel.register(fd, selectors.EVENT_READ, what)
    sel.register(pidfd, selectors.EVENT_READ, "exit")
    deadline = time.monotonic() + wall
    try:
        exited = False
        while not exited:
            left = deadline - time.monotonic()
            if left <= 0:
                watch.timed_out = True
                _kill(proc, watch, sandboxed)
                break
            for key, _ in sel.select(left):
                if key.data == "exit":
                    exited = True
                elif not _read_some(key.fd, watch, key.data):
                    sel.unregister(key.fd)
        proc.wait()  # it has exited, or was just killed: this returns at once
        if not sandboxed:  # what it left behind in its process group goes too
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(proc.pid, signal.SIGKILL)
        _drain(sel, watch)
    except BaseException:  # interrupted: leave nothing running, then let it propagate
        if proc.returncode is None:
            _kill(proc, watch, sandboxed)
            proc.wait()
        raise
    finally:
        sel.close()
        os.close(pidfd)


def _read_some(fd: int, watch: _Watch, what: str) -> bool:
    """Reads what is there; False at end of file."""
    while True:
        try:
            chunk = os.read(fd, 1 << 16)
        except BlockingIOError:
            return True
        if not chunk:
            return False
        if what == "log":
            watch.log.add(chunk)
        elif what == "status" and len(watch.status) < 1 << 16:
            watch.status += chunk
        elif what == "report" and len(watch.report) < 1 << 10:
            watch.report += chunk


def _drain(sel: selectors.BaseSelector, watch: _Watch) -> None:
    """The rest of the pipes after the end. In the sandbox every writer is dead by now (the
    namespace died before bwrap returned); unsandboxed, a daemon that left its group may
    hold the pipe, so this waits at most a few seconds for the end of file."""
    deadline = time.monotonic() + 5
    while any(k.data != "exit" for k in sel.get_map().values()):
        left = deadline - time.monotonic()
        if left <= 0:
            return
        for key, _ in sel.select(left):
            if key.data != "exit" and not _read_some(key.fd, watch, key.data):
                sel.unregister(key.fd)


def _kill(proc: subprocess.Popen[bytes], watch: _Watch, sandboxed: bool) -> None:
    """Ends the whole sandbox: SIGKILL to its PID 1 (the namespace's init), which takes every
    process in the namespace with it before bwrap, waiting for it, returns. Before bwrap has
    said who PID 1 is, bwrap itself is killed (its child dies with it: --die-with-parent)."""
    child = watch.child_pid() if sandboxed else None
    # Not a reused PID: the init's parent is bwrap, or the launcher once bwrap has returned.
    if child is not None and proc.pid in (_parent(child), _parent(_parent(child))):
        try:
            fd = os.pidfd_open(child)
        except OSError:
            fd = -1  # already gone: bwrap is returning by itself
        if fd >= 0:
            try:
                signal.pidfd_send_signal(fd, signal.SIGKILL)
                return
            except OSError:
                pass
            finally:
                os.close(fd)
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)


def _parent(pid: int) -> int:
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return -1
    return int(text.rsplit(")", 1)[1].split()[1])


def _outcome(
    proc: subprocess.Popen[bytes],
    seconds: float,
    watch: _Watch,
    limits: Limits,
    sandboxed: bool,
    command: list[str],
) -> Outcome:
    usage = watch.usage()
    status, rss, cpu = usage or (0, 0, 0.0)
    log = watch.log.text()
    out = Outcome(
        "ok",
        limits,
        seconds=seconds,
        cpu_seconds=cpu,
        peak_memory=rss * 1024,  # Linux: KiB
        log=log,
        log_bytes=watch.log.total,
        sandboxed=sandboxed,
        command=command,
    )
    if watch.timed_out:
        out.status = "timeout"
        return out
    if usage is None or (sandboxed and watch.child_pid() is None):
        out.status = "sandbox"  # the launcher or bwrap failed before starting the program
        return out
    code = os.waitstatus_to_exitcode(status)
    # bwrap (and a shell) report a death by signal N as 128 + N; unsandboxed it is -N
    signum = -code if code < 0 else code - 128 if 128 < code < 128 + 65 else 0
    out.exit_code = code
    if code == 0:
        return out
    out.status = _classify(signum, out, limits, log)
    if out.status == "crashed":
        out.signal = _signal_name(signum)
    return out


def _classify(signum: int, out: Outcome, limits: Limits, log: str) -> str:
    """Which limit (if any) ended a failing program: a signal names CPU and file size; an
    address-space limit shows as a failed allocation (its message, or a crash with a resident
    set close to the limit)."""
    if signum == signal.SIGXCPU or (signum == signal.SIGKILL and out.cpu_seconds >= limits.cpu):
        return "cpu"
    if signum == signal.SIGXFSZ:
        return "file_size"
    if _ALLOC_FAILED.search(log) or out.peak_memory >= 0.75 * limits.memory:
        return "memory"
    return "crashed" if signum else "exit"


def _signal_name(signum: int) -> str:
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"
