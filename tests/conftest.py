from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenes"
sys.path.insert(0, str(Path(__file__).resolve().parent))  # numpy_reference


@pytest.fixture(scope="session")
def rtdemo() -> str:
    from compare.tools import rtdemo_path

    return rtdemo_path()


def run(cmd: list[str], **kw: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, capture_output=True, text=True, check=False, **kw)  # type: ignore[call-overload]
