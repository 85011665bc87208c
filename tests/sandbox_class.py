"""A small class of programs for the sandbox tests: tests/hostile_programs/rt.c with a
student.h of hooks, a Makefile that may do more, and `rtval grade` run on them with small
limits and a private temporary folder (so that what a run leaves there can be checked)."""

from __future__ import annotations

import csv
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from helpers import SCENES, run

RTVAL = str(Path(sys.executable).with_name("rtval"))
PROGRAMS = Path(__file__).resolve().parent / "hostile_programs"
RUN = "./rt {out} {width} {height} {scene}"
LIMITS = ["--run-timeout", "4", "--memory", "256M", "--file-size", "16M", "--processes", "32"]
MAKEFILE = "rt: rt.c student.h\n\tcc -O1 -o rt rt.c -lm\n"
PRELUDE = """#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
"""


def hooks(start: str = "", before: str = "", after: str = "") -> str:
    return (
        f"#define HOOK_START {{ {start} }}\n#define HOOK_BEFORE_WRITE {{ {before} }}\n"
        f"#define HOOK_AFTER_WRITE {{ {after} }}\n"
    )


def student(folder: Path, hook_text: str = "", makefile: str = MAKEFILE, **files: str) -> Path:
    """A student's folder: rt.c, student.h (PRELUDE + hooks), the Makefile and more files."""
    folder.mkdir(parents=True)
    shutil.copy(PROGRAMS / "rt.c", folder / "rt.c")
    include = '#include "deep.h"\n' if "deep.h" in files else ""
    (folder / "student.h").write_text(PRELUDE + include + (hook_text or hooks()))
    (folder / "Makefile").write_text(makefile)
    for name, text in files.items():
        (folder / name).write_text(text)
    return folder


@contextmanager
def private_tmp() -> Iterator[Path]:
    """A temporary folder for rtval's workspaces, traversable by the sandbox user."""
    folder = Path(tempfile.mkdtemp(prefix="rtval-test-tmp-", dir="/tmp"))
    folder.chmod(0o711)
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def grade(
    subs: Path, out: Path, *extra: str, tmp: Path | None = None, limits: bool = True
) -> subprocess.CompletedProcess[str]:
    cmd = [RTVAL, "grade", str(subs), "--scene", str(SCENES / "classic.json"), "--out", str(out)]
    cmd += ["--size", "80x60", "--no-diagnose", "--jobs", "2", "--build", "make", "--run", RUN]
    env = dict(os.environ)
    if tmp is not None:
        env["TMPDIR"] = str(tmp)
    return run([*cmd, *(LIMITS if limits else []), *extra], env=env)


def gradebook(out: Path) -> dict[str, dict[str, str]]:
    with (out / "gradebook.csv").open() as f:
        return {row["student"]: row for row in csv.DictReader(f)}
