"""Fixtures only; shared helpers live in tests/helpers.py."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))  # helpers, numpy_reference


@pytest.fixture(scope="session")
def rtdemo() -> str:
    from compare.render.runner import rtdemo_path

    return rtdemo_path()
