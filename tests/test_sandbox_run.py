"""compare/sandbox/bwrap.py and supervisor.py, directly: true reasons (a signal only from
the wait status, a limit only on the kernel's evidence), CPU time and memory of every
process, the disk and /dev bounds, the seccomp filter, and that nothing of a sandbox outlives
the rtval that started it."""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import tempfile
import uuid
from pathlib import Path

import pytest

from compare.sandbox import seccomp
from compare.sandbox.bwrap import Limits, Workspace, _classify, _hidden, probe, run_sandboxed
from compare.sandbox.output import read_output

pytestmark = pytest.mark.skipif(probe() is not None, reason=f"no sandbox here: {probe()}")
PY = "/usr/bin/python3"
TEN = Limits(time=10)


def _run(script: str, limits: Limits = TEN, **kw: object) -> object:
    with Workspace() as ws:
        return run_sandboxed(["sh", "-c", script], ws, limits, **kw)  # type: ignore[arg-type]


def test_an_exit_code_is_never_read_as_a_signal() -> None:
    out = _run("exit 152")
    assert out.status == "exit" and out.reason == "exit 152"  # type: ignore[attr-defined]
    crashed = _run("kill -SEGV $$")
    assert crashed.reason == "crashed: SIGSEGV"  # type: ignore[attr-defined]


def test_printed_words_do_not_name_a_limit() -> None:
    out = _run("echo 'terminate called after throwing std::bad_alloc'; exit 1")
    assert out.reason == "exit 1"  # type: ignore[attr-defined]


def test_children_count_in_memory_and_cpu() -> None:
    script = (
        "import os\n"
        "for _ in range(3):\n"
        "    if os.fork() == 0:\n"
        "        b = bytearray(200 << 20); b[::4096] = b'x' * (len(b) // 4096)\n"
        "        n = 0\n"
        "        while n < 3_000_000: n += 1\n"
        "        os._exit(0)\n"
        "for _ in range(3): os.wait()\n"
    )
    with Workspace() as ws:
        out = run_sandboxed([PY, "-c", script], ws, Limits(time=30))
    assert out.ok, out.log
    assert out.peak_memory >= 300 << 20  # more than any one process had
    assert out.cpu_seconds > 0.1  # the children's loops, not only the parent's waits


def test_cpu_time_of_the_whole_sandbox_ends_it() -> None:
    out = _run("sh -c 'while :; do :; done' & while :; do :; done", Limits(time=1))
    assert out.status == "timeout", out.reason  # type: ignore[attr-defined]
    assert out.reason == "timed out after 1 s of CPU time"  # type: ignore[attr-defined]


def test_the_supervisor_ends_a_sandbox_at_its_wall_time() -> None:
    out = _run("sleep 1000", Limits(time=1, wall=1.5))
    assert out.status == "wall" and "of wall time" in out.reason  # type: ignore[attr-defined]


def test_a_starved_run_is_busy_not_a_timeout() -> None:
    limits = Limits(time=1, wall=10)
    assert _classify({"stopped": "wall"}, limits, waited=6.0) == ("busy", 0)
    assert _classify({"stopped": "wall"}, limits, waited=0.1) == ("wall", 0)
    assert _classify({"status": 152 << 8}, limits, 0.0) == ("exit", 0)


def test_work_and_out_are_bounded_and_dev_is_read_only() -> None:
    full = _run(
        "head -c 40000000 /dev/zero > /sandbox/out/big; exit 3", Limits(time=10, disk=16 << 20)
    )
    assert full.status == "disk" and "disk limit 16 MiB" in full.reason  # type: ignore[attr-defined]
    dev = _run(
        "echo x > /dev/evil || echo refused; head -c 20000000 /dev/zero > /dev/shm/big || echo small"
    )
    assert "Read-only" in dev.log and "small" in dev.log  # type: ignore[attr-defined]


def test_output_is_read_back_before_the_sandbox_goes() -> None:
    got: list[object] = []
    with Workspace() as ws:
        (ws.src / "in.txt").write_text("copied in")
        ws.links = [("alias", "in.txt")]
        out = run_sandboxed(
            ["sh", "-c", "cat alias > /sandbox/out/o.txt"],
            ws,
            Limits(time=10),
            collect=lambda work, out: got.extend(
                [(out / "o.txt").read_text(), (work / "alias").is_symlink()]
            ),
        )
    assert out.ok and got == ["copied in", True]


def _syscall_numbers(*names: str) -> list[int]:
    lib = seccomp._library()
    assert lib is not None
    return [lib.seccomp_syscall_resolve_name(n.encode()) for n in names]


def test_seccomp_denies_the_kernel_surface() -> None:
    names = ("io_uring_setup", "ptrace", "keyctl", "add_key", "perf_event_open", "bpf",
             "userfaultfd", "mount", "unshare", "setns", "kexec_load")  # fmt: skip
    numbers = _syscall_numbers(*names)
    script = (
        "import ctypes, sys\nlibc = ctypes.CDLL(None, use_errno=True)\n"
        f"for nr in {numbers}:\n"
        "    r = libc.syscall(nr, 0, 0, 0, 0, 0)\n"
        "    print(nr, r, ctypes.get_errno())\n"
    )
    with Workspace() as ws:
        out = run_sandboxed([PY, "-c", script], ws, Limits(time=10))
    assert out.ok, out.log
    rows = [line.split() for line in out.log.splitlines()]
    assert len(rows) == len(names)
    assert all(r[1] == "-1" and r[2] == "1" for r in rows), rows  # EPERM, every one


