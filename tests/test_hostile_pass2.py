"""The second hostile-input pass: the cases no other test file held, and what an
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


def test_sigterm_to_grade_leaves_no_temporary_file(tmp_path: Path) -> None:
    rtdemo = str(Path(sys.executable).with_name("rtdemo"))
    subs, out = tmp_path / "subs", tmp_path / "out"
    subs.mkdir()
    for i in range(8):  # failing ones: each is diagnosed, which keeps grade busy
        size = ["--width", "160", "--height", "120"]
        assert run([rtdemo, "render", CLASSIC, *size, "--mode", "classic", "--no-shadows",
                    "--ppm", str(subs / f"st{i}.ppm")]).returncode == 0  # fmt: skip
    cmd = [RTVAL, "grade", str(subs), "--scene", CLASSIC, "--out", str(out), "--jobs", "2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("[1/8] st"):  # grading has begun: pages are being written
            proc.terminate()
            break
    rest = proc.stdout.read()
    proc.stdout.close()
    assert proc.wait(timeout=120) == 143, rest
    left = [p.name for p in out.rglob("*") if p.name.startswith(".") or p.suffix == ".tmp"]
    assert left == []


def test_names_that_act_or_hide_are_shown_escaped_and_must_be_renamed(tmp_path: Path) -> None:
    """A file name's ESC sequence reached the terminal (progress, --explain), the CSV and the
    page title raw; a bidi override showed "eve<RLO>gnp.exe" as "eveexe.png" and a zero-width
    space made "ma<ZWSP>llory" look like "mallory". Like a name that is not UTF-8, each is
    shown escaped and graded 0 with the reason, never as the name it imitates."""
    names = {"x\x1b[2Jy.ppm": (), "eve\u202egnp.exe.ppm": (), "ma\u200bllory.ppm": (),
             "zwnj\u200c.ppm": ()}  # fmt: skip
    _, out = _graded(tmp_path, names)
    csv = (out / "gradebook.csv").read_text(encoding="utf-8")
    pages = "".join(p.read_text(encoding="utf-8") for p in out.glob("students/*/index.html"))
    for shown in ("x\\x1b[2Jy", "eve\\u202egnp.exe", "ma\\u200bllory"):
        assert f"{shown},fail,0.00" in csv and "holds control or invisible characters" in csv
        assert f"<title>{shown}: fail" in pages
    for text in (csv, pages):
        assert not any(c in text for c in "\x1b\u202e\u200b")
    assert "zwnj\u200c,pass" in csv  # the zero-width non-joiner is part of some scripts' names
