"""Nothing of rtval's is left in $TMPDIR: grading a class and a failing reference clean up after
themselves (a reference render's cap meshes: test_input_checks; the report: its renders go
through the render cache's own tmp/ folder)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from helpers import SCENES, render_demo, run

RTVAL = str(Path(sys.executable).with_name("rtval"))


def _run_in(tmpdir: Path, *args: str) -> int:
    env = {**os.environ, "TMPDIR": str(tmpdir)}
    return run([RTVAL, *args], env=env).returncode


@pytest.mark.slow
def test_grading_leaves_nothing(rtdemo: str, tmp_path: Path) -> None:
    tmpdir, subs = tmp_path / "tmp", tmp_path / "subs"
    tmpdir.mkdir()
    subs.mkdir()
    # One exact student and one that fails (and so is diagnosed, rendering candidates).
    render_demo(
        rtdemo, SCENES / "classic.json", subs / "alice.ppm", "--mode", "classic", size=(64, 48)
    )
    render_demo(rtdemo, SCENES / "classic.json", subs / "bob.ppm", "--mode", "paper", size=(64, 48))
    code = _run_in(
        tmpdir,
        "grade",
        str(subs),
        "--scene",
        "classic",
        "--size",
        "64x48",
        "--out",
        str(tmp_path / "grades"),
    )
    assert code == 0 and (tmp_path / "grades" / "gradebook.csv").is_file()
    assert list(tmpdir.iterdir()) == []


def test_failing_reference_leaves_nothing(tmp_path: Path) -> None:
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    # An output folder that does not exist: the command fails before or after rendering.
    code = _run_in(
        tmpdir,
        "reference",
        str(SCENES / "paper.json"),
        "-o",
        str(tmp_path / "missing" / "ref.exr"),
        "--size",
        "32x24",
    )
    assert code == 4
    assert list(tmpdir.iterdir()) == []
