"""The second hostile-input pass (issue 30): the cases no other test file held, and what an
attack beyond the issue's list found. Each test fails on the code before its fix."""

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


def _graded(tmp_path: Path, names: dict[str, tuple[str, ...]]) -> tuple[Path, Path]:
    """A class of rtdemo renders (name -> rtdemo options) graded at 32x24: (subs, out)."""
    rtdemo = str(Path(sys.executable).with_name("rtdemo"))
    subs, out = tmp_path / "subs", tmp_path / "out"
    subs.mkdir()
    for name, options in names.items():
        cmd = [rtdemo, "render", CLASSIC, "--width", "32", "--height", "24", *options]
        flag = "--png" if name.lower().endswith(".png") else "--ppm"
        assert run([*cmd, "--mode", "classic", flag, str(subs / name)]).returncode == 0
    proc = run(
        [
            RTVAL,
            "grade",
            str(subs),
            "--scene",
            CLASSIC,
            "--size",
            "32x24",
            "--no-diagnose",
            "--out",
            str(out),
        ]
    )
    assert proc.returncode in (0, 2), proc.stdout + proc.stderr
    return subs, out


def test_explain_into_a_closed_pipe_is_quiet_and_exits_141(tmp_path: Path) -> None:
    subs, out = _graded(tmp_path, {"alice.ppm": ()})
    read_end, write_end = os.pipe()
    os.close(read_end)  # `| head` gone before the first line
    try:
        cmd = [RTVAL, "grade", str(subs), "--out", str(out), "--explain", "alice"]
        proc = subprocess.run(cmd, stdout=write_end, stderr=subprocess.PIPE, text=True)
    finally:
        os.close(write_end)
    assert proc.returncode == 141 and proc.stderr == "", proc.stderr
