"""Running untrusted programs (a student's build and renders) in a bubblewrap sandbox.

    ws = Workspace()                      # a fresh folder tree the sandbox may use
    copy the program into ws.src, the scene into ws.inputs
    outcome = run_sandboxed(["./rt", "/sandbox/in/scene.json"], ws, Limits(time=60), collect=f)
    outcome.reason                        # "" on success, else "timed out after 60 s ...", ...
    ws.close()

Inside the sandbox (docs/sandbox.md) the program sees the system read-only (/usr, /etc and
the /bin, /lib links), its inputs at /sandbox/in (read-only), and a memory-backed folder of
--disk bytes holding /sandbox/work (a copy of ws.src, the current folder) and /sandbox/out
(for {out}); a private /tmp of bounded size, a fresh /proc, a read-only minimal /dev with a
small /dev/shm. Nothing else of the machine exists there. It has no network, runs as uid
65534, in new namespaces, under a seccomp filter (compare/sandbox/seccomp.py) and new
session. Its first process is rtval's supervisor (compare/sandbox/supervisor.py), which
starts the program under its limits, watches every process of the sandbox, stops it at its
CPU time or wall time, and reports how it ended; while it waits, `collect` reads what the
program left (through /proc/PID/root: the folder exists only in the sandbox), then
everything ends. Nothing outlives rtval: bwrap is started by a launcher that dies with rtval
(PR_SET_PDEATHSIG), bwrap dies with it (--die-with-parent) and the sandbox with bwrap, and
the supervisor also ends the sandbox at its wall time by itself.
"""

from __future__ import annotations

import contextlib
import functools
import json
import marshal
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
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from compare.errors import ToolError
from compare.sandbox import seccomp, supervisor
from compare.sandbox.trees import remove_tree
from compare.sizes import human_size
from compare.student_ids import displayable

WORK_DIR = "/sandbox/work"  # the program's copy, its current folder
IN_DIR = "/sandbox/in"  # its inputs, read-only
OUT_DIR = "/sandbox/out"  # where {out} points
SRC_DIR = "/sandbox/src"  # what the supervisor copies into work, read-only
SANDBOX_UID = 65534  # nobody
SYSTEM_DIRS = ("/usr", "/etc")  # bound read-only; /bin, /lib... follow as links or binds
SYSTEM_LINKS = ("/bin", "/sbin", "/lib", "/lib32", "/lib64", "/libx32")
PATH = "/usr/local/bin:/usr/bin:/bin:/usr/local/sbin:/usr/sbin:/sbin"
SYSTEM_PYTHON = "/usr/bin/python3"  # runs the supervisor inside (scripts/setup.sh has it)
SHM_SIZE = 8 << 20  # /dev/shm: semaphores and small shared memory only
GRACE = 600.0  # seconds the supervisor waits for rtval to read the output, at most
BACKSTOP = 30.0  # seconds past the wall limit before rtval kills a silent sandbox itself
BUSY_SHARE = 0.25  # waited that share of the wall time for a CPU: the machine was too busy
_SUPERVISOR = Path(supervisor.__file__).read_text()


class SandboxUnavailable(ToolError):
    """No sandbox can be made here (bwrap missing or failing its probe)."""


