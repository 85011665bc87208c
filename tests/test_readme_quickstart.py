"""README's five-minute starts, run as a user would: each start's commands, as README prints
them, in a folder outside the checkout, with the installed rtval and rtdemo on PATH."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import ROOT, SCENES

BIN = Path(sys.executable).parent


def _starts() -> dict[str, list[str]]:
    """Each start's title and the lines of its sh blocks."""
    text = (ROOT / "README.md").read_text()
    part = text.split("## Five-minute starts", 1)[1].split("\n## ", 1)[0]
    starts = {}
    for title, body in re.findall(r"^### (.+?)\n(.*?)(?=^### |\Z)", part, re.S | re.M):
        blocks = re.findall(r"```sh\n(.*?)```", body, re.S)
        starts[title] = [ln for b in blocks for ln in b.splitlines() if ln.strip()]
    return starts


def _shell(lines: list[str], folder: Path) -> list[subprocess.CompletedProcess[str]]:
    """The lines run one by one in one shell environment (a variable set stays set)."""
    env = {**os.environ, "PATH": f"{BIN}:{os.environ['PATH']}"}
    done, prefix = [], ""
    for line in lines:
        if re.fullmatch(r"[A-Z_]+=.*", line):
            prefix += line + "\n"
            continue
        done.append(
            subprocess.run(
                ["bash", "-c", prefix + line],
                cwd=folder,
                env=env,
                capture_output=True,
                text=True,
                timeout=600,
                check=False,
            )
        )
    return done


def _classic(out: Path, *options: str) -> None:
    """The classic scene at its size, as a student's program would write it."""
    cmd = [str(BIN / "rtdemo"), "render", str(SCENES / "classic.json"), "--ppm", str(out)]
    subprocess.run([*cmd, "--mode", "classic", *options], check=True, capture_output=True)


@pytest.fixture
def outside(tmp_path: Path) -> Path:
    folder = tmp_path / "elsewhere"
    folder.mkdir()
    assert not folder.resolve().is_relative_to(ROOT)
    return folder


def test_readme_has_a_start_for_each_user() -> None:
    assert [t.split(":")[0] for t in _starts()] == [
        "A teacher",
        "A student",
        "A maintainer",
        "A reader",
    ]


@pytest.mark.slow
def test_the_teachers_start(outside: Path) -> None:
    (outside / "class").mkdir()
    _classic(outside / "class" / "alice.ppm")
    _classic(outside / "class" / "bob.ppm", "--quirk", "Q2")
    runs = _shell(_starts()["A teacher: grade a class"], outside)
    assert [r.returncode for r in runs] == [0, 0], [r.stderr for r in runs]
    book = (outside / "grades" / "gradebook.csv").read_text()
    alice = next(row for row in book.splitlines() if row.startswith("alice,"))
    bob = next(row for row in book.splitlines() if row.startswith("bob,"))
    assert "pass" in alice and "fail" in bob and "Q2" in bob
    assert "bob" in (outside / "grades" / "index.html").read_text()
    assert "alice" in runs[1].stdout


@pytest.mark.slow
def test_the_students_start(outside: Path) -> None:
    _classic(outside / "my_render.ppm")
    compare, diagnose = _shell(_starts()["A student: check your image"], outside)
    assert compare.returncode == 0 and "PASS" in compare.stdout.upper(), compare.stderr
    assert diagnose.returncode == 0 and "classic" in diagnose.stdout, diagnose.stderr


@pytest.mark.slow
def test_the_maintainers_start(outside: Path) -> None:
    update, check = _shell(_starts()["A maintainer: put a renderer under check"], outside)
    assert update.returncode == 0, update.stdout + update.stderr
    assert check.returncode == 0, check.stdout + check.stderr
    assert (outside / "baselines").is_dir() and "<testsuite" in (outside / "check.xml").read_text()
