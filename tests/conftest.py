"""Fixtures only; shared helpers live in tests/helpers.py."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))  # helpers, numpy_reference


@pytest.fixture(scope="session", autouse=True)
def render_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """One render cache per test process (every rtval command and test of a pytest-xdist
    worker shares it, as on a user's machine), never the user's own ~/.cache/rtval."""
    folder = tmp_path_factory.mktemp("render-cache")
    before = os.environ.get("RTVAL_CACHE")
    os.environ["RTVAL_CACHE"] = str(folder)
    yield folder
    if before is None:
        os.environ.pop("RTVAL_CACHE", None)
    else:
        os.environ["RTVAL_CACHE"] = before


@pytest.fixture(scope="session")
def rtdemo() -> str:
    from compare.render.runner import rtdemo_path

    return rtdemo_path()