@dataclass(frozen=True)
class Limits:
    """What one build or one run may use. Defaults: docs/sandbox.md."""

    time: float = 60.0  # CPU seconds of every process together: what a run is judged by
    wall: float = 0.0  # wall seconds for the whole sandbox; 0: generous, 3 x time + 10
    cpu: float = 600.0  # CPU seconds per process (RLIMIT_CPU): threads add up
    memory: int = 2 << 30  # address space per process (RLIMIT_AS)
    file_size: int = 256 << 20  # largest file a process may write (RLIMIT_FSIZE)
    processes: int = 128  # processes and threads in the sandbox (RLIMIT_NPROC)
    open_files: int = 256  # per process (RLIMIT_NOFILE)
    log: int = 64 << 10  # bytes of stdout+stderr kept: half from the start, half from the end
    tmp: int = 64 << 20  # size of the private /tmp (memory-backed)
    disk: int = 512 << 20  # work and out together (memory-backed)
    inodes: int = 100_000  # files and folders in work and out together

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if name == "wall" and value == 0:
                continue
            if not (value > 0 and value < 2**62):  # also refuses NaN
                raise ValueError(f"limit {name} must be positive, got {value!r}")

    @property
    def wall_limit(self) -> float:
        return self.wall or 3 * self.time + 10

    def rlimits(self) -> list[tuple[str, int, int]]:
        cpu = max(1, int(self.cpu + 0.999))
        # Soft CPU limit first: SIGXCPU says which limit it was; the hard one a second later
        # stops a program that ignores it. No core files: they would fill the folder.
        return [
            ("RLIMIT_CPU", cpu, cpu + 1),
            ("RLIMIT_AS", self.memory, self.memory),
            ("RLIMIT_FSIZE", self.file_size, self.file_size),
            ("RLIMIT_NPROC", self.processes, self.processes),
            ("RLIMIT_NOFILE", self.open_files, self.open_files),
            ("RLIMIT_CORE", 0, 0),
        ]


@dataclass
class Outcome:
    """How one sandboxed command ended, in words for a gradebook row. A reason names a
    signal only when the program was signalled, and a limit only on the kernel's word."""

    # ok, exit, crashed, timeout (CPU time), wall, busy, cpu, memory, file_size, disk, sandbox,
    # host_oom, supervisor
    status: str
    limits: Limits
    exit_code: int | None = None
    signal: str | None = None  # SIGSEGV, ...
    seconds: float = 0.0
    cpu_seconds: float = 0.0  # every process of the sandbox together
    peak_memory: int = 0  # bytes: the resident sets of all its processes together, at most
    log: str = ""  # head and tail of stdout+stderr, made displayable
    log_bytes: int = 0  # all it printed
    sandboxed: bool = True
    command: list[str] = field(default_factory=list)
    waited: float = 0.0  # seconds its processes waited for a CPU (the machine's load)

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
            "timeout": f"timed out after {lim.time:g} s of CPU time",
            "wall": f"timed out after {lim.wall_limit:g} s of wall time "
            f"({self.cpu_seconds:.1f} s of CPU used)",
            "busy": f"not finished in {lim.wall_limit:g} s: the machine was busy (it waited "
            f"{self.waited:.0f} s for a CPU); it runs again next time",
            "cpu": f"killed: CPU time limit {lim.cpu:g} s",
            "memory": f"killed: memory limit {human_size(lim.memory)}",
            "file_size": f"killed: file size limit {human_size(lim.file_size)}",
            "supervisor": "killed the sandbox's supervisor (only the program can)",
            "host_oom": "killed by the machine's out-of-memory killer (the machine's "
            "trouble); it runs again next time",
            "disk": f"stopped: disk limit {human_size(lim.disk)} or {lim.inodes} files "
            "(work and out full)",
            "sandbox": "the sandbox could not start: " + last_line(self.log),
        }[self.status]

    def as_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["limits"] = asdict(self.limits)
        d["reason"] = self.reason
        return d


def last_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return displayable(lines[-1][:300]) if lines else "(no message)"


# -- the folders a sandbox sees ------------------------------------------------------------


def sandbox_owner() -> tuple[int, int] | None:
    """(uid, gid) that bwrap runs as when rtval is root; None: as the calling user (whose
    processes are then mapped to 65534 inside)."""
    return (SANDBOX_UID, SANDBOX_UID) if os.geteuid() == 0 else None