def _marked(marker: str, first: bool = False) -> list[int]:
    """Processes whose command line holds the marker (first: as its program name)."""
    found = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                words = (d / "cmdline").read_bytes().split(b"\0")
            except OSError:
                continue
            if (words[0] == marker.encode()) if first else any(marker.encode() in w for w in words):
                found.append(int(d.name))
    return found


def _wait_for(check: object, tries: int = 400) -> bool:
    """Polls check() at most `tries` times, each a short blocking wait on nothing but time
    spent in a child's exit (a bounded loop, not a sleep-then-expect)."""
    for _ in range(tries):
        if check():  # type: ignore[operator]
            return True
        subprocess.run(["sleep", "0.05"], check=False)
    return False


def test_nothing_outlives_a_killed_rtval(tmp_path: Path) -> None:
    marker = f"rtvk{uuid.uuid4().hex[:8]}"
    base = Path(tempfile.mkdtemp(dir="/tmp"))
    base.chmod(0o711)
    code = (
        "import sys\nfrom compare.sandbox.bwrap import Limits, Workspace, run_sandboxed\n"
        f"ws = Workspace({str(base)!r})\n"
        "name = sys.argv[1] + sys.argv[2]\n"  # the marker is in no command line but its own
        'inner = f\'import os; os.execv("/bin/sleep", ["{name}", "1000"])\'\n'
        "run_sandboxed(['/usr/bin/python3', '-c', inner], ws, Limits(time=600))\n"
    )
    grader = subprocess.Popen([sys.executable, "-c", code, marker[:4], marker[4:]])
    try:
        assert _wait_for(lambda: _marked(marker, first=True)), "the program never started"
        assert os.listdir(base)  # its workspace
        grader.send_signal(signal.SIGKILL)  # as the OOM killer would
        grader.wait()
        assert _wait_for(lambda: not _marked(marker)), "the sandbox outlived rtval"
        with Workspace(str(base)):  # the next rtval removes what the killed one left
            assert len(os.listdir(base)) == 1
        assert os.listdir(base) == []
    finally:
        if grader.poll() is None:
            grader.kill()
            grader.wait()
        for pid in _marked(marker):
            os.kill(pid, signal.SIGKILL)
        os.rmdir(base)


def test_the_teachers_paths_inside_system_folders_are_covered() -> None:
    assert _hidden(["/usr/share", "/nonexistent", "/tmp"]) == ["--tmpfs", "/usr/share"]
    assert ctypes  # used by the seccomp test's script


def test_a_kill_by_the_machines_oom_killer_is_not_the_programs(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    counts = iter([7, 8])  # the kernel's oom_kill counter, before and after the run
    monkeypatch.setattr("compare.sandbox.bwrap._oom_kills", lambda: next(counts))
    out = _run("kill -KILL $$")
    assert out.status == "host_oom" and "runs again" in out.reason  # type: ignore[attr-defined]
    monkeypatch.undo()
    assert _run("kill -KILL $$").reason == "crashed: SIGKILL"  # type: ignore[attr-defined]


def test_rtval_and_rtdemo_are_not_there() -> None:
    out = _run("command -v rtval rtdemo; ls /work /root 2>&1; true")
    assert "rtval" not in out.log and "rtdemo" not in out.log  # type: ignore[attr-defined]


def test_a_program_cannot_forge_the_supervisors_report() -> None:
    forge = (
        "import os\nfor fd in range(3, 64):\n"
        '    try: os.write(fd, b\'{"status": 0, "stopped": ""}\\n\')\n'
        "    except OSError: pass\n"
        "raise SystemExit(7)\n"
    )
    with Workspace() as ws:
        out = run_sandboxed([PY, "-c", forge], ws, TEN)
    assert out.reason == "exit 7"


def test_an_out_folder_swapped_for_a_link_is_not_followed() -> None:
    read: list[tuple[str, bytes]] = []
    with Workspace() as ws:
        out = run_sandboxed(
            ["sh", "-c", "cd /sandbox && rmdir out && ln -s /etc out"],
            ws,
            TEN,
            collect=lambda _w, out: read.append(read_output(out, "passwd", 10, 10)),
        )
    assert out.ok and read == [("no output: its folder out/ is not a folder", b"")]


def test_killing_the_supervisor_is_the_programs_doing() -> None:
    out = _run("kill -KILL $PPID; sleep 5")
    assert out.status == "supervisor", out.log  # type: ignore[attr-defined]
    assert out.reason == "killed the sandbox's supervisor (only the program can)"  # type: ignore[attr-defined]
    peek = _run("ls /proc/$PPID/fd 2>&1; cat /proc/$PPID/mem 2>&1 | head -c 40; true")
    assert "Permission denied" in peek.log  # type: ignore[attr-defined]


def test_files_beyond_the_inode_bound_stop_the_sandbox() -> None:
    out = _run(
        "i=0; while [ $i -lt 5000 ]; do : > f$i; i=$((i+1)); done", Limits(time=10, inodes=200)
    )
    assert out.status == "disk" and "200 files" in out.reason  # type: ignore[attr-defined]
