"""`rtval grade` against what a student (or a broken machine) can plant around it:
links under OUT (with --out inside the submissions a student can make them), stored results
that are links to /dev/zero or FIFOs, a Dask scheduler that never answers, refuses or speaks
junk, and grade killed while its pool works. Each case ends in a clear message and an exit
code, never a write through a link, a hang, exhausted memory or an orphaned worker."""

from __future__ import annotations

import contextlib
import os
import queue
import resource
import select
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from helpers import SCENES, render_demo, run

pytestmark = pytest.mark.slow
RTVAL = str(Path(sys.executable).with_name("rtval"))
SIZE = (32, 24)
BOUND_S = 120  # a bound on a command that must finish, not an expected duration


def _grade_cmd(subs: Path, out: Path, cache: Path, *options: str) -> list[str]:
    size = f"{SIZE[0]}x{SIZE[1]}"
    return [RTVAL, "grade", str(subs), "--scene", "classic", "--out", str(out), "--size", size,
            "--cache", str(cache), *options]  # fmt: skip


def _limited() -> None:
    """The child's address space is capped: reading /dev/zero to the end fails fast."""
    resource.setrlimit(resource.RLIMIT_AS, (8 << 30, 8 << 30))


def _grade(subs: Path, out: Path, cache: Path, *options: str) -> subprocess.CompletedProcess[str]:
    cmd = _grade_cmd(subs, out, cache, *options)
    return run(cmd, cwd=SCENES.parent, timeout=BOUND_S, preexec_fn=_limited)


@pytest.fixture(scope="module")
def klass(tmp_path_factory: pytest.TempPathFactory, rtdemo: str) -> tuple[Path, Path]:
    """(submissions: ann, bob, carol as classic renders; the render cache, warmed)."""
    root = tmp_path_factory.mktemp("hostile-fs")
    subs, cache = root / "subs", root / "cache"
    subs.mkdir()
    render_demo(rtdemo, SCENES / "classic.json", subs / "ann.ppm", "--mode", "classic", size=SIZE)
    for name in ("bob", "carol"):
        shutil.copyfile(subs / "ann.ppm", subs / f"{name}.ppm")
    proc = _grade(subs, root / "warm", cache)
    assert proc.returncode == 0, proc.stderr
    return subs, cache


def _listing(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir()}


@pytest.mark.parametrize("planted", ["students/bob", "students", "references", "results"])
def test_a_link_planted_under_out_is_refused(
    klass: tuple[Path, Path], tmp_path: Path, planted: str
) -> None:
    subs, cache = klass
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "keep.txt").write_text("mine")
    out = tmp_path / "grades"
    (out / planted).parent.mkdir(parents=True, exist_ok=True)
    (out / planted).symlink_to(victim, target_is_directory=True)
    proc = _grade(subs, out, cache)
    assert proc.returncode == 4, proc.stderr
    assert f"{out / planted}: is a symbolic link" in proc.stderr and "Traceback" not in proc.stderr
    assert _listing(victim) == {"keep.txt": b"mine"}


def test_a_bad_stored_result_is_graded_again_with_a_warning(
    klass: tuple[Path, Path], tmp_path: Path
) -> None:
    subs, cache = klass
    out = tmp_path / "grades"
    assert _grade(subs, out, cache).returncode == 0
    results = out / "results"
    (results / "ann.json").unlink()
    (results / "ann.json").symlink_to("/dev/zero")
    (results / "bob.json").unlink()
    os.mkfifo(results / "bob.json")
    copy = tmp_path / "carol.json"
    shutil.copyfile(results / "carol.json", copy)
    (results / "carol.json").unlink()
    (results / "carol.json").symlink_to(copy)  # even a link to a good result is not one
    explained = run([RTVAL, "grade", "--explain", "bob", "--out", str(out)], timeout=BOUND_S)
    assert explained.returncode == 4 and "bob.json" in explained.stderr
    assert "is a FIFO" in explained.stderr
    proc = _grade(subs, out, cache)
    assert proc.returncode == 0, proc.stderr
    for name, what in (("ann", "symbolic link"), ("bob", "FIFO"), ("carol", "symbolic link")):
        assert f"warning: {results / name}.json: is a {what}" in proc.stderr, proc.stderr
        assert (results / f"{name}.json").is_file() and not (results / f"{name}.json").is_symlink()
    assert "(0 resumed)" in proc.stderr


@pytest.fixture
def listener() -> Iterator[tuple[socket.socket, threading.Event]]:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen(8)
    yield s, threading.Event()
    s.close()