class Workspace:
    """A fresh folder tree for one sandboxed command: src/ (the program, copied into the
    sandbox's own work folder when it starts), inputs/ (read-only inside) and, for a run
    without a sandbox only, work/ and out/. It lives in the system's temporary folder, whose
    ancestors the unprivileged sandbox user can traverse (rtval's --out folder may lie below a
    private one); its name holds rtval's pid, so that one left by a killed rtval is removed
    by the next; close() removes it, however deep what a program left there."""

    def __init__(self, base: str | None = None) -> None:
        _sweep_stale(base or tempfile.gettempdir())
        self.root = Path(tempfile.mkdtemp(prefix=f"rtval-sandbox-{os.getpid()}-", dir=base))
        os.chmod(self.root, 0o711)  # traversable, not listable
        self.src = self.root / "src"
        self.inputs = self.root / "inputs"
        self.work = self.root / "work"
        self.out = self.root / "out"
        self.links: list[tuple[str, str]] = []  # made again in the copy of src: a build's
        for d in (self.src, self.inputs, self.work, self.out):
            d.mkdir(mode=0o755)
        owner = sandbox_owner()
        if owner:
            for d in (self.work, self.out):
                os.chown(d, *owner)

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


_STALE = re.compile(r"rtval-sandbox-([0-9]+)-")


@functools.lru_cache(maxsize=4)
def _sweep_stale(base: str) -> None:
    """Removes the workspaces that an rtval killed before it could (SIGKILL, the OOM killer)
    left behind: ours, named after a process that is gone. Once per process and folder."""
    with contextlib.suppress(OSError), os.scandir(base) as it:
        stale = [e for e in it if (m := _STALE.match(e.name)) and not _alive(int(m.group(1)))]
    for e in stale:
        with contextlib.suppress(OSError):
            if e.stat(follow_symlinks=False).st_uid == os.geteuid():
                remove_tree(Path(e.path))


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


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


@dataclass(frozen=True)
class _Fds:
    """The descriptors the sandbox inherits: bwrap's status, the seccomp filter, the
    supervisor's report and its control (rtval closes its end when it has read the output)."""

    status: int
    seccomp: int
    report: int
    control: int


def bwrap_argv(
    ws: Workspace, limits: Limits, fds: _Fds, hide: Sequence[str | Path] = ()
) -> list[str]:
    """The bwrap command line up to (and including) its '--'."""
    env = {"PATH": PATH, "HOME": "/tmp", "TMPDIR": "/tmp", "LANG": "C.UTF-8", "TERM": "dumb"}
    uid = str(SANDBOX_UID)
    args = [bwrap_path(), "--unshare-all", "--unshare-user", "--disable-userns"]
    args += ["--uid", uid, "--gid", uid, "--hostname", "sandbox", "--die-with-parent"]
    args += ["--new-session", *_system_mounts(), "--proc", "/proc", "--dev", "/dev"]
    args += ["--size", str(SHM_SIZE), "--tmpfs", "/dev/shm", "--remount-ro", "/dev"]
    args += ["--size", str(limits.tmp), "--tmpfs", "/tmp", *_hidden(hide)]
    args += ["--size", str(limits.disk), "--tmpfs", "/sandbox"]
    args += ["--dir", WORK_DIR, "--dir", OUT_DIR]
    args += ["--ro-bind", str(ws.src), SRC_DIR, "--ro-bind", str(ws.inputs), IN_DIR]
    args += ["--chdir", WORK_DIR, "--remount-ro", "/"]
    args += ["--json-status-fd", str(fds.status), "--seccomp", str(fds.seccomp), "--clearenv"]
    for k, v in env.items():
        args += ["--setenv", k, v]
    return [*args, "--"]


