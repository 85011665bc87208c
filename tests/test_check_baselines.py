"""`rtval check` and its baselines: a planted link or device where a baseline lives, and a stop signal while the renderer runs."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from helpers import SCENES, run

RTVAL = str(Path(sys.executable).with_name("rtval"))

CLASSIC = str(SCENES / "classic.json")


def _check(base: Path, *args: str) -> tuple[int, str]:
    cmd = [RTVAL, "check", "--baseline", str(base), "--scenes", CLASSIC, "--modes", "paper"]
    proc = run([*cmd, "--size", "32x24", *args])
    return proc.returncode, proc.stdout + proc.stderr


def test_update_never_writes_through_a_folder_linked_into_the_baselines(tmp_path: Path) -> None:
    victim, base = tmp_path / "victim", tmp_path / "base"
    victim.mkdir()
    base.mkdir()
    (base / "classic").symlink_to(victim)
    code, out = _check(base, "--update")
    assert code == 4 and f"{base / 'classic'}: is a symbolic link" in out, out
    assert list(victim.iterdir()) == []


def test_a_baseline_that_is_a_device_is_unreadable_not_missing(tmp_path: Path) -> None:
    base = tmp_path / "base"
    (base / "classic").mkdir(parents=True)
    (base / "classic" / "paper.exr").symlink_to("/dev/zero")
    code, out = _check(base)
    assert code == 2 and "unreadable baseline" in out and "character device" in out, out
    assert "no baseline" not in out
    # --update must not replace the link (nor write into /dev/zero).
    code, out = _check(base, "--update")
    assert code == 4 and "is a symbolic link" in out, out
    assert os.readlink(base / "classic" / "paper.exr") == "/dev/zero"


def _gone(pid: int) -> bool:
    """No such process, or only its zombie (it has exited; init reaps it)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except FileNotFoundError:
        return True


def test_sigterm_to_check_kills_the_renderer_and_exits_143(tmp_path: Path) -> None:
    """The renderer runs in a session of its own; a SIGTERM that killed rtval outright left
    it running. Now the signal unwinds like Ctrl-C: the renderer's group is killed."""
    fifo = tmp_path / "pid"
    os.mkfifo(fifo)
    script = tmp_path / "slow.sh"
    script.write_text(f'#!/bin/sh\necho $$ > "{fifo}"\nexec sleep 600\n')
    script.chmod(0o755)
    cmd = [RTVAL, "check", "--baseline", str(tmp_path / "b"), "--scenes", CLASSIC]
    proc = subprocess.Popen(
        [*cmd, "--renderer", f"{script} {{out}}"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    with open(fifo) as f:  # blocks until the renderer has started
        renderer = int(f.read())
    proc.terminate()
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and "interrupted (SIGTERM)" in err, err
    assert _gone(renderer)