def _serve(s: socket.socket, accepted: threading.Event, reply: bytes) -> None:
    """Accepts connections, sends `reply` (b"": nothing) and keeps them open, never reading."""
    held = []
    while True:
        try:
            conn, _ = s.accept()
        except OSError:  # the test closed the listener
            break
        held.append(conn)
        if reply:
            conn.sendall(reply)
        accepted.set()
    for conn in held:
        conn.close()


@pytest.mark.parametrize(
    ("reply", "message"),
    [
        (b"", "no Dask scheduler answered within 1 s"),
        (b"\xff" * 4096, "does not speak the Dask protocol"),
    ],
)
def test_a_scheduler_that_is_not_one_is_an_error_not_a_hang(
    klass: tuple[Path, Path],
    tmp_path: Path,
    listener: tuple[socket.socket, threading.Event],
    reply: bytes,
    message: str,
) -> None:
    subs, cache = klass
    s, accepted = listener
    threading.Thread(target=_serve, args=(s, accepted, reply), daemon=True).start()
    address = f"tcp://127.0.0.1:{s.getsockname()[1]}"
    dask = ["--executor", "dask", "--scheduler", address, "--scheduler-timeout", "1"]
    proc = _grade(subs, tmp_path / "grades", cache, *dask)
    assert accepted.is_set()
    assert proc.returncode == 4, proc.stderr
    assert f"{address}: {message}" in proc.stderr and "Traceback" not in proc.stderr


def test_a_scheduler_port_that_refuses_fails_at_once(
    klass: tuple[Path, Path], tmp_path: Path
) -> None:
    subs, cache = klass
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()  # nothing listens there now
    dask = ["--executor", "dask", "--scheduler", f"tcp://127.0.0.1:{port}"]
    proc = _grade(subs, tmp_path / "grades", cache, *dask)
    assert proc.returncode == 4 and "cannot connect to the Dask scheduler" in proc.stderr


def _children(pid: int) -> set[int]:
    """The live processes whose parent is `pid`."""
    found = set()
    for entry in os.listdir("/proc"):
        if entry.isdigit() and _stat(int(entry))[1] == pid:
            found.add(int(entry))
    return found


def _ended(pids: set[int], bound: float) -> bool:
    """Whether every process in `pids` ends within `bound` seconds, waited on through pidfds
    (readable when the process exits), not by polling the clock."""
    fds = []
    for pid in pids:
        with contextlib.suppress(ProcessLookupError):  # gone already
            fds.append(os.pidfd_open(pid))
    try:
        deadline = time.monotonic() + bound
        waiting = list(fds)
        while waiting:
            left = deadline - time.monotonic()
            ready = select.select(waiting, [], [], max(0.0, left))[0] if left > 0 else []
            if not ready:
                return False
            waiting = [fd for fd in waiting if fd not in ready]
        return True
    finally:
        for fd in fds:
            os.close(fd)


def _stat(pid: int) -> tuple[str, int]:
    """(state, parent pid) of a process; ("X", 0) when it is gone."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return "X", 0
    fields = text.rsplit(")", 1)[1].split()
    return fields[0], int(fields[1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_pool_workers_die_with_grade(
    klass: tuple[Path, Path], tmp_path: Path, rtdemo: str, sig: signal.Signals
) -> None:
    subs = tmp_path / "subs"
    subs.mkdir()
    first = subs / "s00.ppm"
    render_demo(rtdemo, SCENES / "classic.json", first, "--mode", "paper", size=SIZE)
    for i in range(1, 24):  # failing submissions, each diagnosed: the pool stays busy
        shutil.copyfile(first, subs / f"s{i:02d}.ppm")
    cmd = _grade_cmd(subs, tmp_path / "grades", klass[1], "--jobs", "2")
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, cwd=SCENES.parent)
    lines: queue.Queue[str] = queue.Queue()
    workers: set[int] = set()
    reader = threading.Thread(target=lambda: [lines.put(ln) for ln in proc.stderr or []])
    reader.start()
    try:
        while not lines.get(timeout=BOUND_S).startswith("[1/24]"):  # a worker has graded one
            pass
        workers = _children(proc.pid)
        assert workers
        proc.send_signal(sig)
        proc.wait(timeout=BOUND_S)
        assert _ended(workers, bound=30), f"workers outlived grade: {workers}"  # PDEATHSIG: at once
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        for w in workers:  # survivors (the failure this test catches) hold the pipe open
            if _stat(w)[0] not in ("X", "Z"):
                os.kill(w, signal.SIGKILL)
        reader.join()  # the pipe's end: every writer (grade and its workers) is gone
        assert proc.stderr is not None
        proc.stderr.close()