@functools.lru_cache(maxsize=1)
def probe() -> str | None:
    """None when a sandbox works here, else why not (checked once per process)."""
    bwrap = bwrap_path()
    if not (os.path.isfile(bwrap) and os.access(bwrap, os.X_OK)):
        return f"bubblewrap is not installed ({bwrap} missing; Debian: apt-get install bubblewrap)"
    if not os.path.isfile(SYSTEM_PYTHON):
        return f"{SYSTEM_PYTHON} (which runs the sandbox's supervisor) is missing"
    if not os.path.isfile(SETPRIV):
        return f"{SETPRIV} (util-linux) is missing"
    if not hasattr(os, "pidfd_open"):
        return "this Python or kernel has no pidfd_open (Linux 5.3+ needed)"
    if why := seccomp.unavailable():
        return why
    seen: list[str] = []
    try:
        with Workspace() as ws:
            out = run_sandboxed(
                ["sh", "-c", f"echo ok > {OUT_DIR}/probe"],
                ws,
                Limits(time=30),
                collect=lambda _work, out: seen.extend(os.listdir(out)),
            )
    except OSError as e:
        return f"cannot start {bwrap}: {e}"
    if not out.ok:
        return f"{bwrap} fails here: {last_line(out.log)}"
    return None if seen == ["probe"] else "the sandbox's output cannot be read back here"


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
    report: bytearray = field(default_factory=bytearray)  # the supervisor's line
    timed_out: bool = False  # rtval's own backstop: the supervisor never reported

    def usage(self) -> dict[str, Any] | None:
        """The supervisor's report, once it is complete."""
        if not self.report.endswith(b"\n"):
            return None
        try:
            report = json.loads(self.report)
        except ValueError:
            return None
        return report if isinstance(report, dict) else None

    def child_pid(self) -> int | None:
        m = re.search(rb'"child-pid"\s*:\s*([0-9]+)', self.status)
        return int(m.group(1)) if m else None


# Between rtval and bwrap (or, without a sandbox, the supervisor): util-linux's setpriv takes
# the sandbox user (as root), asks the kernel for SIGKILL when rtval's process goes (after
# the uid change, which would clear the request) and becomes bwrap. Not forked from rtval
# itself: a forked grading worker would start with hundreds of MiB resident.
SETPRIV = "/usr/bin/setpriv"


def _launcher() -> list[str]:
    owner = sandbox_owner()  # as root: never run it as root, even unsandboxed
    as_user = []
    if owner:
        as_user = ["--reuid", str(owner[0]), "--regid", str(owner[1]), "--clear-groups"]
    return [SETPRIV, *as_user, "--pdeathsig", "KILL", "--"]


Collect = Callable[[Path, Path], object]  # (work, out) as rtval can read them, while paused


def run_sandboxed(
    argv: Sequence[str],
    ws: Workspace,
    limits: Limits,
    *,
    sandboxed: bool = True,
    hide: Sequence[str | Path] = (),
    collect: Collect | None = None,
) -> Outcome:
    """Runs argv (in a copy of ws.src) under the limits and says how it ended; `collect`
    reads the program's work and out folders after it ended, before they vanish. Never
    raises for anything the program does; OSError when the launcher cannot start, and what
    collect raises, once the sandbox is gone."""
    pipes = [os.pipe() for _ in range(4)]  # log, bwrap's status, the report, the control
    (log_r, log_w), (status_r, status_w), (report_r, report_w), (control_r, control_w) = pipes
    filter_fd = seccomp.filter_fd() if sandboxed else -1
    fds = _Fds(status_w, filter_fd, report_w, control_r)
    full = _command(argv, ws, limits, fds, sandboxed, hide)
    start, ooms = time.monotonic(), _oom_kills()
    try:
        proc = subprocess.Popen(
            [*_launcher(), *full],
            stdin=subprocess.DEVNULL,
            stdout=log_w,
            stderr=log_w,
            pass_fds=tuple(fd for fd in (status_w, report_w, control_r, filter_fd) if fd >= 0),
            env={"PATH": PATH, "HOME": str(ws.work), "LANG": "C.UTF-8"},
            start_new_session=True,  # its own process group: rtval's signals are not its
        )
    except BaseException:
        for fd in (fd for pair in pipes for fd in pair):
            os.close(fd)
        raise
    finally:
        if filter_fd >= 0:
            os.close(filter_fd)
    for fd in (log_w, status_w, report_w, control_r):
        os.close(fd)
    run = _Run(proc, _Watch(_Log(limits.log)), limits, sandboxed, ws, collect, control_w)
    try:
        run.supervise({log_r: "log", status_r: "status", report_r: "report"})
    finally:
        run.close_control()
        for fd in (log_r, status_r, report_r):
            os.close(fd)
    if run.collect_error is not None:
        raise run.collect_error
    out = _outcome(run.watch, time.monotonic() - start, limits, sandboxed, [*argv])
    machine = out.status == "supervisor" or out.signal == "SIGKILL"
    if machine and _oom_kills() > ooms:  # the kernel's OOM killer took it, not the program
        out.status = "host_oom"
    return out


