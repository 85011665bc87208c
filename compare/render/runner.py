"""Finding rtdemo (renders run as cached jobs: compare/render/jobs.py)."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

from compare.errors import ToolError


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
