"""Finding and running the project's renderers from Python."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path


class ToolError(RuntimeError):
    """A renderer could not be found or failed; the message says which and why."""


def rtdemo_path() -> str:
    """$RTVAL_RTDEMO when set (a build to test), else rtdemo next to this interpreter (the
    venv's bin), else on PATH."""
    chosen = os.environ.get("RTVAL_RTDEMO")
    if chosen:
        if not Path(chosen).is_file():
            raise ToolError(f"RTVAL_RTDEMO={chosen}: no such file")
        return chosen
    beside = Path(sys.executable).with_name("rtdemo")
    if beside.is_file():
        return str(beside)
    found = shutil.which("rtdemo")
    if not found:
        raise ToolError("rtdemo not found: run `make setup` (it builds demo_cpp into .venv)")
    return found


def run_rtdemo(
    args: list[str], *, executable: str | None = None
) -> subprocess.CompletedProcess[str]:
    """Runs `rtdemo ARGS` (or `executable ARGS`); raises ToolError on a non-zero exit."""
    cmd = [executable or rtdemo_path(), *args]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise ToolError(f"rtdemo failed (exit {proc.returncode}): {proc.stderr.strip()}")
    return proc