def _oom_kills() -> int:
    """How many processes the kernel's OOM killer has killed since boot (/proc/vmstat)."""
    try:
        with open("/proc/vmstat", "rb") as f:
            for line in f:
                if line.startswith(b"oom_kill "):
                    return int(line.split()[1])
    except (OSError, ValueError):
        pass
    return 0


def _command(
    argv: Sequence[str],
    ws: Workspace,
    limits: Limits,
    fds: _Fds,
    sandboxed: bool,
    hide: Sequence[str | Path],
) -> list[str]:
    """bwrap and the supervisor (or the supervisor alone), with the supervisor's settings."""
    cfg = {
        "argv": list(argv),
        "cwd": WORK_DIR if sandboxed else str(ws.work),
        "src": SRC_DIR if sandboxed else str(ws.src),
        "links": ws.links,
        "sandboxed": sandboxed,
        "rlimits": limits.rlimits(),
        "time": limits.time,
        "wall": limits.wall_limit,
        "disk_root": "/sandbox" if sandboxed else "",
        "inodes": limits.inodes,
        "report": fds.report,
        "control": fds.control,
        "grace": GRACE,
    }
    # Unsandboxed as root, the supervisor runs as the sandbox user: the system's Python is
    # one it can run (rtval's own may lie in root's home).
    python = SYSTEM_PYTHON if sandboxed or os.path.isfile(SYSTEM_PYTHON) else sys.executable
    tail = [python, "-I", "-S", "-c", _SUPERVISOR, marshal.dumps(cfg).hex()]
    return [*bwrap_argv(ws, limits, fds, hide), *tail] if sandboxed else tail


