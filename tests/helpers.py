"""Paths and a subprocess runner shared by the test modules (imported as `helpers`; pytest's
rootdir-relative import puts tests/ on sys.path)."""

from __future__ import annotations

import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenes"


def run(cmd: list[str], **kw: object) -> subprocess.CompletedProcess[str]:
    """Runs a command, capturing text output; never raises on a non-zero exit."""
    return subprocess.run(cmd, capture_output=True, text=True, check=False, **kw)  # type: ignore[call-overload]
