"""`rtval grade` as a command: a reader gone, a stop signal, and names that act or hide."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from helpers import SCENES, run

RTVAL = str(Path(sys.executable).with_name("rtval"))

CLASSIC = str(SCENES / "classic.json")


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