class _Run:
    """One sandbox watched from rtval's side: its pipes read until the launcher ends, the
    output collected once the supervisor has reported, the sandbox killed past the
    backstop. Waits on events (the launcher's pidfd, the pipes), never by sleeping."""

    def __init__(
        self,
        proc: subprocess.Popen[bytes],
        watch: _Watch,
        limits: Limits,
        sandboxed: bool,
        ws: Workspace,
        collect: Collect | None,
        control: int,
    ) -> None:
        self.proc, self.watch, self.limits, self.sandboxed = proc, watch, limits, sandboxed
        self.ws, self.collect, self.control = ws, collect, control
        self.collect_error: BaseException | None = None

    def close_control(self) -> None:
        if self.control >= 0:
            os.close(self.control)
            self.control = -1

    def supervise(self, pipes: dict[int, str]) -> None:
        pidfd = os.pidfd_open(self.proc.pid)
        sel = selectors.DefaultSelector()
        for fd, what in pipes.items():
            os.set_blocking(fd, False)
            sel.register(fd, selectors.EVENT_READ, what)
        sel.register(pidfd, selectors.EVENT_READ, "exit")
        try:
            self._loop(sel, time.monotonic() + self.limits.wall_limit + BACKSTOP)
            self.proc.wait()  # it has exited, or was just killed: this returns at once
            _drain(sel, self.watch)
        except BaseException:  # interrupted: leave nothing running, then let it propagate
            if self.proc.returncode is None:
                _kill(self.proc, self.watch, self.sandboxed)
                self.proc.wait()
            raise
        finally:
            sel.close()
            os.close(pidfd)

    def _loop(self, sel: selectors.BaseSelector, deadline: float) -> None:
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                self.watch.timed_out = True
                _kill(self.proc, self.watch, self.sandboxed)
                return
            exited = False
            for key, _ in sel.select(left):
                if key.data == "exit":
                    exited = True
                elif not _read_some(key.fd, self.watch, key.data):
                    sel.unregister(key.fd)
            if self.control >= 0 and self.watch.usage() is not None:
                self._collect(sel)
            if exited:
                return

    def _collect(self, sel: selectors.BaseSelector) -> None:
        """The program has ended and every process of it is dead; the supervisor waits
        while its folders are read."""
        for key in list(sel.get_map().values()):
            if key.data == "status":
                _read_some(key.fd, self.watch, "status")
        try:
            if self.collect is not None:
                self.collect(*self._folders())
        except BaseException as e:  # raised again once the sandbox is gone
            self.collect_error = e
        self.close_control()

    def _folders(self) -> tuple[Path, Path]:
        if not self.sandboxed:
            return self.ws.work, self.ws.out
        pid = self.watch.child_pid()
        if pid is None or _parent(pid) != self.proc.pid:  # bwrap's own child, no other
            raise OSError("bwrap did not say which process is the sandbox")
        root = Path(f"/proc/{pid}/root")
        return root / WORK_DIR.lstrip("/"), root / OUT_DIR.lstrip("/")


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
    watch: _Watch, seconds: float, limits: Limits, sandboxed: bool, command: list[str]
) -> Outcome:
    report = watch.usage()
    out = Outcome(
        "ok",
        limits,
        seconds=seconds,
        log=displayable(watch.log.text(), lines=True),
        log_bytes=watch.log.total,
        sandboxed=sandboxed,
        command=command,
    )
    if report is None:  # the supervisor never reported
        out.status = "wall" if watch.timed_out else _silent(watch, out.log)
        return out
    out.seconds = float(report.get("seconds", seconds))
    out.cpu_seconds = float(report.get("cpu", 0.0))
    out.peak_memory = max(int(report.get("peak", 0)), int(report.get("max_rss", 0)))
    out.waited = float(report.get("delay", 0.0))
    out.status, signum = _classify(report, limits, out.waited)
    status = report.get("status")
    if isinstance(status, int) and os.WIFEXITED(status):
        out.exit_code = os.WEXITSTATUS(status)
    if out.status == "crashed":
        out.signal = _signal_name(signum)
    return out


def _silent(watch: _Watch, log: str) -> str:
    """Why no report came: the sandbox never started (bwrap, the launcher or the supervisor
    failed: the machine's trouble), or it started and its supervisor was killed, which only
    the program (the same user inside) or the machine's OOM killer can do."""
    if watch.child_pid() is None or "rtval's sandbox supervisor failed" in log:
        return "sandbox"
    return "supervisor"


def _classify(report: dict[str, Any], limits: Limits, waited: float) -> tuple[str, int]:
    """(status, signal) from the supervisor's evidence: why it stopped the sandbox, the
    program's own wait status (a signal only when it was signalled: an exit code of 152 is
    an exit code), the largest resident set beside the memory limit, a full disk."""
    stopped = report.get("stopped")
    if stopped == "cpu":
        return "timeout", 0
    if stopped == "inodes":
        return "disk", 0
    if stopped == "wall":  # a program that waited long for a CPU was the machine's victim
        return ("busy" if waited > BUSY_SHARE * limits.wall_limit else "wall"), 0
    status = report.get("status")
    if not isinstance(status, int):
        return "sandbox", 0
    signum = os.WTERMSIG(status) if os.WIFSIGNALED(status) else 0
    if signum == signal.SIGXCPU or (
        signum == signal.SIGKILL and float(report.get("main_cpu", 0)) >= limits.cpu
    ):
        return "cpu", signum
    if signum == signal.SIGXFSZ:
        return "file_size", signum
    if not signum and os.WEXITSTATUS(status) == 0:
        return "ok", 0
    if int(report.get("max_rss", 0)) >= 0.75 * limits.memory:
        return "memory", signum
    if report.get("disk_full"):
        return "disk", signum
    return ("crashed" if signum else "exit"), signum


def _signal_name(signum: int) -> str:
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"
