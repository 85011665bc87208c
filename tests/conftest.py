"""Fixtures only; shared helpers live in tests/helpers.py."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))  # helpers, numpy_reference


@pytest.fixture(scope="session", autouse=True)
def _render_cache(tmp_path_factory: pytest.TempPathFactory) -> None:
    """`rtval check` and `compare --against` cache model renders and effect masks in
    $RTVAL_CACHE: one per test session, never the user's ~/.cache (subprocesses inherit it)."""
    os.environ.setdefault("RTVAL_CACHE", str(tmp_path_factory.mktemp("rtval-cache")))


@pytest.fixture(scope="session")
def rtdemo() -> str:
    from compare.render.runner import rtdemo_path

    return rtdemo_path()
