"""Nothing of rtval's is left in $TMPDIR: a Mitsuba reference (its cap meshes), a regression
check and a comparison each clean up after themselves, on success and on error."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from helpers import SCENES, run

RTVAL = str(Path(sys.executable).with_name("rtval"))


def _run_in(tmpdir: Path, *args: str) -> int:
    env = {**os.environ, "TMPDIR": str(tmpdir)}
    return run([RTVAL, *args], env=env).returncode


@pytest.mark.slow
def test_reference_render_leaves_no_mesh_folder(tmp_path: Path) -> None:
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    out = tmp_path / "ref.exr"
    # The paper scene's floor is a cap mesh written as PLY for Mitsuba to load.
    code = _run_in(
        tmpdir, "reference", str(SCENES / "paper.json"), "-o", str(out), "--size", "32x24"
    )
    assert code == 0 and out.is_file()
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
